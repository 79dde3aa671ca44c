"""Manipulability indices, singular values and condition numbers of Jacobians, one or many at once.

Conventions (docs/architecture.md), restated:

- ``J`` has shape (6, n) or (..., 6, n): rows ``vx vy vz wx wy wz`` (the
  frame's linear velocity, m/s, then angular velocity, rad/s), as
  :func:`manipkit.kinematics.jacobian.jacobians` returns them; columns are
  joints. Every function works on the selected rows ``J_s`` (``axes``):
  ``"all"`` (rows 0-5), ``"trans"`` (0-2), ``"rot"`` (3-5) or a list of row
  numbers (``[0, 1]`` for a planar arm's vx, vy; ``[0, 1, 5]`` for vx, vy, wz).
- **Units**: linear rows are m/s per joint rate, angular rows rad/s. When the
  selection holds both (``"all"``), the angular rows are multiplied by a
  characteristic ``length`` L (m) first, so both read as m/s (``L w`` is the
  speed of a point at distance L from the axis). Without ``length`` they are
  used as they are (L = 1 m) and a :class:`MixedUnitsWarning` says so: such a
  number changes with the unit of length.
- The singular values of ``J_s`` (m rows, n columns) are the ``min(m, n)``
  values ``sigma_1 >= ... >= sigma_r``. **Yoshikawa's index** is their
  product, ``w = sigma_1 ... sigma_r``: ``sqrt(det(J_s J_s^T))`` when
  ``m <= n`` (a redundant or square selection), ``sqrt(det(J_s^T J_s))``
  when ``m > n``. So a planar 2R with ``axes="trans"`` (3 rows, vz always 0,
  2 columns) gets ``w = l1 l2 |sin q2|``: the zero row adds no singular value.
  A planar 3R with ``"trans"`` is 3 x 3 with a zero row, so ``w = 0`` at every
  configuration; select the rows of the plane (``axes=[0, 1]``, or
  ``[0, 1, 5]`` with the orientation, where ``w = l1 l2 |sin q2|`` again).
  (Robotics Toolbox's ``manipulability`` takes ``sqrt(det(J_s J_s^T))`` in
  every case, which is 0 for the 2R's ``"trans"``.)
- ``invcondition`` = ``sigma_r / sigma_1`` (in [0, 1], 1 is isotropic),
  ``minsingular`` = ``sigma_r``, ``asada`` = ``lambda_min / lambda_max`` of
  the selected rows' Cartesian inertia ``(J_s M^-1 J_s^T)^-1`` (needs the joint
  space inertia ``M``: :func:`manipkit.kinematics.jacobian.mass_matrix`).

Yoshikawa's index runs compiled (a Householder QR per Jacobian: the product
of ``|R_ii|``, exact to rounding even near a singularity, where
``sqrt(det(J J^T))`` loses half the digits); the others use numpy's SVD.

Examples
--------
>>> import numpy as np
>>> J = np.array([[-1.0, -1.0], [1.0, 0.0], [0, 0], [0, 0], [0, 0], [1.0, 1.0]])  # planar 2R at q = (0, 90 deg)
>>> float(manipulability(J, axes="trans"))  # l1 l2 |sin q2| = 1
1.0
>>> float(manipulability(J, method="invcondition", axes=[0, 1])).__round__(6)  # sqrt((3 - sqrt 5) / (3 + sqrt 5))
0.381966
"""

from __future__ import annotations

import math
import warnings
from typing import NamedTuple

import numpy as np

from manipkit.bounds import length as bounded_length
from manipkit.errors import OptionError, SingularityError
from manipkit.kernels.compile import lazy_kernel

__all__ = [
    "AXES", "METHODS", "Ellipsoid", "MixedUnitsWarning", "condition_number", "force_ellipsoid", "manipulability",
    "mixes_units", "plot_ellipsoid", "select_rows", "singular_values", "velocity_ellipsoid",
]

AXES = {"all": (0, 1, 2, 3, 4, 5), "trans": (0, 1, 2), "rot": (3, 4, 5)}
METHODS = ("yoshikawa", "invcondition", "minsingular", "asada")
ROW_NAMES = ("vx", "vy", "vz", "wx", "wy", "wz")


class MixedUnitsWarning(UserWarning):
    """Linear (m/s) and angular (rad/s) rows were combined without a characteristic length."""


# --------------------------------------------------------------------------
# Rows


def _as_jacobians(J) -> np.ndarray:
    try:
        J = np.asarray(J, dtype=float)
    except (TypeError, ValueError, OverflowError):
        raise OptionError("J must be a Jacobian of numbers, shape (6, n) or (..., 6, n)") from None
    if J.ndim < 2 or J.shape[-2] != 6:
        raise OptionError(f"J must have shape (6, n) or (..., 6, n) (rows vx vy vz wx wy wz), got {J.shape}")
    if J.shape[-1] == 0:
        raise OptionError(f"J has shape {J.shape}: no columns, so no joints to move the frame; give n >= 1")
    if not np.all(np.isfinite(J)):
        raise OptionError("J must hold finite numbers")
    return J


def _rows(axes) -> tuple[int, ...]:
    if isinstance(axes, str):
        if axes not in AXES:
            raise OptionError(f"axes={axes!r} is not one of 'all', 'trans', 'rot' or a list of rows 0-5")
        return AXES[axes]
    try:
        rows = tuple(int(r) for r in axes)
        if any(r != float(a) for r, a in zip(rows, axes)):
            raise ValueError
    except (TypeError, ValueError):
        raise OptionError(f"axes={axes!r:.60}: give 'all', 'trans', 'rot' or a list of row numbers 0-5") from None
    if not rows or any(r < 0 or r > 5 for r in rows) or len(set(rows)) != len(rows):
        raise OptionError(f"axes={list(axes)}: give distinct row numbers 0-5 (vx vy vz wx wy wz), at least one")
    return rows


def mixes_units(axes) -> bool:
    """Whether the rows ``axes`` hold both linear and angular rows (then a characteristic length is needed).

    Examples
    --------
    >>> mixes_units("all"), mixes_units("trans"), mixes_units([0, 1, 5])
    (True, False, True)
    """
    rows = _rows(axes)
    return any(r < 3 for r in rows) and any(r >= 3 for r in rows)


def select_rows(J, axes="all", length: float | None = None, *, stacklevel: int = 2) -> np.ndarray:
    """The rows ``axes`` of ``J`` (..., m, n), angular rows times ``length`` when linear ones are selected too.

    Parameters
    ----------
    J : array_like, shape (..., 6, n)
    axes : "all", "trans", "rot" or sequence of int
    length : float, optional
        Characteristic length L (m, > 0). Used only when the selection mixes
        linear and angular rows; then the angular rows become ``L w`` (m/s).
        Not given: L = 1 m with a :class:`MixedUnitsWarning`.

    Examples
    --------
    >>> J = np.arange(12.0).reshape(6, 2)
    >>> select_rows(J, [0, 5], length=0.5)
    array([[0. , 1. ],
           [5. , 5.5]])
    """
    J = _as_jacobians(J)
    rows = _rows(axes)
    if length is not None:
        length = bounded_length(length, "length")
    contiguous = rows == tuple(range(rows[0], rows[0] + len(rows)))
    selected = J[..., rows[0] : rows[0] + len(rows), :] if contiguous else J[..., list(rows), :]  # a view when it can
    if mixes_units(rows):
        if length is None:
            warnings.warn(
                "linear (m/s) and angular (rad/s) rows are combined without a characteristic length, so the "
                "result depends on the unit of length; pass length=L (m) to scale the angular rows by L, "
                "or select axes='trans' or 'rot'", MixedUnitsWarning, stacklevel=stacklevel + 1)
        elif length != 1.0:
            angular = [k for k, r in enumerate(rows) if r >= 3]
            selected = selected.copy() if contiguous else selected
            selected[..., angular, :] *= length
    return selected


# --------------------------------------------------------------------------
# Indices


def _products_of_singular_values(A, transpose, out):
    """out[k] = product of the singular values of A[k]: |prod diag(R)| of a Householder QR of A[k] (or of A[k]^T).

    The QR is of the tall one (rows >= columns): ``A[k]`` itself, or ``A[k]^T`` when ``transpose``.
    """
    rows, cols = (A.shape[2], A.shape[1]) if transpose else (A.shape[1], A.shape[2])
    work = np.empty((rows, cols))
    for k in range(A.shape[0]):
        for i in range(rows):
            for j in range(cols):
                work[i, j] = A[k, j, i] if transpose else A[k, i, j]
        product = 1.0
        for j in range(cols):
            norm2 = 0.0
            for i in range(j, rows):
                norm2 += work[i, j] * work[i, j]
            norm = math.sqrt(norm2)
            if norm == 0.0:
                product = 0.0
                break
            alpha = -norm if work[j, j] >= 0.0 else norm
            product *= norm
            # v = x - alpha e_1 (stored over the column), |v|^2 = 2 norm (norm + |x_0|)
            work[j, j] -= alpha
            v_norm2 = 2.0 * norm * (norm + abs(work[j, j] + alpha))
            for c in range(j + 1, cols):
                dot = 0.0
                for i in range(j, rows):
                    dot += work[i, j] * work[i, c]
                f = 2.0 * dot / v_norm2
                for i in range(j, rows):
                    work[i, c] -= f * work[i, j]
        out[k] = product


_kernel = lazy_kernel(_products_of_singular_values)


def _yoshikawa(Js: np.ndarray) -> np.ndarray:
    lead = Js.shape[:-2]
    m, n = Js.shape[-2:]
    flat = np.ascontiguousarray(Js).reshape(-1, m, n)
    out = np.empty(flat.shape[0])
    _kernel()(flat, m < n, out)
    return out.reshape(lead)


def singular_values(J, axes="all", length: float | None = None) -> np.ndarray:
    """Singular values (..., min(m, n)) of the selected rows, largest first (see :func:`select_rows`).

    Examples
    --------
    >>> J = np.zeros((6, 2)); J[0, 0], J[1, 1] = 3.0, 2.0
    >>> singular_values(J, "trans")
    array([3., 2.])
    """
    return np.linalg.svd(select_rows(J, axes, length, stacklevel=3), compute_uv=False)


def condition_number(J, axes="all", length: float | None = None) -> np.ndarray:
    """``sigma_1 / sigma_r`` of the selected rows (>= 1; ``inf`` at a singularity).

    Examples
    --------
    >>> J = np.zeros((6, 2)); J[0, 0], J[1, 1] = 3.0, 2.0
    >>> round(float(condition_number(J, "trans")), 12)
    1.5
    """
    s = singular_values(J, axes, length)
    with np.errstate(divide="ignore", invalid="ignore"):
        kappa = s[..., 0] / s[..., -1]
    return np.where(s[..., -1] > 0.0, kappa, np.inf)


def manipulability(J, method: str = "yoshikawa", axes="all", length: float | None = None, *,
                   inertia=None) -> np.ndarray | float:
    """A manipulability index of each Jacobian (the module docstring defines them).

    Parameters
    ----------
    J : array_like, shape (6, n) or (..., 6, n)
    method : {"yoshikawa", "invcondition", "minsingular", "asada"}
        Product of the singular values; ``sigma_min / sigma_max``;
        ``sigma_min``; Asada's ``lambda_min / lambda_max`` of the Cartesian inertia.
    axes : "all", "trans", "rot" or sequence of int
        Rows used (see :func:`select_rows`).
    length : float, optional
        Characteristic length (m) scaling the angular rows when linear ones
        are selected too; a :class:`MixedUnitsWarning` when it is needed and
        not given.
    inertia : array_like, shape (n, n) or (..., n, n), keyword-only
        Joint-space inertia matrix ``M(q)`` (for ``"asada"`` only).

    Returns
    -------
    ndarray, shape (...), or a float for one Jacobian
        Yoshikawa's index is a product of r singular values: for
        ``"trans"`` of a revolute arm, m^r (m/s per rad/s, r times); with
        ``"all"`` and a length, the angular rows count in m as well.

    Examples
    --------
    >>> J = np.zeros((6, 3)); J[0, 0], J[1, 1], J[5, 2] = 2.0, 0.5, 1.0
    >>> float(manipulability(J, axes=[0, 1, 5], length=1.0))  # vx, vy (m/s) and wz (rad/s) times 1 m
    1.0
    """
    if method not in METHODS:
        raise OptionError(f"method={method!r} is not one of {', '.join(repr(m) for m in METHODS)}")
    Js = select_rows(J, axes, length, stacklevel=2)
    if method == "yoshikawa":
        result = _yoshikawa(Js)
    elif method == "asada":
        result = _asada(Js, inertia)
    else:
        s = np.linalg.svd(Js, compute_uv=False)
        if method == "minsingular":
            result = s[..., -1]
        else:
            with np.errstate(divide="ignore", invalid="ignore"):
                result = np.where(s[..., 0] > 0.0, s[..., -1] / s[..., 0], 0.0)
    return float(result) if np.ndim(result) == 0 else result


def _asada(Js: np.ndarray, inertia) -> np.ndarray:
    """``lambda_min / lambda_max`` of ``(J_s M^-1 J_s^T)^-1``, equal to that of ``J_s M^-1 J_s^T``."""
    n = Js.shape[-1]
    if inertia is None:
        raise OptionError("method='asada' needs the joint-space inertia matrix: inertia=M (n x n), "
                            "from manipkit.kinematics.jacobian.mass_matrix(robot, q)")
    M = np.asarray(inertia, dtype=float)
    if M.shape[-2:] != (n, n):
        raise OptionError(f"inertia must have shape ({n}, {n}) or (..., {n}, {n}) for J with {n} columns, got {M.shape}")
    try:
        M_inv_Jt = np.linalg.solve(M, np.swapaxes(Js, -1, -2))
    except np.linalg.LinAlgError:
        raise SingularityError("inertia is singular: a joint-space inertia matrix is symmetric positive definite") from None
    Lambda_inv = Js @ M_inv_Jt
    eig = np.linalg.eigvalsh((Lambda_inv + np.swapaxes(Lambda_inv, -1, -2)) / 2)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(eig[..., -1] > 0.0, np.maximum(eig[..., 0], 0.0) / eig[..., -1], 0.0)


# --------------------------------------------------------------------------
# Ellipsoids


class Ellipsoid(NamedTuple):
    """A manipulability ellipsoid ``{x : x = axes diag(radii) u, |u| <= 1}`` (one or many).

    ``axes`` (..., m, m): unit principal axes as columns, in the Jacobian's
    axes (the base's for ``reference="base"``); ``radii`` (..., m), largest
    first for a velocity ellipsoid (m/s or rad/s per unit joint speed), the
    reciprocals (smallest first, ``inf`` in a singular direction) for a force
    ellipsoid (N or N m per unit joint torque).
    """

    axes: np.ndarray
    radii: np.ndarray


def _ellipsoid_svd(J, axes, length):
    Js = select_rows(J, axes, length, stacklevel=4)
    U, s, _ = np.linalg.svd(Js, full_matrices=True)
    m = Js.shape[-2]
    radii = np.zeros(Js.shape[:-2] + (m,))
    radii[..., : s.shape[-1]] = s
    return U, radii


def velocity_ellipsoid(J, axes="trans", length: float | None = None) -> Ellipsoid:
    """The velocity manipulability ellipsoid: the velocities ``J_s qdot`` for joint rates with ``|qdot| <= 1``.

    Principal axes are the left singular vectors of ``J_s``, radii its
    singular values (zero in a direction the arm cannot move: a singular
    direction, or more rows than joints).

    Examples
    --------
    >>> J = np.zeros((6, 2)); J[0, 0], J[1, 1] = 3.0, 2.0
    >>> velocity_ellipsoid(J).radii
    array([3., 2., 0.])
    """
    U, radii = _ellipsoid_svd(J, axes, length)
    return Ellipsoid(U, radii)


def force_ellipsoid(J, axes="trans", length: float | None = None) -> Ellipsoid:
    """The force manipulability ellipsoid: the forces ``f`` with ``|J_s^T f| <= 1`` (unit joint torque).

    Same axes as the velocity ellipsoid, radii ``1 / sigma_i`` (``inf`` where
    ``sigma_i = 0``: a singular direction takes any force without torque).

    Examples
    --------
    >>> J = np.zeros((6, 2)); J[0, 0], J[1, 1] = 4.0, 2.0
    >>> force_ellipsoid(J).radii
    array([0.25, 0.5 ,  inf])
    """
    U, radii = _ellipsoid_svd(J, axes, length)
    with np.errstate(divide="ignore", over="ignore"):  # a radius of 1e-310 has no finite reciprocal: inf
        return Ellipsoid(U, np.where(radii > 0.0, 1.0 / np.where(radii > 0.0, radii, 1.0), np.inf))


def plot_ellipsoid(ax, ellipsoid: Ellipsoid, center=(0.0, 0.0, 0.0), *, scale: float = 1.0, resolution: int = 24,
                   **style):
    """Draw one ellipsoid on a matplotlib axes: a 3D surface on 3D axes, else its shadow on the x-y plane.

    Parameters
    ----------
    ax : matplotlib Axes or Axes3D
        3D axes (``projection="3d"``) get a surface; 2D axes get an ellipse
        (a 2-row ellipsoid as it is, a 3-row one projected onto the first two
        coordinates: the planar arm's x-y velocities).
    ellipsoid : Ellipsoid
        One ellipsoid (``axes`` (m, m), ``radii`` (m,)), m = 2 or 3.
    center : sequence of float
        Where to draw it (the frame's origin, m).
    scale : float, keyword-only
        Multiplies the radii (a velocity ellipsoid of a 1 m arm is about 1
        m/s per rad/s; scale it to fit the drawing).
    **style
        Passed to ``plot_surface`` or ``matplotlib.patches.Ellipse``.

    Returns
    -------
    The matplotlib artist drawn.

    Raises
    ------
    OptionError, SingularityError
        Several ellipsoids, m not 2 or 3, or an infinite radius (a force
        ellipsoid at a singularity, which has no drawing).
    """
    axes_matrix, radii = np.asarray(ellipsoid.axes, dtype=float), np.asarray(ellipsoid.radii, dtype=float) * scale
    if radii.ndim != 1 or radii.shape[0] not in (2, 3) or axes_matrix.shape != (radii.shape[0],) * 2:
        raise OptionError(f"plot_ellipsoid draws one ellipsoid of 2 or 3 rows, got radii of shape {radii.shape}")
    if not np.all(np.isfinite(radii)):
        raise SingularityError("this ellipsoid has an infinite radius (a force ellipsoid at a singularity): "
                            "it cannot be drawn; draw the velocity ellipsoid instead")
    center = np.asarray(center, dtype=float)
    if getattr(ax, "name", "") == "3d":
        if radii.shape[0] != 3:
            raise OptionError("3D axes draw an ellipsoid of 3 rows (axes='trans' or 'rot')")
        u, v = np.meshgrid(np.linspace(0, 2 * np.pi, resolution), np.linspace(0, np.pi, resolution // 2 + 1))
        sphere = np.stack([np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v)])  # (3, rows, cols)
        points = np.einsum("ij,j,jkl->ikl", axes_matrix, radii, sphere) + center[:3, None, None]
        return ax.plot_surface(*points, **{"alpha": 0.3, **style})
    from matplotlib.patches import Ellipse

    shape = (axes_matrix * radii**2) @ axes_matrix.T  # x^T shape^-1 x <= 1; its shadow on x-y: the top-left 2x2
    eigenvalues, vectors = np.linalg.eigh(shape[:2, :2])
    half = np.sqrt(np.maximum(eigenvalues, 0.0))
    angle = math.degrees(math.atan2(vectors[1, 1], vectors[0, 1]))
    patch = Ellipse(tuple(center[:2]), 2 * half[1], 2 * half[0], angle=angle, **{"fill": False, **style})
    ax.add_patch(patch)
    return patch
