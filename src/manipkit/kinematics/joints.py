"""The joint vector of a robot: which URDF joints it holds, and how it drives Pinocchio's configuration.

Conventions (docs/architecture.md, "Joint vectors"):

- ``q`` has one value per independent degree of freedom, in the order of
  :attr:`manipkit.kinematics.robot.Robot.joint_names`: an angle (rad) for a
  revolute or continuous joint, a distance (m) for a prismatic one.
- A ``<mimic joint="J" multiplier="m" offset="o"/>`` joint has no entry: its
  value is ``m * q[J] + o`` (rad or m), as ROS's ``robot_state_publisher``
  and yourdfpy compute it. A mimic of a mimic is followed to the independent
  joint (multipliers multiply, offsets add up through the chain).
- A ``floating`` joint has six entries, named ``<joint>.x``, ``.y``, ``.z``
  (m) and ``.roll``, ``.pitch``, ``.yaw`` (rad): its motion is
  ``Trans(x, y, z) Rz(yaw) Ry(pitch) Rx(roll)`` (URDF's rpy order). A
  ``planar`` joint has three, ``.x``, ``.y`` (m) and ``.yaw`` (rad):
  ``Trans(x, y, 0) Rz(yaw)`` in the joint frame, whose z axis is the
  plane's normal. All default to 0 (the identity).

Pinocchio is built without its own mimic support (``mimic=False``): its
model then has every URDF joint, and :class:`JointLayout` maps ``q`` onto
that configuration. Pinocchio 4.1's ``mimic=True`` refuses a mimic whose
leader is a continuous joint and a mimic of a mimic (measured); this mapping
handles both, and leaves Pinocchio's own algorithms an independent check.
"""

from __future__ import annotations

import contextlib
import math
import os
import threading
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from manipkit.errors import DescriptionError

__all__ = [
    "COORDINATES",
    "Joint",
    "JointLayout",
    "Mimic",
    "build_model",
    "joint_kind_axis",
    "joint_layout",
    "native_call",
    "root_link",
]

#: The entries of ``q`` a multi-degree-of-freedom joint contributes, in order.
COORDINATES = {"floating": ("x", "y", "z", "roll", "pitch", "yaw"), "planar": ("x", "y", "yaw")}
_LINEAR = ("x", "y", "z")


@dataclass(frozen=True)
class Joint:
    """One entry of the joint vector.

    Attributes
    ----------
    name : str
        The entry's name: the URDF joint's name, or ``<joint>.<coordinate>``
        for the entries of a floating or planar joint.
    type : str
        ``revolute``, ``continuous``, ``prismatic``, ``floating`` or ``planar``.
    axis : ndarray, shape (3,)
        Unit axis in the joint frame (the coordinate's axis for a floating or
        planar joint's entry).
    lower, upper : float
        Position limits (rad or m); -inf/+inf for continuous joints and the
        entries of floating and planar joints.
    parent, child : str
        Parent and child link names.
    joint : str
        The URDF joint's name (equal to ``name`` for a one-degree-of-freedom joint).
    coordinate : str or None
        ``x``, ``y``, ``z``, ``roll``, ``pitch`` or ``yaw`` for an entry of a
        floating or planar joint, else None.
    """

    name: str
    type: str
    axis: np.ndarray
    lower: float
    upper: float
    parent: str
    child: str
    joint: str = ""
    coordinate: str | None = None

    @property
    def is_angular(self) -> bool:
        """Whether the value is an angle (rad) rather than a distance (m)."""
        if self.coordinate is not None:
            return self.coordinate not in _LINEAR
        return self.type != "prismatic"

    def default(self) -> float:
        """0, or the nearest value inside the limits."""
        return float(min(max(0.0, self.lower), self.upper))


@dataclass(frozen=True)
class Mimic:
    """A URDF joint that follows another: value = ``multiplier * q[leader] + offset``.

    ``leader`` is the independent joint the mimic chain ends at (with the
    multipliers and offsets composed); ``declared`` is the joint its
    ``<mimic>`` tag names.
    """

    name: str
    type: str
    leader: str
    multiplier: float
    offset: float
    declared: str
    parent: str
    child: str


@dataclass
class JointLayout:
    """How a robot's joint vector maps onto its Pinocchio model (built by :func:`joint_layout`).

    Attributes
    ----------
    joints : tuple of Joint
        One per entry of ``q``.
    mimics : dict
        Mimic joint name -> :class:`Mimic`, in URDF order.
    columns : dict
        Pinocchio joint id -> list of (column of ``q``, scale, offset, kind, axis)
        for the joint's one-degree-of-freedom motions in order (a floating
        joint has six, a planar three; a mimic joint reads its leader's
        column). ``kind`` is ``"revolute"`` or ``"prismatic"``.
    """

    joints: tuple[Joint, ...]
    mimics: dict[str, Mimic]
    columns: dict[int, list[tuple[int, float, float, str, np.ndarray]]]
    neutral: np.ndarray
    _plain: tuple[np.ndarray, ...] = field(default=(), repr=False)
    _circle: tuple[np.ndarray, ...] = field(default=(), repr=False)
    _multi: list[tuple[str, int, int]] = field(default_factory=list, repr=False)
    _plain_is_copy: bool = field(default=False, repr=False)

    def velocity_map(self, model: pin.Model) -> np.ndarray:
        """``S`` (model.nv, n): Pinocchio's velocity ``v = S qdot`` for joint rates ``qdot`` (``q``'s order).

        A mimic joint's velocity is its multiplier times its leader's rate.
        Floating and planar joints have no such map (Pinocchio's velocity of
        a free flyer is a twist in its own frame, not the rates of x, y, z,
        roll, pitch, yaw): :class:`DescriptionError` for them.
        """
        S = np.zeros((model.nv, len(self.joints)))
        for joint_id, motions in self.columns.items():
            if len(motions) != 1:
                name = model.names[joint_id]
                raise DescriptionError(f"joint '{name}' is floating or planar: its Pinocchio velocity is not a rate "
                                       "of its coordinates; this quantity needs revolute and prismatic joints")
            column, scale, _, _, _ = motions[0]
            S[model.joints[joint_id].idx_v, column] += scale
        return S

    def configuration(self, q: np.ndarray) -> np.ndarray:
        """Pinocchio's configuration vector (size ``model.nq``) for a checked joint vector ``q``."""
        config = self.neutral.copy()
        idx, col, scale, offset = self._plain
        if self._plain_is_copy:  # no mimic among them: the values as they are
            config[idx] = q[col]
        elif idx.size:
            config[idx] = scale * q[col] + offset
        idx, col, scale, offset = self._circle
        if idx.size:  # continuous joints: (cos, sin)
            angles = scale * q[col] + offset
            config[idx] = np.cos(angles)
            config[idx + 1] = np.sin(angles)
        for kind, idx_q, first in self._multi:
            if kind == "floating":
                x, y, z, roll, pitch, yaw = q[first : first + 6]
                config[idx_q : idx_q + 3] = (x, y, z)
                config[idx_q + 3 : idx_q + 7] = _quaternion_xyzw(roll, pitch, yaw)
            else:
                x, y, yaw = q[first : first + 3]
                config[idx_q : idx_q + 4] = (x, y, math.cos(yaw), math.sin(yaw))
        return config


    def configurations(self, Q: np.ndarray) -> np.ndarray:
        """Pinocchio's configuration vectors (model.nq, N), Fortran order, for checked joint vectors ``Q`` (N, n).

        Column ``i`` equals ``configuration(Q[i])``; vectorised over the rows
        (floating and planar joints go row by row).
        """
        Q = np.asarray(Q, dtype=float).reshape(-1, len(self.joints))
        if self._multi:
            return np.asfortranarray(np.stack([self.configuration(q) for q in Q], axis=1).reshape(len(self.neutral), -1))
        config = np.empty((len(self.neutral), len(Q)), order="F")
        config[:] = self.neutral[:, None]
        idx, col, scale, offset = self._plain
        if idx.size:
            config[idx] = scale[:, None] * Q[:, col].T + offset[:, None]
        idx, col, scale, offset = self._circle
        if idx.size:
            angles = scale[:, None] * Q[:, col].T + offset[:, None]
            config[idx] = np.cos(angles)
            config[idx + 1] = np.sin(angles)
        return config


def _quaternion_xyzw(roll: float, pitch: float, yaw: float) -> tuple[float, float, float, float]:
    """Unit quaternion (x, y, z, w) of ``Rz(yaw) Ry(pitch) Rx(roll)``."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return (sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy, cr * cp * cy + sr * sp * sy)


def joint_kind_axis(model: pin.Model, joint_id: int) -> tuple[str, np.ndarray]:
    """(``revolute``|``prismatic``, unit axis in the joint frame) of a one-degree-of-freedom joint.

    Read from the joint's motion subspace S = (linear, angular), which every
    Pinocchio joint model provides (aligned, unaligned, bounded or not).
    """
    jmodel = model.joints[joint_id]
    jdata = jmodel.createData()
    jmodel.calc(jdata, pin.neutral(model))
    S = np.array(jdata.S, dtype=float).ravel()
    linear, angular = S[:3], S[3:]
    if np.linalg.norm(angular) > 0.5:
        return "revolute", angular / np.linalg.norm(angular)
    return "prismatic", linear / np.linalg.norm(linear)


def _mimic_tags(robot_xml, where: str) -> dict[str, tuple[str, float, float]]:
    """Joint name -> (declared leader, multiplier, offset) of every ``<mimic>`` tag, checked."""
    tags = {}
    for element in robot_xml.findall("joint"):
        mimic = element.find("mimic")
        if mimic is None:
            continue
        name = element.get("name")
        leader = mimic.get("joint")
        values = []
        for attribute, default in (("multiplier", 1.0), ("offset", 0.0)):
            text = mimic.get(attribute)
            try:
                value = default if text is None else float(text)
            except ValueError:
                value = math.nan
            if not math.isfinite(value):
                raise DescriptionError(
                    f"{where}: joint '{name}': <mimic {attribute}=\"{text}\"> is not a finite number; "
                    f"give a number such as {default:g}"
                )
            values.append(value)
        if not leader:
            raise DescriptionError(f"{where}: joint '{name}': <mimic> needs joint=\"NAME\", the joint it follows")
        tags[name] = (leader, values[0], values[1])
    return tags


def _resolve_mimics(tags, types: dict[str, str], where: str) -> dict[str, tuple[str, float, float]]:
    """Mimic joint -> (independent leader, multiplier, offset), following mimic chains."""
    resolved = {}
    for name in tags:
        leader, multiplier, offset = tags[name]
        seen = [name]
        while leader in tags:
            if leader in seen:
                cycle = " -> ".join(seen + [leader])
                raise DescriptionError(f"{where}: mimic joints follow each other in a circle ({cycle}); "
                                       "one of them must be an independent joint")
            seen.append(leader)
            next_leader, m, o = tags[leader]
            multiplier, offset, leader = multiplier * m, multiplier * o + offset, next_leader
        if not (math.isfinite(multiplier) and math.isfinite(offset)):
            chain = " -> ".join(seen + [leader])
            raise DescriptionError(f"{where}: the mimic chain {chain} composes to multiplier {multiplier:g}, offset "
                                   f"{offset:g}; give multipliers and offsets whose products stay finite")
        kind = types.get(leader)
        if kind is None:
            raise DescriptionError(f"{where}: joint '{name}' mimics '{tags[name][0]}', which is not a joint of this robot")
        if kind not in ("revolute", "continuous", "prismatic"):
            raise DescriptionError(f"{where}: joint '{name}' mimics '{leader}', a {kind} joint; a mimic follows a "
                                   "revolute, continuous or prismatic joint")
        if types.get(name) not in ("revolute", "continuous", "prismatic"):
            raise DescriptionError(f"{where}: joint '{name}' is {types.get(name)} and has a <mimic>; only revolute, "
                                   "continuous and prismatic joints can mimic another")
        resolved[name] = (leader, multiplier, offset)
    return resolved


def joint_layout(model: pin.Model, robot_xml, where: str = "robot") -> JointLayout:
    """The joint vector of a Pinocchio model built with :func:`build_model` (see the module docstring).

    Raises
    ------
    DescriptionError
        A ``<mimic>`` naming no joint, a fixed or multi-degree-of-freedom
        joint, or joints mimicking each other in a circle; a planar joint
        whose axis is not z; a joint type manipkit does not handle.
    """
    # Over 80 lines: one pass over Pinocchio's joints filling the joint list, columns and mimic tables together.
    elements = {j.get("name"): j for j in robot_xml.findall("joint")}
    types = {name: element.get("type") for name, element in elements.items()}
    tags = _mimic_tags(robot_xml, where)
    mimics_raw = _resolve_mimics(tags, types, where)

    def links(name):
        element = elements.get(name)
        if element is None:
            return "?", "?"
        return element.find("parent").get("link"), element.find("child").get("link")

    joints: list[Joint] = []
    column_of: dict[str, int] = {}
    pending: list[tuple[int, str]] = []  # (joint id, mimic name): columns known once every leader has one
    columns: dict[int, list] = {}
    multi: list[tuple[str, int, int]] = []
    for joint_id in range(1, model.njoints):
        name = model.names[joint_id]
        jmodel = model.joints[joint_id]
        urdf_type = types.get(name, "?")
        parent, child = links(name)
        if name in mimics_raw:
            pending.append((joint_id, name))
            continue
        if urdf_type in COORDINATES and jmodel.nv == len(COORDINATES[urdf_type]):
            if urdf_type == "planar":
                _check_planar_axis(elements[name], name, where)
            first = len(joints)
            motions = []
            for k, coordinate in enumerate(COORDINATES[urdf_type]):
                axis = np.eye(3)[{"x": 0, "y": 1, "z": 2, "roll": 0, "pitch": 1, "yaw": 2}[coordinate]]
                axis.setflags(write=False)
                joints.append(Joint(f"{name}.{coordinate}", urdf_type, axis, -math.inf, math.inf, parent, child,
                                    name, coordinate))
                column_of[f"{name}.{coordinate}"] = first + k
                motions.append((first + k, 1.0, 0.0, "prismatic" if coordinate in _LINEAR else "revolute", axis))
            # Pinocchio's free flyer is Trans(p) R and its planar joint Trans(x, y) Rz: the rotations last,
            # in URDF's rpy order (yaw about z first as a product Rz Ry Rx).
            columns[joint_id] = motions if urdf_type == "planar" else motions[:3] + motions[3:][::-1]
            multi.append((urdf_type, jmodel.idx_q, first))
            continue
        if jmodel.nv != 1:
            raise DescriptionError(
                f"{where}: joint '{name}' is {urdf_type} ({jmodel.nv} degrees of freedom); manipkit handles "
                "revolute, continuous, prismatic, floating, planar and fixed joints"
            )
        kind, axis = joint_kind_axis(model, joint_id)
        axis.setflags(write=False)
        if jmodel.nq == 2:
            lower, upper, urdf_type = -math.inf, math.inf, "continuous"
        else:
            lower = float(model.lowerPositionLimit[jmodel.idx_q])
            upper = float(model.upperPositionLimit[jmodel.idx_q])
            urdf_type = kind if urdf_type not in ("revolute", "prismatic") else urdf_type
        column_of[name] = len(joints)
        columns[joint_id] = [(len(joints), 1.0, 0.0, kind, axis)]
        joints.append(Joint(name, urdf_type, axis, lower, upper, parent, child, name))
    mimics = {}
    for joint_id, name in pending:
        leader, multiplier, offset = mimics_raw[name]
        jmodel = model.joints[joint_id]
        if jmodel.nv != 1:
            raise DescriptionError(f"{where}: mimic joint '{name}' has {jmodel.nv} degrees of freedom; a mimic is "
                                   "revolute, continuous or prismatic")
        kind, axis = joint_kind_axis(model, joint_id)
        axis.setflags(write=False)
        columns[joint_id] = [(column_of[leader], multiplier, offset, kind, axis)]
        parent, child = links(name)
        mimic_type = "continuous" if jmodel.nq == 2 else types.get(name, kind)
        mimics[name] = Mimic(name, mimic_type, leader, multiplier, offset, tags[name][0], parent, child)
    mimics = {name: mimics[name] for name in elements if name in mimics}  # URDF order
    layout = JointLayout(tuple(joints), mimics, columns, pin.neutral(model))
    _index_configuration(layout, model)
    layout._multi = multi
    return layout


def _check_planar_axis(element, name: str, where: str) -> None:
    axis_element = element.find("axis")
    text = axis_element.get("xyz", "1 0 0") if axis_element is not None else "1 0 0"
    try:
        axis = np.array([float(v) for v in text.split()])
    except ValueError:
        axis = np.zeros(3)
    if axis.shape != (3,) or not np.allclose(axis / (np.linalg.norm(axis) or 1.0), (0.0, 0.0, 1.0), atol=1e-9):
        raise DescriptionError(
            f"{where}: planar joint '{name}' has axis \"{text}\"; manipkit handles planar joints moving in their "
            "frame's x-y plane (axis \"0 0 1\"): turn the joint's <origin> so that z is the plane's normal"
        )


def _index_configuration(layout: JointLayout, model: pin.Model) -> None:
    """Index arrays for :meth:`JointLayout.configuration`: where each one-degree-of-freedom value goes."""
    plain, circle = [], []
    for joint_id, motions in layout.columns.items():
        jmodel = model.joints[joint_id]
        if len(motions) != 1:
            continue
        column, scale, offset, _, _ = motions[0]
        (circle if jmodel.nq == 2 else plain).append((jmodel.idx_q, column, scale, offset))

    def arrays(rows):
        rows = np.array(rows, dtype=float).reshape(-1, 4)
        return rows[:, 0].astype(np.intp), rows[:, 1].astype(np.intp), rows[:, 2].copy(), rows[:, 3].copy()

    layout._plain, layout._circle = arrays(plain), arrays(circle)
    _, _, scale, offset = layout._plain
    layout._plain_is_copy = bool(np.all(scale == 1.0) and np.all(offset == 0.0))


def root_link(robot_xml) -> str:
    """The link that is no joint's child."""
    children = {j.find("child").get("link") for j in robot_xml.findall("joint")}
    return next(link.get("name") for link in robot_xml.findall("link") if link.get("name") not in children)


def build_model(text: str) -> tuple[pin.Model | None, list[str]]:
    """Pinocchio's model of URDF text (every joint, mimic ones included), and what its C++ parser printed.

    urdfdom writes its reasons (and its complaints about descriptions it
    still accepts) straight to file descriptor 2, out of reach of Python;
    it is redirected to a temporary file for the call, so the reasons end up
    in manipkit's one-line error or in the robot's warnings instead of raw on
    the terminal.
    """
    model, failure = None, None
    try:
        model, output = native_call(pin.buildModelFromXML, text, mimic=False)
    except (ValueError, RuntimeError) as exc:
        failure, output = " ".join(str(exc).split()), getattr(exc, "native_output", "")
    messages = [" ".join(line.replace("Error:", "").split()) for line in output.splitlines() if line.strip()]
    if model is None and failure and not messages:
        messages = [failure]
    return model, messages


#: Stack (bytes) of the thread :func:`native_call` runs Pinocchio's parsers on. They recurse once per joint
#: (about 2.2 kB a level, measured: 3,800 levels crashed an 8 MB stack); 64 MB holds the 2,000 joints
#: :data:`manipkit.description.validate.MAX_TREE_DEPTH` allows whatever ``ulimit -s`` the main thread has.
NATIVE_STACK_BYTES = 64 << 20
_NATIVE_LOCK = threading.Lock()


def native_call(function, *args, **kwargs):
    """``function(*args, **kwargs)`` (a Pinocchio or coal parser) on a thread with a :data:`NATIVE_STACK_BYTES`
    stack, with what its C++ code writes to file descriptor 2 captured: ``(value, output)``.

    An exception it raises is raised here, with the output as its ``native_output`` attribute. Calls are
    one at a time (file descriptor 2 is the process's); Python's ``sys.stderr`` is flushed first.
    """
    import sys
    import tempfile

    outcome: dict = {}

    def run():
        try:
            outcome["value"] = function(*args, **kwargs)
        except BaseException as exc:  # handed to the caller's thread
            outcome["error"] = exc

    with _NATIVE_LOCK, tempfile.TemporaryFile(mode="w+b") as captured:
        try:
            sys.stderr.flush()
        except (AttributeError, ValueError, OSError):
            pass
        try:
            saved = os.dup(2)
        except OSError:  # no file descriptor 2: nothing to capture
            saved = None
        try:
            if saved is not None:
                os.dup2(captured.fileno(), 2)
            previous = threading.stack_size(NATIVE_STACK_BYTES)
            try:
                worker = threading.Thread(target=run, name="native-parser", daemon=True)
                worker.start()
            finally:
                threading.stack_size(previous)
            worker.join()
        finally:
            if saved is not None:
                os.dup2(saved, 2)
                os.close(saved)
        captured.seek(0)
        output = captured.read().decode("utf-8", errors="replace")
    if "error" in outcome:
        error = outcome["error"]
        with contextlib.suppress(AttributeError, TypeError):
            error.native_output = output
        raise error
    return outcome["value"], output
