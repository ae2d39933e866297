"""An active vertex model on a periodic box that logs its own T1 transitions: T1 truth for the event benchmark.

The tissue is a set of polygons sharing three-fold vertices (x = column,
y = row, px) in a periodic box.  Its energy is the standard one (Farhadifar
et al. 2007; Bi et al. 2015)::

    E = sum_c  K/2 (A_c - A0)^2  +  G/2 (P_c - P0)^2,     P0 = p0 sqrt(A0)

and vertices move overdamped, ``dr_i/dt = -dE/dr_i + v0 <n_c>_i``, where
``<n_c>_i`` is the mean polarity of the cells around vertex ``i`` and each
cell's polarity angle diffuses with rate ``Dr`` (the active vertex model of
Barton et al. 2017).  With ``p0`` above the rigidity threshold (about
3.81) the tissue is fluid and cells exchange neighbours.

A T1 happens when a junction is shorter than ``t1_length``: it is replaced
by a junction of length ``new_length`` perpendicular to it, between the two
cells that were at its ends.  Every T1 is logged with the step it happened
at, the pair that lost the contact and the pair that gained it, so the T1
truth is the model's own record, not a detection on its images.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from ..box import Box
from ..errors import InputError, as_generator, check_positive

__all__ = ["VertexModelMovie", "vertex_model_movie", "vertex_model_events"]


@dataclass
class VertexModelMovie:
    """What :func:`vertex_model_movie` returns.

    Attributes
    ----------
    labels : (T, rows, cols) int32 array
        The rasterised polygons: label ``k`` is cell ``k`` in every frame (a
        pixel belongs to the cell whose polygon holds its centre).
    box : Box
        The periodic box ``(cols, rows)``, px.
    t1_log : DataFrame
        Every T1 the model made: ``step``, ``frame`` (the first saved frame
        showing the new topology), ``cell_a``, ``cell_b`` (the pair losing
        the contact), ``cell_c``, ``cell_d`` (the pair gaining it), ``x``,
        ``y`` (the junction's midpoint, px).
    polygons : list of list of (n, 2) arrays
        Per frame, each cell's polygon (counter-clockwise in x, y, unwrapped
        around its first vertex), px.
    contacts : DataFrame
        The exact junctions of every frame: ``frame``, ``cell_a`` <
        ``cell_b``, ``length`` (px).
    params : dict
        The model's parameters.
    """

    labels: np.ndarray
    box: Box
    t1_log: pd.DataFrame
    polygons: list
    contacts: pd.DataFrame
    params: dict


class _Tissue:
    """Vertex positions and cell polygons (vertex ids, counter-clockwise) on a periodic box."""

    def __init__(self, xy, polys, box):
        self.xy, self.polys, self.box = xy, polys, box
        self.index()

    def index(self):
        """Flat arrays of the polygons, rebuilt after every topology change."""
        sizes = np.array([len(p) for p in self.polys])
        self.vid = np.concatenate(self.polys)
        self.cell = np.repeat(np.arange(len(self.polys)), sizes)
        start = np.repeat(np.cumsum(sizes) - sizes, sizes)
        pos = np.arange(len(self.vid)) - start
        self.nxt = start + (pos + 1) % np.repeat(sizes, sizes)
        self.prv = start + (pos - 1) % np.repeat(sizes, sizes)
        self.first = start

    def unwrapped(self):
        """Each polygon row's position unwrapped around its cell's first vertex (cells are smaller than L/2)."""
        r = self.xy[self.vid]
        return r[self.first] + self.box.min_image(r - r[self.first])

    def shapes(self):
        r = self.unwrapped()
        rn = r[self.nxt]
        n = len(self.polys)
        area = 0.5 * np.bincount(self.cell, r[:, 0] * rn[:, 1] - rn[:, 0] * r[:, 1], minlength=n)
        side = np.hypot(*(rn - r).T)
        return r, area, np.bincount(self.cell, side, minlength=n)

    def forces(self, K, A0, G, P0):
        r, area, perim = self.shapes()
        rn, rp = r[self.nxt], r[self.prv]
        d_area = 0.5 * np.c_[rn[:, 1] - rp[:, 1], rp[:, 0] - rn[:, 0]]
        u_in = (r - rp) / np.hypot(*(r - rp).T)[:, None]
        u_out = (rn - r) / np.hypot(*(rn - r).T)[:, None]
        grad = (K * (area - A0))[self.cell, None] * d_area + (G * (perim - P0))[self.cell, None] * (u_in - u_out)
        f = np.zeros_like(self.xy)
        np.add.at(f, self.vid, -grad)
        return f

    def junctions(self):
        """Every junction once: ``cell_a`` < ``cell_b`` (0-based) and its length, px."""
        d = self.box.min_image(self.xy[self.vid[self.nxt]] - self.xy[self.vid])
        # the row i -> j of one cell and j -> i of the other: key each junction by its two vertex ids
        lo, hi = np.minimum(self.vid, self.vid[self.nxt]), np.maximum(self.vid, self.vid[self.nxt])
        order = np.lexsort((self.cell, hi, lo))
        first, second = order[0::2], order[1::2]
        return self.cell[first], self.cell[second], np.hypot(*d[first].T)

    def short_junctions(self, threshold):
        """Rows ``k`` (junction vid[k] -> vid[nxt[k]] of cell[k]) shorter than threshold, each junction once."""
        d = self.box.min_image(self.xy[self.vid[self.nxt]] - self.xy[self.vid])
        length = np.hypot(*d.T)
        rows = np.flatnonzero((length < threshold) & (self.vid < self.vid[self.nxt]))
        return rows[np.argsort(length[rows])]

    def t1(self, k, new_length):
        """Flip the junction of polygon row ``k``; returns (lost pair, gained pair, midpoint) or None."""
        i, j = int(self.vid[k]), int(self.vid[self.nxt[k]])
        p = int(self.cell[k])  # i -> j counter-clockwise in P: P lies left of i -> j
        cells_i = set(self.cell[self.vid == i].tolist())
        cells_j = set(self.cell[self.vid == j].tolist())
        q = (cells_i & cells_j) - {p}
        a, b = cells_i - cells_j, cells_j - cells_i
        if len(q) != 1 or len(a) != 1 or len(b) != 1:
            return None
        (q,), (a,), (b,) = q, a, b
        if len(self.polys[p]) <= 3 or len(self.polys[q]) <= 3 or len({p, q, a, b}) < 4:
            return None
        d = self.box.min_image(self.xy[j] - self.xy[i])
        mid = self.xy[i] + 0.5 * d
        e = d / np.hypot(*d)
        n = np.array([-e[1], e[0]])  # into P
        self.xy[i] = self.box.wrap(mid + 0.5 * new_length * n)  # i now joins P, A, B
        self.xy[j] = self.box.wrap(mid - 0.5 * new_length * n)  # j now joins Q, A, B

        def drop(cell, v):
            self.polys[cell] = [u for u in self.polys[cell] if u != v]

        def insert_before(cell, new, at):
            poly = self.polys[cell]
            poly.insert(poly.index(at), new)

        drop(p, j)
        drop(q, i)
        insert_before(a, j, i)  # A: ..., j, i, ...  (Q side, then P side)
        insert_before(b, i, j)  # B: ..., i, j, ...
        self.index()
        return (p, q), (a, b), self.box.wrap(mid)


def _rasterise(tissue, shape):
    """Labels 1..n: each pixel to the polygon holding its centre (periodic); rare unclaimed pixels to a neighbour."""
    from scipy import ndimage
    from skimage.draw import polygon

    rows, cols = shape
    out = np.zeros(shape, np.int32)
    # unwrapped polygons lie within half a box of [0, L): shifted by one box they are all positive, which
    # skimage's polygon needs (it clips negative coordinates)
    r = tissue.unwrapped() + np.array([cols, rows])
    for c in range(len(tissue.polys)):
        xy = r[tissue.cell == c]
        rr, cc = polygon(xy[:, 1], xy[:, 0])  # pixel centres inside
        out[rr % rows, cc % cols] = c + 1
    if (out == 0).any():
        tiled = np.tile(out, (3, 3))
        idx = ndimage.distance_transform_edt(tiled == 0, return_distances=False, return_indices=True)
        filled = tiled[idx[0], idx[1]]
        out = filled[rows:2 * rows, cols:2 * cols]
    return out


def vertex_model_movie(n_cells=144, cell_area=300.0, n_frames=60, *, steps_per_frame=50, dt=0.02, p0=3.9, K=None,
                       G=1.0, v0=0.3, Dr=0.1, t1_length=0.5, new_length=0.75, relax_steps=2000,
                       seed=0) -> VertexModelMovie:
    """An active vertex-model movie on a periodic box with its own log of every T1.

    Parameters
    ----------
    n_cells : int
        Number of cells (at least 16).
    cell_area : float
        Target area A0, px^2; the square box's side is ``round(sqrt(n_cells * cell_area))`` px.
    n_frames : int
        Frames saved (at least 2).
    steps_per_frame : int
        Integration steps between two frames.
    dt : float
        Time step (the mobility is 1).
    p0 : float
        Target shape index P0 / sqrt(A0) (fluid above about 3.81).
    K : float, optional
        Area stiffness (default ``1 / A0``, so K A0^2 = G A0).
    G : float
        Perimeter stiffness.
    v0, Dr : float
        Self-propulsion speed (px per unit time) and rotational diffusion rate of the cells' polarity.
    t1_length, new_length : float
        A junction shorter than ``t1_length`` px is flipped into one of ``new_length`` px.
    relax_steps : int
        Steps run before the first frame (from the Voronoi start), T1s included but not logged.
    seed : int
        Seed of the initial seeds and of the polarity noise.

    Returns
    -------
    VertexModelMovie
    """
    from ..synthetic import periodic_voronoi_network

    if int(n_cells) < 16 or int(n_frames) < 2 or int(steps_per_frame) < 1:
        raise InputError(f"vertex_model_movie needs n_cells >= 16, n_frames >= 2 and steps_per_frame >= 1; got "
                         f"{n_cells}, {n_frames}, {steps_per_frame}")
    for name, value in (("cell_area", cell_area), ("dt", dt), ("p0", p0), ("G", G), ("t1_length", t1_length)):
        check_positive(value, name)
    if not new_length > t1_length:
        raise InputError(f"new_length must exceed t1_length ({t1_length}); got {new_length}")
    rng = as_generator(seed)
    side = int(round(np.sqrt(n_cells * cell_area)))
    box = Box(side, side)
    A0 = side * side / n_cells
    K = 1.0 / A0 if K is None else float(K)
    P0 = p0 * np.sqrt(A0)
    net = periodic_voronoi_network(rng.uniform(0, side, (int(n_cells), 2)), box)
    xy = net["vertices"][["x", "y"]].to_numpy(float).copy()
    cv = net["cell_vertices"].sort_values(["cell", "rank"])
    polys = [g["vertex"].tolist() for _, g in cv.groupby("cell", sort=True)]
    tissue = _Tissue(xy, polys, box)
    theta = rng.uniform(0, 2 * np.pi, len(polys))
    log, frames_polys, labels, contacts = [], [], [], []
    degree = np.bincount(tissue.vid, minlength=len(xy)).astype(float)

    def step(record, s):
        nonlocal theta
        f = tissue.forces(K, A0, G, P0)
        pol = np.c_[np.cos(theta), np.sin(theta)][tissue.cell]
        active = np.zeros_like(tissue.xy)
        np.add.at(active, tissue.vid, pol)
        tissue.xy = box.wrap(tissue.xy + dt * (f + v0 * active / degree[:, None]))
        theta = theta + np.sqrt(2 * Dr * dt) * rng.standard_normal(len(theta))
        for k in tissue.short_junctions(t1_length):
            if k >= len(tissue.vid):
                break
            # the row may have changed after an earlier flip of this step: check that it is still short
            d = box.min_image(tissue.xy[tissue.vid[tissue.nxt[k]]] - tissue.xy[tissue.vid[k]])
            if np.hypot(*d) >= t1_length:
                continue
            done = tissue.t1(k, new_length)
            if done is not None and record:
                (p, q), (a, b), mid = done
                log.append((s, p + 1, q + 1, a + 1, b + 1, mid[0], mid[1]))

    def save():
        r = tissue.unwrapped()
        frames_polys.append([r[tissue.cell == c].copy() for c in range(len(tissue.polys))])
        a, b, length = tissue.junctions()
        contacts.append(pd.DataFrame({"frame": len(labels), "cell_a": np.minimum(a, b) + 1,
                                      "cell_b": np.maximum(a, b) + 1, "length": length}))
        labels.append(_rasterise(tissue, (side, side)))

    for s in range(int(relax_steps)):
        step(False, s)
    save()
    for s in range(1, (int(n_frames) - 1) * int(steps_per_frame) + 1):
        step(True, s)
        if s % steps_per_frame == 0:
            save()
    t1 = pd.DataFrame(log, columns=["step", "cell_a", "cell_b", "cell_c", "cell_d", "x", "y"])
    t1.insert(1, "frame", -(-t1["step"] // int(steps_per_frame)))
    params = {"n_cells": int(n_cells), "cell_area": float(A0), "n_frames": int(n_frames),
              "steps_per_frame": int(steps_per_frame), "dt": float(dt), "p0": float(p0), "K": K, "G": float(G),
              "v0": float(v0), "Dr": float(Dr), "t1_length": float(t1_length), "new_length": float(new_length),
              "relax_steps": int(relax_steps), "seed": int(seed)}
    return VertexModelMovie(np.stack(labels), box, t1, frames_polys, pd.concat(contacts, ignore_index=True), params)


def vertex_model_events(t1_log, n_frames, censor=None) -> pd.DataFrame:
    """The model's T1 log at frame resolution as an ``events`` table (kinds as :func:`hexatissue.events.detect_t1`).

    A flip and its inverse between the same two frames are never seen and
    cancel.  The flips of one quartet alternate direction and are paired in
    time: a flip followed by its inverse is a ``cycle`` (``frame_end`` the
    inverse's frame); a last unpaired flip is an ``intercalation``, or
    ``unresolved`` when fewer than ``censor`` frames follow it.

    Parameters
    ----------
    t1_log : DataFrame
        :attr:`VertexModelMovie.t1_log`.
    n_frames : int
        Frames of the movie.
    censor : int, optional
        Frames a T1 must be followed by to be called an intercalation
        (default :func:`hexatissue.events.default_censor` of ``n_frames``).

    Returns
    -------
    DataFrame
        ``event``, ``kind``, ``frame_start`` (first frame with the new
        contact, frame), ``frame_end``, ``duration`` (frame, NaN unless a
        cycle), ``cell_a``, ``cell_b`` (losing), ``cell_c``, ``cell_d``
        (gaining), ``x``, ``y`` (the flipped junction's midpoint, px),
        ``frame_gain`` (= ``frame_start``: the model holds no four-fold
        vertex), ``frame_undo`` (= ``frame_end``).
    """
    from ..events import default_censor

    censor = default_censor(n_frames) if censor is None else int(censor)
    by_quartet = {}
    for row in t1_log.sort_values("step").itertuples():
        lost = (min(row.cell_a, row.cell_b), max(row.cell_a, row.cell_b))
        gained = (min(row.cell_c, row.cell_d), max(row.cell_c, row.cell_d))
        key = tuple(sorted((lost, gained)))
        flips = by_quartet.setdefault(key, [])
        if flips and flips[-1][0] == row.frame and flips[-1][2] == lost:
            flips.pop()  # undone before the next frame: never seen
        else:
            flips.append((int(row.frame), lost, gained, float(row.x), float(row.y)))
    rows = []
    for flips in by_quartet.values():
        k = 0
        while k < len(flips):
            frame, lost, gained, x, y = flips[k]
            if k + 1 < len(flips):
                end, kind, k = float(flips[k + 1][0]), "cycle", k + 2
            else:
                end, k = np.nan, k + 1
                kind = "unresolved" if (n_frames - 1) - frame < censor else "intercalation"
            rows.append((kind, frame, end, end - frame, *lost, *gained, x, y, frame, end))
    cols = ["kind", "frame_start", "frame_end", "duration", "cell_a", "cell_b", "cell_c", "cell_d", "x", "y",
            "frame_gain", "frame_undo"]
    events = pd.DataFrame(rows, columns=cols).sort_values(["frame_start", "cell_a", "cell_b"], ignore_index=True)
    events.insert(0, "event", np.arange(len(events), dtype=np.int64))
    return events.astype({"frame_start": np.int64, "frame_gain": np.int64, "frame_end": float,
                         "duration": float, "frame_undo": float})
