"""The surface stage: cells measured on a height map, against Voronoi tissues on analytic surfaces.

Truth (:mod:`hexatissue.synthetic_surface`): a flat Voronoi tissue on a
plane tilted about the x axis (its own flat areas and gamma_p) and a Voronoi
tessellation lifted onto a Gaussian bump (areas by quadrature of
``sqrt(1 + |grad z|^2)``).  The goals of issue 46: at a 50 degree tilt, median
area error <= 2 % and median ``| |gamma6|_surface - |gamma6|_flat |`` <= 0.05;
areas on a bump within 1 %.
"""
import warnings

import numpy as np
import pandas as pd
import pytest

from hexatissue import (HexatissueWarning, InputError, MechanicsOptions, SurfaceOptions, analyze, mesh_from_labels,
                        read_results)
from hexatissue.geometry import pack_polygons
from hexatissue.surface import surface_arrays, surface_cells
from hexatissue.synthetic import jittered_seeds, voronoi_labels, voronoi_polygons
from hexatissue.synthetic_surface import gaussian_bump_tissue, tilted_plane_tissue

pytestmark = pytest.mark.filterwarnings("ignore::hexatissue.errors.HexatissueWarning")


def _run(labels, height, **options):
    return analyze(labels, surface=SurfaceOptions(image=height, **options), workers=1, progress=False)


def _interior(cells, truth=None):
    cells = cells[~cells["is_border"].to_numpy(bool) & (cells["n_sides"].to_numpy() > 0)]
    return cells if truth is None else cells.merge(truth, on="cell", suffixes=("", "_true"))


def _shoelace(xy):
    return 0.5 * abs(float(np.dot(xy[:, 0], np.roll(xy[:, 1], -1)) - np.dot(np.roll(xy[:, 0], -1), xy[:, 1])))


def _modulus(cells, p, prefix="surface_"):
    return np.hypot(cells[f"{prefix}gamma{p}_re"], cells[f"{prefix}gamma{p}_im"]).to_numpy()


@pytest.mark.parametrize("periodic", [False, True])
def test_a_flat_height_map_gives_the_flat_columns(periodic):
    """On a plane z = const the tangent frame is (x, y): every surface column equals its flat counterpart."""
    labels = voronoi_labels(jittered_seeds((96, 128), 16, seed=2), (96, 128), periodic=periodic)
    movie = analyze(labels, box=True if periodic else None, surface=np.full(labels.shape, 7.0), workers=1,
                    progress=False)
    c = movie.cells[movie.cells["n_sides"] > 0]
    assert len(c) > 30
    np.testing.assert_allclose(c["surface_area"], c["polygon_area"], rtol=1e-12)
    np.testing.assert_allclose(c["surface_perimeter"], c["perimeter"], rtol=1e-12)
    np.testing.assert_array_equal(c[["normal_x", "normal_y", "normal_z"]].to_numpy(), [[0.0, 0.0, 1.0]] * len(c))
    for p in (6, 2):
        for part in ("re", "im"):
            np.testing.assert_allclose(c[f"surface_gamma{p}_{part}"], c[f"gamma{p}_{part}"], atol=1e-12)
    np.testing.assert_array_equal(movie.vertices["z"], 7.0)
    no_polygon = movie.cells[movie.cells["n_sides"] == 0]
    assert no_polygon[["surface_area", "normal_z", "surface_gamma6_re"]].isna().all().all()


def test_the_tilted_plane_truth_is_the_flat_tissue():
    t = tilted_plane_tissue(50, shape=(120, 160), spacing=20, seed=3)
    assert t.labels.shape == (round(120 * np.cos(np.radians(50))), 160) == t.height.shape
    np.testing.assert_allclose(np.diff(t.height, axis=0), np.tan(np.radians(50)))
    polygons = voronoi_polygons(t.seeds, (120, 160))
    np.testing.assert_allclose(t.truth["area"], [_shoelace(polygons[k]) for k in t.truth["cell"]], rtol=1e-12)
    # every projected cell is its flat cell squeezed by cos(tilt) along y
    counts = np.bincount(t.labels.ravel())[t.truth["cell"]]
    ratio = counts / t.truth["area"].to_numpy()
    assert abs(np.median(ratio) - np.cos(np.radians(50))) < 0.01
    with pytest.raises(InputError, match="tilt must be an angle"):
        tilted_plane_tissue(85)


def test_the_bump_truth_is_converged_and_flat_without_a_bump():
    fine = gaussian_bump_tissue(shape=(128, 128), amplitude=50, width=30, spacing=20, subdivisions=16).truth
    coarse = gaussian_bump_tissue(shape=(128, 128), amplitude=50, width=30, spacing=20, subdivisions=8).truth
    np.testing.assert_allclose(coarse["area"], fine["area"], rtol=1e-9)
    np.testing.assert_allclose(coarse["perimeter"], fine["perimeter"], rtol=1e-9)
    flat = gaussian_bump_tissue(shape=(128, 128), amplitude=0.0, width=30, spacing=20)
    polygons = voronoi_polygons(flat.seeds, (128, 128))
    np.testing.assert_allclose(flat.truth["area"], [_shoelace(polygons[k]) for k in flat.truth["cell"]], rtol=1e-10)
    assert (fine["area"] > [_shoelace(polygons[k]) for k in fine["cell"]]).all()  # same seeds: the bump adds area


def test_a_tissue_tilted_50_degrees_meets_the_goals():
    """Issue 46: areas within 2 % and |gamma6| within 0.05 (medians) of the flat tissue, where the flat analysis of
    the projection is 36 % and ~0.2 off."""
    t = tilted_plane_tissue(50, shape=(240, 320), spacing=24, seed=1)
    c = _interior(_run(t.labels, t.height).cells, t.truth)
    assert len(c) == 88
    error = c["surface_area"] / c["area_true"] - 1
    assert np.median(np.abs(error)) <= 0.02
    flat_error = c["polygon_area"] / c["area_true"] - 1
    assert abs(np.median(flat_error) - (np.cos(np.radians(50)) - 1)) < 0.01  # the projection's foreshortening
    g6 = np.hypot(c["gamma6_re_true"], c["gamma6_im_true"]).to_numpy()
    assert np.median(np.abs(_modulus(c, 6) - g6)) <= 0.05
    assert np.median(np.abs(_modulus(c, 6, prefix="") - g6)) > 0.1
    # against the same tissue imaged flat and analysed
    flat = _interior(analyze(t.flat_labels, workers=1, progress=False).cells)
    both = c.merge(flat[["cell", "polygon_area", "gamma6_re", "gamma6_im"]], on="cell", suffixes=("", "_flat"))
    assert np.median(np.abs(both["surface_area"] / both["polygon_area_flat"] - 1)) <= 0.02
    assert np.median(np.abs(_modulus(both, 6) - np.hypot(both["gamma6_re_flat"], both["gamma6_im_flat"]))) <= 0.05
    # the tangent plane and its frame: n = (0, -sin, cos), e1 = x, so gamma6 keeps its phase
    tilt = np.radians(50)
    normal = c[["normal_x", "normal_y", "normal_z"]].to_numpy()
    assert np.median(np.linalg.norm(normal - [0, -np.sin(tilt), np.cos(tilt)], axis=1)) < 0.01
    phase = np.abs(np.hypot(c["surface_gamma6_re"] - c["gamma6_re_true"], c["surface_gamma6_im"] - c["gamma6_im_true"]))
    assert np.median(phase) <= 0.1
    assert np.median(np.abs(c["surface_perimeter"] / c["perimeter_true"] - 1)) <= 0.01


def test_areas_on_a_gaussian_bump_are_within_one_percent():
    """Exact vertices lifted: median 0.1 %, max 1 %; through the analysed network the median error stays within
    1 % and unbiased (the network's own pixel error on the flat tissue is ~0.9 %, median)."""
    b = gaussian_bump_tissue(shape=(256, 256), amplitude=80, width=60, spacing=24, seed=3)
    polygons = voronoi_polygons(b.seeds, b.labels.shape)
    xy, starts = pack_polygons([polygons[k] for k in b.truth["cell"]])
    exact = surface_arrays(xy, starts, np.arange(len(starts)), b.height)
    error = exact["surface_area"] / b.truth["area"].to_numpy() - 1
    assert np.median(np.abs(error)) <= 0.0025 and np.abs(error).max() <= 0.015  # measured 0.11 %, 1.01 %
    perimeter = exact["surface_perimeter"] / b.truth["perimeter"].to_numpy() - 1
    assert np.abs(perimeter).max() <= 0.005
    c = _interior(_run(b.labels, b.height).cells, b.truth)
    assert len(c) == 64
    error = (c["surface_area"] / c["area_true"] - 1).to_numpy()
    assert np.median(np.abs(error)) <= 0.01
    assert abs(np.median(error)) <= 0.005
    assert np.abs(error).max() <= 0.06
    projected = np.median(np.abs(c["polygon_area"] / c["area_true"] - 1))
    assert projected > 0.1  # what the flat analysis misses on this bump


def test_per_cell_values_do_not_change_under_a_rigid_rotation_of_the_image():
    """Labels and height map turned by 90 degrees: the same areas, perimeters and |gamma_p|; the normal turns with
    the image, and gamma_p turns by p times the angle between the two tangent frames' first axes."""
    b = gaussian_bump_tissue(shape=(200, 240), spacing=24, seed=0)
    gy, gx = np.mgrid[0:200, 0:240]
    height = b.height + 0.4 * gx - 0.2 * gy  # a tilted bump: no symmetry left
    cells = _run(b.labels, height).cells
    turned = _run(np.rot90(b.labels).copy(), np.rot90(height).copy()).cells
    c = cells.merge(turned, on="cell", suffixes=("", "_r"))
    c = c[c["n_sides"] > 0]
    assert len(c) == 80 and (c["n_sides"] == c["n_sides_r"]).all()
    for column in ("surface_area", "surface_perimeter", "normal_z"):
        np.testing.assert_allclose(c[column + "_r"], c[column], rtol=1e-10, atol=1e-12)
    # np.rot90: x' = y, y' = W - 1 - x, so a vector (a, b) becomes (b, -a)
    np.testing.assert_allclose(c["normal_x_r"], c["normal_y"], atol=1e-12)
    np.testing.assert_allclose(c["normal_y_r"], -c["normal_x"], atol=1e-12)
    n = c[["normal_x", "normal_y", "normal_z"]].to_numpy()
    e1 = np.column_stack([1 - n[:, 0] ** 2, -n[:, 0] * n[:, 1], -n[:, 0] * n[:, 2]])
    e1 /= np.linalg.norm(e1, axis=1)[:, None]
    e2 = np.cross(n, e1)
    angle = np.arctan2(e2[:, 1], e1[:, 1])  # the turned image's x axis is the original y axis
    for p in (6, 2):
        gamma = (c[f"surface_gamma{p}_re"] + 1j * c[f"surface_gamma{p}_im"]).to_numpy()
        gamma_r = (c[f"surface_gamma{p}_re_r"] + 1j * c[f"surface_gamma{p}_im_r"]).to_numpy()
        np.testing.assert_allclose(np.abs(gamma_r), np.abs(gamma), atol=1e-12)
        np.testing.assert_allclose(gamma_r, gamma * np.exp(-1j * p * angle), atol=1e-10)


def test_calibrated_heights_and_slice_indices_give_the_heights_in_px():
    t = tilted_plane_tissue(30, shape=(120, 160), spacing=20, seed=4)
    in_px = _run(t.labels, t.height).cells
    in_um = _run(t.labels, t.height * 0.25, pixel_size=0.25).cells  # heights in um at 0.25 um/px
    slices = _run(t.labels, t.height / 2.0, pixel_size=0.25, z_step=0.5).cells  # slice index, 0.5 um apart
    for other in (in_um, slices):
        for column in ("surface_area", "surface_perimeter", "normal_y", "surface_gamma6_re"):
            np.testing.assert_allclose(other[column], in_px[column], rtol=1e-9, atol=1e-12)
    assert SurfaceOptions(pixel_size=0.25, z_step=0.5).scale == 2.0


def test_bad_height_maps_and_options_are_refused_naming_the_argument():
    labels = voronoi_labels(jittered_seeds((60, 80), 14, seed=1), (60, 80))
    with pytest.raises(InputError, match="surface has 1 frame"):
        analyze(labels, surface=np.zeros((60, 81)), workers=1, progress=False)
    bad = np.zeros(labels.shape)
    bad[5, 7] = np.nan
    with pytest.raises(InputError, match=r"SurfaceOptions\.image holds 1 NaN"):
        analyze(labels, surface=bad, workers=1, progress=False)
    with pytest.raises(InputError, match=r"SurfaceOptions\.image"):
        SurfaceOptions(image=np.zeros(5))
    with pytest.raises(InputError, match=r"SurfaceOptions\.pixel_size"):
        SurfaceOptions(image=np.zeros((4, 4)), pixel_size=-0.2)
    with pytest.raises(InputError, match=r"SurfaceOptions\.z_step"):
        SurfaceOptions(z_step=0)
    with pytest.raises(InputError, match=r"SurfaceOptions\.center"):
        SurfaceOptions(center="middle")
    with pytest.raises(InputError, match="selects a channel of SurfaceOptions.image"):
        SurfaceOptions(channel=1)
    f = mesh_from_labels(labels)
    with pytest.raises(InputError, match="height holds 1 NaN"):
        surface_cells(f.cells, f.vertices, f.cell_vertices, bad)
    with pytest.raises(InputError, match="height must be a 2-D array"):
        surface_cells(f.cells, f.vertices, f.cell_vertices, np.zeros(4))


def test_the_stage_runs_from_files_and_the_command_line_and_reads_back(tmp_path):
    """``--surface FILE --surface-pixel-size``: the tables of the Python call, the options recorded and read back;
    one height map serves every frame of a movie."""
    import tifffile

    from hexatissue.cli import main

    t = tilted_plane_tissue(40, shape=(100, 120), spacing=20, seed=5)
    labels = np.stack([t.labels, t.labels]).astype(np.uint16)
    tifffile.imwrite(tmp_path / "labels.tif", labels)
    tifffile.imwrite(tmp_path / "height.tif", (t.height * 0.5).astype(np.float32))
    assert main(["analyze", str(tmp_path / "labels.tif"), "--out", str(tmp_path / "out"), "--surface",
                 str(tmp_path / "height.tif"), "--surface-pixel-size", "0.5", "--workers", "1"]) == 0
    back = read_results(tmp_path / "out")
    assert back.options["surface"] == SurfaceOptions(image=str(tmp_path / "height.tif"), pixel_size=0.5)
    direct = _run(labels, t.height.astype(np.float32).astype(float) * 0.5, pixel_size=0.5).cells
    pd.testing.assert_series_equal(back.cells["surface_area"], direct["surface_area"], check_exact=False, rtol=1e-6)
    frames = back.cells.groupby("frame")["surface_area"].sum()
    assert frames[0] == pytest.approx(frames[1])
    assert "z" in back.vertices and back.source["surface"]["path"].endswith("height.tif")


@pytest.mark.parametrize("periodic", [False, True])
def test_the_kernel_equals_its_numpy_reference(periodic):
    """``surface_polygons`` (numba) against its plain-numpy reference, on a bump with degenerate polygons added."""
    from hexatissue.surface import _kernels, _reference

    b = gaussian_bump_tissue(shape=(96, 128), amplitude=30, width=25, spacing=16, seed=6)
    polygons = list(voronoi_polygons(b.seeds, b.labels.shape).values())
    n_cells = len(polygons)
    polygons += [np.array([[3.0, 4.0], [5.0, 6.0]]), np.array([[1.0, 1.0], [1.0, 1.0], [1.0, 1.0]])]
    if periodic:  # unwrapped polygons reaching beyond the image
        polygons.append(polygons[0] + [120.0, -30.0])
    xy, starts = pack_polygons(polygons)
    args = (xy, starts, b.height, 0.7, periodic, 1e-9)
    kernel, reference = _kernels.surface_polygons(*args), _reference.surface_polygons(*args)
    for got, expected in zip(kernel, reference):
        np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-12)
    assert np.isfinite(kernel[0][:n_cells]).all() and np.isnan(kernel[0][n_cells:n_cells + 2]).all()
    end = starts[n_cells + 2] if periodic else len(xy)
    assert np.isnan(kernel[3][starts[n_cells]:end]).all()


def test_the_report_shows_the_curved_tissue(tmp_path):
    """``hexatissue report``'s section: the tangent planes' tilt and the surface over projected area, per frame."""
    from hexatissue.workflows import report

    t = tilted_plane_tissue(40, shape=(120, 160), spacing=20, seed=2)
    movie = _run(t.labels, t.height)
    numbers = report(movie, tmp_path / "report")
    assert numbers["surface"]["median_tilt_deg"] == pytest.approx(40, abs=0.5)
    assert numbers["surface"]["area_ratio"] == pytest.approx(1 / np.cos(np.radians(40)), rel=0.01)
    assert "## Curved tissue" in (tmp_path / "report" / "report.md").read_text()
    assert (tmp_path / "report" / "surface.csv").is_file()
    report(analyze(t.labels, workers=1, progress=False), tmp_path / "flat")  # without a height map: no section
    assert "## Curved tissue" not in (tmp_path / "flat" / "report.md").read_text()
    # the force inference section says its balance and stress are on the surface (in tangent planes)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        forces = analyze(t.labels, surface=t.height, mechanics=MechanicsOptions(enabled=True), workers=1,
                         progress=False)
    report(forces, tmp_path / "forces")
    text = (tmp_path / "forces" / "report.md").read_text()
    assert "## Force inference" in text and "balanced in its tangent plane" in text


def test_a_height_map_file_with_nan_is_refused_saying_so(tmp_path):
    import tifffile

    labels = voronoi_labels(jittered_seeds((60, 80), 14, seed=1), (60, 80))
    height = np.zeros(labels.shape, np.float32)
    height[:3] = np.nan  # no surface found there
    tifffile.imwrite(tmp_path / "height.tif", height)
    with pytest.raises(InputError, match="frame 0 must be a finite 2-D intensity image; it holds 240 NaN"):
        analyze(labels, surface=tmp_path / "height.tif", workers=1, progress=False)


def test_a_height_map_too_steep_or_in_the_wrong_unit_is_flagged():
    t = tilted_plane_tissue(50, shape=(240, 320), spacing=24, seed=2)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        analyze(t.labels, workers=1, progress=False, surface=t.height)
    assert not [w for w in caught if "height map" in str(w.message)]
    # the same heights read as slices of 10 px: tan(tilt) x 10, a tilt of 85 degrees
    with pytest.warns(HexatissueWarning, match=r"tilts the cells by more than 75 degrees.*median tilt 85"):
        analyze(t.labels, workers=1, progress=False, surface=SurfaceOptions(image=t.height, z_step=10.0))
