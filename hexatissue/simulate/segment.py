"""Phase fields -> label image, by the paper's procedure.

A lattice node belongs to cell ``c`` where ``phi_c > phi0 / 2``; where several
cells pass the threshold it goes to the largest field (ties to the lower cell
index).  Gap nodes (no field above ``phi0 / 2``, e.g. at junctions of three
cells) inside the tissue are then filled from their neighbours: repeatedly,
each gap node takes the label of the labelled 4-neighbour (periodic) with the
largest field, until no gap node is left next to a labelled one.  Only gap
nodes *covered by the tissue* are filled, i.e. where the total field
``sum_c phi_c`` exceeds ``phi0 / 2`` (true at junctions, where two or three
interfaces overlap); nodes outside every cell (total field below ``phi0/2``,
e.g. around an isolated cell) are background and stay 0.

Label ``c + 1`` is cell ``c`` (0-based index in the simulation), so ids are
consistent over time.  Images are indexed ``[row, col]``.
"""
from __future__ import annotations

import numpy as np

from ..errors import InputError

__all__ = ["labels_from_max", "labels_from_fields", "segment"]


def labels_from_max(vmax, imax, vsum, phi0, dtype=np.int32) -> np.ndarray:
    """Label image from the per-node largest field ``vmax``, its cell ``imax`` (-1 = none) and total ``vsum``.

    Parameters
    ----------
    vmax : (Ly, Lx) float array
    imax : (Ly, Lx) int array
    vsum : (Ly, Lx) float array
        Total field ``sum_c phi_c``; gap nodes with ``vsum <= phi0 / 2`` stay background.
    phi0 : float
        Bulk field value; the membership threshold is ``phi0 / 2``.

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
    fillable = (labels == 0) & (vsum > 0.5 * phi0)
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
    return labels


def labels_from_fields(fields, phi0, dtype=np.int32) -> np.ndarray:
    """Reference: labels from full-lattice fields ``(N, Ly, Lx)`` (argmax over cells; plain numpy)."""
    fields = np.asarray(fields)
    if fields.ndim != 3:
        raise InputError(f"fields must be (N, Ly, Lx); got shape {fields.shape}")
    vmax = fields.max(0)
    imax = np.where(vmax > 0, fields.argmax(0), -1)
    return labels_from_max(np.maximum(vmax, 0), imax, fields.sum(0), phi0, dtype)


def segment(sim) -> np.ndarray:
    """Label image ``(Ly, Lx)`` of a :class:`~hexatissue.simulate.Simulation` (label = cell index + 1)."""
    vmax, imax, vsum = sim.max_field()
    dtype = np.int16 if sim.params.n_cells < np.iinfo(np.int16).max else np.int32
    return labels_from_max(vmax, imax, vsum, sim.params.phi0, dtype)
