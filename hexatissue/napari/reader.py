"""npe2 reader: a results folder, a label image or stack, an MPF run or cell polygons, opened as napari layers.

The manifest claims only what this reader reads better than napari's own:
folders (napari asks which reader when it is not told; a results folder's
``metadata.json`` opens it with no question), ``metadata.json``, files named
``*labels*.tif(f)``, Tissue Analyzer ``.db`` and hexanematic ``.mat`` files.
A raw TIFF is therefore napari's alone and opens with no reader choice.

A results folder (with ``metadata.json``) is read with
:func:`hexatissue.read_results`; anything else that
:func:`hexatissue.open_source` opens as label images or cell polygons is analysed first with
:func:`hexatissue.analyze` (default options, in this process: forking a
process pool from inside a Qt application is not safe) and shown with its
labels.  Big movies are faster analysed with ``hexatissue analyze`` on the
command line and opened as a folder.
"""
from __future__ import annotations

from pathlib import Path

from ..errors import InputError
from .layers import lazy_stack, movie_layers, open_labels, with_movie

__all__ = ["get_reader", "read_folder", "read_labels_source"]

METADATA = "metadata.json"


def get_reader(path):
    """The reader function for ``path`` (one path: str or Path), or None when hexatissue cannot open it.

    Returns None (napari then tries other readers) for lists of paths,
    folders without ``metadata.json`` that are not label images, and files
    whose first frame is not a label image (e.g. raw intensity images).
    A results folder's ``metadata.json`` stands for its folder.
    """
    if isinstance(path, (list, tuple)):
        if len(path) != 1:
            return None
        path = path[0]
    path = Path(path)
    if (path.is_dir() and (path / METADATA).exists()) or (path.name == METADATA and path.is_file()):
        return read_folder
    try:
        _open_labels(path)
    except InputError:
        return None
    return read_labels_source


def _open_labels(path):
    """The :class:`~hexatissue.Source` of ``path`` with its first frame checked (InputError if it holds
    neither label images nor cell polygons)."""
    from ..source import open_source

    source = open_source(path)
    source.polygons(0) if source.kind == "polygons" else source.frame(0)
    return source


def _one(path) -> Path:
    path = Path(path[0] if isinstance(path, (list, tuple)) else path)
    return path.parent if path.name == METADATA and path.is_file() else path


def _dock_legend():
    """The legend (:mod:`hexatissue.napari.legend`) docked in the viewer the layers are read into: napari gives a
    reader no viewer, so the current one (none when the reader is called outside napari)."""
    import napari

    from .legend import show_legend

    viewer = napari.current_viewer()
    if viewer is not None:
        show_legend(viewer)


def read_folder(path) -> list:
    """Layers of a results folder: labels (from the recorded source or ``labels.tif``), polygons, vertices,
    gamma6 stars, Gamma_p defects, T1 events and tracks (see :func:`hexatissue.napari.layers.movie_layers`); the
    legend docked beside the canvas."""
    from ..results import read_results

    folder = _one(path)
    movie = read_results(folder, lazy=False)
    layers = with_movie(movie_layers(movie, labels=open_labels(movie, folder)), movie)
    _dock_legend()
    return layers


def read_labels_source(path) -> list:
    """Layers of a label image / stack / MPF run, or of cell polygons (vertices table, ``TA.db``, hexanematic
    ``.mat``: no labels layer), analysed now with :func:`hexatissue.analyze` (one process)."""
    from ..pipeline import analyze

    source = _open_labels(_one(path))
    movie = analyze(source, workers=1)
    layers = with_movie(movie_layers(movie, labels=lazy_stack(source) if source.kind == "labels" else None), movie)
    _dock_legend()
    return layers

