"""The 2 pi aliases of closed-form branches (issue 38): every in-limit alias listed, labelled, the generating
configuration found as itself."""

import json
import math

import numpy as np
import pytest
from cli_helper import run_cli

import manipkit
from manipkit.ik.aliases import alias_rows
from manipkit.spatial.rotations import matrix_from_rpy

TWO_PI = 2 * math.pi


@pytest.fixture(scope="module")
def ur5():
    return manipkit.load("ur5")


def test_alias_rows_of_one_vector_by_hand():
    # limits +-2 pi, +-1, +-2 pi: 1.0 -> {1.0, 1.0 - 2 pi}; 0.5 stays (a turn leaves +-1); 0.0 -> {0, -2 pi, 2 pi}
    # (both ends are inside within 1e-12 of the limits): 2 * 1 * 3 = 6 rows, the vector itself first
    lower, upper = [-TWO_PI, -1.0, -TWO_PI], [TWO_PI, 1.0, TWO_PI]
    rows, origin = alias_rows([[1.0, 0.5, 0.0]], lower, upper, [True, True, True])
    expected = [[a, 0.5, c] for a in (1.0, 1.0 - TWO_PI) for c in (0.0, -TWO_PI, TWO_PI)]
    np.testing.assert_allclose(rows, expected, rtol=0, atol=1e-15)
    assert origin.tolist() == [0] * 6


def test_alias_rows_leave_joints_not_aliased_and_rows_outside():
    rows, origin = alias_rows([[1.0, 0.5], [9.0, 0.0]], [-TWO_PI, -1.0], [TWO_PI, 1.0], [False, True])
    assert rows.tolist() == [[1.0, 0.5]] and origin.tolist() == [0]  # 9.0 not aliased and outside: no row


def test_the_generating_branch_has_the_aliases_counted_from_the_limits(ur5):
    # ur5 (example-robot-data): shoulder_pan, shoulder_lift, wrist_1..3 within +-2 pi (6.28318530718, 4e-13 beyond
    # 2 pi), elbow within +-pi. q = (1.0, -0.5, 0.3, 2.0, -1.0, 0.0): values inside per joint 1.0 and 1.0 - 2 pi;
    # -0.5 and -0.5 + 2 pi; 0.3 only; 2.0 and 2.0 - 2 pi; -1.0 and -1.0 + 2 pi; 0.0, 2 pi and -2 pi:
    # 2 * 2 * 1 * 2 * 2 * 3 = 48 rows for that branch, its own row (each joint nearest 0) and 47 aliases.
    chain = ur5.chain("base_link", "tool0")
    q = np.array([1.0, -0.5, 0.3, 2.0, -1.0, 0.0])
    result = manipkit.ik(ur5, chain.fk(q), tip="tool0", all=True)
    rows = result.solutions[:, chain.columns]
    own = int(np.flatnonzero(np.abs(rows - q).max(axis=1) <= 1e-9)[0])
    assert result.alias_of[own] == -1  # q is each joint's value nearest 0: the branch's own row
    group = np.flatnonzero((result.alias_of == own) | (np.arange(len(rows)) == own))
    assert len(group) == 48 and len({tuple(np.round(r, 9)) for r in rows[group]}) == 48
    assert set(result.labels[i] for i in group) == {result.labels[own]}
    turns = (rows[group] - q) / TWO_PI
    np.testing.assert_allclose(turns, np.round(turns), atol=1e-9)
    assert set(np.round(turns[:, 5]).tolist()) == {-1.0, 0.0, 1.0} and set(np.round(turns[:, 2]).tolist()) == {0.0}
    assert bool(np.all(result.within_limits[group]))
    # every row, aliases too: FK by Pinocchio (robot.transform) reaches the target
    T = chain.fk(q)
    for i in group[::7]:
        np.testing.assert_allclose(ur5.transform("base_link", "tool0", result.solutions[i]), T, atol=1e-12)
    assert float(result.residual_position.max()) < 1e-12 and float(result.residual_rotation.max()) < 1e-12


def test_200_random_configurations_are_found_as_themselves(ur5):
    chain = ur5.chain("base_link", "tool0")
    Q = chain.sample(200, seed=38)
    for q in Q:
        result = manipkit.ik(ur5, chain.fk(q), tip="tool0", all=True)
        rows = result.solutions[:, chain.columns]
        assert np.abs(rows - q).max(axis=1).min() <= 1e-9, q
        # deduplicated: no two rows alike
        d = np.abs(rows[:, None] - rows[None]).max(axis=2) + np.eye(len(rows))
        assert d.min() > 1e-9


def test_branches_only_with_aliases_false(ur5):
    chain = ur5.chain("base_link", "tool0")
    T = chain.fk([1.0, -0.5, 0.3, 2.0, -1.0, 0.0])
    branches = manipkit.ik(ur5, T, tip="tool0", all=True, aliases=False)
    every = manipkit.ik(ur5, T, tip="tool0", all=True)
    assert branches.alias_of is None and len(branches.solutions) == 8
    np.testing.assert_array_equal(every.solutions[:8], branches.solutions)  # the branches first, as they were
    assert (every.alias_of[:8] == -1).all() and (every.alias_of[8:] >= 0).all() and every.count == len(every.solutions)
    assert manipkit.ik(ur5, T, tip="tool0").alias_of is None  # all=False: one solution, no aliases


def test_take_renumbers_alias_of(ur5):
    chain = ur5.chain("base_link", "tool0")
    every = manipkit.ik(ur5, chain.fk([1.0, -0.5, 0.3, 2.0, -1.0, 0.0]), tip="tool0", all=True)
    first_alias = int(np.flatnonzero(every.alias_of == 1)[0])
    kept = every.take([1, first_alias, 0])
    assert kept.alias_of.tolist() == [-1, 0, -1]
    assert every.take([first_alias]).alias_of.tolist() == [-1]  # its branch not kept: a row of its own


def test_cli_lists_the_aliases_and_no_aliases_the_branches():
    words = ["ik", "--robot", "ur5", "--tip", "tool0", "--xyz", "0.4", "0.2", "0.3", "--rpy", "0", "3.1", "0", "--all"]
    data = json.loads(run_cli("manipkit", *words, "--format", "json", status=0).stdout)
    alias_of = data["alias_of"]
    assert alias_of[:8] == [None] * 8 and all(a is not None and 0 <= a < 8 for a in alias_of[8:])
    assert len(data["solutions"]) == data["count"] > 8
    text = run_cli("manipkit", *words, status=0).stdout
    assert f"9. [{data['labels'][alias_of[8]]}; 2 pi alias of {alias_of[8] + 1}]" in text
    only = json.loads(run_cli("manipkit", *words, "--no-aliases", "--format", "json", status=0).stdout)
    assert only["alias_of"] is None and len(only["solutions"]) == 8


def test_a_result_with_every_row_outside_the_limits_gets_no_aliases():
    # the panda pose of tests/test_app_cli_ik.py where every branch with joint 7 locked breaks a limit
    panda = manipkit.load("panda")
    T = np.eye(4)
    T[:3, 3] = (-0.2403, -0.0928, 0.1227)
    T[:3, :3] = matrix_from_rpy([-2.25430034, 1.02374649, 0.88313707])
    result = manipkit.ik(panda, T, all=True, lock={"panda_joint7": 0.5})
    assert len(result.solutions) and not result.within_limits.any() and (result.alias_of == -1).all()


def test_the_compiled_nearest_zero_and_leaders_are_the_numpy_rules():
    """``aliases_kernel.nearest_zero_into`` (the general 6R rows' alias nearest 0) and ``leading_rows`` (rows equal
    modulo 2 pi to an earlier one) give, bit for bit, what the numpy formulas they replaced gave: wrap to (-pi, pi]
    by ``pi - mod(pi - q, 2 pi)``, then the first of the turns 0, 1, -1, 2, -2, 3, -3 inside the limits (1e-12
    widened); a row is a leader when no earlier row is within 1e-9 in every entry (aliased ones modulo 2 pi)."""
    from manipkit.ik.aliases_kernel import leading_rows, nearest_zero_into

    rng = np.random.default_rng(5)
    Q = rng.uniform(-20.0, 20.0, (4000, 6))
    Q[:50] = rng.choice([math.pi, -math.pi, 0.0, -0.0, TWO_PI, 3 * math.pi, 1e-300], (50, 6))  # the edges of the wrap
    lower = np.array([-TWO_PI, -math.pi, -2.0, -3 * TWO_PI, -0.1, -math.pi])
    upper = np.array([TWO_PI, math.pi, 2.0, 3 * TWO_PI, 0.1, math.pi])
    Q[50:60] = np.where(rng.random((10, 6)) < 0.5, lower, upper)  # on the limits themselves
    turns = TWO_PI * np.array([0.0, 1.0, -1.0, 2.0, -2.0, 3.0, -3.0])
    wrapped = np.pi - np.mod(np.pi - Q, TWO_PI)
    moved = wrapped[..., None] + turns
    inside = (moved >= (lower - 1e-12)[:, None]) & (moved <= (upper + 1e-12)[:, None])
    want = np.where(inside.any(axis=-1), wrapped + turns[np.argmax(inside, axis=-1)], wrapped)
    got = Q.copy()
    nearest_zero_into()(got, np.arange(6), lower - 1e-12, upper + 1e-12, turns / TWO_PI)
    assert np.array_equal(got, want) and np.array_equal(np.signbit(got), np.signbit(want))
    aliased = np.array([True, True, False, True, True, False])
    for _ in range(200):
        own = rng.choice([0.0, 1.0, 1.0 + TWO_PI, 1.0 + 5e-10, 1.0 + 2e-9, -1.0], (rng.integers(1, 9), 6))
        turned = own[:, None, :] - own[None, :, :]
        turned = np.where(aliased, np.abs(np.remainder(turned + math.pi, TWO_PI) - math.pi), np.abs(turned))
        leader = np.argmax(turned.max(axis=2) <= 1e-9, axis=1)
        assert np.array_equal(leading_rows()(own, aliased), leader == np.arange(len(own)))


def test_measured_rows_are_pinocchios_residuals():
    """``aliases.measured_rows`` (the chain's FK program and the compiled residual, one call) against Pinocchio's FK
    (``robot.transform``) and ``pose_residuals``, row by row, with and without an owner per row."""
    from manipkit.ik.aliases import measured_rows
    from manipkit.spatial.transforms import pose_residuals

    robot = manipkit.load("ur5")
    chain = robot.chain("base_link", "tool0")
    Q = chain.sample(40, seed=3)
    T = chain.fk(chain.sample(5, seed=4))
    owner = np.arange(40) % 5
    position, rotation = measured_rows(chain, T, Q, owner)
    for k in range(40):
        want = pose_residuals(T[owner[k]], robot.transform("base_link", "tool0", Q[k]), project=False)
        assert abs(position[k] - float(want[0])) < 1e-14 and abs(rotation[k] - float(want[1])) < 1e-14
    same = measured_rows(chain, T[owner], Q)
    assert np.array_equal(same[0], position) and np.array_equal(same[1], rotation)
    assert measured_rows(chain, T, Q[:0])[0].shape == (0,)
