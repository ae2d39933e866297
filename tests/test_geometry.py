"""Polygon geometry shared by the mesh and the order stage, against hand-computed shapes."""
import numpy as np
import pandas as pd
import pytest

from hexatissue import Box, InputError
from hexatissue.geometry import lookup, pack_polygons, polygon_area_centroid, polygon_perimeter, table_polygons


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
