"""The bad-input corpus (tests/bad_inputs/cases*.yaml): every case, run as a user runs it.

Each case is a subprocess of the installed entry point, with at most
``MEMORY_LIMIT`` bytes of address space and ``timeout`` seconds (default
120). A user error must exit with status 2, print exactly one line on stderr
naming the problem (the case's fragment), and never show a traceback; a case
with ``forbid: NAME`` also requires that no file NAME appears in its folder
(a description that tries to run a command, for example ``touch NAME``). The
subprocesses of all cases run a few at a time (each in its own empty folder),
then each case is checked as its own test.
"""

import os
import resource
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest
import yaml

HERE = Path(__file__).parent / "bad_inputs"
BIN = Path(sys.executable).parent
CASES = [case for path in sorted(HERE.glob("cases*.yaml")) for case in yaml.safe_load(path.read_text())]
MEMORY_LIMIT = 4 << 30  # bytes of address space per case: a bomb must be refused, not run out of memory
KEYS = {"name", "argv", "expect"}
OPTIONAL_KEYS = {"timeout", "forbid"}


def _limit_memory():
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, MEMORY_LIMIT))


def _run_case(case, folder: Path) -> subprocess.CompletedProcess:
    folder.mkdir(parents=True, exist_ok=True)
    command, *args = (item.format(here=HERE, tmp=folder) for item in case["argv"])
    try:
        result = subprocess.run([str(BIN / command), *args], capture_output=True, text=True, cwd=folder,
                                timeout=case.get("timeout", 120), preexec_fn=_limit_memory)
    except subprocess.TimeoutExpired as exc:
        result = subprocess.CompletedProcess(exc.cmd, "timeout", "", f"timed out after {exc.timeout} s")
    result.folder = folder
    return result


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    root = tmp_path_factory.mktemp("bad_inputs")
    with ThreadPoolExecutor(max_workers=max(2, os.cpu_count() or 2)) as pool:
        futures = {case["name"]: pool.submit(_run_case, case, root / case["name"]) for case in CASES}
        return {name: future.result() for name, future in futures.items()}


def test_corpus_has_at_least_30_cases_with_unique_names():
    names = [case["name"] for case in CASES]
    assert len(names) >= 30 and len(set(names)) == len(names)
    for case in CASES:
        assert KEYS <= set(case) <= KEYS | OPTIONAL_KEYS and case["argv"][0] in ("tf-between", "manipkit"), case


def test_every_description_file_is_used_by_a_case():
    used = " ".join(" ".join(case["argv"]) for case in CASES)
    unused = [p.name for p in (HERE / "descriptions").iterdir() if p.name not in used and p.name != "good_arm.urdf"]
    assert unused == []


def test_the_arm_the_bad_descriptions_are_edited_from_is_valid():
    result = subprocess.run([str(BIN / "tf-between"), "base_link", "tool", "--robot", str(HERE / "descriptions" / "good_arm.urdf"),
                             "--q", "shoulder=0.5", "elbow=-0.25"], capture_output=True, text=True, timeout=60)
    assert result.returncode == 0 and result.stderr == "", result.stderr


@pytest.mark.parametrize("case", CASES, ids=[case["name"] for case in CASES])
def test_bad_input_exits_2_with_one_line_naming_the_problem(case, results):
    result = results[case["name"]]
    command = case["argv"][0]
    output = result.stdout + result.stderr
    assert "Traceback" not in output, output
    assert result.returncode == 2, output
    assert result.stderr.endswith("\n") and result.stderr.count("\n") == 1, result.stderr
    assert result.stderr.startswith(f"{command}: error: "), result.stderr
    assert case["expect"] in result.stderr, result.stderr


@pytest.mark.parametrize("case", [c for c in CASES if "forbid" in c], ids=[c["name"] for c in CASES if "forbid" in c])
def test_a_description_runs_no_command(case, results):
    result = results[case["name"]]
    assert result.returncode == 2
    assert not (result.folder / case["forbid"]).exists(), f"{case['forbid']} was created: the description ran a command"

