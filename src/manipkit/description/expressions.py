"""Safe evaluation of xacro expressions (``${...}`` and ``$(eval ...)``), with bounded cost.

xacro evaluates every ``${...}`` with Python's ``eval`` and checks only the
expression's top-level names, so a lambda or a comprehension reaches
``().__class__.__base__.__subclasses__()`` and runs commands. Here an
expression is parsed to an AST, checked as a whole, then walked by
`simpleeval <https://pypi.org/project/simpleeval/>`_ (an AST evaluator that
has no ``eval``), extended with the rules below.

What an expression may contain (checked before anything is evaluated, at
every depth of the tree, in branches that would not run too):

- literals (numbers, strings, lists, tuples, dicts, sets), names (xacro
  properties and arguments, and the functions and constants of
  :mod:`manipkit.description.xacro_names`), arithmetic, comparisons,
  ``and``/``or``/``not``, ``a if c else b``, subscripts and slices,
  comprehensions (genexps become lists), f-strings;
- calls of allow-listed functions only (a name's value must be one of them);
- attribute access only to allow-listed methods and attributes of plain
  values (``'a b'.split()``, ``x.real``), to keys of YAML mappings
  (``config.joint``) and to names in a namespace (``math.pi``); never to a
  name starting with ``_``;
- no lambda, no ``:=``, no ``@``, no ``await``/``yield``, no statements.

What an evaluation may cost (:mod:`manipkit.description.expression_limits`,
estimated before a value is built wherever it could be large): a string or
container at most :data:`MAX_SIZE` characters and items (counted through
nesting, slices included), nested at most :data:`MAX_VALUE_DEPTH` levels, an
integer at most :data:`MAX_INT_BITS` bits (``9**9**9``, ``int('f' * 10**6, 16)``
and a 10,000-digit hex literal are refused before they are computed), a
``%``/``str.format``/f-string text at most :data:`MAX_SIZE` characters
(estimated from its widths and arguments), a comprehension at most
:data:`MAX_ITERATIONS` steps, an expression at most :data:`MAX_DEPTH` levels
of nesting, and an evaluation (with the properties it evaluates and the YAML
files it reads on the way) at most :data:`TIME_BUDGET_S` seconds, within the
budget of the whole expansion (:func:`expansion_deadline`).

Every refusal is a :class:`~manipkit.errors.DescriptionError` whose message
is one line, ``xacro expression ${EXPR}: REASON``; the error carries
``expression`` and ``reason`` attributes so the caller can name the file and
line (:mod:`manipkit.description.xacro`).
"""

from __future__ import annotations

import ast
import contextlib
import gc
import html
import math
import operator
import threading
import time
from collections.abc import Callable

try:
    import resource
except ImportError:  # not on Windows: the thread's CPU time is the clock there
    resource = None

import simpleeval

from manipkit.description.expression_limits import (
    MAX_INT_BITS,
    MAX_SIZE,
    MAX_VALUE_DEPTH,
    OPERATORS,
    bounded_multiply,
    check_format_string,
    check_percent_format,
    check_size,
    check_text_estimate,
    checked_call,
    checked_str_method,
    measure,
    spec_width,
    text_estimate,
    value_size,
)
from manipkit.description.expression_limits import Refused as _Refused
from manipkit.errors import DescriptionError, ManipkitError
from manipkit.text import printable

__all__ = [
    "ALLOWED_SYNTAX",
    "MAX_DEPTH",
    "MAX_INT_BITS",
    "MAX_ITERATIONS",
    "MAX_SIZE",
    "MAX_VALUE_DEPTH",
    "TIME_BUDGET_S",
    "ALLOWED_ATTRIBUTES",
    "OPERATORS",
    "BoundMethod",
    "Namespace",
    "bounded_multiply",
    "check_format_string",
    "check_percent_format",
    "check_size",
    "checked_call",
    "checked_str_method",
    "evaluate",
    "measure",
    "error_reason",
    "expression_error",
    "check_time",
    "expansion_deadline",
    "parse_expression",
    "refusal",
    "remaining_time",
    "text_estimate",
    "value_size",
]

#: Most steps of all comprehensions in one expression (simpleeval's own limit).
MAX_ITERATIONS = simpleeval.MAX_COMPREHENSION_LENGTH
#: Deepest nesting of an expression's syntax tree.
MAX_DEPTH = 100
#: Seconds one evaluation may take, including the properties it evaluates on the way.
TIME_BUDGET_S = 2.0

VALID = ("an expression may use numbers, strings, properties, arithmetic, comparisons, and/or/not, "
         "'a if c else b', subscripts, comprehensions and calls of math, python and xacro functions")

# Syntax (ast node types) an expression may contain; everything else is refused by name.
ALLOWED_SYNTAX: frozenset[type] = frozenset({
    ast.Expression, ast.Constant, ast.Name, ast.Load, ast.Store,
    ast.UnaryOp, ast.UAdd, ast.USub, ast.Not, ast.Invert,
    ast.BinOp, ast.Add, ast.Sub, ast.Mult, ast.Div, ast.FloorDiv, ast.Mod, ast.Pow,
    ast.LShift, ast.RShift, ast.BitOr, ast.BitXor, ast.BitAnd,
    ast.BoolOp, ast.And, ast.Or,
    ast.Compare, ast.Eq, ast.NotEq, ast.Lt, ast.LtE, ast.Gt, ast.GtE, ast.Is, ast.IsNot, ast.In, ast.NotIn,
    ast.IfExp, ast.Call, ast.keyword, ast.Starred, ast.Attribute, ast.Subscript, ast.Slice,
    ast.List, ast.Tuple, ast.Dict, ast.Set,
    ast.ListComp, ast.SetComp, ast.DictComp, ast.GeneratorExp, ast.comprehension,
    ast.JoinedStr, ast.FormattedValue,
})
_SYNTAX_NAMES = {
    ast.Lambda: "lambda", ast.NamedExpr: "assignment (:=)", ast.MatMult: "the @ operator",
    ast.Await: "await", ast.Yield: "yield", ast.YieldFrom: "yield from",
}


def expression_error(expression: str, reason: str, *, kind: str = "${",
                     error_class: type[DescriptionError] = DescriptionError) -> DescriptionError:
    """``DescriptionError("xacro expression ${EXPR}: REASON")`` (or ``error_class``), one line, with ``expression``
    and ``reason`` attributes."""
    shown = printable(" ".join(str(expression).split()))  # text from a description: no terminal controls
    opening, closing = ("${", "}") if kind == "${" else ("$(eval ", ")")
    error = error_class(f"xacro expression {opening}{shown}{closing}: {printable(' '.join(str(reason).split()))}")
    error.expression, error.reason, error.kind = str(expression), " ".join(str(reason).split()), kind
    escaped = html.escape(str(expression), quote=False).replace('"', "&quot;")  # as written in an XML attribute
    error.needles = tuple(dict.fromkeys((f"{opening}{expression}{closing}", f"{opening}{escaped}{closing}",
                                         f"{opening}{expression}", str(expression), escaped)))  # to find its line
    return error


def refusal(reason: str) -> Exception:
    """The exception to raise from a function an expression calls when it refuses its arguments
    (:func:`evaluate` turns it into ``xacro expression ${EXPR}: REASON``)."""
    return _Refused(reason)


def error_reason(exc: BaseException) -> str:
    """One-line reason for an exception raised while evaluating (``KeyError('a')`` -> ``no key 'a'``)."""
    text = " ".join(str(exc).split()) or type(exc).__name__
    return f"no key {text}" if isinstance(exc, KeyError) else text


def parse_expression(expression: str) -> ast.Expression:
    """The expression's syntax tree, checked: allowed syntax only, no private names, bounded depth.

    Raises ``_Refused`` (internal) with the reason.
    """
    try:
        tree = ast.parse(expression.strip(), mode="eval")
    except SyntaxError as exc:
        raise _Refused(exc.msg or "invalid syntax") from None
    except (RecursionError, MemoryError, ValueError) as exc:  # nesting beyond the parser, a NUL byte
        raise _Refused(f"not a valid expression ({type(exc).__name__}: {exc})") from None
    stack = [(tree, 1)]
    while stack:
        node, depth = stack.pop()
        if depth > MAX_DEPTH:
            raise _Refused(f"nested more than {MAX_DEPTH} levels deep")
        kind = type(node)
        if kind not in ALLOWED_SYNTAX:
            what = _SYNTAX_NAMES.get(kind, kind.__name__)
            raise _Refused(f"{what} is not allowed; {VALID}")
        if kind is ast.Attribute and node.attr.startswith("_"):
            raise _Refused(f"attribute '{node.attr}' is not allowed (names starting with '_' are private)")
        if kind is ast.Name and node.id.startswith("__"):
            raise _Refused(f"name '{node.id}' is not allowed (names starting with '__' are private)")
        if kind is ast.comprehension and not all(isinstance(t, (ast.Name, ast.Tuple, ast.List))
                                                 for t in ast.walk(node.target) if not isinstance(t, ast.Store)):
            raise _Refused(f"a comprehension assigns to names only, not to '{ast.unparse(node.target)}'")
        if kind is ast.Constant and isinstance(node.value, (str, bytes)) and len(node.value) > MAX_SIZE:
            raise _Refused(f"a literal of {len(node.value)} characters, above the limit of {MAX_SIZE}")
        if kind is ast.Constant and type(node.value) is int and node.value.bit_length() > MAX_INT_BITS:
            raise _Refused(f"an integer literal of {node.value.bit_length()} bits, above the limit of "
                           f"{MAX_INT_BITS} bits")
        stack.extend((child, depth + 1) for child in ast.iter_child_nodes(node))
    return tree


# --------------------------------------------------------------------------
# Sizes and bounded operators
# --------------------------------------------------------------------------



# --------------------------------------------------------------------------
# Names, methods and namespaces
# --------------------------------------------------------------------------


class Namespace(dict):
    """Names reached with a dot (``math.pi``, ``python.range``, ``xacro.load_yaml``): a plain mapping."""


class BoundMethod:
    """An allow-listed method of a value, bound to it (``'a b'.split``); calling it may be checked first."""

    __slots__ = ("function", "name")

    def __init__(self, function: Callable, name: str):
        self.function, self.name = function, name

    def __call__(self, *args, **kwargs):
        return self.function(*args, **kwargs)

    def __repr__(self) -> str:
        return f"<method {self.name}>"


_STR_METHODS = frozenset((
    "capitalize casefold center count endswith find format index isalnum isalpha isascii isdecimal isdigit "
    "isidentifier islower isnumeric isprintable isspace istitle isupper join ljust lower lstrip partition "
    "removeprefix removesuffix replace rfind rindex rjust rpartition rsplit rstrip split splitlines "
    "startswith strip swapcase title upper zfill").split())
_NUMBER_ATTRIBUTES = frozenset(("as_integer_ratio", "bit_length", "conjugate", "denominator", "imag", "is_integer",
                                "numerator", "real", "hex"))
#: Attributes allowed on values of each type (methods that build or mutate nothing unbounded).
ALLOWED_ATTRIBUTES: dict[type, frozenset[str]] = {
    str: _STR_METHODS,
    bool: _NUMBER_ATTRIBUTES, int: _NUMBER_ATTRIBUTES, float: _NUMBER_ATTRIBUTES, complex: _NUMBER_ATTRIBUTES,
    list: frozenset(("count", "copy", "index")),
    tuple: frozenset(("count", "index")),
    dict: frozenset(("copy", "get", "items", "keys", "values")),
    set: frozenset(("copy", "difference", "intersection", "isdisjoint", "issubset", "issuperset",
                    "symmetric_difference", "union")),
    frozenset: frozenset(("copy", "difference", "intersection", "isdisjoint", "issubset", "issuperset",
                          "symmetric_difference", "union")),
    slice: frozenset(("start", "step", "stop")),
}


# --------------------------------------------------------------------------
# The evaluator
# --------------------------------------------------------------------------

class _OutOfExpansionTime(Exception):
    """Internal: the expansion around the evaluation is out of time (a plain DescriptionError: no one expression
    is to blame)."""


# One expression's budget is the expanding thread's own computing time, not wall time: a loaded machine (a test
# run beside others) made a plain ${name} exceed 2 s of wall time, and later 2 s of thread CPU time (time spent in
# the kernel on the thread's behalf, reclaiming memory for it, or in a garbage collection of everything the process
# holds, which the expression did not cause). So the clock is the thread's user CPU time (getrusage RUSAGE_THREAD)
# less the garbage collections run on it; an expression that computes forever still spends it and is stopped. The
# whole expansion's budget stays wall time (time.monotonic), so a hostile description is stopped after 30 s
# however busy the machine is.
# Both are kept per thread: the clock is the calling thread's, and an evaluation under way in one thread (a robot
# loaded in a worker thread) must neither lend its deadline to another thread nor be cleared by it.
_local = threading.local()


def _collection_seconds() -> float:
    """Seconds of garbage collection this thread has run so far (counted by :func:`_count_collection`)."""
    return getattr(_local, "collected", 0.0)


def _count_collection(phase: str, info: dict) -> None:
    # on the budget's own clock (this thread's user CPU): wall time would count the collection's waits for the
    # processor too, and on a loaded machine take more off the budget than the collection used
    if phase == "start":
        _local.collecting = _thread_user_seconds()
    elif hasattr(_local, "collecting"):
        _local.collected = _collection_seconds() + _thread_user_seconds() - _local.collecting
        del _local.collecting


gc.callbacks.append(_count_collection)


def _thread_user_seconds() -> float:
    """This thread's user CPU seconds."""
    try:
        return resource.getrusage(resource.RUSAGE_THREAD).ru_utime
    except (AttributeError, OSError):  # no per-thread usage on this platform (no resource, no RUSAGE_THREAD)
        return time.thread_time()


def _computing_time() -> float:
    """This thread's user CPU seconds less its garbage collections: the clock of one expression's budget."""
    return _thread_user_seconds() - _collection_seconds()


def _budgets() -> tuple[list[float], list[tuple[float, str]]]:
    """This thread's (deadline of the outermost evaluation under way, nested ones share it; (deadline, reason)
    of each expansion under way, :func:`expansion_deadline`)."""
    if not hasattr(_local, "deadline"):
        _local.deadline, _local.outer = [], []
    return _local.deadline, _local.outer


def remaining_time() -> float:
    """Seconds left in the evaluation under way (``inf`` when none is)."""
    deadline, _ = _budgets()
    return deadline[0] - _computing_time() if deadline else math.inf


@contextlib.contextmanager
def expansion_deadline(deadline: float, reason: str):
    """Within this block no evaluation runs past ``deadline`` (``time.monotonic()``), refused with ``reason``:
    the budget of a whole expansion, which every evaluation (and every YAML file read) counts against."""
    _, outer = _budgets()
    outer.append((deadline, reason))
    try:
        yield
    finally:
        outer.pop()


def _check_time() -> None:
    deadline, outer = _budgets()
    if outer and time.monotonic() > outer[-1][0]:  # the expansion's budget first: it is the one that ends everything
        raise _OutOfExpansionTime(outer[-1][1])
    if deadline and _computing_time() > deadline[0]:
        raise _Refused(f"evaluation took more than {TIME_BUDGET_S:g} s (the time budget)")


def check_time() -> None:
    """Refuse (``_Refused``) once the evaluation under way, or the expansion around it, is out of time."""
    _check_time()


class _Evaluator(simpleeval.EvalWithCompoundTypes):
    """simpleeval, with xacro's names, allow-listed calls and attributes, and bounded cost."""

    def __init__(self, lookup: Callable[[str], object], allowed_call: Callable[[object], bool],
                 attribute: Callable[[object, str], object], item: Callable[[object, object], object]):
        super().__init__(operators=OPERATORS, functions={}, names={})
        self.lookup, self.allowed_call, self.attribute, self.item = lookup, allowed_call, attribute, item
        self._max_count = 0  # comprehension steps so far
        self.nodes[ast.SetComp] = lambda node: set(self._eval_comprehension(node))
        self.nodes[ast.Starred] = self._eval_starred

    def _eval(self, node):
        _check_time()
        return super()._eval(node)

    def _check_disallowed_items(self, item):
        """Nothing to do: every name and attribute is allow-listed already (simpleeval's walk of each
        result through nested containers would cost the size of every value at every node)."""

    def _eval_starred(self, node):
        raise _Refused("*value is only allowed inside a call or a list, tuple or set")

    def _eval_constant(self, node):
        return node.value

    def _eval_name(self, node):
        try:
            return self.lookup(node.id)
        except KeyError:
            raise NameError(f"name '{node.id}' is not defined") from None

    def _eval_attribute(self, node):
        return self.attribute(self._eval(node.value), node.attr)

    def _eval_subscript(self, node):
        container = self._eval(node.value)
        return self.item(container, self._eval(node.slice))

    def _items(self, nodes) -> list:
        items = []
        for item in nodes:
            if isinstance(item, ast.Starred):
                items.extend(self._eval(item.value))
            else:
                items.append(self._eval(item))
        return items

    def _eval_list(self, node):
        return check_size(self._items(node.elts), "the list")

    def _eval_tuple(self, node):
        return check_size(tuple(self._items(node.elts)), "the tuple")

    def _eval_set(self, node):
        return check_size(set(self._items(node.elts)), "the set")

    def _eval_dict(self, node):
        result = {}
        for key, value in zip(node.keys, node.values):  # key before value, as Python (simpleeval: value first)
            if key is None:
                result.update(self._eval(value))
            else:
                evaluated = self._eval(key)
                result[evaluated] = self._eval(value)
        return check_size(result, "the dict")

    def _eval_comprehension(self, node):
        """List, set, dict comprehensions and generator expressions (made lists), as Python runs them,
        counting steps (:data:`MAX_ITERATIONS`) and the size of the result as it grows (:data:`MAX_SIZE`)."""
        result: list | dict = {} if isinstance(node, ast.DictComp) else []
        scope: dict[str, object] = {}
        size = 0
        enclosing = self.nodes[ast.Name]

        def name(name_node):
            return scope[name_node.id] if name_node.id in scope else enclosing(name_node)

        def bind(target, value) -> None:
            if isinstance(target, ast.Name):
                scope[target.id] = value
                return
            values = list(check_size(value, "the unpacked value") if isinstance(value, (str, bytes)) else value)
            if len(values) != len(target.elts):
                raise ValueError(f"cannot unpack {len(values)} values into {len(target.elts)} names")
            for part, item in zip(target.elts, values):
                bind(part, item)

        def run(index: int) -> None:
            nonlocal size
            generator = node.generators[index]
            for item in self._eval(generator.iter):
                self._max_count += 1
                if self._max_count > MAX_ITERATIONS:
                    raise _Refused(f"comprehensions ran more than {MAX_ITERATIONS} steps (the limit)")
                _check_time()
                bind(generator.target, item)
                if not all(self._eval(test) for test in generator.ifs):
                    continue
                if index + 1 < len(node.generators):
                    run(index + 1)
                    continue
                if isinstance(result, dict):
                    key = self._eval(node.key)
                    result[key] = value = self._eval(node.value)
                    size += value_size(key, MAX_SIZE) + value_size(value, MAX_SIZE)
                else:
                    result.append(self._eval(node.elt))
                    size += value_size(result[-1], MAX_SIZE)
                if size > MAX_SIZE:
                    raise _Refused(f"the comprehension would have more than {MAX_SIZE} characters and items (the limit)")

        self.nodes[ast.Name] = name
        try:
            run(0)
        finally:
            self.nodes[ast.Name] = enclosing
        return result

    def _eval_call(self, node):
        function = self._eval(node.func)
        if not callable(function):  # as Python says it
            raise TypeError(f"'{type(function).__name__}' object is not callable")
        if not self.allowed_call(function):
            what = ast.unparse(node.func)
            raise _Refused(f"calling {what} is not allowed; callable are the math, python and xacro functions, "
                           "str/int/float/bool/list/dict/tuple/set, and methods of plain values")
        args = self._items(node.args)
        kwargs = {}
        for keyword in node.keywords:
            if keyword.arg is None:
                kwargs.update(self._eval(keyword.value))
            else:
                kwargs[keyword.arg] = self._eval(keyword.value)
        checked_call(function, args, kwargs)
        return check_size(function(*args, **kwargs), f"the result of {ast.unparse(node.func)}()")

    def _eval_joinedstr(self, node):
        parts, size = [], 0
        for value in node.values:
            parts.append(str(self._eval(value)))
            size += len(parts[-1])
            if size > MAX_SIZE:
                raise _Refused(f"the f-string would have more than {MAX_SIZE} characters (the limit)")
        return "".join(parts)

    def _eval_formattedvalue(self, node):
        value = self._eval(node.value)
        spec = self._eval(node.format_spec) if node.format_spec is not None else ""
        width = spec_width(str(spec))
        check_text_estimate(width + text_estimate(value, quoted=node.conversion in (114, 97)),
                             f"the f-string field {{{ast.unparse(node.value)}}}")
        value = {115: str, 114: repr, 97: ascii}.get(node.conversion, lambda v: v)(value)
        return format(value, spec)


def _located_error(exc: BaseException) -> ManipkitError | None:
    """The first error with ``needles`` (it names its own expression) in ``exc`` and what it wraps."""
    seen: list[BaseException] = []
    while exc is not None and all(exc is not e for e in seen):
        if isinstance(exc, ManipkitError) and getattr(exc, "needles", None):
            return exc
        seen.append(exc)
        exc = getattr(exc, "exc", None) or exc.__cause__ or exc.__context__  # xacro's XacroException keeps .exc
    return None


def evaluate(expression: str, lookup: Callable[[str], object], *, allowed_call: Callable[[object], bool],
             attribute: Callable[[object, str], object], item: Callable[[object, object], object] = operator.getitem,
             kind: str = "${") -> object:
    """The value of a xacro expression, evaluated safely (module docstring).

    Parameters
    ----------
    expression : str
        The text inside ``${...}`` (or ``$(eval ...)``).
    lookup : callable
        ``lookup(name)`` -> the value of a name, or ``KeyError``.
    allowed_call : callable
        ``allowed_call(value)`` -> whether ``value`` may be called.
    attribute : callable
        ``attribute(value, name)`` -> ``value.name`` if allowed, else raises ``_Refused``
        (see :mod:`manipkit.description.xacro_names`).
    item : callable, keyword-only
        ``item(container, key)`` -> ``container[key]`` (a symbol table is looked up as names are).
    kind : str, keyword-only
        ``"${"`` or ``"$(eval"``, for messages.

    Raises
    ------
    DescriptionError
        Refused syntax, names, calls or attributes, a limit exceeded, or an error of
        the evaluation itself (``name 'x' is not defined``, ``division by zero``), as
        one line ``xacro expression ${EXPR}: REASON``.
    """
    deadline, _ = _budgets()
    outermost = not deadline
    if outermost:
        deadline.append(_computing_time() + TIME_BUDGET_S)
    try:
        tree = parse_expression(expression)
        evaluator = _Evaluator(lookup, allowed_call, attribute, item)
        evaluator.expr = expression
        result = evaluator._eval(tree.body)
        return check_size(result, "the result")
    except _OutOfExpansionTime as exc:
        error = DescriptionError(str(exc))
        error.out_of_time = True  # passed on as it is by the evaluations around this one
        raise error from None
    except _Refused as exc:
        raise expression_error(expression, str(exc), kind=kind) from None
    except RecursionError:
        raise expression_error(expression, "nested too deeply", kind=kind) from None
    except MemoryError:
        raise expression_error(expression, "out of memory", kind=kind) from None
    except Exception as exc:  # noqa: BLE001 - a refusal from a function, or an error of the evaluation itself
        if getattr(exc, "out_of_time", False):
            raise
        located = _located_error(exc)
        if located is not None:
            raise located from None  # from a property evaluated on the way: it names its own expression or text
        kept = type(exc) if isinstance(exc, DescriptionError) else DescriptionError  # ReadNotAllowedError stays one
        raise expression_error(expression, error_reason(exc), kind=kind, error_class=kept) from None
    finally:
        if outermost:
            deadline.clear()
