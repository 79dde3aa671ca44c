"""README.md's command-line tour prints what the commands print today, and its layout names every module.

Every ``$ tf-between ...`` or ``$ manipkit ...`` line of an indented block in
README.md, followed by the output the README shows for it, is run here (in
process, :func:`cli_helper.run_cli`) in one working folder, in README order,
and its stdout and stderr (stderr after stdout, as a terminal shows a one-line
error after nothing) must match the shown lines:

- a line ``...`` stands for any number of lines (none included);
- a line ending in `` ...`` matches a line that starts with what comes before;
- any other line must be equal (trailing spaces aside); blank lines printed are not compared.

``$ cat FILE`` followed by lines writes those lines to FILE (the README shows
the file a later command reads); ``$ echo $?`` checks the exit status of the
command before it. Not run: commands on the reader's own files (``~/...``, or
``...`` for elided arguments), ones that serve the viewer (``view``,
``--view``) and ones whose output the README does not show. The
repository's root in the output is shown as ``...`` (the reader's clone is
elsewhere). The working folder holds a ``docs/`` folder with a copy of the
repository's ``docs/examples`` (the files the tour reads), so what the tour
writes never lands in the repository. The documentation site's examples
(tests/test_docs_site.py) run by the same rules (:func:`run_step`).

The README is a front page: at most about 250 lines, and every file it links
exists (the manual is the site, docs/site/).
"""

from __future__ import annotations

import re
import shlex
import shutil
from pathlib import Path

import pytest
from cli_helper import run_cli

ROOT = Path(__file__).resolve().parents[1]
SHOWN_ROOT = "..."  # the repository's root (where the reader cloned it) as the README's output shows it
PROGRAMS = ("tf-between", "manipkit", "cat", "echo")
#: Too slow for `make test` (a 5 cm iiwa14 map of a million samples): its output is also elided in the README.
SLOW = ("--voxel 0.05 --orientations 200 --samples 1000000",)


def tour() -> list[tuple[int, str, list[str]]]:
    """(line number, command, shown output lines) for every ``$`` line of the README's indented blocks."""
    steps: list[tuple[int, str, list[str]]] = []
    current = None
    for number, line in enumerate((ROOT / "README.md").read_text(encoding="utf-8").splitlines(), 1):
        if line.startswith("    $ "):
            current = (number, line[6:].strip(), [])
            steps.append(current)
        elif current is not None and line.startswith("    ") and line.strip():
            current[2].append(line[4:].rstrip())
        else:
            current = None
    return steps


def runnable(command: str, shown: list[str], need_output: bool = True) -> bool:
    """Whether the tests run ``command`` (shown with output ``shown``; none shown: not run, unless not ``need_output``)."""
    words = shlex.split(command, comments=True)
    if not words or words[0] not in PROGRAMS or (need_output and not shown):
        return False
    if any(word.startswith("~") or word == "..." for word in words) or any(slow in command for slow in SLOW):
        return False
    return not (words[0] == "manipkit" and (words[1] == "view" or "--view" in words or "--view-html" in words))


def matches(shown: list[str], printed: list[str]) -> bool:
    """Whether ``printed`` matches ``shown`` (see the module docstring for ``...``)."""
    if not shown:
        return not printed
    head, rest = shown[0], shown[1:]
    if head == "...":
        return any(matches(rest, printed[i:]) for i in range(len(printed) + 1))
    if not printed:
        return False
    line = printed[0].rstrip()
    ok = line.startswith(head[:-4]) if head.endswith(" ...") else line == head
    return ok and matches(rest, printed[1:])


STEPS = tour()


def new_session(tmp_path: Path) -> dict:
    """A working folder for a run of examples (``docs/examples`` copied in) and the last command's exit status."""
    shutil.copytree(ROOT / "docs" / "examples", tmp_path / "docs" / "examples")
    return {"cwd": tmp_path, "status": None}


def run_step(session: dict, command: str, shown: list[str]) -> str:
    """Run one ``$`` line of an example in ``session``: "" when what it printed matches ``shown``, else the account.

    ``cat FILE`` writes ``shown`` to FILE; ``echo $?`` checks the last exit status; any other command runs in
    process (:func:`cli_helper.run_cli`) in the session's folder."""
    words = shlex.split(command, comments=True)
    cwd = session["cwd"]
    if words[0] == "cat":
        (cwd / words[1]).write_text("\n".join(shown) + "\n", encoding="utf-8")
        return ""
    if words[0] == "echo":
        assert words[1:] == ["$?"] and session["status"] is not None
        return "" if [str(session["status"])] == shown else f"exit status {session['status']}"
    result = run_cli(words[0], *words[1:], cwd=cwd)
    session["status"] = result.returncode
    printed = [line for line in (result.stdout + result.stderr).replace(str(ROOT), SHOWN_ROOT).splitlines() if line.strip()]
    if matches(shown, printed):
        return ""
    return "--- shown:\n" + "\n".join(shown) + "\n--- the command printed:\n" + "\n".join(printed)


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    """The one working folder of the tour and the exit status of the last command."""
    return new_session(tmp_path_factory.mktemp("tour"))


def test_the_tour_has_commands_to_check():
    assert sum(runnable(command, shown) for _, command, shown in STEPS) >= 8


@pytest.mark.parametrize(("number", "command", "shown"), [s for s in STEPS if runnable(s[1], s[2])],
                         ids=[f"README.md:{s[0]}" for s in STEPS if runnable(s[1], s[2])])
def test_the_readme_shows_what_the_command_prints(session, number, command, shown):
    problem = run_step(session, command, shown)
    assert not problem, f"README.md:{number}: {command}\n{problem}"


@pytest.mark.parametrize(("shown", "printed", "ok"), [
    (["a", "...", "d"], ["a", "b", "c", "d"], True),
    (["a", "...", "d"], ["a", "d"], True),
    (["a", "b ..."], ["a", "b c d"], True),
    (["a", "b"], ["a", "b", "c"], False),
    (["a", "...", "e"], ["a", "b", "c", "d"], False),
    (["a x ..."], ["a y"], False),
])
def test_the_matching_rules(shown, printed, ok):
    assert matches(shown, printed) is ok


def test_commands_on_the_readers_own_files_and_the_viewer_are_not_run():
    assert not runnable("manipkit view --robot course_arm", ["x"])
    assert not runnable("tf-between a b --robot ~/ws/x.xacro", ["x"])
    assert not runnable("manipkit tree --robot course_arm", [])
    assert runnable("manipkit tree --robot course_arm", ["robot name is: course_arm"])
    assert not runnable("manipkit reachmap --robot iiwa14 --voxel 0.05 --orientations 200 --samples 1000000 -o m", ["x"])


def test_the_readme_is_a_front_page():
    lines = (ROOT / "README.md").read_text(encoding="utf-8").splitlines()
    assert len(lines) <= 250, f"README.md has {len(lines)} lines: move the detail into docs/site/"
    assert lines[2].lstrip().startswith("make demo") and lines[3].lstrip().startswith("make test")


def test_every_file_the_readme_links_exists():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    targets = [t for t in re.findall(r"\]\(([^)#]+)\)", text) if "://" not in t]
    assert len(targets) >= 10
    missing = [t for t in targets if not (ROOT / t).exists()]
    assert not missing, f"README.md links to missing files: {missing}"
