"""Numba kernel of the flow stage: least-squares affine fits of cell velocities on grid nodes.

:func:`affine_fits` has a plain-numpy twin of the same name and signature in
:mod:`hexatissue.flow._reference`; the tests compare the two.  Positions are
(x, y) = (column, row) in px, velocities in px/frame.

The whole movie goes in one call (frame after frame inside the kernel), so a
1000-frame movie costs no Python loop: per frame the counted cells are binned
on a lattice of bins at least as large as the largest disk radius of the
frame (copied in bin order, so each bin is a run of consecutive memory), and
every node scans the (at most 3 x 3) bins its disk overlaps.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

#: A fit needs its cells spread, in their narrowest direction, by at least this fraction of the disk radius
#: (root mean square about their mean): three nearly collinear cells give no velocity gradient across them.
MIN_SPREAD = 0.1


@njit(cache=True)
def _offset(d, period):
    """Minimum-image displacement along one axis of two positions inside ``[0, period)`` (``d`` itself when
    ``period`` is 0: open image); a comparison, not a division, as it runs for every cell a node scans."""
    if period > 0.0:
        if d > 0.5 * period:
            return d - period
        if d < -0.5 * period:
            return d + period
    return d


@njit(cache=True)
def _bins_of_frame(cx, cy, cu, cv, lo, hi, size, period):
    """Counting sort of the cells ``lo:hi`` (inside the box when periodic) into bins of side >= ``size``.

    Returns ``(xs, ys, us, vs, starts, origin_x, origin_y, bin_x, bin_y, nbx, nby)``: the cells'
    positions and velocities in bin order (so a bin is a run of consecutive memory), the cells of
    bin ``b = by * nbx + bx`` being ``starts[b]:starts[b + 1]``.
    """
    n = hi - lo
    if period[0] > 0.0:
        ox, oy = 0.0, 0.0
        nbx, nby = max(1, int(period[0] // size)), max(1, int(period[1] // size))
        bx_size, by_size = period[0] / nbx, period[1] / nby
    else:
        ox, oy, mx, my = np.inf, np.inf, -np.inf, -np.inf
        for c in range(lo, hi):
            ox, oy = min(ox, cx[c]), min(oy, cy[c])
            mx, my = max(mx, cx[c]), max(my, cy[c])
        if n == 0:
            ox, oy, mx, my = 0.0, 0.0, 0.0, 0.0
        nbx, nby = int((mx - ox) // size) + 1, int((my - oy) // size) + 1
        bx_size, by_size = size, size
    key = np.empty(n, np.int64)
    starts = np.zeros(nbx * nby + 1, np.int64)
    for k in range(n):
        bx = min(max(int((cx[lo + k] - ox) // bx_size), 0), nbx - 1)
        by = min(max(int((cy[lo + k] - oy) // by_size), 0), nby - 1)
        key[k] = by * nbx + bx
        starts[key[k] + 1] += 1
    for b in range(nbx * nby):
        starts[b + 1] += starts[b]
    fill = starts[:-1].copy()
    xs, ys, us, vs = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    for k in range(n):
        j = fill[key[k]]
        xs[j], ys[j], us[j], vs[j] = cx[lo + k], cy[lo + k], cu[lo + k], cv[lo + k]
        fill[key[k]] += 1
    return xs, ys, us, vs, starts, ox, oy, bx_size, by_size, nbx, nby


@njit(cache=True)
def _bin_span(q, r, origin, size, nb, periodic):
    """First and last bin (inclusive; unwrapped when periodic) overlapping ``[q - r, q + r]``."""
    lo = int(math.floor((q - r - origin) / size))
    hi = int(math.floor((q + r - origin) / size))
    if periodic:
        if hi - lo + 1 >= nb:
            return 0, nb - 1
        return lo, hi
    return max(lo, 0), min(hi, nb - 1)


@njit(cache=True)
def affine_fits(cx, cy, cu, cv, cell_rows, nx, ny, nr, node_rows, period, min_cells, out, counts):
    """Least-squares fit ``v = v0 + L (r - r_node)`` to the cells within each node's disk.

    Parameters
    ----------
    cx, cy, cu, cv : (m,) float
        Counted cells (interior, finite position and velocity) sorted by frame: position, px (inside
        ``[0, L)`` in a periodic box), and velocity, px/frame.
    cell_rows : (n_frames, 2) int64
        The cells of frame ``f`` (of the frames that have nodes) are ``cell_rows[f, 0]:cell_rows[f, 1]``.
    nx, ny, nr : (n,) float
        Nodes sorted by the same frame blocks: position and disk radius, px.
    node_rows : (n_frames, 2) int64
        The nodes of frame ``f``, likewise.
    period : (2,) float
        ``(Lx, Ly)`` of a periodic box (minimum-image distances), or ``(0, 0)`` for an open image.
    min_cells : int
        Fewest cells a fit takes (at least 3).
    out : (6, n) float, written
        Per node ``v0x, v0y, Lxx, Lxy, Lyx, Lyy`` with ``L_ij = d v_i / d x_j`` (px/frame and
        1/frame); NaN where there are fewer than ``min_cells`` cells or they are not spread by
        :data:`MIN_SPREAD` x the radius across their narrowest direction.
    counts : (n,) int64, written
        Cells in each node's disk.

    Notes
    -----
    Sums are taken relative to the node (so they are of the size of the radius, whatever the
    image size) and the fit is solved about the cells' mean position: the gradient is
    ``C^-1 cov(r, v)`` with ``C`` the 2 x 2 covariance of the positions, and ``v0`` the mean
    velocity moved from the mean position to the node.  A uniform velocity gives gradients of
    rounding size (its covariances cancel exactly but for the last bits of the means).
    """
    periodic = period[0] > 0.0
    for f in range(cell_rows.shape[0]):
        a, b = node_rows[f, 0], node_rows[f, 1]
        if b == a:
            continue
        rmax = 0.0
        for i in range(a, b):
            rmax = max(rmax, nr[i])
        xs, ys, us, vs, starts, ox, oy, sx, sy, nbx, nby = _bins_of_frame(cx, cy, cu, cv, cell_rows[f, 0],
                                                                          cell_rows[f, 1], max(rmax, 1e-9), period)
        for i in range(a, b):
            qx, qy, r = nx[i], ny[i], nr[i]
            r2 = r * r
            if periodic:
                qx -= period[0] * math.floor(qx / period[0])
                qy -= period[1] * math.floor(qy / period[1])
            x0, x1 = _bin_span(qx, r, ox, sx, nbx, periodic)
            y0, y1 = _bin_span(qy, r, oy, sy, nby, periodic)
            n = 0
            s_x = s_y = s_xx = s_xy = s_yy = s_u = s_v = s_xu = s_yu = s_xv = s_yv = 0.0
            for byu in range(y0, y1 + 1):
                row = (byu % nby) * nbx
                for bxu in range(x0, x1 + 1):
                    bin_ = row + bxu % nbx
                    for s in range(starts[bin_], starts[bin_ + 1]):
                        dx = _offset(xs[s] - qx, period[0])
                        dy = _offset(ys[s] - qy, period[1])
                        if dx * dx + dy * dy > r2:
                            continue
                        u, v = us[s], vs[s]
                        n += 1
                        s_x += dx
                        s_y += dy
                        s_xx += dx * dx
                        s_xy += dx * dy
                        s_yy += dy * dy
                        s_u += u
                        s_v += v
                        s_xu += dx * u
                        s_yu += dy * u
                        s_xv += dx * v
                        s_yv += dy * v
            counts[i] = n
            out[:, i] = np.nan
            if n < max(min_cells, 3):
                continue
            mx, my, mu, mv = s_x / n, s_y / n, s_u / n, s_v / n
            cxx, cxy, cyy = s_xx / n - mx * mx, s_xy / n - mx * my, s_yy / n - my * my
            half_trace = 0.5 * (cxx + cyy)
            det = cxx * cyy - cxy * cxy
            smallest = half_trace - math.sqrt(max(half_trace * half_trace - det, 0.0))
            if not smallest >= (MIN_SPREAD * r) ** 2:
                continue
            cxu, cyu = s_xu / n - mx * mu, s_yu / n - my * mu
            cxv, cyv = s_xv / n - mx * mv, s_yv / n - my * mv
            # [[cxx, cxy], [cxy, cyy]] (dv/dx, dv/dy) = (cov(x, v), cov(y, v)) for v = u and v
            lxx = (cyy * cxu - cxy * cyu) / det
            lxy = (cxx * cyu - cxy * cxu) / det
            lyx = (cyy * cxv - cxy * cyv) / det
            lyy = (cxx * cyv - cxy * cxv) / det
            out[0, i] = mu - lxx * mx - lxy * my
            out[1, i] = mv - lyx * mx - lyy * my
            out[2, i], out[3, i], out[4, i], out[5, i] = lxx, lxy, lyx, lyy
