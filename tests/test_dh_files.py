"""manipkit.dh.files: DH table files, written and read back bit for bit, and one test per failure mode."""

import math
import os

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_dh_table import BUNDLED_TABLES, DH_DIR

from manipkit.dh import DHRow, DHTable, dh_from_yaml, load_dh, save_dh, yaml_from_dh
from manipkit.errors import DHTableError, ManipkitError, OutputError
from manipkit.inputs import MAX_TABLE_BYTES
from manipkit.spatial.transforms import transform_from_xyz_rpy

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


# --------------------------------------------------------------------------
# files users download: bounded, no aliases, every fault one line (issue 15)

ROW = "  - {a: 1, alpha: 0, d: 0, theta: 0}\n"


def laughs(levels=9):
    """A billion-laughs list: level k holds nine aliases of level k - 1, 9**levels items once expanded."""
    items = ["&l0 [lol, lol, lol, lol, lol, lol, lol, lol, lol]"]
    items += [f"&l{k} [{', '.join([f'*l{k - 1}'] * 9)}]" for k in range(1, levels)]
    return "[" + ", ".join(items) + "]"


@pytest.mark.parametrize("where", ["name", "qlim"])
def test_nested_aliases_are_refused_before_they_expand(tmp_path, where):
    text = (f"name: {laughs()}\nconvention: standard\njoints:\n{ROW}" if where == "name"
            else f"convention: standard\njoints:\n  - {{a: 1, alpha: 0, d: 0, theta: 0, qlim: {laughs()}}}\n")
    message = error_for(tmp_path, text)
    assert "alias *l0 refused; a DH table file holds no aliases" in message


def test_an_alias_of_a_list_that_contains_itself_is_refused(tmp_path):
    assert "alias *rows refused" in error_for(tmp_path, "convention: standard\njoints: &rows\n  - {a: 1, alpha: 0, d: 0, theta: 0, name: *rows}\n")


def test_an_anchor_without_an_alias_is_read(tmp_path):
    table = load_dh(write(tmp_path, "convention: standard\njoints:\n  - {a: &len 0.5, alpha: 0, d: 0, theta: 0}\n"))
    assert table.rows[0].a == 0.5


@pytest.mark.parametrize("digits", [401, 5000])
def test_an_integer_too_large_for_a_float_names_row_and_field(tmp_path, digits):
    text = f"convention: standard\njoints:\n{ROW}  - {{a: 0, alpha: 0, d: {'7' * digits}, theta: 0}}\n"
    message = error_for(tmp_path, text)
    assert f"row 2: field 'd' is an integer of {digits} digits, too large; give a number in metres" in message
    assert len(message) < 300


def test_an_integer_of_300_digits_is_read_as_the_float_it_is(tmp_path):
    table = load_dh(write(tmp_path, f"convention: standard\njoints:\n  - {{a: 0, alpha: 0, d: 1{'0' * 299}, theta: 0}}\n"))
    assert table.rows[0].d == 1e299


def test_nesting_deeper_than_a_table_needs_is_refused(tmp_path):
    text = "convention: standard\njoints:\n  - {a: " + "[" * 5000 + "]" * 5000 + ", alpha: 0, d: 0, theta: 0}\n"
    assert "line 3: nested more than 16 levels deep" in error_for(tmp_path, text)


def test_more_values_than_a_table_can_hold_are_refused_while_reading(tmp_path):
    text = "convention: standard\njoints:\n  - {a: 0, alpha: 0, d: 0, theta: 0, qlim: [" + ", ".join(["0"] * 30000) + "]}\n"
    assert "more than 26000 values, above the limit for a DH table (1000 rows at most)" in error_for(tmp_path, text)


def test_a_table_of_1000_rows_is_read_and_1001_refused(tmp_path):
    assert load_dh(write(tmp_path, "convention: standard\njoints:\n" + ROW * 1000)).n == 1000
    message = error_for(tmp_path, "convention: standard\njoints:\n" + ROW * 1001)
    assert "field 'joints' has 1001 rows, above the limit of 1000 rows of a DH table" in message


@pytest.mark.parametrize("name, index, code", [('"arm\\nx"', 4, "000A"), ('"a\\e[2J"', 2, "001B"), ('"j\\ud800"', 2, "D800"),
                                               ('"tab\\tx"', 4, "0009")])
def test_a_name_that_is_not_one_line_of_printable_text_is_refused(tmp_path, name, index, code):
    message = error_for(tmp_path, f"name: {name}\nconvention: standard\njoints:\n{ROW}")
    assert f"field 'name': character {index} is U+{code}, not printable text" in message
    row_message = error_for(tmp_path, f"convention: standard\njoints:\n  - {{a: 1, alpha: 0, d: 0, theta: 0, name: {name}}}\n")
    assert f"row 1: field 'name': character {index} is U+{code}" in row_message


def test_a_value_yaml_takes_for_a_date_but_is_none_is_not_a_number(tmp_path):
    message = error_for(tmp_path, "convention: standard\njoints:\n  - {a: 2020-13-45, alpha: 0, d: 0, theta: 0}\n")
    assert "row 1: field 'a' is '2020-13-45', not a number" in message


def test_messages_stay_short_whatever_the_file_holds(tmp_path):
    key = error_for(tmp_path, "convention: standard\n? " + "k" * 100000 + "\n: 1\njoints:\n" + ROW)
    convention = error_for(tmp_path, "convention: " + "s" * 100000 + "\njoints:\n" + ROW)
    text = error_for(tmp_path, "convention: standard\njoints:\n  - {a: " + "x" * 100000 + ", alpha: 0, d: 0, theta: 0}\n")
    assert "unknown field 'kkkkk" in key and "field 'convention' is 'sssss" in convention and "field 'a' is 'xxxx" in text
    assert max(len(key), len(convention), len(text)) < 300


def test_a_fifo_is_refused_without_waiting_for_a_writer(tmp_path):
    fifo = tmp_path / "table.yaml"
    os.mkfifo(fifo)
    with pytest.raises(DHTableError, match=r"table\.yaml is a FIFO \(named pipe\), not a regular file"):
        load_dh(fifo)


@pytest.mark.parametrize("path, kind", [("/dev/zero", "a character device"), (".", "a folder")])
def test_a_device_or_folder_is_refused(path, kind):
    with pytest.raises(DHTableError, match=f"is {kind}, not a regular file"):
        load_dh(path)


def test_a_file_above_the_table_size_limit_is_refused_unread(tmp_path):
    path = tmp_path / "big.yaml"
    with path.open("w") as stream:
        stream.write("convention: standard\njoints:\n")
        stream.truncate(MAX_TABLE_BYTES + 1)
    with pytest.raises(DHTableError, match=r"big.yaml is 4,194,305 bytes, above the limit of 4 MB \(4,194,304 bytes\)"):
        load_dh(path)


def test_a_file_that_is_not_utf8_is_refused_with_the_byte(tmp_path):
    path = tmp_path / "t.yaml"
    path.write_bytes(b"name: caf\xe9\nconvention: standard\njoints:\n" + ROW.encode())
    with pytest.raises(DHTableError, match=r"t\.yaml: not utf-8 text \(byte 9"):
        load_dh(path)


def test_saving_into_a_missing_folder_creates_nothing(tmp_path):
    with pytest.raises(OutputError, match="cannot write .*missing/t.yaml: no such folder"):
        save_dh(DHTable([DHRow(1, 0, 0, 0)]), tmp_path / "missing" / "t.yaml")
    assert not (tmp_path / "missing").exists()


def test_saving_onto_a_folder_is_refused(tmp_path):
    with pytest.raises(OutputError, match="it is a folder"):
        save_dh(DHTable([DHRow(1, 0, 0, 0)]), tmp_path)


# --------------------------------------------------------------------------
# API parity with the CLI (issue 14, finding 9)


def test_load_dh_takes_a_bundled_table_name_like_the_cli():
    from manipkit.description.sources import bundled_dh_tables

    for name, path in bundled_dh_tables().items():
        assert load_dh(name) == load_dh(path)


def test_load_dh_of_an_unknown_name_lists_the_bundled_tables():
    with pytest.raises(DHTableError, match=r"iiwa15: no such DH table file; did you mean iiwa14.*bundled tables: "):
        load_dh("iiwa15")


@pytest.mark.parametrize(("text", "expected"), [
    ("pi/2", math.pi / 2), ("-pi/4", -math.pi / 4), ("3*pi/4", 3 * math.pi / 4), ("2pi/3", 2 * math.pi / 3),
    ("(pi + 0.5)/2", (math.pi + 0.5) / 2), (" -pi ", -math.pi), ("π/6", math.pi / 6),
])
def test_angles_in_radians_may_be_pi_expressions(text, expected):
    table = dh_from_yaml(
        f"convention: standard\nangles: rad\nbase: {{rpy: [0, '{text}', 0]}}\n"
        f"joints:\n  - {{a: 1, alpha: '{text}', d: 0, theta: {text}, qlim: ['-{text}', 4]}}\n"
    )
    row = table.rows[0]
    assert row.alpha == pytest.approx(expected, abs=1e-15) and row.theta == pytest.approx(expected, abs=1e-15)
    assert row.qlim[0] == pytest.approx(-expected, abs=1e-15)
    assert table.base_rpy[1] == pytest.approx(expected, abs=1e-15)


@pytest.mark.parametrize(("text", "message"), [
    ("pi/", "not a number or pi expression"),
    ("pi**2", "not a number or pi expression"),
    ("__import__('os')", "not a number"),
    ("pi/0", "not a number or pi expression"),
    ("pi" + "+pi" * 40, "not a number or pi expression"),  # too long
])
def test_bad_pi_expressions_are_refused_without_eval(text, message):
    with pytest.raises(DHTableError, match=message):
        dh_from_yaml(f'convention: standard\nangles: rad\njoints:\n  - {{a: 1, alpha: "{text}", d: 0, theta: 0}}\n')


def test_pi_expressions_in_a_degree_file_say_to_use_radians():
    with pytest.raises(DHTableError, match=r"row 1: field 'alpha' is 'pi/2', a pi expression, but the file's angles are degrees"):
        dh_from_yaml("convention: standard\nangles: deg\njoints:\n  - {a: 1, alpha: pi/2, d: 0, theta: 0}\n")
