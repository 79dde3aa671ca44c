"""Blocks of work run here or on a Dask cluster, and merged in block order (docs/architecture.md, "Reachability maps").

:class:`BlockRunner` runs ``fn(job, *arguments)`` for each block: here, one
after the other, on a new ``distributed.LocalCluster`` (``workers``) or on a
running scheduler (``scheduler``); the job is sent to the workers once.
Results come back in any order; :func:`in_block_order` puts them back in
block order, so a merge that is not associative in floating point (a sum)
gives the same bits however the blocks ran.
"""

from __future__ import annotations

import logging

from manipkit.errors import ReachMapError

__all__ = ["BlockRunner", "in_block_order"]


class BlockRunner:
    """Runs blocks here, on a new LocalCluster (``workers``) or on a running cluster (``scheduler``)."""

    def __init__(self, workers: int | None, scheduler: str | None, progress=None):
        self.workers, self.scheduler, self.progress = workers, scheduler, progress
        self.client = self.cluster = None

    def __enter__(self):
        if self.workers is not None or self.scheduler is not None:
            from distributed import Client, LocalCluster

            if self.workers is not None:
                self.cluster = LocalCluster(n_workers=int(self.workers), threads_per_worker=1, processes=True,
                                            dashboard_address=None, silence_logs=logging.ERROR)
                self.client = Client(self.cluster)
            else:
                try:
                    self.client = Client(self.scheduler, timeout=10)
                except (OSError, TimeoutError, ValueError) as exc:
                    raise ReachMapError(f"cannot reach the Dask scheduler '{self.scheduler}': {exc}") from None
        return self

    def __exit__(self, *exc):
        if self.client is not None:
            self.client.close()
        if self.cluster is not None:
            self.cluster.close()

    def run(self, fn, job, argument_lists: list[tuple], desc: str):
        """Yield ``fn(job, *arguments)`` for each tuple of ``argument_lists``, in any order.

        After each block, ``progress(desc, done, total)`` (blocks) when a
        progress callable was given (:mod:`manipkit.app.progress` draws it).
        """
        total = len(argument_lists)
        report = self.progress or (lambda stage, done, total: None)
        report(desc, 0, total)
        if self.client is None:
            for done, arguments in enumerate(argument_lists, start=1):
                yield fn(job, *arguments)
                report(desc, done, total)
            return
        from distributed import as_completed

        job_future = self.client.scatter(job, broadcast=True, hash=False)
        futures = [self.client.submit(fn, job_future, *arguments, pure=False) for arguments in argument_lists]
        for done, future in enumerate(as_completed(futures), start=1):
            yield future.result()
            future.release()
            report(desc, done, total)


def in_block_order(results):
    """The block results of ``results`` (tuples starting with the block number, in any order) in block order."""
    waiting, following = {}, 0
    for result in results:
        waiting[result[0]] = result
        while following in waiting:
            yield waiting.pop(following)
            following += 1
