"""The control page of a view: an HTTP server (standard library, in a thread) wired to a state and a scene.

The page (``page.html``, next to this module) posts slider moves; the
server updates the :class:`ViewerState`, answers with the readout and hands
the new placements to one drawing thread for the :class:`MeshcatScene`.
:func:`open_view` starts it all; :func:`write_static` saves meshcat's
standalone page of one pose instead. Conventions: docs/architecture.md.
"""

from __future__ import annotations

import errno
import json
import threading
from dataclasses import asdict
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import TYPE_CHECKING

from manipkit.app.viewer.scene import MeshcatScene, visual_model
from manipkit.app.viewer.state import DEFAULT_FRAMES, NO_OVERLAY, Overlay, ViewerState
from manipkit.errors import JointValueError, ManipkitError, OptionError, ViewerError
from manipkit.outputs import writable_path, write_text

if TYPE_CHECKING:
    from manipkit.kinematics.robot import Robot

__all__ = ["DEFAULT_PORT", "ViewerServer", "open_view", "page_html", "write_static"]

DEFAULT_PORT = 8700


def _page_template() -> str:
    from importlib import resources

    return resources.files("manipkit.app.viewer").joinpath("page.html").read_text(encoding="utf-8")


class _HTTPServer(ThreadingHTTPServer):
    daemon_threads = True
    app: ViewerServer


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
    ``POST /api/update`` with ``{"reset": true, "q": {name: value}, "frames": [A, B],
    "overlay": {"shown": bool, "kind": "velocity"|"force", "axes": "trans"|"rot"}}``
    (any subset, applied in that order) -> the new q, frames, readout and
    ellipsoid readout (:meth:`ViewerState.snapshot`). A user error answers 400
    with ``{"error": message}`` and the state as it is (a change that failed
    its checks is not applied).

    The port is bound when the server is created (so a busy port fails before
    anything else starts); :meth:`start` serves it from a thread.
    """

    def __init__(self, port: int = DEFAULT_PORT, *, host: str = "127.0.0.1"):
        if not 0 <= int(port) <= 65535:
            raise ViewerError(f"port {port}: give a port from 1 to 65535 (0 = any free port)")
        try:
            self._httpd = _HTTPServer((host, int(port)), _Handler)
        except OSError as exc:
            if exc.errno == errno.EADDRINUSE:
                raise ViewerError(
                    f"port {port} is in use; choose another with --port P (or stop the program using it)"
                ) from None
            raise ViewerError(f"cannot serve on {host}:{port}: {exc.strerror or exc}") from None
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

    def attach(self, state: ViewerState, scene: MeshcatScene, visual) -> ViewerServer:
        """Connect the state and the scene, and draw the start pose."""
        self.state, self.scene, self.visual = state, scene, visual
        scene.draw(state.scene_placements(visual), state.scene_visibility())
        return self

    def _draw_later(self, placements, visible: dict | None = None) -> None:
        with self._scene_wake:
            self._scene_todo = (placements, visible)  # a newer pose replaces one not drawn yet
            self._scene_wake.notify()

    def _draw_loop(self) -> None:
        while True:
            with self._scene_wake:
                while self._scene_todo is None:
                    self._scene_wake.wait()
                (placements, visible), self._scene_todo = self._scene_todo, None
                if placements is _STOP:
                    return
                self._scene_busy = True
            try:
                self.scene.draw(placements, visible)
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

    def start(self) -> ViewerServer:
        """Serve in a daemon thread; returns at once."""
        self._scene_thread = threading.Thread(target=self._draw_loop, name="manipkit-viewer-scene", daemon=True)
        self._scene_thread.start()
        self._thread = threading.Thread(target=self._httpd.serve_forever, name="manipkit-viewer", daemon=True)
        self._thread.start()
        return self

    def wait(self, stop: threading.Event | None = None) -> None:
        """Block until :meth:`close`, or until ``stop`` is set (the command line sets it on Ctrl-C or SIGTERM)."""
        stop = stop or threading.Event()
        while self._thread is not None and self._thread.is_alive() and not stop.wait(0.25):
            pass

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
        """The control page with the initial state (:func:`page_html`)."""
        return page_html(self.initial())

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
                        raise OptionError(f"frames: expected [A, B], got {frames!r}")
                    state.set_frames(*frames)
                overlay = body.get("overlay")
                if overlay is not None:
                    if not isinstance(overlay, dict) or not set(overlay) <= {"shown", "kind", "axes"}:
                        raise OptionError(f"overlay: expected {{shown, kind, axes}} (any of them), got {overlay!r:.80}")
                    state.set_overlay(**overlay)
                self._draw_later(state.scene_placements(self.visual), state.scene_visibility())
            except ManipkitError as exc:
                return 400, {"error": str(exc), **state.snapshot()}
            return 200, state.snapshot()


def page_html(initial: dict) -> str:
    """The control page (``page.html``) with ``initial`` as its JSON state block.

    Robot, link and joint names are user text: the JSON goes into a
    ``<script type="application/json">`` block with ``<``, ``>`` and ``&``
    written as ``\\u003c``, ``\\u003e``, ``\\u0026`` (as Django's
    ``json_script`` does), so no name can end the block (``</script>``) or
    change how the HTML parser reads it (``<!--``); ``JSON.parse`` gives the
    names back unchanged and the page shows them with ``textContent``, as text.
    """
    data = json.dumps(initial)
    for char, escape in (("&", "\\u0026"), ("<", "\\u003c"), (">", "\\u003e")):
        data = data.replace(char, escape)
    return _page_template().replace("{{STATE_JSON}}", data)


def open_view(robot: Robot, *, frames: tuple[str, str] = DEFAULT_FRAMES, q=None, port: int = DEFAULT_PORT,
              host: str = "127.0.0.1", overlay: Overlay = NO_OVERLAY) -> ViewerServer:
    """Start a view: control page on ``port``, meshcat on its own ports (7000 upwards).

    ``overlay``: the manipulability ellipsoid's start settings (:class:`Overlay`; default off).

    Returns the running :class:`ViewerServer` (``.url``: control page,
    ``.scene_url``: meshcat, ``.scene.warnings``: geometry not shown,
    ``.wait()``, ``.close()``).

    Raises
    ------
    ManipkitError
        Unknown frames or joint values, then ``port P is in use; ...`` (both
        before anything starts), meshes not found.
    """
    state = ViewerState(robot, frames=frames, q=q, overlay=overlay)
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


def write_static(robot: Robot, path, *, frames: tuple[str, str] = DEFAULT_FRAMES, q=None,
                 overlay: Overlay = NO_OVERLAY) -> Path:
    """Write a standalone HTML snapshot of the pose (robot, triads at A and B, the ellipsoid if shown); returns the path.

    The file is meshcat's static export: it opens in a browser without a server.
    Names reach it only inside meshcat's base64-encoded drawing commands, never as markup.

    Raises
    ------
    OutputError
        ``cannot write PATH: reason`` (checked before meshcat starts; no folder is created).
    """
    path = writable_path(path)
    state = ViewerState(robot, frames=frames, q=q, overlay=overlay)
    visual = visual_model(robot)
    with MeshcatScene(visual, robot.model, bounds=state.bounds()) as scene:
        scene.draw(state.scene_placements(visual), state.scene_visibility())
        html = scene.static_html()
    return write_text(path, html)
