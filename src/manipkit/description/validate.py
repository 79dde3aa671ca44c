"""Checks on URDF text before a model is built from it.

Pinocchio's parser answers most invalid descriptions with one generic
message (the reason goes to stderr from C++) and accepts some invalid ones
(a joint axis of ``0 0 0`` loads and gives wrong kinematics, a lower limit
above the upper one, a negative mass, a ``<mimic>`` of a joint that does not
exist). These checks run first and say precisely what is wrong, where, and
what would be valid.

Every message starts with where the problem is: ``FILE:LINE:`` for a URDF
file (``FILE:LINE:COLUMN:`` for malformed XML); for a description expanded
from xacro, ``FILE.xacro:LINE:`` when the element's name is found written out
in the xacro sources, else ``FILE.xacro (expanded URDF, line N):``. Then the
element (``joint 'j1'``, ``link 'arm' <inertial>``), the value found, and what
would be valid.

Some problems do not make the kinematics wrong; they are returned as
warnings instead (:attr:`CheckedURDF.warnings`): a non-unit joint axis (it is
normalised in the returned text), a revolute or prismatic joint whose limits
leave it no motion, an inertia tensor that is not positive semi-definite, a
mimic joint that leaves its own limits over its leader's, and mesh files that
do not exist or lie outside what the description may read (``package://``,
``file://`` or a path beside the description; :func:`package_uri_warnings`;
only the viewer needs the meshes). At most :data:`MAX_WARNINGS` are kept, then
a count (:func:`cap_warnings`).
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from manipkit.bounds import MAX_ANGLE, MAX_LENGTH
from manipkit.description.packages import PACKAGE_SCHEME, split_package_uri
from manipkit.errors import DescriptionError, PackageNotFoundError
from manipkit.text import UNPRINTABLE, close_matches, printable, short_text

if TYPE_CHECKING:
    from manipkit.description.access import ReadPolicy
    from manipkit.description.packages import PackageResolver

__all__ = [
    "AXIS_NORM_TOLERANCE",
    "CheckedURDF",
    "JOINT_TYPES",
    "MAX_LENGTH",
    "MAX_LINKS",
    "MAX_MAGNITUDE",
    "MAX_TREE_DEPTH",
    "MAX_WARNINGS",
    "RESERVED_NAMES",
    "SUPPORTED_JOINT_TYPES",
    "XACRO_NAMESPACE",
    "cap_warnings",
    "check_urdf",
    "package_uri_warnings",
]

#: Joint types manipkit computes kinematics for.
SUPPORTED_JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed", "floating", "planar")
#: Every joint type of the URDF specification.
JOINT_TYPES = SUPPORTED_JOINT_TYPES
XACRO_NAMESPACE = "http://www.ros.org/wiki/xacro"

#: Names Pinocchio gives its own root joint and frame; a link or joint of that name would be mixed up with them.
RESERVED_NAMES = ("universe",)
#: Largest magnitude of a length (m), an angle (rad), a mimic multiplier or offset and a mesh scale in a
#: description: the bounds of :mod:`manipkit.bounds` (``MAX_LENGTH`` for lengths, ``MAX_ANGLE`` for angles,
#: the larger of the two for a factor or an offset that may be either), the same a command takes. Real robots
#: are metres and turns; two finite numbers near 1.7e308 would sum to infinity, and a prismatic limit of 1e308
#: made FK print ``[inf, nan, nan]``. Products of these stay far from overflow.
MAX_MAGNITUDE = max(MAX_LENGTH, MAX_ANGLE)

#: Most links (and joints) in a description. Real robots have fewer than 300 (PR2: 88, TIAGo with its hand
#: 89); Pinocchio's model build took minutes for 100,000 links on one root, and a tree image of 20,000 took
#: over a minute and 1.7 GB. Checked right after the XML is parsed, before anything else looks at the links.
MAX_LINKS = 5000

#: Most warnings kept from one description; the rest are counted in one last line.
MAX_WARNINGS = 20

#: Most joints on the way from the root link to any link. Pinocchio's URDF parser walks the tree by
#: recursion, one C++ call per joint: with the usual 8 MB stack it crashes (segmentation fault,
#: nothing printed) on a chain of about 3,800 joints (3,500 load). Real robots are tens deep.
MAX_TREE_DEPTH = 2000

#: A non-unit joint axis is normalised silently below this deviation of its norm from 1
#: (0.7071 0.7071 0 is a unit axis as written by hand), with a warning above it.
AXIS_NORM_TOLERANCE = 1e-4

# A decimal number as URDF writes it (no "1_000", "0x1f", "infinity"); nan/inf are recognised to say so.
_NUMBER = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?")
_NON_FINITE = re.compile(r"[+-]?(nan|inf|infinity)", re.IGNORECASE)

# Optional numeric attributes of joint children that urdfdom parses (and rejects when not numbers).
_JOINT_NUMERIC_ATTRIBUTES = {
    "dynamics": ("damping", "friction"),
    "calibration": ("rising", "falling", "reference_position"),
    "safety_controller": ("soft_lower_limit", "soft_upper_limit", "k_position", "k_velocity"),
    "mimic": ("multiplier", "offset"),
}
_INERTIA_ATTRIBUTES = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")


@dataclass
class CheckedURDF:
    """A URDF description that passed :func:`check_urdf`.

    Attributes
    ----------
    robot : lxml element
        The ``<robot>`` element (``.sourceline`` gives each element's line).
    text : str
        The URDF text to build the model from: the input, with non-unit joint
        axes normalised (unchanged when there were none).
    warnings : list of str
        One line per problem that does not change the kinematics.
    """

    robot: object
    text: str
    warnings: list[str] = field(default_factory=list)


def check_urdf(
    text: str,
    where: str,
    *,
    locate: Callable[[str, str], str | None] | None = None,
) -> CheckedURDF:
    """Parse and check URDF text before Pinocchio sees it.

    Parameters
    ----------
    text : str
        URDF XML.
    where : str
        How to name the description in messages (usually the file name).
    locate : callable, optional
        For text expanded from xacro: ``locate(tag, name)`` returns
        ``"FILE.xacro:LINE"`` where the ``<link>``/``<joint>`` named ``name``
        is written in the xacro sources, or None. Its presence also says the
        line numbers of ``text`` are not the user's.

    Returns
    -------
    CheckedURDF
        The ``<robot>`` element, the text to build from, and warnings.

    Raises
    ------
    DescriptionError
        One line naming the file, the line, the element and what would be
        valid, for: an empty file; malformed XML (line and column); a root
        other than ``<robot name="...">``; xacro elements in a plain URDF;
        links or joints without names or with duplicate names; a joint
        without a type, with an unknown type, or of a type manipkit does not
        handle (floating, planar); a joint without a parent or child, with a
        parent or child link that does not exist, or joining a link to
        itself; a link that is the child of two joints; no root link or more
        than one; a cycle; a tree deeper than :data:`MAX_TREE_DEPTH` joints
        (checked without recursion); a zero axis; a missing ``<limit>`` on a revolute or
        prismatic joint, a ``<limit>`` without effort or velocity, a lower
        limit above the upper one; anything that is not a finite number where
        URDF needs one (origins, axes, limits, dynamics, calibration, safety
        controller, mimic, mass, inertia, geometry sizes, colours); a
        negative mass or size; a ``<mimic>`` of a joint that does not exist or of itself (a warning);
        a ``<visual>``/``<collision>`` without a known geometry; more than :data:`MAX_LINKS` links or
        joints (counted first); a length, angle, limit, mimic multiplier or offset or mesh scale beyond
        :data:`manipkit.bounds.MAX_LENGTH` / ``MAX_ANGLE`` (1e6); a link, joint or robot name holding a
        control, C1, line-separator or bidirectional character (:data:`manipkit.text.UNPRINTABLE`).
        A mimic joint that leaves its own limits over its leader's is a warning.
    """
    return _Checker(where, locate).run(text)


# --------------------------------------------------------------------------
# The checker
# --------------------------------------------------------------------------


class _Checker:
    def __init__(self, where: str, locate):
        self.where = where
        self.locate = locate
        self.expanded = locate is not None
        self.warnings: list[str] = []
        self.dropped = 0  # warnings counted but not kept (see warn)
        self.normalised: list[tuple[object, str]] = []  # (<axis> element, new xyz)

    # -- messages -------------------------------------------------------

    def at(self, element, owner=None) -> str:
        """``FILE:LINE`` of ``element`` (or, after xacro, of its named ``owner`` in the xacro sources)."""
        line = getattr(element, "sourceline", None)
        if not self.expanded:
            return f"{self.where}:{line}" if line else self.where
        owner = owner if owner is not None else element
        name = owner.get("name") if owner is not None else None
        found = self.locate(owner.tag, name) if name and isinstance(owner.tag, str) else None
        if found:
            return found
        return f"{self.where} (expanded URDF, line {line})" if line else self.where

    def fail(self, element, message: str, owner=None):
        raise DescriptionError(f"{self.at(element, owner)}: {message}")

    def warn(self, element, message: str, owner=None) -> None:
        if len(self.warnings) >= MAX_WARNINGS:  # a flood of distinct warnings: counted, not kept
            self.dropped += 1
            return
        self.warnings.append(f"{self.at(element, owner)}: {message}")

    # -- numbers --------------------------------------------------------

    def numbers(self, element, attribute: str, count: int, what: str, owner, *, default=None, unit="",
                non_negative=False, bound=None) -> list[float] | None:
        """``count`` finite numbers from an attribute, or an error naming the element and the value."""
        raw = element.get(attribute)
        if raw is None:
            return default
        tokens = raw.split()
        expected = f"{count} finite number{'s' if count > 1 else ''}{' (' + unit + ')' if unit else ''}"
        shown = f'{attribute}="{raw}"'
        if "${" in raw or "$(" in raw:
            self.fail(element, f"{what} {shown} is an unexpanded xacro expression; "
                      "a file with ${...} or $(...) must be named .xacro (or .urdf.xacro) to be expanded", owner)
        if len(tokens) != count:
            commas = " separated by spaces, not commas" if "," in raw else ""
            self.fail(element, f"{what} {shown} has {len(tokens)} value{'s' if len(tokens) != 1 else ''}; "
                      f"expected {expected}{commas}", owner)
        values = []
        for token in tokens:
            if _NON_FINITE.fullmatch(token):
                self.fail(element, f"{what} {shown}: '{token}' is not finite; expected {expected}", owner)
            if not _NUMBER.fullmatch(token):
                self.fail(element, f"{what} {shown}: '{token}' is not a number; expected {expected}", owner)
            value = float(token)
            if not math.isfinite(value):
                self.fail(element, f"{what} {shown}: '{token}' overflows to infinity; expected {expected}", owner)
            if non_negative and value < 0:
                self.fail(element, f"{what} {shown}: {token} is negative; expected {expected} >= 0", owner)
            if bound is not None and abs(value) > bound:
                unit_text = f" {unit}" if unit else ""
                self.fail(element, f"{what} {shown}: {token}{unit_text} is out of range for a robot; expected "
                          f"|value| <= {short_text(bound)}{unit_text} (is the unit right?)", owner)
            values.append(value)
        return values

    def origin(self, parent, what: str, owner) -> None:
        origin = parent.find("origin")
        if origin is None:
            return
        self.numbers(origin, "xyz", 3, f"{what} <origin>", owner, unit="m", bound=MAX_LENGTH)
        self.numbers(origin, "rpy", 3, f"{what} <origin>", owner, unit="rad", bound=MAX_ANGLE)

    # -- the whole description --------------------------------------------

    def run(self, text: str) -> CheckedURDF:
        root = self.parse(text)
        self.check_width(root)
        links = self.named(root, "link")
        joints = self.named(root, "joint")
        if not links:
            self.fail(root, f"robot '{root.get('name')}' has no <link> elements; a robot needs at least one link")
        for link in links.values():
            self.check_link(link)
        children: dict[str, object] = {}
        for name, joint in joints.items():
            self.check_joint(joint, name, links, joints, children)
        self.check_tree(root, links, joints, children)
        self.check_mimics(joints)
        return CheckedURDF(root, self.normalised_text(text, root),
                           cap_warnings(self.warnings, self.where, dropped=self.dropped))

    def check_width(self, root) -> None:
        """At most :data:`MAX_LINKS` links and joints, counted before anything else looks at them."""
        for tag in ("link", "joint"):
            count = sum(1 for _ in root.iterchildren(tag))
            if count > MAX_LINKS:
                self.fail(root, f"robot '{root.get('name')}' has {count} {tag}s; manipkit loads descriptions of "
                          f"up to {MAX_LINKS} links and {MAX_LINKS} joints (real robots have fewer than 300)")

    def parse(self, text: str):
        from lxml import etree

        if not text.strip():
            raise DescriptionError(f"{self.where}: empty file; a URDF is XML with a <robot name=\"...\"> root element")
        parser = etree.XMLParser(
            resolve_entities="internal", no_network=True, remove_comments=True, remove_pis=True, huge_tree=False
        )
        try:
            root = etree.fromstring(text.encode("utf-8"), parser)
        except etree.XMLSyntaxError as exc:
            line, column = exc.position
            # libxml2 may append the offending source after a newline ("Comment not terminated \n<!--"): keep line one
            message = (exc.msg or str(exc)).strip()
            first_line = message.splitlines()[0] if message else ""
            reason = re.sub(r",? line \d+, column \d+.*$", "", first_line).strip() or "not XML"
            if "Start tag expected" in reason or "Document is empty" in reason:
                reason += " (this is not an XML file)"
            location = f"{self.where}:{line}:{column}" if not self.expanded else f"{self.where} (expanded URDF, line {line})"
            raise DescriptionError(f"{location}: malformed XML: {reason}") from None
        except ValueError as exc:  # e.g. NUL bytes lxml refuses before parsing
            raise DescriptionError(f"{self.where}: not XML text ({exc})") from None
        self.unnamespaced(root)
        if not isinstance(root.tag, str) or root.tag != "robot":
            tag = root.tag if isinstance(root.tag, str) else "?"
            hint = " (this looks like an SDF model; manipkit reads URDF)" if tag == "sdf" else ""
            self.fail(root, f"root element is <{_local(tag)}>, expected <robot name=\"...\">{hint}")
        if not self.expanded:
            for element in root.iter():
                if isinstance(element.tag, str) and element.tag.startswith("{" + XACRO_NAMESPACE + "}"):
                    self.fail(element, f"<xacro:{_local(element.tag)}> in a plain URDF; this file needs xacro "
                              "expansion: name it .urdf.xacro (or .xacro)")
        if not root.get("name"):
            self.fail(root, "<robot> has no name attribute; add name=\"...\" (URDF requires it)")
        self.check_name(root, "robot", root.get("name"))
        dtd = root.getroottree().docinfo.internalDTD
        if dtd is not None and any(True for _ in dtd.iterentities()):
            line = text[: max(text.find("<!ENTITY"), 0)].count("\n") + 1
            raise DescriptionError(
                f"{self.where}:{line}: <!ENTITY> declarations: URDF parsers do not expand them (Pinocchio would "
                "read '&name;' literally); write the values out (or use xacro properties in a .xacro file)"
            )
        return root

    def unnamespaced(self, root) -> None:
        """Read elements in a default XML namespace (``<link xmlns="urn:x">``) by their local names, as
        Pinocchio's parser (not namespace-aware) reads them: otherwise ``{urn:x}link`` would pass every check
        here unseen and still be loaded. Prefixed elements (``<x:link>``) stay apart: to Pinocchio their name
        is ``x:link``, no URDF element."""
        for element in root.iter():
            if isinstance(element.tag, str) and element.tag.startswith("{") and element.prefix is None:
                element.tag = _local(element.tag)

    def named(self, root, tag: str) -> dict:
        named: dict[str, object] = {}
        for index, element in enumerate(root.findall(tag), start=1):
            name = element.get("name")
            if not name:
                self.fail(element, f"<{tag}> number {index} has no name attribute; every {tag} needs a unique name")
            self.check_name(element, tag, name)
            if name in RESERVED_NAMES:
                self.fail(element, f"{tag} '{name}': the name '{name}' is reserved by Pinocchio (its root joint and "
                          f"frame); rename the {tag}")
            if name in named:
                first = getattr(named[name], "sourceline", None)
                first_at = f" (the first is at line {first})" if first and not self.expanded else ""
                self.fail(element, f"two <{tag}> elements are named '{name}'{first_at}; names must be unique")
            named[name] = element
        return named

    def check_name(self, element, tag: str, name: str) -> None:
        """A name is one line of printable text: it is printed in answers (``tf-between``, ``frames``), where a
        line break would forge a line and an escape sequence would drive the terminal."""
        bad = UNPRINTABLE.search(name)
        if bad:
            self.fail(element, f"{tag} name '{printable(name)}': character {bad.start() + 1} is "
                      f"U+{ord(bad.group()):04X}, a control, line-separator or bidirectional character; a name is "
                      "one line of printable text")

    # -- links ----------------------------------------------------------

    def check_link(self, link) -> None:
        name = link.get("name")
        what = f"link '{name}'"
        for inertial in link.findall("inertial"):
            self.check_inertial(inertial, what, link)
        for kind in ("visual", "collision"):
            for element in link.findall(kind):
                self.origin(element, f"{what} <{kind}>", link)
                self.check_geometry(element, f"{what} <{kind}>", link)
                if kind == "visual":
                    for material in element.findall("material"):
                        self.check_material(material, f"{what} <visual>", link)

    def check_inertial(self, inertial, what: str, link) -> None:
        self.origin(inertial, f"{what} <inertial>", link)
        mass = inertial.find("mass")
        if mass is None or mass.get("value") is None:
            self.fail(inertial if mass is None else mass,
                      f"{what} <inertial> has no <mass value=\"...\"/>; give the mass in kg (or remove <inertial>)", link)
        (value,) = self.numbers(mass, "value", 1, f"{what} <mass>", link, unit="kg")
        if value < 0:
            self.fail(mass, f"{what} has mass {short_text(value)} kg; a mass must be >= 0", link)
        inertia = inertial.find("inertia")
        if inertia is None:
            self.fail(inertial, f"{what} <inertial> has no <inertia ixx=... ixy=... ixz=... iyy=... iyz=... izz=.../>", link)
        entries = {}
        for attribute in _INERTIA_ATTRIBUTES:
            if inertia.get(attribute) is None:
                self.fail(inertia, f"{what} <inertia> has no {attribute} attribute; give all of "
                          f"{', '.join(_INERTIA_ATTRIBUTES)} (kg m^2)", link)
            entries[attribute] = self.numbers(inertia, attribute, 1, f"{what} <inertia>", link, unit="kg m^2")[0]
        negative = [a for a in ("ixx", "iyy", "izz") if entries[a] < -1e-9]  # not rounding noise
        if negative:
            listed = ", ".join(f"{a}={short_text(entries[a])}" for a in negative)
            self.warn(inertia, f"{what} <inertia> has negative {listed} "
                      "(a moment of inertia is >= 0); dynamics would be wrong, kinematics are not affected", link)

    def check_geometry(self, element, what: str, link) -> None:
        geometry = element.find("geometry")
        if geometry is None:
            self.fail(element, f"{what} has no <geometry>; give one of <box>, <cylinder>, <sphere>, <mesh>", link)
        shapes = [child for child in geometry if isinstance(child.tag, str)]
        if not shapes:
            self.fail(geometry, f"{what} <geometry> is empty; give one of <box>, <cylinder>, <sphere>, <mesh>", link)
        shape = shapes[0]
        tag = shape.tag
        if tag == "box":
            if shape.get("size") is None:
                self.fail(shape, f"{what} <box> has no size attribute; give size=\"X Y Z\" (m)", link)
            self.numbers(shape, "size", 3, f"{what} <box>", link, unit="m", non_negative=True, bound=MAX_LENGTH)
        elif tag in ("cylinder", "capsule"):
            for attribute in ("radius", "length"):
                if shape.get(attribute) is None:
                    self.fail(shape, f"{what} <{tag}> has no {attribute} attribute; give radius and length (m)", link)
                self.numbers(shape, attribute, 1, f"{what} <{tag}>", link, unit="m", non_negative=True,
                             bound=MAX_LENGTH)
        elif tag == "sphere":
            if shape.get("radius") is None:
                self.fail(shape, f"{what} <sphere> has no radius attribute; give radius=\"R\" (m)", link)
            self.numbers(shape, "radius", 1, f"{what} <sphere>", link, unit="m", non_negative=True, bound=MAX_LENGTH)
        elif tag == "mesh":
            if not shape.get("filename"):
                self.fail(shape, f"{what} <mesh> has no filename attribute; give filename=\"package://PKG/...\" "
                          "or a path", link)
            self.numbers(shape, "scale", 3, f"{what} <mesh>", link, bound=MAX_MAGNITUDE)
        else:
            self.fail(shape, f"{what} <geometry> has <{_local(tag)}>; valid shapes: box, cylinder, sphere, mesh", link)

    def check_material(self, material, what: str, link) -> None:
        color = material.find("color")
        if color is not None:
            rgba = self.numbers(color, "rgba", 4, f"{what} <material> <color>", link, unit="red green blue alpha, 0 to 1")
            if rgba is not None and not all(0.0 <= v <= 1.0 for v in rgba):
                self.fail(color, f"{what} <color rgba=\"{color.get('rgba')}\">: each of red, green, blue, alpha "
                          "must be between 0 and 1", link)

    # -- joints ---------------------------------------------------------

    def check_joint(self, joint, name: str, links: dict, joints: dict, children: dict) -> None:
        what = f"joint '{name}'"
        kind = joint.get("type")
        supported = ", ".join(SUPPORTED_JOINT_TYPES)
        if not kind:
            self.fail(joint, f"{what} has no type attribute; valid types: {supported}")
        if kind not in JOINT_TYPES:
            close = close_matches(kind.lower(), JOINT_TYPES, n=1, cutoff=0.6)
            hint = f"did you mean {close[0]}? " if close else ""
            self.fail(joint, f"{what} has type '{kind}'; {hint}valid types: {supported}")
        ends = {}
        for role in ("parent", "child"):
            element = joint.find(role)
            if element is None or not element.get("link"):
                self.fail(joint if element is None else element, f"{what} has no <{role} link=\"...\"/>", joint)
            link = element.get("link")
            if link not in links:
                close = close_matches(link, list(links), n=2, cutoff=0.6)
                hint = f"did you mean {', '.join(close)}? " if close else ""
                listed = ", ".join(list(links)[:12]) + (", ..." if len(links) > 12 else "")
                self.fail(element, f"{what} {role} link '{link}' does not exist; {hint}links are: {listed}", joint)
            ends[role] = link
        if ends["parent"] == ends["child"]:
            self.fail(joint, f"{what} has link '{ends['parent']}' as both parent and child; "
                      "a joint connects two different links")
        if ends["child"] in children:
            first = children[ends["child"]]
            self.fail(joint, f"link '{ends['child']}' is the child of two joints ('{first.get('name')}' and '{name}'); "
                      "a URDF is a tree: each link has at most one parent joint")
        children[ends["child"]] = joint
        self.origin(joint, what, joint)
        if kind in ("revolute", "continuous", "prismatic"):
            self.check_axis(joint, what)
        limit = joint.find("limit")
        if limit is None and kind in ("revolute", "prismatic"):
            self.fail(joint, f"{kind} {what} has no <limit>; add <limit lower=... upper=... effort=... velocity=...>"
                      + (" or make it continuous" if kind == "revolute" else ""))
        if limit is not None:
            self.check_limit(limit, kind, what, joint)
        for tag, attributes in _JOINT_NUMERIC_ATTRIBUTES.items():
            element = joint.find(tag)
            if element is None:
                continue
            for attribute in attributes:
                self.numbers(element, attribute, 1, f"{what} <{tag}>", joint,
                             bound=MAX_MAGNITUDE if tag == "mimic" else None)
        mimic = joint.find("mimic")
        if mimic is not None:
            target = mimic.get("joint")
            if target == name:
                self.fail(mimic, f"{what} <mimic joint=\"{target}\">: a joint cannot mimic itself; name the joint "
                          f"'{name}' follows, or remove the <mimic>", joint)
            elif not target or target not in joints:
                close = close_matches(target or "", list(joints), n=1, cutoff=0.6)
                hint = f" (did you mean {close[0]}?)" if close else ""
                self.fail(mimic, f"{what} <mimic joint=\"{target or ''}\">: no such joint{hint}; a mimic names the "
                          f"joint '{name}' follows", joint)

    def check_axis(self, joint, what: str) -> None:
        axis = joint.find("axis")
        if axis is None:
            return  # URDF default: 1 0 0
        if axis.get("xyz") is None:  # urdfdom leaves the axis at 0 0 0 then
            self.fail(axis, f"{what} <axis> has no xyz attribute; give xyz=\"1 0 0\" (or another direction), "
                      "or leave <axis> out for the default x axis", joint)
        x, y, z = self.numbers(axis, "xyz", 3, f"{what} <axis>", joint)
        scale = max(abs(x), abs(y), abs(z))  # divided out first where the length of (1e308, 1e308, 0) is not a float
        norm = math.hypot(x, y, z)  # inf when the length is beyond the largest float (then scaled below)
        if norm < 1e-9:
            self.fail(axis, f"{what} has axis '{axis.get('xyz')}'; an axis must be a non-zero vector "
                      "such as '0 0 1' (the direction the joint turns about or slides along)", joint)
        if abs(norm - 1.0) > 1e-12:
            if math.isfinite(norm):
                direction = [v / norm for v in (x, y, z)]
            else:  # beyond the largest float: scaled first
                scaled = math.hypot(x / scale, y / scale, z / scale)
                direction = [v / scale / scaled for v in (x, y, z)]
            unit = " ".join(short_text(v) for v in direction)
            if abs(norm - 1.0) > AXIS_NORM_TOLERANCE:
                length = short_text(norm) if math.isfinite(norm) else "beyond 1.8e308"
                self.warn(axis, f"{what} axis '{axis.get('xyz')}' (length {length}) normalised to '{unit}'", joint)
            self.normalised.append((axis, " ".join(repr(v) for v in direction)))

    def check_limit(self, limit, kind: str, what: str, joint) -> None:
        for attribute in ("effort", "velocity"):
            if limit.get(attribute) is None:
                self.fail(limit, f"{what} <limit> has no {attribute} attribute; URDF requires it "
                          f"(add {attribute}=\"...\"; kinematics do not use it)", joint)
        unit = "m" if kind == "prismatic" else "rad"
        values = {}
        for attribute in ("lower", "upper", "effort", "velocity"):
            moves = attribute in ("lower", "upper") and kind in ("revolute", "prismatic")  # others ignore lower/upper
            number = self.numbers(limit, attribute, 1, f"{what} <limit>", joint,
                                  unit=unit if attribute in ("lower", "upper") else "",
                                  bound=(MAX_LENGTH if kind == "prismatic" else MAX_ANGLE) if moves else None)
            values[attribute] = number[0] if number is not None else 0.0
        lower, upper = values["lower"], values["upper"]
        if kind not in ("revolute", "prismatic"):
            return  # continuous and fixed joints ignore lower/upper
        if lower > upper:
            self.fail(limit, f"{what} has lower limit {short_text(lower)} above upper limit {short_text(upper)} "
                      f"({unit}); swap them", joint)
        if lower == upper:
            missing = [a for a in ("lower", "upper") if limit.get(a) is None]
            why = f" ({' and '.join(missing)} not given: URDF's default is 0)" if missing else ""
            self.warn(limit, f"{what} has limits [{short_text(lower)}, {short_text(upper)}] {unit}{why}: it cannot move; "
                      "give lower= and upper=" + (" or make it continuous" if kind == "revolute" else ""), joint)

    def check_mimics(self, joints: dict) -> None:
        """A warning for a mimic joint that leaves its own limits over its leader's (both revolute or prismatic):
        ``multiplier * [lower, upper] + offset`` outside ``[lower, upper]`` of the follower. A mimic joint follows
        its leader and its own limits are not applied, so this is a warning, not an error: real grippers (and
        hand-written fixtures) often give a follower the leader's limits whatever the multiplier. Its size is
        bounded (:data:`MAX_MAGNITUDE` for the multiplier, offset and limits), so the answer stays finite."""
        for name, joint in joints.items():
            mimic = joint.find("mimic")
            leader = joints.get(mimic.get("joint")) if mimic is not None else None
            if leader is None or joint.get("type") not in ("revolute", "prismatic"):
                continue
            if leader.get("type") not in ("revolute", "prismatic"):
                continue
            multiplier = float(mimic.get("multiplier", 1.0))
            offset = float(mimic.get("offset", 0.0))
            lead_lower, lead_upper = _limits(leader)
            lower, upper = _limits(joint)
            if lower == upper:
                continue  # limits that leave it no motion: warned about already (check_limit)
            ends = sorted((multiplier * lead_lower + offset, multiplier * lead_upper + offset))
            slack = 1e-9 + 1e-9 * max(abs(lower), abs(upper))
            if ends[0] < lower - slack or ends[1] > upper + slack:
                unit = "m" if joint.get("type") == "prismatic" else "rad"
                self.warn(mimic, f"joint '{name}' mimics '{leader.get('name')}' ({name} = {short_text(multiplier)} * "
                          f"{leader.get('name')} + {short_text(offset)}): over the leader's limits "
                          f"[{short_text(lead_lower)}, {short_text(lead_upper)}] it moves over "
                          f"[{short_text(ends[0])}, {short_text(ends[1])}] {unit}, outside its own limits "
                          f"[{short_text(lower)}, {short_text(upper)}] {unit} (they are not applied: it follows "
                          "its leader); widen its <limit> to hold that range, or fix the multiplier and offset", joint)

    # -- the tree -------------------------------------------------------

    def check_tree(self, root, links: dict, joints: dict, children: dict) -> None:
        roots = [name for name in links if name not in children]
        if not roots:
            self.fail(root, "every link has a parent joint, so the joints form a cycle; "
                      "a URDF is a tree with exactly one root link")
        if len(roots) > 1:
            listed = ", ".join(roots[:6]) + (", ..." if len(roots) > 6 else "")
            self.fail(links[roots[1]], f"{len(roots)} root links ({listed}); a URDF has exactly one root: "
                      f"connect the others (e.g. '{roots[1]}') to the tree with joints")
        below: dict[str, list[str]] = {}
        for joint in joints.values():
            below.setdefault(joint.find("parent").get("link"), []).append(joint.find("child").get("link"))
        depth, stack = {roots[0]: 0}, [roots[0]]  # links reached -> joints above them; no recursion
        while stack:
            parent = stack.pop()
            for child in below.get(parent, []):
                if child not in depth:
                    depth[child] = depth[parent] + 1
                    stack.append(child)
        unreachable = [name for name in links if name not in depth]
        if unreachable:
            cycle = _cycle_through(unreachable[0], children)
            shown = " -> ".join(cycle) if cycle else ", ".join(unreachable[:6])
            self.fail(children[unreachable[0]], f"links {', '.join(unreachable[:6])} form a cycle ({shown}) not "
                      f"connected to root '{roots[0]}'; a URDF is a tree: remove one joint of the cycle")
        deepest = max(depth, key=depth.get)
        if depth[deepest] > MAX_TREE_DEPTH:
            self.fail(children[deepest], f"link '{deepest}' is {depth[deepest]} joints below root '{roots[0]}'; "
                      f"manipkit loads trees up to {MAX_TREE_DEPTH} joints deep (Pinocchio's URDF parser recurses "
                      "once per joint and crashes near 3,800)")

    # -- output ---------------------------------------------------------

    def normalised_text(self, text: str, root) -> str:
        """The input text, or (when an axis was normalised) the tree written back with unit axes."""
        if not self.normalised:
            return text
        from lxml import etree

        for axis, xyz in self.normalised:
            axis.set("xyz", xyz)
        return etree.tostring(root, encoding="unicode")


def _limits(joint) -> tuple[float, float]:
    """A checked revolute or prismatic joint's (lower, upper); URDF's default for a missing one is 0."""
    limit = joint.find("limit")
    return float(limit.get("lower", 0.0)), float(limit.get("upper", 0.0))


def cap_warnings(messages: list[str], where: str, *, dropped: int = 0) -> list[str]:
    """``messages`` cut to :data:`MAX_WARNINGS`, with one last line ``WHERE: ... and N more warnings``
    (``dropped`` counts warnings already left out)."""
    messages = list(messages)
    more = dropped + max(len(messages) - MAX_WARNINGS, 0)
    if more:
        messages = messages[:MAX_WARNINGS] + [f"{where}: ... and {more} more warnings"]
    return messages


def _cycle_through(link: str, children: dict) -> list[str]:
    """Links met going up from ``link`` by parent joints until one repeats (the cycle, closed)."""
    path, seen = [link], {link}
    current = link
    while current in children:
        current = children[current].find("parent").get("link")
        path.append(current)
        if current in seen:
            return path[path.index(current):]
        seen.add(current)
    return []


def _local(tag: str) -> str:
    return tag.split("}", 1)[-1]


# --------------------------------------------------------------------------
# package:// URIs
# --------------------------------------------------------------------------


def package_uri_warnings(root, resolver: PackageResolver, where: str, *, locate=None, limit: int = 3,
                         policy: ReadPolicy | None = None) -> list[str]:
    """Warnings for mesh and texture files that do not exist: ``package://``, ``file://`` and plain paths.

    Kinematics do not need meshes, so these are warnings (the viewer raises
    its own error for them, :func:`manipkit.description.meshes.mesh_path`).
    A URI is resolved as the viewer resolves it: ``package://`` with
    :meth:`~manipkit.description.packages.PackageResolver.resolve_uri`, other
    paths with :func:`~manipkit.description.meshes.mesh_search_paths`, a
    relative path against the folder of ``resolver.near`` (the description
    file; without one, relative paths are not checked). Other schemes
    (``http://``) are left to the viewer.

    Parameters
    ----------
    root : lxml element
        The ``<robot>`` element from :func:`check_urdf`.
    resolver : manipkit.description.packages.PackageResolver
        Answers ``package://PKG``; its ``near`` is the description file.
    where, locate
        As for :func:`check_urdf`.
    limit : int
        At most this many missing files are named one by one (then a count).
    policy : ReadPolicy, optional
        What the description may read (:mod:`manipkit.description.access`): a mesh outside it is
        reported as such (whether it exists is not looked at).
    """
    from manipkit.description.meshes import mesh_search_paths

    checker = _Checker(where, locate)
    uris: dict[str, tuple[object, object]] = {}
    for link in root.findall("link"):
        for element in link.iter("mesh", "texture"):
            uri = element.get("filename")
            if uri and uri not in uris and ("://" not in uri or uri.startswith((PACKAGE_SCHEME, "file://"))):
                uris[uri] = (element, link)
    warnings, missing_packages, missing_files = [], {}, []
    for uri, (element, link) in uris.items():
        if not uri.startswith(PACKAGE_SCHEME):
            folder = os.path.dirname(os.path.abspath(resolver.near)) if resolver.near is not None else None
            searched = mesh_search_paths(uri, resolver, relative_to=folder or ".")
            if policy is not None and not policy.allows(searched[0]):
                missing_files.append((element, link, uri, f"{searched[0]} is outside what the description may "
                                      "read (--allow-read DIR allows a folder); not looked at"))
                continue
            if (folder is not None or searched[0].is_absolute()) and not any(p.is_file() for p in searched):
                missing_files.append((element, link, uri, f"no such file {searched[0]}"
                                      f"{', nor in the current folder' * (len(searched) > 1)}"))
            continue
        package, _ = split_package_uri(uri)
        if not package:
            missing_packages.setdefault("", [(element, link, uri, "empty package name (package:/// has three "
                                               "slashes; expected package://PKG/path)"), 0])[1] += 1
            continue
        if package in missing_packages:
            missing_packages[package][1] += 1
            continue
        try:
            path = resolver.resolve_uri(uri)
        except PackageNotFoundError as exc:
            missing_packages[package] = [(element, link, uri, str(exc)), 1]
            continue
        if policy is not None and not policy.allows(path):
            missing_files.append((element, link, uri, f"{path} is outside what the description may read "
                                  "(--allow-read DIR allows a folder); not looked at"))
        elif not os.path.isfile(path):
            missing_files.append((element, link, uri, f"no such file {path}"))
    for (element, link, uri, reason), count in missing_packages.values():
        more = f" and {count - 1} more mesh file(s) of it" if count > 1 else ""
        warnings.append(f"{checker.at(element, link)}: link '{link.get('name')}' mesh {uri}{more}: {reason} "
                        "(kinematics do not need meshes; the viewer does)")
    for element, link, uri, reason in missing_files[:limit]:
        warnings.append(f"{checker.at(element, link)}: link '{link.get('name')}' mesh {uri}: {reason} "
                        "(kinematics do not need meshes; the viewer does)")
    if len(missing_files) > limit:
        warnings.append(f"{where}: {len(missing_files) - limit} more mesh file(s) not found")
    return warnings
