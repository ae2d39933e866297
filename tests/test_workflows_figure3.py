"""Fig. 3e/3g of a sweep for both event definitions (quartet T1s and the paper's per-cell neighbour-list changes).

The analysis folders are real analyses of a small periodic Voronoi movie whose two event tables are
replaced by hand-written ones, so every per-cell mean is computed by hand below.
"""
import json

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from hexatissue import EventOptions, analyze, read_results
from hexatissue.errors import InputError
from hexatissue.schema import validate
from hexatissue.synthetic import voronoi_movie
from hexatissue.workflows import figure3

from .test_events import _hand_movie

# Quartet T1s (frames): cell 1 intercalates at 2 and 8 (interval 6); cells 2, 3 intercalate once (no
# interval); a cycle of 6 frames for cells 2, 3, 8, 9.  Per cell: interval {1: 6}; period {2, 3, 8, 9: 6}.
QUARTETS = [("intercalation", 2, np.nan, (1, 2, 3, 4)), ("intercalation", 8, np.nan, (1, 5, 6, 7)),
            ("cycle", 4, 10.0, (2, 3, 8, 9))]
# Per-cell events: track 1 intercalates at 2, 5, 11 (intervals 3, 6: mean 4.5), track 2 at 3, 7 (4);
# track 3 has cycles of 2 and 4 frames (mean 3), track 4 one of 5.
PER_CELL = [(1, "intercalation", 2, np.nan), (1, "intercalation", 5, np.nan), (1, "intercalation", 11, np.nan),
            (2, "intercalation", 3, np.nan), (2, "intercalation", 7, np.nan),
            (3, "cycle", 1, 3.0), (3, "cycle", 6, 10.0), (4, "cycle", 2, 7.0)]
HAND = {"quartet": {"intercalation_interval": [6.0], "cycle_period": [6.0] * 4},
        "cell_neighbours": {"intercalation_interval": [4.5, 4.0], "cycle_period": [3.0, 5.0]}}


def _quartet_table(cells):
    rows = []
    for k, (kind, start, end, (a, b, c, d)) in enumerate(QUARTETS):
        at = cells[(cells["frame"] == start) & cells["cell"].isin([a, b, c, d])]
        rows.append({"event": k, "kind": kind, "frame_start": start, "frame_end": end, "duration": end - start,
                     "cell_a": a, "cell_b": b, "cell_c": c, "cell_d": d, "x": at["x"].mean(), "y": at["y"].mean(),
                     "frame_gain": start, "frame_undo": end if kind == "cycle" else np.nan, "is_border": False})
    return validate(pd.DataFrame(rows).astype({"kind": "string"}), "events")


def _per_cell_table(cells):
    rows = []
    for k, (track, kind, start, end) in enumerate(PER_CELL):
        at = cells[(cells["frame"] == start) & (cells["cell"] == track)].iloc[0]
        rows.append({"event": k, "track": track, "kind": kind, "frame_start": start, "frame_end": end,
                     "duration": end - start, "n_lost": 1, "n_gained": 1, "x": at["x"], "y": at["y"],
                     "is_border": False})
    return validate(pd.DataFrame(rows).astype({"kind": "string"}), "neighbour_events")


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("fig3")
    out = {}
    for value, seed in ((1e-5, 1), (4e-5, 2)):
        m = voronoi_movie(30, (90, 100), 14, periodic=True, amplitude=0.5, seed=seed)
        np.save(tmp / f"movie{seed}.npy", np.stack([m[t] for t in range(len(m))]))
        movie = analyze(tmp / f"movie{seed}.npy", box=True, events=EventOptions(censor=2), workers=1, progress=False)
        movie = movie.replace(events=_quartet_table(movie.cells), neighbour_events=_per_cell_table(movie.cells))
        movie.write(tmp / f"run{seed}")
        out[value] = tmp / f"run{seed}"
    return out


@pytest.fixture(scope="module")
def summary(runs, tmp_path_factory):
    return figure3(runs, tmp_path_factory.mktemp("out"), dt=4, dl=30.0, control=("cells", "vertices"))


def test_fig3g_per_cell_means_of_both_definitions_are_the_hand_computed_ones(summary):
    records = pd.DataFrame(summary["fig3g"])
    assert set(records["definition"]) == {"quartet", "cell_neighbours"}
    for definition, quantities in HAND.items():
        for quantity, values in quantities.items():
            rows = records[(records["definition"] == definition) & (records["quantity"] == quantity)]
            assert sorted(rows["D_r"]) == [1e-5, 4e-5]
            assert rows["n_cells"].tolist() == [len(values)] * 2
            assert rows["mean"].to_numpy() == pytest.approx([np.mean(values)] * 2)
        expected_p = stats.ttest_ind(quantities["intercalation_interval"], quantities["cycle_period"],
                                     equal_var=False).pvalue if len(quantities["intercalation_interval"]) > 1 else np.nan
        got_p = records[records["definition"] == definition]["t_pvalue"].to_numpy(float)
        np.testing.assert_allclose(got_p, expected_p)
    # the two runs are identical in timing: flat trends for both definitions
    for definition in HAND:
        assert summary["trends"][definition]["intercalation_interval_loglog_slope"] == pytest.approx(0.0, abs=1e-12)
        assert summary["trends"][definition]["cycle_period_loglog_slope"] == pytest.approx(0.0, abs=1e-12)


def test_fig3g_tables_and_figures_are_written_per_definition(summary):
    out = {str(w).rsplit("/", 1)[-1] for w in summary["written"]}
    assert {"fig3g_box.png", "fig3g_box_cell_neighbours.png", "fig3g_vs_param.png",
            "fig3g_vs_param_cell_neighbours.png", "fig3g_cell_timing.csv", "fig3g_summary.csv"} <= out
    folder = next(w for w in summary["written"] if w.endswith("summary.json")).rsplit("/", 1)[0]
    per_cell = pd.read_csv(f"{folder}/fig3g_cell_timing.csv")
    got = per_cell[(per_cell["definition"] == "cell_neighbours") & (per_cell["D_r"] == 1e-5)].set_index("track")
    assert got.loc[[1, 2, 3, 4], "mean_intercalation_interval"].tolist()[:2] == [4.5, 4.0]
    assert got.loc[[3, 4], "mean_cycle_period"].tolist() == [3.0, 5.0]
    assert json.loads(open(f"{folder}/summary.json").read())["trends"].keys() == {"quartet", "cell_neighbours"}


def test_fig3e_panels_for_both_definitions_and_both_controls(summary, runs):
    assert (summary["fig3e"]["definition"], summary["fig3e"]["control"]) == ("quartet", "cells")
    assert (summary["fig3e_vertices"]["definition"], summary["fig3e_vertices"]["control"]) == ("quartet", "vertices")
    per_cell = summary["fig3e_cell_neighbours"]
    assert (per_cell["definition"], per_cell["control"]) == ("cell_neighbours", "cells")
    folder = next(w for w in summary["written"] if w.endswith("summary.json")).rsplit("/", 1)[0]
    for suffix, n_events in (("", len(QUARTETS)), ("_vertices", len(QUARTETS)), ("_cell_neighbours", len(PER_CELL))):
        ev = pd.read_csv(f"{folder}/fig3e{suffix}_distances.csv")
        ctrl = pd.read_csv(f"{folder}/fig3e{suffix}_control.csv")
        with_defect = 0
        for value, run in runs.items():
            defects = read_results(run).defects
            frames = set(defects[defects["p"] == 6]["frame"])
            starts = [q[1] for q in QUARTETS] if suffix != "_cell_neighbours" else [e[2] for e in PER_CELL]
            with_defect += sum(f in frames for f in starts)
        assert len(ev) == with_defect and len(ctrl) == 5 * len(ev)
        pooled = summary[f"fig3e{suffix}"]["pooled"]
        assert pooled["ks_pvalue"] == pytest.approx(stats.ks_2samp(ev["dr"], ctrl["dr"]).pvalue)
    # the per-cell events sit at their cell's centroid: its distance to the nearest defect, by hand
    ev = pd.read_csv(f"{folder}/fig3e_cell_neighbours_distances.csv")
    movie = read_results(runs[1e-5])
    row = ev[(ev["D_r"] == 1e-5) & (ev["frame"] == 5)].iloc[0]  # track 1's intercalation at frame 5
    at = movie.cells[(movie.cells["frame"] == 5) & (movie.cells["cell"] == 1)].iloc[0]
    d = movie.defects[(movie.defects["frame"] == 5) & (movie.defects["p"] == 6)
                      & np.isclose(np.abs(movie.defects["charge"]), 1 / 6)]
    offsets = movie.box.min_image(d[["x", "y"]].to_numpy(float) - [at["x"], at["y"]])
    assert row["dr"] == pytest.approx(np.hypot(*offsets.T).min())


def test_figure3_needs_both_event_tables_and_valid_controls(runs, tmp_path):
    with pytest.raises(InputError, match="control"):
        figure3(runs, tmp_path, control=("cells", "cells"))
    with pytest.raises(InputError, match="control"):
        figure3(runs, tmp_path, control="random")
    movie = read_results(runs[1e-5])
    movie.replace(neighbour_events=None).write(tmp_path / "old")
    with pytest.raises(InputError, match="neighbour_events"):
        figure3({1e-5: tmp_path / "old"}, tmp_path / "fig")


def test_net_displacement_per_window_from_the_centroids(summary, runs):
    """Every cell in every whole window of 4 frames (0-4, 4-8, 8-12 of 14): |sum of minimum-image steps|."""
    travel = {r["D_r"]: r for r in summary["fig3f"]["net_displacement"]}
    for value, run in runs.items():
        movie = read_results(run)
        xy = movie.cells.sort_values(["cell", "frame"])
        nets = []
        for _, c in xy.groupby("cell"):
            pos = c[["x", "y"]].to_numpy(float)
            steps = movie.box.min_image(np.diff(pos, axis=0))
            nets += [np.hypot(*steps[t0:t0 + 4].sum(axis=0)) for t0 in (0, 4, 8)]
        assert travel[value]["n_cell_windows"] == len(nets) == 3 * movie.cells["cell"].nunique()
        assert travel[value]["mean_px"] == pytest.approx(np.mean(nets))
        assert travel[value]["median_px"] == pytest.approx(np.median(nets))


def test_a_coarser_frame_spacing_hides_a_short_cycle_and_keeps_a_lasting_change():
    """Cells 3, 4 are common neighbours of 1 and 2.  1-2 are apart at frame 3 only (a one-frame cycle of cells 1
    and 2); 3-4 touch from frame 5 on (an intercalation of 3 and 4).  Every 2nd frame (0, 2, 4, ...): the
    cycle falls between frames 2 and 4 and vanishes; the contact appears at coarse frame 3 (= frame 6)."""
    from hexatissue.workflows.figure3 import events_at_spacing

    ring = [(1, 3), (1, 4), (2, 3), (2, 4)]
    edges, cells = _hand_movie(lambda f: ring + ([] if f == 3 else [(1, 2)]) + ([(3, 4)] if f >= 5 else []), 20)
    _, full = events_at_spacing(edges, cells, 1, censor=4)
    per_cell = full["cell_neighbours"].set_index("track")
    assert per_cell.loc[[1, 2], "kind"].tolist() == ["cycle", "cycle"]
    assert per_cell.loc[[1, 2], "duration"].tolist() == [1.0, 1.0]
    assert per_cell.loc[[3, 4], "kind"].tolist() == ["intercalation"] * 2
    assert per_cell.loc[[3, 4], "frame_start"].tolist() == [5, 5]
    kept, coarse = events_at_spacing(edges, cells, 2, censor=4)
    assert sorted(kept["frame"].unique()) == list(range(10))
    per_cell = coarse["cell_neighbours"]
    assert sorted(per_cell["track"]) == [3, 4] and set(per_cell["kind"]) == {"intercalation"}
    assert per_cell["frame_start"].tolist() == [3, 3]
    # censor is kept in time: 4 full frames = 2 coarse frames; a change at coarse frame 8 of 0..9 is unresolved
    late = lambda f: ring + [(1, 2)] + ([(3, 4)] if f >= 16 else [])
    _, coarse = events_at_spacing(*_hand_movie(late, 20), 2, censor=4)
    assert set(coarse["cell_neighbours"]["kind"]) == {"unresolved"}
    with pytest.raises(InputError, match="stride"):
        events_at_spacing(edges, cells, 0)


def test_timing_at_stride_one_is_the_analysis_own(tmp_path):
    """Stride 1 re-detects exactly the tables the analysis wrote (same min_length and censor)."""
    from hexatissue.analysis import cell_timing, timing_across_runs
    from hexatissue.synthetic import t1_movie
    from hexatissue.workflows import timing_vs_frame_spacing

    m = t1_movie(periodic=True, seed=2)
    np.save(tmp_path / "t1.npy", np.asarray(m.labels))
    movie = analyze(tmp_path / "t1.npy", box=True, events=EventOptions(min_length=m.min_length, censor=m.censor),
                    workers=1, progress=False)
    movie.write(tmp_path / "res")
    table = timing_vs_frame_spacing({1e-5: tmp_path / "res"}, strides=(1, 3))
    assert set(table["stride"]) == {1, 3} and set(table["frame_interval"]) == {1.0, 3.0}
    for definition, name in (("quartet", "events"), ("cell_neighbours", "neighbour_events")):
        own = timing_across_runs({1e-5: cell_timing(getattr(movie, name), movie.cells)})
        got = table[(table["stride"] == 1) & (table["definition"] == definition)]
        np.testing.assert_allclose(got["mean"].to_numpy(float), own["mean"].to_numpy(float))
        assert got["n_cells"].tolist() == own["n_cells"].tolist()
        counts = getattr(movie, name)["kind"].value_counts()
        assert got["n_cycles"].iloc[0] == counts.get("cycle", 0) > 0
