"""The file formats :func:`hexatissue.open_source` reads: one module per format.

Each module opens its format and returns an :class:`~hexatissue.readers.base.Opened`
record: a *reader* plus what the :class:`~hexatissue.Source` needs besides
the frames (description, calibration, periodic box, whether the ids are
consistent over time, the divisions recorded with the masks).  Only
:mod:`hexatissue.source` makes a ``Source`` from it; the readers never
import ``source`` (they sit below it).

The reader protocol (:class:`Reader`), the one thing a ``Source`` calls:

- ``n_frames`` (int >= 1) and ``shape`` (``(rows, cols)`` of every frame);
- ``describe() -> dict``: JSON-serialisable entries of ``Source.description``
  (``axes``, ``stored_shape``, ``dtype``, ``frame_axis``, ``notes`` and
  format-specific ones);
- ``read(t) -> numpy.ndarray``: frame ``t`` (``0 <= t < n_frames``) as
  stored, RGB collapsed to one integer per pixel, not validated; an
  unreadable frame is an :class:`~hexatissue.InputError`;
- optionally ``kind`` (``"labels"``, the default, or ``"polygons"``: then
  ``polygons(t)`` gives the :class:`~hexatissue.mesh.polygons.Polygons` of
  frame ``t`` and ``read`` refuses), ``independent`` (frames are unrelated
  images: nothing is tracked) and ``close()``.

Readers are picklable: file-backed ones reopen their file lazily.

Modules: :mod:`.base` (the record, axis rules, RGB collapse, the natural
sort key), :mod:`.calibration` (units from file metadata), :mod:`.arrays`
(arrays, lists of arrays, ``.npy``, Cellpose ``_seg.npy``, ``.npz``),
:mod:`.tiff`, :mod:`.png`, :mod:`.folder` (one image file per frame),
:mod:`.zarr` (zarr arrays and groups, OME-Zarr), :mod:`.mpf` (MPF runs and
their stores), :mod:`.ctc` (Cell Tracking Challenge folders),
:mod:`.polygons` (vertices tables, Tissue Analyzer ``TA.db``, hexanematic
``.mat``).
"""
from __future__ import annotations

from typing import Protocol, runtime_checkable

__all__ = ["Reader"]


@runtime_checkable
class Reader(Protocol):
    """The frames of one input, as :class:`~hexatissue.Source` reads them (see the module docstring)."""

    n_frames: int
    shape: tuple

    def describe(self) -> dict:
        """Entries of ``Source.description`` (axes, stored shape, dtype, frame axis, notes, ...)."""

    def read(self, t):
        """Frame ``t`` as stored (2-D array, RGB collapsed), not validated."""
