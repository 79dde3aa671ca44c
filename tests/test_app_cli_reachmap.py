"""``manipkit reachmap`` and ``manipkit base-placement`` as a user runs them (in this process, tests/cli_helper.py).

Independent sources: the planar 3R (4, 2, 1) map's reachable voxels against
r in [1, 7] (closed form, ``workspace_3r``); base placement against targets
made by FK from a known placement of the mobile manipulator.
"""

import json
import math
import os

import numpy as np
import pytest
from cli_helper import run_cli

from manipkit.analysis.reachmap import load
from manipkit.analysis.reachmap.placement import placement_transforms
from manipkit.closed_form.planar_workspace import workspace_3r


@pytest.fixture(scope="module")
def map_3r(tmp_path_factory):
    folder = tmp_path_factory.mktemp("maps")
    out = run_cli("manipkit", "reachmap", "--robot", "planar_3r", "--voxel", "0.5", "--orientations", "8", "--samples", "20000",
              "--method", "hybrid", "-o", folder / "p3r.zarr", "--plot", folder / "p3r.png", "--format", "json",
              "--plot-manipulability", folder / "w.png", "--view-html", folder / "p3r.html", status=0)
    return folder, json.loads(out.stdout)


def test_reachmap_writes_a_map_whose_reachable_voxels_are_the_annulus(map_3r):
    folder, summary = map_3r
    assert summary["robot"] == "planar_3r" and summary["shape"] == [31, 31, 1] and summary["orientations"] == 8
    reach_map = load(folder / "p3r.zarr")
    assert int(reach_map.reachable.sum()) == summary["reachable_voxels"]
    r_min, r_max = workspace_3r(4.0, 2.0, 1.0).reachable
    radius = np.linalg.norm(reach_map.centers()[..., :2], axis=-1)
    half_diagonal = 0.5 * math.sqrt(2) / 2
    assert reach_map.reachable[(radius > r_min + half_diagonal) & (radius < r_max - half_diagonal)].all()
    assert not reach_map.reachable[(radius < r_min - half_diagonal) | (radius > r_max + half_diagonal)].any()
    assert (folder / "p3r.png").stat().st_size > 10_000


def test_reachmap_reports_the_best_manipulability_and_draws_it(map_3r):
    folder, summary = map_3r
    reach_map = load(folder / "p3r.zarr")
    best = np.nanmax(reach_map.manipulability)
    assert summary["best_manipulability"] == best
    ijk = np.unravel_index(np.nanargmax(reach_map.manipulability), reach_map.shape)
    assert summary["best_manipulability_at"] == reach_map.centers()[ijk].tolist()
    assert (folder / "w.png").stat().st_size > 10_000 and summary["plot_manipulability"] == str(folder / "w.png")
    html = (folder / "p3r.html").read_text()
    assert html.count("data:application/octet-binary;base64,") > 10 and summary["view_html"] == str(folder / "p3r.html")


def test_reachmap_without_manipulability(tmp_path):
    out = run_cli("manipkit", "reachmap", "--robot", "planar_2r", "--voxel", "0.25", "--orientations", "4", "--samples", "5000",
              "-o", tmp_path / "m.zarr", "--no-manipulability", status=0).stdout
    assert "manipulability" not in out and load(tmp_path / "m.zarr").manipulability is None


def test_reachmap_text_summary(tmp_path):
    out = run_cli("manipkit", "reachmap", "--robot", "planar_2r", "--voxel", "0.25", "--orientations", "4", "--samples", "5000",
              "-o", tmp_path / "m.zarr", status=0).stdout
    assert out.startswith("reachability map of planar_2r: ee_link in base_link, method hybrid\n")  # a planar default
    assert "grid 19x19x1 voxels of 0.25 m" in out and out.rstrip().endswith(f"wrote {tmp_path / 'm.zarr'}")
    # planar 2R (1, 1): the index |sin q2| peaks at 1 (elbow square, r = sqrt 2); 5000 samples come within 1e-3
    line = next(x for x in out.splitlines() if x.startswith("manipulability (Yoshikawa, the plane's translation rows)"))
    assert float(line.split("best ")[1].split(" ")[0]) > 0.999


def test_base_placement_finds_the_placement_the_targets_were_made_from(load_robot, tmp_path):
    robot = load_robot("mobile_manipulator")
    T = placement_transforms(2.0, 1.0, math.pi / 2) @ robot.fk(robot.sample_q(6, seed=3), base="base_footprint", tip="ee_link")
    lines = ["# x y z then a 4x4"]
    from manipkit.spatial.rotations import rpy_from_matrix

    for pose in T[:5]:
        lines.append(" ".join(repr(float(v)) for v in [*pose[:3, 3], *rpy_from_matrix(pose[:3, :3])]))
    lines += [" ".join(repr(float(v)) for v in row) for row in T[5]]
    (tmp_path / "targets.txt").write_text("\n".join(lines) + "\n")
    run_cli("manipkit", "reachmap", "--robot", "mobile_manipulator", "--base", "base_footprint", "--voxel", "0.1", "--orientations", "6",
        "--samples", "100000", "-o", tmp_path / "mm.zarr", status=0)
    out = json.loads(run_cli("manipkit", "base-placement", "--robot", "mobile_manipulator", "--targets", tmp_path / "targets.txt",
                         "--map", tmp_path / "mm.zarr", "--yaws", "4", "--plot", tmp_path / "bp.png", "--format", "json",
                         status=0).stdout)
    assert out["targets"] == 6 and out["map_estimate"] >= 5 and "any roll" in out["map_estimate_means"]
    # a 5-joint arm: IK matches the position and the tool's z axis (a full pose only from an exact placement)
    assert out["ik_mode"] == "position+axis" and out["ik_axis"] == "z" and out["candidates"] == 20
    # the printed confirmed count equals an independent IK count (random starts only) from the printed placement
    from manipkit.ik.numerical_many import ik_many

    T_B = np.linalg.inv(placement_transforms(out["x"], out["y"], out["yaw"])) @ T
    independent = ik_many(robot, T_B, "base_footprint", "ee_link", mode="position+axis", tol=1e-6, restarts=100,
                          seed=5)
    assert out["confirmed"] == int(np.sum(independent.success)) == sum(out["confirmed_targets"])
    assert out["confirmed"] == max(row["confirmed"] for row in out["candidates_tried"])
    # the best placement reaches as many as the true one: it lies within the arm's reach (< 1 m) of every target
    assert np.hypot(T[:, 0, 3] - out["x"], T[:, 1, 3] - out["y"]).max() < 1.0
    assert (tmp_path / "bp.png").stat().st_size > 10_000


def test_base_placement_of_full_poses_from_an_off_grid_base_is_confirmed_by_ik(load_robot, tmp_path):
    # The testers' case (issue 39): 8 full poses made by the mobile manipulator's 5-joint arm (arm_base, shoulder,
    # bottom_wrist, elbow, top_wrist) from a base pose off the search's grid (yaw 40 deg; the 16 headings are
    # 22.5 deg apart), base-placement run as a user runs it (its own map). Ranked by the map alone it printed a
    # placement from which IK confirmed 0 of 8 full poses: a 5-joint arm reaches a 5-dimensional set of poses, so
    # only the exact base reaches them. IK now re-scores the map's best placements in the mode the arm allows, the
    # position and the tool's z axis, and the printed placement must reach as many as the true base does.
    robot = load_robot("mobile_manipulator")
    assert len(robot.chain("base_footprint", "ee_link").joint_names) == 5
    true_base = placement_transforms(1.3, -0.7, math.radians(40.0))
    T = true_base @ robot.fk(robot.sample_q(8, seed=1), base="base_footprint", tip="ee_link")
    from manipkit.spatial.rotations import rpy_from_matrix

    lines = [" ".join(repr(float(v)) for v in [*pose[:3, 3], *rpy_from_matrix(pose[:3, :3])]) for pose in T]
    (tmp_path / "targets.txt").write_text("\n".join(lines) + "\n")
    out = json.loads(run_cli("manipkit", "base-placement", "--robot", "mobile_manipulator", "--targets",
                             tmp_path / "targets.txt", "--format", "json", status=0).stdout)
    assert out["ik_mode"] == "position+axis" and out["targets"] == 8
    from manipkit.ik.numerical_many import ik_many

    def independent(T_F_P, mode):
        """Targets IK reaches from the floor placement T_F_P (random starts, not the map's seeds), each checked by FK."""
        T_B = np.linalg.inv(T_F_P) @ T
        batch = ik_many(robot, T_B, "base_footprint", "ee_link", mode=mode, tol=1e-6, restarts=100, seed=7)
        for q, target in zip(batch.q[batch.success], T_B[batch.success]):
            reached = robot.transform("base_footprint", "ee_link", q)
            assert np.linalg.norm(reached[:3, 3] - target[:3, 3]) < 1e-6
            assert math.acos(min(1.0, float(reached[:3, 2] @ target[:3, 2]))) < 1e-5
            if mode == "pose":
                assert np.abs(reached[:3, :3] - target[:3, :3]).max() < 1e-5
        return int(batch.success.sum())

    printed = placement_transforms(out["x"], out["y"], out["yaw"])
    assert independent(true_base, "pose") == 8  # full poses of this arm from the true base
    reached_from_true = independent(true_base, "position+axis")
    assert reached_from_true == 8
    assert out["confirmed"] == independent(printed, "position+axis") >= reached_from_true
    assert out["confirmed_full_pose"] == independent(printed, "pose")  # said, not hidden: off the exact base
    # refined off the grid (the base pose and the arm's joints searched together): the full poses, all 8 as from the
    # true base; the true base and the refined one put the arm's first axis (0.05 m behind the base centre) at the
    # same floor point (the arm's first joint is continuous, so the heading about it is free)
    refined = out["refined"]
    found = placement_transforms(refined["x"], refined["y"], refined["yaw"])
    assert refined["confirmed_full_pose"] == independent(found, "pose") == 8
    axis = robot.transform("base_footprint", "arm_base")[:, 3]
    np.testing.assert_allclose((found @ axis)[:2], (true_base @ axis)[:2], atol=1e-6)


@pytest.mark.parametrize(
    ("args", "expect"),
    [
        (["reachmap", "--robot", "planar_3r", "--voxel", "0", "-o", "{tmp}/m.zarr"], "voxel 0.0: give the voxel edge"),
        (["reachmap", "--robot", "planar_3r", "--orientations", "3x", "-o", "{tmp}/m.zarr"], "orientations '3x'"),
        (["reachmap", "--robot", "planar_3r", "--orientations", "8x2", "-o", "{tmp}/m.zarr", "--samples", "10"],
         "the arm is planar"),
        (["reachmap", "--robot", "planar_3r", "--method", "ik", "-o", "{tmp}/m.zarr"], "invalid choice: 'ik'"),
        (["reachmap", "--robot", "planar_3r", "-o", "{tmp}/missing/m.zarr"], "no such folder"),
        (["reachmap", "--robot", "planar_3r", "-o", "{tmp}"], "it exists and is not a reachability map"),
        (["reachmap", "--robot", "planar_3r", "--workers", "0", "-o", "{tmp}/m.zarr"], "workers 0"),
        (["reachmap", "--robot", "planar_3r", "--workers", "2", "--scheduler", "tcp://h:1", "-o", "{tmp}/m.zarr"],
         "not allowed with argument --workers"),
        (["reachmap", "--robot", "planar_3r", "--frame", "nope", "-o", "{tmp}/m.zarr"], "nope"),
        (["reachmap", "--robot", "planar_3r", "-o", "{tmp}/m.zarr", "--no-manipulability", "--plot-manipulability",
          "{tmp}/w.png"], "--plot-manipulability needs the overlay"),
        (["reachmap", "--robot", "planar_3r", "-o", "{tmp}/m.zarr", "--view-html", "{tmp}/missing/v.html"],
         "cannot write"),
        (["reachmap", "--robot", "planar_3r"], "give -o MAP, the folder to write the map to"),
        (["reachmap", "show", "{tmp}/none.zarr"], "none.zarr: no such reachability map"),
        (["reachmap", "show", "{tmp}"], "not a manipkit reachability map"),
        (["reachmap", "show"], "the following arguments are required: MAP"),
        (["reachmap", "--voxel", "0.1", "show", "{tmp}/none.zarr"], "--voxel sets how a map is built"),
        (["reachmap", "-o", "{tmp}/m.zarr", "show", "{tmp}/none.zarr"], "-o sets how a map is built"),
        (["reachmap", "show", "{tmp}/none.zarr", "--plot", "{tmp}/missing/p.png"], "cannot write"),
        (["base-placement", "--robot", "planar_3r", "--targets", "{tmp}/none.txt"], "no such file"),
        (["base-placement", "--robot", "planar_3r", "--targets", "{tmp}/bad.txt"], "bad.txt line 2: 2 numbers"),
        (["base-placement", "--robot", "planar_3r", "--targets", "{tmp}/good.txt", "--map", "{tmp}"],
         "not a manipkit reachability map"),
        (["base-placement", "--robot", "planar_3r", "--targets", "{tmp}/good.txt", "--yaws", "0"], "--yaws 0"),
    ],
)
def test_bad_input_is_one_line_and_status_2(tmp_path, args, expect):
    (tmp_path / "bad.txt").write_text("1 2 3 0 0 0\n1 2\n")
    (tmp_path / "good.txt").write_text("1 2 0 0 0 0\n")
    result = run_cli("manipkit", *(a.replace("{tmp}", str(tmp_path)) for a in args))
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and expect in lines[0], result.stderr
    assert "Traceback" not in result.stderr + result.stdout


def test_base_placement_with_a_map_refuses_settings_the_map_already_fixed(map_3r, tmp_path):
    targets = tmp_path / "targets.txt"
    targets.write_text("4 2 0 0 0 0\n")
    out = run_cli("manipkit", "base-placement", "--robot", "planar_3r", "--targets", targets, "--map", map_3r[0] / "p3r.zarr", "--voxel", "0.1", status=2)
    assert "--voxel sets how a map is built" in out.stderr and out.stderr.count("\n") == 1
    out = run_cli("manipkit", "base-placement", "--robot", "planar_3r", "--targets", targets, "--map", map_3r[0] / "p3r.zarr", "--frame", "link2",
              status=2)
    assert "is a map of 'ee_link', not of 'link2'" in out.stderr


def _interrupt(args, cwd, delay, until=None):
    """Run ``manipkit ARGS`` as a user at a terminal does and press Ctrl-C (SIGINT to the group) after ``delay`` s
    (and once ``until()`` is true, if given: at most 300 s)."""
    import os
    import signal
    import subprocess
    import sys
    import time

    process = subprocess.Popen([sys.executable, "-m", "manipkit.app.cli", *args], cwd=cwd, text=True,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True,
                               preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    time.sleep(delay)
    deadline = time.monotonic() + 300
    while until is not None and not until() and time.monotonic() < deadline and process.poll() is None:
        time.sleep(0.05)
    os.killpg(process.pid, signal.SIGINT)
    try:
        out, err = process.communicate(timeout=60)
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
    return process.returncode, out, err


@pytest.mark.parametrize("where", [[], ["--workers", "1"]], ids=["here", "local-cluster"])
def test_ctrl_c_ends_a_build_with_one_line_and_status_130_and_keeps_the_finished_blocks(tmp_path, where):
    import os

    args = ["reachmap", "--robot", "iiwa14", "--samples", "2000000000", *where, "-o", "m.zarr"]
    status, out, err = _interrupt(args, tmp_path, 1.0, until=lambda: any((tmp_path / ".m.zarr.partial").glob("*.npz")))
    assert status == 130, err
    assert os.listdir(tmp_path) == [".m.zarr.partial"]  # no map folder; the finished blocks beside where it goes
    kept = sorted(os.listdir(tmp_path / ".m.zarr.partial"))
    assert kept[0] == "blocks.json" and len(kept) > 1 and all(name.startswith("sample_block-") for name in kept[1:])
    assert err == f"{len(kept) - 1} finished block(s) kept in .m.zarr.partial: the same command resumes from them\n" \
        "manipkit: interrupted\n", err  # no worker traceback, no Dask log line


def test_output_paths_are_printed_through_the_sanitiser(tmp_path):
    name = "m\x1b[2J\nforged.zarr"
    out = run_cli("manipkit", "reachmap", "--robot", "planar_2r", "--voxel", "0.5", "--samples", "500",
                  "-o", tmp_path / name, status=0)
    assert "\x1b" not in out.stdout and "\nforged" not in out.stdout and "m\\x1b[2J\\x0aforged.zarr" in out.stdout


def test_show_prints_and_draws_what_the_build_did(map_3r, tmp_path):
    folder, built = map_3r
    out = run_cli("manipkit", "reachmap", "show", folder / "p3r.zarr", "--format", "json", "--plot", tmp_path / "p.png",
                  "--plot-manipulability", tmp_path / "w.png", "--view-html", tmp_path / "v.html", status=0)
    shown = json.loads(out.stdout)
    assert shown == {**built, "plot": str(tmp_path / "p.png"), "plot_manipulability": str(tmp_path / "w.png"),
                     "view_html": str(tmp_path / "v.html")}
    assert shown["completeness"]["n"] > 0 and "voxel" in shown["a_yes_means"]  # the checks the build stored
    # the same pictures: the PNG slices are byte for byte the build's (same map, same code path)
    assert (tmp_path / "p.png").read_bytes() == (folder / "p3r.png").read_bytes()
    assert (tmp_path / "w.png").read_bytes() == (folder / "w.png").read_bytes()
    html = (tmp_path / "v.html").read_text()  # the view loads the map's robot by the name it stores
    assert html.count("data:application/octet-binary;base64,") == (folder / "p3r.html").read_text().count(
        "data:application/octet-binary;base64,")


def test_show_text_is_the_build_summary(tmp_path):
    options = ["--voxel", "0.25", "--orientations", "4", "--samples", "5000"]
    built = run_cli("manipkit", "reachmap", "--robot", "planar_2r", *options, "-o", tmp_path / "m.zarr",
                    "--collisions", "self", status=0).stdout
    shown = run_cli("manipkit", "reachmap", "show", tmp_path / "m.zarr", status=0).stdout
    assert built == shown + f"wrote {tmp_path / 'm.zarr'}\n"
    assert "collision-free only: self" in shown and "its support is at least 0.65" in shown
    assert "a yes means: the pose's voxel-bin was reached (the position's 0.25 m voxel" in shown


def test_base_placement_text_says_what_the_map_estimate_counts(tmp_path):
    (tmp_path / "t.txt").write_text("1.5 0 0 0 0 0\n0.5 0.5 0 0 0 0\n")
    run_cli("manipkit", "reachmap", "--robot", "planar_2r", "--voxel", "0.1", "--orientations", "1", "--samples", "20000",
            "-o", tmp_path / "m.zarr", status=0)
    out = run_cli("manipkit", "base-placement", "--robot", "planar_2r", "--targets", tmp_path / "t.txt", "--map",
                  tmp_path / "m.zarr", "--yaws", "2", status=0).stdout
    estimate = next(line for line in out.splitlines() if line.startswith("the map estimates "))
    assert "counting the targets it says yes to; a yes means: the pose's voxel-bin was reached (the position's 0.1 m " \
           "voxel" in estimate and "its support is at least 0.65" in estimate and "interpolate=False" in estimate


def test_show_view_needs_the_maps_robot(map_3r, tmp_path):
    folder, _ = map_3r
    out = run_cli("manipkit", "reachmap", "show", folder / "p3r.zarr", "--robot", "planar_2r", "--view-html",
                  tmp_path / "v.html", status=2)
    assert out.stderr.count("\n") == 1 and "the map is of 'planar_3r': give its robot" in out.stderr
    assert not (tmp_path / "v.html").exists()


def test_show_view_of_a_map_of_a_description_file_needs_that_file(tmp_path):
    import shutil

    from manipkit.description.sources import bundled_dir

    for path in bundled_dir().glob("*.xacro"):
        shutil.copy(path, tmp_path)
    arm = tmp_path / "planar_2r.urdf.xacro"
    arm.write_text(arm.read_text().replace('name="planar_2r"', 'name="my_arm"'))
    run_cli("manipkit", "reachmap", "--robot", arm, "--voxel", "0.5", "--samples", "500", "-o", tmp_path / "m.zarr",
            status=0)
    out = run_cli("manipkit", "reachmap", "show", tmp_path / "m.zarr", "--format", "json", status=0)  # no robot needed
    assert json.loads(out.stdout)["robot"] == "my_arm"
    out = run_cli("manipkit", "reachmap", "show", tmp_path / "m.zarr", "--view-html", tmp_path / "v.html", status=2)
    assert out.stderr.count("\n") == 1 and "the map's robot 'my_arm', which does not load by that name" in out.stderr
    run_cli("manipkit", "reachmap", "show", tmp_path / "m.zarr", "--view-html", tmp_path / "v.html", "--robot", arm,
            status=0)
    assert (tmp_path / "v.html").read_text().count("data:application/octet-binary;base64,") > 1


def test_show_never_reads_a_description_path_the_map_names(tmp_path):
    # A map from anywhere names its robot; a name that is a path is not loaded for the view (nothing is read).
    import shutil

    from manipkit.description.sources import bundled_dir

    for path in bundled_dir().glob("*.xacro"):
        shutil.copy(path, tmp_path)
    arm = tmp_path / "planar_2r.urdf.xacro"
    run_cli("manipkit", "reachmap", "--robot", "planar_2r", "--voxel", "0.5", "--samples", "500", "-o",
            tmp_path / "m.zarr", status=0)
    attrs = tmp_path / "m.zarr" / "zarr.json"
    text = attrs.read_text()
    assert text.count('"planar_2r"') == 1
    attrs.write_text(text.replace('"planar_2r"', json.dumps(str(arm))))  # the stored name is now a file's path
    out = run_cli("manipkit", "reachmap", "show", tmp_path / "m.zarr", "--view-html", tmp_path / "v.html",
                  cwd=tmp_path, status=2)
    assert out.stderr.count("\n") == 1 and "which does not load by that name" in out.stderr
    assert not (tmp_path / "v.html").exists()


def test_show_refuses_the_manipulability_plot_of_a_map_without_it(tmp_path):
    run_cli("manipkit", "reachmap", "--robot", "planar_2r", "--voxel", "0.5", "--samples", "500", "--no-manipulability",
            "-o", tmp_path / "m.zarr", status=0)
    out = run_cli("manipkit", "reachmap", "show", tmp_path / "m.zarr", "--plot-manipulability", tmp_path / "w.png",
                  status=2)
    assert out.stderr.count("\n") == 1 and "was built without the manipulability overlay" in out.stderr


def test_help_documents_build_and_show():
    out = run_cli("manipkit", "reachmap", "--help", status=0).stdout
    assert "manipkit reachmap [--robot R]" in out and "-o MAP" in out and "manipkit reachmap show MAP" in out
    assert ".MAP.partial" in out


def test_ctrl_c_keeps_the_finished_blocks_and_the_same_command_resumes(tmp_path, monkeypatch):
    import contextlib
    import os

    import manipkit.app.progress

    command = ["manipkit", "reachmap", "--robot", "planar_3r", "--voxel", "0.5", "--orientations", "8", "--samples",
               "40000", "--converge", "0", "--method", "hybrid", "--no-manipulability"]
    first = run_cli(*command, "-o", tmp_path / "reference.zarr", status=0)
    assert "40000 samples in 1 blocks (converge 0: every sample of the budget drawn)" in first.stdout
    work = tmp_path / "work"
    work.mkdir()

    @contextlib.contextmanager
    def ctrl_c_after_the_first_block(enabled=None):
        def progress(stage, done, total):
            if done == 1:
                raise KeyboardInterrupt  # what the runner raises where it waits after a Ctrl-C
        yield progress

    with monkeypatch.context() as patch:
        patch.setattr(manipkit.app.progress, "progress_bar", ctrl_c_after_the_first_block)
        out = run_cli(*command, "-o", work / "m.zarr", status=130)
    assert out.stderr == f"1 finished block(s) kept in {work / '.m.zarr.partial'}: the same command resumes from them\n" \
        "manipkit: interrupted\n"
    assert os.listdir(work) == [".m.zarr.partial"]
    out = run_cli(*command, "-o", work / "m.zarr", status=0)
    assert out.stderr == "resuming: 1 of 1 blocks of FK samples already done\n"
    assert os.listdir(work) == ["m.zarr"]  # the blocks are removed once the map is saved
    reference = {p.relative_to(tmp_path / "reference.zarr"): p.read_bytes()
                 for p in sorted((tmp_path / "reference.zarr").rglob("*")) if p.is_file()}
    assert reference == {p.relative_to(work / "m.zarr"): p.read_bytes() for p in sorted((work / "m.zarr").rglob("*"))
                         if p.is_file()}


def test_a_build_writes_nowhere_but_beside_its_output(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "maps").mkdir()
    run_cli("manipkit", "reachmap", "--robot", "planar_2r", "--voxel", "0.5", "--samples", "500", "-o",
            "maps/m.zarr", status=0)
    assert sorted(os.listdir(tmp_path)) == ["maps"] and os.listdir(tmp_path / "maps") == ["m.zarr"]


def test_reachmap_query_decides_the_boundary_band_by_ik_by_default(map_3r, tmp_path):
    folder, _ = map_3r
    # by hand: the planar 3R (4, 2, 1) reaches (x, y, phi) iff its wrist point (x, y) - 1 (cos phi, sin phi) lies in
    # 2 <= r <= 6 (4 - 2 to 4 + 2); poses 0.1 on either side of both circles, and some deep inside at r = 4
    rng = np.random.default_rng(1)
    lines, truth = [], []
    for radius, reachable in ((5.9, True), (6.1, False), (2.1, True), (1.9, False), (4.0, True)):
        for a, phi in rng.uniform(-math.pi, math.pi, (8, 2)).tolist():
            x, y = radius * math.cos(a) + math.cos(phi), radius * math.sin(a) + math.sin(phi)
            lines.append(f"{x!r} {y!r} 0 0 0 {phi!r}")
            truth.append(reachable)
    (tmp_path / "t.txt").write_text("\n".join(lines) + "\n")
    truth = np.array(truth)
    reach_map = load(folder / "p3r.zarr")
    out = run_cli("manipkit", "reachmap", "query", folder / "p3r.zarr", "--targets", tmp_path / "t.txt", status=0).stdout
    rows = [x for x in out.splitlines() if x.startswith("pose ")]
    said = np.array([x.split(": ")[1].startswith("reachable") for x in rows])
    by_ik = np.array(["decided by IK;" in x for x in rows])
    assert len(rows) == 40 and 0 < by_ik.sum() < 40
    assert f"decided by IK near the boundary: {by_ik.sum()} of 40 poses" in out.splitlines()[-1]
    assert np.array_equal(said[by_ik], truth[by_ik])  # IK's answers are the hand derivation's
    from manipkit.inputs.poses import read_targets

    plain = reach_map.query(read_targets(tmp_path / "t.txt"), refine=False)
    assert np.array_equal(said[~by_ik], plain[~by_ik]) and (said != truth).sum() < (plain != truth).sum()
    data = json.loads(run_cli("manipkit", "reachmap", "query", folder / "p3r.zarr", "--targets", tmp_path / "t.txt",
                              "--format", "json", status=0).stdout)
    assert data["refined"] and data["decided_by_ik"] == by_ik.sum() and data["poses_total"] == 40
    assert [p["reachable"] for p in data["poses"]] == said.tolist()
    unrefined = run_cli("manipkit", "reachmap", "query", folder / "p3r.zarr", "--targets", tmp_path / "t.txt",
                        "--no-refine", status=0).stdout
    assert "decided by IK;" not in unrefined and "decided by map;" in unrefined
    assert ("the map's unrefined estimate, not decided by IK (refinement turned off: refine=False, or --no-refine on the "
            "command line); measured "
            "error: completeness: of a held-out sample of") in unrefined.splitlines()[-1]
    assert sum(": reachable by the map (" in x for x in unrefined.splitlines()) == plain.sum()
    run_cli("manipkit", "reachmap", "--voxel", "0.1", "query", folder / "p3r.zarr", "--targets", tmp_path / "t.txt",
            status=2)


def test_reachmap_query_refuses_a_robot_with_no_refine_in_one_line(map_3r, tmp_path):
    # --robot asks for IK refinement by that robot, --no-refine for none: the two cannot both be meant
    folder, _ = map_3r
    (tmp_path / "t.txt").write_text("5 0 0 0 0 0\n")
    result = run_cli("manipkit", "reachmap", "query", folder / "p3r.zarr", "--targets", tmp_path / "t.txt",
                     "--robot", "planar_3r", "--no-refine", status=2)
    line, = result.stderr.strip().splitlines()
    assert "--robot" in line and "--no-refine" in line and "give one of them" in line and not result.stdout
