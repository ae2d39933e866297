"""hexatissue._system: the C library and allocator calls (no-ops where the platform lacks them)."""
import numpy as np

from hexatissue import _system


def test_release_freed_memory_runs_and_keeps_memory_usable():
    """Freed memory (C heap, Arrow's pool) is released; allocation still works after."""
    import pyarrow as pa

    big = np.ones(1_000_000)
    strings = pa.array(["a", "bc"] * 10_000)
    del big, strings
    _system.release_freed_memory()
    assert np.ones(1_000_000).sum() == 1_000_000
