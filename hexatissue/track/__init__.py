"""Link cells across the frames of a label movie by overlap.

Cells in consecutive frames are linked by their intersection over union
(IoU) with an optimal one-to-one assignment
(:func:`scipy.optimize.linear_sum_assignment`).  The overlaps come from a
sparse contingency table of the two label images (one ``bincount`` over the
pixels, no per-cell loops).  Divisions (one cell -> two) are detected before
the assignment; cells that are not linked start or end a track, classified as
border crossings or interior appearances/disappearances.

The tracker is incremental (:class:`Tracker`): it keeps one frame in memory,
so movies of any length are tracked frame by frame.

Conventions: label images are indexed ``[row, col]``, 0 = background or
membrane; track ids are positive integers.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
import pandas as pd
from scipy.optimize import linear_sum_assignment
from scipy.spatial import cKDTree

from .._components import components
from ..errors import InputError, is_real
from ..geometry import distinct_count, in_sorted, row_keys
from ..mesh.labels import compact_labels, touches_outside, validate_labels
from ..options import FOLLOW_MODES, TRACK_MODES
from ..progress import progress as progress_bar
from ..schema import deprecated_column_lists, validate
from ._kernels import _compact_index, _compact_overlaps, _dense_overlaps, _division_kernel, _sparse_overlaps
from ._motion import Field, centroids, fit_field, outline_piv, warp

__all__ = ["Tracker", "FOLLOW_MODES", "IdTracker", "SeparateTracker", "MovieTracker", "TRACK_MODES", "ID_CONSISTENCY",
           "track_labels", "compact_frames", "Overlaps", "count_overlaps", "frame_overlaps", "match_frames",
           "lineage_roots", "check_divisions", "check_extrusions", "EXTRUSION_SHRINK", "division_rows",
           "DIVISION_REASONS", "tracking_qc", "tracking_warning", "EXTRUSION_SHARE", "MIN_EXTRUSIONS", "FAR_APART",
           "CONFIDENT_IOU"]

#: A link is confident at this IoU after warping (it then feeds the fit of the motion field).
CONFIDENT_IOU = 0.5
#: Below this share of confident links, the motion is measured from the outlines (PIV).
CONFIDENT_SHARE = 0.9
#: A refitted field that moves no node by more than this (px) is not used for another linking pass.
REFIT_PX = 1.0

# Largest dense IoU matrix handed to linear_sum_assignment in one piece
# (larger problems are split into connected components of the overlap graph).
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
    index, ids, area = _compact_index(labels.ravel(), top)
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
        return _dense_overlaps(ia, ib, na, nb)
    return _sparse_overlaps(ia, ib, na, nb)


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
    index, ids, area, i, j, n = _compact_overlaps(labels.ravel(), top, previous.index, len(previous.ids))
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


def _divisions(i, j, n, area_a, area_b, child_fraction, mother_fraction, min_iou):
    """Mother index -> two daughter indices, from overlaps.

    A daughter candidate of mother ``i`` is a cell ``j`` lying mostly inside
    ``i`` (``n_ij >= child_fraction * area_j``) and holding a sizeable part of
    it (``n_ij >= mother_fraction * area_i``), and that is not the best
    successor (highest IoU, at least ``min_iou / 2``) of another cell: a
    neighbour that took over part of ``i`` is not its daughter.  A mother with
    two or more candidates divided; its two largest overlaps are the daughters
    (ties: the earlier pair of ``i, j, n``).

    Returns
    -------
    mothers : (m,) int64 array
        Indices into ``area_a``, ascending.
    daughters : (m, 2) int64 array
        Indices into ``area_b``, the larger overlap first.
    """
    i, j, n = (np.ascontiguousarray(x, np.int64) for x in (i, j, n))
    mothers, first, second = _division_kernel(i, j, n, np.asarray(area_a, np.int64), np.asarray(area_b, np.int64),
                                              float(child_fraction), float(mother_fraction), float(min_iou))
    return mothers, np.stack((first, second), axis=1)


def _assign(i, j, iou):
    """Links maximising the summed IoU over the candidate pairs ``(i, j, iou)``; returns (i, j, iou) linked.

    Candidates that are the only option of both their row and their column
    are linked directly; the rest is solved with linear_sum_assignment, per
    connected component when it is large.
    """
    empty = (np.empty(0, np.int64), np.empty(0, np.int64), np.empty(0))
    if len(i) == 0:
        return empty
    row_deg = np.bincount(i)[i]
    col_deg = np.bincount(j)[j]
    alone = (row_deg == 1) & (col_deg == 1)
    out = [(i[alone], j[alone], iou[alone])]
    i, j, iou = i[~alone], j[~alone], iou[~alone]
    if len(i):
        rows, ri = np.unique(i, return_inverse=True)
        cols, cj = np.unique(j, return_inverse=True)
        if len(rows) * len(cols) <= _DENSE_LIMIT:
            groups = [np.arange(len(i))]
        else:  # large problem: the candidate graph splits into independent components
            comp = components(len(rows) + len(cols), ri, len(rows) + cj)[ri]
            order = np.argsort(comp, kind="stable")
            groups = np.split(order, np.flatnonzero(np.diff(comp[order])) + 1)
        for sel in groups:
            sr, sri = np.unique(ri[sel], return_inverse=True)
            sc, sci = np.unique(cj[sel], return_inverse=True)
            dense = np.zeros((len(sr), len(sc)))
            dense[sri, sci] = iou[sel]
            r, c = linear_sum_assignment(dense, maximize=True)
            value = dense[r, c]
            keep = value > 0
            out.append((rows[sr[r[keep]]], cols[sc[c[keep]]], value[keep]))
    return tuple(np.concatenate(parts) for parts in zip(*out))


def _link(i, j, n, area_a, area_b, min_iou, child_fraction, mother_fraction):
    """Divisions, then one-to-one links maximising the summed IoU, from overlaps ``(i, j, n)``.

    Returns ``(r, c, iou of each link, mothers, daughters)``.
    """
    mothers, daughters = _divisions(i, j, n, area_a, area_b, child_fraction, mother_fraction, min_iou)
    if len(mothers):  # mothers and daughters leave the one-to-one assignment
        free = ~(np.isin(i, mothers) | np.isin(j, daughters.ravel()))
        i, j, n = i[free], j[free], n[free]
    iou = n / (area_a[i] + area_b[j] - n)
    cand = iou >= min_iou
    r, c, value = _assign(i[cand], j[cand], iou[cand])
    return r, c, value, mothers, daughters


def _match(a: _Compact, b: _Compact, min_iou, child_fraction, mother_fraction):
    i, j, n = _contingency(a, b)
    r, c, _, mothers, daughters = _link(i, j, n, a.area, b.area, min_iou, child_fraction, mother_fraction)
    return r, c, mothers, daughters


def match_frames(prev, cur, min_iou=0.2, child_fraction=0.6, mother_fraction=0.2):
    """Links between the cells of two consecutive label images.

    Parameters
    ----------
    prev, cur : (rows, cols) int arrays
        Label images indexed ``[row, col]``; 0 = background.
    min_iou : float
        Smallest IoU of a candidate link; among the candidates the links
        maximise the summed IoU (one-to-one).
    child_fraction, mother_fraction : float
        Division rule: a cell of ``cur`` is a daughter of a cell of ``prev``
        when at least ``child_fraction`` of the daughter and at least
        ``mother_fraction`` of the mother overlap; a cell with two or more
        daughters divided (its two largest overlaps are kept).

    Returns
    -------
    links : pandas.DataFrame
        ``cell_prev``, ``cell_next`` (label ids) of the one-to-one links.
    divisions : pandas.DataFrame
        ``mother`` (id in ``prev``), ``daughter_a``, ``daughter_b`` (ids in ``cur``).
    """
    a, b = _compact(validate_labels(prev, "prev")), _compact(validate_labels(cur, "cur"))
    if a.index.shape != b.index.shape:
        raise InputError(f"prev and cur must have the same shape; got {np.shape(prev)} and {np.shape(cur)}")
    r, c, mothers, daughters = _match(a, b, min_iou, child_fraction, mother_fraction)
    links = pd.DataFrame({"cell_prev": a.ids[r], "cell_next": b.ids[c]})
    divisions = pd.DataFrame(
        {"mother": a.ids[mothers], "daughter_a": b.ids[daughters[:, 0]], "daughter_b": b.ids[daughters[:, 1]]}
    )
    return links, divisions


def _check_fractions(min_iou, child_fraction, mother_fraction):
    for name, value in (("min_iou", min_iou), ("child_fraction", child_fraction),
                        ("mother_fraction", mother_fraction)):
        if not 0 < value <= 1:
            raise InputError(f"{name} must be in (0, 1]; got {value!r}")


class _Feed:
    """What the trackers share: frames added one at a time, all of one shape (``_n``, ``_shape``)."""

    def add(self, labels, frame=None) -> np.ndarray:
        """Track one more frame; returns the track id of each cell of ``labels`` (sorted by label id).

        ``frame`` defaults to the number of frames added so far.
        """
        return self.add_valid(validate_labels(labels), frame)

    def _next_frame(self, labels, frame):
        """``(frame index, compact labels)`` of the frame being added; checks its shape."""
        frame = self._n if frame is None else int(frame)
        cur = _compact(labels)
        if self._shape is not None and cur.shape != self._shape:
            raise InputError(f"labels of frame {frame} have shape {cur.shape}; earlier frames had {self._shape}")
        self._shape = cur.shape
        return frame, cur


class Tracker(_Feed):
    """Incremental overlap tracker: feed label images in time order with :meth:`add`.

    Track ids reproduce the labels when they are already consistent: a cell
    starting a track takes its own label as track id unless that id was used
    before, else the next unused id above every id used so far.

    Parameters
    ----------
    min_iou, child_fraction, mother_fraction : float
        See :func:`match_frames`.
    max_gap : int
        Gap closing: a track whose cell is missing for up to ``max_gap``
        frames (a segmentation gap) is continued by a new cell overlapping its
        last mask with IoU >= ``min_iou``.  0 disables gap closing.  The masks
        of ended tracks are kept for ``max_gap`` frames only.
    follow : {"flow", "none"}
        ``"flow"`` (default): follow the tissue's motion.  The previous
        frame's cells are carried along a displacement field before their
        overlaps are counted: the field of the frame pair before, refitted
        from the cells linked with IoU >= :data:`CONFIDENT_IOU` (gridded
        median of their centroid displacements) while it moves a node by
        more than :data:`REFIT_PX`; when fewer than :data:`CONFIDENT_SHARE`
        of the links are confident, the field is measured by
        cross-correlating the two frames' cell outlines (PIV) instead.  Cells
        left unlinked on both sides are then paired by the distance between
        the earlier cell's carried centroid and the later one's, up to half
        the earlier cell's diameter (``sqrt(area)``).  ``"none"``: overlaps
        of the frames as they are (cells moving half a diameter or more per
        frame are lost).
    periodic : bool
        The frames are a periodic box: the warp wraps around the image.
    """

    def __init__(self, min_iou=0.2, child_fraction=0.6, mother_fraction=0.2, max_gap=0, follow="flow",
                 periodic=False):
        _check_fractions(min_iou, child_fraction, mother_fraction)
        if int(max_gap) != max_gap or max_gap < 0:
            raise InputError(f"max_gap must be a non-negative integer number of frames; got {max_gap!r}")
        if follow not in FOLLOW_MODES:
            raise InputError(f"follow must be one of {FOLLOW_MODES}; got {follow!r}")
        self.min_iou, self.child_fraction, self.mother_fraction = min_iou, child_fraction, mother_fraction
        self.max_gap = int(max_gap)
        self.follow, self.periodic = follow, bool(periodic)
        self._field: Field | None = None
        self._links: list[tuple] = []  # per frame pair: see link_qc
        self._prev: _Compact | None = None
        self._prev_tracks = None
        self._prev_frame = None
        self._shape = None
        self._used: set[int] = set()
        self._max_used = 0
        self._frames, self._cells, self._tracks = [], [], []
        self._parent: dict[int, int] = {}
        # ended tracks that gap closing may continue: (track, last frame, flat pixel indices)
        self._dormant: list[tuple[int, int, np.ndarray]] = []
        self._n = 0

    def _new_ids(self, labels: np.ndarray) -> np.ndarray:
        out = np.empty(len(labels), np.int64)
        for k, lab in enumerate(labels.tolist()):
            tid = lab if lab not in self._used else self._max_used + 1
            self._used.add(tid)
            self._max_used = max(self._max_used, tid)
            out[k] = tid
        return out

    def _close_gaps(self, cur: _Compact, frame: int, tracks: np.ndarray, new: np.ndarray):
        """Link cells of ``cur`` that start no track yet to dormant tracks (gap closing)."""
        self._dormant = [d for d in self._dormant if frame - d[1] - 1 <= self.max_gap]
        if not self._dormant or not new.any():
            return
        owner = np.concatenate([np.full(len(p), k) for k, (_, _, p) in enumerate(self._dormant)])
        hit = cur.index[np.concatenate([p for _, _, p in self._dormant])]
        ok = hit >= 0
        owner, hit = owner[ok], hit[ok]
        ok = new[hit]
        key, n = np.unique(owner[ok].astype(np.int64) * len(cur.ids) + hit[ok], return_counts=True)
        i, j = np.divmod(key, len(cur.ids))
        area_d = np.array([len(p) for _, _, p in self._dormant])
        iou = n / (area_d[i] + cur.area[j] - n)
        cand = iou >= self.min_iou
        r, c, _ = _assign(i[cand], j[cand], iou[cand])
        tracks[c] = [self._dormant[k][0] for k in r.tolist()]
        new[c] = False
        self._dormant = [d for k, d in enumerate(self._dormant) if k not in set(r.tolist())]

    def _add_dormant(self, ended: np.ndarray):
        """Remember the masks of the tracks of ``self._prev`` listed in ``ended`` (indices)."""
        if self.max_gap == 0 or len(ended) == 0:
            return
        flat = self._prev.index
        want = np.isin(flat, ended)
        pix = np.flatnonzero(want)
        lab = flat[pix]
        order = np.argsort(lab, kind="stable")
        pix, lab = pix[order], lab[order]
        bounds = np.flatnonzero(np.diff(lab)) + 1
        for part in np.split(pix, bounds):
            k = int(flat[part[0]])
            self._dormant.append((int(self._prev_tracks[k]), self._prev_frame, part))

    def add_valid(self, labels, frame=None) -> np.ndarray:
        """:meth:`add` for labels already checked by :func:`~hexatissue.mesh.labels.validate_labels`."""
        frame, cur = self._next_frame(labels, frame)
        tracks = np.zeros(len(cur.ids), np.int64)
        new = np.ones(len(cur.ids), bool)
        if self._prev is not None:
            if self.follow == "flow":
                r, c, mothers, daughters = self._follow(self._prev, cur, frame)
            else:
                r, c, mothers, daughters = _match(self._prev, cur, self.min_iou, self.child_fraction,
                                                  self.mother_fraction)
            tracks[c] = self._prev_tracks[r]
            new[c] = False
            linked = np.zeros(len(self._prev.ids), bool)  # a mask, not setdiff1d (two hash uniques per frame)
            linked[r] = linked[mothers] = True
            ended = np.flatnonzero(~linked)
            if self.max_gap:
                # cells starting at this frame (not daughters) may continue a track seen before t-1
                starting = new.copy()
                starting[daughters.ravel()] = False
                self._close_gaps(cur, frame, tracks, starting)
                new &= starting | np.isin(np.arange(len(cur.ids)), daughters.ravel())
            self._add_dormant(ended)
        tracks[new] = self._new_ids(cur.ids[new])
        if self._prev is not None:
            for m, (da, db) in zip(mothers.tolist(), daughters.tolist()):
                self._parent[int(tracks[da])] = self._parent[int(tracks[db])] = int(self._prev_tracks[m])
        self._frames.append(frame)
        self._cells.append(cur.stored_ids())
        self._tracks.append(_narrow(tracks))
        self._prev, self._prev_tracks, self._prev_frame = cur, tracks, frame
        self._n += 1
        return tracks

    def _links_along(self, a, b, fld):
        """Links of ``a`` to ``b`` after carrying ``a`` along ``fld`` (as they are when None)."""
        if fld is None or fld.still():
            i, j, n = _contingency(a, b)
            area_a = a.area
        else:
            moved = warp(a.index, a.shape, fld, self.periodic)
            i, j, n = _index_overlaps(moved, b.index, len(a.ids), len(b.ids))
            area_a = np.bincount(moved[moved >= 0], minlength=len(a.ids)).astype(np.int64)
        r, c, iou, mothers, daughters = _link(i, j, n, area_a, b.area, self.min_iou, self.child_fraction,
                                              self.mother_fraction)
        share = float((iou >= CONFIDENT_IOU).mean()) if len(iou) else 0.0
        return share, (r, c, iou, mothers, daughters), fld, (i, j, n, area_a)

    def _follow(self, a: _Compact, b: _Compact, frame):
        """:func:`_match` of two frames along the tissue's motion (see ``follow``); records :meth:`link_qc`."""
        if a.index is None or b.index is None:
            raise InputError("follow='flow' needs every frame's pixels (MovieTracker.needs_pixels)")
        spacing = float(np.sqrt(np.median(a.area))) if len(a.area) else 1.0
        best = self._links_along(a, b, self._field)
        measured = False
        if best[0] < CONFIDENT_SHARE and len(a.ids) and len(b.ids):
            trial = self._links_along(a, b, outline_piv(a.index, b.index, a.shape, spacing, self.periodic))
            measured = True
            if trial[0] >= best[0]:
                best = trial
        for _ in range(3):  # refit from the confident links while the field still moves
            r, c, iou = best[1][:3]
            sure = iou >= CONFIDENT_IOU
            if sure.sum() < 3:
                break
            xy = a.centroids()[r[sure]]
            d = b.centroids()[c[sure]] - xy
            used = best[2]
            if used is None and np.quantile(np.hypot(*d.T), 0.9) <= REFIT_PX:
                break  # cells stay put to within a pixel: nothing to warp (the common, slow case costs no fit)
            fitted = fit_field(xy, d, a.shape, 2 * spacing)
            moved = fitted.at(xy) - (0 if used is None else used.at(xy))
            change = float(np.hypot(*moved.T).max())
            if used is None and change <= REFIT_PX:
                break
            if change <= REFIT_PX:
                best = (best[0], best[1], fitted, best[3])
                break
            trial = self._links_along(a, b, fitted)
            if trial[0] < best[0]:
                break
            best = trial
        share, (r, c, iou, mothers, daughters), fld, overlaps = best
        r, c, rescued = self._rescue(a, b, fld, overlaps, r, c, mothers, daughters)
        self._field = fld
        motion = 0.0 if fld is None else float(np.median(np.hypot(*fld.at(a.centroids()).T)))
        self._links.append((frame, len(a.ids), len(b.ids), len(r), float(np.median(iou)) if len(iou) else np.nan,
                            share, motion / spacing, measured, rescued))
        return r, c, mothers, daughters

    def _rescue(self, a, b, fld, overlaps, r, c, mothers, daughters):
        """Pair cells left unlinked on both sides: a carried earlier cell lying mostly inside a later one (a cell
        entering through the image edge grows from a sliver), or the later cell's centroid within half a diameter
        (``sqrt(area)``) of the earlier one's carried centroid.  Returns the links with them and their number."""
        free_a = np.ones(len(a.ids), bool)
        free_a[r] = free_a[mothers] = False
        free_b = np.ones(len(b.ids), bool)
        free_b[c] = free_b[daughters.ravel()] = False
        ia, ib = np.flatnonzero(free_a), np.flatnonzero(free_b)
        if not len(ia) or not len(ib):
            return r, c, 0
        i, j, n, area_a = overlaps
        inside = free_a[i] & free_b[j] & (n >= 0.5 * np.maximum(area_a[i], 1))
        xy = a.centroids()[ia]
        if fld is not None:
            xy = xy + fld.at(xy)
        gate = 0.5 * np.sqrt(a.area[ia])
        near = cKDTree(b.centroids()[ib]).query_ball_point(xy, gate)
        pi = ia[np.repeat(np.arange(len(ia)), [len(x) for x in near])]
        pj = ib[np.concatenate([np.asarray(x, np.int64) for x in near] + [np.empty(0, np.int64)])]
        pred = a.centroids()[pi]
        if fld is not None:
            pred = pred + fld.at(pred)
        closeness = 1 - np.hypot(*(b.centroids()[pj] - pred).T) / (0.5 * np.sqrt(a.area[pi])) + 1e-9
        # containment first (weight above 1), then closeness in (0, 1]; a pair met both ways keeps its best
        ci, cj = np.r_[i[inside], pi], np.r_[j[inside], pj]
        weight = np.r_[1 + n[inside] / np.maximum(area_a[i[inside]], 1), closeness]
        order = np.lexsort((-weight, cj, ci))
        ci, cj, weight = ci[order], cj[order], weight[order]
        first = np.r_[True, (ci[1:] != ci[:-1]) | (cj[1:] != cj[:-1])] if len(ci) else np.empty(0, bool)
        k, m, _ = _assign(ci[first], cj[first], weight[first])
        return np.r_[r, k], np.r_[c, m], len(k)

    def link_qc(self) -> pd.DataFrame:
        """How each frame was linked to the one before (``follow="flow"``; empty otherwise).

        Returns
        -------
        pandas.DataFrame
            ``frame`` (the later frame of the pair), ``cells_prev``,
            ``cells`` (counts), ``links`` (one-to-one links, divisions apart),
            ``link_iou`` (median IoU of the links after warping,
            dimensionless), ``confident`` (share of the links with IoU >=
            :data:`CONFIDENT_IOU`), ``motion`` (median displacement of the
            earlier frame's cells along the field used, in cell diameters
            ``sqrt(median area)``), ``measured`` (the field came from the
            outlines' cross-correlation, not from the frame before), ``rescued``
            (links made by centroid distance).
        """
        cols = ["frame", "cells_prev", "cells", "links", "link_iou", "confident", "motion", "measured", "rescued"]
        return pd.DataFrame(self._links, columns=cols)

    def tracks(self) -> pd.DataFrame:
        """``frame``, ``cell`` (label id), ``track`` of every cell added so far."""
        frame, cell = _stored_rows(self._frames, self._cells)
        track = np.concatenate(self._tracks, dtype=np.int64) if self._tracks else np.empty(0, np.int64)
        return pd.DataFrame({"frame": frame, "cell": cell, "track": track}, copy=False)  # new arrays: no copy

    @property
    def parents(self) -> dict:
        """``{daughter track: mother track}`` of the divisions found."""
        return dict(self._parent)


#: Tracking modes of :class:`MovieTracker` and :class:`hexatissue.TrackOptions`.
#: ``mode="auto"`` trusts the ids when at least this fraction of the linked cells keep their id (see :class:`MovieTracker`).
ID_CONSISTENCY = 0.9


class IdTracker(_Feed):
    """Trust the label ids: track id = label id; divisions read from the ids and overlaps.

    For consistently labelled movies (curated tracks, MPF runs).  A cell
    missing for some frames keeps its id, so it stays one track across any
    gap.  A division is a mother id that is absent from the next frame while
    two ids never seen before appear there mostly inside its last mask (the
    overlap rule of :func:`match_frames`, applied to those ids only); a
    mother whose id comes back later was not a mother.  The tracker also
    measures how consistent the ids are (:attr:`consistency`).

    Parameters
    ----------
    min_iou, child_fraction, mother_fraction : float
        See :func:`match_frames`.
    """

    def __init__(self, min_iou=0.2, child_fraction=0.6, mother_fraction=0.2):
        _check_fractions(min_iou, child_fraction, mother_fraction)
        self.min_iou, self.child_fraction, self.mother_fraction = min_iou, child_fraction, mother_fraction
        self._prev: _Compact | None = None
        self._shape = None
        self._seen = np.empty(0, np.int64)  # sorted ids seen so far
        self._divisions: dict[int, tuple[int, int]] = {}  # daughter -> (mother, frame of the daughters)
        self._frames, self._cells = [], []
        self.n_linked = 0  # cells of frame t overlapping a cell of frame t+1 with IoU >= min_iou
        self.n_same = 0  # ... that overlap the cell with their own id with IoU >= min_iou
        self._n = 0

    def add_valid(self, labels, frame=None) -> np.ndarray:
        """:meth:`add` for labels already checked by :func:`~hexatissue.mesh.labels.validate_labels`."""
        frame, cur = self._next_frame(labels, frame)
        if self._prev is not None:
            a = self._prev
            i, j, n = _contingency(a, cur)
            iou = n / (a.area[i] + cur.area[j] - n)
            good = iou >= self.min_iou
            self.n_linked += len(np.unique(i[good]))
            self.n_same += int((good & (a.ids[i] == cur.ids[j])).sum())
            ended = ~in_sorted(a.ids, cur.ids)  # both sorted: binary searches, not isin's sort or table
            new = ~in_sorted(cur.ids, self._seen)
            sel = ended[i] & new[j]
            mothers, daughters = _divisions(i[sel], j[sel], n[sel], a.area, cur.area, self.child_fraction,
                                            self.mother_fraction, self.min_iou)
            for m, pair in zip(a.ids[mothers].tolist(), cur.ids[daughters].tolist()):
                for d in pair:
                    self._divisions[d] = (m, frame)
        if self._prev is None or new.any():  # else every id was seen: no union (a hash unique) to make
            self._seen = np.union1d(self._seen, cur.ids)
        self._frames.append(frame)
        self._cells.append(cur.stored_ids())
        self._prev = cur
        self._n += 1
        return cur.ids.copy()

    def add_ids(self, ids, frame) -> None:
        """Add a frame known only by its cell ids (polygon input): track = id; no overlaps, so no divisions."""
        ids = np.asarray(ids, np.int64)
        self._seen = np.union1d(self._seen, ids)
        self._frames.append(int(frame))
        self._cells.append(_narrow(ids))
        self._n += 1

    @property
    def consistency(self) -> float:
        """Of the cells overlapping a cell of the next frame with IoU >= ``min_iou``, the fraction whose
        own id is such a cell (NaN before two frames with cells)."""
        return self.n_same / self.n_linked if self.n_linked else float("nan")

    def tracks(self) -> pd.DataFrame:
        """``frame``, ``cell`` (label id), ``track`` (= ``cell``) of every cell added so far."""
        frames, cells = _stored_rows(self._frames, self._cells)
        return pd.DataFrame({"frame": frames, "cell": cells, "track": cells.copy()}, copy=False)  # new arrays

    @property
    def parents(self) -> dict:
        """``{daughter track: mother track}`` of the divisions found (mothers that never come back)."""
        last = self._last_frames({m for m, _ in self._divisions.values()})
        return {d: m for d, (m, t) in self._divisions.items() if last[m] < t}

    def _last_frames(self, ids) -> dict:
        """``{id: frame}`` of the last frame added that holds each of ``ids`` (asked once, at the end, for
        the mothers only: no per-frame dictionary of every id)."""
        if not ids:
            return {}
        frame, cell = _stored_rows(self._frames, self._cells)
        rows = np.flatnonzero(np.isin(cell, np.fromiter(ids, np.int64)))[::-1]  # the latest rows first
        found, first = np.unique(cell[rows], return_index=True)
        return dict(zip(found.tolist(), frame[rows[first]].tolist()))


class SeparateTracker:
    """No tracking: every cell of every frame is its own track (frames that are unrelated images)."""

    def __init__(self):
        self._frames, self._cells = [], []

    def add_valid(self, labels, frame) -> None:
        """Add a label image (checked by :func:`~hexatissue.mesh.labels.validate_labels`)."""
        self.add_ids(_compact(labels).ids, frame)

    def add_ids(self, ids, frame) -> None:
        """Add a frame by its cell ids."""
        self._frames.append(int(frame))
        self._cells.append(_narrow(np.asarray(ids, np.int64)))

    def tracks(self) -> pd.DataFrame:
        """``frame``, ``cell``, ``track`` (1, 2, ... in frame and cell order)."""
        frames, cells = _stored_rows(self._frames, self._cells)
        return pd.DataFrame({"frame": frames, "cell": cells, "track": np.arange(1, len(cells) + 1, dtype=np.int64)},
                            copy=False)  # new arrays: no copy

    @property
    def parents(self) -> dict:
        """No divisions: ``{}``."""
        return {}


class MovieTracker:
    """Tracking of a whole movie by mode: keep the ids, link by overlap, or decide from the data.

    Parameters
    ----------
    mode : {"auto", "always", "never", "off"}
        ``"never"``: the ids are the tracks (:class:`IdTracker`: track =
        cell, gap-tolerant, divisions read from the ids and overlaps).
        ``"always"``: link cells by overlap (:class:`Tracker`).  ``"off"``:
        every cell of every frame is its own track (:class:`SeparateTracker`).
        ``"auto"``: ``"off"`` when ``independent``, ``"never"`` when
        ``ids_consistent``; otherwise both run and the ids are kept when
        :attr:`IdTracker.consistency` is at least :data:`ID_CONSISTENCY`
        (or when no two frames could be compared), else the overlap tracks
        are used.
    min_iou, child_fraction, mother_fraction : float
        See :func:`match_frames`.
    max_gap : int
        Gap closing of the overlap tracker (see :class:`Tracker`).
    follow : {"flow", "none"}, periodic : bool
        How the overlap tracker links frames (see :class:`Tracker`).
    ids_consistent : bool
        The source guarantees consistent ids (MPF runs, polygon tables with frames).
    independent : bool
        The frames are unrelated images (a folder of polygon files), not a movie.
    """

    def __init__(self, mode="auto", min_iou=0.2, child_fraction=0.6, mother_fraction=0.2, max_gap=0,
                 ids_consistent=False, independent=False, follow="flow", periodic=False):
        if mode not in TRACK_MODES:
            raise InputError(f"mode must be one of {TRACK_MODES}; got {mode!r}")
        self.mode, self.ids_consistent, self.independent = mode, bool(ids_consistent), bool(independent)
        self.ids = IdTracker(min_iou, child_fraction, mother_fraction)
        self.separate = SeparateTracker() if mode == "off" or (mode == "auto" and self.independent) else None
        overlap = mode == "always" or (mode == "auto" and not self.ids_consistent and not self.independent)
        self.overlap = Tracker(min_iou, child_fraction, mother_fraction, max_gap, follow, periodic) if overlap else None

    def add_valid(self, labels, frame=None, overlaps=None):
        """Add the next frame (labels checked by :func:`~hexatissue.mesh.labels.validate_labels`).

        ``labels`` and ``overlaps`` may come from :func:`compact_frames` (run
        ahead, e.g. in the worker that meshed the frames): ``overlaps`` are then
        the counts with the frame added just before, and ``labels`` may lack
        its pixels unless gap closing needs them (:attr:`needs_pixels`).
        """
        labels = _compact(labels)  # once for both trackers, which share the overlaps too
        if overlaps is not None:
            labels.overlaps = (self.ids._prev, overlaps)
        self.ids.add_valid(labels, frame)
        for feed in (self.overlap, self.separate):
            if feed is not None:
                feed.add_valid(labels, frame)

    @property
    def needs_pixels(self) -> bool:
        """Whether every frame's pixels are needed (gap closing keeps the masks of ended tracks; following the
        flow warps them)."""
        return self.overlap is not None and (self.overlap.max_gap > 0 or self.overlap.follow == "flow")

    def add_ids(self, ids, frame):
        """Add the next frame by its cell ids only (polygon input: nothing to overlap)."""
        if self.overlap is not None:
            raise InputError("add_ids: overlap tracking (mode 'always') needs label images; use add_valid")
        self.ids.add_ids(ids, frame)
        if self.separate is not None:
            self.separate.add_ids(ids, frame)

    def decision(self) -> tuple[str, str]:
        """``(resolved mode, reason)``: ``"never"`` (ids kept) or ``"always"`` (overlap tracks), and why."""
        c = self.ids.consistency
        measured = (f"{c:.1%} of the cells overlapping a cell of the next frame (IoU >= {self.ids.min_iou:g}) "
                    f"overlap their own id" if np.isfinite(c) else "no two frames with overlapping cells")
        if self.mode != "auto":
            return self.mode, f"track={self.mode!r} requested; {measured}"
        if self.independent:
            return "off", "the source's frames are independent images, not a movie: every cell is its own track"
        if self.ids_consistent:
            return "never", ("the source's ids are consistent (MPF run, polygon table or Cell Tracking Challenge "
                             "folder): ids kept")
        if not np.isfinite(c):
            return "never", f"{measured}: ids kept"
        if c >= ID_CONSISTENCY:
            return "never", f"{measured} (>= {ID_CONSISTENCY:.0%}): ids kept"
        return "always", f"{measured} (< {ID_CONSISTENCY:.0%}): cells re-tracked"

    def _chosen(self):
        return {"never": self.ids, "always": self.overlap, "off": self.separate}[self.decision()[0]]

    def tracks(self) -> pd.DataFrame:
        """``frame``, ``cell``, ``track`` of the chosen tracking."""
        return self._chosen().tracks()

    @property
    def parents(self) -> dict:
        """``{daughter track: mother track}`` of the chosen tracking."""
        return self._chosen().parents

    def link_qc(self) -> pd.DataFrame:
        """:meth:`Tracker.link_qc` of the overlap tracks when they are the ones chosen (else no rows)."""
        chosen = self._chosen()
        return chosen.link_qc() if isinstance(chosen, Tracker) else Tracker(follow="none").link_qc()

    def summary(self) -> dict:
        """What was decided: ``mode`` requested, ``resolved``, ``reason``, ``id_consistency``, ``threshold``, and
        ``follow`` (how the overlap tracker linked the frames: ``"flow"``, ``"none"``; None without one)."""
        resolved, reason = self.decision()
        c = self.ids.consistency
        return {"mode": self.mode, "resolved": resolved, "reason": reason,
                "id_consistency": float(c) if np.isfinite(c) else None, "threshold": ID_CONSISTENCY,
                "follow": self.overlap.follow if self.overlap is not None else None}


def lineage_table(tracks: pd.DataFrame, parents=None, is_border=None) -> pd.DataFrame:
    """One row per track: its frame span and how it begins and ends.

    Parameters
    ----------
    tracks : pandas.DataFrame
        Columns ``frame``, ``track`` (plus anything else).
    parents : dict, optional
        ``{daughter track: mother track}``.
    is_border : array of bool, optional
        Aligned with ``tracks``: the cell touches the image edge or the
        background.  Tracks starting (ending) on a border cell begin (end) as
        ``border``; otherwise ``appearance`` (``extrusion``).

    Returns
    -------
    pandas.DataFrame
        Columns described in ``hexatissue.schema.TABLES["lineage"]``: ``track``,
        ``frame_start``, ``frame_end`` (frames), ``n_frames``, ``parent``
        (0 = none), ``begin``, ``end``.
    """
    parents = parents or {}
    frame, track = tracks["frame"].to_numpy(np.int64), tracks["track"].to_numpy(np.int64)
    border = np.zeros(len(track), bool) if is_border is None else np.asarray(is_border, bool)
    # rows in (track, frame) order, ties in row order: one index sort instead of a sorted copy and a groupby
    order = np.lexsort((frame, track))
    by_track = track[order]
    change = np.ones(len(order), bool)
    change[1:] = by_track[1:] != by_track[:-1]
    bounds = np.append(np.flatnonzero(change), len(order))
    first, last = order[bounds[:-1]], order[bounds[1:] - 1]  # each track's first and last row
    out = pd.DataFrame({"track": by_track[bounds[:-1]], "frame_start": frame[first], "frame_end": frame[last],
                        "n_frames": np.diff(bounds)})
    del order, by_track, change
    out["parent"] = out["track"].map(parents).fillna(0).astype(np.int64)
    t0, t1 = (frame.min(), frame.max()) if len(frame) else (0, 0)
    mothers = set(parents.values())
    begin = np.where(border[first], "border", "appearance").astype(object)
    begin[out["parent"].to_numpy() > 0] = "division"
    begin[out["frame_start"].to_numpy() == t0] = "movie_start"
    end = np.where(border[last], "border", "extrusion").astype(object)
    end[out["track"].isin(mothers).to_numpy()] = "division"
    end[out["frame_end"].to_numpy() == t1] = "movie_end"
    out["begin"] = pd.array(begin, dtype="string")
    out["end"] = pd.array(end, dtype="string")
    return validate(out.reset_index(drop=True), "lineage")


#: Why a division is suspect (``lineage.division_reason``, several joined by ``;``), in the order they are checked.
DIVISION_REASONS = {
    "mother_continues": "the mother's track goes on after its daughters start",
    "not_two_daughters": "the mother has one daughter or more than two",
    "late_daughter": "a daughter starts more than max_delay frames after the mother's last frame",
    "area_mismatch": "the daughters' areas at their first frame do not sum to the mother's at its last, within "
                     "area_tolerance",
    "short_daughter": "a daughter ends (border, extrusion or division) before min_frames frames",
    "unconfirmed": "a daughter reaches the movie's end before min_frames frames: its persistence cannot be checked",
    "redivision": "the mother was born by a division fewer than min_cycle frames before, or a daughter divides "
                  "again within min_cycle frames",
}


def check_divisions(lineage: pd.DataFrame, cells: pd.DataFrame, min_frames: int = 3, min_cycle: int = 5,
                    area_tolerance: float = 0.4, max_delay: int = 1) -> pd.DataFrame:
    """The lineage with every division checked against what a division must look like.

    A division is kept as found; its two daughter rows are marked suspect
    when the mother does not end before them, it does not have two
    daughters, a daughter starts more than ``max_delay`` frames after the
    mother's last frame, the daughters' first-frame areas do not sum to the
    mother's last-frame area within ``area_tolerance`` (as a fraction of it),
    a daughter lasts fewer than ``min_frames`` frames (or reaches the end of
    the movie before: unconfirmed), or the mother was itself born by a
    division fewer than ``min_cycle`` frames before or a daughter divides
    again within ``min_cycle`` frames (:data:`DIVISION_REASONS`).  An
    over-segmented cell split for a frame or two, or two cells merged then
    split by the overlap tracker, fails these; a real division passes them.

    Parameters
    ----------
    lineage : pandas.DataFrame
        :func:`lineage_table` (``track``, ``frame_start``, ``frame_end``,
        ``n_frames``, ``parent``, ``end``).
    cells : pandas.DataFrame
        ``frame``, ``track``, ``area`` (px).
    min_frames : int
        Frames a daughter must be present.
    min_cycle : int
        Shortest cell cycle, frames: from a cell's first frame (it was born
        by a division) to the first frame of its own daughters.
    area_tolerance : float
        Largest ``|daughters' area / mother's area - 1|``.
    max_delay : int
        Largest ``daughter frame_start - mother frame_end`` (1: the next frame).

    Returns
    -------
    pandas.DataFrame
        ``lineage`` with ``division_area_ratio`` (the daughters' summed area at
        their first frame over the mother's at its last frame, on daughter rows;
        NaN elsewhere, dimensionless), ``division_suspect`` (bool, daughter rows)
        and ``division_reason`` (the :data:`DIVISION_REASONS` keys that apply,
        joined by ``;``; empty when plausible or not a daughter).
    """
    for name, value in (("min_frames", min_frames), ("min_cycle", min_cycle), ("max_delay", max_delay)):
        if isinstance(value, bool) or int(value) != value or value < 0:
            raise InputError(f"{name} must be a non-negative integer number of frames; got {value!r}")
    if not is_real(area_tolerance) or area_tolerance < 0:
        raise InputError(f"area_tolerance must be a finite fraction >= 0; got {area_tolerance!r}")
    out = lineage.copy()
    n = len(out)
    ratio, reasons = np.full(n, np.nan), [[] for _ in range(n)]
    track = out["track"].to_numpy(np.int64)
    parent = out["parent"].to_numpy(np.int64)
    start, end = out["frame_start"].to_numpy(np.int64), out["frame_end"].to_numpy(np.int64)
    ending = out["end"].astype(str).to_numpy()
    row_of = dict(zip(track.tolist(), range(n)))
    area = _areas_at(cells, track, start, end)
    daughters = np.flatnonzero(parent > 0)
    for mother, rows in pd.Series(daughters).groupby(parent[daughters]):
        rows = rows.to_numpy()
        m = row_of.get(int(mother))
        why = []
        if m is None or end[m] >= start[rows].min():
            why.append("mother_continues")
        if len(rows) != 2:
            why.append("not_two_daughters")
        if m is not None and (start[rows] - end[m] > max_delay).any():
            why.append("late_daughter")
        if m is not None:
            ratio[rows] = area[1][rows].sum() / area[0][m]
            if not abs(ratio[rows[0]] - 1) <= area_tolerance:
                why.append("area_mismatch")
        young = (end - start + 1)[rows] < min_frames
        if (young & (ending[rows] != "movie_end")).any():
            why.append("short_daughter")
        if (young & (ending[rows] == "movie_end")).any():
            why.append("unconfirmed")
        again = (ending[rows] == "division") & (end[rows] + 1 - start[rows] < min_cycle)
        if (m is not None and parent[m] > 0 and end[m] + 1 - start[m] < min_cycle) or again.any():
            why.append("redivision")
        for r in rows.tolist():
            reasons[r] = why
    out["division_area_ratio"] = ratio
    out["division_suspect"] = np.array([bool(r) for r in reasons])
    out["division_reason"] = pd.array([";".join(r) for r in reasons], dtype="string")
    return validate(out, "lineage")


#: An extrusion is confirmed when the cell's area at its last frame is at most this fraction of its median area
#: over its track: an extruding cell constricts apically before it leaves the surface.
EXTRUSION_SHRINK = 0.5


def check_extrusions(lineage: pd.DataFrame, cells: pd.DataFrame, shrink: float = EXTRUSION_SHRINK) -> pd.DataFrame:
    """The lineage with every interior extrusion checked: did the cell shrink before it left?

    A cell that ends inside the tissue (``end == "extrusion"``) with its
    last-frame area at most ``shrink`` times its median area over its track
    is a confirmed extrusion; one that vanishes at its usual size (or is seen
    in a single frame) is unconfirmed: as likely a cell the tracking lost, or
    a segmentation error, as a cell that left the tissue.

    Parameters
    ----------
    lineage : pandas.DataFrame
        :func:`lineage_table` (``track``, ``frame_start``, ``frame_end``, ``end``).
    cells : pandas.DataFrame
        ``frame``, ``track``, ``area`` (px).
    shrink : float
        Largest last-frame area of a confirmed extrusion, as a fraction of the track's median area.

    Returns
    -------
    pandas.DataFrame
        ``lineage`` with ``extrusion_area_ratio`` (last-frame area over the
        median area of the track, on extrusion rows; NaN elsewhere,
        dimensionless) and ``extrusion_unconfirmed`` (bool: an extrusion whose
        ratio is above ``shrink``, or NaN: a single frame).
    """
    if not is_real(shrink) or not 0 < shrink < 1:
        raise InputError(f"shrink must be a fraction in (0, 1); got {shrink!r}")
    out = lineage.copy()
    track = out["track"].to_numpy(np.int64)
    ext = (out["end"].astype(str) == "extrusion").to_numpy()
    median = cells.groupby("track")["area"].median()
    last = _areas_at(cells, track, out["frame_start"].to_numpy(np.int64), out["frame_end"].to_numpy(np.int64))[0]
    ratio = np.full(len(out), np.nan)
    one = out["n_frames"].to_numpy(np.int64) == 1
    keep = ext & ~one
    ratio[keep] = last[keep] / median.reindex(track[keep]).to_numpy(float)
    out["extrusion_area_ratio"] = ratio
    out["extrusion_unconfirmed"] = ext & ~(ratio <= shrink)
    return validate(out, "lineage")


def _areas_at(cells, track, start, end):
    """Each track's area (px) at its first frame and at its last, from ``cells`` (``frame``, ``track``, ``area``)."""
    keys = row_keys(cells["frame"].to_numpy(np.int64), cells["track"].to_numpy(np.int64))
    area = cells["area"].to_numpy(float)
    order = np.argsort(keys, kind="stable")
    keys, area = keys[order], area[order]

    def at(frame):
        wanted = row_keys(frame, track)
        pos = np.minimum(np.searchsorted(keys, wanted), max(len(keys) - 1, 0))
        found = (keys[pos] == wanted) if len(keys) else np.zeros(len(wanted), bool)
        return np.where(found, area[pos] if len(keys) else np.nan, np.nan)

    return at(end), at(start)


def division_rows(lineage: pd.DataFrame) -> pd.DataFrame:
    """One row per division of a checked lineage (:func:`check_divisions`).

    Returns
    -------
    pandas.DataFrame
        ``mother`` (track), ``frame`` (first frame of the daughters),
        ``daughter_a``, ``daughter_b`` (tracks; -1 when there is no second
        one), ``area_ratio`` (daughters' area over the mother's,
        dimensionless), ``suspect`` (bool), ``reason``.
    """
    d = lineage[lineage["parent"] > 0].sort_values(["parent", "track"])
    cols = {"mother": [], "frame": [], "daughter_a": [], "daughter_b": [], "area_ratio": [], "suspect": [],
            "reason": []}
    for mother, rows in d.groupby("parent", sort=True):
        ids = rows["track"].tolist()
        cols["mother"].append(int(mother))
        cols["frame"].append(int(rows["frame_start"].min()))
        cols["daughter_a"].append(ids[0])
        cols["daughter_b"].append(ids[1] if len(ids) > 1 else -1)
        first = rows.iloc[0]
        cols["area_ratio"].append(float(first.get("division_area_ratio", np.nan)))
        cols["suspect"].append(bool(first.get("division_suspect", False)))
        cols["reason"].append(str(first.get("division_reason", "")))
    out = pd.DataFrame(cols).astype({"mother": np.int64, "frame": np.int64, "daughter_a": np.int64,
                                     "daughter_b": np.int64, "area_ratio": float, "suspect": bool})
    return out.sort_values(["frame", "mother"], ignore_index=True)


#: A frame's tracking is doubtful when more than this share of its cells end inside the tissue (extrusions) ...
EXTRUSION_SHARE = 0.01
#: ... (and at least this many: one extrusion in a small field of view is biology, not a tracking failure) ...
MIN_EXTRUSIONS = 2
#: ... or when fewer than this share of its links to the frame before overlap with IoU >= CONFIDENT_IOU after
#: warping: the frames look far apart in time (or are different fields of view).
FAR_APART = 0.5


def tracking_qc(lineage: pd.DataFrame, cells: pd.DataFrame, links: pd.DataFrame | None = None) -> pd.DataFrame:
    """Per frame: cells, tracks that appear and disappear, divisions plausible and suspect, and whether the
    tracking there is doubtful.

    Parameters
    ----------
    lineage : pandas.DataFrame
        :func:`lineage_table`, checked by :func:`check_divisions` (without
        ``division_suspect`` every division counts as plausible).
    cells : pandas.DataFrame
        ``frame`` (one row per cell).
    links : pandas.DataFrame, optional
        :meth:`Tracker.link_qc` (``frame``, ``link_iou``, ``confident``,
        ``motion``), e.g. from ``summary["tracking"]["links"]`` of an analysis.

    Returns
    -------
    pandas.DataFrame
        ``frame``, ``cells`` (count), ``appearances`` (tracks starting at
        the frame inside the tissue or at its border, not by division),
        ``disappearances`` (tracks present at the frame before and not
        after it, ended by extrusion or at the border, not by division),
        ``interior_appearances`` and ``extrusions`` (of those, the ones
        inside the tissue), ``divisions`` (mothers whose daughters start at
        the frame), ``divisions_suspect`` (of those, the suspect ones);
        counts per frame.  With ``links``: ``link_iou`` (median IoU of the
        links from the frame before, after warping), ``confident`` (share of
        them with IoU >= :data:`CONFIDENT_IOU`), ``motion`` (median
        displacement from the frame before, cell diameters); NaN at the first
        frame.  ``doubtful`` (bool): more than :data:`EXTRUSION_SHARE` of the
        frame's cells (and at least :data:`MIN_EXTRUSIONS`) ended inside the
        tissue there, or ``confident`` < :data:`FAR_APART`.
    """
    frames = np.unique(cells["frame"].to_numpy(np.int64))
    out = pd.DataFrame({"frame": frames})
    out["cells"] = np.searchsorted(np.sort(cells["frame"].to_numpy(np.int64)), frames, "right") - \
        np.searchsorted(np.sort(cells["frame"].to_numpy(np.int64)), frames, "left")
    begin, end = lineage["begin"].astype(str), lineage["end"].astype(str)
    # the frame after a track's last one, in the movie's own frame numbers
    after = np.searchsorted(frames, lineage["frame_end"].to_numpy(np.int64), "right")
    gone_at = np.where(after < len(frames), frames[np.minimum(after, len(frames) - 1)], -1)

    def per_frame(values):
        return pd.Series(values).value_counts().reindex(frames, fill_value=0).to_numpy(np.int64)

    out["appearances"] = per_frame(lineage.loc[begin.isin(["appearance", "border"]).to_numpy(), "frame_start"])
    out["disappearances"] = per_frame(gone_at[end.isin(["extrusion", "border"]).to_numpy()])
    out["interior_appearances"] = per_frame(lineage.loc[(begin == "appearance").to_numpy(), "frame_start"])
    out["extrusions"] = per_frame(gone_at[(end == "extrusion").to_numpy()])
    daughters = lineage[lineage["parent"] > 0]
    first = daughters.groupby("parent")["frame_start"].min()
    suspect = (daughters.groupby("parent")["division_suspect"].any() if "division_suspect" in daughters.columns
               else pd.Series(False, index=first.index))
    out["divisions"] = per_frame(first.to_numpy())
    out["divisions_suspect"] = per_frame(first[suspect.reindex(first.index).to_numpy(bool)].to_numpy())
    doubtful = (out["extrusions"] > EXTRUSION_SHARE * out["cells"]) & (out["extrusions"] >= MIN_EXTRUSIONS)
    if links is not None:
        links = pd.DataFrame(links)
        for name in ("link_iou", "confident", "motion"):
            values = links.set_index("frame")[name] if len(links) else pd.Series(dtype=float)
            out[name] = values.reindex(frames).to_numpy(float)
        doubtful |= out["confident"] < FAR_APART
    out["doubtful"] = doubtful.to_numpy(bool)
    return out


def tracking_warning(summary: dict) -> str | None:
    """What to tell the user when the tracking of some frames is doubtful (None when none is), from
    :func:`tracking_summary`."""
    frames = summary.get("doubtful_frames") or []
    if not frames:
        return None
    links = summary.get("links") or {}
    confident = dict(zip(links.get("frame", []), links.get("confident", [])))
    far = [t for t in frames if confident.get(t, 1.0) < FAR_APART]
    # frames whose existing links overlap well: the cells that end have no partner in the next frame's labels
    linked = [t for t in frames if t not in far and confident.get(t, np.nan) >= CONFIDENT_SHARE]
    other = [t for t in frames if t not in far and t not in linked]

    def listed(values):
        return ", ".join(str(t) for t in values[:10]) + (", ..." if len(values) > 10 else "")

    parts = []
    if other:
        parts.append(f"at frame(s) {listed(other)} more than {EXTRUSION_SHARE:.0%} of the cells end inside the tissue "
                     f"and fewer links overlap well: extrusions, appearances and divisions there are likely tracking "
                     f"errors")
    if linked:
        parts.append(f"at frame(s) {listed(linked)} more than {EXTRUSION_SHARE:.0%} of the cells end inside the "
                     f"tissue although at least {CONFIDENT_SHARE:.0%} of the links overlap well: the cells that end have "
                     f"no partner in the next frame's labels (cells missing or merged in the segmentation there, or "
                     f"real extrusions); check those frames' labels")
    if far:
        parts.append(f"at frame(s) {listed(far)} fewer than {FAR_APART:.0%} of the links overlap well after following "
                     f"the motion: the frames look far apart in time or are different fields of view; if the ids are "
                     f"the same cell across frames, use --track never; if the frames are unrelated images, --track off")
    return (f"tracking is doubtful at {len(frames)} frame(s) ({listed(frames)}) of a movie with "
            f"{summary.get('interior_extrusions', 0)} interior extrusions and "
            f"{summary.get('interior_appearances', 0)} interior appearances: " + "; ".join(parts)
            + " (those intervals are marked `tracking_doubtful` in the deformation budget and left out of the "
              "report's cumulative budget)")


def lineage_roots(parents: dict, ids) -> dict:
    """``{id: its first ancestor}`` following ``parents`` (``{child: parent}``) up from each of ``ids``.

    An id without a parent is its own root; a cycle (bad input) stops where it closes.
    """
    out = {}
    for i in ids:
        root, seen = int(i), set()
        while root in parents and root not in seen:
            seen.add(root)
            root = int(parents[root])
        out[int(i)] = root
    return out


def track_labels(stack, min_iou=0.2, child_fraction=0.6, mother_fraction=0.2, max_gap=0, progress=False):
    """Track the cells of a label movie by overlap.

    Parameters
    ----------
    stack : T x rows x cols array-like or sequence of 2-D label images
        Frames are read one at a time (``stack[t]``), so lazily indexed
        arrays (zarr, dask, memory maps) are never loaded whole.
    min_iou, child_fraction, mother_fraction : float
        See :func:`match_frames`.
    max_gap : int
        Frames a cell may be missing and still continue its track (see :class:`Tracker`).
    progress : bool
        Show a tqdm progress bar.

    Returns
    -------
    tracks : pandas.DataFrame
        ``frame``, ``cell`` (label id), ``track`` (track id).
    lineage : pandas.DataFrame
        See :func:`lineage_table`; a cell touching background 0 or the image
        edge is a border cell (the mesh's ``is_border`` rule).  Give touching
        labels (membrane images normalised first with
        :func:`hexatissue.mesh.normalize_labels`), else every cell touches 0.
    """

    n = len(stack)
    tracker = Tracker(min_iou, child_fraction, mother_fraction, max_gap)
    border = []
    for t in progress_bar(range(n), enabled=progress, desc="tracking"):
        labels = validate_labels(stack[t], f"stack[{t}]")
        tracker.add(labels, t)
        border.append(np.isin(tracker._cells[-1], touches_outside(labels)))
    tracks = tracker.tracks()
    lineage = lineage_table(tracks, tracker.parents, np.concatenate(border) if border else None)
    return tracks, lineage


def cells_with_tracks(cells, tracker):
    """``cells`` with a ``track`` column after ``cell``, from a :class:`MovieTracker`'s ``(frame, cell) -> track``.

    The tracker must have seen exactly the cells of ``cells`` (the mesh's
    own labels, once each).
    """
    ids = tracker.tracks()
    if all(np.array_equal(ids[c].to_numpy(), cells[c].to_numpy()) for c in ("frame", "cell")):
        track = ids["track"].to_numpy(np.int64)  # the mesh's rows in the tracker's order (frame, id): no search
    else:
        track = _tracks_by_key(cells, ids)
    del ids
    cells = cells.drop(columns="track", errors="ignore")
    cells.insert(cells.columns.get_loc("cell") + 1, "track", track)
    return cells


def _tracks_by_key(cells, ids):
    """The ``track`` of each row of ``cells`` from the tracker's ``ids`` table (rows in any order)."""
    # one sorted int64 key per (frame, cell), not a merge (which needs several times the column's memory)
    keys = row_keys(ids["frame"].to_numpy(np.int64), ids["cell"].to_numpy(np.int64))
    order = np.argsort(keys)
    keys = keys[order]
    wanted = row_keys(cells["frame"].to_numpy(np.int64), cells["cell"].to_numpy(np.int64))
    pos = np.minimum(np.searchsorted(keys, wanted), max(len(keys) - 1, 0))
    # the tracker saw the mesh's own labels, once each: anything else is a bug, not bad input
    if len(wanted) and (len(keys) == 0 or (keys[pos] != wanted).any() or (np.diff(keys) == 0).any()):
        raise AssertionError("mesh cells missing from the tracker's labels, or seen twice")
    return ids["track"].to_numpy(np.int64)[order[pos]]


def tracking_summary(tracker, cells, parents, lineage=None):
    """The tracker's decision and what it changed: rows whose track differs from the id, tracks, divisions
    (plausible and suspect ones when ``lineage`` was checked by :func:`check_divisions`)."""
    out = tracker.summary()
    ids, tracks = cells["cell"].to_numpy(), cells["track"].to_numpy()
    out.update(rows_track_not_cell=int((tracks != ids).sum()), n_ids=distinct_count(ids),
               n_tracks=distinct_count(tracks), n_divisions=len(set(parents.values())))
    if lineage is not None and "division_suspect" in lineage.columns:
        daughters = lineage[lineage["parent"] > 0]
        suspect = daughters.groupby("parent")["division_suspect"].any()
        out.update(n_divisions_plausible=int((~suspect).sum()), n_divisions_suspect=int(suspect.sum()))
    links = tracker.link_qc() if hasattr(tracker, "link_qc") else None
    if links is not None and len(links):  # per frame pair, as JSON lists (metadata.json)
        out["links"] = {name: [v.item() if hasattr(v, "item") else v for v in links[name].tolist()]
                        for name in ("frame", "link_iou", "confident", "motion", "measured", "rescued")}
    if lineage is not None and "extrusion_unconfirmed" in lineage.columns:
        out["n_extrusions_unconfirmed"] = int(lineage["extrusion_unconfirmed"].sum())
    if lineage is not None and out.get("resolved") != "off":  # untracked frames: every cell ends, nothing to doubt
        qc = tracking_qc(lineage, cells, out.get("links"))
        out["doubtful_frames"] = qc.loc[qc["doubtful"], "frame"].astype(int).tolist()
        out["interior_extrusions"] = int(qc["extrusions"].sum())
        out["interior_appearances"] = int(qc["interior_appearances"].sum())
    return out


# the column lists of hexatissue 0.1, now read from the one registry
__getattr__ = deprecated_column_lists(__name__, {"LINEAGE_COLUMNS": ("lineage", None)})
