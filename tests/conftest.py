"""Shared fixtures and helpers: the folder of real third-party data (skipped cleanly when absent), PNG writing."""
import os
import subprocess
import sys
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
REAL_DATA = Path(os.environ.get("HEXATISSUE_REAL_DATA", ROOT.parent / "shared" / "data" / "real"))


def pytest_collection_finish(session):
    """Say at the top of the run how many of the collected tests read the real data, and whether they will run."""
    real = [item for item in session.items if "real_data" in getattr(item, "fixturenames", ())]
    reporter = session.config.pluginmanager.get_plugin("terminalreporter")
    if not real or reporter is None:
        return
    if REAL_DATA.is_dir():
        reporter.write_line(f"real data: {REAL_DATA}; {len(real)} of the collected tests read it (a data set "
                            f"missing from it skips its tests)")
    else:
        reporter.write_line(f"real data: {REAL_DATA} is absent, so {len(real)} of the collected tests will be "
                            f"skipped (they read third-party data); set HEXATISSUE_REAL_DATA to the folder that "
                            f"holds it", yellow=True, bold=True)


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


@contextmanager
def lock_held_elsewhere(folder, filename):
    """``folder``'s lock (:func:`hexatissue.io.lock_folder` on ``filename``) held by another process, as a
    running analysis holds it, for the block (within one process the lock is taken again, not refused)."""
    holder = subprocess.Popen([sys.executable, "-c", (
        "import sys; from hexatissue.io import lock_folder; "
        f"lock = lock_folder({str(folder)!r}, {filename!r}, 'folder'); print('held', flush=True); sys.stdin.read()")],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "held"
        yield
    finally:
        holder.communicate("")
