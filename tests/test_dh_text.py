"""manipkit.dh.text: the boxed printout of a DH table (``str(table)``)."""

import math

from test_dh_table import DH_DIR, seed_table

from manipkit.dh import DHRow, DHTable, format_dh_table, load_dh

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
