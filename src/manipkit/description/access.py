"""What a description may read: its own folder tree, its packages, and the folders the user allows.

A downloaded description is untrusted input, and xacro lets it name any
file: ``<xacro:include filename="/etc/passwd">``, ``${load_yaml('~/.ssh/...')}``
(whose text then shows in an error line) or a mesh at any path. Here every
file a description asks for besides itself (xacro includes,
``xacro.load_yaml``, mesh files) must lie, after symbolic links are
followed, inside one of:

- the description's own folder tree: the ROS package holding the file (the
  nearest folder above it with a ``package.xml``), else the file's folder;
- a package resolved for it (``$(find PKG)``, ``package://PKG``: the
  ``--package-dir`` folders, the workspace around the file, the ROS paths of
  the environment, the bundled robots and example-robot-data);
- a folder the user names with ``--allow-read DIR`` (``allow_read=`` in
  :func:`manipkit.load`).

Anything else is refused (:class:`~manipkit.errors.ReadNotAllowedError`)
with the path named and how to allow it. The policy in force is set for the
duration of an expansion (:func:`reading_under`); outside one (a function
called directly from Python) nothing is checked.
"""

from __future__ import annotations

import contextlib
import os
import threading
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING

from manipkit.errors import DescriptionError, ReadNotAllowedError
from manipkit.text import printable

if TYPE_CHECKING:
    from manipkit.description.packages import PackageResolver

__all__ = ["ReadPolicy", "allowed_folders", "check_readable", "description_tree", "reading_under"]


def description_tree(path: str | os.PathLike) -> Path:
    """The folder tree a description file owns: the ROS package holding it (the nearest folder above it with a
    ``package.xml``), else its own folder."""
    folder = Path(os.path.abspath(path)).parent
    for candidate in (folder, *folder.parents):
        if (candidate / "package.xml").is_file():
            return candidate
    return folder


def allowed_folders(allow_read, *, what: str = "allow_read") -> tuple[Path, ...]:
    """``allow_read`` (a folder, or an iterable of folders) as a tuple of existing folders, or a
    :class:`~manipkit.errors.DescriptionError` naming the argument."""
    if allow_read is None:
        return ()
    items = [allow_read] if isinstance(allow_read, (str, os.PathLike)) else allow_read
    if not isinstance(items, Iterable) or isinstance(items, (bytes, dict)):
        raise DescriptionError(f"{what}: expected a folder or a list of folders, not {type(allow_read).__name__}")
    folders = []
    for item in items:
        if not isinstance(item, (str, os.PathLike)):
            raise DescriptionError(f"{what}: expected a folder path, not {type(item).__name__}")
        text = os.fspath(item)
        if not isinstance(text, str) or "\x00" in text or not text:
            raise DescriptionError(f"{what}: {text!r} is not a folder path")
        if not os.path.isdir(text):
            raise DescriptionError(f"{what}: {text!r} is not a folder")
        folders.append(Path(text))
    return tuple(folders)


class ReadPolicy:
    """The folders a description may read (module docstring), for the file ``description``.

    Parameters
    ----------
    description : path-like
        The top-level description file (always readable).
    resolver : PackageResolver, optional
        Its packages: the folders it has found (when asked) are readable, and its ``package_dirs``.
    allow_read : path-like or iterable of path-like
        Folders the user allows (``--allow-read``), checked by :func:`allowed_folders`.
    """

    def __init__(self, description, resolver: PackageResolver | None = None, allow_read: tuple[Path, ...] = ()):
        self.description = Path(description)
        self.resolver = resolver
        self.allow_read = allowed_folders(allow_read)  # a folder or several; never a string taken apart
        self.read: list[str] = []  # every path checked and allowed, in order: what the expansion read

    def roots(self) -> list[Path]:
        """The readable folders, as given (symbolic links kept): own tree, packages, allowed folders."""
        roots = [description_tree(self.description)]
        real = Path(os.path.realpath(self.description))
        if real != Path(os.path.abspath(self.description)):
            roots.append(description_tree(real))
        if self.resolver is not None:  # the packages given, and those resolved for this description so far
            roots += [Path(p) for p in self.resolver.package_dirs.values()]
            roots += list(self.resolver.found().values())
        roots += list(self.allow_read)
        return roots

    def allows(self, path: str | os.PathLike) -> bool:
        """Whether ``path`` (after following symbolic links) lies inside a readable folder (its real path)."""
        real = os.path.realpath(path)
        if real == os.path.realpath(self.description):
            return True
        return any(_inside(real, os.path.realpath(root)) for root in self.roots())

    def check(self, path: str | os.PathLike, what: str) -> None:
        """Nothing if ``path`` may be read, else :class:`~manipkit.errors.ReadNotAllowedError` naming it."""
        if self.allows(path):
            self.read.append(os.fspath(path))
            return
        shown = printable(os.path.abspath(path))[:300]
        real = printable(os.path.realpath(path))[:300]
        via = f" (a link to {real})" if real != shown else ""
        raise ReadNotAllowedError(
            f"{what}: {shown}{via} is outside what {self.description.name} may read (its own folder "
            f"{description_tree(self.description)}, its packages and --package-dir folders); if you trust it, "
            f"allow it with --allow-read {printable(os.path.dirname(os.path.realpath(path)))[:300] or real} (allow_read= in manipkit.load)"
        )


def _inside(path: str, folder: str) -> bool:
    return path == folder or path.startswith(folder.rstrip(os.sep) + os.sep)


_local = threading.local()  # each thread's stack of policies: an expansion in one thread never checks another's reads


def _policies() -> list[ReadPolicy]:
    if not hasattr(_local, "policies"):
        _local.policies = []
    return _local.policies


@contextlib.contextmanager
def reading_under(policy: ReadPolicy):
    """Within this block :func:`check_readable` checks against ``policy`` (an expansion's files)."""
    policies = _policies()
    policies.append(policy)
    try:
        yield policy
    finally:
        policies.pop()


def check_readable(path: str | os.PathLike, what: str) -> None:
    """Refuse (:class:`~manipkit.errors.ReadNotAllowedError`) reading ``path`` unless the policy in force
    allows it; nothing is checked outside :func:`reading_under`."""
    policies = _policies()
    if policies:
        policies[-1].check(path, what)
