"""Command-line front end: parse, call the library, format. No kinematics here.

``tf-between SOURCE TARGET`` prints T_SOURCE_TARGET (the pose of TARGET in
SOURCE) like ROS 2 ``tf2_echo``; ``manipkit`` groups the other commands.
User errors print one line on stderr and exit with status 2; a bug exits
with status 1 and asks to be reported. Output that cannot be written (a
file through :mod:`manipkit.outputs`, or stdout on a full disk or
``/dev/full``) is a user error, ``cannot write PATH: reason``; a closed
pipe (``| head -1``) ends the command quietly, as Unix tools do. Warnings (a normalised joint axis, an
unresolved ``package://`` mesh, a value moved into its limits by ``--clamp``)
print as ``warning: ...`` lines on stderr; the answer stays alone on stdout.
Joint values outside their limits are an error naming the joint, the value
and the limits, unless ``--clamp`` is given.

One module per command group, each with ``register(commands)`` adding its
subparser(s) and the ``run_*`` functions they call: :mod:`.tf`,
:mod:`.robots` (robots, frames), :mod:`.tree`, :mod:`.dh`, :mod:`.ik`, :mod:`.family`,
:mod:`.workspace`, :mod:`.collisions` (collisions, acm), :mod:`.path`, :mod:`.view`; the options they share are in
:mod:`.common`. How to add a command: docs/architecture.md.

argparse (standard library) is used rather than click/typer so that
``tf-between`` starts fast; heavy modules (and json) are imported inside the
commands, and ``tf-between`` imports no other command's module.
"""

from __future__ import annotations

import argparse
import errno
import functools
import os
import sys
import warnings

from manipkit.app.cli.common import EXIT_INTERNAL, EXIT_OK, EXIT_USAGE, Parser, UsageError, warn
from manipkit.app.cli.tf import run_tf, tf_parser
from manipkit.errors import ManipkitError, OutputError
from manipkit.outputs import cannot_write, refusing_inputs
from manipkit.text import printable, printable_lines

__all__ = ["main", "parsers", "run_command", "tf_between_main"]


def main(argv=None) -> int:
    """``manipkit COMMAND [options]``."""
    return run_command(_main_parser(), argv)


def tf_between_main(argv=None) -> int:
    """``tf-between SOURCE TARGET [options]``."""
    return run_command(tf_parser("tf-between"), argv, run_tf)


def parsers() -> dict[str, argparse.ArgumentParser]:
    """The two programs' parsers by name (``manipkit``, ``tf-between``): what the command-line reference documents."""
    return {"tf-between": tf_parser("tf-between"), "manipkit": _main_parser()}


@functools.cache
def _main_parser() -> argparse.ArgumentParser:
    """The ``manipkit`` parser, built once per process (about 18 ms: 396 options), then reused: parsing leaves a
    parser as it was, and every value it holds (the ``run`` functions, choices, defaults) is fixed when it is built."""
    from manipkit.app.cli import (
        collisions,
        dh,
        family,
        ik,
        path,
        reachmap,
        robots,
        rot,
        singularities,
        statics,
        tf,
        tree,
        velocity,
        view,
        workspace,
    )

    parser = Parser(prog="manipkit", description="Manipulator kinematics from URDF/xacro, without ROS.")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND", parser_class=Parser)
    groups = (tf, robots, tree, dh, ik, family, velocity, singularities, statics, workspace, reachmap, collisions,
              path, view, rot)  # `manipkit --help` order
    for group in groups:
        group.register(commands)
    return parser


def run_command(parser: argparse.ArgumentParser, argv, runner=None) -> int:
    """Parse ``argv`` and run the command (``runner``, else the one the parser chose); the exit status.

    A :class:`~manipkit.errors.ManipkitError` prints one line
    ``PROG: error: ...`` on stderr (status 2); any other exception is a bug:
    one short line asking for a report (status 1), no traceback. stdout is
    flushed before the command counts as done, so a full disk or
    ``/dev/full`` ends as ``PROG: error: cannot write stdout: REASON``
    (status 2), and a reader that went away (``| head -1``) ends the command
    quietly with status 0.
    """
    stdout = sys.stdout  # None when the process was started with stdout closed (``>&-``)
    sys.stdout = _GuardedStdout(stdout)
    with warnings.catch_warnings(), refusing_inputs():  # no output written over a file the command reads
        warnings.showwarning = _warning_line
        return _run_guarded(parser, argv, runner, stdout)


def _warning_line(message, category, filename, lineno, file=None, line=None) -> None:
    """A Python warning raised while a command runs (a kernel cache that cannot be written, ...) as one line."""
    warn(str(message))


def _environment_problem() -> str | None:
    """What is wrong with an environment variable a library reads at import, before the command runs (a
    bogus ``MPLBACKEND`` or ``NUMBA_NUM_THREADS`` made every plot or kernel an internal error)."""
    checks = (("NUMBA_NUM_THREADS", "numba"), ("MPLBACKEND", "matplotlib"))
    for name, module in checks:
        if name not in os.environ:
            continue
        try:
            __import__(module)  # only when the variable is set: the import is what reads it
        except (ValueError, KeyError, TypeError, ImportError) as exc:
            value = printable(os.environ[name])[:40]
            reason = printable(" ".join(str(exc).split()))[:160]
            return f"environment variable {name}={value!r} is refused by {module} ({reason}); unset it or fix it"
    return None


def _run_guarded(parser: argparse.ArgumentParser, argv, runner, stdout) -> int:
    try:
        args = parser.parse_args(argv)
        args.command_line = list(sys.argv[1:] if argv is None else argv)  # what a printed command repeats
        problem = _environment_problem()
        if problem is not None:
            raise UsageError(problem)
        status = (runner or args.run)(args)
        sys.stdout.flush()  # inside the try: a write that fails shows here, not at interpreter exit
        return status
    except ManipkitError as exc:
        _tell(f"{parser.prog}: error: {printable(' '.join(str(exc).split()))}")
        return EXIT_USAGE
    except KeyboardInterrupt:  # Ctrl-C: one line, the shell's status for SIGINT
        print(f"{parser.prog}: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        return EXIT_OK
    except SystemExit as exc:  # rich's console ends a closed pipe (| head -1) with SystemExit(1): quiet, as above
        if isinstance(exc.__context__, BrokenPipeError):
            return EXIT_OK
        raise
    except Exception as exc:  # a bug: short message, no traceback, exit 1
        if (isinstance(exc, OSError) and exc.errno in (errno.EMFILE, errno.ENFILE, errno.EAGAIN, errno.ENOMEM)) or (
                isinstance(exc, RuntimeError) and "can't start new thread" in str(exc)):
            # not a bug: the system refused a resource (no file descriptors or threads left)
            _tell(f"{parser.prog}: error: the system refused a resource ({getattr(exc, 'strerror', None) or exc}); "
                  "raise the limit "
                  "(ulimit -n for open files, ulimit -u for threads) or give fewer --workers")
            return EXIT_USAGE
        detail = printable(" ".join(str(exc).split())[:300])
        _tell(
            f"{parser.prog}: internal error ({type(exc).__name__}: {detail}); this is a bug in manipkit, "
            "please report it with the command line used"
        )
        return EXIT_INTERNAL
    finally:
        sys.stdout = stdout
        _settle(stdout)


def _tell(line: str) -> None:
    """``line`` on stderr, if the process has one (it may have been started with stderr closed)."""
    if sys.stderr is not None:
        print(line, file=sys.stderr)


class _GuardedStdout:
    """``sys.stdout`` while a command runs: a write or flush that fails (full disk, ``/dev/full``, EIO)
    raises :class:`~manipkit.errors.OutputError` ``cannot write stdout: REASON``; a closed pipe
    stays a :class:`BrokenPipeError`. Every write passes the text sanitiser
    (:func:`manipkit.text.printable_lines`): no escape sequence from a
    description reaches the terminal; a character the stream's encoding cannot
    write (``LC_ALL=C``) is written as ``\\uXXXX``. Everything else is the stream's own."""

    def __init__(self, stream):
        self._stream = stream

    def write(self, text: str) -> int:
        if self._stream is None:
            raise OutputError("cannot write stdout: it is closed; give the command somewhere to write (> FILE)")
        text = printable_lines(text)
        try:
            return self._stream.write(text)
        except UnicodeEncodeError:  # a character the terminal's encoding lacks (LC_ALL=C): written as \uXXXX
            encoding = getattr(self._stream, "encoding", None) or "ascii"
            return self._stream.write(text.encode(encoding, "backslashreplace").decode(encoding))
        except BrokenPipeError:
            raise
        except OSError as exc:
            raise cannot_write("stdout", exc) from None

    def flush(self) -> None:
        if self._stream is None:
            return
        try:
            self._stream.flush()
        except BrokenPipeError:
            raise
        except OSError as exc:
            raise cannot_write("stdout", exc) from None

    def __getattr__(self, name):
        return getattr(self._stream, name)


def _settle(stream) -> None:
    """Flush ``stream``; if it cannot take the output (closed pipe, full disk), drop what is left.

    Python flushes stdout once more at exit and would print ``Exception
    ignored ...`` for output that could not be written: pointing the
    process's stdout at ``/dev/null`` lets it exit quietly (the Python
    docs' advice for SIGPIPE). Only the process's own stdout is redirected.
    """
    if stream is None:
        return
    try:
        stream.flush()
    except (OSError, ValueError):  # ValueError: already closed
        if stream is sys.__stdout__:
            try:
                devnull = os.open(os.devnull, os.O_WRONLY)
                os.dup2(devnull, stream.fileno())
                os.close(devnull)
            except (OSError, ValueError):
                pass
