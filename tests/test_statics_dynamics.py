"""Torques along a trajectory (manipkit.statics.dynamics) against pinocchio.rnea called directly and a planar 2R
derived by hand; the CLI's --trajectory."""

import json

import numpy as np
import pinocchio as pin
import pytest
from cli_helper import run_cli
from test_statics_torques import L1, M1, M2, R1, R2, point_mass_2r

import manipkit
from manipkit.errors import OptionError
from manipkit.statics.dynamics import trajectory_torques
from manipkit.statics.torques import Payload, static_torques

G = 9.81


def smooth_trajectory(chain, T=12, seed=0):
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 1, T)
    a, w = rng.uniform(-0.8, 0.8, chain.n), rng.uniform(1, 4, chain.n)
    Q = a * np.sin(np.outer(t, w))
    return t, Q, a * w * np.cos(np.outer(t, w)), -a * w * w * np.sin(np.outer(t, w))


@pytest.mark.parametrize("name", ["iiwa14", "ur5"])
def test_equals_pinocchio_rnea(load_robot, name):
    robot = load_robot(name)
    chain = robot.chain(robot.root_link, "ee_link")
    t, Q, Qd, Qdd = smooth_trajectory(chain)
    answer = trajectory_torques(chain, Q, Qd, Qdd, times=t)
    data = robot.model.createData()
    for k in range(len(t)):
        expected = pin.rnea(robot.model, data, robot.pinocchio_configuration(Q[k]), Qd[k], Qdd[k])
        np.testing.assert_allclose(answer.tau[k], expected, rtol=0, atol=1e-10)
        g = pin.computeGeneralizedGravity(robot.model, data, robot.pinocchio_configuration(Q[k]))
        np.testing.assert_allclose(answer.gravity[k], g, rtol=0, atol=1e-10)
        M = pin.crba(robot.model, data, robot.pinocchio_configuration(Q[k]))
        M = np.triu(M) + np.triu(M, 1).T
        np.testing.assert_allclose(answer.inertial[k], M @ Qdd[k], rtol=0, atol=1e-10)
    total = sum(answer.share[part] for part in ("gravity", "inertial", "coriolis"))
    np.testing.assert_allclose(total[np.isfinite(total)], 1.0, rtol=0, atol=1e-12)


def test_panda_folds_the_mimic_finger_and_holds_it(panda):
    chain = panda.chain("base_link", "ee_link")
    _, Q, Qd, Qdd = smooth_trajectory(chain, T=4, seed=1)
    answer = trajectory_torques(chain, Q, Qd, Qdd)
    data = panda.model.createData()
    for k in range(4):
        whole = chain.full(Q[k])
        v = np.zeros(panda.model.nv)
        a = np.zeros(panda.model.nv)
        v[:7], a[:7] = Qd[k], Qdd[k]  # the arm's joints are the first seven velocity entries; the fingers rest
        expected = pin.rnea(panda.model, data, panda.pinocchio_configuration(whole), v, a)[:7]
        np.testing.assert_allclose(answer.tau[k], expected, rtol=0, atol=1e-10)


def test_planar_2r_point_masses_by_hand(tmp_path):
    """Point masses M1 at R1, M2 at R2, gravity -y: with h = M2 L1 R2 sin(t2),
    tau1 = [M1 R1^2 + M2 (L1^2 + R2^2 + 2 L1 R2 c2)] a1 + M2 (R2^2 + L1 R2 c2) a2 - h (2 w1 w2 + w2^2) + g1,
    tau2 = M2 (R2^2 + L1 R2 c2) a1 + M2 R2^2 a2 + h w1^2 + g2 (g1, g2 as in test_statics_torques)."""
    path = tmp_path / "p2r.urdf"
    path.write_text(point_mass_2r(effort=1e6))
    robot = manipkit.load(str(path))
    Q = np.array([[0.3, -0.7], [1.2, 0.4]])
    Qd = np.array([[0.5, -1.5], [2.0, 0.7]])
    Qdd = np.array([[1.0, 3.0], [-2.0, 0.5]])
    answer = trajectory_torques(robot, Q, Qd, Qdd, gravity=(0, -G, 0))
    for k in range(2):
        (t1, t2), (w1, w2), (a1, a2) = Q[k], Qd[k], Qdd[k]
        c2, h = np.cos(t2), M2 * L1 * R2 * np.sin(t2)
        g1 = G * ((M1 * R1 + M2 * L1) * np.cos(t1) + M2 * R2 * np.cos(t1 + t2))
        g2 = G * M2 * R2 * np.cos(t1 + t2)
        m11 = M1 * R1 ** 2 + M2 * (L1 ** 2 + R2 ** 2 + 2 * L1 * R2 * c2)
        m12, m22 = M2 * (R2 ** 2 + L1 * R2 * c2), M2 * R2 ** 2
        np.testing.assert_allclose(answer.gravity[k], [g1, g2], rtol=0, atol=1e-10)
        np.testing.assert_allclose(answer.inertial[k], [m11 * a1 + m12 * a2, m12 * a1 + m22 * a2], rtol=0, atol=1e-10)
        np.testing.assert_allclose(answer.coriolis[k], [-h * (2 * w1 * w2 + w2 ** 2), h * w1 ** 2], rtol=0, atol=1e-10)


def test_at_rest_it_is_the_static_torque_with_the_payload(iiwa14):
    chain = iiwa14.chain("base_link", "ee_link")
    Q = chain.sample(5, seed=3)
    payload = Payload(2.0, (0, 0.03, 0.1), np.diag([0.01, 0.02, 0.03]))
    answer = trajectory_torques(chain, Q, np.zeros_like(Q), np.zeros_like(Q), payload=payload)
    static = static_torques(chain, Q, payload=payload)
    np.testing.assert_allclose(answer.tau, static.tau, rtol=0, atol=1e-10)


def test_first_sample_over_an_effort_limit(iiwa14):
    chain = iiwa14.chain("base_link", "ee_link")
    t, Q, Qd, Qdd = smooth_trajectory(chain, T=10, seed=4)
    Qdd[6, 5] = 4000.0  # joint 6 (40 N m) is kicked at sample 6
    answer = trajectory_torques(chain, Q, Qd, Qdd, times=t)
    over = np.abs(answer.tau) > answer.effort_limit
    first = int(np.flatnonzero(over.any(axis=1))[0])
    assert answer.first_over == (first, chain.joint_names[int(np.flatnonzero(over[first])[0])])
    assert first <= 6


@pytest.mark.parametrize("kwargs, error", [({"times": [0, 1, 1]}, "increasing"), ({"gravity": (0, 0)}, "gravity")])
def test_bad_trajectories_are_refused(iiwa14, kwargs, error):
    Q = np.zeros((3, 7))
    with pytest.raises(OptionError, match=error):
        trajectory_torques(iiwa14, Q, Q, Q, **kwargs)


def test_cli_trajectory_json_matches_the_library(tmp_path, iiwa14):
    path = tmp_path / "traj.csv"
    path.write_text("# joint 2 swinging, the others at rest (joint 4 from --q)\nt,iiwa_joint_2,iiwa_joint_2.qd,"
                    "iiwa_joint_2.qdd\n0,0.1,0.5,1.0\n0.1,0.2,0.6,20\n0.2,0.3,0.7,300\n")
    report = json.loads(run_cli("manipkit", "torques", "--robot", "iiwa14", "--q", "iiwa_joint_4=0.4",
                                "--trajectory", str(path), "--format", "json", status=0).stdout)
    Q = np.zeros((3, 7))
    Q[:, 1], Q[:, 3] = [0.1, 0.2, 0.3], 0.4
    Qd, Qdd = np.zeros((3, 7)), np.zeros((3, 7))
    Qd[:, 1], Qdd[:, 1] = [0.5, 0.6, 0.7], [1.0, 20.0, 300.0]
    expected = trajectory_torques(iiwa14, Q, Qd, Qdd, times=[0, 0.1, 0.2])
    np.testing.assert_allclose(report["tau"], expected.tau, rtol=0, atol=1e-12)
    assert report["first_over"] == {"sample": 2, "time": 0.2, "joint": "iiwa_joint_2"}
    bad = tmp_path / "bad.csv"
    bad.write_text("t,iiwa_joint_9\n0,1\n")
    result = run_cli("manipkit", "torques", "--robot", "iiwa14", "--trajectory", str(bad), status=2)
    assert "line 1: unknown column iiwa_joint_9" in result.stderr and result.stderr.count("\n") == 1
