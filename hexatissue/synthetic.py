"""Exact synthetic tissues for tests and benchmarks.

Label images are indexed ``[row, col]``; seeds and vertices are ``(x, y)``
with x = column and y = row, origin at the centre of pixel (0, 0).  Label
``k`` (1-based) is the Voronoi cell of ``seeds[k - 1]``.
"""
from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import Voronoi, cKDTree

from .box import Box
from .errors import InputError, as_generator
from .geometry import polygon_area_centroid

__all__ = [
    "jittered_seeds",
    "flowing_movie",
    "FlowingMovie",
    "voronoi_labels",
    "voronoi_truth",
    "voronoi_polygons",
    "hexagonal_seeds",
    "square_labels",
    "draw_membranes",
    "periodic_voronoi_network",
    "vertex_model_tissue",
    "arc_vertex_model_tissue",
    "arcs_at_balance",
    "network_labels",
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


#: Geometry of :func:`rosette_movie` (px): the five rosette seeds at radius 30 (the fan's cell pulled in by
#: ``0.45 x`` its radius at full swing), ten seeds at 60 and fifteen at 95 around the centre of a 200 x 200 image.
#: Chosen by a scan so that every ridge of every state is 0 or >= 9.6 px and the rosette's diagonals 11.1 px.
_ROSETTE = dict(radii=(30.0, 60.0, 95.0), counts=(5, 10, 15), pull=0.45, shape=(200, 200))


def rosette_seeds(fan, amount=1.0):
    """Seeds (x, y) of the rosette tissue of :func:`rosette_movie` in one state.

    Parameters
    ----------
    fan : int or None
        The rosette cell (0..4, label ``fan + 1``) pulled towards the centre:
        the rosette's two diagonals are then the contacts ``fan - (fan + 2)``
        and ``fan - (fan + 3)`` (mod 5).  None: the five rosette seeds on one
        circle, a five-fold vertex (no diagonal).
    amount : float
        Fraction of the full pull (1: diagonals of 11.1 px; smaller values
        give shorter diagonals, for junctions that grow after a swap).

    Returns
    -------
    (30, 2) float array
        Seeds 0-4 the rosette (label = index + 1), then the two outer rings.
    """
    (r1, r2, r3), (n1, n2, n3) = _ROSETTE["radii"], _ROSETTE["counts"]
    radius = np.full(n1, r1)
    if fan is not None:
        radius[int(fan) % n1] *= 1 - _ROSETTE["pull"] * float(amount)
    parts = []
    for r, n in ((radius, n1), (r2, n2), (r3, n3)):
        angle = 2 * np.pi * np.arange(n) / n + np.pi / 2
        parts.append(np.c_[r * np.cos(angle), r * np.sin(angle)])
    rows, cols = _ROSETTE["shape"]
    return np.concatenate(parts) + [cols / 2, rows / 2]


@dataclass
class RosetteMovie:
    """A rasterised five-cell rosette whose diagonal contacts follow a script (:func:`rosette_movie`).

    Attributes
    ----------
    labels : (T, 200, 200) int32 array
        Label ``k`` is the Voronoi cell of seed ``k - 1``; the rosette's cells are 1..5.
    seeds : (T, 30, 2) float array
        Seed positions (x, y) per frame, px.
    edges : pandas.DataFrame
        ``frame``, ``cell_a`` < ``cell_b``, ``length``: exact Voronoi ridges, px.
    cells : pandas.DataFrame
        ``frame``, ``cell``, ``x``, ``y`` (seed position, px), ``is_border``.
    diagonals : list of set
        The rosette's diagonal contacts of each frame, as ``(a, b)`` label pairs, from the script.
    """

    seeds: np.ndarray
    shape: tuple
    edges: pd.DataFrame
    cells: pd.DataFrame
    diagonals: list

    @cached_property
    def labels(self) -> np.ndarray:
        return np.stack([voronoi_labels(s, self.shape) for s in self.seeds])


def rosette_movie(states) -> RosetteMovie:
    """A Voronoi tissue around a five-cell rosette whose diagonals swap as scripted: T1s on adjacent junctions.

    The rosette's five cells (labels 1..5, in angular order) share a centre;
    its two diagonal contacts are those of the cell pulled towards it (a fan,
    :func:`rosette_seeds`).  Going from fan ``k`` to fan ``k + 1`` in one
    frame swaps both diagonals at once: two T1s on junctions that share a
    cell and a vertex, which only resolve as a sequence (``k-(k+2)`` ->
    ``(k+1)-(k+3)``, then ``k-(k+3)`` -> ``(k+1)-(k+4)``).  Fan ``k``, then
    fan ``k + 3``, then fan ``k + 1`` makes the same two T1s in consecutive
    frames; a ``None`` state between two fans holds a five-fold vertex.  The
    other 25 cells never change neighbours (checked), and every ridge of
    every frame is 0 or at least 4 px long (checked; 9.6 px at full pull),
    so the rasterised network has exactly the scripted contacts.

    Parameters
    ----------
    states : sequence of (fan, amount) or fan
        One state per frame: ``fan`` (0..4 or None) and the ``amount`` of
        the pull (default 1), as in :func:`rosette_seeds`.

    Returns
    -------
    RosetteMovie
    """
    states = [s if isinstance(s, tuple) else (s, 1.0) for s in states]
    if not states:
        raise InputError("states must hold at least one frame's state; got none")
    seeds = np.stack([rosette_seeds(fan, amount) for fan, amount in states])
    shape = _ROSETTE["shape"]
    edges = movie_contacts(seeds, shape, periodic=False)
    diagonals = [set() if fan is None else {tuple(sorted((fan % 5 + 1, (fan + k) % 5 + 1))) for k in (2, 3)}
                 for fan, _ in states]
    rosette = (edges["cell_b"] <= 5) & ((edges["cell_b"] - edges["cell_a"]) % 5 > 1) \
        & ((edges["cell_b"] - edges["cell_a"]) % 5 < 4)
    for t, want in enumerate(diagonals):
        here = edges[(edges["frame"] == t) & rosette]
        if set(zip(here["cell_a"], here["cell_b"])) != want:
            raise AssertionError(f"frame {t}: rosette diagonals {sorted(zip(here['cell_a'], here['cell_b']))}, "
                                 f"scripted {sorted(want)}")
    other = edges[~rosette]
    if (other.groupby(["cell_a", "cell_b"]).size() != len(states)).any() or (edges["length"] < 4).any():
        raise AssertionError("unscripted contact changes or ridges shorter than 4 px")
    n = seeds.shape[1]
    rim = [np.isin(np.arange(1, n + 1), _rim_cells(s, shape)) for s in seeds]
    cells = pd.DataFrame({"frame": np.repeat(np.arange(len(states)), n), "cell": np.tile(np.arange(1, n + 1),
                          len(states)), "x": seeds[..., 0].ravel(), "y": seeds[..., 1].ravel(),
                          "is_border": np.concatenate(rim)})
    return RosetteMovie(seeds, shape, edges, cells, diagonals)


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


class FlowingMovie:
    """A Voronoi tissue carried by a uniform flow, with its exact tracking truth (:func:`flowing_movie`).

    Attributes
    ----------
    labels : (frames, rows, cols) int64 array
        The label images (ids shuffled per frame when asked).
    truth : dict
        ``{(frame, label): seed}``: the seed (track identity) of every cell of every frame.
    parents : dict
        ``{daughter seed: mother seed}`` of the divisions.
    extruded : dict
        ``{seed: last frame}`` of the cells removed inside the tissue.
    spacing : float
        Cell spacing (px); a cell's diameter is about this.
    """

    def __init__(self, labels, truth, parents, extruded, spacing):
        self.labels, self.truth, self.parents, self.extruded = labels, truth, parents, extruded
        self.spacing = spacing


def flowing_movie(shape=(240, 320), n_frames=6, spacing=16.0, speed=0.5, shear=0.01, rotation=0.02,
                  divisions=0, extrusions=0, noise=0.0, shuffle=True, growth=0.0, seed=0) -> FlowingMovie:
    """A Voronoi tissue translating, shearing and turning, seen through a fixed open image.

    Every frame the seeds move by the affine map about the image centre
    ``x -> (1 + growth) R(rotation) (x + shear * y e_x) + v``, with ``|v| = speed * spacing``
    (direction drawn once), so cells enter and leave through the image edge.
    Divisions replace a seed by two seeds ``0.3 spacing`` apart (new
    identities); extrusions remove a seed (its neighbours fill its place).
    Both happen to cells at least two spacings inside the image, spread over
    the frames after the first.

    Parameters
    ----------
    shape : (rows, cols)
    n_frames : int
    spacing : float
        Seed spacing, px (a jittered square lattice, jitter 0.35).
    speed : float
        Translation per frame in cell spacings.
    shear, rotation : float
        Simple shear per frame (dimensionless) and rotation per frame (rad).
    growth : float
        Isotropic expansion per frame (lengths grow by ``1 + growth``, areas
        by its square).
    divisions, extrusions : int
        Number of each event in the movie.
    noise : float
        Seed jitter added per frame, px (each seed's own small random motion).
    shuffle : bool
        Give the cells new random ids every frame.
    seed : int or numpy Generator

    Returns
    -------
    FlowingMovie
    """
    rng = as_generator(seed)
    rows, cols = int(shape[0]), int(shape[1])
    if n_frames < 1 or spacing <= 0:
        raise InputError(f"n_frames must be >= 1 and spacing > 0; got {n_frames}, {spacing}")
    centre = np.array([(cols - 1) / 2, (rows - 1) / 2])
    angle = rng.uniform(0, 2 * np.pi)
    v = speed * spacing * np.array([np.cos(angle), np.sin(angle)])
    # a lattice wide enough to cover the image at every frame
    reach = 0.75 * np.hypot(rows, cols) + n_frames * (abs(speed) * spacing + (abs(shear) + abs(rotation) +
                                                                              abs(growth)) * np.hypot(rows, cols)) \
        + 3 * spacing
    side = int(np.ceil(2 * reach))
    pts = jittered_seeds((side, side), spacing, seed=rng) - side / 2 + centre
    ids = np.arange(len(pts))
    cos, sin = np.cos(rotation), np.sin(rotation)
    rot = np.array([[cos, -sin], [sin, cos]])
    lower = np.array([[1.0, shear], [0.0, 1.0]])
    step = (1 + growth) * rot @ lower
    div_at = np.sort(rng.integers(1, n_frames, divisions)) if n_frames > 1 else np.empty(0, int)
    ext_at = np.sort(rng.integers(1, n_frames, extrusions)) if n_frames > 1 else np.empty(0, int)
    parents, extruded, truth, frames, all_seeds = {}, {}, {}, [], []
    next_id = len(pts)
    for t in range(n_frames):
        if t:
            pts = (pts - centre) @ step.T + centre + v
            if noise:
                pts = pts + rng.normal(0, noise, pts.shape)
            inner = np.flatnonzero((pts[:, 0] > 2 * spacing) & (pts[:, 0] < cols - 1 - 2 * spacing) &
                                   (pts[:, 1] > 2 * spacing) & (pts[:, 1] < rows - 1 - 2 * spacing))
            busy = set(parents.values()) | set(parents) | set(extruded)
            inner = np.array([k for k in inner.tolist() if int(ids[k]) not in busy], int)
            n_div, n_ext = int((div_at == t).sum()), int((ext_at == t).sum())
            chosen = rng.choice(inner, size=min(len(inner), n_div + n_ext), replace=False)
            remove = []
            for k in chosen[:n_div].tolist():
                a = rng.uniform(0, np.pi)
                off = 0.15 * spacing * np.array([np.cos(a), np.sin(a)])
                pts = np.vstack([pts, pts[k] + off, pts[k] - off])
                ids = np.append(ids, [next_id, next_id + 1])
                parents[next_id] = parents[next_id + 1] = int(ids[k])
                next_id += 2
                remove.append(k)
            for k in chosen[n_div:].tolist():
                extruded[int(ids[k])] = t - 1
                remove.append(k)
            keep = np.setdiff1d(np.arange(len(pts)), remove)
            pts, ids = pts[keep], ids[keep]
        visible = np.flatnonzero((pts[:, 0] > -2 * spacing) & (pts[:, 0] < cols + 2 * spacing) &
                                 (pts[:, 1] > -2 * spacing) & (pts[:, 1] < rows + 2 * spacing))
        lab = voronoi_labels(pts[visible], (rows, cols)).astype(np.int64)
        present = np.unique(lab)
        frames.append(lab)
        all_seeds.append(dict(zip(present.tolist(), ids[visible][present - 1].tolist())))
    labels = np.stack(frames)
    if shuffle:
        labels, maps = relabel_movie(labels, seed=rng)
        for t, m in enumerate(maps):
            for new, old in m.items():
                truth[(t, new)] = int(all_seeds[t][old])
    else:
        for t, m in enumerate(all_seeds):
            for lab, s in m.items():
                truth[(t, lab)] = int(s)
    return FlowingMovie(labels, truth, parents, extruded, float(spacing))


# ----------------------------------------------------------------------------
# Vertex-model tissues at force balance (truth for force inference)
# ----------------------------------------------------------------------------

def periodic_voronoi_network(seeds, box) -> dict:
    """The exact junction network of the Voronoi tessellation of ``seeds`` in a periodic ``box``.

    Parameters
    ----------
    seeds : (n, 2) array
        Seed positions (x, y), px; cell ``k`` is the cell of ``seeds[k - 1]``.
    box : Box
        The periodic box.

    Returns
    -------
    dict
        The four tables of :mod:`hexatissue.schema` (``cells``, ``vertices``,
        ``edges``, ``cell_vertices``) as DataFrames of frame 0, positions in
        px (vertices wrapped into ``[0, L)``), polygons counter-clockwise in
        (x, y); no cell is a border cell.
    """
    seeds = box.wrap(np.asarray(seeds, dtype=float))
    n = len(seeds)
    if seeds.ndim != 2 or seeds.shape[1] != 2 or n < 9:
        raise InputError(f"seeds must be an (n, 2) array with n >= 9; got shape {seeds.shape}")
    shifts = np.array([(dx, dy) for dx in (-1, 0, 1) for dy in (-1, 0, 1)]) * box.lengths
    vor = Voronoi(np.concatenate([seeds + s for s in shifts]))
    centre = 4 * n  # the copies with shift (0, 0) are points 4n .. 5n - 1
    # a Voronoi vertex and its periodic copies are one vertex: wrapped positions equal to 1e-7 px
    wrapped = box.wrap(vor.vertices)
    tree = cKDTree(wrapped, boxsize=box.lengths)
    pairs = tree.query_pairs(1e-7, output_type="ndarray")
    m = len(wrapped)
    same = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(m, m))
    _, canon = connected_components(same, directed=False)
    polygons = []
    for k in range(n):
        region = vor.regions[vor.point_region[centre + k]]
        xy = vor.vertices[region]
        area = polygon_area_centroid(xy, np.zeros(1, np.int64))[0][0]
        order = np.asarray(region) if area > 0 else np.asarray(region)[::-1]
        polygons.append(canon[order])
    used, vid = np.unique(np.concatenate(polygons), return_inverse=True)
    polygons = np.split(vid, np.cumsum([len(p) for p in polygons])[:-1])
    first = np.full(canon.max() + 1, -1)
    first[canon] = np.arange(m)  # any member of each class
    vxy = wrapped[first[used]]
    cell_rows, rank_rows, vertex_rows = [], [], []
    sides = {}
    for k, poly in enumerate(polygons):
        cell_rows += [k + 1] * len(poly)
        rank_rows += list(range(len(poly)))
        vertex_rows += poly.tolist()
        for a, b in zip(poly, np.roll(poly, -1)):
            sides.setdefault((min(a, b), max(a, b)), []).append(k + 1)
    keys = sorted(sides)
    if any(len(sides[key]) != 2 for key in keys):
        raise InputError("seeds give a tessellation with a junction not between two cells; use more seeds")
    va = np.array([key[0] for key in keys])
    vb = np.array([key[1] for key in keys])
    ca = np.array([min(sides[key]) for key in keys])
    cb = np.array([max(sides[key]) for key in keys])
    length = np.hypot(*box.min_image(vxy[vb] - vxy[va]).T)
    degree = np.bincount(np.r_[va, vb], minlength=len(vxy))
    area, centroid, perimeter = [], [], []
    for poly in polygons:
        xy = box.unwrap_polygon(vxy[poly])
        (a,), (c,) = polygon_area_centroid(xy, np.zeros(1, np.int64))
        area.append(a)
        centroid.append(box.wrap(c))
        perimeter.append(np.hypot(*np.diff(np.vstack([xy, xy[:1]]), axis=0).T).sum())
    centroid = np.array(centroid)
    nv = len(vxy)
    return {
        "cells": pd.DataFrame({"frame": 0, "cell": np.arange(1, n + 1), "x": centroid[:, 0], "y": centroid[:, 1],
                               "area": area, "polygon_area": area, "perimeter": perimeter,
                               "n_sides": [len(p) for p in polygons], "n_boundaries": 1, "is_border": False}),
        "vertices": pd.DataFrame({"frame": 0, "vertex": np.arange(nv), "x": vxy[:, 0], "y": vxy[:, 1],
                                  "degree": degree, "is_border": False}),
        "edges": pd.DataFrame({"frame": 0, "edge": np.arange(len(keys)), "vertex_a": va, "vertex_b": vb,
                               "cell_a": ca, "cell_b": cb, "length": length}),
        "cell_vertices": pd.DataFrame({"frame": 0, "cell": cell_rows, "rank": rank_rows, "vertex": vertex_rows}),
    }


def _polygon_rows(cell_vertices):
    """Row order of cell_vertices by (cell, rank), the next row in each polygon, and each row's first row."""
    cell = cell_vertices["cell"].to_numpy(np.int64)
    order = np.lexsort((cell_vertices["rank"].to_numpy(np.int64), cell))
    c = cell[order]
    start = np.r_[True, c[1:] != c[:-1]]
    first = np.maximum.accumulate(np.where(start, np.arange(len(c)), 0))
    end = np.r_[start[1:], True]
    nxt = np.where(end, first, np.arange(len(c)) + 1)
    return order, nxt, first


class _VertexModel:
    """E = sum_j Lambda_j l_j + sum_c K / 2 (A_c - A0_c)^2 of a periodic network, and its gradient."""

    def __init__(self, tables, box, line_tension, K, A0):
        self.box, self.lam, self.K, self.A0 = box, line_tension, K, A0
        vpos = {v: k for k, v in enumerate(tables["vertices"]["vertex"].to_numpy())}
        edges, cv = tables["edges"], tables["cell_vertices"]
        self.va = np.array([vpos[v] for v in edges["vertex_a"].to_numpy()])
        self.vb = np.array([vpos[v] for v in edges["vertex_b"].to_numpy()])
        order, nxt, first = _polygon_rows(cv)
        self.v = np.array([vpos[v] for v in cv["vertex"].to_numpy()[order]])
        self.nxt, self.first = nxt, first
        cells = tables["cells"]["cell"].to_numpy()
        self.cell = pd.Index(cells).get_indexer(cv["cell"].to_numpy()[order])
        self.n_cells = len(cells)

    def areas(self, xy):
        r = self.box.min_image(xy[self.v] - xy[self.v[self.first]])  # positions relative to each polygon's first
        cross = r[:, 0] * r[self.nxt, 1] - r[self.nxt, 0] * r[:, 1]
        return 0.5 * np.bincount(self.cell, weights=cross, minlength=self.n_cells)

    def energy(self, flat):
        xy = flat.reshape(-1, 2)
        d = self.box.min_image(xy[self.vb] - xy[self.va])
        length = np.hypot(d[:, 0], d[:, 1])
        area = self.areas(xy)
        energy = np.sum(self.lam * length) + 0.5 * self.K * np.sum((area - self.A0) ** 2)
        grad = np.zeros_like(xy)
        f = self.lam[:, None] * d / length[:, None]
        np.add.at(grad, self.vb, f)
        np.add.at(grad, self.va, -f)
        prev = np.empty_like(self.nxt)
        prev[self.nxt] = np.arange(len(self.nxt))
        chord = (self.box.min_image(xy[self.v[self.nxt]] - xy[self.v])
                 - self.box.min_image(xy[self.v[prev]] - xy[self.v]))
        dA = 0.5 * np.stack([chord[:, 1], -chord[:, 0]], axis=1)
        np.add.at(grad, self.v, (self.K * (area - self.A0))[self.cell, None] * dA)
        return energy, grad.ravel()


def vertex_model_tissue(nx=10, ny=10, spacing=20.0, jitter=0.1, tension_spread=0.15, area_spread=0.1, K=0.01,
                        seed=0, row_spacing=None):
    """A periodic vertex-model tissue at force balance, with its exact tensions and pressures.

    The Voronoi tissue of a jittered hexagonal lattice in a periodic box,
    relaxed to the minimum of ``E = sum_j Lambda_j l_j + sum_c K / 2 (A_c -
    A0_c)^2`` (L-BFGS, then Newton steps with finite-difference Hessian
    products to a largest vertex force below 1e-11 x the mean tension).  At the
    minimum the tension of junction ``j`` is ``Lambda_j`` and the pressure of
    cell ``c`` is ``-K (A_c - A0_c)``.

    Parameters
    ----------
    nx, ny : int
        Cells per lattice row and rows (``ny`` even: the lattice is periodic).
    spacing : float
        Lattice pitch, px.
    jitter : float
        Seeds moved by up to ``jitter x spacing`` along x and y.  Larger
        values with larger ``tension_spread`` let junctions shrink to
        nothing (the model has no T1s): an error then.
    tension_spread : float
        ``Lambda_j`` uniform in ``[1 - spread, 1 + spread]``.
    area_spread : float
        ``A0_c`` uniform in ``[1 - spread, 1 + spread]`` x the mean cell area.
    K : float
        Area stiffness, tension/px^3.
    seed : int or numpy.random.Generator
    row_spacing : float, optional
        Distance between lattice rows, px (default ``spacing sqrt(3) / 2``,
        regular hexagons); another value gives a box of another height, e.g.
        a whole number of pixels for :func:`network_labels`.

    Returns
    -------
    tables : dict
        ``cells``, ``vertices``, ``edges``, ``cell_vertices`` at the minimum
        (:func:`periodic_voronoi_network`).
    tension : ndarray
        Per row of ``edges``: ``Lambda_j`` (tension units).
    pressure : ndarray
        Per row of ``cells``: ``-K (A_c - A0_c)`` (tension/px).
    box : Box
    """
    from scipy.optimize import minimize
    from scipy.sparse.linalg import LinearOperator, minres

    for name, value in (("nx", nx), ("ny", ny)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 4:
            raise InputError(f"{name} must be an integer >= 4; got {value!r}")
    if ny % 2:
        raise InputError(f"ny must be even (a periodic hexagonal lattice); got {ny!r}")
    rng = as_generator(seed)
    row = spacing * np.sqrt(3) / 2 if row_spacing is None else float(row_spacing)
    if not row > 0:
        raise InputError(f"row_spacing must be a positive number or None; got {row_spacing!r}")
    box = Box(nx * spacing, ny * row)
    X, Y = np.meshgrid(np.arange(nx) * spacing, np.arange(ny) * row)
    X = X + (np.arange(ny)[:, None] % 2) * spacing / 2
    seeds = np.stack([X.ravel(), Y.ravel()], axis=1) + rng.uniform(-jitter, jitter, (nx * ny, 2)) * spacing
    tables = periodic_voronoi_network(seeds, box)
    lam = rng.uniform(1 - tension_spread, 1 + tension_spread, len(tables["edges"]))
    A0 = box.Lx * box.Ly / (nx * ny) * rng.uniform(1 - area_spread, 1 + area_spread, nx * ny)
    model = _VertexModel(tables, box, lam, K, A0)
    x = minimize(model.energy, tables["vertices"][["x", "y"]].to_numpy(float).ravel(), jac=True, method="L-BFGS-B",
                 options={"maxiter": 100000, "maxfun": 200000, "ftol": 0.0, "gtol": 1e-10, "maxcor": 30}).x
    # L-BFGS stalls near 1e-7 (the energy's relative precision); Newton steps take the force to round-off
    for _ in range(6):
        grad = model.energy(x)[1]
        if np.abs(grad).max() < 1e-11:
            break
        h = 1e-4
        hess = LinearOperator((len(x), len(x)), dtype=float,
                              matvec=lambda v, x=x: (model.energy(x + h * v)[1] - model.energy(x - h * v)[1]) / (2 * h))
        x = x + minres(hess, -grad, rtol=1e-12, maxiter=5000)[0]
    xy = box.wrap(x.reshape(-1, 2))
    force = np.abs(model.energy(xy.ravel())[1]).max()
    d = box.min_image(xy[model.vb] - xy[model.va])
    shortest = float(np.hypot(d[:, 0], d[:, 1]).min())
    if force > 1e-10 or shortest < 0.05 * spacing:
        raise InputError(f"the vertex model did not reach a force balance with every junction kept (largest force "
                         f"{force:.1e}, shortest junction {shortest:.2g} px): lower jitter or tension_spread")
    tables = _with_positions(tables, xy, box)
    return tables, lam, -K * (model.areas(xy) - A0), box


def arc_vertex_model_tissue(nx=10, ny=10, spacing=20.0, jitter=0.1, tension_spread=0.15, area_spread=0.1, K=0.01,
                            seed=0):
    """A periodic tissue of circular-arc junctions at force balance, with its exact tensions and pressures.

    From the straight vertex model :func:`vertex_model_tissue` (tensions
    ``Lambda_j``, pressures ``P_c``, vertices balanced by ``sum_j Lambda_j u_j
    + sum_j (P_left - P_right) c_j / 2 n_j = 0``, ``n_j`` the chord's left
    normal): each junction becomes the arc through the same vertices of half
    angle ``psi_j = atan((P_left - P_right) c_j / (2 Lambda_j))`` with
    tension ``T_j = Lambda_j / cos psi_j``.  Then ``T_j`` along the arc's end
    tangents gives the same vertex forces (force balance), and ``T_j kappa_j =
    P_left - P_right`` (Young-Laplace): an exact equilibrium of free arcs.

    Parameters
    ----------
    nx, ny, spacing, jitter, tension_spread, area_spread, K, seed
        As :func:`vertex_model_tissue`.

    Returns
    -------
    tables : dict
        As :func:`vertex_model_tissue`, with ``edges.curvature`` (1/px,
        signed: positive when the arc turns counter-clockwise from
        ``vertex_a`` to ``vertex_b``).
    tension : ndarray
        Per row of ``edges``: ``T_j`` (tension units).
    pressure : ndarray
        Per row of ``cells``: ``P_c`` (tension/px).
    box : Box
    """
    return arcs_at_balance(*vertex_model_tissue(nx, ny, spacing, jitter, tension_spread, area_spread, K, seed))


def arcs_at_balance(tables, lam, pressure, box):
    """The straight vertex model at force balance ``tables, lam, pressure, box`` redrawn with circular arcs.

    The construction of :func:`arc_vertex_model_tissue`, which calls it with
    :func:`vertex_model_tissue`'s output; returns the same four values.
    """
    edges, cv = tables["edges"], tables["cell_vertices"].sort_values(["cell", "rank"])
    nxt = cv.groupby("cell")["vertex"].transform(lambda v: np.roll(v.to_numpy(), -1))
    step = pd.DataFrame({"v": cv["vertex"].to_numpy(), "w": nxt.to_numpy(), "cell": cv["cell"].to_numpy()})
    ends = pd.DataFrame({"v": edges["vertex_a"].to_numpy(), "w": edges["vertex_b"].to_numpy()})
    left = ends.merge(step, on=["v", "w"], how="left")["cell"].to_numpy()
    right = ends.rename(columns={"v": "w", "w": "v"}).merge(step, on=["v", "w"], how="left")["cell"].to_numpy()
    p_of = pd.Series(pressure, index=tables["cells"]["cell"].to_numpy())
    c = edges["length"].to_numpy(float)
    psi = np.arctan((p_of[left].to_numpy() - p_of[right].to_numpy()) * c / (2 * lam))
    tables = {k: v.copy() for k, v in tables.items()}
    tables["edges"]["curvature"] = 2 * np.sin(psi) / c
    return tables, lam / np.cos(psi), pressure, box


def _with_positions(tables, xy, box):
    """The network tables with the vertices moved to ``xy`` (geometry columns recomputed)."""
    out = {k: v.copy() for k, v in tables.items()}
    out["vertices"]["x"], out["vertices"]["y"] = xy[:, 0], xy[:, 1]
    edges = out["edges"]
    vpos = pd.Index(out["vertices"]["vertex"].to_numpy()).get_indexer
    d = box.min_image(xy[vpos(edges["vertex_b"].to_numpy())] - xy[vpos(edges["vertex_a"].to_numpy())])
    edges["length"] = np.hypot(d[:, 0], d[:, 1])
    cv = out["cell_vertices"].sort_values(["cell", "rank"])
    cells = out["cells"]
    for row, (cell, group) in enumerate(cv.groupby("cell", sort=True)):
        poly = box.unwrap_polygon(xy[vpos(group["vertex"].to_numpy())])
        (a,), (c,) = polygon_area_centroid(poly, np.zeros(1, np.int64))
        k = cells.index[cells["cell"] == cell][0]
        cells.loc[k, ["x", "y"]] = box.wrap(c)
        cells.loc[k, ["area", "polygon_area"]] = a
        cells.loc[k, "perimeter"] = np.hypot(*np.diff(np.vstack([poly, poly[:1]]), axis=0).T).sum()
    return out


def network_labels(tables, box, scale=1.0):
    """The label image of a periodic network of straight junctions, its polygons drawn at ``scale`` px per unit.

    Pixel ``(row, col)`` (centre ``x = col``, ``y = row`` in px) gets the id
    of the cell whose polygon, scaled by ``scale``, holds its centre; the
    image covers the scaled box, which must be a whole number of pixels in
    both directions (so the image is periodic).

    Parameters
    ----------
    tables : dict
        ``cells``, ``vertices``, ``cell_vertices`` of a network in ``box``
        (e.g. :func:`vertex_model_tissue`); cell ids >= 1.
    box : Box
    scale : float
        Pixels per unit of the network's coordinates.

    Returns
    -------
    labels : ndarray (H, W) of int32
        Cell ids; every pixel belongs to a cell.
    box : Box
        The scaled box, ``(W, H)``.
    """
    from skimage.draw import polygon as draw_polygon

    if not (np.isfinite(scale) and scale > 0):
        raise InputError(f"scale must be a positive finite number; got {scale!r}")
    width, height = box.Lx * scale, box.Ly * scale
    W, H = int(round(width)), int(round(height))
    if abs(width - W) > 1e-6 or abs(height - H) > 1e-6:
        raise InputError(f"scale must make the box a whole number of pixels; {scale!r} gives {width:g} x {height:g}")
    xy = tables["vertices"][["x", "y"]].to_numpy(float)
    vpos = {v: k for k, v in enumerate(tables["vertices"]["vertex"].to_numpy())}
    labels = np.zeros((H, W), np.int32)
    cv = tables["cell_vertices"].sort_values(["cell", "rank"])
    for cell, group in cv.groupby("cell", sort=True):
        poly = box.unwrap_polygon(xy[[vpos[v] for v in group["vertex"].to_numpy()]]) * scale
        # pixel centres inside the polygon, shifted so the polygon lies at non-negative coordinates, then wrapped
        shift = np.floor(poly.min(axis=0))
        rr, cc = draw_polygon(poly[:, 1] - shift[1], poly[:, 0] - shift[0])
        labels[(rr + int(shift[1])) % H, (cc + int(shift[0])) % W] = cell
    if (labels == 0).any():
        raise InputError("the polygons of tables do not cover the box (is it a periodic tiling?)")
    return labels, Box(W, H)
