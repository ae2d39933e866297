"""GEFF (graph exchange file format, geff.readthedocs.io) stores of a Movie's graphs.

Two stores, written by :func:`write_geff` into one folder:

- ``neighbours.geff``: undirected; a node per cell and frame (the rows of
  ``cells``), an edge per pair of cells sharing junctions in a frame (the
  rows of :func:`hexatissue.graph.contact_table`: ``length`` px,
  ``n_junctions``);
- ``tracks.geff``: directed, forward in time; the same nodes, an edge from
  each cell-frame of a track to its next one (``is_division`` False) and
  from a mother's last cell-frame to each daughter's first
  (``is_division`` True); ``frame_gap`` is the number of frames the edge
  spans (1 unless the track was missing in between).

Node ids are the same in both stores (row order of ``cells`` sorted by
frame and cell), so the two graphs can be joined.  Node properties are the
columns of ``cells`` (``frame``, ``cell``, ``track``, ``x`` = column,
``y`` = row, ``area``, ``n_sides``, ``is_border``, ``gamma{p}_re/_im``, ...)
plus ``gamma{p}_abs`` and ``gamma{p}_angle`` (arg / p, radians, counter-
clockwise in x, y) and, in ``tracks.geff``, ``lineage`` (the first ancestor's
track).  Values stay in px and frames; the axes (``frame``: time, ``y``,
``x``: space) carry units ``frame`` and ``pixel`` with the Movie's pixel size
and frame interval as ``scale`` and the physical unit as ``scaled_unit``.

When the labels were exported as OME-Zarr too (``labels=``,
``hexatissue export --to geff --with-ome-zarr``), both stores list them in
``related_objects``: ``{"type": "labels", "path": <labels/cells of the
OME-Zarr, relative to the store>, "node_prop": "track"}`` (a node's
segment is the pixels of value ``track`` in frame ``frame``) and
``{"type": "image", "path": <the OME-Zarr's image>}``.  Without them
``related_objects`` is null: the stores hold no segmentation to point to.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from .._version import __version__
from ..errors import InputError
from ..graph import contact_table
from ..io import atomic_dir, check_output_folder, check_replaceable, zarr_attributes
from ..schema import TABLES as SCHEMAS
from ..track import lineage_roots
from .omezarr import LABELS_KEY, NGFF_LENGTH, NGFF_TIME, is_ome_zarr_export  # GEFF uses the OME-NGFF unit names

__all__ = ["write_geff", "is_geff_export", "read_geff", "geff_tables", "neighbour_edges", "track_edges", "NEIGHBOURS",
           "TRACKS"]

NEIGHBOURS = "neighbours.geff"
TRACKS = "tracks.geff"
EDGE_PROPS = {
    "length": ("px", "total length of the junctions the two cells share"),
    "n_junctions": ("", "number of junctions the two cells share"),
    "is_division": ("", "True: mother's last cell-frame -> daughter's first; False: the same track continues"),
    "frame_gap": ("frame", "frames from source to target (1 unless the track is missing in between)"),
}


def _need_geff():
    """Import check: InputError with the install command when the optional ``geff`` package is missing."""
    try:
        import geff  # noqa: F401
        import geff_spec  # noqa: F401
    except ImportError:
        raise InputError("GEFF export and import need the geff package: pip install 'hexatissue[geff]'") from None


def _nodes(cells: pd.DataFrame) -> pd.DataFrame:
    """Cells sorted by frame and cell with ``node`` ids 0..n-1 and |gamma_p|, arg(gamma_p)/p for every p."""
    nodes = cells.sort_values(["frame", "cell"], kind="stable").reset_index(drop=True)
    for col in [c for c in nodes.columns if c.startswith("gamma") and c.endswith("_re")]:
        p = int(col[len("gamma"):-len("_re")])
        z = nodes[col].to_numpy(float) + 1j * nodes[f"gamma{p}_im"].to_numpy(float)
        nodes[f"gamma{p}_abs"] = np.abs(z)
        nodes[f"gamma{p}_angle"] = np.angle(z) / p
    nodes.insert(0, "node", np.arange(len(nodes), dtype=np.int64))
    return nodes


def _node_of(nodes, frame, cell, what):
    key = pd.MultiIndex.from_arrays([nodes["frame"].to_numpy(np.int64), nodes["cell"].to_numpy(np.int64)])
    idx = key.get_indexer(pd.MultiIndex.from_arrays([np.asarray(frame, np.int64), np.asarray(cell, np.int64)]))
    if (idx < 0).any():
        raise InputError(f"{what} names cells that are not in the cells table (first: frame "
                         f"{np.asarray(frame)[idx < 0][0]}, cell {np.asarray(cell)[idx < 0][0]}); the results "
                         f"folder is inconsistent: analyse again")
    return nodes["node"].to_numpy()[idx]


def neighbour_edges(cells: pd.DataFrame, edges: pd.DataFrame) -> pd.DataFrame:
    """Edges of the neighbour graph: ``source``, ``target`` (node ids of :func:`write_geff`), ``length``, ``n_junctions``.

    One row per pair of cells sharing junctions in a frame (the outside,
    cell 0, left out); ``source`` is the cell with the smaller id.
    """
    return _neighbour_edges(_nodes(cells), edges)


def _neighbour_edges(nodes, edges):

    pairs = contact_table(edges)
    return pd.DataFrame({"source": _node_of(nodes, pairs["frame"], pairs["cell_a"], "edges"),
                         "target": _node_of(nodes, pairs["frame"], pairs["cell_b"], "edges"),
                         "length": pairs["length"].to_numpy(float),
                         "n_junctions": pairs["n_junctions"].to_numpy(np.int64)})


def track_edges(cells: pd.DataFrame, lineage: pd.DataFrame | None) -> pd.DataFrame:
    """Edges of the track graph: ``source``, ``target`` (node ids), ``is_division``, ``frame_gap`` (frames)."""
    return _track_edges(_nodes(cells), lineage)


def _track_edges(nodes, lineage):
    by_track = nodes.sort_values(["track", "frame"], kind="stable")
    track, node, frame = (by_track[c].to_numpy(np.int64) for c in ("track", "node", "frame"))
    same = track[1:] == track[:-1]
    out = [pd.DataFrame({"source": node[:-1][same], "target": node[1:][same], "is_division": False,
                         "frame_gap": (frame[1:] - frame[:-1])[same]})]
    if lineage is not None and (lineage["parent"] > 0).any():
        first = by_track.groupby("track").first()
        last = by_track.groupby("track").last()
        links = lineage.loc[lineage["parent"] > 0, ["track", "parent"]]
        links = links[links["track"].isin(first.index) & links["parent"].isin(last.index)]
        out.append(pd.DataFrame({
            "source": last.loc[links["parent"], "node"].to_numpy(np.int64),
            "target": first.loc[links["track"], "node"].to_numpy(np.int64), "is_division": True,
            "frame_gap": (first.loc[links["track"], "frame"].to_numpy(np.int64)
                          - last.loc[links["parent"], "frame"].to_numpy(np.int64))}))
    edges = pd.concat(out, ignore_index=True).astype({"is_division": bool, "frame_gap": np.int64})
    return edges.sort_values(["source", "target"], kind="stable").reset_index(drop=True)


def _lineage_roots(nodes, lineage):

    parents = {} if lineage is None else {int(t): int(p) for t, p in zip(lineage["track"], lineage["parent"]) if p}
    return nodes["track"].map(lineage_roots(parents, nodes["track"].unique().tolist())).to_numpy(np.int64)


def _axes(calibration):
    from geff_spec import Axis

    cal = calibration
    length = dict(scale=cal.pixel_size, scaled_unit=NGFF_LENGTH.get(cal.length_unit)) if cal.has_length else {}
    time = dict(scale=cal.frame_interval, scaled_unit=NGFF_TIME.get(cal.time_unit)) if cal.has_time else {}
    if time and time["scaled_unit"] is None:  # e.g. MPF iterations: a scale without a standard unit
        time = {}
    return [Axis(name="frame", type="time", unit="frame", **time),
            Axis(name="y", type="space", unit="pixel", **length),
            Axis(name="x", type="space", unit="pixel", **length)]


def _props(table, meanings):
    from geff._typing import PropDictNpArray

    props, meta = {}, {}
    for name in table.columns:
        props[name] = PropDictNpArray(values=table[name].to_numpy(), missing=None)  # numbers and bools only
        unit, meaning = meanings.get(name, ("", ""))
        meta[name] = (unit, meaning)
    return props, meta


def _meanings(nodes):
    """``{column: (unit, meaning)}`` from the cells schema, with the ``{p}`` columns and the derived ones."""
    schema = SCHEMAS["cells"]
    out = {}
    for name in nodes.columns:
        key = name
        if name.startswith("gamma") and name.endswith(("_re", "_im")):
            key = "gamma{p}" + name[-3:]
        if key in schema:
            out[name] = schema[key][1:]
        elif name.endswith("_abs"):
            out[name] = ("", f"modulus of the {name[5:-4]}-fold shape function")
        elif name.endswith("_angle"):
            out[name] = ("rad", f"arg(gamma{name[5:-6]}) / {name[5:-6]}: direction of one of its legs, "
                                f"counter-clockwise in x, y")
    out["node"] = ("", "node id (shared by neighbours.geff and tracks.geff)")
    out["lineage"] = ("", "track id of the first ancestor (the weakly connected component)")
    return out


def _write_store(path, nodes, edges, directed, calibration, extra, tracklet, overwrite, labels=None):
    import os

    from geff.core_io import write_arrays
    from geff_spec import GeffMetadata, PropMetadata, RelatedObject


    store = Path(path).resolve()  # the related objects' paths are relative to it
    meanings = _meanings(nodes)
    node_props, node_meta = _props(nodes.drop(columns="node"), meanings)
    edge_props, edge_meta = _props(edges.drop(columns=["source", "target"]), EDGE_PROPS)

    def described(meta, props):
        return {n: PropMetadata(identifier=n, dtype=props[n]["values"].dtype, unit=u or None, description=d or None)
                for n, (u, d) in meta.items()}

    metadata = GeffMetadata(directed=directed, axes=_axes(calibration),
                            node_props_metadata=described(node_meta, node_props),
                            edge_props_metadata=described(edge_meta, edge_props),
                            track_node_props={"tracklet": "track", "lineage": "lineage"} if tracklet else None,
                            related_objects=None if labels is None else [
                                RelatedObject(type="labels", path=os.path.relpath(labels / LABELS_KEY, store),
                                              node_prop="track"),
                                RelatedObject(type="image", path=os.path.relpath(labels, store))],
                            extra={"hexatissue": extra})
    ids = nodes["node"].to_numpy(np.int64)
    pairs = edges[["source", "target"]].to_numpy(np.int64).reshape(-1, 2)
    with atomic_dir(path, owned=is_geff_export, overwrite=overwrite, name="out") as tmp:
        write_arrays(str(tmp), ids, node_props, pairs, edge_props, metadata, zarr_format=2, overwrite=True)
    return Path(path)


def is_geff_export(path) -> bool:
    """Whether ``path`` is a GEFF store written by :func:`write_geff` (its metadata's ``extra`` names hexatissue)."""
    extra = (zarr_attributes(path).get("geff") or {}).get("extra") or {}
    return isinstance(extra, dict) and "hexatissue" in extra


def _check_labels(movie, labels):
    """The OME-Zarr export ``labels`` (absolute), checked to hold the Movie's tracks frame by frame."""
    from ..source import open_source

    labels = Path(labels).resolve()
    if not is_ome_zarr_export(labels):
        raise InputError(f"labels {str(labels)!r} is not an OME-Zarr written by hexatissue (write_ome_zarr_labels, "
                         f"hexatissue export --to ome-zarr); expected the labels exported from these results")
    source = open_source(labels, key=LABELS_KEY)
    if source.n_frames != movie.n_frames or tuple(source.shape) != tuple(movie.shape):
        raise InputError(f"labels {str(labels)!r} hold {source.n_frames} frame(s) of {tuple(source.shape)}; the "
                         f"results have {movie.n_frames} of {tuple(movie.shape)}")
    tracks = movie.cells.groupby("frame")["track"].unique()
    for t in range(movie.n_frames):
        found = np.unique(source.raw_frame(t))
        want = np.sort(tracks.get(t, np.zeros(0, np.int64)))
        if not np.array_equal(found[found > 0], want):
            raise InputError(f"labels {str(labels)!r}, frame {t}: its label values are not the tracks of the "
                             f"results' cells in that frame; expected the OME-Zarr exported from these results")
    return labels


def write_geff(movie, out, *, labels=None, overwrite=False) -> list[Path]:
    """Write the neighbour graph and the track graph of a Movie as two GEFF stores.

    Parameters
    ----------
    movie : Movie
        An analysis (:func:`hexatissue.analyze` or :func:`hexatissue.read_results`).
    out : str or Path
        Output folder; ``out/neighbours.geff`` and ``out/tracks.geff`` are
        (re)written, each atomically.  Nothing else in ``out`` is touched;
        an existing ``neighbours.geff`` or ``tracks.geff`` that is not an
        earlier output of this function is refused (before anything is
        written) unless ``overwrite``.
    labels : str or Path, optional
        The OME-Zarr export of the same results' labels
        (:func:`~hexatissue.exchange.omezarr.write_ome_zarr_labels` through
        ``hexatissue export --to ome-zarr``, whose label values are the
        tracks): both stores point to it in ``related_objects`` (paths
        relative to each store).  It is checked to hold, in every frame,
        exactly the tracks of that frame's cells.  Default: none
        (``related_objects`` null).
    overwrite : bool
        Replace those two paths whatever they hold (never a results folder).

    Returns
    -------
    list of Path
        The two stores.  Their contents are described in the module
        docstring (:mod:`hexatissue.exchange.geff`); positions in px
        (x = column, y = row), times in frames, scales from the Movie's
        calibration.
    """

    _need_geff()
    folder = check_output_folder(out, "out")
    for name in (NEIGHBOURS, TRACKS):
        check_replaceable(folder / name, is_geff_export, name="out", overwrite=overwrite)
    if labels is not None:
        labels = _check_labels(movie, labels)
    nodes = _nodes(movie.cells)
    extra = {"version": movie.version or __version__, "calibration": movie.calibration.to_dict(),
             "box": None if movie.box is None else movie.box.to_list(), "shape": [int(s) for s in movie.shape]}
    neighbours = _write_store(folder / NEIGHBOURS, nodes, _neighbour_edges(nodes, movie.edges), False,
                              movie.calibration, {**extra, "graph": "neighbours"}, tracklet=False,
                              overwrite=overwrite, labels=labels)
    tracked = nodes.assign(lineage=_lineage_roots(nodes, movie.lineage))
    tracks = _write_store(folder / TRACKS, tracked, _track_edges(nodes, movie.lineage), True,
                          movie.calibration, {**extra, "graph": "tracks"}, tracklet=True, overwrite=overwrite,
                          labels=labels)
    return [neighbours, tracks]


def _store(path):
    path = Path(path)
    if not path.exists():
        raise InputError(f"GEFF store {str(path)!r} does not exist; expected a folder written by write_geff "
                         f"(neighbours.geff or tracks.geff) or another GEFF zarr store")
    return str(path)


def read_geff(path):
    """A GEFF store as a networkx graph (node and edge properties as attributes) and its metadata.

    Returns
    -------
    graph : networkx.Graph or networkx.DiGraph
        Node ids as stored; attributes are the stored properties.
    metadata : geff.GeffMetadata
        Axes with units and scales, property metadata, ``extra``.

    Raises
    ------
    InputError
        The path is missing or is not a valid GEFF store.
    """
    _need_geff()
    import geff

    try:
        return geff.read(_store(path), backend="networkx")
    except (ValueError, KeyError, FileNotFoundError) as exc:
        raise InputError(f"GEFF store {str(path)!r} cannot be read: {exc}") from None


def geff_tables(path) -> tuple[pd.DataFrame, pd.DataFrame]:
    """A GEFF store as tables: ``nodes`` (``node`` + every node property) and ``edges`` (``source``, ``target`` + props).

    For the stores of :func:`write_geff`, ``nodes`` without the derived
    columns (``node``, ``gamma{p}_abs``, ``gamma{p}_angle``, ``lineage``)
    equals the Movie's ``cells`` sorted by frame and cell.
    """
    _need_geff()
    from geff.core_io import read_to_memory

    try:
        memory = read_to_memory(_store(path))
    except (ValueError, KeyError, FileNotFoundError) as exc:
        raise InputError(f"GEFF store {str(path)!r} cannot be read: {exc}") from None

    def table(first, props):
        out = pd.DataFrame(first)
        for name, prop in props.items():
            values = np.asarray(prop["values"])
            if values.ndim != 1:
                continue
            series = pd.Series(values)
            if prop.get("missing") is not None and prop["missing"].any():
                series = series.mask(prop["missing"])
            out[name] = series
        return out

    ids = np.asarray(memory["edge_ids"]).reshape(-1, 2)
    nodes = table({"node": np.asarray(memory["node_ids"])}, memory["node_props"])
    edges = table({"source": ids[:, 0], "target": ids[:, 1]}, memory["edge_props"])
    return nodes, edges
