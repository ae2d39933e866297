"""A baseline membrane segmenter: membrane image -> touching cell labels (scikit-image).

This is the simplest classical route, so that a rendered benchmark can be
segmented, analysed and scored on any machine: it is a baseline to beat,
not a competitor to learned segmenters such as Cellpose.  Per frame:

1. robust normalisation (the 1st and 99.5th percentiles go to 0 and 1),
   so the one threshold ``h`` means the same at every brightness;
2. Gaussian smoothing of the membrane signal (``sigma`` px);
3. seeds: the h-minima of the smoothed signal (cell interiors are dark
   basins; a basin shallower than ``h`` is noise, not a cell);
4. seeded watershed on the smoothed signal, without watershed lines, so
   the cells touch and the boundaries run along the membrane ridges;
5. cleanup: cells smaller than ``min_area`` px lose their seed and the
   watershed is run again (their pixels go to the neighbours; this also
   removes a small region enclosed by one cell, a hole).

Output labels are *touching* (no 0-valued membranes and no background):
``hexatissue analyze`` reads them with ``kind="touching"`` (auto-detected)
without the membrane-sharing step, so the cell ids of its tables are the
ids of these labels.  Images are indexed ``[row, col]``.
"""
from __future__ import annotations

import numpy as np

from ..errors import InputError, check_positive
from ..progress import progress

__all__ = ["segment_membranes", "segment_movie"]


def _normalised(image, name):
    arr = np.asarray(image, dtype=float)
    if arr.ndim != 2 or min(arr.shape) < 2 or not np.isfinite(arr).all():
        raise InputError(f"{name} must be a finite 2-D membrane image indexed [row, col]; got shape {arr.shape}")
    lo, hi = np.percentile(arr, [1.0, 99.5])
    if hi <= lo:
        raise InputError(f"{name} is flat (1st and 99.5th percentiles are both {lo:g}); expected a membrane image")
    return (arr - lo) / (hi - lo)


def segment_membranes(image, *, sigma=1.0, h=0.1, min_area=30) -> np.ndarray:
    """Segment a 2-D image of bright membranes into touching cell labels (baseline).

    Parameters
    ----------
    image : (rows, cols) array
        Membrane channel (bright junctions on dark cells), any numeric type.
    sigma : float
        Gaussian smoothing, px.  About half the membrane width; more for noisy images.
    h : float
        Depth of a seed basin, as a fraction of the image's robust range
        (1st to 99.5th percentile).  Smaller values split cells, larger ones merge them.
    min_area : int
        Cells smaller than this (px) are removed and their pixels given to
        their neighbours.

    Returns
    -------
    (rows, cols) uint32 array
        Touching labels 1..n (no 0 pixels), numbered in raster order of
        their seeds.

    Raises
    ------
    InputError
        The image is not a finite 2-D array or is flat, or a parameter is not positive.
    """
    from skimage.filters import gaussian
    from skimage.measure import label
    from skimage.morphology import h_minima
    from skimage.segmentation import watershed

    sigma = check_positive(sigma, "sigma", unit="px")
    h = check_positive(h, "h")
    min_area = check_positive(min_area, "min_area", integer=True, unit="px")
    smooth = gaussian(_normalised(image, "image"), sigma=sigma, preserve_range=True)
    markers = label(h_minima(smooth, h), connectivity=2)
    if markers.max() == 0:  # a single basin: the whole image is one cell
        return np.ones(smooth.shape, np.uint32)
    cells = watershed(smooth, markers)
    small = np.flatnonzero(np.bincount(cells.ravel()) < min_area)
    small = small[small > 0]
    if len(small) and len(small) < markers.max():
        markers[np.isin(markers, small)] = 0
        markers = label(markers > 0, connectivity=2)
        cells = watershed(smooth, markers)
    return cells.astype(np.uint32)


def segment_movie(stack, *, sigma=1.0, h=0.1, min_area=30, show_progress=True) -> np.ndarray:
    """:func:`segment_membranes` on every frame of a ``T x rows x cols`` membrane movie.

    Each frame is segmented on its own (ids are not consistent over time:
    ``hexatissue analyze`` tracks the cells by overlap).  A progress bar
    shows the frames done.

    Returns
    -------
    (T, rows, cols) uint32 array
        Touching labels of every frame.
    """
    n = len(stack)
    if np.ndim(stack[0]) != 2:
        raise InputError(f"stack must be a T x rows x cols movie; got frames of shape {np.shape(stack[0])}")
    frames = [segment_membranes(stack[t], sigma=sigma, h=h, min_area=min_area)
              for t in progress(range(n), enabled=show_progress, desc="baseline segmentation", unit="frame")]
    return np.stack(frames)
