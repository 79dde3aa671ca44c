"""The one IK dispatcher: :func:`ik` for one target, :func:`ik_many` for a stack of targets.

``manipkit.ik(robot_or_chain, T_base_tip, base=..., tip=..., method="auto", all=False)``
answers every IK question of manipkit, in Python and on the command line
(``manipkit ik`` calls it and only formats the answer), so a notebook and a
terminal give the same solutions for the same question.

Conventions (docs/architecture.md): frames base first; ``T_base_tip`` is the
wanted pose of ``tip`` in ``base`` (4x4, metres); joint vectors in
``robot.joint_names`` order (radians or metres), the joints off the chain at
their values in ``q0`` (or their defaults); residuals measured by forward
kinematics of each answer through the real chain; ``tol`` is always that
residual tolerance (metres and radians), ``family_tol`` the tolerance within
which axes count as parallel or meeting.

Which solver answers (``method="auto"``): the closed form wherever the chain
has one for the question (a bundled textbook arm, or a 6R/7R family found in
its geometry: :func:`manipkit.ik.textbook.closed_form_solves`); a chain of 6
revolute joints with none gets every isolated solution by algebraic
elimination (:mod:`manipkit.ik.general6r`: ``method`` ``"algebraic"``,
``arm_family`` ``"general 6R"``; ``method="algebraic"`` asks for it on any 6R
chain and refuses others), and so does a 7R revolute chain with one joint
locked (``lock=``) that no closed form holds; else numerical IK; the result's ``method`` says
which ran, ``arm_family`` the family. ``ik_many`` batches the elimination
(``method`` "algebraic", or "auto" without ``q0`` or ``lock`` on a chain the
single call answers by it: :func:`manipkit.ik.general6r.general_ik_many`,
each target the single call's rows without aliases); on a 6R arm that
has its family only within ``family_tol`` (snapped) each target gets
the single call's rows, the closed form refined and the elimination's, in one batch.
``method="closed_form"`` refuses a chain without one (the message gives the
geometric evidence); ``method="numerical"`` always searches. Options a
solver cannot honour are refused in one line (:class:`manipkit.errors.IKOptionError`),
never dropped: ``lock`` only by the closed forms and the general 6R solver (one joint of a 7R chain),
``arm_angle`` only by the closed forms, ``axis``
(mode ``"position+axis"``) and ``free`` only by numerical IK.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from manipkit.errors import ChainError, IKOptionError
from manipkit.ik.families import FAMILY_TOL
from manipkit.ik.result import SPATIAL_POSE, IKBatch, IKResult

if TYPE_CHECKING:
    from manipkit.kinematics.collisions import CollisionChecker

__all__ = ["METHODS", "ik", "ik_many", "robot_and_frames"]

#: The ``method`` a caller may ask for; a result's ``method`` is one of the last three.
METHODS = ("auto", "closed_form", "numerical", "algebraic")
#: The ``mode`` vocabulary of the dispatcher (what must match); the results say it in words
#: (:data:`manipkit.ik.result.MODES`).
ASKED_MODES = ("pose", "position", "position+axis")


def robot_and_frames(subject, base: str | None, tip: str | None) -> tuple:
    """(robot, base, tip) of a Robot and its frame names (defaults ``base_link``, ``ee_link``), or of a Chain
    (which has its own frames: giving ``base``/``tip`` too is refused)."""
    from manipkit.kinematics.chain import Chain

    if isinstance(subject, Chain):
        if base is not None or tip is not None:
            raise ChainError(f"a chain has its own frames ({subject.base} -> {subject.tip}); give base= and tip= "
                                "only with a robot")
        return subject.robot, subject.base, subject.tip
    return subject, "base_link" if base is None else base, "ee_link" if tip is None else tip


def _check_choice(name: str, value, choices: tuple[str, ...]) -> None:
    if not isinstance(value, str) or value not in choices:
        raise IKOptionError(f"{name} must be one of {', '.join(choices)}, got {value!r:.60}")


def _closed_form_applies(robot, base: str, tip: str, *, method: str, mode: str, family_tol, lock, arm_angle,
                         free) -> bool:
    """Whether the closed form answers (``method`` "auto": where the chain has one), or IKOptionError for an option
    the chosen solver cannot honour."""
    from manipkit.ik.textbook import closed_form_refusal, closed_form_solves

    held = [name for name, given in (("lock", bool(lock)), ("arm_angle", arm_angle is not None)) if given]
    if method == "numerical":
        if held:
            raise IKOptionError(f"{held[0]}= is honoured by the closed forms only; numerical IK does not hold joints "
                                "or an arm angle: leave it out, or use method='closed_form'")
        return False
    if mode == "position+axis" or free:
        what = ("a pointing target (an axis to match, mode 'position+axis'): leave out the axis" if mode == "position+axis"
                else "free floating joints (free=): leave them out")
        if method == "closed_form":
            raise IKOptionError(f"the closed forms do not solve {what}, or use numerical IK")
        if held:
            raise IKOptionError(f"{held[0]}= is honoured by the closed forms only, and they do not solve {what}")
        return False
    if closed_form_solves(robot, base, tip, mode=mode, family_tol=family_tol, lock=lock, arm_angle=arm_angle):
        return True
    if method == "auto" and held == ["lock"] and mode == "pose":
        from manipkit.ik.general6r import general_solves

        if general_solves(robot.chain(base, tip), family_tol=family_tol, lock=lock):
            return False  # a general 7R with one joint locked: the elimination holds it
    if method == "closed_form" or held:  # the closed form was asked for, by name or by its options: say why not
        raise IKOptionError(closed_form_refusal(robot, base, tip, mode=mode, family_tol=family_tol, lock=lock,
                                                arm_angle=arm_angle))
    return False


def _general_applies(robot, base: str, tip: str, *, method: str, mode: str, family_tol, lock, arm_angle,
                     free) -> bool:
    """Whether the general 6R elimination answers (``method`` "algebraic": always, else IKOptionError saying why it
    cannot; "auto": a 6R revolute chain with no closed-form family, for a pose without options it cannot honour)."""
    from manipkit.ik.general6r import general_refusal, general_solves

    chain = robot.chain(base, tip)
    if method != "algebraic":
        return method == "auto" and mode == "pose" and arm_angle is None and not free and \
            general_solves(chain, family_tol=family_tol, lock=lock)
    held = [name for name, given in (("arm_angle", arm_angle is not None), ("free", bool(free))) if given]
    if held or mode != "pose":
        what = f"{held[0]}=" if held else f"mode {mode!r}"
        raise IKOptionError(f"the general 6R solver (method='algebraic') solves a pose of 6 revolute joints (or 7 "
                            f"with one locked); it does not take {what}: leave it out, or use method='auto'")
    refusal = general_refusal(chain, family_tol=family_tol, lock=lock)
    if refusal:
        raise IKOptionError(refusal)
    return True


def _general_answer(robot, target, base: str, tip: str, tol, family_tol, lock) -> IKResult:
    """Every isolated solution of the 6R chain, or the 7R chain with ``lock`` (:func:`manipkit.ik.general6r.general_ik`),
    rows as whole-robot vectors (the off-chain joints at their defaults, as the closed forms give them)."""
    from manipkit.ik.general6r import general_ik

    chain = robot.chain(base, tip)
    result = general_ik(chain, target, tol=tol, family_tol=family_tol, lock=lock)
    if tuple(chain.joint_names) == tuple(robot.joint_names):
        return result
    Q = np.repeat(np.asarray(robot.q(), dtype=float)[None], len(result.solutions), axis=0)
    Q[:, chain.columns] = result.solutions
    Q.setflags(write=False)
    return result.with_rows(Q, robot.joint_names, tuple(int(chain.columns[j]) for j in result.free_joints))


#: Rows nearer than this (rad, each chain joint, modulo 2 pi) are the same solution when two solvers' answers join.
SAME_ROW_TOL = 1e-6
#: The label of a row the general 6R elimination found and the closed form did not (:func:`_with_elimination`).
ELIMINATION_LABEL = "found by elimination"


def _snapped_6r(robot, base: str, tip: str, *, mode: str, family_tol, lock, arm_angle, free) -> bool:
    """Whether ``all=True`` checks a closed form by the general 6R elimination: a pose of 6 revolute joints (no
    lock, arm angle or free axis) whose family holds only within ``family_tol`` (``Family.snap`` not empty).

    The closed form is solved on the nearest ideal arm and each branch refined on the true chain; near a
    boundary of the ideal arm's reach, or where two of its branches nearly meet, a branch of the true arm can be
    missing (0.03 % to 0.5 % of random poses on arms 1e-6 m to 0.2 mm off their family, none on an exact arm).
    """
    from manipkit.ik.families import chain_family
    from manipkit.ik.general6r import general_refusal

    if mode != "pose" or lock or arm_angle is not None or free:
        return False
    chain = robot.chain(base, tip)
    if chain.n != 6 or general_refusal(chain, family_tol=family_tol):
        return False
    return bool(chain_family(chain, tol=family_tol).snap)


def _fresh(new: np.ndarray, known: np.ndarray) -> np.ndarray:
    """Boolean (..., m): each row of ``new`` (..., m, n) that is no row of ``known`` (..., k, n), to
    :data:`SAME_ROW_TOL` in every joint modulo 2 pi (the rule by which the elimination's rows join a closed form's,
    one call or a batch); a NaN row of ``new`` is not fresh, a NaN row of ``known`` equals nothing."""
    gap = np.abs(np.remainder(new[..., :, None, :] - known[..., None, :, :] + np.pi, 2 * np.pi) - np.pi).max(axis=-1)
    return ~np.isnan(new).any(axis=-1) & ~(gap <= SAME_ROW_TOL).any(axis=-1)


def _with_elimination(closed: IKResult, general: IKResult, chain) -> IKResult:
    """The closed form's rows, then each row of the general 6R elimination that none of them is (to
    :data:`SAME_ROW_TOL`, modulo 2 pi on the chain's joints), labelled :data:`ELIMINATION_LABEL` (numbered ``#1``,
    ``#2``, ... when more than one: :func:`~manipkit.ik.branch_names.numbered`); ``closed`` as it
    is when the elimination adds nothing or the answer is a family."""
    from manipkit.ik.branch_names import numbered

    if closed.infinite or general.infinite or not len(general.solutions):
        return closed
    whole = closed.solutions.shape[1] != chain.n
    columns = chain.columns if whole else np.arange(chain.n)
    fresh = np.flatnonzero(_fresh(general.solutions[:, columns], closed.solutions[:, columns]))
    if not len(fresh):
        return closed
    added = general.take(fresh)
    note = (f"{closed.note}; the arm is its family's only within the tolerance, so every solution was also sought by "
            f"the general 6R elimination: {len(fresh)} more it found are listed after the closed form's "
            f"{len(closed.solutions)} (labelled '{ELIMINATION_LABEL}'{', numbered' if len(fresh) > 1 else ''})")
    return closed.extended(added, labels=numbered((ELIMINATION_LABEL,) * len(fresh)), note=note)


#: Slots of :func:`_snapped_many`'s batch: the closed form's 8, then the rows only the elimination finds (a 6R arm
#: has at most 16 isolated solutions).
SNAPPED_SLOTS = 16


def _snapped_many(robot, targets, base: str, tip: str, *, tol, family_tol) -> IKBatch:
    """``ik_many`` on a snapped 6R arm (:func:`_snapped_6r`): per target (N, 4, 4) the rows of ``ik(..., all=True,
    aliases=False)``, batched. Slots 0-7: the closed form's branches on the nearest ideal arm, refined on the true
    chain (:func:`manipkit.ik.chain_ik.refined_many`: labelled by slot, NaN where a branch misses); slots 8 on:
    each row of the general 6R elimination (:func:`manipkit.ik.general6r.general_ik_many`) that none of them is (to
    :data:`SAME_ROW_TOL`, modulo 2 pi), in the elimination's order (:data:`SNAPPED_SLOTS` in all, more where a
    target has more), none where either answer is a one-parameter family, as :func:`_with_elimination` joins them.
    ``branch_labels(i)`` names target ``i``'s rows as the single call does (``ELIMINATION_LABEL`` numbered)."""
    from manipkit.bounds import tolerances
    from manipkit.ik.branch_names import numbered
    from manipkit.ik.chain_ik import refined_many
    from manipkit.ik.families import chain_family
    from manipkit.ik.general6r import general_ik_many
    from manipkit.ik.textbook import checked_targets

    chain = robot.chain(base, tip)
    T = checked_targets(targets)
    flat = T.reshape(-1, 4, 4)
    check = tolerances(tol, error=IKOptionError)
    family = chain_family(chain, tol=family_tol)
    closed = refined_many(chain, flat, family=family, check_tol=check)
    general = general_ik_many(chain, flat, tol=tol, family_tol=family_tol)
    Qc, Qg = np.asarray(closed.solutions), np.asarray(general.solutions)
    known = ~np.isnan(Qc).any(axis=-1)  # (N, 8)
    fresh = _fresh(Qg, Qc)  # (N, 16)
    fresh &= (np.isfinite(np.asarray(closed.count)) & np.isfinite(np.asarray(general.count))).reshape(-1)[:, None]
    extra = fresh.sum(axis=1)
    width = Qc.shape[1]
    k = max(SNAPPED_SLOTS, width + int(extra.max(initial=0)))
    Q = np.full((len(flat), k, chain.n), np.nan)
    Q[:, :width] = Qc
    rank = np.cumsum(fresh, axis=1) - 1  # each fresh row's place after the closed form's slots
    owner, row = np.nonzero(fresh)
    Q[owner, width + rank[owner, row]] = Qg[owner, row]
    count = np.where(np.isfinite(np.asarray(closed.count).reshape(-1)), known.sum(axis=1) + extra,
                     np.inf).reshape(T.shape[:-2])

    def name(index: int) -> tuple[str, ...]:
        found = int(extra[index])
        added = numbered((ELIMINATION_LABEL,) * found) if found else ()
        return closed.branch_labels(index) + tuple(added) + ("",) * (k - width - found)

    def measure(solutions):  # by the chain's FK, as the closed-form batch measures its slots
        from manipkit.spatial.transforms import pose_residuals

        missing = np.isnan(solutions).any(axis=-1)
        reached = chain.fk(np.where(missing[..., None], 0.0, solutions))
        position, rotation = pose_residuals(T.reshape(*T.shape[:-2], 1, 4, 4), reached)
        return np.where(missing, np.nan, position), np.where(missing, np.nan, rotation)

    labels = tuple(closed.labels) + tuple(f"{ELIMINATION_LABEL} {j + 1}" for j in range(k - width))
    return IKBatch(Q.reshape(*T.shape[:-2], k, chain.n), count, labels=labels, mode=SPATIAL_POSE,
                   solver=f"ik_many (the {family.kind} closed form refined on the true chain, and the "
                   "general 6R elimination)", joint_names=tuple(chain.joint_names), measure=measure,
                   limit=check, name=name)


def _checker(robot, given) -> CollisionChecker | None:
    """The collision checker of ``collisions=``/``collision_free=``: True -> the robot against itself."""
    if given is None or given is False:
        return None
    if given is True:
        from manipkit.kinematics.collisions import CollisionChecker

        return CollisionChecker(robot)
    return given


def _chain_distance(result: IKResult, columns, angular, q0: np.ndarray) -> np.ndarray:
    """Per row, the largest joint distance to ``q0`` over the chain's columns (angles modulo 2 pi)."""
    d = result.solutions[:, columns] - q0[columns]
    d = np.where(angular, np.abs(math.pi - np.mod(math.pi - d, 2.0 * math.pi)), np.abs(d))
    return d.max(axis=1) if d.size else np.zeros(len(result.solutions))


def _one(result: IKResult, robot, base: str, tip: str, q0) -> IKResult:
    """The one answer of ``all=False`` from every closed-form branch: the branch inside the joint limits nearest
    ``q0`` (largest joint distance, angles modulo 2 pi), else the first inside the limits in the solver's order;
    a branch outside the limits only when no branch is inside."""
    k = len(result.solutions)
    if k <= 1 or result.infinite:  # a family's rows are samples of its free parameter: all of them are the answer
        return result
    within = np.ones(k, dtype=bool) if result.within_limits is None else np.asarray(result.within_limits)
    candidates = np.flatnonzero(within) if within.any() else np.arange(k)
    if q0 is not None and len(candidates) > 1:
        chain = robot.chain(base, tip)
        angular = np.array([j.is_angular for j in chain.joints], dtype=bool)
        distance = _chain_distance(result, chain.columns, angular, robot.q(q0))
        best = int(candidates[np.argmin(distance[candidates])])
    else:
        best = int(candidates[0])
    return result.take([best])


def _ranked(robot, base: str, tip: str, *, method: str, all: bool, mode: str, lock, arm_angle, free, family_tol,
            closed: bool, count, rank):
    """The redundancy parameter when ``ik`` answers with a 7R arm's ranked set (``all``, ``method`` "auto", a pose,
    no lock, arm angle or free joints, no closed form as asked), else None; ``count``/``rank`` given otherwise: refused."""
    parameter = None
    if all and method == "auto" and mode == "pose" and not lock and arm_angle is None and not free and not closed:
        from manipkit.ik.redundant import redundancy

        parameter = redundancy(robot, base, tip, family_tol=family_tol)
    if parameter is None and (count is not None or rank is not None):
        raise IKOptionError("count= and rank= choose a 7R arm's ranked set across its self-motion: all=True, "
                            "method='auto', a pose, without lock= or arm_angle=, on a 7R chain with a closed form "
                            "per value of its arm angle or of a locked joint, or a general 7R whose end joint locked "
                            "leaves a 6R arm the elimination solves")
    return parameter


def ik(subject, target, *, base: str | None = None, tip: str | None = None, method: str = "auto", all: bool = False,
       mode: str = "pose", axis: str = "z", tol=1e-9, family_tol=FAMILY_TOL, lock=None, arm_angle=None, q0=None,
       restarts: int = 50, seed: int = 0, max_iters: int = 100, damping: float = 1e-1, free=(), collisions=None,
       collision_free=False, count=None, rank=None, aliases: bool = True) -> IKResult:
    """Joint values that put ``tip`` at ``target`` (T_base_tip): the closed form where the chain has one, every
    isolated solution by elimination for another 6R chain's pose, else a numerical search; one result type.

    Parameters
    ----------
    subject : manipkit.kinematics.robot.Robot or manipkit.kinematics.chain.Chain
        The robot (with ``base`` and ``tip``), or a chain (its own frames).
    target : array_like, shape (4, 4)
        ``T_base_tip``: the wanted pose of ``tip`` in ``base`` (metres). Mode
        ``"position"`` uses its translation only.
    base, tip : str, keyword-only
        Base and tip frames, base first (defaults ``base_link`` and ``ee_link``).
    method : {"auto", "closed_form", "numerical", "algebraic"}, keyword-only
        ``"auto"``: the closed form wherever the chain has one for ``mode``,
        else for a pose of a 6R revolute chain the algebraic elimination
        (every isolated solution), else numerical IK. ``"algebraic"``: the
        elimination on any 6R revolute chain (others refused).
    all : bool, keyword-only
        Every solution: every closed-form branch in the solver's documented
        order (shoulder, elbow, wrist), then every other in-limit 2 pi alias
        of each branch where a joint's range spans more than a full turn
        (``alias_of`` names its branch row; :mod:`manipkit.ik.aliases`), or
        every distinct solution numerical restarts find (which proves nothing
        about those it did not find). ``False``: one solution, the in-limit
        branch nearest ``q0`` (the first in order without ``q0``), or the
        first numerical solution found.
    aliases : bool, keyword-only
        With ``all=True`` and a closed form or the general 6R elimination:
        list the 2 pi aliases after the branches (default), or ``False`` the
        branches only (each joint at its in-limit value nearest 0).
    mode : {"pose", "position", "position+axis"}, keyword-only
        What must match: the 6D pose, the origin, or the origin and the
        direction of the tip's ``axis`` (numerical IK only).
    tol : float or (float, float), keyword-only
        Residual tolerance of every returned solution (m, rad): one number
        for both, or ``(position, rotation)``.
    family_tol : float or (float, float), keyword-only
        Tolerance (m, rad) within which the chain's axes count as parallel or
        meeting when its closed-form family is found.
    lock : dict of str to float, keyword-only
        Closed forms: joints held at a value (a 7R arm solved as the 6R arm
        of the others); on a 7R revolute chain whose locked 6R arm has no
        closed form, one joint held by the general 6R elimination (every
        isolated solution, ``method`` ``"algebraic"``); refused elsewhere.
    arm_angle : float or array_like, keyword-only
        Closed forms of 7R SRS arms (iiwa14): the arm angle (rad).
    q0 : array_like or dict, keyword-only
        Start and the off-chain joints' values (numerical IK); for
        ``all=False`` with a closed form, the configuration the chosen
        branch is nearest to.
    restarts, seed, max_iters, damping, free : keyword-only
        Numerical IK's budget and floating joints
        (:func:`manipkit.ik.numerical.ik`).
    collisions : bool or CollisionChecker, keyword-only
        Mark each solution ``collides`` (with ``clearance``): True checks the
        robot against itself; a checker brings its SRDF, floor and world.
    collision_free : bool or CollisionChecker, keyword-only
        Keep only solutions not in collision (numerical IK searches on past
        them); with none left, ``failure.kind == "collision"`` names the pairs.
    count, rank : int, str, keyword-only
        A 7R arm with ``all=True`` and neither ``lock`` nor ``arm_angle``
        (``method="auto"``): ``count`` solutions spread across the
        self-motion, ranked by ``rank`` (``"limits"``, ``"manipulability"``,
        ``"clearance"``): :func:`manipkit.ik.redundant.ranked_set`; refused
        for any other question.

    Returns
    -------
    IKResult
        ``method`` says which solver ran, ``arm_family`` the closed-form
        family, ``failure`` why there is no solution (kind and numbers).

    Raises
    ------
    IKOptionError
        An unknown method or mode, or an option the chosen solver cannot honour.
    UnknownFrameError, ChainError, InvalidTransformError
        Frames the robot does not have; a target that is not a transform.

    Examples
    --------
    >>> import manipkit
    >>> ur5 = manipkit.load("ur5")
    >>> T = ur5.transform("base_link", "tool0", [0.1, -1.0, 1.2, -0.3, 1.0, 0.5])
    >>> every = manipkit.ik(ur5, T, tip="tool0", all=True, aliases=False)
    >>> every.method, every.arm_family, len(every.solutions)
    ('closed_form', 'three parallel, two intersecting', 8)
    >>> with_aliases = manipkit.ik(ur5, T, tip="tool0", all=True)  # five joints of +-2 pi: 2**5 rows per branch
    >>> len(with_aliases.solutions), int((with_aliases.alias_of == -1).sum())
    (256, 8)
    >>> manipkit.ik(ur5, T, tip="tool0", method="numerical").method
    'numerical'
    """
    # Over 80 lines: the docstring (every option, the choice of solver) is most of it.
    robot, base, tip = robot_and_frames(subject, base, tip)
    _check_choice("method", method, METHODS)
    _check_choice("mode", mode, ASKED_MODES)
    closed = method != "algebraic" and _closed_form_applies(robot, base, tip, method=method, mode=mode,
                                                            family_tol=family_tol, lock=lock, arm_angle=arm_angle,
                                                            free=free)
    general = not closed and _general_applies(robot, base, tip, method=method, mode=mode, family_tol=family_tol,
                                              lock=lock, arm_angle=arm_angle, free=free)
    avoid = _checker(robot, collision_free)
    mark = avoid if avoid is not None else _checker(robot, collisions)
    ranked = _ranked(robot, base, tip, method=method, all=all, mode=mode, lock=lock, arm_angle=arm_angle, free=free,
                     family_tol=family_tol, closed=closed, count=count, rank=rank)
    if ranked is not None:
        from manipkit.ik.redundant import ranked_set

        return ranked_set(robot, target, base, tip, solvers=(ik, ik_many), parameter=ranked, count=count, rank=rank,
                          tol=tol, family_tol=family_tol, q0=q0, checker=mark, drop_collisions=avoid is not None)
    if closed or general:
        from manipkit.ik.textbook import analytic_ik

        result = (_general_answer(robot, target, base, tip, tol, family_tol, lock) if general else
                  analytic_ik(robot, target, base, tip, mode=mode, tol=tol, family_tol=family_tol, lock=lock,
                              arm_angle=arm_angle))
        if closed and all and method == "auto" and _snapped_6r(robot, base, tip, mode=mode, family_tol=family_tol,
                                                               lock=lock, arm_angle=arm_angle, free=free):
            result = _with_elimination(result, _general_answer(robot, target, base, tip, tol, family_tol, None),
                                       robot.chain(base, tip))
        if mark is not None:
            from manipkit.ik.collision_marks import mark_collisions

            result = mark_collisions(result, mark, drop=avoid is not None)
        if not all:
            return _one(result, robot, base, tip, q0)
        if not aliases:
            return result
        from manipkit.ik.aliases import with_aliases

        return with_aliases(result, robot.chain(base, tip), target, held=tuple(lock or ()))
    from manipkit.ik.numerical import ik as numerical_ik

    result = numerical_ik(robot, target, base, tip, mode=mode, axis=axis, q0=q0, tol=tol, max_iters=max_iters,
                          restarts=restarts, seed=seed, all=all, damping=damping, free=tuple(free),
                          collision_free=avoid if avoid is not None else False)
    if avoid is None and mark is not None:
        from manipkit.ik.collision_marks import mark_collisions

        result = mark_collisions(result, mark)
    return result


def _batch_closed_form(robot, base: str, tip: str, *, family_tol, lock) -> bool:
    """Whether the batch closed form answers these frames: the chain's geometric family has a solver
    (:func:`manipkit.ik.textbook.analytic_ik_many`); the named solvers of the textbook arms (planar, SCARA,
    Stanford) answer one target per call (:func:`ik`)."""
    from manipkit.errors import ClosedFormIKError
    from manipkit.ik.families import chain_family

    try:
        return chain_family(robot.chain(base, tip), tol=family_tol, lock=lock).solved
    except ClosedFormIKError:
        return False


def ik_many(subject, targets, *, base: str | None = None, tip: str | None = None, method: str = "auto",
            mode: str = "pose", axis: str = "z", tol=1e-9, family_tol=FAMILY_TOL, lock=None, arm_angle=None, q0=None,
            restarts: int = 20, seed: int = 0, max_iters: int = 100, damping: float = 1e-1, time_budget=None,
            threads=None) -> IKBatch:
    """:func:`ik` for a stack of targets ``(N, 4, 4)`` in one compiled call: an :class:`IKBatch`.

    The closed form (``method`` "auto" where the chain has one for a pose)
    gives every branch per target: 8 slots, NaN where a branch does not
    exist (:func:`manipkit.ik.chain_ik.chain_ik_many`; ``arm_angle`` one or
    one per target for a 7R SRS arm; :meth:`IKBatch.branch_labels` names a
    target's slots as :func:`ik` labels its rows). On a 6R arm whose family
    holds only within ``family_tol`` (snapped: :func:`_snapped_6r`), each
    target gets the rows of ``ik(..., all=True, aliases=False)`` instead,
    batched (:func:`_snapped_many`: the closed form's 8 slots refined on the
    true chain by the compiled polisher, then every row the compiled general
    6R elimination adds; 16 slots; 0.21-0.37 ms per target on the xArm7's
    arm, against 3.3-6.5 ms for the single call per target before). A 6R chain with no closed form (``method`` "auto" without ``q0``
    or ``lock``, or "algebraic") gets every isolated solution of each target
    by the compiled general 6R elimination on ``threads`` threads
    (:func:`manipkit.ik.general6r.general_ik_many`: ``method`` "algebraic",
    16 slots, each target's rows those of ``ik(..., all=True,
    aliases=False)``). Numerical IK gives one slot per target
    (also for the textbook arms whose closed form is a named solver, not the
    chain's geometric family: planar, SCARA, Stanford; ``method="closed_form"``
    says so and refuses)
    (:func:`manipkit.ik.numerical_many.ik_many`; ``q0`` one start for all or
    one per target, ``restarts`` per target). ``method``, ``failure_kinds``
    and :meth:`IKBatch.reason` say, per target, which ran and why one failed.

    Examples
    --------
    >>> import manipkit
    >>> ur5 = manipkit.load("ur5")
    >>> chain = ur5.chain("base_link", "tool0")
    >>> batch = manipkit.ik_many(chain, chain.fk(chain.sample(3, seed=1)))
    >>> batch.method, batch.solutions.shape, bool(batch.success.all())
    ('closed_form', (3, 8, 6), True)
    """
    robot, base, tip = robot_and_frames(subject, base, tip)
    _check_choice("method", method, METHODS)
    _check_choice("mode", mode, ASKED_MODES)
    if method == "algebraic" and lock:
        raise IKOptionError("ik_many's general 6R elimination takes no lock= (ik(..., lock=...) does); leave it out")
    if (method == "algebraic" or (method == "auto" and q0 is None and not lock)) and _general_applies(
            robot, base, tip, method=method, mode=mode, family_tol=family_tol, lock=lock, arm_angle=arm_angle,
            free=()):
        from manipkit.ik.general6r import general_ik_many

        return general_ik_many(robot.chain(base, tip), targets, tol=tol, family_tol=family_tol, threads=threads)
    closed = _closed_form_applies(robot, base, tip, method=method, mode=mode, family_tol=family_tol, lock=lock,
                                  arm_angle=arm_angle, free=())
    if closed and method == "auto" and not _batch_closed_form(robot, base, tip, family_tol=family_tol, lock=lock):
        closed = False  # a textbook arm's named solver answers one target per call: the batch is numerical
    if closed and method == "auto" and _snapped_6r(robot, base, tip, mode=mode, family_tol=family_tol, lock=lock,
                                                   arm_angle=arm_angle, free=()):
        return _snapped_many(robot, targets, base, tip, tol=tol, family_tol=family_tol)
    if closed:
        from manipkit.ik.textbook import analytic_ik_many

        return analytic_ik_many(robot, targets, base, tip, tol=tol, family_tol=family_tol, lock=lock,
                                arm_angle=arm_angle)
    from manipkit.ik.numerical_many import ik_many as numerical_many

    return numerical_many(robot, targets, base, tip, q0=q0, mode=mode, axis=axis, tol=tol, max_iters=max_iters,
                          restarts=restarts, seed=seed, damping=damping, time_budget=time_budget, threads=threads)
