"""The ladder's dynamic program (manipkit.paths.ladder) against hand answers and an exhaustive search.

Every path through a small ladder is enumerated in the test (itertools.product over the rungs' candidates),
its edges checked with the rule written here (every |dq_j| <= bound_j) and its cost summed: the least cost and
whether any path exists must equal the dynamic program's.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from manipkit.paths import ladder as ladder_module
from manipkit.paths.ladder import solve_ladder


def brute_force(rungs, bounds, weights=None, penalties=None, forbidden=None):
    """(least cost, path) over every path through the rungs, by enumeration; (inf, None) when none is allowed."""
    n = len(rungs[0][0]) if len(rungs[0]) else 1
    w = np.ones(n) if weights is None else np.asarray(weights)
    best, best_path = np.inf, None
    for path in itertools.product(*[range(len(r)) for r in rungs]):
        cost = 0.0 if penalties is None else penalties[0][path[0]]
        for i in range(len(rungs) - 1):
            a, b = path[i], path[i + 1]
            d = np.abs(np.asarray(rungs[i + 1][b]) - np.asarray(rungs[i][a]))
            if np.any(d > bounds[i]) or (forbidden and (a, b) in forbidden.get(i, ())):
                cost = np.inf
                break
            cost += float(d @ w) + (0.0 if penalties is None else penalties[i + 1][b])
        if cost < best:
            best, best_path = cost, path
    return best, best_path


def test_hand_ladder_one_joint():
    # Rungs {0, 3}, {0.1, 2}, {0.2, 2.9}, bound 0.5 per step: from 0 the path 0 -> 0.1 -> 0.2 costs 0.2; from 3
    # the step to 2 (1.0) or 0.1 (2.9) is too far, so 3 dies; 2 is reachable from neither (|2 - 0| = 2 > 0.5).
    result = solve_ladder([[[0.0], [3.0]], [[0.1], [2.0]], [[0.2], [2.9]]], [[0.5], [0.5]])
    assert result.feasible and result.choice.tolist() == [0, 0, 0]
    assert result.cost == pytest.approx(0.2, abs=1e-15)
    assert result.reached[1].tolist() == [True, False]
    # candidate 2.0 at rung 1: both rung-0 candidates are starts; from 3.0 the step is |2 - 3| = 1, 2 x the
    # bound; from 0.0 it is 4 x. The record keeps the smaller: 2, on joint 0.
    block = next(b for b in result.blocked if b.rung == 1)
    assert block.ratio[1] == pytest.approx(2.0) and block.joint[1] == 0


def test_dead_rung_is_the_first_failure():
    # A jump of 1.0 with a bound of 0.5 at the second step: no path; the first rung with no candidate reached is 2.
    result = solve_ladder([[[0.0]], [[0.4]], [[1.4]], [[1.5]]], [[0.5]] * 3)
    assert not result.feasible and result.first_dead == 2
    assert result.blocked[0].rung == 2 and result.blocked[0].ratio[0] == pytest.approx(2.0)


def test_empty_rung_stops_the_path():
    result = solve_ladder([[[0.0]], np.zeros((0, 1)), [[0.0]]], [[1.0], [1.0]])
    assert not result.feasible and result.first_dead == 1


@pytest.mark.parametrize("seed", range(12))
def test_equals_exhaustive_search(seed):
    rng = np.random.default_rng(seed)
    N, n = rng.integers(2, 6), rng.integers(1, 4)
    rungs = [rng.uniform(-1, 1, (rng.integers(0 if seed % 5 == 4 else 1, 4), n)) for _ in range(N)]
    bounds = rng.uniform(0.3, 1.5, (N - 1, n))
    weights = rng.uniform(0.5, 2.0, n)
    penalties = [np.where(rng.random(len(r)) < 0.2, np.inf, rng.uniform(0, 0.3, len(r))) for r in rungs]
    forbidden = {i: [(int(rng.integers(len(rungs[i]))), int(rng.integers(len(rungs[i + 1]))))]
                 for i in range(N - 1) if len(rungs[i]) and len(rungs[i + 1]) and rng.random() < 0.5}
    expected, path = brute_force(rungs, bounds, weights, penalties, forbidden)
    result = solve_ladder(rungs, bounds, weights=weights, penalties=penalties, forbidden=forbidden)
    assert result.feasible == np.isfinite(expected)
    if result.feasible:
        assert result.cost == pytest.approx(expected, abs=1e-12)
        got = brute_force([[r[c]] for r, c in zip(rungs, result.choice)], bounds, weights,
                          [[p[c]] for p, c in zip(penalties, result.choice)],
                          {i: [(0, 0)] for i, f in forbidden.items() if (result.choice[i], result.choice[i + 1]) in f})
        assert got[0] == pytest.approx(expected, abs=1e-12)  # the returned path is allowed and costs that


def test_reconfigure_takes_the_fewest_breaks():
    # Joint values 0, 0.1 | 5, 5.1 | 10: two jumps no step can make: the fewest breaks is 2, before rungs 2 and 4.
    rungs = [[[0.0]], [[0.1]], [[5.0]], [[5.1]], [[10.0]]]
    result = solve_ladder(rungs, [[0.5]] * 4, reconfigure=True)
    assert result.feasible and result.breaks == (1, 3)
    assert result.cost == pytest.approx(0.2)  # motion of the two steps taken; a break's motion is not counted


def test_reconfigure_prefers_fewer_breaks_over_less_motion():
    # Rung 1 offers 0.45 (reachable from 0 and to 0.9, motion 0.9) or 5 (a break either side). Without breaks
    # the plan takes 0.45; it never trades that for breaks.
    rungs = [[[0.0]], [[5.0], [0.45]], [[0.9]]]
    result = solve_ladder(rungs, [[0.5]] * 2, reconfigure=True)
    assert result.breaks == () and result.choice.tolist() == [0, 1, 0]


def test_progress_reaches_the_total():
    calls = []
    solve_ladder([[[0.0]]] * 5, [[1.0]] * 4, progress=lambda stage, done, total: calls.append((stage, done, total)))
    assert calls[-1] == ("ladder", 4, 4)


def test_sparse_edges_equal_the_dense_block(monkeypatch):
    # Selective bounds (0.05 against values spread over 2) take the sparse path (windows by binary search);
    # with it switched off the dense block must give the same path, cost and failure records.
    rng = np.random.default_rng(7)
    rungs = [np.cumsum(rng.normal(0, 0.02, (60, 3)), axis=0) + rng.uniform(-1, 1, (60, 3)) for _ in range(8)]
    rungs = [np.vstack([r, rungs[0][:5] + 0.01 * i]) for i, r in enumerate(rungs)]  # five slow tracks
    bounds = np.full((7, 3), 0.05)
    sparse = solve_ladder(rungs, bounds, forbidden={2: [(0, 0)]})
    monkeypatch.setattr(ladder_module, "SPARSE_SHARE", -1.0)  # every pair, read as |dq| inv <= 1
    dense = solve_ladder(rungs, bounds, forbidden={2: [(0, 0)]})
    assert sparse.feasible and sparse.cost == pytest.approx(dense.cost, abs=1e-12)
    assert sparse.choice.tolist() == dense.choice.tolist()
    for x, y in zip(sparse.blocked, dense.blocked):
        assert x.rung == y.rung
        np.testing.assert_allclose(x.ratio, y.ratio)
        assert x.joint.tolist() == y.joint.tolist()


def brute_force_blocks(rungs, bounds, forbidden):
    """Per rung, for each candidate no allowed edge reaches: the least over reached predecessors of the step's
    largest |dq_j| / bound_j (forbidden edges excluded), the lowest predecessor on a tie, and its joint; by a
    forward pass written here (every pair, no windows)."""
    reached = [np.ones(len(rungs[0]), dtype=bool)]
    out = {}
    for i in range(len(rungs) - 1):
        prev, nxt = np.asarray(rungs[i]), np.asarray(rungs[i + 1])
        ok = np.zeros(len(nxt), dtype=bool)
        ratio, joint = np.full(len(nxt), np.inf), np.full(len(nxt), -1)
        for b in range(len(nxt)):
            for a in range(len(prev)):
                if not reached[i][a] or (a, b) in forbidden.get(i, ()):
                    continue
                r = np.abs(nxt[b] - prev[a]) / bounds[i]
                if r.max() <= 1.0:
                    ok[b] = True
                if r.max() < ratio[b]:
                    ratio[b], joint[b] = r.max(), int(r.argmax())
        stuck = ~ok
        if stuck.any():
            out[i + 1] = (np.where(stuck, ratio, np.nan), np.where(stuck, joint, -1))
        reached.append(ok)
    return out


@pytest.mark.parametrize("share", [0.25, -1.0])
@pytest.mark.parametrize("seed", range(6))
def test_blocked_records_equal_a_plain_search(monkeypatch, seed, share):
    # Tight bounds leave candidates unreached; each one's record (best ratio in, its joint) must be what every
    # pair gives, with the windows of the selective joint (share 0.25) and on every pair (share -1).
    monkeypatch.setattr(ladder_module, "SPARSE_SHARE", share)
    rng = np.random.default_rng(100 + seed)
    N, n = 6, 3
    rungs = [rng.uniform(-1, 1, (int(rng.integers(5, 30)), n)) for _ in range(N)]
    rungs = [np.vstack([r, 0.02 * i + np.zeros((1, n))]) for i, r in enumerate(rungs)]  # one slow track survives
    bounds = rng.uniform(0.1, 0.5, (N - 1, n))
    forbidden = {i: [(int(rng.integers(len(rungs[i]))), int(rng.integers(len(rungs[i + 1]))))
                     for _ in range(5)] for i in range(N - 1)}
    expected = brute_force_blocks(rungs, bounds, forbidden)
    result = solve_ladder(rungs, bounds, forbidden=forbidden)
    assert result.feasible
    assert {block.rung for block in result.blocked} == set(expected)
    for block in result.blocked:
        ratio, joint = expected[block.rung]
        np.testing.assert_allclose(block.ratio, ratio, rtol=1e-12)
        assert block.joint.tolist() == joint.tolist()
