"""Numba kernels of the defects of a coarse-grained field (:func:`hexatissue.defects.find_defects`).

Their plain-numpy references are in :mod:`hexatissue.defects._reference`
(``field_layouts`` of the same name and signature; ``winding``, every
plaquette's charge, for ``plaquette_defects``); the tests compare the two.
"""
from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def field_layouts(row, col, rows, cuts):
    """Shape of every field of a grid table, whether it holds each of its nodes once, and whether in place.

    Parameters
    ----------
    row, col : (N,) int64
        Node index along y and x of every row of the grid table.
    rows : (M,) int64
        The table rows of every field, field after field.
    cuts : (G + 1,) int64
        Field ``g`` is ``rows[cuts[g]:cuts[g + 1]]`` (never empty).

    Returns
    -------
    shapes : (G, 2) int64
        ``(ny, nx)`` of each field: its largest ``row`` and ``col`` plus one.
    once : (G,) bool
        The field holds every node of its ``ny x nx`` grid exactly once.
    block : (G,) bool
        Moreover its rows are consecutive table rows in row-major node order (so the field is a
        ``(ny, nx)`` reshape of a slice of the columns).
    """
    g_count = cuts.shape[0] - 1
    shapes = np.zeros((g_count, 2), np.int64)
    once, block = np.zeros(g_count, np.bool_), np.zeros(g_count, np.bool_)
    seen = np.zeros(0, np.bool_)
    for g in range(g_count):
        a, b = cuts[g], cuts[g + 1]
        low, ny, nx = 0, row[rows[a]] + 1, col[rows[a]] + 1
        for e in range(a, b):
            low = min(low, row[rows[e]], col[rows[e]])
            ny, nx = max(ny, row[rows[e]] + 1), max(nx, col[rows[e]] + 1)
        shapes[g, 0], shapes[g, 1] = ny, nx
        if low < 0 or b - a != ny * nx:
            continue
        if seen.shape[0] < b - a:
            seen = np.zeros(b - a, np.bool_)
        seen[:b - a] = False
        once[g], block[g] = True, True
        for e in range(a, b):
            node = row[rows[e]] * nx + col[rows[e]]
            if seen[node]:
                once[g], block[g] = False, False
                break
            seen[node] = True
            block[g] = block[g] and node == e - a and rows[e] == rows[a] + (e - a)
    return shapes, once, block


@njit(cache=True)
def _wrapped(d, period):
    """``d`` wrapped into (-period/2, period/2] (as ``hexatissue.defects.field._wrap_angle``)."""
    return d - period * np.ceil(d / period - 0.5)


@njit(cache=True)
def _plaquette_charge(here, right, down, diag, p, period):
    """Charge of a plaquette from its corners' orientations: the four steps counter-clockwise, each wrapped."""
    total = (_wrapped(right - here, period) + _wrapped(diag - right, period)
             + _wrapped(down - diag, period) + _wrapped(here - down, period))
    return np.round(total * p / (2.0 * np.pi)) / p


@njit(cache=True)
def plaquette_defects(theta, p, periodic):
    """The charged plaquettes of a stack of orientation grids (the kernel of :func:`hexatissue.defects.find_defects`).

    Parameters
    ----------
    theta : (g, ny, nx) float
        Orientations ``Arg(field) / p``, radians, indexed ``[grid, row, col]``; NaN nodes make
        the plaquettes around them NaN (never charged).
    p : int
        Symmetry order.
    periodic : bool
        The grids wrap around: ``ny x nx`` plaquettes, else ``(ny - 1) x (nx - 1)``.

    Returns
    -------
    flat : (d,) int64
        Flat index in the ``(g, ny', nx')`` array of plaquettes of every plaquette of nonzero
        charge, ascending (as ``np.flatnonzero`` of the charges).  Plaquette ``[i, j]`` has the
        corners ``[i, j]`` to ``[i+1, j+1]``.
    charge : (d,) float
        Their charges: the sum of the four steps counter-clockwise in x, y, each wrapped into
        ``(-pi/p, pi/p]``, over ``2 pi`` (a nonzero multiple of ``1/p``).

    The charges of every plaquette are :func:`hexatissue.defects.winding` (the plain-numpy path);
    this kernel keeps only the charged ones, without the array of every charge.
    """
    g, ny, nx = theta.shape
    my, mx = (ny, nx) if periodic else (ny - 1, nx - 1)
    period = 2.0 * np.pi / p
    # room for every plaquette: only the pages of the defects found are ever touched
    flat, charge = np.empty(g * my * mx, np.int64), np.empty(g * my * mx)
    row_charges = np.empty(mx)
    d = 0
    for a in range(g):
        for i in range(my):
            top, bottom = theta[a, i], theta[a, i + 1 if i + 1 < ny else 0]
            # a row's charges first, in a loop without branches (the compiler vectorises it), then the charged ones
            for j in range(nx - 1):
                row_charges[j] = _plaquette_charge(top[j], top[j + 1], bottom[j], bottom[j + 1], p, period)
            if periodic:
                row_charges[nx - 1] = _plaquette_charge(top[nx - 1], top[0], bottom[nx - 1], bottom[0], p, period)
            for j in range(mx):
                if row_charges[j] > 0.0 or row_charges[j] < 0.0:  # NaN compares False
                    flat[d], charge[d] = (a * my + i) * mx + j, row_charges[j]
                    d += 1
    return flat[:d].copy(), charge[:d].copy()
