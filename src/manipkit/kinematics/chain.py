"""The joints between a base frame and a tip frame: one immutable object every solver and analysis takes.

``robot.chain(base, tip)`` returns a :class:`Chain` (built once per frame pair
and cached on the robot). Conventions (docs/architecture.md), restated:

- Frames come in the order of ``tf-between SOURCE TARGET``: the base first,
  then the tip. ``chain.fk(Q)`` is ``T_base_tip``, the pose of the tip
  expressed in the base (4x4, metres), as ``robot.transform(base, tip, q)``.
- A *chain vector* has one value per entry of :attr:`Chain.joint_names`
  (rad for revolute and continuous joints, m for prismatic ones): the
  independent joints that move the tip relative to the base, base to tip (a
  mimic joint on the way contributes its leader; a floating or planar joint
  its coordinates, ``base_joint.x`` ...). Every method that takes joint
  values also takes a whole-robot vector (``robot.joint_names`` order) or
  names, and reads the chain's entries from it (:meth:`Chain.q`).
- Jacobian rows are ``vx vy vz wx wy wz`` (the velocity of the tip's origin,
  then its angular velocity); columns follow :attr:`Chain.joint_names`.
  ``reference="base"``: the base's axes (RTB ``jacob0``); ``"local"``: the
  tip's axes (RTB ``jacobe``).

Nothing in a chain changes after it is built: its arrays are read-only and
its compiled programs keep their scratch memory per thread, so one chain may
be used by several threads at once.

Examples
--------
>>> import manipkit
>>> robot = manipkit.load("planar_2r")
>>> chain = robot.chain("base_link", "ee_link")
>>> chain.joint_names
('joint1', 'joint2')
>>> chain.fk([0.0, 0.0])[:3, 3]
array([2., 0., 0.])
>>> chain is robot.chain("base_link", "ee_link")
True
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from manipkit.bounds import MAX_COUNT, count
from manipkit.errors import ChainError, JointLimitError, JointValueError, OptionError
from manipkit.kernels.fk import ChainFK, ChainStep
from manipkit.spatial.rotations import matrix_from_axis_angle
from manipkit.text import repr_text

if TYPE_CHECKING:
    from manipkit.kinematics.robot import Robot

__all__ = ["Chain", "JointAxes", "LIMIT_TOLERANCE", "REFERENCES", "chain_columns", "chain_of", "limits_ok", "chain_steps", "robot_and_frames", "sample_between", "sampling_bounds", "joint_array"]

#: A joint value this far outside its limit still counts as inside (printed values round-trip).
LIMIT_TOLERANCE = 1e-12
REFERENCES = ("base", "local")


@dataclass(frozen=True, eq=False)
class JointAxes:
    """Every joint axis of a chain at one configuration, in the base frame's axes (read-only arrays).

    One row per joint *step* of the chain, base to tip (a mimic joint on the
    way has its own row; ``joint`` says which chain entry drives it).

    Attributes
    ----------
    joint : ndarray of int, shape (m,)
        The entry of :attr:`Chain.joint_names` that moves the step.
    direction : ndarray, shape (m, 3)
        The unit axis (turned about for a revolute joint, slid along for a
        prismatic one), in the base frame.
    point : ndarray, shape (m, 3)
        A point on the axis (m), in the base frame: the joint frame's origin.
    prismatic : ndarray of bool, shape (m,)
    scale : ndarray, shape (m,)
        The step moves by ``scale`` times its chain entry (1, or a mimic's multiplier).
    """

    joint: np.ndarray
    direction: np.ndarray
    point: np.ndarray
    prismatic: np.ndarray
    scale: np.ndarray


def limits_ok(lower, upper) -> tuple[np.ndarray, np.ndarray]:
    """(lower, upper) widened by :data:`LIMIT_TOLERANCE`: what :class:`JointSpace` tests values against."""
    return np.asarray(lower, dtype=float) - LIMIT_TOLERANCE, np.asarray(upper, dtype=float) + LIMIT_TOLERANCE


class JointSpace:
    """The joint-space API, defined once for a :class:`manipkit.kinematics.robot.Robot` (whole-robot vectors,
    :attr:`Robot.joint_names <manipkit.kinematics.robot.Robot.joint_names>` order) and a :class:`Chain` (chain
    vectors): limits, the test against them, clamping, sampling.

    A class using it has ``joints``, ``lower``, ``upper`` (rad or m; infinite
    for a continuous joint) and the validators ``q`` (one vector, checked)
    and ``rows`` (many, checked), ``_limits_ok`` (the limits widened by
    :data:`LIMIT_TOLERANCE`, made once: :func:`limits_ok`), and ``_checked`` (``q`` without a copy
    where the input is already a vector). A value counts as inside its limits up to
    :data:`LIMIT_TOLERANCE` beyond them (printed values round-trip).

    Examples
    --------
    >>> import manipkit
    >>> robot = manipkit.load("iiwa14")
    >>> q = robot.q(iiwa_joint_2=2.5)  # joint 2 is limited to +-120 deg (2.0944 rad)
    >>> robot.outside_limits(q).nonzero()[0].tolist(), bool(robot.within_limits(robot.clamp(q)))
    ([1], True)
    >>> chain = robot.chain("base_link", "ee_link")
    >>> chain.outside_limits(q[chain.columns]).nonzero()[0].tolist()
    [1]
    """

    __slots__ = ()

    def outside_limits(self, Q) -> np.ndarray:
        """Boolean (..., n): which entries of the vectors ``Q`` lie outside their limits (by more than 1e-12)."""
        Q = self.rows(Q)
        lower_ok, upper_ok = self._limits_ok
        return (Q < lower_ok) | (Q > upper_ok)

    def within_limits(self, Q) -> np.ndarray:
        """Boolean (...,): every entry of each vector inside its limits (continuous joints always are)."""
        return ~self.outside_limits(Q).any(axis=-1)

    def limit_violations(self, q) -> list[JointLimitError]:
        """One :class:`JointLimitError` per entry of the vector ``q`` outside its limits, in order (not raised)."""
        q = self.q(q)
        return [JointLimitError(j.name, float(q[k]), j.lower, j.upper, "rad" if j.is_angular else "m")
                for k in np.flatnonzero(self.outside_limits(q)) for j in (self.joints[k],)]

    def check_limits(self, q) -> np.ndarray:
        """The vector of ``q`` (checked by ``q``) when inside the limits, else the :class:`JointLimitError` of the first
        entry outside (its name, value and limits)."""
        q = self._checked(q)
        lower_ok, upper_ok = self._limits_ok
        if ((q < lower_ok) | (q > upper_ok)).any():  # the common case, all inside, in two comparisons
            raise self.limit_violations(q)[0]
        return q

    def clamp(self, Q) -> np.ndarray:
        """The vectors ``Q`` moved to the nearest values inside the limits (a copy)."""
        return np.minimum(np.maximum(self.rows(Q), self.lower), self.upper)

    def sample(self, n: int, *, seed=0) -> np.ndarray:
        """``n`` vectors drawn uniformly inside the limits (continuous joints: [-pi, pi]), shape (n, len(joints)).

        Reproducible: the same ``seed`` (an int or a sequence of ints, as
        ``numpy.random.default_rng`` takes) gives the same rows.
        """
        return sample_between(*sampling_bounds(self.lower, self.upper), n, seed)


class Chain(JointSpace):
    """The independent joints that move ``tip`` relative to ``base``, with their limits and compiled kinematics.

    Build it with :meth:`manipkit.kinematics.robot.Robot.chain` (``robot.chain(base, tip)``);
    the same call returns the same object. Immutable: assigning an attribute
    raises ``AttributeError``.

    Attributes
    ----------
    robot : Robot
    base, tip : str
        Link names (aliases resolved: ``base_link``, ``ee_link``).
    joint_names : tuple of str
        The chain's entries, base to tip (a mimic joint's leader where the
        first joint it drives sits on the way; usually the robot's joint order).
    joints : tuple of Joint
        Their descriptions (type, axis, limits).
    columns : ndarray of int, shape (n,)
        Where each entry sits in a whole-robot vector (``robot.joint_names``).
    lower, upper : ndarray, shape (n,)
        Joint limits (rad or m; infinite for a continuous joint).
    aliasable : ndarray of bool, shape (n,)
        The revolute joints with finite limits (not continuous, not a coordinate of a floating or planar
        joint): ``q`` and ``q + 2 pi k`` place every link alike and may both be inside the limits (the
        entries :mod:`manipkit.ik.aliases` moves by whole turns).
    steps : tuple of ChainStep
        ``T_base_tip = S_0 S_1 ... S_m``; a joint step's ``index`` is its
        column of the *robot's* joint vector, as in
        :class:`manipkit.kernels.fk.ChainStep`. From a base on another
        branch than the tip, the steps go up from the base to the link where
        the two branches meet (each joint on the way inverted: its motion
        undone, ``scale`` and ``offset`` negated, then its placement), then
        down to the tip.
    program : manipkit.kernels.program.ChainProgram
        The chain's one compiled program (the same steps on chain vectors):
        FK, Jacobians, the IK packing and the closed forms' row tables all
        run on it.
    """

    __slots__ = ("robot", "base", "tip", "joint_names", "joints", "columns", "lower", "upper", "steps",
                 "program", "aliasable", "_angular", "_continuous", "_limits_ok")

    def __init__(self, robot: Robot, base: str, tip: str, steps: tuple[ChainStep, ...]):
        columns = list(dict.fromkeys(step.index for step in steps if step.index >= 0))  # base to tip, each once
        position = {column: k for k, column in enumerate(columns)}
        # The same steps, reading the chain vector: the compiled programs run on chain vectors.
        local_steps = tuple(
            step if step.index < 0 else ChainStep(step.rotation, step.translation, position[step.index], step.prismatic,
                                                  step.axis, step.scale, step.offset)
            for step in steps
        )
        set_ = object.__setattr__
        set_(self, "robot", robot)
        set_(self, "base", base)
        set_(self, "tip", tip)
        set_(self, "steps", tuple(steps))
        set_(self, "columns", _read_only(np.array(columns, dtype=np.intp)))
        set_(self, "joints", tuple(robot.joints[c] for c in columns))
        set_(self, "joint_names", tuple(j.name for j in self.joints))
        set_(self, "lower", _read_only(np.array([j.lower for j in self.joints], dtype=float)))
        set_(self, "upper", _read_only(np.array([j.upper for j in self.joints], dtype=float)))
        set_(self, "_angular", _read_only(np.array([j.is_angular for j in self.joints], dtype=bool)))
        set_(self, "_continuous", _read_only(np.array([j.type == "continuous" for j in self.joints], dtype=bool)))
        set_(self, "aliasable", _read_only(np.array(
            [j.is_angular and j.coordinate is None and j.type != "continuous" for j in self.joints], dtype=bool)
            & np.isfinite(self.lower) & np.isfinite(self.upper)))
        from manipkit.kernels.program import ChainProgram  # on the first chain: tf-between builds none

        set_(self, "program", ChainProgram(local_steps, len(columns)))
        set_(self, "_limits_ok", limits_ok(self.lower, self.upper))

    def __setattr__(self, name, value):
        raise AttributeError(f"a Chain is immutable: cannot set '{name}' (build another with robot.chain(base, tip))")

    def __delattr__(self, name):
        raise AttributeError(f"a Chain is immutable: cannot delete '{name}'")

    def __reduce__(self):
        return (_chain_of, (self.robot, self.base, self.tip))

    def __repr__(self) -> str:
        return (f"Chain({self.robot.name!r}, base={self.base!r}, tip={self.tip!r}, {len(self.joint_names)} joints: "
                f"{', '.join(self.joint_names) or 'none'})")

    def __len__(self) -> int:
        return len(self.joint_names)

    @property
    def n(self) -> int:
        """Number of entries of a chain vector."""
        return len(self.joint_names)

    @property
    def compiled_fk(self) -> ChainFK:
        """The chain's prepared batched FK on chain vectors (what :meth:`fk` runs): ``compiled_fk.transforms(Q,
        out=...)`` is :meth:`fk` without its checks, for rows (N, n), finite and C-contiguous, that a compiled
        caller made itself (the closed forms' batch puts its answers through it)."""
        return self.program.fk

    # ------------------------------------------------------------------
    # Joint vectors

    def q(self, values=None, /, *, degrees: bool = False, **joint_values) -> np.ndarray:
        """One chain vector (n,) from joint values, checked (the one validator every chain method uses).

        Parameters
        ----------
        values : sequence, dict or None
            ``n`` values in :attr:`joint_names` order; or a whole-robot vector
            (``len(robot.joint_names)`` values), of which the chain's entries
            are taken; or joint name -> value (any of the robot's joints, as
            :meth:`manipkit.kinematics.robot.Robot.q` takes them; those off
            the chain do not matter). None: every joint at its default (0, or
            the nearest value inside its limits).
        degrees : bool, keyword-only
            Angular values are in degrees (prismatic ones stay in metres).
        **joint_values
            Values by name, as in the dict form.

        Raises
        ------
        JointValueError
            A value that is not a finite real number, an unknown or mimic
            joint (named, with the valid ones), or a sequence whose length is
            neither the chain's nor the robot's.

        Examples
        --------
        >>> import manipkit
        >>> chain = manipkit.load("mobile_manipulator").chain("arm_base", "ee_link")
        >>> float(chain.q(shoulder_joint=90, degrees=True)[0])
        1.5707963267948966
        """
        robot = self.robot
        if values is None or isinstance(values, Mapping) or joint_values:
            return robot.q(values, degrees=degrees, **joint_values)[self.columns]
        if isinstance(values, (str, bytes)):
            raise JointValueError(f"joint values are numbers in joint order or a dict by name, not the text {values!r}")
        q = joint_array(values)
        if q.ndim == 1 and q.shape[0] == len(robot.joint_names) and q.shape[0] != self.n:
            q = robot.q(q, degrees=degrees)[self.columns]
        elif q.shape != (self.n,):
            raise JointValueError(self._length_message(q.shape))
        elif degrees:
            q = np.where(self._angular, np.radians(q), q)
        if not np.isfinite(q).all():
            raise JointValueError("joint values must be finite numbers")
        return np.array(q, dtype=float)

    def rows(self, Q) -> np.ndarray:
        """Many chain vectors (..., n) from ``Q`` (..., n) or whole-robot rows (..., len(robot.joint_names)), checked.

        One configuration by name (a dict) is taken too, as :meth:`q` takes it.
        """
        if isinstance(Q, Mapping):
            return self.q(Q)
        Q = joint_array(Q)
        n_robot = len(self.robot.joint_names)
        if Q.ndim >= 1 and Q.shape[-1] == n_robot and n_robot != self.n:
            Q = Q[..., self.columns]
        elif Q.ndim == 0 or Q.shape[-1] != self.n:
            raise JointValueError(self._length_message(Q.shape, per_row=True))
        if not np.all(np.isfinite(Q)):
            raise JointValueError("joint values must be finite numbers")
        return Q

    def _length_message(self, shape, *, per_row: bool = False) -> str:
        robot = self.robot
        each = " per configuration" if per_row else ""
        whole = "" if len(robot.joint_names) == self.n else f", or {len(robot.joint_names)} for the whole robot"
        return (f"the chain {self.base} -> {self.tip} of robot '{robot.name}' needs {self.n} joint values{each} "
                f"({', '.join(self.joint_names) or 'none'}){whole}; got shape {tuple(shape)}")

    def full(self, q, q_rest=None) -> np.ndarray:
        """A whole-robot vector: the chain's entries from ``q``, the others from ``q_rest`` (default: the robot's defaults)."""
        whole = self.robot.q() if q_rest is None else self.robot.q(q_rest).copy()
        whole[self.columns] = self.q(q)
        return whole

    def _checked(self, q) -> np.ndarray:
        return self.q(q)

    def as_dict(self, q) -> dict[str, float]:
        """Joint name -> value for one chain vector."""
        return dict(zip(self.joint_names, (float(v) for v in self.q(q))))

    # ------------------------------------------------------------------
    # Kinematics

    def fk(self, Q) -> np.ndarray:
        """``T_base_tip`` for one chain vector (4, 4) or many (..., 4, 4), compiled (equal to Pinocchio to ~1e-15).

        Examples
        --------
        >>> import manipkit
        >>> chain = manipkit.load("planar_2r").chain("base_link", "ee_link")
        >>> bool(np.allclose(chain.fk([0.0, np.pi / 2])[:2, 3], [1.0, 1.0]))
        True
        """
        Q = self.rows(Q)
        lead = Q.shape[:-1]
        flat = np.ascontiguousarray(Q.reshape(math.prod(lead), self.n))  # not -1: a chain may have no joints
        return self.program.fk.transforms(flat).reshape(*lead, 4, 4)

    def jacobians(self, Q, *, reference: str = "base") -> np.ndarray:
        """Geometric Jacobians (..., 6, n) of the tip relative to the base (rows vx vy vz wx wy wz; compiled).

        ``J qdot = (v, w)``: ``v`` the velocity of the tip's origin relative
        to the base frame (the time derivative of the translation of
        ``T_base_tip``), ``w`` the tip's angular velocity relative to the
        base (``dR/dt R^T = [w]x``, ``R`` the rotation of ``T_base_tip``),
        both in the base's axes (``reference="base"``) or the tip's
        (``"local"``); column ``k`` is ``d/dq_k`` of ``T_base_tip`` as that
        twist. The same meaning for every chain: base above the tip, or on
        another branch (a finger seen from the other finger): a joint on the
        way up from the base moves the base, so its column is the negated
        motion it gives the base, seen from the base.
        """
        if reference not in REFERENCES:
            raise OptionError(f"reference={reference!r} is not one of 'base', 'local'")
        Q = self.rows(Q)
        lead = Q.shape[:-1]
        J, _, _ = self.program.jacobian.run(np.ascontiguousarray(Q.reshape(math.prod(lead), self.n)), local=reference == "local")
        return J.reshape(*lead, 6, self.n)

    def jacobian(self, q=None, *, reference: str = "base") -> np.ndarray:
        """The geometric Jacobian (6, n) at one configuration (``q`` as :meth:`q` takes it; None: the defaults).

        Columns follow :attr:`joint_names` only (a wheel or a finger off the
        chain has no column), so ranks and singular values are the chain's.

        Examples
        --------
        >>> import manipkit
        >>> chain = manipkit.load("planar_2r").chain("base_link", "ee_link")
        >>> np.round(chain.jacobian([0.0, np.pi / 2])[[0, 1, 5]], 12) + 0.0
        array([[-1., -1.],
               [ 1.,  0.],
               [ 1.,  1.]])
        """
        return self.jacobians(self.q(q)[None], reference=reference)[0]

    def axes(self, q=None) -> JointAxes:
        """Every joint's axis and a point on it, in the base frame, at ``q`` (default: the robot's defaults).

        What analytic IK, singularity tests and reach maps need: the axes at
        the zero configuration give the arm's geometry (which axes meet, which
        are parallel).

        Examples
        --------
        >>> import manipkit
        >>> axes = manipkit.load("planar_2r").chain("base_link", "ee_link").axes()
        >>> axes.direction.round(12) + 0.0, axes.point.round(12) + 0.0
        (array([[0., 0., 1.],
               [0., 0., 1.]]), array([[0., 0., 0.],
               [1., 0., 0.]]))
        """
        q = self.q(q)
        R, p = np.eye(3), np.zeros(3)
        joint, direction, point, prismatic, scale = [], [], [], [], []
        for step in self.program.steps:
            p = p + R @ step.translation
            R = R @ step.rotation
            if step.index < 0:
                continue
            axis = R @ step.axis
            joint.append(step.index)
            direction.append(axis)
            point.append(p.copy())
            prismatic.append(step.prismatic)
            scale.append(step.scale)
            value = step.scale * q[step.index] + step.offset
            if step.prismatic:
                p = p + value * axis
            else:
                R = R @ matrix_from_axis_angle(step.axis, value)
        return JointAxes(
            _read_only(np.array(joint, dtype=np.intp)), _read_only(np.array(direction).reshape(-1, 3)),
            _read_only(np.array(point).reshape(-1, 3)), _read_only(np.array(prismatic, dtype=bool)),
            _read_only(np.array(scale, dtype=float)),
        )


def sampling_bounds(lower, upper) -> tuple[np.ndarray, np.ndarray]:
    """Where joint values are drawn: the limits, and [-pi, pi] for a joint without them (continuous)."""
    lower, upper = np.asarray(lower, dtype=float), np.asarray(upper, dtype=float)
    return np.where(np.isfinite(lower), lower, -math.pi), np.where(np.isfinite(upper), upper, math.pi)


def sample_between(low, high, n: int, seed=0) -> np.ndarray:
    """``n`` rows uniform in the box [low, high] (``seed``: an int, a sequence of ints or a numpy Generator).

    ``n`` is a whole number from 0 to :data:`manipkit.bounds.MAX_COUNT`, checked before anything is
    allocated (:class:`OptionError` naming it otherwise).
    """
    n = count(n, "the number of samples n", minimum=0)
    try:
        rng = np.random.default_rng(seed)
    except (TypeError, ValueError) as exc:
        raise OptionError(f"seed {repr_text(seed)}: give a whole number >= 0, a sequence of them or a numpy "
                          f"Generator ({exc})") from None
    u = rng.random(size=(n, len(low)))
    return low * (1.0 - u) + high * u  # not low + (high - low) u: high - low may overflow


def chain_of(subject, what: str, *, base=None, tip=None) -> Chain:
    """The :class:`Chain` a solver or an analysis works on: the one place a robot and two frames become a chain.

    ``subject`` is a Chain (then no frames may be given: it has its own) or a
    Robot, whose ``chain(base, tip)`` is taken (defaults ``base_link`` and
    ``ee_link``); ``what`` names the caller in the error.
    """
    if isinstance(subject, Chain):
        if base is not None or tip is not None:
            raise ChainError(f"{what}: a chain has its own frames ({subject.base} -> {subject.tip}); give base= and "
                             "tip= only with a robot")
        return subject
    return subject.chain("base_link" if base is None else base, "ee_link" if tip is None else tip)


def robot_and_frames(subject, what: str, *, base=None, tip=None) -> tuple:
    """(robot, base, tip) for a function that takes a robot and two frames, or a :class:`Chain` instead.

    A chain gives its robot and frames (none may be given besides); a robot
    keeps the frames given (defaults ``base_link`` and ``ee_link``).
    """
    if isinstance(subject, Chain):
        chain = chain_of(subject, what, base=base, tip=tip)
        return chain.robot, chain.base, chain.tip
    return subject, ("base_link" if base is None else base), ("ee_link" if tip is None else tip)


def chain_steps(model, columns: dict, frame_id: int, base_id: int | None) -> list[ChainStep]:
    """The steps of ``T_base_frame`` in a Pinocchio model (``base_id`` None: from the root link).

    Pinocchio keeps a robot as ``M_1 J_1(q_1) ... M_k J_k(q_k) X_frame`` over
    the joints supporting a frame: each joint step is the joint's placement
    in its parent joint's frame, then its motion; a floating or planar joint
    is one step per coordinate (its placement on the first); the frame's own
    placement closes the chain (a fixed step, ``index`` -1). From a base,
    ``T_base_frame = T_j_base^-1 T_j_frame`` with ``j`` the deepest joint
    supporting both frames (where their branches meet): the chain opens with
    the base's inverse placement ``[R^T, -R^T p]``, then goes up to ``j``,
    each joint on the way inverted (``(M J(v))^-1 = J(-v) M^-1``: its
    motions in reverse order with ``scale`` and ``offset`` negated, then its
    inverse placement as a fixed step), then down from ``j`` to the frame.
    A base above the frame (or off its path by fixed joints only) has no
    step up. ``columns`` maps a Pinocchio joint id to its ``(column, scale,
    offset, kind, axis)`` motions (:class:`manipkit.kinematics.joints.JointLayout`).
    """
    frame = model.frames[frame_id]
    support = list(model.supports[frame.parentJoint])  # joint ids, universe (0) first
    if base_id is None:
        below, steps = support[1:], []
    else:
        base = model.frames[base_id]
        base_support = list(model.supports[base.parentJoint])
        shared = 0
        while shared < min(len(support), len(base_support)) and support[shared] == base_support[shared]:
            shared += 1
        below = support[shared:]
        R, p = base.placement.rotation, base.placement.translation
        steps = [_fixed_step(R.T, -R.T @ p)]
        for joint_id in reversed(base_support[shared:]):  # up from the base's joint to where the branches meet
            for column, scale, offset, kind, axis in reversed(columns[joint_id]):
                steps.append(ChainStep(_IDENTITY, _ZERO, column, kind == "prismatic", axis, -scale, -offset))
            placement = model.jointPlacements[joint_id]
            R, p = placement.rotation, placement.translation
            steps.append(_fixed_step(R.T, -R.T @ p))
    for joint_id in below:
        placement = model.jointPlacements[joint_id]
        rotation, translation = _read_only_copy(placement.rotation), _read_only_copy(placement.translation)
        for column, scale, offset, kind, axis in columns[joint_id]:
            steps.append(ChainStep(rotation, translation, column, kind == "prismatic", axis, scale, offset))
            rotation, translation = _IDENTITY, _ZERO
    steps.append(_fixed_step(frame.placement.rotation, frame.placement.translation))
    return steps


def _read_only_copy(array) -> np.ndarray:
    return _read_only(np.array(array, dtype=float))


def _fixed_step(rotation, translation) -> ChainStep:
    return ChainStep(_read_only_copy(rotation), _read_only_copy(translation), -1, False, None)


def _chain_of(robot: Robot, base: str, tip: str) -> Chain:
    """Unpickling: the robot's own chain object."""
    return robot.chain(base, tip)


def chain_columns(Q: np.ndarray, columns: np.ndarray) -> np.ndarray:
    """The chain's columns of whole-robot rows ``Q`` (N, n_robot): a view when they are one ascending run (an arm's
    chain is usually the whole robot), else a gathered copy."""
    if columns.size and np.array_equal(columns, np.arange(columns[0], columns[0] + columns.size)):
        return Q[:, int(columns[0]) : int(columns[0]) + columns.size]
    return Q[:, columns]


def joint_array(values) -> np.ndarray:
    """``values`` as a float array; complex or non-numeric entries raise :class:`JointValueError` (one line).

    numpy would drop an imaginary part with a warning; a joint value is a real number (rad or m). At
    most :data:`manipkit.bounds.MAX_COUNT` configurations are taken in one call, checked before any
    result is allocated (a broadcast view of 1e9 rows costs nothing until it is computed on).
    """
    if type(values) is np.ndarray and values.dtype == np.float64:  # the common case: nothing to convert
        return _few_enough(values)
    try:
        array = np.asarray(values)
        if array.dtype.kind == "c" or (
            array.dtype.kind == "O" and any(isinstance(v, (complex, np.complexfloating)) for v in array.flat)
        ):
            raise JointValueError(f"joint values must be real numbers (rad or m); got complex values {repr_text(values)}")
        return _few_enough(array.astype(float, copy=False))
    except OverflowError:
        raise JointValueError(f"joint values must be real numbers (rad or m) a float can hold; got {repr_text(values)}") from None
    except (TypeError, ValueError) as exc:
        if isinstance(exc, JointValueError):
            raise
        raise JointValueError(f"joint values must be real numbers (rad or m), a vector or equal rows of them; "
                              f"got {repr_text(values)}") from None


def _few_enough(Q: np.ndarray) -> np.ndarray:
    configurations = math.prod(Q.shape[:-1])
    if configurations > MAX_COUNT:
        raise JointValueError(f"{configurations} configurations in one call; give at most {MAX_COUNT} "
                              "(split the batch)")
    return Q


def _read_only(array: np.ndarray) -> np.ndarray:
    array.setflags(write=False)
    return array


_IDENTITY, _ZERO = _read_only(np.eye(3)), _read_only(np.zeros(3))
