"""A 7R arm's ranked set across its self-motion (manipkit.ik.redundant), checked against independent sources.

Every solution lands by Pinocchio's own FK (``pin.forwardKinematics`` on the robot's model); the feasible
intervals are checked against a dense sweep written here, which solves each value with the other path of the
dispatcher (``manipkit.ik(..., lock=...)`` per value, refined on the true chain, or ``arm_angle=`` per value)
and counts the distinct in-limit solutions; the ranking against the criterion computed here (limits from the
joints' own limits, manipulability from Pinocchio's Jacobian).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import manipkit
from manipkit.errors import IKOptionError
from manipkit.ik.redundant import redundancy

REALWORLD = next((base / "shared" / "realworld" for base in Path(__file__).resolve().parents[2:4]
                  if (base / "shared" / "realworld").is_dir()), Path("/nonexistent"))
FR3 = REALWORLD / "ws_more/src/franka_description/robots/fr3/fr3.urdf.xacro"
XARM = REALWORLD / "ws_more/src/xarm_ros2/xarm_description/urdf/xarm_device.urdf.xacro"


def arm(name):
    if name == "fr3":
        if not FR3.is_file():
            pytest.skip("the shared real-world workspace is not here")
        return manipkit.load(FR3)
    if name == "xarm7 (xacro)":
        if not XARM.is_file():
            pytest.skip("the shared real-world workspace is not here")
        return manipkit.load(XARM, dof="7", robot_type="xarm")
    return manipkit.load(name)


def pinocchio_pose(robot, base, tip, q):
    """T_base_tip by Pinocchio itself (frames placed by forwardKinematics + updateFramePlacements)."""
    model = robot.model
    data = model.createData()
    pin.forwardKinematics(model, data, robot.pinocchio_configuration(q))
    pin.updateFramePlacements(model, data)
    placement = lambda name: data.oMf[model.getFrameId(robot.frame(name))].homogeneous  # noqa: E731
    return np.linalg.inv(placement(base)) @ placement(tip)


def pose_error(A, B):
    R = A[:3, :3].T @ B[:3, :3]
    sine = 0.5 * np.linalg.norm([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    return float(np.linalg.norm(A[:3, 3] - B[:3, 3])), float(math.atan2(sine, (np.trace(R) - 1.0) / 2.0))


def target_of(robot, q):
    chain = robot.chain("base_link", "ee_link")
    return pinocchio_pose(robot, "base_link", "ee_link", chain.full(q))


def independent_counts(robot, T, parameter, values):
    """Per value: distinct in-limit solutions (angles compared modulo 2 pi) of the dispatcher's per-value path."""
    chain = robot.chain("base_link", "ee_link")
    counts = []
    for v in values:
        if parameter.kind == "arm_angle":
            result = manipkit.ik(robot, T, all=True, arm_angle=float(v))
        else:
            result = manipkit.ik(robot, T, all=True, lock={parameter.name: float(v)})
        rows = [q[chain.columns] for q, ok in zip(result.solutions, result.within_limits) if ok]
        distinct = []
        for q in rows:
            wrapped = np.angle(np.exp(1j * q))
            if not any(np.abs(np.angle(np.exp(1j * (wrapped - d)))).max() < 1e-6 for d in distinct):
                distinct.append(wrapped)
        counts.append(len(distinct))
    return np.array(counts)


CASES = {  # arm -> a configuration inside the limits whose pose has a long self-motion
    "panda": [0.2, -0.4, 0.3, -2.0, 0.2, 1.6, 0.7],
    "iiwa14": [0.3, 0.5, -0.2, -1.2, 0.4, 0.8, 0.1],
    "fr3": [0.2, -0.4, 0.3, -2.0, 0.2, 1.6, 0.7],
    "xarm7": [0.3, 0.4, -0.2, 1.0, 0.3, 0.6, 0.2],
    "xarm7 (xacro)": [0.3, 0.4, -0.2, 1.0, 0.3, 0.6, 0.2],
}


@pytest.mark.parametrize("name", list(CASES))
def test_the_ranked_set_lands_spans_the_sweep_and_is_ranked(name):
    robot = arm(name)
    chain = robot.chain("base_link", "ee_link")
    T = target_of(robot, CASES[name])
    parameter = redundancy(robot, "base_link", "ee_link")
    expected = ("arm_angle", "psi") if name == "iiwa14" else ("lock", chain.joint_names[-1])
    assert (parameter.kind, parameter.name) == expected
    count = 48
    answer = manipkit.ik(robot, T, all=True, count=count)
    # at least 16, distinct, each landing by Pinocchio to 1e-10, inside the limits
    assert len(answer.solutions) == count >= 16
    Q = answer.solutions[:, chain.columns]
    assert len({tuple(np.round(q, 9)) for q in Q}) == len(Q)
    for q in answer.solutions:
        position, rotation = pose_error(pinocchio_pose(robot, "base_link", "ee_link", q), T)
        assert position < 1e-10 and rotation < 1e-10
    assert np.all(Q >= chain.lower - 1e-12) and np.all(Q <= chain.upper + 1e-12)
    if parameter.kind == "lock":  # the row holds the parameter's value
        assert np.allclose(Q[:, parameter.column], answer.parameter_values, atol=0)
    # the dense sweep written here
    step = 0.02 if parameter.kind == "lock" and parameter.upper - parameter.lower < 7 else 0.04
    grid = np.arange(parameter.lower, parameter.upper + 1e-12, step)
    counts = independent_counts(robot, T, parameter, grid)
    intervals = answer.intervals
    inside = np.array([sum(low <= v <= high for _, low, high in intervals) for v in grid])
    ends = np.array([e for _, low, high in intervals for e in (low, high)])
    near_end = np.array([np.min(np.abs(ends - v)) <= step for v in grid])
    assert np.all((inside == counts) | near_end), grid[(inside != counts) & ~near_end]
    assert np.mean(inside == counts) > 0.8
    # the values span >= 90 % of each connected piece of the sweep's feasible set
    feasible = counts > 0
    pieces, i = [], 0
    while i < len(grid):
        if feasible[i]:
            j = i
            while j + 1 < len(grid) and feasible[j + 1]:
                j += 1
            pieces.append((grid[i], grid[j]))
            i = j + 1
        else:
            i += 1
    total = sum(b - a for a, b in pieces)
    covered = 0.0
    for a, b in pieces:
        held = answer.parameter_values[(answer.parameter_values >= a - step) & (answer.parameter_values <= b + step)]
        covered += min(b, held.max()) - max(a, held.min()) if len(held) else 0.0
    assert total > 0.5 and covered >= 0.9 * total
    # ranked by the distance to the limits, computed here from the joints' own limits
    lower = np.array([j.lower for j in chain.joints])
    upper = np.array([j.upper for j in chain.joints])
    margin = (np.minimum(Q - lower, upper - Q) / (upper - lower)).min(axis=1)
    assert margin == pytest.approx(answer.scores, abs=1e-12)
    assert np.all(np.diff(margin) <= 1e-12)
    assert answer.ranked_by == "limits" and set(answer.labels) <= {b for b, _, _ in intervals}


def test_the_default_count_is_sixteen_and_manipulability_ranks_by_pinocchio():
    robot = manipkit.load("panda")
    T = target_of(robot, CASES["panda"])
    answer = manipkit.ik(robot, T, all=True)
    assert answer.solver == "ik.redundant" and len(answer.solutions) == 16 and answer.method == "closed_form"
    ranked = manipkit.ik(robot, T, all=True, rank="manipulability", count=10)
    model, data = robot.model, robot.model.createData()
    frame = model.getFrameId(robot.frame("ee_link"))
    values = []
    for q in ranked.solutions:
        J = pin.computeFrameJacobian(model, data, robot.pinocchio_configuration(q), frame, pin.LOCAL_WORLD_ALIGNED)
        J = J[:, robot.chain("base_link", "ee_link").columns]
        values.append(math.sqrt(max(np.linalg.det(J @ J.T), 0.0)))
    assert np.array(values) == pytest.approx(ranked.scores, rel=1e-9)
    assert np.all(np.diff(values) <= 1e-12)


def test_with_a_lock_or_an_arm_angle_the_answer_is_as_before():
    robot = manipkit.load("panda")
    T = target_of(robot, CASES["panda"])
    locked = manipkit.ik(robot, T, all=True, lock={"panda_joint7": 0.7})
    assert locked.solver.startswith("ik.chain_ik") and not locked.parameter and locked.count == 8
    iiwa = manipkit.load("iiwa14")
    at = manipkit.ik(iiwa, target_of(iiwa, CASES["iiwa14"]), all=True, arm_angle=0.3)
    assert at.solver.startswith("ik.chain_ik") and not at.parameter


def test_bad_options_are_refused_in_one_line():
    robot = manipkit.load("panda")
    T = target_of(robot, CASES["panda"])
    for options in ({"count": 0}, {"count": 10**9}, {"rank": "speed"}, {"rank": "clearance"}):
        with pytest.raises(IKOptionError) as error:
            manipkit.ik(robot, T, all=True, **options)
        assert "\n" not in str(error.value)
    with pytest.raises(IKOptionError, match="ranked set"):  # not a 7R arm
        ur5 = manipkit.load("ur5")
        manipkit.ik(ur5, ur5.transform("base_link", "tool0", [0.1] * 6), tip="tool0", all=True, count=4)


def test_clearance_ranks_by_the_checker_and_marks_each_row():
    from manipkit.kinematics.collisions import CollisionChecker

    robot = manipkit.load("panda")
    T = target_of(robot, CASES["panda"])
    checker = CollisionChecker(robot)
    answer = manipkit.ik(robot, T, all=True, rank="clearance", count=6, collisions=checker)
    distances = []
    for q in answer.solutions:
        report = checker.report(q)
        distances.append(math.inf if report.min_distance is None else report.min_distance.distance)
    assert np.array(distances) == pytest.approx(answer.scores) and list(answer.clearance) == pytest.approx(distances)
    assert np.all(np.diff(distances) <= 1e-12) and len(answer.collides) == len(answer.solutions)


def test_a_chain_with_no_closed_form_per_value_gets_no_ranked_set():
    ur5 = manipkit.load("ur5")
    assert redundancy(ur5, "base_link", "tool0") is None


def test_a_locked_joint_in_the_middle_is_solved_per_value_by_the_dispatcher_with_lock():
    # the rule picks an end joint on every arm here; a middle joint takes the other path (ik with lock= per
    # value), which a general 6R solver in the dispatcher serves: the iiwa14 with joint 3 locked is a 6R arm
    from manipkit.ik.redundant import Redundancy, ranked_set

    robot = manipkit.load("iiwa14")
    chain = robot.chain("base_link", "ee_link")
    T = target_of(robot, CASES["iiwa14"])
    joint = chain.joints[2]
    parameter = Redundancy("lock", joint.name, joint.lower, joint.upper, 2, "spherical wrist, two intersecting")
    answer = ranked_set(robot, T, "base_link", "ee_link", solvers=(manipkit.ik, manipkit.ik_many),
                        parameter=parameter, count=8, step=0.25)
    assert len(answer.solutions) == 8 and answer.parameter == "iiwa_joint_3 (locked)"
    Q = answer.solutions[:, chain.columns]
    assert np.allclose(Q[:, 2], answer.parameter_values, atol=0)
    for q in answer.solutions:
        position, rotation = pose_error(pinocchio_pose(robot, "base_link", "ee_link", q), T)
        assert position < 1e-10 and rotation < 1e-10
    assert np.all(Q >= chain.lower - 1e-12) and np.all(Q <= chain.upper + 1e-12)
    # every interval end inside the parameter's range is a limit crossing: just outside it, the branch's
    # solution (by the per-value path) breaks a limit or does not exist, and just inside it, it is feasible
    checked = 0
    for branch, low, high in answer.intervals:
        for end, outward in ((low, -1e-5), (high, 1e-5)):
            if joint.lower + 1e-6 < end < joint.upper - 1e-6:
                outside = manipkit.ik(robot, T, all=True, lock={joint.name: end + outward})
                rows = [ok for label, ok in zip(outside.labels, outside.within_limits) if label == branch]
                assert not any(rows), (branch, end)
                inside = manipkit.ik(robot, T, all=True, lock={joint.name: end - outward})
                assert any(ok for label, ok in zip(inside.labels, inside.within_limits) if label == branch)
                checked += 1
    assert checked >= 2


def test_no_solution_says_whether_the_pose_is_out_of_reach_or_the_limits_forbid_it():
    from manipkit.spatial.transforms import transform_from_xyz_rpy

    robot = manipkit.load("panda")
    far = manipkit.ik(robot, transform_from_xyz_rpy([2.0, 0.0, 0.0], [0.0, 0.0, 0.0]), all=True)
    assert not far.success and far.failure.kind == "unreachable" and "no branch reaches" in far.reason
    # an iiwa14 pose whose shoulder-to-wrist distance needs |joint 4| = 2.5 rad (an SRS arm's elbow angle is fixed
    # by that distance), past its limit of 2.0944: reachable, but every solution breaks a limit
    iiwa = manipkit.load("iiwa14")
    chain = iiwa.chain("base_link", "ee_link")
    assert chain.upper[3] < 2.5
    T = chain.fk(np.array([0.0, 0.3, 0.0, 2.5, 0.0, 1.0, 0.3]))
    blocked = manipkit.ik(iiwa, T, all=True)
    assert not blocked.success and blocked.failure.kind == "joint_limits", blocked.reason
    assert "breaks a joint limit" in blocked.reason


def test_collision_free_drops_the_rows_in_collision_and_says_so_when_none_is_left():
    from manipkit.kinematics.collisions import CollisionChecker

    robot = manipkit.load("panda")
    T = target_of(robot, CASES["panda"])
    checker = CollisionChecker(robot)
    free = manipkit.ik(robot, T, all=True, count=6, collision_free=checker)
    assert free.success and not any(free.collides)
    assert len(free.parameter_values) == len(free.scores) == len(free.labels) == len(free.solutions)
    # a floor above the arm's base: every configuration is in collision with it
    floored = CollisionChecker(robot, floor=0.3)
    blocked = manipkit.ik(robot, T, all=True, count=4, collision_free=floored)
    assert not blocked.success and blocked.failure.kind == "collision"
    assert len(blocked.parameter_values) == len(blocked.scores) == 0


def test_the_xarm7s_branches_are_its_closed_forms_not_row_positions():
    # the xArm7's locked 6R arm is its family's only within the tolerance: its ranked set used to follow each value's
    # answer by row position ("row 1", "row 2", ...); now by the closed form's branch slots, as the Panda's
    from manipkit.ik.chain_ik import slot_labels
    from manipkit.ik.families import chain_family

    robot = manipkit.load("xarm7")
    chain = robot.chain("base_link", "ee_link")
    sub = robot.chain("base_link", chain.joints[6].parent)
    family = chain_family(sub)
    assert family.snap
    answer = manipkit.ik(robot, target_of(robot, CASES["xarm7"]), all=True)
    assert len(answer.solutions) == 16
    assert set(answer.labels) <= set(slot_labels(family)) and {b for b, _, _ in answer.intervals} <= set(slot_labels(family))
    batch = manipkit.ik_many(robot, sub.fk(sub.sample(3, seed=2)), base=sub.base, tip=sub.tip)
    assert batch.labels[:8] == slot_labels(family)


def test_a_calibrated_srs_arm_s_rows_are_polished_on_the_true_chain():
    # an iiwa14 whose joint 6 sits 2e-5 m off the wrist centre: SRS only within the family tolerance, so the arm
    # angle's closed form solves the nearest ideal arm and every row is polished on the true chain (seven joints,
    # least-norm steps of the one polisher) before it is checked
    from manipkit.ik.families import chain_family
    from manipkit.kinematics.robot import Robot

    text = manipkit.load("iiwa14").urdf
    written = 'rpy="1.5707963267948966 0 0" xyz="0 0 0.2155"'
    assert text.count(written) == 2  # joints 4 and 6
    at = text.rindex(written)
    robot = Robot.from_urdf(text[:at] + 'rpy="1.5707963267948966 0 0" xyz="2e-05 0 0.2155"' + text[at + len(written):])
    chain = robot.chain("base_link", "ee_link")
    family = chain_family(chain)
    assert family.kind == chain_family(manipkit.load("iiwa14").chain("base_link", "ee_link")).kind and family.snap
    T = target_of(robot, CASES["iiwa14"])
    answer = manipkit.ik(robot, T, all=True)
    assert answer.parameter == "psi (arm angle)" and len(answer.solutions) == 16
    for q in answer.solutions:
        position, rotation = pose_error(pinocchio_pose(robot, "base_link", "ee_link", q), T)
        assert position < 1e-10 and rotation < 1e-10
