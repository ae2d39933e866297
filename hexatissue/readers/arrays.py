"""Arrays: in-memory arrays and array-likes, lists of 2-D arrays, ``.npy`` (memory-mapped), Cellpose ``_seg.npy``, ``.npz``.

Arrays without axis names are ``rows x cols``, ``T x rows x cols`` or
``T x C x rows x cols`` (the last needs ``channel=``), optionally with a
last RGB(A) axis of 3 or 4 (:func:`hexatissue.readers.base.array_axes`).
"""
from __future__ import annotations

from functools import partial
from pathlib import Path

import numpy as np

from ..errors import InputError
from .base import (Opened, array_axes, check_axes, collapse_rgb, layout_description, optional_int, plan, read_error,
                   refuse)

__all__ = ["ArrayReader", "ListReader", "open_array", "open_list", "open_npy", "open_npz"]


class ArrayReader:
    """Frames of an indexable array (numpy, memmap, zarr, dask, MPF labels, an opened file's array).

    ``opener`` (a picklable callable returning the array) is used for file-backed arrays: the array is
    opened on first use and not pickled.
    """

    def __init__(self, what, *, array=None, opener=None, axes=None, channel=None, rgb_allowed=True):
        self.what, self._opener = what, opener
        self._arr = array if array is not None else opener()
        shape = tuple(int(n) for n in self._arr.shape)
        self.axes = check_axes(axes, len(shape), what) if axes else array_axes(shape, rgb_allowed)
        if len(self.axes) != len(shape):
            raise InputError(f"{what} has shape {shape}, which does not match its axes {self.axes!r}")
        if self.axes.endswith("SYX"):
            raise InputError(f"axes={self.axes!r}: an array's RGB samples must be its last axis ('YXS')")
        self.rgb = self.axes.endswith("S")
        tail = 3 if self.rgb else 2
        self.layout = plan(self.axes[:-tail], shape[:-tail], channel, what, self.axes)
        self.n_frames = self.layout.n_frames
        self.shape = shape[len(shape) - tail:][:2]
        self.stored_shape = shape
        self.dtype = str(getattr(self._arr, "dtype", "unknown"))
        self._single = len(self.layout.axes) == 0

    def __getstate__(self):
        state = dict(self.__dict__)
        if self._opener is not None:
            state["_arr"] = None
        return state

    @property
    def array(self):
        if self._arr is None:
            self._arr = self._opener()
        return self._arr

    def describe(self) -> dict:
        return layout_description(self.axes, self.stored_shape, self.dtype, self.layout)

    def read(self, t) -> np.ndarray:
        idx = self.layout.index(t)
        try:
            if self._single:
                arr = np.asarray(self.array)
            else:
                arr = np.asarray(self.array[idx[0] if len(idx) == 1 else idx])
        except InputError:
            raise
        except Exception as exc:
            raise read_error(f"{self.what} (frame {t})", exc) from exc
        if not arr.flags.writeable:  # a read-only memory map: hand out an ordinary array
            arr = arr.copy()
        return collapse_rgb(arr) if self.rgb else arr


class ListReader:
    """Frames given as a list of 2-D arrays (or array-likes) of one shape."""

    def __init__(self, frames):
        self.frames = list(frames)
        shapes = []
        for i, f in enumerate(self.frames):
            shape = tuple(getattr(f, "shape", None) or np.shape(f))
            axes = array_axes(shape) if len(shape) in (2, 3) else None
            if axes not in ("YX", "YXS"):
                raise InputError(f"frames[{i}] has shape {shape}; every element of a list of frames must be a 2-D "
                                 f"label image (rows x cols)")
            shapes.append(shape)
        if len(set(shapes)) > 1:
            bad = next(i for i, s in enumerate(shapes) if s != shapes[0])
            raise InputError(f"the frames of a list must all have one shape; frames[0] is {shapes[0]} but "
                             f"frames[{bad}] is {shapes[bad]}")
        self.rgb = len(shapes[0]) == 3
        self.n_frames, self.shape = len(self.frames), shapes[0][:2]
        self.layout = plan("T", (self.n_frames,), None, "the list")
        self.dtype = str(getattr(self.frames[0], "dtype", np.asarray(self.frames[0]).dtype))

    def describe(self) -> dict:
        return layout_description("TYX" + "S" * self.rgb, (self.n_frames,) + tuple(self.shape), self.dtype,
                                  self.layout)

    def read(self, t) -> np.ndarray:
        arr = np.asarray(self.frames[t])
        return collapse_rgb(arr) if self.rgb else arr


def open_array(array, channel, axes=None) -> Opened:
    """An array or lazily indexable array-like with ``.shape`` (frame ``t`` read as ``array[t]``)."""
    reader = ArrayReader("the array", array=array, channel=channel, axes=axes)
    return Opened(reader, {"kind": "array", "path": None, "channel": optional_int(channel)})


def open_list(frames) -> Opened:
    """A non-empty list or tuple of 2-D arrays of one shape, one frame each."""
    return Opened(ListReader(frames), {"kind": "list", "path": None})


def open_npy(path: Path, key, channel, axes=None) -> Opened:
    """A ``.npy`` file (memory-mapped), or a Cellpose ``*_seg.npy`` (its ``masks``, or ``key``)."""
    if path.name.endswith("_seg.npy"):
        key = key or "masks"
        reader = ArrayReader(repr(str(path)), opener=partial(_cellpose_entry, path, key), channel=channel, axes=axes)
        return Opened(reader, {"kind": "cellpose", "path": str(path), "key": key, "channel": optional_int(channel)})
    refuse("a .npy file (it holds one array)", key=key)
    opener = partial(np.load, path, mmap_mode="r", allow_pickle=False)
    reader = ArrayReader(repr(str(path)), opener=opener, channel=channel, axes=axes)
    return Opened(reader, {"kind": "npy", "path": str(path), "channel": optional_int(channel)})


def open_npz(path: Path, key, channel, axes=None) -> Opened:
    """Array ``key`` of a ``.npz`` (default ``"labels"`` or the only array), read whole on first use."""
    key = _npz_key(path, key)
    reader = ArrayReader(repr(str(path)), opener=partial(_npz_entry, path, key), channel=channel, axes=axes)
    return Opened(reader, {"kind": "npz", "path": str(path), "key": key, "channel": optional_int(channel)})


def _cellpose_entry(path, key):
    # Cellpose saves a pickled dict; only files of that name are unpickled
    data = np.load(path, allow_pickle=True)
    if data.dtype != object or data.shape != ():
        raise InputError(f"{Path(path).name}: a Cellpose _seg.npy holds a dict (masks, outlines, ...); this file "
                         f"holds a plain {data.dtype} array of shape {data.shape}: rename it without '_seg' to read "
                         f"it as labels")
    data = data.item()
    if not isinstance(data, dict):
        raise InputError(f"{Path(path).name}: a Cellpose _seg.npy holds a dict (masks, outlines, ...); this file "
                         f"holds a {type(data).__name__}")
    arrays = sorted(k for k, v in data.items() if isinstance(v, np.ndarray) and v.ndim >= 2)
    if key not in arrays:
        raise InputError(f"{Path(path).name}: key={key!r} is not an image array of this Cellpose file; "
                         f"it holds {arrays}")
    return np.asarray(data[key])


def _npz_key(path, key):
    # the file is opened here so that it is closed also when numpy refuses it (a truncated zip)
    with open(path, "rb") as file, np.load(file, allow_pickle=False) as data:
        names = list(data.keys())
    if not names:
        raise InputError(f"{path.name} holds no array; expected a .npz with a label array (named 'labels', or "
                         f"chosen with key=, --key on the command line)")
    if key is None:
        key = "labels" if "labels" in names else (names[0] if len(names) == 1 else None)
        if key is None:
            raise InputError(f"{path.name}: choose an array with key= (--key on the command line); it holds {names}")
    if key not in names:
        raise InputError(f"{path.name}: key={key!r} is not an array of this file; it holds {names}")
    return key


def _npz_entry(path, key):
    # zip members cannot be memory-mapped: the array is read whole on first use
    with open(path, "rb") as file, np.load(file, allow_pickle=False) as data:
        return data[key]
