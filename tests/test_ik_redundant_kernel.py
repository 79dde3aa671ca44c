"""The compiled sweep of a 7R ranked set (manipkit.ik.redundant_kernel) gives the reference's ranked sets.

Two arms, one per kind of parameter the kernel sweeps: the Panda (its last joint locked over the 6R arm "spherical
wrist, two intersecting") and the iiwa14 (the SRS arm angle). On 200 random poses each (FK of seeded in-limit
configurations), the ranked set of one compiled call per pose (``manipkit.ik(arm, T, all=True)``) against the
reference alone: the dispatcher round by round (``ranked_set(..., compiled=False)``), over the numpy closed form for
the Panda (``solve_branches(..., compiled=False)``; the iiwa14's batch keeps its compiled SRS rows, tested against
their numpy reference in test_ik_chain_ik). The same scores in the same order to 1e-9, rows, labels and parameter
values to 1e-9 (rows of one score, to rounding, in either order), the same intervals to 1e-9, every row landing by
Pinocchio's own FK to 1e-10; no round goes through the dispatcher, and some targets are handed back to the numpy
reference (the kernel's hand-back path is taken).
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

import manipkit
import manipkit.closed_form.arms as arms_module
import manipkit.closed_form.srs as srs_module
import manipkit.ik.chain_ik as chain_ik_module
import manipkit.ik.dispatch as dispatch_module
from manipkit.ik.dispatch import ik, ik_many
from manipkit.ik.redundant import ranked_set

POSES = 200


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
    """The ranked sets of ``targets`` by the reference alone: the dispatcher round by round
    (``ranked_set(..., compiled=False)``) over the numpy 6R closed form (``solve_branches(..., compiled=False)``)."""
    original = chain_ik_module.solve_branches
    chain_ik_module.solve_branches = lambda arm, g, *, compiled=True: original(arm, g, compiled=False)
    try:
        return [ranked_set(robot, T, "base_link", "ee_link", solvers=(ik, ik_many), compiled=False) for T in targets]
    finally:
        chain_ik_module.solve_branches = original


def assert_same_sets(robot, targets, compiled, reference):
    """``compiled`` and ``reference`` (ranked sets of ``targets``) agree as the module docstring says; returns the
    rows compared."""
    rows = 0
    for T, new, old in zip(targets, compiled, reference):
        assert new.ranked_by == old.ranked_by and new.parameter == old.parameter
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
    return rows


def recorded(monkeypatch, robot, targets, reference_module, reference_name):
    """(the ranked sets of ``targets`` by ``manipkit.ik``, the dispatcher's batch calls, the calls of the numpy
    reference ``reference_module.reference_name`` made meanwhile)."""
    manipkit.ik(robot, targets[0], all=True)  # the compiled path's one probe of the dispatcher per chain
    dispatched, handed_back = [], []
    batch = dispatch_module.ik_many
    monkeypatch.setattr(dispatch_module, "ik_many", lambda *a, **k: dispatched.append(a) or batch(*a, **k))
    reference = getattr(reference_module, reference_name)
    monkeypatch.setattr(reference_module, reference_name, lambda *a: handed_back.append(a) or reference(*a))
    compiled = [manipkit.ik(robot, T, all=True) for T in targets]
    monkeypatch.undo()
    return compiled, dispatched, handed_back


@pytest.mark.parametrize("name, reference_module, reference_name", [("panda", arms_module, "solve_6r"),
                                                                    ("iiwa14", srs_module, "solve_srs_many")])
def test_the_compiled_ranked_sets_are_the_references_on_random_poses(name, reference_module, reference_name,
                                                                     monkeypatch):
    robot = manipkit.load(name)
    chain = robot.chain("base_link", "ee_link")
    targets = chain.fk(chain.sample(POSES, seed=36))
    compiled, dispatched, handed_back = recorded(monkeypatch, robot, targets, reference_module, reference_name)
    assert not dispatched  # one compiled call per pose, no round through the dispatcher
    if name == "panda":  # some targets near a threshold of the compiled closed form went to the numpy reference
        assert handed_back
    assert assert_same_sets(robot, targets, compiled, reference_sets(robot, targets)) >= 16 * POSES // 2


def test_an_iiwa14_pose_with_the_elbow_stretched_is_handed_back_and_gets_the_references_set(monkeypatch):
    # joint 4 at 0 (and 1e-9 off it): the elbow's subproblem 3 at its tangency, so the compiled SRS closed form
    # hands back every value of the arm angle (none of 200 random poses hands back one); the sweep's samples go to
    # the numpy reference at once, then each narrowing round's, and the set is the reference's
    robot = manipkit.load("iiwa14")
    chain = robot.chain("base_link", "ee_link")
    targets = chain.fk(np.array([[0.3, 0.5, -0.2, q4, 0.4, 0.8, 0.1] for q4 in (0.0, 1e-9)]))
    compiled, dispatched, handed_back = recorded(monkeypatch, robot, targets, srs_module, "solve_srs_many")
    assert not dispatched
    asked = [len(call[2]) for call in handed_back]
    assert asked[0] == 129 and len(asked) <= 2 * 20  # the sweep's 129 samples in one call, then rounds
    assert assert_same_sets(robot, targets, compiled, reference_sets(robot, targets)) == 32


@pytest.mark.parametrize("name", ["panda", "iiwa14"])
def test_a_target_whose_rotation_is_not_exact_gets_the_references_ranked_set(name):
    # check_transform takes a rotation block off by up to 1e-6; the compiled sweep takes exact ones (1e-12) only
    # and answers any other pose the way the reference does (the dispatcher round by round), bit for bit
    robot = manipkit.load(name)
    chain = robot.chain("base_link", "ee_link")
    T = chain.fk(chain.sample(1, seed=5))[0]
    T[:3, :3] *= 1.0 + 1e-9
    new = manipkit.ik(robot, T, all=True)
    old = ranked_set(robot, T, "base_link", "ee_link", solvers=(ik, ik_many), compiled=False)
    assert len(new.solutions) == len(old.solutions) >= 16
    np.testing.assert_array_equal(new.solutions, old.solutions)
    assert new.intervals == old.intervals and new.labels == old.labels
