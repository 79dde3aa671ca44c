"""Writing files a user asks for: the one way a file is written.

Every file manipkit writes (tree pictures and DOT, DH tables, URDF, plots,
static viewer pages) goes through :func:`writing` or :func:`write_text`
(and is checked early by :func:`writable_path`):

- a folder the user did not ask for is never created;
- the file is written to a temporary file in the target folder and renamed
  over the target only when complete: a full disk or an error leaves the old
  file (or nothing), never a truncated one;
- a symbolic link at the output path is replaced by the file, not followed
  into another folder; a device or a pipe the user names (``/dev/null``, a
  FIFO, ``/dev/stdout`` and other links into ``/dev`` or ``/proc``) is
  written as a stream, in place, never renamed over; a FIFO no process reads
  is refused at once (:class:`~manipkit.errors.OutputError`), not waited on; so is a stream that is the
  regular file stdout is redirected to (``-o /dev/stdout > out.txt``), which the report would overwrite;
- a file replaced keeps its mode (a 0600 file stays 0600); a new one gets
  the mode ``open()`` would give it;
- an output that is one of the command's inputs (``inputs=``, or, while
  :func:`refusing_inputs` is in force, as in every command line, any file read
  through :func:`manipkit.inputs.check_input_file`: the robot, an SRDF, a mesh)
  is refused before anything is written;
- a missing folder, a path that is a folder, no permission or a full disk
  give :class:`~manipkit.errors.OutputError` ``cannot write PATH: reason``
  (docs/architecture.md, "Errors and messages").
"""

from __future__ import annotations

import contextlib
import errno
import os
import stat
import threading
from collections.abc import Iterable, Iterator
from pathlib import Path

from manipkit.errors import OutputError
from manipkit.text import printable

__all__ = ["cannot_write", "distinct_outputs", "is_stream", "note_input", "refusing_inputs", "writable_path", "write_text", "writing"]

_READ: set[tuple[int, int]] = set()  # (device, inode) of each file noted as read while refusing_inputs is in force
_REFUSING: list[bool] = []


@contextlib.contextmanager
def refusing_inputs():
    """Within this block (a command line), :func:`writable_path` refuses every file :func:`note_input` noted."""
    _REFUSING.append(True)
    try:
        yield
    finally:
        _REFUSING.pop()
        if not _REFUSING:
            _READ.clear()


def note_input(path: str | os.PathLike) -> None:
    """Remember that ``path`` is an input (the same file by any name) while :func:`refusing_inputs` is in force."""
    if _REFUSING:
        with contextlib.suppress(OSError, ValueError):
            info = os.stat(path)
            _READ.add((info.st_dev, info.st_ino))


def cannot_write(path: str | os.PathLike, exc: OSError) -> OutputError:
    """``OutputError("cannot write PATH: reason")`` for an OSError met while writing ``path``."""
    reason = exc.strerror or str(exc)
    return OutputError(f"cannot write {printable(path)}: {reason}")


def writable_path(path: str | os.PathLike, *, inputs: Iterable[str | os.PathLike | None] = ()) -> Path:
    """``path`` if a file can be written there: its folder exists, it is not a folder, nor one of ``inputs``.

    Checked before expensive work (a plot, a tree image), so the user hears
    about a typo at once. Nothing is created. ``inputs`` are the files the
    command reads (a robot description, a DH table): writing over one of
    them would destroy the input, so it is refused (the same file by any
    name: a symbolic or hard link counts).

    Raises
    ------
    OutputError
        ``cannot write PATH: no such folder FOLDER`` or ``...: it is a folder``.

    Examples
    --------
    >>> writable_path("/nonexistent/x.png")
    Traceback (most recent call last):
    ...
    manipkit.errors.OutputError: cannot write /nonexistent/x.png: no such folder /nonexistent
    """
    if "\0" in str(path):
        raise OutputError(f"cannot write {printable(path)}: a file name cannot hold a NUL character")
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    longest = _name_max(folder)
    if len(os.fsencode(path.name)) > longest:
        raise OutputError(f"cannot write {printable(str(path))[:120]}...: the file name is "
                          f"{len(os.fsencode(path.name))} bytes, more than the {longest} this file system takes")
    try:
        is_folder = path.is_dir()
    except OSError as exc:  # a path too long as a whole (ENAMETOOLONG), a loop
        raise cannot_write(path, exc) from None
    if is_folder:
        raise OutputError(f"cannot write {printable(path)}: it is a folder; give a file name")
    if not folder.is_dir():
        raise OutputError(f"cannot write {printable(path)}: no such folder {printable(folder)}")
    for source in inputs:
        if source is not None and _same_file(path, source):
            raise OutputError(
                f"cannot write {printable(path)}: it is the command's input {printable(source)}; "
                "give another output file name"
            )
    if is_stream(path) and _is_redirected_stdout(path):
        raise OutputError(f"cannot write {printable(path)}: it is the file stdout is redirected to, where the "
                          "command prints its report too (one would overwrite the other); give -o FILE instead")
    if _READ:
        info = None
        with contextlib.suppress(OSError, ValueError):
            info = os.stat(path)
        if info is not None and stat.S_ISREG(info.st_mode) and (info.st_dev, info.st_ino) in _READ:
            raise OutputError(f"cannot write {printable(path)}: the command reads it (it is one of its "
                                  "inputs); give another output file name")
    return path


def distinct_outputs(outputs: Iterable[tuple[str, str | os.PathLike | None]]) -> None:
    """Refuse two outputs of one command that name the same file (the second written would replace the first).

    ``outputs`` are ``(option, path)`` pairs (``path`` None when not asked for). Streams (``/dev/stdout``,
    ``/dev/null``, a FIFO) may be shared. The same file by any name: an existing file by its identity,
    a new one by its absolute path with symbolic links resolved.

    Raises
    ------
    OutputError
        ``OPTION A and OPTION B name the same file PATH``.

    Examples
    --------
    >>> distinct_outputs([("-o", "a.csv"), ("--plot", "./a.csv")])
    Traceback (most recent call last):
    ...
    manipkit.errors.OutputError: -o a.csv and --plot ./a.csv name the same file; give each output its own name
    """
    seen: list[tuple[str, str | os.PathLike, str]] = []
    for option, path in outputs:
        if path is None or is_stream(path):
            continue
        try:
            key = os.path.realpath(path)
        except (OSError, ValueError):
            continue
        for other_option, other, other_key in seen:
            if key == other_key or _same_file(Path(path), other):
                raise OutputError(f"{other_option} {printable(str(other))[:120]} and {option} "
                                  f"{printable(str(path))[:120]} name the same file; give each output its own name")
        seen.append((option, path, key))


def _is_redirected_stdout(path: Path) -> bool:
    """``path`` is the regular file descriptor 1 writes to (``-o /dev/stdout > out.txt``): a second writer into
    it would start at offset 0 over the first, so the two outputs would overwrite each other."""
    try:
        target, out = os.stat(path), os.fstat(1)
    except OSError:
        return False
    return stat.S_ISREG(out.st_mode) and (target.st_dev, target.st_ino) == (out.st_dev, out.st_ino)


def _name_max(folder: Path) -> int:
    """The longest file name (bytes) the file system of ``folder`` takes (255 where it does not say)."""
    try:
        return int(os.pathconf(folder if folder.is_dir() else ".", "PC_NAME_MAX"))
    except (OSError, ValueError):
        return 255


def _same_file(path: Path, other) -> bool:
    try:
        return os.path.samefile(path, other)
    except (OSError, ValueError, TypeError):  # either does not exist (yet), or is no path
        return False


@contextlib.contextmanager
def writing(path: str | os.PathLike, *, inputs: Iterable[str | os.PathLike | None] = ()) -> Iterator[Path]:
    """Context for code that writes a file itself (matplotlib's ``savefig``): write the path it yields.

    The yielded path is a temporary file in the target folder with the
    target's suffix (so a writer that reads the format from the suffix
    still works); it is renamed over ``path`` when the block ends without
    error and removed otherwise. OSError -> OutputError.

    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> with writing(folder / "x.txt") as target:
    ...     _ = target.write_text("ok")
    >>> (folder / "x.txt").read_text(), [p.name for p in folder.iterdir()]
    ('ok', ['x.txt'])
    """
    path = writable_path(path, inputs=inputs)
    if is_stream(path):  # a device or pipe the user named (/dev/stdout, a FIFO): written in place
        with _reader_checked(path):
            try:
                yield path
            except OSError as exc:
                raise cannot_write(path, exc) from None
        return
    try:
        kept = stat.S_IMODE(os.lstat(path).st_mode) if stat.S_ISREG(os.lstat(path).st_mode) else None
    except OSError:
        kept = None  # a new file (or a symbolic link, replaced): the mode a new file gets
    folder = path.parent if str(path.parent) else Path(".")
    import tempfile  # here, not at the top: tf-between's start-up never writes a file

    try:
        handle, name = tempfile.mkstemp(dir=folder, prefix=f".{path.name[:64]}.", suffix=f".part{path.suffix[:16]}")
    except OSError as exc:
        raise cannot_write(path, exc) from None
    os.close(handle)
    temporary = Path(name)
    try:
        yield temporary
        os.chmod(temporary, _new_file_mode() if kept is None else kept)
        os.replace(temporary, path)  # replaces a symbolic link at ``path``, never follows it
    except OSError as exc:
        raise cannot_write(path, exc) from None
    finally:
        with contextlib.suppress(OSError):
            temporary.unlink()


def is_stream(path: str | os.PathLike) -> bool:
    """An existing output written as a stream: a device, a FIFO, a socket, or a symbolic link to one or into
    ``/dev`` or ``/proc`` (``/dev/stdout`` -> ``/proc/self/fd/1``, whatever fd 1 is)."""
    try:
        mode = os.lstat(path).st_mode
    except OSError:
        return False
    if stat.S_ISREG(mode):
        return False
    if not stat.S_ISLNK(mode):
        return True
    # /dev/stdout -> /proc/self/fd/1 -> wherever fd 1 is (a terminal, a pipe, or a regular file: > out.txt):
    # a link that is, or points, into /dev or /proc is a stream whatever it ends at
    steps = [os.path.abspath(path), os.path.join(os.path.dirname(os.path.abspath(path)), os.readlink(path))]
    if any(step.startswith(("/dev/", "/proc/")) for step in steps):
        return True
    try:
        return not stat.S_ISREG(os.stat(path).st_mode)  # a link to a device or FIFO elsewhere
    except OSError:
        return False  # a dangling link: replaced by the file


@contextlib.contextmanager
def _reader_checked(path: Path):
    """For a FIFO: refuse at once when no process reads it (instead of blocking forever in ``open``), and hold
    it open for writing while the block runs (so the writer's own ``open`` does not wait either)."""
    try:
        is_fifo = stat.S_ISFIFO(os.stat(path).st_mode)
    except OSError:
        is_fifo = False
    if not is_fifo:
        yield
        return
    try:
        held = os.open(path, os.O_WRONLY | os.O_NONBLOCK)
    except OSError as exc:
        if exc.errno == errno.ENXIO:
            raise OutputError(f"cannot write {printable(path)}: it is a FIFO (named pipe) that no process is "
                              "reading; start the reader first (cat FIFO &)") from None
        raise cannot_write(path, exc) from None
    try:
        yield
    finally:
        os.close(held)


_UMASK_LOCK = threading.Lock()


def _umask() -> int:
    """The process's umask, read without changing it where Linux tells it (``Umask:`` in /proc/self/status);
    elsewhere set and restored under a lock, so threads of this module never see a changed mask."""
    try:
        with open("/proc/self/status", encoding="ascii") as status:
            for line in status:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    with _UMASK_LOCK:
        mask = os.umask(0o022)
        os.umask(mask)
    return mask


def _new_file_mode() -> int:
    """The mode ``open()`` would give a new file: 0o666 less the process's umask (mkstemp gives 0o600)."""
    return 0o666 & ~_umask()


def write_text(
    path: str | os.PathLike, text: str, *, encoding: str = "utf-8", inputs: Iterable[str | os.PathLike | None] = ()
) -> Path:
    """Write ``text`` to ``path`` through :func:`writing`; OSError (full disk, permission) -> OutputError."""
    with writing(path, inputs=inputs) as target:
        with open(target, "w", encoding=encoding) as stream:
            stream.write(text)
            stream.flush()
            if stat.S_ISREG(os.fstat(stream.fileno()).st_mode):  # /dev/null, a FIFO or a terminal cannot fsync
                os.fsync(stream.fileno())
    return Path(path)
