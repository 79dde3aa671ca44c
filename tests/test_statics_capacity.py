"""Payload capacity (manipkit.statics.capacity): the closed form checked by its round trip through static_torques,
by hand on a planar 2R, and its edge cases (vanishing lever arms, asymmetric limits, gravity alone saturating)."""

import numpy as np
import pytest

import manipkit
from manipkit.errors import OptionError
from manipkit.statics.capacity import capacity_from_parts, payload_capacity
from manipkit.statics.torques import Payload, Wrench, static_torques


@pytest.mark.parametrize("cog", [(0.0, 0.0, 0.0), (0.0, 0.0, 0.15), (0.1, -0.05, 0.2)])
def test_round_trip_at_the_capacity_the_saturating_joint_is_at_its_limit(iiwa14, cog):
    chain = iiwa14.chain("base_link", "ee_link")
    for q in chain.sample(20, seed=3):
        cap = payload_capacity(chain, q, cog=cog)
        assert not cap.gravity_saturates and np.isfinite(cap.max_mass) and cap.max_mass > 0
        k = int(cap.saturating)
        at = static_torques(chain, q, payload=Payload(float(cap.max_mass), cog))
        assert abs(abs(at.tau[k]) - at.effort_limit[k]) < 1e-9
        assert np.all(np.abs(at.tau) <= at.effort_limit + 1e-9)
        above = static_torques(chain, q, payload=Payload(float(cap.max_mass) * (1 + 1e-6) + 1e-9, cog))
        assert abs(above.tau[k]) > above.effort_limit[k]


def test_asymmetric_limits_bound_each_side(iiwa14):
    chain = iiwa14.chain("base_link", "ee_link")
    q = chain.sample(1, seed=11)[0]
    limits = static_torques(chain, q).effort_limit
    lower, upper = -0.5 * limits, 2.0 * limits
    cap = payload_capacity(chain, q, cog=(0, 0, 0.1), effort=(lower, upper))
    k = int(cap.saturating)
    tau = static_torques(chain, q, payload=Payload(float(cap.max_mass), (0, 0, 0.1))).tau
    assert min(abs(tau[k] - lower[k]), abs(tau[k] - upper[k])) < 1e-9
    assert np.all(tau >= lower - 1e-9) and np.all(tau <= upper + 1e-9)


def point_capacity_2r(path):
    text = ('<robot name="p2r"><link name="base_link"/>'
            '<link name="link1"><inertial><origin xyz="0.5 0 0"/><mass value="1"/>'
            '<inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial></link>'
            '<link name="link2"/><link name="ee_link"/>'
            '<joint name="joint1" type="revolute"><parent link="base_link"/><child link="link1"/><axis xyz="0 0 1"/>'
            '<limit lower="-3" upper="3" effort="40" velocity="1"/></joint>'
            '<joint name="joint2" type="revolute"><parent link="link1"/><child link="link2"/><origin xyz="1 0 0"/>'
            '<axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="5" velocity="1"/></joint>'
            '<joint name="tool" type="fixed"><parent link="link2"/><child link="ee_link"/><origin xyz="1 0 0"/>'
            '</joint></robot>')
    path.write_text(text)
    return manipkit.load(str(path))


def test_planar_2r_by_hand_and_a_vanishing_lever_arm(tmp_path):
    """Links of 1 m, 1 kg at 0.5 m on link 1, effort 40 and 5 N m, gravity -y (9.81).

    Stretched along x (q = 0): joint 1 holds 9.81 (0.5 + 2 m), joint 2 holds 9.81 m: m <= 40/(2 9.81) - 0.25 = 1.7887
    on joint 1, m <= 5/9.81 = 0.5097 on joint 2: joint 2 saturates. Link 2 up (q = (0, pi/2)): joint 2 has no lever
    arm (b_2 = 0) and joint 1 holds 9.81 (0.5 + m): m <= 40/9.81 - 0.5 = 3.5775, finite.
    """
    robot = point_capacity_2r(tmp_path / "p2r.urdf")
    g = (0.0, -9.81, 0.0)
    cap = payload_capacity(robot, [0.0, 0.0], gravity=g)
    assert cap.saturating_joint == "joint2" and abs(cap.max_mass - 5 / 9.81) < 1e-12
    cap = payload_capacity(robot, [0.0, np.pi / 2], gravity=g)
    assert cap.saturating_joint == "joint1" and abs(cap.max_mass - (40 / 9.81 - 0.5)) < 1e-12
    over = payload_capacity(robot, [0.0, 0.0], gravity=(0.0, -90.0, 0.0))  # 90 (0.5) = 45 > 40 N m unloaded
    assert over.gravity_saturates and over.max_mass == 0 and over.saturating_joint == "joint1"
    none = payload_capacity(robot, [0.0, 0.0], gravity=(0.0, 0.0, -9.81))  # across the plane: nothing to hold
    assert none.saturating_joint is None and np.isinf(none.max_mass)
    pushed = payload_capacity(robot, [0.0, 0.0], gravity=g, wrench=Wrench((0, 2.0, 0, 0, 0, 0)))  # 2 N up helps
    assert abs(pushed.max_mass - (5 + 2) / 9.81) < 1e-12  # joint 2: 9.81 m - 2 <= 5


def test_capacity_from_parts_is_batched():
    a = np.array([[1.0, -1.0], [5.0, 0.0]])
    b = np.array([[1.0, -2.0], [1.0, 0.0]])
    m, k, over = capacity_from_parts(a, b, np.array([-3.0, -3.0]), np.array([3.0, 3.0]))
    np.testing.assert_allclose(m, [1.0, 0.0])  # row 0: joint 1 (-1 - 2 m >= -3); row 1: gravity saturates joint 0
    assert k.tolist() == [1, 0] and over.tolist() == [False, True]


def test_a_capacity_needs_effort_limits(course_arm):
    with pytest.raises(OptionError, match="needs them"):
        payload_capacity(course_arm, course_arm.q())


@pytest.mark.parametrize("effort, error", [([1.0] * 3, "give 7 limits"), (np.zeros(7), "must be > 0"),
                                           ((np.ones(7), -np.ones(7)), "below its upper")])
def test_bad_effort_limits_are_refused(iiwa14, effort, error):
    with pytest.raises(OptionError, match=error):
        payload_capacity(iiwa14, iiwa14.q(), effort=effort)


def test_the_diagram_is_the_worst_capacity_over_the_configurations(iiwa14):
    from manipkit.statics.diagram import payload_diagram

    chain = iiwa14.chain("base_link", "ee_link")
    Q = chain.sample(60, seed=7)
    offsets = [0.0, 0.1, 0.25]
    diagram = payload_diagram(chain, offsets, Q=Q, direction=(0, 1, 1))
    for d, worst, median, joint, where in zip(offsets, diagram.worst, diagram.median, diagram.worst_joint,
                                              diagram.worst_configuration):
        cap = payload_capacity(chain, Q, cog=d * np.array([0, 1, 1]) / np.sqrt(2))
        i = int(np.argmin(cap.max_mass))
        assert abs(worst - cap.max_mass[i]) < 1e-12 and abs(median - np.median(cap.max_mass)) < 1e-12
        assert joint == chain.joint_names[int(cap.saturating[i])]
        np.testing.assert_array_equal(where, Q[i])
    assert list(diagram.worst) == sorted(diagram.worst, reverse=True)


def _capacity_numpy(a, b, lower, upper, lever_tol=1e-12):
    """The module's rule written with numpy over whole arrays (the compiled pass must give these numbers to the bit)."""
    limited = ~np.isnan(lower) & ~np.isnan(upper)
    over = limited & ((a > upper) | (a < lower))
    with np.errstate(divide="ignore", invalid="ignore"):
        bound = np.where(b > 0, (upper - a) / b, (lower - a) / b)
    bound = np.where(limited & (np.abs(b) > lever_tol), bound, np.inf)
    bound = np.where(over, 0.0, bound)
    saturating = np.where(over.any(axis=-1), np.argmax(over, axis=-1), np.argmin(bound, axis=-1))
    max_mass = np.min(bound, axis=-1)
    return np.maximum(max_mass, 0.0), np.where(np.isinf(max_mass), -1, saturating), over.any(axis=-1)


@pytest.mark.parametrize("lever_tol", [1e-12, 0.0, 0.5])
def test_capacity_from_parts_is_the_numpy_rule_to_the_bit(lever_tol):
    """Random rows with the edge cases mixed in: a torque at its limit (a tie), no lever, a lever under lever_tol,
    NaN and inf torques, signed zeros, a joint without limits, asymmetric limits."""
    rng = np.random.default_rng(37)
    a, b = rng.normal(0, 50, (20000, 7)), rng.normal(0, 5, (20000, 7))
    for array, value, share in ((b, 0.0, 0.1), (b, 1e-13, 0.01), (b, np.nan, 0.001), (a, np.nan, 0.001),
                                (a, np.inf, 0.001), (a, -0.0, 0.01), (b, -0.0, 0.01), (a, 40.0, 0.02)):
        array[rng.random(array.shape) < share] = value
    limits = np.array([320.0, 320.0, 176.0, 176.0, 110.0, 40.0, 40.0])
    for lower, upper in ((-limits, limits), (-0.5 * limits, limits),
                         (np.where(np.arange(7) == 2, np.nan, -limits), np.where(np.arange(7) == 2, np.nan, limits))):
        ours = capacity_from_parts(a, b, lower, upper, lever_tol=lever_tol)
        for got, want in zip(ours, _capacity_numpy(a, b, lower, upper, lever_tol)):
            assert got.dtype == want.dtype and got.tobytes() == want.tobytes()
        one = capacity_from_parts(a[3], b[3], lower, upper, lever_tol=lever_tol)  # one row: numpy scalars
        assert [x.tobytes() for x in one] == [np.asarray(x).tobytes() for x in _capacity_numpy(a[3], b[3], lower,
                                                                                                upper, lever_tol)]
