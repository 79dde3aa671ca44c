"""The view's meshcat server (manipkit.app.viewer.meshcat_server), run for real: loopback only, Host checked,
scene commands on a private socket, and gone with its viewer on SIGKILL or SIGHUP (issue 40).

The viewer is a real ``manipkit view`` subprocess; where the server listens is read from /proc/net/tcp{,6}
(the kernel's table, independent of what the tool prints)."""

import contextlib
import http.client
import os
import re
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

import manipkit

pytestmark = pytest.mark.skipif(not Path("/proc/net/tcp").exists(), reason="reads Linux's /proc/net/tcp")
BIN = Path(sys.executable).parent


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def _listening(pid: int) -> list[tuple[str, int]]:
    """(local address in the kernel's hex, port) of each TCP socket process ``pid`` listens on, IPv4 and IPv6."""
    inodes = set()
    for fd in Path(f"/proc/{pid}/fd").iterdir():
        with contextlib.suppress(OSError):
            target = os.readlink(fd)
            if target.startswith("socket:["):
                inodes.add(target[8:-1])
    found = []
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        if not Path(table).exists():
            continue
        for line in Path(table).read_text().splitlines()[1:]:
            fields = line.split()
            address, hex_port = fields[1].rsplit(":", 1)
            if fields[3] == "0A" and fields[9] in inodes:  # 0A: LISTEN
                found.append((address, int(hex_port, 16)))
    return found


def _port_open(port: int) -> bool:
    with socket.socket() as probe:
        probe.settimeout(2)
        return probe.connect_ex(("127.0.0.1", port)) == 0


def _server_pid(viewer: int) -> int:
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                command = (entry / "cmdline").read_bytes().split(b"\0")
                stat = (entry / "stat").read_text()
            except OSError:
                continue
            if b"manipkit.app.viewer.meshcat_server" in command and int(stat.rsplit(")", 1)[1].split()[1]) == viewer:
                return int(entry.name)
    raise AssertionError("no meshcat server below the viewer")


@pytest.fixture
def viewer(tmp_path):
    port = _free_port()
    env = {**os.environ, "PYTHONPATH": str(Path(manipkit.__file__).parents[1])}  # this checkout's code, from any folder
    process = subprocess.Popen([str(BIN / "manipkit"), "view", "--no-browser", "--port", str(port)], cwd=tmp_path, env=env,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    scene = None
    deadline = time.monotonic() + 180
    while scene is None and time.monotonic() < deadline:
        line = process.stdout.readline()
        if not line:
            break
        match = re.match(r"meshcat scene: http://127\.0\.0\.1:(\d+)/", line)
        scene = int(match.group(1)) if match else None
    if scene is None:
        process.kill()
        pytest.fail(f"the viewer did not start: {process.stderr.read()}")
    yield process, scene
    if process.poll() is None:
        process.kill()
    process.wait(timeout=30)


def _gone(port: int, pid: int, within: float = 10.0) -> bool:
    deadline = time.monotonic() + within
    while time.monotonic() < deadline:
        if not Path(f"/proc/{pid}").exists() and not _port_open(port):
            return True
        time.sleep(0.2)
    return False


def _get(port: int, host: str) -> int:
    connection = http.client.HTTPConnection("127.0.0.1", port, timeout=10)
    connection.request("GET", "/static/", headers={"Host": host})
    status = connection.getresponse().status
    connection.close()
    return status


def test_the_scene_server_listens_on_loopback_only_and_checks_the_host(viewer):
    process, port = viewer
    server = _server_pid(process.pid)
    assert _listening(server) == [("0100007F", port)]  # 127.0.0.1 only: no 0.0.0.0 or [::] socket, no ZMQ port
    assert _get(port, f"127.0.0.1:{port}") == 200
    assert _get(port, f"localhost:{port}") == 200
    assert _get(port, f"attacker.example:{port}") == 403  # a DNS-rebinding page's requests carry its own host
    command = Path(f"/proc/{server}/cmdline").read_bytes().split(b"\0")
    url = next(c.decode() for c in command if c.startswith(b"ipc://"))  # no TCP port for scene commands
    folder = Path(url.removeprefix("ipc://")).parent
    assert folder.stat().st_mode & 0o777 == 0o700 and folder.stat().st_uid == os.getuid()


@pytest.mark.parametrize("signum", [signal.SIGKILL, signal.SIGHUP])
def test_the_scene_server_is_gone_with_its_viewer(viewer, signum):
    process, port = viewer
    server = _server_pid(process.pid)
    url = next(c.decode() for c in Path(f"/proc/{server}/cmdline").read_bytes().split(b"\0") if c.startswith(b"ipc://"))
    os.kill(process.pid, signum)
    process.wait(timeout=30)
    assert _gone(port, server), f"the meshcat server (pid {server}) still serves port {port} after {signum!r}"
    assert not Path(url.removeprefix("ipc://")).parent.exists()
