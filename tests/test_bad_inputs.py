"""The bad-input corpus (tests/bad_inputs/cases*.yaml): every case, run as a user runs it.

A case runs in its own empty folder (its working directory). Most run in
this process (tests/cli_helper.py). A case about the process itself, marked
``subprocess: memory``, ``time``, ``hang`` or ``crash`` (a bomb, a device
read forever, a recursion that could crash the interpreter), runs as a
subprocess of the installed entry point with at most ``MEMORY_LIMIT`` bytes
of address space and ``timeout`` seconds (default 120), at the niceness
``nice`` (default 0: a case that runs until a wall-clock limit stops it
needs the time, not the CPU the other tests are using); those subprocesses
start a few at a time as soon as the first case is checked, and run while
the other cases run here. A user error must exit with status 2, print
exactly one line on stderr naming the problem (the case's fragment), and
never show a traceback; a case with ``forbid: NAME`` also requires that no
file NAME appears in its folder (a description that tries to run a command,
for example ``touch NAME``). Each case is checked as its own test.
"""

import errno
import os
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest
import yaml
from cli_helper import run_cli

HERE = Path(__file__).parent / "bad_inputs"
BIN = Path(sys.executable).parent
CASES = [case for path in sorted(HERE.glob("cases*.yaml")) for case in yaml.safe_load(path.read_text())]
MEMORY_LIMIT = 4 << 30  # bytes of address space per case: a bomb must be refused, not run out of memory
KEYS = {"name", "argv", "expect"}
OPTIONAL_KEYS = {"timeout", "forbid", "subprocess", "nice"}
SUBPROCESS_REASONS = {"memory", "time", "hang", "crash"}


def _argv(case, folder: Path) -> list[str]:
    folder.mkdir(parents=True, exist_ok=True)
    return [item.format(here=HERE, tmp=folder) for item in case["argv"]]


def _run_case_in_process(case, folder: Path):
    result = run_cli(*_argv(case, folder), cwd=folder)
    result.folder = folder
    return result


def _run_case_in_subprocess(case, folder: Path) -> subprocess.CompletedProcess:
    command, *args = _argv(case, folder)
    # bash sets the limit and becomes the command (exec): no preexec_fn, which is unsafe while other threads run
    limited = ["/bin/bash", "-c", f'ulimit -v {MEMORY_LIMIT // 1024} && exec nice -n {int(case.get("nice", 0))} "$@"',
               "bash", str(BIN / command), *args]
    try:
        try:
            result = subprocess.run(limited, capture_output=True, text=True, cwd=folder, timeout=case.get("timeout", 120))
        except OSError as exc:  # the OS could not start bash at all (seen once: EFAULT from exec under load): once more
            if exc.errno != errno.EFAULT:
                raise
            result = subprocess.run(limited, capture_output=True, text=True, cwd=folder, timeout=case.get("timeout", 120))
    except subprocess.TimeoutExpired as exc:
        result = subprocess.CompletedProcess(exc.cmd, "timeout", "", f"timed out after {exc.timeout} s")
    result.folder = folder
    return result


@pytest.fixture(scope="module")
def case_folders(tmp_path_factory):
    return tmp_path_factory.mktemp("bad_inputs")


@pytest.fixture(scope="module")
def subprocess_runs(case_folders):
    """The cases marked ``subprocess``, started a few at a time: case name -> future of the finished process.

    In the order the tests check them, except that cases allowed more than 60 s start first: the slowest
    (an expansion stopped at its 30 s limit) then runs beside the others, not after them.
    """
    cases = sorted((case for case in CASES if "subprocess" in case), key=lambda case: case.get("timeout", 0) <= 60)
    with ThreadPoolExecutor(max_workers=max(2, os.cpu_count() or 2)) as pool:
        yield {case["name"]: pool.submit(_run_case_in_subprocess, case, case_folders / case["name"]) for case in cases}


@pytest.fixture(scope="module")
def results(case_folders, subprocess_runs):
    """``results(case)``: how the case ended, run once (in this process, or the subprocess started for it)."""
    done = {}

    def result(case):
        name = case["name"]
        if name not in done:
            if "subprocess" in case:
                done[name] = subprocess_runs[name].result()
            else:
                done[name] = _run_case_in_process(case, case_folders / name)
        return done[name]

    return result


def test_corpus_has_at_least_30_cases_with_unique_names():
    names = [case["name"] for case in CASES]
    assert len(names) >= 30 and len(set(names)) == len(names)
    for case in CASES:
        assert KEYS <= set(case) <= KEYS | OPTIONAL_KEYS and case["argv"][0] in ("tf-between", "manipkit"), case
        assert case.get("subprocess", "memory") in SUBPROCESS_REASONS, case
        assert "timeout" not in case or "subprocess" in case, f"{case['name']}: a timeout only bounds a subprocess"
        assert "nice" not in case or "subprocess" in case, f"{case['name']}: a niceness only lowers a subprocess"


def test_every_description_file_is_used_by_a_case():
    used = " ".join(" ".join(case["argv"]) for case in CASES)
    unused = [p.name for p in (HERE / "descriptions").iterdir() if p.name not in used and p.name != "good_arm.urdf"]
    assert unused == []


def test_the_arm_the_bad_descriptions_are_edited_from_is_valid():
    result = run_cli("tf-between", "base_link", "tool", "--robot", HERE / "descriptions" / "good_arm.urdf",
                     "--q", "shoulder=0.5", "elbow=-0.25")
    assert result.returncode == 0 and result.stderr == "", result.stderr


@pytest.mark.parametrize("case", CASES, ids=[case["name"] for case in CASES])
def test_bad_input_exits_2_with_one_line_naming_the_problem(case, results):
    result = results(case)
    command = case["argv"][0]
    output = result.stdout + result.stderr
    assert "Traceback" not in output, output
    assert result.returncode == 2, output
    assert result.stderr.endswith("\n") and result.stderr.count("\n") == 1, result.stderr
    assert result.stderr.startswith(f"{command}: error: "), result.stderr
    assert case["expect"] in result.stderr, result.stderr


@pytest.mark.parametrize("case", [c for c in CASES if "forbid" in c], ids=[c["name"] for c in CASES if "forbid" in c])
def test_a_description_runs_no_command(case, results):
    result = results(case)
    assert result.returncode == 2
    assert not (result.folder / case["forbid"]).exists(), f"{case['forbid']} was created: the description ran a command"

