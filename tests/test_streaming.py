"""analyze(out=...): tables streamed to Parquet parts as the frames finish, movie stages on the columns they read.

The streamed run must give exactly the tables of the in-memory run (values,
dtypes, column order), on every kind of movie the stages treat differently:
overlap tracking with relabelled ids, a periodic box, divisions, unrelated
frames, the deformation budget, a checkpointed and resumed run; and its
results folder must read back the same, eagerly or lazily.
"""
import json

import numpy as np
import pandas as pd
import pytest

from hexatissue import DeformationOptions, EventOptions, InputError, TrackOptions, analyze, read_results
from hexatissue import pipeline
from hexatissue._dispatch import references
from hexatissue import stages as _stages
from hexatissue.stored import StoredTable
from hexatissue.synthetic import relabel_movie, t1_movie, voronoi_movie
from tests.test_pipeline import _FailingStack
from tests.test_track import _division_movie

pytestmark = pytest.mark.filterwarnings("ignore::hexatissue.errors.HexatissueWarning")


@pytest.fixture
def small_parts(monkeypatch):
    """Parts of a few frames each, so that every table spans several parts."""
    monkeypatch.setattr(pipeline, "PART_BYTES", 40_000)


def _assert_same_tables(streamed, memory):
    assert list(streamed.tables) == list(memory.tables)
    for name, table in memory.tables.items():
        got = streamed.tables[name]
        got = got.to_pandas() if isinstance(got, StoredTable) else got
        pd.testing.assert_frame_equal(got, table, obj=name)
    assert streamed.summary == memory.summary
    assert {k: v.to_dict() for k, v in streamed.options.items()} == {k: v.to_dict() for k, v in memory.options.items()}


def _relabelled(n_frames=8, seed=3):
    mov = voronoi_movie(60, (120, 140), n_frames, periodic=False, amplitude=0.8, seed=seed)
    return relabel_movie(np.stack([mov[t] for t in range(n_frames)]), seed=seed)[0]


def test_streamed_tables_equal_the_in_memory_ones_with_overlap_tracking_and_the_budget(tmp_path, small_parts):
    stack = _relabelled()
    options = dict(workers=1, progress=False, deformation=DeformationOptions(enabled=True))
    memory = analyze(stack, **options)
    streamed = analyze(stack, out=tmp_path, **options)
    assert isinstance(streamed.cells, StoredTable) and len(streamed.cells.parts) > 2  # several parts per table
    assert (memory.cells["track"] != memory.cells["cell"]).any()  # the ids are not the tracks: tracking did work
    # defects linked a part at a time: tracks across parts, pair events
    assert len(streamed.defects.parts) > 2 and len(memory.defect_events)
    assert (memory.defects.groupby(["p", "track"])["frame"].nunique() > 1).any()
    _assert_same_tables(streamed, memory)
    _assert_same_tables(read_results(tmp_path, lazy=False), memory)
    files = sorted(p.name for p in (tmp_path / "cells").iterdir())
    assert files[0] == "part-00000000-" + files[0][-16:] and all(f.endswith(".parquet") for f in files)
    # the parts read as one table with the readers people use, units in the field metadata
    import pyarrow.dataset as ds

    table = ds.dataset(tmp_path / "cells", format="parquet").to_table()
    assert table.num_rows == len(memory.cells) and table.schema.field("x").metadata[b"unit"] == b"px"
    pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "cells"), memory.cells)


@pytest.mark.parametrize("periodic", [True, False], ids=["periodic", "open"])
def test_streamed_t1_movie_equals_in_memory(tmp_path, small_parts, periodic):
    movie = t1_movie(periodic=periodic, seed=2)
    options = dict(box=movie.box, workers=1, progress=False, deformation=DeformationOptions(enabled=True),
                   events=EventOptions(min_length=movie.min_length, censor=movie.censor))
    memory = analyze(movie.labels, **options)
    assert len(memory.events) and (memory.deformation["region"] == "grid").any()
    streamed = analyze(movie.labels, out=tmp_path, **options)
    # the budget is made a chunk of frames at a time and kept in parts, as the frame tables
    assert streamed.deformation.frame_chunks == streamed.cells.frame_chunks and len(streamed.cells.parts) > 2
    _assert_same_tables(streamed, memory)


def test_streamed_divisions_and_unrelated_frames_equal_in_memory(tmp_path, small_parts):
    stack = _division_movie()[0]
    memory = analyze(stack, workers=1, progress=False)
    assert (memory.lineage["end"] == "division").any()
    _assert_same_tables(analyze(stack, out=tmp_path / "a", workers=1, progress=False), memory)
    off = dict(workers=1, progress=False, track=TrackOptions(mode="off"))
    _assert_same_tables(analyze(stack, out=tmp_path / "b", **off), analyze(stack, **off))


def test_streamed_unrelated_frames_have_each_defect_its_own_track_as_in_memory(tmp_path, small_parts):
    stack = _relabelled(n_frames=4, seed=5)
    off = dict(workers=1, progress=False, track=TrackOptions(mode="off"))
    memory = analyze(stack, **off)
    streamed = analyze(stack, out=tmp_path, **off)
    assert len(streamed.defects.parts) > 1 and len(memory.defects) and memory.defect_events.empty
    for _, of_p in memory.defects.groupby("p"):  # numbered per p in frame, then row order
        assert of_p["track"].tolist() == list(range(len(of_p)))
    _assert_same_tables(streamed, memory)


def test_streamed_run_resumes_from_its_checkpoint(tmp_path):
    stack = _relabelled(n_frames=7, seed=8)
    memory = analyze(stack, workers=1, progress=False)
    with pytest.raises(InputError, match="frame 5.*simulated crash"):
        analyze(_FailingStack(stack, 5), workers=1, progress=False, checkpoint=tmp_path / "ck", checkpoint_every=2,
                out=tmp_path / "out")
    assert not (tmp_path / "out" / "metadata.json").exists()  # the interrupted folder is not a result
    with pytest.raises(InputError, match="metadata.json"):
        read_results(tmp_path / "out")
    # the checkpoint holds the frame states only: the tables of the frames it counts done are the parts in `out`
    assert not list((tmp_path / "ck").glob("*.parquet"))
    assert sorted(p.name for p in (tmp_path / "out" / "cells").iterdir()) == [
        "part-00000000-00000001.parquet", "part-00000002-00000003.parquet"]
    with pytest.raises(InputError, match="another movie or other options"):  # another out folder: not resumed
        analyze(stack, workers=1, progress=False, checkpoint=tmp_path / "ck", checkpoint_every=2,
                out=tmp_path / "elsewhere")
    resumed = analyze(_FailingStack(stack, 1), workers=1, progress=False, checkpoint=tmp_path / "ck",
                      checkpoint_every=2, out=tmp_path / "out")  # frames 0-3 are not read again
    _assert_same_tables(resumed, memory)
    assert resumed.cells.frame_chunks == [(0, 1), (2, 3), (4, 5), (6, 6)]  # one part per checkpoint


def test_a_resumed_streamed_run_refuses_an_out_folder_without_its_frames(tmp_path):
    stack = _relabelled(n_frames=5, seed=9)
    with pytest.raises(InputError, match="simulated crash"):
        analyze(_FailingStack(stack, 3), workers=1, progress=False, checkpoint=tmp_path / "ck", checkpoint_every=2,
                out=tmp_path / "out")
    (tmp_path / "out" / "edges" / "part-00000000-00000001.parquet").unlink()
    with pytest.raises(InputError, match="does not hold the edges of frames 0-1"):
        analyze(_FailingStack(stack, 99), workers=1, progress=False, checkpoint=tmp_path / "ck", checkpoint_every=2,
                out=tmp_path / "out")


def test_lazy_results_read_by_column_and_frame_and_written_elsewhere(tmp_path, small_parts):
    stack = _relabelled(n_frames=6, seed=5)
    memory = analyze(stack, workers=1, progress=False)
    analyze(stack, out=tmp_path / "run", workers=1, progress=False)
    lazy = read_results(tmp_path / "run", lazy=True)
    assert isinstance(lazy.cells, StoredTable) and isinstance(lazy.events, pd.DataFrame)
    assert lazy.cells.columns == list(memory.cells.columns) and len(lazy.cells) == len(memory.cells)
    pd.testing.assert_frame_equal(lazy.table_at("edges", 3), memory.table_at("edges", 3))
    part = lazy.cells.read(["track", "x"], frames=(2, 4))
    f = memory.cells["frame"].between(2, 4)
    pd.testing.assert_frame_equal(part, memory.cells.loc[f, ["track", "x"]].reset_index(drop=True))
    pd.testing.assert_series_equal(lazy.cells["area"], memory.cells["area"])
    # the readers of large tables people use: pyarrow datasets and dask dataframes, one partition per part
    assert lazy.cells.dataset().count_rows() == len(memory.cells)
    frame = lazy.cells.to_dask(["frame", "x"])
    assert frame.npartitions == len(lazy.cells.parts)
    pd.testing.assert_frame_equal(frame.compute().reset_index(drop=True), memory.cells[["frame", "x"]])
    # a lazy Movie written elsewhere: parts copied one by one; as CSV: one file
    lazy.write(tmp_path / "copy", formats=("parquet", "csv"))
    _assert_same_tables(read_results(tmp_path / "copy", lazy=False), memory)
    pd.testing.assert_frame_equal(pd.read_csv(tmp_path / "copy" / "cells.csv"), pd.read_csv(
        memory.write(tmp_path / "csv", formats="csv")[0].parent / "cells.csv"))
    # an in-memory result written over the streamed folder replaces its parts
    memory.write(tmp_path / "run")
    assert not (tmp_path / "run" / "cells").exists() and (tmp_path / "run" / "cells.parquet").exists()
    _assert_same_tables(read_results(tmp_path / "run"), memory)


def test_auto_lazy_by_size_and_bad_values(tmp_path, monkeypatch):
    stack = _relabelled(n_frames=3, seed=6)
    analyze(stack, out=tmp_path, workers=1, progress=False)
    from hexatissue import results

    assert isinstance(read_results(tmp_path).cells, pd.DataFrame)  # small: read
    monkeypatch.setattr(results, "LAZY_BYTES", 1)
    assert isinstance(read_results(tmp_path).cells, StoredTable)  # large: left on disk
    with pytest.raises(InputError, match="lazy must be"):
        read_results(tmp_path, lazy="yes")
    meta = json.loads((tmp_path / "metadata.json").read_text())
    assert meta["tables"]["cells"] == len(read_results(tmp_path, lazy=False).cells)


def test_out_refuses_a_folder_of_someone_elses_tables(tmp_path):
    (tmp_path / "cells.parquet").write_bytes(b"not ours")
    with pytest.raises(InputError, match="not a results folder"):
        analyze(_relabelled(n_frames=2), out=tmp_path, workers=1, progress=False)
    assert (tmp_path / "cells.parquet").read_bytes() == b"not ours"


def test_cli_streams_on_request_and_by_size(tmp_path, monkeypatch, capsys):
    from hexatissue.cli import main
    from hexatissue.samples import sample_path

    sample = str(sample_path("epicure_notum"))
    assert main(["analyze", sample, "--out", str(tmp_path / "s"), "--stream", "yes", "--format", "parquet",
                 "csv"]) == 0
    assert main(["analyze", sample, "--out", str(tmp_path / "m"), "--stream", "no"]) == 0
    assert (tmp_path / "s" / "cells").is_dir() and (tmp_path / "s" / "cells.csv").exists()
    assert (tmp_path / "m" / "cells.parquet").is_file() and not (tmp_path / "m" / "cells").exists()
    _assert_same_tables(read_results(tmp_path / "s"), read_results(tmp_path / "m"))
    # auto: by the input's pixel-frames
    monkeypatch.setattr(pipeline, "STREAM_PIXELS", 1000)
    assert main(["analyze", sample, "--out", str(tmp_path / "a")]) == 0
    assert (tmp_path / "a" / "cells").is_dir()
    assert main(["report", str(tmp_path / "a"), "--out", str(tmp_path / "report")]) == 0


class _KillingStack:
    """Frames of ``stack``; reading frame ``at`` (in the main process, while earlier batches are on the workers)
    kills one dask worker process."""

    def __init__(self, stack, at, kill):
        self.stack, self.at, self.kill, self.shape, self.dtype = stack, at, kill, stack.shape, stack.dtype

    def __getitem__(self, t):
        if t == self.at:
            self.kill()
        return self.stack[t]


@pytest.mark.slow
def test_streamed_run_on_a_dask_cluster_survives_a_killed_worker(tmp_path, small_parts):
    import os
    import signal

    from distributed import Client, LocalCluster

    stack = _relabelled(n_frames=12, seed=4)
    memory = analyze(stack, workers=1, progress=False)
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
            Client(cluster) as client:
        pids = list(client.run(os.getpid).values())
        killed = []

        def kill():
            os.kill(pids[0], signal.SIGKILL)  # the nanny starts a new worker; its tasks run again
            killed.append(pids[0])

        streamed = analyze(_KillingStack(stack, 6, kill), client=client, out=tmp_path, progress=False)
    assert killed
    _assert_same_tables(streamed, memory)


def test_a_stored_table_is_read_a_block_of_frames_at_a_time(tmp_path, small_parts):
    stack = _relabelled(n_frames=6, seed=7)
    memory = analyze(stack, workers=1, progress=False)
    analyze(stack, out=tmp_path, workers=1, progress=False)
    edges = read_results(tmp_path, lazy=True).edges
    read = edges.frames_reader(["cell_a", "length"])  # the frame column is not asked for: still used to find rows
    for first, last in [(0, 0), (1, 3), (4, 5), (6, 9)]:
        want = memory.edges.loc[memory.edges["frame"].between(first, last), ["cell_a", "length"]]
        pd.testing.assert_frame_equal(read(first, last).reset_index(drop=True), want.reset_index(drop=True))


def _stored(tmp_path, n_parts=3, rows=4):
    table = StoredTable(tmp_path / "cells", "cells")
    for k in range(n_parts):
        frame = np.full(rows, k, np.int64)
        table.append(pd.DataFrame({"frame": frame, "cell": np.arange(1, rows + 1), "x": frame * 1.5}), k, k)
    return table


def test_a_column_added_part_by_part_is_kept_on_disk_until_finished(tmp_path):
    table = _stored(tmp_path)
    values = np.arange(12, dtype=np.float64) / 7
    writer = table.column_writer("vx", np.float64)
    for k in range(3):  # one part at a time, as the flow stage writes the velocities
        writer.write(values[4 * k:4 * k + 4])
    writer.close()
    table.add_column("track", np.arange(100, 112), after="cell")
    table.add_column("border", np.arange(12) % 2 == 0)
    hidden = sorted(p.name for p in (tmp_path / "cells").iterdir() if not p.name.startswith("part-"))
    assert hidden == [".added-border.npy", ".added-track.npy", ".added-vx.npy"]
    # the folder's readers skip the added columns' files; the table reads them, a slice at a time
    assert list(pd.read_parquet(tmp_path / "cells").columns) == ["frame", "cell", "x"]
    got = table.read()
    assert list(got.columns) == ["frame", "cell", "track", "x", "vx", "border"]
    np.testing.assert_array_equal(got["vx"], values)
    np.testing.assert_array_equal(table.read(["track"], frames=(1, 1))["track"], np.arange(104, 108))
    assert got["border"].dtype == bool
    # a column added again keeps its place; finish writes them into the parts and removes the files
    table.add_column("track", np.arange(200, 212))
    table.finish()
    assert sorted(p.name for p in (tmp_path / "cells").iterdir()) == [f"part-{k:08d}-{k:08d}.parquet" for k in range(3)]
    back = pd.read_parquet(tmp_path / "cells")
    assert list(back.columns) == ["frame", "cell", "track", "x", "vx", "border"]
    np.testing.assert_array_equal(back["track"], np.arange(200, 212))


def test_a_column_writer_refuses_too_few_or_too_many_values_and_leaves_nothing(tmp_path):
    table = _stored(tmp_path)
    short = table.column_writer("vx", np.float64)
    short.write(np.zeros(11))
    with pytest.raises(ValueError, match="11 values for 12 rows"):
        short.close()
    long = table.column_writer("vy", np.float64)
    with pytest.raises(ValueError, match="more values than the table's 12 rows"):
        long.write(np.zeros(13))
    with pytest.raises(ValueError, match="numeric or bool"):
        table.column_writer("name", object)
    assert table.added == []
    assert all(p.name.startswith("part-") for p in (tmp_path / "cells").iterdir())


def test_a_second_analysis_streaming_into_a_folder_in_use_is_refused(tmp_path):
    """Another process holds the out folder (a running analysis): analyze(out=) refuses it, naming the folder, and
    writes nothing there; once it is free, the folder is used.  In one process the lock is taken again (the CLI
    holds its --out folder while analyze streams into it)."""
    from hexatissue.io import lock_folder
    from hexatissue.results import RUN_LOCK
    from tests.conftest import lock_held_elsewhere

    stack = _relabelled(n_frames=3)
    with lock_held_elsewhere(tmp_path, RUN_LOCK):
        with pytest.raises(InputError, match="out folder .* is in use by another running analysis"):
            analyze(stack, out=tmp_path, workers=1, progress=False)
        assert not (tmp_path / "cells").exists()
    mine = lock_folder(tmp_path, RUN_LOCK, "--out folder")
    try:
        movie = analyze(stack, out=tmp_path, workers=1, progress=False)
    finally:
        mine.close()
    assert (tmp_path / "metadata.json").is_file() and len(movie.cells)


_FLOW_CHUNK = _stages._flow_chunk
_PIDS = []  # the file the recording task writes to (set before the pool forks: its workers inherit it)


def _recording_flow_chunk(span, *args):
    """The flow stage's chunk task, recording the process it ran in."""
    import os

    with open(_PIDS[0], "a") as f:
        f.write(f"{os.getpid()}\n")
    return _FLOW_CHUNK(span, *args)


def test_the_streamed_flow_runs_its_chunks_here_with_a_process_pool_and_equals_in_memory(tmp_path, small_parts,
                                                                                         monkeypatch):
    """With local workers the flow's chunks run in the submitting process (a pool would hold a chunk's working set
    per worker on the same machine); on a dask cluster they go to its workers (the tests below)."""
    import os

    stack = _relabelled(n_frames=8, seed=6)
    memory = analyze(stack, workers=1, progress=False)
    monkeypatch.setattr(_stages, "_flow_chunk", _recording_flow_chunk)
    _PIDS.append(tmp_path / "pids")
    try:
        streamed = analyze(stack, out=tmp_path / "out", workers=2, progress=False)
    finally:
        _PIDS.clear()
    pids = [int(line) for line in (tmp_path / "pids").read_text().split()]
    assert len(pids) == len(streamed.cells.parts) > 2  # one task per chunk
    assert set(pids) == {os.getpid()}
    assert (memory.cells["vx"].notna().sum() > 0) and len(memory.flow)
    _assert_same_tables(streamed, memory)


def test_the_streamed_flow_on_a_dask_client_equals_in_memory(tmp_path, small_parts):
    from distributed import Client, LocalCluster

    stack = _relabelled(n_frames=6, seed=10)
    memory = analyze(stack, workers=1, progress=False)
    # workers in this process, running the references of the kernels not compiled, as the in-process run does
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None) as cluster, \
            Client(cluster) as client, references("auto"):
        streamed = analyze(stack, client=client, out=tmp_path, progress=False)
    assert len(streamed.cells.parts) > 2
    _assert_same_tables(streamed, memory)
