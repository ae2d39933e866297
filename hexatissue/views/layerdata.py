"""What every napari layer of a :class:`~hexatissue.Movie` shares: pure functions, no napari and no Qt import.

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
:func:`hexatissue.napari.layers.aligned` puts the layers on another layer's scale,
translate, units and axis labels instead (the analyze widget: results over their input layer).

Periodic boxes (MPF runs): every polygon is drawn once, contiguous (as
:func:`hexatissue.geometry.table_polygons` unwraps it), at the periodic image
nearest its cell's centroid; a cell cut by the box's edge therefore sticks
out of the box on one side instead of being split.  Tracks are unwrapped the
same way (each step to the nearest periodic image), so a cell that crosses
the edge leaves the box instead of jumping to the far side.
"""
from __future__ import annotations

import numpy as np

from ..plot import typical_spacing

__all__ = ["rgba", "is_movie", "layer_scale", "napari_units", "axis_labels", "common", "metadata", "coords", "spacing"]


def rgba(hex_colors, alpha=1.0) -> np.ndarray:
    """``(N, 4)`` float RGBA of hex strings ``"#rrggbb"``; for no colours, one (napari refuses empty colour arrays
    even for an empty layer)."""
    hex_colors = list(hex_colors) or ["#808080"]
    rgb = np.array([[int(h[i:i + 2], 16) / 255 for i in (1, 3, 5)] for h in hex_colors], float).reshape(-1, 3)
    return np.hstack([rgb, np.full((len(rgb), 1), float(alpha))])


def is_movie(movie) -> bool:
    return int(movie.n_frames) > 1


def layer_scale(movie, time=None) -> tuple:
    """``(frame_interval, pixel_size, pixel_size)`` (movies, or ``time=True``) or ``(pixel_size, pixel_size)``."""
    cal = movie.calibration
    time = is_movie(movie) if time is None else time
    return ((float(cal.frame_interval),) if time else ()) + (float(cal.pixel_size),) * 2


def napari_units(movie, time=None) -> tuple:
    """The layer's ``units``: hexatissue's unit names are pint's, but px, frames and iterations are napari's
    ``"pixel"`` (no physical unit)."""
    cal = movie.calibration
    time = is_movie(movie) if time is None else time
    length = "pixel" if cal.length_unit == "px" else cal.length_unit
    t = "pixel" if cal.time_unit in ("frame", "iteration") else cal.time_unit
    return ((t,) if time else ()) + (length, length)


def axis_labels(movie, time=None) -> tuple:
    time = is_movie(movie) if time is None else time
    return ("t", "y", "x") if time else ("y", "x")


def common(movie, time=None, **extra) -> dict:
    """``scale``, ``units``, ``axis_labels`` and ``metadata`` of a layer (``time``: with a frame axis; default:
    movies)."""
    return {"scale": layer_scale(movie, time), "units": napari_units(movie, time),
            "axis_labels": axis_labels(movie, time), "metadata": metadata(movie, time, **extra)}


def metadata(movie, time=None, **extra) -> dict:
    cal = movie.calibration
    time = is_movie(movie) if time is None else time
    units = ({"t": cal.time_unit} if time else {}) | {"y": cal.length_unit, "x": cal.length_unit}
    return {"units": units, "calibration": cal.to_dict(), "hexatissue_version": movie.version, **extra}


def coords(movie, frame, x, y) -> np.ndarray:
    """``(N, 3)`` ``(frame, y, x)`` for movies, else ``(N, 2)`` ``(y, x)``."""
    cols = ([np.asarray(frame, float)] if is_movie(movie) else []) + [np.asarray(y, float), np.asarray(x, float)]
    return np.stack(cols, axis=1) if len(cols[0]) else np.zeros((0, len(cols)))


def spacing(movie) -> float:
    """Typical cell spacing (px): median nearest-neighbour distance of the centroids in the first frame."""
    cells = movie.cells
    if not len(cells):
        return 1.0
    first = cells[cells["frame"].to_numpy() == cells["frame"].min()]
    return typical_spacing(first[["x", "y"]].to_numpy(float))
