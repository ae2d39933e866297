"""The baseline segmenter on membrane images drawn from exact Voronoi tissues."""
import numpy as np
import pytest
from scipy import ndimage

from hexatissue.benchmark.baseline import segment_membranes, segment_movie
from hexatissue.errors import InputError
from hexatissue.synthetic import draw_membranes, jittered_seeds, voronoi_labels


def _membrane_image(truth, seed, noise=0.05):
    """Bright 2-px membranes on dark cells, blurred (PSF sigma 1 px), with Gaussian noise."""
    membranes = (draw_membranes(truth, width=2) == 0).astype(float)
    rng = np.random.default_rng(seed)
    image = 0.1 + ndimage.gaussian_filter(membranes, 1.0) + rng.normal(0, noise, truth.shape)
    return (1000 * np.clip(image, 0, None)).astype(np.uint16)  # a camera's integer counts


def _jaccard_of_matches(pred, truth):
    """Per truth cell: Jaccard with the predicted cell covering most of it (None when it covers <= 50 %)."""
    out = {}
    for j in np.unique(truth):
        inside = truth == j
        ids, counts = np.unique(pred[inside], return_counts=True)
        i = ids[np.argmax(counts)]
        if counts.max() * 2 <= inside.sum():
            out[int(j)] = None
            continue
        other = pred == i
        out[int(j)] = (inside & other).sum() / (inside | other).sum()
    return out


@pytest.mark.parametrize("seed", [0, 1])
def test_baseline_recovers_every_cell(seed):
    truth = voronoi_labels(jittered_seeds((160, 200), 20, seed=seed), (160, 200))
    pred = segment_membranes(_membrane_image(truth, seed), sigma=1.0)
    assert pred.dtype == np.uint32 and pred.min() >= 1  # touching labels, no membrane pixels
    scores = _jaccard_of_matches(pred, truth)
    n_truth = len(np.unique(truth))
    assert len(np.unique(pred)) == n_truth  # one predicted cell per true cell: nothing split or merged
    assert all(v is not None and v > 0.9 for v in scores.values()), min(v or 0 for v in scores.values())


def test_noise_without_smoothing_makes_extra_cells_that_cleanup_removes():
    truth = voronoi_labels(jittered_seeds((120, 120), 20, seed=3), (120, 120))
    image = _membrane_image(truth, 3, noise=0.15)
    n_truth = len(np.unique(truth))
    noisy = segment_membranes(image, sigma=0.3, h=0.02, min_area=1)
    assert len(np.unique(noisy)) > n_truth  # noise basins became cells
    cleaned = segment_membranes(image, sigma=0.3, h=0.02, min_area=60)
    counts = np.bincount(cleaned.ravel())[1:]
    assert counts.min() >= 60 and len(counts) < len(np.unique(noisy))  # small regions went to their neighbours


def test_segment_movie_frames_are_segmented_independently():
    truth = voronoi_labels(jittered_seeds((100, 100), 20, seed=4), (100, 100))
    image = _membrane_image(truth, 4)
    stack = segment_movie(np.stack([image, image[:, ::-1]]), show_progress=False)
    assert stack.shape == (2, 100, 100)
    np.testing.assert_array_equal(stack[0], segment_membranes(image))
    assert len(np.unique(stack[1])) == len(np.unique(stack[0]))


def test_bad_input_names_the_argument():
    with pytest.raises(InputError, match="image"):
        segment_membranes(np.zeros((3, 4, 5)))
    with pytest.raises(InputError, match="flat"):
        segment_membranes(np.zeros((10, 10)))
    with pytest.raises(InputError, match="sigma"):
        segment_membranes(np.random.default_rng(0).random((10, 10)), sigma=0)


def test_cli_baseline_writes_labels_with_the_input_calibration(tmp_path):
    from hexatissue import open_source
    from hexatissue.cli import main
    from hexatissue.io import write_tiff
    from hexatissue.units import Calibration

    truth = voronoi_labels(jittered_seeds((100, 120), 20, seed=5), (100, 120))
    raw = np.stack([_membrane_image(truth, 5), _membrane_image(truth, 6)])
    cal = Calibration(0.25, "um", 3.0, "min")
    write_tiff(tmp_path / "raw.tif", raw, cal)
    assert main(["benchmark", "baseline", str(tmp_path / "raw.tif"), "--out", str(tmp_path / "labels.tif")]) == 0
    out = open_source(tmp_path / "labels.tif")
    assert out.calibration == cal and out.n_frames == 2
    assert out.frame(0).dtype == np.uint16
    np.testing.assert_array_equal(out.frame(1), segment_membranes(raw[1]))
    assert main(["benchmark", "baseline", str(tmp_path / "missing.tif"), "--out", str(tmp_path / "x.tif")]) == 2


def test_periodic_image_gives_each_cell_crossing_the_edge_one_id():
    from hexatissue.synthetic import hexagonal_seeds

    seeds, box = hexagonal_seeds(8, 8, spacing=24.0, row_spacing=20.8, offset=(11.0, 5.0))  # cells cross every edge
    shape = (int(box.Ly), int(box.Lx))
    truth = voronoi_labels(seeds, shape, periodic=True)
    membranes = (draw_membranes(truth, width=2, periodic=True) == 0).astype(float)
    rng = np.random.default_rng(7)
    image = 0.1 + ndimage.gaussian_filter(membranes, 1.0, mode="wrap") + rng.normal(0, 0.05, shape)
    open_labels = segment_membranes(image)
    pred = segment_membranes(image, periodic=True)
    n_truth = len(np.unique(truth))
    assert len(np.unique(open_labels)) > n_truth  # open: the edge cells come in two pieces
    assert len(np.unique(pred)) == n_truth == 64
    scores = _jaccard_of_matches(pred, truth)
    assert all(v is not None and v > 0.9 for v in scores.values())
