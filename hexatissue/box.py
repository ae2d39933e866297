"""Periodic simulation box.

Coordinates follow the package convention: ``x`` is the image column, ``y``
the image row, with the origin at the centre of pixel (0, 0).  A box of size
``(Lx, Ly)`` spans ``[0, Lx) x [0, Ly)``; a label image of shape ``(Ly, Lx)``
fills it exactly.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import InputError, is_real

__all__ = ["Box", "as_box"]


@dataclass(frozen=True)
class Box:
    """A periodic rectangular box (a torus).  An open image has no box: ``box=None`` everywhere.

    Parameters
    ----------
    Lx, Ly : float
        Box lengths along x (columns) and y (rows), in pixels.
    """

    Lx: float
    Ly: float

    def __post_init__(self):
        for name in ("Lx", "Ly"):
            value = getattr(self, name)
            if not is_real(value) or value <= 0:
                raise InputError(f"Box.{name} must be a positive finite length in pixels; got {value!r}")
            object.__setattr__(self, name, float(value))

    @classmethod
    def from_shape(cls, shape) -> "Box":
        """The box covered by an image of ``shape = (rows, cols)``: ``Box(cols, rows)``."""
        if len(shape) < 2:
            raise InputError(f"shape must have at least two entries (rows, cols); got {shape!r}")
        return cls(float(shape[-1]), float(shape[-2]))

    @property
    def lengths(self) -> np.ndarray:
        """``array([Lx, Ly])``."""
        return np.array([self.Lx, self.Ly], dtype=float)

    def wrap(self, xy):
        """Positions ``(..., 2)`` (x, y) folded into ``[0, L)``."""
        out = np.mod(np.asarray(xy, dtype=float), self.lengths)
        # np.mod returns L itself for tiny negative inputs; fold that back to 0.
        return np.where(out >= self.lengths, 0.0, out)

    def min_image(self, dxy):
        """Displacements ``(..., 2)`` mapped to their shortest periodic image."""
        dxy = np.asarray(dxy, dtype=float)
        L = self.lengths
        return dxy - L * np.round(dxy / L)

    def distance(self, a, b):
        """Euclidean distance between positions ``a`` and ``b`` (minimum image)."""
        return np.hypot(*np.moveaxis(self.min_image(np.asarray(b) - np.asarray(a)), -1, 0))

    def unwrap_polygon(self, vertices, reference=None):
        """Make a polygon ``(n, 2)`` contiguous: each vertex is moved to the image nearest its predecessor.

        The first vertex is first moved to the image nearest ``reference``
        (e.g. the cell centre) when given.
        """
        v = np.asarray(vertices, dtype=float)
        if len(v) == 0:
            return v.copy()
        steps = self.min_image(np.diff(v, axis=0))
        start = v[0] if reference is None else np.asarray(reference, float) + self.min_image(v[0] - reference)
        return np.vstack([start, start + np.cumsum(steps, axis=0)])

    def to_list(self) -> list:
        """``[Lx, Ly]`` (for ``metadata.json``)."""
        return [self.Lx, self.Ly]


def as_box(box, shape=None, name="box"):
    """The one box normaliser: a :class:`Box` or None (open image).

    Parameters
    ----------
    box : Box, True, None or False
        ``True`` builds the periodic box covering an image of ``shape``;
        None and False mean an open image.
    shape : tuple of int, optional
        ``(rows, cols)`` of the image the box must cover exactly.
    name : str
        Argument name used in error messages.
    """
    if box is None or box is False:
        return None
    if box is True:
        if shape is None:
            raise InputError(f"{name}=True needs the image shape to build the periodic box")
        return Box.from_shape(shape)
    if not isinstance(box, Box):
        raise InputError(f"{name} must be a hexatissue.Box, True (periodic image) or None (open image); "
                         f"got {type(box).__name__}")
    if shape is not None and (box.Ly, box.Lx) != (float(shape[-2]), float(shape[-1])):
        raise InputError(f"{name} {box} does not match the image shape {tuple(shape)} (rows, cols); "
                         f"expected Box(Lx={shape[-1]}, Ly={shape[-2]})")
    return box
