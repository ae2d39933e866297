"""numba kernel of the shape functions gamma_p (:func:`hexatissue.order.shape_functions_flat`).

gamma_p = sum_v z_v^p / sum_v |z_v|^p with ``z_v = x_v + i y_v`` the vertex
relative to the cell centre: the same number as the textbook form
``sum |r|^p exp(i p phi) / sum |r|^p``, computed without transcendental
functions (complex powers by repeated squaring, ``|z|^p = (x^2 + y^2)^(p/2)``,
a square root only for odd p).  It agrees with the transcendental form to
~1e-15; its plain-numpy reference (the transcendental form) is in
``tests/test_order.py``.
"""
from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def _power(base, p):
    """``base ** p`` for an integer p >= 0 by repeated squaring (real or complex ``base``)."""
    result = base * 0 + 1
    while p:
        if p & 1:
            result *= base
        base *= base
        p >>= 1
    return result


@njit(cache=True)
def shape_sums(xy, starts, centre, own_centre, orders, degenerate_area):
    """gamma_p of polygons stored back to back, for each p of ``orders``.

    Parameters
    ----------
    xy : (M, 2) float array
        Vertices (x, y), polygon after polygon; polygon k starts at row ``starts[k]``.
    starts : (N,) int64 array
    centre : (N, 2) float array
        Cell centres; ignored with ``own_centre``, which uses the mean of each polygon's vertices.
    own_centre : bool
    orders : (P,) int64 array
        Symmetry orders (>= 1).
    degenerate_area : float
        A polygon whose area is not above ``degenerate_area`` times its mean
        squared vertex radius (collinear or collapsed vertices), or with fewer
        than 3 vertices, gets NaN; so does one whose denominator is not positive.

    Returns
    -------
    (P, N) complex array
    """
    n = len(starts)
    out = np.full((len(orders), n), np.nan + 0j)
    for k in range(n):
        s = starts[k]
        e = starts[k + 1] if k + 1 < n else len(xy)
        nv = e - s
        if nv < 3:
            continue
        if own_centre:
            cx = 0.0
            cy = 0.0
            for v in range(s, e):
                cx += xy[v, 0]
                cy += xy[v, 1]
            cx /= nv
            cy /= nv
        else:
            cx = centre[k, 0]
            cy = centre[k, 1]
        cross = 0.0  # twice the signed area, of the centred polygon
        size2 = 0.0
        for v in range(s, e):
            w = v + 1 if v + 1 < e else s
            x0 = xy[v, 0] - cx
            y0 = xy[v, 1] - cy
            cross += x0 * (xy[w, 1] - cy) - (xy[w, 0] - cx) * y0
            size2 += x0 * x0 + y0 * y0
        if not (0.5 * abs(cross) > degenerate_area * size2 / nv):
            continue
        for q in range(len(orders)):
            p = orders[q]
            num = 0j
            den = 0.0
            for v in range(s, e):
                x = xy[v, 0] - cx
                y = xy[v, 1] - cy
                r2 = x * x + y * y
                weight = _power(r2, p // 2)
                if p & 1:
                    weight *= np.sqrt(r2)
                num += _power(complex(x, y), p)
                den += weight
            if den > 0:
                out[q, k] = num / den
    return out
