import numpy as np
import pytest

from hexatissue import Box, InputError


def test_wrap_and_min_image():
    box = Box(10.0, 20.0)
    np.testing.assert_allclose(box.wrap([[-1.0, 25.0], [10.0, -3.0], [-1e-17, 0.0]]), [[9, 5], [0, 17], [0, 0]])
    np.testing.assert_allclose(box.min_image([6.0, -11.0]), [-4.0, 9.0])
    assert box.distance([0.5, 0.5], [9.5, 19.5]) == pytest.approx(np.sqrt(2))


def test_open_box_is_identity():
    box = Box(10.0, 20.0, periodic=False)
    np.testing.assert_allclose(box.wrap([-1.0, 25.0]), [-1.0, 25.0])
    np.testing.assert_allclose(box.min_image([6.0, -11.0]), [6.0, -11.0])


def test_unwrap_polygon_across_the_edge():
    box = Box(10.0, 10.0)
    square = np.array([[9.0, 9.0], [1.0, 9.0], [1.0, 1.0], [9.0, 1.0]])
    out = box.unwrap_polygon(square, reference=[0.0, 0.0])
    np.testing.assert_allclose(out, [[-1, -1], [1, -1], [1, 1], [-1, 1]])


@pytest.mark.parametrize("bad", [0, -1, np.nan, np.inf])
def test_bad_lengths(bad):
    with pytest.raises(InputError, match="Lx"):
        Box(bad, 1.0)


def test_from_shape():
    box = Box.from_shape((30, 40))
    assert (box.Lx, box.Ly) == (40.0, 30.0)
