"""ROS packages without ROS: ``$(find PKG)`` and ``package://PKG/...`` to folders and files.

A description names files inside ROS packages (xacro's ``$(find PKG)``, mesh
``package://PKG/path`` URIs). :class:`PackageResolver` answers those names
from folders on disk, as ROS would and then from manipkit's built-ins:
``--package-dir``, the workspace around the description file (every
``package.xml`` by its ``<name>``, as colcon and catkin index them),
``ROS_PACKAGE_PATH``, ``AMENT_PREFIX_PATH``, then the bundled robots and
example-robot-data (docs/site/internals/loading.md).
:func:`workspace_root` finds the workspace, :func:`package_index` indexes the
packages below one folder; :func:`split_package_uri` reads a ``package://`` URI.
"""

from __future__ import annotations

import os
import re
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from manipkit.description.sources import bundled_dir, example_robot_data_dir
from manipkit.errors import InputFileError, PackageNotFoundError
from manipkit.inputs import MAX_TABLE_BYTES, check_input_file
from manipkit.text import UNPRINTABLE, printable, repr_text

__all__ = [
    "IGNORE_MARKERS", "MAX_SCAN_DEPTH", "MAX_SCAN_FOLDERS", "PACKAGE_SCHEME", "PackageResolver", "WARNING_REGISTRY",
    "check_package_dirs", "missing_in_package_hint", "package_index", "split_package_uri", "workspace_root",
]

PACKAGE_SCHEME = "package://"

#: The ``warnings`` registry of the package lookup and of xacro's expansion (which re-issues what it
#: recorded into it): a warning shows once until the warning filters next change (one load), as
#: Python's ``default`` action does; under ``always`` (``pytest.warns``) every one shows.
WARNING_REGISTRY: dict = {}

#: A folder scan for ``package.xml`` files stops (with a warning) after this many folders.
MAX_SCAN_FOLDERS = 20_000
#: ... and does not look deeper than this many folders below its root (with a warning).
MAX_SCAN_DEPTH = 10
#: Marker files that hide a folder (and everything below it) from colcon, catkin and ament.
IGNORE_MARKERS = frozenset({"COLCON_IGNORE", "CATKIN_IGNORE", "AMENT_IGNORE"})
#: The package a workspace search starts from must be the file's folder or at most this many levels above.
_PACKAGE_SEARCH_LEVELS = 4


def split_package_uri(uri: str) -> tuple[str, str]:
    """``package://PKG/rest`` -> ``("PKG", "rest")``; the package name is empty for ``package:///...``.

    Examples
    --------
    >>> split_package_uri("package://ur_description/meshes/ur5/base.dae")
    ('ur_description', 'meshes/ur5/base.dae')
    """
    package, _, rest = uri[len(PACKAGE_SCHEME):].partition("/")
    return package, rest


@dataclass
class PackageResolver:
    """Resolve ROS package names to folders without ROS.

    Lookup order (the first place that has the package wins):

    1. ``package_dirs`` given by the user (``--package-dir NAME=DIR``);
    2. the workspace around ``near`` (the description file): the nearest
       ancestor with a ``src/`` folder (its ``src/`` is indexed), else the
       outermost of the consecutive ancestors that are a package or hold one
       (else the file's own folder, two levels deep); never the file-system
       root or the home folder. Every ``package.xml`` below it is indexed by
       its ``<name>``, as colcon and catkin do: folders holding
       ``COLCON_IGNORE``, ``CATKIN_IGNORE`` or ``AMENT_IGNORE`` and hidden
       folders are skipped, and nothing below a package is indexed;
    3. ``ROS_PACKAGE_PATH`` (each entry a package or a folder of packages,
       indexed the same way), then ``AMENT_PREFIX_PATH`` (``PREFIX/share/PKG``);
    4. the built-in packages last: ``manipkit`` (the folder holding
       ``robots/``), ``example-robot-data`` (its share folder) and each
       robot folder of example-robot-data by its folder name.

    A name found in more than one of places 2-4 takes, first, the copy that
    holds the description file the user named (the copy being edited), else
    the first in the order. When the choice is a guess (two packages with the
    same ``<name>`` in a workspace, neither holding the named file) one
    warning names the place used and the others; a user's copy chosen over a
    built-in one (example-robot-data also ships ``ur_description``) is not a
    guess and says nothing.
    A package found once is not searched for again by the same resolver;
    folder indexes are kept per folder for the whole process and re-read
    only when a folder or ``package.xml`` in them changed. A scan stops after
    :data:`MAX_SCAN_FOLDERS` folders (with a warning) and does not go deeper
    than :data:`MAX_SCAN_DEPTH` folders below its root.
    """

    package_dirs: dict[str, Path] = field(default_factory=dict)
    near: Path | None = None
    _found: dict[str, Path] = field(default_factory=dict, init=False, repr=False, compare=False)
    _indexes: dict[Path, dict[str, list[Path]]] = field(default_factory=dict, init=False, repr=False, compare=False)
    _root: tuple | None = field(default=None, init=False, repr=False, compare=False)

    def workspace(self) -> Path | None:
        """The folder indexed as the workspace around ``near`` (None without ``near``); see :func:`workspace_root`."""
        found = self._workspace()
        return None if found is None else found[0]

    def _workspace(self) -> tuple[Path, int] | None:
        if self.near is None:
            return None
        if self._root is None:
            self._root = (workspace_root(Path(self.near)),)
        return self._root[0]

    def candidates(self) -> list[Path]:
        """Folders indexed for packages, in order (for error messages too)."""
        root = self.workspace()
        return ([] if root is None else [root]) + _ros_package_path()

    def builtin(self) -> dict[str, Path]:
        """The packages known without searching: ``manipkit``, example-robot-data and its robot folders."""
        packages = {"manipkit": bundled_dir().parent}
        erd = example_robot_data_dir()
        if erd is not None:
            packages["example-robot-data"] = erd
            packages["example_robot_data"] = erd
            for folder in sorted((erd / "robots").iterdir()):
                if folder.is_dir():
                    packages.setdefault(folder.name, folder)
        return packages

    def find(self, package: str) -> Path:
        """The folder of ``package``; :class:`PackageNotFoundError` lists where it looked."""
        if package not in self._found:
            self._found[package] = self._search(package)
        return self._found[package]

    def found(self) -> dict[str, Path]:
        """The packages this resolver has found so far (name -> folder), in the order they were asked for."""
        return dict(self._found)

    def _index(self, root: Path, depth: int = MAX_SCAN_DEPTH) -> dict[str, list[Path]]:
        if root not in self._indexes:
            self._indexes[root] = package_index(root, max_depth=depth)
        return self._indexes[root]

    def places(self, package: str) -> list[Path]:
        """Every folder (resolved, without repeats) that holds ``package`` in places 2-4 of the order."""
        found: list[Path] = []
        workspace = self._workspace()
        if workspace is not None:
            found += self._index(*workspace).get(package, [])
        for entry in _ros_package_path():
            found += self._index(entry).get(package, [])
        for prefix in _env_path("AMENT_PREFIX_PATH"):
            share = prefix / "share" / package
            if share.is_dir():
                found.append(share)
        builtin = self.builtin()
        if package in builtin:
            found.append(builtin[package])
        unique: list[Path] = []
        for folder in found:
            folder = folder.resolve()
            if folder not in unique:
                unique.append(folder)
        holder = self._holder(unique)
        return unique if holder is None else [holder] + [folder for folder in unique if folder != holder]

    def _holder(self, folders: list[Path]) -> Path | None:
        """The one of ``folders`` that holds the description file the user named (the copy being edited)."""
        if self.near is None:
            return None
        named = Path(self.near).resolve()
        return next((folder for folder in folders if named.is_relative_to(folder)), None)

    def _search(self, package: str) -> Path:
        if package in self.package_dirs:
            folder = Path(self.package_dirs[package]).expanduser()
            if not folder.is_dir():
                raise PackageNotFoundError(
                    f"--package-dir {package}={folder}: no such folder"
                )
            return folder.resolve()
        found = self.places(package)
        if not found:
            raise PackageNotFoundError(f"package '{package}' not found; searched {self._searched_text()}; "
                                       f"give it with --package-dir {package}=DIR")
        builtin = {Path(folder).resolve() for folder in self.builtin().values()}
        ambiguous = [folder for folder in found[1:] if folder not in builtin]  # the user's copy beats a built-in one
        if ambiguous and self._holder(found[:1]) is None:  # the copy holding the named file is the one meant
            # Once per resolver, and once per load: xacro's expansion re-issues the warnings it recorded
            # into the same registry, so the resolver that reads the meshes next does not say it again.
            warnings.warn_explicit(f"package '{package}' found in {len(found)} places: using {found[0]}; not "
                                   f"{', '.join(map(str, found[1:]))} (choose with --package-dir {package}=DIR)",
                                   UserWarning, __file__, 0, module=__name__, registry=WARNING_REGISTRY)
        return found[0]

    def _searched_text(self) -> str:
        root = self.workspace()
        parts = [
            f"--package-dir ({', '.join(self.package_dirs) or 'none given'})",
            f"the workspace {root}" if root is not None else "no workspace (no description file)",
            f"ROS_PACKAGE_PATH ({'; '.join(map(str, _ros_package_path())) or 'not set'})",
            f"AMENT_PREFIX_PATH ({'; '.join(str(p / 'share') for p in _env_path('AMENT_PREFIX_PATH')) or 'not set'})",
            "built-in (manipkit, example-robot-data and its robot folders)",
        ]
        return ", ".join(parts)

    def resolve_uri(self, uri: str) -> str:
        """``package://PKG/rest`` -> absolute path; ``file://`` stripped; others unchanged.

        The one mapping of a ``package://`` URI to a file (the file may not
        exist): :func:`manipkit.description.meshes.mesh_path` and
        :func:`manipkit.description.validate.package_uri_warnings` use it.
        """
        if uri.startswith(PACKAGE_SCHEME):
            package, rest = split_package_uri(uri)
            return str(self.find(package) / rest)
        if uri.startswith("file://"):
            return uri[len("file://") :]
        return uri



def check_package_dirs(package_dirs, *, what: str = "package_dirs", exist: bool = True) -> dict[str, Path]:
    """``package_dirs`` (package name -> folder) checked: a mapping of non-empty names to existing folders
    (``exist=False``: to folder paths, which may not exist yet).

    Raises
    ------
    PackageNotFoundError
        Not a mapping, a name that is not a non-empty string, a folder that is
        not a path, holds a NUL byte, or does not exist; the message names ``what``.

    >>> check_package_dirs(None)
    {}
    """
    if package_dirs is None:
        return {}
    if not isinstance(package_dirs, Mapping):
        raise PackageNotFoundError(f"{what}: expected a dict of package name -> folder, not "
                                   f"{type(package_dirs).__name__} {repr_text(package_dirs)}")
    checked: dict[str, Path] = {}
    for name, folder in package_dirs.items():
        if not isinstance(name, str) or not name.strip() or UNPRINTABLE.search(name):
            raise PackageNotFoundError(f"{what}: a package name is a non-empty line of text, not "
                                       f"{type(name).__name__} {repr_text(name)}")
        if not isinstance(folder, (str, os.PathLike)) or not isinstance(os.fspath(folder), str):
            raise PackageNotFoundError(f"{what}[{name!r}]: expected a folder path (str or pathlib.Path), not "
                                       f"{type(folder).__name__} {repr_text(folder)}")
        text = os.fspath(folder)
        if "\x00" in text or not text:
            raise PackageNotFoundError(f"{what}[{name!r}]: {repr_text(text)} is not a folder path")
        path = Path(text).expanduser()
        if exist and not path.is_dir():
            raise PackageNotFoundError(f"{what}[{name!r}] (--package-dir {name}=DIR): {printable(text)}: no such folder")
        checked[name] = path
    return checked


def _env_path(variable: str) -> list[Path]:
    """The folders of a ``os.pathsep``-separated environment variable, empty entries left out."""
    return [Path(entry).expanduser() for entry in os.environ.get(variable, "").split(os.pathsep) if entry]


def _ros_package_path() -> list[Path]:
    return _env_path("ROS_PACKAGE_PATH")


def workspace_root(near: Path) -> tuple[Path, int] | None:
    """The folder indexed as the workspace around the file ``near`` and how deep to look, or None.

    The nearest ancestor that has a ``src/`` folder and is not itself a
    package gives its ``src/`` (a catkin or colcon workspace); else the
    outermost of the consecutive ancestors that are a package or have one
    directly inside (a checkout of several packages), the first of them at
    most four levels above the file; else the file's own folder, two levels
    deep. The file-system root and the home folder (and what is above it)
    are never indexed.
    """
    start = Path(near).expanduser().resolve().parent
    stops = {Path(start.anchor), Path.home().resolve()}
    chain: list[Path] = []
    for folder in (start, *start.parents):
        if folder in stops:
            break
        chain.append(folder)
    for folder in chain:
        if (folder / "src").is_dir() and not (folder / "package.xml").exists():
            return folder / "src", MAX_SCAN_DEPTH
    outermost = None
    for level, folder in enumerate(chain):
        if _holds_package(folder):
            outermost = folder
        elif outermost is not None or level >= _PACKAGE_SEARCH_LEVELS:
            break
    if outermost is not None:
        return outermost, MAX_SCAN_DEPTH
    return (start, 2) if chain else None


def _holds_package(folder: Path) -> bool:
    """``folder`` is a package or has a package directly inside."""
    if (folder / "package.xml").is_file():
        return True
    try:
        with os.scandir(folder) as entries:
            return any(entry.is_dir() and os.path.isfile(os.path.join(entry.path, "package.xml")) for entry in entries)
    except OSError:
        return False


#: (root, depth) -> (name -> package folders, the stamps that show whether the scan is still current).
_INDEXES: dict[tuple[str, int], tuple[dict[str, list[Path]], list[tuple[str, tuple[int, int]]]]] = {}


def package_index(root: str | os.PathLike, *, max_depth: int = MAX_SCAN_DEPTH) -> dict[str, list[Path]]:
    """The packages below ``root``: ``<name>`` of each ``package.xml`` -> the folders declaring it, in scan order.

    Indexed as colcon and catkin do: ``root`` itself may be a package;
    folders holding ``COLCON_IGNORE``, ``CATKIN_IGNORE`` or ``AMENT_IGNORE``
    and hidden folders are skipped; nothing below a package is indexed;
    sub-folders are visited in name order, depth first. At most
    :data:`MAX_SCAN_FOLDERS` folders and ``max_depth`` levels are visited
    (a warning says so when the scan stops early). The index is kept for the
    process and scanned again only when a visited folder or ``package.xml``
    changed (its modification time or size).
    """
    key = (os.path.abspath(root), max_depth)
    cached = _INDEXES.get(key)
    if cached is not None and _current(cached[1]):
        return cached[0]
    packages, stamps = _scan(Path(key[0]), max_depth)
    _INDEXES[key] = (packages, stamps)
    return packages


def _stamp(path: str) -> tuple[int, int] | None:
    try:
        status = os.stat(path)
    except OSError:
        return None
    return status.st_mtime_ns, status.st_size


def _current(stamps) -> bool:
    return all(_stamp(path) == stamp for path, stamp in stamps)


def _scan(root: Path, max_depth: int):
    """Depth-first walk of ``root`` for :func:`package_index`: (packages, stamps)."""
    packages: dict[str, list[Path]] = {}
    stamps: list[tuple[str, tuple[int, int]]] = []
    seen: set[tuple[int, int]] = set()
    stack = [(str(root), 0)]
    too_deep = None
    while stack:
        folder, depth = stack.pop()
        try:
            status = os.stat(folder)
            with os.scandir(folder) as listing:
                entries = sorted(listing, key=lambda entry: entry.name)
        except OSError:
            continue
        if (status.st_dev, status.st_ino) in seen:  # a symbolic link back up the tree
            continue
        seen.add((status.st_dev, status.st_ino))
        if len(seen) > MAX_SCAN_FOLDERS:
            warnings.warn(f"package search in {root} stopped after {MAX_SCAN_FOLDERS} folders; packages not "
                          f"found yet can be given with --package-dir NAME=DIR", UserWarning, stacklevel=3)
            break
        stamps.append((folder, (status.st_mtime_ns, status.st_size)))
        names = {entry.name for entry in entries}
        if names & IGNORE_MARKERS:
            continue
        if "package.xml" in names:
            manifest = os.path.join(folder, "package.xml")
            stamps.append((manifest, _stamp(manifest)))
            name = _package_xml_name(Path(folder))
            if name is not None:
                packages.setdefault(name, []).append(Path(folder))
            continue  # colcon and catkin index nothing below a package
        subfolders = [entry.path for entry in entries if not entry.name.startswith(".") and _is_dir(entry)]
        if depth >= max_depth:
            too_deep = too_deep or (subfolders[0] if subfolders else None)
            continue
        stack.extend((path, depth + 1) for path in reversed(subfolders))
    if too_deep is not None and max_depth == MAX_SCAN_DEPTH:
        warnings.warn(f"package search in {root} does not look deeper than {MAX_SCAN_DEPTH} folders "
                      f"(left out: {too_deep}, ...); give such packages with --package-dir NAME=DIR",
                      UserWarning, stacklevel=3)
    return packages, stamps


def _is_dir(entry: os.DirEntry) -> bool:
    try:
        return entry.is_dir()
    except OSError:
        return False


def _package_xml_name(folder: Path) -> str | None:
    """The ``<name>`` a ``package.xml`` in ``folder`` declares; None without one (or when it is a FIFO,
    a device, a loop or larger than :data:`~manipkit.inputs.MAX_TABLE_BYTES`: never read then)."""
    try:
        manifest = check_input_file(folder / "package.xml", what="package.xml", max_bytes=MAX_TABLE_BYTES)
        text = manifest.read_text(errors="replace")
    except (InputFileError, OSError):
        return None
    match = re.search(r"<name>\s*([^<\s]+)\s*</name>", text)
    return match.group(1) if match else None


def missing_in_package_hint(resolver: PackageResolver, package: str, folder: Path) -> str:
    """`` (package 'P' was found at FOLDER, but the file is not in it ...)`` for a file missing from a found package.

    The package was found, so ``--package-dir`` is suggested only when other
    copies exist to choose from (issue 25: it was suggested for a file that
    is simply missing).
    """
    folder = Path(folder).resolve()
    builtin = resolver.builtin().get(package)
    which = "the built-in copy at " if builtin is not None and Path(builtin).resolve() == folder else ""
    others = [str(place) for place in resolver.places(package) if place != folder]
    if others:
        choose = f"; other copies: {', '.join(others)} (choose one with --package-dir {package}=DIR)"
    elif which:  # only manipkit's own copy was found: the user's may be outside the workspace
        choose = f"; if your copy is elsewhere, give it with --package-dir {package}=DIR"
    else:
        choose = ""
    return f" (package '{package}' was found, {which}{folder}, but the file is not in it{choose})"
