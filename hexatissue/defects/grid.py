"""Defects of a coarse-grained grid table (:func:`find_defects`): the grids of every frame and p stacked by
layout, their charged plaquettes found at once.
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from ..box import as_box
from ..errors import InputError, check_orders
from ..schema import require_columns, validate
from .._dispatch import Kernels
from . import _kernels


K = Kernels(_kernels, "hexatissue.defects._reference")


def _group_rows(grid):
    """Rows of each (frame, radius) field of a grid table, and whether a frame holds several radii.

    Returns ``(groups, multi)`` with ``groups`` a list of ``(frame, radius, rows)`` sorted by frame
    then radius (``radius`` NaN when the grid has no ``radius`` column).
    """
    frame = grid["frame"].to_numpy() if "frame" in grid.columns else np.zeros(len(grid), np.int64)
    radius = grid["radius"].to_numpy(float) if "radius" in grid.columns else np.full(len(grid), np.nan)
    # fast path: every field a contiguous run of rows (as coarse_grain writes them)
    change = np.flatnonzero((frame[1:] != frame[:-1]) | ~((radius[1:] == radius[:-1]) | np.isnan(radius[1:])))
    bounds = np.r_[0, change + 1, len(grid)]
    runs = [(frame[b0], radius[b0], b0, b1) for b0, b1 in zip(bounds[:-1], bounds[1:])]
    keys = [(f, r) for f, r, _, _ in runs]
    if len(set(keys)) == len(keys):
        runs.sort(key=lambda run: (run[0], run[1]))
        groups = [(f, r, np.arange(b0, b1)) for f, r, b0, b1 in runs]
    else:
        f_code, f_values = pd.factorize(frame, sort=True)
        r_code, r_values = pd.factorize(radius, sort=True, use_na_sentinel=False)
        key = f_code.astype(np.int64) * len(r_values) + r_code
        order = np.argsort(key, kind="stable")
        present, first = np.unique(key[order], return_index=True)
        cuts = np.r_[first, len(order)]
        groups = [(f_values[k // len(r_values)], r_values[k % len(r_values)], order[cuts[g]:cuts[g + 1]])
                  for g, k in enumerate(present)]
    frames = [f for f, _, _ in groups]
    multi = len(set(frames)) < len(frames)
    return groups, multi


def _field_layouts(row, col, groups):
    """Shape of every field of ``groups`` and where its rows are; every node exactly once per field.

    Returns ``(shapes, rows, cuts, block)``: ``shapes`` (n_fields, 2) ``(ny, nx)``, the rows of every
    field back to back (field ``g`` is ``rows[cuts[g]:cuts[g + 1]]``) and whether each field is a
    block of consecutive rows in node order (:func:`hexatissue.defects._kernels.field_layouts`).
    """
    rows = np.concatenate([r for _, _, r in groups])
    cuts = np.r_[0, np.cumsum([len(r) for _, _, r in groups])]
    shapes, once, block = K.field_layouts(row, col, rows, cuts)
    bad = np.flatnonzero(~once | (shapes.min(axis=1) < 2))
    if len(bad):
        ny, nx = shapes[bad[0]]
        if not once[bad[0]]:
            raise InputError(f"grid must hold every node of a {ny} x {nx} grid exactly once per frame (and radius)")
        raise InputError(f"grid must have at least 2 x 2 nodes; got {ny} x {nx}")
    return shapes, rows, cuts, block


def _stacking(layouts, members, shape, row, col):
    """Rows of the grid table and their flat positions in a ``(len(members), ny, nx)`` stack of fields.

    ``members`` are the fields of that shape, ascending.  ``(start, None)`` when the stack is rows
    ``start ..`` in table order (no reordering needed).
    """
    shapes, rows, cuts, block = layouts
    n = shape[0] * shape[1]
    first = rows[cuts[members]]
    if block[members].all() and np.array_equal(first, first[0] + n * np.arange(len(members))):
        return int(first[0]), None
    source = rows if len(members) == len(shapes) else np.concatenate([rows[cuts[g]:cuts[g + 1]] for g in members])
    target = np.repeat(n * np.arange(len(members)), n) + row[source] * shape[1] + col[source]
    return source, target


def _stack(values, source, target, count, shape, fill=np.nan):
    if target is None:  # the stack is a block of consecutive rows
        return values[source:source + count * shape[0] * shape[1]].reshape(count, *shape)
    out = np.full(count * shape[0] * shape[1], fill, dtype=values.dtype)
    out[target] = values[source]
    return out.reshape(count, *shape)


def _stack_positions(x, y, stacking, count, shape, box):
    """Node positions ``(gx, gy)`` of a stack of fields and each field's steps ``(dx, dy)``."""
    gx, gy = _stack(x, *stacking, count, shape), _stack(y, *stacking, count, shape)
    dx = (gx[:, 0, -1] - gx[:, 0, 0]) / (shape[1] - 1)
    dy = (gy[:, -1, 0] - gy[:, 0, 0]) / (shape[0] - 1)
    if box is not None and not (np.allclose(dx * shape[1], box.Lx, rtol=1e-9)
                                and np.allclose(dy * shape[0], box.Ly, rtol=1e-9)):
        raise InputError(f"grid does not tile the periodic box {box}: build it with coarse_grain(..., box=box) "
                         "or pass box=None for an open image")
    return gx, gy, dx, dy


def _stack_defects(re, im, usable, stacking, positions, count, shape, p, box, plaquettes=None):
    """Defects of a stack of fields of one shape: field index in the stack, positions and charges.

    ``plaquettes(theta, p, periodic, stacking, count, shape)``, when given, finds the charged
    plaquettes instead of the flat kernel (the surface's, with the connection between node frames).
    """
    theta = np.arctan2(_stack(im, *stacking, count, shape), _stack(re, *stacking, count, shape))
    theta /= p  # = Arg / p (in place: theta is a new array)
    unusable = ~_stack(usable, *stacking, count, shape, fill=False)
    if unusable.any():
        theta[unusable] = np.nan
    if plaquettes is None:
        flat, charge = K.plaquette_defects(theta, p, box is not None)
    else:
        flat, charge = plaquettes(theta, p, box is not None, stacking, count, shape)
    g, i, j = np.unravel_index(flat, (count, *shape) if box is not None else (count, shape[0] - 1, shape[1] - 1))
    gx, gy, dx, dy = positions
    # plaquette [i, j] spans nodes [i, j] .. [i+1, j+1]; its centre is half a step from node [i, j]
    xy = np.c_[gx[g, i, j] + dx[g] / 2, gy[g, i, j] + dy[g] / 2]
    if box is not None:
        xy = box.wrap(xy)
    return g, xy, charge


def find_defects(grid, p=6, box=None):
    """Topological defects of a coarse-grained p-atic field.

    The charge of every grid plaquette is the winding number of
    ``theta = Arg(Gamma_p) / p`` around it, ``s = (1/2 pi) sum dtheta`` with
    each ``dtheta`` wrapped into ``(-pi/p, pi/p]`` (:func:`plaquette_charges`);
    plaquettes with nonzero ``s`` are defects.  Plaquettes touching an
    invalid node (``valid`` False, e.g. near the edge of an open image) are
    skipped.  In a periodic box the grid wraps around and the charges of a
    fully valid grid sum to zero.

    Parameters
    ----------
    grid : pandas.DataFrame
        Grid table from :func:`hexatissue.coarse_grain` (columns ``row``,
        ``col``, ``x``, ``y``, ``Gamma{p}_re``, ``Gamma{p}_im``; optional
        ``valid``, ``frame`` and ``radius``).  A grid with several radii per
        frame gives the defects of every radius.
    p : int or sequence of int
        Symmetry order(s).
    box : Box, optional
        The periodic box the grid was built in (None for open images).

    Returns
    -------
    pandas.DataFrame
        Defects table, one row per defect, ordered by ``p`` (as given),
        frame, radius: ``frame`` (0 for a grid without one), ``radius`` (R,
        px; only when a frame of ``grid`` holds several radii), ``defect``
        (id, 0-based per frame, p and radius), ``x``, ``y`` (plaquette
        centre, px; x = column, y = row, origin at the centre of pixel (0,
        0)), ``charge`` (a nonzero multiple of ``1/p``), ``p``.
    """
    return grid_defects(grid, p, box)


def grid_defects(grid, p=6, box=None, plaquettes=None, columns=()):
    """:func:`find_defects` with another finder of the charged plaquettes (``plaquettes``, see
    :func:`_stack_defects`; None: the flat winding) that needs the grid's ``columns`` too."""
    orders = check_orders(p)
    fields = [f"Gamma{q}_{part}" for q in orders for part in ("re", "im")]
    require_columns(grid, ("row", "col", "x", "y", *fields, *columns), "grid")
    if len(grid) == 0:
        raise InputError("grid is empty; expected the nodes of at least a 2 x 2 grid")
    box = as_box(box)
    frame_dtype = grid["frame"].dtype if "frame" in grid.columns else np.dtype(np.int64)
    groups, multi = _group_rows(grid)
    row, col = grid["row"].to_numpy(np.int64), grid["col"].to_numpy(np.int64)
    x, y = grid["x"].to_numpy(float), grid["y"].to_numpy(float)
    valid = grid["valid"].to_numpy(bool) if "valid" in grid.columns else None
    layouts = _field_layouts(row, col, groups)
    shapes = {}
    for g, shape in enumerate(map(tuple, layouts[0].tolist())):
        shapes.setdefault(shape, []).append(g)
    stackings = {shape: _stacking(layouts, np.asarray(members), shape, row, col) for shape, members in shapes.items()}
    positions = {shape: _stack_positions(x, y, stackings[shape], len(members), shape, box)
                 for shape, members in shapes.items()}
    found = {"group": [], "rank": [], "x": [], "y": [], "charge": []}
    for rank, q in enumerate(orders):
        re, im = grid[f"Gamma{q}_re"].to_numpy(float), grid[f"Gamma{q}_im"].to_numpy(float)
        usable = np.isfinite(re) & np.isfinite(im)
        if valid is not None:
            usable &= valid
        for shape, members in shapes.items():
            g, xy, charge = _stack_defects(re, im, usable, stackings[shape], positions[shape], len(members), shape,
                                           q, box, plaquettes)
            for name, value in (("group", np.asarray(members)[g]), ("rank", np.full(len(g), rank)),
                                ("x", xy[:, 0]), ("y", xy[:, 1]), ("charge", charge)):
                found[name].append(value)
    found = {name: np.concatenate(value) for name, value in found.items()}
    # rows ordered by p (as given), frame, radius, then plaquette (row-major; lexsort is stable);
    # with one shape of field they come out of the loop in that order already
    key = found["rank"] * len(groups) + found["group"]
    if (key[1:] < key[:-1]).any():
        order = np.lexsort((found["group"], found["rank"]))
        found = {name: value[order] for name, value in found.items()}
    group, rank = found["group"], found["rank"]
    # defect ids: 0-based per (p, frame, radius)
    cut = np.r_[0, np.flatnonzero((np.diff(group) != 0) | (np.diff(rank) != 0)) + 1]
    ids = np.arange(len(group)) - np.repeat(cut, np.diff(np.r_[cut, len(group)]))
    frames = np.array([frame for frame, _, _ in groups], dtype=frame_dtype)
    radii = np.array([radius for _, radius, _ in groups], dtype=float)
    out = pd.DataFrame({"frame": frames[group], "radius": radii[group], "defect": ids.astype(np.int64),
                        "x": found["x"], "y": found["y"], "charge": found["charge"],
                        "p": np.asarray(orders, np.int64)[rank]}, copy=False)  # (new arrays: nothing to copy)
    if not multi:
        out = out.drop(columns="radius")
    return validate(out, "defects")
