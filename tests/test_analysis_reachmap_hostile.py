"""Reach maps under hostile inputs (issue 26): bounded options, safe folders, validated maps, bounded Dask.

Each test names one failure mode. Maps are tiny (planar 2R, voxel 0.5 m, 4
turns) so the suite stays fast; Dask tests use a real LocalCluster or a real
socket server.
"""

import errno
import json
import os
import re
import shutil
import socket
import tempfile
import threading
import time

import numpy as np
import pytest

from manipkit.analysis.reachmap import ReachMapError, build, load, store
from manipkit.analysis.reachmap.blocks import BlockRunner, max_workers, probe_scheduler
from manipkit.analysis.reachmap.placement import base_placement
from manipkit.errors import InputFileError, OutputError
from manipkit.inputs.poses import MAX_TARGETS, read_targets


@pytest.fixture(scope="module")
def tiny(planar_2r):
    return build(planar_2r, voxel=0.5, orientations=4, samples=2000)


def saved(tiny, folder):
    return tiny.save(folder / "m.zarr")


def edit_attributes(path, **changes):
    meta = json.loads((path / "zarr.json").read_text())
    meta["attributes"].update(changes)
    (path / "zarr.json").write_text(json.dumps(meta))


# ---------------------------------------------------------------------------
# Options are bounded before anything is allocated or started


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"voxel": 1e300}, "voxel 1e+300: give the voxel edge in metres (0.05), a number from 1e-06 to 1e+06"),
        ({"voxel": 1e-300}, "a number from 1e-06 to 1e+06"),
        ({"seed": -1}, "seed -1: give a whole number from 0 to"),
        ({"seed": 2**64}, "seed 18446744073709551616"),
        ({"samples": 10**15}, "samples 1000000000000000: give a whole number from 1 to 10000000000"),
        ({"block_samples": 10**9}, "block_samples 1000000000"),
        ({"workers": 10000}, f"workers 10000: give a whole number from 1 to {max_workers()}"),
        ({"ik_restarts": -1}, "ik_restarts -1"),
        ({"ik_tol": float("nan")}, "ik_tol nan"),
        ({"ik_time_budget": 1e9}, "ik_time_budget 1000000000.0"),
        ({"orientations": (1000, 1000)}, "orientations 1000x1000: 1000000 bins, more than 100000"),
        ({"orientations": 10**6}, "orientations 1000000"),
        ({"scheduler": 5}, "scheduler 5: give the address of a running Dask scheduler"),
    ],
)
def test_every_option_is_bounded_with_the_bound_in_the_message(planar_2r, options, message):
    started = time.monotonic()
    with pytest.raises(ReachMapError, match=re.escape(message)):
        build(planar_2r, **{"samples": 10, **options})
    assert time.monotonic() - started < 5.0  # refused before any work


def test_workers_are_bounded_by_the_cores_before_a_cluster_starts():
    assert 1 <= max_workers() <= 64
    with pytest.raises(ReachMapError, match="at most 4 per core and 64"):
        BlockRunner(max_workers() + 1, None)


# ---------------------------------------------------------------------------
# The Python API names the argument


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda m: m.query(np.full((4, 4), np.nan)), "T holds NaN or infinite values"),
        (lambda m: m.query(np.eye(3)), r"T has shape \(3, 3\); give poses \(..., 4, 4\)"),
        (lambda m: m.query("pose"), "T 'pose': give poses"),
        (lambda m: m.index_at([np.nan, 0.0, 0.0]), "xyz holds NaN or infinite values"),
        (lambda m: m.index_at([1.0, 2.0]), r"xyz has shape \(2,\)"),
        (lambda m: m.voxel_of([[np.inf, 0.0, 0.0]]), "xyz holds NaN"),
    ],
)
def test_query_and_index_at_refuse_nan_and_wrong_shapes(tiny, call, message):
    with pytest.raises(ReachMapError, match=message):
        call(tiny)


def test_base_placement_checks_counts_before_allocating(tiny):
    targets = np.eye(4)[None]
    with pytest.raises(ReachMapError, match="yaws 100000000: give from 1 to 3600 headings"):
        base_placement(tiny, targets, yaws=100_000_000)
    with pytest.raises(ReachMapError, match="step 1e-09: give the grid step in metres"):
        base_placement(tiny, targets, step=1e-9)
    with pytest.raises(ReachMapError, match="more than 50000000: use a coarser step"):
        base_placement(tiny, targets, step=1e-6)
    with pytest.raises(ReachMapError, match="targets holds NaN"):
        base_placement(tiny, np.full((1, 4, 4), np.nan))
    with pytest.raises(ReachMapError, match="xs holds NaN"):
        base_placement(tiny, targets, xs=[np.nan], ys=[0.0])


def test_base_placement_in_batches_gives_the_scores_of_one_pass(tiny, monkeypatch):
    from manipkit.analysis.reachmap import placement

    targets = np.tile(np.eye(4), (5, 1, 1))
    targets[:, 0, 3] = np.linspace(-2.0, 2.0, 5)
    whole = base_placement(tiny, targets, yaws=3)
    monkeypatch.setattr(placement, "BATCH_POSES", 7)  # a placement or two per batch
    np.testing.assert_array_equal(base_placement(tiny, targets, yaws=3).scores, whole.scores)


def test_a_targets_file_holds_at_most_max_targets(tmp_path):
    path = tmp_path / "many.txt"
    path.write_text("0 0 0 0 0 0\n" * (MAX_TARGETS + 1))
    with pytest.raises(InputFileError, match=f"more than {MAX_TARGETS} target poses"):
        read_targets(path)


# ---------------------------------------------------------------------------
# Writing: a temporary sibling renamed into place; only a map is replaced


def test_rebuilding_into_a_folder_with_other_files_refuses_and_deletes_nothing(tiny, tmp_path):
    path = saved(tiny, tmp_path)
    (path / "notes.txt").write_text("mine")
    with pytest.raises(OutputError, match="it holds notes.txt, which is not part of a reachability map"):
        tiny.save(path)
    assert (path / "notes.txt").read_text() == "mine"
    (path / "notes.txt").unlink()
    (path / "reach" / "mine").mkdir()
    with pytest.raises(OutputError, match="reach/mine, which is not part of a reachability map"):
        tiny.save(path)


def test_a_map_is_replaced_whole_and_nothing_is_left_beside_it(tiny, planar_2r, tmp_path):
    path = saved(tiny, tmp_path)
    other = build(planar_2r, voxel=0.25, orientations=2, samples=500, manipulability=False)
    other.save(path)
    again = load(path)
    assert again.voxel == 0.25 and again.manipulability is None
    assert not (path / "manipulability").exists()  # the old map's arrays went with it
    assert sorted(os.listdir(tmp_path)) == ["m.zarr"]


def test_a_symlink_or_file_at_the_output_is_refused(tiny, tmp_path):
    target = saved(tiny, tmp_path)
    (tmp_path / "link.zarr").symlink_to(target)
    with pytest.raises(OutputError, match="it is a symbolic link"):
        tiny.save(tmp_path / "link.zarr")
    (tmp_path / "file.zarr").write_text("x")
    with pytest.raises(OutputError, match="it exists and is not a reachability map"):
        tiny.save(tmp_path / "file.zarr")


@pytest.mark.parametrize("failure", [OSError(errno.ENOSPC, "No space left on device"), KeyboardInterrupt()])
def test_a_failed_or_interrupted_write_leaves_no_folder_and_keeps_the_old_map(tiny, tmp_path, monkeypatch, failure):
    def write_then_fail(reach_map, folder):
        (folder / "zarr.json").write_text("{}")
        raise failure

    monkeypatch.setattr(store, "_write_arrays", write_then_fail)
    with pytest.raises(OutputError if isinstance(failure, OSError) else KeyboardInterrupt):
        tiny.save(tmp_path / "new.zarr")
    assert os.listdir(tmp_path) == []  # nothing that blocks a re-run, no hidden partial folder
    monkeypatch.undo()
    path = saved(tiny, tmp_path)
    monkeypatch.setattr(store, "_write_arrays", write_then_fail)
    with pytest.raises(OutputError if isinstance(failure, OSError) else KeyboardInterrupt):
        tiny.save(path)
    assert sorted(os.listdir(tmp_path)) == ["m.zarr"]
    np.testing.assert_array_equal(load(path).reach, tiny.reach)


def test_every_chunk_is_written_even_an_empty_one(planar_2r, tmp_path):
    reach_map = build(planar_2r, voxel=0.05, orientations=2, samples=10, manipulability=False)  # mostly empty
    path = reach_map.save(tmp_path / "m.zarr")
    chunks = list((path / "reach" / "c").rglob("*"))
    grid = [-(-s // 16) for s in reach_map.shape]
    assert sum(p.is_file() for p in chunks) == grid[0] * grid[1] * grid[2]
    np.testing.assert_array_equal(load(path).reach, reach_map.reach)


# ---------------------------------------------------------------------------
# Reading: a map validated as a whole


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"voxel": 0.0}, "voxel is 0.0; it must be a finite number from 1e-06"),
        ({"voxel": "0.5"}, "voxel is '0.5'"),
        ({"origin": [0.0]}, r"origin is \[0.0\]; it must be 3 numbers"),
        ({"origin": [1e300, 0.0, 0.0]}, "origin is 1e"),
        ({"axes": [[0.0] * 3] * 3}, "axes are not orthonormal"),
        ({"axes": [[1.0, 0, 0], [0, 1.0, 0], [0, 0, -1.0]]}, "axes are not orthonormal and right-handed"),
        ({"method": "magic"}, "method is 'magic'"),
        ({"robot": ""}, "robot is ''"),
        ({"joint_names": "j1"}, "joint_names must be a list"),
        ({"settings": {"samples": -5}}, "settings.samples is -5"),
        ({"settings": {"note": [1, 2]}}, "settings must be a table"),
        # what the summary prints (it once stopped on these with an internal error)
        ({"settings": {"checked_threshold": "abc"}}, "settings.checked_threshold is 'abc'; it must be a finite number"),
        ({"settings": {"converge": 2.0}}, "settings.converge is 2.0"),
        ({"settings": {"samples_used": 3}}, "settings.samples_used needs settings.blocks"),
        ({"settings": {"samples_used": 3, "blocks": "x"}}, "settings.blocks is 'x'"),
        ({"settings": {"completeness": {"n": 5, "rate": "abc", "low": 0, "high": 1}}},
         "settings.completeness.rate is 'abc'"),
        ({"settings": {"completeness": {"n": 5}}}, "settings.completeness lacks rate, low, high"),
        ({"settings": {"false_positive": {"n": 1, "failed": 1, "rate": 1.0, "high": 1.0, "mode": ""}}},
         "settings.false_positive.mode is ''"),
        ({"settings": {"false_positive": 7}}, "settings.false_positive must be a table"),
    ],
)
def test_crafted_attributes_are_refused_by_name(tiny, tmp_path, changes, message):
    path = saved(tiny, tmp_path)
    edit_attributes(path, **changes)
    with pytest.raises(InputFileError, match="not a valid reachability map: " + message):
        load(path)


def test_orientations_must_agree_with_the_arrays_and_axes(tiny, tmp_path):
    path = saved(tiny, tmp_path)
    meta = json.loads((path / "zarr.json").read_text())
    orientations = meta["attributes"]["orientations"]
    for changes, message in (({"kind": "conical"}, "orientations.kind"), ({"n_rolls": 0}, "orientations.n_rolls is 0"),
                             ({"axis": [0.0, 0.0, 2.0]}, "orientations.axis has length 2"),
                             ({"axis": [1.0, 0.0, 0.0]}, "perpendicular"),
                             ({"kind": "spatial"}, "a spatial map has identity axes and a cube of voxels")):
        edit_attributes(path, orientations={**orientations, **changes})
        with pytest.raises(InputFileError, match=message):
            load(path)


def test_missing_or_foreign_chunks_are_errors_not_fill_values(tiny, tmp_path):
    path = saved(tiny, tmp_path)
    chunk = path / "reach" / "c" / "0" / "0" / "0" / "0"
    data = chunk.read_bytes()
    chunk.unlink()
    with pytest.raises(InputFileError, match="chunk reach/c/0/0/0/0 is missing"):
        load(path)
    chunk.symlink_to("/etc/passwd")
    with pytest.raises(InputFileError, match="reach/c/0/0/0/0 is a symbolic link"):
        load(path)
    chunk.unlink()
    chunk.write_bytes(data)
    shutil.rmtree(path / "voxel_q")
    with pytest.raises(InputFileError, match="array voxel_q is missing"):
        load(path)


def test_a_chunk_is_decompressed_only_when_its_frame_declares_its_exact_size(tiny, tmp_path):
    from numcodecs.zstd import Zstd

    path = saved(tiny, tmp_path)
    chunk = path / "reach" / "c" / "0" / "0" / "0" / "0"
    size = tiny.reach.size  # one chunk holds the whole small grid
    assert store.zstd_content_size(chunk.read_bytes()) == size
    original = chunk.read_bytes()
    chunk.write_bytes(Zstd().encode(bytes(size * 1000)))  # a bomb in miniature: 1000 times its chunk
    with pytest.raises(InputFileError, match=f"declares {size * 1000} bytes; its chunk holds {size}"):
        load(path)
    chunk.write_bytes(b"\x28\xb5\x2f\xfd\x00\x58" + bytes(16))  # a frame that declares no size (a stream)
    with pytest.raises(InputFileError, match="is not one zstd frame that declares its size"):
        load(path)
    right = Zstd().encode(bytes(size))
    chunk.write_bytes(right + Zstd().encode(bytes(10_000_000)))  # a second frame, which a decoder would add
    with pytest.raises(InputFileError, match="is not one zstd frame that declares its size"):
        load(path)
    chunk.write_bytes(right)  # a well-formed chunk, but no voxel-bin reached: the certificates now name unreached ones
    with pytest.raises(InputFileError, match="cert_keys are not exactly the reached voxel-bins"):
        load(path)
    chunk.write_bytes(original)
    assert load(path).reach.size == size
    chunk.write_bytes(Zstd().encode(np.full(size, 7, dtype=np.uint8).tobytes()))
    with pytest.raises(InputFileError, match="reach holds the code 7"):
        load(path)


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda meta: meta["chunk_grid"]["configuration"].update(chunk_shape=[0, 0, 0, 0]), "a chunk dimension is 0"),
        (lambda meta: meta["codecs"].__setitem__(1, {"name": "gzip", "configuration": {"level": 1}}),
         "not the uint8 Zarr v3 array with bytes and zstd codecs"),
        (lambda meta: meta.update(shape=[11, 11, 1, 5]), "array shapes that disagree"),
        (lambda meta: meta.update(data_type="float64"), "not the uint8 Zarr v3 array"),
    ],
)
def test_crafted_array_metadata_is_refused(tiny, tmp_path, edit, message):
    path = saved(tiny, tmp_path)
    meta = json.loads((path / "reach" / "zarr.json").read_text())
    edit(meta)
    (path / "reach" / "zarr.json").write_text(json.dumps(meta))
    with pytest.raises(InputFileError, match=message):
        load(path)


def test_deeply_nested_metadata_is_refused_before_it_is_parsed(tiny, tmp_path):
    path = saved(tiny, tmp_path)
    text = (path / "zarr.json").read_text().replace('"settings": {', '"x": ' + "[" * 50000 + "]" * 50000 + ', "settings": {')
    (path / "zarr.json").write_text(text)
    with pytest.raises(InputFileError, match="nested 50002 levels deep, more than 32"):
        load(path)
    assert store.writable_map_path(tmp_path / "new.zarr")  # and a new name is still fine


def test_control_characters_in_a_map_never_reach_the_summary_raw(tiny, tmp_path):
    path = saved(tiny, tmp_path)
    edit_attributes(path, robot="arm\x1b[2J\n- forged", frame="ee\u202e")
    text = load(path).summary()
    assert "\x1b" not in text and "\u202e" not in text and "\n- forged" not in text
    assert "arm\\x1b[2J\\x0a- forged" in text


# ---------------------------------------------------------------------------
# Dask: a total handshake timeout, a scratch space that is removed


def test_a_scheduler_that_accepts_and_never_answers_is_refused_in_time():
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(4)
    accepted = []
    stop = threading.Event()

    def accept():
        server.settimeout(0.2)
        while not stop.is_set():
            try:
                accepted.append(server.accept()[0])  # and never answer
            except OSError:
                continue

    thread = threading.Thread(target=accept, daemon=True)
    thread.start()
    try:
        started = time.monotonic()
        with pytest.raises(ReachMapError, match="no answer within 1 s"):
            probe_scheduler(f"tcp://127.0.0.1:{server.getsockname()[1]}", timeout=1.0)
        assert time.monotonic() - started < 8.0 and accepted
    finally:
        stop.set()
        thread.join()
        for connection in accepted:
            connection.close()
        server.close()


def test_a_running_scheduler_answers_the_probe():
    from distributed import LocalCluster

    with LocalCluster(n_workers=0, processes=False, dashboard_address=None) as cluster:
        probe_scheduler(cluster.scheduler_address, timeout=5.0)


def test_local_workers_leave_no_scratch_space_behind(planar_2r, tmp_path, monkeypatch):
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    here = build(planar_2r, voxel=0.5, orientations=4, samples=2000, block_samples=500)
    there = build(planar_2r, voxel=0.5, orientations=4, samples=2000, block_samples=500, workers=1)
    np.testing.assert_array_equal(there.reach, here.reach)
    left = [name for name in os.listdir(tmp_path) if not name.startswith("pymp-")]  # multiprocessing's, until exit
    assert left == []  # no dask-scratch-space/, no manipkit-dask-*


FULL_DISK = '''
import asyncio, errno, sys
import zarr.storage
import manipkit
from manipkit.analysis.reachmap import build
from manipkit.errors import OutputError

original, calls = zarr.storage.LocalStore.set, [0]

async def set_until_the_disk_is_full(self, key, value, **kw):  # the first chunks fit, the others do not
    calls[0] += 1
    if calls[0] > 3 and "/c/" in key:
        await asyncio.sleep(0.01 * (calls[0] % 5))
        raise OSError(errno.ENOSPC, "No space left on device")
    return await original(self, key, value, **kw)

zarr.storage.LocalStore.set = set_until_the_disk_is_full
reach_map = build(manipkit.load("planar_2r"), voxel=0.05, orientations=2, samples=100)
try:
    reach_map.save(sys.argv[1])
except OutputError as exc:
    print(exc)
'''


def test_a_full_disk_while_writing_is_one_line_and_leaves_no_folder(tmp_path):
    import subprocess
    import sys

    result = subprocess.run([sys.executable, "-c", FULL_DISK, str(tmp_path / "m.zarr")], capture_output=True,
                            text=True, timeout=120)
    assert result.stdout.strip().endswith("m.zarr: No space left on device"), result.stdout + result.stderr
    assert result.stderr == ""  # no "Task was destroyed but it is pending!" for each write zarr had running
    assert os.listdir(tmp_path) == []


def test_far_positions_are_refused_or_simply_outside(tiny, tmp_path):
    import warnings

    path = tmp_path / "far.txt"
    path.write_text("1 0 0 0 0 0\n1e300 0 0 0 0 0\n")
    with pytest.raises(InputFileError, match="far.txt line 2: a position of 1e\\+300 m; give positions within 1e\\+06 m"):
        read_targets(path)
    far = np.eye(4)[None].copy()
    far[0, 0, 3] = 1e300
    with pytest.raises(ReachMapError, match="targets: a position of 1e\\+300 m"):
        base_placement(tiny, far)
    with pytest.raises(ReachMapError, match="xs: a position of 1e\\+07 m"):
        base_placement(tiny, np.eye(4)[None], xs=[1e7], ys=[0.0])
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no "invalid value encountered in cast"
        assert tiny.index_at([1e300, -1e300, 0.0]) == 0.0 and tiny.query(far[0]) is False


def test_a_local_cluster_runs_no_preload_the_dask_config_names(planar_2r, tmp_path):
    # what a hostile DASK_CONFIG file, ~/.config/dask yaml or DASK_DISTRIBUTED__*__PRELOAD variable gives: preload
    # scripts in dask's config (files and variables are merged into dask.config when dask is imported)
    import dask

    ran = tmp_path / "RAN"
    script = tmp_path / "evil_preload.py"
    script.write_text(f"open({str(ran)!r}, 'a').write('ran\\n')\n")
    hostile = {f"distributed.{part}.preload": [str(script)] for part in ("scheduler", "worker", "nanny")}
    with dask.config.set(hostile):
        answer = build(planar_2r, voxel=0.5, orientations=4, samples=500, block_samples=500, workers=1)
    assert answer.reachable.any()
    assert not ran.exists(), "a preload script named by the Dask config ran"
