"""Acceptance check (issue 30): hexatissue's OME-Zarr export opened by napari-ome-zarr shows the labels.

Analyses the bundled EpiCure sample, exports it with ``hexatissue export --to ome-zarr``, opens the
store with the napari-ome-zarr reader (not a hexatissue dependency: ``pip install napari-ome-zarr``),
prints each layer (type, shape, scale, units, visible as opened), switches every layer on (the reader
opens labels hidden) and renders the canvas to PNG. Exit status 1 when no label colour shows. Run from the repository root, under an X server:

    QT_QPA_PLATFORM=offscreen xvfb-run -a python scripts/napari_ome_zarr_check.py OUT.png
"""
import sys
import tempfile
import warnings
from pathlib import Path

import napari
import numpy as np

from hexatissue import analyze, open_source
from hexatissue.errors import HexatissueWarning
from hexatissue.exchange.command import export
from hexatissue.napari.screenshot import canvas_image
from hexatissue.samples import sample_path

SAMPLE = sample_path("epicure_notum")


def main(png):
    with tempfile.TemporaryDirectory() as tmp, warnings.catch_warnings():
        warnings.simplefilter("ignore", HexatissueWarning)
        tmp = Path(tmp)
        analyze(open_source(SAMPLE, frame_interval=300, time_unit="s"), progress=False).write(tmp / "results")
        store = export(tmp / "results", tmp / "epicure.zarr", "ome-zarr")[0]
        viewer = napari.Viewer(show=False)
        for layer in viewer.open(str(store), plugin="napari-ome-zarr"):
            data = layer.data[0] if layer.multiscale else layer.data
            print(f"{layer.name}: {layer._type_string} {data.shape} {data.dtype} scale {tuple(layer.scale)} "
                  f"units {tuple(str(u) for u in layer.units)} visible {layer.visible}")
        # ome-zarr-py opens an image's labels/ hidden, by design (the user switches them on): do as a user does
        for layer in viewer.layers:
            layer.visible = True
        viewer.reset_view()
        rgb = canvas_image(viewer, png)[..., :3].reshape(-1, 3)
        viewer.close()
    colours = len(np.unique(rgb, axis=0))
    print(f"{png}: {colours} distinct colours, {(rgb.max(axis=1) > 10).mean():.1%} of the canvas not black")
    return 0 if colours > 2 else 1  # more than the outlines' black and white: the labels' colours show


if __name__ == "__main__":
    sys.exit(main(sys.argv[1] if len(sys.argv) > 1 else "napari_ome_zarr.png"))
