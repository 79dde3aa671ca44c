"""The one IK dispatcher: ``manipkit.ik`` and ``manipkit.ik_many``, and ``manipkit ik`` giving the same answers.

Every solution is checked by Pinocchio's own forward kinematics (``pinocchio_pose``), never by manipkit's.
"""

import json
import math
import warnings
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from cli_helper import run_cli

import manipkit
from manipkit.errors import ChainError, IKOptionError
from manipkit.ik.chain_ik import srs_arm_angle
from manipkit.ik.result import FAILURE_KINDS, IKFailure

REALWORLD = next((base / "shared" / "realworld" / "ws_ros1" / "src" for base in Path(__file__).resolve().parents[2:4]
                  if (base / "shared" / "realworld").is_dir()), Path("/nonexistent"))
IRB2400 = REALWORLD / "abb/abb_irb2400_support/urdf/irb2400.xacro"


def pinocchio_pose(robot, base: str, tip: str, q_full) -> np.ndarray:
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, robot.pinocchio_configuration(q_full))
    return np.linalg.inv(data.oMf[robot.frame_id(base)].homogeneous) @ data.oMf[robot.frame_id(tip)].homogeneous


def rotation_angle(R: np.ndarray) -> float:
    """The angle of R, by atan2 of its skew and symmetric parts (acos near 1 loses half the digits)."""
    skew = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    return math.atan2(np.linalg.norm(skew) / 2.0, (np.trace(R) - 1.0) / 2.0)


def assert_lands(robot, base, tip, Q, T, tol=1e-9):
    for q in Q:
        reached = pinocchio_pose(robot, base, tip, q)
        assert np.linalg.norm(reached[:3, 3] - T[:3, 3]) < tol
        assert rotation_angle(reached[:3, :3].T @ T[:3, :3]) < tol


def rows_of(payload: dict, robot) -> np.ndarray:
    """Whole-robot rows of the JSON solutions (which hold the chain's own joints; the others at their defaults)."""
    return np.array([robot.q(row) for row in payload["solutions"]]).reshape(-1, len(robot.joint_names))


def cli_solutions(robot_words, base, tip, T, *extra):
    rpy = manipkit.rpy_from_matrix(T[:3, :3])
    result = run_cli("manipkit", "ik", *robot_words, "--base", base, "--tip", tip, "--xyz", *(repr(float(v)) for v in T[:3, 3]),
                     "--rpy", *(repr(float(v)) for v in rpy), "--all", "--format", "json", *extra)
    assert result.returncode in (0, 1), result.stderr
    return json.loads(result.stdout), result


def target_from_rpy(T):
    """The target the command builds from its printed numbers (repr: exact), so both sides solve the same pose."""
    return manipkit.transform_from_xyz_rpy(T[:3, 3], manipkit.rpy_from_matrix(T[:3, :3]))


def same_rows(A, B, tol=1e-9):
    assert A.shape == B.shape
    for a in A:
        assert np.min(np.abs(B - a).max(axis=1)) <= tol


def closed_form_cases():
    yield "ur5", ["--robot", "ur5"], "base_link", "tool0", {}, ()
    yield "iiwa14", ["--robot", "iiwa14"], "base_link", "ee_link", {"arm_angle": None}, ()
    if IRB2400.is_file():
        yield "irb2400", ["--robot", str(IRB2400)], "base_link", "tool0", {}, ()


@pytest.mark.parametrize("case", list(closed_form_cases()), ids=lambda case: case[0])
def test_python_and_the_command_give_the_same_closed_form_solutions(case):
    name, words, base, tip, options, flags = case
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = manipkit.load(words[1])
    rng = np.random.default_rng(3)
    for _ in range(3):
        chain = robot.chain(base, tip)
        q = chain.sample(1, seed=int(rng.integers(1 << 30)))[0]
        T = target_from_rpy(chain.fk(q))
        if "arm_angle" in options:  # a 7R SRS arm: at the arm angle of the generating configuration
            psi = srs_arm_angle(chain, q)
            options, flags = {"arm_angle": psi}, ("--arm-angle", repr(float(psi)))
        python = manipkit.ik(robot, T, base=base, tip=tip, all=True, **options)
        payload, _ = cli_solutions(words, base, tip, T, *flags)
        assert python.method == "closed_form" and payload["method"] == "closed_form"
        assert payload["arm_family"] == python.arm_family != ""
        assert len(python.solutions) == len(payload["solutions"]) >= 1
        same_rows(rows_of(payload, robot), python.solutions)
        assert_lands(robot, base, tip, python.solutions, T)
        # the generating configuration is among them (chain columns; angles modulo 2 pi)
        d = python.solutions[:, chain.columns] - q
        assert np.min(np.abs(np.angle(np.exp(1j * d))).max(axis=1)) < 1e-7


def test_a_numerical_only_arm_gives_the_same_solutions_in_python_and_the_command():
    # the Panda's 7R chain has a ranked set with all=True (tests/test_ik_redundant.py): numerical IK by name here
    panda = manipkit.load("panda")
    chain = panda.chain("panda_link0", "panda_hand")
    T = target_from_rpy(chain.fk(chain.sample(1, seed=4)[0]))
    python = manipkit.ik(panda, T, base="panda_link0", tip="panda_hand", all=True, restarts=8, seed=2,
                         method="numerical")
    payload, _ = cli_solutions(["--robot", "panda"], "panda_link0", "panda_hand", T, "--restarts", "8", "--seed", "2",
                               "--method", "numerical")
    assert python.method == payload["method"] == "numerical"
    assert payload["arm_family"] is None and python.arm_family == ""
    assert len(python.solutions) == len(payload["solutions"]) >= 1
    same_rows(rows_of(payload, panda), python.solutions)
    assert_lands(panda, "panda_link0", "panda_hand", python.solutions, T)


def test_auto_takes_the_closed_form_where_there_is_one_and_one_answer_without_all():
    ur5 = manipkit.load("ur5")
    q = np.array([0.1, -1.0, 1.2, -0.3, 1.0, 0.5])
    T = ur5.transform("base_link", "tool0", q)
    every = manipkit.ik(ur5, T, tip="tool0", all=True)
    one = manipkit.ik(ur5, T, tip="tool0", q0=q + 0.05)
    assert one.method == "closed_form" and len(one.solutions) == 1
    # nearest to q0 among the in-limit branches: the generating configuration itself
    assert np.abs(one.q - q).max() < 1e-9
    assert any(np.abs(row - one.q).max() < 1e-12 for row in every.solutions)
    # without q0, the first branch inside the limits, in the solver's order
    first = manipkit.ik(ur5, T, tip="tool0")
    inside = np.flatnonzero(every.within_limits)
    assert np.array_equal(first.q, every.solutions[inside[0]]) and first.labels == (every.labels[inside[0]],)
    numerical = manipkit.ik(ur5, T, tip="tool0", method="numerical", seed=1)
    assert numerical.method == "numerical" and numerical.attempts >= 1
    assert_lands(ur5, "base_link", "tool0", numerical.solutions, T)


def test_a_chain_is_solved_on_its_own_frames():
    ur5 = manipkit.load("ur5")
    chain = ur5.chain("base_link", "tool0")
    T = chain.fk(chain.sample(1, seed=9)[0])
    a = manipkit.ik(chain, T, all=True)
    b = manipkit.ik(ur5, T, base="base_link", tip="tool0", all=True)
    assert np.array_equal(a.solutions, b.solutions)
    with pytest.raises(ChainError, match="a chain has its own frames"):
        manipkit.ik(chain, T, tip="tool0")


def test_options_a_solver_cannot_honour_are_refused_in_one_line():
    panda = manipkit.load("panda")
    T = panda.transform("base_link", "ee_link", panda.q())
    with pytest.raises(IKOptionError, match="no closed-form solver for robot 'panda'"):
        manipkit.ik(panda, T, lock={"panda_joint1": 0.0, "panda_joint3": 0.1})  # one lock: the general 6R answers
    with pytest.raises(IKOptionError, match="no closed-form solver"):
        manipkit.ik(panda, T, method="closed_form")
    ur5 = manipkit.load("ur5")
    T = ur5.transform("base_link", "tool0", ur5.q())
    with pytest.raises(IKOptionError, match="honoured by the closed forms only"):
        manipkit.ik(ur5, T, tip="tool0", method="numerical", arm_angle=0.3)
    with pytest.raises(IKOptionError, match="do not solve a pointing target"):
        manipkit.ik(ur5, T, tip="tool0", method="closed_form", mode="position+axis")
    with pytest.raises(IKOptionError, match="method must be one of auto, closed_form, numerical"):
        manipkit.ik(ur5, T, method="fast")
    for args in (["--lock", "panda_joint1=0", "panda_joint3=0.1"], ["--method", "closed_form"]):
        result = run_cli("manipkit", "ik", "--robot", "panda", "--xyz", "0.4", "0.1", "0.5", "--rpy", "3.14", "0", "0",
                         *args)
        assert result.returncode == 2 and len(result.stderr.strip().splitlines()) == 1, result.stderr


def test_failures_are_records_with_a_kind_and_their_numbers():
    ur5 = manipkit.load("ur5")
    far = np.eye(4)
    far[:3, 3] = (3.0, 0.0, 0.5)  # the UR5 reaches about 0.85 m from its shoulder
    closed = manipkit.ik(ur5, far, tip="tool0", all=True)
    assert not closed.success and closed.q is None and closed.failure.kind == "unreachable"
    assert closed.reason == closed.failure.message != ""
    numerical = manipkit.ik(ur5, far, tip="tool0", method="numerical", restarts=2)
    assert numerical.q is None and numerical.closest is not None  # q means the same for every method
    assert numerical.failure.kind == "unreachable" and dict(numerical.failure.values)["outside_by"] > 1.0
    assert {closed.failure.kind, numerical.failure.kind} <= set(FAILURE_KINDS)
    with pytest.raises(ValueError, match="kind must be one of"):
        IKFailure("nearly", "x")


def test_every_solution_in_collision_is_a_collision_failure_naming_the_pairs():
    from manipkit.kinematics.collisions import CollisionChecker

    panda = manipkit.load("panda")
    checker = CollisionChecker(panda, floor=0.3)  # a floor 0.3 m above the base: the link0 - floor pair touches always
    q = panda.q()
    T = panda.transform("panda_link0", "panda_hand", q)
    result = manipkit.ik(panda, T, base="panda_link0", tip="panda_hand", q0=q, restarts=2, collision_free=checker)
    assert not result.success and result.failure.kind == "collision"
    assert result.failure.pairs and all(len(pair) == 2 for pair in result.failure.pairs)
    assert checker.report(result.closest).in_collision


def test_a_batch_says_per_target_which_method_ran_and_why_one_failed():
    ur5 = manipkit.load("ur5")
    chain = ur5.chain("base_link", "tool0")
    T = chain.fk(chain.sample(3, seed=5))
    T[1, :3, 3] = (3.0, 0.0, 0.5)
    closed = manipkit.ik_many(chain, T)
    assert closed.method == "closed_form"
    assert closed.success.tolist() == [True, False, True]
    assert closed.failure_kinds.tolist() == ["", "unreachable", ""]
    assert closed.reason(0) == "" and closed.failure(0) is None
    assert "no branch reaches the target" in closed.reason(1)
    numerical = manipkit.ik_many(chain, T, method="numerical", restarts=20)
    assert numerical.method == "numerical"
    assert numerical.failure_kinds.tolist() == ["", "tolerance", ""]
    assert dict(numerical.failure(1).values)["position"] > 1.0  # the best it found is over a metre off
    for i in (0, 2):
        assert_lands(ur5, "base_link", "tool0", closed.solutions[i][np.isfinite(closed.solutions[i]).all(axis=1)], T[i])


@pytest.mark.parametrize("name", ["planar_2r", "scara", "stanford_arm"])
def test_a_batch_on_a_textbook_arm_with_a_named_solver_is_solved_numerically(name):
    # their closed forms are named one-target solvers, not the chain's geometric family: ik_many used to refuse them
    robot = manipkit.load(name)
    chain = robot.chain("base_link", "ee_link")
    T = chain.fk(chain.sample(4, seed=2))
    batch = manipkit.ik_many(robot, T, restarts=20)
    assert batch.method == "numerical" and batch.success.all()
    for q, target in zip(batch.q, T):
        assert_lands(robot, "base_link", "ee_link", q[None], target)
    with pytest.raises(IKOptionError, match="no closed-form solver"):
        manipkit.ik_many(robot, T, method="closed_form")
