"""npe2 writers: save from napari through :mod:`hexatissue.exchange` (CTC, GEFF, OME-Zarr).

napari hands a writer the selected layers as ``(data, meta, layer_type)``
(``meta``: the layer's state, with its ``metadata``).  The results a layer
shows travel in ``metadata["movie"]`` (set by this plugin's reader and
widget, :func:`hexatissue.napari.layers.with_movie`):

- **GEFF** (any one of the plugin's Shapes layers, e.g. ``polygons``):
  :func:`hexatissue.exchange.geff.write_geff`, a folder with
  ``neighbours.geff`` and ``tracks.geff``;
- **CTC** (a Labels layer + the plugin's ``polygons``): the labels with track
  ids (:func:`hexatissue.exchange.labels.track_masks`) and the lineage,
  :func:`hexatissue.exchange.ctc.write_ctc`;
- **OME-Zarr** (one Labels layer, ``.zarr``): the labels as they are in
  ``labels/cells``, their cell outlines as the image at the root,
  :func:`hexatissue.exchange.omezarr.write_ome_zarr_labels`, calibrated from
  the layer's scale and units (:func:`hexatissue.napari.widget.layer_calibration`).
"""
from __future__ import annotations

import numpy as np

from ..errors import InputError
from .layers import MOVIE_KEY

__all__ = ["write_geff_layer", "write_ctc_layers", "write_ome_zarr_layer"]


def _movie(meta, what):
    movie = (meta.get("metadata") or {}).get(MOVIE_KEY)
    if movie is None:
        raise InputError(f"{what}: layer {meta.get('name')!r} holds no hexatissue results; choose a layer that "
                         f"hexatissue's reader or Analyze widget made (e.g. 'polygons')")
    return movie


def write_geff_layer(path, data, meta) -> list[str]:
    """Write the results a hexatissue Shapes layer shows as GEFF stores in folder ``path``; returns their paths."""
    from ..exchange.geff import write_geff

    return [str(p) for p in write_geff(_movie(meta, "GEFF"), path)]


def write_ctc_layers(path, layer_data) -> list[str]:
    """Write a Labels layer (the labels the results were computed from) with track ids, and the lineage of the
    results a hexatissue Shapes layer shows, as a Cell Tracking Challenge folder ``path``; returns it."""
    from ..exchange.ctc import write_ctc
    from ..exchange.labels import track_masks

    labels = [(d, m) for d, m, kind in layer_data if kind == "labels"]
    shapes = [m for _, m, kind in layer_data if kind == "shapes"]
    if len(labels) != 1 or len(shapes) != 1:
        raise InputError(f"CTC: select one Labels layer and one hexatissue Shapes layer (e.g. 'polygons'); got "
                         f"layer types {[kind for _, _, kind in layer_data]}")
    movie = _movie(shapes[0], "CTC")
    data = labels[0][0]
    masks = track_masks(movie, labels=np.asarray(data[0] if labels[0][1].get("multiscale") else data))
    return [str(write_ctc(masks, movie.lineage, path))]


def write_ome_zarr_layer(path, data, meta) -> list[str]:
    """Write one Labels layer as an OME-Zarr label image ``path`` (``.zarr``), calibrated by the layer's scale and
    units; returns it."""
    from ..exchange.omezarr import write_ome_zarr_labels
    from ..units import Calibration
    from .widget import layer_calibration

    stack = data[0] if meta.get("multiscale") else data
    cal = layer_calibration(meta["scale"], meta["units"]) if "units" in meta else None
    calibration = None if cal is None else Calibration.from_dict(cal)
    return [str(write_ome_zarr_labels(stack, path, calibration=calibration))]
