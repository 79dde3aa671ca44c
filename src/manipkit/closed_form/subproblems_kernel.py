"""The Paden-Kahan subproblems on scalars and 3-tuples, compiled with numba: the pieces of the closed forms' loops.

The same subproblems as :mod:`manipkit.closed_form.subproblems` (which
broadcasts over arrays of targets), written for one target at a time so a
compiled loop (:mod:`manipkit.closed_form.arms_kernel`,
:mod:`manipkit.closed_form.srs_kernel`) solves a target with no allocation:
angles are carried as cosine and sine, one :func:`atan2` per output angle.
Near a threshold (a tangency, a degenerate rotation) :func:`sp4` and
:func:`sp3` say ``unsure``: the caller then hands the target back to the
numpy reference, which decides. Importing this module imports numba.
"""

from __future__ import annotations

import math

from manipkit.kernels import compile_kernel as _compile


def compile_kernel(py_func, **options):
    """:func:`manipkit.kernels.compile_kernel` with numpy's error model, for every kernel of the closed forms: a
    division by zero gives inf or nan (as in numpy) instead of raising ZeroDivisionError, so no division carries a
    check (a third of the cost of the chain rows' loop). No division here can be by zero (each is guarded, or by a
    joint's nonzero scale); one that were would give nan, which fails every check and leaves the target to the
    reference path."""
    return _compile(py_func, error_model="numpy", **options)

def _sqrt_intrinsic():
    """The IEEE square root as LLVM's ``llvm.sqrt.f64`` instruction, for :func:`sqrt`."""
    from llvmlite import ir
    from numba import types
    from numba.extending import intrinsic

    @intrinsic
    def llvm_sqrt(typingctx, x):
        def codegen(context, builder, signature, args):
            function = builder.module.declare_intrinsic("llvm.sqrt", [ir.DoubleType()])
            return builder.call(function, [args[0]])

        return types.float64(types.float64), codegen

    return llvm_sqrt


_llvm_sqrt = _sqrt_intrinsic()


def inlined_kernel(py_func):
    """:func:`compile_kernel` with ``inline="always"``: numba puts the body into each caller (LLVM leaves these calls
    in place otherwise, each with numba's call convention: a returned status and the tuple through memory)."""
    return compile_kernel(py_func, inline="always")



__all__ = ["MARGIN", "NEAR", "TANGENT", "TOL", "add", "atan2", "compile_kernel", "cross", "dot", "inlined_kernel", "move", "mtv", "mv", "norm", "perpendicular",
           "rotate", "row", "sp1", "sp1_pair", "sqrt", "sp3", "sp3_squared", "sp4", "sub", "wrap", "wrap_by_selects"]

#: How close (relative to the arm's size) a decision may come to its threshold before the reference path decides.
MARGIN = 1e-8
#: How close to tangent (relative to the arm's size) a subproblem 3 or 4 may come before the reference decides.
#: Smaller than MARGIN: the two paths' roundings differ by about 1e-16 of the size there, and between 1e-10 and
#: 1e-8 from tangent their two near-equal angles still agree to about 1e-11 rad (the angle's sensitivity,
#: 1e-16 / sqrt(2 1e-10)); at 1e-8, arms' near-singular targets (the elbow within 3e-4 rad of straight, the wrist
#: centre within 1e-8 m of the shoulder's cylinder) went to the reference's per-call cost of about 2 ms.
TANGENT = 1e-10
TOL = 1e-12  # the subproblems' zero, as the reference's (arms.solve_6r's tol)
NEAR = 1e-6  # arms.NEAR
TWO_PI = 2.0 * math.pi
# Cephes' atan (Moshier, cephes/cmath/atan.c): P/Q on [0, 0.66] after the reduction, and pi/4's low bits
_P0, _P1, _P2, _P3, _P4 = (-8.750608600031904122785e-1, -1.615753718733365076637e1, -7.500855792314704667340e1,
                           -1.228866684490136173410e2, -6.485021904942025371773e1)
_Q0, _Q1, _Q2, _Q3, _Q4 = (2.485846490142306297962e1, 1.650270098316988542046e2, 4.328810604912902668951e2,
                           4.853903996359136964868e2, 1.945506571482613964425e2)
_MOREBITS = 6.123233995736765886130e-17


@compile_kernel
def dot(a, b):
    """a . b of 3-tuples."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@compile_kernel
def cross(a, b):
    """a x b of 3-tuples."""
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@compile_kernel
def sub(a, b):
    """a - b of 3-tuples."""
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


@compile_kernel
def add(a, b):
    """a + b of 3-tuples."""
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


@inlined_kernel
def sqrt(x):
    """The square root of float ``x``: the same correctly rounded IEEE operation as ``math.sqrt`` (nan below 0),
    as an instruction. numba lowers ``math.sqrt`` to a call into libm, which LLVM turns into the instruction only
    where it proves ``x >= 0`` (libm may set errno); one call left in a loop keeps it off the vector registers
    (:mod:`manipkit.closed_form.arms_lanes`)."""
    return _llvm_sqrt(x)


@compile_kernel
def norm(a):
    """|a| of a 3-tuple."""
    return sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])


@compile_kernel
def wrap(x):
    """x wrapped to (-pi, pi]: x itself when inside (no remainder to take: it costs a call into numba's fmod)."""
    if -math.pi < x <= math.pi:
        return x
    return math.pi - (math.pi - x) % TWO_PI


@inlined_kernel
def wrap_by_selects(x):
    """(:func:`wrap` of ``x``, exact): the same number bit for bit, chosen by selects with no branch and no call
    into fmod (so a loop over many angles runs on vector registers), where ``pi - x`` lies in [-2 pi, 4 pi)
    (``exact`` False elsewhere, and for nan). There the remainder ``(pi - x) % 2 pi`` of numba (CPython's rule:
    ``fmod``, then ``+ 2 pi`` when its sign is not the divisor's, ``+0.0`` for a zero) is ``r - 2 pi`` for ``r``
    in [2 pi, 4 pi) (exact, by Sterbenz's lemma, as fmod is), ``r`` in [0, 2 pi), ``r + 2 pi`` (the same addition)
    for ``r`` in [-2 pi, 0); ``r - 2 pi`` would not be exact below ``-2 pi``, so that range is not taken."""
    r = math.pi - x
    m = r - TWO_PI if r >= TWO_PI else (r + TWO_PI if r < 0.0 else r)
    inside = (x > -math.pi) & (x <= math.pi)
    return x if inside else math.pi - m, (r >= -TWO_PI) & (r < 2.0 * TWO_PI)


@compile_kernel
def rotate(k, c, s, p):
    """R(k, t) p (Rodrigues) with c = cos t, s = sin t, as subproblems.rotate."""
    kp = dot(k, p)
    kx = cross(k, p)
    return (c * p[0] + s * kx[0] + (1.0 - c) * kp * k[0],
            c * p[1] + s * kx[1] + (1.0 - c) * kp * k[1],
            c * p[2] + s * kx[2] + (1.0 - c) * kp * k[2])


@compile_kernel
def move(h, p, c, s, x):
    """E(t) x: x turned by t (c = cos t, s = sin t) about the line through p along h."""
    return add(p, rotate(h, c, s, sub(x, p)))


@compile_kernel
def mv(R, x):
    """R x for a (3, 3) array R."""
    return (R[0, 0] * x[0] + R[0, 1] * x[1] + R[0, 2] * x[2],
            R[1, 0] * x[0] + R[1, 1] * x[1] + R[1, 2] * x[2],
            R[2, 0] * x[0] + R[2, 1] * x[1] + R[2, 2] * x[2])


@compile_kernel
def mtv(R, x):
    """R^T x for a (3, 3) array R."""
    return (R[0, 0] * x[0] + R[1, 0] * x[1] + R[2, 0] * x[2],
            R[0, 1] * x[0] + R[1, 1] * x[1] + R[2, 1] * x[2],
            R[0, 2] * x[0] + R[1, 2] * x[1] + R[2, 2] * x[2])


@inlined_kernel
def _sp1_parts(k, p, q):
    """(X, Y, size, miss) of subproblem 1: cos and sin of the angle times X's and Y's norm r, |p off the axis|,
    and |R(k, t) p - q| at the best angle (``hypot(|p_perp| - |q_perp|, k.p - k.q)``: R turns p_perp onto q_perp's
    direction). Where the angle is held 0 (size within TOL, or r = 0) miss is ``|p - q|``."""
    kp, kq = dot(k, p), dot(k, q)
    pp = (p[0] - kp * k[0], p[1] - kp * k[1], p[2] - kp * k[2])
    qp = (q[0] - kq * k[0], q[1] - kq * k[1], q[2] - kq * k[2])
    size, size_q = norm(pp), norm(qp)
    X, Y = dot(pp, qp), dot(k, cross(pp, qp))
    if size <= TOL or X * X + Y * Y == 0.0:  # r = 0 as sp1 takes it (also when the squares underflow)
        return 0.0, 0.0, size, norm(sub(p, q))
    d_perp, d_axis = size - size_q, kp - kq
    return X, Y, size, sqrt(d_perp * d_perp + d_axis * d_axis)


@inlined_kernel
def sp1(k, p, q):
    """Subproblem 1 as subproblems.sp1: (c, s, size, miss) of the angle t with R(k, t) p = q (see _sp1_parts);
    the angle is free, held 0, where size is within TOL."""
    X, Y, size, miss = _sp1_parts(k, p, q)
    r = sqrt(X * X + Y * Y)
    if r == 0.0:
        return 1.0, 0.0, size, miss
    return X / r, Y / r, size, miss


@inlined_kernel
def sp1_pair(k, p, q):
    """:func:`sp1` as (Y, X, size, miss): the unnormalised sine and cosine of its angle, ``atan2(Y, X)``, for a
    caller that takes the atan2 later (no square root, no division; (0, 1) where sp1 holds the angle 0)."""
    X, Y, size, miss = _sp1_parts(k, p, q)
    if X * X + Y * Y == 0.0:
        return 0.0, 1.0, size, miss
    return Y, X, size, miss


@inlined_kernel
def _atan_ratio(n, d):
    """atan(n / d) for 0 <= n <= d, d > 0 (Cephes' atan: reduction at 0.66, a rational of degree 4/5; within 2 ulp).

    Without a branch and with one division for the argument: ``big`` (0 or 1) selects the reduction
    ``(n - d) / (n + d)`` (atan(x) = pi/4 + atan((x - 1) / (x + 1)), n - d exact there) by arithmetic that gives
    n / d itself for 0, so no misprediction is paid (random targets' angles fall either side)."""
    if d < 1e-290 or d > 1e290:  # far from 1 (never in the loops): scaled by an exact power of 2, so 0.66 d and
        scale = 2.0 ** 600 if d < 1.0 else 2.0 ** -600  # n + d neither round as subnormals nor overflow
        n, d = n * scale, d * scale
    big = 1.0 if n > 0.66 * d else 0.0
    x = (n - big * d) / (big * n + d)
    z = x * x
    num = (((_P0 * z + _P1) * z + _P2) * z + _P3) * z + _P4
    den = ((((z + _Q0) * z + _Q1) * z + _Q2) * z + _Q3) * z + _Q4
    return big * (0.25 * math.pi) + (x * (z * num / den) + x + big * (0.5 * _MOREBITS))


@inlined_kernel
def atan2(y, x):
    """atan2(y, x) in [-pi, pi] as math.atan2 to 2 ulp (numba's call into libm costs about twice as much).

    The octant is applied by exact arithmetic on 0/1 flags (``s pi/2 + (1 - 2 s) a``), not by branches: the
    angles of random targets fall in any octant, and a mispredicted branch costs as much as the polynomial."""
    ay, ax = abs(y), abs(x)
    if ay == 0.0 and ax == 0.0:
        return math.copysign(math.pi, y) if math.copysign(1.0, x) < 0.0 else math.copysign(0.0, y)
    swap = 1.0 if ay > ax else 0.0
    a = _atan_ratio(min(ay, ax), max(ay, ax))
    a = swap * (0.5 * math.pi) + (1.0 - 2.0 * swap) * a
    back = 1.0 if math.copysign(1.0, x) < 0.0 else 0.0
    a = back * math.pi + (1.0 - 2.0 * back) * a
    return math.copysign(a, y)


@inlined_kernel
def sp4(h, k, p, d):
    """Subproblem 4 (h . R(k, t) p = d) as subproblems.sp4 away from its thresholds:
    (ca, sa, cb, sb, count, miss, unsure) with angles ``phi + spread`` and ``phi - spread``;
    ``unsure``: degenerate within ``MARGIN`` or tangent within ``TANGENT`` (the reference decides there)."""
    kp = dot(k, p)
    A = h[0] * (p[0] - kp * k[0]) + h[1] * (p[1] - kp * k[1]) + h[2] * (p[2] - kp * k[2])
    B = dot(h, cross(k, p))
    C = d - dot(h, k) * kp
    r = sqrt(A * A + B * B)  # not math.hypot (a call into libm): A, B are lengths near 1, no overflow
    scale = max(1.0, r)
    gap = abs(C) - r
    unsure = r <= MARGIN * scale or abs(gap) <= TANGENT * scale
    if r == 0.0:
        return 1.0, 0.0, 1.0, 0.0, 0.0, abs(C), True
    cphi, sphi = A / r, B / r
    ci = min(1.0, max(-1.0, C / r))
    si = sqrt(1.0 - ci * ci)
    count = 0.0 if gap > TOL * scale else 2.0
    miss = gap if count == 0.0 else 0.0
    return cphi * ci - sphi * si, sphi * ci + cphi * si, cphi * ci + sphi * si, sphi * ci - cphi * si, count, miss, unsure


@compile_kernel
def sp3(k, p1, p2, delta):
    """Subproblem 3 (|R(k, t) p1 - p2| = delta) as subproblems.sp3: (ca, sa, cb, sb, count, miss, unsure)."""
    return sp3_squared(k, p1, p2, delta * delta)


@inlined_kernel
def sp3_squared(k, p1, p2, delta2):
    """:func:`sp3` given delta squared (``delta2``; a caller with a squared distance takes no square root)."""
    d = 0.5 * (dot(p1, p1) + dot(p2, p2) - delta2)
    ca, sa, cb, sb, count, miss, unsure = sp4(p2, k, p1, d)
    if count == 0.0:
        delta = sqrt(delta2)
        ra = norm(sub(rotate(k, ca, sa, p1), p2))
        rb = norm(sub(rotate(k, cb, sb, p1), p2))
        miss = min(abs(ra - delta), abs(rb - delta))
    return ca, sa, cb, sb, count, miss, unsure


@compile_kernel
def perpendicular(h):
    a = (abs(h[0]), abs(h[1]), abs(h[2]))
    i = 0
    if a[1] < a[i]:
        i = 1
    if a[2] < a[i]:
        i = 2
    e = (1.0 if i == 0 else 0.0, 1.0 if i == 1 else 0.0, 1.0 if i == 2 else 0.0)
    v = cross(h, e)
    n = norm(v)
    return (v[0] / n, v[1] / n, v[2] / n)


@compile_kernel
def row(H, i):
    """Row i of a (m, 3) array as a 3-tuple."""
    return (H[i, 0], H[i, 1], H[i, 2])
