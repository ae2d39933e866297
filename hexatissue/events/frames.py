"""Cell-cell contacts of each frame, in track ids, streamed a block of frames at a time; the pairs held
at four-fold vertices.
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from ..errors import InputError, is_real
from ..geometry import in_sorted, lookup, row_keys
from ..graph import pair_groups
from ..schema import FrameRows


def track_contacts(edges: pd.DataFrame, cells: pd.DataFrame | None = None, min_length: float = 0.0) -> pd.DataFrame:
    """Cell-cell contacts per frame, in track ids.

    Parameters
    ----------
    edges : pandas.DataFrame
        ``frame``, ``cell_a``, ``cell_b``, ``length`` (px); several junctions
        between the same two cells are summed.
    cells : pandas.DataFrame, optional
        ``frame``, ``cell`` and ``track``: label ids are translated to track ids.
        Without it (or without ``track``) label ids are track ids.
    min_length : float
        A contact whose total junction length is below ``min_length`` px is
        treated as a four-fold vertex, i.e. not a contact.  0 keeps every junction.

    Returns
    -------
    pandas.DataFrame
        ``frame``, ``a`` < ``b`` (track ids, both > 0), ``length`` (px), sorted.
    """
    if cells is None or "track" not in cells.columns:  # label ids are track ids: every frame of the edges
        frames = edges["frame"].to_numpy(np.int64) if "frame" in edges.columns else np.zeros(0, np.int64)
        cells = pd.DataFrame({"frame": np.unique(frames), "cell": np.int64(0)})
    parts = [(np.full(len(a), frame, np.int64), a, b, length)
             for frame, _, a, b, length in _movie_frames(edges, cells, min_length)]
    frame, a, b, length = (np.concatenate(c) for c in zip(*parts)) if parts else (np.zeros(0, np.int64),) * 4
    return pd.DataFrame({"frame": frame, "a": a, "b": b, "length": length.astype(float)})


#: Cell rows handled at once by the movie-level stages (whole frames): about 0.8 kB of temporaries per row.
BLOCK_ROWS = 1 << 14


class CellFrames:
    """A movie's cells table, read a block of whole frames at a time.

    ``cells``: a DataFrame, or a table kept on disk (anything with
    ``frame_chunks`` and ``read(columns, frames)``:
    :class:`hexatissue.stored.StoredTable`), read part by part, so that the
    T1 search never holds the movie's cells at once.  Blocks come in frame
    order, and a frame's rows in row order (a frame column out of order is
    put in order by one stable sort, of a DataFrame's column or of a part's).
    """

    def __init__(self, cells):
        self.cells = cells
        self.columns = list(cells.columns)
        self.on_disk = not isinstance(cells, pd.DataFrame)
        self._rows = None if self.on_disk else FrameRows(cells["frame"].to_numpy(np.int64))

    def __len__(self):
        return len(self.cells)

    def blocks(self, columns, rows=BLOCK_ROWS):
        """``(frames, block)``: ``frames`` the frames of the block (sorted), ``block`` ``{column: array}`` of the
        ``columns`` that the table has, over the block's rows; about ``rows`` rows a block, a frame at least."""
        columns = [c for c in dict.fromkeys(columns) if c in self.columns]
        if not self.on_disk:
            arrays = {c: self.cells[c].to_numpy() for c in columns}
            for frames, at in self._rows.blocks(rows):
                yield frames, {c: a[at] for c, a in arrays.items()}
            return
        for first, last in self.cells.frame_chunks:
            part = self.cells.read(list(dict.fromkeys(["frame", *columns])), frames=(first, last))
            by_frame = FrameRows(part["frame"].to_numpy(np.int64))
            arrays = {c: part[c].to_numpy() for c in columns}
            del part
            for frames, at in by_frame.blocks(rows):
                yield frames, {c: a[at] for c, a in arrays.items()}

    def last_frame(self) -> int:
        """The last frame with a cell (0 for no cells)."""
        if not self.on_disk:
            return int(self._rows.frames[-1]) if len(self._rows.frames) else 0
        for first, last in reversed(self.cells.frame_chunks):
            frame = self.cells.read(["frame"], frames=(first, last))["frame"].to_numpy(np.int64)
            if len(frame):
                return int(frame.max())
        return 0

    def values_at(self, frame, track, columns):
        """The ``columns`` (of float or bool) of the cell of each (``frame``, ``track``): ``(found, {column:
        array})``, NaN (False) where the cell is not in that frame, the first row if several."""
        found = np.zeros(len(frame), bool)
        out = {c: np.full(len(frame), np.nan) for c in columns if c != "is_border"}
        out.update({c: np.zeros(len(frame), bool) for c in columns if c == "is_border"})
        if not len(frame):
            return found, out
        order = np.argsort(frame, kind="stable")
        wanted = frame[order]
        for frames, block in self.blocks(["frame", "cell", "track", *columns]):
            lo, hi = np.searchsorted(wanted, [frames[0], frames[-1] + 1])
            if lo == hi:
                continue
            sel = order[lo:hi]
            pos = lookup(row_keys(block["frame"].astype(np.int64), block_tracks(block)), None,
                         row_keys(frame[sel], track[sel]))
            hit = pos >= 0
            found[sel] = hit
            for c, values in out.items():
                if c in block:
                    values[sel[hit]] = block[c][pos[hit]]
        return found, out


def cell_frames(cells) -> CellFrames:
    """``cells`` as a :class:`CellFrames` (itself when it is one)."""
    return cells if isinstance(cells, CellFrames) else CellFrames(cells)


def block_tracks(block) -> np.ndarray:
    """Track id of every row of a block of :meth:`CellFrames.blocks`: ``track``, else the label ``cell``."""
    return (block["track"] if "track" in block else block["cell"]).astype(np.int64, copy=False)


def _movie_frames(edges, cells, min_length):
    """Each frame of ``cells`` in turn: ``(frame, tracks, a, b, length)``.

    ``tracks``: the track ids present (sorted, unique); ``a`` < ``b``: its contacts
    in track ids, sorted, with their summed junction ``length`` (px).  The
    contacts exist one block of about ``BLOCK_ROWS`` cell rows at a time: the
    movie-level stages stream the movie instead of holding every contact of
    it (three per cell-frame).
    """
    for col in ("frame", "cell_a", "cell_b", "length"):
        if col not in edges.columns:
            raise InputError(f"edges table is missing column {col!r}; expected frame, cell_a, cell_b, length")
    if not is_real(min_length) or min_length < 0:
        raise InputError(f"min_length must be a finite length >= 0 px; got {min_length!r}")
    return _frames(edges, cell_frames(cells), min_length)


#: Edges whose cells the cells table does not have.
MISSING_CELLS = "edges refer to (frame, cell) pairs missing from the cells table"


def edge_blocks(edges, columns):
    """``read(first, last)``: the ``columns`` of the rows of ``edges`` in frames ``first`` to ``last``, as numpy
    arrays, for ranges that move forward through the movie.

    A DataFrame is sliced; a table kept on disk (anything with a ``frames_reader``,
    :class:`hexatissue.stored.StoredTable`) is read one part at a time, so the movie's edges are never in memory
    at once.
    """
    if hasattr(edges, "frames_reader"):
        read = edges.frames_reader(columns)
        return lambda first, last: [column.to_numpy() for _, column in read(first, last).items()]
    rows = FrameRows(edges["frame"].to_numpy(np.int64))
    arrays = [edges[c].to_numpy() for c in columns]
    return lambda first, last: [a[rows.between(first, last)] for a in arrays]


def _frames(edges, cells, min_length):
    """The generator of :func:`_movie_frames` (its arguments checked): contacts found a block of frames at a time.

    Each block reads the edges of its frames and of any frame since the last
    block's: an edge of a frame without cells is refused (:data:`MISSING_CELLS`)
    wherever it lies.
    """
    translate = "track" in cells.columns
    read = edge_blocks(edges, ["frame", "cell_a", "cell_b", "length"])
    after = None  # the last frame read
    for frames, block in cells.blocks(["frame", "cell", "track"]):
        here, tracks = block["frame"].astype(np.int64, copy=False), block_tracks(block)
        frame, a, b, length = read(frames[0] if after is None else after + 1, frames[-1])
        after = int(frames[-1])
        frame, a, b = (c.astype(np.int64, copy=False) for c in (frame, a, b))  # no copy of int64 columns
        if translate and not in_sorted(_unique(frame), frames).all():
            raise InputError(MISSING_CELLS)
        length = length.astype(float, copy=False)
        keep = a != 0  # contacts with the outside are not cell contacts
        frame, a, b, length = frame[keep], a[keep], b[keep], length[keep]
        order, starts = pair_groups(frame, a, b)
        first = order[starts]
        frame, a, b = frame[first], a[first], b[first]
        length = np.add.reduceat(length[order], starts) if len(starts) else np.zeros(0)
        if min_length > 0:
            keep = length >= min_length
            frame, a, b, length = frame[keep], a[keep], b[keep], length[keep]
        if translate:  # label ids -> track ids
            keys = row_keys(here, block["cell"].astype(np.int64, copy=False))
            a = lookup(keys, tracks, row_keys(frame, a), MISSING_CELLS)
            b = lookup(keys, tracks, row_keys(frame, b), MISSING_CELLS)
            a, b = np.minimum(a, b), np.maximum(a, b)
            if not _increasing(frame, a, b):  # track ids need not keep the label order (they do when ids are kept)
                order = np.lexsort((b, a, frame))
                frame, a, b, length = frame[order], a[order], b[order], length[order]
        present = _unique(row_keys(here, tracks))
        p_bounds = np.searchsorted(present, row_keys(frames, 0))
        c_bounds = np.searchsorted(frame, frames)
        ids = present - row_keys(np.repeat(frames, np.diff(np.append(p_bounds, len(present)))), 0)
        for k, f in enumerate(frames.tolist()):
            lo, hi = c_bounds[k], c_bounds[k + 1] if k + 1 < len(frames) else len(frame)
            p_hi = p_bounds[k + 1] if k + 1 < len(frames) else len(present)
            yield f, ids[p_bounds[k]:p_hi], a[lo:hi], b[lo:hi], length[lo:hi]
    if translate and len(read(-1 if after is None else after + 1, np.iinfo(np.int64).max)[0]):
        raise InputError(MISSING_CELLS)  # edges of frames after the last frame with cells


def _held_frames(edges, cells):
    """Per frame, the pairs of cells around each vertex of four or more cells, and those vertices' cells.

    ``(frame, (a, b, vertex, cell))`` of each frame that has such a vertex, in frame order, made a block
    of frames at a time as they are asked for (:func:`_held_pairs`: all of them in a dict): the pairs
    ``a`` < ``b`` and, per vertex of four or more cells (numbered ``vertex``), its cells (all track ids).

    A four-fold vertex holds a contact (a junction shorter than
    ``merge_distance``, contracted) between one of its two diagonal pairs:
    the contacts table has neither, and a T1 whose flanking contact is held
    so has no quartet of contacts on either side.  These pairs complete the
    flanks the quartet search looks at (:func:`_find_t1`).  Empty when the
    edges have no ``vertex_a``, ``vertex_b``.
    """
    if not {"vertex_a", "vertex_b"} <= set(edges.columns) or len(edges) == 0:
        return
    cells = cell_frames(cells)
    read = edge_blocks(edges, ["frame", "vertex_a", "vertex_b", "cell_a", "cell_b"])
    translate = "track" in cells.columns
    after = None
    for frames, block in cells.blocks(["frame", "cell", "track"]):  # a block of frames at a time: the movie's
        edge_block = read(frames[0] if after is None else after + 1, frames[-1])  # edges four times over would
        after = int(frames[-1])  # not stream
        tracks = None
        if translate:
            tracks = (row_keys(block["frame"].astype(np.int64, copy=False), block["cell"].astype(np.int64, copy=False)),
                      block_tracks(block))
        yield from _held_block(*(c.astype(np.int64, copy=False) for c in edge_block), tracks).items()


def _held_pairs(edges, cells):
    """``{frame: (a, b, vertex, cell)}``: :func:`_held_frames` of every frame at once."""
    return dict(_held_frames(edges, cells))


def _held_block(frame, vertex_a, vertex_b, cell_a, cell_b, tracks):
    """:func:`_held_pairs` of the edges of a few whole frames; ``tracks``: (row keys, track ids) of the cells."""
    frame = np.tile(frame, 4)
    vertex = np.concatenate([vertex_a, vertex_a, vertex_b, vertex_b])  # each end with each side's cell
    cell = np.tile(np.concatenate([cell_a, cell_b]), 2)
    keep = cell > 0
    frame, vertex, cell = frame[keep], vertex[keep], cell[keep]
    order, starts = pair_groups(frame, vertex, cell)
    first = order[starts]  # each (frame, vertex, cell) once, sorted by frame, vertex, cell
    frame, vertex, cell = frame[first], vertex[first], cell[first]
    group = np.r_[True, (frame[1:] != frame[:-1]) | (vertex[1:] != vertex[:-1])].cumsum() - 1
    big = np.bincount(group)[group] >= 4
    frame, group, cell = frame[big], group[big], cell[big]
    if not len(cell):
        return {}
    if tracks is not None:
        cell = lookup(tracks[0], tracks[1], row_keys(frame, cell), MISSING_CELLS)
    later = np.searchsorted(group, group, "right") - np.arange(len(group)) - 1  # each cell with the later ones
    i = np.repeat(np.arange(len(group)), later)
    j = np.arange(later.sum()) - np.repeat(np.cumsum(later) - later, later) + i + 1
    a, b = np.minimum(cell[i], cell[j]), np.maximum(cell[i], cell[j])
    pair_bounds = {int(v): (lo, hi) for v, lo, hi in zip(*_frame_bounds(frame[i]))}
    out = {}
    for value, lo, hi in zip(*_frame_bounds(frame)):
        p0, p1 = pair_bounds[int(value)]
        out[int(value)] = (a[p0:p1], b[p0:p1], group[lo:hi], cell[lo:hi])
    return out


def _frame_bounds(frame):
    """The distinct values of the sorted ``frame`` and where each run starts and ends."""
    starts = np.flatnonzero(np.r_[True, frame[1:] != frame[:-1]])
    return frame[starts], starts, np.r_[starts[1:], len(frame)]


def _unique(values):
    """``np.unique(values)``, without its sort (a hash unique) when ``values`` are strictly increasing already."""
    return values if len(values) < 2 or bool(np.all(values[1:] > values[:-1])) else np.unique(values)


def _increasing(frame, a, b):
    """Whether the rows ``(frame, a, b)`` are in strictly increasing lexicographic order (a lexsort keeps them)."""
    df, da, db = np.diff(frame), np.diff(a), np.diff(b)
    return bool(np.all((df > 0) | ((df == 0) & ((da > 0) | ((da == 0) & (db > 0))))))


def _ids(edges, cells):
    """Every track id a movie's contacts can name, sorted: those of ``cells`` (label ids of the edges too
    when ``cells`` has no ``track``)."""
    cells = cell_frames(cells)
    # each block's distinct ids, then one unique of them all: a union per block would sort the ids so far again at
    # every block (quadratic where every cell is its own track)
    ids = [np.unique(block_tracks(block)) for _, block in cells.blocks(["frame", "cell", "track"])]
    if "track" not in cells.columns:
        ids += [edges["cell_a"].to_numpy(np.int64), edges["cell_b"].to_numpy(np.int64)]
    return np.unique(np.concatenate(ids)) if ids else np.zeros(0, np.int64)


def _check_cells(cells):
    for col in ("frame", "cell", "x", "y"):
        if col not in cells.columns:
            raise InputError(f"cells table is missing column {col!r}; expected frame, cell, x, y")
