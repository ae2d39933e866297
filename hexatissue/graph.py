"""The neighbour graph of a frame (networkx), built from its edges table."""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from .errors import InputError, deprecated_alias
from .frame import Frame

if TYPE_CHECKING:  # networkx (~11 MB) is imported by neighbour_graph only: the analysis uses contact_table
    import networkx as nx

__all__ = ["neighbour_graph", "contact_table", "pair_groups"]


def neighbour_graph(frame: Frame, include_outside: bool = False) -> nx.Graph:
    """Cells as nodes, shared junctions as edges.

    Parameters
    ----------
    frame : Frame
        A junction network (e.g. from :func:`hexatissue.mesh_from_labels`).
    include_outside : bool
        Keep node 0 (the outside of the tissue) and its edges.

    Returns
    -------
    networkx.Graph
        Node ids are cell ids; node attributes are the columns of
        ``frame.cells`` (x, y in px with x = column, y = row, area in px^2,
        ...).  Edge attributes: ``length`` (total length of the junctions
        the two cells share, px) and ``n_junctions``.
    """
    if not isinstance(frame, Frame):
        raise InputError(f"frame must be a hexatissue.Frame; got {type(frame).__name__}")
    import networkx as nx

    graph = nx.Graph()
    cells = frame.cells
    graph.add_nodes_from((int(c), attrs) for c, attrs in zip(cells["cell"], cells.drop(columns="cell").to_dict("records")))
    pairs = contact_table(frame.edges, include_outside)
    if include_outside and (pairs["cell_a"] == 0).any():
        graph.add_node(0)
    graph.add_edges_from(
        (int(a), int(b), {"length": float(s), "n_junctions": int(n)})
        for a, b, s, n in pairs[["cell_a", "cell_b", "length", "n_junctions"]].itertuples(index=False, name=None)
    )
    return graph



neighbor_graph = deprecated_alias(neighbour_graph, "neighbor_graph")  # the spelling of hexatissue 0.1

def contact_table(edges: pd.DataFrame, include_outside: bool = False) -> pd.DataFrame:
    """Cell-cell contacts from an edges table (per frame when it has a ``frame`` column).

    Returns
    -------
    pandas.DataFrame
        [frame,] cell_a < cell_b, length (total length of their junctions,
        px), n_junctions.  Contacts with the outside (cell 0) only when
        ``include_outside``.
    """
    a, b = edges["cell_a"].to_numpy(np.int64), edges["cell_b"].to_numpy(np.int64)
    has_frame = "frame" in edges.columns
    frame = edges["frame"].to_numpy(np.int64) if has_frame else np.zeros(len(a), np.int64)
    length = edges["length"].to_numpy(float)
    if not include_outside:
        keep = a != 0
        frame, a, b, length = frame[keep], a[keep], b[keep], length[keep]
    order, starts = pair_groups(frame, a, b)
    first = order[starts]
    out = pd.DataFrame({"cell_a": a[first], "cell_b": b[first],
                        "length": np.add.reduceat(length[order], starts) if len(starts) else np.zeros(0),
                        "n_junctions": np.diff(np.r_[starts, len(a)]).astype(np.int64)})
    if has_frame:
        out.insert(0, "frame", frame[first])
    return out


def pair_groups(frame, a, b):
    """Rows grouped by equal ``(frame, a, b)``: a stable sorting order and where each group starts in it.

    Parameters
    ----------
    frame : numpy.ndarray or None
        Frame of each row; None for rows of one frame.
    a, b : numpy.ndarray
        Non-negative integer ids of each row.

    Returns
    -------
    order : numpy.ndarray
        Row indices sorted by (frame, a, b), rows of a group in their input order.
    starts : numpy.ndarray
        Position in ``order`` of the first row of each group.
    """
    n = int(max(a.max(), b.max())) + 1 if len(b) else 1
    n_frames = int(frame.max()) + 1 if frame is not None and len(frame) else 1
    # one sort of one int64 key per row (a groupby on three columns needs several times the memory)
    if n_frames * n * n < 2**62:
        key = a * n + b if frame is None else (frame * n + a) * n + b
        order = np.argsort(key, kind="stable")
        new = np.diff(key[order]) != 0
        del key
    else:  # ids too large for one key: a lexicographic sort
        order = np.lexsort((b, a) if frame is None else (b, a, frame))
        new = (np.diff(a[order]) != 0) | (np.diff(b[order]) != 0)
        if frame is not None:
            new |= np.diff(frame[order]) != 0
    starts = np.flatnonzero(np.r_[True, new]) if len(a) else np.zeros(0, np.int64)
    return order, starts
