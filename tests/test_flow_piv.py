"""PIV of a raw channel on the Gamma_p grid against images moved by known amounts."""
import numpy as np
import pandas as pd
import pytest

from hexatissue import Box, InputError
from hexatissue.flow.piv import piv_agreement, piv_displacements, piv_fields

SHAPE = (160, 192)


def blobs(shape, centres, sigma=1.6):
    """An image of Gaussian spots at ``centres`` ((n, 2) x, y), periodic: a sum of separable profiles."""
    ny, nx = shape

    def profile(c, n):  # (spots, n): each spot's Gaussian along one axis, minimum image distance
        d = (np.arange(n)[None, :] - c[:, None] + n / 2) % n - n / 2
        return np.exp(-d**2 / (2 * sigma**2))

    return profile(centres[:, 1], ny).T @ profile(centres[:, 0], nx)


def spots(n=900, seed=1):
    rng = np.random.default_rng(seed)
    return rng.uniform(0, 1, (n, 2)) * [SHAPE[1], SHAPE[0]]


def nodes(margin=24, step=16):
    y, x = np.mgrid[margin:SHAPE[0] - margin + 1:step, margin:SHAPE[1] - margin + 1:step]
    return x.ravel().astype(float), y.ravel().astype(float)


@pytest.mark.parametrize("shift", [(0.0, 0.0), (0.3, -0.7), (2.45, 1.2), (-5.6, 3.3)])
def test_a_translation_is_recovered_to_a_few_hundredths_of_a_pixel(shift):
    centres = spots()
    a = blobs(SHAPE, centres)
    b = blobs(SHAPE, centres + shift)
    x, y = nodes()
    dx, dy, peak = piv_displacements(a, b, x, y, 32, Box(SHAPE[1], SHAPE[0]))
    # the three-point Gaussian fit of a Gaussian spot's correlation (itself Gaussian) is exact; what remains is
    # the texture cut by the windows' edges, which the window-offset passes drive below their 0.005 px
    # tolerance per pass: measured within 0.007 px (one pass alone: 0.2-1 px, 25-30 % towards zero)
    assert np.abs(dx - shift[0]).max() < 0.02 and np.abs(dy - shift[1]).max() < 0.02
    assert np.nanmin(peak) > 0.6


def test_a_simple_shear_gives_the_displacement_at_each_window_centre():
    rate = 0.02  # dx = rate * (y - y0): up to +-1.6 px over the image
    y0 = SHAPE[0] / 2
    centres = spots()
    moved = centres + np.c_[rate * (centres[:, 1] - y0), np.zeros(len(centres))]
    a, b = blobs(SHAPE, centres), blobs(SHAPE, moved)
    x, y = nodes()
    dx, dy, _ = piv_displacements(a, b, x, y, 32)
    # within a window the displacement spans +-0.32 px; the peak follows the displacement of the spots it
    # holds, whose (tapered) mean position is off the window's centre by ~2.5 px rms (some 15 spots in it):
    # errors ~0.05 px rms, at random, so the bound is 0.1 px per window and none on average
    error = dx - rate * (y - y0)
    assert np.abs(error).max() < 0.1 and abs(error.mean()) < 0.01 and np.abs(dy).max() < 0.05
    slope = np.polyfit(y, dx, 1)[0]
    assert slope == pytest.approx(rate, rel=0.02)


def test_piv_fields_halve_the_centred_displacement_and_skip_the_movie_ends():
    centres = spots()
    velocity = np.array([0.4, -0.25])  # px/frame
    images = [blobs(SHAPE, centres + t * velocity) for t in range(4)]
    x, y = nodes()
    grid = pd.concat([pd.DataFrame({"frame": t, "node": np.arange(len(x)), "x": x, "y": y, "radius": 16.0})
                      for t in range(4)], ignore_index=True)
    piv = piv_fields(images, grid, box=Box(SHAPE[1], SHAPE[0]))
    assert (piv["window"] == 32).all()
    ends = piv["frame"].isin([0, 3])
    assert piv.loc[ends, ["piv_vx", "piv_vy"]].isna().all().all()
    assert np.abs(piv.loc[~ends, "piv_vx"] - velocity[0]).max() < 0.025
    assert np.abs(piv.loc[~ends, "piv_vy"] - velocity[1]).max() < 0.025


def test_open_image_windows_leaving_it_and_flat_windows_give_nan():
    a = blobs(SHAPE, spots())
    dx, dy, peak = piv_displacements(a, a, [5.0, 96.0], [80.0, 80.0], 32)
    assert np.isnan(dx[0]) and np.isnan(peak[0]) and dx[1] == pytest.approx(0.0, abs=1e-9)
    flat = np.ones(SHAPE)
    assert np.isnan(piv_displacements(flat, flat, [96.0], [80.0], 32)[0]).all()


@pytest.mark.parametrize("kwargs, match", [
    ({"window": 7}, "window: expected an even"),
    ({"window": 0}, "window"),
    ({"second": np.zeros((3, 3))}, "first, second"),
])
def test_piv_bad_input(kwargs, match):
    args = {"first": np.zeros(SHAPE), "second": np.zeros(SHAPE), "x": [50.0], "y": [50.0], "window": 16}
    with pytest.raises(InputError, match=match):
        piv_displacements(**{**args, **kwargs})


def test_analyze_with_a_raw_channel_puts_its_piv_beside_the_track_field():
    from scipy import ndimage

    from hexatissue import FlowOptions, IntensityOptions, analyze
    from hexatissue.synthetic import jittered_seeds, voronoi_labels

    shape, omega, centre = (200, 240), 0.01, np.array([120.0, 100.0])  # a rigid rotation, rad/frame
    c, s = np.cos(omega), np.sin(omega)
    seeds = jittered_seeds(shape, 12.0, seed=3)
    labels = np.stack([voronoi_labels(centre + (seeds - centre) @ np.linalg.matrix_power(
        np.array([[c, -s], [s, c]]), t).T, shape) for t in range(4)])
    # the raw channel: the cells' junctions, blurred as a membrane marker
    membrane = np.stack([ndimage.gaussian_filter(((lab != np.roll(lab, 1, 0)) | (lab != np.roll(lab, 1, 1)))
                                                 .astype(float), 1.0) for lab in labels])
    movie = analyze(labels, workers=1, progress=False, intensity=IntensityOptions(image=membrane))
    rows = movie.flow[(movie.flow["frame"] == 1) & movie.flow["valid"]].dropna(subset=["piv_vx"])
    assert len(rows) > 50
    truth = omega * np.c_[-(rows["y"] - centre[1]), rows["x"] - centre[0]]  # up to 1.2 px/frame
    piv = rows[["piv_vx", "piv_vy"]].to_numpy()
    # the PIV follows the junctions, drawn on whole pixels: they move by jumps of a pixel as the cells turn
    # (0.5-2.4 px per frame pair here); measured 0.063 px/frame from the rotation at the median node (~8 % of
    # the speed there), the bound 0.1; the track field, from rasterised centroids, agrees as closely
    assert np.median(np.hypot(*(piv - truth).T)) < 0.1
    assert np.median(np.hypot(*(piv - rows[["vx", "vy"]].to_numpy()).T)) < 0.1
    assert movie.flow.loc[movie.flow["frame"].isin([0, 3]), "piv_vx"].isna().all()
    off = analyze(labels, workers=1, progress=False, intensity=IntensityOptions(image=membrane),
                  flow=FlowOptions(piv=False))
    assert "piv_vx" not in off.flow.columns


def test_piv_agreement_counts_only_nodes_with_both_fields():
    """Identical fields: no difference, r = 1; a field of twice the velocity: difference = the tracks' rms;
    invalid nodes and NaN PIV are left out; nothing to compare gives NaN, not a number."""
    rng = np.random.default_rng(0)
    vx, vy = rng.normal(size=50), rng.normal(size=50)
    flow = pd.DataFrame({"valid": True, "vx": vx, "vy": vy, "piv_vx": vx, "piv_vy": vy})
    flow.loc[0, "valid"], flow.loc[1, "piv_vx"] = False, np.nan
    same = piv_agreement(flow)
    assert same["nodes"] == 48 and same["rms_difference"] == 0 and same["r_vx"] == pytest.approx(1)
    double = piv_agreement(flow.assign(piv_vx=2 * flow["vx"], piv_vy=2 * flow["vy"]))
    assert double["relative_difference"] == pytest.approx(1) and double["rms_piv"] == pytest.approx(2 * double["rms_tracks"])
    none = piv_agreement(flow.assign(valid=False))
    assert none["nodes"] == 0 and np.isnan(none["r_vy"]) and np.isnan(none["relative_difference"])
