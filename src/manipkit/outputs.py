"""Writing files a user asks for: one place that turns an OSError into one line.

Every file manipkit writes (tree pictures and DOT, DH tables, URDF, plots,
static viewer pages) goes through :func:`writable_path` or
:func:`write_text`: a folder the user did not ask for is never created, and
a missing folder, a path that is a folder, no permission or a full disk
give :class:`~manipkit.errors.OutputError` ``cannot write PATH: reason``
(docs/architecture.md, "Errors and messages").
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator
from pathlib import Path

from manipkit.errors import OutputError

__all__ = ["cannot_write", "writable_path", "write_text", "writing"]


def cannot_write(path: str | os.PathLike, exc: OSError) -> OutputError:
    """``OutputError("cannot write PATH: reason")`` for an OSError met while writing ``path``."""
    reason = exc.strerror or str(exc)
    return OutputError(f"cannot write {path}: {reason}")


def writable_path(path: str | os.PathLike) -> Path:
    """``path`` if a file can be written there: its folder exists and it is not itself a folder.

    Checked before expensive work (a plot, a tree image), so the user hears
    about a typo at once. Nothing is created.

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
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    if path.is_dir():
        raise OutputError(f"cannot write {path}: it is a folder; give a file name")
    if not folder.is_dir():
        raise OutputError(f"cannot write {path}: no such folder {folder}")
    return path


@contextlib.contextmanager
def writing(path: str | os.PathLike) -> Iterator[Path]:
    """Context for code that writes ``path`` itself (matplotlib's ``savefig``): OSError -> OutputError.

    >>> import tempfile
    >>> with writing(Path(tempfile.mkdtemp()) / "x.txt") as target:
    ...     _ = target.write_text("ok")
    """
    path = writable_path(path)
    try:
        yield path
    except OSError as exc:
        raise cannot_write(path, exc) from None


def write_text(path: str | os.PathLike, text: str, *, encoding: str = "utf-8") -> Path:
    """Write ``text`` to ``path`` (see :func:`writable_path`); OSError (full disk, permission) -> OutputError."""
    with writing(path) as target:
        target.write_text(text, encoding=encoding)
    return target
