"""The link/joint tree of a URDF: as text, as Graphviz DOT and as an image.

All functions take a parsed :class:`yourdfpy.URDF` (or its ``.robot``), as
:func:`parse_structure` returns it from URDF text, and only read
``robot.links`` and ``robot.joints``; the description is never changed.

Conventions, as in URDF and everywhere in manipkit:

- a joint's origin is the pose of the child link frame in the parent link
  frame, printed as ``xyz`` in metres and ``rpy`` in radians with
  R = Rz(yaw) Ry(pitch) Rx(roll);
- a missing ``<origin>`` is the identity, a missing ``<axis>`` is ``1 0 0``;
- children are listed in the order their joints appear in the file.

Descriptions that are not a single tree (several root links, a link that is
the child of two joints, a joint cycle, a joint naming an undeclared link) are
drawn as far as they go and the problem is stated, never raised.

>>> print(tree_text(urdf))                                   # doctest: +SKIP
robot name is: course_arm
root Link: base_link has 1 child(ren)
base_link
└── arm_base_joint (continuous, axis 0 0 1) ── arm_base
    └── shoulder_joint (continuous, axis 0 1 0) ── bicep
...
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from manipkit.errors import OutputError
from manipkit.outputs import writable_path, writing
from manipkit.spatial.rotations import rpy_from_matrix, wrap_angle
from manipkit.text import trimmed_text

__all__ = ["MAX_IMAGE_LINKS", "parse_structure", "tree_dot", "tree_text", "write_tree_image"]

#: Joint types that move along or about their axis.
MOVABLE_TYPES = ("revolute", "continuous", "prismatic")
#: Order in which joint types are counted in summaries.
_TYPE_ORDER = ("revolute", "continuous", "prismatic", "fixed", "floating", "planar")
_IMAGE_FORMATS = ("png", "svg")


# --------------------------------------------------------------------------
# The structure, read once
# --------------------------------------------------------------------------


def parse_structure(text: str):
    """The link/joint structure of URDF text as a ``yourdfpy.URDF`` (no meshes, no scene graph).

    yourdfpy is a second, independent URDF parser; manipkit uses it for the
    tree and as a cross-check of Pinocchio's kinematics.
    """
    from io import BytesIO

    import yourdfpy

    return yourdfpy.URDF.load(
        BytesIO(text.encode()),
        build_scene_graph=False,
        load_meshes=False,
        build_collision_scene_graph=False,
        load_collision_meshes=False,
    )


@dataclass(frozen=True)
class _Tree:
    """The link/joint graph of a description, with a spanning forest.

    ``children[link]`` lists every joint whose parent is ``link`` (file
    order); ``tree_joints`` are the ids of those joints that form the
    spanning forest (a depth-first walk from the roots in file order), the
    other joints close a cycle or give a link a second parent.
    """

    name: str
    links: tuple[str, ...]
    undeclared: frozenset[str]
    joints: tuple  # yourdfpy Joint objects, file order
    children: dict  # link -> tuple of joints
    roots: tuple[str, ...]  # links that are no joint's child
    detached: tuple[str, ...]  # start links of parts no root reaches
    tree_joints: frozenset[int]  # id() of the spanning-forest joints
    warnings: tuple[str, ...]

    def tree_children(self, link: str) -> list:
        """Joints of the spanning forest below ``link``, in file order."""
        return [j for j in self.children.get(link, ()) if id(j) in self.tree_joints]

    @property
    def starts(self) -> tuple[str, ...]:
        return self.roots + self.detached


# Over 80 lines: one pass over the description collecting every problem (duplicates, undeclared links,
# second parents, roots, cycles); the steps share their tables, and splitting them would pass all of them around.
def _analyse(urdf) -> _Tree:
    """The link tree of a parsed description with everything that is not a tree named (warnings)."""
    robot = getattr(urdf, "robot", urdf)
    warnings: list[str] = []
    links = _declared_links(robot, warnings)
    declared = set(links)
    joints = tuple(robot.joints)

    undeclared: list[str] = []
    children: dict[str, list] = {}
    parents_of: dict[str, list[str]] = {}
    for joint in joints:
        for role, link in (("parent", joint.parent), ("child", joint.child)):
            if link not in declared and link not in undeclared:
                undeclared.append(link)
                warnings.append(f"joint '{joint.name}' names {role} link '{link}', which is not declared")
        children.setdefault(joint.parent, []).append(joint)
        parents_of.setdefault(joint.child, []).append(joint.name)
    links += undeclared
    warnings += _joint_warnings(joints, parents_of)

    roots = tuple(link for link in links if link not in parents_of)
    if not links:
        warnings.append("the description declares no links")
    elif len(roots) > 1:
        warnings.append(f"{len(roots)} root links ({', '.join(roots)}); a URDF tree has exactly one root")
    tree_joints, lost, detached = _spanning_forest(links, roots, children)
    if lost:
        warnings.append(f"links no root link reaches (a joint cycle?): {', '.join(lost)}")

    return _Tree(
        name=robot.name,
        links=tuple(links),
        undeclared=frozenset(undeclared),
        joints=joints,
        children={k: tuple(v) for k, v in children.items()},
        roots=roots,
        detached=tuple(detached),
        tree_joints=frozenset(tree_joints),
        warnings=tuple(warnings),
    )


def _declared_links(robot, warnings: list[str]) -> list[str]:
    """Link names in file order, each once (a repeated declaration is a warning)."""
    links: list[str] = []
    for link in robot.links:
        if link.name in links:
            warnings.append(f"link '{link.name}' is declared more than once")
        else:
            links.append(link.name)
    return links


def _joint_warnings(joints, parents_of: dict[str, list[str]]) -> list[str]:
    """Repeated joint names, joints from a link to itself, links with several parent joints."""
    warnings = [f"joint '{name}' is declared {n} times" for name, n in Counter(j.name for j in joints).items() if n > 1]
    warnings += [f"joint '{j.name}' connects link '{j.parent}' to itself" for j in joints if j.parent == j.child]
    warnings += [f"link '{link}' is the child of {len(names)} joints ({', '.join(names)}); a tree allows one"
                 for link, names in parents_of.items() if len(names) > 1]
    return warnings


def _spanning_forest(links, roots, children) -> tuple[set[int], list[str], list[str]]:
    """(ids of the tree joints, links no root reaches, the links the walk restarted from for them).

    Depth-first from each root in file order; a joint whose child is already
    reached closes a cycle or is a second parent.
    """
    reached: set[str] = set()
    tree_joints: set[int] = set()

    def walk(start: str) -> None:
        reached.add(start)
        stack = [iter(children.get(start, ()))]
        while stack:
            joint = next(stack[-1], None)
            if joint is None:
                stack.pop()
            elif joint.child not in reached:
                reached.add(joint.child)
                tree_joints.add(id(joint))
                stack.append(iter(children.get(joint.child, ())))

    for root in roots:
        walk(root)
    lost = [link for link in links if link not in reached]
    detached: list[str] = []
    for link in lost:
        if link not in reached:
            detached.append(link)
            walk(link)
    return tree_joints, lost, detached


# --------------------------------------------------------------------------
# Numbers and joint descriptions
# --------------------------------------------------------------------------


def _rpy_as_written(R) -> np.ndarray:
    """Of the two rpy triples of a rotation, the one with the least total angle.

    (roll, pitch, yaw) and (roll + pi, pi - pitch, yaw + pi) give the same
    matrix. :func:`~manipkit.spatial.rotations.rpy_from_matrix` keeps pitch in [-pi/2, pi/2]; a file that writes
    ``rpy="0 1.5708 0"`` (just past pi/2) reads better as that than as
    ``3.141593 1.570793 3.141593``, so the smaller triple is shown.
    """
    rpy = rpy_from_matrix(np.asarray(R, dtype=float)[..., :3, :3], check=False)
    other = wrap_angle(rpy * (1.0, -1.0, 1.0) + (np.pi, np.pi, np.pi))
    return other if np.abs(other).sum() < np.abs(rpy).sum() - 1e-12 else rpy


def _origin_xyz_rpy(joint) -> tuple[np.ndarray, np.ndarray]:
    """(xyz in metres, rpy in radians) of a joint origin; identity if absent."""
    if joint.origin is None:
        return np.zeros(3), np.zeros(3)
    T = np.asarray(joint.origin, dtype=float)
    return T[:3, 3], _rpy_as_written(T)


def _joint_kind(joint) -> str:
    """``'revolute, axis 0 0 1'``, ``'fixed'``, ``'planar, normal 0 0 1'``; a mimic joint adds ``mimics J (x m + o)``."""
    kind = joint.type or "untyped"
    axis = " ".join(map(trimmed_text, joint.axis if joint.axis is not None else (1.0, 0.0, 0.0)))
    if kind in MOVABLE_TYPES:
        mimic = getattr(joint, "mimic", None)
        if mimic is not None and mimic.joint:  # its value is multiplier * leader + offset: no value of its own
            multiplier = 1.0 if mimic.multiplier is None else mimic.multiplier
            offset = 0.0 if mimic.offset is None else mimic.offset
            return f"{kind}, axis {axis}, mimics {mimic.joint} (x {trimmed_text(multiplier)} + {trimmed_text(offset)})"
        return f"{kind}, axis {axis}"
    if kind == "planar":
        return f"{kind}, normal {axis}"
    return kind


def _joint_lines(joint) -> list[str]:
    """The label of a joint in DOT and in the image: name, type and axis, xyz, rpy."""
    xyz, rpy = _origin_xyz_rpy(joint)
    xyz_text, rpy_text = (" ".join(map(trimmed_text, v)) for v in (xyz, rpy))  # as URDF writes them: 0.089159 0 1
    return [joint.name, _joint_kind(joint), f"xyz {xyz_text}", f"rpy {rpy_text}"]


def _shown(text: str) -> str:
    """``text`` for one line of the text tree or the image: line breaks and tabs in names as ``\\n``, ``\\r``, ``\\t``.

    (XML allows no other control characters, even as character references.)
    """
    return text.replace("\n", "\\n").replace("\r", "\\r").replace("\t", "\\t")


def _summary(tree: _Tree) -> str:
    def plural(n, word):
        return f"{n} {word}" + ("" if n == 1 else "s")

    by_type = Counter(j.type or "untyped" for j in tree.joints)
    order = [t for t in _TYPE_ORDER if t in by_type] + sorted(set(by_type) - set(_TYPE_ORDER))
    text = f"{plural(len(tree.links), 'link')}, {plural(len(tree.joints), 'joint')}"
    if by_type:
        text += ": " + ", ".join(f"{by_type[t]} {t}" for t in order)
    mimics = sum(1 for j in tree.joints if getattr(j, "mimic", None) is not None and j.mimic.joint)
    if mimics:
        text += f" ({plural(mimics, 'mimic joint')}, moved by the joints they follow)"
    return text


# --------------------------------------------------------------------------
# Text
# --------------------------------------------------------------------------


def tree_text(urdf, *, ascii_only: bool = False) -> str:
    """The link tree as text, in the spirit of ROS ``check_urdf``.

    Parameters
    ----------
    urdf : yourdfpy.URDF or yourdfpy.Robot
        The parsed description.
    ascii_only : bool, keyword-only
        Draw the branches with ``|--``, ``` `-- ``` and ``--`` instead of box-drawing
        characters (a terminal whose encoding has none: ``LC_ALL=C``, ``PYTHONIOENCODING=ascii``).

    Returns
    -------
    str
        ``robot name is: NAME``, any warnings (``warning: ...``), then for
        each root link ``root Link: X has N child(ren)`` and its tree, one
        edge per line as ``JOINT (TYPE, axis X Y Z) ── CHILD`` (axis for
        revolute, continuous and prismatic joints, in the joint frame),
        children in file order. A joint reaching a link already shown ends in
        ``(already shown)``. The last line counts links and joints by type.
    """
    tree = _analyse(urdf)
    lines = [f"robot name is: {tree.name}"]
    lines += [f"warning: {w}" for w in tree.warnings]
    shown: set[str] = set()
    for start in tree.starts:
        label = "root" if start in tree.roots else "detached"
        lines.append(f"{label} Link: {start} has {len(tree.children.get(start, ()))} child(ren)")
        lines.append(start)
        shown.add(start)
        # Stack of (iterator over remaining joints, indent prefix).
        stack = [(list(tree.children.get(start, ())), "")]
        while stack:
            pending, prefix = stack[-1]
            if not pending:
                stack.pop()
                continue
            joint = pending.pop(0)
            last = not pending
            branch, more = (("`-- ", "    ") if last else ("|-- ", "|   ")) if ascii_only else \
                (("└── ", "    ") if last else ("├── ", "│   "))
            seen = joint.child in shown
            lines.append(
                f"{prefix}{branch}{joint.name} ({_joint_kind(joint)}) {'--' if ascii_only else '──'} {joint.child}"
                + (" (already shown)" if seen else "")
            )
            if not seen:
                shown.add(joint.child)
                stack.append((list(tree.children.get(joint.child, ())), prefix + more))
    lines.append(_summary(tree))
    return "\n".join(map(_shown, lines)) + "\n"


# --------------------------------------------------------------------------
# Graphviz DOT
# --------------------------------------------------------------------------


def _dot_string(text: str) -> str:
    """A DOT quoted string (an ID): backslashes and quotes escaped, line breaks as ``\\n`` and ``\\r``.

    Graphviz's lexer ends a quoted string only at an unescaped ``"``; with every
    backslash doubled, distinct names stay distinct IDs and each statement stays on one line.
    """
    escaped = text.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n").replace("\r", "\\r")
    return f'"{escaped}"'


def _dot_label(lines) -> str:
    """A DOT label of text lines, shown as written.

    On top of :func:`_dot_string`, ``&`` becomes ``&amp;``: Graphviz reads
    HTML entities (``&lt;``, ``&#60;``) in every label, so a name spelled
    with one would otherwise be drawn as the character it names.
    ``<``, ``>`` and escapes such as ``\\N`` need nothing more: a quoted
    label is never HTML, and the doubled backslash is drawn as one.
    """
    return _dot_string("\n".join(lines).replace("&", "&amp;"))


def tree_dot(urdf) -> str:
    """The link/joint graph in Graphviz DOT, in the spirit of ``urdf_to_graphiz``.

    Parameters
    ----------
    urdf : yourdfpy.URDF or yourdfpy.Robot
        The parsed description.

    Returns
    -------
    str
        A ``digraph``: one ``shape=box`` node per link (id ``"link:NAME"``,
        label ``NAME``; undeclared links dashed), one ``shape=ellipse`` node
        per joint (id ``"joint:NAME"``) labelled with its name, its type
        (and axis, as in :func:`tree_text`) and its origin as ``xyz`` (metres) and ``rpy`` (radians, R = Rz(yaw)
        Ry(pitch) Rx(roll)), rounded to 6 decimals; two edges per joint,
        parent link -> joint -> child link. Render with
        ``dot -Tpng tree.dot -o tree.png``. Every name is escaped (quotes,
        backslashes, line breaks; ``&`` in labels), so Graphviz draws it as
        written and a name cannot end a string or add a statement.
    """
    tree = _analyse(urdf)
    out = [
        f"digraph {_dot_string(tree.name)} {{",
        f"  graph [rankdir=TB, labelloc=t, label={_dot_label([tree.name + ': ' + _summary(tree)])}];",
        '  node [fontname="Helvetica", fontsize=10];',
        '  edge [arrowsize=0.7];',
    ]
    for link in tree.links:
        style = ', style=dashed, color=red, tooltip="not declared"' if link in tree.undeclared else ""
        out.append(f"  {_dot_string('link:' + link)} [label={_dot_label([link])}, shape=box{style}];")
    joint_ids = _joint_ids(tree)
    for joint in tree.joints:
        out.append(f"  {_dot_string(joint_ids[id(joint)])} [label={_dot_label(_joint_lines(joint))}, shape=ellipse];")
    for joint in tree.joints:
        jid = _dot_string(joint_ids[id(joint)])
        out.append(f"  {_dot_string('link:' + joint.parent)} -> {jid};")
        out.append(f"  {jid} -> {_dot_string('link:' + joint.child)};")
    out.append("}")
    return "\n".join(out) + "\n"


def _joint_ids(tree: _Tree) -> dict[int, str]:
    """``joint:NAME``, with ``#2``, ``#3`` ... for repeated names."""
    ids, count = {}, Counter()
    for joint in tree.joints:
        count[joint.name] += 1
        suffix = "" if count[joint.name] == 1 else f"#{count[joint.name]}"
        ids[id(joint)] = f"joint:{joint.name}{suffix}"
    return ids


# --------------------------------------------------------------------------
# Layout (in points, the unit of the drawing)
# --------------------------------------------------------------------------

_FONT_PT = 8.0
_CHAR_W = 0.6021 * _FONT_PT  # advance of DejaVu Sans Mono (1233/2048 em)
_LINE_H = 1.3 * _FONT_PT
_PAD_X, _PAD_Y = 5.0, 3.5
_LINK_H = _LINE_H + 2 * _PAD_Y
_LABEL_LINES = 4
_LABEL_H = _LABEL_LINES * _LINE_H + 2 * _PAD_Y
_BUS_DROP = 9.0  # from a parent box to the horizontal bus of its edges
_EDGE_DROP = 18.0  # from a parent box to the top of a child's joint label
_LABEL_GAP = 7.0  # from a joint label to its child's box
_SIBLING_GAP = 14.0
#: Vertical distance between the centres of a parent and a child link box.
_LEVEL_H = _LINK_H / 2 + _EDGE_DROP + _LABEL_H + _LABEL_GAP + _LINK_H / 2


def _text_width(line: str) -> float:
    return len(_shown(line)) * _CHAR_W + 2 * _PAD_X


def _parent_joint(tree: _Tree) -> dict[str, object]:
    return {j.child: j for j in tree.joints if id(j) in tree.tree_joints}


def _widths(tree: _Tree) -> dict[str, float]:
    """Width in points of each link's column in the image: its box and the label of its joint."""
    parent_joint = _parent_joint(tree)
    widths = {}
    for link in tree.links:
        lines = [link]
        if link in parent_joint:
            lines += _joint_lines(parent_joint[link])
        widths[link] = max(_text_width(line) for line in lines)
    return widths


def _pack(contours: list[list[tuple[float, float]]], gap: float):
    """Place subtrees left to right, each as far left as its contour allows.

    A contour lists, per level below the subtree's root (0 = the root), the
    (left, right) extent relative to the root's x. Returns the x of each
    subtree root (first at 0) and the merged contour.
    """
    xs: list[float] = []
    merged: list[tuple[float, float]] = []
    for contour in contours:
        x = 0.0
        if xs:
            x = max(merged[d][1] - contour[d][0] + gap for d in range(min(len(merged), len(contour))))
        xs.append(x)
        for d, (left, right) in enumerate(contour):
            if d < len(merged):
                merged[d] = (min(merged[d][0], left + x), max(merged[d][1], right + x))
            else:
                merged.append((left + x, right + x))
    return xs, merged


def _layout_tree(tree: _Tree, widths: dict[str, float]) -> dict[str, tuple[float, float]]:
    """Centre (x, y) of each link's box in the image, in points.

    A tidy top-down layout: roots at y = 0, each level ``_LEVEL_H`` lower
    (y decreases downwards), children in file order left to right, each
    subtree packed as far left as its contour allows (per level, with a gap
    between the ``widths`` of :func:`_widths`), and each parent centred over
    its first and last child.
    """
    kids = {link: [j.child for j in tree.tree_children(link)] for link in tree.links}
    # Post-order, iteratively (chains can be deeper than Python's recursion).
    postorder: list[str] = []
    for start in tree.starts:
        stack = [(start, False)]
        while stack:
            link, done = stack.pop()
            if done:
                postorder.append(link)
            else:
                stack.append((link, True))
                stack += [(c, False) for c in reversed(kids[link])]
    offset: dict[str, float] = {}
    contour: dict[str, list[tuple[float, float]]] = {}
    for link in postorder:
        own = (-widths[link] / 2, widths[link] / 2)
        if not kids[link]:
            contour[link] = [own]
            continue
        xs, merged = _pack([contour.pop(c) for c in kids[link]], _SIBLING_GAP)
        middle = (xs[0] + xs[-1]) / 2  # centred over first and last child
        for child, x in zip(kids[link], xs):
            offset[child] = x - middle
        contour[link] = [own] + [(left - middle, right - middle) for left, right in merged]
    xs, _ = _pack([contour[s] for s in tree.starts], 2 * _SIBLING_GAP)
    position: dict[str, tuple[float, float]] = {}
    for start, x in zip(tree.starts, xs):
        position[start] = (x, 0.0)
        todo = [start]
        while todo:
            link = todo.pop()
            px, py = position[link]
            for child in kids[link]:
                position[child] = (px + offset[child], py - _LEVEL_H)
                todo.append(child)
    return position


# --------------------------------------------------------------------------
# Image
# --------------------------------------------------------------------------

_LINK_FACE, _LINK_EDGE = "#dce9f7", "#2f5f98"
_JOINT_FACE = {
    "revolute": "#fde3c8",
    "continuous": "#fdf0b5",
    "prismatic": "#d6f0d2",
    "fixed": "#e8e8e8",
    "floating": "#eadcf6",
    "planar": "#eadcf6",
}
_TEXT_COLOUR = "#1a1a1a"
_MARGIN = 12.0
_MAX_PIXELS = 30000  # per side; above it the PNG resolution is lowered
#: Most links a tree image draws: beyond it the picture is unreadable, and drawing 20,000 took over a minute
#: and 1.7 GB (the text and DOT trees have no such bound below ``validate.MAX_LINKS``).
MAX_IMAGE_LINKS = 1000


# Over 80 lines: one figure drawn top to bottom (header, edges and joint labels, extra joints, link boxes);
# each part uses the same axes, layout and text style, so it reads as one sequence.
def write_tree_image(urdf, path, *, fmt: str | None = None) -> Path:
    """Draw the link tree with matplotlib and save it as PNG or SVG.

    Links are boxes; each joint is a box on the edge just above its child
    link, coloured by type and showing its name, type, axis and origin as
    ``xyz`` (metres) and ``rpy`` (radians, R = Rz(yaw) Ry(pitch) Rx(roll)).
    The root is at the top; each parent is centred over its children. Text
    has a fixed size (8 pt) and the figure grows with the tree, so large
    robots stay readable. Joints outside the spanning tree (second parents,
    cycles) are dashed red arcs, and warnings are listed under the title.
    No Graphviz binary is needed.

    Parameters
    ----------
    urdf : yourdfpy.URDF or yourdfpy.Robot
        The parsed description.
    path : str or os.PathLike
        The file to write.
    fmt : {"png", "svg"}, optional
        The format; by default taken from the suffix of ``path``.

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    OutputError
        If the format is neither PNG nor SVG, the tree has more than
        :data:`MAX_IMAGE_LINKS` links (checked before drawing), or the file cannot be written
        (``cannot write PATH: reason``, checked before drawing: no folder is
        created; see :mod:`manipkit.outputs`).
    """
    # Over 80 lines: the docstring is a third of it; the rest sizes the figure, then calls the drawing steps.
    path = writable_path(path)
    fmt = (fmt or path.suffix.lstrip(".")).lower()
    if fmt not in _IMAGE_FORMATS:
        raise OutputError(
            f"cannot write a tree image as {fmt!r} ({path.name}); use a .png or .svg file or fmt='png'/'svg'"
        )

    import matplotlib
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    tree = _analyse(urdf)
    if len(tree.links) > MAX_IMAGE_LINKS:
        raise OutputError(f"cannot draw a tree image of {len(tree.links)} links ({path.name}); an image shows up "
                          f"to {MAX_IMAGE_LINKS} links; write the tree as text or DOT (--format text or dot)")
    widths = _widths(tree)
    position = _layout_tree(tree, widths)
    parent_joint = _parent_joint(tree)

    header = [f"{tree.name}: {_summary(tree)}"] + [f"warning: {w}" for w in tree.warnings]
    header_h = len(header) * _LINE_H + _PAD_Y
    if position:
        left = min(x - widths[k] / 2 for k, (x, _) in position.items())
        right = max(x + widths[k] / 2 for k, (x, _) in position.items())
        bottom = min(y for _, y in position.values()) - _LINK_H / 2
    else:
        left = right = bottom = 0.0
    right = max(right, left + max(_text_width(line) for line in header))
    top = _LINK_H / 2 + header_h
    x0, x1 = left - _MARGIN, right + _MARGIN
    y0, y1 = bottom - _MARGIN, top + _MARGIN
    width_in, height_in = (x1 - x0) / 72, (y1 - y0) / 72

    dpi = min(150.0, _MAX_PIXELS / max(width_in, height_in))
    fig = Figure(figsize=(width_in, height_in), dpi=dpi)
    FigureCanvasAgg(fig)
    ax = fig.add_axes((0, 0, 1, 1))
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)  # one data unit = one point: sizes match the text
    ax.set_axis_off()
    # parse_math=False: a name with "$" is text, not mathtext (which could fail to parse)
    text = dict(fontsize=_FONT_PT, family="monospace", color=_TEXT_COLOUR, ha="center", va="center",
                parse_math=False)

    for i, line in enumerate(header):
        colour, weight = (_TEXT_COLOUR, "bold") if i == 0 else ("#b00020", "normal")
        ax.text(x0 + _MARGIN, top - (i + 0.5) * _LINE_H, _shown(line), **{**text, "ha": "left", "color": colour},
                weight=weight)

    _draw_joints(ax, position, parent_joint, text)
    _draw_extra_joints(ax, tree, position, widths, text)
    for link, (x, y) in position.items():
        edge = "#b00020" if link in tree.undeclared else _LINK_EDGE
        _box(ax, x, y, _text_width(link), _LINK_H, _LINK_FACE, edge, zorder=2)
        ax.text(x, y, _shown(link), **text, weight="bold", zorder=3)

    with matplotlib.rc_context({"svg.fonttype": "none", "svg.hashsalt": "manipkit"}), writing(path) as target:
        # PNG: zlib level 1 (PR2's 8000 x 3000 picture: 0.2 s less than the default 6, a slightly larger file)
        extra = {"pil_kwargs": {"compress_level": 1}} if fmt == "png" else {}
        fig.savefig(target, format=fmt, dpi=dpi, metadata=_deterministic_metadata(fmt), **extra)
    return path


def _box(ax, cx, cy, w, h, face, edge, **kw) -> None:
    """A rounded box of w x h points centred at (cx, cy)."""
    from matplotlib.patches import FancyBboxPatch

    ax.add_patch(FancyBboxPatch((cx - w / 2, cy - h / 2), w, h, boxstyle="round,pad=0,rounding_size=3",
                                facecolor=face, edgecolor=edge, linewidth=0.8, **kw))


def _draw_joints(ax, position, parent_joint, text) -> None:
    """Each tree joint: the edge from its parent link, and its box of lines just above its child link."""
    line_kw = dict(color="#555555", linewidth=0.8, solid_capstyle="butt", zorder=1)
    for link, (x, y) in position.items():
        joint = parent_joint.get(link)
        if joint is None:
            continue
        px, py = position[joint.parent]
        label_top = py - _LINK_H / 2 - _EDGE_DROP
        bus = py - _LINK_H / 2 - _BUS_DROP
        ax.plot([px, px, x, x], [py - _LINK_H / 2, bus, bus, label_top], **line_kw)
        label_bottom = label_top - _LABEL_H
        ax.plot([x, x], [label_bottom, y + _LINK_H / 2], **line_kw)
        lines = _joint_lines(joint)
        w = max(_text_width(line) for line in lines)
        _box(ax, x, label_top - _LABEL_H / 2, w, _LABEL_H, _JOINT_FACE.get(joint.type, "white"), "#777777", zorder=2)
        for i, line in enumerate(lines):
            ax.text(x, label_top - _PAD_Y - (i + 0.5) * _LINE_H, _shown(line), **text,
                    weight="bold" if i == 0 else "normal", zorder=3)


def _draw_extra_joints(ax, tree, position, widths, text) -> None:
    """Joints outside the spanning forest (second parents, cycles): dashed red arcs with their names."""
    from matplotlib.patches import FancyArrowPatch

    warn = {**text, "color": "#b00020"}
    for joint in tree.joints:
        if id(joint) in tree.tree_joints:
            continue
        (px, py), (cx, cy) = position[joint.parent], position[joint.child]
        name = f"{joint.name} ({joint.type})"
        dx, dy = cx - px, cy - py
        length = float(np.hypot(dx, dy))
        if length < 1.0:  # a joint from a link to itself
            ax.text(px, py - _LINK_H / 2 - _LINE_H, "↺ " + _shown(name), **warn, zorder=3)
            continue
        # Bulge to the right (or down) by more than half the wider column,
        # so the arc and its label clear the boxes at both ends.
        nx, ny = dy / length, -dx / length  # unit normal used by "arc3"
        sign = 1.0 if (nx, -ny) > (0.0, 0.0) else -1.0
        bulge = max(widths[joint.parent], widths[joint.child]) / 2 + 2 * _SIBLING_GAP
        ax.add_patch(
            FancyArrowPatch(
                (px, py), (cx, cy), connectionstyle=f"arc3,rad={sign * 2 * bulge / length}",
                arrowstyle="-", color="#b00020", linewidth=0.8, linestyle="--", zorder=1,
            )
        )
        lx, ly = (px + cx) / 2 + sign * bulge * nx, (py + cy) / 2 + sign * bulge * ny
        ax.text(lx, ly, _shown(name), **{**warn, "ha": "left" if sign * nx >= 0 else "right"}, zorder=3,
                bbox=dict(facecolor="white", edgecolor="none", pad=1))


def _deterministic_metadata(fmt: str) -> dict:
    return {"Software": None} if fmt == "png" else {"Date": None}
