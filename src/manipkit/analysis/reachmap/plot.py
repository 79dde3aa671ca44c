"""Pictures of a reach map: :func:`plot_reachmap` (slices of its index or of its manipulability overlay, matplotlib)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from manipkit.analysis.reachmap.constants import LAYERS
from manipkit.errors import ReachMapError
from manipkit.text import short_text

if TYPE_CHECKING:
    from manipkit.analysis.reachmap.map import ReachMap

__all__ = ["plot_reachmap"]


def plot_reachmap(reach_map: ReachMap, path, *, layer: str = "index") -> None:
    """A layer of the map to ``path`` (matplotlib): the plane of a planar map; two slices through the grid centre otherwise.

    ``layer``: ``"index"`` (0..1) or ``"manipulability"`` (the best
    Yoshikawa index per voxel, blank where nothing reached). Spatial slices:
    horizontal (x-y of ``base``) and vertical (x-z), each through the voxel
    layer that holds the grid's centre.

    Raises
    ------
    ReachMapError
        An unknown layer, or ``"manipulability"`` of a map built without it.
    """
    if layer not in LAYERS:
        raise ReachMapError(f"unknown layer '{layer}'; layers: {', '.join(LAYERS)}")
    if layer == "manipulability" and reach_map.manipulability is None:
        raise ReachMapError("this map was built without manipulability (manipulability=False, --no-manipulability)")
    from matplotlib.figure import Figure  # not pyplot: the caller's backend (a notebook's) stays as it is

    from manipkit.outputs import writing

    v = reach_map.voxel
    index = reach_map.index if layer == "index" else np.ma.masked_invalid(reach_map.manipulability)
    top = 1.0 if layer == "index" else max(float(index.max()) if index.count() else 1.0, 1e-12)
    nx, ny, nz = reach_map.shape
    o = reach_map.origin
    if reach_map.orientations.kind == "planar":
        slices = [(index[:, :, 0], "u (m)", "v (m)", (0.0, 0.0), "the arm's plane")]
    else:
        slices = [
            (index[:, :, nz // 2], "x (m)", "y (m)", (o[0], o[1]), f"z = {short_text(o[2] + nz // 2 * v, 4)} m"),
            (index[:, ny // 2, :], "x (m)", "z (m)", (o[0], o[2]), f"y = {short_text(o[1] + ny // 2 * v, 4)} m"),
        ]
    fig = Figure(figsize=(5.2 * len(slices) + 1.0, 4.8))
    axes = fig.subplots(1, len(slices), squeeze=False)
    for ax, (image, xlabel, ylabel, (a0, b0), where) in zip(axes[0], slices):
        if reach_map.orientations.kind == "planar":  # plane coordinates measured from the grid centre
            a0, b0 = -(nx // 2) * v, -(ny // 2) * v
        extent = (a0 - v / 2, a0 + (image.shape[0] - 0.5) * v, b0 - v / 2, b0 + (image.shape[1] - 0.5) * v)
        shown = ax.imshow(image.T, origin="lower", extent=extent, cmap="viridis", vmin=0.0, vmax=top,
                          interpolation="nearest", aspect="equal")
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
        ax.set_title(where)
    fig.colorbar(shown, ax=list(axes[0]), label="reachability index (1: dexterous)" if layer == "index" else
                 "best Yoshikawa index, translation rows")
    fig.suptitle(f"{reach_map.robot}: {reach_map.frame} in {reach_map.base}, {short_text(v)} m voxels, "
                 f"{reach_map.orientations.size} orientation bins", parse_math=False)  # a "$" in a name is text, not mathtext
    with writing(path) as target:
        fig.savefig(target, dpi=110, bbox_inches="tight")
