import numpy as np
import pandas as pd
import pytest
import tifffile

from hexatissue import InputError, read_labels, read_table, write_table, write_tables
from hexatissue.io import atomic_path

from .conftest import png_write


@pytest.mark.parametrize("suffix", [".tif", ".npy", ".npz", ".png", "_seg.npy"])
def test_read_labels_formats(tmp_path, suffix):
    labels = (np.arange(48).reshape(6, 8) % 5).astype(np.uint16)
    path = tmp_path / f"labels{suffix}"
    if suffix == ".tif":
        tifffile.imwrite(path, labels)
    elif suffix == ".npy":
        np.save(path, labels)
    elif suffix == ".npz":
        np.savez(path, labels=labels)
    elif suffix == ".png":
        png_write(path, labels.astype(np.uint8))
    else:  # Cellpose saves a dict with the masks
        np.save(path, {"masks": labels, "outlines": labels * 0}, allow_pickle=True)
    np.testing.assert_array_equal(read_labels(path), labels)


def test_rgb_skeleton_collapses_to_one_channel(tmp_path):
    skeleton = np.zeros((5, 6, 3), np.uint8)
    skeleton[2] = 255
    path = tmp_path / "skel.tif"
    tifffile.imwrite(path, skeleton)
    assert read_labels(path).shape == (5, 6)


def test_read_labels_errors(tmp_path):
    with pytest.raises(InputError, match="does not exist"):
        read_labels(tmp_path / "nope.tif")
    bad = tmp_path / "bad.tif"
    bad.write_bytes(b"not a tiff")
    with pytest.raises(InputError, match="could not read"):
        read_labels(bad)
    other = tmp_path / "labels.txt"
    other.write_text("1 2")
    with pytest.raises(InputError, match="suffix"):
        read_labels(other)


def test_tables_round_trip_atomically(tmp_path):
    df = pd.DataFrame({"cell": [1, 2], "x": [0.5, 1.5], "is_border": [True, False]})
    for name in ("t.parquet", "t.csv"):
        write_table(df, tmp_path / name)
        pd.testing.assert_frame_equal(read_table(tmp_path / name), df)
    paths = write_tables({"cells": df}, tmp_path / "sub", formats=("parquet", "csv"))
    assert sorted(p.name for p in paths) == ["cells.csv", "cells.parquet"]
    with pytest.raises(InputError):
        write_table(df, tmp_path / "t.xlsx")


def test_atomic_path_leaves_nothing_on_error(tmp_path):
    target = tmp_path / "result.txt"
    with pytest.raises(RuntimeError):
        with atomic_path(target) as tmp:
            tmp.write_text("half")
            raise RuntimeError("interrupted")
    assert not target.exists() and list(tmp_path.iterdir()) == []


def test_atomic_dir_replaces_a_folder_whole_or_not_at_all(tmp_path):
    from hexatissue.io import atomic_dir

    target = tmp_path / "store.zarr"
    with atomic_dir(target) as tmp:
        (tmp / "a").write_text("1")
    assert [p.name for p in target.iterdir()] == ["a"]
    with pytest.raises(RuntimeError):
        with atomic_dir(target, overwrite=True) as tmp:
            (tmp / "b").write_text("2")
            raise RuntimeError("interrupted")
    assert [p.name for p in target.iterdir()] == ["a"]  # the old folder is untouched
    with pytest.raises(InputError, match="not an earlier output.*--overwrite"):  # not known as its own output
        with atomic_dir(target) as tmp:
            (tmp / "c").write_text("3")
    assert [p.name for p in target.iterdir()] == ["a"]
    with atomic_dir(target, owned=lambda p: (p / "a").is_file()) as tmp:  # an earlier output: replaced
        (tmp / "c").write_text("3")
    assert [p.name for p in target.iterdir()] == ["c"]
    with atomic_dir(target, overwrite=True) as tmp:
        (tmp / "d").write_text("4")
    assert [p.name for p in target.iterdir()] == ["d"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["store.zarr"]  # no temporary folders left


def test_atomic_dir_never_replaces_a_results_folder_or_a_file(tmp_path):
    from hexatissue.io import atomic_dir

    results = tmp_path / "results"
    results.mkdir()
    (results / "metadata.json").write_text("{}")
    (results / "cells.parquet").write_text("x")
    for overwrite in (False, True):
        with pytest.raises(InputError, match="results folder.*never replaced"):
            with atomic_dir(results, owned=lambda p: True, overwrite=overwrite):
                pass
    assert sorted(p.name for p in results.iterdir()) == ["cells.parquet", "metadata.json"]
    afile = tmp_path / "notes.txt"
    afile.write_text("mine")
    with pytest.raises(InputError, match="a file"):
        with atomic_dir(afile):
            pass
    assert afile.read_text() == "mine"
    empty = tmp_path / "empty"
    empty.mkdir()
    with atomic_dir(empty) as tmp:  # an empty folder holds nothing to lose
        (tmp / "a").write_text("1")
    assert [p.name for p in empty.iterdir()] == ["a"]


def test_write_tiff_round_trips_dtype_and_calibration(tmp_path):
    from hexatissue import open_source
    from hexatissue.io import write_tiff
    from hexatissue.units import Calibration

    stack = (np.arange(2 * 6 * 7, dtype=np.uint32) * 100_000).reshape(2, 6, 7)  # ids beyond uint16
    cal = Calibration(0.5, "um", 10.0, "s")
    write_tiff(tmp_path / "s.tif", stack, cal)
    src = open_source(tmp_path / "s.tif")
    assert src.calibration == cal and src.n_frames == 2
    np.testing.assert_array_equal(src.frame(1), stack[1])
    write_tiff(tmp_path / "one.tif", stack[0].astype(np.uint16))  # uncalibrated single image
    one = open_source(tmp_path / "one.tif")
    assert one.n_frames == 1 and one.calibration == Calibration() and one.frame(0).dtype == np.uint16
    with pytest.raises(InputError, match="array"):
        write_tiff(tmp_path / "bad.tif", np.zeros((2, 2, 2, 2)))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["one.tif", "s.tif"]  # nothing half-written left
