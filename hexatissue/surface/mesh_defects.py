"""p-atic defects on a labelled mesh: the dual triangles of its junction vertices with the curvature each encloses,
and the charges of a field of the cells (:func:`dual_triangles`, :func:`field_defects`, used by
:func:`hexatissue.surface.mesh_tissue`).
"""
from __future__ import annotations

import warnings

import numpy as np
import pandas as pd

from ..errors import HexatissueWarning
from .transport import solid_angles, transport_angles

__all__ = ["dual_triangles", "field_defects"]

#: A charge times p further than this from an integer is reported (it cannot happen but through round-off).
_CHARGE_TOLERANCE = 1e-6


def dual_triangles(frm, prv, twin, idx, face_of, verts, normal, e1, e2):
    """The dual triangles around the junction vertices ``verts`` (docs/surface.md, "Surface meshes"): each vertex's
    cells counter-clockwise (``ring`` from ``ring_start``, ``d`` of them), its fan triangles of distinct cells
    (``owner`` vertex, cells ``i0, i1, i2``), each side's cells and transport angle (``sides``) and the solid angle
    of each triangle's normals (``curvature``)."""
    n_he = len(frm)
    out_he = np.full(int(frm.max()) + 1 if n_he else 0, -1, np.int64)
    out_he[frm[::-1]] = np.arange(n_he)[::-1]
    # the faces around each interior junction vertex, counter-clockwise: h -> twin(prev(h))
    start = out_he[verts]
    seqs = [idx[face_of[start]]]
    cur = start.copy()
    active = np.ones(len(verts), bool)
    for _ in range(n_he):
        cur = np.where(active, twin[prv[cur]], cur)
        active &= cur != start
        if not active.any():
            break
        seqs.append(np.where(active, idx[face_of[cur]], -2))
    seq = np.column_stack(seqs) if len(verts) else np.zeros((0, 1), np.int64)
    valid = seq != -2
    length = valid.sum(axis=1)
    prev = np.roll(seq, 1, axis=1)
    prev[:, 0] = seq[np.arange(len(seq)), length - 1] if len(seq) else prev[:, 0]
    keep = valid & (seq != prev)
    d = keep.sum(axis=1)
    ring = seq[keep]  # the cells around each vertex, counter-clockwise, vertex after vertex
    ring_start = np.r_[0, np.cumsum(d)[:-1]].astype(np.int64)
    # fan: (c0, c_k, c_k+1), k = 1 .. d-2
    n_tri = np.maximum(d - 2, 0)
    owner = np.repeat(np.arange(len(verts)), n_tri)
    k = np.arange(int(n_tri.sum())) - np.repeat(np.cumsum(n_tri) - n_tri, n_tri) + 1
    i0 = ring[ring_start[owner]]
    i1 = ring[ring_start[owner] + k]
    i2 = ring[ring_start[owner] + k + 1]
    proper = (i0 != i1) & (i1 != i2) & (i0 != i2)
    owner, i0, i1, i2 = owner[proper], i0[proper], i1[proper], i2[proper]
    # each side's transport angle from its lower cell to its higher, once for every field and order
    sides = [(i, j, transport_angles(normal[np.minimum(i, j)], e1[np.minimum(i, j)], normal[np.maximum(i, j)],
                                     e1[np.maximum(i, j)], e2[np.maximum(i, j)]))
             for i, j in ((i0, i1), (i1, i2), (i2, i0))]
    return {"verts": verts, "ring": ring, "ring_start": ring_start, "d": d, "owner": owner, "i0": i0, "i1": i1,
            "i2": i2, "sides": sides, "curvature": solid_angles(normal[i0], normal[i1], normal[i2])}


def field_defects(dual, V, fields, orders, cells, frame, field, valid=None):
    """The defects of one field (one complex array per order, a value per cell, in the cells' frames) on the dual
    triangles (:func:`dual_triangles`), labelled ``field``, and ``{p: (total charge, undefined triangles)}``.

    With ``valid`` (a flag per cell), only the vertices whose cells are all valid are looked at.
    """
    columns = ["frame", "defect", "field", "vertex", "x", "y", "z", "charge", "p", "cell_a", "cell_b", "cell_c",
               "n_cells"]
    verts, ring, ring_start, d = dual["verts"], dual["ring"], dual["ring_start"], dual["d"]
    owner, i0, i1, i2 = dual["owner"], dual["i0"], dual["i1"], dual["i2"]
    looked = np.ones(len(owner), bool)
    if valid is not None:
        outside = np.bincount(owner[~(valid[i0] & valid[i1] & valid[i2])], minlength=len(verts)) > 0
        looked = ~outside[owner]
    rows, totals = [], {}
    for q, gam in zip(orders, fields):
        phase = np.angle(gam)  # phases apart: a product of two tiny gamma_p (p = 1 about the vertex mean) would vanish
        winding = sum(_delta(i, j, phi, phase, q) for i, j, phi in dual["sides"])
        x = np.where(looked, (winding + q * dual["curvature"]) / (2 * np.pi), 0.0)
        ok = np.isfinite(x)
        whole = np.round(x[ok])
        if len(whole) and np.abs(x[ok] - whole).max() > _CHARGE_TOLERANCE:
            warnings.warn(f"defect charges of p = {q} ({field}) are up to {np.abs(x[ok] - whole).max():.2g} / {q} "
                          f"from a multiple of 1/{q} (round-off); rounded", HexatissueWarning, stacklevel=3)
        numer = np.bincount(owner[ok], whole, len(verts)).astype(np.int64)
        bad = np.bincount(owner[~ok], minlength=len(verts)) > 0
        totals[q] = (float(numer[~bad].sum()) / q, int((~ok).sum()))
        hit = np.flatnonzero((numer != 0) & ~bad)
        v = verts[hit]
        rs = ring_start[hit]
        rows.append(pd.DataFrame({
            "frame": np.full(len(hit), frame, np.int64), "defect": np.zeros(len(hit), np.int64),
            "field": np.full(len(hit), field, object), "vertex": v.astype(np.int64), "x": V[v, 0], "y": V[v, 1],
            "z": V[v, 2], "charge": numer[hit] / q, "p": np.full(len(hit), q, np.int64),
            "cell_a": cells[ring[rs]].astype(np.int64), "cell_b": cells[ring[rs + 1]].astype(np.int64),
            "cell_c": cells[ring[rs + 2]].astype(np.int64), "n_cells": d[hit].astype(np.int64)}))
    table = pd.concat(rows, ignore_index=True) if rows else pd.DataFrame(columns=columns)
    return table[columns], totals


def _delta(i, j, phi, phase, p):
    """The wrapped p-fold phase step from cell i to cell j after transport (``phi``: from the lower cell's frame to
    the higher's), antisymmetric in (i, j) by construction."""
    lo, hi = np.minimum(i, j), np.maximum(i, j)
    step = np.angle(np.exp(1j * (phase[hi] - phase[lo] - p * phi)))
    return np.where(i < j, step, -step)
