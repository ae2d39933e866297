"""napari plugin: results folders, label stacks and MPF runs as napari layers (extra ``hexatissue[napari]``).

:mod:`~hexatissue.napari.layers` builds the layer data tuples (every
stage's, from its views module: :mod:`hexatissue.views`) and needs neither
napari nor Qt; :mod:`~hexatissue.napari.reader` is the npe2 reader,
:mod:`~hexatissue.napari.widget` the analyze dock widget and
:mod:`~hexatissue.napari.legend` the legend dock widget (these three import
napari or Qt), :mod:`~hexatissue.napari.writers` the writers (through
:mod:`hexatissue.exchange`), :mod:`~hexatissue.napari.sample` the sample
data and :mod:`~hexatissue.napari.screenshot` the headless canvas image.
The manifest is ``napari.yaml`` in this folder.
"""
from .layers import movie_layers

__all__ = ["movie_layers"]
