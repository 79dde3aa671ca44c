"""Every isolated IK solution of a 6R chain with no closed-form family: :func:`general_ik`, and of a stack of
targets: :func:`general_ik_many`.

The chain (``robot.chain(base, tip)``: 6 revolute joints, Pieper or not:
the xArm6, a Kinova Jaco, a FANUC CRX) is read as its product of
exponentials at the reference configuration ``q0``
(:attr:`manipkit.ik.families.Family.geometry`: the axes in the base frame
and ``M = T_base_tip(q0)``); :mod:`manipkit.closed_form.general6r` gives
every isolated root of ``T M^-1 = E_1 ... E_6`` by the Raghavan-Roth
elimination, compiled (the ways of eliminating it ranked once per chain and kept; a batch's targets in blocks on
threads). Each root is then:

- mapped to joint values ``q = q0 + angle / scale`` and each joint to its
  alias ``q + 2 pi k`` inside the limits nearest 0, as the closed forms do
  (a joint spanning more than 2 pi has others: the note says so); a row
  outside the limits is kept and marked (``within_limits`` False);
- checked by the chain's own forward kinematics (its compiled FK, every row of every target at once); a row that
  misses by more than ``tol`` is moved by Newton steps on the chain
  (``refined`` says how far) and dropped if it still misses (``rejected``).

Near-double roots (two solutions merging at a singular configuration, where
other eigenvalue solvers lose them) are kept: the elimination takes nearly
real eigenvalues as candidates and the polishing decides. When the
elimination read base to tip is poorly conditioned at a target, it is solved
read tip to base too and the rows are merged. A batch gives each target the rows the single call gives it.

What ``result.method`` says: ``"algebraic"`` (:data:`ALGEBRAIC`), with
``arm_family`` ``"general 6R"``. Not ``"closed_form"``: the closed forms
give each branch by explicit formulas and name it (shoulder, elbow, wrist);
this answer comes from an eigenvalue problem, lists every isolated solution
without branch names, and a caller filtering on ``"closed_form"`` should not
take it for one. Not ``"numerical"``: it is complete (every isolated root),
which a search from starts is not.

A 7R chain with one joint locked (``lock={name: value}``, rad: a general 7R
arm such as the Sawyer, solved at one value of its redundancy) is the 6R
chain of the others: the locked joint's motion ``E_k`` at its value folds
into the geometry (:func:`locked_geometry`), rows are 7-joint chain vectors
with the locked joint at exactly its value, and Newton refinement moves the
other six only. What is kept across locked values: the 7R chain's axes
(:func:`~manipkit.ik.families.chain_family`, once), and the ranking of the
elimination's ways, found once per (chain, locked joint) at two generic
values of the joint (not its reference value, often special: the Panda's
joint 2 at 0 is a continuum) and reused for every value (the solve falls back
along it where a way is degenerate or poorly conditioned). Locking the last joint
folds it into ``M`` and the first into the target, so the six axes, and the
elimination prepared on them, are the same arrays at every value; a joint in
the middle moves the axes on one side of it, which the elimination prepares
again per value (under a millisecond).

Covered: chains of exactly 6 revolute joints (one axis each: no mimic
joints), or 7 with one locked. Prismatic joints are not covered (:class:`IKOptionError`; numerical
IK answers them). At a target where every elimination is degenerate (a
singular target, reached by a continuum) the rows are those numerical IK finds
from 50 starts (the note says completeness is not proven there), ``count``
infinite with the free joint named (the one moving most along the Jacobian's
null direction at a singular member); with no singular member, no rows and a
failure of kind ``"singular"``.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from manipkit.bounds import tolerances
from manipkit.closed_form.checks import quantity_text
from manipkit.closed_form.general6r import ranked_ways, solve_targets, way_reason
from manipkit.closed_form.newton_kernel import polish_targets
from manipkit.errors import ClosedFormIKError, IKOptionError
from manipkit.ik.aliases import measured_rows
from manipkit.ik.aliases_kernel import nearest_zero_into
from manipkit.ik.families import FAMILY_TOL, NONE, Geometry, chain_family
from manipkit.ik.result import SPATIAL_POSE, IKBatch, IKFailure, IKResult, read_only
from manipkit.kinematics.chain import limits_ok
from manipkit.spatial.transforms import check_transform, invert_transform, pose_residuals, projected_rotation

if TYPE_CHECKING:
    from manipkit.kinematics.chain import Chain

__all__ = ["ALGEBRAIC", "CHECK_TOL", "GENERAL_6R", "SLOTS", "general_ik", "general_ik_many", "general_refusal",
           "general_solves", "general_ways", "locked_geometry"]

#: ``IKResult.method`` of this solver's answers.
ALGEBRAIC = "algebraic"
#: ``IKResult.arm_family`` of this solver's answers, and the class ``manipkit family`` names.
GENERAL_6R = "general 6R"
#: Residual (m and rad) within which a row's forward kinematics must reach the target.
CHECK_TOL = 1e-10
TWO_PI = 2.0 * math.pi
#: below this conditioning of the base-to-tip elimination the tip-to-base one is solved too
_POOR = 1e-6


def general_refusal(chain: Chain, *, family_tol=FAMILY_TOL, lock=None) -> str:
    """``""`` when :func:`general_ik` takes ``chain`` (with ``lock``); else one line saying why not."""
    if not lock:
        return _unlocked(chain, family_tol)[1]
    return _refusal(chain, family_tol, dict(lock))


def _refusal(chain: Chain, family_tol, lock: dict) -> str:
    """:func:`general_refusal` of ``chain`` with ``lock`` (a dict, empty for none)."""
    names = ", ".join(chain.joint_names) or "no joints"
    if lock and (chain.n != 7 or len(lock) != 1):
        return (f"the general 6R solver does not take lock= here: it holds exactly one joint of a 7-joint chain; "
                f"{chain.base} -> {chain.tip} has {chain.n} joint(s) ({names}) and {len(lock)} locked")
    if not lock and chain.n != 6:
        ways = "choose frames with 6 joints between them, " + ("lock one of the 7 (lock=), " if chain.n == 7 else "")
        return (f"the general 6R solver takes a chain of 6 joints; {chain.base} -> {chain.tip} has {chain.n} "
                f"({names}): {ways}or use numerical IK")
    unknown = [name for name in lock if name not in chain.joint_names]
    if unknown:
        return (f"cannot lock '{unknown[0]}': it is not a joint of the chain {chain.base} -> {chain.tip} ({names})")
    try:  # the unlocked chain's axes (read once per chain): which joints are prismatic does not depend on a value
        family = chain_family(chain, tol=family_tol)
    except ClosedFormIKError as exc:
        return f"the general 6R solver cannot read the chain {chain.base} -> {chain.tip}: {exc}"
    if lock:
        value = next(iter(lock.values()))
        if not isinstance(value, (int, float, np.floating, np.integer)) or not math.isfinite(float(value)):
            return f"cannot lock '{next(iter(lock))}' at {value!r:.40}: give a finite value (rad)"
    if family.geometry.prismatic.any():
        prismatic = [chain.joint_names[int(c)] for c, p in zip(family.geometry.columns, family.geometry.prismatic)
                     if p]
        return (f"the general 6R solver covers revolute joints; {', '.join(prismatic)} "
                f"{'is' if len(prismatic) == 1 else 'are'} prismatic (not covered): use numerical IK")
    return ""


def general_solves(chain: Chain, *, family_tol=FAMILY_TOL, lock=None) -> bool:
    """Whether ``method="auto"`` answers ``chain`` with :func:`general_ik`: 6 revolute joints (or 7 with one
    locked) and no closed-form family within ``family_tol`` (a chain with one gets its closed form)."""
    if chain.n != (7 if lock else 6) or general_refusal(chain, family_tol=family_tol, lock=lock):
        return False
    return chain_family(chain, tol=family_tol, lock=lock or None).kind == NONE


def general_ways(chain: Chain, *, family_tol=FAMILY_TOL) -> tuple[tuple[int, bool], ...]:
    """The ways ``(shift, reversed)`` the chain's loop eliminates regularly, best first
    (:func:`manipkit.closed_form.general6r.ranked_ways`: tried once per chain's axes and kept); ``()`` for a chain
    the solver refuses (:func:`general_refusal`)."""
    return _unlocked(chain, family_tol)[3] or ()


def _unlocked(chain: Chain, family_tol) -> tuple:
    """(chain, its refusal without a lock, geometry, ways, ``M^-1``), made once per (chain, ``family_tol``) and
    kept (the geometry and ways None where the chain is refused): what every call on the chain reads again."""
    key = (id(chain), repr(family_tol))
    cached = _UNLOCKED.get(key)
    if cached is not None and cached[0] is chain:
        return cached
    refusal = _refusal(chain, family_tol, {})
    entry = (chain, refusal, None, None, None)
    if not refusal:
        geometry = chain_family(chain, tol=family_tol).geometry
        ways = ranked_ways(geometry.direction, geometry.point)
        entry = (chain, refusal, geometry, ways, invert_transform(geometry.M, check=False))
    if len(_UNLOCKED) >= 64:
        _UNLOCKED.pop(next(iter(_UNLOCKED)), None)
    _UNLOCKED[key] = entry  # the chain is held, so its id is not reused while the entry lives
    return entry


#: (id(chain), repr(family_tol)) -> :func:`_unlocked`'s entry.
_UNLOCKED: dict = {}


def locked_geometry(chain: Chain, name: str, value: float, *, family_tol=FAMILY_TOL) -> tuple[Geometry, np.ndarray]:
    """(the 6R geometry, ``L``) of the 7R ``chain`` with joint ``name`` locked at ``value`` (rad):
    ``T_base_tip = L E'_1 ... E'_6 M'`` with the six other joints' axes and ``M'`` of the returned geometry.

    With ``E_k`` the locked joint's motion at its value in the 7R product ``T = E_1 ... E_7 M`` (axes at the
    reference configuration ``q0``): for a joint in the first half, ``E_1 ... E_k = E_k (E_k^-1 E_1 E_k) ...``,
    so ``L = E_k`` and the axes before it are moved by ``E_k^-1``; otherwise ``... E_k ... E_7 = ... (E_k E_j
    E_k^-1) ... E_k``, so ``L = I``, the axes after it are moved by ``E_k`` and ``M' = E_k M``. The first and the
    last joint move no axis. ``q0`` of the geometry holds ``value`` in the locked column.
    """
    from manipkit.closed_form.general6r import poe_fk

    base = chain_family(chain, tol=family_tol).geometry
    column = chain.joint_names.index(name)
    k = int(np.flatnonzero(base.columns == column)[0])
    angle = float(base.scale[k]) * (float(value) - float(base.q0[column]))
    E = poe_fk(base.direction[k:k + 1], base.point[k:k + 1], np.array([angle]))
    h, p = base.direction.copy(), base.point.copy()
    L, M = np.eye(4), base.M
    side = np.arange(k) if k < 3 else np.arange(k + 1, len(h))
    move = invert_transform(E, check=False) if k < 3 else E
    if len(side):
        h[side] = h[side] @ move[:3, :3].T
        p[side] = p[side] @ move[:3, :3].T + move[:3, 3]
    if k < 3:
        L = E
    else:
        M = E @ base.M
    keep = np.array([i for i in range(len(h)) if i != k], dtype=np.intp)
    q0 = base.q0.copy()
    q0[column] = float(value)
    geometry = Geometry(h[keep], p[keep], base.scale[keep], base.prismatic[keep], q0, M, base.columns[keep])
    return geometry, L


def _locked_ways(chain: Chain, name: str, family_tol) -> tuple:
    """The ways of the 7R ``chain`` with ``name`` locked, ranked once and kept: those that eliminate the 6R arm at
    two generic values of the joint (:data:`_GENERIC` of its range, or of a radian from its reference value when
    unbounded), in the order found at the first, then those that work at one of them.

    Not at the reference value: it is often special (the Panda's joint 2 at 0 puts joints 1 and 3 on one line, a
    continuum, where no way is regular, although every other value of it has isolated solutions)."""
    key = (id(chain), name, repr(family_tol))
    cached = _LOCKED_WAYS.get(key)
    if cached is not None and cached[0] is chain:
        return cached[1]
    column = chain.joint_names.index(name)
    lower, upper = float(chain.lower[column]), float(chain.upper[column])
    reference = float(chain_family(chain, tol=family_tol).geometry.q0[column])
    bounded = math.isfinite(lower) and math.isfinite(upper) and upper > lower
    found = []
    for fraction in _GENERIC:
        value = lower + fraction * (upper - lower) if bounded else reference + fraction
        geometry, _ = locked_geometry(chain, name, value, family_tol=family_tol)
        found.append(ranked_ways(geometry.direction, geometry.point))
    both = [way for way in found[0] if way in found[1]]
    ways = tuple(dict.fromkeys(both + list(found[0]) + list(found[1])))  # at both values first, then at one
    if len(_LOCKED_WAYS) >= 64:
        _LOCKED_WAYS.pop(next(iter(_LOCKED_WAYS)), None)
    _LOCKED_WAYS[key] = (chain, ways)  # the chain is held, so its id is not reused while the entry lives
    return ways


#: (id(chain), locked joint, family_tol) -> (chain, its ranked ways).
_LOCKED_WAYS: dict = {}
#: Where in a locked joint's range its ways are ranked (the golden section: no symmetric or round value).
_GENERIC = (0.381966, 0.618034)


def _eliminated(geometry, ways: tuple, g: np.ndarray, threads: int) -> tuple:
    """(angles (N, 24 W, 6) in chain order, rows written (N,), status (N, W, 4)) of targets ``g = T M^-1``
    (N, 4, 4): the best way, and the next ones while the elimination is poorly conditioned (their rows appended),
    compiled (:func:`manipkit.closed_form.general6r.solve_targets`)."""
    rows, _, count, status = solve_targets(geometry.direction, geometry.point, g, ways, tol=1e-8, poor=_POOR,
                                           threads=threads)
    return rows, count, status


def _reasons(status: np.ndarray) -> list[str]:
    """Why each way that failed at one target failed (its status rows (W, 4))."""
    return [way_reason(row) for row in status if row[0] > 0]


#: The whole turns tried by :func:`_nearest_zero_alias`, nearest 0 first.
_TURNS = np.array([0.0, 1.0, -1.0, 2.0, -2.0, 3.0, -3.0])


def _nearest_zero_alias(Q: np.ndarray, chain: Chain) -> np.ndarray:
    """Each angle of rows Q (k, n) moved by whole turns (:data:`_TURNS`, in order) to its first value inside the
    chain's limits (within ``LIMIT_TOLERANCE``), wrapped to (-pi, pi] when no alias is inside: a new array, compiled
    (:func:`manipkit.ik.aliases_kernel.nearest_zero_into`)."""
    Q = np.array(Q, dtype=float, order="C")
    low, high = limits_ok(chain.lower, chain.upper)
    nearest_zero_into()(Q, np.arange(Q.shape[1]), low, high, _TURNS)
    return Q


def _distinct(rows: list[np.ndarray], q: np.ndarray) -> bool:
    """``q`` differs from every row (modulo 2 pi) by more than 1e-9 in some joint."""
    if not rows:
        return True
    gap = np.abs(np.pi - np.mod(np.pi - (q - np.asarray(rows)), TWO_PI))
    return bool(np.all(gap.max(axis=1) > 1e-9))


def _singular_family(chain: Chain, T: np.ndarray, check: tuple[float, float], reasons: list[str]) -> IKResult | None:
    """The answer at a target where every elimination is degenerate: the distinct solutions numerical IK finds from
    50 starts, those at a singular configuration standing for a one-parameter family (``count`` inf, the free joint
    named as the one moving most along the Jacobian's null direction); None when none is singular (then the
    degeneracy is no continuum, and the failure says so)."""
    from manipkit.ik.numerical import ik as numerical_ik

    found = numerical_ik(chain.robot, T, chain.base, chain.tip, tol=check, restarts=50, all=True)
    rows = np.asarray(found.solutions, dtype=float)[:, chain.columns]
    names = tuple(chain.joint_names)
    free, texts = [], []
    for q in rows:
        _, sigma, Vt = np.linalg.svd(chain.jacobian(q))
        if sigma[-1] > 1e-6 * sigma[0]:
            continue
        direction = Vt[-1] / np.max(np.abs(Vt[-1]))
        free.append(int(np.argmax(np.abs(direction))))
        texts.append(", ".join(f"{names[i]} {direction[i]:+.3g}" for i in np.flatnonzero(np.abs(direction) > 1e-6)))
    if not free:
        return None
    free_joints = tuple(sorted(set(free)))
    words = (f"singular target: {len(rows)} solution(s) found by numerical IK from 50 starts (the elimination is "
             f"degenerate every way: {reasons[0]}; completeness not proven), {len(free)} of them on a one-parameter "
             f"family moving along the Jacobian's null direction ({texts[0]}), {names[free[0]]} most")
    position, rotation = (np.atleast_1d(e) for e in pose_residuals(T, chain.fk(rows), project=False))
    within = np.asarray(chain.within_limits(rows), dtype=bool).reshape(-1)
    within.setflags(write=False)
    return IKResult(read_only(rows), ("",) * len(rows), math.inf, words, read_only(position), read_only(rotation),
                    mode=SPATIAL_POSE, solver="ik.general6r", joint_names=names,
                    free_parameter=", ".join(names[j] for j in free_joints),
                    family=f"{names[free[0]]} free with the others along the null direction ({texts[0]})",
                    free_joints=free_joints, within_limits=within, refined=read_only(np.zeros(len(rows))),
                    method=ALGEBRAIC, arm_family=GENERAL_6R, iterations=found.iterations, attempts=found.attempts)


def general_ik(chain: Chain, target, *, tol=CHECK_TOL, family_tol=FAMILY_TOL, max_iters: int = 20,
               lock=None) -> IKResult:
    """Every isolated IK solution of a 6R ``chain`` (or a 7R one with a joint locked) for ``T_base_tip = target``,
    by algebraic elimination.

    Parameters
    ----------
    chain : manipkit.kinematics.chain.Chain
        ``robot.chain(base, tip)`` with 6 revolute joints, or 7 with ``lock``.
    target : array_like, shape (4, 4)
        ``T_base_tip`` (metres).
    tol : float or (float, float), keyword-only
        Residual (m, rad) every row's forward kinematics must reach; rows missing by more than this or
        :data:`CHECK_TOL` are refined by Newton steps on the chain, and dropped if they still miss ``tol``.
    family_tol : float or (float, float), keyword-only
        The tolerance the chain's axes are read with (:func:`~manipkit.ik.families.chain_family`).
    max_iters : int, keyword-only
        Newton steps at most per refined row.
    lock : dict of str to float, keyword-only
        On a 7R chain, the one joint held and its value (rad): the 6R chain of the others is solved
        (:func:`locked_geometry`); every row holds the locked joint at exactly this value.

    Returns
    -------
    IKResult
        ``method`` ``"algebraic"``, ``arm_family`` ``"general 6R"``; rows are chain vectors in
        ``chain.joint_names`` order, pairwise distinct modulo 2 pi, sorted; ``within_limits`` and ``refined``
        per row; ``count`` the rows (every isolated solution). Where the elimination is degenerate every way (a
        singular target): the solutions numerical IK finds from 50 starts, ``count`` inf when some lie on a
        one-parameter family (``free_parameter`` the joint moving most along it); ``failure`` of kind
        ``"singular"`` when none does, else ``"unreachable"`` when no root reaches the target.

    Raises
    ------
    IKOptionError
        The chain is not 6 revolute joints, or 7 with one locked (the message says what it has).
    InvalidTransformError
        ``target`` is not a 4x4 homogeneous transform.

    Examples
    --------
    >>> import manipkit, numpy as np
    >>> robot = manipkit.load("ur5")  # a closed-form arm, solved here by the elimination for the example
    >>> chain = robot.chain("base_link", "tool0")
    >>> every = general_ik(chain, chain.fk([0.1, -1.0, 1.2, -0.3, 1.0, 0.5]))
    >>> every.method, every.arm_family, len(every.solutions), bool(every.residual_position.max() < 1e-10)
    ('algebraic', 'general 6R', 8, True)
    """
    refusal = general_refusal(chain, family_tol=family_tol, lock=lock)
    if refusal:
        raise IKOptionError(refusal)
    check = tolerances(tol, error=IKOptionError, what="tol")
    T = check_transform(target, what="IK target")
    T_check = np.array(T, dtype=float)
    T_check[:3, :3] = projected_rotation(T_check[:3, :3])
    geometry, ways, held, g = _setup(chain, T_check[None], lock, family_tol)
    theta, count, status = _eliminated(geometry, ways, g, 1)
    checked = _checked_rows(chain, geometry, T_check[None], g, theta, count, status, held, check, max_iters)
    return _answer(chain, T_check, checked, 0, status[0], ways, held, check, geometry.columns)


def _setup(chain: Chain, T_check: np.ndarray, lock, family_tol) -> tuple:
    """(geometry, ways, held (column, value) or None, ``g = L^-1 T M^-1`` (N, 4, 4)) of targets ``T_check``."""
    held = None  # (column, value) of a locked joint
    if lock:
        (name, value), = dict(lock).items()
        held = (chain.joint_names.index(name), float(value))
        geometry, L = locked_geometry(chain, name, held[1], family_tol=family_tol)
        ways = _locked_ways(chain, name, family_tol)
        g = invert_transform(L, check=False) @ T_check @ invert_transform(geometry.M, check=False)
    else:
        _, _, geometry, ways, M_inv = _unlocked(chain, family_tol)
        g = T_check @ M_inv
    return geometry, ways, held, np.ascontiguousarray(g)


def _checked_rows(chain: Chain, geometry, T_check: np.ndarray, g: np.ndarray, theta: np.ndarray, count: np.ndarray,
                  status: np.ndarray, held, check: tuple[float, float], max_iters: int) -> tuple:
    """The elimination's angles of targets ``T_check`` (N, 4, 4) as checked chain rows: (rows (M, n) sorted by
    target then joint values, ``start`` (N + 1,) where each target's rows begin, residuals (M, 2), refined (M,),
    within the limits (M,), rejected (N,), worst miss of the rejected (N,)).

    Each row: ``q = q0 + angle / scale``, each joint at its in-limit alias nearest 0, the locked joint at its
    value; measured by the chain's FK; one that misses by more than ``tol`` or :data:`CHECK_TOL` is refined by
    Newton steps on the chain (the one polisher, :func:`manipkit.closed_form.newton_kernel.polish_targets`, on the
    chain's own axes towards its ``g = L^-1 T M^-1``) and dropped if it still misses ``check``; a row equal (1e-9,
    modulo 2 pi) to an earlier one of its target is that one. All targets' rows go through one FK call."""
    n_targets, n = len(T_check), chain.n
    owner = np.repeat(np.arange(n_targets), count)
    angles = theta[np.arange(theta.shape[1])[None, :] < count[:, None]]  # (M, 6) in target order
    columns = geometry.columns
    Q = np.empty((len(angles), n))
    Q[:] = geometry.q0
    Q[:, columns] = geometry.q0[columns] + angles / geometry.scale
    Q = _nearest_zero_alias(Q, chain)
    if held is not None:
        Q[:, held[0]] = held[1]  # the locked joint at exactly its value, not an alias
    refined = np.zeros(len(Q))
    position, rotation = measured_rows(chain, T_check, Q, owner)
    polish = (min(check[0], CHECK_TOL), min(check[1], CHECK_TOL))  # rows are refined to this, dropped beyond check
    missing = np.flatnonzero((position > polish[0]) | (rotation > polish[1]))
    if len(missing):
        begun = geometry.scale * (Q[missing][:, columns] - geometry.q0[columns])  # the angles of the product
        moved, _, _ = polish_targets(geometry.direction, geometry.point, g[owner[missing]], begun,
                                     iterations=max_iters, far=math.inf, stop=min(0.1 * min(check), 1e-12))
        step = (np.pi - np.mod(np.pi - (moved - begun), TWO_PI)) / geometry.scale  # each joint's move, unwrapped
        refined[missing] = np.abs(step).max(axis=1)
        better = Q[missing]
        better[:, columns] += step
        better = _nearest_zero_alias(better, chain)
        if held is not None:
            better[:, held[0]] = held[1]
        Q[missing] = better
        position[missing], rotation[missing] = measured_rows(chain, T_check, better, owner[missing])
    keep = (position <= check[0]) & (rotation <= check[1])
    rejected, worst = np.zeros(n_targets, dtype=np.intp), np.zeros(n_targets)
    if not keep.all():
        rejected = np.bincount(owner[~keep], minlength=n_targets)
        np.maximum.at(worst, owner[~keep], np.maximum(position, rotation)[~keep])
    # each way's rows are distinct (1e-7 rad); rows of two ways, or a refined row, may repeat an earlier row
    again = (status[:, :, 0] == 0).sum(axis=1) > 1
    if refined.any():
        again |= np.bincount(owner[refined > 0], minlength=n_targets) > 0
    for t in np.flatnonzero(again):
        mine = np.flatnonzero((owner == t) & keep)
        gap = np.abs(np.pi - np.mod(np.pi - (Q[mine][:, None, :] - Q[mine][None, :, :]), TWO_PI)).max(axis=2)
        kept: list[int] = []
        for i in range(len(mine)):
            if all(gap[i, j] > 1e-9 for j in kept):
                kept.append(i)
            else:
                keep[mine[i]] = False
    order = np.lexsort((*Q.T[::-1], owner))
    order = order[keep[order]]
    start = np.searchsorted(owner[order], np.arange(n_targets + 1))
    Q = Q[order]
    low, high = limits_ok(chain.lower, chain.upper)  # as chain.within_limits tests them
    within = ((Q >= low) & (Q <= high)).all(axis=1)
    return (Q, start, np.stack([position[order], rotation[order]], axis=1), refined[order], within, rejected, worst)


def _answer(chain: Chain, T_check: np.ndarray, checked: tuple, t: int, status: np.ndarray, ways: tuple, held,
            check: tuple[float, float], columns: np.ndarray) -> IKResult:
    """The IKResult of target ``t`` (``T_check`` its pose) of :func:`_checked_rows`' ``checked`` (its ways'
    ``status`` (W, 4); ``columns`` the solved joints' columns)."""
    # Over 80 lines: the parts of one honest answer (rows, limits, note, failure) in order.
    rows, start, residuals, refined_all, within_all, rejected_all, worst_all = checked
    a, b = int(start[t]), int(start[t + 1])
    Q, residual, refined = rows[a:b], residuals[a:b], refined_all[a:b]
    rejected, worst = int(rejected_all[t]), float(worst_all[t])
    reasons = _reasons(status)
    candidates = int(status[status[:, 0] == 0, 2].sum())
    n = chain.n
    within = within_all[a:b]
    parts = [f"{len(Q)} solution(s) of the general 6R elimination (every isolated solution; "
             f"{candidates} real eigenvalue candidate(s))"]
    if len(Q) and not within.all():
        parts.append(f"{int((~within).sum())} outside the joint limits (marked, not dropped)")
    if (refined > 0).any():
        parts.append(f"refined by Newton on the chain (largest step {quantity_text(float(refined.max()))})")
    span = chain.upper[columns] - chain.lower[columns]
    wide = [chain.joint_names[c] for c in columns[chain.aliasable[columns] & (span > TWO_PI + 1e-9)].tolist()]
    if wide and len(Q):
        parts.append(f"{', '.join(wide)} span more than 2 pi: each also has the alias q +- 2 pi where inside its limits")
    if rejected:
        parts.append(f"{rejected} root(s) dropped: after refinement FK missed by up to {worst:.3g} (m or rad), "
                     f"beyond tol ({check[0]:.3g} m, {check[1]:.3g} rad)")
    failure = None
    if held is not None:
        parts[0] += f" with {chain.joint_names[held[0]]} locked at {held[1]:.6g} rad"
    if not len(Q) and not candidates and len(reasons) == len(ways) and held is None:
        family = _singular_family(chain, T_check, check, reasons)
        if family is not None:
            return family
    if not len(Q):
        if not candidates and len(reasons) == len(ways):
            why = reasons[0] if reasons else "no way of eliminating this arm's loop is regular"
            words = (f"no solution listed: the elimination is degenerate every way ({why}); the target is "
                     "reached by a continuum of solutions or the arm is special; numerical IK finds members")
            failure = IKFailure("singular", words)
        else:
            words = (f"no solution: none of the {candidates} real root(s) of the elimination reaches the target "
                     "(out of reach, or an orientation the arm cannot take there)")
            failure = IKFailure("unreachable", words)
        parts = [words] + parts[1:]
    if len(Q) and failure is None:  # fresh arrays of this call: read-only as they are, without the constructor's copies
        arrays = [Q.copy(), residual[:, 0].copy(), residual[:, 1].copy(), within.copy(), refined.copy()]
        for array in arrays:
            array.setflags(write=False)
        return IKResult.of_checked_rows(arrays[0], ("",) * len(Q), "; ".join(parts), *arrays[1:], mode=SPATIAL_POSE,
                                        solver="ik.general6r", joint_names=tuple(chain.joint_names),
                                        arm_family=GENERAL_6R, method=ALGEBRAIC, rejected=rejected)
    Q = np.array(Q, dtype=float).reshape(-1, n)
    return IKResult(read_only(Q, (n,)), ("",) * len(Q), len(Q), "; ".join(parts), read_only(residual[:, 0].copy()),
                    read_only(residual[:, 1].copy()), mode=SPATIAL_POSE, solver="ik.general6r",
                    joint_names=tuple(chain.joint_names), rejected=rejected, within_limits=within,
                    refined=read_only(np.array(refined, dtype=float)), method=ALGEBRAIC, arm_family=GENERAL_6R,
                    failure=failure)


#: Slots of :func:`general_ik_many`'s batch: a 6R arm has at most 16 isolated solutions (more where a target has
#: more rows, joints spanning more than a turn aside: the batch lists no 2 pi aliases).
SLOTS = 16


def general_ik_many(chain: Chain, targets, *, tol=CHECK_TOL, family_tol=FAMILY_TOL, max_iters: int = 20,
                    threads=None) -> IKBatch:
    """:func:`general_ik` for a stack of targets ``T_base_tip`` (N, 4, 4): every isolated solution of each, compiled
    over the targets in blocks on up to ``threads`` threads (None: the cores this process may use).

    Each target's rows are those of ``general_ik(chain, target)`` (the same numbers: the same compiled elimination
    of that target alone and the same checks, all targets' rows through one FK call), in slots ``0 .. k-1`` of
    :data:`SLOTS` (more when a target has more), NaN after; ``count`` inf where a target is reached by a
    continuum (those targets are answered by :func:`general_ik` itself, numerical IK from 50 starts).

    Examples
    --------
    >>> import manipkit
    >>> chain = manipkit.load("ur5").chain("base_link", "tool0")  # a closed-form arm, solved by the elimination here
    >>> batch = general_ik_many(chain, chain.fk(chain.sample(3, seed=1)))
    >>> batch.method, batch.solutions.shape[0], batch.count.tolist(), bool(batch.success.all())  # as the closed form
    ('algebraic', 3, [8.0, 6.0, 4.0], True)
    """
    from manipkit.ik.textbook import checked_targets
    from manipkit.kernels import thread_count

    refusal = general_refusal(chain, family_tol=family_tol)
    if refusal:
        raise IKOptionError(refusal)
    check = tolerances(tol, error=IKOptionError, what="tol")
    T = checked_targets(targets)
    shape = T.shape[:-2]
    flat = T.reshape(-1, 4, 4)
    T_check = np.array(flat, dtype=float)
    T_check[:, :3, :3] = projected_rotation(flat[:, :3, :3])
    for i in np.flatnonzero(np.any(T_check[:, :3, :3] != flat[:, :3, :3], axis=(1, 2))):
        T_check[i] = check_transform(flat[i], what=f"IK target {i}")  # not a rotation to 1e-12: checked, projected
        T_check[i, :3, :3] = projected_rotation(T_check[i, :3, :3])
    geometry, ways, held, g = _setup(chain, T_check, None, family_tol)
    theta, count, status = _eliminated(geometry, ways, g, thread_count(threads))
    rows, start, residuals, _, _, _, _ = _checked_rows(chain, geometry, T_check, g, theta, count, status, held, check,
                                                    max_iters)
    per = np.diff(start)
    answers: dict[int, IKResult] = {}
    for t in np.flatnonzero(per == 0):  # no row: a degenerate target is a family (or a failure) of general_ik's
        if not (status[t, :, 0] == 0).any() and (status[t, :, 0] > 0).sum() == len(ways):
            answers[t] = general_ik(chain, flat[t], tol=tol, family_tol=family_tol, max_iters=max_iters)
    k = max([SLOTS, int(per.max(initial=0)), *(len(a.solutions) for a in answers.values())])
    n_targets, n = len(flat), chain.n
    Q, position, rotation = np.full((n_targets, k, n), np.nan), np.full((n_targets, k), np.nan), np.full(
        (n_targets, k), np.nan)
    slot = np.arange(len(rows)) - np.repeat(start[:-1], per)
    owner = np.repeat(np.arange(n_targets), per)
    Q[owner, slot], position[owner, slot], rotation[owner, slot] = rows, residuals[:, 0], residuals[:, 1]
    counts = per.astype(float)
    kinds = np.where(per > 0, "", "unreachable").astype(object)
    for t, answer in answers.items():
        m = len(answer.solutions)
        Q[t, :m], position[t, :m], rotation[t, :m] = (answer.solutions, answer.residual_position,
                                                      answer.residual_rotation)
        counts[t] = answer.count
        kinds[t] = answer.failure.kind if answer.failure is not None else ""
    success = np.any((position <= check[0]) & (rotation <= check[1]), axis=1)
    q_residuals = np.stack([position[:, 0], rotation[:, 0]], axis=-1)
    return IKBatch(Q.reshape(*shape, k, n), counts.reshape(shape), labels=tuple(f"row {j + 1}" for j in range(k)),
                   mode=SPATIAL_POSE, solver="ik.general6r", joint_names=tuple(chain.joint_names),
                   success=success.reshape(shape), residual_position=position.reshape(*shape, k),
                   residual_rotation=rotation.reshape(*shape, k), q_residuals=q_residuals.reshape(*shape, 2),
                   method=ALGEBRAIC, failure_kinds=np.asarray(kinds, dtype=str).reshape(shape))
