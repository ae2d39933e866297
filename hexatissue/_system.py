"""The C library, where the package needs it directly (Linux only; a no-op elsewhere)."""
from __future__ import annotations

import ctypes
import functools
import mmap
import sys

import numpy as np


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


def reserve(n, dtype):
    """An uninitialised array of ``n`` items of ``dtype`` in a memory map of its own, without huge pages.

    For a buffer reserved larger than it will be filled (the movie's
    tables, filled frame by frame): the kernel backs a page once it is
    written, so the unwritten tail costs address space, not memory.  A plain
    ``np.empty`` does not keep that promise on Linux: numpy asks for
    transparent huge pages on arrays of 4 MiB or more, and the kernel
    (khugepaged, with its default ``max_ptes_none``) then backs whole 2 MiB
    pages around the written part, or an array inside glibc's heap shares
    such pages with its neighbours; on the 200 x 2,500-cell movie of
    ``benchmarks/bench_memory.py`` that was up to 45 MB of the frame phase.
    The map is released when the last array viewing it is freed.
    """
    dtype = np.dtype(dtype)
    if dtype.hasobject:  # references cannot live in raw memory
        return np.empty(n, dtype)
    size = max(n * dtype.itemsize, 1)
    # private: a forked pool worker must not share it (mmap's default on Unix is a shared map)
    mem = mmap.mmap(-1, size, flags=mmap.MAP_PRIVATE | mmap.MAP_ANONYMOUS) if hasattr(mmap, "MAP_PRIVATE") \
        else mmap.mmap(-1, size)
    if hasattr(mmap, "MADV_NOHUGEPAGE"):  # Linux; the flag is a no-op where huge pages are off
        mem.madvise(mmap.MADV_NOHUGEPAGE)
    return np.frombuffer(mem, dtype, count=n)
