"""Gzip-compressed files (``X.tif.gz``, ``X.npy.gz``, ...): decompressed once into a private temporary file.

Public data often ship compressed (the ForSys skeletons are ``.tif.gz``).
The readers read their files lazily, by path and frame by frame, so the
file is decompressed whole into a folder of this process (removed when it
exits) and read from there; the Source still names the ``.gz`` file.
"""
from __future__ import annotations

import atexit
import os
import shutil
import tempfile
import zlib
from pathlib import Path

from ..errors import InputError

__all__ = ["is_gzipped", "gunzip"]

_FOLDER = None
_DONE: dict = {}


def is_gzipped(path: Path) -> bool:
    """Whether ``path`` ends in ``.gz`` (any case)."""
    return Path(path).suffix.lower() == ".gz"


def _folder() -> Path:
    global _FOLDER
    if _FOLDER is None or not _FOLDER.is_dir():
        _FOLDER = Path(tempfile.mkdtemp(prefix="hexatissue-gunzip-"))
        atexit.register(shutil.rmtree, _FOLDER, True)
    return _FOLDER


def gunzip(path: Path) -> Path:
    """The decompressed copy of ``path`` (named like it without ``.gz``); made once per process and file version.

    Raises
    ------
    InputError
        ``path`` is not gzip data, is truncated, or would not fit on the
        temporary folder's disk (its size is read from the gzip trailer and
        checked before decompressing).
    """
    import gzip

    path = Path(path)
    stat = path.stat()
    key = (str(path.resolve()), stat.st_mtime_ns, stat.st_size)
    done = _DONE.get(key)
    if done is not None and done.is_file():
        return done
    with open(path, "rb") as fh:
        if fh.read(2) != b"\x1f\x8b":
            raise InputError(f"path {str(path)!r} ends in .gz but is not gzip data")
        fh.seek(-4, os.SEEK_END)
        size = int.from_bytes(fh.read(4), "little")  # the uncompressed size modulo 2**32 (a lower bound)
    folder = _folder()
    free = shutil.disk_usage(folder).free
    if size > free:
        raise InputError(f"path {str(path)!r} decompresses to at least {size / 1e9:.2f} GB; the temporary folder "
                         f"{str(folder)!r} has {free / 1e9:.2f} GB free: decompress it elsewhere (gunzip) and "
                         f"open that file")
    target = Path(tempfile.mkdtemp(dir=folder)) / path.name[: -len(path.suffix)]
    try:
        with gzip.open(path, "rb") as src, open(target, "wb") as dst:
            shutil.copyfileobj(src, dst, 1 << 20)
    except (OSError, EOFError, zlib.error) as exc:
        target.unlink(missing_ok=True)
        raise InputError(f"path {str(path)!r} could not be decompressed: {exc}; expected a complete gzip file") \
            from None
    _DONE[key] = target
    return target
