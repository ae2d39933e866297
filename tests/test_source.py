"""open_source -> Source: every input kind, laziness, calibration from metadata, overrides and errors."""
import json
import pickle
import tracemalloc
import warnings
from pathlib import Path

import numpy as np
import pytest
import tifffile

from hexatissue import HexatissueWarning, InputError, Source, open_source, read_labels
from hexatissue.units import Calibration

from .conftest import ROOT, png_write, real_subdir

SAMPLE_RUN = ROOT / "hexatissue" / "sample_data" / "mpf_small" / "run.zarr"
SAMPLE_EPICURE = ROOT / "hexatissue" / "sample_data" / "epicure_notum" / "013_crop_labels.tif"


def movie(n=4, rows=6, cols=8, seed=0, dtype=np.uint16, block=4):
    """A T x rows x cols stack of positive labels, different in every frame.

    One id per ``block`` x ``block`` px square, shuffled in each frame: a label image (each id one region) at
    any size; blocks of 16 px or more are cells of a realistic size (most of their pixels inside).
    """
    rng = np.random.default_rng(seed)
    blocks = (-(-rows // block), -(-cols // block))
    ids = np.stack([rng.permutation(blocks[0] * blocks[1]).reshape(blocks) + 1 for _ in range(n)])
    return np.repeat(np.repeat(ids, block, axis=1), block, axis=2)[:, :rows, :cols].astype(dtype)


def assert_frames(source, stack):
    assert source.n_frames == len(source) == len(stack)
    assert source.shape == stack.shape[1:]
    for t in range(len(stack)):
        np.testing.assert_array_equal(source.frame(t), stack[t])
        np.testing.assert_array_equal(source[t], stack[t])
    json.dumps(source.description)  # JSON-serialisable


def assert_reads_one_frame(source, t, stack):
    """frame(t) is right and allocates less than 4 frames' worth of memory; returns the frame."""
    tracemalloc.start()
    try:
        frame = source.frame(t)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    np.testing.assert_array_equal(frame, stack[t])
    assert peak < 4 * stack[0].nbytes < stack.nbytes / 5
    return frame


# -------------------------------------------------------------------------------------------------------------
# arrays and lists
# -------------------------------------------------------------------------------------------------------------
def test_2d_array_is_one_frame():
    image = movie(1)[0]
    s = open_source(image)
    assert isinstance(s, Source)
    assert_frames(s, image[None])
    assert s.box is None and s.ids_consistent is False and s.calibration == Calibration()
    assert s.description["kind"] == "array" and s.description["frame_axis"] is None


def test_3d_array_list_and_tuple():
    stack = movie(5)
    assert_frames(open_source(stack), stack)
    s = open_source(list(stack))
    assert_frames(s, stack)
    assert s.description["kind"] == "list"
    assert_frames(open_source(tuple(stack)), stack)
    assert list(open_source(stack))[2].tolist() == stack[2].tolist()  # iteration gives the frames


def test_array_like_is_read_one_frame_at_a_time():
    stack = movie(6)

    class Lazy:
        shape, dtype = stack.shape, stack.dtype

        def __init__(self):
            self.keys = []

        def __getitem__(self, key):
            self.keys.append(key)
            return stack[key]

    lazy = Lazy()
    s = open_source(lazy)
    assert lazy.keys == []  # opening reads nothing
    np.testing.assert_array_equal(s.frame(4), stack[4])
    assert lazy.keys == [4]


def test_dask_and_zarr_arrays():
    import dask.array as da
    import zarr

    stack = movie(4)
    assert_frames(open_source(da.from_array(stack, chunks=(1, 6, 8))), stack)
    z = zarr.create_array(store={}, shape=stack.shape, chunks=(1, 6, 8), dtype=stack.dtype)
    z[:] = stack
    assert_frames(open_source(z), stack)


def test_channel_of_a_4d_array():
    stack = np.stack([movie(3, seed=1), movie(3, seed=2)], axis=1)  # T x C x Y x X
    with pytest.raises(InputError, match=r"2 channels.*channel=.*with one of \[0, 1\]"):
        open_source(stack)
    s = open_source(stack, channel=1)
    assert_frames(s, stack[:, 1])
    assert s.description["channel"] == 1 and s.description["axes"] == "TCYX"


def test_rgb_arrays_collapse_like_read_labels():
    grey = np.zeros((5, 6, 3), np.uint8)
    grey[1:3] = 7
    np.testing.assert_array_equal(open_source(grey).frame(0), grey[..., 0])
    colour = np.zeros((5, 6, 3), np.uint8)
    colour[0, 0] = (1, 2, 3)
    colour[4, 5] = (0, 0, 9)
    frame = open_source(colour).frame(0)
    assert frame[0, 0] == (1 << 16) | (2 << 8) | 3 and frame[4, 5] == 9 and frame[2, 2] == 0


# -------------------------------------------------------------------------------------------------------------
# files
# -------------------------------------------------------------------------------------------------------------
def test_tiff_stack_and_single_image(tmp_path):
    stack = movie(3)  # 3 frames: photometric given, or tifffile would store them as one planar RGB image
    tifffile.imwrite(tmp_path / "m.tif", stack, photometric="minisblack")
    s = open_source(tmp_path / "m.tif")
    assert_frames(s, stack)
    assert s.description["kind"] == "tiff" and s.description["path"] == str(tmp_path / "m.tif")
    assert s.calibration == Calibration()  # a plain TIFF carries no calibration
    tifffile.imwrite(tmp_path / "one.tiff", stack[0])
    assert_frames(open_source(str(tmp_path / "one.tiff")), stack[:1])


def test_png_grey_16_bit_and_colour(tmp_path):
    image = (movie(1)[0] * 1000).astype(np.uint16)
    png_write(tmp_path / "a.png", image)
    s = open_source(tmp_path / "a.png")
    assert_frames(s, image[None])
    assert s.description["kind"] == "png"
    colour = np.zeros((4, 5, 3), np.uint8)
    colour[:2] = (10, 20, 30)
    colour[2:] = (10, 20, 31)
    png_write(tmp_path / "c.png", colour)
    frame = open_source(tmp_path / "c.png").frame(0)
    assert set(np.unique(frame)) == {(10 << 16) | (20 << 8) | 30, (10 << 16) | (20 << 8) | 31}


def test_npy_is_memory_mapped(tmp_path):
    stack = movie(30, 128, 128, block=16)  # 32 KB per frame, ~1 MB in all
    np.save(tmp_path / "m.npy", stack)
    s = open_source(tmp_path / "m.npy")
    assert s.description["kind"] == "npy"
    frame = assert_reads_one_frame(s, 17, stack)
    frame[0, 0] = 0  # an ordinary writeable array, not the read-only map


def test_cellpose_seg_npy(tmp_path):
    masks, other = movie(1, seed=3)[0], movie(1, seed=4)[0]
    path = tmp_path / "img_seg.npy"
    np.save(path, {"masks": masks, "outlines": other, "filename": "img.tif"}, allow_pickle=True)
    s = open_source(path)
    assert_frames(s, masks[None])
    assert s.description["kind"] == "cellpose" and s.description["key"] == "masks"
    np.testing.assert_array_equal(open_source(path, key="outlines").frame(0), other)
    with pytest.raises(InputError, match=r"key='flows'.*\['masks', 'outlines'\]"):
        open_source(path, key="flows")


def test_npz_default_key_and_errors(tmp_path):
    stack = movie(3)
    np.savez(tmp_path / "a.npz", labels=stack, other=stack[:1])
    assert_frames(open_source(tmp_path / "a.npz"), stack)
    assert_frames(open_source(tmp_path / "a.npz", key="other"), stack[:1])
    np.savez(tmp_path / "b.npz", only=stack)
    assert open_source(tmp_path / "b.npz").description["key"] == "only"
    np.savez(tmp_path / "c.npz", a=stack, b=stack)
    with pytest.raises(InputError, match=r"choose an array with key=.*\['a', 'b'\]"):
        open_source(tmp_path / "c.npz")
    with pytest.raises(InputError, match=r"key='z' is not an array.*\['a', 'b'\]"):
        open_source(tmp_path / "c.npz", key="z")


def test_zarr_array_and_group(tmp_path):
    import zarr

    stack = movie(3)
    z = zarr.create_array(str(tmp_path / "a.zarr"), shape=stack.shape, chunks=(1, 6, 8), dtype=stack.dtype)
    z[:] = stack
    s = open_source(tmp_path / "a.zarr")
    assert_frames(s, stack)
    assert s.description["kind"] == "zarr"
    g = zarr.open_group(str(tmp_path / "g.zarr"), mode="w")
    g.create_array("seg", data=stack, chunks=(1, 6, 8))
    g.create_array("raw", data=stack[:2] * 2, chunks=(1, 6, 8))
    with pytest.raises(InputError, match=r"choose an array with key=.*\['raw', 'seg'\]"):
        open_source(tmp_path / "g.zarr")
    s = open_source(tmp_path / "g.zarr", key="seg")
    assert_frames(s, stack)
    assert s.description["key"] == "seg"
    assert_frames(open_source(zarr.open_group(str(tmp_path / "g.zarr"), mode="r"), key="raw"), stack[:2] * 2)
    with pytest.raises(InputError, match=r"key='nope' is not in it"):
        open_source(tmp_path / "g.zarr", key="nope")


def test_folder_in_natural_order_one_frame_per_file(tmp_path):
    stack = movie(11)
    folder = tmp_path / "frames"
    folder.mkdir()
    for t in range(11):
        tifffile.imwrite(folder / f"frame{t + 1}.tif", stack[t])
    (folder / "notes.txt").write_text("not an image")
    s = open_source(folder)
    assert_frames(s, stack)  # frame2 before frame10
    assert s.description["kind"] == "folder"
    assert [Path(f).name for f in s.description["files"]][:3] == ["frame1.tif", "frame2.tif", "frame3.tif"]
    # a list of paths is the same
    files = [folder / f"frame{t + 1}.tif" for t in range(11)]
    assert_frames(open_source(files), stack)


def test_folder_errors(tmp_path):
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(InputError, match="holds no .tif/.tiff/.png files"):
        open_source(empty)
    beside = tmp_path / "run_folder"  # a folder holding an MPF run, as hexatissue/sample_data/mpf_small does
    (beside / "run.zarr").mkdir(parents=True)
    with pytest.raises(InputError, match=r"pass its path \(.*run\.zarr\)"):
        open_source(beside)
    mixed = tmp_path / "mixed"
    mixed.mkdir()
    tifffile.imwrite(mixed / "a.tif", movie(1)[0])
    png_write(mixed / "b.png", movie(1)[0].astype(np.uint8))
    with pytest.raises(InputError, match="mixes .png and .tif"):
        open_source(mixed)
    sizes = tmp_path / "sizes"
    sizes.mkdir()
    tifffile.imwrite(sizes / "f1.tif", movie(1)[0])
    tifffile.imwrite(sizes / "f2.tif", movie(1, 7, 9)[0])
    s = open_source(sizes)
    s.frame(0)
    with pytest.raises(InputError, match=r"'f2.tif' \(frame 1\) is 7 x 9 px; expected 6 x 8"):
        s.frame(1)
    multi = tmp_path / "multi"
    multi.mkdir()
    tifffile.imwrite(multi / "f1.tif", movie(2), photometric="minisblack")
    with pytest.raises(InputError, match="holds 2 frames; expected one image per file"):
        open_source(multi)


# -------------------------------------------------------------------------------------------------------------
# TIFF: laziness, axes, calibration
# -------------------------------------------------------------------------------------------------------------
def count_page_reads(monkeypatch):
    counts = []
    for cls in (tifffile.TiffPage, tifffile.TiffFrame):
        original = cls.asarray

        def counting(self, *args, _original=original, **kw):
            counts.append(self.index)
            return _original(self, *args, **kw)

        monkeypatch.setattr(cls, "asarray", counting)
    return counts


def test_compressed_tiff_reads_one_page_per_frame(tmp_path, monkeypatch):
    stack = movie(20, 32, 32)
    tifffile.imwrite(tmp_path / "z.tif", stack, compression="zlib", photometric="minisblack")
    reads = count_page_reads(monkeypatch)
    s = open_source(tmp_path / "z.tif")
    assert s.description["tiff_reading"] == "pages"
    assert reads == []
    np.testing.assert_array_equal(s.frame(13), stack[13])
    assert set(reads) == {13}
    np.testing.assert_array_equal(s[-1], stack[-1])
    assert set(reads) == {13, 19}


def test_uncompressed_tiff_is_memory_mapped(tmp_path):
    stack = movie(40, 128, 128, block=16)  # 32 KB per frame
    tifffile.imwrite(tmp_path / "u.tif", stack, photometric="minisblack")
    s = open_source(tmp_path / "u.tif")
    assert s.description["tiff_reading"] == "contiguous"
    assert_reads_one_frame(s, 31, stack)


def test_source_pickles_and_reopens_files(tmp_path):
    stack = movie(5)
    tifffile.imwrite(tmp_path / "z.tif", stack, compression="zlib", photometric="minisblack")
    np.save(tmp_path / "m.npy", stack)
    for path in ("z.tif", "m.npy"):
        s = pickle.loads(pickle.dumps(open_source(tmp_path / path)))
        assert_frames(s, stack)


def test_imagej_calibration(tmp_path):
    stack = movie(3)
    tifffile.imwrite(tmp_path / "ij.tif", stack, imagej=True, resolution=(5, 5),
                     metadata={"unit": "um", "finterval": 2.0, "tunit": "min", "axes": "TYX"})
    s = open_source(tmp_path / "ij.tif")
    assert_frames(s, stack)
    assert s.calibration == Calibration(0.2, "um", 2.0, "min")
    # ImageJ leaves tunit out when it is seconds; micron spelt out
    tifffile.imwrite(tmp_path / "sec.tif", stack, imagej=True, resolution=(4, 4),
                     metadata={"unit": "micron", "finterval": 30, "axes": "TYX"})
    assert open_source(tmp_path / "sec.tif").calibration == Calibration(0.25, "um", 30.0, "s")


def test_imagej_pixel_unit_is_uncalibrated(tmp_path):
    tifffile.imwrite(tmp_path / "px.tif", movie(2), imagej=True, resolution=(5, 5),
                     metadata={"unit": "pixel", "axes": "TYX"})
    s = open_source(tmp_path / "px.tif")
    assert s.calibration == Calibration()
    assert any("pixel size 0.2" in n for n in s.description["notes"])


def test_non_square_pixels_use_x_and_warn(tmp_path):
    tifffile.imwrite(tmp_path / "ns.tif", movie(2), imagej=True, resolution=(5, 4),
                     metadata={"unit": "um", "axes": "TYX"})
    with pytest.warns(HexatissueWarning, match="^non-square pixels: hexatissue uses the x"):
        s = open_source(tmp_path / "ns.tif")
    assert s.calibration.pixel_size == 0.2 and s.calibration.length_unit == "um"


def test_unknown_unit_in_file_warns_and_is_ignored(tmp_path):
    tifffile.imwrite(tmp_path / "ly.tif", movie(2), imagej=True, resolution=(5, 5),
                     metadata={"unit": "lightyear", "axes": "TYX"})
    with pytest.warns(HexatissueWarning, match="unknown length unit 'lightyear'"):
        s = open_source(tmp_path / "ly.tif")
    assert s.calibration == Calibration()
    with pytest.warns(HexatissueWarning, match="unknown length unit"):
        s = open_source(tmp_path / "ly.tif", pixel_size=0.5, length_unit="um")
    assert s.calibration == Calibration(0.5, "um")


def test_ome_tiff_calibration(tmp_path):
    stack = movie(3)
    tifffile.imwrite(tmp_path / "a.ome.tif", stack, ome=True,
                     metadata={"axes": "TYX", "PhysicalSizeX": 0.3, "PhysicalSizeXUnit": "µm", "PhysicalSizeY": 0.3,
                               "PhysicalSizeYUnit": "µm", "TimeIncrement": 1.5, "TimeIncrementUnit": "min"})
    s = open_source(tmp_path / "a.ome.tif")
    assert_frames(s, stack)
    assert s.calibration == Calibration(0.3, "um", 1.5, "min")
    tifffile.imwrite(tmp_path / "nm.ome.tif", stack, ome=True,
                     metadata={"axes": "TYX", "PhysicalSizeX": 250.0, "PhysicalSizeXUnit": "nm"})
    assert open_source(tmp_path / "nm.ome.tif").calibration == Calibration(250.0, "nm")


def test_tcyx_hyperstack_needs_channel(tmp_path):
    stack = np.stack([movie(3, seed=1), movie(3, seed=2)], axis=1)
    tifffile.imwrite(tmp_path / "tc.tif", stack, imagej=True, metadata={"axes": "TCYX"})
    with pytest.raises(InputError, match=r"has 2 channels \(axes 'TCYX'\); pass channel= .*with one of \[0, 1\]"):
        open_source(tmp_path / "tc.tif")
    for c in (0, 1):
        s = open_source(tmp_path / "tc.tif", channel=c)
        assert_frames(s, stack[:, c])
        assert s.description["channel"] == c
    with pytest.raises(InputError, match=r"channel=2 is out of range.*2 channel\(s\), 0 to 1"):
        open_source(tmp_path / "tc.tif", channel=2)
    np.testing.assert_array_equal(read_labels(tmp_path / "tc.tif", channel=1), stack[:, 1])


def test_z_is_time_when_there_is_no_t(tmp_path):
    stack = movie(3)
    tifffile.imwrite(tmp_path / "z.tif", stack, imagej=True, metadata={"axes": "ZYX"})
    s = open_source(tmp_path / "z.tif")
    assert_frames(s, stack)
    assert s.description["frame_axis"] == "Z"
    assert "the Z axis (3) is read as time: there is no T axis" in s.description["notes"]
    tifffile.imwrite(tmp_path / "tz.tif", np.stack([stack, stack]), imagej=True, metadata={"axes": "TZYX"})
    with pytest.raises(InputError, match=r"both a T axis \(2\) and a Z axis \(3\)"):
        open_source(tmp_path / "tz.tif")


def test_rgb_tiff_pages_collapse(tmp_path):
    skeleton = np.zeros((2, 5, 6, 3), np.uint8)
    skeleton[:, 2] = 255
    tifffile.imwrite(tmp_path / "rgb.tif", skeleton, photometric="rgb")
    s = open_source(tmp_path / "rgb.tif")
    assert s.n_frames == 2 and s.shape == (5, 6)
    np.testing.assert_array_equal(s.frame(1), skeleton[1, ..., 0])


def test_big_endian_and_one_bit_tiffs(tmp_path):
    stack = movie(3, dtype=">u2")
    tifffile.imwrite(tmp_path / "be.tif", stack, byteorder=">", photometric="minisblack")
    s = open_source(tmp_path / "be.tif")
    assert s.description["tiff_reading"] == "contiguous"
    assert_frames(s, stack)
    assert s.frame(0).dtype == np.dtype("=u2")  # native byte order for the kernels
    bits = np.zeros((3, 9, 10), bool)
    bits[:, 2:5, 3:7] = True
    bits[1, 0, 0] = True
    tifffile.imwrite(tmp_path / "bits.tif", bits, photometric="minisblack")  # 1 bit per pixel: read page by page
    s = open_source(tmp_path / "bits.tif")
    assert_frames(s, bits.astype(np.uint8))
    assert s.frame(1).dtype == np.uint8


# -------------------------------------------------------------------------------------------------------------
# OME-Zarr and MPF runs
# -------------------------------------------------------------------------------------------------------------
def write_ome_zarr(path, levels, axes, scales, zarr_format=2):
    """A hand-made NGFF image: ``levels`` arrays at paths "0", "1", ... with per-level scale transforms."""
    import zarr

    g = zarr.open_group(str(path), mode="w", zarr_format=zarr_format)
    for i, data in enumerate(levels):
        g.create_array(str(i), data=data, chunks=(1,) * (data.ndim - 2) + data.shape[-2:])
    multiscales = [{
        "version": "0.4", "name": "labels", "axes": axes,
        "datasets": [{"path": str(i), "coordinateTransformations": [{"type": "scale", "scale": s}]}
                     for i, s in enumerate(scales)],
    }]
    if zarr_format == 2:
        g.attrs["multiscales"] = multiscales
    else:
        g.attrs["ome"] = {"version": "0.5", "multiscales": multiscales}
    return g


AXES_TCYX = [{"name": "t", "type": "time", "unit": "minute"}, {"name": "c", "type": "channel"},
             {"name": "y", "type": "space", "unit": "micrometer"}, {"name": "x", "type": "space", "unit": "micrometer"}]


def test_ome_zarr_levels_and_scale(tmp_path):
    full = movie(3, 8, 10)[:, None]  # T x C=1 x Y x X
    half = full[..., ::2, ::2]
    write_ome_zarr(tmp_path / "img.ome.zarr", [full, half], AXES_TCYX,
                   [[2.0, 1.0, 0.5, 0.5], [2.0, 1.0, 1.0, 1.0]])
    s = open_source(tmp_path / "img.ome.zarr")
    assert_frames(s, full[:, 0])
    assert s.calibration == Calibration(0.5, "um", 2.0, "min")
    assert s.description["kind"] == "ome-zarr" and s.description["level"] == 0 and s.description["n_levels"] == 2
    s1 = open_source(tmp_path / "img.ome.zarr", level=1)
    assert_frames(s1, half[:, 0])
    assert s1.calibration == Calibration(1.0, "um", 2.0, "min")
    with pytest.raises(InputError, match=r"level=2 is out of range.*2 level\(s\), 0 to 1"):
        open_source(tmp_path / "img.ome.zarr", level=2)


def test_ome_zarr_0_5_with_channels_and_a_label_subgroup(tmp_path):
    data = np.stack([movie(2, seed=1), movie(2, seed=2)], axis=1)  # T x C=2 x Y x X
    root = write_ome_zarr(tmp_path / "v5.zarr", [data], AXES_TCYX, [[1.0, 1.0, 0.25, 0.25]], zarr_format=3)
    with pytest.raises(InputError, match="2 channels"):
        open_source(tmp_path / "v5.zarr")
    assert_frames(open_source(tmp_path / "v5.zarr", channel=1), data[:, 1])
    # an NGFF label image in labels/cells, selected with key=
    cells = movie(2, seed=5)
    lg = root.require_group("labels")
    lg.attrs["labels"] = ["cells"]
    write_ome_zarr(tmp_path / "v5.zarr" / "labels" / "cells", [cells],
                   [{"name": "t", "type": "time"}, {"name": "y", "type": "space"}, {"name": "x", "type": "space"}],
                   [[1.0, 1.0, 1.0]], zarr_format=3)
    assert open_source(tmp_path / "v5.zarr", channel=0).description["ngff_labels"] == ["labels/cells"]
    s = open_source(tmp_path / "v5.zarr", key="labels/cells")
    assert_frames(s, cells)
    assert s.calibration == Calibration()  # no units on these axes


@pytest.fixture
def sample_run():
    if not SAMPLE_RUN.is_dir():
        pytest.skip("hexatissue/sample_data/mpf_small/run.zarr is absent")
    return SAMPLE_RUN


def test_mpf_run_store_and_run_object(sample_run):
    from hexatissue.simulate import read_run

    run = read_run(sample_run)
    for obj in (sample_run, str(sample_run), run):
        s = open_source(obj)
        assert s.n_frames == 301 and s.shape == (151, 140)
        assert s.ids_consistent is True and s.box == run.box
        assert s.calibration == Calibration(frame_interval=200.0, time_unit="iteration")
        assert s.description["kind"] == "mpf_run" and s.description["save_every"] == 200
        np.testing.assert_array_equal(s.frame(150), np.asarray(run.labels[150]))
        json.dumps(s.description)
    with pytest.raises(InputError, match="key='labels' means nothing for an MPF run store"):
        open_source(sample_run, key="labels")


# -------------------------------------------------------------------------------------------------------------
# calibration overrides
# -------------------------------------------------------------------------------------------------------------
def test_overrides(tmp_path):
    stack = movie(2)
    with pytest.raises(InputError, match="pixel_size=0.5 was given but there is no length unit.*length_unit="):
        open_source(stack, pixel_size=0.5)
    with pytest.raises(InputError, match="frame_interval=3 was given but there is no time unit.*time_unit="):
        open_source(stack, frame_interval=3)
    s = open_source(stack, pixel_size=0.5, length_unit="micron", frame_interval=3, time_unit="seconds")
    assert s.calibration == Calibration(0.5, "um", 3.0, "s")
    tifffile.imwrite(tmp_path / "ij.tif", stack, imagej=True, resolution=(5, 5),
                     metadata={"unit": "um", "finterval": 2.0, "tunit": "min", "axes": "TYX"})
    # a number alone is in the file's unit; "px" / "frame" drop a calibration
    assert open_source(tmp_path / "ij.tif", pixel_size=0.4).calibration == Calibration(0.4, "um", 2.0, "min")
    assert open_source(tmp_path / "ij.tif", length_unit="px", time_unit="frame").calibration == Calibration()
    s = open_source(tmp_path / "ij.tif")
    t = s.with_calibration(frame_interval=10, time_unit="s")
    assert t.calibration == Calibration(0.2, "um", 10.0, "s") and s.calibration.frame_interval == 2.0
    np.testing.assert_array_equal(t.frame(1), stack[1])
    assert open_source(s) is s
    assert open_source(s, pixel_size=0.1).calibration.pixel_size == 0.1


# -------------------------------------------------------------------------------------------------------------
# errors
# -------------------------------------------------------------------------------------------------------------
def test_path_errors(tmp_path):
    with pytest.raises(InputError, match="does not exist"):
        open_source(tmp_path / "nope.tif")
    (tmp_path / "a.txt").write_text("1 2")
    with pytest.raises(InputError, match=r"unknown suffix '.txt'"):
        open_source(tmp_path / "a.txt")
    for name in ("bad.tif", "bad.png", "bad.npy", "bad.npz"):
        (tmp_path / name).write_bytes(b"not an image")
        with pytest.raises(InputError, match="could not read label image"):
            open_source(tmp_path / name)
    (tmp_path / "x.zarr").mkdir()
    with pytest.raises(InputError, match="is not a zarr store"):
        open_source(tmp_path / "x.zarr")


def test_shape_errors():
    with pytest.raises(InputError, match="the list of frames is empty"):
        open_source([])
    with pytest.raises(InputError, match=r"frames\[0\] is \(6, 8\) but frames\[1\] is \(5, 8\)"):
        open_source([np.ones((6, 8), int), np.ones((5, 8), int)])
    with pytest.raises(InputError, match=r"frames\[0\] has shape \(4,\)"):
        open_source([np.ones(4, int)])
    with pytest.raises(InputError, match=r"array has shape \(5,\)"):
        open_source(np.ones(5, int))
    with pytest.raises(InputError, match=r"array has shape \(2, 2, 2, 5, 5\)"):
        open_source(np.ones((2, 2, 2, 5, 5), int))
    with pytest.raises(InputError, match="obj must be a path, an array"):
        open_source(42)


def test_frame_index_errors():
    s = open_source(movie(3))
    with pytest.raises(InputError, match=r"frame index 3 is out of range.*3 frame\(s\), indices 0 to 2"):
        s.frame(3)
    with pytest.raises(InputError, match="out of range"):
        s[-4]
    with pytest.raises(InputError, match="frame index must be an integer"):
        s[1.0]
    np.testing.assert_array_equal(s[np.int64(-1)], movie(3)[2])


def test_bad_frame_content_is_reported_with_its_index():
    stack = movie(3)
    stack[1] = 0
    s = open_source(stack)
    with pytest.raises(InputError, match="frame 1 is all zeros"):
        s.frame(1)


def test_key_channel_level_where_they_mean_nothing(tmp_path):
    stack = movie(2)
    tifffile.imwrite(tmp_path / "m.tif", stack, photometric="minisblack")
    png_write(tmp_path / "p.png", stack[0].astype(np.uint8))
    np.save(tmp_path / "m.npy", stack)
    cases = [
        (stack, {"key": "a"}, "key='a' means nothing for an array"),
        (stack, {"level": 1}, "level=1 means nothing for an array"),
        (stack, {"channel": 0}, r"channel=0 was given but the array has no channel \(C\) axis"),
        (list(stack), {"channel": 0}, "channel=0 means nothing for a list of 2-D arrays"),
        (tmp_path / "m.tif", {"key": "a"}, "key='a' means nothing for a TIFF file"),
        (tmp_path / "m.tif", {"level": 0}, "level=0 means nothing for a TIFF file"),
        (tmp_path / "m.tif", {"channel": 1}, "has no channel"),
        (tmp_path / "p.png", {"channel": 0}, "channel=0 means nothing for a PNG file"),
        (tmp_path / "m.npy", {"key": "a"}, r"key='a' means nothing for a .npy file \(it holds one array\)"),
        (open_source(stack), {"channel": 0}, "means nothing for a Source that is already open"),
    ]
    for obj, kw, message in cases:
        with pytest.raises(InputError, match=message):
            open_source(obj, **kw)
    with pytest.raises(InputError, match="channel must be a non-negative integer"):
        open_source(stack, channel=-1)
    with pytest.raises(InputError, match="key must be a str"):
        open_source(stack, key=3)


def test_read_labels_is_eager_and_matches_the_source(tmp_path):
    stack = movie(4)
    tifffile.imwrite(tmp_path / "m.tif", stack, compression="zlib", photometric="minisblack")
    out = read_labels(tmp_path / "m.tif")
    assert isinstance(out, np.ndarray) and out.shape == stack.shape
    np.testing.assert_array_equal(out, stack)
    np.save(tmp_path / "one.npy", stack[:1])
    assert read_labels(tmp_path / "one.npy").shape == (1, 6, 8)  # a stored frame axis is kept
    floats = stack.astype(np.float32)
    tifffile.imwrite(tmp_path / "f.tif", floats, photometric="minisblack")
    assert read_labels(tmp_path / "f.tif").dtype == np.float32  # as stored; Source.frame validates
    assert open_source(tmp_path / "f.tif").frame(0).dtype == np.int64


# -------------------------------------------------------------------------------------------------------------
# real files
# -------------------------------------------------------------------------------------------------------------
def check_epicure_labels(path):
    s = open_source(path)
    assert s.calibration.pixel_size == 0.2 and s.calibration.length_unit == "um"
    # no frame interval in the file: the sample's documented 300 s (the same bytes as the bundled sample)
    assert (s.calibration.frame_interval, s.calibration.time_unit, s.calibration.time_from) == (300.0, "s", "sample")
    assert s.n_frames == 11 and s.shape == (160, 257)
    with tifffile.TiffFile(path) as tf:
        np.testing.assert_array_equal(s.frame(10), tf.pages[10].asarray().astype(np.int64))


def test_epicure_sample_is_calibrated_from_its_imagej_tags():
    if not SAMPLE_EPICURE.is_file():
        pytest.skip("hexatissue/sample_data/epicure_notum/013_crop_labels.tif is absent")
    check_epicure_labels(SAMPLE_EPICURE)


def test_real_epicure_files(real_data):
    folder = real_subdir(real_data, "epicure_notum")
    check_epicure_labels(folder / "013_crop_labels.tif")
    raw = open_source(folder / "003_crop.tif")  # ImageJ unit "\u00B5m", 3.636363 px/um, finterval 300 s
    assert raw.calibration == Calibration(0.275, "um", 300.0, "s")
    seg = open_source(folder / "003_crop_epyseg.tif")  # EpySeg saved the 11 time points as Z slices
    assert seg.n_frames == 11 and seg.description["frame_axis"] == "Z"
    with pytest.raises(InputError, match="2 channels"):
        open_source(folder / "area3_Composite.tif")
    composite = open_source(folder / "area3_Composite.tif", channel=1)  # unit "pixel": no length calibration
    assert composite.n_frames == 5 and composite.calibration == Calibration(frame_interval=300.0, time_unit="s")
    assert open_source(folder / "static_image.tif").calibration.pixel_size == 0.2306294


def test_real_ome_and_shaped_tiffs(real_data):
    epitools = real_subdir(real_data, "epitools_wingdisc")
    # PartSeg wrote OME-XML with PhysicalSizeX="1.0000000000000002" µm
    s = open_source(epitools / "test_image-projected-segmented.tif")
    assert s.calibration == Calibration(1.0, "um") and s.n_frames == 1 and s.shape == (199, 206)
    itasc = real_subdir(real_data, "itasc_micropattern")
    s = open_source(itasc / "pos00" / "cell_labels.tif")  # tifffile "shaped" file, axis Q
    assert s.n_frames == 10 and s.description["frame_axis"] == "Q"
    with pytest.raises(InputError, match=r"both a T axis \(10\) and a Z axis \(4\)"):
        open_source(itasc / "pos00" / "cell_raw.tif")


def test_real_imagej_header_promising_missing_pages(real_data):
    folder = real_subdir(real_data, "skeletor_pupal_abdomen")
    with pytest.warns(HexatissueWarning, match="ImageJ header says 4 images but the file holds 1 page"):
        s = open_source(folder / "Images" / "Frame_1.tif")
    assert s.n_frames == 1 and s.shape == (1027, 1931)
    with pytest.raises(InputError, match="does not look like a label image"):  # it is the raw microscopy frame
        s.frame(0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        skeletons = open_source(folder / "Final_Skeleton")
    assert skeletons.n_frames == 4 and skeletons.shape == (1027, 1931)
    assert Path(skeletons.description["files"][3]).name == "Final_Skeleton_Frame_4.tif"


def test_recorded_labels_reopen_the_recorded_path_with_its_key_channel_and_level_or_say_why_not(tmp_path):
    from hexatissue.source import MISSING, NOT_A_FILE, recorded_labels

    stack = np.arange(2 * 4 * 5).reshape(2, 4, 5) % 7
    np.savez(tmp_path / "two.npz", other=stack + 1, labels=stack)
    source = open_source(tmp_path / "two.npz", key="other")
    back, why = recorded_labels(json.loads(json.dumps(source.description)))  # as metadata.json gives it back
    assert why is None and back.description["key"] == "other"
    np.testing.assert_array_equal(np.stack(list(back)), stack + 1)
    for desc in (None, {}, {"kind": "array", "path": None}):
        assert recorded_labels(desc) == (None, NOT_A_FILE)
    assert recorded_labels({**source.description, "path": str(tmp_path / "moved.npz")}) == (None, MISSING)
    (tmp_path / "bad.npz").write_bytes(b"not a zip")
    with pytest.raises(InputError, match="bad.npz"):  # there, but unreadable: open_source's error
        recorded_labels({"kind": "npz", "path": str(tmp_path / "bad.npz")})


def test_recorded_mask_is_read_again_from_its_path_or_none(tmp_path):
    from hexatissue.source import read_mask, recorded_mask

    inside = np.zeros((6, 7), bool)
    inside[1:5, 2:6] = True
    tifffile.imwrite(tmp_path / "mask.tif", inside.astype(np.uint8))
    info = read_mask(tmp_path / "mask.tif", (6, 7))[1]
    mask, got = recorded_mask({"path": "x.tif", "mask": info}, (6, 7))
    assert got == info
    np.testing.assert_array_equal(mask, inside)
    for desc in (None, {}, {"path": "x.tif", "mask": None}):
        assert recorded_mask(desc, (6, 7)) == (None, None)
    array_info = read_mask(inside, (6, 7))[1]
    assert recorded_mask({"mask": array_info}, (6, 7)) == (None, array_info)  # an array: not held, not read
    with pytest.raises(InputError, match=r"mask must have the shape of the labels \(6, 8\)"):
        recorded_mask({"mask": info}, (6, 8))


def test_axes_name_the_dimensions_of_a_plain_zarr_array(tmp_path):
    """A zarr array of 4 frames 3 px wide looks like one RGB image: --axes TYX says which (it was refused before)."""
    import zarr

    from hexatissue.cli import main

    stack = np.tile(np.array([[1, 2, 3]], np.int32), (4, 20, 1))
    z = zarr.create_array(tmp_path / "thin.zarr", shape=stack.shape, dtype=stack.dtype)
    z[:] = stack
    with pytest.warns(HexatissueWarning, match="axes='TYX'"):
        assert open_source(tmp_path / "thin.zarr").n_frames == 1
    source = open_source(tmp_path / "thin.zarr", axes="TYX")
    assert source.n_frames == 4 and source.shape == (20, 3)
    np.testing.assert_array_equal(source.frame(2), stack[2])
    group = zarr.open_group(tmp_path / "g.zarr", mode="w")
    group.create_array("labels", shape=stack.shape, dtype=stack.dtype)[:] = stack
    assert open_source(group, axes="TYX").n_frames == 4
    assert main(f"analyze {tmp_path}/thin.zarr --axes TYX --out {tmp_path}/o".split()) == 0
    with pytest.raises(InputError, match="axes='TYX' means nothing for a folder"):
        open_source(tmp_path, axes="TYX")


def test_gzipped_files_are_read_through_and_named_by_their_own_path(tmp_path):
    import gzip

    import tifffile

    stack = (np.arange(3 * 8 * 9, dtype=np.uint16) % 7 + 1).reshape(3, 8, 9)
    tifffile.imwrite(tmp_path / "s.tif", stack, photometric="minisblack")
    np.save(tmp_path / "a.npy", stack[0])
    for name in ("s.tif", "a.npy"):
        (tmp_path / f"{name}.gz").write_bytes(gzip.compress((tmp_path / name).read_bytes()))
    src = open_source(tmp_path / "s.tif.gz")
    assert src.n_frames == 3 and src.description["path"] == str(tmp_path / "s.tif.gz")
    assert any("gzip" in note for note in src.description["notes"])
    np.testing.assert_array_equal(np.stack([src.frame(t) for t in range(3)]), stack)
    np.testing.assert_array_equal(open_source(tmp_path / "a.npy.gz").frame(0),
                                  stack[0])
    (tmp_path / "cut.tif.gz").write_bytes((tmp_path / "s.tif.gz").read_bytes()[:60])
    with pytest.raises(InputError, match=r"cut\.tif\.gz' could not be decompressed"):
        open_source(tmp_path / "cut.tif.gz")
    (tmp_path / "plain.tif.gz").write_bytes((tmp_path / "s.tif").read_bytes())
    with pytest.raises(InputError, match=r"ends in \.gz but is not gzip data"):
        open_source(tmp_path / "plain.tif.gz")
    (tmp_path / "x.txt.gz").write_bytes(gzip.compress(b"hello"))
    with pytest.raises(InputError, match=r"x\.txt\.gz' is gzip-compressed \.txt; expected"):
        open_source(tmp_path / "x.txt.gz")


def test_a_tiff_written_page_by_page_is_read_frame_by_frame(tmp_path):
    # tifffile.TiffWriter.write once per frame: 240 one-page series (was read as its first frame)
    stack = np.random.default_rng(0).integers(1, 50, size=(240, 12, 10)).astype(np.uint16)
    with tifffile.TiffWriter(tmp_path / "pages.tif") as tw:
        for frame in stack:
            tw.write(frame)
    src = open_source(tmp_path / "pages.tif")
    assert src.n_frames == 240 and src.shape == (12, 10)
    np.testing.assert_array_equal(np.stack([src.frame(t) for t in range(240)]), stack)
    assert any("240 image series of one page each" in note for note in src.description["notes"])
    # series of different shapes: series 0 is read, and a warning says what was left
    with tifffile.TiffWriter(tmp_path / "mixed.tif") as tw:
        tw.write(stack[0])
        tw.write(stack[1, :5, :5])
    with pytest.warns(HexatissueWarning, match=r"holds 2 image series \(YX \(12, 10\); YX \(5, 5\)\); only series 0"):
        mixed = open_source(tmp_path / "mixed.tif")
    assert mixed.n_frames == 1


def test_an_imagej_header_that_undercounts_the_pages_is_warned_and_every_page_read(tmp_path):
    stack = (np.arange(4 * 6 * 7, dtype=np.uint16) % 11 + 1).reshape(4, 6, 7)
    with tifffile.TiffWriter(tmp_path / "ij.tif") as tw:  # a header for 2 frames on a file of 4 pages
        for t, frame in enumerate(stack):
            tw.write(frame, description="ImageJ=1.11a\nimages=2\nframes=2\n" if t == 0 else None, metadata=None)
    assert tifffile.TiffFile(tmp_path / "ij.tif").series[0].shape == (2, 6, 7)  # what tifffile alone gives
    with pytest.warns(HexatissueWarning, match=r"ImageJ header says 2 image\(s\) \(axes 'TYX'\) but the file holds "
                                               r"4 pages"):
        src = open_source(tmp_path / "ij.tif")
    np.testing.assert_array_equal(np.stack([src.frame(t) for t in range(src.n_frames)]), stack)
