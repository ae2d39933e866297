"""From a label image, stack or MPF run to a folder of result tables and figures.

This is what ``hexatissue analyze`` does; it strings the stages together:
junction network (:func:`hexatissue.mesh_from_labels`, or
:func:`hexatissue.analyze_movie` for movies with tracks and T1 events), then
the coarse-grained shape parameter Gamma_p and its defects for every p.
"""
from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
import pandas as pd

from .box import Box
from .errors import InputError
from .frame import Frame
from .io import atomic_path, read_labels

__all__ = ["analyze_to_folder", "order_tables", "save_figures"]


def order_tables(cells, p=(6, 2), box=None, radius=None, spacing=None):
    """Coarse-grained field and defects for each symmetry order.

    Returns
    -------
    grid : pandas.DataFrame
        :func:`hexatissue.coarse_grain` columns, with ``Gamma{p}_re``/``_im``
        for every p (same nodes for all p).
    defects : pandas.DataFrame
        :func:`hexatissue.find_defects` rows of every p (column ``p``).
    """
    from .defects import find_defects
    from .order import coarse_grain

    grids, defects = [], []
    for q in p:
        grid = coarse_grain(cells, p=q, radius=radius, spacing=spacing, box=box)
        defects.append(find_defects(grid, p=q, box=box))
        grids.append(grid)
    keys = [c for c in ("frame", "node") if c in grids[0].columns]
    merged = grids[0]
    for grid in grids[1:]:
        merged = merged.merge(grid[keys + [c for c in grid.columns if c.startswith("Gamma")]], on=keys)
    return merged, pd.concat(defects, ignore_index=True)


def _source(path, periodic):
    """Labels array (2-D or 3-D) or MPF run path, and the box."""
    path = Path(path)
    if path.is_dir() or path.suffix == ".zarr":
        return str(path), None
    labels = read_labels(path)
    if labels.ndim not in (2, 3):
        raise InputError(f"{path}: expected a 2-D image or a T x Y x X stack; got shape {labels.shape}")
    return labels, (Box.from_shape(labels.shape) if periodic else None)


def analyze_to_folder(source, out, *, periodic=False, p=(2, 6), order_p=(6, 2), radius=None, spacing=None,
                      formats=("parquet",), figures=False, client=None, n_workers=None, track=None,
                      min_length=0.0, censor=10, **mesh_options) -> dict:
    """Analyse a label image, stack or MPF run and write every table to ``out``.

    Parameters
    ----------
    source : path
        Label image or stack file (see :func:`hexatissue.read_labels`) or an
        MPF run store (``.zarr``).
    out : path
        Output folder: ``cells``, ``vertices``, ``edges``, ``cell_vertices``,
        ``grid``, ``defects`` (and for movies ``events``, ``lineage``,
        ``cell_events``) as Parquet/CSV, ``metadata.json``, and PNG figures in
        ``figures/`` when ``figures``.
    periodic : bool
        The images tile a periodic box (MPF runs carry their own box).
    p : sequence of int
        Shape-function orders of the cells table.
    order_p : sequence of int
        Orders for which Gamma_p and defects are computed (each must be in ``p``).
    radius, spacing : float, optional
        Coarse-graining disk radius and grid spacing, px (default 1.5 R_cell and R_cell).
    client, n_workers, track, min_length, censor
        Movie options of :func:`hexatissue.analyze_movie`.
    **mesh_options
        Passed to :func:`hexatissue.mesh_from_labels`.

    Returns
    -------
    dict
        Summary numbers (frames, cells per frame, events by kind, defects by charge, seconds).
    """
    from .mesh import mesh_from_labels
    from .pipeline import analyze_movie

    missing = set(order_p) - set(p)
    if missing:
        raise InputError(f"order_p {sorted(missing)} must also be shape-function orders p={list(p)}")
    start = time.perf_counter()
    data, box = _source(source, periodic)
    mesh_options = dict(mesh_options, p=tuple(p))
    if isinstance(data, np.ndarray) and data.ndim == 2:
        result = mesh_from_labels(data, box=box, **mesh_options)
        n_frames = 1
    else:
        result = analyze_movie(data, box=box, track=track, client=client, n_workers=n_workers,
                               min_length=min_length, censor=censor, **mesh_options)
        box = result.box
        n_frames = len(result)
    tables = result.tables()
    interior = result.cells[~result.cells["is_border"]]
    if len(interior) and order_p:
        tables["grid"], tables["defects"] = order_tables(result.cells, order_p, box, radius, spacing)
    out = Path(out)
    written = [str(p_) for p_ in _write_all(tables, out, formats)]
    if figures:
        written += [str(p_) for p_ in save_figures(result, tables, data, out / "figures", order_p)]
    summary = _summary(source, result, tables, n_frames, time.perf_counter() - start)
    meta = dict(summary, options={k: (list(v) if isinstance(v, tuple) else v) for k, v in mesh_options.items()},
                periodic=box is not None, order_p=list(order_p), radius=radius, spacing=spacing)
    _write_json(meta, out / "metadata.json")
    summary["written"] = written
    return summary


def _write_all(tables, out, formats):
    from .io import write_tables

    return write_tables(tables, out, formats=formats)


def _summary(source, result, tables, n_frames, seconds):
    from . import __version__

    cells = result.cells
    summary = {
        "input": str(source),
        "hexatissue_version": __version__,
        "frames": int(n_frames),
        "cells_per_frame": len(cells) / n_frames,
        "interior_cells_per_frame": int((~cells["is_border"]).sum()) / n_frames,
        "vertices_per_frame": len(result.vertices) / n_frames,
        "junctions_per_frame": len(result.edges) / n_frames,
        "seconds": round(seconds, 2),
    }
    if "events" in tables:
        summary["events"] = tables["events"]["kind"].value_counts().to_dict()
    if "defects" in tables:
        d = tables["defects"]
        summary["defects"] = {f"p={q}": {"+": int((g["charge"] > 0).sum()), "-": int((g["charge"] < 0).sum())}
                              for q, g in d.groupby("p")}
    return summary


def _write_json(obj, path):
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(obj, indent=2, default=str))


def save_figures(result, tables, labels, folder, order_p=(6,)):
    """PNG figures of the first and last frame: polygons, six-legged stars, Gamma_p field with defects."""
    from . import plot

    folder = Path(folder)
    frames = [None] if isinstance(result, Frame) else sorted({int(result.frames[0]), int(result.frames[-1])})
    written = []
    for t in frames:
        frame = result if t is None else result.frame(t)
        image = _frame_labels(labels, t)
        polygons = frame.polygons()
        tag = "" if t is None else f"_frame{t:04d}"
        path = folder / f"polygons{tag}.png"
        plot.plot_labels(labels=image, polygons=polygons, cells=frame.cells, path=path)
        written.append(path)
        path = folder / f"stars6{tag}.png"
        plot.plot_stars(frame.cells, p=6, polygons=polygons, path=path)
        written.append(path)
        if "grid" in tables:
            for q in order_p:
                grid, defects = _at_frame(tables["grid"], t), _at_frame(tables["defects"], t)
                defects = defects[defects["p"] == q]
                path = folder / f"order{q}{tag}.png"
                plot.plot_order_field(grid, defects, p=q, polygons=polygons, box=frame.box, path=path)
                written.append(path)
    return written


def _frame_labels(labels, t):
    """The label image of frame t (None for a single image's t); reads one frame of an MPF run."""
    if isinstance(labels, np.ndarray):
        return labels if labels.ndim == 2 else labels[t]
    from .pipeline import open_movie

    return np.asarray(open_movie(labels)[0][t])


def _at_frame(table, t):
    return table if t is None or "frame" not in table.columns else table[table["frame"] == t]
