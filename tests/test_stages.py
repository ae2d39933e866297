"""The list of stages: what it declares is true, and a new stage plugs in with its entry alone.

A new frame stage and a new movie stage are added here the way a contributor
adds one (an options class, schema entries, one entry in ``STAGES``), and
``analyze``, the results folder, the checkpoints and the command line take
them up with no other change.
"""
from dataclasses import dataclass, replace

import numpy as np
import pandas as pd
import pytest

from hexatissue import InputError, analyze, read_results, schema
from hexatissue import stages as S
from hexatissue.options import OPTION_CLASSES, _Options, cli_field
from hexatissue.synthetic import voronoi_movie

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
            if table in ("labels", "polygons"):  # what the mesh hands the later frame stages
                assert stage.per == "frame"
                continue
            assert table in schema.TABLES, (stage.name, name)
            assert not column or _column_in_schema(table, column), (stage.name, name)


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
    analyze(labels, intensity=image, mechanics=MechanicsOptions(enabled=True),
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
    """Toy movie stage: a new table, the mean toy area per frame."""
    cells = movie.tables["cells"]
    mean = cells.groupby("frame")["toy_area"].mean()
    movie.tables["toy_summary"] = pd.DataFrame({"frame": mean.index.to_numpy(np.int64),
                                                "mean_toy_area": mean.to_numpy(float)})


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
                                                           "mean_toy_area": ("f", "px^2", "mean toy area")})
        frame_entry = S.Stage("toy area", ToyOptions, "frame", reads=("cells",), writes=("cells.toy_area",),
                              run=_elongation)
        movie_entry = S.Stage("toy summary", ToyOptions, "movie", reads=("cells.toy_area",),
                              writes=("toy_summary",), run=_area_summary)
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
