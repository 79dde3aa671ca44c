"""The site's generated parts (an MkDocs hook: mkdocs.yml ``hooks``), so they cannot drift from the code.

- ``<!-- cli-reference -->`` (``cli.md``): one section per command and
  subcommand, each with its ``--help`` text as the command prints it (at 100
  columns), so the page lists every command and option ``--help`` shows.
- Sphinx roles left in the rendered docstrings (``:func:`x```, which mkdocstrings
  shows as written) are dropped, leaving the code: ``x``.
- ``<!-- top-level-names -->`` (``api/manipkit.md``): every name ``import
  manipkit`` offers, linked to the API page that documents its module.

``python docs/hooks.py`` prints the command-line reference.
"""

from __future__ import annotations

import argparse
import os
import re
from pathlib import Path

MARKER = "<!-- cli-reference -->"
NAMES_MARKER = "<!-- top-level-names -->"
SITE = Path(__file__).resolve().parent / "site"
COLUMNS = "100"


def commands(parser: argparse.ArgumentParser, name: str):
    """(full command name, parser) for ``parser`` and every subcommand below it, depth first, in ``--help`` order."""
    yield name, parser
    for action in parser._actions:  # argparse keeps its subcommands only here
        if isinstance(action, argparse._SubParsersAction):
            seen = set()
            for sub_name, sub in action.choices.items():
                if id(sub) not in seen:  # an alias names the same parser again
                    seen.add(id(sub))
                    yield from commands(sub, f"{name} {sub_name}")


def help_text(parser: argparse.ArgumentParser) -> str:
    """``parser``'s ``--help`` text, wrapped at :data:`COLUMNS` columns whatever the terminal."""
    previous = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = COLUMNS
    try:
        return parser.format_help()
    finally:
        if previous is None:
            del os.environ["COLUMNS"]
        else:
            os.environ["COLUMNS"] = previous


def markdown() -> str:
    """The reference: a section per command (``tf-between``, then ``manipkit`` and each of its subcommands)."""
    from manipkit.app.cli import parsers

    parts = []
    for program, parser in parsers().items():
        for name, command in commands(parser, program):
            level = "#" * min(2 + name.count(" "), 4)
            parts.append(f"{level} `{name}`\n")
            parts.append("```text\n" + help_text(command).rstrip() + "\n```\n")
    return "\n".join(parts)


def api_pages() -> dict[str, str]:
    """Module -> the API page (relative to ``api/``) that renders it with ``::: module``."""
    found = {}
    for page in sorted((SITE / "api").glob("*.md")):
        for module in re.findall(r"^::: (manipkit[\w.]*)$", page.read_text(encoding="utf-8"), flags=re.M):
            found.setdefault(module, page.name)
    return found


def names_markdown() -> str:
    """A table of ``manipkit``'s top-level names (its lazy table and modules), each linked to its module's page."""
    import manipkit

    pages = api_pages()
    rows = ["| name | defined in |", "|---|---|"]
    for name, home in {**manipkit._LAZY, **manipkit._LAZY_MODULES}.items():
        if home not in pages:
            raise ValueError(f"manipkit.{name} lives in {home}, which no page under docs/site/api renders")
        rows.append(f"| `manipkit.{name}` | [`{home}`]({pages[home]}#{home}) |")
    return "\n".join(rows) + "\n"


def on_page_markdown(text, page, **_):
    """MkDocs hook: the markers replaced by :func:`markdown` and :func:`names_markdown`."""
    if MARKER in text:
        text = text.replace(MARKER, markdown())
    if NAMES_MARKER in text:
        text = text.replace(NAMES_MARKER, names_markdown())
    return text


ROLE = re.compile(r":(?:attr|class|data|exc|func|meth|mod|obj|py:\w+):(?=<code>)")


def on_page_content(html, page, **_):
    """MkDocs hook: ``:func:<code>x</code>`` (a Sphinx role mkdocstrings leaves as text) -> ``<code>x</code>``."""
    return ROLE.sub("", html)


if __name__ == "__main__":
    print(markdown())
