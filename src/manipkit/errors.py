"""One exception family for every user-facing error.

Each message names what is wrong and what would be valid, in one line, so
the command line can print it as is (exit status 2) and a notebook user can
read it without a traceback.
"""

from __future__ import annotations

__all__ = [
    "ChainError",
    "ClosedFormIKError",
    "CollisionError",
    "DHDerivationError",
    "DHTableError",
    "DescriptionError",
    "IKOptionError",
    "InputFileError",
    "InvalidRotationError",
    "InvalidTransformError",
    "JointLimitError",
    "JointValueError",
    "ManipkitError",
    "OptionError",
    "OutputError",
    "PackageNotFoundError",
    "ReadNotAllowedError",
    "PlanarArmError",
    "SingularityError",
    "UnknownFrameError",
    "UnknownRobotError",
    "ViewerError",
]


class ManipkitError(Exception):
    """Base class: a user error with a one-line, self-explaining message."""


class UnknownRobotError(ManipkitError, LookupError):
    """A robot name or path that is not bundled, not in example-robot-data and not a file."""


class DescriptionError(ManipkitError, ValueError):
    """A URDF or xacro description that cannot be expanded, parsed or trusted."""


class PackageNotFoundError(DescriptionError):
    """A ``package://`` URI or ``$(find PKG)`` that resolves to no folder."""


class ReadNotAllowedError(DescriptionError):
    """A file a description asks for (an include, a YAML file, a mesh) outside what it may read
    (:mod:`manipkit.description.access`)."""


class UnknownFrameError(ManipkitError, KeyError):
    """A frame (link) name the robot does not have."""

    def __str__(self) -> str:  # KeyError would quote the message
        return str(self.args[0]) if self.args else ""


class JointValueError(ManipkitError, ValueError):
    """An unknown joint name, a non-numeric or non-finite value, or a wrong count."""


class InvalidRotationError(ManipkitError, ValueError):
    """A 3x3 matrix that is not a rotation (within the stated tolerance)."""


class InvalidTransformError(ManipkitError, ValueError):
    """A matrix file that cannot be read as a 4x4 homogeneous transform."""


class ChainError(ManipkitError, ValueError):
    """Two frames that do not form a chain from a base down to a tip."""


class PlanarArmError(ManipkitError, ValueError):
    """A link length or target that a planar arm cannot take (not a number, not finite, not positive)."""


class DHTableError(ManipkitError, ValueError):
    """A DH table file (or table) that cannot be read or written: names the file, row and field."""


class DHDerivationError(ManipkitError, ValueError):
    """No DH table or DH expression for this request: base and tip are the same frame, no movable
    joint lies between them, the convention is unknown, or symbolic FK would exceed its bounds."""


class ClosedFormIKError(ManipkitError, ValueError):
    """A pose or arm parameter a closed-form (decoupled) IK solver cannot take: names the value and what is valid."""


class CollisionError(ManipkitError, ValueError):
    """Collision checks that cannot be made or trusted: a robot without ``<collision>`` geometry or whose collision
    meshes cannot be loaded, an SRDF that is malformed or names links the robot does not have, a malformed world
    file, an unknown geometry kind."""


class InputFileError(ManipkitError, ValueError):
    """An input file that cannot be read safely: missing, a folder, a FIFO or device, too large, not text."""


class OutputError(ManipkitError, ValueError):
    """An output the user asked for that cannot be made: an unsupported file format, a path that cannot be written."""


class IKOptionError(ManipkitError, ValueError):
    """An IK option that is not valid (mode, axis, tolerance, budget)."""


class ReachMapError(ManipkitError, ValueError):
    """A reachability-map option that is not valid (voxel, orientations, method, samples, workers), or a map file."""


class OptionError(ManipkitError, ValueError):
    """An argument a function does not take: a name not in its list (``reference``, ``axes``, ``method``), a
    number out of its range (samples, length, tolerance, confidence), or an array of the wrong shape."""


class SingularityError(ManipkitError, ValueError):
    """A quantity that does not exist at this configuration: roll-pitch-yaw rates at gimbal lock, an
    infinite ellipsoid radius at a singularity, a singular inertia matrix."""


class ViewerError(ManipkitError, RuntimeError):
    """The viewer cannot start or serve: a port in use or out of range, the meshcat server stopped or never
    started, a missing optional package (ipywidgets)."""


class JointLimitError(JointValueError):
    """A joint value outside its joint's limits (from :meth:`manipkit.kinematics.robot.Robot.check_limits`).

    Attributes
    ----------
    joint : str
    value, lower, upper : float
        The value and the limits (rad for angular joints, m for prismatic ones).
    unit : str
        ``"rad"`` or ``"m"``.
    """

    def __init__(self, joint: str, value: float, lower: float, upper: float, unit: str = "rad"):
        self.joint, self.value, self.lower, self.upper, self.unit = joint, value, lower, upper, unit
        side = f"above its upper limit {upper:.6g}" if value > upper else f"below its lower limit {lower:.6g}"
        super().__init__(
            f"joint '{joint}' = {value:.6g} is {side} (limits [{lower:.6g}, {upper:.6g}] {unit})"
        )

