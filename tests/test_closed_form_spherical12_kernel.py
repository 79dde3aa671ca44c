"""The compiled "spherical wrist, two intersecting" closed form (closed_form.spherical12_kernel) gives the numpy
reference's answers (arms.solve_6r), and the Panda's ranked set built on it is the reference's.

The 6R arm is the Panda's with its last joint locked, solved at every value of its ranked set's sweep and
narrowing. Compared with the reference: the valid slots, their angles (modulo 2 pi, to 1e-9 rad), the misses and
which targets are handed back; then the whole ranked set of 200 random Panda poses with the compiled path (the
sweep, narrowing and rows in one compiled call per pose, ik.redundant_kernel, over the compiled closed form)
against the same set with the reference alone (the dispatcher round by round, ``ranked_set(..., compiled=False)``,
over ``solve_branches(..., compiled=False)``): the same scores in the same order, rows, labels and parameter values
to 1e-9 (rows of one score, to rounding, in either order), the same intervals, every row landing by Pinocchio's own
FK to 1e-10.
"""

import math

import numpy as np
import pinocchio as pin
import pytest

import manipkit
import manipkit.closed_form.arms as arms_module
import manipkit.ik.chain_ik as chain_ik_module
from manipkit.closed_form.arms import SPHERICAL_12, solve_6r
from manipkit.closed_form.spherical12_kernel import solve_spherical_12_many
from manipkit.ik.dispatch import ik, ik_many
from manipkit.ik.redundant import ranked_set

POSES = 200


@pytest.fixture(scope="module")
def panda():
    robot = manipkit.load("panda")
    return robot, robot.chain("base_link", "ee_link")


def pinocchio_pose(robot, q):
    """T_base_link_ee_link by Pinocchio itself (forwardKinematics + updateFramePlacements)."""
    model, data = robot.model, robot.model.createData()
    pin.forwardKinematics(model, data, robot.pinocchio_configuration(q))
    pin.updateFramePlacements(model, data)
    placement = lambda name: data.oMf[model.getFrameId(robot.frame(name))].homogeneous  # noqa: E731
    return np.linalg.inv(placement("base_link")) @ placement("ee_link")


def pose_error(A, B):
    R = A[:3, :3].T @ B[:3, :3]
    sine = 0.5 * np.linalg.norm([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    return max(float(np.linalg.norm(A[:3, 3] - B[:3, 3])), float(math.atan2(sine, (np.trace(R) - 1.0) / 2.0)))


def swept_calls(robot, targets):
    """Every (arm, g) the ranked sets of ``targets`` hand to the closed form (the sweep and the narrowing, through
    the dispatcher: ``ranked_set(..., compiled=False)``)."""
    calls = []
    original = chain_ik_module.solve_branches

    def recording(arm, g, *, compiled=True):
        calls.append((arm, np.array(g)))
        return original(arm, g, compiled=compiled)

    chain_ik_module.solve_branches = recording
    try:
        for T in targets:
            ranked_set(robot, T, "base_link", "ee_link", solvers=(ik, ik_many), compiled=False)
    finally:
        chain_ik_module.solve_branches = original
    return calls


def wrapped(d):
    return np.pi - np.mod(np.pi - d, 2.0 * np.pi)


def test_the_kernel_gives_the_references_branches_and_misses_over_the_pandas_sweeps(panda):
    robot, chain = panda
    calls = swept_calls(robot, chain.fk(chain.sample(20, seed=7)))
    assert calls and all(arm.family.kind == SPHERICAL_12 for arm, _ in calls)
    solved = handed_back = 0
    for arm, g in calls:
        theta, valid, miss, fallback = solve_spherical_12_many(arm.h, arm.p, arm.points["wrist"],
                                                               arm.points["shoulder"], g)
        reference = solve_6r(SPHERICAL_12, arm.h, arm.p, g, arm.points)
        kept = ~fallback
        assert (valid[kept] == reference.valid[kept]).all()
        assert not valid[fallback].any()
        assert (reference.free[kept] == -1).all()
        gap = np.abs(wrapped(theta - reference.theta))[kept][valid[kept]]
        assert gap.size == 0 or gap.max() < 1e-9
        for key in ("shoulder", "reach", "orientation"):
            np.testing.assert_allclose(miss[key][kept], reference.miss[key][kept], rtol=0, atol=1e-12)
        solved += int(kept.sum())
        handed_back += int(fallback.sum())
    assert solved > 1000 and handed_back <= solved // 100  # generic targets: the kernel answers nearly all


def test_a_batch_reports_each_targets_own_reach_miss():
    # an arm of the family: axes 1 (z) and 2 (y) meet at 0, the elbow (y) at (0, 0, 0.3), the wrist centre at
    # (0, 0, 0.7): the elbow turns it on a circle of radius 0.4 about (0, 0, 0.3), so |w - s| reaches 0.1 to 0.7 m
    h = np.array([[0, 0, 1], [0, 1, 0], [0, 1, 0], [0, 0, 1], [0, 1, 0], [0, 0, 1]], dtype=float)
    p = np.array([[0, 0, 0], [0, 0, 0], [0, 0, 0.3], [0, 0, 0.7], [0, 0, 0.7], [0, 0, 0.7]], dtype=float)
    points = {"wrist": np.array([0.0, 0.0, 0.7]), "shoulder": np.zeros(3)}
    g = np.eye(4)[None].repeat(2, axis=0)
    g[0, 2, 3], g[1, 2, 3] = 0.1, 0.2  # the wrist centre at 0.8 and 0.9 m: 0.1 and 0.2 m beyond the 0.7 m reach
    together = solve_6r(SPHERICAL_12, h, p, g, points).miss["reach"]
    alone = [float(solve_6r(SPHERICAL_12, h, p, g[i:i + 1], points).miss["reach"][0]) for i in range(2)]
    np.testing.assert_allclose(alone, [0.1, 0.2], atol=1e-12)
    np.testing.assert_allclose(together, alone, atol=1e-12)
    _, valid, miss, fallback = solve_spherical_12_many(h, p, points["wrist"], points["shoulder"], g)
    assert not fallback.any() and not valid.any()
    np.testing.assert_allclose(miss["reach"], alone, atol=1e-12)


def tie_groups(scores, tol=1e-9):
    """Index groups of consecutive ``scores`` (best first) within ``tol`` of the group's first."""
    groups = []
    for i, score in enumerate(scores):
        if groups and abs(scores[groups[-1][0]] - score) <= tol:
            groups[-1].append(i)
        else:
            groups.append([i])
    return [tuple(g) for g in groups]


def reference_sets(robot, targets):
    """The ranked sets of ``targets`` by the reference alone: the sweep through the dispatcher round by round
    (``ranked_set(..., compiled=False)``) over the numpy closed form (``solve_branches(..., compiled=False)``)."""
    original = chain_ik_module.solve_branches
    chain_ik_module.solve_branches = lambda arm, g, *, compiled=True: original(arm, g, compiled=False)
    try:
        return [ranked_set(robot, T, "base_link", "ee_link", solvers=(ik, ik_many), compiled=False) for T in targets]
    finally:
        chain_ik_module.solve_branches = original


def test_the_pandas_ranked_sets_are_the_references_on_random_poses(panda, monkeypatch):
    robot, chain = panda
    targets = chain.fk(chain.sample(POSES, seed=36))
    manipkit.ik(robot, targets[0], all=True)  # the compiled path's one probe of the dispatcher per chain
    dispatched, handed_back = [], []
    original = chain_ik_module.solve_branches
    monkeypatch.setattr(chain_ik_module, "solve_branches", lambda arm, g, *, compiled=True: dispatched.append(g)
                        or original(arm, g, compiled=compiled))
    reference_6r = arms_module.solve_6r
    monkeypatch.setattr(arms_module, "solve_6r", lambda *args: handed_back.append(args) or reference_6r(*args))
    compiled = [manipkit.ik(robot, T, all=True) for T in targets]  # the sweep compiled: ik.redundant_kernel
    monkeypatch.undo()
    assert not dispatched  # one compiled call per pose, no round through the dispatcher
    assert handed_back  # some targets near a threshold of the compiled closed form went to the numpy reference
    reference = reference_sets(robot, targets)
    rows = 0
    for T, new, old in zip(targets, compiled, reference):
        assert new.ranked_by == old.ranked_by
        assert len(new.solutions) == len(old.solutions)
        np.testing.assert_allclose(new.scores, old.scores, rtol=0, atol=1e-9)
        # rows of one score (a wrist flip leaves the joint nearest its limit where it was: the same score to
        # rounding) are ranked in either order; each such group holds the same rows, labels and values
        for group in tie_groups(old.scores):
            assert sorted(new.labels[i] for i in group) == sorted(old.labels[i] for i in group)
            matched = [min(group, key=lambda j: (new.labels[j] != old.labels[i],
                                                 abs(new.parameter_values[j] - old.parameter_values[i])))
                       for i in group]
            assert sorted(matched) == list(group)
            for i, j in zip(group, matched):
                assert new.labels[j] == old.labels[i]
                np.testing.assert_allclose(new.solutions[j], old.solutions[i], rtol=0, atol=1e-9)
                assert abs(new.parameter_values[j] - old.parameter_values[i]) <= 1e-9
        assert [i[0] for i in new.intervals] == [i[0] for i in old.intervals]
        np.testing.assert_allclose([i[1:] for i in new.intervals], [i[1:] for i in old.intervals], rtol=0,
                                   atol=1e-9)
        for q in new.solutions:
            assert pose_error(pinocchio_pose(robot, q), T) <= 1e-10
        rows += len(new.solutions)
    assert rows >= 16 * POSES // 2


def test_a_target_whose_rotation_is_not_exact_gets_the_references_ranked_set(panda):
    # check_transform takes a rotation block off by up to 1e-6; the compiled sweep takes exact ones (1e-12) only
    # and answers any other pose the way the reference does (the dispatcher round by round)
    robot, chain = panda
    T = chain.fk(chain.sample(1, seed=5))[0]
    T[:3, :3] *= 1.0 + 1e-9
    new = manipkit.ik(robot, T, all=True)
    old = ranked_set(robot, T, "base_link", "ee_link", solvers=(ik, ik_many), compiled=False)
    assert len(new.solutions) == len(old.solutions) >= 16
    np.testing.assert_array_equal(new.solutions, old.solutions)
    assert new.intervals == old.intervals and new.labels == old.labels
