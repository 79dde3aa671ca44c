"""Orientation bins of a reachability map: approach directions times rolls, or turns about a planar arm's axis.

Conventions (docs/site/internals/reach-maps.md):

- Rotations are ``R_base_frame`` (3x3, columns the frame's axes in the base
  frame). The **approach axis** is the frame's z axis (column 2), as in
  capability maps (Zacharias et al. 2007) and ROS grasp frames.
- **Spatial**: ``n_directions`` approach directions spread evenly on the
  unit sphere by the Fibonacci lattice (:func:`fibonacci_directions`), each
  with ``n_rolls`` rolls about it. A rotation falls in the bin of the nearest
  direction (largest dot product with its z axis) and of the nearest roll,
  the roll being the angle of its x axis about that direction measured from
  the direction's reference axis (:attr:`OrientationSet.references`).
  ``n_rolls = 1`` ignores the roll: the bin is the approach direction alone.
- **Planar** (every joint axis parallel to one axis ``a``): the frame turns
  only about ``a``; its orientation is one angle ``phi`` about ``a`` (the
  angle of a fixed frame vector perpendicular to ``a``, measured from the
  plane's ``u`` axis), cut into ``n`` equal bins centred on ``k 2 pi / n``.
- :meth:`OrientationSet.rotations` gives each bin's representative rotation
  (the bin's centre), which falls in its own bin.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = [
    "OrientationSet", "fibonacci_directions", "nearest_direction", "perpendicular", "planar_orientations",
    "spatial_orientations",
]

GOLDEN_ANGLE = math.pi * (3.0 - math.sqrt(5.0))  # rad, about 137.5 degrees


def fibonacci_directions(n: int) -> np.ndarray:
    """(n, 3) unit vectors spread evenly on the sphere (the Fibonacci lattice), +z first.

    Point ``i`` has ``z = 1 - (2 i + 1) / n`` and azimuth ``i`` times the
    golden angle, so every point stands for the same area ``4 pi / n``.

    >>> d = fibonacci_directions(200)
    >>> d.shape, bool(np.allclose(np.linalg.norm(d, axis=1), 1.0)), bool(abs(d.mean(axis=0)).max() < 1e-2)
    ((200, 3), True, True)
    """
    i = np.arange(n, dtype=float)
    z = 1.0 - (2.0 * i + 1.0) / n
    rho = np.sqrt(np.maximum(1.0 - z * z, 0.0))
    azimuth = i * GOLDEN_ANGLE
    return np.column_stack([rho * np.cos(azimuth), rho * np.sin(azimuth), z])


def perpendicular(d) -> np.ndarray:
    """(..., 3) unit vectors perpendicular to the unit vectors ``d``: ``unit(d x e)``, ``e`` the world x axis, or y near x.

    >>> perpendicular(np.array([0.0, 0.0, 1.0]))
    array([0., 1., 0.])
    """
    d = np.asarray(d, dtype=float)
    e = np.where(np.abs(d[..., :1]) < 0.9, [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    c = np.cross(d, e)
    return c / np.linalg.norm(c, axis=-1, keepdims=True)


def _nearest_rows(V, D, out):
    """``out[i] = argmax_j V[i] . D[j]`` (the first on a tie), without the (N, M) matrix of dot products."""
    for i in range(V.shape[0]):
        v0, v1, v2 = V[i, 0], V[i, 1], V[i, 2]
        best, best_j = -np.inf, 0
        for j in range(D.shape[0]):
            dot = v0 * D[j, 0] + v1 * D[j, 1] + v2 * D[j, 2]
            if dot > best:
                best, best_j = dot, j
        out[i] = best_j


_NEAREST = None


def nearest_direction(v, directions) -> np.ndarray:
    """(...,) index of the direction (rows of ``directions``, (M, 3)) with the largest dot product with each ``v`` (..., 3).

    Compiled (numba, :func:`manipkit.kernels.compile.compile_kernel`): the
    same answer as ``argmax(v @ directions.T)`` without its (N, M) matrix.

    >>> int(nearest_direction(np.array([0.1, 0.0, 1.0]), np.eye(3)))
    2
    """
    global _NEAREST
    if _NEAREST is None:
        from manipkit.kernels.compile import compile_kernel

        _NEAREST = compile_kernel(_nearest_rows)
    v = np.asarray(v, dtype=float)
    flat = np.ascontiguousarray(v.reshape(-1, 3))
    out = np.empty(flat.shape[0], dtype=np.int64)
    _NEAREST(flat, np.ascontiguousarray(directions, dtype=float), out)
    return out.reshape(v.shape[:-1])


@dataclass(frozen=True, eq=False)
class OrientationSet:
    """The orientation bins of a map (see the module docstring for both kinds).

    Attributes
    ----------
    kind : {"spatial", "planar"}
    n_directions, n_rolls : int
        Spatial: approach directions and rolls about each. Planar: 1 and the
        number of turns about the axis.
    directions, references : ndarray, shape (n_directions, 3)
        Spatial: unit approach directions and the unit reference axis (roll 0)
        perpendicular to each, in the base frame. Planar: the axis ``a`` and ``u``.
    axis : ndarray, shape (3,), or None
        Planar: the common joint axis ``a`` in the base frame.
    tool_axis : ndarray, shape (3,), or None
        Planar: the frame's own vector (in its axes) along ``a``, the same in
        every configuration.
    tool_vector : ndarray, shape (3,), or None
        Planar: the frame vector (in the frame's own axes, perpendicular to
        ``tool_axis``) whose angle about ``a`` is the orientation.
    """

    kind: str
    n_directions: int
    n_rolls: int
    directions: np.ndarray
    references: np.ndarray
    axis: np.ndarray | None = None
    tool_axis: np.ndarray | None = None
    tool_vector: np.ndarray | None = None

    @property
    def size(self) -> int:
        """Number of bins (``n_directions * n_rolls``)."""
        return self.n_directions * self.n_rolls

    @property
    def label(self) -> str:
        """``"200x1"`` (directions x rolls) or ``"36 about the axis"``."""
        return f"{self.n_rolls} about the axis" if self.kind == "planar" else f"{self.n_directions}x{self.n_rolls}"

    def bin_of(self, R) -> np.ndarray:
        """(...,) int bin of each rotation ``R`` (..., 3, 3) (``R_base_frame``), by the rules of the module docstring."""
        R = np.asarray(R, dtype=float)
        if self.kind == "planar":
            u, a = self.references[0], self.axis
            w = R @ self.tool_vector
            phi = np.arctan2(w @ np.cross(a, u), w @ u)
            return np.mod(np.rint(phi * (self.n_rolls / (2.0 * math.pi))), self.n_rolls).astype(np.int64)
        z = R[..., :, 2]
        direction = nearest_direction(z, self.directions)
        if self.n_rolls == 1:
            return direction.astype(np.int64)
        d, r = self.directions[direction], self.references[direction]
        x = R[..., :, 0]
        psi = np.arctan2(np.einsum("...i,...i->...", np.cross(d, r), x), np.einsum("...i,...i->...", r, x))
        roll = np.mod(np.rint(psi * (self.n_rolls / (2.0 * math.pi))), self.n_rolls).astype(np.int64)
        return direction * self.n_rolls + roll

    def rotations(self) -> np.ndarray:
        """(size, 3, 3) the representative rotation (bin centre) of each bin, in bin order."""
        angles = 2.0 * math.pi * np.arange(self.n_rolls) / self.n_rolls
        c, s = np.cos(angles), np.sin(angles)
        if self.kind == "planar":
            u, a = self.references[0], self.axis
            v = np.cross(a, u)
            b = self.tool_axis
            w = self.tool_vector
            tool_basis = np.column_stack([w, np.cross(b, w), b])
            out = np.empty((self.n_rolls, 3, 3))
            for k in range(self.n_rolls):
                u_k = c[k] * u + s[k] * v
                out[k] = np.column_stack([u_k, np.cross(a, u_k), a]) @ tool_basis.T
            return out
        d = self.directions[:, None, :]
        r = self.references[:, None, :]
        x = c[None, :, None] * r + s[None, :, None] * np.cross(d, r)
        d = np.broadcast_to(d, x.shape)
        out = np.stack([x, np.cross(d, x), d], axis=-1)  # columns x, y = z cross x, z = d
        return out.reshape(self.size, 3, 3)

    def attrs(self) -> dict:
        """The set as JSON-ready values (for a map's metadata); :func:`from_attrs` rebuilds it."""
        out = {"kind": self.kind, "n_directions": self.n_directions, "n_rolls": self.n_rolls}
        if self.kind == "planar":
            out.update(axis=self.axis.tolist(), u=self.references[0].tolist(), tool_axis=self.tool_axis.tolist(),
                       tool_vector=self.tool_vector.tolist())
        return out

    @staticmethod
    def from_attrs(attrs: dict) -> OrientationSet:
        """The set described by :meth:`attrs`."""
        if attrs["kind"] == "planar":
            return planar_orientations(int(attrs["n_rolls"]), np.array(attrs["axis"]), np.array(attrs["u"]),
                                       np.array(attrs["tool_axis"]), np.array(attrs["tool_vector"]))
        return spatial_orientations(int(attrs["n_directions"]), int(attrs["n_rolls"]))


def spatial_orientations(n_directions: int, n_rolls: int = 1) -> OrientationSet:
    """Fibonacci approach directions times ``n_rolls`` rolls (see the module docstring).

    >>> bins = spatial_orientations(20, 4)
    >>> R = bins.rotations()
    >>> bins.size, bool(np.array_equal(bins.bin_of(R), np.arange(20 * 4)))
    (80, True)
    """
    directions = fibonacci_directions(n_directions)
    return OrientationSet("spatial", n_directions, n_rolls, directions, perpendicular(directions))


def planar_orientations(n: int, axis, u, tool_axis, tool_vector) -> OrientationSet:
    """``n`` turns about the unit ``axis`` (base frame), angle 0 where ``tool_vector`` (frame axes) points along ``u``.

    ``tool_axis`` is the frame's own vector along ``axis`` (constant for a
    planar arm), ``tool_vector`` a unit vector perpendicular to it.

    >>> bins = planar_orientations(8, [0, 0, 1.0], [1.0, 0, 0], [0, 0, 1.0], [1.0, 0, 0])
    >>> bool(np.array_equal(bins.bin_of(bins.rotations()), np.arange(8)))
    True
    """
    a = np.asarray(axis, dtype=float)
    u = np.asarray(u, dtype=float)
    return OrientationSet("planar", 1, int(n), a[None, :], u[None, :], a, np.asarray(tool_axis, dtype=float),
                          np.asarray(tool_vector, dtype=float))
