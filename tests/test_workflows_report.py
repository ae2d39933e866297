"""``hexatissue report`` on analysis folders: a synthetic periodic movie, a single frame, real movies."""
import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from hexatissue import Calibration, EventOptions, OrderOptions, analyze, read_results
from hexatissue.box import Box
from hexatissue.errors import InputError
from hexatissue.synthetic import voronoi_movie
from hexatissue.workflows import command, report

from .conftest import real_subdir

ROOT = Path(__file__).resolve().parents[1]
SAMPLE = ROOT / "hexatissue" / "sample_data" / "epicure_notum" / "013_crop_labels.tif"


def analyze_to(source, out, periodic=False, censor=10, p=(6, 2)):
    """What ``hexatissue analyze SOURCE --out OUT`` does: analyze, then write the results folder."""
    movie = analyze(source, box=True if periodic else None, events=EventOptions(censor=censor),
                    order=OrderOptions(p=p), workers=1, progress=False)
    movie.write(out)
    return out


@pytest.fixture(scope="module")
def movie_results(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("movie")
    m = voronoi_movie(40, (90, 100), 16, periodic=True, amplitude=0.5, seed=1)
    np.save(tmp / "movie.npy", np.stack([m[t] for t in range(len(m))]))
    return analyze_to(tmp / "movie.npy", tmp / "results", periodic=True, censor=3)


def _png_ok(path):
    data = Path(path).read_bytes()
    return data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 5000


def test_the_results_folder_is_read_back_with_its_box(movie_results):
    assert read_results(movie_results).box == Box(100.0, 90.0)


@pytest.fixture(scope="module")
def movie_report(movie_results, tmp_path_factory):
    out = tmp_path_factory.mktemp("report")
    return out, report(movie_results, out, dl=25.0, dt=4, seed=3, order_p=(6,))


def test_report_on_a_periodic_movie(movie_results, movie_report):
    out, numbers = movie_report
    names = {Path(w).name for w in numbers["written"]}
    for name in ("order6_frame0000.png", "order6_frame0015.png", "events.png", "t1_defects.png", "migration.png",
                 "timing.png", "report.md", "t1_defect_distances.csv", "migration.csv", "cell_timing.csv"):
        assert name in names
    assert all(_png_ok(out / n) for n in names if n.endswith(".png"))
    events = pd.read_parquet(movie_results / "events.parquet")
    assert numbers["events"] == events["kind"].astype(str).value_counts().to_dict()
    text = (out / "report.md").read_text()
    for heading in ("## Tissue", "## T1 events", "(Fig. 3e)", "(Fig. 3f)", "(Fig. 3g)"):
        assert heading in text
    for link in ("t1_defects.png", "migration.png", "timing.png"):
        assert f"]({link})" in text
    # Fig. 3g by both definitions: quartets and the paper's per-cell neighbour lists
    per_cell = pd.read_csv(out / "cell_timing_neighbour_lists.csv")
    movie = read_results(movie_results)
    assert "Second definition, the paper's per-cell one" in text and len(per_cell) == movie.cells["track"].nunique()
    # one-frame cycles (flickers) are counted apart, not averaged into cycle periods
    ne = movie.neighbour_events
    flickers = int(((ne["kind"].astype(str) == "cycle") & (ne["duration"] <= 1)).sum())
    assert numbers["timing_per_cell_definition"]["n_flickers"] == flickers
    assert numbers["timing_per_cell_definition"]["n_intercalation_cells"] == \
        per_cell["mean_intercalation_interval"].notna().sum()


def test_report_tables_use_the_box_and_the_window(movie_report):
    out, numbers = movie_report
    prox = pd.read_csv(out / "t1_defect_distances.csv")
    assert numbers["proximity"]["n_events"] == len(prox) > 0
    # minimum image in the recovered box: no offset exceeds half the box
    assert (prox["dx"].abs() <= 50.0 + 1e-9).all() and (prox["dy"].abs() <= 45.0 + 1e-9).all()
    assert len(pd.read_csv(out / "control_distances.csv")) == 5 * len(prox)
    mig = pd.read_csv(out / "migration.csv")
    assert set(mig["frame_end"] - mig["frame_start"]) == {4} and set(mig["frame_start"]) == {0, 4, 8}
    assert numbers["migration"]["n_subregion_windows"] == len(mig)
    timing = pd.read_csv(out / "cell_timing.csv")
    assert numbers["timing"]["n_intercalation_cells"] == timing["mean_intercalation_interval"].notna().sum()


def test_report_on_a_single_frame(movie_results, tmp_path):
    m = voronoi_movie(40, (90, 100), 1, periodic=True, seed=1)
    np.save(tmp_path / "frame.npy", m[0])
    analyze_to(tmp_path / "frame.npy", tmp_path / "res", periodic=True)
    numbers = report(tmp_path / "res")
    out = tmp_path / "res" / "report"
    pngs = sorted(p.name for p in out.glob("*.png"))
    assert pngs == ["cells.png", "order2.png", "order6.png"]
    assert all(_png_ok(out / n) for n in pngs)
    assert numbers["frames"] == 1 and "proximity" not in numbers
    text = (out / "report.md").read_text()
    assert "single image" in text and "Fig. 3e" not in text


def test_report_command_passes_its_options(monkeypatch, tmp_path, capsys):
    import argparse

    import sys

    report_module = sys.modules["hexatissue.workflows.report"]  # the package exports the function of that name

    seen = {}

    def fake(results, out, **kw):
        seen.update(kw, calibration=results.calibration, out=out)
        return {"written": [str(tmp_path / "report.md")]}

    monkeypatch.setattr(report_module, "report", fake)
    res = analyze_to(voronoi_movie(20, (50, 60), 1, seed=0)[0], tmp_path / "res")
    parser = argparse.ArgumentParser()
    command.add_parser(parser.add_subparsers(dest="command"))
    args = parser.parse_args(["report", str(res), "--out", "OUT", "--dt", "5", "--dl", "30", "--seed", "2",
                              "--n-control", "3", "--frame-interval", "500", "--time-unit", "iterations",
                              "--include-border", "--control", "vertices", "--pixel-size", "0.25"])
    assert args.func(args) == 0
    assert seen == {"out": "OUT", "p": 6, "dl": 30.0, "dt": 5, "n_control": 3, "seed": 2, "include_border": True,
                    "control": "vertices", "calibration": Calibration(0.25, "um", 500.0, "iteration")}
    assert "report written" in capsys.readouterr().out


def test_report_bad_folder(tmp_path):
    with pytest.raises(InputError, match="does not exist or is not a folder"):
        report(tmp_path / "missing")
    with pytest.raises(InputError, match="no metadata.json"):
        report(tmp_path)


@pytest.mark.slow
def test_report_on_the_bundled_epicure_sample(tmp_path):
    res = tmp_path / "epicure"
    analyze_to(SAMPLE, res)
    numbers = report(res, dt=3)
    out = res / "report"
    assert numbers["frames"] == 11
    for name in ("order6_frame0000.png", "order6_frame0010.png", "migration.png", "cells.png"):
        assert _png_ok(out / name)
    # the sample has no T1 event: no empty event, T1-defect or timing panels (issue 29)
    assert numbers["events"] == {}
    assert not any((out / name).exists() for name in ("events.png", "t1_defects.png", "timing.png"))
    assert numbers["migration"]["n_subregion_windows"] > 0
    assert "## T1 events" in (out / "report.md").read_text()


def test_report_on_a_real_microscopy_movie(real_data, tmp_path):
    path = real_subdir(real_data, "itasc_micropattern") / "pos00" / "cell_labels.tif"
    res = tmp_path / "itasc"
    analyze_to(path, res, censor=3, p=(6,))
    numbers = report(res, dt=3)
    events = pd.read_parquet(res / "events.parquet")
    assert len(events) > 0 and numbers["proximity"]["n_events"] > 0
    assert np.isfinite(numbers["proximity"]["ks_pvalue"])
    assert numbers["migration"]["n_subregion_windows"] > 0
    for name in ("t1_defects.png", "migration.png", "timing.png", "events.png"):
        assert _png_ok(res / "report" / name)
    # the junction-level control runs on the same real movie
    numbers = report(res, tmp_path / "vertex_report", dt=3, control="vertices")
    assert numbers["proximity"]["n_control"] > 0 and np.isfinite(numbers["proximity"]["ks_pvalue"])


def test_report_through_the_hexatissue_command(tmp_path):
    """'hexatissue report' is wired in cli.SUBCOMMAND_MODULES."""
    from hexatissue import cli

    m = voronoi_movie(30, (70, 80), 1, periodic=False, seed=2)
    np.save(tmp_path / "frame.npy", m[0])
    analyze_to(tmp_path / "frame.npy", tmp_path / "res", p=(6,))
    assert cli.main(["report", str(tmp_path / "res"), "--out", str(tmp_path / "cli")]) == 0
    assert (tmp_path / "cli" / "report.md").exists() and _png_ok(tmp_path / "cli" / "order6.png")
    assert cli.main(["report", str(tmp_path / "nothing")]) == 2  # InputError -> exit code 2


def test_report_shows_physical_units_from_the_results(tmp_path):
    """A calibrated movie reports micrometres; a different pixel size scales every length."""
    m = voronoi_movie(30, (70, 80), 8, periodic=True, amplitude=0.5, seed=4)
    stack = np.stack([m[t] for t in range(8)])
    numbers = {}
    for size in (0.2, 0.4):
        movie = analyze(stack, box=True, events=EventOptions(censor=2), workers=1, progress=False)
        movie = movie.replace(calibration=Calibration(size, "um", 5.0, "min"))
        numbers[size] = report(movie, tmp_path / f"r{size}", dt=3)
        text = (tmp_path / f"r{size}" / "report.md").read_text()
        assert f"pixel size: {size:g} µm" in text and "frame interval: 5 min" in text
    median = numbers[0.2]["proximity"]["median_dr_events"]
    assert numbers[0.4]["proximity"]["median_dr_events"] == median  # tables stay in px
    lines = [(tmp_path / f"r{s}" / "report.md").read_text() for s in (0.2, 0.4)]
    assert f"({median * 0.2:.3g} µm)" in lines[0] and f"({median * 0.4:.3g} µm)" in lines[1]


def test_report_has_the_deformation_budget_in_physical_time(tmp_path):
    """With the deformation stage, the report tabulates the cumulative budget and draws its curves and map."""
    from hexatissue import DeformationOptions
    from hexatissue.synthetic import t1_movie

    m = t1_movie(periodic=True)
    movie = analyze(m.labels, box=m.box, workers=1, progress=False, deformation=DeformationOptions(enabled=True))
    movie.replace(calibration=Calibration(0.5, "um", 2.0, "min")).write(tmp_path / "res")
    numbers = report(tmp_path / "res", dt=5)
    out = tmp_path / "res" / "report"
    text = (out / "report.md").read_text()
    assert "## Deformation budget" in text and "(70 min)" in text
    assert _png_ok(out / "deformation.png") and _png_ok(out / "deformation_map.png")
    cumulative = {row["contribution"]: row for row in numbers["deformation"]["cumulative"]}
    tissue = movie.deformation[movie.deformation["region"] == "tissue"]
    assert cumulative["intercalations"]["cumulative xx"] == pytest.approx(tissue["t1_intercalation_xx"].sum())
    assert numbers["deformation"]["max_closure"] < 1e-12
    assert "deformation.csv" in {Path(w).name for w in numbers["written"]}


def test_report_has_tracking_quality_and_the_division_table(tmp_path):
    """The scripted movie of tests/test_track.py (a re-division, a one-frame flicker, a clean division): the
    report's tracking-quality section has the per-frame counts of tracking_qc, every division with its reason,
    and the T1 section says how many contacts were held as four-fold vertices."""
    from hexatissue.track import division_rows, tracking_qc
    from tests.test_track import _analysed, _interior_cells, _scripted_divisions

    first = _scripted_divisions([])[0][0]
    a, b, c = _interior_cells(first, 3)
    n0 = int(first.max())
    labels, _ = _scripted_divisions([(3, a, (5.0, 1.0)), (5, n0 + 1, (1.0, 4.0)), (4, b, (-1.0, 5.0)),
                                     (5, b, None), (6, c, (4.0, -3.0))])
    movie, _ = _analysed(labels)
    movie.write(tmp_path / "res")
    numbers = report(tmp_path / "res", dt=2)
    text = (tmp_path / "res" / "report" / "report.md").read_text()
    section = text[text.index("## Tracking quality"):text.index("## T1 events")]
    assert "divisions: 4, of which 1 plausible and 3 suspect" in section
    assert numbers["tracking_qc"] == {"appearances": 0, "disappearances": 1, "divisions": 4,
                                      "divisions_plausible": 1, "divisions_suspect": 3, "interior_appearances": 0,
                                      "extrusions": 1, "extrusions_unconfirmed": 1, "doubtful_frames": []}
    qc = pd.read_csv(tmp_path / "res" / "report" / "tracking_qc.csv")
    pd.testing.assert_frame_equal(qc, tracking_qc(movie.lineage, movie.cells, movie.summary["tracking"].get("links")),
                                  check_dtype=False)
    divisions = division_rows(movie.lineage)
    for r in divisions.itertuples():
        assert f"| {r.mother} | {r.frame} | {r.daughter_a} | {r.daughter_b} |" in section
    assert "`redivision`:" in section and "`short_daughter`:" in section
    held = movie.summary["events"]
    assert (f"{held['n_held_contacts']} contact-frames at {held['n_held_vertices']} vertex-frames"
            in text[text.index("## T1 events"):])


def test_a_movie_without_events_has_no_empty_panels_and_says_so(tmp_path):
    """EpiCure-like: no T1 in a short movie; before, the report showed empty panels and nan statistics."""
    frames = [voronoi_movie(40, (90, 100), 1, seed=1)[0]] * 4  # motionless: no neighbour exchange
    np.save(tmp_path / "still.npy", np.stack(frames))
    analyze_to(tmp_path / "still.npy", tmp_path / "res")
    numbers = report(tmp_path / "res")
    out = tmp_path / "res" / "report"
    names = {p.name for p in out.glob("*.png")}
    assert not {"events.png", "t1_defects.png", "timing.png"} & names and "cells.png" in names
    text = (out / "report.md").read_text()
    assert "nan" not in text.replace("nan px", "")  # no statistic of nothing
    assert "Nothing to compare: there are no T1 events" in text and "Too little to compare" in text
    assert numbers["events"] == {}


WHOLE_TABLES = ("cells", "vertices", "edges", "cell_vertices", "grid", "defects", "flow")


@pytest.mark.slow  # about 30 s on a loaded machine
def test_the_report_of_a_streamed_folder_reads_columns_and_equals_the_in_memory_report(tmp_path, monkeypatch):
    from hexatissue import DeformationOptions, MechanicsOptions, pipeline
    from hexatissue.stored import StoredTable

    monkeypatch.setattr(pipeline, "PART_BYTES", 40_000)  # every table in several parts
    m = voronoi_movie(30, (80, 90), 8, periodic=False, amplitude=0.6, seed=2)
    analyze(np.stack([m[t] for t in range(len(m))]), out=tmp_path / "results", events=EventOptions(censor=3),
            order=OrderOptions(p=(6, 2)), deformation=DeformationOptions(enabled=True),
            mechanics=MechanicsOptions(enabled=True), workers=1, progress=False)
    assert len(StoredTable.open(tmp_path / "results" / "cells", "cells").parts) > 2
    reads, read = [], StoredTable.read

    def recording(self, columns=None, frames=None):
        reads.append((self.name, columns, frames))
        return read(self, columns, frames)

    monkeypatch.setattr(StoredTable, "read", recording)
    kwargs = dict(dl=25.0, dt=4, seed=3)
    streamed = report(tmp_path / "results", tmp_path / "streamed", **kwargs)
    # every whole-movie read names its columns: a table is read whole only one frame at a time (the figures)
    assert reads and all(columns is not None or frames[0] == frames[1] for _, columns, frames in reads)
    assert {name for name, columns, _ in reads if columns is not None} >= {"cells", "grid", "defects", "edges"}
    wide = {name: max(len(c) for n, c, _ in reads if n == name and c is not None) for name in ("cells", "edges")}
    assert wide["cells"] < len(read(StoredTable.open(tmp_path / "results" / "cells", "cells")).columns) // 2
    whole = read_results(tmp_path / "results", lazy=False)
    reads.clear()
    memory = report(whole, tmp_path / "memory", **kwargs)
    assert not reads  # the tables in memory are used as they are
    written = [Path(p).name for p in memory.pop("written")]
    assert [Path(p).name for p in streamed.pop("written")] == written
    # NaN is not equal to itself in a dict; their JSON texts are equal
    assert json.dumps(streamed, sort_keys=True, default=str) == json.dumps(memory, sort_keys=True, default=str)
    assert {"mechanics", "deformation", "flow", "migration", "proximity", "timing"} <= set(memory)
    for name in written:
        a, b = (tmp_path / "streamed" / name).read_bytes(), (tmp_path / "memory" / name).read_bytes()
        if name == "report.md":  # the title names the results folder, or "movie" for a Movie
            a, b = a.split(b"\n", 1)[1], b.split(b"\n", 1)[1]
        assert a == b, name
