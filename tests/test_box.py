import numpy as np
import pytest

from hexatissue import Box, InputError
from hexatissue.box import as_box


def test_wrap_and_min_image():
    box = Box(10.0, 20.0)
    np.testing.assert_allclose(box.wrap([[-1.0, 25.0], [10.0, -3.0], [-1e-17, 0.0]]), [[9, 5], [0, 17], [0, 0]])
    np.testing.assert_allclose(box.min_image([6.0, -11.0]), [-4.0, 9.0])
    assert box.distance([0.5, 0.5], [9.5, 19.5]) == pytest.approx(np.sqrt(2))


def test_as_box_is_the_one_normaliser():
    assert as_box(None) is None and as_box(False) is None  # open image
    assert as_box(True, (30, 40)) == Box(40.0, 30.0)
    box = Box(40, 30)
    assert as_box(box, (30, 40)) is box and as_box(box) is box
    with pytest.raises(InputError, match="does not match the image shape"):
        as_box(box, (40, 30))
    with pytest.raises(InputError, match="needs the image shape"):
        as_box(True)
    with pytest.raises(InputError, match="must be a hexatissue.Box"):
        as_box((40, 30))


def test_box_is_always_periodic():
    with pytest.raises(TypeError):
        Box(10.0, 20.0, periodic=False)
    assert Box(10, 20).to_list() == [10.0, 20.0]


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
