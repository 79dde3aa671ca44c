"""Every isolated IK solution of a general 6R chain (manipkit.ik.general6r) through the one dispatcher and the CLI.

Arms: the real UFactory xArm6 of ../shared/realworld/ws_more (axes 4, 5, 6 miss
meeting by 51 mm, 5 and 6 by 38 mm: no closed form), loaded as its users load
it (skipped when the workspace is not here); random DH arms written to URDF by
manipkit.dh.urdf_from_dh. (The Kinova Jaco2 j2n6 is not in ../shared/realworld.)
Every row is checked by Pinocchio's forward kinematics (``robot.transform``),
completeness against manipkit's own numerical IK from many random starts.

``MANIPKIT_GENERAL6R_POSES=10000`` (and ``MANIPKIT_GENERAL6R_COMPLETENESS=200``)
runs the long versions of the two xArm6 sweeps (minutes; the project has no
slow-test marker and ``make fuzz`` runs only tests/test_fuzz.py).
"""

import json
import math
import os
from pathlib import Path

import numpy as np
import pytest
from cli_helper import run_cli

import manipkit
from manipkit.dh import DHRow, DHTable, urdf_from_dh
from manipkit.errors import IKOptionError
from manipkit.ik.general6r import general_ik, general_solves
from manipkit.kinematics.robot import Robot

REALWORLD = next((base / "shared" / "realworld" for base in Path(__file__).resolve().parents[2:4]
                  if (base / "shared" / "realworld").is_dir()), Path("/nonexistent"))
XARM = REALWORLD / "ws_more" / "src" / "xarm_ros2" / "xarm_description" / "urdf" / "xarm_device.urdf.xacro"
needs_xarm = pytest.mark.skipif(not XARM.is_file(), reason=f"the shared real-world workspace is not here ({XARM})")
POSES = int(os.environ.get("MANIPKIT_GENERAL6R_POSES", "1000"))
COMPLETENESS = int(os.environ.get("MANIPKIT_GENERAL6R_COMPLETENESS", "20"))


@pytest.fixture(scope="module")
def xarm6():
    return manipkit.load(XARM, dof="6", robot_type="xarm")


def wrapped(a):
    return np.pi - np.mod(np.pi - np.asarray(a), 2 * np.pi)


def pinocchio_miss(robot, base, tip, rows, T) -> float:
    """The largest entry of |T_reached - T| over the rows, by Pinocchio (robot.transform)."""
    return max((float(np.abs(robot.transform(base, tip, q, check_limits=False) - T).max()) for q in rows), default=0.0)


def random_dh_robot(seed: int) -> Robot:
    rng = np.random.default_rng(seed)
    rows = [DHRow(float(rng.uniform(-0.4, 0.4)), float(rng.uniform(-math.pi, math.pi)), float(rng.uniform(-0.4, 0.4)),
                  0.0, qlim=(-math.pi, math.pi)) for _ in range(6)]
    return Robot.from_urdf(urdf_from_dh(DHTable(rows, "standard", f"random{seed}")))


@needs_xarm
def test_xarm6_is_named_general_6r_and_auto_uses_the_elimination(xarm6):
    chain = xarm6.chain("base_link", "ee_link")
    assert general_solves(chain)
    q = chain.sample(1, seed=4)[0]
    result = manipkit.ik(xarm6, chain.fk(q), all=True)
    assert (result.method, result.arm_family, result.solver) == ("algebraic", "general 6R", "ik.general6r")
    assert np.abs(wrapped(result.solutions - q)).max(axis=1).min() < 1e-7
    one = manipkit.ik(xarm6, chain.fk(q), q0=q)  # all=False: the in-limit solution nearest q0 is q itself
    assert one.method == "algebraic" and len(one.solutions) == 1
    assert np.abs(wrapped(one.q - q)).max() < 1e-7 and bool(one.within_limits[0])


@needs_xarm
def test_xarm6_every_solution_lands_and_the_generating_configuration_is_found(xarm6):
    chain = xarm6.chain("base_link", "ee_link")
    Q = chain.sample(POSES, seed=21)
    found, worst, rows = 0, 0.0, 0
    for q in Q:
        T = chain.fk(q)
        result = general_ik(chain, T)
        rows += len(result.solutions)
        worst = max(worst, pinocchio_miss(xarm6, "base_link", "ee_link", result.solutions, T))
        if len(result.solutions) and np.abs(wrapped(result.solutions - q)).max(axis=1).min() < 1e-7:
            found += 1
    assert worst < 1e-10
    assert found >= 0.999 * POSES, f"{POSES - found} of {POSES} generating configurations missing"
    assert rows <= 16 * POSES


def _numerical_solutions(robot, T, restarts, seed):
    found = manipkit.ik(robot, T, method="numerical", all=True, restarts=restarts, seed=seed, tol=1e-10)
    return found.solutions


@needs_xarm
def test_xarm6_no_solution_found_by_a_many_start_search_is_missing(xarm6):
    chain = xarm6.chain("base_link", "ee_link")
    missing, searched = [], 0
    for k, q in enumerate(chain.sample(COMPLETENESS, seed=5)):
        T = chain.fk(q)
        every = general_ik(chain, T).solutions
        for row in _numerical_solutions(xarm6, T, 200, k):
            searched += 1
            if not len(every) or np.abs(wrapped(every - row)).max(axis=1).min() > 1e-6:
                missing.append((k, row))
    assert searched >= COMPLETENESS  # the search found something to compare
    assert not missing, f"{len(missing)} of {searched} numerically found solutions missing, e.g. {missing[0]}"


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_random_dh_arms_through_the_dispatcher(seed):
    robot = random_dh_robot(seed)
    chain = robot.chain("base_link", "ee_link")
    assert general_solves(chain)
    found, worst = 0, 0.0
    Q = chain.sample(100, seed=seed)
    for q in Q:
        T = chain.fk(q)
        result = manipkit.ik(robot, T, all=True)
        assert result.method == "algebraic"
        worst = max(worst, pinocchio_miss(robot, "base_link", "ee_link", result.solutions, T))
        found += bool(len(result.solutions)) and np.abs(wrapped(result.solutions - q)).max(axis=1).min() < 1e-7
    assert worst < 1e-10 and found == len(Q)
    T = chain.fk(Q[0])
    every = manipkit.ik(robot, T, all=True).solutions
    for row in _numerical_solutions(robot, T, 200, seed):
        assert np.abs(wrapped(every - row)).max(axis=1).min() < 1e-6


def _det_j(chain, q):
    return float(np.linalg.det(chain.jacobian(q)))


@needs_xarm
def test_xarm6_double_root_at_a_singular_configuration_is_kept(xarm6):
    """A configuration with det J = 0 inside the limits (found by bisection on joint 3): its pose has a double root
    there, and just beside it two close real roots; both must be in the answer (ssik lost such roots, #528)."""
    chain = xarm6.chain("base_link", "ee_link")
    rng = np.random.default_rng(8)
    for _ in range(50):
        q = chain.sample(1, seed=int(rng.integers(1 << 30)))[0]
        grid = np.linspace(chain.lower[2] + 0.01, chain.upper[2] - 0.01, 121)
        values = [_det_j(chain, np.r_[q[:2], t, q[3:]]) for t in grid]
        change = np.flatnonzero(np.sign(values[:-1]) != np.sign(values[1:]))
        if len(change):
            break
    lo, hi = grid[change[0]], grid[change[0] + 1]
    sign = np.sign(_det_j(chain, np.r_[q[:2], lo, q[3:]]))
    for _ in range(70):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if np.sign(_det_j(chain, np.r_[q[:2], mid, q[3:]])) == sign else (lo, mid)
    star = np.r_[q[:2], 0.5 * (lo + hi), q[3:]]
    assert abs(_det_j(chain, star)) < 1e-9
    result = general_ik(chain, chain.fk(star))
    assert np.abs(wrapped(result.solutions - star)).max(axis=1).min() < 1e-5
    assert pinocchio_miss(xarm6, "base_link", "ee_link", result.solutions, chain.fk(star)) < 1e-10
    beside = star + np.r_[0, 0, 1e-4, 0, 0, 0]
    result = general_ik(chain, chain.fk(beside))
    close = np.abs(wrapped(result.solutions - star)).max(axis=1) < 5e-3
    assert close.sum() >= 2, f"{int(close.sum())} root(s) beside the fold, 2 expected"


@needs_xarm
def test_wrong_chains_are_refused_in_one_line(xarm6):
    five = xarm6.chain("base_link", "link5")
    with pytest.raises(IKOptionError, match="takes a chain of 6 joints; .* has 5"):
        general_ik(five, five.fk(np.zeros(5)))
    with pytest.raises(IKOptionError, match="has 5") as refused:
        manipkit.ik(xarm6, five.fk(np.zeros(5)), tip="link5", method="algebraic")
    assert "lock" not in str(refused.value)  # locking a joint makes 6 of 7 only, not of 5
    with pytest.raises(IKOptionError, match="has 5"):
        manipkit.ik_many(xarm6, five.fk(np.zeros((1, 5))), tip="link5", method="algebraic")
    with pytest.raises(IKOptionError, match="takes no lock="):
        manipkit.ik_many(xarm6, np.eye(4)[None], method="algebraic", lock={"joint1": 0.0})
    with pytest.raises(IKOptionError, match="does not take lock="):
        manipkit.ik(xarm6, np.eye(4), method="algebraic", lock={"joint1": 0.0})


def test_eight_joints_and_prismatic_joints_are_refused():
    rows = [DHRow(0.1, 1.0, 0.1, 0.0) for _ in range(8)]
    robot = Robot.from_urdf(urdf_from_dh(DHTable(rows, "standard", "eight")))
    with pytest.raises(IKOptionError, match="has 8"):
        manipkit.ik(robot, np.eye(4), method="algebraic")
    rows = [DHRow(0.1, 1.0, 0.1, 0.0, type="prismatic" if k == 2 else "revolute") for k in range(6)]
    robot = Robot.from_urdf(urdf_from_dh(DHTable(rows, "standard", "rprrrr")))
    with pytest.raises(IKOptionError, match="joint_3 is prismatic"):
        manipkit.ik(robot, np.eye(4), method="algebraic")
    assert manipkit.ik(robot, robot.transform("base_link", "ee_link", np.full(6, 0.2)), restarts=5).method == "numerical"


def _xarm_words():
    return ["--robot", str(XARM), "--arg", "dof:=6", "--arg", "robot_type:=xarm"]


@needs_xarm
def test_cli_ik_all_prints_the_algebraic_answer_and_json_equals_the_python_call(xarm6):
    words = ["--xyz", "0.35", "0.05", "0.25", "--rpy", "3.0", "0.2", "0.1"]
    text = run_cli("manipkit", "ik", *_xarm_words(), *words, "--all")
    assert text.returncode == 0, text.stderr
    assert text.stdout.startswith("algebraic elimination (general 6R, frame ee_link in base_link): ")
    as_json = run_cli("manipkit", "ik", *_xarm_words(), *words, "--all", "--format", "json")
    answer = json.loads(as_json.stdout)
    from manipkit.spatial.transforms import transform_from_xyz_rpy

    python = manipkit.ik(xarm6, transform_from_xyz_rpy([0.35, 0.05, 0.25], [3.0, 0.2, 0.1]), all=True)
    assert (answer["method"], answer["arm_family"]) == ("algebraic", "general 6R")
    assert len(answer["solutions"]) == len(python.solutions) >= 2
    for row, q in zip(answer["solutions"], python.solutions):
        assert [row[name] for name in xarm6.joint_names] == q.tolist()
    assert answer["within_limits"] == python.within_limits.tolist()
    assert f"{len(python.solutions)} solution(s) (every isolated solution)" in text.stdout


@needs_xarm
def test_cli_family_names_the_general_6r_class_with_the_evidence():
    text = run_cli("manipkit", "family", *_xarm_words())
    assert text.returncode == 0, text.stderr
    assert "family: none" in text.stdout and "axes 4, 5, 6 meet at" in text.stdout
    assert "class: general 6R: 6 revolute joints, no closed-form family" in text.stdout
    answer = json.loads(run_cli("manipkit", "family", *_xarm_words(), "--format", "json").stdout)
    assert answer["class"] == "general 6R" and answer["family"] == "none" and "Raghavan-Roth" in answer["general_6r"]
    ur5 = json.loads(run_cli("manipkit", "family", "--robot", "ur5", "--tip", "tool0", "--format", "json").stdout)
    assert ur5["class"] == "three parallel, two intersecting" and ur5["general_6r"] is None


def test_on_a_ur5_the_elimination_gives_the_closed_form_s_branches():
    """An independent source: the UR closed form. method='algebraic' on the same chain must give the same set."""
    ur5 = manipkit.load("ur5")
    chain = ur5.chain("base_link", "tool0")
    for q in chain.sample(30, seed=6):
        T = chain.fk(q)
        closed = manipkit.ik(ur5, T, tip="tool0", all=True)
        algebraic = manipkit.ik(ur5, T, tip="tool0", all=True, method="algebraic")
        assert algebraic.method == "algebraic" and closed.method == "closed_form"
        assert len(algebraic.solutions) == len(closed.solutions) >= 2
        for row in closed.solutions:
            assert np.abs(wrapped(algebraic.solutions - row)).max(axis=1).min() < 1e-8


def test_a_singular_target_is_a_family_with_the_free_joint_named():
    """UR5 with wrist_2 = 0: axis 6 along axes 2, 3, 4, a one-parameter family (the closed form names wrist_3_joint);
    every elimination is degenerate there, so the answer is what numerical IK finds, marked as a family."""
    ur5 = manipkit.load("ur5")
    chain = ur5.chain("base_link", "tool0")
    T = chain.fk([0.1, -1.0, 1.2, -0.3, 0.0, 0.5])
    closed = manipkit.ik(ur5, T, tip="tool0", all=True)
    assert math.isinf(closed.count) and closed.free_parameter == "wrist_3_joint"
    result = manipkit.ik(ur5, T, tip="tool0", all=True, method="algebraic")
    assert math.isinf(result.count) and "wrist_3_joint" in result.free_parameter
    assert "completeness not proven" in result.note and result.failure is None
    assert pinocchio_miss(ur5, "base_link", "tool0", result.solutions, T) < 1e-9


@needs_xarm
def test_asking_the_xarm6_for_a_closed_form_points_to_the_algebraic_method(xarm6):
    with pytest.raises(IKOptionError, match="method 'algebraic' .* every isolated solution of this 6R chain"):
        manipkit.ik(xarm6, np.eye(4), method="closed_form")


def test_compiled_elimination_gives_the_numpy_reference_solutions_on_640_solves():
    """The compiled elimination (closed_form.general6r_kernel: prepare, equations, pencil, eigenvalues, joints,
    polishing) against the numpy reference (compiled=False): the same rows to 1e-9 rad on 4 random DH arms x 160
    poses, each row landing by Pinocchio's FK to 1e-10."""
    from manipkit.closed_form.general6r import solve_way
    from manipkit.ik.families import chain_family
    from manipkit.ik.general6r import general_ways

    solves = rows_seen = 0
    for seed in range(4):
        robot = random_dh_robot(100 + seed)
        chain = robot.chain(robot.base_link, "ee_link")
        geometry = chain_family(chain).geometry
        way = general_ways(chain)[0]
        Q = chain.sample(160, seed=seed)
        for q, T in zip(Q, chain.fk(Q)):
            g = T @ np.linalg.inv(geometry.M)
            fast = solve_way(geometry.direction, geometry.point, g, way, compiled=True).theta
            slow = solve_way(geometry.direction, geometry.point, g, way, compiled=False).theta
            assert fast.shape == slow.shape
            assert np.abs(wrapped(fast - slow)).max(initial=0.0) <= 1e-9
            rows = np.broadcast_to(geometry.q0, fast.shape).copy()
            rows[:, geometry.columns] = geometry.q0[geometry.columns] + fast / geometry.scale
            assert pinocchio_miss(robot, chain.base, chain.tip, rows, T) <= 1e-10
            assert np.abs(wrapped(rows - q)).max(axis=1).min() <= 1e-7  # the generating configuration is found
            solves += 1
            rows_seen += len(rows)
    assert solves == 640 and rows_seen > 640


@needs_xarm
def test_batch_gives_the_single_calls_rows_on_200_xarm6_poses(xarm6):
    """ik_many on the xArm6 (the compiled elimination over a stack, on 2 threads): per target the same rows as
    ik(all=True, aliases=False) to 1e-9 rad, each landing by Pinocchio's FK to 1e-10, the generating configuration
    among them for every target; 1 and 2 threads give the same bits. (Before, the batch was numerical: 1 slot.)"""
    chain = xarm6.chain("base_link", "ee_link")
    Q = chain.sample(200, seed=17)
    T = chain.fk(Q)
    batch = manipkit.ik_many(xarm6, T, threads=2)
    assert batch.method == "algebraic" and batch.solutions.shape[0] == 200 and bool(batch.success.all())
    assert np.array_equal(manipkit.ik_many(xarm6, T, threads=1).solutions, batch.solutions, equal_nan=True)
    assert np.array_equal(manipkit.ik_many(xarm6, T, method="algebraic").solutions, batch.solutions, equal_nan=True)
    for i, (q, target) in enumerate(zip(Q, T)):
        single = manipkit.ik(xarm6, target, all=True, aliases=False).solutions[:, chain.columns]
        rows = batch.solutions[i][~np.isnan(batch.solutions[i, :, 0])]
        assert rows.shape == single.shape and batch.count[i] == len(single)
        assert np.abs(rows - single).max(initial=0.0) <= 1e-9
        assert pinocchio_miss(xarm6, "base_link", "ee_link", rows, target) <= 1e-10
        assert np.abs(wrapped(rows - q)).max(axis=1).min() <= 1e-7
    position = batch.residual_position[~np.isnan(batch.residual_position)]
    assert position.max() <= 1e-10


def test_batch_of_a_random_arm_matches_general_ik_with_a_shaped_stack():
    """general_ik_many on a random DH arm: targets (2, 5, 4, 4) keep their shape, each target's rows are
    general_ik's, in its order, NaN after them."""
    from manipkit.ik.general6r import general_ik_many

    robot = random_dh_robot(101)
    chain = robot.chain(robot.base_link, "ee_link")
    T = chain.fk(chain.sample(10, seed=4)).reshape(2, 5, 4, 4)
    batch = general_ik_many(chain, T)
    assert batch.solutions.shape[:2] == (2, 5) and batch.count.shape == (2, 5)
    for index in np.ndindex(2, 5):
        single = general_ik(chain, T[index]).solutions
        rows = batch.solutions[index]
        assert np.abs(rows[:len(single)] - single).max(initial=0.0) <= 1e-9 and np.isnan(rows[len(single):]).all()


def test_batch_answers_a_singular_target_as_the_single_call_does():
    """A UR5 batch by the elimination (method='algebraic') with a singular target (wrist_2 = 0, every elimination
    degenerate) between two regular ones: the singular one counts inf with the single call's rows (numerical IK's
    family members), the others their 8 branches; all succeed, every row landing by Pinocchio."""
    ur5 = manipkit.load("ur5")
    chain = ur5.chain("base_link", "tool0")
    Q = np.array([[0.3, -1.2, 1.0, -0.5, 0.8, 0.2], [0.1, -1.0, 1.2, -0.3, 0.0, 0.5], [-0.4, -0.9, 1.4, 0.6, -1.1, 1.0]])
    T = chain.fk(Q)
    batch = manipkit.ik_many(ur5, T, tip="tool0", method="algebraic")
    single = manipkit.ik(ur5, T[1], tip="tool0", all=True, method="algebraic", aliases=False)
    assert batch.method == "algebraic" and batch.count[0] == 8 and batch.count[2] == 8 and math.isinf(batch.count[1])
    rows = batch.solutions[1][~np.isnan(batch.solutions[1, :, 0])]
    assert np.abs(rows - single.solutions[:, chain.columns]).max() <= 1e-9 and bool(batch.success.all())
    for i in range(3):
        found = batch.solutions[i][~np.isnan(batch.solutions[i, :, 0])]
        assert pinocchio_miss(ur5, "base_link", "tool0", found, T[i]) < 1e-9


def _locked_search(chain, T, joint, value, starts, seed):
    """Every solution a search finds (written here, independent of the solver): Gauss-Newton on the six unlocked
    joints of ``chain`` from ``starts`` random configurations at once (chain.fk and chain.jacobians, the rotation
    error from the skew part of R_T R^T, damped far from a solution, steps of at most 0.5 rad), the converged ones (to 1e-11 m and rad) returned, joint ``joint`` at
    ``value``."""
    rng = np.random.default_rng(seed)
    Q = rng.uniform(-np.pi, np.pi, (starts, chain.n))
    Q[:, joint] = value
    free = [j for j in range(chain.n) if j != joint]
    for _ in range(100):
        reached = chain.fk(Q)
        M = T[:3, :3] @ np.swapaxes(reached[:, :3, :3], 1, 2)
        error = np.concatenate([T[:3, 3] - reached[:, :3, 3],
                                0.5 * np.stack([M[:, 2, 1] - M[:, 1, 2], M[:, 0, 2] - M[:, 2, 0],
                                                M[:, 1, 0] - M[:, 0, 1]], axis=1)], axis=1)
        J = chain.jacobians(Q)[:, :, free]
        damping = np.minimum(1e-2, (error ** 2).sum(axis=1))[:, None, None]  # Levenberg-Marquardt, vanishing near
        step = np.linalg.solve(np.swapaxes(J, 1, 2) @ J + damping * np.eye(6),
                               (np.swapaxes(J, 1, 2) @ error[:, :, None]))[:, :, 0]
        Q[:, free] += step / np.maximum(1.0, np.abs(step).max(axis=1) / 0.5)[:, None]  # at most 0.5 rad a step
    reached = chain.fk(Q)
    M = T[:3, :3] @ np.swapaxes(reached[:, :3, :3], 1, 2)
    done = (np.abs(reached[:, :3, 3] - T[:3, 3]).max(axis=1) < 1e-11) & (np.abs(M - np.eye(3)).max(axis=(1, 2)) < 1e-11)
    return Q[done]


@pytest.mark.parametrize("joint", [0, 1, 2, 3, 4])
def test_the_panda_with_any_of_its_first_five_joints_locked(joint):
    """The Panda with joint 1..5 locked leaves a 6R arm with no closed form: the general solver answers. Every row
    lands by Pinocchio to 1e-10, holds the locked joint at exactly its value, the generating configuration is among
    the rows on every one of 30 poses, and on 4 of them no solution of a 200-start search (written here) is missing.
    Joint 2 is the case that failed: ranked at its reference value 0, where joints 1 and 3 are one line (a
    continuum), no way of eliminating was kept, so every target was answered "degenerate" with no row."""
    robot = manipkit.load("panda")
    chain = robot.chain("base_link", "ee_link")
    name = chain.joint_names[joint]
    for k, q in enumerate(chain.sample(30, seed=70 + joint)):
        T = robot.transform("base_link", "ee_link", chain.full(q))
        answer = manipkit.ik(robot, T, all=True, lock={name: float(q[joint])})
        assert (answer.method, answer.arm_family) == ("algebraic", "general 6R"), answer.note
        rows = np.asarray(answer.solutions)[:, chain.columns]
        assert np.all(rows[:, joint] == q[joint])
        assert pinocchio_miss(robot, "base_link", "ee_link", answer.solutions, T) < 1e-10
        assert np.abs(wrapped(rows - q)).max(axis=1).min() < 1e-7, (k, answer.note)
        if k < 4:
            found = _locked_search(chain, T, joint, float(q[joint]), 200, k)
            assert len(found)  # the search found something to compare
            gaps = np.abs(wrapped(found[:, None, :] - rows[None, :, :])).max(axis=2).min(axis=1)
            assert (gaps < 1e-6).all(), f"{int((gaps >= 1e-6).sum())} of {len(found)} searched solutions missing"


@pytest.mark.parametrize("lock", [None, "panda_joint3"])
def test_rows_refined_on_the_chain_land_and_are_the_unrefined_rows(lock):
    """A tolerance below what the elimination's polishing reaches (2e-15) sends rows through the refinement
    (newton_kernel.polish_targets on the chain's axes towards g): each refined row is marked (``refined`` > 0),
    lands by Pinocchio to 1e-14 (its residual measured to within 2e-15), and is a row the default tolerance
    gives, to 1e-9 rad. 2e-15 rad is about nine ulps of a rotation angle, so a row may stay above it on one
    machine's floating point and not another's: such a row is counted in ``rejected``, never returned, and the
    returned rows with the rejected ones are the default tolerance's rows. On a random DH arm (general 6R) and
    on the Panda with joint 3 locked (g = L^-1 T M^-1)."""
    robot = random_dh_robot(2) if lock is None else manipkit.load("panda")
    chain = robot.chain("base_link", "ee_link")
    refined_rows = rejected_rows = plain_rows = 0
    for k, q in enumerate(chain.sample(12, seed=81)):
        T = chain.fk(q)
        held = {lock: float(q[chain.joint_names.index(lock)])} if lock else None
        tight = general_ik(chain, T, tol=2e-15, lock=held)
        plain = general_ik(chain, T, lock=held)
        assert len(tight.solutions) + tight.rejected == len(plain.solutions), k
        gaps = np.abs(wrapped(tight.solutions[:, None, :] - plain.solutions[None, :, :])).max(axis=2, initial=0.0)
        assert (gaps.min(axis=1, initial=0.0) < 1e-9).all(), k
        refined_rows += int((tight.refined > 0).sum())
        rejected_rows, plain_rows = rejected_rows + tight.rejected, plain_rows + len(plain.solutions)
        assert (tight.residual_position <= 2e-15).all() and (tight.residual_rotation <= 2e-15).all()
        assert pinocchio_miss(robot, chain.base, chain.tip, [chain.full(s) for s in tight.solutions], T) < 1e-14
    assert refined_rows > 10  # the refinement ran
    assert rejected_rows <= plain_rows // 20  # and brought all but a few rows to 2e-15
