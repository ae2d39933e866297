"""The budget of a movie, a chunk of frames at a time (:func:`budget_chunks`), and of tables in memory
(:func:`deformation_budget`, the case of one chunk): the terms of each interval and region as the ``deformation``
table's columns, and each T1's share of them.

Each frame's triangulation depends on the frames around it: a four-fold vertex or rosette keeps the
diagonals of the previous frame's triangulation, and one that the past says nothing about takes those of
the triangulation it resolves into later.  So the movie is read twice, chunk by chunk: backwards (last
chunk first) for what each frame's rings resolve into (:func:`_resolved_into`), then forwards, carrying the
last frame (its triangulation, contacts, cells and grid rows) from chunk to chunk (:func:`_chunk_budget`).  Once those are known, an interval's budget depends only on its two frames.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
import pandas as pd

from ..errors import InputError
from ..geometry import in_sorted
from ..options import T1_SOURCES
from ..schema import DEFORMATION_TERMS, ISOTROPIC_TERMS, empty_table, require_columns
from .interval import _pair
from .movie import _Candidates, _Frames, _Lineage, _runs
from .regions import _Layers, _Membership, _grid_nodes, roi_tracks
from .triangulation import _triangulation, frame_contacts, triangle_edges

__all__ = ["deformation_budget", "budget_chunks", "event_shear"]

_GRID_COLUMNS = ("frame", "node", "x", "y", "row", "col")


def _columns():
    names = []
    for term in DEFORMATION_TERMS:
        names.extend([f"{term}_xx", f"{term}_xy"] + ([f"{term}_iso"] if term in ISOTROPIC_TERMS else []))
    return names + ["rotation"]


def deformation_budget(cells, vertices, cell_vertices, lineage, t1=None, *, box=None, grid=None, roi=None,
                       roi_frame=0, t1_events="quartets", tolerance=1e-12, progress=None):
    """The tissue's deformation budget between consecutive frames (the triangle method).

    The tables in memory are the one chunk of :func:`budget_chunks`.

    Parameters
    ----------
    cells, vertices, cell_vertices : pandas.DataFrame
        The movie's tables (``cells`` with ``track``).
    lineage : pandas.DataFrame
        ``track``, ``frame_start``, ``parent``, ``end`` (divisions and
        extrusions).
    t1 : pandas.DataFrame, optional
        The ``events`` table (``t1_events="quartets"``) or the
        ``neighbour_events`` table (``"neighbours"``) that names the kind of
        each T1; without it every retriangulation is a ``rearrangement``.
    box : Box, optional
        The periodic box, or None for an open image.
    grid : pandas.DataFrame, optional
        The Gamma_p grid (``frame``, ``node``, ``x``, ``y``, ``row``,
        ``col``): adds a budget per grid node (its Voronoi region; a triangle
        belongs to the node nearest its centre).
    roi : (rows, cols) int or bool array, optional
        Regions of interest drawn on frame ``roi_frame`` that follow their
        cells (:func:`roi_tracks`): adds a budget per region.
    t1_events : {"quartets", "neighbours"}
        Whether ``t1`` is the quartet table or the per-cell one.
    tolerance : float
        The closure the quadrature is refined to, relative to the size of the
        terms.
    progress : callable, optional
        ``progress(done, total)`` after each frame of the forward pass
        (``total``: the frames with cells).

    Returns
    -------
    table : pandas.DataFrame
        ``hexatissue.schema.TABLES["deformation"]`` but ``tracking_doubtful``
        (the analysis adds it): per frame pair and region, ``frame``,
        ``region``, ``region_id``, ``area`` (px^2), each term's ``_xx``,
        ``_xy`` (shear, 1/frame) and, for the terms that change areas,
        ``_iso`` (1/frame, the rate of log area), ``rotation`` (rad/frame),
        ``n_triangles`` and ``n_flipped`` (counts; -1 on region rows).
    event_shear : pandas.DataFrame
        ``event``, ``shear_xx``, ``shear_xy``: each T1's share of the T1 terms
        times the tissue's triangulated area (px^2), summed over the frames
        its triangulation changes (forward and, for a cycle, back).
    """
    _check_tables(t1_events, cells, vertices, cell_vertices, lineage)
    gridded = grid is not None and len(grid) > 0
    tables = {"cells": cells, "vertices": vertices, "cell_vertices": cell_vertices}
    if gridded:
        tables["grid"] = require_columns(grid, _GRID_COLUMNS, "grid")
    frame = cells["frame"].to_numpy(np.int64)
    spans = [(int(frame.min()), int(frame.max()))] if len(frame) else []
    K = int(cells["track"].to_numpy(np.int64).max(initial=0)) + 1
    # one chunk: every read of it is the whole tables
    chunks = _chunks(lambda first, last: tables, spans, lineage, t1, K, box, gridded, roi, roi_frame, t1_events,
                     tolerance, progress)
    parts, shares = [], []
    for _, table, share in chunks:
        parts.append(table)
        shares.append(share)
    return (parts[0] if parts else _table([])), event_shear(shares)


def budget_chunks(read, spans, lineage, t1=None, *, box=None, grid=False, roi=None, roi_frame=0,
                  t1_events="quartets", tolerance=1e-12, progress=None):
    """The deformation budget of a movie read a chunk of frames at a time (:func:`deformation_budget`'s).

    Memory holds one chunk's tables at a time, and beyond them what is kept
    per track (the lineage, the regions of interest) and per T1 (the events,
    their shares), and, for every frame, the diagonals its four-fold
    vertices and rosettes resolve into (8 bytes each: 8.7 kB a frame on a
    4,800-cell tissue with ~1,000 four-fold vertices a frame).

    Parameters
    ----------
    read : callable
        ``read(first, last)``: a dict of the ``cells``, ``vertices`` and
        ``cell_vertices`` (and ``grid`` when ``grid``) DataFrames of frames
        ``first`` to ``last``, each in its rows' order (the columns of
        :func:`deformation_budget`).  Each chunk is read twice: backwards,
        then forwards.
    spans : list of (int, int)
        The chunks' first and last frames, in frame order, not overlapping.
    lineage : pandas.DataFrame
        ``track``, ``frame_start``, ``parent``, ``end``: every track of the
        cells.
    t1, box, roi, roi_frame, t1_events, tolerance, progress
        As for :func:`deformation_budget` (``progress``'s total is the
        frames with cells).
    grid : bool
        Also a budget per node of the Gamma_p grid that ``read`` gives.

    Returns
    -------
    iterator of ((int, int), pandas.DataFrame, tuple)
        Per chunk, in frame order: its frames, the rows of the intervals
        that end in it (:func:`deformation_budget`'s ``table``; no rows
        when none does), and its T1 shares
        (event ids, shear xx, shear xy: one entry per interval that changes
        the event's triangulation), which :func:`event_shear` sums.
    """
    _check_tables(t1_events, lineage=lineage)
    spans = [(int(first), int(last)) for first, last in spans]
    if any(b[0] <= a[1] for a, b in zip(spans, spans[1:])) or any(first > last for first, last in spans):
        raise InputError(f"spans must be (first, last) frames in order, not overlapping; got {spans}")
    K = int(lineage["track"].to_numpy(np.int64).max(initial=0)) + 1
    return _chunks(read, spans, lineage, t1, K, box, bool(grid), roi, roi_frame, t1_events, tolerance, progress)


def _check_tables(t1_events, cells=None, vertices=None, cell_vertices=None, lineage=None):
    if t1_events not in T1_SOURCES:
        raise InputError(f"t1_events must be one of {T1_SOURCES}; got {t1_events!r}")
    for table, columns, name in ((cells, ("frame", "cell", "track", "x", "y"), "cells"),
                                 (vertices, ("frame", "vertex", "x", "y", "is_border"), "vertices"),
                                 (cell_vertices, ("frame", "cell", "vertex"), "cell_vertices"),
                                 (lineage, ("track", "frame_start", "parent", "end"), "lineage")):
        if table is not None:
            require_columns(table, columns, name)


class _Movie(NamedTuple):
    """What every interval's budget needs beyond its two frames: per track, per T1, per frame's rings."""

    box: object
    K: int  # above every track id: the base of the pair keys
    lineage: _Lineage
    candidates: _Candidates
    members: tuple | None  # the regions of interest: (_Membership, number of labels)
    grid: bool
    later: dict  # frame -> the sorted pair keys its rings resolve into (_resolved_into)
    tolerance: float


class _Carry(NamedTuple):
    """The forward pass's state between chunks: the last frame triangulated (``time``, None before the first),
    its triangulation's pair keys (``edges``), its triangles (``triangles``: ids, corners), its contacts, and its
    rows of ``cells`` and ``grid`` (the interval into the next chunk's first frame starts from them)."""

    time: int | None = None
    edges: np.ndarray | None = None
    triangles: tuple | None = None
    contacts: np.ndarray | None = None
    cells: pd.DataFrame | None = None
    grid: pd.DataFrame | None = None


def _chunks(read, spans, lineage, t1, K, box, grid, roi, roi_frame, t1_events, tolerance, progress):
    members = None
    if roi is not None:
        at = read(roi_frame, roi_frame)["cells"] if spans else None
        if at is None or not (at["frame"].to_numpy() == roi_frame).any():
            first, last = (spans[0][0], spans[-1][1]) if spans else (0, -1)
            raise InputError(f"roi_frame {roi_frame} has no cells; the movie's frames are {first}..{last}")
        members = _Membership(roi_tracks(at, lineage, roi, roi_frame))
        members = (members, int(members.values.max()) + 1 if len(members.values) else 1)
    later, total = _resolved_into(read, spans, K, box)
    movie = _Movie(box, K, _Lineage(lineage), _Candidates(t1, t1_events), members, grid, later, tolerance)
    carry = _Carry()
    done = 0

    def step():
        nonlocal done
        done += 1
        progress(done, total)

    for first, last in spans:
        table, share, carry = _chunk_budget(read(first, last), (first, last), carry, movie,
                                            None if progress is None else step)
        yield (first, last), table, share


def _resolved_into(read, spans, K, box):
    """The backward pass: for each frame, the pair keys of the triangulation after it that its four-fold vertices
    and rosettes may take their diagonals from; and how many frames have cells.

    A ring the previous frame says nothing about (held since the first frame, or formed from other contacts)
    takes the fan with the most diagonals of the triangulation it resolves into, so that resolving into
    those contacts later is no retriangulation that no event explains.  That triangulation is the next
    frame's, itself chosen the same way from the frame after it, back from the last frame (a gap in the
    frames ends the chain).  Only its keys of the frame's rings' diagonals are kept: those are the only ones a
    ring's fan asks about.  Kept whole, the keys would be ~2.8 per cell and frame (106 kB a frame on the
    4,800-cell benchmark movie, ``voronoi_movie(4800, (1024, 1024), F, amplitude=0.3)``: 0.22 GB over its
    2,083 frames); its rings' diagonals are 8.7 kB a frame (1,080 keys, 18 MB over 2,083 frames), small
    enough to keep in memory rather than on disk.
    """
    later, following, after, total = {}, None, None, 0
    for first, last in reversed(spans):
        tables = read(first, last)
        frames = _Frames(tables["cells"], box)
        if len(frames.track) and int(frames.track.max()) >= K:
            raise InputError(f"cells has track {int(frames.track.max())}, above every track of the lineage "
                             f"({K - 1}): the lineage must list every track of the cells")
        index = _FrameTables(tables)
        for t in sorted(frames.bounds, reverse=True):
            if not first <= t <= last:
                continue
            total += 1
            if after is not None and after != t + 1:
                following = None
            ids, _, diagonals = _triangles(frames, index, t, K, following)
            if following is not None:
                kept = following[in_sorted(following, diagonals)]
                if len(kept):
                    later[t] = kept
            following = triangle_edges(ids, K)
            after = t
    return later, total


def _chunk_budget(tables, span, carry, movie, step=None):
    """The budget of the intervals that end in the chunk of frames ``span``.

    Parameters
    ----------
    tables : dict of pandas.DataFrame
        ``cells``, ``vertices``, ``cell_vertices`` (and ``grid``) of the
        chunk's frames.
    span : (int, int)
        The chunk's first and last frame.
    carry : _Carry
        The forward pass's state after the frames before the chunk
        (``_Carry()`` before the first).
    movie : _Movie
        What the intervals need beyond their frames (the lineage, the T1s,
        the regions, the backward pass's keys).
    step : callable, optional
        Called after each frame of the chunk.

    Returns
    -------
    table : pandas.DataFrame
        The intervals' rows (:func:`deformation_budget`'s ``table``).
    shares : tuple of arrays
        Event ids, shear xx and xy (px^2) of each T1 each interval matched.
    carry : _Carry
        The state after the chunk's last frame.
    """
    first, last = span
    box, K = movie.box, movie.K
    cells, grid = tables["cells"], tables.get("grid") if movie.grid else None
    if carry.cells is not None:  # the last frame before the chunk, where the interval into its first frame starts
        cells = pd.concat([carry.cells, cells], ignore_index=True)
        grid = pd.concat([carry.grid, grid], ignore_index=True) if movie.grid else None
    frames = _Frames(cells, box)
    index = _FrameTables(tables)
    layers = _Layers(_grid_nodes(grid) if movie.grid else None, movie.members, box)
    rows, events = [], []
    for t in sorted(frames.bounds):
        if not first <= t <= last:  # the frame before the chunk: its triangulation is carried too
            continue
        tri = _triangles(frames, index, t, K, carry.edges, movie.later.get(t))[:2]
        sl = frames.rows(t)
        contacts = frame_contacts(frames.track[sl], frames.cell[sl], index.part("cell_vertices", t), K)
        if carry.triangles is not None and t == carry.time + 1:
            blocks, ev, info = _pair(frames, movie.lineage, layers, t - 1, carry.triangles, tri, movie.candidates,
                                     movie.tolerance, K, (carry.contacts, contacts))
            rows.append(_rows(t - 1, blocks, layers, info))
            events.extend(ev)
        carry = _Carry(t, triangle_edges(tri[0], K), tri, contacts)
        if step is not None:
            step()
    if carry.time is not None and first <= carry.time <= last:
        carry = carry._replace(cells=cells[cells["frame"].to_numpy() == carry.time],
                               grid=grid[grid["frame"].to_numpy() == carry.time] if movie.grid else None)
    ids, sxx, sxy = (np.array(v, dtype) for v, dtype in zip(zip(*events) if events else ((), (), ()),
                                                            (np.int64, float, float)))
    return _table(rows), (ids, sxx, sxy), carry


def event_shear(shares):
    """Each T1's shear summed over the chunks' ``shares`` (:func:`budget_chunks`): ``event``, ``shear_xx``,
    ``shear_xy`` (px^2), one row per event, by event id."""
    ids, sxx, sxy = (np.concatenate([s[k] for s in shares]) if shares else np.zeros(0, dtype)
                     for k, dtype in enumerate((np.int64, float, float)))
    return pd.DataFrame({"event": ids, "shear_xx": sxx, "shear_xy": sxy}).groupby("event", as_index=False).sum()


class _FrameTables:
    """The ``vertices`` and ``cell_vertices`` of a chunk by frame (each frame's rows in the table's order)."""

    def __init__(self, tables):
        self.tables = {name: tables[name] for name in ("vertices", "cell_vertices")}
        self.index = {name: _frame_index(table) for name, table in self.tables.items()}

    def part(self, name, t):
        order, bounds = self.index[name]
        a, b = bounds.get(t, (0, 0))
        return self.tables[name].iloc[order[a:b]]


def _triangles(frames, index, t, K, before, after=None):
    """Frame ``t``'s triangles (ids, corners) and the pair keys of its rings' diagonals (:func:`_triangulation`)."""
    sl = frames.rows(t)
    return _triangulation(frames.track[sl], frames.xy[sl], frames.cell[sl], index.part("vertices", t),
                           index.part("cell_vertices", t), frames.box, before, frames.interior[sl], K, after)


def _frame_index(table):
    frame = table["frame"].to_numpy(np.int64)
    order = np.argsort(frame, kind="stable")
    return order, {int(f): (a, b) for f, a, b in _runs(frame[order])}


def _rows(t, blocks, layers, info):
    """The interval's rows, as per-layer dicts of numpy columns (one DataFrame is made per chunk)."""
    names = _columns()
    parts = []
    for i, (layer, block) in enumerate(zip(layers.names(), blocks)):
        present = info["complete"][i]
        n = int(present.sum())
        if layer == "grid":
            region_id = layers.grid[t][0]
        else:
            region_id = np.arange(block.shape[1]) if layer == "roi" else np.full(block.shape[1], -1)
        columns = {"frame": np.full(n, t, np.int64), "region": np.full(n, layer, object),
                   "region_id": region_id[present].astype(np.int64), "area": info["area"][i][present]}
        columns.update(zip(names, block[:, present]))
        columns["n_triangles"] = np.full(n, info["n_triangles"] if layer == "tissue" else -1, np.int64)
        columns["n_flipped"] = np.full(n, info["n_flipped"] if layer == "tissue" else -1, np.int64)
        parts.append(columns)
    return parts


def _table(rows):
    """The ``deformation`` table from the intervals' column dicts."""
    parts = [part for interval in rows for part in interval]
    if not parts:
        return empty_table("deformation")
    # its columns as they are joined, not copied again into one block per dtype (a chunk's rows of a 4,800-cell
    # movie with its grid are ~100 MB)
    table = pd.DataFrame({name: np.concatenate([p[name] for p in parts]) for name in parts[0]}, copy=False)
    table["region"] = table["region"].astype("string")
    return table
