"""hexatissue._system: the C library and allocator calls (no-ops where the platform lacks them)."""
import sys

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


def test_release_freed_memory_trims_the_c_heap_and_arrows_pool(monkeypatch):
    """Both releases happen: glibc's ``malloc_trim(0)``, and Arrow's ``release_unused`` once pyarrow is loaded."""
    calls = []

    class Libc:
        def malloc_trim(self, pad):
            calls.append(("malloc_trim", pad))

    class Pool:
        def release_unused(self):
            calls.append(("release_unused",))

    class Arrow:
        def default_memory_pool(self):
            return Pool()

    monkeypatch.setattr(_system, "libc", Libc)
    monkeypatch.delitem(sys.modules, "pyarrow", raising=False)
    _system.release_freed_memory()
    assert calls == [("malloc_trim", 0)]  # no pyarrow loaded: nothing to release there (and no import of it)
    monkeypatch.setitem(sys.modules, "pyarrow", Arrow())
    _system.release_freed_memory()
    assert calls == [("malloc_trim", 0), ("malloc_trim", 0), ("release_unused",)]


def test_reserve_gives_writable_private_arrays_of_any_dtype():
    """``reserve``: n items of the dtype, writable, own memory (not shared with another array), freed with it."""
    for dtype in (np.int64, np.float32, bool, np.int8):
        a, b = _system.reserve(1000, dtype), _system.reserve(1000, dtype)
        assert a.shape == (1000,) and a.dtype == np.dtype(dtype) and a.flags.writeable
        a[:] = 1
        b[:] = 0
        assert a.all() and not b.any()
    assert _system.reserve(0, np.int64).shape == (0,)
    objects = _system.reserve(3, object)  # references cannot live in a raw map: a plain array
    objects[:] = ["a", None, 1]
    assert list(objects) == ["a", None, 1]


def test_reserved_buffer_is_not_shared_with_a_forked_child():
    """The map is private: a child's writes do not reach the parent (pool workers are forked)."""
    import multiprocessing as mp

    if "fork" not in mp.get_all_start_methods():
        return
    a = _system.reserve(10, np.int64)
    a[:] = 7
    child = mp.get_context("fork").Process(target=a.fill, args=(0,))
    child.start()
    child.join()
    assert child.exitcode == 0 and (a == 7).all()
