"""YAML a user names, loaded with bounds: PyYAML's safe loader, limited while it composes.

:func:`load_yaml` is PyYAML's ``SafeLoader`` (no tags that build objects, so no
code runs) with three bounds checked before any value is built, and two
readings fixed while constructing:

- nesting at most ``max_depth`` deep (PyYAML composes by recursion: a file of
  100,000 ``[`` would otherwise end in a ``RecursionError``);
- at most ``max_nodes`` values counted with repetition, each use of an alias
  counted again (a few nested aliases stand for billions of values);
- a key given twice in one mapping is refused (PyYAML keeps the last silently);
- an integer literal of more than :data:`LONGEST_INTEGER` characters is read as
  the float it denotes (``inf`` beyond 1.8e308), never converted digit by digit
  (Python refuses 4300+ digits, and ``float`` of a 400-digit ``int`` overflows);
- ``1e-3`` and ``-2E5`` are numbers (YAML 1.1, which PyYAML follows, reads a
  float without a dot as text).

Errors are one line naming the file (``where``) and the line, raised as the
caller's ``error`` class.
"""

from __future__ import annotations

import math
import re

from manipkit.text import printable

__all__ = ["LONGEST_INTEGER", "MAX_YAML_DEPTH", "MAX_YAML_NODES", "load_yaml"]

#: Default nesting limit (levels of lists and mappings).
MAX_YAML_DEPTH = 100
#: Default limit on values, each use of an alias counted again.
MAX_YAML_NODES = 1_000_000
#: Integer literals longer than this are read as floats (a 64-bit integer has at most 20 characters).
LONGEST_INTEGER = 20
_EXPONENT_FLOAT = re.compile(r"^[-+]?(?:[0-9][0-9_]*)(?:\.[0-9_]*)?[eE][-+]?[0-9]+$")


def _loader_class(where: str, error: type[Exception], max_depth: int, max_nodes: int):
    import yaml

    class BoundedLoader(yaml.SafeLoader):  # the pure-Python parser: its compose_node can be bounded
        depth = nodes = 0

        def compose_node(self, parent, index):
            event = self.peek_event()
            line = event.start_mark.line + 1
            if self.depth >= max_depth:
                raise error(f"{where}: line {line}: YAML nested more than {max_depth} levels deep")
            self.depth += 1
            try:
                node = super().compose_node(parent, index)
            finally:
                self.depth -= 1
            if parent is None:
                _count_nodes(node, where, error, max_nodes)
            return node

    def construct_mapping(loader, node, deep=False):
        seen = {}
        for key_node, _ in node.value:
            if isinstance(key_node, yaml.ScalarNode):
                if key_node.value in seen:
                    raise error(f"{where}: line {key_node.start_mark.line + 1}: key "
                                f"'{printable(key_node.value)[:40]}' given twice (first at line {seen[key_node.value]}); "
                                "keep one")
                seen[key_node.value] = key_node.start_mark.line + 1
        return yaml.SafeLoader.construct_mapping(loader, node, deep=deep)

    def construct_integer(loader, node):
        if len(node.value) > LONGEST_INTEGER:
            try:
                value = float(node.value.replace("_", ""))
            except ValueError:  # hexadecimal, octal or base 60: the text, refused where a number is due
                return loader.construct_scalar(node)
            if math.isinf(value):  # not inf: the file holds no infinity, but an integer beyond every float
                digits = sum(c.isdigit() for c in node.value)
                raise error(f"{where}: line {node.start_mark.line + 1}: an integer of {digits} digits, beyond the "
                            "range of numbers (about 1.8e308)")
            return value
        return yaml.SafeLoader.construct_yaml_int(loader, node)

    BoundedLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, construct_mapping)
    BoundedLoader.add_constructor("tag:yaml.org,2002:int", construct_integer)
    BoundedLoader.add_implicit_resolver("tag:yaml.org,2002:float", _EXPONENT_FLOAT, list("-+0123456789"))
    return BoundedLoader


def _count_nodes(root, where: str, error: type[Exception], max_nodes: int) -> None:
    """Refuse a node graph of more than ``max_nodes`` nodes counted with repetition, walked without recursion."""
    stack, seen = [root], 0
    while stack:
        node = stack.pop()
        seen += 1
        if seen > max_nodes:
            raise error(f"{where}: more than {max_nodes} YAML values (each use of an alias counted)")
        if isinstance(node.value, list):
            for item in node.value:
                stack.extend(item if isinstance(item, tuple) else (item,))


def load_yaml(text: str, where: str, *, error: type[Exception], max_depth: int = MAX_YAML_DEPTH,
              max_nodes: int = MAX_YAML_NODES):
    """The YAML document in ``text``, bounded as the module says, else one line as ``error``.

    Parameters
    ----------
    text : str
        The file's text (read through :func:`manipkit.inputs.files.read_text`, which bounds its size).
    where : str
        The file's printable name, for the messages.
    error : exception class, keyword-only
        The :class:`manipkit.errors.ManipkitError` subclass to raise.
    max_depth, max_nodes : int, keyword-only
        Nesting levels and values (aliases counted each time used) allowed.

    Examples
    --------
    >>> from manipkit.errors import InputFileError
    >>> load_yaml("- {xyz: [1e-3, 0, 1], t: 0}", "a.yaml", error=InputFileError)
    [{'xyz': [0.001, 0, 1], 't': 0}]
    """
    import yaml

    try:
        return yaml.load(text, Loader=_loader_class(where, error, max_depth, max_nodes))  # noqa: S506 - a SafeLoader
    except error:
        raise
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None) or getattr(exc, "context_mark", None)
        at = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise error(f"{where}: malformed YAML{at}: {printable(problem)[:200]}") from None
    except RecursionError:  # a bound above the interpreter's stack: still one line
        raise error(f"{where}: YAML nested too deeply") from None
    except (ValueError, OverflowError) as exc:  # a value PyYAML's constructors cannot build (a date out of range)
        raise error(f"{where}: a value cannot be read ({printable(' '.join(str(exc).split()))[:200]})") from None
