"""Static joint torques: what each motor of a chain must produce to hold the arm still under gravity, a payload and
external wrenches, for one configuration or many at once.

Conventions (docs/architecture.md), restated:

- ``tau = g(q) - sum_i J_i(q)^T w_i`` (Pinocchio's ``computeStaticTorque``):
  ``g(q) = dV/dq`` is the gradient of the potential energy (Pinocchio's
  ``computeGeneralizedGravity``), and each wrench ``w_i`` is applied **on**
  the robot by the world (a force pushing the tool down is ``(0, 0, -5)``
  N). ``tau`` is the torque (N m; N for a prismatic joint) the motor must
  produce; a positive value turns the joint the positive way about its axis.
  Drake's gravity term is the negative of this one, and Robotics Toolbox's
  ``pay`` returns ``-J^T W``.
- ``gravity`` (m/s^2) is given in the axes of the robot's root link (the
  world of the URDF, Pinocchio's ``model.gravity``), default ``(0, 0, -9.81)``.
- A :class:`Payload` is a rigid body **added** to the tip link (its own mass
  stays): mass (kg), the centre of gravity's offset from the tip's origin in
  the tip frame's axes (m), and optionally its inertia (kg m^2, about the
  CoG, in the tip frame's axes; statics does not need it).
- A :class:`Wrench` ``(fx, fy, fz, tx, ty, tz)`` (N, N m) acts at the origin
  of its ``frame``; its components are in the chain base's axes
  (``axes="base"``) or in the frame's own axes (``axes="frame"``).
- Joint values and answers are chain vectors (:attr:`manipkit.kinematics.chain.Chain.joint_names`):
  the joints between ``base`` and ``tip``; joints off the chain (fingers)
  hold their values from ``q_rest`` (the robot's defaults unless given), and
  the links they carry weigh on the chain.

How it is computed: the bodies moved by the chain are lumped per chain joint
(everything rigidly attached after it, fingers included at ``q_rest``: mass
and centre of gravity in that joint's frame); then a compiled pass over 64
configurations at a time (:mod:`manipkit.statics.gravity_kernel`) turns gravity into each
joint's frame, adds the lumps up from the tip in those frames and takes each joint's moment
of their weight (and the payload's), ``g(q) = -sum_s m_s J_s(q)^T g``; a wrench's part is ``-J^T w`` from the
compiled Jacobians. No Python loop over configurations. Tested against
Pinocchio to 1e-10.

Examples
--------
>>> import manipkit
>>> robot = manipkit.load("planar_2r")
>>> answer = static_torques(robot, [0.0, 0.0], gravity=(-9.81, 0.0, 0.0))  # in-plane gravity along -x: no torque
>>> bool(abs(answer.tau).max() < 1e-12)
True
"""

from __future__ import annotations

import functools
import math
import weakref
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from manipkit import bounds
from manipkit.errors import OptionError
from manipkit.kernels.fk import ChainStep, z_to_axis
from manipkit.kernels.program import JacobianProgram
from manipkit.kinematics.chain import chain_of
from manipkit.statics.audit import inertia_grade
from manipkit.text import repr_text

if TYPE_CHECKING:
    from manipkit.kinematics.chain import Chain
    from manipkit.kinematics.robot import Robot

__all__ = ["GRAVITY", "Payload", "StaticTorques", "Wrench", "WRENCH_AXES", "chain_bodies", "effort_limits",
           "gravity_in_base", "lumped_bodies", "point_program", "whole_rows", "margins", "payload_torques", "static_torques", "wrench_torques"]

GRAVITY = (0.0, 0.0, -9.81)
WRENCH_AXES = ("base", "frame")


def _vector(value, length: int, what: str) -> np.ndarray:
    try:
        array = np.asarray(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise OptionError(f"{what} {repr_text(value)}: give {length} real numbers") from None
    if array.shape != (length,):
        raise OptionError(f"{what} {repr_text(value)}: give {length} numbers, got {array.size}")
    if not np.all(np.isfinite(array)):
        raise OptionError(f"{what} {repr_text(value)}: every component must be a finite number")
    return array


@dataclass(frozen=True)
class Payload:
    """A rigid body held by the tip link, added to it (the tip link keeps its own mass).

    Parameters
    ----------
    mass : float
        kg, >= 0 and finite.
    cog : (3,) float
        The centre of gravity's offset from the tip frame's origin, in the
        tip frame's axes (m).
    inertia : (3, 3) float or None
        About the CoG, in the tip frame's axes (kg m^2), symmetric positive
        semidefinite; used by inverse dynamics only.

    Examples
    --------
    >>> Payload(2.0, (0.0, 0.0, 0.1)).cog.tolist()
    [0.0, 0.0, 0.1]
    """

    mass: float
    cog: np.ndarray = field(default_factory=lambda: np.zeros(3))
    inertia: np.ndarray | None = None

    def __post_init__(self):
        try:
            mass = float(self.mass)
        except (TypeError, ValueError):
            raise OptionError(f"payload mass {repr_text(self.mass)}: give a number of kg >= 0") from None
        if not (math.isfinite(mass) and mass >= 0):
            raise OptionError(f"payload mass {repr_text(self.mass)} kg: give a finite mass >= 0")
        if mass > bounds.MAX_MASS:
            raise OptionError(f"payload mass {repr_text(mass)} kg: give a mass up to {bounds.MAX_MASS:g} kg")
        object.__setattr__(self, "mass", mass)
        cog = _vector(self.cog, 3, "payload centre of gravity")
        if np.abs(cog).max() > bounds.MAX_LENGTH:
            raise OptionError(f"payload centre of gravity {repr_text(cog.tolist())} m: give coordinates within "
                              f"{bounds.MAX_LENGTH:g} m")
        object.__setattr__(self, "cog", cog)
        if self.inertia is not None:
            inertia = _vector(self.inertia, 9, "payload inertia").reshape(3, 3)
            if not np.allclose(inertia, inertia.T, atol=1e-12) or np.linalg.eigvalsh(inertia).min() < -1e-12:
                raise OptionError("payload inertia: give a symmetric positive semidefinite 3x3 matrix (kg m^2)")
            object.__setattr__(self, "inertia", inertia)


@dataclass(frozen=True)
class Wrench:
    """A force and a moment applied on the robot at ``frame``'s origin (the world pushes on the robot).

    Parameters
    ----------
    wrench : (6,) float
        ``(fx, fy, fz, tx, ty, tz)``: N then N m.
    frame : str
        The frame (link) at whose origin it acts; ``"ee_link"`` by default, the tip.
    axes : {"base", "frame"}
        Components in the chain base's axes or in ``frame``'s own axes.

    Examples
    --------
    >>> Wrench((0, 0, -5, 0, 0, 0)).force.tolist()
    [0.0, 0.0, -5.0]
    """

    wrench: np.ndarray
    frame: str = "ee_link"
    axes: str = "base"

    def __post_init__(self):
        object.__setattr__(self, "wrench", _vector(self.wrench, 6, "wrench (fx, fy, fz, tx, ty, tz)"))
        if self.axes not in WRENCH_AXES:
            raise OptionError(f"wrench axes={self.axes!r} is not one of 'base', 'frame'")
        if not isinstance(self.frame, str):
            raise OptionError(f"wrench frame {repr_text(self.frame)}: give a frame (link) name")

    @property
    def force(self) -> np.ndarray:
        return self.wrench[:3]

    @property
    def moment(self) -> np.ndarray:
        return self.wrench[3:]


@dataclass(frozen=True)
class StaticTorques:
    """The answer of :func:`static_torques` (arrays (..., n): one row per configuration given).

    Attributes
    ----------
    joint_names : tuple of str
        The chain's joints, base to tip.
    tau : ndarray
        ``gravity + payload + wrench`` (N m or N): what the motors must produce.
    gravity, payload, wrench : ndarray
        The parts: the robot's own weight ``g(q)``, the payload's weight, and ``-sum J^T w``.
    effort_limit : ndarray, shape (n,)
        The URDF's ``effort`` per joint (NaN where none is given, or 0).
    margin : ndarray
        ``100 (1 - |tau| / effort_limit)`` percent (NaN where no limit); negative when over the limit. Computed
        from ``tau`` on first use (:func:`margins`), so a batch that never asks does not pay for it.
    saturating : ndarray of int
        (...,) the joint with the least margin (the first to saturate as the load grows), -1 when no joint has a
        limit; :attr:`saturating_joint` names it for one configuration. Computed with ``margin``.
    base, tip : str
    gravity_vector : ndarray, shape (3,)
        In the root link's axes (m/s^2).
    inertia_grade : str
        The robot's grade from the inertia audit (:func:`manipkit.statics.audit.inertia_grade`): "A" nothing
        found, "B" warnings, "C" errors that make these torques wrong.
    """

    joint_names: tuple
    tau: np.ndarray
    gravity: np.ndarray
    payload: np.ndarray
    wrench: np.ndarray
    effort_limit: np.ndarray
    base: str
    tip: str
    gravity_vector: np.ndarray
    inertia_grade: str = ""

    @functools.cached_property
    def _margins(self) -> tuple[np.ndarray, np.ndarray]:
        return margins(self.tau, self.effort_limit)

    @property
    def margin(self) -> np.ndarray:
        """``100 (1 - |tau| / effort_limit)`` (..., n) percent, NaN where no limit (computed on first use)."""
        return self._margins[0]

    @property
    def saturating(self) -> np.ndarray:
        """(...,) the joint of least margin among those with a limit, -1 when none has one (on first use)."""
        return self._margins[1]

    @property
    def saturating_joint(self) -> str | None:
        """The name of the joint with the least margin (one configuration), or None without limits."""
        if np.ndim(self.saturating) != 0:
            raise OptionError("saturating_joint names one configuration's joint; index a batch with .saturating")
        k = int(self.saturating)
        return None if k < 0 else self.joint_names[k]

    @property
    def over_limit(self) -> np.ndarray:
        """Boolean (..., n): the joints whose torque exceeds their effort limit."""
        return np.nan_to_num(self.margin, nan=1.0) < 0


# --------------------------------------------------------------------------
# The chain's bodies, lumped per joint


def _chain_joint_ids(chain: Chain) -> list[tuple[int, int]]:
    """(Pinocchio joint id, position in ``chain.steps``) of each joint step of the chain, base to tip."""
    robot = chain.robot
    model = robot.model
    tip_joint = model.frames[robot.frame_id(chain.tip)].parentJoint
    base_joint = model.frames[robot.frame_id(chain.base)].parentJoint
    support = list(model.supports[tip_joint])
    below = support[support.index(base_joint) + 1:]
    owners = [joint_id for joint_id in below for _ in robot.joint_layout.columns.get(joint_id, ())]
    positions = [k for k, step in enumerate(chain.steps) if step.index >= 0]
    if len(owners) != len(positions):  # the chain's steps are built from the same walk (chain_steps)
        raise RuntimeError(f"chain {chain.base} -> {chain.tip}: {len(positions)} joint steps for {len(owners)} motions")
    return list(zip(owners, positions))


def chain_bodies(chain: Chain, q_rest=None) -> list[tuple[int, str, float, np.ndarray]]:
    """Every body moved by the chain's joints: (position in ``chain.steps`` of its joint, link, mass, CoG) each.

    A body is Pinocchio's: a link with the links fixed to it merged, named by
    that link. Each is given to the deepest chain joint above it (a finger's
    body to the joint carrying the hand); its centre of gravity is written in
    that joint's frame (m), with the joints off the chain at ``q_rest`` (a
    whole-robot vector; default the robot's defaults). Massless bodies are left out. Base to tip.
    """
    import pinocchio as pin

    robot = chain.robot
    model = robot.model
    data = model.createData()
    pin.forwardKinematics(model, data, robot.pinocchio_configuration(robot.q() if q_rest is None else q_rest))
    last_step = {}
    for joint_id, position in _chain_joint_ids(chain):
        last_step[joint_id] = position  # a floating or planar joint's last coordinate carries its body
    link_of = {}
    for frame in model.frames:
        if frame.type == pin.FrameType.BODY:
            link_of.setdefault(frame.parentJoint, frame.name)
    bodies = []
    for body in range(1, model.njoints):
        inertia = model.inertias[body]
        if inertia.mass <= 0:
            continue
        owner = next((j for j in reversed(list(model.supports[body])) if j in last_step), None)
        if owner is None:  # not moved by the chain's joints
            continue
        centre = np.asarray(data.oMi[owner].actInv(data.oMi[body].act(inertia.lever)))
        bodies.append((last_step[owner], link_of.get(body, model.names[body]), float(inertia.mass), centre))
    return sorted(bodies, key=lambda b: b[0])


def lumped_bodies(chain: Chain, q_rest=None) -> list[tuple[int, float, np.ndarray]]:
    """:func:`chain_bodies` lumped per chain joint: (position in ``chain.steps``, mass, CoG in its frame), base to tip."""
    lumps: dict[int, list] = {}
    for position, _, mass, centre in chain_bodies(chain, q_rest):
        lump = lumps.setdefault(position, [0.0, np.zeros(3)])
        lump[0] += mass
        lump[1] = lump[1] + mass * centre
    return [(position, m, first / m) for position, (m, first) in sorted(lumps.items())]


_TABLES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()  # robot -> {(base, tip, rest): tables}


def _gravity_tables(chain: Chain, q_rest) -> tuple:
    """The arguments of :func:`manipkit.statics.gravity_kernel.gravity_rows` that do not change per row, for the
    chain with the joints off it at ``q_rest``: made once per (chain, rest) and kept (robots are immutable)."""
    robot = chain.robot
    key = (chain.base, chain.tip, None if q_rest is None else robot.q(q_rest).tobytes())
    per_robot = _TABLES.setdefault(robot, {})
    tables = per_robot.get(key)
    if tables is not None:
        return tables
    program = chain.program.jacobian  # the chain's steps on chain vectors
    joint_steps = [k for k, step in enumerate(chain.steps) if step.index >= 0]
    masses, moments = np.zeros(len(joint_steps)), np.zeros((len(joint_steps), 3))
    for position, mass, centre in lumped_bodies(chain, q_rest):
        k = joint_steps.index(position)
        masses[k] = mass  # the program turns each joint frame by A (its axis onto z): the CoG in those axes is A^T c
        moments[k] = mass * (z_to_axis(chain.steps[position].axis).T @ centre)
    tables = (program.rotations, program.translations, program.identity, program.kinds, program.columns,
              program.scales, program.offsets, masses, moments)
    return per_robot.setdefault(key, tables)


def _static_parts(chain: Chain, Q: np.ndarray, g_base: np.ndarray, payload, tau_w, q_rest) -> tuple:
    """(g(q), the payload's part, tau) (N, n) each for chain vectors ``Q`` (N, n): the compiled gravity pass
    (:mod:`manipkit.statics.gravity_kernel`), the rows cut into blocks taken by threads
    (:func:`manipkit.statics.gravity_kernel.static_blocks`). ``tau_w`` (N, n) or None is the wrenches' part, added to
    ``tau``."""
    from manipkit.kernels import thread_count
    from manipkit.statics.gravity_kernel import gravity_rows_kernel, joint_tan_half, static_blocks

    tables = _gravity_tables(chain, q_rest)
    n_rows = Q.shape[0]
    tau_g, tau_p, tau = np.empty((n_rows, chain.n)), np.empty((n_rows, chain.n)), np.empty((n_rows, chain.n))
    mass = 0.0 if payload is None else payload.mass
    cog = np.zeros(3) if payload is None else payload.cog
    one_g = g_base.shape[0] == 1
    no_w = np.empty((0, chain.n))
    gravity_kernel = gravity_rows_kernel()

    def work(start: int, stop: int) -> None:
        rows = slice(start, stop)
        gravity_kernel(Q[rows], joint_tan_half(Q[rows], tables[4], tables[5], tables[6]), *tables, mass, cog,
                       g_base if one_g else g_base[rows], no_w if tau_w is None else tau_w[rows],
                       tau_g[rows], tau_p[rows], tau[rows])

    static_blocks(work, n_rows, thread_count(None))
    return tau_g, tau_p, tau


def point_program(chain: Chain, position: int, point) -> JacobianProgram:
    """The compiled Jacobian of a point fixed after step ``position`` of the chain (offset ``point`` in its frame)."""
    steps = list(chain.steps[:position + 1]) + [ChainStep(np.eye(3), np.asarray(point, dtype=float), -1, False, None)]
    return JacobianProgram.from_steps(steps, len(chain.robot.joint_names))


def whole_rows(chain: Chain, Q, q_rest) -> tuple[np.ndarray, tuple]:
    """(whole-robot rows (N, n_robot), the leading shape) for chain vectors ``Q`` (..., n)."""
    Q = chain.rows(Q)
    lead = Q.shape[:-1]
    robot = chain.robot
    rest = robot.q() if q_rest is None else robot.q(q_rest)
    flat = np.empty((math.prod(lead), len(robot.joint_names)))
    flat[:] = rest
    flat[:, chain.columns] = Q.reshape(-1, chain.n)
    return flat, lead


def gravity_in_base(chain: Chain, whole: np.ndarray, gravity) -> np.ndarray:
    """The gravity vector (N, 3) in the chain base's axes, from ``gravity`` in the root link's axes."""
    g = bounds.gravity(_vector(gravity, 3, "gravity"), "gravity")
    robot = chain.robot
    if chain.base == robot.root_link:
        return np.broadcast_to(g, (whole.shape[0], 3))
    R_root_base = robot.fk(whole, base=robot.root_link, tip=chain.base)[:, :3, :3]
    return np.einsum("nji,j->ni", R_root_base, g)  # R^T g


def _weight_torques(program: JacobianProgram, whole, columns, mass: float, g_base) -> np.ndarray:
    """``-m J_p^T g`` (N, n) for the point of ``program``: the torque that holds a point mass up."""
    J, _, _ = program.run(np.ascontiguousarray(whole))
    return -mass * np.einsum("nik,ni->nk", J[:, :3, :][:, :, columns], g_base)


def payload_torques(chain: Chain, whole, payload: Payload, g_base) -> np.ndarray:
    """The payload's part of ``tau`` (N, n): its weight at its CoG, held by the chain."""
    program = point_program(chain, len(chain.steps) - 1, payload.cog)  # after the tip's own placement
    return _weight_torques(program, whole, chain.columns, payload.mass, g_base)


def wrench_torques(chain: Chain, whole, wrench: Wrench) -> np.ndarray:
    """``-J^T w`` (N, n) for a wrench applied on the robot at its frame's origin (UnknownFrameError for a bad frame)."""
    robot = chain.robot
    frame = robot.frame(wrench.frame)
    J = robot.jacobians(whole, base=chain.base, tip=frame, reference="local" if wrench.axes == "frame" else "base")
    return -np.einsum("nik,i->nk", J[:, :, chain.columns], wrench.wrench)


def effort_limits(chain: Chain) -> np.ndarray:
    """The URDF effort limit (N m or N) of each chain joint, NaN where none is given (missing, 0 or infinite)."""
    robot = chain.robot
    model = robot.model
    mimics = set(robot.mimic_joints)
    limits = np.full(chain.n, np.nan)
    for joint_id, entries in robot.joint_layout.columns.items():
        if model.names[joint_id] in mimics:
            continue
        for k, (column, *_rest) in enumerate(entries):
            where = np.flatnonzero(chain.columns == column)
            if where.size:
                value = float(model.effortLimit[model.joints[joint_id].idx_v + k])
                limits[where[0]] = value if math.isfinite(value) and value > 0 else np.nan
    return limits


def margins(tau: np.ndarray, limits: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(margin percent (..., n), index of the least margin (...,), -1 without limits) for torques against limits.

    ``margin = 100 (1 - |tau| / limit)``, NaN where the limit is NaN; the least margin is sought among the joints with
    a finite limit (the first one on a tie). Compiled (:func:`manipkit.statics.gravity_kernel.margin_rows`).
    """
    from manipkit.statics.gravity_kernel import margin_rows_kernel

    tau = np.asarray(tau, dtype=float)
    flat = np.ascontiguousarray(tau.reshape(-1, tau.shape[-1]))
    margin, saturating = np.empty_like(flat), np.empty(flat.shape[0], dtype=np.intp)
    margin_rows_kernel()(flat, np.ascontiguousarray(limits, dtype=float), margin, saturating)
    return margin.reshape(tau.shape), saturating.reshape(tau.shape[:-1])


def static_torques(robot: Robot | Chain, q, *, payload: Payload | None = None, wrench=None, gravity=GRAVITY,
                   base: str | None = None, tip: str | None = None, q_rest=None) -> StaticTorques:
    """The torques the chain's motors must produce to hold still: ``tau = g(q) - sum J^T w`` (see the module).

    Parameters
    ----------
    robot : Robot or Chain
    q : array_like, shape (n,) or (..., n)
        Chain vectors (rad, m), or whole-robot vectors (the chain's entries are read).
    payload : Payload, optional
        Added to the tip link.
    wrench : Wrench or sequence of Wrench, optional
        Applied on the robot; the frame must exist (:class:`~manipkit.errors.UnknownFrameError`).
    gravity : (3,) float, keyword-only
        m/s^2 in the root link's axes.
    base, tip : str, keyword-only
        The chain (defaults ``base_link``, ``ee_link``); not with a Chain.
    q_rest : optional
        A whole-robot vector for the joints off the chain (default: the robot's defaults).

    Returns
    -------
    StaticTorques

    Examples
    --------
    >>> import manipkit
    >>> robot = manipkit.load("planar_2r")  # two 1 m links in the x-y plane
    >>> answer = static_torques(robot, [0.0, 0.0], wrench=Wrench((0, 1.0, 0, 0, 0, 0)), gravity=(0, 0, -9.81))
    >>> np.round(answer.wrench, 12) + 0.0  # 1 N along +y at the tip 2 m out: the motors resist -2 and -1 N m
    array([-2., -1.])
    """
    chain = chain_of(robot, "static_torques", base=base, tip=tip)
    if payload is not None and not isinstance(payload, Payload):
        raise OptionError(f"payload {repr_text(payload)}: give a manipkit.statics.Payload(mass, cog)")
    wrenches = () if wrench is None else (wrench,) if isinstance(wrench, Wrench) else tuple(wrench)
    for w in wrenches:
        if not isinstance(w, Wrench):
            raise OptionError(f"wrench {repr_text(w)}: give a manipkit.statics.Wrench(wrench, frame)")
    Q = chain.rows(q)
    lead = Q.shape[:-1]
    Q = np.ascontiguousarray(Q.reshape(-1, chain.n), dtype=float)
    g = _vector(gravity, 3, "gravity")
    whole = None
    if wrenches or chain.base != chain.robot.root_link:  # the whole robot's rows: the base's turn, the wrench frames
        whole = np.ascontiguousarray(whole_rows(chain, Q, q_rest)[0])
    g_base = g[None] if whole is None else np.ascontiguousarray(gravity_in_base(chain, whole, g))
    tau_w = None
    for w in wrenches:
        part = wrench_torques(chain, whole, w)
        tau_w = part if tau_w is None else tau_w + part
    tau_g, tau_p, tau = _static_parts(chain, Q, g_base, payload, tau_w, q_rest)
    if tau_w is None:
        tau_w = np.zeros(tau.shape)  # calloc: no pass over the rows
    shape = (*lead, chain.n)
    return StaticTorques(
        chain.joint_names, tau.reshape(shape), tau_g.reshape(shape), tau_p.reshape(shape), tau_w.reshape(shape),
        effort_limits(chain), chain.base, chain.tip, g, inertia_grade(chain.robot),
    )
