"""Cell polygons as input: vertices tables, Tissue Analyzer ``TA.db``, hexanematic ``.mat`` files.

Three formats are read (each into :class:`~hexatissue.mesh.polygons.Polygons`, one per frame):

- a **vertices table** (CSV or Parquet): one row per polygon vertex, columns
  ``cell``, ``x``, ``y`` with each cell's rows contiguous and in polygon
  order, and an optional ``frame`` column for movies (ids are then taken as
  tracks: a cell keeps its id over time);
- a **Tissue Analyzer** ``TA.db`` (SQLite): the ``Cells`` table's
  ``vx_coords_cells`` (``"x:y#x:y#..."``, TA's vertices in order);
- the **hexanematic** ``ImageN_Polygon.mat`` files (MATLAB struct
  ``Polygon`` with ``Vertex{k}``, closed polygons): one file is one frame, a
  folder of them is a set of independent images (not a movie).

:func:`open_polygons` opens any of them for :func:`hexatissue.open_source`
(a Source of ``kind == "polygons"``); the network is built from the
polygons by :func:`hexatissue.mesh.polygons.polygon_network`.  Coordinates
are taken as given: x = column, y = row, px.
"""
from __future__ import annotations

import sqlite3
from pathlib import Path

import numpy as np
import pandas as pd

from ..errors import InputError
from ..geometry import pack_polygons
from ..mesh.polygons import Polygons, polygon_shape
from ..schema import rows_by_frame
from .base import Opened, natural_key
from .folder import IMAGE_SUFFIXES

__all__ = ["TABLE_SUFFIXES", "TA_SUFFIXES", "POLYGON_SUFFIXES", "read_vertices_table", "read_tissue_analyzer",
           "read_polygon_mat", "PolygonReader", "is_polygon_folder", "open_polygons"]

TABLE_SUFFIXES = (".csv", ".parquet")
TA_SUFFIXES = (".db", ".sqlite")
POLYGON_SUFFIXES = TABLE_SUFFIXES + TA_SUFFIXES + (".mat",)


def read_vertices_table(path) -> tuple[list, list]:
    """Polygons of a vertices table (CSV or Parquet), frame by frame.

    Parameters
    ----------
    path : str or Path
        ``.csv`` or ``.parquet`` with columns ``cell`` (positive integer
        ids), ``x``, ``y`` (px; x = column, y = row) and optionally
        ``frame`` (integers); one row per vertex, each cell's rows
        contiguous and in polygon order (a repeated closing vertex is
        dropped).  Other columns are ignored.

    Returns
    -------
    frames : list of Polygons
        One per distinct ``frame`` value, ascending (one frame without the column).
    values : list of int
        The file's frame value of each.
    """
    path = Path(path)
    try:
        table = pd.read_parquet(path) if path.suffix.lower() == ".parquet" else pd.read_csv(path)
    except Exception as exc:  # any reader failure is a bad file
        raise InputError(f"could not read the vertices table {str(path)!r}: {type(exc).__name__}: {exc}") from exc
    missing = [c for c in ("cell", "x", "y") if c not in table.columns]
    if missing:
        raise InputError(f"vertices table {path.name!r} is missing column(s) {missing}; expected columns cell, x, y "
                         f"(one row per polygon vertex, in order) and optionally frame; it has {list(table.columns)}")
    if len(table) == 0:
        raise InputError(f"vertices table {path.name!r} has no rows; expected one row per polygon vertex")
    for name in ("cell", "frame") if "frame" in table.columns else ("cell",):
        column = table[name]
        if not pd.api.types.is_numeric_dtype(column) or column.isna().any() or (column % 1 != 0).any():
            raise InputError(f"vertices table {path.name!r}: column {name!r} must hold integers; got dtype "
                             f"{column.dtype}")
    for name in ("x", "y"):
        if not pd.api.types.is_numeric_dtype(table[name]):
            raise InputError(f"vertices table {path.name!r}: column {name!r} must hold numbers (px); got dtype "
                             f"{table[name].dtype}")
        bad = ~np.isfinite(table[name].to_numpy(float))
        if bad.any():
            row = int(np.flatnonzero(bad)[0])
            raise InputError(f"vertices table {path.name!r}: column {name!r} is empty, NaN or infinite on row {row} "
                             f"(cell {table['cell'].iloc[row]}); expected a finite coordinate (px) on every row")
    frame = table["frame"].to_numpy(np.int64) if "frame" in table.columns else np.zeros(len(table), np.int64)
    cell = table["cell"].to_numpy(np.int64)
    xy = table[["x", "y"]].to_numpy(float)
    frames, values = [], []
    for value, rows in rows_by_frame(frame).items():
        ids, first, counts = _runs(cell[rows])
        at = f"{path.name!r}" + (f", frame {value}" if "frame" in table.columns else "")
        if len(np.unique(ids)) < len(ids):
            repeated = ids[pd.Series(ids).duplicated().to_numpy()][0]
            raise InputError(f"vertices table {at}: the rows of cell {repeated} are not contiguous; expected each "
                             f"cell's vertices on consecutive rows, in polygon order")
        polys = [xy[rows[s:s + c]] for s, c in zip(first, counts)]
        packed, starts = pack_polygons(polys, "polygons")
        frames.append(Polygons(ids, packed, starts))
        values.append(int(value))
    if not frames:
        raise InputError(f"vertices table {path.name!r} has no rows; expected one row per polygon vertex")
    return frames, values


def _runs(values):
    """Value, first index and length of each run of equal consecutive values."""
    if not len(values):
        return values, np.zeros(0, np.int64), np.zeros(0, np.int64)
    first = np.flatnonzero(np.r_[True, values[1:] != values[:-1]])
    return values[first], first, np.diff(np.r_[first, len(values)])


def read_tissue_analyzer(path) -> tuple[Polygons, list]:
    """Cell polygons of a Tissue Analyzer database (``TA.db``).

    TA stores each cell's vertices, in order, in ``Cells.vx_coords_cells``
    as ``"x:y#x:y#..."`` (px; x = column, y = row); neighbouring cells list
    the same vertex coordinates.  Cells with fewer than 3 vertices (TA's
    slivers cut by the image edge, all border cells) have no polygon and
    are left out.

    Returns
    -------
    polygons : Polygons
        Cells in the table's row order, ids ``local_id_cells``.
    notes : list of str
        What was left out.
    """
    path = Path(path)
    try:
        with sqlite3.connect(f"file:{path}?mode=ro", uri=True) as con:
            names = {r[0] for r in con.execute("select name from sqlite_master where type='table'")}
            if "Cells" not in names:
                raise InputError(f"{path.name!r} is not a Tissue Analyzer database: it has no Cells table "
                                 f"(tables: {sorted(names)})")
            rows = con.execute("select local_id_cells, vx_coords_cells from Cells").fetchall()
    except sqlite3.Error as exc:
        raise InputError(f"could not read {str(path)!r} as a Tissue Analyzer database (SQLite): {exc}") from exc
    ids, polys, dropped = [], [], []
    for cell, coords in rows:
        try:
            xy = np.array([[float(v) for v in point.split(":")] for point in str(coords).split("#")], float)
        except ValueError:
            raise InputError(f"{path.name!r}: vx_coords_cells of cell {cell} is not 'x:y#x:y#...'; got "
                             f"{str(coords)[:60]!r}") from None
        if xy.ndim != 2 or xy.shape[1] != 2:
            raise InputError(f"{path.name!r}: vx_coords_cells of cell {cell} is not 'x:y#x:y#...'")
        if len(np.unique(xy, axis=0)) < 3:
            dropped.append(int(cell))
            continue
        ids.append(int(cell))
        polys.append(xy)
    packed, starts = pack_polygons(polys, "polygons")
    notes = [f"Tissue Analyzer cells with fewer than 3 vertices left out (no polygon): {dropped}"] if dropped else []
    return Polygons(np.asarray(ids, np.int64), packed, starts), notes


def read_polygon_mat(path) -> Polygons:
    """Cell polygons of a hexanematic ``ImageN_Polygon.mat`` (Armengol-Collado et al. 2023).

    The MATLAB struct ``Polygon`` holds ``Vertex{k}``: the closed polygon of
    cell ``k`` (first vertex repeated; columns x, y in px).  Cells are
    numbered 1..K in file order (row k of the published ``exp_N.dat``).
    """
    from scipy.io import loadmat

    path = Path(path)
    try:
        data = loadmat(path, simplify_cells=True)
    except Exception as exc:  # not a MATLAB file
        raise InputError(f"could not read {str(path)!r} as a MATLAB .mat file: {type(exc).__name__}: {exc}") from exc
    polygon = data.get("Polygon")
    if not isinstance(polygon, dict) or "Vertex" not in polygon:
        found = sorted(k for k in data if not k.startswith("__"))
        raise InputError(f"{path.name!r} has no struct 'Polygon' with a field 'Vertex' (the hexanematic polygon "
                         f"format); it holds {found}")
    vertex = polygon["Vertex"]
    vertex = [vertex] if isinstance(vertex, np.ndarray) and vertex.dtype != object else list(vertex)
    polys = []
    for k, v in enumerate(vertex, start=1):
        v = np.asarray(v, float)
        if v.ndim != 2 or v.shape[1] != 2 or len(v) < 2:
            raise InputError(f"{path.name!r}: Polygon.Vertex{{{k}}} must be an (n + 1, 2) array of x, y; got shape "
                             f"{v.shape}")
        if not np.array_equal(v[0], v[-1]):
            raise InputError(f"{path.name!r}: Polygon.Vertex{{{k}}} is not closed (its last vertex is not its first); "
                             f"the hexanematic format repeats the first vertex at the end")
        polys.append(v)
    packed, starts = pack_polygons(polys, "Polygon.Vertex")
    return Polygons(np.arange(1, len(polys) + 1, dtype=np.int64), packed, starts)


class PolygonReader:
    """Frames of polygons for :class:`~hexatissue.Source` (read eagerly: polygon files are small).

    ``kind == "polygons"``: :meth:`polygons` gives a frame, :meth:`read` refuses.
    """

    kind = "polygons"

    def __init__(self, frames, independent, description):
        self.frames = frames
        self.independent = independent
        self.n_frames = len(frames)
        self.shape = polygon_shape(frames)
        self.description = description

    def describe(self) -> dict:
        return {**self.description, "n_cells": [len(f) for f in self.frames]}

    def polygons(self, t) -> Polygons:
        return self.frames[t]

    def read(self, t):
        raise InputError(f"{self.description['path']!r} holds cell polygons, not a label image: analyze it "
                         f"(hexatissue.analyze) or read its polygons with source.polygons(t)")


def is_polygon_folder(path: Path) -> bool:
    """A folder of hexanematic ``.mat`` polygon files and no images."""
    suffixes = {p.suffix.lower() for p in path.iterdir() if p.is_file() and not p.name.startswith(".")}
    return ".mat" in suffixes and not suffixes & set(IMAGE_SUFFIXES)


def open_polygons(path) -> Opened:
    """Cell polygons from a vertices table, a ``TA.db`` or ``.mat`` file(s), for :func:`hexatissue.open_source`.

    Parameters
    ----------
    path : Path
        A ``.csv``/``.parquet`` vertices table, a Tissue Analyzer ``.db``, a
        hexanematic ``.mat`` file, or a folder of ``.mat`` files (one
        independent image each, natural order).

    Returns
    -------
    Opened
        A :class:`PolygonReader` (``kind == "polygons"``; the Source's
        ``source.polygons(t)`` gives frame ``t``) and its description.  A
        vertices table with a ``frame`` column is a movie whose ids are the
        tracks (``ids_consistent``); a folder of ``.mat`` files is a set of
        independent images (``independent``: nothing is tracked).
    """
    path = Path(path)
    suffix = path.suffix.lower()
    base = {"path": str(path), "notes": []}
    if path.is_dir():
        files = sorted((p for p in path.iterdir() if p.suffix.lower() == ".mat" and not p.name.startswith(".")),
                       key=lambda p: natural_key(p.name))
        frames = [read_polygon_mat(p) for p in files]
        description = {**base, "kind": "polygon_mat_folder", "files": [p.name for p in files],
                       "notes": ["each .mat file is an independent image, not a movie frame: nothing is tracked"]}
        return Opened(PolygonReader(frames, True, description), description)
    if suffix in TABLE_SUFFIXES:
        frames, values = read_vertices_table(path)
        description = {**base, "kind": "vertices_table", "frame_values": values}
        if values != list(range(len(values))):
            description["notes"] = [f"the table's frame values {values[:5]}{'...' if len(values) > 5 else ''} are "
                                    f"frames 0 to {len(values) - 1}"]
        return Opened(PolygonReader(frames, False, description), description, ids_consistent=True)
    if suffix in TA_SUFFIXES:
        polygons, notes = read_tissue_analyzer(path)
        description = {**base, "kind": "tissue_analyzer", "notes": notes}
        return Opened(PolygonReader([polygons], True, description), description)
    description = {**base, "kind": "polygon_mat"}
    return Opened(PolygonReader([read_polygon_mat(path)], True, description), description)
