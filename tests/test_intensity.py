"""A raw channel on the junction network: exact on linear images and rectangular tissues; through analyze."""
import numpy as np
import pytest

from hexatissue import Box, InputError, analyze, mesh_from_labels
from hexatissue.intensity import measure_intensity
from hexatissue.synthetic import jittered_seeds, voronoi_labels

from .conftest import real_subdir


def _linear(shape, a=0.7, b=-0.3, c=50.0):
    y, x = np.mgrid[0:shape[0], 0:shape[1]].astype(float)
    return a * x + b * y + c


def test_a_linear_image_gives_exact_junction_and_cell_means():
    """Bilinear sampling of a linear image is exact: a junction's mean is its midpoint's value, a cell's mean
    the value at its pixel centroid."""
    labels = voronoi_labels(jittered_seeds((90, 120), 14, seed=2), (90, 120))
    f = mesh_from_labels(labels)
    image = _linear(labels.shape)
    cells, edges = measure_intensity(f.cells, f.vertices, f.edges, labels, image)
    xy = f.vertices.set_index("vertex")[["x", "y"]]
    a, b = xy.loc[edges["vertex_a"]].to_numpy(), xy.loc[edges["vertex_b"]].to_numpy()
    inside = ((np.minimum(a, b) >= 0) & (np.maximum(a, b) <= [119, 89])).all(axis=1)  # no clamping at the edge
    assert inside.sum() > 60
    mid = (a + b)[inside] / 2
    np.testing.assert_allclose(edges["intensity_mean"][inside], 0.7 * mid[:, 0] - 0.3 * mid[:, 1] + 50, rtol=1e-12)
    np.testing.assert_allclose(edges["intensity_total"], edges["intensity_mean"] * edges["length"], rtol=1e-12)
    np.testing.assert_allclose(cells["intensity_mean"], 0.7 * cells["x"] - 0.3 * cells["y"] + 50, rtol=1e-12)


@pytest.mark.parametrize("periodic", [False, True])
def test_junction_polarity_of_rectangular_cells(periodic):
    """Cells 2w x w under a uniform image: P = (2 * 2w - 2 * w) / (6 w) = 1/3 along x for every full cell."""
    w = 6
    ids = np.arange(1, 6 * 5 + 1).reshape(5, 6)
    labels = np.kron(ids, np.ones((w, 2 * w), int))
    box = Box.from_shape(labels.shape) if periodic else None
    f = mesh_from_labels(labels, box=box)
    cells, _ = measure_intensity(f.cells, f.vertices, f.edges, labels, np.full(labels.shape, 3.0), box)
    inner = cells[~cells["is_border"]]
    assert len(inner) == (30 if periodic else 12)
    np.testing.assert_allclose(inner["junction_polarity_re"], 1 / 3, atol=1e-12)
    np.testing.assert_allclose(inner["junction_polarity_im"], 0.0, atol=1e-12)
    np.testing.assert_allclose(inner["intensity_mean"], 3.0)


def test_bad_intensity_images():
    labels = voronoi_labels(jittered_seeds((60, 80), 14, seed=1), (60, 80))
    f = mesh_from_labels(labels)
    with pytest.raises(InputError, match="shape"):
        measure_intensity(f.cells, f.vertices, f.edges, labels, np.zeros((10, 10)))
    bad = np.zeros(labels.shape)
    bad[3, 3] = np.nan
    with pytest.raises(InputError, match="NaN"):
        measure_intensity(f.cells, f.vertices, f.edges, labels, bad)
    with pytest.raises(InputError, match="intensity has 3 frame"):
        analyze(np.stack([labels] * 2), intensity=np.stack([bad * 0] * 3), workers=1, progress=False)


def test_analyze_measures_every_frame_and_records_the_channel():
    labels = voronoi_labels(jittered_seeds((60, 80), 14, seed=3), (60, 80))
    stack = np.stack([labels, labels])
    images = np.stack([_linear(labels.shape), 2 * _linear(labels.shape)])
    movie = analyze(stack, intensity=images, workers=1, progress=False)
    e = movie.edges
    ratio = e[e["frame"] == 1]["intensity_mean"].to_numpy() / e[e["frame"] == 0]["intensity_mean"].to_numpy()
    np.testing.assert_allclose(ratio, 2.0)
    assert movie.source["intensity"]["kind"] == "array"
    one = analyze(stack, intensity=images[0], workers=1, progress=False)  # one frame for every frame
    np.testing.assert_allclose(one.cells["intensity_mean"].to_numpy()[: len(one.cells) // 2],
                               one.cells["intensity_mean"].to_numpy()[len(one.cells) // 2:])


def test_the_intensity_stage_takes_its_options_from_analyze_and_the_command_line(tmp_path):
    """IntensityOptions(step=...) reaches the junction sampling; the CLI's --intensity-step gives the same
    tables; the options are recorded (the image by its path) and read back."""
    import tifffile

    from hexatissue import IntensityOptions, read_results
    from hexatissue.cli import main

    labels = voronoi_labels(jittered_seeds((60, 80), 14, seed=3), (60, 80)).astype(np.uint16)
    rng = np.random.default_rng(1)
    image = rng.random(labels.shape)  # not linear: the samples' spacing shows in the means
    tifffile.imwrite(tmp_path / "labels.tif", labels)
    tifffile.imwrite(tmp_path / "raw.tif", image)
    coarse = analyze(tmp_path / "labels.tif", intensity=IntensityOptions(image=tmp_path / "raw.tif", step=2.0),
                     workers=1, progress=False)
    fine = analyze(tmp_path / "labels.tif", intensity=str(tmp_path / "raw.tif"), workers=1, progress=False)
    f = mesh_from_labels(labels)
    _, expected = measure_intensity(f.cells, f.vertices, f.edges, labels, image, step=2.0)
    np.testing.assert_array_equal(coarse.edges["intensity_mean"], expected["intensity_mean"])
    assert not np.allclose(coarse.edges["intensity_mean"], fine.edges["intensity_mean"])
    assert coarse.options["intensity"].to_dict() == {"image": str(tmp_path / "raw.tif"), "channel": None, "step": 2.0}
    assert main(["analyze", str(tmp_path / "labels.tif"), "--out", str(tmp_path / "out"), "--intensity",
                 str(tmp_path / "raw.tif"), "--intensity-step", "2", "--workers", "1"]) == 0
    back = read_results(tmp_path / "out")
    np.testing.assert_array_equal(back.edges["intensity_mean"], coarse.edges["intensity_mean"])
    assert back.options["intensity"] == IntensityOptions(image=str(tmp_path / "raw.tif"), step=2.0)
    with pytest.raises(InputError, match="selects a channel of IntensityOptions.image, which is not given"):
        IntensityOptions(channel=1)


def test_epicure_junctions_are_brighter_than_cells(real_data, tmp_path):
    """EpiCure 013 with its raw membrane channel: junctions carry the marker in every frame (CLI path)."""
    from hexatissue import read_results
    from hexatissue.cli import main

    folder = real_subdir(real_data, "epicure_notum")
    assert main(["analyze", str(folder / "013_crop_labels.tif"), "--intensity", str(folder / "013_crop.tif"),
                 "--out", str(tmp_path / "r"), "--workers", "1", "--no-fields"]) == 0
    m = read_results(tmp_path / "r")
    per_frame = m.edges.groupby("frame")["intensity_mean"].median() / m.cells.groupby("frame")["intensity_mean"].median()
    assert len(per_frame) == 11 and (per_frame > 1.5).all()
    assert m.source["intensity"]["path"].endswith("013_crop.tif")
