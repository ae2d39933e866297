"""Movie orchestration: label stack or MPF run -> junction networks, tracks, T1 events.

:func:`analyze_movie` reads one frame at a time, tracks cells by overlap in
the main process (only the previous frame is kept), and extracts each
frame's junction network with :func:`hexatissue.mesh_from_labels` in
parallel: a local process pool by default, or a dask.distributed cluster when
a ``client`` is given.  At most a few frames are in flight at once, so the
memory used does not grow with the movie's length beyond its output tables.

Conventions: label images are indexed ``[row, col]``; tables use ``x`` =
column, ``y`` = row, in px, origin at the centre of pixel (0, 0).
"""
from __future__ import annotations

import os
import pickle
from collections import deque
from pathlib import Path

import numpy as np
import pandas as pd

from .box import Box
from .errors import InputError
from .events import cell_event_stats, detect_t1
from .frame import MESH_TABLES, Movie
from .mesh.labels import validate_labels
from .track import Tracker, lineage_table

__all__ = ["analyze_movie", "open_movie"]


def _is_run(obj) -> bool:
    return hasattr(obj, "labels") and hasattr(obj, "box")


def open_movie(source):
    """Frames, default box and whether ids are already consistent, from any supported source.

    Parameters
    ----------
    source : array-like, sequence, run object or path
        A T x rows x cols array or lazily indexable array-like (numpy, memmap,
        zarr, dask, ...), a sequence of 2-D label images, an MPF run (any
        object with ``.labels`` and ``.box``), or a path: a label stack file
        (see :func:`hexatissue.read_labels`) or an MPF run folder / ``.zarr``
        store (read with ``hexatissue.simulate.read_run``).

    Returns
    -------
    frames : indexable
        ``frames[t]`` is the label image of frame ``t``.
    n_frames : int
    box : Box or None
        The run's box, else None.
    is_run : bool
        True for MPF runs (their ids are consistent: no tracking needed).
    """
    if isinstance(source, (str, Path)):
        path = Path(source)
        if path.is_dir() or path.suffix == ".zarr":
            try:
                from .simulate import read_run
            except ImportError as exc:  # the simulator is an optional part of the package tree
                raise InputError(f"source {str(path)!r} looks like an MPF run, but hexatissue.simulate.read_run "
                                 f"is unavailable: {exc}") from exc
            source = read_run(path)
        else:
            from .io import read_labels

            source = read_labels(path)
    if _is_run(source):
        frames = source.labels
        return frames, _length(frames, "run.labels"), source.box, True
    if isinstance(source, (list, tuple)):
        if not source:
            raise InputError("stack_or_run is an empty sequence; expected at least one label image")
        return source, len(source), None, False
    shape = getattr(source, "shape", None)
    if shape is None or not hasattr(source, "__getitem__"):
        raise InputError(f"stack_or_run must be a T x rows x cols label stack, a list of label images, an MPF "
                         f"run or a path; got {type(source).__name__}")
    if len(shape) != 3:
        raise InputError(f"stack_or_run must be a T x rows x cols label stack; got shape {tuple(shape)} "
                         f"(use hexatissue.mesh_from_labels for a single image)")
    return source, int(shape[0]), None, False


def _length(frames, name):
    shape = getattr(frames, "shape", None)
    n = int(shape[0]) if shape is not None else len(frames)
    if n < 1:
        raise InputError(f"{name} holds no frames; expected at least one")
    return n


def _mesh_job(labels, frame, box, mesh_options):
    """Junction network of one frame: its four tables with a leading ``frame`` column."""
    from . import mesh_from_labels

    result = mesh_from_labels(labels, box=box, **mesh_options)
    out = {}
    for name in MESH_TABLES:
        table = getattr(result, name)
        if "frame" in table.columns:
            table = table.drop(columns="frame")
        table.insert(0, "frame", np.full(len(table), frame, dtype=np.int64))
        out[name] = table
    return out


class _Serial:
    """An executor running jobs in the calling process (n_workers=1)."""

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


class _Pool:
    """A local process pool.

    Workers are forked where the OS allows it: they start at once and need no
    importable ``__main__`` (scripts piped to Python, notebooks).  The mesh
    kernels are serial numba code, so no numba thread pool is forked.
    Elsewhere (Windows) the platform's default start method is used.
    """

    def __init__(self, n_workers):
        import multiprocessing as mp
        from concurrent.futures import ProcessPoolExecutor

        from .mesh import warm_up

        method = "fork" if "fork" in mp.get_all_start_methods() else None
        if method == "fork":
            warm_up()  # compile the kernels once here; forked workers inherit them
        self.pool = ProcessPoolExecutor(max_workers=n_workers, mp_context=mp.get_context(method))

    def submit(self, fn, *args):
        return self.pool.submit(fn, *args)

    def shutdown(self):
        self.pool.shutdown(wait=True, cancel_futures=True)


def _executor(client, n_workers, n_frames):
    if client is not None:
        threads = sum(client.nthreads().values()) if hasattr(client, "nthreads") else 1
        return _Dask(client), max(2, 2 * threads)
    if n_workers is None:
        n_workers = os.cpu_count() or 1
    if int(n_workers) != n_workers or n_workers < 1:
        raise InputError(f"n_workers must be a positive integer; got {n_workers!r}")
    n_workers = min(int(n_workers), n_frames)
    if n_workers == 1:
        return _Serial(), 1
    return _Pool(n_workers), 2 * n_workers


def _check_box(box, shape):
    if box is None or box is False:
        return None
    if box is True:  # periodic box covering the frames
        return Box.from_shape(shape)
    if not isinstance(box, Box):
        raise InputError(f"box must be a hexatissue.Box, True (periodic frames) or None; got {type(box).__name__}")
    if (box.Ly, box.Lx) != (float(shape[0]), float(shape[1])):
        raise InputError(f"box {box} does not match the frames' shape {tuple(shape)} (rows, cols); "
                         f"expected Box(Lx={shape[1]}, Ly={shape[0]})")
    return box


def _extract(frames, n_frames, box, tracker, client, n_workers, mesh_options, store, progress):
    """Per-frame mesh tables (in frame order), tracking and the checked box, with bounded frames in flight."""
    from .progress import progress as progress_bar

    parts = {name: [] for name in MESH_TABLES}
    start, shape = 0, None
    if store is not None:
        start, loaded, saved_tracker, shape = store.load()
        if start:
            parts, tracker = loaded, saved_tracker
    if start >= n_frames:
        return parts, shape, tracker, _check_box(box, shape)
    executor, max_inflight = _executor(client, n_workers, n_frames - start)
    pending: deque = deque()
    snapshots = {}  # frame -> pickled tracker state after that frame (for checkpoints)
    due = store.due(start, n_frames) if store is not None else set()
    new_parts = {name: [] for name in MESH_TABLES}

    def collect(item):
        t, future = item
        for name, table in future.result().items():
            parts[name].append(table)
            new_parts[name].append(table)
        if t + 1 in due:
            store.save(t + 1, new_parts, snapshots.pop(t, None), shape)
            for name in new_parts:
                new_parts[name] = []

    try:
        for t in progress_bar(range(start, n_frames), enabled=progress, desc="frames", initial=start,
                              total=n_frames):
            labels = validate_labels(frames[t], f"frame {t}")
            if shape is None:
                shape = labels.shape
            if t == start:
                box = _check_box(box, shape)
            if tracker is not None:
                tracker.add(labels, t)
                if t + 1 in due:
                    snapshots[t] = pickle.dumps(tracker)
            pending.append((t, executor.submit(_mesh_job, labels, t, box, mesh_options)))
            while len(pending) >= max_inflight:
                collect(pending.popleft())
        while pending:
            collect(pending.popleft())
    finally:
        executor.shutdown()
    return parts, shape, tracker, box


class _Checkpoint:
    """Mesh tables and tracker state saved every ``every`` frames in ``directory``."""

    def __init__(self, directory, options, every):
        if int(every) != every or every < 1:
            raise InputError(f"checkpoint_every must be a positive integer number of frames; got {every!r}")
        self.dir = Path(directory)
        self.options = options
        self.every = int(every)
        self.state_path = self.dir / "checkpoint.json"

    def due(self, start, n_frames):
        """Frame counts after which a checkpoint is written."""
        return set(range(start + self.every, n_frames + 1, self.every)) | {n_frames}

    def load(self):
        """(frames done, tables, tracker, shape) from the last checkpoint, or (0, None, None, None)."""
        import json

        if not self.state_path.exists():
            return 0, None, None, None
        state = json.loads(self.state_path.read_text())
        if state["options"] != self.options:
            raise InputError(f"checkpoint folder {str(self.dir)!r} holds another movie or other options "
                             f"({state['options']}); use a new folder or delete it")
        parts = {name: [pd.read_parquet(self.dir / f) for f in state["files"][name]] for name in MESH_TABLES}
        tracker = None
        if state["tracker"]:
            tracker = pickle.loads((self.dir / state["tracker"]).read_bytes())
        return int(state["done"]), parts, tracker, tuple(state["shape"])

    def save(self, done, new_parts, tracker_bytes, shape):
        import json

        from .io import atomic_path

        state = {"options": self.options, "done": 0, "files": {name: [] for name in MESH_TABLES}, "tracker": None,
                 "shape": list(shape)}
        if self.state_path.exists():
            state = json.loads(self.state_path.read_text())
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


def analyze_movie(stack_or_run, box=None, track=None, client=None, n_workers=None, *, min_length=0.0,
                  censor=10, max_gap=0, min_iou=0.2, checkpoint=None, checkpoint_every=100, progress=True,
                  **mesh_options) -> Movie:
    """Junction networks, tracks, lineage and classified T1 events of a label movie or MPF run.

    Parameters
    ----------
    stack_or_run : array-like, sequence, run object or path
        See :func:`open_movie`: a T x rows x cols label stack (frames are read
        one at a time with ``stack[t]``), a list of label images, an MPF run
        (``.labels``, ``.box``) or a path to either.  0 = background/membrane.
    box : Box or bool, optional
        Periodic box of the frames (``Box(cols, rows)``; ``True`` builds it
        from the frame shape); default: the run's box, else None (open images).
    track : bool, optional
        Link cells by overlap (:class:`hexatissue.track.Tracker`).  Default:
        True for label stacks (consistent ids are reproduced), False for MPF
        runs, whose ids are already consistent.
    client : dask.distributed.Client, optional
        Run the per-frame mesh extraction on this cluster.
    n_workers : int, optional
        Local processes for mesh extraction when no client is given (default:
        all cores; 1 runs in this process).
    min_length : float
        Junctions shorter than this (px) count as four-fold vertices in T1
        detection (:func:`hexatissue.events.detect_t1`); 0 = raw network.
    censor : int
        Right-censoring window for T1 classification, frames.
    max_gap, min_iou : int, float
        Tracking options (gap closing in frames; smallest IoU of a link).
    checkpoint : str or Path, optional
        Folder for checkpoints: every ``checkpoint_every`` frames the mesh
        tables of the finished frames and the tracker state are saved there
        (atomically); a later call with the same movie and options resumes
        after the last checkpoint.  The tracker state is a pickle: only
        resume from folders you wrote yourself.
    checkpoint_every : int
        Frames per checkpoint.
    progress : bool
        Show a tqdm progress bar.
    **mesh_options
        Passed to :func:`hexatissue.mesh_from_labels` (``kind``,
        ``merge_distance``, ``p``, ``center``).

    Returns
    -------
    Movie
        Mesh tables (``cells`` with a ``track`` column, ``vertices``,
        ``edges``, ``cell_vertices``, each with ``frame``) and in
        ``movie.extra``: ``events`` (:func:`~hexatissue.events.detect_t1`),
        ``lineage`` (:func:`~hexatissue.track.lineage_table`) and
        ``cell_events`` (:func:`~hexatissue.events.cell_event_stats`).
    """
    frames, n_frames, run_box, is_run = open_movie(stack_or_run)
    box = run_box if box is None else box
    do_track = (not is_run) if track is None else bool(track)
    tracker = Tracker(min_iou=min_iou, max_gap=max_gap) if do_track else None
    store = None
    if checkpoint is not None:
        options = dict(n_frames=n_frames, box=repr(box), track=do_track, min_iou=min_iou, max_gap=max_gap,
                       mesh=repr(sorted(mesh_options.items())))
        store = _Checkpoint(checkpoint, options, checkpoint_every)
    parts, shape, tracker, box = _extract(frames, n_frames, box, tracker, client, n_workers, mesh_options, store,
                                     progress)
    tables = {name: pd.concat(parts[name], ignore_index=True) for name in MESH_TABLES}
    cells = tables["cells"]
    if tracker is not None:
        ids = tracker.tracks()
        cells = cells.merge(ids, on=["frame", "cell"], how="left", validate="one_to_one")
        if cells["track"].isna().any():
            raise AssertionError("mesh cells missing from the tracker's labels")
        cells["track"] = cells["track"].astype(np.int64)
        parents = tracker.parents
    else:
        cells = cells.assign(track=cells["cell"].to_numpy(np.int64))
        parents = {}
    tables["cells"] = cells
    border = cells["is_border"].to_numpy(bool) if "is_border" in cells.columns else None
    lineage = lineage_table(cells[["frame", "track"]], parents, border)
    events = detect_t1(tables["edges"], cells, min_length=min_length, censor=censor, box=box)
    extra = {"events": events, "lineage": lineage, "cell_events": cell_event_stats(events, cells)}
    return Movie(**tables, box=box, shape=tuple(shape), extra=extra)
