"""Membrane maps -> touching cell labels: the classical route (scikit-image), for inputs that are not labels yet.

A membrane map is an image of bright junctions on dark cells: a raw membrane
channel, a pixel classifier's membrane probability, or a binary membrane
mask.  ``hexatissue analyze --kind membrane-map`` segments each frame with
:func:`segment_membranes` before the mesh, and the synthetic benchmark uses
it as its baseline segmenter (:mod:`hexatissue.benchmark.baseline`).  It is
a baseline, not a competitor to learned segmenters such as Cellpose.  Per
frame:

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

With ``periodic=True`` (images of a periodic tissue, such as MPF runs) the
frame is padded by wrapping, segmented, and the pieces of a cell that
crosses the image edge are given one id.

Output labels are *touching* (no 0-valued membranes and no background).
Images are indexed ``[row, col]``.
"""
from __future__ import annotations

import numpy as np

from .._components import components
from ..errors import FrameWarning, InputError, check_positive

__all__ = ["segment_membranes", "segment_membrane_map", "basin_count"]

#: The segmentation of ``--kind membrane-map`` is warned about when its cell count is outside this range of
#: the image's dark basins (:func:`basin_count`).  Measured (basins / truth or curated labels): synthetic
#: membrane maps 0.97-1.06, with half or 80 % of the junctions broken by a 7-px gap still 0.96-1.03 while the
#: segmentation falls to 0.65-0.93 of the truth; segmentation / basins: EpiCure notum raw and two-class
#: frames 0.92-1.02, EpiTools 1.26, and 2.29 on the EpiCure static image (435 cells where Cellpose has 217).
PLAUSIBLE_RATIO = (0.75, 1.5)


def _normalised(image, name):
    arr = np.asarray(image, dtype=float)
    if arr.ndim != 2 or min(arr.shape) < 2 or not np.isfinite(arr).all():
        raise InputError(f"{name} must be a finite 2-D membrane image indexed [row, col]; got shape {arr.shape}")
    lo, hi = np.percentile(arr, [1.0, 99.5])
    if hi <= lo:
        raise InputError(f"{name} is flat (1st and 99.5th percentiles are both {lo:g}); expected a membrane image")
    return (arr - lo) / (hi - lo)


def segment_membranes(image, *, sigma=1.0, h=0.1, min_area=30, periodic=False) -> np.ndarray:
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
    periodic : bool
        The image tiles a periodic box: a cell crossing the image edge gets
        one id (its pieces on opposite edges are joined).

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
    image = _normalised(image, "image")
    if periodic:
        return _periodic(image, sigma=sigma, h=h, min_area=min_area)
    smooth = gaussian(image, sigma=sigma, preserve_range=True)
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


def basin_count(image) -> int:
    """How many cells the membrane image shows: the peaks of the distance to the nearest membrane.

    Membrane pixels are those of the smoothed, normalised image above its
    Otsu threshold.  Each cell's interior holds one peak of the distance to
    them, also when its membrane has a gap (where the watershed merges two
    cells); peaks closer than a typical inner radius (the median of the top
    tenth of distances) are one.
    """
    from scipy import ndimage
    from skimage.feature import peak_local_max
    from skimage.filters import gaussian, threshold_otsu

    smooth = gaussian(_normalised(image, "image"), sigma=1.0, preserve_range=True)
    dark = smooth <= threshold_otsu(smooth)
    if not dark.any() or dark.all():
        return int(dark.any())
    distance = ndimage.distance_transform_edt(dark)
    inside = distance[dark]
    radius = float(np.median(inside[inside >= np.percentile(inside, 90)]))
    peaks = peak_local_max(distance, min_distance=max(2, int(radius)), threshold_abs=max(1.5, 0.5 * radius),
                           exclude_border=False)
    return len(peaks)


def segment_membrane_map(image, *, periodic=False) -> np.ndarray:
    """:func:`segment_membranes` with its defaults, warning when the number of cells is implausible.

    For ``--kind membrane-map``.  The count is compared with the image's dark
    basins (:func:`basin_count`); outside :data:`PLAUSIBLE_RATIO` of them a
    :class:`~hexatissue.errors.FrameWarning` says both numbers.
    """
    import warnings

    cells = segment_membranes(image, periodic=periodic)
    n_cells = int(np.count_nonzero(np.bincount(cells.ravel())[1:]))
    basins = basin_count(image)
    low, high = PLAUSIBLE_RATIO
    if basins and not low <= n_cells / basins <= high:
        how = "fewer" if n_cells < low * basins else "more"
        warnings.warn(FrameWarning(
            f"the membrane-map segmentation has {how} cells than the image's dark basins (the peaks of the distance "
            f"to the membranes, one per cell even where a membrane has a gap): it looks "
            f"{'under' if how == 'fewer' else 'over'}-segmented; check the labels (hexatissue export --to ome-zarr) "
            f"or segment with a learned tool (Cellpose, EpySeg) and analyse its labels",
            f"{n_cells} cells, {basins} basins"), stacklevel=3)
    return cells


def _periodic(image, **parameters):
    """Segment a periodic image: wrap-pad it by a quarter of its size, segment, and join the pieces of each cell.

    A pixel of the image appears again in the padding one period away; the
    central label there and the padded copy's label are the same cell.  Only
    copies within half the padding of the image are used (the watershed near
    the padding's outer edge lacks context and may merge cells).
    """
    rows, cols = image.shape
    pad = max(8, min(rows, cols) // 4)
    lab = segment_membranes(np.pad(image, pad, mode="wrap"), **parameters).astype(np.int64)
    centre = lab[pad:pad + rows, pad:pad + cols]
    strip = pad // 2
    a, b = [], []
    for dy in (-rows, 0, rows):
        for dx in (-cols, 0, cols):
            # centre pixels whose copy (row + dy, col + dx) lies in the padding, at most `strip` px out
            r = np.arange(rows)[(np.arange(rows) + dy >= -strip) & (np.arange(rows) + dy < rows + strip)]
            c = np.arange(cols)[(np.arange(cols) + dx >= -strip) & (np.arange(cols) + dx < cols + strip)]
            if (dy, dx) == (0, 0) or not len(r) or not len(c):
                continue
            a.append(centre[np.ix_(r, c)].ravel())
            b.append(lab[np.ix_(r + dy + pad, c + dx + pad)].ravel())
    a, b = np.concatenate(a), np.concatenate(b)
    n = int(lab.max()) + 1
    _, out = np.unique(components(n, a, b)[centre], return_inverse=True)
    return (out.reshape(centre.shape) + 1).astype(np.uint32)
