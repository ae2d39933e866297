"""TIFF files (tifffile): series 0, read frame by frame; ImageJ hyperstacks and OME-TIFF with their calibration."""
from __future__ import annotations

import threading
import warnings
from pathlib import Path

import numpy as np

from ..errors import HexatissueWarning, InputError, user_stacklevel
from .base import Opened, check_axes, collapse_rgb, layout_description, optional_int, plan, read_error
from .calibration import tiff_calibration

__all__ = ["TiffReader", "open_tiff"]


class TiffReader:
    """Frames of series 0 of a TIFF file: one positioned read per frame when contiguous, else one page per read.

    Contiguous data are read with a plain file read into a new array, not
    through a memory map: the pages of a map stay in the process's resident
    memory once touched, so streaming a long stack through one would grow
    the reader's RSS by the whole file.
    """

    def __init__(self, path, channel, axes=None):
        import tifffile

        self.path, self.what = Path(path), repr(str(path))
        self.notes = []
        self._lock = threading.Lock()
        self._tf = None
        tf = tifffile.TiffFile(self.path)
        try:
            self._inspect(tf, channel, axes)
        except BaseException:
            tf.close()
            raise
        if self.mode == "contiguous":
            tf.close()
        else:
            self._tf = tf

    def _inspect(self, tf, channel, axes):
        series = tf.series[0]
        pages_as_frames = False
        if len(tf.series) > 1:
            # tifffile.TiffWriter.write called once per frame: one series per page, all alike
            pages_as_frames = (not tf.is_ome and len(tf.pages) == len(tf.series)
                               and all(s.shape == series.shape and s.dtype == series.dtype and s.axes == series.axes
                                       and s.axes == s.keyframe.axes for s in tf.series))
            if pages_as_frames:
                self.notes.append(f"the file holds {len(tf.series)} image series of one page each, all "
                                  f"{series.axes} {tuple(series.shape)} {series.dtype}: each is read as a frame")
            else:
                shapes = sorted({f"{s.axes} {tuple(int(n) for n in s.shape)}" for s in tf.series})
                text = (f"TIFF {self.what} holds {len(tf.series)} image series ({'; '.join(shapes[:4])}"
                        f"{'; ...' if len(shapes) > 4 else ''}); only series 0 ({series.axes} "
                        f"{tuple(int(n) for n in series.shape)}) is read: save the frames as one stack to read "
                        f"them all")
                warnings.warn(text, HexatissueWarning, stacklevel=user_stacklevel())
                self.notes.append(f"the file holds {len(tf.series)} image series; series 0 is read")
        page_axes = series.keyframe.axes
        self.axes, self.stored_shape = series.axes, tuple(int(n) for n in series.shape)
        self.dtype = str(series.dtype)
        if not self.axes.endswith(page_axes) or page_axes.replace("S", "") != "YX":
            raise InputError(f"TIFF {self.what} has axes {self.axes!r} with pages of axes {page_axes!r}; expected "
                             f"pages of rows x cols (YX, optionally with RGB samples S)")
        # planes a page holds besides its rows and cols (planar RGB: samples first) that axes= calls frames
        self._inner = 1
        if axes is not None:
            axes = check_axes(axes, len(self.axes), f"TIFF {self.what} (axes {self.axes!r})")
            if "S" in axes and "S" in page_axes:  # colour as the file says (planar or not): its own axes
                axes = axes[: len(axes) - 3] + page_axes
            if page_axes == "SYX" and "S" not in axes:  # the planes of each page are frames or channels
                self._inner = self.stored_shape[-3]
                page_axes = "YX"
            elif axes[len(axes) - len(page_axes):] not in (page_axes, page_axes.replace("SYX", "YXS")):
                raise InputError(f"axes={axes!r} does not fit TIFF {self.what}: its pages are {page_axes!r}; only "
                                 f"the axes before the pages, or the planes of planar RGB pages, can be renamed")
            self.notes.append(f"axes {axes!r} given for the file's {self.axes!r}")
            self.axes = axes
        elif page_axes == "SYX" and self.stored_shape[-3] in (3, 4) and not (tf.is_imagej or tf.is_ome):
            # tifffile.imwrite(path, stack) of 3 or 4 frames stores them as planar RGB(A): the file cannot tell
            n = self.stored_shape[-3]
            raise InputError(f"TIFF {self.what} holds {n} planes of {self.stored_shape[-2]} x {self.stored_shape[-1]} "
                             f"px marked as planar RGB{'A' if n == 4 else ''} samples, as tifffile.imwrite stores a "
                             f"stack of {n} frames too: say which with axes='TYX' ({n} frames) or axes='SYX' (one "
                             f"colour-labelled image) (--axes on the command line)")
        self.page_axes = page_axes
        lead_axes = self.axes[: len(self.axes) - len(page_axes)]
        lead_sizes = self.stored_shape[: len(lead_axes)]
        self.calibration = tiff_calibration(tf, self.notes)
        n_pages = int(np.prod(lead_sizes, dtype=np.int64)) // self._inner
        if pages_as_frames:
            self.mode = "ifds"
            lead_axes, lead_sizes = "I", (len(tf.pages),)
            self.axes = lead_axes + page_axes
            self.stored_shape = tuple(lead_sizes) + tuple(series.keyframe.shape)
        elif tf.is_imagej and axes is None and len(tf.pages) > max(n_pages, 1) and _pages_alike(tf, series):
            # an ImageJ header describing fewer images than the file's pages: the others would be dropped
            n_ifd = len(tf.pages)
            warnings.warn(f"TIFF {self.what}: its ImageJ header says {n_pages} image(s) (axes {self.axes!r}) but the "
                          f"file holds {n_ifd} pages of the same shape; each page is read as a frame",
                          HexatissueWarning, stacklevel=user_stacklevel())
            self.notes.append(f"ImageJ header says {n_pages} image(s) (axes {self.axes!r}) but the file holds "
                              f"{n_ifd} pages; each page is read as a frame")
            self.mode = "ifds"
            lead_axes, lead_sizes = "I", (n_ifd,)
            self.axes = lead_axes + page_axes
            self.stored_shape = tuple(lead_sizes) + tuple(series.keyframe.shape)
            self._inner = 1
        elif series.dataoffset is not None:
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
        self.layout = plan(lead_axes, lead_sizes, channel, f"TIFF {self.what}", self.axes)
        self.n_frames = self.layout.n_frames
        keyframe = series.keyframe
        self.shape = tuple(int(n) for n, a in zip(keyframe.shape, keyframe.axes) if a in "YX")

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
        described = layout_description(self.axes, self.stored_shape, self.dtype, self.layout, self.notes)
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
                    k, plane = self._page_and_plane(idx)
                    pages = self._tf.pages if self.mode == "ifds" else self._tf.series[0].pages
                    arr = pages[k].asarray()
                    if self._inner > 1:
                        arr = arr[plane]
        except Exception as exc:
            raise read_error(f"{self.what} (frame {t})", exc) from exc
        if "S" in self.page_axes:
            arr = collapse_rgb(np.moveaxis(arr, self.page_axes.index("S"), -1))
        return arr

    def _page_and_plane(self, idx):
        """The page holding frame ``idx`` and its plane in that page (planes named frames by ``axes=``)."""
        k = int(np.ravel_multi_index(idx, self.layout.sizes)) if idx else 0
        return divmod(k, self._inner)

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


def _pages_alike(tf, series) -> bool:
    """Whether every page of the file has the shape and dtype of the series' first page (walks the IFDs once)."""
    key = series.keyframe
    return all(page.shape == key.shape and page.dtype == key.dtype for page in tf.pages)


def _has_page(series, k) -> bool:
    try:
        return series.pages[k] is not None
    except IndexError:
        return False


def open_tiff(path: Path, channel, axes=None) -> Opened:
    """A ``.tif``/``.tiff`` file, with the calibration of its ImageJ or OME metadata."""
    reader = TiffReader(path, channel, axes)
    return Opened(reader, {"kind": "tiff", "path": str(path), "channel": optional_int(channel)}, reader.calibration)
