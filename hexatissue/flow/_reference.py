"""Plain-numpy reference of the kernel in :mod:`hexatissue.flow._kernels` (same name and signature).

It ignores the bins and works by brute force (every node against every cell
of its frame) and solves each fit with :func:`numpy.linalg.lstsq`, so it is
slow but obviously right; the tests compare the kernel against it.
"""
from __future__ import annotations

import numpy as np

from ._kernels import MIN_SPREAD


def affine_fits(cx, cy, cu, cv, cell_rows, nx, ny, nr, node_rows, period, min_cells, out, counts):
    """Reference of :func:`hexatissue.flow._kernels.affine_fits`."""
    for f in range(len(cell_rows)):
        cells = slice(cell_rows[f, 0], cell_rows[f, 1])
        xy = np.c_[cx[cells], cy[cells]]
        uv = np.c_[cu[cells], cv[cells]]
        for i in range(node_rows[f, 0], node_rows[f, 1]):
            d = xy - [nx[i], ny[i]]
            if period[0] > 0:
                d = d - period * np.rint(d / period)
            inside = (d ** 2).sum(axis=1) <= nr[i] ** 2
            counts[i] = inside.sum()
            out[:, i] = np.nan
            if counts[i] < max(min_cells, 3):
                continue
            spread = np.linalg.eigvalsh(np.cov(d[inside].T, bias=True))[0]
            if not spread >= (MIN_SPREAD * nr[i]) ** 2:
                continue
            design = np.c_[np.ones(counts[i]), d[inside]]
            coef = np.linalg.lstsq(design, uv[inside], rcond=None)[0]  # rows: v0, d/dx, d/dy; columns: vx, vy
            out[:, i] = [coef[0, 0], coef[0, 1], coef[1, 0], coef[2, 0], coef[1, 1], coef[2, 1]]
