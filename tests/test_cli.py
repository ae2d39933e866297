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
    assert (out / "metadata.json").exists() and (out / "cell_vertices.parquet").exists()
    assert not list(out.glob("*.tmp"))


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
    assert "analyze" in capsys.readouterr().out
