"""Fuzzing the description loaders: mutated URDF and xacro never crash, hang or load wrong.

Each case starts from a bundled robot: its expanded URDF (``Robot.from_urdf``
or ``manipkit.load`` of a ``.urdf`` file) or its xacro files (``manipkit.load``
of the top-level ``.urdf.xacro`` in a scratch copy of ``robots/``). The text is
mutated: elements deleted, duplicated or swapped; attributes set to random
numbers, NaN, inf, garbage, empty, huge or tiny values, or removed; links and
joints renamed (dangling references); joint types changed; axes zeroed or
scaled; limits swapped; the text truncated or spliced with random characters
or bytes; a value moved into a DOCTYPE entity; for xacro also arguments and
properties removed, ``${...}`` expressions, includes and macro calls broken,
and xacro arguments given odd values.

The oracle, for every case:

- the loader raises a :class:`ManipkitError` whose message is one non-empty
  line, or returns a robot; any other exception is a bug;
- a returned robot was built from a valid description, as judged by
  :func:`description_problems` below, written from the URDF specification
  (and what urdfdom, the reference parser, refuses), independently of
  ``manipkit.description.validate``;
- a returned robot is consistent with its text: the movable joints, their
  types, parents, children, axes and limits, the links and the root are those
  the text declares; ``sample_q`` stays finite and inside the limits; FK of
  every link at random joint values inside the limits is finite, the batched
  ``Robot.fk`` equals ``Robot.transform``, and both agree with yourdfpy's FK
  (a second parser composing the chain itself) to 1e-9 (rotation) and
  1e-9 * (1 + the summed link offsets) (translation);
- every case ends within the hypothesis deadline, and a hard alarm guards
  against hangs that the deadline cannot interrupt.

``MANIPKIT_FUZZ_EXAMPLES`` sets the number of cases per fuzz test (default
300, deterministic; ``make fuzz`` runs 10,000 with fresh randomness and the
example database). When a case fails, its shrunk input is written to
``/tmp/manipkit_fuzz_failure.*`` (``/tmp/manipkit_fuzz_failure_xacro/`` for
xacro) so it can be replayed with ``manipkit.load``.
"""

from __future__ import annotations

import ast
import copy
import functools
import io
import math
import os
import re
import shutil
import signal
import tempfile
import time
from contextlib import contextmanager, redirect_stderr, redirect_stdout
from dataclasses import dataclass, field
from datetime import timedelta
from io import BytesIO
from pathlib import Path

import numpy as np
import pytest
import yourdfpy
from hypothesis import HealthCheck, currently_in_test_context, event, given, settings
from hypothesis import strategies as st
from lxml import etree

import manipkit
from manipkit.description.sources import bundled_dir, bundled_robots, resolve_robot
from manipkit.description.xacro import urdf_text
from manipkit.errors import ManipkitError
from manipkit.kinematics.robot import Robot

EXAMPLES = int(os.environ.get("MANIPKIT_FUZZ_EXAMPLES", "300"))
FUZZING = "MANIPKIT_FUZZ_EXAMPLES" in os.environ  # make fuzz: fresh randomness, example database
DEADLINE_MS = int(os.environ.get("MANIPKIT_FUZZ_DEADLINE_MS", "2000"))
# An include loop makes xacro recurse to Python's recursion limit before it fails: about 1 s.
XACRO_DEADLINE_MS = int(os.environ.get("MANIPKIT_FUZZ_XACRO_DEADLINE_MS", "5000"))
HARD_TIMEOUT_S = 20.0  # a case still running after this is a hang, even inside C++ or a busy loop
FAILURE_PREFIX = Path(tempfile.gettempdir()) / "manipkit_fuzz_failure"

FUZZ_SETTINGS = settings(
    max_examples=EXAMPLES,
    deadline=timedelta(milliseconds=DEADLINE_MS),
    derandomize=not FUZZING,
    database=settings.default.database if FUZZING else None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large, HealthCheck.filter_too_much],
    print_blob=True,
)
XACRO_FUZZ_SETTINGS = settings(FUZZ_SETTINGS, deadline=timedelta(milliseconds=XACRO_DEADLINE_MS))
# pytest-timeout's 300 s (pyproject) is for one ordinary test; the fuzz tests get a budget per case.
FUZZ_TIMEOUT = pytest.mark.timeout(max(300, int(EXAMPLES * 0.5)))


# ==========================================================================
# The independent judge of a description: the URDF specification, written out
# ==========================================================================

JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed", "floating", "planar")
MOVABLE = ("revolute", "continuous", "prismatic")
# The entries of a floating or planar joint in the joint vector (manipkit's documented naming, ``<joint>.<coordinate>``;
# URDF gives a floating joint six degrees of freedom and a planar one three: two translations in the plane, one turn)
COORDINATES = {"floating": ("x", "y", "z", "roll", "pitch", "yaw"), "planar": ("x", "y", "yaw")}
# A number as URDF (urdfdom, via std::istringstream in the C locale) reads one:
# ASCII digits, optional sign, point and exponent; no nan, inf, hex, '_' or other scripts.
NUMBER = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?\Z")


class _Invalid(Exception):
    """One reason a description is not valid URDF."""


@dataclass
class SpecJoint:
    name: str
    type: str
    parent: str
    child: str
    xyz: np.ndarray
    rpy: np.ndarray
    axis: np.ndarray  # unit vector (URDF default 1 0 0), for movable joints
    lower: float
    upper: float


@dataclass
class Spec:
    """What a URDF text declares, read by the rules of the specification."""

    problems: list[str] = field(default_factory=list)
    links: list[str] = field(default_factory=list)
    joints: dict[str, SpecJoint] = field(default_factory=dict)
    root: str | None = None


def _numbers(value: str | None, count: int, what: str) -> list[float]:
    if value is None:
        raise _Invalid(f"{what} is missing")
    tokens = value.split()
    if len(tokens) != count or not all(NUMBER.match(t) for t in tokens):
        raise _Invalid(f"{what} is {value!r}, not {count} number(s)")
    numbers = [float(t) for t in tokens]
    if not all(math.isfinite(x) for x in numbers):
        raise _Invalid(f"{what} is {value!r}, not finite")
    return numbers


def _optional_numbers(element, attribute: str, count: int, what: str, default: float = 0.0) -> list[float]:
    if element is None or element.get(attribute) is None:
        return [default] * count
    return _numbers(element.get(attribute), count, what)


def _unit(vector: list[float]) -> np.ndarray:
    v = np.array(vector, dtype=float)
    big = np.max(np.abs(v))
    if big == 0.0:
        raise _Invalid("a movable joint's axis is zero")
    v = v / big  # scale first: the norm of (5e-324, 0, 0) underflows, its direction does not
    return v / np.linalg.norm(v)


def _check_origin(parent, what: str) -> tuple[list[float], list[float]]:
    origin = parent.find("origin")
    return (_optional_numbers(origin, "xyz", 3, f"{what} origin xyz"),
            _optional_numbers(origin, "rpy", 3, f"{what} origin rpy"))


def _check_link_contents(link, name: str, problems: list[str]) -> None:
    """Inertial, visual and collision numbers: urdfdom refuses a model whose numbers do not parse."""
    def guarded(check):
        try:
            check()
        except _Invalid as exc:
            problems.append(f"link '{name}': {exc} (inertial/geometry)")

    inertial = link.find("inertial")
    if inertial is not None:
        guarded(lambda: _check_origin(inertial, "inertial"))
        mass, inertia = inertial.find("mass"), inertial.find("inertia")
        guarded(lambda: _numbers(None if mass is None else mass.get("value"), 1, "inertial mass value"))
        for key in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz"):
            guarded(lambda key=key: _numbers(None if inertia is None else inertia.get(key), 1, f"inertia {key}"))
    for kind in ("visual", "collision"):
        for shape_owner in link.findall(kind):
            guarded(lambda owner=shape_owner: _check_origin(owner, kind))
            geometry = shape_owner.find("geometry")
            for shape in [] if geometry is None else list(geometry):
                sizes = {"box": (("size", 3),), "cylinder": (("radius", 1), ("length", 1)), "sphere": (("radius", 1),),
                         "capsule": (("radius", 1), ("length", 1))}.get(shape.tag, ())
                for attribute, count in sizes:
                    guarded(lambda shape=shape, attribute=attribute, count=count:
                            _numbers(shape.get(attribute), count, f"{kind} {shape.tag} {attribute}"))
                if shape.tag == "mesh" and shape.get("scale") is not None:
                    guarded(lambda shape=shape: _numbers(shape.get("scale"), 3, f"{kind} mesh scale"))


def _joint(element, name: str, links: set[str]) -> SpecJoint:
    kind = element.get("type")
    if kind not in JOINT_TYPES:
        raise _Invalid(f"joint '{name}' has type {kind!r}")
    ends = []
    for tag in ("parent", "child"):
        end = element.find(tag)
        link = None if end is None else end.get("link")
        if not link or link not in links:
            raise _Invalid(f"joint '{name}' {tag} link {link!r} is missing or does not exist")
        ends.append(link)
    xyz, rpy = _check_origin(element, f"joint '{name}'")
    axis = np.array([1.0, 0.0, 0.0])
    if kind in MOVABLE or kind == "planar":
        axis_element = element.find("axis")
        if axis_element is not None and axis_element.get("xyz") is not None:  # <axis/> keeps 1 0 0 (urdfdom)
            axis = _unit(_numbers(axis_element.get("xyz"), 3, f"joint '{name}' axis xyz"))
    limit = element.find("limit")
    lower, upper = -math.inf, math.inf
    if limit is None and kind in ("revolute", "prismatic"):
        raise _Invalid(f"{kind} joint '{name}' has no <limit>")
    if limit is not None:  # urdfdom reads a <limit> on any joint type
        for attribute in ("effort", "velocity"):  # required by the URDF schema
            _numbers(limit.get(attribute), 1, f"joint '{name}' limit {attribute}")
        low = _optional_numbers(limit, "lower", 1, f"joint '{name}' limit lower")[0]
        high = _optional_numbers(limit, "upper", 1, f"joint '{name}' limit upper")[0]
        if kind in ("revolute", "prismatic"):
            if low > high:
                raise _Invalid(f"joint '{name}' has lower limit {low} above upper limit {high}")
            lower, upper = low, high
    return SpecJoint(name, kind, ends[0], ends[1], np.array(xyz), np.array(rpy), axis, lower, upper)


def read_spec(text: str) -> Spec:
    """Read a URDF text by the specification; ``problems`` lists why it is invalid (empty: valid)."""
    spec = Spec()
    parser = etree.XMLParser(resolve_entities=True, no_network=True, huge_tree=False, remove_comments=True)
    try:
        robot = etree.fromstring(text.encode("utf-8"), parser)
    except (etree.XMLSyntaxError, UnicodeEncodeError, ValueError) as exc:
        spec.problems.append(f"not well-formed XML: {exc}")
        return spec
    if robot.tag != "robot":
        spec.problems.append(f"root element is {robot.tag!r}, not <robot>")
        return spec
    if not robot.get("name"):
        spec.problems.append("<robot> has no name")
    names: dict[str, list[str]] = {"link": [], "joint": []}
    for tag in names:
        for element in robot.findall(tag):
            name = element.get("name")
            if not name:
                spec.problems.append(f"a <{tag}> has no name")
            elif name in names[tag]:
                spec.problems.append(f"two <{tag}> elements are named '{name}'")
            names[tag].append(name)
    spec.links = [n for n in names["link"] if n]
    if not spec.links:
        spec.problems.append("no <link>")
    links = set(spec.links)
    for element in robot.findall("link"):
        _check_link_contents(element, element.get("name"), spec.problems)
    for element in robot.findall("joint"):
        name = element.get("name")
        try:
            spec.joints.setdefault(name, _joint(element, name, links))
        except _Invalid as exc:
            spec.problems.append(str(exc))
    if spec.problems:
        return spec

    # The tree: every link has at most one parent, one root, every link below it.
    parent_of: dict[str, str] = {}
    for joint in spec.joints.values():
        if joint.child in parent_of:
            spec.problems.append(f"link '{joint.child}' has two parents")
        parent_of[joint.child] = joint.parent
    roots = [link for link in spec.links if link not in parent_of]
    if len(roots) != 1:
        spec.problems.append(f"{len(roots)} root links")
        return spec
    spec.root = roots[0]
    for link in spec.links:
        seen, up = {link}, link
        while up in parent_of:
            up = parent_of[up]
            if up in seen:
                spec.problems.append(f"link '{link}' is on a cycle")
                return spec
            seen.add(up)
    return spec


def description_problems(text: str) -> list[str]:
    """Why a URDF text is invalid (empty list: valid)."""
    return read_spec(text).problems


def _matrix_from_rpy(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """R = Rz(yaw) Ry(pitch) Rx(roll), the URDF convention, multiplied out by hand."""
    cr, sr, cp, sp, cy, sy = (math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch),
                              math.cos(yaw), math.sin(yaw))
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def _matrix_from_axis_angle(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rodrigues: I + sin(angle) K + (1 - cos(angle)) K^2, K the cross-product matrix of the unit axis."""
    x, y, z = axis
    K = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    return np.eye(3) + math.sin(angle) * K + (1.0 - math.cos(angle)) * (K @ K)


def spec_fk(spec: Spec, values: dict[str, float], link: str) -> np.ndarray:
    """T_root_link composed from the text itself: origin(xyz, rpy) then the joint's motion, root to link."""
    joint_above = {joint.child: joint for joint in spec.joints.values()}
    chain = []
    while link != spec.root:
        chain.append(joint_above[link])
        link = chain[-1].parent
    T = np.eye(4)
    for joint in reversed(chain):
        step = np.eye(4)
        step[:3, :3] = _matrix_from_rpy(*joint.rpy)
        step[:3, 3] = joint.xyz
        motion = np.eye(4)
        if joint.type in ("revolute", "continuous"):
            motion[:3, :3] = _matrix_from_axis_angle(joint.axis, values[joint.name])
        elif joint.type == "prismatic":
            motion[:3, 3] = joint.axis * values[joint.name]
        elif joint.type in COORDINATES:  # floating: Trans(x, y, z) Rz(yaw) Ry(pitch) Rx(roll); planar: Trans(x, y) Rz(yaw)
            at = {c: values[f"{joint.name}.{c}"] for c in COORDINATES[joint.type]}
            motion[:3, :3] = _matrix_from_rpy(at.get("roll", 0.0), at.get("pitch", 0.0), at["yaw"])
            motion[:3, 3] = at["x"], at["y"], at.get("z", 0.0)
        T = T @ step @ motion
    return T


# ==========================================================================
# The oracle
# ==========================================================================


class CaseTimeout(BaseException):
    """A case ran past the hard timeout (a BaseException, so no ``except Exception`` in the loader hides it)."""


@contextmanager
def hard_timeout(seconds: float):
    """SIGALRM after ``seconds``; pytest-timeout's own timer (also SIGALRM) is put back afterwards."""
    def on_alarm(signum, frame):
        raise CaseTimeout(f"case still running after {seconds} s")

    start = time.monotonic()
    previous_handler = signal.signal(signal.SIGALRM, on_alarm)
    previous_remaining, previous_interval = signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous_handler)
        if previous_remaining:
            left = max(previous_remaining - (time.monotonic() - start), 1e-3)
            signal.setitimer(signal.ITIMER_REAL, left, previous_interval)


def _event(label: str) -> None:
    if currently_in_test_context():  # also called from the plain regression tests below
        event(label)


def load_cleanly_or_refuse(load) -> Robot | None:
    """Run a loader: a robot, or None after a clean ManipkitError; anything else fails the case."""
    try:
        with hard_timeout(HARD_TIMEOUT_S):
            robot = load()
    except ManipkitError as exc:
        message = str(exc)
        assert message.strip(), f"{type(exc).__name__} with an empty message"
        assert "\n" not in message and "\r" not in message, f"{type(exc).__name__} message is not one line: {message!r}"
        _event(f"refused: {type(exc).__name__}")
        return None
    except CaseTimeout:
        raise AssertionError(f"hang: the loader ran past {HARD_TIMEOUT_S} s") from None
    except Exception as exc:  # noqa: BLE001 - any other exception is the bug this test looks for
        raise AssertionError(f"uncaught {type(exc).__module__}.{type(exc).__name__}: {exc}") from exc
    _event("loaded")
    return robot


def _yourdfpy(text: str):
    urdf = yourdfpy.URDF.load(BytesIO(text.encode()), build_scene_graph=True, load_meshes=False,
                              build_collision_scene_graph=False, load_collision_meshes=False)
    # URDF axes are directions (ROS' KDL and Pinocchio normalise them); yourdfpy scales a
    # prismatic step by the axis as written, so give it the unit axis.
    for joint in urdf.robot.joints:
        if joint.axis is not None and joint.type in MOVABLE:
            joint.axis = _unit(list(joint.axis))
    return urdf


def _joint_values(robot: Robot, rng: np.random.Generator, n: int) -> np.ndarray:
    """``n`` joint vectors inside the limits (continuous: [-pi, pi]), without overflow for huge limits."""
    Q = np.empty((n, len(robot.joints)))
    for i, joint in enumerate(robot.joints):
        u = rng.random(n)
        if math.isfinite(joint.lower) and math.isfinite(joint.upper):
            Q[:, i] = joint.lower * (1.0 - u) + joint.upper * u
        else:
            Q[:, i] = -math.pi * (1.0 - u) + math.pi * u
    return Q


def check_robot(robot: Robot, seed: int, text: str | None = None) -> None:
    """A returned robot: valid description, and consistent with it and with yourdfpy.

    ``text`` is the URDF as the user gave it (or as xacro expands it), judged and parsed by yourdfpy
    as it is, whatever manipkit made of it; default: ``robot.urdf``.
    """
    text = robot.urdf if text is None else text
    try:
        _check_robot(robot, seed, text)
    except AssertionError:
        raise
    except Exception as exc:  # noqa: BLE001 - a loaded robot's own API must not fail on it
        raise AssertionError(f"a loaded robot's API raised {type(exc).__name__}: {exc}") from exc


def _check_robot(robot: Robot, seed: int, text: str) -> None:
    spec = read_spec(text)
    assert not spec.problems, "model built from an invalid description: " + "; ".join(spec.problems[:4])

    movable = {name: j for name, j in spec.joints.items() if j.type in MOVABLE}
    entries = {f"{name}.{c}": j for name, j in spec.joints.items() for c in COORDINATES.get(j.type, ())}
    assert set(robot.joint_names) == set(movable) | set(entries), (
        f"joints {robot.joint_names} != movable joints {sorted(movable)} and coordinates {sorted(entries)}")
    for joint in robot.joints:
        if joint.name in entries:  # one coordinate of a floating or planar joint: its type and ends are the joint's
            declared = entries[joint.name]
            assert (joint.type, joint.parent, joint.child) == (declared.type, declared.parent, declared.child), (
                f"coordinate '{joint.name}': {joint.type} {joint.parent} -> {joint.child}, "
                f"declared {declared.type} {declared.parent} -> {declared.child}")
            continue
        declared = movable[joint.name]
        assert (joint.type, joint.parent, joint.child) == (declared.type, declared.parent, declared.child), (
            f"joint '{joint.name}': {joint.type} {joint.parent} -> {joint.child}, "
            f"declared {declared.type} {declared.parent} -> {declared.child}")
        assert np.allclose(joint.axis, declared.axis, atol=1e-12, rtol=0), (
            f"joint '{joint.name}' axis {joint.axis}, declared {declared.axis}")
        for got, want, which in ((joint.lower, declared.lower, "lower"), (joint.upper, declared.upper, "upper")):
            assert got == want or abs(got - want) <= 1e-12 * abs(want), f"joint '{joint.name}' {which} {got}, declared {want}"
    assert set(robot.frame_names) == set(spec.links), (
        f"frames {sorted(robot.frame_names)} != links {sorted(spec.links)}")
    assert robot.root_link == spec.root, f"root {robot.root_link!r}, declared {spec.root!r}"

    sampled = robot.sample_q(3, seed=seed)
    assert np.all(np.isfinite(sampled)), f"sample_q gave non-finite values {sampled}"
    assert not robot.outside_limits(sampled).any(), "sample_q left the limits"

    try:
        urdf = _yourdfpy(text)
    except Exception as exc:  # noqa: BLE001
        raise AssertionError(f"yourdfpy cannot read a description manipkit loaded: {type(exc).__name__}: {exc}") from exc
    # Rounding in a translation grows with the lengths composed: offsets and prismatic strokes.
    length = sum(float(np.linalg.norm(j.xyz)) for j in spec.joints.values())
    length += sum(max(abs(j.lower), abs(j.upper)) for j in movable.values() if j.type == "prismatic")
    tol_translation = 1e-9 * (1.0 + length)

    # yourdfpy's scene graph (trimesh) drops every edge within 1e-8 of the identity and ignores
    # updates smaller than 1e-8: allow that much per joint against it.
    snap = 2e-8 * len(spec.joints)

    Q = np.vstack([robot.q(), _joint_values(robot, np.random.default_rng(seed), 3)])
    batched = {frame: robot.fk(Q, base=robot.root_link, tip=frame) for frame in robot.frame_names}
    # yourdfpy takes a floating or planar joint's value as one matrix or vector of its own: it judges the trees
    # without them, the hand-composed FK every tree
    judged_by_yourdfpy = not entries
    for q_index, q in enumerate(Q):
        values = {name: float(value) for name, value in zip(robot.joint_names, q)}
        if judged_by_yourdfpy:
            urdf.update_cfg(values)
        for frame in robot.frame_names:
            T = robot.transform(robot.root_link, frame, q, check_limits=False)
            assert np.all(np.isfinite(T)), f"non-finite FK of '{frame}' at q = {q.tolist()}: {T.tolist()}"
            references = (
                (batched[frame][q_index], "Robot.fk", 0.0),
                (spec_fk(spec, values, frame), "the text composed by hand", 0.0),
                *(((urdf.get_transform(frame_to=frame, frame_from=spec.root), "yourdfpy", snap),)
                  if judged_by_yourdfpy else ()),
            )
            for other, who, slack in references:
                rotation = float(np.abs(T[:3, :3] - other[:3, :3]).max())
                translation = float(np.abs(T[:3, 3] - other[:3, 3]).max())
                assert rotation <= 1e-9 + slack and translation <= tol_translation + slack, (
                    f"silently wrong answer: T_{spec.root}_{frame} at q = {q.tolist()} differs from {who} by "
                    f"{rotation:.3g} (rotation), {translation:.3g} m (translation)")


# ==========================================================================
# Mutations
# ==========================================================================

SPECIAL_NUMBERS = (
    "nan", "NaN", "-nan", "inf", "-inf", "Infinity", "1e400", "-1e400", "1e300", "-1e300",
    "1.7976931348623157e308", "1e12", "-1e12", "1e-12", "1e-300", "5e-324", "-0", "0", "1", "-1", "2",
    "3.141592653589793", "0.5", "+1", "1.", ".5",
)
GARBAGE = ("", " ", "abc", "1,2,3", "0x10", "1_0", "1e", "--1", "\u0661", "1 2", "1 2 3 4", "${l1}", "None", "true")
XML_TEXT = st.characters(codec="utf-8", exclude_categories=("Cs", "Cc", "Cn"))

number_token = st.one_of(
    st.sampled_from(SPECIAL_NUMBERS),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers(-10**6, 10**6).map(str),
)
attribute_value = st.one_of(
    number_token,
    st.lists(number_token, min_size=1, max_size=4).map(" ".join),
    st.sampled_from(GARBAGE),
    st.text(XML_TEXT, max_size=12),
)
JOINT_TYPE_CHOICES = JOINT_TYPES + ("", "Revolute", "hinge", "spherical", "continuous ")
SCALES = (0.0, 5e-324, 1e-300, 1e-12, -1.0, 2.0, 1e12, 1e300, math.inf, math.nan)


def _pick(data, items, label):
    items = list(items)
    if not items:
        return None
    return items[data.draw(st.integers(0, len(items) - 1), label=label)]


def _elements(root) -> list:
    return [e for e in root.iter() if e is not root and isinstance(e.tag, str)]


def _named(root, tag: str) -> list:
    return [e for e in root if e.tag == tag]


def _names(root) -> list[str]:
    return [e.get("name") for e in root if e.tag in ("link", "joint") and e.get("name")]


def delete_element(data, root) -> None:
    element = _pick(data, _elements(root), "delete")
    if element is not None:
        element.getparent().remove(element)


def duplicate_element(data, root) -> None:
    element = _pick(data, _elements(root), "duplicate")
    if element is not None:
        element.addnext(copy.deepcopy(element))


def swap_elements(data, root) -> None:
    elements = _elements(root)
    a, b = _pick(data, elements, "swap a"), _pick(data, elements, "swap b")
    if a is None or a is b or any(x is b for x in a.iter()) or any(x is a for x in b.iter()):
        return
    mark_a, mark_b = etree.Element("mark"), etree.Element("mark")
    a.addprevious(mark_a)
    b.addprevious(mark_b)
    mark_a.getparent().replace(mark_a, b)
    mark_b.getparent().replace(mark_b, a)


def set_attribute(data, root) -> None:
    element = _pick(data, [e for e in _elements(root) if e.attrib] or _elements(root), "set attribute of")
    if element is None:
        return
    keys = list(element.attrib) + ["xyz", "rpy", "lower", "upper", "value", "name", "link", "type"]
    key = _pick(data, keys, "attribute")
    element.set(key, data.draw(attribute_value, label="value"))


def remove_attribute(data, root) -> None:
    element = _pick(data, [e for e in _elements(root) if e.attrib], "remove attribute of")
    if element is not None:
        del element.attrib[_pick(data, list(element.attrib), "attribute")]


def rename(data, root) -> None:
    element = _pick(data, [e for e in root if e.tag in ("link", "joint")], "rename")
    if element is None:
        return
    name = element.get("name") or ""
    choices = st.one_of(
        st.sampled_from(_names(root) + ["world", "universe", "base_link", "ee_link", "", name + "_x", name.upper()]),
        st.text(XML_TEXT, max_size=8),
    )
    element.set("name", data.draw(choices, label="new name"))


def relink(data, root) -> None:
    ends = [end for joint in _named(root, "joint") for end in joint if end.tag in ("parent", "child")]
    end = _pick(data, ends, "relink")
    if end is not None:
        choices = st.one_of(st.sampled_from(_names(root) + ["", "missing_link"]), st.text(XML_TEXT, max_size=6))
        end.set("link", data.draw(choices, label="link"))


def change_joint_type(data, root) -> None:
    joint = _pick(data, _named(root, "joint"), "joint type of")
    if joint is not None:
        joint.set("type", data.draw(st.sampled_from(JOINT_TYPE_CHOICES), label="type"))


def change_axis(data, root) -> None:
    joint = _pick(data, _named(root, "joint"), "axis of")
    if joint is None:
        return
    axis = joint.find("axis")
    if axis is None:
        axis = etree.SubElement(joint, "axis")
        axis.set("xyz", "0 0 1")
    how = data.draw(st.sampled_from(["zero", "scale", "random", "remove"]), label="axis change")
    if how == "remove":
        joint.remove(axis)
    elif how == "zero":
        axis.set("xyz", "0 0 0")
    elif how == "scale":
        factor = data.draw(st.sampled_from(SCALES), label="factor")
        try:
            values = [float(v) * factor for v in axis.get("xyz", "1 0 0").split()]
        except ValueError:
            values = [factor]
        axis.set("xyz", " ".join(repr(v) for v in values))
    else:
        axis.set("xyz", " ".join(data.draw(st.lists(number_token, min_size=3, max_size=3), label="axis")))


def swap_limits(data, root) -> None:
    limit = _pick(data, [e for e in _elements(root) if e.tag == "limit"], "limits of")
    if limit is not None:
        lower, upper = limit.get("lower", "0"), limit.get("upper", "0")
        limit.set("lower", upper)
        limit.set("upper", lower)


TREE_OPS = (delete_element, duplicate_element, swap_elements, set_attribute, remove_attribute, rename, relink,
            change_joint_type, change_axis, swap_limits)


def truncate(data, text: str) -> str:
    return text[: data.draw(st.integers(0, len(text)), label="truncate at")]


def insert_text(data, text: str) -> str:
    at = data.draw(st.integers(0, len(text)), label="insert at")
    return text[:at] + data.draw(st.text(max_size=16), label="inserted") + text[at:]


def delete_slice(data, text: str) -> str:
    start = data.draw(st.integers(0, len(text)), label="cut from")
    stop = data.draw(st.integers(start, min(len(text), start + 200)), label="cut to")
    return text[:start] + text[stop:]


def value_into_entity(data, text: str) -> str:
    """Move one attribute value into a DOCTYPE entity (expanded by some XML parsers, not by others)."""
    values = list(re.finditer(r'="([^"&<]*)"', text))
    match = _pick(data, values, "entity for")
    if match is None:
        return text
    body = text[: match.start(1)] + "&v;" + text[match.end(1):]
    declaration = re.match(r"\s*<\?xml[^>]*\?>", body)
    at = declaration.end() if declaration else 0
    return body[:at] + f'<!DOCTYPE robot [<!ENTITY v "{match.group(1)}">]>' + body[at:]


TEXT_OPS = (truncate, insert_text, delete_slice, value_into_entity)


def mutate_xml(data, text: str, *, max_tree_ops: int = 3) -> str:
    """Tree mutations (when the text parses), then text mutations."""
    try:
        root = etree.fromstring(text.encode())
    except etree.XMLSyntaxError:
        root = None
    if root is not None:
        for op in data.draw(st.lists(st.sampled_from(TREE_OPS), max_size=max_tree_ops), label="tree mutations"):
            op(data, root)
        text = etree.tostring(root, encoding="unicode")
    for op in data.draw(st.lists(st.sampled_from(TEXT_OPS), max_size=2), label="text mutations"):
        text = op(data, text)
    return text


# ==========================================================================
# Seeds and scratch space
# ==========================================================================


@functools.lru_cache(maxsize=1)
def urdf_seeds() -> dict[str, str]:
    """Name -> expanded URDF of every bundled robot."""
    return {name: urdf_text(resolve_robot(name)) for name in sorted(bundled_robots())}


def xacro_includes(text: str) -> list[str]:
    return re.findall(r'<xacro:include\s+filename="([^"$]+)"', text)


@functools.lru_cache(maxsize=1)
def xacro_seeds() -> dict[str, tuple[str, ...]]:
    """Top-level xacro file -> the files it is made of (itself and its includes, transitively)."""
    seeds = {}
    for path in sorted(bundled_robots().values()):
        files, todo = [path.name], [path.name]
        while todo:
            for included in xacro_includes((bundled_dir() / todo.pop()).read_text()):
                if included not in files:
                    files.append(included)
                    todo.append(included)
        seeds[path.name] = tuple(files)
    return seeds


@pytest.fixture(scope="module")
def scratch(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("fuzz")


def _save_failure(suffix: str, content: bytes | str) -> Path:
    path = Path(f"{FAILURE_PREFIX}{suffix}")
    path.write_bytes(content if isinstance(content, bytes) else content.encode("utf-8", "surrogateescape"))
    return path


# ==========================================================================
# The fuzz tests
# ==========================================================================


def run_urdf_case(data, scratch: Path) -> None:
    """One URDF case: draw a seed and mutations, load, judge (AssertionError on a bug)."""
    seeds = urdf_seeds()
    seed_name = data.draw(st.sampled_from(sorted(seeds)), label="seed robot")
    q_seed = data.draw(st.integers(0, 2**16), label="q seed")  # every draw before the (slow) load
    text = mutate_xml(data, seeds[seed_name])
    if data.draw(st.booleans(), label="through a .urdf file"):
        raw = text.encode("utf-8", "surrogatepass")
        if data.draw(st.booleans(), label="insert raw bytes"):
            at = data.draw(st.integers(0, len(raw)), label="bytes at")
            raw = raw[:at] + data.draw(st.binary(min_size=1, max_size=8), label="bytes") + raw[at:]
            try:
                text = raw.decode("utf-8")
            except UnicodeDecodeError:
                text = None  # not UTF-8: not a valid description (the loader must refuse it)
        path = scratch / f"{seed_name}.urdf"
        path.write_bytes(raw)
        loader = functools.partial(manipkit.load, path)
    else:
        raw = text
        loader = functools.partial(Robot.from_urdf, text)
    try:
        robot = load_cleanly_or_refuse(loader)
        if robot is not None:
            assert text is not None, "model built from a file that is not UTF-8 text"
            check_robot(robot, seed=q_seed, text=text)
    except AssertionError:
        _save_failure(".urdf", raw)
        raise


@FUZZ_TIMEOUT
@FUZZ_SETTINGS
@given(data=st.data())
def test_mutated_urdf_is_refused_cleanly_or_loads_correctly(data, scratch):
    run_urdf_case(data, scratch)


XACRO_ARG_VALUES = st.one_of(number_token, st.sampled_from(GARBAGE + ("${1/0}", "$(arg l1)", "0", "-1")))
BROKEN_EXPRESSIONS = ("", "1/0", "nope", "(", "l1 +", "'abc'", "1e999", "float('nan')", "pi * 1e308", "${", "}")
BROKEN_INCLUDES = ("missing.xacro", "", "dh/iiwa14.yaml", "$(find no_such_package)/x.xacro", "../missing/x.xacro")


def remove_xacro_declaration(data, text: str, _name: str) -> str:
    tags = list(re.finditer(r"<xacro:(?:arg|property)\b[^>]*/>", text))
    match = _pick(data, tags, "remove declaration")
    return text if match is None else text[: match.start()] + text[match.end():]


def break_expression(data, text: str, _name: str) -> str:
    expressions = list(re.finditer(r"\$\{([^}]*)\}", text))
    match = _pick(data, expressions, "break expression")
    if match is None:
        return text
    broken = data.draw(st.one_of(st.sampled_from(BROKEN_EXPRESSIONS), st.text(XML_TEXT, max_size=6)), label="expression")
    if broken in ("${", "}"):  # unbalanced: drop the closing brace
        return text[: match.end() - 1] + text[match.end():]
    return text[: match.start(1)] + broken.replace('"', "'") + text[match.end(1):]


def break_include(data, text: str, name: str) -> str:
    includes = list(re.finditer(r'<xacro:include\s+filename="([^"]*)"', text))
    match = _pick(data, includes, "break include")
    if match is None:
        return text
    target = data.draw(st.sampled_from(BROKEN_INCLUDES + (name,)), label="include target")  # name: includes itself
    return text[: match.start(1)] + target + text[match.end(1):]


def break_macro_call(data, text: str, _name: str) -> str:
    calls = [m for m in re.finditer(r"<xacro:(\w+)((?:\s+\w+=\"[^\"]*\")*)", text)
             if m.group(1) not in ("arg", "property", "include", "macro", "if", "unless", "insert_block")]
    match = _pick(data, calls, "break macro call")
    if match is None:
        return text
    if data.draw(st.booleans(), label="rename the macro"):
        return text[: match.start(1)] + match.group(1) + "_missing" + text[match.end(1):]
    params = list(re.finditer(r'\s+\w+="[^"]*"', match.group(2)))
    param = _pick(data, params, "drop parameter")
    if param is None:
        return text
    start = match.start(2) + param.start()
    return text[:start] + text[start + len(param.group(0)):]


def xml_mutations(data, text: str, _name: str) -> str:
    return mutate_xml(data, text, max_tree_ops=2)


XACRO_OPS = (remove_xacro_declaration, break_expression, break_include, break_macro_call, xml_mutations)


def expand_xacro_independently(path: Path, args: dict[str, str]) -> str:
    """The URDF that xacro itself makes of a file (not manipkit's expansion), for the oracle."""
    import xacro

    quiet = io.StringIO()
    try:
        with redirect_stdout(quiet), redirect_stderr(quiet):
            return xacro.process_file(str(path), mappings=dict(args)).toxml()
    except Exception as exc:  # noqa: BLE001
        raise AssertionError(f"manipkit loaded a xacro file that xacro cannot expand: {type(exc).__name__}: {exc}") from exc


def run_xacro_case(data, scratch: Path) -> None:
    """One xacro case: draw a robot, a file of it, mutations and arguments, load, judge."""
    top = data.draw(st.sampled_from(sorted(xacro_seeds())), label="seed robot")
    target = data.draw(st.sampled_from(xacro_seeds()[top]), label="file to mutate")
    q_seed = data.draw(st.integers(0, 2**16), label="q seed")  # every draw before the (slow) load
    text = (bundled_dir() / target).read_text()
    for op in data.draw(st.lists(st.sampled_from(XACRO_OPS), min_size=1, max_size=3), label="xacro mutations"):
        text = op(data, text, target)
    declared = re.findall(r'<xacro:arg\s+name="([^"]+)"', (bundled_dir() / top).read_text())
    args = {}
    if data.draw(st.booleans(), label="give an argument"):
        name = data.draw(st.sampled_from(declared + ["not_an_argument"]), label="argument")
        args[name] = data.draw(XACRO_ARG_VALUES, label="argument value")

    case = Path(tempfile.mkdtemp(dir=scratch))
    try:
        shutil.copytree(bundled_dir(), case, dirs_exist_ok=True)
        (case / target).write_text(text)
        try:
            robot = load_cleanly_or_refuse(functools.partial(manipkit.load, case / top, **args))
            if robot is not None:
                check_robot(robot, seed=q_seed, text=expand_xacro_independently(case / top, args))
        except AssertionError:
            saved = Path(f"{FAILURE_PREFIX}_xacro")
            shutil.rmtree(saved, ignore_errors=True)
            shutil.copytree(case, saved)
            (saved / "HOW_TO_REPLAY.txt").write_text(f"manipkit.load({str(saved / top)!r}, **{args!r})\n")
            raise
    finally:
        shutil.rmtree(case, ignore_errors=True)


@FUZZ_TIMEOUT
@XACRO_FUZZ_SETTINGS
@given(data=st.data())
def test_mutated_xacro_is_refused_cleanly_or_loads_correctly(data, scratch):
    run_xacro_case(data, scratch)


# ==========================================================================
# xacro expressions: random syntax trees, allowed and forbidden
# ==========================================================================
#
# Each case builds an expression's syntax tree from node types an expression may use (literals,
# properties, arithmetic, comparisons, and/or/not, conditionals, calls of allowed functions, allowed
# methods, subscripts, displays, comprehensions, f-strings) and node types it may not, turns it into
# text (ast.unparse) and evaluates it inside a small xacro description (the text arrives as the xacro
# argument `e` in `${$(arg e)}`, so any character reaches the evaluator). The oracle:
#
# - a tree with a statically forbidden part anywhere (lambda, :=, @, an attribute or name starting
#   with '_', a comprehension assigning to an attribute; the escapes that run `touch SENTINEL`), even
#   in a branch that would not run, is refused with one line naming the expression;
# - a tree with a dynamically forbidden part (a name xacro does not give: getattr, open, type, ...; an
#   attribute of a value that is not allowed: gi_frame, append, format_map, a '{0.x}' format field) is
#   refused with one line, or evaluates when that part is not reached; never evaluated by Python here;
# - any other tree gives what Python itself gives for the same text with the same names (the text in the
#   expanded URDF equals str() of Python's value), or the same error, or a refusal naming a limit;
# - no case creates the sentinel file, raises anything but a DescriptionError, or runs past the hard timeout.

EXPRESSION_DEADLINE_MS = int(os.environ.get("MANIPKIT_FUZZ_EXPRESSION_DEADLINE_MS", "6000"))  # > the 2 s budget
EXPRESSION_SETTINGS = settings(FUZZ_SETTINGS, deadline=timedelta(milliseconds=EXPRESSION_DEADLINE_MS))
CLEAN, DYNAMIC, STATIC = 0, 1, 2  # classes of a tree: the worst part decides
EXPRESSION_PROPERTIES = {"a": 3, "b": 0.5, "s": "arm", "l": [3, 1, 2], "d": {"k": 1, "j": 2}}
EXPRESSION_DESCRIPTION = """<?xml version="1.0"?>
<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:arg name="e" default="0"/>
  <xacro:property name="a" value="3"/>
  <xacro:property name="b" value="0.5"/>
  <xacro:property name="s" value="arm"/>
  <xacro:property name="l" value="${[3, 1, 2]}"/>
  <xacro:property name="d" value="${dict(k=1, j=2)}"/>
  <link name="base"><visual><geometry><box size="1 1 1"/></geometry><material name="${$(arg e)}"/></visual></link>
</robot>
"""
FUNCTIONS = ("max", "min", "len", "str", "int", "float", "round", "sorted", "list", "sin", "cos", "sqrt", "radians",
             "fabs", "floor", "ceil", "bool", "degrees", "atan2", "hypot", "isnan")
NAMESPACED = (("python", "abs"), ("python", "tuple"), ("python", "sum"), ("python", "any"), ("python", "all"),
              ("python", "range"), ("python", "reversed"), ("python", "zip"), ("math", "pi"), ("math", "cos"),
              ("xacro", "tokenize"))
STR_METHODS = ("upper", "lower", "strip", "split", "title", "count", "startswith", "replace", "join", "find", "zfill")
OTHER_METHODS = ("index", "count", "copy", "get", "keys", "values", "items", "real", "imag", "bit_length")
DUNDERS = ("__class__", "__dict__", "__globals__", "__subclasses__", "__base__", "__mro__", "__builtins__",
           "__import__", "__init__", "_module", "__self__", "__code__", "__reduce__", "__getattribute__")
UNSAFE_NAMES = ("getattr", "setattr", "eval", "exec", "open", "compile", "globals", "locals", "vars", "type",
                "input", "breakpoint", "help", "memoryview", "object", "super", "classmethod")
UNSAFE_ATTRIBUTES = ("gi_frame", "f_globals", "f_back", "f_locals", "gi_code", "cr_frame", "mro", "format_map",
                     "append", "extend", "pop", "clear", "encode", "to_bytes", "translate", "expandtabs", "setdefault",
                     "update", "sort", "insert", "remove", "system", "modules")
BINARY = (ast.Add, ast.Sub, ast.Mult, ast.Div, ast.FloorDiv, ast.Mod, ast.BitOr, ast.BitAnd, ast.BitXor, ast.RShift)
COMPARE = (ast.Eq, ast.NotEq, ast.Lt, ast.LtE, ast.Gt, ast.GtE, ast.In, ast.NotIn)  # "is": identity of literals varies
LETTERS = st.text("abcdefgh xyz", max_size=6)


def _escapes(sentinel: Path) -> list[tuple[str, int]]:
    """Known sandbox escapes (each creates ``sentinel`` when it runs), with their class."""
    touch = f"'touch {sentinel}'"
    return [
        ("(lambda: [c for c in ().__class__.__base__.__subclasses__() if c.__name__ == 'catch_warnings'][0]()"
         f"._module.sys.modules['os'].system({touch}))()", STATIC),
        ("[c for c in ().__class__.__base__.__subclasses__() if c.__name__ == 'catch_warnings'][0]()"
         f"._module.sys.modules['os'].system({touch})", STATIC),
        (f"__import__('os').system({touch})", STATIC),
        (f"[x for x in [1] if (x := __import__('os').system({touch}))]", STATIC),
        (f"math.sin.__self__.__import__('os').system({touch})", STATIC),
        (f"[g.gi_frame.f_back.f_back.f_globals['os'].system({touch}) for g in [(i for i in [1])]]", DYNAMIC),
        (f"open('{sentinel}', 'w')", DYNAMIC),
        ("python.type('X', (), dict())", DYNAMIC),
        ("python.vars(math)", DYNAMIC),
        ("'{0.__class__.__base__}'.format(1)", DYNAMIC),
    ]


def _node(tree: ast.AST) -> ast.AST:
    return ast.fix_missing_locations(tree)


@st.composite
def clean_leaf(draw):
    kind = draw(st.sampled_from(["int", "float", "str", "const", "property", "constant", "function", "big"]))
    if kind == "int":
        return ast.Constant(draw(st.integers(-1000, 1000))), CLEAN
    if kind == "float":
        return ast.Constant(draw(st.sampled_from([0.5, -2.25, 1e-3, 3.0, 1e308, 0.1]))), CLEAN
    if kind == "str":
        return ast.Constant(draw(LETTERS)), CLEAN
    if kind == "big":  # a long text or a deep value: what the estimates are for
        return ast.parse(draw(st.sampled_from(["'x' * 100000", "'é' * 50000", "[[[[[[[[1]]]]]]]]",
                                                "python.slice(python.slice(1))"])), mode="eval").body, CLEAN
    if kind == "const":
        return ast.Constant(draw(st.sampled_from([True, False, None]))), CLEAN
    if kind == "property":
        return ast.Name(draw(st.sampled_from(sorted(EXPRESSION_PROPERTIES))), ast.Load()), CLEAN
    if kind == "constant":
        return ast.Name(draw(st.sampled_from(["pi", "e", "tau", "inf"])), ast.Load()), CLEAN
    space, name = draw(st.sampled_from(NAMESPACED))
    return ast.Attribute(ast.Name(space, ast.Load()), name, ast.Load()), CLEAN


@st.composite
def forbidden_leaf(draw, sentinel: Path):
    kind = draw(st.sampled_from(["escape", "dunder_name", "unsafe_name"]))
    if kind == "escape":
        text, cls = draw(st.sampled_from(_escapes(sentinel)))
        return ast.parse(text, mode="eval").body, cls
    if kind == "dunder_name":
        name = draw(st.sampled_from(DUNDERS))
        return ast.Name(name, ast.Load()), STATIC if name.startswith("__") else DYNAMIC  # a property may be _x
    return ast.Name(draw(st.sampled_from(UNSAFE_NAMES)), ast.Load()), DYNAMIC


def _worst(*parts) -> int:
    return max((cls for _, cls in parts), default=CLEAN)


# Over 80 lines: one branch per node type, allowed and forbidden, each a few lines, drawn from one list.
@st.composite
def compound(draw, children, forbidden: bool):
    """One node over ``children`` (a strategy of (node, class)); forbidden node types when ``forbidden``."""
    kinds = ["binop", "pow", "shift", "unary", "boolop", "compare", "ifexp", "call", "method", "subscript", "slice",
             "list", "tuple", "set", "dict", "listcomp", "setcomp", "dictcomp", "genexp", "fstring", "keyword_call",
             "slice_object", "int_base", "percent", "format", "load_yaml"]
    if forbidden:
        kinds += ["lambda", "walrus", "matmul", "dunder_attribute", "unsafe_attribute", "format_field",
                  "store_attribute"]
    kind = draw(st.sampled_from(kinds))
    one = draw(children)
    if kind == "binop":
        two = draw(children)
        return ast.BinOp(one[0], draw(st.sampled_from(BINARY))(), two[0]), _worst(one, two)
    if kind == "pow":  # a small literal exponent keeps Python's own evaluation bounded
        return ast.BinOp(one[0], ast.Pow(), ast.Constant(draw(st.integers(-2, 4)))), one[1]
    if kind == "shift":
        return ast.BinOp(one[0], ast.LShift(), ast.Constant(draw(st.integers(0, 8)))), one[1]
    if kind == "unary":
        return ast.UnaryOp(draw(st.sampled_from([ast.USub, ast.UAdd, ast.Not, ast.Invert]))(), one[0]), one[1]
    if kind == "boolop":
        two = draw(children)
        return ast.BoolOp(draw(st.sampled_from([ast.And, ast.Or]))(), [one[0], two[0]]), _worst(one, two)
    if kind == "compare":
        rest = draw(st.lists(children, min_size=1, max_size=2))
        ops = [draw(st.sampled_from(COMPARE))() for _ in rest]
        return ast.Compare(one[0], ops, [r[0] for r in rest]), _worst(one, *rest)
    if kind == "ifexp":
        two, three = draw(children), draw(children)
        return ast.IfExp(one[0], two[0], three[0]), _worst(one, two, three)
    if kind in ("call", "keyword_call"):
        args = [one] + draw(st.lists(children, max_size=2))
        name = draw(st.sampled_from(FUNCTIONS))
        keywords = [ast.keyword("key", ast.Name("str", ast.Load()))] if kind == "keyword_call" else []
        name = "sorted" if keywords else name
        return ast.Call(ast.Name(name, ast.Load()), [a[0] for a in args], keywords), _worst(*args)
    if kind == "method":
        name = draw(st.sampled_from(STR_METHODS + OTHER_METHODS))
        args = draw(st.lists(children, max_size=1 if name not in ("replace",) else 2))
        if name in ("real", "imag"):
            return ast.Attribute(one[0], name, ast.Load()), one[1]
        return (ast.Call(ast.Attribute(one[0], name, ast.Load()), [a[0] for a in args], []), _worst(one, *args))
    if kind == "subscript":
        two = draw(children)
        return ast.Subscript(one[0], two[0], ast.Load()), _worst(one, two)
    if kind == "slice":
        bounds = [ast.Constant(draw(st.integers(-3, 3))) if draw(st.booleans()) else None for _ in range(3)]
        if bounds[2] is not None and bounds[2].value == 0:
            bounds[2] = None
        return ast.Subscript(one[0], ast.Slice(*bounds), ast.Load()), one[1]
    if kind in ("list", "tuple", "set"):
        items = [one] + draw(st.lists(children, max_size=2))
        elements = [i[0] for i in items]
        display = ast.Set(elements) if kind == "set" else {"list": ast.List, "tuple": ast.Tuple}[kind](elements, ast.Load())
        return display, _worst(*items)
    if kind == "dict":
        two = draw(children)
        return ast.Dict([one[0]], [two[0]]), _worst(one, two)
    if kind in ("listcomp", "setcomp", "dictcomp", "genexp"):
        source = ast.Name(draw(st.sampled_from(["l", "s", "d"])), ast.Load())
        loop = ast.comprehension(ast.Name("x", ast.Store()), source, [], 0)
        elt = ast.BinOp(ast.Name("x", ast.Load()), ast.Mult(), one[0]) if draw(st.booleans()) else one[0]
        if kind == "dictcomp":
            return ast.DictComp(ast.Name("x", ast.Load()), elt, [loop]), one[1]
        if kind == "genexp":  # a generator is made a list here: pass it to a function that consumes it
            consumer = draw(st.sampled_from(["list", "sorted", "max", "min"]))
            return ast.Call(ast.Name(consumer, ast.Load()), [ast.GeneratorExp(elt, [loop])], []), one[1]
        return {"listcomp": ast.ListComp, "setcomp": ast.SetComp}[kind](elt, [loop]), one[1]
    if kind == "slice_object":  # python.slice(...): nested slices are measured like containers (issue 26)
        parts = [one] + draw(st.lists(children, max_size=2))
        call = ast.Call(ast.Attribute(ast.Name("python", ast.Load()), "slice", ast.Load()), [p[0] for p in parts], [])
        return call, _worst(*parts)
    if kind == "int_base":  # int(text, base): bounded by the text's length before it is parsed
        digits = ast.Constant(draw(st.text("0123456789abcdefxXoObB_ -", max_size=8)))
        text = draw(st.sampled_from([digits, one[0], ast.BinOp(digits, ast.Mult(), ast.Constant(
            draw(st.sampled_from([1, 3, 1000, 100_000]))))]))
        base = ast.Constant(draw(st.sampled_from([0, 2, 8, 10, 16, 36])))
        return ast.Call(ast.Name("int", ast.Load()), [text, base], []), one[1] if text is one[0] else CLEAN
    if kind == "percent":  # '%' formatting of a string: widths and arguments estimated first
        template = draw(st.sampled_from(["%s", "%r_%s", "%(k)s%(k)s", "%5.2f", "%d%%", "%-8s|", "%s" * 40,
                                         "%99999999d", "%.3e"]))
        return ast.BinOp(ast.Constant(template), ast.Mod(), one[0]), one[1]
    if kind == "format":  # str.format: each field as long as its longest argument, estimated first
        template = draw(st.sampled_from(["{}", "{0}{0}", "{!r}", "{:>5}", "{0:.3}", "{k}", "{0}" * 40, "{:>123456789}"]))
        two = draw(children)
        keywords = [ast.keyword("k", two[0])] if "{k}" in template else []
        call = ast.Call(ast.Attribute(ast.Constant(template), "format", ast.Load()), [one[0]], keywords)
        return call, _worst(one, two) if keywords else one[1]
    if kind == "load_yaml":  # a file of the description's own, one that is missing, and ones outside it
        name = draw(st.sampled_from(["c.yaml", "missing.yaml", "/etc/passwd", "../outside.yaml", "/dev/zero"]))
        call = ast.Call(ast.Attribute(ast.Name("xacro", ast.Load()), "load_yaml", ast.Load()), [ast.Constant(name)], [])
        if draw(st.booleans()):
            return ast.BinOp(call, ast.Add(), one[0]), max(one[1], DYNAMIC)
        return call, DYNAMIC
    if kind == "fstring":
        conversion = draw(st.sampled_from([-1, 115, 114, 97]))
        spec = ast.JoinedStr([ast.Constant(draw(st.sampled_from([".2f", ">6", "", "^5", ">12345678", ".0e"])))])
        value = ast.FormattedValue(one[0], conversion, spec if draw(st.booleans()) else None)
        return ast.JoinedStr([ast.Constant(draw(LETTERS)), value]), one[1]
    if kind == "lambda":
        arguments = ast.arguments(posonlyargs=[], args=[], vararg=None, kwonlyargs=[], kw_defaults=[], kwarg=None,
                                  defaults=[])
        return ast.Call(ast.Lambda(arguments, one[0]), [], []), STATIC
    if kind == "walrus":
        return ast.NamedExpr(ast.Name("y", ast.Store()), one[0]), STATIC
    if kind == "matmul":
        return ast.BinOp(one[0], ast.MatMult(), draw(children)[0]), STATIC
    if kind == "dunder_attribute":
        return ast.Attribute(one[0], draw(st.sampled_from(DUNDERS)), ast.Load()), STATIC
    if kind == "unsafe_attribute":
        return ast.Attribute(one[0], draw(st.sampled_from(UNSAFE_ATTRIBUTES)), ast.Load()), max(one[1], DYNAMIC)
    if kind == "format_field":
        template = draw(st.sampled_from(["{0.real}", "{0[0]}", "{x.y}", "{0.__class__}"]))
        return ast.Call(ast.Attribute(ast.Constant(template), "format", ast.Load()), [one[0]], []), max(one[1], DYNAMIC)
    # store_attribute: a comprehension that assigns to an attribute
    loop = ast.comprehension(ast.Attribute(ast.Name("l", ast.Load()), "x", ast.Store()), one[0], [], 0)
    return ast.ListComp(ast.Constant(1), [loop]), STATIC


def expression_trees(sentinel: Path, forbidden: bool):
    leaves = clean_leaf() if not forbidden else st.one_of(clean_leaf(), clean_leaf(), forbidden_leaf(sentinel))
    return st.recursive(leaves, lambda children: compound(children, forbidden), max_leaves=8)


def _python_names() -> dict[str, object]:
    """The names of xacro expressions for Python's own eval (namespaces as objects with attributes)."""
    from types import SimpleNamespace

    from manipkit.description.xacro_names import xacro_globals

    names = dict(xacro_globals())
    for space in ("python", "math", "xacro"):
        names[space] = SimpleNamespace(**xacro_globals()[space])
    names.update(copy.deepcopy(EXPRESSION_PROPERTIES))
    return names


def python_value(text: str):
    """What Python itself makes of a clean expression: ("value", str of it) or ("error", message)."""
    import warnings

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", SyntaxWarning)  # "is" with a literal
            value = eval(text, {"__builtins__": {}, **_python_names()})  # noqa: S307 - clean trees only (no escapes)
        return "value", str(value)
    except Exception as exc:  # noqa: BLE001 - the expression's own error
        return "error", f"{type(exc).__name__}: {exc}"


def _expanded_material(urdf: str) -> str:
    return etree.fromstring(urdf.encode()).find("link/visual/material").get("name")


LIMIT_WORDS = ("limit", "time budget", "adds numbers only", "'*' width")


def run_expression_case(data, scratch: Path, forbidden: bool) -> None:
    from manipkit.description.xacro import describe

    sentinel = scratch / "SENTINEL"
    tree, cls = data.draw(expression_trees(sentinel, forbidden), label="expression tree")
    text = ast.unparse(_node(tree))
    path = scratch / "expression.urdf.xacro"
    if not path.exists():
        path.write_text(EXPRESSION_DESCRIPTION)
        (scratch / "c.yaml").write_text("k: 1\nl: [1, 2]\n")  # read by xacro.load_yaml('c.yaml')
        (scratch.parent / "outside.yaml").write_text("secret: hunter2\n")  # outside the description's folder
    source = resolve_robot(path)
    outcome, detail = "value", None
    try:
        with hard_timeout(HARD_TIMEOUT_S):
            detail = _expanded_material(describe(source, {"e": text}).text)
    except ManipkitError as exc:
        outcome, detail = "refused", str(exc)
    except CaseTimeout:
        raise AssertionError(f"hang: ${{{text}}} ran past {HARD_TIMEOUT_S} s") from None
    except Exception as exc:  # noqa: BLE001 - any other exception is a bug
        raise AssertionError(f"${{{text}}}: uncaught {type(exc).__name__}: {exc}") from exc
    assert not sentinel.exists(), f"${{{text}}} ran code: {sentinel} was created"
    assert "root:" not in str(detail) and "hunter2" not in str(detail), f"${{{text}}} disclosed a file: {detail}"
    if outcome == "refused":
        assert detail.strip() and "\n" not in detail and "\r" not in detail, f"not one line: {detail!r}"
        assert "xacro expression ${" in detail, detail
    if cls == STATIC:
        assert outcome == "refused", f"${{{text}}} has a forbidden part but gave {detail!r}"
        assert any(w in detail for w in ("is not allowed", "assigns to names only", "syntax", "never closed",
                                         "nested more than")), detail
        _event("forbidden: refused")
        return
    if cls == DYNAMIC:  # refused when reached; never given to Python here (it could run)
        _event(f"unsafe name or attribute: {'refused' if outcome == 'refused' else 'not reached'}")
        return
    if outcome == "refused" and any(word in detail for word in LIMIT_WORDS):
        _event("allowed: refused at a limit")
        return
    if outcome == "refused" and "values is not allowed (attributes are read from" in detail:
        _event("allowed: attribute of a function or type refused (Python would read it)")
        return
    with hard_timeout(HARD_TIMEOUT_S):
        kind, expected = python_value(text)
    if kind == "value" and " at 0x" in expected:  # an object's address: no text to compare
        _event("allowed: value without a comparable text")
        return
    if kind == "value":
        assert outcome == "value", f"${{{text}}}: Python gives {expected!r}, here: {detail}"
        assert detail == expected, f"${{{text}}}: Python gives {expected!r}, here {detail!r}"
        _event("allowed: same value as Python")
    else:
        assert outcome == "refused", f"${{{text}}}: Python raises {expected}, here the value {detail!r}"
        message = " ".join(expected.split(": ", 1)[-1].split())
        unqualified = re.compile(r"\b\w+\.(\w+\(\))")  # int.bit_length() or bool.bit_length(): how it was called
        assert unqualified.sub(r"\1", message) in unqualified.sub(r"\1", detail), \
            f"${{{text}}}: Python raises {expected}, here: {detail}"
        _event("allowed: same error as Python")


@FUZZ_TIMEOUT
@EXPRESSION_SETTINGS
@given(data=st.data())
def test_xacro_expression_allowed_gives_pythons_value(data, scratch):
    run_expression_case(data, scratch, forbidden=False)


@FUZZ_TIMEOUT
@EXPRESSION_SETTINGS
@given(data=st.data())
def test_xacro_expression_forbidden_is_refused_and_runs_nothing(data, scratch):
    run_expression_case(data, scratch, forbidden=True)


@pytest.mark.parametrize("index", range(10))
def test_every_known_escape_is_refused_and_runs_nothing(index, scratch):
    from manipkit.description.xacro import describe

    path = scratch / "expression.urdf.xacro"
    path.write_text(EXPRESSION_DESCRIPTION)
    sentinel = scratch / "SENTINEL"
    with pytest.raises(ManipkitError, match=r"xacro expression \$\{"):
        describe(resolve_robot(path), {"e": _escapes(sentinel)[index][0]})
    assert not sentinel.exists()


def test_the_expression_oracle_compares_with_python():
    assert python_value("max(l) + a") == ("value", "6")
    assert python_value("1 / 0") == ("error", "ZeroDivisionError: division by zero")
    assert python_value("s.upper() + str(d['k'])") == ("value", "ARM1")


# ==========================================================================
# The oracle itself: it passes every bundled robot and flags what it must
# ==========================================================================


@pytest.mark.parametrize("name", sorted(bundled_robots()))
def test_every_bundled_robot_passes_the_oracle_unmutated(name):
    robot = manipkit.load(name)
    assert description_problems(robot.urdf) == []
    check_robot(robot, seed=1)


LINKS = '<link name="base"/><link name="arm"/>'
JOINT = ('<joint name="j" type="{type}"><parent link="base"/><child link="arm"/><origin xyz="{xyz}"/>'
         '<axis xyz="{axis}"/><limit lower="{lower}" upper="{upper}" effort="1" velocity="1"/></joint>')


def _urdf(type="revolute", xyz="0 0 0.1", axis="0 0 1", lower="-1", upper="1", links=LINKS) -> str:
    return f'<robot name="t">{links}{JOINT.format(type=type, xyz=xyz, axis=axis, lower=lower, upper=upper)}</robot>'


@pytest.mark.parametrize(
    "text, fragment",
    [
        (_urdf(), None),
        (_urdf(xyz="1e308 0 0"), None),  # huge but finite: valid
        (_urdf(axis="0 0 1e-300"), None),  # tiny but not zero: a direction
        (_urdf()[:-5], "not well-formed"),
        (_urdf(xyz="nan 0 0"), "not 3 number"),
        (_urdf(xyz="1_0 0 0"), "not 3 number"),
        (_urdf(xyz="1e400 0 0"), "not finite"),
        (_urdf(axis="0 0 0"), "axis is zero"),
        (_urdf(lower="1", upper="-1"), "above upper limit"),
        (_urdf(type="hinge"), "has type 'hinge'"),
        (_urdf(links='<link name="base"/><link name="base"/>'), "two <link> elements"),
        (_urdf(links='<link name="base"/>'), "child link 'arm'"),
        (_urdf(links=LINKS + '<link name="c"/>'), "2 root links"),
        (_urdf(links='<link name="base"><inertial><mass value="abc"/></inertial></link><link name="arm"/>'),
         "mass value"),
        (_urdf(links='<link name="base"><visual><geometry><box size="1 nan 1"/></geometry></visual></link>'
                     '<link name="arm"/>'), "box size"),
    ],
)
def test_the_oracle_judges_descriptions_by_the_specification(text, fragment):
    problems = description_problems(text)
    if fragment is None:
        assert problems == []
    else:
        assert any(fragment in p for p in problems), problems


# ==========================================================================
# Regression cases: minimal inputs the fuzzer found (all fixed; `what`
# records what went wrong before the fix)
# ==========================================================================


def _two_links(joint: str, links=("a", "b"), head: str = "") -> str:
    return head + '<robot name="t">' + "".join(f'<link name="{n}"/>' for n in links) + joint + "</robot>"


def _refused_cleanly_or_correct(text: str) -> None:
    robot = load_cleanly_or_refuse(functools.partial(Robot.from_urdf, text))
    if robot is not None:
        check_robot(robot, seed=0, text=text)


def _found(name: str, text: str, what: str):
    return pytest.param(text, id=name)


FOUND = [
    _found("entity_in_joint_name", _two_links(
        '<joint name="&v;" type="continuous"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/></joint>',
        head='<!DOCTYPE robot [<!ENTITY v "j1">]>'),
        "expat (manipkit.description.validate) expands the entity, Pinocchio's parser does not: the joint is named '&v;'"),
    _found("joint_named_universe", _two_links(
        '<joint name="universe" type="continuous"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/></joint>'),
        "Pinocchio's root joint is 'universe': the (cos, sin) of this joint go to the wrong entries, "
        "T_a_b at q = 0.5 is [[1, -0.5], [0.5, 1]], not a rotation"),
    _found("link_named_universe", _two_links(
        '<joint name="j1" type="continuous"><parent link="a"/><child link="universe"/><axis xyz="0 0 1"/></joint>',
        links=("a", "universe")),
        "a link named 'universe' loads but is missing from Robot.frame_names"),
    _found("huge_axis", _two_links(
        '<joint name="j1" type="revolute"><parent link="a"/><child link="b"/><axis xyz="1e200 0 0"/>'
        '<limit lower="-2" upper="2" effort="1" velocity="1"/></joint>'),
        "the axis' norm overflows (1e400): the axis becomes zero, T_a_b(q) = cos(q) I, not a rotation"),
    _found("offsets_overflow", _two_links(
        '<joint name="j1" type="continuous"><parent link="a"/><child link="b"/><origin xyz="1.7e308 0 0"/></joint>'
        '<joint name="j2" type="fixed"><parent link="b"/><child link="c"/><origin xyz="1.7e308 0 0"/></joint>',
        links=("a", "b", "c")),
        "two finite offsets whose sum overflows: T_a_c has inf and nan (no magnitude bound on lengths)"),
    _found("fk_without_movable_joints", _two_links(
        '<joint name="j1" type="fixed"><parent link="a"/><child link="b"/><origin xyz="1 0 0"/></joint>'),
        "Robot.fk(Q of shape (n, 0), 'b') raises ValueError (cannot reshape array of size 0)"),
    _found("limits_overflow_sample_q", _two_links(
        '<joint name="j1" type="prismatic"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/>'
        '<limit lower="-1e308" upper="1e308" effort="1" velocity="1"/></joint>'),
        "Robot.sample_q raises OverflowError (upper - lower overflows)"),
    _found("axis_without_xyz", _two_links(
        '<joint name="j1" type="revolute"><parent link="a"/><child link="b"/><axis/>'
        '<limit lower="-2" upper="2" effort="1" velocity="1"/></joint>'),
        "<axis/> means the default 1 0 0; the model gets a zero axis (Joint.axis NaN, T_a_b(q) = cos(q) I)"),
    _found("nearly_aligned_axis", _two_links(
        '<joint name="j1" type="continuous"><parent link="a"/><child link="b"/><axis xyz="1 0 1e-7"/></joint>'),
        "the batched FK (fk_kernel.z_to_axis) took a unit axis as a coordinate axis when its largest entry was within "
        "1e-14 of 1, i.e. for every other entry below ~1.4e-7; Robot.fk differed from Robot.transform by 1.4e-7 rad"),
    _found("axis_of_largest_floats", _two_links(
        '<joint name="j1" type="continuous"><parent link="a"/><child link="b"/>'
        '<axis xyz="1e300 1.7976931348623157e308 1.7976931348623157e308"/></joint>'),
        "the axis' length is beyond the largest float (math.hypot gives inf): it was normalised to 0 0 0 and the "
        "joint's axis was NaN; the components are divided by the largest first"),
    _found("unterminated_comment", '<robot name="r"><link name="a"/><!--\x80 s',
        "libxml2's message carries the offending source after a newline ('Comment not terminated \\n<!--'): "
        "the error was two lines"),
    _found("floating_and_planar_joints", _two_links(
        '<joint name="f" type="floating"><parent link="a"/><child link="b"/></joint>'
        '<joint name="p" type="planar"><parent link="b"/><child link="c"/><axis xyz="0 0 1"/></joint>'
        '<joint name="j" type="revolute"><parent link="c"/><child link="d"/><axis xyz="0 0 1"/>'
        '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>', links=("a", "b", "c", "d")),
        "the judge counted revolute, continuous and prismatic joints only, while a floating joint has six entries "
        "and a planar one three (f.x ... f.yaw, p.x, p.y, p.yaw): a mutation to 'floating' failed the judge"),
]


@pytest.mark.parametrize("text", FOUND)
def test_found_by_the_fuzzer_is_refused_cleanly_or_loads_correctly(text):
    _refused_cleanly_or_correct(text)
