"""Finished blocks of a long build saved as they finish, read back when the same build runs again (resuming).

(docs/site/internals/reach-maps.md.) A :class:`BlockStore` is a
folder that holds the results of one build's blocks, under the
**fingerprint** of that build (a SHA-256 of everything that determines its
results, canonical JSON): ``blocks.json`` (:data:`STORE_FORMAT`, the
fingerprint and the settings behind it, readable) and one ``.npz`` file per
finished block (numpy, read with ``allow_pickle=False``), named after the
block's function, its block number and a digest of its arguments
(``sample_block-3-<digest>.npz``). A block's result is a tuple of whole
numbers, arrays, ``None`` and tuples of these; the file also records the
fingerprint and the digest, so a file copied from another build is not taken.

Files are written to a temporary name in the folder and renamed (a killed
process leaves a whole file or none). On opening, a folder of another
fingerprint is emptied (its settings differ: :class:`BlockStoreWarning`
names the first one); a folder that holds anything else than a store's own
files, a file or a symbolic link is refused (:class:`OutputError`), never
emptied. Reading checks each file (it opens, its layout is a result's, the
fingerprint and digest are this block's, and the caller's ``checks`` for its
function: shapes, dtypes, keys within the grid); a file that fails is
computed again, never trusted.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import re
import shutil
import stat
import tempfile
import warnings
import zipfile
from collections.abc import Callable
from pathlib import Path

import numpy as np

from manipkit.errors import OutputError
from manipkit.outputs import cannot_write
from manipkit.text import printable

__all__ = ["STORE_FORMAT", "BlockStore", "BlockStoreWarning", "ResumeNote", "arguments_digest", "fingerprint_of",
           "open_store", "remove_store"]

STORE_FORMAT = "manipkit-blocks-1"
TABLE = "blocks.json"
MAX_TABLE_BYTES = 1 << 20
MAX_MEMBERS = 256  # arrays in one block's file (a result's layout, flattened)
_BLOCK_FILE = re.compile(r"[A-Za-z_][A-Za-z0-9_]*-\d+-[0-9a-f]{24}\.npz")
_TEMPORARY = re.compile(r"\.tmp-.*")


class BlockStoreWarning(UserWarning):
    """Saved blocks that were not used: a folder of another build emptied, or files that failed their checks."""


class ResumeNote(UserWarning):
    """Blocks read back instead of computed: ``resuming: N of M blocks of STAGE already done``."""


def fingerprint_of(settings: dict) -> str:
    """SHA-256 (hex) of ``settings`` as canonical JSON (sorted keys, no spaces): equal settings, equal fingerprint.

    >>> fingerprint_of({"b": 1, "a": [2.5]}) == fingerprint_of({"a": [2.5], "b": 1})
    True
    """
    text = json.dumps(settings, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode()).hexdigest()


def arguments_digest(arguments: tuple) -> str:
    """SHA-256 (hex) of a block's arguments: whole numbers, floats, strings, None, arrays (dtype, shape and bytes)
    and tuples of these (each tuple's length and items in order).

    >>> arguments_digest((1, (None, 2.5))) == arguments_digest((1, (None, 2.5))) != arguments_digest((1, None, 2.5))
    True
    """
    digest = hashlib.sha256()
    _digest_into(digest, arguments)
    return digest.hexdigest()


def _digest_into(digest, values: tuple) -> None:
    for value in values:
        if isinstance(value, np.ndarray):
            array = np.ascontiguousarray(value)
            digest.update(f"array {array.dtype.str} {array.shape}|".encode())
            digest.update(array.tobytes())
        elif value is None or isinstance(value, bool | int | float | str | np.integer | np.floating):
            digest.update(f"{type(value).__name__} {value!r}|".encode())
        elif isinstance(value, tuple):
            digest.update(f"tuple {len(value)}(".encode())
            _digest_into(digest, value)
            digest.update(b")|")
        else:
            raise TypeError(f"a block argument of type {type(value).__name__} has no digest")


def _pack(result, path: str, arrays: dict) -> None:
    """Flatten ``result`` into ``arrays``: ``path.int``, ``path.array``, ``path.none``, ``path.tuple`` (its length)."""
    if result is None:
        arrays[f"{path}.none"] = np.zeros(0)
    elif isinstance(result, tuple):
        arrays[f"{path}.tuple"] = np.array(len(result), dtype=np.int64)
        for i, value in enumerate(result):
            _pack(value, f"{path}.{i}", arrays)
    elif isinstance(result, int | np.integer) and not isinstance(result, bool):
        arrays[f"{path}.int"] = np.array(int(result), dtype=np.int64)
    elif isinstance(result, np.ndarray) and result.dtype != object:
        arrays[f"{path}.array"] = result
    else:
        raise TypeError(f"a block result holds a {type(result).__name__}; results are tuples of numbers and arrays")


def _unpack(arrays: dict, path: str = "r"):
    """The result :func:`_pack` flattened at ``path``; ValueError if the layout is not one it writes."""
    if f"{path}.none" in arrays:
        return None
    if f"{path}.int" in arrays:
        value = arrays[f"{path}.int"]
        if value.shape != () or value.dtype != np.int64:
            raise ValueError(f"{path} is not a whole number")
        return int(value)
    if f"{path}.array" in arrays:
        return arrays[f"{path}.array"]
    if f"{path}.tuple" in arrays:
        length = arrays[f"{path}.tuple"]
        if length.shape != () or length.dtype != np.int64 or not 0 <= int(length) <= 64:
            raise ValueError(f"{path} is not a tuple of at most 64 items")
        return tuple(_unpack(arrays, f"{path}.{i}") for i in range(int(length)))
    raise ValueError(f"{path} is missing")


def _check_members(path: Path) -> None:
    """ValueError unless every member of the ``.npz`` at ``path`` is stored uncompressed (as :func:`numpy.savez`
    writes) and its ``.npy`` header declares no more bytes than the member holds (no allocation beyond the file)."""
    with zipfile.ZipFile(path) as archive:
        members = archive.infolist()
        if len(members) > MAX_MEMBERS:
            raise ValueError(f"{len(members)} arrays, more than {MAX_MEMBERS}")
        for member in members:
            if member.compress_type != zipfile.ZIP_STORED or member.file_size > os.path.getsize(path):
                raise ValueError(f"{member.filename} is not stored as numpy.savez stores it")
            with archive.open(member) as stream:
                version = np.lib.format.read_magic(stream)
                if version not in ((1, 0), (2, 0)):
                    raise ValueError(f"{member.filename}: .npy version {version}")
                reader = np.lib.format.read_array_header_1_0 if version == (1, 0) else \
                    np.lib.format.read_array_header_2_0
                shape, _, dtype = reader(stream)
                if dtype.hasobject or int(np.prod(shape, dtype=object)) * dtype.itemsize > member.file_size:
                    raise ValueError(f"{member.filename} declares more data than it holds")


class BlockStore:
    """The saved blocks of one build (module docstring): :meth:`load` and :meth:`save` by function and arguments.

    ``checks`` maps a block function's name to ``check(result, arguments)``,
    which returns None for a result it accepts, else what is wrong (a short
    phrase). Open one with :func:`open_store`.
    """

    def __init__(self, folder: Path, fingerprint: str, checks: dict[str, Callable] | None = None):
        self.folder, self.fingerprint, self.checks = Path(folder), fingerprint, dict(checks or {})

    def path_of(self, fn, arguments: tuple) -> Path:
        """The file of block ``fn(job, *arguments)`` (its number is ``arguments[0]``)."""
        return self.folder / f"{fn.__name__}-{int(arguments[0])}-{arguments_digest(arguments)[:24]}.npz"

    def load(self, fn, arguments: tuple):
        """(result, None) of the saved block, (None, None) if it was not saved, (None, reason) if its file fails a check."""
        path = self.path_of(fn, arguments)
        if not os.path.lexists(path):
            return None, None
        try:
            if not stat.S_ISREG(os.lstat(path).st_mode):
                return None, "not a regular file"
            _check_members(path)
            with np.load(path, allow_pickle=False) as data:
                arrays = {name: data[name] for name in data.files}
            if str(arrays.pop("fingerprint", "")) != self.fingerprint or \
                    str(arrays.pop("arguments", "")) != arguments_digest(arguments):
                return None, "saved for another block or build"
            if not all(name == "r" or name.startswith("r.") for name in arrays):
                return None, "holds arrays a block result does not have"
            result = _unpack(arrays)
        except (OSError, ValueError, EOFError, KeyError, MemoryError, zipfile.BadZipFile, zipfile.LargeZipFile) as exc:
            return None, f"cannot be read ({printable(' '.join(str(exc).split()))[:60]})"
        check = self.checks.get(fn.__name__)
        reason = check(result, arguments) if check is not None else None
        return (None, reason) if reason else (result, None)

    def save(self, fn, arguments: tuple, result) -> None:
        """Write block ``fn(job, *arguments)``'s ``result`` (to a temporary name, then renamed into place)."""
        arrays = {"fingerprint": np.array(self.fingerprint), "arguments": np.array(arguments_digest(arguments))}
        _pack(result, "r", arrays)
        path = self.path_of(fn, arguments)
        try:
            handle, temporary = tempfile.mkstemp(prefix=".tmp-", dir=self.folder)
            try:
                with os.fdopen(handle, "wb") as stream:
                    np.savez(stream, **arrays)
                os.replace(temporary, path)
            except BaseException:
                with contextlib.suppress(OSError):
                    os.unlink(temporary)
                raise
        except OSError as exc:
            raise cannot_write(str(path), exc) from None

    def remove(self) -> None:
        """Remove the folder and everything in it (once the build's result is safe)."""
        remove_store(self.folder)


def _read_table(folder: Path) -> dict | None:
    """``blocks.json`` of ``folder`` if it is a store's (format, fingerprint and settings), else None."""
    path = folder / TABLE
    try:
        if not stat.S_ISREG(os.lstat(path).st_mode) or os.lstat(path).st_size > MAX_TABLE_BYTES:
            return None
        table = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError, RecursionError):  # RecursionError: a tampered table nested thousands deep
        return None
    if not isinstance(table, dict) or table.get("format") != STORE_FORMAT or \
            not isinstance(table.get("fingerprint"), str) or not isinstance(table.get("settings"), dict):
        return None
    return table


def _check_store_folder(folder: Path) -> None:
    """OutputError unless ``folder`` is a folder holding only a store's files (it is never emptied otherwise)."""
    shown = printable(str(folder))
    if folder.is_symlink() or not folder.is_dir():
        raise OutputError(f"cannot keep finished blocks in {shown}: it exists and is not a folder of saved blocks; "
                          "move it")
    for name in os.listdir(folder):
        mode = os.lstat(folder / name).st_mode
        ours = name == TABLE or _BLOCK_FILE.fullmatch(name) or _TEMPORARY.fullmatch(name)
        if not ours or not stat.S_ISREG(mode):
            raise OutputError(f"cannot keep finished blocks in {shown}: it holds {printable(name)}, which manipkit did "
                              "not save there; move it")
    if any(_BLOCK_FILE.fullmatch(name) for name in os.listdir(folder)) and _read_table(folder) is None:
        raise OutputError(f"cannot keep finished blocks in {shown}: its {TABLE} is missing or not manipkit's; move it")


def _first_difference(old: dict, new: dict) -> str:
    for key in sorted(set(old) | set(new)):
        if old.get(key) != new.get(key):
            return f"{key} was {printable(json.dumps(old.get(key)))[:60]}, now {printable(json.dumps(new.get(key)))[:60]}"
    return "the code that computes them changed"


def open_store(folder, settings: dict, checks: dict[str, Callable] | None = None) -> BlockStore:
    """The store in ``folder`` for a build with ``settings`` (JSON-ready), made if new (its parent must exist).

    Blocks saved in ``folder`` under other settings are removed, with one
    :class:`BlockStoreWarning` naming a setting that differs; leftover
    temporary files (a killed write) are removed.

    Raises
    ------
    OutputError
        ``folder`` is a file, a symbolic link or a folder holding anything a
        store does not hold, or it cannot be written.
    """
    folder = Path(folder)
    fingerprint = fingerprint_of(settings)
    shown = printable(str(folder))
    try:
        if os.path.lexists(folder):
            _check_store_folder(folder)
            table = _read_table(folder)
            if table is not None and table["fingerprint"] != fingerprint:
                warnings.warn(f"discarding the finished blocks in {shown}: they are of a build with other settings "
                              f"({_first_difference(table['settings'], settings)})", BlockStoreWarning, stacklevel=2)
                shutil.rmtree(folder)
        if not folder.exists():
            os.mkdir(folder)
        for name in os.listdir(folder):
            if _TEMPORARY.fullmatch(name):
                os.unlink(folder / name)
        if _read_table(folder) is None:
            text = json.dumps({"format": STORE_FORMAT, "fingerprint": fingerprint, "settings": settings}, indent=1)
            handle, temporary = tempfile.mkstemp(prefix=".tmp-", dir=folder)
            with os.fdopen(handle, "w", encoding="utf-8") as stream:
                stream.write(text + "\n")
            os.replace(temporary, folder / TABLE)
    except OSError as exc:
        raise cannot_write(shown, exc) from None
    return BlockStore(folder, fingerprint, checks)


def remove_store(folder) -> None:
    """Remove the store folder ``folder`` if it is one (a folder of a store's files only); nothing else is touched."""
    folder = Path(folder)
    if not os.path.lexists(folder):
        return
    try:
        _check_store_folder(folder)
    except OutputError:
        return
    shutil.rmtree(folder, ignore_errors=True)
