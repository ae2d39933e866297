"""The numba mesh kernels on small hand-made label images, against hand-written truth and the plain-Python reference.

Every case asserts the kernels' outputs against values worked out by hand
(docstrings say how) and that the reference in ``hexatissue.mesh._reference``
gives exactly the same; a randomized test does the latter on jittered
Voronoi tissues.  Corner (ci, cj) is at x = cj - 0.5, y = ci - 0.5;
directions 0 +x, 1 +y, 2 -x, 3 -y; left and right in x-y axes (see
``_kernels``).  Vertex ids are corners in raster order.
"""
import warnings
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from hexatissue.mesh import _kernels as K
from hexatissue.mesh import _reference as R
from hexatissue.mesh import network as N
from hexatissue.mesh.labels import normalize_labels
from hexatissue.synthetic import jittered_seeds, voronoi_labels

JUNCTION_FIELDS = ("start", "end", "start_arm", "end_arm", "left", "right", "dx", "dy", "ncrack")
LOOP_FIELDS = ("row", "col", "left", "right", "dx", "dy", "ncrack")


def run(impl, labels, periodic=False, membrane=None, max_reach=N.ARM_REACH):
    """corner_types -> trace_junctions (+ arm fits) -> mark_junctions -> trace_loops of ``impl`` (kernel or reference).

    ``max_reach`` overrides the network's arm reach.
    """
    lab = np.asarray(labels, np.int32)
    membrane = np.zeros(lab.shape, bool) if membrane is None else membrane
    flags = N._membrane_flags(membrane, periodic)  # as network._trace gives them: size 0 for touching labels
    corners, vi, vj, n_cracks = impl.corner_types(lab, periodic)
    arms, kind = corners & 15, corners >> 4  # one byte per corner: arm bits | type << 4
    *junctions, count, mean, direction = impl.trace_junctions(lab, periodic, corners, vi, vj, 4 * len(vi) + 1,
                                                              flags, max_reach)
    visited = impl.mark_junctions(periodic, corners, vi, vj, junctions[0], junctions[2])
    vid = R._vertex_map(arms.shape, vi, vj)  # vertex ids are the ranks of the vertices in raster order
    loops = impl.trace_loops(lab, periodic, corners, visited.copy())  # the kernel marks the loops in `visited`
    return SimpleNamespace(
        arms=arms, kind=kind, vid=vid, vi=vi, vj=vj, n_cracks=n_cracks, visited=visited,
        j=dict(zip(JUNCTION_FIELDS, junctions)), loops=dict(zip(LOOP_FIELDS, loops)),
        count=count, mean=mean, direction=direction,
    )


def assert_same_axis(a, b):
    """Unit line directions equal up to sign (the sign of a line's axis is an artefact)."""
    np.testing.assert_allclose(np.linalg.norm(a, axis=-1), 1.0, atol=1e-12)
    np.testing.assert_allclose(np.abs(np.sum(a * b, axis=-1)), 1.0, atol=1e-9)


def assert_kernels_match_reference(k, r):
    for name in ("arms", "kind", "vi", "vj", "visited", "count"):
        a, b = getattr(k, name), getattr(r, name)
        assert a.dtype == b.dtype, name
        np.testing.assert_array_equal(a, b, err_msg=name)
    assert k.n_cracks == r.n_cracks
    # junctions and loops come in a defined order (first end / first crack in raster order): compare as they are
    for table in ("j", "loops"):
        for name, a in getattr(k, table).items():
            b = getattr(r, table)[name]
            assert a.dtype == b.dtype, name
            np.testing.assert_array_equal(a, b, err_msg=f"{table}.{name}")
    np.testing.assert_allclose(k.mean, r.mean, rtol=0, atol=1e-12)
    used = k.count > 0
    assert_same_axis(k.direction[used], r.direction[used])
    assert not k.direction[~used].any() and not k.mean[~used].any()


def both(labels, periodic=False, membrane=None, max_reach=N.ARM_REACH):
    """The kernels' outputs, after checking that the reference gives the same."""
    k = run(K, labels, periodic, membrane, max_reach)
    assert_kernels_match_reference(k, run(R, labels, periodic, membrane, max_reach))
    return k


def vertex(k, ci, cj):
    v = int(k.vid[ci, cj])
    assert v >= 0, f"corner ({ci}, {cj}) is not a vertex"
    return v


def junction_rows(k):
    return [tuple(int(k.j[f][i]) for f in JUNCTION_FIELDS) for i in range(len(k.j["start"]))]


def arms_seen_from(k, v):
    """{arm: (other vertex, its arm, left, right, dx, dy, cracks)} of the junctions at vertex v, walked from v."""
    out = {}
    for s, e, sa, ea, left, right, dx, dy, n in junction_rows(k):
        if s == v:
            out[sa] = (e, ea, left, right, dx, dy, n)
        if e == v:
            out[ea] = (s, sa, right, left, -dx, -dy, n)
    return out


def loop_rows(k):
    return [tuple(int(k.loops[f][i]) for f in LOOP_FIELDS) for i in range(len(k.loops["row"]))]


# --- corner types and junctions -----------------------------------------------------------------

def test_two_cells_side_by_side():
    """3 x 4 image, cells 1 | 2: the boundary x = 1.5 runs down corner column 2 from (0, 2) to (3, 2).

    Vertices: the two ends (three-fold: two cells and the outside) and the
    four image corners.  Every junction worked out by walking the lattice.
    """
    labels = np.array([[1, 1, 2, 2]] * 3)
    k = both(labels)
    assert list(zip(k.vi, k.vj)) == [(0, 0), (0, 2), (0, 4), (3, 0), (3, 2), (3, 4)]
    assert k.kind[0, 2] == k.kind[3, 2] == 3 and k.arms[0, 2] == 0b0111 and k.arms[3, 2] == 0b1101
    assert k.kind[0, 0] == 2 and k.kind[1, 2] == k.kind[2, 2] == 2
    assert junction_rows(k) == [
        # start, end, start arm, end arm, left, right, dx, dy, cracks
        (0, 1, 0, 2, 1, 0, 2, 0, 2),  # top edge of cell 1
        (0, 3, 1, 3, 0, 1, 0, 3, 3),  # left edge
        (1, 2, 0, 2, 2, 0, 2, 0, 2),  # top edge of cell 2
        (1, 4, 1, 3, 1, 2, 0, 3, 3),  # the 1 | 2 junction: moving +y, cell 1 (x < 1.5) is on the left
        (2, 5, 1, 3, 2, 0, 0, 3, 3),
        (3, 4, 0, 2, 0, 1, 2, 0, 2),
        (4, 5, 0, 2, 0, 2, 2, 0, 2),
    ]
    assert k.n_cracks == 2 * (3 + 4) + 3 and k.visited.sum() == k.n_cracks
    assert loop_rows(k) == []


def test_three_cell_t_junction():
    """5 x 6 image: 1 (cols 0-1) and 2 (cols 2-5) over 3 (rows 3-4); the T corner is (3, 2).

    Its block is TL 1, TR 2, BL 3, BR 3: arms 0 (2 | 3), 2 (1 | 3), 3 (1 | 2);
    they reach the image edge after 4, 2 and 3 cracks.
    """
    labels = np.ones((5, 6), int)
    labels[:3, 2:] = 2
    labels[3:] = 3
    k = both(labels)
    t = vertex(k, 3, 2)
    assert k.kind[3, 2] == 3 and k.arms[3, 2] == 0b1101
    assert {(int(i), int(j)) for i, j in zip(*np.nonzero(k.kind == 3))} == {(0, 2), (3, 0), (3, 2), (3, 6)}
    assert arms_seen_from(k, t) == {
        0: (vertex(k, 3, 6), 2, 3, 2, 4, 0, 4),
        2: (vertex(k, 3, 0), 0, 1, 3, -2, 0, 2),
        3: (vertex(k, 0, 2), 1, 2, 1, 0, -3, 3),
    }


def test_four_fold_corner():
    """4 x 4 image of four 2 x 2 quadrants 1 2 / 3 4: corner (2, 2) has four distinct labels, four arms of 2 cracks."""
    labels = np.repeat(np.repeat([[1, 2], [3, 4]], 2, axis=0), 2, axis=1)
    k = both(labels)
    assert k.arms[2, 2] == 0b1111
    assert list(zip(*np.nonzero(k.kind == 4))) == [(2, 2)]
    assert arms_seen_from(k, vertex(k, 2, 2)) == {
        0: (vertex(k, 2, 4), 2, 4, 2, 2, 0, 2),
        1: (vertex(k, 4, 2), 3, 3, 4, 0, 2, 2),
        2: (vertex(k, 2, 0), 0, 1, 3, -2, 0, 2),
        3: (vertex(k, 0, 2), 1, 2, 1, 0, -2, 2),
    }
    assert k.n_cracks == 16 + 8


def test_cell_inside_another_is_a_loop_without_vertex():
    """6 x 6 image of 1 with a 2 x 2 cell 2 at rows/cols 2-3: its boundary (8 cracks) has no vertex.

    Only the image edge is traced as junctions (4 x 6 cracks between the
    image corners); the loop starts at its first crack, the top of pixel
    (2, 2) leaving corner (2, 2) along +x, with cell 2 below it, on the left.
    """
    labels = np.ones((6, 6), int)
    labels[2:4, 2:4] = 2
    k = both(labels)
    assert len(k.vi) == 4 and sorted(k.j["ncrack"]) == [6] * 4
    assert k.n_cracks == 24 + 8 and k.visited.sum() == 24
    assert loop_rows(k) == [(2, 2, 2, 1, 0, 0, 8)]


@pytest.mark.parametrize(
    "pixels, background, corner_kind, loops",
    [
        # 2 at (1, 1) and 3 at (2, 2): TR = BL = 1 is connected (type 6); two 4-crack loops
        ({(1, 1): 2, (2, 2): 3}, 1, 6, [(1, 1, 2, 1, 0, 0, 4), (2, 2, 3, 1, 0, 0, 4)]),
        # 2 at (1, 2) and 3 at (2, 1): TL = BR = 1 is connected (type 5)
        ({(1, 2): 2, (2, 1): 3}, 1, 5, [(1, 2, 2, 1, 0, 0, 4), (2, 1, 3, 1, 0, 0, 4)]),
        # two labels in a checkerboard, 2 on the diagonal, 1 off it: the smaller (1) is connected, so 2 is in two pieces
        ({(1, 1): 2, (2, 2): 2}, 1, 6, [(1, 1, 2, 1, 0, 0, 4), (2, 2, 2, 1, 0, 0, 4)]),
        # the same with 3 off the diagonal: now 2 is the smaller and connected: one loop of 8 cracks through (2, 2) twice
        ({(1, 1): 2, (2, 2): 2}, 3, 5, [(1, 1, 2, 3, 0, 0, 8)]),
    ],
)
def test_diagonal_contact_tie_rule(pixels, background, corner_kind, loops):
    """Two pixels touching diagonally at corner (2, 2) in a 4 x 4 image: no vertex; the connected label decides the loops."""
    labels = np.full((4, 4), background)
    for (i, j), lab in pixels.items():
        labels[i, j] = lab
    k = both(labels)
    assert k.arms[2, 2] == 0b1111 and k.kind[2, 2] == corner_kind and k.vid[2, 2] == -1
    assert len(k.vi) == 4  # only the image corners
    assert loop_rows(k) == loops


def test_junctions_wrap_around_the_torus():
    """6 x 8 torus: 1 in cols 0-3; 2 (rows 0-2) over 3 (rows 3-5) in cols 4-7.

    Vertices (0, 0), (0, 4), (3, 0), (3, 4).  Boundaries run down corner
    columns 0 and 4 and along corner rows 0 and 3; those at column 0 and
    row 0 are between pixels on opposite image edges.  A junction leaving
    (0, 0) along -x wraps to column 7 and ends at (0, 4) after 4 cracks:
    its displacement is -4, where the corners' columns differ by +4.
    """
    labels = np.ones((6, 8), int)
    labels[:3, 4:] = 2
    labels[3:, 4:] = 3
    k = both(labels, periodic=True)
    assert list(zip(k.vi, k.vj)) == [(0, 0), (0, 4), (3, 0), (3, 4)]
    assert (k.kind[k.vi, k.vj] == 3).all()
    assert junction_rows(k) == [
        (0, 2, 1, 3, 2, 1, 0, 3, 3),  # down column 0 (left: pixels of column 7, cell 2)
        (0, 1, 2, 0, 3, 2, -4, 0, 4),  # along row 0 to the left, wrapping: between row 5 (3) and row 0 (2)
        (0, 2, 3, 1, 1, 3, 0, -3, 3),  # up column 0, wrapping through row 5
        (1, 3, 1, 3, 1, 2, 0, 3, 3),
        (1, 3, 3, 1, 3, 1, 0, -3, 3),  # up column 4, wrapping
        (2, 3, 2, 0, 2, 3, -4, 0, 4),  # along row 3 to the left, wrapping
    ]
    assert k.n_cracks == 6 + 6 + 4 + 4 and k.visited.sum() == k.n_cracks
    assert loop_rows(k) == []


def test_loops_around_the_torus():
    """Bands on a torus: boundaries without vertices whose net displacement is a whole box length.

    Horizontal bands (6 x 8): two loops of 8 cracks, dx = 8.  Width-2
    diagonal bands on a 4 x 4 torus (label 1 where (row - col) mod 4 < 2):
    staircases along (1, 1) that close after (4, 4); every corner has two arms.
    """
    labels = np.ones((6, 8), int)
    labels[3:] = 2
    k = both(labels, periodic=True)
    assert len(k.vi) == 0 and len(k.j["start"]) == 0
    # first crack: corner (0, 0) along +x, between row 5 (2, above) and row 0 (1, below: on the left)
    assert loop_rows(k) == [(0, 0, 1, 2, 8, 0, 8), (3, 0, 2, 1, 8, 0, 8)]

    i, j = np.indices((4, 4))
    k = both(np.where((i - j) % 4 < 2, 1, 2), periodic=True)
    assert (k.kind == 2).all() and len(k.vi) == 0
    rows = loop_rows(k)
    assert [r[4:] for r in rows] == [(4, 4, 8)] * 2
    assert {r[2:4] for r in rows} == {(1, 2), (2, 1)}


# --- arm line fits ------------------------------------------------------------------------------

@pytest.fixture
def straight():
    """10 x 6 image, cells 1 | 2: the junction from (0, 3) down to (10, 3), 10 cracks, midpoints (0, k + 0.5)."""
    labels = np.ones((10, 6), int)
    labels[:, 3:] = 2
    return labels


def fit(k, ci, cj, d):
    v = vertex(k, ci, cj)
    return int(k.count[v, d]), tuple(k.mean[v, d]), k.direction[v, d]


def test_arm_lines_on_a_straight_junction(straight):
    k = both(straight)  # the network's reach: half the junction, 5 cracks
    n, mean, direction = fit(k, 0, 3, 1)
    assert (n, mean) == (5, (0.0, 2.5))
    assert_same_axis(direction, np.array([0.0, 1.0]))
    assert fit(k, 10, 3, 3)[:2] == (5, (0.0, -2.5))

    for r, expect in [(1, (1, 0.5)), (4, (4, 2.0)), (30, (5, 2.5))]:  # at most r cracks, at most half the junction
        kr = both(straight, max_reach=r)
        assert fit(kr, 0, 3, 1)[:2] == (expect[0], (0.0, expect[1]))
        assert fit(kr, 10, 3, 3)[:2] == (expect[0], (0.0, -expect[1]))
        assert_same_axis(fit(kr, 0, 3, 1)[2], np.array([0.0, 1.0]))
        if r == 1:  # a single crack: exactly the arm direction
            assert fit(kr, 0, 3, 1)[2].tolist() == [0.0, 1.0]


def test_arm_lines_follow_membrane_pixels(straight):
    """Membrane pixels beside a crack move its fit point to their centre: column 2 -> x = -0.5; both sides -> midpoint."""
    for cols, x in [((2,), -0.5), ((3,), 0.5), ((2, 3), 0.0)]:
        membrane = np.zeros(straight.shape, bool)
        membrane[:, list(cols)] = True
        k = both(straight, membrane=membrane, max_reach=4)
        n, mean, direction = fit(k, 0, 3, 1)
        assert (n, mean) == (4, (x, 2.0))
        assert_same_axis(direction, np.array([0.0, 1.0]))
        assert fit(k, 10, 3, 3)[:2] == (4, (x, -2.0))  # fitted from the junction's end: the same points


def test_arm_lines_on_a_bent_junction():
    """12 x 12 image of 1 with cell 2 in rows 4.. and columns 10..: the junction (4, 12) -> (4, 10) -> (12, 10) bends.

    It has 2 + 8 = 10 cracks, so each arm fits 5.  From (4, 12) along -x
    the points are (-0.5, 0), (-1.5, 0), (-2, 0.5), (-2, 1.5), (-2, 2.5):
    mean (-1.6, 0.9), an axis between the two legs (covariance xx 0.34,
    xy -0.36, yy 0.94: theta = atan2(-0.72, -0.6) / 2).  From (12, 10) along -y
    the 5 points are straight: mean (0, -2.5), axis (0, 1).
    """
    labels = np.ones((12, 12), int)
    labels[4:, 10:] = 2
    k = both(labels)
    n, mean, direction = fit(k, 4, 12, 2)
    assert n == 5
    np.testing.assert_allclose(mean, (-1.6, 0.9), rtol=0, atol=1e-15)
    theta = np.arctan2(-0.72, -0.6) / 2
    assert_same_axis(direction, np.array([np.cos(theta), np.sin(theta)]))
    assert fit(k, 12, 10, 3)[:2] == (5, (0.0, -2.5))
    assert_same_axis(fit(k, 12, 10, 3)[2], np.array([0.0, 1.0]))


# --- chaining half-edges into cycles -----------------------------------------------------------

def chain_both(cell, frm, to):
    cell, frm, to = (np.asarray(a, np.int64) for a in (cell, frm, to))
    out = K.chain_cycles(cell, frm, to)
    for a, b in zip(out, R.chain_cycles(cell, frm, to)):
        assert a.dtype == b.dtype
        np.testing.assert_array_equal(a, b)
    return [a.tolist() for a in out]


def test_chain_two_adjacent_squares():
    """Vertices 0 1 2 on y = 0 and 3 4 5 on y = 1: cell 1 = 0 1 4 3, cell 2 = 1 2 5 4 (counter-clockwise).

    Half-edges sorted by (cell, from): cell 1: 0>1, 1>4, 3>0, 4>3; cell 2: 1>2, 2>5, 4>1, 5>4.
    """
    cycle, order, starts = chain_both([1, 1, 1, 1, 2, 2, 2, 2], [0, 1, 3, 4, 1, 2, 4, 5], [1, 4, 0, 3, 2, 5, 1, 4])
    assert cycle == [0] * 4 + [1] * 4
    assert order == [0, 1, 3, 2, 4, 5, 7, 6]
    assert starts == [0, 4, 8]


def test_chain_cell_with_a_hole():
    """Cell 1: outer square 0 1 2 3 and the hole's boundary 4 7 6 5 (reversed); cell 2 fills the hole 4 5 6 7."""
    cell = [1] * 8 + [2] * 4
    frm = [0, 1, 2, 3, 4, 5, 6, 7, 4, 5, 6, 7]
    to = [1, 2, 3, 0, 7, 4, 5, 6, 5, 6, 7, 4]
    cycle, order, starts = chain_both(cell, frm, to)
    assert cycle == [0] * 4 + [1] * 4 + [2] * 4
    assert order == [0, 1, 2, 3, 4, 7, 6, 5, 8, 9, 10, 11]
    assert starts == [0, 4, 8, 12]


def test_chain_pinched_cell_and_empty_input():
    """A figure-8 through vertex 0 (0 1 2 and 0 3 4): the first unused half-edge at 0 joins both loops in one cycle."""
    cycle, order, starts = chain_both([1] * 6, [0, 0, 1, 2, 3, 4], [1, 3, 2, 0, 4, 0])
    assert cycle == [0] * 6 and order == [0, 2, 3, 1, 4, 5] and starts == [0, 6]
    assert chain_both([], [], []) == [[], [], [0]]


# --- pixel moments ------------------------------------------------------------------------------

def test_cell_moments_unwrap_on_the_torus():
    """4 x 6 image: 1 in columns 0 and 5, 2 in columns 1-4.

    On the torus each pixel is taken within half a box of its label's circular
    mean: cell 1 (columns 0 and 5) is centred at column 5.5, so column 0 is
    column 6; cell 2 at 2.5.  Along y both cells are bands around the whole
    torus, so their first pixel's row 0 is the reference and row 3 (3 > 4 / 2
    below row 0) is row -1.
    """
    labels = np.full((4, 6), 2, np.int32)
    labels[:, [0, 5]] = 1
    for periodic, sx1, rows in [(False, 4 * (0 + 5), 0 + 1 + 2 + 3), (True, 4 * (6 + 5), 0 + 1 + 2 - 1)]:
        count, sx, sy = K.cell_moments(labels, 3, periodic)
        for a, b in zip((count, sx, sy), R.cell_moments(labels, 3, periodic)):
            assert a.dtype == b.dtype
            np.testing.assert_array_equal(a, b)
        assert count.tolist() == [0, 8, 16] and sx.tolist() == [0, sx1, 4 * 10] and sy.tolist() == [0, 2 * rows, 4 * rows]


# --- randomized ---------------------------------------------------------------------------------

def chain_traced(k):
    """Chain the half-edges of every traced junction and loop point (its cell on the left), as the polygons kernel does."""
    loop_v = len(k.vi) + np.arange(len(k.loops["row"]))
    a, b = np.r_[k.j["start"], loop_v], np.r_[k.j["end"], loop_v]
    cell = np.r_[k.j["left"], k.loops["left"], k.j["right"], k.loops["right"]].astype(np.int64)
    frm, to = np.r_[a, b], np.r_[b, a]
    inside = cell != 0
    cell, frm, to = cell[inside], frm[inside], to[inside]
    order = order_both(cell, frm)
    return chain_both(cell[order], frm[order], to[order]), cell


def order_both(cell, frm):
    """half_edge_order of the kernel, checked against its reference."""
    cell, frm = np.asarray(cell, np.int64), np.asarray(frm, np.int64)
    n_cells = int(cell.max()) + 1 if len(cell) else 0
    order = K.half_edge_order(cell, frm, n_cells)
    np.testing.assert_array_equal(order, R.half_edge_order(cell, frm, n_cells))
    return order


def test_half_edge_order_hand_made():
    """Cells 2 0 2 1 2 from vertices 5 3 1 4 1: cell 0 (index 1), cell 1 (3), cell 2 by vertex, the tie kept 2, 4."""
    assert order_both([2, 0, 2, 1, 2], [5, 3, 1, 4, 1]).tolist() == [1, 3, 2, 4, 0]
    assert order_both([], []).tolist() == []


def moments_both(labels, periodic):
    pixels = np.asarray(labels, np.int32)
    for a, b in zip(K.cell_moments(pixels, pixels.max() + 1, periodic), R.cell_moments(pixels, pixels.max() + 1, periodic)):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("periodic", [False, True], ids=["open", "periodic"])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_reference_equals_kernels_on_voronoi(periodic, seed):
    """Jittered Voronoi images, touching and with 1-px membranes (for the arm fits): every output equal."""
    shape = (22, 28)
    seeds = jittered_seeds(shape, 6, seed=seed)
    for membrane_width in (0, 1):
        raw = voronoi_labels(seeds, shape, periodic, membrane=membrane_width)
        labels, membrane = normalize_labels(raw, "membrane" if membrane_width else "touching", periodic)
        assert membrane.any() == bool(membrane_width)
        k = both(labels, periodic, membrane)
        assert len(k.vi) > 10 and (k.count > 0).sum() == 2 * len(k.j["start"])
        (_, _, starts), cell = chain_traced(k)
        assert len(starts) - 1 == len(np.unique(cell))  # Voronoi cells are convex: one cycle each
        moments_both(labels, periodic)


def test_reference_equals_kernels_on_random_labels():
    """Tiny images of random labels 0-4 (pixel noise and 2 x 2 blocks), open and periodic, random membranes, any reach.

    They are full of what Voronoi tissues rarely have: four-fold and
    diagonal corners, loops, cells in pieces or pinched, background 0.
    """
    rng = np.random.default_rng(11)
    seen = np.zeros(7, int)
    for case in range(40):
        labels = rng.integers(0, rng.integers(1, 5) + 1, rng.integers(2, 7, 2))
        if rng.random() < 0.5:
            labels = np.repeat(np.repeat(labels, 2, axis=0), 2, axis=1)
        periodic = bool(rng.random() < 0.5)
        membrane = rng.random(labels.shape) < 0.3
        k = both(labels, periodic, membrane)
        both(labels, periodic, membrane, max_reach=1 + case % 5)
        chain_traced(k)
        moments_both(labels, periodic)
        seen += np.bincount(k.kind.ravel(), minlength=7)
        seen[1] += len(k.loops["row"])  # (type 1 does not exist: count loops there)
    assert (seen[[1, 3, 4, 5, 6]] > 0).all()


# --- connected components (merged vertices) ---------------------------------------------------------

def test_components_hand_made():
    """Edges 3-1, 4-0, 0-2 on six vertices: {0, 2, 4} is component 0 (smallest vertex 0), {1, 3} is 1, {5} is 2."""
    for impl in (K, R):
        label, first = impl.components(6, np.array([3, 4, 0]), np.array([1, 0, 2]))
        assert label.tolist() == [0, 1, 0, 1, 0, 2] and first.tolist() == [0, 1, 5]


def test_components_equal_reference_and_scipy():
    """Random graphs (self-loops, repeated edges, no edge): kernel == reference == scipy's numbering."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    rng = np.random.default_rng(3)
    for _ in range(50):
        n = int(rng.integers(1, 40))
        m = int(rng.integers(0, 2 * n))
        a, b = rng.integers(0, n, m), rng.integers(0, n, m)
        label, first = K.components(n, a, b)
        ref_label, ref_first = R.components(n, a, b)
        _, scipy_label = connected_components(coo_matrix((np.ones(m), (a, b)), shape=(n, n)), directed=False)
        np.testing.assert_array_equal(label, ref_label)
        np.testing.assert_array_equal(first, ref_first)
        np.testing.assert_array_equal(label, scipy_label)
        np.testing.assert_array_equal(first, np.unique(label, return_index=True)[1])


def test_present_ids_equal_reference():
    """Which ids occur, for the label dtypes the mesh sees (uint8, uint16, int32, int64), incl. absent 0 and gaps."""
    rng = np.random.default_rng(8)
    for dtype in (np.uint8, np.uint16, np.int32, np.int64):
        for _ in range(5):
            labels = rng.choice([1, 3, 4, 9], size=tuple(rng.integers(1, 20, 2))).astype(dtype)
            top = int(labels.max()) + int(rng.integers(0, 3))
            np.testing.assert_array_equal(K.present_ids(labels, top), R.present_ids(labels, top))
    assert K.present_ids(np.array([[0, 2], [2, 5]], np.int32), 5).tolist() == [True, False, True, False, False, True]


def test_label_summary_equals_reference():
    """min, max, any nonzero and equal-neighbour counts for every integer dtype the readers give, and views."""
    rng = np.random.default_rng(9)
    for dtype in (np.uint8, np.uint16, np.uint32, np.uint64, np.int8, np.int16, np.int32, np.int64):
        for _ in range(4):
            labels = rng.integers(0, 4, tuple(rng.integers(2, 12, 2))).astype(dtype)
            assert K.label_summary(labels) == R.label_summary(labels)
            assert K.label_summary(labels[::2, 1:]) == R.label_summary(labels[::2, 1:]) if labels.shape[0] > 3 else True
    labels = np.array([[0, 0, 5], [0, 2, 5]], np.int32)  # pairs equal: 1 + 0 across, 1 + 0 + 1 down
    assert K.label_summary(labels) == (0, 5, True, 1, 2)
    assert K.label_summary(np.zeros((2, 2), np.uint8))[2] is False


@pytest.mark.parametrize("spacing", [9, 30])
def test_cell_moments_equal_reference_on_a_larger_torus(spacing):
    """64 x 72 periodic Voronoi (small cells, some across the edges; or a few cells wider than half the box)."""
    labels = voronoi_labels(jittered_seeds((64, 72), spacing, seed=7), (64, 72), True).astype(np.int32)
    labels = np.roll(labels, (5, 11), axis=(0, 1))  # cells across both edges
    for periodic in (True, False):
        moments_both(labels, periodic)


def test_arm_intersections_equal_reference():
    """Random arm lines of random clusters (parallel lines, empty clusters, far intersections): bit for bit."""
    rng = np.random.default_rng(12)
    for _ in range(30):
        nv, n_clusters = int(rng.integers(1, 30)), int(rng.integers(1, 10))
        cluster = rng.integers(0, n_clusters, nv)
        off = rng.normal(0, 1, (nv, 2))
        count = rng.integers(0, 9, (nv, 4))
        mean = rng.normal(0, 2, (nv, 4, 2))
        angle = rng.choice([0.0, np.pi / 2, rng.uniform(0, np.pi)], (nv, 4))  # some exactly parallel
        direction = np.stack([np.cos(angle), np.sin(angle)], axis=-1)
        m = int(rng.integers(0, 3 * nv))
        v, arm = rng.integers(0, nv, m), rng.integers(0, 4, m)
        args = (cluster, off, v, arm, count, mean, direction, n_clusters, 1.5)
        np.testing.assert_array_equal(K.arm_intersections(*args), R.arm_intersections(*args))
    # two perpendicular lines through (1, 0.5) relative to the centre of one cluster: the shift is that point
    direction = np.array([[[1.0, 0.0], [0.0, 1.0], [0, 0], [0, 0]]])
    mean = np.array([[[0.0, 0.5], [1.0, 0.0], [0, 0], [0, 0]]])
    shift = K.arm_intersections(np.array([0]), np.zeros((1, 2)), np.array([0, 0]), np.array([0, 1]),
                                np.ones((1, 4), np.int64), mean, direction, 1, 1.5)
    np.testing.assert_allclose(shift, [[1.0, 0.5]], atol=1e-15)


@pytest.mark.parametrize("labels", [
    [[2, 2, 0, 1, 0], [1, 2, 2, 2, 1], [0, 2, 2, 2, 2], [2, 1, 1, 2, 1], [2, 2, 2, 2, 0], [2, 0, 0, 0, 1]],
    [[1, 2, 1, 1, 0, 2], [1, 1, 1, 1, 1, 2], [2, 0, 0, 1, 2, 2], [2, 2, 0, 2, 2, 0]],
])
def test_cell_moments_pixels_half_a_box_away_tie_alike(labels):
    # scattered labels on tiny tori whose circular mean lies exactly half a box from some of their
    # pixels: numba's and numpy's cos/sin differ in the last bit, which used to pick different images
    labels = np.array(labels, np.int32)
    n = int(labels.max()) + 1
    for a, b in zip(K.cell_moments(labels, n, True), R.cell_moments(labels, n, True)):
        np.testing.assert_array_equal(a, b)


def test_merge_clusters_hand_made():
    """Vertices 0 (0, 0), 1 (1.5, 0), 2 (0.5, 1.9), 3 (0.5, 6), no arm lines (no sub-pixel shift), merge 2 px.

    Round 1 contracts 0-1 (1.5 px); junction 1-2 (2.15 px) then runs from the
    merged vertex (0.75, 0) to vertex 2: (-0.25, 1.9), 1.92 px, so round 2
    contracts it too.  The cluster {0, 1, 2} sits at the mean (2/3, 1.9/3);
    junction 2-3 is kept, from there to vertex 3: (0.5 - 2/3, 6 - 1.9/3).
    """
    pos = np.array([[0.0, 0.0], [1.5, 0.0], [0.5, 1.9], [0.5, 6.0]])
    start, end = np.array([0, 1, 2]), np.array([1, 2, 3])
    vec = pos[end] - pos[start]
    no_arm = -np.ones(3, np.int64)
    args = (pos, start, end, no_arm, no_arm, vec, np.zeros((4, 4), np.int64), np.zeros((4, 4, 2)),
            np.zeros((4, 4, 2)), np.zeros(2), 2.0, N.MAX_MERGE_ROUNDS, N.MAX_SHIFT)
    centre, keep, a, b, kvec = K.merge_clusters(*args)
    np.testing.assert_allclose(centre, [[2 / 3, 1.9 / 3], [0.5, 6.0]], atol=1e-15)
    np.testing.assert_array_equal(keep, [False, False, True])
    np.testing.assert_array_equal(a, [0])
    np.testing.assert_array_equal(b, [1])
    np.testing.assert_allclose(kvec, [[0.5 - 2 / 3, 6 - 1.9 / 3]], atol=1e-15)
    for x, y in zip(K.merge_clusters(*args), R.merge_clusters(*args)):
        np.testing.assert_array_equal(x, y)
    # one round only: junction 1-2 stays although it became shorter
    centre, keep, a, b, kvec = K.merge_clusters(*args[:-2], 1, N.MAX_SHIFT)
    np.testing.assert_array_equal(keep, [False, True, True])
    np.testing.assert_allclose(centre, [[0.75, 0.0], [0.5, 1.9], [0.5, 6.0]], atol=1e-15)


@pytest.mark.parametrize("periodic", [False, True], ids=["open", "periodic"])
def test_merge_clusters_equal_reference_on_voronoi(periodic):
    """Traced jittered Voronoi images (with their arm lines), merge distances 0-3.5 px: every output equal."""
    from hexatissue.box import Box

    for seed in range(3):
        shape = (40, 46)
        labels = voronoi_labels(jittered_seeds(shape, 5, seed=seed), shape, periodic).astype(np.int32)
        pos, j, lines = N._trace(labels, periodic, np.zeros(shape, bool))
        lengths = Box.from_shape(shape).lengths if periodic else np.zeros(2)
        for merge_distance in (0.0, 1.0, 2.0, 3.5, np.sqrt(2.0), np.sqrt(5.0)):  # some on the lengths (ties)
            args = (pos, j["start"], j["end"], j["start_arm"], j["end_arm"], j["vec"], lines["count"],
                    lines["mean"], lines["direction"], lengths, merge_distance, N.MAX_MERGE_ROUNDS, N.MAX_SHIFT)
            for x, y in zip(K.merge_clusters(*args), R.merge_clusters(*args)):
                np.testing.assert_array_equal(x, y)


def test_segment_total_equals_numpy_reduceat():
    """Sums of 1..300 values of mixed magnitudes (numpy's pairwise blocks of 8 and its split above 128): bit for bit."""
    rng = np.random.default_rng(3)
    for n in range(1, 301):
        values = rng.normal(size=n + 5) * 10.0 ** rng.uniform(-4, 4, n + 5)
        assert K.segment_total(values, 3, n) == np.add.reduceat(values[3:3 + n], [0])[0] == R.segment_total(values, 3, n)


def polygons_both(centre, kept, n_labels):
    args = (centre, kept["a"], kept["b"], kept["left"], kept["right"], kept["vec"], n_labels)
    out = K.polygons(*args)
    for x, y in zip(out, R.polygons(*args)):
        assert x.dtype == y.dtype
        np.testing.assert_array_equal(x, y)
    return out


def test_polygons_two_unit_squares():
    """Cells 1 = [0, 1] x [0, 1] and 2 = [1, 2] x [0, 1]: one counter-clockwise square each, from its lowest vertex.

    Vertices 0 (0, 0), 1 (1, 0), 2 (2, 0), 3 (2, 1), 4 (1, 1), 5 (0, 1); each
    junction has its left cell on its left in x-y axes (1 -> 4 between cells 1 and 2).
    """
    centre = np.array([[0.0, 0.0], [1, 0], [2, 0], [2, 1], [1, 1], [0, 1]])
    a, b = np.array([0, 1, 4, 5, 1, 2, 3]), np.array([1, 4, 5, 0, 2, 3, 4])
    kept = dict(a=a, b=b, left=np.array([1, 1, 1, 1, 2, 2, 2]), right=np.array([0, 2, 0, 0, 0, 0, 0]),
                vec=centre[b] - centre[a])
    poly_start, poly_len, poly_area, poly_perimeter, verts, xy, n_cycles = polygons_both(centre, kept, 3)
    np.testing.assert_array_equal(poly_start, [-1, 0, 4])
    np.testing.assert_array_equal(poly_len, [0, 4, 4])
    np.testing.assert_array_equal(poly_area, [np.nan, 1.0, 1.0])
    np.testing.assert_array_equal(poly_perimeter, [np.nan, 4.0, 4.0])
    np.testing.assert_array_equal(verts, [0, 1, 4, 5, 1, 2, 3, 4])
    np.testing.assert_array_equal(xy, centre[verts])
    np.testing.assert_array_equal(n_cycles, [0, 1, 1])


@pytest.mark.parametrize("periodic", [False, True], ids=["open", "periodic"])
def test_polygons_equal_reference(periodic):
    """Networks of jittered Voronoi images (merge distances 0-3.5 px) and of tiny random label images."""
    from hexatissue.box import Box

    rng = np.random.default_rng(5)
    images = [voronoi_labels(jittered_seeds((40, 46), 5, seed=s), (40, 46), periodic) for s in range(3)]
    images += [rng.integers(0, 4, (int(rng.integers(3, 12)), int(rng.integers(3, 12)))) for _ in range(40)]
    for labels in images:
        labels = np.asarray(labels, np.int32)
        box = Box.from_shape(labels.shape) if periodic else None
        pos, j, lines = N._trace(labels, periodic, np.zeros(labels.shape, bool))
        for merge_distance in (0.0, 2.0, 3.5):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                centre, kept, _ = N._merge_short(pos, j, lines, merge_distance, box)
            polygons_both(centre, kept, int(labels.max()) + 1)


def test_cell_vertex_rows_hand_made():
    """Rows 2, 0, 1 of three cells; cell 1 has no polygon; cell 2's polygon crosses the edge of a 10 x 10 box.

    Cell 0: vertices 3, 1, 2 at rows 0-2 of ``verts``; cell 2: vertices 0, 4
    at rows 3-4, unwrapped at x = 10.5 and 9.5 while vertex 0 sits at x = 0.5:
    image (1, 0) for vertex 0, (0, 0) for vertex 4.
    """
    centre = np.array([[0.5, 5.0], [1, 1], [2, 1], [1, 2], [9.5, 5.0]])
    verts = np.array([3, 1, 2, 0, 4])
    xy = np.array([[1.0, 2], [1, 1], [2, 1], [10.5, 5.0], [9.5, 6.0]])
    poly_start, poly_len = np.array([0, -1, 3]), np.array([3, 0, 2])
    args = (np.array([2, 0, 1]), poly_start, poly_len, verts, xy, centre, np.array([10.0, 10.0]))
    row, rank, vertex, image, polygon_xy, first = K.cell_vertex_rows(*args)
    np.testing.assert_array_equal(row, [0, 0, 1, 1, 1])
    np.testing.assert_array_equal(rank, [0, 1, 0, 1, 2])
    np.testing.assert_array_equal(vertex, [0, 4, 3, 1, 2])
    np.testing.assert_array_equal(image, [[1, 0], [0, 0], [0, 0], [0, 0], [0, 0]])
    np.testing.assert_array_equal(polygon_xy, [[10.5, 5.0], [9.5, 5.0], [1, 2], [1, 1], [2, 1]])
    np.testing.assert_array_equal(first, [0, 2])
    for lengths in (args[-1], np.zeros(2)):  # periodic and open
        for x, y in zip(K.cell_vertex_rows(*args[:-1], lengths), R.cell_vertex_rows(*args[:-1], lengths)):
            assert x.dtype == y.dtype
            np.testing.assert_array_equal(x, y)


def test_length_below_decides_as_hypot():
    """A 3-4-5 triangle exactly on the limit, just either side of it, zero, and random near ties."""
    below = K._length_below.py_func
    assert not below(3.0, 4.0, 5.0, False) and below(3.0, 4.0, 5.0, True)
    assert below(3.0, 4.0, np.nextafter(5.0, 6.0), False) and not below(3.0, 4.0, np.nextafter(5.0, 4.0), True)
    assert not below(0.0, 0.0, 0.0, False) and below(0.0, 0.0, 0.0, True)
    rng = np.random.default_rng(8)
    xy = rng.normal(0, 3, (2000, 2))
    for limit in (np.hypot(*xy.T) * (1 + rng.normal(0, 1e-15, 2000)), np.full(2000, 2.0)):
        for or_equal in (False, True):
            got = [K._length_below(x, y, lim, or_equal) for (x, y), lim in zip(xy, limit)]
            want = np.hypot(*xy.T) <= limit if or_equal else np.hypot(*xy.T) < limit
            np.testing.assert_array_equal(got, want)


def test_at_most_two_values():
    """One value, two values, a third in the last pixel, strided samples and random tiny images (against the reference)."""
    image = np.zeros((5, 7), np.uint16)
    assert K.at_most_two_values(image)
    image[2, 3] = 9
    assert K.at_most_two_values(image)
    image[-1, -1] = 4
    assert not K.at_most_two_values(image) and K.at_most_two_values(image[:, :-1])
    assert K.at_most_two_values(image[::2, ::3]) == R.at_most_two_values(image[::2, ::3])
    rng = np.random.default_rng(4)
    for _ in range(200):
        labels = rng.integers(0, int(rng.integers(1, 4)), (int(rng.integers(1, 5)), int(rng.integers(1, 5))))
        assert K.at_most_two_values(labels) == R.at_most_two_values(labels)


@pytest.mark.parametrize("scale, chosen", [(1.0, 0), (2.0, 4)], ids=["tie: the first", "the larger"])
def test_polygons_largest_cycle_of_a_cell_in_two_pieces(scale, chosen):
    """Cell 1 in two pieces: a unit square (vertices 0-3) and a square of side ``scale`` (vertices 4-7).

    Its polygon is the cycle of larger area; of two equal ones the first
    (the one from the lowest vertex).  Both count in its cycles.
    """
    square = np.array([[0.0, 0], [1, 0], [1, 1], [0, 1]])
    centre = np.vstack([square, [5.0, 0] + scale * square])
    a, b = np.arange(8), np.array([1, 2, 3, 0, 5, 6, 7, 4])
    kept = dict(a=a, b=b, left=np.ones(8, np.int64), right=np.zeros(8, np.int64), vec=centre[b] - centre[a])
    poly_start, poly_len, poly_area, _, verts, _, n_cycles = polygons_both(centre, kept, 2)
    assert poly_start[1] == chosen and poly_len[1] == 4 and poly_area[1] == (1.0 if chosen == 0 else scale**2)
    np.testing.assert_array_equal(verts, np.arange(8))
    assert n_cycles[1] == 2


@pytest.mark.parametrize("periodic", [False, True])
@pytest.mark.parametrize("dtype", [np.int32, np.uint16, np.int64])
def test_few_sparse_ids_give_the_tables_of_compacted_labels(monkeypatch, periodic, dtype):
    """Labels with few ids, gaps between them and 0 pixels, used as they are (no compaction pass), give the
    tables of the compacted route exactly; ``checked_labels`` reports the image's min and max id."""
    from hexatissue import Box, mesh_from_labels
    from hexatissue.mesh.labels import checked_labels

    seeds = jittered_seeds((200, 240), 20.0, seed=4)
    labels = voronoi_labels(seeds, (200, 240), periodic=periodic)
    labels = (labels * 3 + 2).astype(dtype)  # ids 5, 8, ...: gaps, and no id 1..4
    labels[:3, :3] = 0
    lab, lowest, top = checked_labels(labels)
    assert (lowest, top) == (0, int(labels.max()))
    assert top + 1 <= labels.size // N.PIXELS_PER_ID  # few ids: kept as they are
    box = Box.from_shape(labels.shape) if periodic else None
    kept = mesh_from_labels(labels, box=box)
    monkeypatch.setattr(N, "PIXELS_PER_ID", labels.size + 1)  # every image compacted
    compacted = mesh_from_labels(labels, box=box)
    for name in ("cells", "vertices", "edges", "cell_vertices"):
        pd.testing.assert_frame_equal(getattr(kept, name), getattr(compacted, name))


def test_checked_labels_of_a_bool_image_are_not_summarised():
    from hexatissue.mesh.labels import checked_labels

    lab, lowest, top = checked_labels(np.eye(4, dtype=bool))
    assert lab.dtype == np.uint8 and lowest is None and top is None


def test_fork_bytes_marks_the_corners_of_type_3_and_4():
    """Every corner code (arm bits | type << 4, types 0..6) in every byte of a word: bit 0 of the byte is set
    exactly for types 3 and 4."""
    rng = np.random.default_rng(5)
    codes = rng.integers(0, 16, (2000, 8)) | (rng.integers(0, 7, (2000, 8)) << 4)
    codes[:112, 0] = np.arange(112)  # every code once
    for row in codes.astype(np.uint8):
        got = int(K._fork_bytes(row.view(np.uint64)[0]))
        want = sum(1 << (8 * b) for b in range(8) if row[b] >> 4 in (3, 4))
        assert got == want


def test_word_counts_of_corner_codes():
    """Arm bits (low nibbles) and fork flags of 8 codes a word: the counts a byte-by-byte loop gives."""
    rng = np.random.default_rng(6)
    codes = (rng.integers(0, 16, (2000, 8)) | (rng.integers(0, 7, (2000, 8)) << 4)).astype(np.uint8)
    codes[:112 // 8] = np.arange(112, dtype=np.uint8).reshape(-1, 8)  # every code (types 0..6) once
    codes[-1] = 0x4F  # the largest counts: four arms, a fork, in every byte
    for row in codes:
        word = row.view(np.uint64)[0]
        assert int(K._arm_count(word)) == sum(bin(int(c) & 15).count("1") for c in row)
        assert int(K._byte_sum(K._fork_bytes(word))) == sum(int(c) >> 4 in (3, 4) for c in row)


@pytest.mark.parametrize("width", [1, 2, 7, 8, 9, 16, 63])
def test_run_starts_of_rows(width):
    """The start column of every run of equal values (rows of width not a multiple of 8, runs of 1 px, one run)."""
    rng = np.random.default_rng(width)
    for k in range(30):
        row = rng.integers(0, 1 + k % 4, width).astype(np.int32)
        is_start = np.zeros((width + 7) // 8, np.uint64)
        run_start = np.full(width + 3, -1, np.int64)
        end = K._run_starts(row, is_start, run_start, 2)
        want = np.flatnonzero(np.r_[True, row[1:] != row[:-1]])
        np.testing.assert_array_equal(run_start[2:end], want)
        assert end == 2 + len(want) and (run_start[:2] == -1).all()


@pytest.mark.parametrize("periodic", [False, True], ids=["open", "periodic"])
def test_cell_moments_with_more_runs_than_first_room(periodic):
    """Runs of 1-2 px (many more than one per RUN_PIXELS px): the run arrays grow, the moments stay the reference's."""
    rng = np.random.default_rng(3)
    labels = rng.integers(0, 5, (40, 96)).astype(np.int32)
    assert (np.diff(labels, axis=1) != 0).sum() > labels.size // K.RUN_PIXELS + labels.shape[1]
    moments_both(labels, periodic)
    moments_both(np.where(labels[:, :1] > 2, labels, 7), periodic)  # label 7 a band around the torus


@pytest.mark.parametrize("shape", [(2, 2), (3, 5), (7, 9), (16, 16)])
def test_corner_types_vertices_on_small_lattices(shape):
    """Lattices whose corner count is not a multiple of 8, open and periodic, with image corners: the word scan
    finds the reference's vertices."""
    rng = np.random.default_rng(shape[0] * shape[1])
    for periodic in (False, True):
        for _ in range(20):
            lab = rng.integers(0, 4, shape).astype(np.int32)
            got, want = K.corner_types(lab, periodic), R.corner_types(lab, periodic)
            for g, w in zip(got, want):
                np.testing.assert_array_equal(g, w)


def test_arm_fits_looked_up_by_path_equal_the_fits_computed():
    """The fit of an arm read back from the table (a hit), fitted and stored (a miss) or fitted with the table
    full: the same numbers as the line fit of its crack midpoints, on every arm of a Voronoi tissue."""
    labels = voronoi_labels(jittered_seeds((48, 56), 7, seed=2), (48, 56), True).astype(np.int32)
    corners, vi, vj, _ = K.corner_types(labels, True)
    nci, ncj = corners.shape
    no_membrane = np.zeros((0, 0), bool)
    keys = np.full(K.FIT_SLOTS + 1, -1, np.int64)
    keys[K.FIT_SLOTS] = 0
    fits = np.empty((K.FIT_SLOTS, 4))
    full = keys.copy()
    full[K.FIT_SLOTS] = K.FIT_FILL  # no room: every path fitted, none stored
    n_arms = 0
    for v in range(len(vi)):
        for d in range(4):
            if not (corners[vi[v], vj[v]] >> d) & 1:
                continue
            _, _, _, _, n, _, head, _ = K._walk(corners, False, vi[v], vj[v], d, nci, ncj)
            for half in {1, min(n, 3), min(n, 8)}:
                want = K._line_fit(half, d, *K._arm_sums(corners, no_membrane, vi[v], vj[v], d, half, nci, ncj))
                for table in (keys, keys, full):  # a miss then a hit (or two hits), then the full table
                    got = K._arm_fit(corners, no_membrane, vi[v], vj[v], d, half, nci, ncj, head, table, fits)
                    assert got == want
            n_arms += 1
    assert n_arms > 100 and 0 < keys[K.FIT_SLOTS] < n_arms and (full[:K.FIT_SLOTS] == -1).all()
