"""``manipkit view``: the robot in a browser (meshcat) with joint sliders and a live T_A_B readout.

Serves the control page of :mod:`manipkit.app.viewer` until Ctrl-C (or
SIGTERM), or writes a standalone HTML snapshot with ``--static``
(docs/architecture.md, "app"). ``--ellipsoid [velocity|force]`` starts with
the manipulability ellipsoid of B relative to A shown (``--ellipsoid-axes
trans|rot``); the page's checkbox toggles it. ``--collisions self,floor``
checks each pose (``--floor Z|none``, ``--srdf``, ``--geometry``, parsed as
``reachmap`` parses them): links in contact are drawn red and the readout
names the pairs in contact and the closest pair. The viewer (meshcat, Pinocchio's visualizer)
is imported only when this command runs.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

from manipkit.app.cli.collisions import add_collision_set_options, collision_set
from manipkit.app.cli.common import EXIT_OK, add_joint_options, add_robot_options, joint_vector, load_robot, warn
from manipkit.outputs import writable_path
from manipkit.text import number_text

__all__ = ["register", "run_view"]


def register(commands) -> None:
    """Add ``manipkit view`` to the subparsers ``commands``."""
    view = commands.add_parser("view", help="the robot in a browser (meshcat) with joint sliders and a live T_A_B readout")
    add_robot_options(view)
    add_joint_options(view)
    view.add_argument("--frames", nargs=2, default=["base_link", "ee_link"], metavar=("A", "B"),
                      help="frames of the readout T_A_B and of the two triads (default base_link ee_link)")
    view.add_argument("--ellipsoid", nargs="?", const="velocity", choices=("velocity", "force"), default=None,
                      metavar="KIND", help="start with the manipulability ellipsoid of B relative to A shown: velocity "
                                           "(the default KIND) or force; the page's checkbox toggles it")
    view.add_argument("--ellipsoid-axes", choices=("trans", "rot"), default="trans",
                      help="rows of the ellipsoid: trans (linear velocity or force, default) or rot (angular)")
    add_collision_set_options(view, what="check each pose and draw the links in contact red")
    view.add_argument("--port", type=int, default=8700, metavar="P", help="port of the control page (default 8700, 0 = any free port)")
    view.add_argument("--no-browser", action="store_true", help="print the URLs but do not open a browser")
    view.add_argument("--static", type=Path, default=None, metavar="FILE.html",
                      help="write a standalone HTML snapshot of the pose instead of serving")
    view.set_defaults(run=run_view)


def run_view(args) -> int:
    """Serve the view until stopped (opening a browser when there is a display), or write ``--static``."""
    import signal
    import threading
    import webbrowser

    from manipkit.app import viewer

    if args.static is not None:
        writable_path(args.static, inputs=(args.robot,))  # before the robot is loaded and meshcat started
    robot = load_robot(args, mesh_warnings=False)
    q = joint_vector(robot, args)
    frames = tuple(args.frames)
    overlay = viewer.Overlay(args.ellipsoid is not None, args.ellipsoid or "velocity", args.ellipsoid_axes)
    collisions = viewer.collision_view(robot, **collision_set(args))
    if collisions is not None and collisions.settings is None:
        warn(collisions.text(None))  # said once; the readout says it too
    if args.static is not None:
        path = viewer.write_static(robot, args.static, frames=frames, q=q, overlay=overlay, collisions=collisions)
        size = path.stat().st_size / 1e6
        shown = f" and the {overlay.kind} ellipsoid at {frames[1]}" if overlay.shown else ""
        shown += ", links in contact red" if collisions is not None and collisions.settings is not None else ""
        print(f"wrote {path} ({number_text(size, 1)} MB): {robot.name} with triads at {frames[0]} and {frames[1]}"
              f"{shown}; open it in a browser, no server needed")
        if collisions is not None and collisions.settings is not None:
            print(collisions.text(collisions.report(robot, q)))
        return EXIT_OK

    # Ctrl-C (SIGINT) and `kill` (SIGTERM) set an event the wait below watches: raising KeyboardInterrupt inside
    # a thread join could leave the server's locks half taken, and the viewer then hung at exit under load
    stopping = threading.Event()

    def stop(signum, frame):
        stopping.set()

    previous = {sig: signal.signal(sig, stop) for sig in (signal.SIGINT, signal.SIGTERM)}
    view = None
    try:
        view = viewer.open_view(robot, frames=frames, q=q, port=args.port, overlay=overlay, collisions=collisions)
        for warning in view.scene.warnings:
            warn(warning)
        print(f"control page: {view.url}", flush=True)
        print(f"meshcat scene: {view.scene_url}", flush=True)
        print(f"robot {robot.name}, T_{frames[0]}_{frames[1]} live; Ctrl-C stops the viewer", flush=True)
        if not args.no_browser:
            if sys.platform.startswith("linux") and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
                print("no display found: open the control page in a browser yourself", flush=True)
            else:  # in a thread: a console browser must not hold up the server
                threading.Thread(target=webbrowser.open, args=(view.url,), daemon=True).start()
        view.wait(stopping)
        if stopping.is_set():
            print("viewer stopped", flush=True)
    except KeyboardInterrupt:  # a Ctrl-C before the handlers were set
        print("viewer stopped", flush=True)
    finally:
        if view is not None:
            view.close()
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    return EXIT_OK
