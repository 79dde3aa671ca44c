"""The general 6R elimination (manipkit.closed_form.general6r) on random DH arms, checked by DH forward kinematics.

Every number here is checked against forward kinematics written in this file
from the DH parameters (standard DH: Rot_z(theta) Trans_z(d) Trans_x(a)
Rot_x(alpha)), not the solver's product of exponentials: every returned row
must land on the target, and the configuration the target was made from must
be among the rows.
"""

import math

import numpy as np
import pytest

from manipkit.closed_form import general6r
from manipkit.errors import ClosedFormIKError


def dh_fk(dh: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """T (4, 4) of standard DH rows (d, a, alpha) at joint angles theta (6,)."""
    T = np.eye(4)
    for (d, a, alpha), t in zip(dh, theta):
        ct, st, ca, sa = math.cos(t), math.sin(t), math.cos(alpha), math.sin(alpha)
        T = T @ np.array([[ct, -st * ca, st * sa, a * ct], [st, ct * ca, -ct * sa, a * st], [0, sa, ca, d], [0, 0, 0, 1]])
    return T


def dh_axes(dh: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(directions (6, 3), points (6, 3), M) of the DH arm at theta = 0: axis i is z_{i-1}."""
    T = np.eye(4)
    h, p = [], []
    for d, a, alpha in dh:
        h.append(T[:3, 2].copy())
        p.append(T[:3, 3].copy())
        T = T @ dh_fk(np.array([[d, a, alpha]]), np.zeros(1))
    return np.array(h), np.array(p), T


def random_dh(rng, parallel: bool = False) -> np.ndarray:
    dh = np.column_stack([rng.uniform(-0.5, 0.5, 6), rng.uniform(-0.5, 0.5, 6), rng.uniform(-math.pi, math.pi, 6)])
    if parallel:  # axes 2 and 3 parallel (alpha_2 = 0), as the xArm6 and most cobots have
        dh[1, 2] = 0.0
    return dh


def wrapped(a):
    return np.pi - np.mod(np.pi - np.asarray(a), 2 * np.pi)


def solve_dh(dh, theta):
    h, p, M = dh_axes(dh)
    arm = general6r.prepare(h, p)
    T = dh_fk(dh, theta)
    return general6r.solve(arm, T @ np.linalg.inv(M)), T, M


def test_both_sides_are_of_degree_one_in_each_joint():
    """The interpolated coefficients reproduce the 14 quantities at random angles (not just on the grid)."""
    rng = np.random.default_rng(3)
    h, p, M = dh_axes(random_dh(rng))
    arm = general6r.prepare(h, p)
    for _ in range(5):
        t4, t5 = rng.uniform(-3, 3, 2)
        E = general6r.poe_fk(arm.h[3:5], arm.p[3:5], np.array([t4, t5]))
        direct = general6r.rr_sides(E[:3, :3] @ arm.x6 + E[:3, 3] - arm.o, E[:3, :3] @ arm.h[5])
        basis = np.kron([1, math.cos(t4), math.sin(t4)], [1, math.cos(t5), math.sin(t5)])
        assert np.abs(arm.P @ basis - direct).max() < 1e-12


@pytest.mark.parametrize("parallel", [False, True], ids=["general", "axes 2, 3 parallel"])
def test_random_arms_every_row_lands_and_the_generating_configuration_is_found(parallel):
    rng = np.random.default_rng(11 if parallel else 7)
    poses, found, rows, worst = 600, 0, 0, 0.0
    for k in range(poses):
        if k % 20 == 0:
            dh = random_dh(rng, parallel)
        theta = rng.uniform(-math.pi, math.pi, 6)
        roots, T, M = solve_dh(dh, theta)
        rows += len(roots.theta)
        for row in roots.theta:  # independent FK: the DH matrices
            worst = max(worst, float(np.abs(dh_fk(dh, row) - T).max()))
        found += bool(len(roots.theta)) and bool(np.any(np.abs(wrapped(roots.theta - theta)).max(axis=1) < 1e-7))
    assert worst < 1e-10
    assert found >= 0.999 * poses, f"{poses - found} of {poses} generating configurations missing"
    assert rows <= 16 * poses


def test_at_most_sixteen_and_an_even_count_for_a_general_arm():
    rng = np.random.default_rng(5)
    dh = random_dh(rng)
    counts = [len(solve_dh(dh, rng.uniform(-math.pi, math.pi, 6))[0].theta) for _ in range(50)]
    assert max(counts) <= 16 and all(c % 2 == 0 for c in counts)  # complex roots come in pairs: real ones are even


def _det_jacobian(h, p, theta):
    frames = [np.eye(4)]
    for i in range(6):
        frames.append(frames[-1] @ general6r.poe_fk(h[i:i + 1], p[i:i + 1], theta[i:i + 1]))
    J = np.empty((6, 6))
    for i in range(6):
        w = frames[i][:3, :3] @ h[i]
        J[:3, i] = np.cross(frames[i][:3, :3] @ p[i] + frames[i][:3, 3], w)  # the spatial twist (v = q x w)
        J[3:, i] = w
    return np.linalg.det(J)


def singular_configuration(h, p, rng):
    """A configuration with det J = 0 (a fold of the IK map: its pose has a double root there), by bisection on
    joint 3 from a sign change of det J."""
    while True:
        theta = rng.uniform(-math.pi, math.pi, 6)
        grid = np.linspace(-math.pi, math.pi, 181)
        values = []
        for t in grid:
            theta[2] = t
            values.append(_det_jacobian(h, p, theta))
        changes = np.flatnonzero(np.sign(values[:-1]) != np.sign(values[1:]))
        if len(changes):
            lo, hi = grid[changes[0]], grid[changes[0] + 1]
            f_lo = values[changes[0]]
            for _ in range(80):
                mid = 0.5 * (lo + hi)
                theta[2] = mid
                f = _det_jacobian(h, p, theta)
                if np.sign(f) == np.sign(f_lo):
                    lo, f_lo = mid, f
                else:
                    hi = mid
            theta[2] = 0.5 * (lo + hi)
            return theta


def test_near_double_roots_are_kept():
    """ssik#528: a Doosan m0609 lost 4 of 8 solutions at near-double roots. At a fold (det J = 0) the pose has a
    double root; just beside it two real roots 1e-4 apart: both must be returned, and the double root itself."""
    rng = np.random.default_rng(2)
    for trial in range(6):
        dh = random_dh(rng, parallel=trial % 2 == 1)
        h, p, M = dh_axes(dh)
        arm = general6r.prepare(h, p)
        star = singular_configuration(h, p, rng)
        assert abs(_det_jacobian(h, p, star)) < 1e-9
        roots = general6r.solve(arm, dh_fk(dh, star) @ np.linalg.inv(M))
        distance = np.abs(wrapped(roots.theta - star)).max(axis=1)
        assert distance.min() < 1e-5, f"trial {trial}: the double root is missing"
        for row in roots.theta:
            assert np.abs(dh_fk(dh, row) - dh_fk(dh, star)).max() < 1e-10
        near = star.copy()
        near[2] += 1e-4  # one of a pair of close real roots
        roots = general6r.solve(arm, dh_fk(dh, near) @ np.linalg.inv(M))
        distance = np.abs(wrapped(roots.theta - star)).max(axis=1)
        close = int(np.sum(distance < 5e-3))
        assert close >= 2, f"trial {trial}: {close} root(s) near the fold, 2 expected"
        assert np.abs(wrapped(roots.theta - near)).max(axis=1).min() < 1e-7


def test_bad_arrays_are_refused():
    with pytest.raises(ClosedFormIKError, match="6 joint axes"):
        general6r.prepare(np.eye(3)[[0, 1, 2, 0, 1]], np.zeros((5, 3)))


def test_compiled_eigenvalues_inverse_and_null_vector_match_numpy():
    """closed_form.eigen_kernel against numpy: every eigenvalue of 300 random real matrices (sizes 2-24, rows scaled
    over 6 decades, as the elimination's companion matrices are) to 1e-11 relative, matched one to one; a 12 x 12
    inverse; the null vector of A - lambda I at an eigenvalue lambda (complex)."""
    from manipkit.closed_form.eigen_kernel import eigenvalues, inverse, null_vector

    rng = np.random.default_rng(3)
    for _ in range(300):
        n = int(rng.integers(2, 25))
        A = rng.normal(size=(n, n)) * 10.0 ** rng.uniform(-3, 3, size=(n, 1))
        wr, wi = np.empty(n), np.empty(n)
        assert eigenvalues(A, wr, wi)
        reference = list(np.linalg.eigvals(A))
        for z in wr + 1j * wi:
            k = int(np.argmin([abs(r - z) for r in reference]))
            assert abs(reference.pop(k) - z) <= 1e-11 * (1.0 + abs(z))
    A = rng.normal(size=(12, 12))
    out = np.empty((12, 12))
    assert inverse(A, out) and np.abs(out @ A - np.eye(12)).max() < 1e-12
    assert not inverse(np.zeros((3, 3)), np.empty((3, 3)))
    lam = np.linalg.eigvals(A)[0]
    u = np.empty(12, dtype=complex)
    null_vector((A - lam * np.eye(12)).astype(complex), u)
    assert np.abs((A - lam * np.eye(12)) @ u).max() < 1e-12 and np.isclose(np.abs(u).max(), 1.0)
