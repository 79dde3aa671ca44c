"""manipkit.dh: table files, printing, symbolic FK, URDF export, and the bundled tables in robots/dh/.

Independent sources: Pinocchio on the bundled URDFs (``manipkit.load``)
against the tables in robots/dh/; ``dh_fk`` (numpy) against SymPy's
``dh_fk_symbolic``; ``dh_fk`` against Pinocchio and yourdfpy on the URDF that
``urdf_from_dh`` writes; and values worked out by hand in the comments or
printed in seed 004 (its Table 1, home pose and t_x, t_z formulas).
"""

import math
from io import BytesIO
from pathlib import Path

import numpy as np
import pytest
import sympy
from hypothesis import given, settings
from hypothesis import strategies as st

import manipkit
from manipkit.dh import (
    DHRow,
    DHTable,
    dh_fk,
    dh_fk_symbolic,
    dh_from_yaml,
    dh_symbols,
    format_dh_table,
    format_symbolic,
    load_dh,
    save_dh,
    shorthand,
    transform_from_xyz_rpy,
    urdf_from_dh,
    yaml_from_dh,
)
from manipkit.errors import DHTableError, ManipkitError
from manipkit.kinematics.robot import Robot

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


def write(tmp_path, text, name="table.yaml"):
    path = tmp_path / name
    path.write_text(text)
    return path


VALID = """\
name: two
convention: standard
angles: deg
joints:
  - {a: 1, alpha: 0, d: 0, theta: 0}
  - {a: 1, alpha: 90, d: 0.5, theta: 30}
"""


def error_for(tmp_path, text) -> str:
    path = write(tmp_path, text)
    with pytest.raises(DHTableError) as info:
        load_dh(path)
    message = str(info.value)
    assert message.startswith(str(path)) and "\n" not in message
    return message


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
    T_urdf, T_seed = robot.fk(Q, "ee_link"), dh_fk(table, Q)
    position = np.linalg.norm(T_urdf[:, :3, 3] - T_seed[:, :3, 3], axis=1)
    rotation = rotation_angle_deg(T_urdf[:, :3, :3], T_seed[:, :3, :3])
    # Over these 1000 samples the flange positions differ by 0.86 m in the median and by up to
    # 1.8 m; the orientations by 26 to 180 deg (measured when this test was written).
    assert np.median(position) > 0.5 and position.max() > 1.5 and rotation.min() > 10.0
    # At q = 0 both stand straight up with the flange at z = L1 + L2 + L3 + L4 = 1.306 m, but the
    # seed's flange is turned by 180 deg about z: 0T8 = diag(-1, -1, 1) (seed eq. 4.4), the URDF's is I.
    q0 = np.zeros(7)
    assert np.linalg.norm(robot.fk(q0, "ee_link")[:3, 3] - dh_fk(table, q0)[:3, 3]) < 1e-12
    assert rotation_angle_deg(robot.fk(q0, "ee_link")[:3, :3], dh_fk(table, q0)[:3, :3]) == pytest.approx(180.0)
    # At q2 = 0.5 rad (others 0) the URDF arm leans towards +x, the seed's towards -x (joint 2
    # reversed): the flange is at x = +-(L2 + L3 + L4) sin 0.5 = +-0.946 * 0.479426 = +-0.453537 m,
    # so the positions differ by 2 * 0.453537 = 0.907074 m.
    q = np.array([0, 0.5, 0, 0, 0, 0, 0.0])
    assert robot.fk(q, "ee_link")[0, 3] == pytest.approx(0.946 * math.sin(0.5), abs=1e-12)
    assert dh_fk(table, q)[0, 3] == pytest.approx(-0.946 * math.sin(0.5), abs=1e-12)
    assert np.linalg.norm(robot.fk(q, "ee_link")[:3, 3] - dh_fk(table, q)[:3, 3]) == pytest.approx(0.907074, abs=1e-6)


def test_seed_table_is_the_urdf_with_joints_2_and_6_reversed_and_the_flange_turned_180_degrees():
    # The diagnosis written in robots/dh/iiwa14.yaml: T_seed(q) = T_urdf(q1, -q2, q3, q4, q5, -q6, q7) @ Rz(pi).
    robot = manipkit.load("iiwa14")
    Q = samples_within_limits(robot, 1000, seed=5)
    signs = np.array([1, -1, 1, 1, 1, -1, 1.0])
    assert np.abs(dh_fk(seed_table(), Q) - robot.fk(Q * signs, "ee_link") @ rot_z(math.pi)).max() < 1e-9


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
        z_urdf = robot.fk(Q, f"iiwa_link_{i}")[:, :3, 2]
        z_dh = dh_fk(table, Q, upto=i)[:, :3, 2]
        assert np.abs(z_urdf - z_dh).max() < 1e-12, i


# --------------------------------------------------------------------------
# files: round trips


finite = st.floats(min_value=-1e6, max_value=1e6, allow_nan=False, allow_infinity=False)
degrees_values = st.floats(min_value=-1e6, max_value=1e6, allow_nan=False, allow_infinity=False)
names = st.text(alphabet=st.characters(blacklist_categories=("Cs", "Cc")), max_size=12)


@st.composite
def tables(draw, angle):
    n = draw(st.integers(1, 5))
    rows = []
    for _ in range(n):
        kind = draw(st.sampled_from(["revolute", "prismatic"]))
        qlim = None
        if draw(st.booleans()):
            lower, upper = sorted(draw(st.lists(angle if kind == "revolute" else finite, min_size=2, max_size=2, unique=True)))
            qlim = (lower, upper)
        rows.append(DHRow(draw(finite), draw(angle), draw(finite), draw(angle), kind, qlim, draw(names)))
    placements = {}
    for what in ("base", "tool"):
        if draw(st.booleans()):
            rpy = tuple(draw(st.lists(angle, min_size=3, max_size=3)))
            placements[what] = transform_from_xyz_rpy(draw(st.lists(finite, min_size=3, max_size=3)), rpy)
            placements[f"{what}_rpy"] = rpy
    return DHTable(rows, draw(st.sampled_from(["standard", "modified"])), draw(names), **placements)


@settings(max_examples=150, deadline=None)
@given(tables(finite))
def test_save_then_load_round_trips_exactly_in_radians(tmp_path_factory, table):
    path = tmp_path_factory.mktemp("rt") / "t.yaml"
    save_dh(table, path, angles="rad")
    assert load_dh(path) == table


@settings(max_examples=150, deadline=None)
@given(tables(degrees_values.map(math.radians)))
def test_save_then_load_round_trips_exactly_in_degrees(tmp_path_factory, table):
    # Angles are the radian values of float numbers of degrees, as every table read from a file in degrees.
    path = tmp_path_factory.mktemp("rt") / "t.yaml"
    save_dh(table, path, angles="deg")
    loaded = load_dh(path)
    assert loaded == table
    for what in ("base", "tool"):
        assert np.array_equal(getattr(loaded, what), getattr(table, what))


@pytest.mark.parametrize("filename", BUNDLED_TABLES)
def test_bundled_table_round_trips_through_save(tmp_path, filename):
    table = load_dh(DH_DIR / filename)
    save_dh(table, tmp_path / filename)
    assert load_dh(tmp_path / filename) == table


def test_saved_degrees_are_the_short_numbers_a_person_writes(tmp_path):
    # degrees(radians(30)) is 29.999999999999996; the writer picks 30, which reads back to the same float.
    table = DHTable([DHRow(0.36, math.radians(30), 0, math.radians(-90), qlim=(math.radians(-170), math.radians(170)))], "modified", "t")
    assert "{a: 0.36, alpha: 30, d: 0, theta: -90, qlim: [-170, 170]}" in yaml_from_dh(table)


def test_table_whose_base_is_a_bare_matrix_round_trips_to_rounding(tmp_path):
    base = transform_from_xyz_rpy([0.1, 0.2, 0.3], [0.3, -0.2, 1.0])
    table = DHTable([DHRow(1, 0, 0, 0)], "standard", "t", base=base)  # no base_rpy: rpy is recomputed
    save_dh(table, tmp_path / "t.yaml")
    assert np.abs(load_dh(tmp_path / "t.yaml").base - base).max() < 1e-15


def test_header_is_written_as_comments(tmp_path):
    save_dh(DHTable([DHRow(1, 0, 0, 0)]), tmp_path / "t.yaml", header="from the URDF\nchain base_link -> ee_link")
    assert (tmp_path / "t.yaml").read_text().startswith("# from the URDF\n# chain base_link -> ee_link\n")


def test_rpy_of_base_and_tool_are_in_the_files_angle_unit(tmp_path):
    text = "convention: standard\nangles: deg\nbase: {xyz: [0, 0, 1], rpy: [0, 0, 90]}\njoints:\n  - {a: 1, alpha: 0, d: 0, theta: 0}\n"
    base = load_dh(write(tmp_path, text)).base
    assert np.allclose(base, transform_from_xyz_rpy([0, 0, 1], [0, 0, math.pi / 2]), atol=1e-15)


def test_radians_are_the_default_angle_unit(tmp_path):
    text = "convention: standard\njoints:\n  - {a: 1, alpha: 1.5, d: 0, theta: 0, qlim: [-1, 1]}\n"
    row = load_dh(write(tmp_path, text)).rows[0]
    assert row.alpha == 1.5 and row.qlim == (-1.0, 1.0)


def test_prismatic_limits_stay_in_metres_in_a_degree_file(tmp_path):
    text = "convention: standard\nangles: deg\njoints:\n  - {a: 0, alpha: 0, d: 0, theta: 90, type: prismatic, qlim: [0, 0.5]}\n"
    row = load_dh(write(tmp_path, text)).rows[0]
    assert row.type == "prismatic" and row.qlim == (0.0, 0.5) and row.theta == math.radians(90)


def test_number_written_as_exponent_text_is_read(tmp_path):
    # PyYAML reads 1e-3 (no dot) as the string '1e-3'; the loader accepts it as a number.
    text = "convention: standard\njoints:\n  - {a: 1e-3, alpha: 0, d: 0, theta: 0}\n"
    assert load_dh(write(tmp_path, text)).rows[0].a == 0.001


def test_table_name_defaults_to_the_file_name(tmp_path):
    text = "convention: standard\njoints:\n  - {a: 1, alpha: 0, d: 0, theta: 0}\n"
    assert load_dh(write(tmp_path, text, "my_arm.yaml")).name == "my_arm"


# --------------------------------------------------------------------------
# files: errors (one per failure mode)


def test_missing_file_is_named(tmp_path):
    with pytest.raises(DHTableError, match=r"nope\.yaml: no such DH table file"):
        load_dh(tmp_path / "nope.yaml")


def test_malformed_yaml_names_the_line(tmp_path):
    text = "convention: standard\njoints:\n  - {a: 1, alpha: 0, d: 0, theta: 0\n  - {a: 1}\n"
    assert "malformed YAML at line 4" in error_for(tmp_path, text)


def test_missing_field_names_the_row_and_the_field(tmp_path):
    message = error_for(tmp_path, VALID.replace("alpha: 90, ", ""))
    assert "row 2: missing field 'alpha'; required fields: a, alpha, d, theta" in message


def test_unknown_field_suggests_the_closest_name(tmp_path):
    message = error_for(tmp_path, VALID.replace("alpha: 90", "alpah: 90"))
    assert "row 2: unknown field 'alpah' (did you mean 'alpha'?); valid fields: a, alpha, d, theta, type, qlim, name" in message


def test_unknown_top_level_field_suggests_the_closest_name(tmp_path):
    message = error_for(tmp_path, VALID.replace("convention:", "conventon:"))
    assert "unknown field 'conventon' (did you mean 'convention'?)" in message


def test_missing_convention_is_refused(tmp_path):
    message = error_for(tmp_path, VALID.replace("convention: standard\n", ""))
    assert "missing field 'convention'" in message


def test_non_numeric_value_names_row_field_and_unit(tmp_path):
    message = error_for(tmp_path, VALID.replace("theta: 30", "theta: thirty"))
    assert "row 2: field 'theta' is 'thirty', not a number; give a number in degrees (angles: deg)" in message


def test_boolean_is_not_a_number(tmp_path):
    message = error_for(tmp_path, VALID.replace("d: 0.5", "d: yes"))
    assert "row 2: field 'd' is True, not a number; give a number in metres" in message


def test_non_finite_value_is_refused(tmp_path):
    message = error_for(tmp_path, VALID.replace("d: 0.5", "d: .inf"))
    assert "row 2: field 'd' is inf, not finite" in message


def test_bad_convention_lists_the_valid_ones(tmp_path):
    message = error_for(tmp_path, VALID.replace("convention: standard", "convention: craig"))
    assert "field 'convention' is 'craig'; choose standard or modified" in message


def test_bad_angle_unit_lists_the_valid_ones(tmp_path):
    message = error_for(tmp_path, VALID.replace("angles: deg", "angles: degrees"))
    assert "field 'angles' is 'degrees'; choose rad or deg" in message


def test_bad_joint_type_lists_the_valid_ones(tmp_path):
    message = error_for(tmp_path, VALID.replace("theta: 30}", "theta: 30, type: linear}"))
    assert "row 2: field 'type' is 'linear'; choose revolute or prismatic" in message


def test_empty_joint_list_is_refused(tmp_path):
    message = error_for(tmp_path, "convention: standard\njoints: []\n")
    assert "field 'joints' is empty" in message


def test_repeated_key_is_refused_instead_of_keeping_the_last(tmp_path):
    message = error_for(tmp_path, VALID.replace("d: 0.5", "d: 0.5, d: 0.7"))
    assert "key 'd' given twice" in message


def test_limits_in_the_wrong_order_are_refused(tmp_path):
    message = error_for(tmp_path, VALID.replace("theta: 30}", "theta: 30, qlim: [90, -90]}"))
    assert "row 2: field 'qlim' is [90, -90]; the lower limit must be below the upper" in message


def test_limits_that_are_not_a_pair_are_refused(tmp_path):
    message = error_for(tmp_path, VALID.replace("theta: 30}", "theta: 30, qlim: 90}"))
    assert "row 2: field 'qlim' must be a list of 2 numbers" in message


def test_base_with_a_short_xyz_is_refused(tmp_path):
    message = error_for(tmp_path, VALID.replace("joints:", "base: {xyz: [0, 0]}\njoints:"))
    assert "base: field 'xyz' must be a list of 3 numbers in metres" in message


def test_tool_with_an_unknown_field_is_refused(tmp_path):
    message = error_for(tmp_path, VALID.replace("joints:", "tool: {xyz: [0, 0, 1], rot: [0, 0, 0]}\njoints:"))
    assert "field 'tool': unknown field 'rot'" in message


def test_row_that_is_not_a_mapping_is_refused(tmp_path):
    message = error_for(tmp_path, "convention: standard\njoints:\n  - [1, 0, 0, 0]\n")
    assert "row 1 must be a mapping {a, alpha, d, theta}; got a list" in message


def test_file_that_is_not_a_mapping_is_refused(tmp_path):
    message = error_for(tmp_path, "- a\n- b\n")
    assert "a DH table is a mapping with the keys" in message


def test_table_errors_are_manipkit_and_value_errors():
    with pytest.raises(ManipkitError):
        dh_from_yaml("convention: standard\njoints: []\n")
    with pytest.raises(ValueError):
        dh_from_yaml("convention: standard\njoints: []\n")


def test_saving_a_non_finite_value_is_refused(tmp_path):
    with pytest.raises(DHTableError, match="row 1 d is nan"):
        save_dh(DHTable([DHRow(0, 0, math.nan, 0)]), tmp_path / "t.yaml")


def test_row_with_an_unknown_type_is_refused():
    with pytest.raises(ValueError, match="choose revolute or prismatic"):
        DHRow(0, 0, 0, 0, "spherical")


# --------------------------------------------------------------------------
# printing


def test_standard_table_prints_as_a_boxed_table_with_heading():
    table = DHTable([DHRow(4, 0, 0, 0), DHRow(2, math.pi / 2, 0.5, -math.pi / 2, qlim=(-math.pi, math.pi))], "standard", "arm")
    assert format_dh_table(table) == "\n".join([
        "arm: standard DH, 2 joints (RR)",
        "┌───┬──────────┬─────┬────┬─────┬───────────────┐",
        "│ j │ θⱼ       │ dⱼ  │ aⱼ │ αⱼ  │ q limits      │",
        "├───┼──────────┼─────┼────┼─────┼───────────────┤",
        "│ 1 │ q1       │   0 │  4 │  0° │             - │",
        "│ 2 │ q2 - 90° │ 0.5 │  2 │ 90° │ [-180°, 180°] │",
        "└───┴──────────┴─────┴────┴─────┴───────────────┘",
    ])


def test_modified_table_prints_a_and_alpha_of_the_previous_row_first():
    text = format_dh_table(seed_table())
    assert text.splitlines()[0] == "iiwa14_seed004: modified DH, 7 joints (RRRRRRR)"
    assert text.splitlines()[2] == "│ j │ aⱼ₋₁ │ αⱼ₋₁ │ θⱼ        │ dⱼ   │ q limits │"
    assert "│ 2 │    0 │  90° │ q2 + 180° │    0 │        - │" in text


def test_prismatic_joint_variable_is_in_the_d_column():
    table = DHTable([DHRow(0, 0, 0.1, math.pi / 2, "prismatic", (0, 0.5))], "standard")
    assert "│ 1 │ 90° │ q1 + 0.1 │  0 │ 0° │ [0, 0.5] m │" in format_dh_table(table)


def test_base_and_tool_are_printed_below_the_table_when_not_identity():
    table = load_dh(DH_DIR / "iiwa14.yaml")
    last = format_dh_table(table).splitlines()[-1]
    assert last == "tool: xyz = [0, 0, 0.126] m, rpy = [0°, 0°, 0°] (R = Rz(yaw) Ry(pitch) Rx(roll))"
    assert "base:" not in format_dh_table(table)


def test_row_names_get_a_joint_column():
    assert "│ 1 │ joint1 │ q1 │" in format_dh_table(load_dh(DH_DIR / "planar_2r.yaml"))


def test_str_of_a_table_is_its_boxed_printout():
    table = load_dh(DH_DIR / "planar_3r.yaml")
    assert str(table) == format_dh_table(table)


# --------------------------------------------------------------------------
# symbolic forward kinematics


@pytest.mark.parametrize("filename", ["planar_2r.yaml", "planar_3r.yaml", "iiwa14.yaml", "iiwa14_seed004.yaml"])
def test_symbolic_fk_equals_numeric_fk_at_random_configurations(filename):
    table = load_dh(DH_DIR / filename)
    f = sympy.lambdify(dh_symbols(table.n), dh_fk_symbolic(table), "numpy")
    rng = np.random.default_rng(11)
    worst = max(np.abs(np.array(f(*q), dtype=float) - dh_fk(table, q)).max() for q in rng.uniform(-3, 3, (50, table.n)))
    assert worst < 1e-12


@pytest.mark.parametrize("convention", ["standard", "modified"])
def test_symbolic_fk_with_prismatic_rows_base_and_tool_equals_numeric_fk(convention):
    rng = np.random.default_rng(4)
    table = random_table(rng, convention)
    f = sympy.lambdify(dh_symbols(table.n), dh_fk_symbolic(table), "numpy")
    worst = max(np.abs(np.array(f(*q), dtype=float) - dh_fk(table, q)).max() for q in random_q(table, rng, 30))
    assert worst < 1e-12


def test_symbolic_fk_upto_stops_before_the_tool():
    table = load_dh(DH_DIR / "iiwa14.yaml")
    f = sympy.lambdify(dh_symbols(7), dh_fk_symbolic(table, upto=4), "numpy")
    q = np.random.default_rng(2).uniform(-2, 2, 7)
    assert np.abs(np.array(f(*q), dtype=float) - dh_fk(table, q, upto=4)).max() < 1e-12


def test_seed_home_pose_comes_out_exactly():
    # Seed eq. 4.4: at q = 0, 0T7 = [diag(-1, -1, 1) | (0, 0, L1 + L2 + L3)] and
    # 0T8 = [diag(-1, -1, 1) | (0, 0, L1 + L2 + L3 + L4)], with
    # L1 + L2 + L3 = 0.36 + 0.42 + 0.40 = 1.18 = 59/50 and + L4 = 1.306 = 653/500.
    table = seed_table()
    zero = {q: 0 for q in dh_symbols(7)}
    T08 = dh_fk_symbolic(table).subs(zero)
    T07 = dh_fk_symbolic(table, upto=7).subs(zero)
    rotation = [[-1, 0, 0], [0, -1, 0], [0, 0, 1]]
    assert T08 == sympy.Matrix([[*rotation[0], 0], [*rotation[1], 0], [*rotation[2], sympy.Rational(653, 500)], [0, 0, 0, 1]])
    assert T07 == sympy.Matrix([[*rotation[0], 0], [*rotation[1], 0], [*rotation[2], sympy.Rational(59, 50)], [0, 0, 0, 1]])


def test_seed_translation_matches_the_seeds_printed_formulas():
    # Seed appendix, "Tooltip transformation matrix elements" (in the shorthand c_i, s_i):
    # t_x = -L2 c1 s2 - L3 (c1 c4 s2 + s4 (c1 c2 c3 - s1 s3))
    #       - L4 (c6 (c1 c4 s2 + s4 (c1 c2 c3 - s1 s3)) - s6 (c5 (c1 s2 s4 - c4 (c1 c2 c3 - s1 s3)) + s5 (c1 c2 s3 + c3 s1)))
    # t_z = L1 + L2 c2 + L3 (c2 c4 - c3 s2 s4) + L4 (c6 (c2 c4 - c3 s2 s4) - s6 (c5 (c2 s4 + c3 c4 s2) - s2 s3 s5))
    c = sympy.symbols("c_1:8", real=True)
    s = sympy.symbols("s_1:8", real=True)
    c1, c2, c3, c4, c5, c6, c7 = c
    s1, s2, s3, s4, s5, s6, s7 = s
    L1, L2, L3, L4 = (sympy.Rational(v) for v in ("0.36", "0.42", "0.40", "0.126"))
    t_x = (-L2 * c1 * s2 - L3 * (c1 * c4 * s2 + s4 * (c1 * c2 * c3 - s1 * s3))
           - L4 * (c6 * (c1 * c4 * s2 + s4 * (c1 * c2 * c3 - s1 * s3))
                   - s6 * (c5 * (c1 * s2 * s4 - c4 * (c1 * c2 * c3 - s1 * s3)) + s5 * (c1 * c2 * s3 + c3 * s1))))
    t_z = L1 + L2 * c2 + L3 * (c2 * c4 - c3 * s2 * s4) + L4 * (c6 * (c2 * c4 - c3 * s2 * s4) - s6 * (c5 * (c2 * s4 + c3 * c4 * s2) - s2 * s3 * s5))
    T = shorthand(dh_fk_symbolic(seed_table()))
    assert sympy.expand(T[0, 3] - t_x) == 0
    assert sympy.expand(T[2, 3] - t_z) == 0


def test_short_decimal_lengths_become_exact_rationals():
    T = dh_fk_symbolic(DHTable([DHRow(0, 0, 0.36, 0)], "modified"))
    assert T[2, 3] == sympy.Rational(9, 25)


def test_long_decimal_lengths_stay_floats():
    T = dh_fk_symbolic(DHTable([DHRow(0, 0, 0.1234567891234, 0)], "modified"))
    assert isinstance(T[2, 3], sympy.Float) and float(T[2, 3]) == 0.1234567891234


def test_angles_that_are_multiples_of_15_degrees_become_exact():
    # alpha = 30 deg: row A = Rx(pi/6) Tx(0) Rz(q1) Tz(1); its (1, 2) entry is -sin(pi/6) = -1/2 exactly,
    # and the z translation d cos(alpha) = cos(pi/6) = sqrt(3)/2.
    T = dh_fk_symbolic(DHTable([DHRow(0, math.radians(30), 1, 0)], "modified"))
    assert T[1, 2] == sympy.Rational(-1, 2) and T[2, 3] == sympy.sqrt(3) / 2


def test_simplify_folds_sums_of_joint_angles():
    # Planar 3R (4, 2, 1): x = 4 cos q1 + 2 cos(q1 + q2) + cos(q1 + q2 + q3) (the URDF's comment).
    q1, q2, q3 = dh_symbols(3)
    T = dh_fk_symbolic(load_dh(DH_DIR / "planar_3r.yaml"))
    assert T[0, 3] == 4 * sympy.cos(q1) + 2 * sympy.cos(q1 + q2) + sympy.cos(q1 + q2 + q3)
    assert T[0, 0] == sympy.cos(q1 + q2 + q3)


def test_trigsimp_option_gives_the_same_matrix_as_the_default_on_a_planar_arm():
    table = load_dh(DH_DIR / "planar_2r.yaml")
    assert sympy.simplify(dh_fk_symbolic(table, simplify="trigsimp") - dh_fk_symbolic(table)) == sympy.zeros(4, 4)


def test_without_simplify_the_product_is_left_as_it_is():
    T = dh_fk_symbolic(load_dh(DH_DIR / "planar_2r.yaml"), simplify=False)
    q1, q2 = dh_symbols(2)
    assert T[0, 0] == sympy.cos(q1) * sympy.cos(q2) - sympy.sin(q1) * sympy.sin(q2)


def test_custom_symbol_names_are_used():
    t1, t2 = sympy.symbols("theta_1 theta_2", real=True)
    T = dh_fk_symbolic(load_dh(DH_DIR / "planar_2r.yaml"), symbols=["theta_1", "theta_2"])
    assert T[0, 3] == sympy.cos(t1) + sympy.cos(t1 + t2)


def test_prismatic_symbol_is_added_to_d():
    q1 = dh_symbols(1)[0]
    T = dh_fk_symbolic(DHTable([DHRow(0, 0, 0.5, 0, "prismatic")], "standard"))
    assert T[2, 3] == q1 + sympy.Rational(1, 2)


def test_wrong_number_of_symbols_is_refused():
    with pytest.raises(ValueError, match="2 joint symbols needed, got 3"):
        dh_fk_symbolic(load_dh(DH_DIR / "planar_2r.yaml"), symbols="a b c")


def test_shorthand_writes_c_i_s_i_and_joined_indices():
    T = shorthand(dh_fk_symbolic(load_dh(DH_DIR / "planar_3r.yaml")))
    c_1, c_12, c_123, s_123 = sympy.symbols("c_1 c_12 c_123 s_123", real=True)
    assert T[0, 3] == 4 * c_1 + 2 * c_12 + c_123
    assert T[1, 0] == s_123


def test_shorthand_uses_the_number_in_custom_symbol_names():
    t1 = sympy.Symbol("theta_1", real=True)
    assert shorthand(sympy.sin(t1)) == sympy.Symbol("s_1", real=True)


def test_latex_form_is_a_bmatrix():
    text = format_symbolic(shorthand(dh_fk_symbolic(load_dh(DH_DIR / "planar_2r.yaml"))), latex=True)
    assert text.startswith(r"\begin{bmatrix}") and text.endswith(r"\end{bmatrix}") and "c_{12}" in text


def test_text_form_is_the_pretty_matrix_when_narrow():
    text = format_symbolic(sympy.Matrix([[1, 0], [0, 1]]))
    assert text == sympy.pretty(sympy.Matrix([[1, 0], [0, 1]]), use_unicode=True)


def test_text_form_lists_entries_when_too_wide():
    T = shorthand(dh_fk_symbolic(seed_table()))
    lines = format_symbolic(T, width=100).splitlines()
    assert len(lines) == 16 and lines[0].startswith("T[1,1] = ") and lines[-1] == "T[4,4] = 1"


# --------------------------------------------------------------------------
# URDF export


def yourdfpy_fk(text, joint_names, Q, frame="ee_link"):
    import yourdfpy

    urdf = yourdfpy.URDF.load(BytesIO(text.encode()), build_scene_graph=True, load_meshes=False,
                              build_collision_scene_graph=False, load_collision_meshes=False)
    out = []
    for q in Q:
        urdf.update_cfg(dict(zip(joint_names, q)))
        out.append(urdf.get_transform(frame_to=frame, frame_from="base_link"))
    return np.array(out)


@pytest.mark.parametrize("convention", ["standard", "modified"])
def test_urdf_chain_equals_dh_fk_in_pinocchio_at_200_configurations(convention):
    # Revolute and prismatic rows, random twists and offsets, non-identity base and tool.
    rng = np.random.default_rng(17)
    table = random_table(rng, convention)
    robot = Robot.from_urdf(urdf_from_dh(table))
    assert robot.joint_names == tuple(f"joint_{i}" for i in range(1, 6))
    Q = random_q(table, rng, 200)
    assert np.abs(robot.fk(Q, "ee_link") - dh_fk(table, Q)).max() < 1e-12


@pytest.mark.parametrize("convention", ["standard", "modified"])
def test_urdf_chain_equals_dh_fk_in_yourdfpy_at_200_configurations(convention):
    rng = np.random.default_rng(23)
    table = random_table(rng, convention)
    Q = random_q(table, rng, 200)
    T = yourdfpy_fk(urdf_from_dh(table), [f"joint_{i}" for i in range(1, 6)], Q)
    assert np.abs(T - dh_fk(table, Q)).max() < 1e-12


def test_modified_urdf_links_are_the_dh_frames():
    rng = np.random.default_rng(5)
    table = random_table(rng, "modified")
    robot = Robot.from_urdf(urdf_from_dh(table))
    Q = random_q(table, rng, 50)
    for i in range(table.n + 1):
        assert np.abs(robot.fk(Q, f"link_{i}") - dh_fk(table, Q, upto=i)).max() < 1e-12, i


def test_standard_urdf_link_i_is_dh_frame_i_before_its_common_normal():
    # Standard DH: A_i = Rz(theta_i + q_i) Tz(d_i) Tx(a_i) Rx(alpha_i). URDF joint i turns about z_{i-1},
    # so link_i = frame_{i-1} Rz(theta_i + q_i) Tz(d_i) and frame_i = link_i Tx(a_i) Rx(alpha_i).
    rng = np.random.default_rng(6)
    table = random_table(rng, "standard")
    robot = Robot.from_urdf(urdf_from_dh(table))
    Q = random_q(table, rng, 50)
    assert np.abs(robot.fk(Q, "link_0") - dh_fk(table, Q, upto=0)).max() < 1e-12
    for i, row in enumerate(table.rows, start=1):
        T_frame_i = robot.fk(Q, f"link_{i}") @ trans_x(row.a) @ rot_x(row.alpha)
        assert np.abs(T_frame_i - dh_fk(table, Q, upto=i)).max() < 1e-12, i


def test_urdf_from_the_iiwa_table_agrees_with_the_bundled_iiwa():
    table = load_dh(DH_DIR / "iiwa14.yaml")
    exported, bundled = Robot.from_urdf(urdf_from_dh(table)), manipkit.load("iiwa14")
    assert exported.joint_names == bundled.joint_names  # the rows' names
    Q = samples_within_limits(bundled, 200, seed=9)
    assert np.abs(exported.fk(Q, "ee_link") - bundled.fk(Q, "ee_link")).max() < 1e-12


def test_urdf_joint_limits_are_the_rows_or_the_defaults():
    table = DHTable([DHRow(0, 0, 0, 0, qlim=(-1.0, 2.0)), DHRow(0, 0, 0, 0), DHRow(0, 0, 0, 0, "prismatic")], "standard")
    robot = Robot.from_urdf(urdf_from_dh(table))
    assert [(j.type, j.lower, j.upper) for j in robot.joints] == [
        ("revolute", -1.0, 2.0), ("revolute", -math.pi, math.pi), ("prismatic", -1.0, 1.0)]


def test_urdf_links_have_visuals_and_positive_masses():
    text = urdf_from_dh(load_dh(DH_DIR / "iiwa14.yaml"))
    robot = Robot.from_urdf(text)
    assert all(inertia.mass > 0 for inertia in robot.model.inertias[1:])
    assert text.count("<cylinder ") >= 7 + 4  # a joint marker per moving link and the d segments
    assert {"base_link", "link_0", "link_7", "ee_link"} <= set(robot.frame_names)


def test_urdf_robot_name_defaults_to_the_table_name():
    assert '<robot name="planar_2r">' in urdf_from_dh(load_dh(DH_DIR / "planar_2r.yaml"))
    assert '<robot name="other">' in urdf_from_dh(load_dh(DH_DIR / "planar_2r.yaml"), name="other")


# --------------------------------------------------------------------------
# tables


def test_tables_compare_equal_by_value():
    a = DHTable([DHRow(1, 0, 0, 0)], "standard", "x")
    assert a == DHTable([DHRow(1.0, 0.0, 0.0, 0.0)], "standard", "x")
    assert a != DHTable([DHRow(1, 0, 0, 0)], "modified", "x")
    assert a != DHTable([DHRow(1, 0, 0, 0)], "standard", "x", base=transform_from_xyz_rpy([0, 0, 1]))
