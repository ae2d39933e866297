"""Render docs/figures/napari_epicure.png: the EpiCure sample's results in a headless napari viewer.

Run from the repository root, with the napari extra installed, under an X server:

    QT_QPA_PLATFORM=offscreen xvfb-run -a python scripts/napari_figure.py [FRAME]
"""
import sys
import tempfile
import warnings
from pathlib import Path

import napari
from qtpy.QtWidgets import QApplication

from hexatissue import analyze, open_source
from hexatissue.errors import HexatissueWarning
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
        # room for the legend's labels, which reset_view does not count (it fits the layers' points)
        viewer.camera.zoom *= 0.85
        viewer.camera.center = (viewer.camera.center[0], viewer.camera.center[1], viewer.camera.center[2] + 8.0)
        viewer.scale_bar.visible = True
        canvas_image(viewer, out)
        viewer.close()
    print(out)


if __name__ == "__main__":
    main(*[int(a) for a in sys.argv[1:]])
