"""Deviation re-planning of :func:`manipkit.paths.plan.plan_path` (issue 39): eager per rung pair, and said when unfinished.

The planner checks a chosen step between waypoints for deviation (the joint-interpolated points at ``k / 16``,
``k = 1..15``, within ``path_tol`` of the Cartesian path); the first time a step between two rungs deviates, every
pair of their candidates the velocity bound lets pass is checked at once and the deviating ones forbidden, so the
deviation re-plans are at most one per rung pair. Checked here against a brute force written in the test: every
edge of the ladder checked for deviation up front (its own interpolation: position linear, rotation
``R_a expm(s log(R_a^T R_b))``, distance by the rotation angle ``arccos((tr R - 1) / 2)``), then a plain dynamic
program over the candidates.

The cases (UR5 of example-robot-data, base_link -> tool0) are lines of 6 waypoints near the wrist singularity
(q5 near 0), found by a seeded search: ``FEASIBLE`` needs a re-plan (its cheapest path flips the wrist between
waypoints) and stays feasible; ``BLOCKED`` is feasible without the check and proven blocked with it.
"""

from __future__ import annotations

import numpy as np
import pytest

import manipkit
from manipkit.paths.plan import FAILURE_KINDS, plan_path
from manipkit.paths.poses import interpolate_poses
from manipkit.paths.rungs import build_rungs, ik_source, tool_rotations

Q_FEASIBLE = np.array([-0.7905, -1.1109, 0.8564, -1.9693, 0.1026, 1.2386])
D_FEASIBLE = np.array([-0.08217015, 0.01053751, -0.07334831])
Q_TIMED = np.array([-4.55270912, -3.74961081, 1.85088472, -2.39144618, -3.76915605, -1.26757838])
D_TIMED = np.array([-0.25011738, -0.06922526, 0.13415508])
Q_BLOCKED = np.array([0.4627, 0.8718, 0.687, -2.5369, 0.1296, 0.8291])
D_BLOCKED = np.array([-0.11476894, -0.07634195, -0.11589982])


@pytest.fixture(scope="module")
def chain():
    return manipkit.load("ur5").chain("base_link", "tool0")


def line(chain, q, displacement, n=6):
    T0 = chain.fk(q)
    poses = np.repeat(T0[None], n, axis=0)
    poses[:, :3, 3] += np.linspace(0.0, 1.0, n)[:, None] * np.asarray(displacement)
    return poses


def deviating(chain, Qa, Qb, Ta, Tb, tol=(1e-3, np.pi / 180), depth=4) -> np.ndarray:
    """(len(Qa), len(Qb)) bools: the step Qa[a] -> Qb[b] leaves the path Ta -> Tb at one of the fractions
    k / 2**depth, k = 1 .. 2**depth - 1 (written out here; every pair's joint-space straight line by FK)."""
    s = np.arange(1, 2 ** depth) / 2 ** depth
    Q = Qa[:, None, None, :] + s[None, None, :, None] * (Qb[None, :, None, :] - Qa[:, None, None, :])
    T = chain.fk(Q.reshape(-1, Qa.shape[1])).reshape(len(Qa), len(Qb), len(s), 4, 4)
    wanted = interpolate_poses(Ta, Tb, s)  # (len(s), 4, 4)
    position = np.linalg.norm(T[..., :3, 3] - wanted[:, :3, 3], axis=-1)
    cos = (np.einsum("fji,abfji->abf", wanted[:, :3, :3], T[..., :3, :3]) - 1.0) / 2.0
    return ((position > tol[0]) | (np.arccos(np.clip(cos, -1.0, 1.0)) > tol[1])).any(axis=-1)


def leaves_path(chain, qa, qb, Ta, Tb) -> bool:
    """The one step qa -> qb leaves the path Ta -> Tb (:func:`deviating`)."""
    return bool(deviating(chain, np.atleast_2d(qa), np.atleast_2d(qb), Ta, Tb)[0, 0])


def brute_force(chain, poses, *, aliases, speed=None):
    """Every edge checked for speed and deviation, then the dynamic program: (feasible, cost, first rung none of
    whose candidates is reached or None)."""
    rungs = build_rungs(chain, poses, tool_rotations(None, np.zeros(1)), source=ik_source(chain.robot, chain.base,
                        chain.tip), arm_angles=None, tol=1e-9, aliases=aliases, restarts=20, seed=0)
    model = chain.robot.model  # the UR5's 6 joints are the model's 6 velocity entries, in chain order
    limits = np.array([model.velocityLimit[model.joints[model.getJointId(name)].idx_v] for name in chain.joint_names])
    cost = np.zeros(len(rungs.Q[0]))
    first_dead = None if len(cost) else 0
    for i in range(len(poses) - 1):
        Qa, Qb = rungs.Q[i], rungs.Q[i + 1]
        dt = np.inf if speed is None else np.linalg.norm(poses[i + 1, :3, 3] - poses[i, :3, 3]) / speed
        motion = np.abs(Qb[None, :, :] - Qa[:, None, :])  # (a, b, joint)
        allowed = (motion <= limits * dt).all(axis=-1) & ~deviating(chain, Qa, Qb, poses[i], poses[i + 1])
        through = np.where(allowed, cost[:, None] + motion.sum(axis=-1), np.inf)  # (a, b)
        cost = through.min(axis=0) if len(Qa) else np.full(len(Qb), np.inf)
        if first_dead is None and not np.isfinite(cost).any():
            first_dead = i + 1
    best = float(cost.min()) if len(cost) else np.inf
    return bool(np.isfinite(best)), best, first_dead


@pytest.mark.parametrize("aliases", [False, True])
def test_the_plan_is_the_brute_force_over_every_checked_edge(chain, aliases):
    poses = line(chain, Q_FEASIBLE, D_FEASIBLE)
    plan = plan_path(chain, poses, aliases=aliases)
    feasible, cost, _ = brute_force(chain, poses, aliases=aliases)
    assert feasible and plan.feasible
    assert plan.cost == pytest.approx(cost, abs=1e-9)
    # the path takes none of the deviating steps: the brute force's own check on every step of it
    assert not any(leaves_path(chain, plan.q[i], plan.q[i + 1], poses[i], poses[i + 1]) for i in range(5))
    assert 1 <= plan.replans <= len(poses) - 1  # at most one deviation re-plan per rung pair


def test_without_the_check_the_cheapest_path_leaves_the_path(chain):
    # the case needs the check: the least motion over the candidates, steps unchecked, is cheaper and deviates
    poses = line(chain, Q_FEASIBLE, D_FEASIBLE)
    loose = plan_path(chain, poses, aliases=False, path_tol=10.0)
    plan = plan_path(chain, poses, aliases=False)
    assert loose.replans == 0 and loose.cost < plan.cost - 1e-6
    assert any(leaves_path(chain, loose.q[i], loose.q[i + 1], poses[i], poses[i + 1]) for i in range(5))


def test_running_out_of_replans_is_reported_as_unfinished(chain):
    poses = line(chain, Q_FEASIBLE, D_FEASIBLE)
    plan = plan_path(chain, poses, aliases=False, max_replans=0)
    assert not plan.feasible and plan.first_failure is None and plan.resolution["unfinished"]
    records = [(i, f) for i, waypoint in enumerate(plan.failures) for f in waypoint if f.kind == "unfinished"]
    assert "unfinished" in FAILURE_KINDS
    assert len(records) == 1 and records[0][1].count == 0
    # where the cheapest (unchecked) path first leaves the path: the waypoint its deviating step enters
    loose = plan_path(chain, poses, aliases=False, path_tol=10.0)
    first = next(i for i in range(5) if leaves_path(chain, loose.q[i], loose.q[i + 1], poses[i], poses[i + 1]))
    assert records[0][0] == first + 1


def test_a_path_blocked_after_replans_is_proven_blocked_not_unfinished(chain):
    poses = line(chain, Q_BLOCKED, D_BLOCKED)
    assert plan_path(chain, poses, aliases=False, path_tol=10.0).feasible  # blocked only by the deviation check
    plan = plan_path(chain, poses, aliases=False)
    feasible, _, first_dead = brute_force(chain, poses, aliases=False)
    assert not feasible and first_dead is not None
    assert not plan.feasible and plan.replans >= 1
    assert plan.first_failure == first_dead  # exact: the first waypoint the brute force reaches no candidate of
    assert plan.resolution["unfinished"] is False
    assert not any(f.kind == "unfinished" for waypoint in plan.failures for f in waypoint)
    assert any(f.kind == "deviation" for f in plan.failures[first_dead])


def test_first_failure_is_exact_when_steps_leave_the_path(chain):
    # timed at 0.2 m/s: every candidate of waypoint 4 is cut off (too fast, or every step in leaves the path); main
    # named waypoint 5, the deviating steps into 4 never having been chosen
    poses = line(chain, Q_TIMED, D_TIMED)
    plan = plan_path(chain, poses, speed=0.2, aliases=False)
    feasible, _, first_dead = brute_force(chain, poses, aliases=False, speed=0.2)
    assert not feasible and not plan.feasible
    assert plan.first_failure == first_dead == 4
    assert plan.resolution["unfinished"] is False
