"""SRDF files: MoveIt's semantic description of a robot, and the one a loaded robot ships.

An SRDF (``<robot name="...">``) names, for the URDF robot of the same
name, the pairs of links a collision check may skip
(``<disable_collisions link1= link2= reason=/>``, MoveIt's reasons
``Adjacent``, ``Default``, ``Always``, ``Never``, ``User``), the planning
groups (``<group>`` with a ``<chain base_link= tip_link=/>``) and the end
effectors (``<end_effector parent_link=/>``). :func:`read_srdf_file` reads
one (bounded in size, entity declarations refused, names quoted with a
bounded prefix in messages); :func:`shipped_srdf` finds the one a robot's
description ships, looking in this order (the first place with a match wins):

1. the description's own folder tree
   (:func:`manipkit.description.access.description_tree`), ``*.srdf`` files
   at most :data:`MAX_SRDF_DEPTH` folders down;
2. the MoveIt configuration packages of the workspace around the file
   (every package whose ``<name>`` ends in ``moveit_config``, as the MoveIt
   Setup Assistant names them: ``khi_rs007n_moveit_config``,
   ``tm5-900-moveit_config``), those whose name holds the robot's name first;
3. example-robot-data's ``srdf/`` folder beside a description it ships.

A file matches when its ``<robot name>`` is the URDF's ``<robot name>`` and
every link it names is a link of the robot (a file for another variant is
passed over, and the reason kept as a note). Of several matches in one
place, a file named after the robot (``ur5.srdf`` for ``ur5``) comes first,
then by path. At most :data:`MAX_SRDF_CANDIDATES` files are read.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from manipkit.errors import CollisionError, InputFileError
from manipkit.memo import keep
from manipkit.text import close_matches, printable, quoted_name, repr_text

__all__ = ["MAX_SRDF_BYTES", "MAX_SRDF_CANDIDATES", "MAX_SRDF_DEPTH", "Srdf", "check_srdf_links", "parse_srdf",
           "read_srdf_file", "shipped_srdf"]

#: Largest SRDF file read (bytes); real ones are a few kB (the PR2's is 60 kB).
MAX_SRDF_BYTES = 16 * 1024 * 1024
#: Most SRDF files :func:`shipped_srdf` reads for one robot.
MAX_SRDF_CANDIDATES = 50
#: How many folders below a description's tree (or a MoveIt package) :func:`shipped_srdf` looks for ``*.srdf``.
MAX_SRDF_DEPTH = 4
#: Characters of a name quoted in a message (a 10 MB link name is cut to this).
QUOTE_CHARS = 60


@dataclass(frozen=True)
class Srdf:
    """What manipkit reads from an SRDF file (picklable, immutable).

    Attributes
    ----------
    path : Path
        The file.
    robot : str
        Its ``<robot name>``.
    disabled : tuple of (str, str, str)
        ``<disable_collisions>``: (link1, link2, reason), the link names sorted, in file order.
    tips : tuple of str
        The links an arm's tool frame is declared at: every ``<end_effector parent_link>``, then every
        group's ``<chain tip_link>``, in file order, each once.
    end_effectors : int
        How many of ``tips`` (the first ones) are ``<end_effector parent_link>``.
    kind : str
        ``"srdf"`` (an SRDF file), or ``"mjcf"``: the pairs an MJCF file's contact rules exclude
        (:func:`manipkit.description.mjcf.mjcf_rules`; ``path`` is the MJCF file, ``tips`` empty).
    """

    path: Path
    robot: str
    disabled: tuple[tuple[str, str, str], ...]
    tips: tuple[str, ...]
    end_effectors: int = 0
    kind: str = "srdf"

    def pairs(self) -> dict[tuple[str, str], str]:
        """The disabled pairs: (link1, link2) sorted -> reason."""
        return {(a, b): reason for a, b, reason in self.disabled}

    def links(self) -> set[str]:
        """Every link the file names (disabled pairs and tips)."""
        return {name for a, b, _ in self.disabled for name in (a, b)} | set(self.tips)


def parse_srdf(text: str, where: str) -> Srdf:
    """The :class:`Srdf` of SRDF ``text`` (``where``: the file, for messages and :attr:`Srdf.path`).

    Raises
    ------
    CollisionError
        Entity declarations (an SRDF has none; MoveIt does not expand them), not XML, a root other than
        ``<robot>``, a ``<disable_collisions>`` without ``link1``/``link2``.

    Examples
    --------
    >>> s = parse_srdf('<robot name="arm"><disable_collisions link1="b" link2="a" reason="Never"/>'
    ...                '<group name="g"><chain base_link="a" tip_link="tool0"/></group></robot>', "arm.srdf")
    >>> s.robot, s.disabled, s.tips
    ('arm', (('a', 'b', 'Never'),), ('tool0',))
    """
    shown = printable(where)
    if "<!ENTITY" in text or "<!DOCTYPE" in text:
        line = text[: min(i for i in (text.find("<!DOCTYPE"), text.find("<!ENTITY")) if i >= 0)].count("\n") + 1
        raise CollisionError(f"{shown}:{line}: <!DOCTYPE>/<!ENTITY> declarations: an SRDF has none (MoveIt does "
                             "not expand them); remove them")
    import xml.etree.ElementTree as ET  # here, not at the top: only a robot that ships an SRDF parses one

    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise CollisionError(f"{shown}: not a valid SRDF (XML): {exc}; an SRDF is <robot> with "
                             "<disable_collisions link1=... link2=... reason=.../> elements") from None
    if root.tag != "robot":
        raise CollisionError(f"{shown}: the root element is <{repr_text(root.tag, QUOTE_CHARS)[1:-1]}>; an SRDF's "
                             "is <robot>")
    disabled = []
    for number, element in enumerate(root.iter("disable_collisions"), 1):
        a, b = element.get("link1"), element.get("link2")
        if a is None or b is None:
            raise CollisionError(f"{shown}: <disable_collisions> number {number} needs both link1 and link2")
        a, b = (a, b) if a <= b else (b, a)
        disabled.append((a, b, element.get("reason") or "User"))
    ends = tuple(dict.fromkeys(e.get("parent_link") for e in root.iter("end_effector") if e.get("parent_link")))
    chains = [chain.get("tip_link") for group in root.iter("group") for chain in group.iter("chain")]
    tips = ends + tuple(t for t in dict.fromkeys(chains) if t and t not in ends)
    return Srdf(Path(where), root.get("name") or "", tuple(disabled), tips, len(ends))


def read_srdf_file(path: str | os.PathLike) -> Srdf:
    """:func:`parse_srdf` of a file, read through :func:`manipkit.inputs.read_text` (at most :data:`MAX_SRDF_BYTES`).

    Raises
    ------
    InputFileError
        Missing, a folder or device, too large, not UTF-8.
    CollisionError
        As :func:`parse_srdf`.
    """
    import hashlib

    from manipkit.inputs.files import read_text

    # A robot's load looks for its SRDF among every SRDF beside it (example-robot-data ships 38): each text is
    # parsed once a process (a Srdf is immutable); the file is read each time, so a changed file is parsed again.
    text = read_text(path, what="SRDF file", max_bytes=MAX_SRDF_BYTES)
    key = (os.fspath(path), hashlib.sha256(text.encode("utf-8", "surrogatepass")).digest())
    parsed = _PARSED.get(key)
    return parsed if parsed is not None else keep(_PARSED, key, parse_srdf(text, str(path)), limit=_KEPT_SRDF)


#: SRDF texts parsed in this process: (path as given, SHA-256 of the text) -> Srdf, at most _KEPT_SRDF (the oldest
#: go).
_PARSED: dict[tuple, Srdf] = {}
_KEPT_SRDF = 512


def check_srdf_links(srdf: Srdf, links, robot: str) -> None:
    """Nothing if every link ``srdf`` names is in ``links``, else :class:`CollisionError` naming the first
    unknown one (quoted, at most :data:`QUOTE_CHARS` characters), the closest link names and the robot."""
    known = set(links)
    element = "<disable_collisions>" if srdf.kind == "srdf" else "the pair its contact rules disable,"
    for number, (a, b, _) in enumerate(srdf.disabled, 1):
        for name in (a, b):
            if name not in known:
                raise CollisionError(f"{printable(str(srdf.path))}: {element} number {number} names link "
                                     f"{_quoted(name)}, which robot '{printable(robot)}' does not have; "
                                     f"{_close(name, known)}(is this {'SRDF' if srdf.kind == 'srdf' else 'file'} "
                                     "for another robot?)")
    for name in srdf.tips:
        if name not in known:
            raise CollisionError(f"{printable(str(srdf.path))}: a group or end effector names link {_quoted(name)}, "
                                 f"which robot '{printable(robot)}' does not have; {_close(name, known)}"
                                 "(is this SRDF for another robot?)")


def _quoted(name: str) -> str:
    return quoted_name(name, QUOTE_CHARS)


def _close(name: str, known: set[str]) -> str:
    close = close_matches(name, sorted(known), n=3, cutoff=0.5)
    return f"did you mean {', '.join(close)}? " if close else ""


def shipped_srdf(description: str | os.PathLike, robot: str, links, resolver=None) -> tuple[Srdf | None, tuple]:
    """The SRDF the description ``description`` of robot ``robot`` ships (module docstring), and notes.

    Parameters
    ----------
    description : path-like
        The top-level description file (a name that is not a file: nothing is found).
    robot : str
        The URDF's ``<robot name>``.
    links : iterable of str
        The robot's links: a file naming another link is passed over.
    resolver : PackageResolver, optional
        For the workspace around the file (default: one made for ``description``).

    Returns
    -------
    (Srdf or None, tuple of str)
        The file found (None: none), and one note per file for this robot (its ``<robot name>``) passed
        over because it names a link the robot does not have (files that cannot be read are passed over
        silently: whose they are cannot be told).
    """
    path = Path(description)
    if not path.is_file():
        return None, ()
    known, notes, read = set(links), [], [0]
    for place in _places(path, robot, resolver):
        matches = []
        for candidate in place:
            if read[0] >= MAX_SRDF_CANDIDATES:
                break
            read[0] += 1
            try:
                srdf = read_srdf_file(candidate)
            except (CollisionError, InputFileError):
                continue  # not an SRDF manipkit reads: not this robot's, as far as can be told
            if srdf.robot != robot:
                continue
            try:
                check_srdf_links(srdf, known, robot)
            except CollisionError as exc:
                notes.append(str(exc))
                continue
            matches.append(srdf)
        if matches:
            matches.sort(key=lambda s: (s.path.name.removesuffix(".srdf") != robot, str(s.path)))
            return matches[0], tuple(notes)
    return None, tuple(notes)


def _places(path: Path, robot: str, resolver):
    """The candidate files of each place, in the order of the module docstring (each a list of paths)."""
    from manipkit.description.access import description_tree
    from manipkit.description.sources import example_robot_data_dir

    tree = description_tree(path)
    yield _srdf_files(tree)
    if resolver is None:
        from manipkit.description.packages import PackageResolver

        resolver = PackageResolver(near=path)
    workspace = resolver.workspace()
    if workspace is not None:
        from manipkit.description.packages import package_index

        packages = sorted(((name, folder) for name, folders in package_index(workspace).items()
                           for folder in folders if name.replace("-", "_").endswith("moveit_config")),
                          key=lambda item: (robot.lower() not in item[0].lower(), item[0], str(item[1])))
        yield [file for _, folder in packages for file in _srdf_files(folder) if not _inside(file, tree)]
    erd = example_robot_data_dir()
    if erd is not None and _inside(path, erd / "robots"):
        robot_folder = erd / "robots" / Path(os.path.relpath(path.resolve(), (erd / "robots").resolve())).parts[0]
        yield sorted((robot_folder / "srdf").glob("*.srdf"))


def _inside(path: Path, folder: Path) -> bool:
    return Path(os.path.realpath(path)).is_relative_to(os.path.realpath(folder))


def _srdf_files(folder: Path) -> list[Path]:
    """``*.srdf`` files below ``folder``, at most :data:`MAX_SRDF_DEPTH` levels down, hidden folders skipped, sorted."""
    found: list[Path] = []
    stack = [(str(folder), 0)]
    visited = 0
    while stack and visited < 2000:
        current, depth = stack.pop()
        visited += 1
        try:
            with os.scandir(current) as listing:
                entries = sorted(listing, key=lambda entry: entry.name)
        except OSError:
            continue
        for entry in entries:
            try:
                if entry.name.endswith(".srdf") and entry.is_file():
                    found.append(Path(entry.path))
                elif depth < MAX_SRDF_DEPTH and not entry.name.startswith(".") and entry.is_dir(follow_symlinks=False):
                    stack.append((entry.path, depth + 1))
            except OSError:
                continue
    return sorted(found)[:MAX_SRDF_CANDIDATES]
