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
empty (no variables): the measurements are ``obs`` columns.  ``uns`` holds
the units and meanings of the ``obs`` columns (from
:mod:`hexatissue.schema`), the calibration that converts px and frames, and
where the data came from.  ``anndata`` is an optional extra
(``pip install 'hexatissue[anndata]'``), imported only here.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .._version import __version__
from ..errors import InputError
from ..graph import contact_table
from ..schema import column_units

__all__ = ["movie_to_anndata", "write_anndata", "is_anndata_export"]

SUFFIXES = (".h5ad", ".zarr")


def _need_anndata():
    """The anndata module; InputError with the install command when the optional package is missing."""
    try:
        import anndata
    except ImportError:
        raise InputError("AnnData export needs the anndata package: pip install 'hexatissue[anndata]'") from None
    return anndata


def movie_to_anndata(movie):
    """The cells of a Movie as an AnnData object (see the module's description).

    Parameters
    ----------
    movie : Movie
        An analysis (:func:`hexatissue.read_results`).

    Returns
    -------
    anndata.AnnData
        ``n_obs`` = rows of ``cells``, no variables.  ``obs``: every column
        of ``cells`` in its unit (``uns["units"]``: ``x``, ``y`` px,
        ``area`` px^2, ``frame`` frames, ...); ``obsm["spatial"]``:
        ``(n_obs, 2)`` float, columns ``x``, ``y`` (px); ``obsp``:
        ``spatial_connectivities`` (1 or 0), ``spatial_distances`` (px) and
        ``contact_length`` (px), sparse CSR, symmetric, nonzero only
        between two cells of one frame that share a junction;
        ``uns``: ``units`` and ``descriptions`` (by ``obs`` column, and
        ``spatial``), ``calibration`` (pixel size, frame interval and their
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
    adata = anndata.AnnData(obs=obs, obsm={"spatial": xy})
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
