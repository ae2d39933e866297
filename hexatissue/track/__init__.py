"""Link cells across the frames of a label movie by overlap.

Cells in consecutive frames are linked by their intersection over union
(IoU) with an optimal one-to-one assignment
(:func:`scipy.optimize.linear_sum_assignment`).  The overlaps come from a
sparse contingency table of the two label images (one ``bincount`` over the
pixels, no per-cell loops).  Divisions (one cell -> two) are detected before
the assignment; cells that are not linked start or end a track, classified as
border crossings or interior appearances/disappearances.

The tracker is incremental (:class:`Tracker`): it keeps one frame in memory,
so movies of any length are tracked frame by frame.

Conventions: label images are indexed ``[row, col]``, 0 = background or
membrane; track ids are positive integers.

The package, by concept (each module imports only those listed before it):
:mod:`.overlap` (compact frames and their overlaps), :mod:`.linking` (one
frame pair linked), :mod:`.tracker` (the overlap tracker), :mod:`.lineage`
(the lineage and its division and extrusion checks), :mod:`.movie` (trackers
by id and per frame, the movie tracker) and :mod:`.qc` (checks and summary).
"""
from __future__ import annotations

from ..options import FOLLOW_MODES, TRACK_MODES
from ..schema import deprecated_column_lists
from .lineage import (DIVISION_REASONS, EXTRUSION_SHRINK, check_divisions, check_extrusions, checked_tracks,
                      division_rows, join_spans, lineage_from_spans, lineage_roots, lineage_table, track_spans)
from .linking import match_frames
from .movie import ID_CONSISTENCY, IdTracker, MovieTracker, SeparateTracker, cells_with_tracks, track_labels
from .overlap import Overlaps, compact_frames, count_overlaps, frame_overlaps
from .qc import EXTRUSION_SHARE, FAR_APART, MIN_EXTRUSIONS, CellCounts, tracking_qc, tracking_summary, tracking_warning
from .tracker import CONFIDENT_IOU, CONFIDENT_SHARE, REFIT_PX, Tracker

__all__ = ["Tracker", "FOLLOW_MODES", "IdTracker", "SeparateTracker", "MovieTracker", "TRACK_MODES", "ID_CONSISTENCY",
           "track_labels", "compact_frames", "Overlaps", "count_overlaps", "frame_overlaps", "match_frames",
           "lineage_roots", "check_divisions", "check_extrusions", "EXTRUSION_SHRINK", "division_rows",
           "DIVISION_REASONS", "tracking_qc", "tracking_warning", "EXTRUSION_SHARE", "MIN_EXTRUSIONS", "FAR_APART",
           "CONFIDENT_IOU", "CONFIDENT_SHARE", "REFIT_PX", "cells_with_tracks", "lineage_table", "tracking_summary",
           "track_spans", "join_spans", "lineage_from_spans", "checked_tracks", "CellCounts"]


# the column lists of hexatissue 0.1, now read from the one registry
__getattr__ = deprecated_column_lists(__name__, {"LINEAGE_COLUMNS": ("lineage", None)})
