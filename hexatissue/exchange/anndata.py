"""A results folder as an AnnData object (``.h5ad`` or ``.zarr``), for scanpy / squidpy users.

One observation per cell and frame (the ``cells`` table's rows, in its
order): ``obs`` holds every column of the table (ids ``frame``, ``cell``,
``track`` in columns, as in every hexatissue table; the index is
``"frame:cell"``), ``obsm["spatial"]`` the pixel centroids ``(x, y)``, and
``obsp`` the neighbour graph of each frame as sparse matrices named as
squidpy's ``spatial_neighbors`` names them: ``spatial_connectivities`` (1
for two cells that share a junction in the same frame), ``spatial_distances``
(their centroid distance, px, across the periodic box when there is one),
and ``contact_length`` (the total length of their junctions, px).  ``X`` is
the per-cell feature matrix (:func:`cell_features`: area, perimeter,
``n_sides``, the shape functions, the shape tensor, and the junction tension,
pressure and velocity when the run computed them), one variable per
feature with its unit in ``var["unit"]``; values a cell-frame lacks (NaN in
``obs``: the velocity at a track's ends, a border cell without a polygon)
are the feature's mean in ``X`` and flagged in ``layers["missing"]``, so
that scanpy's ``pp.neighbors`` and ``tl.umap`` run on it.  ``uns`` holds the
units and meanings of the ``obs`` columns (from :mod:`hexatissue.schema`),
the calibration that converts px and frames, and where the data came from.
``anndata`` is an optional extra (``pip install 'hexatissue[anndata]'``),
imported only here.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .._version import __version__
from ..errors import InputError
from ..geometry import lookup, polygon_shape_tensor, row_keys, table_polygons
from ..graph import contact_table
from ..schema import column_units

__all__ = ["movie_to_anndata", "write_anndata", "is_anndata_export", "cell_features", "FEATURES"]

SUFFIXES = (".h5ad", ".zarr")


def _need_anndata():
    """The anndata module; InputError with the install command when the optional package is missing."""
    try:
        import anndata
    except ImportError:
        raise InputError("AnnData export needs the anndata package: pip install 'hexatissue[anndata]'") from None
    return anndata


#: The variables of ``X`` (those the run computed, in this order; ``gamma{p}`` once per order p): unit, meaning.
FEATURES = {
    "area": ("px^2", "number of pixels of the cell (cells.area)"),
    "perimeter": ("px", "perimeter of the vertex polygon (cells.perimeter)"),
    "n_sides": ("", "number of polygon vertices (cells.n_sides)"),
    "gamma{p}_re": ("", "real part of the p-fold shape function (cells.gamma{p}_re)"),
    "gamma{p}_im": ("", "imaginary part of the p-fold shape function (cells.gamma{p}_im)"),
    "shape_xx": ("px^2", "shape tensor of the vertex polygon, xx: its second area moment about the centroid over "
                         "its area (a square of side a: a^2/12)"),
    "shape_xy": ("px^2", "shape tensor, xy"),
    "shape_yy": ("px^2", "shape tensor, yy"),
    "tension": ("tension", "inferred tension of the cell's junctions, mean weighted by junction length "
                           "(edges.tension, with --mechanics)"),
    "pressure": ("tension/px", "inferred pressure relative to the frame's mean (cells.pressure, with --mechanics)"),
    "vx": ("px/frame", "velocity along x (cells.vx)"),
    "vy": ("px/frame", "velocity along y, rows (cells.vy)"),
}


def _orders(cells):
    return [int(c[len("gamma"):-len("_re")]) for c in cells.columns
            if c.startswith("gamma") and c.endswith("_re") and c[len("gamma"):-len("_re")].isdigit()]


def _junction_tension(movie, keys):
    """Length-weighted mean tension of each cell's junctions (NaN without a junction of known tension), for the
    cells of sorted ``keys`` (:func:`hexatissue.geometry.row_keys` of frame and cell)."""
    edges = movie.edges
    frame = edges["frame"].to_numpy(np.int64)
    weight = edges["length"].to_numpy(float)
    tension = edges["tension"].to_numpy(float)
    total, norm = np.zeros(len(keys)), np.zeros(len(keys))
    for side in ("cell_a", "cell_b"):
        row = lookup(keys, np.arange(len(keys)), row_keys(frame, edges[side].to_numpy(np.int64)))
        ok = (row >= 0) & np.isfinite(tension)  # the outside (cell 0) has no row
        total += np.bincount(row[ok], weight[ok] * tension[ok], len(keys))
        norm += np.bincount(row[ok], weight[ok], len(keys))
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(norm > 0, total / norm, np.nan)


def cell_features(movie):
    """The per-cell features of a Movie, the ``X`` of :func:`movie_to_anndata`.

    Parameters
    ----------
    movie : Movie
        An analysis (:func:`hexatissue.read_results`).

    Returns
    -------
    features : pandas.DataFrame
        One row per row of ``cells`` (same order), one column per feature of
        :data:`FEATURES` that the run computed: ``area`` (px^2),
        ``perimeter`` (px), ``n_sides``, ``gamma{p}_re``/``_im`` for each
        order p analysed, ``shape_xx``/``_xy``/``_yy`` (px^2, the shape
        tensor of the vertex polygon), ``tension`` (the length-weighted
        mean tension of the cell's junctions) and ``pressure`` with
        ``--mechanics``, ``vx``/``vy`` (px/frame) with the flow stage.
        NaN where a cell-frame has no value (no polygon, a track's end, no
        inferred force).
    left_out : dict
        ``{feature: why}`` for the features of :data:`FEATURES` that are not
        columns (not computed in this run, or NaN for every cell).
    """
    import pandas as pd

    cells = movie.cells.reset_index(drop=True)
    keys = row_keys(cells["frame"].to_numpy(np.int64), cells["cell"].to_numpy(np.int64))
    order = np.argsort(keys, kind="stable")
    sorted_keys = keys[order]
    columns, left_out = {}, {}
    for name in ("area", "perimeter", "n_sides"):
        columns[name] = cells[name].to_numpy(float)
    for p in _orders(cells):
        re, im = cells[f"gamma{p}_re"].to_numpy(float), cells[f"gamma{p}_im"].to_numpy(float)
        lacking = np.isnan(re) | np.isnan(im)  # a cell without a polygon: neither part is a measurement
        columns[f"gamma{p}_re"], columns[f"gamma{p}_im"] = np.where(lacking, np.nan, re), np.where(lacking, np.nan, im)
    shape = np.full((len(cells), 3), np.nan)
    if len(movie.cell_vertices):
        poly_keys, xy, starts = table_polygons(movie.vertices, movie.cell_vertices, movie.box)
        rows = lookup(sorted_keys, order, row_keys(poly_keys["frame"].to_numpy(np.int64),
                                                   poly_keys["cell"].to_numpy(np.int64)))
        tensor = polygon_shape_tensor(xy, starts)
        # a cell of fewer than 3 vertices (n_sides 0) has no polygon: its row stays NaN like its perimeter
        has_polygon = (rows >= 0) & (np.diff(np.r_[starts, len(xy)]) >= 3)
        shape[rows[has_polygon]] = tensor[has_polygon]
    columns.update(shape_xx=shape[:, 0], shape_xy=shape[:, 1], shape_yy=shape[:, 2])
    columns["tension"] = None
    if "tension" in movie.edges.columns:
        columns["tension"] = np.empty(len(cells))
        columns["tension"][order] = _junction_tension(movie, keys[order])
    for name in ("pressure", "vx", "vy"):
        columns[name] = cells[name].to_numpy(float) if name in cells.columns else None
    features = {}
    for name, values in columns.items():
        if values is None:
            left_out[name] = "not computed in this run"
        elif len(values) and np.isnan(values).all():
            left_out[name] = "NaN for every cell-frame"
        else:
            features[name] = values
    return pd.DataFrame(features), left_out


def _feature_meaning(name):
    """``(unit, meaning)`` of a feature column, the ``{p}`` patterns filled in."""
    if name.startswith("gamma"):
        p = name[len("gamma"):-3]
        unit, meaning = FEATURES["gamma{p}" + name[-3:]]
        return unit, meaning.replace("p-fold", f"{p}-fold").replace("{p}", p)
    return FEATURES[name]


def movie_to_anndata(movie):
    """The cells of a Movie as an AnnData object (see the module's description).

    Parameters
    ----------
    movie : Movie
        An analysis (:func:`hexatissue.read_results`).

    Returns
    -------
    anndata.AnnData
        ``n_obs`` = rows of ``cells``; ``n_vars`` = the features of
        :func:`cell_features` that the run computed.  ``X``: those
        features (float64, NaN replaced by the feature's mean over the
        cell-frames that have it); ``var``: ``unit`` and ``description`` of
        each; ``layers["missing"]``: True where ``X`` holds such a mean
        (``obs`` keeps the NaN); ``obs``: every column
        of ``cells`` in its unit (``uns["units"]``: ``x``, ``y`` px,
        ``area`` px^2, ``frame`` frames, ...); ``obsm["spatial"]``:
        ``(n_obs, 2)`` float, columns ``x``, ``y`` (px); ``obsp``:
        ``spatial_connectivities`` (1 or 0), ``spatial_distances`` (px) and
        ``contact_length`` (px), sparse CSR, symmetric, nonzero only
        between two cells of one frame that share a junction;
        ``uns``: ``units`` and ``descriptions`` (by ``obs`` column, and
        ``spatial``), ``features`` (``left_out``: ``{feature: why}``, and
        how missing values were filled), ``calibration`` (pixel size, frame interval and their
        units), ``spatial_neighbors`` (squidpy's keys of the two matrices),
        ``hexatissue`` (version, source, box).
    """
    import pandas as pd
    from scipy import sparse

    anndata = _need_anndata()
    cells = movie.cells.reset_index(drop=True)
    n = len(cells)
    frame = cells["frame"].to_numpy(np.int64)
    cell = cells["cell"].to_numpy(np.int64)
    obs = cells.copy()
    obs.index = pd.Index([f"{t}:{c}" for t, c in zip(frame, cell)], dtype=str)
    xy = cells[["x", "y"]].to_numpy(np.float64)
    contacts = contact_table(movie.edges)
    row_of = pd.Series(np.arange(n), index=pd.MultiIndex.from_arrays([frame, cell]))
    a = row_of.reindex(pd.MultiIndex.from_arrays([contacts["frame"], contacts["cell_a"]])).to_numpy()
    b = row_of.reindex(pd.MultiIndex.from_arrays([contacts["frame"], contacts["cell_b"]])).to_numpy()
    if np.isnan(a).any() or np.isnan(b).any():
        raise InputError("the edges table names cells that are not in the cells table; expected the tables of one "
                         "analysis (hexatissue.read_results)")
    a, b = a.astype(np.int64), b.astype(np.int64)
    d = xy[b] - xy[a]
    if movie.box is not None:  # the shortest way across the periodic box
        d = movie.box.min_image(d)
    distance = np.hypot(d[:, 0], d[:, 1])

    def symmetric(values):
        m = sparse.coo_matrix((np.r_[values, values], (np.r_[a, b], np.r_[b, a])), shape=(n, n))
        return m.tocsr()

    units = column_units("cells", obs.columns)
    cal = movie.calibration
    features, left_out = cell_features(movie)
    values = features.to_numpy(np.float64).reshape(n, features.shape[1])
    missing = np.isnan(values)
    if missing.any():
        values = np.where(missing, np.nanmean(values, axis=0), values)  # no column is NaN throughout
    var = pd.DataFrame({"unit": [_feature_meaning(c)[0] for c in features.columns],
                        "description": [_feature_meaning(c)[1] for c in features.columns]},
                       index=pd.Index([str(c) for c in features.columns], dtype=str))
    adata = anndata.AnnData(X=values, obs=obs, var=var, obsm={"spatial": xy}, layers={"missing": missing})
    adata.obsp["spatial_connectivities"] = symmetric(np.ones(len(a)))
    adata.obsp["spatial_distances"] = symmetric(distance)
    adata.obsp["contact_length"] = symmetric(contacts["length"].to_numpy(float))
    adata.uns["units"] = {**{c: u for c, (u, _) in units.items()}, "spatial": "px", "spatial_distances": "px",
                          "contact_length": "px"}
    adata.uns["descriptions"] = {**{c: m for c, (_, m) in units.items()},
                                 "spatial": "pixel centroid (x = column, y = row)",
                                 "spatial_connectivities": "1 for two cells of one frame that share a junction",
                                 "spatial_distances": "centroid distance of two neighbours",
                                 "contact_length": "total length of the junctions two neighbours share"}
    adata.uns["features"] = {
        "left_out": left_out,
        "missing": "X holds the feature's mean over the cell-frames that have it where a cell-frame has no value "
                   "(obs holds NaN there); layers['missing'] is True at those entries",
        "n_missing": {str(c): int(k) for c, k in zip(features.columns, missing.sum(axis=0))}}
    adata.uns["calibration"] = {k: v for k, v in cal.to_dict().items() if v is not None}
    adata.uns["spatial_neighbors"] = {"connectivities_key": "spatial_connectivities",
                                      "distances_key": "spatial_distances",
                                      "params": {"method": "shared junction (hexatissue junction network)"}}
    adata.uns["hexatissue"] = {"version": movie.version or __version__, "n_frames": int(movie.n_frames),
                               "shape": [int(s) for s in movie.shape],
                               "box": [] if movie.box is None else [float(v) for v in movie.box.to_list()],
                               "source": str((movie.source or {}).get("path") or "")}
    return adata


def is_anndata_export(path) -> bool:
    """Whether ``path`` is an AnnData file or store written by :func:`write_anndata` (it holds ``uns/hexatissue``)."""
    path = Path(path)
    if path.is_dir():
        return (path / "uns" / "hexatissue").is_dir()
    try:
        import h5py

        with h5py.File(path, "r") as f:
            return "uns/hexatissue" in f
    except (ImportError, OSError):
        return False


def write_anndata(movie, path, *, overwrite=False) -> Path:
    """Write :func:`movie_to_anndata` of ``movie`` to ``path`` (``.h5ad`` or ``.zarr``); returns the path.

    An existing ``path`` is replaced (atomically) only if it is an earlier
    output of this function; anything else is refused unless ``overwrite``
    (a results folder always is).
    """
    from ..io import atomic_dir, atomic_path, check_replaceable

    path = Path(path)
    if path.suffix.lower() not in SUFFIXES:
        raise InputError(f"path {str(path)!r} must end in .h5ad or .zarr (the AnnData file to write)")
    check_replaceable(path, is_anndata_export, name="out", overwrite=overwrite)
    if path.suffix.lower() == ".h5ad" and path.is_dir():
        raise InputError(f"out {str(path)!r} is a folder; an .h5ad AnnData file is a single file")
    adata = movie_to_anndata(movie)
    if path.suffix.lower() == ".h5ad":
        with atomic_path(path) as tmp:
            adata.write_h5ad(tmp)
    else:
        with atomic_dir(path, owned=is_anndata_export, overwrite=overwrite, name="out") as tmp:
            adata.write_zarr(tmp)
    return path
