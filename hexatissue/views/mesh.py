"""The junction network's presentation: the tissue's numbers and its cell statistics in the report, the cell
polygons in ``analyze --figures``, the polygons and vertices in napari."""
from __future__ import annotations

import numpy as np

from ..geometry import table_polygons
from ..plot import CONTROL_COLOR, EVENT_COLOR, empty_panel, finish_panels, panels, plot_labels
from ..units import as_calibration
from . import LayerMaker, Section, StageView, WidgetField, columns, shown_frames, single
from .layerdata import common, coords, is_movie, rgba

__all__ = ["VIEW", "plot_cell_distributions", "polygon_layer", "vertex_layer", "SIDES_COLORS", "VERTEX_COLORS",
           "POLYGON_EDGE_COLOR"]

#: Epithelial cell apical areas span about 5-500 µm^2 (Drosophila ~10-50, MDCK ~100-400); a mean outside this
#: wider range says the pixel size is wrong more likely than the cells.
CELL_AREA_UM2 = (1.0, 5000.0)

#: The columns of ``cells`` the report's tissue numbers and cell figure read (over every frame: their means and
#: histograms pool every cell-frame).
CELL_STATISTICS = ("is_border", "n_sides", "area")


def _tissue(movie, report):
    """The tissue: frames, cells, calibration, sides and areas of the interior cells."""
    cells, cal = columns(movie, "cells", CELL_STATISTICS), movie.calibration
    n_frames = max(len(movie), 1)
    inner = cells[~cells["is_border"].to_numpy(bool)]
    numbers = report.numbers
    numbers.update(frames=len(movie), cells_per_frame=len(cells) / n_frames)
    lines = ["## Tissue", "",
             f"- frames: {len(movie)}" + ("" if len(movie) > 1 else " (single image)"),
             f"- cells per frame: {len(cells) / n_frames:.1f} ({len(inner) / n_frames:.1f} interior)",
             f"- periodic box: {movie.box is not None}",
             "- pixel size: " + (f"{cal.pixel_size:g} {cal.length_label}" if cal.has_length else "not calibrated (px)"),
             "- frame interval: " + (f"{cal.frame_interval:g} {cal.time_label}" if cal.has_time
                                     else "not calibrated (frames)"),
             f"- calibration: {cal.origin_text}"]
    if len(inner):
        polygons = inner["n_sides"].to_numpy() >= 3
        left_out = int((~polygons).sum())
        if polygons.any():
            lines.append(f"- mean number of sides (interior cells with a polygon, n_sides >= 3): "
                         f"{inner['n_sides'][polygons].mean():.3f}"
                         + (f"; {left_out} interior fragment(s) with fewer than 3 vertices left out" if left_out
                            else ""))
        numbers["mean_sides"] = float(inner["n_sides"][polygons].mean()) if polygons.any() else float("nan")
        if polygons.any():
            share = {n: float((inner["n_sides"][polygons] == n).mean()) for n in (5, 6, 7)}
            numbers["side_shares"] = share
            lines.append(f"- hexagons {100 * share[6]:.1f} %, pentagons {100 * share[5]:.1f} %, heptagons "
                         f"{100 * share[7]:.1f} % of them")
        numbers["fragments_left_out"] = left_out
        area = inner["area"].mean()
        lines.append(f"- mean cell area (interior): {area:.4g} px^2"
                     + (f" ({cal.area(area):.4g} {cal.length_label}^2)" if cal.has_length else ""))
        if cal.has_length and cal.length_unit == "um" and not CELL_AREA_UM2[0] <= cal.area(area) <= CELL_AREA_UM2[1]:
            lines.append(f"- **check the pixel size**: a mean cell area of {cal.area(area):.4g} µm^2 is outside "
                         f"{CELL_AREA_UM2[0]:g}-{CELL_AREA_UM2[1]:g} µm^2, the range of epithelial cells")
    return lines


def plot_cell_distributions(cells, path=None, calibration=None, figsize=(10, 3.6)):
    """Distributions of the interior cells' number of sides and area, over every frame of ``cells``.

    Parameters
    ----------
    cells : pandas.DataFrame
        A ``cells`` table (``n_sides``, ``area`` in px^2, ``is_border``); border cells are left out (cut by the
        image edge), and so are cells without a polygon (``n_sides`` < 3) from the sides panel.
    path : path-like, optional
        PNG written atomically.
    calibration : Calibration, optional
        Areas in its length unit squared (px^2 when None).

    Returns
    -------
    matplotlib.figure.Figure
        Left: fraction of cells per number of sides, with the percentages; right: histogram of the areas with
        the mean marked.
    """
    cal = as_calibration(calibration)
    inner = cells[~cells["is_border"].to_numpy(bool)]
    fig, (left, right) = panels(2, figsize)
    sides = inner["n_sides"].to_numpy(int)
    sides = sides[sides >= 3]
    if len(sides):
        values, counts = np.unique(sides, return_counts=True)
        share = counts / counts.sum()
        left.bar(values, share, color=EVENT_COLOR, width=0.8)
        for v, f in zip(values, share):
            left.text(v, f, f"{100 * f:.1f}%", ha="center", va="bottom", fontsize=8)
        left.set_xticks(values)
        left.set_ylim(0, min(1.0, share.max() * 1.18))
    else:
        empty_panel(left, "no interior cell with a polygon")
    left.set_xlabel("number of sides (neighbours)")
    left.set_ylabel("fraction of interior cells")
    left.set_title(f"{len(sides)} interior cell-frames", fontsize=10)
    area = cal.area(inner["area"].to_numpy(float))
    unit = f"{cal.length_label}$^2$" if cal.has_length else "px$^2$"
    if len(area):
        right.hist(area, bins=min(40, max(5, len(area) // 10)), color=CONTROL_COLOR)
        right.axvline(area.mean(), color="k", linewidth=1)
        right.text(area.mean(), right.get_ylim()[1] * 0.95, f" mean {area.mean():.3g} {unit}", fontsize=8,
                   va="top")
    else:
        empty_panel(right, "no interior cell")
    right.set_xlabel(f"cell area ({unit})")
    right.set_ylabel("cells")
    return finish_panels(fig, path, "interior cells: neighbour number and area")


def _cell_figure(movie, report):
    """Neighbour numbers and areas of the interior cells."""
    if movie.cells is None or not len(movie.cells):
        return []
    path = report.out / "cells.png"
    plot_cell_distributions(columns(movie, "cells", CELL_STATISTICS), path=path, calibration=movie.calibration)
    return report.figure(path, "neighbour number and area of the interior cells")


def _figures(movie, folder, source=None):
    """The cell polygons (over the labels when ``source`` holds them) of the first and last frame."""
    written = []
    single = len(movie) == 1
    for t in shown_frames(movie):
        frame = movie.frame(t)
        labels = source.frame(t) if source is not None and source.kind == "labels" else None  # polygons: no image
        path = folder / f"{'' if single else f'frame{t:04d}_'}polygons.png"
        plot_labels(labels, frame.polygons(), frame.cells, path=path, box=frame.box,
                    calibration=getattr(frame, "calibration", None))
        written.append(path)
    return written


#: Polygon colour by number of sides (Okabe-Ito colours, kept apart from the red / blue of the defects);
#: 3 or fewer sides use the ``3`` colour, 9 or more the ``9`` colour.
SIDES_COLORS = {3: "#56b4e9", 4: "#f0e442", 5: "#009e73", 6: "#d9d9d9", 7: "#e69f00", 8: "#cc79a7", 9: "#000000"}


#: Vertex colour by degree: degree 2 (image corners) as 3, degree >= 4 as 4.
VERTEX_COLORS = {3: "#303030", 4: "#ff7f0e"}


# opaque faces: the labels layer's random colours must not mix with the n_sides colours (the junctions are the
# polygons' dark edges; hide the polygons to see the labels)
POLYGON_FACE_ALPHA = 1.0


POLYGON_EDGE_COLOR = "#303030"


# ---------------------------------------------------------------------------------------------------------
# cells: polygons and stars
# ---------------------------------------------------------------------------------------------------------
def _sides_colors(n_sides, alpha) -> np.ndarray:
    keys = np.clip(np.asarray(n_sides, int), 3, 9)
    return rgba([SIDES_COLORS[int(k)] for k in keys], alpha)


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
    movie_axis = is_movie(movie)
    data = [np.column_stack(([np.full(len(poly), f, float)] if movie_axis else []) + [poly[:, 1], poly[:, 0]])
            for f, poly in zip(rows["frame"].to_numpy(), polys)]
    sides = rows["n_sides"].to_numpy()
    kwargs = {"name": "polygons", "shape_type": "polygon",
              "edge_color": POLYGON_EDGE_COLOR, "face_color": _sides_colors(sides, POLYGON_FACE_ALPHA),
              "edge_width": 0.6, "opacity": 1.0, "features": rows, "ndim": 3 if movie_axis else 2,
              **common(movie, colors="n_sides", sides_colors=SIDES_COLORS)}
    return data, kwargs, "shapes"


# ---------------------------------------------------------------------------------------------------------
# vertices, defects, T1 events
# ---------------------------------------------------------------------------------------------------------
def vertex_layer(movie) -> tuple:
    """Points layer of the vertices, four-fold (degree >= 4) ones in orange; ``features`` = the vertices table."""
    v = movie.vertices.reset_index(drop=True)
    degree = np.clip(v["degree"].to_numpy(int), 3, 4)
    kwargs = {"name": "vertices", "size": 1.6, "border_width": 0, "visible": False,
              "face_color": rgba([VERTEX_COLORS[int(d)] for d in degree]), "features": v,
              **common(movie)}
    return coords(movie, v["frame"], v["x"], v["y"]), kwargs, "points"


def _legend(movie, p):
    return [(("≤3" if k == 3 else "≥9" if k == 9 else str(k)) + " sides", "square", c)
            for k, c in SIDES_COLORS.items()]


VIEW = StageView(figures=_figures, report=(Section(10, _tissue), Section(12, _cell_figure)),
                 layers=(LayerMaker(10, single(polygon_layer)), LayerMaker(20, single(vertex_layer))),
                 legend=_legend,
                 widget=(WidgetField("merge_distance", name="merge_distance", label="merge distance (px)",
                                     limits={"min": 0.0, "max": 100.0, "step": 0.5}),))
