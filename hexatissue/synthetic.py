"""Exact synthetic tissues for tests and benchmarks.

Label images are indexed ``[row, col]``; seeds and vertices are ``(x, y)``
with x = column and y = row, origin at the centre of pixel (0, 0).  Label
``k`` (1-based) is the Voronoi cell of ``seeds[k - 1]``.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import Voronoi, cKDTree

from .box import Box
from .errors import InputError, as_generator
from .geometry import polygon_area_centroid

__all__ = [
    "jittered_seeds",
    "voronoi_labels",
    "voronoi_truth",
    "voronoi_polygons",
    "hexagonal_seeds",
    "square_labels",
    "draw_membranes",
]


def jittered_seeds(shape, spacing, jitter=0.35, seed=0):
    """Seeds on a square lattice of pitch ``spacing`` px, each moved by up to ``jitter * spacing``.

    Returns an ``(n, 2)`` array of (x, y) inside an image of ``shape = (rows, cols)``.
    Jittered lattices avoid the tiny cells of Poisson seeds.
    """
    rng = as_generator(seed)
    ny, nx = int(shape[0] // spacing), int(shape[1] // spacing)
    if nx < 1 or ny < 1:
        raise InputError(f"spacing {spacing} is larger than the image shape {shape}")
    gx, gy = np.meshgrid((np.arange(nx) + 0.5) * shape[1] / nx, (np.arange(ny) + 0.5) * shape[0] / ny)
    xy = np.c_[gx.ravel(), gy.ravel()]
    xy += rng.uniform(-jitter, jitter, size=xy.shape) * spacing
    return xy


def hexagonal_seeds(nx, ny, spacing=15.0, row_spacing=13.0, offset=(0.25, 0.25)):
    """Seeds of a hexagonal tiling that is periodic in a box of ``(nx * spacing, ny * row_spacing)``.

    ``ny`` must be even.  ``row_spacing = 13`` with ``spacing = 15`` is within
    0.1 % of a regular hexagonal lattice.  Returns ``(seeds, box)``.
    """
    if ny % 2:
        raise InputError(f"ny must be even for a periodic hexagonal lattice; got {ny}")
    j, i = np.meshgrid(np.arange(nx), np.arange(ny))
    x = (j + 0.5 * (i % 2)) * spacing + offset[0]
    y = i * row_spacing + offset[1]
    return np.c_[x.ravel(), y.ravel()], Box(nx * spacing, ny * row_spacing)


def voronoi_labels(seeds, shape, periodic=False, membrane=0.0):
    """Rasterised Voronoi tessellation: each pixel gets the label of its nearest seed.

    Parameters
    ----------
    seeds : (n, 2) array
        Seed positions (x, y), px.
    shape : (rows, cols)
        Image shape.
    periodic : bool
        Nearest seed by minimum-image distance in the box ``(cols, rows)``.
    membrane : float
        When > 0, pixels whose centre lies within ``membrane / 2`` px of a
        Voronoi ridge are set to 0: junction lines of that width centred on
        the exact ridges (``membrane=1`` gives 1-px lines that still separate
        the cells in 4-connectivity).

    Returns
    -------
    (rows, cols) int32 array with labels 1..n (and 0 on membranes).
    """
    seeds = np.asarray(seeds, dtype=float)
    rows, cols = int(shape[0]), int(shape[1])
    if periodic:
        box = Box(cols, rows)
        tree = cKDTree(box.wrap(seeds), boxsize=[cols, rows])
    else:
        tree = cKDTree(seeds)
    out = np.empty((rows, cols), dtype=np.int32)
    x = np.arange(cols, dtype=float)
    chunk = max(1, 2**20 // max(cols, 1))
    for r0 in range(0, rows, chunk):
        r = np.arange(r0, min(rows, r0 + chunk), dtype=float)
        gx, gy = np.meshgrid(x, r)
        pix = np.c_[gx.ravel(), gy.ravel()]
        if membrane > 0:
            dist, idx = tree.query(pix, k=2, workers=-1)
            lab = idx[:, 0] + 1
            # distance to the bisector of the two nearest seeds (the images the tree used)
            u1, u2 = seeds[idx[:, 0]] - pix, seeds[idx[:, 1]] - pix
            if periodic:
                u1, u2 = box.min_image(u1), box.min_image(u2)
            gap = (dist[:, 1] ** 2 - dist[:, 0] ** 2) / (2 * np.hypot(*(u1 - u2).T))
            lab[gap < membrane / 2] = 0
        else:
            lab = tree.query(pix, workers=-1)[1] + 1
        out[r0 : r0 + len(r)] = lab.reshape(len(r), cols)
    return out


def voronoi_truth(seeds, shape, periodic=False):
    """Exact Voronoi neighbour pairs and vertices for :func:`voronoi_labels`.

    Returns
    -------
    pairs : dict
        ``{(a, b): ridge_length}`` with labels ``a < b`` (1-based), px.  For an
        open image, ridges are clipped to the image rectangle.
    vertices : (m, 2) array
        Voronoi vertices (x, y) inside the image (wrapped into the box when periodic).
    """
    seeds = np.asarray(seeds, dtype=float)
    rows, cols = int(shape[0]), int(shape[1])
    n = len(seeds)
    if periodic:
        box = Box(cols, rows)
        base = box.wrap(seeds)
        shifts = np.array([(dx, dy) for dx in (-1, 0, 1) for dy in (-1, 0, 1)]) * [cols, rows]
        pts = np.concatenate([base + s for s in shifts])
        owner = np.tile(np.arange(n), len(shifts))
    else:
        span = 4.0 * max(rows, cols)
        far = np.array([[-span, -span], [-span, span], [span, -span], [span, span]]) + [cols / 2, rows / 2]
        pts = np.concatenate([seeds, far])
        owner = np.r_[np.arange(n), -np.ones(4, int)]
    vor = Voronoi(pts)
    lo = np.array([-0.5, -0.5])
    hi = np.array([cols - 0.5, rows - 0.5])
    pairs = {}
    for (p, q), ridge in zip(vor.ridge_points, vor.ridge_vertices):
        a, b = owner[p], owner[q]
        if a < 0 or b < 0 or a == b or -1 in ridge:
            continue
        v0, v1 = vor.vertices[ridge[0]], vor.vertices[ridge[1]]
        if periodic:
            # keep each ridge once: the copy whose midpoint lies in the box
            mid = 0.5 * (v0 + v1)
            if not (np.all(mid >= lo) and np.all(mid < hi)):
                continue
            length = np.hypot(*(v1 - v0))
        else:
            length = _clipped_length(v0, v1, lo, hi)
            if length <= 0:
                continue
        key = (int(min(a, b)) + 1, int(max(a, b)) + 1)
        pairs[key] = pairs.get(key, 0.0) + length
    verts = vor.vertices
    if periodic:
        inside = np.all((verts >= 0) & (verts < [cols, rows]), axis=1)
    else:
        inside = np.all((verts >= lo) & (verts <= hi), axis=1)
    return pairs, verts[inside]


def voronoi_polygons(seeds, shape):
    """Exact polygons of the Voronoi cells of ``seeds`` that lie wholly inside an open image.

    Parameters
    ----------
    seeds : (n, 2) array
        Seed positions (x, y), px; label ``k`` is the cell of seed ``k - 1``
        (as in :func:`voronoi_labels`).
    shape : (int, int)
        ``(rows, cols)`` of the image; cells reaching beyond the rectangle
        ``[-0.5, cols - 0.5] x [-0.5, rows - 0.5]`` (or unbounded) are left out.

    Returns
    -------
    dict
        ``{label: (m, 2) array of (x, y)}``, counter-clockwise in (x, y);
        neighbouring cells share their vertices exactly (same floats).
    """
    seeds = np.asarray(seeds, dtype=float)
    rows, cols = int(shape[0]), int(shape[1])
    vor = Voronoi(seeds)
    lo, hi = np.array([-0.5, -0.5]), np.array([cols - 0.5, rows - 0.5])
    out = {}
    for k, region_index in enumerate(vor.point_region):
        region = vor.regions[region_index]
        if not region or -1 in region:
            continue
        xy = vor.vertices[region]
        if np.all((xy >= lo) & (xy <= hi)):
            area = polygon_area_centroid(xy, np.zeros(1, np.int64))[0][0]
            out[k + 1] = xy if area > 0 else xy[::-1]
    return out


def _clipped_length(v0, v1, lo, hi):
    """Length of the segment v0-v1 inside the rectangle [lo, hi] (Liang-Barsky)."""
    d = v1 - v0
    t0, t1 = 0.0, 1.0
    for k in range(2):
        if d[k] == 0:
            if not lo[k] <= v0[k] <= hi[k]:
                return 0.0
            continue
        ta, tb = (lo[k] - v0[k]) / d[k], (hi[k] - v0[k]) / d[k]
        t0, t1 = max(t0, min(ta, tb)), min(t1, max(ta, tb))
    return max(0.0, t1 - t0) * float(np.hypot(*d))


def square_labels(nx, ny, side):
    """A square tiling: ``ny x nx`` squares of ``side`` px, labels 1..nx*ny row by row."""
    i, j = np.divmod(np.arange(ny * side * nx * side), nx * side)
    return ((i // side) * nx + (j // side) + 1).reshape(ny * side, nx * side).astype(np.int32)


def draw_membranes(labels, width=1, periodic=False):
    """Set junction pixels to 0, as in Tissue Analyzer / EpySeg images.

    ``width=1`` zeroes every pixel whose right or lower neighbour has another
    label (1-px lines that still separate the cells in 4-connectivity);
    ``width=2`` zeroes both sides of every junction.
    """
    if width not in (1, 2):
        raise InputError(f"width must be 1 or 2 px; got {width!r}")
    lab = np.asarray(labels)
    if periodic:
        right, down = np.roll(lab, -1, axis=1), np.roll(lab, -1, axis=0)
        left, up = np.roll(lab, 1, axis=1), np.roll(lab, 1, axis=0)
    else:
        right = np.c_[lab[:, 1:], lab[:, -1:]]
        down = np.r_[lab[1:], lab[-1:]]
        left = np.c_[lab[:, :1], lab[:, :-1]]
        up = np.r_[lab[:1], lab[:-1]]
    mask = (right != lab) | (down != lab)
    if width == 2:
        mask |= (left != lab) | (up != lab)
    out = lab.copy()
    out[mask] = 0
    return out


# ---------------------------------------------------------------------------
# Synthetic movies: Voronoi seeds moved smoothly, with scripted T1 events whose
# truth follows from the exact Voronoi tessellation of the seeds.
# ---------------------------------------------------------------------------

from dataclasses import dataclass, field  # noqa: E402
from functools import cached_property  # noqa: E402

import pandas as pd  # noqa: E402

__all__ += ["T1Movie", "t1_movie", "VoronoiMovie", "voronoi_movie", "movie_contacts", "relabel_movie"]

# Scripted quartets of t1_movie: (name, lattice row, lattice col of cell a, lambda schedule).
# lambda = -1: the hexagonal quartet (a-b share a junction); 0: the four seeds are
# cocircular (an exact four-fold vertex); +1: c-d share a junction.  A junction of
# the quartet is either absent or >= 9.7 px long, so rasterisation never hides it.
_T1_SCRIPT = (
    # name, row, col, [(first frame, lambda), ...] piecewise constant steps, ramps marked by 'ramp'
    ("cycle", 1, 1, [(0, -1.0), (3, "ramp", -0.5, 6), (6, 0.5), (12, -0.5), (13, "ramp", -1.0, 16)]),
    ("intercalation", 1, 6, [(0, -1.0), (6, "ramp", -0.5, 9), (9, 0.5), (10, "ramp", 1.0, 14)]),
    ("fourfold_intercalation", 4, 3, [(0, -1.0), (8, "ramp", -0.5, 12), (12, 0.0), (18, 0.5)]),
    ("fourfold_return", 4, 8, [(0, -1.0), (16, "ramp", -0.5, 20), (20, 0.0), (25, -0.5)]),
    ("fourfold_cycle", 7, 1, [(0, -1.0), (18, "ramp", -0.5, 22), (22, 0.0), (25, 0.5), (29, 0.0), (31, -0.5)]),
    ("late", 7, 6, [(0, -1.0), (30, "ramp", -0.5, 34), (34, 0.5)]),
)


def _schedule(steps, n_frames):
    """lambda(t) for t = 0..n_frames-1 from piecewise constant steps and linear ramps."""
    lam = np.empty(n_frames)
    for k, step in enumerate(steps):
        start = step[0]
        stop = steps[k + 1][0] if k + 1 < len(steps) else n_frames
        if len(step) == 2:
            lam[start:stop] = step[1]
        else:  # ("ramp", target, reached at frame)
            _, _, target, reach = step
            t = np.arange(start, stop)
            lam0 = lam[start - 1]
            lam[start:stop] = lam0 + (target - lam0) * np.clip((t - start + 1) / (reach - start), 0, 1)
    return lam


@dataclass
class T1Movie:
    """A rasterised Voronoi movie with scripted T1 events and its exact truth.

    Attributes
    ----------
    labels : (T, rows, cols) int32 array
        Label ``k`` is the Voronoi cell of seed ``k - 1``; ids are consistent
        over time.  Rendered on first access.
    seeds : (T, n, 2) float array
        Seed positions (x, y) per frame, px (wrapped into the box when periodic).
    box : Box or None
        The periodic box, or None for an open image.
    events : pandas.DataFrame
        True events, columns of the ``events`` table (``event``, ``kind``,
        ``frame_start``, ``frame_end``, ``duration``, ``cell_a``..``cell_d``,
        ``x``, ``y``) plus ``frame_gain`` (first frame c-d are in contact) and
        ``quartet`` (the script entry).
    cells : pandas.DataFrame
        ``frame``, ``cell``, ``x``, ``y`` (seed position, px), ``is_border``.
    edges : pandas.DataFrame
        ``frame``, ``cell_a`` < ``cell_b``, ``length``: exact Voronoi ridges (px),
        clipped to the image when open.
    min_length : float
        Junctions shorter than this are four-fold vertices in the truth (px).
    censor : int
        Right-censoring window used to classify the truth (frames).
    quartets : pandas.DataFrame
        ``name``, ``cell_a``, ``cell_b``, ``cell_c``, ``cell_d`` of every scripted quartet.
    """

    seeds: np.ndarray
    shape: tuple
    box: Box | None
    events: pd.DataFrame
    cells: pd.DataFrame
    edges: pd.DataFrame
    min_length: float
    censor: int
    quartets: pd.DataFrame = field(default_factory=pd.DataFrame)

    @cached_property
    def labels(self) -> np.ndarray:
        return np.stack([voronoi_labels(s, self.shape, periodic=self.box is not None) for s in self.seeds])


def movie_contacts(seeds, shape, periodic):
    """Exact Voronoi ridges of every frame: ``frame``, ``cell_a`` < ``cell_b``, ``length`` (px)."""
    rows = []
    for t, s in enumerate(seeds):
        pairs, _ = voronoi_truth(s, shape, periodic=periodic)
        rows.extend((t, a, b, length) for (a, b), length in pairs.items())
    return pd.DataFrame(rows, columns=["frame", "cell_a", "cell_b", "length"]).astype(
        {"frame": np.int64, "cell_a": np.int64, "cell_b": np.int64, "length": float})


def _quartet_seeds(base, row, col, nx):
    """Indices (a, b, c, d) and frame (centre, u, w) of the hexagonal quartet at lattice (row, col)."""
    a, b = row * nx + col, row * nx + col + 1
    m = 0.5 * (base[a] + base[b])
    u = (base[b] - base[a]) / np.hypot(*(base[b] - base[a]))
    w = np.array([-u[1], u[0]])
    dist = np.hypot(*(base - m).T)
    c, d = sorted(np.argsort(dist)[2:4], key=lambda k: np.dot(base[k] - m, w))
    return (a, b, c, d), m, u, w


def _truth_events(contacts, quartets, n_frames, min_length, censor, seeds, box):
    """True events from each scripted quartet's contact state per frame (Voronoi with the min-length rule)."""
    on = contacts[contacts["length"] >= min_length]
    keys = set(zip(on["frame"], on["cell_a"], on["cell_b"]))
    rows = []
    for q in quartets.itertuples():
        ab, cd = tuple(sorted((q.cell_a, q.cell_b))), tuple(sorted((q.cell_c, q.cell_d)))
        state = []
        for t in range(n_frames):
            has_ab, has_cd = (t, *ab) in keys, (t, *cd) in keys
            if has_ab and has_cd:
                raise AssertionError(f"quartet {q.name}: a-b and c-d in contact at frame {t}")
            state.append("ab" if has_ab else "cd" if has_cd else "4")
        # Each T1 = the last 'ab' run ends and 'cd' follows (possibly after a four-fold '4' run).
        t1s, lost_at = [], None  # (frame lost, frame gained, direction)
        for t in range(1, n_frames):
            if state[t] == state[t - 1]:
                continue
            if state[t] == "4":
                lost_at, from_state = t, state[t - 1]
            else:
                origin = state[t - 1] if state[t - 1] != "4" else from_state
                start = t if state[t - 1] != "4" else lost_at
                if origin != state[t]:
                    t1s.append((start, t, origin))
        k = 0
        while k < len(t1s):
            start, gain, origin = t1s[k]
            la, lb, gc, gd = (ab + cd) if origin == "ab" else (cd + ab)
            if k + 1 < len(t1s):
                end = t1s[k + 1][1]
                kind, k = "cycle", k + 2
            else:
                end = np.nan
                kind = "unresolved" if (n_frames - 1) - start < censor else "intercalation"
                k += 1
            xy = seeds[start, [la - 1, lb - 1, gc - 1, gd - 1]]
            if box is not None:
                xy = xy[0] + box.min_image(xy - xy[0])
            centre = xy.mean(axis=0) if box is None else box.wrap(xy.mean(axis=0))
            rows.append((kind, start, end, end - start, la, lb, gc, gd, centre[0], centre[1], gain, q.name))
    cols = ["kind", "frame_start", "frame_end", "duration", "cell_a", "cell_b", "cell_c", "cell_d", "x", "y",
            "frame_gain", "quartet"]
    events = pd.DataFrame(rows, columns=cols).sort_values(["frame_start", "cell_a", "cell_b"], ignore_index=True)
    events.insert(0, "event", np.arange(len(events), dtype=np.int64))
    return events.astype({"frame_end": float, "duration": float})


def t1_movie(periodic=True, n_frames=36, nx=12, ny=10, min_length=4.0, censor=5, wobble=0.6,
             drift=(0.31, 0.17), seed=0) -> T1Movie:
    """A hexagonal Voronoi tissue moved smoothly, with scripted T1 events and exact truth.

    Every seed wobbles on a small circle (radius ``wobble`` px, random phase);
    in a periodic box the whole tissue also drifts by ``drift`` px per frame.
    Six quartets follow scripts (see ``_T1_SCRIPT``): a T1 cycle, an
    intercalation, a four-fold vertex held for 6 frames that resolves into an
    intercalation, one held 5 frames that resolves back (no T1), a cycle whose
    both halves pass through held four-fold vertices, and a T1 within
    ``censor`` frames of the end (unresolved).  The four seeds of a quartet
    move rigidly so a held four-fold vertex is exact.

    The truth comes from the exact Voronoi tessellation of the seeds (periodic
    images included), with the rule that a ridge shorter than ``min_length``
    px is a four-fold vertex, not a contact.  Every ridge of every frame is
    either absent or at least 9 px long (checked), so the rule is unambiguous
    after rasterisation; the function also checks that the only contacts that
    change are those of the scripted quartets.

    Parameters
    ----------
    periodic : bool
        Periodic box of ``(30 nx, 26 ny)`` px, or an open image of that shape.
    n_frames : int
        At least 36 (the scripts end at frame 34).
    nx, ny : int
        Lattice size (``ny`` even); at least 12 x 10.
    min_length : float
        Truth contact rule (px); use the same value for detection.
    censor : int
        Right-censoring window used to classify the truth (frames).
    wobble : float
        Radius of every seed's circular motion, px.
    drift : (float, float)
        Translation per frame (periodic only), px.
    seed : int or numpy.random.Generator
        Random phases.

    Returns
    -------
    T1Movie
    """
    if n_frames < 36 or nx < 12 or ny < 10 or ny % 2:
        raise InputError(f"t1_movie needs n_frames >= 36, nx >= 12 and an even ny >= 10; got {n_frames}, {nx}, {ny}")
    rng = as_generator(seed)
    base, box = hexagonal_seeds(nx, ny, spacing=30.0, row_spacing=26.0, offset=(7.25, 6.25))
    shape = (int(box.Ly), int(box.Lx))
    n = len(base)
    phase = rng.uniform(0, 2 * np.pi, n)
    quartets, groups = [], []
    lams = []
    for name, row, col, steps in _T1_SCRIPT:
        (a, b, c, d), m, u, w = _quartet_seeds(base, row, col, nx)
        quartets.append((name, a + 1, b + 1, c + 1, d + 1))
        groups.append(((a, b, c, d), m, u, w))
        lams.append(_schedule(steps, n_frames))
        phase[[a, b, c, d]] = phase[a]  # rigid quartet: its four-fold vertex stays exact
    t = np.arange(n_frames)[:, None]
    omega = 2 * np.pi / 24.0
    seeds = base[None] + wobble * np.stack([np.cos(omega * t + phase), np.sin(omega * t + phase)], axis=-1)
    p0, q0 = 15.0, 26.0
    r0 = 0.5 * (p0 + q0)
    for ((a, b, c, d), m, u, w), lam in zip(groups, lams):
        p = r0 + lam * (r0 - p0)
        q = r0 - lam * (r0 - p0)
        shift = seeds[:, a] - base[a]  # the quartet's common wobble
        centre = m + shift
        seeds[:, a] = centre - p[:, None] * u
        seeds[:, b] = centre + p[:, None] * u
        seeds[:, c] = centre - q[:, None] * w
        seeds[:, d] = centre + q[:, None] * w
    if periodic:
        seeds = box.wrap(seeds + np.asarray(drift, float) * t[..., None])
    out_box = box if periodic else None
    quartets = pd.DataFrame(quartets, columns=["name", "cell_a", "cell_b", "cell_c", "cell_d"])
    edges = movie_contacts(seeds, shape, periodic)
    _check_script(edges, quartets, min_length)
    border = np.zeros((n_frames, n), bool)
    if not periodic:  # cells whose clipped Voronoi region reaches the image edge
        for k in range(n_frames):
            border[k, _rim_cells(seeds[k], shape) - 1] = True
    cells = pd.DataFrame({
        "frame": np.repeat(np.arange(n_frames), n), "cell": np.tile(np.arange(1, n + 1), n_frames),
        "x": seeds[..., 0].ravel(), "y": seeds[..., 1].ravel(), "is_border": border.ravel()})
    events = _truth_events(edges, quartets, n_frames, min_length, censor, seeds, out_box)
    return T1Movie(seeds, shape, out_box, events, cells, edges, float(min_length), int(censor), quartets)


def _rim_cells(seeds, shape):
    """Labels of the cells owning a pixel on the image rim (nearest seed, as in voronoi_labels)."""
    rows, cols = shape
    r, c = np.arange(rows, dtype=float), np.arange(cols, dtype=float)
    rim = np.r_[np.c_[c, np.zeros(cols)], np.c_[c, np.full(cols, rows - 1.0)],
                np.c_[np.zeros(rows), r], np.c_[np.full(rows, cols - 1.0), r]]
    _, idx = cKDTree(seeds).query(rim)
    return np.unique(idx) + 1


def _check_script(edges, quartets, min_length):
    """The truth is unambiguous: ridges are 0 or >= 2 min_length, and only scripted contacts change."""
    lengths = edges["length"].to_numpy()
    bad = (lengths > 1e-6) & (lengths < 2 * min_length)
    if bad.any():
        raise AssertionError(f"ambiguous ridge lengths near min_length: {edges[bad].head()}")
    on = edges[lengths >= min_length]
    n_frames = int(edges["frame"].max()) + 1
    counts = on.groupby(["cell_a", "cell_b"]).size()
    changing = set(counts[counts < n_frames].index)
    scripted = set()
    for q in quartets.itertuples():
        scripted |= {tuple(sorted((q.cell_a, q.cell_b))), tuple(sorted((q.cell_c, q.cell_d)))}
    if not changing <= scripted:
        raise AssertionError(f"unscripted contact changes: {sorted(changing - scripted)}")


def relabel_movie(labels, seed=0, max_id=None):
    """Give every frame's cells new random ids (a random permutation per frame).

    Returns ``(relabelled, maps)`` where ``maps[t]`` is ``{new id: old id}`` of frame ``t``.
    ``max_id`` (default 4 x the largest id) bounds the new ids.
    """
    rng = as_generator(seed)
    labels = np.asarray(labels)
    top = int(labels.max())
    max_id = max_id or 4 * top + 10
    out = np.empty(labels.shape, np.int64)
    maps = []
    for t in range(len(labels)):
        ids = np.unique(labels[t])
        ids = ids[ids > 0].astype(np.int64)
        new = rng.choice(np.arange(1, max_id + 1), size=len(ids), replace=False)
        lut = np.zeros(top + 1, np.int64)
        lut[ids] = new
        out[t] = lut[labels[t].astype(np.int64)]
        maps.append(dict(zip(new.tolist(), ids.tolist())))
    return out, maps


class VoronoiMovie:
    """A lazily rendered Voronoi movie: ``movie[t]`` is the label image of frame ``t``.

    Seeds start on a jittered lattice and each moves smoothly on its own
    Lissajous orbit (amplitude ``amplitude`` x the cell spacing, periods 60 to
    240 frames), so neighbours exchange now and then.  Frames are rendered on
    demand (nothing is stored), which makes arbitrarily long test movies cheap
    in memory.  Label ``k`` is the cell of seed ``k - 1`` in every frame.
    """

    def __init__(self, n_cells, shape, n_frames, periodic=True, amplitude=0.3, seed=0):
        rows, cols = int(shape[0]), int(shape[1])
        if n_cells < 2 or n_frames < 1:
            raise InputError(f"n_cells must be >= 2 and n_frames >= 1; got {n_cells}, {n_frames}")
        rng = as_generator(seed)
        spacing = np.sqrt(rows * cols / n_cells)
        # a lattice with at least n_cells sites, jittered, then random sites dropped: exactly n_cells seeds
        ny = max(1, int(round(rows / spacing)))
        nx = int(np.ceil(n_cells / ny))
        gx, gy = np.meshgrid((np.arange(nx) + 0.5) * cols / nx, (np.arange(ny) + 0.5) * rows / ny)
        base = np.c_[gx.ravel(), gy.ravel()]
        base = base[np.sort(rng.permutation(len(base))[:n_cells])]
        base = base + rng.uniform(-0.3, 0.3, size=base.shape) * spacing
        self.base = base
        self.n_cells = len(base)
        self.periodic = bool(periodic)
        self.box = Box(cols, rows) if periodic else None
        self.shape = (int(n_frames), rows, cols)
        self.ndim, self.dtype = 3, np.dtype(np.int32)
        self._amp = amplitude * spacing
        self._period = rng.uniform(60, 240, size=(self.n_cells, 2))
        self._phase = rng.uniform(0, 2 * np.pi, size=(self.n_cells, 2))

    def __len__(self):
        return self.shape[0]

    def seeds(self, t):
        """Seed positions (x, y) at frame ``t``, px."""
        xy = self.base + self._amp * np.sin(2 * np.pi * t / self._period + self._phase)
        if self.periodic:
            return self.box.wrap(xy)
        return np.clip(xy, 0, [self.shape[2] - 1, self.shape[1] - 1])

    def __getitem__(self, t):
        if not isinstance(t, (int, np.integer)):
            raise InputError(f"VoronoiMovie is indexed by one integer frame; got {t!r}")
        t = int(t) + (self.shape[0] if t < 0 else 0)
        if not 0 <= t < self.shape[0]:
            raise IndexError(f"frame {t} out of range 0..{self.shape[0] - 1}")
        return voronoi_labels(self.seeds(t), self.shape[1:], periodic=self.periodic)


def voronoi_movie(n_cells, shape, n_frames, periodic=True, amplitude=0.3, seed=0) -> VoronoiMovie:
    """A lazily rendered, smoothly moving Voronoi movie (see :class:`VoronoiMovie`)."""
    return VoronoiMovie(n_cells, shape, n_frames, periodic=periodic, amplitude=amplitude, seed=seed)
