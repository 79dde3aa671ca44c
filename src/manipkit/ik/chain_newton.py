"""Chain vectors polished by Newton steps on the true chain: :func:`newton_rows`, the IK layer's use of the one
compiled polisher (:mod:`manipkit.closed_form.newton_kernel`).

A chain of revolute joints is exactly the product of exponentials of its axes at the reference configuration
``q0`` (:class:`manipkit.ik.families.Geometry`, measured on the chain itself, locked joints folded in):
``T_base_tip(q) = E_1 ... E_n M``, ``E_i`` the rotation by ``scale[i] (q[c_i] - q0[c_i])`` about the i-th
axis. A row ``q`` is polished towards ``T`` as the angles ``theta = scale (q - q0)`` of the same product written in
the tip's frame at ``q0``, ``M^-1 T(q) = (M^-1 E_1 M) ... (M^-1 E_n M)``, towards ``g = M^-1 T``: the error is
then the tip's own (its position and rotation errors in those axes), so each step is the step of Newton on the
chain's pose error (for seven joints its least-norm step, the same in any axes). The locked joints (no axis)
stay. The caller checks the result by the chain's own FK (the polisher's residual is the
product's, within rounding of it: the product matches the chain's FK to 6.7e-15 on the xArm7's arm, so a check
tighter than about 1e-14 can drop a polished row).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from manipkit.spatial.transforms import invert_transform

if TYPE_CHECKING:
    from manipkit.ik.families import Geometry

__all__ = ["POLISH_STOP", "newton_rows"]

#: A row stops when its pose error (m plus rad, the product's) is below this.
POLISH_STOP = 1e-13


def newton_rows(geometry: Geometry, T: np.ndarray, Q: np.ndarray, *, iterations: int, stop: float = POLISH_STOP
                ) -> np.ndarray:
    """Rows ``Q`` (k, n) of the chain of ``geometry`` after at most ``iterations`` Newton steps each towards its
    target ``T`` (4, 4, or (k, 4, 4), ``T_base_tip``, m): the solved ``columns`` moved (by less than a turn from
    where they started: no wrapping), the others as given.

    >>> import manipkit
    >>> from manipkit.ik.families import chain_family
    >>> chain = manipkit.load("ur5").chain("base_link", "tool0")
    >>> q = np.array([0.1, -1.2, 1.4, -0.3, 1.1, 0.5])
    >>> rows = newton_rows(chain_family(chain).geometry, chain.fk(q), q[None] + 0.01, iterations=8)
    >>> bool(np.abs(rows - q).max() < 1e-12)
    True
    """
    from manipkit.closed_form.newton_kernel import polish_targets

    if geometry.prismatic.any() or len(geometry.columns) not in (6, 7):
        raise ValueError(f"the polisher takes 6 or 7 revolute axes, not {len(geometry.columns)} "
                         f"({int(geometry.prismatic.sum())} prismatic)")
    Q = np.array(Q, dtype=float).reshape(-1, len(geometry.q0))
    if not len(Q):
        return Q
    columns, scale = geometry.columns, geometry.scale
    theta = scale * (Q[:, columns] - geometry.q0[columns])
    R, t = geometry.M[:3, :3], geometry.M[:3, 3]  # the axes in the tip's frame at q0: T = M (M^-1 E_1 M) ... M^-1 T
    g = invert_transform(geometry.M, check=False) @ np.asarray(T, dtype=float)
    out, _, _ = polish_targets(geometry.direction @ R, (geometry.point - t) @ R, np.broadcast_to(g, (len(Q), 4, 4)),
                               theta, iterations=iterations, far=np.inf, stop=stop)
    step = np.pi - np.mod(np.pi - (out - theta), 2.0 * np.pi)  # the move, from the wrapped answer
    Q[:, columns] += step / scale
    return Q
