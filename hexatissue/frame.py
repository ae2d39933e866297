"""Containers for one time point (:class:`Frame`) and many (:class:`Movie`).

They hold tidy tables plus metadata and no algorithms.  Positions are in
pixels, ``x`` = column and ``y`` = row, origin at the centre of pixel (0, 0).
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import pandas as pd

from .box import Box
from .errors import InputError

__all__ = ["Frame", "Movie", "MESH_TABLES"]

MESH_TABLES = ("cells", "vertices", "edges", "cell_vertices")


@dataclass
class Frame:
    """The junction network of one image.

    Attributes
    ----------
    cells, vertices, edges, cell_vertices : pandas.DataFrame
        Tables described in :mod:`hexatissue.schema`.
    frame : int or None
        Time point, or None for a single image.
    box : Box or None
        The periodic box, or None for an open image.
    shape : tuple of int
        ``(rows, cols)`` of the source image.
    pixel_size : float
        Physical size of a pixel (``units`` per px); tables stay in pixels.
    units : str
        Physical unit of ``pixel_size``.
    """

    cells: pd.DataFrame
    vertices: pd.DataFrame
    edges: pd.DataFrame
    cell_vertices: pd.DataFrame
    frame: int | None = None
    box: Box | None = None
    shape: tuple = ()
    pixel_size: float = 1.0
    units: str = "px"

    def tables(self) -> dict[str, pd.DataFrame]:
        """The four tables by name."""
        return {name: getattr(self, name) for name in MESH_TABLES}

    def polygons(self) -> dict[int, np.ndarray]:
        """Ordered polygon of every cell: ``{cell: (n, 2) array of (x, y)}``, counter-clockwise in (x, y).

        In a periodic box each polygon is unwrapped to be contiguous around
        its cell (coordinates may then leave ``[0, L)``).
        """
        cv = self.cell_vertices.sort_values(["cell", "rank"])
        xy = self.vertices.set_index("vertex").loc[cv["vertex"], ["x", "y"]].to_numpy()
        cells = cv["cell"].to_numpy()
        starts = np.flatnonzero(np.r_[True, cells[1:] != cells[:-1]]) if len(cells) else np.array([], int)
        out = {}
        for s, e in zip(starts, np.r_[starts[1:], len(cells)]):
            poly = xy[s:e]
            out[int(cells[s])] = self.box.unwrap_polygon(poly) if self.box is not None else poly
        return out

    def write(self, directory, formats=("parquet",)) -> list[Path]:
        """Write every table to ``directory/<table>.<fmt>``; returns the paths written."""
        from .io import write_tables

        return write_tables(self.tables(), directory, formats=formats)


@dataclass
class Movie:
    """Many frames: the per-frame tables concatenated with a ``frame`` column, plus metadata.

    Further tables produced by the time-lapse analysis (``events``,
    ``lineage``, ...) live in :attr:`extra`.
    """

    cells: pd.DataFrame
    vertices: pd.DataFrame
    edges: pd.DataFrame
    cell_vertices: pd.DataFrame
    box: Box | None = None
    shape: tuple = ()
    pixel_size: float = 1.0
    units: str = "px"
    frame_interval: float = 1.0
    extra: dict = field(default_factory=dict)

    @classmethod
    def from_frames(cls, frames, **metadata) -> "Movie":
        """Concatenate :class:`Frame` objects (their ``frame`` attribute, or their position, is the frame index)."""
        frames = list(frames)
        if not frames:
            raise InputError("frames must contain at least one Frame; got an empty sequence")
        tables = {}
        for name in MESH_TABLES:
            parts = []
            for i, f in enumerate(frames):
                t = getattr(f, name)
                t = t.drop(columns="frame", errors="ignore")
                t.insert(0, "frame", i if f.frame is None else int(f.frame))
                parts.append(t)
            tables[name] = pd.concat(parts, ignore_index=True)
        first = frames[0]
        meta = dict(box=first.box, shape=first.shape, pixel_size=first.pixel_size, units=first.units)
        meta.update(metadata)
        return cls(**tables, **meta)

    @property
    def frames(self) -> np.ndarray:
        """Sorted frame indices present in the cells table."""
        return np.unique(self.cells["frame"].to_numpy())

    def __len__(self) -> int:
        return len(self.frames)

    def frame(self, t: int) -> Frame:
        """The :class:`Frame` at time point ``t``."""
        if t not in set(self.frames.tolist()):
            raise InputError(f"frame {t} is not in this movie; it has frames {self.frames.min()}..{self.frames.max()}")
        parts = {}
        for name in MESH_TABLES:
            table = getattr(self, name)
            parts[name] = table[table["frame"] == t].reset_index(drop=True)
        return Frame(**parts, frame=int(t), box=self.box, shape=self.shape, pixel_size=self.pixel_size, units=self.units)

    def tables(self) -> dict[str, pd.DataFrame]:
        """All tables by name (mesh tables first, then :attr:`extra`)."""
        out = {name: getattr(self, name) for name in MESH_TABLES}
        out.update(self.extra)
        return out

    def write(self, directory, formats=("parquet",)) -> list[Path]:
        """Write every table to ``directory/<table>.<fmt>``; returns the paths written."""
        from .io import write_tables

        return write_tables(self.tables(), directory, formats=formats)

    def replace(self, **changes) -> "Movie":
        """A copy with some attributes replaced."""
        return replace(self, **changes)
