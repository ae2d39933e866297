"""T1 events of a movie of labelled surface meshes (:func:`mesh_events`): the contacts of every frame's cells
along the mesh, through the quartet search and classification of flat movies (:mod:`hexatissue.events`).
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from ..errors import InputError
from ..events import classify_t1, default_censor, find_t1
from ..geometry import lookup, row_keys
from ..schema import require_columns, validate

__all__ = ["mesh_events"]


def mesh_events(cells, junctions, censor=None) -> pd.DataFrame:
    """The T1 events of labelled meshes whose cell labels follow the cells from frame to frame.

    Two cells are in contact in a frame when a junction of
    :func:`~hexatissue.surface.mesh_tissue` separates them; a contact lost
    and another gained between the four cells around it are one T1, paired
    and classified as in a flat movie (:func:`hexatissue.detect_t1`:
    ``cycle`` when the inverse T1 restores the contact, ``intercalation``,
    or ``unresolved`` within ``censor`` frames of the last).  A label is a
    track: MorphoGraphX's parent labels, or meshes segmented with tracked
    labels; labels renumbered in every frame give meaningless events.

    Parameters
    ----------
    cells, junctions : pandas.DataFrame
        The ``mesh_cells`` and ``mesh_junctions`` tables of every frame
        (:func:`~hexatissue.surface.mesh_tables`).
    censor : int, optional
        Right-censoring window, frames (default
        :func:`hexatissue.events.default_censor` of the frames).

    Returns
    -------
    pandas.DataFrame
        ``hexatissue.schema.SURFACE_MESH_TABLES["mesh_events"]``: ``event``,
        ``kind``, ``frame_start``, ``frame_end``, ``duration`` (frames),
        ``cell_a``, ``cell_b`` (lose the contact), ``cell_c``, ``cell_d``
        (gain it; labels), ``x``, ``y``, ``z`` (mean of the four cells'
        centroids at ``frame_start``, px), ``frame_gain``, ``frame_undo``
        (frames), ``is_border``.
    """
    require_columns(cells, ("frame", "cell", "x", "y", "z", "is_border"), "mesh_cells")
    require_columns(junctions, ("frame", "cell_a", "cell_b"), "mesh_junctions")
    n_frames = int(cells["frame"].max()) + 1 if len(cells) else 0
    if censor is None:
        censor = default_censor(n_frames)
    elif isinstance(censor, bool) or int(censor) != censor or censor < 1:
        raise InputError(f"censor must be a whole number of frames >= 1; got {censor!r}")
    a, b = junctions["cell_a"].to_numpy(np.int64), junctions["cell_b"].to_numpy(np.int64)
    inside = (a > 0) & (b > 0)  # the background and the mesh's edge are no cell
    # two cells may share several junctions (a cell wrapping round another): one contact
    contacts = pd.DataFrame({"frame": junctions["frame"].to_numpy(np.int64)[inside],
                             "a": np.minimum(a, b)[inside], "b": np.maximum(a, b)[inside]}).drop_duplicates()
    presence = pd.DataFrame({"frame": cells["frame"].to_numpy(np.int64), "track": cells["cell"].to_numpy(np.int64)})
    events = classify_t1(find_t1(contacts.sort_values(["frame", "a", "b"], ignore_index=True), presence),
                         max(n_frames - 1, 0), int(censor))
    quartet = np.stack([events[c].to_numpy(np.int64) for c in ("cell_a", "cell_b", "cell_c", "cell_d")], axis=1)
    # each quartet cell's row at frame_start (a and b are there: a contact is lost between present cells)
    at = lookup(row_keys(cells["frame"], cells["cell"]), None,
                row_keys(events["frame_start"].to_numpy(np.int64)[:, None], quartet).ravel()).reshape(quartet.shape)
    found = at >= 0
    xyz = np.where(found[..., None], cells[["x", "y", "z"]].to_numpy(float)[at], np.nan)
    centre = np.nanmean(xyz, axis=1) if len(events) else np.zeros((0, 3))
    border = (found & cells["is_border"].to_numpy(bool)[at]).any(axis=1)
    events.insert(8, "x", centre[:, 0])
    events.insert(9, "y", centre[:, 1])
    events.insert(10, "z", centre[:, 2])
    events["is_border"] = border
    events.insert(0, "event", np.arange(len(events), dtype=np.int64))
    return validate(events, "mesh_events")
