"""A reachability map in meshcat: its reachable voxels as coloured points beside the robot at its default pose.

The positions and values come from the map (:class:`manipkit.analysis.reachmap.map.ReachMap`);
this module computes no kinematics of its own (the robot's pose is drawn
by :class:`ViewerState`, the map is placed at ``T_root_base`` from
:meth:`Robot.transform`). Conventions (docs/architecture.md): metres, the
scene's world frame is the robot's root link.

Each layer (``"index"``, and ``"manipulability"`` when the map holds it) is a
meshcat folder ``reachmap/<layer>`` of ``bands`` point clouds, one per band
of values (``reachmap/index/0.8-1``: the voxels with index in [0.8, 1]), so
meshcat's controls can hide the outer shells to see inside. Every point is a
square the size of a voxel at the voxel's centre, coloured by its value on
the viridis scale (0 to 1 for the index, 0 to the map's best for the
manipulability); only reachable voxels (index > 0) are drawn. The index
layer is shown, the manipulability layer hidden until ticked.
"""

from __future__ import annotations

import signal
import time
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from manipkit.app.viewer.scene import MeshcatScene, visual_model
from manipkit.app.viewer.state import ViewerState
from manipkit.errors import ManipkitError, ReachMapError
from manipkit.outputs import writable_path, write_text
from manipkit.text import short_text

if TYPE_CHECKING:
    from pathlib import Path

    from manipkit.analysis.reachmap.map import ReachMap
    from manipkit.kinematics.robot import Robot

__all__ = ["BANDS", "MAP_ROOT", "VoxelBand", "reachmap_scene", "serve_until_stopped", "voxel_bands",
           "write_reachmap_html"]

MAP_ROOT = "reachmap"  # meshcat folder of the map's layers
BANDS = 5


class VoxelBand(NamedTuple):
    """One point cloud of a layer: the voxels whose value lies in one band."""

    path: str  # meshcat path, "reachmap/<layer>/<low>-<high>"
    centres: np.ndarray  # (N, 3) voxel centres, m, in the map's base frame
    values: np.ndarray  # (N,) index or best manipulability
    colours: np.ndarray  # (N, 3) RGB in 0..1 (viridis of value / top)


def voxel_bands(reach_map: ReachMap, layer: str = "index", *, bands: int = BANDS) -> list[VoxelBand]:
    """The reachable voxels of ``layer`` split into ``bands`` equal bands of value (empty bands left out).

    The scale runs from 0 to ``top``: 1 for the index, the map's largest
    best index for ``"manipulability"``; band ``k`` holds the values in
    ``[k top / bands, (k + 1) top / bands)``, the last one its upper end too.

    Raises
    ------
    ReachMapError
        An unknown layer, or ``"manipulability"`` of a map built without it.
    """
    from matplotlib import colormaps

    if layer == "index":
        values = reach_map.index
    elif layer == "manipulability":
        if reach_map.manipulability is None:
            raise ReachMapError("this map was built without manipulability (manipulability=False, --no-manipulability)")
        values = reach_map.manipulability
    else:
        raise ReachMapError(f"unknown layer '{layer}'; layers: index, manipulability")
    reached = reach_map.reachable
    centres, values = reach_map.centers()[reached], values[reached]
    top = 1.0 if layer == "index" else max(float(values.max()) if values.size else 0.0, 1e-300)
    scaled = np.clip(values / top, 0.0, 1.0)
    band = np.minimum((scaled * bands).astype(int), bands - 1)
    colours = colormaps["viridis"](scaled)[:, :3]
    out = []
    for k in range(bands):
        pick = band == k
        if pick.any():
            name = f"{short_text(k * top / bands, 3)}-{short_text((k + 1) * top / bands, 3)}"
            out.append(VoxelBand(f"{MAP_ROOT}/{layer}/{name}", centres[pick], values[pick], colours[pick]))
    return out


def _draw_map(viewer, reach_map: ReachMap, T_root_base: np.ndarray, *, shown: str, bands: int) -> None:
    import meshcat.geometry as mg

    layers = ["index"] + (["manipulability"] if reach_map.manipulability is not None else [])
    for layer in layers:
        for band in voxel_bands(reach_map, layer, bands=bands):
            cloud = mg.PointCloud(band.centres.T.astype(np.float32), band.colours.T.astype(np.float32),
                                  size=float(reach_map.voxel))
            viewer[band.path].set_object(cloud)
        viewer[f"{MAP_ROOT}/{layer}"].set_property("visible", layer == shown)
    viewer[MAP_ROOT].set_transform(T_root_base)


def reachmap_scene(reach_map: ReachMap, robot: Robot, *, layer: str = "index", bands: int = BANDS,
                   visual=None) -> MeshcatScene:
    """A :class:`MeshcatScene` (its own meshcat server) with the robot at its default pose and the map's voxels.

    Triads mark the map's ``base`` and ``frame``; ``layer`` is shown first
    (the other one is in meshcat's controls, hidden). ``visual``: the robot's
    :func:`visual_model` when loaded already (its missing meshes said once), else loaded here.
    Close the scene when done.

    Raises
    ------
    ReachMapError
        A map of another robot, an unknown layer or one the map does not hold.
    """
    if reach_map.robot != robot.name:
        raise ReachMapError(f"the map is of '{reach_map.robot}', not of '{robot.name}': give its robot")
    voxel_bands(reach_map, layer, bands=1)  # the layer exists, before meshcat starts
    state = ViewerState(robot, frames=(reach_map.base, reach_map.frame))
    T_root_base = robot.transform(robot.root_link, reach_map.base, state.q, check_limits=False)
    visual = visual_model(robot) if visual is None else visual
    lower, upper = state.bounds(visual)
    base = state.base_origin()
    floor_height = min(float(base[2]), float(lower[2]))  # under the robot; voxels below it show through the grid
    reached = reach_map.centers()[reach_map.reachable] @ T_root_base[:3, :3].T + T_root_base[:3, 3]
    if reached.size:
        lower, upper = np.minimum(lower, reached.min(axis=0)), np.maximum(upper, reached.max(axis=0))
    scene = MeshcatScene(visual, robot.model, bounds=(lower, upper), base=base, floor_height=floor_height)
    try:
        scene.draw(state.scene_placements(visual), state.scene_visibility())
        _draw_map(scene.viewer, reach_map, T_root_base, shown=layer, bands=bands)
    except BaseException:
        scene.close()
        raise
    return scene


def write_reachmap_html(reach_map: ReachMap, path, *, robot: Robot, layer: str = "index", bands: int = BANDS,
                        visual=None) -> Path:
    """Write :func:`reachmap_scene` as meshcat's standalone HTML page (opens without a server); returns the path.

    Raises
    ------
    OutputError
        ``cannot write PATH: reason`` (checked before meshcat starts).
    """
    path = writable_path(path)
    with reachmap_scene(reach_map, robot, layer=layer, bands=bands, visual=visual) as scene:
        html = scene.static_html()
    return write_text(path, html)


def serve_until_stopped(scene: MeshcatScene, poll: float = 0.5) -> None:
    """Keep ``scene`` open until Ctrl-C, SIGTERM or its meshcat server stops; then close it."""

    def stop(signum, frame):
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, stop)
    try:
        while True:
            time.sleep(poll)
            scene.draw({})  # raises once the meshcat server has stopped
    except (KeyboardInterrupt, ManipkitError):
        pass
    finally:
        scene.close()
        signal.signal(signal.SIGTERM, previous)
