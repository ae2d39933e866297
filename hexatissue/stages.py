"""The list of analysis stages that :func:`hexatissue.analyze` runs, in order.

Each :class:`Stage` names its options class (its keyword of ``analyze``, its
entry in ``metadata.json`` and in checkpoints, its group of ``hexatissue
analyze`` flags), the tables it reads and the tables or columns it writes,
and the function that runs it:

- **frame stages** run in a worker, once per frame, in list order, on a
  :class:`FrameData` (the frame's labels and tables); what they write is
  gathered into the movie's tables in frame order;
- **movie stages** run once, in the main process, in list order, on a
  :class:`MovieData` (every table of the movie) after the frames are done
  (a stage whose chunks of frames are independent may send them to a
  dask cluster's workers: :meth:`MovieData.map_chunks`, as the tissue flow
  does);
  a movie stage may also follow the frames as they come (its
  :class:`FrameState`: the tracks stage's tracker), in frame order, in the
  main process, its state saved in the checkpoints.

A stage's figures, report section and napari layers live in its views
module (``Stage.views``, on the analysis floor: :mod:`hexatissue.views`),
which the report, ``analyze --figures`` and the napari plugin take from
this list.

Adding a stage: its module (the computation, with its ``_kernels`` and
``_reference``), its options class (:mod:`hexatissue.options`), its tables or
columns in :mod:`hexatissue.schema`, one entry in :data:`STAGES` with the
small function that calls it (and the name of its views module), and tests.
The spine, the checkpoints, the command line, the report, the figures and the
napari plugin take the rest from here.
"""
from __future__ import annotations

import pickle
import warnings
from collections import deque
from contextlib import closing
from dataclasses import dataclass, field, replace
from typing import Callable

import numpy as np
import pandas as pd

from ._system import release_freed_memory
from .defects import MovieDefects, default_max_distance, find_defects
from .deformation import budget_chunks, event_shear, read_roi
from .errors import FrameWarning, HexatissueWarning, InputError, user_stacklevel
from .events import cell_event_stats, default_censor, events_summary, t1_tables
from .flow import cell_velocities, flow_fields, surface_flow_fields, surface_velocities
from .flow.piv import piv_fields
from .geometry import distinct_count, in_sorted
from .intensity import measure_intensity
from .mechanics import MU_RANGE, cell_stress, frame_forces, stress_grid
from .mesh.labels import mesh_labels
from .mesh.network import network_columns
from .mesh.polygons import polygon_network
from .options import (OPTION_CLASSES, DeformationOptions, EventOptions, FlowOptions, IntensityOptions,
                      MechanicsOptions, MeshOptions, OrderOptions, SurfaceOptions, TrackOptions)
from .order import coarse_grain, gamma_arrays, gamma_columns, polygon_rows
from .schema import TABLES as SCHEMAS, empty_table, interior_mask, validate
from .stored import StoredTable
from .surface import cell_heights, lift, node_normals, surface_arrays, surface_coarse_grain, surface_defects
from .track import (CellCounts, MovieTracker, cells_with_tracks, check_divisions, check_extrusions, checked_tracks,
                    compact_frames, join_spans, lineage_from_spans, track_spans, tracking_summary, tracking_warning)

__all__ = ["Stage", "FrameState", "STAGES", "FrameData", "MovieData", "read_table", "stage_options", "frame_stages",
           "movie_stages", "frame_tables", "worker_stages", "run_frame"]

@dataclass(frozen=True)
class FrameState:
    """What a movie stage follows frame by frame while the frame stages run (the tracks stage: its tracker).

    The spine makes the state once (``new``), sends ``params(state, source)``
    with every batch of consecutive frames to the worker, which calls
    ``prepare(frames, params)`` after the frame stages (the
    :class:`FrameData` of the batch; one picklable payload per frame), then
    hands each frame's payload to ``add(state, payload, t)`` in frame order,
    in the main process.  The state is saved in every checkpoint
    (``dump``; ``load`` on resume) and handed to the movie stages in
    :attr:`MovieData.states`.

    Attributes
    ----------
    new : callable
        ``new(options, source, box) -> state``, with the stage's options, the
        opened Source and the box (None: open image).
    prepare : callable
        ``prepare(frames, params) -> list``: one payload per frame, in the worker.
    add : callable
        ``add(state, payload, t)``.
    params : callable
        ``params(state, source)``: what ``prepare`` needs (picklable; None by default).
    dump, load : callable
        The state to bytes and back (default: pickle; only resume from checkpoint folders you wrote).
    """

    new: Callable
    prepare: Callable
    add: Callable
    params: Callable = field(default=lambda state, source: None)  # noqa: E731  (nothing to send)
    dump: Callable = field(default=pickle.dumps)
    load: Callable = field(default=pickle.loads)


@dataclass(frozen=True)
class Stage:
    """One step of :func:`hexatissue.analyze`.

    Attributes
    ----------
    name : str
        What the stage is called in messages and docs.
    options : type
        Its options class; ``options.stage`` is the keyword of ``analyze``
        that gives the options object (several stages may share one).
    per : {"frame", "movie"}
        Runs once per frame (in a worker) or once over the whole movie.
    reads, writes : tuple of str
        Tables (``"cells"``) or columns (``"cells.track"``) it reads and
        writes; ``"labels"``, ``"polygons"`` and ``"image"`` are the frame's
        normalised labels, its cell polygons and the stage's own image;
        ``"height"`` the height map the surface stage hands on to the order
        fields stage (:attr:`FrameData.height_scale`).
    run : callable
        ``run(data, options)`` with a :class:`FrameData` or a :class:`MovieData`.
    enabled : callable, optional
        ``enabled(options)``: whether the stage runs with these options
        (None: always).
    image : bool
        The stage measures an image of its own (``options.image``, read
        frame by frame like the labels).
    state : FrameState, optional
        A movie stage's state that follows the frames (the tracker).
    views : str or object, optional
        Its presentation: the name of a module (imported by the report, the
        figures and the napari plugin, never by the analysis) whose ``VIEW``
        is a :class:`hexatissue.views.StageView`, or the view itself.
    """

    name: str
    options: type
    per: str
    reads: tuple
    writes: tuple
    run: Callable
    enabled: Callable = field(default=None)
    image: bool = False
    state: FrameState | None = None
    views: object = None

    def runs_with(self, options) -> bool:
        """Whether the stage runs with these options (``enabled(options)``; always when ``enabled`` is None)."""
        return self.enabled is None or bool(self.enabled(options))


@dataclass
class FrameData:
    """One frame as the frame stages see it.

    ``labels`` is the validated input frame until the mesh stage replaces it
    by the touching labels its network was built from (which the tracker then
    links); ``raw_ids`` are the smallest and largest id of the input frame
    when known; ``cell_polygons`` is the frame of a polygon source;
    ``polygons`` the ``(xy, starts)`` the mesh built for its cells with a
    polygon, in the rows' order; ``images`` each image stage's frame by stage
    options name; ``tables`` the frame's tables by name, each a dict of numpy
    columns in the table's column order, never a DataFrame (columns pickle
    cheaply from the workers, and the spine's ``Rows`` read them without a
    copy).  A stage reads a table as a DataFrame with :meth:`table`, stores
    one with :meth:`set_table`, or adds columns to its dict.
    """

    t: int
    box: object = None
    labels: np.ndarray | None = None
    raw_ids: tuple = (None, None)
    mask: np.ndarray | None = None
    cell_polygons: object = None
    images: dict = field(default_factory=dict)
    membrane: np.ndarray | None = None
    polygons: tuple | None = None
    tables: dict = field(default_factory=dict)
    height_scale: float | None = None  # px per unit of images["surface"], once the surface stage ran

    def table(self, name) -> pd.DataFrame:
        """The frame's table ``name`` as a DataFrame over its columns (no copy)."""
        return pd.DataFrame(self.tables[name], copy=False)

    def set_table(self, name, table):
        """Store ``table`` (a DataFrame, or columns by name) as the frame's table ``name``: numpy columns."""
        self.tables[name] = {column: np.asarray(values) for column, values in table.items()}


@dataclass
class MovieData:
    """The movie as the movie stages see it: its tables, and what they decide.

    ``tables`` by name (stages add, replace and drop them): DataFrames, or,
    when the movie's tables are streamed to a folder (``folder``), the frame
    tables as :class:`~hexatissue.stored.StoredTable` (Parquet parts on
    disk).  Stages read them with :meth:`read` (only the columns they use)
    and add columns with :meth:`add_column`, so that a stage works the same
    on either.  ``source`` the opened :class:`~hexatissue.Source`;
    ``states`` the :class:`FrameState` of each stage that has one, by stage
    options name (``states["track"]``: the
    :class:`~hexatissue.track.MovieTracker` that linked the frames);
    ``options`` the options by stage name (a stage records what it
    resolved, e.g. the tracking mode used); ``summary`` what the stages
    decided, by stage name.  ``executor``: the spine's maker of the
    analysis's executor (:meth:`map_chunks`), ``executor(n_tasks, warm_ups)
    -> (executor, tasks kept in flight)``, on the dask ``client`` the frames
    ran on (the spine gives none for local workers, whose chunks would add
    their working sets on the same machine); None: every chunk runs in this
    process.
    """

    tables: dict
    box: object
    n_frames: int
    source: object
    states: dict
    options: dict
    summary: dict = field(default_factory=dict)
    images: dict = field(default_factory=dict)  # the image stages' Sources by stage name (the flow's PIV reads them)
    folder: object = None  # where the streamed tables are written (None: every table in memory)
    executor: Callable | None = None

    def read(self, name, columns=None, frames=None) -> pd.DataFrame:
        """Table ``name``: only the ``columns`` it has (all when None), only the rows of frames ``first`` to
        ``last`` when ``frames = (first, last)``.  A table on disk is read from its parts (:func:`read_table`)."""
        return read_table(self.tables[name], columns, frames)

    def map_chunks(self, fn, chunks, *args):
        """``fn(chunk, *args)`` of every chunk (e.g. ``(first, last)`` of :meth:`frame_chunks`), yielded in chunk
        order; on the analysis's executor when the tables are on disk.

        Parameters
        ----------
        fn : callable
            ``fn(chunk, *args)``: one chunk's result, picklable.
        chunks : iterable
            The chunks, in the order their results are wanted.
        *args
            What ``fn`` needs besides its chunk, picklable (sent with every task).

        Yields
        ------
        object
            ``fn(chunk, *args)`` of each chunk, in chunk order.

        Notes
        -----
        The tasks are independent: ``fn`` (a module-level function, sent by
        name) reads its inputs itself, from ``args``: the tables as kept
        (``self.tables[name]``, read with :func:`read_table`; a
        :class:`~hexatissue.stored.StoredTable` pickles as the paths of its
        parts and added columns, a few hundred bytes), never a table's rows.
        When the movie's tables are streamed (``folder``) and there is an
        :attr:`executor`, the chunks run on its local process pool (the
        first chunk here, before the pool forks, so the workers inherit the
        numba kernels it compiled) or on the dask cluster (whose
        workers must see the out folder: a shared filesystem); with the
        tables in memory, one worker, or one chunk, here.  One chunk per
        worker is computed ahead of the chunk taken (a chunk's working set
        is large), so memory holds as many chunks as there are workers.  A task's
        warnings are issued here, in chunk order; its exception is raised
        here (the same type and message as when run here); the pool's
        workers are killed then, or when the caller stops before the last
        chunk (close the generator: ``contextlib.closing``).  With dask, a
        chunk whose worker is lost is run again by the scheduler.
        """
        chunks = list(chunks)
        if self.folder is None or self.executor is None or len(chunks) < 2:
            for chunk in chunks:
                yield fn(chunk, *args)
            return
        ahead = []

        def first_here():  # a pool's warm-up: the kernels compiled here are forked into its workers
            ahead.append(fn(chunks[0], *args))

        work, in_flight = self.executor(len(chunks), (first_here,))
        # one chunk per worker (the executor keeps two tasks per worker for the frames): a chunk's working set is
        # hundreds of MB, so memory then holds as many chunks as there are workers, whatever the movie's length
        in_flight = max(1, in_flight // 2)
        pending = deque()
        try:
            if ahead:
                yield ahead.pop()
                chunks = chunks[1:]
            for chunk in chunks:
                pending.append(work.submit(_chunk_task, fn, chunk, args))
                if len(pending) >= in_flight:
                    yield _chunk_result(pending.popleft())
            while pending:
                yield _chunk_result(pending.popleft())
        except BaseException:  # an error, an interrupt, or the caller gone: the tasks still running are of no use
            pending.clear()  # a dask future released is cancelled
            work.shutdown(abort=True)
            raise
        work.shutdown()

    def add_column(self, name, column, values, after=None):
        """Set ``column`` of table ``name`` to ``values`` (every row, in order): replaced in place or appended,
        or, with ``after``, moved to just after that column."""
        table = self.tables[name]
        if isinstance(table, StoredTable):
            table.add_column(column, values, after)
        elif after is not None:
            if column in table.columns:
                del table[column]
            table.insert(table.columns.get_loc(after) + 1, column, values)
        else:
            table[column] = values

    def column_writer(self, name, column, dtype, after=None):
        """A writer that adds ``column`` to table ``name`` from its values chunk by chunk in row order (``write``,
        then ``close``; as :meth:`add_column` once closed): written to disk as it goes when the table is kept
        there (:class:`~hexatissue.stored.ColumnWriter`)."""
        table = self.tables[name]
        if isinstance(table, StoredTable):
            return table.column_writer(column, dtype, after)
        return _ColumnPieces(lambda values: self.add_column(name, column, values, after), dtype)

    def frame_chunks(self, name) -> list:
        """``(first, last)`` frames of the chunks table ``name`` is kept in (one chunk for a table in memory)."""
        table = self.tables[name]
        return table.frame_chunks if isinstance(table, StoredTable) else [(0, max(self.n_frames - 1, 0))]

    def put_chunks(self, name, chunks, orders=None):
        """Table ``name`` made chunk by chunk: ``chunks`` yields ``((first, last), DataFrame)``; written as parts
        when the movie's tables are streamed, else concatenated."""
        if self.folder is None:
            parts = [table for _, table in chunks]
            self.tables[name] = pd.concat(parts, ignore_index=True) if len(parts) > 1 else parts[0]
            return
        stored = StoredTable(self.folder / name, name, orders)
        for (first, last), table in chunks:
            stored.append(table, first, last)
        kept = {path for _, _, _, path in stored.parts}
        for path in self.folder.joinpath(name).glob("part-*.parquet"):  # a table replaced: its other parts go
            if path not in kept:
                path.unlink()
        self.tables[name] = stored


def read_table(table, columns=None, frames=None) -> pd.DataFrame:
    """A movie's table as kept: by column and frame range, from memory or from its parts on disk.

    Parameters
    ----------
    table : pandas.DataFrame or StoredTable
        The table (``MovieData.tables[name]``); a
        :class:`~hexatissue.stored.StoredTable` is read from its parts.
    columns : sequence of str, optional
        The columns wanted (those the table lacks are left out); None: all.
    frames : (int, int), optional
        Only the rows of frames ``first`` to ``last`` (inclusive).

    Returns
    -------
    pandas.DataFrame
        The rows and columns asked for, in the table's row order, with the
        table's columns and units (:func:`hexatissue.schema.describe`).
    """
    if isinstance(table, StoredTable):
        return table.read(columns, frames)
    if frames is not None:
        f = table["frame"].to_numpy()
        inside = (f >= frames[0]) & (f <= frames[1])
        if not inside.all():
            table = table[inside].reset_index(drop=True)
    return table if columns is None else table[[c for c in columns if c in table.columns]]


def _chunk_task(fn, chunk, args):
    """In a worker: ``fn(chunk, *args)`` and its warnings, as ``(category, text)`` pairs for the main process."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = fn(chunk, *args)
    return result, [(w.category, str(w.message)) for w in caught]


def _chunk_result(future):
    """A chunk task's result, its warnings issued here (through this process's filters)."""
    result, caught = future.result()
    for category, text in caught:
        warnings.warn(text, category, stacklevel=user_stacklevel())
    return result


class _ColumnPieces:
    """:meth:`MovieData.column_writer` of a table in memory: the values gathered, then added at ``close``."""

    def __init__(self, add, dtype):
        self.add, self.dtype, self.pieces = add, np.dtype(dtype), []

    def write(self, values):
        self.pieces.append(np.asarray(values, self.dtype))

    def close(self):
        self.add(np.concatenate(self.pieces) if self.pieces else np.zeros(0, self.dtype))


# ----------------------------------------------------------------------------
# Frame stages
# ----------------------------------------------------------------------------

def _mesh(frame, options):
    """Junction network of the frame's labels (or of its cell polygons)."""
    if frame.cell_polygons is not None:
        tables = polygon_network(frame.cell_polygons, frame.t, where=f"frame {frame.t}")
        frame.labels = frame.cell_polygons.cell  # the ids the tracker follows
    else:
        raw = frame.labels
        frame.labels, frame.membrane = mesh_labels(raw, frame.box, options, frame.mask, frame.raw_ids[0])
        # the largest id is known while the labels are the ones checked
        tables, frame.polygons = network_columns(frame.labels, frame.membrane, frame.box, options.merge_distance,
                                                 frame.t, frame.raw_ids[1] if frame.labels is raw else None)
    for name, table in tables.items():
        frame.set_table(name, table)


def _intensity(frame, options):
    """Junction and cell intensities of the stage's image, and junction polarity."""
    cells, edges = measure_intensity(frame.table("cells"), frame.table("vertices"), frame.table("edges"),
                                     frame.labels, frame.images["intensity"], frame.box, options.step)
    frame.set_table("cells", cells)
    frame.set_table("edges", edges)


def _shape_order(frame, options):
    """gamma_p of every cell with a polygon, from the polygons the mesh built (or from the tables)."""
    if frame.polygons is not None:
        cells = frame.tables["cells"]
        cells.update(gamma_arrays(*frame.polygons, polygon_rows(cells["n_sides"] > 0), options.p, options.center))
        return
    frame.set_table("cells", validate(gamma_columns(frame.table("cells"), frame.table("vertices"),
                                                    frame.table("cell_vertices"), frame.box, options.p,
                                                    options.center), "cells"))


def _surface(frame, options):
    """Each cell on the height map's surface: the height above its centroid, 3-D area and perimeter, normal, gamma_p
    in its tangent plane (for the orders of the order stage's columns); every vertex's height."""
    height = frame.images["surface"]  # finite, of the labels' shape: checked when read (Source.image, analyze)
    frame.height_scale = options.scale  # the order fields stage coarse-grains on the surface
    cells = frame.tables["cells"]
    orders = tuple(int(c[5:-3]) for c in cells if c.startswith("gamma") and c.endswith("_re"))  # OrderOptions.p
    vertices = frame.tables["vertices"]
    vertices["z"] = lift(height, np.column_stack([vertices["x"], vertices["y"]]), options.scale, frame.box)[:, 2]
    cells["z"] = cell_heights(height, cells["x"], cells["y"], options.scale, frame.box)  # the cells' 3-D positions
    # the mesh's polygons: a label image's (analyze refuses image stages on cell polygons, which have no pixels)
    cells.update(surface_arrays(*frame.polygons, polygon_rows(cells["n_sides"] > 0), height, options.scale,
                                frame.box, orders, options.center))
    measured = np.isfinite(cells["normal_z"])
    with_polygon = int((cells["n_sides"] > 0).sum())
    if with_polygon and not measured.any():
        warnings.warn(FrameWarning("no cell could be measured on the surface (every surface column is NaN): the "
                                   "lifted polygons have no area; check the height map's unit "
                                   "(SurfaceOptions.pixel_size, z_step)", f"{with_polygon} cells with a polygon"),
                      stacklevel=user_stacklevel())
        return
    tilt = float(np.degrees(np.arccos(np.median(cells["normal_z"][measured])))) if measured.any() else 0.0
    if tilt > MAX_TILT:  # a projection of so steep a surface keeps little of the cells' shapes
        warnings.warn(FrameWarning(f"the height map tilts the cells by more than {MAX_TILT:g} degrees (median): "
                                   f"their projected outlines are too foreshortened for the surface columns to be "
                                   f"trusted; check the height map's unit (SurfaceOptions.pixel_size, z_step)",
                                   f"median tilt {tilt:.0f} degrees"), stacklevel=user_stacklevel())


#: Median tilt of a frame's cells (degrees) above which the surface stage warns: on tilted Voronoi tissues the
#: median area error is 1.1 % at 30 degrees, 1.6 % at 50 and 2.4 % at 70 (benchmarks/results_surface.md), and a
#: cell tilted 75 degrees is projected to a quarter of its width.
MAX_TILT = 75.0


def _fields(frame, options):
    """The frame's coarse-grained fields Gamma_p and their defects, for every p: of the cells' gamma_p, or, after
    the surface stage, of their surface gamma_p transported into each node's tangent plane (docs/surface.md)."""
    cells = validate(frame.table("cells"), "cells")
    height = frame.images.get("surface") if frame.height_scale is not None else None
    # a constant height map is the image plane: frames (x, y), transport the identity, the surface columns the flat
    # ones (to 1e-12): the flat field and defects, byte for byte, with the nodes' normal (0, 0, 1)
    plane = height is not None and float(np.ptp(height)) == 0.0
    on_surface = height is not None and not plane
    prefix = "surface_" if on_surface else ""
    usable = interior_mask(cells) & np.isfinite(cells[f"{prefix}gamma{options.p[0]}_re"].to_numpy(float))
    if not usable.any():
        grid = empty_table("grid", options.p)
        if height is not None:
            for name in ("normal_x", "normal_y", "normal_z"):
                grid[name] = np.zeros(0)
        frame.set_table("grid", grid)
        frame.set_table("defects", empty_table("defects"))
        return
    kwargs = dict(p=options.p, radius=options.radius, spacing=options.spacing, box=frame.box,
                  min_coverage=options.min_coverage, r_cell=options.r_cell, origin=options.origin,
                  shape=options.shape, validity=options.validity)
    if on_surface:
        grid = surface_coarse_grain(cells, height, frame.height_scale, **kwargs)
    else:
        grid = coarse_grain(cells, **kwargs)
    rows, cols = (int(grid["row"].max()) + 1, int(grid["col"].max()) + 1) if len(grid) else (0, 0)
    if min(rows, cols) < 2:  # a small field of view: the field is kept, but no plaquette winds around a defect
        warnings.warn(f"the Gamma_p grid is only {rows} x {cols} node(s) (a small field of view): no defects; a "
                      f"smaller --spacing gives more nodes", HexatissueWarning, stacklevel=user_stacklevel())
        defects = empty_table("defects")
    elif on_surface:
        defects = surface_defects(grid, p=options.p, box=frame.box)
    else:
        defects = find_defects(grid, p=options.p, box=frame.box)
    if plane:
        grid["normal_x"], grid["normal_y"], grid["normal_z"] = 0.0, 0.0, 1.0
    frame.set_table("grid", grid)
    frame.set_table("defects", defects)


def _mechanics(frame, options):
    """Tensions, pressures and stress of the frame from force balance, and the stress on its Gamma_p grid; after the
    surface stage, each vertex balanced in the height map's tangent plane and each cell's stress in its own
    (docs/surface.md, "Forces on a height map")."""
    tables = {name: frame.table(name) for name in ("cells", "vertices", "edges", "cell_vertices")}
    cells, edges, vertices = tables["cells"], tables["edges"], tables["vertices"]
    height = frame.images.get("surface") if frame.height_scale is not None else None
    on_surface = height is not None and "z" in vertices.columns
    normals = (node_normals(height, vertices["x"].to_numpy(float), vertices["y"].to_numpy(float),
                            frame.height_scale, frame.box) if on_surface else None)
    # the junction model needs the junctions' own pixels: a label image (not polygons)
    forces, curvature, model, share = frame_forces(frame.labels, cells, vertices, edges,
                                                   tables["cell_vertices"], box=frame.box,
                                                   junctions=options.junctions, method=options.method,
                                                   mu=options.mu, sd=options.sd, normals=normals)
    stress = cell_stress(cells, vertices, edges, forces.edges["tension"].to_numpy(),
                         forces.cells["pressure"].to_numpy(), box=frame.box, surface=on_surface)
    columns = {"cells": {"pressure": forces.cells["pressure"], "pressure_sd": forces.cells["pressure_sd"],
                         **{c: stress[c] for c in ("stress_xx", "stress_xy", "stress_yy")}},
               "edges": {"tension": forces.edges["tension"], "tension_sd": forces.edges["tension_sd"],
                         "curvature": pd.Series(curvature)}}
    for name, new in columns.items():
        table = frame.tables[name]
        for column, values in new.items():
            table[column] = values.to_numpy(float)
    grid = frame.table("grid") if "grid" in frame.tables else None
    if grid is not None and len(grid):
        frame.set_table("stress", stress_grid(cells, stress, grid, box=frame.box, surface=on_surface))
    else:
        frame.set_table("stress", empty_table("stress"))
    frame.set_table("force_fit", pd.DataFrame({
        "frame": [frame.t], "arcs": [model == "curved"], "curved_share": [share], "mu": [forces.mu],
        "residual": [forces.residual], "n_equations": [forces.n_equations], "n_unknowns": [forces.n_unknowns],
        "n_free": [int((forces.undetermined["reason"] == "free").sum())]}))
    if options.method == "bayes" and options.mu is None and forces.mu >= MU_RANGE[1] * (1 - 1e-9):
        # measured on mouse_epidermis_laptrack frame 1: every tension 1.00 with a median s.d. of 0.012
        warnings.warn(f"force inference: ABIC chose the largest prior weight it searches ({MU_RANGE[1]:g}): the "
                      f"junctions' geometry does not resolve tension differences here, so every tension is the "
                      f"prior's 1 and its s.d. the prior's, not a measurement", HexatissueWarning,
                      stacklevel=user_stacklevel())
    missing = forces.undetermined
    if len(missing):
        warnings.warn(_undetermined_warning(missing, options.method, n_edges=len(forces.edges), n_cells=len(forces.cells),
                                            n_equations=int(forces.n_equations)),
                      stacklevel=user_stacklevel())


def _undetermined_warning(missing, method, n_edges, n_cells, n_equations):
    """A :class:`FrameWarning` for the tensions and pressures the force balance does not fix: those it leaves free
    (an open tissue's border leaves fewer balanced vertices than unknowns: Bayes's prior completes them, least
    squares leaves them NaN) and those with no equation at all (NaN either way), counted in the frame's detail."""
    free = missing["reason"] == "free"
    counts = missing[~free].groupby(["kind", "reason"]).size()
    no_estimate = "; ".join(f"{n} {kind}(s): {reason}" for (kind, reason), n in counts.items())
    edges_free = int((free & (missing["kind"] == "edge")).sum())
    cells_free = int((free & (missing["kind"] == "cell")).sum())
    detail = (f"{edges_free} of {n_edges} tensions and {cells_free} of {n_cells} pressures not fixed by the balance "
              f"alone, {n_equations} equations" + (f"; no estimate: {no_estimate}" if no_estimate else ""))
    if method == "lsq":
        text = ("force inference (least squares): the force balance does not fix every tension and pressure (an open "
                "tissue's border leaves fewer balanced vertices than unknowns); those it leaves free are NaN, as are "
                "those without an equation; the Bayesian estimate (--mechanics-method bayes) completes the free ones")
    else:
        text = ("force inference: the force balance alone does not fix every tension and pressure (an open tissue's "
                "border leaves fewer balanced vertices than unknowns); the Bayesian estimate completes the free ones "
                "with its prior of equal tensions, and their tension_sd / pressure_sd say how well the data pin them; "
                "tensions and pressures without any equation are NaN")
    return FrameWarning(text, detail)


# ----------------------------------------------------------------------------
# Movie stages
# ----------------------------------------------------------------------------

def _new_tracker(options, source, box):
    """The tracker of the tracks stage (:class:`~hexatissue.track.MovieTracker`), for this source and box."""
    if source.kind == "polygons" and options.mode == "always":
        raise InputError("track mode 'always' (overlap tracking) needs label images; cells given as polygons are "
                         "tracked by their ids: use 'never' (ids are tracks), 'off' or 'auto'")
    return MovieTracker(options.mode, options.min_iou, options.child_fraction, options.mother_fraction,
                        options.max_gap, ids_consistent=source.ids_consistent, independent=source.independent,
                        follow=options.follow, periodic=box is not None)


def _tracker_params(tracker, source):
    """Whether the worker keeps every frame's pixels (gap closing needs them; polygons have none)."""
    return source.kind != "polygons" and tracker.needs_pixels


def _compact_batch(frames, pixels):
    """In the worker: each label frame compacted, with its overlaps with the batch's previous frame
    (:func:`hexatissue.track.compact_frames`), so the main process only links cells; polygon frames: their
    cell ids."""
    if frames and frames[0].cell_polygons is not None:
        return [(True, frame.labels, None) for frame in frames]
    return [(False, labels, overlaps) for labels, overlaps in compact_frames([f.labels for f in frames], pixels)]


def _link(tracker, payload, t):
    """In the main process, in frame order: the frame's cells linked to the earlier frames'."""
    ids, labels, overlaps = payload
    if ids:
        tracker.add_ids(labels, t)  # the cell ids: polygons have no labels to overlap
    else:
        tracker.add_valid(labels, t, overlaps)


#: The columns each movie stage reads, by table: a table kept on disk is read for these alone (the cells table of a
#: long movie holds ~20 columns; the tracks stage needs 6).  The T1 events stage reads the cells (frame, cell, track,
#: x, y, is_border) and the edges a block of frames at a time, from the tables as they are kept.
TRACK_READS = {"cells": ("frame", "cell", "x", "y", "area", "is_border")}
FLOW_READS = {"cells": ("frame", "cell", "track", "x", "y", "is_border", "z", "normal_x", "normal_y", "normal_z"),
              "grid": ("frame", "node", "x", "y", "radius", "valid", "normal_x", "normal_y", "normal_z")}
#: The flow's columns on a height map's surface (after the surface stage), in the cells table and the flow table.
SURFACE_VELOCITIES = ("vz", "surface_vx", "surface_vy", "vn")
SURFACE_FLOW = ("surface_vx", "surface_vy", "vn", "surface_vorticity", "surface_divergence", "surface_strain_xx",
                "surface_strain_xy", "mean_curvature", "areal_rate")
T1_READS = {"vertices": ("n_merged",)}
DEFECT_READS = {"grid": ("frame", "spacing")}
DEFORMATION_READS = {"cells": ("frame", "cell", "track", "x", "y", "area", "is_border"),
                     "vertices": ("frame", "vertex", "x", "y", "degree", "is_border"),
                     "cell_vertices": ("frame", "cell", "rank", "vertex", "image_x", "image_y"),
                     "grid": ("frame", "node", "row", "col", "x", "y", "valid", "radius", "spacing")}


def _tracks(movie, options):
    """Each cell's ``track`` from the tracker, the lineage, and what tracking decided.

    Chunk by chunk of the cells' frames (one chunk for tables in memory): the
    tracks are written, and each chunk's tracks' spans and counts kept; the
    lineage is made of the spans, and its divisions and extrusions checked on
    the rows of the tracks they look at alone (a second pass).
    """
    tracker, src = movie.states["track"], movie.source
    writer = movie.column_writer("cells", "track", np.int64, after="cell")
    spans, counts = [], []
    for span in movie.frame_chunks("cells"):
        cells = cells_with_tracks(movie.read("cells", TRACK_READS["cells"], frames=span), tracker, span)
        track = cells["track"].to_numpy(np.int64)
        writer.write(track)
        spans.append(track_spans(cells["frame"].to_numpy(np.int64), track, cells["is_border"].to_numpy(bool)))
        counts.append(CellCounts.of(cells))
    writer.close()
    counts = CellCounts.join(counts)
    # a source that records its divisions (CTC folders) is the lineage wherever its ids are the tracks
    keep_ids = src.parents is not None and tracker.decision()[0] == "never"
    parents = src.parents if keep_ids else tracker.parents
    frames = (int(counts.frames[0]), int(counts.frames[-1])) if len(counts.frames) else (0, 0)
    lineage = lineage_from_spans(join_spans(spans), parents, frames)
    checked = _rows_of_tracks(movie, checked_tracks(lineage))
    lineage = check_divisions(lineage, checked, options.division_min_frames, options.division_min_cycle,
                              options.division_area_tolerance, 1 + options.max_gap)
    movie.tables["lineage"] = check_extrusions(lineage, checked)
    movie.summary["tracking"] = tracking_summary(tracker, counts, parents, movie.tables["lineage"])
    broken = tracking_warning(movie.summary["tracking"])
    if broken:
        warnings.warn(broken, HexatissueWarning, stacklevel=user_stacklevel())
    movie.options["track"] = options.replace(mode=movie.summary["tracking"]["resolved"])
    movie.states["track"] = None  # its per-cell-frame ids are in cells now; the later stages need the memory


def _rows_of_tracks(movie, tracks):
    """``frame``, ``track``, ``area`` of the cells of ``tracks`` (sorted), read chunk by chunk."""
    parts = []
    for span in movie.frame_chunks("cells"):
        cells = movie.read("cells", ("frame", "track", "area"), frames=span)
        parts.append(cells[in_sorted(cells["track"].to_numpy(np.int64), tracks)])
    return pd.concat(parts, ignore_index=True) if len(parts) > 1 else parts[0].reset_index(drop=True)


def _defect_tracks(movie, options):
    """Defects linked over frames per p (``track``) and their pair events (``defect_events``).

    Chunk by chunk of the defects' frames (one chunk for tables in memory):
    the default largest displacement comes from the grid's spacings, counted
    chunk by chunk; then each chunk's defects are linked, carrying the last
    frame's defects of each p to the next chunk, and written as they are done.
    When the frames are unrelated images (tracking ``off``) every frame is
    tracked alone: each defect is its own track and there are no pair events.
    """
    n_frames = movie.n_frames
    with_grid, values, counts = _grid_spacings(movie)
    max_distance = options.defect_max_distance
    if max_distance is None:
        max_distance = default_max_distance(values, counts)
    missing = n_frames - with_grid if len(movie.tables["cells"]) else 0
    if missing:
        warnings.warn(f"{missing} of {n_frames} frame(s) have no interior cell with a polygon: no Gamma_p field "
                      f"or defects there", HexatissueWarning, stacklevel=user_stacklevel())
    linked = movie.summary.get("tracking", {}).get("resolved") != "off"
    linker = MovieDefects(options.p, max_distance, movie.box, linked)

    def chunks():
        # the parts as they are: each is read whole before the tracked one replaces it
        for first, last in movie.frame_chunks("defects") or [(0, max(n_frames - 1, 0))]:
            release_freed_memory()  # the previous chunk's working set, before this one's
            # every column (a table in memory is itself, emptied column by column as its rows are linked)
            yield (first, last), linker.link(movie.read("defects", frames=(first, last)), first, last)

    movie.put_chunks("defects", chunks(), options.p)
    movie.tables["defect_events"] = linker.events()


def _grid_spacings(movie):
    """How many frames have a grid, and the distinct values of the grid's ``spacing`` with how many rows hold each
    (per chunk, concatenated: a few a frame), read chunk by chunk of frames."""
    with_grid, values, counts = 0, [np.zeros(0)], [np.zeros(0, np.int64)]
    for span in movie.frame_chunks("grid"):
        grid = movie.read("grid", DEFECT_READS["grid"], frames=span)
        with_grid += distinct_count(grid["frame"].to_numpy())  # the chunks hold distinct frames
        chunk_values, chunk_counts = np.unique(grid["spacing"].to_numpy(float), return_counts=True)
        values.append(chunk_values)
        counts.append(chunk_counts)
    return with_grid, np.concatenate(values), np.concatenate(counts)


def _flow(movie, options):
    """Every tracked cell's velocity (``cells.vx``, ``vy``) and, on the Gamma_p grid when there is one, ``flow``;
    after the surface stage also on the surface: the cells' 3-D velocities in their tangent frames and, on the
    surface field's grid, the surface divergence and the areal rate with the normal motion (docs/flow.md).

    Chunk by chunk of the cells' frames (one chunk for tables in memory), each
    chunk independent (:func:`_flow_chunk`) and, when the tables are on disk,
    on the analysis's executor (:meth:`MovieData.map_chunks`); the results are
    written here, in chunk order.
    """
    gridded = "grid" in movie.tables
    surface = getattr(movie.options.get("surface"), "enabled", False)
    names = ("vx", "vy") + (SURFACE_VELOCITIES if surface else ())
    writers = {name: movie.column_writer("cells", name, np.float64) for name in names}
    spans = movie.frame_chunks("cells")
    results = movie.map_chunks(_flow_chunk, spans, movie.tables["cells"], movie.tables.get("grid"), movie.box,
                               options.radius_factor, options.min_cells, surface)

    def chunks():
        for span, (velocities, flow) in zip(spans, results):
            for name, writer in writers.items():
                writer.write(velocities[name])
            if gridded:
                yield span, flow

    with closing(results):  # an error here stops the chunks still running
        if gridded:
            movie.put_chunks("flow", chunks())
        else:
            for _ in chunks():  # the velocities are written as the chunks go; there is no field to keep
                pass
    for writer in writers.values():
        writer.close()
    if not gridded:
        return
    image = movie.images.get("intensity")
    if options.piv and image is not None and image.n_frames == movie.n_frames > 2:
        flow = movie.read("flow")
        piv = piv_fields(image.images(), movie.read("grid"), movie.box)
        for column in ("piv_vx", "piv_vy", "piv_peak"):
            flow[column] = piv[column].to_numpy()
        movie.tables["flow"] = flow


def _flow_chunk(span, cells, grid, box, radius_factor, min_cells, surface=False):
    """The tissue flow of frames ``span = (first, last)`` from the ``cells`` and ``grid`` tables as kept (grid None:
    no field): ``(velocities, flow)``, the span's cells' ``vx``, ``vy`` (and, on the ``surface``, the
    :data:`SURFACE_VELOCITIES`) by name in row order, and its ``flow`` rows (None without a grid).

    A velocity is a centred difference along the track, so the cells are read
    with one frame more on either side; the grid's fits are per frame.
    """
    release_freed_memory()  # the previous chunk's working set, before this one's
    first, last = span
    cells = read_table(cells, FLOW_READS["cells"], frames=(first - 1, last + 1))
    vx, vy = cell_velocities(cells, box)
    velocities = {"vx": vx, "vy": vy}
    if surface:
        velocities.update({name: values for name, values in surface_velocities(cells, box).items()
                           if name in SURFACE_VELOCITIES})
    frame = cells["frame"].to_numpy()
    inside = (frame >= first) & (frame <= last)
    velocities = {name: values[inside] for name, values in velocities.items()}
    if grid is None:
        return velocities, None
    cells = cells[inside].assign(**velocities)
    grid = read_table(grid, FLOW_READS["grid"], frames=span)
    flow = flow_fields(cells, grid, box, radius_factor, min_cells)
    if surface and "normal_x" in grid.columns:
        fields = surface_flow_fields(cells, grid, box, radius_factor, min_cells)
        for name in SURFACE_FLOW:
            flow[name] = fields[name].to_numpy()
    del cells, grid
    release_freed_memory()  # a worker would hold this chunk's working set while the others run theirs
    return velocities, flow


def _t1_events(movie, options):
    """Quartet T1s and per-cell neighbour changes from one pass over the contacts, classified."""
    censor = default_censor(movie.n_frames) if options.censor is None else options.censor
    tables = movie.tables
    # the cells and edges as they are kept: a table on disk is read a part at a time, a block of frames at a time
    # (hexatissue.events.frames.CellFrames, edge_blocks)
    tables["events"], tables["neighbour_events"] = t1_tables(tables["edges"], tables["cells"], options.min_length,
                                                             censor, movie.box)
    movie.summary["events"] = events_summary(tables["events"], censor, options.censor is not None, movie.n_frames,
                                             (movie.read("vertices", T1_READS["vertices"], frames=span)
                                              for span in movie.frame_chunks("vertices"))
                                             if "vertices" in tables else None)
    movie.options["events"] = options.replace(censor=censor)


def _cell_events(movie, options):
    """Per-cell T1 statistics; the rows of each track are the lineage's ``n_frames``."""
    movie.tables["cell_events"] = cell_event_stats(movie.tables["events"], lineage=movie.tables["lineage"])


def _deformation(movie, options):
    """The tissue's deformation budget per frame pair (whole tissue, grid regions, regions of interest).

    Chunk by chunk of the cells' frames (one chunk for tables in memory,
    :func:`~hexatissue.deformation.budget_chunks`): each chunk's rows are
    kept as the frame tables are (parts when streamed), the T1s' shares
    summed at the end.
    """
    tracking = movie.summary.get("tracking", {}).get("resolved")
    if tracking == "off" or movie.n_frames < 2:
        why = "its frames are unrelated images (tracking off)" if tracking == "off" else "it has one frame"
        raise InputError(f"the deformation budget needs cell tracks over consecutive frames; this source has none: "
                         f"{why}. Run it on a movie, without --track off")
    tables = movie.tables
    t1 = tables["events"] if options.t1_events == "quartets" else tables["neighbour_events"]
    gridded = bool(options.grid and "grid" in tables and len(tables["grid"]))
    roi = read_roi(options.roi) if options.roi is not None else None
    shape = tuple(movie.source.shape)[-2:]
    if roi is not None and roi.shape != shape:
        raise InputError(f"DeformationOptions.roi has shape {roi.shape}; the frames are {shape} (rows, cols)")
    names = ("cells", "vertices", "cell_vertices") + (("grid",) if gridded else ())

    def read(first, last):
        release_freed_memory()  # the previous chunk's working set, before this one's
        return {name: movie.read(name, DEFORMATION_READS[name], frames=(first, last)) for name in names}

    chunks = budget_chunks(read, movie.frame_chunks("cells"), tables["lineage"], t1, box=movie.box, grid=gridded,
                           roi=roi, roi_frame=options.roi_frame, t1_events=options.t1_events)
    doubtful = _doubtful_intervals(movie)
    shares = []
    summary = {"pairs": 0, "max_closure": 0.0, "n_flipped": 0, "doubtful_pairs": set()}

    def parts():
        for span, budget, share in chunks:
            budget["tracking_doubtful"] = budget["frame"].isin(doubtful).to_numpy(bool)
            shares.append(share)
            tissue = budget[budget["region"] == "tissue"]
            summary["pairs"] += int(len(tissue))
            summary["max_closure"] = max(summary["max_closure"], float(
                tissue[["closure_xx", "closure_xy"]].abs().to_numpy().max(initial=0.0)))
            summary["n_flipped"] += int(tissue["n_flipped"].sum())
            summary["doubtful_pairs"] |= set(tissue["frame"].tolist()) & doubtful
            yield span, budget

    movie.put_chunks("deformation", parts())
    if options.t1_events == "quartets":
        events = tables["events"].drop(columns=["shear_xx", "shear_xy"], errors="ignore")
        tables["events"] = events.merge(event_shear(shares), on="event", how="left")
    summary["doubtful_pairs"] = sorted(int(t) for t in summary["doubtful_pairs"])
    movie.summary["deformation"] = summary


def _doubtful_intervals(movie) -> set:
    """Intervals (their first frame) whose later frame's tracking is doubtful, or in which a suspect division or
    an unconfirmed extrusion happens: their events are more likely tracking errors than biology."""
    bad = {int(t) - 1 for t in movie.summary.get("tracking", {}).get("doubtful_frames", [])}
    lineage = movie.tables["lineage"]
    if "division_suspect" in lineage.columns:
        suspect = lineage[(lineage["parent"] > 0) & lineage["division_suspect"].to_numpy(bool)]
        bad |= {int(t) - 1 for t in suspect["frame_start"].tolist()}
    if "extrusion_unconfirmed" in lineage.columns:  # the cell is gone from the frame after its last one
        bad |= {int(t) for t in lineage.loc[lineage["extrusion_unconfirmed"].to_numpy(bool), "frame_end"].tolist()}
    return bad


def _fields_on(options):
    return options.fields


def _enabled(options):
    return options.enabled


#: Every stage of :func:`hexatissue.analyze`, in the order it runs: the frame stages (each frame, in a worker), then
#: the movie stages (once, in the main process).  ``tests/test_stages.py`` records a run and compares.
STAGES = (
    Stage("junction network", MeshOptions, "frame", reads=("labels",),
          writes=("cells", "vertices", "edges", "cell_vertices", "labels", "polygons"), run=_mesh,
          views="hexatissue.views.mesh"),
    Stage("intensity", IntensityOptions, "frame", reads=("labels", "image", "cells", "vertices", "edges"),
          writes=("cells.intensity_mean", "cells.junction_polarity_re", "cells.junction_polarity_im",
                  "edges.intensity_mean", "edges.intensity_total"),
          run=_intensity, enabled=_enabled, image=True),
    Stage("shape order", OrderOptions, "frame", reads=("polygons", "cells"),
          writes=("cells.gamma{p}_re", "cells.gamma{p}_im"), run=_shape_order, views="hexatissue.views.order"),
    Stage("surface", SurfaceOptions, "frame", reads=("polygons", "image", "cells", "vertices"),
          writes=("cells.z", "cells.surface_area", "cells.surface_perimeter", "cells.normal_x", "cells.normal_y",
                  "cells.normal_z", "cells.surface_gamma{p}_re", "cells.surface_gamma{p}_im", "vertices.z",
                  "height"),
          run=_surface, enabled=_enabled, image=True, views="hexatissue.views.surface"),
    Stage("order fields", OrderOptions, "frame", reads=("cells", "height"), writes=("grid", "defects"), run=_fields,
          enabled=_fields_on),
    Stage("mechanics", MechanicsOptions, "frame",
          reads=("labels", "cells", "vertices", "edges", "cell_vertices", "grid", "height"),
          writes=("edges.tension", "edges.tension_sd", "edges.curvature", "cells.pressure", "cells.pressure_sd",
                  "cells.stress_xx", "cells.stress_xy", "cells.stress_yy", "stress", "force_fit"),
          run=_mechanics, enabled=_enabled, views="hexatissue.views.mechanics"),
    Stage("tracks", TrackOptions, "movie", reads=("cells",), writes=("cells.track", "lineage"), run=_tracks,
          state=FrameState(new=_new_tracker, prepare=_compact_batch, add=_link, params=_tracker_params),
          views="hexatissue.views.track"),
    Stage("defect tracks", OrderOptions, "movie", reads=("cells", "grid", "defects"),
          writes=("defects.track", "defect_events"), run=_defect_tracks, enabled=_fields_on),
    Stage("tissue flow", FlowOptions, "movie", reads=("cells", "grid"),
          writes=("cells.vx", "cells.vy", "cells.vz", "cells.surface_vx", "cells.surface_vy", "cells.vn", "flow"),
          run=_flow, enabled=_enabled, views="hexatissue.views.flow"),
    Stage("T1 events", EventOptions, "movie", reads=("cells", "edges", "vertices"),
          writes=("events", "neighbour_events"), run=_t1_events, views="hexatissue.views.events"),
    Stage("cell events", EventOptions, "movie", reads=("events", "lineage"), writes=("cell_events",),
          run=_cell_events),
    Stage("deformation budget", DeformationOptions, "movie",
          reads=("cells", "vertices", "cell_vertices", "lineage", "events", "neighbour_events", "grid"),
          writes=("deformation", "events.shear_xx", "events.shear_xy"), run=_deformation, enabled=_enabled,
          views="hexatissue.views.deformation"),
)


def stage_options(given) -> dict:
    """The options of every stage by name: those ``given`` (checked), the defaults for the others.

    ``given`` maps stage names to options objects (None: the defaults); for a
    stage that measures an image (``intensity``), an image (path, array or
    Source) stands for its options with that image.
    """
    unknown = sorted(set(given) - set(OPTION_CLASSES))
    if unknown:
        raise TypeError(f"analyze() got unexpected keyword argument(s) {unknown}; the stages' options are "
                        f"{sorted(OPTION_CLASSES)}")
    image_stages = {s.options.stage for s in STAGES if s.image}
    options = {}
    for name, cls in OPTION_CLASSES.items():
        value = given.get(name)
        if value is None:
            value = cls()
        elif name in image_stages and not isinstance(value, cls):
            value = cls(image=value)  # an image stands for the stage's options with that image
        if not isinstance(value, cls):
            raise InputError(f"{name} must be a hexatissue.{cls.__name__}; got {type(value).__name__}")
        options[name] = value
    if options["deformation"].enabled and options["track"].mode == "off":
        raise InputError("DeformationOptions.enabled needs cell tracks, and TrackOptions.mode is 'off'")
    return options


def _active(per, options):
    return tuple(s for s in STAGES if s.per == per and s.runs_with(options[s.options.stage]))


def frame_stages(options) -> tuple:
    """The frame stages that run with ``options`` (by stage name), in order."""
    return _active("frame", options)


def movie_stages(options) -> tuple:
    """The movie stages that run with ``options`` (by stage name), in order."""
    return _active("movie", options)


def frame_tables(stages) -> tuple:
    """The tables (not columns) that the frame ``stages`` write."""
    return tuple(name for s in stages for name in s.writes if name in SCHEMAS)


def worker_stages(stages, options) -> tuple:
    """``(run, options)`` of the frame ``stages`` as a worker runs them.

    Only the stage's function goes to the worker (a module-level function,
    pickled by name); an image stage's image is read in the main process and
    sent frame by frame (:attr:`FrameData.images`), so its options go
    without it.
    """
    out = []
    for stage in stages:
        given = options[stage.options.stage]
        out.append((stage.run, replace(given, image=None, channel=None) if stage.image else given))
    return tuple(out)


def run_frame(frame, stages):
    """Run the frame ``stages`` (``(run, options)`` pairs, :func:`worker_stages`) on ``frame``.

    Returns the warnings they raised: caught here, in the worker, as
    ``(category, text, detail)`` triples (``detail``: the frame's part of a
    :class:`~hexatissue.errors.FrameWarning`, else ""), so the main process
    reports them with their frames.
    """
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            for run, options in stages:
                run(frame, options)
        except InputError as exc:  # name the frame, once
            where = f"frame {frame.t}"
            raise InputError(str(exc) if str(exc).startswith(where) else f"{where}: {exc}") from None
    return [(w.category, getattr(w.message, "text", str(w.message)), getattr(w.message, "detail", ""))
            for w in caught]
