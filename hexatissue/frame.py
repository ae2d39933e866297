"""Containers for one time point (:class:`Frame`) and a whole analysis (:class:`Movie`).

They hold tidy tables plus metadata and no algorithms.  Every table has a
``frame`` column (0 for a single image).  Positions are in pixels, ``x`` =
column and ``y`` = row, origin at the centre of pixel (0, 0); times in
frames.  The physical units travel in :class:`~hexatissue.units.Calibration`.

A results folder is a saved Movie: :meth:`Movie.write` and
:func:`read_results` round-trip every table and ``metadata.json``.
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field, fields, replace
from pathlib import Path

import numpy as np
import pandas as pd

from .box import Box
from .errors import InputError
from .geometry import mesh_order_polygons, table_polygons
from .units import Calibration

__all__ = ["Frame", "Movie", "read_results", "MESH_TABLES", "TABLES"]

MESH_TABLES = ("cells", "vertices", "edges", "cell_vertices")
#: Every table of a Movie, in the order they are written.
TABLES = MESH_TABLES + ("grid", "defects", "defect_events", "events", "neighbour_events", "lineage", "cell_events")
FORMATS = ("parquet", "csv")
METADATA = "metadata.json"


def _polygons(network) -> dict[int, np.ndarray]:
    keys, xy, starts = table_polygons(network.vertices, network.cell_vertices, network.box)
    ends = np.r_[starts[1:], len(xy)]
    return {int(c): xy[s:e] for c, s, e in zip(keys["cell"].to_numpy(), starts, ends)}


@dataclass
class Frame:
    """The junction network of one image.

    Attributes
    ----------
    cells, vertices, edges, cell_vertices : pandas.DataFrame
        Tables described in :mod:`hexatissue.schema`, each with ``frame``.
    frame : int
        Time point (0 for a single image).
    box : Box or None
        The periodic box, or None for an open image.
    shape : tuple of int
        ``(rows, cols)`` of the source image.
    calibration : Calibration
        Pixel size and frame interval (tables stay in px and frames).
    """

    cells: pd.DataFrame
    vertices: pd.DataFrame
    edges: pd.DataFrame
    cell_vertices: pd.DataFrame
    frame: int = 0
    box: Box | None = None
    shape: tuple = ()
    calibration: Calibration = field(default_factory=Calibration)

    def __post_init__(self):
        self._mesh_tables = ()  # cells, vertices, cell_vertices as mesh_from_labels built them (see from_mesh)

    @classmethod
    def from_mesh(cls, tables, frame, box, shape) -> "Frame":
        """The Frame of :func:`hexatissue.mesh_from_labels`: ``tables`` are in its row order.

        It remembers these very tables, so :meth:`mesh_polygons` can read
        the polygons row by row for as long as they are the Frame's tables.
        """
        out = cls(**tables, frame=frame, box=box, shape=shape)
        out._mesh_tables = (out.cells, out.vertices, out.cell_vertices)
        return out

    def mesh_polygons(self):
        """``(xy, starts)`` of the cells with ``n_sides > 0``, in the ``cells`` rows' order, or None.

        Read row by row (:func:`hexatissue.geometry.mesh_order_polygons`),
        without the keys :meth:`polygons` looks up, when the tables are
        those :meth:`from_mesh` was given (None for tables replaced or
        read back from files, and for rows that no longer add up).
        """
        now = (self.cells, self.vertices, self.cell_vertices)
        built = getattr(self, "_mesh_tables", ())  # (absent from a Frame pickled before it existed)
        if len(built) != len(now) or any(a is not b for a, b in zip(built, now)):
            return None
        return mesh_order_polygons(*now, self.box)

    def tables(self) -> dict[str, pd.DataFrame]:
        """The four tables by name."""
        return {name: getattr(self, name) for name in MESH_TABLES}

    def polygons(self) -> dict[int, np.ndarray]:
        """Ordered polygon of every cell: ``{cell: (n, 2) array of (x, y)}``, counter-clockwise in (x, y).

        In a periodic box each polygon is unwrapped to be contiguous from its
        first vertex (coordinates may then leave ``[0, L)``).
        """
        return _polygons(self)

    def replace(self, **changes) -> "Frame":
        """A copy with some attributes replaced."""
        return replace(self, **changes)


@dataclass
class Movie:
    """Every table of an analysis, concatenated over frames, plus the metadata to read it.

    Attributes
    ----------
    cells, vertices, edges, cell_vertices : pandas.DataFrame
        Junction networks (see :func:`hexatissue.mesh_from_labels`); ``cells``
        has ``track`` and ``gamma{p}`` columns after :func:`hexatissue.analyze`.
    grid, defects, defect_events : pandas.DataFrame or None
        Coarse-grained fields Gamma_p, their defects (with defect ``track``)
        and defect pair creation / annihilation.
    events, neighbour_events, lineage, cell_events : pandas.DataFrame or None
        T1 events (quartets), neighbour-list changes of each cell (the
        paper's per-cell definition), cell lineage and per-cell T1 statistics.
    box : Box or None
        Periodic box, or None for open images.
    shape : tuple of int
        ``(rows, cols)`` of the frames.
    n_frames : int
        Frames analysed (also those without cells).
    calibration : Calibration
        Pixel size and frame interval with their units.
    options : dict
        The options objects used, by stage name (``mesh``, ``order``, ``track``, ``events``).
    source : dict
        Description of the input (see :class:`hexatissue.Source`).
    version : str
        hexatissue version that produced the tables.
    summary : dict
        What :func:`hexatissue.analyze` decided from the data: ``tracking``
        (mode requested and used, why, id consistency, rows whose track
        differs from the cell id, divisions) and ``events`` (censoring
        window used and its rule, events classified).
    """

    cells: pd.DataFrame
    vertices: pd.DataFrame
    edges: pd.DataFrame
    cell_vertices: pd.DataFrame
    grid: pd.DataFrame | None = None
    defects: pd.DataFrame | None = None
    defect_events: pd.DataFrame | None = None
    events: pd.DataFrame | None = None
    neighbour_events: pd.DataFrame | None = None
    lineage: pd.DataFrame | None = None
    cell_events: pd.DataFrame | None = None
    box: Box | None = None
    shape: tuple = ()
    n_frames: int = 0
    calibration: Calibration = field(default_factory=Calibration)
    options: dict = field(default_factory=dict)
    source: dict = field(default_factory=dict)
    version: str = ""
    summary: dict = field(default_factory=dict)

    def __post_init__(self):
        if not self.n_frames:
            self.n_frames = int(self.cells["frame"].max()) + 1 if len(self.cells) else 0

    @classmethod
    def from_frames(cls, frames) -> "Movie":
        """Concatenate :class:`Frame` objects (their ``frame`` attribute is the frame index)."""
        frames = list(frames)
        if not frames:
            raise InputError("frames must contain at least one Frame; got an empty sequence")
        tables = {}
        for name in MESH_TABLES:
            parts = [getattr(f, name).assign(frame=np.int64(f.frame)) for f in frames]
            tables[name] = pd.concat(parts, ignore_index=True)
        first = frames[0]
        n = max(int(f.frame) for f in frames) + 1
        return cls(**tables, box=first.box, shape=first.shape, n_frames=n, calibration=first.calibration)

    @property
    def frames(self) -> np.ndarray:
        """Sorted frame indices present in the cells table."""
        return np.unique(self.cells["frame"].to_numpy())

    def __len__(self) -> int:
        return int(self.n_frames)

    def frame(self, t: int) -> Frame:
        """The :class:`Frame` at time point ``t`` (its four mesh tables; ``cells`` keeps every column)."""
        if not 0 <= t < self.n_frames:
            raise InputError(f"frame {t} is not in this movie; it has frames 0..{self.n_frames - 1}")
        parts = {name: self.table_at(name, t) for name in MESH_TABLES}
        return Frame(**parts, frame=int(t), box=self.box, shape=self.shape, calibration=self.calibration)

    def table_at(self, name: str, t: int) -> pd.DataFrame:
        """Rows of table ``name`` at frame ``t`` (index reset)."""
        table = self.tables().get(name)
        if table is None:
            raise InputError(f"this movie has no {name!r} table; it has {sorted(self.tables())}")
        return table[table["frame"].to_numpy() == t].reset_index(drop=True)

    def polygons(self, t: int) -> dict[int, np.ndarray]:
        """Cell polygons of frame ``t`` (see :meth:`Frame.polygons`)."""
        return self.frame(t).polygons()

    def tables(self) -> dict[str, pd.DataFrame]:
        """Every table present, by name, in :data:`TABLES` order."""
        return {name: getattr(self, name) for name in TABLES if getattr(self, name) is not None}

    def replace(self, **changes) -> "Movie":
        """A copy with some attributes replaced."""
        return replace(self, **changes)

    def metadata(self) -> dict:
        """What ``metadata.json`` holds: box, shape, frames, calibration, options, summary, source, version."""
        return {
            "hexatissue_version": self.version,
            "n_frames": int(self.n_frames),
            "shape": [int(s) for s in self.shape],
            "box": None if self.box is None else self.box.to_list(),
            "calibration": self.calibration.to_dict(),
            "options": {name: opts.to_dict() for name, opts in self.options.items()},
            "summary": self.summary,
            "source": self.source,
            "tables": {name: int(len(table)) for name, table in self.tables().items()},
        }

    def write(self, directory, formats=("parquet",)) -> list[Path]:
        """Write every table to ``directory/<table>.<fmt>`` and ``metadata.json`` (last); returns the paths.

        Files are written to temporary names and renamed, so a folder is never
        left with half a table; ``metadata.json`` is written last, so a folder
        that has it is complete.  Rewriting an existing results folder first
        removes its ``metadata.json`` (a write interrupted half-way leaves a
        folder that :func:`read_results` refuses, never old and new tables
        passing for one result), then the tables of this Movie are written
        and the old tables it does not have are removed.
        """
        return write_results(self, directory, formats)


def write_results(movie, directory, formats=("parquet",), release=False) -> list[Path]:
    """:meth:`Movie.write`; with ``release``, each table is dropped from ``movie`` once written, smallest first.

    For a caller that does not use the tables afterwards (``hexatissue
    analyze``): the Parquet writer's buffers then come on top of the tables
    not yet written, not of all of them (the largest is written last, when
    the others are freed).  The files are the same either way.
    """
    from .io import atomic_path, check_output_folder, write_table
    from ._system import release_freed_memory

    formats = tuple(formats) if isinstance(formats, (list, tuple)) else (formats,)
    bad = [f for f in formats if f not in FORMATS]
    if bad or not formats:
        raise InputError(f"formats must be one or more of {FORMATS}; got {list(formats)}")
    directory = check_output_folder(directory, "directory")
    meta = dict(movie.metadata(), formats=list(formats))  # before any table is released
    (directory / METADATA).unlink(missing_ok=True)  # the folder is incomplete from here until the end
    tables = movie.tables()
    names = sorted(tables, key=lambda n: int(tables[n].memory_usage().sum())) if release else list(tables)
    written = []
    for name in names:
        if release:  # the previous table's pages (and what the caller freed last), before this table's buffers
            release_freed_memory()
        written += [write_table(tables[name], directory / f"{name}.{fmt}") for fmt in formats]
        if release:
            del tables[name]
            setattr(movie, name, None)
    for name in TABLES:
        for fmt in FORMATS:
            stale = directory / f"{name}.{fmt}"
            if stale not in written:
                stale.unlink(missing_ok=True)
    with atomic_path(directory / METADATA) as tmp:
        tmp.write_text(json.dumps(meta, indent=2))
    return written + [directory / METADATA]


def read_results(directory) -> Movie:
    """A results folder (:meth:`Movie.write`, ``hexatissue analyze``) read back as a :class:`Movie`.

    Parameters
    ----------
    directory : str or Path
        Folder holding ``metadata.json`` and the tables (Parquet preferred
        over CSV when both exist).

    Returns
    -------
    Movie
        Every table found, with box, shape, number of frames, calibration,
        options, summary, source and version from ``metadata.json``.
    """
    from .io import read_table
    from .options import OPTION_CLASSES
    from .schema import TABLES as SCHEMAS, coerce

    folder = Path(directory)
    if not folder.is_dir():
        raise InputError(f"results folder {str(folder)!r} does not exist or is not a folder; expected the output "
                         f"of hexatissue analyze")
    meta_path = folder / METADATA
    if not meta_path.exists():
        raise InputError(f"results folder {str(folder)!r} has no {METADATA}: it is not a complete hexatissue "
                         f"results folder (analyze writes metadata.json last)")
    try:
        meta = json.loads(meta_path.read_text())
        if not isinstance(meta, dict):
            raise ValueError("not a JSON object")
    except (OSError, ValueError) as exc:
        raise InputError(f"results folder {str(folder)!r}: {METADATA} cannot be read ({exc}); the folder is "
                         f"damaged: write it again") from None
    tables = {}
    for name in TABLES:
        for fmt in FORMATS:
            path = folder / f"{name}.{fmt}"
            if path.exists():
                table = read_table(path)
                tables[name] = coerce(table, name) if fmt == "csv" and name in SCHEMAS else table
                break
    # metadata.json is the manifest: every table it lists must be there, with the row count it gives
    listed = meta.get("tables", {})
    wrong = [name for name, rows in listed.items() if name in TABLES
             and (name not in tables or len(tables[name]) != int(rows))]
    if wrong:
        raise InputError(f"results folder {str(folder)!r} does not match its {METADATA}: table(s) {wrong} are "
                         f"missing or have other row counts; the folder is damaged or was partly overwritten")
    missing = [name for name in MESH_TABLES if name not in tables]
    if missing:
        raise InputError(f"results folder {str(folder)!r} is missing table(s) {missing}")
    try:
        options = {name: OPTION_CLASSES[name].from_dict(value) for name, value in meta.get("options", {}).items()}
    except (InputError, KeyError) as exc:
        raise InputError(f"results folder {str(folder)!r} was written by hexatissue "
                         f"{meta.get('hexatissue_version', '?')} with options this version cannot read ({exc}); "
                         f"analyse the data again") from None
    known = {f.name for f in fields(Movie)}
    return Movie(**{k: v for k, v in tables.items() if k in known},
                 box=None if meta.get("box") is None else Box(*meta["box"]),
                 shape=tuple(meta.get("shape", ())), n_frames=int(meta.get("n_frames", 0)),
                 calibration=Calibration.from_dict(meta.get("calibration", {})), options=options,
                 source=meta.get("source", {}), version=meta.get("hexatissue_version", ""),
                 summary=meta.get("summary", {}))
