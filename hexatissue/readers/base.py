"""What every reader shares: the :class:`Opened` record, the axis rules, the RGB collapse, the natural sort key.

Axis rules, the same for TIFF files, arrays and OME-Zarr images (see
:mod:`hexatissue.source`): the last two axes are rows and columns, a
trailing sample axis of 3 or 4 values is RGB(A), a channel axis (C) of more
than one channel needs ``channel=``, the frame axis is T or, without a T
axis longer than one, the one other axis longer than one.
"""
from __future__ import annotations

import re
import warnings
from dataclasses import dataclass

import numpy as np

from ..errors import HexatissueWarning, InputError, user_stacklevel

__all__ = ["Opened", "KEY_USE", "LEVEL_USE", "CHANNEL_USE", "refuse", "optional_int", "read_error", "natural_key", "Layout",
           "plan", "collapse_rgb", "array_axes", "layout_description", "check_axes", "AXIS_LETTERS"]

KEY_USE = "key= selects an array in a .npz, a Cellpose _seg.npy or a zarr group"
LEVEL_USE = "level= selects a resolution level of an OME-Zarr image"
CHANNEL_USE = "channel= selects one index of a channel (C) axis"
AXES_USE = "axes= names the dimensions of an array, a .npy / .npz file, a TIFF file or a plain zarr array"


@dataclass(frozen=True, eq=False)
class Opened:
    """An opened input: its reader and what :func:`hexatissue.open_source` makes the Source of.

    Attributes
    ----------
    reader : Reader
        The frames (see :class:`hexatissue.readers.Reader`).
    description : dict
        Entries of ``Source.description`` besides the reader's own
        (``kind``, ``path``, ``key``, ``channel``, ...).
    calibration : Calibration or None
        Read from the file's metadata (None: uncalibrated).
    box : Box or None
        The periodic box (MPF runs).
    ids_consistent : bool
        A label id names the same cell in every frame.
    parents : dict or None
        ``{daughter track: mother track}`` recorded with the masks.
    notes : tuple of str
        Added after the reader's notes in ``description["notes"]``.
    """

    reader: object
    description: dict
    calibration: object = None
    box: object = None
    ids_consistent: bool = False
    parents: dict | None = None
    notes: tuple = ()


def refuse(what, **given):
    """InputError for key/channel/level/axes given where they select nothing."""
    use = {"key": KEY_USE, "channel": CHANNEL_USE, "level": LEVEL_USE, "axes": AXES_USE}
    for name, value in given.items():
        if value is not None:
            raise InputError(f"{name}={value!r} means nothing for {what}; {use[name]}")


def optional_int(value):
    """``int(value)``, None kept (for descriptions)."""
    return None if value is None else int(value)


def read_error(what, exc) -> InputError:
    """The InputError of a reader failure (any exception of a third-party reader)."""
    return InputError(f"could not read label image {what}: {type(exc).__name__}: {exc}")


def natural_key(name):
    """Sort key putting ``frame2`` before ``frame10``."""
    return [int(p) if p.isdigit() else p.lower() for p in re.split(r"(\d+)", name)], name


# ---------------------------------------------------------------------------------------------------------
# axes: which axis is time, which is the channel, is there an RGB axis
# ---------------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Layout:
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


def plan(axes, sizes, channel, what, full_axes=None) -> Layout:
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
    return Layout(axes, tuple(int(n) for n in sizes), frame, c if c >= 0 else None,
                  channel if c >= 0 else None, tuple(notes))


def collapse_rgb(arr: np.ndarray) -> np.ndarray:
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


def array_axes(shape, rgb_allowed=True):
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
                      f"pass axes='TYX' (--axes TYX on the command line)", HexatissueWarning,
                      stacklevel=user_stacklevel())
    return ("", "T", "TC")[lead] + "YX" + ("S" if rgb else "")


#: Axis letters a stored array or TIFF series may be given (``axes=``): time, channel, depth, rows, cols, RGB(A).
AXIS_LETTERS = "TCZYXS"


def check_axes(axes, ndim, what):
    """``axes`` (letters of :data:`AXIS_LETTERS`, one per stored dimension, ending in YX or YXS) as a str."""
    if not isinstance(axes, str) or not axes:
        raise InputError(f"axes must be a string of axis letters ({AXIS_LETTERS}); got {axes!r}")
    axes = axes.upper()
    if set(axes) - set(AXIS_LETTERS) or len(set(axes)) < len(axes) or not axes.replace("S", "").endswith("YX") \
            or ("S" in axes and not axes.endswith(("YXS", "SYX"))):
        raise InputError(f"axes={axes!r}: expected one letter per stored dimension from {AXIS_LETTERS!r}, each "
                         f"once, ending in 'YX' (rows, cols), optionally with RGB samples 'S' (e.g. 'TYX', 'YXS', "
                         f"'TCYX')")
    if len(axes) != ndim:
        raise InputError(f"axes={axes!r} has {len(axes)} letter(s) but {what} has {ndim} dimension(s)")
    return axes


def layout_description(axes, stored_shape, dtype, layout, notes=()) -> dict:
    """The ``describe()`` entries of a reader: axes, stored shape, dtype, frame axis, notes."""
    frame = None if layout.frame_axis is None else layout.axes[layout.frame_axis]
    return {"axes": axes, "stored_shape": [int(n) for n in stored_shape], "dtype": str(dtype), "frame_axis": frame,
            "notes": list(layout.notes) + list(notes)}
