"""A raw channel measured on the junction network: junction and cell intensities, junction polarity.

What Tissue Analyzer and TissueMiner users do with E-cadherin or myosin images: the intensity along
every junction, inside every cell, and how a cell's bright junctions are oriented.  Positions follow
the package convention (x = column, y = row, px, origin at the centre of pixel (0, 0)); intensities
are in the raw image's own units.

- **Junction intensity**: the image sampled (bilinear interpolation) every ``step`` px along the
  straight segment between the junction's two vertices; ``intensity_mean`` is the mean of the
  samples and ``intensity_total`` = mean x length (integrated intensity, intensity x px).
- **Cell intensity**: the mean over the cell's pixels (its label region, membranes shared out).
- **Junction polarity** of a cell: ``P = sum_j w_j exp(2 i theta_j) / sum_j w_j`` over its junctions
  with ``w_j = intensity_total_j`` and ``theta_j`` the junction's direction: a nematic of modulus
  in [0, 1] (0 when intensity is spread evenly over directions, 1 when it all sits on parallel
  junctions) whose argument / 2 is the axis of the bright junctions.
"""
from __future__ import annotations

import numpy as np

from .errors import InputError, check_positive
from .geometry import bilinear
from .mesh.labels import compact_labels

__all__ = ["measure_intensity", "STEP"]

STEP = 0.5  # px between samples along a junction


def _junction_samples(vertices, edges, image, box, step):
    """Mean sampled intensity and direction (rad) of every junction (NaN for closed loops)."""
    xy = vertices.set_index("vertex")[["x", "y"]]
    p0 = xy.reindex(edges["vertex_a"]).to_numpy(float)
    p1 = xy.reindex(edges["vertex_b"]).to_numpy(float)
    d = p1 - p0 if box is None else box.min_image(p1 - p0)
    length = np.hypot(d[:, 0], d[:, 1])
    n = np.maximum(2, np.ceil(length / step).astype(np.int64) + 1)
    owner = np.repeat(np.arange(len(edges)), n)
    start = np.cumsum(n) - n
    frac = (np.arange(n.sum()) - start[owner]) / (n[owner] - 1)
    sx, sy = p0[owner, 0] + frac * d[owner, 0], p0[owner, 1] + frac * d[owner, 1]
    values = bilinear(image, sx, sy, box is not None)
    mean = np.bincount(owner, values, len(edges)) / n if len(edges) else np.zeros(0)
    loop = edges["vertex_a"].to_numpy() == edges["vertex_b"].to_numpy()
    mean[loop] = np.nan  # a boundary with no vertex: not a straight segment
    return mean, np.arctan2(d[:, 1], d[:, 0])


def measure_intensity(cells, vertices, edges, labels, image, box=None, step=STEP):
    """Intensities of a raw channel on one frame's junction network.

    Parameters
    ----------
    cells, vertices, edges : pandas.DataFrame
        One frame's tables (:func:`hexatissue.mesh_from_labels`).
    labels : (rows, cols) int array
        The touching labels the network was built from (cell ids = ``cells.cell``).
    image : (rows, cols) array
        The raw channel, same shape, indexed ``[row, col]``.
    box : Box, optional
        Periodic box (junctions across the edge are sampled across it).
    step : float
        Distance between samples along a junction, px.

    Returns
    -------
    cells : pandas.DataFrame
        A copy with ``intensity_mean`` (mean over the cell's pixels) and
        ``junction_polarity_re``, ``junction_polarity_im`` (dimensionless
        nematic of its junctions' integrated intensity; NaN without junctions).
    edges : pandas.DataFrame
        A copy with ``intensity_mean`` (mean along the junction) and
        ``intensity_total`` (mean x length, intensity x px); NaN for closed
        loops.
    """
    step = check_positive(step, "step", unit="px")
    image = np.asarray(image, dtype=float)
    if image.shape != np.shape(labels):
        raise InputError(f"intensity image has shape {image.shape}; expected the labels' shape {np.shape(labels)}")
    if not np.isfinite(image).all():
        raise InputError("intensity image contains NaN or infinite values; expected finite intensities")
    compact, id_of = compact_labels(np.asarray(labels))  # any id range: bincounts over compact ids
    index = np.searchsorted(id_of, cells["cell"].to_numpy(np.int64))
    n = len(id_of)
    count = np.bincount(compact.ravel(), minlength=n)
    total = np.bincount(compact.ravel(), image.ravel(), minlength=n)
    with np.errstate(invalid="ignore", divide="ignore"):
        cell_mean = total[index] / count[index]
    mean, theta = _junction_samples(vertices, edges, image, box, step)
    integrated = mean * edges["length"].to_numpy(float)
    w = np.nan_to_num(integrated)
    z = w * np.exp(2j * theta)
    num, den = np.zeros(n, complex), np.zeros(n)
    for side in ("cell_a", "cell_b"):
        c = np.searchsorted(id_of, edges[side].to_numpy(np.int64))
        np.add.at(num, c, z)
        np.add.at(den, c, w)
    with np.errstate(invalid="ignore", divide="ignore"):
        polarity = num[index] / den[index]
    out_cells = cells.assign(intensity_mean=cell_mean, junction_polarity_re=polarity.real,
                             junction_polarity_im=polarity.imag)
    out_edges = edges.assign(intensity_mean=mean, intensity_total=integrated)
    return out_cells, out_edges
