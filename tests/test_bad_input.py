"""The bad-input corpus (issue 12): every bad input gives a clear InputError (CLI: exit 2, one line) or a valid result.

Each case is small and synthetic.  API cases call the library; CLI cases run
``hexatissue.cli.main`` in this process (the same code as the command) and
check the exit code and that stderr is one line with no traceback.
"""
import json
import math
import os
import signal
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import hexatissue as ht
from hexatissue import Box, HexatissueWarning, InputError
from hexatissue.cli import main
from hexatissue.io import check_output_folder, read_table


def tiles(n=4, size=8):
    """n x n square cells of size x size px, ids 1..n^2."""
    r = np.arange(n * size) // size
    return (r[:, None] * n + r[None, :] + 1).astype(np.int32)


LAB = tiles()
REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def frame():
    return ht.shape_order(ht.mesh_from_labels(LAB))


def island():
    t = np.ones((8, 8), int)
    t[:, 4:] = 2
    t[3, 3] = 3
    return t


# ---------------------------------------------------------------------------------------------------
# API: bad input -> InputError naming the argument
# ---------------------------------------------------------------------------------------------------
API_ERRORS = {
    "uint64 ids >= 2**63": (lambda f: ht.mesh_from_labels(LAB.astype(np.uint64) + np.uint64(2**63)), "2**63"),
    "uint64 ids >= 2**63 with 0": (lambda f: ht.mesh_from_labels(np.where(LAB > 8, LAB.astype(np.uint64)
                                                                           + np.uint64(2**63), 0)), "2**63"),
    "labels 1-D": (lambda f: ht.mesh_from_labels(np.arange(5)), "2-D"),
    "labels 3-D": (lambda f: ht.mesh_from_labels(np.ones((2, 4, 4), int)), "2-D"),
    "labels 1 x 5": (lambda f: ht.mesh_from_labels(np.ones((1, 5), int)), "2 x 2"),
    "labels all zero": (lambda f: ht.mesh_from_labels(np.zeros((6, 6), int)), "all zeros"),
    "labels NaN": (lambda f: ht.mesh_from_labels(np.where(LAB == 1, np.nan, LAB.astype(float))), "NaN"),
    "labels non-integer float": (lambda f: ht.mesh_from_labels(LAB + 0.5), "non-integer"),
    "labels negative": (lambda f: ht.mesh_from_labels(LAB - 3), "negative"),
    "labels strings": (lambda f: ht.mesh_from_labels(np.array([["a", "b"], ["c", "d"]])), "integer"),
    "labels complex": (lambda f: ht.mesh_from_labels(LAB.astype(complex)), "integer"),
    "merge_distance '2'": (lambda f: ht.mesh_from_labels(LAB, merge_distance="2"), "merge_distance"),
    "merge_distance -1": (lambda f: ht.mesh_from_labels(LAB, merge_distance=-1), "merge_distance"),
    "merge_distance NaN": (lambda f: ht.mesh_from_labels(LAB, merge_distance=float("nan")), "merge_distance"),
    "merge_distance None": (lambda f: ht.mesh_from_labels(LAB, merge_distance=None), "merge_distance"),
    "membrane_width -1": (lambda f: ht.mesh_from_labels(LAB, membrane_width=-1), "membrane_width"),
    "membrane_width 1.5": (lambda f: ht.mesh_from_labels(LAB, membrane_width=1.5), "membrane_width"),
    "kind unknown": (lambda f: ht.mesh_from_labels(LAB, kind="voronoi"), "kind"),
    "box of another shape": (lambda f: ht.mesh_from_labels(LAB, box=Box(10, 10)), "box"),
    "box a tuple": (lambda f: ht.mesh_from_labels(LAB, box=(32, 32)), "box"),
    "p=1.5": (lambda f: ht.shape_order(f, p=1.5), "p must"),
    "p=True": (lambda f: ht.shape_order(f, p=True), "p must"),
    "p=None": (lambda f: ht.shape_order(f, p=None), "p must"),
    "p='6'": (lambda f: ht.shape_order(f, p="6"), "p must"),
    "p=0": (lambda f: ht.shape_order(f, p=0), "p must"),
    "p=[]": (lambda f: ht.shape_order(f, p=[]), "at least one"),
    "p=(6, 6)": (lambda f: ht.shape_order(f, p=(6, 6)), "twice"),
    "center unknown": (lambda f: ht.shape_order(f, center="median"), "center"),
    "Box('64', 64)": (lambda f: Box("64", 64), "Box.Lx"),
    "Box(0, 1)": (lambda f: Box(0, 1), "Box.Lx"),
    "Box(1, NaN)": (lambda f: Box(1, float("nan")), "Box.Ly"),
    "Box(True, 3)": (lambda f: Box(True, 3), "Box.Lx"),
    "Box(None, 3)": (lambda f: Box(None, 3), "Box.Lx"),
    "coarse_grain radius '5'": (lambda f: ht.coarse_grain(f.cells, radius="5"), "radius"),
    "coarse_grain radius -1": (lambda f: ht.coarse_grain(f.cells, radius=-1.0), "radius"),
    "coarse_grain spacing 0": (lambda f: ht.coarse_grain(f.cells, spacing=0), "spacing"),
    "coarse_grain spacing 0.001 (huge grid)": (lambda f: ht.coarse_grain(f.cells, spacing=0.001), "spacing 0.001"),
    "coarse_grain p 2.5": (lambda f: ht.coarse_grain(f.cells, p=2.5), "p must"),
    "pixel_size -1": (lambda f: ht.open_source(LAB, pixel_size=-1, length_unit="um"), "pixel_size"),
    "pixel_size NaN": (lambda f: ht.open_source(LAB, pixel_size=float("nan"), length_unit="um"), "pixel_size"),
    "pixel_size '1'": (lambda f: ht.open_source(LAB, pixel_size="1", length_unit="um"), "pixel_size"),
    "pixel_size without unit": (lambda f: ht.open_source(LAB, pixel_size=0.5), "length_unit"),
    "length_unit unknown": (lambda f: ht.open_source(LAB, pixel_size=0.5, length_unit="furlong"), "unit"),
    "frame_interval 0": (lambda f: ht.open_source(LAB, frame_interval=0, time_unit="s"), "frame_interval"),
    "0-frame stack": (lambda f: ht.open_source(np.zeros((0, 8, 8), int)), "holds no frame"),
    "empty list": (lambda f: ht.open_source([]), "list"),
    "frames of two shapes": (lambda f: ht.open_source([LAB, LAB[:16]]), "shape"),
    "channel -1": (lambda f: ht.open_source(LAB, channel=-1), "channel"),
    "level True": (lambda f: ht.open_source(LAB, level=True), "level"),
    "key 3": (lambda f: ht.open_source(LAB, key=3), "key"),
    "missing path": (lambda f: ht.open_source("/nonexistent/labels.tif"), "labels.tif"),
    "object": (lambda f: ht.open_source(object()), "obj"),
    "frame index 1.0": (lambda f: ht.open_source(LAB).frame(1.0), "frame index"),
    "frame index out of range": (lambda f: ht.open_source(LAB).frame(3), "out of range"),
    "analyze mesh='x'": (lambda f: ht.analyze(LAB, mesh="x", progress=False), "mesh"),
    "analyze workers 0": (lambda f: ht.analyze(np.stack([LAB, LAB]), workers=0, progress=False), "workers"),
    "analyze workers 1.5": (lambda f: ht.analyze(np.stack([LAB, LAB]), workers=1.5, progress=False), "workers"),
    "MeshOptions merge '2'": (lambda f: ht.MeshOptions(merge_distance="2"), "merge_distance"),
    "OrderOptions p None": (lambda f: ht.OrderOptions(p=None), "OrderOptions.p"),
    "OrderOptions fields 1": (lambda f: ht.OrderOptions(fields=1), "fields"),
    "OrderOptions spacing '1'": (lambda f: ht.OrderOptions(spacing="1"), "spacing"),
    "TrackOptions min_iou 0": (lambda f: ht.TrackOptions(min_iou=0), "min_iou"),
    "TrackOptions max_gap 1.5": (lambda f: ht.TrackOptions(max_gap=1.5), "max_gap"),
    "EventOptions censor -1": (lambda f: ht.EventOptions(censor=-1), "censor"),
    "detect_t1 min_length 'x'": (lambda f: ht.detect_t1(f.edges, f.cells, min_length="x"), "min_length"),
    "Movie.write format xlsx": (lambda f: ht.Movie.from_frames([f]).write("/tmp/never", formats=("xlsx",)),
                                "formats"),
    "read_results of a missing folder": (lambda f: ht.read_results("/nonexistent/results"), "does not exist"),
    "Calibration px with pixel_size 2": (lambda f: ht.Calibration(pixel_size=2.0), "length_unit"),
}


@pytest.mark.parametrize("name", sorted(API_ERRORS))
def test_api_bad_input_raises_input_error(name, frame):
    call, text = API_ERRORS[name]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HexatissueWarning)
        with pytest.raises(InputError, match=None) as info:
            call(frame)
    assert text.lower() in str(info.value).lower(), str(info.value)


# ---------------------------------------------------------------------------------------------------
# API: formerly silent wrong answers -> right values or a warning
# ---------------------------------------------------------------------------------------------------
def test_16bit_rgb_colours_stay_distinct(tmp_path):
    tifffile = pytest.importorskip("tifffile")
    rgb = np.zeros((16, 16, 3), np.uint16)
    rgb[:, :8, 0] = 1          # colour (1, 0, 0)
    rgb[:, 8:, 1] = 256        # colour (0, 256, 0): the same id under 8-bit shifts
    path = tmp_path / "rgb16.tif"
    tifffile.imwrite(path, rgb, photometric="rgb")
    lab = ht.open_source(path).frame(0)
    assert len(np.unique(lab)) == 2
    assert lab[0, 0] == 1 << 32 and lab[0, 15] == 256 << 16
    assert len(ht.mesh_from_labels(lab).cells) == 2


def test_8bit_rgb_keeps_its_documented_ids():
    rgb = np.zeros((16, 16, 3), np.uint8)
    rgb[:, :8] = (1, 2, 3)
    rgb[:, 8:] = (4, 5, 6)
    with pytest.warns(HexatissueWarning, match="RGB"):
        lab = ht.open_source(rgb).frame(0)
    assert set(np.unique(lab)) == {(1 << 16) | (2 << 8) | 3, (4 << 16) | (5 << 8) | 6}


def test_t_y_3_stack_warns_and_axes_or_a_list_read_frames(tmp_path, capsys):
    stack = np.stack([np.repeat([[1, 2, 3]], 10, axis=0)] * 4)  # 4 frames of 10 x 3 px
    with pytest.warns(HexatissueWarning, match=r"pass axes='TYX' \(--axes TYX on the command line\)"):
        src = ht.open_source(stack)
    assert (src.n_frames, src.shape) == (1, (4, 10))
    for src in (ht.open_source(list(stack)), ht.open_source(stack, axes="TYX")):
        assert (src.n_frames, src.shape) == (4, (10, 3))
    np.save(tmp_path / "tiles.npy", stack)
    assert main(["analyze", str(tmp_path / "tiles.npy"), "--axes", "TYX", "--out", str(tmp_path / "o")]) == 0
    assert ht.read_results(tmp_path / "o").n_frames == 4


def test_a_stack_of_three_or_four_frames_saved_by_tifffile_is_not_read_as_one_colour_image(tmp_path, capsys):
    """Issue 32: tifffile.imwrite(path, stack) of 3-4 frames stores planar RGB; it was read as one frame of
    merged colour ids, silently."""
    import tifffile

    stack = np.stack([np.repeat(np.repeat(np.arange(1, 17).reshape(4, 4) + 20 * t, 8, 0), 8, 1)
                      for t in range(3)]).astype(np.uint16)
    tifffile.imwrite(tmp_path / "stack.tif", stack)
    with pytest.raises(InputError, match=r"holds 3 planes .* axes='TYX' \(3 frames\) or axes='SYX'"):
        ht.open_source(tmp_path / "stack.tif")
    src = ht.open_source(tmp_path / "stack.tif", axes="TYX")
    assert src.n_frames == 3 and all(np.array_equal(src.frame(t), stack[t]) for t in range(3))
    colour = ht.open_source(tmp_path / "stack.tif", axes="SYX")
    assert colour.n_frames == 1 and len(np.unique(colour.frame(0))) == 16
    tifffile.imwrite(tmp_path / "zipped.tif", stack, compression="zlib")  # pages, not one contiguous block
    src = ht.open_source(tmp_path / "zipped.tif", axes="TYX")
    assert all(np.array_equal(src.frame(t), stack[t]) for t in range(3))
    tifffile.imwrite(tmp_path / "imagej.tif", stack, imagej=True, metadata={"axes": "TYX"})  # the file says: no question
    assert ht.open_source(tmp_path / "imagej.tif").n_frames == 3
    err = _cli_error(["analyze", str(tmp_path / "stack.tif"), "--out", str(tmp_path / "o")], capsys)
    assert "--axes on the command line" in err
    with pytest.raises(InputError, match="axes='TXY': expected one letter per stored dimension"):
        ht.open_source(tmp_path / "stack.tif", axes="TXY")
    with pytest.raises(InputError, match="axes='TCYX' has 4 letter"):
        ht.open_source(tmp_path / "stack.tif", axes="TCYX")
    with pytest.raises(InputError, match="axes='TYX' means nothing for a polygon file"):
        pd.DataFrame({"cell": [1, 1, 1], "x": [0, 1, 0], "y": [0, 0, 1.0]}).to_csv(tmp_path / "v.csv", index=False)
        ht.open_source(tmp_path / "v.csv", axes="TYX")


@pytest.mark.parametrize("labels, kwargs", [(island(), {}), (np.array([[1, 2], [3, 4]]), {}),
                                            (LAB, {"merge_distance": 1e9})],
                         ids=["cell inside a cell", "2 x 2 image", "merge_distance 1e9"])
def test_cells_losing_their_polygon_warn(labels, kwargs):
    with pytest.warns(HexatissueWarning, match="no boundary polygon"):
        f = ht.mesh_from_labels(labels, **kwargs)
    assert (f.cells["n_sides"] == 0).any()


def test_lone_cell_on_background_does_not_warn():
    blob = np.zeros((20, 20), np.uint8)
    blob[5:15, 5:15] = 1
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert len(ht.mesh_from_labels(blob).cells) == 1


def test_p_checked_everywhere():
    with pytest.raises(InputError):
        ht.OrderOptions(p=(6, 1.5))
    f = ht.shape_order(ht.mesh_from_labels(LAB), p=6)
    assert not any(c.startswith("gamma1") for c in f.cells.columns)


def test_degenerate_polygon_has_no_shape_function():
    flat = np.array([[0.0, 0.0], [1.0, 1e-15], [2.0, 0.0]])
    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    gamma = ht.shape_function([flat, square], p=4)
    assert np.isnan(gamma[0])
    assert gamma[1] == pytest.approx(-1.0)  # corners at 45 degrees: exp(4i pi/4)


def test_periodic_centroid_of_a_cell_wider_than_half_the_box():
    lab = np.ones((64, 64), np.int32)
    lab[8:30, 10:50] = 2      # 40 px wide in a 64 px box
    for shift in (0, 30):
        cells = ht.mesh_from_labels(np.roll(lab, shift, axis=1), box=True).cells.set_index("cell")
        assert cells.loc[2, "x"] == pytest.approx((29.5 + shift) % 64)
        assert cells.loc[2, "y"] == pytest.approx(18.5)


def test_grid_cap_refuses_fine_spacing_fast(frame):
    start = time.perf_counter()
    with pytest.raises(InputError, match="spacing"):
        ht.coarse_grain(frame.cells, spacing=0.001)  # 8001 x 8001 nodes over the interior cells
    assert time.perf_counter() - start < 5
    grid = ht.coarse_grain(frame.cells, spacing=4.0)
    assert len(grid) == 3 * 3   # the interior centroids span 8 px: 3 nodes a side at 4 px


# ---------------------------------------------------------------------------------------------------
# Output folders, tables, checkpoints
# ---------------------------------------------------------------------------------------------------
def test_output_folder_checks(tmp_path):
    afile = tmp_path / "file"
    afile.write_text("x")
    with pytest.raises(InputError, match="is a file"):
        check_output_folder(afile, "--out")
    with pytest.raises(InputError, match="below the file"):
        check_output_folder(afile / "sub", "--out")
    assert check_output_folder(tmp_path / "new" / "deeper", "--out") == tmp_path / "new" / "deeper"
    assert not (tmp_path / "new").exists()  # nothing created


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="root writes anywhere")
def test_output_folder_not_writable(tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    try:
        with pytest.raises(InputError, match="not writable"):
            check_output_folder(ro / "out", "--out")
    finally:
        ro.chmod(0o700)


def movie(n_frames=1):
    return ht.analyze(np.stack([LAB] * n_frames) if n_frames > 1 else LAB, workers=1, progress=False)


def test_rewriting_a_results_folder_removes_stale_tables(tmp_path):
    movie(2).write(tmp_path, formats=("parquet", "csv"))
    assert (tmp_path / "events.csv").exists()
    small = movie(1).replace(events=None, lineage=None, cell_events=None)
    small.write(tmp_path)
    assert not (tmp_path / "events.parquet").exists() and not (tmp_path / "cells.csv").exists()
    back = ht.read_results(tmp_path)
    assert back.events is None and len(back.cells) == 16


def test_interrupted_rewrite_leaves_no_manifest(tmp_path, monkeypatch):
    movie(1).write(tmp_path)
    import hexatissue.results as results

    def boom(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(results, "write_table", boom)  # the first table written
    with pytest.raises(KeyboardInterrupt):
        movie(1).write(tmp_path)
    assert not (tmp_path / "metadata.json").exists()
    with pytest.raises(InputError, match="metadata.json"):
        ht.read_results(tmp_path)


def test_results_folder_not_matching_its_manifest(tmp_path):
    movie(1).write(tmp_path)
    pd.read_parquet(tmp_path / "cells.parquet").head(3).to_parquet(tmp_path / "cells.parquet")
    with pytest.raises(InputError, match="does not match"):
        ht.read_results(tmp_path)


def test_garbled_metadata_and_tables(tmp_path):
    movie(1).write(tmp_path)
    (tmp_path / "edges.parquet").write_bytes(b"PAR1 not parquet at all PAR1")
    with pytest.raises(InputError, match="cannot be read"):
        read_table(tmp_path / "edges.parquet")
    with pytest.raises(InputError, match="edges.parquet"):
        ht.read_results(tmp_path)
    (tmp_path / "metadata.json").write_text("{ truncated")
    with pytest.raises(InputError, match="metadata.json"):
        ht.read_results(tmp_path)
    with pytest.raises(InputError, match="is a file"):
        movie(1).write(tmp_path / "metadata.json")


STACK = np.stack([LAB, LAB, LAB])


def test_checkpoint_folder_that_is_a_file(tmp_path):
    (tmp_path / "ck").write_text("x")
    with pytest.raises(InputError, match="checkpoint"):
        ht.analyze(STACK, workers=1, progress=False, checkpoint=tmp_path / "ck")


def test_checkpoint_folder_is_locked(tmp_path):
    fcntl = pytest.importorskip("fcntl")
    folder = tmp_path / "ck"
    folder.mkdir()
    with open(folder / "checkpoint.lock", "a+") as held:
        fcntl.flock(held.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        with pytest.raises(InputError, match="in use by another"):
            ht.analyze(STACK, workers=1, progress=False, checkpoint=folder)
    done = ht.analyze(STACK, workers=1, progress=False, checkpoint=folder)  # the lock is free again
    assert len(done.cells) == 3 * 16


@pytest.mark.parametrize("damage", ["garbled state", "state not a dict", "missing part", "truncated part",
                                    "missing tracker"])
def test_damaged_checkpoint(tmp_path, damage):
    folder = tmp_path / "ck"
    ht.analyze(STACK, workers=1, progress=False, checkpoint=folder, checkpoint_every=2)
    state = json.loads((folder / "checkpoint.json").read_text())
    part = folder / state["files"]["cells"][0]
    if damage == "garbled state":
        (folder / "checkpoint.json").write_text('{"key": ')
    elif damage == "state not a dict":
        (folder / "checkpoint.json").write_text("[1, 2]")
    elif damage == "missing part":
        part.unlink()
    elif damage == "truncated part":
        part.write_bytes(part.read_bytes()[:40])
    else:
        (folder / state["states"]["track"]).unlink()
    with pytest.raises(InputError, match="damaged"):
        ht.analyze(STACK, workers=1, progress=False, checkpoint=folder, checkpoint_every=2)


def test_worker_warnings_name_their_frames():
    frames = [LAB, np.kron(island(), np.ones((4, 4), int)), LAB]
    with pytest.warns(HexatissueWarning, match=r"^frame 1: some interior cells have no boundary polygon") as record:
        ht.analyze(frames, workers=2, progress=False)
    texts = [str(w.message) for w in record if "no boundary polygon" in str(w.message)]
    assert len(texts) == 1
    assert record[0].filename == __file__  # points at the caller, not at an internal line


# ---------------------------------------------------------------------------------------------------
# Simulators
# ---------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("fields, text", [
    (dict(n_cells=60, Lx=96, Ly=96), "do not fit"),
    (dict(n_cells=440, Lx=50, Ly=50), "do not fit"),
    (dict(n_cells=600, Lx=64, Ly=64), "do not fit"),
    (dict(n_cells=6, Lx=48, Ly=44, patch=30), "Params.patch"),
    (dict(n_cells=6, Lx=48, Ly=44, dt=5.0), "Params.dt"),
    (dict(n_cells=6, Lx=48, Ly=44, v0="fast"), "Params.v0"),
    (dict(n_cells=True), "Params.n_cells"),
])
def test_simulator_params(fields, text):
    from hexatissue.simulate import Params

    with pytest.raises(InputError, match=text.replace(".", r"\.")):
        Params(**fields)


def test_simulator_packing_of_the_paper_is_accepted():
    from hexatissue.simulate import Params

    p = Params()
    assert p.n_cells * math.pi * p.R**2 / (p.Lx * p.Ly) == pytest.approx(1.1817, abs=1e-3)


@pytest.fixture
def mpf_store(tmp_path):
    """A small run store written through RunStore (two frames and a checkpoint; no time stepping)."""
    from hexatissue.simulate import Params, initial_state
    from hexatissue.simulate.segment import segment
    from hexatissue.simulate.store import RunStore

    params = Params(n_cells=6, Lx=48, Ly=44)
    sim = initial_state(params, seed=1)
    store = RunStore.create(tmp_path / "run.zarr", params, 1, 0, 10, 5, 0)
    store.reserve(3, 0)
    for step in (0, 5):
        store.append_frame(segment(sim), step, sim.moments(), sim.theta.copy())
    store.write_checkpoint(sim)
    return tmp_path / "run.zarr"


def _chunk_files(path, name):
    return sorted(p for p in (path / name / "c").rglob("*") if p.is_file())


def test_mpf_store_intact_reads(mpf_store):
    from hexatissue.simulate import read_run

    run = read_run(mpf_store)
    assert len(run) == 2 and (run.cells["area"] > 100).all()


@pytest.mark.parametrize("damage", ["deleted x chunk", "deleted labels chunk", "truncated x chunk"])
def test_mpf_store_damaged_frames(mpf_store, damage):
    from hexatissue.simulate import read_run

    name = "labels" if "labels" in damage else "x"
    chunk = _chunk_files(mpf_store, name)[0]
    if damage.startswith("deleted"):
        chunk.unlink()
    else:
        chunk.write_bytes(chunk.read_bytes()[:5])
    with pytest.raises(InputError, match="damaged"):
        read_run(mpf_store).cells


@pytest.mark.parametrize("damage", ["missing array", "deleted chunk", "garbled rng state"])
def test_mpf_store_damaged_checkpoint(mpf_store, damage):
    import zarr

    from hexatissue.simulate.store import RunStore

    g = zarr.open_group(str(mpf_store), mode="r+")
    slot = g.attrs["checkpoint"]
    if damage == "missing array":
        del g[f"checkpoint/{slot}/theta"]
    elif damage == "deleted chunk":
        _chunk_files(mpf_store / "checkpoint" / slot, "phi")[0].unlink()
    else:
        g[f"checkpoint/{slot}"].attrs["rng_state"] = "{not json"
    with pytest.raises(InputError, match="damaged"):
        RunStore.open(mpf_store).read_checkpoint()


def test_hydro_params_and_steps():
    from hexatissue.hydro import HydroParams
    from hexatissue.hydro.run import integrate
    from hexatissue.hydro.solver import Solver

    with pytest.raises(InputError, match="HydroParams.dt"):
        HydroParams(dt=50.0)
    solver = Solver(16, HydroParams())
    state = solver.state_from_fields(np.ones((16, 16), complex))
    with pytest.raises(InputError, match="steps"):
        integrate(solver, state, steps=-3, progress=False)


def test_hydro_blow_up_is_an_error(monkeypatch):
    from hexatissue.hydro import HydroParams
    from hexatissue.hydro.run import integrate
    from hexatissue.hydro.solver import Solver

    solver = Solver(16, HydroParams())
    state = solver.state_from_fields(np.ones((16, 16), complex))
    monkeypatch.setattr(solver, "step", lambda s: setattr(s, "psi_hat", s.psi_hat * np.nan))
    with pytest.raises(InputError, match="unstable"):
        integrate(solver, state, steps=4, save_every=2, progress=False)


def test_hydro_damaged_checkpoint(tmp_path):
    from hexatissue.hydro import HydroParams
    from hexatissue.hydro.run import integrate
    from hexatissue.hydro.solver import Solver

    solver = Solver(16, HydroParams())
    state = solver.state_from_fields(np.ones((16, 16), complex))
    integrate(solver, state, steps=4, save_every=2, field_every=1, out=tmp_path / "h.zarr", progress=False)
    ckpt = tmp_path / "h.zarr" / "checkpoint.npz"
    ckpt.write_bytes(ckpt.read_bytes()[:100])
    with pytest.raises(InputError, match="checkpoint.npz"):
        integrate(solver, state, steps=8, save_every=2, out=tmp_path / "h.zarr", resume=True, progress=False)


# ---------------------------------------------------------------------------------------------------
# CLI: exit 2 and one line
# ---------------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    d = tmp_path_factory.mktemp("cli")
    np.save(d / "labels.npy", LAB)
    np.save(d / "empty.npy", np.zeros((0, 8, 8), np.int32))
    (d / "afile").write_text("x")
    results = d / "results"
    movie(1).write(results)
    garbled = d / "garbled"
    movie(1).write(garbled)
    (garbled / "cells.parquet").write_bytes(b"PAR1 garbage PAR1")
    return d


CLI_CASES = {
    "--out is a file": ("analyze {d}/labels.npy --out {d}/afile", "is a file"),
    "--out below a file": ("analyze {d}/labels.npy --out {d}/afile/sub", "below the file"),
    "--checkpoint is a file": ("analyze {d}/labels.npy --out {d}/o1 --checkpoint {d}/afile", "--checkpoint"),
    "missing input": ("analyze {d}/nothing.tif --out {d}/o2", "nothing.tif"),
    "0-frame stack": ("analyze {d}/empty.npy --out {d}/o3", "holds no frame"),
    "--workers 0": ("analyze {d}/labels.npy --out {d}/o4 --workers 0", "workers"),
    "--p 0": ("analyze {d}/labels.npy --out {d}/o5 --p 0", "p must"),
    "--merge-distance -1": ("analyze {d}/labels.npy --out {d}/o6 --merge-distance -1", "--merge-distance must"),
    "--pixel-size -1": ("analyze {d}/labels.npy --out {d}/o7 --pixel-size -1", "pixel_size"),
    "--pixel-size nan": ("analyze {d}/labels.npy --out {d}/o8 --pixel-size nan", "pixel_size"),
    "--spacing 0.001": ("analyze {d}/labels.npy --out {d}/o9 --spacing 0.001", "spacing"),
    "--units furlong": ("analyze {d}/labels.npy --out {d}/o10 --pixel-size 1 --units furlong", "unit"),
    "--radius 1e6": ("analyze {d}/labels.npy --out {d}/o11 --radius 1e6",
                     "--radius 1e+06 px is larger than the frames' diagonal"),
    "--radius 1e4": ("analyze {d}/labels.npy --out {d}/o12 --radius 1e4", "give at most"),
    "--merge-distance 1e6": ("analyze {d}/labels.npy --out {d}/o13 --merge-distance 1e6",
                             "--merge-distance 1e+06 px is larger than the frames' diagonal"),
    "hydro --alpha -1e-3 read as a number": ("hydro dipole --alpha -1e-3 --n 32 --distance 8 --dt 50 --out "
                                              "{d}/h4.zarr", "--dt = 50"),
    "report on garbled parquet": ("report {d}/garbled --out {d}/rep", "cannot be read"),
    "report on a missing folder": ("report {d}/nowhere", "does not exist"),
    "simulate 60 cells in 96 x 96": ("simulate --out {d}/s1.zarr --cells 60 --size 96 96", "--cells"),
    "simulate 440 cells in 50 x 50": ("simulate --out {d}/s2.zarr --cells 440 --size 50 50", "--cells"),
    "simulate 600 cells in 64 x 64": ("simulate --out {d}/s3.zarr --cells 600 --size 64 64", "do not fit"),
    "simulate --patch 30": ("simulate --out {d}/s4.zarr --cells 6 --size 48 44 --patch 30", "--patch = 30"),
    "simulate --dt 5": ("simulate --out {d}/s5.zarr --cells 6 --size 48 44 --dt 5", "--dt = 5"),
    "simulate --overwrite onto a file": ("simulate --out {d}/afile --cells 6 --size 48 44 --overwrite", "is a file"),
    "simulate onto an existing store": ("simulate --out {d}/results --cells 6 --size 48 44", "already exists"),
    "simulate --resume of nothing": ("simulate --out {d}/none.zarr --resume", "does not exist"),
    "simulate --checkpoint-seconds -1": ("simulate --out {d}/s6.zarr --cells 6 --size 48 44 --checkpoint-seconds -1"
                                         " --steps 0 --relax 0", "--checkpoint-seconds"),
    "hydro --dt 50": ("hydro dipole --alpha -0.1 --n 32 --distance 8 --dt 50 --out {d}/h1.zarr", "--dt = 50"),
    "hydro --steps -3": ("hydro dipole --alpha -0.1 --n 32 --distance 8 --steps -3 --out {d}/h2.zarr", "steps"),
    "hydro --resume of nothing": ("hydro dipole --alpha -0.1 --out {d}/h3.zarr --resume", "--resume"),
    "hydro --out is a file": ("hydro dipole --alpha -0.1 --n 32 --distance 8 --steps 2 --out {d}/afile", "is a file"),
}


@pytest.mark.parametrize("name", sorted(CLI_CASES))
def test_cli_bad_input_exits_2_with_one_line(name, inputs, capsys):
    argv, text = CLI_CASES[name]
    code = main(argv.format(d=inputs).split())
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    errors = [line for line in err if ": error: " in line]
    assert len(errors) == 1 and text in errors[0], err
    assert not any("Traceback" in line for line in err)


def test_cli_out_checked_before_computing(inputs, monkeypatch):
    import hexatissue.pipeline as pipeline

    monkeypatch.setattr(pipeline, "analyze", lambda *a, **k: pytest.fail("computed before checking --out"))
    assert main(f"analyze {inputs}/labels.npy --out {inputs}/afile".split()) == 2


def test_cli_scheduler_unreachable(inputs, monkeypatch, capsys):
    import dask.distributed

    def refuse(address, **kwargs):
        raise OSError(f"Timed out trying to connect to {address} after 30 s")

    monkeypatch.setattr(dask.distributed, "Client", refuse)
    code = main(f"analyze {inputs}/labels.npy --out {inputs}/o11 --scheduler tcp://127.0.0.1:1".split())
    err = capsys.readouterr().err
    assert code == 2 and "--scheduler 'tcp://127.0.0.1:1'" in err and "Traceback" not in err


def test_cli_debug_shows_the_traceback(inputs):
    with pytest.raises(InputError, match="is a file"):
        main(f"analyze {inputs}/labels.npy --out {inputs}/afile --debug".split())
    with pytest.raises(InputError, match="is a file"):
        main(f"--debug analyze {inputs}/labels.npy --out {inputs}/afile".split())


def test_cli_valid_input_still_works(inputs, capsys):
    assert main(f"analyze {inputs}/labels.npy --out {inputs}/ok".split()) == 0
    assert len(ht.read_results(inputs / "ok").cells) == 16


def test_cli_warnings_are_one_line(tmp_path, capsys):
    np.save(tmp_path / "island.npy", np.kron(island(), np.ones((4, 4), int)))
    assert main(f"analyze {tmp_path}/island.npy --out {tmp_path}/o".split()) == 0
    err = capsys.readouterr().err
    assert "hexatissue analyze: warning: frame 0: some interior cells have no boundary polygon" in err
    assert "warnings.warn" not in err and ".py:" not in err


# ---------------------------------------------------------------------------------------------------
# Worker processes die with their parent
# ---------------------------------------------------------------------------------------------------
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="PR_SET_PDEATHSIG is Linux-only")
def test_pool_workers_die_with_a_killed_parent(tmp_path):
    script = (
        "import numpy as np, hexatissue as ht, sys\n"
        "r = np.arange(256) // 8\n"
        "lab = (r[:, None] * 32 + r[None, :] + 1).astype(np.int32)\n"
        "frames = [lab] * 400\n"
        "sys.stdout.write('start\\n'); sys.stdout.flush()\n"
        "ht.analyze(frames, workers=2, progress=False)\n"
    )
    env = dict(os.environ, PYTHONPATH=str(REPO))
    proc = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, env=env)
    try:
        assert proc.stdout.readline().strip() == b"start"
        children = []
        for _ in range(200):  # wait for the pool (up to 20 s)
            path = Path(f"/proc/{proc.pid}/task/{proc.pid}/children")
            children = [int(c) for c in path.read_text().split()] if path.exists() else []
            if len(children) >= 2:
                break
            time.sleep(0.1)
        assert len(children) >= 2, "the pool did not start"
        proc.send_signal(signal.SIGKILL)
        proc.wait(10)
        deadline = time.monotonic() + 10
        alive = children
        while alive and time.monotonic() < deadline:
            alive = [c for c in alive if Path(f"/proc/{c}").exists()
                     and "zombie" not in Path(f"/proc/{c}/status").read_text().lower()]
            time.sleep(0.1)
        assert not alive, f"workers {alive} outlived their parent"
    finally:
        if proc.poll() is None:
            proc.kill()


def test_a_small_field_of_view_is_analysed_with_a_warning_per_frame_not_refused(tmp_path):
    """Issue 32: a crop with 1-2 interior cells gave 'grid must have at least 2 x 2 nodes' and no table."""
    import tifffile

    sample = Path(__file__).resolve().parents[1] / "hexatissue" / "sample_data" / "epicure_notum" / "013_crop_labels.tif"
    crop = tifffile.imread(sample)[:, 68:127, 0:59]
    with pytest.warns(HexatissueWarning, match=r"grid is only 1 x 1 node\(s\).*no defects"):
        movie = ht.analyze(crop, progress=False, workers=1)
    assert len(movie.grid) and len(movie.defects) == 0 and movie.grid["frame"].nunique() == 11
    tifffile.imwrite(tmp_path / "crop.tif", crop)
    assert main(["analyze", str(tmp_path / "crop.tif"), "--out", str(tmp_path / "out")]) == 0
    assert (tmp_path / "out" / "metadata.json").exists()


def _cli_error(args, capsys):
    """The one-line error of a CLI call that must fail with exit code 2."""
    assert main(args) == 2
    return capsys.readouterr().err.strip().splitlines()[-1]


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs on this system")
def test_a_pipe_given_as_input_is_refused_not_read_forever(tmp_path, capsys):
    os.mkfifo(tmp_path / "labels.tif")
    with pytest.raises(InputError, match="not a regular file or a folder"):
        ht.open_source(tmp_path / "labels.tif")
    assert "not a regular file" in _cli_error(["analyze", str(tmp_path / "labels.tif"), "--out",
                                               str(tmp_path / "o")], capsys)


def test_empty_containers_say_they_are_empty(tmp_path):
    np.save(tmp_path / "zero.npy", np.zeros((0, 10, 10), np.int32))
    with pytest.raises(InputError, match=r"holds no frame \(a stack of 0 images\)"):
        ht.open_source(tmp_path / "zero.npy")
    np.savez(tmp_path / "empty.npz")
    with pytest.raises(InputError, match="holds no array"):
        ht.open_source(tmp_path / "empty.npz")
    np.save(tmp_path / "plain_seg.npy", np.zeros((5, 5)))
    with pytest.raises(InputError, match="holds a plain float64 array of shape \\(5, 5\\): rename it"):
        ht.open_source(tmp_path / "plain_seg.npy").frame(0)


def test_vertices_tables_with_holes_or_crossings_are_refused(tmp_path):
    (tmp_path / "header.csv").write_text("cell,x,y\n")
    with pytest.raises(InputError, match="has no rows"):
        ht.open_source(tmp_path / "header.csv")
    pd.DataFrame({"cell": [1, 1, 1], "x": [0, 1, np.nan], "y": [0, 0, 1]}).to_csv(tmp_path / "nan.csv", index=False)
    with pytest.raises(InputError, match=r"column 'x' is empty, NaN or infinite on row 2 \(cell 1\)"):
        ht.open_source(tmp_path / "nan.csv")
    # a bow-tie: its shoelace area (3.0) is not the area it encloses (3.75)
    bowtie = {1: np.array([[0.0, 0.0], [4.0, 3.0], [4.0, 0.0], [0.0, 2.0]])}
    with pytest.raises(InputError, match="polygon of cell 1 crosses itself"):
        ht.mesh_from_polygons(bowtie)
    square = {1: np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 3.0], [0.0, 3.0]])}
    assert ht.mesh_from_polygons(square).cells["polygon_area"].iloc[0] == 12.0


def test_min_area_is_checked_and_named():
    labels = np.repeat(np.repeat(np.arange(1, 10).reshape(3, 3), 10, 0), 10, 1)
    for value in ("5", True, -1.0, float("nan")):
        with pytest.raises(InputError, match="min_area must be a non-negative number of px"):
            ht.mesh_from_labels(labels, min_area=value)
    with pytest.raises(InputError, match=r"regions smaller than min_area = 1e\+09 px"):
        ht.mesh_from_labels(labels, min_area=10**9)


def test_hydro_flags_out_of_range_are_named(tmp_path, capsys):
    base = ["hydro", "quadrupole", "--alpha", "1", "--n", "64", "--out", str(tmp_path / "h.zarr")]
    assert "--max-time must be a positive simulated time" in _cli_error(base + ["--max-time", "-1"], capsys)
    assert "--orientation-deg must be a finite angle in degrees" in _cli_error(base + ["--orientation-deg", "nan"],
                                                                              capsys)
    assert _cli_error(base + ["--ell", "-3"], capsys).startswith("hexatissue hydro: error: --ell must be a positive")


def test_a_results_table_that_lost_a_column_is_refused(tmp_path, capsys):
    labels = np.repeat(np.repeat(np.arange(1, 26).reshape(5, 5), 12, 0), 12, 1)
    ht.analyze(labels, progress=False, workers=1).write(tmp_path / "res", formats=("csv",))
    cells = pd.read_csv(tmp_path / "res" / "cells.csv")
    cells.drop(columns=["x"]).to_csv(tmp_path / "res" / "cells.csv", index=False)
    with pytest.raises(InputError, match="cells.csv: cells table is missing column 'x'"):
        ht.read_results(tmp_path / "res")
    assert "cells.csv: cells table is missing column 'x'" in _cli_error(["report", str(tmp_path / "res")], capsys)


@pytest.mark.skipif(sys.platform == "win32", reason="no fcntl locks")
def test_an_out_folder_in_use_by_another_run_is_refused(tmp_path, capsys):
    """Issue 32: two analyze runs into one --out both exited 0, the later silently replacing the earlier."""
    from tests.conftest import lock_held_elsewhere

    labels = np.repeat(np.repeat(np.arange(1, 26).reshape(5, 5), 12, 0), 12, 1)
    np.save(tmp_path / "labels.npy", labels)
    with lock_held_elsewhere(tmp_path / "out", ".hexatissue.lock"):  # as a running analysis holds it
        assert "--out folder" in _cli_error(["analyze", str(tmp_path / "labels.npy"), "--out", str(tmp_path / "out")],
                                            capsys)
        assert not (tmp_path / "out" / "metadata.json").exists()
    assert main(["analyze", str(tmp_path / "labels.npy"), "--out", str(tmp_path / "out")]) == 0
    # a run that fails during the analysis does not leave the folder it made behind
    np.save(tmp_path / "empty.npy", np.zeros((2, 30, 30), np.int32))  # no cell: refused frame by frame
    assert main(["analyze", str(tmp_path / "empty.npy"), "--out", str(tmp_path / "new")]) == 2
    assert not (tmp_path / "new").exists()


def _random_crops(stack, n, seed=0):
    """``n`` crops of 40-109 px a side of a (T, rows, cols) label stack, at random places."""
    rng = np.random.default_rng(seed)
    for _ in range(n):
        h, w = rng.integers(40, 110, 2)
        y, x = rng.integers(0, max(1, stack.shape[1] - h)), rng.integers(0, max(1, stack.shape[2] - w))
        yield stack[:, y:y + h, x:x + w]


def _every_crop_is_analysed(stack):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HexatissueWarning)  # small fields: no defects, cells without polygon
        for crop in _random_crops(stack, 40):
            movie = ht.analyze(crop, progress=False, workers=1)
            assert len(movie) == len(crop) and movie.cells["frame"].nunique() == len(crop)


@pytest.mark.slow  # 17-32 s: many crops through analyze
def test_random_crops_of_the_bundled_sample_are_all_analysed():
    """Issue 32: 17 of 80 random crops of the EpiCure stack ended the analysis (too small a Gamma_p grid)."""
    import tifffile

    _every_crop_is_analysed(tifffile.imread(Path(__file__).resolve().parents[1] / "hexatissue" / "sample_data" / "epicure_notum"
                                            / "013_crop_labels.tif"))


@pytest.mark.slow  # 17-32 s: many crops through analyze
def test_random_crops_of_real_stacks_are_all_analysed(real_data):
    from .conftest import real_subdir

    _every_crop_is_analysed(np.load(real_subdir(real_data, "mouse_epidermis_laptrack") / "labels.npy"))
    wing = np.load(real_subdir(real_data, "epitools_wingdisc") / "SegResults_CLabels_RegIm_TYX.npz")["CLabels"]
    _every_crop_is_analysed(wing)


def test_warnings_on_a_folder_name_the_file(tmp_path, capsys):
    """A folder of frames (hexanematic .mat files, image sequences): a warning names the file, not 'frame 35'."""
    import tifffile

    folder = tmp_path / "frames"
    folder.mkdir()
    tifffile.imwrite(folder / "t01.tif", tiles().astype(np.uint16))
    tifffile.imwrite(folder / "t02.tif", np.kron(island(), np.ones((4, 4), int)).astype(np.uint16))
    assert main(f"analyze {folder} --out {tmp_path}/o".split()) == 0
    err = capsys.readouterr().err
    assert "hexatissue analyze: warning: file t02.tif: some interior cells have no boundary polygon" in err


def test_the_bundled_sample_warns_only_about_the_border_cell_its_merge_left_with_two_vertices():
    from hexatissue.samples import sample_path

    with pytest.warns(HexatissueWarning) as record:
        movie = ht.analyze(sample_path("epicure_notum"), workers=1, progress=False)
    texts = [str(w.message) for w in record if "no boundary polygon" in str(w.message)]
    # frame 0: cell 115 touches 104 and, by a junction shorter than merge_distance, 109; merged, it keeps two
    # vertices. Frames 1-2 and 4-7: border cells with one neighbour (two vertices by design): no warning
    assert texts == ["frame 0: some border cells have no boundary polygon: once their junctions shorter than "
                     "merge_distance were merged they kept two vertices (where they meet the outside): n_sides 0, "
                     "no polygon_area, perimeter or shape function (border cells are left out of interior "
                     "statistics)"]
    lost = movie.cells[movie.cells["n_sides"] == 0]
    assert lost["is_border"].all() and set(lost["frame"]) == {0, 1, 2, 4, 5, 6, 7}


def test_results_are_never_written_over_someone_elses_tables(tmp_path, capsys):
    folder = tmp_path / "theirs"
    folder.mkdir()
    (folder / "cells.csv").write_text("their,own\n1,2\n")
    (folder / "notes.txt").write_text("kept")
    np.save(tmp_path / "labels.npy", LAB)
    assert main(f"analyze {tmp_path}/labels.npy --out {folder}".split()) == 2
    assert "holds cells.csv but is not a results folder" in capsys.readouterr().err
    assert sorted(p.name for p in folder.iterdir()) == ["cells.csv", "notes.txt"]
    assert (folder / "cells.csv").read_text() == "their,own\n1,2\n"
    with pytest.raises(InputError, match="not a results folder"):
        movie(1).write(folder)
    # a results folder, or one an interrupted run left (its lock, no metadata.json), is rewritten as before
    assert main(f"analyze {tmp_path}/labels.npy --out {tmp_path}/ours".split()) == 0
    (tmp_path / "ours" / "metadata.json").unlink()
    assert main(f"analyze {tmp_path}/labels.npy --out {tmp_path}/ours".split()) == 0
    assert len(ht.read_results(tmp_path / "ours").cells) == 16
