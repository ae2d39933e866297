"""T1 events from neighbour-graph changes, classified as cycles, intercalations or unresolved.

A **T1** is a neighbour exchange in a quartet of cells: cells ``a`` and
``b`` lose their shared junction and cells ``c`` and ``d`` gain one, where
``c`` and ``d`` were common neighbours of ``a`` and ``b`` before or ``a``
and ``b`` are common neighbours of ``c`` and ``d`` after (either: two T1s on
junctions that share a vertex, in one frame, each see their quartet on one
side only).  The intermediate four-fold vertex may persist: a-b is lost at
frame ``t1`` and c-d gained at ``t2 >= t1``, with neither contact present in
between.  Every loss and every gain is one T1 at most.

Classification per quartet, in time order:

- ``cycle``: the T1 is later undone by the inverse T1 on the same quartet
  (c-d lost, a-b regained); ``frame_end`` is the first frame a-b touch again
  and ``duration = frame_end - frame_start``.
- ``intercalation``: never undone before the end of the movie.
- ``unresolved``: not undone, but it started fewer than ``censor`` frames
  before the last frame, so the movie is too short to tell (right-censored).
  Leave these out of rate and lifetime statistics.  By default ``censor``
  comes from the movie's length (:func:`default_censor`).

Contacts that appear or disappear because a cell enters, leaves, divides or
dies (a cell absent in one of the two frames) are not T1s; contacts with
cell 0 (outside the tissue) are not cell contacts.  Cell ids are track ids.
Positions follow the package convention: ``x`` = column, ``y`` = row, px,
origin at the centre of pixel (0, 0).

The package, by concept (each module imports only those listed before it):
:mod:`.frames` (the contacts of each frame, in track ids), :mod:`.classify`
(the kinds and the censoring window), :mod:`.pairing` (losses and gains
paired into T1s), :mod:`.quartets` (each frame's contact graph and the raw
T1s), :mod:`.neighbours` (the per-cell definition), :mod:`.detect` (the
events table, and both tables from one pass) and :mod:`.summary` (per-cell
statistics and the stage's summary).
"""
from __future__ import annotations

from ..schema import deprecated_column_lists
from . import classify, frames, neighbours, pairing, quartets, summary
from .classify import CENSOR_DIVISOR, CENSOR_MAX, classify_t1, default_censor
from .detect import detect_t1, t1_tables
from .frames import track_contacts
from .neighbours import neighbour_events
from .quartets import find_t1
from .summary import cell_event_stats, events_summary, intercalation_intervals

__all__ = ["detect_t1", "neighbour_events", "t1_tables", "default_censor", "CENSOR_MAX", "CENSOR_DIVISOR", "classify_t1",
           "find_t1", "track_contacts", "cell_event_stats", "intercalation_intervals", "events_summary"]

# beyond __all__, the package's constants and the helpers the tests compare with their references keep their
# names here (assigned, not imported: the module map above says where each lives)
T1_KINDS, KERNELS, NO_INTERCALATION = classify.T1_KINDS, classify.KERNELS, summary.NO_INTERCALATION
CYCLE, INTERCALATION, UNRESOLVED = classify.CYCLE, classify.INTERCALATION, classify.UNRESOLVED
BLOCK_ROWS, MISSING_CELLS, SLOT_TABLE_ROWS = frames.BLOCK_ROWS, frames.MISSING_CELLS, quartets.SLOT_TABLE_ROWS
_held_pairs, _ids, _movie_frames = frames._held_pairs, frames._ids, frames._movie_frames
_Changes, _Lists, _same_cells_every_frame = neighbours._Changes, neighbours._Lists, neighbours._same_cells_every_frame
_pair_losses_and_gains = pairing._pair_losses_and_gains
_FrameGraph, _directed = quartets._FrameGraph, quartets._directed
_index_of, _t1_step = quartets._index_of, quartets._t1_step


# the column lists of hexatissue 0.1, now read from the one registry
__getattr__ = deprecated_column_lists(__name__, {
    "EVENT_EXTRA_COLUMNS": ("events", ("frame_gain", "frame_undo", "is_border")),
    "CELL_EVENT_COLUMNS": ("cell_events", None)})
