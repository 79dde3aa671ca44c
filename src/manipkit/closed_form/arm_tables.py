"""Standard DH tables of the decoupled textbook arms (SCARA, Stanford arm, elbow arm) and their parameter checks.

Conventions (docs/architecture.md): standard DH (Spong),
``A_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i)``; metres and radians. At
their default parameters the tables are the bundled ``robots/dh/*.yaml``
tables and agree with the bundled ``robots/*.urdf.xacro`` descriptions.
:mod:`manipkit.ik.decoupled` solves them.
"""

from __future__ import annotations

import math

import numpy as np

from manipkit.closed_form.checks import quantity_text
from manipkit.dh.table import DHRow, DHTable
from manipkit.errors import ClosedFormIKError

__all__ = [
    "ELBOW_VARIABLES",
    "SCARA_JOINTS",
    "SCARA_VARIABLES",
    "SIX_JOINTS",
    "STANFORD_VARIABLES",
    "elbow_dh_table",
    "finite_number",
    "positive_length",
    "scara_dh_table",
    "stanford_dh_table",
    "stroke_limits",
]

#: Joint names of the bundled URDFs, in table order.
SIX_JOINTS = ("joint1", "joint2", "joint3", "joint4", "joint5", "joint6")
SCARA_JOINTS = SIX_JOINTS[:4]
#: The joint variables by their textbook names (Spong), in table order.
SCARA_VARIABLES = ("theta1", "theta2", "d3", "theta4")
STANFORD_VARIABLES = ("theta1", "theta2", "d3", "theta4", "theta5", "theta6")
ELBOW_VARIABLES = ("theta1", "theta2", "theta3", "theta4", "theta5", "theta6")


def finite_number(value, what: str) -> float:
    """A finite scalar, or :class:`ClosedFormIKError` naming ``what``."""
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ClosedFormIKError(f"{what} must be a number, got {value!r:.80}") from None
    if array.ndim != 0:
        raise ClosedFormIKError(f"{what} must be a single number, got shape {array.shape}")
    number = float(array)
    if not math.isfinite(number):
        raise ClosedFormIKError(f"{what} = {number} is not finite; give a finite number")
    return number


def positive_length(value, what: str) -> float:
    """A link length (m): a finite scalar > 0."""
    number = finite_number(value, what)
    if number <= 0.0:
        raise ClosedFormIKError(f"{what} = {quantity_text(number)} is not a valid link length; it must be > 0 (m)")
    return number


def stroke_limits(value, what: str, *, lowest: float | None = None) -> tuple[float, float]:
    """A prismatic joint's ``(lower, upper)`` limits (m), lower < upper (and >= ``lowest``)."""
    try:
        lower, upper = value
    except (TypeError, ValueError):
        raise ClosedFormIKError(f"{what} must be a pair (lower, upper) in metres, got {value!r:.80}") from None
    lower, upper = finite_number(lower, f"{what}[0]"), finite_number(upper, f"{what}[1]")
    if not lower < upper:
        raise ClosedFormIKError(f"{what} = ({quantity_text(lower)}, {quantity_text(upper)}): the lower limit must be below the upper one")
    if lowest is not None and lower < lowest:
        raise ClosedFormIKError(
            f"{what} = ({quantity_text(lower)}, {quantity_text(upper)}): the lower limit must be >= {quantity_text(lowest)} m "
            "(the boom cannot reach back through the shoulder)"
        )
    return lower, upper



def scara_dh_table(*, a1: float = 0.35, a2: float = 0.25, d1: float = 0.4, d4: float = 0.05,
                   d3_limits: tuple[float, float] = (0.0, 0.3)) -> DHTable:
    """Standard DH table of the SCARA (Spong's SCARA, base height in row 1).

    Parameters
    ----------
    a1, a2 : float, keyword-only
        Link lengths (m), > 0.
    d1 : float, keyword-only
        Height of the arm above the base frame (m).
    d4 : float, keyword-only
        Tool length below the quill tip (m).
    d3_limits : (float, float), keyword-only
        Quill stroke (m); d3 slides the tool *down*.

    Returns
    -------
    DHTable
        Rows ``(a, alpha, d, theta)``: ``(a1, 0, d1, t1)``, ``(a2, 180 deg, 0, t2)``,
        ``(0, 0, d3, 0)`` prismatic, ``(0, 0, d4, t4)``; joints ``joint1 .. joint4``.
        The defaults are the bundled ``scara`` robot (robots/dh/scara.yaml).

    Examples
    --------
    >>> from manipkit.dh import dh_fk
    >>> dh_fk(scara_dh_table(), [0.0, 0.0, 0.1, 0.0])[:3, 3].round(12) + 0.0  # stretched along x, 0.1 down
    array([0.6 , 0.  , 0.25])
    """
    a1, a2 = positive_length(a1, "a1"), positive_length(a2, "a2")
    d1, d4 = finite_number(d1, "d1"), finite_number(d4, "d4")
    lower, upper = stroke_limits(d3_limits, "d3_limits")
    pi = math.pi
    rows = (
        DHRow(a1, 0.0, d1, 0.0, qlim=(-pi, pi), name="joint1"),
        DHRow(a2, pi, 0.0, 0.0, qlim=(-pi, pi), name="joint2"),
        DHRow(0.0, 0.0, 0.0, 0.0, type="prismatic", qlim=(lower, upper), name="joint3"),
        DHRow(0.0, 0.0, d4, 0.0, qlim=(-pi, pi), name="joint4"),
    )
    return DHTable(rows, "standard", "scara")


def stanford_dh_table(*, d1: float = 0.0, d2: float = 0.154, d6: float = 0.263,
                      d3_limits: tuple[float, float] = (0.1, 1.0)) -> DHTable:
    """Standard DH table of the Stanford arm in the frames of Spong's Example 3.5.

    Parameters
    ----------
    d1 : float, keyword-only
        Shoulder height above the base frame (m); Spong takes 0.
    d2 : float, keyword-only
        Shoulder offset (m).
    d6 : float, keyword-only
        Wrist centre to tool (m).
    d3_limits : (float, float), keyword-only
        Boom stroke (m), lower limit >= 0.

    Returns
    -------
    DHTable
        Rows ``(theta, d, a, alpha)``: ``(t1, d1, 0, -90)``, ``(t2, d2, 0, 90)``,
        ``(0, d3, 0, 0)`` prismatic, ``(t4, 0, 0, -90)``, ``(t5, 0, 0, 90)``,
        ``(t6, d6, 0, 0)``; joints ``joint1 .. joint6``. The defaults are the
        bundled ``stanford_arm`` robot (robots/dh/stanford_arm.yaml).

    Examples
    --------
    >>> from manipkit.dh import dh_fk
    >>> dh_fk(stanford_dh_table(), [0.0, 0.0, 0.5, 0.0, 0.0, 0.0])[:3, 3].round(12)  # boom up
    array([0.   , 0.154, 0.763])
    """
    d1, d2, d6 = finite_number(d1, "d1"), finite_number(d2, "d2"), finite_number(d6, "d6")
    lower, upper = stroke_limits(d3_limits, "d3_limits", lowest=0.0)
    pi, half = math.pi, math.pi / 2.0
    rows = (
        DHRow(0.0, -half, d1, 0.0, qlim=(-pi, pi), name="joint1"),
        DHRow(0.0, half, d2, 0.0, qlim=(-pi, pi), name="joint2"),
        DHRow(0.0, 0.0, 0.0, 0.0, type="prismatic", qlim=(lower, upper), name="joint3"),
        DHRow(0.0, -half, 0.0, 0.0, qlim=(-pi, pi), name="joint4"),
        DHRow(0.0, half, 0.0, 0.0, qlim=(-pi, pi), name="joint5"),
        DHRow(0.0, 0.0, d6, 0.0, qlim=(-pi, pi), name="joint6"),
    )
    return DHTable(rows, "standard", "stanford_arm")


def elbow_dh_table(*, d1: float = 0.4, a2: float = 0.45, a3: float = 0.4, d6: float = 0.1) -> DHTable:
    """Standard DH table of Spong's elbow manipulator with a spherical wrist.

    Parameters
    ----------
    d1 : float, keyword-only
        Shoulder height above the base frame (m).
    a2, a3 : float, keyword-only
        Upper arm and forearm (shoulder axis to wrist centre) lengths (m), > 0.
    d6 : float, keyword-only
        Wrist centre to tool (m).

    Returns
    -------
    DHTable
        Rows ``(a, alpha, d, theta)``: ``(0, 90, d1, t1)``, ``(a2, 0, 0, t2)``,
        ``(a3, 0, 0, t3)``, ``(0, -90, 0, t4)``, ``(0, 90, 0, t5)``,
        ``(0, 0, d6, t6)``; joints ``joint1 .. joint6``. The defaults are the
        bundled ``elbow_arm`` robot (robots/dh/elbow_arm.yaml).

    Examples
    --------
    >>> from manipkit.dh import dh_fk
    >>> dh_fk(elbow_dh_table(), np.zeros(6))[:3, 3].round(12) + 0.0  # arm along x, tool along -y
    array([ 0.85, -0.1 ,  0.4 ])
    """
    d1, d6 = finite_number(d1, "d1"), finite_number(d6, "d6")
    a2, a3 = positive_length(a2, "a2"), positive_length(a3, "a3")
    pi, half = math.pi, math.pi / 2.0
    rows = (
        DHRow(0.0, half, d1, 0.0, qlim=(-pi, pi), name="joint1"),
        DHRow(a2, 0.0, 0.0, 0.0, qlim=(-pi, pi), name="joint2"),
        DHRow(a3, 0.0, 0.0, 0.0, qlim=(-pi, pi), name="joint3"),
        DHRow(0.0, -half, 0.0, 0.0, qlim=(-pi, pi), name="joint4"),
        DHRow(0.0, half, 0.0, 0.0, qlim=(-pi, pi), name="joint5"),
        DHRow(0.0, 0.0, d6, 0.0, qlim=(-pi, pi), name="joint6"),
    )
    return DHTable(rows, "standard", "elbow_arm")
