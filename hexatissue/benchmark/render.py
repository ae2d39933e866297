"""Rendered fluorescence microscopy of a ground-truth movie: membrane (and nuclear) channel, uint16.

OpenCV is the project's tool for rendering synthetic microscopy images: the
junctions are drawn with ``cv2.polylines`` (anti-aliased, ``cv2.LINE_AA``),
the nuclei with ``cv2.circle`` and the Gaussian PSF is ``cv2.GaussianBlur``.  The Airy PSF and stage drift are
applied together in Fourier space (the PSF's transfer function times the
phase ramp of an exact, band-limited shift): ``cv2.warpAffine``'s
interpolation moved fine detail by up to 0.15 px more or less than asked
(measured by phase correlation).  The camera (shot and read noise, ADU) is
one numba kernel, :func:`hexatissue.benchmark._kernels.camera`, whose
random numbers are a counter-based stream (splitmix64 of the frame's seed,
the pixel and the draw), so a frame's noise depends only on the seed and the
frame number.

Geometry comes from the truth tables, not the labels: every junction is the
segment between its two vertices (``edges`` and ``vertices`` tables), in px
with x = column and y = row, origin at the centre of pixel (0, 0).  In a
periodic box a junction crossing the box edge is drawn on both sides
(wrap-around), and the PSF and drift wrap too.

The image model, per frame ``t`` (photon counts = electrons; quantum
efficiency 1):

1. ``clean = background`` where the truth label is 0, ``cytoplasm * f_cell``
   inside cells (``f_cell`` lognormal, mean 1, CV ``cytoplasm_cv``, fixed
   per track);
2. ``+ A * m``: the membrane drawing ``m`` (lines of ``membrane_width`` px,
   value ``f_junction``: lognormal, mean 1, CV ``junction_cv``, fixed per
   pair of cells, optionally bent by ``curvature``); the amplitude ``A`` is
   set once, on frame 0, so that the frame has the requested SNR;
3. blurred by the PSF, shifted by the stage drift ``(dx_t, dy_t)``,
   multiplied by ``exp(-bleach_rate * t)``;
4. ``electrons = Poisson(clean) + Normal(0, read_noise)``, recorded as
   ``ADU = round(gain * electrons + offset)`` clipped to uint16.  The
   Poisson counts are exact (:func:`poisson_counts`: alias tables and
   inversion, transformed rejection for means of 1024 and more), the
   normal deviates too (ziggurat); :mod:`hexatissue.benchmark._kernels`.

**SNR** (frame 0, computed on the noise-free image after the PSF): with J
the junction centreline pixels (the junction segments rasterised 1 px wide)
and C the cytoplasm pixels (inside a cell and farther than
``membrane_width / 2 + 3 psf_sigma + 1`` px from every centreline),

    SNR = (mean_J clean - mean_C clean) / sqrt(mean_C clean + read_noise**2)

i.e. the membrane's contrast over the cytoplasm in units of the noise
standard deviation in the cytoplasm (shot and read noise, in electrons).
Photobleaching lowers it over time by ``exp(-bleach_rate t)`` in the
numerator and its square root in the shot-noise term.

**Drift**: the truth stays in specimen coordinates; the image is shifted.  A
truth point ``(x, y)`` of frame ``t`` is seen at ``(x + dx_t, y + dy_t)`` in
the image (``Renderer.drift``: a Gaussian random walk with per-axis step
``drift`` px, ``dx_0 = dy_0 = 0``).  On an open field of view the pixels
shifted in from outside are the mirror image of the edge (the truth has
nothing there).
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import pandas as pd

# cv2 is imported by the methods that draw: OpenCV loads ~17 MB of libraries, which every CLI call would
# pay (the CLI builds RenderOptions' fields into its parser)

from .._hashing import GOLDEN, mix64
from ..errors import InputError, as_generator
from ..options import _fail, _Options, cli_field
from ..schema import rows_by_frame

__all__ = ["RenderOptions", "Renderer", "render", "poisson_counts", "transfer_function", "PSFS", "SHOT_NOISE", "SNR_DEFINITION"]

#: the SNR, in one line (for benchmark.json)
SNR_DEFINITION = ("frame 0, noise-free image after the PSF, electrons: (mean over junction centreline pixels - mean "
                  "over cytoplasm pixels) / sqrt(mean over cytoplasm pixels + read_noise**2); cytoplasm = inside "
                  "a cell and farther than membrane_width / 2 + 3 psf_sigma + 1 px from every centreline")

PSFS = ("gaussian", "airy")
SHOT_NOISE = ("poisson", "gaussian")
#: drawing sub-pixel precision: cv2 coordinates are integers in units of 1 / 2**_SHIFT px
_SHIFT = 4
#: junction intensities are drawn into uint8 (cv2 anti-aliases 8-bit images only) as multiples of 1/_LEVEL of
#: the mean, in _BUCKET such steps: one cv2.polylines call per bucket present (about 15 per frame at CV 0.25)
_LEVEL, _BUCKET = 64, 4
#: points along a bent junction (a parabola through its two vertices)
_CURVE_POINTS = 7


@dataclass(frozen=True)
class RenderOptions(_Options, title="rendering (docs/benchmark.md)"):
    """How a truth movie is rendered (see :mod:`hexatissue.benchmark.render` for the image model).

    Parameters
    ----------
    snr : float
        Membrane contrast over the cytoplasm in units of the cytoplasm's
        noise standard deviation, on frame 0 (defined in the module docstring).
    membrane_width : int
        Line thickness of the junctions before the PSF, px (cv2 thickness).
    junction_cv : float
        Coefficient of variation of the junction intensities (lognormal,
        mean 1, one value per pair of cells for the whole movie).
    curvature : float
        RMS sagitta of a junction as a fraction of its length (0: straight
        segments between the vertices; 0.05 is a slight bend).
    cytoplasm : float
        Mean expected photons per pixel inside cells, frame 0.
    cytoplasm_cv : float
        Coefficient of variation of the cytoplasm level between cells.
    background : float
        Expected photons per pixel where the truth has no cell (label 0).
    psf : {"gaussian", "airy"}
        Point spread function.
    psf_sigma : float
        Gaussian standard deviation, px; for ``"airy"``, the sigma of the
        Gaussian that best fits it (0.21 lambda / NA; first dark ring at
        2.9 sigma).
        0 disables the PSF.
    read_noise : float
        Camera read noise, electrons RMS (Gaussian).
    gain : float
        ADU per electron.
    offset : float
        Camera offset, ADU (keeps read noise from clipping at 0).
    bleach_rate : float
        Photobleaching: the fluorescence of frame t is exp(-bleach_rate t)
        of frame 0; per frame.
    drift : float
        Stage drift: per-axis standard deviation of the random-walk step, px
        per frame (0: none).
    nuclei : bool
        Add a nuclear channel (disks at the cells' pixel centroids).
    nucleus_radius : float, optional
        Nuclear radius, px (default: 0.4 x the mean cell radius of frame 0).
    nucleus_photons : float
        Expected photons per pixel inside a nucleus, above ``background``, frame 0.
    shot_noise : {"poisson", "gaussian"}
        ``"poisson"``: exact Poisson counts; ``"gaussian"``: Normal(clean,
        clean + read_noise^2) in one draw, the usual approximation for
        counts above ~20 (a frame renders about 2 x faster).
    """

    snr: float = cli_field(20.0, "--snr", "membrane contrast over the cytoplasm in noise standard deviations, frame 0 "
                           "(docs/benchmark.md)")
    membrane_width: int = cli_field(2, "--membrane-width", "junction line thickness before the PSF, px")
    junction_cv: float = cli_field(0.25, "--junction-cv", "coefficient of variation of the junction intensities (one "
                                   "per cell pair)")
    curvature: float = cli_field(0.0, "--curvature", "RMS junction bend (sagitta) as a fraction of its length; 0 = "
                                 "straight")
    cytoplasm: float = cli_field(50.0, "--cytoplasm", "expected photons per pixel inside cells, frame 0")
    cytoplasm_cv: float = cli_field(0.1, "--cytoplasm-cv", "coefficient of variation of the cytoplasm level between "
                                    "cells")
    background: float = cli_field(10.0, "--background", "expected photons per pixel where there is no cell")
    psf: str = cli_field("gaussian", "--psf", "point spread function", choices=PSFS)
    psf_sigma: float = cli_field(1.0, "--psf-sigma", "PSF Gaussian sigma (Airy: of its best-fit Gaussian), px; 0 = "
                                 "none")
    read_noise: float = cli_field(2.0, "--read-noise", "camera read noise, electrons RMS")
    gain: float = cli_field(1.0, "--gain", "ADU per electron")
    offset: float = cli_field(100.0, "--offset", "camera offset, ADU")
    bleach_rate: float = cli_field(0.0, "--bleach-rate", "photobleaching rate per frame: fluorescence x exp(-rate t)")
    drift: float = cli_field(0.0, "--drift", "stage drift: random-walk step per axis, px per frame (recorded in "
                             "drift.csv)")
    nuclei: bool = cli_field(False, "--nuclei", "add a nuclear channel (disks at the cell centroids)",
                             action="store_true")
    nucleus_radius: float | None = cli_field(None, "--nucleus-radius", "nuclear radius, px (default 0.4 x the mean "
                                             "cell radius)")
    nucleus_photons: float = cli_field(200.0, "--nucleus-photons",
                                       "expected photons per pixel inside a nucleus, frame 0")
    shot_noise: str = cli_field("poisson", "--shot-noise", "exact Poisson counts, or their normal approximation "
                                "(faster)", choices=SHOT_NOISE)

    def __post_init__(self):
        self._number("snr", strict=True)
        self._number("membrane_width", integer=True, strict=True, high=32)
        self._number("junction_cv", high=2.0)
        self._number("curvature", high=0.5)
        for name in ("cytoplasm", "background", "cytoplasm_cv", "psf_sigma", "read_noise", "offset",
                     "bleach_rate", "drift", "nucleus_photons"):
            self._number(name)
        self._number("gain", strict=True)
        self._number("nucleus_radius", strict=True, allow_none=True)
        if self.psf not in PSFS:
            _fail(type(self), "psf", self.psf, f"one of {PSFS}")
        if self.shot_noise not in SHOT_NOISE:
            _fail(type(self), "shot_noise", self.shot_noise, f"one of {SHOT_NOISE}")
        if not isinstance(self.nuclei, bool):
            _fail(type(self), "nuclei", self.nuclei, "True or False")


def _hash_uniform(key, *ids):
    """Uniform numbers in (0, 1) that depend only on ``key`` and the integer ids (splitmix64 finaliser).

    Junction and cell properties are functions of the cells' ids, so they
    are the same in every frame and independent of table order.
    """
    h = np.full(np.shape(ids[0]), np.uint64(key), dtype=np.uint64)
    for i, v in enumerate(ids):
        with np.errstate(over="ignore"):
            h = mix64(h ^ (np.asarray(v).astype(np.uint64) + np.uint64(GOLDEN * (i + 1) % 2**64)))
    return ((h >> np.uint64(11)).astype(np.float64) + 0.5) / 2.0**53


def _lognormal(u, cv):
    """Lognormal values of mean 1 and coefficient of variation ``cv`` from uniforms ``u``."""
    from scipy.special import ndtri

    s = np.sqrt(np.log1p(cv**2))
    return np.exp(s * ndtri(u) - 0.5 * s**2)


def _by_frame(table, columns):
    """``{frame: {column: numpy array}}`` of a table (rows of each frame in table order)."""
    data = {c: table[c].to_numpy() for c in columns}
    return {int(f): {c: data[c][rows] for c in columns} for f, rows in rows_by_frame(table["frame"]).items()}


def transfer_function(shape, psf, sigma):
    """Optical transfer function of the PSF on the ``rfft2`` grid of an image of ``shape`` (rows, cols).

    ``"gaussian"``: exp(-2 pi^2 sigma^2 f^2).  ``"airy"``: the incoherent OTF of a
    circular pupil (the Fourier transform of the Airy pattern (2 J1(v) / v)^2),
    (2 / pi) (arccos q - q sqrt(1 - q^2)) with q = f / f_c, zero beyond the cutoff
    f_c = 2 NA / lambda.  Its best-fit Gaussian has sigma = 0.21 lambda / NA
    (Zhang, Zerubia & Olivo-Marin 2007, paraxial widefield), so f_c = 0.42 / sigma.
    f in cycles per px; sigma 0 gives 1 (no blur).
    """
    fy = np.fft.fftfreq(shape[0])[:, None]
    fx = np.fft.rfftfreq(shape[1])[None, :]
    f = np.hypot(fx, fy)
    if sigma <= 0:
        return np.ones_like(f)
    if psf == "gaussian":
        return np.exp(-2 * np.pi**2 * sigma**2 * f**2)
    q = np.minimum(f * sigma / 0.42, 1.0)
    return (2 / np.pi) * (np.arccos(q) - q * np.sqrt(1 - q**2))


def _shift_ramp(shape, dx, dy):
    """Phase ramp translating an image of ``shape`` by (dx, dy) px (x = column) on its ``rfft2`` grid."""
    rows, cols = shape
    ramp_y = np.exp(-2j * np.pi * dy * np.fft.fftfreq(rows))
    ramp_x = np.exp(-2j * np.pi * dx * np.fft.rfftfreq(cols))
    # the Nyquist frequency of a real signal cannot carry a phase: keep its real part
    if cols % 2 == 0:
        ramp_x[-1] = np.cos(np.pi * dx)
    if rows % 2 == 0:
        ramp_y[rows // 2] = np.cos(np.pi * dy)
    return ramp_y[:, None] * ramp_x[None, :]


class Renderer:
    """Renders frames of a :class:`~hexatissue.benchmark.Truth` (deterministic for a seed).

    Parameters
    ----------
    truth : Truth
        Labels and tables of the ground-truth movie.
    options : RenderOptions
    seed : int or numpy.random.Generator
        Everything random (junction and cell intensities, drift, noise)
        follows from it (:func:`hexatissue.errors.as_generator`).

    Attributes
    ----------
    drift : pandas.DataFrame
        ``frame``, ``dx``, ``dy``: the image shift of every frame, px (a truth
        point (x, y) is seen at (x + dx, y + dy)).
    amplitude : float
        Membrane photons per unit junction intensity (set by ``snr`` on frame 0).
    nucleus_radius : float or None
        Nuclear radius used, px.
    channels : int
        1, or 2 with the nuclear channel (membrane first).
    """

    def __init__(self, truth, options=RenderOptions(), seed=0):
        from .truth import Truth

        if not isinstance(truth, Truth):
            raise InputError(f"truth must be a hexatissue.benchmark.Truth (e.g. truth_from_run); got "
                             f"{type(truth).__name__}")
        if not isinstance(options, RenderOptions):
            raise InputError(f"options must be a hexatissue.benchmark.RenderOptions; got {type(options).__name__}")
        self.truth, self.options = truth, options
        rng = as_generator(seed)
        self._keys = rng.integers(0, 2**63, size=2)  # junction and cell intensities
        n = len(truth)
        steps = rng.normal(0.0, options.drift, size=(n, 2)) if options.drift > 0 else np.zeros((n, 2))
        steps[0] = 0.0
        walk = np.cumsum(steps, axis=0)
        self._walk = walk
        self.drift = pd.DataFrame({"frame": np.arange(n, dtype=np.int64), "dx": walk[:, 0], "dy": walk[:, 1]})
        self._frame_seeds = rng.integers(0, 2**63, size=n)
        self._shape = truth.labels.shape[1:]
        box = truth.box
        self._period = None if box is None else np.array([box.Lx, box.Ly])
        o = options
        self._pad = int(np.ceil(o.membrane_width / 2 + (7.7 if o.psf == "airy" else 4) * o.psf_sigma)) + 2
        if self._period is None:  # the Fourier shift wraps: the pad must hold the largest drift
            self._pad += int(np.ceil(np.abs(walk).max()))
        # cv2.GaussianBlur for a Gaussian PSF without drift; else one pass in Fourier space (PSF and shift)
        self._fourier = o.psf == "airy" or o.drift > 0
        self._otf = {}
        movie = truth.movie
        self._edges = _by_frame(movie.edges, ("vertex_a", "vertex_b", "cell_a", "cell_b"))
        self._vertices = _by_frame(movie.vertices, ("vertex", "x", "y"))
        self._cells = _by_frame(movie.cells, ("cell", "x", "y", "area"))
        top = int(truth.labels.max()) if truth.labels.size else 0
        # expected photons by label id: background at 0, each cell's own cytoplasm level
        self._level = np.r_[o.background, o.cytoplasm * _lognormal(_hash_uniform(self._keys[1], np.arange(1, top + 1)),
                                                                   o.cytoplasm_cv)].astype(np.float32)
        self.channels = 2 if o.nuclei else 1
        self.nucleus_radius = None
        if o.nuclei:
            area = self._cells.get(0, {}).get("area", np.zeros(0))
            mean_radius = np.sqrt(area.mean() / np.pi) if len(area) else 5.0
            self.nucleus_radius = float(o.nucleus_radius or 0.4 * mean_radius)
        self.amplitude = self._calibrate()

    def __len__(self):
        return len(self.truth)

    # -- geometry ------------------------------------------------------------------------------------
    def _junctions(self, t):
        """Polylines (n, k, 2) in px (unwrapped from their first vertex) and their intensities of frame ``t``."""
        e = self._edges.get(t)
        if e is None:
            return np.zeros((0, 2, 2)), np.zeros(0)
        v = self._vertices[t]
        ids = v["vertex"]
        lut = np.full(int(ids.max()) + 1, -1, np.int64)
        lut[ids] = np.arange(len(ids))
        xy = np.c_[v["x"], v["y"]]
        ia, ib = lut[e["vertex_a"]], lut[e["vertex_b"]]
        ca, cb = e["cell_a"], e["cell_b"]
        p0, d = xy[ia], xy[ib] - xy[ia]
        if self._period is not None:
            d -= self._period * np.round(d / self._period)
        keep = np.hypot(*d.T) > 0  # a band around the torus (one degree-2 vertex) has no straight segment
        if self._period is None:
            # a junction with cell 0 along the image edge is the edge of the field of view, not a membrane
            keep &= ~((ca == 0) & self._on_edge(p0) & self._on_edge(p0 + d))
        p0, d, ca, cb = p0[keep], d[keep], ca[keep], cb[keep]
        level = _lognormal(_hash_uniform(self._keys[0], ca, cb), self.options.junction_cv)
        if self.options.curvature > 0 and len(d):
            lines = self._bend(t, p0, d, ca, cb)
        else:
            lines = np.stack([p0, p0 + d], axis=1)
        return lines, level

    def _on_edge(self, xy):
        """Points (x, y) on the rim of the open image: within half a pixel of its outer pixel centres."""
        rows, cols = self._shape
        x, y = xy[:, 0], xy[:, 1]
        return (x < 0.5) | (x > cols - 1.5) | (y < 0.5) | (y > rows - 1.5)

    def _bend(self, t, p0, d, ca, cb):
        """Parabolic junctions: sagitta ``curvature * length * z`` (z standard normal per cell pair), toward cell_b for z > 0."""
        from scipy.special import ndtri

        z = ndtri(_hash_uniform(self._keys[0] ^ 0x5DEECE66D, ca, cb))
        normal = np.c_[-d[:, 1], d[:, 0]]  # length |d|: sagitta = curvature * z * |d|
        cells = self._cells[t]
        lut = np.zeros((int(cells["cell"].max()) + 1, 2))
        lut[cells["cell"]] = np.c_[cells["x"], cells["y"]]
        to_b = lut[cb] - (p0 + 0.5 * d)
        if self._period is not None:
            to_b -= self._period * np.round(to_b / self._period)
        side = np.where(np.einsum("ij,ij->i", normal, to_b) < 0, -1.0, 1.0)
        s = np.linspace(0.0, 1.0, _CURVE_POINTS)
        bulge = 4 * s * (1 - s)
        amp = (self.options.curvature * z * side)[:, None, None]
        return p0[:, None] + s[None, :, None] * d[:, None] + amp * bulge[None, :, None] * normal[:, None]

    def _copies(self, lines):
        """The polylines moved into the padded canvas, and the index of each one's original.

        In a periodic box, every periodic image that reaches the padded canvas
        is drawn, so junctions crossing the box edge appear on both sides.
        """
        if self._period is None:
            return lines + self._pad, np.arange(len(lines))
        rows, cols = self._shape
        lo, hi = lines.min(axis=1), lines.max(axis=1)
        out, index = [], []
        for sx in (-1, 0, 1):
            for sy in (-1, 0, 1):
                shift = self._period * (sx, sy)
                a, b = lo + shift, hi + shift
                hit = np.flatnonzero((b[:, 0] >= -self._pad) & (a[:, 0] <= cols + self._pad)
                                     & (b[:, 1] >= -self._pad) & (a[:, 1] <= rows + self._pad))
                out.append(lines[hit] + shift)
                index.append(hit)
        return np.concatenate(out) + self._pad, np.concatenate(index)

    def _canvas(self):
        rows, cols = self._shape
        return np.zeros((rows + 2 * self._pad, cols + 2 * self._pad), np.uint8)

    def _membrane(self, t, width=None, aa=True):
        """Padded uint8 drawing of the junctions of frame ``t``: the junction intensity in units of 1 / _LEVEL."""
        import cv2
        lines, level = self._junctions(t)
        canvas = self._canvas()
        if not len(lines):
            return canvas
        code = np.clip(np.round(level * (_LEVEL / _BUCKET)), 1, 255 // _BUCKET).astype(np.int64) * _BUCKET
        copies, index = self._copies(lines)
        pts = np.round(copies * 2**_SHIFT).astype(np.int32)
        codes = code[index]
        kind = cv2.LINE_AA if aa else cv2.LINE_8
        thickness = int(width or self.options.membrane_width)
        order = np.argsort(codes, kind="stable")
        values, starts = np.unique(codes[order], return_index=True)
        for value, group in zip(values, np.split(order, starts[1:])):
            cv2.polylines(canvas, pts[group], False, int(value), thickness, kind, _SHIFT)
        return canvas

    def _pad_image(self, image):
        import cv2
        border = cv2.BORDER_WRAP if self._period is not None else cv2.BORDER_REFLECT_101
        p = self._pad
        return cv2.copyMakeBorder(image, p, p, p, p, border)

    def _cytoplasm(self, t):
        return self._pad_image(self._level.take(self.truth.labels[t]))

    def _optics(self, layer, dx=0.0, dy=0.0):
        """A padded layer blurred by the PSF and shifted by (dx, dy), cropped to the frame."""
        import cv2
        o = self.options
        if not self._fourier:
            blurred = cv2.GaussianBlur(layer, (0, 0), o.psf_sigma) if o.psf_sigma > 0 else layer
            return self._crop(blurred)
        # periodic: transform exactly one box (the convolution and the shift wrap); open: the padded
        # canvas, whose pad holds the PSF's reach and the largest drift
        # in single precision (scipy.fft keeps float32; numpy's works in float64, 3 x slower): rounding
        # errors ~1e-7 of the image's total, far below one photon
        from scipy import fft

        image = self._crop(layer) if self._period is not None else layer
        if image.shape not in self._otf:
            self._otf[image.shape] = transfer_function(image.shape, o.psf, o.psf_sigma).astype(np.float32)
        spectrum = fft.rfft2(image)
        spectrum *= self._otf[image.shape]
        if dx or dy:
            spectrum *= _shift_ramp(image.shape, dx, dy).astype(np.complex64)
        image = fft.irfft2(spectrum, s=image.shape)
        return image if self._period is not None else self._crop(image)

    def _crop(self, image):
        p = self._pad
        return image[p:p + self._shape[0], p:p + self._shape[1]]

    def _calibrate(self):
        """Membrane amplitude giving the requested SNR on frame 0 (module docstring)."""
        import cv2
        o = self.options
        cyto = self._optics(self._cytoplasm(0))
        drawn = self._optics(self._membrane(0).astype(np.float32) * np.float32(1.0 / _LEVEL))
        centre = self._crop(self._membrane(0, width=1, aa=False)) > 0
        far = cv2.distanceTransform((~centre).astype(np.uint8), cv2.DIST_L2, 5)
        inside = (self.truth.labels[0] > 0) & (far > o.membrane_width / 2 + 3 * o.psf_sigma + 1)
        if not centre.any() or not inside.any():
            raise InputError("the truth's frame 0 has no junctions or no cytoplasm far from them; the SNR cannot "
                             "be set (use a movie with several cells of more than a few px)")
        # clean = cyto + A drawn; SNR (A dm + dc) = sqrt(q + A m) with the means over J (centre) and C
        # (inside): dm, dc their differences, m the membrane's share of C (the Airy PSF's rings reach
        # it), q = C's cytoplasm + read noise^2.  A is the larger root of the quadratic.
        dm = float(drawn[centre].mean() - drawn[inside].mean())
        dc = float(cyto[centre].mean() - cyto[inside].mean())
        m, q, snr2 = float(drawn[inside].mean()), float(cyto[inside].mean()) + o.read_noise**2, o.snr**2
        b = 2 * dm * dc - snr2 * m
        root = (-b + np.sqrt(b * b - 4 * dm * dm * (dc * dc - snr2 * q))) / (2 * dm * dm)
        return float(max(root, 0.0))

    def _nuclei(self, t):
        import cv2
        o = self.options
        cells = self._cells.get(t, {"x": np.zeros(0), "y": np.zeros(0)})
        centres = np.c_[cells["x"], cells["y"]][:, None, :]
        canvas = self._canvas()
        if len(centres):
            r = self.nucleus_radius
            centres = self._copies(np.concatenate([centres - r, centres + r], axis=1))[0][:, :1] + r
            for x, y in np.round(centres[:, 0] * 2**_SHIFT).astype(np.int64):
                cv2.circle(canvas, (int(x), int(y)), int(round(r * 2**_SHIFT)), 255, -1, cv2.LINE_AA, _SHIFT)
        return canvas.astype(np.float32) * np.float32(o.nucleus_photons / 255.0) + np.float32(o.background)

    # -- frames --------------------------------------------------------------------------------------
    def clean(self, t):
        """Expected electrons of frame ``t`` before noise: ``(channels, rows, cols)`` float32."""
        import cv2
        t = int(t)
        if not 0 <= t < len(self):
            raise InputError(f"frame {t} is not in the truth; it has frames 0..{len(self) - 1}")
        o = self.options
        # cytoplasm + A m in one pass (m = the uint8 drawing / _LEVEL)
        layers = [cv2.addWeighted(self._cytoplasm(t), 1.0, self._membrane(t), self.amplitude / _LEVEL, 0.0,
                                  dtype=cv2.CV_32F)]
        if o.nuclei:
            layers.append(self._nuclei(t))
        dx, dy = self._walk[t]
        fade = np.float32(np.exp(-o.bleach_rate * t))
        out = np.empty((len(layers),) + tuple(self._shape), np.float32)
        for channel, layer in zip(out, layers):
            np.multiply(self._optics(layer, dx, dy), fade, out=channel)
        return out

    def frame(self, t):
        """Frame ``t`` as recorded by the camera: ``(channels, rows, cols)`` uint16 ADU."""
        from ._kernels import ZIGGURAT, camera

        o = self.options
        clean = self.clean(t)
        adu = camera(clean.reshape(-1), np.uint64(self._frame_seeds[int(t)]), o.shot_noise == "poisson",
                     float(o.read_noise), float(o.gain), float(o.offset), _poisson_tables(), ZIGGURAT)
        return adu.reshape(clean.shape)


@lru_cache(maxsize=1)
def _poisson_tables():
    """The alias tables of Poisson(n), n < TABLE_MAX, and the reciprocals (built once, ~0.1 s)."""
    from ._kernels import RECIPROCALS, TABLE_MAX, alias_tables

    return alias_tables(TABLE_MAX - 1) + (RECIPROCALS,)


def poisson_counts(mean, seed=0):
    """Exact Poisson counts of the expected counts ``mean`` (any shape, >= 0), float32.

    The camera's sampler (:mod:`hexatissue.benchmark._kernels`):
    alias tables and inversion below
    :data:`~hexatissue.benchmark._kernels.TABLE_MAX`
    (``poisson_small``), transformed rejection above (``poisson_large``);
    both exact.  ``seed`` (int or Generator) gives the key of the stream.
    """
    from ._kernels import poisson_counts as kernel

    key = np.uint64(as_generator(seed).integers(0, 2**63))
    lam = np.ascontiguousarray(mean, dtype=np.float32).ravel()
    return kernel(lam, key, *_poisson_tables()).reshape(np.shape(mean))


def render(truth, options=RenderOptions(), *, seed=0, progress=True):
    """Every frame of ``truth`` rendered: ``(T, rows, cols)`` uint16, or ``(T, 2, rows, cols)`` with nuclei.

    See :class:`Renderer` (it also gives the drift and the amplitude used).
    """
    from ..progress import progress as bar

    r = Renderer(truth, options, seed)
    frames = np.stack([r.frame(t) for t in bar(range(len(r)), enabled=progress, desc="render", unit="frame")])
    return frames[:, 0] if r.channels == 1 else frames
