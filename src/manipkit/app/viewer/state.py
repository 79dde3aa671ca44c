"""The state of a view: joint values and frames A, B -> the readout and where the scene's nodes go.

:class:`ViewerState` holds what the user chose: one value per movable joint
(clamped into its limits) and two frames A and B. It answers the slider
specs, the readout (exactly the JSON of ``tf-between A B --format json``,
from :func:`manipkit.app.pose.pose_report`, and its text, from
:func:`manipkit.app.pose.pose_text`) and where everything in the scene goes
(triads from :meth:`manipkit.kinematics.robot.Robot.transform`, visuals from
Pinocchio's ``updateGeometryPlacements``). No meshcat, no browser:
unit-testable as is.

Conventions (docs/architecture.md): metres and radians; ``T_a_b`` is the pose
of frame b expressed in frame a; the scene's world frame is the robot's root link.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from manipkit.app.pose import pose_report, pose_text
from manipkit.errors import ManipkitError
from manipkit.spatial.rotations import wrap_angle

if TYPE_CHECKING:
    from manipkit.kinematics.robot import Robot

__all__ = ["DEFAULT_FRAMES", "FREE_RANGE", "TRIAD_PATHS", "VISUALS_ROOT", "SliderSpec", "ViewerState"]

DEFAULT_FRAMES = ("base_link", "ee_link")
#: meshcat paths: Pinocchio's MeshcatVisualizer puts visuals under VISUALS_ROOT/<geometry name>.
VISUALS_ROOT = "pinocchio/visuals"
TRIAD_PATHS = ("manipkit/frame_a", "manipkit/frame_b")
#: Slider span (m) of a floating or planar joint's x, y, z, which have no limits.
FREE_RANGE = 2.0


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

    Examples
    --------
    >>> import manipkit
    >>> state = ViewerState(manipkit.load("planar_2r"))
    >>> state.set_joint("joint1", 10.0)   # clamped into the limits
    3.141592653589793
    >>> state.readout()["target"]
    'ee_link'
    """

    def __init__(self, robot: Robot, *, frames: tuple[str, str] = DEFAULT_FRAMES, q=None):
        self.robot = robot
        self._frames = self._checked_frames(frames)
        self._continuous = np.array([joint.is_angular and not math.isfinite(joint.upper - joint.lower)
                                     for joint in robot.joints], dtype=bool)
        start = robot.q() if q is None else q
        robot.as_dict(start)  # checks the shape and that the values are finite numbers
        self._q = self._in_range(start)
        self._start = self._q.copy()

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
            raise ManipkitError(f"frames: give two frame names A and B, got {frames!r}")
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

    def geometry_placements(self, visual_model) -> dict[str, np.ndarray]:
        """Scene path -> T_root_geometry (4x4, mesh scale applied to the rotation columns) of each visual.

        ``visual_model`` is the Pinocchio ``GeometryModel`` from :func:`visual_model`.
        The placements are :meth:`Robot.geometry_placements` (Pinocchio's, in
        the robot's root link); only the mesh scale is added here.
        """
        placements = self.robot.geometry_placements(visual_model, self._q)
        return {
            f"{VISUALS_ROOT}/{geometry.name}": T * np.append(geometry.meshScale, 1.0)  # T @ diag(scale, 1)
            for geometry, T in zip(visual_model.geometryObjects, placements)
        }

    def scene_placements(self, visual_model=None) -> dict[str, np.ndarray]:
        """Everything the scene draws: the visuals (if a model is given) and the triads at A and B."""
        placements = {} if visual_model is None else self.geometry_placements(visual_model)
        placements.update(self.frame_placements())
        return placements

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper corners (m, root frame) of the box around every frame origin at the current pose.

        Used to aim the camera and size the triads.
        """
        root = self.robot.root_link
        origins = np.array([self.robot.transform(root, f, self._q, check_limits=False)[:3, 3] for f in self.robot.frame_names])
        return origins.min(axis=0), origins.max(axis=0)

    def snapshot(self) -> dict:
        """What the control page shows after a change: q, frames, the readout and its two renderings."""
        report = self.readout()
        return {
            "q": report["q"],
            "frames": list(self._frames),
            "readout": report,
            "readout_json": json.dumps(report, indent=2),
            "readout_text": pose_text(report),
        }
