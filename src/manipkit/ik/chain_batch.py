"""The compiled batch of :func:`manipkit.ik.chain_ik.chain_ik_many` (UR, OPW and SRS families), on threads.

Targets are cut into contiguous blocks; each block is solved and aliased by
:func:`manipkit.closed_form.arms_kernel.solve_rows_into` (a 7R SRS arm, each
target at its own arm angle:
:func:`manipkit.closed_form.srs_kernel.solve_srs_rows_into`; compiled, no GIL),
its non-empty slots alone are put through the chain's compiled FK
(``chain.compiled_fk``: :class:`manipkit.kernels.fk.ChainFK`, whose loop
runs without the GIL too) and measured by
:func:`manipkit.closed_form.arms_kernel.measure_at` (``pose_residuals``'
compiled twin). Up to ``threads`` threads of a pool take blocks at once
while the calling thread waits; a batch of at most one block
(:data:`BLOCK`) or under :data:`MIN_TARGETS_PER_THREAD` targets per thread
runs on the calling thread alone. Every number of a target is computed from that target
alone, by the same operations whatever block or thread it falls in, so the
answers are the same bit for bit on any number of threads (tested). Targets
the compiled loop hands back are solved afterwards by the numpy reference
(:func:`manipkit.closed_form.arms.solve_6r`,
:func:`manipkit.closed_form.srs.solve_srs_many`, through ``chain_ik``) and
checked the same way.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from manipkit.kernels.blocks import run_blocks

if TYPE_CHECKING:
    from manipkit.kinematics.chain import Chain

__all__ = ["BLOCK", "MIN_TARGETS_PER_THREAD", "checked_many"]

#: Fewest targets per thread: a smaller batch runs on the calling thread alone (a thread's start, about 0.1 ms,
#: is worth about 100 targets).
MIN_TARGETS_PER_THREAD = 256
#: Targets per block: one block's rows, packed rows and reached poses (about 1.7 MB) stay in a 2 MB L2 cache; half as
#: many Python calls between the compiled loops as blocks of 512 (6-10 % faster per pose on 2 threads, measured).
BLOCK = 1024


def _run_blocks(work, n_targets: int, threads: int) -> None:
    """``work(start, stop)`` on the blocks of :data:`BLOCK` targets covering ``0 .. n_targets``, on up to
    ``threads`` threads (:func:`~manipkit.kernels.blocks.run_blocks`)."""
    run_blocks(work, n_targets, block=BLOCK, min_rows_per_thread=MIN_TARGETS_PER_THREAD, threads=threads,
               name="chain_ik_many")


def _check(chain: Chain, T: np.ndarray, project: np.ndarray, packed: np.ndarray, index: np.ndarray,
           check: tuple[float, float], residuals: np.ndarray, success: np.ndarray, projected) -> None:
    """``residuals`` ((B, 8, 2), written) of the rows ``packed`` (M, n) in slots ``index`` (M,) (``8 n + k``)
    against targets ``T`` (B, 4, 4) (their rotations projected where ``project``), NaN in the empty slots, and
    ``success`` (B,): the chain's compiled FK of those rows alone, then the compiled residual. ``projected``:
    targets (K, 4, 4) -> the same with their rotation blocks projected to rotations."""
    from manipkit.closed_form.arms_kernel import measure_at

    if project.any():
        T = T.copy()
        T[project] = projected(T[project])
    reached = chain.compiled_fk.transforms(packed) if len(packed) else np.empty((0, 4, 4))  # rows the solvers made
    measure_at(T, reached, index, check, residuals, success)


def checked_many(chain: Chain, prepared: tuple, T: np.ndarray, check: tuple[float, float], threads: int, *,
                 reference, projected, arm_angles: np.ndarray | None = None
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``chain_ik_many`` of the UR, OPW and SRS families: every branch of targets ``T`` (N, 4, 4) solved, aliased,
    put through the chain's FK and measured against ``check`` (m, rad), in blocks on up to ``threads`` threads.

    ``prepared``: the chain's constants (``ik.ideal_arm.compiled_arm``); ``arm_angles`` (N,, rad): a 7R SRS
    arm's, one per target (None for the 6R families); ``reference``: indices (K,) of targets -> (valid (K, 8),
    free (K,): a free angle, rows (K, 8, n)) by the numpy reference, for the targets the compiled loop hands back;
    ``projected`` as :func:`_check` takes it. Returns (rows (N, 8, n), count (N,), success (N,), residuals
    (N, 8, 2)).
    """
    T = np.ascontiguousarray(T, dtype=float)
    if arm_angles is None:
        from manipkit.closed_form.arms_kernel import solve_rows_into

        def solve(a: int, b: int, *outputs) -> int:
            return solve_rows_into(prepared, T[a:b], *outputs)
    else:
        from manipkit.closed_form.srs_kernel import solve_srs_rows_into

        def solve(a: int, b: int, *outputs) -> int:
            return solve_srs_rows_into(prepared, T[a:b], arm_angles[a:b], *outputs)
    N, n = T.shape[0], int(prepared[1][3])
    valid, fallback, project = np.zeros((N, 8), dtype=bool), np.zeros(N, dtype=bool), np.zeros(N, dtype=bool)
    Q, residuals, success = np.empty((N, 8, n)), np.empty((N, 8, 2)), np.empty(N, dtype=bool)

    def work(a: int, b: int) -> None:  # row slices of C-contiguous arrays: views, written in place
        packed, index = np.empty((8 * (b - a), n)), np.empty(8 * (b - a), dtype=np.int64)
        M = solve(a, b, valid[a:b], fallback[a:b], project[a:b], Q[a:b], packed, index)
        _check(chain, T[a:b], project[a:b], packed[:M], index[:M], check, residuals[a:b], success[a:b], projected)

    _run_blocks(work, N, threads)
    free_any = np.zeros(N, dtype=bool)
    if fallback.any():  # the targets handed back: the numpy reference, then the same check
        rows = np.flatnonzero(fallback)
        valid[rows], free_any[rows], Q[rows] = reference(rows)
        checked, reached = np.empty((len(rows), 8, 2)), np.empty(len(rows), dtype=bool)
        index = np.flatnonzero(~np.isnan(Q[rows, :, 0]).reshape(-1))
        _check(chain, T[rows], project[rows], Q[rows].reshape(-1, n)[index], index, check, checked, reached, projected)
        residuals[rows], success[rows] = checked, reached
    return Q, np.where(free_any, np.inf, valid.sum(axis=-1).astype(float)), success, residuals
