"""xacro descriptions to URDF text, in-process and without ROS, with errors that name the file and line.

:func:`describe` (and :func:`urdf_text`) turn a
:class:`~manipkit.description.sources.RobotSource` into URDF text: a plain URDF
is read as is, a ``.xacro`` file is expanded with the ``xacro`` package
(:func:`expand_xacro`), ``$(find PKG)`` answered by a
:class:`~manipkit.description.packages.PackageResolver`. xacro reports errors
without lines; here every one becomes ``FILE.xacro:LINE: what, and what would
be valid``, found by searching the xacro sources (:func:`xacro_locator` does
the same for the validator's messages about links and joints).

The ``xacro`` package and lxml are imported inside the functions that need
them, so importing this module stays cheap (docs/architecture.md).
"""

from __future__ import annotations

import difflib
import re
from pathlib import Path
from typing import NamedTuple

from manipkit.description.packages import PackageResolver
from manipkit.description.sources import RobotSource
from manipkit.errors import DescriptionError, PackageNotFoundError

__all__ = [
    "XacroExpansion",
    "describe",
    "expand_xacro",
    "urdf_text",
    "xacro_arg_declarations",
    "xacro_locator",
]



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
        From :func:`manipkit.description.sources.resolve_robot`.
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
    import contextlib
    import io

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


# Over 80 lines: one branch per kind of xacro error message, most specific first; the order matters,
# so the branches stay together.
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
