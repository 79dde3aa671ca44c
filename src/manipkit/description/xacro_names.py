"""The names a xacro expression may use, attribute access, and ``xacro.load_yaml`` made safe.

xacro exposes to ``${...}`` the builtins ``list dict map len str float int
bool min max round sorted range``, every public name of :mod:`math` (directly
and as ``math.NAME``), a ``python`` namespace of more builtins and a
``xacro`` namespace (``load_yaml``, ``abs_filename``, ``dotify``, ``arg``,
``message``, ``warning``, ``error``, ``print_location``, ``fatal``,
``tokenize``). :func:`xacro_globals` gives the same names with these
differences:

- ``python.type`` and ``python.vars`` are left out (they reach any object's
  class and ``__dict__``);
- functions whose cost grows with their arguments are bounded (the limits of
  :mod:`manipkit.description.expressions`): ``range`` (at most ``MAX_SIZE``
  items), ``round`` of an integer to ``-n`` digits, ``sum`` (numbers only),
  ``math.factorial``/``comb``/``perm``/``prod``/``lcm`` (results of at most
  ``MAX_INT_BITS`` bits), ``xacro.tokenize`` (its separators are characters, not a
  regular expression); the lazy ``map``, ``zip``, ``filter``, ``enumerate`` and
  ``reversed`` count their items and their nesting (``MAX_VALUE_DEPTH``);
- ``load_yaml`` (:func:`load_yaml`) checks the file first (a regular file of
  at most :data:`MAX_YAML_BYTES`, inside what the description may read:
  :mod:`manipkit.description.access`), reads YAML with PyYAML's safe loader
  (libyaml's parser when installed; plain YAML and xacro's unit tags
  ``!degrees``, ``!radians``, ``!meters``, ``!millimeters``, ``!foot``,
  ``!inches``; no ``!!python`` tags; integers of at most ``MAX_INT_BITS``
  bits), refuses a document whose aliases expand past ``MAX_SIZE`` values and
  characters or ``MAX_VALUE_DEPTH`` levels, and counts its time against the
  expression's and the expansion's budgets.

``$(eval ...)`` has its own names (:func:`eval_lookup`), as in xacro:
``true false True False``, ``arg(NAME)``, ``dirname()``, ``env``,
``optenv``, ``find``, every name of :mod:`math`, the xacro arguments (typed
as xacro types them), and the builtins of the ``python`` namespace (xacro
gives ``$(eval)`` all of Python's builtins, ``open`` and ``exec`` included).

xacro and PyYAML are imported inside the functions that use them.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from pathlib import Path

from manipkit.description.access import check_readable
from manipkit.description.expressions import (
    ALLOWED_ATTRIBUTES,
    MAX_INT_BITS,
    MAX_SIZE,
    MAX_VALUE_DEPTH,
    BoundMethod,
    Namespace,
    bounded_multiply,
    check_time,
    checked_str_method,
    evaluate,
    measure,
    refusal,
    remaining_time,
    value_size,
)
from manipkit.errors import DescriptionError, InputFileError
from manipkit.inputs import read_text

__all__ = [
    "MAX_YAML_BYTES",
    "allowed_call",
    "attribute",
    "eval_lookup",
    "evaluate_eval",
    "evaluate_expression",
    "item",
    "load_yaml",
    "symbol_lookup",
    "xacro_globals",
]


#: Largest YAML file ``xacro.load_yaml`` reads (real configuration files are a few kB; PyYAML reads about
#: 1 MB a second here, and a read cannot be interrupted, so this keeps one read within the time budget).
MAX_YAML_BYTES = 256 * 1024


# --------------------------------------------------------------------------
# Bounded versions of builtins and math functions
# --------------------------------------------------------------------------


def _range(*args):
    result = range(*args)
    try:
        count = len(result)
    except OverflowError:
        count = math.inf
    if count > MAX_SIZE:
        raise refusal(f"range{args} has {count} items, above the limit of {MAX_SIZE}")
    return result


def _round(number, ndigits=None):
    if isinstance(number, int) and isinstance(ndigits, int) and ndigits < -4 * MAX_INT_BITS:
        return 0  # |number| < 2**MAX_INT_BITS < 10**(-ndigits) / 2, so Python's answer is 0 (after computing 10**-ndigits)
    return round(number, ndigits)


def _sum(iterable, start=0):
    if not isinstance(start, (int, float, complex)):
        raise refusal("python.sum adds numbers only here (a list of lists is added in quadratic time); "
                      "use '+' or ''.join")
    return sum(iterable, start)


def _factorial(n):
    if isinstance(n, int) and n > 1 and math.lgamma(n + 1) / math.log(2) > MAX_INT_BITS:
        raise refusal(f"factorial({n}) would have more than {MAX_INT_BITS} bits (the limit)")
    return math.factorial(n)


def _comb(n, k):
    if isinstance(n, int) and n > MAX_INT_BITS:
        raise refusal(f"comb({n}, ...) may have more than {MAX_INT_BITS} bits (the limit)")
    return math.comb(n, k)


def _perm(n, k=None):
    count = n if k is None else k
    if isinstance(n, int) and isinstance(count, int) and count > 0 and count * n.bit_length() > MAX_INT_BITS:
        raise refusal(f"perm({n}, {count}) may have more than {MAX_INT_BITS} bits (the limit)")
    return math.perm(n, k)


def _prod(iterable, *, start=1):
    result = start
    for item in iterable:
        result = bounded_multiply(result, item)
    return result


def _lcm(*integers):
    bits = sum(abs(i).bit_length() for i in integers if isinstance(i, int))
    if bits > MAX_INT_BITS:
        raise refusal(f"lcm of numbers with {bits} bits in all may be above the limit of {MAX_INT_BITS} bits")
    return math.lcm(*integers)


def _tokenize(s, sep=",; ", skip_empty=True):
    """``xacro.tokenize``, with the separators taken as characters (xacro puts them in a regular expression
    unescaped: ``sep="x](a+)+b[y"`` would make one that backtracks without end)."""
    import re

    results = re.split("[" + re.escape(str(sep)) + "]", s)
    return [item for item in results if item] if skip_empty else results


_MATH_BOUNDED = {"factorial": _factorial, "comb": _comb, "perm": _perm, "prod": _prod, "lcm": _lcm}
#: The math functions and constants an expression may use (named, not every name of ``math``: a later Python's
#: ``math.sumprod`` would multiply integers without a bound).
_MATH_NAMES = (
    "acos", "acosh", "asin", "asinh", "atan", "atan2", "atanh", "cbrt", "ceil", "comb", "copysign", "cos", "cosh",
    "degrees", "dist", "e", "erf", "erfc", "exp", "exp2", "expm1", "fabs", "factorial", "floor", "fmod", "frexp",
    "fsum", "gamma", "gcd", "hypot", "inf", "isclose", "isfinite", "isinf", "isnan", "isqrt", "lcm", "ldexp",
    "lgamma", "log", "log10", "log1p", "log2", "modf", "nan", "nextafter", "perm", "pi", "pow", "prod", "radians",
    "remainder", "sin", "sinh", "sqrt", "tan", "tanh", "tau", "trunc", "ulp",
)


class _BoundedIterator:
    """The items of a lazy builtin (``map``, ``zip``, ``filter``, ``enumerate``, ``reversed``), counted.

    ``python.list(python.zip(python.range(N), ...))`` would otherwise build its whole result in C before any
    size check: the items are refused once their sizes add up to more than :data:`MAX_SIZE`, and the time
    budget is checked at every item.
    """

    __slots__ = ("_items", "_size", "_name", "nesting")

    def __init__(self, items, name: str, nesting: int = 1):
        self._items, self._size, self._name = items, 0, name
        #: How deeply lazy objects and values are nested inside this one (a chain of ``python.zip(p)`` through
        #: properties would be a chain of iterators, freed recursively): measured like a container's depth.
        self.nesting = nesting

    def __iter__(self):
        return self

    def __next__(self):
        item = next(self._items)
        self._size += value_size(item)
        if self._size > MAX_SIZE:
            raise refusal(f"python.{self._name}(...) makes more than {MAX_SIZE} characters and items (the limit)")
        if remaining_time() < 0.0:
            raise refusal(f"python.{self._name}(...) ran past the time budget")
        return item


def _bounded_lazy(function):
    def bounded(*args, **kwargs):
        nesting = 1 + max((measure(a)[1] for a in (*args, *kwargs.values())), default=0)
        if nesting > MAX_VALUE_DEPTH:
            raise refusal(f"python.{function.__name__}(...) would be nested more than {MAX_VALUE_DEPTH} levels deep "
                          "(lazy values inside each other; the limit)")
        return _BoundedIterator(function(*args, **kwargs), function.__name__, nesting)

    bounded.__name__ = function.__name__
    return bounded


_MAP, _ZIP, _FILTER, _ENUMERATE, _REVERSED = (_bounded_lazy(f) for f in (map, zip, filter, enumerate, reversed))


# --------------------------------------------------------------------------
# The names
# --------------------------------------------------------------------------


@functools.lru_cache(maxsize=1)
def xacro_globals() -> dict[str, object]:
    """Name -> value for every name a ``${...}`` expression may use besides properties (module docstring)."""
    import xacro

    python = Namespace({
        "list": list, "dict": dict, "map": _MAP, "len": len, "str": str, "float": float, "int": int, "bool": bool,
        "True": True, "False": False, "min": min, "max": max, "round": _round, "abs": abs, "all": all, "any": any,
        "complex": complex, "divmod": divmod, "enumerate": _ENUMERATE, "filter": _FILTER, "frozenset": frozenset,
        "hash": hash, "isinstance": isinstance, "issubclass": issubclass, "ord": ord, "repr": repr,
        "reversed": _REVERSED, "slice": slice, "set": set, "sum": _sum, "tuple": tuple, "zip": _ZIP,
        "sorted": sorted, "range": _range,
    })
    math_names = Namespace({k: _MATH_BOUNDED.get(k, getattr(math, k)) for k in _MATH_NAMES if hasattr(math, k)})
    own = xacro._global_symbols["xacro"]  # xacro's NameSpace: read its entries without lazy evaluation
    xacro_names = Namespace({k: dict.__getitem__(own, k) for k in
                             ("arg", "message", "warning", "error", "print_location", "fatal")})
    xacro_names["tokenize"] = _tokenize
    xacro_names.update(load_yaml=load_yaml, abs_filename=xacro.abs_filename_spec, dotify=xacro.YamlDictWrapper)
    names: dict[str, object] = {k: python[k] for k in ("list", "dict", "map", "len", "str", "float", "int", "bool",
                                                       "True", "False", "min", "max", "round", "sorted", "range")}
    names.update(math_names)
    names.update(load_yaml=load_yaml, abs_filename=xacro.abs_filename_spec, dotify=xacro.YamlDictWrapper)
    names.update(python=python, math=math_names, xacro=xacro_names)
    return names


@functools.lru_cache(maxsize=1)
def _eval_functions() -> dict[str, object]:
    """The names of ``$(eval ...)`` other than the xacro arguments (as xacro's ``substitution_args._eval``)."""
    import xacro
    import xacro.substitution_args as substitution_args

    context = xacro.substitution_args_context
    names: dict[str, object] = {k: v for k, v in xacro_globals()["python"].items()}
    names.update({k: v for k, v in xacro_globals()["math"].items()})
    names.update({
        "true": True, "false": False, "True": True, "False": False,
        "env": lambda name: substitution_args._eval_env(name),
        "optenv": lambda name, default="": substitution_args._eval_optenv(name, default),
        "find": lambda package: substitution_args._eval_find(package),  # looked up at each call: it may be patched
        "arg": lambda name: substitution_args.convert_value(
            substitution_args._eval_arg(name, args=context.get("arg", {})), "auto"),
        "dirname": lambda: substitution_args._eval_dirname(context.get("filename")),
    })
    return names


@functools.lru_cache(maxsize=1)
def _callable_ids() -> frozenset[int]:
    values = [*xacro_globals().values(), *_eval_functions().values()]
    for namespace in ("python", "math", "xacro"):
        values += list(xacro_globals()[namespace].values())
    return frozenset(id(v) for v in values if callable(v))


def allowed_call(value: object) -> bool:
    """Whether an expression may call ``value``: a function or type of the names above, or an allowed method."""
    return isinstance(value, BoundMethod) or id(value) in _callable_ids()


def symbol_lookup(symbols) -> Callable[[str], object]:
    """``lookup(name)`` for a xacro symbol table: the properties in scope (evaluated lazily, as xacro does),
    then :func:`xacro_globals`; ``KeyError`` if neither has it."""
    import xacro

    def lookup(name: str) -> object:
        table = symbols
        while isinstance(table, xacro.Table):
            if dict.__contains__(table, name):
                return table[name]
            table = table.parent
        return xacro_globals()[name]

    return lookup


def eval_lookup(name: str) -> object:
    """``lookup(name)`` for ``$(eval ...)``: its functions and constants, then the xacro arguments."""
    import xacro
    import xacro.substitution_args as substitution_args

    names = _eval_functions()
    if name in names:
        return names[name]
    return substitution_args.convert_value(xacro.substitution_args_context.get("arg", {})[name], "auto")


def attribute(value: object, name: str) -> object:
    """``value.name`` if an expression may read it (module docstring of :mod:`.expressions`), else a refusal."""
    import xacro

    if name.startswith("_"):
        raise refusal(f"attribute '{name}' is not allowed (names starting with '_' are private)")
    if isinstance(value, Namespace):
        if name in value:
            return value[name]
        raise NameError(f"name '{name}' is not defined")
    if isinstance(value, xacro.NameSpace):  # a <xacro:include ns="..."> namespace
        try:
            return symbol_lookup(value)(name)
        except KeyError:
            raise NameError(f"name '{name}' is not defined") from None
    if isinstance(value, xacro.YamlDictWrapper):
        if name in ALLOWED_ATTRIBUTES[dict]:
            return BoundMethod(getattr(value, name), f"dict.{name}")
        if hasattr(dict, name):
            raise refusal(f"method '{name}' of a YAML mapping is not allowed; allowed: "
                          f"{', '.join(sorted(ALLOWED_ATTRIBUTES[dict]))}, or a key")
        try:
            return xacro.YamlListWrapper.wrap(dict.__getitem__(value, name))
        except KeyError:
            raise AttributeError(f"The yaml dictionary has no key '{name}'") from None
    for kind in type(value).__mro__:
        allowed = ALLOWED_ATTRIBUTES.get(kind)
        if allowed is None:
            continue
        if not hasattr(kind, name):  # a plain value (an allowed type): as Python says it
            raise AttributeError(f"'{type(value).__name__}' object has no attribute '{name}'")
        if name not in allowed:
            raise refusal(f"attribute '{name}' of {type(value).__name__} values is not allowed; allowed: "
                          f"{', '.join(sorted(allowed))}")
        found = getattr(value, name)
        if kind is str:
            return BoundMethod(checked_str_method(value, name), f"str.{name}")
        return BoundMethod(found, f"{kind.__name__}.{name}") if callable(found) else found
    raise refusal(f"attribute '{name}' of {type(value).__name__} values is not allowed "
                  "(attributes are read from strings, numbers, lists, dicts, sets, YAML data and namespaces)")


def item(container: object, key: object) -> object:
    """``container[key]``; a xacro symbol table (an include's namespace) is looked up as names are, so
    its parents end at :func:`xacro_globals`, never at xacro's own globals."""
    import xacro

    if isinstance(container, xacro.Table):
        return symbol_lookup(container)(key)
    return container[key]


def evaluate_expression(expression: str, symbols) -> object:
    """The value of ``${expression}`` with xacro symbol table ``symbols`` (xacro's ``safe_eval``, made safe)."""
    return evaluate(str(expression), symbol_lookup(symbols), allowed_call=allowed_call, attribute=attribute,
                    item=item)


def evaluate_eval(expression: str) -> str:
    """The text of ``$(eval expression)`` (xacro's ``substitution_args._eval``, made safe)."""
    value = evaluate(str(expression), eval_lookup, allowed_call=allowed_call, attribute=attribute, item=item,
                     kind="$(eval")
    return str(value)


# --------------------------------------------------------------------------
# xacro.load_yaml
# --------------------------------------------------------------------------


@functools.lru_cache(maxsize=1)
def _yaml_loader():
    """PyYAML's SafeLoader with xacro's unit tags (a subclass: the global SafeLoader is left alone)."""
    import xacro
    import yaml

    class Loader(getattr(yaml, "CSafeLoader", yaml.SafeLoader)):  # libyaml's parser: about 5 times faster
        pass

    def bounded_int(loader, node):  # YAML 1.1 ints: 0x..., 0b..., and base 60 (1:2:3) built digit by digit
        text = loader.construct_scalar(node)
        if len(text) * 6 > MAX_INT_BITS:
            raise refusal(f"a YAML integer of {len(text)} characters may have more than {MAX_INT_BITS} bits (the limit)")
        return yaml.SafeLoader.construct_yaml_int(loader, node)

    Loader.add_constructor("tag:yaml.org,2002:int", bounded_int)

    def unit_constructor(factor: float):
        def construct(loader, node):
            text = loader.construct_scalar(node)
            return float(evaluate(str(text), lambda n: xacro_globals()[n], allowed_call=allowed_call,
                                  attribute=attribute)) * factor
        return construct

    for unit in xacro.ConstructUnits:
        Loader.add_constructor(unit.value.tag, unit_constructor(unit.value.conversion_constant))
    return Loader


def load_yaml(filename) -> object:
    """``xacro.load_yaml``, safely: the file checked before it is read, safe YAML, aliases bounded.

    Raises
    ------
    InputFileError
        Not a regular file (a FIFO, a device, a folder), missing, or above ``MAX_YAML_BYTES``.
    DescriptionError
        Not YAML, a tag other than plain YAML and xacro's units (``!!python/...``), or
        aliases that expand past ``MAX_SIZE`` values and characters.
    """
    import xacro
    import yaml

    if not str(filename).strip():  # an argument left at its default "" (UR's ur.xacro without its *_params)
        raise InputFileError("xacro.load_yaml of an empty file name; give the YAML file (an argument holding "
                             "its path left empty?)")
    filename = xacro.abs_filename_spec(str(filename))
    name = Path(filename).name
    check_time()  # a comprehension of loads: each counts against the evaluation's and the expansion's budgets
    check_readable(filename, "xacro.load_yaml")
    xacro.filestack.append(filename)
    try:
        text = read_text(filename, what="YAML file", max_bytes=MAX_YAML_BYTES)
        try:
            data = yaml.load(text, Loader=_yaml_loader())  # noqa: S506 - a SafeLoader subclass
        except yaml.MarkedYAMLError as exc:
            mark = exc.problem_mark or exc.context_mark
            where = f"{name}:{mark.line + 1}" if mark else name
            problem = " ".join(str(exc.problem or exc.context or "not YAML").split())
            hint = ("; xacro.load_yaml reads plain YAML and the unit tags !radians, !degrees, !meters, "
                    "!millimeters, !foot, !inches") if "constructor for the tag" in problem else ""
            raise DescriptionError(f"{where}: {problem}{hint}") from None
        except yaml.YAMLError as exc:
            raise DescriptionError(f"{name}: not YAML ({' '.join(str(exc).split())})") from None
        except RecursionError:
            raise DescriptionError(f"{name}: YAML nested too deeply") from None
    finally:
        xacro.filestack.pop()
        xacro.all_includes.append(filename)
    size, depth, _ = measure(data, MAX_SIZE)
    if size > MAX_SIZE:
        raise DescriptionError(f"{name}: the YAML document expands (through its aliases) to more than {MAX_SIZE} "
                               "values and characters, the limit; write the values out or use fewer aliases")
    if depth > MAX_VALUE_DEPTH:
        raise DescriptionError(f"{name}: the YAML document expands (through its aliases) to more than "
                               f"{MAX_VALUE_DEPTH} levels of nesting, the limit (real configuration files nest a few "
                               "levels)")
    check_time()
    return xacro.YamlListWrapper.wrap(data)
