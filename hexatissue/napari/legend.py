"""The legend of the result layers: a dock widget beside the canvas, never a layer.

A legend drawn as a points layer lived in data space: its symbols were
scaled with the tissue (a cell spacing each), it widened the data extent so
the tissue filled half the canvas, its text was cut at the canvas edge and
the scale bar covered its last entry.  Here it is a Qt label in a dock
widget: a coloured symbol per entry of
:func:`hexatissue.napari.layers.legend_entries` (every stage's legend rows,
as its layers draw them) and its text, at the font size of the viewer,
whatever the zoom.

It shows the results of the newest layer that carries a Movie
(``metadata["movie"]``, :func:`hexatissue.napari.layers.with_movie`: the
reader's and the analyze widget's layers) and follows layers as they are
added and removed; ``p`` is that of the results' stars layer.  The reader
and the analyze widget dock it (:func:`show_legend`) in the viewer they add
layers to; it is also in the Plugins menu ("hexatissue: Legend").
"""
from __future__ import annotations

from html import escape

from qtpy.QtCore import Qt
from qtpy.QtWidgets import QLabel, QVBoxLayout, QWidget

from .layers import MOVIE_KEY, legend_entries

__all__ = ["LegendWidget", "legend_html", "show_legend", "SYMBOLS", "DOCK_NAME"]

#: The text symbol of each napari symbol name the layers use.
SYMBOLS = {"square": "■", "disc": "●", "triangle_up": "▲", "cross": "✚", "star": "★"}
#: The legend's dock widget name (one per viewer).
DOCK_NAME = "legend"


def legend_html(entries) -> str:
    """Rich text of the legend ``entries`` (``label``, ``symbol``, ``color`` rows): a coloured symbol and its label
    per line; a symbol drawn white (the T1 cycles) gets a grey outline so it shows on a light theme too."""
    rows = []
    for label, symbol, color in entries[["label", "symbol", "color"]].itertuples(index=False):
        mark = escape(SYMBOLS.get(str(symbol), "●"))
        outline = ";background-color:#606060" if str(color).lower() in ("#ffffff", "white") else ""
        rows.append(f'<span style="color:{escape(str(color))}{outline};font-size:large">{mark}</span>'
                    f"&nbsp;{escape(str(label))}")
    return "<br>".join(rows)


def _shown(viewer):
    """``(movie, p)`` of the newest layer carrying a Movie, or ``(None, None)``."""
    for layer in reversed(list(viewer.layers)):
        movie = layer.metadata.get(MOVIE_KEY)
        if movie is None:
            continue
        ps = [other.metadata.get("p") for other in viewer.layers
              if other.metadata.get(MOVIE_KEY) is movie and other.name.endswith(" stars")]
        return movie, int(ps[0]) if ps and ps[0] is not None else 6
    return None, None


class LegendWidget(QWidget):
    """The legend of the newest hexatissue results in ``napari_viewer`` (a dock widget; see the module docstring)."""

    def __init__(self, napari_viewer):
        super().__init__()
        self.viewer = napari_viewer
        self.label = QLabel()
        self.label.setTextFormat(Qt.TextFormat.RichText)
        self.label.setAlignment(Qt.AlignmentFlag.AlignLeft | Qt.AlignmentFlag.AlignTop)
        layout = QVBoxLayout(self)
        layout.addWidget(self.label)
        layout.addStretch(1)
        napari_viewer.layers.events.inserted.connect(self.refresh)
        napari_viewer.layers.events.removed.connect(self.refresh)
        self.refresh()

    def refresh(self, *_):
        """Show the legend of the newest results (or say there are none)."""
        movie, p = _shown(self.viewer)
        self.entries = legend_entries(movie, p) if movie is not None else None
        self.label.setText(legend_html(self.entries) if self.entries is not None else
                           "no hexatissue results among the layers")


def show_legend(viewer):
    """Dock the legend in ``viewer`` (once: an existing legend dock is refreshed); returns the LegendWidget."""
    widget = viewer.window.dock_widgets.get(DOCK_NAME)  # name -> the docked widget
    if isinstance(widget, LegendWidget):
        widget.refresh()
        return widget
    widget = LegendWidget(viewer)
    viewer.window.add_dock_widget(widget, name=DOCK_NAME, area="right")
    return widget
