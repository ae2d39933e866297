"""First run: compile the kernels of the stages after the mesh in a second process, beside the first.

On an empty numba cache, ``hexatissue analyze`` spends most of its time
compiling, one kernel after the other, and half of that is the mesh's.  The
CLI therefore starts ``python -m hexatissue._precompile`` beside the run: it
analyses a small moving Voronoi movie with every default stage, its mesh made by
the plain-numpy references (so that it does not compile the kernels the run
itself compiles first), and so compiles the order, defect, tracking, event and
flow kernels into numba's cache while the run compiles the mesh's; the run
then loads them from the cache.  Measured in benchmarks/results_precompile.md.
"""
from __future__ import annotations

import os
import subprocess
import sys
import warnings

import numpy as np

__all__ = ["start"]


def start():
    """Start the second process when it can help (2 or more cores); return it (``Popen``) or None.

    It is given this process's id and dies with it (:func:`_die_with`): a
    run killed outright (SIGKILL, the OOM killer) leaves no compiler behind.
    """
    if (os.cpu_count() or 1) < 2:
        return None
    return subprocess.Popen([sys.executable, "-m", __name__, str(os.getpid())], stdin=subprocess.DEVNULL,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def _die_with(parent):
    """Ask the kernel (Linux) to SIGKILL this process when ``parent`` dies; exit now if it already has."""
    import signal

    from ._executors import PR_SET_PDEATHSIG
    from ._system import libc

    prctl = getattr(libc(), "prctl", None)
    if prctl is not None:
        prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    if os.getppid() != parent:  # the run ended (or was killed) before the request took effect
        os._exit(0)


class _References:
    """The mesh kernels' module with every kernel that has a plain-numpy reference replaced by it."""

    def __init__(self, kernels, references):
        self._kernels, self._references = kernels, references

    def __getattr__(self, name):
        return getattr(self._references, name, None) or getattr(self._kernels, name)


def _main():
    from .errors import HexatissueWarning
    from .mesh import _kernels, _reference, network
    from .pipeline import analyze
    from .synthetic import voronoi_movie

    network.K = _References(_kernels, _reference)
    movie = voronoi_movie(40, (96, 128), 6, periodic=False, amplitude=2.0, seed=1)
    labels = np.stack([np.asarray(movie[t]) for t in range(len(movie))])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HexatissueWarning)
        analyze(labels, workers=1, progress=False)


if __name__ == "__main__":
    if len(sys.argv) > 1:
        _die_with(int(sys.argv[1]))
    _main()
