"""Property-based fuzz of mesh_from_labels on small random label images, open and periodic.

Any label image either raises InputError or gives a network whose tables
are consistent: every interior edge separates two distinct cells, degrees
are >= 2, every id refers to an existing row, and on a torus whose cells
are all disks V - E + F = 0.
"""
import warnings

import numpy as np
import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402
from hypothesis.extra.numpy import arrays  # noqa: E402

from hexatissue import HexatissueWarning, InputError, mesh_from_labels  # noqa: E402

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


def check_network(f, periodic):
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
    if periodic and len(cells) > 1 and (cells["n_boundaries"] == 1).all() and has.all() \
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
    check_network(f, periodic=periodic)
    if periodic:  # vertices folded into the box
        assert ((f.vertices[["x", "y"]] >= 0).all().all() and (f.vertices["x"] < f.shape[1]).all()
                and (f.vertices["y"] < f.shape[0]).all())
