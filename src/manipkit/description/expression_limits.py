"""What a xacro expression may build, estimated before it is built (:mod:`manipkit.description.expressions`).

Every value an expression makes is bounded: strings and containers by
:data:`MAX_SIZE` characters and items (counted through nesting, slices
included), nesting by :data:`MAX_VALUE_DEPTH`, integers by
:data:`MAX_INT_BITS` bits. The operators and builtins whose result can be
large or slow (``* ** << + % //``, ``divmod``, ``int(text, base)``,
``str``/``repr``, ``%`` and ``str.format`` formatting, f-string fields, string
methods that pad or replace) estimate the result from their operands first
and refuse it (:class:`Refused`) before it is built; every result is
measured after (:func:`check_size`).
"""

from __future__ import annotations

import ast
import math
import operator
import re
import string
from collections.abc import Callable

import simpleeval

from manipkit.inputs import MAX_TABLE_BYTES

__all__ = [
    "MAX_INT_BITS",
    "MAX_SIZE",
    "MAX_VALUE_DEPTH",
    "OPERATORS",
    "Refused",
    "bounded_multiply",
    "check_format_string",
    "check_percent_format",
    "check_size",
    "check_text_estimate",
    "checked_call",
    "checked_str_method",
    "measure",
    "spec_width",
    "text_estimate",
    "value_size",
]

#: Most bits of an integer made by ``**``, ``*`` or ``<<`` (about 3,000 digits).
MAX_INT_BITS = 10_000
#: Most characters and items of a string or container an expression builds (counted through nesting);
#: as large as the largest YAML file ``xacro.load_yaml`` reads (``manipkit.inputs.MAX_TABLE_BYTES``).
MAX_SIZE = MAX_TABLE_BYTES
#: Deepest nesting of a value an expression builds or a YAML file holds (lists, tuples, dicts, sets and slices
#: inside each other; real descriptions nest a few levels). A deeper chain could crash the interpreter when freed.
MAX_VALUE_DEPTH = 100


class Refused(Exception):
    """An expression is refused for the reason given (turned into a one-line ``DescriptionError`` by
    :func:`manipkit.description.expressions.evaluate`)."""


_WORD = 2**63  # an int below this in size counts as one item (1 + bit_length // 64)


def measure(value: object, limit: int = MAX_SIZE) -> tuple[int, int, int]:
    """``(size, depth, bits)`` of ``value``: characters plus items counted through nesting (shared parts each
    time, slices and their start, stop and step included), the deepest nesting of containers and slices (a plain
    value is depth 0), and the most bits of an integer in it. The walk stops once the size passes ``limit`` or
    the depth passes :data:`MAX_VALUE_DEPTH` (no recursion: a chain of a million slices is measured safely)."""
    kind = type(value)
    if kind is str:  # most values an expansion measures: the walk below gives the same
        return len(value) or 1, 0, 0
    if kind is float:
        return 1, 0, 0
    total, deepest, bits, stack = 0, 0, 0, [(value, 0)]
    while stack:
        item, depth = stack.pop()
        deepest = max(deepest, depth)
        if isinstance(item, (str, bytes, bytearray)):
            total += len(item) or 1
        elif isinstance(item, dict):
            total += 1
            stack.extend((x, depth + 1) for x in item.keys())
            stack.extend((x, depth + 1) for x in item.values())
        elif isinstance(item, (list, tuple, set, frozenset)):
            total += 1
            if all(type(x) is float or (type(x) is int and -_WORD < x < _WORD) for x in item):
                total += len(item)  # flat numbers count one each: a zip of ranges is millions of these
                deepest = max(deepest, depth + bool(item))
            else:
                stack.extend((x, depth + 1) for x in item)
        elif isinstance(item, slice):
            total += 1
            stack.extend(((item.start, depth + 1), (item.stop, depth + 1), (item.step, depth + 1)))
        elif isinstance(item, range):
            total += len(item)
        elif isinstance(item, int) and not isinstance(item, bool):
            total += 1 + item.bit_length() // 64
            bits = max(bits, item.bit_length())
        else:
            total += 1
            deepest = max(deepest, depth + getattr(item, "nesting", 0))  # a lazy python.map/zip/...: its own count
        if total > limit or deepest > MAX_VALUE_DEPTH:
            break
    return total, deepest, bits


def value_size(value: object, limit: int = MAX_SIZE) -> int:
    """Characters plus items of ``value``, counted through nesting (shared parts each time), stopping past ``limit``."""
    return measure(value, limit)[0]


def check_size(value: object, what: str = "the value") -> object:
    """``value`` if it is within the bounds of what an expression may build, else ``Refused``: at most
    :data:`MAX_SIZE` characters and items, nested at most :data:`MAX_VALUE_DEPTH` levels (containers and
    slices), integers of at most :data:`MAX_INT_BITS` bits."""
    if isinstance(value, (float, bool, type(None))):
        return value
    if _is_int(value):
        if value.bit_length() > MAX_INT_BITS:
            raise Refused(f"{what} would be an integer of {value.bit_length()} bits, above the limit of "
                           f"{MAX_INT_BITS} bits")
        return value
    size, depth, bits = measure(value)
    if size > MAX_SIZE:
        raise Refused(f"{what} would have more than {MAX_SIZE} characters and items (the limit)")
    if depth > MAX_VALUE_DEPTH:
        raise Refused(f"{what} would be nested more than {MAX_VALUE_DEPTH} levels deep (lists, tuples, dicts, "
                       "sets and slices inside each other; the limit)")
    if bits > MAX_INT_BITS:
        raise Refused(f"{what} would hold an integer of {bits} bits, above the limit of {MAX_INT_BITS} bits")
    return value


def text_estimate(value: object, limit: int = MAX_SIZE, *, quoted: bool = False) -> int:
    """An upper bound of ``len(str(value))`` (``len(repr(value))`` with ``quoted``), found without building
    the text: a string is its length (up to 10 characters for each one ``repr`` escapes), an integer
    0.31 digits per bit, a float 25, a container the sum of its items' ``repr`` and separators. Stops
    once past ``limit``."""
    total, stack = 0, [(value, quoted)]
    while stack and total <= limit:
        item, in_repr = stack.pop()
        if isinstance(item, str):
            if not in_repr:
                total += len(item)
            elif item.isascii() and item.isprintable():
                total += len(item) + item.count("\\") + item.count("'") + 2
            else:
                total += 10 * len(item) + 2
        elif isinstance(item, (bytes, bytearray)):
            total += 4 * len(item) + 14
        elif isinstance(item, bool) or item is None:
            total += 5
        elif isinstance(item, int):
            total += int(item.bit_length() * 0.302) + 2
        elif isinstance(item, (float, complex)):
            total += 50
        elif isinstance(item, dict):
            total += 2 + 4 * len(item) + 30  # braces, ': ' and ', '; a wrapper's name
            stack.extend((x, True) for x in item.keys())
            stack.extend((x, True) for x in item.values())
        elif isinstance(item, (list, tuple, set, frozenset)):
            total += 2 + 2 * len(item) + 12  # brackets, ', ', 'frozenset(' ... ')'
            stack.extend((x, True) for x in item)
        elif isinstance(item, slice):
            total += 20
            stack.extend(((item.start, True), (item.stop, True), (item.step, True)))
        elif isinstance(item, range):
            total += 60
        else:
            total += 200  # '<method str.split>' and the like
    return total


def check_text_estimate(estimate: int, what: str) -> None:
    if estimate > MAX_SIZE:
        raise Refused(f"{what} would have about {estimate} characters or more, above the limit of {MAX_SIZE}")


def _is_int(value: object) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _bits_refused(left, op: str, right, bits: float) -> Refused:
    return Refused(f"{_short(left)} {op} {_short(right)} would have about {bits:.3g} bits, "
                    f"above the limit of {MAX_INT_BITS} bits")


def _short(value: object) -> str:
    text = repr(value) if not _is_int(value) or value.bit_length() < 64 else f"<{value.bit_length()}-bit integer>"
    return text if len(text) <= 40 else text[:37] + "..."


def _power(left, right):
    if _is_int(left) and _is_int(right) and right > 0 and abs(left) > 1:
        bits = right * left.bit_length()
        if bits > MAX_INT_BITS:
            raise _bits_refused(left, "**", right, bits)
    return left ** right


def _repeat_size(sequence, count) -> None:
    if isinstance(sequence, (str, bytes, list, tuple)) and isinstance(count, int):
        size = value_size(sequence) * max(int(count), 0)
        if size > MAX_SIZE:
            raise Refused(f"repeating a {type(sequence).__name__} of size {value_size(sequence)} {count} times "
                           f"would make {size} characters and items, above the limit of {MAX_SIZE}")


def _multiply(left, right):
    if _is_int(left) and _is_int(right):
        bits = left.bit_length() + right.bit_length()
        if bits > MAX_INT_BITS:
            raise _bits_refused(left, "*", right, bits)
    elif isinstance(right, (int, bool)):
        _repeat_size(left, right)
    elif isinstance(left, (int, bool)):
        _repeat_size(right, left)
    return left * right


def _add(left, right):
    if not isinstance(left, (int, float, complex)) and not isinstance(right, (int, float, complex)):
        size = value_size(left) + value_size(right)
        if size > MAX_SIZE:
            raise Refused(f"adding would make {size} characters and items, above the limit of {MAX_SIZE}")
    return left + right


def _shift_left(left, right):
    if _is_int(left) and _is_int(right) and left and right > 0:
        bits = left.bit_length() + right
        if bits > MAX_INT_BITS:
            raise _bits_refused(left, "<<", right, bits)
    return left << right


def _check_operand_bits(left, op: str, right) -> None:
    """``//``, ``%`` and ``divmod`` run in quadratic time on huge integers, uninterruptibly: refuse operands
    above :data:`MAX_INT_BITS` bits before dividing (every integer an expression makes is within it already)."""
    for value in (left, right):
        if _is_int(value) and value.bit_length() > MAX_INT_BITS:
            raise Refused(f"{_short(left)} {op} {_short(right)}: an operand of {value.bit_length()} bits, above the "
                          f"limit of {MAX_INT_BITS} bits")


def _modulo(left, right):
    if isinstance(left, (str, bytes)):
        check_percent_format(left if isinstance(left, str) else left.decode("latin-1"), right)
        return check_size(left % right, "the formatted string")
    _check_operand_bits(left, "%", right)
    return left % right


def _floor_divide(left, right):
    _check_operand_bits(left, "//", right)
    return left // right


def _arguments_estimate(args, kwargs=None, *, quoted: bool = False) -> int:
    """The longest text one argument of a format could make (an upper bound, :func:`text_estimate`; its
    ``repr`` with ``quoted``, for ``%r`` and ``!r``)."""
    values = list(args) + list((kwargs or {}).values())
    return max((text_estimate(v, quoted=quoted) for v in values), default=0)


# %[(name)][flags][width][.precision][length]type
_PERCENT_FIELD = re.compile(r"%(?:\([^)]*\))?[-#0 +]*(\*|\d+)?(?:\.(\*|\d*))?[hlL]?(.?)", re.S)


def _width(digits: str | None, what: str) -> int:
    if not digits:
        return 0
    if digits == "*":
        raise Refused(f"a '*' width or precision in {what} is not allowed; write the number")
    if len(digits) > 7:
        raise Refused(f"a width or precision of {len(digits)} digits in {what}, above the limit of {MAX_SIZE}")
    return int(digits)


def check_percent_format(fmt: str, arguments: object = ()) -> None:
    """Refuse a ``%`` format whose widths and precisions add up to more than :data:`MAX_SIZE` (or use ``*``),
    or whose text would (estimated before formatting: each field as long as the longest argument)."""
    total, fields, quoted = 0, 0, False
    for match in _PERCENT_FIELD.finditer(fmt):
        total += _width(match.group(1), "a % format") + _width(match.group(2), "a % format")
        fields += match.group(3) not in ("%", "")
        quoted = quoted or match.group(3) in ("r", "a")
    if total > MAX_SIZE:
        raise Refused(f"the widths in a % format add up to {total}, above the limit of {MAX_SIZE}")
    values = arguments.values() if isinstance(arguments, dict) else arguments if isinstance(arguments, tuple) else (arguments,)
    check_text_estimate(len(fmt) + total + fields * _arguments_estimate(values, quoted=quoted),
                        "the % formatted string")


def spec_width(spec: str) -> int:
    if "{" in spec:
        raise Refused("a nested {...} inside a format spec is not allowed")
    return sum(_width(digits, "a format spec") for digits in re.findall(r"\d+", spec))


def check_format_string(fmt: str, args=(), kwargs=None) -> None:
    """Refuse a ``str.format`` template with attribute or index access in a field, nested specs, huge widths,
    or a text that would be too long (estimated before formatting: each field as long as the longest argument)."""
    total, count, quoted = 0, 0, False
    try:
        fields = list(string.Formatter().parse(fmt))
    except ValueError as exc:
        raise Refused(f"format string: {exc}") from None
    for _literal, field, spec, conversion in fields:
        if field is None:
            continue
        if "." in field or "[" in field:
            raise Refused(f"format field '{{{field}}}' is not allowed; a field is empty, a position or a name")
        total += spec_width(spec or "")
        count += 1
        quoted = quoted or conversion in ("r", "a")
    if total > MAX_SIZE:
        raise Refused(f"the widths in a format string add up to {total}, above the limit of {MAX_SIZE}")
    check_text_estimate(len(fmt) + total + count * _arguments_estimate(args, kwargs, quoted=quoted),
                        "the formatted string")


bounded_multiply = _multiply

#: simpleeval's operators, with ``+ * ** << %`` bounded (and ``>>`` plain).
OPERATORS: dict[type, Callable] = {
    **simpleeval.DEFAULT_OPERATORS,
    ast.Add: _add, ast.Mult: _multiply, ast.Pow: _power, ast.LShift: _shift_left, ast.Mod: _modulo,
    ast.FloorDiv: _floor_divide,
    ast.RShift: operator.rshift,  # cannot grow (simpleeval bounds it like <<, with other messages than Python's)
}



def checked_str_method(text: str, name: str) -> Callable:
    """``text.name`` (an allowed string method), with its arguments checked first where the result could be huge."""
    method = getattr(text, name)

    def checked(*args, **kwargs):
        if name in ("center", "ljust", "rjust", "zfill") and args and _is_int(args[0]) and args[0] > MAX_SIZE:
            raise Refused(f"str.{name}({args[0]}) would make a string above the limit of {MAX_SIZE} characters")
        if name == "format":
            check_format_string(text, args, kwargs)
            return check_size(method(*args, **kwargs), "the formatted string")
        if name == "replace" and len(args) >= 2 and isinstance(args[1], str):
            size = len(text) + (len(text) + 1) * len(args[1])
            if size > MAX_SIZE:
                raise Refused(f"str.replace could make {size} characters, above the limit of {MAX_SIZE}")
        if name == "join" and len(args) == 1 and not kwargs:
            try:
                items = list(args[0])
            except TypeError:
                raise TypeError("can only join an iterable") from None  # as str.join says it
            check_size(items, "the joined items")
            if len(text) * len(items) > MAX_SIZE:
                raise Refused(f"str.join would make more than {MAX_SIZE} characters (the limit)")
            return method(items)
        return method(*args, **kwargs)

    return checked


def _int_bits_estimate(args) -> float:
    """Most bits ``int(*args)`` could make, from the length of a text and its base (0: by prefix, at most 4 bits
    a digit for 0x); 0 for other arguments (an int of a float has at most 1,024 bits)."""
    if not args or not isinstance(args[0], (str, bytes, bytearray)):
        return 0.0
    base = args[1] if len(args) > 1 and _is_int(args[1]) else 10
    per_digit = math.log2(base) if 2 <= base <= 36 else 4.0
    return len(args[0]) * per_digit


def checked_call(function: Callable, args: list, kwargs: dict) -> None:
    """Refuse a call of a builtin whose result would be too large, estimated before it is made: ``int`` of a
    long text (:data:`MAX_INT_BITS`), ``str``/``repr``/``ascii`` of a large value and ``divmod`` of huge
    integers; other calls are checked after (:func:`check_size` of the result)."""
    if function is int:
        bits = _int_bits_estimate(args) if not kwargs else len(str(args[0] if args else "")) * 6.0
        if bits > MAX_INT_BITS:
            raise Refused(f"int() of a text of {len(args[0] if args else '')} characters would have up to "
                           f"{bits:.0f} bits, above the limit of {MAX_INT_BITS} bits")
    elif function in (str, repr, ascii) and args:
        check_text_estimate(text_estimate(args[0], quoted=function is not str), f"{function.__name__}() of the value")
    elif function is divmod and len(args) == 2:
        _check_operand_bits(args[0], "divmod", args[1])


