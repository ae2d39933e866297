"""Topological defects of p-atic fields by winding numbers.

For a complex field ``F`` sampled on a regular grid (``Gamma_p`` coarse-grained
from cells, or ``Psi_6`` of the continuum model), the orientation is
``theta = Arg(F) / p``.  Around every grid plaquette the charge is
``s = (1 / 2 pi) sum dtheta`` with each ``dtheta`` wrapped into
``(-pi/p, pi/p]``, so ``s`` is a multiple of ``1/p``; nonzero ``s`` marks a
defect at the plaquette centre.  Loops run counter-clockwise in (x, y),
x = column, y = row.
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from .errors import InputError

__all__ = ["plaquette_charges", "defects_from_field"]


def _wrap_angle(d, p):
    """``d`` wrapped into ``(-pi/p, pi/p]``."""
    period = 2.0 * np.pi / p
    return d - period * np.ceil(d / period - 0.5)


def plaquette_charges(field, p, periodic=False):
    """Winding number of ``Arg(field)/p`` around every plaquette of a grid.

    Parameters
    ----------
    field : (ny, nx) complex array
        Field on a regular grid indexed ``[row, col]`` (row = y, col = x).
        NaN nodes make the plaquettes around them NaN.
    p : int
        Symmetry order.
    periodic : bool
        Whether the grid wraps around (a torus); then there are ``ny x nx``
        plaquettes, else ``(ny - 1) x (nx - 1)``.

    Returns
    -------
    (ny', nx') float array
        Charge of plaquette ``[i, j]`` (corners ``[i, j]`` to ``[i+1, j+1]``),
        an exact multiple of ``1/p`` (NaN where a corner is NaN).
    """
    field = np.asarray(field)
    if field.ndim != 2 or min(field.shape) < 2:
        raise InputError(f"field must be a 2-D grid of at least 2 x 2 nodes; got shape {field.shape}")
    if isinstance(p, bool) or not isinstance(p, (int, np.integer)) or p < 1:
        raise InputError(f"p must be a positive integer symmetry order; got {p!r}")
    theta = np.angle(field) / p
    theta[~np.isfinite(field)] = np.nan
    if periodic:
        right = np.roll(theta, -1, axis=1)
        down = np.roll(theta, -1, axis=0)
        diag = np.roll(right, -1, axis=0)
        here = theta
    else:
        here, right = theta[:-1, :-1], theta[:-1, 1:]
        down, diag = theta[1:, :-1], theta[1:, 1:]
    # counter-clockwise in (x, y): [i,j] -> [i,j+1] -> [i+1,j+1] -> [i+1,j] -> [i,j]
    total = (
        _wrap_angle(right - here, p)
        + _wrap_angle(diag - right, p)
        + _wrap_angle(down - diag, p)
        + _wrap_angle(here - down, p)
    )
    return np.round(total * p / (2.0 * np.pi)) / p


def defects_from_field(field, p, x0=0.0, y0=0.0, spacing=1.0, periodic=False, box=None):
    """Defects of a gridded p-atic field as a table.

    Parameters
    ----------
    field : (ny, nx) complex array
        Field indexed ``[row, col]``; node ``[i, j]`` sits at
        ``x = x0 + j * spacing``, ``y = y0 + i * spacing``.
    p : int
        Symmetry order.
    x0, y0, spacing : float
        Grid origin and spacing, px.
    periodic : bool
        Whether the grid wraps around.
    box : Box, optional
        When given and periodic, defect positions are wrapped into it.

    Returns
    -------
    pandas.DataFrame
        One row per defect: ``defect`` (id), ``x``, ``y`` (plaquette centre,
        px; x = column, y = row), ``charge`` (multiple of 1/p), ``p``.
    """
    charges = plaquette_charges(field, p, periodic=periodic)
    i, j = np.nonzero(np.nan_to_num(charges) != 0)
    xy = np.c_[x0 + (j + 0.5) * spacing, y0 + (i + 0.5) * spacing]
    if box is not None and box.periodic:
        xy = box.wrap(xy)
    return pd.DataFrame(
        {
            "defect": np.arange(len(i), dtype=np.int64),
            "x": xy[:, 0],
            "y": xy[:, 1],
            "charge": charges[i, j],
            "p": np.full(len(i), int(p), dtype=np.int64),
        }
    )
