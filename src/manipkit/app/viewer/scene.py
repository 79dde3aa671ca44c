"""The scene of a view: the robot's visual geometry and a meshcat adapter that draws it with two triads.

:func:`visual_model` loads the robot's ``<visual>`` geometry (meshes
resolved first) as a Pinocchio ``GeometryModel``; :class:`MeshcatScene`
starts a meshcat server, loads that geometry through Pinocchio's
``MeshcatVisualizer`` (a DAE visual as coloured triangles:
:mod:`manipkit.app.viewer.coloured_meshes`) and draws the placements :class:`ViewerState`
computes, plus a triad at A and at B, and tints the visuals of links in
collision (:data:`COLLISION_COLOUR`) until they are free. It computes nothing itself.

Conventions (docs/architecture.md): metres; placements are 4x4 ``T_root_node``
in the robot's root link. meshcat and ``pinocchio.visualize`` are imported
when a scene starts.
"""

from __future__ import annotations

import atexit
import contextlib
import io
import math
import os
import queue
import shutil
import subprocess
import sys
import threading
import warnings
from typing import TYPE_CHECKING

import numpy as np

from manipkit.app.viewer.state import ELLIPSOID_PATH, TRIAD_PATHS, VISUALS_ROOT
from manipkit.errors import ViewerError

if TYPE_CHECKING:
    from manipkit.kinematics.robot import Robot

__all__ = ["CAMERA_AZIMUTH_DEG", "CAMERA_ELEVATION_DEG", "CAMERA_FOV_DEG", "COLLISION_COLOUR", "FRAME_FILL", "TRIAD_DOTS",
           "MeshcatScene",
           "camera_distance", "floor_lines", "visual_model"]

#: The opening view: from the direction between +x and +y (45 deg), looking down 30 deg at the robot's centre.
CAMERA_AZIMUTH_DEG = 45.0
CAMERA_ELEVATION_DEG = 30.0
#: meshcat's camera: a perspective camera with this vertical field of view.
CAMERA_FOV_DEG = 75.0
#: The robot's box fills at most this fraction of the half field of view (in a square window; a wider one has room).
FRAME_FILL = 0.85


def visual_model(robot: Robot):
    """The robot's ``<visual>`` geometry as a Pinocchio ``GeometryModel`` (:meth:`Robot.visual_model`).

    Links whose mesh files are missing are drawn by their collision shapes or as
    lines between joint origins, with one :class:`~manipkit.description.meshes.MissingMeshWarning`
    (``Robot.visual_model(missing_meshes="draw")``): a view without meshes beats no view.
    """
    return robot.visual_model(missing_meshes="draw")


# ----------------------------------------------------------------------
# Framing: the camera and the floor
# ----------------------------------------------------------------------


def _camera_axes(azimuth_deg: float, elevation_deg: float):
    """Unit vectors (root frame): towards the camera from its target, the view's right, the view's up."""
    a, e = math.radians(azimuth_deg), math.radians(elevation_deg)
    back = np.array([math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)])
    right = np.array([-math.sin(a), math.cos(a), 0.0])
    return back, right, np.cross(back, right)


def camera_distance(lower, upper, *, azimuth_deg: float = CAMERA_AZIMUTH_DEG,
                    elevation_deg: float = CAMERA_ELEVATION_DEG, fov_deg: float = CAMERA_FOV_DEG,
                    fill: float = FRAME_FILL) -> float:
    """How far from the box's centre a camera looking at it must be for all 8 corners to be in the picture (m).

    The camera looks at the centre of the box ``lower``..``upper`` from
    ``azimuth_deg`` (from +x towards +y) and ``elevation_deg`` above the
    horizontal; a corner at ``x`` right, ``y`` up and depth ``z`` is inside when
    ``|x|, |y| <= fill * tan(fov / 2) * z`` (a square window: a wider one shows more).

    Examples
    --------
    >>> d = camera_distance([-0.5, -0.5, -0.5], [0.5, 0.5, 0.5], elevation_deg=0.0, azimuth_deg=0.0, fill=1.0)
    >>> round(d, 6) == round(0.5 + 0.5 / math.tan(math.radians(37.5)), 6)  # the near face's corners bound it
    True
    """
    lower, upper = np.asarray(lower, dtype=float), np.asarray(upper, dtype=float)
    back, right, up = _camera_axes(azimuth_deg, elevation_deg)
    half = (upper - lower) / 2
    corners = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)]) * half
    slope = fill * math.tan(math.radians(fov_deg) / 2)
    needed = corners @ back + np.maximum(np.abs(corners @ right), np.abs(corners @ up)) / slope
    return max(float(needed.max()), 0.1)


def _step_125(value: float) -> float:
    """The nearest of 1, 2 or 5 times a power of ten to ``value`` (on a log scale)."""
    power = 10.0 ** math.floor(math.log10(value))
    return min((m * power for m in (1.0, 2.0, 5.0, 10.0)), key=lambda step: abs(math.log(value / step)))


def floor_lines(lower, upper, base, height: float | None = None) -> tuple[np.ndarray, np.ndarray, float, float]:
    """The floor grid: line segments one cell long in the plane under the base, sized to the robot.

    The floor is horizontal at ``height`` (default: the lower of the base's
    height and the box's bottom), centred under ``base`` (root frame); it reaches as far from the
    base as the farthest corner of the box (rounded up to whole cells), in
    cells of 1, 2 or 5 times a power of ten, about a fifth of that reach.
    Segments one cell long (not lines across the grid) draw correctly even
    where the grid passes behind the camera.

    Returns
    -------
    points : ndarray, shape (2 N, 3)
        Segment ends, pairwise (root frame, m).
    colours : ndarray, shape (2 N, 3)
        RGB in 0..1: the two lines through the base darker.
    step, half : float
        Cell size and half width (m).
    """
    lower, upper, base = (np.asarray(v, dtype=float) for v in (lower, upper, base))
    corners = np.array([[x, y, z] for x in (lower[0], upper[0]) for y in (lower[1], upper[1])
                        for z in (lower[2], upper[2])])
    reach = max(float(np.linalg.norm(corners - base, axis=1).max()), 0.1)
    step = _step_125(reach / 5)
    cells = int(math.ceil(reach / step - 1e-9))
    half = cells * step
    ticks = np.arange(-cells, cells + 1) * step
    height = min(float(base[2]), float(lower[2])) if height is None else float(height)
    starts, ends, through = [], [], []
    for k, tick in enumerate(ticks):
        for a, b in zip(ticks[:-1], ticks[1:]):
            starts += [(tick, a), (a, tick)]  # a segment along y at x = tick, one along x at y = tick
            ends += [(tick, b), (b, tick)]
            through += [k == cells] * 2
    starts, ends = np.array(starts) + base[:2], np.array(ends) + base[:2]
    points = np.empty((2 * len(starts), 3))
    points[0::2, :2], points[1::2, :2], points[:, 2] = starts, ends, height
    colours = np.where(np.repeat(through, 2)[:, None], 0.27, 0.55) * np.ones(3)
    return points, colours, step, half


# ----------------------------------------------------------------------
# Scene: meshcat adapter
# ----------------------------------------------------------------------

_AXES = (  # triad axis -> (colour, T_frame_cylinder for a unit cylinder along y), lengths scaled later
    ("x", 0xE41A1C, np.array([[0.0, 1, 0, 0.5], [-1, 0, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])),
    ("y", 0x4DAF4A, np.array([[1.0, 0, 0, 0], [0, 1, 0, 0.5], [0, 0, 1, 0], [0, 0, 0, 1]])),
    ("z", 0x377EB8, np.array([[1.0, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0.5], [0, 0, 0, 1]])),
)
TRIAD_DOTS = (0x222222, 0xE040E0)  # origin dot of A (near black) and B (magenta)
ELLIPSOID_COLOUR = 0xE040E0  # B's colour, translucent
#: RGBA (0..1) of a visual whose link is in collision: opaque pure red (the triads' x axes are 0xE41A1C).
COLLISION_COLOUR = (1.0, 0.0, 0.0, 1.0)


class MeshcatScene:
    """The meshcat side of a view: a meshcat server, the robot's visuals, two triads and the ellipsoid.

    It computes nothing: :meth:`draw` sends the placements it is given
    (scene path -> 4x4 in the robot's root frame) and the visibilities
    (path -> bool) and tints (path -> in collision: drawn in :data:`COLLISION_COLOUR`,
    or back in its own colours), skipping unchanged ones. The manipulability ellipsoid is a
    translucent unit sphere at ``ELLIPSOID_PATH``, hidden until shown; its
    placement scales it (:meth:`ViewerState.ellipsoid_placement`).

    Parameters
    ----------
    visual : pinocchio.GeometryModel
        From :func:`visual_model`.
    model : pinocchio.Model
        ``robot.model`` (Pinocchio's visualizer wants it).
    bounds : (lower, upper), keyword-only
        Box around the robot (m, root frame; :meth:`ViewerState.bounds`): the
        camera orbits its centre and opens where the whole box is in the
        picture (:func:`camera_distance`); the floor and the triads are sized from it.
    base : (3,) array_like, keyword-only
        Where the robot stands (root frame, m; default the root's origin): the
        floor grid lies under it (:func:`floor_lines`), replacing meshcat's
        fixed 20 m grid at the root's height.
    floor_height : float, keyword-only
        The floor's height (root frame, m); default the lower of the base's and the box's bottom.
    """

    def __init__(self, visual, model, *, bounds=((0.0, 0.0, 0.0), (1.0, 1.0, 1.0)), base=(0.0, 0.0, 0.0),
                 floor_height: float | None = None):
        with warnings.catch_warnings():  # meshcat 0.3 imports pyzmq's zmq.eventloop.ioloop, which warns it is deprecated
            warnings.filterwarnings("ignore", message=r"zmq\.eventloop\.ioloop is deprecated")
            import meshcat
            import meshcat.geometry as mg

            from manipkit.app.viewer.coloured_meshes import Visualizer

        self._proc, zmq_url, self.url = _start_meshcat_server()
        self._closed = False
        atexit.register(self.close)
        try:
            with contextlib.redirect_stdout(io.StringIO()):  # meshcat prints its URL; the caller decides
                self.viewer = meshcat.Visualizer(zmq_url=zmq_url)
            self.visualizer = Visualizer(model, visual_model=visual)
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                self.visualizer.initViewer(viewer=self.viewer)
                self.visualizer.loadViewerModel(rootNodeName=VISUALS_ROOT.split("/")[0])
            #: Pinocchio's complaints about geometry it could not show (one line each).
            self.warnings = [" ".join(str(w.message).split()) for w in caught if "get_image" not in str(w.message)]
            lower, upper = np.asarray(bounds[0], dtype=float), np.asarray(bounds[1], dtype=float)
            size = max(float(np.linalg.norm(upper - lower)), 0.2)
            length = min(max(0.2 * size, 0.05), 0.3)
            for path, dot in zip(TRIAD_PATHS, TRIAD_DOTS):
                node = self.viewer[path]
                for axis, colour, T in _AXES:
                    node[axis].set_object(mg.Cylinder(length, 0.04 * length), mg.MeshLambertMaterial(color=colour))
                    placement = T.copy()
                    placement[:3, 3] *= length
                    node[axis].set_transform(placement)
                node["origin"].set_object(mg.Sphere(0.09 * length), mg.MeshLambertMaterial(color=dot))
            self.viewer[ELLIPSOID_PATH].set_object(
                mg.Sphere(1.0), mg.MeshLambertMaterial(color=ELLIPSOID_COLOUR, opacity=0.35, transparent=True))
            self.viewer[ELLIPSOID_PATH].set_property("visible", False)
            # The floor: meshcat's grid (20 m, at the root's height) replaced by one under the base, sized to
            # the robot; it stays meshcat's "Grid" node, so meshcat's controls still show and hide it.
            points, colours, _, _ = floor_lines(lower, upper, base, floor_height)
            self.viewer["/Grid"].set_object(mg.LineSegments(
                mg.PointsGeometry(points.T.astype(np.float32), colours.T.astype(np.float32)),
                mg.LineBasicMaterial(vertexColors=True)))
            # meshcat's camera orbits the origin: shift the robot, the grid and the axes so that the
            # robot's centre sits there (the scene keeps its own geometry: the shift is one transform).
            shift = np.eye(4)
            shift[:3, 3] = -(lower + upper) / 2
            for root in ("/meshcat", "/Grid", "/Axes"):
                self.viewer[root].set_transform(shift)
            # The camera looks at the centre from a three-quarter view, down CAMERA_ELEVATION_DEG, far enough for
            # the whole box. The camera node is y-up: its position is (x, z, -y) in the robot's frame.
            back, _, _ = _camera_axes(CAMERA_AZIMUTH_DEG, CAMERA_ELEVATION_DEG)
            x, y, z = camera_distance(lower - length, upper + length) * back  # the triads' arms in the picture too
            self.viewer["/Cameras/default/rotated/<object>"].set_property("position", [x, z, -y])
        except BaseException:
            self.close()
            raise
        self._sent: dict[str, np.ndarray] = {}
        self._visible: dict[str, bool] = {ELLIPSOID_PATH: False}
        self._tinted: dict[str, bool] = {}
        #: scene path -> the visual's GeometryObject, to give it its own colours back after a tint.
        self._geometry = {f"{VISUALS_ROOT}/{geometry.name}": geometry for geometry in visual.geometryObjects}

    def draw(self, placements: dict[str, np.ndarray], visible: dict[str, bool] | None = None,
             tinted: dict[str, bool] | None = None) -> None:
        """Place scene nodes (path -> 4x4), show or hide them (path -> bool) and tint visuals (path -> in collision);
        unchanged ones are not re-sent.

        A node is placed before it is shown, so it never appears at an old pose.
        """
        if self._closed or self._proc.poll() is not None:
            raise ViewerError("the meshcat server has stopped; restart the viewer")
        for path, tint in (tinted or {}).items():  # before placing: a visual loaded again is placed afresh
            if self._tinted.get(path, False) != bool(tint):
                self._tint(path, bool(tint))
        for path, T in placements.items():
            previous = self._sent.get(path)
            if previous is None or not np.array_equal(previous, T):
                self.viewer[path].set_transform(T)
                self._sent[path] = np.array(T, copy=True)
        for path, shown in (visible or {}).items():
            if self._visible.get(path) != bool(shown):
                self.viewer[path].set_property("visible", bool(shown))
                self._visible[path] = bool(shown)

    def _tint(self, path: str, tint: bool) -> None:
        """Draw the visual at ``path`` in :data:`COLLISION_COLOUR`, or in its own colours again.

        Its own colours: the URDF's colour, as Pinocchio's visualizer set it
        (8 bits a channel, opaque unless the alpha says otherwise); a DAE drawn
        as coloured triangles is sent again, in red or in its vertex colours; a
        COLLADA mesh drawn from its file is loaded again.
        """
        self._tinted[path] = tint
        if path in self.visualizer.coloured:  # a DAE drawn as coloured triangles: the same triangles, in red or not
            self.visualizer.draw_coloured(path, COLLISION_COLOUR if tint else None)
            self._sent.pop(path, None)  # the fresh object is placed by this draw's placements
            return
        if tint:
            self.viewer[path].set_property("color", list(COLLISION_COLOUR))
            return
        geometry = self._geometry[path]
        mesh_path = str(getattr(geometry, "meshPath", "") or "")
        if mesh_path.lower().endswith(".dae") and not geometry.overrideMaterial:
            import pinocchio as pin

            self.visualizer.loadViewerGeometryObject(geometry, pin.GeometryType.VISUAL)
            self._sent.pop(path, None)  # the fresh object is placed by this draw's placements
            return
        r, g, b, a = (float(v) for v in geometry.meshColor)
        self.viewer[path].set_property("color", [int(r * 255) / 255, int(g * 255) / 255, int(b * 255) / 255, a])

    @property
    def tinted(self) -> dict[str, bool]:
        """The tints last sent to meshcat (scene path -> drawn in the collision colour)."""
        return dict(self._tinted)

    @property
    def visible(self) -> dict[str, bool]:
        """The visibilities last sent to meshcat (scene path -> shown)."""
        return dict(self._visible)

    @property
    def drawn(self) -> dict[str, np.ndarray]:
        """The placements last sent to meshcat (scene path -> 4x4)."""
        return {path: T.copy() for path, T in self._sent.items()}

    def static_html(self) -> str:
        """meshcat's standalone page of the current scene (no server needed to open it)."""
        return self.viewer.static_html()

    def close(self) -> None:
        """Stop the meshcat server (idempotent)."""
        if getattr(self, "_closed", True):
            return
        self._closed = True
        viewer = getattr(self, "viewer", None)
        if viewer is not None:
            viewer.window.zmq_socket.close(linger=0)
        if self._proc.poll() is None:
            self._proc.kill()
            self._proc.wait(timeout=10)
        with contextlib.suppress(OSError):
            self._proc.stdin.close()
        shutil.rmtree(getattr(self._proc, "private_folder", ""), ignore_errors=True)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def _start_meshcat_server(timeout: float = 30.0):
    """Start :mod:`manipkit.app.viewer.meshcat_server`; returns (process, zmq_url, web_url).

    Started here rather than by ``meshcat.Visualizer()`` so that its output is
    drained (a long session cannot fill a pipe) and the viewer owns its
    lifetime: the server listens on loopback only, takes scene commands on a
    private ``ipc://`` socket, and exits when this process does (its stdin is
    a pipe from here). It runs in its own session so a notebook interrupt leaves it be.
    """
    from manipkit.app.viewer.meshcat_server import private_zmq_url

    zmq_url, folder = private_zmq_url()
    proc = subprocess.Popen(
        [sys.executable, "-u", "-m", "manipkit.app.viewer.meshcat_server", zmq_url, str(os.getpid())],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
        text=True, start_new_session=True,
    )
    proc.private_folder = folder  # removed by MeshcatScene.close
    lines: queue.Queue = queue.Queue()

    def drain():
        for line in proc.stdout:
            lines.put(line)
        lines.put(None)

    threading.Thread(target=drain, name="meshcat-server-output", daemon=True).start()
    urls: dict[str, str] = {}
    try:
        while len(urls) < 2:
            line = lines.get(timeout=timeout)
            if line is None:
                raise ViewerError(f"the meshcat server exited at start-up (status {proc.wait()})")
            key, _, value = line.strip().partition("=")
            if key in ("zmq_url", "web_url"):
                urls[key] = value
    except queue.Empty:
        proc.kill()
        raise ViewerError(f"the meshcat server did not start within {timeout:g} s") from None
    except BaseException:
        proc.kill()
        raise
    return proc, urls["zmq_url"], urls["web_url"]
