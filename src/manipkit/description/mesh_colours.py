"""A COLLADA (DAE) visual mesh as coloured triangles: vertex and colour arrays the viewer sends as they are.

The viewer used to hand each DAE file's text to the browser, whose COLLADA
loader (three.js) parsed it on every page: 5-7 s of CPU for a Panda or a UR5
page in a software-drawn browser, a 15 MB page for the Panda, and the UR5's
joint housings of example-robot-data missing from the picture.
:func:`coloured_triangles` reads the file once with pycollada instead: every
triangle of every ``<triangles>``/``<polylist>``/``<polygons>`` of the
scene's geometry instances (``<lines>`` are not drawn), the node transforms
applied (pycollada's bound geometry), in the file's units times its
``<unit meter>``, each vertex with the diffuse colour of its material (the
mesh's own colour where a primitive names no material).
A primitive's triangles share its vertices, and the browser computes the
normals from them (smooth across each primitive): the file's own normals are
nearly one per corner (403,215 corners, 402,998 distinct for the Panda), and
sending them made the Panda's page 22 MB.

It answers ``None`` (draw the file as before) for what it would draw
differently from the file: a texture or a translucent material, an up axis
other than ``Z_UP``, a file with a ``<!DOCTYPE>`` or ``<!ENTITY>`` (never
parsed here), or one pycollada cannot read. It reads no other file.
"""

from __future__ import annotations

import io
import os
import warnings
from pathlib import Path
from typing import NamedTuple

import numpy as np

__all__ = ["ColouredMesh", "coloured_triangles"]


class ColouredMesh(NamedTuple):
    """Triangles with an RGB colour per vertex, in the mesh file's frame (m, unscaled by the URDF)."""

    vertices: np.ndarray  # (n, 3) float64
    colours: np.ndarray  # (n, 3) float64 in 0..1
    faces: np.ndarray  # (m, 3) int64 rows into vertices


def _opaque_colour(effect, default_rgba) -> tuple[float, float, float] | None:
    """The RGB of a material's effect if it is a plain opaque colour, else None."""
    if effect is None:
        rgb = tuple(float(c) for c in default_rgba[:3])
        return rgb if float(default_rgba[3]) >= 1.0 and all(0.0 <= c <= 1.0 for c in rgb) else None
    diffuse = effect.diffuse
    if not isinstance(diffuse, tuple) or len(diffuse) != 4 or float(diffuse[3]) < 1.0:
        return None  # a texture, or translucent
    transparent, transparency = effect.transparent, effect.transparency
    if transparent is not None:  # opacity as three.js's COLLADA loader reads it: only A_ONE, fully opaque, passes
        if str(getattr(effect, "opaque_mode", "A_ONE")) != "A_ONE" or not isinstance(transparent, tuple):
            return None
        if float(transparent[3]) * (1.0 if transparency is None else float(transparency)) < 1.0:
            return None
    rgb = tuple(float(c) for c in diffuse[:3])
    return tuple(min(max(c, 0.0), 1.0) for c in rgb) if all(map(np.isfinite, rgb)) else None  # as three.js clamps


def coloured_triangles(path: str | os.PathLike, default_rgba=(1.0, 1.0, 1.0, 1.0)) -> ColouredMesh | None:
    """The triangles of a DAE file with a colour per vertex, or None to draw the file itself.

    Parameters
    ----------
    path : path-like
        A ``.dae`` file (checked by the loader already: a regular file of bounded size).
    default_rgba : (4,) array_like
        The colour of a primitive whose material is missing (the URDF's colour of the visual).

    Returns
    -------
    ColouredMesh or None
        Vertices in metres in the file's frame (``<unit meter>`` applied, node
        transforms applied, the URDF's scale not). None: see the module docstring.
    """
    try:
        data = Path(path).read_bytes()
    except OSError:  # gone since the loader checked it: Pinocchio's loading says so
        return None
    if b"<!DOCTYPE" in data or b"<!ENTITY" in data:
        return None
    try:
        with warnings.catch_warnings():  # pycollada's numpy.matrix and deprecated members; numpy on a bad number
            warnings.simplefilter("ignore", (DeprecationWarning, PendingDeprecationWarning, RuntimeWarning))
            return _read(data, default_rgba)
    except Exception:  # noqa: BLE001 - any file pycollada cannot read is drawn as the file (its text is not shown)
        return None


def _read(data: bytes, default_rgba) -> ColouredMesh | None:
    import collada

    mesh = collada.Collada(io.BytesIO(data), aux_file_loader=lambda name: None,
                           ignore=[collada.common.DaeUnsupportedError, collada.common.DaeBrokenRefError])
    if mesh.assetInfo.upaxis != "Z_UP" or mesh.scene is None:
        return None
    parts = []
    for geometry in mesh.scene.objects("geometry"):
        for primitive in geometry.primitives():
            triangles = primitive.triangleset() if hasattr(primitive, "triangleset") else primitive
            if not isinstance(triangles, collada.triangleset.BoundTriangleSet) or len(triangles.vertex_index) == 0:
                continue  # <lines>: not drawn (a Panda link has two, a millimetre long)
            rgb = _opaque_colour(triangles.material.effect if triangles.material is not None else None, default_rgba)
            if rgb is None:
                return None
            parts.append((triangles, rgb))
    return _joined(parts, float(mesh.assetInfo.unitmeter or 1.0)) if parts else None


def _joined(parts, unit: float) -> ColouredMesh:
    """One vertex per distinct position of each primitive (shared by its triangles); the primitives end to end."""
    vertices, colours, faces, offset = [], [], [], 0
    for triangles, rgb in parts:
        unique, inverse = np.unique(np.asarray(triangles.vertex_index, dtype=np.int64).reshape(-1), return_inverse=True)
        if unique[0] < 0 or unique[-1] >= len(triangles.vertex):  # numpy would wrap a negative index
            raise IndexError("a <p> index outside the positions")
        vertices.append(np.asarray(triangles.vertex, dtype=float)[unique] * unit)
        colours.append(np.broadcast_to(rgb, (len(unique), 3)))
        faces.append(inverse.reshape(-1, 3) + offset)
        offset += len(unique)
    mesh = ColouredMesh(np.concatenate(vertices), np.concatenate(colours).astype(float), np.concatenate(faces))
    if not np.isfinite(mesh.vertices).all():
        raise ValueError("a position that is not a finite number")
    return mesh
