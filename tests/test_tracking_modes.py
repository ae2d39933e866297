"""Tracking modes (auto / always / never), id-trusting tracks with divisions, and the censoring rule."""
import warnings

import numpy as np
import pandas as pd
import pytest

from hexatissue import EventOptions, TrackOptions, analyze
from hexatissue.errors import HexatissueWarning, InputError
from hexatissue.events import default_censor
from hexatissue.synthetic import jittered_seeds, relabel_movie, t1_movie, voronoi_labels, voronoi_movie
from hexatissue.track import ID_CONSISTENCY, IdTracker, MovieTracker
from tests.conftest import ROOT, real_subdir

SHAPE = (90, 130)


def _movie(n_frames=6, periodic=False, seed=3):
    mov = voronoi_movie(40, SHAPE, n_frames, periodic=periodic, amplitude=0.3, seed=seed)
    return np.stack([mov[t] for t in range(n_frames)]).astype(np.int64)


def _run(stack, mode="auto", **events):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HexatissueWarning)
        return analyze(stack, track=TrackOptions(mode=mode), events=EventOptions(**events), workers=1,
                       progress=False)


def _division_movie():
    """Frames 0-1: N Voronoi cells; frames 2-3: cell k+1 replaced by two daughters N+1, N+2 (ids kept)."""
    seeds = jittered_seeds(SHAPE, 20, seed=4)
    k, n = 7, len(seeds)
    split = np.vstack([np.delete(seeds, k, axis=0), seeds[k] + [-4.0, 0.0], seeds[k] + [4.0, 0.0]])
    lut = np.r_[0, np.delete(np.arange(1, n + 1), k), n + 1, n + 2]  # voronoi ids -> consistent ids
    before, after = voronoi_labels(seeds, SHAPE), lut[voronoi_labels(split, SHAPE)]
    return np.stack([before, before, after, after]).astype(np.int64), k + 1, n + 1, n + 2


def test_consistent_ids_are_kept_across_a_gap():
    stack = _movie()
    gone = int(stack[0][45, 65])  # an interior cell
    stack[2:4][stack[2:4] == gone] = 0  # missing for two frames
    ids = IdTracker()
    for t, frame in enumerate(stack):
        ids.add(frame, t)
    n_cells = [len(np.setdiff1d(np.unique(f), [0])) for f in stack]  # 40, 40, 39, 39, 40, 40
    # every cell of frames 0..4 overlaps itself in the next frame, except `gone` at frame 1 (next: absent)
    assert ids.n_same == ids.n_linked == sum(n_cells[:-1]) - 1 and ids.consistency == 1.0
    assert ids.parents == {}
    mv = _run(stack)
    assert (mv.cells["track"] == mv.cells["cell"]).all()
    lin = mv.lineage.set_index("track")
    assert lin.loc[gone, "frame_start"] == 0 and lin.loc[gone, "frame_end"] == 5 and lin.loc[gone, "n_frames"] == 4
    tracking = mv.summary["tracking"]
    assert tracking["resolved"] == "never" and tracking["mode"] == "auto"
    assert tracking["rows_track_not_cell"] == 0 and tracking["n_tracks"] == tracking["n_ids"] == 40
    assert mv.options["track"] == TrackOptions(mode="never")


def test_divisions_are_read_from_ids():
    stack, mother, da, db = _division_movie()
    ids = IdTracker()
    for t, frame in enumerate(stack):
        ids.add(frame, t)
    assert ids.parents == {da: mother, db: mother}
    for mode in ("auto", "never"):
        mv = _run(stack, mode)
        assert (mv.cells["track"] == mv.cells["cell"]).all()
        lin = mv.lineage.set_index("track")
        assert lin.loc[mother, "end"] == "division" and lin.loc[mother, "frame_end"] == 1
        assert lin.loc[da, "parent"] == lin.loc[db, "parent"] == mother
        assert (lin.loc[[da, db], "begin"] == "division").all() and (lin.loc[[da, db], "frame_start"] == 2).all()
        assert mv.summary["tracking"]["n_divisions"] == 1 and mv.summary["tracking"]["resolved"] == "never"


def test_a_mother_id_that_comes_back_did_not_divide():
    stack, mother, da, db = _division_movie()
    ids = IdTracker()
    for t, frame in enumerate([stack[0], stack[1], stack[2], stack[0]]):  # the "daughters" merge back
        ids.add(frame, t)
    assert ids.parents == {}


def test_relabelled_movie_is_retracked_by_overlap():
    stack = _movie(n_frames=5, periodic=True)
    relabelled, maps = relabel_movie(stack, seed=2)
    mv = _run(relabelled)
    tracking = mv.summary["tracking"]
    assert tracking["resolved"] == "always" and tracking["id_consistency"] < 0.1 < ID_CONSISTENCY
    truth = [maps[f][c] for f, c in zip(mv.cells["frame"], mv.cells["cell"])]
    pairs = set(zip(mv.cells["track"], truth))
    assert len(pairs) == mv.cells["track"].nunique() == 40  # one track per original cell
    first = mv.cells[mv.cells["frame"] == 0]
    assert tracking["rows_track_not_cell"] == int((mv.cells["track"] != mv.cells["cell"]).sum()) > 0
    assert (first["track"] == first["cell"]).all()
    # "never" keeps the (inconsistent) ids, "always" overlap-tracks even consistent ones
    assert (_run(relabelled, "never").cells.eval("track == cell")).all()
    always = _run(stack, "always")
    assert always.summary["tracking"]["resolved"] == "always" and always.summary["tracking"]["id_consistency"] == 1.0
    assert (always.cells["track"] == always.cells["cell"]).all()


def test_track_mode_is_validated():
    for bad in ("sometimes", True, None):
        with pytest.raises(InputError, match="TrackOptions.mode"):
            TrackOptions(mode=bad)
    with pytest.raises(InputError, match="mode"):
        MovieTracker(mode="maybe")
    assert TrackOptions.from_dict(TrackOptions(mode="always").to_dict()) == TrackOptions(mode="always")


def test_default_censor_rule():
    assert [default_censor(n) for n in (0, 1, 4, 5, 10, 11, 49, 50, 301)] == [1, 1, 1, 1, 2, 2, 9, 10, 10]
    for bad in (-1, 2.5, True):
        with pytest.raises(InputError, match="n_frames"):
            default_censor(bad)
    with pytest.raises(InputError, match="EventOptions.censor"):
        EventOptions(censor=1.5)


def test_censor_comes_from_the_movie_and_is_recorded():
    movie = t1_movie(periodic=False, censor=default_censor(36), seed=2)  # truth classified with censor 7
    mv = _run(movie.labels, min_length=movie.min_length)
    assert mv.options["events"].censor == 7 and mv.summary["events"]["censor"] == 7
    assert mv.summary["events"]["censor_rule"] == "min(10, max(1, n_frames // 5))"
    key = ["kind", "frame_start", "cell_a", "cell_b", "cell_c", "cell_d"]
    pd.testing.assert_frame_equal(mv.events[key].astype({"kind": object}), movie.events[key].astype({"kind": object}))
    counts = movie.events["kind"].value_counts()
    assert mv.summary["events"]["n_unresolved"] == counts["unresolved"] == 1
    assert mv.summary["events"]["n_classified"] == len(movie.events) - 1


def test_warning_when_the_censor_leaves_nothing_classified():
    movie = t1_movie(periodic=False, seed=2)
    first = movie.labels[:12]  # the scripted T1s have started, none is undone yet
    with pytest.warns(HexatissueWarning, match="no T1 event is classified as an intercalation"):
        mv = analyze(first, events=EventOptions(min_length=movie.min_length, censor=12), workers=1,
                     progress=False)
    assert len(mv.events) == int((movie.events["frame_start"] < 11).sum()) > 0
    assert (mv.events["kind"] == "unresolved").all() and mv.summary["events"]["n_classified"] == 0
    assert mv.summary["events"]["censor_rule"] == "given"


# ----------------------------------------------------------------------------
# Real curated movies: the ids come back unchanged, divisions are kept
# ----------------------------------------------------------------------------

@pytest.mark.parametrize("where", ["sample", "real"])
def test_epicure_curated_tracks_and_division_kept_by_default(where, request):
    pytest.importorskip("imagecodecs")
    if where == "sample":
        path = ROOT / "hexatissue" / "sample_data" / "epicure_notum" / "013_crop_labels.tif"
        if not path.exists():
            pytest.skip("the bundled EpiCure sample is absent")
    else:
        path = real_subdir(request.getfixturevalue("real_data"), "epicure_notum") / "013_crop_labels.tif"
    mv = _run(path)
    cells = mv.cells
    assert len(cells) == 902 and (cells["track"] == cells["cell"]).all()
    lin = mv.lineage.set_index("track")
    assert lin.loc[477, "parent"] == lin.loc[490, "parent"] == 73 and lin.loc[73, "end"] == "division"
    assert lin.loc[477, "frame_start"] == lin.loc[490, "frame_start"] == 3 and lin.loc[73, "frame_end"] == 2
    assert (lin["parent"] > 0).sum() == 2  # the one annotated division, nothing invented
    # ... and it is plausible: 627 px of daughters at frame 3 from a 662 px mother at frame 2 (ratio 0.947)
    assert not lin.loc[[477, 490], "division_suspect"].any() and (lin.loc[[477, 490], "division_reason"] == "").all()
    assert lin.loc[477, "division_area_ratio"] == pytest.approx(627 / 662, rel=1e-12)
    tracking = mv.summary["tracking"]
    assert tracking["resolved"] == "never" and tracking["n_divisions"] == 1 and tracking["rows_track_not_cell"] == 0
    assert tracking["n_divisions_plausible"] == 1 and tracking["n_divisions_suspect"] == 0
    assert tracking["id_consistency"] > 0.99
    assert mv.options["events"].censor == 2  # 11 frames


def test_itasc_pos00_tracks_kept_and_events_classified(real_data):
    tifffile = pytest.importorskip("tifffile")
    path = real_subdir(real_data, "itasc_micropattern") / "pos00" / "cell_labels.tif"
    if not path.exists():
        pytest.skip("pos00/cell_labels.tif is absent")
    labels = tifffile.imread(path).astype(np.int64)  # AGPL data: read in place, never copied
    mv = _run(labels)
    cells = mv.cells
    assert (cells["track"] == cells["cell"]).all() and cells["track"].nunique() == 125
    lin = mv.lineage
    assert (lin["parent"] == 0).all() and not (lin["end"] == "division").any()  # no division invented
    assert mv.summary["tracking"]["resolved"] == "never" and mv.summary["tracking"]["id_consistency"] > 0.95
    ev = mv.events
    assert mv.options["events"].censor == 2  # 10 frames
    unresolved = ev["kind"] == "unresolved"
    # within the last censor frames only a T1 already undone (a cycle) is classified
    intercalation = ev["kind"] == "intercalation"
    assert (ev.loc[unresolved, "frame_start"] > 9 - 2).all() and (ev.loc[intercalation, "frame_start"] <= 7).all()
    assert (ev.loc[~unresolved & ~intercalation, "kind"] == "cycle").all()
    assert (ev.loc[ev["kind"] == "cycle", "frame_end"] <= 9).all()
    assert (ev["kind"] == "intercalation").sum() > 0 and mv.summary["events"]["n_classified"] == (~unresolved).sum()
    # the former fixed window of 10 frames leaves no intercalation in a 10-frame movie: a warning says so
    with pytest.warns(HexatissueWarning, match="no T1 event is classified as an intercalation"):
        ten = analyze(labels, events=EventOptions(censor=10), workers=1, progress=False)
    assert ten.summary["events"]["n_intercalations"] == 0 and ten.summary["events"]["n_unresolved"] > 0


def test_report_says_why_the_event_sections_are_empty(tmp_path):
    from hexatissue.workflows import report

    movie = t1_movie(periodic=False, seed=2)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HexatissueWarning)
        mv = analyze(movie.labels[:12], events=EventOptions(min_length=movie.min_length, censor=12), workers=1,
                     progress=False)
        report(mv, tmp_path, dl=60.0, seed=0)
    text = (tmp_path / "report.md").read_text()
    n = len(mv.events)
    assert f"All {n} T1 events that are not undone are unresolved: each starts within censor = 12 frames" in text
    assert "Too little to compare: 0 cell(s) with a cycle period, 0 with an intercalation interval. All" in text
    assert "Intercalations per cell are all 0 here: All" in text
    assert "- tracking: label ids kept as tracks (track='auto')" in text
    assert f"- unresolved: {n} (censor 12 frames)" in text


def test_cli_track_choices():
    from hexatissue.cli import build_parser, stage_options

    parser = build_parser()
    options = stage_options(parser.parse_args(["analyze", "in.tif", "--out", "o"]))
    assert options["track"].mode == "auto" and options["events"].censor is None
    args = parser.parse_args(["analyze", "in.tif", "--out", "o", "--track", "never"])
    assert stage_options(args)["track"].mode == "never"
    for bad in (["--track", "yes"], ["--no-track"]):
        with pytest.raises(SystemExit):
            parser.parse_args(["analyze", "in.tif", "--out", "o", *bad])


def test_mode_off_makes_every_cell_its_own_track():
    """track='off' (unrelated images): no track spans two frames, so no T1 events and no defect links."""
    stack = _movie(n_frames=4)
    movie = _run(stack, mode="off")
    assert movie.summary["tracking"]["resolved"] == "off"
    assert movie.cells["track"].is_unique and (movie.lineage["n_frames"] == 1).all()
    assert len(movie.events) == 0 and len(movie.defect_events) == 0
    assert not movie.defects.duplicated(["p", "track"]).any()
    same = _run(stack, mode="never")  # the tables other than tracks (and the velocities along them) do not
    track_columns = ["track", "vx", "vy"]  # depend on the mode
    pd.testing.assert_frame_equal(movie.cells.drop(columns=track_columns), same.cells.drop(columns=track_columns))
    assert movie.cells[["vx", "vy"]].isna().all().all() and same.cells["vx"].notna().any()
