"""Ground-truth movies for synthetic benchmarks: a label stack whose ids are track ids, and its exact tables.

Label images are indexed ``[t, row, col]``; tables use x = column and y = row
in px, origin at the centre of pixel (0, 0).  A :class:`Truth` is built from
a source whose cell identity is exact over time, so no tracking step is
involved: an MPF run (each phase field is one cell for the whole run) or a
scripted Voronoi movie of :mod:`hexatissue.synthetic` (label ``k`` is seed
``k - 1`` in every frame).  The tables are :func:`hexatissue.analyze` of
these labels with ``TrackOptions(mode="never")`` (``track == cell``;
divisions and extrusions, where the source has them, are read from the ids).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from ..box import Box
from ..errors import InputError
from ..results import Movie
from ..units import Calibration

__all__ = ["Truth", "truth_from_labels", "truth_from_run", "truth_from_voronoi", "truth_from_t1", "truth_from_vertex_model",
           "crop_labels"]

#: Columns of the events table that define a T1 (quartet, timing, kind); x, y are quartet centres.
T1_KEY = ["kind", "frame_start", "frame_end", "duration", "cell_a", "cell_b", "cell_c", "cell_d", "frame_gain"]


@dataclass
class Truth:
    """A ground-truth movie: labels whose ids are track ids, and every table of them.

    Attributes
    ----------
    labels : (T, rows, cols) int32 array
        Cell ids (= track ids, consistent over time), 0 = no cell.
    movie : Movie
        The exact tables of ``labels`` (cells, vertices, edges,
        cell_vertices, lineage, events, ...), px and frames; its box is
        None for an open field of view.
    source : dict
        JSON description of how the truth was made (kind and parameters).
    """

    labels: np.ndarray
    movie: Movie
    source: dict

    @property
    def box(self) -> Box | None:
        """The periodic box, or None for an open field of view."""
        return self.movie.box

    @property
    def calibration(self) -> Calibration:
        return self.movie.calibration

    def __len__(self) -> int:
        return int(self.labels.shape[0])


def truth_from_labels(labels, *, box=None, source=None, calibration=None, min_length=0.0, censor=None,
                      workers=1, progress=True) -> Truth:
    """The truth of a label movie whose ids are already track ids.

    Parameters
    ----------
    labels : (T, rows, cols) integer array
        Ids consistent over time (0 = no cell).
    box : Box or None
        Periodic box, or None for an open image.
    source : dict, optional
        Description stored as :attr:`Truth.source` and in the Movie's ``source``.
    calibration : Calibration, optional
        Pixel size and frame interval of the movie.
    min_length, censor : float, int
        T1 detection options (:class:`hexatissue.EventOptions`).
    workers : int
        Processes for :func:`hexatissue.analyze` (1: this process).
    progress : bool
        Progress bar of the analysis.

    Returns
    -------
    Truth
    """
    from ..options import EventOptions, TrackOptions
    from ..pipeline import analyze

    labels = np.asarray(labels)
    if labels.ndim != 3 or labels.shape[0] < 1 or not np.issubdtype(labels.dtype, np.integer):
        raise InputError(f"labels must be a T x rows x cols integer array; got shape {labels.shape}, "
                         f"dtype {labels.dtype}")
    labels = labels.astype(np.int32, copy=False)
    movie = analyze(labels, box=box if box is not None else False, track=TrackOptions(mode="never"),
                    events=EventOptions(min_length=min_length, censor=censor), workers=workers, progress=progress)
    source = dict(source or {"kind": "labels"})
    movie = movie.replace(source=source, calibration=calibration or Calibration())
    return Truth(labels, movie, source)


def crop_labels(labels, crop):
    """A field of view ``crop = (row0, col0, rows, cols)`` cut from a periodic label movie (wrapping).

    Ids are kept, so they stay track ids; cells cut by the window's edge
    touch the image edge and become border cells, as in real data.
    Returns the cropped ``(T, rows, cols)`` array.
    """
    labels = np.asarray(labels)
    try:
        row0, col0, rows, cols = (int(v) for v in crop)
        ok = len(tuple(crop)) == 4 and rows >= 8 and cols >= 8 and row0 >= 0 and col0 >= 0
    except (TypeError, ValueError):
        ok = False
    if not ok or rows > labels.shape[1] or cols > labels.shape[2]:
        raise InputError(f"crop must be (row0, col0, rows, cols) with non-negative origin and 8 <= rows <= "
                         f"{labels.shape[1]}, 8 <= cols <= {labels.shape[2]} (the box); got {crop!r}")
    r = (row0 + np.arange(rows)) % labels.shape[1]
    c = (col0 + np.arange(cols)) % labels.shape[2]
    return np.ascontiguousarray(labels[:, r][:, :, c])


def _finish(labels, box, crop, source, **kwargs) -> Truth:
    """Crop (optional; the cropped view is open) and analyse."""
    if crop is not None:
        if box is None:
            raise InputError("crop needs a periodic source (a field of view cut from a torus); this source is open")
        labels, box = crop_labels(labels, crop), None
        source = dict(source, crop=[int(v) for v in crop])
    return truth_from_labels(labels, box=box, source=source, **kwargs)


def truth_from_run(run, *, frames=None, crop=None, min_length=0.0, censor=None, workers=1,
                   progress=True) -> Truth:
    """The truth of an MPF run (a ``.zarr`` store of :mod:`hexatissue.simulate`, or an opened run).

    Parameters
    ----------
    run : str, Path or MPFRun
        The run; its labels (phase fields segmented by the paper's rule)
        are the truth labels, their ids the cells' identities.
    frames : slice or sequence of int, optional
        Frames to use (default all).
    crop : (row0, col0, rows, cols), optional
        Open field of view cut from the periodic box (see :func:`crop_labels`).
    min_length, censor, workers, progress
        As in :func:`truth_from_labels`.

    Returns
    -------
    Truth
        Calibrated in simulation iterations (frame interval = ``save_every``).
    """
    from ..source import open_source

    src = open_source(run)
    if src.description.get("kind") != "mpf_run":
        raise InputError(f"run must be an MPF run store (hexatissue simulate --out RUN.zarr); got a "
                         f"{src.description.get('kind')} source")
    index = range(src.n_frames)[frames] if isinstance(frames, slice) or frames is None else frames
    index = list(range(src.n_frames)) if frames is None else list(index)
    labels = np.stack([src.frame(t) for t in index])
    source = {"kind": "mpf_run", "path": src.description.get("path"), "frames": [int(t) for t in index],
              "seed": src.description.get("seed"), "save_every": src.description.get("save_every")}
    return _finish(labels, src.box, crop, source, calibration=src.calibration, min_length=min_length,
                   censor=censor, workers=workers, progress=progress)


def truth_from_voronoi(n_cells=100, shape=(256, 256), n_frames=10, *, periodic=True, amplitude=0.3, seed=0,
                       crop=None, workers=1, progress=True) -> Truth:
    """The truth of a smoothly moving Voronoi movie (:func:`hexatissue.synthetic.voronoi_movie`).

    Label ``k`` is the Voronoi cell of seed ``k - 1`` in every frame; see
    :class:`hexatissue.synthetic.VoronoiMovie` for the motion.  ``crop`` as
    in :func:`truth_from_run`.  Returns a :class:`Truth`.
    """
    from ..synthetic import voronoi_movie

    vm = voronoi_movie(n_cells, shape, n_frames, periodic=periodic, amplitude=amplitude, seed=seed)
    labels = np.stack([vm[t] for t in range(len(vm))])
    source = {"kind": "voronoi", "n_cells": int(n_cells), "shape": [int(s) for s in shape],
              "n_frames": int(n_frames), "periodic": bool(periodic), "amplitude": float(amplitude),
              "seed": int(seed)}
    return _finish(labels, vm.box, crop, source, workers=workers, progress=progress)


def truth_from_t1(*, periodic=True, n_frames=36, seed=0, workers=1, progress=True) -> Truth:
    """The truth of the scripted T1 movie (:func:`hexatissue.synthetic.t1_movie`).

    The events table is the analysis of the rasterised labels with the
    script's ``min_length`` and ``censor``; it is checked against the events
    derived from the seeds (the exact Voronoi tessellation) and an
    AssertionError is raised if they differ in any of :data:`T1_KEY`.
    """
    from ..synthetic import t1_movie

    m = t1_movie(periodic=periodic, n_frames=n_frames, seed=seed)
    source = {"kind": "t1", "periodic": bool(periodic), "n_frames": int(n_frames), "seed": int(seed),
              "min_length": float(m.min_length), "censor": int(m.censor)}
    truth = truth_from_labels(m.labels, box=m.box, source=source, min_length=m.min_length, censor=m.censor,
                              workers=workers, progress=progress)
    got = truth.movie.events[T1_KEY].astype({"kind": object}).reset_index(drop=True)
    want = m.events[T1_KEY].astype({"kind": object}).reset_index(drop=True)
    try:
        pd.testing.assert_frame_equal(got, want, check_dtype=False)
    except AssertionError as exc:
        raise AssertionError(f"the analysed T1 events differ from the scripted ones: {exc}") from None
    return truth


def truth_from_vertex_model(*, n_cells=196, n_frames=60, v0=1.0, steps_per_frame=150, seed=0, workers=1, progress=True,
                            **model) -> Truth:
    """The truth of an active vertex-model movie whose T1 events are the model's own log.

    The cells, tracks and network are the analysis of the rasterised polygons
    (:func:`truth_from_labels`); the ``events`` table is not detected: it is
    :func:`~hexatissue.benchmark.vertex_model.vertex_model_events` of the
    model's T1 log (:func:`~hexatissue.benchmark.vertex_model.vertex_model_movie`,
    whose other parameters ``model`` passes on); ``truth.source`` holds the
    model's parameters and ``n_t1_flips``, the number of flips it made.
    Returns a :class:`Truth`.
    """
    from .vertex_model import vertex_model_events, vertex_model_movie

    m = vertex_model_movie(n_cells=n_cells, n_frames=n_frames, v0=v0, steps_per_frame=steps_per_frame, seed=seed,
                           **model)
    source = {"kind": "vertex_model", **m.params, "n_t1_flips": int(len(m.t1_log))}
    truth = truth_from_labels(m.labels, box=m.box, source=source, workers=workers, progress=progress)
    events = vertex_model_events(m.t1_log, n_frames)
    events["is_border"] = False
    return Truth(truth.labels, truth.movie.replace(events=events), source)
