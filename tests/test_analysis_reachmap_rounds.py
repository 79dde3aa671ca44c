"""Sampling rounds in flight (issue 24): two rounds handed out at once, each block of round k given the voxel-bins
known before round k - 1, blocks grouped into tasks on a cluster; the map the same here and on 1, 2 and 3 workers.

Independent sources: ``numpy.packbits`` of a boolean array for the bit-packed snapshots, the blocks' own results
recomputed one by one (no snapshot) for what a snapshot must hold, and the in-process build's saved files, byte for
byte, for the builds on clusters.
"""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from manipkit.analysis.reachmap import builder
from manipkit.analysis.reachmap.blocks import BlockRunner, run_blocks
from manipkit.analysis.reachmap.jobs import sample_block
from manipkit.analysis.reachmap.stages import ROUND_BLOCKS, KnownBins

# planar 3R (4, 2, 1) at 0.25 m, 16 turns: blocks of 1000 samples, stopping inside a round after the third (checked
# below), so rounds with a snapshot, the pipeline and the stop inside a round all happen
SETTINGS = {"voxel": 0.25, "orientations": 16, "samples": 200_000, "block_samples": 1000, "converge": 0.0005,
            "holdout": 500, "fp_checks": 5, "manipulability": False}


@settings(max_examples=50, deadline=None)
@given(st.integers(1, 40), st.integers(1, 9), st.lists(st.lists(st.integers(0, 10**6)), max_size=5))
def test_known_bins_are_packed_as_numpy_packs_them(n_voxels, n_bins, chunks):
    known = KnownBins(n_voxels, n_bins)
    bins, voxels = np.zeros(n_voxels * n_bins, dtype=bool), np.zeros(n_voxels, dtype=bool)
    for chunk in chunks:
        keys = np.unique(np.array(chunk, dtype=np.int64) % (n_voxels * n_bins))
        known.add(keys, np.unique(keys // n_bins))
        bins[keys], voxels[keys // n_bins] = True, True
        snapshot = known.snapshot()
        assert snapshot[0].tobytes() == np.packbits(bins).tobytes()
        assert snapshot[1].tobytes() == np.packbits(voxels).tobytes()
    snapshot = known.snapshot()
    known.add(np.array([0]), np.array([0]))
    assert snapshot[0].tobytes() == np.packbits(bins).tobytes()  # a snapshot is a copy: later blocks leave it alone


class RecordingRunner(BlockRunner):
    """A runner that records every block it is handed: (job, arguments)."""

    handed: list = []

    def submit(self, fn, job, argument_lists, desc):
        if fn is sample_block:
            RecordingRunner.handed.extend((job, arguments) for arguments in argument_lists)
        return super().submit(fn, job, argument_lists, desc)


@pytest.fixture(scope="module")
def recorded(planar_3r):
    """The map built here with SETTINGS by a :class:`RecordingRunner`, and the blocks it was handed: one build for
    the test of the snapshots and the reference of the builds on workers (the runner only records)."""
    with pytest.MonkeyPatch.context() as monkeypatch:
        monkeypatch.setattr(builder, "BlockRunner", RecordingRunner)
        RecordingRunner.handed = []
        reach_map = builder.build(planar_3r.chain("base_link", "ee_link"), **SETTINGS)
        handed = list(RecordingRunner.handed)
    return reach_map, handed


def test_each_round_is_given_the_bins_known_before_the_round_ahead_of_it(recorded):
    reach_map, handed = recorded
    blocks = reach_map.settings["blocks"]
    assert reach_map.settings["converged"] and blocks > 3 * ROUND_BLOCKS and blocks % ROUND_BLOCKS != 0
    job = handed[0][0]
    numbers = [arguments[0] for _, arguments in handed]
    rounds = -(-blocks // ROUND_BLOCKS)
    assert numbers == list(range((rounds + 1) * ROUND_BLOCKS))  # the round after the stopping one was handed out too
    n_keys = int(np.prod(reach_map.shape)) * reach_map.orientations.size
    reached, reached_voxels = np.zeros(n_keys, dtype=bool), np.zeros(n_keys // reach_map.orientations.size, dtype=bool)
    for k in range(rounds + 1):
        snapshots = [arguments[1] for _, arguments in handed[k * ROUND_BLOCKS:(k + 1) * ROUND_BLOCKS]]
        assert all(s is snapshots[0] for s in snapshots)  # one object per round: sent to a cluster once
        if k < 2:
            assert snapshots[0] is None
        else:  # the bins reached by rounds 0 .. k - 2, recomputed here block by block without any snapshot
            for b in range((k - 2) * ROUND_BLOCKS, (k - 1) * ROUND_BLOCKS):
                _, keys, voxels, *_ = sample_block(job, b)
                reached[keys], reached_voxels[voxels] = True, True
            assert snapshots[0][0].tobytes() == np.packbits(reached).tobytes()
            assert snapshots[0][1].tobytes() == np.packbits(reached_voxels).tobytes()


def test_the_map_is_the_same_here_and_on_one_two_and_three_workers(planar_3r, recorded, tmp_path):
    chain = planar_3r.chain("base_link", "ee_link")
    here = recorded[0]  # built here with SETTINGS
    files = {path.relative_to(tmp_path / "here"): path.read_bytes()
             for path in sorted(here.save(tmp_path / "here").rglob("*")) if path.is_file()}
    assert here.settings["blocks"] > 3 * ROUND_BLOCKS
    for workers in (1, 2, 3):
        there = builder.build(chain, **SETTINGS, workers=workers).save(tmp_path / f"w{workers}")
        assert {path.relative_to(there): path.read_bytes() for path in sorted(there.rglob("*")) if path.is_file()} \
            == files, f"{workers} worker(s)"


def test_a_task_runs_its_blocks_in_order():
    def fn(job, block, extra):
        return block, job, extra

    assert run_blocks(fn, "job", [(3, None), (4, "x")]) == [(3, "job", None), (4, "job", "x")]
