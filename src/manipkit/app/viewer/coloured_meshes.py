"""Pinocchio's meshcat visualizer, drawing a DAE visual as coloured triangles sent as binary arrays.

:func:`manipkit.description.mesh_colours.coloured_triangles` reads the file;
:class:`Visualizer` sends its arrays (a three.js ``BufferGeometry`` with a
position and a colour per vertex, drawn with vertex colours; three.js computes the normals) where
Pinocchio's visualizer would send the file's text, and Pinocchio's own loading
otherwise (STL, OBJ, shapes, a DAE it cannot draw so). Imported when a scene starts (it imports meshcat
and ``pinocchio.visualize``).
"""

from __future__ import annotations

import warnings

import numpy as np

from manipkit.description.mesh_colours import ColouredMesh, coloured_triangles

with warnings.catch_warnings():  # meshcat 0.3 imports pyzmq's zmq.eventloop.ioloop, which warns it is deprecated
    warnings.filterwarnings("ignore", message=r"zmq\.eventloop\.ioloop is deprecated")
    import meshcat.geometry as mg
    from pinocchio.visualize import MeshcatVisualizer

__all__ = ["ColouredTriangles", "Visualizer"]


class ColouredTriangles(mg.Geometry):
    """A :class:`~manipkit.description.mesh_colours.ColouredMesh` as meshcat geometry (float32 and uint32 arrays)."""

    def __init__(self, mesh: ColouredMesh):
        super().__init__()
        self.vertices = np.ascontiguousarray(mesh.vertices, dtype=np.float32)
        self.colours = np.ascontiguousarray(mesh.colours, dtype=np.float32)
        self.faces = np.ascontiguousarray(mesh.faces, dtype=np.uint32)

    def lower(self, object_data):
        attributes = {"position": mg.pack_numpy_array(self.vertices.T), "color": mg.pack_numpy_array(self.colours.T)}
        return {"uuid": self.uuid, "type": "BufferGeometry",
                "data": {"attributes": attributes, "index": mg.pack_numpy_array(self.faces.T)}}


class Visualizer(MeshcatVisualizer):
    """``pinocchio.visualize.MeshcatVisualizer`` that draws what it can of DAE visuals as coloured triangles.

    ``coloured`` maps each scene path drawn so to its geometry; :meth:`draw_coloured`
    draws it again in its own colours or in one colour (a tint), the same
    triangles either way. A URDF colour given to a DAE visual does not change
    its colours: meshcat's loader of a DAE file never applied it (it takes the
    file's materials), so the picture stays what it was.
    """

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.coloured: dict[str, ColouredTriangles] = {}

    def loadViewerGeometryObject(self, geometry_object, geometry_type, color=None):  # noqa: N802 - Pinocchio's name
        path = self.getViewerNodeName(geometry_object, geometry_type)
        if path not in self.coloured and color is None and str(geometry_object.meshPath).lower().endswith(".dae"):
            mesh = coloured_triangles(geometry_object.meshPath, geometry_object.meshColor)
            if mesh is not None:
                self.coloured[path] = ColouredTriangles(mesh)
        if path not in self.coloured:
            return super().loadViewerGeometryObject(geometry_object, geometry_type, color)
        self.draw_coloured(path)
        return None

    def draw_coloured(self, path: str, rgba=None) -> None:
        """Send the triangles at ``path`` in their own colours (``rgba`` None) or all in ``rgba`` (0..1)."""
        if rgba is None:
            material = mg.MeshPhongMaterial(vertexColors=True)
        else:
            r, g, b, a = (float(v) for v in rgba)
            material = mg.MeshPhongMaterial(color=int(r * 255) * 65536 + int(g * 255) * 256 + int(b * 255),
                                            opacity=a, transparent=a < 1.0)
        self.viewer[path].set_object(self.coloured[path], material)
