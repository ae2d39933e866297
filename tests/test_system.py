"""hexatissue._system: the C library and allocator calls (no-ops where the platform lacks them)."""
import numpy as np

from hexatissue import _system


def test_allocator_calls_run_and_keep_memory_usable():
    """The command line's allocator setting and the release of freed memory run; allocation still works after."""
    _system.return_freed_memory_early()
    big = np.ones(1_000_000)  # above the fixed mmap threshold: a mapping of its own
    small = np.ones(100)
    del big
    _system.release_freed_memory()
    assert small.sum() == 100
    assert np.ones(1_000_000).sum() == 1_000_000
