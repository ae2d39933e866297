"""Property-based fuzz of mesh_from_labels on small random label images, open and periodic.

Any label image either raises InputError or gives a network whose tables
are consistent: every interior edge separates two distinct cells, degrees
are >= 2, every id refers to an existing row, and on a torus whose cells
are all disks V - E + F = 0.  "Disk" is decided on the pixels the network
is traced from (each label one 4-connected piece that does not wrap around
the torus) and by one boundary (no pinch): n_boundaries alone is not
enough, since merging contracts a label's small pieces, so a label in
pieces can come out with one boundary.
"""
import warnings

import numpy as np
import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402
from hypothesis.extra.numpy import arrays  # noqa: E402

from scipy import ndimage  # noqa: E402

from hexatissue import HexatissueWarning, InputError, mesh_from_labels  # noqa: E402
from hexatissue.mesh.labels import normalize_labels  # noqa: E402

SETTINGS = settings(max_examples=200, deadline=None, database=None, suppress_health_check=[HealthCheck.too_slow])


@st.composite
def label_images(draw):
    rows = draw(st.integers(2, 12))
    cols = draw(st.integers(2, 12))
    n = draw(st.integers(1, 6))
    image = draw(arrays(np.int32, (rows, cols), elements=st.integers(0, n)))
    if draw(st.booleans()):  # blocky images: cells of several pixels, like real segmentations
        image = np.kron(image[: max(1, rows // 2), : max(1, cols // 2)], np.ones((2, 2), np.int32))
    return image


def cells_are_disks(labels):
    """Every label of a periodic label image is one 4-connected piece that does not wrap around the torus.

    In a 3 x 3 tiling, the piece holding one of the label's pixels of the
    central copy must be one copy of the whole label: as many pixels, at
    every one of the label's positions modulo the box.
    """
    tiled = np.tile(labels, (3, 3))
    rows, cols = labels.shape
    for value in np.unique(labels):
        pieces, _ = ndimage.label(tiled == value)
        r, c = np.argwhere(labels == value)[0]
        piece = np.argwhere(pieces == pieces[r + rows, c + cols])
        folded = {(i % rows, j % cols) for i, j in piece}
        if len(piece) != len(folded) or len(folded) != (labels == value).sum():
            return False
    return True


def check_network(f, periodic, disks=False):
    cells, vertices, edges, cv = f.cells, f.vertices, f.edges, f.cell_vertices
    ids = set(cells["cell"])
    assert 0 not in ids and len(ids) == len(cells)
    vids = set(vertices["vertex"])
    assert vids == set(range(len(vertices)))
    # every edge joins existing vertices and separates two distinct cells (0 = outside, only on open images)
    assert set(edges["vertex_a"]) <= vids and set(edges["vertex_b"]) <= vids
    assert (edges["cell_a"] < edges["cell_b"]).all()
    interior = edges[edges["cell_a"] != 0]
    assert set(interior["cell_a"]) <= ids and set(interior["cell_b"]) <= ids
    if periodic:  # no image edge on a torus: only background 0 is outside
        assert (edges["cell_a"] != 0).all() or cells["is_border"].any()
    assert (edges["length"] >= 0).all()
    assert (vertices["degree"] >= 2).all()
    # polygons reference existing cells and vertices; ranks are 0..n-1; n_sides agrees
    assert set(cv["cell"]) <= ids and set(cv["vertex"]) <= vids
    sides = cv.groupby("cell")["rank"].agg(["count", "min", "max"])
    assert (sides["min"] == 0).all() and (sides["max"] == sides["count"] - 1).all()
    n_sides = cells.set_index("cell")["n_sides"]
    assert (n_sides.loc[sides.index] == sides["count"]).all()
    assert (n_sides.drop(sides.index) == 0).all()
    has = cells["n_sides"] > 0
    assert (cells.loc[has, "polygon_area"] > 0).all()
    assert np.isfinite(cells[["x", "y", "area"]].to_numpy()).all()
    assert cells["area"].sum() <= f.shape[0] * f.shape[1]
    if periodic and disks and len(cells) > 1 and (cells["n_boundaries"] == 1).all() and has.all() \
            and not cells["is_border"].any():
        # no background and every cell a disk on the torus: Euler characteristic 0
        assert len(vertices) - len(edges) + len(cells) == 0


def mesh_or_input_error(image, periodic, merge_distance):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HexatissueWarning)
        try:
            return mesh_from_labels(image, box=True if periodic else None, merge_distance=merge_distance)
        except InputError:
            return None


@pytest.mark.parametrize("periodic", [False, True], ids=["open", "periodic"])
@SETTINGS
@given(image=label_images(), merge_distance=st.sampled_from([0.0, 2.0]))
def test_fuzz(periodic, image, merge_distance):
    f = mesh_or_input_error(image, periodic, merge_distance)
    if f is None:
        return
    check_network(f, periodic=periodic,
                  disks=periodic and cells_are_disks(normalize_labels(image, periodic=periodic)[0]))
    if periodic:  # vertices folded into the box
        assert ((f.vertices[["x", "y"]] >= 0).all().all() and (f.vertices["x"] < f.shape[1]).all()
                and (f.vertices["y"] < f.shape[0]).all())


def torus_voronoi(rows, cols, seeds):
    """Labels 1..n of the periodic Voronoi tessellation of ``seeds`` (x, y) on a rows x cols torus of pixels."""
    y, x = np.mgrid[0:rows, 0:cols] + 0.5
    dx = np.abs(x[..., None] - seeds[:, 0])
    dy = np.abs(y[..., None] - seeds[:, 1])
    d2 = np.minimum(dx, cols - dx) ** 2 + np.minimum(dy, rows - dy) ** 2
    return (np.argmin(d2, axis=-1) + 1).astype(np.int32)


@SETTINGS
@given(rows=st.integers(4, 24), cols=st.integers(4, 24), merge_distance=st.sampled_from([0.0, 2.0]),
       seeds=arrays(float, st.tuples(st.integers(2, 8), st.just(2)), elements=st.floats(0, 0.999)))
def test_fuzz_periodic_tilings(rows, cols, merge_distance, seeds):
    """Tilings of a small torus by pixel Voronoi cells, some wider than half the box, some bands around it:
    whenever every cell is a disk, V - E + F = 0 (merging never folds a loop around the torus into a point)."""
    image = torus_voronoi(rows, cols, seeds * [cols, rows])
    f = mesh_or_input_error(image, True, merge_distance)
    if f is None:
        return
    check_network(f, periodic=True, disks=cells_are_disks(normalize_labels(image, periodic=True)[0]))


def test_short_junctions_around_the_box_are_not_contracted_into_a_point():
    """Two bands of cells around a 5 px wide torus: the junctions along the row between them (1, 1, 1 and 2 px,
    5 px in all) go around the box.  Contracting them (merge_distance 2) would fold that loop into a point:
    one stays, as a loop edge whose vector is the box's width, and V - E + F = 0 as without merging."""
    image = np.array([[2, 2, 3, 3, 3]] * 5 + [[4, 5, 5, 4, 4]] * 7 + [[1, 1, 1, 6, 6]] * 2 + [[1, 1, 3, 6, 6]]
                     + [[2, 2, 3, 3, 3]] * 2, np.int32)
    assert cells_are_disks(image)
    for merge_distance in (0.0, 2.0):
        f = mesh_from_labels(image, box=True, merge_distance=merge_distance)
        check_network(f, periodic=True, disks=True)
        assert len(f.vertices) - len(f.edges) + len(f.cells) == 0
    loops = f.edges[f.edges["vertex_a"] == f.edges["vertex_b"]]
    assert len(loops) == 1 and loops["length"].iloc[0] == pytest.approx(5.0, abs=0.5)
