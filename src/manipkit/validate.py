"""Checks on URDF text before a model is built from it.

Pinocchio's parser answers most invalid descriptions with one generic
message (the reason goes to stderr from C++) and accepts some invalid ones
(a joint axis of ``0 0 0`` loads and gives wrong kinematics). These checks
run first and name the element that is wrong and what would be valid.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

from manipkit.errors import DescriptionError

JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed", "floating", "planar")


def parse_urdf(text: str, where: str) -> ET.Element:
    """Parse and check URDF text; return the ``<robot>`` element.

    Parameters
    ----------
    text : str
        URDF XML.
    where : str
        How to name the description in messages (usually the file name).

    Raises
    ------
    DescriptionError
        Malformed XML (with line and column), no ``<robot>`` root, links or
        joints without names or with duplicate names, a joint whose parent or
        child link does not exist, an unknown joint type, a zero or
        non-finite axis, a lower limit above the upper one, non-finite
        numbers in origins or limits, a link with two parents, or a tree
        with no root or more than one.
    """
    try:
        robot = ET.fromstring(text)
    except ET.ParseError as exc:
        line, column = exc.position
        reason = str(exc).split(": line")[0]
        raise DescriptionError(f"{where}: malformed XML at line {line}, column {column}: {reason}") from None
    if robot.tag != "robot":
        raise DescriptionError(f"{where}: root element is <{robot.tag}>, expected <robot>")

    links = _named(robot, "link", where)
    joints = _named(robot, "joint", where)
    if not links:
        raise DescriptionError(f"{where}: no <link> elements; a robot needs at least one link")

    children: dict[str, str] = {}
    for name, joint in joints.items():
        kind = joint.get("type")
        if kind not in JOINT_TYPES:
            raise DescriptionError(
                f"{where}: joint '{name}' has type '{kind}'; valid types: {', '.join(JOINT_TYPES)}"
            )
        parent, child = (_link_ref(joint, tag, name, where) for tag in ("parent", "child"))
        for role, link in (("parent", parent), ("child", child)):
            if link not in links:
                raise DescriptionError(
                    f"{where}: joint '{name}' {role} link '{link}' does not exist; "
                    f"links are: {', '.join(list(links)[:12])}"
                )
        if child in children:
            raise DescriptionError(
                f"{where}: link '{child}' is the child of two joints ('{children[child]}' and '{name}'); "
                "a URDF is a tree"
            )
        children[child] = name
        origin = joint.find("origin")
        if origin is not None:
            for attribute in ("xyz", "rpy"):
                _numbers(origin.get(attribute, "0 0 0"), 3, f"joint '{name}' origin {attribute}", where)
        if kind in ("revolute", "continuous", "prismatic"):
            _check_axis(joint, name, where)
        if kind in ("revolute", "prismatic"):
            _check_limit(joint, name, where)

    roots = [link for link in links if link not in children]
    if len(roots) != 1:
        if not roots:
            raise DescriptionError(f"{where}: every link has a parent; the joints form a cycle")
        raise DescriptionError(
            f"{where}: {len(roots)} root links ({', '.join(roots[:6])}); a URDF has exactly one root, "
            "connect the others with joints"
        )
    _check_cycles(links, joints, roots[0], where)
    return robot


def _named(robot: ET.Element, tag: str, where: str) -> dict[str, ET.Element]:
    named: dict[str, ET.Element] = {}
    for index, element in enumerate(robot.findall(tag), start=1):
        name = element.get("name")
        if not name:
            raise DescriptionError(f"{where}: <{tag}> number {index} has no name attribute")
        if name in named:
            raise DescriptionError(f"{where}: two <{tag}> elements are named '{name}'; names must be unique")
        named[name] = element
    return named


def _link_ref(joint: ET.Element, tag: str, name: str, where: str) -> str:
    element = joint.find(tag)
    if element is None or not element.get("link"):
        raise DescriptionError(f"{where}: joint '{name}' has no <{tag} link=\"...\"/>")
    return element.get("link")


def _numbers(text: str, count: int, what: str, where: str) -> list[float]:
    try:
        values = [float(token) for token in text.split()]
    except ValueError:
        raise DescriptionError(f"{where}: {what} is '{text}'; expected {count} numbers") from None
    if len(values) != count:
        raise DescriptionError(f"{where}: {what} is '{text}'; expected {count} numbers")
    if not all(math.isfinite(v) for v in values):
        raise DescriptionError(f"{where}: {what} is '{text}'; numbers must be finite")
    return values


def _check_axis(joint: ET.Element, name: str, where: str) -> None:
    axis = joint.find("axis")
    if axis is None:
        return  # URDF default: 1 0 0
    x, y, z = _numbers(axis.get("xyz", "1 0 0"), 3, f"joint '{name}' axis", where)
    if math.sqrt(x * x + y * y + z * z) < 1e-9:
        raise DescriptionError(
            f"{where}: joint '{name}' has axis '{axis.get('xyz')}'; an axis must be a non-zero vector such as '0 0 1'"
        )


def _check_limit(joint: ET.Element, name: str, where: str) -> None:
    limit = joint.find("limit")
    if limit is None:
        raise DescriptionError(
            f"{where}: {joint.get('type')} joint '{name}' has no <limit>; "
            "add <limit lower=... upper=... effort=... velocity=...> or make it continuous"
        )
    bounds = {}
    for attribute in ("lower", "upper", "effort", "velocity"):
        if limit.get(attribute) is not None:
            bounds[attribute] = _numbers(limit.get(attribute), 1, f"joint '{name}' limit {attribute}", where)[0]
    lower, upper = bounds.get("lower", 0.0), bounds.get("upper", 0.0)
    if lower > upper:
        raise DescriptionError(
            f"{where}: joint '{name}' has lower limit {lower:g} above upper limit {upper:g}; swap them"
        )


def _check_cycles(links: dict, joints: dict, root: str, where: str) -> None:
    below: dict[str, list[str]] = {}
    for joint in joints.values():
        below.setdefault(joint.find("parent").get("link"), []).append(joint.find("child").get("link"))
    seen, stack = {root}, [root]
    while stack:
        for child in below.get(stack.pop(), []):
            seen.add(child)
            stack.append(child)
    unreachable = [link for link in links if link not in seen]
    if unreachable:
        raise DescriptionError(
            f"{where}: links {', '.join(unreachable[:6])} form a cycle not connected to root '{root}'"
        )
