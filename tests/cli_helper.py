"""Run ``tf-between`` and ``manipkit`` in the test process, as a user would run them: ``run_cli``.

``run_cli("manipkit", "tree", "--robot", "panda")`` calls the entry point's
``main(argv)`` (``[project.scripts]`` in pyproject.toml) and returns a
:class:`CliResult` with the fields of :class:`subprocess.CompletedProcess`
that the tests read: ``returncode``, ``stdout`` and ``stderr``. It costs what
the command itself costs (tens of milliseconds for most), where a subprocess
adds most of a second (the interpreter and the imports), and the command
sees what it would see as a process:

- stdout and stderr are files on descriptors 1 and 2 (what C code such as
  Pinocchio writes is captured too), encoded as a Python process encodes a
  pipe (UTF-8; strict on stdout, backslashreplace on stderr); stdin is
  /dev/null;
- ``sys.argv`` is the command line, the working folder is ``cwd`` and the
  environment has the changes in ``env`` (a value of None removes the
  variable);
- the warnings filters are those of a fresh interpreter (pytest shows
  DeprecationWarning, a process does not), and logging has no root handler
  (pytest's capture handlers would swallow what a process prints);
- ``SystemExit`` (argparse's ``--help`` and usage errors) becomes the exit
  status, as the interpreter makes it;
- stdout and stderr are decoded strictly as UTF-8, as
  ``subprocess.run(..., text=True)`` decodes them in a UTF-8 locale.

Everything above is put back afterwards, whatever the command did: the
streams and descriptors, ``sys.argv``, the working folder, the whole
environment, the warnings filters, every logger's level, handlers and
switches, the SIGINT/SIGTERM/SIGPIPE handlers, numpy's error and print
settings, the recursion and integer-digit limits. So nothing leaks from one
test to the next.

Use a subprocess instead only where the test is about the process itself: a
crash, a timeout or a hang, a signal, memory, what happens when stdout is
closed or a full disk, the locale or ``PYTHONIOENCODING``, the cold start.
Say why in a comment there.
"""

from __future__ import annotations

import contextlib
import logging
import os
import signal
import sys
import tempfile
import warnings
from collections.abc import Mapping
from dataclasses import dataclass

__all__ = ["CliResult", "run_cli"]

#: A fresh interpreter's warnings filters (release build, no -W or PYTHONWARNINGS), the first one first.
_DEFAULT_FILTERS = (
    ("default", DeprecationWarning, "__main__"),
    ("ignore", DeprecationWarning, None),
    ("ignore", PendingDeprecationWarning, None),
    ("ignore", ImportWarning, None),
    ("ignore", ResourceWarning, None),
)
_SIGNALS = tuple(getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGPIPE") if hasattr(signal, name))


@dataclass
class CliResult:
    """What a command did: ``args`` (the command line), ``returncode``, ``stdout``, ``stderr``."""

    args: list[str]
    returncode: int
    stdout: str
    stderr: str


def _entry_point(command: str):
    from manipkit.app.cli import main, tf_between_main

    entry_points = {"manipkit": main, "tf-between": tf_between_main}  # pyproject.toml [project.scripts]
    if command not in entry_points:
        raise ValueError(f"unknown command {command!r}; the entry points are {', '.join(entry_points)}")
    return entry_points[command]


def run_cli(command: str, *args, status: int | None = None, cwd: str | os.PathLike | None = None,
            env: Mapping[str, str | None] | None = None) -> CliResult:
    """Run ``command ARGS`` (``tf-between`` or ``manipkit``) in this process; its status and output.

    ``args`` are turned into strings (paths and numbers may be given);
    ``status``, when given, is the exit status the test expects (asserted,
    with the output in the message); ``cwd`` is the working folder while it
    runs; ``env`` sets (or, with None, removes) environment variables while
    it runs.
    """
    main = _entry_point(command)
    argv = [str(arg) for arg in args]
    outer = sys.stdout, sys.stderr
    with contextlib.ExitStack() as stack:
        stack.enter_context(_restored_process_state())
        out_file = stack.enter_context(tempfile.TemporaryFile())
        err_file = stack.enter_context(tempfile.TemporaryFile())
        stack.enter_context(_descriptor_redirected(1, out_file))
        stack.enter_context(_descriptor_redirected(2, err_file))
        sys.argv = [command, *argv]
        sys.stdin = stack.enter_context(open(os.devnull, encoding="utf-8"))
        # Text streams on descriptors 1 and 2 like a process's own (line buffering keeps them in order with C writes).
        sys.stdout = stack.enter_context(open(1, "w", encoding="utf-8", errors="strict", closefd=False, buffering=1))
        sys.stderr = stack.enter_context(open(2, "w", encoding="utf-8", errors="backslashreplace", closefd=False,
                                              buffering=1))
        _set_environment(env or {})
        if cwd is not None:
            os.chdir(cwd)
        _fresh_warnings_and_logging(outer)
        try:
            returncode = main(argv)
        except SystemExit as exc:  # argparse: --help (0), usage errors (2); as the interpreter turns it into a status
            returncode = _exit_status(exc.code)
        finally:
            sys.stdout.flush()
            sys.stderr.flush()
        out_file.seek(0)
        err_file.seek(0)
        # decoded strictly, as subprocess.run(text=True) does in a UTF-8 locale: bytes that are no UTF-8 are an error
        stdout = out_file.read().decode("utf-8")
        stderr = err_file.read().decode("utf-8")
        _repoint_handlers({id(sys.stdout): "stdout", id(sys.stderr): "stderr"})
    result = CliResult([command, *argv], returncode, stdout, stderr)
    if status is not None:
        assert result.returncode == status, result.stdout[-2000:] + result.stderr
    return result


def _exit_status(code) -> int:
    if code is None:
        return 0
    if isinstance(code, int):
        return code
    print(code, file=sys.stderr)  # sys.exit("message"): the message on stderr, status 1
    return 1


@contextlib.contextmanager
def _descriptor_redirected(fd: int, file):
    """Descriptor ``fd`` writes to ``file`` inside the block, then goes back to what it was."""
    saved = os.dup(fd)
    try:
        os.dup2(file.fileno(), fd)
        yield
    finally:
        os.dup2(saved, fd)
        os.close(saved)


def _set_environment(changes: Mapping[str, str | None]) -> None:
    for name, value in changes.items():
        if value is None:
            os.environ.pop(name, None)
        else:
            os.environ[name] = str(value)


def _fresh_warnings_and_logging(outer_streams) -> None:
    """The warnings filters of a fresh interpreter; no root logging handler (a process has none)."""
    warnings.resetwarnings()
    for action, category, module in reversed(_DEFAULT_FILTERS):
        warnings.filterwarnings(action, category=category, module=module or "")
    logging.root.handlers = []
    _repoint_handlers({id(outer_streams[0]): "stdout", id(outer_streams[1]): "stderr",
                       id(sys.__stdout__): "stdout", id(sys.__stderr__): "stderr"})


@contextlib.contextmanager
def _restored_process_state():
    """Put back, on the way out, everything of the process a command or :func:`run_cli` may change."""
    streams = sys.stdin, sys.stdout, sys.stderr
    argv = list(sys.argv)
    cwd = os.getcwd()
    environ = dict(os.environ)
    limits = sys.getrecursionlimit(), sys.get_int_max_str_digits()
    handlers = {signum: signal.getsignal(signum) for signum in _SIGNALS}
    loggers = _logger_states()
    numpy = sys.modules.get("numpy")
    numpy_settings = (numpy.geterr(), numpy.get_printoptions()) if numpy else None
    try:
        with warnings.catch_warnings():
            yield
    finally:
        sys.stdin, sys.stdout, sys.stderr = streams
        sys.argv = argv
        os.chdir(cwd)
        if dict(os.environ) != environ:
            os.environ.clear()
            os.environ.update(environ)
        sys.setrecursionlimit(limits[0])
        sys.set_int_max_str_digits(limits[1])
        for signum, handler in handlers.items():
            if handler is not None:  # None: set from outside Python, cannot be put back from here
                signal.signal(signum, handler)
        _restore_loggers(loggers)
        if numpy_settings:
            numpy.seterr(**numpy_settings[0])
            numpy.set_printoptions(**numpy_settings[1])


def _all_loggers() -> list[logging.Logger]:
    return [logging.root, *(obj for obj in logging.root.manager.loggerDict.values() if isinstance(obj, logging.Logger))]


def _logger_states() -> dict:
    loggers = _all_loggers()
    return {
        "disable": logging.root.manager.disable,
        "loggers": [(lg, lg.level, list(lg.handlers), lg.propagate, lg.disabled) for lg in loggers],
        "streams": [(h, h.stream) for lg in loggers for h in lg.handlers if isinstance(h, logging.StreamHandler)],
    }


def _restore_loggers(state: dict) -> None:
    logging.disable(state["disable"])
    for logger, level, handlers, propagate, disabled in state["loggers"]:
        logger.setLevel(level)
        logger.handlers = handlers
        logger.propagate = propagate
        logger.disabled = disabled
    for handler, stream in state["streams"]:
        handler.stream = stream


class _CurrentStream:
    """Stands for ``sys.stdout`` or ``sys.stderr`` as they are when written to (see :func:`_repoint_handlers`)."""

    def __init__(self, name: str):
        self.name = name

    def write(self, text: str) -> int:
        return getattr(sys, self.name).write(text)

    def flush(self) -> None:
        getattr(sys, self.name).flush()


def _repoint_handlers(streams: dict) -> None:
    """Logging handlers that write to one of ``streams`` (id -> "stdout" or "stderr") write to it as it is then.

    Before a command: the handlers a library set up on the test process's
    stderr write to the command's stderr, as they would in a process of its
    own. After it: a handler made while it ran (a library imported then)
    writes to ``sys.stderr`` as it is later, not to the closed stream of
    that command. :func:`_restore_loggers` puts the first kind back.
    """
    for logger in _all_loggers():
        for handler in logger.handlers:
            stream = getattr(handler, "stream", None)
            if stream is not None and id(stream) in streams:
                handler.stream = _CurrentStream(streams[id(stream)])
