"""Numba kernels of the deformation budget: triangle shapes and the continuous part (:mod:`.flow`).

Each kernel has a plain-numpy twin of the same name and signature in
:mod:`hexatissue.deformation._reference`; the tests compare the two.
:func:`triangle_shapes` gives the area and elongation of triangles from
their corners.  For :func:`flow_sums`, for
every path point ``tau`` and triangle it forms ``F = I + tau M``, the
velocity gradient ``L = M F^-1``, the area ``A0 det F`` and the elongation of
``F S0``, and adds the area-weighted quantities of :data:`SUMS` into the
triangle's region of each layer.
"""
from __future__ import annotations

import numpy as np
from numba import njit

#: The area-weighted sums per path point and region, in this order (``A`` the triangle's area).
SUMS = ("A", "A Qxx", "A Qxy", "A vxx", "A vxy", "A trL", "A w", "A Jxx", "A Jxy", "A Qxx trL", "A Qxy trL",
        "A w Qxx", "A w Qxy")


@njit(cache=True)
def _corotation_factor(q2):
    """``(1 - 2q coth 2q) / q^2`` of ``q2 = |Q|^2``, with its series below |Q| = 1e-2."""
    if q2 < 1e-4:
        return -4.0 / 3.0 + 16.0 / 45.0 * q2 - 128.0 / 945.0 * q2 * q2
    q = np.sqrt(q2)
    return (1.0 - 2.0 * q / np.tanh(2.0 * q)) / q2


@njit(cache=True, error_model="numpy")
def _elongation(a, b, c, d):
    """Area and elongation (xx, xy) of the state tensor [[a, b], [c, d]] (see :mod:`.triangles`)."""
    area = a * d - b * c
    sdet = np.sqrt(abs(area))
    px, py = 0.5 * (a - d), 0.5 * (b + c)
    # Q is P turned by the rotation theta = atan2(W, T): its cosine and sine without the angle
    tr, wr = 0.5 * (a + d), 0.5 * (c - b)
    rr = np.sqrt(tr * tr + wr * wr)
    cs, sn = tr / rr, wr / rr
    ratio = np.sqrt(px * px + py * py) / sdet
    if ratio < 1e-4:
        scale = (1.0 - ratio * ratio / 6.0) / sdet
    else:
        scale = np.arcsinh(ratio) / ratio / sdet
    return area, scale * (cs * px - sn * py), scale * (sn * px + cs * py)


@njit(cache=True, error_model="numpy")  # a degenerate triangle: NaN elongation, as numpy, not an exception
def triangle_shapes(xy, reference_inverse):
    """Area, Q_xx, Q_xy of triangles with corners ``xy`` (m, 3, 2): the state tensor ``R C^-1``'s."""
    m = xy.shape[0]
    area, qxx, qxy = np.empty(m), np.empty(m), np.empty(m)
    c00, c01, c10, c11 = reference_inverse[0, 0], reference_inverse[0, 1], reference_inverse[1, 0], reference_inverse[1, 1]
    for n in range(m):
        r00, r10 = xy[n, 1, 0] - xy[n, 0, 0], xy[n, 1, 1] - xy[n, 0, 1]
        r01, r11 = xy[n, 2, 0] - xy[n, 0, 0], xy[n, 2, 1] - xy[n, 0, 1]
        area[n], qxx[n], qxy[n] = _elongation(r00 * c00 + r01 * c10, r00 * c01 + r01 * c11,
                                              r10 * c00 + r11 * c10, r10 * c01 + r11 * c11)
    return area, qxx, qxy


@njit(cache=True, error_model="numpy")
def flow_sums(M, S0, A0, tau, labels, offsets, n_regions):
    """Area-weighted sums (:data:`SUMS`) per path point and region: ``(len(tau), n_regions, 13)``.

    ``labels`` (layers, m): each triangle's region in each layer (-1: none),
    counted from ``offsets[layer]`` in the output.
    """
    G, m = tau.shape[0], M.shape[0]
    out = np.zeros((G, n_regions, 13))
    for g in range(G):
        t = tau[g]
        for n in range(m):
            m00, m01, m10, m11 = M[n, 0, 0], M[n, 0, 1], M[n, 1, 0], M[n, 1, 1]
            f00, f01, f10, f11 = 1.0 + t * m00, t * m01, t * m10, 1.0 + t * m11
            det = f00 * f11 - f01 * f10
            # L = M adj(F) / det F
            l00 = (m00 * f11 - m01 * f10) / det
            l01 = (-m00 * f01 + m01 * f00) / det
            l10 = (m10 * f11 - m11 * f10) / det
            l11 = (-m10 * f01 + m11 * f00) / det
            area = A0[n] * det
            a = f00 * S0[n, 0, 0] + f01 * S0[n, 1, 0]
            b = f00 * S0[n, 0, 1] + f01 * S0[n, 1, 1]
            c = f10 * S0[n, 0, 0] + f11 * S0[n, 1, 0]
            d = f10 * S0[n, 0, 1] + f11 * S0[n, 1, 1]
            _, qxx, qxy = _elongation(a, b, c, d)
            vxx, vxy = 0.5 * (l00 - l11), 0.5 * (l01 + l10)
            iso = l00 + l11
            w = 0.5 * (l10 - l01)
            along = (-qxy * vxx + qxx * vxy) * _corotation_factor(qxx * qxx + qxy * qxy)
            for layer in range(labels.shape[0]):
                lab = labels[layer, n]
                if lab < 0:
                    continue
                o = out[g, offsets[layer] + lab]
                o[0] += area
                o[1] += area * qxx
                o[2] += area * qxy
                o[3] += area * vxx
                o[4] += area * vxy
                o[5] += area * iso
                o[6] += area * w
                o[7] += area * -qxy * along
                o[8] += area * qxx * along
                o[9] += area * qxx * iso
                o[10] += area * qxy * iso
                o[11] += area * w * qxx
                o[12] += area * w * qxy
    return out
