"""napari layer data of a :class:`~hexatissue.Movie`: pure functions, no napari and no Qt import.

Each function returns a napari *layer data tuple* ``(data, kwargs, layer_type)``
that ``napari.layers.Layer.create(*t)`` (or a reader's return value) turns into
a layer.  Coordinates follow napari's order, ``(row, col)`` = ``(y, x)``, with
a leading frame coordinate when the movie has more than one frame; the
tables' ``x`` is the column and ``y`` the row, in px.  Every layer carries
``scale = (frame_interval, pixel_size, pixel_size)`` for movies (or
``(pixel_size, pixel_size)`` for one image) from the Movie's calibration, so
the viewer's axes (and its scale bar) are in the calibrated units, which
are also the layers' ``units`` (napari's pint names: ``"pixel"`` for px,
frames and simulation iterations) and in ``kwargs["metadata"]["units"]``
(hexatissue's names); the axes are labelled ``("t", "y", "x")`` (``("y", "x")``).
:func:`aligned` puts the layers on another layer's scale, translate, units and
axis labels instead (the analyze widget: results over their input layer).

Periodic boxes (MPF runs): every polygon is drawn once, contiguous (as
:func:`hexatissue.geometry.table_polygons` unwraps it), at the periodic image
nearest its cell's centroid; a cell cut by the box's edge therefore sticks
out of the box on one side instead of being split.  Tracks are unwrapped the
same way (each step to the nearest periodic image), so a cell that crosses
the edge leaves the box instead of jumping to the far side.
"""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from ..errors import HexatissueWarning, InputError
from ..geometry import table_polygons
from ..plot import MINUS_COLOR, PLUS_COLOR, _star_segments, _typical_spacing

__all__ = ["movie_layers", "labels_layer", "polygon_layer", "vertex_layer", "star_layer", "defect_layers",
           "event_layer", "track_layer", "legend_layer", "open_labels", "layer_scale", "aligned", "with_movie", "SIDES_COLORS",
           "EVENT_COLORS"]

#: Polygon colour by number of sides (Okabe-Ito colours, kept apart from the red / blue of the defects);
#: 3 or fewer sides use the ``3`` colour, 9 or more the ``9`` colour.
SIDES_COLORS = {3: "#56b4e9", 4: "#f0e442", 5: "#009e73", 6: "#d9d9d9", 7: "#e69f00", 8: "#cc79a7", 9: "#000000"}
#: T1 event colour by kind.
EVENT_COLORS = {"cycle": "#ffffff", "intercalation": "#ffd700", "unresolved": "#888888"}
VERTEX_COLORS = {3: "#303030", 4: "#ff7f0e"}
MOVIE_KEY = "movie"  # the layer metadata key of the Movie a layer shows (for the writers)  # degree 2 (image corners) as 3, degree >= 4 as 4
# opaque faces: the labels layer's random colours must not mix with the n_sides colours (the junctions are the
# polygons' dark edges; hide the polygons to see the labels)
POLYGON_FACE_ALPHA = 1.0
POLYGON_EDGE_COLOR = "#303030"
DEFECT_SIZE = 0.8  # defect marker diameter, in typical cell spacings
STAR_COLOR = "#ff3cd2"  # bright magenta: visible on every polygon colour and on black
STAR_SCALE = 0.45  # star leg for |gamma_p| = 1, in typical cell spacings (as hexatissue.plot.plot_stars)


def _rgba(hex_colors, alpha=1.0) -> np.ndarray:
    """``(N, 4)`` float RGBA of hex strings ``"#rrggbb"``; for no colours, one (napari refuses empty colour arrays
    even for an empty layer)."""
    hex_colors = list(hex_colors) or ["#808080"]
    rgb = np.array([[int(h[i:i + 2], 16) / 255 for i in (1, 3, 5)] for h in hex_colors], float).reshape(-1, 3)
    return np.hstack([rgb, np.full((len(rgb), 1), float(alpha))])


def _is_movie(movie) -> bool:
    return int(movie.n_frames) > 1


def layer_scale(movie, time=None) -> tuple:
    """``(frame_interval, pixel_size, pixel_size)`` (movies, or ``time=True``) or ``(pixel_size, pixel_size)``."""
    cal = movie.calibration
    time = _is_movie(movie) if time is None else time
    return ((float(cal.frame_interval),) if time else ()) + (float(cal.pixel_size),) * 2


def _napari_units(movie, time=None) -> tuple:
    """The layer's ``units``: hexatissue's unit names are pint's, but px, frames and iterations are napari's
    ``"pixel"`` (no physical unit)."""
    cal = movie.calibration
    time = _is_movie(movie) if time is None else time
    length = "pixel" if cal.length_unit == "px" else cal.length_unit
    t = "pixel" if cal.time_unit in ("frame", "iteration") else cal.time_unit
    return ((t,) if time else ()) + (length, length)


def _axis_labels(movie, time=None) -> tuple:
    time = _is_movie(movie) if time is None else time
    return ("t", "y", "x") if time else ("y", "x")


def _common(movie, time=None, **extra) -> dict:
    """``scale``, ``units``, ``axis_labels`` and ``metadata`` of a layer (``time``: with a frame axis; default:
    movies)."""
    return {"scale": layer_scale(movie, time), "units": _napari_units(movie, time),
            "axis_labels": _axis_labels(movie, time), "metadata": _metadata(movie, time, **extra)}


def aligned(layers, scale, translate=None, units=None, axis_labels=None) -> list:
    """The layer data tuples placed on another layer's grid: its ``scale``, ``translate``, ``units`` and
    ``axis_labels`` (each given for that layer's axes, e.g. ``(t, y, x)``), taken for each layer's last axes.

    A result layer of the analyze widget must lie exactly over its input
    layer whatever that layer's calibration: the tables are in px and
    frames, so the input's scale maps them to the same world coordinates.
    A layer with fewer axes (the 2-D legend over a movie) takes the last
    ones.

    Parameters
    ----------
    layers : list of (data, kwargs, layer_type)
        From :func:`movie_layers`; not modified.
    scale, translate : sequence of float
        World units per data unit and world offset of the reference layer's axes (translate default: 0).
    units, axis_labels : sequence of str, optional
        The reference layer's (default: those of each layer).

    Returns
    -------
    list of (data, kwargs, layer_type)
        New kwargs; data shared.
    """
    scale = tuple(float(s) for s in scale)
    translate = (0.0,) * len(scale) if translate is None else tuple(float(t) for t in translate)
    if len(translate) != len(scale):
        raise InputError(f"translate must have one value per axis of scale {scale}; got {translate}")
    out = []
    for data, kwargs, kind in layers:
        n = len(kwargs["scale"])
        if n > len(scale):
            raise InputError(f"scale {scale} has fewer axes than the {kwargs['name']!r} layer ({n})")
        new = dict(kwargs, scale=scale[-n:], translate=translate[-n:])
        if units is not None:
            new["units"] = tuple(str(u) for u in units)[-n:]
        if axis_labels is not None:
            new["axis_labels"] = tuple(str(a) for a in axis_labels)[-n:]
        out.append((data, new, kind))
    return out


def _metadata(movie, time=None, **extra) -> dict:
    cal = movie.calibration
    time = _is_movie(movie) if time is None else time
    units = ({"t": cal.time_unit} if time else {}) | {"y": cal.length_unit, "x": cal.length_unit}
    return {"units": units, "calibration": cal.to_dict(), "hexatissue_version": movie.version, **extra}


def _coords(movie, frame, x, y) -> np.ndarray:
    """``(N, 3)`` ``(frame, y, x)`` for movies, else ``(N, 2)`` ``(y, x)``."""
    cols = ([np.asarray(frame, float)] if _is_movie(movie) else []) + [np.asarray(y, float), np.asarray(x, float)]
    return np.stack(cols, axis=1) if len(cols[0]) else np.zeros((0, len(cols)))


def _spacing(movie) -> float:
    """Typical cell spacing (px): median nearest-neighbour distance of the centroids in the first frame."""
    cells = movie.cells
    if not len(cells):
        return 1.0
    first = cells[cells["frame"].to_numpy() == cells["frame"].min()]
    return _typical_spacing(first[["x", "y"]].to_numpy(float))


# ---------------------------------------------------------------------------------------------------------
# labels
# ---------------------------------------------------------------------------------------------------------
def open_labels(movie, folder=None):
    """The label images the Movie was computed from, read lazily, or None with a warning.

    Tried in order: the source recorded in the Movie's metadata (its path,
    absolute or relative to the working directory, or a relative path
    taken from the folder holding ``folder``, as when ``hexatissue analyze
    IMAGE --out results`` ran beside ``results``; with the same ``key``,
    ``channel`` and ``level``), then ``labels.tif`` in ``folder``.  A
    candidate whose frame count or shape differs from the Movie's is
    skipped.

    Parameters
    ----------
    movie : Movie
        With ``source``, ``shape`` and ``n_frames``.
    folder : str or Path, optional
        The results folder.

    Returns
    -------
    dask.array.Array or None
        ``(frames, rows, cols)`` integer labels for movies, ``(rows, cols)``
        for one image; None (and a HexatissueWarning saying why) when no
        candidate is found.
    """
    from ..source import open_source

    desc = movie.source or {}
    candidates = []
    if desc.get("path"):
        selection = {k: desc.get(k) for k in ("key", "channel", "level")}
        candidates.append((Path(desc["path"]), selection))
        if folder is not None and not Path(desc["path"]).is_absolute():
            # `hexatissue analyze IMAGE --out results` records IMAGE relative to where it ran: results/..
            candidates.append((Path(folder).resolve().parent / desc["path"], selection))
    if folder is not None:
        candidates.append((Path(folder) / "labels.tif", {}))
    tried = []
    for path, selection in candidates:
        if not path.exists():
            tried.append(f"{path} (absent)")
            continue
        try:
            source = open_source(path, **selection)
        except InputError as exc:
            tried.append(f"{path} ({exc})")
            continue
        if source.n_frames != movie.n_frames or tuple(source.shape) != tuple(movie.shape):
            tried.append(f"{path} ({source.n_frames} frame(s) of {source.shape}, the results have "
                         f"{movie.n_frames} of {tuple(movie.shape)})")
            continue
        return lazy_stack(source)
    warnings.warn(f"no label image shown: none found among {tried or ['(no source recorded)']}",
                  HexatissueWarning, stacklevel=2)
    return None


def lazy_stack(source):
    """A :class:`~hexatissue.Source` as a dask array read frame by frame: ``(T, rows, cols)``, or 2-D for one frame."""
    import dask
    import dask.array as da

    first = source.frame(0)
    frames = [da.from_array(first, chunks=first.shape)] + [
        da.from_delayed(dask.delayed(source.frame)(t), first.shape, first.dtype) for t in range(1, source.n_frames)]
    return da.stack(frames) if source.n_frames > 1 else frames[0]


def labels_layer(movie, labels) -> tuple:
    """Labels layer of ``labels`` (array of the Movie's frames and shape)."""
    expect = ((int(movie.n_frames),) if _is_movie(movie) else ()) + tuple(int(s) for s in movie.shape)
    if tuple(labels.shape) != expect:
        raise InputError(f"labels must have shape {expect} (the results' frames and image shape); "
                         f"got {tuple(labels.shape)}")
    return labels, {"name": "labels", "opacity": 0.35, **_common(movie)}, "labels"


# ---------------------------------------------------------------------------------------------------------
# cells: polygons and stars
# ---------------------------------------------------------------------------------------------------------
def _sides_colors(n_sides, alpha) -> np.ndarray:
    keys = np.clip(np.asarray(n_sides, int), 3, 9)
    return _rgba([SIDES_COLORS[int(k)] for k in keys], alpha)


def _cell_polygons(movie):
    """``(cells rows with a polygon, list of (n, 2) (x, y) arrays)``, in the cells table's order."""
    keys, xy, starts = table_polygons(movie.vertices, movie.cell_vertices, movie.box)
    ends = np.r_[starts[1:], len(xy)]
    keys = keys.assign(_start=starts, _end=ends)
    rows = movie.cells.reset_index(drop=True).merge(keys, on=["frame", "cell"], how="inner", sort=False)
    rows = rows[(rows["_end"] - rows["_start"]).to_numpy() >= 3]
    start, n = rows["_start"].to_numpy(), (rows["_end"] - rows["_start"]).to_numpy()
    offsets = np.cumsum(n) - n  # where each kept polygon starts in the gathered vertices
    flat = xy[np.repeat(start - offsets, n) + np.arange(n.sum())]
    if movie.box is not None and len(rows):  # the periodic image of each polygon nearest its cell's centroid
        d = np.add.reduceat(flat, offsets, axis=0) / n[:, None] - rows[["x", "y"]].to_numpy(float)
        flat = flat - np.repeat(movie.box.lengths * np.round(d / movie.box.lengths), n, axis=0)
    polys = np.split(flat, offsets[1:]) if len(rows) else []
    return rows.drop(columns=["_start", "_end"]).reset_index(drop=True), polys


def polygon_layer(movie) -> tuple:
    """Shapes layer of every cell polygon, faces coloured by ``n_sides`` (opaque), dark grey edges.

    Cells without a polygon (``n_sides`` 0) are left out, so there is one
    shape per cells row with ``n_sides >= 3``; ``features`` are those rows
    (frame, cell, track, n_sides, areas, ...).
    """
    rows, polys = _cell_polygons(movie)
    movie_axis = _is_movie(movie)
    data = [np.column_stack(([np.full(len(poly), f, float)] if movie_axis else []) + [poly[:, 1], poly[:, 0]])
            for f, poly in zip(rows["frame"].to_numpy(), polys)]
    sides = rows["n_sides"].to_numpy()
    kwargs = {"name": "polygons", "shape_type": "polygon",
              "edge_color": POLYGON_EDGE_COLOR, "face_color": _sides_colors(sides, POLYGON_FACE_ALPHA),
              "edge_width": 0.6, "opacity": 1.0, "features": rows, "ndim": 3 if movie_axis else 2,
              **_common(movie, colors="n_sides", sides_colors=SIDES_COLORS)}
    return data, kwargs, "shapes"


def star_layer(movie, p=6, scale=STAR_SCALE) -> tuple:
    """Vectors layer of p-legged stars at the cell centroids: orientation Arg(gamma_p)/p, legs ~ |gamma_p|.

    Each leg is one vector from the centroid; its length is ``scale`` x the
    typical cell spacing x ``|gamma_p|`` (as :func:`hexatissue.plot.plot_stars`).
    Cells whose ``gamma{p}`` is NaN get no star.  ``features``: frame, cell,
    track and ``abs_gamma{p}`` of each leg's cell.
    """
    cells = movie.cells
    re, im = f"gamma{p}_re", f"gamma{p}_im"
    if re not in cells.columns:
        raise InputError(f"p={p!r}: the cells table has no {re!r} column; the results have "
                         f"{sorted(c[5:-3] for c in cells.columns if c.startswith('gamma') and c.endswith('_re'))}")
    gamma = cells[re].to_numpy(float) + 1j * cells[im].to_numpy(float)
    xy = cells[["x", "y"]].to_numpy(float)
    ok = np.isfinite(gamma) & np.isfinite(xy).all(axis=1)
    segments = _star_segments(xy[ok], np.angle(gamma[ok]) / p, np.abs(gamma[ok]) * scale * _spacing(movie), p)
    frame = np.repeat(cells["frame"].to_numpy()[ok], p)
    start = _coords(movie, frame, segments[:, 0, 0], segments[:, 0, 1])
    step = _coords(movie, np.zeros(len(frame)), *(segments[:, 1] - segments[:, 0]).T)
    leg = cells.loc[ok, ["frame", "cell", "track"]].reset_index(drop=True)
    features = leg.loc[np.repeat(np.arange(len(leg)), p)].reset_index(drop=True).assign(
        **{f"abs_gamma{p}": np.repeat(np.abs(gamma[ok]), p)})
    kwargs = {"name": f"gamma{p} stars", "edge_width": 0.7, "edge_color": STAR_COLOR,
              "vector_style": "line", "length": 1.0, "features": features,
              **_common(movie, p=int(p), leg_per_unit_gamma_px=scale * _spacing(movie))}
    return np.stack([start, step], axis=1), kwargs, "vectors"


# ---------------------------------------------------------------------------------------------------------
# vertices, defects, T1 events
# ---------------------------------------------------------------------------------------------------------
def vertex_layer(movie) -> tuple:
    """Points layer of the vertices, four-fold (degree >= 4) ones in orange; ``features`` = the vertices table."""
    v = movie.vertices.reset_index(drop=True)
    degree = np.clip(v["degree"].to_numpy(int), 3, 4)
    kwargs = {"name": "vertices", "size": 1.6, "border_width": 0, "visible": False,
              "face_color": _rgba([VERTEX_COLORS[int(d)] for d in degree]), "features": v,
              **_common(movie)}
    return _coords(movie, v["frame"], v["x"], v["y"]), kwargs, "points"


def defect_layers(movie, shown=6) -> list:
    """One Points layer per order p of the Gamma_p defects: +1/p (and other positive charges) as red discs,
    negative ones as blue triangles; ``features`` = the defects rows.  Only the layer of p = ``shown``
    starts visible (the colours are the same for every p)."""
    d = movie.defects
    if d is None:
        return []
    size = DEFECT_SIZE * _spacing(movie)
    out = []
    for p in sorted(int(v) for v in d["p"].unique()):
        rows = d[d["p"].to_numpy() == p].reset_index(drop=True)
        plus = rows["charge"].to_numpy(float) > 0
        kwargs = {"name": f"Gamma{p} defects", "size": size,
                  "face_color": _rgba(np.where(plus, PLUS_COLOR, MINUS_COLOR)), "border_color": "black",
                  "border_width": 0.1, "symbol": np.where(plus, "disc", "triangle_up"), "features": rows,
                  "visible": p == shown,
                  **_common(movie, p=p, colors={"+": PLUS_COLOR, "-": MINUS_COLOR})}
        out.append((_coords(movie, rows["frame"], rows["x"], rows["y"]), kwargs, "points"))
    return out


def event_layer(movie) -> tuple | None:
    """Points layer of the T1 events at their quartet centre in the first frame after the contact is lost
    (``frame_start``), coloured by kind; ``features`` = the events rows (kind, duration, cells, ...)."""
    e = movie.events
    if e is None:
        return None
    e = e.reset_index(drop=True)
    colors = [EVENT_COLORS.get(str(k), "#888888") for k in e["kind"]]
    kwargs = {"name": "T1 events", "size": 0.5 * _spacing(movie), "symbol": "star",
              "face_color": _rgba(colors), "border_color": "black", "border_width": 0.1, "features": e,
              "ndim": 3 if _is_movie(movie) else 2, **_common(movie, colors=EVENT_COLORS)}
    return _coords(movie, e["frame_start"], e["x"], e["y"]), kwargs, "points"


def deformation_layers(movie) -> list:
    """Vectors layers of the deformation budget's shear rate on the grid regions, per frame interval.

    One bar per grid node and interval, centred on the node along the
    stretching axis: the total shear rate (white) and the T1s' part (cycles,
    intercalations and unresolved together; red), lengths in proportion to
    the rate (the largest total: 0.9 x the cell spacing).  Empty when the
    results have no grid budget.  ``features``: frame, node and the rate's
    xx, xy components (1/frame).
    """
    budget, grid = movie.deformation, movie.grid
    if budget is None or grid is None:
        return []
    rows = budget[budget["region"] == "grid"].reset_index(drop=True)
    if not len(rows):
        return []
    nodes = grid.drop_duplicates(["frame", "node"]).set_index(["frame", "node"])
    xy = nodes.loc[list(zip(rows["frame"], rows["region_id"])), ["x", "y"]].to_numpy(float)
    t1 = [sum(rows[f"{k}_{c}"].to_numpy() for k in ("t1_cycle", "t1_intercalation", "t1_unresolved"))
          for c in ("xx", "xy")]
    total = [rows[f"total_{c}"].to_numpy() for c in ("xx", "xy")]
    largest = max(float(np.nanmax(np.hypot(*total), initial=0.0)), 1e-300)
    out = []
    for name, (xx, xy_), colour in (("shear rate (total)", total, "white"), ("shear rate (T1s)", t1, "#d62728")):
        half = 0.45 * _spacing(movie) * np.hypot(xx, xy_) / largest
        angle = 0.5 * np.arctan2(xy_, xx)  # the stretching axis
        d = np.c_[np.cos(angle), np.sin(angle)] * half[:, None]
        start = _coords(movie, rows["frame"], xy[:, 0] - d[:, 0], xy[:, 1] - d[:, 1])
        step = _coords(movie, np.zeros(len(rows)), 2 * d[:, 0], 2 * d[:, 1])
        features = pd.DataFrame({"frame": rows["frame"], "node": rows["region_id"], "rate_xx": xx, "rate_xy": xy_})
        kwargs = {"name": name, "edge_width": 1.5, "edge_color": colour, "vector_style": "line", "length": 1.0,
                  "features": features, "visible": name.endswith("(total)"),
                  **_common(movie, bar_per_unit_rate_px=0.9 * _spacing(movie) / largest)}
        out.append((np.stack([start, step], axis=1), kwargs, "vectors"))
    return out


# ---------------------------------------------------------------------------------------------------------
# tracks
# ---------------------------------------------------------------------------------------------------------
def track_layer(movie) -> tuple | None:
    """Tracks layer ``[track, t, y, x]`` of the cell centroids, with the lineage graph ``{daughter: [parent]}``.

    None for a single image.  In a periodic box each track is unwrapped
    (contiguous; see the module docstring).  ``features``: n_sides, area
    and cell id of each point.
    """
    if not _is_movie(movie) or not len(movie.cells):
        return None
    cells = movie.cells.sort_values(["track", "frame"], kind="stable").reset_index(drop=True)
    xy = cells[["x", "y"]].to_numpy(float, copy=True)  # unwrapped in place below
    track = cells["track"].to_numpy()
    if movie.box is not None:
        starts = np.flatnonzero(np.r_[True, track[1:] != track[:-1]])
        for s, e in zip(starts, np.r_[starts[1:], len(track)]):
            xy[s:e] = movie.box.unwrap_polygon(xy[s:e])
    data = np.column_stack([track, cells["frame"].to_numpy(), xy[:, 1], xy[:, 0]]).astype(float)
    graph = {}
    if movie.lineage is not None and len(movie.lineage):
        lin = movie.lineage
        present = set(np.unique(track).tolist())
        for child, parent in zip(lin["track"].to_numpy(), lin["parent"].to_numpy()):
            if parent != 0 and child in present and parent in present:
                graph[int(child)] = [int(parent)]
    kwargs = {"name": "tracks", "graph": graph, "tail_length": 5, "visible": False,
              "features": cells[["cell", "n_sides", "area"]], **_common(movie, time=True)}
    return data, kwargs, "tracks"


# ---------------------------------------------------------------------------------------------------------
# tissue flow
# ---------------------------------------------------------------------------------------------------------
#: Arrow length of the 95th-percentile node speed of the flow layer, in grid spacings (as hexatissue.plot.plot_flow).
FLOW_ARROW = 0.9
FLOW_COLOR = "#00c8ff"


def flow_layer(movie) -> tuple | None:
    """Vectors layer of the tissue flow: an arrow of the fitted velocity at every valid node of ``flow``.

    None when the results have no ``flow`` table or no valid node.  Arrows
    are drawn to one scale over the movie: the 95th-percentile speed spans
    :data:`FLOW_ARROW` grid spacings (``metadata["px_per_velocity"]``: px of
    arrow per px/frame).  ``features``: frame, node, ``speed`` (px/frame),
    ``vorticity`` and ``divergence`` (1/frame) of each node.
    """
    flow = movie.tables.get("flow")
    if flow is None:
        return None
    rows = flow[flow["valid"].to_numpy(bool)].reset_index(drop=True)
    if not len(rows):
        return None
    u, v = rows["vx"].to_numpy(float), rows["vy"].to_numpy(float)
    speed = np.hypot(u, v)
    typical = float(np.percentile(speed, 95)) or 1.0
    first = rows[rows["frame"] == rows["frame"].iloc[0]]
    per_velocity = FLOW_ARROW * _typical_spacing(first[["x", "y"]].to_numpy(float)) / typical
    start = _coords(movie, rows["frame"], rows["x"], rows["y"])
    step = _coords(movie, np.zeros(len(rows)), u * per_velocity, v * per_velocity)
    features = rows[["frame", "node", "vorticity", "divergence"]].assign(speed=speed)
    kwargs = {"name": "flow", "edge_width": 1.2, "edge_color": FLOW_COLOR, "vector_style": "arrow",
              "length": 1.0, "features": features, **_common(movie, px_per_velocity=per_velocity)}
    return np.stack([start, step], axis=1), kwargs, "vectors"


# ---------------------------------------------------------------------------------------------------------
# force inference
# ---------------------------------------------------------------------------------------------------------
def tension_layer(movie) -> tuple | None:
    """Vectors layer of the junctions with an inferred tension (``--mechanics``), coloured by it.

    Each junction is a line from ``vertex_a`` to ``vertex_b`` (minimum image
    in a periodic box); colour: the ``tension`` feature on viridis, between
    its 2nd and 98th percentiles.  ``features``: frame, edge, tension,
    tension_sd.  None when the results have no tensions.
    """
    edges = movie.tables.get("edges")
    if edges is None or "tension" not in edges.columns:
        return None
    edges = edges[np.isfinite(edges["tension"].to_numpy(float))].reset_index(drop=True)
    v = movie.vertices.set_index(["frame", "vertex"])[["x", "y"]]
    a = v.reindex(list(zip(edges["frame"], edges["vertex_a"]))).to_numpy(float)
    b = v.reindex(list(zip(edges["frame"], edges["vertex_b"]))).to_numpy(float)
    d = b - a if movie.box is None else movie.box.min_image(b - a)
    start = _coords(movie, edges["frame"], a[:, 0], a[:, 1])
    step = _coords(movie, np.zeros(len(edges)), d[:, 0], d[:, 1])
    tension = edges["tension"].to_numpy(float)
    low, high = np.percentile(tension, [2, 98]) if len(tension) else (0.0, 1.0)
    features = edges[["frame", "edge", "tension"] + (["tension_sd"] if "tension_sd" in edges else [])]
    kwargs = {"name": "tension", "edge_width": 1.5, "edge_color": "tension", "edge_colormap": "viridis",
              "edge_contrast_limits": (float(low), float(high) if high > low else float(low) + 1.0),
              "vector_style": "line", "length": 1.0, "features": features, "visible": False, **_common(movie)}
    return np.stack([start, step], axis=1), kwargs, "vectors"


def with_movie(layers, movie) -> list:
    """The layer tuples with ``metadata["movie"]`` = the Movie, so that this plugin's writers
    (:mod:`hexatissue.napari.writers`) can export the results a layer shows."""
    return [(data, dict(kwargs, metadata={**kwargs.get("metadata", {}), MOVIE_KEY: movie}), kind)
            for data, kwargs, kind in layers]


# ---------------------------------------------------------------------------------------------------------
# legend
# ---------------------------------------------------------------------------------------------------------
def legend_entries(p=6, events=True) -> pd.DataFrame:
    """The legend's rows: ``label``, ``symbol`` and ``color`` (hex) of the polygon side classes, the
    Gamma_p defects, the gamma_p stars and (``events``) the T1 kinds, as the layers draw them."""
    rows = [(("≤3" if k == 3 else "≥9" if k == 9 else str(k)) + " sides", "square", c)
            for k, c in SIDES_COLORS.items()]
    rows += [(f"Γ{p} defect, charge > 0", "disc", PLUS_COLOR), (f"Γ{p} defect, charge < 0", "triangle_up", MINUS_COLOR),
             (f"γ{p} star", "cross", STAR_COLOR)]
    if events:
        rows += [(f"T1 {kind}", "star", c) for kind, c in EVENT_COLORS.items()]
    return pd.DataFrame(rows, columns=["label", "symbol", "color"])


def legend_layer(movie, p=6) -> tuple:
    """Points layer of the legend: one symbol per entry of :func:`legend_entries` with its label, in a column
    to the right of the image (2-D, so shown in every frame), a cell spacing apart.

    ``features``: the entries (``label``, ``symbol``, ``color``)."""
    entries = legend_entries(p, events=movie.events is not None)
    step = _spacing(movie)
    rows, cols = (float(s) for s in movie.shape)
    y = step * (0.6 + 1.2 * np.arange(len(entries)))
    data = np.column_stack([y, np.full(len(entries), cols + 1.5 * step)])
    kwargs = {"name": "legend", "size": 0.8 * step, "symbol": entries["symbol"].to_numpy(),
              "face_color": _rgba(entries["color"]), "border_color": "#808080", "border_width": 0.05,
              "features": entries,
              "text": {"string": "{label}", "anchor": "upper_left", "translation": [0.4 * step, 0.7 * step],
                       "color": "white", "size": 10},
              **_common(movie, time=False)}
    return data, kwargs, "points"


# ---------------------------------------------------------------------------------------------------------
# everything
# ---------------------------------------------------------------------------------------------------------
def movie_layers(movie, labels=None, p=6) -> list:
    """Every layer of a Movie, bottom to top: labels (when given), polygons, vertices, gamma_p stars,
    Gamma_p defects (one layer per p), T1 events, tracks, the tissue flow, the deformation budget's
    shear rates and the inferred junction tensions (when the results have them), then the legend;
    vertices, tracks,
    the T1s' shear, the tensions and the defects of other orders than ``p`` start hidden.

    Parameters
    ----------
    movie : Movie
        From :func:`hexatissue.read_results` or :func:`hexatissue.analyze`.
    labels : array, optional
        The label images (``(T, rows, cols)`` or ``(rows, cols)``), e.g.
        :func:`open_labels`; no labels layer when None.
    p : int
        Order of the shape function drawn as stars (6: six-legged stars).

    Returns
    -------
    list of (data, kwargs, layer_type)
        napari layer data tuples.
    """
    layers = [labels_layer(movie, labels)] if labels is not None else []
    layers += [polygon_layer(movie), vertex_layer(movie)]
    if f"gamma{p}_re" in movie.cells.columns:
        layers.append(star_layer(movie, p))
    layers += defect_layers(movie, shown=p)
    layers += [t for t in (event_layer(movie), track_layer(movie), flow_layer(movie)) if t is not None]
    layers += deformation_layers(movie)
    tensions = tension_layer(movie)
    layers += [tensions] if tensions is not None else []
    return layers + [legend_layer(movie, p)]
