"""Browser view of a robot: meshcat scene, joint sliders and a live T_A_B readout.

Three layers, each usable on its own:

- :class:`ViewerState` holds what the user chose: one value per movable
  joint (clamped into its limits) and two frames A and B. It answers the
  slider specs, the readout (exactly the JSON of ``tf-between A B --format
  json``, from :func:`manipkit.app.pose.pose_report`, and its text, from
  :func:`manipkit.app.pose.pose_text`) and where everything in the scene goes
  (triads from :meth:`manipkit.kinematics.robot.Robot.transform`, visuals from
  Pinocchio's ``updateGeometryPlacements``). No meshcat, no browser:
  unit-testable as is.
- :class:`MeshcatScene` is a thin adapter: it starts a meshcat server, loads
  the robot's visual geometry through Pinocchio's ``MeshcatVisualizer`` and
  draws the placements the state computes, plus a triad at A and at B.
- :class:`ViewerServer` serves the control page (standard library HTTP
  server, in a thread): the page posts slider moves, the server updates the
  state and the scene and answers with the readout.

Conventions (DESIGN.md): metres and radians; ``T_a_b`` is the pose of frame b
expressed in frame a; the scene's world frame is the robot's root link.
Pinocchio, meshcat, ``pinocchio.visualize`` and ipywidgets are imported
inside the functions that need them, so importing this module stays cheap.
"""

from __future__ import annotations

import atexit
import contextlib
import errno
import io
import json
import math
import queue
import subprocess
import sys
import threading
import warnings
from dataclasses import asdict, dataclass
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

import numpy as np

from manipkit.errors import DescriptionError, JointValueError, ManipkitError, PackageNotFoundError
from manipkit.app.pose import pose_report, pose_text
from manipkit.spatial.rotations import wrap_angle

DEFAULT_PORT = 8700
DEFAULT_FRAMES = ("base_link", "ee_link")
#: meshcat paths: Pinocchio's MeshcatVisualizer puts visuals under VISUALS_ROOT/<geometry name>.
VISUALS_ROOT = "pinocchio/visuals"
TRIAD_PATHS = ("manipkit/frame_a", "manipkit/frame_b")

__all__ = [
    "DEFAULT_FRAMES", "DEFAULT_PORT", "SliderSpec", "ViewerState", "MeshcatScene", "ViewerServer",
    "visual_model", "open_view", "write_static", "notebook_view", "NotebookView",
]


# ----------------------------------------------------------------------
# State: joint values and frames -> readout and scene placements
# ----------------------------------------------------------------------


@dataclass(frozen=True)
class SliderSpec:
    """One slider of the control page.

    ``lower``/``upper`` are the joint limits (continuous joints: one step
    above -pi to pi, so every slider position is an angle in (-pi, pi]);
    ``unit`` is ``rad`` or ``m``; ``step`` is a thousandth of the range (for
    widgets that need one; the browser's range input takes any value).
    """

    name: str
    type: str
    lower: float
    upper: float
    step: float
    value: float
    unit: str


class ViewerState:
    """Joint values and the frames A, B of a view; answers the readout and the scene placements.

    Parameters
    ----------
    robot : manipkit.kinematics.robot.Robot
    frames : (str, str), keyword-only
        A and B; the readout is T_A_B, the pose of B expressed in A.
    q : array_like, shape (n,), optional, keyword-only
        Start pose (radians, metres); default every joint at 0 or the nearest
        value inside its limits. Clamped into the limits like a slider would
        (continuous joints: wrapped to (-pi, pi]).

    Examples
    --------
    >>> import manipkit
    >>> state = ViewerState(manipkit.load("planar_2r"))
    >>> state.set_joint("joint1", 10.0)   # clamped into the limits
    3.141592653589793
    >>> state.readout()["target"]
    'ee_link'
    """

    def __init__(self, robot, *, frames: tuple[str, str] = DEFAULT_FRAMES, q=None):
        self.robot = robot
        self._frames = self._checked_frames(frames)
        self._continuous = np.array([joint.type == "continuous" for joint in robot.joints], dtype=bool)
        start = robot.q() if q is None else q
        robot.as_dict(start)  # checks the shape and that the values are finite numbers
        self._q = self._in_range(start)
        self._start = self._q.copy()
        self._data = robot.model.createData()  # the scene's own Pinocchio workspace (robot.data is the robot's)

    # Joint values -------------------------------------------------------

    @property
    def q(self) -> np.ndarray:
        """The joint vector (copy), in ``robot.joint_names`` order."""
        return self._q.copy()

    def set_joint(self, name: str, value) -> float:
        """Set one joint; returns the value used (clamped into the limits, continuous joints wrapped to (-pi, pi]).

        Raises
        ------
        JointValueError
            Unknown joint (the valid ones are listed), or a value that is not a finite number.
        """
        self.robot.q({name: value})  # validates the name and the number, with the model's messages
        index = self.robot.joint_names.index(name)
        q = self._q.copy()
        q[index] = float(value)
        self._q = self._in_range(q)
        return float(self._q[index])

    def set_joints(self, values: dict) -> None:
        """Set several joints at once (all checked before any is set)."""
        self.robot.q(dict(values))
        for name, value in values.items():
            self.set_joint(name, value)

    def reset(self) -> None:
        """Back to the start pose (the ``q`` given at construction)."""
        self._q = self._start.copy()

    def _in_range(self, q) -> np.ndarray:
        """``q`` clamped into the joint limits, continuous joints (no limits) wrapped to (-pi, pi]."""
        q = self.robot.clamp(q)
        q[self._continuous] = wrap_angle(q[self._continuous])
        return q

    def sliders(self) -> list[SliderSpec]:
        """One :class:`SliderSpec` per movable joint, in ``robot.joint_names`` order."""
        specs = []
        for joint, value in zip(self.robot.joints, self._q):
            if joint.type == "continuous":  # (-pi, pi]: the left end is one step above -pi, which would read as +pi
                step = 2.0 * math.pi / 1000
                lower, upper = -math.pi + step, math.pi
            else:
                lower, upper = joint.lower, joint.upper
                step = (upper - lower) / 1000
            specs.append(SliderSpec(joint.name, joint.type, float(lower), float(upper), float(step),
                                    float(value), "rad" if joint.is_angular else "m"))
        return specs

    # Frames -------------------------------------------------------------

    @property
    def frames(self) -> tuple[str, str]:
        """(A, B), as given (aliases such as ``ee_link`` are kept)."""
        return self._frames

    def set_frames(self, a: str, b: str) -> None:
        """Choose A and B. Raises :class:`UnknownFrameError` (with the closest names) for unknown frames."""
        self._frames = self._checked_frames((a, b))

    def frame_choices(self) -> tuple[str, ...]:
        """Every frame the pickers offer: the robot's links, then ``base_link``/``ee_link`` if they are aliases."""
        names = self.robot.frame_names
        return names + tuple(alias for alias in DEFAULT_FRAMES if alias not in names)

    def _checked_frames(self, frames) -> tuple[str, str]:
        frames = tuple(frames)
        if len(frames) != 2 or not all(isinstance(f, str) for f in frames):
            raise ManipkitError(f"frames: give two frame names A and B, got {frames!r}")
        for name in frames:
            self.robot.frame(name)  # UnknownFrameError names the closest frames
        return frames

    # Answers ------------------------------------------------------------

    def readout(self) -> dict:
        """T_A_B as ``tf-between A B --format json`` prints it (same keys, same numbers)."""
        a, b = self._frames
        return pose_report(self.robot, a, b, self._q)

    def frame_placements(self) -> dict[str, np.ndarray]:
        """Scene path -> T_root_frame (4x4) of the triads at A and B."""
        root = self.robot.root_link
        return {path: self.robot.transform(root, frame, self._q) for path, frame in zip(TRIAD_PATHS, self._frames)}

    def geometry_placements(self, visual_model) -> dict[str, np.ndarray]:
        """Scene path -> T_root_geometry (4x4, mesh scale applied to the rotation columns) of each visual.

        ``visual_model`` is the Pinocchio ``GeometryModel`` from :func:`visual_model`.
        The placements are Pinocchio's (``updateGeometryPlacements``; its world
        frame is the robot's root link); only the mesh scale is added here.
        """
        import pinocchio as pin

        geometry_data = visual_model.createData()
        pin.updateGeometryPlacements(self.robot.model, self._data, visual_model, geometry_data,
                                     self.robot.pinocchio_configuration(self._q))
        return {
            f"{VISUALS_ROOT}/{geometry.name}": placement.homogeneous * np.append(geometry.meshScale, 1.0)  # T @ diag(scale, 1)
            for geometry, placement in zip(visual_model.geometryObjects, geometry_data.oMg)
        }

    def scene_placements(self, visual_model=None) -> dict[str, np.ndarray]:
        """Everything the scene draws: the visuals (if a model is given) and the triads at A and B."""
        placements = {} if visual_model is None else self.geometry_placements(visual_model)
        placements.update(self.frame_placements())
        return placements

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper corners (m, root frame) of the box around every frame origin at the current pose.

        Used to aim the camera and size the triads.
        """
        root = self.robot.root_link
        origins = np.array([self.robot.transform(root, f, self._q)[:3, 3] for f in self.robot.frame_names])
        return origins.min(axis=0), origins.max(axis=0)

    def snapshot(self) -> dict:
        """What the control page shows after a change: q, frames, the readout and its two renderings."""
        report = self.readout()
        return {
            "q": report["q"],
            "frames": list(self._frames),
            "readout": report,
            "readout_json": json.dumps(report, indent=2),
            "readout_text": pose_text(report),
        }


# ----------------------------------------------------------------------
# Visual geometry: package:// meshes resolved, then Pinocchio's GeometryModel
# ----------------------------------------------------------------------


def visual_model(robot):
    """The robot's ``<visual>`` geometry as a Pinocchio ``GeometryModel``.

    Mesh files (``package://``, ``file://`` or relative paths) are resolved
    with :class:`manipkit.description.sources.PackageResolver` (``--package-dir`` folders,
    example-robot-data, folders around the description, ``ROS_PACKAGE_PATH``)
    before Pinocchio reads them.

    Raises
    ------
    PackageNotFoundError
        A mesh whose package or file cannot be found; the message names the
        URI, the link and the places searched.
    """
    import pinocchio as pin

    text, package_dirs = _resolved_visual_urdf(robot)
    try:
        return pin.buildGeomFromUrdfString(robot.model, text, pin.GeometryType.VISUAL, package_dirs=package_dirs)
    except (ValueError, RuntimeError) as exc:
        raise DescriptionError(
            f"{robot.name}: Pinocchio cannot load the visual geometry: {' '.join(str(exc).split())}"
        ) from None


def _resolved_visual_urdf(robot) -> tuple[str, list[str]]:
    """URDF text whose visual mesh filenames are absolute paths, and the package folders used."""
    import xml.etree.ElementTree as ET

    from manipkit.description.sources import PackageResolver

    root = ET.fromstring(robot.urdf)
    meshes = [(link.get("name"), mesh) for link in root.iter("link") for mesh in link.findall("visual/geometry/mesh")]
    if not meshes:
        return robot.urdf, []
    near = robot.source.path if robot.source.path.exists() else None
    resolver = PackageResolver(dict(robot.package_dirs), near=near)
    folders: set[str] = set()
    for link, mesh in meshes:
        uri = mesh.get("filename", "")
        path = _mesh_path(resolver, uri, link, robot)
        if uri.startswith("package://"):
            folders.add(str(resolver.find(uri[len("package://"):].partition("/")[0]).parent))
        mesh.set("filename", str(path))
    return ET.tostring(root, encoding="unicode"), sorted(folders)


def _mesh_path(resolver, uri: str, link: str, robot) -> Path:
    where = f"link '{link}': mesh {uri}"
    if uri.startswith("package://"):
        try:
            path = Path(resolver.resolve_uri(uri))
        except PackageNotFoundError as exc:
            raise PackageNotFoundError(f"{where} cannot be resolved: {exc}") from None
        if not path.is_file():
            package = uri[len("package://"):].partition("/")[0]
            raise PackageNotFoundError(
                f"{where} resolves to {path}, which does not exist (package '{package}' is {resolver.find(package)}); "
                f"give the right folder with --package-dir {package}=DIR"
            )
        return path
    if "://" in uri and not uri.startswith("file://"):
        raise PackageNotFoundError(f"{where}: only package://, file:// and file paths are supported")
    path = Path(resolver.resolve_uri(uri)).expanduser()
    searched = [path] if path.is_absolute() else [robot.source.path.parent / path, Path.cwd() / path]
    for candidate in searched:
        if candidate.is_file():
            return candidate.resolve()
    raise PackageNotFoundError(f"{where} not found; looked at {', '.join(map(str, searched))}")


# ----------------------------------------------------------------------
# Scene: meshcat adapter
# ----------------------------------------------------------------------

_AXES = (  # triad axis -> (colour, T_frame_cylinder for a unit cylinder along y), lengths scaled later
    ("x", 0xE41A1C, np.array([[0.0, 1, 0, 0.5], [-1, 0, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])),
    ("y", 0x4DAF4A, np.array([[1.0, 0, 0, 0], [0, 1, 0, 0.5], [0, 0, 1, 0], [0, 0, 0, 1]])),
    ("z", 0x377EB8, np.array([[1.0, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0.5], [0, 0, 0, 1]])),
)
TRIAD_DOTS = (0x222222, 0xE040E0)  # origin dot of A (near black) and B (magenta)


class MeshcatScene:
    """The meshcat side of a view: a meshcat server, the robot's visuals and two triads.

    It computes nothing: :meth:`draw` sends the placements it is given
    (scene path -> 4x4 in the robot's root frame), skipping unchanged ones.

    Parameters
    ----------
    visual : pinocchio.GeometryModel
        From :func:`visual_model`.
    model : pinocchio.Model
        ``robot.model`` (Pinocchio's visualizer wants it).
    bounds : (lower, upper), keyword-only
        Box around the robot (m, root frame; :meth:`ViewerState.bounds`): the
        camera orbits its centre and the triads are sized from it.
    """

    def __init__(self, visual, model, *, bounds=((0.0, 0.0, 0.0), (1.0, 1.0, 1.0))):
        with warnings.catch_warnings():  # meshcat 0.3 imports a deprecated pyzmq module
            warnings.simplefilter("ignore", DeprecationWarning)
            import meshcat
            import meshcat.geometry as mg
            from pinocchio.visualize import MeshcatVisualizer

        self._proc, zmq_url, self.url = _start_meshcat_server()
        self._closed = False
        atexit.register(self.close)
        try:
            with contextlib.redirect_stdout(io.StringIO()):  # meshcat prints its URL; the caller decides
                self.viewer = meshcat.Visualizer(zmq_url=zmq_url)
            self.visualizer = MeshcatVisualizer(model, visual_model=visual)
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
            # meshcat's camera orbits the origin: shift the robot, the grid and the axes so that the
            # robot's centre sits there (the scene keeps its own geometry: the shift is one transform).
            shift = np.eye(4)
            shift[:3, 3] = -(lower + upper) / 2
            for root in ("/meshcat", "/Grid", "/Axes"):
                self.viewer[root].set_transform(shift)
            # The camera node is y-up: its position is (x, z, -y) in the robot's frame.
            distance = 1.1 * size
            self.viewer["/Cameras/default/rotated/<object>"].set_property(
                "position", [1.0 * distance, 0.6 * distance, 0.8 * distance])
        except BaseException:
            self.close()
            raise
        self._sent: dict[str, np.ndarray] = {}

    def draw(self, placements: dict[str, np.ndarray]) -> None:
        """Place scene nodes (path -> 4x4); nodes whose placement did not change are not re-sent."""
        if self._closed or self._proc.poll() is not None:
            raise ManipkitError("the meshcat server has stopped; restart the viewer")
        for path, T in placements.items():
            previous = self._sent.get(path)
            if previous is None or not np.array_equal(previous, T):
                self.viewer[path].set_transform(T)
                self._sent[path] = np.array(T, copy=True)

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

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def _start_meshcat_server(timeout: float = 30.0):
    """Start ``python -m meshcat.servers.zmqserver``; returns (process, zmq_url, web_url).

    Started here rather than by ``meshcat.Visualizer()`` so that its output is
    drained (a long session cannot fill a pipe) and the viewer owns its
    lifetime; it runs in its own session so a notebook interrupt leaves it be.
    """
    proc = subprocess.Popen(
        [sys.executable, "-u", "-m", "meshcat.servers.zmqserver"],
        stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
        text=True, start_new_session=True,
    )
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
                raise ManipkitError(f"the meshcat server exited at start-up (status {proc.wait()})")
            key, _, value = line.strip().partition("=")
            if key in ("zmq_url", "web_url"):
                urls[key] = value
    except queue.Empty:
        proc.kill()
        raise ManipkitError(f"the meshcat server did not start within {timeout:g} s") from None
    except BaseException:
        proc.kill()
        raise
    return proc, urls["zmq_url"], urls["web_url"]


# ----------------------------------------------------------------------
# Control page: HTTP server -> state -> scene
# ----------------------------------------------------------------------


def _page_template() -> str:
    from importlib import resources

    return resources.files("manipkit.app").joinpath("viewer_page.html").read_text(encoding="utf-8")


class _HTTPServer(ThreadingHTTPServer):
    daemon_threads = True
    app: "ViewerServer"


class _Handler(BaseHTTPRequestHandler):
    protocol_version = "HTTP/1.1"  # keep-alive: one connection for a whole drag
    disable_nagle_algorithm = True
    timeout = 60
    server: _HTTPServer

    def do_GET(self):
        path = self.path.split("?")[0]
        if path in ("/", "/index.html"):
            self._send(200, self.server.app.page().encode(), "text/html; charset=utf-8")
        elif path == "/api/state":
            self._send_json(200, self.server.app.initial())
        elif path == "/favicon.ico":
            self._send(204, b"", "image/x-icon")
        else:
            self._send_json(404, {"error": f"no page {path}; the control page is /"})

    def do_POST(self):
        if self.path.split("?")[0] != "/api/update":
            self._send_json(404, {"error": f"no endpoint {self.path}"})
            return
        try:
            length = int(self.headers.get("Content-Length") or 0)
            body = json.loads(self.rfile.read(length) or b"{}")
            if not isinstance(body, dict):
                raise ValueError("expected a JSON object")
        except ValueError as exc:
            self._send_json(400, {"error": f"bad request body: {exc}"})
            return
        status, answer = self.server.app.update(body)
        self._send_json(status, answer)

    def _send_json(self, status: int, payload: dict):
        self._send(status, json.dumps(payload).encode(), "application/json")

    def _send(self, status: int, body: bytes, content_type: str):
        self.send_response(status)
        self.send_header("Content-Type", content_type)
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Cache-Control", "no-store")
        self.end_headers()
        self.wfile.write(body)

    def log_message(self, format, *args):  # quiet: the terminal shows the URLs, not every request
        pass


_STOP: dict = {}  # tells the drawing thread to end


class ViewerServer:
    """The control page's HTTP server, wired to a :class:`ViewerState` and a :class:`MeshcatScene`.

    Routes: ``GET /`` (the page), ``GET /api/state`` (sliders, frames, readout),
    ``POST /api/update`` with ``{"reset": true, "q": {name: value}, "frames": [A, B]}``
    (any subset, applied in that order) -> the new q, frames and readout. A
    user error answers 400 with ``{"error": message}`` and the unchanged state.

    The port is bound when the server is created (so a busy port fails before
    anything else starts); :meth:`start` serves it from a thread.
    """

    def __init__(self, port: int = DEFAULT_PORT, *, host: str = "127.0.0.1"):
        if not 0 <= int(port) <= 65535:
            raise ManipkitError(f"port {port}: give a port from 1 to 65535 (0 = any free port)")
        try:
            self._httpd = _HTTPServer((host, int(port)), _Handler)
        except OSError as exc:
            if exc.errno == errno.EADDRINUSE:
                raise ManipkitError(
                    f"port {port} is in use; choose another with --port P (or stop the program using it)"
                ) from None
            raise ManipkitError(f"cannot serve on {host}:{port}: {exc.strerror or exc}") from None
        self._httpd.app = self
        self.host, self.port = host, self._httpd.server_address[1]
        self.url = f"http://{host}:{self.port}/"
        self.state: ViewerState | None = None
        self.scene: MeshcatScene | None = None
        self.visual = None
        self._lock = threading.Lock()  # guards the state (and the robot's Pinocchio data)
        self._thread: threading.Thread | None = None
        # The scene is drawn by one thread (meshcat's zmq socket is not thread-safe), latest placements first:
        self._scene_wake = threading.Condition()
        self._scene_todo: dict | None = None  # placements not drawn yet
        self._scene_busy = False
        self._scene_error: str | None = None
        self._scene_thread: threading.Thread | None = None

    def attach(self, state: ViewerState, scene: MeshcatScene, visual) -> "ViewerServer":
        """Connect the state and the scene, and draw the start pose."""
        self.state, self.scene, self.visual = state, scene, visual
        scene.draw(state.scene_placements(visual))
        return self

    def _draw_later(self, placements: dict) -> None:
        with self._scene_wake:
            self._scene_todo = placements  # a newer pose replaces one not drawn yet
            self._scene_wake.notify()

    def _draw_loop(self) -> None:
        while True:
            with self._scene_wake:
                while self._scene_todo is None:
                    self._scene_wake.wait()
                placements, self._scene_todo = self._scene_todo, None
                if placements is _STOP:
                    return
                self._scene_busy = True
            try:
                self.scene.draw(placements)
            except ManipkitError as exc:
                self._scene_error = str(exc)
            finally:
                with self._scene_wake:
                    self._scene_busy = False
                    self._scene_wake.notify_all()

    def wait_for_scene(self, timeout: float = 10.0) -> bool:
        """Block until the scene shows the latest change (True) or ``timeout`` s pass (False)."""
        with self._scene_wake:
            return self._scene_wake.wait_for(lambda: self._scene_todo is None and not self._scene_busy, timeout)

    @property
    def scene_url(self) -> str:
        return self.scene.url

    def start(self) -> "ViewerServer":
        """Serve in a daemon thread; returns at once."""
        self._scene_thread = threading.Thread(target=self._draw_loop, name="manipkit-viewer-scene", daemon=True)
        self._scene_thread.start()
        self._thread = threading.Thread(target=self._httpd.serve_forever, name="manipkit-viewer", daemon=True)
        self._thread.start()
        return self

    def wait(self) -> None:
        """Block until :meth:`close` (Ctrl-C interrupts the wait)."""
        while self._thread is not None and self._thread.is_alive():
            self._thread.join(0.25)

    def close(self) -> None:
        """Stop the HTTP server and the meshcat server (idempotent)."""
        if self._thread is not None and self._thread.is_alive():
            self._httpd.shutdown()
        self._httpd.server_close()
        if self._scene_thread is not None and self._scene_thread.is_alive():
            self._draw_later(_STOP)
            self._scene_thread.join(timeout=10)
        if self.scene is not None:
            self.scene.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    # Request handling (called from the HTTP threads) ---------------------

    def initial(self) -> dict:
        with self._lock:
            state = self.state
            return {
                "robot": state.robot.name,
                "sliders": [asdict(spec) for spec in state.sliders()],
                "frame_choices": list(state.frame_choices()),
                "scene_url": self.scene_url,
                **state.snapshot(),
            }

    def page(self) -> str:
        data = json.dumps(self.initial()).replace("</", "<\\/")  # safe inside <script>
        return _page_template().replace("{{STATE_JSON}}", data)

    def update(self, body: dict) -> tuple[int, dict]:
        """Apply a change from the page; (HTTP status, answer).

        The answer (the readout) does not wait for the scene: the new
        placements go to the drawing thread, which sends them to meshcat
        right after (see :meth:`wait_for_scene`).
        """
        if self._scene_error is not None:
            return 500, {"error": self._scene_error}
        with self._lock:
            state = self.state
            try:
                values, frames = body.get("q") or {}, body.get("frames")
                if not isinstance(values, dict):
                    raise JointValueError("q: expected {joint name: value}")
                if body.get("reset"):
                    state.reset()
                state.set_joints(values)
                if frames is not None:
                    if not isinstance(frames, list) or len(frames) != 2:
                        raise ManipkitError(f"frames: expected [A, B], got {frames!r}")
                    state.set_frames(*frames)
                self._draw_later(state.scene_placements(self.visual))
            except ManipkitError as exc:
                return 400, {"error": str(exc), **state.snapshot()}
            return 200, state.snapshot()


def open_view(robot, *, frames: tuple[str, str] = DEFAULT_FRAMES, q=None, port: int = DEFAULT_PORT,
              host: str = "127.0.0.1") -> ViewerServer:
    """Start a view: control page on ``port``, meshcat on its own ports (7000 upwards).

    Returns the running :class:`ViewerServer` (``.url``: control page,
    ``.scene_url``: meshcat, ``.scene.warnings``: geometry not shown,
    ``.wait()``, ``.close()``).

    Raises
    ------
    ManipkitError
        Unknown frames or joint values, then ``port P is in use; ...`` (both
        before anything starts), meshes not found.
    """
    state = ViewerState(robot, frames=frames, q=q)
    server = ViewerServer(port, host=host)
    scene = None
    try:
        visual = visual_model(robot)
        scene = MeshcatScene(visual, robot.model, bounds=state.bounds())
        server.attach(state, scene, visual)
        return server.start()
    except BaseException:
        server.close()
        if scene is not None:
            scene.close()
        raise


def write_static(robot, path, *, frames: tuple[str, str] = DEFAULT_FRAMES, q=None) -> Path:
    """Write a standalone HTML snapshot of the pose (robot and triads at A and B); returns the path.

    The file is meshcat's static export: it opens in a browser without a server.
    """
    path = Path(path)
    state = ViewerState(robot, frames=frames, q=q)
    visual = visual_model(robot)
    with MeshcatScene(visual, robot.model, bounds=state.bounds()) as scene:
        scene.draw(state.scene_placements(visual))
        html = scene.static_html()
    try:
        path.write_text(html, encoding="utf-8")
    except OSError as exc:
        raise ManipkitError(f"cannot write {path}: {exc.strerror or exc}") from None
    return path


# ----------------------------------------------------------------------
# Jupyter: the same state and scene, with ipywidgets sliders
# ----------------------------------------------------------------------


class NotebookView:
    """A view inside a notebook: ipywidgets sliders, frame pickers, a readout and the meshcat scene.

    Build it with :func:`notebook_view`; display it as the last expression of
    a cell. ``sliders`` (joint name -> FloatSlider), ``frame_a``/``frame_b``
    (Dropdown), ``reset_button``, ``readout`` (HTML) and ``widget`` are the
    ipywidgets; ``state`` and ``scene`` are the shared layers.
    """

    def __init__(self, state: ViewerState, scene: MeshcatScene, visual, *, height: int = 420):
        import ipywidgets as w

        self.state, self.scene, self.visual = state, scene, visual
        self._syncing = False
        self.sliders = {
            spec.name: w.FloatSlider(
                value=spec.value, min=spec.lower, max=spec.upper, step=spec.step, description=spec.name,
                continuous_update=True, readout_format=".4f", style={"description_width": "initial"},
                layout=w.Layout(width="100%"),
            )
            for spec in state.sliders()
        }
        choices = list(state.frame_choices())
        self.frame_a = w.Dropdown(options=choices, value=state.frames[0], description="A")
        self.frame_b = w.Dropdown(options=choices, value=state.frames[1], description="B")
        self.reset_button = w.Button(description="reset")
        self.readout = w.HTML()
        self.error = w.HTML()
        self.scene_widget = w.HTML(
            f'<iframe src="{scene.url}" style="width:100%;height:{height}px;border:0"></iframe>',
            layout=w.Layout(width="60%"),
        )
        for name, slider in self.sliders.items():
            slider.observe(lambda change, name=name: self._on_joint(name, change["new"]), names="value")
        self.frame_a.observe(lambda change: self._on_frames(), names="value")
        self.frame_b.observe(lambda change: self._on_frames(), names="value")
        self.reset_button.on_click(lambda button: self._on_reset())
        controls = w.VBox([*self.sliders.values(), w.HBox([self.frame_a, self.frame_b]), self.reset_button,
                           self.error, self.readout], layout=w.Layout(width="40%"))
        self.widget = w.HBox([controls, self.scene_widget])
        self._refresh()

    def _on_joint(self, name: str, value: float) -> None:
        if not self._syncing:
            self.state.set_joint(name, value)
            self._refresh()

    def _on_frames(self) -> None:
        if not self._syncing:
            try:
                self.state.set_frames(self.frame_a.value, self.frame_b.value)
            except ManipkitError as exc:
                self.error.value = f"<span style='color:#b00'>{exc}</span>"
                return
            self._refresh()

    def _on_reset(self) -> None:
        self.state.reset()
        self._refresh()

    def _refresh(self) -> None:
        """Draw the scene and show the readout; put the sliders where the state says."""
        import html

        self.scene.draw(self.state.scene_placements(self.visual))
        self._syncing = True
        try:
            for spec in self.state.sliders():
                self.sliders[spec.name].value = spec.value
        finally:
            self._syncing = False
        snapshot = self.state.snapshot()
        self.error.value = ""
        self.readout.value = f"<pre>{html.escape(snapshot['readout_text'])}</pre>"

    def close(self) -> None:
        """Stop the meshcat server."""
        self.scene.close()

    def _ipython_display_(self):
        from IPython.display import display

        display(self.widget)


def notebook_view(robot, frames: tuple[str, str] = DEFAULT_FRAMES, q=None) -> NotebookView:
    """The viewer inline in Jupyter: meshcat scene plus ipywidgets sliders and a live T_A_B readout.

    Raises
    ------
    ManipkitError
        If ipywidgets is not installed (``pip install ipywidgets``).
    """
    try:
        import ipywidgets  # noqa: F401
    except ImportError:
        raise ManipkitError("the notebook viewer needs ipywidgets: pip install ipywidgets") from None
    state = ViewerState(robot, frames=frames, q=q)
    visual = visual_model(robot)
    scene = MeshcatScene(visual, robot.model, bounds=state.bounds())
    try:
        return NotebookView(state, scene, visual)
    except BaseException:
        scene.close()
        raise
