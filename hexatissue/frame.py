"""The container of one time point's junction network (:class:`Frame`).

It holds tidy tables plus metadata and no algorithms.  Every table has a
``frame`` column (0 for a single image).  Positions are in pixels, ``x`` =
column and ``y`` = row, origin at the centre of pixel (0, 0).  The physical
units travel in :class:`~hexatissue.units.Calibration`.  A whole analysis
is a :class:`hexatissue.Movie` (:mod:`hexatissue.results`).
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass, field, replace

import numpy as np
import pandas as pd

from .box import Box
from .geometry import mesh_order_polygons, table_polygons
from .units import Calibration

__all__ = ["Frame", "Tables", "MESH_TABLES"]

#: The tables of a junction network.
MESH_TABLES = ("cells", "vertices", "edges", "cell_vertices")


class Tables(dict):
    """A Movie's tables by name, in the schema's order (:data:`hexatissue.schema.TABLES`).

    Calling it (``movie.tables()``, the spelling of hexatissue 0.1) returns a
    plain dict of the same tables; it is deprecated.
    """

    def __call__(self):
        warnings.warn(".tables() is deprecated: .tables is the mapping of tables by name",
                      DeprecationWarning, stacklevel=2)
        return dict(self)


def _polygons(network) -> dict[int, np.ndarray]:
    keys, xy, starts = table_polygons(network.vertices, network.cell_vertices, network.box)
    ends = np.r_[starts[1:], len(xy)]
    return {int(c): xy[s:e] for c, s, e in zip(keys["cell"].to_numpy(), starts, ends)}


@dataclass
class Frame:
    """The junction network of one image.

    Attributes
    ----------
    cells, vertices, edges, cell_vertices : pandas.DataFrame
        Tables described in :mod:`hexatissue.schema`, each with ``frame``.
    frame : int
        Time point (0 for a single image).
    box : Box or None
        The periodic box, or None for an open image.
    shape : tuple of int
        ``(rows, cols)`` of the source image.
    calibration : Calibration
        Pixel size and frame interval (tables stay in px and frames).
    """

    cells: pd.DataFrame
    vertices: pd.DataFrame
    edges: pd.DataFrame
    cell_vertices: pd.DataFrame
    frame: int = 0
    box: Box | None = None
    shape: tuple = ()
    calibration: Calibration = field(default_factory=Calibration)

    def __post_init__(self):
        self._mesh_tables = ()  # cells, vertices, cell_vertices as mesh_from_labels built them (see from_mesh)

    @classmethod
    def from_mesh(cls, tables, frame, box, shape) -> "Frame":
        """The Frame of :func:`hexatissue.mesh_from_labels`: ``tables`` are in its row order.

        It remembers these very tables, so :meth:`mesh_polygons` can read
        the polygons row by row for as long as they are the Frame's tables.
        """
        out = cls(**tables, frame=frame, box=box, shape=shape)
        out._mesh_tables = (out.cells, out.vertices, out.cell_vertices)
        return out

    def mesh_polygons(self):
        """``(xy, starts)`` of the cells with ``n_sides > 0``, in the ``cells`` rows' order, or None.

        Read row by row (:func:`hexatissue.geometry.mesh_order_polygons`),
        without the keys :meth:`polygons` looks up, when the tables are
        those :meth:`from_mesh` was given (None for tables replaced or
        read back from files, and for rows that no longer add up).
        """
        now = (self.cells, self.vertices, self.cell_vertices)
        built = getattr(self, "_mesh_tables", ())  # (absent from a Frame pickled before it existed)
        if len(built) != len(now) or any(a is not b for a, b in zip(built, now)):
            return None
        return mesh_order_polygons(*now, self.box)

    @property
    def tables(self) -> Tables:
        """The four tables by name."""
        return Tables((name, getattr(self, name)) for name in MESH_TABLES)

    def polygons(self) -> dict[int, np.ndarray]:
        """Ordered polygon of every cell: ``{cell: (n, 2) array of (x, y)}``, counter-clockwise in (x, y).

        In a periodic box each polygon is unwrapped to be contiguous from its
        first vertex (coordinates may then leave ``[0, L)``).
        """
        return _polygons(self)

    def replace(self, **changes) -> "Frame":
        """A copy with some attributes replaced."""
        return replace(self, **changes)
