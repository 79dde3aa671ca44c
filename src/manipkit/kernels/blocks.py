"""Rows of a batch in blocks on threads: :func:`run_blocks`.

Compiled kernels release the GIL, so a batch (configurations of static torques) is cut into blocks of rows and
the blocks run on a few threads, the caller's among them. Every row's numbers come from that row alone, so the
answer is the same bits on any number of threads. Standard library only.
"""

from __future__ import annotations

import threading
from collections.abc import Callable

__all__ = ["run_blocks"]


def run_blocks(work: Callable[[int, int], None], n_rows: int, *, block: int, min_rows_per_thread: int,
               threads: int, name: str) -> None:
    """``work(start, stop)`` on the blocks of ``block`` rows covering ``0 .. n_rows``, on up to ``threads`` threads.

    One thread (the caller's) when there are fewer than ``min_rows_per_thread`` rows per thread or only one block.
    Otherwise the caller takes blocks in order with ``threads - 1`` helper threads, each taking the next block not
    yet taken: on a loaded machine a helper that is not given a core before the caller has taken every block
    costs nothing but its start (the caller does not sleep until its helpers are scheduled and wake it), and the
    caller waits at the end only for blocks already running. An error stops blocks from being taken (a Ctrl-C
    while waiting too); those running finish, then the first error is raised here. ``name`` prefixes the helper
    threads' names (``manipkit-NAME``).
    """
    blocks = [(a, min(a + block, n_rows)) for a in range(0, n_rows, block)]
    used = max(1, min(threads, n_rows // min_rows_per_thread, len(blocks)))
    if used == 1:
        for a, b in blocks:
            work(a, b)
        return
    state = threading.Condition()
    taken, running, failures = [0], [0], []

    def drain() -> None:
        while True:
            with state:
                if failures or taken[0] == len(blocks):
                    return
                a, b = blocks[taken[0]]
                taken[0] += 1
                running[0] += 1
            try:
                work(a, b)
            except BaseException as exc:  # raised by the caller once the running blocks are done
                with state:
                    failures.append(exc)
            finally:
                with state:
                    running[0] -= 1
                    state.notify_all()

    for k in range(used - 1):
        threading.Thread(target=drain, name=f"manipkit-{name}-{k}", daemon=True).start()
    try:
        drain()
        with state:
            state.wait_for(lambda: running[0] == 0)
    except BaseException as exc:  # a Ctrl-C while waiting: no block starts now, those running finish
        with state:
            failures.append(exc)
            state.wait_for(lambda: running[0] == 0)
        raise
    if failures:
        raise failures[0]
