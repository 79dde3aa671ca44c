"""Numbers as text, in one place: for printed answers and for error messages.

Every layer formats numbers through these functions (docs/architecture.md,
"Shared helpers"), so a value reads the same in a pose printout, a DH table
and a message. None of them prints ``-0``.

- :func:`number_text`: a fixed number of decimals (printed answers: poses, joint values).
- :func:`short_text`: up to ``digits`` significant digits (messages, tables).
- :func:`trimmed_text`: fixed decimals with trailing zeros dropped (link trees).
- :func:`near_text`: enough digits to show how a value differs from an expected one.
- :func:`vector_text`: ``[a b c]`` with any of the above.

And the one text sanitiser (docs/architecture.md, "Printed text"): every
string that came from a file, an argument or the environment is printed
through :func:`printable` (one line) or :func:`printable_lines` (line
breaks kept), so no control, C1 or bidirectional-override character reaches
the user's terminal raw.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Iterable

__all__ = [
    "UNPRINTABLE",
    "clipped_text",
    "close_matches",
    "near_text",
    "number_text",
    "printable",
    "printable_lines",
    "quoted_name",
    "repr_text",
    "short_text",
    "trimmed_text",
    "vector_text",
]


def _no_negative_zero(text: str) -> str:
    if text.startswith("-") and float(text) == 0.0:
        return text[1:]
    return text


def number_text(value: float, precision: int = 6, *, zero: float = 0.0) -> str:
    """``value`` with ``precision`` decimals, without the sign of a value that rounds to zero.

    A value with ``|value| <= zero`` is rounding noise and prints as zero
    (docs/architecture.md, "Printed noise": 1e-9 of the number's scale).

    Examples
    --------
    >>> number_text(-1e-9), number_text(0.5, 3), number_text(1.2e-16, 17, zero=1e-9)
    ('0.000000', '0.500', '0.00000000000000000')
    """
    value = float(value)
    if abs(value) <= zero:
        value = 0.0
    return _no_negative_zero(f"{value:.{precision}f}")


def short_text(value: float, digits: int = 6, *, zero: float = 0.0) -> str:
    """Up to ``digits`` significant digits (``%g``); a value with ``|value| <= zero`` prints as ``0``.

    ``zero`` drops rounding noise (for example ``1e-12`` after a numerical
    derivation); with the default 0 only an exact or negative zero is ``0``.

    Examples
    --------
    >>> short_text(0.1234567), short_text(-0.0), short_text(2.8e-10, zero=1e-9), short_text(1e-300)
    ('0.123457', '0', '0', '1e-300')
    """
    value = float(value)
    if math.isfinite(value) and abs(value) <= zero:
        return "0"
    return _no_negative_zero(f"{value:.{digits}g}")


def trimmed_text(value: float, decimals: int = 6) -> str:
    """``decimals`` decimals with trailing zeros (and a bare point) dropped.

    Examples
    --------
    >>> trimmed_text(0.089159), trimmed_text(1.0), trimmed_text(-1e-12)
    ('0.089159', '1', '0')
    """
    text = f"{round(float(value), decimals) + 0.0:.{decimals}f}"
    return text.rstrip("0").rstrip(".") if "." in text else text


def near_text(value: float, expected: float | None = None) -> str:
    """``value`` with enough significant digits (4 to 15) to show how it differs from ``expected``.

    Examples
    --------
    >>> near_text(1.0000004, 1.0), near_text(0.35)
    ('1.0000004', '0.35')
    """
    value = float(value)
    if not math.isfinite(value):
        return str(value)
    digits = 4
    if expected is not None and value != expected:
        gap = abs(value - expected)
        digits = int(min(max(math.ceil(-math.log10(gap / max(abs(expected), 1.0))) + 2, 4), 15))
    return _no_negative_zero(f"{value:.{digits}g}")


def vector_text(values: Iterable[float], number: Callable[[float], str] = short_text) -> str:
    """``[a b c]``, each entry formatted by ``number``.

    Examples
    --------
    >>> vector_text([0, 0.5, -1e-20]), vector_text([0.1, 0.2], lambda v: number_text(v, 2))
    ('[0 0.5 -1e-20]', '[0.10 0.20]')
    """
    return "[" + " ".join(number(float(v)) for v in values) + "]"


def repr_text(value, limit: int = 60) -> str:
    """``repr(value)`` on one line, cut to ``limit`` characters (for a value quoted in a message)."""
    text = " ".join(printable(repr(value)).split())
    return text if len(text) <= limit else text[: limit - 3] + "..."


# What never reaches a terminal raw: C0 controls and DEL (escape sequences, bell, backspace, carriage
# return, line breaks), C1 controls (U+0080-U+009F: CSI, OSC, ...), lone surrogates, the line and paragraph
# separators, and the bidirectional controls that reorder what is shown (the "Trojan Source" set: ALM, LRM,
# RLM, LRE/RLE/PDF/LRO/RLO, LRI/RLI/FSI/PDI).
_UNPRINTABLE = re.compile("[\x00-\x1f\x7f-\x9f\u061c\u200e\u200f\u2028-\u202e\u2066-\u2069\ud800-\udfff]")
_UNPRINTABLE_IN_LINES = re.compile(
    "[\x00-\x08\x0b-\x1f\x7f-\x9f\u061c\u200e\u200f\u2028-\u202e\u2066-\u2069\ud800-\udfff]"
)


#: The characters :func:`printable` escapes (C0 and C1 controls, DEL, lone surrogates, line and paragraph
#: separators, bidirectional controls): ``UNPRINTABLE.search(name)`` finds the first one in a name, for
#: refusing names that hold one (link, joint and robot names: :mod:`manipkit.description.validate`).
UNPRINTABLE = _UNPRINTABLE


def _escaped(match: re.Match) -> str:
    code = ord(match.group())
    return f"\\x{code:02x}" if code < 0x100 else f"\\u{code:04x}"


def printable(text) -> str:
    """``str(text)`` as one line of printable text: control, C1 and bidi characters as ``\\xNN``/``\\uNNNN``.

    For any string from a file, an argument or the environment that is
    printed (a link name, a file name, a message from a description). A line
    break is escaped too, so a name cannot forge a line of the output.

    Examples
    --------
    >>> printable("base\\n- Translation: [0 0 0]"), printable("\\x1b[2Jhi"), printable("a\\u202eb")
    ('base\\\\x0a- Translation: [0 0 0]', '\\\\x1b[2Jhi', 'a\\\\u202eb')
    """
    return _UNPRINTABLE.sub(_escaped, str(text))


def printable_lines(text) -> str:
    """``str(text)`` with line breaks and tabs kept and every other unprintable character escaped.

    The last guard on everything the command line writes to stdout (text
    that is already lines: a table, a tree).

    >>> printable_lines("a\\tb\\nc\\rd")
    'a\\tb\\nc\\\\x0dd'
    """
    return _UNPRINTABLE_IN_LINES.sub(_escaped, str(text))


#: Longest name :func:`close_matches` compares (longer names, given or known, get no suggestion): difflib's
#: cost grows with the product of the lengths (a 200,000-character near miss took 41 s).
MAX_MATCHED_CHARS = 200


def close_matches(name, known, n: int = 3, cutoff: float = 0.5) -> list[str]:
    """The "did you mean" candidates for ``name`` among ``known`` (:func:`difflib.get_close_matches`), bounded
    in time: names longer than :data:`MAX_MATCHED_CHARS`, and more than 10,000 candidates, are not compared.

    >>> close_matches("shouldr", ["shoulder", "elbow"])
    ['shoulder']
    >>> close_matches("x" * 200_000, ["x"])
    []
    """
    import difflib
    import itertools

    name = str(name)
    if len(name) > MAX_MATCHED_CHARS:
        return []
    candidates = [k for k in itertools.islice(known, 10_000) if isinstance(k, str) and len(k) <= MAX_MATCHED_CHARS]
    return difflib.get_close_matches(name, candidates, n=n, cutoff=cutoff)


def clipped_text(text, limit: int = 60) -> str:
    """``text`` for a message: printable, and a long one cut, with its length (a value typed by a user, echoed).

    >>> clipped_text("9" * 400, 10)
    '9999999999... (400 characters)'
    """
    shown = printable(text)
    return shown if len(shown) <= limit else f"{shown[:limit]}... ({len(str(text)):,} characters)"


def quoted_name(name, limit: int = 60) -> str:
    """``'name'`` for a message: printable, and a long one cut, with its length (a 10 MB name is never echoed).

    >>> quoted_name("a" * 100, 10)
    "'aaaaaaaaaa...' (100 characters)"
    """
    text = printable(name)
    return f"'{text}'" if len(text) <= limit else f"'{text[:limit]}...' ({len(str(name)):,} characters)"
