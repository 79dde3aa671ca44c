"""manipkit.app.viewer without a browser: state -> readout and scene, visual geometry, servers, --static, notebooks.

Independent sources: the readout and the scene placements against the
course arm's joint table composed by hand (tests/reference.py) and hand
values, the readout also against the ``tf-between`` command (run in
process, tests/cli_helper.py); the static export decoded back from meshcat's msgpack commands.
The manipulability overlay against ``velocity_ellipsoid``/``force_ellipsoid``
of ``robot.jacobian`` computed here, the planar 2R's singular values derived
by hand, and velocities from central differences of ``robot.transform``; its
singularity lines are ``manipkit jacobian``'s (tests/test_app_jacobian_text.py).
The browser half is in test_app_viewer_browser.py; the HTTP server's refusals
(Host, Origin, token, body size and depth) in test_app_viewer_http.py.
"""

import base64
import html
import html.parser
import http.client
import json
import math
import re
import socket
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from cli_helper import run_cli
from reference import (
    COURSE_ARM_JOINTS as COURSE_ARM_TABLE,
)
from reference import (
    POSE_A,
    compose_chain,
    course_arm_T_base_ee,
    course_arm_T_base_top_wrist,
    matrix_from_axis_angle,
    matrix_from_rpy,
    rot_z,
    urdf_origin,
)

import manipkit
from manipkit.analysis.manipulability import force_ellipsoid, velocity_ellipsoid
from manipkit.app.pose import pose_text
from manipkit.app.viewer import (
    ELLIPSOID_PATH,
    TRIAD_PATHS,
    VISUALS_ROOT,
    Overlay,
    ViewerServer,
    ViewerState,
    open_view,
    visual_model,
    write_static,
)
from manipkit.errors import JointValueError, ManipkitError, PackageNotFoundError, UnknownFrameError

COURSE_ARM_JOINTS = ("arm_base_joint", "shoulder_joint", "bottom_wrist_joint", "elbow_joint", "top_wrist_joint")


@pytest.fixture(scope="module")
def robots():
    return {name: manipkit.load(name) for name in ("course_arm", "iiwa14", "stanford_arm", "panda", "ur5")}


def random_q(robot, seed=0):
    return robot.sample_q(1, seed=seed)[0]


def tf_between(source, target, q: dict, *options, robot="course_arm") -> str:
    args = [f"{name}={value!r}" for name, value in q.items()]
    return run_cli("tf-between", source, target, "--robot", robot, "--q", *args, *options, status=0).stdout


def tf_between_json(source, target, q: dict, robot="course_arm") -> dict:
    return json.loads(tf_between(source, target, q, "--format", "json", robot=robot))


def course_arm_T_base(link: str, q) -> np.ndarray:
    """T_base_link_<link> of the course arm from its joint table (tests/reference.py), q in joint order."""
    if link == "ee_link":
        return course_arm_T_base_ee(q)
    chain = ("base_link", "arm_base", "bicep", "bottom_wrist", "elbow", "top_wrist").index(link)
    return compose_chain(COURSE_ARM_TABLE[:chain], q[:chain])


def listening_socket():
    sock = socket.socket()
    sock.bind(("127.0.0.1", 0))
    sock.listen()
    return sock


# ----------------------------------------------------------------------
# ViewerState: joint values
# ----------------------------------------------------------------------


def test_set_joint_clamps_into_the_limits(robots):
    robot = robots["iiwa14"]
    state = ViewerState(robot)
    joint = robot.joints[1]
    assert state.set_joint(joint.name, joint.upper + 0.5) == joint.upper
    assert state.q[1] == joint.upper
    assert state.set_joint(joint.name, -100) == joint.lower
    assert state.set_joint(joint.name, 0.25) == 0.25


def test_start_pose_outside_the_limits_is_clamped_and_defaults_are_inside(robots):
    robot = robots["stanford_arm"]  # joint3 is prismatic with limits [0.1, 1]
    assert ViewerState(robot).q[2] == 0.1
    assert ViewerState(robot, q=robot.q(joint3=5.0)).q[2] == 1.0


def test_continuous_joint_wraps_into_minus_pi_pi_and_keeps_the_pose(robots):
    robot = robots["course_arm"]  # every joint of the course arm is continuous
    state = ViewerState(robot)
    used = state.set_joint("shoulder_joint", 4.0)
    assert used == pytest.approx(4.0 - 2 * math.pi, abs=1e-15)
    assert state.set_joint("elbow_joint", math.pi) == math.pi  # the upper end of (-pi, pi] stays
    q_given = robot.q(shoulder_joint=4.0, elbow_joint=math.pi)
    assert np.abs(robot.transform("base_link", "ee_link", state.q) - robot.transform("base_link", "ee_link", q_given)).max() < 1e-12


@pytest.mark.parametrize("given", [-3 * math.pi, 3 * math.pi, -math.pi, -5 * math.pi])
def test_continuous_joint_wraps_odd_multiples_of_pi_to_plus_pi(robots, given):
    robot = robots["course_arm"]
    assert ViewerState(robot).set_joint("shoulder_joint", given) == math.pi  # (-pi, pi], as DESIGN.md wraps angles
    assert ViewerState(robot, q=robot.q(elbow_joint=given)).q[3] == math.pi  # the start pose too


def test_set_joint_rejects_unknown_joints_and_non_numbers(robots):
    state = ViewerState(robots["course_arm"])
    with pytest.raises(JointValueError, match="has no joint 'shoulder'; did you mean shoulder_joint.*joints: arm_base_joint"):
        state.set_joint("shoulder", 0.1)
    with pytest.raises(JointValueError, match="'abc' is not a number"):
        state.set_joint("shoulder_joint", "abc")
    with pytest.raises(JointValueError, match="not finite"):
        state.set_joint("shoulder_joint", float("nan"))
    assert list(state.q) == [0.0] * 5


def test_set_joints_checks_every_value_before_setting_any(robots):
    state = ViewerState(robots["course_arm"])
    with pytest.raises(JointValueError):
        state.set_joints({"shoulder_joint": 0.3, "nope": 1.0})
    assert state.q[1] == 0.0


def test_reset_returns_to_the_start_pose(robots):
    robot = robots["course_arm"]
    state = ViewerState(robot, q=robot.q(elbow_joint=0.4))
    state.set_joint("elbow_joint", -1.0)
    state.set_joint("shoulder_joint", 1.0)
    state.reset()
    assert list(state.q) == list(robot.q(elbow_joint=0.4))


def test_sliders_span_the_limits_and_continuous_joints_span_minus_pi_pi(robots):
    iiwa = robots["iiwa14"]
    specs = ViewerState(iiwa, q=iiwa.q(iiwa_joint_2=0.5)).sliders()
    assert [s.name for s in specs] == list(iiwa.joint_names)
    assert [(s.lower, s.upper) for s in specs] == [(j.lower, j.upper) for j in iiwa.joints]
    assert specs[1].value == 0.5 and specs[1].unit == "rad" and specs[1].type == "revolute"
    assert specs[0].step == pytest.approx((specs[0].upper - specs[0].lower) / 1000)
    course = ViewerState(robots["course_arm"]).sliders()
    # continuous joints: (-pi, pi] in 1000 steps, the left end one step above -pi (which wraps to +pi)
    assert {(s.type, s.lower, s.upper) for s in course} == {("continuous", -math.pi + 2 * math.pi / 1000, math.pi)}
    assert all(s.step == pytest.approx(2 * math.pi / 1000) for s in course)
    prismatic = ViewerState(robots["stanford_arm"]).sliders()[2]
    assert (prismatic.type, prismatic.unit, prismatic.lower, prismatic.upper) == ("prismatic", "m", 0.1, 1.0)


# ----------------------------------------------------------------------
# ViewerState: frames and readout
# ----------------------------------------------------------------------


def test_readout_is_the_pose_of_the_course_arm_joint_table(robots):
    robot = robots["course_arm"]
    q = random_q(robot, seed=4)
    shown = ViewerState(robot, frames=("bicep", "ee_link"), q=q).readout()
    assert list(shown) == ["source", "target", "robot", "q", "translation", "quaternion_xyzw", "rpy", "matrix"]
    assert (shown["source"], shown["target"], shown["robot"]) == ("bicep", "ee_link", "course_arm")
    assert shown["q"] == dict(zip(robot.joint_names, q))
    # the joint table composed by hand (tests/reference.py): T_bicep_ee = inv(T_base_bicep) T_base_ee
    by_hand = np.linalg.inv(course_arm_T_base("bicep", q)) @ course_arm_T_base_ee(q)
    assert np.abs(np.array(shown["matrix"]) - by_hand).max() < 1e-12
    assert np.abs(np.array(shown["translation"]) - by_hand[:3, 3]).max() < 1e-12
    assert np.abs(matrix_from_rpy(*shown["rpy"]) - by_hand[:3, :3]).max() < 1e-12  # R = Rz(yaw) Ry(pitch) Rx(roll)
    x, y, z, w = shown["quaternion_xyzw"]  # (x, y, z, w) = (sin(angle/2) axis, cos(angle/2))
    axis = np.array([x, y, z]) / np.linalg.norm([x, y, z])
    angle = 2 * math.atan2(np.linalg.norm([x, y, z]), w)
    assert np.abs(matrix_from_axis_angle(axis, angle) - by_hand[:3, :3]).max() < 1e-12


def test_readout_equals_the_tf_between_json(robots):
    robot = robots["course_arm"]
    state = ViewerState(robot, frames=("base_link", "top_wrist"))
    for name, value in zip(COURSE_ARM_JOINTS, (0.3, -1.2, 0.7, 2.0, -0.4)):
        state.set_joint(name, value)
    shown = json.loads(state.snapshot()["readout_json"])
    assert shown == tf_between_json("base_link", "top_wrist", shown["q"])
    # and the number itself, against the course arm's joint table composed by hand (tests/reference.py)
    by_hand = course_arm_T_base_top_wrist([shown["q"][name] for name in COURSE_ARM_JOINTS])
    assert np.abs(np.array(shown["matrix"]) - by_hand).max() < 1e-12


def test_readout_text_is_the_pose_text_of_tf_between(robots):
    robot = robots["course_arm"]
    state = ViewerState(robot, q=robot.q(shoulder_joint=0.5))
    text = state.snapshot()["readout_text"]
    assert text.splitlines()[0] == "pose of ee_link expressed in base_link (T_base_link_ee_link, as tf2_echo base_link ee_link):"
    # the command prints its robot and joint lines, then the same pose lines
    assert tf_between("base_link", "ee_link", {"shoulder_joint": 0.5}).endswith("\n" + text + "\n")
    # and the numbers are the pose of the joint table composed by hand
    by_hand = course_arm_T_base_ee((0.0, 0.5, 0.0, 0.0, 0.0))
    translation = re.search(r"Translation \(m\): \[(.*)\]", text).group(1)
    assert np.allclose([float(v) for v in translation.split(",")], by_hand[:3, 3], atol=5e-7)
    matrix = [[float(v) for v in line.split()] for line in text.splitlines()[-4:]]
    assert np.allclose(matrix, by_hand, atol=5e-7)


def test_set_frames_rejects_unknown_frames_and_keeps_the_old_ones(robots):
    state = ViewerState(robots["course_arm"])
    with pytest.raises(UnknownFrameError, match="no frame 'elbw'; did you mean elbow"):
        state.set_frames("base_link", "elbw")
    assert state.frames == ("base_link", "ee_link")
    with pytest.raises(UnknownFrameError):
        ViewerState(robots["course_arm"], frames=("nowhere", "ee_link"))


def test_frame_choices_are_the_links_plus_the_aliases(robots):
    assert ViewerState(robots["course_arm"]).frame_choices() == robots["course_arm"].frame_names
    panda = ViewerState(robots["panda"]).frame_choices()  # panda has no link called base_link or ee_link
    assert panda == robots["panda"].frame_names + ("base_link", "ee_link")


# ----------------------------------------------------------------------
# ViewerState: scene placements
# ----------------------------------------------------------------------


@pytest.mark.parametrize("q", [(0.0,) * 5, POSE_A, (0.3, -1.2, 0.7, 2.0, -0.4)])
def test_geometry_placements_are_the_course_arm_visuals_on_its_joint_table(robots, q):
    robot = robots["course_arm"]
    placements = ViewerState(robot, q=q).geometry_placements(visual_model(robot))
    assert len(placements) == 7
    # <visual><origin> of each link in robots/course_arm.xacro, on the link's pose composed by hand
    expected = {
        "bicep_0": course_arm_T_base("bicep", q) @ urdf_origin((0.0, -0.026, 0.1345), (0.0, -1.5708, 0.0)),
        "top_wrist_0": course_arm_T_base_top_wrist(q) @ urdf_origin((0.0, 0.0, 0.13522 / 2), (3.14, 0.0, 1.5708)),
        "ee_link_0": course_arm_T_base_ee(q),
    }
    for name, T in expected.items():
        assert np.abs(placements[f"{VISUALS_ROOT}/{name}"] - T).max() < 1e-12, name


def test_geometry_placements_scale_the_mesh(tmp_path):
    (tmp_path / "arm.stl").write_text(STL)
    robot = manipkit.load(one_mesh_urdf(tmp_path, "arm.stl", scale="2 3 4", origin="0.1 0 0.2"))
    placements = ViewerState(robot, q=robot.q(joint1=0.5)).geometry_placements(visual_model(robot))
    # T_base_arm = Rz(0.5) (joint1 about z at the origin), then the visual's offset, then diag(2, 3, 4) on the columns
    T_base_arm = np.eye(4)
    T_base_arm[:3, :3] = rot_z(0.5)
    expected = T_base_arm @ urdf_origin((0.1, 0.0, 0.2), (0.0, 0.0, 0.0)) @ np.diag([2.0, 3.0, 4.0, 1.0])
    assert list(placements) == [f"{VISUALS_ROOT}/arm_0"]
    assert np.abs(placements[f"{VISUALS_ROOT}/arm_0"] - expected).max() < 1e-12


def test_geometry_placements_move_with_their_links(robots):
    """Each visual keeps a constant pose in its link (robot.transform of the parent frame) whatever q is."""
    robot = robots["panda"]
    visual = visual_model(robot)
    offsets = []
    for seed in (1, 2):
        q = random_q(robot, seed)
        placements = ViewerState(robot, q=q).geometry_placements(visual)
        offsets.append({
            g.name: np.linalg.inv(robot.transform(robot.root_link, robot.model.frames[g.parentFrame].name, q))
            @ placements[f"{VISUALS_ROOT}/{g.name}"]
            for g in visual.geometryObjects
        })
    for name in offsets[0]:
        assert np.abs(offsets[0][name] - offsets[1][name]).max() < 1e-12


def test_triads_sit_at_frames_a_and_b(robots):
    robot = robots["course_arm"]  # its root link is base_link
    q = random_q(robot, 5)
    state = ViewerState(robot, frames=("bicep", "ee_link"), q=q)
    triads = state.frame_placements()
    assert list(triads) == list(TRIAD_PATHS)
    assert np.abs(triads["manipkit/frame_a"] - course_arm_T_base("bicep", q)).max() < 1e-12
    assert np.abs(triads["manipkit/frame_b"] - course_arm_T_base_ee(q)).max() < 1e-12
    T_a_b = np.linalg.inv(triads["manipkit/frame_a"]) @ triads["manipkit/frame_b"]
    assert np.abs(T_a_b - np.array(state.readout()["matrix"])).max() < 1e-12


def test_bounds_are_the_box_around_the_frame_origins(robots):
    robot = robots["course_arm"]
    # at q = 0 the arm stands straight up: bicep at x = -0.05166 (its joint's origin), the joints above it
    # at x = -0.05166 + 0.05194 = 0.00028, ee_link at z = 0.1 + 0.20271 + 0.269 + 0.13522 + 0.20994 + 0.13522 = 1.05209
    lower, upper = ViewerState(robot).bounds()
    assert np.allclose(lower, [-0.05166, 0.0, 0.0], atol=1e-6) and np.allclose(upper, [0.00028, 0.0, 1.05209], atol=1e-6)
    q = random_q(robot, 2)
    origins = np.array([course_arm_T_base(link, q)[:3, 3] for link in robot.frame_names])
    lower, upper = ViewerState(robot, q=q).bounds()
    assert np.abs(lower - origins.min(axis=0)).max() < 1e-12 and np.abs(upper - origins.max(axis=0)).max() < 1e-12


# ----------------------------------------------------------------------
# ViewerState: the manipulability overlay
# ----------------------------------------------------------------------


@pytest.fixture(scope="module")
def planar_2r():
    return manipkit.load("planar_2r")


def ellipsoid_matrix(T):
    """E = M M^T of a placement T = [M p]: the ellipsoid drawn is {p + x : x^T E^-1 x <= 1} (sign-free)."""
    return T[:3, :3] @ T[:3, :3].T


@pytest.mark.parametrize("kind, axes", [("velocity", "trans"), ("velocity", "rot"), ("force", "trans"), ("force", "rot")])
def test_ellipsoid_readout_is_that_of_the_jacobian_of_b_relative_to_a(robots, kind, axes):
    robot = robots["iiwa14"]
    q = random_q(robot, 7)
    state = ViewerState(robot, frames=("iiwa_link_2", "ee_link"), q=q, overlay=Overlay(True, kind, axes))
    report = state.ellipsoid()
    J = robot.jacobian(q, tip="ee_link", base="iiwa_link_2", reference="base")
    expected = (velocity_ellipsoid if kind == "velocity" else force_ellipsoid)(J, axes)
    assert (report["frame"], report["base"], report["kind"], report["axes"]) == ("ee_link", "iiwa_link_2", kind, axes)
    assert np.abs(np.array(report["radii"]) - expected.radii).max() < 1e-12
    # principal axes up to the sign of each column
    dots = np.abs(np.sum(np.array(report["principal_axes"]) * expected.axes, axis=0))
    assert np.abs(dots - 1.0).max() < 1e-9
    s = np.linalg.svd(J[:3], compute_uv=False)
    assert report["manipulability_translation"] == pytest.approx(np.prod(s), rel=1e-12)
    rows = slice(0, 3) if axes == "trans" else slice(3, 6)
    s_rows = np.linalg.svd(J[rows], compute_uv=False)
    assert report["condition_number"] == pytest.approx(s_rows[0] / s_rows[-1], rel=1e-9)


def test_ellipsoid_sits_at_b_with_a_s_axes_turned_into_the_root(robots):
    """Placement: centre at B's origin (robot.transform); shape scale^2 R_root_A U diag(r^2) U^T R_root_A^T."""
    robot = robots["iiwa14"]
    q = random_q(robot, 3)
    state = ViewerState(robot, frames=("iiwa_link_2", "ee_link"), q=q, overlay=Overlay(True))
    T = state.ellipsoid_placement()
    assert np.abs(T[:3, 3] - robot.transform("base_link", "ee_link", q)[:3, 3]).max() < 1e-12
    assert np.array_equal(T[3], [0.0, 0.0, 0.0, 1.0]) and np.linalg.det(T[:3, :3]) > 0
    report = state.ellipsoid()
    assert not report["capped"]
    R_root_a = robot.transform("base_link", "iiwa_link_2", q)[:3, :3]
    U = np.array(report["principal_axes"])
    drawn = report["scale"] * np.array(report["radii"])
    expected = R_root_a @ U @ np.diag(drawn**2) @ U.T @ R_root_a.T
    assert np.abs(ellipsoid_matrix(T) - expected).max() < 1e-12
    assert state.scene_placements()[ELLIPSOID_PATH].tolist() == T.tolist()


def test_velocity_ellipsoid_holds_the_velocities_of_unit_joint_rates(robots):
    """Independent of the Jacobian code: B's velocity in A's axes by central differences of robot.transform(A, B).

    Every unit joint rate moves B at a velocity v with scale R_root_A v inside the drawn ellipsoid, and
    the fastest direction (the top right singular vector) lands on its surface.
    """
    robot = robots["course_arm"]
    q = random_q(robot, 11)
    state = ViewerState(robot, frames=("bicep", "ee_link"), q=q, overlay=Overlay(True))
    T, report = state.ellipsoid_placement(), state.ellipsoid()
    E_inv = np.linalg.inv(ellipsoid_matrix(T))
    R_root_a = robot.transform("base_link", "bicep", q)[:3, :3]

    def velocity(qdot, h=1e-6):  # d/dt p_bicep_ee, in bicep's axes
        plus = robot.transform("bicep", "ee_link", q + h * qdot, check_limits=False)[:3, 3]
        minus = robot.transform("bicep", "ee_link", q - h * qdot, check_limits=False)[:3, 3]
        return (plus - minus) / (2 * h)

    rng = np.random.default_rng(0)
    for _ in range(20):
        qdot = rng.normal(size=len(q))
        x = report["scale"] * R_root_a @ velocity(qdot / np.linalg.norm(qdot))
        assert x @ E_inv @ x <= 1 + 1e-6
    J_v = np.array([velocity(e) for e in np.eye(len(q))]).T  # (3, n) by differences
    top = np.linalg.svd(J_v)[2][0]
    x = report["scale"] * R_root_a @ velocity(top)
    assert x @ E_inv @ x == pytest.approx(1.0, abs=1e-6)


@pytest.mark.parametrize("q2", [0.4, 1.3, 2.5])
def test_planar_2r_ellipsoid_by_hand(planar_2r, q2):
    """l1 = l2 = 1, q1 = 0: J_v = [[-s2, -s2], [1 + c2, c2]]; sigma1 sigma2 = |s2|, sigma1^2 + sigma2^2 = 3 + 2 c2."""
    state = ViewerState(planar_2r, q=[0.0, q2], overlay=Overlay(True))
    report = state.ellipsoid()
    total, product = 3 + 2 * math.cos(q2), abs(math.sin(q2))
    root = math.sqrt(total**2 - 4 * product**2)
    by_hand = [math.sqrt((total + root) / 2), math.sqrt((total - root) / 2), 0.0]
    assert np.abs(np.array(report["radii"]) - by_hand).max() < 1e-12
    assert report["manipulability_translation"] == pytest.approx(product, rel=1e-12)
    assert report["condition_number"] == pytest.approx(by_hand[0] / by_hand[1], rel=1e-12)
    assert (report["rank_translation"], report["generic_rank_translation"], report["singular"]) == (2, 2, False)
    assert (report["rank"], report["generic_rank"]) == (2, 2)
    # the radius 0 (no motion along z) is drawn as a thin disc: 1e-3 of the robot's size, never 0
    T = state.ellipsoid_placement()
    assert np.linalg.norm(T[:3, 2]) == pytest.approx(1e-3 * state.size, rel=1e-12)
    assert abs(T[2, 0]) < 1e-12 and abs(T[2, 1]) < 1e-12  # the disc lies in the plane of the arm


def test_ellipsoid_at_a_singularity_reads_inf_and_caps_the_force_ellipsoid(planar_2r):
    state = ViewerState(planar_2r, q=[0.3, 0.0], overlay=Overlay(True))  # arm straight: singular
    report = state.ellipsoid()
    # sigma_2 is 0 up to rounding: the condition number is huge (or inf), the rank of the translation rows 1, not 2
    assert report["manipulability_translation"] < 1e-15
    assert report["condition_number"] is None or report["condition_number"] > 1e12
    assert (report["rank_translation"], report["generic_rank_translation"], report["singular"]) == (1, 2, True)
    assert (report["rank"], report["generic_rank"]) == (2, 2)  # all rows: it can still turn
    text = state.snapshot()["ellipsoid_text"]
    assert "rank: 2 of 2 (all rows), 1 of 2 (translation rows), 1 of 1 (rotation rows)" in text
    assert "singular: yes (family: elbow straight: joint2 = 0 or 180 deg)" in text
    state.set_overlay(axes="rot")  # the rows drawn do not change the decision: the rotation rows keep rank 1 of 1
    assert state.ellipsoid()["singular"] is True
    state.set_overlay(axes="trans")
    state.set_overlay(kind="force")
    report = state.ellipsoid()
    assert report["radii"][2] is None and (report["radii"][1] is None or report["radii"][1] > 1e12)
    assert report["capped"]  # 1/sigma_2: a force along the arm takes (next to) no torque
    radii_drawn = np.linalg.norm(state.ellipsoid_placement()[:3, :3], axis=0)
    assert np.allclose(sorted(radii_drawn)[1:], [state.size, state.size], rtol=1e-12)
    text = state.snapshot()["ellipsoid_text"]
    assert "capped: radii above" in text and ", inf" in text
    json.dumps(state.snapshot(), allow_nan=False)  # the page's JSON.parse takes no Infinity


def test_ellipsoid_scale_is_stated_and_rounded_to_1_2_5(planar_2r):
    state = ViewerState(planar_2r, overlay=Overlay(True))  # straight along x at q = 0: size = 2 m
    assert state.size == 2.0
    assert ViewerState(planar_2r, q=[0.0, 2.5]).size == 2.0  # the size is the default pose's, whatever the start pose
    # velocity/trans 0.5; velocity/rot 0.2 * 2 = 0.4 -> 0.5 m per rad/s; force/trans 0.1 * 4 = 0.4 -> 0.5 m per N;
    # force/rot 0.3 * 2 = 0.6 -> 0.5 m per N m
    scales = {}
    for kind in ("velocity", "force"):
        for axes in ("trans", "rot"):
            state.set_overlay(kind=kind, axes=axes)
            scales[kind, axes] = (state.ellipsoid_scale(), state.ellipsoid()["scale_unit"])
    assert scales == {("velocity", "trans"): (0.5, "m per m/s"), ("velocity", "rot"): (0.5, "m per rad/s"),
                      ("force", "trans"): (0.5, "m per N"), ("force", "rot"): (0.5, "m per N m")}
    state.set_overlay(kind="velocity", axes="trans")
    assert "radii x 0.5 m per m/s, at most 2 m" in state.snapshot()["ellipsoid_text"]


def test_overlay_off_draws_and_computes_nothing(robots):
    state = ViewerState(robots["course_arm"])
    assert state.overlay == Overlay(False, "velocity", "trans")
    assert ELLIPSOID_PATH not in state.scene_placements()
    assert state.scene_visibility() == {ELLIPSOID_PATH: False}
    snapshot = state.snapshot()
    assert snapshot["ellipsoid"] is None and snapshot["ellipsoid_text"] == ""
    assert snapshot["overlay"] == {"shown": False, "kind": "velocity", "axes": "trans"}
    state.set_overlay(shown=True)
    assert ELLIPSOID_PATH in state.scene_placements() and state.scene_visibility() == {ELLIPSOID_PATH: True}


def test_ellipsoid_follows_the_joints_and_the_frames(robots):
    robot = robots["course_arm"]
    state = ViewerState(robot, overlay=Overlay(True))
    before = state.ellipsoid()
    state.set_joint("elbow_joint", 1.0)
    moved = state.ellipsoid()
    assert moved["manipulability_translation"] != before["manipulability_translation"]
    J = robot.jacobian(state.q, tip="ee_link", base="base_link")
    assert np.abs(np.array(moved["radii"]) - velocity_ellipsoid(J).radii).max() < 1e-12
    state.set_frames("bicep", "top_wrist")
    report = state.ellipsoid()
    J = robot.jacobian(state.q, tip="top_wrist", base="bicep")
    assert (report["frame"], report["base"]) == ("top_wrist", "bicep")
    assert np.abs(np.array(report["radii"]) - velocity_ellipsoid(J).radii).max() < 1e-12
    assert np.abs(state.ellipsoid_placement()[:3, 3] - robot.transform("base_link", "top_wrist", state.q)[:3, 3]).max() < 1e-12


def test_frames_up_the_tree_have_an_ellipsoid_and_fixed_together_say_so_and_draw_none(robots):
    # A below B (ee_link, then bicep up the arm) is a chain too (issue 35): the Jacobian of bicep relative to
    # ee_link, drawn at bicep; frames fixed together have none, and the readout says so
    robot = robots["course_arm"]
    state = ViewerState(robot, frames=("ee_link", "bicep"), overlay=Overlay(True))
    report = state.ellipsoid()
    chain = robot.chain("ee_link", "bicep")
    assert "error" not in report and chain.joint_names == ("top_wrist_joint", "elbow_joint", "bottom_wrist_joint")
    J = chain.jacobian(state.q[chain.columns])
    assert np.abs(np.array(report["radii"]) - velocity_ellipsoid(J).radii).max() < 1e-12
    assert np.abs(state.ellipsoid_placement()[:3, 3] - robot.transform("base_link", "bicep", state.q)[:3, 3]).max() < 1e-12
    assert state.scene_visibility() == {ELLIPSOID_PATH: True}
    json.dumps(state.snapshot(), allow_nan=False)
    state.set_frames("ee_link", "ee_link")  # a chain without joints: nothing moves, nothing to draw
    assert state.ellipsoid()["error"] == "no joint moves ee_link relative to ee_link"
    assert state.scene_visibility() == {ELLIPSOID_PATH: False}
    json.dumps(state.snapshot(), allow_nan=False)
    state.set_frames("bicep", "ee_link")
    assert "error" not in state.ellipsoid() and state.scene_visibility() == {ELLIPSOID_PATH: True}


@pytest.mark.parametrize("change, message", [
    ({"kind": "speed"}, "ellipsoid kind 'speed': give velocity or force"),
    ({"axes": "all"}, "ellipsoid axes 'all': give trans .* or rot"),
    ({"shown": "yes"}, "ellipsoid shown: expected true or false"),
])
def test_bad_overlay_settings_name_the_choices_and_change_nothing(robots, change, message):
    state = ViewerState(robots["course_arm"], overlay=Overlay(True, "force", "rot"))
    with pytest.raises(ManipkitError, match=message):
        state.set_overlay(**change)
    assert state.overlay == Overlay(True, "force", "rot")


# ----------------------------------------------------------------------
# Visual geometry and package:// meshes
# ----------------------------------------------------------------------

STL = """solid tetra
facet normal 0 0 -1
outer loop
vertex 0 0 0
vertex 0.1 0 0
vertex 0 0.1 0
endloop
endfacet
facet normal 0 -1 0
outer loop
vertex 0 0 0
vertex 0 0 0.1
vertex 0.1 0 0
endloop
endfacet
endsolid tetra
"""


def one_mesh_urdf(folder: Path, filename: str, *, scale: str = "1 1 1", origin: str = "0 0 0") -> Path:
    path = folder / "arm.urdf"
    path.write_text(f"""<?xml version="1.0"?>
<robot name="mesh_arm">
  <link name="base_link"/>
  <link name="arm">
    <visual><origin xyz="{origin}"/><geometry><mesh filename="{filename}" scale="{scale}"/></geometry></visual>
  </link>
  <joint name="joint1" type="revolute">
    <parent link="base_link"/><child link="arm"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
</robot>
""")
    return path


def test_example_robot_data_meshes_resolve_to_files(robots):
    for geometry in visual_model(robots["panda"]).geometryObjects:
        assert Path(geometry.meshPath).is_absolute() and Path(geometry.meshPath).is_file(), geometry.meshPath


def test_dae_visuals_are_sent_as_coloured_triangles_and_tinted_by_sending_them_again(robots):
    """Every Panda visual (DAE) reaches meshcat as coloured triangles, never as the file's text; a tint sends
    the same triangles in the collision colour, and untinting them sends them in their own colours again."""
    from manipkit.app.viewer.scene import COLLISION_COLOUR, MeshcatScene
    from manipkit.description.mesh_colours import coloured_triangles

    visual = visual_model(robots["panda"])
    paths = {f"{VISUALS_ROOT}/{g.name}": g for g in visual.geometryObjects}
    with MeshcatScene(visual, robots["panda"].model) as scene:
        assert set(scene.visualizer.coloured) == set(paths)
        for path, geometry in paths.items():
            sent, expected = scene.visualizer.coloured[path], coloured_triangles(geometry.meshPath, geometry.meshColor)
            np.testing.assert_array_equal(sent.vertices, expected.vertices.astype(np.float32))
            np.testing.assert_array_equal(sent.faces, expected.faces)
        shown = {c["path"]: c["object"] for c in meshcat_commands(scene.static_html()) if c["type"] == "set_object"}
        for path in paths:
            assert shown[f"/meshcat/{path}"]["object"]["type"] == "Mesh", path  # not "_meshfile_object" (a file)
            assert [g["type"] for g in shown[f"/meshcat/{path}"]["geometries"]] == ["BufferGeometry"], path
        commands = []
        send = scene.viewer.window.send
        scene.viewer.window.send = lambda command: (commands.append(command), send(command))[1]
        path = f"{VISUALS_ROOT}/panda_link3_0"
        scene.draw({path: np.eye(4)}, tinted={path: True})
        scene.draw({path: np.eye(4)}, tinted={path: False})
    tinted, untinted = (c.object for c in commands if type(c).__name__ == "SetObject" and c.path.lower() == "/meshcat/" + path)
    assert tinted.geometry is untinted.geometry is scene.visualizer.coloured[path]
    red = tuple(int(v * 255) for v in COLLISION_COLOUR[:3])
    assert tinted.material.color == red[0] * 65536 + red[1] * 256 + red[2] and not tinted.material.vertexColors
    assert untinted.material.vertexColors and untinted.material.color == 0xFFFFFF


def test_a_dae_given_a_urdf_colour_keeps_its_files_colours_as_meshcat_drew_it():
    """The Unitree Z1's URDF gives each DAE visual a colour (Pinocchio's overrideMaterial); meshcat's DAE loader
    never applied it (it takes the file's materials, main.min.js's "_meshfile_object"), so the triangles keep the
    file's colours: vertex colours, as coloured_triangles reads them."""
    from manipkit.app.viewer.scene import MeshcatScene
    from manipkit.description.mesh_colours import coloured_triangles

    robot = manipkit.load("z1")
    visual = visual_model(robot)
    assert all(g.overrideMaterial and g.meshPath.lower().endswith(".dae") for g in visual.geometryObjects)
    with MeshcatScene(visual, robot.model) as scene:
        shown = {c["path"]: c["object"] for c in meshcat_commands(scene.static_html()) if c["type"] == "set_object"}
        for geometry in visual.geometryObjects:
            drawn = shown[f"/meshcat/{VISUALS_ROOT}/{geometry.name}"]
            assert drawn["materials"][0]["vertexColors"], geometry.name
            colours = scene.visualizer.coloured[f"{VISUALS_ROOT}/{geometry.name}"].colours
            np.testing.assert_array_equal(colours, coloured_triangles(geometry.meshPath).colours.astype(np.float32))


def test_unresolved_package_mesh_names_the_uri_and_the_places_searched(tmp_path):
    robot = manipkit.load(one_mesh_urdf(tmp_path, "package://no_such_pkg/meshes/arm.stl"))
    with pytest.raises(PackageNotFoundError) as error:
        robot.visual_model()  # missing_meshes="error", the library's default (the viewer draws instead)
    message = str(error.value)
    assert "link 'arm': mesh package://no_such_pkg/meshes/arm.stl cannot be resolved" in message
    assert "package 'no_such_pkg' not found; searched" in message and str(tmp_path) in message
    assert "--package-dir no_such_pkg=DIR" in message and "\n" not in message


def test_mesh_missing_from_a_found_package_says_where_it_looked(tmp_path):
    (tmp_path / "my_pkg").mkdir()
    robot = manipkit.load(one_mesh_urdf(tmp_path, "package://my_pkg/meshes/arm.stl"),
                          package_dirs={"my_pkg": tmp_path / "my_pkg"})
    with pytest.raises(PackageNotFoundError, match=r"resolves to .*my_pkg/meshes/arm.stl, which does not exist"):
        robot.visual_model()


@pytest.mark.parametrize("how", ["package", "relative"])
def test_package_and_relative_meshes_load(tmp_path, how):
    (tmp_path / "my_pkg" / "meshes").mkdir(parents=True)
    mesh = tmp_path / "my_pkg" / "meshes" / "arm.stl"
    mesh.write_text(STL)
    uri = "package://my_pkg/meshes/arm.stl" if how == "package" else "my_pkg/meshes/arm.stl"
    robot = manipkit.load(one_mesh_urdf(tmp_path, uri), package_dirs={"my_pkg": tmp_path / "my_pkg"})
    visual = visual_model(robot)
    assert [Path(g.meshPath) for g in visual.geometryObjects] == [mesh.resolve()]


def test_view_with_an_unresolved_mesh_draws_the_link_and_says_so_in_one_line(tmp_path):
    path = one_mesh_urdf(tmp_path, "package://no_such_pkg/meshes/arm.stl")
    result = run_cli("manipkit", "view", "--robot", path, "--static", tmp_path / "x.html", status=0)
    assert result.stderr == ("warning: mesh_arm: 1 of 1 visual mesh files are missing (the first: link 'arm' mesh "
                             "package://no_such_pkg/meshes/arm.stl: package 'no_such_pkg' not found; searched "
                             + result.stderr.split("not found; searched ")[1])
    assert result.stderr.count("\n") == 1 and "drawn instead: 1 link as lines between joint origins" in result.stderr
    assert (tmp_path / "x.html").is_file()


# ----------------------------------------------------------------------
# Real descriptions without their meshes (issue 25, item 6)
# ----------------------------------------------------------------------

REALWORLD = next((base / "shared" / "realworld" for base in Path(__file__).resolve().parents[2:4]
                  if (base / "shared" / "realworld").is_dir()), Path("/nonexistent"))
needs_realworld = pytest.mark.skipif(not REALWORLD.is_dir(), reason=f"the shared real-world descriptions are not here ({REALWORLD})")


def copy_without_meshes(source: Path, workspace: Path) -> Path:
    """``source`` (a repository folder) copied into ``workspace/src`` without any ``meshes`` folder; returns the copy."""
    import shutil

    target = workspace / "src" / source.name
    shutil.copytree(source, target, ignore=shutil.ignore_patterns("meshes"))
    assert not list(target.rglob("*.dae")) and not list(target.rglob("*.stl")) and not list(target.rglob("*.STL"))
    return target


@pytest.fixture(scope="module")
def abb_without_meshes(tmp_path_factory):
    """ABB IRB 2400 (ros-industrial/abb), whose links have mesh visuals and mesh collisions only."""
    copy = copy_without_meshes(REALWORLD / "ws_ros1" / "src" / "abb", tmp_path_factory.mktemp("abb_ws"))
    return copy / "abb_irb2400_support" / "urdf" / "irb2400.xacro"


@pytest.fixture(scope="module")
def sawyer_without_meshes(tmp_path_factory):
    """Sawyer (RethinkRobotics/sawyer_robot), whose links have primitive collision shapes."""
    copy = copy_without_meshes(REALWORLD / "ws_more" / "src" / "sawyer_robot", tmp_path_factory.mktemp("sawyer_ws"))
    return copy / "sawyer_description" / "urdf" / "sawyer.urdf.xacro"


@needs_realworld
def test_links_without_meshes_or_primitive_collisions_are_drawn_as_lines_between_joint_origins(abb_without_meshes):
    import warnings

    from manipkit.description.meshes import MissingMeshWarning

    robot = manipkit.load(abb_without_meshes)
    with pytest.raises(PackageNotFoundError):
        robot.visual_model()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        visual = visual_model(robot)
    assert [w.category for w in caught] == [MissingMeshWarning]
    assert str(caught[0].message).endswith("drawn instead: 7 links as lines between joint origins")
    assert str(caught[0].message).startswith("abb_irb2400: 7 of 7 visual mesh files are missing (the first: link "
                                             "'base_link' mesh package://abb_irb2400_support/meshes/irb2400/visual/")
    # every line runs from a link's origin to a child joint's origin: its two ends (placement +- length/2 along
    # its z axis) are the origins of the joint's parent and child links, by Robot.transform, at a bent pose
    q = robot.q({name: 0.3 + 0.2 * k for k, name in enumerate(robot.joint_names)})
    origins = {link: robot.transform(robot.root_link, link, q, check_limits=False)[:3, 3] for link in robot.frame_names}
    placements = robot.geometry_placements(visual, q)
    sticks = 0
    for geometry, T in zip(visual.geometryObjects, placements):
        if type(geometry.geometry).__name__ == "Cylinder":
            half = geometry.geometry.halfLength * T[:3, 2]
            ends = [T[:3, 3] - half, T[:3, 3] + half]
            parent = robot.model.frames[geometry.parentFrame].name
            assert np.linalg.norm(ends[0] - origins[parent]) < 1e-12, parent
            assert min(np.linalg.norm(ends[1] - o) for o in origins.values()) < 1e-12, parent
            sticks += 1
    # one line per joint whose origin is away from its parent's (IRB 2400: joint_1 starts at the base's origin)
    offsets = [j for j in robot.joints if np.linalg.norm(origins[j.child] - origins[j.parent]) > 0.04]
    assert sticks >= len(offsets) >= 5


@needs_realworld
def test_links_with_primitive_collision_shapes_are_drawn_by_them(sawyer_without_meshes):
    import warnings
    import xml.etree.ElementTree as ET

    robot = manipkit.load(sawyer_without_meshes)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        visual = visual_model(robot)
    assert len(caught) == 1 and str(caught[0].message).endswith("drawn instead: 10 links by their collision shapes")
    # independent: the description's own <collision> primitives of those links, kind by kind
    root = ET.fromstring(robot.urdf)
    meshless = {link.get("name") for link in root.iter("link") if link.find("visual/geometry/mesh") is not None}
    expected = sorted((link.get("name"), c[0].tag) for link in root.iter("link") if link.get("name") in meshless
                      for c in link.findall("collision/geometry"))
    drawn = sorted((robot.model.frames[g.parentFrame].name, type(g.geometry).__name__.lower())
                   for g in visual.geometryObjects if robot.model.frames[g.parentFrame].name in meshless)
    assert drawn == expected and len(drawn) >= 10


@needs_realworld
def test_view_static_of_a_description_without_meshes_writes_the_view_with_one_warning(abb_without_meshes, tmp_path):
    out = tmp_path / "abb.html"
    result = run_cli("manipkit", "view", "--robot", abb_without_meshes, "--static", out, status=0)
    assert result.stderr.count("\n") == 1 and "7 of 7 visual mesh files are missing" in result.stderr
    assert out.is_file() and f"wrote {out}" in result.stdout


@needs_realworld
def test_reachmap_view_html_without_meshes_prints_its_summary_and_warns_once(abb_without_meshes, tmp_path):
    result = run_cli("manipkit", "reachmap", "--robot", abb_without_meshes, "--samples", "2000", "--orientations", "8",
                     "--voxel", "0.2", "-o", tmp_path / "map.zarr", "--view-html", tmp_path / "map.html", status=0)
    assert result.stderr.count("visual mesh files are missing") == 1 and result.stderr.count("\n") == 1
    assert result.stdout.startswith("reachability map of abb_irb2400: ")
    assert f"wrote {tmp_path / 'map.zarr'}, {tmp_path / 'map.html'}" in result.stdout
    assert (tmp_path / "map.html").is_file()


# ----------------------------------------------------------------------
# Servers
# ----------------------------------------------------------------------


def test_port_in_use_is_a_clear_error():
    with listening_socket() as busy:
        port = busy.getsockname()[1]
        with pytest.raises(ManipkitError, match=f"^port {port} is in use; choose another with --port"):
            ViewerServer(port)


def test_view_on_a_busy_port_exits_2_before_starting_meshcat():
    with listening_socket() as busy:
        port = busy.getsockname()[1]
        result = run_cli("manipkit", "view", "--no-browser", "--port", port)
    assert result.returncode == 2
    assert result.stderr == f"manipkit: error: port {port} is in use; choose another with --port P (or stop the program using it)\n"
    assert "meshcat" not in result.stdout


@pytest.fixture(scope="module")
def view(robots):
    server = open_view(robots["course_arm"], port=0)
    yield server
    server.close()


def request(server, method, path, body=None):
    connection = http.client.HTTPConnection("127.0.0.1", server.port, timeout=10)
    connection.request(method, path, body=None if body is None else json.dumps(body),
                       headers={"Content-Type": "application/json", "X-Manipkit-Token": server.token})
    response = connection.getresponse()
    payload = response.read()
    connection.close()
    return response.status, payload


def test_control_page_is_self_contained(view):
    status, page = request(view, "GET", "/")
    html = page.decode()
    assert status == 200
    for marker in ('id="readout-json"', 'id="frame-a"', 'id="frame-b"', 'id="reset"', 'iframe id="scene"',
                   "window.manipkitTimings", '"shoulder_joint"', view.scene_url):
        assert marker in html, marker
    assert not re.search(r"<(script|link|img)[^>]+(src|href)=", html), "the page must load nothing else (offline)"


def test_update_answers_the_readout_and_draws_the_scene(view, robots):
    robot = robots["course_arm"]
    status, payload = request(view, "POST", "/api/update", {"q": {"shoulder_joint": 0.6, "elbow_joint": -0.3}})
    answer = json.loads(payload)
    assert status == 200
    q = robot.q(shoulder_joint=0.6, elbow_joint=-0.3)
    assert answer["q"] == robot.as_dict(q)
    assert np.array_equal(answer["readout"]["matrix"], robot.transform("base_link", "ee_link", q))
    assert json.loads(answer["readout_json"]) == answer["readout"]
    assert answer["readout_text"] == pose_text(answer["readout"])
    assert view.wait_for_scene()
    expected = ViewerState(robot, q=q).scene_placements(view.visual)
    for path, T in expected.items():
        assert np.array_equal(view.scene.drawn[path], T), path

    status, payload = request(view, "POST", "/api/update", {"frames": ["bicep", "top_wrist"], "reset": True})
    answer = json.loads(payload)
    assert status == 200 and answer["frames"] == ["bicep", "top_wrist"] and set(answer["q"].values()) == {0.0}
    assert view.wait_for_scene()
    assert np.array_equal(view.scene.drawn["manipkit/frame_a"], robot.transform("base_link", "bicep"))


def test_update_with_a_bad_joint_answers_400_and_the_unchanged_state(view):
    status, payload = request(view, "POST", "/api/update", {"q": {"shoulder": 1.0}})
    answer = json.loads(payload)
    assert status == 400 and "has no joint 'shoulder'" in answer["error"]
    assert answer["q"] == view.state.readout()["q"]
    status, payload = request(view, "POST", "/api/update", b"not json".decode())
    assert status == 400


def test_update_toggles_the_ellipsoid_in_the_scene_and_the_answer(view, robots):
    robot = robots["course_arm"]
    status, payload = request(view, "POST", "/api/update",
                              {"reset": True, "frames": ["base_link", "ee_link"], "q": {"elbow_joint": 0.9},
                               "overlay": {"shown": True}})
    answer = json.loads(payload)
    assert status == 200 and answer["overlay"] == {"shown": True, "kind": "velocity", "axes": "trans"}
    q = robot.q(elbow_joint=0.9)
    J = robot.jacobian(q, tip="ee_link", base="base_link")
    assert np.abs(np.array(answer["ellipsoid"]["radii"]) - velocity_ellipsoid(J).radii).max() < 1e-12
    assert "Yoshikawa index (translation rows)" in answer["ellipsoid_text"]
    assert view.wait_for_scene()
    expected = ViewerState(robot, q=q, overlay=Overlay(True)).ellipsoid_placement()
    assert np.abs(view.scene.drawn[ELLIPSOID_PATH] - expected).max() < 1e-12
    assert view.scene.visible[ELLIPSOID_PATH] is True

    status, payload = request(view, "POST", "/api/update", {"overlay": {"kind": "nope"}})
    assert status == 400 and "give velocity or force" in json.loads(payload)["error"]
    status, payload = request(view, "POST", "/api/update", {"overlay": {"colour": "red"}})
    assert status == 400 and "overlay: expected {shown, kind, axes}" in json.loads(payload)["error"]
    status, payload = request(view, "POST", "/api/update", {"overlay": {"shown": False}})
    assert status == 200 and json.loads(payload)["ellipsoid"] is None
    assert view.wait_for_scene() and view.scene.visible[ELLIPSOID_PATH] is False


def test_close_stops_the_meshcat_server_and_frees_the_port(robots):
    server = open_view(robots["course_arm"], port=0)
    port, process = server.port, server.scene._proc
    server.close()
    assert process.poll() is not None
    ViewerServer(port).close()  # the port can be bound again


def test_importing_the_cli_does_not_import_meshcat():
    # a fresh interpreter (a subprocess): what the CLI's import loads is part of its cold start
    code = "import sys, manipkit.app.cli; print(sorted(m for m in ('meshcat', 'pinocchio.visualize', 'manipkit.app.viewer') if m in sys.modules))"
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert result.stdout.strip() == "[]"


# ----------------------------------------------------------------------
# --static
# ----------------------------------------------------------------------


def meshcat_commands(html: str) -> list[dict]:
    import umsgpack

    blobs = re.findall(r"data:application/octet-binary;base64,([A-Za-z0-9+/=]+)", html)
    return [umsgpack.unpackb(base64.b64decode(blob)) for blob in blobs]


def test_static_html_holds_the_scene_at_the_pose(robots, tmp_path):
    robot = robots["course_arm"]
    q = robot.q(shoulder_joint=0.6, top_wrist_joint=1.1)
    path = write_static(robot, tmp_path / "pose.html", frames=("bicep", "ee_link"), q=q)
    html = path.read_text()
    assert "MeshCat.Viewer" in html
    commands = meshcat_commands(html)
    objects = {c["path"] for c in commands if c["type"] == "set_object"}
    transforms = {c["path"]: np.array(c["matrix"]).reshape(4, 4).T for c in commands if c["type"] == "set_transform"}
    expected = ViewerState(robot, frames=("bicep", "ee_link"), q=q).scene_placements(visual_model(robot))
    assert len(expected) == 7 + 2
    for scene_path, T in expected.items():
        assert np.abs(transforms[f"/meshcat/{scene_path}"] - T).max() < 1e-12, scene_path
    for geometry in visual_model(robot).geometryObjects:
        assert f"/meshcat/{VISUALS_ROOT}/{geometry.name}" in objects


def test_static_html_with_the_ellipsoid_shows_it_at_its_placement(robots, tmp_path):
    robot = robots["course_arm"]
    q = robot.q(shoulder_joint=0.6, elbow_joint=0.8)
    overlay = Overlay(True, "force", "trans")
    html = write_static(robot, tmp_path / "e.html", q=q, overlay=overlay).read_text()
    commands = meshcat_commands(html)
    path = f"/meshcat/{ELLIPSOID_PATH}"
    assert any(c["type"] == "set_object" and c["path"] == path for c in commands)
    visible = [c["value"] for c in commands if c["type"] == "set_property" and c["path"] == path]
    assert visible == [False, True]  # created hidden, then shown
    transforms = [np.array(c["matrix"]).reshape(4, 4).T for c in commands if c["type"] == "set_transform" and c["path"] == path]
    expected = ViewerState(robot, q=q, overlay=overlay).ellipsoid_placement()
    assert len(transforms) == 1 and np.abs(transforms[0] - expected).max() < 1e-12


def test_cli_static_with_the_force_ellipsoid_of_the_rotation_rows(tmp_path, robots):
    out = tmp_path / "force.html"
    result = run_cli("manipkit", "view", "--static", out, "--q", "elbow_joint=0.7", "--ellipsoid", "force",
                     "--ellipsoid-axes", "rot")
    assert result.returncode == 0, result.stderr
    assert "and the force ellipsoid at ee_link;" in result.stdout
    commands = meshcat_commands(out.read_text())
    path = f"/meshcat/{ELLIPSOID_PATH}"
    assert [c["value"] for c in commands if c["type"] == "set_property" and c["path"] == path] == [False, True]
    robot = robots["course_arm"]
    expected = ViewerState(robot, q=robot.q(elbow_joint=0.7), overlay=Overlay(True, "force", "rot")).ellipsoid_placement()
    drawn = [np.array(c["matrix"]).reshape(4, 4).T for c in commands if c["type"] == "set_transform" and c["path"] == path]
    assert np.abs(drawn[0] - expected).max() < 1e-12


def test_cli_rejects_an_unknown_ellipsoid_kind(tmp_path):
    result = run_cli("manipkit", "view", "--static", tmp_path / "x.html", "--ellipsoid", "speed")
    assert result.returncode == 2 and result.stderr.count("\n") == 1
    assert "--ellipsoid: invalid choice: 'speed' (choose from 'velocity', 'force')" in result.stderr


def test_cli_static_prints_the_path(tmp_path):
    out = tmp_path / "snap.html"
    result = run_cli("manipkit", "view", "--static", out, "--q", "shoulder_joint=0.3")
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith(f"wrote {out} (") and out.stat().st_size > 100_000


# ----------------------------------------------------------------------
# Jupyter
# ----------------------------------------------------------------------


@pytest.fixture()
def notebook(robots):
    pytest.importorskip("ipywidgets")
    from manipkit.app.viewer import notebook_view

    view = notebook_view(robots["course_arm"])
    yield view
    view.close()


def test_notebook_sliders_drive_the_state_the_scene_and_the_readout(notebook, robots):
    robot = robots["course_arm"]
    assert list(notebook.sliders) == list(COURSE_ARM_JOINTS)
    elbow = notebook.sliders["elbow_joint"]  # continuous: (-pi, pi], the left end one step above -pi
    assert (elbow.min, elbow.max) == (pytest.approx(-math.pi + 2 * math.pi / 1000), math.pi)
    notebook.sliders["elbow_joint"].value = 0.8
    q = robot.q(elbow_joint=0.8)
    assert list(notebook.state.q) == list(q)
    assert np.array_equal(notebook.scene.drawn["manipkit/frame_b"], robot.transform("base_link", "ee_link", q))
    assert html.escape(pose_text(notebook.state.readout())) in notebook.readout.value
    notebook.frame_a.value = "bicep"
    assert notebook.state.frames == ("bicep", "ee_link")
    assert "T_bicep_ee_link" in notebook.readout.value
    notebook.reset_button.click()
    assert notebook.sliders["elbow_joint"].value == 0.0 and list(notebook.state.q) == [0.0] * 5
    assert notebook.scene.url in notebook.scene_widget.value


def test_notebook_ellipsoid_checkbox_draws_the_ellipsoid_and_its_readout(notebook, robots):
    robot = robots["course_arm"]
    assert notebook.ellipsoid.value is False and notebook.ellipsoid_readout.value == ""
    notebook.ellipsoid.value = True
    assert notebook.scene.visible[ELLIPSOID_PATH] is True
    assert "Yoshikawa index (translation rows)" in notebook.ellipsoid_readout.value
    notebook.ellipsoid_axes.value = "rot"
    notebook.sliders["elbow_joint"].value = 0.5
    q = robot.q(elbow_joint=0.5)
    expected = ViewerState(robot, q=q, overlay=Overlay(True, "velocity", "rot")).ellipsoid_placement()
    assert np.abs(notebook.scene.drawn[ELLIPSOID_PATH] - expected).max() < 1e-12
    assert "condition number (rotation rows)" in notebook.ellipsoid_readout.value
    notebook.ellipsoid.value = False
    assert notebook.scene.visible[ELLIPSOID_PATH] is False and notebook.ellipsoid_readout.value == ""


def test_notebook_view_without_ipywidgets_says_how_to_install_it(robots, monkeypatch):
    from manipkit.app.viewer import notebook_view

    monkeypatch.setitem(sys.modules, "ipywidgets", None)  # import ipywidgets -> ImportError
    with pytest.raises(ManipkitError, match="pip install ipywidgets"):
        notebook_view(robots["course_arm"])


# ----------------------------------------------------------------------
# Names that mean something in HTML and JavaScript (issue 15)
# ----------------------------------------------------------------------

# names holding line breaks are refused at load (issue 26): the loadable copy of hostile_names.urdf
HOSTILE = Path(__file__).parent / "bad_inputs" / "outputs" / "hostile_names_one_line.urdf"
HOSTILE_TEXTS = ["</script><script>alert(1)</script>", "<!--<script>", "</SCRIPT >", "a & b &amp; <b>c</b>",
                 "'\"` \\ \u2028\u2029", "]]>", "<![CDATA[", "{{STATE_JSON}}", "{{TOKEN}}"]


class _Scripts(html.parser.HTMLParser):
    """The elements and <script> texts of a page, as the standard library's HTML parser reads them."""

    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.tags, self.scripts, self._open = [], [], None

    def handle_starttag(self, tag, attrs):
        self.tags.append(tag)
        if tag == "script":
            self._open = []

    def handle_data(self, data):
        if self._open is not None:
            self._open.append(data)

    def handle_endtag(self, tag):
        if tag == "script":
            self.scripts.append("".join(self._open))
            self._open = None


def scripts_of(page: str) -> _Scripts:
    parser = _Scripts()
    parser.feed(page)
    parser.close()
    return parser


def test_control_page_keeps_hostile_names_inside_its_json_block():
    from manipkit.app.viewer.server import _page_template, page_html

    initial = {"robot": HOSTILE_TEXTS[0], "frame_choices": HOSTILE_TEXTS, "frames": HOSTILE_TEXTS[:2],
               "sliders": [{"name": text, "type": "revolute", "unit": "rad", "lower": -1, "upper": 1, "value": 0}
                           for text in HOSTILE_TEXTS]}
    page = page_html(initial, token="session-token")
    template = scripts_of(_page_template())
    parsed = scripts_of(page)
    assert parsed.tags == template.tags  # no element added or lost
    assert json.loads(parsed.scripts[0]) == initial  # JSON.parse gives every name back as written
    assert parsed.scripts[1] == template.scripts[1]  # the page's own script is untouched
    assert page.count('<meta name="manipkit-token" content="session-token">') == 1  # a name "{{TOKEN}}" stays a name
    # No "<" at all inside the block: nothing in it can end it or open a comment (<!--), whatever the parser.
    block = page.split('<script id="manipkit-state" type="application/json">', 1)[1].split("</script>", 1)[0]
    assert "<" not in block and ">" not in block and "&" not in block


def test_static_export_of_hostile_names_keeps_them_in_meshcats_commands(tmp_path):
    robot = manipkit.load(HOSTILE)
    path = write_static(robot, tmp_path / "hostile.html")
    page = path.read_text()
    parsed = scripts_of(page)
    assert parsed.tags.count("script") == 3  # meshcat's page: its library, the drawing commands, an empty block
    names = [link for link in robot.frame_names if link not in ("base_link", "ee_link")] + [robot.name]
    outside = re.sub(r"data:application/octet-binary;base64,[A-Za-z0-9+/=]+", "", page)
    assert not any(name in outside for name in names)  # names are only inside the base64 commands
    objects = {c["path"] for c in meshcat_commands(page) if c["type"] == "set_object"}
    assert any("say \"hi\" \\o/ <b>x</b>" in p for p in objects), objects


def test_cli_static_of_hostile_names(tmp_path):
    out = tmp_path / "hostile.html"
    result = run_cli("manipkit", "view", "--robot", HOSTILE, "--static", out)
    assert result.returncode == 0 and result.stderr == "", result.stderr
    assert scripts_of(out.read_text()).tags.count("script") == 3


def test_notebook_error_line_escapes_the_names_in_its_message(notebook, monkeypatch):
    from manipkit.errors import UnknownFrameError

    def refuse(a, b):
        raise UnknownFrameError("no frame '</span><img src=x onerror=alert(1)>' & more")

    monkeypatch.setattr(notebook.state, "set_frames", refuse)
    notebook.frame_a.value = "bicep"  # the picker's change reaches set_frames, which refuses
    assert notebook.error.value == ("<span style='color:#b00'>no frame &#x27;&lt;/span&gt;&lt;img src=x "
                                    "onerror=alert(1)&gt;&#x27; &amp; more</span>")


def test_a_mimic_joint_has_no_slider_and_its_link_moves_with_the_leader(panda):
    # Panda's second finger mimics the first (multiplier 1): one slider, both fingers open by the same distance
    state = ViewerState(panda, frames=("panda_hand", "panda_rightfinger"))
    names = [spec.name for spec in state.sliders()]
    assert "panda_finger_joint1" in names and "panda_finger_joint2" not in names
    state.set_joint("panda_finger_joint1", 0.03)
    # the right finger slides along -y of the hand (URDF axis 0 -1 0 of panda_finger_joint2) by the leader's value
    assert state.readout()["translation"][1] == pytest.approx(-0.03, abs=1e-12)
    visuals = panda.visual_model()
    placements = state.geometry_placements(visuals)
    right = [T for path, T in placements.items() if "rightfinger" in path]
    expected = panda.transform(panda.root_link, "panda_rightfinger", state.q)
    assert right and np.allclose(right[0][:3, 3], expected[:3, 3], atol=1e-9)


# ----------------------------------------------------------------------
# Framing: the floor and the camera (issue 25, item 9; the pictures are in test_app_viewer_browser.py)
# ----------------------------------------------------------------------


def test_the_floor_lies_under_the_base_reaches_the_farthest_corner_in_one_cell_segments():
    from manipkit.app.viewer.scene import floor_lines

    lower, upper, base = np.array([-0.2, -0.1, 0.0]), np.array([0.3, 0.1, 1.3]), np.array([0.05, 0.0, 0.0])
    points, colours, step, half = floor_lines(lower, upper, base)
    reach = np.linalg.norm([0.3 - 0.05, 0.1, 1.3])  # the farthest corner (0.3, +-0.1, 1.3) from the base, by hand
    assert step == 0.2 and half == pytest.approx(1.4) and reach <= half < reach + step
    assert np.all(points[:, 2] == 0.0)  # the base's height, the box's bottom
    assert np.allclose(points[:, :2].min(axis=0), base[:2] - half) and np.allclose(points[:, :2].max(axis=0), base[:2] + half)
    lengths = np.linalg.norm(points[1::2] - points[0::2], axis=1)
    assert np.allclose(lengths, step)  # one cell each: nothing long enough to cross the camera's plane
    assert len(points) == 2 * 2 * 15 * 14 and colours.shape == points.shape
    # the box's bottom below the base lowers the floor; a given height wins
    assert floor_lines(lower - [0, 0, 0.4], upper, base)[0][0, 2] == pytest.approx(-0.4)
    assert floor_lines(lower, upper, base, 0.25)[0][0, 2] == 0.25


def test_the_camera_sees_every_corner_of_the_robots_box_30_deg_from_above(robots):
    from manipkit.app.viewer.scene import CAMERA_ELEVATION_DEG, FRAME_FILL, camera_distance

    state = ViewerState(robots["panda"])
    lower, upper = state.bounds(visual_model(robots["panda"]))
    distance = camera_distance(lower, upper)
    e, a = np.radians(CAMERA_ELEVATION_DEG), np.radians(45.0)
    eye = (lower + upper) / 2 + distance * np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])
    forward = (lower + upper) / 2 - eye
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    slopes = []
    for corner in np.array(np.meshgrid(*zip(lower, upper))).reshape(3, -1).T:
        v = corner - eye
        depth = v @ forward
        slopes.append(max(abs(v @ right), abs(v @ up)) / depth)
    limit = FRAME_FILL * np.tan(np.radians(37.5))
    assert max(slopes) == pytest.approx(limit, rel=1e-9)  # the tightest corner touches the margin, none beyond
    # the box holds the meshes, not only the frame origins: panda_link0's mesh reaches behind the base
    assert lower[0] < state.bounds()[0][0] - 0.05
