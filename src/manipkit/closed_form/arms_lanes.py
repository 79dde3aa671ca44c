"""The 6R closed forms of :mod:`manipkit.closed_form.arms_kernel` as straight-line code, one target per vector lane.

The same Paden-Kahan sequences as :func:`manipkit.closed_form.arms.solve_6r`
for the two 6R families (``"three parallel, two intersecting"``, the UR
arms, and ``"spherical wrist, two parallel"``, the OPW arms), with the same
operations in the same order as the reference's decisions need them, but
written without a branch or an early return: every branch of a target is
computed, and each decision the reference takes near a threshold becomes a
flag (``handed back``: the numpy reference answers that target). The loop of
:func:`ur_chunk` and :func:`opw_chunk` over :data:`LANES` targets then has
no control flow, no call and one array per direction, so the compiler runs
it on vector registers, four targets at a time (about 3x faster than one
target at a time on the machines we measure; the numbers are the same bit
for bit, as vector and scalar floating-point operations are the same IEEE
operations).

A lane writes :data:`ENTRIES` numbers at ``out[e * L + n]`` (target ``n`` of
``L``): entries ``0..47`` the sine-like and ``48..95`` the cosine-like
argument of the atan2 of angle ``j`` of branch ``slot`` (entry ``6 slot +
j``; UR: column 3 holds the turn of joints 2, 3, 4 together, from which
:func:`manipkit.closed_form.arms_kernel` takes joint 4), ``96..103`` 1.0
where branch ``slot`` is valid, ``104`` 1.0 where the reference must decide.
Branch ``slot = 4 shoulder + 2 elbow + wrist`` as the reference numbers
them. The arm comes as a tuple (:func:`arm_tuple`), so no array is passed
inside the loop. Importing this module imports numba.
"""

from __future__ import annotations

from manipkit.closed_form.subproblems_kernel import (
    MARGIN,
    NEAR,
    add,
    compile_kernel,
    dot,
    inlined_kernel,
    move,
    perpendicular,
    rotate,
    row,
    sp1,
    sp1_pair,
    sp3_squared,
    sp4,
    sub,
)

__all__ = ["ENTRIES", "LANES", "OPW_ANGLES", "OPW_COPIES", "UR_ANGLES", "UR_COPIES", "arm_tuple", "opw_chunk", "opw_lane", "opw_one", "put_lane", "ur_chunk", "ur_lane", "ur_one"]

#: Targets per chunk of :func:`ur_chunk` and :func:`opw_chunk` (a chunk's numbers, 105 x 64 x 8 bytes, stay in L1/L2).
LANES = 64
#: Numbers a lane writes per target (see the module's text).
ENTRIES = 105


def _shared_angles(clear):
    """(entries whose atan2 is taken, (entry, equal entry) pairs): angle ``j`` of branch ``slot`` is angle ``j`` of
    branch ``slot & ~clear[j]`` (the slot bits it does not depend on cleared), the same two atan2 arguments by
    construction."""
    source = [(6 * slot + j, 6 * (slot & ~clear[j]) + j) for slot in range(8) for j in range(6)]
    return tuple(e for e, s in source if e == s), tuple((e, s) for e, s in source if e != s)


#: The UR lanes' distinct angles (30 of 48) and the copies: t1 per shoulder (slot bit 4), t4's turn, t5 and t6 per
#: shoulder and wrist choice (the elbow, bit 2, does not change them).
UR_ANGLES, UR_COPIES = _shared_angles((3, 0, 0, 2, 2, 2))
#: The OPW lanes' distinct angles (34 of 48) and the copies: t1 per shoulder, t2 and t3 per shoulder and elbow choice
#: (the wrist, bit 1, does not change them).
OPW_ANGLES, OPW_COPIES = _shared_angles((3, 1, 1, 0, 0, 0))


@inlined_kernel
def arm_tuple(H, P, c, scale):
    """The ideal arm as one tuple for the lanes: (h (6 3-tuples), p (6 3-tuples), c, scale, edge, v3, v5, h45):
    axes and points, the wrist point, the arm's size, the near-miss edge (``2 NEAR scale``), unit vectors
    perpendicular to axes 4 and 6, and ``h5 . h6``."""
    h = (row(H, 0), row(H, 1), row(H, 2), row(H, 3), row(H, 4), row(H, 5))
    p = (row(P, 0), row(P, 1), row(P, 2), row(P, 3), row(P, 4), row(P, 5))
    return h, p, c, scale, 2.0 * NEAR * scale, perpendicular(h[3]), perpendicular(h[5]), dot(h[4], h[5])


@inlined_kernel
def _mv(R, x):
    """R x for R a row-major 9-tuple."""
    return (R[0] * x[0] + R[1] * x[1] + R[2] * x[2], R[3] * x[0] + R[4] * x[1] + R[5] * x[2],
            R[6] * x[0] + R[7] * x[1] + R[8] * x[2])


@inlined_kernel
def _mtv(R, x):
    """R^T x for R a row-major 9-tuple."""
    return (R[0] * x[0] + R[3] * x[1] + R[6] * x[2], R[1] * x[0] + R[4] * x[1] + R[7] * x[2],
            R[2] * x[0] + R[5] * x[1] + R[8] * x[2])


@inlined_kernel
def _put(out, n, L, slot, angles, ok):
    """Branch ``slot`` of target ``n``: its six angles' (sine-like, cosine-like) pairs and its validity."""
    b = 6 * slot
    out[b * L + n], out[(48 + b) * L + n] = angles[0], angles[1]
    out[(b + 1) * L + n], out[(49 + b) * L + n] = angles[2], angles[3]
    out[(b + 2) * L + n], out[(50 + b) * L + n] = angles[4], angles[5]
    out[(b + 3) * L + n], out[(51 + b) * L + n] = angles[6], angles[7]
    out[(b + 4) * L + n], out[(52 + b) * L + n] = angles[8], angles[9]
    out[(b + 5) * L + n], out[(53 + b) * L + n] = angles[10], angles[11]
    out[(96 + slot) * L + n] = 1.0 * ok


# ---------------------------------------------------------------------------------------------------------------
# UR family: three parallel axes (2, 3, 4), axes 5 and 6 meeting the wrist point


@inlined_kernel
def _ur_elbow(K, y1, c3, s3, ok):
    """Joint 2 of one elbow choice: (y2, x2, handed back, valid)."""
    h, p, scale, edge = K[0], K[1], K[3], K[4]
    elbow = move(h[2], p[2], c3, s3, p[3])
    y2, x2, size2, miss2 = sp1_pair(h[1], sub(elbow, p[1]), y1)
    back = (size2 <= MARGIN) | (ok & (miss2 > 1e-11 * scale) & (miss2 <= edge))
    return y2, x2, back, ok & (miss2 <= 1e-9 * scale)


@inlined_kernel
def _ur_wrist(K, R, t, c1, s1, c5, s5, wanted, count5):
    """Joints 6, 3 (both elbows), 2 and the turn of 2-4 of one joint-5 choice."""
    h, p, edge, v3 = K[0], K[1], K[4], K[5]
    c6, minus_s6, size6, _ = sp1(h[5], rotate(h[4], c5, -s5, h[1]), wanted)
    s6 = -minus_s6
    x = move(h[5], p[5], c6, -s6, move(h[4], p[4], c5, -s5, p[3]))
    y1 = sub(move(h[0], p[0], c1, -s1, add(_mv(R, x), t)), p[1])
    c3a, s3a, c3b, s3b, count3, miss3, unsure3 = sp3_squared(h[2], sub(p[3], p[2]), sub(p[1], p[2]), dot(y1, y1))
    # size6 <= MARGIN: axis 6 along the parallel axes, t6 free (the reference picks the member)
    back = (size6 <= MARGIN) | unsure3 | ((count3 == 0.0) & (miss3 <= edge))
    # the angle about h2 of R1^T R_g R6^T R5^T (the turn of joints 2, 3, 4 together)
    u0 = rotate(h[0], c1, -s1, _mv(R, rotate(h[5], c6, -s6, rotate(h[4], c5, -s5, v3))))
    yt, xt, _, _ = sp1_pair(h[1], v3, u0)
    ok = (count5 > 0.0) & (count3 > 0.0)
    ya, xa, back_a, ok_a = _ur_elbow(K, y1, c3a, s3a, ok)
    yb, xb, back_b, ok_b = _ur_elbow(K, y1, c3b, s3b, ok)
    return ((c6, s6, yt, xt, c3a, s3a, c3b, s3b, ya, xa, yb, xb), back | back_a | back_b, ok_a, ok_b)


@inlined_kernel
def _ur_shoulder(K, R, t, c1, s1, Rgh6):
    """The four branches of one joint-1 choice: their angles (slots ``2 elbow + wrist``; each six (sine-like,
    cosine-like) pairs: t1, t2, t3, the turn of 2-4, t5, t6), validity, and whether the reference must decide."""
    h, edge = K[0], K[4]
    x5 = rotate(h[0], c1, -s1, Rgh6)  # R1^T R_g h6
    wanted = _mtv(R, rotate(h[0], c1, s1, h[1]))  # R_g^T R1 h2
    c5a, s5a, c5b, s5b, count5, miss5, unsure5 = sp4(h[1], h[4], h[5], dot(x5, h[1]))
    back = unsure5 | ((count5 == 0.0) & (miss5 <= edge))
    A, back_a, ok_aa, ok_ab = _ur_wrist(K, R, t, c1, s1, c5a, s5a, wanted, count5)
    B, back_b, ok_ba, ok_bb = _ur_wrist(K, R, t, c1, s1, c5b, s5b, wanted, count5)
    angles = ((s1, c1, A[8], A[9], A[5], A[4], A[2], A[3], s5a, c5a, A[1], A[0]),
              (s1, c1, B[8], B[9], B[5], B[4], B[2], B[3], s5b, c5b, B[1], B[0]),
              (s1, c1, A[10], A[11], A[7], A[6], A[2], A[3], s5a, c5a, A[1], A[0]),
              (s1, c1, B[10], B[11], B[7], B[6], B[2], B[3], s5b, c5b, B[1], B[0]))
    return angles, (ok_aa, ok_ba, ok_ab, ok_bb), back | back_a | back_b


@inlined_kernel
def ur_lane(K, R, t):
    """Every branch of one UR target (``R`` row-major 9-tuple, ``t`` 3-tuple, in the solve frame): (angles, valid,
    handed back) of the two joint-1 choices (:func:`_ur_shoulder`'s), for :func:`put_lane`."""
    h, p, c = K[0], K[1], K[2]
    w = add(_mv(R, c), t)
    ca, sa, cb, sb, count1, miss1, unsure = sp4(h[1], h[0], sub(w, p[0]), dot(h[1], sub(c, p[0])))
    Rgh6 = _mv(R, h[5])
    angles_a, ok_a, back_a = _ur_shoulder(K, R, t, ca, -sa, Rgh6)  # t1 = -theta of subproblem 4
    angles_b, ok_b, back_b = _ur_shoulder(K, R, t, cb, -sb, Rgh6)
    return angles_a, angles_b, ok_a, ok_b, unsure | (count1 == 0.0) | back_a | back_b


# ---------------------------------------------------------------------------------------------------------------
# OPW family: spherical wrist at c, axes 2 and 3 parallel


@inlined_kernel
def _opw_wrist(K, x, rv, c4, s4):
    """Joints 5 and 6 of one joint-4 choice (``c4``, ``s4``: the angle -t4): (s5, c5, y6, x6, size5, miss5)."""
    h, v5 = K[0], K[6]
    c5, s5, size5, miss5 = sp1(h[4], h[5], rotate(h[3], c4, s4, x))
    turned = rotate(h[4], c5, -s5, rotate(h[3], c4, s4, rv))
    y6, x6, _, _ = sp1_pair(h[5], v5, turned)
    return s5, c5, y6, x6, size5, miss5


@inlined_kernel
def _opw_elbow(K, s1, c1, x1, v1, w1, c3, s3, count3):
    """The two wrist branches of one shoulder and elbow choice: their angles (t1, t2, t3, t4, t5, t6 as
    (sine-like, cosine-like) pairs), validity (the same for both), and whether the reference must decide."""
    h, p, c, scale, edge, h45 = K[0], K[1], K[2], K[3], K[4], K[7]
    elbow = move(h[2], p[2], c3, s3, c)
    c2, s2, size2, miss2 = sp1(h[1], sub(elbow, p[1]), sub(w1, p[1]))
    arm_ok = count3 > 0.0
    back = (size2 <= MARGIN) | (arm_ok & (miss2 > 1e-11 * scale) & (miss2 <= edge))
    arm_ok = arm_ok & (miss2 <= 1e-9 * scale)
    # R_rem = (R1 R2 R3)^T R_g: x = R_rem h6, and R_rem v
    x = rotate(h[2], c3, -s3, rotate(h[1], c2, -s2, x1))
    rv = rotate(h[2], c3, -s3, rotate(h[1], c2, -s2, v1))
    # subproblem 2: R(h4, -t4) x = R(h5, t5) h6
    c4a, s4a, c4b, s4b, count4, miss4, unsure4 = sp4(h[4], h[3], x, h45)
    back = back | unsure4 | ((count4 == 0.0) & (miss4 <= edge))
    s5a, c5a, y6a, x6a, size5a, miss5a = _opw_wrist(K, x, rv, c4a, s4a)
    s5b, c5b, y6b, x6b, size5b, miss5b = _opw_wrist(K, x, rv, c4b, s4b)
    # sp2's sqrt(tol) acceptance: the pair's first member decides (handed back near its edge)
    back = back | (size5a <= MARGIN) | (size5b <= MARGIN)
    back = back | ((count4 > 0.0) & (miss5a > 1e-10) & (miss5a <= 2e-6))
    ok = arm_ok & (count4 > 0.0) & (not (miss5a > 1e-6))
    return ((s1, c1, s2, c2, s3, c3, -s4a, c4a, s5a, c5a, y6a, x6a),
            (s1, c1, s2, c2, s3, c3, -s4b, c4b, s5b, c5b, y6b, x6b)), ok, back


@inlined_kernel
def _opw_shoulder(K, c1, s1, w, Rgh6, Rgv):
    """The four branches of one joint-1 choice (slots ``2 elbow + wrist``): angles, validity, handed back."""
    h, p, c, edge = K[0], K[1], K[2], K[4]
    w1 = move(h[0], p[0], c1, -s1, w)
    x1, v1 = rotate(h[0], c1, -s1, Rgh6), rotate(h[0], c1, -s1, Rgv)
    reach = sub(w1, p[1])
    c3a, s3a, c3b, s3b, count3, miss3, unsure3 = sp3_squared(h[2], sub(c, p[2]), sub(p[1], p[2]), dot(reach, reach))
    back = unsure3 | ((count3 == 0.0) & (miss3 <= edge))
    A, ok_a, back_a = _opw_elbow(K, s1, c1, x1, v1, w1, c3a, s3a, count3)
    B, ok_b, back_b = _opw_elbow(K, s1, c1, x1, v1, w1, c3b, s3b, count3)
    return (A[0], A[1], B[0], B[1]), (ok_a, ok_a, ok_b, ok_b), back | back_a | back_b


@inlined_kernel
def opw_lane(K, R, t):
    """Every branch of one OPW target (``R`` row-major 9-tuple, ``t`` 3-tuple, in the solve frame): as
    :func:`ur_lane`."""
    h, p, c, v5 = K[0], K[1], K[2], K[6]
    w = add(_mv(R, c), t)
    ca, sa, cb, sb, count1, miss1, unsure = sp4(h[1], h[0], sub(w, p[0]), dot(h[1], sub(c, p[0])))
    Rgh6, Rgv = _mv(R, h[5]), _mv(R, v5)
    angles_a, ok_a, back_a = _opw_shoulder(K, ca, -sa, w, Rgh6, Rgv)
    angles_b, ok_b, back_b = _opw_shoulder(K, cb, -sb, w, Rgh6, Rgv)
    return angles_a, angles_b, ok_a, ok_b, unsure | (count1 == 0.0) | back_a | back_b


@inlined_kernel
def put_lane(out, n, L, lane):
    """A lane's answer (:func:`ur_lane`, :func:`opw_lane`) into ``out[e * L + n]`` (see the module's text)."""
    angles_a, angles_b, ok_a, ok_b, back = lane
    _put(out, n, L, 0, angles_a[0], ok_a[0])
    _put(out, n, L, 1, angles_a[1], ok_a[1])
    _put(out, n, L, 2, angles_a[2], ok_a[2])
    _put(out, n, L, 3, angles_a[3], ok_a[3])
    _put(out, n, L, 4, angles_b[0], ok_b[0])
    _put(out, n, L, 5, angles_b[1], ok_b[1])
    _put(out, n, L, 6, angles_b[2], ok_b[2])
    _put(out, n, L, 7, angles_b[3], ok_b[3])
    out[104 * L + n] = 1.0 * (back | (not (ok_a[0] | ok_a[1] | ok_a[2] | ok_a[3] | ok_b[0] | ok_b[1] | ok_b[2]
                                             | ok_b[3])))


@inlined_kernel
def _lane_target(G, n, L):
    """Target ``n`` of a chunk ``G`` (12 L,): entry ``i`` of the top three rows of its 4 x 4 at ``G[i L + n]``."""
    R = (G[n], G[L + n], G[2 * L + n], G[4 * L + n], G[5 * L + n], G[6 * L + n], G[8 * L + n], G[9 * L + n],
         G[10 * L + n])
    return R, (G[3 * L + n], G[7 * L + n], G[11 * L + n])


@compile_kernel
def ur_chunk(K, G, out):
    """:func:`ur_lane` on the :data:`LANES` targets of ``G`` (12 LANES,) into ``out`` (ENTRIES LANES,)."""
    for n in range(LANES):
        R, t = _lane_target(G, n, LANES)
        put_lane(out, n, LANES, ur_lane(K, R, t))


@compile_kernel
def opw_chunk(K, G, out):
    """:func:`opw_lane` on the :data:`LANES` targets of ``G`` (12 LANES,) into ``out`` (ENTRIES LANES,)."""
    for n in range(LANES):
        R, t = _lane_target(G, n, LANES)
        put_lane(out, n, LANES, opw_lane(K, R, t))


@compile_kernel
def ur_one(K, R, t, out):
    """:func:`ur_lane` on one target into ``out`` (ENTRIES,) (compiled once, called by the one-target loops)."""
    put_lane(out, 0, 1, ur_lane(K, R, t))


@compile_kernel
def opw_one(K, R, t, out):
    """:func:`opw_lane` on one target into ``out`` (ENTRIES,)."""
    put_lane(out, 0, 1, opw_lane(K, R, t))
