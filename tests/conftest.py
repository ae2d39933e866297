"""Shared fixtures and helpers: the folder of real third-party data (skipped cleanly when absent), PNG writing."""
import os
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
REAL_DATA = Path(os.environ.get("HEXATISSUE_REAL_DATA", ROOT.parent / "shared" / "data" / "real"))


@pytest.fixture(scope="session")
def real_data():
    """Path to ``../shared/data/real``; skips the test when the folder is not there."""
    if not REAL_DATA.is_dir():
        pytest.skip(f"real data folder {REAL_DATA} is absent")
    return REAL_DATA


def real_subdir(real_data, name):
    path = real_data / name
    if not path.is_dir():
        pytest.skip(f"real data set {name} is absent")
    return path


def png_write(path, image):
    """Write a 2-D (grey) or RGB image as PNG with OpenCV (the package's PNG reader)."""
    import cv2

    if image.ndim == 3:
        image = image[..., ::-1]  # OpenCV writes BGR
    ok, buf = cv2.imencode(".png", np.ascontiguousarray(image))
    assert ok
    Path(path).write_bytes(buf.tobytes())


def mdck_published_gamma(folder, image, p):
    """Published gamma_p of every cell of MDCK image ``image`` (``dat/exp_N.dat``: x, y, then Re/Im of gamma 2..6).

    Row k is cell k of ``mat/ImageN_Polygon.mat``.
    """
    dat = np.loadtxt(folder / "dat" / f"exp_{image}.dat")
    return dat[:, 2 + 2 * (p - 2)] + 1j * dat[:, 3 + 2 * (p - 2)]
