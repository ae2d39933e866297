"""A lazily rendered movie (the scale benchmark's input) analyses to the same tables as the eager array.

``benchmarks/bench_scale.py`` feeds ``analyze`` movies far larger than memory as array-likes that
render or read one frame per ``[t]``; these tests hold that this path reads frames one at a time
and changes no table, and that the synthetic movie's truth (label ``k`` = seed ``k - 1`` in every
frame) comes back as one track per seed.
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from hexatissue import analyze, open_source
from hexatissue.options import DeformationOptions
from hexatissue.synthetic import voronoi_movie

N_CELLS, SHAPE, N_FRAMES = 40, (90, 100), 8


class CountingMovie:
    """A lazy movie that records every index it is read with (and never holds more than the frame asked)."""

    def __init__(self, movie):
        self.movie, self.shape, self.dtype, self.ndim = movie, movie.shape, movie.dtype, 3
        self.reads = []

    def __getitem__(self, t):
        self.reads.append(t)
        return self.movie[t]


def _movie():
    return voronoi_movie(N_CELLS, SHAPE, N_FRAMES, periodic=False, amplitude=0.5, seed=2)


def test_lazy_movie_is_read_frame_by_frame():
    lazy = CountingMovie(_movie())
    src = open_source(lazy)
    assert (src.n_frames, src.shape) == (N_FRAMES, SHAPE)
    assert lazy.reads == []  # opening reads no frame
    np.testing.assert_array_equal(src.frame(3), _movie()[3])
    assert lazy.reads == [3]


def test_lazy_movie_gives_the_eager_tables_and_the_truth():
    deformation = DeformationOptions(enabled=True)
    lazy = CountingMovie(_movie())
    from_lazy = analyze(lazy, workers=1, progress=False, deformation=deformation)
    # every read is one integer frame, and no frame is read more than twice (the warm-up reads the first two)
    assert all(isinstance(t, (int, np.integer)) for t in lazy.reads)
    assert sorted(set(lazy.reads)) == list(range(N_FRAMES))
    assert max(lazy.reads.count(t) for t in range(N_FRAMES)) <= 2
    eager = np.stack([_movie()[t] for t in range(N_FRAMES)])
    from_eager = analyze(eager, workers=1, progress=False, deformation=deformation)
    assert set(from_lazy.tables) == set(from_eager.tables)
    for name, table in from_eager.tables.items():
        pd.testing.assert_frame_equal(from_lazy.tables[name], table, obj=name)
    assert len(from_lazy.tables["events"]) > 0  # the movie has neighbour exchanges: the event tables are compared
    cells = from_lazy.cells
    # truth: every seed is a cell of every frame, and each track is one seed (label) throughout
    assert (cells.groupby("frame")["cell"].apply(lambda c: sorted(c.tolist())) == [list(range(1, N_CELLS + 1))]
            * N_FRAMES).all()
    per_track = cells.groupby("track")["cell"].nunique()
    assert len(per_track) == N_CELLS and (per_track == 1).all()
