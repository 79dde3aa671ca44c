"""Batched forward kinematics of one serial chain, compiled once into numpy structure-of-arrays code.

Conventions (DESIGN.md), restated:

- ``Q`` has one row per configuration and one column per movable joint of the
  robot, in ``robot.joint_names`` order (radians, metres); only the chain's
  columns are read.
- The result is ``T_root_frame``, shape (N, 4, 4): the pose of the chain's
  tip frame in the frame the chain starts from (the root link, or a base
  frame above the tip: ``Robot._chain(frame_id, base_id)``), for each row
  of ``Q``.

How it is fast (:class:`ChainFK`): a chain is a product of constant
placements ``X_k = [C_k, t_k]`` and joint motions,
``T = X_0 J_0(q_0) X_1 J_1(q_1) ... X_m``. It is prepared once:

1. every joint axis ``a`` is turned into the local z axis, ``J(a, q) = A Jz(q)
   A^T`` with ``A`` a rotation taking z to ``a`` (a signed permutation when
   ``a`` lies on a coordinate axis), and ``A``, ``A^T`` are folded into the
   neighbouring constants;
2. each constant rotation is split as ``Rz(alpha) S Rz(gamma)`` where that
   makes ``S`` a signed permutation, and ``alpha``/``gamma`` become angle
   offsets of the neighbouring revolute joints (a URDF ``rpy`` yaw, a tool
   frame turned about the last axis, a DH twist of +-90 deg cost nothing);
3. the product is traced symbolically over the 9 rotation and 3 translation
   entries, each an ``offset + scale * array`` of length N (or a constant):
   entries that are 0 or +-1 are never multiplied, signs and constant scales
   stay symbolic, and what is left is a straight-line list of numpy ufunc
   calls on float64 arrays (about 20 per joint), with its temporaries packed
   into a few reused rows of a workspace (in-place where the operand dies).

``cos q`` and ``sin q`` of every revolute joint come from one ``tan(q / 2)``
per angle (``c = 2 / (1 + t^2) - 1``, ``s = t * 2 / (1 + t^2)``; numpy's
float64 ``tan`` is vectorised with SIMD where ``sin`` and ``cos`` are not),
accurate to a few units in the last place for any angle. Configurations are
processed in blocks that stay in the CPU cache; each block's 16 entries are
written to the output with one transposing copy.

The answer equals Pinocchio's ``framesForwardKinematics`` to about 1e-15
(tested to 1e-12): placement entries within 1e-14 of 0 or +-1 are taken as
exactly that (a URDF ``rpy`` of 1.5707963 leaves 6e-17 where 0 is meant).

Examples
--------
>>> import numpy as np
>>> import manipkit
>>> robot = manipkit.load("planar_2r")
>>> fk = chain_fk_for(robot, "ee_link")
>>> T = fk.transforms(np.array([[0.0, np.pi / 2]]))
>>> np.round(T[0, :2, 3], 12)
array([1., 1.])
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

__all__ = ["ChainFK", "chain_fk", "chain_fk_for"]

SNAP_TOL = 1e-14  # placement entries this close to 0 or +-1 are taken as exactly that
SPLIT_TOL = SNAP_TOL  # a rotation is split about z only if the rest is a signed permutation to this
DEFAULT_BLOCK = 8192  # configurations per block: the workspace (about 20 rows of 64 KiB) stays in L2 cache


# --------------------------------------------------------------------------
# Constant geometry: axes to z, rotations split about z


def _snap(M: np.ndarray) -> np.ndarray:
    M = np.array(M, dtype=float)
    for value in (0.0, 1.0, -1.0):
        M[np.abs(M - value) < SNAP_TOL] = value
    return M


def _rot_z(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _is_signed_permutation(M: np.ndarray, tol: float = SPLIT_TOL) -> bool:
    near = np.minimum(np.abs(M), np.abs(np.abs(M) - 1.0))
    return bool(np.all(near < tol)) and bool(np.all(np.sum(np.abs(M) > 0.5, axis=0) == 1))


def _z_to_axis(axis: np.ndarray) -> np.ndarray:
    """A rotation A with A @ e_z = axis: a signed permutation when the axis is a coordinate axis."""
    axis = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    k = int(np.argmax(np.abs(axis)))
    # Snap only when the other two entries are themselves below SNAP_TOL: |axis[k]| can round
    # to 1 while they are as large as 1e-7, which would turn the joint about the wrong axis.
    if np.delete(np.abs(axis), k).max() < SNAP_TOL:
        sign = math.copysign(1.0, axis[k])
        z = np.zeros(3)
        z[k] = sign
        x = np.zeros(3)
        x[(k + 1) % 3] = 1.0
        return np.column_stack((x, np.cross(z, x), z))
    helper = np.eye(3)[int(np.argmin(np.abs(axis)))]
    x = np.cross(helper, axis)
    x /= np.linalg.norm(x)
    return np.column_stack((x, np.cross(axis, x), axis))


def _split_about_z(C: np.ndarray, *, left: bool, right: bool) -> tuple[float, np.ndarray, float]:
    """(alpha, S, gamma) with C = Rz(alpha) S Rz(gamma), S a signed permutation when possible.

    ``left`` / ``right`` say whether a revolute z joint stands there to take
    ``alpha`` / ``gamma`` as an angle offset; a side that cannot take one gets 0.
    """
    if _is_signed_permutation(C) or not (left or right):
        return 0.0, C, 0.0
    candidates = []
    if abs(abs(C[2, 2]) - 1.0) < SPLIT_TOL:  # a turn about z, possibly after a half turn about x
        if right:
            candidates.append((0.0, math.atan2(-C[0, 1], C[0, 0])))
        if left:
            candidates.append((math.atan2(C[1, 0], C[0, 0]), 0.0))
    elif abs(C[2, 2]) < SPLIT_TOL and left and right:  # Rz(alpha) Ry(+-90 deg) Rz(gamma)
        candidates.append((math.atan2(C[1, 2], C[0, 2]), math.atan2(C[2, 1], -C[2, 0])))
    for alpha, gamma in candidates:
        S = _rot_z(-alpha) @ C @ _rot_z(-gamma)
        if _is_signed_permutation(S):
            return alpha, np.round(S), gamma
    return 0.0, C, 0.0


@dataclass
class _Segment:
    """One constant placement X = [C, t] and the joint after it (``joint`` None for the tip)."""

    C: np.ndarray
    t: np.ndarray
    joint: int | None = None  # column of Q
    prismatic: bool = False
    offset: float = 0.0  # added to the joint value (rad): a rotation about z folded into it


def _segments(steps) -> list[_Segment]:
    """Constant placements with every joint moving along/about its local z axis, offsets folded in."""
    segments: list[_Segment] = []
    C, t = np.eye(3), np.zeros(3)  # the constant product since the last joint
    A_prev_T = np.eye(3)  # A^T of the last joint, folded into what follows it
    for step in steps:
        rotation = np.asarray(step.rotation, dtype=float)
        translation = np.asarray(step.translation, dtype=float)
        t = t + C @ translation
        C = C @ rotation
        if step.index < 0:
            continue
        A = _z_to_axis(step.axis)
        segments.append(_Segment(A_prev_T @ C @ A, A_prev_T @ t, int(step.index), bool(step.prismatic)))
        C, t, A_prev_T = np.eye(3), np.zeros(3), A.T
    segments.append(_Segment(A_prev_T @ C, A_prev_T @ t))
    for k, seg in enumerate(segments):
        left = k > 0 and not segments[k - 1].prismatic
        right = seg.joint is not None and not seg.prismatic
        alpha, S, gamma = _split_about_z(_snap(seg.C), left=left, right=right)
        if alpha:
            segments[k - 1].offset += alpha
        seg.offset += gamma
        seg.C = _snap(S)
        seg.t = _snap(_rot_z(-alpha) @ seg.t)
    return segments


# --------------------------------------------------------------------------
# Symbolic entries and the straight-line program


@dataclass(frozen=True)
class _Entry:
    """``const + scale * var``; var None means the constant ``const``."""

    const: float = 0.0
    scale: float = 0.0
    var: int | None = None

    @property
    def is_zero(self) -> bool:
        return self.var is None and self.const == 0.0


_ZERO = _Entry()


class _Tracer:
    """Emits ufunc calls on numbered variables; constant folding and signs stay symbolic."""

    def __init__(self, n_inputs: int):
        self.n_vars = n_inputs  # variables 0 .. n_inputs-1 are the cos/sin/value rows
        self.ops: list[tuple[np.ufunc, object, object, int]] = []

    def _emit(self, ufunc, a, b) -> int:
        out = self.n_vars
        self.n_vars += 1
        self.ops.append((ufunc, a, b, out))
        return out

    @staticmethod
    def constant(value: float) -> _Entry:
        return _Entry(float(value))

    def scaled(self, e: _Entry, k: float) -> _Entry:
        if k == 0.0 or e.is_zero:
            return _ZERO
        return _Entry(e.const * k, e.scale * k, e.var)

    def add(self, a: _Entry, b: _Entry) -> _Entry:
        if a.var is None:
            return _Entry(a.const + b.const, b.scale, b.var)
        if b.var is None:
            return _Entry(a.const + b.const, a.scale, a.var)
        ratio = b.scale / a.scale
        if ratio == 1.0:
            var = self._emit(np.add, a.var, b.var)
        elif ratio == -1.0:
            var = self._emit(np.subtract, a.var, b.var)
        else:
            var = self._emit(np.add, a.var, self._emit(np.multiply, b.var, ratio))
        return _Entry(a.const + b.const, a.scale, var)

    def times(self, e: _Entry, var: int) -> _Entry:
        """``e * x`` for an input row ``x`` (a cosine, a sine or a joint value)."""
        if e.var is None:
            return _ZERO if e.const == 0.0 else _Entry(0.0, e.const, var)
        if e.const == 0.0:
            return _Entry(0.0, e.scale, self._emit(np.multiply, e.var, var))
        shifted = self._emit(np.add, e.var, e.const / e.scale)
        return _Entry(0.0, e.scale, self._emit(np.multiply, shifted, var))


def _trace(segments: list[_Segment]):
    """Symbolic T = X_0 J_0 X_1 J_1 ... X_m: (tracer, R entries 3x3, p entries 3, input rows)."""
    revolute = [s for s in segments if s.joint is not None and not s.prismatic]
    prismatic = [s for s in segments if s.joint is not None and s.prismatic]
    n_rev = len(revolute)
    # input rows: cos of each revolute joint, then sin, then each prismatic joint's value
    tracer = _Tracer(2 * n_rev + len(prismatic))
    rows = {}
    for i, seg in enumerate(revolute):
        rows[id(seg)] = (i, n_rev + i)
    for i, seg in enumerate(prismatic):
        rows[id(seg)] = 2 * n_rev + i
    first = segments[0]
    R = [[tracer.constant(first.C[i, j]) for j in range(3)] for i in range(3)]
    p = [tracer.constant(first.t[i]) for i in range(3)]
    for k, seg in enumerate(segments[:-1]):
        if seg.prismatic:  # p += R e_z q
            q = rows[id(seg)]
            p = [tracer.add(p[i], tracer.times(R[i][2], q)) for i in range(3)]
        else:  # R = R Rz(q): x' = x c + y s, y' = y c - x s (columns x, y of R)
            c, s = rows[id(seg)]
            for i in range(3):
                x, y = R[i][0], R[i][1]
                R[i][0] = tracer.add(tracer.times(x, c), tracer.times(y, s))
                R[i][1] = tracer.add(tracer.times(y, c), tracer.scaled(tracer.times(x, s), -1.0))
        nxt = segments[k + 1]
        for i in range(3):  # p += R t, then R = R C
            for j in range(3):
                if nxt.t[j] != 0.0:
                    p[i] = tracer.add(p[i], tracer.scaled(R[i][j], nxt.t[j]))
        R = [[_combine(tracer, R[i], nxt.C[:, j]) for j in range(3)] for i in range(3)]
    return tracer, R, p, revolute, prismatic


def _combine(tracer: _Tracer, row: list[_Entry], column: np.ndarray) -> _Entry:
    total = _ZERO
    for entry, k in zip(row, column):
        if k != 0.0:
            total = tracer.add(total, tracer.scaled(entry, k))
    return total


# --------------------------------------------------------------------------
# The prepared kernel


class ChainFK:
    """Batched FK of one chain (root to a frame), prepared once, then run on any number of rows.

    Parameters
    ----------
    steps : sequence
        The chain from the root (or a base frame), each step with ``rotation`` (3, 3) and
        ``translation`` (3,) (the constant placement in the previous joint's
        frame, applied translation first), ``index`` (column of ``Q`` of the
        joint after it, or -1 for a fixed placement, e.g. the tip frame's),
        ``prismatic`` (bool) and ``axis`` (3,) (unit, in the joint frame).
        This is what ``Robot._chain(frame_id)`` holds; see :func:`chain_fk_for`.
    n_joints : int
        Columns of ``Q`` (all of the robot's movable joints).
    block : int, keyword-only
        Configurations per block (cache-sized; the answer does not depend on it).

    Examples
    --------
    >>> import manipkit
    >>> robot = manipkit.load("iiwa14")
    >>> fk = chain_fk_for(robot, "ee_link")
    >>> Q = robot.sample_q(1000, seed=0)
    >>> T_base_ee = fk.transforms(Q)
    >>> T_base_ee.shape
    (1000, 4, 4)
    >>> bool(np.allclose(T_base_ee[7], robot.transform("base_link", "ee_link", Q[7]), atol=1e-12))
    True
    """

    def __init__(self, steps: Sequence, n_joints: int, *, block: int = DEFAULT_BLOCK):
        if block < 1:
            raise ValueError(f"block must be at least 1, got {block}")
        self.n_joints = int(n_joints)
        self.block = int(block)
        segments = _segments(steps)
        tracer, R, p, revolute, prismatic = _trace(segments)
        self.n_revolute, self.n_prismatic = len(revolute), len(prismatic)
        self._rev_cols = np.array([s.joint for s in revolute], dtype=np.intp)
        self._half_offsets = np.array([0.5 * s.offset for s in revolute])
        self._has_offsets = bool(np.any(self._half_offsets != 0.0))
        self._pri_cols = np.array([s.joint for s in prismatic], dtype=np.intp)
        self._rev_slice = _as_slice(self._rev_cols)
        self._pri_slice = _as_slice(self._pri_cols)
        outputs = [R[i][j] for i in range(3) for j in range(3)] + p
        self._ops, self._n_slots, self._finish = _allocate(tracer, outputs)
        self.n_ops = len(self._ops) + len(self._finish)  # ufunc calls per block, besides the 6 for cos/sin
        # the 16 entries of T per block (row-major), constants filled once
        self._template = np.zeros(16)
        self._template[15] = 1.0
        for k, e in enumerate(outputs):
            if e.var is None:
                self._template[_row(k)] = e.const
        self._bound: dict[int, tuple] = {}

    def __repr__(self) -> str:
        return (
            f"ChainFK({self.n_revolute} revolute, {self.n_prismatic} prismatic joints; "
            f"{self.n_ops} ufunc calls per block of {self.block})"
        )

    # --------------------------------------------------------------

    def _workspace(self, size: int):
        """Arrays and the program bound to them, for blocks of ``size`` rows (cached)."""
        bound = self._bound.get(size)
        if bound is None:
            n_rev, n_pri = self.n_revolute, self.n_prismatic
            trig = np.empty((2 * n_rev, size))  # rows: cos of each revolute joint, then sin
            half = np.empty((n_rev, size))  # q / 2, then 2 / (1 + tan^2)
            values = np.empty((n_pri, size))
            slots = np.empty((self._n_slots, size))
            out = np.empty((16, size))
            out[:] = self._template[:, None]
            rows = list(trig) + list(values)

            def ref(operand):
                kind, index = operand
                if kind == "in":
                    return rows[index]
                if kind == "slot":
                    return slots[index]
                if kind == "out":
                    return out[index]
                return index  # a float

            program = [(ufunc, ref(a), ref(b), ref(o)) for ufunc, a, b, o in self._ops + self._finish]
            bound = self._bound[size] = (trig, half, values, out, program)
        return bound

    def _run_block(self, Q_block: np.ndarray, T_block: np.ndarray) -> None:
        trig, half, values, out, program = self._workspace(Q_block.shape[0])
        n_rev = self.n_revolute
        if n_rev:
            cos, sin = trig[:n_rev], trig[n_rev:]
            np.multiply(_columns(Q_block, self._rev_slice, self._rev_cols).T, 0.5, out=half)
            if self._has_offsets:
                half += self._half_offsets[:, None]
            np.tan(half, out=sin)  # t = tan(q / 2)
            np.multiply(sin, sin, out=cos)
            cos += 1.0
            np.divide(2.0, cos, out=half)  # 2 / (1 + t^2)
            np.multiply(sin, half, out=sin)  # sin q = 2 t / (1 + t^2)
            np.subtract(half, 1.0, out=cos)  # cos q = (1 - t^2) / (1 + t^2)
        if self.n_prismatic:
            values[...] = _columns(Q_block, self._pri_slice, self._pri_cols).T
        for ufunc, a, b, o in program:
            ufunc(a, b, o)
        T_block.reshape(-1, 16)[...] = out.T

    def transforms(self, Q, out: np.ndarray | None = None) -> np.ndarray:
        """T_root_frame for every row of ``Q``.

        Parameters
        ----------
        Q : array_like, shape (N, n_joints)
            Joint vectors (radians, metres); finite values are the caller's job.
        out : ndarray, shape (N, 4, 4), optional
            Written in place and returned (C-contiguous float64).

        Returns
        -------
        T : ndarray, shape (N, 4, 4)
        """
        Q = np.asarray(Q, dtype=float)
        if Q.ndim != 2 or Q.shape[1] != self.n_joints:
            raise ValueError(f"Q must have shape (N, {self.n_joints}), got {Q.shape}")
        n = Q.shape[0]
        if out is None:
            out = np.empty((n, 4, 4))
        elif out.shape != (n, 4, 4) or out.dtype != np.float64 or not out.flags.c_contiguous:
            raise ValueError(f"out must be a C-contiguous float64 array of shape ({n}, 4, 4)")
        block = self.block
        full = n - n % block
        for start in range(0, full, block):
            self._run_block(Q[start : start + block], out[start : start + block])
        if full < n:
            self._run_block(Q[full:], out[full:])
            self._bound.pop(n - full, None)  # do not keep workspaces for odd sizes
        return out

    def rotations_translations(self, Q) -> tuple[np.ndarray, np.ndarray]:
        """(R (N, 3, 3), p (N, 3)) of T_root_frame, as views into one (N, 4, 4) array."""
        T = self.transforms(Q)
        return T[:, :3, :3], T[:, :3, 3]


def _as_slice(columns: np.ndarray):
    """A slice equal to the index array, when it is a contiguous ascending run (no copy to gather)."""
    if columns.size and np.array_equal(columns, np.arange(columns[0], columns[0] + columns.size)):
        return slice(int(columns[0]), int(columns[0]) + columns.size)
    return None


def _columns(Q_block: np.ndarray, as_slice, columns: np.ndarray) -> np.ndarray:
    return Q_block[:, as_slice] if as_slice is not None else Q_block[:, columns]


def _row(k: int) -> int:
    """Row of T (flattened 4x4) of output ``k``: R entries row-major (0..8), then p (9..11)."""
    return 4 * (k // 3) + k % 3 if k < 9 else 4 * (k - 9) + 3


def _allocate(tracer: _Tracer, outputs: list[_Entry]):
    """Map the tracer's variables to workspace rows, reusing a row as soon as its variable is dead.

    Returns (ops, number of slots, finishing ops that write the 12 outputs),
    operands as ("in", row) / ("slot", row) / ("out", row) / ("const", value).
    """
    n_inputs = tracer.n_vars - len(tracer.ops)
    ops = tracer.ops
    last_use = {}
    for i, (_, a, b, _) in enumerate(ops):
        for v in (a, b):
            if isinstance(v, int):
                last_use[v] = i
    for e in outputs:
        if e.var is not None:
            last_use[e.var] = len(ops)
    # An output that is exactly a temporary nobody else reads is written by its producing op straight
    # into the output row (a subtraction swaps its operands for a minus sign): one copy less each.
    read = {v for _, a, b, _ in ops for v in (a, b) if isinstance(v, int)}
    uses = {}
    for e in outputs:
        if e.var is not None:
            uses[e.var] = uses.get(e.var, 0) + 1
    producer = {out: i for i, (_, _, _, out) in enumerate(ops)}
    direct: dict[int, int] = {}  # op index -> output row
    done: set[int] = set()  # outputs written directly
    for k, e in enumerate(outputs):
        v = e.var
        if v is None or v < n_inputs or v in read or uses[v] != 1 or e.const != 0.0:
            continue
        i = producer[v]
        ufunc, a, b, out = ops[i]
        if e.scale == -1.0 and ufunc is np.subtract:
            ops[i] = (ufunc, b, a, out)
        elif e.scale != 1.0:
            continue
        direct[i] = _row(k)
        done.add(k)
    slot_of: dict[int, int] = {}
    free: list[int] = []
    n_slots = 0
    placed = []

    def operand(v):
        if isinstance(v, float):
            return ("const", v)
        if v < n_inputs:
            return ("in", v)
        return ("slot", slot_of[v])

    for i, (ufunc, a, b, out) in enumerate(ops):
        args = (operand(a), operand(b))
        for v in {a, b}:
            if isinstance(v, int) and v >= n_inputs and last_use[v] == i:
                free.append(slot_of[v])  # dead after this op: its row can take the result (in place)
        if i in direct:
            placed.append((ufunc, args[0], args[1], ("out", direct[i])))
            continue
        if free:
            slot_of[out] = free.pop()
        else:
            slot_of[out] = n_slots
            n_slots += 1
        if out not in last_use:  # never read (cannot happen for a traced chain, but cheap to guard)
            free.append(slot_of[out])
        placed.append((ufunc, args[0], args[1], ("slot", slot_of[out])))
    finish = []
    for k, e in enumerate(outputs):
        if e.var is None or k in done:
            continue  # constant (in the template) or already written
        row = _row(k)
        src = operand(e.var)
        if e.scale == 1.0:
            finish.append((np.add, src, ("const", e.const), ("out", row)))
        elif e.const == 0.0:
            finish.append((np.multiply, src, ("const", e.scale), ("out", row)))
        else:
            finish.append((np.multiply, src, ("const", e.scale), ("out", row)))
            finish.append((np.add, ("out", row), ("const", e.const), ("out", row)))
    return placed, n_slots, finish


# --------------------------------------------------------------------------
# Convenience


def chain_fk(steps: Sequence, Q, *, n_joints: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(R (N, 3, 3), p (N, 3)) of the chain ``steps`` for every row of ``Q`` (prepares a :class:`ChainFK`)."""
    Q = np.asarray(Q, dtype=float)
    return ChainFK(steps, Q.shape[1] if n_joints is None else n_joints).rotations_translations(Q)


def chain_fk_for(robot, frame: str) -> ChainFK:
    """The prepared :class:`ChainFK` from ``robot``'s root link to ``frame`` (rows of Q in ``robot.joint_names`` order)."""
    return ChainFK(robot._chain(robot.frame_id(frame)), len(robot.joints))
