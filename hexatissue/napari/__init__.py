"""napari plugin: results folders, label stacks and MPF runs as napari layers (extra ``hexatissue[napari]``).

:mod:`~hexatissue.napari.layers` builds the layer data tuples and needs
neither napari nor Qt; :mod:`~hexatissue.napari.reader` is the npe2 reader
and :mod:`~hexatissue.napari.widget` the dock widget (these two import
napari), :mod:`~hexatissue.napari.writers` the writers (through
:mod:`hexatissue.exchange`), :mod:`~hexatissue.napari.sample` the sample
data and :mod:`~hexatissue.napari.screenshot` the headless canvas image.
The manifest is ``napari.yaml`` in this folder.
"""
from .layers import movie_layers

__all__ = ["movie_layers"]
