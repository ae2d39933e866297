"""The scorer against exact truth: truth vs itself is perfect; each hand-made corruption moves exactly its scores.

Truth: the scripted Voronoi T1 movie of hexatissue.synthetic (120 cells, 36 frames, periodic, 5 true T1
events), analysed once.  A corruption of the labels changes frame K only: the prediction is the truth's
tables with frame K replaced by the analysis of the corrupted frame, and T1 events and lineage re-derived
from them with the pipeline's own functions (what analyze does after the frame jobs).  Every expected value
is computed here from the truth's tables and the label images.
"""
import json

import warnings

import numpy as np
import pandas as pd
import pytest

from hexatissue import OrderOptions, analyze
from hexatissue.benchmark.score import score, score_to_folder
from hexatissue.box import Box
from hexatissue.cli import main
from hexatissue.errors import HexatissueWarning, InputError
from hexatissue.events import detect_t1
from hexatissue.io import write_tiff
from hexatissue.synthetic import t1_movie
from hexatissue.track import lineage_table

K = 20  # the corrupted frame
ORDER = OrderOptions(p=(6,), fields=False)
ALL_BUT_DIVISIONS = {"seg_jaccard", "split_score", "merge_score", "missed_score", "extra_score",
                     "neighbour_pairs_precision", "neighbour_pairs_recall", "vertex_precision", "vertex_recall",
                     "n_sides_accuracy", "link_precision", "link_recall", "t1_precision", "t1_recall",
                     "t1_kind_accuracy", "gamma6_score"}


@pytest.fixture(scope="module")
def truth(tmp_path_factory):
    movie = t1_movie(periodic=True)
    labels = movie.labels
    result = analyze(labels, box=movie.box, order=ORDER, workers=1, progress=False)
    folder = tmp_path_factory.mktemp("truth")
    result.write(folder)
    write_tiff(folder / "labels.tif", labels.astype(np.uint16))
    return folder, result, labels


def _neighbours(result, t):
    e = result.edges[result.edges["frame"] == t]
    out = {}
    for a, b in zip(e["cell_a"], e["cell_b"]):
        if a > 0 and b > 0:
            out.setdefault(int(a), set()).add(int(b))
            out.setdefault(int(b), set()).add(int(a))
    return out


def _far_cells(result, t):
    """Cells of frame t more than two contacts away from every cell of every true T1 quartet."""
    nb = _neighbours(result, t)
    near = set(result.events[["cell_a", "cell_b", "cell_c", "cell_d"]].to_numpy().ravel().tolist())
    for _ in range(2):
        near |= {y for x in near for y in nb[x]}
    return sorted(set(nb) - near), nb


def _far_pair(result, labels, t):
    """Two neighbouring far cells (a, b), a the larger."""
    far, nb = _far_cells(result, t)
    a = far[len(far) // 2]
    b = next(y for y in sorted(nb[a]) if y in far and len(nb[a] & nb[y]) == 2)
    areas = np.bincount(labels[t].ravel())
    return (a, b) if areas[a] > areas[b] else (b, a)


def _spliced(result, labels, frame):
    """The truth's tables with frame K replaced by the analysis of ``frame``; events and lineage re-derived."""
    one = analyze(frame, box=result.box, order=ORDER, workers=1, progress=False)
    tables = {}
    for name in ("cells", "vertices", "edges", "cell_vertices"):
        old, new = getattr(result, name), getattr(one, name).assign(frame=np.int64(K))
        if name == "cells":
            new = new.assign(track=new["cell"])
        parts = [old[old["frame"] < K], new[old.columns], old[old["frame"] > K]]
        tables[name] = pd.concat(parts, ignore_index=True)
    cells = tables["cells"]
    opts = result.options["events"]
    tables["events"] = detect_t1(tables["edges"], cells, min_length=opts.min_length, censor=opts.censor,
                                 box=result.box)
    tables["lineage"] = lineage_table(cells[["frame", "track"]], {}, cells["is_border"].to_numpy(bool))
    stack = labels.copy()
    stack[K] = frame
    return result.replace(**tables), stack


def _counts(result):
    """Totals of the truth: cells, distinct contacts, vertices, links, T1 events."""
    pairs = result.edges[(result.edges["cell_a"] > 0) & (result.edges["cell_b"] > 0)]
    n_pairs = len(pairs[["frame", "cell_a", "cell_b"]].drop_duplicates())
    n_links = len(result.cells) - result.cells["track"].nunique()  # every track spans the movie without gaps
    return len(result.cells), n_pairs, len(result.vertices), n_links, len(result.events)


def _check(summary, expected):
    """Every expected score exactly (to rounding); every other score of ALL_BUT_DIVISIONS is 1."""
    assert set(summary) == ALL_BUT_DIVISIONS  # no division in the truth: those scores are left out, not 1
    for name in ALL_BUT_DIVISIONS:
        assert summary[name] == pytest.approx(expected.get(name, 1.0), abs=1e-12), name


def test_truth_against_itself_is_perfect(truth, tmp_path):
    folder, result, _ = truth
    scores = score(folder, folder, show_progress=False)
    assert scores.summary == {name: 1.0 for name in scores.summary}
    assert set(scores.summary) == ALL_BUT_DIVISIONS
    n_cells, n_pairs, n_vertices, n_links, n_t1 = _counts(result)
    c = scores.counts
    assert (c["n_truth_cells"], c["n_truth_pairs"], c["n_truth_vertices"], c["n_truth_links"], c["n_truth_t1"]) == \
        (n_cells, n_pairs, n_vertices, n_links, n_t1) == (4320, n_pairs, n_vertices, 4200, 5)
    assert "division_precision" in scores.notes[-1]
    assert scores.notes[:2] == [f"prediction labels: {folder / 'labels.tif'}", f"truth labels: {folder / 'labels.tif'}"]
    written = score_to_folder(scores, tmp_path / "out")
    assert json.loads((tmp_path / "out" / "scores.json").read_text()) == scores.summary
    assert {p.name for p in written} >= {"scores.json", "counts.json", "summary.txt", "scores.png", "cells.parquet",
                                         "t1.parquet", "links.parquet", "vertices.parquet", "neighbour_pairs.parquet"}


def test_two_cells_merged(truth):
    folder, result, labels = truth
    a, b = _far_pair(result, labels, K)
    frame = labels[K].copy()
    frame[frame == b] = a
    pred, stack = _spliced(result, labels, frame)
    scores = score(pred, folder, pred_labels=stack, show_progress=False)
    n_cells, n_pairs, n_vertices, n_links, _ = _counts(result)
    nb = _neighbours(result, K)
    union = (nb[a] | nb[b]) - {a, b}
    lost = 1 + len(nb[b] - {a})  # truth pairs a-b and b-x: b has no match in frame K
    extra = len(union - nb[a])  # predicted a-x where only b touched x
    common = nb[a] & nb[b]  # the two cells at the ends of the a-b junction lose a side
    ns = result.cells.set_index(["frame", "cell"])["n_sides"]
    wrong = len(common) + int(ns[(K, a)] != len(union))
    assert scores.counts["n_merge"] == 1 and scores.counts["n_split"] == 0
    _check(scores.summary, {
        "seg_jaccard": 1 - 1 / n_cells,  # J_a + J_b = (|a| + |b|) / |a u b| = 1: one cell's worth lost
        "merge_score": 1 - 1 / (n_cells - 1),
        "neighbour_pairs_precision": (n_pairs - lost) / (n_pairs - lost + extra),
        "neighbour_pairs_recall": (n_pairs - lost) / n_pairs,
        "vertex_recall": (n_vertices - 2) / n_vertices,  # the a-b junction's two ends are gone
        "n_sides_accuracy": (n_cells - 1 - wrong) / (n_cells - 1),
        "link_recall": (n_links - 2) / n_links,  # b's links into and out of frame K
        "gamma6_score": scores.summary["gamma6_score"]})
    assert scores.summary["gamma6_score"] < 1
    err = scores.tables["cells"].query("gamma6_error > 1e-9")
    assert set(err["frame"]) == {K} and a in set(err["cell"]) and set(err["cell"]) <= union | {a}


def test_one_cell_missed(truth):
    folder, result, labels = truth
    far, nb = _far_cells(result, K)
    x = far[0]
    frame = labels[K].copy()
    frame[frame == x] = 0
    pred, stack = _spliced(result, labels, frame)
    scores = score(pred, folder, pred_labels=stack, show_progress=False)
    n_cells, n_pairs, n_vertices, n_links, _ = _counts(result)
    assert scores.counts["n_missed"] == 1
    _check(scores.summary, {"seg_jaccard": 1 - 1 / n_cells, "missed_score": 1 - 1 / n_cells,
                            "neighbour_pairs_recall": (n_pairs - len(nb[x])) / n_pairs,
                            "link_recall": (n_links - 2) / n_links})


def test_one_cell_split(truth):
    folder, result, labels = truth
    far, nb = _far_cells(result, K)
    x = far[1]
    frame = labels[K].copy()
    rows, cols = np.nonzero(frame == x)
    cells = result.cells.set_index(["frame", "cell"])
    cx, cy = cells.loc[(K, x), "x"], cells.loc[(K, x), "y"]
    # cut off the part beyond half-way to the junction with neighbour y (a band along that junction)
    y = min(nb[x])
    d = np.array([cells.loc[(K, y), "x"] - cx, cells.loc[(K, y), "y"] - cy])
    d = Box(360, 260).min_image(d)
    along = ((cols - cx) * d[0] + (rows - cy) * d[1]) / np.hypot(*d)
    z = int(labels.max()) + 1
    cut = along > 0.25 * np.hypot(*d)
    frame[rows[cut], cols[cut]] = z
    pred, stack = _spliced(result, labels, frame)
    scores = score(pred, folder, pred_labels=stack, show_progress=False)
    n_cells, n_pairs, n_vertices, n_links, _ = _counts(result)
    pn = _neighbours(pred, K)
    missed = len(nb[x] - pn[x])  # contacts of x now made only by the split-off part z
    wrong = len((pn[x] & pn[z]) - {x, z})  # cells touching both parts gain a side (the new vertex)
    kept = (~cut).sum() / len(cut)
    assert 0.6 < kept < 0.9 and scores.counts["n_split"] == 1 and scores.counts["n_extra"] == 0
    _check(scores.summary, {
        "seg_jaccard": 1 - (1 - kept) / n_cells, "split_score": 1 - 1 / n_cells,
        "neighbour_pairs_precision": (n_pairs - missed) / (n_pairs - missed + len(pn[z])),
        "neighbour_pairs_recall": (n_pairs - missed) / n_pairs,
        "vertex_precision": n_vertices / (n_vertices + 2),  # the two ends of the cut
        "n_sides_accuracy": 1 - wrong / n_cells,
        "gamma6_score": scores.summary["gamma6_score"]})


def test_junction_flipped(truth):
    """A T1 drawn into frame K: the a-b junction is replaced by a c-d junction across a disc."""
    folder, result, labels = truth
    a, b = _far_pair(result, labels, K)
    v = result.vertices[result.vertices["frame"] == K].set_index("vertex")
    edges = result.edges
    e = edges[(edges["frame"] == K) & (edges["cell_a"] == min(a, b)) & (edges["cell_b"] == max(a, b))].iloc[0]
    v1, v2 = v.loc[e["vertex_a"], ["x", "y"]].to_numpy(float), v.loc[e["vertex_b"], ["x", "y"]].to_numpy(float)
    nb = _neighbours(result, K)
    cv = result.cell_vertices[result.cell_vertices["frame"] == K]
    c = next(x for x in nb[a] & nb[b] if e["vertex_a"] in set(cv[cv["cell"] == x]["vertex"]))
    d = next(x for x in nb[a] & nb[b] if x != c)
    mid, length = 0.5 * (v1 + v2), np.hypot(*(v2 - v1))
    r, col = np.mgrid[:labels.shape[1], :labels.shape[2]]
    disc = np.hypot(col - mid[0], r - mid[1]) < length / 2 + 2
    frame = labels[K].copy()
    toward_v1 = (col - mid[0]) * (v2 - v1)[0] + (r - mid[1]) * (v2 - v1)[1] < 0
    frame[disc & toward_v1], frame[disc & ~toward_v1] = c, d
    pred, stack = _spliced(result, labels, frame)
    scores = score(pred, folder, pred_labels=stack, show_progress=False)
    n_cells, n_pairs, n_vertices, n_links, n_t1 = _counts(result)
    old = labels[K]
    jac = [((old == q) & (frame == q)).sum() / ((old == q) | (frame == q)).sum() for q in (a, b, c, d)]
    assert set(_neighbours(pred, K)[c]) == nb[c] | {d}
    _check(scores.summary, {
        "seg_jaccard": 1 - (4 - sum(jac)) / n_cells,
        "neighbour_pairs_precision": (n_pairs - 1) / n_pairs, "neighbour_pairs_recall": (n_pairs - 1) / n_pairs,
        "vertex_precision": (n_vertices - 2) / n_vertices, "vertex_recall": (n_vertices - 2) / n_vertices,
        "n_sides_accuracy": (n_cells - 4) / n_cells,  # a, b lose a side, c, d gain one
        "t1_precision": n_t1 / (n_t1 + 1),  # the flip is detected as a one-frame T1 cycle
        "gamma6_score": scores.summary["gamma6_score"]})
    extra = scores.tables["t1"].query("status == 'extra'").iloc[0]
    assert (extra["pred_kind"], extra["pred_frame_start"]) == ("cycle", K)
    assert {extra["cell_a"], extra["cell_b"]} == {a, b} and {extra["cell_c"], extra["cell_d"]} == {c, d}


def test_two_tracks_swapped(truth):
    folder, result, labels = truth
    a, b = _far_pair(result, labels, K)
    cells = result.cells.copy()
    later = cells["frame"] >= K
    cells.loc[later & (cells["cell"] == a), "track"] = b
    cells.loc[later & (cells["cell"] == b), "track"] = a
    scores = score(result.replace(cells=cells), folder, pred_labels=labels, show_progress=False)
    n_links = _counts(result)[3]
    # the links of tracks a and b from frame K-1 to K join the wrong cells; every other link is right
    _check(scores.summary, {"link_precision": (n_links - 2) / n_links, "link_recall": (n_links - 2) / n_links})
    bad = scores.tables["links"].query("status != 'matched'")
    assert len(bad) == 4 and set(bad["frame"]) == {K - 1}


def test_one_t1_removed(truth):
    folder, result, labels = truth
    n_t1 = len(result.events)
    removed = result.events.iloc[2]
    pred = result.replace(events=result.events.drop(index=2).reset_index(drop=True))
    scores = score(pred, folder, pred_labels=labels, show_progress=False)
    _check(scores.summary, {"t1_recall": (n_t1 - 1) / n_t1})
    missed = scores.tables["t1"].query("status == 'missed'")
    assert missed["event"].tolist() == [removed["event"]]


def test_cli_finds_labels_from_metadata_and_scores(truth, tmp_path, capsys):
    folder, result, labels = truth
    short = labels[:3].astype(np.uint16)
    write_tiff(tmp_path / "labels.tif", short)
    pred_labels = tmp_path / "pred.tif"
    write_tiff(pred_labels, np.where(short == 7, 0, short))  # one cell missed in every frame
    assert main(["analyze", str(tmp_path / "labels.tif"), "--out", str(tmp_path / "truth"), "--periodic",
                 "--no-fields", "--p", "6", "--workers", "1"]) == 0
    assert main(["analyze", str(pred_labels), "--out", str(tmp_path / "pred"), "--periodic", "--no-fields",
                 "--p", "6", "--workers", "1"]) == 0
    assert main(["benchmark", "score", str(tmp_path / "pred"), str(tmp_path / "truth"), "--out",
                 str(tmp_path / "scores")]) == 0
    out = capsys.readouterr().out
    summary = json.loads((tmp_path / "scores" / "scores.json").read_text())
    assert summary["missed_score"] == pytest.approx(1 - 3 / 360) and "missed_score" in out  # 120 cells x 3 frames
    assert (tmp_path / "scores" / "summary.txt").read_text().startswith("score")


def test_without_labels_only_vertex_scores_and_a_warning(truth):
    _, result, _ = truth
    bare = result.replace(source={})
    with pytest.warns(HexatissueWarning, match="no label images"):
        scores = score(bare, bare, show_progress=False)
    assert set(scores.summary) == {"vertex_precision", "vertex_recall"}


def test_periodic_truth_against_an_open_analysis_warns_and_scores_lower(truth):
    # a user who forgets --periodic for the prediction: the scores drop at the box edge, and the
    # scorer says why instead of leaving a silently low vertex precision
    folder, result, labels = truth
    open_pred = analyze(labels, order=ORDER, workers=1, progress=False)
    with pytest.warns(HexatissueWarning, match="analyse the prediction with .*--periodic"):
        scores = score(open_pred, folder, pred_labels=labels, show_progress=False)
    assert any("open image" in note for note in scores.notes)
    assert scores.summary["vertex_precision"] < 1.0
    with warnings.catch_warnings():
        warnings.simplefilter("error", HexatissueWarning)  # same boxes: no such warning
        same = score(result, folder, pred_labels=labels, show_progress=False)
    assert same.summary["vertex_precision"] == 1.0


def test_a_mask_the_results_do_not_hold_is_said_not_dropped_silently(truth):
    folder, result, labels = truth
    masked = result.replace(source={**result.source, "mask": {"kind": "array", "path": None}})
    with pytest.warns(HexatissueWarning, match="mask given as an array"):
        score(masked, folder, pred_labels=labels, show_progress=False)


def test_labels_recorded_in_the_metadata_are_found_or_the_side_has_none(truth, tmp_path):
    folder, result, labels = truth
    write_tiff(tmp_path / "labels.tif", labels.astype(np.uint16))
    recorded = result.replace(source={"kind": "tiff", "path": str(tmp_path / "labels.tif"), "key": None,
                                      "channel": None, "level": None})
    scores = score(recorded, folder, show_progress=False)
    assert f"prediction labels: {tmp_path / 'labels.tif'}" in scores.notes
    assert scores.summary["seg_jaccard"] == 1.0
    for source in ({**recorded.source, "path": str(tmp_path / "moved.tif")}, {"kind": "array", "path": None}):
        with pytest.warns(HexatissueWarning, match="no label images for the prediction"):
            scores = score(result.replace(source=source), folder, show_progress=False)
        assert "seg_jaccard" not in scores.summary and "vertex_precision" in scores.summary


def test_t1_dated_by_its_held_interval(truth):
    """A T1 reported as a four-fold vertex held from 4 frames early up to the truth's frame is on time for
    t1_timing='held', late for 'start'; one whose interval ends 3 frames early needs a tolerance of 3."""
    folder, result, labels = truth
    ev = result.events
    k = int(np.flatnonzero((ev["frame_start"] >= 5).to_numpy())[0])
    held = ev.copy()
    t = int(ev.loc[k, "frame_start"])
    held.loc[k, ["frame_start", "frame_gain"]] = [t - 4, t]  # a-b lost at t - 4, c-d gained at t
    pred = result.replace(events=held)
    n = len(ev)
    start = score(pred, folder, pred_labels=labels, frame_tolerance=2, show_progress=False)
    _check(start.summary, {"t1_recall": (n - 1) / n, "t1_precision": (n - 1) / n})
    on_time = score(pred, folder, pred_labels=labels, frame_tolerance=0, t1_timing="held", show_progress=False)
    _check(on_time.summary, {"t1_recall": 1.0, "t1_precision": 1.0})
    early = ev.copy()
    early.loc[k, ["frame_start", "frame_gain"]] = [t - 5, t - 3]
    pred = result.replace(events=early)
    for tolerance, recall in ((2, (n - 1) / n), (3, 1.0)):
        s = score(pred, folder, pred_labels=labels, frame_tolerance=tolerance, t1_timing="held", show_progress=False)
        _check(s.summary, {"t1_recall": recall, "t1_precision": recall})
    with pytest.raises(InputError, match="t1_timing"):
        score(pred, folder, pred_labels=labels, t1_timing="gain")


def test_bad_input(truth):
    folder, result, labels = truth
    with pytest.raises(InputError, match="frame_tolerance"):
        score(folder, folder, frame_tolerance=-1)
    with pytest.raises(InputError, match="vertex_radius"):
        score(folder, folder, vertex_radius=0)
    with pytest.raises(InputError, match="same frames"):
        score(result.replace(n_frames=3), folder, pred_labels=labels)
    with pytest.raises(InputError, match="prediction labels"):
        score(folder, folder, pred_labels=labels[:5])
    assert main(["benchmark", "score", str(folder / "nothing"), str(folder), "--out", str(folder / "s")]) == 2


def _dividing(split_from, n_frames=5):
    """A still Voronoi tissue whose cell 13 divides into 40 and 41 (left / right halves) from ``split_from`` on."""
    from hexatissue.synthetic import jittered_seeds, voronoi_labels

    base = voronoi_labels(jittered_seeds((120, 120), 24, seed=2), (120, 120))
    out = np.repeat(base[None], n_frames, axis=0)
    r, c = np.nonzero(base == 13)
    right = c > c.mean()
    out[split_from:, r[right], c[right]] = 40
    out[split_from:, r[~right], c[~right]] = 41
    return out


def test_divisions_found_late_within_the_tolerance_or_missed():
    truth_labels = _dividing(2)
    truth = analyze(truth_labels, order=ORDER, workers=1, progress=False)
    assert truth.lineage["parent"].tolist().count(13) == 2
    same = score(truth, truth, pred_labels=truth_labels, truth_labels=truth_labels, show_progress=False)
    assert same.summary["division_precision"] == same.summary["division_recall"] == 1.0
    late_labels = _dividing(3)
    late = analyze(late_labels, order=ORDER, workers=1, progress=False)
    for tolerance, expected in ((0, 0.0), (1, 1.0)):
        s = score(late, truth, pred_labels=late_labels, truth_labels=truth_labels, frame_tolerance=tolerance,
                  show_progress=False)
        assert s.summary["division_precision"] == s.summary["division_recall"] == expected
    # links: 24 other tracks x 4; truth 13 (frames 0-1) 1 and daughters (2-4) 2 each = 101; prediction 13
    # (0-2) 2 and daughters (3-4) 1 each = 100.  In frame 2 the undivided mother covers each true daughter
    # with IoU 0.5 (not > 0.5): unmatched, so 13's link 1->2 and the daughters' links 2->3 are not matched.
    assert s.counts["n_truth_links"] == 101 and s.counts["n_pred_links"] == 100
    assert s.summary["link_precision"] == pytest.approx(99 / 100)
    assert s.summary["link_recall"] == pytest.approx(99 / 101)
    never = score(_dividing(9), truth, truth_labels=truth_labels, show_progress=False)  # analysed by score
    assert never.summary["division_recall"] == 0.0 and "division_precision" not in never.summary


@pytest.mark.slow
def test_baseline_analyze_score_loop_on_the_t1_movie(truth):
    """Blurred noisy membranes of the whole T1 movie -> baseline -> analyze -> score (about a minute)."""
    from scipy import ndimage

    from hexatissue.benchmark.baseline import segment_movie
    from hexatissue.synthetic import draw_membranes

    folder, result, labels = truth
    rng = np.random.default_rng(0)
    raw = [0.1 + ndimage.gaussian_filter((draw_membranes(f, 2, periodic=True) == 0).astype(float), 1.0, mode="wrap")
           + rng.normal(0, 0.05, f.shape) for f in labels]
    seg = segment_movie(raw, periodic=True, show_progress=False)
    pred = analyze(seg, box=result.box, order=ORDER, workers=1, progress=False)
    s = score(pred, folder, pred_labels=seg, show_progress=False).summary
    assert s["neighbour_pairs_recall"] >= 0.98 and s["t1_recall"] * s["t1_kind_accuracy"] >= 0.9


def test_overlaps_are_those_of_the_pixel_pairs():
    """The scorer's overlaps (counted by the tracker's kernels) against a count of the pixel pairs' codes."""
    import importlib

    from hexatissue.synthetic import jittered_seeds, voronoi_labels

    overlaps = importlib.import_module("hexatissue.benchmark.score")._overlaps
    shape = (70, 90)
    truth = voronoi_labels(jittered_seeds(shape, 25, seed=4), shape)
    truth[:, :4] = 0
    for pred in (voronoi_labels(jittered_seeds(shape, 30, seed=5), shape) * 3,
                 np.where(truth % 4 == 0, 0, truth),  # cells missing from the prediction
                 voronoi_labels(jittered_seeds(shape, 30, seed=5), shape).astype(np.int64) * 2**33):  # sparse ids
        ov, t_area, p_area = overlaps(7, truth, pred)
        tl, pl = truth.ravel().astype(np.int64), pred.ravel().astype(np.int64)
        pairs = pd.DataFrame({"truth": tl, "pred": pl})
        n = pairs[(pairs["truth"] > 0) & (pairs["pred"] > 0)].value_counts().sort_index()
        expected = pd.DataFrame({"frame": np.int64(7), "truth": n.index.get_level_values(0).to_numpy(np.int64),
                                 "pred": n.index.get_level_values(1).to_numpy(np.int64),
                                 "n": n.to_numpy(np.int64)})
        pd.testing.assert_frame_equal(ov, expected, check_exact=True)
        for area, lab in ((t_area, tl), (p_area, pl)):
            ids, counts = np.unique(lab[lab > 0], return_counts=True)
            pd.testing.assert_frame_equal(area, pd.DataFrame({"frame": np.int64(7), "cell": ids,
                                                              "area": counts.astype(np.int64)}), check_exact=True)
    with pytest.raises(InputError, match="expected the same image size"):
        overlaps(0, truth, truth[:-1])
