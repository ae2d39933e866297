"""The C library and the allocators, where the package needs them directly (Linux only; a no-op elsewhere)."""
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


M_MMAP_THRESHOLD = -3  # from glibc's <malloc.h>
#: Blocks from this size up get their own mapping, returned to the OS when freed (glibc's initial threshold).
MMAP_THRESHOLD = 128 * 1024


def return_freed_memory_early():
    """Make freed large blocks leave the process at once, for a run that holds large tables (``hexatissue analyze``).

    Process-wide, so only the command line calls it (a library user's
    process keeps its own settings).  glibc raises its mmap threshold to the
    largest block freed (up to 32 MB), after which such blocks come from the
    heap and their pages stay resident when freed between live ones; a fixed
    threshold (``mallopt(M_MMAP_THRESHOLD)``) keeps every block of 128 KiB
    and more in a mapping of its own, unmapped when freed.  Forked pool
    workers inherit it.  (Arrow's system pool instead of mimalloc was tried
    too: no gain in the CLI run, the Parquet writer's own buffers stay with
    mimalloc.)
    """
    mallopt = getattr(libc(), "mallopt", None)
    if mallopt is not None:
        mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD)
