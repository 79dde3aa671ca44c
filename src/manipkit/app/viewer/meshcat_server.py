"""The meshcat server of a view, run as ``python -m manipkit.app.viewer.meshcat_server``: private, and tied to its viewer.

meshcat's own ``meshcat.servers.zmqserver`` listens for the browser on every
interface (``0.0.0.0`` and ``[::]``) and for scene commands on a TCP port any
local user can reach, and it outlives a viewer killed by a signal. This
launcher runs the same bridge (``meshcat.servers.zmqserver.ZMQWebSocketBridge``)
with three changes:

- the web server listens on ``127.0.0.1`` only, and answers only requests whose
  ``Host`` is a loopback name (``127.0.0.1``, ``localhost``, ``[::1]``, with the
  port): a DNS-rebinding page, whose requests carry its own host name, gets 403;
- scene commands arrive on a ZeroMQ ``ipc://`` socket in a folder only the user
  can enter (created 0700 by :func:`private_zmq_url`), not on a TCP port;
- it exits when its viewer does, whatever ended the viewer (a SIGKILL, a closed
  terminal's SIGHUP): its standard input is a pipe from the viewer, which the
  kernel closes when the viewer dies, and its parent process id is watched.

It prints ``zmq_url=...`` and ``web_url=...`` lines, as meshcat's server does.
"""

from __future__ import annotations

import os
import shutil
import signal
import sys
import tempfile
import threading
import time

__all__ = ["LOOPBACK_HOSTS", "main", "private_zmq_url"]

#: Host names (without the port) the web server answers.
LOOPBACK_HOSTS = ("127.0.0.1", "localhost", "[::1]", "::1")


def private_zmq_url() -> tuple[str, str]:
    """A fresh ``ipc://`` URL in a new folder of mode 0700 (only the user reaches the socket): (url, folder)."""
    folder = tempfile.mkdtemp(prefix="manipkit-meshcat-")  # mkdtemp makes it 0700, owned by the user
    return f"ipc://{os.path.join(folder, 'scene')}", folder


def _exit_with_parent(parent: int, zmq_url: str) -> None:
    """Exit this process when the viewer is gone: its pipe on stdin closes, or this process is re-parented.
    The private folder of an ``ipc://`` socket goes too (the viewer, killed, could not remove it)."""
    def leave():
        folder = os.path.dirname(zmq_url.removeprefix("ipc://"))
        if zmq_url.startswith("ipc://") and os.path.basename(folder).startswith("manipkit-meshcat-"):
            shutil.rmtree(folder, ignore_errors=True)
        os.kill(os.getpid(), signal.SIGKILL)  # from a thread: sys.exit would end the thread only

    def stdin_closed():
        try:
            while sys.stdin.buffer.read(4096):
                pass
        except (OSError, ValueError):
            pass
        leave()

    def parent_gone():
        while os.getppid() == parent:
            time.sleep(0.5)
        leave()

    threading.Thread(target=stdin_closed, name="viewer-pipe", daemon=True).start()
    threading.Thread(target=parent_gone, name="viewer-pid", daemon=True).start()


def _host_checked(app) -> None:
    """Make ``app`` (a tornado Application) answer 403 to a request whose Host is not a loopback name."""
    import tornado.web

    class Refused(tornado.web.RequestHandler):
        def prepare(self):
            raise tornado.web.HTTPError(403)

    find = app.find_handler

    def find_handler(request, **kwargs):
        host = request.host.rsplit(":", 1)[0] if not request.host.endswith("]") else request.host
        if host.lower() not in LOOPBACK_HOSTS:
            return app.get_handler_delegate(request, Refused)
        return find(request, **kwargs)

    app.find_handler = find_handler


def main(argv: list[str] | None = None) -> None:
    """``meshcat_server ZMQ_URL PARENT_PID``: serve until the viewer (PARENT_PID) is gone."""
    import warnings

    zmq_url, parent = (argv if argv is not None else sys.argv[1:])[:2]
    _exit_with_parent(int(parent), zmq_url)
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=r"zmq\.eventloop\.ioloop is deprecated")
        import tornado.web
        from meshcat.servers.zmqserver import ZMQWebSocketBridge

    listen = tornado.web.Application.listen

    def loopback_listen(self, port, address="", **kwargs):
        return listen(self, port, address="127.0.0.1", **kwargs)

    tornado.web.Application.listen = loopback_listen  # the bridge calls app.listen(port) with no address
    bridge = ZMQWebSocketBridge(zmq_url=zmq_url, host="127.0.0.1")
    _host_checked(bridge.app)
    print(f"zmq_url={bridge.zmq_url}", flush=True)
    print(f"web_url={bridge.web_url}", flush=True)
    try:
        bridge.run()
    except KeyboardInterrupt:
        pass


if __name__ == "__main__":
    main()
