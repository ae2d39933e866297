"""Tissue-scale analyses (Fig. 3e-g) against inputs with known answers."""
import numpy as np
import pandas as pd
import pytest
from scipy import stats

from hexatissue.analysis import (cell_displacements, cell_steps, cell_timing, in_time_units, fit_gaussian_mixture,
                                 frames_per_window, migration_populations, migration_table, nearest_defect,
                                 random_cell_distances, random_vertex_distances, t1_defect_distances,
                                 t1_defect_proximity, timing_across_runs, timing_summary, timing_test)
from hexatissue.box import Box
from hexatissue.errors import HexatissueWarning, InputError
from hexatissue.events import cell_event_stats

SIXTH = 1.0 / 6.0


def _defects(rows):
    """rows of (frame, x, y, charge[, p])."""
    df = pd.DataFrame([r if len(r) == 5 else (*r, 6) for r in rows], columns=["frame", "x", "y", "charge", "p"])
    df.insert(1, "defect", df.groupby("frame").cumcount().astype(np.int64))
    return df


def _events(rows):
    """rows of (kind, frame_start, duration, a, b, c, d, x, y)."""
    df = pd.DataFrame(rows, columns=["kind", "frame_start", "duration", "cell_a", "cell_b", "cell_c", "cell_d",
                                     "x", "y"])
    df.insert(0, "event", np.arange(len(df), dtype=np.int64))
    df["duration"] = df["duration"].astype(float)
    df["frame_end"] = df["frame_start"] + df["duration"]
    df["is_border"] = False
    return df


# ----------------------------------------------------------------------------
# T1-defect proximity (Fig. 3e)
# ----------------------------------------------------------------------------

def test_events_on_defects_have_zero_distance():
    defects = _defects([(0, 10.0, 20.0, SIXTH), (0, 50.0, 60.0, -SIXTH), (3, 70.5, 5.25, -SIXTH)])
    events = _events([("cycle", 0, 2, 1, 2, 3, 4, 50.0, 60.0), ("intercalation", 3, np.nan, 5, 6, 7, 8, 70.5, 5.25),
                      ("unresolved", 0, np.nan, 9, 10, 11, 12, 10.0, 20.0)])
    out = t1_defect_distances(events, defects)
    assert out["dr"].tolist() == [0.0, 0.0, 0.0]
    assert out["charge"].tolist() == [-SIXTH, -SIXTH, SIXTH]
    assert out["defect"].tolist() == [1, 0, 0]


def test_nearest_defect_signed_offsets_and_frame_matching():
    defects = _defects([(0, 10.0, 10.0, SIXTH), (0, 40.0, 10.0, -SIXTH), (1, 12.0, 10.0, -SIXTH)])
    out = nearest_defect([0, 0, 1, 2], [[13.0, 14.0], [30.0, 10.0], [13.0, 14.0], [0.0, 0.0]], defects)
    np.testing.assert_allclose(out["dx"][:3], [-3.0, 10.0, -1.0])
    np.testing.assert_allclose(out["dy"][:3], [-4.0, 0.0, -4.0])
    np.testing.assert_allclose(out["dr"][:3], [5.0, 10.0, np.hypot(1, 4)])
    assert out["defect"].tolist() == [0, 1, 0, -1]  # frame 2 has no defect
    assert np.isnan(out["dr"][3]) and np.isnan(out["charge"][3])


def test_nearest_defect_ignores_other_charges_and_orders():
    defects = _defects([(0, 1.0, 1.0, 2 * SIXTH), (0, 2.0, 2.0, 0.5, 2), (0, 30.0, 1.0, SIXTH)])
    out = nearest_defect([0], [[0.0, 0.0]], defects, p=6)
    assert out["defect"][0] == 2 and out["dx"][0] == 30.0


def test_periodic_minimum_image_across_the_box_edge():
    box = Box(100.0, 80.0)
    defects = _defects([(0, 99.0, 52.0, SIXTH), (0, 50.0, 40.0, -SIXTH)])
    out = nearest_defect([0, 0], [[1.0, 50.0], [50.0, 1.0]], defects, box=box)
    np.testing.assert_allclose(out[["dx", "dy"]].to_numpy(), [[-2.0, 2.0], [0.0, 39.0]])
    assert out["defect"].tolist() == [0, 1]
    # across the y edge: (50, 1) to (50, 79) is 2 px
    d2 = _defects([(0, 50.0, 79.0, SIXTH), (0, 50.0, 30.0, SIXTH)])
    out2 = nearest_defect([0], [[50.0, 1.0]], d2, box=box)
    assert (out2["dx"][0], out2["dy"][0], out2["defect"][0]) == (0.0, -2.0, 0)
    # the same points in an open image are far apart
    open_ = nearest_defect([0, 0], [[1.0, 50.0], [50.0, 1.0]], defects)
    np.testing.assert_allclose(open_["dx"], [49.0, 0.0])


def test_nearest_defect_matches_brute_force_periodic():
    rng = np.random.default_rng(3)
    box = Box(73.0, 51.0)
    d_xy, q_xy = rng.uniform(0, 1, (40, 2)) * box.lengths, rng.uniform(0, 1, (200, 2)) * box.lengths
    frames_d, frames_q = rng.integers(0, 3, 40), rng.integers(0, 3, 200)
    defects = _defects([(f, x, y, SIXTH if k % 2 else -SIXTH) for k, (f, (x, y)) in enumerate(zip(frames_d, d_xy))])
    out = nearest_defect(frames_q, q_xy, defects, box=box)
    for i in range(len(q_xy)):
        same = defects[defects["frame"] == frames_q[i]]
        delta = box.min_image(same[["x", "y"]].to_numpy() - q_xy[i])
        k = np.argmin(np.hypot(*delta.T))
        np.testing.assert_allclose([out["dx"][i], out["dy"][i]], delta[k], atol=1e-12)
        assert out["defect"][i] == same["defect"].iloc[k]


def test_random_control_is_seeded_and_draws_interior_cells_of_the_frame():
    cells = pd.DataFrame({"frame": np.repeat([0, 1], 6), "cell": np.tile(np.arange(1, 7), 2),
                          "x": np.arange(12.0), "y": np.zeros(12),
                          "is_border": np.tile([False, False, False, False, True, True], 2)})
    defects = _defects([(0, 0.0, 0.0, SIXTH), (1, 0.0, 0.0, SIXTH)])
    a = random_cell_distances(cells, [0, 0, 1], defects, n_per_frame=2, seed=7)
    b = random_cell_distances(cells, [0, 0, 1], defects, n_per_frame=2, seed=7)
    pd.testing.assert_frame_equal(a, b)
    assert len(a) == 6 and (a["frame"] == 0).sum() == 4
    assert set(a["track"]) <= {1, 2, 3, 4}  # no border cell drawn
    f0 = a[a["frame"] == 0]
    assert f0["track"].is_unique  # without replacement while the frame has enough cells
    np.testing.assert_allclose(a["dr"], np.abs(a["x"]))


def test_vertex_control_draws_interior_vertices_of_degree_three_or_more():
    # vertices 1-3 sit on the defect (distance 0), 4 is an image corner (degree 2), 5 a border vertex
    vertices = pd.DataFrame({"frame": 0, "vertex": [1, 2, 3, 4, 5], "x": [0.0, 0.0, 0.0, 9.0, 9.0],
                             "y": 0.0, "degree": [3, 4, 3, 2, 3], "is_border": [False, False, False, False, True]})
    defects = _defects([(0, 0.0, 0.0, SIXTH)])
    d = random_vertex_distances(vertices, [0, 0], defects, n_per_frame=3, seed=0)
    assert len(d) == 6 and set(d["vertex"]) == {1, 2, 3} and (d["dr"] == 0).all()
    ev = _events([("cycle", 0, 1, 1, 2, 3, 4, 3.0, 4.0)])
    res = t1_defect_proximity(ev, None, defects, control="vertices", vertices=vertices, n_control=2)
    assert res.control_kind == "vertices" and res.events["dr"].iloc[0] == pytest.approx(5.0)
    assert (res.control["dr"] == 0).all() and res.ks_pvalue_closer > 0.5  # the T1 is farther than the control
    with pytest.raises(InputError, match="vertices table"):
        t1_defect_proximity(ev, None, defects, control="vertices")
    with pytest.raises(InputError, match="control"):
        t1_defect_proximity(ev, None, defects, control="junctions")


def test_proximity_detects_events_near_defects():
    rng = np.random.default_rng(0)
    n_frames, box = 20, Box(200.0, 200.0)
    d_rows, e_rows, c_rows = [], [], []
    for t in range(n_frames):
        dxy = rng.uniform(0, 200, (4, 2))
        d_rows += [(t, x, y, SIXTH if k % 2 else -SIXTH) for k, (x, y) in enumerate(dxy)]
        for k in range(3):  # events within 3 px of a defect
            x, y = box.wrap(dxy[k] + rng.uniform(-3, 3, 2))
            e_rows.append(("cycle", t, 2.0, 1, 2, 3, 4, x, y))
        cxy = rng.uniform(0, 200, (50, 2))
        c_rows += [(t, i + 1, x, y) for i, (x, y) in enumerate(cxy)]
    cells = pd.DataFrame(c_rows, columns=["frame", "cell", "x", "y"])
    res = t1_defect_proximity(_events(e_rows), cells, _defects(d_rows), box=box, n_control=5, seed=1)
    s = res.summary()
    assert s["n_events"] == 60 and s["n_control"] == 300
    assert res.events["dr"].max() <= 3 * np.sqrt(2) + 1e-9
    assert s["ks_pvalue"] < 1e-10 and s["ks_pvalue_closer"] < 1e-10
    expect = stats.ks_2samp(res.events["dr"], res.control["dr"])
    assert res.ks_statistic == pytest.approx(expect.statistic) and res.ks_pvalue == pytest.approx(expect.pvalue)


def test_proximity_excludes_border_events_and_empty_input():
    defects = _defects([(0, 0.0, 0.0, SIXTH)])
    ev = _events([("cycle", 0, 1, 1, 2, 3, 4, 1.0, 1.0), ("cycle", 0, 1, 1, 2, 3, 4, 2.0, 2.0)])
    ev.loc[1, "is_border"] = True
    assert len(t1_defect_distances(ev, defects)) == 1
    assert len(t1_defect_distances(ev, defects, include_border=True)) == 2
    cells = pd.DataFrame({"frame": [0], "cell": [1], "x": [5.0], "y": [0.0]})
    res = t1_defect_proximity(ev.iloc[:0], cells, defects)
    assert res.summary()["n_events"] == 0 and np.isnan(res.ks_pvalue)


def test_proximity_bad_input():
    with pytest.raises(InputError, match="defects"):
        nearest_defect([0], [[0.0, 0.0]], pd.DataFrame({"x": [1.0]}))
    with pytest.raises(InputError, match="same length"):
        nearest_defect([0, 1], [[0.0, 0.0]], _defects([(0, 0.0, 0.0, SIXTH)]))
    with pytest.raises(InputError, match="seed"):
        random_cell_distances(pd.DataFrame({"frame": [0], "cell": [1], "x": [0.0], "y": [0.0]}), [0],
                              _defects([(0, 0.0, 0.0, SIXTH)]), seed=1.5)


# ----------------------------------------------------------------------------
# Migration (Fig. 3f)
# ----------------------------------------------------------------------------

def _path_cells(paths, border=None):
    """cells table from {track: (T, 2) positions}."""
    rows = []
    for track, xy in paths.items():
        for t, (x, y) in enumerate(xy):
            rows.append((t, track, track, x, y, False if border is None else border.get((track, t), False)))
    return pd.DataFrame(rows, columns=["frame", "cell", "track", "x", "y", "is_border"])


def test_prescribed_paths_give_exact_displacement_sums():
    # cell 1: steps (1,0), (0,2), (3,4), (-1,-1) ; cell 2 at rest; cell 3 moves 0.5 px in x per frame
    p1 = np.cumsum([[30.0, 60.0], [1, 0], [0, 2], [3, 4], [-1, -1]], axis=0)
    p2 = np.tile([[80.0, 10.0]], (5, 1))
    p3 = np.c_[10.0 + 0.5 * np.arange(5), np.full(5, 90.0)]
    cells = _path_cells({1: p1, 2: p2, 3: p3})
    out = cell_displacements(cells, dl=25.0, dt=2, extent=(100, 100))
    out = out.set_index(["window", "track"])
    assert sorted(out.index.get_level_values("window").unique()) == [0, 1]
    assert out.loc[(0, 1), "displacement"] == pytest.approx((1 + 4) / 625)
    assert out.loc[(1, 1), "displacement"] == pytest.approx((25 + 2) / 625)
    assert out.loc[(0, 1), "msd"] == pytest.approx(1 + 4)
    assert out.loc[(1, 1), "msd"] == pytest.approx(2**2 + 3**2)
    assert out.loc[(0, 2), "displacement"] == 0.0
    assert out.loc[(1, 3), "displacement"] == pytest.approx(0.5 / 625)
    assert out.loc[(1, 3), "msd"] == pytest.approx(1.0)
    # subregions at the window start (extent 100 x 100 -> 4 x 4 bins of 25 px, origin at -0.5)
    assert (out.loc[(0, 1), "col"], out.loc[(0, 1), "row"]) == (1, 2)
    assert (out.loc[(1, 1), "col"], out.loc[(1, 1), "row"]) == (1, 2)
    assert (out.loc[(0, 2), "col"], out.loc[(0, 2), "row"]) == (3, 0)
    assert (out.loc[(0, 1), "frame_start"], out.loc[(0, 1), "frame_end"]) == (0, 2)


def test_periodic_steps_across_the_box_edge():
    box = Box(100.0, 50.0)
    xy = np.array([[98.0, 49.0], [0.5, 1.0], [3.0, 48.5], [99.0, 47.5]])  # steps (2.5, 2), (2.5, -2.5), (-4, -1)
    cells = _path_cells({7: xy})
    steps = cell_steps(cells, box=box)
    np.testing.assert_allclose(steps[["dx", "dy"]].to_numpy(), [[2.5, 2.0], [2.5, -2.5], [-4.0, -1.0]])
    out = cell_displacements(cells, dl=10.0, dt=3, box=box)
    assert out["displacement"].iloc[0] == pytest.approx((2.5**2 + 4 + 2 * 2.5**2 + 16 + 1) / 100)
    assert out["msd"].iloc[0] == pytest.approx(1.0**2 + 1.5**2)
    open_steps = cell_steps(cells)
    assert open_steps["dx"].iloc[0] == pytest.approx(-97.5)


def test_incomplete_and_border_cells_are_left_out():
    p = np.c_[np.arange(5.0) + 10, np.full(5, 10.0)]
    cells = _path_cells({1: p, 2: p + 20, 3: p + 40}, border={(3, 2): True})
    cells = cells[~((cells["track"] == 2) & (cells["frame"] == 3))]  # track 2 missing at frame 3
    out = cell_displacements(cells, dl=25.0, dt=4, extent=(100, 100))
    assert out["track"].tolist() == [1]
    with_border = cell_displacements(cells, dl=25.0, dt=4, extent=(100, 100), include_border=True)
    assert with_border["track"].tolist() == [1, 3]


def test_migration_table_defect_density_and_event_counts():
    box = Box(100.0, 100.0)
    paths = {1: np.c_[np.full(5, 10.0), np.full(5, 10.0) + np.arange(5)], 2: np.tile([[12.0, 20.0]], (5, 1)),
             3: np.tile([[60.0, 60.0]], (5, 1))}
    cells = _path_cells(paths)
    # one defect in subregion (0, 0) in every frame, a second one there in frames 0 and 1 only; a -1/3 ignored
    d = [(t, 5.0, 5.0, SIXTH) for t in range(5)] + [(0, 20.0, 20.0, -SIXTH), (1, 20.0, 20.0, -SIXTH),
                                                    (2, 20.0, 20.0, -2 * SIXTH)]
    events = _events([("cycle", 1, 1, 1, 2, 3, 4, 0, 0), ("intercalation", 2, np.nan, 1, 5, 6, 2, 0, 0),
                      ("intercalation", 3, np.nan, 1, 5, 6, 7, 0, 0)])
    table = migration_table(cells, _defects(d), dl=25.0, dt=2, box=box, events=events).set_index(
        ["window", "row", "col"])
    area = 25.0**2
    assert table.loc[(0, 0, 0), "n_cells"] == 2
    assert table.loc[(0, 0, 0), "defect_density"] == pytest.approx((2 + 2 + 1) / 3 / area)  # frames 0, 1, 2
    assert table.loc[(1, 0, 0), "defect_density"] == pytest.approx(1 / area)  # frames 2, 3, 4
    assert table.loc[(0, 2, 2), "defect_density"] == 0.0
    assert table.loc[(0, 0, 0), "displacement"] == pytest.approx((2 / 625 + 0) / 2)
    assert table.loc[(0, 0, 0), "msd"] == pytest.approx(4 / 2)
    # window 0 = steps ending at frames 1, 2: cell 1 in a cycle and an intercalation, cell 2 in both too
    assert table.loc[(0, 0, 0), "cycles_per_cell"] == 1.0
    assert table.loc[(0, 0, 0), "intercalations_per_cell"] == 1.0
    assert table.loc[(1, 0, 0), "intercalations_per_cell"] == 0.5  # frame 3 event: cell 1 only
    assert table.loc[(0, 0, 0), "x"] == 12.5 and table.loc[(0, 2, 2), "y"] == 62.5


def test_migration_table_with_events_and_no_complete_window():
    # regression (MDCK polygon folder through the report): a movie shorter than one window, with events,
    # raised KeyError 'n_cycles' instead of giving an empty table with the event columns
    cells = _path_cells({1: np.c_[np.arange(3.0) + 10, np.full(3, 10.0)]})
    events = _events([("cycle", 1, 1, 1, 2, 3, 4, 0, 0)])
    with pytest.warns(HexatissueWarning, match="no complete window"):
        table = migration_table(cells, _defects([(0, 5.0, 5.0, SIXTH)]), dl=25.0, dt=5, extent=(100, 100),
                                events=events)
    assert table.empty
    assert {"cycles_per_cell", "intercalations_per_cell", "defect_density", "n_cells"} <= set(table.columns)


def test_frames_per_window():
    assert frames_per_window(25_000, 500) == 50
    assert frames_per_window(25_000, 1000) == 25
    with pytest.raises(InputError, match="multiple"):
        frames_per_window(25_000, 300)


def test_gaussian_mixture_recovers_two_populations():
    rng = np.random.default_rng(5)
    x = np.r_[rng.normal(-2.0, 0.3, 600), rng.normal(0.5, 0.5, 400)]
    m = fit_gaussian_mixture(x, 2, seed=1)
    np.testing.assert_allclose(m.means, [-2.0, 0.5], atol=0.08)
    np.testing.assert_allclose(m.sds, [0.3, 0.5], atol=0.06)
    np.testing.assert_allclose(m.weights, [0.6, 0.4], atol=0.04)
    assert m.converged
    single = fit_gaussian_mixture(x, 1)
    assert single.means[0] == pytest.approx(x.mean()) and single.sds[0] == pytest.approx(x.std())
    assert single.bic - m.bic > 100
    assert -2.0 < m.boundary() < 0.5
    assert m.pdf(np.array([0.0]))[0] > 0


def test_migration_populations_split_slow_and_fast():
    rng = np.random.default_rng(2)
    n_slow, n_fast = 80, 60
    table = pd.DataFrame({
        "displacement": np.r_[10 ** rng.normal(-3, 0.15, n_slow), 10 ** rng.normal(-1, 0.15, n_fast)],
        "msd": np.r_[np.full(n_slow, 1.0), np.full(n_fast, 9.0)],
        "defect_density": np.r_[np.full(n_slow, 1e-4), np.full(n_fast, 5e-4)] + rng.uniform(0, 1e-5, n_slow + n_fast),
        "n_cells": np.full(n_slow + n_fast, 4), "cycles_per_cell": np.r_[np.full(n_slow, 0.5), np.zeros(n_fast)],
        "intercalations_per_cell": np.r_[np.full(n_slow, 0.5), np.full(n_fast, 1.5)]})
    pops = migration_populations(table, seed=0)
    assert (pops.table["population"] == np.r_[["slow"] * n_slow, ["fast"] * n_fast]).all()
    assert 1e-3 < pops.threshold < 1e-1 and pops.delta_bic > 50
    s = pops.summary.set_index("population")
    assert s.loc["slow", "n_subregions"] == n_slow and s.loc["fast", "cycle_fraction"] == 0.0
    assert s.loc["slow", "cycle_fraction"] == pytest.approx(0.5)
    assert s.loc["fast", "intercalations_per_cell"] == pytest.approx(1.5)
    assert pops.spearman_rho > 0.5
    assert pops.verdict == "two populations"


def test_nested_mixture_components_are_one_population():
    """A narrow core inside wide tails: two components fit better, but they never cross -> no split."""
    rng = np.random.default_rng(3)
    logd = np.r_[rng.normal(-1.5, 0.05, 600), rng.normal(-1.5, 0.3, 400)]
    table = pd.DataFrame({"displacement": 10**logd, "defect_density": rng.uniform(1e-4, 2e-4, len(logd))})
    with pytest.warns(HexatissueWarning, match="do not cross"):
        pops = migration_populations(table, seed=0)
    assert pops.delta_bic > 10 and np.isnan(pops.threshold)
    assert pops.verdict == "nested components: one population"
    assert (pops.table["population"] == "").all()


# ----------------------------------------------------------------------------
# Event timing (Fig. 3g)
# ----------------------------------------------------------------------------

def _timing_events():
    # cell 1 intercalates at frames 3, 7, 15 (intervals 4, 8); cell 2 at 3 and 7 (interval 4);
    # cell 1 cycles with durations 2 and 4; cell 9 one cycle of 6; an unresolved T1 is ignored
    return _events([
        ("intercalation", 3, np.nan, 1, 2, 3, 4, 0, 0), ("intercalation", 7, np.nan, 1, 2, 5, 6, 0, 0),
        ("intercalation", 15, np.nan, 1, 8, 10, 11, 0, 0), ("cycle", 20, 2, 1, 12, 13, 14, 0, 0),
        ("cycle", 30, 4, 1, 15, 16, 17, 0, 0), ("cycle", 30, 6, 9, 18, 19, 20, 0, 0),
        ("unresolved", 40, np.nan, 1, 2, 3, 4, 0, 0)])


def test_prescribed_event_times_give_exact_means():
    t = cell_timing(_timing_events()).set_index("track")
    assert t.loc[1, "mean_intercalation_interval"] == 6.0
    assert t.loc[2, "mean_intercalation_interval"] == 4.0
    assert t.loc[1, "mean_cycle_period"] == 3.0 and t.loc[9, "mean_cycle_period"] == 6.0
    assert np.isnan(t.loc[3, "mean_intercalation_interval"])
    scaled = cell_timing(_timing_events(), frame_interval=500).set_index("track")
    assert scaled.loc[1, "mean_intercalation_interval"] == 3000.0
    frames = cell_timing(_timing_events())
    pd.testing.assert_frame_equal(in_time_units(frames, 500), scaled.reset_index())
    pd.testing.assert_frame_equal(frames, cell_timing(_timing_events()))  # the input is not changed
    with pytest.raises(InputError, match="frame_interval"):
        in_time_units(frames, 0)
    pd.testing.assert_frame_equal(cell_timing(_timing_events()), cell_event_stats(_timing_events()))


def test_timing_summary_test_and_runs():
    t = cell_timing(_timing_events())
    s = timing_summary(t).set_index("quantity")
    assert s.loc["intercalation_interval", "n_cells"] == 2 and s.loc["intercalation_interval", "mean"] == 5.0
    cyc = t["mean_cycle_period"].dropna().to_numpy()  # one value per cell in a cycle: 3 (cell 1), 2, 2, 2, 6 x 4
    assert s.loc["cycle_period", "n_cells"] == len(cyc)
    assert s.loc["cycle_period", "median"] == np.median(cyc)
    assert s.loc["cycle_period", "q25"] == np.quantile(cyc, 0.25)
    test = timing_test(t)
    ref = stats.ttest_ind(t["mean_intercalation_interval"].dropna(), cyc, equal_var=False)
    assert test["pvalue"] == pytest.approx(ref.pvalue) and test["t_statistic"] == pytest.approx(ref.statistic)
    slower = t.assign(mean_intercalation_interval=t["mean_intercalation_interval"] * 2)
    runs = timing_across_runs({1e-5: t, 1e-6: slower})
    assert runs["D_r"].tolist() == [1e-6, 1e-6, 1e-5, 1e-5]
    ic = runs[runs["quantity"] == "intercalation_interval"].set_index("D_r")
    assert ic.loc[1e-6, "mean"] == 10.0 and ic.loc[1e-5, "mean"] == 5.0
    with pytest.raises(InputError):
        timing_across_runs({})


# ----------------------------------------------------------------------------
# Figures: full and empty inputs render and are written atomically as PNG
# ----------------------------------------------------------------------------

def _figure_inputs():
    """(proximity result, empty one, migration populations, empty ones, per-cell timing in frames)."""
    rng = np.random.default_rng(1)
    d_rows = [(t, *rng.uniform(0, 100, 2), SIXTH if k else -SIXTH) for t in range(5) for k in range(2)]
    e_rows = [("cycle", t, 2.0, 1, 2, 3, 4, *rng.uniform(0, 100, 2)) for t in range(5)]
    cells = pd.DataFrame({"frame": np.repeat(np.arange(5), 10), "cell": np.tile(np.arange(1, 11), 5),
                          "x": rng.uniform(0, 100, 50), "y": rng.uniform(0, 100, 50)})
    full = t1_defect_proximity(_events(e_rows), cells, _defects(d_rows), box=Box(100.0, 100.0))
    empty = t1_defect_proximity(_events(e_rows).iloc[:0], cells, _defects(d_rows))
    table = pd.DataFrame({"displacement": 10 ** np.r_[rng.normal(-3, 0.1, 30), rng.normal(-1, 0.1, 20)],
                          "msd": np.ones(50), "defect_density": rng.uniform(0, 1e-3, 50), "n_cells": np.ones(50)})
    pops, no_pops = migration_populations(table), migration_populations(table.iloc[:0])
    return full, empty, pops, no_pops, cell_timing(_timing_events())


def test_figures_render_with_data_and_when_empty(tmp_path):
    from hexatissue.analysis import plot_migration, plot_t1_defect_distances, plot_timing, plot_timing_vs_parameter
    from hexatissue.views.events import plot_event_overview

    full, empty, pops, no_pops, timing = _figure_inputs()
    across = timing_across_runs({1e-5: timing, 4e-5: timing})
    figs = {"prox": lambda p: plot_t1_defect_distances(full, path=p),
            "prox_empty": lambda p: plot_t1_defect_distances(empty, path=p),
            "mig": lambda p: plot_migration(pops, path=p), "mig_empty": lambda p: plot_migration(no_pops, path=p),
            "timing": lambda p: plot_timing({1e-5: timing, 4e-5: timing}, path=p),
            "timing_empty": lambda p: plot_timing(timing.iloc[:0], path=p),
            "vs": lambda p: plot_timing_vs_parameter(across, path=p),
            "events": lambda p: plot_event_overview(_timing_events(), path=p),
            "events_empty": lambda p: plot_event_overview(_timing_events().iloc[:0], path=p)}
    for name, draw in figs.items():
        fig = draw(tmp_path / f"{name}.png")
        assert fig.axes and (tmp_path / f"{name}.png").read_bytes()[:4] == b"\x89PNG"
    assert not list(tmp_path.glob(".*.tmp"))


@pytest.mark.parametrize("calibrated", [False, True])
def test_figures_show_distances_and_times_in_the_calibration_units(calibrated):
    from hexatissue.analysis import plot_migration, plot_t1_defect_distances, plot_timing, plot_timing_vs_parameter
    from hexatissue.views.events import plot_event_overview
    from hexatissue.units import Calibration

    cal = Calibration(0.5, "um", 2.0, "min") if calibrated else None
    um, px2um, fi = ("µm", 0.5, 2.0) if calibrated else ("px", 1.0, 1.0)
    minutes = "min" if calibrated else "frames"
    full, _, pops, _, timing = _figure_inputs()

    ax, ax2 = plot_t1_defect_distances(full, calibration=cal).axes
    assert ax.get_xlabel() == f"distance to nearest defect ({um})"
    assert ax2.get_xlabel().endswith(f"({um})") and ax2.get_ylabel() == f"dy ({um})"
    shown = np.concatenate([c.get_offsets() for c in ax2.collections if len(c.get_offsets())])
    np.testing.assert_allclose(np.sort(shown[:, 0]), np.sort(full.events["dx"] * px2um))
    np.testing.assert_allclose(np.sort(shown[:, 1]), np.sort(full.events["dy"] * px2um))

    ax = plot_migration(pops, calibration=cal).axes[0]
    density = pops.table["defect_density"].to_numpy() / px2um**2  # per µm^2: 4x the per-px^2 value
    decade = int(np.floor(np.log10(density.max())))
    assert decade == (-3 if calibrated else -4)
    assert ax.get_xlabel() == f"defect density ($10^{{{decade}}}$ {um}$^{{-2}}$)"
    shown = np.concatenate([c.get_offsets()[:, 0] for c in ax.collections])
    np.testing.assert_allclose(np.sort(shown), np.sort(density) / 10.0**decade)

    ax = plot_timing({1e-5: timing}, calibration=cal).axes[0]
    assert ax.get_ylabel() == f"time ({minutes})"
    ends = np.concatenate([ln.get_ydata() for ln in ax.lines])  # whisker ends: the extreme per-cell means
    values = timing[["mean_intercalation_interval", "mean_cycle_period"]].to_numpy()
    assert ends.min() == np.nanmin(values) * fi and ends.max() == np.nanmax(values) * fi
    ax = plot_timing_vs_parameter(timing_across_runs({1e-5: timing, 4e-5: timing}), calibration=cal).axes[0]
    assert ax.get_ylabel() == f"time ({minutes})"
    means = sorted(ln.get_ydata()[0] for ln in ax.lines if ln.get_marker() == "o")
    assert means == pytest.approx(sorted(np.nanmean(values, axis=0) * fi))

    ax, ax2 = plot_event_overview(_timing_events(), calibration=cal).axes
    assert ax.get_xlabel() == f"time ({minutes})" and ax2.get_xlabel() == f"T1-cycle duration ({minutes})"
    assert ax.lines[0].get_xdata().max() == 40 * fi  # last event starts at frame 40
    bars = [(b.get_x(), b.get_width(), b.get_height()) for b in ax2.patches if b.get_height() > 0]
    assert bars == [((d - 0.5) * fi, fi, 1.0) for d in (2, 4, 6)]  # cycle durations 2, 4, 6 frames


def test_timing_vs_parameter_shows_a_mean_outside_its_quartiles():
    """Per-cell intervals 1, 10, 10, 10, 10: mean 8.2 below q25 = 10; the bar still spans q25..q75."""
    from hexatissue.analysis import plot_timing_vs_parameter, timing_across_runs

    table = pd.DataFrame({"mean_intercalation_interval": [1.0, 10.0, 10.0, 10.0, 10.0],
                          "mean_cycle_period": [np.nan, 4.0, 6.0, np.nan, np.nan]})
    across = timing_across_runs({1e-5: table, 4e-5: table})
    ax = plot_timing_vs_parameter(across).axes[0]
    means = sorted(ln.get_ydata()[0] for ln in ax.lines if ln.get_marker() == "o")
    assert means == pytest.approx([5.0, 8.2])
    bars = sorted(tuple(seg[:, 1]) for c in ax.collections for seg in c.get_segments())
    assert bars == [(4.5, 5.5)] * 2 + [(10.0, 10.0)] * 2
