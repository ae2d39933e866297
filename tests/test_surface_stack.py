"""The height map of a z-stack (:func:`hexatissue.surface.height_map`) and its projection, against exact surfaces.

Truth: Voronoi tissues on a tilted plane and a Gaussian bump
(:mod:`hexatissue.synthetic_surface`) imaged as z-stacks of their junctions
(:func:`~hexatissue.synthetic_surface.junction_stack`: a Gaussian point spread
function, background and noise), whose heights are known at every pixel; the
cells' exact areas on the surface; and the EpiTools sample z-stack with the
projection EpiTools made of it (third-party data, skipped when absent).
"""
import warnings

import numpy as np
import pytest

from tests.conftest import real_subdir
from hexatissue import InputError, SurfaceOptions, analyze
from hexatissue.cli import main
from hexatissue.surface import height_map, project_stack
from hexatissue.surface.stack import _local_plane
from hexatissue.synthetic_surface import gaussian_bump_tissue, junction_stack, tilted_plane_tissue


def _surface_area_error(tissue, height):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cells = analyze(tissue.labels, surface=height, workers=1, progress=False).cells
    cells = cells.merge(tissue.truth, on="cell", suffixes=("", "_true"))
    return float(np.median(np.abs(cells["surface_area"] / cells["area_true"] - 1)))


@pytest.mark.parametrize("noise", [0.05, 0.3])
def test_the_height_of_a_tissue_tilted_50_degrees_is_found_and_gives_its_areas(noise):
    tissue = tilted_plane_tissue(50.0, shape=(320, 400))
    z_step = 4.0
    found = height_map(junction_stack(tissue, z_step=z_step, noise=noise)).height * z_step
    error = np.abs(found - tissue.height)[16:-16, 16:-16]
    # measured: median 0.08 px (noise 0.05), 0.27 px (noise 0.3); the planes are 4 px apart
    assert np.median(error) < 0.5, np.median(error)
    # measured: 1.72 % and 1.97 % against 1.49 % with the exact height map, 35.7 % flat
    assert _surface_area_error(tissue, found) < 0.025


def test_the_height_of_a_gaussian_bump_in_a_noisy_stack_is_found():
    tissue = gaussian_bump_tissue((256, 256), amplitude=80.0, width=60.0, spacing=20.0)
    found = height_map(junction_stack(tissue, z_step=4.0, noise=0.3)).height * 4.0
    error = np.abs(found - tissue.height)
    # measured: median 0.39 px, 95th percentile 1.52 px over a bump 80 px high
    assert np.median(error) < 1.0 and np.percentile(error, 95) < 3.0, (np.median(error), np.percentile(error, 95))


def test_the_local_plane_is_exact_on_any_plane_whatever_the_weights():
    rows, cols = np.indices((60, 80), dtype=float)
    plane = 3.0 + 0.7 * cols - 0.4 * rows
    # lopsided: nothing on the right, whose pixels are within the smoothing's reach (4 sigma) of the weights
    weight = np.random.default_rng(0).uniform(0, 1, plane.shape) * (cols < 50)
    np.testing.assert_allclose(_local_plane(plane, weight, 8.0), plane, atol=1e-8)
    line = np.zeros_like(plane)
    line[30] = 1.0  # weights on one row determine no plane across it: the local mean is taken there
    assert np.isfinite(_local_plane(plane, line, 8.0)).all()


def test_the_projection_takes_the_planes_at_the_surface():
    rng = np.random.default_rng(1)
    stack = rng.uniform(0, 1, (9, 20, 30))
    height = rng.uniform(0, 8, (20, 30))
    k = np.rint(height).astype(int)
    rows, cols = np.indices(height.shape)
    np.testing.assert_array_equal(project_stack(stack, height, 0), stack[k, rows, cols])
    wide = np.max([stack[np.clip(k + d, 0, 8), rows, cols] for d in (-1, 0, 1)], axis=0)
    np.testing.assert_array_equal(project_stack(stack, height, 1), wide)


def test_bad_stacks_are_refused_saying_why():
    with pytest.raises(InputError, match="at least 3"):
        height_map(np.ones((2, 10, 10)))
    with pytest.raises(InputError, match="no plane brighter"):
        height_map(np.ones((5, 10, 10)))
    with pytest.raises(InputError, match="NaN"):
        height_map(np.full((5, 10, 10), np.nan))
    with pytest.raises(InputError, match="sigma"):
        height_map(np.random.default_rng(0).uniform(size=(5, 10, 10)), sigma=0)
    with pytest.raises(InputError, match="planes' shape"):
        project_stack(np.ones((5, 10, 10)), np.ones((10, 11)))


def test_the_command_writes_a_height_map_that_analyze_reads(tmp_path, capsys):
    import tifffile

    tissue = tilted_plane_tissue(30.0, shape=(160, 200))
    stack = junction_stack(tissue, z_step=2.0)
    tifffile.imwrite(tmp_path / "stack.tif", stack, ome=True, metadata={"axes": "ZYX"})
    out, proj = tmp_path / "height.tif", tmp_path / "proj.tif"
    assert main(["height-map", str(tmp_path / "stack.tif"), "--out", str(out), "--projection", str(proj)]) == 0
    assert "ZYX, " in capsys.readouterr().out
    height = tifffile.imread(out)
    assert height.shape == tissue.labels.shape and height.dtype == np.float32
    assert np.median(np.abs(height * 2.0 - tissue.height)) < 0.5
    assert tifffile.imread(proj).shape == tissue.labels.shape
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cells = analyze(tissue.labels, surface=SurfaceOptions(image=str(out), z_step=2.0), workers=1,
                        progress=False).cells
    assert abs(np.median(cells["normal_z"]) - np.cos(np.radians(30.0))) < 0.01
    # an existing file is kept; a 2-D image is no stack; a channel axis needs --channel
    assert main(["height-map", str(tmp_path / "stack.tif"), "--out", str(out)]) == 2
    assert "already exists" in capsys.readouterr().err
    tifffile.imwrite(tmp_path / "flat.tif", stack[0])
    assert main(["height-map", str(tmp_path / "flat.tif"), "--out", str(tmp_path / "h2.tif")]) == 2
    assert "needs a z-stack" in capsys.readouterr().err
    np.save(tmp_path / "two.npy", np.stack([stack, stack], axis=1))  # Z, C, Y, X
    assert main(["height-map", str(tmp_path / "two.npy"), "--axes", "ZCYX", "--out", str(tmp_path / "h3.tif")]) == 2
    assert "--channel" in capsys.readouterr().err
    assert main(["height-map", str(tmp_path / "two.npy"), "--axes", "ZCYX", "--channel", "1",
                 "--out", str(tmp_path / "h3.tif")]) == 0


def test_the_epitools_stack_projects_as_epitools_projects_it(real_data):
    import tifffile

    folder = real_subdir(real_data, "epitools_wingdisc")
    stack = tifffile.imread(folder / "test_image.tif")
    theirs = tifffile.imread(folder / "test_image-projected.tif").astype(float)
    surface = height_map(stack)
    ours = project_stack(stack, surface.height, 1).astype(float)
    # measured: correlation 0.9962; the surface lies between planes 17.8 and 28.2 of 30
    assert np.corrcoef(ours.ravel(), theirs.ravel())[0, 1] > 0.99
    assert 15 < surface.height.min() and surface.height.max() < 29
