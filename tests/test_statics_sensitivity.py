"""The sensitivity band and the per-body contributions (manipkit.statics.sensitivity) against Pinocchio with
perturbed inertias; the force polytope and ellipsoid with gravity (manipkit.statics.capability)."""

import numpy as np
import pinocchio as pin
import pytest

from manipkit.errors import OptionError
from manipkit.statics.capability import force_capacity
from manipkit.statics.capacity import payload_capacity
from manipkit.statics.sensitivity import gravity_contributions, torque_band
from manipkit.statics.torques import Payload, Wrench, static_torques

Q_IIWA = [0.3, 0.5, -0.2, -1.0, 0.4, 0.5, 0.1]


def pinocchio_gravity(robot, q, change=None):
    """computeGeneralizedGravity on a copy of the model whose body ``change[0]`` has mass factor and CoG shift."""
    model = robot.model.copy()
    if change is not None:
        body, factor, shift = change
        old = model.inertias[body]
        model.inertias[body] = pin.Inertia(old.mass * factor, old.lever + shift, old.inertia)
    return pin.computeGeneralizedGravity(model, model.createData(), robot.pinocchio_configuration(q))


def test_the_band_is_exact_body_by_body(iiwa14):
    """On iiwa14 every body hangs on its own joint, so the band's box is in Pinocchio's body frames: each joint's
    high end is the nominal torque plus, body by body, the largest change over the 16 corners (torques add)."""
    percent, p = 10.0, 0.1
    band = torque_band(iiwa14, Q_IIWA, percent=percent)
    nominal = pinocchio_gravity(iiwa14, Q_IIWA)
    np.testing.assert_allclose(band.nominal, nominal, rtol=0, atol=1e-10)
    high, low = nominal.copy(), nominal.copy()
    for body in range(1, iiwa14.model.njoints):
        lever = np.asarray(iiwa14.model.inertias[body].lever)
        reach = p * np.linalg.norm(lever)
        changes = np.array([pinocchio_gravity(iiwa14, Q_IIWA, (body, 1 + p * sm, reach * np.array([sx, sy, sz])))
                            - nominal for sm in (-1, 1) for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
        high += changes.max(axis=0)
        low += changes.min(axis=0)
    np.testing.assert_allclose(band.high, high, rtol=0, atol=1e-10)
    np.testing.assert_allclose(band.low, low, rtol=0, atol=1e-10)


def test_the_band_holds_random_perturbations_and_bounds_the_capacity(iiwa14):
    rng = np.random.default_rng(0)
    band = torque_band(iiwa14, Q_IIWA, percent=20, payload=Payload(1.0, (0, 0, 0.1)))
    assert band.capacity_low <= band.capacity_nominal <= band.capacity_high
    cap = payload_capacity(iiwa14, Q_IIWA, cog=(0, 0, 0.1))
    assert abs(band.capacity_nominal - float(cap.max_mass)) < 1e-9
    model = iiwa14.model.copy()
    for _ in range(20):
        for body in range(1, model.njoints):
            old = iiwa14.model.inertias[body]
            shift = 0.2 * np.linalg.norm(old.lever) * rng.uniform(-1, 1, 3)
            model.inertias[body] = pin.Inertia(old.mass * rng.uniform(0.8, 1.2), old.lever + shift, old.inertia)
        g = pin.computeGeneralizedGravity(model, model.createData(), iiwa14.pinocchio_configuration(Q_IIWA))
        assert np.all(band.low - 1e-12 <= g) and np.all(g <= band.high + 1e-12)


def test_zero_percent_is_the_nominal_torque(panda):
    q = panda.chain("base_link", "ee_link").sample(1, seed=2)[0]
    band = torque_band(panda, q, percent=0)
    np.testing.assert_allclose(band.low, band.nominal, rtol=0, atol=1e-12)
    np.testing.assert_allclose(band.high, band.nominal, rtol=0, atol=1e-12)
    np.testing.assert_allclose(band.nominal, static_torques(panda, q).gravity, rtol=0, atol=1e-10)
    with pytest.raises(OptionError, match="percent"):
        torque_band(panda, q, percent=-5)


def test_contributions_add_up_and_name_each_body(panda):
    q = panda.chain("base_link", "ee_link").sample(1, seed=3)[0]
    parts = gravity_contributions(panda, q)
    links = [link for link, _, _ in parts]
    assert links[:2] == ["panda_link1", "panda_link2"] and "panda_leftfinger" in links
    np.testing.assert_allclose(sum(t for _, _, t in parts), static_torques(panda, q).gravity, rtol=0, atol=1e-10)
    # a body weighs only on the joints above it: panda_link4's body gives nothing to joints 4.. (index 3 on)
    link4 = next(t for link, _, t in parts if link == "panda_link4")
    assert np.all(link4[4:] == 0) and abs(link4[1]) > 0


def test_force_polytope_round_trip(iiwa14):
    """At the largest force along d the limiting joint is at its limit (the tool applies t d: w = -t d on it)."""
    rng = np.random.default_rng(1)
    directions = rng.normal(size=(8, 3))
    payload = Payload(2.0, (0, 0, 0.05))
    for kind in ("force", "moment"):
        cap = force_capacity(iiwa14, Q_IIWA, kind=kind, directions=directions, payload=payload)
        for d, t, joint in zip(cap.directions, cap.along, cap.saturating):
            w = np.concatenate([-t * d, np.zeros(3)] if kind == "force" else [np.zeros(3), -t * d])
            at = static_torques(iiwa14, Q_IIWA, payload=payload, wrench=Wrench(w))
            k = at.joint_names.index(joint)
            assert abs(abs(at.tau[k]) - at.effort_limit[k]) < 1e-9
            assert np.all(np.abs(at.tau) <= at.effort_limit + 1e-9)


def test_force_ellipsoid_surface_and_the_gravity_free_case(iiwa14):
    cap = force_capacity(iiwa14, Q_IIWA)
    chain = iiwa14.chain("base_link", "ee_link")
    J = chain.jacobian(Q_IIWA)[:3]
    g = static_torques(iiwa14, Q_IIWA).tau
    limits = static_torques(iiwa14, Q_IIWA).effort_limit
    for i in range(3):
        f = cap.centre + cap.radii[i] * cap.axes[:, i]
        assert abs(np.linalg.norm((g + J.T @ f) / limits) - 1) < 1e-9
    free = force_capacity(iiwa14, Q_IIWA, gravity=(0, 0, 0))
    np.testing.assert_allclose(free.centre, 0, atol=1e-9)
    eig = np.linalg.eigvalsh(J @ np.diag(1 / limits ** 2) @ J.T)  # the classic force ellipsoid f^T (J D^2 J^T) f <= 1
    np.testing.assert_allclose(np.sort(free.radii), np.sort(1 / np.sqrt(eig)), rtol=1e-10)


def test_an_empty_ellipsoid_when_gravity_uses_the_budget(iiwa14):
    cap = force_capacity(iiwa14, [0, 1.5, 0, 0, 0, 0, 0], gravity=(0, 0, -200.0))
    assert cap.empty and np.all(cap.radii == 0) and np.all(cap.along == 0)
