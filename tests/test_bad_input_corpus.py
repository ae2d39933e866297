"""A generated corpus of bad and odd inputs through the real entry points (slow job).

Every case runs in its own temporary folder through ``hexatissue.analyze``,
``hexatissue.open_source`` or the command (``hexatissue.cli.main``: the code
of ``hexatissue analyze|report|export``) and has one expected outcome:

- ``error``: an :class:`~hexatissue.InputError` (the command: exit 2 and one
  ``error:`` line) whose message holds the given texts (the argument and
  what was wrong);
- ``ok``: a result, with no warning, and checked where a truth is known
  (the 16 cells of the tiling every array case is made from);
- ``warn``: a result with a :class:`~hexatissue.HexatissueWarning` holding
  the given text.

Any other exception (a traceback) or warning fails the case, as does running past the
per-case timeout (a hang), or any change to a file that was there before the
case other than the outputs it names.  The options cases are built from
``options.OPTION_CLASSES``: a numeric field added to a stage's options is
covered by the generic values at once and fails until its expected outcomes
at 0 and at a huge value are written into ``ZERO`` and ``HUGE``.

``docs/input.md`` holds the table of classes and counts this module builds;
``test_docs_table_matches_the_corpus`` checks it.
"""
from __future__ import annotations

import contextlib
import gzip
import hashlib
import importlib.util
import io
import math
import os
import warnings
from collections import Counter
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np
import pytest

import hexatissue as ht
from hexatissue import HexatissueWarning, InputError
from hexatissue.cli import main
from hexatissue.options import OPTION_CLASSES

pytestmark = [pytest.mark.slow, pytest.mark.timeout(240)]

REPO = Path(__file__).resolve().parents[1]


def tiles(n=4, size=8):
    """n x n square cells of size x size px, ids 1..n^2 (the truth of every array case: 16 cells)."""
    r = np.arange(n * size) // size
    return (r[:, None] * n + r[None, :] + 1).astype(np.int32)


LAB = tiles()
STACK = np.stack([LAB, LAB, LAB])


@dataclass
class Case:
    cls: str          # class of input (the rows of the table in docs/input.md)
    name: str
    run: object       # run(d): the call, in the case's folder d
    expect: str       # "error", "ok" or "warn"
    texts: tuple = ()  # texts the error or warning must hold
    setup: object = None  # setup(d): writes the inputs before the snapshot
    writes: tuple = ("out",)  # paths (relative to d) the case may create or change
    check: object = None  # check(result): the truth of a valid result
    documented: str = ""  # the outcome counted in docs/input.md when it differs (an optional dependency missing)
    keep: tuple = ()  # paths under ``writes`` that must stay as they were (someone else's files)


CASES: dict[str, Case] = {}


def add(cls, name, run, expect, *texts, setup=None, writes=("out",), check=None, documented="", keep=()):
    key = f"{cls}: {name}"
    assert key not in CASES, key
    CASES[key] = Case(cls, name, run, expect, texts, setup, writes, check, documented or expect, keep)


def cells_per_frame(n):
    """A check: every frame of the result holds n cells."""
    def check(movie):
        counts = movie.cells.groupby("frame").size()
        assert len(counts) == len(movie) and (counts == n).all(), counts.to_dict()
    return check


def cli(*argv):
    """A case's run: the command with ``{d}`` in its arguments replaced by the case's folder."""
    return lambda d: ("cli", [str(a).format(d=d) for a in argv])


# ---------------------------------------------------------------------------------------------------
# arrays: shapes, dtypes, values
# ---------------------------------------------------------------------------------------------------
def _obj(values):
    out = np.empty(values.shape, dtype=object)
    for idx in np.ndindex(values.shape):
        out[idx] = values[idx].item()
    return out


def _rgb(alpha):
    colours = np.random.default_rng(1).integers(0, 256, (17, 3), dtype=np.uint8)
    img = colours[LAB]
    return np.dstack([img, np.full(LAB.shape, 255, np.uint8)]) if alpha else img


def _noise():
    return np.random.default_rng(2).integers(0, 4000, (80, 80)).astype(np.uint16)


def _white_membranes():
    lab = np.kron(tiles(4, 1), np.ones((9, 9), np.int32)).astype(np.uint8)
    lab[::9, :] = 255
    lab[:, ::9] = 255
    return lab


ARRAYS = {
    # name: (array maker, analyze outcome, texts, open_source outcome, texts, n cells per frame when valid)
    "int32 tiles": (lambda: LAB, "ok", (), "ok", (), 16),
    "uint8": (lambda: LAB.astype(np.uint8), "ok", (), "ok", (), 16),
    "uint16": (lambda: LAB.astype(np.uint16), "ok", (), "ok", (), 16),
    "int8": (lambda: LAB.astype(np.int8), "ok", (), "ok", (), 16),
    "int16": (lambda: LAB.astype(np.int16), "ok", (), "ok", (), 16),
    "int64": (lambda: LAB.astype(np.int64), "ok", (), "ok", (), 16),
    "uint32": (lambda: LAB.astype(np.uint32), "ok", (), "ok", (), 16),
    "uint64": (lambda: LAB.astype(np.uint64), "ok", (), "ok", (), 16),
    "big-endian int32": (lambda: LAB.astype(">i4"), "ok", (), "ok", (), 16),
    "big-endian uint16": (lambda: LAB.astype(">u2"), "ok", (), "ok", (), 16),
    "float64 whole numbers": (lambda: LAB.astype(float), "ok", (), "ok", (), 16),
    "float32 whole numbers": (lambda: LAB.astype(np.float32), "ok", (), "ok", (), 16),
    "float16 whole numbers": (lambda: LAB.astype(np.float16), "ok", (), "ok", (), 16),
    "Fortran order": (lambda: np.asfortranarray(LAB), "ok", (), "ok", (), 16),
    "transposed view": (lambda: LAB.T, "ok", (), "ok", (), 16),
    "every other pixel (strided view)": (lambda: np.repeat(np.repeat(LAB, 2, 0), 2, 1)[::2, ::2], "ok", (), "ok",
                                         (), 16),
    "read-only": (lambda: _readonly(LAB), "ok", (), "ok", (), 16),
    "ids 2**40 apart": (lambda: LAB.astype(np.int64) * 2**40, "ok", (), "ok", (), 16),
    "ids near 2**62": (lambda: LAB.astype(np.int64) + 2**62, "ok", (), "ok", (), 16),
    "uint64 ids >= 2**63": (lambda: LAB.astype(np.uint64) + np.uint64(2**63), "error", ("2**63",), "error",
                            ("2**63",), 0),
    "int64 min": (lambda: np.where(LAB == 1, np.iinfo(np.int64).min, LAB.astype(np.int64)), "error",
                  ("negative",), "error", ("negative",), 0),
    "negative ids": (lambda: LAB - 3, "error", ("negative",), "error", ("negative",), 0),
    "NaN pixel": (lambda: np.where(LAB == 1, np.nan, LAB.astype(float)), "error", ("NaN",), "error", ("NaN",), 0),
    "inf pixel": (lambda: np.where(LAB == 1, np.inf, LAB.astype(float)), "error", ("inf",), "error", ("inf",), 0),
    "-inf pixel": (lambda: np.where(LAB == 1, -np.inf, LAB.astype(float)), "error", ("inf",), "error", ("inf",),
                   0),
    "fractional floats": (lambda: LAB + 0.5, "error", ("non-integer",), "error", ("non-integer",), 0),
    "float ids beyond 2**53": (lambda: LAB.astype(float) + 2.0**60, "error", ("below 2**31",), "error",
                               ("below 2**31",), 0),
    "probability map in [0, 1]": (lambda: np.random.default_rng(3).random((80, 80)), "error", ("membrane-map",),
                                  "error", ("membrane-map",), 0),
    "complex": (lambda: LAB.astype(complex), "error", ("integer",), "error", ("integer",), 0),
    "object array of ints": (lambda: _obj(LAB), "error", ("object",), "error", ("object",), 0),
    "object array of mixed values": (lambda: _mixed(), "error", ("object",), "error", ("object",), 0),
    "strings": (lambda: LAB.astype(str), "error", ("integer",), "error", ("integer",), 0),
    "bytes": (lambda: LAB.astype("S4"), "error", ("integer",), "error", ("integer",), 0),
    "datetime64": (lambda: LAB.astype("datetime64[s]"), "error", ("integer",), "error", ("integer",), 0),
    "timedelta64": (lambda: LAB.astype("timedelta64[s]"), "error", ("integer",), "error", ("integer",), 0),
    "structured dtype": (lambda: np.zeros((32, 32), [("a", "i4"), ("b", "f4")]), "error", ("integer",), "error",
                         ("integer",), 0),
    "bool all True": (lambda: np.ones((32, 32), bool), "warn", ("no interior cell",), "ok", (), 1),
    "bool all False": (lambda: np.zeros((32, 32), bool), "error", ("no cell is left",), "ok", (), 0),
    "bool skeleton grid": (lambda: _grid(), "ok", (), "ok", (), 16),
    "all zero": (lambda: np.zeros((32, 32), np.int32), "error", ("all zeros",), "error", ("all zeros",), 0),
    "one id everywhere": (lambda: np.ones((32, 32), np.int32), "warn", ("no interior cell",), "ok", (), 1),
    "white membranes (255)": (lambda: _white_membranes(), "error", ("255",), "ok", (), 0),
    "raw noise image": (lambda: _noise(), "error", ("does not look like a label image",), "error",
                        ("does not look like a label image",), 0),
    "0-d scalar": (lambda: np.array(5), "error", ("shape ()", "rows x cols"), "error", ("shape ()",), 0),
    "1-D": (lambda: np.arange(32), "error", ("shape (32,)", "rows x cols"), "error", ("shape (32,)",), 0),
    "0 x 0": (lambda: np.zeros((0, 0), np.int32), "error", ("2 x 2", "(0, 0)"), "error", ("2 x 2",), 0),
    "0 x 8": (lambda: np.zeros((0, 8), np.int32), "error", ("2 x 2", "(0, 8)"), "error", ("2 x 2",), 0),
    "8 x 0": (lambda: np.zeros((8, 0), np.int32), "error", ("2 x 2", "(8, 0)"), "error", ("2 x 2",), 0),
    "0 frames of 8 x 8": (lambda: np.zeros((0, 8, 8), np.int32), "error", ("no frame",), "error", ("no frame",), 0),
    "1 x 1": (lambda: np.ones((1, 1), np.int32), "error", ("2 x 2",), "error", ("2 x 2",), 0),
    "1 x 32": (lambda: np.arange(1, 33, dtype=np.int32)[None], "error", ("2 x 2",), "error", ("2 x 2",), 0),
    "2 x 2 of four cells": (lambda: np.array([[1, 2], [3, 4]], np.int32), "warn", ("polygon",), "ok", (), 4),
    "3-D stack": (lambda: STACK, "ok", (), "ok", (), 16),
    "3-D stack of one frame": (lambda: LAB[None], "ok", (), "ok", (), 16),
    "4-D T x C x Y x X": (lambda: np.stack([STACK, STACK], axis=1), "error", ("channel",), "error", ("channel",), 0),
    "4-D with a size-1 axis": (lambda: STACK[:, None], "ok", (), "ok", (), 16),
    "5-D": (lambda: STACK[:, None, None], "error", ("shape (3, 1, 1, 32, 32)",), "error",
            ("shape (3, 1, 1, 32, 32)",), 0),
    "6-D": (lambda: STACK[:, None, None, None], "error", ("shape (3, 1, 1, 1, 32, 32)",), "error",
            ("shape (3, 1, 1, 1, 32, 32)",), 0),
    "RGB colours of the ids": (lambda: _rgb(False), "warn", ("RGB",), "warn", ("RGB",), 16),
    "RGBA colours of the ids": (lambda: _rgb(True), "warn", ("RGB",), "warn", ("RGB",), 16),
    # read as 32 frames of 32 x 2 px: none holds an interior cell, which the result says
    "Y x X x 2": (lambda: np.dstack([LAB, LAB]), "warn", ("no interior cell",), "ok", (), 0),
    "list of 2-D frames": (lambda: [LAB, LAB], "ok", (), "ok", (), 16),
    "list of frames of two shapes": (lambda: [LAB, LAB[:16]], "error", ("shape",), "error", ("shape",), 0),
    "empty list": (lambda: [], "error", ("list of frames is empty",), "error", ("list of frames is empty",), 0),
    "list of numbers": (lambda: [1, 2, 3], "error", (), "error", (), 0),
    "nested Python lists": (lambda: LAB.tolist(), "error", ("frames[0]", "2-D"), "error", ("frames[0]", "2-D"), 0),
    "None": (lambda: None, "error", ("None",), "error", ("None",), 0),
    "a number": (lambda: 3.5, "error", (), "error", (), 0),
    "a dict": (lambda: {"labels": LAB}, "error", ("dict",), "error", ("dict",), 0),
    "masked array": (lambda: np.ma.masked_array(LAB, LAB == 1), "error", ("masked array", "filled(0)"), "error",
                     ("masked array", "filled(0)"), 0),
    "masked array, nothing masked": (lambda: np.ma.masked_array(LAB), "ok", (), "ok", (), 16),
}


def _readonly(a):
    a = a.copy()
    a.flags.writeable = False
    return a


def _mixed():
    out = _obj(LAB)
    out[0, 0] = "a"
    out[1, 1] = None
    return out


def _grid():
    g = np.zeros((33, 33), bool)
    g[::8, :] = True
    g[:, ::8] = True
    return g


def _analyze(make, **kw):
    kw = {"workers": 1, "progress": False, **kw}
    return lambda d: ht.analyze(make(), **kw)


def _open_all(make):
    def run(d):
        src = ht.open_source(make())
        for t in range(len(src)):
            src.frame(t)
        return src
    return run


for name, (make, outcome, texts, src_outcome, src_texts, n) in ARRAYS.items():
    add("array -> analyze", name, _analyze(make), outcome, *texts, check=cells_per_frame(n) if n else None)
    add("array -> open_source", name, _open_all(make), src_outcome, *src_texts)


# the same arrays saved as .npy and read by the command
NPY = ("uint16", "big-endian int32", "float64 whole numbers", "fractional floats", "NaN pixel", "negative ids",
       "uint64 ids >= 2**63", "complex", "bool skeleton grid", "all zero", "1 x 1", "0 x 0", "0 frames of 8 x 8",
       "3-D stack", "4-D T x C x Y x X", "5-D", "RGB colours of the ids", "raw noise image", "strings",
       "structured dtype")


def _save_npy(make):
    return lambda d: np.save(d / "in.npy", np.asarray(make()))


for name in NPY:
    make, outcome, texts, *_ = ARRAYS[name]
    add("array as .npy -> analyze command", name, cli("analyze", "{d}/in.npy", "--out", "{d}/out", "--workers", 1),
        outcome, *(t for t in texts if t not in ("None", "dict")), setup=_save_npy(make))


# ---------------------------------------------------------------------------------------------------
# files
# ---------------------------------------------------------------------------------------------------
def _write(name, data):
    def setup(d):
        path = d / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(data() if callable(data) else data)
    return setup


def _npy_bytes(a):
    buf = io.BytesIO()
    np.save(buf, a)
    return buf.getvalue()


def _tif_bytes(a):
    import tifffile
    buf = io.BytesIO()
    tifffile.imwrite(buf, a)
    return buf.getvalue()


def _png_bytes(a):
    from PIL import Image
    buf = io.BytesIO()
    Image.fromarray(a).save(buf, format="PNG")
    return buf.getvalue()


def _npz_bytes(**arrays):
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return buf.getvalue()


VALID = {".npy": lambda: _npy_bytes(LAB), ".tif": lambda: _tif_bytes(LAB.astype(np.uint16)),
         ".png": lambda: _png_bytes(LAB.astype(np.uint8)), ".npz": lambda: _npz_bytes(labels=LAB)}


def _analyze_path(name, **kw):
    return lambda d: ht.analyze(d / name, workers=1, progress=False, **kw)


def _analyze_cmd(name, *extra):
    return cli("analyze", "{d}/" + name, "--out", "{d}/out", "--workers", 1, *extra)


for suffix in (".tif", ".tiff", ".png", ".npy", ".npz", ".csv", ".parquet", ".db", ".mat", ".zarr", ".gz", ".txt"):
    add("files", f"empty {suffix}", _analyze_path("in" + suffix), "error", "in" + suffix,
        setup=_write("in" + suffix, b""))
for suffix, data in VALID.items():
    add("files", f"valid {suffix}", _analyze_path("in" + suffix), "ok", setup=_write("in" + suffix, data),
        check=cells_per_frame(16))
    add("files", f"truncated {suffix}", _analyze_path("in" + suffix), "error", "in" + suffix,
        setup=_write("in" + suffix, lambda data=data: data()[: len(data()) // 2]))
    add("files", f"header only {suffix}", _analyze_path("in" + suffix), "error", "in" + suffix,
        setup=_write("in" + suffix, lambda data=data: data()[:16]))
    add("files", f"random bytes named {suffix}", _analyze_path("in" + suffix), "error", "in" + suffix,
        setup=_write("in" + suffix, np.random.default_rng(4).bytes(3000)))
    for other, other_data in VALID.items():
        if other != suffix and other != ".npz":
            add("files", f"{other} content named {suffix}", _analyze_path("in" + suffix), "error", "in" + suffix,
                setup=_write("in" + suffix, other_data))
    add("files", f"unknown suffix .xyz holding {suffix}", _analyze_path("in.xyz"), "error", "in.xyz",
        setup=_write("in.xyz", data))
    add("files", f"no suffix holding {suffix}", _analyze_path("in"), "error", "in", setup=_write("in", data))
    add("files", f".gz of a valid {suffix}", _analyze_path(f"in{suffix}.gz"), "ok",
        setup=_write(f"in{suffix}.gz", lambda data=data: gzip.compress(data())), check=cells_per_frame(16))
    add("files", f".gz of garbage named {suffix}.gz", _analyze_path(f"in{suffix}.gz"), "error", f"in{suffix}.gz",
        setup=_write(f"in{suffix}.gz", np.random.default_rng(5).bytes(2000)))
    add("files", f".gz of a truncated {suffix}", _analyze_path(f"in{suffix}.gz"), "error", f"in{suffix}.gz",
        setup=_write(f"in{suffix}.gz", lambda data=data: gzip.compress(data()[: len(data()) // 2])))
    add("files", f"truncated .gz of a {suffix}", _analyze_path(f"in{suffix}.gz"), "error", f"in{suffix}.gz",
        setup=_write(f"in{suffix}.gz", lambda data=data: gzip.compress(data())[:40]))


def _symlink(target, name="link.npy", make_target=True):
    def setup(d):
        if make_target:
            (d / target).write_bytes(_npy_bytes(LAB))
        os.symlink(d / target, d / name)
    return setup


def _loop(d):
    os.symlink(d / "b.npy", d / "a.npy")
    os.symlink(d / "a.npy", d / "b.npy")


add("files", "symlink to a valid .npy", _analyze_path("link.npy"), "ok", setup=_symlink("real.npy"),
    check=cells_per_frame(16))
add("files", "dangling symlink", _analyze_path("link.npy"), "error", "link.npy",
    setup=_symlink("gone.npy", make_target=False))
add("files", "symlink loop", _analyze_path("a.npy"), "error", "a.npy", setup=_loop)
add("files", "symlink to a folder of frames", _analyze_path("link"), "ok", check=cells_per_frame(16),
    setup=lambda d: (_frames(d / "frames", [LAB, LAB]), os.symlink(d / "frames", d / "link")))
add("files", "missing file", _analyze_path("nothing.npy"), "error", "nothing.npy")
add("files", "a folder named .npy", _analyze_path("in.npy"), "error", "in.npy",
    setup=lambda d: (d / "in.npy").mkdir())
add("files", "a folder named .tif", _analyze_path("in.tif"), "error", "in.tif",
    setup=lambda d: (d / "in.tif").mkdir())
add("files", "a FIFO", _analyze_path("pipe.npy"), "error", "pipe.npy", setup=lambda d: os.mkfifo(d / "pipe.npy"))
add("files", "/dev/null", lambda d: ht.analyze("/dev/null", workers=1, progress=False), "error", "/dev/null")
add("files", "a path with a NUL byte", lambda d: ht.analyze(str(d / "a\0b.npy"), workers=1, progress=False),
    "error", "a\\x00b.npy")
add("files", "a path below a file", _analyze_path("in.npy/sub.npy"), "error", "sub.npy",
    setup=_write("in.npy", VALID[".npy"]))
add("files", "a path of 300 characters", lambda d: ht.analyze(d / ("x" * 300 + ".npy"), workers=1,
                                                                progress=False), "error", "xxxx")
add("files", "unreadable (mode 000; root reads it)", _analyze_path("locked.npy"),
    "ok" if os.geteuid() == 0 else "error", *(() if os.geteuid() == 0 else ("locked.npy",)),
    setup=lambda d: (_write("locked.npy", VALID[".npy"])(d), os.chmod(d / "locked.npy", 0)),
    check=cells_per_frame(16) if os.geteuid() == 0 else None, documented="ok")


def _npy_header(shape, dtype="<i8"):
    """A .npy file whose header declares ``shape`` but that holds 1 kB of data."""
    from numpy.lib import format as npformat
    buf = io.BytesIO()
    npformat.write_array_header_1_0(buf, {"descr": dtype, "fortran_order": False, "shape": shape})
    return buf.getvalue() + bytes(1000)


def _png_header(width, height):
    """A PNG whose header declares width x height px (a decompression bomb's header) over 100 bytes of pixels."""
    import struct
    import zlib

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
    header = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(bytes(100)))
            + chunk(b"IEND", b""))


add("files", ".npy declaring 100,000 x 100,000 int64", _analyze_path("in.npy"), "error", "in.npy",
    setup=_write("in.npy", lambda: _npy_header((100000, 100000))))
add("files", ".npy declaring 10**7 frames", _analyze_path("in.npy"), "error", "in.npy",
    setup=_write("in.npy", lambda: _npy_header((10**7, 64, 64), "<i4")))
add("files", ".png declaring 100,000 x 100,000 px", _analyze_path("in.png"), "error", "in.png",
    setup=_write("in.png", lambda: _png_header(100000, 100000)))

SQUARES = "cell,x,y\n1,0,0\n1,10,0\n1,10,10\n1,0,10\n2,10,0\n2,20,0\n2,20,10\n2,10,10\n"
VERTICES = {
    "two squares": (SQUARES, "warn", ("no interior cell",)),
    "wrong columns": ("a,b,c\n1,2,3\n", "error", ("missing column(s)", "cell, x, y")),
    "header only": ("cell,x,y\n", "error", ("no rows",)),
    "NaN coordinate": (SQUARES.replace("1,10,0", "1,nan,0"), "error", ("column 'x'", "NaN")),
    "inf coordinate": (SQUARES.replace("1,10,0", "1,inf,0"), "error", ("column 'x'", "infinite")),
    "text coordinate": (SQUARES.replace("1,10,0", "1,a,0"), "error", ("column 'x' must hold numbers",)),
    "a cell of two vertices": ("cell,x,y\n1,0,0\n1,10,0\n", "error", ("cell 1", "at least 3")),
    "negative cell ids": (SQUARES.replace("\n1,", "\n-1,"), "error", ("must be positive", "-1")),
    "fractional cell ids": (SQUARES.replace("\n1,", "\n1.5,"), "error", ("column 'cell' must hold integers",)),
}
for name, (text, outcome, texts) in VERTICES.items():
    add("vertices tables", name, _analyze_path("in.csv"), outcome, *texts, setup=_write("in.csv", text.encode()))
    add("vertices tables", f"{name} (command)", _analyze_cmd("in.csv"), outcome, *texts,
        setup=_write("in.csv", text.encode()))


def _frames(folder, frames, suffix=".tif"):
    folder.mkdir(parents=True, exist_ok=True)
    for i, f in enumerate(frames):
        (folder / f"frame{i}{suffix}").write_bytes(_tif_bytes(f) if suffix == ".tif" else _png_bytes(f))


FOLDERS = {
    "frames of one shape": (lambda d: _frames(d / "in", [LAB, LAB, LAB]), "ok", (), 16),
    "frames of two shapes": (lambda d: _frames(d / "in", [LAB, LAB[:16], LAB]), "error",
                             ("frame1.tif", "expected 32 x 32"), 0),
    "frames of two dtypes": (lambda d: _frames(d / "in", [LAB.astype(np.uint16), LAB.astype(np.uint8)]), "ok", (),
                             16),
    "a 2-D frame and a stack": (lambda d: _frames(d / "in", [LAB, STACK]), "error", ("frame1.tif",), 0),
    "an empty folder": (lambda d: (d / "in").mkdir(), "error", ("in",), 0),
    "only text files": (lambda d: _write("in/notes.txt", b"hello")(d), "error", ("in",), 0),
    "images and text files": (lambda d: (_frames(d / "in", [LAB, LAB]), _write("in/notes.txt", b"x")(d)), "ok", (),
                              16),
    "tif and png frames mixed": (lambda d: (_frames(d / "in", [LAB]), _frames(d / "in2", [LAB.astype(np.uint8)],
                                                                              ".png"),
                                            os.replace(d / "in2/frame0.png", d / "in/frame1.png")), "error",
                                 (".png",), 0),
    "a truncated frame among good ones": (lambda d: (_frames(d / "in", [LAB, LAB, LAB]),
                                                     _write("in/frame1.tif", _tif_bytes(LAB)[:100])(d)), "error",
                                          ("frame1.tif",), 0),
    "an empty frame among good ones": (lambda d: (_frames(d / "in", [LAB, LAB]), _write("in/frame1.tif", b"")(d)),
                                       "error", ("frame1.tif",), 0),
    # 1,024 px: too small for the label-ness tests (docs/input.md); its cells have no polygons, which is said
    "a frame of noise among labels": (lambda d: _frames(d / "in", [LAB, _noise()[:32, :32], LAB]), "warn",
                                      ("frame1.tif",), 0),
    "a sub-folder among frames": (lambda d: (_frames(d / "in", [LAB, LAB]), (d / "in/sub").mkdir()), "ok", (), 16),
    "hidden files among frames": (lambda d: (_frames(d / "in", [LAB, LAB]),
                                             _write("in/._frame0.tif", b"\0\5\x16\7")(d)), "ok", (), 16),
}
for name, (setup, outcome, texts, n) in FOLDERS.items():
    add("folders", name, _analyze_path("in"), outcome, *texts, setup=setup, check=cells_per_frame(n) if n else None)
    add("folders", f"{name} (command)", _analyze_cmd("in"), outcome, *texts, setup=setup)

NPZ = {
    "one key": (dict(labels=LAB), (), "ok", ()),
    "no key given, two arrays": (dict(a=LAB, b=LAB), (), "error", ("--key", "'a'", "'b'")),
    "key given": (dict(a=LAB, b=LAB), ("--key", "b"), "ok", ()),
    "key missing": (dict(a=LAB), ("--key", "zzz"), "error", ("zzz", "'a'")),
    "no arrays": ({}, (), "error", ("no array",)),
    "key of a 1-D array": (dict(a=np.arange(5)), (), "error", ("shape (5,)",)),
    "key of strings": (dict(a=LAB.astype(str)), (), "error", ("integer",)),
    "object array (pickled)": (dict(a=_obj(LAB)), (), "error", ("pickle",)),
}
for name, (arrays, extra, outcome, texts) in NPZ.items():
    add("npz keys", name, _analyze_cmd("in.npz", *extra), outcome, *texts,
        setup=_write("in.npz", lambda arrays=arrays: _npz_bytes(**arrays)))


# ---------------------------------------------------------------------------------------------------
# options: every numeric field of every stage at 0, negative, NaN, inf, huge and of the wrong type
# ---------------------------------------------------------------------------------------------------
def numeric_fields():
    """(stage, class, field) of every int or float field of ``OPTION_CLASSES``."""
    out = []
    for stage, cls in OPTION_CLASSES.items():
        for f in fields(cls):
            kind = str(f.type).split(" |")[0]
            if kind in ("int", "float"):
                out.append((stage, cls, f))
    return out


# the stage's other options a field needs to be used at all
NEEDS = {"intensity": dict(image=STACK.astype(float)), "surface": dict(image=STACK.astype(float)), "deformation": dict(enabled=True),
         "mechanics": dict(enabled=True)}
NEEDS_FLAGS = {"intensity": ("--intensity", "{d}/raw.npy"), "surface": ("--surface", "{d}/raw.npy"),
               "deformation": ("--deformation",),
               "mechanics": ("--mechanics",)}
#: expected outcome of each numeric field at 0 and at 1e12: "ok", "warn:" and the warning's text, or the error's
#: text (which also names the field, as ``MeshOptions.field`` or its flag; "bare:" where it names it otherwise)
ZERO = {"mesh.merge_distance": "ok", "mesh.membrane_width": "ok", "mesh.min_area": "ok", "mesh.fill_holes": "ok",
        "order.radius": "> 0", "order.spacing": "> 0", "order.min_coverage": "ok", "order.r_cell": "> 0",
        "order.defect_max_distance": "> 0", "track.min_iou": "> 0", "track.max_gap": "ok",
        "track.child_fraction": "> 0", "track.mother_fraction": "> 0", "track.division_min_frames": "ok",
        "track.division_min_cycle": "ok", "track.division_area_tolerance": "ok", "events.min_length": "ok",
        "events.censor": "ok", "intensity.channel": "bare:channel=0", "intensity.step": "> 0",
        "deformation.roi_frame": "ok", "surface.channel": "bare:channel=0", "surface.pixel_size": "> 0",
        "surface.z_step": "> 0", "flow.radius_factor": "> 0", "flow.min_cells": ">= 3", "mechanics.mu": "positive"}
HUGE = {"mesh.merge_distance": "larger than the frames' diagonal", "mesh.membrane_width": "ok",
        "mesh.min_area": "bare:min_area = 1e+12", "mesh.fill_holes": "ok",
        "order.radius": "larger than the frames' diagonal", "order.spacing": "warn:1 x 1 node",
        "order.min_coverage": "<= 1.0", "order.r_cell": "warn:1 x 1 node",
        "order.defect_max_distance": "ok", "track.min_iou": "<= 1.0", "track.max_gap": "ok",
        "track.child_fraction": "<= 1.0", "track.mother_fraction": "<= 1.0", "track.division_min_frames": "ok",
        "track.division_min_cycle": "ok", "track.division_area_tolerance": "ok", "events.min_length": "ok",
        "events.censor": "ok", "intensity.channel": "bare:channel=1000000000000",
        "intensity.step": "larger than the frames' diagonal", "deformation.roi_frame": "ok",
        "surface.channel": "bare:channel=1000000000000", "surface.pixel_size": "ok",
        "surface.z_step": "warn:check the height map's unit",
        "flow.radius_factor": "ok", "flow.min_cells": "ok", "mechanics.mu": "warn:force balance alone"}
VALUES = {"0": 0, "-1": -1, "NaN": math.nan, "inf": math.inf, "-inf": -math.inf, "1e12": 10**12, "'x'": "x",
          "True": True, "[1]": [1]}
CLI_VALUES = {"0": "0", "-1": "-1", "NaN": "nan", "inf": "inf", "1e12": "1e12", "'x'": "x"}


def _expected(key, label, flag):
    """(outcome, texts) of field ``key`` set to the value ``label``; ``flag``: the name the error must give."""
    if label in ("0", "1e12"):
        table = ZERO if label == "0" else HUGE
        text = table[key]
        if text.startswith("warn:"):
            return "warn", (text[5:],)
        if text.startswith("bare:"):  # the message names the field as the stage's function calls it
            return "error", (text[5:],)
        return ("ok", ()) if text == "ok" else ("error", (flag, text))
    return "error", (flag,)


def _options_run(stage, cls, name, value):
    def run(d):
        options = {stage: cls(**{**NEEDS.get(stage, {}), name: value})}
        return ht.analyze(STACK, workers=1, progress=False, **options)
    return run


def _raw(d):
    np.save(d / "raw.npy", STACK.astype(float))


for stage, cls, f in numeric_fields():
    key = f"{stage}.{f.name}"
    for label, value in VALUES.items():
        outcome, texts = _expected(key, label, f"{cls.__name__}.{f.name}")
        add("options (API)", f"{key} = {label}", _options_run(stage, cls, f.name, value), outcome, *texts,
            check=cells_per_frame(16) if outcome == "ok" else None)
    if "flag" not in f.metadata:
        continue
    flag = f.metadata["flag"]
    for label, text in CLI_VALUES.items():
        outcome, texts = _expected(key, label, flag)
        integer = str(f.type).startswith("int")
        if label == "'x'" or (integer and label in ("NaN", "inf", "1e12")):
            # argparse refuses what int() / float() cannot read
            outcome, texts = "error", (f"argument {flag}: invalid",)
        add("options (command)", f"{flag} {text}",
            cli("analyze", "{d}/in.npy", "--out", "{d}/out", "--workers", 1, *NEEDS_FLAGS.get(stage, ()), flag, text),
            outcome, *texts, setup=lambda d: (_write("in.npy", _npy_bytes(STACK))(d), _raw(d)))

# the other fields by their annotation: every value below is refused naming the field, except those in OTHER_OK
OTHER_VALUES = {"str": {"'nonsense'": "nonsense", "3": 3, "None": None},
                "bool": {"1": 1, "'yes'": "yes", "None": None},
                "tuple": {"'x'": "x", "[-1]": [-1], "[1.5]": [1.5], "[NaN]": [math.nan], "[]": []}}
OTHER_OK = {("mesh.background", "[]"), ("mechanics.curved", "None")}
for stage, cls in OPTION_CLASSES.items():
    for f in fields(cls):
        kind = str(f.type).split(" |")[0]
        for label, value in OTHER_VALUES.get(kind, {}).items():
            key = f"{stage}.{f.name}"
            ok = (key, label) in OTHER_OK
            # force inference on the open tiling always says what the balance leaves free
            outcome, texts = (("warn", ("force balance alone",)) if stage == "mechanics" else ("ok", ())) if ok else \
                ("error", (f"{cls.__name__}.{f.name}",))
            add("options (API)", f"{key} = {label}", _options_run(stage, cls, f.name, value), outcome, *texts,
                check=cells_per_frame(16) if ok else None)

CHOICES = [(f.metadata["flag"], stage) for stage, cls in OPTION_CLASSES.items() for f in fields(cls)
           if "flag" in f.metadata and f.metadata["argparse"].get("choices")]
for flag, stage in CHOICES:
    add("options (command)", f"{flag} not one of its choices",
        cli("analyze", "{d}/in.npy", "--out", "{d}/out", flag, "nonsense"), "error", f"argument {flag}: invalid choice",
        setup=_write("in.npy", lambda: _npy_bytes(STACK)))
for stage, cls in OPTION_CLASSES.items():
    add("options (API)", f"{stage} = a dict", lambda d, stage=stage: ht.analyze(LAB, **{stage: {}}), "error",
        stage)
    add("options (API)", f"{stage}: an unknown field", lambda d, cls=cls: cls.from_dict({"zzz": 1}), "error", "zzz")

RUN_ARGS = {
    "workers = 0": (dict(workers=0), "error", ("workers",)),
    "workers = -2": (dict(workers=-2), "error", ("workers",)),
    "workers = 1.5": (dict(workers=1.5), "error", ("workers",)),
    "workers = '2'": (dict(workers="2"), "error", ("workers",)),
    "workers = True": (dict(workers=True), "error", ("workers",)),
    "workers = 10**9": (dict(workers=10**9), "ok", ()),
    "checkpoint_every = 0": (dict(checkpoint_every=0), "error", ("checkpoint_every",)),
    "checkpoint_every = NaN": (dict(checkpoint_every=math.nan), "error", ("checkpoint_every",)),
    "box of another shape": (dict(box=ht.Box(10, 10)), "error", ("box",)),
    "box = 'yes'": (dict(box="yes"), "error", ("box",)),
    "box = True": (dict(box=True), "ok", ()),
    "mask of another shape": (dict(mask=np.ones((5, 5), bool)), "error", ("mask", "shape")),
    "mask all outside": (dict(mask=np.zeros((32, 32), bool)), "error", ("mask",)),
    "mask of NaN": (dict(mask=np.full((32, 32), np.nan)), "error", ("mask",)),
    "mask a missing file": (dict(mask="/nonexistent/mask.tif"), "error", ("mask",)),
}
for name, (kw, outcome, texts) in RUN_ARGS.items():
    add("analyze arguments", name, _analyze(lambda: STACK, **kw), outcome, *texts,
        check=cells_per_frame(16) if outcome == "ok" else None)

CLI_RUN = {
    "--workers 0": (("--workers", "0"), "error", ("workers must be a positive integer",)),
    "--workers -1": (("--workers", "-1"), "error", ("workers must be a positive integer",)),
    "--workers x": (("--workers", "x"), "error", ("argument --workers: invalid",)),
    "--pixel-size 0": (("--pixel-size", "0"), "error", ("pixel_size",)),
    "--pixel-size inf": (("--pixel-size", "inf"), "error", ("pixel_size",)),
    "--frame-interval -1": (("--frame-interval", "-1"), "error", ("frame_interval",)),
    "--frame-interval nan": (("--frame-interval", "nan"), "error", ("frame_interval",)),
    "--units furlong": (("--pixel-size", "1", "--units", "furlong"), "error", ("furlong",)),
    "--time-unit fortnight": (("--frame-interval", "1", "--time-unit", "fortnight"), "error", ("fortnight",)),
    "--channel 5 of a label stack": (("--channel", "5"), "error", ("channel",)),
    "--level 3 of an .npy": (("--level", "3"), "error", ("level",)),
    "--axes QYX": (("--axes", "QYX"), "error", ("axes='QYX'", "TCZYXS")),
    "--axes YX of a stack": (("--axes", "YX"), "error", ("axes",)),
    "--key of an .npy": (("--key", "a"), "error", ("key",)),
    "--mask of another shape": (("--mask", "{d}/small.npy"), "error", ("mask",)),
    "--mask a folder": (("--mask", "{d}"), "error", ("mask",)),
    "--format xml": (("--format", "xml"), "error", ("argument --format: invalid choice",)),
    "--out is the input file": (("--out", "{d}/in.npy"), "error", ("--out",)),
    "--checkpoint is the input file": (("--checkpoint", "{d}/in.npy"), "error", ("--checkpoint",)),
    "--deformation-roi missing": (("--deformation", "--deformation-roi", "{d}/nothing.npy"), "error",
                                  ("--deformation-roi",)),
    "--deformation-roi of a .txt": (("--deformation", "--deformation-roi", "{d}/small.txt"), "error",
                                    ("--deformation-roi",)),
    "--intensity of another shape": (("--intensity", "{d}/small.npy"), "error", ("intensity", "shape")),
    "--intensity missing": (("--intensity", "{d}/nothing.tif"), "error", ("nothing.tif",)),
    "--intensity-channel without --intensity": (("--intensity-channel", "0"), "error", ("--intensity",)),
}
for name, (extra, outcome, texts) in CLI_RUN.items():
    add("analyze command arguments", name,
        cli("analyze", "{d}/in.npy", "--out", "{d}/out", "--workers", 1, *extra) if "--out" not in extra else
        cli("analyze", "{d}/in.npy", "--workers", 1, *extra), outcome, *texts,
        setup=lambda d: (_write("in.npy", _npy_bytes(STACK))(d), _write("small.npy", _npy_bytes(LAB[:8, :8]))(d),
                         _write("small.txt", b"x")(d)))


def _in_npy(d):
    np.save(d / "in.npy", STACK)


def _earlier(d, *extra):
    _in_npy(d)
    main(["analyze", str(d / "in.npy"), "--out", str(d / "out"), "--workers", "1", *extra])


OUT_TARGETS = {
    "a folder of someone else's files": (lambda d: (_in_npy(d), _write("out/mine.txt", b"keep me")(d)), "ok", (),
                                         ("out/mine.txt",)),
    "a folder holding someone else's cells.parquet": (lambda d: (_in_npy(d), _write("out/cells.parquet",
                                                                                     b"mine")(d)), "error",
                                                      ("holds cells.parquet", "not a results folder"), ()),
    "a folder holding someone else's cells.csv": (lambda d: (_in_npy(d), _write("out/cells.csv", b"mine")(d)),
                                                  "error", ("holds cells.csv",), ()),
    "an earlier results folder": (_earlier, "ok", (), ()),
    "an earlier results folder with figures": (lambda d: _earlier(d, "--figures"), "ok", (), ()),
    "an earlier results folder, as csv": (lambda d: _earlier(d, "--format", "csv"), "ok", (), ()),
    "an existing file": (lambda d: (_in_npy(d), _write("out", b"keep me")(d)), "error", ("is a file",), ()),
    "a folder without write permission (root writes anyway)": (
        lambda d: (_in_npy(d), (d / "out").mkdir(), os.chmod(d / "out", 0o500)),
        "ok" if os.geteuid() == 0 else "error", *(((), ()) if os.geteuid() == 0 else (("cannot be written",), ()))),
}
for name, (setup, outcome, texts, keep) in OUT_TARGETS.items():
    add("analyze --out onto existing paths", name, cli("analyze", "{d}/in.npy", "--out", "{d}/out", "--workers", 1),
        outcome, *texts, setup=setup, keep=keep, documented="ok" if "root" in name else outcome)


# ---------------------------------------------------------------------------------------------------
# exports onto existing paths; report on folders that are not results
# ---------------------------------------------------------------------------------------------------
def _results(d, name="res"):
    np.save(d / "labels.npy", STACK)  # the label-image exports (ctc, ome-zarr) read the analysed file again
    ht.analyze(d / "labels.npy", workers=1, progress=False).write(d / name)


def _export(d, fmt, target):
    main(["export", str(d / "res"), str(d / target), "--to", fmt])


GEFF = ("neighbours.geff", "tracks.geff")
HAS_ANNDATA = importlib.util.find_spec("anndata") is not None
# name: (setup(d, target), extra flags, outcome, texts); geff writes its two stores into OUT, so other files in
# OUT stay (only the two stores are its own)
EXPORT_TARGETS = {
    "onto an existing file": (lambda d, t: _write(t, b"keep me")(d), (), "error", ("already exists (a file)",)),
    "onto a folder of someone else's files": (lambda d, t: _write(t + "/mine.txt", b"keep me")(d), (), "error",
                                              ("already exists (a folder, 1 entries)",)),
    "onto a folder of someone else's files, --overwrite": (lambda d, t: _write(t + "/mine.txt", b"keep me")(d),
                                                          ("--overwrite",), "ok", ()),
    "onto a results folder, --overwrite": (lambda d, t: _results(d, t), ("--overwrite",), "error",
                                           ("is a results folder",)),
    "onto an empty folder": (lambda d, t: (d / t).mkdir(), (), "ok", ()),
    "again onto its own output": (lambda d, t: None, (), "ok", ()),
    "below a file": (lambda d, t: _write("afile", b"keep me")(d), (), "error", ("afile",)),
}
GEFF_OUTCOMES = {"onto an existing file": ("error", ("is a file",)),
                 "onto a folder of someone else's files": ("ok", ()),
                 "onto a results folder, --overwrite": ("ok", ())}


def _export_setup(extra_setup, fmt, target, again):
    def setup(d):
        _results(d)
        extra_setup(d, target)
        if again:
            _export(d, fmt, target)
    return setup


for fmt in ("geff", "ctc", "ome-zarr", "anndata"):
    target = "out.zarr" if fmt == "anndata" else "out"
    for name, (setup, extra, outcome, texts) in EXPORT_TARGETS.items():
        if fmt == "geff":
            outcome, texts = GEFF_OUTCOMES.get(name, (outcome, texts))
        documented = outcome
        if fmt == "anndata" and outcome == "ok" and not HAS_ANNDATA:  # an optional dependency
            outcome, texts = "error", ("needs the anndata package",)
        where = "afile/sub" if name == "below a file" else target
        writes = tuple(f"{target}/{g}" for g in GEFF) if fmt == "geff" else (target,)
        add("export onto existing paths", f"{fmt} {name}",
            cli("export", "{d}/res", "{d}/" + where, "--to", fmt, *extra),
            outcome, *texts, setup=_export_setup(setup, fmt, target, name == "again onto its own output"),
            writes=writes, documented=documented)
    add("export onto existing paths", f"{fmt} onto the results folder itself",
        cli("export", "{d}/res", "{d}/res", "--to", fmt, "--overwrite"), "error", "the export would replace it",
        setup=_results)
    add("export of non-results", f"{fmt} of an empty folder", cli("export", "{d}/in", "{d}/" + target, "--to", fmt),
        "error", "metadata.json", setup=lambda d: (d / "in").mkdir())
    add("export of non-results", f"{fmt} of a label image", cli("export", "{d}/labels.npy", "{d}/" + target, "--to",
                                                                 fmt), "error", "labels.npy",
        setup=lambda d: np.save(d / "labels.npy", LAB))


REPORT = {
    "an empty folder": (lambda d: (d / "in").mkdir(), "error", ("metadata.json",)),
    "a folder of images": (lambda d: _frames(d / "in", [LAB, LAB]), "error", ("metadata.json",)),
    "a label image file": (lambda d: _write("in", _npy_bytes(LAB))(d), "error", ("in",)),
    "a missing folder": (None, "error", ("does not exist",)),
    "metadata.json empty": (lambda d: (_results(d, "in"), _write("in/metadata.json", b"")(d)), "error",
                            ("metadata.json",)),
    "metadata.json a list": (lambda d: (_results(d, "in"), _write("in/metadata.json", b"[1, 2]")(d)), "error",
                             ("metadata.json",)),
    "metadata.json without its tables": (lambda d: (_results(d, "in"), (d / "in/cells.parquet").unlink()), "error",
                                         ("cells",)),
    "cells.parquet garbage": (lambda d: (_results(d, "in"), _write("in/cells.parquet", b"PAR1 x PAR1")(d)), "error",
                              ("cells",)),
    "a report folder": (lambda d: (_results(d, "res"), main(["report", str(d / "res")]),
                                   os.replace(d / "res/report", d / "in")), "error", ("metadata.json",)),
    "an export folder": (lambda d: (_results(d, "res"), _export(d, "ctc", "in")), "error", ("metadata.json",)),
}
for name, (setup, outcome, texts) in REPORT.items():
    add("report on non-results", name, cli("report", "{d}/in", "--out", "{d}/out"), outcome, *texts, setup=setup,
        writes=("out", "res"))
add("report on non-results", "--out is the results folder itself", cli("report", "{d}/res", "--out", "{d}/res"),
    "error", "is the results folder itself", setup=_results)
add("report on non-results", "--out is a file", cli("report", "{d}/res", "--out", "{d}/res/metadata.json"), "error",
    "is a file", setup=_results)
add("report on non-results", "--dl 0", cli("report", "{d}/res", "--out", "{d}/out", "--dl", "0"), "error",
    "dl must be a positive", setup=_results)
add("report on non-results", "--p 0", cli("report", "{d}/res", "--out", "{d}/out", "--p", "0"), "error", "p",
    setup=_results)
add("report on non-results", "--n-control -1", cli("report", "{d}/res", "--out", "{d}/out", "--n-control", "-1"),
    "error", "n_control must be a positive integer", setup=_results)


# ---------------------------------------------------------------------------------------------------
# the runner
# ---------------------------------------------------------------------------------------------------
def _snapshot(d):
    """Every path under ``d`` with its content hash (folders: None); symlinks by their target."""
    out = {}
    for root, dirs, files in os.walk(d):
        for name in dirs + files:
            path = Path(root) / name
            rel = path.relative_to(d).as_posix()
            if path.is_symlink():
                out[rel] = ("link", os.readlink(path))
            elif path.is_dir():
                out[rel] = None
            elif path.is_file():
                with contextlib.suppress(PermissionError):
                    out[rel] = hashlib.sha1(path.read_bytes()).hexdigest()
            else:
                out[rel] = "special"
    return out


def _under(rel, writes):
    return any(rel == w or rel.startswith(w + "/") for w in writes)


def _run_cli(argv):
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            code = main(argv)
        except SystemExit as exc:  # argparse: exit 2 with a usage line and one error line
            code = exc.code
    return code, err.getvalue()


@pytest.mark.parametrize("key", sorted(CASES))
def test_case(key, tmp_path, monkeypatch):
    case = CASES[key]
    d = tmp_path / "case"
    d.mkdir()
    cwd = tmp_path / "cwd"
    cwd.mkdir()
    monkeypatch.chdir(cwd)
    if case.setup is not None:
        with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()), \
                contextlib.redirect_stderr(io.StringIO()):
            warnings.simplefilter("ignore")
            case.setup(d)
    before = _snapshot(d)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            result = case.run(d)
            error = None
        except InputError as exc:
            result, error = None, str(exc)
        if isinstance(result, tuple) and result and result[0] == "cli":
            code, err = _run_cli(result[1])
            lines = err.strip().splitlines()
            assert "Traceback" not in err, err
            if code == 2:
                errors = [line for line in lines if ": error: " in line]
                assert len(errors) == 1, err
                error = errors[0]
            else:
                assert code == 0, (code, err)
                result = None
                caught = [line for line in lines if ": warning: " in line]
    # numpy's RuntimeWarnings and unclosed files reaching the user are defects too
    other = [f"{w.category.__name__}: {w.message}" for w in caught
             if hasattr(w, "category") and not issubclass(w.category, HexatissueWarning)]
    assert not other, other
    warned = [str(w.message) if hasattr(w, "message") else w for w in caught
              if not hasattr(w, "category") or issubclass(w.category, HexatissueWarning)]
    outcome = "error" if error is not None else ("warn" if warned else "ok")
    assert outcome == case.expect, (outcome, error, warned)
    if outcome == "error":
        for text in case.texts:
            assert text in error, (text, error)
    elif outcome == "warn":
        for text in case.texts:
            assert any(text in w for w in warned), (text, warned)
    if case.check is not None and result is not None:
        case.check(result)
    after = _snapshot(d)
    writes = () if outcome == "error" else case.writes  # a refused call leaves everything as it was
    for rel, state in before.items():
        if not _under(rel, writes) or rel in case.keep:
            assert after.get(rel) == state, f"{rel} was changed or deleted"
    for rel in set(after) - set(before):
        assert _under(rel, writes), f"{rel} was written"
    assert not any(cwd.iterdir()), "files were written into the working folder"


# ---------------------------------------------------------------------------------------------------
# the table of docs/input.md
# ---------------------------------------------------------------------------------------------------
def corpus_table() -> str:
    """The Markdown table of the corpus: each class, its cases and how many end as errors, results, warnings."""
    counts = Counter((c.cls, c.documented) for c in CASES.values())
    classes = list(dict.fromkeys(c.cls for c in CASES.values()))
    rows = ["| class | cases | refused (InputError / exit 2) | result | result with a warning |",
            "|---|---|---|---|---|"]
    for cls in classes:
        n = sum(counts[(cls, e)] for e in ("error", "ok", "warn"))
        rows.append(f"| {cls} | {n} | {counts[(cls, 'error')]} | {counts[(cls, 'ok')]} | {counts[(cls, 'warn')]} |")
    total = [sum(counts[(c, e)] for c in classes) for e in ("error", "ok", "warn")]
    rows.append(f"| all | {sum(total)} | {total[0]} | {total[1]} | {total[2]} |")
    return "\n".join(rows)


def test_docs_table_matches_the_corpus():
    text = (REPO / "docs" / "input.md").read_text()
    assert corpus_table() in text, "docs/input.md: replace the corpus table by\n" + corpus_table()


def test_corpus_size_and_every_numeric_option_has_its_expectations():
    assert len(CASES) >= 300
    keys = {f"{stage}.{f.name}" for stage, _, f in numeric_fields()}
    assert keys == set(ZERO) == set(HUGE), keys ^ set(ZERO)
