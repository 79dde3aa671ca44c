"""Mesh files of a description: ``package://``, ``file://`` and relative URIs to absolute paths.

The one mesh resolver of manipkit: the viewer needs the files
(:func:`urdf_with_mesh_paths` gives it URDF text whose meshes are absolute
paths), and validation warns about meshes that do not resolve
(:func:`manipkit.description.validate.package_uri_warnings`). Both map a
``package://`` URI to a file with
:meth:`~manipkit.description.packages.PackageResolver.resolve_uri`, and any
other path with :func:`mesh_search_paths`.

When mesh files are absent (large files not pulled, a description copied
without its meshes), :func:`visual_urdf` with ``missing="draw"`` still gives
something to look at: a link whose meshes are all missing is drawn by its
primitive collision shapes (box, cylinder, sphere) if it has any, else as a
skeleton: a line (thin cylinder) from its origin to each child joint's origin
and a ball at its origin. :class:`MissingMeshes` says what was missing and
what is drawn instead, in one line (:meth:`MissingMeshes.message`).

Kinematics never need meshes, so nothing here runs when a robot is only
loaded for transforms (docs/architecture.md).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, NamedTuple

from manipkit.bounds import MAX_MESH_BYTES, MAX_TEXTURE_BYTES
from manipkit.description.packages import PACKAGE_SCHEME, missing_in_package_hint, split_package_uri
from manipkit.errors import DescriptionError, InputFileError, OptionError, PackageNotFoundError
from manipkit.text import printable

if TYPE_CHECKING:
    from manipkit.description.access import ReadPolicy
    from manipkit.description.packages import PackageResolver

__all__ = ["MISSING_MESHES", "SKELETON_COLOUR", "MissingMeshWarning", "MissingMeshes", "VisualURDF",
           "check_mesh_file", "mesh_path", "mesh_references", "mesh_search_paths", "urdf_with_mesh_paths",
           "visual_urdf"]

#: What :func:`visual_urdf` does with a mesh file it cannot find: raise, or draw the link another way.
MISSING_MESHES = ("error", "draw")
#: RGBA of what is drawn in place of missing meshes (a blue grey, unlike any real link's colour).
SKELETON_COLOUR = (0.45, 0.55, 0.75, 1.0)
_PRIMITIVES = ("box", "cylinder", "sphere")


class MissingMeshWarning(UserWarning):
    """Mesh files of a description are missing: the view draws their links another way (:class:`MissingMeshes`)."""


@dataclass(frozen=True)
class MissingMeshes:
    """The visual meshes :func:`visual_urdf` could not find, and what it drew instead.

    Attributes
    ----------
    missing : tuple of (link, uri, reason)
        Each missing visual mesh, in file order.
    total : int
        Visual meshes in the description.
    by_collision, by_lines : tuple of str
        Links drawn by their primitive collision shapes, and links drawn as
        lines between joint origins (a link with some of its meshes found keeps those, in neither).
    """

    missing: tuple[tuple[str, str, str], ...]
    total: int
    by_collision: tuple[str, ...]
    by_lines: tuple[str, ...]

    def message(self, robot: str) -> str:
        """One line: how many meshes are missing (the first named, with why) and what is drawn instead."""
        link, uri, reason = self.missing[0]
        drawn = [f"{len(links)} link{'s' * (len(links) != 1)} {how}"
                 for links, how in ((self.by_collision, "by their collision shapes"),
                                    (self.by_lines, "as lines between joint origins")) if links]
        instead = f"; drawn instead: {', '.join(drawn)}" if drawn else ""
        return (f"{robot}: {len(self.missing)} of {self.total} visual mesh files are missing (the first: link "
                f"'{link}' mesh {uri}: {reason}){instead}")


class VisualURDF(NamedTuple):
    """:func:`visual_urdf`'s answer."""

    text: str  # URDF whose visual meshes are absolute paths (and substitutes where meshes are missing)
    package_folders: list[str]  # what Pinocchio's package_dirs expects
    missing: MissingMeshes | None  # None when every mesh was found


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
            raise PackageNotFoundError(f"{where} resolves to {path}, which does not exist"
                                       + missing_in_package_hint(resolver, package, resolver.find(package)))
        if policy is not None:
            policy.check(path, where)
        return check_mesh_file(path, where, policy)
    if "://" in uri and not uri.startswith("file://"):
        raise PackageNotFoundError(f"{where}: only package://, file:// and file paths are supported")
    searched = mesh_search_paths(uri, resolver, relative_to=relative_to)
    if policy is not None and not policy.allows(searched[0]):
        policy.check(searched[0], where)  # raises, naming the path (whether it exists is not looked at)
    for candidate in searched:
        if policy is not None and not policy.allows(candidate):
            continue  # the current folder, outside what the description may read
        if candidate.is_file():
            return check_mesh_file(candidate.resolve(), where, policy)
    raise PackageNotFoundError(f"{where} not found; looked at {', '.join(map(str, searched))}")


def check_mesh_file(path: Path, where: str, policy: ReadPolicy | None = None) -> Path:
    """``path`` if the mesh file and every file it names may be read: the one check before a mesh loader runs.

    Pinocchio's meshcat loader reads the textures a DAE names
    (``<library_images>``/``<init_from>``, relative to the DAE's folder) and
    embeds them in the page or scene; assimp (coal's loader) reads the
    material libraries an OBJ names (``mtllib``). So each named file (:func:`mesh_references`)
    must exist (a DAE texture; an OBJ material library may be absent, nothing is read then), be a regular
    file of at most :data:`~manipkit.bounds.MAX_TEXTURE_BYTES`, and lie inside ``policy``; the mesh
    itself is a regular file of at most :data:`~manipkit.bounds.MAX_MESH_BYTES`.

    Raises
    ------
    InputFileError
        The mesh or a file it names is not a regular file, or too large.
    ReadNotAllowedError
        A file the mesh names lies outside ``policy`` (the message names the mesh and the file, never its text).
    DescriptionError
        A DAE names a texture that does not exist, or an empty ``<init_from>``.
    """
    from manipkit.inputs import check_input_file

    try:
        check_input_file(path, what="mesh file", max_bytes=MAX_MESH_BYTES)
    except InputFileError as exc:
        raise InputFileError(f"{where}: {printable(exc)}") from None
    for kind, named, required in mesh_references(path):
        shown = printable(named)[:200]
        if not named.strip():
            raise DescriptionError(f"{where}: {path.name} has an empty {kind}; remove it or name a file")
        target = Path(named)
        target = target if target.is_absolute() else path.parent / target
        if policy is not None:
            policy.check(target, f"{where}: {path.name} {kind} {shown}")
        if not os.path.lexists(target) and not required:
            continue
        if not target.exists():
            raise DescriptionError(f"{where}: {path.name} {kind} {shown} does not exist")
        try:
            check_input_file(target, what=kind.split()[0], max_bytes=MAX_TEXTURE_BYTES)
        except InputFileError as exc:
            raise InputFileError(f"{where}: {path.name} names a {printable(exc)[:400]}") from None
    return path


def mesh_references(path: str | os.PathLike) -> list[tuple[str, str, bool]]:
    """The files a mesh file names for its loaders to read: ``(kind, name as written, required)`` each.

    A DAE's ``<init_from>`` inside ``<library_images>`` (parsed as Pinocchio's
    meshcat loader parses it, any namespace; required: that loader fails on a
    missing one) and an OBJ's ``mtllib`` names (not required). STL names nothing.

    Examples
    --------
    >>> import tempfile
    >>> obj = Path(tempfile.mkdtemp()) / "a.obj"
    >>> _ = obj.write_text("mtllib ../../x.mtl\\nv 0 0 0\\n")
    >>> mesh_references(obj)
    [('mtllib', '../../x.mtl', False)]
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".obj":
        found = []
        with open(path, "rb") as stream:
            for raw in stream:
                line = raw.decode("utf-8", "replace").strip()
                if line.startswith("mtllib") and line[6:7] in (" ", "\t"):
                    found += [("mtllib", name, False) for name in line[7:].split()]  # assimp: one or more names
        return found
    if suffix != ".dae":
        return []
    import xml.etree.ElementTree as ET

    found, depth = [], 0
    try:
        for event, element in ET.iterparse(path, events=("start", "end")):
            tag = element.tag if isinstance(element.tag, str) else ""
            if "library_images" in tag:
                depth += 1 if event == "start" else -1
            elif event == "end" and depth > 0 and "init_from" in tag:
                found.append(("texture <init_from>", element.text or "", True))
    except ET.ParseError as exc:
        raise DescriptionError(f"{printable(path)}: not a readable COLLADA (DAE) file: {printable(exc)[:200]}") from None
    return found


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
    urdf_text: str, resolver: PackageResolver, *, relative_to: str | os.PathLike, element: str = "visual",
    policy: ReadPolicy | None = None,
) -> tuple[str, list[str]]:
    """URDF text whose ``<visual>`` (or ``<collision>``) mesh filenames are absolute paths, and the package folders used.

    Parameters
    ----------
    urdf_text : str
        URDF XML.
    resolver : PackageResolver
        Answers ``package://PKG``.
    relative_to : str or path-like, keyword-only
        The folder of the description file (for relative mesh paths).
    element : str, keyword-only
        ``"visual"`` (the viewer) or ``"collision"`` (collision geometry,
        :mod:`manipkit.kinematics.collisions`): whose meshes are resolved.
    policy : ReadPolicy, optional, keyword-only
        What the description may read; as for :func:`mesh_path`.

    Returns
    -------
    text : str
        ``urdf_text`` with each ``element`` mesh's ``filename`` replaced by
        :func:`mesh_path` (``urdf_text`` itself when there are no such meshes).
    package_folders : list of str
        Sorted: the parent folder of each package a ``package://`` mesh
        named (what Pinocchio's ``package_dirs`` expects).

    Raises
    ------
    PackageNotFoundError
        As :func:`mesh_path`, for the first mesh that cannot be resolved.
    """
    text, folders, _ = visual_urdf(urdf_text, resolver, relative_to=relative_to, element=element, policy=policy)
    return text, folders


def visual_urdf(urdf_text: str, resolver: PackageResolver, *, relative_to: str | os.PathLike,
                missing: str = "error", element: str = "visual", policy: ReadPolicy | None = None) -> VisualURDF:
    """:func:`urdf_with_mesh_paths`, and with ``missing="draw"`` links whose mesh files are absent drawn another way.

    Parameters
    ----------
    urdf_text, resolver, relative_to, element, policy
        As for :func:`urdf_with_mesh_paths` (``missing="draw"`` is for visuals only).
    missing : {"error", "draw"}, keyword-only
        ``"error"``: the first mesh that cannot be found raises. ``"draw"``:
        it is left out; a link left without visuals is drawn by its primitive
        collision shapes (box, cylinder, sphere) when it has some, else as lines
        (cylinders of radius about 1 % of the robot's joint offsets summed, 3 to
        20 mm) from its origin to each child joint's origin with a ball at its
        origin, in :data:`SKELETON_COLOUR`.

    Returns
    -------
    VisualURDF
        ``(text, package_folders, missing)``; ``missing`` is a
        :class:`MissingMeshes` or None when every mesh was found.

    Raises
    ------
    PackageNotFoundError
        With ``missing="error"``, as :func:`mesh_path`.
    """
    import xml.etree.ElementTree as ET

    if element not in ("visual", "collision"):
        raise OptionError(f"element must be 'visual' or 'collision', not {element!r:.40}")
    if missing not in MISSING_MESHES or (missing == "draw" and element != "visual"):
        raise OptionError(f"missing={missing!r:.40}: give one of {', '.join(MISSING_MESHES)} (draw: visuals only)")
    root = ET.fromstring(urdf_text)
    meshes = [(link, visual, mesh) for link in root.iter("link") for visual in link.findall(element)
              for mesh in visual.findall("geometry/mesh")]
    if not meshes:
        return VisualURDF(urdf_text, [], None)
    folders: set[str] = set()
    absent: list[tuple[str, str, str]] = []
    emptied = []
    for link, visual, mesh in meshes:
        uri = mesh.get("filename", "")
        try:
            path = mesh_path(uri, resolver, relative_to=relative_to, link=link.get("name"), policy=policy)
        except PackageNotFoundError as exc:
            if missing == "error":
                raise
            absent.append((link.get("name"), uri, _reason(str(exc), link.get("name"), uri)))
            if visual in link:
                link.remove(visual)
                if link.find("visual") is None:
                    emptied.append(link)
            continue
        if uri.startswith(PACKAGE_SCHEME):
            folders.add(str(resolver.find(split_package_uri(uri)[0]).parent))
        mesh.set("filename", str(path))
    if not absent:
        return VisualURDF(ET.tostring(root, encoding="unicode"), sorted(folders), None)
    by_collision, by_lines = _draw_instead(root, emptied)
    report = MissingMeshes(tuple(absent), len(meshes), tuple(by_collision), tuple(by_lines))
    return VisualURDF(ET.tostring(root, encoding="unicode"), sorted(folders), report)


def _reason(message: str, link: str, uri: str) -> str:
    """:func:`mesh_path`'s message without its own "link 'L': mesh URI" prefix."""
    for prefix in (f"link '{link}': mesh {uri} ", f"link '{link}': mesh {uri}: "):
        if message.startswith(prefix):
            return message[len(prefix):].removeprefix("cannot be resolved: ")
    return message


def _draw_instead(root, links) -> tuple[list[str], list[str]]:
    """Give each link in ``links`` (no visuals left) visuals: its primitive collision shapes, else a skeleton."""
    import copy
    import xml.etree.ElementTree as ET

    children: dict[str, list[tuple[float, float, float]]] = {}
    offsets = []
    for joint in root.findall("joint"):
        parent, origin = joint.find("parent"), joint.find("origin")
        xyz = _numbers(origin.get("xyz") if origin is not None else None)
        offsets.append(math.hypot(*xyz))
        if parent is not None:
            children.setdefault(parent.get("link"), []).append(xyz)
    radius = min(max(0.01 * sum(offsets), 0.003), 0.02)
    colour = " ".join(f"{c:g}" for c in SKELETON_COLOUR)
    by_collision, by_lines = [], []

    def add(link, geometry, xyz=(0.0, 0.0, 0.0), rpy=(0.0, 0.0, 0.0), origin=None):
        visual = ET.SubElement(link, "visual")
        if origin is not None:
            visual.append(copy.deepcopy(origin))
        else:
            ET.SubElement(visual, "origin", xyz=" ".join(map(repr, xyz)), rpy=" ".join(map(repr, rpy)))
        visual.append(geometry)
        material = ET.SubElement(visual, "material", name="manipkit_missing_mesh")
        ET.SubElement(material, "color", rgba=colour)

    for link in links:
        shapes = [(c.find("origin"), c.find("geometry")) for c in link.findall("collision")]
        shapes = [(o, g) for o, g in shapes if g is not None and len(g) and g[0].tag in _PRIMITIVES]
        if shapes:
            for origin, geometry in shapes:
                add(link, copy.deepcopy(geometry), origin=origin)
            by_collision.append(link.get("name"))
            continue
        ball = ET.Element("geometry")
        ET.SubElement(ball, "sphere", radius=repr(1.6 * radius))
        add(link, ball)
        for xyz in children.get(link.get("name"), []):
            length = math.hypot(*xyz)
            if length < 2 * radius:
                continue
            stick = ET.Element("geometry")
            ET.SubElement(stick, "cylinder", radius=repr(radius), length=repr(length))
            # a cylinder lies along z: turn z onto the offset (yaw about z, then pitch about y)
            pitch = math.acos(max(-1.0, min(1.0, xyz[2] / length)))
            yaw = math.atan2(xyz[1], xyz[0])
            add(link, stick, xyz=tuple(v / 2 for v in xyz), rpy=(0.0, pitch, yaw))
        by_lines.append(link.get("name"))
    return by_collision, by_lines


def _numbers(text: str | None) -> tuple[float, float, float]:
    """A URDF ``xyz`` attribute as three floats (0 where absent; the description was validated)."""
    try:
        values = tuple(float(v) for v in (text or "").split())
    except ValueError:
        return (0.0, 0.0, 0.0)
    return values if len(values) == 3 and all(math.isfinite(v) for v in values) else (0.0, 0.0, 0.0)
