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

from ..box import Box, as_box
from .._system import release_freed_memory
from ..errors import InputError, check_orders, check_p, check_positive
from ..geometry import match_points
from ..schema import require_columns, rows_by_frame, string_column, validate
from .._dispatch import Kernels
from . import _kernels

K = Kernels(_kernels, "hexatissue.defects._reference")

#: the ``kind`` of a defect event, alphabetical (events carry its index until their table is built)
EVENT_KINDS = ("annihilation", "appearance", "creation", "disappearance")

__all__ = [
    "plaquette_charges",
    "defects_from_field",
    "find_defects",
    "defect_density",
    "track_defects",
    "defect_events",
    "charge_mask",
]


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


# ----------------------------------------------------------------------------
# Defects of a coarse-grained grid table
# ----------------------------------------------------------------------------

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


def _stack_defects(re, im, usable, stacking, positions, count, shape, p, box):
    """Defects of a stack of fields of one shape: field index in the stack, positions and charges."""
    theta = np.arctan2(_stack(im, *stacking, count, shape), _stack(re, *stacking, count, shape))
    theta /= p  # = Arg / p (in place: theta is a new array)
    unusable = ~_stack(usable, *stacking, count, shape, fill=False)
    if unusable.any():
        theta[unusable] = np.nan
    flat, charge = K.plaquette_defects(theta, p, box is not None)
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
    orders = check_orders(p)
    fields = [f"Gamma{q}_{part}" for q in orders for part in ("re", "im")]
    require_columns(grid, ("row", "col", "x", "y", *fields), "grid")
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
                                           q, box)
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


def defect_density(defects, extent, bin_size, time_column="frame", frames=None):
    """Number and charge density of defects on a square-ish grid of bins, per frame.

    Parameters
    ----------
    defects : pandas.DataFrame
        Defects table (``x``, ``y``, ``charge``; ``time_column`` for movies).
    extent : Box or (rows, cols)
        A periodic box spans ``[0, Lx) x [0, Ly)`` (positions are wrapped
        into it); an open image's shape spans ``[-0.5, cols - 0.5) x [-0.5, rows - 0.5)``
        (pixel centres at integer x = column, y = row).
    bin_size : float
        Requested bin side, px; the extent is cut into ``round(L / bin_size)``
        equal bins per axis (at least one).
    time_column : str
        Column giving the frame; when absent from ``defects`` the table is one frame.
    frames : array_like, optional
        Frames to report (frames without defects get zero density).  Default:
        the frames present in ``defects``.

    Returns
    -------
    pandas.DataFrame
        One row per bin and frame: ``frame`` (when ``time_column`` exists or
        ``frames`` is given), ``row``, ``col`` (bin index along y and x),
        ``x``, ``y`` (bin centre, px), ``n_plus``, ``n_minus`` (defects of
        positive and negative charge), ``density`` (``(n_plus + n_minus) /
        bin area``, 1/px^2), ``charge_density`` (sum of charges / bin area,
        1/px^2).  Defects outside the extent are ignored.
    """
    require_columns(defects, ("x", "y", "charge"), "defects")
    if isinstance(extent, Box):
        lo, size = np.zeros(2), extent.lengths
        wrap = extent.wrap
    else:
        if len(extent) != 2 or min(extent) <= 0:
            raise InputError(f"extent must be a Box or an image shape (rows, cols); got {extent!r}")
        lo, size, wrap = np.array([-0.5, -0.5]), np.array([extent[1], extent[0]], float), (lambda xy: xy)
    check_positive(bin_size, "bin_size", unit="px")
    nbins = np.maximum(1, np.round(size / bin_size)).astype(int)
    step = size / nbins
    has_time = time_column in defects.columns
    times = defects[time_column].to_numpy() if has_time else np.zeros(len(defects), np.int64)
    with_frame = has_time or frames is not None
    frames = np.unique(times if frames is None else np.asarray(frames)) if with_frame else np.zeros(1, np.int64)
    xy = wrap(defects[["x", "y"]].to_numpy(float))
    ij = np.floor((xy - lo) / step).astype(np.int64)
    inside = ((ij >= 0) & (ij < nbins)).all(axis=1) & np.isin(times, frames)
    frame_index = np.searchsorted(frames, times)
    charge = defects["charge"].to_numpy(float)
    shape = (len(frames), nbins[1], nbins[0])
    n_plus, n_minus, q = np.zeros(shape), np.zeros(shape), np.zeros(shape)
    at = (frame_index[inside], ij[inside, 1], ij[inside, 0])
    np.add.at(n_plus, at, charge[inside] > 0)
    np.add.at(n_minus, at, charge[inside] < 0)
    np.add.at(q, at, charge[inside])
    f, r, c = np.meshgrid(frames, np.arange(nbins[1]), np.arange(nbins[0]), indexing="ij")
    area = step[0] * step[1]
    out = pd.DataFrame(
        {
            "row": r.ravel().astype(np.int64),
            "col": c.ravel().astype(np.int64),
            "x": lo[0] + (c.ravel() + 0.5) * step[0],
            "y": lo[1] + (r.ravel() + 0.5) * step[1],
            "n_plus": n_plus.ravel().astype(np.int64),
            "n_minus": n_minus.ravel().astype(np.int64),
            "density": (n_plus + n_minus).ravel() / area,
            "charge_density": q.ravel() / area,
        }
    )
    if with_frame:
        out.insert(0, "frame", f.ravel())
    return out


# ----------------------------------------------------------------------------
# Tracking defects across frames
# ----------------------------------------------------------------------------


def _match(a, b, max_distance, box):
    """Optimal one-to-one matching of points ``a`` to ``b`` within ``max_distance``; ``(ia, ib)``."""
    pairs = match_points(a, b, max_distance, box)
    pairs = pairs[np.argsort(pairs[:, 0], kind="stable")]  # in the order of a
    return pairs[:, 0].astype(np.int64), pairs[:, 1].astype(np.int64)


def _charge_keys(charge):
    """Integer keys identifying equal charges (robust to float round-off)."""
    return np.round(np.asarray(charge, float) * 7_207_200).astype(np.int64)  # lcm(1..16) * 10


def _frame_sequence(times, frames):
    """Sorted frames to link consecutively; defects in frames not listed are an error."""
    present = np.unique(times)
    if frames is None:
        return present
    frames = np.unique(np.asarray(frames))
    if not np.isin(present, frames).all():
        raise InputError("frames must list every frame present in the defects table")
    return frames


def track_defects(defects, max_distance, box=None, time_column="frame", frames=None):
    """Link defects across consecutive frames into tracks.

    Between each pair of consecutive frames, defects of the same charge are
    matched one to one by optimal assignment
    (:func:`scipy.optimize.linear_sum_assignment`): among the matchings that
    link the most defects with every link shorter than ``max_distance``, the
    one of least total distance.  Distances are minimum-image in a periodic
    ``box``.  Defects left unmatched start (or end) a track, which is how
    pair creation and annihilation show up (see :func:`defect_events`).

    Parameters
    ----------
    defects : pandas.DataFrame
        Defects table with columns ``time_column``, ``x``, ``y`` (px; x =
        column, y = row, origin at the centre of pixel (0, 0)) and ``charge``.
    max_distance : float
        Largest displacement of a defect between consecutive frames, px.
    box : Box, optional
        Periodic box for minimum-image distances; None (or a non-periodic
        box) for an open image.
    time_column : str
        Column giving the time point (default ``"frame"``).
    frames : array_like, optional
        Every time point of the movie, including those without defects.
        Consecutive entries are linked; by default the sorted distinct values
        of ``time_column`` are (so a frame without any defect would be
        skipped over; pass ``frames`` to break tracks there).

    Returns
    -------
    pandas.DataFrame
        A copy of ``defects`` (same rows, same order) with an added ``track``
        column (int64): tracks are numbered from 0 in order of their first
        frame, then of row order.
    """
    require_columns(defects, (time_column, "x", "y", "charge"), "defects")
    box = as_box(box)
    check_positive(max_distance, "max_distance", unit="px")
    times = defects[time_column].to_numpy()
    xy = defects[["x", "y"]].to_numpy(float)
    keys = _charge_keys(defects["charge"].to_numpy(float))
    sequence = _frame_sequence(times, frames)
    track = np.full(len(defects), -1, np.int64)
    rows_of = rows_by_frame(times)
    empty = np.zeros(0, np.int64)
    previous = empty
    next_id = 0
    for t in sequence:
        current = rows_of.get(t, empty)
        for key in np.unique(keys[current]):
            cur = current[keys[current] == key]
            prev = previous[keys[previous] == key]
            ia, ib = _match(xy[prev], xy[cur], max_distance, box)
            track[cur[ib]] = track[prev[ia]]
        new = current[track[current] < 0]
        track[new] = np.arange(next_id, next_id + len(new))
        next_id += len(new)
        previous = current
    return defects.assign(track=track)  # a new table sharing the given columns until either is modified


def _track_ends(tracked, time_column, first):
    """One row per track: its first (``first=True``) or last frame, position and charge.

    The rows of ``tracked`` (index kept) in the order of a stable sort by
    time.  Found from one argsort of the time column, not a sorted copy of
    the table and a groupby (several copies of its columns on a movie's
    defects).
    """
    order = np.argsort(tracked[time_column].to_numpy(), kind="stable")
    track = tracked["track"].to_numpy()[order]
    if first:
        at = np.unique(track, return_index=True)[1]
    else:
        at = len(track) - 1 - np.unique(track[::-1], return_index=True)[1]
    return tracked.iloc[order[np.sort(at)]]


def _pair_ends(xy, charge, pair_distance, box):
    """Positions in one frame's ends: positive matched to negative (charges cancelling) within ``pair_distance``."""
    keys = _charge_keys(charge)
    ia, ib = [np.zeros(0, np.int64)], [np.zeros(0, np.int64)]
    for key in np.unique(keys[keys > 0]):  # each charge q pairs with -q only: independent matchings
        pos, neg = np.flatnonzero(keys == key), np.flatnonzero(keys == -key)
        i, j = _match(xy[pos], xy[neg], pair_distance, box)
        ia.append(pos[i])
        ib.append(neg[j])
    ia, ib = np.concatenate(ia), np.concatenate(ib)
    order = np.argsort(ia, kind="stable")  # in row order of the positive ends
    return ia[order], ib[order]


def defect_events(tracked, pair_distance, box=None, time_column="frame", include_unpaired=False, frames=None):
    """Creation and annihilation of +- defect pairs from tracked defects.

    A track that starts after the first frame of the movie is a birth and one
    that ends before the last frame is a death.  In each frame, births are
    paired (positive with negative, charges summing to zero, within
    ``pair_distance``) by optimal assignment into *creation* events, and
    deaths likewise into *annihilation* events.  Births and deaths without a
    partner (a defect entering or leaving an open image, or a linking
    failure) are ``appearance`` / ``disappearance`` events, reported only if
    ``include_unpaired``.

    Parameters
    ----------
    tracked : pandas.DataFrame
        Output of :func:`track_defects` (columns ``time_column``, ``x``,
        ``y``, ``charge``, ``track``).
    pair_distance : float
        Largest separation of the two partners, px (typically the
        ``max_distance`` used for tracking, or a few grid spacings).
    box : Box, optional
        Periodic box for minimum-image distances and midpoints.
    time_column : str
        Column giving the time point.
    include_unpaired : bool
        Also report unpaired births and deaths.
    frames : array_like, optional
        Every time point of the movie.  Only its first and last entries
        matter: tracks starting at the first or ending at the last frame are
        not events.  Default: the first and last frames present in
        ``tracked`` (so a pair annihilating just before a final frame without
        any defect would be missed; pass ``frames`` to catch it).

    Returns
    -------
    pandas.DataFrame
        One row per event, sorted by time: ``time_column`` (for a creation:
        the first frame in which the pair exists; for an annihilation: the
        last frame in which it exists), ``kind`` (``"creation"``,
        ``"annihilation"``, and if requested ``"appearance"``,
        ``"disappearance"``), ``x``, ``y`` (px: pair midpoint, minimum image,
        wrapped into a periodic box; the defect itself for unpaired events),
        ``track_plus``, ``track_minus`` (track ids of the positive and
        negative partners; -1 when absent), ``separation`` (px, distance
        between the partners; NaN when unpaired).
    """
    require_columns(tracked, (time_column, "x", "y", "charge", "track"), "tracked")
    box = as_box(box)
    check_positive(pair_distance, "pair_distance", unit="px")
    columns = [time_column, "kind", "x", "y", "track_plus", "track_minus", "separation"]
    if len(tracked) == 0:
        return _empty_events(columns, time_column)
    span = tracked[time_column].to_numpy() if frames is None else np.asarray(frames)
    if len(span) == 0:
        raise InputError("frames must list at least one time point")
    t_first, t_last = span.min(), span.max()
    parts = []  # the columns of each frame's events of each kind: arrays, not a Python tuple per event
    codes = {name: code for code, name in enumerate(EVENT_KINDS)}
    for first, kind, lone in ((True, codes["creation"], codes["appearance"]),
                              (False, codes["annihilation"], codes["disappearance"])):
        ends = _track_ends(tracked, time_column, first).reset_index(drop=True)
        ends = ends[ends[time_column] != (t_first if first else t_last)]
        times = ends[time_column].to_numpy()
        xy = ends[["x", "y"]].to_numpy(float)
        charge, track = ends["charge"].to_numpy(float), ends["track"].to_numpy(np.int64)
        for at in rows_by_frame(times).values():  # one frame's births (or deaths) at a time, as arrays
            ip, ineg = _pair_ends(xy[at], charge[at], pair_distance, box)
            parts.append(_pair_rows(xy[at], track[at], ip, ineg, times[at[0]], kind, box))
            if include_unpaired:
                alone = np.setdiff1d(np.arange(len(at)), np.r_[ip, ineg])
                parts.append(_lone_rows(xy[at][alone], charge[at][alone], track[at][alone], times[at[0]], lone))
    if not sum(len(part[0]) for part in parts):
        return _empty_events(columns, time_column)
    cols = {c: np.concatenate([part[k] for part in parts]) for k, c in enumerate(columns)}
    # by time, kind (its codes sort as the names do), x, y: a numpy sort, and the names made a column once, in order
    order = np.lexsort((cols["y"], cols["x"], cols["kind"], cols[time_column]))
    cols = {c: v[order] for c, v in cols.items()}
    cols["kind"] = string_column(cols["kind"], EVENT_KINDS)
    out = pd.DataFrame(cols, copy=False)
    return validate(out, "defect_events") if time_column == "frame" else out


def _event_columns(t, kind, x, y, track_plus, track_minus, separation):
    """One frame's events of one kind as the columns of :func:`defect_events` (``t`` and the :data:`EVENT_KINDS`
    code ``kind`` repeated)."""
    return (np.full(len(x), t), np.full(len(x), kind, np.int8), x, y, track_plus, track_minus, separation)


def _pair_rows(xy, track, ip, ineg, t, kind, box):
    d = xy[ineg] - xy[ip]
    if box is not None:
        d = box.min_image(d)
    mid = xy[ip] + d / 2
    if box is not None:
        mid = box.wrap(mid)
    return _event_columns(t, kind, mid[:, 0], mid[:, 1], track[ip], track[ineg], np.hypot(d[:, 0], d[:, 1]))


def _lone_rows(xy, charge, track, t, kind):
    plus = charge > 0
    return _event_columns(t, kind, xy[:, 0], xy[:, 1], np.where(plus, track, -1), np.where(plus, -1, track),
                          np.full(len(xy), np.nan))


def _empty_events(columns, time_column):
    out = pd.DataFrame({c: pd.Series(dtype=float) for c in columns})
    out["kind"] = out["kind"].astype("string")
    for c in ("track_plus", "track_minus"):
        out[c] = out[c].astype(np.int64)
    return out


#: Default largest defect displacement between frames, in grid spacings (:func:`link_movie_defects`).
DEFECT_SPACINGS = 1.5


def link_movie_defects(tables, orders, max_distance=None, box=None, n_frames=0, linked=True):
    """Link ``tables["defects"]`` over frames per p (``track``); add their pair events as ``tables["defect_events"]``.

    ``tables`` holds a movie's ``grid`` and ``defects`` (every frame, every
    p); ``orders`` the p to keep; ``max_distance`` the largest displacement
    of a defect between frames, px (None: :data:`DEFECT_SPACINGS` grid
    spacings); ``n_frames`` the movie's frames.  With ``linked`` False
    (frames that are unrelated images) every frame is tracked alone: each
    defect is its own track and there are no pair events.  The tables come
    in a dict so that the untracked defects are freed column
    by column as the tracked table is built (an argument would stay
    referenced by the caller for the whole call); tracking reads a copy of
    four columns of each p, not of the whole table.
    """
    defects, grid = tables.pop("defects"), tables["grid"]

    groups = [np.arange(n_frames)] if linked else [np.array([t]) for t in range(n_frames)]
    if max_distance is None:
        spacing = grid["spacing"].to_numpy(float)
        max_distance = DEFECT_SPACINGS * float(np.median(spacing)) if len(spacing) else 1.0
        release_freed_memory()  # np.median's sorted copy of the grid column would stay resident under the tracking
    p = defects["p"].to_numpy()
    track = np.zeros(len(defects), np.int64)
    pair_events = []
    for q in orders:
        rows = np.flatnonzero(p == q)
        # only the columns tracking reads, not a copy of the table per p
        of_p = pd.DataFrame({c: defects[c].to_numpy()[rows] for c in ("frame", "x", "y", "charge")})
        rows_of = None if linked else rows_by_frame(of_p["frame"].to_numpy())  # not one scan per frame
        n_tracks = 0
        for frames in groups:
            at = slice(None) if linked else rows_of.get(int(frames[0]), np.zeros(0, np.int64))
            t = track_defects(of_p if linked else of_p.iloc[at], max_distance, box=box, frames=frames)
            t["track"] += n_tracks
            n_tracks = int(t["track"].max()) + 1 if len(t) else n_tracks
            track[rows[at]] = t["track"].to_numpy()
            pair_events.append(defect_events(t, max_distance, box=box, frames=frames).assign(p=np.int64(q)))
            del t
        del of_p, rows_of
        release_freed_memory()  # tracking and pairing leave freed memory resident under the next p
    # the rows of every p, by frame, p and defect (a stable sort), taken one column at a time from the
    # table given away: at most one column more than the defects table in memory
    rows = np.lexsort((defects["defect"].to_numpy(), p, defects["frame"].to_numpy()))
    rows = rows[np.isin(p[rows], orders)]
    del p
    columns = {c: defects.pop(c).to_numpy()[rows] for c in list(defects.columns) if c != "track"}
    del defects
    columns["track"] = track[rows]
    pair_events = pd.concat(pair_events, ignore_index=True)
    tables["defects"] = validate(pd.DataFrame(columns, copy=False), "defects")
    tables["defect_events"] = validate(pair_events.astype({"frame": np.int64}), "defect_events")
