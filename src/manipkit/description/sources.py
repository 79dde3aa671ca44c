"""Where robot descriptions come from: names and paths to description files.

A robot is named in one of three ways:

- a bundled name (``course_arm``, ``iiwa14``, ...): ``robots/NAME.urdf.xacro``
  in this project;
- an example-robot-data name (``panda``, ``ur5``, ...): the URDF files that
  the PyPI distribution ``example-robot-data`` installs under
  ``cmeel.prefix/share/example-robot-data/robots/`` (it ships no Python
  loader, so they are found through ``importlib.metadata``);
- a path to a ``.urdf`` or ``.xacro`` file, or a MuJoCo MJCF ``.xml`` file
  (read through MuJoCo's compiler: :mod:`~manipkit.description.mjcf`).

:func:`resolve_robot` turns a name into a :class:`RobotSource`, and
:func:`resolve_dh_table` a DH table name into its file. The rest of the way to
URDF text is elsewhere in :mod:`manipkit.description`: ROS packages in
:mod:`~manipkit.description.packages`, xacro expansion in
:mod:`~manipkit.description.xacro`.

This module knows nothing about kinematics; :mod:`manipkit.kinematics.robot` builds the
Pinocchio model from the text of these files.
"""

from __future__ import annotations

import errno
import os
import stat
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

from manipkit.errors import UnknownRobotError
from manipkit.inputs import MAX_DESCRIPTION_BYTES, MAX_TABLE_BYTES, check_input_file
from manipkit.text import close_matches, repr_text

__all__ = [
    "DEFAULT_ROBOT",
    "EXAMPLE_ROBOT_DATA_ARMS",
    "RobotSource",
    "bundled_dh_tables",
    "bundled_dir",
    "bundled_robots",
    "example_robot_data_arms",
    "example_robot_data_dir",
    "example_robot_data_urdfs",
    "resolve_dh_table",
    "resolve_robot",
]

DEFAULT_ROBOT = "course_arm"
_SUFFIXES = (".urdf", ".xacro", ".xml")  # a description file by path: URDF, xacro, MJCF

#: example-robot-data arms known by a short name: file under the
#: distribution's ``robots/`` folder, and the frame used as ``ee_link``.
EXAMPLE_ROBOT_DATA_ARMS: dict[str, tuple[str, str]] = {
    "panda": ("panda_description/urdf/panda.urdf", "panda_hand_tcp"),
    "ur3": ("ur_description/urdf/ur3_robot.urdf", "tool0"),
    "ur5": ("ur_description/urdf/ur5_robot.urdf", "tool0"),
    "ur10": ("ur_description/urdf/ur10_robot.urdf", "tool0"),
    "kinova": ("kinova_description/robots/kinova.urdf", "j2s6s200_end_effector"),
    "z1": ("z1_description/urdf/z1.urdf", "link06"),
    "so_arm": ("so_arm_description/urdf/so101.urdf", "gripper_frame_link"),
    "so100": ("so_arm_description/urdf/so100.urdf", "gripper"),
    "so101": ("so_arm_description/urdf/so101.urdf", "gripper_frame_link"),
    "xarm7": ("xarm_description/urdf/xarm7.urdf", "link_eef"),
}


@dataclass(frozen=True)
class RobotSource:
    """A resolved robot description: where it is and how to read it.

    Attributes
    ----------
    name : str
        Short name (bundled or example-robot-data name, or the file stem).
    path : Path
        The ``.urdf``, ``.xacro`` or MJCF ``.xml`` file.
    origin : str
        ``"bundled"``, ``"example-robot-data"`` or ``"file"``.
    ee_frame : str or None
        The frame declared as end effector, if known.
    """

    name: str
    path: Path
    origin: str
    ee_frame: str | None = None

    @property
    def is_xacro(self) -> bool:
        return self.path.suffix == ".xacro"

    @property
    def is_mjcf(self) -> bool:
        """A ``.xml`` file: MuJoCo MJCF (compiled by MuJoCo; a ``<robot>`` root is read as URDF)."""
        return self.path.suffix == ".xml"


# --------------------------------------------------------------------------
# Where things live
# --------------------------------------------------------------------------


@lru_cache(maxsize=1)
def bundled_dir() -> Path:
    """The folder of bundled descriptions (``robots/`` of the source tree).

    In a source or editable install this is ``<repo>/robots``; an installed
    wheel carries a copy at ``manipkit/data/robots``.
    """
    package = Path(__file__).resolve().parents[1]  # src/manipkit (or site-packages/manipkit)
    for candidate in (package.parents[1] / "robots", package / "data" / "robots"):
        if candidate.is_dir():
            return candidate
    raise UnknownRobotError(
        f"bundled robots folder not found (looked in {package.parents[1] / 'robots'} "
        f"and {package / 'data' / 'robots'}); reinstall manipkit"
    )


def bundled_robots() -> dict[str, Path]:
    """Bundled robot names -> their top-level ``NAME.urdf.xacro`` file."""
    return {
        p.name[: -len(".urdf.xacro")]: p for p in sorted(bundled_dir().glob("*.urdf.xacro"))
    }


@lru_cache(maxsize=1)
def example_robot_data_dir() -> Path | None:
    """The ``share/example-robot-data`` folder of the installed distribution.

    This folder is also what ``package://example-robot-data/...`` means.
    Returns None when example-robot-data is not installed.

    The distribution's ``dist-info`` folder is looked for on ``sys.path``
    first, as :mod:`importlib.metadata` finds it (its files are located from
    the folder holding it); only where none is found is
    :mod:`importlib.metadata` itself asked (it costs about 50 ms to import, a
    fifth of ``tf-between``'s start).
    """
    import sys

    for entry in sys.path:
        try:
            found = sorted(Path(entry or ".").glob("example_robot_data-*.dist-info"))
        except OSError:
            continue
        if found:
            path = Path(entry or ".") / "cmeel.prefix" / "share" / "example-robot-data"
            return path if path.is_dir() else None
    from importlib import metadata

    try:
        dist = metadata.distribution("example-robot-data")
    except metadata.PackageNotFoundError:
        return None
    path = Path(dist.locate_file("cmeel.prefix/share/example-robot-data"))
    return path if path.is_dir() else None


def example_robot_data_urdfs() -> dict[str, Path]:
    """Every URDF file of example-robot-data by file stem (``ur5_robot``, ``talos_reduced``, ...)."""
    root = example_robot_data_dir()
    if root is None:
        return {}
    return {p.stem: p for p in sorted((root / "robots").glob("*/*/*.urdf"))}


def example_robot_data_arms() -> dict[str, RobotSource]:
    """The short-named arms of :data:`EXAMPLE_ROBOT_DATA_ARMS` that are installed."""
    root = example_robot_data_dir()
    if root is None:
        return {}
    arms = {}
    for name, (relative, ee_frame) in EXAMPLE_ROBOT_DATA_ARMS.items():
        path = root / "robots" / relative
        if path.is_file():
            arms[name] = RobotSource(name, path, "example-robot-data", ee_frame)
    return arms


# --------------------------------------------------------------------------
# Name -> description file
# --------------------------------------------------------------------------


def resolve_robot(spec: str | os.PathLike | None = None) -> RobotSource:
    """Find the description a robot name or path refers to.

    Parameters
    ----------
    spec : str or path-like, optional
        Bundled name, example-robot-data name (short arm name such as
        ``panda`` or any URDF file stem such as ``talos_reduced``), or a path
        to a ``.urdf`` / ``.xacro`` / MJCF ``.xml`` file. Defaults to :data:`DEFAULT_ROBOT`.

    Raises
    ------
    UnknownRobotError
        When nothing matches (the message lists the closest known names), the
        name is empty, or the path is a folder or not a .urdf/.xacro/.xml file; ``spec``
        is not a str or path, or holds a NUL byte.
    InputFileError
        The path is a FIFO, device or socket, a symlink loop, not readable,
        or larger than :data:`manipkit.inputs.MAX_DESCRIPTION_BYTES`: refused
        before anything reads it.
    """
    spec = DEFAULT_ROBOT if spec is None else spec
    if not isinstance(spec, (str, os.PathLike)) or not isinstance(os.fspath(spec), str):
        raise UnknownRobotError(f"robot: expected a name or a path (str or pathlib.Path), not "
                                f"{type(spec).__name__} {repr_text(spec)}")
    text = os.fspath(spec)
    if "\x00" in text:
        raise UnknownRobotError(f"robot: {repr_text(text)} holds a NUL byte (character {text.index(chr(0)) + 1}); "
                                "no name or path does")
    bundled = bundled_robots()
    if not text.strip():
        raise UnknownRobotError(
            f"the robot name is empty; give a bundled name ({', '.join(bundled)}), an example-robot-data name "
            "(see `manipkit robots`) or a path to a .urdf/.xacro/.xml (MJCF) file"
        )
    if text in bundled:
        return RobotSource(text, bundled[text], "bundled")
    arms = example_robot_data_arms()
    if text in arms:
        return arms[text]
    urdfs = example_robot_data_urdfs()
    if text in urdfs:
        return RobotSource(text, urdfs[text], "example-robot-data")

    path = Path(text).expanduser()
    looks_like_path = os.sep in text or path.suffix in _SUFFIXES
    mode = _file_mode(path, what="robot file", strict=looks_like_path)
    if mode is not None and stat.S_ISDIR(mode):
        raise UnknownRobotError(f"{text} is a folder; give a .urdf, .xacro or MJCF .xml file inside it")
    if mode is not None and stat.S_ISREG(mode) and path.suffix not in _SUFFIXES:
        raise UnknownRobotError(f"{text}: not a robot description; give a .urdf, .xacro or MJCF .xml file")
    if mode is not None:  # a regular file (size checked), or a FIFO, device or socket (refused)
        path = check_input_file(path, what="robot file", max_bytes=MAX_DESCRIPTION_BYTES)
        return RobotSource(path.name.split(".")[0], path.resolve(), "file")
    if looks_like_path:
        raise UnknownRobotError(f"robot file not found: {text}")

    known = list(bundled) + list(arms) + list(urdfs)
    close = close_matches(text, known, n=4, cutoff=0.5)
    hint = f"did you mean {', '.join(close)}? " if close else ""
    raise UnknownRobotError(
        f"unknown robot '{text}'; {hint}bundled: {', '.join(bundled)}; "
        f"example-robot-data: {', '.join(arms)} (see `manipkit robots`), or a path to a .urdf/.xacro/.xml (MJCF) file"
    )


def bundled_dh_tables() -> dict[str, Path]:
    """Bundled DH table names -> ``robots/dh/NAME.yaml``."""
    return {p.stem: p for p in sorted((bundled_dir() / "dh").glob("*.yaml"))}


def resolve_dh_table(spec: str | os.PathLike) -> Path:
    """A DH table file from a bundled table name (``iiwa14_seed004``) or a path.

    Raises
    ------
    UnknownRobotError
        When neither exists; the message lists the bundled tables.
    InputFileError
        The path is a folder, FIFO or device, a symlink loop, or larger than
        :data:`manipkit.inputs.MAX_TABLE_BYTES`.
    """
    text = os.fspath(spec)
    tables = bundled_dh_tables()
    if text in tables:
        return tables[text]
    path = Path(text).expanduser()
    if text.strip() and _file_mode(path, what="DH table", strict=True) is not None:
        return check_input_file(path, what="DH table", max_bytes=MAX_TABLE_BYTES)  # a folder, FIFO, huge file: refused
    close = close_matches(text, list(tables), n=3, cutoff=0.5)
    hint = f"did you mean {', '.join(close)}? " if close else ""
    raise UnknownRobotError(
        f"DH table not found: {text}; {hint}bundled tables: {', '.join(tables) or 'none'}, or a path to a .yaml file"
    )


def _file_mode(path: Path, *, what: str, strict: bool) -> int | None:
    """``st_mode`` of ``path`` (symlinks followed), or None when nothing is there.

    A symlink loop (and, when ``strict``, any other reason ``stat`` fails
    but a missing file: a name too long, a folder that cannot be searched)
    raises :class:`~manipkit.errors.InputFileError` naming the reason, rather
    than "not found". Nothing is opened: a FIFO is never read here.
    """
    try:
        return path.stat().st_mode
    except (FileNotFoundError, NotADirectoryError):
        return None
    except OSError as exc:
        if strict or exc.errno == errno.ELOOP:
            check_input_file(path, what=what)  # raises, naming the reason
        return None

