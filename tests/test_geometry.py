"""Polygon geometry shared by the mesh and the order stage, against hand-computed shapes."""
import numpy as np
import pandas as pd
import pytest

from hexatissue import Box, InputError
from hexatissue.geometry import distinct_count, lookup, pack_polygons, polygon_area_centroid, polygon_perimeter, table_polygons


def test_area_centroid_perimeter_of_a_square_and_a_triangle():
    xy, starts = pack_polygons([[[0, 0], [2, 0], [2, 2], [0, 2], [0, 0]], [[0, 0], [0, 3], [4, 0]]])
    assert starts.tolist() == [0, 4]  # the repeated closing vertex is dropped
    area, centroid = polygon_area_centroid(xy, starts)
    np.testing.assert_allclose(area, [4.0, -6.0])  # counter-clockwise positive
    np.testing.assert_allclose(centroid, [[1, 1], [4 / 3, 1]])
    np.testing.assert_allclose(polygon_perimeter(xy, starts), [8.0, 12.0])


def test_table_polygons_unwraps_across_the_torus():
    box = Box(10, 10)
    vertices = pd.DataFrame({"frame": [0] * 4 + [1] * 3, "vertex": [0, 1, 2, 3, 0, 1, 2],
                             "x": [9.0, 1.0, 1.0, 9.0, 0.0, 3.0, 0.0], "y": [9.0, 9.0, 1.0, 1.0, 0.0, 0.0, 3.0]})
    cv = pd.DataFrame({"frame": [1, 1, 1, 0, 0, 0, 0], "cell": [5, 5, 5, 2, 2, 2, 2],
                       "rank": [0, 1, 2, 0, 1, 2, 3], "vertex": [0, 1, 2, 3, 2, 1, 0]})
    keys, xy, starts = table_polygons(vertices, cv, box)
    assert keys.to_dict("list") == {"frame": [0, 1], "cell": [2, 5]}
    area, _ = polygon_area_centroid(xy, starts)
    np.testing.assert_allclose(area, [-4.0, 4.5])  # a 2 x 2 square across the corner, clockwise; a triangle
    np.testing.assert_allclose(xy[:4], [[9, 1], [11, 1], [11, -1], [9, -1]])
    with pytest.raises(InputError, match="missing from the vertices table"):
        table_polygons(vertices, cv.assign(vertex=cv["vertex"] + 10), box)


def test_lookup():
    keys = np.array([5, 3, 9])
    assert lookup(keys, None, np.array([3, 9, 4, 5])).tolist() == [1, 2, -1, 0]
    assert lookup(np.array([], np.int64), None, np.array([1])).tolist() == [-1]
    with pytest.raises(InputError, match="gone"):
        lookup(keys, np.arange(3), np.array([4]), "gone")


def test_distinct_count_equals_nunique():
    rng = np.random.default_rng(3)
    cases = [np.array([], np.int64), np.array([0]), np.array([7, 7, 7], np.uint16),
             rng.integers(0, 50, 1000),  # flags
             rng.integers(-5, 5, 100),  # negative ids: np.unique
             np.array([1, 2 ** 40, 2 ** 40, 3]),  # far beyond the number of ids: np.unique
             np.tile(np.arange(2500), 20) + rng.integers(0, 3, 50000)]
    for ids in cases:
        assert distinct_count(ids) == pd.Series(ids).nunique()


def test_polygons_of_cells_wider_than_half_the_box_come_back_exactly():
    """A junction longer than L/2: minimum-image steps would fold it; the recorded periodic images do not."""
    from hexatissue import mesh_from_labels
    from hexatissue.geometry import polygon_area_centroid as area_of

    labels = np.zeros((8, 24), int)
    labels[:4, :20], labels[:4, 20:] = 1, 2   # top row: a cell 20 px wide and one of 4 px
    labels[4:, :2], labels[4:, 2:] = 3, 4     # bottom row: 2 px and 22 px
    f = mesh_from_labels(labels, box=Box(24, 8))
    keys, xy, starts = table_polygons(f.vertices, f.cell_vertices, f.box)
    area, _ = area_of(xy, starts)
    expected = f.cells.set_index("cell").loc[keys["cell"], "polygon_area"].to_numpy()
    np.testing.assert_allclose(area, expected)
    assert sorted(np.round(area).tolist()) == [8.0, 16.0, 80.0, 88.0]  # 2 x 4, 4 x 4, 20 x 4, 22 x 4
    # without the recorded images, minimum-image steps fold the long junctions: the areas come out wrong
    _, xy_old, _ = table_polygons(f.vertices, f.cell_vertices.drop(columns=["image_x", "image_y"]), f.box)
    assert not np.allclose(area_of(xy_old, starts)[0], expected)


def test_match_points_is_the_dense_optimum_with_periodic_distances():
    # the one matcher (defect linking and pairing, vertex scores): most pairs within the radius, then the
    # least total distance, as a dense assignment with forbidden pairs priced out would give
    from scipy.optimize import linear_sum_assignment

    from hexatissue.geometry import match_points

    box = Box(50.0, 40.0)
    rng = np.random.default_rng(1)
    for k in range(20):
        a = rng.uniform(0, 1, (30, 2)) * box.lengths
        b = box.wrap(a[:25] + rng.normal(0, 1.2, (25, 2)))
        pairs = match_points(a, b, 2.0, box if k % 2 else None)
        d = a[:, None] - b[None]
        dist = np.hypot(*(box.min_image(d) if k % 2 else d).transpose(2, 0, 1))
        assert np.allclose(pairs[:, 2], dist[pairs[:, 0].astype(int), pairs[:, 1].astype(int)])
        assert (pairs[:, 2] <= 2.0).all() and len(set(pairs[:, 0])) == len(set(pairs[:, 1])) == len(pairs)
        ok = dist <= 2.0
        r, c = linear_sum_assignment(np.where(ok, dist, 1.0 + 30 * 3.0))
        assert len(pairs) == int(ok[r, c].sum())
        assert pairs[:, 2].sum() == pytest.approx(dist[r, c][ok[r, c]].sum(), rel=1e-12)
    assert match_points(np.zeros((0, 2)), np.ones((3, 2)), 1.0).shape == (0, 3)


def test_polygon_shape_tensor_is_the_exact_second_area_moment():
    """Rotated rectangles: R diag(w^2, h^2) R^T / 12 whatever the place and winding; an ellipse's diag(a^2, b^2) / 4
    as its inscribed polygon refines; NaN without an area."""
    from hexatissue.geometry import pack_polygons, polygon_shape_tensor

    polygons, want = [], []
    for w, h, angle, centre in ((40, 20, 0.0, (100, 50)), (7, 3, 0.6, (-5, 1e4)), (1, 1, 2.0, (0.5, 0.5))):
        c, s = np.cos(angle), np.sin(angle)
        rot = np.array([[c, -s], [s, c]])
        corners = np.array([[-w, -h], [w, -h], [w, h], [-w, h]]) / 2 @ rot.T + centre
        polygons += [corners, corners[::-1]]  # counter-clockwise and clockwise
        tensor = rot @ np.diag([w**2, h**2]) @ rot.T / 12
        want += [[tensor[0, 0], tensor[0, 1], tensor[1, 1]]] * 2
    xy, starts = pack_polygons(polygons)
    np.testing.assert_allclose(polygon_shape_tensor(xy, starts), want, rtol=1e-9, atol=1e-9)
    theta = np.linspace(0, 2 * np.pi, 20001)[:-1]
    xy, starts = pack_polygons([np.c_[7 * np.cos(theta), 3 * np.sin(theta)], [[0, 0], [1, 1]]])
    got = polygon_shape_tensor(xy, starts)
    np.testing.assert_allclose(got[0], [49 / 4, 0, 9 / 4], rtol=1e-7, atol=1e-12)
    assert np.isnan(got[1]).all()
