"""manipkit.text: the one text sanitiser (issue 26: escape sequences reached the terminal raw)."""

import unicodedata

from hypothesis import given
from hypothesis import strategies as st

from manipkit.text import printable, printable_lines

BIDI_CONTROLS = "\u061c\u200e\u200f\u202a\u202b\u202c\u202d\u202e\u2066\u2067\u2068\u2069"


def shown_raw(text: str) -> set[str]:
    """Characters a terminal would act on rather than show: Unicode's Cc and Cs, the separators, bidi controls."""
    return {c for c in text if unicodedata.category(c) in ("Cc", "Cs", "Zl", "Zp") or c in BIDI_CONTROLS}


@given(st.text())
def test_printable_leaves_nothing_a_terminal_acts_on(text):
    assert shown_raw(printable(text)) == set()


@given(st.text())
def test_printable_lines_keeps_only_line_breaks_and_tabs(text):
    assert shown_raw(printable_lines(text)) <= {"\n", "\t"}


@given(st.text(alphabet=st.characters(blacklist_categories=("Cc", "Cs", "Zl", "Zp"), blacklist_characters=BIDI_CONTROLS)))
def test_printable_text_is_unchanged(text):
    assert printable(text) == text == printable_lines(text)


def test_hand_cases():
    assert printable("\x1b]0;owned\x07") == "\\x1b]0;owned\\x07"  # retitle the window
    assert printable("safe\u202etxt.exe") == "safe\\u202etxt.exe"  # right-to-left override
    assert printable("\x9b2J") == "\\x9b2J"  # C1 CSI: clear screen on terminals that take 8-bit controls
    assert printable("a\nb") == "a\\x0ab" and printable_lines("a\nb") == "a\nb"
