"""Rows of a batch in blocks on threads: :func:`run_blocks`.

Compiled kernels release the GIL, so a batch (targets of IK, configurations of static torques) is cut into
blocks of rows and the blocks run on a few threads. Every row's numbers come from that row alone, so the answer
is the same bits on any number of threads. Standard library only.
"""

from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor

__all__ = ["run_blocks"]


def run_blocks(work: Callable[[int, int], None], n_rows: int, *, block: int, min_rows_per_thread: int,
               threads: int, name: str) -> None:
    """``work(start, stop)`` on the blocks of ``block`` rows covering ``0 .. n_rows``, on up to ``threads`` threads.

    One thread (the caller's) when there are fewer than ``min_rows_per_thread`` rows per thread or only one block.
    An error cancels the blocks not started (a Ctrl-C while waiting too); those running finish, then it is raised
    here. ``name`` prefixes the threads' names (``manipkit-NAME``).
    """
    blocks = [(a, min(a + block, n_rows)) for a in range(0, n_rows, block)]
    used = max(1, min(threads, n_rows // min_rows_per_thread, len(blocks)))
    if used == 1:
        for a, b in blocks:
            work(a, b)
        return
    with ThreadPoolExecutor(max_workers=used, thread_name_prefix=f"manipkit-{name}") as pool:
        futures = [pool.submit(work, a, b) for a, b in blocks]
        try:
            for future in futures:
                future.result()
        except BaseException:
            for future in futures:
                future.cancel()
            raise
