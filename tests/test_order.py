import numpy as np
import pytest

from hexatissue import InputError, shape_function

from .conftest import real_subdir


def regular(n, radius=5.0, phase=0.0, center=(0.0, 0.0)):
    t = phase + 2 * np.pi * np.arange(n) / n
    return np.c_[center[0] + radius * np.cos(t), center[1] + radius * np.sin(t)]


@pytest.mark.parametrize("p", [3, 4, 5, 6])
def test_regular_p_gon_has_unit_gamma(p):
    g = shape_function([regular(p, phase=0.3)], p=p)[0]
    assert abs(g) == pytest.approx(1.0)
    assert np.angle(g) == pytest.approx(np.angle(np.exp(1j * p * 0.3)))


def test_rotation_multiplies_by_phase():
    rng = np.random.default_rng(1)
    polys = [regular(6) + rng.normal(scale=0.5, size=(6, 2)) for _ in range(20)]
    for p in (2, 6):
        g = shape_function(polys, p=p)
        rot = [np.c_[-q[:, 1], q[:, 0]] for q in polys]  # rotation by +pi/2 in (x, y)
        np.testing.assert_allclose(shape_function(rot, p=p), g * np.exp(1j * p * np.pi / 2), atol=1e-12)


def test_closing_vertex_and_centres():
    hexagon = regular(6, center=(3.0, 4.0))
    closed = np.vstack([hexagon, hexagon[:1]])
    assert shape_function([closed])[0] == pytest.approx(shape_function([hexagon])[0])
    # area centroid differs from the vertex mean on an irregular polygon
    poly = np.array([[0, 0], [4, 0], [4, 1], [1, 1], [1, 4], [0, 4]], float)
    g_mean = shape_function([poly], p=2)[0]
    g_area = shape_function([poly], p=2, center="area_centroid")[0]
    g_explicit = shape_function([poly], p=2, center=np.array([[poly[:, 0].mean(), poly[:, 1].mean()]]))[0]
    assert g_explicit == pytest.approx(g_mean)
    assert abs(g_area - g_mean) > 1e-3


def test_degenerate_polygons_are_nan():
    g = shape_function([np.zeros((2, 2)), regular(6)])
    assert np.isnan(g[0]) and abs(g[1]) == pytest.approx(1)


@pytest.mark.parametrize("bad", [dict(p=0), dict(p=2.5), dict(center="middle")])
def test_bad_arguments(bad):
    with pytest.raises(InputError):
        shape_function([regular(6)], **bad)


def test_bad_polygon_shape():
    with pytest.raises(InputError, match=r"polygons\[0\]"):
        shape_function([np.zeros((4, 3))])


def test_published_mdck_gamma(real_data):
    """Armengol-Collado et al. 2023: gamma_p from the published polygons equals the published values."""
    scipy_io = pytest.importorskip("scipy.io")
    folder = real_subdir(real_data, "hexanematic_mdck")
    worst = 0.0
    for image in range(6, 69):
        mat = scipy_io.loadmat(folder / "mat" / f"Image{image}_Polygon.mat", simplify_cells=True)
        polys = [np.asarray(v, float) for v in mat["Polygon"]["Vertex"]]
        dat = np.loadtxt(folder / "dat" / f"exp_{image}.dat")
        assert len(polys) == len(dat)
        for k, p in enumerate(range(2, 7)):
            published = dat[:, 2 + 2 * k] + 1j * dat[:, 3 + 2 * k]
            worst = max(worst, np.abs(shape_function(polys, p=p) - published).max())
    assert worst < 1e-9
