"""manipkit.dh.check: agreement of a DH table with a URDF chain, and the diagnosis.

Each wrong table below is made from a right one by one known change (hand
derivations in the comments); the diagnosis must name that change: its
fields (manipkit.dh.diagnosis) hold the numbers, and the sentences
``manipkit dh check`` prints (manipkit.app.dh_text) say them.
"""

import math

import numpy as np
import pytest

import manipkit
from manipkit.app.dh_text import diagnosis_lines
from manipkit.description.sources import bundled_dh_tables
from manipkit.dh import DHRow, DHTable, dh_fk, load_dh
from manipkit.dh.check import check_dh, screws
from manipkit.dh.diagnosis import EntryChange
from manipkit.spatial.transforms import transform_from_xyz_rpy

# planar_3r with its default lengths 4 2 1: standard DH rows (a, alpha, d, theta) = (l_i, 0, 0, 0),
# since every joint turns about z and each link runs along its x axis.
PLANAR_3R = [DHRow(4.0, 0.0, 0.0, 0.0), DHRow(2.0, 0.0, 0.0, 0.0), DHRow(1.0, 0.0, 0.0, 0.0)]


# planar_3r and iiwa14: session fixtures of conftest.py


def seed_iiwa_table():
    """Seed 004 Table 1 (modified DH), row 8 written as the tool."""
    r = math.radians
    rows = [DHRow(0, 0, 0.36, 0)] + [
        DHRow(0, r(90), d, r(180)) for d in (0, 0.42, 0, 0.40, 0)
    ] + [DHRow(0, r(90), 0, 0)]
    tool = np.eye(4)
    tool[2, 3] = 0.126
    return DHTable(rows, "modified", "iiwa14 seed 004", tool=tool)


def _text(result) -> str:
    return "\n".join(diagnosis_lines(result))


def test_right_table_passes(planar_3r):
    result = check_dh(DHTable(PLANAR_3R, "standard"), planar_3r)
    assert result.passed and result.max_position_error < 1e-12 and result.diagnosis.kind == "agrees"
    assert diagnosis_lines(result) == []
    assert result.joints == ("joint1", "joint2", "joint3")
    assert (result.base, result.tip) == ("base_link", "ee_link")


def test_wrong_link_length_is_named_with_the_value_the_urdf_implies(planar_3r):
    # a_2 = 2.5 instead of 2: the third axis sits at x = 4 + 2.5 = 6.5 instead of 6 at q = 0.
    rows = [PLANAR_3R[0], DHRow(2.5, 0.0, 0.0, 0.0), PLANAR_3R[2]]
    result = check_dh(DHTable(rows, "standard"), planar_3r)
    assert not result.passed
    # Stretched out the error is exactly 0.5 m; the samples come close to it.
    assert 0.45 < result.max_position_error <= 0.5 + 1e-12
    diagnosis = result.diagnosis
    assert diagnosis.kind == "single entry" and len(diagnosis.fixes) == 1
    fix = diagnosis.fixes[0]
    assert fix.entry == EntryChange(2, "a", 2.5, pytest.approx(2.0, abs=1e-12)) and fix.entry.unit == "m"
    assert fix.residual <= 1e-9 and fix.candidate is result.candidate
    assert result.candidate.rows[1].a == pytest.approx(2.0, abs=1e-12)
    assert "row 2: a = 2.5 m, the URDF implies 2 m: reconciles them fully" in _text(result)


def test_two_wrong_link_lengths_locate_the_first_joint_that_disagrees(planar_3r):
    # a_1 = 4.5 and a_2 = 2.5: no single entry explains it; joint 2's axis is 0.5 m off, at x = 4.5 instead of 4.
    rows = [DHRow(4.5, 0.0, 0.0, 0.0), DHRow(2.5, 0.0, 0.0, 0.0), PLANAR_3R[2]]
    result = check_dh(DHTable(rows, "standard"), planar_3r)
    diagnosis = result.diagnosis
    assert diagnosis.kind == "axes compared" and diagnosis.fixes == () and diagnosis.partial is None
    assert diagnosis.first_difference == 2 and diagnosis.differing_joints == (2, 3) and diagnosis.reversed_joints == ()
    # joint 2 turns about z through (4, 0, 0) in the URDF, through (4.5, 0, 0) in the table: parallel, 0.5 m apart
    axis = diagnosis.axes[1]
    assert axis.relation == "different" and axis.distance == pytest.approx(0.5, abs=1e-9) and axis.angle < 1e-9
    assert np.allclose(axis.urdf_point, [4, 0, 0], atol=1e-9) and np.allclose(axis.table_point, [4.5, 0, 0], atol=1e-9)
    assert diagnosis.derived.convention == "standard"
    assert diagnosis.differences == (EntryChange(1, "a", 4.5, pytest.approx(4.0)), EntryChange(2, "a", 2.5, pytest.approx(2.0)))
    assert result.candidate is not None and check_dh(result.candidate, planar_3r).passed
    text = _text(result)
    assert "the chains stop agreeing at joint 2 (joint2)" in text and "distance 0.5 m" in text
    assert "none of the corrections tried reconciles them: a constant base or tool transform, a single table entry" in text
    assert "row 1: a = 4.5 m, the URDF implies 4 m" in text and "row 2: a = 2.5 m, the URDF implies 2 m" in text


def test_wrong_joint_zero_offset_is_named(planar_3r):
    # theta_2 = +0.5 rad = 28.6479 deg in the table, 0 in the URDF.
    rows = [PLANAR_3R[0], DHRow(2.0, 0.0, 0.0, 0.5), PLANAR_3R[2]]
    result = check_dh(DHTable(rows, "standard"), planar_3r)
    assert result.diagnosis.fixes[0].entry == EntryChange(2, "theta", 0.5, pytest.approx(0.0, abs=1e-12))
    assert result.diagnosis.fixes[0].entry.unit == "rad"
    assert "row 2: theta = 28.6479 deg, the URDF implies 0 deg: reconciles them fully" in _text(result)


def test_constant_base_offset_is_found(planar_3r):
    base = np.eye(4)
    base[:3, 3] = [0.1, 0.2, 0.3]
    result = check_dh(DHTable(PLANAR_3R, "standard", base=base), planar_3r)
    fix = result.diagnosis.fixes[0]
    assert result.diagnosis.kind == fix.kind == "base and tool" and fix.tool is None and fix.reversed == ()
    assert np.allclose(fix.base, [[1, 0, 0, -0.1], [0, 1, 0, -0.2], [0, 0, 1, -0.3], [0, 0, 0, 1]], atol=1e-12)
    assert ("a constant base transform xyz [-0.1 -0.2 -0.3] m, rpy [0 0 0] deg (before row 1): reconciles them fully"
            in _text(result))


@pytest.mark.parametrize("robot_name", ["planar_3r", "scara"])
def test_base_and_tool_transform_of_an_arm_with_parallel_axes_are_found(robot_name):
    # The right table with a base B = xyz [.1 .2 .3], Rz(0.4) before row 1 and a tool X = xyz [.05 -.02 0],
    # Rz(0.3) after the last row: the URDF needs B^-1 before and X^-1 after, by hand
    #   B^-1 = Rz(-0.4), -Rz(-0.4) [.1 .2 .3] = [-(.1 cos .4 + .2 sin .4), -(.2 cos .4 - .1 sin .4), -.3]
    #        = xyz [-0.16999 -0.14527 -0.3], rpy [0 0 -22.92 deg];
    #   X^-1 = Rz(-0.3), -Rz(-0.3) [.05 -.02 0] = [-(.05 cos .3 - .02 sin .3), .02 cos .3 + .05 sin .3, 0]
    #        = xyz [-0.0418564 0.0338827 0], rpy [0 0 -17.19 deg].
    # Every joint turns or slides along z, so only the axes' offsets fix the turn of the base about z.
    # (A shift along z would commute with the whole chain; the diagnosis puts it in the base.)
    right = load_dh(bundled_dh_tables()[robot_name])
    base = transform_from_xyz_rpy([0.1, 0.2, 0.3], [0.0, 0.0, 0.4])
    tool = transform_from_xyz_rpy([0.05, -0.02, 0.0], [0.0, 0.0, 0.3])
    table = DHTable(right.rows, "standard", base=base @ right.base, tool=right.tool @ tool)
    result = check_dh(table, manipkit.load(robot_name))
    fix = result.diagnosis.fixes[0]
    assert fix.kind == "base and tool"
    assert np.allclose(fix.base, np.linalg.inv(base), atol=1e-9) and np.allclose(fix.tool, np.linalg.inv(tool), atol=1e-9)
    assert (
        "a base transform xyz [-0.16999 -0.14527 -0.3] m, rpy [0 0 -22.9183] deg and a tool transform "
        "xyz [-0.0418564 0.0338827 0] m, rpy [0 0 -17.1887] deg: reconciles them fully"
    ) in _text(result)


def test_revolute_joint_against_a_prismatic_row_says_which_turns(planar_3r):
    rows = PLANAR_3R[:2] + [DHRow(1.0, 0.0, 0.0, 0.0, type="prismatic")]
    result = check_dh(DHTable(rows, "standard"), planar_3r)
    axis = result.diagnosis.axes[2]
    assert result.diagnosis.first_difference == 3 and axis.relation == "joint type"
    assert not axis.urdf_slides and axis.table_point is None
    assert "the chains stop agreeing at joint 3 (joint3): the URDF joint turns, the table's row slides" in _text(result)
    scara = load_dh(bundled_dh_tables()["scara"])  # row 3 is scara's quill, joint3 slides
    rows = list(scara.rows)
    rows[2] = DHRow(rows[2].a, rows[2].alpha, rows[2].d, rows[2].theta)
    result = check_dh(DHTable(rows, "standard"), manipkit.load("scara"))
    assert result.diagnosis.axes[2].relation == "joint type" and result.diagnosis.axes[2].urdf_slides
    assert "the chains stop agreeing at joint 3 (joint3): the URDF joint slides, the table's row turns" in _text(result)


def test_a_flipped_alpha_is_named_as_that_entry(planar_3r):
    # alpha_2 = 180 deg flips the z axis of frame 2, so joint 3 turns about -z: one entry explains it
    # (before, this was reported as "joint 3 reversed and a tool transform").
    rows = [PLANAR_3R[0], DHRow(2.0, math.pi, 0.0, 0.0), PLANAR_3R[2]]
    result = check_dh(DHTable(rows, "standard"), planar_3r)
    assert result.diagnosis.kind == "single entry"
    assert result.diagnosis.fixes[0].entry == EntryChange(2, "alpha", math.pi, pytest.approx(0.0, abs=1e-12))
    assert all(fix.reversed == () for fix in result.diagnosis.fixes)
    text = _text(result)
    assert "row 2: alpha = 180 deg, the URDF implies 0 deg: reconciles them fully" in text
    assert "turns the other way" not in text


def test_reversed_joint_is_found(planar_3r):
    # Joint 3 reversed in standard DH: alpha_2 and alpha_3 both 180 deg (reverse_joint's rule; theta = d = 0).
    rows = [PLANAR_3R[0], DHRow(2.0, math.pi, 0.0, 0.0), DHRow(1.0, math.pi, 0.0, 0.0)]
    result = check_dh(DHTable(rows, "standard"), planar_3r)
    fix = result.diagnosis.fixes[0]
    assert result.diagnosis.kind == fix.kind == "reversed joint" and fix.reversed == (3,)
    assert fix.base is None and fix.tool is None  # the home poses agree once joint 3 is reversed
    assert fix.changes == (EntryChange(2, "alpha", math.pi, pytest.approx(0.0, abs=1e-12)),
                           EntryChange(3, "alpha", math.pi, pytest.approx(0.0, abs=1e-12)))
    assert result.diagnosis.reversed_joints == (3,)  # at q = 0, joint 3's table axis is -z
    assert "joint 3 (joint3) turns the other way: reversing it in the table (row 2: alpha 180 deg -> 0 deg; " \
        "row 3: alpha 180 deg -> 0 deg): reconciles them fully" in _text(result)
    assert check_dh(result.candidate, planar_3r).passed


def test_wrong_row_count_is_reported(planar_3r):
    result = check_dh(DHTable(PLANAR_3R + [DHRow(0.5, 0.0, 0.0, 0.0)], "standard"), planar_3r)
    assert not result.passed and math.isnan(result.max_position_error) and result.samples == 0
    assert result.diagnosis.kind == "row count" and result.diagnosis.rows == 4
    assert result.diagnosis.extra_row == DHRow(0.5, 0.0, 0.0, 0.0)
    lines = diagnosis_lines(result)
    assert lines[0].startswith("the table has 4 rows but the URDF chain base_link -> ee_link has 3 movable joints")
    assert lines[1] == ("the last row (a=0.5, alpha=0 deg, d=0, theta=0 deg) has no joint to map to: "
                        "if it only places the tool, write it as `tool:` instead of a row")
    result = check_dh(DHTable(PLANAR_3R[:2], "standard"), planar_3r)
    assert result.diagnosis.rows == 2 and result.diagnosis.extra_row is None
    assert diagnosis_lines(result)[1] == "1 joint(s) of the URDF chain have no row; check --base and --tip"
    result = check_dh(DHTable(PLANAR_3R + PLANAR_3R[:2], "standard"), planar_3r)
    assert diagnosis_lines(result)[1] == "2 row(s) too many; check --base and --tip"


def test_a_chain_without_joints_differs_by_a_tool_transform(planar_3r):
    # link3 -> ee_link is fixed on planar_3r: ee_link sits 1 m along x (the last link); a table with no rows and the
    # tool xyz [0.1 0 0], Rz(0.2) needs X = tool^-1 Tx(1) after it: rotation Rz(-0.2), translation Rz(-0.2) [0.9 0 0]
    # = [0.9 cos 0.2, -0.9 sin 0.2, 0] = [0.88206, -0.178802, 0].
    table = DHTable([], "standard", tool=transform_from_xyz_rpy([0.1, 0.0, 0.0], [0.0, 0.0, 0.2]))
    result = check_dh(table, planar_3r, base="link3", samples=20)
    assert result.diagnosis.kind == "no joints" and result.candidate is None
    assert np.allclose(result.diagnosis.tool, transform_from_xyz_rpy([0.88206, -0.178802, 0], [0, 0, -0.2]), atol=1e-5)
    assert diagnosis_lines(result)[1] == ("a constant tool transform xyz [0.88206 -0.178802 0] m, rpy [0 0 -11.4592] deg "
                                          "(after the last row)")


def test_seed_iiwa_table_fails_with_a_reversed_joint_and_a_base_half_turn(iiwa14):
    # Hand check at q = 0: the seed's 0T8 has rotation diag(-1, -1, 1) (seed eq. 4.4) while the URDF's
    # flange is upright (identity), a half turn about z; its pi offsets and +90 deg twists make the z axes
    # of frames 2 and 6 point along -y where the URDF's joints 2 and 6 turn about +y, while joint 4's
    # points along +y. Turning the whole table by Rz(180 deg) at the base flips y: then only joint 4 is
    # reversed, the simplest explanation (one joint and the base, rather than two joints and the tool).
    result = check_dh(seed_iiwa_table(), iiwa14)
    assert not result.passed and result.max_rotation_error > 3.0
    half_turn = np.diag([-1.0, -1.0, 1.0, 1.0])  # Rz(180 deg)
    first, second = result.diagnosis.fixes
    assert result.diagnosis.kind == first.kind == "reversed joint" and first.reversed == (4,)
    assert first.tool is None and np.allclose(first.base, half_turn, atol=1e-9)
    assert [(c.row, c.entry) for c in first.changes] == [(4, "alpha"), (5, "alpha")]
    # or, as the table stands, joints 2 and 6 reversed (their z axes point along -y) and the tool turned
    assert result.diagnosis.reversed_joints == (2, 6) and second.reversed == (2, 6) and second.candidate is None
    assert second.kind == "base and tool" and second.base is None and np.allclose(second.tool, half_turn, atol=1e-9)
    lines = diagnosis_lines(result)
    assert lines[1].startswith("joint 4 (iiwa_joint_4) turns the other way")
    assert ("with a constant base transform xyz [0 0 0] m, rpy [0 0 180] deg (before row 1): reconciles them fully "
            "(remaining error ") in lines[1]
    assert lines[2] == ("or equally joint 2 (iiwa_joint_2) turns the other way and joint 6 (iiwa_joint_6) turns the other "
                        "way: with joint(s) 2, 6 reversed, a constant tool transform xyz [0 0 0] m, rpy [0 0 180] deg "
                        "(after the last row): reconciles them fully")
    assert check_dh(result.candidate, iiwa14).passed


def test_screws_of_a_planar_arm_match_the_hand_values(planar_3r):
    # Joint i turns about +z through (sum of the earlier lengths, 0, 0): S = (0, 0, 1, -w x p) = (0, 0, 1, 0, -x_i, 0).
    S = screws(lambda q: dh_fk(DHTable(PLANAR_3R, "standard"), q), 3)
    expected = np.array([[0, 0, 1, 0, 0, 0], [0, 0, 1, 0, -4, 0], [0, 0, 1, 0, -6, 0]], dtype=float)
    assert np.abs(S - expected).max() < 1e-9
    S = screws(lambda Q: dh_fk(DHTable(PLANAR_3R, "standard"), Q), 3, vectorised=True)  # one call, 7 poses
    assert np.abs(S - expected).max() < 1e-9


def test_screws_from_a_vectorised_fk_are_those_of_one_pose_at_a_time(iiwa14):
    # one call of Robot.fk for the 15 poses (vectorised=True), or Robot.transform pose by pose: the same axes
    q0 = np.array([0.3, -0.5, 0.2, 1.1, -0.4, 0.6, 0.1])
    one = screws(lambda q: iiwa14.transform("base_link", "ee_link", q), 7, q0)
    many = screws(lambda Q: iiwa14.fk(Q, base="base_link", tip="ee_link"), 7, q0, vectorised=True)
    assert np.abs(one - many).max() < 1e-9  # the differences' own error: about 1e-10 at the step 1e-5
    assert np.allclose(np.linalg.norm(one[:, :3], axis=1), 1.0, atol=1e-9)  # revolute: unit axes


def test_tip_not_below_base_is_a_clear_error(planar_3r):
    with pytest.raises(manipkit.ManipkitError, match="is not below"):
        check_dh(DHTable(PLANAR_3R, "standard"), planar_3r, base="link2", tip="link1")


# Every bundled table and the robot it describes; the seed's table is kept to fail.
TABLE_ROBOTS = {
    "planar_2r": ("planar_2r", True),
    "planar_3r": ("planar_3r", True),
    "iiwa14": ("iiwa14", True),
    "iiwa14_seed004": ("iiwa14", False),
    "course_arm_standard": ("course_arm", True),
    "course_arm_modified": ("course_arm", True),
    "scara": ("scara", True),
    "stanford_arm": ("stanford_arm", True),
    "elbow_arm": ("elbow_arm", True),
}


def test_every_bundled_table_is_registered_here():
    from manipkit.description.sources import bundled_dh_tables

    assert set(bundled_dh_tables()) == set(TABLE_ROBOTS)


@pytest.mark.parametrize("name", sorted(TABLE_ROBOTS))
def test_bundled_table_against_its_urdf(name):
    from manipkit.description.sources import bundled_dh_tables
    from manipkit.dh import load_dh

    robot_name, should_pass = TABLE_ROBOTS[name]
    result = check_dh(load_dh(bundled_dh_tables()[name]), manipkit.load(robot_name), samples=1000, tol=1e-9)
    assert result.passed is should_pass
    if should_pass:
        assert result.max_position_error <= 1e-9 and result.max_rotation_error <= 1e-9
    else:
        assert result.max_position_error > 1.0  # the seed's table misses by metres (see test_dh.py)


def test_cli_fix_writes_a_corrected_table_that_passes(tmp_path):
    # issue 14 finding 5, from the shell: the ur5 table derived from the URDF, turned by Rz(180 deg) at the base
    from cli_helper import run_cli

    from manipkit.dh import dh_from_urdf_chain, save_dh

    table = dh_from_urdf_chain(manipkit.load("ur5"), convention="standard")
    turned = DHTable(table.rows, "standard", "ur5 turned", base=transform_from_xyz_rpy([0, 0, 0], [0, 0, math.pi]) @ table.base,
                     tool=table.tool)
    save_dh(turned, tmp_path / "turned.yaml")
    fixed = tmp_path / "fixed.yaml"
    run = run_cli("manipkit", "dh", "check", tmp_path / "turned.yaml", "--robot", "ur5", "--fix", fixed)
    assert run.returncode == 1, run.stderr
    assert "- a constant base transform xyz [0 0 0] m, rpy [0 0 180] deg (before row 1): reconciles them fully" in run.stdout
    assert f"wrote the corrected table to {fixed} (it passes)" in run.stdout
    assert not any(line.startswith("base:") for line in fixed.read_text().splitlines())  # the turned table's base Rz(180 deg), undone: the identity again
    assert check_dh(load_dh(fixed), manipkit.load("ur5")).passed
