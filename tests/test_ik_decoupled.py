"""manipkit.ik.decoupled: closed-form IK of the SCARA, Stanford arm and elbow arm, checked through the URDF.

The targets are made by the bundled URDF models' forward kinematics (Pinocchio's
model, `Robot.fk`) at random joint values inside the limits, and every solution is
mapped back through the same URDF model: the closed-form solvers only ever see
the DH tables, so the two sides are independent. Conventions (DESIGN.md):
metres and radians, T_a_b is the pose of frame b in frame a, standard DH
A_i = Rz(theta) Tz(d) Tx(a) Rx(alpha), angles wrapped to (-pi, pi].
"""

import io
import math

import numpy as np
import pytest
import yourdfpy
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import manipkit
from manipkit.description.sources import bundled_dh_tables
from manipkit.dh import dh_fk, load_dh
from manipkit.dh.check import check_dh
from manipkit.errors import ClosedFormIKError, InvalidTransformError, ManipkitError
from manipkit.ik.decoupled import (
    elbow_dh_table,
    ik_elbow,
    ik_scara,
    ik_stanford,
    scara_dh_table,
    stanford_dh_table,
    wrist_center,
)
from manipkit.ik.result import IKResult
from manipkit.spatial.rotations import rot_x, rot_y, rot_z, rotation_angle_between

TOL = 1e-9
PI = math.pi
SETTINGS = settings(max_examples=100, deadline=None)

# --------------------------------------------------------------------------
# fixtures and helpers


@pytest.fixture(scope="module")
def scara(load_robot):
    return load_robot("scara")


@pytest.fixture(scope="module")
def stanford(load_robot):
    return load_robot("stanford_arm")


@pytest.fixture(scope="module")
def elbow(load_robot):
    return load_robot("elbow_arm")


def urdf_pose(robot, q):
    """T_base_link_ee_link by the URDF model (Pinocchio's joint placements)."""
    return robot.fk(np.asarray(q, dtype=float), base="base_link", tip="ee_link")


def assert_all_reach(robot, result, T):
    """Every row maps back to T through the URDF model within 1e-9 (m, rad) and lies inside the URDF limits."""
    assert result.solutions.shape == (len(result.labels), len(robot.joint_names))
    assert result.joint_names == robot.joint_names
    poses = urdf_pose(robot, result.solutions)
    for i, pose in enumerate(poses):
        position = np.linalg.norm(pose[:3, 3] - T[:3, 3])
        rotation = float(rotation_angle_between(pose[:3, :3], T[:3, :3]))
        assert position <= TOL and rotation <= TOL, (result.labels[i], position, rotation)
    lower = np.array([j.lower for j in robot.joints])
    upper = np.array([j.upper for j in robot.joints])
    assert np.all(result.solutions >= lower) and np.all(result.solutions <= upper)
    angular = np.array([j.is_angular for j in robot.joints])
    assert np.all(result.solutions[:, angular] > -PI)  # wrapped to (-pi, pi]
    assert np.all(result.residuals <= TOL) and result.rejected == 0


def joint_distance(robot, a, b):
    """Largest difference between two joint vectors, angles compared modulo 2 pi."""
    difference = np.asarray(a, dtype=float) - np.asarray(b, dtype=float)
    angular = np.array([j.is_angular for j in robot.joints])
    difference[..., angular] = (difference[..., angular] + PI) % (2 * PI) - PI
    return np.max(np.abs(difference), axis=-1)


def assert_original_found(robot, result, q):
    assert result.count > 0, result.reason
    assert np.min(joint_distance(robot, result.solutions, q)) < 1e-7, (q, result.solutions)


def any_angle():
    return st.floats(-PI, PI)


def clear_of_zero_and_pi(margin=0.05):
    """Angles with |sin| comfortably above 0: in (margin, pi - margin) or its negative."""
    return st.tuples(st.floats(margin, PI - margin), st.sampled_from([1.0, -1.0])).map(lambda t: t[0] * t[1])


# --------------------------------------------------------------------------
# the robots and their DH tables


@pytest.mark.parametrize("name", ["scara", "stanford_arm", "elbow_arm"])
def test_description_has_masses_limits_and_the_standard_frames(name):
    robot = manipkit.load(name)
    assert robot.root_link == "base_link" and "ee_link" in robot.frame_names
    urdf = yourdfpy.URDF.load(io.StringIO(robot.urdf), build_scene_graph=False, load_meshes=False)
    assert urdf.validate()
    for link in urdf.robot.links:
        assert link.inertial is not None and link.inertial.mass > 0, link.name
        assert link.visuals, link.name
    for joint in urdf.robot.joints:
        if joint.type != "fixed":
            assert joint.limit.effort > 0 and joint.limit.velocity > 0, joint.name
    for joint in robot.joints:
        assert joint.lower < joint.upper, joint.name
        if joint.type == "prismatic":
            assert 0.0 <= joint.lower and joint.upper <= 1.0, joint.name
        else:
            assert (joint.lower, joint.upper) == (-PI, PI), joint.name
    prismatic = [j.name for j in robot.joints if j.type == "prismatic"]
    assert prismatic == ([] if name == "elbow_arm" else ["joint3"])


@pytest.mark.parametrize(
    "name, table",
    [("scara", scara_dh_table()), ("stanford_arm", stanford_dh_table()), ("elbow_arm", elbow_dh_table())],
)
def test_bundled_table_passes_check_dh_and_equals_the_solver_table(name, table):
    robot = manipkit.load(name)
    loaded = load_dh(bundled_dh_tables()[name])
    result = check_dh(loaded, robot, samples=500, tol=1e-9)
    assert result.passed, result.diagnosis
    assert check_dh(table, robot, samples=500, tol=1e-9).passed
    Q = robot.sample_q(50, seed=3)
    assert np.max(np.abs(dh_fk(loaded, Q) - dh_fk(table, Q))) < 1e-12
    assert np.allclose([row.qlim for row in loaded.rows], [row.qlim for row in table.rows], atol=1e-12, rtol=0)


def test_stanford_urdf_is_spongs_T06_for_other_xacro_arguments():
    # d1, d2, d6 and the stroke are xacro arguments; the table built from the same numbers must agree.
    robot = manipkit.load("stanford_arm", d1=0.3, d2=-0.1, d6=0.05, d3_min=0.2, d3_max=0.8)
    table = stanford_dh_table(d1=0.3, d2=-0.1, d6=0.05, d3_limits=(0.2, 0.8))
    assert check_dh(table, robot, samples=200).passed
    assert robot.joints[2].lower == 0.2 and robot.joints[2].upper == 0.8


def test_scara_and_elbow_urdfs_follow_their_xacro_arguments():
    scara = manipkit.load("scara", d1=0.6, a1=0.5, a2=0.5, d4=0.0, d3_max=0.4)
    assert check_dh(scara_dh_table(d1=0.6, a1=0.5, a2=0.5, d4=0.0, d3_limits=(0.0, 0.4)), scara, samples=200).passed
    elbow = manipkit.load("elbow_arm", d1=0.2, a2=0.3, a3=0.3, d6=0.2)
    assert check_dh(elbow_dh_table(d1=0.2, a2=0.3, a3=0.3, d6=0.2), elbow, samples=200).passed


def test_scara_pose_at_a_hand_computed_configuration(scara):
    # t1 = 90 deg, t2 = -90 deg, d3 = 0.1, t4 = 0: link 1 along +y (0.35), link 2 along +x (0.25),
    # height d1 - d3 - d4 = 0.4 - 0.1 - 0.05 = 0.25; tool x heading t1 + t2 - t4 = 0, z down:
    # R = Rz(0) Rx(pi) = diag(1, -1, -1).
    T = urdf_pose(scara, [PI / 2, -PI / 2, 0.1, 0.0])
    expected = np.array([[1, 0, 0, 0.25], [0, -1, 0, 0.35], [0, 0, -1, 0.25], [0, 0, 0, 1.0]])
    assert np.max(np.abs(T - expected)) < 1e-12


# --------------------------------------------------------------------------
# wrist centre


def test_wrist_center_is_vectorised_and_moves_back_along_the_tool_z():
    T = np.broadcast_to(np.eye(4), (3, 2, 4, 4)).copy()
    T[..., :3, :3] = rot_x(PI / 2)  # tool z along -y
    T[..., :3, 3] = [1.0, 2.0, 3.0]
    o_c = wrist_center(T, 0.5)
    assert o_c.shape == (3, 2, 3)
    assert np.allclose(o_c, [1.0, 2.5, 3.0], atol=1e-15)


@given(any_angle(), any_angle(), st.floats(0.1, 1.0), any_angle(), any_angle(), any_angle(),
       st.sampled_from([0.0, 0.35]))
@SETTINGS
def test_stanford_wrist_centre_matches_seed_001(t1, t2, d3, t4, t5, t6, d1):
    # Seed 001 part 2, checked by hand: frame 3's origin is A1 A2 A3 applied to the origin.
    #   A3 origin: (0, 0, d3).
    #   A2 = Rz(t2) Tz(d2) Rx(90): Rx(90) (0, 0, d3) = (0, -d3, 0); + (0, 0, d2); Rz(t2): (s2 d3, -c2 d3, d2).
    #   A1 = Rz(t1) Tz(d1) Rx(-90): Rx(-90) (x, y, z) = (x, z, -y) gives (s2 d3, d2, c2 d3);
    #       Rz(t1) and + (0, 0, d1): (c1 s2 d3 - s1 d2, s1 s2 d3 + c1 d2, c2 d3 + d1).
    # The wrist joints turn about axes through that point, so o - d6 R z lands on it for every t4, t5, t6.
    d2, d6 = 0.154, 0.263
    T = dh_fk(stanford_dh_table(d1=d1), [t1, t2, d3, t4, t5, t6])
    c1, s1, c2, s2 = math.cos(t1), math.sin(t1), math.cos(t2), math.sin(t2)
    seed = [c1 * s2 * d3 - s1 * d2, s1 * s2 * d3 + c1 * d2, c2 * d3 + d1]
    assert np.allclose(wrist_center(T, d6), seed, atol=1e-14)


def test_wrist_center_rejects_a_matrix_of_the_wrong_shape():
    with pytest.raises(ClosedFormIKError, match=r"\(\.\.\., 4, 4\)"):
        wrist_center(np.eye(3), 0.1)


# --------------------------------------------------------------------------
# SCARA


@given(any_angle(), clear_of_zero_and_pi(), st.floats(0.0, 0.3), any_angle())
@SETTINGS
def test_scara_generic_pose_has_two_solutions_through_the_urdf(scara, t1, t2, d3, t4):
    q = [t1, t2, d3, t4]
    T = urdf_pose(scara, q)
    result = ik_scara(T)
    assert result.count == 2 and result.labels == ("righty", "lefty") and not result.singular
    assert_all_reach(scara, result, T)
    assert_original_found(scara, result, q)
    assert result.solutions[0, 1] > 0 > result.solutions[1, 1]


def test_scara_righty_has_the_elbow_right_of_the_line_to_the_quill(scara):
    T = urdf_pose(scara, [0.2, 1.0, 0.1, 0.0])
    result = ik_scara(T)
    for q, label in zip(result.solutions, result.labels):
        elbow = scara.fk(q, base="base_link", tip="link2")[:2, 3]
        cross_z = T[0, 3] * elbow[1] - T[1, 3] * elbow[0]  # > 0: elbow left of base -> quill, seen from above
        assert (cross_z < 0) == (label == "righty")


def test_scara_righty_solution_is_seed_001_problem_1(scara):
    # Seed 001 problem 1, with its names l2 = a1, l3 = a2 and r3 = r: the righty branch is
    # theta1 = atan2(y, x) - acos((a1^2 + r^2 - a2^2) / (2 a1 r)), theta2 = pi - acos((a1^2 + a2^2 - r^2) / (2 a1 a2)),
    # the law of cosines in the triangle base-elbow-quill. (The seed gives only this branch, and d3 with the wrong sign.)
    a1, a2 = 0.35, 0.25
    T = urdf_pose(scara, [-0.7, 2.0, 0.2, 1.0])
    x, y = T[0, 3], T[1, 3]
    r = math.hypot(x, y)
    theta1 = math.atan2(y, x) - math.acos((a1**2 + r**2 - a2**2) / (2 * a1 * r))
    theta2 = PI - math.acos((a1**2 + a2**2 - r**2) / (2 * a1 * a2))
    righty = ik_scara(T).solutions[0]
    assert righty[:2] == pytest.approx([theta1, theta2], abs=1e-12)
    assert righty[2] == pytest.approx(0.4 - 0.05 - T[2, 3], abs=1e-15)  # d3 = d1 - d4 - z


@pytest.mark.parametrize("t2, label", [(0.0, "straight"), (PI, "folded")])
def test_scara_on_the_workspace_boundary_has_one_solution(scara, t2, label):
    q = [0.6, t2, 0.15, -0.4]
    T = urdf_pose(scara, q)
    result = ik_scara(T)
    assert result.labels == (label,)
    assert_all_reach(scara, result, T)
    assert_original_found(scara, result, q)


def test_scara_with_equal_links_at_the_base_is_a_family_in_theta1():
    robot = manipkit.load("scara", a1=0.3, a2=0.3)
    T = urdf_pose(robot, [0.9, PI, 0.1, 0.4])
    result = ik_scara(T, a1=0.3, a2=0.3)
    assert len(result.solutions) == 1 and result.singular and result.free_joints == (0,)
    assert result.count == math.inf and result.free_parameter == "theta1"
    assert "theta1 free" in result.family
    assert_all_reach(robot, result, T)
    row = result.solutions[0]
    for t in (-2.0, 0.5, 3.0):  # theta1 = t, theta4 = theta4_row + t
        member = [t, row[1], row[2], row[3] + t]
        assert np.max(np.abs(urdf_pose(robot, member) - T)) < 1e-12


def _scaled(T, factor):
    T = T.copy()
    T[:2, 3] *= factor
    return T


def _shifted(T, dz):
    T = T.copy()
    T[2, 3] += dz
    return T


def _tilted(T, angle):
    T = T.copy()
    T[:3, :3] = rot_x(angle) @ T[:3, :3]
    return T


@pytest.mark.parametrize(
    "change, words",
    [
        (lambda T: _scaled(T, 3.0), ["too far", "outside by", "annulus"]),
        (lambda T: _shifted(T, 0.5), ["d3 = -0.4", "lower limit 0 m", "too high"]),
        (lambda T: _shifted(T, -0.3), ["above its upper limit 0.3 m", "too low"]),
        (lambda T: _tilted(T, 0.01), ["tilted 0.01 rad", "straight down"]),
    ],
)
def test_scara_unreachable_targets_have_no_solution_and_say_why(scara, change, words):
    T = change(urdf_pose(scara, [0.3, 1.0, 0.1, 0.2]))
    result = ik_scara(T)
    assert result.count == 0 and result.solutions.shape == (0, 4)
    assert result.reason.startswith("no solution: ")
    for word in words:
        assert word in result.reason


# --------------------------------------------------------------------------
# Stanford arm


@given(any_angle(), clear_of_zero_and_pi(), st.floats(0.1, 1.0), any_angle(), clear_of_zero_and_pi(), any_angle())
@SETTINGS
def test_stanford_generic_pose_has_four_solutions_through_the_urdf(stanford, t1, t2, d3, t4, t5, t6):
    q = [t1, t2, d3, t4, t5, t6]
    T = urdf_pose(stanford, q)
    result = ik_stanford(T)
    assert result.labels == ("front, no flip", "front, flip", "back, no flip", "back, flip")
    assert not result.singular and result.family == ""
    assert_all_reach(stanford, result, T)
    assert_original_found(stanford, result, q)
    # front: theta2 in (0, pi); back: (-pi, 0); no flip: theta5 > 0; all four share d3
    assert list(np.sign(result.solutions[:, 1])) == [1, 1, -1, -1]
    assert list(np.sign(result.solutions[:, 4])) == [1, -1, 1, -1]
    assert np.ptp(result.solutions[:, 2]) < 1e-12


def test_stanford_front_reaches_toward_the_side_joint_1_faces(stanford):
    T = urdf_pose(stanford, [2.5, -1.0, 0.5, 0.1, 0.2, 0.3])
    o_c = wrist_center(T, 0.263)
    for q, label in zip(ik_stanford(T).solutions, ik_stanford(T).labels):
        rho = math.cos(q[0]) * o_c[0] + math.sin(q[0]) * o_c[1]
        assert (rho > 0) == label.startswith("front")


@pytest.mark.parametrize("t5", [0.0, PI])
def test_stanford_wrist_singularity_gives_the_family(stanford, t5):
    q = [0.4, 0.8, 0.6, 0.3, t5, -0.2]
    T = urdf_pose(stanford, q)
    result = ik_stanford(T)
    # Only the front arm (the original) has z3 parallel to z6; the back arm's boom points elsewhere
    # (d2 != 0 turns it), so it keeps both wrist solutions.
    assert result.labels == ("front, wrist singular", "back, no flip", "back, flip")
    assert result.singular and result.free_joints == (3,) and "theta4 = t" in result.family
    assert_all_reach(stanford, result, T)
    row = result.solutions[0]
    assert row[3] == 0.0 and row[4] == pytest.approx(t5, abs=1e-12)
    # theta4 + theta6 (theta5 = 0) or theta4 - theta6 (theta5 = pi) equals the original's
    if t5 == 0.0:
        assert row[5] == pytest.approx(0.3 - 0.2, abs=1e-12)
    else:
        assert row[5] == pytest.approx(-(0.3 + 0.2), abs=1e-12)
    sign = -1.0 if t5 == 0.0 else 1.0
    for t in (-2.5, 0.3, 1.7):
        member = [row[0], row[1], row[2], t, row[4], row[5] + sign * t]
        assert np.max(np.abs(urdf_pose(stanford, member) - T)) < 1e-12


def test_stanford_boom_vertical_has_one_shoulder_solution(stanford):
    # theta2 = 0: rho = s2 d3 = 0, the wrist centre on the cylinder r = |d2| about joint 1's axis.
    q = [0.7, 0.0, 0.5, 0.3, 1.1, -0.4]
    T = urdf_pose(stanford, q)
    result = ik_stanford(T)
    assert result.labels == ("vertical, no flip", "vertical, flip")
    assert_all_reach(stanford, result, T)
    assert_original_found(stanford, result, q)


def test_stanford_without_offset_on_the_axis_is_a_family_in_theta1():
    robot = manipkit.load("stanford_arm", d2=0)
    T = urdf_pose(robot, [1.2, 0.0, 0.5, 0.3, 1.0, -0.2])
    result = ik_stanford(T, d2=0.0)
    assert result.singular and result.free_joints == (0,) and "theta1 free" in result.family
    assert result.labels == ("overhead, no flip", "overhead, flip")
    assert_all_reach(robot, result, T)


@pytest.mark.parametrize(
    "q, words",
    [
        ([0.4, 0.8, 1.0, 0.3, 1.0, -0.2], ["d3 = 1.5 m", "above its upper limit 1 m by 0.5 m", "too far"]),
        ([0.4, 0.8, 0.1, 0.3, 1.0, -0.2], ["d3 = 0.05 m", "below its lower limit 0.1 m by 0.05 m", "too close"]),
    ],
)
def test_stanford_prismatic_limit_drops_the_solutions_and_says_which(q, words):
    # Targets made with a longer or shorter boom than the default arm can take:
    # a table with d3 offset by +0.5 or -0.05 m gives wrist centres at d3 = 1.5 m and 0.05 m.
    offset = 0.5 if q[2] == 1.0 else -0.05
    T = dh_fk(stanford_dh_table(d3_limits=(0.0, 2.0)), np.array(q) + [0, 0, offset, 0, 0, 0])
    result = ik_stanford(T)
    assert result.count == 0
    for word in words:
        assert word in result.reason
    assert ik_stanford(T, d3_limits=(0.0, 2.0)).count == 4  # the same target with a longer stroke


def test_stanford_wrist_centre_inside_the_offset_cylinder_is_unreachable():
    T = np.eye(4)
    T[:3, 3] = [0.05, 0.0, 0.263 + 0.5]  # tool z up, wrist centre at (0.05, 0, 0.5): r = 0.05 < d2 = 0.154
    result = ik_stanford(T)
    assert result.count == 0
    assert "inside the cylinder r < |d2| = 0.154 m" in result.reason and "by 0.104 m" in result.reason


# --------------------------------------------------------------------------
# elbow arm


def elbow_configs():
    return st.tuples(any_angle(), any_angle(), clear_of_zero_and_pi(), any_angle(), clear_of_zero_and_pi(), any_angle())


@given(elbow_configs())
@SETTINGS
def test_elbow_generic_pose_has_eight_solutions_through_the_urdf(elbow, q):
    u = 0.45 * math.cos(q[1]) + 0.4 * math.cos(q[1] + q[2])  # wrist centre's distance from joint 1's axis
    assume(abs(u) > 1e-3)
    T = urdf_pose(elbow, q)
    result = ik_elbow(T)
    assert result.count == 8 and not result.singular
    expected = tuple(
        f"{shoulder}, {elbow_}, {wrist}"
        for shoulder in ("front", "back") for elbow_ in ("elbow up", "elbow down") for wrist in ("no flip", "flip")
    )
    assert result.labels == expected
    assert_all_reach(elbow, result, T)
    assert_original_found(elbow, result, q)


def test_elbow_up_means_the_elbow_above_the_shoulder_wrist_line(elbow):
    T = urdf_pose(elbow, [0.3, 0.5, -1.2, 0.2, 0.8, 0.1])
    result = ik_elbow(T)
    shoulder = np.array([0.0, 0.0, 0.4])
    for q, label in zip(result.solutions, result.labels):
        elbow_point = elbow.fk(q, base="base_link", tip="link3")[:3, 3]  # joint 3 sits at link3's origin
        centre = elbow.fk(q, base="base_link", tip="link4")[:3, 3]  # the wrist centre
        u, v = centre - shoulder, elbow_point - shoulder
        above = (v - (v @ u) / (u @ u) * u)[2] > 0
        assert above == ("elbow up" in label), label


def test_elbow_wrist_singularity_makes_every_arm_solution_singular(elbow):
    # z3 = (s1, -c1, 0) depends on theta1 only, so z6 parallel to z3 holds in front and back alike
    # (theta5 = 0 in front, pi in back): one row per arm solution.
    q = [0.4, 0.8, -0.6, 0.3, 0.0, -0.2]
    T = urdf_pose(elbow, q)
    result = ik_elbow(T)
    assert len(result.solutions) == 4 and all(label.endswith("wrist singular") for label in result.labels)
    assert result.singular and result.free_joints == (3,)
    assert result.count == math.inf and result.free_parameter == "theta4"
    assert_all_reach(elbow, result, T)
    for row in result.solutions:
        sign = -1.0 if abs(row[4]) < 1e-9 else 1.0
        for t in (-1.0, 2.0):
            member = [*row[:3], t, row[4], row[5] + sign * t]
            assert np.max(np.abs(urdf_pose(elbow, member) - T)) < 1e-12


@pytest.mark.parametrize("t3, label", [(0.0, "arm straight"), (PI, "arm folded")])
def test_elbow_on_a_boundary_sphere_has_four_solutions(elbow, t3, label):
    q = [0.4, 0.3, t3, 0.3, 1.0, -0.2]
    T = urdf_pose(elbow, q)
    result = ik_elbow(T)
    assert result.count == 4 and all(label in text for text in result.labels)
    assert_all_reach(elbow, result, T)
    assert_original_found(elbow, result, q)


def test_elbow_wrist_centre_on_the_base_axis_is_a_family_in_theta1(elbow):
    T = urdf_pose(elbow, [0.4, PI / 2, 0.0, 0.3, 1.0, -0.2])  # arm straight up
    result = ik_elbow(T)
    assert result.singular and result.free_joints == (0,) and "theta1 free" in result.family
    assert all(label.startswith("overhead") for label in result.labels)
    assert_all_reach(elbow, result, T)


def test_elbow_far_target_has_no_solution_and_says_how_far(elbow):
    T = urdf_pose(elbow, [0.4, 0.3, 0.0, 0.3, 1.0, -0.2])  # stretched: wrist centre 0.85 m from the shoulder
    T[:3, 3] += 0.2 * T[:3, 3] / np.linalg.norm(T[:3, 3])
    far = ik_elbow(T)
    assert far.count == 0 and "too far" in far.reason and "a2 + a3 = 0.85 m" in far.reason
    near = np.eye(4)
    near[:3, 3] = [0.01, 0.0, 0.4 + 0.1]  # tool z up: wrist centre 0.01 m from the shoulder, inside |a2 - a3|
    result = ik_elbow(near)
    assert result.count == 0 and "too close" in result.reason and "outside by 0.04 m" in result.reason


# --------------------------------------------------------------------------
# verification and bad input


def test_candidates_failing_the_fk_check_are_dropped_and_counted():
    T = dh_fk(stanford_dh_table(), [0.4, 0.8, 0.6, 0.3, 1.0, -0.2])
    shear = np.eye(4)
    shear[0, 1] = shear[1, 0] = 1e-7  # not quite a rotation: passes the 1e-6 rotation check, misses 1e-9
    result = ik_stanford(T @ shear)
    assert result.count == 0 and result.rejected == 4
    assert "failed the forward-kinematics check" in result.reason


def test_result_is_read_only_data():
    result = ik_elbow(dh_fk(elbow_dh_table(), [0.5, 0.4, -1.0, 0.3, 0.9, 0.2]))
    assert isinstance(result, IKResult)
    with pytest.raises(ValueError):
        result.solutions[0, 0] = 1.0


@pytest.mark.parametrize(
    "call, error, words",
    [
        (lambda: ik_elbow(np.eye(3)), InvalidTransformError, "expected (4, 4)"),
        (lambda: ik_elbow(np.diag([1.0, 1.0, 2.0, 1.0])), InvalidTransformError, "T: rotation column 2 (z axis)"),
        (lambda: ik_elbow(np.full((4, 4), np.nan)), InvalidTransformError, "not finite"),
        (lambda: ik_elbow(np.eye(4), a2=0.0), ClosedFormIKError, "a2 = 0"),
        (lambda: ik_scara(np.eye(4), d3_limits=(0.3, 0.1)), ClosedFormIKError, "lower limit must be below"),
        (lambda: ik_stanford(np.eye(4), d3_limits=(-0.1, 1.0)), ClosedFormIKError, ">= 0"),
        (lambda: ik_stanford(np.eye(4), tol=0.0), ClosedFormIKError, "tol must be a positive number"),
    ],
)
def test_bad_input_is_a_clear_error(call, error, words):
    with pytest.raises(error) as info:
        call()
    assert isinstance(info.value, ManipkitError)
    assert words in str(info.value)


def test_closed_form_agrees_with_rotations_used_by_the_tables():
    # R_0^3 of the Stanford arm is Rz(t1) Ry(t2) (seed 001 part c) and of the elbow arm Rz(t1) Rx(90) Rz(t2 + t3).
    q = [0.3, -0.9, 0.5, 0.0, 0.0, 0.0]
    assert np.allclose(dh_fk(stanford_dh_table(), q, upto=3)[:3, :3], rot_z(0.3) @ rot_y(-0.9), atol=1e-15)
    q = [0.3, -0.9, 0.4, 0.0, 0.0, 0.0]
    assert np.allclose(dh_fk(elbow_dh_table(), q, upto=3)[:3, :3], rot_z(0.3) @ rot_x(PI / 2) @ rot_z(-0.5), atol=1e-15)


def test_stanford_theta1_branches_are_seed_001_part_b_corrected(stanford):
    # From -s1 x_c + c1 y_c = d2 (seed eq. 3) with (x_c, y_c) = r (cos phi, sin phi): r sin(phi - theta1) = d2, so
    # front: theta1 = phi - atan(d2 / sqrt(r^2 - d2^2)); back: theta1 = phi + atan(d2 / sqrt(r^2 - d2^2)) - pi
    # (the seed's "+" branch lacks the - pi).
    T = urdf_pose(stanford, [0.4, 0.8, 0.6, 0.3, 1.0, -0.2])
    x_c, y_c, _ = wrist_center(T, 0.263)
    r, phi, d2 = math.hypot(x_c, y_c), math.atan2(y_c, x_c), 0.154
    offset = math.atan(d2 / math.sqrt(r * r - d2 * d2))
    theta1 = ik_stanford(T).solutions[:, 0]
    assert theta1 == pytest.approx([phi - offset] * 2 + [phi + offset - PI] * 2, abs=1e-12)
