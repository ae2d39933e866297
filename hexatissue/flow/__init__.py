"""Tissue flow: cell velocities, velocity-gradient fields on the Gamma_p grid, and their statistics.

- :func:`cell_velocities`: every tracked cell's velocity by centred differences in time;
- :func:`flow_fields`: velocity, vorticity, divergence and strain rate on the nodes of the
  coarse-grained order field (:func:`hexatissue.coarse_grain`), from a least-squares affine fit
  to the cells within each node's disk;
- :func:`surface_velocities`, :func:`surface_flow_fields` (:mod:`hexatissue.flow.surface`): on a height
  map's surface, each cell's 3-D velocity in its tangent frame (and its normal velocity), and the surface
  divergence, vorticity, rate of strain, mean curvature and areal rate on the grid of the surface field;
- :func:`velocity_statistics`, :func:`velocity_correlation`, :func:`mean_squared_displacement`,
  :func:`flow_summary` (:mod:`hexatissue.flow.statistics`): mean speed, polar order, spatial velocity
  correlation and its length, MSD and its exponent;
- :func:`t1_flow`, :func:`defect_flow`, :func:`angular_harmonics` (:mod:`hexatissue.flow.centred`):
  the flow averaged around T1 events and around ±1/p defects in their own axes, and its angular
  harmonics.

Tables stay in px and frames (velocities in px/frame, rates in 1/frame); :func:`velocity_unit`
and :func:`in_units` give them in a calibration's units (µm/min) for figures and reports.
Positions are (x, y) = (column, row), so y grows downwards: a positive vorticity
``dvy/dx - dvx/dy`` turns clockwise on the image as displayed.
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from ..box import as_box
from ..errors import check_positive
from ..schema import interior_mask, require_columns, validate
from ..units import in_units, velocity_unit  # the flow's units (defined with the calibration), kept in its API
from ._grid import check_min_cells, grid_fits
from .surface import area_rates, surface_flow_fields, surface_velocities
from .centred import angular_harmonics, defect_flow, t1_flow
from .statistics import (MIN_BIN_PAIRS, SPARSE_BIN, CorrelationLength, _centred_rows, cell_spacing, correlation_length,
                         flow_summary, mean_squared_displacement, msd_exponent, reliable_bins, rms_step,
                         velocity_correlation, velocity_statistics)

__all__ = ["cell_velocities", "flow_fields", "surface_velocities", "surface_flow_fields", "area_rates",
           "velocity_statistics", "velocity_correlation", "correlation_length",
           "mean_squared_displacement", "msd_exponent", "flow_summary", "velocity_unit", "in_units", "MIN_CELLS",
           "t1_flow", "defect_flow", "angular_harmonics", "reliable_bins", "SPARSE_BIN", "MIN_BIN_PAIRS", "CorrelationLength",
           "rms_step", "cell_spacing"]

#: Fewest cells an affine fit takes (three non-collinear points fix a 2-D affine map).
MIN_CELLS = 3


def cell_velocities(cells, box=None):
    """Velocity of every cell, px/frame, by centred differences along its track.

    ``v(t) = (r(t + 1) - r(t - 1)) / 2`` of the cell's centroid ``r = (x, y)``
    (minimum image in a periodic box), for a cell whose track is present in
    both frames ``t - 1`` and ``t + 1``.  A track starts at a division and
    ends at one (the daughters are new tracks), so the velocity is NaN on the
    first and last frame of every track (movie ends, divisions, cells
    entering or leaving the field of view) and beside a gap closed by the
    tracker (a missing neighbouring frame).  Untracked frames (tracking
    ``off``: every cell its own track) have no velocities.

    Parameters
    ----------
    cells : pandas.DataFrame
        Cells table: ``frame``, ``x``, ``y`` (px) and ``track`` (or ``cell``,
        whose ids are then the tracks).
    box : Box, optional
        Periodic box (minimum-image displacements); None for an open image.

    Returns
    -------
    vx, vy : numpy.ndarray of float
        Velocity along x (columns) and y (rows) of every row of ``cells``, in
        row order, px/frame (NaN where undefined, see above).
    """
    box = as_box(box)
    order, xy, inner = _centred_rows(cells)
    v = np.full((len(xy), 2), np.nan)
    d = xy[inner + 1] - xy[inner - 1]
    v[inner] = 0.5 * (d if box is None else box.min_image(d))
    out = np.empty_like(v)
    out[order] = v
    return out[:, 0].copy(), out[:, 1].copy()


def flow_fields(cells, grid, box=None, radius_factor=2.0, min_cells=MIN_CELLS):
    """Velocity, vorticity, divergence and strain rate on the nodes of a coarse-grained grid.

    For every node, the velocities ``v`` of the cells within a disk of radius
    ``radius_factor x`` the node's coarse-graining radius (centroid distance,
    minimum image in a periodic box) are fitted by least squares, with equal
    weights (the coarse-grained order field weighs the cells of its disk
    equally), by the affine field ``v(r) = v0 + L (r - r_node)``;
    ``L_ij = d v_i / d x_j`` is the velocity gradient.  Border cells do not
    enter the fits (their centroids move as they are cut by the image edge),
    as they do not enter Gamma_p.

    The default disk (twice the order field's, 3 R_cell) holds ~9 cells: the
    order field's own disk of 1.5 R_cell holds 2.25 cells on average, too few
    for a gradient at most nodes.

    Parameters
    ----------
    cells : pandas.DataFrame
        Cells table with ``frame``, ``x``, ``y`` (px), ``vx``, ``vy``
        (px/frame, e.g. from :func:`cell_velocities`; NaN rows are left out)
        and optionally ``is_border``.
    grid : pandas.DataFrame
        Grid table of :func:`hexatissue.coarse_grain`: ``frame``, ``node``,
        ``x``, ``y``, ``radius`` (px), ``valid``.
    box : Box, optional
        Periodic box; None for an open image.
    radius_factor : float
        Disk radius of the fits in units of the grid's ``radius``.
    min_cells : int
        Fewest cells a fit takes (at least 3).  A fit also needs its cells
        spread across the disk: their root-mean-square distance from their
        mean, in the narrowest direction, at least
        ``hexatissue.flow._kernels.MIN_SPREAD`` (0.1) x the radius.

    Returns
    -------
    pandas.DataFrame
        The ``flow`` table, one row per row of ``grid``, in its order:
        ``frame``, ``node`` (the grid's), ``x``, ``y`` (node position, px),
        ``radius`` (disk radius of the fit, px), ``vx``, ``vy`` (fitted
        velocity at the node, px/frame), ``vorticity`` (``dvy/dx - dvx/dy``,
        1/frame; positive is clockwise on the displayed image, whose y axis
        points down), ``divergence`` (``dvx/dx + dvy/dy``, 1/frame),
        ``strain_xx`` (``(dvx/dx - dvy/dy) / 2``, 1/frame), ``strain_xy``
        (``(dvx/dy + dvy/dx) / 2``, 1/frame; the traceless symmetric strain
        rate is ``[[strain_xx, strain_xy], [strain_xy, -strain_xx]]``; with
        the vorticity and the divergence they give the whole gradient,
        ``dvx/dy = strain_xy - vorticity / 2``, ...), ``n_cells`` (cells with a
        velocity in the disk) and ``valid`` (the grid node is valid and the fit
        exists).  Fields are NaN where there is no fit.
    """
    require_columns(cells, ["frame", "x", "y", "vx", "vy"], "cells")
    require_columns(grid, ["frame", "node", "x", "y", "radius", "valid"], "grid")
    box = as_box(box)
    radius_factor = check_positive(radius_factor, "radius_factor")
    min_cells = check_min_cells(min_cells)
    xy = cells[["x", "y"]].to_numpy(float)
    uv = cells[["vx", "vy"]].to_numpy(float)
    use = interior_mask(cells) & np.isfinite(xy).all(axis=1) & np.isfinite(uv).all(axis=1)
    g_frame = grid["frame"].to_numpy(np.int64)
    names = ["x", "y", "radius", "vx", "vy", "vorticity", "divergence", "strain_xx", "strain_xy"]
    # one float block whose rows are the columns (as coarse_grain's grid): no copy into the DataFrame
    block = np.empty((len(names), len(grid)))
    columns = dict(zip(names, block))
    columns["x"][:], columns["y"][:] = grid["x"].to_numpy(float), grid["y"].to_numpy(float)
    np.multiply(grid["radius"].to_numpy(float), radius_factor, out=columns["radius"])
    (u, v), counts = grid_fits(xy[use], cells["frame"].to_numpy(np.int64)[use], uv[use], g_frame, block[:2].T,
                               columns["radius"], box, min_cells)
    (v0x, lxx, lxy), (v0y, lyx, lyy) = u, v
    columns["vx"][:], columns["vy"][:] = v0x, v0y
    np.subtract(lyx, lxy, out=columns["vorticity"])
    np.add(lxx, lyy, out=columns["divergence"])
    np.multiply(np.subtract(lxx, lyy, out=columns["strain_xx"]), 0.5, out=columns["strain_xx"])
    np.multiply(np.add(lxy, lyx, out=columns["strain_xy"]), 0.5, out=columns["strain_xy"])
    valid = grid["valid"].to_numpy(bool) & np.isfinite(lxx)
    table = pd.DataFrame({"frame": g_frame, "node": grid["node"].to_numpy(np.int64), **columns, "n_cells": counts,
                          "valid": valid}, copy=False)
    return validate(table, "flow")
