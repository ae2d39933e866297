"""A height map from a z-stack of a junction-stained epithelium (:func:`height_map`), and the surface projection
it gives (:func:`project_stack`).

The surface stage needs the height of the tissue at every pixel.  Surface
projection tools (LocalZProjector, SurfCut, PreMosa, EpiTools) compute one on
the way to their projected image; when only the z-stack is at hand,
:func:`height_map` finds it the same way: in each pixel's neighbourhood the
plane where the junction signal is brightest, refined below a plane, then
smoothed over the tissue with each pixel weighed by how clearly its
profile peaks (cell interiors and dim regions carry little weight, so the
surface there is interpolated from the junctions around them).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage as ndi

from ..errors import InputError, check_positive

__all__ = ["HeightMap", "height_map", "project_stack", "SIGMA", "SMOOTH"]

#: Default lateral blur of each plane before the peak search, px: spreads the junctions' signal over the cells'
#: interiors so that every pixel's profile peaks at the junction plane around it (docs/surface.md, measured).
SIGMA = 4.0
#: Default width of the smoothing of the per-pixel peaks into the height map, px (a Gaussian's sigma).
SMOOTH = 8.0


@dataclass
class HeightMap:
    """A z-stack's surface.

    Attributes
    ----------
    height : (rows, cols) float64 array
        z of the surface at every pixel, in planes (0 = the stack's first
        plane; fractional: refined below a plane).  ``SurfaceOptions(z_step=)``
        converts it to px.
    peak : (rows, cols) float64 array
        Each pixel's own brightest plane (after the lateral blur, refined),
        before smoothing.
    contrast : (rows, cols) float64 array
        How clearly each pixel's profile peaks: its peak above the profile's
        median, in the stack's intensity unit (0 where it does not).
    """

    height: np.ndarray
    peak: np.ndarray
    contrast: np.ndarray


def _check_stack(stack, name="stack") -> np.ndarray:
    try:
        s = np.asarray(stack)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a z-stack array (planes, rows, cols); got {type(stack).__name__}") from None
    if s.ndim != 3 or min(s.shape) < 1:
        raise InputError(f"{name} must be a z-stack (planes, rows, cols); got shape {s.shape}")
    if s.shape[0] < 3:
        raise InputError(f"{name} has {s.shape[0]} plane(s); a height map needs at least 3 (planes, rows, cols)")
    if not (np.issubdtype(s.dtype, np.integer) or np.issubdtype(s.dtype, np.floating)):
        raise InputError(f"{name} must hold intensities (integers or floats); got dtype {s.dtype}")
    s = s.astype(np.float32, copy=False)
    if not np.isfinite(s).all():
        raise InputError(f"{name} has NaN or infinite intensities")
    return s


def height_map(stack, sigma=SIGMA, smooth=SMOOTH) -> HeightMap:
    """The surface of a junction-stained epithelium in a z-stack: the height of its brightest plane per pixel.

    1. Each plane is blurred laterally (a Gaussian of ``sigma`` px).
    2. Each pixel's brightest plane k, refined by the parabola through
       planes k - 1, k, k + 1 (not at the stack's first or last plane).
    3. Its contrast: the blurred profile's peak above the profile's median.
    4. The height map: at each pixel, the plane fitted to the peaks around
       it by least squares weighted by a Gaussian of ``smooth`` px times the
       contrast to the 4th power, so that pixels whose profile barely peaks
       (cell interiors, dim or empty regions, noise) take the height of the
       junctions around them; a plane, not a mean, so that a sloping surface
       is not flattened at the image's edges.

    Parameters
    ----------
    stack : (planes, rows, cols) array
        Intensities of one time point, plane 0 first; the junctions (or any
        apical signal) bright.
    sigma : float
        Lateral blur before the peak search, px (:data:`SIGMA`).  Of the
        order of a junction's width to a quarter of a cell's diameter.
    smooth : float
        Smoothing of the height map, px (:data:`SMOOTH`): below a cell's
        diameter the surface follows the junctions' own height differences;
        far above it, the tissue's curvature is lost.

    Returns
    -------
    HeightMap
        ``height`` in planes: analyse with ``SurfaceOptions(image=height,
        z_step=<plane spacing in px>)`` (or ``pixel_size`` and ``z_step`` in
        a calibrated unit: docs/surface.md).
    """
    s = _check_stack(stack)
    check_positive(sigma, "sigma", unit="px")
    check_positive(smooth, "smooth", unit="px")
    n = s.shape[0]
    blurred = ndi.gaussian_filter(s, (0.0, float(sigma), float(sigma)), mode="nearest")
    k = blurred.argmax(axis=0)
    rows, cols = np.indices(k.shape)
    inner = np.clip(k, 1, n - 2)
    below, at, above = (blurred[inner + d, rows, cols].astype(float) for d in (-1, 0, 1))
    curvature = below - 2 * at + above
    with np.errstate(invalid="ignore", divide="ignore"):
        shift = np.where(curvature < 0, 0.5 * (below - above) / curvature, 0.0)
    # at the first or last plane the peak may lie beyond the stack: no refinement there
    peak = k + np.where((k == inner) & np.isfinite(shift), np.clip(shift, -0.5, 0.5), 0.0)
    contrast = np.maximum(blurred.max(axis=0) - np.median(blurred, axis=0), 0.0).astype(float)
    del blurred
    if not contrast.any():
        raise InputError("stack has no plane brighter than the others anywhere (every profile is flat); it holds no "
                         "surface to find")
    # a profile's contrast to the 4th power: noise peaks (low contrast) barely count against the junctions' (measured
    # on junction_stack tissues with noise 0.3: median height error 0.27 px against 0.59 px with the contrast itself)
    height = _local_plane(peak, (contrast / contrast.max()) ** 4, float(smooth))
    return HeightMap(height=height, peak=peak.astype(float), contrast=contrast)


def _local_plane(values, weight, smooth):
    """At each pixel, the value there of the plane fitted by weighted least squares to ``values`` around it (weights
    ``weight`` times a Gaussian of ``smooth`` px; none beyond the image).

    A local plane rather than a local mean: a mean is biased wherever the
    surface slopes and the weights are lopsided (the image's edges, a dim
    side), a plane is exact on any tilted surface.  Where the weights do not
    determine a plane (all on one line) the local mean is taken.
    """
    rows, cols = np.indices(values.shape, dtype=float)

    def g(a):
        return ndi.gaussian_filter(a, smooth, mode="constant", cval=0.0)

    s0, sx, sy = g(weight), g(weight * cols), g(weight * rows)
    sxx, sxy, syy = g(weight * cols * cols), g(weight * cols * rows), g(weight * rows * rows)
    wz = weight * values
    sz, sxz, syz = g(wz), g(wz * cols), g(wz * rows)
    # the moments about each pixel: the fitted plane's value there is its constant term
    mx, my = sx - cols * s0, sy - rows * s0
    mxx = sxx - 2 * cols * sx + cols * cols * s0
    mxy = sxy - cols * sy - rows * sx + cols * rows * s0
    myy = syy - 2 * rows * sy + rows * rows * s0
    rz, rx, ry = sz, sxz - cols * sz, syz - rows * sz
    det = s0 * (mxx * myy - mxy * mxy) - mx * (mx * myy - mxy * my) + my * (mx * mxy - mxx * my)
    num = rz * (mxx * myy - mxy * mxy) - mx * (rx * myy - mxy * ry) + my * (rx * mxy - mxx * ry)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = rz / s0
        # a determinant this small against the weights' spread: the plane is not determined
        plane = np.where(np.abs(det) > 1e-9 * s0 * (mxx * myy + 1e-300), num / det, mean)
    bad = ~np.isfinite(plane)
    if bad.any():  # no weight within the smoothing's reach
        plane[bad] = np.average(values, weights=weight)
    return plane


def project_stack(stack, height, depth=1) -> np.ndarray:
    """The surface projection: at each pixel the brightest of the planes within ``depth`` of the height map.

    Parameters
    ----------
    stack : (planes, rows, cols) array
    height : (rows, cols) array
        The surface, in planes (:func:`height_map`'s ``height``).
    depth : int
        Planes kept on either side of the surface's nearest plane (0: that
        plane alone).

    Returns
    -------
    (rows, cols) array of the stack's dtype
    """
    s = np.asarray(stack)
    if s.ndim != 3:
        raise InputError(f"stack must be a z-stack (planes, rows, cols); got shape {s.shape}")
    h = np.asarray(height, dtype=float)
    if h.shape != s.shape[1:]:
        raise InputError(f"height has shape {h.shape}; expected the stack's planes' shape {s.shape[1:]}")
    if not np.isfinite(h).all():
        raise InputError("height has NaN or infinite values")
    if int(depth) != depth or depth < 0:
        raise InputError(f"depth must be a whole number of planes >= 0; got {depth!r}")
    centre = np.clip(np.rint(h).astype(np.int64), 0, s.shape[0] - 1)
    out = None
    for d in range(-int(depth), int(depth) + 1):
        plane = np.take_along_axis(s, np.clip(centre + d, 0, s.shape[0] - 1)[None], axis=0)[0]
        out = plane if out is None else np.maximum(out, plane)
    return out
