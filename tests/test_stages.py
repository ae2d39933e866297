"""The list of stages: what it declares is true, and a new stage plugs in with its entry alone.

A new frame stage and a new movie stage are added here the way a contributor
adds one (an options class, schema entries, one entry in ``STAGES``, and the
stage's views module: this one, whose ``VIEW`` holds its figure, report
section, napari layer, legend rows and widget field), and ``analyze``, the
results folder, the checkpoints, the command line, the report, ``analyze
--figures`` and the napari layers and widget take them up with no other
change.  The movie stage also follows the frames (a
:class:`~hexatissue.stages.FrameState`, as the tracks stage's tracker does).
"""
from dataclasses import dataclass, replace

import numpy as np
import pandas as pd
import pytest

from hexatissue import InputError, analyze, read_results, schema
from hexatissue import stages as S
from hexatissue.options import OPTION_CLASSES, _Options, cli_field
from hexatissue.synthetic import voronoi_movie
from hexatissue.views import LayerMaker, Section, StageView, WidgetField

pytestmark = pytest.mark.filterwarnings("ignore::hexatissue.errors.HexatissueWarning")


def _column_in_schema(table, column):
    return any(c == column or schema._pattern(c).match(column) for c in schema.TABLES[table])


def test_every_stage_names_a_registered_options_class_and_writes_what_the_schema_has():
    assert {s.options for s in S.STAGES} == set(OPTION_CLASSES.values())
    for stage in S.STAGES:
        assert OPTION_CLASSES[stage.options.stage] is stage.options
        assert stage.per in ("frame", "movie")
        for name in stage.writes:
            table, _, column = name.partition(".")
            if table in ("labels", "polygons", "height"):  # what the mesh (the surface stage) hands the later frame stages
                assert stage.per == "frame"
                continue
            assert table in schema.TABLES, (stage.name, name)
            assert not column or _column_in_schema(table, column), (stage.name, name)


def test_every_views_module_named_in_the_list_is_a_stage_view_on_the_analysis_floor():
    from hexatissue.views import StageView, stage_views

    named = [s for s in S.STAGES if s.views is not None]
    assert {s.views for s in named} == {f"hexatissue.views.{m}" for m in ("mesh", "order", "surface", "track", "events",
                                                                          "flow", "deformation", "mechanics")}
    views = stage_views()
    assert [stage.name for stage, _ in views] == [s.name for s in named]
    assert all(isinstance(view, StageView) for _, view in views)


def test_tables_read_are_written_by_an_earlier_stage():
    written = {"labels", "image"}
    for stage in S.STAGES:
        for name in stage.reads:
            assert name.partition(".")[0] in written, (stage.name, name)
        written |= {name.partition(".")[0] for name in stage.writes}


def test_stage_options_fill_defaults_and_refuse_what_is_not_an_options_object():
    options = S.stage_options({})
    assert set(options) == set(OPTION_CLASSES)
    assert all(isinstance(options[name], cls) for name, cls in OPTION_CLASSES.items())
    with pytest.raises(InputError, match="mesh must be a hexatissue.MeshOptions; got dict"):
        S.stage_options({"mesh": {"kind": "touching"}})
    with pytest.raises(TypeError, match="unexpected keyword argument"):
        S.stage_options({"meshh": None})
    image = np.zeros((4, 4))
    assert S.stage_options({"intensity": image})["intensity"].image is image


def test_the_stages_that_run_follow_the_options():
    names = [s.name for s in S.frame_stages(S.stage_options({}))]
    assert names == ["junction network", "shape order", "order fields"]
    from hexatissue import OrderOptions

    off = S.stage_options({"order": OrderOptions(fields=False), "intensity": np.zeros((2, 2))})
    assert [s.name for s in S.frame_stages(off)] == ["junction network", "intensity", "shape order"]
    assert "defect tracks" not in [s.name for s in S.movie_stages(off)]
    assert S.frame_tables(S.frame_stages(off)) == ("cells", "vertices", "edges", "cell_vertices")


def test_frame_stages_are_listed_before_movie_stages():
    per = [s.per for s in S.STAGES]
    assert per == sorted(per, key=("frame", "movie").index), [s.name for s in S.STAGES]


def _recorded(stage, log):
    """The stage's entry with a ``run`` that first notes the stage's name in ``log``."""
    def run(data, options):
        log.append(stage.name)
        return stage.run(data, options)
    return replace(stage, run=run)


def test_stages_are_listed_in_the_order_analyze_runs_them(monkeypatch):
    """A run with every stage on, recorded: the list's order is the order the stages ran in."""
    from hexatissue import DeformationOptions, MechanicsOptions

    log = []
    monkeypatch.setattr(S, "STAGES", tuple(_recorded(s, log) for s in S.STAGES))
    movie_frames = voronoi_movie(30, (64, 64), 3, periodic=False, amplitude=0.3, seed=1)
    labels = np.stack([np.asarray(movie_frames[t]) for t in range(3)])
    image = np.random.default_rng(0).random(labels.shape)
    analyze(labels, intensity=image, surface=image, mechanics=MechanicsOptions(enabled=True),
            deformation=DeformationOptions(enabled=True), workers=1, progress=False)
    listed = [s.name for s in S.STAGES]
    assert list(dict.fromkeys(log)) == listed  # every stage ran, first in the list's order
    per_frame = [s.name for s in S.STAGES if s.per == "frame"]
    once = [s.name for s in S.STAGES if s.per == "movie"]
    assert log == per_frame * 3 + once


# --- a new frame stage and a new movie stage, added as a contributor would --------------------------------

def _elongation(frame, options):
    """Toy frame stage: each cell's pixel count times a factor, as a new cells column."""
    cells = frame.tables["cells"]
    cells["toy_area"] = np.asarray(cells["area"], float) * options.factor


def _area_summary(movie, options):
    """Toy movie stage: a new table, the mean toy area per frame, and the cells its frame state counted."""
    cells = movie.tables["cells"]
    mean = cells.groupby("frame")["toy_area"].mean()
    counted = dict(movie.states["toy"])
    movie.tables["toy_summary"] = pd.DataFrame({"frame": mean.index.to_numpy(np.int64),
                                                "mean_toy_area": mean.to_numpy(float),
                                                "n_counted": [counted[t] for t in mean.index]})


def _new_count(options, source, box):
    return []  # (frame, cells) in the order the frames were added


def _count_cells(frames, params):
    """In the worker, after the frame stages: each frame's number of cells, times ``params`` (1)."""
    return [params * len(frame.tables["cells"]["cell"]) for frame in frames]


def _add_count(state, payload, t):
    assert not state or state[-1][0] == t - 1  # in frame order
    state.append((t, payload))


def _toy_figures(movie, folder, source=None):
    from matplotlib.figure import Figure

    from hexatissue.plot import save_figure

    fig = Figure()
    fig.add_subplot().plot(movie.toy_summary["frame"], movie.toy_summary["mean_toy_area"])
    path = folder / "toy.png"
    save_figure(fig, path)
    return [path]


def _toy_section(movie, report):
    if "toy_summary" not in movie.tables:
        return []
    mean = float(movie.toy_summary["mean_toy_area"].mean())
    report.numbers["toy"] = mean
    report.table(movie.toy_summary, "toy_summary.csv")
    return ["## Toy stage", "", f"- mean toy area: {mean:.6g} px^2", ""] + report.figure(
        _toy_figures(movie, report.out)[0], "toy area")


def _toy_layers(movie, p):
    cells = movie.cells
    return [(cells[["frame", "y", "x"]].to_numpy(float), {"name": "toy cells", "features": cells[["toy_area"]]},
             "points")]


#: The toy stage's presentation, found through its entry's ``views`` (this module's name).
VIEW = StageView(figures=_toy_figures, report=(Section(95, _toy_section),), layers=(LayerMaker(55, _toy_layers),),
                 legend=lambda movie, p: [("toy cell", "disc", "#00ff00")], widget=(WidgetField("factor"),))


@pytest.fixture
def toy_stage(monkeypatch):
    """Registers a toy options class, its schema entries and two list entries; undone afterwards."""
    @dataclass(frozen=True)
    class ToyOptions(_Options, stage="toy", title="toy stage"):
        factor: float = cli_field(2.0, "--toy-factor", "factor of the toy area")

    ToyOptions.__qualname__ = "ToyOptions"  # workers unpickle it as this module's global
    monkeypatch.setitem(globals(), "ToyOptions", ToyOptions)
    try:
        monkeypatch.setitem(schema.TABLES["cells"], "toy_area", ("f", "px^2", "toy: area x factor"))
        monkeypatch.setattr(schema, "_OPTIONAL", schema._OPTIONAL | {"toy_area"})  # a column a stage adds
        monkeypatch.setitem(schema.TABLES, "toy_summary", {"frame": ("i", "frame", "time point"),
                                                           "mean_toy_area": ("f", "px^2", "mean toy area"),
                                                           "n_counted": ("i", "", "cells its frame state counted")})
        frame_entry = S.Stage("toy area", ToyOptions, "frame", reads=("cells",), writes=("cells.toy_area",),
                              run=_elongation)
        movie_entry = S.Stage("toy summary", ToyOptions, "movie", reads=("cells.toy_area",),
                              writes=("toy_summary",), run=_area_summary, views=__name__,
                              state=S.FrameState(new=_new_count, prepare=_count_cells, add=_add_count,
                                                 params=lambda state, source: 1))
        stages = list(S.STAGES)
        stages.insert(1, frame_entry)
        stages.append(movie_entry)
        monkeypatch.setattr(S, "STAGES", tuple(stages))
        yield ToyOptions
    finally:
        OPTION_CLASSES.pop("toy", None)


def test_a_new_frame_stage_and_movie_stage_run_save_and_read_back(toy_stage, tmp_path):
    movie_frames = voronoi_movie(30, (64, 64), 3, periodic=False, amplitude=0.3, seed=1)
    labels = np.stack([np.asarray(movie_frames[t]) for t in range(3)])
    movie = analyze(labels, toy=toy_stage(factor=3.0), workers=1, progress=False)
    np.testing.assert_array_equal(movie.cells["toy_area"], 3.0 * movie.cells["area"])
    assert list(movie.toy_summary["frame"]) == [0, 1, 2]
    assert movie.options["toy"] == toy_stage(factor=3.0)
    movie.write(tmp_path / "out")
    back = read_results(tmp_path / "out")
    pd.testing.assert_frame_equal(back.tables["toy_summary"], movie.toy_summary)
    assert back.options["toy"] == toy_stage(factor=3.0)
    # the workers of a process pool run it too, with the same tables
    pooled = analyze(labels, toy=toy_stage(factor=3.0), workers=2, progress=False)
    for name, table in movie.tables.items():
        pd.testing.assert_frame_equal(pooled.tables[name], table, obj=name)


def test_a_new_stage_gets_its_flag_and_its_checkpoint_key(toy_stage, tmp_path):
    from hexatissue.cli import build_parser, stage_options

    args = build_parser().parse_args(["analyze", "x.tif", "--out", "o", "--toy-factor", "5"])
    assert stage_options(args)["toy"] == toy_stage(factor=5.0)
    movie_frames = voronoi_movie(30, (64, 64), 2, periodic=False, amplitude=0.3, seed=1)
    labels = np.stack([np.asarray(movie_frames[t]) for t in range(2)])
    analyze(labels, toy=toy_stage(factor=5.0), workers=1, progress=False, checkpoint=tmp_path / "ck")
    with pytest.raises(InputError, match="holds another movie or other options"):
        analyze(labels, toy=toy_stage(factor=6.0), workers=1, progress=False, checkpoint=tmp_path / "ck")


def test_a_new_stage_follows_the_frames_and_resumes_from_a_checkpoint(toy_stage, tmp_path):
    """The toy stage's frame state counts each frame's cells in the worker and adds them in frame order, in one
    process and in a pool, and is saved in the checkpoints: a resumed run ends with the same state."""
    from tests.test_pipeline import _FailingStack

    movie_frames = voronoi_movie(30, (64, 64), 5, periodic=False, amplitude=0.3, seed=1)
    labels = np.stack([np.asarray(movie_frames[t]) for t in range(5)])
    full = analyze(labels, toy=toy_stage(), workers=1, progress=False)
    expected = full.cells.groupby("frame").size().to_numpy()
    np.testing.assert_array_equal(full.toy_summary["n_counted"], expected)
    pooled = analyze(labels, toy=toy_stage(), workers=2, progress=False)
    pd.testing.assert_frame_equal(pooled.toy_summary, full.toy_summary)
    with pytest.raises(InputError, match="simulated crash"):
        analyze(_FailingStack(labels, 3), toy=toy_stage(), workers=1, progress=False, checkpoint=tmp_path,
                checkpoint_every=2)
    state = (tmp_path / "checkpoint.json").read_text()
    assert '"toy": "toy_state_00000002.pkl"' in state and '"track": "track_state_00000002.pkl"' in state
    resumed = analyze(_FailingStack(labels, 1), toy=toy_stage(), workers=1, progress=False, checkpoint=tmp_path,
                      checkpoint_every=2)  # frames 0-1 come from the checkpoint, with the counts of the state
    pd.testing.assert_frame_equal(resumed.toy_summary, full.toy_summary)


def test_a_new_stage_brings_its_figure_report_section_napari_layer_and_widget_field(toy_stage, tmp_path):
    """The report, analyze --figures, the napari layers and legend, and the widget's fields take the toy stage's
    views from its entry alone, in the place its ranks give."""
    from hexatissue.napari.layers import legend_entries, movie_layers
    from hexatissue.views import widget_fields
    from hexatissue.workflows import report, save_movie_figures

    movie_frames = voronoi_movie(30, (64, 64), 3, periodic=False, amplitude=0.3, seed=1)
    labels = np.stack([np.asarray(movie_frames[t]) for t in range(3)])
    analyze(labels, toy=toy_stage(factor=3.0), workers=1, progress=False).write(tmp_path / "out")
    movie = read_results(tmp_path / "out")
    numbers = report(tmp_path / "out")
    text = (tmp_path / "out" / "report" / "report.md").read_text()
    assert "## Toy stage" in text and "![toy area](toy.png)" in text
    assert text.index("## Tissue flow") < text.index("## Toy stage")  # rank 95: after the flow (60)
    assert numbers["toy"] == pytest.approx(3.0 * movie.cells.groupby("frame")["area"].mean().mean())
    assert {"toy.png", "toy_summary.csv"} <= {p.rsplit("/", 1)[-1] for p in numbers["written"]}
    figures = save_movie_figures(movie, tmp_path / "figures")
    assert tmp_path / "figures" / "toy.png" in figures and (tmp_path / "figures" / "toy.png").stat().st_size
    names = [kw["name"] for _, kw, _ in movie_layers(movie)]
    assert names.index("T1 events") < names.index("toy cells") < names.index("tracks")  # rank 55: between
    data, kw, kind = movie_layers(movie)[names.index("toy cells")]
    assert kind == "points" and len(data) == len(movie.cells)
    assert list(legend_entries(movie)["label"])[-1] == "toy cell"
    assert (toy_stage, WidgetField("factor")) in widget_fields()


# ----------------------------------------------------------------------------
# A movie stage's chunks on the analysis's executor (MovieData.map_chunks)
# ----------------------------------------------------------------------------

def _chunk_movie(folder, workers=None, client=None, make=None):
    """A MovieData whose tables are on disk (``folder``), with the spine's executor of ``workers`` or ``client``."""
    from functools import partial

    from hexatissue._executors import executor

    return S.MovieData(tables={}, box=None, n_frames=12, source=None, states={}, options={}, folder=folder,
                       executor=make or partial(executor, client, workers))


def _square_chunk(span, scale):
    """A chunk task: the chunk's frames times ``scale``, with the process it ran in."""
    import os

    return [t * scale for t in range(span[0], span[1] + 1)], os.getpid()


def _slow_first_chunk(span, scale):
    """Later chunks finish first: the results must still come in chunk order."""
    import time

    time.sleep(0.2 if span[0] == 2 else 0.0)
    return _square_chunk(span, scale)[0]


def _failing_chunk(span):
    if span[0] == 4:
        raise InputError(f"frames {span[0]}-{span[1]}: no cells")
    return span


def _warning_chunk(span):
    import warnings

    from hexatissue.errors import HexatissueWarning

    warnings.warn(f"chunk {span[0]}", HexatissueWarning)
    return span


SPANS = [(0, 1), (2, 3), (4, 5), (6, 7), (8, 9), (10, 11)]


def test_chunks_on_a_process_pool_come_back_in_order_from_the_workers(tmp_path):
    import os

    got = list(_chunk_movie(tmp_path, workers=2).map_chunks(_square_chunk, SPANS, 3))
    assert [values for values, _ in got] == [[3 * t for t in range(a, b + 1)] for a, b in SPANS]
    pids = [pid for _, pid in got]
    # the first chunk runs here (the pool forks after it), the others in the pool's workers
    assert pids[0] == os.getpid() and os.getpid() not in pids[1:] and len(set(pids[1:])) <= 2
    assert list(_chunk_movie(tmp_path, workers=2).map_chunks(_slow_first_chunk, SPANS, 1)) == [
        list(range(a, b + 1)) for a, b in SPANS]
    # tables in memory (no folder), one worker or no executor: every chunk here
    for movie in (_chunk_movie(None, workers=2), _chunk_movie(tmp_path, workers=1),
                  replace(_chunk_movie(tmp_path), executor=None)):
        assert {pid for _, pid in movie.map_chunks(_square_chunk, SPANS, 1)} == {os.getpid()}


def test_chunks_in_flight_are_bounded_by_the_executor(tmp_path):
    submitted = []

    class Counting:
        def submit(self, fn, *args):
            submitted.append(args[1])
            done = fn(*args)
            return type("Done", (), {"result": lambda self: done})()

        def shutdown(self, abort=False):
            submitted.append("abort" if abort else "end")

    # an executor of two workers keeps four tasks in flight for the frames; a chunk's working set is large, so
    # one chunk per worker: the chunk taken and at most one more
    results = _chunk_movie(tmp_path, make=lambda n, warm_ups: (Counting(), 4)).map_chunks(_square_chunk, SPANS, 1)
    for k, _ in enumerate(results):
        assert len(submitted) <= k + 2
    assert submitted == [*SPANS, "end"]
    # three workers (six tasks in flight for the frames): three chunks sent before the first is taken
    results = _chunk_movie(tmp_path, make=lambda n, warm_ups: (Counting(), 6)).map_chunks(_square_chunk, SPANS, 1)
    submitted.clear()
    next(results)
    results.close()  # the caller stops early: the executor is stopped, no further chunk is sent
    assert submitted == [(0, 1), (2, 3), (4, 5), "abort"]


@pytest.mark.parametrize("workers", [1, 2])
def test_an_error_in_a_chunk_task_is_the_error_raised_in_process(tmp_path, workers):
    with pytest.raises(InputError, match=r"^frames 4-5: no cells$"):
        list(_chunk_movie(tmp_path, workers=workers).map_chunks(_failing_chunk, SPANS))


def test_a_chunk_tasks_warnings_are_issued_in_chunk_order(tmp_path):
    from hexatissue.errors import HexatissueWarning

    with pytest.warns(HexatissueWarning) as caught:
        assert list(_chunk_movie(tmp_path, workers=2).map_chunks(_warning_chunk, SPANS)) == SPANS
    assert [str(w.message) for w in caught] == [f"chunk {a}" for a, _ in SPANS]


def _killing_chunk(span, marks):
    """A chunk task whose worker dies (SIGKILL, as the OOM killer does) the first time it runs chunk (4, 5)."""
    import os
    import signal

    from pathlib import Path

    Path(marks, f"{span[0]}-{os.getpid()}").touch()  # every run of every chunk, by process
    if span[0] == 4 and not Path(marks, "killed").exists():
        Path(marks, "killed").write_text(str(os.getpid()))
        os.kill(os.getpid(), signal.SIGKILL)
    return span


def test_a_lost_pool_worker_stops_the_chunks_as_it_stops_the_frames(tmp_path):
    import multiprocessing as mp
    import time
    from concurrent.futures.process import BrokenProcessPool

    with pytest.raises(BrokenProcessPool):  # as a frame batch's lost worker does: the run stops, its pool killed
        list(_chunk_movie(tmp_path, workers=2).map_chunks(_killing_chunk, SPANS, tmp_path))
    assert (tmp_path / "killed").exists()
    deadline = time.monotonic() + 2.0  # the killed workers are reaped as they are found dead
    while mp.active_children() and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not mp.active_children()


def _sleeping_chunk(span):
    import time

    if span[0]:  # the first chunk runs here, before the pool forks; the others wait in the workers
        time.sleep(60)
    return span


def test_an_interrupt_stops_the_chunks_and_their_workers_at_once(tmp_path):
    import multiprocessing as mp
    import signal
    import threading
    import time

    main = threading.main_thread().ident
    timer = threading.Timer(1.0, lambda: signal.pthread_kill(main, signal.SIGINT))  # Ctrl-C, as the terminal sends it
    start = time.monotonic()
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        list(_chunk_movie(tmp_path, workers=2).map_chunks(_sleeping_chunk, SPANS))
    while mp.active_children() and time.monotonic() < start + 3.0:
        time.sleep(0.05)
    assert not mp.active_children() and time.monotonic() - start < 3.0


@pytest.mark.slow
def test_a_lost_dask_worker_costs_its_chunks_alone(tmp_path):
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
            Client(cluster) as client:
        got = list(_chunk_movie(tmp_path, client=client).map_chunks(_killing_chunk, SPANS, tmp_path))
    assert got == SPANS
    killed = (tmp_path / "killed").read_text()
    runs = {a: sorted(p.name.split("-")[1] for p in tmp_path.glob(f"{a}-*")) for a, _ in SPANS}
    # the scheduler ran the lost worker's chunks again elsewhere (the one it was running, and those whose results it
    # held, not yet taken); every other chunk ran once
    assert len(runs[4]) == 2 and killed in runs[4]
    assert all(len(pids) == 1 or (len(pids) == 2 and killed in pids) for pids in runs.values())
