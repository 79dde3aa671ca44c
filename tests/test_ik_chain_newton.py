"""The one Newton polisher on a true chain (manipkit.ik.chain_newton over manipkit.closed_form.newton_kernel),
checked against a Newton iteration written here on Pinocchio's own forward kinematics.

The reference below: the pose by ``pin.forwardKinematics`` + ``updateFramePlacements``, the error (position
difference, ``pin.log3(R_target R^T)``), the Jacobian by central differences of that pose (step 1e-7), the step
``pinv(J) e`` (for seven joints the least-norm step). Each row the polisher returns must land by Pinocchio to
1e-12 and be the reference's root to 1e-10.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import manipkit
from manipkit.closed_form.newton_kernel import polish_rows, polish_targets
from manipkit.ik.chain_newton import newton_rows
from manipkit.ik.families import chain_family


def pinocchio_pose(robot, chain, q):
    """T_base_tip of the chain's joint vector ``q`` by Pinocchio itself."""
    model = robot.model
    data = model.createData()
    pin.forwardKinematics(model, data, robot.pinocchio_configuration(chain.full(q)))
    pin.updateFramePlacements(model, data)
    placement = lambda name: data.oMf[model.getFrameId(robot.frame(name))].homogeneous  # noqa: E731
    return np.linalg.inv(placement(chain.base)) @ placement(chain.tip)


def pinocchio_error(robot, chain, T, q):
    reached = pinocchio_pose(robot, chain, q)
    return np.concatenate([T[:3, 3] - reached[:3, 3], pin.log3(T[:3, :3] @ reached[:3, :3].T)])


def reference_newton(robot, chain, T, q, columns, steps):
    """Newton on Pinocchio's FK, the Jacobian of the error by central differences, over ``columns`` only."""
    q = np.array(q, dtype=float)
    for _ in range(steps):
        e = pinocchio_error(robot, chain, T, q)
        if np.abs(e).max() < 1e-14:
            break
        J = np.empty((6, len(columns)))
        for k, c in enumerate(columns):
            dq = np.zeros_like(q)
            dq[c] = 1e-7
            J[:, k] = -(pinocchio_error(robot, chain, T, q + dq) - pinocchio_error(robot, chain, T, q - dq)) / 2e-7
        q[columns] += np.linalg.pinv(J) @ e
    return q


def starts(chain, count, seed, spread=2e-3):
    rng = np.random.default_rng(seed)
    Q = chain.sample(count, seed=seed)
    return Q, Q + rng.uniform(-spread, spread, Q.shape)


@pytest.mark.parametrize("name, tip_of", [("xarm7", "snapped 6R"), ("ur5", "6R"), ("iiwa14", "7R")])
def test_rows_land_by_pinocchio_and_are_the_reference_newton_roots(name, tip_of):
    robot = manipkit.load(name)
    whole = robot.chain("base_link", "ee_link")
    chain = robot.chain("base_link", whole.joints[6].parent) if tip_of == "snapped 6R" else whole
    geometry = chain_family(chain).geometry
    if tip_of == "snapped 6R":
        assert chain_family(chain).snap  # the xArm7's arm is its family's only within the tolerance
    Q, Q_start = starts(chain, 6, seed=36)
    T = chain.fk(Q)
    rows = newton_rows(geometry, T, Q_start, iterations=20)
    for q, target, start, row in zip(Q, T, Q_start, rows):
        position, rotation = np.abs(pinocchio_error(robot, chain, target, row)).reshape(2, 3).max(axis=1)
        assert position < 1e-12 and rotation < 1e-12
        expected = reference_newton(robot, chain, target, start, geometry.columns, 20)
        assert np.abs(row - expected).max() < 1e-9
        if len(geometry.columns) == 6:  # a 6R arm's root near the start is the generating configuration
            assert np.abs(row - q).max() < 1e-9


def test_seven_joints_take_the_least_norm_step():
    robot = manipkit.load("iiwa14")
    chain = robot.chain("base_link", "ee_link")
    geometry = chain_family(chain).geometry
    Q, Q_start = starts(chain, 4, seed=5, spread=1e-4)
    T = chain.fk(Q)
    one = newton_rows(geometry, T, Q_start, iterations=1)
    for target, start, row in zip(T, Q_start, one):
        J = np.empty((6, 7))
        for c in range(7):
            dq = np.zeros(7)
            dq[c] = 1e-7
            J[:, c] = -(pinocchio_error(robot, chain, target, start + dq)
                        - pinocchio_error(robot, chain, target, start - dq)) / 2e-7
        step = np.linalg.pinv(J) @ pinocchio_error(robot, chain, target, start)
        assert np.abs((row - start) - step).max() < 1e-8 * max(1.0, np.abs(step).max())
        # least norm: no part of the step along the self-motion (the Jacobian's null space)
        null = np.linalg.svd(J)[2][-1]
        assert abs(null @ (row - start)) < 1e-9


def test_a_locked_joint_stays_and_the_others_reach_the_target():
    robot = manipkit.load("xarm7")
    chain = robot.chain("base_link", "ee_link")
    name = chain.joint_names[3]
    Q, Q_start = starts(chain, 4, seed=11)
    for q, start in zip(Q, Q_start):
        start[3] = q[3]
        geometry = chain_family(chain, lock={name: float(q[3])}).geometry
        assert 3 not in geometry.columns.tolist()
        row = newton_rows(geometry, chain.fk(q), start[None], iterations=20)[0]
        assert row[3] == q[3]
        assert np.abs(pinocchio_error(robot, chain, chain.fk(q), row)).max() < 1e-12


def test_polish_rows_is_polish_targets_with_one_target():
    rng = np.random.default_rng(3)
    h = rng.normal(size=(6, 3))
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    p = rng.normal(size=(6, 3))
    from manipkit.closed_form.general6r import poe_fk

    theta = rng.uniform(-3.0, 3.0, 6)
    G = poe_fk(h, p, theta)
    start = theta + rng.uniform(-0.05, 0.05, (5, 6))
    start[2] += 2.0  # far: dropped
    rows, residual = polish_rows(h, p, G, start, iterations=8, far=0.5)
    every, residual_all, kept = polish_targets(h, p, G, start, iterations=8, far=0.5)
    assert kept.tolist() == [True, True, False, True, True]
    assert np.array_equal(rows, every[kept]) and np.array_equal(residual, residual_all[kept])
    assert np.abs(rows - theta).max() < 1e-12
