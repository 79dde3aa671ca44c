"""One answer type for every IK solver: :class:`IKResult` for one target, :class:`IKBatch` for many.

Numerical IK (:func:`manipkit.ik.numerical.ik`, with or without
``all=True``), the closed forms (:mod:`manipkit.ik.planar`,
:mod:`manipkit.ik.planar_modes`, :mod:`manipkit.ik.decoupled`
and :func:`manipkit.ik.textbook.analytic_ik`) all return an
:class:`IKResult`; batched numerical IK (:func:`manipkit.ik.numerical_many.ik_many`)
and the planar batch solvers (``ik_2r_batch``, ``ik_3r_batch``) return an
:class:`IKBatch`, with the same field names and leading target axes
(docs/site/internals/ik-results.md). This module sits beside ``errors.py``
and ``text.py``, below kinematics and closed_form, so both use it; it
imports numpy, errors and text only. :func:`manipkit.bounds.tolerances` is the
one parser of residual tolerances.

Conventions: metres and radians; solutions are joint vectors in
``joint_names`` order (a robot's whole joint vector for numerical IK and
``analytic_ik``; the solver's table order otherwise); residuals are measured
by forward kinematics of each answer through the real chain
(:func:`manipkit.spatial.transforms.pose_residuals`), never taken from the
solver's algebra or iteration.
"""

from __future__ import annotations

import html
import math
from collections.abc import Callable
from dataclasses import dataclass, field, fields, replace

import numpy as np

from manipkit.errors import ClosedFormIKError
from manipkit.text import short_text

__all__ = [
    "FAILURE_KINDS",
    "METHODS",
    "MODES",
    "PLANAR_POSE",
    "PLANAR_POSITION",
    "SPATIAL_POINTING",
    "SPATIAL_POSE",
    "SPATIAL_POSITION",
    "IKBatch",
    "IKFailure",
    "IKResult",
    "failure_of",
    "read_only",
]

PLANAR_POSITION = "planar position (x, y)"
PLANAR_POSE = "planar pose (x, y, phi)"
SPATIAL_POSITION = "spatial position (x, y, z)"
SPATIAL_POSE = "spatial pose (x, y, z, R)"
SPATIAL_POINTING = "spatial position and pointing axis (x, y, z, axis)"
#: What a solver can be asked to meet: the ``mode`` of every result. The closed forms solve the first four;
#: numerical IK solves the spatial ones (its ``mode="pose"``, ``"position"``, ``"position+axis"``).
MODES = (PLANAR_POSITION, PLANAR_POSE, SPATIAL_POSITION, SPATIAL_POSE, SPATIAL_POINTING)
#: How an answer was found (:attr:`IKResult.method`): every branch in closed form, a numerical search, or every
#: isolated solution of a general 6R chain by algebraic elimination (:mod:`manipkit.ik.general6r`).
METHODS = ("closed_form", "numerical", "algebraic")


def read_only(array, shape_tail: tuple[int, ...] = ()) -> np.ndarray:
    """A float copy of ``array`` that cannot be written to (an empty input gets shape ``(0, *shape_tail)``)."""
    copy = np.array(array, dtype=float)
    if copy.size == 0 and shape_tail:
        copy = copy.reshape((0,) + tuple(shape_tail))
    copy.setflags(write=False)
    return copy


#: How an IK answer can fail (:attr:`IKFailure.kind`): the target lies beyond what the chain can reach (or a
#: component it cannot meet: ``unmet``); every solution found breaks a joint limit; every solution found is in
#: collision; the best configuration found misses the target by more than ``tol`` (numerical IK that did not
#: converge, or closed-form rows that failed the forward-kinematics check); the target is reached only at a
#: singular configuration the solver does not list.
FAILURE_KINDS = ("unreachable", "joint_limits", "collision", "tolerance", "singular")
#: The kinds a result's own fields show (:func:`failure_of`); the others only the solver knows and records.
DERIVED_KINDS = ("unreachable", "tolerance")


@dataclass(frozen=True)
class IKFailure:
    """Why an IK answer has no solution, as data: what failed, the joints or link pairs concerned, the numbers.

    Attributes
    ----------
    kind : str
        One of :data:`FAILURE_KINDS`.
    message : str
        The same in one sentence with its numbers (what :attr:`IKResult.reason` prints).
    joints : tuple of str
        The joints concerned (``joint_limits``: those outside their limits), else ``()``.
    pairs : tuple of (str, str)
        ``collision``: the link pairs in contact (the deepest of the first solution first), else ``()``.
    values : tuple of (str, float)
        Named numbers, metres and radians: ``("outside_by", 0.3)``, ``("position", 1e-3)`` (a best residual),
        ``("distance", -0.01)`` (a pair's signed distance), the ``unmet`` components.

    Examples
    --------
    >>> from manipkit.ik.planar import ik_2r
    >>> failure = ik_2r(3.0, 0.0, 1.0, 1.0).failure
    >>> failure.kind, dict(failure.values)["outside_by"]
    ('unreachable', 1.0)
    """

    kind: str
    message: str
    joints: tuple[str, ...] = ()
    pairs: tuple[tuple[str, str], ...] = ()
    values: tuple[tuple[str, float], ...] = ()

    def __post_init__(self):
        if self.kind not in FAILURE_KINDS:
            raise ValueError(f"IKFailure.kind must be one of {', '.join(FAILURE_KINDS)}, got {self.kind!r}")


def failure_of(result: IKResult) -> IKFailure | None:
    """The failure a result's own fields show (None with a solution): ``unmet`` or ``outside_by`` -> unreachable;
    a closest configuration or rows rejected by the FK check -> tolerance; else unreachable (no branch exists).

    Solvers that know more (collisions, joint limits) give :class:`IKFailure` themselves.
    """
    if result.solutions.shape[0]:
        return None
    values = tuple((name, float(size)) for name, size in result.unmet)
    if result.outside_by > 0.0:
        values += (("outside_by", float(result.outside_by)),)
    if result.unmet or result.outside_by > 0.0:
        return IKFailure("unreachable", result.note, values=values)
    if result.closest_residuals is not None:
        position, rotation = (float(v) for v in result.closest_residuals)
        return IKFailure("tolerance", result.note, values=(("position", position), ("rotation", rotation)))
    if result.rejected:
        return IKFailure("tolerance", result.note, values=(("rejected", float(result.rejected)),))
    return IKFailure("unreachable", result.note)


@dataclass(frozen=True, eq=False, repr=False, init=False)
class IKResult:
    """Every IK answer for one target, from any solver (numerical or closed form).

    Attributes
    ----------
    solutions : ndarray, shape (k, n)
        The solutions, read-only, one joint vector per row (rad, continuous and
        closed-form angles wrapped to (-pi, pi]; m for a prismatic joint), in
        the solver's documented order: the closed forms list their branches
        in a fixed order (planar: elbow-down first; decoupled: see
        :mod:`manipkit.ik.decoupled`), numerical IK in the order
        found (``all=True``: pairwise distinct, angles compared modulo 2 pi).
        For a family (``count`` infinite) a row holds one representative (the
        free joint at 0), or the members at a few sampled values of a free
        parameter that is not a joint (:meth:`members` gives any others).
    labels : tuple of str
        One per row: the branch (``"elbow-down"``, ``"front, elbow up, no
        flip"``, ``"phi = 0.5, elbow-down"``); ``""`` where a solver has no
        name for it (numerical IK).
    count : int or float
        0, 1, 2, ... solutions, or ``math.inf`` for a one-parameter family
        (``free_parameter`` names it). A numerical search counts what it
        found (it proves neither that there are no others nor a continuum).
    note : str
        The solver's account in one line, with its numbers: how many
        solutions and why (which case, which family), or why none.
    residual_position, residual_rotation : ndarray, shape (k,)
        Per row: the distance (m) between the reached and the wanted frame
        origin, and the rotation residual (rad) of ``mode`` (the angle
        between reached and wanted orientation for a pose, between the
        pointing axes for a pointing target, 0 for a position), measured by
        forward kinematics of the row through the real chain (the robot's
        URDF, or the solver's DH table).
    mode : str
        What was asked, one of :data:`MODES`.
    solver : str
        The function that answered, e.g. ``"planar.ik_2r"``, ``"ik.numerical"``.
    joint_names : tuple of str
        The joints the columns stand for (``()`` when the solver has no names for them).
    free_parameter : str
        With an infinite ``count``: the free joint(s) or parameter by their
        textbook names (``"q1"``, ``"theta4"``, ``"phi"``); else ``""``.
    family : str
        The family in words (which joint is free and how the others follow), or ``""``.
    free_joints : tuple of int
        Columns (0-based) of the free joints.
    unmet : tuple of (str, float)
        With no solution: each component of the target the arm provably
        cannot meet and by how much (m or rad), e.g. ``(("orientation", 1.14),)``,
        ``(("z", 0.3),)``, ``(("position", 0.2),)``; ``()`` otherwise.
    rejected : int
        Candidates dropped because their forward kinematics missed the target.
    outside_by : float
        How far (m) the target (2R), wrist point (3R) or, for numerical IK,
        the target beyond the chain's reach bound lies out of reach; 0.0 when
        reachable or not known to be out of reach.
    side : str
        ``"too far"`` or ``"too close"`` when out of reach, else ``""``.
    iterations, attempts : int
        Numerical IK: Levenberg-Marquardt iterations and starts used (summed
        over every attempt made); 0 for a closed form.
    closest, closest_residuals : ndarray or None
        Numerical IK with no solution: the configuration found closest to
        the target, and its (position m, rotation rad) residuals; else None.
    family_function : callable or None
        For a family whose free parameter is not a joint: ``values -> IKResult``
        (see :meth:`members`).
    within_limits : ndarray of bool, shape (k,), or None
        Per row: inside the joint limits (the closed forms of
        :mod:`manipkit.ik.chain_ik` keep out-of-limit branches and
        mark them here); None when the solver does not say.
    refined : ndarray, shape (k,), or None
        Per row: how far (largest joint change, rad or m) Newton steps on
        the true chain moved the closed form's answer (0: exact as solved;
        a calibrated arm solved on its nearest ideal arm moves); None when
        the solver does not refine.
    collides : tuple of bool
        When collisions were asked for (``ik(..., collision_free=...)``,
        :func:`manipkit.ik.collision_marks.mark_collisions`): per row, whether
        the configuration is in collision; ``()`` when they were not.
    clearance : ndarray, shape (k,), or None
        With ``collides``: per row, the distance (m) of the closest checked
        pair (negative: penetration depth; inf when no pair is checked).
    parameter : str
        A 7R arm's ranked set (:mod:`manipkit.ik.redundant`): the redundancy
        parameter in words (``"psi (arm angle)"``, ``"panda_joint7 (locked)"``),
        else ``""``; ``labels`` are then the branches.
    parameter_values : ndarray, shape (k,), or None
        Per row, the parameter's value (rad); None outside a ranked set.
    intervals : tuple of (str, float, float)
        Every branch's feasible intervals of the parameter (branch, low, high; rad).
    ranked_by : str
        The criterion the rows are ordered by, best first (``"limits"``,
        ``"manipulability"``, ``"clearance"``), else ``""``.
    scores : ndarray, shape (k,), or None
        Per row, the value of ``ranked_by`` (larger is better).

    method : str
        ``"closed_form"`` (every branch from the geometry or a textbook
        solver), ``"numerical"`` (a search from starts) or ``"algebraic"``
        (every isolated solution of a general 6R chain from an eigenvalue
        problem, :mod:`manipkit.ik.general6r`): :data:`METHODS`.
    arm_family : str
        With a closed form from the chain's geometry: the family of the arm
        (``"three parallel, two intersecting"``, ``"spherical wrist"``, the
        SRS class), else ``""``.
    failure : IKFailure or None
        None with a solution; else why there is none, as data (kind, joints
        or pairs concerned, numbers), from which :attr:`reason` is worded.
    alias_of : ndarray of int, shape (k,), or None
        ``all=True`` with a closed form or the general 6R elimination
        (:func:`manipkit.ik.aliases.with_aliases`): per row, -1 for a
        branch's own row (each joint at its in-limit value nearest 0), else
        the row of the branch it is a 2 pi alias of (the same link
        placements, other joint values inside the limits); None when the
        solver lists no aliases (numerical IK, ``all=False``, ``aliases=False``).

    Properties: ``q`` (the first solution, or None: the same for every
    method), ``q_residuals``, ``success``, ``reason`` (``""`` on success,
    else ``failure.message``), ``residuals``, ``infinite``, ``singular``.

    Examples
    --------
    >>> from manipkit.ik.planar import ik_2r
    >>> result = ik_2r(0.0, 1.5, 1.0, 1.0)
    >>> result.success, result.count, result.labels, result.reason
    (True, 2, ('elbow-down', 'elbow-up'), '')
    >>> result.q.round(6)
    array([0.848062, 1.445468])
    """

    solutions: np.ndarray
    labels: tuple[str, ...]
    count: int | float
    note: str
    residual_position: np.ndarray
    residual_rotation: np.ndarray
    mode: str = ""
    solver: str = ""
    joint_names: tuple[str, ...] = ()
    free_parameter: str = ""
    family: str = ""
    free_joints: tuple[int, ...] = ()
    unmet: tuple[tuple[str, float], ...] = ()
    rejected: int = 0
    outside_by: float = 0.0
    side: str = ""
    iterations: int = 0
    attempts: int = 0
    closest: np.ndarray | None = None
    closest_residuals: np.ndarray | None = None
    family_function: Callable[..., IKResult] | None = field(default=None, repr=False)
    within_limits: np.ndarray | None = None
    refined: np.ndarray | None = None
    collides: tuple[bool, ...] = ()
    clearance: np.ndarray | None = None
    parameter: str = ""
    parameter_values: np.ndarray | None = None
    intervals: tuple[tuple[str, float, float], ...] = ()
    ranked_by: str = ""
    scores: np.ndarray | None = None
    method: str = "closed_form"
    arm_family: str = ""
    failure: IKFailure | None = None
    alias_of: np.ndarray | None = None

    def __init__(self, solutions, labels, count, note, residual_position, residual_rotation, mode="", solver="",
                 joint_names=(), free_parameter="", family="", free_joints=(), unmet=(), rejected=0, outside_by=0.0,
                 side="", iterations=0, attempts=0, closest=None, closest_residuals=None, family_function=None,
                 within_limits=None, refined=None, collides=(), clearance=None, parameter="", parameter_values=None,
                 intervals=(), ranked_by="", scores=None, method="closed_form", arm_family="", failure=None,
                 alias_of=None):
        # The fields in their declared order with the same defaults; written into the instance's __dict__ at once
        # (a frozen dataclass's generated __init__ sets them one by one: 4 us of each numerical solve).
        fields = dict(locals())
        del fields["self"]
        self.__dict__.update(fields)
        self.__post_init__()

    def replaced(self, **changes) -> IKResult:
        """``dataclasses.replace(self, **changes)`` (the same result, tested equal) without its loop over the fields
        (40 us of each IK call that lists aliases); TypeError for a name that is not a field, as it raises."""
        unknown = changes.keys() - _FIELD_NAMES
        if unknown:
            raise TypeError(f"IKResult has no field {sorted(unknown)[0]!r}")
        other = object.__new__(type(self))
        other.__dict__.update(self.__dict__, **changes)
        other.__post_init__()
        return other

    @classmethod
    def of_checked_rows(cls, solutions: np.ndarray, labels: tuple[str, ...], note: str, residual_position: np.ndarray,
                        residual_rotation: np.ndarray, within_limits: np.ndarray, refined: np.ndarray, *, mode: str,
                        solver: str, joint_names: tuple[str, ...], arm_family: str = "", method: str = "closed_form",
                        rejected: int = 0) -> IKResult:
        """The result of ``count = len(labels)`` checked rows, from arrays that are read-only already: the same
        result as the constructor's (tested equal), without its copies (a compiled solver's single call).

        ``solutions`` (k, n) float; ``residual_position``, ``residual_rotation``, ``refined`` (k,) float;
        ``within_limits`` (k,) bool; each a read-only ndarray (ValueError otherwise: use the constructor, which
        copies what is writable), of ``k`` rows (the caller's promise; ``solutions`` is checked).
        """
        ndarray = np.ndarray  # one expression, no loop: this runs in every compiled single call
        if (type(solutions) is not ndarray or type(residual_position) is not ndarray
                or type(residual_rotation) is not ndarray or type(within_limits) is not ndarray
                or type(refined) is not ndarray or solutions.flags.writeable or residual_position.flags.writeable
                or residual_rotation.flags.writeable or within_limits.flags.writeable or refined.flags.writeable):
            raise ValueError("IKResult.of_checked_rows takes read-only arrays; use IKResult(...)")
        k = len(labels)
        if solutions.ndim != 2 or within_limits.dtype != np.bool_ or len(solutions) != k or method not in METHODS:
            raise ValueError(f"IKResult.of_checked_rows: solutions ({k}, n), within_limits of bool and a method of "
                             f"{', '.join(METHODS)} expected, got {solutions.shape}, {within_limits.dtype}, {method!r}")
        self = object.__new__(cls)
        # the other fields keep their defaults: a dataclass holds each field's default as a class attribute
        self.__dict__.update(solutions=solutions, labels=labels, count=k, note=note, residual_position=residual_position,
                             residual_rotation=residual_rotation, mode=mode, solver=solver, joint_names=joint_names,
                             within_limits=within_limits, refined=refined, arm_family=arm_family, method=method,
                             rejected=rejected)
        if not k:
            self.__dict__["failure"] = failure_of(self)
        return self

    def with_rows(self, solutions: np.ndarray, joint_names: tuple[str, ...], free_joints: tuple[int, ...]) -> IKResult:
        """This answer with its rows in another joint order (a chain's rows as whole-robot vectors, by
        ``analytic_ik``): ``solutions`` (k, n) a read-only float array of the same k rows, ``joint_names`` and
        ``free_joints`` (columns) in its order; every other field as it is (shared, not copied: all read-only).

        Examples
        --------
        >>> from manipkit.ik.planar import ik_2r
        >>> chain_rows = ik_2r(0.0, 1.5, 1.0, 1.0)
        >>> rows = np.hstack([chain_rows.solutions, np.zeros((2, 1))])
        >>> rows.setflags(write=False)
        >>> whole = chain_rows.with_rows(rows, ("q1", "q2", "gripper"), ())
        >>> whole.solutions.shape, whole.labels == chain_rows.labels, whole.joint_names
        ((2, 3), True, ('q1', 'q2', 'gripper'))
        """
        if (type(solutions) is not np.ndarray or solutions.flags.writeable or solutions.ndim != 2
                or len(solutions) != len(self.solutions) or solutions.dtype != np.float64):
            raise ValueError(f"IKResult.with_rows takes a read-only float array of {len(self.solutions)} rows, got "
                             f"{type(solutions).__name__} {np.shape(solutions)}")
        other = object.__new__(type(self))
        other.__dict__.update(self.__dict__, solutions=solutions, joint_names=tuple(joint_names),
                              free_joints=tuple(free_joints))
        return other

    def take(self, rows) -> IKResult:
        """This answer with only ``rows`` (indices or a boolean mask) of its solutions, every per-row field
        (labels, residuals, within_limits, refined, collides, clearance, parameter_values, scores) following
        them; ``count`` becomes the number kept (a family keeps ``inf`` while a row is left). ``alias_of``
        follows too, renumbered: an alias whose branch row is not kept becomes -1 (a row of its own).

        Examples
        --------
        >>> from manipkit.ik.planar import ik_2r
        >>> both = ik_2r(0.0, 1.5, 1.0, 1.0)
        >>> up = both.take([1])
        >>> up.labels, up.count, bool((up.q == both.solutions[1]).all())
        (('elbow-up',), 1, True)
        """
        index = np.arange(len(self.solutions))[np.asarray(rows) if np.size(rows) else np.zeros(0, dtype=np.intp)]
        per_row = dict(
            solutions=self.solutions[index], labels=tuple(self.labels[i] for i in index),
            residual_position=self.residual_position[index], residual_rotation=self.residual_rotation[index],
            within_limits=None if self.within_limits is None else self.within_limits[index],
            refined=None if self.refined is None else self.refined[index],
            collides=tuple(self.collides[i] for i in index) if self.collides else (),
            clearance=None if self.clearance is None else self.clearance[index],
            parameter_values=None if self.parameter_values is None else self.parameter_values[index],
            scores=None if self.scores is None else self.scores[index],
            alias_of=None if self.alias_of is None else _renumbered(self.alias_of, index),
        )
        count = self.count if math.isinf(self.count) and len(index) else len(index)
        return self.replaced(count=count, **per_row)

    def extended(self, other: IKResult, *, labels: tuple[str, ...], note: str) -> IKResult:
        """This answer's rows, then ``other``'s (the same joint order and mode), with ``labels`` for ``other``'s rows
        and ``note`` as the note; every per-row field follows its rows (``alias_of`` -1 for ``other``'s), ``count``
        counts every row, every other field is this answer's.

        Examples
        --------
        >>> from manipkit.ik.planar import ik_2r
        >>> both = ik_2r(0.0, 1.5, 1.0, 1.0)
        >>> joined = both.take([0]).extended(both.take([1]), labels=("found again",), note="two")
        >>> joined.labels, joined.count, bool((joined.solutions == both.solutions).all())
        (('elbow-down', 'found again'), 2, True)
        """
        if other.solutions.shape[1:] != self.solutions.shape[1:] or len(labels) != len(other.solutions):
            raise ValueError(f"IKResult.extended: rows of shape {other.solutions.shape} with {len(labels)} labels "
                             f"cannot follow rows of shape {self.solutions.shape}")

        def joined(name, default):
            mine, theirs = getattr(self, name), getattr(other, name)
            if mine is None and theirs is None:
                return None
            mine = np.full(len(self.solutions), default) if mine is None else mine
            theirs = np.full(len(other.solutions), default) if theirs is None else theirs
            return np.concatenate([mine, theirs])

        alias_of = None if self.alias_of is None else np.concatenate(
            [self.alias_of, np.full(len(other.solutions), -1, dtype=np.intp)])
        collides = (tuple(self.collides) or (False,) * len(self.solutions)) + \
            (tuple(other.collides) or (False,) * len(other.solutions)) if (self.collides or other.collides) else ()
        return self.replaced(solutions=np.concatenate([self.solutions, other.solutions]),
                             labels=tuple(self.labels) + tuple(labels),
                             count=len(self.solutions) + len(other.solutions), note=note,
                             residual_position=np.concatenate([self.residual_position, other.residual_position]),
                             residual_rotation=np.concatenate([self.residual_rotation, other.residual_rotation]),
                             within_limits=joined("within_limits", True), refined=joined("refined", 0.0),
                             collides=collides, clearance=joined("clearance", np.nan),
                             parameter_values=joined("parameter_values", np.nan), scores=joined("scores", np.nan),
                             alias_of=alias_of)

    def __post_init__(self):
        for name in ("solutions", "residual_position", "residual_rotation", "closest", "closest_residuals", "refined",
                     "clearance", "parameter_values", "scores"):
            value = getattr(self, name)
            if value is not None and (not isinstance(value, np.ndarray) or value.flags.writeable):
                object.__setattr__(self, name, read_only(value))  # arrays of a result are read-only copies
        if self.within_limits is not None:
            within = np.array(self.within_limits, dtype=bool).reshape(-1)
            within.setflags(write=False)
            object.__setattr__(self, "within_limits", within)
        if self.alias_of is not None and (not isinstance(self.alias_of, np.ndarray) or self.alias_of.dtype != np.intp
                                           or self.alias_of.flags.writeable):
            alias_of = np.array(self.alias_of, dtype=np.intp).reshape(-1)
            alias_of.setflags(write=False)
            object.__setattr__(self, "alias_of", alias_of)
        if self.solutions.ndim != 2:
            raise ValueError(f"IKResult.solutions must have shape (k, n), got {self.solutions.shape}")
        if self.method not in METHODS:
            raise ValueError(f"IKResult.method must be one of {', '.join(METHODS)}, got {self.method!r}")
        if self.solutions.shape[0]:
            object.__setattr__(self, "failure", None)
        elif self.failure is None or self.failure.kind in DERIVED_KINDS:  # what the fields show, kept in step with them
            object.__setattr__(self, "failure", failure_of(self))
        elif self.failure.message != self.note:
            object.__setattr__(self, "failure", replace(self.failure, message=self.note))

    # ------------------------------------------------------------------

    @property
    def success(self) -> bool:
        """At least one solution (every row has passed the forward-kinematics check)."""
        return self.solutions.shape[0] > 0

    @property
    def reason(self) -> str:
        """Why there is no solution (``failure.message``), or ``""`` on success; never None."""
        return "" if self.failure is None else self.failure.message

    @property
    def q(self) -> np.ndarray | None:
        """The first solution (``solutions[0]``), or None when there is none, whatever the method (a failed
        numerical search keeps the configuration it found closest in :attr:`closest`)."""
        return self.solutions[0] if self.solutions.shape[0] else None

    @property
    def q_residuals(self) -> np.ndarray | None:
        """(2,): position (m) and rotation (rad) residual of :attr:`q` (None when ``q`` is None)."""
        return self.residuals[0] if self.solutions.shape[0] else None

    @property
    def residuals(self) -> np.ndarray:
        """(k, 2): position (m) and rotation (rad) residual of each row."""
        return read_only(np.column_stack([self.residual_position, self.residual_rotation]), (2,))

    @property
    def infinite(self) -> bool:
        """True for one-parameter families of solutions."""
        return math.isinf(self.count)

    @property
    def singular(self) -> bool:
        """True when a row stands for a family (a joint is free)."""
        return bool(self.free_joints)

    @property
    def free_joint(self) -> int | None:
        """The first free joint's column, or None."""
        return self.free_joints[0] if self.free_joints else None

    def members(self, values) -> IKResult:
        """The members of the family at ``values`` of its free parameter (``free_parameter``).

        Every returned row is checked by forward kinematics like the
        solver's own rows. Raises :class:`manipkit.errors.ClosedFormIKError`
        when this result is not a family with a parameter.
        """
        if self.family_function is None:
            raise ClosedFormIKError(
                "this result is not a family of solutions with a free parameter "
                f"(count = {self.count}); members() applies to position-only answers of planar 3R and SCARA arms"
            )
        return self.family_function(values)

    # ------------------------------------------------------------------

    def __repr__(self) -> str:
        parts = [f"solver={self.solver!r}", f"mode={self.mode!r}", f"count={self.count}", f"success={self.success}"]
        parts.insert(0, f"method={self.method!r}")
        q, residuals, name = (self.q, self.q_residuals, "q") if self.success else (self.closest, self.closest_residuals,
                                                                                    "closest")
        if q is not None:
            parts.append(f"{name}=[" + ", ".join(short_text(float(v)) for v in q) + "]")
        if residuals is not None:
            parts.append(f"residual=({short_text(float(residuals[0]), 3)} m, {short_text(float(residuals[1]), 3)} rad)")
        if self.attempts:
            parts.append(f"iterations={self.iterations}, attempts={self.attempts}")
        if not self.success:
            parts.append(f"reason={self.reason!r}")
        return f"IKResult({', '.join(parts)})"

    def _repr_html_(self) -> str:
        """An HTML table for Jupyter: one row per solution (label, joint values, residuals in m and rad,
        success), or the closest configuration a numerical search found; the caption says what answered and
        whether there is any solution; the note follows the table. Text is escaped."""
        count = "infinitely many" if self.infinite else str(self.count)
        if self.attempts:
            head = (f"numerical IK{' (' + self.solver + ')' if self.solver else ''}: {count} solution(s) from "
                    f"{self.attempts} start(s), {self.iterations} iterations")
        else:
            head = f"closed form{' (' + self.solver + ')' if self.solver else ''}: {count} solution(s)"
        if self.mode:
            head += f", {self.mode}"
        if self.free_parameter:
            head += f", free: {self.free_parameter}"
        n = self.solutions.shape[1]
        names = self.joint_names if len(self.joint_names) == n else tuple(f"q{i + 1}" for i in range(n))
        cells = ["#", "label", *names, "position (m)", "rotation (rad)", "success"]
        lines = [f"<table><caption>{html.escape(head)}; success: {self.success}</caption>",
                 "<tr>" + "".join(f"<th>{html.escape(c)}</th>" for c in cells) + "</tr>"]
        rows = [(str(i), label, q, r, "True") for i, (label, q, r) in
                enumerate(zip(self.labels, self.solutions, self.residuals), start=1)]
        if not rows and self.closest is not None:
            rows = [("-", "closest found (fails)", self.closest, self.closest_residuals, "False")]
        for index, label, q, (position, rotation), success in rows:
            values = [index, label, *(short_text(float(v)) for v in q), short_text(float(position), 3),
                      short_text(float(rotation), 3), success]
            lines.append("<tr>" + "".join(f"<td>{html.escape(v)}</td>" for v in values) + "</tr>")
        lines.append("</table>")
        if self.note:
            lines.append(f"<p>{html.escape(self.note)}</p>")
        return "\n".join(lines)


#: The names :meth:`IKResult.replaced` sets.
_FIELD_NAMES = frozenset(f.name for f in fields(IKResult))


def _renumbered(alias_of: np.ndarray, index: np.ndarray) -> np.ndarray:
    """``alias_of`` of the rows ``index`` kept, as rows of the kept ones (-1 where the branch row is not kept)."""
    new = np.full(len(alias_of), -1, dtype=np.intp)
    new[index] = np.arange(len(index))
    return np.where(alias_of[index] >= 0, new[np.maximum(alias_of[index], 0)], -1)


class IKBatch:
    """IK answers for many targets at once: the fields of :class:`IKResult` with leading target axes ``(...)``.

    From :func:`manipkit.ik.numerical_many.ik_many` (targets ``(N,)``, one
    slot: ``k = 1``) and the planar batch solvers
    (:func:`manipkit.ik.planar.ik_2r_batch`, ``ik_3r_batch``:
    targets of any shape ``(...)``, two slots). Immutable; arrays read-only.

    Attributes
    ----------
    solutions : ndarray, shape (..., k, n)
        Per target, ``k`` slots of joint vectors, NaN where absent. Planar:
        slot 0 elbow-down (or the one boundary solution, straight or folded,
        or for infinitely many the representative with q1 = 0), slot 1
        elbow-up. ``ik_many``: slot 0 holds the solution where there is one.
    labels : tuple of str, shape (k,)
        The slots' names (``("elbow-down", "elbow-up")``; ``("",)`` for numerical IK;
        the closed form's 8 slots: the solver's choices, ``"shoulder a, elbow b, wrist a"``). The branch a
        slot holds at one target, named as the single call names it: :meth:`branch_labels`.
    count : ndarray of float, shape (...)
        0.0, 1.0, 2.0 or ``inf`` per target (float so ``inf`` fits).
    success : ndarray of bool, shape (...)
        At least one slot whose forward kinematics reach the target within
        the tolerance.
    residual_position, residual_rotation : ndarray, shape (..., k)
        Per slot, m and rad, by forward kinematics of the slot through the
        real chain (NaN where the slot is empty). The closed-form batches
        measure them, and ``success``, on first use: solving millions of
        targets does not pay for it unless asked.
    residuals : ndarray, shape (..., k, 2)
    q : ndarray, shape (..., n)
        Per target, the first solution; ``ik_many``: or, where there is none,
        the configuration found closest to the target (NaN for a closed form).
    q_residuals : ndarray, shape (..., 2)
        The residuals of ``q``.
    mode, solver, joint_names : str, str, tuple of str
        As in :class:`IKResult`.
    outside_by : ndarray, shape (...), or None
        Planar: how far (m) the target (2R) or wrist point (3R) lies outside
        the reachable annulus, 0.0 where reachable; None for ``ik_many``.
    iterations, attempts : ndarray of int, shape (...), or None
        ``ik_many``: Levenberg-Marquardt iterations and starts per target;
        None for a closed form.
    method : str
        ``"closed_form"`` or ``"numerical"``, as in :class:`IKResult`.
    failure_kinds : ndarray of str, shape (...)
        Per target, ``""`` where it succeeded, else the kind of failure
        (:data:`FAILURE_KINDS`); :meth:`failure` and :meth:`reason` give one
        target's record and sentence.
    """

    __slots__ = ("solutions", "labels", "count", "mode", "solver", "joint_names", "q", "outside_by", "iterations",
                 "attempts", "method", "_given", "_measure", "_limit", "_measured", "_kinds", "_name")

    def __init__(self, solutions, count, *, labels: tuple[str, ...], mode: str, solver: str = "",
                 joint_names: tuple[str, ...] = (), q=None, success=None, residual_position=None,
                 residual_rotation=None, q_residuals=None, measure: Callable | None = None, limit=(0.0, 0.0),
                 outside_by=None, iterations=None, attempts=None, method: str = "closed_form", failure_kinds=None,
                 name: Callable | None = None):
        if method not in METHODS:
            raise ValueError(f"IKBatch.method must be one of {', '.join(METHODS)}, got {method!r}")
        set_ = object.__setattr__
        set_(self, "method", method)
        set_(self, "_kinds", None if failure_kinds is None else _frozen(np.asarray(failure_kinds, dtype=str)))
        solutions = _frozen(solutions)
        set_(self, "solutions", solutions)
        set_(self, "labels", tuple(labels))
        set_(self, "count", _frozen(count))
        set_(self, "mode", mode)
        set_(self, "solver", solver)
        set_(self, "joint_names", tuple(joint_names))
        set_(self, "q", _frozen(solutions[..., 0, :] if q is None else q))
        set_(self, "outside_by", None if outside_by is None else _frozen(outside_by))
        set_(self, "iterations", None if iterations is None else _frozen(iterations))
        set_(self, "attempts", None if attempts is None else _frozen(attempts))
        given = None
        if measure is None:  # measured by the solver already
            given = (_frozen(success), _frozen(residual_position), _frozen(residual_rotation), _frozen(q_residuals))
        set_(self, "_given", given)
        set_(self, "_measure", measure)
        set_(self, "_limit", limit)
        set_(self, "_measured", None)
        set_(self, "_name", name)

    def __setattr__(self, name, value):
        raise AttributeError(f"an IKBatch is immutable: cannot set '{name}'")

    def __delattr__(self, name):
        raise AttributeError(f"an IKBatch is immutable: cannot delete '{name}'")

    def __len__(self) -> int:
        """The number of targets along the first axis (a batch of one unshaped target has no length, as in numpy)."""
        if np.ndim(self.count) == 0:
            raise TypeError("len() of an IKBatch of one unshaped target")
        return int(np.shape(self.count)[0])

    def __repr__(self) -> str:
        shape = np.shape(self.count)
        return (f"IKBatch(solver={self.solver!r}, mode={self.mode!r}, targets {shape}, "
                f"{self.solutions.shape[-2]} slot(s) of {self.solutions.shape[-1]} joints)")

    def _fields(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(success, residual_position, residual_rotation, q_residuals): given, or measured once by ``measure``."""
        if self._given is not None:
            return self._given
        measured = self._measured
        if measured is None:
            position, rotation = self._measure(self.solutions)
            within = (position <= self._limit[0]) & (rotation <= self._limit[1])  # NaN (no slot): False
            q_residuals = np.stack([position[..., 0], rotation[..., 0]], axis=-1)
            measured = (_frozen(within.any(axis=-1)), _frozen(position), _frozen(rotation), _frozen(q_residuals))
            object.__setattr__(self, "_measured", measured)  # a cache of derived data; the answers are unchanged
        return measured

    @property
    def success(self) -> np.ndarray:
        """(...) bool: a slot reaches the target within the tolerance (forward kinematics)."""
        return self._fields()[0]

    @property
    def residual_position(self) -> np.ndarray:
        """(..., k) m per slot (NaN where empty), by forward kinematics."""
        return self._fields()[1]

    @property
    def residual_rotation(self) -> np.ndarray:
        """(..., k) rad per slot (NaN where empty), by forward kinematics; 0 in a position mode."""
        return self._fields()[2]

    @property
    def residuals(self) -> np.ndarray:
        """(..., k, 2): position (m) and rotation (rad) residual per slot."""
        return _frozen(np.stack([self.residual_position, self.residual_rotation], axis=-1))

    @property
    def q_residuals(self) -> np.ndarray:
        """(..., 2): position (m) and rotation (rad) residual of ``q``."""
        return self._fields()[3]

    @property
    def failure_kinds(self) -> np.ndarray:
        """(...) str: ``""`` where a target succeeded, else its failure kind (:data:`FAILURE_KINDS`).

        Given by the solver where it knows (numerical IK: beyond the reach bound or not converged); else from the
        slots: a target with no branch at all is ``unreachable`` (or ``outside_by`` > 0), one whose branches all
        failed the forward-kinematics check is ``tolerance``.
        """
        success = self.success
        if self._kinds is not None:
            return _frozen(np.where(success, "", self._kinds))
        some_slot = np.isfinite(self.solutions).all(axis=-1).any(axis=-1)
        outside = np.zeros(success.shape, dtype=bool) if self.outside_by is None else self.outside_by > 0.0
        kinds = np.where(success, "", np.where(outside | ~some_slot, "unreachable", "tolerance"))
        return _frozen(kinds.astype(str))

    def failure(self, index) -> IKFailure | None:
        """Target ``index``'s failure record (None where it succeeded), with its numbers (m, rad)."""
        kind = str(self.failure_kinds[index])
        if not kind:
            return None
        values = []
        if self.outside_by is not None and float(self.outside_by[index]) > 0.0:
            values.append(("outside_by", float(self.outside_by[index])))
        position, rotation = (float(v) for v in self.q_residuals[index])
        if math.isfinite(position):
            values += [("position", position), ("rotation", rotation)]
        if kind == "unreachable":
            message = "no branch reaches the target" + (f": outside by {short_text(values[0][1], 4)} m"
                                                        if values and values[0][0] == "outside_by" else "")
            if self.method == "numerical":
                message = "target out of reach of the chain"
        elif math.isfinite(position):
            message = (f"best residual {short_text(position, 3)} m, {short_text(rotation, 3)} rad, above the "
                       f"tolerance {short_text(self._limit[0], 3)} m, {short_text(self._limit[1], 3)} rad")
        else:
            message = "no slot reaches the target within the tolerance"
        return IKFailure(kind, message, values=tuple(values))

    def branch_labels(self, index: int) -> tuple[str, ...]:
        """Target ``index``'s (flat, over the leading axes) slots named as the single call names the same rows: per
        slot, its branch name (:func:`manipkit.ik.branch_names.branch_names`: ``manipkit.ik(..., all=True)`` of that
        target labels its rows so), ``""`` where the slot is empty; :attr:`labels` for a batch without such names
        (numerical IK, the planar solvers). Computed per call, from the rows: a closed-form batch does not name the
        branches of every target unless asked."""
        if self._name is None:
            return self.labels
        return self._name(int(index))

    def reason(self, index) -> str:
        """Why target ``index`` has no solution, in one sentence with its numbers; ``""`` where it succeeded."""
        failure = self.failure(index)
        return "" if failure is None else failure.message


def _frozen(array) -> np.ndarray:
    """``array`` as a read-only numpy array (a view when it is one already)."""
    array = np.asarray(array)
    if array.flags.writeable:
        array = array.view()
        array.setflags(write=False)
    return array
