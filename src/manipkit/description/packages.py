"""ROS packages without ROS: ``$(find PKG)`` and ``package://PKG/...`` to folders and files.

A description names files inside ROS packages (xacro's ``$(find PKG)``, mesh
``package://PKG/path`` URIs). :class:`PackageResolver` answers those names
from folders on disk, in the order its docstring states (docs/architecture.md,
"Loading descriptions"); :func:`split_package_uri` reads a ``package://`` URI.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass, field
from pathlib import Path

from manipkit.description.sources import bundled_dir, example_robot_data_dir
from manipkit.errors import InputFileError, PackageNotFoundError
from manipkit.inputs import MAX_TABLE_BYTES, check_input_file

__all__ = ["PACKAGE_SCHEME", "PackageResolver", "split_package_uri"]

PACKAGE_SCHEME = "package://"


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

    Lookup order: ``package_dirs`` given by the user (``NAME=DIR``); the
    built-in packages (``manipkit`` -> the folder holding ``robots/``,
    ``example-robot-data`` -> its share folder, and each
    ``*_description`` folder of example-robot-data by name); a folder named
    PKG (or holding a ``package.xml`` that declares PKG) among the ancestors
    of ``near`` and their sub-folders; the folders on ``ROS_PACKAGE_PATH``.
    A package found once is not searched for again by the same resolver.
    """

    package_dirs: dict[str, Path] = field(default_factory=dict)
    near: Path | None = None
    _found: dict[str, Path] = field(default_factory=dict, init=False, repr=False, compare=False)

    def candidates(self) -> list[Path]:
        """Folders searched for packages, in order (for error messages too)."""
        places: list[Path] = []
        if self.near is not None:
            for ancestor in list(self.near.resolve().parents)[:4]:
                if ancestor.parent != ancestor:  # never crawl the file-system root
                    places.append(ancestor)
        for entry in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep):
            if entry:
                places.append(Path(entry))
        return places

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

    def _search(self, package: str) -> Path:
        if package in self.package_dirs:
            folder = Path(self.package_dirs[package]).expanduser()
            if not folder.is_dir():
                raise PackageNotFoundError(
                    f"--package-dir {package}={folder}: no such folder"
                )
            return folder.resolve()
        builtin = self.builtin()
        if package in builtin:
            return builtin[package]
        searched = []
        for place in self.candidates():
            searched.append(str(place))
            found = _package_in(place, package)
            if found is not None:
                return found
        raise PackageNotFoundError(
            f"package '{package}' not found; searched --package-dir ({', '.join(self.package_dirs) or 'none given'}), "
            f"built-in (manipkit, example-robot-data and its robot folders), and {'; '.join(searched) or 'no other folders'}; "
            f"give it with --package-dir {package}=DIR"
        )

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


def _package_in(place: Path, package: str) -> Path | None:
    """A folder for ``package``: ``place`` itself, a folder in it, or a folder in its ``src/``."""
    if not place.is_dir():
        return None
    folders = [place]
    for parent in (place, place / "src"):
        try:
            folders += sorted(p for p in parent.iterdir() if p.is_dir())
        except OSError:
            continue
    for folder in folders:
        if folder.name == package or _package_xml_name(folder) == package:
            return folder.resolve()
    return None


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
