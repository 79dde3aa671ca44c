"""Resumable reach-map builds (issue 24): finished blocks kept, an interrupted build resumes to the same map.

The independent source is the uninterrupted build: a resumed build must save
a Zarr folder whose every file is byte for byte the uninterrupted one's (the
map's arrays, certificates, checks and settings, including where sampling
stopped under ``converge``). Builds are interrupted by raising from the
progress callback after a given block (the block is saved before the
callback runs), or by SIGKILL of a process where a real kill is the point.
"""

import io
import os
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from manipkit.analysis.reachmap import blockstore, build
from manipkit.analysis.reachmap.blockstore import BlockStoreWarning, ResumeNote, open_store
from manipkit.analysis.reachmap.jobs import ik_block, sample_block
from manipkit.analysis.reachmap.stages import ROUND_BLOCKS
from manipkit.errors import OutputError

# planar 3R (4, 2, 1): at most 80 FK blocks of 1000 samples in rounds of ROUND_BLOCKS (16), stopping in the second
# round at a share of new bins, then IK fill
SETTINGS = {"voxel": 0.5, "orientations": 8, "samples": 80_000, "block_samples": 1_000, "method": "hybrid",
            "converge": 0.002, "holdout": 2_000, "fp_checks": 20}


class Stop(Exception):
    """The interruption: raised from the progress callback."""


def stop_after(stage: str, blocks: int):
    def progress(label, done, total):
        if label.startswith(stage) and done == blocks:
            raise Stop
    return progress


def files_of(folder: Path) -> dict:
    """Every file under ``folder`` (relative path -> bytes)."""
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def reference(planar_3r, tmp_path_factory):
    """The uninterrupted build, saved; and its settings."""
    folder = tmp_path_factory.mktemp("reference")
    reach_map = build(planar_3r.chain("base_link", "ee_link"), **SETTINGS)
    assert reach_map.settings["converged"] and ROUND_BLOCKS < reach_map.settings["blocks"] < 2 * ROUND_BLOCKS  # stops
    # in the second round: the stopping rule and a round after the first are exercised
    assert reach_map.settings["fill_passes"] >= 1 and reach_map.ik_keys.size > 0  # and the IK fill
    return files_of(reach_map.save(folder / "m.zarr"))


def resumed(planar_3r, resume_dir, out: Path, **changes):
    """Build again with ``resume_dir``; (saved files, ResumeNote messages, BlockStoreWarning messages)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        reach_map = build(planar_3r.chain("base_link", "ee_link"), **{**SETTINGS, **changes}, resume_dir=resume_dir)
    notes = [str(w.message) for w in caught if issubclass(w.category, ResumeNote)]
    refused = [str(w.message) for w in caught if issubclass(w.category, BlockStoreWarning)]
    return files_of(reach_map.save(out)), notes, refused


def interrupted(planar_3r, resume_dir, stage: str, blocks: int, **changes):
    with pytest.raises(Stop):
        build(planar_3r.chain("base_link", "ee_link"), **{**SETTINGS, **changes}, resume_dir=resume_dir,
              progress=stop_after(stage, blocks))


@pytest.mark.parametrize(("stage", "blocks"), [("FK samples", 3), ("FK samples, blocks 17-", 2), ("IK fill", 1)])
def test_an_interrupted_build_resumes_to_the_same_map_byte_for_byte(planar_3r, reference, tmp_path, stage, blocks):
    keep = tmp_path / ".m.zarr.partial"
    interrupted(planar_3r, keep, stage, blocks)
    saved = sorted(p.name for p in keep.glob("*.npz"))
    assert saved and all(name.startswith(("sample_block-", "ik_block-")) for name in saved)
    files, notes, refused = resumed(planar_3r, keep, tmp_path / "m.zarr")
    assert files == reference and not refused
    assert notes[0] == "resuming: 16 of 16 blocks of FK samples, blocks 1-16 of at most 80 already done" \
        if stage != "FK samples" else notes == ["resuming: 3 of 16 blocks of FK samples, blocks 1-16 of at most 80 "
                                                "already done"]
    if stage == "IK fill":
        assert notes[-1] == "resuming: 1 of 1 blocks of IK fill, pass 1 already done"


def test_a_resumed_build_on_a_local_cluster_gives_the_same_map(planar_3r, reference, tmp_path):
    # blocks saved here, the rest computed by a Dask worker: the merge order makes it the same map
    keep = tmp_path / "blocks"
    interrupted(planar_3r, keep, "FK samples", 5)
    files, notes, _ = resumed(planar_3r, keep, tmp_path / "m.zarr", workers=1)
    assert files == reference and notes[0].startswith("resuming: 5 of 16 blocks")


def test_a_killed_build_resumes_to_the_same_map(planar_3r, reference, tmp_path):
    # a real kill (SIGKILL, no clean-up of any kind) right after block 4 is saved; the process is the point
    keep = tmp_path / "blocks"
    script = (
        "import os, signal, manipkit\n"
        "from manipkit.analysis.reachmap import build\n"
        "def progress(stage, done, total):\n"
        "    if done == 4: os.kill(os.getpid(), signal.SIGKILL)\n"
        f"build(manipkit.load('planar_3r').chain('base_link', 'ee_link'), **{SETTINGS!r}, resume_dir={str(keep)!r}, "
        "progress=progress)\n"
    )
    keep.mkdir()
    (keep / ".tmp-half-written").write_bytes(b"PK")  # what a kill during a write leaves: removed, not refused
    process = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300,
                             env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)})
    assert process.returncode == -9, process.stderr
    assert len(list(keep.glob("sample_block-*.npz"))) == 4 and not (keep / ".tmp-half-written").exists()
    files, notes, refused = resumed(planar_3r, keep, tmp_path / "m.zarr")
    assert files == reference and notes[0].startswith("resuming: 4 of 16 blocks") and not refused


def test_a_tampered_or_foreign_block_is_computed_again(planar_3r, reference, tmp_path):
    keep = tmp_path / "blocks"
    interrupted(planar_3r, keep, "FK samples", 6)
    files = sorted(keep.glob("sample_block-*.npz"), key=lambda p: int(p.name.split("-")[1]))
    files[0].write_bytes(files[0].read_bytes()[:-100])  # truncated
    with np.load(files[1]) as data:  # another bin's certificate in the first row: well formed, but it reaches elsewhere
        arrays = dict(data)
    arrays["r.5.array"] = arrays["r.5.array"].copy()
    arrays["r.5.array"][0] = arrays["r.5.array"][-1]
    np.savez(files[1], **arrays)
    with np.load(files[2]) as data:  # keys outside the grid
        arrays = dict(data)
    arrays["r.1.array"] = arrays["r.1.array"] + 10**9
    np.savez(files[2], **arrays)
    os.replace(files[4], keep / files[3].name)  # block 4's file under block 3's name: another block's result
    files, notes, refused = resumed(planar_3r, keep, tmp_path / "m.zarr")
    assert files == reference
    assert notes[0].startswith("resuming: 1 of 16 blocks")  # block 5 only (block 4's file was moved away)
    assert len(refused) == 1 and refused[0].startswith("4 saved block(s) of FK samples, blocks 1-16 of at most 80 in ")
    assert "(block 0: cannot be read" in refused[0] and refused[0].endswith("computing them again")


def test_blocks_of_other_settings_are_discarded_with_a_warning(planar_3r, tmp_path):
    keep = tmp_path / "blocks"
    interrupted(planar_3r, keep, "FK samples", 3)
    other = build(planar_3r.chain("base_link", "ee_link"), **{**SETTINGS, "seed": 1})
    files, notes, refused = resumed(planar_3r, keep, tmp_path / "m.zarr", seed=1)
    assert files == files_of(other.save(tmp_path / "other.zarr")) and notes == []
    assert refused == [f"discarding the finished blocks in {keep}: they are of a build with other settings "
                       "(seed was 0, now 1)"]


def test_a_folder_that_is_not_a_block_store_is_refused_and_kept(planar_3r, tmp_path):
    keep = tmp_path / "mine"
    keep.mkdir()
    (keep / "notes.txt").write_text("mine")
    with pytest.raises(OutputError, match="it holds notes.txt, which manipkit did not save there; move it"):
        build(planar_3r.chain("base_link", "ee_link"), **SETTINGS, resume_dir=keep)
    assert (keep / "notes.txt").read_text() == "mine"
    (tmp_path / "file").write_text("x")
    with pytest.raises(OutputError, match="it exists and is not a folder of saved blocks"):
        build(planar_3r.chain("base_link", "ee_link"), **SETTINGS, resume_dir=tmp_path / "file")


def test_without_resume_dir_nothing_is_written(planar_3r, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(Stop):
        build(planar_3r.chain("base_link", "ee_link"), **SETTINGS, progress=stop_after("FK samples", 3))
    assert os.listdir(tmp_path) == []


arrays = hnp.arrays(st.sampled_from([np.float64, np.int64, np.bool_, np.uint8]), hnp.array_shapes(min_dims=0, max_dims=3,
                                                                                                   min_side=0, max_side=4))
results = st.recursive(st.one_of(st.none(), st.integers(-2**63, 2**63 - 1), arrays),
                       lambda inner: st.lists(inner, max_size=4).map(tuple), max_leaves=8)


@settings(max_examples=40, deadline=None)
@given(block=st.integers(0, 10**6), result=results)
def test_a_saved_result_reads_back_as_it_was(tmp_path_factory, block, result):
    store = open_store(tmp_path_factory.mktemp("store") / "s", {"any": "settings"})
    store.save(sample_block, (block,), result)
    back, reason = store.load(sample_block, (block,))
    assert reason is None
    assert _same(back, result)
    assert store.load(ik_block, (block,)) == (None, None) and store.load(sample_block, (block + 1,)) == (None, None)


def _same(a, b) -> bool:
    if isinstance(b, tuple):
        return isinstance(a, tuple) and len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    if isinstance(b, np.ndarray):
        return isinstance(a, np.ndarray) and a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()
    return type(a) is type(b) and a == b if b is not None else a is None


def test_a_store_that_cannot_be_written_is_dropped_with_one_warning(planar_3r, reference, tmp_path, monkeypatch):
    import errno

    def full_disk(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    keep = tmp_path / "blocks"
    monkeypatch.setattr(blockstore.np, "savez", full_disk)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        reach_map = build(planar_3r.chain("base_link", "ee_link"), **SETTINGS, resume_dir=keep)
    said = [str(w.message) for w in caught if issubclass(w.category, BlockStoreWarning)]
    assert len(said) == 1 and said[0].startswith("cannot write ") and "No space left on device; the build goes on" in said[0]
    assert files_of(reach_map.save(tmp_path / "m.zarr")) == reference
    assert sorted(os.listdir(keep)) == ["blocks.json"]  # no half-written file left


def test_a_file_that_declares_more_data_than_it_holds_is_refused_before_it_is_read(tmp_path):
    import zipfile

    store = open_store(tmp_path / "s", {"any": "settings"})
    store.save(sample_block, (0,), (0, np.zeros(3)))
    path = store.path_of(sample_block, (0,))
    with zipfile.ZipFile(path) as archive:
        members = {m.filename: archive.read(m) for m in archive.infolist()}
    header = np.lib.format.header_data_from_array_1_0(np.zeros(3))
    header["shape"] = (10**12,)  # 8 TB declared in a file of a few hundred bytes
    forged = io.BytesIO()
    np.lib.format.write_array_header_1_0(forged, header)
    members["r.1.array.npy"] = forged.getvalue() + np.zeros(3).tobytes()
    with zipfile.ZipFile(path, "w") as archive:
        for name, data in members.items():
            archive.writestr(name, data)
    result, reason = store.load(sample_block, (0,))
    assert result is None and reason == "cannot be read (r.1.array.npy declares more data than it holds)"
