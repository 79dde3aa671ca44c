"""A general 7R arm (no joint leaves a closed form) through the general 6R solver with one joint locked, and its
ranked set across the self-motion (manipkit.ik.general6r with lock=, manipkit.ik.redundant).

Arm: the Rethink Sawyer of the shared MuJoCo Menagerie copy (``rethink_robotics_sawyer/sawyer.xml``, loaded by
path through manipkit's MJCF reader; skipped when ../shared is not here). No Kinova Gen3 or Flexiv Rizon
description is in ../shared/realworld. Every row is checked by Pinocchio's forward kinematics
(``robot.transform``); the feasible set of the locked joint by a dense sweep written here (the general solver per
value through ``manipkit.ik(..., lock=...)``, counting distinct in-limit rows itself).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import manipkit
from manipkit.errors import IKOptionError

REALWORLD = next((base / "shared" / "realworld" for base in Path(__file__).resolve().parents[2:4]
                  if (base / "shared" / "realworld").is_dir()), Path("/nonexistent"))
SAWYER = REALWORLD / "menagerie" / "rethink_robotics_sawyer" / "sawyer.xml"
pytestmark = pytest.mark.skipif(not SAWYER.is_file(), reason=f"the shared real-world workspace is not here ({SAWYER})")
BASE, TIP = "base", "right_l6"
#: a configuration inside the limits whose pose has a long self-motion in right_j6 (14.5 rad of feasible tracks)
CASE = [-0.93, 0.51, -1.21, 1.62, 0.43, -0.87, 0.41]


@pytest.fixture(scope="module")
def sawyer():
    return manipkit.load(SAWYER)


def wrapped(a):
    return np.pi - np.mod(np.pi - np.asarray(a), 2 * np.pi)


def pinocchio_miss(robot, rows, T) -> float:
    """The largest entry of |T_reached - T| over the rows, by Pinocchio (robot.transform)."""
    return max((float(np.abs(robot.transform(BASE, TIP, q, check_limits=False) - T).max()) for q in rows), default=0.0)


@pytest.mark.parametrize(("joint", "poses"), [(6, 200), (0, 100), (3, 100)])
def test_a_locked_joint_is_held_every_row_lands_and_the_generating_configuration_is_found(sawyer, joint, poses):
    chain = sawyer.chain(BASE, TIP)
    name = chain.joint_names[joint]
    found, rows = 0, 0
    for q in chain.sample(poses, seed=40 + joint):
        T = sawyer.transform(BASE, TIP, q)
        result = manipkit.ik(sawyer, T, base=BASE, tip=TIP, all=True, lock={name: float(q[joint])})
        assert (result.method, result.arm_family, result.solver) == ("algebraic", "general 6R", "ik.general6r")
        Q = np.asarray(result.solutions)
        rows += len(Q)
        assert np.all(Q[:, joint] == q[joint])  # held at exactly its value
        assert pinocchio_miss(sawyer, Q, T) < 1e-10
        found += bool(len(Q)) and np.abs(wrapped(Q - q)).max(axis=1).min() < 1e-7
    assert found >= 0.99 * poses, (found, poses)
    assert rows > 2 * poses  # a general 6R arm has many solutions: not one row per pose


def test_the_algebraic_method_takes_one_lock_and_refuses_others(sawyer):
    chain = sawyer.chain(BASE, TIP)
    q = np.array(CASE)
    T = chain.fk(q)
    answer = manipkit.ik(sawyer, T, base=BASE, tip=TIP, all=True, method="algebraic", lock={"right_j2": q[2]})
    assert answer.method == "algebraic" and np.abs(wrapped(answer.solutions - q)).max(axis=1).min() < 1e-7
    with pytest.raises(IKOptionError, match="exactly one joint"):
        manipkit.ik(sawyer, T, base=BASE, tip=TIP, method="algebraic", lock={"right_j2": 0.1, "right_j3": 0.2})
    with pytest.raises(IKOptionError, match="not a joint"):
        manipkit.ik(sawyer, T, base=BASE, tip=TIP, method="algebraic", lock={"elbow": 0.1})
    with pytest.raises(IKOptionError, match="lock one of 7"):
        manipkit.ik(sawyer, T, base=BASE, tip=TIP, method="algebraic")
    with pytest.raises(IKOptionError, match="arm_angle"):
        manipkit.ik(sawyer, T, base=BASE, tip=TIP, method="algebraic", lock={"right_j2": 0.1}, arm_angle=0.2)
    with pytest.raises(IKOptionError, match="closed forms only"):
        manipkit.ik(sawyer, T, base=BASE, tip=TIP, method="numerical", lock={"right_j2": 0.1})
