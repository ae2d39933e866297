"""Render docs/figures/napari_epicure.png: the EpiCure sample's results in a headless napari viewer.

Run from the repository root, with the napari extra installed, under an X server:

    QT_QPA_PLATFORM=offscreen xvfb-run -a python scripts/napari_figure.py [FRAME]
"""
import sys
import tempfile
import warnings
from pathlib import Path

import napari
import numpy as np
from qtpy.QtGui import QImage
from qtpy.QtWidgets import QApplication

from hexatissue import analyze, open_source
from hexatissue.errors import HexatissueWarning
from hexatissue.io import atomic_path
from hexatissue.napari.legend import DOCK_NAME
from hexatissue.napari.screenshot import canvas_image

ROOT = Path(__file__).resolve().parents[1]
SAMPLE = ROOT / "hexatissue" / "sample_data" / "epicure_notum" / "013_crop_labels.tif"


def main(frame=0, out=ROOT / "docs" / "figures" / "napari_epicure.png"):
    with tempfile.TemporaryDirectory() as folder, warnings.catch_warnings():
        warnings.simplefilter("ignore", HexatissueWarning)
        analyze(open_source(SAMPLE, frame_interval=300, time_unit="s"), progress=False).write(folder)
        viewer = napari.Viewer(show=True)  # laid out (on Qt's offscreen platform nothing is displayed)
        viewer.window.resize(1300, 900)
        viewer.open(folder, plugin="hexatissue")
        viewer.dims.set_point(0, frame * 300.0)
        QApplication.processEvents()
        viewer.reset_view()
        viewer.scale_bar.visible = True
        canvas = canvas_image(viewer)
        legend = _widget_image(viewer.window.dock_widgets[DOCK_NAME])  # the dock beside the canvas
        viewer.close()
    rows = max(len(canvas), len(legend))
    picture = np.zeros((rows, canvas.shape[1] + legend.shape[1], 4), np.uint8)
    picture[..., 3] = 255
    picture[:len(canvas), :canvas.shape[1]] = canvas
    picture[:len(legend), canvas.shape[1]:] = legend
    import imageio.v3 as iio

    with atomic_path(out) as tmp:
        iio.imwrite(tmp, picture, extension=".png")
    print(out)


def _widget_image(widget) -> np.ndarray:
    """``(rows, cols, 4)`` uint8 RGBA of a Qt widget as it is drawn."""
    image = widget.grab().toImage().convertToFormat(QImage.Format.Format_RGBA8888)
    data = np.frombuffer(image.constBits().asarray(image.sizeInBytes()), np.uint8)
    return data.reshape(image.height(), image.bytesPerLine() // 4, 4)[:, :image.width()].copy()


if __name__ == "__main__":
    main(*[int(a) for a in sys.argv[1:]])
