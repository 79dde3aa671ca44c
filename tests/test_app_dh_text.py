"""manipkit.app.dh_text: the sentences of `manipkit dh check`, from the diagnosis data of manipkit.dh.check.

Cases the check reaches are run for real; wordings no bundled robot reaches
(a sliding joint's zero offset, a long list of differences) are built by
hand from the data types, with the numbers worked out in the comments.
"""

import dataclasses
import math

import numpy as np
import pytest

import manipkit
from manipkit.app.dh_text import SHOWN_DIFFERENCES, diagnosis_lines, fix_reason
from manipkit.description.sources import bundled_dh_tables
from manipkit.dh import DHRow, DHTable, dh_fk, dh_from_urdf_chain, load_dh, reverse_joint
from manipkit.dh.check import DHCheck, check_dh
from manipkit.dh.diagnosis import AxisComparison, DHCorrection, DHDiagnosis, EndChange, EntryChange


@pytest.fixture(scope="module")
def scara(load_robot):
    return load_robot("scara"), load_dh(bundled_dh_tables()["scara"])


def _axis(joint, slides, relation="same"):
    z = np.array([0.0, 0.0, 1.0])
    point = None if slides else np.zeros(3)
    return AxisComparison(joint, relation, z, z, point, point, 0.0, None if slides else 0.0)


def _check(diagnosis, joints=("j1", "j2", "j3")) -> DHCheck:
    return DHCheck(0.25, 0.5, False, diagnosis, joints, 100, 1e-9, None)


def test_a_reversed_sliding_joint_slides_the_other_way(scara):
    # scara's joint 3 is the quill (prismatic, along -z); reverse_joint turns its z axis over.
    robot, table = scara
    result = check_dh(reverse_joint(table, 2), robot, samples=200)
    fix = result.diagnosis.fixes[0]
    assert result.diagnosis.kind == "reversed joint" and fix.reversed == (3,)
    assert result.diagnosis.axes[2].urdf_slides and result.diagnosis.axes[2].relation == "reversed"
    line = diagnosis_lines(result, summary=False)[0]
    assert line.startswith("joint 3 (joint3) slides the other way: reversing it in the table (row 2: alpha 0 deg -> 180 deg; ")
    assert "turns the other way" not in line


def test_reversed_joints_as_the_table_stands_say_how_each_moves(scara):
    # joints 1 (turns about z) and 3 (slides along -z) reversed: at q = 0 both screws are the URDF's negated
    robot, table = scara
    result = check_dh(reverse_joint(reverse_joint(table, 2), 0), robot, samples=200)
    assert result.diagnosis.kind == "axes compared" and result.diagnosis.reversed_joints == (1, 3)
    lines = diagnosis_lines(result, summary=False)
    assert lines[:3] == [
        "joint 1 (joint1) turns the other way: the table's z axis points opposite to the URDF axis [0 0 1] at q = 0",
        "joint 3 (joint3) slides the other way: the table's z axis points opposite to the URDF axis [0 0 -1] at q = 0",
        "every joint axis of the table lies on the URDF's axis at q = 0 (some reversed)",
    ]
    assert lines[3].startswith("with joint(s) 1, 3 reversed, no tool transform: reconciles them fully")


def test_zero_offsets_of_a_sliding_joint_are_in_metres_and_added_to_d():
    # joint 1 turns (offset -0.3 rad = -17.1887 deg), joint 2 slides (offset +0.05 m); no tool transform left
    offsets = DHCorrection("joint offsets", 1e-12, offsets=[(1, -0.3), (2, 0.05)], tool=np.eye(4))
    diagnosis = DHDiagnosis("axes compared", fixes=(offsets,), axes=(_axis(1, False), _axis(2, True), _axis(3, False)))
    assert diagnosis_lines(_check(diagnosis), summary=False)[1] == (
        "joint zero offsets (joint 1 by -17.1887 deg, joint 2 by +0.05 m added to theta or d) and no tool transform: "
        "reconciles them fully (remaining error 1e-12)"
    )
    only_sliding = DHCorrection("joint offsets", 1e-12, offsets=[(2, -0.05)], tool=np.eye(4))
    diagnosis = DHDiagnosis("axes compared", fixes=(only_sliding,), axes=diagnosis.axes)
    assert "(joint 2 by -0.05 m added to d)" in diagnosis_lines(_check(diagnosis))[2]


def test_differences_beyond_the_shown_ones_are_counted():
    # 15 entries and the base differ from the derived table: the first 12 are listed, the other 4 counted
    changes = [EntryChange(row, "a", 0.1 * row, 0.0) for row in range(1, 16)]
    base = np.eye(4)
    base[:3, 3] = [0.0, 0.0, 0.2]
    derived = DHTable([DHRow(0, 0, 0, 0)] * 15, "modified")
    diagnosis = DHDiagnosis("axes compared", axes=tuple(_axis(j, False) for j in range(1, 16)), derived=derived,
                            differences=(*changes, EndChange("base", base, np.eye(4))))
    lines = diagnosis_lines(_check(diagnosis, tuple(f"j{k}" for k in range(1, 16))), summary=False)
    assert lines[0] == "every joint axis of the table lies on the URDF's axis at q = 0"
    assert lines[1].startswith("none of the corrections tried reconciles them")
    assert lines[2].startswith("the modified DH table derived from the URDF (as `manipkit dh from-urdf` derives it) "
                               "differs in 16 place(s)")
    assert lines[3] == "row 1: a = 0.1 m, the URDF implies 0 m"
    assert len(lines) == 3 + SHOWN_DIFFERENCES + 1 and lines[-1] == "... and 4 more"
    assert "base xyz [0 0 0.2] m, rpy [0 0 0] deg, the URDF implies xyz [0 0 0] m, rpy [0 0 0] deg" not in lines


def test_when_nothing_reconciles_the_words_claim_only_what_was_tried(load_robot):
    # The Stanford arm's table with d_3 (the boom, prismatic) 0.1 m longer and theta_5 0.2 rad smaller: zero offsets
    # (-0.1 m on joint 3, +0.2 rad on joint 5) reconcile it exactly (checked below), but the offsets are fitted joint
    # by joint and the boom's offset moves no axis it is fitted on, so the search misses them. The sentence used to
    # say "no ... joint zero offset ... reconciles them", which was untrue here.
    robot = load_robot("stanford_arm")
    table = dh_from_urdf_chain(robot, convention="standard")
    rows = list(table.rows)
    rows[2] = dataclasses.replace(rows[2], d=rows[2].d + 0.1)
    rows[4] = dataclasses.replace(rows[4], theta=rows[4].theta - 0.2)
    changed = DHTable(rows, "standard", base=table.base, tool=table.tool)
    Q = np.random.default_rng(0).uniform(-1, 1, size=(20, 6))
    assert np.abs(dh_fk(changed, Q + [0, 0, -0.1, 0, 0.2, 0]) - dh_fk(table, Q)).max() < 1e-12
    result = check_dh(changed, robot, samples=200)
    assert result.diagnosis.kind == "axes compared" and result.diagnosis.fixes == ()
    assert ("none of the corrections tried reconciles them: a constant base or tool transform, a single table entry, "
            "one length with a base and tool transform, one reversed joint (or those reversed at q = 0), joint zero "
            "offsets fitted joint by joint") in diagnosis_lines(result)
    assert [(c.row, c.entry) for c in result.diagnosis.differences] == [(3, "d"), (5, "theta")]


def test_fix_reason_is_the_correction_behind_the_candidate(planar_3r):
    # theta_2 = 0.5 rad in the table, 0 in the URDF: the --fix header names that entry
    rows = [DHRow(4, 0, 0, 0), DHRow(2, 0, 0, 0.5), DHRow(1, 0, 0, 0)]
    result = check_dh(DHTable(rows, "standard"), planar_3r, samples=50)
    assert fix_reason(result).startswith("row 2: theta = 28.6479 deg, the URDF implies 0 deg: reconciles them fully")
    assert fix_reason(check_dh(DHTable([DHRow(4, 0, 0, 0), DHRow(2, 0, 0, 0), DHRow(1, 0, 0, 0)], "standard"),
                               planar_3r, samples=50)) == ""


def test_the_summary_says_the_errors_in_metres_radians_and_degrees():
    diagnosis = DHDiagnosis("no joints", tool=np.eye(4))
    lines = diagnosis_lines(_check(diagnosis, ()))
    # 0.5 rad = 28.6479 deg, four significant digits
    assert lines == ["does not agree: max position error 0.25 m, max rotation error 0.5 rad (28.65 deg) over 100 samples",
                     "no tool transform"]
    assert diagnosis_lines(_check(diagnosis, ()), summary=False) == ["no tool transform"]
    assert math.isclose(math.degrees(0.5), 28.6479, rel_tol=1e-5)


def test_a_diagnosis_refuses_an_unknown_kind():
    with pytest.raises(ValueError, match="diagnosis kind 'guess'"):
        DHDiagnosis("guess")
    with pytest.raises(ValueError, match="correction kind 'guess'"):
        DHCorrection("guess", 0.0)


def test_the_diagnosis_is_immutable(planar_3r):
    rows = [DHRow(4, 0, 0, 0), DHRow(2.5, 0, 0, 0), DHRow(1, 0, 0, 0)]
    diagnosis = check_dh(DHTable(rows, "standard"), planar_3r, samples=50).diagnosis
    with pytest.raises(AttributeError):
        diagnosis.kind = "agrees"
    with pytest.raises(ValueError):
        diagnosis.axes[0].urdf_direction[0] = 1.0  # read-only arrays
    assert manipkit.dh.DHDiagnosis is DHDiagnosis
