"""Defects of one orientation field: the winding of its angle around each plaquette (:func:`winding`,
:func:`plaquette_charges`) and the charged plaquettes as a table (:func:`defects_from_field`).
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from ..errors import InputError, check_p


def charge_mask(charge, p):
    """Mask of the defects of elementary charge ``±1/p``."""
    return np.isclose(np.abs(np.asarray(charge, float)), 1.0 / p)


def _wrap_angle(d, p):
    """``d`` wrapped into ``(-pi/p, pi/p]``."""
    period = 2.0 * np.pi / p
    return d - period * np.ceil(d / period - 0.5)


def plaquette_charges(field, p, periodic=False):
    """Winding number of ``Arg(field)/p`` around every plaquette of a grid (or of a stack of grids).

    Parameters
    ----------
    field : (..., ny, nx) complex array
        Field on a regular grid indexed ``[row, col]`` (row = y, col = x);
        leading axes, if any, index independent grids of the same shape.
        NaN nodes make the plaquettes around them NaN.
    p : int
        Symmetry order.
    periodic : bool
        Whether the grid wraps around (a torus); then there are ``ny x nx``
        plaquettes, else ``(ny - 1) x (nx - 1)``.

    Returns
    -------
    (..., ny', nx') float array
        Charge of plaquette ``[i, j]`` (corners ``[i, j]`` to ``[i+1, j+1]``),
        an exact multiple of ``1/p`` (NaN where a corner is NaN).
    """
    field = np.asarray(field)
    if field.ndim < 2 or min(field.shape[-2:]) < 2:
        raise InputError(f"field must be a 2-D grid of at least 2 x 2 nodes; got shape {field.shape}")
    p = check_p(p)
    return winding(_orientation(field, p), p, periodic)


def _orientation(field, p):
    """``Arg(field) / p``, NaN where ``field`` is not finite."""
    theta = np.angle(field) / p
    theta[~np.isfinite(field)] = np.nan
    return theta


def winding(theta, p, periodic):
    """Plaquette charges of orientations ``theta`` (..., ny, nx), radians: the plain-numpy path.

    :func:`plaquette_charges` after the orientation; the reference of the kernel
    ``hexatissue.defects._kernels.plaquette_defects``.
    """
    if periodic:
        right = np.roll(theta, -1, axis=-1)
        down = np.roll(theta, -1, axis=-2)
        diag = np.roll(right, -1, axis=-2)
        here = theta
    else:
        here, right = theta[..., :-1, :-1], theta[..., :-1, 1:]
        down, diag = theta[..., 1:, :-1], theta[..., 1:, 1:]
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
    if box is not None:
        xy = box.wrap(xy)
    return _defect_table(xy, charges[i, j], p)


def _defect_table(xy, charge, p):
    """Defects table from plaquette-centre positions (x, y) and their charges."""
    return pd.DataFrame(
        {
            "defect": np.arange(len(charge), dtype=np.int64),
            "x": xy[:, 0],
            "y": xy[:, 1],
            "charge": charge,
            "p": np.full(len(charge), int(p), dtype=np.int64),
        }
    )
