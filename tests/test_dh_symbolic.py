"""manipkit.dh.symbolic: DH forward kinematics in SymPy.

Independent sources: ``dh_fk`` (numpy) against SymPy's ``dh_fk_symbolic``,
and seed 004's home pose and printed t_x, t_z formulas.
"""

import math

import numpy as np
import pytest
import sympy
from test_dh_table import DH_DIR, random_q, random_table, seed_table

from manipkit.dh import DHRow, DHTable, dh_fk, dh_fk_symbolic, dh_symbols, format_symbolic, load_dh, shorthand
from manipkit.dh.symbolic import MAX_SYMBOLIC_OPS
from manipkit.errors import DHDerivationError

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
    # 4 rows (revolute, prismatic, revolute, prismatic), as in the symbolic Jacobian's test: every kind of row, a base
    # and a tool; a fifth (revolute) row adds no kind of row and triples SymPy's time (1 s -> 3 s here)
    table = random_table(rng, convention, n=4)
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
# bounded work (issue 15): rows and operations, with a message pointing at the numeric form


def twisted_table(n, alpha_deg=30):
    return DHTable([DHRow(0.1 * (i + 1), math.radians(alpha_deg), 0.05, 0) for i in range(n)], "standard", f"twisted{n}")


def test_symbolic_fk_of_more_rows_than_the_limit_is_refused_before_any_work():
    with pytest.raises(DHDerivationError, match="200 rows, above the limit of 20 rows for symbolic forward kinematics; "
                                                 r"print the numeric table instead \(manipkit dh show TABLE, without --symbolic"):
        dh_fk_symbolic(twisted_table(200, alpha_deg=0))


def test_symbolic_fk_stops_when_the_matrix_passes_the_operation_limit():
    # 30 deg twists: about 4,500 operations after 5 rows, 12,000 after 6 (sympy.count_ops)
    T5 = dh_fk_symbolic(twisted_table(5))
    assert sum(sympy.count_ops(entry) for entry in T5) <= MAX_SYMBOLIC_OPS
    with pytest.raises(DHDerivationError, match=r"twisted8': the symbolic T_base_tool grows to \d+ operations at row 6 of 8, "
                                                 "above the limit of 10000"):
        dh_fk_symbolic(twisted_table(8))


def test_operation_and_row_limits_can_be_given():
    table = load_dh(DH_DIR / "planar_2r.yaml")
    with pytest.raises(DHDerivationError, match="at row 2 of 2, above the limit of 20"):
        dh_fk_symbolic(table, max_ops=20)
    with pytest.raises(DHDerivationError, match="2 rows, above the limit of 1 rows"):
        dh_fk_symbolic(table, max_rows=1)


def test_the_bundled_tables_stay_well_inside_the_limits():
    for path in sorted(DH_DIR.glob("*.yaml")):
        T = dh_fk_symbolic(load_dh(path))
        assert sum(sympy.count_ops(entry) for entry in T) < MAX_SYMBOLIC_OPS / 4, path.name


def test_latex_title_stays_inside_its_comment():
    q1 = sympy.Symbol("q1", real=True)
    text = format_symbolic(sympy.Matrix([[sympy.cos(q1)]]), latex=True, title="T of arm\n\\input{/etc/passwd}\r\u2028x")
    first, rest = text.split("\n", 1)
    assert first == "% T of arm \\input{/etc/passwd}  x" and rest.startswith("\\begin{bmatrix}")
    assert format_symbolic(sympy.Matrix([[1]]), title="T of arm").splitlines()[0] == "T of arm"


@pytest.mark.parametrize("names", [["q1", "x}\\input{y"], ["q1", "a b"], ["$", "q2"]])
def test_joint_symbols_must_be_names(names):
    with pytest.raises(DHDerivationError, match="is not a name; use letters, digits and _"):
        dh_symbols(2, [sympy.Symbol(name) for name in names])


def test_symbols_true_writes_lengths_as_symbols_that_substitute_back():
    # Issue 14: symbolic FK wrote link lengths as fractions (21/50); symbols=True gives L1..Ln and d1..dn.
    from manipkit.dh.symbolic import dh_length_symbols

    planar = load_dh("planar_2r")
    T = dh_fk_symbolic(planar, symbols=True)
    L1, L2, q1, q2 = sympy.symbols("L1 L2 q1 q2", real=True)
    # hand derivation for a planar 2R arm: x = L1 c1 + L2 c12, y = L1 s1 + L2 s12
    assert sympy.simplify(T[0, 3] - (L1 * sympy.cos(q1) + L2 * sympy.cos(q1 + q2))) == 0
    assert sympy.simplify(T[1, 3] - (L1 * sympy.sin(q1) + L2 * sympy.sin(q1 + q2))) == 0
    # every bundled table: the symbolic matrix with the values substituted is the numeric FK
    for name in ("iiwa14", "course_arm_modified", "scara"):
        table = load_dh(name)
        T = dh_fk_symbolic(table, symbols=True)
        fractions = {sympy.Rational(repr(v)) for v in dh_length_symbols(table).values()}  # 0.36 -> 9/25
        assert not fractions & T.atoms(sympy.Rational), name
        q = np.linspace(0.1, 0.7, table.n)
        joints = dh_symbols(table.n)
        numeric = np.array(T.subs(dh_length_symbols(table)).subs(dict(zip(joints, q))).evalf(), dtype=float)
        assert np.abs(numeric - dh_fk(table, q)).max() < 1e-12
