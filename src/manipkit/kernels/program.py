"""The one compiled program of a chain: its steps prepared once for FK, Jacobians, IK and the row-by-row check.

A :class:`manipkit.kinematics.chain.Chain` builds one :class:`ChainProgram`
from its steps (base to tip, indexing the chain vector) and every compiled
computation on the chain runs on it:

- ``program.fk``: the batched FK (:class:`manipkit.kernels.fk.ChainFK`);
- ``program.jacobian``: the batched geometric Jacobian (:class:`JacobianProgram`);
- ``program.ik_tables``: the chain packed for the Levenberg-Marquardt kernel
  of :mod:`manipkit.ik.lm_kernel` (:func:`pack_chain`);
- ``program.row_tables``: the FK program packed for one configuration at a
  time inside another compiled loop (:func:`manipkit.kernels.fk.row_tables`,
  the closed forms' check).

Each is derived from the same steps the first time it is asked for and kept
(the program is immutable, so the derived tables never change). numpy,
numba (inside the kernels) and :mod:`manipkit.errors` only.

Conventions: a step's joint value is ``scale * q[index] + offset`` (rad or
m), ``q`` a chain vector; poses are ``T_base_tip``; Jacobian rows are
``vx vy vz wx wy wz`` (the velocity of the tip's origin relative to the base,
then the tip's angular velocity relative to the base), in the base's axes
(``local=False``) or the tip's (``local=True``), columns by chain entry.

Examples
--------
>>> import numpy as np
>>> z = np.array([0.0, 0.0, 1.0])
>>> steps = [ChainStep(np.eye(3), np.zeros(3), 0, False, z), ChainStep(np.eye(3), np.array([1.0, 0, 0]), 1, False, z),
...          ChainStep(np.eye(3), np.array([1.0, 0, 0]), -1, False, None)]
>>> program = ChainProgram(steps, 2)
>>> J, R, p = program.jacobian.run(np.array([[0.0, np.pi / 2]]))
>>> np.round(J[0][[0, 1, 5]], 12) + 0.0  # vx, vy, wz of a 2R arm with unit links
array([[-1., -1.],
       [ 1.,  0.],
       [ 1.,  1.]])
"""

from __future__ import annotations

import threading
from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from manipkit.kernels.compile import lazy_kernel
from manipkit.kernels.fk import ChainFK, ChainStep, row_tables, snap_placement, z_to_axis

__all__ = ["ChainProgram", "IKProgram", "JacobianProgram", "LMOptions", "pack_chain"]

BLOCK = 8192  # rows per numpy tan call of the Jacobian
_REVOLUTE, _PRISMATIC, _TIP = 0, 1, -1


class ChainProgram:
    """The compiled program of one chain (steps base to tip, ``n`` chain entries), prepared once.

    Parameters
    ----------
    steps : sequence of ChainStep
        ``T_base_tip = S_0 S_1 ... S_m``; a joint step's ``index`` is its entry of the chain vector.
    n : int
        Entries of the chain vector.

    Attributes
    ----------
    steps : tuple of ChainStep
    n : int
    fk : ChainFK
        The batched FK (built with the program: every chain runs FK).
    """

    __slots__ = ("steps", "n", "fk", "_derived", "_lock")

    def __init__(self, steps: Sequence[ChainStep], n: int):
        self.steps = tuple(steps)
        self.n = int(n)
        self.fk = ChainFK(self.steps, self.n)
        self._derived: dict = {}  # name -> table, made on first use
        self._lock = threading.Lock()

    def __repr__(self) -> str:
        return f"ChainProgram({self.n} entries, {len(self.steps)} steps)"

    def __getstate__(self):
        return {"steps": self.steps, "n": self.n}

    def __setstate__(self, state):
        self.__init__(state["steps"], state["n"])

    def _get(self, name: str, make):
        table = self._derived.get(name)
        if table is None:
            with self._lock:
                table = self._derived.get(name)
                if table is None:
                    table = self._derived[name] = make()
        return table

    @property
    def jacobian(self) -> JacobianProgram:
        """The batched Jacobian of the chain (:class:`JacobianProgram`)."""
        return self._get("jacobian", lambda: JacobianProgram.from_steps(self.steps, self.n))

    @property
    def ik_tables(self) -> tuple[np.ndarray, np.ndarray]:
        """(geometry, kinds) of :func:`pack_chain` for the whole chain vector (read-only)."""
        return self._get("ik", lambda: _read_only(pack_chain(self.steps, range(self.n))))

    @property
    def row_tables(self) -> tuple[np.ndarray, np.ndarray]:
        """(floats, ints) of :func:`manipkit.kernels.fk.row_tables`: :attr:`fk`'s program packed for
        :func:`manipkit.kernels.fk.pose_rows` on chain vectors (read-only)."""
        return self._get("rows", lambda: _read_only(row_tables(self.fk)))


def _read_only(arrays: tuple[np.ndarray, ...]) -> tuple[np.ndarray, ...]:
    for array in arrays:
        array.setflags(write=False)
    return arrays


# --------------------------------------------------------------------------
# The Jacobian: every joint about / along its local z axis


@dataclass(frozen=True)
class JacobianProgram:
    """A chain prepared for the compiled Jacobian loop (built by :meth:`from_steps`).

    ``rotations[k]``, ``translations[k]`` (k = 0..S) are the constant
    placements before joint ``k`` (the last one: before the tip), with every
    joint turned to its local z axis; ``kinds[k]`` 0 revolute, 1 prismatic;
    ``rows[k]`` the joint's row among the revolute (or prismatic) ones;
    ``columns[k]`` its column of the joint vector, ``scales[k]``,
    ``offsets[k]`` its value ``scale * q[column] + offset``.
    """

    rotations: np.ndarray  # (S + 1, 3, 3)
    translations: np.ndarray  # (S + 1, 3)
    identity: np.ndarray  # (S + 1,) bool: rotations[k] is the identity (skipped)
    kinds: np.ndarray  # (S,) int
    rows: np.ndarray  # (S,) int
    columns: np.ndarray  # (S,) int
    scales: np.ndarray  # (S,)
    offsets: np.ndarray  # (S,)
    n_joints: int

    @classmethod
    def from_steps(cls, steps: Sequence[ChainStep], n_joints: int) -> JacobianProgram:
        """Fold the fixed steps and the joints' axis rotations into one constant placement per joint."""
        rotations, translations, kinds, columns, scales, offsets = [], [], [], [], [], []
        C, t, A_prev_T = np.eye(3), np.zeros(3), np.eye(3)
        for step in steps:
            t = t + C @ np.asarray(step.translation, dtype=float)
            C = C @ np.asarray(step.rotation, dtype=float)
            if step.index < 0:
                continue
            A = z_to_axis(step.axis)
            rotations.append(A_prev_T @ C @ A)
            translations.append(A_prev_T @ t)
            kinds.append(_PRISMATIC if step.prismatic else _REVOLUTE)
            columns.append(int(step.index))
            scales.append(float(step.scale))
            offsets.append(float(step.offset))
            C, t, A_prev_T = np.eye(3), np.zeros(3), A.T
        rotations.append(A_prev_T @ C)
        translations.append(A_prev_T @ t)
        R = snap_placement(np.array(rotations).reshape(-1, 3, 3))  # a URDF rpy of 1.5707963 leaves 6e-17 where 0 is meant
        kinds_a = np.array(kinds, dtype=np.int64)
        rows = np.zeros(len(kinds), dtype=np.int64)
        rows[kinds_a == _REVOLUTE] = np.arange(int(np.sum(kinds_a == _REVOLUTE)))
        rows[kinds_a == _PRISMATIC] = np.arange(int(np.sum(kinds_a == _PRISMATIC)))
        return cls(
            np.ascontiguousarray(R), np.array(translations).reshape(-1, 3),
            np.array([np.array_equal(r, np.eye(3)) for r in R], dtype=bool), kinds_a, rows,
            np.array(columns, dtype=np.int64), np.array(scales), np.array(offsets), int(n_joints),
        )

    def run(self, Q: np.ndarray, *, local: bool = False, out_columns=None, width: int | None = None
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(J (N, 6, n), R (N, 3, 3), p (N, 3)) for the rows of ``Q`` (N, n), in the chain base's axes.

        ``local``: J in the tip frame's axes instead. ``R``, ``p`` are the tip's pose in the chain's base.
        ``out_columns`` (n,), ``width``: entry ``k`` fills column ``out_columns[k]`` of a J ``width`` wide,
        zero elsewhere (a robot's Jacobian in its joint order, written once).
        """
        n = Q.shape[0]
        J = np.zeros((n, 6, self.n_joints if width is None else int(width)))
        columns = self.columns if out_columns is None else np.asarray(out_columns, dtype=np.int64)[self.columns]
        R = np.empty((n, 3, 3))
        p = np.empty((n, 3))
        revolute = self.kinds == _REVOLUTE
        rev_cols, pri_cols = self.columns[revolute], self.columns[~revolute]
        rev_scale, pri_scale = self.scales[revolute], self.scales[~revolute]
        rev_offset, pri_offset = self.offsets[revolute], self.offsets[~revolute]
        kernel = _jacobian_kernel()
        for start in range(0, n, BLOCK):
            block = Q[start : start + BLOCK]
            tan_half = np.ascontiguousarray((block[:, rev_cols] * (0.5 * rev_scale) + 0.5 * rev_offset).T)
            np.tan(tan_half, out=tan_half)
            values = np.ascontiguousarray((block[:, pri_cols] * pri_scale + pri_offset).T)
            kernel(tan_half, values, self.rotations, self.translations, self.identity, self.kinds, self.rows,
                   columns, self.scales, local, J[start : start + BLOCK], R[start : start + BLOCK],
                   p[start : start + BLOCK])
        return J, R, p


def _jacobian_rows(tan_half, values, rotations, translations, identity, kinds, rows, columns, scales, local, J, R_out, p_out):
    """Fill J (zeros on entry), R_out, p_out for every configuration (compiled by numba, see :func:`_kernel`)."""
    n_steps = kinds.shape[0]
    origins = np.empty((n_steps, 3))
    axes = np.empty((n_steps, 3))
    R = np.empty((3, 3))
    tmp = np.empty((3, 3))
    p = np.empty(3)
    for n in range(J.shape[0]):
        for i in range(3):
            p[i] = 0.0
            for j in range(3):
                R[i, j] = 1.0 if i == j else 0.0
        for k in range(n_steps + 1):
            t = translations[k]
            for i in range(3):  # p <- p + R t
                p[i] += R[i, 0] * t[0] + R[i, 1] * t[1] + R[i, 2] * t[2]
            if not identity[k]:  # R <- R C
                C = rotations[k]
                for i in range(3):
                    r0, r1, r2 = R[i, 0], R[i, 1], R[i, 2]
                    for j in range(3):
                        tmp[i, j] = r0 * C[0, j] + r1 * C[1, j] + r2 * C[2, j]
                for i in range(3):
                    for j in range(3):
                        R[i, j] = tmp[i, j]
            if k == n_steps:
                break
            for i in range(3):
                origins[k, i] = p[i]
                axes[k, i] = R[i, 2]
            if kinds[k] == _REVOLUTE:  # R <- R Rz(q)
                th = tan_half[rows[k], n]
                w = 2.0 / (1.0 + th * th)
                c, s = w - 1.0, th * w
                for i in range(3):
                    x, y = R[i, 0], R[i, 1]
                    R[i, 0] = x * c + y * s
                    R[i, 1] = y * c - x * s
            else:  # p <- p + q z
                v = values[rows[k], n]
                for i in range(3):
                    p[i] += v * R[i, 2]
        for k in range(n_steps):
            col, sc = columns[k], scales[k]
            z0, z1, z2 = axes[k, 0], axes[k, 1], axes[k, 2]
            if kinds[k] == _REVOLUTE:
                d0, d1, d2 = p[0] - origins[k, 0], p[1] - origins[k, 1], p[2] - origins[k, 2]
                J[n, 0, col] += sc * (z1 * d2 - z2 * d1)
                J[n, 1, col] += sc * (z2 * d0 - z0 * d2)
                J[n, 2, col] += sc * (z0 * d1 - z1 * d0)
                J[n, 3, col] += sc * z0
                J[n, 4, col] += sc * z1
                J[n, 5, col] += sc * z2
            else:
                J[n, 0, col] += sc * z0
                J[n, 1, col] += sc * z1
                J[n, 2, col] += sc * z2
        if local:  # rows R^T v, R^T w
            for col in range(J.shape[2]):
                for h in range(2):
                    a0, a1, a2 = J[n, 3 * h, col], J[n, 3 * h + 1, col], J[n, 3 * h + 2, col]
                    for i in range(3):
                        J[n, 3 * h + i, col] = R[0, i] * a0 + R[1, i] * a1 + R[2, i] * a2
        for i in range(3):
            p_out[n, i] = p[i]
            for j in range(3):
                R_out[n, i, j] = R[i, j]


_jacobian_kernel = lazy_kernel(_jacobian_rows, error_model="numpy")


# --------------------------------------------------------------------------
# The IK kernel's packing


class IKProgram(NamedTuple):
    """One chain and mode prepared for the compiled iteration (built by :class:`manipkit.ik.numerical.IKSolver`).

    A named tuple, so that a compiled loop takes the whole program as one
    argument (numba types a named tuple of arrays and numbers as one value):
    ``manipkit.ik.numerical_many``'s loop does.

    ``geometry``, ``kinds``: the chain program's :attr:`ChainProgram.ik_tables`
    (base to tip, targets are ``T_base_tip``), with ``kinds[:, 1]`` the
    solved joint's position among the solved ones (-1: not solved for);
    ``mode_code``, ``axis_index``: the mode and pointing axis; ``lower``,
    ``upper`` (rad or m), ``sample_low``, ``sample_high`` (where random starts
    are drawn: continuous joints in [-pi, pi]) and ``wrap`` (continuous
    joints, wrapped to (-pi, pi]) of the solved joints, in their order; the
    steps not solved for (floating coordinates not freed) read
    ``fixed_scale * q[fixed_columns] + fixed_offset`` (``q`` a chain vector)
    at ``fixed_steps`` of the ``n_steps``. Read by
    :meth:`~manipkit.ik.numerical.IKSolver.solve` and
    :func:`manipkit.ik.numerical_many.ik_many` alike.
    """

    geometry: np.ndarray
    kinds: np.ndarray
    mode_code: int
    axis_index: int
    lower: np.ndarray
    upper: np.ndarray
    sample_low: np.ndarray
    sample_high: np.ndarray
    wrap: np.ndarray
    fixed_steps: np.ndarray
    fixed_columns: np.ndarray
    fixed_scale: np.ndarray
    fixed_offset: np.ndarray
    n_steps: int

    @property
    def has_cs(self) -> bool:
        """Some solved joint is continuous (its answers are wrapped)."""
        return bool(self.wrap.any())


class LMOptions(NamedTuple):
    """The Levenberg-Marquardt settings of a batch in one argument of a compiled function: tolerances (m, rad),
    iterations per attempt, restarts per target, the time budget per target (s, 0: none), the initial damping and
    the stall rule (``manipkit.ik.lm_kernel.STALL_WINDOW``, ``STALL_GAIN``, ``SHRINK_MIN``)."""

    tol_position: float
    tol_rotation: float
    max_iters: int
    restarts: int
    budget: float
    tau: float
    stall_window: int
    stall_gain: float
    shrink_min: float


def pack_chain(steps: Sequence[ChainStep], chain_user_columns) -> tuple[np.ndarray, np.ndarray]:
    """(geometry (S+1, 17) float, kinds (S+1, 2) int) of base-to-tip ``steps`` for the IK kernel.

    ``steps`` are :class:`manipkit.kernels.fk.ChainStep` (the last one, index
    -1, closes the chain at the tip); ``chain_user_columns[j]`` is the joint
    value (a step's ``index``) of the ``j``-th solved joint. A row is the step's rotation
    (9, row-major), translation (3), axis (3), then the ``scale`` and
    ``offset`` of its joint value (a mimic joint reads its leader's column).
    A fixed step before a joint (a base's inverse placement, a joint inverted
    on the way up from the base) is folded into the joint's placement, so
    the kernel's rows are the joints and the tip.
    """
    column_of = {int(user): j for j, user in enumerate(chain_user_columns)}
    steps = _folded(steps)
    geometry = np.zeros((len(steps), 17))
    kinds = np.full((len(steps), 2), -1, dtype=np.int64)
    for k, step in enumerate(steps):
        geometry[k, :9] = np.asarray(step.rotation, dtype=float).ravel()
        geometry[k, 9:12] = np.asarray(step.translation, dtype=float)
        if step.index >= 0:
            geometry[k, 12:15] = np.asarray(step.axis, dtype=float)
            geometry[k, 15:17] = (step.scale, step.offset)
            kinds[k, 0] = _PRISMATIC if step.prismatic else _REVOLUTE
            kinds[k, 1] = column_of.get(int(step.index), -1)
    return geometry, kinds


def _folded(steps: Sequence[ChainStep]) -> list[ChainStep]:
    """``steps`` with every fixed step but the last multiplied into the placement of the step after it."""
    folded: list[ChainStep] = []
    C, t = None, None  # the fixed placements pending since the last joint
    for step in steps[:-1]:
        if step.index < 0:
            R, p = np.asarray(step.rotation, dtype=float), np.asarray(step.translation, dtype=float)
            C, t = (R, p) if C is None else (C @ R, t + C @ p)
            continue
        if C is not None:
            step = ChainStep(C @ step.rotation, t + C @ step.translation, step.index, step.prismatic, step.axis,
                             step.scale, step.offset)
            C, t = None, None
        folded.append(step)
    last = steps[-1]
    if C is not None:
        last = ChainStep(C @ last.rotation, t + C @ last.translation, last.index, last.prismatic, last.axis,
                         last.scale, last.offset)
    return [*folded, last]
