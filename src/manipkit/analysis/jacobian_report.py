"""The Jacobian report: one configuration's ranks, whether it is singular, the families that hold, what is lost.

:func:`jacobian_report` is the one place that decides "singular": ``manipkit
jacobian`` and the viewer's overlay both print its answer (worded in
:mod:`manipkit.app.jacobian_text`). The report is data, no words.

Conventions (docs/architecture.md), restated:

- The Jacobian is the chain's (``chain.jacobian(q, reference=...)``, 6 x n):
  rows ``vx vy vz wx wy wz`` (the velocity of the tip's origin, m/s, then its
  angular velocity, rad/s), one column per entry of ``chain.joint_names``.
  ``reference="base"``: the base's axes; ``"local"``: the tip's axes. Every
  direction in the report is written in those axes.
- Ranks count the singular values above ``tol``: of all rows (angular rows
  times the characteristic ``length``, m), of the translation rows and of the
  rotation rows. The *generic* rank of a set of rows is the largest over
  random samples of the chain (``chain.sample``), and so are the *movable
  rows*: those not zero at every sample. A planar arm never moves vz, wx, wy,
  so it never loses them.
- A configuration is **singular** when the rank of all rows or of the
  translation rows is below its generic rank.
- At a singular configuration the report gives
  - the singular families of :mod:`manipkit.analysis.singularities` that
    hold (all of them; only for a robot's ``base_link`` -> ``ee_link`` chain,
    where they are defined);
  - joints whose columns are equal or opposite (on one axis);
  - the **lost directions**: for each set of rows that lost rank and whose
    generic rank is the number of its movable rows, a basis of the directions
    in those rows that no joint motion gives: the origin cannot move along a
    translation direction, the frame cannot turn about a rotation direction,
    and an "all" direction (angular part times ``length``) is a combination of
    both that the other two do not already cover;
  - the **null motions**: a basis of unit joint-rate vectors that keep the
    origin still (the null space of the translation rows when they lost rank,
    else of all rows). Each one either leaves the whole frame still
    (``still="frame"``: the null space of all rows, listed first) or keeps
    only the origin still and turns the frame (``still="origin"``, with its
    angular velocity). One-joint motions are exactly that joint's unit
    vector, two-joint motions come next, other vectors last.

Examples
--------
>>> import manipkit
>>> chain = manipkit.load("planar_2r").chain("base_link", "ee_link")
>>> report = jacobian_report(chain, [0.3, 0.0])
>>> report.singular, report.rank_translation, report.generic_rank_translation
(True, 1, 2)
>>> [ROW_NAMES[i] for i in report.movable_rows]
['vx', 'vy', 'wz']
>>> [f.name for f in report.families]
['elbow straight']
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from manipkit.analysis.manipulability import condition_number, manipulability
from manipkit.analysis.singularities import FAMILY_TOL, SingularFamily, families_at
from manipkit.bounds import length as bounded_length
from manipkit.errors import OptionError

if TYPE_CHECKING:
    from manipkit.kinematics.chain import Chain

__all__ = [
    "GENERIC_SAMPLES", "ROW_GROUPS", "ROW_NAMES", "SINGULAR_TOL", "JacobianReport", "LostDirection", "NullMotion",
    "jacobian_report",
]

ROW_NAMES = ("vx", "vy", "vz", "wx", "wy", "wz")
#: The sets of rows whose ranks the report gives: name -> row indices.
ROW_GROUPS = {"all": (0, 1, 2, 3, 4, 5), "translation": (0, 1, 2), "rotation": (3, 4, 5)}
#: Default: singular values at most this (m/s or rad/s times length, per unit joint rate) do not count to a rank.
SINGULAR_TOL = 1e-9
#: Random configurations (``chain.sample(GENERIC_SAMPLES, seed=0)``) that give the generic ranks and movable rows.
GENERIC_SAMPLES = 32
_IN_SPAN = 1e-6  # a unit vector this close to a subspace lies in it (numerical null spaces are good to ~1e-15)
_NOISE = 1e-12  # components of a unit vector below this are rounding noise


@dataclass(frozen=True, eq=False)
class NullMotion:
    """A joint motion that keeps the tip's origin still (read-only arrays).

    Attributes
    ----------
    joint_rates : ndarray, shape (n,)
        A unit vector in joint space (rad/s or m/s per entry of
        ``chain.joint_names``); the largest entry is positive.
    velocity : ndarray, shape (3,)
        The origin's velocity it gives (m/s): zero up to the report's ``tol``.
    angular_velocity : ndarray, shape (3,)
        The frame's angular velocity it gives (rad/s), in the report's axes.
    still : str
        ``"frame"``: the whole frame stays still (the angular velocity is zero
        too); ``"origin"``: only the origin does, the frame turns.
    """

    joint_rates: np.ndarray
    velocity: np.ndarray
    angular_velocity: np.ndarray
    still: str

    @property
    def joints(self) -> tuple[int, ...]:
        """The chain entries that move (non-zero rates)."""
        return tuple(int(i) for i in np.flatnonzero(self.joint_rates))


@dataclass(frozen=True, eq=False)
class LostDirection:
    """A direction in the rows the arm can move that no joint motion gives here.

    ``rows`` is ``"translation"`` (``direction`` (3,): the origin cannot move
    along it), ``"rotation"`` ((3,): the frame cannot turn about it) or
    ``"all"`` ((6,), rows vx .. wz with the angular ones times the report's
    length: a combination of moving and turning). Unit vectors, largest
    entry positive, in the report's axes.
    """

    rows: str
    direction: np.ndarray


@dataclass(frozen=True, eq=False)
class JacobianReport:
    """What :func:`jacobian_report` found at one configuration (immutable; arrays read-only).

    Attributes
    ----------
    chain : Chain
    q : ndarray, shape (n,)
        The chain vector (rad, m).
    reference : str
        ``"base"`` or ``"local"``: the axes of the rows and of every direction here.
    length : float
        Characteristic length (m) multiplying the angular rows where all rows are combined.
    tol : float
        Singular values at most this do not count to a rank.
    family_tol : float
        Distance (rad or m) within which a singular family holds.
    jacobian : ndarray, shape (6, n)
        Rows vx vy vz wx wy wz, the chain's columns.
    singular_values : ndarray
        Of all rows, angular ones times ``length``, largest first.
    rank, rank_translation, rank_rotation : int
    generic_rank, generic_rank_translation, generic_rank_rotation : int
    movable_rows : tuple of int
        Rows (0..5 = vx .. wz) not zero at every sampled configuration.
    singular : bool
        ``rank < generic_rank`` or ``rank_translation < generic_rank_translation``.
    families : tuple of SingularFamily
        Every known family within ``family_tol`` of ``q`` (empty for chains
        other than the robot's base_link -> ee_link, and for robots without
        known families); given whether or not the configuration is singular.
    same_axis : tuple of tuple of int
        At a singular configuration: groups of chain entries whose columns
        are equal or opposite (revolute joints on one axis, prismatic joints
        along one direction).
    lost : tuple of LostDirection
        At a singular configuration: translation directions, then rotation
        directions, then combined ones.
    motions : tuple of NullMotion
        At a singular configuration: those leaving the frame still first.
    manipulability, manipulability_translation, condition_number : float
        Yoshikawa's index of all rows (angular ones times ``length``) and of
        the translation rows, and the condition number of all rows (inf when
        a singular value is 0): :mod:`manipkit.analysis.manipulability`.
    """

    chain: Chain
    q: np.ndarray
    reference: str
    length: float
    tol: float
    family_tol: float
    jacobian: np.ndarray
    singular_values: np.ndarray
    rank: int
    rank_translation: int
    rank_rotation: int
    generic_rank: int
    generic_rank_translation: int
    generic_rank_rotation: int
    movable_rows: tuple[int, ...]
    singular: bool
    families: tuple[SingularFamily, ...]
    same_axis: tuple[tuple[int, ...], ...]
    lost: tuple[LostDirection, ...]
    motions: tuple[NullMotion, ...]
    manipulability: float
    manipulability_translation: float
    condition_number: float

    @property
    def joint_names(self) -> tuple[str, ...]:
        """The chain's joints, one per column."""
        return self.chain.joint_names

    def ranks(self, rows: str) -> tuple[int, int]:
        """(rank, generic rank) of ``rows``: ``"all"``, ``"translation"`` or ``"rotation"``."""
        suffix = {"all": "", "translation": "_translation", "rotation": "_rotation"}[rows]
        return getattr(self, f"rank{suffix}"), getattr(self, f"generic_rank{suffix}")


def jacobian_report(chain: Chain, q=None, *, reference: str = "base", length: float = 1.0,
                    tol: float = SINGULAR_TOL, family_tol: float = FAMILY_TOL) -> JacobianReport:
    """The Jacobian of ``chain`` at ``q`` with its ranks, whether it is singular and what is lost there.

    Parameters
    ----------
    chain : Chain
        ``robot.chain(base, tip)``.
    q : optional
        Joint values as :meth:`Chain.q` takes them (a chain vector, a
        whole-robot vector, a dict); default every joint at 0 or the nearest
        value inside its limits.
    reference : "base" or "local", keyword-only
        Axes of the rows (the base's, RTB ``jacob0``; the tip's, RTB ``jacobe``).
    length : float, keyword-only
        Characteristic length (m, > 0) multiplying the angular rows when all rows are combined.
    tol : float, keyword-only
        Singular values at most ``tol`` (>= 0) do not count to a rank.
    family_tol : float, keyword-only
        Distance (rad or m) within which a singular family holds.

    Returns
    -------
    JacobianReport
        See the module docstring for what each part means.

    Examples
    --------
    >>> import manipkit
    >>> report = jacobian_report(manipkit.load("scara").chain("base_link", "ee_link"), [0.3, 0.0, 0.1, 0.0])
    >>> report.singular, report.rank, report.generic_rank
    (True, 3, 4)
    """
    length = bounded_length(length, "length")
    if not (isinstance(tol, (int, float)) and math.isfinite(tol) and tol >= 0):
        raise OptionError(f"tol={tol!r:.40}: give a tolerance >= 0")
    q = chain.q(q)
    if reference not in ("base", "local"):
        raise OptionError(f"reference={reference!r:.40} is not one of 'base', 'local'")
    J = chain.jacobian(q, reference=reference) if chain.n else np.zeros((6, 0))  # no joints: nothing moves the tip
    generic, movable = _generic(chain, reference, float(length), float(tol))
    scaled = _scaled(J, length)
    ranks = {name: _rank(scaled[list(rows)], tol) for name, rows in ROW_GROUPS.items()}
    singular = ranks["all"] < generic["all"] or ranks["translation"] < generic["translation"]
    robot = chain.robot
    families = ()
    if chain.base == robot.frame("base_link") and chain.tip == robot.frame("ee_link"):
        families = tuple(families_at(robot, chain.full(q), family_tol))
    same_axis, lost, motions = (), (), ()
    if singular:
        same_axis = _same_axis(scaled, tol)
        lost = _lost_directions(scaled, ranks, generic, movable, tol)
        motions = _null_motions(J, scaled, tol, translation=ranks["translation"] < generic["translation"])
    s = np.linalg.svd(scaled, compute_uv=False) if J.shape[1] else np.zeros(0)
    return JacobianReport(
        chain, _read_only(q), reference, float(length), float(tol), float(family_tol), _read_only(J), _read_only(s),
        ranks["all"], ranks["translation"], ranks["rotation"],
        generic["all"], generic["translation"], generic["rotation"], movable, bool(singular), families, same_axis,
        lost, motions,
        float(manipulability(J, "yoshikawa", "all", length)) if J.shape[1] else 0.0,
        float(manipulability(J, "yoshikawa", "trans")) if J.shape[1] else 0.0,
        float(condition_number(J, "all", length)) if J.shape[1] else math.inf,
    )


# --------------------------------------------------------------------------
# ranks and what the arm can ever move


def _scaled(J: np.ndarray, length: float) -> np.ndarray:
    """Jacobians (..., 6, n) with the angular rows times ``length`` (the units agree: m/s)."""
    return np.concatenate([J[..., :3, :], length * J[..., 3:, :]], axis=-2)


def _rank(A: np.ndarray, tol: float) -> int:
    if A.size == 0:
        return 0
    return int(np.sum(np.linalg.svd(A, compute_uv=False) > tol))


@functools.lru_cache(maxsize=64)
def _generic(chain: Chain, reference: str, length: float, tol: float) -> tuple[dict[str, int], tuple[int, ...]]:
    """({rows: generic rank}, movable rows) over ``GENERIC_SAMPLES`` random configurations of the chain (cached)."""
    if chain.n == 0:
        return {name: 0 for name in ROW_GROUPS}, ()
    Js = _scaled(chain.jacobians(chain.sample(GENERIC_SAMPLES, seed=0), reference=reference), length)
    ranks = {}
    for name, rows in ROW_GROUPS.items():
        s = np.linalg.svd(Js[:, list(rows)], compute_uv=False)
        ranks[name] = int(np.max(np.sum(s > tol, axis=-1)))
    movable = tuple(i for i in range(6) if np.max(np.abs(Js[:, i, :])) > tol)
    return ranks, movable


# --------------------------------------------------------------------------
# what is lost


def _same_axis(scaled: np.ndarray, tol: float) -> tuple[tuple[int, ...], ...]:
    """Groups of columns (each moving the frame) that are equal or opposite, in column order."""
    n = scaled.shape[1]
    moving = [np.linalg.norm(scaled[:, k]) > tol for k in range(n)]
    groups: list[list[int]] = []
    for k in range(n):
        if not moving[k]:
            continue
        for group in groups:
            first = scaled[:, group[0]]
            if min(np.linalg.norm(first - scaled[:, k]), np.linalg.norm(first + scaled[:, k])) <= tol:
                group.append(k)
                break
        else:
            groups.append([k])
    return tuple(tuple(group) for group in groups if len(group) > 1)


def _lost_directions(scaled, ranks, generic, movable, tol) -> tuple[LostDirection, ...]:
    """Directions no joint motion gives, per set of rows that lost rank and can be told (see the module docstring)."""
    found: list[LostDirection] = []
    known: list[np.ndarray] = []  # as 6-vectors, to leave out of the combined directions
    for name in ("translation", "rotation", "all"):
        rows = [r for r in ROW_GROUPS[name] if r in movable]
        if ranks[name] >= generic[name] or generic[name] != len(rows):
            continue  # nothing lost, or more directions missing than are lost (fewer joints than rows)
        U, s, _ = np.linalg.svd(scaled[rows], full_matrices=True)
        rank = int(np.sum(s > tol))
        complement = np.zeros((6, len(rows) - rank))
        complement[rows] = U[:, rank:]
        candidates = [np.eye(6)[r] for r in rows]
        for d in _simple_basis(complement, candidates, start=known if name == "all" else ()):
            known.append(d)
            offset = 3 if name == "rotation" else 0
            found.append(LostDirection(name, _read_only(d if name == "all" else d[offset:offset + 3].copy())))
    return tuple(found)


def _null_basis(A: np.ndarray, tol: float) -> np.ndarray:
    """Orthonormal columns spanning the joint motions ``x`` with ``A x`` zero (singular values at most ``tol``)."""
    _, s, Vt = np.linalg.svd(A, full_matrices=True)
    return Vt[int(np.sum(s > tol)):].T


def _motion_candidates(A: np.ndarray, tol: float) -> list[np.ndarray]:
    """One-joint motions (a column of ``A`` that is zero), then two-joint ones (two parallel columns)."""
    n = A.shape[1]
    still = [np.linalg.norm(A[:, k]) <= tol for k in range(n)]
    candidates = [np.eye(n)[k] for k in range(n) if still[k]]
    for a in range(n):
        for b in range(a + 1, n):
            if still[a] or still[b]:
                continue
            _, s, Vt = np.linalg.svd(A[:, [a, b]])
            if s[-1] <= tol:
                x = np.zeros(n)
                x[[a, b]] = Vt[-1]
                candidates.append(x)
    return candidates


def _null_motions(J, scaled, tol, *, translation: bool) -> tuple[NullMotion, ...]:
    """The frame-still motions (null space of all rows), then, when the translation rows lost rank, the rest of theirs."""
    frame = _simple_basis(_null_basis(scaled, tol), _motion_candidates(scaled, tol))
    origin = []
    if translation:
        origin = _simple_basis(_null_basis(J[:3], tol), _motion_candidates(J[:3], tol), start=frame)
    motions = []
    for still, rates in [("frame", x) for x in frame] + [("origin", x) for x in origin]:
        twist = J @ rates
        motions.append(NullMotion(_read_only(rates), _read_only(twist[:3]), _read_only(twist[3:]), still))
    return tuple(motions)


def _simple_basis(span: np.ndarray, candidates, *, start=()) -> list[np.ndarray]:
    """Unit vectors that complete ``start`` to a basis of the columns of ``span`` (orthonormal), ``start`` left out.

    The candidates that lie in the span come first, each if it adds a
    direction; what is left is an orthonormal basis of the rest. Each vector
    is cleaned of rounding noise and signed so that its largest entry is
    positive (the first of equal ones).
    """
    k = span.shape[1]
    chosen = [np.asarray(v, dtype=float) for v in start]
    new: list[np.ndarray] = []

    def outside(v, basis) -> float:
        if not basis:
            return float(np.linalg.norm(v))
        Q = np.linalg.qr(np.column_stack(basis))[0]
        return float(np.linalg.norm(v - Q @ (Q.T @ v)))

    for c in candidates:
        if len(chosen) >= k:
            break
        c = c / np.linalg.norm(c)
        if np.linalg.norm(c - span @ (span.T @ c)) <= _IN_SPAN and outside(c, chosen) > _IN_SPAN:
            chosen.append(c)
            new.append(_signed(c))
    if len(chosen) < k:
        rest = span
        if chosen:
            Q = np.linalg.qr(np.column_stack(chosen))[0]
            rest = span - Q @ (Q.T @ span)
        U = np.linalg.svd(rest, full_matrices=False)[0]
        new += [_signed(u) for u in U[:, : k - len(chosen)].T]
    return new


def _signed(v: np.ndarray) -> np.ndarray:
    """``v`` without rounding noise, unit length, its largest entry (the first of equal ones) positive."""
    v = np.where(np.abs(v) <= _NOISE, 0.0, v)
    v = v / np.linalg.norm(v)
    return (v if v[np.argmax(np.round(np.abs(v), 9))] > 0 else -v) + 0.0  # + 0.0: no negative zeros


def _read_only(array: np.ndarray) -> np.ndarray:
    array = np.array(array, dtype=float)
    array.setflags(write=False)
    return array
