"""manipkit.dh.symbolic_jacobian: the geometric Jacobian of a DH table in SymPy, and its determinant.

Independent sources: hand derivations (in the comments), Pinocchio's
``computeFrameJacobian`` (LOCAL_WORLD_ALIGNED) of the bundled URDF the table
describes, and central differences of the numeric ``dh_fk``.
"""

import numpy as np
import pinocchio as pin
import pytest
import sympy
from test_dh_table import random_q, random_table

from manipkit.description.sources import bundled_dh_tables
from manipkit.dh import DHRow, DHTable, dh_fk, dh_symbols, load_dh
from manipkit.dh.symbolic_jacobian import dh_jacobian_symbolic, format_jacobian, jacobian_determinant
from manipkit.errors import DHDerivationError

TABLES = bundled_dh_tables()
q1, q2, q3, q4, q5, q6 = sympy.symbols("q1:7", real=True)


def pinocchio_jacobian(robot, q, frame="ee_link", base="base_link"):
    """(6, n) Jacobian of ``frame``'s origin in ``base``'s axes, columns in ``robot.joint_names`` order, by Pinocchio."""
    model = robot.model
    data = model.createData()
    config = robot.pinocchio_configuration(q)
    pin.computeJointJacobians(model, data, config)
    pin.updateFramePlacements(model, data)
    J_world = pin.getFrameJacobian(model, data, robot.frame_id(frame), pin.LOCAL_WORLD_ALIGNED)
    R = data.oMf[robot.frame_id(base)].rotation  # base_link is fixed to the root: only its axes differ
    J_base = np.vstack([R.T @ J_world[:3], R.T @ J_world[3:]])
    columns = [model.joints[model.getJointId(name)].idx_v for name in robot.joint_names]
    return J_base[:, columns]


# --------------------------------------------------------------------------
# hand derivations


def test_planar_2r_jacobian_and_determinant_by_hand():
    # p = (l1 c1 + l2 c12, l1 s1 + l2 s12); column i = z x (p - o_i) with z = e_z, o_1 = 0,
    # o_2 = (l1 c1, l1 s1): J_v = [[-l1 s1 - l2 s12, -l2 s12], [l1 c1 + l2 c12, l2 c12]], w_z = (1, 1).
    # det J_v = (-l1 s1 - l2 s12) l2 c12 + l2 s12 (l1 c1 + l2 c12) = l1 l2 (s12 c1 - c12 s1) = l1 l2 sin q2.
    l1, l2 = sympy.symbols("l1 l2", real=True)
    J = dh_jacobian_symbolic(load_dh(TABLES["planar_2r"]), lengths={"a1": "l1", "a2": "l2"})
    expected = sympy.Matrix([
        [-l1 * sympy.sin(q1) - l2 * sympy.sin(q1 + q2), -l2 * sympy.sin(q1 + q2)],
        [l1 * sympy.cos(q1) + l2 * sympy.cos(q1 + q2), l2 * sympy.cos(q1 + q2)],
        [0, 0], [0, 0], [0, 0], [1, 1],
    ])
    assert (J - expected).applyfunc(sympy.simplify) == sympy.zeros(6, 2)
    assert sympy.simplify(jacobian_determinant(J, [0, 1]) - l1 * l2 * sympy.sin(q2)) == 0


def test_planar_2r_with_numbers_has_determinant_sin_q2():
    # l1 = l2 = 1 in the bundled table
    J = dh_jacobian_symbolic(load_dh(TABLES["planar_2r"]))
    assert jacobian_determinant(J, [0, 1]) == sympy.sin(q2)


def test_planar_3r_determinant_of_the_moving_rows_is_l1_l2_sin_q2():
    # rows vx, vy, wz: subtracting column 3 (-l3 s123, l3 c123, 1) from columns 1 and 2 leaves the 2R's
    # position block with a zero in the wz row, so det = det(2R block) * 1 = l1 l2 sin q2 (l3 drops out).
    J = dh_jacobian_symbolic(load_dh(TABLES["planar_3r"]), lengths={"a1": "l1", "a2": "l2", "a3": "l3"})
    l1, l2 = sympy.symbols("l1 l2", real=True)
    assert sympy.simplify(jacobian_determinant(J, [0, 1, 5]) - l1 * l2 * sympy.sin(q2)) == 0


def test_scara_jacobian_and_determinant_by_hand():
    # Spong's SCARA: p = (a1 c1 + a2 c12, a1 s1 + a2 s12, d1 - d3 - d4); z_0 = z_1 = e_z, z_2 = z_3 = -e_z
    # (the 180 deg twist of row 2). Columns: joint 1, 2 as the 2R's with w = e_z; the quill (prismatic,
    # along z_2 = -e_z): (0, 0, -1; 0, 0, 0); joint 4 about -e_z through p: (0, 0, 0; 0, 0, -1).
    # Rows vx, vy, vz, wz: det = det(2R block) * det([[-1, 0], [0, -1]]) = a1 a2 sin q2.
    a1, a2 = sympy.symbols("a1 a2", real=True)
    J = dh_jacobian_symbolic(load_dh(TABLES["scara"]), lengths={"a1": "a1", "a2": "a2"})
    expected = sympy.Matrix([
        [-a1 * sympy.sin(q1) - a2 * sympy.sin(q1 + q2), -a2 * sympy.sin(q1 + q2), 0, 0],
        [a1 * sympy.cos(q1) + a2 * sympy.cos(q1 + q2), a2 * sympy.cos(q1 + q2), 0, 0],
        [0, 0, -1, 0], [0, 0, 0, 0], [0, 0, 0, 0], [1, 1, 0, -1],
    ])
    assert (J - expected).applyfunc(sympy.simplify) == sympy.zeros(6, 4)
    assert sympy.simplify(jacobian_determinant(J, [0, 1, 2, 5]) - a1 * a2 * sympy.sin(q2)) == 0


def test_stanford_arm_determinant_is_d3_squared_sin_q2_sin_q5():
    # At the wrist centre o_c (frame 3) the wrist's columns have no linear part, so det J = det(J_11) det(J_22).
    # J_22 = [z_3 z_4 z_5] with R_3^6 = Rz(t4) Ry(t5) Rz(t6): det = sin t5 (z_3 and z_5 meet at angle t5).
    # J_11: o_c = (c1 s2 d3 - s1 d2, s1 s2 d3 + c1 d2, c2 d3) (Spong eq. for the Stanford arm); the columns
    # z0 x o_c, z1 x (o_c - o_1), z_2 = (c1 s2, s1 s2, c2): spherical coordinates (q1, q2, d3) shifted by
    # d2 sideways, det = d3^2 sin q2 (the Jacobian of spherical coordinates; the sideways d2 shift is along
    # the q1 direction only and cancels). So det J = d3^2 sin q2 sin q5; d2 and d6 do not appear.
    J = dh_jacobian_symbolic(load_dh(TABLES["stanford_arm"]), lengths={"d2": "d2", "d6": "d6"}, point=3)
    assert sympy.simplify(jacobian_determinant(J) - q3**2 * sympy.sin(q2) * sympy.sin(q5)) == 0
    assert J[:3, 3:] == sympy.zeros(3, 3)


def test_elbow_arm_determinant_factors_into_elbow_shoulder_and_wrist():
    # Spong's elbow manipulator: det J_11 = a2 a3 s3 (a2 c2 + a3 c23) (elbow straight: s3 = 0; wrist centre
    # on joint 1's axis: a2 c2 + a3 c23 = 0), spherical wrist det J_22 = sin q5.
    a2, a3 = sympy.symbols("a2 a3", real=True)
    J = dh_jacobian_symbolic(load_dh(TABLES["elbow_arm"]), lengths={"a2": "a2", "a3": "a3", "d6": "d6"}, point=3)
    expected = a2 * a3 * sympy.sin(q3) * (a2 * sympy.cos(q2) + a3 * sympy.cos(q2 + q3)) * sympy.sin(q5)
    assert sympy.simplify(jacobian_determinant(J) - expected) == 0


def test_the_determinant_is_the_same_at_the_tool_and_at_the_wrist_centre():
    # v_tool = v_centre + w x (p_tool - o_c): a unimodular change of rows (stanford, numbers, at random q)
    table = load_dh(TABLES["stanford_arm"])
    at_tool = sympy.lambdify(dh_symbols(6), dh_jacobian_symbolic(table), "numpy")
    at_centre = sympy.lambdify(dh_symbols(6), dh_jacobian_symbolic(table, point=3), "numpy")
    rng = np.random.default_rng(3)
    for q in rng.uniform(-3, 3, (20, 6)):
        q[2] = rng.uniform(0.1, 1.0)
        assert np.linalg.det(np.array(at_tool(*q), float)) == pytest.approx(np.linalg.det(np.array(at_centre(*q), float)), abs=1e-12)


# --------------------------------------------------------------------------
# numerically, against Pinocchio on the bundled robots


@pytest.mark.parametrize(("table_name", "robot_name"), [
    ("planar_2r", "planar_2r"), ("planar_3r", "planar_3r"), ("scara", "scara"), ("stanford_arm", "stanford_arm"),
    ("elbow_arm", "elbow_arm"), ("iiwa14", "iiwa14"), ("course_arm_standard", "course_arm"),
    ("course_arm_modified", "course_arm"),
])
def test_symbolic_jacobian_equals_pinocchio_on_the_bundled_robot(load_robot, table_name, robot_name):
    # the bundled tables map base_link (DH frame 0, their base transform included) to ee_link (their tool)
    table = load_dh(TABLES[table_name])
    robot = load_robot(robot_name)
    J = sympy.lambdify(dh_symbols(table.n), dh_jacobian_symbolic(table, simplify=False), "numpy")
    worst = 0.0
    for q in robot.sample_q(20, seed=5):
        numeric = np.array(J(*q), dtype=float)
        worst = max(worst, np.abs(numeric - pinocchio_jacobian(robot, q)).max())
    assert worst < 1e-9


@pytest.mark.parametrize("convention", ["standard", "modified"])
def test_symbolic_jacobian_equals_central_differences_of_dh_fk(convention):
    # linear rows: d p / d q_i; angular rows: the axial vector of (dR/dq_i) R^T; random tables with
    # prismatic rows, a turned base and tool
    rng = np.random.default_rng(8)
    table = random_table(rng, convention, n=4)
    J = sympy.lambdify(dh_symbols(table.n), dh_jacobian_symbolic(table, simplify=False), "numpy")
    h = 1e-6
    for q in random_q(table, rng, 5):
        numeric = np.zeros((6, table.n))
        R = dh_fk(table, q)[:3, :3]
        for i in range(table.n):
            step = np.zeros(table.n)
            step[i] = h
            plus, minus = dh_fk(table, q + step), dh_fk(table, q - step)
            numeric[:3, i] = (plus[:3, 3] - minus[:3, 3]) / (2 * h)
            W = (plus[:3, :3] - minus[:3, :3]) / (2 * h) @ R.T
            numeric[3:, i] = (W[2, 1], W[0, 2], W[1, 0])
        assert np.abs(np.array(J(*q), dtype=float) - numeric).max() < 1e-7


def test_point_moves_the_linear_rows_by_w_cross_r():
    # v_point = v_tool + w x (o_point - p_tool), angular rows unchanged (elbow arm, numbers, random q)
    table = load_dh(TABLES["elbow_arm"])
    at_tool = sympy.lambdify(dh_symbols(6), dh_jacobian_symbolic(table), "numpy")
    at_centre = sympy.lambdify(dh_symbols(6), dh_jacobian_symbolic(table, point=3), "numpy")
    for q in np.random.default_rng(2).uniform(-3, 3, (10, 6)):
        Jt, Jc = np.array(at_tool(*q), float), np.array(at_centre(*q), float)
        r = dh_fk(table, q, upto=3)[:3, 3] - dh_fk(table, q)[:3, 3]
        assert np.abs(Jc[:3] - (Jt[:3] + np.cross(Jt[3:].T, r).T)).max() < 1e-12
        assert np.abs(Jc[3:] - Jt[3:]).max() < 1e-15


# --------------------------------------------------------------------------
# printing and errors


def test_format_jacobian_writes_textbook_shorthand_in_latex():
    J = dh_jacobian_symbolic(load_dh(TABLES["planar_2r"]), lengths={"a1": "l1", "a2": "l2"})
    latex = format_jacobian(J[:2, :], latex=True, title="planar 2R")
    assert latex.startswith("% planar 2R\n\\begin{bmatrix}")
    assert "s_{12}" in latex and "c_{1}" in latex and "\\sin" not in latex


def test_determinant_of_a_redundant_arm_is_sqrt_det_j_jt():
    # planar 3R, rows vx, vy only (2 x 3): sqrt(det(J J^T)) is zero only when all links are in line
    J = dh_jacobian_symbolic(load_dh(TABLES["planar_3r"]))
    f = sympy.lambdify(dh_symbols(3), jacobian_determinant(J, [0, 1]), "numpy")
    g = sympy.lambdify(dh_symbols(3), J.extract([0, 1], [0, 1, 2]), "numpy")
    for q in np.random.default_rng(1).uniform(-3, 3, (10, 3)):
        Jv = np.array(g(*q), float)
        assert f(*q) == pytest.approx(np.sqrt(np.linalg.det(Jv @ Jv.T)), abs=1e-12)
    # Cauchy-Binet: det(J_v J_v^T) = sum of the squared 2x2 minors. Column k of J_v is
    # sum_{m >= k} l_m (-sin t_m, cos t_m) with t_m = q1 + .. + qm, so minor(i, j) = sum_{a >= i, b >= j}
    # l_a l_b sin(t_b - t_a); with l = 4, 2, 1: minor(1, 2) = 8 s2 + 4 s23 (the a = 2, 3 terms cancel),
    # minor(1, 3) = 4 s23 + 2 s3, minor(2, 3) = 2 s3.
    s2, s3, s23 = sympy.sin(q2), sympy.sin(q3), sympy.sin(q2 + q3)
    expected = sympy.sqrt((8 * s2 + 4 * s23)**2 + (4 * s23 + 2 * s3)**2 + (2 * s3)**2)
    assert sympy.simplify(jacobian_determinant(J, [0, 1]) - expected) == 0
    assert f(0.3, 0.0, np.pi) == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("key", ["b1", "a0", "a3", "d", "length"])
def test_a_length_key_that_names_no_field_is_refused(key):
    with pytest.raises(DHDerivationError, match="give a1 .. a2 or d1 .. d2"):
        dh_jacobian_symbolic(load_dh(TABLES["planar_2r"]), lengths={key: "l"})


def test_more_rows_than_joints_is_refused_with_the_count():
    J = dh_jacobian_symbolic(load_dh(TABLES["planar_2r"]))
    with pytest.raises(DHDerivationError, match="3 rows for 2 joints"):
        jacobian_determinant(J, [0, 1, 5])


def test_a_point_that_is_no_frame_is_refused():
    with pytest.raises(DHDerivationError, match="0 .. 2"):
        dh_jacobian_symbolic(DHTable([DHRow(1, 0, 0, 0), DHRow(1, 0, 0, 0)]), point=3)


def test_a_table_whose_symbolic_jacobian_would_explode_is_refused_in_bounded_time():
    # nine rows twisted by 30 deg: each row about triples the expressions; dh_fk_symbolic stops at
    # MAX_SYMBOLIC_OPS, and the Jacobian (built from the same products) must stop there too, not run for minutes
    import math

    from manipkit.dh.table import DHRow, DHTable
    from manipkit.errors import DHDerivationError

    rows = tuple(DHRow(a=0.1, alpha=math.radians(30), d=0.1, theta=0.0) for _ in range(9))
    with pytest.raises(DHDerivationError, match="operations at row"):
        dh_jacobian_symbolic(DHTable(rows, "standard", "skew"), simplify=False)
