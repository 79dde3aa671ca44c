"""Which link ``ee_link`` means on a robot that has no link of that name: the arm's tool frame.

The rule, in order (the first that applies wins; :func:`choose_tool_frame`):

1. a link named ``ee_link`` (the bundled textbook arms: the name itself, not a choice);
2. the tip the SRDF the robot ships declares (:mod:`manipkit.description.srdf`):
   an ``<end_effector parent_link>``, else the group ``<chain tip_link>``
   farthest down the arm (Kinova's ``j2n6s300_end_effector``, not the wrist);
3. the end effector the robot's source declares (example-robot-data's);
4. a link named the way users name an arm's tool frame (:data:`TOOL_FRAME_NAMES`:
   ``tool0``, ``flange``, ``*_tcp``, ``*_hand_tcp``, ``end_effector_link``,
   ``*_end_effector``, ``*_ee_link``, ``link_eef``, ``*_tool_link``, ``*_tool_frame``,
   ``*_grasping_frame``, ``*_gripper_tip``, ``*_hand``; MuJoCo MJCF's tool sites
   ``pinch_site`` and ``attachment_site``): of several, the one
   farthest down the arm (most movable joints above it, then most links),
   so a gripper's TCP wins over the flange it hangs from; a tie is broken
   by the order of the list, then by name;
5. the last link before the tree splits into fingers: going up from the tip
   of the longest chain, the first link with two or more branches that hold
   movable joints, each of at most :data:`FINGER_JOINTS` joints and shorter
   than the arm above it (a gripper's palm, not a mobile base);
6. the tip of the longest chain.

A finger is never chosen by rule 4 or 5: on a real arm with a gripper the
tip of the longest chain is a finger (``panda_leftfinger``,
``l_gripper_finger_link``), which is the wrong answer to "where is my tool".
Every output that uses the choice names the link and the rule
(:attr:`Robot.ee_reason <manipkit.kinematics.robot.Robot>`).
"""

from __future__ import annotations

import re
from collections.abc import Sequence

__all__ = ["FINGER_JOINTS", "TOOL_FRAME_NAMES", "choose_tool_frame", "tool_frame_of"]

#: Link names of an arm's tool frame, as regular expressions on the name after its last ``/``
#: (Interbotix writes ``wx250s/ee_gripper_link``), in the order that breaks a tie.
TOOL_FRAME_NAMES = (
    r"(.*_)?hand_tcp", r"(.*_)?tcp", r"(.*_)?pinch_site", r"(.*_)?grasping_frame", r"(.*_)?gripper_tip",
    r"(.*_)?tool_frame", r"ee_gripper_link", r"tool0", r"(.*_)?tool_link", r"(.*_)?ee_link", r"end_effector_link",
    r"(.*_)?end_effector", r"(.*_)?link_eef", r"(.*_)?eef", r"(.*_)?flange", r"(.*_)?attachment_site", r"(.*_)?hand",
)
_PATTERNS = tuple(re.compile(pattern, re.IGNORECASE) for pattern in TOOL_FRAME_NAMES)
_SHOWN = "tool0, flange, *_tcp, *_tool_link, link_eef, ..."

#: Most movable joints a branch may hold and still count as a finger (a hand's finger has 3 or 4).
FINGER_JOINTS = 4


def choose_tool_frame(
    names: Sequence[str], parents: Sequence[int], movable: Sequence[bool], *, declared: str | None = None,
    source: str = "the description", srdf_tips: Sequence[str] = (), srdf_ends: int = 0, srdf: str = "the SRDF",
) -> tuple[str, str]:
    """(link name, the reason in words) of the link ``ee_link`` means, by the rule in the module docstring.

    Parameters
    ----------
    names : sequence of str
        The links, in an order where a parent comes before its children.
    parents : sequence of int
        Index of each link's parent link in ``names`` (-1 for the root).
    movable : sequence of bool
        Whether the joint from the parent to each link moves (False for the root and fixed joints).
    declared : str, optional
        The end effector the robot's source declares.
    srdf_tips : sequence of str, optional
        The tips the robot's SRDF (named ``srdf`` in the reason) declares: its first ``srdf_ends`` are
        ``<end_effector parent_link>``, the rest ``<chain tip_link>``.

    Examples
    --------
    >>> names = ["base", "link1", "flange", "tool0", "palm", "left_finger", "right_finger"]
    >>> choose_tool_frame(names, [-1, 0, 1, 2, 3, 4, 4], [False, True, True, False, False, True, True])
    ('tool0', 'tool0, named like an arm tool frame (tool0, flange, *_tcp, *_tool_link, link_eef, ...)')
    """
    if "ee_link" in names:
        return "ee_link", "the robot's ee_link"
    joints_above = [0] * len(names)
    links_above = [0] * len(names)
    for i, parent in enumerate(parents):
        if parent >= 0:
            joints_above[i] = joints_above[parent] + bool(movable[i])
            links_above[i] = links_above[parent] + 1

    def depth(i: int) -> tuple[int, int]:
        return joints_above[i], links_above[i]

    index = {name: i for i, name in enumerate(names)}
    ends = [tip for tip in srdf_tips[:srdf_ends] if tip in index]
    if ends:
        return ends[0], f"{ends[0]}, the end effector declared in {srdf}"
    chains = [tip for tip in srdf_tips[srdf_ends:] if tip in index]
    if chains:
        tip = max(chains, key=lambda name: depth(index[name]))
        return tip, f"{tip}, the planning group's tip declared in {srdf}"
    if declared and declared in names:
        return declared, f"{declared}, the end effector declared for {source}"

    named = []
    for i, name in enumerate(names):
        rank = next((k for k, pattern in enumerate(_PATTERNS) if pattern.fullmatch(name.rsplit("/", 1)[-1])), None)
        if rank is not None:
            named.append((depth(i), -rank, _reverse(name), i))
    if named:
        i = max(named)[3]
        others = [names[j] for *_, j in named if j != i and depth(j) == depth(i)]
        tie = f"; also {', '.join(sorted(others)[:3])} at the same depth (--tip chooses)" if others else ""
        return names[i], f"{names[i]}, named like an arm tool frame ({_SHOWN}){tie}"
    tip = max(range(len(names)), key=depth)
    palm = _finger_split(tip, parents, movable, joints_above)
    if palm is not None:
        return names[palm], f"{names[palm]}, the last link before the tree splits into fingers"
    return names[tip], f"{names[tip]}, the tip of the longest chain (no tool frame named)"


def _reverse(name: str) -> tuple[int, ...]:
    """A key that sorts names in reverse order under ``max`` (so the first name alphabetically wins a tie)."""
    return tuple(-ord(c) for c in name)


def _finger_split(tip: int, parents: Sequence[int], movable: Sequence[bool], joints_above: Sequence[int]) -> int | None:
    """The first link up from ``tip`` whose branches with movable joints are two or more, each a finger."""
    n = len(parents)
    deepest = list(joints_above)  # most movable joints above any link in each link's subtree
    for i in range(n - 1, -1, -1):  # children come after their parents
        if parents[i] >= 0:
            deepest[parents[i]] = max(deepest[parents[i]], deepest[i])
    children: list[list[int]] = [[] for _ in range(n)]
    for i, parent in enumerate(parents):
        if parent >= 0:
            children[parent].append(i)
    link = parents[tip]
    while link >= 0:
        branches = [deepest[c] - joints_above[link] for c in children[link] if deepest[c] > joints_above[link]]
        if len(branches) >= 2:  # fingers: short branches at the end of a longer arm (not a base's wheels and arm)
            return link if max(branches) <= min(FINGER_JOINTS, joints_above[link] - 1) else None
        link = parents[link]
    return None


def tool_frame_of(model, frame_ids: dict[str, int], declared: str | None, source: str, *,
                  srdf=None) -> tuple[str, str]:
    """:func:`choose_tool_frame` on a Pinocchio model's link tree (``frame_ids``: link name -> its BODY frame),
    with the tips of ``srdf`` (a :class:`manipkit.description.srdf.Srdf`, or None)."""
    import pinocchio as pin

    frames = model.frames
    links = [i for i, f in enumerate(frames) if f.type == pin.FrameType.BODY and f.name != "universe"
             and frame_ids.get(f.name) == i]
    index = {frame_id: k for k, frame_id in enumerate(links)}
    parents, movable = [], []
    for frame_id in links:
        parent, moves = frames[frame_id].parentFrame, False
        while parent > 0 and parent not in index:  # up through the joint frame(s) to the parent link
            moves = moves or frames[parent].type == pin.FrameType.JOINT
            parent = frames[parent].parentFrame
        parents.append(index.get(parent, -1) if parent != frame_id else -1)
        movable.append(moves)
    tips, ends, where = (), 0, "the SRDF"
    if srdf is not None:
        tips, ends, where = srdf.tips, srdf.end_effectors, srdf.path.name
    return choose_tool_frame([frames[i].name for i in links], parents, movable, declared=declared, source=source,
                             srdf_tips=tips, srdf_ends=ends, srdf=where)
