"""The state of a view: joint values and frames A, B -> the readout and where the scene's nodes go.

:class:`ViewerState` holds what the user chose: one value per movable joint
(clamped into its limits) and two frames A and B. It answers the slider
specs, the readout (exactly the JSON of ``tf-between A B --format json``,
from :func:`manipkit.app.pose.pose_report`, and its text, from
:func:`manipkit.app.pose.pose_text`) and where everything in the scene goes
(triads from :meth:`manipkit.kinematics.robot.Robot.transform`, visuals from
Pinocchio's ``updateGeometryPlacements``). No meshcat, no browser:
unit-testable as is.

The manipulability overlay (:class:`Overlay`, off unless asked for) adds the
velocity or force ellipsoid of B relative to A, translation or rotation rows,
from the Jacobian report of the chain A -> B
(:func:`manipkit.analysis.jacobian_report.jacobian_report`, ``reference="base"``,
the defaults of ``manipkit jacobian``) and :mod:`manipkit.analysis.manipulability`,
and a readout of Yoshikawa's index (translation rows), the condition number
and the report's ranks, singular families and lost motions in the words of
``manipkit jacobian`` (:mod:`manipkit.app.jacobian_text`). When A is not
above B there is no chain: the readout says so and no ellipsoid is drawn. The ellipsoid sits at B's
origin; its principal axes (A's axes) are turned into the root frame with
``T_root_A``; its radii are multiplied by a display scale (:meth:`ViewerState.ellipsoid_scale`)
and held between ``1e-3 * size`` and ``size`` (a force ellipsoid near a
singularity grows without bound; a velocity ellipsoid flattens).

Collision checks (:class:`~manipkit.app.viewer.collision_state.CollisionView`,
off unless asked for) add, at each pose, the report of
:mod:`manipkit.kinematics.collisions` (computed once per pose, asked by the
readout and the scene in turn): the pairs in contact and the closest pair in
the words of ``manipkit collisions``, and which visuals to tint
(:meth:`ViewerState.collision_tints`: those of the links in contact). A robot
without collision geometry gets one line saying collisions are unavailable.

Conventions (docs/architecture.md): metres and radians; ``T_a_b`` is the pose
of frame b expressed in frame a; the scene's world frame is the robot's root link.
"""

from __future__ import annotations

import copy
import json
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from manipkit.analysis.jacobian_report import SINGULAR_TOL, jacobian_report
from manipkit.analysis.manipulability import condition_number, force_ellipsoid, velocity_ellipsoid
from manipkit.app.jacobian_text import singularity_data, singularity_lines
from manipkit.app.pose import pose_report, pose_text
from manipkit.errors import ChainError, OptionError
from manipkit.spatial.rotations import wrap_angle
from manipkit.text import short_text

if TYPE_CHECKING:
    from manipkit.app.viewer.collision_state import CollisionView
    from manipkit.kinematics.collisions import CollisionReport
    from manipkit.kinematics.robot import Robot

__all__ = [
    "DEFAULT_FRAMES", "ELLIPSOID_AXES", "ELLIPSOID_KINDS", "ELLIPSOID_PATH", "FREE_RANGE", "NO_OVERLAY", "RADIUS_FLOOR",
    "SINGULAR_TOL", "TRIAD_PATHS", "VISUALS_ROOT", "Overlay", "SliderSpec", "ViewerState", "ellipsoid_text",
]

DEFAULT_FRAMES = ("base_link", "ee_link")
#: meshcat paths: Pinocchio's MeshcatVisualizer puts visuals under VISUALS_ROOT/<geometry name>.
VISUALS_ROOT = "pinocchio/visuals"
TRIAD_PATHS = ("manipkit/frame_a", "manipkit/frame_b")
#: Slider span (m) of a floating or planar joint's x, y, z, which have no limits.
FREE_RANGE = 2.0
#: meshcat path of the manipulability ellipsoid (a unit sphere placed with axes times radii).
ELLIPSOID_PATH = "manipkit/ellipsoid"
ELLIPSOID_KINDS = ("velocity", "force")
ELLIPSOID_AXES = ("trans", "rot")
#: (kind, axes) -> (c, p, unit of the radii, unit of the scale): display scale c * size**p, rounded to 1, 2 or 5
#: times a power of ten, so that a typical arm's ellipsoid is about a third of its size.
_SCALES = {
    ("velocity", "trans"): (0.5, 0, "m/s", "m per m/s"),
    ("velocity", "rot"): (0.2, 1, "rad/s", "m per rad/s"),
    ("force", "trans"): (0.1, 2, "N", "m per N"),
    ("force", "rot"): (0.3, 1, "N m", "m per N m"),
}
_ROWS = {"trans": "translation", "rot": "rotation"}
#: Radii drawn are held in [RADIUS_FLOOR * size, size] (m): a flat ellipsoid stays drawable, an unbounded one fits.
RADIUS_FLOOR = 1e-3


@dataclass(frozen=True)
class Overlay:
    """The manipulability overlay's settings: shown or not, ``kind`` velocity or force, ``axes`` trans or rot."""

    shown: bool = False
    kind: str = "velocity"
    axes: str = "trans"

    def __post_init__(self):
        if not isinstance(self.shown, bool):
            raise OptionError(f"ellipsoid shown: expected true or false, got {self.shown!r:.40}")
        if self.kind not in ELLIPSOID_KINDS:
            raise OptionError(f"ellipsoid kind {self.kind!r:.40}: give velocity or force")
        if self.axes not in ELLIPSOID_AXES:
            raise OptionError(f"ellipsoid axes {self.axes!r:.40}: give trans (translation rows) or rot (rotation rows)")


#: The overlay off (the default of a view).
NO_OVERLAY = Overlay()


def _round_125(value: float) -> float:
    """``value`` rounded to the nearest of 1, 2, 5 times a power of ten (on a log scale)."""
    exponent = math.floor(math.log10(value))
    mantissa = value / 10.0**exponent
    best = min((1.0, 2.0, 5.0, 10.0), key=lambda m: abs(math.log(mantissa / m)))
    return float(f"{best * 10.0**exponent:.12g}")


@dataclass(frozen=True)
class SliderSpec:
    """One slider of the control page.

    ``lower``/``upper`` are the joint limits (continuous joints: one step
    above -pi to pi, so every slider position is an angle in (-pi, pi]);
    ``unit`` is ``rad`` or ``m``; ``step`` is a thousandth of the range (for
    widgets that need one; the browser's range input takes any value).
    """

    name: str
    type: str
    lower: float
    upper: float
    step: float
    value: float
    unit: str


class ViewerState:
    """Joint values and the frames A, B of a view; answers the readout and the scene placements.

    Parameters
    ----------
    robot : Robot
    frames : (str, str), keyword-only
        A and B; the readout is T_A_B, the pose of B expressed in A.
    q : array_like, shape (n,), optional, keyword-only
        Start pose (radians, metres); default every joint at 0 or the nearest
        value inside its limits. Clamped into the limits like a slider would
        (continuous joints: wrapped to (-pi, pi]).
    overlay : Overlay, optional, keyword-only
        The manipulability ellipsoid's settings (default: not shown).
    collisions : CollisionView, optional, keyword-only
        What is checked for collisions at each pose (:func:`~manipkit.app.viewer.collision_state.collision_view`);
        default None: nothing is checked and the readout says nothing about collisions.

    Examples
    --------
    >>> import manipkit
    >>> state = ViewerState(manipkit.load("planar_2r"))
    >>> state.set_joint("joint1", 10.0)   # clamped into the limits
    3.141592653589793
    >>> state.readout()["target"]
    'ee_link'
    """

    def __init__(self, robot: Robot, *, frames: tuple[str, str] = DEFAULT_FRAMES, q=None, overlay: Overlay = NO_OVERLAY,
                 collisions: CollisionView | None = None):
        self.robot = robot
        self._frames = self._checked_frames(frames)
        self._continuous = np.array([joint.is_angular and not math.isfinite(joint.upper - joint.lower)
                                     for joint in robot.joints], dtype=bool)
        start = robot.q() if q is None else q
        robot.as_dict(start)  # checks the shape and that the values are finite numbers
        self._q = self._in_range(start)
        self._start = self._q.copy()
        if not isinstance(overlay, Overlay):
            raise OptionError(f"overlay: expected an Overlay, got {type(overlay).__name__}")
        self._overlay = overlay
        self._ellipsoid_cache: tuple | None = None  # (q, frames, overlay) -> (report, placement) last computed
        self._collisions = collisions
        self._collision_cache: tuple | None = None  # (q bytes, report) last computed
        lower, upper = self._box(self._in_range(robot.q()))
        #: Size of the robot (m), for the ellipsoid's display scale and cap: the diagonal of the box around
        #: every frame origin at the default pose (every joint at 0 or the nearest value inside its limits),
        #: at least 0.2 m. It does not depend on the start pose, so two views of a robot draw alike.
        self.size = max(float(np.linalg.norm(upper - lower)), 0.2)

    # Joint values -------------------------------------------------------

    @property
    def q(self) -> np.ndarray:
        """The joint vector (copy), in ``robot.joint_names`` order."""
        return self._q.copy()

    def set_joint(self, name: str, value) -> float:
        """Set one joint; returns the value used (clamped into the limits, continuous joints wrapped to (-pi, pi]).

        Raises
        ------
        JointValueError
            Unknown joint (the valid ones are listed), or a value that is not a finite number.
        """
        self.robot.q({name: value})  # validates the name and the number, with the model's messages
        index = self.robot.joint_names.index(name)
        q = self._q.copy()
        q[index] = float(value)
        self._q = self._in_range(q)
        return float(self._q[index])

    def set_joints(self, values: dict) -> None:
        """Set several joints at once (all checked before any is set)."""
        self.robot.q(dict(values))
        for name, value in values.items():
            self.set_joint(name, value)

    def reset(self) -> None:
        """Back to the start pose (the ``q`` given at construction)."""
        self._q = self._start.copy()

    def _in_range(self, q) -> np.ndarray:
        """``q`` clamped into the joint limits, continuous joints (no limits) wrapped to (-pi, pi]."""
        q = self.robot.clamp(q)
        q[self._continuous] = wrap_angle(q[self._continuous])
        return q

    def sliders(self) -> list[SliderSpec]:
        """One :class:`SliderSpec` per entry of ``q``, in ``robot.joint_names`` order (mimic joints follow their leader).

        A floating or planar joint's x, y, z have no limits: their sliders span
        [-FREE_RANGE, FREE_RANGE] m.
        """
        specs = []
        for joint, value in zip(self.robot.joints, self._q):
            if joint.is_angular and not math.isfinite(joint.upper - joint.lower):
                # continuous, or a floating/planar joint's angle: (-pi, pi], the left end one step above -pi
                step = 2.0 * math.pi / 1000
                lower, upper = -math.pi + step, math.pi
            elif not math.isfinite(joint.upper - joint.lower):  # a floating or planar joint's x, y, z
                lower, upper = -FREE_RANGE, FREE_RANGE
                step = (upper - lower) / 1000
            else:
                lower, upper = joint.lower, joint.upper
                step = (upper - lower) / 1000
            specs.append(SliderSpec(joint.name, joint.type, float(lower), float(upper), float(step),
                                    float(value), "rad" if joint.is_angular else "m"))
        return specs

    # Frames -------------------------------------------------------------

    @property
    def frames(self) -> tuple[str, str]:
        """(A, B), as given (aliases such as ``ee_link`` are kept)."""
        return self._frames

    def set_frames(self, a: str, b: str) -> None:
        """Choose A and B. Raises :class:`UnknownFrameError` (with the closest names) for unknown frames."""
        self._frames = self._checked_frames((a, b))

    def frame_choices(self) -> tuple[str, ...]:
        """Every frame the pickers offer: the robot's links, then ``base_link``/``ee_link`` if they are aliases."""
        names = self.robot.frame_names
        return names + tuple(alias for alias in DEFAULT_FRAMES if alias not in names)

    def _checked_frames(self, frames) -> tuple[str, str]:
        frames = tuple(frames)
        if len(frames) != 2 or not all(isinstance(f, str) for f in frames):
            raise OptionError(f"frames: give two frame names A and B, got {frames!r}")
        for name in frames:
            self.robot.frame(name)  # UnknownFrameError names the closest frames
        return frames

    # Answers ------------------------------------------------------------

    def readout(self) -> dict:
        """T_A_B as ``tf-between A B --format json`` prints it (same keys, same numbers)."""
        a, b = self._frames
        return pose_report(self.robot, a, b, self._q)

    def frame_placements(self) -> dict[str, np.ndarray]:
        """Scene path -> T_root_frame (4x4) of the triads at A and B."""
        root = self.robot.root_link
        return {path: self.robot.transform(root, frame, self._q, check_limits=False) for path, frame in zip(TRIAD_PATHS, self._frames)}

    def geometry_placements(self, visual_model, *, scaled: bool = True) -> dict[str, np.ndarray]:
        """Scene path -> T_root_geometry (4x4, mesh scale applied to the rotation columns) of each visual.

        ``visual_model`` is the Pinocchio ``GeometryModel`` from :func:`visual_model`.
        The placements are :meth:`Robot.geometry_placements` (Pinocchio's, in
        the robot's root link); only the mesh scale is added here (``scaled=False``:
        not even that, the rigid placement, as an animation keyframe wants it).
        """
        placements = self.robot.geometry_placements(visual_model, self._q)
        return {
            f"{VISUALS_ROOT}/{geometry.name}": T * np.append(geometry.meshScale, 1.0) if scaled else T  # T @ diag(s, 1)
            for geometry, T in zip(visual_model.geometryObjects, placements)
        }

    def scene_placements(self, visual_model=None) -> dict[str, np.ndarray]:
        """Everything the scene draws: the visuals (if a model is given), the triads at A and B, the ellipsoid if shown."""
        placements = {} if visual_model is None else self.geometry_placements(visual_model)
        placements.update(self.frame_placements())
        if self._overlay.shown and self.ellipsoid_placement() is not None:
            placements[ELLIPSOID_PATH] = self.ellipsoid_placement()
        return placements

    def bounds(self, visual_model=None) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper corners (m, root frame) of the box around every frame origin at the current pose.

        With ``visual_model`` (from :func:`visual_model`) the box holds the
        visual geometry too: each object's own bounding box (coal's local
        AABB, mesh scale applied) placed where :meth:`geometry_placements` puts
        it. Used to aim the camera, lay the floor and size the triads.
        """
        lower, upper = self._box(self._q)
        if visual_model is None:
            return lower, upper
        unit = np.array([[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)], dtype=float)
        for geometry, T in zip(visual_model.geometryObjects, self.robot.geometry_placements(visual_model, self._q)):
            T = T * np.append(geometry.meshScale, 1.0)  # as geometry_placements draws it
            shape = geometry.geometry
            if shape is None:
                continue
            shape.computeLocalAABB()
            low, high = np.asarray(shape.aabb_local.min_, dtype=float), np.asarray(shape.aabb_local.max_, dtype=float)
            if not (np.all(np.isfinite(low)) and np.all(np.isfinite(high))):
                continue  # a half-space or plane has no box
            corners = (low + unit * (high - low)) @ T[:3, :3].T + T[:3, 3]
            lower, upper = np.minimum(lower, corners.min(axis=0)), np.maximum(upper, corners.max(axis=0))
        return lower, upper

    def base_origin(self) -> np.ndarray:
        """Where the robot stands: the origin of ``base_link`` (:attr:`Robot.base_link`) in the root frame (m), at the current pose."""
        return self.robot.transform(self.robot.root_link, self.robot.base_link, self._q, check_limits=False)[:3, 3]

    def _box(self, q) -> tuple[np.ndarray, np.ndarray]:
        root = self.robot.root_link
        origins = np.array([self.robot.transform(root, f, q, check_limits=False)[:3, 3] for f in self.robot.frame_names])
        return origins.min(axis=0), origins.max(axis=0)

    def snapshot(self) -> dict:
        """What the control page shows after a change: q, frames, the readout and its two renderings, the overlay,
        the collisions.

        ``overlay`` holds the settings; ``ellipsoid`` is :meth:`ellipsoid` (None
        when the overlay is off) and ``ellipsoid_text`` its text ("" when off).
        ``collisions`` is :meth:`CollisionView.as_dict` of :meth:`collision_report`
        (None when nothing is checked) and ``collisions_text`` its lines ("" then).
        """
        report = self.readout()
        ellipsoid = self.ellipsoid() if self._overlay.shown else None
        return {
            "q": report["q"],
            "frames": list(self._frames),
            "readout": report,
            "readout_json": json.dumps(report, indent=2),
            "readout_text": pose_text(report),
            "overlay": {"shown": self._overlay.shown, "kind": self._overlay.kind, "axes": self._overlay.axes},
            "ellipsoid": ellipsoid,
            "ellipsoid_text": "" if ellipsoid is None else ellipsoid_text(ellipsoid),
            **self._collision_snapshot(),
        }

    # Collisions -----------------------------------------------------------

    @property
    def collision_view(self) -> CollisionView | None:
        """What is checked for collisions (None: nothing)."""
        return self._collisions

    def collision_report(self) -> CollisionReport | None:
        """The collision report at the current pose (:meth:`CollisionView.report`); None when nothing is checked
        or collisions are unavailable for this robot. Computed once per pose."""
        if self._collisions is None:
            return None
        key = self._q.tobytes()
        if self._collision_cache is None or self._collision_cache[0] != key:
            self._collision_cache = (key, self._collisions.report(self.robot, self._q))
        return self._collision_cache[1]

    def collided_links(self) -> frozenset:
        """The links in contact at the current pose (with each other or the floor); empty when nothing is checked."""
        report = self.collision_report()
        if report is None:
            return frozenset()
        return frozenset(name for pair in report.pairs for name in (pair.link1, pair.link2)) - {"floor"}

    def collision_tints(self, visual_model) -> dict[str, bool]:
        """Scene path -> tinted (drawn in the collision colour), for each visual: those of the links in contact.

        Empty when nothing is checked, so the scene's colours are never touched then.
        """
        if self._collisions is None or self.collision_report() is None:
            return {}
        links, frames = self.collided_links(), self.robot.model.frames
        return {f"{VISUALS_ROOT}/{geometry.name}": frames[geometry.parentFrame].name in links
                for geometry in visual_model.geometryObjects}

    def _collision_snapshot(self) -> dict:
        if self._collisions is None:
            return {"collisions": None, "collisions_text": ""}
        report = self.collision_report()
        return {"collisions": self._collisions.as_dict(report), "collisions_text": self._collisions.text(report)}

    # Manipulability overlay ----------------------------------------------

    @property
    def overlay(self) -> Overlay:
        """The manipulability overlay's settings."""
        return self._overlay

    def set_overlay(self, *, shown: bool | None = None, kind: str | None = None, axes: str | None = None) -> Overlay:
        """Change the overlay's settings (those given); returns the new :class:`Overlay`.

        Raises :class:`ManipkitError` naming the valid choices (nothing is changed then).
        """
        current = self._overlay
        self._overlay = Overlay(current.shown if shown is None else shown, current.kind if kind is None else kind,
                                current.axes if axes is None else axes)
        return self._overlay

    def ellipsoid_scale(self) -> float:
        """Display scale of the radii (m per unit of the radii, :data:`_SCALES`): ``c * size**p`` rounded to 1-2-5."""
        c, p, _, _ = _SCALES[(self._overlay.kind, self._overlay.axes)]
        return _round_125(c * self.size**p)

    def _ellipsoid(self) -> tuple[dict, np.ndarray | None]:
        key = (self._q.tobytes(), self._frames, self._overlay)
        cached = self._ellipsoid_cache
        if cached is None or cached[0] != key:  # the readout and the scene ask for the same pose in turn
            self._ellipsoid_cache = (key, self._compute_ellipsoid())
        report, T = self._ellipsoid_cache[1]
        return copy.deepcopy(report), None if T is None else T.copy()

    def _compute_ellipsoid(self) -> tuple[dict, np.ndarray | None]:
        a, b = self._frames
        kind, axes = self._overlay.kind, self._overlay.axes
        settings = {"frame": b, "base": a, "reference": "base", "kind": kind, "axes": axes}
        try:
            chain = self.robot.chain(a, b)
        except ChainError as exc:  # A is not above B: no chain, no Jacobian report (the readout says why)
            return {**settings, "error": str(exc)}, None
        if chain.n == 0:  # B fixed to A: there is no ellipsoid to draw
            return {**settings, "error": f"no joint moves {b} relative to {a}"}, None
        report = jacobian_report(chain, self._q[chain.columns], reference="base", tol=SINGULAR_TOL)
        J = report.jacobian  # the chain's joints only
        shape = (velocity_ellipsoid if kind == "velocity" else force_ellipsoid)(J, axes)
        kappa = float(condition_number(J, axes))
        scale = self.ellipsoid_scale()
        with np.errstate(over="ignore"):
            wanted = scale * shape.radii
        drawn = np.clip(wanted, RADIUS_FLOOR * self.size, self.size)
        root = self.robot.root_link
        T_root_a = self.robot.transform(root, a, self._q, check_limits=False)
        T_root_b = self.robot.transform(root, b, self._q, check_limits=False)
        R_root_axes = T_root_a[:3, :3] @ shape.axes  # principal axes (columns) from A's axes into the root's
        if np.linalg.det(R_root_axes) < 0:  # a reflection: the opposite last axis is the same ellipsoid
            R_root_axes[:, -1] *= -1.0
        T_root_ellipsoid = np.eye(4)
        T_root_ellipsoid[:3, :3] = R_root_axes * drawn  # R @ diag(drawn): a unit sphere -> the ellipsoid
        T_root_ellipsoid[:3, 3] = T_root_b[:3, 3]
        _, _, unit, scale_unit = _SCALES[(kind, axes)]
        answer = {
            **settings,
            "manipulability_translation": report.manipulability_translation,
            "condition_number": kappa if math.isfinite(kappa) else None,
            **singularity_data(report),
            "singularity_lines": singularity_lines(report),
            "radii": [float(r) if math.isfinite(r) else None for r in shape.radii],
            "unit": unit,
            "principal_axes": shape.axes.tolist(),
            "center": T_root_b[:3, 3].tolist(),
            "scale": scale,
            "scale_unit": scale_unit,
            "cap": self.size,
            "capped": bool(np.any(wanted > self.size)),
        }
        return answer, T_root_ellipsoid

    def ellipsoid(self) -> dict:
        """The overlay's readout, JSON-ready (whether shown or not).

        Keys: ``frame`` (B), ``base`` (A), ``reference`` ("base"), ``kind``,
        ``axes``. When A is not above B in the link tree there is no chain
        between them, and when no joint moves B relative to A nothing moves:
        ``error`` says so (and which order would do), and nothing is drawn. Otherwise: ``manipulability_translation``
        (Yoshikawa's index of the translation rows); ``condition_number`` (of
        the ``axes`` rows, None for infinite); the ranks, ``singular``, the
        singular families and what is lost, exactly as ``manipkit jacobian
        --base A --frame B`` gives them (:func:`manipkit.app.jacobian_text.singularity_data`
        of :func:`manipkit.analysis.jacobian_report.jacobian_report`, singular
        values above ``SINGULAR_TOL`` counted) and ``singularity_lines``, its
        text; ``radii`` (largest first for velocity, None for an infinite
        force radius) in ``unit`` per unit joint rate (velocity) or joint
        effort (force); ``principal_axes`` (3x3, columns, in A's axes);
        ``center`` (B's origin, m, root frame); ``scale`` (display scale,
        ``scale_unit``); ``cap`` (m) and ``capped`` (a radius times the scale
        is above the cap and is drawn at the cap).
        """
        return self._ellipsoid()[0]

    def ellipsoid_placement(self) -> np.ndarray | None:
        """T_root_ellipsoid (4x4): a unit sphere -> the ellipsoid drawn (columns = root-frame principal axes times
        drawn radii); None when A is not above B (no chain, nothing drawn)."""
        return self._ellipsoid()[1]

    def scene_visibility(self) -> dict[str, bool]:
        """Scene path -> shown, for the nodes that can be hidden (the ellipsoid; hidden when A is not above B)."""
        return {ELLIPSOID_PATH: self._overlay.shown and self.ellipsoid_placement() is not None}


def ellipsoid_text(report: dict) -> str:
    """The overlay's readout (:meth:`ViewerState.ellipsoid`) as lines for people.

    The ranks, ``singular: yes/no`` and what is lost are the lines
    ``manipkit jacobian`` prints (:func:`manipkit.app.jacobian_text.singularity_lines`).
    """
    if "error" in report:
        return f"no Jacobian of {report['frame']} relative to {report['base']}: {report['error']}"
    rows = _ROWS[report["axes"]]
    kappa = report["condition_number"]
    radii = ", ".join("inf" if r is None else short_text(r, 4, zero=1e-12) for r in report["radii"])
    per = "per unit joint rate" if report["kind"] == "velocity" else "per unit joint torque or force"
    lines = [
        f"Jacobian of {report['frame']} relative to {report['base']}, in {report['base']}'s axes",
        f"Yoshikawa index (translation rows): {short_text(report['manipulability_translation'], 6, zero=1e-15)}",
        f"condition number ({rows} rows): " + ("inf" if kappa is None else short_text(kappa, 6)),
        *report["singularity_lines"],
        f"{report['kind']} ellipsoid ({rows}), radii ({report['unit']} {per}): {radii}",
        f"drawn at {report['frame']}'s origin, radii x {short_text(report['scale'])} {report['scale_unit']}, "
        f"at most {short_text(report['cap'], 3)} m",
    ]
    if report["capped"]:
        cap = short_text(report["cap"], 3)
        lines.append(f"capped: radii above {cap} m as drawn are drawn at {cap} m (near a singularity, a force "
                     "ellipsoid grows without bound)")
    return "\n".join(lines)
