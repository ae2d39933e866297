"""Label frames in compact form and the overlaps of two frames (the contingency table of their cells)."""
from __future__ import annotations

from bisect import bisect_left, bisect_right
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
import pandas as pd

from ..errors import InputError
from ..mesh.labels import compact_labels, validate_labels
from . import _kernels
from .._dispatch import Kernels
from ._motion import centroids

K = Kernels(_kernels, "hexatissue.track._reference", names={"_dense_overlaps": "_dense_overlaps_reference",
                                                            "_sparse_overlaps": "_sparse_overlaps_reference"})

# Largest dense matrix made in one piece: two frames' overlap counts here, the IoU matrix handed to
# linear_sum_assignment in .linking (larger problems are split into connected components of the overlap graph).
_DENSE_LIMIT = 4_000_000


@dataclass
class _Compact:
    """A label image as compact indices 0..n-1 (-1 = background) plus ids and areas."""

    index: np.ndarray | None  # int32 per pixel, -1 for background; None once no overlap will be counted here
    ids: np.ndarray  # label id of each index
    area: np.ndarray  # pixels per index
    shape: tuple = ()
    # the overlaps with the previous frame, (previous, (i, j, n)), kept for the other tracker of a movie
    overlaps: tuple = field(default=(), repr=False)
    _stored: np.ndarray | None = field(default=None, repr=False)
    _centroid: np.ndarray | None = field(default=None, repr=False)

    def __getstate__(self):  # a pickled tracker (checkpoint) does not carry the previous frame
        return {**self.__dict__, "overlaps": ()}

    def without_pixels(self) -> "_Compact":
        """This frame without its pixel index (ids and areas only): enough once its overlaps are counted."""
        return _Compact(None, self.ids, self.area, self.shape, _stored=self._stored, _centroid=self._centroid)

    def centroids(self) -> np.ndarray:
        """Pixel centroid (x, y) of each cell, px (counted once, from the pixel index)."""
        if self._centroid is None:
            self._centroid = centroids(self.index, self.shape, len(self.ids))
        return self._centroid

    def stored_ids(self) -> np.ndarray:
        """``ids`` as the trackers keep them for every frame: one array (int32 when the ids fit) for both trackers."""
        if self._stored is None:
            self._stored = _narrow(self.ids)
        return self._stored


def _narrow(values: np.ndarray) -> np.ndarray:
    """``values`` as int32 when they fit (half the memory of what the trackers keep per cell-frame), else as given."""
    small = np.iinfo(np.int32)
    if len(values) and (values.min() < small.min or values.max() > small.max):
        return values
    return values.astype(np.int32)


def _frame_span(frames, span) -> slice:
    """The positions of a tracker's frame list ``frames`` (ascending) inside ``span`` = ``(first, last)``: all of
    them when ``span`` is None."""
    if span is None:
        return slice(0, len(frames))
    return slice(bisect_left(frames, span[0]), bisect_right(frames, span[1]))


def _stored_rows(frames, cells) -> tuple[np.ndarray, np.ndarray]:
    """``(frame, cell)`` int64 columns of the rows kept by a tracker: one frame number and one id array per frame."""
    if not frames:
        return np.empty(0, np.int64), np.empty(0, np.int64)
    frame = np.repeat(np.asarray(frames, np.int64), [len(c) for c in cells])
    return frame, np.concatenate(cells, dtype=np.int64)


def _compact(labels: np.ndarray) -> _Compact:
    if isinstance(labels, _Compact):  # already compacted for the other tracker of a MovieTracker
        return labels
    top = int(labels.max())
    if not _id_table_fits(top, labels.size):
        return _compact_reference(labels)
    index, ids, area = K._compact_index(labels.ravel(), top)
    return _Compact(index, ids, area, labels.shape)


def _id_table_fits(top, n_pixels):
    """Whether the compaction kernels may index a table over ids 0..``top`` (else the ids are too sparse)."""
    return top < 2**24 and top <= 4 * n_pixels


def _compact_reference(labels: np.ndarray) -> _Compact:
    """Reference of :func:`_compact` (and its path for sparse ids): compact labels, then a bincount."""
    compact, ids = compact_labels(labels)
    area = np.bincount(compact.ravel(), minlength=len(ids))
    return _Compact((compact.ravel() - 1).astype(np.int32), ids[1:].astype(np.int64), area[1:].astype(np.int64),
                    labels.shape)


def _index_overlaps(ia, ib, na, nb):
    """Sparse overlap counts ``(i, j, n)`` of two flat compact indices (dense count table when it is small)."""
    if (na + 1) * (nb + 1) <= _DENSE_LIMIT:
        return K._dense_overlaps(ia, ib, na, nb)
    return K._sparse_overlaps(ia, ib, na, nb)


def _contingency(a: _Compact, b: _Compact):
    """Sparse overlap counts ``(i, j, n)`` between the cells of two compact frames (computed once per pair)."""
    if b.overlaps and b.overlaps[0] is a:
        a.overlaps = ()
        return b.overlaps[1]
    out = _index_overlaps(a.index, b.index, len(a.ids), len(b.ids))
    a.overlaps = ()  # a's own link to its predecessor is no longer needed: the chain of frames is not kept
    b.overlaps = (a, out)
    return out


def _compact_after(previous: _Compact, labels: np.ndarray):
    """``(_compact(labels), its overlaps with previous)``, in one pass over the pixels when the kernels allow it."""
    top = int(labels.max())
    fused = (_id_table_fits(top, labels.size) and (len(previous.ids) + 1) * (top + 1) <= _DENSE_LIMIT
             and previous.index is not None and previous.index.size == labels.size)
    if not fused:
        cur = _compact(labels)
        return cur, _contingency(previous, cur)
    index, ids, area, i, j, n = K._compact_overlaps(labels.ravel(), top, previous.index, len(previous.ids))
    return _Compact(index, ids, area, labels.shape), (i, j, n)


def compact_frames(labels, pixels=False) -> list:
    """Consecutive frames as a :class:`MovieTracker` takes them, with their overlaps counted here.

    For the process that meshed the frames (:func:`hexatissue.analyze`'s
    workers), so that the tracker only links them.  The overlaps of the
    first frame with the one before it are left to the tracker, which holds
    that one.

    Parameters
    ----------
    labels : sequence of (rows, cols) int arrays
        Consecutive label images (checked by :func:`~hexatissue.mesh.labels.validate_labels`).
    pixels : bool
        Keep every frame's pixel index (:attr:`MovieTracker.needs_pixels`);
        otherwise only the first frame (the tracker counts its overlaps with
        the frame before) and the last one (the next batch's first frame
        overlaps it; a checkpoint after it keeps it) keep theirs.

    Returns
    -------
    list of (compact frame, overlaps)
        Arguments of :meth:`MovieTracker.add_valid`; ``overlaps`` is None for the first frame.
    """
    out = []
    for k, lab in enumerate(labels):
        if not out:
            out.append((_compact(lab), None))
            if pixels:
                out[0][0].centroids()
            continue
        previous = out[-1][0]
        cur, overlaps = _compact_after(previous, lab)
        cur.overlaps = ()  # sent apart from the frame: a pickled _Compact drops them
        if pixels:  # the tracker follows the flow from the cells' centroids: counted here, beside the mesh
            cur.centroids()
        if not pixels and k > 1:
            out[-1] = previous.without_pixels(), out[-1][1]
        out.append((cur, overlaps))
    return out


class Overlaps(NamedTuple):
    """The cells of two label images and their pixel overlaps (:func:`count_overlaps`).

    ``ids_prev`` / ``ids_next`` are the cell ids present (sorted, > 0),
    ``area_prev`` / ``area_next`` their areas (px); pair ``k`` is cell
    ``ids_prev[i[k]]`` overlapping cell ``ids_next[j[k]]`` by ``n[k]`` px,
    one entry per overlapping pair, sorted by ``(i, j)``.  All int64.
    """

    ids_prev: np.ndarray
    area_prev: np.ndarray
    ids_next: np.ndarray
    area_next: np.ndarray
    i: np.ndarray
    j: np.ndarray
    n: np.ndarray


def count_overlaps(prev, cur) -> Overlaps:
    """The cells of two label images of one shape, their areas and pixel overlaps, counted by the tracker's kernels.

    For callers whose labels are valid by construction (the output of
    :func:`~hexatissue.mesh.labels.mesh_labels`, of
    :func:`~hexatissue.mesh.labels.validate_labels`): they are not checked
    again here (an all-background frame is fine: no cells);
    :func:`frame_overlaps` checks them.

    Parameters
    ----------
    prev, cur : (rows, cols) non-negative int arrays
        Label images indexed ``[row, col]``, of the same shape; 0 =
        background (ignored).

    Returns
    -------
    Overlaps
        ``ids_prev``, ``area_prev``, ``ids_next``, ``area_next``, ``i``,
        ``j``, ``n``.
    """
    if prev.shape != cur.shape:
        raise InputError(f"prev and cur must have the same shape; got {prev.shape} and {cur.shape}")
    a, b = _compact(prev), _compact(cur)
    i, j, n = _contingency(a, b)
    return Overlaps(a.ids.astype(np.int64, copy=False), a.area.astype(np.int64, copy=False),
                    b.ids.astype(np.int64, copy=False), b.area.astype(np.int64, copy=False), i, j, n)


def frame_overlaps(prev, cur) -> pd.DataFrame:
    """Pixel overlaps between the cells of two label images of the same shape.

    Parameters
    ----------
    prev, cur : (rows, cols) int arrays
        Label images indexed ``[row, col]``; 0 = background (ignored).

    Returns
    -------
    pandas.DataFrame
        One row per overlapping pair: ``cell_prev``, ``cell_next`` (label ids),
        ``overlap`` (px), ``area_prev``, ``area_next`` (px), ``iou``
        (overlap / union, dimensionless).
    """
    prev, cur = validate_labels(prev, "prev"), validate_labels(cur, "cur")
    ov = count_overlaps(prev, cur)
    i, j, n = ov.i, ov.j, ov.n
    union = ov.area_prev[i] + ov.area_next[j] - n
    return pd.DataFrame(
        {"cell_prev": ov.ids_prev[i], "cell_next": ov.ids_next[j], "overlap": n, "area_prev": ov.area_prev[i],
         "area_next": ov.area_next[j], "iou": n / union}
    )
