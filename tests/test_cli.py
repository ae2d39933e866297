import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import tifffile

import hexatissue as ht
from hexatissue.cli import main
from hexatissue.synthetic import jittered_seeds, voronoi_labels

SAMPLE = str(Path(__file__).resolve().parents[1] / "hexatissue" / "sample_data" / "epicure_notum" / "013_crop_labels.tif")


def assert_same_results(cli_dir, api_dir):
    """Two results folders hold identical tables and the same metadata (bar the source path)."""
    a, b = ht.read_results(cli_dir), ht.read_results(api_dir)
    assert set(a.tables) == set(b.tables)
    for name, table in a.tables.items():
        pd.testing.assert_frame_equal(table, b.tables[name], obj=name)
    assert a.metadata() == b.metadata()


def _cellpose_file(tmp_path):
    labels = voronoi_labels(jittered_seeds((90, 120), 15, seed=3), (90, 120))
    path = tmp_path / "img_seg.npy"
    np.save(path, {"masks": labels.astype(np.uint16), "outlines": labels * 0}, allow_pickle=True)
    return path


def _mpf_run(tmp_path):
    from hexatissue.simulate import Params, run_simulation

    path = tmp_path / "run.zarr"
    run_simulation(path, Params(n_cells=6, Lx=48, Ly=44, v0=0.01), steps=60, save_every=10, relax=30, seed=5,
                   progress=False)
    return path


@pytest.mark.parametrize("make", ["sample", "mpf", "cellpose"])
def test_cli_and_library_write_identical_results(tmp_path, make, capsys):
    """hexatissue analyze X --out D == analyze(open_source(X)).write(D) for the bundled sample, an MPF run, Cellpose."""
    path = {"sample": lambda: SAMPLE, "mpf": lambda: _mpf_run(tmp_path), "cellpose": lambda: _cellpose_file(tmp_path)}[make]()
    assert main(["analyze", str(path), "--out", str(tmp_path / "cli"), "--workers", "1"]) == 0
    ht.analyze(ht.open_source(path), workers=1, progress=False).write(tmp_path / "api")
    assert_same_results(tmp_path / "cli", tmp_path / "api")
    back = ht.read_results(tmp_path / "cli")
    assert back.source["path"] == str(path)


def test_epicure_calibration_comes_from_the_tiff_and_can_be_overridden(tmp_path):
    assert main(["analyze", SAMPLE, "--out", str(tmp_path / "a"), "--workers", "1", "--no-fields"]) == 0
    meta = json.loads((tmp_path / "a" / "metadata.json").read_text())
    assert meta["calibration"]["pixel_size"] == 0.2 and meta["calibration"]["length_unit"] == "um"
    assert main(["analyze", SAMPLE, "--out", str(tmp_path / "b"), "--workers", "1", "--no-fields",
                 "--pixel-size", "0.1", "--frame-interval", "5", "--time-unit", "min"]) == 0
    cal = ht.read_results(tmp_path / "b").calibration
    assert cal == ht.Calibration(0.1, "um", 5.0, "min")
    # the tables stay in px whatever the calibration
    pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "a" / "cells.parquet"),
                                  pd.read_parquet(tmp_path / "b" / "cells.parquet"))


def test_analyze_single_image(tmp_path, capsys):
    labels = voronoi_labels(jittered_seeds((90, 120), 15, seed=0), (90, 120), periodic=True)
    path = tmp_path / "labels.tif"
    tifffile.imwrite(path, labels)
    assert main(["analyze", str(path), "--out", str(tmp_path / "out"), "--periodic", "--p", "2", "4", "6"]) == 0
    cells = pd.read_parquet(tmp_path / "out" / "cells.parquet")
    assert len(cells) == labels.max() and {"gamma4_re", "gamma6_im"} <= set(cells.columns)
    edges = pd.read_parquet(tmp_path / "out" / "edges.parquet")
    vertices = pd.read_parquet(tmp_path / "out" / "vertices.parquet")
    assert len(vertices) - len(edges) + len(cells) == 0  # torus
    assert "1 frame(s)" in capsys.readouterr().out


def test_analyze_stack_writes_frame_column(tmp_path):
    out = tmp_path / "out"
    assert main(["analyze", SAMPLE, "--out", str(out), "--format", "parquet", "csv"]) == 0
    cells = pd.read_csv(out / "cells.csv")
    assert sorted(cells["frame"].unique()) == list(range(11))
    per_frame = cells.groupby("frame").size()
    assert (per_frame == [82, 81, 81, 82, 82, 81, 82, 82, 83, 83, 83]).all()  # published counts
    for name in ("cell_vertices", "grid", "defects", "events", "lineage", "cell_events"):
        assert (out / f"{name}.parquet").exists(), name
    assert (out / "metadata.json").exists() and not list(out.glob("*.tmp"))
    # the curated ids are consistent: they are kept (--track auto), and the annotated division
    # 73 -> 477 + 490 at frame 3 is found
    assert (cells["track"] == cells["cell"]).all()
    lineage = pd.read_parquet(out / "lineage.parquet").set_index("track")
    assert lineage.loc[477, "parent"] == 73 and lineage.loc[490, "parent"] == 73
    assert lineage.loc[477, "frame_start"] == 3
    defects = pd.read_parquet(out / "defects.parquet")
    assert set(defects["p"]) <= {2, 6} and np.all(np.isin(np.round(defects["charge"] * 6), [-1, 1]) | (defects["p"] == 2))


def test_analyze_figures(tmp_path):
    labels = voronoi_labels(jittered_seeds((120, 150), 14, seed=1), (120, 150))
    path = tmp_path / "labels.npy"
    np.save(path, labels)
    assert main(["analyze", str(path), "--out", str(tmp_path / "out"), "--figures", "--p", "6"]) == 0
    pngs = sorted(p.name for p in (tmp_path / "out" / "figures").glob("*.png"))
    assert pngs == ["gamma6_defects.png", "polygons.png", "stars6.png"]
    assert all((tmp_path / "out" / "figures" / name).stat().st_size > 10_000 for name in pngs)


def test_analyze_bad_input(tmp_path, capsys):
    assert main(["analyze", str(tmp_path / "missing.tif"), "--out", str(tmp_path / "o")]) == 2
    assert "does not exist" in capsys.readouterr().err
    path = tmp_path / "float.npy"
    np.save(path, np.full((10, 10), 0.5))
    assert main(["analyze", str(path), "--out", str(tmp_path / "o")]) == 2
    assert "non-integer" in capsys.readouterr().err


def test_help_lists_commands(capsys):
    with pytest.raises(SystemExit):
        main(["--help"])
    text = capsys.readouterr().out
    assert "analyze" in text and "hydro" in text


def test_the_command_does_not_import_what_only_other_commands_use(tmp_path):
    """``hexatissue analyze`` of an image never loads OpenCV, scipy.stats or networkx (~50 MB, 0.4 s a call)."""
    import subprocess
    import sys

    labels = voronoi_labels(jittered_seeds((64, 64), 12.0, seed=1), (64, 64))
    np.save(tmp_path / "labels.npy", labels.astype(np.int32))
    code = ("import sys; from hexatissue.cli import main; "
            f"rc = main(['analyze', {str(tmp_path / 'labels.npy')!r}, '--out', {str(tmp_path / 'out')!r}]); "
            "print(rc, *sorted(m for m in ('cv2', 'scipy.stats', 'networkx') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.split("\n")[-2] == "0", out


def test_a_run_that_compiles_says_so_after_checking_its_input(tmp_path, monkeypatch, capsys):
    """On an empty cache a run that compiles (here: every input counts as large) announces it, with the measured
    figure; a small input (references) and a refused input (nothing compiled) print no such message."""
    import hexatissue.mesh
    import hexatissue.pipeline
    from hexatissue.cli import COMPILE_TEXT

    labels = tmp_path / "labels.npy"
    np.save(labels, np.kron(np.arange(1, 10).reshape(3, 3), np.ones((6, 6), int)))
    refused = tmp_path / "float.npy"
    np.save(refused, np.full((10, 10), 0.5))
    monkeypatch.setattr(hexatissue.mesh, "kernels_cached", lambda: False)
    assert main(f"analyze {labels} --out {tmp_path}/small".split()) == 0
    assert "compiling" not in capsys.readouterr().err  # small: the references run, nothing is compiled
    monkeypatch.setattr(hexatissue.pipeline, "REFERENCE_PIXELS", 0)
    assert main(f"analyze {refused} --out {tmp_path}/o".split()) == 2
    err = capsys.readouterr().err
    assert "non-integer" in err and "compiling" not in err
    assert main(f"analyze {labels} --out {tmp_path}/large".split()) == 0
    err = capsys.readouterr().err
    assert "first run on an empty numba cache: compiling the kernels" in err and COMPILE_TEXT in err
    monkeypatch.setattr(hexatissue.mesh, "kernels_cached", lambda: True)
    assert main(f"analyze {labels} --out {tmp_path}/o2".split()) == 0
    assert "compiling" not in capsys.readouterr().err


def test_kernels_cached_reads_numba_s_index():
    from hexatissue.mesh import _kernels, kernels_cached

    _kernels.cell_moments(np.ones((2, 2), np.int32), 2, False)  # compiled or loaded: cached now
    assert kernels_cached()
