import numpy as np
import pandas as pd
import pytest
import tifffile

from hexatissue.cli import main
from hexatissue.synthetic import jittered_seeds, voronoi_labels

SAMPLE = "sample_data/epicure_notum/013_crop_labels.tif"


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
    from pathlib import Path

    sample = Path(__file__).resolve().parents[1] / SAMPLE
    out = tmp_path / "out"
    assert main(["analyze", str(sample), "--out", str(out), "--format", "parquet", "csv"]) == 0
    cells = pd.read_csv(out / "cells.csv")
    assert sorted(cells["frame"].unique()) == list(range(11))
    per_frame = cells.groupby("frame").size()
    assert (per_frame == [82, 81, 81, 82, 82, 81, 82, 82, 83, 83, 83]).all()  # published counts
    for name in ("cell_vertices", "grid", "defects", "events", "lineage", "cell_events"):
        assert (out / f"{name}.parquet").exists(), name
    assert (out / "metadata.json").exists() and not list(out.glob("*.tmp"))
    # the curated ids are consistent: tracking reproduces them (cells leaving the crop and coming back
    # start new tracks), and the annotated division 73 -> 477 + 490 at frame 3 is found
    assert (cells["track"] == cells["cell"]).mean() > 0.95
    lineage = pd.read_parquet(out / "lineage.parquet").set_index("track")
    assert lineage.loc[477, "parent"] == 73 and lineage.loc[490, "parent"] == 73
    assert lineage.loc[477, "frame_start"] == 3
    defects = pd.read_parquet(out / "defects.parquet")
    assert set(defects["p"]) <= {2, 6} and np.all(np.isin(np.round(defects["charge"] * 6), [-1, 1]) | (defects["p"] == 2))


def test_analyze_figures(tmp_path):
    labels = voronoi_labels(jittered_seeds((120, 150), 14, seed=1), (120, 150))
    path = tmp_path / "labels.npy"
    np.save(path, labels)
    assert main(["analyze", str(path), "--out", str(tmp_path / "out"), "--figures", "--order-p", "6"]) == 0
    pngs = sorted(p.name for p in (tmp_path / "out" / "figures").glob("*.png"))
    assert pngs == ["order6.png", "polygons.png", "stars6.png"]
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
