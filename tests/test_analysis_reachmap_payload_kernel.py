"""The compiled loops of a payload layer's block (manipkit.analysis.reachmap.payload_kernel) against the numpy
operations they replace, written out here: which closed-form branches are kept, and the per-bin best, worst and
saturating joint; equal to the bit on crafted rows (missing branches, residuals at the tolerance, aliases of the
configuration 2 pi away, entries at and past the widened limits, continuous joints, NaN and infinite capacities,
ties)."""

import warnings

import numpy as np

from manipkit.analysis.reachmap.payload_kernel import kept_branches_kernel, per_bin_kernel
from manipkit.kinematics.chain import limits_ok

TOL = 1e-6


def _kept_numpy(q, S, position, rotation, lower_ok, upper_ok):
    with np.errstate(invalid="ignore"):
        found = ~np.isnan(S).any(axis=-1) & (position <= TOL) & (rotation <= TOL)
    S = np.where(found[..., None], S, q[:, None])
    turn = S - q[:, None]
    turn -= 2 * np.pi * np.round(turn / (2 * np.pi))
    found &= ~((S < lower_ok) | (S > upper_ok)).any(axis=-1) & (np.abs(turn) > TOL).any(axis=-1)
    return np.concatenate([q[:, None], S], axis=1), np.concatenate([np.ones((len(q), 1), dtype=bool), found], axis=1)


def test_kept_branches_are_the_numpy_filter_to_the_bit():
    rng = np.random.default_rng(7)
    n_rows, k, n = 5000, 8, 6
    lower, upper = np.full(n, -2.9), np.full(n, 2.9)
    lower[5], upper[5] = -np.inf, np.inf  # a continuous joint
    q = rng.uniform(-2.8, 2.8, (n_rows, n))
    S = rng.uniform(-3.0, 3.0, (n_rows, k, n))
    S[rng.random((n_rows, k)) < 0.2] = np.nan  # missing branches
    alias = rng.random((n_rows, k)) < 0.1  # the configuration itself, 2 pi away on the continuous joint
    S[alias] = q[np.nonzero(alias)[0]]
    S[alias, 5] += 2 * np.pi
    near = rng.random((n_rows, k)) < 0.05  # within the tolerance of the configuration
    S[near] = q[np.nonzero(near)[0]] + 0.5 * TOL
    lower_ok, upper_ok = limits_ok(lower, upper)
    edge = rng.random((n_rows, k, n)) < 0.01  # at the widened limit, and the next number past it
    edge[..., 5] = False
    edge &= ~(alias | near)[..., None]
    at = np.broadcast_to(upper_ok, S.shape)[edge]
    S[edge] = np.where(rng.random(at.size) < 0.5, at, np.nextafter(at, np.inf))
    position, rotation = rng.uniform(0, 2 * TOL, (n_rows, k)), rng.uniform(0, 2 * TOL, (n_rows, k))
    position[rng.random((n_rows, k)) < 0.05] = TOL
    position[np.isnan(S).any(axis=-1)] = np.nan
    rows, kept = np.empty((n_rows, 1 + k, n)), np.empty((n_rows, 1 + k), dtype=bool)
    kept_branches_kernel()(q, S, position, rotation, TOL, lower_ok, upper_ok, rows, kept)
    want_rows, want_kept = _kept_numpy(q, S, position, rotation, lower_ok, upper_ok)
    assert np.array_equal(kept, want_kept) and rows[kept].tobytes() == want_rows[kept].tobytes()
    assert np.array_equal(rows, np.where(kept[..., None], rows, q[:, None]))  # a row not kept holds the configuration
    assert 0.1 < kept[:, 1:].mean() < 0.9 and not kept[:, 1:][alias | near].any()


def test_per_bin_is_the_numpy_reduction_to_the_bit():
    rng = np.random.default_rng(8)
    n_rows, k = 20000, 9
    kept = rng.random((n_rows, k)) < 0.4
    kept[:, 0] = True
    values = rng.choice([0.0, 1.0, 2.5, 7.0, np.inf], size=kept.sum())  # ties, zeros, unbounded
    spread = rng.random(values.size) < 0.3
    values[spread] = rng.uniform(0, 50, spread.sum())
    values[rng.random(values.size) < 0.01] = np.nan
    joints = rng.integers(-1, 7, values.size)
    best, worst, worst_joint = np.empty(n_rows), np.empty(n_rows), np.empty(n_rows, dtype=np.int64)
    per_bin_kernel()(kept, values, joints, best, worst, worst_joint)
    mass = np.full(kept.shape, np.nan)
    mass[kept] = values
    joint = np.full(kept.shape, -1, dtype=np.int64)
    joint[kept] = joints
    at_worst = np.argmin(np.where(kept, mass, np.inf), axis=1)
    picked = np.arange(n_rows)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # an all-NaN row: nanmax says so
        want_best = np.nanmax(mass, axis=1)
    assert best.tobytes() == want_best.tobytes()
    assert worst.tobytes() == mass[picked, at_worst].tobytes()
    assert np.array_equal(worst_joint, joint[picked, at_worst])
