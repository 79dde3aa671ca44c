"""The compiled loops of a payload layer's block: which closed-form branches of a voxel-bin's pose are weighed, and
the block's capacities reduced per voxel-bin (:mod:`manipkit.analysis.reachmap.payloadmap`).

Numbers in, numbers out (numpy and :mod:`manipkit.kernels` only, so that a change to the modules around them does
not recompile them). Each loop does in one pass over the rows what a chain of numpy operations did over the whole
block, with the same operations per number, so the answers are numpy's to the bit.
"""

from __future__ import annotations

import math

import numpy as np

from manipkit.kernels import lazy_kernel

__all__ = ["kept_branches", "kept_branches_kernel", "per_bin", "per_bin_kernel"]


def kept_branches(q, S, residual_position, residual_rotation, tol, lower_ok, upper_ok, rows, kept):
    """Fill ``rows`` (N, 1 + k, n) and ``kept`` (N, 1 + k) (overwritten) from configurations ``q`` (N, n) and the
    closed-form branches ``S`` (N, k, n) of their poses (NaN: no branch), with the branches' FK residuals (N, k)
    (m, rad).

    Row 0 is the configuration, kept; row ``1 + j`` is branch ``j``, kept when it exists (no NaN), both residuals
    are within ``tol``, every entry lies within ``lower_ok .. upper_ok`` (n,) (the chain's limits widened as
    :func:`manipkit.kinematics.chain.limits_ok`; infinite for a continuous joint), and some entry differs from the
    configuration's by more than ``tol`` modulo 2 pi (``d - 2 pi rint(d / 2 pi)``); a row not kept holds the
    configuration.
    """
    n_rows, n_branches, n = S.shape
    two_pi = 2 * np.pi
    for r in range(n_rows):
        for i in range(n):
            rows[r, 0, i] = q[r, i]
        kept[r, 0] = True
        for j in range(n_branches):
            found = residual_position[r, j] <= tol and residual_rotation[r, j] <= tol
            for i in range(n):
                if math.isnan(S[r, j, i]):
                    found = False
            turned = False
            if found:
                for i in range(n):
                    s = S[r, j, i]
                    if s < lower_ok[i] or s > upper_ok[i]:
                        found = False
                    turn = s - q[r, i]
                    turn -= two_pi * np.rint(turn / two_pi)
                    if abs(turn) > tol:
                        turned = True
            keep = found and turned
            kept[r, 1 + j] = keep
            for i in range(n):
                rows[r, 1 + j, i] = S[r, j, i] if keep else q[r, i]


def per_bin(kept, mass, joint, best, worst, worst_joint):
    """Per configuration ``r`` (row of ``kept`` (N, K)): ``best`` (N,) the largest and ``worst`` (N,) the smallest of
    the capacities (kg) of its kept rows, and ``worst_joint`` (N,) the saturating joint there (the first kept row on
    a tie; NaN capacities as ``numpy.nanmax`` and ``argmin`` take them: ignored by the largest, the first NaN is
    the smallest). ``mass`` and ``joint`` (M,) hold the kept rows' capacities and joints in row-major order of
    ``kept``, whose first column is kept in every row (the stored configuration)."""
    m = 0
    for r in range(kept.shape[0]):
        top, low, low_joint, first = np.nan, np.inf, -1, True
        for j in range(kept.shape[1]):
            if not kept[r, j]:
                continue
            value = mass[m]
            if not math.isnan(value) and (math.isnan(top) or value > top):
                top = value
            if first or (not math.isnan(low) and (math.isnan(value) or value < low)):
                low, low_joint, first = value, joint[m], False
            m += 1
        best[r], worst[r], worst_joint[r] = top, low, low_joint


# nogil: they may run on blocks of rows from several threads at once
kept_branches_kernel = lazy_kernel(kept_branches, error_model="numpy", nogil=True)
per_bin_kernel = lazy_kernel(per_bin, error_model="numpy", nogil=True)
