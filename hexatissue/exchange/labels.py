"""The label images of a results folder again, with their ids replaced by track ids.

A results folder holds tables, not images; :func:`track_masks` re-opens the
labels it was computed from (the path in ``metadata.json``, or one given),
applies the analysis's own label normalisation
(:func:`hexatissue.mesh.labels.mesh_labels` with the recorded mesh options and
mask), checks that every cell of the ``cells`` table is there with its pixel
area, and maps ``(frame, cell)`` to ``track``.
"""
from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..mesh.labels import detect_kind, mesh_labels, relabel
from ..views import columns

__all__ = ["track_masks"]


def _labels_source(movie, labels):
    from ..source import MISSING, open_source, recorded_labels

    if labels is not None:
        return open_source(labels), "labels"
    desc = movie.source or {}
    source, why = recorded_labels(desc)
    if why == MISSING:
        raise InputError(f"the labels recorded in the results, {desc['path']!r}, do not exist (moved, and not at their "
                         f"path relative to the results folder either); pass them with --labels FILE (labels= in "
                         f"Python)")
    if source is None:
        raise InputError(f"the results were computed from {desc.get('kind', 'an unknown input')!r} data that were "
                         f"not a file, so their labels cannot be re-opened; pass the label image or stack the "
                         f"results were computed from (--labels FILE on the command line, labels= in Python)")
    return source, f"the recorded labels {desc['path']!r}"


def _mask(movie, mask):
    from ..source import read_mask, recorded_mask

    if mask is not None:
        return read_mask(mask, tuple(movie.shape))[0]
    inside, info = recorded_mask(movie.source, tuple(movie.shape))
    if info is not None and inside is None:
        raise InputError("the results were computed with a mask given as an array; pass the same mask "
                         "(--mask FILE on the command line, mask= in Python)")
    return inside


def track_masks(movie, labels=None, mask=None, membranes=False) -> list[np.ndarray]:
    """The frames of a Movie's labels with track ids: the masks of a CTC export or a tracked label stack.

    Parameters
    ----------
    movie : Movie
        An analysis (:func:`hexatissue.read_results`).
    labels : path, array or Source, optional
        The label image or stack it was computed from (default: the path in
        ``movie.source``).
    mask : path or array, optional
        The region-of-interest mask of the analysis (default: the path in
        ``movie.source["mask"]``, when there was one).
    membranes : bool
        Keep the input's membranes (or skeleton lines) at 0 instead of
        sharing them out: the labels as given, with track ids.  Analysing
        these again gives the same network as the results (the EpiCure
        sample: every side count and area), which the touching labels do not
        quite (docs/exchange.md); the cells' pixel counts are then those of
        the input, without their share of the membranes.

    Returns
    -------
    list of (rows, cols) int64 arrays
        One per frame, indexed ``[row, col]``: the labels as the mesh used
        them (membranes shared out, background and outside 0; with
        ``membranes``, the membrane pixels 0 too), each cell's pixels set to
        its ``track``; 0 elsewhere.

    Raises
    ------
    InputError
        No usable labels (not a file, moved: pass ``labels``), labels with
        another number of frames or shape, or labels whose cells differ
        from the ``cells`` table (other ids or pixel areas: not the labels
        of these results, or other mesh options).
    """
    from ..options import MeshOptions
    from ..progress import progress

    source, what = _labels_source(movie, labels)
    if source.n_frames != movie.n_frames or tuple(source.shape) != tuple(movie.shape):
        raise InputError(f"{what} hold {source.n_frames} frame(s) of {source.shape}; the results have "
                         f"{movie.n_frames} of {tuple(movie.shape)}: pass the labels they were computed from")
    inside = _mask(movie, mask)
    mesh = movie.options.get("mesh", MeshOptions())
    cells = columns(movie, "cells", ["frame", "cell", "track", "area"]).sort_values(["frame", "cell"], kind="stable")
    frame_of = cells["frame"].to_numpy(np.int64)
    bounds = np.searchsorted(frame_of, np.arange(movie.n_frames + 1))
    ids, tracks = cells["cell"].to_numpy(np.int64), cells["track"].to_numpy(np.int64)
    area = cells["area"].to_numpy(float)
    out = []
    for t in progress(range(movie.n_frames), desc="labels", unit="frame"):
        raw = source.checked_frame(t, mesh.kind)[0]
        lab, membrane = mesh_labels(raw, movie.box, mesh, inside)
        lo, hi = bounds[t], bounds[t + 1]
        found, counts = np.unique(lab, return_counts=True)
        pos = np.searchsorted(found, ids[lo:hi])
        ok = (pos < len(found)) & (found[np.minimum(pos, len(found) - 1)] == ids[lo:hi])
        if not ok.all() or not np.array_equal(counts[pos[ok]].astype(float), area[lo:hi]):
            raise InputError(f"{what}, frame {t}: the cells differ from the results' cells table (other ids or "
                             f"pixel areas); pass the labels the results were computed from (--labels FILE)")
        tracked = relabel(lab, ids[lo:hi], tracks[lo:hi], others=0)
        if membranes:  # the input's 0 pixels (membranes, and holes the mesh filled); a skeleton's lines
            kind = mesh.kind if mesh.kind != "auto" else detect_kind(raw, movie.box is not None)
            tracked = np.where(membrane if kind == "skeleton" else membrane | (raw == 0), 0, tracked)
        out.append(tracked)
    return out
