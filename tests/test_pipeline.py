"""hexatissue.analyze end to end: rasterised synthetic movies with exact truth, executors, inputs, real data."""
import json
import warnings
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from hexatissue.box import Box
from hexatissue.errors import HexatissueWarning, InputError
from hexatissue import EventOptions, TrackOptions, analyze
from hexatissue.synthetic import relabel_movie, t1_movie, voronoi_movie
from tests.conftest import real_subdir
from tests.test_events import assert_valid_quartets

def analyze_movie(source, box=None, *, workers=1, min_length=0.0, censor=10, track="auto", max_gap=0, client=None,
                  checkpoint=None, checkpoint_every=100):
    """analyze() with the event and tracking options of these tests, one process by default, no progress bar."""
    return analyze(source, box=box, track=TrackOptions(mode=track, max_gap=max_gap),
                   events=EventOptions(min_length=min_length, censor=censor), workers=workers, client=client,
                   checkpoint=checkpoint, checkpoint_every=checkpoint_every)


KEY = ["kind", "frame_start", "frame_end", "duration", "cell_a", "cell_b", "cell_c", "cell_d", "frame_gain"]


@pytest.fixture(scope="module", params=[True, False], ids=["periodic", "open"])
def movie(request):
    return t1_movie(periodic=request.param, seed=2)


def _events_by_truth_ids(events, cells, maps):
    """Events with track ids replaced by the original labels (via the relabelling maps)."""
    to_orig = {}
    for f, c, t in zip(cells["frame"], cells["cell"], cells["track"]):
        to_orig.setdefault(t, set()).add(maps[f][c])
    assert all(len(v) == 1 for v in to_orig.values()), "a track mixes several original cells"
    to_orig = {t: v.pop() for t, v in to_orig.items()}
    out = events.copy()
    for col in ("cell_a", "cell_b", "cell_c", "cell_d"):
        out[col] = out[col].map(to_orig)
    # the original ids may order a pair differently
    for x, y in (("cell_a", "cell_b"), ("cell_c", "cell_d")):
        lo, hi = np.minimum(out[x], out[y]), np.maximum(out[x], out[y])
        out[x], out[y] = lo, hi
    return out.sort_values(["frame_start", "cell_a", "cell_b"], ignore_index=True)


def test_rasterised_movie_events_equal_truth(movie):
    mv = analyze_movie(movie.labels, box=movie.box, workers=1, min_length=movie.min_length,
                       censor=movie.censor)
    ev = mv.events
    pd.testing.assert_frame_equal(ev[KEY].astype({"kind": object}), movie.events[KEY].astype({"kind": object}))
    # quartet centre from pixel centroids vs from the seeds
    np.testing.assert_allclose(ev[["x", "y"]], movie.events[["x", "y"]], atol=1.5)
    assert (mv.cells["track"] == mv.cells["cell"]).all()
    lin = mv.lineage
    assert len(lin) == movie.labels.max() and (lin["begin"] == "movie_start").all()
    stats = mv.cell_events.set_index("track")
    assert stats["n_cycles"].sum() == 4 * 2 and stats["n_intercalations"].sum() == 4 * 2
    cyc = movie.events[movie.events["kind"] == "cycle"].iloc[0]
    assert stats.loc[cyc["cell_a"], "mean_cycle_period"] == cyc["duration"]


def test_relabelled_movie_gives_same_events_with_a_process_pool(movie):
    relabelled, maps = relabel_movie(movie.labels, seed=7)
    mv = analyze_movie(relabelled, box=movie.box, workers=2, min_length=movie.min_length,
                       censor=movie.censor)
    got = _events_by_truth_ids(mv.events, mv.cells, maps)
    pd.testing.assert_frame_equal(got[KEY].astype({"kind": object}), movie.events[KEY].astype({"kind": object}))


def test_dask_client_gives_the_serial_result():
    distributed = pytest.importorskip("distributed")
    stack = voronoi_movie(30, (80, 110), 6, periodic=True, amplitude=0.5, seed=4)
    box = Box(110, 80)
    serial = analyze_movie(stack, box=box, workers=1)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        parallel = analyze_movie(stack, box=box, client=client)
    for name, table in serial.tables.items():
        pd.testing.assert_frame_equal(parallel.tables[name], table)


def test_run_objects_skip_tracking_unless_forced():
    stack = voronoi_movie(30, (80, 110), 4, periodic=True, seed=1)
    labels = np.stack([stack[t] for t in range(4)])
    relabelled, maps = relabel_movie(labels, seed=3)
    run = SimpleNamespace(labels=relabelled, box=Box(110, 80), cells=None, params=None)
    mv = analyze_movie(run, workers=1)
    assert mv.box == run.box
    assert (mv.cells["track"] == mv.cells["cell"]).all()  # identity trusted
    mv = analyze_movie(run, track="always", workers=1)
    orig = np.array([maps[f][c] for f, c in zip(mv.cells["frame"], mv.cells["cell"])])
    assert len(set(zip(mv.cells["track"], orig))) == len(np.unique(orig)) == mv.cells["track"].nunique()
    # a label stack can be trusted too
    mv = analyze_movie(relabelled, box=True, track="never", workers=1)
    assert (mv.cells["track"] == mv.cells["cell"]).all() and mv.box == run.box


def test_inputs_and_writing(tmp_path):
    stack = voronoi_movie(20, (60, 90), 3, periodic=False, seed=0)
    from_lazy = analyze_movie(stack, workers=1)
    from_list = analyze_movie([stack[t] for t in range(3)], workers=1)
    pd.testing.assert_frame_equal(from_lazy.cells, from_list.cells)
    assert sorted(from_lazy.frames.tolist()) == [0, 1, 2]
    paths = from_lazy.write(tmp_path)
    names = {p.name for p in paths}
    assert {"events.parquet", "lineage.parquet", "cell_events.parquet", "cells.parquet"} <= names
    back = pd.read_parquet(tmp_path / "lineage.parquet")
    assert list(back.columns) == list(from_lazy.lineage.columns)
    # a saved stack file is read too
    np.save(tmp_path / "stack.npy", np.stack([stack[t] for t in range(3)]))
    from_file = analyze_movie(tmp_path / "stack.npy", workers=1)
    pd.testing.assert_frame_equal(from_file.cells, from_lazy.cells)


def test_bad_input():
    with pytest.raises(InputError, match="empty"):
        analyze_movie([])
    with pytest.raises(InputError, match="does not match"):
        analyze_movie(np.ones((2, 5, 6), int), box=Box(5, 6), workers=1)
    with pytest.raises(InputError, match="workers"):
        analyze_movie(np.ones((2, 5, 6), int), workers=0)
    with pytest.raises(InputError, match="must be a path, an array"):
        analyze_movie(42)
    with pytest.raises(InputError, match="mesh must be a hexatissue.MeshOptions"):
        analyze(np.ones((2, 5, 6), int), mesh={"kind": "touching"})
    with pytest.raises(InputError, match="EventOptions.censor"):
        EventOptions(censor=-1)


def test_epicure_division_through_the_pipeline(real_data):
    path = real_subdir(real_data, "epicure_notum") / "013_crop_labels_copy.npz"
    if not path.exists():
        pytest.skip("013_crop_labels_copy.npz is absent")
    labels = np.load(path)["labels"]
    relabelled, maps = relabel_movie(labels.astype(np.int64), seed=1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HexatissueWarning)
        mv = analyze_movie(relabelled, workers=1, max_gap=4)
    cells = mv.cells.assign(curated=[maps[f][c] for f, c in zip(mv.cells["frame"], mv.cells["cell"])])
    track_of = cells.drop_duplicates("curated").set_index("curated")["track"]
    lin = mv.lineage.set_index("track")
    assert lin.loc[track_of[73], "end"] == "division"
    assert lin.loc[track_of[477], "parent"] == lin.loc[track_of[490], "parent"] == track_of[73]
    assert_valid_quartets(mv.events, mv.edges, mv.cells)


@pytest.mark.parametrize("pos", ["pos00", "pos01", "pos02"])
def test_itasc_events_are_valid_quartets_and_stable_under_relabelling(real_data, pos):
    tifffile = pytest.importorskip("tifffile")
    path = real_subdir(real_data, "itasc_micropattern") / pos / "cell_labels.tif"
    if not path.exists():
        pytest.skip(f"{pos}/cell_labels.tif is absent")
    labels = tifffile.imread(path).astype(np.int64)  # AGPL data: read in place, never copied
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HexatissueWarning)
        mv = analyze_movie(labels, workers=1, censor=3, track="always")  # overlap tracking, stable under relabelling
        relabelled, maps = relabel_movie(labels, seed=5)
        mv2 = analyze_movie(relabelled, workers=1, censor=3)
    ev = mv.events
    assert len(ev) > 0
    assert_valid_quartets(ev, mv.edges, mv.cells)
    # same events once the relabelled run's tracks are mapped back to the original tracks
    orig_track = {(f, c): t for f, c, t in zip(mv.cells["frame"], mv.cells["cell"], mv.cells["track"])}
    to_first = {}
    for f, c, t in zip(mv2.cells["frame"], mv2.cells["cell"], mv2.cells["track"]):
        to_first.setdefault(t, set()).add(orig_track[(f, maps[f][c])])
    assert all(len(v) == 1 for v in to_first.values())
    maps_back = {t: v.pop() for t, v in to_first.items()}
    got = mv2.events.copy()
    for col in ("cell_a", "cell_b", "cell_c", "cell_d"):
        got[col] = got[col].map(maps_back)
    canon = lambda df: sorted((r.kind, r.frame_start, r.frame_gain, tuple(sorted((r.cell_a, r.cell_b))),
                               tuple(sorted((r.cell_c, r.cell_d)))) for r in df.itertuples())
    assert canon(got) == canon(ev)


class _FailingStack:
    """A lazily indexed stack whose frame ``fail_at`` cannot be read (a crash mid-run)."""

    def __init__(self, stack, fail_at):
        self.stack, self.fail_at, self.shape = stack, fail_at, stack.shape

    def __getitem__(self, t):
        if t == self.fail_at:
            raise RuntimeError("simulated crash")
        return self.stack[t]


def test_checkpoint_resume_gives_the_uninterrupted_result(tmp_path):
    mov = voronoi_movie(25, (70, 90), 7, periodic=False, amplitude=0.5, seed=8)
    stack = relabel_movie(np.stack([mov[t] for t in range(7)]), seed=2)[0]
    full = analyze_movie(stack, workers=1)
    with pytest.raises(InputError, match="frame 5.*simulated crash"):  # a reader failure names the frame
        analyze_movie(_FailingStack(stack, 5), workers=1, checkpoint=tmp_path, checkpoint_every=2)
    # frames 0-1 and 2-3, saved at 2 and 4, packed into one part (the two spans are equal)
    assert sorted(p.name for p in tmp_path.glob("cells_*.parquet")) == ["cells_00000000-00000004.parquet"]
    resumed = analyze_movie(_FailingStack(stack, 1), workers=1, checkpoint=tmp_path, checkpoint_every=2)  # frames 0-3 come from the checkpoint and are not read again
    for name, table in full.tables.items():
        pd.testing.assert_frame_equal(resumed.tables[name], table)
    with pytest.raises(InputError, match="other options"):
        analyze_movie(stack, workers=1, checkpoint=tmp_path, max_gap=3)


def test_checkpoint_written_with_the_tracker_alone_resumes(tmp_path):
    """A checkpoint whose state names the tracker's pickle under ``tracker`` (before the stages kept their frame
    states by name) resumes as the tracks stage's state, to the uninterrupted result."""
    mov = voronoi_movie(25, (70, 90), 5, periodic=False, amplitude=0.5, seed=8)
    stack = np.stack([mov[t] for t in range(5)])
    full = analyze_movie(stack, workers=1)
    with pytest.raises(InputError, match="simulated crash"):
        analyze_movie(_FailingStack(stack, 3), workers=1, checkpoint=tmp_path, checkpoint_every=2)
    state = json.loads((tmp_path / "checkpoint.json").read_text())
    assert state["states"] == {"track": "track_state_00000002.pkl"}
    state["tracker"] = state.pop("states")["track"]
    (tmp_path / "checkpoint.json").write_text(json.dumps(state))
    resumed = analyze_movie(_FailingStack(stack, 1), workers=1, checkpoint=tmp_path, checkpoint_every=2)
    for name, table in full.tables.items():
        pd.testing.assert_frame_equal(resumed.tables[name], table)


def test_checkpoint_parts_are_packed_for_long_movies(tmp_path):
    """Saved every frame, a table keeps about log2(frames) files, and a crash anywhere resumes to the same tables."""
    mov = voronoi_movie(12, (40, 50), 37, periodic=False, amplitude=0.5, seed=3)
    stack = np.stack([mov[t] for t in range(37)])
    full = analyze_movie(stack, workers=1)
    for crash in (6, 23):
        folder = tmp_path / f"c{crash}"
        with pytest.raises(InputError, match="simulated crash"):
            analyze_movie(_FailingStack(stack, crash), workers=1, checkpoint=folder, checkpoint_every=1)
        parts = sorted(p.name for p in folder.glob("cells_*.parquet"))
        assert len(parts) <= np.log2(crash) + 1, parts  # 23 parts, one per frame, before packing
        state = json.loads((folder / "checkpoint.json").read_text())
        assert sorted(state["files"]["cells"]) == parts  # nothing left behind, nothing missing
        resumed = analyze_movie(_FailingStack(stack, -1), workers=1, checkpoint=folder, checkpoint_every=1)
        for name, table in full.tables.items():
            pd.testing.assert_frame_equal(resumed.tables[name], table)
    assert len(list((tmp_path / "c23").glob("cells_*.parquet"))) <= np.log2(37) + 1


def test_short_mpf_run_end_to_end(tmp_path):
    simulate = pytest.importorskip("hexatissue.simulate")
    if not hasattr(simulate, "read_run"):
        pytest.skip("hexatissue.simulate.read_run is not available")
    params = simulate.Params(n_cells=6, Lx=48, Ly=44, D_r=1e-3, v0=0.01)
    path = tmp_path / "run.zarr"
    simulate.run_simulation(path, params, steps=60, save_every=10, relax=30, seed=5)
    run = simulate.read_run(path)
    mv = analyze_movie(path, workers=1)  # a run store path: read with read_run
    assert mv.box == run.box and len(mv) == run.labels.shape[0]
    assert (mv.cells["track"] == mv.cells["cell"]).all()  # MPF ids are consistent: no tracking
    # every simulated cell is found, and its phase-field centre lies inside its own label region
    # (pixel centroids may differ by a few px: holes between unrelaxed cells go to their neighbours)
    both = mv.cells.merge(run.cells, on=["frame", "cell"], suffixes=("", "_run"), validate="one_to_one")
    assert len(both) == len(run.cells)
    centre = np.round(both[["x_run", "y_run"]].to_numpy()).astype(int) % [int(run.box.Lx), int(run.box.Ly)]
    owner = [np.asarray(run.labels[t])[y, x] for t, (x, y) in zip(both["frame"], centre)]
    assert (np.array(owner) == both["cell"].to_numpy()).all()
    d = run.box.min_image(both[["x", "y"]].to_numpy() - both[["x_run", "y_run"]].to_numpy())
    assert np.abs(d).max() < 6.0
    lin = mv.lineage
    assert len(lin) == params.n_cells and (lin["begin"] == "movie_start").all()
    assert_valid_quartets(mv.events, mv.edges, mv.cells)


def test_a_tqdm_class_draws_the_progress_bar():
    """analyze(progress=<tqdm subclass>) counts the frames with that class (the napari widget passes napari's)."""
    from tqdm import tqdm

    made = []

    class Recorder(tqdm):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, disable=True, **kwargs)
            made.append(self)
            self.seen = 0

        def __iter__(self):
            for item in self.iterable:
                self.seen += 1
                yield item

    stack = voronoi_movie(20, (60, 90), 3, periodic=False, seed=0)
    analyze(stack, workers=1, progress=Recorder)
    assert len(made) == 1 and made[0].total == 3 and made[0].seen == 3



def test_tracks_are_attached_to_cells_in_any_row_order():
    """The track of each cell row is the same whether the rows come in the tracker's order or shuffled."""
    from hexatissue.track import cells_with_tracks
    from hexatissue.track import MovieTracker

    movie = np.stack([np.asarray(f) for f in voronoi_movie(20, (40, 48), 4, periodic=True, amplitude=0.3, seed=5)])
    tracker = MovieTracker("always")
    for t, lab in enumerate(relabel_movie(movie, seed=2)[0]):  # ids relabelled: tracks differ from ids
        tracker.add_valid(lab, t)
    expected = tracker.tracks()
    cells = expected[["frame", "cell"]].assign(area=np.arange(len(expected), dtype=float))
    ordered = cells_with_tracks(cells, tracker)
    assert ordered.columns.tolist() == ["frame", "cell", "track", "area"]
    assert ordered["track"].tolist() == expected["track"].tolist()
    shuffled = cells.sample(frac=1, random_state=0).reset_index(drop=True)
    pd.testing.assert_frame_equal(cells_with_tracks(shuffled, tracker).sort_values("area", ignore_index=True), ordered)
    with pytest.raises(AssertionError, match="missing"):
        cells_with_tracks(cells.assign(cell=cells["cell"] + 1000), tracker)


def test_frames_without_a_field_are_counted_in_one_warning():
    """A frame of one cell (no interior polygon) has no Gamma_p grid: the warning counts it, once, among three."""
    from hexatissue import open_source
    from hexatissue.synthetic import jittered_seeds, voronoi_labels

    tissue = voronoi_labels(jittered_seeds((96, 96), 12.0, seed=1), (96, 96)).astype(np.int32)
    with pytest.warns(HexatissueWarning, match=r"^1 of 3 frame\(s\) have no interior cell") as record:
        movie = analyze(open_source(np.stack([tissue, np.ones_like(tissue), tissue])))
    assert sum("have no interior cell" in str(w.message) for w in record) == 1
    assert sorted(movie.grid["frame"].unique()) == [0, 2]


def test_checkpoint_knows_its_file_by_any_path_and_a_rewritten_file_as_another(tmp_path, monkeypatch):
    """Issue 32: a checkpoint made with an absolute path was refused when resumed with a relative one."""
    mov = voronoi_movie(20, (60, 70), 4, periodic=False, amplitude=0.5, seed=3)
    stack = np.stack([mov[t] for t in range(4)])
    np.save(tmp_path / "movie.npy", stack)
    first = analyze_movie(tmp_path / "movie.npy", workers=1, checkpoint=tmp_path / "ck")
    monkeypatch.chdir(tmp_path)
    again = analyze_movie("movie.npy", workers=1, checkpoint="ck")  # the same file, by a relative path
    pd.testing.assert_frame_equal(again.cells, first.cells)
    np.save(tmp_path / "movie.npy", stack[::-1])  # rewritten under the same name: another movie
    with pytest.raises(InputError, match="holds another movie"):
        analyze_movie("movie.npy", workers=1, checkpoint="ck")
