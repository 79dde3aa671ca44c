"""A reach map's payload layer: per voxel the best and worst payload capacity, and what a pose can carry.

(docs/site/guides/reach.md; built by :func:`manipkit.analysis.reachmap.payloadmap.payload_map`.)
Each reached voxel-bin stores one configuration (its certificate,
``ReachMap.cert_q``: the first FK sample that landed in the bin, or the IK
answer that filled it) and so one pose, the certificate's FK pose. The layer's
``configurations`` says which configurations of that pose are weighed:

- ``"branches"`` (a chain with a closed-form family, not a 7R SRS arm): the
  certificate and every closed-form branch of its pose inside the joint
  limits (:func:`manipkit.ik.dispatch.ik_many`, FK residual within 1e-6 m and
  rad; the 2 pi aliases of a branch hold the same torques and are not listed);
- ``"self_motion"`` (a 7R SRS arm, whose pose has a one-parameter
  self-motion, the default): the certificate and every closed-form branch (up
  to 8) of its pose inside the joint limits, as for ``"branches"``, at the
  certificate's own arm angle (:func:`manipkit.ik.chain_ik.srs_arm_angle`)
  and at ``arm_angles`` more arm angles ``psi_j = -pi + 2 pi j / arm_angles``
  (j = 0 .. arm_angles - 1; rad, the resolution ``2 pi / arm_angles``): a
  branch counts at a sampled angle only where it exists and lies inside the
  limits, so the samples weighed are the grid's points in each branch's
  feasible intervals (a feasible stretch shorter than a step can fall between
  two and be missed);
- ``"arm_angle_branches"`` (a 7R SRS arm with ``arm_angles=0``): the same at
  the certificate's own arm angle only; the rest of the self-motion is not
  weighed;
- ``"certificates"`` (numerical IK only, or ``branches=False``): the
  certificate alone, one per bin.

At each configuration the capacity is the largest payload mass (kg) whose
centre of gravity sits at ``cog`` (m, in the tip frame's axes) that every
chain joint holds against gravity ``gravity`` (m/s^2, in the map's base
frame) within its effort limits
(:func:`manipkit.statics.capacity.payload_capacity`, closed form: the torque is
affine in the mass). Per voxel, over its reached orientation bins and their
configurations:

- ``best`` (kg): the largest capacity; ``worst`` (kg): the smallest;
- ``saturating``: the chain joint (index into ``joints``) that reaches its
  limit at the worst capacity (-1: none, the capacity is unbounded, or the
  voxel is not reached);
- NaN in ``best`` and ``worst`` where the map reached nothing; 0 where the
  arm's own weight already saturates a joint; ``inf`` where no joint bounds
  the mass (every lever arm vanishes).

``bins`` and ``bins_worst`` keep the largest and smallest capacity of each
voxel-bin (aligned with ``cert_keys``; equal with ``"certificates"``), so a
pose is answered at the map's resolution (its voxel and orientation bin):
:func:`capacity_at` gives ``bins``, what the bin's pose carries on its best
branch. Other poses in the same bin may carry more or less.

Stored in the map's Zarr folder as arrays ``payload_best``,
``payload_worst``, ``payload_saturating``, ``payload_bins`` and
``payload_bins_worst`` and the
attribute ``payload`` (:meth:`PayloadLayer.attrs`), read back validated
(:func:`layer_from_stored`).
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from manipkit.analysis.reachmap.constants import finite_array

if TYPE_CHECKING:
    from manipkit.analysis.reachmap.map import ReachMap

__all__ = ["CONFIGURATIONS", "MAX_ARM_ANGLES", "PAYLOAD_ARRAYS", "PayloadInvalid", "PayloadLayer", "arm_angle_grid",
           "capacity_at", "checked_attrs", "layer_from_stored", "per_voxel"]

#: The arrays of a payload layer in a map's folder and their data types.
PAYLOAD_ARRAYS = {"payload_best": "float64", "payload_worst": "float64", "payload_saturating": "int64",
                  "payload_bins": "float64", "payload_bins_worst": "float64"}
#: What a layer's ``configurations`` may be (module docstring), and how the command line says it.
CONFIGURATIONS = {"branches": "branches: every closed-form branch in the joint limits of each voxel-bin's pose",
                  "self_motion": "branches: every closed-form branch in the joint limits of each voxel-bin's pose at "
                                 "its stored configuration's arm angle and at {arm_angles} arm angles {step} deg "
                                 "apart over the self-motion",
                  "arm_angle_branches": "branches: every closed-form branch in the joint limits at each voxel-bin's "
                                        "stored configuration's arm angle (not the whole self-motion)",
                  "certificates": "branches: 1 per voxel-bin, its stored configuration (no branches weighed)"}
MAX_G = 1e3  # m/s^2: the largest gravity a stored layer may name
#: The most arm angles a layer samples over the self-motion (a resolution of 0.35 deg).
MAX_ARM_ANGLES = 1024


def arm_angle_grid(arm_angles: int) -> np.ndarray:
    """The arm angles (rad) a ``"self_motion"`` layer samples: ``-pi + 2 pi j / arm_angles``, j = 0 .. arm_angles - 1."""
    return -math.pi + 2.0 * math.pi * np.arange(arm_angles) / arm_angles


class PayloadInvalid(ValueError):
    """What is wrong with a stored payload layer (the store names the map)."""


@dataclass(frozen=True, eq=False)
class PayloadLayer:
    """A reach map's payload layer (the module docstring says what each entry means).

    Attributes
    ----------
    best, worst : ndarray, shape (nx, ny, nz)
        kg: the largest and smallest capacity over the voxel's reached bins (NaN: not reached; inf: unbounded).
    saturating : ndarray of int64, shape (nx, ny, nz)
        The joint (index into ``joints``) saturating at ``worst`` (-1: none).
    bins, bins_worst : ndarray, shape (C,)
        kg: the largest and smallest capacity of each voxel-bin, aligned with ``ReachMap.cert_keys``.
    cog : ndarray, shape (3,)
        m: the payload's centre of gravity from the tip's origin, in the tip frame's axes.
    gravity : ndarray, shape (3,)
        m/s^2, in the map's base frame.
    joints : tuple of str
        The chain joints, in the order ``saturating`` indexes.
    lower, upper : ndarray, shape (len(joints),)
        The effort limits used (N m or N; NaN: none).
    inertia_grade : str
        The robot's inertia-audit grade when the layer was built (:func:`manipkit.statics.audit.inertia_grade`).
    configurations : {"branches", "self_motion", "arm_angle_branches", "certificates"}
        Which configurations of each bin's pose were weighed (module docstring).
    arm_angles : int
        ``"self_motion"``: the arm angles sampled besides the stored configuration's own (the resolution is
        ``2 pi / arm_angles`` rad, :func:`arm_angle_grid`); 0 otherwise.
    """

    best: np.ndarray
    worst: np.ndarray
    saturating: np.ndarray
    bins: np.ndarray
    cog: np.ndarray
    gravity: np.ndarray
    joints: tuple[str, ...]
    lower: np.ndarray
    upper: np.ndarray
    inertia_grade: str = ""
    bins_worst: np.ndarray | None = None
    configurations: str = "certificates"
    arm_angles: int = 0

    def __post_init__(self):
        if self.bins_worst is None:
            object.__setattr__(self, "bins_worst", self.bins)

    def configurations_text(self) -> str:
        """Which configurations were weighed, in words (:data:`CONFIGURATIONS`, the arm angles' count and step)."""
        step = 360.0 / self.arm_angles if self.arm_angles else 0.0
        return CONFIGURATIONS[self.configurations].format(arm_angles=self.arm_angles, step=f"{step:g}")

    def carries(self, mass: float) -> np.ndarray:
        """(nx, ny, nz) bool: voxels where the best capacity is at least ``mass`` (kg): some reached orientation bin
        of the voxel holds it on some weighed configuration."""
        return np.nan_to_num(self.best, nan=-1.0) >= float(mass)

    def carries_everywhere(self, mass: float) -> np.ndarray:
        """(nx, ny, nz) bool: voxels where the worst capacity is at least ``mass`` (kg): every reached bin holds it on
        every weighed configuration."""
        return np.nan_to_num(self.worst, nan=-1.0) >= float(mass)

    def same_load(self, cog, gravity) -> bool:
        """Whether the layer was built for this CoG (m, tip axes) and gravity (m/s^2, base frame), to 1e-12."""
        return bool(np.allclose(self.cog, np.asarray(cog, dtype=float), rtol=0, atol=1e-12)
                    and np.allclose(self.gravity, np.asarray(gravity, dtype=float), rtol=0, atol=1e-12))

    def attrs(self) -> dict:
        """The layer's settings as JSON-ready values (NaN limits as None): the map's ``payload`` attribute."""
        def listed(values):
            return [None if math.isnan(v) else float(v) for v in np.asarray(values, dtype=float)]

        return {"cog": listed(self.cog), "gravity": listed(self.gravity), "joints": list(self.joints),
                "lower": listed(self.lower), "upper": listed(self.upper), "inertia_grade": self.inertia_grade,
                "configurations": self.configurations, "arm_angles": self.arm_angles,
                "arm_angle_step_rad": 2.0 * math.pi / self.arm_angles if self.arm_angles else None}


def capacity_at(reach_map: ReachMap, T) -> np.ndarray:
    """(...,) kg: the stored (best) capacity of each pose's voxel-bin (``T`` (..., 4, 4), ``T_base_frame``); NaN where the
    voxel-bin was not reached or the pose is outside the grid.

    The voxel-bin is the pose's voxel and orientation bin (the map's
    resolution, :meth:`ReachMap.resolution`); the capacity is its
    certificate's. Raises :class:`~manipkit.errors.ReachMapError` for poses
    that are not finite (..., 4, 4) and :class:`~manipkit.errors.ReachMapError`
    when the map has no payload layer.
    """
    from manipkit.errors import ReachMapError

    layer = reach_map.payload
    if layer is None:
        raise ReachMapError("the map has no payload layer: add one with manipkit.reachmap.payload_map(map, robot, "
                            "cog=...) or 'manipkit reachmap ... --payload MASS@X,Y,Z'")
    T = finite_array(T, "T", (4, 4), "poses (..., 4, 4) T_base_frame")
    ijk, inside = reach_map.voxel_of(T[..., :3, 3])
    flat = np.ravel_multi_index(tuple(np.moveaxis(np.where(inside[..., None], ijk, 0), -1, 0)), reach_map.shape)
    keys = flat * reach_map.orientations.size + reach_map.orientations.bin_of(T[..., :3, :3])
    cert = reach_map.cert_keys
    if len(cert) == 0:
        return np.full(keys.shape, np.nan)
    row = np.clip(np.searchsorted(cert, keys), 0, len(cert) - 1)
    return np.where(inside & (cert[row] == keys), layer.bins[row], np.nan)


def _vector(value, what: str, n: int, *, nullable: bool = False, bound: float = math.inf) -> np.ndarray:
    if not isinstance(value, list) or len(value) != n:
        raise PayloadInvalid(f"payload.{what} must be a list of {n} numbers")
    out = []
    for v in value:
        if v is None and nullable:
            out.append(math.nan)
        elif isinstance(v, bool) or not isinstance(v, numbers.Real) or not math.isfinite(v) or abs(v) > bound:
            raise PayloadInvalid(f"payload.{what} holds {v!r:.40}; it must hold finite numbers"
                                 + (" or null" if nullable else ""))
        else:
            out.append(float(v))
    return np.array(out)


def checked_attrs(a, joint_names: tuple[str, ...]) -> dict:
    """The ``payload`` attribute of a stored map, every entry checked (raises :class:`PayloadInvalid`)."""
    if not isinstance(a, dict) or a.get("configurations") not in CONFIGURATIONS:
        raise PayloadInvalid(f"payload must be the table manipkit writes (configurations: "
                             f"{' or '.join(CONFIGURATIONS)})")
    joints = a.get("joints")
    if not isinstance(joints, list) or not joints or not all(isinstance(j, str) and j in joint_names for j in joints):
        raise PayloadInvalid("payload.joints must name joints of the map's robot")
    n = len(joints)
    grade = a.get("inertia_grade", "")
    if not isinstance(grade, str) or len(grade) > 8:
        raise PayloadInvalid("payload.inertia_grade must be a short name")
    lower, upper = _vector(a.get("lower"), "lower", n, nullable=True), _vector(a.get("upper"), "upper", n, nullable=True)
    if np.any(lower >= upper):
        raise PayloadInvalid("payload.lower must be below payload.upper")
    arm_angles = a.get("arm_angles", 0)
    sampled = a["configurations"] == "self_motion"
    if isinstance(arm_angles, bool) or not isinstance(arm_angles, int) or \
            not (1 <= arm_angles <= MAX_ARM_ANGLES if sampled else arm_angles == 0):
        raise PayloadInvalid(f"payload.arm_angles must be a whole number from 1 to {MAX_ARM_ANGLES} for "
                             "\"self_motion\", 0 otherwise")
    return {"arm_angles": arm_angles, "cog": _vector(a.get("cog"), "cog", 3, bound=1e6), "gravity": _vector(a.get("gravity"), "gravity", 3,
                                                                                    bound=MAX_G),
            "joints": tuple(joints), "lower": lower, "upper": upper, "inertia_grade": grade,
            "configurations": a["configurations"]}


def layer_from_stored(attrs, arrays: dict, cert_keys: np.ndarray, n_bins: int, joint_names) -> PayloadLayer:
    """The layer of a stored map from its ``payload`` attribute and arrays, checked against its certificates.

    ``bins_worst`` must be >= 0 (inf allowed) at every certificate, ``bins``
    at least that (equal for ``"certificates"``); ``best`` and ``worst`` must
    be the largest of ``bins`` and the smallest of ``bins_worst`` per voxel
    (NaN exactly where no voxel-bin is reached), and ``saturating`` a joint
    index or -1.
    Raises :class:`PayloadInvalid` naming what is wrong.
    """
    a = checked_attrs(attrs, tuple(joint_names))
    best, worst, sat, bins, bins_worst = (arrays[name] for name in PAYLOAD_ARRAYS)
    if bins_worst.shape != cert_keys.shape or np.isnan(bins_worst).any() or (bins_worst < 0).any():
        raise PayloadInvalid("payload_bins_worst must hold a capacity >= 0 kg for each certificate")
    if bins.shape != cert_keys.shape or np.isnan(bins).any() or (bins < bins_worst).any() or \
            (a["configurations"] == "certificates" and not np.array_equal(bins, bins_worst)):
        raise PayloadInvalid("payload_bins must hold, for each certificate, a capacity >= payload_bins_worst (equal "
                             "to it when one configuration per bin is weighed)")
    expected_best, expected_worst, _ = per_voxel(cert_keys, bins, np.zeros(bins.shape, dtype=np.int64), n_bins,
                                                 best.size, worst_capacity=bins_worst)
    same = np.array_equal(expected_best, best.reshape(-1), equal_nan=True) and \
        np.array_equal(expected_worst, worst.reshape(-1), equal_nan=True)
    if not same:
        raise PayloadInvalid("payload_best and payload_worst are not the largest and smallest capacity of each "
                             "voxel's certificates")
    if sat.size and (sat.min() < -1 or sat.max() >= len(a["joints"])):
        raise PayloadInvalid("payload_saturating holds values that are not a joint index or -1")
    return PayloadLayer(best, worst, sat, bins, bins_worst=bins_worst, **a)


def per_voxel(cert_keys: np.ndarray, capacity: np.ndarray, saturating: np.ndarray, n_bins: int, n_voxels: int, *,
              worst_capacity: np.ndarray | None = None):
    """(best, worst, saturating of the worst) per voxel (flat) of capacities per certificate (keys increasing).

    ``capacity`` is each voxel-bin's largest, ``worst_capacity`` its smallest
    (default the same) with ``saturating`` the joint there. NaN (and -1) where
    a voxel has no certificate; the worst's joint is the first certificate in
    key order with the smallest capacity.
    """
    worst_capacity = capacity if worst_capacity is None else worst_capacity
    best, worst = np.full(n_voxels, np.nan), np.full(n_voxels, np.nan)
    sat = np.full(n_voxels, -1, dtype=np.int64)
    voxels = cert_keys // n_bins
    if voxels.size:
        np.fmax.at(best, voxels, capacity)
        order = np.lexsort((worst_capacity, voxels))  # stable: equal capacities stay in key order
        first = order[np.flatnonzero(np.diff(voxels[order], prepend=-1))]
        worst[voxels[first]] = worst_capacity[first]
        sat[voxels[first]] = saturating[first]
    return best, worst, sat
