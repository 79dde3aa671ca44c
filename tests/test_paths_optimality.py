"""plan_path is optimal for its cost: the same answer as an independent search over EAIK's solutions.

For 20 random UR5 lines: every IK solution EAIK (PyPI ``eaik``, in the dev extra) gives at every waypoint, every
in-limit 2 pi alias of each (enumerated here), the same edge rule (every |dq_j| <= v_j dt, v_j the URDF velocity
limit, dt the step's length over the speed) and a plain dynamic program written here: the same feasibility and
the same least summed joint motion, to 1e-9. The between-waypoint path check is switched off (a tolerance of
10 m) so that both search the same ladder.
"""

from __future__ import annotations

import itertools
import math

import eaik.IK_URDF as eaik_urdf  # in the dev extra: a missing EAIK fails the suite, it never skips
import numpy as np
import pytest

import manipkit
from manipkit.paths.plan import plan_path


def aliases(q, lower, upper):
    """Every q + 2 pi k (per joint, k in -2..2) inside [lower, upper]."""
    per_joint = [[v + 2 * math.pi * k for k in range(-2, 3) if lower[j] <= v + 2 * math.pi * k <= upper[j]]
                 for j, v in enumerate(q)]
    return [list(c) for c in itertools.product(*per_joint)]


def plain_dp(rungs, bound):
    """Least sum |dq| through the rungs with |dq_j| <= bound[i][j] on every step; inf when no path.

    Every pair of consecutive rungs is tried (numpy over the pairs of one step, no pruning)."""
    width = len(bound[0])
    cost = np.zeros(len(rungs[0]))
    for i in range(1, len(rungs)):
        a = np.asarray(rungs[i - 1], dtype=float).reshape(-1, width)
        b = np.asarray(rungs[i], dtype=float).reshape(-1, width)
        d = np.abs(b[:, None, :] - a[None, :, :])  # d[new, old, joint]
        allowed = (d <= np.asarray(bound[i - 1])).all(axis=2) & np.isfinite(cost)[None, :]
        cost = np.where(allowed, cost[None, :] + d.sum(axis=2), math.inf).min(axis=1, initial=math.inf)
    return float(cost.min(initial=math.inf))


@pytest.fixture(scope="module")
def setup():
    robot = manipkit.load("ur5")
    chain = robot.chain("base_link", "tool0")
    bot = eaik_urdf.UrdfRobot(str(robot.source.path))
    q = chain.sample(1, seed=0)[0]
    X = np.linalg.inv(np.asarray(bot.fwdKin(q))) @ chain.fk(q)  # EAIK's end frame -> tool0, fixed on the last link
    other = chain.sample(1, seed=1)[0]
    assert np.abs(np.asarray(bot.fwdKin(other)) @ X - chain.fk(other)).max() <= 1e-12  # the same offset elsewhere
    return chain, bot, X


@pytest.mark.parametrize("seed", range(20))
def test_same_cost_as_a_plain_search_over_eaik(setup, seed):
    chain, bot, X = setup
    rng = np.random.default_rng(seed)
    q0 = chain.sample(1, seed=100 + seed)[0]
    direction = rng.normal(size=3)
    direction /= np.linalg.norm(direction)
    speed = float(rng.uniform(0.05, 0.4))
    T0 = np.asarray(bot.fwdKin(q0))
    poses_eaik = np.repeat(T0[None], 6, axis=0)
    poses_eaik[:, :3, 3] += 0.01 * np.arange(6)[:, None] * direction  # 1 cm steps, orientation fixed
    lower, upper = np.asarray(chain.lower), np.asarray(chain.upper)
    rungs = []
    for T in poses_eaik:
        answer = bot.IK(T)
        exact = np.atleast_2d(answer.Q)[~np.asarray(answer.is_LS, dtype=bool).reshape(-1)]
        exact = [q for q in exact if np.abs(np.asarray(bot.fwdKin(q)) - T).max() <= 1e-9]
        rungs.append([a for q in exact for a in aliases(q, lower, upper)])
    limits = np.array([3.15, 3.15, 3.15, 3.2, 3.2, 3.2])  # the URDF's velocity limits (ur5_robot.urdf)
    bound = [list(limits * 0.01 / speed)] * 5
    expected = plain_dp(rungs, bound)
    plan = plan_path(chain, poses_eaik @ X, speed=speed, path_tol=(10.0, 10.0))
    assert plan.feasible == math.isfinite(expected)  # 18 of the 20 seeds are feasible, 2 are not (too fast)
    if plan.feasible:
        assert plan.cost == pytest.approx(expected, abs=1e-9)
