"""Tests of manipkit.description.tree: the link/joint tree as text, DOT and an image.

Expected values come from the URDF text itself (read here with
xml.etree, independently of yourdfpy), from Pinocchio's rpy conversions, or
are written out by hand below.
"""

from __future__ import annotations

import io
import math
import re
import shutil
import struct
import subprocess
import sys
import xml.etree.ElementTree as ET
from collections import Counter, defaultdict
from importlib import metadata
from pathlib import Path

import pytest
import yourdfpy
from hypothesis import given, settings
from hypothesis import strategies as st

from manipkit.description import tree
from manipkit.errors import OutputError

UR5_FILE = "cmeel.prefix/share/example-robot-data/robots/ur_description/urdf/ur5_robot.urdf"
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def load(text: str) -> yourdfpy.URDF:
    return yourdfpy.URDF.load(
        io.BytesIO(text.encode()),
        build_scene_graph=False,
        load_meshes=False,
        build_collision_scene_graph=False,
        load_collision_meshes=False,
    )


def robot(name: str, links, joints) -> str:
    """URDF text from link names and (name, type, parent, child, xyz, rpy, axis) rows."""
    parts = [f'<robot name="{name}">']
    parts += [f'<link name="{link}"/>' for link in links]
    for jname, jtype, parent, child, xyz, rpy, axis in joints:
        parts.append(
            f'<joint name="{jname}" type="{jtype}"><parent link="{parent}"/><child link="{child}"/>'
            f'<origin xyz="{xyz}" rpy="{rpy}"/><axis xyz="{axis}"/>'
            '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
        )
    return "".join(parts) + "</robot>"


# The course arm's first two joints below a fixed mount (shared/reference/course_arm.md).
CHAIN = robot(
    "chain",
    ["base_link", "arm_base", "bicep"],
    [
        ("mount_joint", "fixed", "base_link", "arm_base", "0 0 0.1", "0 0 0", "1 0 0"),
        ("shoulder_joint", "revolute", "arm_base", "bicep", "-0.05166 0 0.20271", "0 0 1.5708", "0 1 0"),
    ],
)

# A torso with a long left arm, a head with a camera and a prismatic right arm.
BRANCHING = robot(
    "branching",
    ["torso", "left_upper_arm", "left_forearm", "left_hand", "head", "camera", "right_slider"],
    [
        ("left_shoulder", "revolute", "torso", "left_upper_arm", "0 0.2 0.4", "0 0 0", "0 1 0"),
        ("left_elbow", "continuous", "left_upper_arm", "left_forearm", "0 0 -0.3", "0 0 0", "0 1 0"),
        ("left_wrist", "revolute", "left_forearm", "left_hand", "0 0 -0.25", "0 0 0", "1 0 0"),
        ("neck", "revolute", "torso", "head", "0 0 0.5", "0 0 0", "0 0 1"),
        ("camera_mount", "fixed", "head", "camera", "0.1 0 0.05", "0 1.5708 0", "1 0 0"),
        ("right_rail", "prismatic", "torso", "right_slider", "0 -0.2 0.4", "0 0 0", "0 0 -1"),
    ],
)


@pytest.fixture(scope="module")
def ur5_path() -> Path:
    return Path(metadata.distribution("example-robot-data").locate_file(UR5_FILE))


@pytest.fixture(scope="module")
def ur5(ur5_path) -> yourdfpy.URDF:
    return yourdfpy.URDF.load(
        str(ur5_path),
        build_scene_graph=False,
        load_meshes=False,
        build_collision_scene_graph=False,
        load_collision_meshes=False,
    )


@pytest.fixture(scope="module")
def ur5_xml(ur5_path):
    """Links and joints of the UR5 as written in the file (robot-level tags only)."""
    root = ET.parse(ur5_path).getroot()
    links = [e.get("name") for e in root.findall("link")]
    joints = []
    for e in root.findall("joint"):
        origin = e.find("origin")
        joints.append(
            dict(
                name=e.get("name"),
                type=e.get("type"),
                parent=e.find("parent").get("link"),
                child=e.find("child").get("link"),
                xyz=[float(v) for v in origin.get("xyz").split()],
                rpy=[float(v) for v in origin.get("rpy").split()],
            )
        )
    return links, joints


# --------------------------------------------------------------------------
# A small DOT reader for the statements tree_dot writes
# --------------------------------------------------------------------------

_QUOTED = r'"((?:[^"\\]|\\.)*)"'


def _unescape(text: str) -> str:
    return re.sub(r"\\(.)", lambda m: "\n" if m.group(1) == "n" else m.group(1), text)


def parse_dot(dot: str):
    """(nodes {id: {attr: value}}, edges [(tail, head)]) of a flat digraph."""
    lines = dot.strip().splitlines()
    assert re.fullmatch(r"digraph " + _QUOTED + r" \{", lines[0]), lines[0]
    assert lines[-1] == "}"
    nodes, edges = {}, []
    for line in lines[1:-1]:
        line = line.strip()
        if edge := re.fullmatch(_QUOTED + r" -> " + _QUOTED + ";", line):
            edges.append((_unescape(edge.group(1)), _unescape(edge.group(2))))
        elif node := re.fullmatch(_QUOTED + r" \[(.*)\];", line):
            attrs = dict(
                (key, _unescape(quoted) if quoted or bare == "" else bare)
                for key, quoted, bare in re.findall(r"(\w+)=(?:" + _QUOTED + r"|([^,\s]+))", node.group(2))
            )
            nodes[_unescape(node.group(1))] = attrs
        else:
            assert re.fullmatch(r"(graph|node|edge) \[.*\];", line), f"unexpected DOT line: {line}"
    return nodes, edges


# --------------------------------------------------------------------------
# Text
# --------------------------------------------------------------------------


def test_text_of_a_chain_reads_like_check_urdf():
    assert tree.tree_text(load(CHAIN)) == (
        "robot name is: chain\n"
        "root Link: base_link has 1 child(ren)\n"
        "base_link\n"
        "└── mount_joint (fixed) ── arm_base\n"
        "    └── shoulder_joint (revolute, axis 0 1 0) ── bicep\n"
        "3 links, 2 joints: 1 revolute, 1 fixed\n"
    )


def test_text_branches_in_file_order_with_box_drawing():
    assert tree.tree_text(load(BRANCHING)) == (
        "robot name is: branching\n"
        "root Link: torso has 3 child(ren)\n"
        "torso\n"
        "├── left_shoulder (revolute, axis 0 1 0) ── left_upper_arm\n"
        "│   └── left_elbow (continuous, axis 0 1 0) ── left_forearm\n"
        "│       └── left_wrist (revolute, axis 1 0 0) ── left_hand\n"
        "├── neck (revolute, axis 0 0 1) ── head\n"
        "│   └── camera_mount (fixed) ── camera\n"
        "└── right_rail (prismatic, axis 0 0 -1) ── right_slider\n"
        "7 links, 6 joints: 3 revolute, 1 continuous, 1 prismatic, 1 fixed\n"
    )


def test_text_names_every_ur5_link_and_joint_with_its_type(ur5, ur5_xml):
    links, joints = ur5_xml
    text = tree.tree_text(ur5)
    edge_lines = [line for line in text.splitlines() if " ── " in line]
    assert len(edge_lines) == len(joints)
    for joint in joints:
        (line,) = [edge for edge in edge_lines if f" {joint['name']} (" in edge]
        assert f"{joint['name']} ({joint['type']}" in line
        assert line.endswith(f" ── {joint['child']}")
    shown = {line.split(" ── ")[-1] for line in edge_lines} | {text.splitlines()[2]}
    assert shown == set(links)


def test_text_states_the_ur5_root_and_its_child_count(ur5, ur5_xml):
    _, joints = ur5_xml
    (root,) = {j["parent"] for j in joints} - {j["child"] for j in joints}
    n_children = sum(j["parent"] == root for j in joints)
    lines = tree.tree_text(ur5).splitlines()
    assert lines[:3] == ["robot name is: ur5", f"root Link: {root} has {n_children} child(ren)", root]


def test_text_ends_with_ur5_link_and_joint_counts_by_type(ur5, ur5_xml):
    links, joints = ur5_xml
    types = Counter(j["type"] for j in joints)
    assert tree.tree_text(ur5).splitlines()[-1] == (
        f"{len(links)} links, {len(joints)} joints: {types['revolute']} revolute, {types['fixed']} fixed"
    )


def test_text_shows_axis_for_movable_joints_only(ur5):
    for line in tree.tree_text(ur5).splitlines():
        if "(fixed" in line:
            assert "axis" not in line
        elif "(revolute" in line:
            assert re.search(r"\(revolute, axis -?\d -?\d -?\d\)", line)


def test_text_names_every_root_when_there_are_several():
    two = robot(
        "two",
        ["a", "a_child", "b"],
        [("ja", "fixed", "a", "a_child", "0 0 0", "0 0 0", "1 0 0")],
    )
    lines = tree.tree_text(load(two)).splitlines()
    assert "warning: 2 root links (a, b); a URDF tree has exactly one root" in lines
    assert "root Link: a has 1 child(ren)" in lines
    assert "root Link: b has 0 child(ren)" in lines


def test_text_shows_a_joint_cycle_once_and_warns():
    cyclic = robot(
        "cyclic",
        ["base", "p", "q"],
        [
            ("p_to_q", "revolute", "p", "q", "0 0 0", "0 0 0", "0 0 1"),
            ("q_to_p", "revolute", "q", "p", "0 0 0", "0 0 0", "0 0 1"),
        ],
    )
    text = tree.tree_text(load(cyclic))
    assert "warning: links no root link reaches (a joint cycle?): p, q" in text
    assert "root Link: base has 0 child(ren)" in text
    assert "detached Link: p has 1 child(ren)" in text
    assert "q_to_p (revolute, axis 0 0 1) ── p (already shown)" in text


def test_text_warns_about_a_link_with_two_parents():
    two_parents = robot(
        "two_parents",
        ["base", "left", "right", "tip"],
        [
            ("to_left", "fixed", "base", "left", "0 0 0", "0 0 0", "1 0 0"),
            ("to_right", "fixed", "base", "right", "0 0 0", "0 0 0", "1 0 0"),
            ("left_tip", "fixed", "left", "tip", "0 0 0", "0 0 0", "1 0 0"),
            ("right_tip", "fixed", "right", "tip", "0 0 0", "0 0 0", "1 0 0"),
        ],
    )
    text = tree.tree_text(load(two_parents))
    assert "warning: link 'tip' is the child of 2 joints (left_tip, right_tip); a tree allows one" in text
    assert text.count("── tip\n") == 1
    assert "right_tip (fixed) ── tip (already shown)" in text


def test_text_warns_about_a_joint_from_a_link_to_itself():
    text = tree.tree_text(load(robot("loop", ["base"], [("spin", "fixed", "base", "base", "0 0 0", "0 0 0", "1 0 0")])))
    assert "warning: joint 'spin' connects link 'base' to itself" in text
    assert "spin (fixed) ── base (already shown)" in text


def test_text_warns_about_a_joint_naming_an_undeclared_link():
    text = tree.tree_text(
        load(robot("ghost", ["base"], [("to_ghost", "fixed", "base", "ghost", "0 0 0", "0 0 0", "1 0 0")]))
    )
    assert "warning: joint 'to_ghost' names child link 'ghost', which is not declared" in text
    assert "to_ghost (fixed) ── ghost" in text


def test_text_of_a_description_without_links_says_so():
    text = tree.tree_text(load('<robot name="empty"></robot>'))
    assert text.splitlines() == [
        "robot name is: empty",
        "warning: the description declares no links",
        "0 links, 0 joints",
    ]


# --------------------------------------------------------------------------
# DOT
# --------------------------------------------------------------------------


def test_dot_has_a_box_per_link_and_an_ellipse_per_joint(ur5, ur5_xml):
    links, joints = ur5_xml
    nodes, _ = parse_dot(tree.tree_dot(ur5))
    boxes = {nid for nid, attrs in nodes.items() if attrs["shape"] == "box"}
    ellipses = {nid for nid, attrs in nodes.items() if attrs["shape"] == "ellipse"}
    assert boxes == {f"link:{name}" for name in links}
    assert ellipses == {f"joint:{j['name']}" for j in joints}
    assert len(nodes) == len(links) + len(joints)


def test_dot_edges_run_parent_link_to_joint_to_child_link(ur5, ur5_xml):
    _, joints = ur5_xml
    _, edges = parse_dot(tree.tree_dot(ur5))
    assert len(edges) == 2 * len(joints)
    expected = set()
    for j in joints:
        expected |= {(f"link:{j['parent']}", f"joint:{j['name']}"), (f"joint:{j['name']}", f"link:{j['child']}")}
    assert set(edges) == expected


def test_dot_joint_labels_show_the_file_origins(ur5, ur5_xml):
    _, joints = ur5_xml
    nodes, _ = parse_dot(tree.tree_dot(ur5))
    for j in joints:
        label = nodes[f"joint:{j['name']}"]["label"].split("\n")
        assert label[0] == j["name"]
        assert label[1].split(",")[0] == j["type"]
        (xyz_line,) = [line for line in label if line.startswith("xyz ")]
        (rpy_line,) = [line for line in label if line.startswith("rpy ")]
        assert [float(v) for v in xyz_line.split()[1:]] == pytest.approx(j["xyz"], abs=1e-6)
        # Same angles up to whole turns: the file writes -3.14159265359, a hair past -pi.
        for printed, written in zip(map(float, rpy_line.split()[1:]), j["rpy"]):
            assert math.remainder(printed - written, 2 * math.pi) == pytest.approx(0, abs=1e-6)


def test_dot_joint_labels_show_axis_of_movable_joints(ur5):
    nodes, _ = parse_dot(tree.tree_dot(ur5))
    assert nodes["joint:shoulder_pan_joint"]["label"].split("\n")[1] == "revolute, axis 0 0 1"
    assert nodes["joint:ee_fixed_joint"]["label"].split("\n")[1] == "fixed"


def test_dot_prints_a_pitch_past_ninety_degrees_as_written():
    nodes, _ = parse_dot(tree.tree_dot(load(BRANCHING)))
    # The file says rpy="0 1.5708 0"; 1.5708 > pi/2, so the rpy with pitch in
    # [-pi/2, pi/2] would be (pi, pi - 1.5708, pi) = "3.141593 1.570793 3.141593".
    assert "rpy 0 1.5708 0" in nodes["joint:camera_mount"]["label"].split("\n")
    assert "xyz 0.1 0 0.05" in nodes["joint:camera_mount"]["label"].split("\n")


def test_dot_quotes_names_with_quotes_and_backslashes():
    odd = (
        '<robot name="odd &quot;bot&quot;"><link name="base"/><link name="say &quot;hi&quot; \\o/"/>'
        '<joint name="j &quot;1&quot;" type="fixed"><parent link="base"/>'
        '<child link="say &quot;hi&quot; \\o/"/></joint></robot>'
    )
    dot = tree.tree_dot(load(odd))
    nodes, edges = parse_dot(dot)
    assert dot.startswith('digraph "odd \\"bot\\"" {')
    assert nodes['link:say "hi" \\o/']["label"] == 'say "hi" \\o/'
    assert nodes['joint:j "1"']["label"].split("\n")[0] == 'j "1"'
    assert edges == [("link:base", 'joint:j "1"'), ('joint:j "1"', 'link:say "hi" \\o/')]


def test_dot_keeps_link_and_joint_of_the_same_name_apart():
    same = robot("same", ["base", "arm"], [("arm", "revolute", "base", "arm", "0 0 0", "0 0 0", "0 0 1")])
    nodes, edges = parse_dot(tree.tree_dot(load(same)))
    assert nodes["link:arm"]["shape"] == "box"
    assert nodes["joint:arm"]["shape"] == "ellipse"
    assert edges == [("link:base", "joint:arm"), ("joint:arm", "link:arm")]


def test_dot_draws_an_undeclared_link_dashed():
    ghost = robot("ghost", ["base"], [("to_ghost", "fixed", "base", "ghost", "0 0 0", "0 0 0", "1 0 0")])
    nodes, edges = parse_dot(tree.tree_dot(load(ghost)))
    assert nodes["link:ghost"]["style"] == "dashed"
    assert len(edges) == 2


# --------------------------------------------------------------------------
# Layout
# --------------------------------------------------------------------------


def _edges(urdf):
    return [(j.parent, j.child) for j in urdf.robot.joints]


def _layout(urdf):
    """(centre of each link's box, width of its column), as write_tree_image computes them."""
    analysed = tree._analyse(urdf)
    widths = tree._widths(analysed)
    return tree._layout_tree(analysed, widths), widths


def _assert_tidy(urdf):
    position, widths = _layout(urdf)
    assert set(position) == {link.name for link in urdf.robot.links}
    for parent, child in _edges(urdf):
        assert position[parent][1] > position[child][1], (parent, child)
    levels = defaultdict(list)
    for link, (x, y) in position.items():
        levels[y].append((x, link))
    for row in levels.values():
        row.sort()
        for (xa, a), (xb, b) in zip(row, row[1:]):
            assert xb - xa >= (widths[a] + widths[b]) / 2, (a, b)
    children = defaultdict(list)
    for parent, child in _edges(urdf):
        children[parent].append(child)
    for parent, kids in children.items():
        xs = [position[k][0] for k in kids]
        assert xs == sorted(xs), "children in file order, left to right"
        assert position[parent][0] == pytest.approx((xs[0] + xs[-1]) / 2)


def test_layout_of_the_ur5_is_tidy(ur5):
    _assert_tidy(ur5)


def test_layout_of_a_branching_tree_is_tidy():
    _assert_tidy(load(BRANCHING))


def test_layout_gives_each_level_one_height(ur5):
    position, _ = _layout(ur5)
    depth = {"world": 0}
    for parent, child in _edges(ur5) * len(position):  # enough passes for any order
        if parent in depth:
            depth[child] = depth[parent] + 1
    heights = {y for _, y in position.values()}
    assert len(heights) == max(depth.values()) + 1
    for link, (_, y) in position.items():
        assert y == pytest.approx(position["world"][1] - depth[link] * tree._LEVEL_H)


def test_layout_widths_hold_the_link_name_and_its_joint_label():
    urdf = load(BRANCHING)
    widths = tree._widths(tree._analyse(urdf))
    # "left_upper_arm" is 14 characters, its joint's longest line
    # "revolute, axis 0 1 0" is 20.
    assert widths["left_upper_arm"] == pytest.approx(20 * tree._CHAR_W + 2 * tree._PAD_X)
    assert widths["torso"] == pytest.approx(5 * tree._CHAR_W + 2 * tree._PAD_X)


def test_layout_packs_a_short_subtree_under_a_wide_neighbour():
    # The left subtree is narrow at the top and wide two levels down; the
    # right leaf may sit above that wide part, the right subtree's deep node
    # may not overlap it.
    urdf = load(
        robot(
            "packing",
            ["r", "a", "a1", "a2", "a1x", "a2x", "b", "b1", "b1x"],
            [
                ("ja", "fixed", "r", "a", "0 0 0", "0 0 0", "1 0 0"),
                ("ja1", "fixed", "a", "a1", "0 0 0", "0 0 0", "1 0 0"),
                ("ja2", "fixed", "a", "a2", "0 0 0", "0 0 0", "1 0 0"),
                ("ja1x", "fixed", "a1", "a1x", "0 0 0", "0 0 0", "1 0 0"),
                ("ja2x", "fixed", "a2", "a2x", "0 0 0", "0 0 0", "1 0 0"),
                ("jb", "fixed", "r", "b", "0 0 0", "0 0 0", "1 0 0"),
                ("jb1", "fixed", "b", "b1", "0 0 0", "0 0 0", "1 0 0"),
                ("jb1x", "fixed", "b1", "b1x", "0 0 0", "0 0 0", "1 0 0"),
            ],
        )
    )
    _assert_tidy(urdf)


def test_layout_puts_every_root_on_the_top_level_side_by_side():
    urdf = load(robot("two", ["a", "a_child", "b"], [("ja", "fixed", "a", "a_child", "0 0 0", "0 0 0", "1 0 0")]))
    position, widths = _layout(urdf)
    assert position["a"][1] == position["b"][1] > position["a_child"][1]
    assert position["b"][0] - position["a"][0] >= (widths["a"] + widths["b"]) / 2


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.tuples(st.integers(0, 10**6), st.integers(1, 30)), min_size=1, max_size=40),
)
def test_layout_of_random_trees_is_tidy(rows):
    # Link k hangs below a random earlier link; names of random length.
    links = [f"l{k}_" + "x" * length for k, (_, length) in enumerate(rows)]
    joints = [
        (f"j{k}", "fixed", links[parent % k], links[k], "0 0 0", "0 0 0", "1 0 0")
        for k, (parent, _) in enumerate(rows)
        if k > 0
    ]
    _assert_tidy(load(robot("random", links, joints)))


def test_layout_handles_a_chain_deeper_than_the_recursion_limit():
    n = sys.getrecursionlimit() + 10
    links = [f"l{k}" for k in range(n)]
    joints = [(f"j{k}", "fixed", links[k - 1], links[k], "0 0 0", "0 0 0", "1 0 0") for k in range(1, n)]
    position, _ = _layout(load(robot("deep", links, joints)))
    assert position[links[-1]][1] == pytest.approx(-(n - 1) * tree._LEVEL_H)


# --------------------------------------------------------------------------
# Image
# --------------------------------------------------------------------------


def _png_size(path: Path) -> tuple[int, int]:
    data = path.read_bytes()
    assert data[:8] == PNG_MAGIC
    assert data[12:16] == b"IHDR"
    return struct.unpack(">II", data[16:24])


def test_png_of_the_ur5_is_a_real_png(ur5, tmp_path):
    import matplotlib.image

    path = tree.write_tree_image(ur5, tmp_path / "ur5.png")
    assert path == tmp_path / "ur5.png"
    width, height = _png_size(path)
    assert width > 0 and height > 0
    assert matplotlib.image.imread(path).shape[:2] == (height, width)


def test_png_grows_with_the_width_and_depth_of_the_tree(ur5, tmp_path):
    chain_w, chain_h = _png_size(tree.write_tree_image(load(CHAIN), tmp_path / "chain.png"))
    ur5_w, ur5_h = _png_size(tree.write_tree_image(ur5, tmp_path / "ur5.png"))
    wide = robot(
        "wide",
        ["hub"] + [f"spoke_{k}" for k in range(12)],
        [(f"j{k}", "fixed", "hub", f"spoke_{k}", "0 0 0", "0 0 0", "1 0 0") for k in range(12)],
    )
    wide_w, wide_h = _png_size(tree.write_tree_image(load(wide), tmp_path / "wide.png"))
    assert ur5_h > 2 * chain_h  # 7 levels against 3
    assert wide_w > 2 * ur5_w  # 12 leaves side by side against at most 2
    assert wide_h < ur5_h


def test_svg_is_xml_with_an_svg_root_naming_every_link_and_joint(ur5, ur5_xml, tmp_path):
    links, joints = ur5_xml
    path = tree.write_tree_image(ur5, tmp_path / "ur5.svg")
    root = ET.parse(path).getroot()
    assert root.tag == "{http://www.w3.org/2000/svg}svg"
    texts = {"".join(e.itertext()).strip() for e in root.iter("{http://www.w3.org/2000/svg}text")}
    assert set(links) <= texts
    assert {j["name"] for j in joints} <= texts
    assert "xyz 0 -0.1197 0.425" in texts  # elbow_joint's origin


def test_image_format_argument_overrides_the_suffix(tmp_path):
    path = tree.write_tree_image(load(CHAIN), tmp_path / "tree.img", fmt="png")
    assert path.read_bytes()[:8] == PNG_MAGIC


def test_image_of_an_unknown_format_names_the_valid_ones(tmp_path):
    with pytest.raises(ValueError, match=r"'jpg'.*\.png or \.svg"):
        tree.write_tree_image(load(CHAIN), tmp_path / "tree.jpg")
    assert not (tmp_path / "tree.jpg").exists()


def test_image_draws_a_description_that_is_not_a_tree(tmp_path):
    broken = robot(
        "broken",
        ["a", "b", "p", "q"],
        [
            ("p_to_q", "revolute", "p", "q", "0 0 0", "0 0 0", "0 0 1"),
            ("q_to_p", "revolute", "q", "p", "0 0 0", "0 0 0", "0 0 1"),
            ("to_ghost", "fixed", "a", "ghost", "0 0 0", "0 0 0", "1 0 0"),
            ("spin", "fixed", "ghost", "ghost", "0 0 0", "0 0 0", "1 0 0"),
        ],
    )
    path = tree.write_tree_image(load(broken), tmp_path / "broken.svg")
    texts = {"".join(e.itertext()).strip() for e in ET.parse(path).getroot().iter("{http://www.w3.org/2000/svg}text")}
    assert {"a", "b", "p", "q", "ghost", "q_to_p (revolute)", "↺ spin (fixed)"} <= texts
    assert any(t.startswith("warning: 2 root links (a, b)") for t in texts)


def test_image_boxes_are_as_wide_as_their_monospace_text():
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    dpi = 720  # fine pixels: at 72 dpi, hinting rounds each advance to a whole pixel
    fig = Figure(dpi=dpi)
    renderer = FigureCanvasAgg(fig).get_renderer()
    line = "wrist_3_link-tool0_fixed_joint"
    for weight in ("normal", "bold"):
        text = fig.text(0, 0, line, fontsize=tree._FONT_PT, family="monospace", weight=weight)
        width = text.get_window_extent(renderer).width * 72 / dpi  # in points
        # DejaVu Sans Mono advances 1233/2048 em per character.
        assert width == pytest.approx(len(line) * tree._FONT_PT * 1233 / 2048, rel=0.02)
        assert width < tree._text_width(line)


def test_import_leaves_matplotlib_unloaded():
    src = Path(tree.__file__).resolve().parents[1]
    code = "import sys, manipkit.description.tree; print('matplotlib' in sys.modules)"
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, env={"PYTHONPATH": str(src)}
    )
    assert out.stdout.strip() == "False"


# --------------------------------------------------------------------------
# Names that mean something in DOT, HTML or mathtext (issue 15)
# --------------------------------------------------------------------------

HOSTILE = Path(__file__).parent / "bad_inputs" / "outputs" / "hostile_names.urdf"


def hostile_names():
    """(robot name, link names, joint names) of hostile_names.urdf, read with xml.etree (not yourdfpy)."""
    root = ET.parse(HOSTILE).getroot()
    return root.get("name"), [e.get("name") for e in root.findall("link")], [e.get("name") for e in root.findall("joint")]


def dot_tokens(dot: str) -> list[tuple[str, str]]:
    """DOT text as tokens, by Graphviz's lexer (lib/cgraph/scan.l): in a quoted string only ``\\"`` is an
    escape (and backslash-newline a continuation); every other character, backslashes included, is kept."""
    tokens, i = [], 0
    while i < len(dot):
        c = dot[i]
        if c.isspace():
            i += 1
        elif c == '"':
            j, text = i + 1, []
            while True:
                assert j < len(dot), f"unterminated string from offset {i}"
                if dot.startswith('\\"', j):
                    text.append('"')
                    j += 2
                elif dot.startswith("\\\n", j):
                    j += 2
                elif dot[j] == '"':
                    break
                else:
                    text.append(dot[j])
                    j += 1
            tokens.append(("id", "".join(text)))
            i = j + 1
        elif dot.startswith("->", i):
            tokens.append(("op", "->"))
            i += 2
        elif c in "{}[];,=":
            tokens.append(("op", c))
            i += 1
        else:
            bare = re.match(r"[A-Za-z_0-9.]+", dot[i:])
            assert bare, f"unexpected character {c!r} at offset {i}"
            tokens.append(("id", bare.group()))
            i += bare.end()
    return tokens


def read_dot(dot: str):
    """(graph name, graph attributes, nodes {id: attrs}, edges [(tail, head)]) by DOT's grammar for a flat digraph."""
    tokens = dot_tokens(dot)
    pos = 0

    def take(kind=None, value=None):
        nonlocal pos
        token = tokens[pos]
        assert (kind is None or token[0] == kind) and (value is None or token[1] == value), (token, pos)
        pos += 1
        return token[1]

    def attributes():
        attrs = {}
        take("op", "[")
        while tokens[pos] != ("op", "]"):
            key = take("id")
            take("op", "=")
            attrs[key] = take("id")
            if tokens[pos] == ("op", ","):
                take()
        take("op", "]")
        return attrs

    take("id", "digraph")
    name = take("id")
    take("op", "{")
    graph, nodes, edges = {}, {}, []
    while tokens[pos] != ("op", "}"):
        first = take("id")
        if tokens[pos] == ("op", "->"):
            take()
            edges.append((first, take("id")))
        elif first == "graph":
            graph.update(attributes())
        elif first in ("node", "edge"):
            attributes()
        else:
            assert first not in nodes, f"node {first!r} declared twice"
            nodes[first] = attributes()
        take("op", ";")
    take("op", "}")
    assert pos == len(tokens), "text after the graph"
    return name, graph, nodes, edges


def label_text(label: str, node: str = "", graph: str = "") -> str:
    """What Graphviz draws for a label (lib/common/labels.c): ``\\\\`` is a backslash; ``\\n``, ``\\l``, ``\\r``
    end a line; ``\\N`` and ``\\G`` are the node and graph names; HTML entities are decoded. Lines are joined by
    newlines (``\\r`` kept as a carriage return, so a name's own CR can be told from its newline)."""
    import html

    breaks = {"n": "\n", "l": "\n", "r": "\r", "N": node, "G": graph}
    text = re.sub(r"\\(.)", lambda m: "\\" if m.group(1) == "\\" else breaks.get(m.group(1), m.group(1)), label, flags=re.S)
    return html.unescape(text)


def test_dot_of_hostile_names_parses_and_every_name_survives():
    robot_name, links, joints = hostile_names()
    dot = tree.tree_dot(load(HOSTILE.read_text()))
    name, graph, nodes, edges = read_dot(dot)
    assert len(dot.strip().splitlines()) == 4 + len(links) + 3 * len(joints) + 1  # one statement a line
    assert label_text(graph["label"], graph=name).startswith(robot_name + ": 4 links, 3 joints")
    link_nodes = {label_text(attrs["label"], node, name): node for node, attrs in nodes.items() if attrs["shape"] == "box"}
    assert sorted(link_nodes) == sorted(links)
    joint_labels = [label_text(attrs["label"], node, name) for node, attrs in nodes.items() if attrs["shape"] == "ellipse"]
    assert [label.rsplit("\n", 3)[0] for label in joint_labels] == joints  # name, then type, xyz, rpy
    parents = {e.get("name"): (e.find("parent").get("link"), e.find("child").get("link"))
               for e in ET.parse(HOSTILE).getroot().findall("joint")}
    joint_nodes = {label.rsplit("\n", 3)[0]: node for label, node in
                   zip(joint_labels, [n for n, a in nodes.items() if a["shape"] == "ellipse"])}
    expected = [edge for joint, (parent, child) in parents.items()
                for edge in ((link_nodes[parent], joint_nodes[joint]), (joint_nodes[joint], link_nodes[child]))]
    assert edges == expected


def test_dot_label_writes_an_ampersand_as_an_entity_so_graphviz_shows_it_as_written():
    # Graphviz decodes entities in every label: a link called "a &amp; b" would be drawn "a & b".
    spelled = robot("amp", ["a &amp;amp; b", "c &lt; d"], [("j", "fixed", "a &amp;amp; b", "c &lt; d", "0 0 0", "0 0 0", "1 0 0")])
    _, _, nodes, _ = read_dot(tree.tree_dot(load(spelled)))
    assert nodes["link:a &amp; b"]["label"] == "a &amp;amp; b"
    assert label_text(nodes["link:a &amp; b"]["label"]) == "a &amp; b"
    assert label_text(nodes["link:c < d"]["label"]) == "c < d"


@pytest.mark.skipif(shutil.which("dot") is None, reason="Graphviz's dot is not installed (apt-get install graphviz)")
def test_graphviz_draws_hostile_names_as_written(tmp_path):
    _, links, joints = hostile_names()
    source = tmp_path / "tree.dot"
    source.write_text(tree.tree_dot(load(HOSTILE.read_text())))
    svg = subprocess.run(["dot", "-Tsvg", str(source)], capture_output=True, text=True, check=True, timeout=60).stdout
    ns = "{http://www.w3.org/2000/svg}"
    drawn = []
    for group in ET.fromstring(svg).iter(f"{ns}g"):
        if group.get("class") == "node":
            drawn.append([text.text or "" for text in group.iter(f"{ns}text")])
    # Graphviz draws one <text> per line; a line break inside a name (LF or CR) starts a new one.
    assert sorted(lines for lines in drawn if len(lines) <= 3) == sorted(re.split("[\r\n]", link) for link in links)
    assert [lines[:-3] for lines in drawn if len(lines) > 3] == [re.split("[\r\n]", joint) for joint in joints]


def test_text_tree_shows_line_breaks_in_names_as_escapes():
    robot_name, links, _ = hostile_names()
    text = tree.tree_text(load(HOSTILE.read_text()))
    assert text.splitlines()[0] == f"robot name is: {robot_name}"
    assert len(text.splitlines()) == 1 + 1 + 1 + 3 + 1  # name, root line, root, one line per joint, summary
    assert 'say "hi" \\o/ <b>x</b> &amp; \\N\\l\\ntwo\\rthree' in text


@pytest.mark.parametrize("suffix", ["png", "svg"])
def test_image_draws_hostile_names_as_plain_text(tmp_path, suffix):
    # "tool$\frac{1}{$" once failed inside matplotlib's mathtext parser (an internal error)
    _, links, joints = hostile_names()
    path = tree.write_tree_image(load(HOSTILE.read_text()), tmp_path / f"hostile.{suffix}")
    if suffix == "png":
        assert path.read_bytes()[:8] == PNG_MAGIC
        return
    texts = {"".join(e.itertext()) for e in ET.parse(path).getroot().iter("{http://www.w3.org/2000/svg}text")}
    shown = {name.replace("\n", "\\n").replace("\r", "\\r") for name in links + joints}
    assert shown <= texts


def test_image_into_a_missing_folder_is_an_output_error_and_creates_nothing(tmp_path):
    target = tmp_path / "no_such_folder" / "tree.png"
    with pytest.raises(OutputError) as caught:
        tree.write_tree_image(load(CHAIN), target)
    assert str(caught.value) == f"cannot write {target}: no such folder {target.parent}"
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("suffix", ["png", "svg"])
def test_image_onto_a_full_disk_is_an_output_error(tmp_path, suffix):
    # /dev/full: every write fails with ENOSPC, as on a full disk (a device is written in place; a symbolic
    # link at the output path would be replaced, not followed: manipkit.outputs)
    with pytest.raises(OutputError) as caught:
        tree.write_tree_image(load(CHAIN), "/dev/full", fmt=suffix)
    assert str(caught.value) == "cannot write /dev/full: No space left on device"
