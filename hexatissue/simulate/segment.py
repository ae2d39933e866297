"""Phase fields -> label image, by the paper's procedure.

A lattice node belongs to cell ``c`` where ``phi_c > phi0 / 2``; where several
cells pass the threshold it goes to the largest field (ties to the lower cell
index).  Gap nodes (no field above ``phi0 / 2``, e.g. at junctions of three
cells) inside the tissue are then filled from their neighbours: repeatedly,
each gap node takes the label of the labelled 4-neighbour (periodic) with the
largest field, until no gap node is left next to a labelled one.  Gap nodes
are filled where the tissue covers them (total field ``sum_c phi_c`` above
``phi0 / 2``, true at junctions where interfaces overlap) and in every hole
smaller than ``max_hole`` px (default: one cell's target area pi R^2): a
hole that cannot hold a cell belongs to the cells around it, as in the
paper's procedure (active runs open such holes transiently).  Larger empty
regions, e.g. around an isolated cell, are background and stay 0.

Label ``c + 1`` is cell ``c`` (0-based index in the simulation), so ids are
consistent over time.  Images are indexed ``[row, col]``.
"""
from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..mesh.labels import label_skeleton

__all__ = ["labels_from_max", "labels_from_fields", "segment"]


def labels_from_max(vmax, imax, vsum, phi0, dtype=np.int32, max_hole=0.0) -> np.ndarray:
    """Label image from the per-node largest field ``vmax``, its cell ``imax`` (-1 = none) and total ``vsum``.

    Parameters
    ----------
    vmax : (Ly, Lx) float array
    imax : (Ly, Lx) int array
    vsum : (Ly, Lx) float array
        Total field ``sum_c phi_c``; gap nodes with ``vsum <= phi0 / 2`` stay background.
    phi0 : float
        Bulk field value; the membership threshold is ``phi0 / 2``.
    max_hole : float
        Gap regions (4-connected, periodic) of fewer px are filled even where
        the total field is below ``phi0 / 2``.

    Returns
    -------
    (Ly, Lx) array of ``dtype``: cell index + 1, 0 = background.
    """
    vmax = np.asarray(vmax, dtype=float)
    imax = np.asarray(imax)
    vsum = np.asarray(vsum, dtype=float)
    if not (vmax.shape == imax.shape == vsum.shape) or vmax.ndim != 2:
        raise InputError(f"vmax, imax and vsum must be 2-D arrays of one shape; got {vmax.shape}, {imax.shape}, {vsum.shape}")
    labels = np.where(vmax > 0.5 * phi0, imax + 1, 0).astype(dtype)
    _fill_from_neighbours(labels, vmax, (labels == 0) & (vsum > 0.5 * phi0))
    gap = labels == 0
    if max_hole > 0 and gap.any():
        # holes left once the covered gaps are filled (these thin lines would otherwise join them)
        holes = label_skeleton(~gap, periodic=True)  # the 4-connected gap regions of the torus
        small = np.bincount(holes.ravel()) < max_hole
        small[0] = False
        _fill_from_neighbours(labels, vmax, small[holes])
    return labels


def _fill_from_neighbours(labels, vmax, fillable):
    """Give ``fillable`` gap nodes, layer by layer, the label of their 4-neighbour with the largest field."""
    fillable = fillable.copy()
    while fillable.any():
        best_v = np.full(vmax.shape, -np.inf)
        best_l = np.zeros_like(labels)
        for axis, shift in ((0, 1), (0, -1), (1, 1), (1, -1)):
            nl = np.roll(labels, shift, axis)
            nv = np.roll(vmax, shift, axis)
            better = (nl > 0) & (nv > best_v)
            best_v = np.where(better, nv, best_v)
            best_l = np.where(better, nl, best_l)
        take = fillable & (best_l > 0)
        if not take.any():
            break
        labels[take] = best_l[take]
        fillable &= ~take


def labels_from_fields(fields, phi0, dtype=np.int32, max_hole=0.0) -> np.ndarray:
    """Reference: labels from full-lattice fields ``(N, Ly, Lx)`` (argmax over cells; plain numpy)."""
    fields = np.asarray(fields)
    if fields.ndim != 3:
        raise InputError(f"fields must be (N, Ly, Lx); got shape {fields.shape}")
    vmax = fields.max(0)
    imax = np.where(vmax > 0, fields.argmax(0), -1)
    return labels_from_max(np.maximum(vmax, 0), imax, fields.sum(0), phi0, dtype, max_hole)


def segment(sim) -> np.ndarray:
    """Label image ``(Ly, Lx)`` of a :class:`~hexatissue.simulate.Simulation` (label = cell index + 1)."""
    vmax, imax, vsum = sim.max_field()
    dtype = np.int16 if sim.params.n_cells < np.iinfo(np.int16).max else np.int32
    p = sim.params
    return labels_from_max(vmax, imax, vsum, p.phi0, dtype, max_hole=np.pi * p.R**2)
