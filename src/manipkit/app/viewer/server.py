"""The control page of a view: an HTTP server (standard library, in a thread) wired to a state and a scene.

The page (``page.html``, next to this module) posts slider moves; the
server updates the :class:`ViewerState`, answers with the readout and hands
the new placements to one drawing thread for the :class:`MeshcatScene`.
:func:`open_view` starts it all; :func:`write_static` saves meshcat's
standalone page of one pose instead. Conventions: docs/architecture.md.

The server serves its own page and nothing else (docs/architecture.md,
"The viewer's HTTP server"): it answers only the ``Host`` it was started
with, refuses requests from another origin, takes writes and state reads
only with the session's token (embedded in the page) and a JSON body of at
most ``MAX_BODY_BYTES`` nested at most ``MAX_JSON_DEPTH`` deep, and answers
every refusal with a one-line JSON error, never a traceback.
"""

from __future__ import annotations

import errno
import json
import re
import secrets
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
    from manipkit.app.viewer.collision_state import CollisionView
    from manipkit.kinematics.robot import Robot

__all__ = [
    "DEFAULT_PORT", "MAX_BODY_BYTES", "MAX_JSON_DEPTH", "TOKEN_HEADER", "ViewerServer", "open_view", "page_html",
    "write_static",
]

DEFAULT_PORT = 8700
#: Largest request body (bytes) the server reads, checked from Content-Length before reading; the page sends < 1 kB.
MAX_BODY_BYTES = 64 * 1024
#: Deepest nesting of JSON arrays and objects in a request body (the page's own requests nest 2 deep).
MAX_JSON_DEPTH = 20
#: The header that carries the session's token (:attr:`ViewerServer.token`) on writes and state reads.
TOKEN_HEADER = "X-Manipkit-Token"
# Sent with every answer: the control page is never framed by another page, and nothing is sniffed.
_SECURITY_HEADERS = (("X-Content-Type-Options", "nosniff"), ("X-Frame-Options", "DENY"),
                     ("Content-Security-Policy", "frame-ancestors 'none'"))


def _page_template() -> str:
    from importlib import resources

    return resources.files("manipkit.app.viewer").joinpath("page.html").read_text(encoding="utf-8")


class _HTTPServer(ThreadingHTTPServer):
    daemon_threads = True
    app: ViewerServer

    def handle_error(self, request, client_address):
        """A connection that broke while answering (the handler answers every request itself): nothing to print."""


class _Refused(Exception):
    """A request the server does not serve: its HTTP status and a one-line reason (answered as JSON)."""

    def __init__(self, status: int, message: str):
        super().__init__(message)
        self.status = status


class _Handler(BaseHTTPRequestHandler):
    protocol_version = "HTTP/1.1"  # keep-alive: one connection for a whole drag
    disable_nagle_algorithm = True
    server: _HTTPServer

    def setup(self):
        self.timeout = self.server.app.read_timeout  # a silent connection (or a body that never comes) ends
        super().setup()

    def do_GET(self):
        self._answer(self._get)

    def do_POST(self):
        self._answer(self._post)

    def _answer(self, route) -> None:
        """Check where the request comes from, route it, and answer; a refusal or a bug is one JSON line, never a traceback."""
        try:
            self._check_host_and_origin()
            status, payload = route()
        except _Refused as exc:  # the body may be unread: answer, then close the connection
            self._send_json(exc.status, {"error": str(exc)}, close=True)
            return
        except Exception as exc:  # a bug in the viewer: answer it, keep the user's terminal clean
            self._send_json(500, {"error": f"internal error in the viewer ({type(exc).__name__}); this is a bug in "
                                           "manipkit, please report it"}, close=True)
            return
        if isinstance(payload, bytes):
            self._send(status, payload, "text/html; charset=utf-8")
        else:
            self._send_json(status, payload)

    def _get(self) -> tuple[int, dict | bytes]:
        path = self.path.split("?")[0]
        if path in ("/", "/index.html"):
            return 200, self.server.app.page().encode()
        if path == "/api/state":
            self._check_token()
            return 200, self.server.app.initial()
        if path == "/favicon.ico":
            return 204, b""
        raise _Refused(404, f"no page {_quoted(path)}; the control page is /")

    def _post(self) -> tuple[int, dict]:
        path = self.path.split("?")[0]
        if path != "/api/update":
            raise _Refused(404, f"no endpoint {_quoted(path)}; the page posts to /api/update")
        self._check_token()
        return self.server.app.update(self._json_body())

    def _check_host_and_origin(self) -> None:
        """The Host the server was started with (no other name: DNS rebinding), and no Origin but its own."""
        app = self.server.app
        hosts = self.headers.get_all("Host") or []
        if len(hosts) != 1 or hosts[0].strip().lower() not in app.hosts:
            shown = _quoted(hosts[0]) if len(hosts) == 1 else f"{len(hosts)} Host headers"
            raise _Refused(403, f"host {shown} is not this viewer's; open {app.url}")
        origins = self.headers.get_all("Origin")
        if origins is not None and (len(origins) != 1 or origins[0].strip().lower() not in app.origins):
            raise _Refused(403, f"a request from origin {_quoted(', '.join(origins))} is refused; only the control "
                                f"page {app.url} may use this viewer")

    def _check_token(self) -> None:
        given = (self.headers.get(TOKEN_HEADER) or "").strip().encode("latin-1", "replace")
        if not given:
            raise _Refused(403, f"no {TOKEN_HEADER} header; only the control page {self.server.app.url} may use this viewer")
        if not secrets.compare_digest(given, self.server.app.token.encode()):
            raise _Refused(403, f"wrong {TOKEN_HEADER}; reload the control page {self.server.app.url}")

    def _json_body(self) -> dict:
        """The request body as a JSON object: ``application/json``, a Content-Length checked before reading, bounded depth."""
        content_type = self.headers.get_content_type()  # text/plain when missing or malformed
        if content_type != "application/json":
            raise _Refused(415, f"Content-Type {_quoted(content_type)}: send application/json")
        if self.headers.get("Transfer-Encoding"):
            raise _Refused(411, "a chunked body is not read: send the body with a Content-Length")
        lengths = self.headers.get_all("Content-Length") or []
        if not lengths:
            raise _Refused(411, f"no Content-Length: give the body's size in bytes (at most {MAX_BODY_BYTES})")
        if len(lengths) != 1 or not re.fullmatch(r"[0-9]{1,20}", lengths[0].strip()):
            raise _Refused(400, f"Content-Length {_quoted(', '.join(lengths))}: give one number of bytes "
                                f"from 0 to {MAX_BODY_BYTES}")
        length = int(lengths[0])
        if length > MAX_BODY_BYTES:
            raise _Refused(413, f"a body of {length} bytes is more than this viewer reads ({MAX_BODY_BYTES})")
        try:
            raw = self.rfile.read(length)
        except TimeoutError:
            raise _Refused(408, f"the body's {length} bytes did not arrive within {self.server.app.read_timeout:g} s") from None
        if len(raw) != length:
            raise _Refused(400, f"the body ended after {len(raw)} of its {length} bytes")
        return _json_object(raw)

    def send_error(self, code, message=None, explain=None):
        """The standard library's own refusals (a malformed request line, headers too long, an unknown method), as JSON."""
        reason = message or self.responses.get(code, ("",))[0]
        self._send_json(code, {"error": f"{code} {reason}"}, close=True)

    def _send_json(self, status: int, payload: dict, *, close: bool = False):
        self._send(status, json.dumps(payload).encode(), "application/json", close=close)

    def _send(self, status: int, body: bytes, content_type: str, *, close: bool = False):
        self.send_response(status)
        self.send_header("Content-Type", content_type)
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Cache-Control", "no-store")
        for name, value in _SECURITY_HEADERS:
            self.send_header(name, value)
        if close:
            self.send_header("Connection", "close")
            self.close_connection = True
        self.end_headers()
        if getattr(self, "command", None) != "HEAD" and status >= 200 and status not in (204, 304):
            self.wfile.write(body)

    def log_message(self, format, *args):  # quiet: the terminal shows the URLs, not every request (nor a bad one)
        pass


def _quoted(text: str, limit: int = 80) -> str:
    """``text`` quoted for a one-line message, cut at ``limit`` characters (JSON escapes the rest)."""
    return repr(text[:limit] + ("..." if len(text) > limit else ""))


def _json_object(raw: bytes, *, max_depth: int = MAX_JSON_DEPTH) -> dict:
    """A request body parsed as one JSON object, its nesting checked (without recursion) before it is parsed.

    Raises the viewer's refusal (HTTP 400) for a body that is not UTF-8, nests
    deeper than ``max_depth``, is not JSON, holds NaN or Infinity, or is not an object.
    """
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise _Refused(400, f"the body is not UTF-8 (byte {exc.start}): send a JSON object") from None
    if _json_depth(text, max_depth) > max_depth:
        raise _Refused(400, f"the body nests arrays and objects more than {max_depth} deep: send a JSON object "
                            f"nested at most {max_depth} deep")

    def no_constant(name):
        raise ValueError(f"{name} is not a number JSON allows")

    try:
        body = json.loads(text, parse_constant=no_constant)
    except ValueError as exc:  # JSONDecodeError, NaN/Infinity, an integer of more digits than Python converts
        raise _Refused(400, f"the body is not JSON: {' '.join(str(exc).split())[:120]}") from None
    if not isinstance(body, dict):
        kind = {list: "array", str: "string", bool: "boolean", type(None): "null"}.get(type(body), "number")
        raise _Refused(400, f"the body is a JSON {kind}: send a JSON object")
    return body


_JSON_STRUCTURE = re.compile(r'[\[\]{}"\\]')


def _json_depth(text: str, limit: int) -> int:
    """How deep arrays and objects nest in the JSON ``text`` (brackets inside strings skipped), stopping past ``limit``.

    One pass over the structural characters, no recursion, so any depth is measured in linear time.
    """
    depth = deepest = 0
    in_string, escaped_at = False, -1
    for match in _JSON_STRUCTURE.finditer(text):
        char, at = match.group(), match.start()
        if in_string:
            if at == escaped_at:  # the character after a backslash
                continue
            if char == "\\":
                escaped_at = at + 1
            elif char == '"':
                in_string = False
        elif char == '"':
            in_string = True
        elif char in "[{":
            depth += 1
            deepest = max(deepest, depth)
            if depth > limit:
                break
        elif char in "]}":
            depth -= 1
    return deepest


_STOP: dict = {}  # tells the drawing thread to end


class ViewerServer:
    """The control page's HTTP server, wired to a :class:`ViewerState` and a :class:`MeshcatScene`.

    Routes: ``GET /`` (the page), ``GET /api/state`` (sliders, frames, readout),
    ``POST /api/update`` with ``{"reset": true, "q": {name: value}, "frames": [A, B],
    "overlay": {"shown": bool, "kind": "velocity"|"force", "axes": "trans"|"rot"}}``
    (any subset, applied in that order) -> the new q, frames, readout,
    ellipsoid readout and collisions (:meth:`ViewerState.snapshot`); the links in
    collision are tinted in the scene. A user error answers 400
    with ``{"error": message}`` and the state as it is (a change that failed
    its checks is not applied).

    Only the control page may use it: every request must name one of
    :attr:`hosts` as its ``Host`` (the address given, 127.0.0.1, localhost or
    [::1], with the port) and, if it has an ``Origin``, come from one of
    :attr:`origins`; ``/api/update`` and ``/api/state`` need the session's
    :attr:`token` (a fresh ``secrets.token_urlsafe``, written into the page)
    in the ``X-Manipkit-Token`` header, and ``/api/update`` an
    ``application/json`` body of at most ``MAX_BODY_BYTES`` with a
    Content-Length, nested at most ``MAX_JSON_DEPTH`` deep. Anything else is
    refused (403, 404, 408, 411, 413, 415 or 400) with ``{"error": message}``.

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
        name = f"[{host}]" if ":" in host else host  # an IPv6 address, as a Host header writes it
        self.url = f"http://{name}:{self.port}/"
        #: The Host headers this server answers (lowercase); any other name is refused, so a page whose
        #: name was rebound to 127.0.0.1 (DNS rebinding) cannot read or drive the view.
        names = {name.lower(), "127.0.0.1", "localhost", "[::1]"}
        self.hosts = frozenset({f"{n}:{self.port}" for n in names} | (names if self.port == 80 else set()))
        #: The Origin headers this server accepts: its own page's, under any of :attr:`hosts`.
        self.origins = frozenset(f"http://{h}" for h in self.hosts)
        #: The session's secret: written into the control page, required on writes and state reads.
        self.token = secrets.token_urlsafe(32)
        #: Seconds a connection may stay silent (between requests, or within one) before it is closed.
        self.read_timeout = 60.0
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
        scene.draw(state.scene_placements(visual), state.scene_visibility(), state.collision_tints(visual))
        return self

    def _draw_later(self, placements, visible: dict | None = None, tinted: dict | None = None) -> None:
        with self._scene_wake:
            self._scene_todo = (placements, visible, tinted)  # a newer pose replaces one not drawn yet
            self._scene_wake.notify()

    def _draw_loop(self) -> None:
        while True:
            with self._scene_wake:
                while self._scene_todo is None:
                    self._scene_wake.wait()
                (placements, visible, tinted), self._scene_todo = self._scene_todo, None
                if placements is _STOP:
                    return
                self._scene_busy = True
            try:
                self.scene.draw(placements, visible, tinted)
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
        """The control page with the initial state and the session's token (:func:`page_html`)."""
        return page_html(self.initial(), token=self.token)

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
                unknown = sorted(set(body) - {"reset", "q", "frames", "overlay"})
                if unknown:
                    raise OptionError(f"unknown key {unknown[0]!r:.80} in the update: give any of reset, q, frames, overlay")
                values, frames = body.get("q") or {}, body.get("frames")
                if not isinstance(values, dict):
                    raise JointValueError("q: expected {joint name: value}")
                if body.get("reset"):
                    state.reset()
                state.set_joints(values)
                if frames is not None:
                    if not isinstance(frames, list) or len(frames) != 2:
                        raise OptionError(f"frames: expected [A, B], got {frames!r:.80}")
                    state.set_frames(*frames)
                overlay = body.get("overlay")
                if overlay is not None:
                    if not isinstance(overlay, dict) or not set(overlay) <= {"shown", "kind", "axes"}:
                        raise OptionError(f"overlay: expected {{shown, kind, axes}} (any of them), got {overlay!r:.80}")
                    state.set_overlay(**overlay)
                self._draw_later(state.scene_placements(self.visual), state.scene_visibility(),
                                 state.collision_tints(self.visual))
            except ManipkitError as exc:
                return 400, {"error": str(exc), **state.snapshot()}
            return 200, state.snapshot()


def page_html(initial: dict, *, token: str = "") -> str:
    """The control page (``page.html``) with ``initial`` as its JSON state block and ``token`` in its meta tag.

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
    if not re.fullmatch(r"[A-Za-z0-9_-]*", token):
        raise ViewerError(f"token {token!r:.40}: give letters, digits, '-' and '_' only (secrets.token_urlsafe)")
    fills = {"STATE_JSON": data, "TOKEN": token}  # one pass: a name that reads {{TOKEN}} stays a name
    return re.sub(r"\{\{(STATE_JSON|TOKEN)\}\}", lambda match: fills[match.group(1)], _page_template())


def open_view(robot: Robot, *, frames: tuple[str, str] = DEFAULT_FRAMES, q=None, port: int = DEFAULT_PORT,
              host: str = "127.0.0.1", overlay: Overlay = NO_OVERLAY, collisions: CollisionView | None = None) -> ViewerServer:
    """Start a view: control page on ``port``, meshcat on its own ports (7000 upwards).

    ``overlay``: the manipulability ellipsoid's start settings (:class:`Overlay`; default off).
    ``collisions``: what is checked at each pose (:func:`~manipkit.app.viewer.collision_state.collision_view`;
    default nothing); with a floor checked, the floor grid is drawn at its height.

    Returns the running :class:`ViewerServer` (``.url``: control page,
    ``.scene_url``: meshcat, ``.scene.warnings``: geometry not shown,
    ``.wait()``, ``.close()``).

    Raises
    ------
    ManipkitError
        Unknown frames or joint values, then ``port P is in use; ...`` (both
        before anything starts); Pinocchio cannot read a mesh file (a missing one is drawn another way, with
        one ``MissingMeshWarning``).
    """
    state = ViewerState(robot, frames=frames, q=q, overlay=overlay, collisions=collisions)
    server = ViewerServer(port, host=host)
    scene = None
    try:
        visual = visual_model(robot)
        scene = MeshcatScene(visual, robot.model, bounds=state.bounds(visual), base=state.base_origin(),
                             floor_height=None if collisions is None else collisions.floor)
        server.attach(state, scene, visual)
        return server.start()
    except BaseException:
        server.close()
        if scene is not None:
            scene.close()
        raise


def write_static(robot: Robot, path, *, frames: tuple[str, str] = DEFAULT_FRAMES, q=None,
                 overlay: Overlay = NO_OVERLAY, collisions: CollisionView | None = None) -> Path:
    """Write a standalone HTML snapshot of the pose (robot, triads at A and B, the ellipsoid if shown, the links in
    collision tinted if ``collisions`` are checked); returns the path.

    The file is meshcat's static export: it opens in a browser without a server.
    Names reach it only inside meshcat's base64-encoded drawing commands, never as markup.

    Raises
    ------
    OutputError
        ``cannot write PATH: reason`` (checked before meshcat starts; no folder is created).
    """
    path = writable_path(path)
    state = ViewerState(robot, frames=frames, q=q, overlay=overlay, collisions=collisions)
    visual = visual_model(robot)
    with MeshcatScene(visual, robot.model, bounds=state.bounds(visual), base=state.base_origin(),
                      floor_height=None if collisions is None else collisions.floor) as scene:
        scene.draw(state.scene_placements(visual), state.scene_visibility(), state.collision_tints(visual))
        html = scene.static_html()
    return write_text(path, html)
