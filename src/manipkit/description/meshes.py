"""Mesh files of a description: ``package://``, ``file://`` and relative URIs to absolute paths.

The one mesh resolver of manipkit: the viewer needs the files
(:func:`urdf_with_mesh_paths` gives it URDF text whose meshes are absolute
paths), and validation warns about meshes that do not resolve
(:func:`manipkit.description.validate.package_uri_warnings`). Both map a
``package://`` URI to a file with
:meth:`~manipkit.description.packages.PackageResolver.resolve_uri`, and any
other path with :func:`mesh_search_paths`.

Kinematics never need meshes, so nothing here runs when a robot is only
loaded for transforms (docs/architecture.md).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

from manipkit.description.packages import PACKAGE_SCHEME, split_package_uri
from manipkit.errors import PackageNotFoundError

if TYPE_CHECKING:
    from manipkit.description.access import ReadPolicy
    from manipkit.description.packages import PackageResolver

__all__ = ["mesh_path", "mesh_search_paths", "urdf_with_mesh_paths"]


def mesh_path(uri: str, resolver: PackageResolver, *, relative_to: str | os.PathLike, link: str,
              policy: ReadPolicy | None = None) -> Path:
    """The existing file a mesh URI names.

    Parameters
    ----------
    uri : str
        A ``<mesh filename="...">``: ``package://PKG/path``, ``file:///path``,
        an absolute path, or a path relative to the description file.
    resolver : PackageResolver
        Answers ``package://PKG``.
    relative_to : str or path-like, keyword-only
        The folder of the description file; a relative path is looked for
        there, then in the current folder.
    link : str, keyword-only
        The link the mesh belongs to, named in messages.
    policy : ReadPolicy, optional, keyword-only
        What the description may read (:mod:`manipkit.description.access`); a mesh outside it is refused.

    Returns
    -------
    pathlib.Path
        The file (absolute, unless ``relative_to`` is relative).

    Raises
    ------
    PackageNotFoundError
        The package is not found, the file is not in it, the file is not
        found, or the URI has another scheme (``http://`` ...); the message
        names the link, the URI and the places searched.
    ReadNotAllowedError
        The file is outside what the description may read (``policy``).

    Examples
    --------
    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> _ = (folder / "arm.stl").write_bytes(b"solid arm")
    >>> from manipkit.description.packages import PackageResolver
    >>> mesh_path("arm.stl", PackageResolver(), relative_to=folder, link="arm") == (folder / "arm.stl").resolve()
    True
    """
    where = f"link '{link}': mesh {uri}"
    if uri.startswith(PACKAGE_SCHEME):
        try:
            path = Path(resolver.resolve_uri(uri))
        except PackageNotFoundError as exc:
            raise PackageNotFoundError(f"{where} cannot be resolved: {exc}") from None
        if not path.is_file():
            package, _ = split_package_uri(uri)
            raise PackageNotFoundError(
                f"{where} resolves to {path}, which does not exist (package '{package}' is {resolver.find(package)}); "
                f"give the right folder with --package-dir {package}=DIR"
            )
        if policy is not None:
            policy.check(path, where)
        return path
    if "://" in uri and not uri.startswith("file://"):
        raise PackageNotFoundError(f"{where}: only package://, file:// and file paths are supported")
    searched = mesh_search_paths(uri, resolver, relative_to=relative_to)
    if policy is not None and not policy.allows(searched[0]):
        policy.check(searched[0], where)  # raises, naming the path (whether it exists is not looked at)
    for candidate in searched:
        if policy is not None and not policy.allows(candidate):
            continue  # the current folder, outside what the description may read
        if candidate.is_file():
            return candidate.resolve()
    raise PackageNotFoundError(f"{where} not found; looked at {', '.join(map(str, searched))}")


def mesh_search_paths(uri: str, resolver: PackageResolver, *, relative_to: str | os.PathLike) -> list[Path]:
    """Where a mesh URI that is not ``package://`` is looked for, in order (the files may not exist).

    ``file:///path`` and absolute paths name one file; a relative path is
    looked for in ``relative_to`` (the description file's folder), then in
    the current folder. :func:`mesh_path` takes the first that exists;
    :func:`manipkit.description.validate.package_uri_warnings` warns when none does.

    Examples
    --------
    >>> from manipkit.description.packages import PackageResolver
    >>> mesh_search_paths("file:///meshes/a.stl", PackageResolver(), relative_to="/robot")
    [PosixPath('/meshes/a.stl')]
    >>> mesh_search_paths("meshes/a.stl", PackageResolver(), relative_to="/robot")[0]
    PosixPath('/robot/meshes/a.stl')
    """
    path = Path(resolver.resolve_uri(uri)).expanduser()
    return [path] if path.is_absolute() else [Path(relative_to) / path, Path.cwd() / path]


def urdf_with_mesh_paths(
    urdf_text: str, resolver: PackageResolver, *, relative_to: str | os.PathLike, policy: ReadPolicy | None = None
) -> tuple[str, list[str]]:
    """URDF text whose ``<visual>`` mesh filenames are absolute paths, and the package folders used.

    Parameters
    ----------
    urdf_text : str
        URDF XML.
    resolver : PackageResolver
        Answers ``package://PKG``.
    relative_to : str or path-like, keyword-only
        The folder of the description file (for relative mesh paths).
    policy : ReadPolicy, optional, keyword-only
        What the description may read; as for :func:`mesh_path`.

    Returns
    -------
    text : str
        ``urdf_text`` with each visual mesh's ``filename`` replaced by
        :func:`mesh_path` (``urdf_text`` itself when there are no visual meshes).
    package_folders : list of str
        Sorted: the parent folder of each package a ``package://`` mesh
        named (what Pinocchio's ``package_dirs`` expects).

    Raises
    ------
    PackageNotFoundError
        As :func:`mesh_path`, for the first mesh that cannot be resolved.
    """
    import xml.etree.ElementTree as ET

    root = ET.fromstring(urdf_text)
    meshes = [(link.get("name"), mesh) for link in root.iter("link") for mesh in link.findall("visual/geometry/mesh")]
    if not meshes:
        return urdf_text, []
    folders: set[str] = set()
    for link, mesh in meshes:
        uri = mesh.get("filename", "")
        path = mesh_path(uri, resolver, relative_to=relative_to, link=link, policy=policy)
        if uri.startswith(PACKAGE_SCHEME):
            folders.add(str(resolver.find(split_package_uri(uri)[0]).parent))
        mesh.set("filename", str(path))
    return ET.tostring(root, encoding="unicode"), sorted(folders)
