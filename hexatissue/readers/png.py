"""PNG files, read with OpenCV (imported only when a PNG is read); the size is read from the header."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import InputError
from ..units import Calibration
from .base import Opened, collapse_rgb, layout_description, plan, read_error, refuse

__all__ = ["PngReader", "open_png"]


class PngReader:
    """One PNG image, read with OpenCV (a declared dependency); colour channels reordered to RGB(A)."""

    def __init__(self, path, channel=None):
        self.path, self.what = Path(path), repr(str(path))
        refuse("a PNG file", channel=channel)
        with open(self.path, "rb") as fh:
            head = fh.read(33)
        if head[:8] != b"\x89PNG\r\n\x1a\n" or head[12:16] != b"IHDR":
            raise InputError(f"could not read label image {self.what}: not a PNG file (bad signature)")
        cols, rows = int.from_bytes(head[16:20], "big"), int.from_bytes(head[20:24], "big")
        self.shape = (rows, cols)
        self.n_frames = 1
        self.calibration = Calibration()
        self.dtype = "uint16" if head[24] == 16 else "uint8"
        self.layout = plan("", (), None, self.what)

    def describe(self) -> dict:
        return layout_description("YX", self.shape, self.dtype, self.layout)

    def read(self, t) -> np.ndarray:
        import cv2

        try:
            arr = cv2.imdecode(np.fromfile(self.path, np.uint8), cv2.IMREAD_UNCHANGED)
            if arr is None:
                raise ValueError("OpenCV could not decode the file")
        except Exception as exc:
            raise read_error(self.what, exc) from exc
        if arr.ndim == 3:  # OpenCV gives BGR(A)
            arr = collapse_rgb(arr[..., [2, 1, 0] + ([3] if arr.shape[-1] == 4 else [])])
        return arr


def open_png(path: Path) -> Opened:
    """A ``.png`` file (one frame, no calibration)."""
    return Opened(PngReader(path), {"kind": "png", "path": str(path)})
