"""One image file per frame: a folder of ``.tif``/``.png`` files (natural order) or a list of file paths."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import InputError
from .base import Opened, natural_key, optional_int, read_error
from .png import PngReader
from .tiff import TiffReader

__all__ = ["IMAGE_SUFFIXES", "image_reader", "FilesReader", "open_folder", "open_files"]

IMAGE_SUFFIXES = (".tif", ".tiff", ".png")


def image_reader(path, channel):
    """The reader of one ``.png`` (:class:`PngReader`) or TIFF (:class:`TiffReader`) file."""
    suffix = Path(path).suffix.lower()
    return PngReader(path, channel) if suffix == ".png" else TiffReader(path, channel)


class FilesReader:
    """One image file per frame; only frame 0's file is opened up front.

    Parameters
    ----------
    paths : list of path
        One ``.tif``/``.tiff``/``.png`` file per frame, each holding one image.
    channel : int or None
        Index along the channel axis of every file.
    what : str
        What the files are, for error messages (``"folder 'x'"``).
    """

    def __init__(self, paths, channel, what):
        self.paths, self.channel, self.what = [Path(p) for p in paths], channel, what
        first = self._open(0)
        self.shape, self.dtype, self.calibration = first.shape, first.dtype, first.calibration
        self.n_frames = len(self.paths)
        self._first = first.describe()

    def _open(self, t):
        path = self.paths[t]
        try:
            reader = image_reader(path, self.channel)
        except InputError:
            raise
        except Exception as exc:
            raise read_error(repr(str(path)), exc) from exc
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


def _from_files(paths, channel, description, what) -> Opened:
    reader = FilesReader(paths, channel, what)
    return Opened(reader, {**description, "channel": optional_int(channel)}, reader.calibration)


def open_folder(path: Path, channel) -> Opened:
    """A folder of ``.tif``/``.tiff`` or ``.png`` files (not both), one frame per file in natural order."""
    files = [p for p in path.iterdir() if p.is_file() and not p.name.startswith(".")]
    images = sorted((p for p in files if p.suffix.lower() in IMAGE_SUFFIXES), key=lambda p: natural_key(p.name))
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


def open_files(frames, channel) -> Opened:
    """A list of image file paths, one frame per file, in the list's order."""
    paths = [Path(f) for f in frames]
    for i, p in enumerate(paths):
        if not p.is_file() or p.suffix.lower() not in IMAGE_SUFFIXES:
            raise InputError(f"frames[{i}] = {str(p)!r} is not an existing .tif/.tiff/.png file; a list of "
                             f"paths gives one frame per image file")
    return _from_files(paths, channel, {"kind": "list", "path": None}, "the list of files")
