"""Global conditioning index (analysis.dexterity) against a quadrature of the 2R's hand-derived condition number."""

import numpy as np
import pytest

from manipkit.analysis.dexterity import generic_rank, global_conditioning_index
from manipkit.analysis.manipulability import MixedUnitsWarning
from manipkit.errors import ManipkitError


def inverse_condition_2r(l1, l2, q2):
    # Columns of J_xy: a = z x p (|a|^2 = |p|^2 = l1^2 + l2^2 + 2 l1 l2 cos q2) and b = z x (p - o2) (|b|^2 = l2^2),
    # so tr(J J^T) = |a|^2 + |b|^2 and det(J J^T) = (l1 l2 sin q2)^2; the squared singular values are
    # (tr +- sqrt(tr^2 - 4 det)) / 2 and 1/kappa is the square root of their ratio. q1 does not enter.
    tr = l1**2 + 2 * l2**2 + 2 * l1 * l2 * np.cos(q2)
    det = (l1 * l2 * np.sin(q2)) ** 2
    root = np.sqrt(np.maximum(tr**2 - 4 * det, 0.0))
    return np.sqrt((tr - root) / (tr + root))


def test_planar_2r_gci_equals_the_quadrature(load_robot):
    robot = load_robot("planar_2r", l1="0.7", l2="0.4")  # joint limits -pi..pi
    q2 = np.linspace(-np.pi, np.pi, 200_001)
    exact = np.trapezoid(inverse_condition_2r(0.7, 0.4, q2), q2) / (2 * np.pi)
    gci = global_conditioning_index(robot, 100_000, axes=[0, 1], seed=3, chunk=30_000)
    half = (gci.high - gci.low) / 2
    assert abs(gci.mean - exact) < 2 * half  # a seeded draw: not flaky
    assert half < 2e-3
    assert gci.length is None and gci.axes == (0, 1) and gci.samples == 100_000
    assert "95% confidence interval" in str(gci)


def test_the_estimate_does_not_depend_on_the_chunk_size(iiwa14):
    one = global_conditioning_index(iiwa14, 3000, axes="trans", seed=5, chunk=3000)
    many = global_conditioning_index(iiwa14, 3000, axes="trans", seed=5, chunk=701)
    assert one.mean == pytest.approx(many.mean, rel=1e-13, abs=0)
    assert one.std == pytest.approx(many.std, rel=1e-9)


def test_samples_are_uniform_inside_the_limits(iiwa14):
    # the GCI draws its configurations from the chain (Chain.sample, here from a Generator as it does)
    Q = iiwa14.chain("base_link", "ee_link").sample(20_000, seed=np.random.default_rng(0))
    lower = np.array([j.lower for j in iiwa14.joints])
    upper = np.array([j.upper for j in iiwa14.joints])
    assert np.all(Q >= lower) and np.all(Q <= upper)
    np.testing.assert_allclose(Q.mean(axis=0), (lower + upper) / 2, atol=0.05 * (upper - lower).max())


def test_progress_callable_and_length(iiwa14):
    calls = []
    gci = global_conditioning_index(iiwa14, 2500, seed=1, chunk=1000, length=0.4,
                                    progress=lambda stage, d, t: calls.append((stage, d, t)))
    assert calls == [("sampling the joint space", d, 2500) for d in (1000, 2000, 2500)]
    assert gci.length == 0.4 and 0.0 < gci.mean < 1.0
    with pytest.warns(MixedUnitsWarning):
        global_conditioning_index(iiwa14, 10, seed=1)


def test_progress_that_is_not_a_callable_is_refused(iiwa14):
    # the library does not draw bars (manipkit.app.progress does): True is not a progress callable
    with pytest.raises(ManipkitError, match="must be a callable progress"):
        global_conditioning_index(iiwa14, 100, axes="rot", progress=True)


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"samples": 1}, "at least 2"),
    ({"samples": 10.5}, "whole number"),
    ({"chunk": 0}, "chunk"),
    ({"confidence": 1.0}, "between 0 and 1"),
    ({"axes": "xyz"}, "axes='xyz'"),
    ({"length": 0.0}, "length 0: give a length in metres from 1e-09"),
])
def test_bad_arguments(planar_2r, kwargs, message):
    with pytest.raises(ManipkitError, match=message):
        global_conditioning_index(planar_2r, **{"samples": 10, **kwargs})


def test_fast_inverse_condition_equals_the_svd_one(iiwa14, planar_2r):
    from manipkit.analysis.dexterity import _inverse_condition
    from manipkit.analysis.manipulability import manipulability, select_rows
    from manipkit.kinematics.jacobian import jacobians

    for robot, axes in ((iiwa14, "all"), (iiwa14, "trans"), (planar_2r, "trans"), (planar_2r, [0, 1])):
        J = jacobians(robot, robot.sample_q(500, seed=8))
        np.testing.assert_allclose(_inverse_condition(select_rows(J, axes, 0.5)),
                                   manipulability(J, "invcondition", axes, 0.5), rtol=0, atol=1e-7)


def test_a_chain_or_a_robot_with_its_frames_give_the_same_index(load_robot):
    robot = load_robot("mobile_manipulator")
    chain = robot.chain("arm_base", "ee_link")
    by_chain = global_conditioning_index(chain, 3000, length=0.3, seed=2)
    by_robot = global_conditioning_index(robot, 3000, base="arm_base", tip="ee_link", length=0.3, seed=2)
    assert by_chain == by_robot and (by_chain.base, by_chain.frame) == ("arm_base", "ee_link")
    with pytest.raises(TypeError, match="positional argument"):  # the 0.1 positional frame, base: gone
        global_conditioning_index(robot, 3000, "ee_link", "arm_base", length=0.3, seed=2)


def test_generic_rank_of_the_planar_3r_by_hand(load_robot):
    # planar 3R: vz = wx = wy = 0 always, so translation rows have rank 2 (vx, vy) and all rows rank 3 (vx, vy, wz)
    chain = load_robot("planar_3r").chain("base_link", "ee_link")
    assert generic_rank(chain, axes="trans") == 2 and generic_rank(chain, axes="all", length=1.0) == 3
