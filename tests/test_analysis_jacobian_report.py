"""manipkit.analysis.jacobian_report: ranks, the singular decision, the families that hold and what is lost.

Independent sources: null spaces and lost directions derived by hand in the
comments (from the joint axes at the configuration: a revolute column is
``(w x (p - o), w)``), Pinocchio's ``computeFrameJacobian``
(LOCAL_WORLD_ALIGNED; base_link is the root of these robots) for every
motion's velocity, and the hand-derived singular families of
:mod:`manipkit.analysis.singularities`.
"""

import math
import zlib

import numpy as np
import pinocchio as pin
import pytest

from manipkit.analysis.jacobian_report import ROW_NAMES, jacobian_report
from manipkit.analysis.singularities import KNOWN_ROBOTS, singular_families
from manipkit.errors import ManipkitError


def pinocchio_jacobian(robot, q):
    """(6, n) Jacobian of ee_link in the root's axes, columns in ``robot.joint_names`` order."""
    J = pin.computeFrameJacobian(robot.model, robot.model.createData(), robot.pinocchio_configuration(q),
                                 robot.frame_id("ee_link"), pin.LOCAL_WORLD_ALIGNED)
    return J[:, [robot.model.joints[robot.model.getJointId(name)].idx_v for name in robot.joint_names]]


def report_of(robot, q=None, **options):
    return jacobian_report(robot.chain("base_link", "ee_link"), q, **options)


def motions_as(report, still):
    return [m for m in report.motions if m.still == still]


# --------------------------------------------------------------------------
# hand-derived null spaces


def test_planar_2r_straight_loses_the_direction_along_the_arm(planar_2r):
    # l1 = l2 = 1, q = (0.3, 0), s = sin 0.3, c = cos 0.3. Rows vx, vy, wz:
    #   column 1 = (-2 s, 2 c, 1), column 2 = (-s, c, 1).
    # Translation rows: column 1 = 2 x column 2, rank 1 of 2; both are across the arm, so the origin cannot
    # move along (c, s, 0). Their null space: 2 x1 + x2 = 0, x = (-1, 2)/sqrt(5) (largest entry positive);
    # it turns the frame at wz = x1 + x2 = 1/sqrt(5) = 0.447 rad/s. All rows: det [[2c, c], [1, 1]] = c != 0,
    # rank 2 of 2: no motion leaves the whole frame still. vz, wx, wy are 0 at every configuration: not lost.
    report = report_of(planar_2r, [0.3, 0.0])
    s, c = math.sin(0.3), math.cos(0.3)
    np.testing.assert_allclose(report.jacobian[[0, 1, 5]], [[-2 * s, -s], [2 * c, c], [1, 1]], atol=1e-15)
    assert report.singular
    assert (report.ranks("all"), report.ranks("translation"), report.ranks("rotation")) == ((2, 2), (1, 2), (1, 1))
    assert [ROW_NAMES[i] for i in report.movable_rows] == ["vx", "vy", "wz"]
    assert [(lost.rows, lost.direction.tolist()) for lost in report.lost] == [("translation", pytest.approx([c, s, 0]))]
    [motion] = report.motions
    assert motion.still == "origin"
    np.testing.assert_allclose(motion.joint_rates, np.array([-1.0, 2.0]) / math.sqrt(5), atol=1e-15)
    np.testing.assert_allclose(motion.velocity, 0.0, atol=1e-15)
    np.testing.assert_allclose(motion.angular_velocity, [0, 0, 1 / math.sqrt(5)], atol=1e-15)
    assert [f.name for f in report.families] == ["elbow straight"]


def test_a_regular_configuration_loses_nothing(planar_2r, iiwa14):
    for robot, q in ((planar_2r, [0.3, 1.0]), (iiwa14, iiwa14.sample_q(1, seed=1)[0])):
        report = report_of(robot, q)
        assert not report.singular and report.rank == report.generic_rank
        assert report.lost == () and report.motions == () and report.same_axis == () and report.families == ()


def test_iiwa14_upright_joints_1_3_5_7_spin_the_flange_about_z(iiwa14):
    # q = 0: the flange origin p = (0, 0, 1.306). Joints 1, 3, 5, 7 turn about +z through the z axis, so
    # w x (p - o) = 0: each column is (0, 0, 0, 0, 0, 1). Joints 2, 4, 6 turn about +y, -y, +y at heights
    # 0.36, 0.78, 1.18: columns (0.946, 0, 0, 0, 1, 0), (-0.526, 0, 0, 0, -1, 0), (0.126, 0, 0, 0, 1, 0).
    # Translation rows: vx only, rank 1 of 3 (lost: y and z). Rotation rows: wy and wz, rank 2 of 3 (lost: x).
    # All rows: the z column plus two in (vx, wy): rank 3 of 6.
    # Null space of all rows (4 = 7 - 3): x1 + x3 + x5 + x7 = 0 (three pairs 1-3, 1-5, 1-7 as (1, -1)/sqrt2) and
    # x2 - x4 + x6 = 0, 0.946 x2 - 0.526 x4 + 0.126 x6 = 0 -> 0.82 x2 = 0.4 x4: (1, 2.05, 1.05)/2.511.
    # Null space of the translation rows (6 = 7 - 1) adds joint 1 alone (it keeps the origin still and turns the
    # flange at 1 rad/s about z; joints 3, 5, 7 alone do the same: they differ from it by a frame-still pair)
    # and joints 2, 4 as 0.946 x2 = 0.526 x4: (0.526, 0.946)/1.0824, turning at 0.486 - 0.874 = -0.388 rad/s about y.
    report = report_of(iiwa14)
    assert report.singular
    assert (report.ranks("all"), report.ranks("translation"), report.ranks("rotation")) == ((3, 6), (1, 3), (2, 3))
    assert report.same_axis == ((0, 2, 4, 6),)
    assert [(lost.rows, lost.direction.tolist()) for lost in report.lost] == [
        ("translation", [0.0, 1.0, 0.0]), ("translation", [0.0, 0.0, 1.0]), ("rotation", [1.0, 0.0, 0.0])]
    frame, origin = motions_as(report, "frame"), motions_as(report, "origin")
    assert len(frame) == 4 and len(origin) == 2 and report.motions == tuple(frame + origin)
    half = math.sqrt(0.5)
    for motion, other in zip(frame[:3], (2, 4, 6)):
        expected = np.zeros(7)
        expected[[0, other]] = half, -half
        np.testing.assert_allclose(motion.joint_rates, expected, atol=1e-15)
    np.testing.assert_allclose(frame[3].joint_rates, np.array([0, 1, 0, 2.05, 0, 1.05, 0]) / math.sqrt(6.305), atol=1e-12)
    assert origin[0].joint_rates.tolist() == [1.0, 0, 0, 0, 0, 0, 0]  # exactly the unit vector of joint 1
    np.testing.assert_allclose(origin[0].angular_velocity, [0, 0, 1], atol=1e-15)
    np.testing.assert_allclose(origin[1].joint_rates, np.array([0, 0.526, 0, 0.946, 0, 0, 0]) / math.hypot(0.526, 0.946),
                               atol=1e-12)
    np.testing.assert_allclose(origin[1].angular_velocity, [0, (0.526 - 0.946) / math.hypot(0.526, 0.946), 0], atol=1e-12)
    # checked against Pinocchio: frame-still motions move nothing, origin-still ones only turn the frame;
    # together they span the translation rows' null space, which holds joint 7 alone
    J = pinocchio_jacobian(iiwa14, iiwa14.q())
    for motion in report.motions:
        twist = J @ motion.joint_rates
        assert np.abs(twist[:3]).max() < 1e-12 and np.linalg.norm(motion.joint_rates) == pytest.approx(1.0, abs=1e-15)
        assert (np.abs(twist[3:]).max() < 1e-12) == (motion.still == "frame")
    span = np.array([m.joint_rates for m in report.motions])
    assert np.linalg.matrix_rank(span, tol=1e-9) == 6
    assert np.linalg.matrix_rank(np.vstack([span, np.eye(7)[6]]), tol=1e-9) == 6
    assert [f.name for f in report.families] == ["elbow straight", "shoulder and wrist axes aligned"]


def test_scara_joint4_is_the_tool_roll_keeping_the_origin_still(load_robot):
    # q = (0.3, 0, 0.1, 0): joint 4 turns about -z on the vertical line through the tool origin, so its column
    # is (0, 0, 0, 0, 0, -1): alone it keeps the origin still and turns the tool at 1 rad/s about -z.
    # a1 = 0.35, a2 = 0.25, elbow straight: the translation columns of joints 1 and 2 are 0.6 (-s, c, 0) and
    # 0.25 (-s, c, 0), rank 2 of 3 with the quill's (0, 0, -1); the origin cannot move along (c, s, 0).
    # All rows (vx vy vz wz movable): 0.6 x1 + 0.25 x2 = 0 leaves the origin still and turns the tool by
    # x1 + x2, which joint 4 cancels with x4 = x1 + x2: (-0.25, 0.6, 0, 0.35)/sqrt(0.545), rank 3 of 4.
    scara = load_robot("scara")
    report = report_of(scara, [0.3, 0.0, 0.1, 0.0])
    assert report.singular and report.ranks("all") == (3, 4) and report.ranks("translation") == (2, 3)
    assert [ROW_NAMES[i] for i in report.movable_rows] == ["vx", "vy", "vz", "wz"]
    s, c = math.sin(0.3), math.cos(0.3)
    assert [(lost.rows, lost.direction.tolist()) for lost in report.lost] == [("translation", pytest.approx([c, s, 0]))]
    [frame] = motions_as(report, "frame")
    np.testing.assert_allclose(frame.joint_rates, np.array([-0.25, 0.6, 0, 0.35]) / math.sqrt(0.545), atol=1e-12)
    [roll] = motions_as(report, "origin")
    assert roll.joint_rates.tolist() == [0.0, 0.0, 0.0, 1.0]
    np.testing.assert_allclose(roll.angular_velocity, [0, 0, -1], atol=1e-15)
    np.testing.assert_allclose(roll.velocity, 0.0, atol=1e-15)


def test_stanford_arm_default_names_the_wrist_and_the_boom(load_robot):
    # Default q = (0, 0, 0.1, 0, 0, 0): joint5 = 0 (wrist straight: joints 4 and 6 both on the z line through
    # (0, 0.154)) and joint2 = 0 (the boom along joint 1's axis), d3 = 0.1 (not the boom-in family, d3 = 0).
    # Tool origin p = (0, 0.154, 0.363). Columns: j1 (-0.154, 0, 0, 0, 0, 1), j2 (0.363, 0, 0, 0, 1, 0),
    # j3 (0, 0, 1, 0, 0, 0), j4 = j6 = (0, 0, 0, 0, 0, 1), j5 (0.263, 0, 0, 0, 1, 0).
    # Translation rows: vx and vz only, rank 2 of 3: the origin cannot move along y (the shoulder offset).
    # Rotation rows: wy, wz, rank 2 of 3: the frame cannot turn about x. All rows: rank 4 of 6.
    # Joint 4 alone keeps the origin still and turns the tool at 1 rad/s about z; joints 1 and 2 as
    # -0.154 x1 + 0.363 x2 = 0: (0.363, 0.154)/0.3943 keep it still too and turn it about (0, 0.391, 0.921).
    stanford = load_robot("stanford_arm")
    report = report_of(stanford)
    assert [f.name for f in report.families] == ["wrist", "boom along joint 1's axis"]
    assert report.singular and report.ranks("all") == (4, 6)
    assert report.ranks("translation") == (2, 3) and report.ranks("rotation") == (2, 3)
    assert report.same_axis == ((3, 5),)
    assert [(lost.rows, lost.direction.tolist()) for lost in report.lost] == [
        ("translation", [0.0, 1.0, 0.0]), ("rotation", [1.0, 0.0, 0.0])]
    frame, origin = motions_as(report, "frame"), motions_as(report, "origin")
    assert len(frame) == 2
    np.testing.assert_allclose(frame[0].joint_rates, [0, 0, 0, math.sqrt(0.5), 0, -math.sqrt(0.5)], atol=1e-15)
    assert origin[0].joint_rates.tolist() == [0, 0, 0, 1.0, 0, 0]
    np.testing.assert_allclose(origin[0].angular_velocity, [0, 0, 1], atol=1e-15)
    r = math.hypot(0.363, 0.154)
    np.testing.assert_allclose(origin[1].joint_rates, [0.363 / r, 0.154 / r, 0, 0, 0, 0], atol=1e-12)
    np.testing.assert_allclose(origin[1].angular_velocity, [0, 0.154 / r, 0.363 / r], atol=1e-12)


def test_stanford_wrist_alone_loses_one_combined_direction(load_robot):
    # joint2 = 0.7, joint3 = 0.5, joint5 = 0: only the wrist family. Joints 4 and 6 have equal columns (one
    # axis): turning 4 forward and 6 back by as much, (1, -1)/sqrt2, leaves the tool still; translation and
    # rotation rows keep rank 3 each, so the one direction lost mixes moving and turning (checked: no column
    # of the Jacobian has a part along it)
    stanford = load_robot("stanford_arm")
    q = stanford.q(joint2=0.7, joint3=0.5, joint5=0.0)
    report = report_of(stanford, q)
    assert [f.name for f in report.families] == ["wrist"] and report.ranks("all") == (5, 6)
    assert report.same_axis == ((3, 5),)
    [motion] = report.motions
    assert motion.still == "frame" and motion.joints == (3, 5)
    np.testing.assert_allclose(motion.joint_rates[[3, 5]], [math.sqrt(0.5), -math.sqrt(0.5)], atol=1e-15)
    [lost] = report.lost
    assert lost.rows == "all" and lost.direction.shape == (6,)
    assert np.abs(lost.direction @ pinocchio_jacobian(stanford, q)).max() < 1e-12  # length 1: rows as they are


def test_iiwa_with_two_aligned_pairs_names_both_axes(iiwa14):
    # joint2 = 0 puts joints 1 and 3 on one axis, joint6 = 0 joints 5 and 7 (the "shoulder and wrist axes
    # aligned" family): two pairs of equal columns, so two frame-still pair motions
    q = iiwa14.q(iiwa_joint_2=0.0, iiwa_joint_4=0.8, iiwa_joint_6=0.0, iiwa_joint_3=0.3)
    report = report_of(iiwa14, q)
    assert report.singular and report.same_axis == ((0, 2), (4, 6))
    assert [m.joints for m in motions_as(report, "frame")][:2] == [(0, 2), (4, 6)]
    assert "shoulder and wrist axes aligned" in [f.name for f in report.families]


# --------------------------------------------------------------------------
# properties


@pytest.mark.parametrize("robot_name", KNOWN_ROBOTS)
def test_members_of_every_family_are_singular_and_name_it(load_robot, robot_name):
    robot = load_robot(robot_name)
    chain = robot.chain("base_link", "ee_link")
    for family in singular_families(robot):
        if not family.reachable:
            continue
        for q in family.sample(np.random.default_rng(zlib.crc32(family.name.encode())), 4):
            report = jacobian_report(chain, q)
            assert report.singular, (family.name, q)
            assert family.name in [f.name for f in report.families]
            J = pinocchio_jacobian(robot, q)
            for motion in report.motions:  # unit joint rates that keep the origin still (Pinocchio)
                assert np.linalg.norm(motion.joint_rates) == pytest.approx(1.0, abs=1e-12)
                assert np.abs(J[:3] @ motion.joint_rates).max() < 1e-9
                assert np.count_nonzero(motion.joint_rates) > 1 or np.max(motion.joint_rates) == 1.0
            for lost in report.lost:  # no joint motion gives any part along a lost direction
                rows = {"translation": J[:3], "rotation": J[3:], "all": J}[lost.rows]
                assert np.abs(lost.direction @ rows).max() < 1e-9
                assert np.linalg.norm(lost.direction) == pytest.approx(1.0, abs=1e-12)


@pytest.mark.parametrize("robot_name", ["planar_2r", "planar_3r"])
def test_a_planar_arm_never_loses_rows_it_cannot_move(load_robot, robot_name):
    robot = load_robot(robot_name)
    for q in [np.zeros(len(robot.joint_names)), *robot.sample_q(5, seed=2)]:
        q[1] = 0.0  # the elbow straight: singular
        report = report_of(robot, q)
        assert report.singular and [ROW_NAMES[i] for i in report.movable_rows] == ["vx", "vy", "wz"]
        for lost in report.lost:  # the rotation rows (wz alone) never lose rank; vz, wx, wy are never named
            assert lost.rows != "rotation"
            full = lost.direction if lost.rows == "all" else np.r_[lost.direction, np.zeros(3)]
            assert full[2] == 0.0 and full[3] == 0.0 and full[4] == 0.0


def test_the_local_reference_gives_the_same_ranks_and_decision(iiwa14, planar_2r):
    for robot, q in ((iiwa14, iiwa14.q()), (iiwa14, iiwa14.sample_q(1, seed=5)[0]), (planar_2r, [0.3, 0.0])):
        base, local = report_of(robot, q), report_of(robot, q, reference="local")
        assert local.reference == "local" and base.singular == local.singular
        assert [base.ranks(rows) for rows in ("all", "translation", "rotation")] == \
            [local.ranks(rows) for rows in ("all", "translation", "rotation")]


def test_families_are_only_those_of_the_base_link_to_ee_link_chain(iiwa14):
    report = jacobian_report(iiwa14.chain("iiwa_link_2", "ee_link"), iiwa14.q())
    assert report.families == () and report.singular


def test_the_report_is_immutable(planar_2r):
    report = report_of(planar_2r, [0.3, 0.0])
    with pytest.raises(AttributeError):
        report.singular = False
    with pytest.raises(ValueError):
        report.jacobian[0, 0] = 1.0
    with pytest.raises(ValueError):
        report.motions[0].joint_rates[0] = 1.0


def test_joint_values_by_name(iiwa14):
    chain = iiwa14.chain("base_link", "ee_link")
    by_name = jacobian_report(chain, {"iiwa_joint_4": 0.0, "iiwa_joint_2": 0.5})
    assert by_name.q[1] == 0.5 and by_name.singular  # the elbow straight


def test_a_chain_without_joints_has_rank_0_and_is_not_singular(planar_2r):
    report = jacobian_report(planar_2r.chain("ee_link", "ee_link"), [])
    assert report.jacobian.shape == (6, 0) and report.rank == report.generic_rank == 0
    assert not report.singular and report.movable_rows == () and report.motions == ()


@pytest.mark.parametrize(("options", "message"), [
    ({"length": 0.0}, r"length 0: give a length in metres from 1e-09 to 1e\+06"),
    ({"length": 1e308}, r"length 1e\+308: give a length in metres from 1e-09 to 1e\+06"),
    ({"tol": -1.0}, "tol=-1.0: give a tolerance >= 0"),
    ({"reference": "world"}, "reference='world' is not one of"),
])
def test_bad_options_are_refused(planar_2r, options, message):
    with pytest.raises(ManipkitError, match=message):
        report_of(planar_2r, [0.3, 0.0], **options)
