"""benchmarks/: the benchmark code runs on tiny sizes and its correctness checks pass.

No timing is asserted here (speed goals live in benchmarks/README.md and are
measured by `make bench`). What is checked: every workload of ``python -m
benchmarks --quick`` runs, manipkit's own answers pass their checks (they
never skip), a peer that is not installed is reported as missing, a peer
that is installed agrees with manipkit, and a peer with wrong answers gets
no time.
"""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks import peers, run, workloads  # noqa: E402


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory):
    """`python -m benchmarks --quick` as `make bench` runs it, into a temporary folder."""
    out = tmp_path_factory.mktemp("bench")
    result = subprocess.run([sys.executable, "-m", "benchmarks", "--quick", "--out", str(out)], cwd=ROOT,
                            capture_output=True, text=True, timeout=280)
    assert result.returncode == 0, result.stderr[-3000:]
    return result, json.loads((out / "results.json").read_text()), out


def test_quick_run_covers_every_workload(quick_run):
    _, results, _ = quick_run
    assert {r["workload"] for r in results["rows"]} == {"fk_single", "fk_batch", "ik", "planar", "cold_start", "viewer", "jacobian", "gci",
                                                          "reachmap_fk", "reachmap_hybrid", "ik_many", "reachmap_agreement",
                                                          "reachmap_dask", "collisions", "acm", "reachmap_collisions",
                                                          "analytic", "statics", "reachmap_payload", "redundant", "general6r"}
    assert {r["robot"] for r in results["rows"] if r["workload"] in ("fk_batch", "ik")} == {"iiwa14", "panda"}


def test_our_answers_pass_their_checks_and_are_timed(quick_run):
    _, results, _ = quick_run
    ours = [r for r in results["rows"] if r["tool"].startswith("manipkit")]
    assert len(ours) >= 12
    for r in ours:
        if r["status"] == "missing":  # only the browser round trip may be missing (no Chromium here)
            assert "Chromium" in r["tool"], r
            continue
        assert r["status"] == "ok", r
        assert r["median_s"] > 0 and r["p95_s"] >= r["median_s"], r


def test_no_answer_is_wrong(quick_run):
    _, results, _ = quick_run
    assert [r for r in results["rows"] if r["status"] == "wrong"] == []


def test_every_ik_answer_counted_as_a_success_was_checked_by_pinocchio(quick_run):
    _, results, _ = quick_run
    ours = [r for r in results["rows"] if r["workload"] == "ik" and r["ours"]]
    assert [r["success"] for r in ours] == [1.0, 1.0]
    assert all("Pinocchio FK" in r["check"] for r in ours)


def test_missing_peers_are_reported_not_timed(quick_run):
    _, results, _ = quick_run
    for r in results["rows"]:
        if r["status"] == "missing":
            assert r["median_s"] is None and r["note"], r


def test_installed_peers_agree_with_manipkit(quick_run):
    _, results, _ = quick_run
    installed = [key for key in peers.PEER_PACKAGES if peers.missing_reason(key) is None]
    if not installed:
        pytest.skip("no peer installed (`make bench` installs roboticstoolbox-python, ikpy, kinpy)")
    peer_rows = [r for r in results["rows"] if r["workload"].startswith("fk") and not r["tool"].startswith(("manipkit", "Pinocchio"))]
    assert peer_rows and all(r["status"] in ("ok", "missing") for r in peer_rows)
    assert any(r["status"] == "ok" for r in peer_rows)


def test_table_chart_and_goals_are_written(quick_run):
    result, results, out = quick_run
    assert "x ours" in result.stdout and "manipkit Robot.fk(Q, tip=frame)" in result.stdout
    assert (out / "results.png").stat().st_size > 10_000
    assert [g["goal"] for g in results["goals"]][:3] == [
        "batched FK, iiwa14: <= 0.2 us per configuration",
        "batched FK, iiwa14: >= 25x faster than Robotics Toolbox batched fkine",
        "batched FK, iiwa14: >= 5x faster than a Python loop over Pinocchio",
    ]
    assert results["machine"]["cpu"] and results["machine"]["cores"]


# --------------------------------------------------------------------------
# The gate: a fast wrong answer never counts


class WrongPeer:
    """A peer that is fast and off by 1e-6 m."""

    name = "Robotics Toolbox"
    version = "0"

    def __init__(self, robot, urdf_path):
        import manipkit

        self.robot = manipkit.load(robot.source.name)
        self.cols = peers.chain_columns(self.robot)

    def fk(self, q):
        full = self.robot.q()
        full[self.cols] = q
        T = self.robot.transform(self.robot.root_link, "ee_link", full)
        T[0, 3] += 1e-6
        return T

    def fk_batch_call(self, Q):
        return Q

    def fk_batch(self, Q):
        return np.array([self.fk(q) for q in Q])


def test_a_peer_with_wrong_answers_gets_no_time(monkeypatch):
    monkeypatch.setattr(peers, "load_peer", lambda key, robot, path: (WrongPeer(robot, path), None))
    rows = workloads.fk_workload("iiwa14", n_single=5, n_batch=20, repeats=1, loop_subset=5, peer_list=("rtb",))
    theirs = [r for r in rows if r["tool"].startswith("Robotics Toolbox")]
    assert len(theirs) == 2
    for r in theirs:
        assert r["status"] == "wrong" and r["median_s"] is None
        assert "1.0e-06" in r["check"]


def test_a_missing_peer_is_a_reason():
    if peers.missing_reason("kinpy") is None:
        pytest.skip("kinpy is installed")
    assert "kinpy is not installed" in peers.missing_reason("kinpy")


def test_chain_elements_alternate_links_and_joints_from_the_root():
    import manipkit

    robot = manipkit.load("iiwa14")
    names = peers.chain_elements(robot, "ee_link")
    assert names[0] == robot.root_link and names[-1] == "ee_link"
    assert names[1::2] == ["iiwa_base_joint", *[f"iiwa_joint_{i}" for i in range(1, 8)], "ee_joint"]


def test_kinematic_urdf_keeps_every_joint_and_drops_meshes():
    import manipkit

    robot = manipkit.load("panda")
    text = peers.kinematic_urdf(robot)
    assert "<visual" not in text and "<collision" not in text
    assert text.count("<joint ") == robot.urdf.count("<joint ")


# --------------------------------------------------------------------------
# Goals and the README block


def _row(workload, robot, tool, median, ours=False, **extra):
    return {"workload": workload, "robot": robot, "tool": tool, "median_s": median, "ours": ours, **extra}


def test_goals_say_met_or_by_how_much_missed():
    rows = [
        _row("fk_batch", "iiwa14", "manipkit Robot.fk(Q, tip=frame)", 0.1e-6, ours=True),
        _row("fk_batch", "iiwa14", "Robotics Toolbox fkine(Q), batched", 2e-6),
        _row("fk_batch", "iiwa14", "Pinocchio, Python loop", 0.3e-6),
        _row("ik", "iiwa14", "manipkit ik", 300e-6, ours=True, success=0.999),
        _row("ik", "iiwa14", "Robotics Toolbox ik_LM (C++)", 100e-6),
        _row("planar", "2R", "manipkit planar.ik_2r_batch (numpy)", 50e-9, ours=True),
        _row("cold_start", "-", "manipkit tf-between base_link ee_link", 0.3, ours=True),
    ]
    run.add_ratios(rows)
    by_goal = {g["goal"]: g for g in run.goals(rows)}
    assert by_goal["batched FK, iiwa14: <= 0.2 us per configuration"]["met"] is True
    assert by_goal["batched FK, iiwa14: >= 25x faster than Robotics Toolbox batched fkine"]["detail"] == "missed by 1.2x"
    assert by_goal["batched FK, iiwa14: >= 5x faster than a Python loop over Pinocchio"]["detail"] == "missed by 1.7x"
    assert by_goal["numerical IK, iiwa14: median <= 100 us per solve"]["detail"] == "missed by 3.0x"
    assert by_goal["closed-form 2R IK: >= 10 million targets per second"]["measured"] == "20.0 M/s"
    assert by_goal["tf-between cold start: median <= 0.25 s"]["detail"] == "missed by 0.050 s (1.20x)"
    rows.append(_row("cold_start", "-", 'python -c "import pinocchio"', 0.2))
    by_goal = {g["goal"]: g for g in run.goals(rows)}
    assert by_goal["tf-between cold start: median <= 0.25 s"]["detail"].endswith("`import pinocchio` alone: 0.200 s in the same run")


def test_readme_block_is_replaced_between_its_markers(tmp_path):
    readme = tmp_path / "README.md"
    readme.write_text(f"# title\n\nhand-written\n\n{run.START}\nold\n{run.END}\n\nafter\n")
    results = {"date": "2026-01-01T00:00:00+00:00", "seconds": 1.0, "goals": [], "rows": [
        {**_row("planar", "2R", "manipkit planar.ik_2r_batch (numpy)", 5e-8, ours=True), "p95_s": 6e-8, "unit": "target",
         "n": 10, "status": "ok", "check": "", "note": "", "ratio": None}],
        "machine": {"cpu": "CPU", "cores": 2, "uname": "Linux", "python": "3.11", "load_average_start": [1, 1, 1],
                    "load_average_end": [1, 1, 1]}}
    run.update_readme(readme, results, "results.png")
    text = readme.read_text()
    assert text.startswith("# title\n\nhand-written\n") and text.endswith("\n\nafter\n")
    assert "old" not in text and "50.0 ns/target" in text and text.count(run.START) == 1


def test_every_row_group_names_the_workload_that_measures_it(quick_run):
    _, results, _ = quick_run
    assert {r["workload"] for r in results["rows"]} <= set(run.STEP_OF_GROUP)
    assert set(run.STEP_OF_GROUP.values()) == set(run.WORKLOADS)
    assert all(r["step"] == run.STEP_OF_GROUP[r["workload"]] and r["date"] == results["date"] for r in results["rows"])


def _results(date, rows, workloads):
    machine = {"load_average_start": [1.0, 1.0, 1.0], "load_average_end": [1.5, 1.0, 1.0]}
    return {"date": date, "machine": machine, "quick": False, "seconds": 10.0, "goals": [], "rows": rows,
            "runs": [{"date": date, "workloads": workloads, "seconds": 10.0, **machine}]}


def test_merge_keeps_the_rows_of_workloads_not_rerun_with_their_dates():
    fk_old = workloads.row("fk_batch", "iiwa14", "manipkit", [1e-6], unit="config", ours=True)
    ik_old = workloads.row("ik", "iiwa14", "manipkit", [5e-5], unit="solve", ours=True)
    old = {"date": "2026-01-01", "machine": {"load_average_start": [0.1], "load_average_end": [0.2]}, "quick": False,
           "seconds": 5.0, "goals": [], "rows": [fk_old, ik_old]}  # an older file: no steps, dates or runs
    ik_new = {**workloads.row("ik", "iiwa14", "manipkit", [4e-5], unit="solve", ours=True), "step": "ik",
              "date": "2026-02-02"}
    merged = run.merge_results(old, _results("2026-02-02", [ik_new], ["ik"]))
    assert [(r["workload"], r["median_s"], r["date"]) for r in merged["rows"]] == [
        ("fk_batch", 1e-6, "2026-01-01"), ("ik", 4e-5, "2026-02-02")]  # the old ik row is replaced, fk kept
    assert [(r["date"], r["workloads"]) for r in merged["runs"]] == [("2026-01-01", ["fk"]), ("2026-02-02", ["ik"])]
    fk_new = {**fk_old, "step": "fk", "date": "2026-03-03"}
    partly = run.merge_results(_results("2026-02-02", [{**fk_old, "step": "fk", "date": "2026-02-02"}, ik_new],
                                        ["fk", "ik"]), _results("2026-03-03", [fk_new], ["fk"]))
    assert [(r["date"], r["workloads"]) for r in partly["runs"]] == [("2026-02-02", ["ik"]), ("2026-03-03", ["fk"])]
    again = run.merge_results(merged, _results("2026-03-03", [{**ik_new, "date": "2026-03-03"}], ["ik", "fk"]))
    assert [r["date"] for r in again["runs"]] == ["2026-03-03"]  # a run none of whose rows remain is dropped
