"""manipkit.dh.symbolic_statics: g(q) of a DH table with point masses, against a hand derivation and against central
differences of the potential energy computed numerically with dh_fk (an independent path from the SymPy frames)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import sympy

from manipkit.dh.files import load_dh
from manipkit.dh.symbolic import dh_symbols
from manipkit.dh.symbolic_statics import dh_gravity_symbolic
from manipkit.dh.table import DHRow, DHTable, dh_fk
from manipkit.errors import DHDerivationError


def test_a_vertical_planar_2r_with_masses_at_mid_links_matches_the_hand_derivation():
    # Links l1, l2 in the x-y plane, y up, gravity (0, -g, 0). Standard DH frame i sits at the far end of link i,
    # x along it, so the middle of link i is c_i = (-l_i / 2, 0, 0) in frame i. Heights of the two masses:
    #   y1 = l1/2 sin q1,   y2 = l1 sin q1 + l2/2 sin(q1 + q2).
    # V = g (m1 y1 + m2 y2), so
    #   g1 = dV/dq1 = g [(m1 l1/2 + m2 l1) cos q1 + m2 l2/2 cos(q1 + q2)],
    #   g2 = dV/dq2 = g m2 l2/2 cos(q1 + q2).
    l1, l2, m1, m2, g = 0.7, 0.45, 3.0, 1.5, 9.81
    arm = DHTable([DHRow(l1, 0, 0, 0), DHRow(l2, 0, 0, 0)])
    torques = dh_gravity_symbolic(arm, [m1, m2], centres=[(-l1 / 2, 0, 0), (-l2 / 2, 0, 0)], gravity=(0, -g, 0))
    q1, q2 = dh_symbols(2)
    numeric = sympy.lambdify((q1, q2), torques, "numpy")
    rng = np.random.default_rng(3)
    for a, b in rng.uniform(-math.pi, math.pi, size=(20, 2)):
        expected = [g * ((m1 * l1 / 2 + m2 * l1) * math.cos(a) + m2 * l2 / 2 * math.cos(a + b)),
                    g * m2 * l2 / 2 * math.cos(a + b)]
        np.testing.assert_allclose(np.ravel(numeric(a, b)), expected, rtol=0, atol=1e-10)


def test_symbols_stay_symbols_and_the_textbook_form_comes_out():
    arm = DHTable([DHRow(1, 0, 0, 0), DHRow(1, 0, 0, 0)])
    torques = dh_gravity_symbolic(arm, ["m1", "m2"], gravity=(0, "-g", 0), lengths={"a1": "l1", "a2": "l2"})
    g, l1, l2, m1, m2 = sympy.symbols("g l1 l2 m1 m2", real=True)
    q1, q2 = dh_symbols(2)
    assert sympy.simplify(torques[0] - g * ((m1 + m2) * l1 * sympy.cos(q1) + m2 * l2 * sympy.cos(q1 + q2))) == 0
    assert sympy.simplify(torques[1] - g * m2 * l2 * sympy.cos(q1 + q2)) == 0


def potential(table: DHTable, q, masses, centres, gravity) -> float:
    """V = -sum m_i g . p_i with p_i = F_i c_i, F_i by the numeric DH FK (dh_fk ... upto=i)."""
    total = 0.0
    for i, (m, c) in enumerate(zip(masses, centres)):
        F = dh_fk(table, q, upto=i + 1)
        total -= m * float(np.dot(gravity, F[:3, :3] @ c + F[:3, 3]))
    return total


@pytest.mark.parametrize("name", ["elbow_arm", "stanford_arm", "scara", "course_arm_modified", "iiwa14"])
def test_g_of_q_is_the_gradient_of_the_potential_on_spatial_tables(name):
    table = load_dh(name)
    rng = np.random.default_rng(len(name))
    masses = rng.uniform(0.5, 4.0, table.n)
    centres = rng.uniform(-0.2, 0.2, (table.n, 3))
    gravity = np.array([0.3, -0.4, -9.81])  # a tilted base: every component in play
    torques = dh_gravity_symbolic(table, list(masses), centres=[list(c) for c in centres], gravity=list(gravity),
                                  simplify=table.n < 4)  # folding is cosmetic: the same function either way
    numeric = sympy.lambdify(dh_symbols(table.n), torques, "numpy")
    limits = [row.qlim if row.qlim is not None else (-math.pi, math.pi) for row in table.rows]
    low, high = np.array([lo for lo, _ in limits]), np.array([hi for _, hi in limits])
    h = 1e-6
    for q in rng.uniform(low, high, size=(5, table.n)):
        expected = []
        for j in range(table.n):
            step = np.zeros(table.n)
            step[j] = h
            expected.append((potential(table, q + step, masses, centres, gravity)
                             - potential(table, q - step, masses, centres, gravity)) / (2 * h))
        np.testing.assert_allclose(np.ravel(numeric(*q)), expected, rtol=0, atol=1e-6)


def test_a_massless_arm_holds_nothing():
    table = load_dh("elbow_arm")
    assert dh_gravity_symbolic(table, [0] * table.n) == sympy.zeros(table.n, 1)


@pytest.mark.parametrize("kwargs, message", [
    ({"masses": [1.0]}, "masses: give 2 values"),
    ({"masses": [1.0, "m 2"]}, "mass 2 'm 2': give a number or a symbol name"),
    ({"masses": [1.0, float("inf")]}, "give a finite number"),
    ({"masses": [1.0, -2.0]}, "mass 2 = -2 kg: give a mass >= 0 kg"),
    ({"masses": [1.0, 2.0], "centres": [(0, 0, 0)]}, "centres: give 2 points"),
    ({"masses": [1.0, 2.0], "centres": [(0, 0, 0), (0, 0)]}, "centre 2: give three coordinates"),
    ({"masses": [1.0, 2.0], "gravity": (0, -9.81)}, "gravity: give three components"),
])
def test_bad_input_is_one_clear_error(kwargs, message):
    arm = DHTable([DHRow(1, 0, 0, 0), DHRow(1, 0, 0, 0)])
    with pytest.raises(DHDerivationError, match=message):
        dh_gravity_symbolic(arm, **kwargs)
