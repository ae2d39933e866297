"""The coarse-grained field Gamma_p on a labelled mesh: each cell's disk along the surface, the cells' gamma_p
transported into its frame (:func:`coarse_field`, used by :func:`hexatissue.surface.mesh_tissue`).
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from .transport import arc_lengths, transport_angles

__all__ = ["RADIUS_FACTOR", "cell_radius", "coarse_field"]

#: Default coarse-graining radius on a mesh, in units of R_cell = sqrt(mean area / pi).  The flat grid's 1.5 R_cell
#: disks sit anywhere between cells and hold (1.5)^2 = 2.25 cells on average; centred on a cell, whose neighbours are
#: about 1.9 R_cell away (a hexagonal tiling's spacing), a 1.5 R_cell disk holds the cell alone (1.0-1.2 cells on
#: spheres of 400 cells) and Gamma_p is gamma_p.  2.5 R_cell takes in the first shell of neighbours, not the second
#: (3.3 R_cell): about 7 cells (docs/surface.md, "Gamma_p on a mesh").
RADIUS_FACTOR = 2.5


def cell_radius(area, interior):
    """R_cell = sqrt(mean area / pi) of the interior cells with a positive finite area (of every such cell when no
    cell is interior: a patch that is all border), as :func:`hexatissue.order.cell_radius`; NaN without any."""
    good = np.isfinite(area) & (area > 0)
    use = good & interior if (good & interior).any() else good
    return float(np.sqrt(area[use].mean() / np.pi)) if use.any() else np.nan


def coarse_field(centroid, normal, e1, e2, gammas, orders, interior, radius):
    """Gamma_p at every cell (docs/surface.md, "Gamma_p on a mesh"), the cells averaged in each disk and whether
    the disk lies on the tissue.

    Cell j is in cell c's disk when :func:`arc_lengths` between their
    centroids is at most ``radius``; the interior cells of the disk whose
    gamma_p of every order is finite enter the mean, each carried into c's
    frame (``gamma_j exp(i p phi_jc)``, :func:`transport_angles`).  An empty
    disk gives NaN.  A disk is valid when it averages a cell and holds no
    border cell (the flat grid's full coverage: the disk does not reach the
    tissue's edge).
    """
    nc = len(centroid)
    ok = np.isfinite(centroid).all(axis=1) & np.isfinite(normal).all(axis=1)
    gamma = np.column_stack(gammas) if len(orders) else np.zeros((nc, 0), complex)
    member = ok & interior & np.isfinite(gamma).all(axis=1)
    nodes = np.flatnonzero(ok)
    if not np.isfinite(radius) or len(nodes) == 0:
        return [np.full(nc, complex(np.nan, np.nan)) for _ in orders], np.zeros(nc, np.int64), np.zeros(nc, bool)
    # an arc is never shorter than its chord: the chord's ball holds every cell of the disk
    pairs = cKDTree(centroid[nodes]).query_pairs(radius * (1 + 1e-9), output_type="ndarray")
    i, j = nodes[pairs[:, 0]], nodes[pairs[:, 1]]
    node, cell = np.r_[i, j, nodes], np.r_[j, i, nodes]
    near = arc_lengths(centroid[node], centroid[cell], normal[node], normal[cell]) <= radius
    edge = np.bincount(node[near & ~interior[cell]], minlength=nc) > 0
    near &= member[cell]
    node, cell = node[near], cell[near]
    phi = transport_angles(normal[cell], e1[cell], normal[node], e1[node], e2[node])
    phi[node == cell] = 0.0  # a cell in its own frame: exactly, not to the round-off of the rotation's formula
    keep = np.isfinite(phi)  # opposed normals (a disk across a thin fold) have no minimal rotation: not averaged
    node, cell, phi = node[keep], cell[keep], phi[keep]
    count = np.bincount(node, minlength=nc)
    means = []
    for a, q in enumerate(orders):
        carried = gamma[cell, a] * np.exp(1j * q * phi)
        total = np.bincount(node, carried.real, nc) + 1j * np.bincount(node, carried.imag, nc)
        with np.errstate(invalid="ignore", divide="ignore"):
            means.append(np.where(count > 0, total / np.maximum(count, 1), complex(np.nan, np.nan)))
    return means, count.astype(np.int64), (count > 0) & ~edge
