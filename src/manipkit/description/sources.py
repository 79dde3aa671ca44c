"""Where robot descriptions come from, and how they become URDF text.

A robot is named in one of three ways:

- a bundled name (``course_arm``, ``iiwa14``, ...): ``robots/NAME.urdf.xacro``
  in this project;
- an example-robot-data name (``panda``, ``ur5``, ...): the URDF files that
  the PyPI distribution ``example-robot-data`` installs under
  ``cmeel.prefix/share/example-robot-data/robots/`` (it ships no Python
  loader, so they are found through ``importlib.metadata``);
- a path to a ``.urdf`` or ``.xacro`` file.

xacro files are expanded in-process with the ``xacro`` package. ROS is not
needed: ``$(find PKG)`` and ``package://PKG/...`` resolve through
:class:`PackageResolver` (explicit ``--package-dir NAME=DIR`` folders first,
then the bundled and example-robot-data packages, then the folders around the
description file, then ``ROS_PACKAGE_PATH``).

This module knows nothing about kinematics; :mod:`manipkit.kinematics.robot` builds the
Pinocchio model from the text returned here.
"""

from __future__ import annotations

import difflib
import os
import re
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import NamedTuple

from manipkit.errors import DescriptionError, PackageNotFoundError, UnknownRobotError

DEFAULT_ROBOT = "course_arm"

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
        The ``.urdf`` or ``.xacro`` file.
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
    """
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
        to a ``.urdf`` / ``.xacro`` file. Defaults to :data:`DEFAULT_ROBOT`.

    Raises
    ------
    UnknownRobotError
        When nothing matches; the message lists the closest known names.
    """
    spec = DEFAULT_ROBOT if spec is None else spec
    text = os.fspath(spec)
    bundled = bundled_robots()
    if text in bundled:
        return RobotSource(text, bundled[text], "bundled")
    arms = example_robot_data_arms()
    if text in arms:
        return arms[text]
    urdfs = example_robot_data_urdfs()
    if text in urdfs:
        return RobotSource(text, urdfs[text], "example-robot-data")

    path = Path(text).expanduser()
    looks_like_path = os.sep in text or path.suffix in (".urdf", ".xacro")
    if path.is_file():
        if path.suffix not in (".urdf", ".xacro"):
            raise UnknownRobotError(
                f"{text}: not a robot description; give a .urdf or .xacro file"
            )
        name = path.name.split(".")[0]
        return RobotSource(name, path.resolve(), "file")
    if path.is_dir():
        raise UnknownRobotError(f"{text} is a folder; give a .urdf or .xacro file inside it")
    if looks_like_path:
        raise UnknownRobotError(f"robot file not found: {text}")

    known = list(bundled) + list(arms) + list(urdfs)
    close = difflib.get_close_matches(text, known, n=4, cutoff=0.5)
    hint = f"did you mean {', '.join(close)}? " if close else ""
    raise UnknownRobotError(
        f"unknown robot '{text}'; {hint}bundled: {', '.join(bundled)}; "
        f"example-robot-data: {', '.join(arms)} (see `manipkit robots`), or a path to a .urdf/.xacro file"
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
    """
    text = os.fspath(spec)
    tables = bundled_dh_tables()
    if text in tables:
        return tables[text]
    path = Path(text).expanduser()
    if path.is_file():
        return path
    close = difflib.get_close_matches(text, list(tables), n=3, cutoff=0.5)
    hint = f"did you mean {', '.join(close)}? " if close else ""
    raise UnknownRobotError(
        f"DH table not found: {text}; {hint}bundled tables: {', '.join(tables) or 'none'}, or a path to a .yaml file"
    )


# --------------------------------------------------------------------------
# Packages: $(find PKG) and package://PKG/...
# --------------------------------------------------------------------------


@dataclass
class PackageResolver:
    """Resolve ROS package names to folders without ROS.

    Lookup order: ``package_dirs`` given by the user (``NAME=DIR``); the
    built-in packages (``manipkit`` -> the folder holding ``robots/``,
    ``example-robot-data`` -> its share folder, and each
    ``*_description`` folder of example-robot-data by name); a folder named
    PKG (or holding a ``package.xml`` that declares PKG) among the ancestors
    of ``near`` and their sub-folders; the folders on ``ROS_PACKAGE_PATH``.
    """

    package_dirs: dict[str, Path] = field(default_factory=dict)
    near: Path | None = None

    def candidates(self) -> list[Path]:
        """Folders searched for packages, in order (for error messages too)."""
        places: list[Path] = []
        if self.near is not None:
            for ancestor in list(self.near.resolve().parents)[:4]:
                if ancestor.parent != ancestor:  # never crawl the file-system root
                    places.append(ancestor)
        for entry in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep):
            if entry:
                places.append(Path(entry))
        return places

    def builtin(self) -> dict[str, Path]:
        packages = {"manipkit": bundled_dir().parent}
        erd = example_robot_data_dir()
        if erd is not None:
            packages["example-robot-data"] = erd
            packages["example_robot_data"] = erd
            for folder in sorted((erd / "robots").iterdir()):
                if folder.is_dir():
                    packages.setdefault(folder.name, folder)
        return packages

    def find(self, package: str) -> Path:
        """The folder of ``package``; :class:`PackageNotFoundError` lists where it looked."""
        if package in self.package_dirs:
            folder = Path(self.package_dirs[package]).expanduser()
            if not folder.is_dir():
                raise PackageNotFoundError(
                    f"--package-dir {package}={folder}: no such folder"
                )
            return folder.resolve()
        builtin = self.builtin()
        if package in builtin:
            return builtin[package]
        searched = []
        for place in self.candidates():
            searched.append(str(place))
            found = _package_in(place, package)
            if found is not None:
                return found
        raise PackageNotFoundError(
            f"package '{package}' not found; searched --package-dir ({', '.join(self.package_dirs) or 'none given'}), "
            f"built-in (manipkit, example-robot-data and its robot folders), and {'; '.join(searched) or 'no other folders'}; "
            f"give it with --package-dir {package}=DIR"
        )

    def resolve_uri(self, uri: str) -> str:
        """``package://PKG/rest`` -> absolute path; ``file://`` stripped; others unchanged."""
        if uri.startswith("package://"):
            package, _, rest = uri[len("package://") :].partition("/")
            return str(self.find(package) / rest)
        if uri.startswith("file://"):
            return uri[len("file://") :]
        return uri


def _package_in(place: Path, package: str) -> Path | None:
    """A folder for ``package``: ``place`` itself, a folder in it, or a folder in its ``src/``."""
    if not place.is_dir():
        return None
    folders = [place]
    for parent in (place, place / "src"):
        try:
            folders += sorted(p for p in parent.iterdir() if p.is_dir())
        except OSError:
            continue
    for folder in folders:
        if folder.name == package or _package_xml_name(folder) == package:
            return folder.resolve()
    return None


def _package_xml_name(folder: Path) -> str | None:
    manifest = folder / "package.xml"
    if not manifest.is_file():
        return None
    match = re.search(r"<name>\s*([^<\s]+)\s*</name>", manifest.read_text(errors="replace"))
    return match.group(1) if match else None


# --------------------------------------------------------------------------
# Description file -> URDF text
# --------------------------------------------------------------------------


class XacroExpansion(NamedTuple):
    """URDF text expanded from a xacro file, and the ``<xacro:arg>`` declarations it met (name -> default)."""

    text: str
    declared: dict


def urdf_text(
    source: RobotSource,
    xacro_args: dict[str, object] | None = None,
    package_dirs: dict[str, Path] | None = None,
) -> str:
    """The URDF XML of a description, expanding xacro in-process.

    Parameters
    ----------
    source : RobotSource
        From :func:`resolve_robot`.
    xacro_args : dict, optional
        xacro ``<xacro:arg>`` values (``--arg k=v``); values are turned into strings.
        Given for a plain URDF, they are an error (they would be ignored silently).
    package_dirs : dict, optional
        Package name -> folder, for ``$(find PKG)``.
    """
    return describe(source, xacro_args, package_dirs).text


def describe(
    source: RobotSource,
    xacro_args: dict[str, object] | None = None,
    package_dirs: dict[str, Path] | None = None,
) -> XacroExpansion:
    """As :func:`urdf_text`, with the xacro arguments the files declare (empty for plain URDF)."""
    xacro_args = {k: str(v) for k, v in (xacro_args or {}).items()}
    if not source.is_xacro:
        if xacro_args:
            raise DescriptionError(
                f"{source.path.name} is plain URDF; xacro arguments "
                f"({', '.join(xacro_args)}) only apply to .xacro files"
            )
        return XacroExpansion(_read_description(source.path), {})
    resolver = PackageResolver(dict(package_dirs or {}), near=source.path)
    return expand_xacro(source.path, xacro_args, resolver)


def xacro_arg_declarations(files) -> dict[str, str | None]:
    """The ``<xacro:arg name default>`` declarations in xacro ``files`` (name -> default, first wins).

    Read with lxml; a file that does not parse is skipped (xacro reports it).
    """
    from lxml import etree

    declared: dict[str, str | None] = {}
    parser = etree.XMLParser(remove_comments=True, resolve_entities=False, no_network=True)
    for file in files:
        try:
            root = etree.parse(str(file), parser).getroot()
        except (OSError, etree.XMLSyntaxError):
            continue
        for element in root.iter(etree.Element):
            if element.tag == "xacro:arg" or (element.prefix == "xacro" and etree.QName(element).localname == "arg"):
                name = element.get("name")
                if name:
                    declared.setdefault(name, element.get("default"))
    return declared


def expand_xacro(path: Path, args: dict[str, str], resolver: PackageResolver) -> XacroExpansion:
    """Expand a xacro file to URDF text, with ``$(find)`` answered by ``resolver``.

    Unknown argument names (declared in none of the files the expansion
    read) are an error listing the declared ones (xacro itself would ignore
    them silently). Every xacro error names the xacro
    file and line it comes from (``FILE.xacro:LINE: ...``): xacro reports
    no lines, so the line is found by searching the xacro sources for the
    offending expression, argument, include or macro.

    ``$(find)`` is routed to ``resolver`` by patching
    ``xacro.substitution_args._eval_find`` for the duration of the call.
    xacro imports that module (and PyYAML, ~8 ms) only when it meets the
    first ``$(...)``, so the patch is applied at that moment too: a file
    without substitutions (the course arm) never pays for the import.
    """
    import io
    import contextlib

    import xacro

    _read_description(path)
    missing: list[tuple[str, PackageNotFoundError]] = []

    def find(package: str) -> str:
        try:
            return str(resolver.find(package))
        except PackageNotFoundError as exc:
            missing.append((package, exc))  # xacro wraps exceptions; keep ours
            raise

    original_extension = xacro.eval_extension  # xacro's handler of every $(...)
    patched = []  # (substitution_args module, its own _eval_find), once patched

    def eval_extension(text: str):
        if not patched:
            import xacro.substitution_args as substitution_args

            patched.append((substitution_args, substitution_args._eval_find))
            substitution_args._eval_find = find
        return original_extension(text)

    xacro.eval_extension = eval_extension
    xacro.all_includes.clear()  # xacro appends every file it includes (module-global)
    stderr = io.StringIO()
    try:
        with contextlib.redirect_stderr(stderr), contextlib.redirect_stdout(stderr):
            document = xacro.process_file(str(path), mappings=dict(args))
    except Exception as exc:  # xacro raises many kinds; all are description errors
        declared = xacro_arg_declarations([path, *xacro.all_includes])
        raise _xacro_error(exc, path, missing, declared) from None
    finally:
        xacro.eval_extension = original_extension
        for substitution_args, original_find in patched:
            substitution_args._eval_find = original_find
    # xacro ignores arguments nobody declared; here they are an error (a typo would pass silently)
    declared = xacro_arg_declarations([path, *xacro.all_includes])
    unknown = sorted(set(args) - set(declared))
    if unknown:
        valid = ", ".join(f"{k} (default {v})" for k, v in declared.items()) or "none"
        raise DescriptionError(f"{path.name}: unknown xacro argument {', '.join(unknown)}; declared: {valid}")
    return XacroExpansion(document.toxml(), declared)


def _read_description(path: Path) -> str:
    """The text of a description file, or a one-line error (unreadable, not UTF-8 text, empty)."""
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise DescriptionError(f"{path}: cannot read ({exc.strerror or exc})") from None
    try:
        data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise DescriptionError(
            f"{path.name}: not a text file (byte 0x{data[exc.start]:02x} at offset {exc.start} is not UTF-8); "
            "a URDF or xacro description is XML text"
        ) from None
    if not data.strip():
        raise DescriptionError(f"{path.name}: empty file; a description is XML with a <robot name=\"...\"> root element")
    return data.decode("utf-8-sig")  # a byte-order mark is not part of the XML


def _xacro_error(exc: BaseException, path: Path, missing: list, declared: dict) -> DescriptionError:
    """One-line error for a failed xacro expansion: ``FILE.xacro:LINE: what, and what would be valid``."""
    import xml.parsers.expat

    import xacro

    stack = [Path(f) for f in (xacro.filestack or []) if f]
    current = stack[-1] if stack else path
    macros = [m for m in (getattr(xacro, "macrostack", None) or [])]
    macro_files = [Path(h[-1]) for m in reversed(macros) for h in (m.history or [])[-1:] if h and h[-1]]
    files = _xacro_search_files(path, macro_files + list(reversed(stack)))
    text = " ".join(str(exc).split()) or type(exc).__name__

    def at(*needles: str, pattern: str | None = None) -> str:
        found = _find_in_files(files, needles, pattern)
        return found or current.name

    if missing:
        package, error = missing[0]
        location = at(pattern=r"\$\(find\s+" + re.escape(package) + r"\s*\)")
        return PackageNotFoundError(f"{location}: $(find {package}): {error}")
    if isinstance(exc, xml.parsers.expat.ExpatError):
        reason = xml.parsers.expat.ErrorString(exc.code) if exc.code else text
        return DescriptionError(f"{current.name}:{exc.lineno}:{exc.offset}: malformed XML: {reason}")
    if isinstance(exc, RecursionError):
        names = list(dict.fromkeys(m.body.getAttribute("name") for m in macros[-3:]))
        location = at(pattern=r"<xacro:(" + "|".join(map(re.escape, names)) + r")\b") if names else current.name
        return DescriptionError(f"{location}: xacro recursion too deep "
                                f"(macro {', '.join(names) or '?'} calls itself without end?)")
    match = re.search(r"(.*?)\s*when evaluating expression '(.*)'$", text)
    if match:
        reason, expression = match.groups()
        location = at("${" + expression + "}", expression)
        return DescriptionError(f"{location}: xacro expression ${{{expression}}}: {reason}")
    if "missing attribute 'default'" in text and "xacro:arg" in text:
        location = at(pattern=r"<xacro:arg\b(?![^>]*\bdefault\s*=)[^>]*>")
        name = _attribute_on_line(files, location, "name") or "NAME"
        return DescriptionError(f'{location}: <xacro:arg name="{name}"> has no default; xacro needs '
                                f'default="..." (--arg {name}=VALUE then overrides it)')
    match = re.search(r"Undefined substitution argument (\S+)", text)
    if match:
        name = match.group(1)
        location = at(pattern=r"\$\(arg\s+" + re.escape(name) + r"\s*\)")
        valid = ", ".join(declared) or "none"
        return DescriptionError(f'{location}: $(arg {name}): no such xacro argument; declare '
                                f'<xacro:arg name="{name}" default="..."/> (declared: {valid})')
    match = re.search(r"No such file or directory: (\S+)", text)
    if match:
        missing_file = match.group(1)
        location = at(pattern=r"<xacro:include\b[^>]*" + re.escape(Path(missing_file).name))
        return DescriptionError(f"{location}: xacro:include: file not found: {missing_file}")
    match = re.search(r"unknown macro name: (?:xacro:)?(\S+)", text)
    if match:
        name = match.group(1)
        location = at(pattern=r"<xacro:" + re.escape(name) + r"\b")
        known = _xacro_macro_names(files)
        close = difflib.get_close_matches(name, known, n=1, cutoff=0.5)
        hint = f"did you mean {close[0]}? " if close else ""
        return DescriptionError(f"{location}: unknown xacro macro '{name}'; {hint}macros: {', '.join(known) or 'none defined'}")
    match = re.search(r"Undefined parameters? \[(.*)\]", text)
    if match and macros:
        name = macros[-1].body.getAttribute("name")
        location = at(pattern=r"<xacro:" + re.escape(name) + r"\b")
        return DescriptionError(f"{location}: xacro macro '{name}' called without parameter(s) {match.group(1)}; "
                                "give them as attributes")
    match = re.search(r"invalid expression: (.*)$", text)
    if match:
        location = at(match.group(1))
        return DescriptionError(f"{location}: xacro: invalid expression {match.group(1)} (unclosed ${{...}}?)")
    match = re.search(r"Unknown substitution command \[([^\]]*)\]", text)
    if match:
        command = match.group(1)
        location = at("$(" + command)
        return DescriptionError(f"{location}: xacro: unknown substitution $({command}); "
                                "valid: find, arg, env, optenv, dirname, eval")
    match = re.search(r'conditional "([^"]*)"', text)
    if match:
        return DescriptionError(f"{at(match.group(1))}: xacro: {text}")
    quoted = re.findall(r"'([^']{2,})'", text)
    location = at(*quoted) if quoted else current.name
    return DescriptionError(f"{location}: xacro: {text}")


def _xacro_search_files(top: Path, stack: list[Path]) -> list[Path]:
    """Files to search for an error's source: the ones xacro was in, then the top file, then its xacro siblings."""
    files: list[Path] = []
    for candidate in stack + [top]:
        candidate = candidate if candidate.is_absolute() else (Path.cwd() / candidate)
        if candidate.is_file() and candidate not in files:
            files.append(candidate)
    for folder in dict.fromkeys(f.parent for f in list(files)):
        for sibling in sorted(folder.glob("*.xacro"))[:50]:
            if sibling not in files:
                files.append(sibling)
    return files


def _find_in_files(files: list[Path], needles=(), pattern: str | None = None) -> str | None:
    """``NAME:LINE`` of the first match of ``pattern`` or of a needle (in order) in ``files``, or None."""
    regexes = ([re.compile(pattern)] if pattern else []) + [re.compile(re.escape(n)) for n in needles if n]
    for regex in regexes:
        for path in files:
            try:
                text = _without_comments(path.read_text(errors="replace"))
            except OSError:
                continue
            found = regex.search(text)
            if found:
                return f"{path.name}:{text.count(chr(10), 0, found.start()) + 1}"
    return None


def _without_comments(text: str) -> str:
    """XML text with each comment blanked out (newlines kept, so line numbers stay)."""
    return re.sub(r"<!--.*?-->", lambda m: re.sub(r"[^\n]", " ", m.group()), text, flags=re.S)


def _attribute_on_line(files: list[Path], location: str, attribute: str) -> str | None:
    name, _, line = location.rpartition(":")
    for path in files:
        if path.name == name and line.isdigit():
            lines = path.read_text(errors="replace").splitlines()
            match = re.search(rf'\b{attribute}\s*=\s*["\']([^"\']*)', lines[int(line) - 1] if int(line) <= len(lines) else "")
            return match.group(1) if match else None
    return None


def _xacro_macro_names(files: list[Path]) -> list[str]:
    names: list[str] = []
    for path in files:
        try:
            text = _without_comments(path.read_text(errors="replace"))
        except OSError:
            continue
        names += re.findall(r"<xacro:macro\b[^>]*\bname\s*=\s*[\"']([^\"']+)", text)
    return list(dict.fromkeys(names))


def xacro_locator(path: Path):
    """``locate(tag, name)`` for :func:`manipkit.description.validate.check_urdf`: where a link or joint is written in xacro.

    Searches the xacro file and the xacro files beside it for
    ``<TAG ... name="NAME"``; returns ``"FILE.xacro:LINE"`` or None (the
    name may be built by an expression, e.g. ``${prefix}_joint``).
    """
    files = _xacro_search_files(path, [])
    cache: dict[tuple[str, str], str | None] = {}

    def locate(tag: str, name: str) -> str | None:
        key = (tag, name)
        if key not in cache:
            pattern = rf"<{re.escape(tag)}\b[^>]*\bname\s*=\s*[\"']{re.escape(name)}[\"']"
            cache[key] = _find_in_files(files, pattern=pattern)
        return cache[key]

    return locate


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
