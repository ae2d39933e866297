"""Where the spine's per-frame work, and the movie stages' chunks, run: in this process, a local process pool, or a
dask cluster.

Every executor has ``submit(fn, *args) -> future`` (with ``future.result()``)
and ``shutdown()``; :func:`executor` picks one.  The frames have theirs; each
movie stage that maps its chunks (:meth:`hexatissue.stages.MovieData.map_chunks`)
makes its own from the same ``client`` or ``workers``: a pool forks then, and
its workers are gone once the stage's chunks are done.
"""
from __future__ import annotations

import os

import numpy as np

from ._system import libc
from .errors import check_positive

__all__ = ["executor", "batch_size", "BATCH_PIXELS", "BATCH_FRAMES"]


class _Serial:
    """An executor running jobs in the calling process (workers=1)."""

    class _Done:
        def __init__(self, value):
            self._value = value

        def result(self):
            return self._value

    def submit(self, fn, *args):
        return self._Done(fn(*args))

    def shutdown(self, abort=False):
        pass


class _Dask:
    """Adapter submitting jobs to a dask.distributed client."""

    def __init__(self, client):
        self.client = client

    def submit(self, fn, *args):
        return self.client.submit(fn, *args, pure=False)

    def shutdown(self, abort=False):
        pass


def _die_with_parent():
    """Pool initializer: on Linux, ask the kernel to SIGKILL this worker when its parent dies.

    Without it a parent killed by SIGKILL (or the OOM killer) leaves its
    workers alive, holding memory and the parent's pipes.  ``prctl`` is
    Linux-only; elsewhere this does nothing (workers then notice the broken
    pipe at their next task).
    """
    import signal

    prctl = getattr(libc(), "prctl", None)
    if prctl is None:
        return
    prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    if os.getppid() == 1:  # the parent died before prctl took effect
        os._exit(1)


PR_SET_PDEATHSIG = 1  # from <linux/prctl.h>


class _Pool:
    """A local process pool whose workers die with the parent (:func:`_die_with_parent`).

    ``warm_ups``: functions that compile the numba kernels the workers run.

    Workers are forked where the OS allows it: they start at once and need no
    importable ``__main__`` (scripts piped to Python, notebooks).  The mesh
    kernels are serial numba code, so no numba thread pool is forked.
    Elsewhere (Windows) the platform's default start method is used.
    """

    def __init__(self, n_workers, warm_ups=()):
        import multiprocessing as mp
        from concurrent.futures import ProcessPoolExecutor

        method = "fork" if "fork" in mp.get_all_start_methods() else None
        if method == "fork":
            for compile_kernels in warm_ups:  # compile the kernels once here; forked workers inherit them
                compile_kernels()
        self.pool = ProcessPoolExecutor(max_workers=n_workers, mp_context=mp.get_context(method),
                                        initializer=_die_with_parent)

    def submit(self, fn, *args):
        return self.pool.submit(fn, *args)

    def shutdown(self, abort=False):
        """Stop the pool: wait for the running tasks, or (``abort``: an interrupted run) kill the workers now.

        A task can run for seconds (a batch of large frames); an interrupted
        run must not wait for it.  Python 3.14 has ``kill_workers``; before
        it, the executor's private state (CPython 3.8-3.13) is used: the
        pipe feeding the workers (``_call_queue``) may be blocked on a batch
        no worker will read, so the exit must not wait for its thread; the
        workers (``_processes``) are killed; and this process's own end of
        the results pipe (``_result_queue._writer``) is closed, so that the
        pool's thread, reading a result a killed worker left half-written,
        sees the pipe end instead of waiting forever (and the process exit
        with it).
        """
        if abort:
            kill = getattr(self.pool, "kill_workers", None)
            if kill is not None:
                kill()
                return
            queue = getattr(self.pool, "_call_queue", None)
            if queue is not None:
                queue.cancel_join_thread()
            processes = list((getattr(self.pool, "_processes", None) or {}).values())
            results = getattr(self.pool, "_result_queue", None)
            self.pool.shutdown(wait=False, cancel_futures=True)
            for process in processes:
                process.kill()
            writer = getattr(results, "_writer", None)
            if writer is not None:
                writer.close()
            return
        self.pool.shutdown(wait=True, cancel_futures=True)


def executor(client, workers, n_tasks, warm_ups=()):
    """``(executor, tasks kept in flight)`` for ``n_tasks`` tasks: twice the workers, so none waits while the main
    process collects.  ``warm_ups`` run here before a pool forks (:class:`_Pool`)."""
    if client is not None:
        threads = sum(client.nthreads().values()) if hasattr(client, "nthreads") else 1
        return _Dask(client), max(2, 2 * threads)
    workers = (os.cpu_count() or 1) if workers is None else check_positive(workers, "workers", integer=True)
    workers = min(workers, n_tasks)
    if workers == 1:
        return _Serial(), 1
    return _Pool(workers, warm_ups), 2 * workers


#: Frames per task: as many as hold about this many pixels (one task's IPC and bookkeeping for several
#: small frames), at most BATCH_FRAMES, and few enough that every task in flight has frames.
BATCH_PIXELS = 2**20
BATCH_FRAMES = 8


def batch_size(n_frames, shape, max_inflight):
    """Frames per task for ``n_frames`` frames of ``shape`` with ``max_inflight`` tasks in flight."""
    by_pixels = BATCH_PIXELS // max(int(np.prod(shape)), 1)
    return int(max(1, min(BATCH_FRAMES, by_pixels, n_frames // (2 * max_inflight))))
