"""Defect density per unit area and frame, by charge (:func:`defect_density`)."""
from __future__ import annotations

import numpy as np
import pandas as pd

from ..box import Box
from ..errors import InputError, check_positive
from ..schema import require_columns


def defect_density(defects, extent, bin_size, time_column="frame", frames=None):
    """Number and charge density of defects on a square-ish grid of bins, per frame.

    Parameters
    ----------
    defects : pandas.DataFrame
        Defects table (``x``, ``y``, ``charge``; ``time_column`` for movies).
    extent : Box or (rows, cols)
        A periodic box spans ``[0, Lx) x [0, Ly)`` (positions are wrapped
        into it); an open image's shape spans ``[-0.5, cols - 0.5) x [-0.5, rows - 0.5)``
        (pixel centres at integer x = column, y = row).
    bin_size : float
        Requested bin side, px; the extent is cut into ``round(L / bin_size)``
        equal bins per axis (at least one).
    time_column : str
        Column giving the frame; when absent from ``defects`` the table is one frame.
    frames : array_like, optional
        Frames to report (frames without defects get zero density).  Default:
        the frames present in ``defects``.

    Returns
    -------
    pandas.DataFrame
        One row per bin and frame: ``frame`` (when ``time_column`` exists or
        ``frames`` is given), ``row``, ``col`` (bin index along y and x),
        ``x``, ``y`` (bin centre, px), ``n_plus``, ``n_minus`` (defects of
        positive and negative charge), ``density`` (``(n_plus + n_minus) /
        bin area``, 1/px^2), ``charge_density`` (sum of charges / bin area,
        1/px^2).  Defects outside the extent are ignored.
    """
    require_columns(defects, ("x", "y", "charge"), "defects")
    if isinstance(extent, Box):
        lo, size = np.zeros(2), extent.lengths
        wrap = extent.wrap
    else:
        if len(extent) != 2 or min(extent) <= 0:
            raise InputError(f"extent must be a Box or an image shape (rows, cols); got {extent!r}")
        lo, size, wrap = np.array([-0.5, -0.5]), np.array([extent[1], extent[0]], float), (lambda xy: xy)
    check_positive(bin_size, "bin_size", unit="px")
    nbins = np.maximum(1, np.round(size / bin_size)).astype(int)
    step = size / nbins
    has_time = time_column in defects.columns
    times = defects[time_column].to_numpy() if has_time else np.zeros(len(defects), np.int64)
    with_frame = has_time or frames is not None
    frames = np.unique(times if frames is None else np.asarray(frames)) if with_frame else np.zeros(1, np.int64)
    xy = wrap(defects[["x", "y"]].to_numpy(float))
    ij = np.floor((xy - lo) / step).astype(np.int64)
    inside = ((ij >= 0) & (ij < nbins)).all(axis=1) & np.isin(times, frames)
    frame_index = np.searchsorted(frames, times)
    charge = defects["charge"].to_numpy(float)
    shape = (len(frames), nbins[1], nbins[0])
    n_plus, n_minus, q = np.zeros(shape), np.zeros(shape), np.zeros(shape)
    at = (frame_index[inside], ij[inside, 1], ij[inside, 0])
    np.add.at(n_plus, at, charge[inside] > 0)
    np.add.at(n_minus, at, charge[inside] < 0)
    np.add.at(q, at, charge[inside])
    f, r, c = np.meshgrid(frames, np.arange(nbins[1]), np.arange(nbins[0]), indexing="ij")
    area = step[0] * step[1]
    out = pd.DataFrame(
        {
            "row": r.ravel().astype(np.int64),
            "col": c.ravel().astype(np.int64),
            "x": lo[0] + (c.ravel() + 0.5) * step[0],
            "y": lo[1] + (r.ravel() + 0.5) * step[1],
            "n_plus": n_plus.ravel().astype(np.int64),
            "n_minus": n_minus.ravel().astype(np.int64),
            "density": (n_plus + n_minus).ravel() / area,
            "charge_density": q.ravel() / area,
        }
    )
    if with_frame:
        out.insert(0, "frame", f.ravel())
    return out
