"""The viewer's HTTP server refuses what is not its own page's request: real requests against a real server.

Every rule of docs/architecture.md ("The viewer's HTTP server") is checked
with http.client (headers written by hand where a rule is about them)
against a running :func:`open_view`: the Host it answers, the Origin it
accepts, the session token, ``application/json``, the body's size (from
Content-Length, before reading) and its JSON depth, one-line JSON errors,
and nothing on stderr. That the page's own requests still work in a browser
is test_app_viewer_browser.py; here the token is read from the served page
as a client would.
"""

import http.client
import json
import re
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

import manipkit
from manipkit.app.viewer import open_view
from manipkit.app.viewer.server import MAX_BODY_BYTES, MAX_JSON_DEPTH, TOKEN_HEADER, ViewerServer, page_html
from manipkit.errors import ViewerError

BIN = Path(sys.executable).parent
EVIL = "http://evil.example"


@pytest.fixture(scope="module")
def view():
    server = open_view(manipkit.load("course_arm"), port=0)
    yield server
    server.close()


def send(view, method, path, body=b"", headers=(), *, host=True, timeout=10):
    """One request with exactly the given headers (``host``: add ``Host: 127.0.0.1:PORT``); (status, headers, body)."""
    connection = http.client.HTTPConnection("127.0.0.1", view.port, timeout=timeout)
    try:
        connection.putrequest(method, path, skip_host=True, skip_accept_encoding=True)
        if host:
            connection.putheader("Host", f"127.0.0.1:{view.port}")
        for name, value in headers:
            connection.putheader(name, value)
        connection.endheaders(body if isinstance(body, bytes) else body.encode())
        response = connection.getresponse()
        return response.status, response, response.read()
    finally:
        connection.close()


def post(view, body, *headers, token=True, content_type="application/json", **options):
    """POST /api/update with a correct Content-Length, the token and ``content_type`` unless told otherwise."""
    raw = body if isinstance(body, bytes) else (body if isinstance(body, str) else json.dumps(body)).encode()
    fixed = [("Content-Length", str(len(raw)))]
    if content_type is not None:
        fixed.append(("Content-Type", content_type))
    if token:
        fixed.append((TOKEN_HEADER, view.token))
    return send(view, "POST", "/api/update", raw, [*fixed, *headers], **options)


def error_of(status, response, body) -> str:
    """The one-line JSON error of a refusal (and the connection is closed: an unread body must not be parsed)."""
    assert response.getheader("Content-Type") == "application/json"
    text = body.decode()
    assert "\n" not in text
    message = json.loads(text)["error"]
    assert message and "\n" not in message and "Traceback" not in message
    return message


def shoulder(view) -> float:
    return view.state.readout()["q"]["shoulder_joint"]


def moved_to(view, value) -> int:
    status, _, _ = post(view, {"q": {"shoulder_joint": value}})
    return status


# ----------------------------------------------------------------------
# The page's own requests
# ----------------------------------------------------------------------


def test_the_page_carries_the_token_and_its_requests_are_served(view):
    status, response, page = send(view, "GET", "/")
    assert status == 200 and response.getheader("X-Frame-Options") == "DENY"
    token = re.search(r'<meta name="manipkit-token" content="([A-Za-z0-9_-]+)">', page.decode()).group(1)
    assert token == view.token and len(token) >= 40
    origin = ("Origin", f"http://127.0.0.1:{view.port}")  # the page's fetch sends its own origin
    status, _, body = post(view, {"q": {"shoulder_joint": 0.25}}, origin, content_type="application/json; charset=utf-8")
    assert status == 200 and json.loads(body)["q"]["shoulder_joint"] == 0.25
    status, _, body = send(view, "GET", "/api/state", headers=[(TOKEN_HEADER, token)])
    assert status == 200 and json.loads(body)["q"]["shoulder_joint"] == 0.25


@pytest.mark.parametrize("host", ["localhost", "LocalHost", "127.0.0.1"])
def test_the_loopback_names_with_the_port_are_answered(view, host):
    status, _, _ = send(view, "GET", "/", headers=[("Host", f"{host}:{view.port}")], host=False)
    assert status == 200


def test_each_server_has_its_own_token_and_the_page_holds_only_a_safe_one():
    first, second = ViewerServer(0), ViewerServer(0)
    try:
        assert first.token != second.token
    finally:
        first.close()
        second.close()
    assert '<meta name="manipkit-token" content="abc-_9">' in page_html({}, token="abc-_9")
    with pytest.raises(ViewerError, match="token"):
        page_html({}, token='"><script>')


# ----------------------------------------------------------------------
# Host and Origin: no other site, no rebound name
# ----------------------------------------------------------------------


@pytest.mark.parametrize("host", ["evil.example", "evil.example:{port}", "127.0.0.1:1", "localhost.:{port}",
                                  "127.0.0.1:{port}.evil.example", ""])
def test_a_foreign_host_is_refused_for_the_page_the_state_and_updates(view, host):
    host = host.format(port=view.port)
    before = shoulder(view)
    for method, path in (("GET", "/"), ("GET", "/api/state")):
        status, response, body = send(view, method, path, headers=[("Host", host), (TOKEN_HEADER, view.token)],
                                      host=False)
        assert status == 403 and "is not this viewer's" in error_of(status, response, body)
        assert view.token not in body.decode()
    status, response, body = post(view, {"q": {"shoulder_joint": before + 0.1}}, ("Host", host), host=False)
    assert status == 403 and "is not this viewer's" in error_of(status, response, body)
    assert shoulder(view) == before


def test_a_request_without_a_host_or_with_two_is_refused(view):
    status, response, body = send(view, "GET", "/", host=False)
    assert status == 403 and "is not this viewer's" in error_of(status, response, body)
    status, response, body = send(view, "GET", "/", headers=[("Host", f"127.0.0.1:{view.port}")])
    assert status == 403 and "2 Host headers" in error_of(status, response, body)


@pytest.mark.parametrize("origin", [EVIL, "null", f"http://127.0.0.1:{1}", "https://127.0.0.1"])
def test_a_cross_origin_request_is_refused_even_with_the_token(view, origin):
    before = shoulder(view)
    status, response, body = post(view, {"q": {"shoulder_joint": before + 0.1}}, ("Origin", origin))
    assert status == 403 and "only the control page" in error_of(status, response, body)
    status, response, body = send(view, "GET", "/api/state", headers=[("Origin", origin), (TOKEN_HEADER, view.token)])
    assert status == 403
    assert shoulder(view) == before


# ----------------------------------------------------------------------
# Writes: the token, application/json
# ----------------------------------------------------------------------


def test_a_simple_cross_site_form_post_cannot_move_the_joints(view):
    # What any web page can send without a preflight: text/plain, no custom header, its own Origin
    before = shoulder(view)
    body = json.dumps({"q": {"shoulder_joint": before + 0.2}})
    status, response, answer = post(view, body, token=False, content_type="text/plain")
    assert status == 403 and TOKEN_HEADER in error_of(status, response, answer)
    assert shoulder(view) == before


@pytest.mark.parametrize("content_type", ["text/plain", "application/x-www-form-urlencoded", "multipart/form-data",
                                          "application/jsonx", None])
def test_a_body_that_is_not_application_json_is_refused_with_415(view, content_type):
    before = shoulder(view)
    status, response, body = post(view, {"q": {"shoulder_joint": before + 0.2}}, content_type=content_type)
    assert status == 415 and "send application/json" in error_of(status, response, body)
    assert shoulder(view) == before


@pytest.mark.parametrize("token", [None, "", "wrong", "x" * 43, "\u00e9"])
def test_a_missing_or_wrong_token_is_refused_for_updates_and_state_reads(view, token):
    before = shoulder(view)
    headers = [] if token is None else [(TOKEN_HEADER, token)]
    status, response, body = post(view, {"q": {"shoulder_joint": before + 0.2}}, *headers, token=False)
    assert status == 403 and TOKEN_HEADER in error_of(status, response, body)
    status, response, body = send(view, "GET", "/api/state", headers=headers)
    assert status == 403 and TOKEN_HEADER in error_of(status, response, body)
    assert shoulder(view) == before


# ----------------------------------------------------------------------
# Bodies: size from Content-Length before reading, JSON depth
# ----------------------------------------------------------------------


def test_a_huge_content_length_is_refused_with_413_before_reading(view):
    # 100 GB announced, nothing sent: the answer comes at once, without waiting for (or allocating) the body
    headers = [("Content-Type", "application/json"), (TOKEN_HEADER, view.token), ("Content-Length", str(100 << 30))]
    started = time.monotonic()
    status, response, body = send(view, "POST", "/api/update", b"", headers, timeout=5)
    assert time.monotonic() - started < 3
    assert status == 413 and f"({MAX_BODY_BYTES})" in error_of(status, response, body)
    assert response.getheader("Connection") == "close"


def test_a_body_one_byte_over_the_limit_is_refused_and_one_at_it_is_read(view):
    assert moved_to(view, 0.0) == 200
    padded = json.dumps({"q": {"shoulder_joint": 0.125}})
    status, _, _ = post(view, padded + " " * (MAX_BODY_BYTES - len(padded)))
    assert status == 200 and shoulder(view) == 0.125
    status, response, body = post(view, padded + " " * (MAX_BODY_BYTES + 1 - len(padded)))
    assert status == 413 and "65537 bytes" in error_of(status, response, body)


@pytest.mark.parametrize(("lengths", "status", "fragment"), [
    ([], 411, "no Content-Length"),
    (["-1"], 400, "give one number of bytes"),
    (["abc"], 400, "give one number of bytes"),
    (["1_0"], 400, "give one number of bytes"),
    (["+10"], 400, "give one number of bytes"),
    (["1e3"], 400, "give one number of bytes"),
    (["10", "10"], 400, "give one number of bytes"),
])
def test_a_missing_or_malformed_content_length_is_refused(view, lengths, status, fragment):
    headers = [("Content-Type", "application/json"), (TOKEN_HEADER, view.token)]
    headers += [("Content-Length", length) for length in lengths]
    answer = send(view, "POST", "/api/update", b'{"reset":true}', headers)
    assert answer[0] == status and fragment in error_of(*answer)


def test_a_chunked_body_is_refused(view):
    headers = [("Content-Type", "application/json"), (TOKEN_HEADER, view.token), ("Transfer-Encoding", "chunked")]
    answer = send(view, "POST", "/api/update", b"e\r\n{\"reset\":true}\r\n0\r\n\r\n", headers)
    assert answer[0] == 411 and "Content-Length" in error_of(*answer)


def test_a_body_shorter_than_its_content_length_is_refused(view):
    with socket.create_connection(("127.0.0.1", view.port), timeout=10) as connection:
        connection.sendall(f"POST /api/update HTTP/1.1\r\nHost: 127.0.0.1:{view.port}\r\nContent-Type: application/json\r\n"
                           f"{TOKEN_HEADER}: {view.token}\r\nContent-Length: 100\r\n\r\n{{}}".encode())
        connection.shutdown(socket.SHUT_WR)  # the client is done: 2 of the 100 bytes came
        head, _, body = connection.makefile("rb").read().partition(b"\r\n\r\n")
    assert head.startswith(b"HTTP/1.1 400 ") and "ended after 2 of its 100 bytes" in json.loads(body)["error"]


def test_a_body_that_never_comes_is_refused_after_the_read_timeout(view, monkeypatch):
    monkeypatch.setattr(view, "read_timeout", 0.5)
    with socket.create_connection(("127.0.0.1", view.port), timeout=10) as connection:
        connection.sendall(f"POST /api/update HTTP/1.1\r\nHost: 127.0.0.1:{view.port}\r\nContent-Type: application/json\r\n"
                           f"{TOKEN_HEADER}: {view.token}\r\nContent-Length: 100\r\n\r\n{{}}".encode())
        head, _, body = connection.makefile("rb").read().partition(b"\r\n\r\n")  # the client waits, sends no more
    assert head.startswith(b"HTTP/1.1 408 ") and "did not arrive within 0.5 s" in json.loads(body)["error"]


@pytest.mark.parametrize("depth", [MAX_JSON_DEPTH + 1, 30_000])
def test_deep_json_is_refused_with_400_without_a_recursion_error(view, depth):
    body = "[" * depth + "]" * depth
    assert len(body) <= MAX_BODY_BYTES
    answer = post(view, body)
    assert answer[0] == 400 and f"more than {MAX_JSON_DEPTH} deep" in error_of(*answer)
    answer = post(view, '{"q": ' + "{" * depth)  # unclosed: measured all the same
    assert answer[0] == 400 and f"more than {MAX_JSON_DEPTH} deep" in error_of(*answer)


def test_json_at_the_depth_limit_and_brackets_inside_strings_are_not_refused_for_depth(view):
    nested = "[" * (MAX_JSON_DEPTH - 2) + "]" * (MAX_JSON_DEPTH - 2)
    answer = post(view, '{"q": {"shoulder_joint": ' + nested + "}}")  # depth 20: parsed, then refused as no number
    assert answer[0] == 400 and "is not a number" in error_of(*answer)
    brackets = json.dumps({"frames": ['\\"[{' * 100, "ee_link"]})  # escaped quotes and brackets inside a string
    answer = post(view, brackets)
    assert answer[0] == 400 and "deep" not in error_of(*answer)


@pytest.mark.parametrize(("body", "fragment"), [
    (b"not json", "the body is not JSON"),
    (b"", "the body is not JSON"),
    (b'{"q": {"shoulder_joint": NaN}}', "NaN is not a number JSON allows"),
    (b'{"q": {"shoulder_joint": ' + b"9" * 5000 + b"}}", "the body is not JSON"),
    (b"\xff\xfe{}", "not UTF-8"),
    (b"[1, 2]", "a JSON array: send a JSON object"),
    (b'"text"', "a JSON string: send a JSON object"),
    (b'{"colour": "red"}', "unknown key 'colour' in the update"),
])
def test_a_body_that_is_no_update_is_refused_with_one_line(view, body, fragment):
    before = shoulder(view)
    answer = post(view, body)
    assert answer[0] == 400 and fragment in error_of(*answer)
    assert shoulder(view) == before


# ----------------------------------------------------------------------
# Whatever arrives: one JSON line back, nothing on the terminal
# ----------------------------------------------------------------------


def raw_exchange(port, data: bytes) -> bytes:
    """Send ``data``, then read until the server closes; what arrived before a reset is returned.

    A server that refuses a request before reading its body closes the
    connection with bytes unread, and the kernel then resets it: the reset
    can beat our own shutdown or cut the reading short (seen on a loaded machine).
    """
    chunks = []
    with socket.create_connection(("127.0.0.1", port), timeout=10) as connection:
        try:
            connection.sendall(data)
            connection.shutdown(socket.SHUT_WR)
            while chunk := connection.recv(65536):
                chunks.append(chunk)
        except OSError as exc:  # a reset (ENOTCONN, ECONNRESET, EPIPE); a timeout is a failure
            if isinstance(exc, TimeoutError):
                raise
    return b"".join(chunks)


@pytest.mark.parametrize(("request_bytes", "status"), [
    (b"DELETE /api/update HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n\r\n", 501),
    (b"GET /" + b"a" * 70_000 + b" HTTP/1.1\r\n\r\n", 414),
    (b"GET / HTTP/1.1\r\n" + b"X: y\r\n" * 101 + b"\r\n", 431),
])
def test_the_standard_librarys_own_refusals_are_json_too(view, request_bytes, status):
    answer = raw_exchange(view.port, request_bytes.replace(b"{port}", str(view.port).encode()))
    head, _, body = answer.partition(b"\r\n\r\n")
    assert head.startswith(f"HTTP/1.1 {status} ".encode())
    assert json.loads(body)["error"].startswith(str(status))


def test_a_request_line_that_is_no_http_gets_the_json_line_alone(view):
    # No HTTP version to answer in, so (as the standard library does for HTTP/0.9) no status line: the body alone
    answer = raw_exchange(view.port, b"GARBAGE\r\n\r\n")
    assert json.loads(answer) == {"error": "400 Bad request syntax ('GARBAGE')"}


def test_hostile_requests_print_nothing_on_the_viewers_terminal(tmp_path):
    # As the user runs it: `manipkit view` in a terminal, a hostile page (or script) hammering the port
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    proc = subprocess.Popen([str(BIN / "manipkit"), "view", "--no-browser", "--port", str(port)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        for line in proc.stdout:
            if line.startswith("robot "):
                break
        host = f"Host: 127.0.0.1:{port}\r\n".encode()
        hostile = [
            b"POST /api/update HTTP/1.1\r\n" + host + b"Content-Type: application/json\r\nContent-Length: "
            + str(100 << 30).encode() + b"\r\n\r\n",
            b"POST /api/update HTTP/1.1\r\n" + host + b"Content-Type: text/plain\r\nContent-Length: 40\r\n\r\n"
            + b'{"q": {"shoulder_joint": 1.0}}',
            b"POST /api/update HTTP/1.1\r\nHost: evil.example\r\nContent-Length: 60000\r\n\r\n" + b"[" * 60000,
            b"GET /api/state HTTP/1.1\r\nHost: rebound.example:" + str(port).encode() + b"\r\n\r\n",
            b"\x16\x03\x01\x02\x00\x01\x00\x01\xfc\x03\x03" + bytes(range(256)),  # a TLS hello
            b"GARBAGE\r\n\r\n",
        ]
        for data in hostile:
            raw_exchange(port, data)
        with socket.create_connection(("127.0.0.1", port)) as connection:  # a client that leaves mid-request
            connection.sendall(b"POST /api/update HTTP/1.1\r\n" + host + b"Content-Length: 10\r\n")
        status = http.client.HTTPConnection("127.0.0.1", port, timeout=10)
        status.request("GET", "/")
        assert status.getresponse().status == 200  # still serving
        status.close()
    finally:
        proc.send_signal(signal.SIGTERM)
        out, err = proc.communicate(timeout=30)
    assert proc.returncode == 0
    assert err == "", err
    assert "viewer stopped" in out
