"""The DH diagnosis names the one change made to a right table, and its corrected table passes.

Right tables are derived from every bundled robot and the example-robot-data
arms (``dh_from_urdf_chain``, checked to agree with the URDF first: the
independent source is Pinocchio's FK of the URDF). Each is then changed in
one known way: a base rotation about z, about x and about a general axis, a
tool transform, a base and a tool at once, each single entry (a, d, alpha,
theta) in turn, one reversed joint (``reverse_joint``, whose FK is checked
here against the table's FK with that joint value negated). The diagnosis
must name that change (its fields, and the sentences of
manipkit.app.dh_text), and ``DHCheck.candidate`` must pass ``check_dh``.
"""

import dataclasses
import math

import numpy as np
import pytest

from manipkit.app.dh_text import diagnosis_lines
from manipkit.description.sources import bundled_robots, example_robot_data_arms
from manipkit.dh import DHTable, dh_fk, dh_from_urdf_chain
from manipkit.dh.check import check_dh
from manipkit.dh.diagnosis import EntryChange
from manipkit.dh.entries import reverse_joint
from manipkit.spatial.rotations import matrix_from_axis_angle
from manipkit.spatial.transforms import transform_from_xyz_rpy

SAMPLES = 150  # configurations per check: enough to tell a 1e-3 change from agreement

# so_arm is so101 under another name
ROBOTS = sorted(set(bundled_robots()) | set(example_robot_data_arms()) - {"so_arm"})
# both conventions for the arms of the issue, one (alternating) for the others: the suite stays fast
CASES = [
    (name, convention)
    for k, name in enumerate(ROBOTS)
    for convention in (("standard", "modified") if name in ("ur5", "panda") else (("standard", "modified")[k % 2],))
]


@pytest.fixture(scope="module")
def tables(load_robot):
    cache = {}

    def get(name, convention):
        if (name, convention) not in cache:
            robot = load_robot(name)
            table = dh_from_urdf_chain(robot, convention=convention)
            assert check_dh(table, robot, samples=SAMPLES).passed  # the right table
            cache[name, convention] = robot, table
        return cache[name, convention]

    return get


def _diagnose(robot, table):
    """The diagnosis (data) and its sentences (text), once the corrected table is checked to pass."""
    result = check_dh(table, robot, samples=SAMPLES)
    text = "\n".join(diagnosis_lines(result))
    assert not result.passed
    assert result.candidate is not None, text
    assert check_dh(result.candidate, robot, samples=SAMPLES).passed
    return result.diagnosis, text


def _rotation(axis, angle):
    T = np.eye(4)
    T[:3, :3] = matrix_from_axis_angle(np.asarray(axis, dtype=float), angle)
    return T


@pytest.mark.parametrize(("name", "convention"), CASES)
def test_a_base_rotation_is_named(tables, name, convention):
    robot, table = tables(name, convention)
    for axis in ([0, 0, 1], [1, 0, 0], [1, -2, 3]):
        B = _rotation(axis, 0.7)
        B[:3, 3] = [0.05, -0.1, 0.2] if axis == [1, -2, 3] else 0.0
        diagnosis, text = _diagnose(robot, dataclasses.replace(table, base=B @ table.base))
        fix = diagnosis.fixes[0]
        assert fix.kind == "base and tool" and fix.tool is None, text
        assert np.allclose(fix.base, np.linalg.inv(B), atol=1e-7), text  # table.base is the derived table's own
        assert "a constant base transform" in text.splitlines()[1], text


@pytest.mark.parametrize(("name", "convention"), CASES)
def test_a_tool_transform_and_a_base_with_a_tool_are_named(tables, name, convention):
    robot, table = tables(name, convention)
    X = transform_from_xyz_rpy([0.01, -0.02, 0.03], [0.2, -0.3, 0.4])
    diagnosis, text = _diagnose(robot, dataclasses.replace(table, tool=table.tool @ X))
    fix = diagnosis.fixes[0]
    assert fix.kind == "base and tool" and fix.base is None and np.allclose(fix.tool, np.linalg.inv(X), atol=1e-7), text
    assert "a constant tool transform" in text.splitlines()[1], text
    if table.n > 1:  # with one joint, a base and a tool are not told apart from one another
        B = transform_from_xyz_rpy([0.1, 0.0, -0.05], [0.3, 0.5, -0.6])
        diagnosis, text = _diagnose(robot, dataclasses.replace(table, base=B @ table.base, tool=table.tool @ X))
        assert any(fix.kind == "base and tool" and fix.base is not None and fix.tool is not None
                   for fix in diagnosis.fixes), text
        assert "a base transform" in text and "and a tool transform" in text, text


@pytest.mark.parametrize(("name", "convention"), CASES)
@pytest.mark.parametrize(("entry", "change"), [("a", 0.013), ("d", -0.021), ("alpha", 0.3), ("theta", 0.4)])
def test_a_wrong_entry_is_named_with_the_value_the_urdf_implies(tables, name, convention, entry, change):
    robot, table = tables(name, convention)
    row = (ROBOTS.index(name) + "adth".index(entry[0])) % table.n  # a different row for each entry and robot
    rows = list(table.rows)
    rows[row] = dataclasses.replace(rows[row], **{entry: getattr(rows[row], entry) + change})
    diagnosis, text = _diagnose(robot, dataclasses.replace(table, rows=tuple(rows)))
    named = [fix.entry for fix in diagnosis.fixes if fix.entry is not None] + list(diagnosis.differences)
    assert any(getattr(change, "row", None) == row + 1 and change.entry == entry for change in named), text
    assert f"row {row + 1}: {entry} = " in text, text


@pytest.mark.parametrize(("name", "convention"), CASES)
def test_a_reversed_joint_is_named(tables, name, convention):
    robot, table = tables(name, convention)
    j = ROBOTS.index(name) % table.n
    reversed_table = reverse_joint(table, j)
    # its FK is the table's with q_j negated (the definition of a reversed joint)
    Q = robot.sample_q(20, seed=1)[:, [robot.joint_names.index(n) for n in robot.chain_joints("base_link", "ee_link")]]
    flipped = Q.copy()
    flipped[:, j] *= -1
    assert np.abs(dh_fk(reversed_table, Q) - dh_fk(table, flipped)).max() < 1e-12
    diagnosis, text = _diagnose(robot, reversed_table)
    assert diagnosis.kind in ("reversed joint", "axes compared"), text
    assert j + 1 in diagnosis.fixes[0].reversed or j + 1 in diagnosis.reversed_joints, text
    moves = "slides" if reversed_table.rows[j].type == "prismatic" else "turns"
    assert f"joint {j + 1} ({robot.chain_joints('base_link', 'ee_link')[j]}) {moves} the other way" in text, text


def test_reverse_joint_twice_gives_the_table_back(tables):
    robot, table = tables("ur5", "modified")
    for j in range(table.n):
        again = reverse_joint(reverse_joint(table, j), j)
        Q = np.random.default_rng(j).uniform(-3, 3, size=(10, table.n))
        assert np.abs(dh_fk(again, Q) - dh_fk(table, Q)).max() < 1e-12


def test_issue_finding_5_a_base_half_turn_is_not_a_reversed_joint(tables):
    # The published UR5 table differs from the URDF (checked from base_link) by Rz(180 deg) before row 1.
    robot, table = tables("ur5", "standard")
    diagnosis, text = _diagnose(robot, dataclasses.replace(table, base=_rotation([0, 0, 1], math.pi) @ table.base))
    assert diagnosis.kind == "base and tool" and all(fix.reversed == () for fix in diagnosis.fixes)
    assert np.allclose(diagnosis.fixes[0].base, np.diag([-1.0, -1.0, 1.0, 1.0]), atol=1e-12)
    assert "a constant base transform xyz [0 0 0] m, rpy [0 0 180] deg (before row 1): reconciles them fully" in text
    assert "turns the other way" not in text and "none of the corrections tried" not in text


def test_issue_finding_6_a_wrong_link_length_is_named(tables):
    robot, table = tables("ur5", "standard")
    rows = list(table.rows)
    rows[1] = dataclasses.replace(rows[1], a=0.43)  # the URDF's 0.425 m upper arm, mistyped
    diagnosis, text = _diagnose(robot, dataclasses.replace(table, rows=tuple(rows)))
    assert diagnosis.kind == "single entry"
    assert diagnosis.fixes[0].entry == EntryChange(2, "a", 0.43, pytest.approx(0.425, abs=1e-12))
    assert "row 2: a = 0.43 m, the URDF implies 0.425 m: reconciles them fully" in text


def test_issue_finding_6_a_flipped_alpha_is_named_not_a_reversed_joint(tables):
    robot, table = tables("ur5", "standard")
    rows = list(table.rows)
    assert rows[3].alpha == pytest.approx(-math.pi / 2)
    rows[3] = dataclasses.replace(rows[3], alpha=math.pi / 2)
    diagnosis, text = _diagnose(robot, dataclasses.replace(table, rows=tuple(rows)))
    assert diagnosis.fixes[0].entry == EntryChange(4, "alpha", math.pi / 2, pytest.approx(-math.pi / 2, abs=1e-12))
    assert "row 4: alpha = 90 deg, the URDF implies -90 deg: reconciles them fully" in text
    assert "turns the other way" not in text


def test_two_wrong_entries_are_listed_against_the_derived_table(tables):
    robot, table = tables("ur5", "standard")
    rows = list(table.rows)
    rows[1] = dataclasses.replace(rows[1], a=0.43)
    rows[2] = dataclasses.replace(rows[2], a=0.4)
    result = check_dh(DHTable(rows, "standard", base=table.base, tool=table.tool), robot, samples=SAMPLES)
    assert check_dh(result.candidate, robot, samples=SAMPLES).passed  # the derived table
    diagnosis = result.diagnosis
    assert diagnosis.kind == "axes compared" and diagnosis.fixes == () and diagnosis.first_difference == 3
    assert diagnosis.differences == (EntryChange(2, "a", 0.43, pytest.approx(0.425, abs=1e-12)),
                                     EntryChange(3, "a", 0.4, pytest.approx(0.39225, abs=1e-12)))
    text = "\n".join(diagnosis_lines(result))
    assert "none of the corrections tried reconciles them" in text
    assert "differs in 2 place(s)" in text
    assert "row 2: a = 0.43 m, the URDF implies 0.425 m" in text and "row 3: a = 0.4 m, the URDF implies 0.39225 m" in text


@pytest.mark.parametrize("name", ["ur5", "panda", "iiwa14", "kinova", "xarm7"])
def test_a_wrong_length_is_named_also_when_the_base_is_turned(tables, name):
    # The issue's published-table case: one length wrong AND the table's base turned against the URDF's.
    # The longest middle length is changed (the first row's d and the last row's lengths are the base's and
    # the tool's to take up); the base is turned about a general axis.
    robot, table = tables(name, "standard")
    middle = [(abs(getattr(r, e)), i, e) for i, r in enumerate(table.rows[1:-1], start=1) for e in ("a", "d")]
    _, row, entry = max(middle)
    rows = list(table.rows)
    rows[row] = dataclasses.replace(rows[row], **{entry: getattr(rows[row], entry) + 0.005})
    B = _rotation([1, 2, -1], 2.0)
    diagnosis, text = _diagnose(robot, DHTable(tuple(rows), "standard", base=B @ table.base, tool=table.tool))
    fix = diagnosis.fixes[0]
    assert diagnosis.kind == fix.kind == "length with base and tool", text
    assert (fix.entry.row, fix.entry.entry) == (row + 1, entry)
    assert fix.entry.urdf_value == pytest.approx(fix.entry.table_value - 0.005, abs=1e-9), text
    assert np.allclose(fix.base[:3, :3], B[:3, :3].T, atol=1e-7), text
    assert f"row {row + 1}: {entry} = " in text and "with a constant base transform" in text, text


def test_issue_finding_6_published_ur5_table_with_a_wrong_length(tmp_path, load_robot):
    # The published UR5 standard table (alpha_1 = +90 deg, a_2 = -0.425 m, a_3 = -0.39225 m), against the URDF
    # from base_link: Rz(180 deg) apart (finding 5); with a_2 mistyped as -0.43 (finding 6) the diagnosis
    # names both.
    from manipkit.dh import dh_from_yaml

    table = dh_from_yaml("\n".join([
        "convention: standard", "angles: rad", "joints:",
        "  - {a: 0, alpha: pi/2, d: 0.089159, theta: 0}",
        "  - {a: -0.43, alpha: 0, d: 0, theta: 0}",
        "  - {a: -0.39225, alpha: 0, d: 0, theta: 0}",
        "  - {a: 0, alpha: pi/2, d: 0.10915, theta: 0}",
        "  - {a: 0, alpha: -pi/2, d: 0.09465, theta: 0}",
        "  - {a: 0, alpha: 0, d: 0.0823, theta: 0}",
    ]))
    robot = load_robot("ur5")
    result = check_dh(table, robot, tip="tool0", samples=SAMPLES)
    fix = result.diagnosis.fixes[0]
    assert fix.kind == "length with base and tool" and (result.base, result.tip) == ("base_link", "tool0")
    assert fix.entry == EntryChange(2, "a", -0.43, pytest.approx(-0.425, abs=1e-12))
    assert np.allclose(fix.base, np.diag([-1.0, -1.0, 1.0, 1.0]), atol=1e-9)
    assert np.allclose(fix.tool, np.eye(4), atol=1e-8)  # within RECONCILE_TOL: no tool transform, none named
    lines = diagnosis_lines(result)
    assert lines[1].startswith(
        "row 2: a = -0.43 m, the URDF implies -0.425 m, with a constant base transform xyz [0 0 0] m, "
        "rpy [0 0 180] deg (before row 1): reconciles them fully"
    ), lines
    assert check_dh(result.candidate, robot, tip="tool0").passed
