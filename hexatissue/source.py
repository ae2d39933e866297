"""The one place that looks at what the user gave: :func:`open_source` -> :class:`Source`.

A :class:`Source` is a read-only, lazily read movie of 2-D label images
indexed ``[row, col]`` (or, for polygon files, of cell polygons:
``source.kind == "polygons"``, see :mod:`hexatissue.polygons`):
``source.frame(t)`` (or ``source[t]``) reads frame
``t`` and nothing else, and validates it once with
:func:`hexatissue.mesh.labels.validate_labels`.  It also carries the
periodic box of simulation runs, whether label ids are already consistent
over time, and the physical :class:`~hexatissue.units.Calibration` found in
the file's own metadata (ImageJ, OME-XML, OME-Zarr) or given by the user.

Axis rules, the same for TIFF files, arrays and OME-Zarr images:

- the last two axes are rows (Y) and columns (X); a trailing sample axis
  of 3 or 4 values (RGB / RGBA; arrays and ``.npy`` files too) is
  collapsed to one integer per pixel: equal channels give that channel,
  distinct colours give ``R << 16 | G << 8 | B`` (8-bit; ``R << 32 | G << 16 | B``
  for 16-bit channels); a 3-D array with a last axis of 3 or 4 is read as
  RGB with a warning (pass ``list(array)`` for frames 3 or 4 px wide);
- a channel axis (C) of more than one channel needs ``channel=``;
- the frame axis is T; when there is no T axis (or it has a single
  entry) any other single axis (e.g. Z, or ImageJ's untyped "images") is
  read as time, and ``description["notes"]`` says so (ImageJ saves plain
  stacks as Z slices unless told otherwise, so a time series often comes
  as Z); T and Z both longer than one is an error;
- arrays without axis names are ``rows x cols``, ``T x rows x cols`` or
  ``T x C x rows x cols`` (the last needs ``channel=``).
"""
from __future__ import annotations

import os
import re
import threading
import warnings
from dataclasses import dataclass, field, replace
from functools import partial
from pathlib import Path

import numpy as np

from .box import Box
from .errors import HexatissueWarning, InputError, user_stacklevel
from .exchange.ctc import is_ctc_folder
from .mesh.labels import checked_labels
from .polygons import POLYGON_SUFFIXES, open_polygons
from .units import Calibration, normalize_length_unit, normalize_time_unit

__all__ = ["Source", "open_source"]

IMAGE_SUFFIXES = (".tif", ".tiff", ".png")
FILE_SUFFIXES = (".tif", ".tiff", ".png", ".npy", ".npz") + POLYGON_SUFFIXES
MPF_FORMAT = "hexatissue-mpf"  # attrs["format"] of a run store (hexatissue.simulate.store), what read_run needs
NON_SQUARE = "non-square pixels: hexatissue uses the x (column) pixel size for all lengths"
_KEY_USE = "key= selects an array in a .npz, a Cellpose _seg.npy or a zarr group"
_LEVEL_USE = "level= selects a resolution level of an OME-Zarr image"


# ---------------------------------------------------------------------------------------------------------
# the Source
# ---------------------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class Source:
    """A movie of 2-D label images, read lazily one frame at a time.

    Made by :func:`open_source`; not meant to be built directly.

    Attributes
    ----------
    n_frames : int
        Number of frames (at least 1).
    shape : tuple of int
        ``(rows, cols)`` of every frame.
    box : Box or None
        The periodic box of an MPF run (``run.box``); None for images, which
        are open (not periodic).
    ids_consistent : bool
        True when a label id names the same cell in every frame (MPF runs);
        False for label files and arrays, whose ids must be tracked.
    calibration : Calibration
        Pixel size and frame interval with their units.
    description : dict
        JSON-serialisable account of what was opened: ``kind`` (``"tiff"``,
        ``"png"``, ``"npy"``, ``"cellpose"``, ``"npz"``, ``"zarr"``,
        ``"ome-zarr"``, ``"mpf_run"``, ``"array"``, ``"list"``,
        ``"folder"``, ``"ctc"``; for polygons ``"vertices_table"``,
        ``"tissue_analyzer"``, ``"polygon_mat"`` or ``"polygon_mat_folder"``),
        ``path`` (str or None), ``key``, ``channel``,
        ``level``, ``axes`` (axis letters of the data as stored, e.g.
        ``"TCYX"``), ``stored_shape``, ``dtype``, ``frame_axis`` (letter of
        the axis read as time, or None for a single image), ``notes``
        (list of str: choices made while reading) and kind-specific entries.
    parents : dict or None
        ``{daughter track: mother track}`` of the divisions recorded with the
        masks (Cell Tracking Challenge folders); :func:`hexatissue.analyze`
        uses them as the lineage when the ids are kept.  None: divisions are
        found from the masks.
    """

    n_frames: int
    shape: tuple
    box: Box | None
    ids_consistent: bool
    calibration: Calibration
    description: dict
    _reader: object = field(repr=False)
    parents: dict | None = None

    def __post_init__(self):
        if not (isinstance(self.n_frames, int) and self.n_frames >= 1):
            raise InputError(f"Source.n_frames must be a positive int; got {self.n_frames!r}")
        if len(self.shape) != 2:
            raise InputError(f"Source.shape must be (rows, cols); got {self.shape!r}")
        object.__setattr__(self, "shape", (int(self.shape[0]), int(self.shape[1])))

    def _index(self, t) -> int:
        if isinstance(t, (bool, np.bool_)) or not isinstance(t, (int, np.integer)):
            raise InputError(f"frame index must be an integer; got {t!r} ({type(t).__name__})")
        t = int(t)
        if not -self.n_frames <= t < self.n_frames:
            raise InputError(f"frame index {t} is out of range: the source has {self.n_frames} frame(s), "
                             f"indices 0 to {self.n_frames - 1} (or -1 to -{self.n_frames})")
        return t % self.n_frames

    def _raw(self, t) -> np.ndarray:
        """Frame ``t`` as stored (RGB collapsed, native byte order), not validated."""
        arr = self._reader.read(self._index(t))
        return arr if arr.dtype.isnative else arr.astype(arr.dtype.newbyteorder("="))

    def frame(self, t) -> np.ndarray:
        """The label image of frame ``t``, read now (and only it).

        Parameters
        ----------
        t : int
            Frame index, ``0 <= t < n_frames`` (negative indices count from
            the end).

        Returns
        -------
        numpy.ndarray
            2-D non-negative integer array indexed ``[row, col]``.

        Raises
        ------
        InputError
            The index is out of range, the frame cannot be read, or it is
            not a valid label image.
        """
        return self.checked_frame(t)[0]

    def checked_frame(self, t):
        """:meth:`frame`, and its smallest and largest id (None for a bool image), found while checking it."""
        t = self._index(t)
        return checked_labels(self._raw(t), f"frame {t}")

    def image(self, t) -> np.ndarray:
        """Frame ``t`` as an intensity image (float64, not checked as labels): for a raw channel.

        Raises
        ------
        InputError
            The index is out of range, the frame cannot be read, or it is not
            a finite 2-D image.
        """
        t = self._index(t)
        arr = np.asarray(self._raw(t), dtype=float)
        if arr.ndim != 2 or not np.isfinite(arr).all():
            raise InputError(f"frame {t} must be a finite 2-D intensity image; got shape {arr.shape}")
        return arr

    @property
    def kind(self) -> str:
        """``"labels"`` (label images: :meth:`frame`) or ``"polygons"`` (cell polygons: :meth:`polygons`)."""
        return getattr(self._reader, "kind", "labels")

    @property
    def independent(self) -> bool:
        """True when the frames are unrelated images (a folder of polygon files), not a movie: nothing is tracked."""
        return bool(getattr(self._reader, "independent", False))

    def polygons(self, t):
        """The cell polygons of frame ``t`` (:class:`hexatissue.polygons.Polygons`) of a polygon source.

        Raises
        ------
        InputError
            The source holds label images, or the index is out of range.
        """
        if self.kind != "polygons":
            raise InputError(f"this source holds label images, not cell polygons; use source.frame({t!r})")
        return self._reader.polygons(self._index(t))

    def __len__(self) -> int:
        return self.n_frames

    def __getitem__(self, t) -> np.ndarray:
        return self.frame(t)

    def __iter__(self):
        for t in range(self.n_frames):
            yield self.frame(t)

    def with_calibration(self, *, pixel_size=None, length_unit=None, frame_interval=None,
                         time_unit=None) -> "Source":
        """A copy with calibration fields changed (None keeps a field).

        Parameters
        ----------
        pixel_size : float, optional
            Pixel side in ``length_unit`` (or in the current length unit).
        length_unit : str, optional
            ``"um"``, ``"nm"``, ...; ``"px"`` removes the length calibration.
        frame_interval : float, optional
            Time between frames in ``time_unit`` (or the current time unit).
        time_unit : str, optional
            ``"s"``, ``"min"``, ...; ``"frame"`` removes the time calibration.

        Returns
        -------
        Source
            Same frames, new calibration.

        Raises
        ------
        InputError
            ``pixel_size`` (``frame_interval``) is given while neither the
            argument ``length_unit`` (``time_unit``) nor the current
            calibration has a unit, or a value is invalid.
        """
        cal = _override(self.calibration, pixel_size, length_unit, frame_interval, time_unit)
        return replace(self, calibration=cal)

    def __repr__(self):
        d = self.description
        where = f" {d['path']!r}" if d.get("path") else ""
        return (f"Source({d.get('kind')}{where}: {self.n_frames} frame(s) of {self.shape[0]} x {self.shape[1]}, "
                f"{_cal_text(self.calibration)})")


def _cal_text(cal: Calibration) -> str:
    length = f"{cal.pixel_size:g} {cal.length_unit}/px" if cal.has_length else "px"
    time = f"{cal.frame_interval:g} {cal.time_unit}/frame" if cal.has_time else "frames"
    return f"{length}, {time}"


def _override(cal: Calibration, pixel_size, length_unit, frame_interval, time_unit) -> Calibration:
    """``cal`` with the user's values; a number without any unit is refused."""
    if pixel_size is not None and length_unit is None and not cal.has_length:
        raise InputError(f"pixel_size={pixel_size!r} was given but there is no length unit (the source is "
                         f"uncalibrated); pass length_unit= as well (e.g. 'um')")
    if frame_interval is not None and time_unit is None and not cal.has_time:
        raise InputError(f"frame_interval={frame_interval!r} was given but there is no time unit (the source "
                         f"is uncalibrated); pass time_unit= as well (e.g. 's', 'min')")
    if length_unit is not None and pixel_size is None and normalize_length_unit(length_unit) == "px":
        pixel_size = 1.0
    if time_unit is not None and frame_interval is None and normalize_time_unit(time_unit) == "frame":
        frame_interval = 1.0
    return cal.replace(pixel_size=pixel_size, length_unit=length_unit, frame_interval=frame_interval,
                       time_unit=time_unit)


# ---------------------------------------------------------------------------------------------------------
# open_source
# ---------------------------------------------------------------------------------------------------------
def open_source(obj, *, key=None, channel=None, level=None, pixel_size=None, length_unit=None,
                frame_interval=None, time_unit=None) -> Source:
    """Open label images, a label movie or an MPF run as a lazily read :class:`Source`.

    Parameters
    ----------
    obj : Source, array-like, list, MPF run or path
        - a :class:`Source` (returned as is, with calibration overrides);
        - a 2-D array (one frame), a ``T x rows x cols`` array or any lazily
          indexable array-like with ``.shape`` (numpy, memmap, zarr, dask;
          frame ``t`` is read as ``obj[t]``), or ``T x C x rows x cols``
          with ``channel=``;
        - a list or tuple of 2-D arrays of one shape, or of image file paths
          (one frame per file);
        - an MPF run (any object with ``.labels`` and ``.box``, e.g.
          ``hexatissue.simulate.read_run(path)``);
        - a path: ``.tif``/``.tiff`` (read page by page; ImageJ hyperstacks
          and OME-TIFF), ``.png``, ``.npy`` (memory-mapped), Cellpose
          ``*_seg.npy`` (its ``masks``), ``.npz``, a zarr array or group,
          an OME-Zarr image (NGFF 0.4 / 0.5), an MPF run store, or a folder
          of ``.tif``/``.png`` files (one frame per file, natural order:
          ``frame2`` before ``frame10``), or a Cell Tracking Challenge
          folder (``maskTTT.tif`` + ``res_track.txt``, or
          ``TRA/man_trackTTT.tif`` + ``TRA/man_track.txt``): its ids are
          tracks (``ids_consistent``), tracks continuing across a gap are
          given one id again, and its divisions are ``Source.parents``
          (:mod:`hexatissue.exchange.ctc`);
        - cell polygons (a Source of ``kind == "polygons"``, frames read with
          ``source.polygons(t)``; :func:`hexatissue.polygons.open_polygons`):
          a vertices table (``.csv``/``.parquet``), a Tissue Analyzer
          ``.db``, a hexanematic ``.mat`` file or a folder of ``.mat`` files
          (independent images).
    key : str, optional
        The array in a ``.npz`` (default ``"labels"`` or the only array), a
        Cellpose ``_seg.npy`` (default ``"masks"``) or a zarr group
        (default ``"labels"`` or the only array; a sub-group path such as
        ``"labels/cells"`` selects an NGFF label image).
    channel : int, optional
        Index along the channel (C) axis; required when there are several.
    level : int, optional
        Resolution level of an OME-Zarr image (default 0, the full one).
    pixel_size : float, optional
        Overrides the file's pixel size (in ``length_unit``, else in the
        file's unit).
    length_unit : str, optional
        Overrides the file's length unit (``"um"``, ``"nm"``, ...;
        ``"px"`` drops the length calibration).
    frame_interval : float, optional
        Overrides the file's frame interval (in ``time_unit``, else in the
        file's unit).
    time_unit : str, optional
        Overrides the file's time unit (``"s"``, ``"min"``, ``"h"``, ...;
        ``"frame"`` drops the time calibration).

    Returns
    -------
    Source
        ``n_frames``, ``shape``, ``box``, ``ids_consistent``,
        ``calibration``, ``description`` and ``frame(t)``.

    Raises
    ------
    InputError
        A missing path, an unknown suffix, an unreadable file, an array of
        the wrong dimension, an empty list, frames of different shapes, a
        missing ``channel=`` for several channels, ``key``/``channel``/
        ``level`` given where they mean nothing, or a ``pixel_size``
        (``frame_interval``) with no unit anywhere.

    Warns
    -----
    HexatissueWarning
        Non-square pixels (the x size is used), a unit in the file's
        metadata that hexatissue does not know (that calibration is
        ignored), or an ImageJ file with fewer pages than its header says.

    Notes
    -----
    Calibration read from files: ImageJ TIFF (``unit`` and the
    XResolution tag, pixel size = 1 / pixels per unit; ``finterval`` with
    ``tunit``, seconds when ``tunit`` is absent as in ImageJ), OME-TIFF
    (``PhysicalSizeX``/``PhysicalSizeXUnit``, ``TimeIncrement``/
    ``TimeIncrementUnit``), OME-Zarr (the ``scale`` of the chosen level
    and the axis units).  The resolution tags of plain TIFFs are not used
    (72 dpi defaults are common).  MPF runs: one frame every
    ``save_every`` iterations, lengths in px.  Values are rounded to 12
    significant digits (``1.0000000000000002`` -> ``1.0``), pixel sizes
    from ImageJ's resolution tags to 7 (what their 6 decimals hold).
    """
    for name, value in (("channel", channel), ("level", level)):
        if value is not None and (isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer))
                                  or value < 0):
            raise InputError(f"{name} must be a non-negative integer index; got {value!r}")
    if key is not None and not isinstance(key, str):
        raise InputError(f"key must be a str naming an array; got {key!r} ({type(key).__name__})")
    if isinstance(obj, Source):
        _refuse(f"a Source that is already open", key=key, channel=channel, level=level)
        source = obj
    elif isinstance(obj, (str, os.PathLike)):
        source = _open_path(Path(obj), key, channel, level)
    elif _is_run(obj):
        _refuse("an MPF run", key=key, channel=channel, level=level)
        source = _from_run(obj)
    elif _is_zarr_group(obj):
        source = _open_zarr_group(obj, None, key, channel, level)
    elif isinstance(obj, (list, tuple)):
        _refuse("a list of frames", key=key, level=level)
        source = _from_list(obj, channel)
    elif hasattr(obj, "shape") and hasattr(obj, "__getitem__"):
        _refuse("an array", key=key, level=level)
        reader = _ArrayReader("the array", array=obj, channel=channel)
        source = _make(reader, {"kind": "array", "path": None, "channel": _int(channel)})
    else:
        raise InputError(f"obj must be a path, an array (rows x cols or T x rows x cols), a list of 2-D arrays, "
                         f"an MPF run or a Source; got {type(obj).__name__}")
    if any(v is not None for v in (pixel_size, length_unit, frame_interval, time_unit)):
        source = source.with_calibration(pixel_size=pixel_size, length_unit=length_unit,
                                         frame_interval=frame_interval, time_unit=time_unit)
    return source


def _refuse(what, **given):
    """InputError for key/channel/level given where they select nothing."""
    use = {"key": _KEY_USE, "channel": "channel= selects one index of a channel (C) axis",
           "level": _LEVEL_USE}
    for name, value in given.items():
        if value is not None:
            raise InputError(f"{name}={value!r} means nothing for {what}; {use[name]}")


def _is_run(obj) -> bool:
    return hasattr(obj, "labels") and hasattr(obj, "box")


def _is_zarr_group(obj) -> bool:
    return type(obj).__module__.split(".")[0] == "zarr" and hasattr(obj, "array_keys") and hasattr(obj, "attrs")


def _make(reader, description, calibration=None, box=None, ids_consistent=False, parents=None) -> Source:
    desc = {"key": None, "channel": None, "level": None, **description, **reader.describe()}
    return Source(n_frames=int(reader.n_frames), shape=tuple(reader.shape), box=box, ids_consistent=ids_consistent,
                  calibration=calibration or Calibration(), description=desc, _reader=reader, parents=parents)


def _read_error(what, exc) -> InputError:
    return InputError(f"could not read label image {what}: {type(exc).__name__}: {exc}")


# ---------------------------------------------------------------------------------------------------------
# axes: which axis is time, which is the channel, is there an RGB axis
# ---------------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class _Layout:
    """Leading axes (before rows, cols and samples): frame t -> index tuple into them."""

    axes: str  # one letter per leading axis
    sizes: tuple
    frame_axis: int | None
    channel_axis: int | None
    channel: int | None
    notes: tuple = ()

    @property
    def n_frames(self) -> int:
        return 1 if self.frame_axis is None else int(self.sizes[self.frame_axis])

    def index(self, t) -> tuple:
        idx = [0] * len(self.axes)
        if self.frame_axis is not None:
            idx[self.frame_axis] = t
        if self.channel_axis is not None:
            idx[self.channel_axis] = self.channel
        return tuple(idx)


def _plan(axes, sizes, channel, what, full_axes=None) -> _Layout:
    """The layout of leading ``axes`` (letters, e.g. ``"TCZ"``) of ``sizes``; see the module docstring."""
    full_axes = full_axes or axes
    notes = []
    c = axes.find("C")
    if c >= 0 and sizes[c] > 1:
        if channel is None:
            raise InputError(f"{what} has {sizes[c]} channels (axes {full_axes!r}); pass channel= (--channel on the command line) with one of "
                             f"{list(range(sizes[c]))}")
    elif channel is not None and c < 0:
        raise InputError(f"channel={channel!r} was given but {what} has no channel (C) axis (axes {full_axes!r}); "
                         f"leave channel out")
    if c >= 0 and channel is None:
        channel = 0
    if c >= 0 and not channel < sizes[c]:
        raise InputError(f"channel={channel!r} is out of range: {what} has {sizes[c]} channel(s), "
                         f"0 to {sizes[c] - 1}")
    long = [i for i, (a, n) in enumerate(zip(axes, sizes)) if a != "C" and n > 1]
    if "T" in axes and "Z" in axes and all(sizes[axes.index(a)] > 1 for a in "TZ"):
        raise InputError(f"{what} has both a T axis ({sizes[axes.index('T')]}) and a Z axis "
                         f"({sizes[axes.index('Z')]}) (axes {full_axes!r}); hexatissue reads 2-D label frames: "
                         f"save one Z plane or a projection per time point")
    if len(long) > 1:
        raise InputError(f"{what} has axes {full_axes!r} of shape {tuple(sizes)}: more than one axis besides the "
                         f"channel, rows and cols is longer than 1; expected at most one time axis")
    if long:
        frame = long[0]
    else:
        frame = axes.find("T") if "T" in axes else None
    if frame is not None and axes[frame] != "T":
        notes.append(f"the {axes[frame]} axis ({sizes[frame]}) is read as time: there is no T axis "
                     f"{'longer than 1' if 'T' in axes else ''}".rstrip())
    return _Layout(axes, tuple(int(n) for n in sizes), frame, c if c >= 0 else None,
                   channel if c >= 0 else None, tuple(notes))


def _collapse_rgb(arr: np.ndarray) -> np.ndarray:
    """One integer per pixel from a trailing RGB(A) axis.

    Equal channels give that channel; distinct colours of ``b``-bit channels
    (8 or 16) give ``R << 2b | G << b | B``, one id per colour.
    """
    rgb = arr[..., :3]
    if np.array_equal(rgb[..., 0], rgb[..., 1]) and np.array_equal(rgb[..., 0], rgb[..., 2]):
        return np.ascontiguousarray(rgb[..., 0])
    if rgb.dtype.kind not in "iu":
        raise InputError(f"an RGB image of dtype {rgb.dtype} with distinct channels cannot be read as labels; "
                         f"expected 8- or 16-bit integer colours, or pass channel= for one channel")
    bits = 8 if rgb.dtype.itemsize == 1 else 16
    if rgb.min() < 0 or rgb.max() >= 2**bits:
        raise InputError(f"an RGB image of dtype {rgb.dtype} has channel values from {rgb.min()} to {rgb.max()}; "
                         f"colour labels need channels in 0..{2**bits - 1} (8- or 16-bit), or pass channel=")
    rgb = rgb.astype(np.int64)
    return (rgb[..., 0] << (2 * bits)) | (rgb[..., 1] << bits) | rgb[..., 2]


def _array_axes(shape, rgb_allowed=True):
    """Axis letters of an array without names: rows x cols, T x rows x cols, T x C x rows x cols (+ RGB)."""
    rgb = rgb_allowed and len(shape) >= 3 and shape[-1] in (3, 4)
    lead = len(shape) - 2 - rgb
    if lead < 0 or lead > 2:
        raise InputError(f"array has shape {tuple(shape)}; expected rows x cols, T x rows x cols or "
                         f"T x C x rows x cols (with channel=), optionally with a last RGB(A) axis of 3 or 4")
    if rgb and len(shape) == 3:
        # as likely a T x rows x cols stack of 3 or 4 px wide frames: say which reading was taken
        warnings.warn(f"an array of shape {tuple(shape)} is read as one RGB(A) image of {shape[0]} x {shape[1]} "
                      f"px (last axis = colour); to read it as {shape[0]} frames of {shape[1]} x {shape[2]} px, "
                      f"pass list(array)", HexatissueWarning, stacklevel=user_stacklevel())
    return ("", "T", "TC")[lead] + "YX" + ("S" if rgb else "")


# ---------------------------------------------------------------------------------------------------------
# readers: n_frames, shape, read(t) -> raw 2-D frame, describe() -> dict; picklable (files reopen lazily)
# ---------------------------------------------------------------------------------------------------------
class _ArrayReader:
    """Frames of an indexable array (numpy, memmap, zarr, dask, MPF labels, an opened file's array).

    ``opener`` (a picklable callable returning the array) is used for file-backed arrays: the array is
    opened on first use and not pickled.
    """

    def __init__(self, what, *, array=None, opener=None, axes=None, channel=None, rgb_allowed=True):
        self.what, self._opener = what, opener
        self._arr = array if array is not None else opener()
        shape = tuple(int(n) for n in self._arr.shape)
        self.axes = axes or _array_axes(shape, rgb_allowed)
        if len(self.axes) != len(shape):
            raise InputError(f"{what} has shape {shape}, which does not match its axes {self.axes!r}")
        self.rgb = self.axes.endswith("S")
        tail = 3 if self.rgb else 2
        self.layout = _plan(self.axes[:-tail], shape[:-tail], channel, what, self.axes)
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
        return _describe(self.axes, self.stored_shape, self.dtype, self.layout)

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
            raise _read_error(f"{self.what} (frame {t})", exc) from exc
        if not arr.flags.writeable:  # a read-only memory map: hand out an ordinary array
            arr = arr.copy()
        return _collapse_rgb(arr) if self.rgb else arr


def _describe(axes, stored_shape, dtype, layout, notes=()) -> dict:
    frame = None if layout.frame_axis is None else layout.axes[layout.frame_axis]
    return {"axes": axes, "stored_shape": [int(n) for n in stored_shape], "dtype": str(dtype), "frame_axis": frame,
            "notes": list(layout.notes) + list(notes)}


class _TiffReader:
    """Frames of series 0 of a TIFF file: one positioned read per frame when contiguous, else one page per read.

    Contiguous data are read with a plain file read into a new array, not
    through a memory map: the pages of a map stay in the process's resident
    memory once touched, so streaming a long stack through one would grow
    the reader's RSS by the whole file.
    """

    def __init__(self, path, channel):
        import tifffile

        self.path, self.what = Path(path), repr(str(path))
        self.notes = []
        self._lock = threading.Lock()
        self._tf = None
        tf = tifffile.TiffFile(self.path)
        try:
            self._inspect(tf, channel)
        except BaseException:
            tf.close()
            raise
        if self.mode == "contiguous":
            tf.close()
        else:
            self._tf = tf

    def _inspect(self, tf, channel):
        series = tf.series[0]
        if len(tf.series) > 1:
            self.notes.append(f"the file holds {len(tf.series)} image series; series 0 is read")
        page_axes = series.keyframe.axes
        self.axes, self.stored_shape = series.axes, tuple(int(n) for n in series.shape)
        self.dtype = str(series.dtype)
        if not self.axes.endswith(page_axes) or page_axes.replace("S", "") != "YX":
            raise InputError(f"TIFF {self.what} has axes {self.axes!r} with pages of axes {page_axes!r}; expected "
                             f"pages of rows x cols (YX, optionally with RGB samples S)")
        self.page_axes = page_axes
        lead_axes = self.axes[: len(self.axes) - len(page_axes)]
        lead_sizes = self.stored_shape[: len(lead_axes)]
        self.calibration = _tiff_calibration(tf, self.notes)
        n_pages = int(np.prod(lead_sizes, dtype=np.int64))
        if series.dataoffset is not None:
            self.mode = "contiguous"
            self._offset = int(series.dataoffset)
            self._file_dtype = np.dtype(tf.byteorder + series.dtype.char).str
        elif n_pages > 1 and not _has_page(series, n_pages - 1):
            # ImageJ header promising more images than the file holds (e.g. re-saved compressed): read the IFDs
            n_ifd = len(tf.pages)
            warnings.warn(f"TIFF {self.what}: its ImageJ header says {n_pages} images but the file holds "
                          f"{n_ifd} page(s); reading the pages that are there", HexatissueWarning,
                          stacklevel=user_stacklevel())
            self.notes.append(f"ImageJ header says {n_pages} images (axes {self.axes!r}) but the file holds "
                              f"{n_ifd} page(s); each page is read as a frame")
            self.mode = "ifds"
            lead_axes, lead_sizes = ("I", (n_ifd,)) if n_ifd > 1 else ("", ())
            self.axes = lead_axes + page_axes
            self.stored_shape = tuple(lead_sizes) + tuple(series.keyframe.shape)
        else:
            self.mode = "pages"
        self.layout = _plan(lead_axes, lead_sizes, channel, f"TIFF {self.what}", self.axes)
        self.n_frames = self.layout.n_frames
        self.shape = tuple(int(n) for n, a in zip(series.keyframe.shape, page_axes) if a != "S")

    def __getstate__(self):
        state = dict(self.__dict__)
        state.update(_tf=None, _lock=None)
        return state

    def __setstate__(self, state):
        self.__dict__.update(state)
        self._lock = threading.Lock()

    def __del__(self):
        self.close()

    def close(self):
        tf, self._tf = getattr(self, "_tf", None), None
        if tf is not None:
            tf.close()

    def describe(self) -> dict:
        described = _describe(self.axes, self.stored_shape, self.dtype, self.layout, self.notes)
        return {**described, "tiff_reading": self.mode}

    def read(self, t) -> np.ndarray:
        idx = self.layout.index(t)
        try:
            with self._lock:
                if self.mode == "contiguous":
                    arr = self._read_contiguous(idx)
                else:
                    if self._tf is None:
                        import tifffile

                        self._tf = tifffile.TiffFile(self.path)
                    k = int(np.ravel_multi_index(idx, self.layout.sizes)) if idx else 0
                    pages = self._tf.pages if self.mode == "ifds" else self._tf.series[0].pages
                    arr = pages[k].asarray()
        except Exception as exc:
            raise _read_error(f"{self.what} (frame {t})", exc) from exc
        if "S" in self.page_axes:
            arr = _collapse_rgb(np.moveaxis(arr, self.page_axes.index("S"), -1))
        return arr

    def _read_contiguous(self, idx) -> np.ndarray:
        page_shape = self.stored_shape[len(idx):]
        dtype = np.dtype(self._file_dtype)
        count = int(np.prod(page_shape, dtype=np.int64))
        k = int(np.ravel_multi_index(idx, self.layout.sizes)) if idx else 0
        with open(self.path, "rb") as fh:
            fh.seek(self._offset + k * count * dtype.itemsize)
            arr = np.fromfile(fh, dtype=dtype, count=count)
        if arr.size != count:
            raise OSError(f"the file ends inside image {k} ({arr.size} of {count} values)")
        return arr.reshape(page_shape)


def _has_page(series, k) -> bool:
    try:
        return series.pages[k] is not None
    except IndexError:
        return False


class _PngReader:
    """One PNG image, read with OpenCV (a declared dependency); colour channels reordered to RGB(A)."""

    def __init__(self, path, channel=None):
        self.path, self.what = Path(path), repr(str(path))
        _refuse(f"a PNG file", channel=channel)
        with open(self.path, "rb") as fh:
            head = fh.read(33)
        if head[:8] != b"\x89PNG\r\n\x1a\n" or head[12:16] != b"IHDR":
            raise InputError(f"could not read label image {self.what}: not a PNG file (bad signature)")
        cols, rows = int.from_bytes(head[16:20], "big"), int.from_bytes(head[20:24], "big")
        self.shape = (rows, cols)
        self.n_frames = 1
        self.calibration = Calibration()
        self.dtype = "uint16" if head[24] == 16 else "uint8"
        self.layout = _plan("", (), None, self.what)

    def describe(self) -> dict:
        return _describe("YX", self.shape, self.dtype, self.layout)

    def read(self, t) -> np.ndarray:
        import cv2

        try:
            arr = cv2.imdecode(np.fromfile(self.path, np.uint8), cv2.IMREAD_UNCHANGED)
            if arr is None:
                raise ValueError("OpenCV could not decode the file")
        except Exception as exc:
            raise _read_error(self.what, exc) from exc
        if arr.ndim == 3:  # OpenCV gives BGR(A)
            arr = _collapse_rgb(arr[..., [2, 1, 0] + ([3] if arr.shape[-1] == 4 else [])])
        return arr


def _image_reader(path, channel):
    suffix = Path(path).suffix.lower()
    return _PngReader(path, channel) if suffix == ".png" else _TiffReader(path, channel)


class _FilesReader:
    """One image file per frame; only frame 0's file is opened up front."""

    def __init__(self, paths, channel, what):
        self.paths, self.channel, self.what = [Path(p) for p in paths], channel, what
        first = self._open(0)
        self.shape, self.dtype, self.calibration = first.shape, first.dtype, first.calibration
        self.n_frames = len(self.paths)
        self._first = first.describe()

    def _open(self, t):
        path = self.paths[t]
        try:
            reader = _image_reader(path, self.channel)
        except InputError:
            raise
        except Exception as exc:
            raise _read_error(repr(str(path)), exc) from exc
        if reader.n_frames != 1:
            raise InputError(f"{self.what}: file {path.name!r} (frame {t}) holds {reader.n_frames} frames; "
                             f"expected one image per file")
        return reader

    def describe(self) -> dict:
        notes = [f"one frame per file; frame 0 has axes {self._first['axes']!r}"] + self._first["notes"]
        return {"axes": "TYX", "stored_shape": [self.n_frames, *self.shape], "dtype": self.dtype, "frame_axis": "T",
                "notes": notes, "files": [str(p) for p in self.paths]}

    def read(self, t) -> np.ndarray:
        reader = self._open(t)
        if tuple(reader.shape) != tuple(self.shape):
            raise InputError(f"{self.what}: file {self.paths[t].name!r} (frame {t}) is {reader.shape[0]} x "
                             f"{reader.shape[1]} px; expected {self.shape[0]} x {self.shape[1]} like frame 0")
        arr = reader.read(0)
        getattr(reader, "close", lambda: None)()
        return arr


class _ListReader:
    """Frames given as a list of 2-D arrays (or array-likes) of one shape."""

    def __init__(self, frames):
        self.frames = list(frames)
        shapes = []
        for i, f in enumerate(self.frames):
            shape = tuple(getattr(f, "shape", None) or np.shape(f))
            axes = _array_axes(shape) if len(shape) in (2, 3) else None
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
        self.layout = _plan("T", (self.n_frames,), None, "the list")
        self.dtype = str(getattr(self.frames[0], "dtype", np.asarray(self.frames[0]).dtype))

    def describe(self) -> dict:
        return _describe("TYX" + "S" * self.rgb, (self.n_frames,) + tuple(self.shape), self.dtype, self.layout)

    def read(self, t) -> np.ndarray:
        arr = np.asarray(self.frames[t])
        return _collapse_rgb(arr) if self.rgb else arr


# ---------------------------------------------------------------------------------------------------------
# calibration from file metadata
# ---------------------------------------------------------------------------------------------------------
def _clean(value) -> float:
    """``value`` as float without float noise (12 significant digits)."""
    return float(f"{float(value):.12g}")


def _file_unit(unit, normalize, kind, notes):
    """Canonical unit from a file's metadata, or None (with a warning) when hexatissue does not know it."""
    try:
        return normalize(str(unit))
    except InputError:
        warnings.warn(f"unknown {kind} unit {unit!r} in the file's metadata; that calibration is ignored (pass "
                      f"{'length_unit' if kind == 'length' else 'time_unit'}= to set it)", HexatissueWarning,
                      stacklevel=user_stacklevel())
        notes.append(f"unknown {kind} unit {unit!r} in the metadata: ignored")
        return None


def _calibration(notes, size_x=None, size_y=None, length_unit=None, interval=None, time_unit=None) -> Calibration:
    """A Calibration from raw metadata values (None or non-positive = absent); units are file spellings."""
    fields = {}
    lu = _file_unit(length_unit, normalize_length_unit, "length", notes) if length_unit is not None else None
    if lu not in (None, "px") and size_x is not None and np.isfinite(size_x) and size_x > 0:
        fields.update(pixel_size=_clean(size_x), length_unit=lu)
        if size_y is not None and size_y > 0 and not np.isclose(size_x, size_y, rtol=1e-6):
            warnings.warn(NON_SQUARE, HexatissueWarning, stacklevel=user_stacklevel())
            notes.append(f"non-square pixels: x {_clean(size_x)} and y {_clean(size_y)} {lu}; "
                         f"the x size is used for all lengths")
    elif lu == "px" and size_x not in (None, 1, 1.0):
        notes.append(f"the length unit is pixels; the pixel size {_clean(size_x)} in the metadata is ignored")
    tu = _file_unit(time_unit, normalize_time_unit, "time", notes) if time_unit is not None else None
    if tu not in (None, "frame") and interval is not None and np.isfinite(interval) and interval > 0:
        fields.update(frame_interval=_clean(interval), time_unit=tu)
    return Calibration(**fields)


def _tiff_calibration(tf, notes) -> Calibration:
    if tf.is_ome and tf.ome_metadata:
        return _ome_xml_calibration(tf.ome_metadata, notes)
    md = tf.imagej_metadata if tf.is_imagej else None
    if not md:
        return Calibration()
    page = tf.pages[0]

    def per_pixel(tag):
        t = page.tags.get(tag)
        if t is None:
            return None
        num, den = t.value if isinstance(t.value, tuple) else (t.value, 1)
        # pixel size = 1 / (pixels per unit); ImageJ stores pixels per unit with 6 decimals, so 7
        # significant digits of the pixel size are all it holds (0.275 um, not 0.275000048)
        return float(f"{den / num:.7g}") if num else None

    unit = md.get("unit")
    size_x, size_y = per_pixel("XResolution"), per_pixel("YResolution")
    if unit is not None and size_x is None:
        size_x = size_y = 1.0  # ImageJ: a unit without a resolution means 1 unit per pixel
    interval = md.get("finterval")
    # ImageJ writes tunit only when it is not its default, seconds
    tunit = md.get("tunit", "sec") if interval else None
    return _calibration(notes, size_x, size_y, unit, float(interval) if interval else None, tunit)


def _ome_xml_calibration(xml, notes) -> Calibration:
    import xml.etree.ElementTree as ET

    root = ET.fromstring(xml)
    pixels = next((e for e in root.iter() if e.tag.rsplit("}", 1)[-1] == "Pixels"), None)
    if pixels is None:
        return Calibration()
    a = pixels.attrib

    def number(name):
        return float(a[name]) if name in a else None

    size_x = number("PhysicalSizeX")
    length_unit = a.get("PhysicalSizeXUnit", "µm") if size_x is not None else None  # OME's default unit
    interval = number("TimeIncrement")
    time_unit = a.get("TimeIncrementUnit", "s") if interval is not None else None
    return _calibration(notes, size_x, number("PhysicalSizeY"), length_unit, interval, time_unit)


# ---------------------------------------------------------------------------------------------------------
# paths
# ---------------------------------------------------------------------------------------------------------
def _open_path(path: Path, key, channel, level) -> Source:
    if not path.exists():
        raise InputError(f"path {str(path)!r} does not exist; expected a label image or polygon file "
                         f"({', '.join(FILE_SUFFIXES)}), a folder of images, a zarr store or an MPF run (.zarr)")
    try:
        if path.is_dir():
            if _is_zarr_dir(path):
                return _open_zarr_path(path, key, channel, level)
            if path.suffix.lower() == ".zarr":
                raise InputError(f"path {str(path)!r} is not a zarr store (no zarr.json, .zgroup or .zarray in it)")
            if _is_polygon_folder(path):
                _refuse("a folder of polygon files", key=key, channel=channel, level=level)
                return open_polygons(path)
            if is_ctc_folder(path):
                return _open_ctc(path, key, channel, level)
            _refuse("a folder of images", key=key, level=level)
            return _open_folder(path, channel)
        suffix = path.suffix.lower()
        if suffix in POLYGON_SUFFIXES:
            _refuse("a polygon file", key=key, channel=channel, level=level)
            return open_polygons(path)
        if suffix in (".tif", ".tiff"):
            _refuse("a TIFF file", key=key, level=level)
            reader = _TiffReader(path, channel)
            return _make(reader, {"kind": "tiff", "path": str(path), "channel": _int(channel)}, reader.calibration)
        if suffix == ".png":
            _refuse("a PNG file", key=key, channel=channel, level=level)
            return _make(_PngReader(path), {"kind": "png", "path": str(path)})
        if suffix == ".npy":
            _refuse("a .npy file", level=level)
            if path.name.endswith("_seg.npy"):
                key = key or "masks"
                reader = _ArrayReader(repr(str(path)), opener=partial(_cellpose_entry, path, key), channel=channel)
                return _make(reader, {"kind": "cellpose", "path": str(path), "key": key, "channel": _int(channel)})
            _refuse("a .npy file (it holds one array)", key=key)
            opener = partial(np.load, path, mmap_mode="r", allow_pickle=False)
            reader = _ArrayReader(repr(str(path)), opener=opener, channel=channel)
            return _make(reader, {"kind": "npy", "path": str(path), "channel": _int(channel)})
        if suffix == ".npz":
            _refuse("a .npz file", level=level)
            key = _npz_key(path, key)
            reader = _ArrayReader(repr(str(path)), opener=partial(_npz_entry, path, key), channel=channel)
            return _make(reader, {"kind": "npz", "path": str(path), "key": key, "channel": _int(channel)})
    except InputError:
        raise
    except Exception as exc:  # any reader failure becomes a clear InputError
        raise _read_error(repr(str(path)), exc) from exc
    raise InputError(f"path {str(path)!r} has unknown suffix {path.suffix!r}; expected one of {FILE_SUFFIXES}, "
                     f"a folder of images or a zarr store")


def _int(value):
    return None if value is None else int(value)


def _is_polygon_folder(path: Path) -> bool:
    """A folder of hexanematic ``.mat`` polygon files and no images."""
    suffixes = {p.suffix.lower() for p in path.iterdir() if p.is_file() and not p.name.startswith(".")}
    return ".mat" in suffixes and not suffixes & set(IMAGE_SUFFIXES)


def _cellpose_entry(path, key):
    # Cellpose saves a pickled dict; only files of that name are unpickled
    data = np.load(path, allow_pickle=True).item()
    arrays = sorted(k for k, v in data.items() if isinstance(v, np.ndarray) and v.ndim >= 2)
    if key not in arrays:
        raise InputError(f"{Path(path).name}: key={key!r} is not an image array of this Cellpose file; "
                         f"it holds {arrays}")
    return np.asarray(data[key])


def _npz_key(path, key):
    with np.load(path, allow_pickle=False) as data:
        names = list(data.keys())
    if key is None:
        key = "labels" if "labels" in names else (names[0] if len(names) == 1 else None)
        if key is None:
            raise InputError(f"{path.name}: choose an array with key= (--key on the command line); it holds {names}")
    if key not in names:
        raise InputError(f"{path.name}: key={key!r} is not an array of this file; it holds {names}")
    return key


def _npz_entry(path, key):
    # zip members cannot be memory-mapped: the array is read whole on first use
    with np.load(path, allow_pickle=False) as data:
        return data[key]


def _natural_key(name):
    """Sort key putting ``frame2`` before ``frame10``."""
    return [int(p) if p.isdigit() else p.lower() for p in re.split(r"(\d+)", name)], name


def _open_folder(path: Path, channel) -> Source:
    files = [p for p in path.iterdir() if p.is_file() and not p.name.startswith(".")]
    images = sorted((p for p in files if p.suffix.lower() in IMAGE_SUFFIXES), key=lambda p: _natural_key(p.name))
    if not images:
        found = sorted({p.suffix.lower() or p.name for p in path.iterdir()})
        inside = sorted(str(p) for p in path.iterdir() if p.suffix.lower() == ".zarr")
        hint = f"; to open a zarr store inside it, pass its path ({', '.join(inside)})" if inside else ""
        raise InputError(f"folder {str(path)!r} holds no .tif/.tiff/.png files (found {found}); expected one label "
                         f"image per frame{hint}")
    kinds = {"png" if p.suffix.lower() == ".png" else "tiff" for p in images}
    if len(kinds) > 1:
        raise InputError(f"folder {str(path)!r} mixes .png and .tif files; expected one kind of image file per "
                         f"frame (move the others away)")
    return _from_files(images, channel, {"kind": "folder", "path": str(path)}, f"folder {str(path)!r}")


def _open_ctc(path: Path, key, channel, level) -> Source:
    """A Cell Tracking Challenge folder: masks whose ids are tracks (consistent), divisions from its track file."""
    from .exchange.ctc import CtcReader

    _refuse("a Cell Tracking Challenge folder", key=key, channel=channel, level=level)
    reader = CtcReader(path)
    desc = {"kind": "ctc", "path": str(path), "layout": reader.layout, "gaps_merged": len(reader.same)}
    return _make(reader, desc, reader.calibration, ids_consistent=True, parents=reader.parents)


def _from_files(paths, channel, description, what) -> Source:
    reader = _FilesReader(paths, channel, what)
    return _make(reader, {**description, "channel": _int(channel)}, reader.calibration)


def _from_list(frames, channel) -> Source:
    if len(frames) == 0:
        raise InputError("the list of frames is empty; expected at least one label image")
    if all(isinstance(f, (str, os.PathLike)) for f in frames):
        paths = [Path(f) for f in frames]
        for i, p in enumerate(paths):
            if not p.is_file() or p.suffix.lower() not in IMAGE_SUFFIXES:
                raise InputError(f"frames[{i}] = {str(p)!r} is not an existing .tif/.tiff/.png file; a list of "
                                 f"paths gives one frame per image file")
        return _from_files(paths, channel, {"kind": "list", "path": None}, "the list of files")
    _refuse("a list of 2-D arrays", channel=channel)
    return _make(_ListReader(frames), {"kind": "list", "path": None})


def _from_run(run, path=None) -> Source:
    attrs = dict(getattr(run, "attrs", None) or {})
    labels = run.labels
    n = int(labels.shape[0]) if hasattr(labels, "shape") else len(labels)
    if n < 1:
        raise InputError("the MPF run holds no frames yet; expected at least one")
    reader = _ArrayReader("the MPF run's labels", array=labels, axes="TYX", rgb_allowed=False)
    save_every = attrs.get("save_every")
    calibration = Calibration(frame_interval=float(save_every), time_unit="iteration") if save_every else Calibration()
    run_path = getattr(run, "path", path)
    desc = {"kind": "mpf_run", "path": None if run_path is None else str(run_path),
            "save_every": None if save_every is None else int(save_every)}
    for name in ("seed", "relax", "steps", "format_version"):
        if isinstance(attrs.get(name), (int, np.integer)):
            desc[name] = int(attrs[name])
    return _make(reader, desc, calibration, box=run.box, ids_consistent=True)


# ---------------------------------------------------------------------------------------------------------
# zarr: arrays, groups, OME-Zarr (NGFF), MPF run stores
# ---------------------------------------------------------------------------------------------------------
def _is_zarr_dir(path: Path) -> bool:
    return any((path / name).exists() for name in ("zarr.json", ".zgroup", ".zarray"))


def _zarr_node(path, key=None):
    import zarr

    node = zarr.open(str(path), mode="r")
    return node if key is None else node[key]


def _is_zarr_array(node) -> bool:
    return hasattr(node, "shape") and not hasattr(node, "array_keys")


def _open_zarr_path(path: Path, key, channel, level) -> Source:
    node = _zarr_node(path)
    if _is_zarr_array(node):
        _refuse("a zarr array", key=key, level=level)
        reader = _ArrayReader(repr(str(path)), opener=partial(_zarr_node, path), channel=channel)
        return _make(reader, {"kind": "zarr", "path": str(path), "channel": _int(channel)})
    return _open_zarr_group(node, path, key, channel, level)


def _ngff(attrs):
    """The first multiscales entry of NGFF 0.4 (``attrs["multiscales"]``) or 0.5 (``attrs["ome"]``), else None."""
    ms = attrs.get("multiscales") or (attrs.get("ome") or {}).get("multiscales")
    return ms[0] if ms else None


def _open_zarr_group(group, path, key, channel, level) -> Source:
    attrs = dict(group.attrs)
    where = repr(str(path)) if path is not None else "the zarr group"
    if attrs.get("format") == MPF_FORMAT:
        _refuse("an MPF run store", key=key, channel=channel, level=level)
        if path is None:
            raise InputError("a zarr group holding an MPF run must be given as its path (or as "
                             "hexatissue.simulate.read_run(path))")
        from .simulate.store import read_run

        return _from_run(read_run(path), path)
    node = group
    if key is not None:
        try:
            node = group[key]
        except KeyError:
            raise InputError(f"zarr group {where}: key={key!r} is not in it; it holds arrays "
                             f"{sorted(group.array_keys())} and groups {sorted(group.group_keys())}") from None
        if _is_zarr_array(node):
            _refuse("a zarr array", level=level)
            opener = partial(_zarr_node, path, key) if path is not None else None
            reader = _ArrayReader(f"{where} key {key!r}", array=None if opener else node, opener=opener,
                                  channel=channel)
            return _make(reader, {"kind": "zarr", "path": _str(path), "key": key, "channel": _int(channel)})
        attrs = dict(node.attrs)
    ms = _ngff(attrs)
    if ms is not None:
        return _open_ome_zarr(node, ms, path, key, channel, level, where)
    if key is not None:
        raise InputError(f"zarr group {where}: key={key!r} is a group without OME-Zarr multiscales; expected an "
                         f"array or an OME-Zarr image")
    _refuse(f"zarr group {where} (not an OME-Zarr image)", level=level)
    names = sorted(group.array_keys())
    chosen = "labels" if "labels" in names else (names[0] if len(names) == 1 else None)
    if chosen is None:
        raise InputError(f"zarr group {where}: choose an array with key= (--key on the command line); it holds arrays {names} and groups "
                         f"{sorted(group.group_keys())}")
    return _open_zarr_group(group, path, chosen, channel, level)


def _str(path):
    return None if path is None else str(path)


def _open_ome_zarr(group, ms, path, key, channel, level, where) -> Source:
    datasets = ms.get("datasets") or []
    level = 0 if level is None else int(level)
    if not level < len(datasets):
        raise InputError(f"level={level} is out of range: OME-Zarr image {where} has {len(datasets)} level(s), "
                         f"0 to {len(datasets) - 1} (paths {[d.get('path') for d in datasets]})")
    dataset = datasets[level]
    ndim = len(group[dataset["path"]].shape)
    # NGFF 0.1/0.2 have no "axes": their images are (t, c, z, y, x); 0.3 names them with strings
    axes = [a if isinstance(a, dict) else {"name": a} for a in ms.get("axes") or "tczyx"[5 - ndim:]]
    names = [str(a.get("name", "")).lower() for a in axes]
    if names[-2:] != ["y", "x"]:
        raise InputError(f"OME-Zarr image {where} has axes {names}; expected the last two to be 'y' and 'x'")

    def letter(a):
        kind = str(a.get("type", "")).lower()
        name = str(a.get("name", "")).lower()
        if kind == "time" or name == "t":
            return "T"
        if kind == "channel" or name == "c":
            return "C"
        return name.upper() if len(name) == 1 else "Q"

    letters = "".join(letter(a) for a in axes[:-2]) + "YX"
    array_key = dataset["path"] if key is None else f"{key}/{dataset['path']}"
    opener = partial(_zarr_node, path, array_key) if path is not None else None
    array = None if opener else group[dataset["path"]]
    reader = _ArrayReader(f"OME-Zarr image {where} level {level}", array=array, opener=opener,
                          axes=letters, channel=channel)
    scale = _ngff_scale(ms, dataset, len(axes))
    notes = []
    t_axis = letters.find("T")
    calibration = _calibration(notes, scale[-1], scale[-2], axes[-1].get("unit"),
                               scale[t_axis] if t_axis >= 0 else None,
                               axes[t_axis].get("unit") if t_axis >= 0 else None)
    if not calibration.has_length and scale[-1] != 1:
        notes.append(f"pixels of level {level} are {scale[-1]:g} base units wide but the x axis has no unit; "
                     f"lengths are in px of this level")
    labels = group.get("labels") if hasattr(group, "get") else None
    desc = {"kind": "ome-zarr", "path": _str(path), "key": key, "channel": _int(channel), "level": level,
            "dataset_path": str(dataset["path"]), "n_levels": len(datasets), "scale": [float(s) for s in scale],
            "axis_names": names}
    if labels is not None and "labels" in dict(getattr(labels, "attrs", {})):
        desc["ngff_labels"] = [f"labels/{n}" for n in dict(labels.attrs)["labels"]]
    source = _make(reader, desc, calibration)
    source.description["notes"].extend(notes)
    return source


def _ngff_scale(ms, dataset, n_axes):
    """Scale per axis of one level: the dataset's scale times the multiscale's own (NGFF coordinateTransformations)."""
    scale = np.ones(n_axes)
    for transforms in (dataset.get("coordinateTransformations"), ms.get("coordinateTransformations")):
        for tr in transforms or []:
            if tr.get("type") == "scale" and "scale" in tr:
                scale = scale * np.asarray(tr["scale"], float)
    return [float(s) for s in scale]
