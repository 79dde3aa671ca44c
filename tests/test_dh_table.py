"""manipkit.dh.table: DH rows and tables, their FK, and the bundled tables in robots/dh/.

Independent sources: Pinocchio on the bundled URDFs (``manipkit.load``)
against the tables in robots/dh/, and values worked out by hand in the
comments or printed in seed 004 (its Table 1 and home pose).

The helpers below (bundled table paths, random tables, samples) are shared by
the other test_dh_*.py files, which import them from here.
"""

import math
from pathlib import Path

import numpy as np
import pytest

import manipkit
from manipkit.dh import DHRow, DHTable, dh_fk, load_dh
from manipkit.errors import DHTableError
from manipkit.spatial.transforms import transform_from_xyz_rpy

DH_DIR = Path(__file__).resolve().parents[1] / "robots" / "dh"
BUNDLED_TABLES = sorted(p.name for p in DH_DIR.glob("*.yaml"))


# --------------------------------------------------------------------------
# helpers


def rot_x(angle):
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[1.0, 0.0, 0.0, 0.0], [0.0, c, -s, 0.0], [0.0, s, c, 0.0], [0.0, 0.0, 0.0, 1.0]])


def trans_x(a):
    T = np.eye(4)
    T[0, 3] = a
    return T


def rot_z(angle):
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0, 0.0], [s, c, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]])


def samples_within_limits(robot, n, seed):
    """n joint vectors drawn uniformly inside the URDF's limits (fixed seed)."""
    lower = np.array([j.lower for j in robot.joints])
    upper = np.array([j.upper for j in robot.joints])
    return np.random.default_rng(seed).uniform(lower, upper, size=(n, len(robot.joints)))


def rotation_angle_deg(R_a, R_b):
    cos = (np.trace(np.swapaxes(R_a, -1, -2) @ R_b, axis1=-2, axis2=-1) - 1.0) / 2.0
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))



def random_table(rng, convention, n=5):
    """A table with revolute and prismatic rows, random parameters, limits on some rows, base and tool."""
    rows = []
    for i in range(n):
        kind = "prismatic" if i in (1, 3) else "revolute"
        qlim = (-0.5, 0.7) if kind == "prismatic" else ((-2.0, 2.5) if i == 0 else None)
        a, d = rng.uniform(-0.5, 0.5, size=2)
        alpha, theta = rng.uniform(-math.pi, math.pi, size=2)
        rows.append(DHRow(a, alpha, d, theta, kind, qlim))
    base_rpy, tool_rpy = rng.uniform(-math.pi, math.pi, size=(2, 3))
    base = transform_from_xyz_rpy(rng.uniform(-1, 1, 3), base_rpy)
    tool = transform_from_xyz_rpy(rng.uniform(-1, 1, 3), tool_rpy)
    return DHTable(rows, convention, f"random_{convention}", base, tool)


def random_q(table, rng, count):
    return np.column_stack([
        rng.uniform(-0.5, 0.7, count) if not row.is_revolute else rng.uniform(-math.pi, math.pi, count)
        for row in table.rows
    ])


def seed_table():
    return load_dh(DH_DIR / "iiwa14_seed004.yaml")


# --------------------------------------------------------------------------
# bundled tables (robots/dh/)


@pytest.mark.parametrize("filename", BUNDLED_TABLES)
def test_every_bundled_table_loads(filename):
    table = load_dh(DH_DIR / filename)
    assert table.n >= 2 and table.name == filename[: -len(".yaml")]


def test_the_four_bundled_tables_exist():
    assert set(BUNDLED_TABLES) >= {"planar_2r.yaml", "planar_3r.yaml", "iiwa14.yaml", "iiwa14_seed004.yaml"}


@pytest.mark.parametrize("name", ["planar_2r", "planar_3r", "iiwa14"])
def test_bundled_table_row_names_and_limits_are_the_urdf_joints(name):
    robot = manipkit.load(name)
    table = load_dh(DH_DIR / f"{name}.yaml")
    assert tuple(row.name for row in table.rows) == robot.joint_names
    for row, joint in zip(table.rows, robot.joints):
        assert row.qlim == pytest.approx((joint.lower, joint.upper), abs=1e-12)


def test_seed_table_is_exactly_seed_004_table_1():
    # Table 1 of seed 004 (modified DH), L1..L4 = 0.36, 0.42, 0.40, 0.126:
    #   i  a_{i-1}  alpha_{i-1}  d_i  theta_i
    #   1  0        0            L1   q1
    #   2  0        pi/2         0    pi + q2
    #   3  0        pi/2         L2   pi + q3
    #   4  0        pi/2         0    pi + q4
    #   5  0        pi/2         L3   pi + q5
    #   6  0        pi/2         0    pi + q6
    #   7  0        pi/2         0    q7
    #   8  0        0            L4   0          (no joint: the tool)
    table = seed_table()
    half, pi = math.pi / 2, math.pi
    expected = [(0, 0, 0.36, 0), (0, half, 0, pi), (0, half, 0.42, pi), (0, half, 0, pi),
                (0, half, 0.40, pi), (0, half, 0, pi), (0, half, 0, 0)]
    assert table.convention == "modified"
    assert np.abs(np.array([(r.a, r.alpha, r.d, r.theta) for r in table.rows]) - np.array(expected)).max() < 1e-15
    assert all(r.is_revolute for r in table.rows)
    tool = np.eye(4)
    tool[2, 3] = 0.126
    assert np.array_equal(table.base, np.eye(4)) and np.array_equal(table.tool, tool)


def test_seed_table_disagrees_with_the_urdf_by_metres_and_180_degrees():
    robot = manipkit.load("iiwa14")
    table = seed_table()
    Q = samples_within_limits(robot, 1000, seed=2024)
    T_urdf, T_seed = robot.fk(Q, tip="ee_link"), dh_fk(table, Q)
    position = np.linalg.norm(T_urdf[:, :3, 3] - T_seed[:, :3, 3], axis=1)
    rotation = rotation_angle_deg(T_urdf[:, :3, :3], T_seed[:, :3, :3])
    # Over these 1000 samples the flange positions differ by 0.86 m in the median and by up to
    # 1.8 m; the orientations by 26 to 180 deg (measured when this test was written).
    assert np.median(position) > 0.5 and position.max() > 1.5 and rotation.min() > 10.0
    # At q = 0 both stand straight up with the flange at z = L1 + L2 + L3 + L4 = 1.306 m, but the
    # seed's flange is turned by 180 deg about z: 0T8 = diag(-1, -1, 1) (seed eq. 4.4), the URDF's is I.
    q0 = np.zeros(7)
    assert np.linalg.norm(robot.fk(q0, tip="ee_link")[:3, 3] - dh_fk(table, q0)[:3, 3]) < 1e-12
    assert rotation_angle_deg(robot.fk(q0, tip="ee_link")[:3, :3], dh_fk(table, q0)[:3, :3]) == pytest.approx(180.0)
    # At q2 = 0.5 rad (others 0) the URDF arm leans towards +x, the seed's towards -x (joint 2
    # reversed): the flange is at x = +-(L2 + L3 + L4) sin 0.5 = +-0.946 * 0.479426 = +-0.453537 m,
    # so the positions differ by 2 * 0.453537 = 0.907074 m.
    q = np.array([0, 0.5, 0, 0, 0, 0, 0.0])
    assert robot.fk(q, tip="ee_link")[0, 3] == pytest.approx(0.946 * math.sin(0.5), abs=1e-12)
    assert dh_fk(table, q)[0, 3] == pytest.approx(-0.946 * math.sin(0.5), abs=1e-12)
    assert np.linalg.norm(robot.fk(q, tip="ee_link")[:3, 3] - dh_fk(table, q)[:3, 3]) == pytest.approx(0.907074, abs=1e-6)


def test_seed_table_is_the_urdf_with_joints_2_and_6_reversed_and_the_flange_turned_180_degrees():
    # The diagnosis written in robots/dh/iiwa14.yaml: T_seed(q) = T_urdf(q1, -q2, q3, q4, q5, -q6, q7) @ Rz(pi).
    robot = manipkit.load("iiwa14")
    Q = samples_within_limits(robot, 1000, seed=5)
    signs = np.array([1, -1, 1, 1, 1, -1, 1.0])
    assert np.abs(dh_fk(seed_table(), Q) - robot.fk(Q * signs, tip="ee_link") @ rot_z(math.pi)).max() < 1e-9


def test_corrected_iiwa_table_differs_from_the_seed_only_in_the_documented_entries():
    # Rows 2, 3, 6, 7: alpha +90 -> -90 (z2 and z6 reversed); row 7: theta offset 0 -> 180 (flange
    # turned); names and limits added. Everything else is the seed's.
    seed, fixed = seed_table(), load_dh(DH_DIR / "iiwa14.yaml")
    changes = []
    for i, (s, f) in enumerate(zip(seed.rows, fixed.rows), start=1):
        for field in ("a", "alpha", "d", "theta", "type"):
            if getattr(s, field) != getattr(f, field):
                changes.append((i, field, getattr(s, field), getattr(f, field)))
    half = math.pi / 2
    assert changes == [
        (2, "alpha", half, -half), (3, "alpha", half, -half), (6, "alpha", half, -half),
        (7, "alpha", half, -half), (7, "theta", 0.0, math.pi),
    ]
    assert np.array_equal(seed.base, fixed.base) and np.array_equal(seed.tool, fixed.tool)


def test_corrected_iiwa_dh_frames_have_the_urdf_joint_axes():
    # Each DH frame i's z axis is joint i's axis, pointing the same way as in the URDF (iiwa_link_i's z).
    robot = manipkit.load("iiwa14")
    table = load_dh(DH_DIR / "iiwa14.yaml")
    Q = samples_within_limits(robot, 50, seed=3)
    for i in range(1, 8):
        z_urdf = robot.fk(Q, tip=f"iiwa_link_{i}")[:, :3, 2]
        z_dh = dh_fk(table, Q, upto=i)[:, :3, 2]
        assert np.abs(z_urdf - z_dh).max() < 1e-12, i


# --------------------------------------------------------------------------
# tables


def test_tables_compare_equal_by_value():
    a = DHTable([DHRow(1, 0, 0, 0)], "standard", "x")
    assert a == DHTable([DHRow(1.0, 0.0, 0.0, 0.0)], "standard", "x")
    assert a != DHTable([DHRow(1, 0, 0, 0)], "modified", "x")
    assert a != DHTable([DHRow(1, 0, 0, 0)], "standard", "x", base=transform_from_xyz_rpy([0, 0, 1]))


def test_row_with_an_unknown_type_is_refused():
    with pytest.raises(ValueError, match="choose revolute or prismatic"):
        DHRow(0, 0, 0, 0, "spherical")


# --------------------------------------------------------------------------
# names: one line of printable text (they go into XML, YAML, LaTeX and boxes)


@pytest.mark.parametrize("name", ["a\nb", "x\x00", "esc\x1b[2J", "nel\x85", "\ud800"])
def test_a_row_or_table_name_with_a_control_character_is_refused(name):
    with pytest.raises(DHTableError, match="not printable text; a name is one line of printable text"):
        DHRow(1, 0, 0, 0, name=name)
    with pytest.raises(DHTableError, match="DH table name: character"):
        DHTable([DHRow(1, 0, 0, 0)], "standard", name)


def test_names_with_markup_characters_are_kept_as_text():
    name = 'a --> <link name="extra"/> \\input{x} %'
    assert DHTable([DHRow(1, 0, 0, 0, name=name)], "standard", name).rows[0].name == name


# issue 26: dh_fk passed NaN through, and took joint values no rotation can be read from
@pytest.mark.parametrize("value", [math.nan, math.inf, 1e7, 10**400])
def test_dh_fk_refuses_joint_values_that_are_not_finite_or_too_large(value):
    table = DHTable([DHRow(1.0, 0.0, 0.0, 0.0)], "standard", "one")
    with pytest.raises(manipkit.ManipkitError, match="q"):
        dh_fk(table, [value])
