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


# --------------------------------------------------------------------------
# float noise (issue 14, finding 7)


def test_float_noise_of_a_derivation_prints_as_zero(load_robot):
    # ur5's URDF writes pi/2 as 1.570796325, so the derived theta offsets of rows 2 and 4 are -4.9e-12 rad
    # (-2.8e-10 deg): noise, printed as "q2", not "q2 - 2.80557e-10°". kinova's base has a translation of
    # -3.2e-14 m and angles of 1e-23 deg.
    from manipkit.dh import dh_from_urdf_chain

    ur5 = dh_from_urdf_chain(load_robot("ur5"), convention="standard")
    assert 0 < abs(ur5.rows[1].theta) < 1e-10  # the noise is there in the numbers (kept: FK stays exact)
    text = format_dh_table(ur5)
    assert "e-" not in text and "│ 2 │ q2 │" in text
    kinova = format_dh_table(dh_from_urdf_chain(load_robot("kinova"), convention="standard"))
    assert "base: xyz = [0, 0, 0] m, rpy = [180°, 0°, 0°]" in kinova and "e-" not in kinova


def test_a_tool_at_gimbal_lock_prints_roll_0_and_says_so(load_robot):
    # ur5, modified DH: the tool's rotation has pitch -90 deg up to 5e-12 rad of noise, where only yaw + roll
    # is defined. Before, the noise chose roll = 90, yaw = 180; now roll = 0 and yaw = -90 (same rotation:
    # Rz(180) Ry(-90) Rx(90) = Rz(-90) Ry(-90), checked below against the table's matrix).
    from manipkit.dh import dh_from_urdf_chain
    from manipkit.spatial.rotations import matrix_from_rpy

    table = dh_from_urdf_chain(load_robot("ur5"), convention="modified")
    last = format_dh_table(table).splitlines()[-1]
    assert last == (
        "tool: xyz = [0, 0, 0] m, rpy = [0°, -90°, -90°] (R = Rz(yaw) Ry(pitch) Rx(roll); "
        "gimbal lock: only yaw + roll is defined, roll set to 0)"
    )
    printed = matrix_from_rpy([0.0, -math.pi / 2, -math.pi / 2])
    assert abs(printed - table.tool[:3, :3]).max() < 1e-9
    assert abs(matrix_from_rpy([math.pi / 2, -math.pi / 2, math.pi]) - printed).max() < 1e-12


# --------------------------------------------------------------------------
# Jupyter views (issue 14, finding 9: a DHTable showed as a raw dataclass dump)


def test_repr_is_one_readable_line():
    table = load_dh(DH_DIR / "iiwa14.yaml")
    assert repr(table) == "DHTable('iiwa14', modified DH, 7 joints RRRRRRR, with tool; print() it for the table)"


def test_html_view_has_one_row_per_joint_with_the_printout_cells_escaped():
    table = DHTable([DHRow(1, 0, 0, 0, name="j<1>"), DHRow(0.5, math.pi / 2, 0.2, math.pi / 2)], "standard", "arm & co")
    html = table._repr_html_()
    assert "arm &amp; co: standard DH, 2 joints (RR)" in html and "j&lt;1&gt;" in html and "<j<1>" not in html
    assert html.count("<tr>") == 3  # the header and two joints
    assert "<td style=\"text-align: right\">q2 + 90°</td>" in html and "<td style=\"text-align: right\">90°</td>" in html


def test_latex_view_is_math_with_joint_variables_and_escaped_names():
    table = DHTable([DHRow(1, 0, 0, 0, name="shoulder_pan"), DHRow(0.5, math.pi / 2, 0.2, -math.pi / 2)], "standard", "a_b")
    latex = table._repr_latex_()
    assert latex.startswith("$$\n\\begin{array}{rrrrrrr}") and latex.endswith("\\end{array}\n$$")
    assert "\\text{a\\_b: standard DH, 2 joints (RR)}" in latex
    assert "j & \\text{joint} & \\theta_j & d_j & a_j & \\alpha_j & q\\ \\text{limits} \\\\ \\hline" in latex
    assert "2 & \\text{-} & q_{2} - 90^\\circ & 0.2 & 0.5 & 90^\\circ & - \\\\" in latex
