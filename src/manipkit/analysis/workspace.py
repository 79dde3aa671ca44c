"""Sampled workspaces and their pictures (planar arms for now).

Conventions (docs/architecture.md): metres and radians; planar arms move in the x-y
plane of their base frame, joints turn about +z (see :mod:`manipkit.closed_form.planar`).
The analytic radii come from :func:`manipkit.closed_form.planar_workspace.workspace_2r` and
:func:`manipkit.closed_form.planar_workspace.workspace_3r`; the samples here are an independent
picture of the same sets. matplotlib is imported inside the plotting
function only, so importing this module stays cheap.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from manipkit.closed_form.planar import chain_points, fk_2r, fk_3r
from manipkit.closed_form.planar_workspace import Workspace, workspace_2r, workspace_3r
from manipkit.errors import PlanarArmError
from manipkit.kinematics.chain import chain_of
from manipkit.outputs import writable_path, writing
from manipkit.spatial.rotations import wrap_angle
from manipkit.text import number_text, short_text

if TYPE_CHECKING:
    from manipkit.kinematics.chain import Chain
    from manipkit.kinematics.robot import Robot

__all__ = ["planar_link_lengths", "planar_workspace", "plot_planar_workspace", "sample_planar_workspace"]

_PLOT_SUFFIXES = (".png", ".svg")


def _planar_lengths(lengths) -> tuple[float, ...]:
    try:
        values = tuple(float(v) for v in lengths)
    except (TypeError, ValueError):
        raise PlanarArmError(f"lengths must be 2 or 3 numbers (l1, l2[, l3]), got {lengths!r:.80}") from None
    if len(values) not in (2, 3):
        raise PlanarArmError(f"lengths must be 2 or 3 link lengths (a planar 2R or 3R arm), got {len(values)}")
    return values


def planar_workspace(lengths) -> Workspace:
    """Analytic workspace of a planar 2R or 3R arm with these link lengths.

    Parameters
    ----------
    lengths : sequence of float
        ``(l1, l2)`` or ``(l1, l2, l3)`` in metres, each > 0.

    Returns
    -------
    Workspace
        From :func:`manipkit.closed_form.planar_workspace.workspace_2r` or
        :func:`manipkit.closed_form.planar_workspace.workspace_3r`.

    Examples
    --------
    >>> planar_workspace([4, 2, 1]).dexterous
    ((3.0, 5.0),)
    """
    values = _planar_lengths(lengths)
    return workspace_2r(*values) if len(values) == 2 else workspace_3r(*values)


def sample_planar_workspace(lengths, n: int, *, rng) -> np.ndarray:
    """Tool positions of random configurations of a planar 2R or 3R arm.

    Parameters
    ----------
    lengths : sequence of float
        ``(l1, l2)`` or ``(l1, l2, l3)`` in metres, each > 0.
    n : int
        Number of configurations.
    rng : numpy.random.Generator or int, keyword-only
        Source of the joint angles (an int seeds a new generator).

    Returns
    -------
    points : ndarray, shape (n, 2)
        Tool positions ``(x, y)`` in the base frame (m), from
        :func:`manipkit.closed_form.planar.fk_2r` / :func:`~manipkit.closed_form.planar.fk_3r` with
        every joint angle uniform in [-pi, pi). Uniform angles do not give
        uniform points: they crowd where the arm folds.

    Examples
    --------
    >>> points = sample_planar_workspace([4, 2, 1], 1000, rng=0)
    >>> points.shape, bool(np.all(np.hypot(*points.T) <= 7.0))
    ((1000, 2), True)
    """
    values = _planar_lengths(lengths)
    planar_workspace(values)  # validates the lengths
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 0:
        raise PlanarArmError(f"n = {n!r} must be a whole number >= 0 of configurations")
    Q = np.random.default_rng(rng).uniform(-math.pi, math.pi, (int(n), len(values)))
    if len(values) == 2:
        x, y = fk_2r(Q[:, 0], Q[:, 1], *values)
    else:
        x, y, _ = fk_3r(Q[:, 0], Q[:, 1], Q[:, 2], *values)
    return np.stack([x, y], axis=-1).reshape(int(n), 2)


def _showcase_configurations(count: int, joints: int, rng: np.random.Generator) -> np.ndarray:
    """Configurations to draw: the stretched and folded ones first (as in the seed's figure), then random.

    Each is turned by a different q1 so the drawings do not overlap.
    """
    if joints == 2:
        shapes = [(0.0, 0.0), (0.0, math.pi)]
    else:  # the seed's four: outer and inner reach, outer and inner dexterous reach for 4, 2, 1
        shapes = [(0.0, 0.0, 0.0), (0.0, math.pi, 0.0), (0.0, 0.0, math.pi), (0.0, math.pi, math.pi)]
    rows = [list(shape) for shape in shapes[:count]]
    while len(rows) < count:
        rows.append(list(rng.uniform(-math.pi, math.pi, joints)))
    Q = np.array(rows, dtype=float).reshape(count, joints)
    Q[:, 0] += np.radians(30.0 + 360.0 * np.arange(count) / max(count, 1))
    Q[:, 0] = wrap_angle(Q[:, 0])
    return Q


def _radius_text(low: float, high: float) -> str:
    if low == high:
        return f"r = {short_text(low, 4)}"
    if low == 0.0:
        return f"r ≤ {short_text(high, 4)}"
    return f"{short_text(low, 4)} ≤ r ≤ {short_text(high, 4)}"


def _draw_reachable(ax, points: np.ndarray, reachable: tuple[float, float]) -> None:
    """The sampled tool positions (faint dots) and the reachable boundary circles (black)."""
    from matplotlib.patches import Circle

    ax.plot(
        points[:, 0], points[:, 1], linestyle="none", marker=".", markersize=1.5, color="tab:blue",
        alpha=0.25, rasterized=True, label=f"tool, {len(points)} random configurations",
    )
    r_min, r_max = reachable
    reach_label = f"reachable boundary ({_radius_text(r_min, r_max)})"
    for radius in (r_max, r_min):
        if radius > 0.0:
            ax.add_patch(Circle((0.0, 0.0), radius, fill=False, edgecolor="black", linewidth=1.4, label=reach_label))
            reach_label = None


def _draw_dexterous(ax, dexterous) -> None:
    """The dexterous set: red circles, the area between them shaded (a marker for the base point alone)."""
    from matplotlib.patches import Annulus, Circle

    dext_label = "dexterous (" + ", ".join(_radius_text(lo, hi) for lo, hi in dexterous) + ")"
    for low, high in dexterous:
        if high == 0.0:
            ax.plot([0.0], [0.0], marker="o", markersize=9, color="red", fillstyle="none", linestyle="none",
                    label=dext_label)
        else:
            if high > low:
                shade = Circle((0.0, 0.0), high) if low == 0.0 else Annulus((0.0, 0.0), high, high - low)
                shade.set(facecolor="red", alpha=0.12, edgecolor="none")
                ax.add_patch(shade)
            for radius in (low, high):
                if radius > 0.0:
                    ax.add_patch(Circle((0.0, 0.0), radius, fill=False, edgecolor="red", linewidth=1.2,
                                        label=dext_label))
                    dext_label = None
        dext_label = None


def _draw_arms(ax, Q: np.ndarray, values: tuple[float, ...]) -> None:
    """The arm at each configuration of ``Q`` as a polyline: base (blue), joints (cyan, magenta), tool (green)."""
    colours = ["0.15", "tab:purple", "tab:brown", "tab:olive", "tab:gray"]
    joint_colours = ["cyan", "magenta", "gold"]
    for k, (q, chain) in enumerate(zip(Q, chain_points(Q, values))):
        degrees = ", ".join(number_text(v, 0) for v in np.degrees(q))
        ax.plot(chain[:, 0], chain[:, 1], color=colours[k % len(colours)], linewidth=2.2,
                label=f"q = ({degrees}) deg", zorder=3)
        ax.plot(0.0, 0.0, marker="o", markersize=8, color="blue", fillstyle="none", zorder=4)
        for j in range(1, len(values)):
            ax.plot(chain[j, 0], chain[j, 1], marker="o", markersize=7, color=joint_colours[j - 1],
                    markeredgecolor=joint_colours[j - 1], fillstyle="none", markeredgewidth=1.8, zorder=4)
        ax.plot(chain[-1, 0], chain[-1, 1], marker="o", markersize=7, color="green", zorder=4)


def plot_planar_workspace(
    lengths,
    path,
    *,
    n_samples: int = 20000,
    configurations: int = 3,
    seed: int = 0,
) -> Path:
    """Draw the workspace of a planar 2R or 3R arm to a PNG or SVG file.

    The picture shows the tool positions of ``n_samples`` random
    configurations, the analytic reachable boundary circles (black), for 3R
    the dexterous workspace (red circles, shaded), and a few configurations
    as link polylines: base (blue), joints (cyan, magenta), tool (green), as
    in the seed's 3R figure. Equal aspect, a legend, the radii in the title.

    Parameters
    ----------
    lengths : sequence of float
        ``(l1, l2)`` or ``(l1, l2, l3)`` in metres, each > 0.
    path : str or path-like
        Output file; the suffix ``.png`` or ``.svg`` picks the format. Its
        folder must exist: none is created (:mod:`manipkit.outputs`).
    n_samples : int, keyword-only
        Random configurations to sample (joint angles uniform in [-pi, pi)).
    configurations : int, keyword-only
        Arm drawings: first straight and folded ones (for 3R the seed's
        ``(0, 0, 0)``, ``(0, pi, 0)``, ``(0, 0, pi)``, ``(0, pi, pi)``, each
        turned by its own q1), then random ones.
    seed : int, keyword-only
        Seeds the random samples and configurations, so the file is
        reproducible.

    Returns
    -------
    Path
        ``path``, written.

    Raises
    ------
    PlanarArmError
        Lengths that are not 2 or 3 positive numbers, a suffix other than
        ``.png``/``.svg``, a bad ``configurations``.
    OutputError
        ``cannot write PATH: reason``: a missing folder or a folder as
        ``path`` (checked before sampling), a full disk, no permission.

    Examples
    --------
    >>> import tempfile, os
    >>> out = plot_planar_workspace([4, 2, 1], os.path.join(tempfile.mkdtemp(), "ws.png"), n_samples=500)
    >>> out.read_bytes()[:8] == b"\\x89PNG\\r\\n\\x1a\\n"
    True
    """
    # Over 80 lines: half of it is the docstring; the drawing steps are the _draw_* helpers.
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    values = _planar_lengths(lengths)
    ws = planar_workspace(values)
    path = writable_path(path)
    if path.suffix.lower() not in _PLOT_SUFFIXES:
        raise PlanarArmError(f"cannot write '{path.name}': use a file name ending in .png or .svg")
    if isinstance(configurations, bool) or not isinstance(configurations, (int, np.integer)) or configurations < 0:
        raise PlanarArmError(f"configurations = {configurations!r} must be a whole number >= 0")
    rng = np.random.default_rng(seed)
    points = sample_planar_workspace(values, n_samples, rng=rng)

    figure = Figure(figsize=(7.5, 7.5))
    FigureCanvasAgg(figure)
    ax = figure.add_subplot()
    ax.set_aspect("equal", adjustable="box")
    r_min, r_max = ws.reachable
    limit = 1.12 * r_max
    ax.set_xlim(-limit, limit)
    ax.set_ylim(-limit, limit)
    ax.grid(True, color="0.9", linewidth=0.6)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")

    _draw_reachable(ax, points, ws.reachable)

    _draw_dexterous(ax, ws.dexterous)
    _draw_arms(ax, _showcase_configurations(int(configurations), len(values), rng), values)

    lengths_text = ", ".join(short_text(v, 4) for v in values)
    if ws.dexterous:
        dext_text = ", ".join(_radius_text(lo, hi) for lo, hi in ws.dexterous)
    else:
        dext_text = "empty"
    ax.set_title(
        f"planar {len(values)}R workspace, l = ({lengths_text}) m\n"
        f"reachable {_radius_text(r_min, r_max)}; dexterous {dext_text}",
        fontsize=11,
    )
    legend = ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.09), ncol=2, fontsize=8, frameon=False)
    sample_handle = legend.legend_handles[0]  # the sample dots, drawn tiny and faint in the plot
    sample_handle.set_markersize(8)
    sample_handle.set_alpha(0.6)
    with writing(path) as target:
        figure.savefig(target, dpi=110, bbox_inches="tight")
    return path


def planar_link_lengths(chain: Chain | Robot, *, base: str | None = None, tip: str | None = None,
                        tol: float = 1e-9) -> tuple[float, ...]:
    """Link lengths of a loaded planar arm, read off its chain's joint axes at the default configuration.

    ``chain`` is a :class:`~manipkit.kinematics.chain.Chain` or a robot with
    ``base=`` and ``tip=`` (defaults ``base_link``, ``ee_link``). The arm is
    planar when every joint is revolute about the same axis direction as the
    first and all joint origins and the tip lie in one plane perpendicular to
    it. The lengths are the distances between consecutive joint axes (their
    origins, :meth:`Chain.axes`) and from the last axis to the tip.

    Raises
    ------
    PlanarArmError
        If the chain is not a planar 2R or 3R arm.
    """
    chain = chain_of(chain, "planar_link_lengths", base=base, tip=tip)
    name = chain.robot.name
    if chain.n not in (2, 3):
        raise PlanarArmError(f"robot '{name}' has {chain.n} joints from {chain.base} to {chain.tip}; the planar "
                             "workspace needs a 2R or 3R arm")
    axes = chain.axes()
    if axes.prismatic.any():
        joint = chain.joint_names[int(axes.joint[np.flatnonzero(axes.prismatic)[0]])]
        raise PlanarArmError(f"joint '{joint}' is prismatic; the planar workspace needs revolute joints")
    points = [*axes.point, chain.fk(chain.q())[:3, 3]]
    normal = axes.direction[0]
    if any(np.linalg.norm(np.cross(normal, axis)) > tol for axis in axes.direction):
        raise PlanarArmError(f"robot '{name}': the joint axes are not parallel, so it is not a planar arm")
    if any(abs((p - points[0]) @ normal) > tol for p in points):
        raise PlanarArmError(f"robot '{name}': the joints do not lie in one plane, so it is not a planar arm")
    return tuple(float(np.linalg.norm(b - a)) for a, b in zip(points[:-1], points[1:]))
