"""Tissue flow: cell velocities and the velocity-gradient fields on the Gamma_p grid, against exact truth."""
import numpy as np
import pandas as pd
import pytest

from hexatissue import Box, InputError, analyze
from hexatissue.flow import cell_velocities, flow_fields
from hexatissue.flow import _kernels as K
from hexatissue.flow import _reference as R
from hexatissue.order import coarse_grain
from hexatissue.synthetic import jittered_seeds, voronoi_labels

pytestmark = pytest.mark.filterwarnings("ignore::hexatissue.errors.HexatissueWarning")

SHAPE = (200, 240)
CENTRE = np.array([120.0, 100.0])


@pytest.fixture(scope="module")
def tissue():
    """One open Voronoi tissue analysed by hexatissue: its cells table (x, y, area, is_border, gamma)."""
    labels = voronoi_labels(jittered_seeds(SHAPE, 12.0, seed=3), SHAPE)
    return analyze(labels, workers=1, progress=False).cells


def moved(cells, maps, box=None):
    """The cells of ``tissue`` at frames 0, 1, ...: centroids moved by ``maps[t]`` (a function of (n, 2) xy)."""
    frames = []
    for t, move in enumerate(maps):
        frame = cells.copy()
        xy = move(cells[["x", "y"]].to_numpy(float))
        if box is not None:
            xy = box.wrap(xy)
        frame["x"], frame["y"] = xy[:, 0], xy[:, 1]
        frame["frame"], frame["track"] = t, cells["cell"].to_numpy()
        frames.append(frame)
    return pd.concat(frames, ignore_index=True)


def fields_of(cells, box=None):
    vx, vy = cell_velocities(cells, box)
    cells = cells.assign(vx=vx, vy=vy)
    grid = coarse_grain(cells, p=6, box=box)
    return cells, grid, flow_fields(cells, grid, box)


def rotation(angle):
    c, s = np.cos(angle), np.sin(angle)
    return lambda xy: CENTRE + (xy - CENTRE) @ np.array([[c, -s], [s, c]]).T


def interior(flow, t):
    rows = flow[(flow["frame"] == t) & flow["valid"]]
    assert len(rows) > 50  # the check is over many nodes
    return rows


def test_velocities_are_centred_differences_nan_at_track_ends_and_gaps():
    cells = pd.DataFrame({"frame": [0, 1, 2, 3, 0, 1, 3, 4, 5],
                          "track": [1, 1, 1, 1, 2, 2, 2, 2, 2],
                          "x": [0.0, 1.0, 3.0, 6.0, 10.0, 10.0, 10.0, 12.0, 15.0],
                          "y": [0.0, 0.0, 0.0, 0.0, 5.0, 4.0, 3.0, 2.0, 0.0]})
    shuffled = cells.sample(frac=1.0, random_state=1)  # row order does not matter
    vx, vy = cell_velocities(shuffled)
    got = pd.DataFrame({"vx": vx, "vy": vy}, index=shuffled.index).sort_index()
    nan = np.nan
    # track 1: ends NaN, (3 - 0) / 2 and (6 - 1) / 2; track 2: frame 2 is missing, so only frame 4 is centred
    np.testing.assert_array_equal(got["vx"], [nan, 1.5, 2.5, nan, nan, nan, nan, 2.5, nan])
    np.testing.assert_array_equal(got["vy"], [nan, 0.0, 0.0, nan, nan, nan, nan, -1.5, nan])


def test_velocities_take_the_minimum_image_and_divisions_end_tracks():
    box = Box(100.0, 50.0)
    cells = pd.DataFrame({"frame": [0, 1, 2, 2, 3, 3], "track": [1, 1, 1, 2, 2, 3],
                          "x": [98.0, 99.5, 1.0, 40.0, 41.0, 39.0], "y": [49.0, 0.0, 1.0, 10.0, 10.0, 10.0]})
    vx, vy = cell_velocities(cells, box)
    np.testing.assert_allclose(vx, [np.nan, 1.5, np.nan, np.nan, np.nan, np.nan])
    np.testing.assert_allclose(vy, [np.nan, 1.0, np.nan, np.nan, np.nan, np.nan])
    ids = cells.drop(columns="track").rename(columns={"frame": "frame"}).assign(cell=cells["track"])
    np.testing.assert_array_equal(cell_velocities(ids, box)[0], vx)  # without track: the label ids are the tracks


@pytest.mark.parametrize("case", ["rotation", "shear", "dilation"])
def test_affine_motions_are_recovered_within_one_percent(tissue, case):
    omega, gamma, eps = 0.02, 0.03, 0.01  # rad/frame, 1/frame, 1/frame
    if case == "rotation":
        maps = [rotation(omega * t) for t in range(5)]
        truth = {"vorticity": 2 * omega, "divergence": 0.0, "strain_xx": 0.0, "strain_xy": 0.0}
        exact = {"vorticity": 2 * np.sin(omega)}  # what centred differences of a rotation give
    elif case == "shear":  # vx = gamma y
        maps = [lambda xy, t=t: xy + np.c_[gamma * t * (xy[:, 1] - CENTRE[1]), 0 * xy[:, 1]] for t in range(5)]
        truth = {"vorticity": -gamma, "divergence": 0.0, "strain_xx": 0.0, "strain_xy": gamma / 2}
        exact = truth
    else:  # r(t) = c + exp(eps t) (r0 - c): v = eps (r - c)
        maps = [lambda xy, t=t: CENTRE + np.exp(eps * t) * (xy - CENTRE) for t in range(5)]
        truth = {"vorticity": 0.0, "divergence": 2 * eps, "strain_xx": 0.0, "strain_xy": 0.0}
        exact = {"divergence": 2 * np.sinh(eps)}
    cells, grid, flow = fields_of(moved(tissue, maps))
    rows = interior(flow, 2)
    for name, value in truth.items():
        got = rows[name].to_numpy()
        scale = max(abs(v) for v in truth.values())
        assert np.abs(got - value).max() <= 0.01 * scale, (name, got.min(), got.max(), value)
        if name in exact:
            np.testing.assert_allclose(got, exact[name], rtol=1e-9, atol=1e-12)
    # the fitted velocity at each node is the motion's velocity there
    node = rows[["x", "y"]].to_numpy() - CENTRE
    if case == "shear":
        np.testing.assert_allclose(rows["vx"], gamma * node[:, 1], atol=1e-9)
        np.testing.assert_allclose(rows["vy"], 0.0, atol=1e-9)
    assert (flow["frame"].isin([0, 4]) & flow["valid"]).sum() == 0  # no velocity on the first and last frame
    pd.testing.assert_series_equal(flow["node"], grid["node"])


@pytest.mark.parametrize("periodic", [False, True])
def test_a_uniform_translation_has_zero_gradients(tissue, periodic):
    box = Box(SHAPE[1], SHAPE[0]) if periodic else None
    shift = np.array([1.7, -0.6])
    cells, grid, flow = fields_of(moved(tissue, [lambda xy, t=t: xy + t * shift for t in range(4)], box), box)
    rows = interior(flow, 1)
    for name in ("vorticity", "divergence", "strain_xx", "strain_xy"):
        assert np.abs(rows[name]).max() < 1e-12, name
    np.testing.assert_allclose(rows[["vx", "vy"]].to_numpy(), np.broadcast_to(shift, (len(rows), 2)), rtol=1e-12)


def test_kernel_matches_reference_and_counts_the_disk():
    rng = np.random.default_rng(0)
    for period in (np.zeros(2), np.array([60.0, 50.0])):
        n_frames, m = 3, 60
        frames = np.sort(rng.integers(0, n_frames + 1, m))  # frame 3 has cells but no nodes
        cx, cy = rng.uniform(0, 60, m), rng.uniform(0, 50, m)  # inside the box, as the kernel wants
        cu, cv = rng.normal(size=m), rng.normal(size=m)
        cx[:4], cy[:4] = [10, 12, 14, 16], 20.0  # four collinear cells: no fit around them alone
        blocks = np.arange(n_frames)
        cb = np.c_[np.searchsorted(frames, blocks), np.searchsorted(frames, blocks, "right")]
        nf = np.repeat(blocks, 40)
        nx, ny = rng.uniform(-5, 65, len(nf)), rng.uniform(-5, 55, len(nf))
        nr = rng.choice([4.0, 9.0, 14.0, 40.0], len(nf))
        nb = np.c_[np.searchsorted(nf, blocks), np.searchsorted(nf, blocks, "right")]
        out_k, out_r = np.empty((6, len(nf))), np.empty((6, len(nf)))
        n_k, n_r = np.empty(len(nf), np.int64), np.empty(len(nf), np.int64)
        K.affine_fits(cx, cy, cu, cv, cb, nx, ny, nr, nb, period, 3, out_k, n_k)
        R.affine_fits(cx, cy, cu, cv, cb, nx, ny, nr, nb, period, 3, out_r, n_r)
        np.testing.assert_array_equal(n_k, n_r)
        np.testing.assert_allclose(out_k, out_r, rtol=1e-9, atol=1e-9)
        assert np.isfinite(out_k).all(axis=0).sum() > 20 and np.isnan(out_k).all(axis=0).sum() > 5


def test_collinear_cells_give_no_gradient():
    cells = pd.DataFrame({"frame": 0, "x": [0.0, 1.0, 2.0, 3.0], "y": 0.0, "vx": [0.0, 1.0, 2.0, 3.0], "vy": 0.0})
    grid = pd.DataFrame({"frame": [0], "node": [0], "x": [1.5], "y": [0.0], "radius": [5.0], "valid": [True]})
    flow = flow_fields(cells, grid, radius_factor=1.0)
    assert flow["n_cells"].tolist() == [4] and not flow["valid"].any() and np.isnan(flow["vorticity"]).all()


@pytest.mark.parametrize("kwargs, match", [
    ({"radius_factor": 0}, "radius_factor must be a positive"),
    ({"min_cells": 2}, "min_cells must be an integer >= 3"),
    ({"box": "periodic"}, "box must be a hexatissue.Box"),
])
def test_flow_fields_bad_input(kwargs, match):
    cells = pd.DataFrame({"frame": [0], "x": [0.0], "y": [0.0], "vx": [0.0], "vy": [0.0]})
    grid = pd.DataFrame({"frame": [0], "node": [0], "x": [0.0], "y": [0.0], "radius": [5.0], "valid": [True]})
    with pytest.raises(InputError, match=match):
        flow_fields(cells, grid, **kwargs)
    with pytest.raises(InputError, match=r"cells is missing column\(s\) \['vx', 'vy'\]"):
        flow_fields(cells.drop(columns=["vx", "vy"]), grid)


# --- statistics ----------------------------------------------------------------------------------------------

def test_velocity_statistics_of_a_drift_and_of_opposite_motions():
    from hexatissue.flow import velocity_statistics

    cells = pd.DataFrame({"frame": [0, 0, 0, 1, 1, 1], "x": 0.0, "y": 0.0,
                          "vx": [3.0, 3.0, 3.0, 1.0, -1.0, np.nan], "vy": [4.0, 4.0, 4.0, 0.0, 0.0, 0.0],
                          "is_border": [False, False, False, False, False, False]})
    stats = velocity_statistics(cells)
    assert stats["frame"].tolist() == [0, 1] and stats["n_cells"].tolist() == [3, 2]
    np.testing.assert_allclose(stats["mean_speed"], [5.0, 1.0])
    np.testing.assert_allclose(stats["polar_order"], [1.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(stats[["mean_vx", "mean_vy"]].to_numpy(), [[3.0, 4.0], [0.0, 0.0]], atol=1e-15)


def test_velocity_correlation_is_each_bins_normalised_pair_sum_of_the_fluctuations():
    from hexatissue.flow import velocity_correlation

    rng = np.random.default_rng(2)
    box = Box(40.0, 30.0)
    cells = pd.DataFrame({"frame": np.repeat([0, 1], 12), "x": rng.uniform(0, 40, 24), "y": rng.uniform(0, 30, 24),
                          "vx": rng.normal(size=24), "vy": rng.normal(size=24)})
    got = velocity_correlation(cells, box, r_max=15.0, bins=3)
    # brute force: every pair i < j of the same frame (no self-pairs), minimum image
    dot, norm, count = np.zeros(3), np.zeros(3), np.zeros(3)
    for _, f in cells.groupby("frame"):
        xy, dv = f[["x", "y"]].to_numpy(), f[["vx", "vy"]].to_numpy()
        dv = dv - dv.mean(axis=0)
        for i in range(len(f)):
            for j in range(i + 1, len(f)):
                r = np.hypot(*box.min_image(xy[j] - xy[i]))
                if r <= 15.0:
                    k = min(int(r // 5.0), 2)
                    dot[k] += dv[i] @ dv[j]
                    norm[k] += 0.5 * (dv[i] @ dv[i] + dv[j] @ dv[j])
                    count[k] += 1
    np.testing.assert_array_equal(got["n_pairs"], count)
    np.testing.assert_allclose(got["correlation"], dot / norm, rtol=1e-12)
    np.testing.assert_allclose(got["r"], [2.5, 7.5, 12.5])
    assert (got["correlation"].abs() <= 1).all() and (got["correlation_sd"] > 0).all()


def test_velocity_correlation_of_a_few_close_fast_cells_stays_within_one():
    # two cells close together moving fast the same way, among slow ones: the old normalisation by the mean
    # fluctuation of every cell gave C > 1 in the first bin (1.3 on a real movie)
    from hexatissue.flow import velocity_correlation

    rng = np.random.default_rng(1)
    x, y = rng.uniform(20, 180, 60), rng.uniform(20, 180, 60)
    vx, vy = 0.1 * rng.normal(size=60), 0.1 * rng.normal(size=60)
    x[1], y[1], vx[:2], vy[:2] = x[0] + 1.0, y[0], 3.0, 0.0
    got = velocity_correlation(pd.DataFrame({"frame": 0, "x": x, "y": y, "vx": vx, "vy": vy}), r_max=20.0, bins=10)
    assert got["correlation"].iloc[0] == pytest.approx(1.0, abs=0.02)
    assert (got["correlation"].dropna().abs() <= 1 + 1e-12).all()


def _exponential_field(n, xi, rng):
    """A Gaussian random field on an n x n torus with covariance exp(-r / xi), unit variance
    (2-D spectrum (1 + k^2 xi^2)^(-3/2))."""
    k = 2 * np.pi * np.fft.fftfreq(n)
    amplitude = (1 + (k[:, None] ** 2 + k[None, :] ** 2) * xi ** 2) ** -0.75
    field = np.real(np.fft.ifft2(np.fft.fft2(rng.normal(size=(n, n))) * amplitude))
    return field / field.std()


def _correlated_cells(xi, noise=0.0, frames=8, n=500, spacing=10, seed=0):
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:n:spacing, 0:n:spacing]
    rows = []
    for t in range(frames):
        vx, vy = _exponential_field(n, xi, rng)[y, x].ravel(), _exponential_field(n, xi, rng)[y, x].ravel()
        rows.append(pd.DataFrame({"frame": t, "track": np.arange(x.size), "x": x.ravel().astype(float),
                                  "y": y.ravel().astype(float),
                                  "vx": vx + noise * rng.normal(size=vx.size),
                                  "vy": vy + noise * rng.normal(size=vx.size), "area": float(spacing ** 2)}))
    return pd.concat(rows, ignore_index=True), Box(float(n), float(n))


def test_correlation_length_of_a_field_with_exponential_correlation():
    from hexatissue.flow import correlation_length, flow_summary, velocity_correlation

    cells, box = _correlated_cells(30.0)
    fit = correlation_length(velocity_correlation(cells, box, r_max=150.0), spacing=10.0)
    assert fit.reason == "" and fit.n_bins >= 3
    assert fit.length == pytest.approx(30.0, rel=0.08) and 0 < fit.sd < 0.1 * fit.length
    assert fit.amplitude == pytest.approx(1.0, abs=0.1)
    # velocity noise uncorrelated between cells lowers the amplitude, not the length
    noisy, _ = _correlated_cells(30.0, noise=1.0)
    fit_noisy = correlation_length(velocity_correlation(noisy, box, r_max=150.0), spacing=10.0)
    assert fit_noisy.length == pytest.approx(30.0, rel=0.1) and fit_noisy.amplitude == pytest.approx(0.5, abs=0.08)
    summary = flow_summary(cells, box, velocity_correlation(cells, box, r_max=150.0),
                           pd.DataFrame({"lag": [1], "msd": [1.0]}))
    assert summary["cell_spacing"] == 10.0 and summary["correlation_length"] == pytest.approx(fit.length)
    assert summary["correlation_reason"] == ""


def test_correlation_length_is_refused_with_its_reason():
    from hexatissue.flow import correlation_length, velocity_correlation

    cells, box = _correlated_cells(30.0, frames=3)
    rng = np.random.default_rng(4)
    white = cells.assign(vx=rng.normal(size=len(cells)), vy=rng.normal(size=len(cells)))
    fit = correlation_length(velocity_correlation(white, box, r_max=150.0), spacing=10.0)
    assert np.isnan(fit.length) and "hardly correlate" in fit.reason
    # a decay shorter than a cell spacing: refused, naming the spacing
    r = np.arange(10.0, 60.0, 5.0)
    short = pd.DataFrame({"r": r, "correlation": 0.5 * np.exp(-r / 4.0) + 1e-4, "n_pairs": 1000})
    fit = correlation_length(short, spacing=10.0)
    assert np.isnan(fit.length) and "below one cell spacing (10 px)" in fit.reason
    assert correlation_length(short).length == pytest.approx(4.0, rel=0.05)
    # C(r) that hardly decays over the field: longer than the field measures
    flat = pd.DataFrame({"r": r, "correlation": 0.9 * np.exp(-r / 500.0), "n_pairs": 1000})
    fit = correlation_length(flat, spacing=10.0)
    assert np.isnan(fit.length) and "longer than the field" in fit.reason
    # a bin of a few pairs (two tiny cells) does not decide it
    sparse = short.assign(correlation=np.where(r == 10.0, -0.5, short["correlation"]),
                          n_pairs=np.where(r == 10.0, 3, 1000))
    assert correlation_length(sparse).length == pytest.approx(4.0, rel=0.05)


def test_a_noisy_bin_near_zero_does_not_end_the_fit_but_a_significant_zero_does():
    from hexatissue.flow import correlation_length

    r = np.arange(10.0, 90.0, 5.0)
    c = 0.8 * np.exp(-r / 25.0)
    table = pd.DataFrame({"r": r, "correlation": c, "correlation_sd": 0.01, "n_pairs": 1000})
    noisy_first = table.assign(correlation=np.where(r == 10.0, -0.05, c), correlation_sd=np.where(r == 10.0, 0.3, 0.01))
    fit = correlation_length(noisy_first, spacing=8.0)
    assert fit.n_bins == len(r) and fit.length == pytest.approx(25.0, rel=0.05)
    significant = table.assign(correlation=np.where(r == 30.0, -0.05, c))  # below 0 by 5 s.e.: C's first zero
    assert correlation_length(significant, spacing=8.0).n_bins == 4


def test_rms_step_exceeds_the_centred_velocity_by_the_centroid_jitter():
    from hexatissue.flow import cell_velocities, rms_step

    rng = np.random.default_rng(5)
    t = np.arange(200)
    jitter = 0.3
    x = 10.0 + 0.5 * t + jitter * rng.normal(size=t.size)  # steady 0.5 px/frame plus white centroid noise
    cells = pd.DataFrame({"frame": t, "track": 1, "x": x, "y": 20.0 + jitter * rng.normal(size=t.size)})
    vx, vy = cell_velocities(cells)
    rms_v = np.sqrt(np.nanmean(vx ** 2 + vy ** 2))
    # steps: 0.5^2 + 2 * 2 jitter^2; centred differences: 0.5^2 + 2 * jitter^2 / 2
    assert rms_step(cells) == pytest.approx(np.sqrt(0.25 + 4 * jitter ** 2), rel=0.1)
    assert rms_v == pytest.approx(np.sqrt(0.25 + jitter ** 2), rel=0.1)


def test_msd_of_ballistic_tracks_is_quadratic_across_the_periodic_edge():
    from hexatissue.flow import mean_squared_displacement, msd_exponent

    box = Box(50.0, 50.0)
    t = np.arange(30)
    speed = np.array([[1.5, 0.5], [-2.0, 1.0]])
    rows = []
    for k, v in enumerate(speed):
        xy = box.wrap(np.array([10.0, 20.0]) + t[:, None] * v)
        rows.append(pd.DataFrame({"frame": t, "track": k + 1, "x": xy[:, 0], "y": xy[:, 1]}))
    cells = pd.concat(rows, ignore_index=True)
    cells = cells[~((cells["track"] == 2) & (cells["frame"] == 10))]  # a gap: no pair spans it
    msd = mean_squared_displacement(cells, box, lags=[1, 5, 20])
    # track 1: 30 - lag pairs; track 2 is frames 0-9 and 11-29: (10 - lag)+ + (19 - lag)+
    assert msd["n_pairs"].tolist() == [29 + 27, 25 + 19, 10 + 0]
    lag = msd["lag"].to_numpy(float)
    pairs = msd["n_pairs"].to_numpy(float)
    n1 = 30 - lag
    expected = (n1 * (speed[0] ** 2).sum() + (pairs - n1) * (speed[1] ** 2).sum()) * lag ** 2 / pairs
    np.testing.assert_allclose(msd["msd"], expected, rtol=1e-12)
    lags = np.array([1.0, 2.0, 4.0, 8.0, 16.0])
    assert msd_exponent(pd.DataFrame({"lag": lags, "msd": 3.0 * lags ** 1.5})) == pytest.approx(1.5, rel=1e-12)


# --- the stage, end to end ------------------------------------------------------------------------------------

def test_analyze_of_a_rotating_voronoi_movie_recovers_its_vorticity_and_reports_it(tmp_path):
    from hexatissue import Calibration, FlowOptions, read_results
    from hexatissue.workflows.report import report

    omega = 0.02  # rad/frame; Voronoi tessellations rotate with their seeds, so the cells rotate rigidly
    seeds = jittered_seeds(SHAPE, 12.0, seed=3)
    labels = np.stack([voronoi_labels(rotation(omega * t)(seeds), SHAPE) for t in range(5)])
    movie = analyze(labels, workers=1, progress=False)
    movie.calibration = Calibration(0.5, "um", 2.0, "min")
    rows = interior(movie.flow, 2)
    # pixel centroids rotate with the cells up to their rasterisation
    assert np.median(rows["vorticity"]) == pytest.approx(2 * np.sin(omega), rel=0.01)
    assert np.abs(np.median(rows["divergence"])) < 0.01 * 2 * omega
    assert np.isnan(movie.cells.loc[movie.cells["frame"].isin([0, 4]), "vx"]).all()
    movie.write(tmp_path / "out")
    back = read_results(tmp_path / "out")
    pd.testing.assert_frame_equal(back.flow, movie.flow)
    assert back.options["flow"] == FlowOptions()
    numbers = report(tmp_path / "out")
    text = (tmp_path / "out" / "report" / "report.md").read_text()
    assert "## Tissue flow" in text and "µm/min" in text and "flow_frame0002.png" in text
    assert (tmp_path / "out" / "report" / "flow_frame0002.png").stat().st_size > 10_000
    speed = np.hypot(movie.cells["vx"], movie.cells["vy"])[~movie.cells["is_border"]].mean()
    assert numbers["flow"]["mean_speed"] == pytest.approx(speed)
    off = analyze(labels, workers=1, progress=False, flow=FlowOptions(enabled=False))
    assert "vx" not in off.cells.columns and "flow" not in off.tables


def test_flow_flags():
    from hexatissue import FlowOptions
    from hexatissue.cli import build_parser, stage_options

    args = build_parser().parse_args(["analyze", "x.tif", "--out", "o", "--no-flow", "--flow-radius-factor", "3"])
    assert stage_options(args)["flow"] == FlowOptions(enabled=False, radius_factor=3.0)
    with pytest.raises(InputError, match="FlowOptions.min_cells must be an integer >= 3"):
        FlowOptions(min_cells=2)


# --- flow around T1 events -------------------------------------------------------------------------------------

def _event_field(rho):
    """A flow in an event's axes: v_r = 0.3 cos 6 phi, v_phi = -0.2 sin 2 phi (px/frame)."""
    phi = np.arctan2(rho[:, 1], rho[:, 0])
    vr, vt = 0.3 * np.cos(6 * phi), -0.2 * np.sin(2 * phi)
    return np.c_[vr * np.cos(phi) - vt * np.sin(phi), vr * np.sin(phi) + vt * np.cos(phi)]


def test_t1_flow_rotates_each_event_into_its_axes_and_the_harmonics_are_exact():
    from hexatissue.flow import angular_harmonics, t1_flow

    rng = np.random.default_rng(4)
    tables, events, s = [], [], 6.0
    for e in range(6):
        centre, theta, drift = rng.uniform(40, 60, 2), rng.uniform(-np.pi, np.pi), rng.normal(size=2)
        rot = np.array([[np.cos(theta), -np.sin(theta)], [np.sin(theta), np.cos(theta)]])
        rho = np.r_[[[0, s], [0, -s], [-s, 0], [s, 0]], rng.uniform(-30, 30, (60, 2))]  # a, b, c, d, others
        xy = centre + rho @ rot.T
        v = _event_field(rho) @ rot.T + drift
        track = 100 * e + np.arange(len(rho))
        tables.append(pd.DataFrame({"frame": e, "track": track, "x": xy[:, 0], "y": xy[:, 1],
                                    "vx": v[:, 0], "vy": v[:, 1]}))
        events.append((e, "cycle" if e % 2 else "intercalation", e, *track[:4]))
    cells = pd.concat(tables, ignore_index=True)
    events = pd.DataFrame(events, columns=["event", "kind", "frame_start", "cell_a", "cell_b", "cell_c", "cell_d"])
    average, samples = t1_flow(cells, events, offsets=[0, 1], extent=20.0, bin_size=4.0)
    assert set(samples["offset"]) == {0}  # no frame 1 of any event: nothing at offset 1
    d = samples[np.isclose(samples["x"], s) & np.isclose(samples["y"], 0.0)]
    assert sorted(d["event"]) == list(range(6))  # cell d lands on +x in every event's axes
    rho = samples[["x", "y"]].to_numpy()
    np.testing.assert_allclose(samples[["vx", "vy"]].to_numpy(), _event_field(rho), atol=1e-12)  # drift removed
    assert np.hypot(*rho.T).max() <= 20.0
    harmonics = angular_harmonics(samples, r_min=1.0)
    for kind, group in harmonics.groupby("kind"):
        radial = group.set_index("n")[["radial_cos", "radial_sin"]]
        tangential = group.set_index("n")[["tangential_cos", "tangential_sin"]]
        expected_r, expected_t = np.zeros((9, 2)), np.zeros((9, 2))
        expected_r[6, 0], expected_t[2, 1] = 0.3, -0.2
        np.testing.assert_allclose(radial.to_numpy(), expected_r, atol=1e-10)
        np.testing.assert_allclose(tangential.to_numpy(), expected_t, atol=1e-10)
    # the bins hold the means of their samples, and count the events of each kind
    assert set(average["n_events"]) == {3}
    np.testing.assert_allclose((average["vx"] * average["n_samples"]).sum(), samples["vx"].sum())
    assert average["n_samples"].sum() == len(samples)


@pytest.mark.parametrize("charge", [1, -1])
def test_defect_flow_turns_each_defect_by_its_orientation(charge):
    from hexatissue.flow import defect_flow

    p, rng = 6, np.random.default_rng(5 + charge)
    s = charge / p
    box = Box(80.0, 80.0)
    tables, grids, defects = [], [], []
    for t in range(3):
        centre, theta0 = rng.uniform(0, 80, 2), rng.uniform(-0.9, 0.9) * np.pi / p
        alpha = theta0 / (1 - s)
        gx, gy = np.meshgrid(np.arange(2.5, 80, 5.0), np.arange(2.5, 80, 5.0))
        d = box.min_image(np.c_[gx.ravel(), gy.ravel()] - centre)
        gamma = 0.8 * np.exp(1j * p * (s * np.arctan2(d[:, 1], d[:, 0]) + theta0))
        grids.append(pd.DataFrame({"frame": t, "x": gx.ravel(), "y": gy.ravel(), "Gamma6_re": gamma.real,
                                   "Gamma6_im": gamma.imag, "valid": True, "spacing": 5.0}))
        rho = rng.uniform(-25, 25, (80, 2))
        rot = np.array([[np.cos(alpha), -np.sin(alpha)], [np.sin(alpha), np.cos(alpha)]])
        xy = box.wrap(centre + rho @ rot.T)
        v = _event_field(rho) @ rot.T + rng.normal(size=2)
        tables.append(pd.DataFrame({"frame": t, "track": np.arange(80), "x": xy[:, 0], "y": xy[:, 1],
                                    "vx": v[:, 0], "vy": v[:, 1]}))
        defects.append((t, 10 + t, *centre, s, p))
    cells = pd.concat(tables, ignore_index=True)
    defects = pd.DataFrame(defects, columns=["frame", "defect", "x", "y", "charge", "p"])
    average, samples = defect_flow(cells, defects, pd.concat(grids, ignore_index=True), p=p, box=box,
                                   extent=20.0, bin_size=4.0)
    assert set(samples["kind"]) == {"+1/6" if charge > 0 else "-1/6"} and set(samples["event"]) == {10, 11, 12}
    for _, group in samples.groupby("event"):
        rho = group[["x", "y"]].to_numpy()
        expected = _event_field(rho)
        np.testing.assert_allclose(group[["vx", "vy"]].to_numpy(), expected - expected.mean(axis=0), atol=1e-9)
        assert np.hypot(*rho.T).max() <= 20.0


def test_a_frame_without_grid_nodes_lends_its_cells_to_no_other_frame():
    rng = np.random.default_rng(7)
    xy = rng.uniform(0, 40, (30, 2))
    cells = pd.concat([pd.DataFrame({"frame": t, "x": xy[:, 0], "y": xy[:, 1], "vx": float(t + 1), "vy": 0.0})
                       for t in range(3)], ignore_index=True)
    grid = pd.DataFrame({"frame": [2, 0], "node": [0, 0], "x": 20.0, "y": 20.0, "radius": 15.0, "valid": True})
    flow = flow_fields(cells, grid, radius_factor=1.0)  # frame 1 has cells but no node; the grid is not sorted
    np.testing.assert_allclose(flow["vx"], [3.0, 1.0], rtol=1e-12)
    assert flow["frame"].tolist() == [2, 0] and flow["valid"].all()


def test_event_flow_bad_input():
    from hexatissue.flow import t1_flow

    cells = pd.DataFrame({"frame": [0], "track": [1], "x": [0.0], "y": [0.0], "vx": [0.0], "vy": [0.0]})
    events = pd.DataFrame({"event": [0], "kind": ["cycle"], "frame_start": [0], "cell_a": [1], "cell_b": [2],
                           "cell_c": [3], "cell_d": [4]})
    with pytest.raises(InputError, match="cells needs an 'area' column"):
        t1_flow(cells, events)
    with pytest.raises(InputError, match="offsets must be one or more integers"):
        t1_flow(cells, events, offsets=[0.5], extent=10.0, bin_size=2.0)
    with pytest.raises(InputError, match=r"events is missing column\(s\) \['cell_d'\]"):
        t1_flow(cells, events.drop(columns="cell_d"), extent=10.0, bin_size=2.0)
    average, samples = t1_flow(cells, events, extent=10.0, bin_size=2.0)  # cells b, c, d absent: no sample
    assert len(average) == 0 and len(samples) == 0
