"""The fast paths of the frame job give the tables of the plain paths, exactly.

The frame job (the frame stages of ``hexatissue.stages`` as a worker runs
them, :func:`hexatissue.stages.run_frame`) returns the network tables as numpy
columns and takes gamma_p from the polygons the mesh built; the plain path
is ``mesh_from_labels`` then ``shape_order`` (polygons read from the tables'
rows in the mesh's order, ``Frame.mesh_polygons``), and a network made of
the same tables again (``Frame(**tables)``) has its polygons rebuilt through
the tables' keys.  All run the same kernels, so the tables must be equal bit
for bit.  The kernels themselves are checked against their plain-Python
references in ``test_mesh_kernels.py``; here the whole network built with
the references equals the one built with the kernels.
"""
import pickle
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from hexatissue import Box, Frame, OrderOptions, mesh_from_labels, open_source, shape_order
from hexatissue.geometry import table_polygons
from hexatissue.mesh import _reference as R
from hexatissue.mesh import network as N
from hexatissue.options import MeshOptions
from hexatissue.stages import FrameData, frame_stages, run_frame, stage_options, worker_stages
from hexatissue.synthetic import voronoi_movie

SAMPLE = Path(__file__).resolve().parents[1] / "hexatissue" / "sample_data" / "epicure_notum" / "013_crop_labels.tif"
TABLES = ("cells", "vertices", "edges", "cell_vertices")


def _frame_job(labels, t, box, mesh, order, ids=(None, None), image=None):
    """``(tables, labels, warnings)`` of one frame, as a worker of ``analyze`` computes them."""
    options = stage_options({"mesh": mesh, "order": order, "intensity": image})
    frame = FrameData(t=t, box=box, labels=labels, raw_ids=ids, images={} if image is None else {"intensity": image})
    found = run_frame(frame, worker_stages(frame_stages(options), options))
    return frame.tables, frame.labels, found


def sample_labels():
    return np.asarray(open_source(SAMPLE).frame(0))


def movie_frames(n=4):
    movie = voronoi_movie(60, (96, 104), n, periodic=True, amplitude=0.3, seed=4)
    return [np.asarray(movie[t]).astype(np.uint16) for t in range(n)], Box(104.0, 96.0)


def plain_tables(labels, box, t, p):
    frame = shape_order(mesh_from_labels(labels, box=box, frame=t), p=p)
    return {name: getattr(frame, name) for name in TABLES}


@pytest.mark.filterwarnings("ignore::hexatissue.errors.HexatissueWarning")
@pytest.mark.parametrize("p", [(6, 2), (6,), (2, 3, 4)])
def test_frame_job_equals_mesh_then_shape_order(p):
    """Bundled sample (open image) and a periodic synthetic movie: every table identical."""
    frames, box = movie_frames()
    cases = [(sample_labels(), None, 0)] + [(f, box, t) for t, f in enumerate(frames)]
    for labels, b, t in cases:
        tables, _, _ = _frame_job(labels, t, b, MeshOptions(), OrderOptions(p=p, fields=False))
        expected = plain_tables(labels, b, t, p)
        for name in TABLES:
            assert isinstance(tables[name], dict)  # numpy columns, read without pandas in the main process
            pd.testing.assert_frame_equal(pd.DataFrame(tables[name]), expected[name], check_exact=True,
                                          obj=f"{name}, frame {t}")


@pytest.mark.filterwarnings("ignore::hexatissue.errors.HexatissueWarning")
def test_frame_job_given_the_ids_the_source_found_equals_the_job_without():
    """The smallest and largest id that checking the frame found (Source.checked_frame), passed to the job: the
    same tables (a membrane sample, whose labels change, and touching uint16 movie frames, whose labels do not)."""
    source = open_source(SAMPLE)
    labels, lowest, top = source.checked_frame(0)
    np.testing.assert_array_equal(labels, source.frame(0))
    assert (lowest, top) == (labels.min(), labels.max())
    frames, box = movie_frames(2)
    for labels, b, ids in [(labels, None, (lowest, top))] + [(f, box, (f.min(), f.max())) for f in frames]:
        options = (MeshOptions(), OrderOptions(fields=False))
        given, _, _ = _frame_job(labels, 0, b, *options, ids=(int(ids[0]), int(ids[1])))
        found, _, _ = _frame_job(labels, 0, b, *options)
        for name in TABLES:
            pd.testing.assert_frame_equal(pd.DataFrame(given[name]), pd.DataFrame(found[name]), check_exact=True)


def network_cases():
    frames, box = movie_frames(2)
    return [(sample_labels(), None), (frames[0], box), (frames[1], None)]


@pytest.mark.filterwarnings("ignore::hexatissue.errors.HexatissueWarning")
@pytest.mark.parametrize("case", range(3))
def test_mesh_polygons_equal_the_polygons_rebuilt_through_the_keys(case):
    """A Frame fresh from the mesh reads its polygons row by row: the same numbers as the keys' rebuild."""
    labels, box = network_cases()[case]
    frame = mesh_from_labels(labels, box=box)
    xy, starts = frame.mesh_polygons()
    keys, xy_keys, starts_keys = table_polygons(frame.vertices, frame.cell_vertices, box)
    np.testing.assert_array_equal(xy, xy_keys)
    np.testing.assert_array_equal(starts, starts_keys)
    np.testing.assert_array_equal(keys["cell"], frame.cells["cell"][frame.cells["n_sides"] > 0])
    rebuilt = Frame(**frame.tables, box=box, shape=frame.shape)  # as if read from files: no row order known
    assert rebuilt.mesh_polygons() is None
    pd.testing.assert_frame_equal(shape_order(frame).cells, shape_order(rebuilt).cells, check_exact=True)


@pytest.mark.filterwarnings("ignore::hexatissue.errors.HexatissueWarning")
def test_mesh_polygons_are_forgotten_once_the_tables_change():
    """Replaced or reassigned tables, or n_sides edited in place, are read through the keys again."""
    labels, box = network_cases()[1]
    frame = mesh_from_labels(labels, box=box)
    assert frame.mesh_polygons() is not None
    assert frame.replace(frame=0).mesh_polygons() is None  # a new Frame: its tables are not known to be the mesh's
    shuffled = frame.cells.sample(frac=1.0, random_state=0)
    moved = mesh_from_labels(labels, box=box)
    moved.cells = shuffled
    assert moved.mesh_polygons() is None
    expected = shape_order(frame).cells.set_index("cell")
    pd.testing.assert_frame_equal(shape_order(moved).cells.set_index("cell").loc[expected.index], expected,
                                  check_exact=True)
    edited = mesh_from_labels(labels, box=box)
    edited.cells.loc[0, "n_sides"] += 1  # in place: the same table object
    assert edited.mesh_polygons() is None  # the n_sides no longer add up to the rows
    sent = pickle.loads(pickle.dumps(frame))  # to a worker and back: its tables are still the ones built
    np.testing.assert_array_equal(sent.mesh_polygons()[0], frame.mesh_polygons()[0])
    del sent.__dict__["_mesh_tables"]  # as a Frame pickled before Frames kept their tables
    assert sent.mesh_polygons() is None


@pytest.mark.filterwarnings("ignore::hexatissue.errors.HexatissueWarning")
def test_frame_job_with_an_intensity_image_equals_the_plain_path():
    """With an intensity image the cells table gains its columns first, then gamma_p, as before."""
    from hexatissue.intensity import measure_intensity

    labels = sample_labels()
    image = np.random.default_rng(0).random(labels.shape)
    tables, lab, _ = _frame_job(labels, 0, None, MeshOptions(), OrderOptions(fields=False), image=image)
    frame = mesh_from_labels(labels)
    cells, edges = measure_intensity(frame.cells, frame.vertices, frame.edges, lab, image, None)
    expected = shape_order(frame.replace(cells=cells), p=OrderOptions().p).cells
    pd.testing.assert_frame_equal(pd.DataFrame(tables["cells"]), expected, check_exact=True)
    pd.testing.assert_frame_equal(pd.DataFrame(tables["edges"]), edges, check_exact=True)


def _numpy_columns_only(frame):
    """Every table of ``frame`` is a dict of 1-d numpy columns of one length, and ``frame.table`` a DataFrame over
    them (no copy)."""
    assert frame.tables
    for name, columns in frame.tables.items():
        assert isinstance(columns, dict), name
        assert all(isinstance(v, np.ndarray) and v.ndim == 1 for v in columns.values()), name
        assert len({len(v) for v in columns.values()}) == 1, name
        table = frame.table(name)
        assert list(table.columns) == list(columns) and len(table) == len(next(iter(columns.values()))), name
        assert all(np.shares_memory(table[c].to_numpy(), v) for c, v in columns.items()), name


@pytest.mark.filterwarnings("ignore::hexatissue.errors.HexatissueWarning")
def test_every_frame_stage_leaves_the_frame_tables_as_numpy_columns():
    """Labels through every frame stage (mesh, intensity, shape order, surface, order fields, mechanics) and cell
    polygons through theirs: no frame table is a DataFrame, and a stored DataFrame comes back equal."""
    from hexatissue import MechanicsOptions
    from hexatissue.mesh.polygons import as_polygons

    labels = np.asarray(voronoi_movie(40, (80, 80), 1, periodic=False, amplitude=0.3, seed=1)[0])
    image = np.random.default_rng(0).random(labels.shape)
    options = stage_options({"intensity": image, "surface": image, "mechanics": MechanicsOptions(enabled=True)})
    stages = frame_stages(options)
    assert [s.name for s in stages] == ["junction network", "intensity", "shape order", "surface", "order fields",
                                        "mechanics"]
    frame = FrameData(t=0, labels=labels, images={"intensity": image, "surface": image})
    run_frame(frame, worker_stages(stages, options))
    assert set(frame.tables) == {*TABLES, "grid", "defects", "stress", "force_fit"}
    _numpy_columns_only(frame)
    options = stage_options({})
    polygons = FrameData(t=0, cell_polygons=as_polygons(mesh_from_labels(labels).polygons()))
    run_frame(polygons, worker_stages(frame_stages(options), options))
    assert set(polygons.tables) == {*TABLES, "grid", "defects"}
    _numpy_columns_only(polygons)
    grid = frame.table("grid")
    polygons.set_table("grid", grid)
    assert isinstance(polygons.tables["grid"], dict)
    pd.testing.assert_frame_equal(polygons.table("grid"), grid, check_exact=True)


def reference_kernels():
    """network's kernel module with every kernel replaced by its plain-Python reference."""
    names = ("corner_types", "trace_junctions", "mark_junctions", "trace_loops", "cell_moments", "merge_clusters",
             "polygons", "cell_vertex_rows", "components")  # the references of the kernels these call (chaining, ...) in turn
    return SimpleNamespace(**{name: getattr(R, name) for name in names})


@pytest.mark.filterwarnings("ignore::hexatissue.errors.HexatissueWarning")
def test_network_from_reference_kernels_equals_network_from_kernels(monkeypatch):
    """A crop of the sample and a periodic frame: the tables from the references equal the kernels' tables.

    The references fit the arm lines by an eigen-decomposition, not the
    kernels' closed form, so positions agree to rounding (1e-12 px), not bit
    for bit; every integer column is equal.
    """
    frames, box = movie_frames(1)
    cases = [(sample_labels()[:60, :90], None), (frames[0], box)]
    fast = [plain_tables(labels, b, 0, (6, 2)) for labels, b in cases]
    monkeypatch.setattr(N, "K", reference_kernels())
    for (labels, b), expected in zip(cases, fast):
        slow = plain_tables(labels, b, 0, (6, 2))
        for name in TABLES:
            pd.testing.assert_frame_equal(slow[name], expected[name], check_exact=False, rtol=1e-12, atol=1e-12,
                                          obj=name)


@pytest.mark.filterwarnings("ignore::hexatissue.errors.HexatissueWarning")
def test_movie_rows_from_columns_equal_concatenated_tables():
    """Rows fed the frame job's columns gives pd.concat of the plain per-frame tables (and checks the schema)."""
    from hexatissue._rows import Rows

    frames, box = movie_frames()
    rows = {name: Rows(len(frames)) for name in TABLES}
    for t, labels in enumerate(frames):
        tables, _, _ = _frame_job(labels, t, box, MeshOptions(), OrderOptions(fields=False))
        for name in TABLES:
            rows[name].append(tables[name])
    for name in TABLES:
        expected = pd.concat([plain_tables(f, box, t, OrderOptions().p)[name] for t, f in enumerate(frames)],
                             ignore_index=True)
        pd.testing.assert_frame_equal(rows[name].table(name), expected, check_exact=True)
