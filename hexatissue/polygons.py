"""Cell polygons as input: the junction network without a label image.

Three formats are read (each into :class:`Polygons`, one per frame):

- a **vertices table** (CSV or Parquet): one row per polygon vertex, columns
  ``cell``, ``x``, ``y`` with each cell's rows contiguous and in polygon
  order, and an optional ``frame`` column for movies (ids are then taken as
  tracks: a cell keeps its id over time);
- a **Tissue Analyzer** ``TA.db`` (SQLite): the ``Cells`` table's
  ``vx_coords_cells`` (``"x:y#x:y#..."``, TA's vertices in order);
- the **hexanematic** ``ImageN_Polygon.mat`` files (MATLAB struct
  ``Polygon`` with ``Vertex{k}``, closed polygons): one file is one frame, a
  folder of them is a set of independent images (not a movie).

:func:`polygon_network` turns one frame of polygons into the four tables the
mesh makes from labels (``cells``, ``vertices``, ``edges``,
``cell_vertices``; same schema).  Coordinates are taken as given: x =
column, y = row, px (the files' own origin, no half-pixel shift).
"""
from __future__ import annotations

import sqlite3
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from .errors import HexatissueWarning, InputError
from .geometry import next_vertex, pack_polygons, polygon_area_centroid, polygon_cells
from .schema import rows_by_frame, validate

__all__ = ["Polygons", "SHARED_TOLERANCE", "polygon_network", "mesh_from_polygons", "read_vertices_table",
           "read_tissue_analyzer", "read_polygon_mat", "POLYGON_SUFFIXES"]

#: Polygon vertices closer than this (px) are one vertex of the network (shared by the polygons).
SHARED_TOLERANCE = 1e-6
TABLE_SUFFIXES = (".csv", ".parquet")
TA_SUFFIXES = (".db", ".sqlite")
POLYGON_SUFFIXES = TABLE_SUFFIXES + TA_SUFFIXES + (".mat",)


@dataclass(frozen=True, eq=False)
class Polygons:
    """The cell polygons of one frame, back to back, in the file's cell order.

    Attributes
    ----------
    cell : (N,) int64 array
        Cell ids (positive, distinct).
    xy : (M, 2) float array
        Vertices (x = column, y = row, px), polygon after polygon, not closed.
    starts : (N,) int64 array
        First row in ``xy`` of each polygon.
    """

    cell: np.ndarray
    xy: np.ndarray
    starts: np.ndarray

    def __len__(self):
        return len(self.cell)


def as_polygons(polygons, name="polygons") -> Polygons:
    """:class:`Polygons` from ``{cell: (n, 2) array}`` or a sequence of arrays (cells numbered from 1)."""
    if isinstance(polygons, Polygons):
        return polygons
    if isinstance(polygons, dict):
        ids, polys = list(polygons), list(polygons.values())
    else:
        polys = list(polygons)
        ids = list(range(1, len(polys) + 1))
    xy, starts = pack_polygons(polys, name)
    return Polygons(np.asarray(ids, np.int64), xy, starts)


# ---------------------------------------------------------------------------------------------------------
# polygons -> network tables
# ---------------------------------------------------------------------------------------------------------
def polygon_network(polygons, frame=0, tolerance=SHARED_TOLERANCE, where="") -> dict:
    """The junction network of cell polygons: the tables :func:`hexatissue.mesh_from_labels` makes.

    Polygon vertices closer than ``tolerance`` are one network vertex (at
    their mean position); a polygon side used by two polygons is the
    junction between them, a side used by one only is a junction with the
    outside (cell 0), so its cell and vertices are on the border.  Every
    polygon vertex is a network vertex and every side an edge (a vertex
    shared by two cells only has degree 2).  Polygons are made
    counter-clockwise in (x, y); repeated consecutive vertices are dropped.

    Parameters
    ----------
    polygons : Polygons, dict or sequence
        One frame of polygons (see :func:`as_polygons`); x = column, y = row, px.
    frame : int
        Frame number written in every table.
    tolerance : float
        Distance (px) within which vertices are shared.  A vertex of one
        polygon lying on a side of another without being its vertex is not
        detected (that side stays a border side of both).
    where : str
        Where the polygons come from, for error messages.

    Returns
    -------
    dict of pandas.DataFrame
        ``cells``: ``frame``, ``cell``, ``x``, ``y`` (area centroid of the
        polygon, px), ``area`` and ``polygon_area`` (polygon area, px^2),
        ``perimeter`` (px), ``n_sides``, ``n_boundaries`` (1), ``is_border``
        (a side not shared with another polygon), in the input's cell order;
        ``vertices``: ``frame``, ``vertex``, ``x``, ``y`` (px), ``degree``,
        ``is_border``; ``edges``: ``frame``, ``edge``, ``vertex_a``,
        ``vertex_b``, ``cell_a`` < ``cell_b`` (0 = outside), ``length`` (px);
        ``cell_vertices``: ``frame``, ``cell``, ``rank`` (counter-clockwise),
        ``vertex``, ``image_x``, ``image_y`` (0).

    Raises
    ------
    InputError
        Ids not positive or repeated, coordinates not finite, a polygon with
        fewer than 3 distinct vertices, of zero area or passing through one
        vertex twice.

    Warns
    -----
    HexatissueWarning
        Polygons that overlap along a side (a side used by three polygons, or
        by two on the same side of it: digitisation errors occur in published
        polygon data); such a side is a junction between the first two cells
        using it.
    """
    polys = as_polygons(polygons)
    at = f" ({where})" if where else ""
    cell, xy = polys.cell, polys.xy
    _check_ids(cell, at)
    owner = _owner(polys)
    bad = ~np.isfinite(xy).all(axis=1)
    if bad.any():
        raise InputError(f"polygon of cell {cell[owner[bad][0]]}{at} has a NaN or infinite vertex; expected finite "
                         f"x, y (px)")
    vid, position = _shared_vertices(xy, tolerance)
    keep = vid != vid[next_vertex(len(xy), polys.starts)]  # drops repeats, including a closing vertex
    vid, owner = vid[keep], owner[keep]
    lengths = np.bincount(owner, minlength=len(cell))
    starts = (np.cumsum(lengths) - lengths).astype(np.int64)
    _check_polygons(cell, vid, owner, lengths, at)
    area, _ = polygon_area_centroid(position[vid], starts)
    flat = np.abs(area) <= 1e-12 * np.maximum(1.0, _extent(position) ** 2)
    if flat.any():
        raise InputError(f"polygon of cell {cell[np.flatnonzero(flat)[0]]}{at} has zero area (its vertices are "
                         f"collinear); expected a closed polygon enclosing the cell")
    vid = _counter_clockwise(vid, starts, lengths, area < 0)
    cells, vertices, edges, cell_vertices = _tables(cell, vid, owner, starts, position)
    out = {}
    for name, table in (("cells", cells), ("vertices", vertices), ("edges", edges), ("cell_vertices", cell_vertices)):
        table.insert(0, "frame", np.full(len(table), frame, dtype=np.int64))
        out[name] = validate(table, name)
    return out


def mesh_from_polygons(polygons, tolerance=SHARED_TOLERANCE, frame=0):
    """The junction network of cell polygons as a :class:`~hexatissue.Frame` (see :func:`polygon_network`).

    Parameters
    ----------
    polygons : Polygons, dict or sequence
        ``{cell: (n, 2) array of (x, y)}`` or a sequence (cells numbered from
        1); x = column, y = row, px.  A repeated closing vertex is dropped.
    tolerance : float
        Vertices closer than this (px) are shared.
    frame : int
        Frame number of the tables.

    Returns
    -------
    Frame
        ``cells``, ``vertices``, ``edges``, ``cell_vertices`` as
        :func:`polygon_network` describes; shape from the largest
        coordinates, open image (no box).
    """
    from .frame import Frame

    polys = as_polygons(polygons)
    return Frame(**polygon_network(polys, frame, tolerance), frame=frame, shape=polygon_shape([polys]))


def polygon_shape(frames) -> tuple:
    """``(rows, cols)`` of the image the polygons lie in: the pixels holding their largest y and x (at least 1)."""
    top = np.zeros(2)
    for polys in frames:
        if len(polys.xy):
            top = np.maximum(top, np.floor(polys.xy.max(axis=0) + 0.5) + 1)
    return int(max(top[1], 1)), int(max(top[0], 1))


def _owner(polys):
    return np.repeat(np.arange(len(polys.cell)), np.diff(np.r_[polys.starts, len(polys.xy)]))


def _extent(position):
    return float(np.ptp(position, axis=0).max()) if len(position) else 1.0


def _check_ids(cell, at):
    if (cell <= 0).any():
        raise InputError(f"cell ids{at} must be positive (0 is the outside); got {int(cell[cell <= 0][0])}")
    ids, counts = np.unique(cell, return_counts=True)
    if (counts > 1).any():
        raise InputError(f"cell ids{at} must be distinct within a frame (one polygon per cell); cell "
                         f"{int(ids[counts > 1][0])} has {int(counts.max())} polygons")


def _shared_vertices(xy, tolerance):
    """Network vertex of every polygon vertex (numbered in order of first appearance) and their positions."""
    from scipy.spatial import cKDTree

    from ._components import components

    if isinstance(tolerance, (bool, np.bool_)) or not np.isscalar(tolerance) or not tolerance >= 0:
        raise InputError(f"tolerance must be a distance >= 0 in px; got {tolerance!r}")
    points, group = np.unique(xy, axis=0, return_inverse=True)
    group = group.ravel()
    merged = np.arange(len(points))
    if tolerance > 0 and len(points) > 1:
        pairs = cKDTree(points).query_pairs(tolerance, output_type="ndarray")
        merged = components(len(points), pairs[:, 0], pairs[:, 1])
    group = merged[group]
    # renumber by first appearance, so vertex ids follow the file
    n = int(merged.max()) + 1 if len(merged) else 0
    first = np.full(n, len(group))
    np.minimum.at(first, group, np.arange(len(group)))
    rank = np.empty(n, np.int64)
    rank[np.argsort(first, kind="stable")] = np.arange(n)
    # a vertex sits at the mean of its distinct points: exactly the shared point when sharing is exact
    owner = rank[merged]
    count = np.bincount(owner, minlength=n)
    position = np.stack([np.bincount(owner, points[:, k], minlength=n) for k in (0, 1)], axis=1)
    return rank[group], position / np.maximum(count, 1)[:, None]


def _check_polygons(cell, vid, owner, lengths, at):
    few = lengths < 3
    if few.any():
        raise InputError(f"polygon of cell {cell[np.flatnonzero(few)[0]]}{at} has {lengths[few][0]} distinct "
                         f"vertices; expected a closed polygon of at least 3")
    pairs = pd.DataFrame({"owner": owner, "vid": vid})
    twice = pairs.duplicated()
    if twice.any():
        raise InputError(f"polygon of cell {cell[owner[twice.to_numpy()][0]]}{at} passes through one vertex twice "
                         f"(it touches or crosses itself); expected a simple polygon")


def _counter_clockwise(vid, starts, lengths, reverse):
    """Polygons reversed where ``reverse`` (counter-clockwise in x, y: positive shoelace area)."""
    if not reverse.any():
        return vid
    index = np.arange(len(vid))
    rows = np.repeat(reverse, lengths)
    begin = np.repeat(starts, lengths)
    end = np.repeat(starts + lengths - 1, lengths)
    index[rows] = (begin + end - index)[rows]
    return vid[index]


def _tables(cell, vid, owner, starts, position):
    """The four network tables of polygons given as network vertex ids (counter-clockwise)."""
    nxt = next_vertex(len(vid), starts)
    u, v = vid, vid[nxt]
    n_vertices = len(position)
    key = np.minimum(u, v) * n_vertices + np.maximum(u, v)
    order = np.argsort(key, kind="stable")
    sorted_key = key[order]
    begin = np.flatnonzero(np.r_[True, sorted_key[1:] != sorted_key[:-1]])
    count = np.diff(np.r_[begin, len(key)])
    first = order[begin]
    second = np.where(count >= 2, order[np.minimum(begin + 1, len(order) - 1)], -1)
    paired = second >= 0
    overlap = (count > 2) | (paired & (u[first] == u[np.where(paired, second, 0)]))
    if overlap.any():
        k = int(np.flatnonzero(overlap)[0])
        users = sorted(int(c) for c in cell[owner[order[begin[k]:begin[k] + count[k]]]])
        warnings.warn(f"{int(overlap.sum())} polygon side(s) are not shared the way a tiling shares them (by "
                      f"more than two polygons, or by two on the same side of it): the polygons overlap, e.g. cells "
                      f"{users} along {_side(position, u[first[k]], v[first[k]])}; each such side is one junction "
                      f"between the first two cells that use it", HexatissueWarning, stacklevel=2)
    by_file = np.argsort(first, kind="stable")  # edges in order of first appearance
    first, second = first[by_file], second[by_file]
    left = cell[owner[first]]
    right = np.where(second >= 0, cell[owner[np.maximum(second, 0)]], 0)
    a, b = u[first], v[first]
    edges = pd.DataFrame({"edge": np.arange(len(first), dtype=np.int64), "vertex_a": a.astype(np.int64),
                          "vertex_b": b.astype(np.int64), "cell_a": np.minimum(left, right).astype(np.int64),
                          "cell_b": np.maximum(left, right).astype(np.int64),
                          "length": np.hypot(*(position[b] - position[a]).T)})
    outside = edges["cell_a"].to_numpy() == 0
    vborder = np.zeros(n_vertices, bool)
    vborder[a[outside]] = vborder[b[outside]] = True
    degree = np.bincount(a, minlength=n_vertices) + np.bincount(b, minlength=n_vertices)
    vertices = pd.DataFrame({"vertex": np.arange(n_vertices, dtype=np.int64), "x": position[:, 0],
                             "y": position[:, 1], "degree": degree.astype(np.int64), "is_border": vborder})
    border_ids = np.union1d(left[outside], right[outside])
    cells = polygon_cells(cell, position[vid], starts)
    cells["is_border"] = np.isin(cell, border_ids)
    cell_vertices = pd.DataFrame({"cell": cell[owner], "rank": (np.arange(len(vid)) - starts[owner]).astype(np.int64),
                                  "vertex": vid.astype(np.int64), "image_x": np.zeros(len(vid), np.int64),
                                  "image_y": np.zeros(len(vid), np.int64)})
    return cells, vertices, edges, cell_vertices


def _side(position, a, b):
    (x0, y0), (x1, y1) = position[a], position[b]
    return f"({x0:g}, {y0:g})-({x1:g}, {y1:g})"


# ---------------------------------------------------------------------------------------------------------
# readers
# ---------------------------------------------------------------------------------------------------------
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
    for name in ("cell", "frame") if "frame" in table.columns else ("cell",):
        column = table[name]
        if not pd.api.types.is_numeric_dtype(column) or column.isna().any() or (column % 1 != 0).any():
            raise InputError(f"vertices table {path.name!r}: column {name!r} must hold integers; got dtype "
                             f"{column.dtype}")
    for name in ("x", "y"):
        if not pd.api.types.is_numeric_dtype(table[name]):
            raise InputError(f"vertices table {path.name!r}: column {name!r} must hold numbers (px); got dtype "
                             f"{table[name].dtype}")
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


# ---------------------------------------------------------------------------------------------------------
# the Source of polygon files
# ---------------------------------------------------------------------------------------------------------
class _PolygonReader:
    """Frames of polygons for :class:`~hexatissue.Source` (read eagerly: polygon files are small)."""

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


def open_polygons(path):
    """A :class:`~hexatissue.Source` of cell polygons from a vertices table, a ``TA.db`` or ``.mat`` file(s).

    Parameters
    ----------
    path : Path
        A ``.csv``/``.parquet`` vertices table, a Tissue Analyzer ``.db``, a
        hexanematic ``.mat`` file, or a folder of ``.mat`` files (one
        independent image each, natural order).

    Returns
    -------
    Source
        ``kind == "polygons"``; ``source.polygons(t)`` gives frame ``t``.
        A vertices table with a ``frame`` column is a movie whose ids are
        the tracks (``ids_consistent``); a folder of ``.mat`` files is a set
        of independent images (``independent``: nothing is tracked).
    """
    from .source import _make, _natural_key

    path = Path(path)
    suffix = path.suffix.lower()
    base = {"path": str(path), "notes": []}
    if path.is_dir():
        files = sorted((p for p in path.iterdir() if p.suffix.lower() == ".mat" and not p.name.startswith(".")),
                       key=lambda p: _natural_key(p.name))
        frames = [read_polygon_mat(p) for p in files]
        description = {**base, "kind": "polygon_mat_folder", "files": [p.name for p in files],
                       "notes": ["each .mat file is an independent image, not a movie frame: nothing is tracked"]}
        return _make(_PolygonReader(frames, True, description), description)
    if suffix in TABLE_SUFFIXES:
        frames, values = read_vertices_table(path)
        description = {**base, "kind": "vertices_table", "frame_values": values}
        if values != list(range(len(values))):
            description["notes"] = [f"the table's frame values {values[:5]}{'...' if len(values) > 5 else ''} are "
                                    f"frames 0 to {len(values) - 1}"]
        return _make(_PolygonReader(frames, False, description), description, ids_consistent=True)
    if suffix in TA_SUFFIXES:
        polygons, notes = read_tissue_analyzer(path)
        description = {**base, "kind": "tissue_analyzer", "notes": notes}
        return _make(_PolygonReader([polygons], True, description), description)
    description = {**base, "kind": "polygon_mat"}
    return _make(_PolygonReader([read_polygon_mat(path)], True, description), description)
