"""Pictures of a planned path (``manipkit path --plot`` and ``--map``): the joints along it, and the feasibility map.

:func:`joint_plot` draws each joint of ``plan.q`` along the path (against the waypoint times, or the waypoint
index without timing; the retimed motion as a line when given) between its limits, and under them the
singularity margin, the smallest singular value of the chain's 6 x n Jacobian (base axes; m/rad and rad/rad
mixed, as ``--singular-tol`` reads it) at each waypoint. :func:`feasibility_map` draws
:attr:`~manipkit.paths.plan.PathPlan.feasibility`, waypoint by tool angle, coloured by kind
(:data:`~manipkit.paths.plan.FEASIBILITY_KINDS`), and stores the drawn cells in the PNG's text chunk
``manipkit:feasibility`` (JSON) so that a reader can check the data, not the pixels. matplotlib is imported
inside the functions (no pyplot: a figure and an Agg canvas); files are written through
:func:`manipkit.outputs.writing`.
"""

from __future__ import annotations

import json
import math

import numpy as np

from manipkit.outputs import writing

__all__ = ["MAP_COLOURS", "MAP_KEY", "feasibility_map", "joint_plot"]

#: The PNG text chunk holding the feasibility map's cells (JSON: kinds, angles in degrees, cells).
MAP_KEY = "manipkit:feasibility"
#: A colour per :data:`~manipkit.paths.plan.FEASIBILITY_KINDS` entry, in that order.
MAP_COLOURS = ("#3b3b3b", "#8c564b", "#9467bd", "#d62728", "#ff7f0e", "#ffd92f", "#a6d96a", "#1a9850")


def _figure(width: float, height: float, rows: int = 1, ratios=None):
    import matplotlib

    matplotlib.use("Agg", force=False)
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(rows, 1, sharex=True, gridspec_kw=None if ratios is None else {"height_ratios": ratios})
    return fig, np.atleast_1d(axes)


def joint_plot(plan, chain, path, *, motion=None, title: str = "", dpi: int = 110, inputs=()) -> dict:
    """Draw the joints along ``plan`` between their limits, and the singularity margin, to the PNG ``path``.

    Returns the data drawn: ``x`` (s or waypoint index), ``q`` (N, n), ``lower``, ``upper`` (n,), ``sigma``
    (N,, the smallest singular value of the Jacobian at each waypoint)."""
    Q = np.asarray(plan.q)
    x = np.asarray(plan.t) if plan.t is not None else np.arange(len(Q), dtype=float)
    if motion is not None:
        x = np.asarray(motion.waypoint_times)
    sigma = np.linalg.svd(chain.jacobians(Q), compute_uv=False)[:, -1]
    n = Q.shape[1]
    fig, axes = _figure(8.0, 1.3 * n + 2.0, n + 1)
    for j, (ax, name, joint) in enumerate(zip(axes, plan.joint_names, chain.joints)):
        if motion is not None:
            ax.plot(motion.t, motion.q[:, j], color="tab:blue", lw=1.2)
        ax.plot(x, Q[:, j], "o", color="tab:blue", ms=2.5)
        for bound in (chain.lower[j], chain.upper[j]):
            if math.isfinite(bound):
                ax.axhline(bound, color="tab:red", ls="--", lw=0.8)
        finite = [b for b in (chain.lower[j], chain.upper[j]) if math.isfinite(b)]
        low, high = min(finite + [Q[:, j].min()]), max(finite + [Q[:, j].max()])
        pad = 0.05 * max(high - low, 0.2)
        ax.set_ylim(low - pad, high + pad)
        ax.set_ylabel(f"{name}\n[{'rad' if joint.is_angular else 'm'}]", fontsize=7)
        ax.tick_params(labelsize=7)
    axes[-1].plot(x, sigma, "-o", color="tab:purple", ms=2.5, lw=1.0)
    axes[-1].set_ylabel("smallest\nsingular value", fontsize=7)
    axes[-1].set_ylim(0.0, 1.1 * max(float(sigma.max()), 1e-6))
    axes[-1].tick_params(labelsize=7)
    axes[-1].set_xlabel("time [s]" if motion is not None or plan.t is not None else "waypoint")
    fig.suptitle(title or "joints along the path (red dashes: limits)", fontsize=9)
    with writing(path, inputs=inputs) as target:
        fig.savefig(target, format="png", dpi=dpi, metadata={"Software": None})
    return {"x": x, "q": Q, "lower": np.asarray(chain.lower), "upper": np.asarray(chain.upper), "sigma": sigma}


def feasibility_map(plan, path, *, free_axis: str = "", title: str = "", dpi: int = 110, inputs=()) -> np.ndarray:
    """Draw ``plan.feasibility`` (waypoint x tool angle, coloured by kind) to the PNG ``path``; return the cells."""
    from matplotlib.colors import BoundaryNorm, ListedColormap
    from matplotlib.patches import Patch

    from manipkit.paths.plan import FEASIBILITY_KINDS

    cells = np.asarray(plan.feasibility)
    angles = np.degrees(np.asarray(plan.free_angles))
    N, A = cells.shape
    fig, axes = _figure(8.0, 4.5)
    ax = axes[0]
    step = float(angles[1] - angles[0]) if A > 1 else 1.0
    extent = (-0.5, N - 0.5, angles[0] - step / 2, angles[-1] + step / 2)
    cmap = ListedColormap(MAP_COLOURS)
    ax.imshow(cells.T, origin="lower", aspect="auto", interpolation="nearest", extent=extent, cmap=cmap,
              norm=BoundaryNorm(np.arange(len(MAP_COLOURS) + 1) - 0.5, len(MAP_COLOURS)))
    ax.set_xlabel("waypoint")
    ax.set_ylabel(f"tool angle about {free_axis or 'the free axis'} [deg]")
    present = sorted(set(cells.ravel().tolist()))
    ax.legend(handles=[Patch(color=MAP_COLOURS[k], label=FEASIBILITY_KINDS[k].replace("_", " ")) for k in present],
              loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7)
    if plan.first_failure is not None:
        ax.axvline(plan.first_failure - 0.5, color="black", lw=1.0)
    fig.suptitle(title or "feasibility: waypoint x tool angle", fontsize=9)
    data = json.dumps({"kinds": list(FEASIBILITY_KINDS), "angles_deg": angles.tolist(), "cells": cells.tolist()})
    with writing(path, inputs=inputs) as target:
        fig.savefig(target, format="png", dpi=dpi, metadata={"Software": None, MAP_KEY: data})
    return cells
