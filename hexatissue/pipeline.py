"""The analysis spine: ``analyze(source) -> Movie``.

It runs the list of stages (:data:`hexatissue.stages.STAGES`) over a source::

    open_source(...)  ->  per frame, in parallel: the frame stages (labels -> junction network
                                                  -> intensities -> gamma_p -> Gamma_p and defects
                                                  -> tensions, pressures and stress)
                      ->  in frame order, in this process: the movie stages' frame states
                                                  (the tracks stage's tracker links the cells)
                      ->  over the movie: the movie stages (tracks and lineage, defect tracks and
                                          pair events, tissue flow, T1 events, per-cell
                                          statistics, the deformation budget)
                      ->  Movie  ->  Movie.write(folder)  <->  read_results(folder)

Frames are read one at a time from the :class:`~hexatissue.Source` and sent
to the workers in batches of consecutive frames; at most a few batches are
in flight, so memory does not grow with the movie's length beyond its output
tables.  The workers also compact each frame's labels and count their
overlaps with the previous frame (the tracks stage's
:class:`~hexatissue.stages.FrameState`), so the tracker only links cells.  The
per-frame work runs in a local process pool (default) or on a
dask.distributed cluster (``client``).  Conventions: label images are
indexed ``[row, col]``; tables use ``x`` = column, ``y`` = row, in px, origin
at the centre of pixel (0, 0); times in frames.
"""
from __future__ import annotations

import warnings
from collections import deque
from functools import partial
from pathlib import Path

import numpy as np

from ._checkpoint import Checkpoint
from ._dispatch import reference_mode, references
from ._executors import batch_size, executor
from ._rows import Rows
from ._system import release_freed_memory
from ._version import __version__
from .box import as_box
from .errors import HexatissueWarning, InputError, check_positive, user_stacklevel
from .progress import progress as progress_bar
from .io import check_output_folder, lock_folder
from .results import METADATA, RUN_LOCK, Movie, check_replaceable_tables, write_results
from .schema import TABLES as SCHEMAS
from .source import open_source, read_mask
from .stored import PART_PATTERN, StoredTable
from .stages import (FrameData, MovieData, frame_stages, frame_tables, movie_stages, run_frame, stage_options,
                     worker_stages)

__all__ = ["analyze"]

#: Pixels (all frames) up to which a run on an empty numba cache runs the references of the kernels not yet
#: compiled instead of compiling them.  At this limit (one dense 707 x 707 px image, cells 16 px apart) the
#: references took 7.2 CPU-s against 38.0 for compiling (benchmarks/results_first_run.md); some references
#: search by brute force (cost growing faster than the pixels), so a larger limit would soon lose.
REFERENCE_PIXELS = 500_000


def analyze(source, *, box=None, mask=None, client=None, workers=None, checkpoint=None, checkpoint_every=100,
            progress=True, out=None, **options) -> Movie:
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
    mask : array or path, optional
        Region of interest of every frame: a 2-D bool or integer image
        (nonzero = inside) of the frames' shape, or a path to one (read with
        :func:`hexatissue.open_source`, one frame).  Pixels outside it are 0,
        so cells outside vanish and cells cut by its edge are border cells.
        Recorded as ``source["mask"]`` in ``metadata.json``.
    client : dask.distributed.Client, optional
        Run the per-frame work on this cluster.
    workers : int, optional
        Local processes when no client is given (default: all cores; 1 runs
        in this process).
    checkpoint : str or Path, optional
        Folder for checkpoints: every ``checkpoint_every`` frames the tables
        of the finished frames and the stages' frame states (the tracker) are saved there
        (atomically); a later call with the same source and options resumes
        after the last checkpoint.  The folder is locked while a run uses it
        (``checkpoint.lock``): a second run on it raises InputError.  The tracker's state is a pickle: only
        resume from folders you wrote yourself.
    checkpoint_every : int
        Frames per checkpoint.
    progress : bool or tqdm class
        Show a progress bar (on a terminal; see :mod:`hexatissue.progress`);
        a tqdm subclass (e.g. ``napari.utils.progress``) draws it with that class.
    out : str or Path, optional
        Stream the results to this folder: the frame tables are written as
        they finish, in Parquet parts of a chunk of frames (``<out>/cells/
        part-<first>-<last>.parquet``, ...; about :data:`PART_BYTES` of rows
        each, and never across a checkpoint), the movie
        stages read only the columns they use, and the folder is a complete
        results folder (``metadata.json`` written last) when ``analyze``
        returns.  Memory holds one chunk of frames and the columns the movie
        stages read, not the movie's tables; the tables are those of the
        run without ``out``.  Parquet only.
    **options
        The options of each stage (:data:`hexatissue.stages.STAGES`), by
        stage name: ``mesh`` (:class:`~hexatissue.MeshOptions`), ``order``
        (:class:`~hexatissue.OrderOptions`), ``track``
        (:class:`~hexatissue.TrackOptions`), ``events``
        (:class:`~hexatissue.EventOptions`), ``intensity``
        (:class:`~hexatissue.IntensityOptions`: a raw channel, e.g.
        E-cadherin or myosin, of the labels' shape, measured along every
        junction and in every cell; a path, array or Source stands for
        ``IntensityOptions(image=...)``; recorded as ``source["intensity"]``
        in ``metadata.json``).  A stage not given runs with its defaults.

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
        and units: :func:`hexatissue.schema.describe`.  With ``out``, the
        frame tables and ``flow`` are :class:`~hexatissue.stored.StoredTable`
        objects (read on demand from the folder's parts), as
        ``read_results(out, lazy=True)`` gives them.  The Movie carries the
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
    check_positive(checkpoint_every, "checkpoint_every", integer=True)  # also without a checkpoint: no value is ignored
    src = open_source(source)
    options = stage_options(options)
    _check_limits(options, src.shape)
    frame_work, movie_work = frame_stages(options), movie_stages(options)
    if src.kind == "polygons":
        _check_polygon_run(box, mask, frame_work)
    box = src.box if box is None else as_box(box, src.shape)
    mask, mask_info = read_mask(mask, src.shape)
    images = {s.options.stage: _image_source(s.options.stage, options[s.options.stage], src)
              for s in frame_work if s.image}
    followers = {s.options.stage: s.state for s in movie_work if s.state is not None}
    states = {name: follow.new(options[name], src, box) for name, follow in followers.items()}
    tables = frame_tables(frame_work)
    orders = options["order"].p
    streamed = None if out is None else _Streamed(out, tables, orders)
    try:
        store = None
        if checkpoint is not None:
            key = dict(n_frames=src.n_frames, shape=list(src.shape), box=None if box is None else box.to_list(),
                       source=_identity(src.description), options={k: v.to_dict() for k, v in options.items()},
                       mask=mask_info, images={name: _identity(image.description) for name, image in images.items()})
            if streamed is not None:  # the parts in `out` are the checkpoint's tables: it keeps the frame states
                key["out"] = str(streamed.folder.resolve())
            store = Checkpoint(checkpoint, key, checkpoint_every, () if streamed is not None else tables)
        with references(kernel_mode(src, client)):
            rows, states = _extract(src, box, frame_work, options, mask, images, followers, states, tables, client,
                                    workers, store, progress, streamed)
            release_freed_memory()  # the frames' freed temporaries, before the movie stages
            if streamed is None:
                done = {name: rows.pop(name).table(name, orders) for name in tables}
            else:
                streamed.flush(rows, src.n_frames - 1)  # what a resumed checkpoint held beyond the last part
                done = dict(streamed.tables)
            del rows
            # a movie stage's independent chunks go to a dask cluster's workers (memory on their nodes); a local
            # process pool would add a chunk's working set per worker on this machine for no time measured
            # (benchmarks/results_scale.md: 240 / 40 frames 1.82 with workers=2, flow no faster on 2 cores)
            movie = MovieData(tables=done, box=box, n_frames=src.n_frames, source=src, states=states,
                              options=dict(options), images=images,
                              folder=None if streamed is None else streamed.folder,
                              executor=None if client is None else partial(executor, client, workers))
            del states, done
            for stage in movie_work:
                stage.run(movie, options[stage.options.stage])
                release_freed_memory()  # after each movie stage: its freed working set would stay under the next
        result = Movie(**movie.tables, box=box, shape=tuple(src.shape), n_frames=src.n_frames,
                       calibration=src.calibration, options=movie.options,
                       source=_described(src.description, mask_info, images), version=__version__,
                       summary=movie.summary)
        if streamed is not None:
            write_results(result, streamed.folder)  # the parts are finished in place; the small tables, metadata.json
        return result
    finally:
        if streamed is not None:
            streamed.release()  # the out folder's lock: another run may write there now


#: Bytes of rows (all frame tables) a streamed run (``analyze(out=...)``) gathers before it writes them as one part
#: per table: 128 MB is ~20 frames of a 4,800-cell tissue (1.3 kB per cell and frame), a few hundred files per table
#: for 10^7 cell-frames.
PART_BYTES = 128 * 1024 ** 2


#: Pixel-frames above which ``hexatissue analyze`` streams its tables (``--stream auto``): the default stages'
#: tables take about 6 bytes per pixel-frame (1.3 kB per cell-frame on a tissue of 4,800 cells in 1024 x 1024 px,
#: benchmarks/results_scale.md), so 1.5e8 pixel-frames (150 frames of 1024 x 1024) are about 1 GB in memory.
STREAM_PIXELS = 150_000_000


def streams_by_default(source) -> bool:
    """Whether ``hexatissue analyze`` streams the tables of ``source`` unless told (:data:`STREAM_PIXELS`)."""
    return source.n_frames * int(np.prod(source.shape)) > STREAM_PIXELS


class _Streamed:
    """The frame tables of a streamed run, written to ``folder`` in parts as the frames finish.

    A part holds the frames gathered since the last one: :data:`PART_BYTES`
    of rows, and never frames on both sides of a checkpoint.  With a
    checkpoint, the parts are its tables (it keeps the frame states): the
    parts are written before the checkpoint that counts their frames done,
    and a resumed run keeps those and removes the others (:meth:`resume`).
    """

    def __init__(self, folder, names, orders):
        # absolute: the movie stages' tasks read the parts in processes that may run elsewhere (a dask worker)
        self.folder = check_output_folder(folder, "out").absolute()
        check_replaceable_tables(self.folder, "out")
        # a second analysis streaming into this folder is refused (the CLI holding it already is not)
        self.lock = lock_folder(self.folder, RUN_LOCK, "out folder")
        (self.folder / METADATA).unlink(missing_ok=True)  # incomplete from here until write_results ends
        self.tables = {name: StoredTable(self.folder / name, name, orders) for name in names}
        self.orders = orders
        self.first = 0  # the first frame not yet written

    def release(self):
        """Let go of the out folder's lock (:func:`hexatissue.io.lock_folder`)."""
        if self.lock is not None:
            self.lock.close()

    def resume(self, start):
        """Keep the parts of frames before ``start`` (a resumed checkpoint's: its tables are these parts), remove
        every other part in the folder (an earlier result's, or frames written after the last checkpoint).

        InputError when the parts kept do not hold every frame before ``start`` (the folder was changed).
        """
        for name in SCHEMAS:
            folder = self.folder / name
            if not folder.is_dir():
                continue
            for path in sorted(folder.glob("part-*.parquet")):
                span = PART_PATTERN.fullmatch(path.name)
                if span is None or int(span.group(1)) >= start or name not in self.tables:
                    path.unlink()
        if not start:
            return
        for name in self.tables:
            try:
                kept = StoredTable.open(self.folder / name, name)
            except InputError:
                kept = None
            if kept is None or kept.frame_chunks[0][0] != 0 or kept.frame_chunks[-1][1] != start - 1 or any(
                    b[0] != a[1] + 1 for a, b in zip(kept.frame_chunks, kept.frame_chunks[1:])):
                raise InputError(f"out folder {str(self.folder)!r} does not hold the {name} of frames 0-{start - 1} "
                                 f"that the checkpoint counts done; use the out folder the checkpointed run wrote, "
                                 f"or delete the checkpoint folder to start again")
            self.tables[name].parts = kept.parts
        self.first = start

    def due(self, rows, checkpoint_saved, last) -> bool:
        """Whether the rows gathered are written now: at the last frame, at a checkpoint (whose tables are the
        parts: a part never spans one), or when large enough."""
        return last or checkpoint_saved or sum(r.nbytes for r in rows.values()) >= PART_BYTES

    def flush(self, rows, last):
        """Write the rows of frames ``self.first`` to ``last`` as the next part of every table; empty ``rows``."""
        if last < self.first:
            return
        for name in self.tables:
            self.tables[name].append(rows[name].table(name, self.orders), self.first, last)
            rows[name] = Rows(rows[name].expected_frames)
        self.first = last + 1


def kernel_mode(source, client=None) -> str:
    """How :func:`analyze` runs the kernels of ``source`` (:func:`hexatissue._dispatch.references`).

    ``"auto"`` for a small input analysed locally: a kernel not yet compiled
    (in this process or numba's cache) runs its plain-numpy reference, so the
    run waits on no compilation; ``"kernel"`` otherwise (a dask cluster's
    workers compile on their side).  Small: at most :data:`REFERENCE_PIXELS`
    pixels in all frames.  Inside :func:`hexatissue._dispatch.references` the
    caller's mode is kept.
    """
    if reference_mode() != "kernel":
        return reference_mode()
    return "auto" if client is None and source.n_frames * int(np.prod(source.shape)) <= REFERENCE_PIXELS else "kernel"


def first_run_compiles(source, client=None) -> bool:
    """Whether :func:`analyze` of ``source`` compiles the numba kernels (numba's cache does not hold the mesh's).

    A small input (:func:`kernel_mode`) never waits on compilation.
    """
    from .mesh import kernels_cached

    return kernel_mode(source, client) == "kernel" and client is None and not kernels_cached()


def _identity(description):
    """A source's description as a checkpoint key: its path resolved (the same file by a relative or an absolute
    path, or through a link, is the same input), and a file's size and modification time (a file rewritten
    under the same name is not)."""
    path = description.get("path")
    if not path:
        return description
    resolved = Path(path).resolve()
    out = dict(description, path=str(resolved))
    if resolved.is_file():
        stat = resolved.stat()
        out.update(size=stat.st_size, mtime_ns=stat.st_mtime_ns)
    return out


def _described(description, mask_info, images):
    """The source's description with the mask and the images of the image stages."""
    out = dict(description)
    if mask_info is not None:
        out["mask"] = mask_info
    out.update({name: image.description for name, image in images.items()})
    return out


def _image_source(name, options, src):
    """The image of stage options ``name`` as a Source of the labels' shape, one frame per frame or one for all."""
    try:
        image = open_source(options.image, channel=options.channel)
    except InputError as exc:
        raise InputError(f"{name}: {exc}") from None
    if image.shape != src.shape or image.n_frames not in (1, src.n_frames):
        raise InputError(f"{name} has {image.n_frames} frame(s) of {image.shape}; expected {src.n_frames} frame(s) "
                         f"(or one) of the labels' shape {src.shape}")
    return image


def _check_polygon_run(box, mask, stages):
    """Refuse what cell polygons cannot have: a periodic box, a mask, an image stage (the tracks stage refuses
    overlap tracking when it makes its tracker)."""
    if box is not None and box is not False:
        raise InputError(f"box={box!r}: cell polygons are an open image; a periodic box needs label images")
    pixels = (["mask"] if mask is not None else []) + [s.options.stage for s in stages if s.image]
    if pixels:
        raise InputError(f"{pixels[0]}= needs a label image; the source holds cell polygons (no pixels)")


def _check_limits(options, shape):
    """Refuse, before any work, option values that only cost memory and time on frames of ``shape``, naming the limit.

    The coarse-graining disk's cost grows as its radius squared (a raster of
    the disk per node): on the bundled 160 x 257 px sample, radius 1e4 px
    took 21 s and 830 MB, 1e6 px ran out of memory, while any radius beyond
    the frames' diagonal averages every node over the whole image.  A
    merge distance beyond the diagonal merges every vertex into one; an
    intensity step beyond it samples each junction at its two vertices
    only.  Frames under 2 x 2 px are left to the first frame's read, which
    names them.
    """
    if min(shape) < 2:  # reading the first frame refuses it, naming the frame and its shape
        return
    diagonal = float(np.hypot(*shape))
    order, mesh = options["order"], options["mesh"]
    radii = np.atleast_1d(np.asarray(order.radius if order.radius is not None else [], float))
    if order.fields and radii.size and radii.max() > diagonal:
        raise InputError(f"OrderOptions.radius {radii.max():g} px is larger than the frames' diagonal "
                         f"({diagonal:.0f} px): every node's disk would hold the whole image, at a cost growing as "
                         f"the radius squared (memory and time); give at most {diagonal:.0f} px (default 1.5 R_cell)")
    intensity = options["intensity"]
    if intensity.enabled and intensity.step > diagonal:
        raise InputError(f"IntensityOptions.step {intensity.step:g} px is larger than the frames' diagonal "
                         f"({diagonal:.0f} px): every junction would be sampled at its two ends only, its vertices; "
                         f"give at most {diagonal:.0f} px (default 0.5 px)")
    if mesh.merge_distance > diagonal:
        raise InputError(f"MeshOptions.merge_distance {mesh.merge_distance:g} px is larger than the frames' "
                         f"diagonal ({diagonal:.0f} px): every vertex would merge into one and the network would have "
                         f"no junction; give at most {diagonal:.0f} px (default 2 px)")


class _FrameWarnings:
    """Warnings of the frame jobs, reported once per distinct text with the frames it occurred in.

    ``files``: the file of each frame (a folder of images or polygon files), named instead of the frame number.
    The per-frame details of a :class:`~hexatissue.errors.FrameWarning` follow, frame by frame.
    """

    def __init__(self, files=None):
        self.frames = {}
        self.files = files

    def add(self, t, found):
        for category, text, detail in found:
            self.frames.setdefault((category, text), {}).setdefault(int(t), detail)

    def emit(self):
        word = "file" if self.files else "frame"
        for (category, text), details in self.frames.items():
            frames = sorted(details)
            names = [Path(self.files[f]).name if self.files else str(f) for f in frames]
            shown = ", ".join(names[:10]) + (f", ... ({len(frames)} {word}s)" if len(frames) > 10 else "")
            each = "; ".join(f"{word} {n}: {details[f]}" for n, f in zip(names[:3], frames[:3]) if details[f])
            if each and len(frames) > 3:
                each += "; ..."
            warnings.warn(f"{word}{'s' if len(frames) > 1 else ''} {shown}: {text}" + (f" ({each})" if each else ""),
                          category, stacklevel=user_stacklevel())


def _batch_job(batch, stages, follow):
    """The frame ``stages`` (``(run, options)`` pairs) on consecutive frames (:class:`FrameData`), in one task.

    Then each frame state's ``prepare`` (``follow``: ``(name, prepare,
    params)`` triples, :class:`~hexatissue.stages.FrameState`) makes its
    payload of every frame here, in the worker (the tracks stage: the label
    frames compacted, with their overlaps with the batch's previous frame),
    so that the main process only adds them.  Returns ``[(tables, {name:
    payload}, warnings), ...]`` in frame order.
    """
    found = [run_frame(frame, stages) for frame in batch]
    payloads = {name: prepare(batch, params) for name, prepare, params in follow}
    return [(frame.tables, {name: p[k] for name, p in payloads.items()}, found[k]) for k, frame in enumerate(batch)]


def _extract(src, box, stages, options, mask, images, followers, states, tables, client, workers, store, progress,
             streamed=None):
    """Per-frame ``tables`` (in frame order, as :class:`Rows`) and the frame ``states`` (by stage options name, of
    the :class:`~hexatissue.stages.FrameState` ``followers``), with few frames in flight.

    A checkpoint folder is locked for the whole extraction: two runs cannot share it.
    """
    args = (src, box, stages, options, mask, images, followers, states, tables, client, workers, store, progress,
            streamed)
    if store is None:
        return _extract_locked(*args)
    store.lock()
    try:
        return _extract_locked(*args)
    finally:
        store.unlock()


def _extract_locked(src, box, stages, options, mask, images, followers, states, tables, client, workers, store,
                    progress, streamed):
    """The frame loop: batches of consecutive frames go to the executor; their results join the frame states in
    frame order.

    A batch never spans a checkpoint (the tracker's last frame keeps its
    pixels, which the checkpointed tracker holds for the next frame's
    overlaps).
    """
    n_frames = src.n_frames
    rows = {name: Rows(n_frames) for name in tables}
    start = 0
    if store is not None:
        start, loaded, saved_states = store.load({name: f.load for name, f in followers.items()})
        if start:
            states = saved_states
            for name, parts in loaded.items():
                for table in parts:
                    rows[name].append(table, frames=table["frame"].nunique() if "frame" in table else 1)
    if streamed is not None:
        streamed.resume(start)
    if start >= n_frames:
        return rows, states
    sent = worker_stages(stages, options)
    follow = tuple((name, f.prepare, f.params(states[name], src)) for name, f in followers.items())

    def warm_up():
        """The job's first frames, once, here: forked workers inherit exactly the compiled kernels they need."""
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", HexatissueWarning)  # reported when the frames are analysed
            _batch_job([frame_data(t) for t in range(start, min(start + 2, n_frames))], sent, follow)

    pending: deque = deque()
    due = store.due(start, n_frames) if store is not None else set()
    saved = {name: r.n for name, r in rows.items()}  # rows already in checkpoint files

    files = src.description.get("files")
    frame_warnings = _FrameWarnings(files if files is not None and len(files) == n_frames else None)
    polygons = src.kind == "polygons"

    def collect(first, future):
        for t, (done, payloads, found) in enumerate(future.result(), start=first):
            frame_warnings.add(t, found)
            for name, follower in followers.items():
                follower.add(states[name], payloads[name], t)
            for name, table in done.items():
                rows[name].append(table)
            del done, payloads
            if streamed is not None and streamed.due(rows, t + 1 in due, t + 1 == n_frames):
                streamed.flush(rows, t)  # before the checkpoint that counts these frames done
            if t + 1 in due:
                new = {name: [r.table(start=saved[name])] for name, r in rows.items()
                       if name in store.tables and r.n > saved[name]}
                store.save(t + 1, new, {name: f.dump(states[name]) for name, f in followers.items()})
                saved.update({name: r.n for name, r in rows.items()})

    def frame_data(t):
        if polygons:
            return FrameData(t=t, cell_polygons=src.polygons(t))
        with warnings.catch_warnings(record=True) as caught:  # reported with the frames' other warnings
            warnings.simplefilter("always")
            labels, lowest, top = src.checked_frame(t, options["mesh"].kind)
        frame_warnings.add(t, [(w.category, getattr(w.message, "text", str(w.message)),
                                getattr(w.message, "detail", "")) for w in caught])
        frame_images = {name: image.image(t if image.n_frames > 1 else 0) for name, image in images.items()}
        return FrameData(t=t, box=box, labels=labels, raw_ids=(lowest, top), mask=mask, images=frame_images)

    work, max_inflight = executor(client, workers, n_frames - start, warm_ups=(warm_up,))
    size = batch_size(n_frames - start, src.shape, max_inflight)
    try:
        batch = []
        for t in progress_bar(range(start, n_frames), enabled=progress, desc="frames", initial=start,
                              total=n_frames):
            batch.append(frame_data(t))
            if len(batch) < size and t + 1 not in due and t + 1 < n_frames:
                continue
            pending.append((t + 1 - len(batch), work.submit(_batch_job, batch, sent, follow)))
            batch = []
            while len(pending) >= max_inflight:
                collect(*pending.popleft())
        while pending:
            collect(*pending.popleft())
    except BaseException:  # an error or an interrupt (Ctrl-C): the workers' tasks are of no use, stop them now
        work.shutdown(abort=True)
        raise
    else:
        work.shutdown()
    finally:
        frame_warnings.emit()
    return rows, states
