"""The C library, where the package needs it directly (Linux only; a no-op elsewhere)."""
from __future__ import annotations

import ctypes
import functools
import sys


@functools.cache
def libc():
    """The process's C library on Linux (glibc or musl), else None."""
    if not sys.platform.startswith("linux"):
        return None
    try:
        return ctypes.CDLL(None)
    except OSError:
        return None


def release_freed_memory():
    """Return freed memory to the OS: glibc's ``malloc_trim`` (a no-op elsewhere, musl included) and Arrow's pools.

    glibc keeps memory freed in the middle of its heap resident: without
    this, the temporaries of a thousand frames' jobs (tens of MB of holes
    between the growing tables) stay in the process under the movie-level
    stages and the writing of the tables.  Arrow's pools (``release_unused``)
    likewise keep what pandas' string columns and the Parquet writer freed.
    """
    trim = getattr(libc(), "malloc_trim", None)
    if trim is not None:
        trim(0)
    arrow = sys.modules.get("pyarrow")  # pandas' string columns and the Parquet writer allocate from Arrow's pool
    if arrow is not None:
        arrow.default_memory_pool().release_unused()
