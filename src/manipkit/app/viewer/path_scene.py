"""A task path in meshcat: the tool path drawn as a polyline with waypoint markers, the arm animated along a joint path.

The caller hands over what to draw: the poses ``T_base_tip`` (N, 4, 4) of
the path and, when there is a joint path, its rows (N, n_robot), whole-robot
joint vectors in ``robot.joint_names`` order, one per waypoint, with their
times. This module plans nothing and solves no IK; where each node goes at a
row is :class:`ViewerState`'s answer (Pinocchio's geometry placements, the
triads from :meth:`Robot.transform`), as in the live view.

The scene (meshcat folder ``path``, placed at ``T_root_base``, the triad at
A): ``path/line``, the polyline through the poses' origins; ``path/waypoints``,
a point at each origin; and, on a path that fails, ``path/first_failure``, a
red sphere at the first waypoint where every candidate died. The triads mark
the chain's base (A) and tip (B). With rows, one meshcat animation moves every
visual, both triads and the ``path`` folder (it follows the base, should the
base move with the joints) through the rows: keyframe ``k`` at the time
``times[k]`` (s), or :data:`UNTIMED_STEP` s apart when the path has no times,
played in a loop; three.js interpolates each node's position and rotation
between keyframes (not the joints: between distant rows the links part).
meshcat's controls (Animations) pause, seek and slow it.

Numbers: meshcat sends geometry to WebGL as float32, so the polyline's and the
markers' vertices are the poses' translations rounded to float32 (within
2**-24 of their size); node placements and keyframes are float64.

Conventions (docs/architecture.md): metres, seconds; the scene's world frame is
the robot's root link.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from manipkit.app.viewer.scene import MeshcatScene, visual_model
from manipkit.app.viewer.state import TRIAD_PATHS, ViewerState
from manipkit.errors import OptionError
from manipkit.outputs import writable_path, write_text

if TYPE_CHECKING:
    from pathlib import Path

    from manipkit.kinematics.robot import Robot

__all__ = ["FAILURE_COLOUR", "FPS", "PATH_COLOUR", "PATH_ROOT", "UNTIMED_STEP", "WAYPOINT_COLOUR", "path_keyframes",
           "path_scene", "write_path_html"]

PATH_ROOT = "path"  # meshcat folder of the path's line, markers and failure mark
#: Seconds between keyframes of a path without times (no --speed, no t in the file).
UNTIMED_STEP = 0.1
#: meshcat's animation clips count time in frames at this rate; keyframe k sits at frame ``FPS * times[k]``.
FPS = 30
PATH_COLOUR = 0xFF7F00  # orange: neither a triad axis nor the collision red
WAYPOINT_COLOUR = (0.15, 0.15, 0.15)
FAILURE_COLOUR = 0xFF0000


def _checked(robot: Robot, poses, rows, times) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
    poses = np.asarray(poses, dtype=float)
    if poses.ndim != 3 or poses.shape[1:] != (4, 4) or len(poses) == 0 or not np.isfinite(poses).all():
        raise OptionError(f"poses: give finite T_base_tip of shape (N, 4, 4), got shape {poses.shape}")
    if rows is not None:
        rows = np.asarray(rows, dtype=float)
        n = robot.q().size
        if rows.shape != (len(poses), n) or not np.isfinite(rows).all():
            raise OptionError(f"rows: give one finite whole-robot joint vector per pose, shape ({len(poses)}, "
                              f"{n}), got {rows.shape}")
    if times is not None:
        times = np.asarray(times, dtype=float)
        if times.shape != (len(poses),) or not np.isfinite(times).all() or (np.diff(times) <= 0).any():
            raise OptionError(f"times: give {len(poses)} finite times that increase, got shape {times.shape}")
    return poses, rows, times


def path_keyframes(robot: Robot, rows, *, base: str, tip: str, visual) -> list[dict[str, np.ndarray]]:
    """Per row, scene path -> T_root_node (4x4, no mesh scale: meshcat animates position and rotation, and the
    scale stays as drawn): every visual, the triads at ``base`` and ``tip``, and the ``path`` folder at the base."""
    state = ViewerState(robot, frames=(base, tip))
    keyframes = []
    for row in np.asarray(rows, dtype=float):
        state.set_joints(robot.as_dict(row))
        placements = state.geometry_placements(visual, scaled=False)
        placements.update(state.frame_placements())
        placements[PATH_ROOT] = placements[TRIAD_PATHS[0]]
        keyframes.append(placements)
    return keyframes


def _draw_path(viewer, poses: np.ndarray, T_root_base: np.ndarray, *, size: float, failure: int | None) -> None:
    import meshcat.geometry as mg

    origins = poses[:, :3, 3].T.astype(np.float32)
    viewer[f"{PATH_ROOT}/line"].set_object(mg.Line(mg.PointsGeometry(origins), mg.LineBasicMaterial(color=PATH_COLOUR)))
    colours = np.tile(np.array(WAYPOINT_COLOUR, dtype=np.float32)[:, None], (1, origins.shape[1]))
    viewer[f"{PATH_ROOT}/waypoints"].set_object(mg.PointCloud(origins, colours, size=0.015 * size))
    if failure is not None:
        viewer[f"{PATH_ROOT}/first_failure"].set_object(mg.Sphere(0.015 * size),
                                                          mg.MeshLambertMaterial(color=FAILURE_COLOUR))
        at = np.eye(4)
        at[:3, 3] = poses[failure, :3, 3]
        viewer[f"{PATH_ROOT}/first_failure"].set_transform(at)
    viewer[PATH_ROOT].set_transform(T_root_base)


def _animate(viewer, keyframes: list[dict[str, np.ndarray]], times: np.ndarray) -> None:
    from meshcat.animation import Animation

    animation = Animation(default_framerate=FPS)
    for placements, t in zip(keyframes, times):
        with animation.at_frame(viewer, FPS * float(t)) as frame:
            for path, T in placements.items():
                frame[path].set_transform(T)

    viewer.set_animation(animation, play=True, repetitions=float("inf"))  # in a loop


def path_scene(robot: Robot, poses, rows=None, *, base: str, tip: str, times=None, q=None,
               first_failure: int | None = None, visual=None) -> MeshcatScene:
    """A :class:`MeshcatScene` (its own meshcat server) with the tool path drawn and the arm on its joint path.

    Parameters
    ----------
    robot : Robot
    poses : array_like, shape (N, 4, 4)
        The path, ``T_base_tip`` (m): the polyline joins their origins.
    rows : array_like, shape (N, n_robot), optional
        The joint path as whole-robot vectors (rad or m), one per pose; the arm is animated through them. None:
        the arm stands still at ``q``.
    base, tip : str, keyword-only
        The chain's frames: the path is drawn in ``base``; the triads mark both.
    times : array_like, shape (N,), optional, keyword-only
        When each row is reached (s, increasing); default :data:`UNTIMED_STEP` s apart.
    q : array_like, shape (n_robot,), optional, keyword-only
        The pose without rows (default every joint at 0 or the nearest value inside its limits).
    first_failure : int, optional, keyword-only
        The waypoint marked as where the path fails.
    visual : pinocchio.GeometryModel, optional, keyword-only
        The robot's :func:`visual_model` when loaded already, else loaded here.

    Close the scene when done.

    Raises
    ------
    OptionError
        Poses, rows or times of the wrong shape, not finite, or times that do not increase.
    """
    poses, rows, times = _checked(robot, poses, rows, times)
    if first_failure is not None and not 0 <= first_failure < len(poses):
        raise OptionError(f"first_failure {first_failure}: give a waypoint index in 0..{len(poses) - 1}")
    visual = visual_model(robot) if visual is None else visual
    state = ViewerState(robot, frames=(base, tip), q=q if rows is None else rows[0])
    keyframes = None if rows is None else path_keyframes(robot, rows, base=base, tip=tip, visual=visual)
    lower, upper = state.bounds(visual)
    roots = [state.frame_placements()[TRIAD_PATHS[0]]] if keyframes is None else [k[PATH_ROOT] for k in keyframes]
    for T_root_base in roots:
        drawn = poses[:, :3, 3] @ T_root_base[:3, :3].T + T_root_base[:3, 3]
        lower, upper = np.minimum(lower, drawn.min(axis=0)), np.maximum(upper, drawn.max(axis=0))
    if keyframes is not None:
        for placements in keyframes:
            origins = np.array([T[:3, 3] for T in placements.values()])
            lower, upper = np.minimum(lower, origins.min(axis=0)), np.maximum(upper, origins.max(axis=0))
    base_origin = state.base_origin()
    scene = MeshcatScene(visual, robot.model, bounds=(lower, upper), base=base_origin,
                         floor_height=min(float(base_origin[2]), float(lower[2])))
    try:
        scene.draw(state.scene_placements(visual), state.scene_visibility())
        size = max(float(np.linalg.norm(upper - lower)), 0.2)
        _draw_path(scene.viewer, poses, roots[0], size=size, failure=first_failure)
        if keyframes is not None:
            _animate(scene.viewer, keyframes, UNTIMED_STEP * np.arange(len(poses)) if times is None else times)
    except BaseException:
        scene.close()
        raise
    return scene


def write_path_html(robot: Robot, path, poses, rows=None, *, base: str, tip: str, times=None, q=None,
                    first_failure: int | None = None, visual=None, inputs=()) -> Path:
    """Write :func:`path_scene` as meshcat's standalone HTML page (opens without a server); returns the path.

    ``inputs``: the files the command read, never written over (:func:`manipkit.outputs.writable_path`).

    Raises
    ------
    OutputError
        ``cannot write PATH: reason`` (checked before meshcat starts).
    """
    path = writable_path(path, inputs=inputs)
    with path_scene(robot, poses, rows, base=base, tip=tip, times=times, q=q, first_failure=first_failure,
                    visual=visual) as scene:
        html = scene.static_html()
    return write_text(path, html, inputs=inputs)
