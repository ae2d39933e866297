"""A port, used only for comparison, of the published coarse-graining and defect rules.

Armengol-Collado et al., *Epithelia are multiscale active liquid crystals*, Nature Physics (2023)
published pure-Python scripts (GitHub ``livioNcarenza/hexanematic``, commit 5a60fbe:
``coarse_graining.py`` and ``plot_hexatics.py`` / ``plot_nematics.py``).  This module is not
their code and is not part of hexatissue: it was written for this benchmark from a reading of
those scripts, and follows their algorithm and its loop structure (every radius, every node,
every cell, in plain Python), so that its timing stands for theirs and its results can be
checked against hexatissue on the same nodes and radii.

The rules it follows (script:line at that commit):

- R_cell is one fixed value for every image, 21.5 px (coarse_graining.py:110); radii are
  R = m R_cell, m = 1, 2, ... (:117, :178).
- The grid is fixed, not derived from the cells: 23 x 23 nodes at x, y = k * 500/23,
  k = 0..22, i.e. ``linspace(0, 500, 23, endpoint=False)`` (:122-123), so nodes lie outside the
  cells' bounding box too.
- A cell belongs to a node's disk when the distance between its centre of mass and the node is
  <= R (:217, :222).  Gamma_p is the plain mean of the member cells' gamma_p; an empty disk keeps
  the initial sums, Gamma_p = 0 (:240).
- The mean |Gamma_p| of an image is over the nodes with |Gamma_2| > 0 (:307), i.e. the nodes with
  at least one cell (for every p).
- Defects (plot_hexatics.py:112-162): theta = Arg(Gamma_p) / p at every node (an empty node has
  theta = 0); for the plaquette with upper corner (i, j), i along x and j along y, i, j >= 1, the
  differences around (i, j) -> (i-1, j) -> (i-1, j-1) -> (i, j-1) -> (i, j) (counter-clockwise in
  x, y) are each wrapped into (-pi/p, pi/p] (:154-157); a defect is a plaquette with
  |sum| > 0.01 (:159), of charge sum / 2 pi (:162).  The script records the position as
  ``0.5 * (2 * x_i + 1)`` (:160), half a pixel past node i; this port reports the plaquette
  centre instead, the position that its plotting code draws the marker at up to that half pixel.

Deliberately not ported: the scripts' file input and output (the grid is written with 7
significant digits, :278-292, and read back by plot_hexatics.py, which also assumes a grid step
of 21.5148 px, :73, instead of 500/23); here the grid goes from one step to the next in memory.
"""
from __future__ import annotations

import math

#: The published parameters (coarse_graining.py:110, :121-123).
R_CELL = 21.5
GRID_SIZE = 500.0
GRID_NODES = 23
ORDERS = (2, 3, 4, 5, 6)


def grid_axis():
    """Node coordinates along x (and y): k * 500 / 23, k = 0..22, as numpy.linspace computes them."""
    step = GRID_SIZE / GRID_NODES
    return [k * step for k in range(GRID_NODES)]


def read_dat(path):
    """Cells of an ``exp_#.dat`` file: lists x, y and {p: list of complex gamma_p} for p = 2..6."""
    xs, ys, gammas = [], [], {p: [] for p in ORDERS}
    with open(path) as handle:
        for line in handle:
            cols = [float(v) for v in line.split()]
            if not cols:
                continue
            xs.append(cols[0])
            ys.append(cols[1])
            for k, p in enumerate(ORDERS):
                gammas[p].append(complex(cols[2 + 2 * k], cols[3 + 2 * k]))
    return xs, ys, gammas


def coarse_grain(xs, ys, gammas, axis, radii):
    """Gamma_p on the grid for every radius: ``{p: [radius][i][j]}`` (i along x, j along y); 0 when empty.

    Also returns the number of cells in each disk, ``[radius][i][j]``.
    """
    out = {p: [] for p in gammas}
    counts = []
    n_cells = len(xs)
    for radius in radii:
        per_p = {p: [[0j] * len(axis) for _ in axis] for p in gammas}
        count = [[0] * len(axis) for _ in axis]
        for i, gx in enumerate(axis):
            for j, gy in enumerate(axis):
                total = {p: 0j for p in gammas}
                members = 0
                for c in range(n_cells):
                    dx, dy = gx - xs[c], gy - ys[c]
                    if math.sqrt(dx * dx + dy * dy) <= radius:
                        members += 1
                        for p in gammas:
                            total[p] += gammas[p][c]
                if members:
                    for p in gammas:
                        per_p[p][i][j] = total[p] / members
                count[i][j] = members
        for p in gammas:
            out[p].append(per_p[p])
        counts.append(count)
    return out, counts


def _wrap(d, p):
    """``d`` wrapped once into (-pi/p, pi/p] (enough for a difference of two angles in [-pi/p, pi/p])."""
    if d <= -math.pi / p:
        d += 2.0 * math.pi / p
    if d > math.pi / p:
        d -= 2.0 * math.pi / p
    return d


def defects(field, p, axis):
    """Defects of one gridded field ``field[i][j]``: list of (x, y, charge) at plaquette centres."""
    theta = [[math.atan2(v.imag, v.real) / p for v in column] for column in field]
    found = []
    for i in range(1, len(axis)):
        for j in range(1, len(axis)):
            loop = (theta[i][j], theta[i - 1][j], theta[i - 1][j - 1], theta[i][j - 1])
            winding = sum(_wrap(loop[(k + 1) % 4] - loop[k], p) for k in range(4))
            if abs(winding) > 0.01:
                found.append((0.5 * (axis[i - 1] + axis[i]), 0.5 * (axis[j - 1] + axis[j]),
                              winding / (2.0 * math.pi)))
    return found


def mean_abs(field, field2):
    """Mean |Gamma_p| over the nodes with |Gamma_2| > 0 (0 when there is none)."""
    total, n = 0.0, 0
    for column, column2 in zip(field, field2):
        for v, v2 in zip(column, column2):
            if abs(v2) > 0:
                total += abs(v)
                n += 1
    return total / n if n else 0.0


def analyse_image(path, factors):
    """Everything the published scripts compute for one image: Gamma_p, counts, defects and means per radius."""
    xs, ys, gammas = read_dat(path)
    axis = grid_axis()
    radii = [f * R_CELL for f in factors]
    fields, counts = coarse_grain(xs, ys, gammas, axis, radii)
    found = {(p, k): defects(fields[p][k], p, axis) for p in fields for k in range(len(radii))}
    means = {(p, k): mean_abs(fields[p][k], fields[2][k]) for p in fields for k in range(len(radii))}
    return fields, counts, found, means
