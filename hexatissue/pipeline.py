"""The analysis spine: ``analyze(source) -> Movie``.

One function strings every stage together, frame by frame:

    open_source(...)  ->  per frame, in parallel: labels -> junction network (mesh)
                                                  -> gamma_p, Gamma_p and defects (order)
                      ->  in frame order, in this process: overlap tracking
                      ->  over the movie: lineage, T1 events, per-cell statistics,
                                          defect tracks and pair events
                      ->  Movie  ->  Movie.write(folder)  <->  read_results(folder)

Frames are read one at a time from the :class:`~hexatissue.Source` and sent
to the workers in batches of consecutive frames; at most a few batches are
in flight, so memory does not grow with the movie's length beyond its output
tables.  The workers also compact each frame's labels and count their
overlaps with the previous frame, so the tracker only links cells.  The
per-frame work runs in a local process pool (default) or on a
dask.distributed cluster (``client``).  Conventions: label images are
indexed ``[row, col]``; tables use ``x`` = column, ``y`` = row, in px, origin
at the centre of pixel (0, 0); times in frames.
"""
from __future__ import annotations

import json
import os
import pickle
import warnings
from collections import deque

import numpy as np
import pandas as pd

from ._system import libc, release_freed_memory, reserve
from .box import as_box
from .errors import HexatissueWarning, InputError, check_positive, user_stacklevel
from .events import cell_event_stats, default_censor, t1_tables
from .frame import MESH_TABLES, Movie
from .options import EventOptions, MeshOptions, OrderOptions, TrackOptions, check_options
from .geometry import distinct_count, row_keys
from .mesh.labels import mesh_labels
from .schema import empty_table, interior_mask, rows_by_frame, validate
from .source import read_mask
from .track import MovieTracker, lineage_table

__all__ = ["analyze"]

#: Tables produced frame by frame (and saved in checkpoints).
FRAME_TABLES = MESH_TABLES + ("grid", "defects")
DEFECT_SPACINGS = 1.5  # default largest defect displacement between frames, in grid spacings


def analyze(source, *, box=None, mesh=MeshOptions(), order=OrderOptions(), track=TrackOptions(),
            events=EventOptions(), mask=None, intensity=None, client=None, workers=None, checkpoint=None,
            checkpoint_every=100, progress=True) -> Movie:
    """Every table of a label image, label movie or MPF run: networks, order, defects, tracks, T1 events.

    Parameters
    ----------
    source : Source or anything :func:`hexatissue.open_source` accepts
        A path (label image or stack, MPF run, ...), an array, a list of
        frames or an opened :class:`~hexatissue.Source`.  0 = background or
        membrane.
    box : Box, True, False or None
        Periodic box of the frames (``True``: the box covering the frame
        shape); ``False`` forces an open image; None (default): the source's
        own box (MPF runs), else an open image.
    mesh, order, track, events : MeshOptions, OrderOptions, TrackOptions, EventOptions
        Options of each stage (see :mod:`hexatissue.options`).
    mask : array or path, optional
        Region of interest of every frame: a 2-D bool or integer image
        (nonzero = inside) of the frames' shape, or a path to one (read with
        :func:`hexatissue.open_source`, one frame).  Pixels outside it are 0,
        so cells outside vanish and cells cut by its edge are border cells.
        Recorded as ``source["mask"]`` in ``metadata.json``.
    intensity : Source, path or array, optional
        A raw channel (e.g. E-cadherin, myosin) of the same shape, with one
        frame per frame of ``source`` or one frame for all: measured along
        every junction and in every cell (:func:`hexatissue.intensity.measure_intensity`;
        columns ``intensity_mean``, ``intensity_total`` in ``edges`` and
        ``intensity_mean``, ``junction_polarity_re/_im`` in ``cells``).
        Recorded as ``source["intensity"]`` in ``metadata.json``.
    client : dask.distributed.Client, optional
        Run the per-frame work on this cluster.
    workers : int, optional
        Local processes when no client is given (default: all cores; 1 runs
        in this process).
    checkpoint : str or Path, optional
        Folder for checkpoints: every ``checkpoint_every`` frames the tables
        of the finished frames and the tracker state are saved there
        (atomically); a later call with the same source and options resumes
        after the last checkpoint.  The folder is locked while a run uses it
        (``checkpoint.lock``): a second run on it raises InputError.  The tracker state is a pickle: only
        resume from folders you wrote yourself.
    checkpoint_every : int
        Frames per checkpoint.
    progress : bool or tqdm class
        Show a progress bar (on a terminal; see :mod:`hexatissue.progress`);
        a tqdm subclass (e.g. ``napari.utils.progress``) draws it with that class.

    Returns
    -------
    Movie
        ``cells`` (mesh columns, ``track``, ``gamma{p}_re/_im``),
        ``vertices``, ``edges``, ``cell_vertices``, ``grid`` (``Gamma{p}``
        for every p, :func:`~hexatissue.coarse_grain`), ``defects`` (every
        p, with defect ``track``), ``defect_events``, ``events`` (T1s,
        :func:`~hexatissue.detect_t1`), ``neighbour_events`` (the paper's
        per-cell definition, :func:`~hexatissue.events.neighbour_events`), ``lineage``
        (:func:`~hexatissue.track.lineage_table`) and ``cell_events``
        (:func:`~hexatissue.events.cell_event_stats`); every table has a
        ``frame`` column except the per-event and per-track ones.  Columns
        and units: :func:`hexatissue.schema.describe`.  The Movie carries the
        box, shape, calibration (pixel size, frame interval), the options
        used (``track.mode`` and ``events.censor`` resolved: see
        :class:`~hexatissue.TrackOptions` and
        :func:`~hexatissue.events.default_censor`), ``summary`` (what
        tracking decided and changed, the censoring window and how many T1s
        it left classifiable) and the source's description.

    Warns
    -----
    HexatissueWarning
        When no T1 event is an intercalation because every one that is not
        undone is ``unresolved`` (the censoring window covers them all).
    """
    from ._version import __version__
    from .source import open_source

    src = open_source(source)
    for name, value in (("mesh", mesh), ("order", order), ("track", track), ("events", events)):
        check_options(value, name)
    if src.kind == "polygons":
        _check_polygon_run(box, mask, intensity, track)
    box = src.box if box is None else as_box(box, src.shape)
    mask, mask_info = read_mask(mask, src.shape)
    raw = _intensity_source(intensity, src)
    tracker = MovieTracker(track.mode, track.min_iou, track.child_fraction, track.mother_fraction, track.max_gap,
                           ids_consistent=src.ids_consistent, independent=src.independent)
    store = None
    if checkpoint is not None:
        requested = {"mesh": mesh, "order": order, "track": track, "events": events}
        key = dict(n_frames=src.n_frames, shape=list(src.shape), box=None if box is None else box.to_list(),
                   source=src.description, options={k: v.to_dict() for k, v in requested.items()}, mask=mask_info,
                   intensity=None if raw is None else raw.description)
        store = _Checkpoint(checkpoint, key, checkpoint_every)
    rows, tracker = _extract(src, box, mesh, order, mask, raw, tracker, client, workers, store, progress)
    release_freed_memory()  # the frames' freed temporaries, before the movie-level stages
    tables = {name: rows.pop(name).table(name, order.p) for name in FRAME_TABLES}
    cells = _with_tracks(tables["cells"], tracker)
    tables["cells"] = cells
    # a source that records its divisions (CTC folders) is the lineage wherever its ids are the tracks
    keep_ids = src.parents is not None and tracker.decision()[0] == "never"
    parents = src.parents if keep_ids else tracker.parents
    tables["lineage"] = lineage_table(cells[["frame", "track"]], parents, cells["is_border"].to_numpy(bool))
    tracking = _tracking_summary(tracker, cells, parents)
    del tracker, parents  # its per-cell-frame ids are in cells now; the movie-level stages need the memory
    release_freed_memory()  # after each movie-level stage: its freed working set would stay under the next
    if order.fields:  # first of the movie-level stages: each leaves some memory resident, and it needs the most
        _warn_frames_without_field(cells, tables["grid"], src.n_frames)
        _defect_tracks(tables, order, box, src.n_frames, linked=tracking["resolved"] != "off")
        release_freed_memory()
    else:
        del tables["grid"], tables["defects"]
    censor = default_censor(src.n_frames) if events.censor is None else events.censor
    # quartet T1s and per-cell neighbour changes from one pass over the contacts
    tables["events"], tables["neighbour_events"] = t1_tables(tables["edges"], cells, events.min_length, censor, box)
    release_freed_memory()  # else the statistics' working set comes on top of the T1 stage's freed ~20 MB
    tables["cell_events"] = cell_event_stats(tables["events"], cells)
    release_freed_memory()
    summary = {"tracking": tracking, "events": _events_summary(tables["events"], events, censor, src.n_frames)}
    options = {"mesh": mesh, "order": order, "track": track.replace(mode=summary["tracking"]["resolved"]),
               "events": events.replace(censor=censor)}
    return Movie(**tables, box=box, shape=tuple(src.shape), n_frames=src.n_frames, calibration=src.calibration,
                 options=options, source=_described(src.description, mask_info, raw), version=__version__,
                 summary=summary)


def _described(description, mask_info, raw):
    """The source's description with the mask and the intensity channel used."""
    out = dict(description)
    if mask_info is not None:
        out["mask"] = mask_info
    if raw is not None:
        out["intensity"] = raw.description
    return out


def _intensity_source(intensity, src):
    """The raw channel as a Source of the labels' shape, one frame per frame or one for all (or None)."""
    from .source import open_source

    if intensity is None:
        return None
    try:
        raw = open_source(intensity)
    except InputError as exc:
        raise InputError(f"intensity: {exc}") from None
    if raw.shape != src.shape or raw.n_frames not in (1, src.n_frames):
        raise InputError(f"intensity has {raw.n_frames} frame(s) of {raw.shape}; expected {src.n_frames} frame(s) "
                         f"(or one) of the labels' shape {src.shape}")
    return raw


class _Rows:
    """One table of the movie, filled frame by frame into one growing buffer per column.

    What ``pd.concat`` of the per-frame tables gives, without keeping them:
    each frame's table is copied into the buffers on arrival and dropped, so
    its memory is reused by the next frame, and :meth:`table` wraps the
    buffers without a copy.  (Keeping thousands of small per-frame tables,
    then concatenating them, holds the movie twice at the end, and the C
    heap keeps the freed parts resident.)  Buffers are reserved for the
    expected number of rows and doubled when full; the reserved tail is
    never written, so it costs address space, not memory
    (:func:`~hexatissue._system.reserve`).  Frames whose
    columns or dtypes differ from the first one's (or non-NumPy dtypes) fall
    back to ``pd.concat``.
    """

    def __init__(self, expected_frames=1):
        self.expected_frames = max(int(expected_frames), 1)
        self.n = 0
        self.names = self.dtypes = self.buffers = None
        self.parts = None  # the pd.concat fallback

    def append(self, df, frames=1):
        """Add the rows of ``df`` (the table of ``frames`` frames, used to size the buffers).

        ``df`` is a DataFrame or, as the frame job returns the network tables,
        a dict of numpy columns (reading those is free; ``df[name]`` is not).
        """
        if isinstance(df, dict):
            names, dtypes, n_rows = list(df), [a.dtype for a in df.values()], len(next(iter(df.values())))
            column = df.__getitem__
        else:
            names, dtypes, n_rows = list(df.columns), list(df.dtypes), len(df)
            column = lambda name: df[name].to_numpy()  # noqa: E731
        if self.parts is not None:
            self.parts.append(pd.DataFrame(df))
            return
        if self.buffers is None:
            if not all(isinstance(dt, np.dtype) for dt in dtypes):
                self.parts = [pd.DataFrame(df)]
                return
            self.names, self.dtypes = names, dtypes
            capacity = int(1.1 * max(n_rows, 1) / max(frames, 1) * self.expected_frames) + 16
            self.buffers = [reserve(capacity, dt) for dt in self.dtypes]
        elif names != self.names or dtypes != self.dtypes:
            self.parts = [self.table(), pd.DataFrame(df)]
            self.names = self.dtypes = self.buffers = None
            return
        end = self.n + n_rows
        if end > len(self.buffers[0]):
            capacity = max(end, 2 * len(self.buffers[0]))
            for k, old in enumerate(self.buffers):  # one column at a time
                new = reserve(capacity, old.dtype)
                new[:self.n] = old[:self.n]
                self.buffers[k] = new
                del old, new
        for buf, name in zip(self.buffers, self.names):
            buf[self.n:end] = column(name)
        self.n = end

    def table(self, name=None, orders=None, start=0) -> pd.DataFrame:
        """The rows from ``start`` on (views of the buffers); ``empty_table(name, orders)`` if nothing came."""
        if self.parts is not None:
            out = pd.concat(self.parts, ignore_index=True)
            return out.iloc[start:].reset_index(drop=True) if start else out
        if self.buffers is None:
            return empty_table(name, orders)
        out = pd.DataFrame({n: buf[start:self.n] for n, buf in zip(self.names, self.buffers)}, copy=False)
        return validate(out, name) if name is not None else out  # the frame job's columns are checked here


def _with_tracks(cells, tracker):
    """``cells`` with a ``track`` column after ``cell``, from the tracker's ``(frame, cell) -> track``."""
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


def _tracking_summary(tracker, cells, parents):
    """The tracker's decision and what it changed: rows whose track differs from the id, tracks, divisions."""
    out = tracker.summary()
    ids, tracks = cells["cell"].to_numpy(), cells["track"].to_numpy()
    out.update(rows_track_not_cell=int((tracks != ids).sum()), n_ids=distinct_count(ids),
               n_tracks=distinct_count(tracks), n_divisions=len(set(parents.values())))
    return out


#: Warning when the censoring window leaves no T1 to count as an intercalation.
NO_INTERCALATION = ("no T1 event is classified as an intercalation: every T1 that is not undone starts within the "
                    "censoring window of the movie's end and is unresolved (see EventOptions.censor and "
                    "movie.summary['events'])")


def _events_summary(events, options, censor, n_frames):
    """Censoring window used (and where it came from) and the number of events of each kind."""
    counts = events["kind"].astype(str).value_counts()
    n = {kind: int(counts.get(kind, 0)) for kind in ("cycle", "intercalation", "unresolved")}
    if n["unresolved"] and not n["intercalation"]:
        warnings.warn(NO_INTERCALATION, HexatissueWarning, stacklevel=3)
    rule = "given" if options.censor is not None else "min(10, max(1, n_frames // 5))"
    return {"censor": int(censor), "censor_rule": rule, "n_frames": int(n_frames), "n_events": int(len(events)),
            "n_cycles": n["cycle"], "n_intercalations": n["intercalation"], "n_unresolved": n["unresolved"],
            "n_classified": n["cycle"] + n["intercalation"]}


def _warn_frames_without_field(cells, grid, n_frames):
    missing = n_frames - distinct_count(grid["frame"].to_numpy()) if len(cells) else 0
    if missing:
        warnings.warn(f"{missing} of {n_frames} frame(s) have no interior cell with a polygon: no Gamma_p field "
                      f"or defects there", HexatissueWarning, stacklevel=3)


def _defect_tracks(tables, order, box, n_frames, linked=True):
    """Link ``tables["defects"]`` over frames per p (``track``); add their pair events as ``tables["defect_events"]``.

    With ``linked`` False (frames that are unrelated images) every frame is
    tracked alone: each defect is its own track and there are no pair events.
    The tables come in a dict so that the untracked defects are freed column
    by column as the tracked table is built (an argument would stay
    referenced by the caller for the whole call); tracking reads a copy of
    four columns of each p, not of the whole table.
    """
    from .defects import defect_events, track_defects

    defects, grid = tables.pop("defects"), tables["grid"]

    groups = [np.arange(n_frames)] if linked else [np.array([t]) for t in range(n_frames)]
    max_distance = order.defect_max_distance
    if max_distance is None:
        spacing = grid["spacing"].to_numpy(float)
        max_distance = DEFECT_SPACINGS * float(np.median(spacing)) if len(spacing) else 1.0
        release_freed_memory()  # np.median's sorted copy of the grid column would stay resident under the tracking
    p = defects["p"].to_numpy()
    track = np.zeros(len(defects), np.int64)
    pair_events = []
    for q in order.p:
        rows = np.flatnonzero(p == q)
        # only the columns tracking reads, not a copy of the table per p
        of_p = pd.DataFrame({c: defects[c].to_numpy()[rows] for c in ("frame", "x", "y", "charge")})
        rows_of = None if linked else rows_by_frame(of_p["frame"].to_numpy())  # not one scan per frame
        n_tracks = 0
        for frames in groups:
            at = slice(None) if linked else rows_of.get(int(frames[0]), np.zeros(0, np.int64))
            t = track_defects(of_p if linked else of_p.iloc[at], max_distance, box=box, frames=frames)
            t["track"] += n_tracks
            n_tracks = int(t["track"].max()) + 1 if len(t) else n_tracks
            track[rows[at]] = t["track"].to_numpy()
            pair_events.append(defect_events(t, max_distance, box=box, frames=frames).assign(p=np.int64(q)))
            del t
        del of_p, rows_of
        release_freed_memory()  # tracking and pairing leave freed memory resident under the next p
    # the rows of every p, by frame, p and defect (a stable sort), taken one column at a time from the
    # table given away: at most one column more than the defects table in memory
    rows = np.lexsort((defects["defect"].to_numpy(), p, defects["frame"].to_numpy()))
    rows = rows[np.isin(p[rows], order.p)]
    del p
    columns = {c: defects.pop(c).to_numpy()[rows] for c in list(defects.columns) if c != "track"}
    del defects
    columns["track"] = track[rows]
    pair_events = pd.concat(pair_events, ignore_index=True)
    tables["defects"] = validate(pd.DataFrame(columns, copy=False), "defects")
    tables["defect_events"] = validate(pair_events.astype({"frame": np.int64}), "defect_events")


# ----------------------------------------------------------------------------
# One frame: mesh and order stages (runs in a worker)
# ----------------------------------------------------------------------------

def _frame_job(labels, t, box, mesh, order, mask=None, image=None, ids=(None, None)):
    """Tables of one frame, its normalised labels (for the tracker) and its warnings.

    ``ids``: the smallest and largest id of ``labels`` if known (found when
    the source checked the frame: :meth:`hexatissue.Source.checked_frame`),
    else None: the mesh then needs no pass over the image for them.

    Warnings are caught here, in the worker, and returned as ``(category,
    text)`` pairs, so the main process reports them with their frames.
    The shape functions come from the polygons the mesh built.  Without an
    intensity image the network tables are dicts of numpy columns (checked
    against the schema when the movie's tables are assembled, in
    ``_Rows.table``); the grid and defects are DataFrames.
    """
    from .mesh.network import as_tables, network_columns
    from .order import gamma_arrays, gamma_columns, polygon_rows

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        lab, membrane = mesh_labels(labels, box, mesh, mask, ids[0])
        # the largest id is known while the labels are the ones checked
        columns, polygons = network_columns(lab, membrane, box, mesh.merge_distance, t,
                                            ids[1] if lab is labels else None)
        if image is None:  # numpy columns: no network DataFrame to build here, pickle or read in the main process
            cells = columns["cells"]
            cells.update(gamma_arrays(*polygons, polygon_rows(cells["n_sides"] > 0), order.p, order.center))
            tables = columns
        else:
            from .intensity import measure_intensity

            tables = as_tables(columns)
            cells, tables["edges"] = measure_intensity(tables["cells"], tables["vertices"], tables["edges"],
                                                       lab, image, box)
            tables["cells"] = validate(gamma_columns(cells, None, None, box, order.p, order.center, polygons),
                                       "cells")
        if order.fields:
            tables.update(_order_fields(validate(pd.DataFrame(tables["cells"]), "cells"), box, order))
    found = [(w.category, str(w.message)) for w in caught]
    return tables, lab, found


def _polygon_job(polygons, t, order):
    """Tables of one frame of cell polygons, its cell ids (for the tracker) and its warnings."""
    from .order import gamma_columns
    from .mesh.polygons import polygon_network

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        tables = polygon_network(polygons, t, where=f"frame {t}")
        tables["cells"] = validate(gamma_columns(tables["cells"], tables["vertices"], tables["cell_vertices"], None,
                                                 order.p, order.center), "cells")
        if order.fields:
            tables.update(_order_fields(tables["cells"], None, order))
    return tables, polygons.cell, [(w.category, str(w.message)) for w in caught]


def _batch_job(job, batch, pixels):
    """``job`` (:func:`_frame_job` or :func:`_polygon_job`) of consecutive frames, in one task.

    ``batch`` holds the job's arguments for each frame.  Label frames come
    back compacted for the tracker, with their overlaps with the batch's
    previous frame counted here (:func:`hexatissue.track.compact_frames`;
    ``pixels``: keep every frame's pixels, for gap closing), so that the main
    process only links them; polygon frames come back as their cell ids.
    Returns ``[(tables, labels, overlaps or None, warnings), ...]`` in frame order.
    """
    from .track import compact_frames

    done = [job(*args) for args in batch]
    if job is _polygon_job:
        return [(tables, ids, None, found) for tables, ids, found in done]
    tracked = compact_frames([labels for _, labels, _ in done], pixels)
    return [(tables, labels, overlaps, found) for (tables, _, found), (labels, overlaps) in zip(done, tracked)]


def _check_polygon_run(box, mask, intensity, track):
    """Refuse what cell polygons cannot have: a periodic box, a mask, a raw channel, overlap tracking."""
    if box is not None and box is not False:
        raise InputError(f"box={box!r}: cell polygons are an open image; a periodic box needs label images")
    for name, value in (("mask", mask), ("intensity", intensity)):
        if value is not None:
            raise InputError(f"{name}= needs a label image; the source holds cell polygons (no pixels)")
    if track.mode == "always":
        raise InputError("track mode 'always' (overlap tracking) needs label images; cells given as polygons are "
                         "tracked by their ids: use 'never' (ids are tracks), 'off' or 'auto'")


class _FrameWarnings:
    """Warnings of the frame jobs, reported once per distinct text with the frames it occurred in."""

    def __init__(self):
        self.frames = {}

    def add(self, t, found):
        for category, text in found:
            self.frames.setdefault((category, text), []).append(int(t))

    def emit(self):
        for (category, text), frames in self.frames.items():
            frames = sorted(set(frames))
            shown = ", ".join(str(f) for f in frames[:10]) + (f", ... ({len(frames)} frames)" if len(frames) > 10
                                                              else "")
            warnings.warn(f"frame{'s' if len(frames) > 1 else ''} {shown}: {text}", category,
                          stacklevel=user_stacklevel())


def _order_fields(cells, box, order):
    """The fields of one frame's order stage: the grid and defects of every p."""
    from .defects import find_defects
    from .order import coarse_grain

    first = order.p[0]
    usable = interior_mask(cells) & np.isfinite(cells[f"gamma{first}_re"].to_numpy(float))
    if not usable.any():
        return {"grid": empty_table("grid", order.p), "defects": empty_table("defects")}
    grid = coarse_grain(cells, p=order.p, radius=order.radius, spacing=order.spacing, box=box,
                        min_coverage=order.min_coverage, r_cell=order.r_cell, origin=order.origin,
                        shape=order.shape, validity=order.validity)
    return {"grid": grid, "defects": find_defects(grid, p=order.p, box=box)}


# ----------------------------------------------------------------------------
# Executors and the frame loop
# ----------------------------------------------------------------------------

class _Serial:
    """An executor running jobs in the calling process (workers=1)."""

    class _Done:
        def __init__(self, value):
            self._value = value

        def result(self):
            return self._value

    def submit(self, fn, *args):
        return self._Done(fn(*args))

    def shutdown(self):
        pass


class _Dask:
    """Adapter submitting jobs to a dask.distributed client."""

    def __init__(self, client):
        self.client = client

    def submit(self, fn, *args):
        return self.client.submit(fn, *args, pure=False)

    def shutdown(self):
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

    Workers are forked where the OS allows it: they start at once and need no
    importable ``__main__`` (scripts piped to Python, notebooks).  The mesh
    kernels are serial numba code, so no numba thread pool is forked.
    Elsewhere (Windows) the platform's default start method is used.
    """

    def __init__(self, n_workers):
        import multiprocessing as mp
        from concurrent.futures import ProcessPoolExecutor

        from . import track
        from .mesh import warm_up

        method = "fork" if "fork" in mp.get_all_start_methods() else None
        if method == "fork":
            warm_up()  # compile the kernels once here; forked workers inherit them
            track.warm_up()
        self.pool = ProcessPoolExecutor(max_workers=n_workers, mp_context=mp.get_context(method),
                                        initializer=_die_with_parent)

    def submit(self, fn, *args):
        return self.pool.submit(fn, *args)

    def shutdown(self):
        self.pool.shutdown(wait=True, cancel_futures=True)


def _executor(client, workers, n_frames):
    """``(executor, tasks kept in flight)``: twice the workers, so none waits while the main process collects."""
    if client is not None:
        threads = sum(client.nthreads().values()) if hasattr(client, "nthreads") else 1
        return _Dask(client), max(2, 2 * threads)
    workers = (os.cpu_count() or 1) if workers is None else check_positive(workers, "workers", integer=True)
    workers = min(workers, n_frames)
    if workers == 1:
        return _Serial(), 1
    return _Pool(workers), 2 * workers


#: Frames per task: as many as hold about this many pixels (one task's IPC and bookkeeping for several
#: small frames), at most BATCH_FRAMES, and few enough that every task in flight has frames.
BATCH_PIXELS = 2**20
BATCH_FRAMES = 8


def _batch_size(n_frames, shape, max_inflight):
    """Frames per task for ``n_frames`` frames of ``shape`` with ``max_inflight`` tasks in flight."""
    by_pixels = BATCH_PIXELS // max(int(np.prod(shape)), 1)
    return int(max(1, min(BATCH_FRAMES, by_pixels, n_frames // (2 * max_inflight))))


def _extract(src, box, mesh, order, mask, raw, tracker, client, workers, store, progress):
    """Per-frame tables (in frame order) and the tracker, with a bounded number of frames in flight.

    A checkpoint folder is locked for the whole extraction: two runs cannot share it.
    """
    if store is not None:
        store.lock()
        try:
            return _extract_locked(src, box, mesh, order, mask, raw, tracker, client, workers, store, progress)
        finally:
            store.unlock()
    return _extract_locked(src, box, mesh, order, mask, raw, tracker, client, workers, store, progress)


def _extract_locked(src, box, mesh, order, mask, raw, tracker, client, workers, store, progress):
    """The frame loop: batches of consecutive frames go to the executor; their results are tracked in order.

    A batch never spans a checkpoint (its last frame keeps its pixels, which
    the checkpointed tracker holds for the next frame's overlaps).
    """
    from .progress import progress as progress_bar

    n_frames = src.n_frames
    rows = {name: _Rows(n_frames) for name in FRAME_TABLES}
    start = 0
    if store is not None:
        start, loaded, saved_tracker = store.load()
        if start:
            tracker = saved_tracker
            for name, tables in loaded.items():
                for table in tables:
                    rows[name].append(table, frames=table["frame"].nunique() if "frame" in table else 1)
    if start >= n_frames:
        return rows, tracker
    executor, max_inflight = _executor(client, workers, n_frames - start)
    batch_size = _batch_size(n_frames - start, src.shape, max_inflight)
    pending: deque = deque()
    due = store.due(start, n_frames) if store is not None else set()
    saved = {name: r.n for name, r in rows.items()}  # rows already in checkpoint files

    frame_warnings = _FrameWarnings()
    polygons = src.kind == "polygons"
    job = _polygon_job if polygons else _frame_job
    pixels = not polygons and tracker.needs_pixels

    def collect(first, future):
        for t, (tables, labels, overlaps, found) in enumerate(future.result(), start=first):
            frame_warnings.add(t, found)
            if polygons:
                tracker.add_ids(labels, t)  # the cell ids: polygons have no labels to overlap
            else:
                tracker.add_valid(labels, t, overlaps)
            for name, table in tables.items():
                rows[name].append(table)
            del tables, labels, overlaps
            if t + 1 in due:
                new = {name: [r.table(start=saved[name])] for name, r in rows.items() if r.n > saved[name]}
                store.save(t + 1, new, pickle.dumps(tracker))
                saved.update({name: r.n for name, r in rows.items()})

    def frame_args(t):
        if polygons:
            return src.polygons(t), t, order
        image = None if raw is None else raw.image(t if raw.n_frames > 1 else 0)
        labels, lowest, top = src.checked_frame(t)
        return labels, t, box, mesh, order, mask, image, (lowest, top)

    try:
        batch = []
        for t in progress_bar(range(start, n_frames), enabled=progress, desc="frames", initial=start,
                              total=n_frames):
            batch.append(frame_args(t))
            if len(batch) < batch_size and t + 1 not in due and t + 1 < n_frames:
                continue
            pending.append((t + 1 - len(batch), executor.submit(_batch_job, job, batch, pixels)))
            batch = []
            while len(pending) >= max_inflight:
                collect(*pending.popleft())
        while pending:
            collect(*pending.popleft())
    finally:
        executor.shutdown()
        frame_warnings.emit()
    return rows, tracker


class _Checkpoint:
    """Frame tables and tracker state saved every ``every`` frames in ``directory``."""

    def __init__(self, directory, key, every):
        from .io import check_output_folder

        self.every = check_positive(every, "checkpoint_every", integer=True)
        self.dir = check_output_folder(directory, "checkpoint")
        self.key = json.loads(json.dumps(key))  # as it reads back from JSON
        self.state_path = self.dir / "checkpoint.json"
        self._lock = None

    def lock(self):
        """Take the folder's exclusive lock (``checkpoint.lock``, fcntl); InputError when another run holds it.

        The lock is released by :meth:`unlock`, or by the OS when the
        process ends.  Where fcntl is missing (Windows) nothing is locked.
        """
        try:
            import fcntl
        except ImportError:
            return
        self.dir.mkdir(parents=True, exist_ok=True)
        handle = open(self.dir / "checkpoint.lock", "a+")
        try:
            fcntl.flock(handle.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            handle.close()
            raise InputError(f"checkpoint folder {str(self.dir)!r} is in use by another running analysis "
                             f"(its checkpoint.lock is held); wait for it to finish or use another folder") from None
        handle.seek(0)
        handle.truncate()
        handle.write(f"{os.getpid()}\n")
        handle.flush()
        self._lock = handle

    def unlock(self):
        """Release the lock taken by :meth:`lock`."""
        if self._lock is not None:
            self._lock.close()  # closing the file releases the flock
            self._lock = None

    def _damaged(self, what):
        return InputError(f"checkpoint folder {str(self.dir)!r} is damaged ({what}); delete it (or use another "
                          f"folder) to start again")

    def due(self, start, n_frames):
        """Frame counts after which a checkpoint is written."""
        return set(range(start + self.every, n_frames + 1, self.every)) | {n_frames}

    def _state(self):
        if not self.state_path.exists():
            return None
        try:
            state = json.loads(self.state_path.read_text())
            if not (isinstance(state, dict) and {"key", "done", "files", "tracker"} <= set(state)
                    and isinstance(state["files"], dict)):
                raise ValueError("not a checkpoint state")
        except (OSError, ValueError) as exc:
            raise self._damaged(f"checkpoint.json cannot be read: {exc}") from None
        return state

    def load(self):
        """(frames done, tables, tracker) from the last checkpoint, or (0, None, None)."""
        from .io import read_table

        state = self._state()
        if state is None:
            return 0, None, None
        if state["key"] != self.key:
            raise InputError(f"checkpoint folder {str(self.dir)!r} holds another movie or other options; "
                             f"use a new folder or delete it")
        try:
            parts = {name: [read_table(self.dir / f) for f in state["files"].get(name, [])]
                     for name in FRAME_TABLES}
        except InputError as exc:
            raise self._damaged(str(exc)) from None
        tracker = None
        if state["tracker"]:
            try:
                tracker = pickle.loads((self.dir / state["tracker"]).read_bytes())
            except Exception as exc:  # missing or truncated pickle
                raise self._damaged(f"tracker state {state['tracker']!r}: {type(exc).__name__}: {exc}") from None
        return int(state["done"]), parts, tracker

    def save(self, done, new_parts, tracker_bytes):
        from .io import atomic_path

        state = self._state() or {"key": self.key, "done": 0, "files": {name: [] for name in FRAME_TABLES},
                                  "tracker": None}
        for name, tables in new_parts.items():
            if not tables:
                continue
            fname = f"{name}_{done:08d}.parquet"
            with atomic_path(self.dir / fname) as tmp:
                pd.concat(tables, ignore_index=True).to_parquet(tmp, index=False)
            state["files"][name].append(fname)
        if tracker_bytes is not None:
            fname = f"tracker_{done:08d}.pkl"
            with atomic_path(self.dir / fname) as tmp:
                tmp.write_bytes(tracker_bytes)
            if state["tracker"]:
                (self.dir / state["tracker"]).unlink(missing_ok=True)
            state["tracker"] = fname
        state["done"] = int(done)
        # the state file is written last: a crash before this line leaves the previous checkpoint valid
        with atomic_path(self.state_path) as tmp:
            tmp.write_text(json.dumps(state))
