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

import contextlib
import os
import re
import threading
import time
import warnings
from pathlib import Path
from typing import NamedTuple

from manipkit.description.packages import WARNING_REGISTRY, PackageResolver, missing_in_package_hint
from manipkit.description.sources import RobotSource
from manipkit.errors import DescriptionError, InputFileError, ManipkitError, PackageNotFoundError, ReadNotAllowedError
from manipkit.inputs import MAX_DESCRIPTION_BYTES, check_input_file, file_digest
from manipkit.memo import keep
from manipkit.text import close_matches

__all__ = [
    "EXPANSION_SECONDS",
    "MAX_XACRO_CHILDREN",
    "MAX_EXPANDED_CHARACTERS",
    "MAX_TEXT_CHARACTERS",
    "MAX_XACRO_ELEMENTS",
    "XacroExpansion",
    "describe",
    "expand_xacro",
    "urdf_text",
    "xacro_arg_declarations",
    "xacro_locator",
]

#: Most elements one xacro expansion may process (macros calling macros many times over).
MAX_XACRO_ELEMENTS = 500_000
#: Longest text (an attribute, a property, a text node) one evaluation may make.
MAX_TEXT_CHARACTERS = 4 * 1024 * 1024
#: Most characters all the evaluations of one expansion may make together.
MAX_EXPANDED_CHARACTERS = 4 * MAX_DESCRIPTION_BYTES
#: Most child nodes (elements, text, comments) an expansion may give one element: a robot of
#: ``validate.MAX_LINKS`` links and joints has about 20,000 with the text between them.
MAX_XACRO_CHILDREN = 50_000
#: Seconds one xacro expansion may take (real descriptions take well under one).
EXPANSION_SECONDS = 30.0
#: How many nodes a macro's expansion inserts between two looks at the clock.
_INSERTIONS_PER_CHECK = 256

# xacro keeps its state in module globals (the files included, the functions patched by _xacro_hooks) and an
# expansion redirects the process's stdout and stderr, so one expansion runs at a time in a process.
_EXPANDING = threading.Lock()


class XacroExpansion(NamedTuple):
    """URDF text expanded from a xacro file, and the ``<xacro:arg>`` declarations it met (name -> default)."""

    text: str
    declared: dict


def urdf_text(
    source: RobotSource,
    xacro_args: dict[str, object] | None = None,
    package_dirs: dict[str, Path] | None = None,
    *,
    allow_read: tuple[Path, ...] = (),
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
    allow_read : tuple of Path, keyword-only
        Folders the description may read besides its own tree and packages (``--allow-read``;
        :mod:`manipkit.description.access`).
    """
    return describe(source, xacro_args, package_dirs, allow_read=allow_read).text


def describe(
    source: RobotSource,
    xacro_args: dict[str, object] | None = None,
    package_dirs: dict[str, Path] | None = None,
    *,
    allow_read: tuple[Path, ...] = (),
) -> XacroExpansion:
    """As :func:`urdf_text`, with the xacro arguments the files declare (empty for plain URDF and MJCF).

    A MuJoCo MJCF ``.xml`` file is compiled by MuJoCo and written out as URDF
    (:func:`manipkit.description.mjcf.mjcf_urdf`).
    """
    xacro_args = {k: str(v) for k, v in (xacro_args or {}).items()}
    if not source.is_xacro:
        if xacro_args:
            raise DescriptionError(
                f"{source.path.name} is {'an MJCF file' if source.is_mjcf else 'plain URDF'}; xacro arguments "
                f"({', '.join(xacro_args)}) only apply to .xacro files"
            )
        if source.is_mjcf:  # MuJoCo's compiler, written out as URDF (manipkit.description.mjcf)
            from manipkit.description.mjcf import mjcf_urdf

            return XacroExpansion(mjcf_urdf(source.path, allow_read=allow_read), {})
        return XacroExpansion(_read_description(source.path), {})
    resolver = PackageResolver(dict(package_dirs or {}), near=source.path)
    return expand_xacro(source.path, xacro_args, resolver, allow_read=allow_read)


def xacro_arg_declarations(files) -> dict[str, str | None]:
    """The ``<xacro:arg name default>`` declarations in xacro ``files`` (name -> default, first wins).

    Read with lxml; a file that does not parse is skipped (xacro reports it).
    """
    return {name: default for name, (_, default) in _arg_declaration_sites(files).items()}


def _arg_declaration_sites(files) -> dict[str, tuple[str, str | None]]:
    """``<xacro:arg>`` declarations in ``files``: name -> (``FILE:LINE``, default or None), first wins."""
    from lxml import etree

    declared: dict[str, tuple[str, str | None]] = {}
    parser = etree.XMLParser(remove_comments=True, resolve_entities=False, no_network=True)
    for file in files:
        try:
            check_input_file(file, what="xacro file", max_bytes=MAX_DESCRIPTION_BYTES)  # a FIFO is not opened
            root = etree.parse(str(file), parser).getroot()
        except (ManipkitError, OSError, etree.XMLSyntaxError):
            continue
        for element in root.iter(etree.Element):
            if element.tag == "xacro:arg" or (element.prefix == "xacro" and etree.QName(element).localname == "arg"):
                name = element.get("name")
                if name:
                    declared.setdefault(name, (f"{Path(file).name}:{element.sourceline}", element.get("default")))
    return declared


def _arg_uses(files) -> set[str]:
    """The argument names ``$(arg NAME)`` reads in ``files`` (outside comments)."""
    used: set[str] = set()
    for file in files:
        text = _source_text(Path(file))
        if text is not None:
            used.update(re.findall(r"\$\(arg\s+([^\s()]+)\s*\)", _without_comments(text)))
    return used


def expand_xacro(path: Path, args: dict[str, str], resolver: PackageResolver, *,
                 allow_read: tuple[Path, ...] = ()) -> XacroExpansion:
    """Expand a xacro file to URDF text, with ``$(find)`` answered by ``resolver``.

    Unknown argument names (declared in none of the files the expansion
    read, and read by no ``$(arg NAME)`` there) are an error listing the
    declared ones (xacro itself would ignore them silently). An argument
    declared without a default is required: given, it is used (xacro would
    refuse the declaration even then); not given, the error says so and how
    to give it, as it does for an argument read before its declaration.
    Every xacro error names the xacro file and line it comes from
    (``FILE.xacro:LINE: ...``): xacro reports no lines, so the line is found
    by searching the xacro sources for the offending expression, argument,
    include or macro. Python warnings raised while xacro runs (a package
    found in two places) are issued once each after a successful expansion.

    Descriptions are untrusted input, so for the duration of the call
    (:func:`_xacro_hooks`) xacro's evaluation is replaced by a safe one:
    ``${...}`` and ``$(eval ...)`` go through
    :mod:`manipkit.description.expressions` (no code runs; bounded cost),
    ``xacro.load_yaml`` through :func:`manipkit.description.xacro_names.load_yaml`,
    every file is checked by :func:`manipkit.inputs.check_input_file` before xacro
    opens it (a FIFO would block) and must be one the description may read
    (:mod:`manipkit.description.access`: its own folder tree, its packages,
    ``allow_read``), a file that includes itself is refused, the expansion is
    bounded (:data:`MAX_XACRO_ELEMENTS`, :data:`MAX_TEXT_CHARACTERS`,
    :data:`MAX_EXPANDED_CHARACTERS`, :data:`EXPANSION_SECONDS`, which every
    evaluation and YAML file counts against), and what xacro prints
    (``xacro.message``/``warning``) is dropped after :data:`MAX_XACRO_OUTPUT`
    characters. Environment variables read by ``$(env)``/``$(optenv)`` are
    named in a warning: their values become part of the description.

    ``$(find)`` is routed to ``resolver`` by patching
    ``xacro.substitution_args._eval_find``. xacro imports that module (and
    PyYAML, ~8 ms) only when it meets the first ``$(...)``, so the patch is
    applied at that moment too: a file without substitutions (the course arm)
    never pays for the import.

    An expansion is kept for the process and given again while nothing it
    depends on changed (:data:`_EXPANSIONS` says what); the copy returned is
    the caller's own.
    """
    import xacro

    from manipkit.description.access import ReadPolicy, reading_under

    _read_description(path)
    key = _expansion_key(path, args, resolver, allow_read)
    kept = _kept_expansion(key, resolver)
    if kept is not None:
        return kept
    missing: list[tuple[str, PackageNotFoundError]] = []
    environment: list[str] = []
    stderr = _BoundedOutput()
    policy = ReadPolicy(path, resolver, allow_read)
    with _EXPANDING:  # held until the error, if any, is made: it reads xacro's file and macro stacks
        try:
            # xacro's own messages go to stderr, which is captured; Python warnings (a package found twice
            # during $(find)) are recorded instead and issued once each after a successful expansion (_reissue);
            # an error is one line, and names the package folder it concerns itself
            with warnings.catch_warnings(record=True) as caught, _xacro_hooks(path, resolver, missing, environment), \
                    reading_under(policy), contextlib.redirect_stderr(stderr), contextlib.redirect_stdout(stderr):
                warnings.simplefilter("always")
                xacro.all_includes.clear()  # xacro appends every file it includes (module-global)
                document = xacro.process_file(str(path), mappings=dict(args))
                included = list(xacro.all_includes)
        except Exception as exc:  # xacro raises many kinds; all are description errors (one line: no warnings)
            raise _xacro_error(exc, path, missing, resolver) from None
    _reissue(caught)
    if environment:
        names = ", ".join(dict.fromkeys(environment))
        warnings.warn(f"{path.name}: reads environment variable(s) {names} ($(env)/$(optenv)); their values "
                      "become part of the description (link names, paths)", UserWarning, stacklevel=2)
    files = [path, *(Path(f) for f in included)]
    _remember_files(path, files)
    digests = _digests([os.fspath(path), *policy.read])
    expansion = XacroExpansion(document.toxml(), _declared_arguments(path, args, files))
    if not (caught or environment or missing) and not _find_in_files(files, pattern=_GLOB_INCLUDE):
        _keep_expansion(key, digests, resolver.found(), files, expansion)
    return expansion


def _declared_arguments(path: Path, args: dict[str, str], files: list[Path]) -> dict[str, str]:
    """The arguments ``files`` declare (name: default); an argument given that none declares or reads is an error.

    xacro ignores arguments nobody declared or reads; here they are an error (a typo would pass silently).
    ``$(arg NAME)`` without a declaration is valid xacro: the argument must then be given.
    """
    declared = xacro_arg_declarations(files)
    unknown = sorted(set(args) - set(declared) - _arg_uses(files))
    if unknown:
        valid = ", ".join(f"{k} (default {v})" for k, v in declared.items()) or "none"
        raise DescriptionError(f"{path.name}: unknown xacro argument {', '.join(unknown)}; declared: {valid}")
    return declared


#: Expansions kept in this process, at most _KEPT_EXPANSIONS (the oldest go): a notebook or a session of tests
#: loads the same robot again and again, and the expansion is most of a load (25 ms of the course arm's 28 ms).
#: Key: the file (as given and its real path), the arguments, the package folders given, the folders allowed and
#: the working folder; value: the digest of every file the expansion read (includes, YAML: each file the read
#: policy allowed), the packages it found and where, the files to remember and the expansion. Kept only when the
#: expansion warned nothing, read no environment variable and included no wildcard pattern (a new file could
#: match it); used only while every file read holds the same bytes and the caller's resolver finds every
#: package in the same folder.
_EXPANSIONS: dict[tuple, tuple] = {}
_KEPT_EXPANSIONS = 64
_GLOB_INCLUDE = r"<[\w:]*include\b[^>]*\bfilename\s*=\s*[\"'][^\"']*[*?\[]"


def _digests(files) -> tuple | None:
    """(path, SHA-256 of its bytes) of each of ``files`` once, or None when one cannot be read as an input."""
    try:
        return tuple((file, file_digest(file, what="xacro file", max_bytes=MAX_DESCRIPTION_BYTES))
                     for file in dict.fromkeys(files))
    except InputFileError:
        return None


def _expansion_key(path: Path, args: dict[str, str], resolver: PackageResolver, allow_read) -> tuple | None:
    """What a kept expansion is found by (see _EXPANSIONS); None where there is no working folder (deleted): not kept."""
    from manipkit.description.access import allowed_folders

    try:
        cwd = os.getcwd()
    except OSError:
        return None
    return (os.fspath(path), os.path.realpath(path), cwd, tuple(sorted(args.items())),
            tuple(sorted((name, os.fspath(folder)) for name, folder in resolver.package_dirs.items())),
            tuple(os.fspath(folder) for folder in allowed_folders(allow_read)))


def _kept_expansion(key: tuple, resolver: PackageResolver) -> XacroExpansion | None:
    from manipkit.outputs import note_input

    kept = _EXPANSIONS.get(key) if key is not None else None
    if kept is None:
        return None
    digests, found, files, expansion = kept
    if _digests(file for file, _ in digests) != digests:
        return None
    try:
        if any(resolver.find(name) != folder for name, folder in found.items()):
            return None
    except PackageNotFoundError:
        return None
    for file, _ in digests:
        note_input(file)  # as reading it would (manipkit.outputs)
    _remember_files(Path(key[0]), files)
    return XacroExpansion(expansion.text, dict(expansion.declared))


def _keep_expansion(key: tuple, digests: tuple | None, found: dict, files: list[Path], expansion: XacroExpansion):
    if key is None or digests is None:
        return
    keep(_EXPANSIONS, key, (digests, dict(found), list(files), XacroExpansion(expansion.text, dict(expansion.declared))),
         limit=_KEPT_EXPANSIONS)


#: Most characters of what xacro prints during one expansion (``xacro.message``, ``xacro.warning``) that are
#: kept; they are not shown (an error says what went wrong), so the rest is dropped.
MAX_XACRO_OUTPUT = 64 * 1024


class _BoundedOutput:
    """A text stream that keeps the first :data:`MAX_XACRO_OUTPUT` characters written to it and drops the rest."""

    def __init__(self):
        self.parts: list[str] = []
        self.size = 0

    def write(self, text: str) -> int:
        if self.size < MAX_XACRO_OUTPUT:
            kept = str(text)[: MAX_XACRO_OUTPUT - self.size]
            self.parts.append(kept)
            self.size += len(kept)
        return len(text)

    def flush(self) -> None:
        pass

    def getvalue(self) -> str:
        return "".join(self.parts)


def _reissue(caught: list) -> None:
    """Issue the warnings recorded during an expansion again, once per text, into the package lookup's registry."""
    seen = set()
    for caught_warning in caught:
        key = (str(caught_warning.message), caught_warning.category)
        if key not in seen:
            seen.add(key)
            warnings.warn_explicit(caught_warning.message, caught_warning.category, caught_warning.filename,
                                   caught_warning.lineno, registry=WARNING_REGISTRY)


# Over 80 lines: one hook per xacro function replaced, each a few lines, patched and restored together.
@contextlib.contextmanager
def _xacro_hooks(path: Path, resolver: PackageResolver, missing: list, environment: list):
    """Replace xacro's evaluation, file opening and unbounded loops for one expansion (restored after)."""
    # Over 80 lines: the six hooks share one expansion's state (deadline, counts, missing packages) as closures.
    import xacro

    from manipkit.description.expressions import MAX_SIZE, expansion_deadline
    from manipkit.description.xacro_names import evaluate_eval, evaluate_expression

    def find(package: str) -> str:
        try:
            return str(resolver.find(package))
        except PackageNotFoundError as exc:
            missing.append((package, exc))  # xacro wraps exceptions; keep ours
            raise

    originals = {name: getattr(xacro, name)
                 for name in ("eval_extension", "safe_eval", "parse", "eval_text", "eval_all", "check_attrs",
                              "replace_node")}
    patched = []  # (substitution_args module, its own _eval_find, _eval_env, _eval_optenv), once patched
    deadline = time.monotonic() + EXPANSION_SECONDS
    out_of_time = f"{path.name}: xacro expansion took more than {EXPANSION_SECONDS:g} s, the limit"
    counts = {"elements": 0, "characters": 0}

    def eval_extension(text: str):  # every $(...)
        if not patched:
            import xacro.substitution_args as substitution_args

            own = (substitution_args._eval_find, substitution_args._eval_env, substitution_args._eval_optenv)
            patched.append((substitution_args, own))

            def env(name):
                environment.append(str(name))
                return own[1](name)

            def optenv(name, default=""):
                environment.append(str(name))
                return own[2](name, default)

            substitution_args._eval_find, substitution_args._eval_env, substitution_args._eval_optenv = find, env, optenv
        if text.startswith("$(eval ") and text.endswith(")"):  # as xacro.substitution_args.resolve_args
            return evaluate_eval(text[7:-1])
        return originals["eval_extension"](text)

    def safe_eval(expression, symbols, locals=None):  # noqa: A002 - xacro's signature
        return evaluate_expression(expression, symbols)

    def parse(inp, filename=None):
        if inp is None and filename:
            _check_xacro_file(os.path.join(xacro.root_dir, filename), [f for f in xacro.filestack[:-1] if f])
        return originals["parse"](inp, filename)

    def eval_text(text, symbols):
        try:
            result = originals["eval_text"](text, symbols)
        except Exception as exc:
            ours = next((e for e in _exception_chain(exc) if isinstance(e, ManipkitError)), None)
            if ours is not None and getattr(ours, "needles", None):  # the text as written, before $(arg ...)
                ours.needles = (*ours.needles, str(text))
            raise
        if isinstance(result, str):
            counts["characters"] += len(result)
            if len(result) > MAX_TEXT_CHARACTERS or counts["characters"] > MAX_EXPANDED_CHARACTERS:
                error = DescriptionError(
                    f"xacro text '{_clip(text)}' makes {len(result)} characters ({counts['characters']} in all "
                    f"so far), above the limit of {MAX_TEXT_CHARACTERS} for one text and "
                    f"{MAX_EXPANDED_CHARACTERS} for a description (properties that repeat each other?)")
                error.needles = (str(text),)
                raise error
        return result

    def eval_all(node, macros, symbols):
        counts["elements"] += 1
        if counts["elements"] > MAX_XACRO_ELEMENTS:
            raise DescriptionError(f"{path.name}: xacro expansion made more than {MAX_XACRO_ELEMENTS} elements, "
                                   "the limit (macros that call each other many times over?)")
        if time.monotonic() > deadline:
            raise DescriptionError(out_of_time)
        return originals["eval_all"](node, macros, symbols)

    def replace_node(node, by, content_only=False):  # a macro's expansion put in place of its call
        # minidom finds each insertion point by a linear search of the parent's children, so filling one parent
        # with n nodes costs n^2 / 2 steps, none of them in eval_all: without this bound a doubling macro ran far
        # past the time limit between two checks (100 s and more on a loaded machine)
        parent = node.parentNode
        docs = [] if by is None else by if isinstance(by, list) else [by]
        adding = sum(len(doc.childNodes) for doc in docs) if content_only else len(docs)
        if parent is not None and len(parent.childNodes) + adding > MAX_XACRO_CHILDREN:
            raise DescriptionError(f"{path.name}: xacro expansion put more than {MAX_XACRO_CHILDREN} nodes in one "
                                   f"<{getattr(parent, 'tagName', 'document')[:40]}>, the limit (macros that call "
                                   "each other many times over?)")
        if time.monotonic() > deadline:
            raise DescriptionError(out_of_time)
        if parent is None or adding <= _INSERTIONS_PER_CHECK:
            return originals["replace_node"](node, by, content_only)
        # xacro.xmlutils.replace_node's own steps, with the clock read between them: one call filling a parent
        # with tens of thousands of nodes ran 6 s and more past the limit
        nodes = [child for doc in docs for child in list(doc.childNodes)] if content_only else docs
        for k, child in enumerate(nodes):
            if k % _INSERTIONS_PER_CHECK == 0 and time.monotonic() > deadline:
                raise DescriptionError(out_of_time)
            parent.insertBefore(child, node)
        parent.removeChild(node)

    def check_attrs(tag, required, optional):  # <xacro:arg name="x"/>: a required argument, used when given
        if tag.tagName == "xacro:arg" and "default" in required and not tag.hasAttribute("default"):
            name = tag.getAttribute("name")
            given = xacro.substitution_args_context["arg"]
            if name and name in given:
                return originals["check_attrs"](tag, ["name"], []) + [given[name]]
            if name:
                location = _find_in_files([Path(f) for f in reversed(xacro.filestack or []) if f],
                                          pattern=_arg_declaration_pattern(name))
                raise DescriptionError(f'{location or path.name}: <xacro:arg name="{name}"> has no default, so xacro '
                                       f"argument '{name}' is required; give it with --arg {name}:=VALUE")
        return originals["check_attrs"](tag, required, optional)

    assert MAX_SIZE <= MAX_TEXT_CHARACTERS  # an expression's value always fits in one text
    hooks = {"eval_extension": eval_extension, "safe_eval": safe_eval, "parse": parse, "eval_text": eval_text,
             "eval_all": eval_all, "check_attrs": check_attrs, "replace_node": replace_node}
    for name, hook in hooks.items():
        setattr(xacro, name, hook)
    try:
        with expansion_deadline(deadline, out_of_time):
            yield
    finally:
        for name, original in originals.items():
            setattr(xacro, name, original)
        for substitution_args, own in patched:
            substitution_args._eval_find, substitution_args._eval_env, substitution_args._eval_optenv = own


def _clip(text: object, size: int = 60) -> str:
    text = " ".join(str(text).split())
    return text if len(text) <= size else text[: size - 3] + "..."


def _check_xacro_file(filename: str, including: list[str]) -> None:
    """Before xacro opens ``filename`` (included by the last of ``including``): a regular file of bounded
    size that is not already being included (a file that includes itself recurses without end)."""
    includer = Path(including[-1]) if including else None
    where = ""
    if includer is not None:
        name = re.escape(Path(filename).name)
        where = (_find_in_files([includer], pattern=r"<xacro:include\b[^>]*" + name) or includer.name) + ": "
    if os.path.lexists(filename):  # a missing file: xacro's own error, located by _xacro_error
        from manipkit.description.access import check_readable

        try:
            check_readable(filename, "xacro:include")
            check_input_file(filename, what="xacro file", max_bytes=MAX_DESCRIPTION_BYTES)
        except InputFileError as exc:
            raise InputFileError(f"{where}xacro:include: {exc}" if where else str(exc)) from None
        except ReadNotAllowedError as exc:
            raise ReadNotAllowedError(f"{where}{exc}") from None
    opened = [os.path.realpath(f) for f in including]
    me = os.path.realpath(filename)
    if me in opened:
        chain = " -> ".join(Path(f).name for f in [*including[opened.index(me):], filename])
        raise DescriptionError(f"{where}xacro:include: {Path(filename).name} includes itself ({chain}); "
                               "a file cannot include itself, directly or through other files")


_EXPANDED_FILES: dict[Path, list[Path]] = {}  # top-level xacro file -> the files its last expansion read


def _remember_files(path: Path, files: list[Path]) -> None:
    keep(_EXPANDED_FILES, path.resolve(), [f if f.is_absolute() else Path.cwd() / f for f in files], limit=64)


def _read_description(path: Path) -> str:
    """The text of a description file, or a one-line error (not a regular file, too large, unreadable,
    not UTF-8 text, empty)."""
    check_input_file(path, what="robot file", max_bytes=MAX_DESCRIPTION_BYTES)
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
def _xacro_error(exc: BaseException, path: Path, missing: list, resolver: PackageResolver) -> DescriptionError:
    """One-line error for a failed xacro expansion: ``FILE.xacro:LINE: what, and what would be valid``."""
    # Over 80 lines: one case per kind of xacro failure, in the order they are recognised; each is a few lines.
    import xml.parsers.expat

    import xacro

    from manipkit.description.expressions import error_reason

    stack = [Path(f) for f in (xacro.filestack or []) if f]
    current = stack[-1] if stack else path
    macros = [m for m in (getattr(xacro, "macrostack", None) or [])]
    macro_files = [Path(h[-1]) for m in reversed(macros) for h in (m.history or [])[-1:] if h and h[-1]]
    read = [Path(f) for f in xacro.all_includes]
    files = _xacro_search_files(path, macro_files + list(reversed(stack)) + read)
    text = " ".join(str(exc).split()) or type(exc).__name__
    chain = _exception_chain(exc)

    def at(*needles: str, pattern: str | None = None) -> str:
        found = _find_in_files(files, needles, pattern)
        return found or current.name

    if missing:
        package, error = missing[0]
        location = at(pattern=r"\$\(find\s+" + re.escape(package) + r"\s*\)")
        return PackageNotFoundError(f"{location}: $(find {package}): {error}")
    ours = next((e for e in chain if isinstance(e, ManipkitError)), None)
    if ours is not None:  # a safe-evaluation refusal, an include or YAML file refused, a limit reached
        needles = getattr(ours, "needles", None)
        return type(ours)(f"{at(*needles)}: {ours}") if needles else ours
    if isinstance(exc, xml.parsers.expat.ExpatError):
        reason = xml.parsers.expat.ErrorString(exc.code) if exc.code else text
        return DescriptionError(f"{current.name}:{exc.lineno}:{exc.offset}: malformed XML: {reason}")
    if any(isinstance(e, RecursionError) for e in chain):
        names = list(dict.fromkeys(m.body.getAttribute("name") for m in macros[-3:]))
        if not names:
            return DescriptionError(f"{current.name}: xacro recursion too deep (elements or properties nested "
                                    "more than about a few hundred levels)")
        location = at(pattern=r"<xacro:(" + "|".join(map(re.escape, names)) + r")\b")
        return DescriptionError(f"{location}: xacro recursion too deep "
                                f"(macro {', '.join(names)} calls itself without end?)")
    evaluating = [e for e in chain if "when evaluating expression '" in str(getattr(e, "suffix", "") or "")]
    if evaluating:  # the innermost expression (a property evaluated on the way names its own)
        expression = re.search(r"when evaluating expression '(.*)'", evaluating[-1].suffix, re.S).group(1)
        reason = error_reason(evaluating[-1].exc)
        location = at("${" + expression + "}", expression)
        return DescriptionError(f"{location}: xacro expression ${{{' '.join(expression.split())}}}: {reason}")
    match = re.search(r"Undefined substitution argument (\S+)", text)
    if match:
        return _undefined_arg_error(match.group(1), path, files, at)
    match = re.search(r"No such file or directory: (\S+)", text)
    if match:
        missing_file = match.group(1)
        location = at(pattern=r"<xacro:include\b[^>]*" + re.escape(Path(missing_file).name))
        return DescriptionError(f"{location}: xacro:include: file not found: {missing_file}"
                                f"{_package_hint(missing_file, resolver)}")
    match = re.search(r"unknown macro name: (?:xacro:)?(\S+)", text)
    if match:
        name = match.group(1)
        location = at(pattern=r"<xacro:" + re.escape(name) + r"\b")
        known = _xacro_macro_names(files)
        close = close_matches(name, known, n=1, cutoff=0.5)
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


def _package_hint(missing_file: str, resolver: PackageResolver) -> str:
    """For a file missing under a package folder ``$(find)`` chose: which folder that was, and how to choose another."""
    for package, folder in resolver.found().items():
        if Path(missing_file).is_relative_to(folder):
            return missing_in_package_hint(resolver, package, folder)
    return ""


def _arg_declaration_pattern(name: str) -> str:
    return r"<xacro:arg\b[^>]*\bname\s*=\s*[\"']" + re.escape(name) + r"[\"']"


def _undefined_arg_error(name: str, path: Path, files: list[Path], at) -> DescriptionError:
    """``$(arg NAME)`` met before any value: required (declared later, or without a default) or undeclared."""
    location = at(pattern=r"\$\(arg\s+" + re.escape(name) + r"\s*\)")
    sites = _arg_declaration_sites(list(dict.fromkeys([*files, *_written_includes(path)])))
    give = f"give it with --arg {name}:=VALUE"
    if name in sites:
        declared_at, default = sites[name]
        if default is None:
            return DescriptionError(f"{location}: xacro argument '{name}' is required (declared without a default "
                                    f"at {declared_at}); {give}")
        return DescriptionError(f"{location}: xacro argument '{name}' is read before its declaration at "
                                f"{declared_at}, so its default '{default}' does not apply yet; {give} "
                                "(or declare it before its first use)")
    valid = ", ".join(sites) or "none"
    return DescriptionError(f'{location}: $(arg {name}): no such xacro argument; declare <xacro:arg name="{name}" '
                            f'default="..."/> (declared: {valid}) or {give}')


def _exception_chain(exc: BaseException) -> list[BaseException]:
    """``exc`` and the exceptions it wraps (xacro's ``XacroException.exc``, causes and contexts), outermost first."""
    chain: list[BaseException] = []
    while exc is not None and all(exc is not seen for seen in chain):
        chain.append(exc)
        exc = getattr(exc, "exc", None) or exc.__cause__ or exc.__context__
    return chain


def _xacro_search_files(top: Path, stack: list[Path]) -> list[Path]:
    """Files to search for an error's source: the ones xacro was in and had read, then the top file.

    Only files the expansion read: a sibling file that defines the same link would name the wrong file.
    """
    files: list[Path] = []
    for candidate in stack + [top]:
        candidate = candidate if candidate.is_absolute() else (Path.cwd() / candidate)
        if candidate not in files and _source_text(candidate) is not None:
            files.append(candidate)
    return files


def _source_text(path: Path) -> str | None:
    """The text of a xacro source file for searching, or None (missing, not a regular file, too large)."""
    try:
        check_input_file(path, what="xacro file", max_bytes=MAX_DESCRIPTION_BYTES)
        return path.read_text(errors="replace")
    except (ManipkitError, OSError):
        return None


def _find_in_files(files: list[Path], needles=(), pattern: str | None = None) -> str | None:
    """``NAME:LINE`` of the first match of ``pattern`` or of a needle (in order) in ``files``, or None."""
    regexes = ([re.compile(pattern)] if pattern else []) + [re.compile(re.escape(n)) for n in needles if n]
    texts = {path: _source_text(path) for path in files}
    for regex in regexes:
        for path in files:
            if texts[path] is None:
                continue
            text = _without_comments(texts[path])
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
        if path.name == name and line.isdigit() and _source_text(path) is not None:
            lines = _source_text(path).splitlines()
            match = re.search(rf'\b{attribute}\s*=\s*["\']([^"\']*)', lines[int(line) - 1] if int(line) <= len(lines) else "")
            return match.group(1) if match else None
    return None


def _xacro_macro_names(files: list[Path]) -> list[str]:
    names: list[str] = []
    for path in files:
        if _source_text(path) is None:
            continue
        text = _without_comments(_source_text(path))
        names += re.findall(r"<xacro:macro\b[^>]*\bname\s*=\s*[\"']([^\"']+)", text)
    return list(dict.fromkeys(names))


def _written_includes(path: Path, limit: int = 200) -> list[Path]:
    """``path`` and the files its ``<xacro:include filename="...">`` name literally (no ``$(...)``), transitively."""
    files, todo = [path], [path]
    while todo and len(files) < limit:
        current = todo.pop()
        for name in re.findall(r'<xacro:include\s+filename="([^"$]+)"', _without_comments(_source_text(current) or "")):
            included = current.parent / name
            if included not in files:
                files.append(included)
                todo.append(included)
    return files


def xacro_locator(path: Path):
    """``locate(tag, name)`` for :func:`manipkit.description.validate.check_urdf`: where a link or joint is written in xacro.

    Searches the files the last expansion of ``path`` read (the file and its
    includes; before any expansion, the file and the includes written out in
    it) for ``<TAG ... name="NAME"``; returns ``"FILE.xacro:LINE"`` or None
    (the name may be built by an expression, e.g. ``${prefix}_joint``).
    """
    read = _EXPANDED_FILES.get(Path(path).resolve()) or _written_includes(Path(path))
    files = _xacro_search_files(Path(path), read)
    cache: dict[tuple[str, str], str | None] = {}

    def locate(tag: str, name: str) -> str | None:
        key = (tag, name)
        if key not in cache:
            pattern = rf"<{re.escape(tag)}\b[^>]*\bname\s*=\s*[\"']{re.escape(name)}[\"']"
            cache[key] = _find_in_files(files, pattern=pattern)
        return cache[key]

    return locate
