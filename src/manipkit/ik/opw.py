"""The OPW parameters of a spherical-wrist arm, read from its geometry and checked by FK: :func:`opw_parameters`.

ROS-Industrial's opw_kinematics (after Brandstoetter, Angerer and Hofbaur,
"An analytical solution of the inverse kinematics problem of industrial
serial manipulators with an ortho-parallel basis and a spherical wrist",
2014) describes these arms by seven lengths and two per-joint vectors:

- ``c1``: height of axis 2 above the base; ``a1``: its offset from axis 1;
  ``b``: the lateral offset of the wrist centre;
- ``c2``: axis 2 to axis 3; ``c3``: axis 3 to the wrist centre along axis 4,
  ``a2``: the elbow offset across it; ``c4``: wrist centre to the tool;
- OPW joint angles ``theta_i = sign_corrections[i] * q_i - offsets[i]``.

In the OPW zero pose the arm points straight up along the base z axis and
the tool's z axis is axis 6. The parameters are read from the chain's axes
at ``q0`` (:mod:`manipkit.ik.families`) and then checked: the OPW
forward kinematics (:func:`opw_fk`) must reproduce the chain's compiled FK
at random configurations; ``fk_error`` is the largest difference found.
A chain whose base or tip frame is not OPW's (axis 1 off the base z axis,
a tool frame whose z is not axis 6) has none: the error says which.

Given a chain object; never imports the kinematics layer.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from manipkit.closed_form.arms import rotation_matrix
from manipkit.closed_form.checks import quantity_text
from manipkit.errors import ClosedFormIKError
from manipkit.ik.families import OPW, Family, chain_family
from manipkit.ik.ideal_arm import ideal_arm

if TYPE_CHECKING:
    from manipkit.kinematics.chain import Chain

__all__ = ["OPWParameters", "opw_fk", "opw_parameters"]

_X, _Y, _Z = np.eye(3)


@dataclass(frozen=True)
class OPWParameters:
    """opw_kinematics' description of an arm (metres, radians), and how well it reproduces the chain."""

    a1: float
    a2: float
    b: float
    c1: float
    c2: float
    c3: float
    c4: float
    offsets: tuple[float, ...]
    sign_corrections: tuple[int, ...]
    fk_error: float

    def __str__(self) -> str:
        lengths = ", ".join(f"{name} = {quantity_text(getattr(self, name))}"
                            for name in ("a1", "a2", "b", "c1", "c2", "c3", "c4"))
        offsets = ", ".join(quantity_text(v) for v in self.offsets)
        signs = ", ".join(str(s) for s in self.sign_corrections)
        return (f"OPW parameters: {lengths} m; offsets [{offsets}] rad; sign_corrections [{signs}]; "
                f"checked by FK: largest difference {quantity_text(self.fk_error)}")


def _wrap(angle: float) -> float:
    return math.pi - (math.pi - angle) % (2.0 * math.pi)


def opw_fk(parameters: OPWParameters, q) -> np.ndarray:
    """The OPW forward kinematics: ``T_base_tool`` (4, 4) for joint values ``q`` (6,), as opw_kinematics computes it.

    Examples
    --------
    >>> p = OPWParameters(0.1, -0.135, 0.0, 0.615, 0.705, 0.755, 0.085, (0.0,) * 6, (1,) * 6, 0.0)
    >>> opw_fk(p, np.zeros(6))[:3, 3].round(6)  # straight up: x = a1 + a2, z = c1 + c2 + c3 + c4
    array([-0.035,  0.   ,  2.16 ])
    """
    s = np.asarray(parameters.sign_corrections, dtype=float)
    t = s * np.asarray(q, dtype=float) - np.asarray(parameters.offsets)
    psi3 = math.atan2(parameters.a2, parameters.c3)
    k = math.hypot(parameters.a2, parameters.c3)
    cx1 = parameters.c2 * math.sin(t[1]) + k * math.sin(t[1] + t[2] + psi3) + parameters.a1
    cz1 = parameters.c2 * math.cos(t[1]) + k * math.cos(t[1] + t[2] + psi3)
    centre = rotation_matrix(_Z, t[0]) @ np.array([cx1, parameters.b, cz1]) + np.array([0.0, 0.0, parameters.c1])
    R = (rotation_matrix(_Z, t[0]) @ rotation_matrix(_Y, t[1] + t[2])
         @ rotation_matrix(_Z, t[3]) @ rotation_matrix(_Y, t[4]) @ rotation_matrix(_Z, t[5]))
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = centre + parameters.c4 * R[:, 2]
    return T


def _sign(value: float, what: str) -> int:
    if abs(abs(value) - 1.0) > 1e-6:
        raise ClosedFormIKError(f"no OPW parameters: {what} is not along its OPW axis (cosine {quantity_text(value)})")
    return 1 if value > 0 else -1


def opw_parameters(chain: Chain, *, family: Family | None = None, samples: int = 8, check_tol: float = 1e-9) -> OPWParameters:
    """opw_kinematics' parameters of a spherical-wrist arm with axes 2 || 3, checked by FK.

    Raises :class:`ClosedFormIKError` when the chain is not of that family
    (read base to tip), when its base or tool frame is not OPW's, or when
    the OPW forward kinematics misses the chain's by more than ``check_tol``
    at one of ``samples`` random configurations (the message gives the miss).
    """
    # Over 80 lines: one reading of the seven lengths, six signs and six offsets, in the order the angles nest.
    family = chain_family(chain) if family is None else family
    if family.kind != OPW or family.reversed:
        raise ClosedFormIKError(f"no OPW parameters: the chain is '{family.kind}'"
                                f"{' read tip to base' if family.reversed else ''}, not a spherical wrist with axes "
                                "2 || 3 read base to tip")
    arm = ideal_arm(family)
    h, p, scale, q0 = arm.h, arm.p, family.geometry.scale, family.geometry.q0
    if np.any(np.abs(np.abs(scale) - 1.0) > 1e-12):
        raise ClosedFormIKError("no OPW parameters: a joint is scaled (a mimic multiplier); OPW signs are +-1")
    off_axis = math.hypot(*np.cross(h[0], p[0])[:2]) if abs(h[0][2]) > 0 else math.inf
    if abs(abs(h[0][2]) - 1.0) > 1e-9 or math.hypot(p[0][0], p[0][1]) > 1e-9:
        raise ClosedFormIKError(f"no OPW parameters: axis 1 is not the base z axis (direction {h[0].round(6).tolist()}, "
                                f"{quantity_text(off_axis)} m from the origin); OPW needs the base frame on axis 1")
    c = arm.points["wrist"]
    M = family.geometry.M
    # joint 1: OPW's axis 2 is R_z(t1) y with the shoulder at +x (a1 >= 0)
    t1 = math.atan2(-h[1][0], h[1][1])
    if (p[1] @ (rotation_matrix(_Z, t1) @ _X)) < 0.0:
        t1 = _wrap(t1 + math.pi)
    R1 = rotation_matrix(_Z, t1)
    x1, y1 = R1 @ _X, R1 @ _Y
    a1, b, c1 = float(p[1] @ x1), float(c @ y1), float(p[1][2])
    upper = p[2] - p[1]
    t2 = math.atan2(upper @ x1, upper[2])
    c2 = math.hypot(upper @ x1, upper[2])
    fore = c - p[2]
    t23 = math.atan2(h[3] @ x1, h[3][2])  # OPW's axis 4 at t2 + t3 is (sin, 0, cos) in frame 1
    if (fore @ h[3]) * (1.0 if (h[3] @ (math.sin(t23) * x1 + math.cos(t23) * _Z)) > 0 else -1.0) < 0.0:
        t23 = _wrap(t23 + math.pi)  # the wrist centre ahead of axis 3 along axis 4: c3 > 0
    R0c = R1 @ rotation_matrix(_Y, t23)
    c3 = float(fore @ R0c[:, 2])
    a2 = float(fore @ R0c[:, 0])
    R_tool = M[:3, :3]
    if np.linalg.norm(np.cross(R_tool[:, 2], h[5])) > 1e-9:
        raise ClosedFormIKError("no OPW parameters: the tool frame's z axis is not axis 6 (OPW's tool frame is "
                                "the flange, z along axis 6); choose that frame as the tip")
    c4 = float((M[:3, 3] - c) @ R_tool[:, 2])
    if np.linalg.norm(np.cross(M[:3, 3] - c, R_tool[:, 2])) > 1e-9:
        raise ClosedFormIKError("no OPW parameters: the tool origin is off axis 6; OPW's tool sits on it")
    h5c = R0c.T @ h[4]
    t4 = math.atan2(-h5c[0], h5c[1])  # OPW's axis 5 is R_0c R_z(t4) y: taken along ours (sign +1)
    R_ce = R0c.T @ R_tool
    rest = rotation_matrix(_Z, t4).T @ R_ce  # = R_y(t5) R_z(t6)
    t5 = math.atan2(rest[0, 2], rest[2, 2])
    last = rotation_matrix(_Y, t5).T @ rest
    t6 = math.atan2(last[1, 0], last[0, 0])
    theta = np.array([t1, t2, t23 - t2, t4, t5, t6])
    axes_opw = [_Z, y1, y1, R0c[:, 2], R0c @ rotation_matrix(_Z, t4) @ _Y, R_tool[:, 2]]
    signs = tuple(_sign(float(h[i] @ axes_opw[i]) * float(np.sign(scale[i])), f"axis {i + 1}") for i in range(6))
    offsets = tuple(_wrap(float(signs[i] * q0[i] - theta[i])) + 0.0 for i in range(6))
    params = OPWParameters(a1, a2, b, c1, c2, c3, c4, offsets, signs, 0.0)
    rng = np.random.default_rng(0)
    error = 0.0
    for q in rng.uniform(-math.pi, math.pi, size=(samples, 6)):
        difference = opw_fk(params, q) - np.asarray(chain.fk(q))
        error = max(error, float(np.max(np.abs(difference))))
    if error > check_tol:
        raise ClosedFormIKError(f"no OPW parameters: the OPW forward kinematics misses the chain by {quantity_text(error)} "
                                f"(> {quantity_text(check_tol)}); the arm is not ortho-parallel in OPW's sense")
    return OPWParameters(a1, a2, b, c1, c2, c3, c4, offsets, signs, error)
