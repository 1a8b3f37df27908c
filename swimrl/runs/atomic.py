"""Atomic file writes: the one helper behind every file the commands write.

:func:`atomic_write` writes the bytes (or lets a callable write them to a binary file) into a
temporary file next to the destination, ``.<name>.<pid>.tmp`` (:func:`temp_path`: one per
process, so two writers never write into each other's temporary file), flushes it to disk
(``fsync``) and renames it onto the destination (:func:`os.replace`): a reader, or a kill at
any moment (even ``kill -9``), finds the old file or the new one, never a part of one. A
temporary file is removed when the writing fails; one left by a killed process is never read.

The destination of a symbolic link is the file it points to (the link stays); a destination
that is not a regular file (``/dev/stdout``, a pipe) is written directly.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import BinaryIO


def temp_path(path: Path) -> Path:
    """``<dir>/.<name>.<pid>.tmp``: the temporary file of ``path`` written by this process."""
    path = Path(path)
    return path.with_name(f".{path.name}.{os.getpid()}.tmp")


def _fsync_dir(directory: Path) -> None:
    """Flush a directory's entries (the rename) to disk, where the system allows it."""
    try:
        fd = os.open(directory, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def atomic_write(path: Path, data: bytes | Callable[[BinaryIO], object], *,
                 make_dirs: bool = False) -> Path:
    """Write ``data`` (bytes, or a callable writing to the open binary file it is given) to
    ``path`` atomically: a temporary file in the same directory, ``fsync``, rename. With
    ``make_dirs`` the directory is made first. Returns ``path``."""
    path = Path(path)
    if make_dirs:
        path.parent.mkdir(parents=True, exist_ok=True)

    def write(fh: BinaryIO) -> None:
        if callable(data):
            data(fh)
        else:
            fh.write(data)

    if path.exists() and not path.is_file():  # a device or a pipe: nothing to rename onto
        with open(path, "wb") as fh:
            write(fh)
        return path
    target = path.resolve()
    tmp = temp_path(target)
    try:
        with open(tmp, "wb") as fh:
            write(fh)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, target)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    _fsync_dir(target.parent)
    return path


def atomic_write_text(path: Path, text: str, *, make_dirs: bool = False) -> Path:
    """:func:`atomic_write` of ``text`` encoded as UTF-8."""
    return atomic_write(path, text.encode("utf-8"), make_dirs=make_dirs)
