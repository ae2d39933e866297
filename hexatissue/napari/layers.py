"""napari layer data of a :class:`~hexatissue.Movie`: pure functions, no napari and no Qt import.

Every stage's layers come from its views module (:mod:`hexatissue.views`, named by its entry in
:data:`hexatissue.stages.STAGES`), stacked by rank; this module adds the labels and knows no stage.

Each function returns a napari *layer data tuple* ``(data, kwargs, layer_type)``, in the coordinates,
scale, units and axis labels :mod:`hexatissue.views.layerdata` describes; :func:`aligned` puts the
layers on another layer's scale, translate, units and axis labels instead (the analyze widget: results
over their input layer).

Periodic boxes: polygons and tracks are drawn contiguous, as :mod:`hexatissue.views.layerdata` says.
"""
from __future__ import annotations

import warnings
from pathlib import Path

import pandas as pd

from ..errors import HexatissueWarning, InputError
from ..views import layer_makers, legend_rows
from ..views.layerdata import common, is_movie, layer_scale

__all__ = ["movie_layers", "labels_layer", "legend_entries", "open_labels", "lazy_stack", "layer_scale", "aligned",
           "with_movie", "MOVIE_KEY"]

MOVIE_KEY = "movie"  # the layer metadata key of the Movie a layer shows (for the writers)


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
    expect = ((int(movie.n_frames),) if is_movie(movie) else ()) + tuple(int(s) for s in movie.shape)
    if tuple(labels.shape) != expect:
        raise InputError(f"labels must have shape {expect} (the results' frames and image shape); "
                         f"got {tuple(labels.shape)}")
    return labels, {"name": "labels", "opacity": 0.35, **common(movie)}, "labels"


def with_movie(layers, movie) -> list:
    """The layer tuples with ``metadata["movie"]`` = the Movie, so that this plugin's writers
    (:mod:`hexatissue.napari.writers`) can export the results a layer shows."""
    return [(data, dict(kwargs, metadata={**kwargs.get("metadata", {}), MOVIE_KEY: movie}), kind)
            for data, kwargs, kind in layers]


def legend_entries(movie, p=6) -> pd.DataFrame:
    """The legend's rows: ``label``, ``symbol`` and ``color`` (hex) of every stage's layers as they are drawn (the
    polygon side classes, the Gamma_p defects, the gamma_p stars, the T1 kinds when the results have events)."""
    return pd.DataFrame(legend_rows(movie, p), columns=["label", "symbol", "color"])


def movie_layers(movie, labels=None, p=6) -> list:
    """Every layer of a Movie, bottom to top: labels (when given), then every stage's layers by rank (polygons,
    vertices, gamma_p stars, Gamma_p defects (one layer per p), T1 events, tracks, the tissue flow, the
    deformation budget's shear rates, the inferred junction tensions, when the results have them); the legend is
    a dock widget (:mod:`hexatissue.napari.legend`), not a layer; vertices,
    tracks, the T1s' shear, the tensions and the defects of other orders than ``p`` start hidden.

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
    for maker in layer_makers():
        layers += maker.make(movie, p)
    return layers
