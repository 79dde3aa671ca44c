"""The words of ``manipkit dh check``: a :class:`~manipkit.dh.check.DHCheck` and its diagnosis as sentences.

:func:`manipkit.dh.check.check_dh` returns the diagnosis as data
(:mod:`manipkit.dh.diagnosis`); here it is only worded, for the CLI (text
and JSON) and the notebooks. :func:`diagnosis_lines` gives every sentence,
the error summary first; :func:`fix_reason` the one a ``--fix`` file's
header repeats.

Numbers (docs/architecture.md): metres, and degrees for angles (the data is
in radians); lengths and vectors with six significant digits, entries within
1e-9 m or 1e-7 deg of zero (fitting noise) as 0; rpy is ``R = Rz(yaw)
Ry(pitch) Rx(roll)`` (roll 0 at gimbal lock). A base or tool transform
within ``RECONCILE_TOL`` of the identity is no transform. At most
``SHOWN_DIFFERENCES`` entries that differ from the derived table are listed.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from manipkit.dh.check import RECONCILE_TOL
from manipkit.dh.diagnosis import EntryChange
from manipkit.dh.entries import ANGLE_ENTRIES
from manipkit.dh.text import NOISE
from manipkit.spatial.rotations import rpy_from_matrix, wrap_angle
from manipkit.text import short_text, vector_text

if TYPE_CHECKING:
    from manipkit.dh.check import DHCheck
    from manipkit.dh.diagnosis import DHCorrection, DHDiagnosis, EndChange

__all__ = ["SHOWN_DIFFERENCES", "diagnosis_lines", "fix_reason"]

#: Entries that differ from the derived table listed one by one; the rest are counted.
SHOWN_DIFFERENCES = 12


def diagnosis_lines(check: DHCheck, *, summary: bool = True) -> list[str]:
    """Every sentence of the diagnosis, in order; none when the table agrees.

    Parameters
    ----------
    check : DHCheck
    summary : bool
        Start with the largest errors (``does not agree: ...``), when there
        were samples; ``manipkit dh check`` prints them in its own words and
        leaves this out of its text output.

    Examples
    --------
    >>> import manipkit
    >>> from manipkit.dh import DHRow, DHTable, check_dh
    >>> rows = [DHRow(4, 0, 0, 0), DHRow(2.5, 0, 0, 0), DHRow(1, 0, 0, 0)]  # planar_3r's a_2 is 2 m
    >>> check = check_dh(DHTable(rows, "standard"), manipkit.load("planar_3r"), samples=50)
    >>> print(diagnosis_lines(check)[0])  # doctest: +ELLIPSIS
    does not agree: max position error 0.5 m, max rotation error ... over 50 samples
    >>> print(diagnosis_lines(check, summary=False)[0])  # doctest: +ELLIPSIS
    row 2: a = 2.5 m, the URDF implies 2 m: reconciles them fully (remaining error ...)
    """
    diagnosis = check.diagnosis
    if diagnosis.kind == "agrees":
        return []
    if diagnosis.kind == "row count":
        return _row_count_lines(check)
    lines = [_summary_line(check)] if summary and check.samples else []
    if diagnosis.kind == "no joints":
        return lines + [_tool_text(diagnosis.tool)]
    if diagnosis.kind != "axes compared":
        (first, *others) = diagnosis.fixes
        lines.append(f"{_correction_text(first, check)}: reconciles them fully (remaining error {short_text(first.residual, 2)})")
        return lines + [f"or equally {_correction_text(other, check)}: reconciles them fully" for other in others]
    return lines + _axes_lines(check)


def fix_reason(check: DHCheck) -> str:
    """The first finding after the error summary, which a ``--fix`` file's header repeats: the correction behind
    ``check.candidate`` when a stage up to one reversed joint found it, else the first finding of the axes
    comparison (a reversed joint, or where the axes stop agreeing); "" when the table agrees."""
    return next(iter(diagnosis_lines(check, summary=False)), "")


def _summary_line(check: DHCheck) -> str:
    rotation = check.max_rotation_error
    return (
        f"does not agree: max position error {short_text(check.max_position_error, 4)} m, max rotation error "
        f"{short_text(rotation, 4)} rad ({short_text(math.degrees(rotation), 4)} deg) over {check.samples} samples"
    )


def _row_count_lines(check: DHCheck) -> list[str]:
    rows, joints, extra = check.diagnosis.rows, len(check.joints), check.diagnosis.extra_row
    lines = [
        f"the table has {rows} rows but the URDF chain {check.base} -> {check.tip} has {joints} movable joints"
        f" ({', '.join(check.joints) or 'none'}); rows map in order to those joints"
    ]
    if extra is not None:
        lines.append(
            f"the last row (a={short_text(extra.a)}, alpha={short_text(math.degrees(extra.alpha))} deg, "
            f"d={short_text(extra.d)}, theta={short_text(math.degrees(extra.theta))} deg) has no joint to map to: "
            "if it only places the tool, write it as `tool:` instead of a row"
        )
    elif rows < joints:
        lines.append(f"{joints - rows} joint(s) of the URDF chain have no row; check --base and --tip")
    else:
        lines.append(f"{rows - joints} row(s) too many; check --base and --tip")
    return lines


def _axes_lines(check: DHCheck) -> list[str]:
    """Stage 4: the reversed joints, where the axes stop agreeing, the fix tried, the derived table's entries."""
    diagnosis = check.diagnosis
    lines = [
        f"{_joint(check, j)} {_moves(diagnosis, j)} the other way: the table's z axis points opposite to the URDF "
        f"axis {_vector(diagnosis.axes[j - 1].urdf_direction)} at q = 0"
        for j in diagnosis.reversed_joints
    ]
    differing = diagnosis.differing_joints
    if differing:
        first = diagnosis.axes[differing[0] - 1]
        lines.append(f"the chains stop agreeing at {_joint(check, first.joint)}: {_axis_difference(first)}")
        if len(differing) > 1:
            lines.append("axes also differ at joints " + ", ".join(f"{j} ({check.joints[j - 1]})" for j in differing[1:]))
    else:
        lines.append("every joint axis of the table lies on the URDF's axis at q = 0" +
                     (" (some reversed)" if diagnosis.reversed_joints else ""))
    if diagnosis.fixes:
        fix = diagnosis.fixes[0]
        lines.append(f"{_correction_text(fix, check)}: reconciles them fully (remaining error {short_text(fix.residual, 2)})")
    else:
        if diagnosis.partial is not None:
            lines.append(f"{_correction_text(diagnosis.partial, check)}: reduces the error to "
                         f"{short_text(diagnosis.partial.residual, 3)} but does not reconcile them fully")
        lines.append("none of the corrections tried reconciles them: a constant base or tool transform, a single table "
                     "entry, one length with a base and tool transform, one reversed joint (or those reversed at q = 0), "
                     "joint zero offsets fitted joint by joint")
    return lines + _difference_lines(diagnosis)


def _difference_lines(diagnosis: DHDiagnosis) -> list[str]:
    found = diagnosis.differences
    if not found:
        return []
    shown = [_difference_text(change) for change in found[:SHOWN_DIFFERENCES]]
    if len(found) > SHOWN_DIFFERENCES:
        shown.append(f"... and {len(found) - SHOWN_DIFFERENCES} more")
    return [
        f"the {diagnosis.derived.convention} DH table derived from the URDF (as `manipkit dh from-urdf` derives it) "
        f"differs in {len(found)} place(s); DH frames are not unique, so an entry can also differ where a frame was "
        "chosen differently:",
        *shown,
    ]


def _difference_text(change: EntryChange | EndChange) -> str:
    if isinstance(change, EntryChange):
        return _entry_fit_text(change)
    return f"{change.end} {_pose_text(change.table_value)}, the URDF implies {_pose_text(change.urdf_value)}"


def _correction_text(fix: DHCorrection, check: DHCheck) -> str:
    """One correction in words, without what it achieves (``: reconciles them fully`` and the like)."""
    diagnosis = check.diagnosis
    if fix.kind == "single entry":
        return _entry_fit_text(fix.entry)
    if fix.kind == "length with base and tool":
        parts = []
        if fix.base is not None and not _is_identity(fix.base):
            parts.append(_base_text(fix.base))
        if fix.tool is not None and not _is_identity(fix.tool):
            parts.append(_tool_text(fix.tool))
        return _entry_fit_text(fix.entry) + "".join(f", with {part}" for part in parts)
    if fix.kind == "reversed joint":
        j = fix.reversed[0]
        changes = "; ".join(_change_text(change) for change in fix.changes)
        ends = _base_and_tool_text(fix)
        return (f"{_joint(check, j)} {_moves(diagnosis, j)} the other way: reversing it in the table ({changes})"
                + (f", with {ends}" if ends else ""))
    text = _flips_text(fix) + (_base_and_tool_text(fix) if fix.kind == "base and tool" else _offsets_text(fix, diagnosis))
    if fix.reversed and diagnosis.kind != "axes compared":  # the reversed joints are not named on lines of their own
        named = " and ".join(f"{_joint(check, j)} {_moves(diagnosis, j)} the other way" for j in fix.reversed)
        return f"{named}: {text}"
    return text


def _flips_text(fix: DHCorrection) -> str:
    return f"with joint(s) {', '.join(map(str, fix.reversed))} reversed, " if fix.reversed else ""


def _base_and_tool_text(fix: DHCorrection) -> str:
    if fix.base is None:
        return "" if fix.tool is None else _tool_text(fix.tool)
    if fix.tool is None:
        return _base_text(fix.base)
    return f"a base transform {_pose_text(fix.base)} and a tool transform {_pose_text(fix.tool)}"


def _offsets_text(fix: DHCorrection, diagnosis: DHDiagnosis) -> str:
    """``joint zero offsets (joint 2 by -17.1887 deg added to theta) and ...``: a sliding joint's in m, added to d."""
    slides = [diagnosis.axes[j - 1].urdf_slides for j, _ in fix.offsets]
    described = ", ".join(
        f"joint {j} by {'+' if o > 0 else '-'}" + (f"{short_text(abs(o))} m" if slide else f"{short_text(math.degrees(abs(o)))} deg")
        for (j, o), slide in zip(fix.offsets, slides)
    )
    entries = "d" if all(slides) else "theta or d" if any(slides) else "theta"
    return f"joint zero offsets ({described} added to {entries}) and {_tool_text(fix.tool)}"


def _axis_difference(axes) -> str:
    """How a joint's axis in the table differs from the URDF's (an AxisComparison that is not same or reversed)."""
    if axes.relation == "joint type":
        urdf_moves, table_moves = ("slides", "turns") if axes.urdf_slides else ("turns", "slides")
        return f"the URDF joint {urdf_moves}, the table's row {table_moves} (check the row's type)"
    angle = short_text(math.degrees(axes.angle), 3)
    along_u, along_d = _vector(axes.urdf_direction), _vector(axes.table_direction)
    if axes.urdf_slides:  # both slide
        return f"its axis differs by {angle} deg (URDF {along_u}, table {along_d})"
    return (
        f"its axis differs: URDF along {along_u} through {_vector(axes.urdf_point)}, table along {along_d} "
        f"through {_vector(axes.table_point)} (angle {angle} deg, distance {short_text(axes.distance, 4)} m)"
    )


def _joint(check: DHCheck, j: int) -> str:
    return f"joint {j} ({check.joints[j - 1]})"


def _moves(diagnosis: DHDiagnosis, j: int) -> str:
    """``turns``, or ``slides`` for a prismatic joint."""
    return "slides" if diagnosis.axes[j - 1].urdf_slides else "turns"


def _entry_fit_text(entry: EntryChange) -> str:
    return (f"row {entry.row}: {entry.entry} = {_entry_text(entry.entry, entry.table_value)}, the URDF implies "
            f"{_entry_text(entry.entry, entry.urdf_value)}")


def _change_text(change: EntryChange | EndChange) -> str:
    """``row 2: alpha 0 deg -> 180 deg``, or the new base or tool."""
    if isinstance(change, EntryChange):
        return (f"row {change.row}: {change.entry} {_entry_text(change.entry, change.table_value)} -> "
                f"{_entry_text(change.entry, change.urdf_value)}")
    return f"{change.end} {_pose_text(change.urdf_value)}"


def _entry_text(entry: str, value: float) -> str:
    if entry in ANGLE_ENTRIES:
        return f"{short_text(math.degrees(float(wrap_angle(value))), 6, zero=math.degrees(NOISE))} deg"
    return f"{short_text(value, 6, zero=NOISE)} m"


def _is_identity(T) -> bool:
    return bool(np.abs(T - np.eye(4)).max() < RECONCILE_TOL)


def _base_text(B) -> str:
    return f"a constant base transform {_pose_text(B)} (before row 1)"


def _tool_text(X) -> str:
    if _is_identity(X):
        return "no tool transform"
    return f"a constant tool transform {_pose_text(X)} (after the last row)"


def _pose_text(T) -> str:
    rpy = np.degrees(rpy_from_matrix(T[:3, :3], check=False, gimbal_tol=NOISE))  # at gimbal lock roll is 0
    return f"xyz {_vector(T[:3, 3])} m, rpy {_vector(rpy, 6, zero=math.degrees(NOISE))} deg"


def _vector(values, digits: int = 6, *, zero: float = 1e-9) -> str:
    """:func:`manipkit.text.vector_text` with ``digits`` significant digits; entries within ``zero`` of zero
    (finite-difference noise: 1e-9 m, 1e-7 deg) print as 0."""
    return vector_text(values, lambda v: short_text(v, digits, zero=zero))
