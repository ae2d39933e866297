"""The first run on an empty numba cache: which implementation runs (:mod:`hexatissue._dispatch`), the references
that replace the kernels on small inputs giving the kernels' tables, and a first run of the bundled sample that
compiles none of the kernels with a reference and leaves nothing running."""
import os
import subprocess
import sys
import types
import warnings
from pathlib import Path

import numpy as np
import pytest

from hexatissue import _dispatch
from hexatissue._dispatch import Kernels, references
from hexatissue.pipeline import analyze, kernel_mode
from hexatissue.samples import sample_path
from hexatissue.source import open_source

ROOT = Path(__file__).resolve().parents[1]


def _fake_kernel(compiled, index_path):
    """A stand-in for a numba dispatcher: its compiled overloads and its cache index file."""
    cache = types.SimpleNamespace(_cache_file=types.SimpleNamespace(_index_path=str(index_path)))
    kernel = types.SimpleNamespace(overloads={"sig": 1} if compiled else {}, _cache=cache)
    return kernel


def test_kernels_choose_the_reference_only_for_what_is_not_compiled(tmp_path, monkeypatch):
    cached = tmp_path / "cached.nbi"
    cached.touch()
    module = types.SimpleNamespace(cold=_fake_kernel(False, tmp_path / "absent.nbi"),
                                   on_disk=_fake_kernel(False, cached), in_memory=_fake_kernel(True, tmp_path / "x"),
                                   alone=_fake_kernel(False, tmp_path / "absent.nbi"))
    reference = types.SimpleNamespace(cold="ref cold", on_disk="ref on_disk", in_memory="ref in_memory",
                                      renamed="ref alone")
    monkeypatch.setitem(sys.modules, "fake_reference", reference)
    k = Kernels(module, "fake_reference", names={"alone": "renamed"})
    assert _dispatch.reference_mode() == "kernel"
    assert k.cold is module.cold and k.on_disk is module.on_disk  # outside the block: the kernels
    with references("auto"):
        assert _dispatch.reference_mode() == "auto"
        assert k.cold == "ref cold" and k.alone == "ref alone"  # not compiled, not cached
        assert k.on_disk is module.on_disk and k.in_memory is module.in_memory  # compiled or cached: kept
        with references("reference"):
            assert k.on_disk == "ref on_disk" and k.in_memory == "ref in_memory"
    assert _dispatch.reference_mode() == "kernel" and k.cold is module.cold
    with pytest.raises(ValueError, match="mode must be one of"):
        with references("numpy"):
            pass


def test_small_inputs_run_references_and_large_ones_compile(monkeypatch):
    import hexatissue.pipeline as pipeline

    source = open_source(sample_path("epicure_notum"))
    assert kernel_mode(source) == "auto"  # 11 x 160 x 257 px
    assert kernel_mode(source, client=object()) == "kernel"  # a cluster's workers compile on their side
    with references("reference"):
        assert kernel_mode(source) == "reference"  # the caller's choice is kept
    monkeypatch.setattr(pipeline, "REFERENCE_PIXELS", source.n_frames * 160 * 257 - 1)
    assert kernel_mode(source) == "kernel"


def _assert_tables_equal(a, b):
    """Every table of two Movies: integer, boolean and text columns equal, floats equal to 1e-12 (summation order)."""
    assert set(a.tables) == set(b.tables)
    for name, table in a.tables.items():
        other = b.tables[name]
        assert list(table.columns) == list(other.columns) and len(table) == len(other), name
        for column in table.columns:
            x, y = table[column].to_numpy(), other[column].to_numpy()
            if x.dtype.kind in "fc":
                np.testing.assert_allclose(x, y, rtol=1e-12, atol=1e-12, err_msg=f"{name}.{column}")
            else:
                np.testing.assert_array_equal(x, y, err_msg=f"{name}.{column}")


def test_the_references_give_the_kernels_tables_on_the_sample(monkeypatch):
    """Measured: every integer, boolean and text column identical; floats within 5.5e-12 (polygon_area, px^2)."""
    import hexatissue.pipeline as pipeline

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with references("reference"):
            by_reference = analyze(sample_path("epicure_notum"), workers=1, progress=False)
        monkeypatch.setattr(pipeline, "REFERENCE_PIXELS", 0)  # every kernel compiled (or loaded from the cache)
        by_kernel = analyze(sample_path("epicure_notum"), workers=1, progress=False)
    assert len(by_kernel.cells) == 902 and len(by_kernel.neighbour_events) > 0  # the tables compared hold rows
    _assert_tables_equal(by_reference, by_kernel)


@pytest.mark.parametrize("periodic", [False, True])
def test_fill_gaps_reference_equals_kernel(periodic):
    from hexatissue.mesh import _kernels as K, _reference as R

    rng = np.random.default_rng(3)
    for _ in range(30):
        labels = rng.integers(1, 6, tuple(rng.integers(1, 25, 2))).astype(np.int32)
        labels[rng.random(labels.shape) < 0.5] = 0
        for passes in (1, 2, 5):
            out = R.fill_gaps(labels, passes, periodic)
            np.testing.assert_array_equal(out, K.fill_gaps(labels, passes, periodic))
            assert out.dtype == labels.dtype


def test_compaction_and_division_references_equal_kernels():
    from hexatissue.track import _kernels as K, _reference as R

    rng = np.random.default_rng(4)
    for _ in range(30):
        flat = rng.integers(0, 40, int(rng.integers(1, 400))).astype(np.int32)
        top = int(flat.max())
        for x, y in zip(R._compact_index(flat, top), K._compact_index(flat, top)):
            np.testing.assert_array_equal(x, y)
            assert x.dtype == y.dtype
        prev, ids, _ = K._compact_index(rng.permutation(flat), top)
        for x, y in zip(R._compact_overlaps(flat, top, prev, len(ids)), K._compact_overlaps(flat, top, prev, len(ids))):
            np.testing.assert_array_equal(x, y)
            assert x.dtype == y.dtype
    # a mother split in two daughters, a cell that moved on, and a neighbour that took a sliver
    i, j, n = (np.array(v, np.int64) for v in ([0, 0, 1, 2, 2], [0, 1, 2, 2, 3], [50, 45, 80, 5, 90]))
    area_a, area_b = np.array([100, 80, 95], np.int64), np.array([52, 47, 85, 90], np.int64)
    for x, y in zip(R._division_reference(i, j, n, area_a, area_b, 0.5, 0.2, 0.3),
                    K._division_kernel(i, j, n, area_a, area_b, 0.5, 0.2, 0.3)):
        np.testing.assert_array_equal(x, y)
    np.testing.assert_array_equal(K._division_kernel(i, j, n, area_a, area_b, 0.5, 0.2, 0.3)[0], [0])


def test_plaquette_and_shape_references_equal_kernels():
    from hexatissue.defects import _kernels as DK, _reference as DR
    from hexatissue.order import DEGENERATE_AREA, _kernels as OK, _reference as OR

    rng = np.random.default_rng(5)
    theta = rng.uniform(-np.pi, np.pi, (3, 9, 11))
    theta[1, 4, 5] = np.nan
    for periodic in (False, True):
        flat, charge = DR.plaquette_defects(theta, 6, periodic)
        kflat, kcharge = DK.plaquette_defects(theta, 6, periodic)
        assert len(flat) > 0
        np.testing.assert_array_equal(flat, kflat)
        np.testing.assert_allclose(charge, kcharge, rtol=0, atol=1e-12)
    xy = rng.normal(size=(40, 2))
    starts = np.array([0, 6, 9, 11, 20], np.int64)  # a 2-gon among them: NaN
    centre = rng.normal(size=(5, 2))
    orders = np.array([2, 6], np.int64)
    for own in (True, False):
        np.testing.assert_allclose(OR.shape_sums(xy, starts, centre, own, orders, DEGENERATE_AREA),
                                   OK.shape_sums(xy, starts, centre, own, orders, DEGENERATE_AREA), rtol=1e-12, atol=1e-12)


@pytest.mark.slow
def test_the_first_run_of_the_sample_compiles_no_kernel_with_a_reference(tmp_path):
    """``hexatissue analyze`` of the bundled sample on an empty numba cache: no compile message, no kernel compiled
    (numba's cache holds no index), and nothing of the run is left running."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"), HEXATISSUE_PROGRESS="0",
               PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    run = subprocess.Popen([sys.executable, "-m", "hexatissue.cli", "analyze", str(sample_path("epicure_notum")),
                            "--out", str(tmp_path / "o")], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                           text=True, start_new_session=True)
    _, err = run.communicate(timeout=600)
    assert run.returncode == 0, err
    assert "compiling" not in err
    left = subprocess.run(["ps", "-o", "stat=", "-s", str(run.pid)], capture_output=True, text=True).stdout.split()
    assert [s for s in left if not s.startswith("Z")] == []
    assert sorted(p.name for p in (tmp_path / "cache").rglob("*.nbi")) == []


def test_the_events_references_give_the_kernels_events_on_scripted_t1s():
    """The events stage's references (one level up: the T1 step, the neighbour lists, the list changes) give the
    kernels' T1 and neighbour-change tables on the scripted T1 movie, whose T1s the sample lacks."""
    import pandas as pd

    from hexatissue.events import t1_tables
    from hexatissue.synthetic import t1_movie

    movie = t1_movie(periodic=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tables = analyze(movie.labels, box=movie.box, workers=1, progress=False)
        by_kernel = t1_tables(tables.edges, tables.cells, min_length=4.0, censor=5, box=movie.box)
        with references("reference"):
            by_reference = t1_tables(tables.edges, tables.cells, min_length=4.0, censor=5, box=movie.box)
    assert len(by_kernel[0]) >= 3 and len(by_kernel[1]) > 0  # T1s and neighbour changes to compare
    for a, b in zip(by_reference, by_kernel):
        pd.testing.assert_frame_equal(a, b, check_exact=True)
