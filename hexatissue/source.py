"""The one place that looks at what the user gave: :func:`open_source` -> :class:`Source`.

A :class:`Source` is a read-only, lazily read movie of 2-D label images
indexed ``[row, col]`` (or, for polygon files, of cell polygons:
``source.kind == "polygons"``, see :mod:`hexatissue.readers.polygons`):
``source.frame(t)`` (or ``source[t]``) reads frame
``t`` and nothing else, and validates it once with
:func:`hexatissue.mesh.labels.validate_labels`.  It also carries the
periodic box of simulation runs, whether label ids are already consistent
over time, and the physical :class:`~hexatissue.units.Calibration` found in
the file's own metadata (ImageJ, OME-XML, OME-Zarr) or given by the user.

Each format is read by a module of :mod:`hexatissue.readers`, which returns
a reader and what the Source needs besides it; this module picks the
reader (:func:`open_source`) and makes the Source, the only place one is
made.  It also reads whole label stacks (:func:`read_labels`) and
region-of-interest masks (:func:`read_mask`), and reopens the labels and
mask a results folder was computed from (:func:`recorded_labels`,
:func:`recorded_mask`).

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
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from .box import Box
from .errors import InputError
from .mesh.labels import check_mask, checked_labels
from .mesh.segment import segment_membrane_map
from .readers.arrays import open_array, open_list, open_npy, open_npz
from .readers.base import Opened, read_error, refuse
from .readers.ctc import is_ctc_folder, open_ctc
from .readers.folder import open_files, open_folder
from .readers.gzipped import gunzip, is_gzipped
from .readers.mpf import is_run, open_run
from .readers.png import open_png
from .readers.polygons import POLYGON_SUFFIXES, is_polygon_folder, open_polygons
from .readers.tiff import open_tiff
from .readers.zarr import is_zarr_dir, is_zarr_group, open_zarr_group, open_zarr_path
from .units import Calibration

__all__ = ["Source", "open_source", "read_labels", "read_mask", "recorded_labels", "recorded_mask", "NOT_A_FILE",
           "MISSING", "FILE_SUFFIXES"]

FILE_SUFFIXES = (".tif", ".tiff", ".png", ".npy", ".npz") + POLYGON_SUFFIXES


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

    def raw_frame(self, t) -> np.ndarray:
        """Frame ``t`` as stored, not checked as a label image (:meth:`frame` checks it).

        For readers of the stored values themselves (:func:`read_labels`,
        :func:`hexatissue.exchange.ctc.check_ctc`): the dtype is the file's
        (in native byte order), RGB(A) is collapsed to one integer per pixel,
        and nothing is validated (negative or float values are kept).

        Parameters
        ----------
        t : int
            Frame index, ``0 <= t < n_frames`` (negative indices count from
            the end).

        Returns
        -------
        numpy.ndarray
            2-D array indexed ``[row, col]``.

        Raises
        ------
        InputError
            The index is out of range or the frame cannot be read (a polygon
            source has no label image).
        """
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

    def checked_frame(self, t, kind="auto"):
        """:meth:`frame`, and its smallest and largest id (None for a bool image), found while checking it.

        With ``kind="membrane-map"`` the frame is a membrane image (or probability map), segmented
        into touching labels first (:func:`hexatissue.mesh.segment.segment_membrane_map`, which warns when the
        number of cells is implausible).
        """
        t = self._index(t)
        if kind == "membrane-map":
            return checked_labels(segment_membrane_map(self.image(t), periodic=self.box is not None), f"frame {t}")
        return checked_labels(self.raw_frame(t), f"frame {t}", kind)

    def image(self, t) -> np.ndarray:
        """Frame ``t`` as an intensity image (float64, not checked as labels): for a raw channel.

        Raises
        ------
        InputError
            The index is out of range, the frame cannot be read, or it is not
            a finite 2-D image.
        """
        t = self._index(t)
        arr = np.asarray(self.raw_frame(t), dtype=float)
        if arr.ndim != 2:
            raise InputError(f"frame {t} must be a finite 2-D intensity image; got shape {arr.shape}")
        bad = ~np.isfinite(arr)
        if bad.any():
            raise InputError(f"frame {t} must be a finite 2-D intensity image; it holds {int(bad.sum())} NaN or "
                             f"infinite value(s)")
        return arr

    def images(self) -> "_Images":
        """The frames as intensity images (:meth:`image`), a lazy sequence: ``len`` and ``[t]``, one read per item."""
        return _Images(self)

    @property
    def kind(self) -> str:
        """``"labels"`` (label images: :meth:`frame`) or ``"polygons"`` (cell polygons: :meth:`polygons`)."""
        return getattr(self._reader, "kind", "labels")

    @property
    def independent(self) -> bool:
        """True when the frames are unrelated images (a folder of polygon files), not a movie: nothing is tracked."""
        return bool(getattr(self._reader, "independent", False))

    def polygons(self, t):
        """The cell polygons of frame ``t`` (:class:`hexatissue.mesh.polygons.Polygons`) of a polygon source.

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
        cal = self.calibration.override(pixel_size=pixel_size, length_unit=length_unit,
                                        frame_interval=frame_interval, time_unit=time_unit)
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


# ---------------------------------------------------------------------------------------------------------
# open_source
# ---------------------------------------------------------------------------------------------------------
def open_source(obj, *, key=None, channel=None, level=None, axes=None, pixel_size=None, length_unit=None,
                frame_interval=None, time_unit=None) -> Source:
    """Open label images, a label movie or an MPF run as a lazily read :class:`Source`.

    Parameters
    ----------
    obj : Source, array-like, list, MPF run or path
        - a :class:`Source` (returned as is, with calibration overrides);
        - a 2-D array (one frame), a ``T x rows x cols`` array or any lazily
          indexable array-like with ``.shape`` (numpy, memmap, zarr, dask;
          frame ``t`` is read as ``obj[t]``), or ``T x C x rows x cols``
          with ``channel=`` (a numpy masked array with masked pixels is
          refused: its mask would not be read);
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
          (:mod:`hexatissue.readers.ctc`);
        - cell polygons (a Source of ``kind == "polygons"``, frames read with
          ``source.polygons(t)``; :func:`hexatissue.readers.polygons.open_polygons`):
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
    axes : str, optional
        What the dimensions of an array, ``.npy``/``.npz`` or TIFF are, one
        letter each from ``TCZYXS`` (time, channel, depth, rows, cols, RGB
        samples), ending in ``YX`` (or ``YXS``): e.g. ``"TYX"`` for a stack
        of 3 or 4 frames that would otherwise read as one colour image (a
        TIFF written by ``tifffile.imwrite`` stores such a stack as planar
        RGB: it is refused until ``axes`` says which).
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
        refuse("a Source that is already open", key=key, channel=channel, level=level, axes=axes)
        source = obj
    elif isinstance(obj, (str, os.PathLike)):
        source = _with_documented_calibration(_open_path(Path(obj), key, channel, level, axes), Path(obj))
    elif is_run(obj):
        refuse("an MPF run", key=key, channel=channel, level=level, axes=axes)
        source = _make(open_run(obj))
    elif is_zarr_group(obj):
        source = _make(open_zarr_group(obj, None, key, channel, level, axes))
    elif isinstance(obj, (list, tuple)):
        refuse("a list of frames", key=key, level=level, axes=axes)
        source = _make(_from_list(obj, channel))
    elif isinstance(obj, np.ma.MaskedArray) and np.ma.getmask(obj) is not np.ma.nomask and np.ma.getmask(obj).any():
        # its frames would be read without the mask, so masked pixels would silently stay cells
        raise InputError(f"a masked array ({int(np.ma.getmask(obj).sum())} masked pixels) is not read with its mask; "
                         f"pass obj.filled(0) to make the masked pixels background, or the region to keep as mask= "
                         f"(--mask on the command line)")
    elif hasattr(obj, "shape") and hasattr(obj, "__getitem__"):
        refuse("an array", key=key, level=level)
        source = _make(open_array(obj, channel, axes))
    else:
        raise InputError(f"obj must be a path, an array (rows x cols or T x rows x cols), a list of 2-D arrays, "
                         f"an MPF run or a Source; got {type(obj).__name__}")
    if any(v is not None for v in (pixel_size, length_unit, frame_interval, time_unit)):
        source = source.with_calibration(pixel_size=pixel_size, length_unit=length_unit,
                                         frame_interval=frame_interval, time_unit=time_unit)
    return source


def _with_documented_calibration(source, path):
    """A bundled sample's Source with what its file's calibration lacks taken from the sample's documentation
    (:func:`hexatissue.samples.documented_calibration`; origin ``"sample"``, and a note saying so)."""
    from .samples import documented_calibration

    documented = documented_calibration(path)
    cal = source.calibration
    if documented is None:
        return source
    changes, filled = {}, []
    if not cal.has_length and documented.has_length:
        changes.update(pixel_size=documented.pixel_size, length_unit=documented.length_unit, length_from="sample")
        filled.append(f"pixel size {documented.pixel_size:g} {documented.length_unit}")
    if not cal.has_time and documented.has_time:
        changes.update(frame_interval=documented.frame_interval, time_unit=documented.time_unit, time_from="sample")
        filled.append(f"frame interval {documented.frame_interval:g} {documented.time_unit}")
    if not changes:
        return source
    notes = [*source.description.get("notes", []),
             f"{' and '.join(filled)} from the bundled sample's documentation (the file's metadata has none)"]
    return replace(source, calibration=replace(cal, **changes), description={**source.description, "notes": notes})


def _absolute(path):
    """A local file's path made absolute, so that a results folder finds it from any folder (URLs stay as they are)."""
    if path and os.path.exists(path):
        return os.path.abspath(path)
    return path


def _make(opened: Opened) -> Source:
    """The Source of an opened input (the one place a Source is made)."""
    reader = opened.reader
    desc = {"key": None, "channel": None, "level": None, **opened.description, **reader.describe()}
    desc["path"] = _absolute(desc.get("path"))
    if opened.notes:
        desc["notes"].extend(opened.notes)
    if int(reader.n_frames) == 0:
        raise InputError(f"{desc.get('path') or 'the input'} holds no frame (a stack of 0 images); expected at least "
                         f"one label image")
    return Source(n_frames=int(reader.n_frames), shape=tuple(reader.shape), box=opened.box,
                  ids_consistent=opened.ids_consistent, calibration=opened.calibration or Calibration(),
                  description=desc, _reader=reader, parents=opened.parents)


def _from_list(frames, channel) -> Opened:
    if len(frames) == 0:
        raise InputError("the list of frames is empty; expected at least one label image")
    if all(isinstance(f, (str, os.PathLike)) for f in frames):
        return open_files(frames, channel)
    refuse("a list of 2-D arrays", channel=channel)
    return open_list(frames)


def _open_path(path: Path, key, channel, level, axes=None) -> Source:
    try:
        path.stat()
    except FileNotFoundError:
        pass  # refused just below, with what is expected
    except (OSError, ValueError) as exc:  # a name too long, a symlink loop, a NUL byte in the name
        detail = getattr(exc, "strerror", None) or exc
        raise InputError(f"path {str(path)!r} cannot be opened: {detail}; expected a label image or polygon file, a "
                         f"folder of images or a zarr store") from None
    if not path.exists():
        raise InputError(f"path {str(path)!r} does not exist; expected a label image or polygon file "
                         f"({', '.join(FILE_SUFFIXES)}), a folder of images, a zarr store or an MPF run (.zarr)")
    if not (path.is_file() or path.is_dir()):  # a FIFO, socket or device would block or stream forever
        raise InputError(f"path {str(path)!r} is not a regular file or a folder (a pipe, socket or device); "
                         f"expected a label image or polygon file, a folder of images or a zarr store")
    try:
        return _make(_path_reader(path, key, channel, level, axes))
    except InputError:
        raise
    except Exception as exc:  # any reader failure becomes a clear InputError
        raise read_error(repr(str(path)), exc) from exc


def _path_reader(path: Path, key, channel, level, axes=None) -> Opened:
    """The reader of an existing path, chosen by what it is (folder, zarr store) and its suffix."""
    if path.is_dir():
        if is_zarr_dir(path):
            return open_zarr_path(path, key, channel, level, axes)
        refuse("a folder (each file is one frame)", axes=axes)
        if path.suffix.lower() == ".zarr":
            raise InputError(f"path {str(path)!r} is not a zarr store (no zarr.json, .zgroup or .zarray in it)")
        if is_polygon_folder(path):
            refuse("a folder of polygon files", key=key, channel=channel, level=level)
            return open_polygons(path)
        if is_ctc_folder(path):
            return open_ctc(path, key, channel, level)
        refuse("a folder of images", key=key, level=level)
        return open_folder(path, channel)
    if is_gzipped(path):
        inner = Path(path.stem).suffix.lower()
        if inner not in FILE_SUFFIXES:
            raise InputError(f"path {str(path)!r} is gzip-compressed {inner or 'data without a suffix'}; expected "
                             f"one of {FILE_SUFFIXES} compressed (e.g. .tif.gz)")
        plain = gunzip(path)
        try:
            opened = _path_reader(plain, key, channel, level, axes)
        except InputError as exc:  # the message names the user's file, not the temporary copy
            raise InputError(str(exc).replace(str(plain), str(path))) from None
        if isinstance(getattr(opened.reader, "what", None), str):  # the same for errors of later frame reads
            opened.reader.what = opened.reader.what.replace(str(plain), str(path))
        return replace(opened, description={**opened.description, "path": str(path)},
                       notes=(*opened.notes, f"decompressed from {path.name} (gzip) into a temporary file"))
    suffix = path.suffix.lower()
    if suffix in POLYGON_SUFFIXES:
        refuse("a polygon file", key=key, channel=channel, level=level, axes=axes)
        return open_polygons(path)
    if suffix in (".tif", ".tiff"):
        refuse("a TIFF file", key=key, level=level)
        return open_tiff(path, channel, axes)
    if suffix == ".png":
        refuse("a PNG file", key=key, channel=channel, level=level, axes=axes)
        return open_png(path)
    if suffix == ".npy":
        refuse("a .npy file", level=level)
        return open_npy(path, key, channel, axes)
    if suffix == ".npz":
        refuse("a .npz file", level=level)
        return open_npz(path, key, channel, axes)
    raise InputError(f"path {str(path)!r} has unknown suffix {path.suffix!r}; expected one of {FILE_SUFFIXES} "
                     f"(each also gzip-compressed, ending in .gz), a folder of images or a zarr store")


# ---------------------------------------------------------------------------------------------------------
# eager reading: a whole label stack, a region-of-interest mask
# ---------------------------------------------------------------------------------------------------------
def read_labels(path, key: str | None = None, *, channel: int | None = None) -> np.ndarray:
    """Read a 2-D label image or a T x Y x X label stack, whole (eager).

    Built on the readers of :func:`hexatissue.open_source`, which reads the
    same files lazily, one frame at a time, with their calibration.

    Parameters
    ----------
    path : str or Path
        ``.tif``/``.tiff`` (tifffile), ``.png``, ``.npy``, a Cellpose
        ``*_seg.npy`` (its ``masks``), ``.npz`` (array ``key``, by default
        ``labels`` or the only array in the file), or any other path
        :func:`hexatissue.open_source` reads (zarr, OME-Zarr, a folder of
        images, an MPF run store).
    key : str, optional
        Array name inside an ``.npz``, a Cellpose ``_seg.npy`` file or a zarr
        group.
    channel : int, optional
        Index along the channel axis of a multi-channel file.

    Returns
    -------
    numpy.ndarray
        Indexed ``[row, col]``, or ``[t, row, col]`` when the data have a
        frame axis.  RGB images with equal channels (skeletons saved as RGB)
        are reduced to one channel; distinct colours become one integer per
        colour (``R << 16 | G << 8 | B``, 16-bit ``R << 32 | G << 16 | B``), decided frame by frame.  Values are
        as stored (not validated).

    Raises
    ------
    InputError
        The file is missing, has an unknown suffix or cannot be read, or has
        several channels and no ``channel``.
    """
    if not isinstance(path, (str, os.PathLike)):
        raise InputError(f"path must be a str or Path; got {type(path).__name__} (use hexatissue.open_source for "
                         f"arrays)")
    source = open_source(path, key=key, channel=channel)
    frames = [source.raw_frame(t) for t in range(source.n_frames)]
    if source.description["frame_axis"] is None:
        return frames[0]
    return np.stack(frames)


def read_mask(mask, shape):
    """A region-of-interest mask as a bool array of ``shape`` and its description for ``metadata.json``.

    Parameters
    ----------
    mask : None, array-like or path
        2-D bool or integer image (nonzero = inside) or a path read with
        :func:`hexatissue.open_source` (one frame).
    shape : tuple of int
        ``(rows, cols)`` of the frames.

    Returns
    -------
    mask : (rows, cols) bool array or None
    info : dict or None
        ``path`` (None for an array), ``shape`` and ``inside`` (pixel count).
    """
    if mask is None:
        return None, None
    path = None
    if isinstance(mask, (str, os.PathLike)):
        path = _absolute(str(mask))
        try:
            src = open_source(mask)
            if src.n_frames != 1:
                raise InputError(f"it must be one 2-D image; it has {src.n_frames} frames")
            mask = src.frame(0)
        except InputError as exc:
            raise InputError(f"mask {path!r}: {exc}") from None
    inside = check_mask(mask, shape)
    return inside, {"path": path, "shape": list(inside.shape), "inside": int(inside.sum())}


# ---------------------------------------------------------------------------------------------------------
# the input a results folder records: its labels and mask again
# ---------------------------------------------------------------------------------------------------------
#: Why :func:`recorded_labels` cannot reopen the labels: the input was not a file (an array, a list, a run
#: object, a synthetic movie), or the recorded path does not exist (moved, or relative to another folder).
NOT_A_FILE, MISSING = "not a file", "missing"


def recorded_labels(description):
    """The labels a results folder was computed from, reopened as recorded in its ``metadata.json``.

    The one place that reads a recorded input description back (for
    ``hexatissue export``'s track masks and the benchmark scorer); each
    caller decides what to do when it cannot.

    Parameters
    ----------
    description : dict or None
        The recorded :attr:`Source.description` (``Movie.source``): its
        ``path`` with ``key``, ``channel`` and ``level``; ``kind`` says what
        it was when it was not a file.

    Returns
    -------
    source : Source or None
        The recorded ``path`` opened with its ``key``, ``channel`` and
        ``level``; None when it cannot be reopened.
    why : str or None
        None, or why not: :data:`NOT_A_FILE` (no ``path`` recorded) or
        :data:`MISSING` (the recorded path does not exist).

    Raises
    ------
    InputError
        The recorded path exists but cannot be opened (as :func:`open_source`).
    """
    desc = description if isinstance(description, dict) else {}
    path = desc.get("path")
    if not path:
        return None, NOT_A_FILE
    if not Path(path).exists():
        return None, MISSING
    return open_source(path, key=desc.get("key"), channel=desc.get("channel"), level=desc.get("level")), None


def recorded_mask(description, shape):
    """The region-of-interest mask a results folder was computed with, read again from its recorded path.

    Parameters
    ----------
    description : dict or None
        The recorded :attr:`Source.description` (``Movie.source``); its
        ``mask`` entry is :func:`read_mask`'s ``info``.
    shape : tuple of int
        ``(rows, cols)`` of the frames.

    Returns
    -------
    mask : (rows, cols) bool array or None
        None when no mask was recorded, or when it was given as an array
        (``info["path"]`` is None: the results folder does not hold it).
    info : dict or None
        The recorded mask entry (None: no mask): the caller tells the two
        None masks apart by it.

    Raises
    ------
    InputError
        The recorded mask cannot be read or has another shape (as :func:`read_mask`).
    """
    info = (description if isinstance(description, dict) else {}).get("mask")
    if not info:
        return None, None
    if not info.get("path"):
        return None, info
    return read_mask(info["path"], shape)[0], info


class _Images:
    """A Source's frames read as intensity images, one at a time (:meth:`Source.images`)."""

    def __init__(self, source):
        self.source = source

    def __len__(self):
        return self.source.n_frames

    def __getitem__(self, t):
        return self.source.image(t)
