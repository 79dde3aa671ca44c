"""The documentation site (mkdocs.yml, docs/site/, docs/hooks.py): its examples run, its references are complete.

- Every ```` ```console ```` block of a page: each ``$ tf-between ...`` or
  ``$ manipkit ...`` line is run in process (:func:`cli_helper.run_cli`), and
  what it prints (stdout, then stderr) must match the lines shown below it by
  README's rules (:func:`test_readme.run_step`: ``...`` for any lines, a line
  ending in `` ...`` for its beginning; ``$ cat FILE`` writes the lines shown,
  ``$ echo $?`` checks the exit status); the repository's root shows as ``...``.
  A page's blocks run in page order in one working folder (what one writes,
  the next may read), and the commands README's tests leave out are left out
  here too (:func:`test_readme.runnable`: the reader's own files, the viewer).
- Every ```` ```pycon ```` block is a doctest, the blocks of a page sharing
  one namespace in page order (ELLIPSIS and NORMALIZE_WHITESPACE on).
- The command-line reference lists every command and every option of every
  subparser that ``--help`` shows; every top-level name is on an API page.
- The site builds with ``mkdocs build --strict`` (a warning fails), about 10 s.
"""

from __future__ import annotations

import argparse
import doctest
import importlib.util
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest
from test_readme import PROGRAMS, new_session, run_step, runnable

ROOT = Path(__file__).resolve().parents[1]
SITE = ROOT / "docs" / "site"
PAGES = sorted(SITE.rglob("*.md"))
FENCE = re.compile(r"^```(console|pycon)\n(.*?)^```$", re.M | re.S)


def _hooks():
    spec = importlib.util.spec_from_file_location("manipkit_docs_hooks", ROOT / "docs" / "hooks.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def blocks(page: Path, kind: str) -> list[tuple[int, str]]:
    """(line number, text) of each fenced block of ``kind`` (console or pycon) on ``page``."""
    text = page.read_text(encoding="utf-8")
    return [(text.count("\n", 0, m.start()) + 1, m.group(2)) for m in FENCE.finditer(text) if m.group(1) == kind]


def console_steps(text: str) -> list[tuple[str, list[str]]]:
    steps = []
    for line in text.splitlines():
        if line.startswith("$ "):
            steps.append((line[2:], []))
        elif steps and line.strip():
            steps[-1][1].append(line.rstrip())
    return steps


CONSOLE = [(page, number, text) for page in PAGES for number, text in blocks(page, "console")]
PYCON = [page for page in PAGES if blocks(page, "pycon")]


def test_the_site_has_examples_to_run():
    assert len(CONSOLE) >= 8 and len(PYCON) >= 6


@pytest.fixture(scope="module")
def sessions(tmp_path_factory):
    """One working folder per page (its blocks run in page order), made on the page's first block."""
    made: dict = {}

    def session(page: Path) -> dict:
        if page not in made:
            made[page] = new_session(tmp_path_factory.mktemp(page.stem))
        return made[page]

    return session


@pytest.mark.parametrize(("page", "number", "text"), CONSOLE,
                         ids=[f"{page.relative_to(SITE)}:{number}" for page, number, _ in CONSOLE])
def test_the_console_examples_print_what_the_page_shows(sessions, page, number, text):
    for command, shown in console_steps(text):
        words = shlex.split(command)
        assert words[0] in PROGRAMS, f"{page.name}:{number}: {command}"
        if not runnable(command, shown, need_output=False):
            continue
        problem = run_step(sessions(page), command, shown)
        assert not problem, f"{page.relative_to(SITE)}:{number}: {command}\n{problem}"


@pytest.mark.parametrize("page", PYCON, ids=[str(page.relative_to(SITE)) for page in PYCON])
def test_the_python_examples_run(page):
    parser, runner = doctest.DocTestParser(), doctest.DocTestRunner(
        optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    namespace: dict = {}
    for number, text in blocks(page, "pycon"):
        test = parser.get_doctest(text, namespace, f"{page.name}:{number}", str(page), number)
        runner.run(test, clear_globs=False)
    assert runner.summarize(verbose=False).failed == 0


def _options(parser: argparse.ArgumentParser) -> list[str]:
    """Every option string and positional name ``parser``'s ``--help`` shows (suppressed ones aside)."""
    shown = []
    for action in parser._actions:
        if action.help == argparse.SUPPRESS or isinstance(action, argparse._SubParsersAction):
            continue
        shown += action.option_strings or [action.metavar or action.dest]
    return shown


def test_the_command_line_reference_lists_every_option_of_every_subparser():
    from manipkit.app.cli import parsers

    hooks = _hooks()
    text = hooks.markdown()
    sections = dict(re.findall(r"^#+ `([^`]+)`\n(.*?)(?=^#+ `|\Z)", text, flags=re.M | re.S))
    count = 0
    for program, parser in parsers().items():
        for name, command in hooks.commands(parser, program):
            assert name in sections, f"no section for {name}"
            for option in _options(command):
                assert re.search(rf"(?<![\w-]){re.escape(option)}(?![\w-])", sections[name]), f"{name}: {option}"
                count += 1
    assert len(sections) >= 20 and count >= 200  # manipkit's 20-odd commands and their options


def test_every_subcommand_has_a_section_even_below_a_group():
    from manipkit.app.cli import parsers

    names = [name for name, _ in _hooks().commands(parsers()["manipkit"], "manipkit")]
    assert {"manipkit dh check", "manipkit dh show", "manipkit reachmap show", "manipkit ik"} <= set(names)


def test_every_top_level_name_links_to_the_page_of_its_module():
    import manipkit

    table = _hooks().names_markdown()
    for name in [*manipkit._LAZY, *manipkit._LAZY_MODULES]:
        assert f"`manipkit.{name}`" in table


def test_the_site_builds_without_warnings(tmp_path):
    pytest.importorskip("mkdocs")
    pytest.importorskip("mkdocstrings_handlers.python")
    result = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path / "site")],
                            cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr[-3000:]
    cli = (tmp_path / "site" / "cli" / "index.html").read_text(encoding="utf-8")
    assert "manipkit reachmap show" in cli and "--q-file" in cli
    api = (tmp_path / "site" / "api" / "kinematics" / "index.html").read_text(encoding="utf-8")
    assert "manipkit.kinematics.robot.Robot.transform" in api  # a docstring rendered by mkdocstrings
