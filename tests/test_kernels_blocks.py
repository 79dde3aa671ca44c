"""manipkit.kernels.blocks.run_blocks: every row once, on the caller and its helper threads, errors raised."""

import threading
import time

import pytest

from manipkit.kernels.blocks import run_blocks


@pytest.mark.parametrize("threads", [1, 2, 3])
def test_every_block_runs_once_and_the_caller_takes_blocks_too(threads):
    seen, lock = [], threading.Lock()

    def work(a, b):
        time.sleep(0.001)
        with lock:
            seen.append((a, b, threading.current_thread() is threading.main_thread()))

    run_blocks(work, 1050, block=100, min_rows_per_thread=10, threads=threads, name="test")
    assert sorted((a, b) for a, b, _ in seen) == [(a, min(a + 100, 1050)) for a in range(0, 1050, 100)]
    assert any(main for _, _, main in seen)  # the caller is one of the threads
    assert len(seen) == 11


def test_an_error_in_a_block_is_raised_after_the_running_blocks_finish():
    finished, lock = [], threading.Lock()

    def work(a, b):
        if a == 300:
            raise ValueError("block 3")
        time.sleep(0.002)
        with lock:
            finished.append(a)

    with pytest.raises(ValueError, match="block 3"):
        run_blocks(work, 2000, block=100, min_rows_per_thread=10, threads=2, name="test")
    assert len(finished) < 19  # blocks stop being taken once the error is seen
    count = len(finished)
    time.sleep(0.02)
    assert len(finished) == count  # nothing still running after the raise
