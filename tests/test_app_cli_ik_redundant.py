"""``manipkit ik --all`` on a 7R arm: the ranked set, its intervals and options; every arm's rows hold the chain's
own joints and the printed check line reproduces the answer (run here through tf-between)."""

from __future__ import annotations

import json
import re
import shlex

import numpy as np
import pytest
from cli_helper import run_cli

import manipkit

PANDA = ["--robot", "panda", "--xyz", "0.4", "0.1", "0.5", "--rpy", "3.14159", "0", "0"]


def check_line_lands(stdout: str, xyz) -> None:
    """The printed ``check one with`` command, run: its translation is the target's (the IK tolerance)."""
    line = next(line for line in stdout.splitlines() if line.startswith("check one with: "))
    words = shlex.split(line.removeprefix("check one with: "))
    assert words[0] == "tf-between"
    check = run_cli(*words, "--format", "json")
    assert check.returncode == 0, check.stderr
    assert json.loads(check.stdout)["translation"] == pytest.approx([float(v) for v in xyz], abs=1e-9)


def test_ik_all_on_the_panda_prints_the_ranked_set_with_intervals_and_labels():
    text = run_cli("manipkit", "ik", *PANDA, "--all")
    assert text.returncode == 0, text.stderr
    rows = [line for line in text.stdout.splitlines() if re.match(r"\d+\. \[", line)]
    assert len(rows) == 16
    assert "finger" not in text.stdout
    assert all("panda_joint7 = " in row and "; limits " in row for row in rows)
    printed = [(m.group(1), float(m.group(2)), float(m.group(3))) for m in
               re.finditer(r"feasible: \[(.+?)\] panda_joint7 from (\S+) to (\S+) rad", text.stdout)]
    data = json.loads(run_cli("manipkit", "ik", *PANDA, "--all", "--format", "json").stdout)
    assert [(i["branch"], i["low"], i["high"]) for i in data["intervals"]] == [
        (b, pytest.approx(low, abs=1e-6), pytest.approx(high, abs=1e-6)) for b, low, high in printed]
    assert data["parameter"] == "panda_joint7 (locked)" and data["ranked_by"] == "limits"
    assert len(data["solutions"]) == len(data["parameter_values"]) == len(data["scores"]) == 16
    assert all(set(q) == {f"panda_joint{k}" for k in range(1, 8)} for q in data["solutions"])
    assert np.all(np.diff(data["scores"]) <= 0)
    # the text rows are the JSON rows, in the same order
    first = dict(word.split("=") for word in rows[0].split("] ")[1].split())
    assert {k: float(v) for k, v in first.items()} == pytest.approx(data["solutions"][0], abs=1e-6)
    check_line_lands(text.stdout, PANDA[3:6])


def test_count_and_rank_options():
    data = json.loads(run_cli("manipkit", "ik", *PANDA, "--all", "--count", "5", "--rank", "manipulability",
                              "--format", "json").stdout)
    assert len(data["solutions"]) == 5 and data["ranked_by"] == "manipulability"
    robot = manipkit.load("panda")
    chain = robot.chain("base_link", "ee_link")
    J = chain.jacobians(np.array([[q[name] for name in chain.joint_names] for q in data["solutions"]]))
    assert np.sqrt(np.linalg.det(J @ np.swapaxes(J, 1, 2))) == pytest.approx(data["scores"], rel=1e-9)


@pytest.mark.parametrize("options", [["--count", "0"], ["--count", "1000000000"], ["--count", "many"],
                                     ["--rank", "speed"], ["--rank", "clearance"]])
def test_bad_count_or_rank_is_one_line_and_exit_2(options):
    result = run_cli("manipkit", "ik", *PANDA, "--all", *options)
    assert result.returncode == 2 and result.stdout == ""
    assert len(result.stderr.strip().splitlines()) == 1, result.stderr


def test_the_iiwa_prints_its_arm_angle_intervals():
    xyz = ["0.4", "0.1", "0.5"]
    result = run_cli("manipkit", "ik", "--robot", "iiwa14", "--xyz", *xyz, "--rpy", "3.14159", "0", "0", "--all")
    assert result.returncode == 0, result.stderr
    assert "across the self-motion of psi (arm angle)" in result.stdout and "feasible: [" in result.stdout
    assert len(re.findall(r"^\d+\. \[.*; psi = ", result.stdout, flags=re.M)) == 16
    check_line_lands(result.stdout, xyz)


@pytest.mark.parametrize("options", [
    ["--robot", "panda", "--lock", "panda_joint7=0.5", "--all"],
    ["--robot", "panda", "--position-only"],
    ["--robot", "ur5", "--tip", "tool0", "--all"],
])
def test_every_arm_prints_only_its_own_joints_and_the_check_line_lands(options):
    xyz = ["0.4", "0.1", "0.5"]
    orientation = [] if "--position-only" in options else ["--rpy", "3.14159", "0", "0"]
    result = run_cli("manipkit", "ik", *options, "--xyz", *xyz, *orientation)
    assert result.returncode == 0, result.stderr
    assert "finger" not in result.stdout
    check_line_lands(result.stdout, xyz)
