"""Global conditioning index (Gosselin and Angeles): how well an arm is conditioned over its whole joint space.

Conventions (docs/architecture.md), restated:

- The index is the mean of the inverse condition number ``1 / kappa =
  sigma_min / sigma_max`` of the frame's Jacobian (rows ``axes``, angular
  rows times the characteristic ``length`` when both kinds are selected: see
  :mod:`manipkit.analysis.manipulability`) over the joint space, joints
  uniform inside their limits (continuous joints over [-pi, pi]), as
  Gosselin and Angeles (1991) define it with the joint space as the domain:
  ``GCI = (integral of 1/kappa dq) / (integral of dq)``, in [0, 1].
- It is estimated by Monte Carlo: ``samples`` configurations drawn from one
  generator seeded by ``seed`` (the same draws whatever the chunk size), in
  chunks of ``chunk`` rows (batched Jacobians and SVDs, bounded memory); the
  confidence interval is the normal one, ``mean +- z s / sqrt(N)``.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from statistics import NormalDist
from typing import TYPE_CHECKING

import numpy as np

from manipkit.analysis.manipulability import (
    MixedUnitsWarning,
    mixes_units,
    select_rows,
    singular_values,
)
from manipkit.errors import OptionError
from manipkit.kinematics.chain import chain_of
from manipkit.text import short_text

if TYPE_CHECKING:
    from manipkit.kinematics.chain import Chain
    from manipkit.kinematics.robot import Robot

__all__ = ["CHUNK", "ConditioningIndex", "generic_rank", "global_conditioning_index", "rank"]

CHUNK = 50_000  # configurations per batch (about 20 MB of Jacobians for a 7-joint arm)


@dataclass(frozen=True)
class ConditioningIndex:
    """A Monte Carlo estimate of the global conditioning index.

    Attributes
    ----------
    mean : float
        The estimate of the GCI (mean of ``sigma_min / sigma_max``), in [0, 1].
    low, high : float
        The ``confidence`` interval of the mean (normal approximation).
    std : float
        Sample standard deviation of the inverse condition number.
    samples : int
    confidence : float
    frame, base : str
    axes : str or tuple of int
    length : float or None
        Characteristic length used (m), None when the rows did not need one.
    """

    mean: float
    low: float
    high: float
    std: float
    samples: int
    confidence: float
    frame: str
    base: str
    axes: str | tuple
    length: float | None

    def __str__(self) -> str:
        return (f"GCI = {short_text(self.mean, 4)} ({short_text(100 * self.confidence, 3)}% confidence interval "
                f"{short_text(self.low, 4)} to {short_text(self.high, 4)}, {self.samples} samples)")


def global_conditioning_index(chain: Chain | Robot, samples: int = 100_000, *, base: str | None = None,
                              tip: str | None = None, axes="all", length: float | None = None, seed: int = 0,
                              chunk: int = CHUNK, confidence: float = 0.95,
                              progress: Callable[[str, int, int], None] | None = None) -> ConditioningIndex:
    """Mean inverse condition number of the Jacobian over the joint space, with a confidence interval.

    Parameters
    ----------
    chain : Chain or Robot
        The chain whose Jacobian is used (``robot.chain(base, tip)``), or a
        robot with ``base=`` and ``tip=`` (defaults ``base_link``, ``ee_link``).
    samples : int
        Configurations drawn uniformly inside the chain's limits (at least 2).
    axes : "all", "trans", "rot" or sequence of int, keyword-only
        Rows used (:func:`manipkit.analysis.manipulability.select_rows`).
    length : float, optional, keyword-only
        Characteristic length (m) for ``axes`` mixing linear and angular rows
        (a :class:`~manipkit.analysis.manipulability.MixedUnitsWarning` when needed and not given).
    seed : int, keyword-only
        Seed of the sampler; the estimate does not depend on ``chunk``.
    chunk : int, keyword-only
        Configurations per batch.
    confidence : float, keyword-only
        Level of the interval, in (0, 1).
    progress : callable, keyword-only, optional
        Called as ``progress("sampling the joint space", done, samples)``
        after each chunk (the command line draws it with
        :func:`manipkit.app.progress.progress_bar`).

    Returns
    -------
    ConditioningIndex

    Examples
    --------
    >>> import manipkit
    >>> gci = global_conditioning_index(manipkit.load("planar_2r"), 20_000, axes=[0, 1], seed=1)
    >>> 0.0 < gci.low < gci.mean < gci.high < 1.0
    True
    """
    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or samples < 2:
        raise OptionError(f"samples={samples!r:.40} must be a whole number of configurations, at least 2")
    if isinstance(chunk, bool) or not isinstance(chunk, (int, np.integer)) or chunk < 1:
        raise OptionError(f"chunk={chunk!r:.40} must be a whole number of configurations, at least 1")
    if not (0.0 < confidence < 1.0):
        raise OptionError(f"confidence={confidence!r:.40} must be between 0 and 1 (0.95 for 95%)")
    if mixes_units(axes):
        select_rows(np.zeros((6, 1)), axes, length, stacklevel=2)  # the one warning, or the check of length
        if length is None:
            length = 1.0
    else:
        length = None
    chain = chain_of(chain, "global_conditioning_index", base=base, tip=tip)
    rng = np.random.default_rng(seed)
    total = total_sq = 0.0
    done = 0
    if progress and not callable(progress):
        raise OptionError(f"progress={progress!r:.40} must be a callable progress(stage, done, total) or None; "
                            "the command line draws the bar (manipkit dexterity --progress yes)")
    while done < samples:
        m = min(chunk, samples - done)
        J = chain.jacobians(chain.sample(m, seed=rng))  # the chain's columns: no wheel or finger reads singular
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", MixedUnitsWarning)
            inverse = _inverse_condition(select_rows(J, axes, length))
        total += float(np.sum(inverse))
        total_sq += float(np.sum(inverse * inverse))
        done += m
        if progress:
            progress("sampling the joint space", done, samples)
    mean = total / samples
    variance = max(total_sq - samples * mean * mean, 0.0) / (samples - 1)
    std = math.sqrt(variance)
    half = NormalDist().inv_cdf(0.5 + confidence / 2) * std / math.sqrt(samples)
    return ConditioningIndex(mean, mean - half, mean + half, std, int(samples), float(confidence), chain.tip,
                             chain.base, axes if isinstance(axes, str) else tuple(int(a) for a in axes), length)


def _inverse_condition(Js: np.ndarray) -> np.ndarray:
    """``sigma_min / sigma_max`` from the eigenvalues of the Gram matrix (``J J^T`` or ``J^T J``, the smaller).

    Twice as fast as numpy's SVD here; the eigenvalue ``sigma_min^2`` carries an
    absolute error of about ``1e-16 sigma_max^2``, so the ratio is off by at most
    about 1e-8, far inside the interval of any Monte Carlo estimate
    (:func:`manipkit.analysis.manipulability.manipulability` with
    ``"invcondition"`` uses the SVD and is exact to rounding).
    """
    Jt = np.swapaxes(Js, -1, -2)
    gram = Js @ Jt if Js.shape[-2] <= Js.shape[-1] else Jt @ Js
    eigenvalues = np.linalg.eigvalsh(gram)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.sqrt(np.maximum(eigenvalues[..., 0], 0.0) / eigenvalues[..., -1])
    return np.where(eigenvalues[..., -1] > 0.0, ratio, 0.0)


def rank(J, axes="all", length: float | None = None, *, tol: float = 1e-9) -> np.ndarray | int:
    """Number of singular values of the selected rows above ``tol`` (same units as the rows, after ``length``).

    Examples
    --------
    >>> J = np.zeros((6, 2)); J[1] = [2.0, 1.0]; J[5] = [1.0, 1.0]  # planar 2R stretched out along x
    >>> rank(J, "trans"), rank(J, "all", 1.0)
    (1, 2)
    """
    result = np.sum(singular_values(J, axes, length) > tol, axis=-1)
    return int(result) if np.ndim(result) == 0 else result


def generic_rank(chain: Chain | Robot, *, base: str | None = None, tip: str | None = None, axes="all",
                 length: float | None = None, samples: int = 32, seed: int = 0, tol: float = 1e-9) -> int:
    """The rank of the Jacobian's rows ``axes`` at a generic configuration: the largest over random samples.

    ``chain`` as in :func:`global_conditioning_index`. A configuration is
    singular for these rows when its rank is below this one. The generic rank
    is not always ``min(rows, joints)``: a planar 3R has ``"trans"`` rank 2
    (vz is always 0), a planar 2R has ``"all"`` rank 2 even stretched out (it
    can still turn), while its ``"trans"`` rank drops there.
    (:func:`manipkit.analysis.jacobian_report.jacobian_report` gives the
    generic ranks of all, translation and rotation rows at once.)

    Examples
    --------
    >>> import manipkit
    >>> chain = manipkit.load("planar_3r").chain("base_link", "ee_link")
    >>> generic_rank(chain, axes="trans"), generic_rank(chain, axes="all", length=1.0)
    (2, 3)
    """
    chain = chain_of(chain, "generic_rank", base=base, tip=tip)
    Q = chain.sample(samples, seed=seed)
    return int(np.max(rank(chain.jacobians(Q), axes, length, tol=tol), initial=0))
