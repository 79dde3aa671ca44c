"""Hostile inputs of issue 40 that need more than a command line to set up (the corpus holds the rest).

Each test re-creates one case the testers found not clean and fails on the code before its fix: a crafted
reach map naming an SRDF, a texture larger than the bound, a mesh whose texture is a FIFO.
"""

import json
import os
from pathlib import Path

import pytest
from cli_helper import run_cli

from manipkit.bounds import MAX_TEXTURE_BYTES
from manipkit.description.access import ReadPolicy
from manipkit.description.meshes import check_mesh_file, mesh_references
from manipkit.errors import DescriptionError, InputFileError, ReadNotAllowedError

HERE = Path(__file__).parent / "bad_inputs" / "hostile_meshes"


def test_a_crafted_map_cannot_make_base_placement_read_an_srdf_of_its_choosing(tmp_path):
    run_cli("manipkit", "reachmap", "--robot", "planar_2r", "--voxel", "0.25", "--orientations", "1",
            "--samples", "500", "-o", tmp_path / "p.zarr", "--collisions", "self", status=0)
    meta = tmp_path / "p.zarr" / "zarr.json"
    record = json.loads(meta.read_text())
    assert record["attributes"]["settings"]["collisions"]["srdf"] is None
    record["attributes"]["settings"]["collisions"]["srdf"] = "/etc/passwd"
    meta.write_text(json.dumps(record))
    (tmp_path / "t.txt").write_text("0.5 0 0 0 0 0\n")
    result = run_cli("manipkit", "base-placement", "--robot", "planar_2r", "--targets", tmp_path / "t.txt",
                     "--map", tmp_path / "p.zarr")
    assert result.returncode == 2 and result.stderr.count("\n") == 1
    assert result.stderr.startswith("manipkit: error: --map ") and "its SRDF: /etc/passwd is outside what" in result.stderr
    assert "not a valid SRDF" not in result.stderr  # never opened


def _dae_naming(folder: Path, texture: str) -> Path:
    text = (HERE / "texture_dotdot.dae").read_text().replace("../descriptions/good_arm.urdf", texture)
    path = folder / "m.dae"
    path.write_text(text)
    return path


def test_a_texture_above_the_bound_is_refused_before_it_is_read(tmp_path):
    big = tmp_path / "big.png"
    with open(big, "wb") as stream:  # sparse: no disk used
        stream.truncate(MAX_TEXTURE_BYTES + 1)
    dae = _dae_naming(tmp_path, "big.png")
    with pytest.raises(InputFileError, match=r"m.dae names a texture .*big.png is 33,554,433 bytes, above the limit of 32 MB"):
        check_mesh_file(dae, "link 'a': mesh m.dae", ReadPolicy(dae))


def test_a_texture_that_is_a_fifo_or_missing_or_empty_is_refused(tmp_path):
    os.mkfifo(tmp_path / "pipe.png")
    with pytest.raises(InputFileError, match="is a FIFO"):
        check_mesh_file(_dae_naming(tmp_path, "pipe.png"), "m", ReadPolicy(tmp_path / "m.dae"))
    with pytest.raises(DescriptionError, match="texture <init_from> gone.png does not exist"):
        check_mesh_file(_dae_naming(tmp_path, "gone.png"), "m", ReadPolicy(tmp_path / "m.dae"))
    with pytest.raises(DescriptionError, match="has an empty texture <init_from>"):
        check_mesh_file(_dae_naming(tmp_path, ""), "m", ReadPolicy(tmp_path / "m.dae"))


def test_a_texture_inside_the_folder_is_read_and_one_outside_by_a_link_is_not(tmp_path):
    (tmp_path / "ok.png").write_bytes(b"\x89PNG\r\n")
    dae = _dae_naming(tmp_path, "ok.png")
    assert check_mesh_file(dae, "m", ReadPolicy(dae)) == dae
    (tmp_path / "link.png").symlink_to("/etc/hostname")
    with pytest.raises(ReadNotAllowedError, match=r"link.png \(a link to /etc/hostname\) is outside"):
        check_mesh_file(_dae_naming(tmp_path, "link.png"), "m", ReadPolicy(dae))


def test_mesh_references_are_the_files_the_loaders_read():
    assert mesh_references(HERE / "texture_environ.dae") == [("texture <init_from>", "/proc/self/environ", True)]
    assert mesh_references(HERE / "obj_mtllib_passwd.obj") == [("mtllib", "/etc/passwd", False)]
    assert mesh_references(HERE / "flat.stl") == []


@pytest.mark.parametrize("geometry", ["hulls", "meshes"])
def test_a_flat_collision_mesh_is_a_thin_plate_not_a_crash(tmp_path, geometry):
    """flat.stl: a 0.1 m square plate at z = 0 of upper_arm, which is 0.3 m above base_link at q = 0; base_link's
    box (0.05 m high, centred) tops at z = 0.025, so the distance is 0.275 m by hand. Hull building segfaulted."""
    import subprocess
    import sys

    env = {**os.environ, "PYTHONPATH": str(Path(__file__).parents[1] / "src")}
    result = subprocess.run([str(Path(sys.executable).parent / "manipkit"), "collisions", "--robot",
                             str(HERE / "flat_mesh.urdf"), "--geometry", geometry], capture_output=True, text=True,
                            cwd=tmp_path, env=env, timeout=300)
    assert result.returncode == 0, result.stderr
    assert "closest pair: base_link - upper_arm, distance 0.2750 m" in result.stdout
    assert result.stderr == ""


def _chain(path: Path, joints: int, namespace: str = "") -> Path:
    """A URDF chain of ``joints`` fixed joints, 1 mm apart along z (elements in ``namespace`` if given)."""
    ns = f' xmlns="{namespace}"' if namespace else ""
    rows = ['<robot name="deep">', '<link name="l0"/>']
    rows += [f'<link name="l{i}"{ns}/><joint name="j{i}" type="fixed"{ns}><parent link="l{i - 1}"/>'
             f'<child link="l{i}"/><origin xyz="0 0 0.001"/></joint>' for i in range(1, joints + 1)]
    path.write_text("\n".join(rows + ["</robot>\n"]))
    return path


def _manipkit_limited(tmp_path, *args, stack_kb: int = 4096):
    import subprocess
    import sys

    env = {**os.environ, "PYTHONPATH": str(Path(__file__).parents[1] / "src")}
    command = ["/bin/bash", "-c", f'ulimit -s {stack_kb} && exec "$@"', "bash",
               str(Path(sys.executable).parent / "manipkit"), *map(str, args)]
    return subprocess.run(command, capture_output=True, text=True, cwd=tmp_path, env=env, timeout=600)


def test_the_deepest_chain_allowed_loads_under_a_4_mb_stack(tmp_path):
    """2000 joints (MAX_TREE_DEPTH) segfaulted Pinocchio's recursive parser on a 4 MB main-thread stack; it runs
    on a thread with its own stack now. T_l0_l2000 is 2000 x 1 mm = 2 m along z, by hand."""
    result = _manipkit_limited(tmp_path, "tf", "l0", "l2000", "--robot", _chain(tmp_path / "deep.urdf", 2000),
                               "--format", "json")
    assert result.returncode == 0, result.stderr[-500:]
    matrix = json.loads(result.stdout)["matrix"]
    assert matrix[2][3] == pytest.approx(2.0, abs=1e-9) and matrix[0][3] == 0.0


def test_a_namespaced_4000_deep_chain_is_refused_not_a_segfault(tmp_path):
    result = _manipkit_limited(tmp_path, "frames", "--robot", _chain(tmp_path / "ns.urdf", 4000, "urn:x"))
    assert result.returncode == 2 and result.stderr.count("\n") == 1, result.stderr[-500:]
    assert "link 'l4000' is 4000 joints below root 'l0'; manipkit loads trees up to 2000 joints deep" in result.stderr


def test_did_you_mean_is_bounded_in_time_for_a_200000_character_near_miss():
    """41-51 s before (difflib over 200,000 characters); the name is quoted by a bounded prefix."""
    import time

    started = time.monotonic()
    result = run_cli("manipkit", "tf", "base_link", "shoulder_link" + "x" * 200_000)
    assert time.monotonic() - started < 10
    assert result.returncode == 2 and result.stderr.count("\n") == 1 and len(result.stderr) < 2000
    assert "has no frame 'shoulder_linkxxx" in result.stderr and "(200,013 characters)" in result.stderr


def test_world_numbers_as_yaml_reads_them(tmp_path):
    """YAML 1.1 reads 1e-3 as text; it is a number (a 1 mm sphere)."""
    from manipkit.kinematics.world import read_world

    path = tmp_path / "w.yaml"
    path.write_text("obstacles:\n  - {name: b, sphere: 1e-3, xyz: [1e-1, 0, -2E+0]}\n")
    (name, shape, T), = read_world(path)
    assert name == "b" and shape.radius == 0.001 and list(T[:3, 3]) == [0.1, 0.0, -2.0]


def test_an_obstacle_far_away_named_like_nothing_is_not_in_collision(tmp_path):
    """A 1 cm sphere 8 m away is free of the arm (before, named like a link it reported IN COLLISION)."""
    path = tmp_path / "w.yaml"
    path.write_text("obstacles:\n  - {name: far_ball, sphere: 0.01, xyz: [8, 0, 0]}\n")
    result = run_cli("manipkit", "collisions", "--robot", "course_arm", "--world", path, "--format", "json", status=0)
    assert json.loads(result.stdout)["in_collision"] is False


def _manipkit_env(tmp_path, *args, env=None, shell_prefix=""):
    import subprocess
    import sys

    full = {**os.environ, "PYTHONPATH": str(Path(__file__).parents[1] / "src"), **(env or {})}
    command = ["/bin/bash", "-c", f'{shell_prefix}exec "$@"', "bash", str(Path(sys.executable).parent / "manipkit"),
               *map(str, args)]
    return subprocess.run(command, capture_output=True, text=True, cwd=tmp_path, env=full, timeout=600)


def _one_line(result, fragment):
    assert result.returncode == 2, result.stderr[-800:]
    assert result.stderr.count("\n") == 1 and result.stderr.startswith("manipkit: error: "), result.stderr[-800:]
    assert fragment in result.stderr and "Traceback" not in result.stdout + result.stderr


@pytest.mark.parametrize("name, value, module", [("NUMBA_NUM_THREADS", "0", "numba"),
                                                 ("MPLBACKEND", "bogus", "matplotlib")])
def test_a_bogus_library_environment_variable_is_one_line(tmp_path, name, value, module):
    result = _manipkit_env(tmp_path, "tf", "base_link", "ee_link", "--robot", "planar_2r", env={name: value})
    _one_line(result, f"environment variable {name}='{value}' is refused by {module} (")


def test_frames_into_a_closed_pipe_ends_quietly(tmp_path):
    """`frames | head -1` exited 1 with no message (rich raises SystemExit(1) on a closed pipe)."""
    result = _manipkit_env(tmp_path, "frames", "--robot", "panda", shell_prefix="set -o pipefail; ")
    assert result.returncode == 0
    import subprocess

    piped = subprocess.run(f'"{Path(os.sys.executable).parent / "manipkit"}" frames --robot panda | head -1; '
                           'echo "status=${PIPESTATUS[0]}"', shell=True, executable="/bin/bash", capture_output=True,
                           text=True, cwd=tmp_path, timeout=300,
                           env={**os.environ, "PYTHONPATH": str(Path(__file__).parents[1] / "src")})
    assert piped.stdout.strip().endswith("status=0") and piped.stderr == "", piped.stderr


def test_an_output_name_of_300_characters_is_one_line(tmp_path):
    result = run_cli("manipkit", "tree", "--robot", "planar_2r", "-o", tmp_path / ("a" * 300 + ".png"))
    _one_line(result, "the file name is 304 bytes, more than the 255 this file system takes")


def test_workers_under_a_low_open_file_limit_is_one_line(tmp_path):
    result = _manipkit_env(tmp_path, "reachmap", "--robot", "planar_2r", "--samples", "2000", "--voxel", "0.25",
                           "--orientations", "1", "--workers", "2", "-o", tmp_path / "m.zarr", shell_prefix="ulimit -n 40 && ")
    _one_line(result, "--workers 2 needs about 192 open files and the limit is 40 (ulimit -n)")


def test_a_deep_blocks_json_in_a_resume_folder_is_not_an_internal_error(tmp_path):
    from manipkit.analysis.reachmap.blockstore import _read_table  # the reader under test

    folder = tmp_path / "blocks"
    folder.mkdir()
    (folder / "blocks.json").write_text("[" * 100_000 + "]" * 100_000)
    assert _read_table(folder) is None  # not a store's table (RecursionError before)
