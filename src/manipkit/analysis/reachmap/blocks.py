"""Blocks of work run here or on a Dask cluster, and merged in block order (docs/site/internals/reach-maps.md).

:class:`BlockRunner` runs ``fn(job, *arguments)`` for each block: here, one
after the other, on a new ``distributed.LocalCluster`` (``workers``) or on a
running scheduler (``scheduler``); the job is sent to the workers once.
Results come back in any order; :func:`in_block_order` puts them back in
block order, so a merge that is not associative in floating point (a sum)
gives the same bits however the blocks ran.

Resources are bounded and cleaned up: at most :func:`max_workers` local
workers (checked before anything starts); a scheduler must answer a
handshake within ``SCHEDULER_TIMEOUT_S`` seconds in all (connect and reply);
the local workers keep their scratch space in a temporary folder removed
when the runner closes (none is left in ``$TMPDIR``); they are forked by a
fork server started with SIGINT ignored, so they ignore Ctrl-C (SIGINT goes
to the whole process group: the process that started them stops them);
the runner records a Ctrl-C and raises it where it waits; and Dask's own
log lines and warnings are silenced while the runner is open, so a Ctrl-C
or a failure ends as one line, not a worker traceback each.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import numbers
import os
import shutil
import signal
import tempfile
import threading
import time

import numpy as np

from manipkit.errors import ReachMapError
from manipkit.text import printable

__all__ = ["FORK_SERVER_PRELOAD", "SCHEDULER_TIMEOUT_S", "Batch", "BlockRunner", "check_workers", "in_block_order",
           "max_workers", "probe_scheduler", "run_blocks"]

SCHEDULER_TIMEOUT_S = 10.0  # seconds a scheduler has to accept the connection and answer its first message
WORKERS_PER_CORE = 4  # local worker processes per core, at most (each is single-threaded and CPU-bound)
MAX_WORKERS = 64  # local worker processes, at most, whatever the machine
POLL_S = 0.02  # seconds between looks at finished blocks (and at a recorded Ctrl-C)
DASK_LOGGERS = ("distributed", "tornado", "asyncio")
#: What multiprocessing's fork server imports once, before it forks the LocalCluster's workers
#: (:func:`_forkserver_ignoring_sigint`): Dask's own choice, "distributed" (Dask sets it only when the server is
#: already running, started by that function), and what every block's job needs unpickled. Each worker otherwise
#: imported them itself: about 0.6 s of CPU a worker (3.5 of 20 s in a test that starts 1, 2 and 3 workers).
FORK_SERVER_PRELOAD = ("distributed", "numpy", "pinocchio", "manipkit.kinematics.robot", "manipkit.analysis.reachmap.jobs")
# A local cluster has no dashboard: its monitors (the workers' sampling profiler every 10 ms, each server's
# event-loop tick every 20 ms, the system monitor, the nannies' memory checks every 100 ms) cost this process and
# each worker about 5 % of a core while they wait; measured, these settings cut that about fourfold.
LOCAL_CLUSTER_CONFIG = {"distributed.worker.profile.enabled": False, "distributed.admin.tick.interval": "1s",
                        "distributed.admin.system-monitor.interval": "2s",
                        "distributed.worker.memory.monitor-interval": "1s",
                        # the cluster manipkit starts runs no code the environment names (a DASK_CONFIG file,
                        # ~/.config/dask, DASK_* variables): no preload script or its arguments, on any server
                        **{f"distributed.{part}.{key}": [] for part in ("scheduler", "worker", "nanny", "client")
                           for key in ("preload", "preload-argv")}}
# A call's blocks go to a cluster a few to a task (a task costs the scheduler and client, in this process, about
# 4 ms): at least TASKS_PER_CORE tasks per worker thread, so the work is still shared out evenly, and at most
# BLOCKS_PER_TASK blocks in one.
TASKS_PER_CORE = 2
BLOCKS_PER_TASK = 8


#: Seconds a close of the Dask client and cluster may take after a Ctrl-C before the workers are ended.
CLOSE_TIMEOUT_S = 3.0


def max_workers() -> int:
    """Most local worker processes a runner starts: ``WORKERS_PER_CORE`` per core, at most ``MAX_WORKERS``."""
    return min(MAX_WORKERS, WORKERS_PER_CORE * (os.cpu_count() or 1))


def check_workers(workers) -> None:
    """``workers`` is None or a whole number in 1..:func:`max_workers`, else :class:`ReachMapError` with the bound."""
    if workers is None:
        return
    top = max_workers()
    if isinstance(workers, bool) or not isinstance(workers, numbers.Integral) or not 1 <= workers <= top:
        raise ReachMapError(f"workers {printable(repr(workers))}: give a whole number from 1 to {top} (worker processes, "
                            f"at most {WORKERS_PER_CORE} per core and {MAX_WORKERS}), or none to run here")


def probe_scheduler(address: str, timeout: float = SCHEDULER_TIMEOUT_S) -> None:
    """Raise :class:`ReachMapError` unless a Dask scheduler at ``address`` answers within ``timeout`` seconds in all.

    distributed's own ``Client(timeout=...)`` bounds the TCP connect only: a
    server that accepts and never answers would keep it waiting forever. The
    probe (connect, send ``identity``, read the reply) runs on its own event
    loop in its own thread, so it also works where a loop is running (Jupyter).
    """
    import asyncio
    from concurrent.futures import ThreadPoolExecutor
    from concurrent.futures import TimeoutError as FutureTimeout

    from distributed.comm import connect

    async def handshake():
        comm = await connect(address, timeout=timeout)
        try:
            await comm.write({"op": "identity", "reply": True})
            reply = await comm.read()
        finally:
            comm.abort()
        if not isinstance(reply, dict) or reply.get("type") != "Scheduler":
            raise ValueError("it answered, but not as a Dask scheduler")

    def run():
        return asyncio.run(asyncio.wait_for(handshake(), timeout))

    where = f"cannot reach the Dask scheduler '{printable(address)}'"
    pool = ThreadPoolExecutor(1)
    try:
        pool.submit(run).result(timeout + 5.0)
    except (TimeoutError, FutureTimeout):
        raise ReachMapError(f"{where}: no answer within {timeout:g} s; give the address of a running scheduler "
                            "(tcp://host:8786)") from None
    except (OSError, ValueError, TypeError) as exc:
        raise ReachMapError(f"{where}: {printable(' '.join(str(exc).split())[:200])}") from None
    finally:
        pool.shutdown(wait=False)


@contextlib.contextmanager
def _quiet_dask():
    """Dask's loggers off while the runner is open (a cancelled task or closed comm logs a traceback, even at
    CRITICAL), and its warnings (a port in use) not shown: the runner's own errors say what went wrong."""
    import warnings

    import distributed  # noqa: F401 - its loggers exist once it is imported

    names = [name for name in list(logging.root.manager.loggerDict) if name.split(".")[0] in DASK_LOGGERS]
    loggers = [logging.getLogger(name) for name in [*DASK_LOGGERS, *names]]
    disabled = [logger.disabled for logger in loggers]
    for logger in loggers:
        logger.disabled = True
    try:
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", module="distributed")
            yield
    finally:
        for logger, was in zip(loggers, disabled):
            logger.disabled = was


def _forkserver_ignoring_sigint() -> None:
    """Start multiprocessing's fork server with SIGINT ignored, so every worker it forks ignores Ctrl-C.

    An ignored signal stays ignored through exec, and the fork server gives
    its children the disposition it started with; the main process ignores
    SIGINT only for the few milliseconds the server takes to start. A fork
    server already running (started earlier in a notebook) is used as it is.
    Only the main thread may change a signal's disposition; elsewhere the
    server starts as it would. The server first imports
    :data:`FORK_SERVER_PRELOAD`, so that each worker it forks has them.
    """
    import multiprocessing
    from multiprocessing import forkserver

    multiprocessing.get_context("forkserver").set_forkserver_preload(list(FORK_SERVER_PRELOAD))
    if threading.current_thread() is not threading.main_thread():
        forkserver.ensure_running()
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        forkserver.ensure_running()
    finally:
        signal.signal(signal.SIGINT, previous)


class BlockRunner:
    """Runs blocks here, on a new LocalCluster (``workers``) or on a running cluster (``scheduler``).

    With a cluster, a Ctrl-C (SIGINT, on the main thread) is recorded by the
    runner's own handler and raised as KeyboardInterrupt where the runner
    waits (every ``POLL_S`` seconds), never inside Dask's callbacks (a
    KeyboardInterrupt raised in one is swallowed, and the build would go on);
    a second Ctrl-C raises at once.
    """

    def __init__(self, workers: int | None, scheduler: str | None, progress=None, store=None):
        check_workers(workers)
        self.workers, self.scheduler, self.progress, self.store = workers, scheduler, progress, store
        self.client = self.cluster = self.scratch = self.sent_job = None
        self.cores = 1  # worker threads of the cluster
        self.interrupted = threading.Event()
        self.quiet = contextlib.ExitStack()

    def __enter__(self):
        if self.workers is None and self.scheduler is None:
            return self
        self.quiet.enter_context(_quiet_dask())
        self._record_sigint()
        try:
            self._start()
            self.raise_if_interrupted()
        except BaseException:
            self.__exit__(None, None, None)
            raise
        return self

    def _record_sigint(self) -> None:
        if threading.current_thread() is not threading.main_thread():
            return

        def record(signum, frame):
            if self.interrupted.is_set():
                raise KeyboardInterrupt
            self.interrupted.set()

        previous = signal.signal(signal.SIGINT, record)
        self.quiet.callback(signal.signal, signal.SIGINT, previous)

    def raise_if_interrupted(self) -> None:
        """KeyboardInterrupt if a Ctrl-C was recorded."""
        if self.interrupted.is_set():
            raise KeyboardInterrupt

    def _start(self) -> None:
        from distributed import Client, LocalCluster

        if self.workers is None:
            probe_scheduler(self.scheduler)
            try:
                self.client = Client(self.scheduler, timeout=SCHEDULER_TIMEOUT_S)
            except (OSError, TimeoutError, ValueError) as exc:
                raise ReachMapError(f"cannot reach the Dask scheduler '{printable(self.scheduler)}': "
                                    f"{printable(' '.join(str(exc).split())[:200])}") from None
            self.cores = max(1, sum(self.client.nthreads().values()))
            return
        _enough_open_files(int(self.workers))
        try:
            self.scratch = tempfile.mkdtemp(prefix="manipkit-dask-")
        except OSError as exc:
            raise ReachMapError(f"cannot make a scratch folder for the Dask workers in {printable(tempfile.gettempdir())}: "
                                f"{exc.strerror or exc}; free some space or set TMPDIR") from None
        import dask

        _forkserver_ignoring_sigint()
        self.quiet.enter_context(dask.config.set({"temporary-directory": self.scratch,  # the scheduler's and nannies'
                                                  "distributed.worker.multiprocessing-method": "forkserver",
                                                  **LOCAL_CLUSTER_CONFIG}))
        self.cluster = LocalCluster(n_workers=int(self.workers), threads_per_worker=1, processes=True, host="127.0.0.1",
                                    scheduler_port=0, dashboard_address=None, silence_logs=logging.CRITICAL, local_directory=self.scratch)
        self.client = Client(self.cluster)
        self.cores = int(self.workers)

    def __exit__(self, *exc):
        # After a Ctrl-C the user waits: workers busy in compiled code (a numba compile, a long block) do not
        # answer a graceful close, which then took 45 s; closes with a short timeout end it in about 20 s.
        hurry = exc[0] is not None and issubclass(exc[0], KeyboardInterrupt)
        try:
            with _quiet_dask():  # closing after a Ctrl-C cancels tasks: no log lines for those
                for part in (self.client, self.cluster):
                    if part is not None:
                        try:
                            part.close(timeout=CLOSE_TIMEOUT_S) if hurry else part.close()
                        except (TimeoutError, OSError, RuntimeError, asyncio.CancelledError):
                            if not hurry:
                                raise
        finally:
            self.client = self.cluster = self.sent_job = None
            if self.scratch is not None:
                shutil.rmtree(self.scratch, ignore_errors=True)
                self.scratch = None
            self.quiet.close()

    def run(self, fn, job, argument_lists: list[tuple], desc: str):
        """Yield ``fn(job, *arguments)`` for each tuple of ``argument_lists``, in any order (:meth:`submit`, then
        :meth:`Batch.results`)."""
        return self.submit(fn, job, argument_lists, desc).results()

    def submit(self, fn, job, argument_lists: list[tuple], desc: str) -> Batch:
        """Hand the blocks ``fn(job, *arguments)`` of ``argument_lists`` to the runner; their results come from
        :meth:`Batch.results`.

        On a cluster the blocks start at once (submit the next batch before
        the results of this one are merged and the workers never wait for the
        merge); here, each runs when :meth:`Batch.results` asks for it.
        With a ``store`` (:class:`manipkit.analysis.reachmap.blockstore.BlockStore`),
        blocks saved by an earlier run of the same build are read back instead
        of computed (a :class:`~manipkit.analysis.reachmap.blockstore.ResumeNote` says
        how many), and each computed block is saved before it is yielded.
        """
        saved = self._saved_blocks(fn, argument_lists, desc)
        missing = [arguments for i, arguments in enumerate(argument_lists) if i not in saved]
        groups, futures = [], []
        if self.client is not None and missing:
            self.raise_if_interrupted()
            job_future = self._sent_job(job)
            sent = self._shared_sent(missing)
            per_task = min(BLOCKS_PER_TASK, max(1, len(missing) // (TASKS_PER_CORE * self.cores)))
            groups = [missing[i:i + per_task] for i in range(0, len(missing), per_task)]
            futures = [self.client.submit(run_blocks, fn, job_future,
                                          [tuple(sent.get(id(a), a) for a in arguments) for arguments in group],
                                          pure=False) for group in groups]
        return Batch(self, fn, job, len(argument_lists), desc, list(saved.values()), missing, zip(futures, groups))

    def _sent_job(self, job):
        """The future of ``job`` on the cluster: sent to every worker once per runner (again for another job)."""
        if self.sent_job is None or self.sent_job[0] is not job:
            self.sent_job = (job, self.client.scatter(job, broadcast=True, hash=False))
        return self.sent_job[1]

    def _shared_sent(self, argument_lists: list[tuple]) -> dict:
        """{id: future} of the arguments every block shares (the same tuple or array object in every list, such as
        a round's snapshot of what is reached): sent to every worker once, not with each block."""
        first = argument_lists[0]
        shared = [a for i, a in enumerate(first) if isinstance(a, tuple | np.ndarray)
                  and all(len(args) > i and args[i] is a for args in argument_lists)]
        return {id(a): self.client.scatter(a, broadcast=True, hash=False) for a in shared}

    def _saved_blocks(self, fn, argument_lists: list[tuple], desc: str) -> dict:
        """{index in ``argument_lists``: result} of the blocks the store holds, checked; notes and warnings said."""
        if self.store is None:
            return {}
        import warnings

        from manipkit.analysis.reachmap.blockstore import BlockStoreWarning, ResumeNote

        saved, refused = {}, []
        for i, arguments in enumerate(argument_lists):
            result, reason = self.store.load(fn, arguments)
            if result is not None:
                saved[i] = result
            elif reason is not None:
                refused.append((arguments[0], reason))
        if refused:
            block, reason = refused[0]
            warnings.warn(f"{len(refused)} saved block(s) of {desc} in {printable(str(self.store.folder))} not used "
                          f"(block {block}: {reason}); computing them again", BlockStoreWarning, stacklevel=3)
        if saved:
            warnings.warn(f"resuming: {len(saved)} of {len(argument_lists)} blocks of {desc} already done",
                          ResumeNote, stacklevel=3)
        return saved

    def _kept(self, fn, arguments: tuple, result):
        """``result``, saved in the store first (when there is one); a store that cannot be written (a full disk)
        is dropped with one warning, and the build goes on without it."""
        if self.store is not None:
            import warnings

            from manipkit.analysis.reachmap.blockstore import BlockStoreWarning
            from manipkit.errors import OutputError

            try:
                self.store.save(fn, arguments, result)
            except OutputError as exc:
                warnings.warn(f"{exc}; the build goes on without keeping its finished blocks", BlockStoreWarning,
                              stacklevel=3)
                self.store = None
        return result


class Batch:
    """Blocks handed to a :class:`BlockRunner` (:meth:`BlockRunner.submit`): read back from its store, running on
    its cluster, or waiting to run here when :meth:`results` asks for them."""

    def __init__(self, runner: BlockRunner, fn, job, total: int, desc: str, saved: list, missing: list[tuple],
                 tasks):
        self.runner, self.fn, self.job, self.total, self.desc = runner, fn, job, total, desc
        self.saved, self.missing = saved, missing
        self.pending = {future.key: (future, group) for future, group in tasks}  # a cluster's tasks: their blocks

    def results(self):
        """Yield each block's result, in any order; ``progress(desc, done, total)`` (blocks) after each."""
        runner = self.runner
        report = runner.progress or (lambda stage, done, total: None)
        report(self.desc, 0, self.total)
        done = 0
        for result in self.saved:
            yield result
            done += 1
            report(self.desc, done, self.total)
        if runner.client is None:
            for arguments in self.missing:
                yield runner._kept(self.fn, arguments, self.fn(self.job, *arguments))
                done += 1
                report(self.desc, done, self.total)
            return
        if not self.pending:
            return
        from distributed import as_completed

        finished = as_completed([future for future, _ in self.pending.values()], with_results=True)
        while not finished.is_empty():  # results are fetched in the background as their blocks finish
            runner.raise_if_interrupted()
            ready = finished.next_batch(block=False)
            if not ready:
                time.sleep(POLL_S)
            for future, results in ready:
                _, group = self.pending.pop(future.key)
                future.release()
                for arguments, result in zip(group, results, strict=True):
                    yield runner._kept(self.fn, arguments, result)
                    done += 1
                    report(self.desc, done, self.total)

    def cancel(self) -> None:
        """Drop the blocks not yielded yet (on a cluster their tasks are cancelled; here they never run)."""
        self.missing = []
        futures = [future for future, _ in self.pending.values()]
        self.pending = {}
        if futures and self.runner.client is not None:
            self.runner.client.cancel(futures)


def run_blocks(fn, job, argument_lists: list[tuple]) -> list:
    """``[fn(job, *arguments) for arguments in argument_lists]``: one task of a cluster, a few blocks in a row."""
    return [fn(job, *arguments) for arguments in argument_lists]


def in_block_order(results, first: int = 0):
    """The block results of ``results`` (tuples starting with the block number, ``first``, ``first + 1``, ..., in any
    order) in block order."""
    waiting, following = {}, first
    for result in results:
        waiting[result[0]] = result
        while following in waiting:
            yield waiting.pop(following)
            following += 1


#: Open files a local Dask cluster needs: the scheduler and client, and each worker's nanny, process and
#: connections (measured: 2 workers failed to start under ulimit -n 40, with tracebacks from the workers).
_FILES_BASE, _FILES_PER_WORKER = 128, 32


def _enough_open_files(workers: int) -> None:
    """Raise the soft open-file limit towards the hard one if a cluster of ``workers`` needs more; a
    :class:`~manipkit.errors.ReachMapError` in one line when even the hard limit is too low."""
    try:
        import resource
    except ImportError:  # not POSIX: nothing to check
        return
    needed = _FILES_BASE + _FILES_PER_WORKER * workers
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    if soft == resource.RLIM_INFINITY or soft >= needed:
        return
    if hard == resource.RLIM_INFINITY or hard >= needed:
        try:
            resource.setrlimit(resource.RLIMIT_NOFILE, (needed, hard))
            return
        except (ValueError, OSError):
            pass
    raise ReachMapError(f"--workers {workers} needs about {needed} open files and the limit is {soft} (ulimit -n); "
                        "raise the limit or give fewer workers")
