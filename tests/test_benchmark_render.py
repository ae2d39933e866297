"""Synthetic benchmarks: truth movies, OpenCV rendering and benchmark folders, against exact truth."""
import json
from pathlib import Path

import cv2
import numpy as np
import pandas as pd
import pytest
import tifffile

from hexatissue import InputError, open_source, read_results
from hexatissue.benchmark import (Renderer, RenderOptions, crop_labels, make_benchmark, truth_from_labels,
                                  truth_from_run, truth_from_t1, truth_from_voronoi)
from hexatissue.benchmark.truth import T1_KEY
from hexatissue.cli import main
from hexatissue.synthetic import t1_movie

ROOT = Path(__file__).resolve().parents[1]
RUN = ROOT / "hexatissue" / "sample_data" / "mpf_small" / "run.zarr"
QUIET = dict(progress=False)


@pytest.fixture(scope="module")
def periodic():
    return truth_from_voronoi(40, (96, 104), 3, seed=4, **QUIET)


@pytest.fixture(scope="module")
def static():
    """A periodic Voronoi tissue that does not move: every frame has the same geometry."""
    return truth_from_voronoi(40, (96, 104), 4, amplitude=0.0, seed=5, **QUIET)


@pytest.fixture(scope="module")
def run_truth():
    return truth_from_run(RUN, frames=slice(0, 3), **QUIET)


def segment_distance(truth, t):
    """Distance of every pixel centre to the nearest truth junction segment of frame t (min image when periodic)."""
    m = truth.movie
    e = m.edges[m.edges["frame"] == t]
    v = m.vertices[m.vertices["frame"] == t].set_index("vertex")
    a = v.loc[e["vertex_a"], ["x", "y"]].to_numpy()
    d = v.loc[e["vertex_b"], ["x", "y"]].to_numpy() - a
    rows, cols = truth.labels.shape[1:]
    period = None if truth.box is None else np.array([truth.box.Lx, truth.box.Ly])
    if period is not None:
        d -= period * np.round(d / period)
    else:  # the image edge is not a membrane
        edge = lambda p: (p[:, 0] < 0.5) | (p[:, 0] > cols - 1.5) | (p[:, 1] < 0.5) | (p[:, 1] > rows - 1.5)
        keep = ~((e["cell_a"].to_numpy() == 0) & edge(a) & edge(a + d))
        a, d = a[keep], d[keep]
    y, x = np.mgrid[:rows, :cols]
    pix = np.c_[x.ravel(), y.ravel()].astype(float)
    best = np.full(len(pix), np.inf)
    for p0, dd in zip(a, d):
        r = pix - p0
        if period is not None:
            r -= period * np.round(r / period)
        s = np.clip(r @ dd / max(dd @ dd, 1e-12), 0, 1)
        best = np.minimum(best, np.hypot(*(r - s[:, None] * dd).T))
    return best.reshape(rows, cols)


def electrons(frame, options):
    return (frame.astype(float) - options.offset) / options.gain


def test_same_seed_gives_identical_bytes_and_another_seed_does_not(periodic, tmp_path):
    opts = RenderOptions(curvature=0.05, drift=0.4, nuclei=True)
    a = make_benchmark(periodic, tmp_path / "a", render=opts, seed=3, **QUIET)
    b = make_benchmark(periodic, tmp_path / "b", render=opts, seed=3, **QUIET)
    c = make_benchmark(periodic, tmp_path / "c", render=opts, seed=4, **QUIET)
    assert (a / "raw.tif").read_bytes() == (b / "raw.tif").read_bytes()
    assert (a / "raw.tif").read_bytes() != (c / "raw.tif").read_bytes()
    assert (a / "drift.csv").read_text() == (b / "drift.csv").read_text()


@pytest.mark.parametrize("psf", ["gaussian", "airy"])
def test_brightest_pixels_lie_on_truth_junctions(periodic, psf):
    opts = RenderOptions(snr=40, membrane_width=2, psf=psf, psf_sigma=1.0, curvature=0.0)
    frame = Renderer(periodic, opts, seed=1).frame(1)[0]
    dist = segment_distance(periodic, 1)
    top = frame >= np.quantile(frame, 0.9)
    # a 2-px line blurred by sigma = 1 px: its bright core stays within width / 2 + 1 sigma of the centreline
    assert np.quantile(dist[top], 0.99) <= 2.0
    assert dist[top].max() <= 2.0 + 1.0
    # and the dimmest 50 % are away from junctions: inside the cells
    assert np.median(dist[frame <= np.quantile(frame, 0.5)]) > 3.0


@pytest.mark.parametrize("snr, width, psf", [(8.0, 2, "gaussian"), (3.0, 1, "gaussian"), (5.0, 3, "airy")])
def test_measured_snr_is_the_requested_one(run_truth, snr, width, psf):
    opts = RenderOptions(snr=snr, membrane_width=width, psf=psf, psf_sigma=1.2, cytoplasm=60.0, cytoplasm_cv=0.0,
                         read_noise=3.0, gain=2.5)
    frame = electrons(Renderer(run_truth, opts, seed=2).frame(0)[0], opts)
    dist = segment_distance(run_truth, 0)
    junction = dist <= 0.5
    cytoplasm = (run_truth.labels[0] > 0) & (dist > width / 2 + 3 * 1.2 + 1)
    measured = (frame[junction].mean() - frame[cytoplasm].mean()) / frame[cytoplasm].std()
    assert measured == pytest.approx(snr, rel=0.08)
    # the noise in the cytoplasm is shot noise of its level plus read noise (gain-corrected, electrons)
    assert frame[cytoplasm].std() == pytest.approx(np.sqrt(60.0 + 3.0**2), rel=0.05)


def test_photobleaching_follows_exp_minus_k_t(static):
    opts = RenderOptions(bleach_rate=0.15, read_noise=0.0, cytoplasm=200.0)
    r = Renderer(static, opts, seed=0)
    signal = [electrons(r.frame(t)[0], opts).mean() for t in range(len(static))]
    ratio = np.array(signal) / signal[0]
    np.testing.assert_allclose(ratio, np.exp(-0.15 * np.arange(len(static))), rtol=0.005)


def test_drift_shifts_the_image_by_the_recorded_amount(static):
    from skimage.registration import phase_cross_correlation

    r = Renderer(static, RenderOptions(drift=1.5, snr=30), seed=7)
    assert r.drift.loc[0, ["dx", "dy"]].tolist() == [0.0, 0.0]
    assert np.abs(r.drift[["dx", "dy"]].to_numpy()[1:]).max() > 0.5
    ref = r.clean(0)[0]
    for t in range(1, len(static)):
        shift, _, _ = phase_cross_correlation(ref, r.clean(t)[0], upsample_factor=100)
        # phase_cross_correlation gives the (row, col) shift that moves frame t back onto frame 0
        assert (-shift[1], -shift[0]) == pytest.approx(tuple(r.drift.loc[t, ["dx", "dy"]]), abs=0.02)


def test_rendering_wraps_around_the_periodic_box(periodic):
    """Rolling the labels by whole pixels rolls the rendered image: the box edge is invisible."""
    shift = (37, 51)
    rolled = truth_from_labels(np.roll(periodic.labels, shift, axis=(1, 2)), box=periodic.box, **QUIET)
    opts = RenderOptions(curvature=0.06, nuclei=True)
    a = Renderer(periodic, opts, seed=1).clean(1)
    b = Renderer(rolled, opts, seed=1).clean(1)
    np.testing.assert_allclose(np.roll(a, shift, axis=(1, 2)), b, rtol=0, atol=0.02 * a.max())


def test_nuclear_channel_has_a_bright_disk_at_every_cell_centroid(periodic, tmp_path):
    out = make_benchmark(periodic, tmp_path / "n", render=RenderOptions(nuclei=True, nucleus_radius=3.0), **QUIET)
    raw = tifffile.imread(out / "raw.tif")
    assert raw.shape == (3, 2) + periodic.labels.shape[1:]
    cells = periodic.movie.cells[periodic.movie.cells["frame"] == 0]
    nuc = raw[0, 1].astype(float)
    at_centre = nuc[np.round(cells["y"]).astype(int) % 96, np.round(cells["x"]).astype(int) % 104]
    assert np.all(at_centre > 100 + 10 + 0.5 * 200)  # offset + background + half the nuclear signal
    assert np.median(nuc) < 100 + 10 + 0.2 * 200  # most pixels are outside the nuclei


def test_raw_tif_opens_with_pixel_size_and_frame_interval(periodic, tmp_path):
    out = make_benchmark(periodic, tmp_path / "cal", pixel_size=0.325, frame_interval=5.0, **QUIET)
    with tifffile.TiffFile(out / "raw.tif") as tf:
        assert tf.is_imagej and tf.series[0].axes == "TYX" and tf.series[0].dtype == np.uint16
        assert tf.series[0].shape == periodic.labels.shape
        md = tf.imagej_metadata
        assert md["unit"] == "um" and md["finterval"] == 5.0 and md["tunit"] == "min"
        num, den = tf.pages[0].tags["XResolution"].value
        assert den / num == pytest.approx(0.325, rel=1e-6)
    for path in (out / "raw.tif", out / "truth" / "labels.tif"):
        cal = open_source(path).calibration
        assert (cal.pixel_size, cal.length_unit, cal.frame_interval, cal.time_unit) == (0.325, "um", 5.0, "min")
    meta = json.loads((out / "benchmark.json").read_text())
    assert meta["render"] == RenderOptions().to_dict() and meta["seed"] == 0
    assert meta["source"]["kind"] == "voronoi" and meta["calibration"]["pixel_size"] == 0.325


def test_truth_folder_reads_back_with_the_source_labels(run_truth, tmp_path):
    from hexatissue.simulate import read_run

    np.testing.assert_array_equal(run_truth.labels, np.asarray(read_run(RUN).labels[:3]))
    out = make_benchmark(RUN, tmp_path / "mpf", n_frames=3, **QUIET)
    movie = read_results(out / "truth")
    for name, table in run_truth.movie.tables.items():
        pd.testing.assert_frame_equal(getattr(movie, name), table, check_dtype=False)
    assert movie.box == run_truth.box and movie.calibration.time_unit == "iteration"
    np.testing.assert_array_equal(tifffile.imread(out / "truth" / "labels.tif"), run_truth.labels)
    # no tracking step: track == cell in every row
    assert (movie.cells["track"] == movie.cells["cell"]).all()
    assert movie.summary["tracking"]["resolved"] == "never"


def test_t1_truth_events_are_the_scripted_ones():
    truth = truth_from_t1(periodic=False, seed=2, **QUIET)
    scripted = t1_movie(periodic=False, seed=2).events
    pd.testing.assert_frame_equal(truth.movie.events[T1_KEY].astype({"kind": object}),
                                  scripted[T1_KEY].astype({"kind": object}), check_dtype=False)
    assert set(truth.movie.events["kind"]) == {"cycle", "intercalation", "unresolved"}


def test_crop_gives_an_open_view_with_border_cells_at_its_edge():
    crop = (140, 120, 60, 70)  # wraps across both box edges (box 140 x 151)
    truth = truth_from_run(RUN, frames=[0, 5], crop=crop, **QUIET)
    full = np.asarray(open_source(RUN).frame(5))
    rows, cols = (140 + np.arange(60)) % 151, (120 + np.arange(70)) % 140
    np.testing.assert_array_equal(truth.labels[1], full[np.ix_(rows, cols)])
    assert truth.box is None and truth.source["crop"] == list(crop)
    cells = truth.movie.cells[truth.movie.cells["frame"] == 1]
    lab = truth.labels[1]
    on_edge = set(np.unique(np.r_[lab[0], lab[-1], lab[:, 0], lab[:, -1]]).tolist()) - {0}
    assert set(cells.loc[cells["is_border"], "cell"]) == on_edge
    assert (~cells["is_border"]).sum() >= 3  # and interior cells remain
    assert set(cells["track"]) <= set(np.unique(full).tolist())  # ids are the run's cell ids (tracks)


@pytest.mark.parametrize("field, value", [("snr", 0), ("membrane_width", 1.5), ("psf", "lorentz"),
                                          ("nuclei", "yes"), ("junction_cv", -0.1), ("gain", 0),
                                          ("shot_noise", "none"), ("nucleus_radius", -2.0)])
def test_bad_render_options_name_the_field(field, value):
    with pytest.raises(InputError, match=f"RenderOptions.{field}"):
        RenderOptions(**{field: value})


def test_render_options_round_trip_and_other_bad_input(periodic, tmp_path):
    opts = RenderOptions(snr=3.5, psf="airy", nuclei=True, nucleus_radius=4.0)
    assert RenderOptions.from_dict(opts.to_dict()) == opts
    with pytest.raises(InputError, match="no field"):
        RenderOptions.from_dict({"sn": 3})
    with pytest.raises(InputError, match="crop"):
        crop_labels(periodic.labels, (0, 0, 500, 20))
    with pytest.raises(InputError, match="neither"):
        make_benchmark("voronio", tmp_path / "x", **QUIET)
    with pytest.raises(InputError, match="options"):
        Renderer(periodic, {"snr": 3})
    with pytest.raises(InputError, match="truth must be"):
        Renderer(periodic.labels)
    with pytest.raises(InputError, match="used as it is"):
        make_benchmark(periodic, tmp_path / "y", n_frames=2, **QUIET)
    with pytest.raises(InputError, match="periodic"):
        truth_from_voronoi(20, (60, 60), 1, periodic=False, crop=(0, 0, 30, 30), **QUIET)


def test_cli_make_writes_a_benchmark_folder(tmp_path, capsys):
    out = tmp_path / "cli"
    code = main(["benchmark", "make", "--from", "voronoi", "--cells", "30", "--frames", "2", "--size", "80", "90",
                 "--snr", "6", "--membrane-width", "3", "--psf", "airy", "--seed", "9", "--out", str(out)])
    assert code == 0
    meta = json.loads((out / "benchmark.json").read_text())
    assert meta["render"]["snr"] == 6.0 and meta["render"]["membrane_width"] == 3 and meta["seed"] == 9
    assert set(meta["render"]) == set(RenderOptions().to_dict())
    assert tifffile.imread(out / "raw.tif").shape == (2, 80, 90)
    assert main(["benchmark", "make", "--from", "voronoi", "--snr", "-1", "--out", str(tmp_path / "bad")]) == 2
    assert "--snr must be" in capsys.readouterr().err
    with pytest.raises(InputError, match="neither"):  # --debug after the action shows the traceback
        main(["benchmark", "make", "--from", "voronio", "--out", str(tmp_path / "bad"), "--debug"])


def test_ctc_folder_passes_its_format_check(periodic, tmp_path):
    from hexatissue.exchange.ctc import check_ctc

    out = make_benchmark(periodic, tmp_path / "ctc", **QUIET)
    check_ctc(out / "ctc")
    assert (out / "ctc" / "TRA" / "man_track.txt").exists()


def _encoded_pmf(tables, n):
    """The distribution an alias table of Poisson(n) samples: P(k) = (prob[k] + sum over j aliased to k of 1 - prob[j]) / K."""
    offset, size, prob, alias = tables
    start, k_n = int(offset[n]), int(size[n])
    p, a = prob[start:start + k_n], alias[start:start + k_n]
    pmf = p.copy()
    np.add.at(pmf, a, 1 - p)
    pmf -= np.where(a == np.arange(k_n), 1 - p, 0)
    return pmf / k_n


def test_alias_tables_encode_the_poisson_distribution():
    from scipy.stats import poisson

    from hexatissue.benchmark import _kernels as kernels, _reference as reference

    for tables in (kernels.alias_tables(64), reference.alias_tables(64)):
        for n in (0, 1, 7, 33, 64):
            pmf = _encoded_pmf(tables, n)
            want = poisson.pmf(np.arange(len(pmf)), n) if n else (np.arange(len(pmf)) == 0).astype(float)
            np.testing.assert_allclose(pmf, want, rtol=0, atol=1e-14)
            assert poisson.sf(len(pmf) - 1, n) < 1e-31  # the support left out
    big = kernels.alias_tables(kernels.TABLE_MAX - 1)
    pmf = _encoded_pmf(big, 1000)  # exp(k log n - n - lgamma(k + 1)) of numbers ~7000: 1e-12 relative
    np.testing.assert_allclose(pmf, poisson.pmf(np.arange(len(pmf)), 1000), rtol=1e-11, atol=1e-300)


def _poisson_tables(n_max):
    from hexatissue.benchmark import _kernels as kernels

    return kernels.alias_tables(n_max) + (kernels.RECIPROCALS,)


def test_poisson_kernel_equals_its_reference_on_the_same_key():
    from hexatissue.benchmark import _kernels as kernels, _reference as reference

    rng = np.random.default_rng(11)
    # TABLE_MAX and above: the transformed-rejection sampler
    lam = np.r_[0.0, 1e-6, 0.999, 3.999, 1023.99, 1024.0, rng.uniform(0, 200, 20000), rng.uniform(1e3, 1e5, 2000),
                rng.uniform(0.5, 1, 5000)].astype(np.float32)  # K >= 4 of the fractional mean sometimes
    tables = _poisson_tables(kernels.TABLE_MAX - 1)
    key = np.uint64(0xC0FFEE123456789)
    np.testing.assert_array_equal(kernels.poisson_counts(lam, key, *tables),
                                  reference.poisson_counts(lam, key, *tables))


def test_camera_kernel_equals_its_reference_on_the_same_key():
    from hexatissue.benchmark import _kernels as kernels, _reference as reference

    rng = np.random.default_rng(12)
    # negative and NaN means count as 0; 90000: clipped at 65535; a 0 offset clips read noise at 0
    clean = np.r_[0.0, -3.0, np.nan, 90000.0, rng.uniform(0, 300, 30000), rng.uniform(1e3, 4e4, 500)].astype(np.float32)
    tables = _poisson_tables(kernels.TABLE_MAX - 1)
    for shot_poisson, read_noise, gain, offset in [(True, 2.0, 1.0, 100.0), (True, 3.5, 1.7, 0.0),
                                                   (False, 2.0, 0.8, 100.0), (False, 0.0, 2.0, 10.0)]:
        args = (np.uint64(77), shot_poisson, read_noise, gain, offset, tables, kernels.ZIGGURAT)
        got = kernels.camera(clean, *args)
        assert got.dtype == np.uint16 and got[3] == 65535
        np.testing.assert_array_equal(got, reference.camera(clean, *args))


def test_ziggurat_tables_close_and_the_normal_deviates_are_normal():
    from scipy.stats import kstest, norm

    from hexatissue.benchmark import _kernels as kernels, _reference as reference

    k, w, f = kernels.ZIGGURAT
    x1 = w[1] * 2.0**52  # the top layer's width: its area v = x1 (1 - f(x1)) closes the ziggurat at x0 = 0
    assert x1 * (1 - f[1]) == pytest.approx(4.92867323399e-3, rel=1e-8)
    z = reference.standard_normal(np.uint64(99), np.arange(400000), *kernels.ZIGGURAT)
    assert kstest(z, "norm").pvalue > 1e-3
    # the rare branches: the tail beyond r = 3.654 and the wedges
    r = w[-1] * 2.0**52
    tail = np.abs(z) > r
    assert tail.sum() == pytest.approx(z.size * 2 * norm.sf(r), abs=5 * np.sqrt(z.size * 2 * norm.sf(r)))
    assert kstest(np.abs(z[tail]), lambda x: 1 - norm.sf(x) / norm.sf(r)).pvalue > 1e-3


def test_camera_records_exact_poisson_counts_and_normal_read_noise():
    """The fused camera: counts alone (no read noise, gain 1) are Poisson; read noise alone (no light) is normal."""
    from scipy.stats import chisquare, kstest, poisson

    from hexatissue.benchmark import _kernels as kernels

    tables = _poisson_tables(kernels.TABLE_MAX - 1)
    for mean in (0.6, 42.3):
        x = kernels.camera(np.full(200000, mean, np.float32), np.uint64(5), True, 0.0, 1.0, 0.0, tables,
                           kernels.ZIGGURAT)
        k = np.arange(poisson.ppf(1e-4, mean), poisson.ppf(1 - 1e-4, mean) + 1)
        observed = np.r_[(x < k[0]).sum(), np.histogram(x, np.r_[k, k[-1] + 1] - 0.5)[0], (x > k[-1]).sum()]
        expected = np.r_[poisson.cdf(k[0] - 1, mean), poisson.pmf(k, mean), poisson.sf(k[-1], mean)] * x.size
        keep = expected > 0
        assert chisquare(observed[keep], expected[keep]).pvalue > 1e-3
    # read noise of 1 electron at gain 1000 ADU / electron: ADU = round(1000 z + 30000)
    adu = kernels.camera(np.zeros(200000, np.float32), np.uint64(6), True, 1.0, 1000.0, 30000.0, tables,
                         kernels.ZIGGURAT)
    assert kstest((adu.astype(float) - 30000) / 1000, "norm").pvalue > 1e-3


@pytest.mark.parametrize("mean", [0.3, 7.5, 63.2, 1500.0])  # 1500: above the tables, transformed rejection
def test_poisson_counts_follow_the_poisson_distribution(mean):
    from scipy.stats import chisquare, poisson

    from hexatissue.benchmark.render import poisson_counts

    x = poisson_counts(np.full((400, 500), mean, np.float32), seed=5)
    assert x.shape == (400, 500) and x.dtype == np.float32 and np.all(x == np.round(x))
    assert x.mean() == pytest.approx(mean, abs=5 * np.sqrt(mean / x.size))
    assert x.var() == pytest.approx(mean, rel=0.02)
    # chi-square against the Poisson pmf: one bin per count between the 1e-4 quantiles, the tails pooled
    lo, hi = poisson.ppf(1e-4, mean), poisson.ppf(1 - 1e-4, mean)
    k = np.arange(lo, hi + 1)
    observed = np.r_[(x < lo).sum(), np.histogram(x, np.r_[k, hi + 1] - 0.5)[0], (x > hi).sum()]
    expected = np.r_[poisson.cdf(lo - 1, mean), poisson.pmf(k, mean), poisson.sf(hi, mean)] * x.size
    keep = expected > 0
    assert chisquare(observed[keep], expected[keep]).pvalue > 1e-3
