"""benchmarks/bench_path_peers.py: the check of a peer's joint trajectory and the peer subprocess, with a fake peer.

No real peer is needed (roboplan and Tesseract live in their own venvs, ``make peers``): the fake peer is a
script written here, run by this interpreter, and the trajectories checked are made from plan_path's own
answer, whose every waypoint lands by FK (plan_path checks it to 1e-9).
"""

import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import manipkit  # noqa: E402
from benchmarks import bench_path_peers  # noqa: E402
from manipkit.paths.plan import plan_path  # noqa: E402


@pytest.fixture(scope="module")
def line():
    """A 20-waypoint UR5 line, 1 cm steps along x from FK of a fixed configuration, and its plan."""
    chain = manipkit.load("ur5").chain("base_link", "tool0")
    q0 = np.array([0.3, -1.2, 1.4, -1.6, -1.5, 0.2])
    poses = np.repeat(chain.fk(q0)[None], 20, axis=0)
    poses[:, 0, 3] += 0.01 * np.arange(20)
    plan = plan_path(chain, poses, speed=0.1)
    assert plan.feasible
    return chain, q0, poses, plan


def test_the_plans_own_path_is_completed_at_its_cost(line):
    chain, _, poses, plan = line
    check = bench_path_peers.check_peer_path(chain, poses, plan.q)
    assert check["completed"] and check["reached"] == 20
    # summed |dq| by hand: the plan's cost is the same sum (its default cost, weights 1)
    assert check["cost"] == pytest.approx(np.abs(np.diff(plan.q, axis=0)).sum(), abs=1e-12)
    assert check["cost"] == pytest.approx(plan.cost, abs=1e-9)


def test_samples_between_waypoints_are_allowed_and_add_no_motion(line):
    chain, _, poses, plan = line
    middle = 0.5 * (plan.q[:-1] + plan.q[1:])  # on the joint segment: |dq| splits in two halves
    Q = np.empty((2 * len(plan.q) - 1, plan.q.shape[1]))
    Q[0::2], Q[1::2] = plan.q, middle
    check = bench_path_peers.check_peer_path(chain, poses, Q)
    assert check["completed"]
    assert check["cost"] == pytest.approx(plan.cost, abs=1e-9)


def test_a_waypoint_missed_by_more_than_the_tolerance_stops_the_count(line):
    chain, _, poses, plan = line
    Q = plan.q.copy()
    Q[7, 0] += 1e-5  # the base joint turned 1e-5 rad: the tool's rotation is off by 1e-5 rad > 1e-6
    check = bench_path_peers.check_peer_path(chain, poses, Q)
    assert not check["completed"] and check["reached"] == 7 and check["cost"] is None
    loose = bench_path_peers.check_peer_path(chain, poses, Q, (1e-3, 1e-3))
    assert loose["completed"]


def test_waypoints_must_be_reached_in_order(line):
    chain, _, poses, plan = line
    check = bench_path_peers.check_peer_path(chain, poses, plan.q[::-1])
    assert check["reached"] == 1 and not check["completed"]  # waypoint 0 only at the last sample


FAKE_PEER = """
import sys
import numpy as np
data = np.load(sys.argv[1])
out = {}
for k in range(int(data["paths"])):
    out[f"q_{k}"] = np.repeat(data[f"q0_{k}"][None], 3, axis=0)  # stands still at the start
    out[f"seconds_{k}"] = 0.5
    out[f"error_{k}"] = "" if k else "RuntimeError: gave up"
np.savez(sys.argv[2], **out)
"""


def test_run_peer_feeds_the_poses_through_a_file_and_reads_the_answers(line, tmp_path):
    chain, q0, poses, _ = line
    script = tmp_path / "fake_peer.py"
    script.write_text(FAKE_PEER, encoding="utf-8")
    lines = [(q0, poses, 0.1), (q0, poses, 0.2)]
    answers, why = bench_path_peers.run_peer("fake", lines, chain, str(chain.robot.source.path),
                                             python=Path(sys.executable), script=script)
    assert why == "" and len(answers) == 2
    assert answers[0][2] == "RuntimeError: gave up" and answers[1][2] == ""
    assert answers[1][1] == 0.5 and np.array_equal(answers[1][0][0], q0)
    assert bench_path_peers.check_peer_path(chain, poses, answers[1][0])["reached"] == 1


def test_a_missing_peer_venv_is_named_not_raised(line, tmp_path):
    chain, q0, poses, _ = line
    answers, why = bench_path_peers.run_peer("fake", [(q0, poses, 0.1)], chain, "x.urdf",
                                             python=tmp_path / "no" / "python", script=tmp_path / "x.py")
    assert answers is None and "missing (make peers)" in why


def test_a_crashing_peer_reports_its_error_line(line, tmp_path):
    chain, q0, poses, _ = line
    script = tmp_path / "crash.py"
    script.write_text("raise ValueError('Mesh package://x could not be found.')\n", encoding="utf-8")
    answers, why = bench_path_peers.run_peer("fake", [(q0, poses, 0.1)], chain, "x.urdf",
                                             python=Path(sys.executable), script=script)
    assert answers is None and why == "ValueError: Mesh package://x could not be found."
