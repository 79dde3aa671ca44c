"""Numerical edge cases: link lengths from 1e-6 m to 1e3 m, workspace boundaries, singular configurations.

Scales. Every length of an arm is multiplied by s = 1e-6, 1e-5, ..., 1e3 m (one
scale per decade). FK and the closed-form solvers compose lengths with sines and
cosines of angles that do not depend on s, so every position is s times a
number of order 1 and its rounding error is a few ulps of s. The tests ask for
a relative error (error / s) of at most REL = 1e-12 (measured when this was
written: at most 4e-15 at every scale, for FK, ik_2r, ik_3r, ik_stanford and
ik_elbow alike). Rotations do not scale: their error is asked to be at most
1e-12 rad (measured: at most 1.3e-15).

The solvers' tolerances are absolute (metres, and radians for the rotation
part), so the tests pass tolerances scaled with s: ``tol=1e-12 * s`` for the
planar solvers, ``tol=1e-10 * s`` for numerical IK, and for the decoupled
solvers, whose one ``tol`` bounds both metres and radians, ``1e-12 * max(1,
s)`` (above the ~1e-15 rad rounding of a rotation, and 1e-12 relative in
position for s >= 1; below 1 m the tests check the relative position error
themselves).

Boundaries and singularities: on the boundary of the workspace a 2R target
has exactly one solution, just outside none and the solver says how far;
at a singular configuration (iiwa14 at q = 0, the elbow arm stretched, the
Stanford arm's wrist at theta5 = 0 or pi) every solver returns answers that
reach the target (checked here through an independent forward kinematics:
the closed forms ``fk_2r``, or ``dh_fk`` of the bundled DH tables) or fails
with a reason, never a wrong success. The derivations are in the comments.
"""

from __future__ import annotations

import functools
import math

import numpy as np
import pinocchio as pin
import pytest

import manipkit
from manipkit.closed_form.arm_tables import elbow_dh_table, stanford_dh_table
from manipkit.closed_form.planar import fk_2r, fk_3r
from manipkit.description.sources import bundled_dh_tables
from manipkit.dh import dh_fk, load_dh
from manipkit.ik.decoupled import ik_elbow, ik_stanford
from manipkit.ik.numerical import ik
from manipkit.ik.planar import ik_2r, ik_3r
from manipkit.spatial.rotations import rot_z, rotation_angle_between

SCALES = [10.0**k for k in range(-6, 4)]  # 1e-6 m .. 1e3 m
SCALE_IDS = [f"s={s:g}" for s in SCALES]
FEW_SCALES = [1e-6, 1.0, 1e3]
REL = 1e-12  # relative position accuracy asked of FK and of the closed forms
ROT = 1e-12  # rad

# Planar arms: 2R with unequal links (so the inner boundary is a circle, not a point), 3R as bundled.
L2R = (1.0, 0.6)
L3R = (4.0, 2.0, 1.0)
# Decoupled arms: the bundled defaults, with a shoulder height for the Stanford arm.
STANFORD = {"d1": 0.1, "d2": 0.154, "d6": 0.263, "d3_min": 0.1, "d3_max": 1.0}
ELBOW = {"d1": 0.4, "a2": 0.45, "a3": 0.4, "d6": 0.1}


@functools.cache
def scaled_robot(name: str, s: float, **lengths: float) -> manipkit.kinematics.robot.Robot:
    """A bundled arm with every length argument multiplied by s (xacro args as exact float text)."""
    return manipkit.load(name, **{k: repr(float(v * s)) for k, v in lengths.items()})


def planar_2r(s: float):
    return scaled_robot("planar_2r", s, l1=L2R[0], l2=L2R[1])


def planar_3r(s: float):
    return scaled_robot("planar_3r", s, l1=L3R[0], l2=L3R[1], l3=L3R[2])


def wrapped(angle):
    """Angle difference mapped to [-pi, pi]."""
    return np.pi - np.mod(np.pi - np.asarray(angle), 2.0 * np.pi)


def closed_form_tol(s: float) -> dict:
    tol = 1e-12 * max(1.0, s)
    return {"tol": tol, "singular_tol": tol / 4.0}


def stanford_args(s: float) -> dict:
    return {"d1": STANFORD["d1"] * s, "d2": STANFORD["d2"] * s, "d6": STANFORD["d6"] * s,
            "d3_limits": (STANFORD["d3_min"] * s, STANFORD["d3_max"] * s)}


def elbow_args(s: float) -> dict:
    return {k: v * s for k, v in ELBOW.items()}


def assert_rows_reach(table, rows, T, s):
    """Every row's DH forward kinematics reaches T: position to REL * s, rotation to ROT."""
    T_rows = dh_fk(table, np.asarray(rows))
    position = np.linalg.norm(T_rows[..., :3, 3] - T[:3, 3], axis=-1)
    rotation = np.atleast_1d(rotation_angle_between(T_rows[..., :3, :3], T[:3, :3]))
    assert position.max() <= REL * s, f"position error {position.max() / s:.3g} relative"
    assert rotation.max() <= ROT, f"rotation error {rotation.max():.3g} rad"


def joint_distance(a, b, revolute) -> float:
    d = np.asarray(a, dtype=float) - np.asarray(b, dtype=float)
    return float(np.max(np.where(revolute, np.abs(wrapped(d)), np.abs(d))))


# ==========================================================================
# FK of the URDF against the closed forms, at every scale
# ==========================================================================


@pytest.mark.parametrize("s", SCALES, ids=SCALE_IDS)
def test_planar_2r_urdf_fk_equals_the_closed_form_at_every_scale(s):
    robot = planar_2r(s)
    l1, l2 = (L * s for L in L2R)
    Q = np.random.default_rng(1).uniform(-math.pi, math.pi, size=(100, 2))
    x, y = fk_2r(Q[:, 0], Q[:, 1], l1, l2)
    T_batched = robot.fk(Q, tip="ee_link")
    T_pinocchio = np.array([robot.transform("base_link", "ee_link", q) for q in Q])
    for T in (T_batched, T_pinocchio):
        error = np.max(np.abs(T[:, :3, 3] - np.stack([x, y, np.zeros_like(x)], axis=-1)))
        assert error <= REL * s, f"relative error {error / s:.3g}"
        # the tool frame is turned by q1 + q2 about z
        assert np.abs(T[:, :3, :3] - rot_z(Q[:, 0] + Q[:, 1])).max() <= ROT


@pytest.mark.parametrize("s", SCALES, ids=SCALE_IDS)
def test_planar_3r_urdf_fk_equals_the_closed_form_at_every_scale(s):
    robot = planar_3r(s)
    Q = np.random.default_rng(2).uniform(-math.pi, math.pi, size=(100, 3))
    x, y, phi = fk_3r(Q[:, 0], Q[:, 1], Q[:, 2], *(L * s for L in L3R))
    T = robot.fk(Q, tip="ee_link")
    assert np.max(np.abs(T[:, 0, 3] - x)) <= REL * s and np.max(np.abs(T[:, 1, 3] - y)) <= REL * s
    assert np.max(np.abs(T[:, 2, 3])) <= REL * s
    assert np.max(np.abs(wrapped(np.arctan2(T[:, 1, 0], T[:, 0, 0]) - phi))) <= ROT


@pytest.mark.parametrize("s", SCALES, ids=SCALE_IDS)
def test_stanford_and_elbow_urdfs_equal_their_dh_tables_at_every_scale(s):
    rng = np.random.default_rng(3)
    stanford = scaled_robot("stanford_arm", s, **STANFORD)
    table = stanford_dh_table(**stanford_args(s))
    Q = rng.uniform(-math.pi, math.pi, size=(50, 6))
    Q[:, 2] = rng.uniform(STANFORD["d3_min"], STANFORD["d3_max"], size=50) * s
    assert np.abs(stanford.fk(Q, tip="ee_link")[:, :3, 3] - dh_fk(table, Q)[:, :3, 3]).max() <= REL * s
    elbow = scaled_robot("elbow_arm", s, **ELBOW)
    Q = rng.uniform(-math.pi, math.pi, size=(50, 6))
    assert np.abs(elbow.fk(Q, tip="ee_link")[:, :3, 3] - dh_fk(elbow_dh_table(**elbow_args(s)), Q)[:, :3, 3]).max() <= REL * s


# ==========================================================================
# Closed-form IK round trips, at every scale
# ==========================================================================


@pytest.mark.parametrize("s", SCALES, ids=SCALE_IDS)
def test_ik_2r_round_trip_keeps_relative_accuracy_at_every_scale(s):
    l1, l2 = (L * s for L in L2R)
    rng = np.random.default_rng(4)
    for q1, q2 in rng.uniform(-math.pi, math.pi, size=(100, 2)):
        if abs(math.sin(q2)) < 0.05:  # keep off the boundary circles (q2 = 0, pi): 2 solutions
            continue
        x, y = fk_2r(q1, q2, l1, l2)
        result = ik_2r(x, y, l1, l2, tol=1e-12 * s)
        assert result.count == 2, result.reason
        for row in result.solutions:
            assert math.hypot(*(np.subtract(fk_2r(*row, l1, l2), (x, y)))) <= REL * s
        assert min(np.abs(wrapped(result.solutions - (q1, q2))).max(axis=1)) <= 1e-9


@pytest.mark.parametrize("s", SCALES, ids=SCALE_IDS)
def test_ik_3r_round_trip_keeps_relative_accuracy_at_every_scale(s):
    lengths = tuple(L * s for L in L3R)
    rng = np.random.default_rng(5)
    for q in rng.uniform(-math.pi, math.pi, size=(100, 3)):
        if abs(math.sin(q[1])) < 0.05:
            continue
        x, y, phi = fk_3r(*q, *lengths)
        result = ik_3r(x, y, phi, *lengths, tol=1e-12 * s)
        assert result.count == 2, result.reason
        for row in result.solutions:
            xr, yr, phir = fk_3r(*row, *lengths)
            assert math.hypot(xr - x, yr - y) <= REL * s and abs(wrapped(phir - phi)) <= ROT
        assert min(np.abs(wrapped(result.solutions - q)).max(axis=1)) <= 1e-9


@pytest.mark.parametrize("s", SCALES, ids=SCALE_IDS)
def test_stanford_closed_form_round_trip_through_dh_fk_at_every_scale(s):
    table = stanford_dh_table(**stanford_args(s))
    revolute = np.array([True, True, False, True, True, True])
    rng = np.random.default_rng(6)
    for _ in range(40):
        q = rng.uniform(-3.0, 3.0, size=6)
        q[2] = rng.uniform(0.2, 0.9) * s
        if abs(math.sin(q[1])) < 0.1 or abs(math.sin(q[4])) < 0.1:
            continue  # generic: boom off vertical, wrist off its singularity -> 4 solutions
        T = dh_fk(table, q)
        result = ik_stanford(T, **stanford_args(s), **closed_form_tol(s))
        assert result.count == 4 and result.rejected == 0, result.reason
        assert_rows_reach(table, result.solutions, T, s)
        scaled = q / np.where(revolute, 1.0, s)  # compare d3 relative to s
        assert min(joint_distance(row / np.where(revolute, 1.0, s), scaled, revolute) for row in result.solutions) <= 1e-9


@pytest.mark.parametrize("s", SCALES, ids=SCALE_IDS)
def test_elbow_closed_form_round_trip_through_dh_fk_at_every_scale(s):
    table = elbow_dh_table(**elbow_args(s))
    rng = np.random.default_rng(7)
    for _ in range(40):
        q = rng.uniform(-3.0, 3.0, size=6)
        a2, a3 = ELBOW["a2"], ELBOW["a3"]
        reach = a2 * math.cos(q[1]) + a3 * math.cos(q[1] + q[2])  # wrist centre's distance from joint 1's axis / s
        if abs(math.sin(q[2])) < 0.1 or abs(math.sin(q[4])) < 0.1 or abs(reach) < 0.05:
            continue  # generic: elbow bent, wrist off its singularity, wrist centre off the axis -> 8 solutions
        T = dh_fk(table, q)
        result = ik_elbow(T, **elbow_args(s), **closed_form_tol(s))
        assert result.count == 8 and result.rejected == 0, result.reason
        assert_rows_reach(table, result.solutions, T, s)
        assert min(joint_distance(row, q, np.full(6, True)) for row in result.solutions) <= 1e-9


# ==========================================================================
# Numerical IK on the planar arms, at every scale
# ==========================================================================


@pytest.mark.parametrize("s", SCALES, ids=SCALE_IDS)
@pytest.mark.parametrize("name", ["planar_2r", "planar_3r"])
def test_numerical_position_ik_on_planar_arms_at_every_scale(name, s):
    robot, lengths = (planar_2r(s), L2R) if name == "planar_2r" else (planar_3r(s), L3R)
    fk = fk_2r if name == "planar_2r" else (lambda *a: fk_3r(*a)[:2])
    tol = 1e-10 * s
    for q in np.random.default_rng(8).uniform(-3.0, 3.0, size=(5, len(lengths))):
        target = np.array([*fk(*q, *(L * s for L in lengths)), 0.0])
        result = ik(robot, target, mode="position", tol=tol)
        assert result.success, result.reason
        # checked by the closed form, not by the solver's own residual
        reached = np.array(fk(*result.q, *(L * s for L in lengths)))
        assert np.linalg.norm(reached - target[:2]) <= tol


# ==========================================================================
# The workspace boundary of a 2R arm
# ==========================================================================
# x = l1 c1 + l2 c12, y = l1 s1 + l2 s12 give r^2 = x^2 + y^2 = l1^2 + l2^2 + 2 l1 l2 cos q2, so
# cos q2 = (r^2 - l1^2 - l2^2) / (2 l1 l2). At r = l1 + l2 this is 1: q2 = 0 (one solution, the arm
# stretched toward the target, q1 = atan2(y, x)); at r = |l1 - l2| it is -1: q2 = pi (folded, q1
# points away from the target when l2 > l1, toward it when l1 > l2); beyond either circle |cos q2| > 1
# and there is no real solution. The distance outside is r - (l1 + l2), or |l1 - l2| - r.


@pytest.mark.parametrize("s", SCALES, ids=SCALE_IDS)
@pytest.mark.parametrize("direction", [0.0, 0.7, -2.5, math.pi])
def test_stretched_2r_target_has_exactly_one_solution_at_every_scale(s, direction):
    l1, l2 = (L * s for L in L2R)
    x, y = (l1 + l2) * math.cos(direction), (l1 + l2) * math.sin(direction)
    result = ik_2r(x, y, l1, l2, tol=1e-12 * s)
    assert (result.count, result.labels) == (1, ("straight",)), result.reason
    (q1, q2), = result.solutions
    assert q2 == 0.0 and abs(wrapped(q1 - direction)) <= 1e-12


@pytest.mark.parametrize("s", SCALES, ids=SCALE_IDS)
def test_2r_target_just_outside_has_no_solution_and_says_how_far(s):
    l1, l2 = (L * s for L in L2R)
    gap = 1e-6 * (l1 + l2)
    result = ik_2r(l1 + l2 + gap, 0.0, l1, l2, tol=1e-12 * s)
    assert (result.count, result.side) == (0, "too far") and result.solutions.shape[0] == 0
    assert abs(result.outside_by - gap) <= REL * s
    assert result.reason.startswith("no solution") and "outside by" in result.reason


@pytest.mark.parametrize("s", SCALES, ids=SCALE_IDS)
def test_2r_inner_boundary_folded_has_one_solution_and_just_inside_none(s):
    l1, l2 = (L * s for L in L2R)
    inner = l1 - l2  # l1 > l2: folded, link 1 points at the target and link 2 back from it
    folded = ik_2r(inner * math.cos(1.0), inner * math.sin(1.0), l1, l2, tol=1e-12 * s)
    assert (folded.count, folded.labels) == (1, ("folded",)), folded.reason
    assert np.allclose(folded.solutions, [[1.0, math.pi]], atol=1e-12, rtol=0)
    gap = 1e-6 * inner
    closer = ik_2r(inner - gap, 0.0, l1, l2, tol=1e-12 * s)
    assert (closer.count, closer.side) == (0, "too close")
    assert abs(closer.outside_by - gap) <= REL * s


@pytest.mark.parametrize("s", SCALES, ids=SCALE_IDS)
def test_3r_wrist_point_on_the_outer_circle_has_one_solution(s):
    l1, l2, l3 = (L * s for L in L3R)
    # the wrist point (x - l3 cos phi, y - l3 sin phi) at distance l1 + l2: links 1 and 2 stretched
    phi, direction = 0.4, -1.1
    x = (l1 + l2) * math.cos(direction) + l3 * math.cos(phi)
    y = (l1 + l2) * math.sin(direction) + l3 * math.sin(phi)
    result = ik_3r(x, y, phi, l1, l2, l3, tol=1e-12 * s)
    assert (result.count, result.labels) == (1, ("straight",)), result.reason
    assert np.allclose(result.solutions, [[direction, 0.0, wrapped(phi - direction)]], atol=1e-12, rtol=0)


@pytest.mark.parametrize("s", SCALES, ids=SCALE_IDS)
def test_numerical_ik_at_the_stretched_2r_is_correct(s):
    robot = planar_2r(s)
    l1, l2 = (L * s for L in L2R)
    tol = 1e-10 * s
    target = np.array([(l1 + l2) * math.cos(0.7), (l1 + l2) * math.sin(0.7), 0.0])
    result = ik(robot, target, mode="position", tol=tol)
    # The Jacobian loses rank at q2 = 0 (both columns perpendicular to the arm), so the solver can
    # only stop short: r = (l1 + l2) - l1 l2 q2^2 / (2 (l1 + l2)) + O(q2^4), so a residual <= tol
    # needs |q2| <= sqrt(2 tol (l1 + l2) / (l1 l2)). Either a correct answer or a clear failure.
    if result.success:
        reached = np.array(fk_2r(*result.q, l1, l2))
        assert np.linalg.norm(reached - target[:2]) <= tol
        assert abs(result.q[1]) <= 1.01 * math.sqrt(2.0 * tol * (l1 + l2) / (l1 * l2))
        assert abs(wrapped(result.q[0] - 0.7)) <= 1e-4
    else:
        assert result.reason


@pytest.mark.parametrize("s", SCALES, ids=SCALE_IDS)
def test_numerical_ik_just_outside_the_reach_fails_with_the_distance(s):
    robot = planar_2r(s)
    l1, l2 = (L * s for L in L2R)
    gap = 1e-6 * (l1 + l2)  # 1e4 times the tolerance: no success may be claimed
    target = np.array([(l1 + l2 + gap) * math.cos(-2.0), (l1 + l2 + gap) * math.sin(-2.0), 0.0])
    result = ik(robot, target, mode="position", tol=1e-10 * s)
    assert not result.success
    assert result.reason.startswith("target out of reach")
    # The best the arm can do is stretch toward the target: residual = gap. (With only a few restarts,
    # below s = 1 m a start can stall against the joint-1 limit far from it; the default 50 find it.)
    assert gap * (1.0 - 1e-9) <= result.closest_residuals[0] <= gap * (1.0 + 1e-3)
    # beyond the reach bound (l1 + l2 from joint 1's origin) by the gap: unmet, provably
    assert result.unmet == (("position", pytest.approx(gap, rel=1e-6)),) and result.outside_by == result.unmet[0][1]


# ==========================================================================
# Singular configurations
# ==========================================================================


def assert_correct_or_clear_failure(result, error_at, tol):
    """A success must really reach the target (``error_at(q)`` from an independent FK); a failure must say why."""
    if result.success:
        position, rotation = error_at(np.asarray(result.q))
        assert position <= tol * (1.0 + 1e-6) and rotation <= tol * (1.0 + 1e-6), (position, rotation)
    else:
        assert result.reason and "\n" not in result.reason


@pytest.fixture(scope="module")
def iiwa():
    return manipkit.load("iiwa14")


@pytest.fixture(scope="module")
def iiwa_table():
    return load_dh(bundled_dh_tables()["iiwa14"])


def dh_error(table, T):
    def error_at(q):
        T_q = dh_fk(table, q)
        return float(np.linalg.norm(T_q[:3, 3] - T[:3, 3])), float(rotation_angle_between(T_q[:3, :3], T[:3, :3]))
    return error_at


def test_iiwa_at_zero_is_a_singular_configuration(iiwa):
    # At q = 0 the iiwa stands straight up: joints 1, 3, 5, 7 turn about the same vertical line through
    # ee_link (the same twist: omega = z, v = 0 at the flange), joints 2, 4, 6 about horizontal lines
    # parallel to y at heights h_i below it (omega = y, v = y x (0, 0, h_i) = (h_i, 0, 0)), which span
    # only (v_x, omega_y). So the 6 x 7 Jacobian has rank 3: v_x, omega_y, omega_z.
    data = iiwa.model.createData()
    J = pin.computeFrameJacobian(iiwa.model, data, iiwa.pinocchio_configuration(np.zeros(7)),
                                 iiwa.frame_id("ee_link"), pin.LOCAL_WORLD_ALIGNED)
    assert np.linalg.matrix_rank(J, tol=1e-9) == 3


@pytest.mark.parametrize("start", ["random", "at the singularity", "near it"])
def test_iiwa_ik_to_the_zero_pose_is_correct_or_fails_clearly(iiwa, iiwa_table, start):
    T = iiwa.transform("base_link", "ee_link", np.zeros(7))
    q0 = {"random": None, "at the singularity": np.zeros(7), "near it": np.full(7, 1e-9)}[start]
    result = ik(iiwa, T, q0=q0, tol=1e-10)
    assert_correct_or_clear_failure(result, dh_error(iiwa_table, T), 1e-10)


@pytest.mark.parametrize("eps", [1e-12, 1e-8, 1e-4])
def test_iiwa_ik_next_to_the_zero_singularity_is_correct_or_fails_clearly(iiwa, iiwa_table, eps):
    T = iiwa.transform("base_link", "ee_link", np.full(7, eps))
    result = ik(iiwa, T, tol=1e-10)
    assert_correct_or_clear_failure(result, dh_error(iiwa_table, T), 1e-10)


@pytest.mark.parametrize("s", FEW_SCALES, ids=[f"s={s:g}" for s in FEW_SCALES])
def test_elbow_arm_stretched_straight_has_four_solutions_each_correct(s):
    # theta3 = 0 puts the wrist centre at distance a2 + a3 from the shoulder (the outer sphere): the
    # planar 2R of links 2, 3 has the single solution "straight", times front/back and the two wrist flips.
    table = elbow_dh_table(**elbow_args(s))
    q = np.array([0.5, 0.4, 0.0, 0.3, 0.9, 0.2])
    T = dh_fk(table, q)
    result = ik_elbow(T, **elbow_args(s), **closed_form_tol(s))
    assert result.count == 4 and all("arm straight" in label for label in result.labels), result.reason
    assert_rows_reach(table, result.solutions, T, s)
    assert min(joint_distance(row, q, np.full(6, True)) for row in result.solutions) <= 1e-9


@pytest.mark.parametrize("s", FEW_SCALES, ids=[f"s={s:g}" for s in FEW_SCALES])
def test_elbow_arm_wrist_centre_just_beyond_reach_has_no_solution_and_says_by_how_much(s):
    # Move the target so that the wrist centre o_c = o - d6 R z lies 1e-6 (a2 + a3) beyond the outer sphere.
    args = elbow_args(s)
    table = elbow_dh_table(**args)
    T = dh_fk(table, [0.5, 0.4, 0.0, 0.3, 0.9, 0.2])
    shoulder = np.array([0.0, 0.0, args["d1"]])
    wrist = T[:3, 3] - args["d6"] * T[:3, 2]
    gap = 1e-6 * (args["a2"] + args["a3"])
    T_out = T.copy()
    T_out[:3, 3] += gap * (wrist - shoulder) / np.linalg.norm(wrist - shoulder)
    result = ik_elbow(T_out, **args, **closed_form_tol(s))
    assert result.count == 0 and result.reason.startswith("no solution") and "outside by" in result.reason


@pytest.mark.parametrize("s", FEW_SCALES, ids=[f"s={s:g}" for s in FEW_SCALES])
@pytest.mark.parametrize("theta5", [0.0, math.pi])
def test_stanford_wrist_singularity_gives_a_family_that_all_reaches_the_pose(s, theta5):
    # With the wrist rows, R_3^6 = Rz(theta4) Ry(theta5) Rz(theta6). At theta5 = 0 it is
    # Rz(theta4 + theta6): only the sum is fixed, so (t, theta6_row - t) reaches the pose for every t.
    # At theta5 = pi, Rz(theta4) Ry(pi) Rz(theta6) = Rz(theta4 - theta6) Ry(pi): only the difference
    # is fixed, and (t, theta6_row + t) does. The solver returns one row with theta4 = 0 for it.
    args = stanford_args(s)
    table = stanford_dh_table(**args)
    q = np.array([0.4, 0.8, 0.6 * s, 0.3, theta5, -0.2])
    T = dh_fk(table, q)
    result = ik_stanford(T, **args, **closed_form_tol(s))
    assert result.singular and 3 in result.free_joints, result.reason
    singular_rows = [row for row, label in zip(result.solutions, result.labels) if "wrist singular" in label]
    assert len(singular_rows) == 1
    row = singular_rows[0]
    assert row[3] == 0.0 and abs(abs(row[4]) - theta5) <= 1e-12
    sign = -1.0 if theta5 == 0.0 else 1.0
    family = [np.array([*row[:3], t, row[4], row[5] + sign * t]) for t in (-2.0, -0.3, 0.3, 1.0, 2.5)]
    assert_rows_reach(table, result.solutions, T, s)
    assert_rows_reach(table, family, T, s)


@pytest.mark.parametrize("theta5", [1e-13, 1e-11, 1e-9, 1e-6, math.pi - 1e-9])
def test_stanford_near_the_wrist_singularity_every_returned_row_is_correct(theta5):
    # Within singular_tol of the singular set the solver answers with the singular representative
    # (theta5 = 0), which misses the pose by about theta5 rad: still within tol. Outside it, the two
    # ZYZ branches: theta4 and theta6 are ill-conditioned there (error ~ 1e-16 / sin theta5) but
    # their sum is not, and every row is checked through the table's FK before it is returned.
    table = stanford_dh_table()
    T = dh_fk(table, [0.4, 0.8, 0.6, 0.3, theta5, -0.2])
    result = ik_stanford(T, tol=1e-9, singular_tol=1e-10)
    assert result.count >= 3 and result.rejected == 0, result.reason
    T_rows = dh_fk(table, result.solutions)
    assert np.linalg.norm(T_rows[:, :3, 3] - T[:3, 3], axis=-1).max() <= 1e-9
    assert np.max(rotation_angle_between(T_rows[:, :3, :3], T[:3, :3])) <= 1e-9


@pytest.mark.parametrize(
    "name, q",
    [
        ("stanford_arm", [0.4, 0.8, 0.6, 0.3, 0.0, -0.2]),  # wrist singular: theta5 = 0
        ("stanford_arm", [0.4, 0.8, 0.6, 0.3, math.pi, -0.2]),  # wrist singular: theta5 = pi
        ("elbow_arm", [0.5, 0.4, 0.0, 0.3, 0.9, 0.2]),  # arm straight: theta3 = 0
        ("elbow_arm", [0.5, 0.4, 0.0, 0.3, 0.0, 0.2]),  # arm straight and wrist singular
        ("elbow_arm", [0.0, math.pi / 2, 0.0, 0.3, 0.9, 0.2]),  # wrist centre on joint 1's axis
    ],
)
def test_numerical_ik_at_decoupled_singularities_is_correct_or_fails_clearly(name, q):
    robot = manipkit.load(name)
    table = stanford_dh_table() if name == "stanford_arm" else elbow_dh_table()
    T = robot.transform("base_link", "ee_link", np.array(q))
    assert np.abs(T - dh_fk(table, q)).max() <= 1e-12  # the table is an independent FK of the URDF
    for q0 in (None, np.array(q)):
        result = ik(robot, T, q0=q0, tol=1e-10)
        assert_correct_or_clear_failure(result, dh_error(table, T), 1e-10)
