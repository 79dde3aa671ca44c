"""The 2 pi aliases of IK solutions: :func:`alias_rows` (pure arrays) and :func:`with_aliases` (an IK result).

A revolute joint at ``q`` and at ``q + 2 pi k`` puts every link in the same
place, so where a joint's range spans more than a full turn (the UR arms'
+-2 pi) one branch of a closed form is several joint vectors inside the
limits. The closed forms give each branch once, each joint at its in-limit
value nearest 0 (:mod:`manipkit.ik.chain_ik`); ``manipkit.ik(..., all=True)``
then lists every other in-limit alias of every branch after the branches,
each with ``alias_of`` naming its branch's row (:class:`manipkit.ik.result.IKResult`).

Conventions: radians; rows are joint vectors (whole-robot or chain order, as
given); a value counts as inside its limits within
:data:`manipkit.kinematics.chain.LIMIT_TOLERANCE` (as ``within_limits``);
only joints whose limits are finite are aliased (a continuous joint's angle
stays wrapped to (-pi, pi]), and a joint at most :data:`MAX_TURNS` whole
turns from its value.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from manipkit.ik.aliases_kernel import fresh_aliases, leading_rows
from manipkit.ik.result import PLANAR_POSITION, SPATIAL_POSITION, IKResult
from manipkit.kinematics.chain import limits_ok
from manipkit.spatial.transforms import check_transform, pose_residuals, projected_rotation

if TYPE_CHECKING:
    from manipkit.kinematics.chain import Chain

__all__ = ["MAX_ALIAS_ROWS", "MAX_TURNS", "alias_rows", "measured_rows", "warm_up", "with_aliases"]

TWO_PI = 2.0 * math.pi
#: The most whole turns an alias is from the value it aliases (a range of +-3 full turns is covered).
MAX_TURNS = 3
#: The most alias rows one answer lists (beyond, the note says how many were left out).
MAX_ALIAS_ROWS = 4096
#: The turns tried, the value itself first: ties and orders go to the fewest turns.
_TURNS = np.array([0] + [s * k for k in range(1, MAX_TURNS + 1) for s in (-1, 1)], dtype=float)


def alias_rows(Q, lower, upper, aliased, *, limit: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Every vector ``q + 2 pi k`` (k whole, per entry) inside the limits, of each row of ``Q``.

    Parameters
    ----------
    Q : array_like, shape (m, n)
        Joint vectors (rad for the aliased entries).
    lower, upper : array_like, shape (n,)
        The limits; a value within ``LIMIT_TOLERANCE`` of a limit is inside.
    aliased : array_like of bool, shape (n,)
        The entries that may move by whole turns (revolute joints with finite
        limits); the others keep their value and must be inside as they are.
    limit : int or None, keyword-only
        The most rows to give (the first ones, in the order below); None: every one.

    Returns
    -------
    rows : ndarray, shape (r, n)
        Each row's aliases in turn, the row itself first when it is inside,
        then the others in the order of the fewest turns, the first entry's
        turns changing slowest (``itertools.product``); a row with an entry
        that has no value inside contributes none.
    origin : ndarray of int, shape (r,)
        The row of ``Q`` each came from.

    Examples
    --------
    >>> rows, origin = alias_rows([[1.0, 0.5]], [-2 * np.pi, -1.0], [2 * np.pi, 1.0], [True, True])
    >>> (rows - [1.0, 0.5]).round(6).tolist(), origin.tolist()
    ([[0.0, 0.0], [-6.283185, 0.0]], [0, 0])
    """
    Q = np.asarray(Q, dtype=float).reshape(len(Q), -1)
    low, high = limits_ok(lower, upper)
    rows, origin, _ = _fresh_aliases(Q, low, high, aliased, limit, np.zeros((0, Q.shape[1])), None)
    return rows, origin




def _fresh_aliases(Q, low, high, aliased, limit, listed, cap):
    """:func:`manipkit.ik.aliases_kernel.fresh_aliases` with the aliased entries those with finite limits, ``limit``
    and ``cap`` None for none:
    (rows (r, n), their rows of ``Q`` (r,), how many fresh ones there are, counted up to ``cap + 1``)."""
    aliased = np.asarray(aliased, dtype=bool) & np.isfinite(low) & np.isfinite(high)
    unbounded = np.iinfo(np.int64).max // 2
    return fresh_aliases()(np.ascontiguousarray(Q, dtype=float), np.ascontiguousarray(low, dtype=float),
                           np.ascontiguousarray(high, dtype=float), aliased, _TURNS,
                           unbounded if limit is None else int(limit), np.ascontiguousarray(listed, dtype=float),
                           unbounded if cap is None else int(cap))


def measured_rows(chain: Chain, T: np.ndarray, Q: np.ndarray, owner: np.ndarray | None = None
                  ) -> tuple[np.ndarray, np.ndarray]:
    """(position m (M,), rotation rad (M,)) of chain rows ``Q`` (M, n) against targets ``T`` (N, 4, 4) whose rotation
    blocks are rotations, row ``k`` against ``T[owner[k]]`` (``owner`` None: ``T[k]``): the chain's FK program and
    ``pose_residuals(project=False)``'s compiled twin in one compiled call
    (:func:`manipkit.closed_form.check_kernel.measure_rows`), without numpy's per-call cost on a few rows."""
    from manipkit.closed_form.check_kernel import measure_rows

    residuals = np.empty((len(Q), 2))
    if len(Q):
        floats, ints = chain.program.row_tables
        owner = np.arange(len(Q)) if owner is None else np.ascontiguousarray(owner, dtype=np.intp)
        measure_rows(np.ascontiguousarray(Q, dtype=float), np.ascontiguousarray(T, dtype=float), owner, floats, ints,
                     residuals)
    return residuals[:, 0], residuals[:, 1]


def with_aliases(result: IKResult, chain: Chain, target, *, held=()) -> IKResult:
    """``result`` (every branch of a closed form or of the general 6R elimination) with, after its rows, every other
    in-limit 2 pi alias of each row inside the limits, and ``alias_of`` saying whose.

    Parameters
    ----------
    result : IKResult
        Rows as whole-robot vectors (``chain.robot.joint_names``) or in chain order; a family (``count``
        infinite) or a result without rows is returned as it is, with ``alias_of`` all -1.
    chain : Chain
        The chain solved: its revolute joints with finite limits are aliased.
    target : array_like, shape (4, 4)
        ``T_base_tip`` the rows reach: each alias is measured by forward kinematics of the chain, as every row is.
    held : iterable of str, keyword-only
        Joints held at a value (``lock=``): never aliased.

    Returns
    -------
    IKResult
        The branch rows first, as they were (``alias_of`` -1), then the aliases of row 0, of row 1, ... (``alias_of``
        the row; labels, ``within_limits``, collision marks as the branch's); ``count`` counts every row. Rows
        outside the limits are not aliased; an alias equal (to 1e-9) to a row already listed is left out (rows equal
        modulo 2 pi, a branch found twice, list their aliases once, as aliases of the first).
    """
    k = len(result.solutions)
    branch = np.full(k, -1, dtype=np.intp)
    if not k or result.infinite:
        return result.replaced(alias_of=branch)
    whole = result.solutions.shape[1] != chain.n
    columns = chain.columns if whole else np.arange(chain.n)
    aliased = chain.aliasable.copy()  # writable, as the kernels were compiled for
    if held:
        aliased &= np.array([name not in held for name in chain.joint_names], dtype=bool)
    within = np.ones(k, dtype=bool) if result.within_limits is None else np.asarray(result.within_limits)
    inside = np.flatnonzero(within)
    if not len(inside):  # no row inside the limits: none is aliased
        return result.replaced(alias_of=branch)
    own = result.solutions[inside][:, columns]
    # Rows equal modulo 2 pi (a doubled branch) have the same aliases: the first of them, its leader, lists them.
    leaders = np.flatnonzero(leading_rows()(np.ascontiguousarray(own, dtype=float), aliased))
    # every alias of the leaders (the first MAX_ALIAS_ROWS + rows + 1), less those equal to a branch row (to 1e-9)
    low, high = limits_ok(chain.lower, chain.upper)
    chain_rows, origin, fresh = _fresh_aliases(own[leaders], low, high, aliased, MAX_ALIAS_ROWS + len(own) + 1, own,
                                               MAX_ALIAS_ROWS)
    left_out = fresh > MAX_ALIAS_ROWS
    if not len(chain_rows):
        return result.replaced(alias_of=branch)
    of = inside[leaders[origin]]
    Q = np.array(result.solutions[of], dtype=float)
    Q[:, columns] = chain_rows
    T = check_transform(target, what="IK target")
    if result.mode in (PLANAR_POSITION, SPATIAL_POSITION):
        position, rotation = pose_residuals(T, chain.fk(chain_rows), mode="position")
    else:
        T = np.array(T, dtype=float)
        T[:3, :3] = projected_rotation(T[:3, :3])
        position, rotation = measured_rows(chain, T[None], chain_rows, np.zeros(len(chain_rows), dtype=np.intp))
    labels = result.labels
    note = (f"{result.note}; listed after the {k} branch row(s): their {len(of)} other in-limit 2 pi alias(es) "
            "(alias_of names each one's branch)")
    if left_out:
        note += f"; more beyond the first {MAX_ALIAS_ROWS} are left out (aliases=False lists the branches only)"
    per_row = dict(
        solutions=np.concatenate([result.solutions, Q]),
        labels=labels + tuple([labels[i] for i in of.tolist()]),  # each alias carries its branch's per-row fields
        residual_position=np.concatenate([result.residual_position, np.atleast_1d(position)]),
        residual_rotation=np.concatenate([result.residual_rotation, np.atleast_1d(rotation)]),
        within_limits=None if result.within_limits is None else np.concatenate([within, np.ones(len(of), bool)]),
        refined=None if result.refined is None else np.concatenate([result.refined, result.refined[of]]),
        collides=result.collides + tuple([result.collides[i] for i in of.tolist()]) if result.collides else (),
        clearance=None if result.clearance is None else np.concatenate([result.clearance, result.clearance[of]]),
    )
    return result.replaced(count=k + len(of), note=note, alias_of=np.concatenate([branch, of]), **per_row)


def warm_up() -> None:
    """Compile (or load from the kernel cache) the aliases' kernels with the types :func:`with_aliases` and the
    general 6R rows pass (``make kernels``)."""
    from manipkit.ik.aliases_kernel import nearest_zero_into

    alias_rows(np.zeros((1, 2)), [-7.0, -1.0], [7.0, 1.0], [True, True])
    leading_rows()(np.zeros((2, 2)), np.ones(2, dtype=bool))
    nearest_zero_into()(np.zeros((1, 2)), np.arange(2), np.full(2, -7.0), np.full(2, 7.0), np.zeros(1))
