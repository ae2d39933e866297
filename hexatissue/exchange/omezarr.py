"""Label stacks as OME-Zarr (OME-NGFF 0.4) multiscale images.

:func:`write_ome_zarr_labels` writes a zarr (v2) group with ``multiscales``
metadata: axes ``t`` (time), ``y``, ``x`` (space) with their units when the
calibration has them, one array per level (``0`` the full resolution, then
``1``, ``2``, ... each half the size of the one before), a ``scale``
coordinate transformation per level (frame interval, pixel size x 2**level)
and ``image-label`` metadata marking it as labels.  Levels are made with
:func:`downsample_labels`, the mode of each 2 x 2 block, never a mean (a
mean of two ids is a third id).  :func:`hexatissue.open_source` reads the
file with ``level=``.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import InputError, check_positive
from ..units import as_calibration

__all__ = ["write_ome_zarr_labels", "downsample_labels", "NGFF_LENGTH", "NGFF_TIME"]

NGFF_VERSION = "0.4"
#: hexatissue unit names -> OME-NGFF unit names (also GEFF's)
NGFF_LENGTH = {"um": "micrometer", "nm": "nanometer", "mm": "millimeter", "cm": "centimeter", "m": "meter"}
NGFF_TIME = {"ms": "millisecond", "s": "second", "min": "minute", "h": "hour"}
MAX_CHUNK = 1024  # px per chunk side by default


def downsample_labels(frame) -> np.ndarray:
    """One label image at half the resolution: the mode of each 2 x 2 block.

    Parameters
    ----------
    frame : (rows, cols) integer array
        Label image indexed ``[row, col]``.

    Returns
    -------
    numpy.ndarray
        ``(ceil(rows / 2), ceil(cols / 2))``, same dtype.  Pixel ``[i, j]``
        is the value held by most of the pixels ``[2i:2i+2, 2j:2j+2]``
        (an odd last row or column is repeated); on a tie between two
        values, or when all four differ, the top-left pixel's value (the
        nearest neighbour).
    """
    f = np.asarray(frame)
    if f.ndim != 2 or f.dtype.kind not in "iu":
        raise InputError(f"frame must be a 2-D integer label image; got {f.dtype} of shape {f.shape}")
    f = np.pad(f, ((0, f.shape[0] % 2), (0, f.shape[1] % 2)), mode="edge")
    a, b, c, d = f[0::2, 0::2], f[0::2, 1::2], f[1::2, 0::2], f[1::2, 1::2]
    # pixels of each block holding a's, b's, c's value; d's value never beats all of them alone: any tie
    # involves a (two pairs, or four distinct values), and d's count equals that of the earlier equal pixel
    na = 1 + (a == b) + (a == c) + (a == d)
    nb = 1 + (b == a) + (b == c) + (b == d)
    nc = 1 + (c == a) + (c == b) + (c == d)
    out = np.where(nb > na, b, a)
    return np.where(nc > np.maximum(na, nb), c, out)


def _frames(stack):
    if isinstance(stack, (list, tuple)):
        if not stack:
            raise InputError("stack must hold at least one frame; got an empty sequence")
        return len(stack), lambda t: np.asarray(stack[t]), np.asarray(stack[0]).shape
    if not hasattr(stack, "shape") or len(stack.shape) not in (2, 3):
        raise InputError(f"stack must be a (rows, cols) or (T, rows, cols) label array or a sequence of 2-D "
                         f"frames; got {type(stack).__name__} of shape {getattr(stack, 'shape', '?')}")
    if len(stack.shape) == 2:
        return 1, lambda t: np.asarray(stack), tuple(stack.shape)
    return int(stack.shape[0]), lambda t: np.asarray(stack[t]), tuple(stack.shape[1:])


def _axes(cal):
    axes = [{"name": "t", "type": "time"}, {"name": "y", "type": "space"}, {"name": "x", "type": "space"}]
    if cal.has_time and cal.time_unit in NGFF_TIME:
        axes[0]["unit"] = NGFF_TIME[cal.time_unit]
    if cal.has_length and cal.length_unit in NGFF_LENGTH:
        for a in axes[1:]:
            a["unit"] = NGFF_LENGTH[cal.length_unit]
    return axes


def write_ome_zarr_labels(stack, path, *, calibration=None, levels=1, chunks=None) -> Path:
    """Write a label stack as an OME-Zarr (NGFF 0.4) multiscale image, atomically.

    Parameters
    ----------
    stack : (T, rows, cols) or (rows, cols) integer array-like, or a sequence of 2-D frames
        Label images indexed ``[t, row, col]``, 0 = background; read one frame
        at a time (zarr, dask and memory maps are fine).
    path : str or Path
        The ``.zarr`` folder to write (replaced if it exists).
    calibration : Calibration, dict or None
        Pixel size and frame interval: the ``scale`` of every level is
        ``[frame_interval, pixel_size * 2**level, pixel_size * 2**level]`` and
        the axes carry the units (``micrometer``, ``minute``, ...);
        uncalibrated axes have scale 1 per frame and per level-0 pixel and no
        unit.
    levels : int
        Resolution levels (1: only the full one).
    chunks : tuple of int, optional
        Chunk shape ``(1, rows, cols)`` of level 0 (default: one frame,
        at most 1024 x 1024 px); coarser levels use the same, clipped to
        their size.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    InputError
        A stack that is not integer labels of one shape, ``levels`` < 1 or
        more levels than halvings of the frame, or bad ``chunks``.
    """
    import zarr

    from ..io import atomic_dir

    cal = as_calibration(calibration)
    levels = check_positive(levels, "levels", integer=True)
    n, read, shape = _frames(stack)
    if len(shape) != 2 or min(shape) < 1:
        raise InputError(f"stack frames must be 2-D (rows, cols); got shape {shape}")
    if min(shape) < 2 ** (levels - 1):
        raise InputError(f"levels={levels} halves a {shape[0]} x {shape[1]} frame below 1 px; use at most "
                         f"{int(np.log2(min(shape))) + 1} levels")
    if chunks is None:
        chunks = (1, min(shape[0], MAX_CHUNK), min(shape[1], MAX_CHUNK))
    if len(chunks) != 3 or not all(isinstance(c, (int, np.integer)) and c >= 1 for c in chunks):
        raise InputError(f"chunks must be three positive ints (t, rows, cols); got {chunks!r}")
    first = read(0)
    if first.dtype.kind not in "iu" and first.dtype != bool:
        raise InputError(f"stack must hold integer labels; got dtype {first.dtype}")
    dtype = first.dtype
    spacing = cal.pixel_size if cal.has_length else 1.0
    interval = cal.frame_interval if cal.has_time else 1.0
    datasets = [{"path": str(k), "coordinateTransformations": [
        {"type": "scale", "scale": [float(interval), float(spacing * 2**k), float(spacing * 2**k)]}]}
        for k in range(levels)]
    with atomic_dir(path) as tmp:
        group = zarr.open_group(str(tmp), mode="w", zarr_format=2)
        arrays, size = [], shape
        for k in range(levels):
            arrays.append(group.create_array(str(k), shape=(n, *size), dtype=dtype, fill_value=0,
                                             chunks=(1, min(chunks[1], size[0]), min(chunks[2], size[1]))))
            size = ((size[0] + 1) // 2, (size[1] + 1) // 2)
        for t in range(n):
            frame = first if t == 0 else read(t)
            if frame.shape != shape or frame.dtype.kind not in "iub":
                raise InputError(f"stack frame {t} is {frame.dtype} {frame.shape}; expected integer labels of "
                                 f"{shape} like frame 0")
            if frame.size and frame.min() < 0:
                raise InputError(f"stack frame {t} has negative ids; expected 0 = background and positive ids")
            for k, arr in enumerate(arrays):
                if k:
                    frame = downsample_labels(frame)
                arr[t] = frame.astype(dtype, copy=False)
        group.attrs.update({
            "multiscales": [{"version": NGFF_VERSION, "name": Path(path).stem, "axes": _axes(cal),
                             "datasets": datasets, "type": "mode",
                             "metadata": {"method": "mode of each 2 x 2 block (hexatissue.exchange.omezarr)"}}],
            "image-label": {"version": NGFF_VERSION}})
    return Path(path)
