"""benchmarks/against.py: its arguments, its child programs and the checks that compare the two sides.

No second worktree is made and nothing is timed here (``python -m
benchmarks.against REF`` compiles a checkout's kernels: minutes). What is
checked: the arguments, that every workload's child program is valid Python
for both API layouts, the child harness's two modes (run in this process on a
tiny snippet), and that the comparisons say WRONG when the sides disagree.
"""

import json
import sys
from pathlib import Path
from string import Template

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks import against  # noqa: E402


def test_arguments_have_their_defaults_and_refuse_zero_rounds(capsys):
    args = against.parse_args(["f7af5f5"])
    assert (args.ref, args.rounds, args.repeats, args.cold_runs, args.quick) == ("f7af5f5", 5, 3, 15, False)
    with pytest.raises(SystemExit) as stop:
        against.parse_args(["f7af5f5", "--rounds", "0"])
    assert stop.value.code == 2
    assert "at least 1" in capsys.readouterr().err


def test_a_name_that_is_not_a_commit_exits_2_in_one_line(capsys):
    assert against.main(["no-such-ref-for-against"]) == 2
    assert capsys.readouterr().err.strip().count("\n") == 0


def test_layout_is_read_from_the_files(tmp_path):
    assert against.layout(ROOT / "src") == "ik-package"
    (tmp_path / "manipkit" / "closed_form").mkdir(parents=True)
    (tmp_path / "manipkit" / "closed_form" / "chain_ik.py").write_text("")
    assert against.layout(tmp_path) == "closed-form-package"
    with pytest.raises(against.AgainstError):
        against.layout(tmp_path / "nothing")


@pytest.mark.parametrize("api", sorted(against.IMPORTS))
def test_every_child_program_is_python_with_its_layouts_imports(api):
    for workload in against.WORKLOADS:
        source = against.child_source(workload, api, against.SIZES["quick"])
        compile(source, workload, "exec")
        if workload == "ik":
            assert against.IMPORTS[api]["ik"] in source
        if workload.startswith("closed"):
            assert against.IMPORTS[api]["closed"] in source
    assert set(against.row_labels(against.SIZES["full"])) == {
        key for _, labels in against.WORKLOADS.values() for key in labels}


def run_harness(snippet, mode, out, repeats, monkeypatch):
    monkeypatch.setattr(sys, "argv", ["-c", mode, str(out), str(repeats)])
    exec(compile(Template(against.HARNESS).substitute(snippet=snippet), "child", "exec"), {"__name__": "__main__"})


def test_the_harness_saves_answers_and_times_per_call(tmp_path, monkeypatch):
    snippet = "calls = []\nadd('row', 4, lambda: calls.append(1) or {'a': np.arange(3.0)})"
    run_harness(snippet, "check", tmp_path / "a.npz", 0, monkeypatch)
    with np.load(tmp_path / "a.npz") as data:
        assert data.files == ["row|a"] and data["row|a"].tolist() == [0.0, 1.0, 2.0]
    run_harness(snippet, "time", tmp_path / "t.json", 3, monkeypatch)
    seconds = json.loads((tmp_path / "t.json").read_text())
    assert set(seconds) == {"row"} and 0.0 < seconds["row"] < 1.0


def test_solution_sets_match_in_any_order_and_differ_by_count_or_value():
    A = np.full((2, 3, 2), np.nan)
    A[0, :2] = [[0.1, 0.2], [0.3, 0.4]]
    A[1, :1] = [[1.0, -1.0]]
    B = np.full((2, 4, 2), np.nan)
    B[0, [3, 1]] = [[0.1, 0.2], [0.3, 0.4]]  # the same set, other slots and order
    B[1, 2] = [1.0, -1.0]
    assert against.solution_set_gap(A, B) == 0.0
    B[0, 3, 1] += 1e-6
    assert against.solution_set_gap(A, B) == pytest.approx(1e-6)
    assert not against.compare("cf_batch_ur5", {"solutions": A}, {"solutions": B})[0]
    B[0, 0] = [5.0, 5.0]  # one solution more on one side
    assert against.solution_set_gap(A, B) == np.inf


def test_poses_and_inputs_must_agree():
    Q, T = np.zeros((3, 7)), np.tile(np.eye(4), (3, 1, 1))
    assert against.compare("fk_batch_iiwa14", {"Q": Q, "T": T}, {"Q": Q, "T": T.copy()})[0]
    moved = T.copy()
    moved[1, 0, 3] += 1e-10
    assert not against.compare("fk_batch_iiwa14", {"Q": Q, "T": T}, {"Q": Q, "T": moved})[0]
    ok, check = against.compare("fk_batch_iiwa14", {"Q": Q, "T": T}, {"Q": Q + 1e-3, "T": T})
    assert not ok and "different inputs" in check


def test_verdict_needs_every_round_beyond_the_noise():
    assert against.verdict(np.array([1.2, 1.15, 1.3])) == "slower"
    assert against.verdict(np.array([1.2, 1.05, 1.3])) == "same"
    assert against.verdict(np.array([0.5, 0.8])) == "faster"
