"""The Paden-Kahan subproblems: hand-derived cases, no-solution and free cases, and round trips."""

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from manipkit.closed_form.subproblems import rotate, sp1, sp2, sp3, sp4

Z, X, Y = np.array([0.0, 0, 1]), np.array([1.0, 0, 0]), np.array([0.0, 1, 0])

unit = st.tuples(*[st.floats(-1, 1)] * 3).map(np.array).filter(lambda v: np.linalg.norm(v) > 0.2).map(
    lambda v: v / np.linalg.norm(v))
vector = st.tuples(*[st.floats(-2, 2)] * 3).map(np.array)
angle = st.floats(-math.pi + 1e-6, math.pi)


def same_angle(a, b, tol=1e-8):
    return abs(math.remainder(a - b, 2 * math.pi)) < tol


def test_sp1_quarter_turn_about_z():
    theta, free, miss = sp1(Z, X, Y)
    assert math.isclose(theta, math.pi / 2) and not free and miss < 1e-15


def test_sp1_point_on_axis_is_free():
    theta, free, _ = sp1(Z, 2 * Z, 2 * Z)
    assert free and theta == 0.0


def test_sp1_unequal_lengths_give_the_least_squares_angle_and_the_miss():
    theta, free, miss = sp1(Z, X, 3 * Y)
    assert math.isclose(theta, math.pi / 2) and math.isclose(miss, 2.0)


def test_sp4_plane_through_the_circle_gives_two_angles():
    answer = sp4(X, Z, X, 0.5)  # cos t = 0.5
    assert answer.count == 2 and sorted(answer.theta.round(12)) == sorted([round(math.pi / 3, 12), -round(math.pi / 3, 12)])


def test_sp4_tangent_plane_gives_one_angle():
    answer = sp4(X, Z, X, 1.0)
    assert answer.count == 1 and np.allclose(answer.theta, 0.0)


def test_sp4_plane_beyond_the_circle_has_none_and_says_by_how_much():
    answer = sp4(X, Z, X, 1.25)
    assert answer.count == 0 and math.isclose(answer.miss, 0.25)


def test_sp4_normal_along_the_axis_is_free_or_impossible():
    assert sp4(Z, Z, X + Z, 1.0).count == math.inf
    impossible = sp4(Z, Z, X + Z, 2.0)
    assert impossible.count == 0 and math.isclose(impossible.miss, 1.0)


def test_sp3_circle_meets_sphere_twice():
    # p1 = x rotates on the unit circle; distance sqrt(2) from the origin-offset point (0, 0, 1) everywhere
    # distance 1 from (1, 1, 0): at t = 0 and t = pi / 2
    answer = sp3(Z, X, X + Y, 1.0)
    assert answer.count == 2
    assert {round(float(t), 9) for t in answer.theta} == {0.0, round(math.pi / 2, 9)}


def test_sp3_unreachable_distance_names_the_gap():
    answer = sp3(Z, X, np.zeros(3), 2.0)
    assert answer.count == 0 and math.isclose(answer.miss, 1.0)


def test_sp2_two_perpendicular_axes():
    answer = sp2(Z, X, X, Z)  # R(z, t1) x = R(x, t2) z: the common vector +-y
    assert answer.count == 2
    for t1, t2 in answer.theta:
        assert np.allclose(rotate(Z, t1, X), rotate(X, t2, Z))


def test_sp2_unequal_lengths_have_no_solution():
    assert sp2(Z, X, X, 2 * Z).count == 0


def test_sp2_vector_on_the_first_axis_is_free():
    assert sp2(Z, Z, X, Y).count == math.inf


@settings(max_examples=200, deadline=None)
@given(unit, vector, vector, angle)
def test_sp4_round_trip(k, h, p, t):
    """Every returned angle solves it; the generating angle is among them, to within what a tangency snaps
    (the tolerance is on h . R p, so near a tangency an angle is good to sqrt(tol / r) only)."""
    d = float(h @ rotate(k, t, p))
    answer = sp4(h, k, p, d, tol=1e-9)
    assert answer.count >= 1
    r = math.hypot(h @ (p - (k @ p) * k), h @ np.cross(k, p))
    if math.isfinite(answer.count):
        assert any(same_angle(float(s), t, 1e-3) for s in answer.theta) or r < 1e-2
        for s in answer.theta:
            assert abs(h @ rotate(k, s, p) - d) < 1e-8 * max(1, np.linalg.norm(h) * np.linalg.norm(p))


@settings(max_examples=200, deadline=None)
@given(unit, vector, vector, angle)
def test_sp3_round_trip(k, p1, p2, t):
    delta = float(np.linalg.norm(rotate(k, t, p1) - p2))
    answer = sp3(k, p1, p2, delta, tol=1e-9)
    assert answer.count >= 1
    for s in answer.theta[: int(min(answer.count, 2))]:  # squared distances: what the tolerance bounds
        assert abs(np.linalg.norm(rotate(k, s, p1) - p2) ** 2 - delta**2) < 1e-8


@settings(max_examples=200, deadline=None)
@given(unit, unit, vector, angle, angle)
def test_sp2_round_trip(k1, k2, p2, t1, t2):
    p1 = rotate(k1, -t1, rotate(k2, t2, p2))  # so that R(k1, t1) p1 = R(k2, t2) p2
    answer = sp2(k1, p1, k2, p2, tol=1e-9)
    assert answer.count >= 1
    if math.isfinite(answer.count):
        pairs = answer.theta[: int(answer.count)]
        for a, b in pairs:  # near a tangency the angles are good to sqrt(tol): the vectors to about tol ** 0.5
            assert np.linalg.norm(rotate(k1, a, p1) - rotate(k2, b, p2)) < 1e-4
        recovered = any(same_angle(a, t1, 1e-3) and same_angle(b, t2, 1e-3) for a, b in pairs)
        degenerate = np.linalg.norm(np.cross(k1, p1)) < 1e-2 or np.linalg.norm(np.cross(k2, p2)) < 1e-2 or \
            abs(abs(k1 @ k2) - 1) < 1e-2
        assert recovered or degenerate


@settings(max_examples=200, deadline=None)
@given(unit, vector, angle)
def test_sp1_round_trip(k, p, t):
    theta, free, miss = sp1(k, p, rotate(k, t, p))
    assert miss < 1e-9
    if np.linalg.norm(np.cross(k, p)) > 1e-6:
        assert same_angle(float(theta), t, 1e-6)
