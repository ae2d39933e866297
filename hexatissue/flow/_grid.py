"""Least-squares affine fits of per-cell values on the nodes of a grid: the fits of the flow fields, flat and on a
height map's surface."""
from __future__ import annotations

import numpy as np

from .._dispatch import Kernels
from ..errors import InputError
from . import _kernels

K = Kernels(_kernels, "hexatissue.flow._reference")


def check_min_cells(min_cells) -> int:
    """``min_cells`` of a fit, an integer >= 3; else :class:`InputError`."""
    if isinstance(min_cells, bool) or not isinstance(min_cells, (int, np.integer)) or min_cells < 3:
        raise InputError(f"min_cells must be an integer >= 3 (an affine fit needs three cells); got {min_cells!r}")
    return int(min_cells)


def _period(box):
    """``(Lx, Ly)`` of a periodic box, ``(0, 0)`` for an open image (the kernels' convention)."""
    return np.zeros(2) if box is None else box.lengths


def _frame_rows(frames, blocks):
    """``(start, end)`` of the rows of each of the frames ``blocks`` in the sorted ``frames`` (empty if absent)."""
    return np.c_[np.searchsorted(frames, blocks, "left"), np.searchsorted(frames, blocks, "right")].astype(np.int64)


def grid_fits(xy, frame, values, grid_frame, grid_xy, radius, box, min_cells):
    """Affine fits ``f = f0 + (df/dx, df/dy) . (r - r_node)`` of every column of ``values`` on every node.

    Parameters
    ----------
    xy : (m, 2) float
        Positions of the cells that count (finite, interior), px.
    frame : (m,) int
        Their frames.
    values : (m, k) float
        Their values, finite; each column is fitted on its own, all on the
        same cells (the kernel's fits of two columns at a time).
    grid_frame : (n,) int
        The nodes' frames.
    grid_xy : (n, 2) float
        The nodes' positions, px.
    radius : (n,) float
        Disk radius of each node's fit, px.
    box : Box or None
        Periodic box (minimum-image distances) or None for an open image.
    min_cells : int
        Fewest cells a fit takes.

    Returns
    -------
    fits : (k, 3, n) float
        Per column and node: the fitted value at the node and its
        derivatives along x and y (per px); NaN where the kernel has no fit
        (fewer than ``min_cells`` cells, or cells not spread across the disk).
    counts : (n,) int64
        Cells in each node's disk.
    """
    c_order = np.argsort(frame, kind="stable")
    xy, values, frame = xy[c_order], values[c_order], frame[c_order]
    if box is not None:
        xy = box.wrap(xy)
    # the grid of analyze is in frame order: then its rows go to the kernel as they are
    g_order = None if bool(np.all(grid_frame[1:] >= grid_frame[:-1])) else np.argsort(grid_frame, kind="stable")

    def sorted_(a):
        return np.ascontiguousarray(a if g_order is None else a[g_order])

    blocks = np.unique(grid_frame)
    cell_rows, node_rows = _frame_rows(frame, blocks), _frame_rows(sorted_(grid_frame), blocks)
    nx, ny, nr = sorted_(grid_xy[:, 0]), sorted_(grid_xy[:, 1]), sorted_(radius)
    cx, cy = np.ascontiguousarray(xy[:, 0]), np.ascontiguousarray(xy[:, 1])
    n, k = len(grid_frame), values.shape[1]
    fits = np.empty((k + k % 2, 3, n))
    counts = np.empty(n, np.int64)
    out = np.empty((6, n))
    for j in range(0, k, 2):
        u = np.ascontiguousarray(values[:, j])
        v = np.ascontiguousarray(values[:, j + 1]) if j + 1 < k else np.zeros(len(u))
        K.affine_fits(cx, cy, u, v, cell_rows, nx, ny, nr, node_rows, _period(box), int(min_cells), out, counts)
        fits[j] = out[[0, 2, 3]]
        fits[j + 1] = out[[1, 4, 5]]
    if g_order is not None:
        fits[:, :, g_order], counts[g_order] = fits.copy(), counts.copy()
    return fits[:k], counts
