"""The overlap tracker: frame by frame, optionally following the tissue's motion (:class:`Tracker`)."""
from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.spatial import cKDTree

from ..errors import InputError
from ..mesh.labels import validate_labels
from ..options import FOLLOW_MODES
from ._motion import Field, fit_field, outline_piv, warp
from .linking import _assign, _check_fractions, _link, _match
from .overlap import _Compact, _compact, _contingency, _index_overlaps, _frame_span, _narrow, _stored_rows

#: A link is confident at this IoU after warping (it then feeds the fit of the motion field).
CONFIDENT_IOU = 0.5
#: Below this share of confident links, the motion is measured from the outlines (PIV).
CONFIDENT_SHARE = 0.9
#: A refitted field that moves no node by more than this (px) is not used for another linking pass.
REFIT_PX = 1.0


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

    def tracks(self, frames=None) -> pd.DataFrame:
        """``frame``, ``cell`` (label id), ``track`` of every cell added so far (of frames ``first`` to ``last``
        when ``frames = (first, last)``)."""
        at = _frame_span(self._frames, frames)
        frame, cell = _stored_rows(self._frames[at], self._cells[at])
        track = np.concatenate(self._tracks[at], dtype=np.int64) if self._tracks[at] else np.empty(0, np.int64)
        return pd.DataFrame({"frame": frame, "cell": cell, "track": track}, copy=False)  # new arrays: no copy

    @property
    def parents(self) -> dict:
        """``{daughter track: mother track}`` of the divisions found."""
        return dict(self._parent)
