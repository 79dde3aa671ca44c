"""Every IK solution of a 7R arm as a ranked, diverse set across its self-motion: :func:`ranked_set`.

A 7R arm reaches a generic pose along a one-parameter self-motion. This
module names that parameter (:func:`redundancy`), finds per closed-form
branch the intervals of it whose solutions lie inside the joint limits,
and returns ``count`` solutions spread over those intervals, ranked by a
stated criterion, as one :class:`manipkit.ik.result.IKResult`
(``manipkit.ik(arm, T, all=True)`` on a 7R chain without ``lock``/``arm_angle``
hands it back).

The parameter (the rule of :func:`redundancy`):

- a 7R SRS arm (axes 1-3 and 5-7 meet: the iiwa14): the arm angle ``psi``
  (rad, on ``[-pi, pi]``), solved by the SRS closed form;
- otherwise one joint held at a value, the others solved as a 6R arm by
  the one dispatcher (``method="auto"``): the first of the last joint, the
  first joint, then the others from the tip whose locked 6R arm the
  dispatcher solves in closed form (Panda, FR3, xArm7: the last joint,
  within its limits);
- a general 7R arm (no joint leaves a closed form: the Sawyer, a Kinova
  Gen3, a Flexiv Rizon): the last joint, else the first, whose locked 6R
  arm the general 6R elimination solves (:func:`manipkit.ik.general6r.general_ik`
  with ``lock=``; its ways eliminate regularly). An end joint because locking
  it moves no axis of the other six (it folds into the tip pose or the
  target), so the 6R arm is the same at every value: the dispatcher's choice
  of solver holds for all of them, and a round's values are solved in one
  batch of the compiled elimination (``ik_many`` on the 6R sub-chain the
  locked joint leaves, :func:`manipkit.ik.general6r.general_ik_many`: each
  value's rows those of ``ik(..., lock=, method="algebraic")``, which answers
  per value where the links do not split there). A chain where neither qualifies gets
  no ranked set (numerical restarts answer, as before).

The inner solve is the dispatcher's: :func:`manipkit.ik.dispatch.ik_many`
(batched, one call per sweep or bisection round) for the SRS arm angle and
for a locked end joint, a general 7R's too (solved as the 6R sub-chain it leaves, the target
moved by the locked joint's transform, inverted as a rigid transform),
:func:`manipkit.ik.dispatch.ik` with ``lock=`` per value for a locked joint
in the middle. Where the dispatcher's batch answers each value by a compiled
closed form (the SRS arm angle; an end joint locked over "spherical wrist,
two intersecting": iiwa14, Panda, FR3; asked once per chain), the sweep, the
narrowing and the chosen rows run instead in one compiled call per pose
(:mod:`manipkit.ik.redundant_kernel`, the same closed forms, checks and rule;
``ranked_set(..., compiled=False)`` keeps the rounds through the dispatcher,
the reference).

Branches are the closed form's branches (its slot labels, or its row labels
per value), followed across the sweep by that label. The elimination names
no branches: its rows are labelled ``"root 1"``, ``"root 2"``, ... by
nearest-neighbour continuation (each value's rows matched to the tracks'
rows at the nearest solved values, interpolated between two, largest joint
difference modulo 2 pi, among the tracks with a row at the nearest value
solved on either side; rows left over start new tracks). These
labels are continuation tracks, not geometric branches: a track ends where
two roots merge (a fold of the self-motion), and two tracks crossing near one
value may swap. Feasible intervals: the
parameter is swept at steps of at most ``step`` (rad; both ends included),
a sample is feasible for a branch when the branch exists there, passes the
forward-kinematics check and lies inside every joint limit; each change
between two samples is bracketed and narrowed (false position on the
branch's limit margin, Illinois variant, else bisection) to :data:`PARAMETER_TOL`
or until a joint at the feasible end is within :data:`MARGIN_TOL` of its
limit (endpoints are the feasible side of the last bracket). A feasible stretch or
a gap shorter than a step between two samples can be missed; an interval of
``psi`` through +-pi is listed as two (one at each end); a wide joint's other
2 pi aliases are not branches of their own. Rows that miss the target by a
little (a calibrated arm's arm angle solved on its nearest ideal arm) are
polished by Newton steps on the true chain; a snapped 6R arm's (the xArm7's
with its last joint locked) come refined from the dispatcher's batch.

The set: ``count`` values spread over the intervals of every branch (each
interval gets a share proportional to its length, at least one while the
count allows, longest first, lengths taken to :data:`PARAMETER_TOL` and
equal ones in interval order; inside it, one at the middle or ``k >= 2``
evenly from 1 % inside one end to 1 % inside the other), each solved and
checked by forward kinematics of the whole chain, then ordered by ``rank``
(:data:`RANKS`, best first): ``"limits"`` the smallest distance of a joint
to its nearest limit as a fraction of its range (0 at a limit, 0.5 at the
middle); ``"manipulability"`` Yoshikawa's ``sqrt(det(J J^T))`` of the
chain's 6 x 7 base-frame Jacobian; ``"clearance"`` the distance (m) of the
closest checked pair of a collision checker (negative: penetration).
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from manipkit.bounds import count as bounded_count
from manipkit.bounds import tolerances
from manipkit.errors import IKOptionError
from manipkit.ik.families import FAMILY_TOL, SRS, chain_family
from manipkit.ik.general6r import ALGEBRAIC, GENERAL_6R, general_solves, locked_geometry
from manipkit.ik.result import SPATIAL_POSE, IKFailure, IKResult
from manipkit.spatial.transforms import invert_transform

if TYPE_CHECKING:
    from manipkit.kinematics.chain import Chain

__all__ = ["DEFAULT_COUNT", "MAX_SOLUTIONS", "PARAMETER_TOL", "RANKS", "SWEEP_STEP", "Redundancy", "check_options",
           "ranked_set", "redundancy", "scores"]

#: Solutions in a ranked set unless asked otherwise.
DEFAULT_COUNT = 16
#: The most a ranked set holds (each is solved and ranked).
MAX_SOLUTIONS = 10_000
#: How the set is ordered, best first (see the module docstring).
RANKS = ("limits", "manipulability", "clearance")
#: A limit crossing is narrowed until its bracket is narrower than this (rad) ...
PARAMETER_TOL = 1e-7
#: ... or its feasible end has a joint within this (rad or m) of its limit.
MARGIN_TOL = 1e-10
#: A joint this far (rad or m) past its limit still counts as inside (rounding).
LIMIT_SLACK = 1e-12
#: The widest step (rad) of the sweep over the parameter.
SWEEP_STEP = 2.0 * math.pi / 128
_INSET = 0.01  # the spread's ends, as a fraction of an interval inside it
#: Rows of the batched closed forms missing the target by less than this (m or rad) are polished by Newton steps.
POLISH_BELOW = 1e-3
POLISH_TO = 1e-12  # (m, rad) what the polish aims at (the closed forms' own rows are near 1e-15)
POLISH_STEPS = 8
#: The compiled sweep's calls per pose at most (each after the numpy reference answered what it handed back: the
#: sweep's at once, then a narrowing round's; at most 20 rounds narrow a step of SWEEP_STEP to PARAMETER_TOL);
#: beyond, the pose is answered through the dispatcher round by round.
HAND_BACKS = 32


@dataclass(frozen=True)
class Redundancy:
    """The redundancy parameter of a 7R chain.

    Attributes
    ----------
    kind : str
        ``"arm_angle"`` (SRS arm angle ``psi``) or ``"lock"`` (a joint held).
    name : str
        ``"psi"`` or the locked joint's name.
    lower, upper : float
        The parameter's range (rad): ``[-pi, pi]`` for ``psi``, the joint's limits for a joint.
    column : int
        The locked joint's place in the chain vector (-1 for ``psi``).
    family : str
        The closed-form family that solves each value (the SRS class, or that of the locked 6R arm).
    """

    kind: str
    name: str
    lower: float
    upper: float
    column: int
    family: str

    @property
    def label(self) -> str:
        """The parameter in words: ``"psi (arm angle)"`` or ``"panda_joint7 (locked)"``."""
        return "psi (arm angle)" if self.kind == "arm_angle" else f"{self.name} (locked)"


_REDUNDANCY: dict = {}


def redundancy(robot, base: str, tip: str, *, family_tol=FAMILY_TOL) -> Redundancy | None:
    """The redundancy parameter of the chain ``base -> tip`` by the rule of the module docstring, or None when it
    is not a 7R chain of revolute joints or no joint leaves a 6R arm the dispatcher solves in closed form."""
    from manipkit.ik.textbook import closed_form_solves

    chain = robot.chain(base, tip)
    key = (id(chain), repr(family_tol))
    cached = _REDUNDANCY.get(key)
    if cached is not None and cached[0] is chain:
        return cached[1]
    found = None
    if chain.n == 7 and all(j.type == "revolute" for j in chain.joints):
        family = chain_family(chain, tol=family_tol)
        if family.kind == SRS:
            found = Redundancy("arm_angle", "psi", -math.pi, math.pi, -1, SRS)
        else:
            for column in (6, 0, 5, 4, 3, 2, 1):
                joint = chain.joints[column]
                value = float(np.clip(0.0, joint.lower, joint.upper))
                kind = closed_form_solves(robot, base, tip, family_tol=family_tol, lock={joint.name: value})
                if kind:
                    found = Redundancy("lock", joint.name, float(joint.lower), float(joint.upper), column, kind)
                    break
            for column in (6, 0) if found is None else ():
                joint = chain.joints[column]
                lock = {joint.name: float(np.clip(0.0, joint.lower, joint.upper))}
                if general_solves(chain, family_tol=family_tol, lock=lock) and \
                        _eliminates(chain, joint.name, family_tol):
                    found = Redundancy("lock", joint.name, float(joint.lower), float(joint.upper), column, GENERAL_6R)
                    break
    if len(_REDUNDANCY) >= 64:
        _REDUNDANCY.clear()
    _REDUNDANCY[key] = (chain, found)
    return found


def _eliminates(chain: Chain, name: str, family_tol) -> bool:
    """Whether the 7R ``chain`` with ``name`` locked has a regular way of elimination (ranked once per axes)."""
    from manipkit.closed_form.general6r import ranked_ways

    geometry, _ = locked_geometry(chain, name, 0.0, family_tol=family_tol)
    return bool(ranked_ways(geometry.direction, geometry.point))


class _Tracks:
    """Nearest-neighbour continuation of unlabelled rows (the general 6R elimination's) across parameter values:
    :meth:`assign` gives each row of one value the index of its track (new tracks numbered on).

    The tracks alive at a value are those with a row at the nearest value solved below it or above it; each of
    the value's rows joins the alive track whose expected row (interpolated between its rows either side, else its
    nearest) is closest (largest joint difference modulo 2 pi; pairs taken closest first, one row per track), and
    rows left over start new tracks (roots born in pairs at a fold); alive tracks left over end there.
    """

    def __init__(self):
        self.solved: list[float] = []  # every value solved, ascending
        self.values: list[list[float]] = []  # per track: the values it has a row at, ascending
        self.rows: list[list[np.ndarray]] = []  # per track: its row at each of them
        self.members: list[set[float]] = []  # per track: the values it has a row at, as a set

    def _predicted(self, t: int, value: float) -> np.ndarray:
        """Track ``t``'s row expected at ``value``: interpolated between its samples either side, else its nearest."""
        values, rows = self.values[t], self.rows[t]
        i = bisect.bisect_left(values, value)
        if i < len(values) and values[i] == value:
            return rows[i]
        if 0 < i < len(values):
            v0, v1 = values[i - 1], values[i]
            return rows[i - 1] + (value - v0) / (v1 - v0) * _wrapped(rows[i] - rows[i - 1])
        return rows[min(i, len(values) - 1)]

    def _alive(self, value: float) -> list[int]:
        """The tracks with a row at the nearest solved value below or above ``value`` (or at ``value``)."""
        i = bisect.bisect_left(self.solved, value)
        near = {self.solved[k] for k in (i - 1, i) if 0 <= k < len(self.solved)}
        if i < len(self.solved) and self.solved[i] == value:
            near = {value}
        return [t for t, members in enumerate(self.members) if any(v in members for v in near)]

    def assign(self, value: float, rows: np.ndarray) -> list[int]:
        value = float(value)
        out = [-1] * len(rows)
        alive = self._alive(value) if len(rows) else []
        if alive:
            guesses = np.array([self._predicted(t, value) for t in alive])  # (alive, n)
            gap = np.abs(_wrapped(rows[:, None, :] - guesses[None])).max(axis=-1)  # (rows, alive)
            used = set()
            for flat in np.argsort(gap, axis=None, kind="stable"):
                r, a = divmod(int(flat), gap.shape[1])
                if out[r] < 0 and a not in used:
                    out[r] = alive[a]
                    used.add(a)
        for r in range(len(rows)):
            if out[r] < 0:
                self.values.append([])
                self.rows.append([])
                self.members.append(set())
                out[r] = len(self.values) - 1
            i = bisect.bisect_left(self.values[out[r]], value)
            if i < len(self.values[out[r]]) and self.values[out[r]][i] == value:
                continue  # solved at this value before: the track keeps its row
            self.values[out[r]].insert(i, value)
            self.members[out[r]].add(value)
            self.rows[out[r]].insert(i, np.array(rows[r], dtype=float))
        i = bisect.bisect_left(self.solved, value)
        if not (i < len(self.solved) and self.solved[i] == value):
            self.solved.insert(i, value)
        return out


def _wrapped(d: np.ndarray) -> np.ndarray:
    return np.pi - np.mod(np.pi - d, 2.0 * np.pi)


class _Solver:
    """Every branch of the chain at many values of the parameter, through the one dispatcher.

    ``solve(values)`` -> ``(Q, ok, margin)``: ``Q`` (N, B, 7) chain vectors (NaN where a branch does not exist),
    ``ok`` (N, B) the branch exists, passes the FK check and lies inside the joint limits; ``labels`` the B
    branches' names (the per-value path adds branches as new labels appear).
    """

    def __init__(self, robot, T: np.ndarray, base: str, tip: str, parameter: Redundancy, tol, family_tol, solvers):
        self.robot, self.T, self.base, self.tip, self.parameter = robot, T, base, tip, parameter
        self.ik, self.ik_many = solvers
        self.tol, self.family_tol = tol, family_tol
        self.chain = robot.chain(base, tip)
        self.labels: list[str] = []
        self.reached_any = False  # some branch reached the target at some value (inside the limits or not)
        self.sub = None
        self.tracks = _Tracks() if parameter.family == GENERAL_6R else None
        if parameter.kind == "lock" and parameter.column in (0, 6):
            joint = self.chain.joints[parameter.column]
            if parameter.column == 6:  # T = T_base_parent(q1..q6) T_parent_tip(q7)
                self.sub = (base, joint.parent, robot.chain(joint.parent, tip))
            else:  # T = T_base_child(q1) T_child_tip(q2..q7)
                self.sub = (joint.child, tip, robot.chain(base, joint.child))
            if self.sub[2].joint_names != (joint.name,) or \
                    robot.chain(self.sub[0], self.sub[1]).n != 6:
                self.sub = None  # a chain whose links do not split there: solve with lock= per value

    def solve(self, values: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        ik_many = self.ik_many
        values = np.asarray(values, dtype=float)
        n = len(values)
        if self.parameter.kind == "arm_angle":
            batch = ik_many(self.robot, np.broadcast_to(self.T, (n, 4, 4)), base=self.base, tip=self.tip,
                            tol=self.tol, family_tol=self.family_tol, arm_angle=values)
            Q = np.array(batch.solutions, dtype=float)
        elif self.sub is not None:
            sub_base, sub_tip, moving = self.sub
            A = moving.fk(values[:, None])
            inverse = invert_transform(A, check=False)  # A is an FK pose: rigid
            targets = self.T @ inverse if self.parameter.column == 6 else inverse @ self.T
            batch = ik_many(self.robot, targets, base=sub_base, tip=sub_tip, tol=self.tol,
                            family_tol=self.family_tol)
            Q6 = np.asarray(batch.solutions, dtype=float)
            Q = np.insert(Q6, self.parameter.column, values[:, None], axis=2)
            if self.tracks is not None and batch.method == ALGEBRAIC:  # the elimination batched over the values
                return self._tracked(values, [rows[~np.isnan(rows).any(axis=-1)] for rows in Q])
            if batch.method != "closed_form" or self.tracks is not None:  # a solver ik answers, ik_many does not batch
                self.sub = None
                return self._per_value(values)
        else:
            return self._per_value(values)
        if not self.labels:
            self.labels = list(batch.labels)
        return self._checked(Q, np.array(batch.residual_position), np.array(batch.residual_rotation))

    def _per_value(self, values: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        answers, method = [], "auto" if self.tracks is None else ALGEBRAIC  # an end joint: the same 6R arm
        for value in values:
            result = self.ik(self.robot, self.T, base=self.base, tip=self.tip, all=True, aliases=False, tol=self.tol, method=method,
                        family_tol=self.family_tol, lock={self.parameter.name: float(value)})
            answers.append((np.asarray(result.solutions, dtype=float)[:, self.chain.columns], result.labels))
        if self.tracks is not None:
            return self._tracked(values, [rows for rows, _ in answers])
        return self._labelled(values, answers)

    def _tracked(self, values: np.ndarray, rows: list) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`_labelled` of each value's chain rows labelled by their tracks (:class:`_Tracks`), values in order."""
        return self._labelled(values, [(Q, [f"root {t + 1}" for t in self.tracks.assign(float(value), Q)])
                                       for value, Q in zip(values, rows)])

    def _labelled(self, values: np.ndarray, answers: list) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(Q, ok, margin)`` of :meth:`solve` from each value's (chain rows, labels): a label's first row."""
        rows = []
        for chain_rows, labels in answers:
            found: dict = {}
            for label, q in zip(labels, chain_rows):
                if label not in self.labels:
                    self.labels.append(label)
                found.setdefault(label, q)
            rows.append(found)
        Q = np.full((len(values), len(self.labels), 7), np.nan)
        for i, found in enumerate(rows):
            for label, q in found.items():
                Q[i, self.labels.index(label)] = q
        position, rotation, _ = self._residuals(Q)
        return self._checked(Q, position, rotation)

    def _residuals(self, Q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(position, rotation, reached poses) of rows ``Q`` (..., 7) by the chain's FK (NaN rows: measured at 0)."""
        from manipkit.spatial.transforms import pose_residuals

        filled = np.where(np.isnan(Q), 0.0, Q)
        reached = self.chain.fk(filled)
        position, rotation = pose_residuals(np.broadcast_to(self.T, reached.shape), reached)
        return position, rotation, reached

    def _checked(self, Q: np.ndarray, position: np.ndarray, rotation: np.ndarray) -> tuple:
        """``(Q, ok, margin)``: the rows that miss the target by more than :data:`POLISH_TO` and less than
        :data:`POLISH_BELOW` moved by Newton steps on the true chain (the batched closed forms solve the nearest
        ideal arm of a calibrated one and do not refine; their residuals, per slot by the chain's FK, say which),
        then ``ok`` (N, B): the row exists, reaches the target within ``tol`` and lies inside the joint limits,
        and ``margin`` (N, B): its joints' least distance to a limit (rad; negative outside; NaN where it does
        not exist or does not reach the target)."""
        exists = ~np.isnan(Q).any(axis=-1)
        Q = np.where(exists[..., None], Q, np.nan)
        position = np.where(exists, np.nan_to_num(position, nan=np.inf), np.inf)
        rotation = np.where(exists, np.nan_to_num(rotation, nan=np.inf), np.inf)
        worst = np.maximum(position, rotation)
        polish = exists & (worst > POLISH_TO) & (worst < POLISH_BELOW)
        if polish.any():
            rows = self._polished(Q[polish])
            Q[polish] = rows
            position[polish], rotation[polish], _ = self._residuals(rows)
        filled = np.where(exists[..., None], Q, 0.0)
        reached = exists & (position <= self.tol[0]) & (rotation <= self.tol[1])
        margin = np.minimum(filled - self.chain.lower, self.chain.upper - filled).min(axis=-1)
        margin = np.where(reached, margin, np.nan)
        self.reached_any = self.reached_any or bool(reached.any())
        return Q, reached & (margin >= -LIMIT_SLACK), margin

    def _polished(self, rows: np.ndarray) -> np.ndarray:
        """Rows (m, 7) moved by at most :data:`POLISH_STEPS` Newton steps on the true chain by the one polisher
        (:func:`manipkit.ik.chain_newton.newton_rows`): all seven joints for the arm angle (least-norm steps), else
        the locked joint held (the six others' product at its value, :func:`manipkit.ik.general6r.locked_geometry`)."""
        from manipkit.ik.chain_newton import newton_rows

        if self.parameter.kind == "arm_angle":
            return newton_rows(chain_family(self.chain, tol=self.family_tol).geometry, self.T, rows,
                               iterations=POLISH_STEPS)
        out, column = np.array(rows, dtype=float), self.parameter.column
        for value in np.unique(out[:, column]):
            mine = out[:, column] == value
            geometry, L = locked_geometry(self.chain, self.parameter.name, float(value), family_tol=self.family_tol)
            out[mine] = newton_rows(geometry, invert_transform(L, check=False) @ self.T, out[mine],
                                    iterations=POLISH_STEPS)
        return out


class _Compiled:
    """The sweep, narrowing and rows of a pose in one compiled call (:mod:`manipkit.ik.redundant_kernel`; the same
    answers as :class:`_Solver` and :func:`_intervals`, tested) where the dispatcher's batch answers each value by a
    compiled closed form: a 7R SRS arm's arm angle, or an end joint locked over a 6R arm "spherical wrist, two
    intersecting". :meth:`of` gives it for a solver where it applies."""

    #: (id of the 7R chain, family_tol, parameter) -> (chain, (kind, ideal arm, constants, slot labels) or None)
    _PREPARED: dict = {}

    def __init__(self, solver: _Solver, prepared: tuple):
        from manipkit.ik.redundant_kernel import pack_settings

        self.solver = solver
        self.kind, self.arm, self.constants, _ = prepared
        self.settings = pack_settings(solver.tol, PARAMETER_TOL, MARGIN_TOL, LIMIT_SLACK, POLISH_TO, POLISH_BELOW)
        m = len(self.arm.h)
        self.known = (np.zeros(0), np.zeros((0, 8, m)), np.zeros((0, 8), dtype=bool))

    @classmethod
    def of(cls, solver: _Solver) -> _Compiled | None:
        """The compiled path for ``solver``, or None (asked once per chain, by one target through ``ik_many``)."""
        key = (id(solver.chain), repr(solver.family_tol), solver.parameter)
        cached = cls._PREPARED.get(key)
        if cached is None or cached[0] is not solver.chain:
            if len(cls._PREPARED) >= 64:
                cls._PREPARED.clear()
            cached = cls._PREPARED[key] = (solver.chain, cls._prepared(solver))
        if cached[1] is None:
            return None
        if not solver.labels:
            solver.labels = list(cached[1][3])
        return cls(solver, cached[1])

    @staticmethod
    def _prepared(solver: _Solver) -> tuple | None:
        """(kind, ideal arm, the kernel's constants, slot labels) of the solver's chain, or None."""
        from manipkit.ik.chain_ik import slot_labels
        from manipkit.ik.families import SPHERICAL_12
        from manipkit.ik.ideal_arm import compiled_arm, ideal_arm
        from manipkit.ik.redundant_kernel import ARM_ANGLE, LOCKED

        parameter, chain = solver.parameter, solver.chain
        if parameter.kind == "arm_angle":
            kind, sub, frames, arm_angle = ARM_ANGLE, chain, (solver.base, solver.tip), [0.0]
            moving = (np.zeros(0), np.zeros(1, dtype=np.int64))  # no locked joint: an empty FK program
            column = -1
        elif solver.sub is not None and solver.tracks is None:
            kind, frames, arm_angle = LOCKED, solver.sub[:2], None
            sub = solver.robot.chain(*frames)
            moving, column = solver.sub[2].program.row_tables, int(parameter.column)
        else:
            return None
        family = chain_family(sub, tol=solver.family_tol)
        wanted = SRS if kind == ARM_ANGLE else SPHERICAL_12
        if family.kind != wanted or family.snap or (kind == ARM_ANGLE and family.reversed):
            return None
        probe = solver.ik_many(solver.robot, sub.fk(np.zeros((1, sub.n))), base=frames[0], tip=frames[1],
                               tol=solver.tol, family_tol=solver.family_tol, arm_angle=arm_angle)
        if probe.method != "closed_form" or probe.solver != f"ik.chain_ik_many ({wanted})" or \
                tuple(probe.labels) != slot_labels(family):
            return None
        arm = ideal_arm(family)
        return (kind, arm, (*compiled_arm(sub, arm), *moving, column,
                            np.array([chain.lower, chain.upper], dtype=float)), tuple(probe.labels))

    def _run(self, kernel, *head):
        """``kernel(kind, *head, T, constants..., known...)`` until it answers: each target it hands back is solved
        by the numpy reference and added to the known answers; None when it says to answer the pose in Python."""
        from manipkit.ik.redundant_kernel import DONE, PYTHON, reference_branches

        T = np.ascontiguousarray(self.solver.T, dtype=float)
        for _ in range(HAND_BACKS):
            out = kernel(self.kind, *head, T, *self.constants, self.settings, *self.known)
            status, asked, g = out[0], out[-2], out[-1]
            if status == DONE:
                return out
            if status == PYTHON:
                return None
            theta, valid = reference_branches(self.kind, self.arm, np.array(g), np.array(asked))
            values, thetas, valids = self.known
            self.known = (np.concatenate([values, asked]), np.concatenate([thetas, np.nan_to_num(theta)]),
                          np.concatenate([valids, valid]))
        return None

    def intervals(self, lower: float, upper: float, step: float) -> list[tuple[int, float, float]] | None:
        """:func:`_intervals` of the solver's pose (None: answer it in Python)."""
        from manipkit.ik.redundant_kernel import sweep_intervals

        values, rounds = _sweep(lower, upper, step)
        out = self._run(sweep_intervals, values, rounds)
        if out is None:
            return None
        _, runs, reached, _, _ = out
        self.solver.reached_any = self.solver.reached_any or bool(reached)
        return [(int(b), float(low), float(high)) for b, low, high in sorted(runs.tolist(), key=lambda r: (r[0], r[1]))]

    def rows(self, values: np.ndarray) -> tuple[np.ndarray, np.ndarray, None] | None:
        """``(Q, ok, None)`` of :meth:`_Solver.solve` at ``values`` (None: answer them in Python)."""
        from manipkit.ik.redundant_kernel import sweep_rows

        out = self._run(sweep_rows, np.ascontiguousarray(values, dtype=float))
        if out is None:
            return None
        _, Q, ok, reached, _, _ = out
        self.solver.reached_any = self.solver.reached_any or bool(reached)
        return Q, ok, None


def _pad(ok: np.ndarray, width: int) -> np.ndarray:
    """``ok`` (N, b) widened to (N, width) with False (branches first seen later)."""
    return ok if ok.shape[1] >= width else np.pad(ok, ((0, 0), (0, width - ok.shape[1])))


def _sweep(lower: float, upper: float, step: float) -> tuple[np.ndarray, int]:
    """(the sweep's values, both ends included, at steps of at most ``step``; the narrowing's most rounds)."""
    samples = max(2, math.ceil((upper - lower) / step) + 1)
    return np.linspace(lower, upper, samples), max(0, math.ceil(math.log2(max(step, 1e-300) / PARAMETER_TOL)))


def _intervals(solver: _Solver, lower: float, upper: float, step: float) -> list[tuple[int, float, float]]:
    """(branch, low, high) of every feasible interval, low to high per branch in branch order.

    Every change of feasibility between two neighbouring samples is a bracket, narrowed in rounds (all brackets'
    next values solved in one call): by the Illinois variant of false position on the branch's limit margin
    (its joints' least distance to a limit, rad; negative outside) while both ends have one, else by bisection,
    until the bracket is narrower than :data:`PARAMETER_TOL` or the feasible end lies within :data:`MARGIN_TOL`
    of a limit.
    """
    values, rounds = _sweep(lower, upper, step)
    samples = len(values)
    _, ok, margin = solver.solve(values)
    B = ok.shape[1]
    runs = []  # [branch, first sample, last sample, low, high]
    for b in range(B):
        column = ok[:, b]
        i = 0
        while i < samples:
            if not column[i]:
                i += 1
                continue
            j = i
            while j + 1 < samples and column[j + 1]:
                j += 1
            runs.append([b, i, j, values[i], values[j]])
            i = j + 1
    brackets = []  # [run, end (0 low, 1 high), outside, inside, margin outside, margin inside, side kept last]
    for r, (b, i, j, _, _) in enumerate(runs):
        if i > 0:
            brackets.append([r, 0, values[i - 1], values[i], margin[i - 1, b], margin[i, b], 0])
        if j < samples - 1:
            brackets.append([r, 1, values[j + 1], values[j], margin[j + 1, b], margin[j, b], 0])
    for _ in range(rounds):
        active = [k for k, (_, _, out, inn, _, g_in, _) in enumerate(brackets)
                  if abs(out - inn) > PARAMETER_TOL and not (g_in <= MARGIN_TOL)]
        if not active:
            break
        trial = []
        for k in active:
            _, _, out, inn, g_out, g_in, _ = brackets[k]
            if math.isfinite(g_out) and math.isfinite(g_in) and g_in > g_out:
                t = min(max(g_in / (g_in - g_out), 0.01), 0.99)  # false position, kept off the ends
                trial.append(inn + t * (out - inn))
            else:
                trial.append(0.5 * (out + inn))
        _, ok_at, margin_at = solver.solve(np.array(trial))
        width = max(len(solver.labels), B)
        ok_at, margin_at = _pad(ok_at, width), np.pad(margin_at, ((0, 0), (0, width - margin_at.shape[1])),
                                                          constant_values=np.nan)
        for index, k in enumerate(active):
            bracket = brackets[k]
            b = runs[bracket[0]][0]
            if ok_at[index, b]:
                bracket[3], bracket[5] = trial[index], margin_at[index, b]
                if bracket[6] == 1:  # the outside end kept twice running: halve its margin (Illinois)
                    bracket[4] *= 0.5
                bracket[6] = 1
            else:
                bracket[2], bracket[4] = trial[index], margin_at[index, b]
                if bracket[6] == -1:
                    bracket[5] *= 0.5
                bracket[6] = -1
    for r, end, _, inside, *_ in brackets:
        runs[r][3 + end] = inside
    return [(b, float(low), float(high)) for b, _, _, low, high in sorted(runs, key=lambda run: (run[0], run[3]))]


def _spread(intervals: list[tuple[int, float, float]], count: int) -> list[tuple[int, float]]:
    """(branch, value) of ``count`` values over ``intervals`` (the module docstring's rule)."""
    if not intervals:
        return []
    # lengths on a grid of PARAMETER_TOL (the ends are known to that much): intervals of one length (the two
    # branches of a wrist flip share their limits) get their shares by their order, not by rounding noise
    lengths = np.round(np.array([high - low for _, low, high in intervals]) / PARAMETER_TOL) * PARAMETER_TOL
    order = np.argsort(-lengths, kind="stable")
    share = np.zeros(len(intervals), dtype=int)
    share[order[:min(count, len(intervals))]] = 1
    left = count - int(share.sum())
    if left > 0 and lengths.sum() > 0:
        wanted = lengths / lengths.sum() * count
        extra = np.maximum(np.floor(wanted) - share, 0).astype(int)
        while extra.sum() > left:
            extra[np.argmax(extra)] -= 1
        share += extra
        left = count - int(share.sum())
        remainder = wanted - share
        for i in np.argsort(-remainder, kind="stable")[:left]:
            share[i] += 1
    chosen = []
    for (branch, low, high), k in zip(intervals, share):
        if k == 1:
            chosen.append((branch, 0.5 * (low + high)))
        elif k >= 2:
            inset = _INSET * (high - low)
            chosen += [(branch, float(v)) for v in np.linspace(low + inset, high - inset, k)]
    return chosen


def scores(chain: Chain, Q, rank: str, *, checker=None, q_rest=None) -> np.ndarray:
    """The ranking criterion of each chain vector of ``Q`` (k, n), larger is better (:data:`RANKS`).

    ``"limits"``: min over joints of min(q - lower, upper - q) / (upper - lower) (joints without finite limits
    left out); ``"manipulability"``: sqrt(det(J J^T)), J the 6 x n base-frame Jacobian; ``"clearance"``: the
    closest checked pair's distance (m) by ``checker`` (:class:`manipkit.kinematics.collisions.CollisionChecker`)
    at the whole-robot vector ``chain.full(q, q_rest)``.
    """
    Q = np.asarray(Q, dtype=float).reshape(-1, chain.n)
    if rank == "limits":
        finite = np.isfinite(chain.lower) & np.isfinite(chain.upper)
        span = np.where(finite, chain.upper - chain.lower, 1.0)
        margin = np.minimum(Q - chain.lower, chain.upper - Q) / span
        return np.where(finite, margin, np.inf).min(axis=1) if finite.any() else np.full(len(Q), np.inf)
    if rank == "manipulability":
        J = chain.jacobians(Q)
        return np.sqrt(np.maximum(np.linalg.det(J @ np.swapaxes(J, -1, -2)), 0.0))
    if rank == "clearance":
        if checker is None:
            raise IKOptionError("rank 'clearance' needs a collision checker (collisions=True or a checker; "
                                "ik --collisions or --collision-free)")
        reports = [checker.report(chain.full(q, q_rest)) for q in Q]
        return np.array([np.inf if r.min_distance is None else r.min_distance.distance for r in reports])
    raise IKOptionError(f"rank must be one of {', '.join(RANKS)}, got {rank!r:.60}")


def check_options(count, rank) -> tuple[int, str]:
    """``(count, rank)`` checked (defaults :data:`DEFAULT_COUNT`, ``"limits"``), or IKOptionError in one line."""
    count = DEFAULT_COUNT if count is None else bounded_count(count, "count", maximum=MAX_SOLUTIONS,
                                                               error=IKOptionError)
    rank = "limits" if rank is None else rank
    if not isinstance(rank, str) or rank not in RANKS:
        raise IKOptionError(f"rank must be one of {', '.join(RANKS)}, got {rank!r:.60}")
    return count, rank


def ranked_set(robot, target, base: str, tip: str, *, solvers: tuple, parameter: Redundancy | None = None,
               count=None, rank=None, tol=1e-9, family_tol=FAMILY_TOL, step: float = SWEEP_STEP, q0=None,
               checker=None, drop_collisions: bool = False, compiled: bool = True) -> IKResult:
    """``count`` solutions of the 7R chain ``base -> tip`` for ``target`` (T_base_tip, 4x4, m) spread across its
    self-motion and ranked (the module docstring: parameter, intervals, spread, criteria).

    Parameters
    ----------
    robot : manipkit.kinematics.robot.Robot
    target : array_like, shape (4, 4)
    base, tip : str
    solvers : (callable, callable)
        The one dispatcher's :func:`manipkit.ik.dispatch.ik` and :func:`manipkit.ik.dispatch.ik_many`, the
        inner solve (handed in by the dispatcher, which calls this module: ``manipkit.ik(arm, T, all=True)``).
    parameter : Redundancy, optional
        Default: :func:`redundancy` of the chain (IKOptionError when it has none).
    count : int, optional
        Solutions wanted (default :data:`DEFAULT_COUNT`, at most :data:`MAX_SOLUTIONS`); fewer come back when
        the feasible intervals are fewer or empty.
    rank : {"limits", "manipulability", "clearance"}, optional
        The order, best first (default ``"limits"``); ``"clearance"`` needs ``checker``.
    tol : float or (float, float)
        Residual tolerance (m, rad) of every solution, by the chain's FK.
    step : float
        The sweep's widest step (rad).
    q0 : array_like or dict, optional
        Values of the joints off the chain (rows are whole-robot vectors).
    checker : CollisionChecker, optional
        Marks ``collides`` and ``clearance`` per row; ``drop_collisions`` keeps the collision-free rows only.
    compiled : bool
        A locked end joint over a 6R arm "spherical wrist, two intersecting" (Panda, FR3): the sweep, narrowing and
        rows in one compiled call per pose (:mod:`manipkit.ik.redundant_kernel`); False: through the dispatcher
        round by round (the reference; the same answers, tested).

    Returns
    -------
    IKResult
        Rows best first; ``labels`` the branches, ``parameter`` and ``parameter_values`` the parameter and its
        value per row, ``intervals`` every branch's feasible intervals, ``ranked_by`` and ``scores`` the
        criterion and its value per row.

    Examples
    --------
    >>> import manipkit
    >>> iiwa = manipkit.load("iiwa14")
    >>> T = iiwa.transform("base_link", "ee_link", [0.3, 0.5, -0.2, -1.2, 0.4, 0.8, 0.1])
    >>> answer = manipkit.ik(iiwa, T, all=True, count=8)
    >>> answer.parameter, len(answer.solutions), answer.ranked_by
    ('psi (arm angle)', 8, 'limits')
    """
    # Over 80 lines: the docstring is most of it.
    count, rank = check_options(count, rank)
    if rank == "clearance" and checker is None:
        scores(robot.chain(base, tip), np.zeros((0, 7)), rank)  # the one message
    tol = tolerances(tol)
    if parameter is None:
        parameter = redundancy(robot, base, tip, family_tol=family_tol)
        if parameter is None:
            raise IKOptionError(f"the chain {base} -> {tip} has no redundancy parameter with a closed form "
                                "(a 7R arm of revolute joints whose arm angle or one locked joint leaves a solved arm)")
    from manipkit.spatial.transforms import check_transform, pose_residuals, projected_rotation

    T = np.array(check_transform(target), dtype=float)
    solver = _Solver(robot, T, base, tip, parameter, tol, family_tol, solvers)
    chain = solver.chain
    fast = _Compiled.of(solver) if compiled else None
    found = None if fast is None else fast.intervals(parameter.lower, parameter.upper, float(step))
    if found is None:
        fast = None
        found = _intervals(solver, parameter.lower, parameter.upper, float(step))
    chosen = _spread(found, count)
    labels_all = list(solver.labels)
    rows, labels, values = [], [], []
    if chosen:
        at = np.array([v for _, v in chosen])
        answered = None if fast is None else fast.rows(at)
        Q, ok, _ = solver.solve(at) if answered is None else answered
        ok = _pad(ok, len(solver.labels))
        for k, (branch, value) in enumerate(chosen):
            if branch < Q.shape[1] and ok[k, branch]:
                rows.append(Q[k, branch])
                labels.append(labels_all[branch])
                values.append(value)
    Q = np.array(rows, dtype=float).reshape(-1, 7)
    rest = None if q0 is None else robot.q(q0)
    # the target's rotation projected once where it is not exact (pose_residuals' rule; FK poses are rotations)
    reference = T.copy()
    reference[:3, :3] = projected_rotation(T[:3, :3])
    position, rotation = (pose_residuals(np.broadcast_to(reference, (len(Q), 4, 4)), chain.fk(Q), project=False)
                          if len(Q) else (np.zeros(0), np.zeros(0)))
    score = scores(chain, Q, rank, checker=checker, q_rest=rest) if len(Q) else np.zeros(0)
    order = np.argsort(-score, kind="stable")
    whole = np.repeat(np.asarray(robot.q() if rest is None else rest, dtype=float)[None], len(Q), axis=0)
    whole[:, chain.columns] = Q[order]  # chain.full of each row (its rows are checked finite)
    intervals = tuple((labels_all[b], low, high) for b, low, high in found)
    spans = sum(high - low for _, low, high in found)
    note = (f"{len(Q)} solution(s) across the self-motion of {parameter.label}, spread over {len(found)} feasible "
            f"interval(s) of {len({b for b, _, _ in found})} branch(es) (total {spans:.6g} rad of "
            f"[{parameter.lower:.6g}, {parameter.upper:.6g}]; sweep step {min(step, parameter.upper - parameter.lower):.3g} "
            f"rad, crossings narrowed to {PARAMETER_TOL:g} rad), ranked by {rank} (best first)")
    failure = None
    if not len(Q):
        where = f"at any value of {parameter.label} on [{parameter.lower:.6g}, {parameter.upper:.6g}] (swept at {step:.3g} rad)"
        if solver.reached_any:
            note = f"every solution breaks a joint limit {where}"
            failure = IKFailure("joint_limits", note)
        else:
            note = f"no branch reaches the target {where}"
    result = IKResult(whole, tuple(labels[i] for i in order), len(Q), note, position[order], rotation[order],
                      mode=SPATIAL_POSE, solver="ik.redundant", joint_names=tuple(robot.joint_names),
                      within_limits=np.ones(len(Q), dtype=bool),
                      method=ALGEBRAIC if parameter.family == GENERAL_6R else "closed_form",
                      arm_family=(f"7R, {parameter.family}" if parameter.kind == "arm_angle"
                                  else f"7R, {parameter.family} with {parameter.name} locked"),
                      parameter=parameter.label, parameter_values=np.array(values)[order] if values else np.zeros(0),
                      intervals=intervals, ranked_by=rank, scores=score[order], failure=failure)
    if checker is not None:
        from manipkit.ik.collision_marks import mark_collisions

        marked = mark_collisions(result, checker)
        keep = np.array([not c for c in marked.collides], dtype=bool)
        if drop_collisions and keep.any() and not keep.all():
            kept = marked.take(keep)
            result = kept.replaced(note=f"{kept.note}; {int((~keep).sum())} in collision dropped")
        elif drop_collisions and len(keep) and not keep.any():  # every row collides: the collision failure
            result = mark_collisions(result, checker, drop=True).replaced(parameter_values=np.zeros(0),
                                                                          scores=np.zeros(0))
        else:
            result = marked
    return result

