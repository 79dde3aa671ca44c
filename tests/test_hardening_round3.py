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
