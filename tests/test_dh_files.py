"""manipkit.dh.files: DH table files, written and read back bit for bit, and one test per failure mode."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_dh_table import BUNDLED_TABLES, DH_DIR

from manipkit.dh import DHRow, DHTable, dh_from_yaml, load_dh, save_dh, transform_from_xyz_rpy, yaml_from_dh
from manipkit.errors import DHTableError, ManipkitError

# --------------------------------------------------------------------------
# helpers


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
