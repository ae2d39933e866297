"""Longitudinal p-atic stress of the cells of a multiphase-field configuration.

Works on the simulator's per-cell phase-field patches (``run.patches``);
lattice indices ``[cell, row, col]`` with row = y and col = x.
"""
from __future__ import annotations

import numpy as np

from ..errors import InputError, check_p, check_positive

__all__ = ["cell_stress"]


def cell_stress(phi, theta, k_phi, p, dx=1.0):
    """Longitudinal p-atic stress of every cell of a multiphase-field (MPF) configuration ::

        sigma_par = -k_phi sum_r |grad phi_c|^p cos(p (alpha(r) - theta_c)),

    with ``alpha`` the direction of ``grad phi_c`` at lattice site ``r`` and
    ``theta_c`` the cell's p-fold orientation.  This is the complex form of
    ``-k_phi sum_r (grad phi_c)^{(x)p} : n_c^{(x)p}`` with both tensors
    reduced to their symmetric traceless part and rescaled by ``2^(p-1)``
    (the full contraction of the traceless parts is ``2^(1-p)`` times this
    value).  For p = 2 and a cell elongated along ``theta_c`` it is positive:
    the interface gradients are steepest across the long axis.

    Parameters
    ----------
    phi : (n_cells, P, P) float array
        Per-cell phase-field patches, indexed ``[cell, row, col]`` (row = y,
        col = x), as saved by the MPF simulator: each patch holds one cell's
        field ``phi_c`` on a P x P window of the lattice (any origin; the
        result does not depend on it) that contains the whole cell, with
        ``phi_c -> 0`` at the patch edge.  Gradients are second-order central
        differences (one-sided at the patch edge).
    theta : (n_cells,) float array
        Orientation ``theta_c`` of each cell, rad, measured from +x towards
        +y (e.g. ``np.angle(gamma_p) / p``).
    k_phi : float
        Interface stiffness ``k_phi`` of the MPF free energy.
    p : int
        Symmetry order (2 nematic, 6 hexatic).
    dx : float
        Lattice spacing (gradients are per unit ``dx``).

    Returns
    -------
    (n_cells,) float array
        ``sigma_par`` per cell, in units of ``k_phi * [phi]^p / dx^p`` (a sum
        over lattice sites, not an average).
    """
    p = check_p(p)
    phi = np.asarray(phi, dtype=float)
    theta = np.asarray(theta, dtype=float)
    if phi.ndim != 3 or phi.shape[1] < 3 or phi.shape[2] < 3:
        raise InputError(f"phi must be an (n_cells, P, P) array of patches with P >= 3; got shape {phi.shape}")
    if theta.shape != (phi.shape[0],):
        raise InputError(f"theta must hold one angle per cell, shape ({phi.shape[0]},); got {theta.shape}")
    if not np.isfinite(k_phi):
        raise InputError(f"k_phi must be a finite number; got {k_phi!r}")
    check_positive(dx, "dx")
    grad_y, grad_x = np.gradient(phi, dx, axis=(1, 2))
    # |grad phi|^p cos(p (alpha - theta)) = Re[(phi_x + i phi_y)^p e^{-i p theta}]
    moment = ((grad_x + 1j * grad_y) ** p).sum(axis=(1, 2))
    return -k_phi * np.real(moment * np.exp(-1j * p * theta))
