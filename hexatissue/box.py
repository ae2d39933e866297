"""Periodic simulation box.

Coordinates follow the package convention: ``x`` is the image column, ``y``
the image row, with the origin at the centre of pixel (0, 0).  A box of size
``(Lx, Ly)`` spans ``[0, Lx) x [0, Ly)``; a label image of shape ``(Ly, Lx)``
fills it exactly.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import InputError

__all__ = ["Box", "check_box", "periodic_or_none"]


@dataclass(frozen=True)
class Box:
    """A rectangular box, periodic in both directions by default.

    Parameters
    ----------
    Lx, Ly : float
        Box lengths along x (columns) and y (rows), in pixels.
    periodic : bool
        Whether opposite sides are identified (a torus).
    """

    Lx: float
    Ly: float
    periodic: bool = True

    def __post_init__(self):
        for name in ("Lx", "Ly"):
            value = getattr(self, name)
            if not np.isfinite(value) or value <= 0:
                raise InputError(f"Box.{name} must be a positive finite length in pixels; got {value!r}")

    @classmethod
    def from_shape(cls, shape, periodic: bool = True) -> "Box":
        """The box covered by an image of ``shape = (rows, cols)``: ``Box(cols, rows)``."""
        if len(shape) < 2:
            raise InputError(f"shape must have at least two entries (rows, cols); got {shape!r}")
        return cls(float(shape[-1]), float(shape[-2]), periodic)

    @property
    def lengths(self) -> np.ndarray:
        """``array([Lx, Ly])``."""
        return np.array([self.Lx, self.Ly], dtype=float)

    def wrap(self, xy):
        """Positions ``(..., 2)`` (x, y) folded into ``[0, L)``; unchanged when not periodic."""
        xy = np.asarray(xy, dtype=float)
        if not self.periodic:
            return xy
        out = np.mod(xy, self.lengths)
        # np.mod returns L itself for tiny negative inputs; fold that back to 0.
        return np.where(out >= self.lengths, 0.0, out)

    def min_image(self, dxy):
        """Displacements ``(..., 2)`` mapped to their shortest periodic image."""
        dxy = np.asarray(dxy, dtype=float)
        if not self.periodic:
            return dxy
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
        if not self.periodic or len(v) == 0:
            return v.copy()
        steps = self.min_image(np.diff(v, axis=0))
        start = v[0] if reference is None else np.asarray(reference, float) + self.min_image(v[0] - reference)
        return np.vstack([start, start + np.cumsum(steps, axis=0)])


def check_box(box):
    """``box`` if it is a :class:`Box` or None; else :class:`InputError`."""
    if box is not None and not isinstance(box, Box):
        raise InputError(f"box must be a hexatissue.Box or None; got {type(box).__name__}")
    return box


def periodic_or_none(box):
    """``box`` when it is a periodic :class:`Box`, None for None or an open box; else :class:`InputError`."""
    check_box(box)
    return box if box is not None and box.periodic else None
