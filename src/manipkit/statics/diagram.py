"""The payload diagram as vendors draw it: the largest payload mass against the centre of gravity's offset.

For each offset ``d`` (m) along a direction of the tip frame (its z axis, the
flange's normal, by default), the payload capacity
(:mod:`manipkit.statics.capacity`) is computed at every configuration given
(sampled inside the limits, or a list of poses); the diagram's curve is the
**worst case** over them (the smallest capacity), with the configuration and
the joint that set it, and the median beside it. The torque is affine in the
mass and, at a fixed configuration, affine in the offset, so each point is
the closed form, batched over the configurations.

Examples
--------
>>> import manipkit
>>> d = payload_diagram(manipkit.load("iiwa14"), [0.0, 0.2], samples=50, seed=0)
>>> d.offsets.tolist(), bool(d.worst[0] >= d.worst[1])  # a longer lever arm carries less
([0.0, 0.2], True)
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from manipkit.bounds import MAX_COUNT, count
from manipkit.errors import OptionError
from manipkit.kinematics.chain import chain_of
from manipkit.outputs import writing
from manipkit.statics.capacity import capacity_from_parts
from manipkit.statics.torques import (
    GRAVITY,
    Payload,
    effort_limits,
    gravity_in_base,
    payload_torques,
    static_torques,
)

if TYPE_CHECKING:
    from manipkit.kinematics.chain import Chain
    from manipkit.kinematics.robot import Robot

__all__ = ["PayloadDiagram", "draw_payload_diagram", "payload_diagram"]


@dataclass(frozen=True)
class PayloadDiagram:
    """Capacity against CoG offset (see the module).

    Attributes
    ----------
    offsets : ndarray (k,)
        m along ``direction`` (tip frame's axes).
    worst, median : ndarray (k,)
        kg over the configurations (``inf`` where nothing bounds the mass).
    worst_configuration : ndarray (k, n)
        The chain vector where the worst case is met.
    worst_joint : tuple of str or None
        The joint that saturates there.
    direction : ndarray (3,)
    configurations : int
        How many configurations each point is the worst over.
    robot, base, tip : str
    inertia_grade : str
        The robot's inertia-audit grade (:func:`manipkit.statics.audit.inertia_grade`).
    """

    offsets: np.ndarray
    worst: np.ndarray
    median: np.ndarray
    worst_configuration: np.ndarray
    worst_joint: tuple
    direction: np.ndarray
    configurations: int
    robot: str
    base: str
    tip: str
    inertia_grade: str = ""

    def as_dict(self) -> dict:
        """JSON-ready (``null`` for an unbounded mass)."""
        def finite(values):
            return [float(v) if math.isfinite(v) else None for v in values]

        return {"robot": self.robot, "base": self.base, "tip": self.tip, "direction": self.direction.tolist(),
                "configurations": self.configurations, "offsets": self.offsets.tolist(),
                "worst_mass": finite(self.worst), "median_mass": finite(self.median),
                "worst_joint": list(self.worst_joint), "worst_configuration": self.worst_configuration.tolist(),
                "inertia_grade": self.inertia_grade}


def payload_diagram(robot: Robot | Chain, offsets, *, Q=None, samples: int = 1000, seed=0, direction=(0.0, 0.0, 1.0),
                    gravity=GRAVITY, base: str | None = None, tip: str | None = None) -> PayloadDiagram:
    """The worst-case payload capacity over configurations ``Q`` (or ``samples`` drawn inside the limits) per offset.

    Parameters
    ----------
    offsets : array_like (k,)
        CoG distances from the tip's origin along ``direction`` (m, >= 0).
    Q : array_like (N, n), optional
        Chain vectors; default ``chain.sample(samples, seed=seed)``.
    direction : (3,) float
        In the tip frame's axes; normalised.
    """
    chain = chain_of(robot, "payload_diagram", base=base, tip=tip)
    offsets = np.asarray(offsets, dtype=float).reshape(-1)
    if offsets.size == 0 or not np.all(np.isfinite(offsets)) or np.any(offsets < 0):
        raise OptionError("offsets: give one or more finite distances >= 0 (m)")
    count(offsets.size, "the number of offsets", minimum=1, maximum=MAX_COUNT)
    direction = np.asarray(direction, dtype=float).reshape(-1)
    if direction.shape != (3,) or not np.all(np.isfinite(direction)) or np.linalg.norm(direction) == 0:
        raise OptionError("direction: give 3 finite numbers, not all 0 (tip frame's axes)")
    direction = direction / np.linalg.norm(direction)
    Q = chain.sample(samples, seed=seed) if Q is None else chain.rows(Q).reshape(-1, chain.n)
    if Q.shape[0] == 0:
        raise OptionError("payload_diagram needs at least one configuration")
    limits = effort_limits(chain)
    if np.isnan(limits).all():
        raise OptionError(f"no effort limit on any joint of the chain {chain.base} -> {chain.tip}: a payload "
                          "diagram needs them (URDF <limit effort=...>)")
    plain = static_torques(chain, Q, gravity=gravity)
    unloaded = plain.gravity
    whole = np.ascontiguousarray(np.broadcast_to(chain.robot.q(), (Q.shape[0], len(chain.robot.joint_names))))
    whole[:, chain.columns] = Q
    g_base = gravity_in_base(chain, whole, gravity)
    worst, median, where, joints = [], [], [], []
    for d in offsets:
        per_kg = payload_torques(chain, whole, Payload(1.0, d * direction), g_base)
        m, k, _ = capacity_from_parts(unloaded, per_kg, -limits, limits)
        i = int(np.argmin(m))
        worst.append(float(m[i]))
        median.append(float(np.median(m)))
        where.append(Q[i])
        joints.append(None if k[i] < 0 else chain.joint_names[int(k[i])])
    name = chain.robot.name
    return PayloadDiagram(offsets, np.array(worst), np.array(median), np.array(where), tuple(joints), direction,
                          int(Q.shape[0]), name, chain.base, chain.tip, plain.inertia_grade)


def draw_payload_diagram(diagram: PayloadDiagram, path, *, dpi: int = 120) -> None:
    """Draw ``diagram`` (mass against offset, worst case and median) as a PNG file at ``path`` (written atomically)."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6.4, 4.2))
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    x = diagram.offsets * 1000.0
    ax.plot(x, np.where(np.isfinite(diagram.worst), diagram.worst, np.nan), "o-", color="tab:red",
            label=f"worst case over {diagram.configurations} configurations")
    ax.plot(x, np.where(np.isfinite(diagram.median), diagram.median, np.nan), "--", color="tab:blue",
            label="median")
    d = ", ".join(f"{v:g}" for v in np.round(diagram.direction, 3))
    ax.set_xlabel(f"centre of gravity offset along ({d}) of {diagram.tip} (mm)")
    ax.set_ylabel("largest payload held still (kg)")
    ax.set_title(f"{diagram.robot}: payload against CoG offset (static, effort limits of the URDF)", fontsize=9)
    ax.set_ylim(bottom=0)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    with writing(path) as target:
        fig.savefig(target, format="png", dpi=dpi, metadata={"Software": None})
