"""Reading files a user names, safely: regular files only, bounded in size, one-line errors.

Every file manipkit reads on a user's behalf (descriptions, xacro includes,
DH tables, ``--compare`` matrices, ``--q-file`` tables, YAML loaded from
xacro) goes through :func:`check_input_file` (and :func:`read_text` when it
is read whole), so a FIFO, a device, a folder or a huge file is refused
before any parser sees it, with :class:`~manipkit.errors.InputFileError`
naming the file and what would be valid (docs/site/internals/limits.md).
"""

from __future__ import annotations

import errno
import os
import stat
from pathlib import Path

from manipkit.errors import InputFileError
from manipkit.outputs import note_input

__all__ = [
    "MAX_DESCRIPTION_BYTES",
    "MAX_MATRIX_BYTES",
    "MAX_TABLE_BYTES",
    "check_input_file",
    "file_digest",
    "read_text",
]

#: URDF and xacro files (and each xacro include): the largest real descriptions are a few MB.
MAX_DESCRIPTION_BYTES = 64 * 1024 * 1024
#: DH tables and YAML files loaded from xacro.
MAX_TABLE_BYTES = 4 * 1024 * 1024
#: A hand-written 4x4 matrix (``--compare``): text, CSV, JSON or .npy.
MAX_MATRIX_BYTES = 1024 * 1024


def _size_text(size: int) -> str:
    for unit, scale in (("GB", 1 << 30), ("MB", 1 << 20), ("kB", 1 << 10)):
        if size >= scale:
            return f"{size / scale:.3g} {unit}"
    return f"{size} bytes"


def _too_large(what: str, path: Path, size: int, limit: int) -> InputFileError:
    """``... is 100 MB, above the limit of 1 MB``; exact bytes where rounding would hide the difference."""
    size_text, limit_text = _size_text(size), _size_text(limit)
    if size_text == limit_text:
        size_text, limit_text = f"{size:,} bytes", f"{limit_text} ({limit:,} bytes)"
    return InputFileError(f"{what} {path} is {size_text}, above the limit of {limit_text} for a {what}")


def check_input_file(path: str | os.PathLike, *, what: str, max_bytes: int | None = None) -> Path:
    """``path`` if it is a regular file (following symlinks) no larger than ``max_bytes``.

    Parameters
    ----------
    path : str or path-like
    what : str, keyword-only
        What the file is, for messages (``"robot file"``, ``"--q-file"``).
    max_bytes : int or None, keyword-only
        Largest size accepted; None for no limit (files that are streamed).

    Raises
    ------
    InputFileError
        Missing, a folder, a FIFO, socket or device, a symlink loop, not
        readable, or too large; the message names the file and the limit.

    Examples
    --------
    >>> check_input_file("/dev/null", what="--q-file")
    Traceback (most recent call last):
    ...
    manipkit.errors.InputFileError: --q-file /dev/null is a character device, not a regular file; give a file
    """
    path = Path(path)
    try:
        info = path.stat()
    except FileNotFoundError:
        raise InputFileError(f"{what} {path}: no such file") from None
    except OSError as exc:  # a symlink loop (ELOOP), a name too long, no permission on a folder
        if exc.errno == errno.ELOOP:
            raise InputFileError(f"{what} {path} is a symlink loop (it points back to itself); give a file") from None
        raise InputFileError(f"{what} {path}: cannot be read ({exc.strerror or exc})") from None
    mode = info.st_mode
    if not stat.S_ISREG(mode):
        kind = ("a folder" if stat.S_ISDIR(mode) else "a FIFO (named pipe)" if stat.S_ISFIFO(mode)
                else "a socket" if stat.S_ISSOCK(mode) else "a character device" if stat.S_ISCHR(mode)
                else "a block device" if stat.S_ISBLK(mode) else "not a regular file")
        raise InputFileError(f"{what} {path} is {kind}, not a regular file; give a file")
    if max_bytes is not None and info.st_size > max_bytes:
        raise _too_large(what, path, info.st_size, max_bytes)
    if not os.access(path, os.R_OK):
        raise InputFileError(f"{what} {path}: permission denied (not readable)")
    note_input(path)  # a command line never writes its output over a file it reads (manipkit.outputs)
    return path


def read_text(path: str | os.PathLike, *, what: str, max_bytes: int, encoding: str = "utf-8") -> str:
    """The whole text of a checked input file (:func:`check_input_file`), a leading BOM removed.

    Raises
    ------
    InputFileError
        As :func:`check_input_file`, or the bytes are not ``encoding`` text
        (the message gives the byte offset).
    """
    path = check_input_file(path, what=what, max_bytes=max_bytes)
    try:
        with open(path, "rb") as stream:
            data = stream.read(max_bytes + 1)  # the file may have grown since stat()
    except OSError as exc:
        raise InputFileError(f"{what} {path}: cannot be read ({exc.strerror or exc})") from None
    if len(data) > max_bytes:
        raise InputFileError(f"{what} {path} is above the limit of {_size_text(max_bytes)} for a {what}")
    try:
        return data.decode(encoding).removeprefix("\ufeff")
    except UnicodeDecodeError as exc:
        raise InputFileError(f"{what} {path}: not {encoding} text (byte {exc.start}: {data[exc.start:exc.start + 1]!r})") from None


def file_digest(path: str | os.PathLike, *, what: str, max_bytes: int) -> bytes:
    """The SHA-256 digest of a checked input file's bytes (:func:`check_input_file`): what tells a memo of what
    was read from the file whether the file still holds the same (a rewrite within one clock tick keeps its
    modification time; its bytes tell).

    Raises
    ------
    InputFileError
        As :func:`check_input_file`, or the file cannot be read.
    """
    import hashlib

    path = check_input_file(path, what=what, max_bytes=max_bytes)
    try:
        with open(path, "rb") as stream:
            return hashlib.file_digest(stream, "sha256").digest()
    except OSError as exc:
        raise InputFileError(f"{what} {path}: cannot be read ({exc.strerror or exc})") from None
