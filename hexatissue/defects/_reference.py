"""Plain-numpy references of the kernels in :mod:`hexatissue.defects._kernels`.

:func:`field_layouts` and :func:`plaquette_defects` have the kernels' names and signatures; the latter keeps
the charged plaquettes of :func:`winding` (the plain-numpy path of
:func:`hexatissue.defects.plaquette_charges`), which gives every plaquette's charge.
"""
from __future__ import annotations

import numpy as np

from .field import winding  # the reference of _kernels.plaquette_defects, beside plaquette_charges


def field_layouts(row, col, rows, cuts):
    """Reference of :func:`hexatissue.defects._kernels.field_layouts` (one field at a time, numpy)."""
    n_fields = len(cuts) - 1
    shapes, once, block = np.zeros((n_fields, 2), np.int64), np.zeros(n_fields, bool), np.zeros(n_fields, bool)
    for g, (a, b) in enumerate(zip(cuts[:-1], cuts[1:])):
        r, c = row[rows[a:b]], col[rows[a:b]]
        shapes[g] = r.max() + 1, c.max() + 1
        n = shapes[g].prod()
        if len(r) != n or r.min() < 0 or c.min() < 0:
            continue
        node = r * shapes[g, 1] + c
        once[g] = np.bincount(node, minlength=n).max() == 1
        block[g] = once[g] and (node == np.arange(n)).all() and (rows[a:b] == rows[a] + np.arange(n)).all()
    return shapes, once, block


def plaquette_defects(theta, p, periodic):
    """Reference of :func:`hexatissue.defects._kernels.plaquette_defects`: the charged plaquettes of :func:`winding`."""
    charge = winding(theta, p, periodic).ravel()
    flat = np.flatnonzero(charge != 0)  # NaN != 0, but a NaN plaquette is never charged
    flat = flat[np.isfinite(charge[flat])]
    return flat.astype(np.int64), charge[flat]
