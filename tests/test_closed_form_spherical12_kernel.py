"""The compiled "spherical wrist, two intersecting" closed form (closed_form.spherical12_kernel) gives the numpy
reference's answers (arms.solve_6r), and the Panda's ranked set built on it is the reference's.

The 6R arm is the Panda's with its last joint locked, solved at every value of its ranked set's sweep and
narrowing. Compared with the reference: the valid slots, their angles (modulo 2 pi, to 1e-9 rad), the misses and
which targets are handed back. The whole ranked set built on it (compiled with its sweep: ik.redundant_kernel) is
compared with the reference alone in tests/test_ik_redundant_kernel.py.
"""

import numpy as np
import pytest

import manipkit
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
