"""MPF parameter sweeps: runs, analyses, resume and skip."""
import json

import numpy as np
import pandas as pd
import pytest

from hexatissue import Calibration, EventOptions, read_results
from hexatissue.workflows import sweep
from hexatissue.errors import InputError
from hexatissue.simulate import Params, read_run, run_simulation

BASE = Params(n_cells=6, Lx=48, Ly=44, v0=0.01)
RUN = dict(steps=60, save_every=10, relax=30, seed=5)
ANALYZE = {"events": EventOptions(censor=2)}


def test_sweep_runs_analyses_and_skips_finished_runs(tmp_path):
    out = tmp_path / "sw"
    table = sweep("dr", [1e-3, 1e-2], out, params=BASE, workers=1, progress=False, **ANALYZE, **RUN)
    assert table["status"].tolist() == ["new", "new"]
    assert table["value"].tolist() == [1e-3, 1e-2] and set(table["param"]) == {"D_r"}
    for value, path, results in table[["value", "path", "results"]].itertuples(index=False):
        run = read_run(path)
        assert run.params.D_r == value and len(run) == 7 and run.params.n_cells == 6
        cells = pd.read_parquet(f"{results}/cells.parquet")
        assert sorted(cells["frame"].unique()) == list(range(7))
        assert json.loads(open(f"{results}/metadata.json").read())["box"] == [48.0, 44.0]
    assert (out / "D_r=0.001" / "done.json").exists()
    stamp = (out / "D_r=0.001" / "done.json").stat().st_mtime_ns
    again = sweep("D_r", [1e-3, 1e-2], out, params=BASE, workers=1, progress=False, **ANALYZE, **RUN)
    assert again["status"].tolist() == ["skipped", "skipped"]
    assert (out / "D_r=0.001" / "done.json").stat().st_mtime_ns == stamp
    assert again["n_frames"].tolist() == [7, 7]


def test_sweep_resumes_a_partial_run_exactly(tmp_path):
    out = tmp_path / "sw"
    part = out / "D_r=0.001" / "run.zarr"
    part.parent.mkdir(parents=True)
    run_simulation(part, BASE.replace(D_r=1e-3), steps=30, save_every=10, relax=30, seed=5, progress=False)
    assert len(read_run(part)) == 4
    table = sweep("dr", [1e-3], out, params=BASE, workers=1, progress=False, **ANALYZE, **RUN)
    assert table["status"].tolist() == ["resumed"] and table["n_frames"].tolist() == [7]
    full = tmp_path / "full.zarr"
    run_simulation(full, BASE.replace(D_r=1e-3), progress=False, **RUN)
    np.testing.assert_array_equal(np.asarray(read_run(part).labels), np.asarray(read_run(full).labels))


def test_sweep_refuses_to_mix_settings(tmp_path):
    out = tmp_path / "sw"
    sweep("dr", [1e-3], out, params=BASE, workers=1, progress=False, **ANALYZE, **RUN)
    (out / "D_r=0.001" / "done.json").unlink()
    with pytest.raises(InputError, match="seed"):
        sweep("dr", [1e-3], out, params=BASE, workers=1, progress=False, **{**RUN, "seed": 6})


def test_sweep_never_overwrites_a_foreign_folder(tmp_path):
    foreign = tmp_path / "sw" / "D_r=0.001" / "run.zarr"
    foreign.mkdir(parents=True)
    (foreign / "precious.txt").write_text("keep me")
    with pytest.raises(InputError, match="not an MPF run store"):
        sweep("dr", [1e-3], tmp_path / "sw", params=BASE, workers=1, progress=False, **RUN)
    assert (foreign / "precious.txt").read_text() == "keep me"


def test_sweep_bad_input(tmp_path):
    with pytest.raises(InputError, match="Params field"):
        sweep("speed", [1.0], tmp_path, params=BASE)
    with pytest.raises(InputError, match="at least one"):
        sweep("dr", [], tmp_path, params=BASE)
    with pytest.raises(InputError, match="duplicate"):
        sweep("dr", [1e-3, 0.001], tmp_path, params=BASE)


@pytest.mark.slow
def test_sweep_in_local_processes_and_on_dask(tmp_path):
    from distributed import Client, LocalCluster

    local = sweep("dr", [1e-3, 1e-2], tmp_path / "local", params=BASE, workers=2, progress=False,
                  **ANALYZE, **RUN)
    assert local["status"].tolist() == ["new", "new"]
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
            Client(cluster) as client:
        remote = sweep("dr", [1e-3, 1e-2], tmp_path / "dask", params=BASE, client=client, progress=False,
                       **ANALYZE, **RUN)
    assert remote["status"].tolist() == ["new", "new"]
    for a, b in zip(local["path"], remote["path"]):
        np.testing.assert_array_equal(np.asarray(read_run(a).labels), np.asarray(read_run(b).labels))


def test_figure3_from_a_sweep(tmp_path):
    from scipy import stats

    from hexatissue.workflows import figure3

    table = sweep("dr", [1e-3, 1e-2], tmp_path / "sw", params=BASE.replace(n_cells=8, Lx=56, Ly=50), workers=1,
                  progress=False, **ANALYZE, **RUN)
    summary = figure3(table, tmp_path / "fig", dt=2, dl=20.0)
    fig = tmp_path / "fig"
    for name in ("fig3e.png", "fig3f.png", "fig3g_box.png", "fig3g_vs_param.png", "summary.json"):
        assert (fig / name).exists()
    ev, ctrl = pd.read_csv(fig / "fig3e_distances.csv"), pd.read_csv(fig / "fig3e_control.csv")
    assert set(ev["D_r"]) <= {1e-3, 1e-2} and len(ctrl) == 5 * len(ev)
    pooled = summary["fig3e"]["pooled"]
    if len(ev):
        assert pooled["ks_pvalue"] == pytest.approx(stats.ks_2samp(ev["dr"], ctrl["dr"]).pvalue)
    mig = pd.read_csv(fig / "fig3f_migration.csv")
    assert set(mig["D_r"]) == {1e-3, 1e-2} and set(mig["frame_end"] - mig["frame_start"]) == {2}
    across = pd.read_csv(fig / "fig3g_summary.csv")
    assert sorted(across["D_r"].unique()) == [1e-3, 1e-2] and len(across) == 8  # 2 runs x 2 quantities x 2 definitions
    assert across.groupby("definition").size().to_dict() == {"cell_neighbours": 4, "quartet": 4}
    assert json.loads((fig / "summary.json").read_text())["values"] == [1e-3, 1e-2]
    # the report's default migration window is the paper's 25,000 iterations when the movie spans it
    from hexatissue.workflows.report import default_window

    movie = read_results(table["results"][0])
    assert movie.calibration == Calibration(frame_interval=RUN["save_every"], time_unit="iteration")
    assert summary["frame_interval"] == RUN["save_every"] and summary["time_unit"] == "iteration"
    assert default_window(movie.replace(n_frames=10_000)) == 25_000 // RUN["save_every"]
    assert default_window(movie) == 7 // 4  # the run is shorter than the paper's window
    assert default_window(movie.replace(n_frames=40, calibration=Calibration())) == 10


def test_loglog_slope_is_exact_on_a_power_law():
    from hexatissue.workflows import loglog_slope

    x = np.array([1e-6, 1e-5, 4e-5, 8e-5])
    assert loglog_slope(x, 3.0 * x**-0.5) == pytest.approx(-0.5)
    assert loglog_slope(x, np.full(4, 7.0)) == pytest.approx(0.0)
    assert np.isnan(loglog_slope([1.0], [2.0]))
