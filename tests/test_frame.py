"""Frame and Movie containers: a results folder is a saved Movie, read back table for table."""
import json

import numpy as np
import pandas as pd
import pytest

from hexatissue import (Box, Calibration, DeformationOptions, EventOptions, InputError, MechanicsOptions, Movie,
                        OrderOptions, analyze, mesh_from_labels, read_results)
from hexatissue.io import read_units
from hexatissue.schema import TABLES, column_units
from hexatissue.synthetic import draw_membranes, jittered_seeds, voronoi_labels, voronoi_movie


@pytest.fixture(scope="module")
def movie():
    stack = voronoi_movie(30, (70, 90), 5, periodic=True, amplitude=0.5, seed=3)
    source = np.stack([stack[t] for t in range(5)])
    # every stage on, so that every table of the schema is written and read back
    return analyze(source, box=True, events=EventOptions(censor=2), deformation=DeformationOptions(enabled=True),
                   mechanics=MechanicsOptions(enabled=True, sd=False), workers=1,
                   progress=False).replace(calibration=Calibration(0.5, "um", 2.0, "min"))


@pytest.mark.parametrize("fmt", ["parquet", "csv"])
def test_write_and_read_results_round_trip_every_table(movie, tmp_path, fmt):
    written = movie.write(tmp_path, formats=(fmt,))
    assert written[-1].name == "metadata.json"
    back = read_results(tmp_path)
    assert set(back.tables) == set(movie.tables) == set(TABLES)
    for name, table in movie.tables.items():
        pd.testing.assert_frame_equal(back.tables[name], table, check_dtype=(fmt == "parquet"), obj=name)
    assert back.metadata() == movie.metadata()
    assert back.box == Box(90, 70) and back.shape == (70, 90) and len(back) == 5
    assert back.calibration == Calibration(0.5, "um", 2.0, "min")
    assert back.options["events"] == EventOptions(censor=2) and back.options["track"].mode == "never"
    assert back.summary == movie.summary and back.summary["tracking"]["rows_track_not_cell"] == 0


def test_metadata_json_records_box_units_options_and_source(movie, tmp_path):
    movie.write(tmp_path)
    meta = json.loads((tmp_path / "metadata.json").read_text())
    assert meta["box"] == [90.0, 70.0] and meta["shape"] == [70, 90] and meta["n_frames"] == 5
    assert meta["calibration"] == {"pixel_size": 0.5, "length_unit": "um", "frame_interval": 2.0, "time_unit": "min",
                                   "length_from": "given", "time_from": "given"}
    assert meta["options"]["order"]["p"] == [6, 2]
    assert meta["source"]["kind"] == "array"
    assert meta["tables"]["cells"] == len(movie.cells)


def test_every_table_has_a_frame_column_even_for_one_image():
    labels = voronoi_labels(jittered_seeds((60, 80), 14, seed=1), (60, 80))
    frame = mesh_from_labels(labels, frame=3)
    for table in frame.tables.values():
        assert (table["frame"] == 3).all()
    single = analyze(labels, workers=1, progress=False)
    assert len(single) == 1
    for name in ("cells", "vertices", "edges", "cell_vertices", "grid", "defects"):
        assert (single.tables[name]["frame"] == 0).all(), name
    assert single.events.empty and (single.lineage["begin"] == "movie_start").all()


def test_movie_frame_and_polygons(movie):
    f = movie.frame(2)
    assert (f.cells["frame"] == 2).all() and f.box == movie.box and f.calibration == movie.calibration
    polys = movie.polygons(2)
    cells = f.cells.set_index("cell")
    assert set(polys) == set(cells.index)
    assert all(len(polys[c]) == cells.loc[c, "n_sides"] for c in polys)
    with pytest.raises(InputError, match="frame 9 is not in this movie"):
        movie.frame(9)


def test_from_frames_concatenates_frames():
    labels = voronoi_labels(jittered_seeds((60, 80), 14, seed=2), (60, 80))
    frames = [mesh_from_labels(labels, frame=t) for t in range(3)]
    m = Movie.from_frames(frames)
    assert len(m) == 3 and m.cells["frame"].tolist() == sorted(m.cells["frame"].tolist())
    pd.testing.assert_frame_equal(m.frame(1).cells, frames[1].cells)


def test_read_results_errors(tmp_path):
    with pytest.raises(InputError, match="does not exist"):
        read_results(tmp_path / "nope")
    with pytest.raises(InputError, match="no metadata.json"):
        read_results(tmp_path)
    (tmp_path / "metadata.json").write_text("{}")
    with pytest.raises(InputError, match="missing table"):
        read_results(tmp_path)
    with pytest.raises(InputError, match="formats"):
        Movie(*(pd.DataFrame({"frame": []}) for _ in range(4))).write(tmp_path, formats=("xlsx",))


def test_membrane_and_skeleton_movies_are_tracked_on_the_mesh_labels():
    """The tracker sees the labels the mesh used: skeletons (regions renumbered every frame) and membranes."""
    stack = voronoi_movie(25, (70, 90), 4, periodic=False, amplitude=0.4, seed=5)
    touching = np.stack([stack[t] for t in range(4)])
    membranes = np.stack([draw_membranes(f, width=1) for f in touching])
    skeleton = (membranes == 0).astype(np.uint8) * 255
    ref = analyze(touching, workers=1, progress=False, order=OrderOptions(fields=False))
    for labels in (membranes, skeleton):
        got = analyze(labels, workers=1, progress=False, order=OrderOptions(fields=False))
        # one track per true cell: every track keeps one true label over its frames
        true = [touching[int(f)][int(round(y)), int(round(x))] for f, x, y in got.cells[["frame", "x", "y"]].to_numpy()]
        pairs = set(zip(got.cells["track"], true))
        assert len(pairs) == got.cells["track"].nunique() == ref.cells["track"].nunique()


def test_write_results_releasing_tables_writes_the_same_files(movie, tmp_path):
    """``write_results(release=True)`` (the CLI's writer) writes the files of Movie.write and drops each table."""
    from hexatissue.results import write_results

    kept = movie.write(tmp_path / "kept")
    copy = movie.replace()
    released = write_results(copy, tmp_path / "released", release=True)
    assert sorted(p.name for p in released) == sorted(p.name for p in kept) and released[-1].name == "metadata.json"
    for path in kept:
        assert (tmp_path / "released" / path.name).read_bytes() == path.read_bytes(), path.name
    assert copy.tables == {} and set(movie.tables) == set(TABLES)  # the original keeps its tables


def test_the_movie_holds_its_tables_by_name_each_also_an_attribute(movie):
    assert movie.tables["cells"] is movie.cells and list(movie.tables) == [n for n in TABLES if n in movie.tables]
    copy = movie.replace(grid=None, events=None)
    assert copy.grid is None and "grid" not in copy.tables and "events" not in copy.tables
    assert movie.grid is not None  # replace makes a copy
    copy.grid = movie.grid  # set back: in the schema's order again
    assert list(copy.tables) == [n for n in TABLES if n in copy.tables]
    with pytest.raises(AttributeError, match="no attribute 'gird'"):
        movie.gird
    with pytest.raises(InputError, match="'flows' has none"):
        movie.replace(flows=movie.cells)
    with pytest.raises(InputError, match="must be a pandas DataFrame"):
        movie.replace(grid=[1, 2])
    with pytest.warns(DeprecationWarning, match=r"\.tables\(\) is deprecated"):
        assert movie.tables() == dict(movie.tables)  # the call of hexatissue 0.1, for one release


def test_a_table_computed_outside_analyze_is_saved_once_it_has_a_schema(movie, tmp_path, monkeypatch):
    """A results folder holds any table with a schema: written, listed in metadata.json, read back."""
    speeds = pd.DataFrame({"frame": np.arange(5, dtype=np.int64), "mean_speed": np.linspace(0.0, 1.0, 5)})
    with pytest.raises(InputError, match="'speeds' has none"):
        movie.replace(speeds=speeds)
    monkeypatch.setitem(TABLES, "speeds", {"frame": ("i", "frame", "time point"),
                                           "mean_speed": ("f", "px/frame", "mean cell speed")})
    with_speeds = movie.replace(speeds=speeds)
    with_speeds.write(tmp_path)
    assert json.loads((tmp_path / "metadata.json").read_text())["tables"]["speeds"] == 5
    pd.testing.assert_frame_equal(read_results(tmp_path).speeds, speeds)
    monkeypatch.delitem(TABLES, "speeds")
    movie.write(tmp_path)  # rewritten without it, and without its schema: the previous result's table goes
    assert not (tmp_path / "speeds.parquet").exists()


def test_parquet_columns_carry_their_unit_and_meaning_and_read_results_checks_them(movie, tmp_path):
    import pyarrow as pa
    import pyarrow.parquet as pq

    movie.write(tmp_path)
    area = pq.read_schema(tmp_path / "cells.parquet").field("area").metadata
    assert area == {b"unit": b"px^2", b"description": TABLES["cells"]["area"][2].encode()}
    gamma = pq.read_schema(tmp_path / "cells.parquet").field("gamma6_re").metadata  # a {p} column
    assert gamma[b"description"] == TABLES["cells"]["gamma{p}_re"][2].encode()
    for name, table in movie.tables.items():  # every schema column of every table, nothing else
        fields = pq.read_schema(tmp_path / f"{name}.parquet")
        for column in table.columns:
            meta = fields.field(column).metadata
            spec = column_units(name, [column]).get(column)
            assert (meta is not None and b"unit" in meta) == (spec is not None), (name, column)
            if spec is not None:
                assert (meta[b"unit"].decode(), meta[b"description"].decode()) == spec
    assert read_units(tmp_path / "edges.parquet")["length"][0] == "px"
    # another tool rewrote cells.parquet in micrometres: read_results refuses it, naming the column and units
    table = pq.read_table(tmp_path / "cells.parquet")
    fields = [f.with_metadata({b"unit": b"um^2", b"description": b"area"}) if f.name == "area" else f
              for f in table.schema]
    pq.write_table(pa.Table.from_arrays(table.columns, schema=pa.schema(fields, metadata=table.schema.metadata)),
                   tmp_path / "cells.parquet")
    with pytest.raises(InputError, match=r"cells.parquet: column 'area' is in 'um\^2' in the file; expected 'px\^2'"):
        read_results(tmp_path)
