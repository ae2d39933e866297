"""First run: compile the kernels of the stages after the mesh in a second process, beside the first.

On an empty numba cache, ``hexatissue analyze`` spends most of its time
compiling, one kernel after the other, and half of that is the mesh's.  The
CLI therefore starts ``python -m hexatissue._precompile`` beside the run: it
analyses a small moving Voronoi movie with every default stage, its mesh made by
the plain-numpy references (so that it does not compile the kernels the run
itself compiles first), and so compiles the order, defect, tracking, event and
flow kernels into numba's cache while the run compiles the mesh's; the run
then loads them from the cache.  Measured in benchmarks/README.md ("First
run").
"""
from __future__ import annotations

import os
import subprocess
import sys
import warnings

import numpy as np

__all__ = ["start"]


def start():
    """Start the second process when it can help (2 or more cores); return it (``Popen``) or None."""
    if (os.cpu_count() or 1) < 2:
        return None
    return subprocess.Popen([sys.executable, "-m", __name__], stdin=subprocess.DEVNULL,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


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
    _main()
