"""Batched forward kinematics of one serial chain, run by one compiled loop over configurations.

Conventions (docs/architecture.md), restated:

- ``Q`` has one row per configuration and one column per joint value the
  steps index (a :class:`manipkit.kinematics.chain.Chain`'s program: its
  chain vector, radians and metres).
- The result is ``T_base_tip``, shape (N, 4, 4): the pose of the chain's
  tip frame in its base frame, for each row of ``Q``.
- A chain is a list of :class:`ChainStep`: constant placements and the
  joints between them, from the base to the tip (up the tree from the base
  and down again, when base and tip are on different branches).

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
3. the rotation ``R`` of the running product is kept as three stored columns
   with labels: column ``j`` of ``R`` is ``sign[j] * stored[col[j]]``. A
   signed permutation ``S`` only relabels (``R S`` costs nothing at run
   time); a general rotation mixes the stored columns once (27 multiplications)
   and resets the labels. A sign between the two columns a joint turns is
   folded into the joint's angle, a sign on a translation into the constant.

What is left per configuration is, for each joint, ``R <- R Rz(q)`` on two
stored columns (12 multiplications) or ``p += q z`` (3), and ``p += R t``
for the nonzero entries of each ``t`` (3 each): about 115 multiplications for
a 7-joint arm. :func:`_poses` runs them compiled with numba, one step at a
time over a chunk of 256 configurations held as structure of arrays in the L1
cache, so that each step's loop over configurations is vectorised (SIMD);
the last loop writes the (N, 4, 4) output.

``cos q`` and ``sin q`` of every revolute joint come from one ``tan(q / 2)``
per angle (``c = 2 / (1 + t^2) - 1``, ``s = t * 2 / (1 + t^2)``; numpy's
float64 ``tan`` is vectorised with SIMD where ``sin`` and ``cos`` are not),
accurate to a few units in the last place for any angle; ``tan`` runs in
numpy on blocks of rows, the rest in the compiled loop. numba is imported
and the loop compiled (or loaded from numba's cache) when a :class:`ChainFK`
first runs, not when this module is imported.

The compiled kernels (this loop and those of :mod:`manipkit.ik.lm_kernel`)
are made by :func:`manipkit.kernels.compile.compile_kernel`: numba's on-disk
cache when it works, else compiled in memory with one warning. numpy, numba
and :mod:`manipkit.errors` only: a :class:`manipkit.kinematics.chain.Chain`
builds its program here (:mod:`manipkit.kernels.program`).

The answer equals Pinocchio's ``framesForwardKinematics`` to about 1e-15
(tested to 1e-12): placement entries within 1e-14 of 0 or +-1 are taken as
exactly that (a URDF ``rpy`` of 1.5707963 leaves 6e-17 where 0 is meant).

Examples
--------
A planar 2R arm with unit links (joint 2 one metre out along x, the tip one
metre further):

>>> import numpy as np
>>> z = np.array([0.0, 0.0, 1.0])
>>> steps = [ChainStep(np.eye(3), np.zeros(3), 0, False, z), ChainStep(np.eye(3), np.array([1.0, 0, 0]), 1, False, z),
...          ChainStep(np.eye(3), np.array([1.0, 0, 0]), -1, False, None)]
>>> T = ChainFK(steps, 2).transforms(np.array([[0.0, np.pi / 2]]))
>>> np.round(T[0, :2, 3], 12)
array([1., 1.])
"""

from __future__ import annotations

import math
import threading
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from manipkit.errors import ChainError, IKOptionError, JointValueError
from manipkit.kernels.compile import lazy_kernel

__all__ = [
    "MAX_THREADS", "ChainFK", "ChainStep", "chain_fk", "pose_rows", "pose_rows_kernel", "row_tables", "snap_placement",
    "thread_count", "z_to_axis",
]

#: Most threads a compiled batch (``ik_many``, ``chain_ik_many``) uses by default: the cores it may run on, up to this.
MAX_THREADS = 8

SNAP_TOL = 1e-14  # placement entries this close to 0 or +-1 are taken as exactly that
SPLIT_TOL = SNAP_TOL  # a rotation is split about z only if the rest is a signed permutation to this
DEFAULT_BLOCK = 8192  # rows per numpy tan call (the angles of a block stay in L2 cache)
CHUNK = 256  # configurations per pass of the compiled loop (R and p of a chunk, 24 KiB, stay in L1 cache)
_REVOLUTE, _PRISMATIC = 0, 1


def thread_count(threads) -> int:
    """Threads a compiled batch (``ik_many``, ``chain_ik_many``) runs on: ``threads`` checked (a whole number
    >= 1), or for None the cores this process may run on (its CPU affinity), at most :data:`MAX_THREADS`.

    Raises :class:`manipkit.errors.IKOptionError` for anything else (the batches are IK's).
    """
    import numbers
    import os

    if threads is None:
        cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
        return max(1, min(MAX_THREADS, cores))
    if isinstance(threads, bool) or not isinstance(threads, numbers.Integral) or threads < 1:
        raise IKOptionError(f"threads must be a whole number of threads, at least 1, or None; got {threads!r}")
    return int(threads)


# --------------------------------------------------------------------------
# The chain: constant placements and the joints between them


@dataclass(frozen=True)
class ChainStep:
    """One factor of a chain's pose product ``T_base_frame = S_0 S_1 ... S_m``.

    A step is the constant placement ``[rotation, translation]`` (the
    translation applied first, in the previous joint's frame, metres),
    followed, for a joint step, by the joint's motion: a turn of ``q``
    radians about ``axis`` (revolute) or a shift of ``q`` metres along it
    (prismatic), ``q`` being column ``index`` of the robot's joint vector
    (``robot.joint_names`` order). A fixed step (``index == -1``, ``axis``
    None) is a placement only: the frame's own placement closes every chain,
    and a base frame's inverse placement opens a chain that starts below
    the root (:meth:`manipkit.kinematics.robot.Robot.chain`).

    Attributes
    ----------
    rotation : ndarray, shape (3, 3)
        Constant rotation of the step's frame in the previous joint's frame.
    translation : ndarray, shape (3,)
        Constant translation (m), in the previous joint's frame.
    index : int
        Column of the joint after the placement, or -1 for a fixed step.
    prismatic : bool
        The joint slides (m) instead of turning (rad).
    axis : ndarray, shape (3,), or None
        Unit joint axis in the joint's own frame (None for a fixed step).
    scale, offset : float
        The joint's value is ``scale * q[index] + offset`` (rad or m): 1 and
        0 for an independent joint; a URDF ``<mimic>`` joint reads its
        leader's column with the mimic's ``multiplier`` and ``offset``.
    """

    rotation: np.ndarray
    translation: np.ndarray
    index: int
    prismatic: bool
    axis: np.ndarray | None
    scale: float = 1.0
    offset: float = 0.0


# --------------------------------------------------------------------------
# Constant geometry: axes to z, rotations split about z


def snap_placement(M: np.ndarray) -> np.ndarray:
    """A copy of ``M`` with entries within :data:`SNAP_TOL` of 0 or +-1 set to exactly that.

    A URDF ``rpy`` of 1.5707963 leaves 6e-17 where 0 is meant; snapped, a
    rotation about a coordinate axis is recognised as a signed permutation.
    """
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


def z_to_axis(axis: np.ndarray) -> np.ndarray:
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
    offset: float = 0.0  # added to the joint value (rad or m): a mimic's offset, a rotation about z folded into it
    multiplier: float = 1.0  # the joint value is multiplier * Q[:, joint] + offset (a mimic joint's multiplier)


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
        A = z_to_axis(step.axis)
        segments.append(_Segment(A_prev_T @ C @ A, A_prev_T @ t, int(step.index), bool(step.prismatic),
                                 float(step.offset), float(step.scale)))
        C, t, A_prev_T = np.eye(3), np.zeros(3), A.T
    segments.append(_Segment(A_prev_T @ C, A_prev_T @ t))
    for k, seg in enumerate(segments):
        left = k > 0 and not segments[k - 1].prismatic
        right = seg.joint is not None and not seg.prismatic
        alpha, S, gamma = _split_about_z(snap_placement(seg.C), left=left, right=right)
        if alpha:
            segments[k - 1].offset += alpha
        seg.offset += gamma
        seg.C = snap_placement(S)
        seg.t = snap_placement(_rot_z(-alpha) @ seg.t)
    return segments


# --------------------------------------------------------------------------
# The kernel's tables: stored columns of R, relabelled by signed permutations


@dataclass
class _Program:
    """What :func:`_poses` runs, for a chain of n joints (see the module docstring, step 3).

    ``R0`` (3, 3) and ``p0`` (3,) are ``X_0`` (``R0[c]`` is stored column ``c``);
    joint ``k`` is ``joints[k] = (kind, a, b, row)``: a revolute joint turns
    stored columns ``a`` (x) and ``b`` (y) by angle row ``row``, a prismatic
    joint moves ``p`` along stored column ``a`` by value row ``row``; then
    ``X_{k+1}``: ``p += sum_c shifts[k, c] * stored[c]``, and if ``mixed[k]``,
    ``stored[c] <- sum_d mixes[k, d, c] * stored[d]``. At the end, column
    ``j`` of ``R`` is ``out_signs[j] * stored[out_cols[j]]``. Each joint value
    is multiplied by ``scales[k]`` (+-1) before use.
    """

    R0: np.ndarray
    p0: np.ndarray
    joints: np.ndarray  # (n, 4) int
    scales: np.ndarray  # (n,)
    shifts: np.ndarray  # (n, 3)
    mixes: np.ndarray  # (n, 3, 3)
    mixed: np.ndarray  # (n,) bool
    out_cols: np.ndarray  # (3,) int
    out_signs: np.ndarray  # (3,)


def _program(segments: list[_Segment]) -> _Program:
    """The tables of :class:`_Program` for ``segments`` (from :func:`_segments`): signed permutations become labels."""
    n = len(segments) - 1
    joints = np.zeros((n, 4), dtype=np.int64)
    scales, shifts = np.ones(n), np.zeros((n, 3))
    mixes, mixed = np.zeros((n, 3, 3)), np.zeros(n, dtype=bool)
    col, sign = [0, 1, 2], [1.0, 1.0, 1.0]  # column j of R is sign[j] * stored[col[j]]
    n_rev = n_pri = 0
    for k, (seg, nxt) in enumerate(zip(segments[:-1], segments[1:])):
        if seg.prismatic:  # p += q R e_z = (sign[2] q) stored[col[2]]
            joints[k] = (_PRISMATIC, col[2], -1, n_pri)
            scales[k], n_pri = sign[2], n_pri + 1
        else:  # x' = x c + y s, y' = y c - x s; on the stored columns the same with s -> sign[0] sign[1] s
            joints[k] = (_REVOLUTE, col[0], col[1], n_rev)
            scales[k], n_rev = sign[0] * sign[1], n_rev + 1
        for j in range(3):  # p += R t
            shifts[k, col[j]] += sign[j] * nxt.t[j]
        if _is_signed_permutation(nxt.C):  # R S: column j of R S is S[i, j] * column i of R, i = perm[j]
            perm = np.argmax(np.abs(nxt.C), axis=0)
            sign = [float(np.sign(nxt.C[perm[j], j])) * sign[perm[j]] for j in range(3)]
            col = [col[perm[j]] for j in range(3)]
        else:  # R C: stored[c] <- sum over j of sign[j] C[j, c] stored[col[j]]
            for j in range(3):
                mixes[k, col[j]] = sign[j] * nxt.C[j]
            mixed[k] = True
            col, sign = [0, 1, 2], [1.0, 1.0, 1.0]
    return _Program(np.ascontiguousarray(segments[0].C.T), segments[0].t.copy(), joints, scales, shifts,
                    mixes, mixed, np.array(col, dtype=np.int64), np.array(sign))


def _poses(tan_half, values, R0, p0, joints, shifts, mixes, mixed, out_cols, out_signs, T):
    """Write T[n] = X_0 J_0 X_1 ... X_m for every configuration n (compiled by numba, see :func:`_kernel`).

    ``tan_half[r, n]`` is ``tan(q / 2)`` of revolute joint row ``r`` (offset
    and sign folded in), ``values[r, n]`` the value of prismatic joint row
    ``r`` (sign folded in); the other arguments are those of :class:`_Program`.
    Configurations are taken ``CHUNK`` at a time; every loop over ``j`` (the
    configurations of a chunk) reads and writes rows of ``R`` and ``p``, so it
    is vectorised.
    """
    R = np.empty((3, 3, CHUNK))  # R[c, i, j]: entry i of stored column c, configuration j
    p = np.empty((3, CHUNK))
    for start in range(0, T.shape[0], CHUNK):
        m = min(CHUNK, T.shape[0] - start)
        for i in range(3):
            p[i, :m] = p0[i]
            for c in range(3):
                R[c, i, :m] = R0[c, i]
        for k in range(joints.shape[0]):
            kind, a, b, row = joints[k, 0], joints[k, 1], joints[k, 2], joints[k, 3]
            if kind == _REVOLUTE:  # R <- R Rz(q) on stored columns a (x) and b (y)
                t = tan_half[row, start : start + m]
                X, Y = R[a], R[b]
                for j in range(m):
                    w = 2.0 / (1.0 + t[j] * t[j])
                    cos, sin = w - 1.0, t[j] * w
                    for i in range(3):
                        x, y = X[i, j], Y[i, j]
                        X[i, j] = x * cos + y * sin
                        Y[i, j] = y * cos - x * sin
            else:  # p <- p + q z
                v = values[row, start : start + m]
                Z = R[a]
                for j in range(m):
                    for i in range(3):
                        p[i, j] += Z[i, j] * v[j]
            for c in range(3):  # p <- p + R t
                d = shifts[k, c]
                if d != 0.0:
                    S = R[c]
                    for j in range(m):
                        for i in range(3):
                            p[i, j] += S[i, j] * d
            if mixed[k]:  # R <- R C, C not a signed permutation
                M = mixes[k]
                for j in range(m):
                    for i in range(3):
                        r0, r1, r2 = R[0, i, j], R[1, i, j], R[2, i, j]
                        for c in range(3):
                            R[c, i, j] = r0 * M[0, c] + r1 * M[1, c] + r2 * M[2, c]
        for j in range(m):
            n = start + j
            for i in range(3):
                for c in range(3):
                    T[n, i, c] = out_signs[c] * R[out_cols[c], i, j]
                T[n, i, 3] = p[i, j]
                T[n, 3, i] = 0.0
            T[n, 3, 3] = 1.0




# error_model="numpy": a float division by zero gives inf instead of raising; the check for it would keep LLVM
# from vectorising the loops (a division by 1 + t^2 >= 1 never takes it anyway)
# nogil: the loop touches no Python object, so threads (the closed forms' batched check) may run it at once
_kernel = lazy_kernel(_poses, error_model="numpy", nogil=True)


# --------------------------------------------------------------------------
# The prepared kernel


class ChainFK:
    """Batched FK of one chain (base to tip), prepared once, then run on any number of rows.

    Parameters
    ----------
    steps : sequence of ChainStep
        The chain from the base to the tip (``Chain.program.steps``).
    n_joints : int
        Columns of ``Q`` (the joint values the steps index).
    block : int, keyword-only
        Rows per numpy ``tan`` call (cache-sized; the answer does not depend on it).

    Attributes
    ----------
    n_ops : int
        Multiplications per configuration in the compiled loop, besides ``cos`` and ``sin``.

    Examples
    --------
    >>> import manipkit
    >>> chain = manipkit.load("iiwa14").chain("base_link", "ee_link")
    >>> fk = ChainFK(chain.program.steps, chain.n)
    >>> Q = chain.sample(1000, seed=0)
    >>> T_base_ee = fk.transforms(Q)
    >>> T_base_ee.shape
    (1000, 4, 4)
    >>> bool(np.allclose(T_base_ee[7], chain.robot.transform("base_link", "ee_link", chain.full(Q[7])), atol=1e-12))
    True
    """

    def __init__(self, steps: Sequence[ChainStep], n_joints: int, *, block: int = DEFAULT_BLOCK):
        if block < 1:
            raise ChainError(f"block must be at least 1 row, got {block}")
        self.n_joints = int(n_joints)
        self.block = int(block)
        segments = _segments(steps)
        program = self._program = _program(segments)
        joints = segments[:-1]
        revolute = np.array([not s.prismatic for s in joints], dtype=bool)
        self.n_revolute, self.n_prismatic = int(revolute.sum()), int((~revolute).sum())
        self._rev_cols = np.array([s.joint for s in joints if not s.prismatic], dtype=np.intp)
        self._pri_cols = np.array([s.joint for s in joints if s.prismatic], dtype=np.intp)
        self._rev_slice = _as_slice(self._rev_cols)
        self._pri_slice = _as_slice(self._pri_cols)
        # tan(half) with half = scale * (multiplier q + offset) / 2; prismatic values the same without the half
        multipliers = np.array([s.multiplier for s in joints])
        offsets = np.array([s.offset for s in joints])
        self._half_scales = 0.5 * program.scales[revolute] * multipliers[revolute]
        self._half_offsets = 0.5 * offsets[revolute] * program.scales[revolute]
        self._has_offsets = bool(np.any(self._half_offsets != 0.0))
        self._pri_scales = program.scales[~revolute] * multipliers[~revolute]
        self._pri_offsets = offsets[~revolute] * program.scales[~revolute]
        self._has_pri_offsets = bool(np.any(self._pri_offsets != 0.0))
        # R Rz(q): 12, p += q z: 3, each nonzero entry of a t: 3, a general R C: 27, the signs of the output: 9
        self.n_ops = (12 * self.n_revolute + 3 * self.n_prismatic + 3 * int(np.count_nonzero(program.shifts))
                      + 27 * int(program.mixed.sum()) + 9)
        # Scratch arrays per block size, per thread: a ChainFK is shared (robot.chain caches it), so two
        # threads running it at once must not write the same buffers.
        self._workspace = threading.local()

    def __repr__(self) -> str:
        return (
            f"ChainFK({self.n_revolute} revolute, {self.n_prismatic} prismatic joints; "
            f"{self.n_ops} multiplications per configuration)"
        )

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        del state["_workspace"]
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._workspace = threading.local()

    def _buffers(self) -> dict[int, tuple[np.ndarray, np.ndarray]]:
        """This thread's scratch arrays, by block size."""
        cache = getattr(self._workspace, "buffers", None)
        if cache is None:
            cache = self._workspace.buffers = {}
        return cache

    def _run_block(self, kernel, Q_block: np.ndarray, T_block: np.ndarray) -> None:
        size = Q_block.shape[0]
        cache = self._buffers()
        buffers = cache.get(size)
        if buffers is None:
            buffers = cache[size] = (np.empty((self.n_revolute, size)), np.empty((self.n_prismatic, size)))
        tan_half, values = buffers
        if self.n_revolute:
            np.multiply(_columns(Q_block, self._rev_slice, self._rev_cols).T, self._half_scales[:, None], out=tan_half)
            if self._has_offsets:
                tan_half += self._half_offsets[:, None]
            np.tan(tan_half, out=tan_half)
        if self.n_prismatic:
            np.multiply(_columns(Q_block, self._pri_slice, self._pri_cols).T, self._pri_scales[:, None], out=values)
            if self._has_pri_offsets:
                values += self._pri_offsets[:, None]
        P = self._program
        kernel(tan_half, values, P.R0, P.p0, P.joints, P.shifts, P.mixes, P.mixed, P.out_cols, P.out_signs, T_block)

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
            raise JointValueError(f"Q must have shape (N, {self.n_joints}), got {Q.shape}")
        n = Q.shape[0]
        if out is None:
            out = np.empty((n, 4, 4))
        elif out.shape != (n, 4, 4) or out.dtype != np.float64 or not out.flags.c_contiguous:
            raise JointValueError(f"out must be a C-contiguous float64 array of shape ({n}, 4, 4), one pose per row of Q")
        kernel = _kernel()
        block = self.block
        full = n - n % block
        for start in range(0, full, block):
            self._run_block(kernel, Q[start : start + block], out[start : start + block])
        if full < n:
            self._run_block(kernel, Q[full:], out[full:])
            self._buffers().pop(n - full, None)  # do not keep buffers for odd sizes
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


# --------------------------------------------------------------------------
# Convenience


def chain_fk(steps: Sequence[ChainStep], Q, *, n_joints: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(R (N, 3, 3), p (N, 3)) of the chain ``steps`` for every row of ``Q`` (prepares a :class:`ChainFK`)."""
    Q = np.asarray(Q, dtype=float)
    return ChainFK(steps, Q.shape[1] if n_joints is None else n_joints).rotations_translations(Q)


# --------------------------------------------------------------------------
# One configuration at a time, from inside another compiled loop (the closed forms' check of every branch)


def row_tables(fk: ChainFK) -> tuple[np.ndarray, np.ndarray]:
    """The program of the batched FK ``fk`` packed as (floats, ints), for :func:`pose_rows`.

    The rows :func:`pose_rows` takes are the rows ``fk`` takes (a chain's:
    chain vectors). The preparation is ``fk``'s own (axes turned to z,
    rotations split about z, signed permutations as labels), laid out in two
    flat arrays so a compiled caller passes the chain in two arguments; a
    chain packs it once (``ChainProgram.row_tables``). ``ints``: ``[m, n_rev,
    n_pri]``, then ``joints`` (m, 4), ``mixed`` (m,), ``out_cols`` (3), the
    revolute then prismatic entries of the joint vector; ``floats``: ``R0``
    (9), ``p0`` (3), ``out_signs`` (3), ``shifts`` (m, 3), ``mixes`` (m, 3,
    3), then the revolute joints' half scales and half offsets, the prismatic
    joints' scales and offsets (the joint value rules of :class:`ChainFK`).
    """
    P = fk._program
    m = P.joints.shape[0]
    ints = np.concatenate([[m, fk.n_revolute, fk.n_prismatic], P.joints.reshape(-1), P.mixed.astype(np.int64),
                           P.out_cols, fk._rev_cols, fk._pri_cols]).astype(np.int64)
    floats = np.concatenate([P.R0.reshape(-1), P.p0, P.out_signs, P.shifts.reshape(-1), P.mixes.reshape(-1),
                             fk._half_scales, fk._half_offsets, fk._pri_scales, fk._pri_offsets]).astype(float)
    return floats, ints


def pose_rows(Q, present, floats, ints, states, out):
    """Write ``out[r]`` (4, 4) = T_base_tip of every joint vector ``Q[r]`` (K, n) with ``present[r]``, by the tables
    of :func:`row_tables`; other entries of ``out`` are not written.

    The computation of :func:`_poses` for one configuration at a time
    (``cos q`` and ``sin q`` from ``tan(q / 2)``, as :class:`ChainFK` takes
    them; equal to it to a few units in the last place). ``states`` is
    (m + 1, 4, 3) scratch, ``m`` the program's joints: ``states[k]`` holds
    the three stored columns and the position before joint step ``k``. A
    row starts again from the previous present row's state at its first
    step whose joint value differs (bit for bit; the first present row from
    the base): a step's state depends only on the state before it and its
    joint value, so the poses are those of each row alone, bit for bit
    (tested), and branches of one target that share their first joints
    (a closed form's shoulder) pay for them once. Compiled by
    :func:`pose_rows_kernel`, it is called from other compiled loops.
    """
    m, n_rev = ints[0], ints[1]  # joints, revolute joints
    j0 = 3  # offsets of the tables in ints, then in floats
    mix0 = j0 + 4 * m
    oc = mix0 + m
    rc = oc + 3
    pc = rc + n_rev
    s0 = 15
    x0 = s0 + 3 * m
    h0 = x0 + 9 * m
    v0 = h0 + 2 * n_rev
    for c in range(3):
        for i in range(3):
            states[0, c, i] = floats[3 * c + i]
        states[0, 3, c] = floats[9 + c]
    previous = -1
    for r in range(Q.shape[0]):
        if not present[r]:
            continue
        first = 0  # the first step whose joint value differs from the previous row's (same bits: -0.0 is not 0.0)
        while previous >= 0 and first < m:
            entry = ints[j0 + 4 * first + 3]
            column = ints[rc + entry] if ints[j0 + 4 * first] == _REVOLUTE else ints[pc + entry]
            a, b = Q[r, column], Q[previous, column]
            if not (a == b and math.copysign(1.0, a) == math.copysign(1.0, b)):
                break
            first += 1
        for k in range(first, m):  # states[k + 1] = step k of states[k] (indexed whole: a view costs two atomic counts)
            e = k + 1
            for c in range(4):
                for i in range(3):
                    states[e, c, i] = states[k, c, i]
            kind, a, b, row = ints[j0 + 4 * k], ints[j0 + 4 * k + 1], ints[j0 + 4 * k + 2], ints[j0 + 4 * k + 3]
            if kind == _REVOLUTE:
                t = math.tan(Q[r, ints[rc + row]] * floats[h0 + row] + floats[h0 + n_rev + row])
                w = 2.0 / (1.0 + t * t)
                cos, sin = w - 1.0, t * w
                for i in range(3):
                    x, y = states[e, a, i], states[e, b, i]
                    states[e, a, i] = x * cos + y * sin
                    states[e, b, i] = y * cos - x * sin
            else:
                v = Q[r, ints[pc + row]] * floats[v0 + row] + floats[v0 + ints[2] + row]
                for i in range(3):
                    states[e, 3, i] += states[e, a, i] * v
            for c in range(3):
                d = floats[s0 + 3 * k + c]
                if d != 0.0:
                    for i in range(3):
                        states[e, 3, i] += states[e, c, i] * d
            if ints[mix0 + k]:
                base = x0 + 9 * k
                for i in range(3):
                    r0, r1, r2 = states[e, 0, i], states[e, 1, i], states[e, 2, i]
                    for c in range(3):
                        states[e, c, i] = r0 * floats[base + c] + r1 * floats[base + 3 + c] + r2 * floats[base + 6 + c]
        for i in range(3):
            for c in range(3):
                out[r, i, c] = floats[12 + c] * states[m, ints[oc + c], i]
            out[r, i, 3] = states[m, 3, i]
            out[r, 3, i] = 0.0
        out[r, 3, 3] = 1.0
        previous = r


pose_rows_kernel = lazy_kernel(pose_rows, error_model="numpy")
