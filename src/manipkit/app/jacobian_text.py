"""A Jacobian report in data and in words, the same for ``manipkit jacobian`` and the viewer's overlay.

The report comes from :func:`manipkit.analysis.jacobian_report.jacobian_report`
(the one place that decides "singular"); here it is only laid out:
:func:`singularity_data` (JSON-ready) and :func:`singularity_lines` (text).
Conventions (docs/architecture.md): rows ``vx vy vz wx wy wz`` (m/s of the
frame's origin, then rad/s), directions in the report's axes (the base's
with ``reference="base"``), joint motions as unit vectors of joint rates.

The sentences say what stays still and nothing more: "leave the frame still"
only when the origin does not move and the frame does not turn; "keep the
origin still and turn the frame at W rad/s about (x, y, z)" when only the
origin stays.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from manipkit.analysis.jacobian_report import ROW_NAMES
from manipkit.text import short_text

if TYPE_CHECKING:
    from manipkit.analysis.jacobian_report import JacobianReport, NullMotion

__all__ = ["singularity_data", "singularity_lines"]

_DIGITS = 3  # significant digits of directions, rates and joint motions
_ZERO = 1e-9  # entries of a unit vector at most this print as 0


def singularity_data(report: JacobianReport) -> dict:
    """The ranks, the decision and what is lost, JSON-ready.

    Keys: ``rank``, ``generic_rank`` (all rows, angular ones times the
    report's length), ``rank_translation``, ``generic_rank_translation``,
    ``rank_rotation``, ``generic_rank_rotation``, ``singular_tol``,
    ``movable_rows`` (row names), ``singular``, ``singular_families``
    (``{"name", "condition"}`` each), ``same_axis`` (lists of joint names),
    ``lost_directions`` (``{"rows", "direction"}``: rows ``translation``,
    ``rotation`` (3 entries) or ``all`` (6, angular ones times the length)),
    ``lost_motions`` (``{"joint_rates": {joint: rate}, "velocity",
    "angular_velocity", "still": "frame" | "origin"}``).
    """
    names = report.joint_names
    return {
        "rank": report.rank,
        "generic_rank": report.generic_rank,
        "rank_translation": report.rank_translation,
        "generic_rank_translation": report.generic_rank_translation,
        "rank_rotation": report.rank_rotation,
        "generic_rank_rotation": report.generic_rank_rotation,
        "singular_tol": report.tol,
        "movable_rows": [ROW_NAMES[i] for i in report.movable_rows],
        "singular": report.singular,
        "singular_families": [{"name": f.name, "condition": f.condition} for f in report.families],
        "same_axis": [[names[k] for k in group] for group in report.same_axis],
        "lost_directions": [{"rows": lost.rows, "direction": lost.direction.tolist()} for lost in report.lost],
        "lost_motions": [
            {
                "joint_rates": dict(zip(names, motion.joint_rates.tolist())),
                "velocity": motion.velocity.tolist(),
                "angular_velocity": motion.angular_velocity.tolist(),
                "still": motion.still,
            }
            for motion in report.motions
        ],
    }


def singularity_lines(report: JacobianReport) -> list[str]:
    """The ranks, ``singular: yes/no`` with every family that holds, then one indented line per finding.

    Examples
    --------
    >>> import manipkit
    >>> from manipkit.analysis.jacobian_report import jacobian_report
    >>> chain = manipkit.load("planar_2r").chain("base_link", "ee_link")
    >>> print("\\n".join(singularity_lines(jacobian_report(chain, [0.0, 0.0]))))
    rank: 2 of 2 (all rows), 1 of 2 (translation rows), 1 of 1 (rotation rows), singular values below 1e-09 not counted
    rows the arm moves: vx, vy, wz (vz, wx, wy are 0 at every configuration, so never lost)
    singular: yes (family: elbow straight: joint2 = 0 or 180 deg)
      the origin cannot move along (1, 0, 0)
      joint1 and joint2 moving as (-0.447, 0.894) keep the origin still and turn the frame at 0.447 rad/s about (0, 0, 1)
    """
    ranks = ", ".join(f"{rank} of {generic} ({rows} rows)"
                      for rows, (rank, generic) in ((rows, report.ranks(rows)) for rows in ("all", "translation", "rotation")))
    lines = [f"rank: {ranks}, singular values below {short_text(report.tol)} not counted"]
    never = [name for i, name in enumerate(ROW_NAMES) if i not in report.movable_rows]
    if never and report.joint_names:
        moved = ", ".join(ROW_NAMES[i] for i in report.movable_rows) or "none"
        lines.append(f"rows the arm moves: {moved} ({', '.join(never)} {'is' if len(never) == 1 else 'are'} 0 at every "
                     "configuration, so never lost)")
    lines.append(_decision(report))
    if not report.singular:
        return lines
    names = report.joint_names
    for group in report.same_axis:
        prismatic = report.chain.joints[group[0]].type == "prismatic"
        lines.append(f"  {_and([names[k] for k in group])} {'slide along the same direction' if prismatic else 'turn about the same axis'}")
    for lost in report.lost:
        lines.append("  " + _lost_text(lost.rows, lost.direction, report.length))
    lines += ["  " + _motion_text(motion, names) for motion in report.motions]
    return lines


def _decision(report: JacobianReport) -> str:
    families = "; ".join(f"{f.name}: {f.condition}" for f in report.families)
    which = "family" if len(report.families) == 1 else "families"
    if report.singular:
        return "singular: yes" + (f" ({which}: {families})" if families else "")
    if families:
        return f"singular: no (within {short_text(report.family_tol)} of the {which}: {families})"
    return "singular: no"


def _and(words: list[str]) -> str:
    return words[0] if len(words) == 1 else ", ".join(words[:-1]) + " and " + words[-1]


def _vector(values) -> str:
    return "(" + ", ".join(short_text(v, _DIGITS, zero=_ZERO) for v in np.asarray(values, dtype=float)) + ")"


def _lost_text(rows: str, direction: np.ndarray, length: float) -> str:
    if rows == "translation":
        return f"the origin cannot move along {_vector(direction)}"
    if rows == "rotation":
        return f"the frame cannot turn about {_vector(direction)}"
    shown = [i for i in range(6) if abs(direction[i]) > _ZERO]
    return (f"the frame cannot move as ({', '.join(ROW_NAMES[i] for i in shown)}) = {_vector(direction[shown])} "
            f"(moving and turning at once; angular rows times {short_text(length)} m)")


def _motion_text(motion: NullMotion, names) -> str:
    joints = motion.joints
    w = motion.angular_velocity
    if len(joints) == 1:
        who, verbs = f"{names[joints[0]]} alone", ("leaves", "keeps", "turns")
    else:
        who = f"{_and([names[k] for k in joints])} moving as {_vector(motion.joint_rates[list(joints)])}"
        verbs = ("leave", "keep", "turn")
    if motion.still == "frame":
        return f"{who} {verbs[0]} the frame still"
    rate = float(np.linalg.norm(w))
    return (f"{who} {verbs[1]} the origin still and {verbs[2]} the frame at {short_text(rate, _DIGITS)} rad/s "
            f"about {_vector(w / rate)}")
