"""Junction network (vertices, junctions, ordered polygons) of a label image."""
from __future__ import annotations

import warnings

import numpy as np
import pandas as pd

from .._dispatch import Kernels, compiled_or_cached
from ..box import as_box
from ..errors import HexatissueWarning, InputError, is_real
from ..frame import Frame
from ..schema import validate
from . import _kernels
from ..options import POCKET_AREA
from .labels import check_mask, checked_labels, compact_labels, normalize_valid
from .segment import segment_membrane_map

K = Kernels(_kernels, "hexatissue.mesh._reference")

__all__ = ["mesh_from_labels", "network_tables", "kernels_cached"]

ARM_REACH = 8  # cracks per arm (at most; half the junction) in the local line fit of sub-pixel vertex positions
MAX_SHIFT = 1.5  # px: a fitted vertex further than this from its pixel corner is not trusted
MAX_MERGE_ROUNDS = 5  # contraction rounds; a second one is rare, a third practically never needed
#: Labels with ids up to one per this many pixels are used as they are, not compacted: the tables
#: over ids (~130 B per id) then stay below 2 B/px, and the pass that finds which ids occur is saved.
PIXELS_PER_ID = 64
#: An image in which most ids come in pieces (several boundary cycles each, on average at least this many) is
#: not a label image of cells: a pixel classifier's class map, a binary membrane map or a colour-mapped rendering
#: whose colours repeat.  Real segmentations have 1.000-1.016 cycles per cell (10 datasets, docs/input.md).
PIECES_PER_ID = 3
#: With this many ids or more, 2 cycles per id on average suffice: 57 cells drawn with 20 colours have 2.6-2.9
#: (benchmarks/input_corpus.py), while a few bands around a torus have 2 cycles each and are cells.
MANY_IDS = 10


def _cat(*arrays):
    """``np.concatenate(arrays)``: what ``np.r_`` does here, at a fifth of its call cost (counts on small frames)."""
    return np.concatenate(arrays)


def _membrane_flags(membrane, periodic):
    """The membrane flags as the arm fits read them: padded by one pixel like the corner lattice's labels.

    Of size 0 for touching labels (no membrane): every fit point is then a
    crack midpoint and the kernel reads no flags.
    """
    if not membrane.any():
        return np.zeros((0, 0), bool)
    return np.pad(membrane, 1, mode="wrap" if periodic else "constant")


def _trace(lab32, periodic, membrane):
    """Vertices (corner rows/cols) and junctions of a compact label image, incl. vertex-less loops.

    ``membrane`` marks the pixels that were 0-valued junction lines in the input.
    """
    h, w = lab32.shape
    # on an open image the image corners are vertices, so border polygons follow the image edge
    corners, vi, vj, n_cracks = K.corner_types(lab32, periodic)
    n_max = 4 * len(vi) + 1
    start, end, sarm, earm, left, right, dx, dy, ncrack, count, mean, direction = K.trace_junctions(
        lab32, periodic, corners, vi, vj, n_max, _membrane_flags(membrane, periodic), ARM_REACH
    )
    if not periodic:  # vertices on the image edge: the edge bends their arms; keep them at the pixel corner
        on_edge = (vi == 0) | (vj == 0) | (vi == h) | (vj == w)
        count[on_edge] = 0
    if ncrack.sum() < n_cracks:  # boundaries with no vertex on them are left
        visited = K.mark_junctions(periodic, corners, vi, vj, start, sarm)
        lr, lc, ll, lrt, ldx, ldy, _ = K.trace_loops(lab32, periodic, corners, visited)
    else:
        lr = lc = ll = lrt = ldx = ldy = np.zeros(0, np.int64)
    n_loops = len(lr)
    loop_v = len(vi) + np.arange(n_loops)
    no_arm = -np.ones(n_loops, np.int64)  # loop points are not vertices: no arm lines
    junctions = dict(
        start=_cat(start, loop_v),
        end=_cat(end, loop_v),
        start_arm=_cat(sarm, no_arm),
        end_arm=_cat(earm, no_arm),
        left=_cat(left.astype(np.int64), ll),
        right=_cat(right.astype(np.int64), lrt),
        vec=np.column_stack((_cat(dx, ldx), _cat(dy, ldy))).astype(float),
    )
    pos = np.column_stack((_cat(vj, lc) - 0.5, _cat(vi, lr) - 0.5))
    lines = dict(count=count, mean=mean, direction=direction)
    return pos, junctions, lines


def _merge_short(pos, j, lines, merge_distance, box):
    """Contract junctions shorter than ``merge_distance``; returns merged positions, kept junctions and the
    cell-cell junctions contracted into each vertex (``vertices.n_merged``).

    Lengths are measured between sub-pixel vertex positions, which depend on
    what was merged, so contraction is repeated until no kept junction is
    shorter than ``merge_distance`` (:func:`._kernels.merge_clusters`).
    """
    lengths = box.lengths if box is not None else np.zeros(2)
    centre, keep, a, b, vec = K.merge_clusters(pos, j["start"], j["end"], j["start_arm"], j["end_arm"], j["vec"],
                                               lines["count"], lines["mean"], lines["direction"], lengths,
                                               float(merge_distance), MAX_MERGE_ROUNDS, MAX_SHIFT)
    # each cell-cell junction contracted into a vertex is a contact held as a four-fold vertex: counted on its
    # vertex (clusters are the components of the contracted junctions, numbered as the kernel numbers them)
    contracted = ~keep & (j["left"] > 0) & (j["right"] > 0)
    cluster = K.components(len(pos), j["start"][~keep], j["end"][~keep])[0]
    held = np.bincount(cluster[j["start"][contracted]], minlength=len(centre))
    # a junction whose ends merged into one vertex encloses a cell smaller than merge_distance, unless it goes
    # around a periodic box: its vector is then a box period, not ~0 (the rule of _kernels.unwrap_short), and it
    # stays, a loop edge of the torus's network
    collapsed = (a == b) & (j["start"] != j["end"])[keep]
    if box is not None:
        collapsed &= np.hypot(vec[:, 0], vec[:, 1]) <= 0.5 * lengths.min()
    if collapsed.any():
        # constant text: Python then shows it once per place, not once per frame of a movie
        warnings.warn(
            "junctions closing on a single merged vertex (cells smaller than merge_distance) were dropped",
            HexatissueWarning,
            stacklevel=3,
        )
    sel = ~collapsed
    kept = dict(a=a[sel], b=b[sel], left=j["left"][keep][sel], right=j["right"][keep][sel], vec=vec[sel])
    # drop vertices left without a junction and renumber 0..V-1
    used = np.zeros(len(centre), bool)
    used[kept["a"]] = used[kept["b"]] = True
    new = np.cumsum(used) - 1
    kept["a"], kept["b"] = new[kept["a"]], new[kept["b"]]
    centre, held = centre[used], held[used]
    if box is not None:
        centre = box.wrap(centre)
    return centre, kept, held


def mesh_from_labels(
    labels,
    box=None,
    *,
    kind="auto",
    merge_distance=2.0,
    membrane_width=3,
    min_area=None,
    background=(),
    fill_holes=POCKET_AREA,
    outside="auto",
    mask=None,
    frame=0,
) -> Frame:
    """Junction network of a 2-D label image: vertices, junctions, ordered polygons, cell table.

    Boundaries between labels are traced along pixel edges; pixel corners
    where three or more boundaries meet are vertices, and the boundary
    between two vertices is a junction.  Vertices closer than
    ``merge_distance`` along a junction are merged into one, so a four-fold
    vertex (a T1 intermediate), which rasterisation splits into two
    three-fold corners a pixel apart, has degree 4.  This is geometry only:
    the shape functions gamma_p are the order stage's
    (:func:`hexatissue.shape_order`).

    Parameters
    ----------
    labels : (rows, cols) integer array
        Label image indexed ``[row, col]``; 0 = background or membrane.
        Float arrays with integer values are accepted.
    box : Box, optional
        Periodic box covering the image exactly (``Box(cols, rows)``); None
        for an open image.  Junctions and polygons then wrap across the edges.
    kind : {"auto", "touching", "membrane", "skeleton"}
        Convention of ``labels`` (see :mod:`hexatissue.mesh.labels`).
    merge_distance : float
        Junctions shorter than this (px, straight line between their ends)
        are contracted into a single vertex.
    membrane_width : int
        Zero pixels within this many px of a cell are membrane and are shared
        out between the cells (kinds ``membrane`` and ``skeleton``).
    min_area : int, optional
        Regions with fewer pixels are treated as membrane.  Default: 4 px for
        skeletons (specks enclosed by junction lines), else 0.
    background : sequence of int
        Label ids that are outside (e.g. a rim label of hand-labelled data):
        set to 0 before anything else (for skeletons: ids of the enclosed
        regions, which are the output's cell ids).  Cells touching them are
        border cells.
    fill_holes : int
        0-valued pockets smaller than this many px (4-connected, not touching
        the edge of an open image) are holes between touching cells and are
        filled from their neighbours; 0 disables.  The default, 16 px, closes
        the gaps at triple junctions of segmented phase fields.
    outside : {"auto", "none"}
        ``"auto"``: for a skeleton on an open image, an enclosed region that
        touches the image edge and is more than 20 x the median region area
        is the outside of a masked skeleton (0), not a cell.  ``"none"``
        keeps every enclosed region as a cell.
    mask : (rows, cols) bool or integer array, optional
        Region of interest (nonzero = inside): pixels outside it are 0 in the
        normalised labels, so cells outside it vanish and cells cut by its
        edge are border cells.
    frame : int
        Time point, stored in every table's ``frame`` column.

    Returns
    -------
    Frame
        Tables (x = column, y = row, px, origin at the centre of pixel (0, 0)),
        each with a leading ``frame`` column:

        ``cells``: cell (label id), x, y (pixel centroid, px), area (pixel
        count incl. the cell's share of membranes, px^2), polygon_area (area
        of the vertex polygon, px^2), perimeter (of the vertex polygon, px),
        n_sides (polygon vertices; 0 when the cell has no vertex polygon:
        its boundary has fewer than 3 vertices, e.g. a cell enclosed by one
        other cell or by background (no vertex) or a lens between two cells
        (2 vertices), so the straight-line polygon encloses no area; then
        polygon_area and perimeter are NaN, and they are finite for every
        cell with n_sides >= 3),
        n_boundaries (boundary cycles; > 1 for cells with holes or in pieces),
        is_border (has a junction with cell 0: the image edge of an open
        image, background 0, a ``background`` label, the outside of a
        skeleton or the pixels outside ``mask``).

        ``vertices``: vertex, x, y (px), degree (number of junction ends; 2
        at the corners of an open image and for the single point placed on
        a boundary with no vertex that winds around a periodic box),
        is_border (touches cell 0).  A closed boundary with no vertex that
        does not wind around the box (a cell enclosed by one other cell or
        by background) is not a junction: it has no point and no edge.

        ``edges``: edge, vertex_a, vertex_b, cell_a < cell_b (0 = outside),
        length (straight distance between the vertices, px).

        ``cell_vertices``: cell, rank, vertex; each polygon counter-clockwise
        in (x, y) (positive shoelace area), which looks clockwise on screen
        where y points down.

    Raises
    ------
    InputError
        For labels that are not a 2-D non-negative integer image with at least
        one cell, a box that does not match the image, or a mask that is
        not an image of the labels' shape.

    Warns
    -----
    HexatissueWarning
        When cells come in several pieces or have holes (their largest
        boundary cycle is used), when cells smaller than
        ``merge_distance`` collapse to a point, and when cells are left
        without a boundary polygon (``n_sides`` 0).
    """
    if kind == "membrane-map":
        labels = segment_membrane_map(labels, periodic=box is not None)
    lab, lowest, top = checked_labels(labels, kind=kind)
    box = as_box(box, lab.shape)
    if not (is_real(merge_distance) and merge_distance >= 0):
        raise InputError(f"merge_distance must be a non-negative length in px; got {merge_distance!r}")
    normalized, membrane = normalize_valid(lab, kind, box is not None, membrane_width, min_area,
                                           background=background, fill_holes=fill_holes, outside=outside,
                                           mask=check_mask(mask, lab.shape), lowest=lowest)
    # the largest id is known while the labels are the ones checked
    tables = network_tables(normalized, membrane, box, merge_distance, frame, top if normalized is lab else None)
    return Frame.from_mesh(tables, frame=int(frame), box=box, shape=tuple(lab.shape))


def network_tables(lab, membrane, box, merge_distance, frame=0, top=None) -> dict:
    """The four network tables of touching labels (output of :func:`hexatissue.mesh.normalize_labels`).

    The checked core of :func:`mesh_from_labels`, for callers that have
    validated and normalised the labels already (the analysis pipeline).
    ``top``: ``lab.max()`` if the caller knows it already.
    """
    columns, _ = network_columns(lab, membrane, box, merge_distance, frame, top)
    return as_tables(columns)


def network_columns(lab, membrane, box, merge_distance, frame=0, top=None):
    """:func:`network_tables` as numpy columns, and the cells' polygons as the order stage reads them.

    Returns
    -------
    columns : dict
        Table name -> {column name: array}, the columns of
        :func:`network_tables` in their order (``frame`` first).
    polygons : (xy, starts)
        The polygons of the cells with ``n_sides > 0``, in the order of
        the cells rows, back to back (:mod:`hexatissue.geometry`): the
        same numbers :func:`hexatissue.geometry.table_polygons` reads back
        from the tables (vertex position plus its periodic image).
    """
    periodic = box is not None
    lab32, ids = _label_ids(lab, top)
    n_labels = len(ids)
    pos, junctions, lines = _trace(lab32, periodic, membrane)
    centre, kept, held = _merge_short(pos, junctions, lines, merge_distance, box)
    poly_start, poly_len, poly_area, poly_perimeter, verts, xy, n_cycles = K.polygons(
        centre, kept["a"], kept["b"], kept["left"], kept["right"], kept["vec"], n_labels)
    cells = _cell_columns(lab32, ids, periodic, box, junctions, poly_len, poly_area, poly_perimeter, n_cycles)
    centre, kept, verts, held = _drop_closed_loops(centre, kept, verts, held)
    vertices, edges, cell_vertices, polygons = _network_columns(centre, kept, ids, cells, poly_start, poly_len,
                                                                verts, xy, box)
    vertices["n_merged"] = held.astype(np.int64)
    columns = {"cells": cells, "vertices": vertices, "edges": edges, "cell_vertices": cell_vertices}
    for name, table in columns.items():
        n = len(next(iter(table.values())))
        columns[name] = {"frame": np.full(n, frame, dtype=np.int64), **table}
    return columns, polygons


def _label_ids(lab, top=None):
    """Labels as int32 and the id of each of their values (``ids[0] == 0``), as :func:`.labels.compact_labels`.

    Few ids (up to one per ``PIXELS_PER_ID`` px) are kept as they are, ids
    that do not occur included: the cells table takes the ids with pixels
    (:func:`_cell_columns`), and no pass over the image looks for them.
    ``top``: ``lab.max()`` if the caller knows it already.
    """
    top = int(lab.max()) if top is None else top
    if top + 1 <= lab.size // PIXELS_PER_ID:
        return lab.astype(np.int32, copy=False), np.arange(top + 1)
    return compact_labels(lab, top)


def as_tables(columns) -> dict:
    """Validated DataFrames of :func:`network_columns`' ``columns``, each built at once."""
    return {name: validate(pd.DataFrame(table, copy=False), name) for name, table in columns.items()}


def _drop_closed_loops(centre, kept, verts, held):
    """Network without the contractible boundaries that have no vertex on them, and without their points.

    Such a boundary (a cell enclosed by one other cell or by background) is
    traced as a junction from a degree-2 point back to itself, of length 0:
    it has no end points, so it is not a junction.  It still counts in the
    cells' ``n_boundaries`` and ``is_border``.  A loop around a periodic box
    (a band of cells) has a nonzero length and stays.
    """
    loop = (kept["a"] == kept["b"]) & (kept["vec"] == 0).all(axis=1)
    if not loop.any():
        return centre, kept, verts, held
    kept = {k: v[~loop] for k, v in kept.items()}
    used = np.zeros(len(centre), bool)
    used[kept["a"]] = used[kept["b"]] = True
    new = np.cumsum(used) - 1
    kept["a"], kept["b"] = new[kept["a"]], new[kept["b"]]
    # polygons never hold a loop point (a one-point cycle encloses no area), so every polygon vertex is kept
    return centre[used], kept, new[verts], held[used]


def _cell_columns(lab32, ids, periodic, box, junctions, poly_len, poly_area, poly_perimeter, n_cycles):
    count, sx, sy = K.cell_moments(lab32, len(ids), periodic)
    present = np.flatnonzero(count > 0)
    present = present[present != 0]
    centroid = np.column_stack((sx[present], sy[present])) / count[present, None]
    if box is not None:
        centroid = box.wrap(centroid)
    border = np.zeros(len(ids), bool)
    touches_zero = (junctions["left"] == 0) | (junctions["right"] == 0)
    border[junctions["left"][touches_zero]] = True
    border[junctions["right"][touches_zero]] = True

    has_poly = poly_len[present] > 0
    data = {
        "cell": ids[present].astype(np.int64),
        "x": centroid[:, 0],
        "y": centroid[:, 1],
        "area": count[present],
        "polygon_area": poly_area[present],
        "perimeter": poly_perimeter[present],
        "n_sides": poly_len[present].astype(np.int64),
        "n_boundaries": n_cycles[present].astype(np.int64),
        "is_border": border[present],
    }
    _refuse_ids_in_pieces(n_cycles[present])
    if (n_cycles[present] > 1).any():
        warnings.warn(
            "some cells have several boundary cycles (pieces, holes or pinches); their largest cycle is "
            "used as polygon (see the n_boundaries column)",
            HexatissueWarning,
            stacklevel=3,
        )
    # by design without a polygon: a lone cell on background (no vertex), and a border cell with one neighbour
    # (its boundary has two vertices, where the neighbour and the background meet); others have lost theirs
    if (~has_poly).any():
        lost = _lost_polygons(junctions, ids, present, border, has_poly)
        if (lost & ~border[present]).any():
            warnings.warn(
                "some interior cells have no boundary polygon (too small, or all their vertices merged within "
                "merge_distance): n_sides 0, no polygon_area, perimeter or shape function",
                HexatissueWarning,
                stacklevel=3,
            )
        if (lost & border[present]).any():
            warnings.warn(
                "some border cells have no boundary polygon: once their junctions shorter than merge_distance "
                "were merged they kept two vertices (where they meet the outside): n_sides 0, no polygon_area, "
                "perimeter or shape function (border cells are left out of interior statistics)",
                HexatissueWarning,
                stacklevel=3,
            )
    return data


def _lost_polygons(junctions, ids, present, border, has_poly):
    """Which present cells lack a polygon that should have one: they have neighbours and are not a border cell
    with one neighbour (whose boundary has two vertices); computed only for frames with a cell without one."""
    between = (junctions["left"] != 0) & (junctions["right"] != 0)
    pairs = np.unique(np.sort(np.column_stack((junctions["left"], junctions["right"]))[between], axis=1), axis=0)
    n_neighbours = np.bincount(pairs.ravel(), minlength=len(ids))[present]
    two_vertex = border[present] & (n_neighbours == 1)
    return ~has_poly & (n_neighbours > 0) & ~two_vertex


def _refuse_ids_in_pieces(cycles):
    """Refuse labels whose ids mostly come in several separate regions: classes or colours, not cells."""
    in_pieces = int(np.count_nonzero(cycles > 1))
    least = 2 if len(cycles) >= MANY_IDS else PIECES_PER_ID
    if in_pieces and in_pieces >= len(cycles) / 2 and cycles.mean() >= least:
        raise InputError(
            f"labels do not look like cell labels: {in_pieces} of {len(cycles)} ids each cover several separate "
            f"regions ({cycles.mean():.1f} boundaries per id; a cell has one). Is it a pixel classifier's class map "
            f"(e.g. ilastik Simple Segmentation), a binary membrane map, a colour rendering of labels whose "
            f"colours repeat, or a dim raw image with few grey values? For a membrane or probability map use --kind membrane-map; otherwise export the "
            f"segmentation's label image (one id per cell)")


def _network_columns(centre, kept, ids, cells, poly_start, poly_len, verts, xy, box):
    cell_a = ids[np.minimum(kept["left"], kept["right"])]
    cell_b = ids[np.maximum(kept["left"], kept["right"])]
    degree = np.bincount(kept["a"], minlength=len(centre)) + np.bincount(kept["b"], minlength=len(centre))
    vborder = np.zeros(len(centre), bool)
    outside = cell_a == 0
    vborder[kept["a"][outside]] = True
    vborder[kept["b"][outside]] = True
    vertices = {
        "vertex": np.arange(len(centre), dtype=np.int64),
        "x": centre[:, 0],
        "y": centre[:, 1],
        "degree": degree.astype(np.int64),
        "is_border": vborder,
    }
    edges = {
        "edge": np.arange(len(cell_a), dtype=np.int64),
        "vertex_a": kept["a"].astype(np.int64),
        "vertex_b": kept["b"].astype(np.int64),
        "cell_a": cell_a.astype(np.int64),
        "cell_b": cell_b.astype(np.int64),
        "length": np.hypot(*kept["vec"].T),
    }
    lengths = box.lengths if box is not None else np.zeros(2)
    row, rank, vertex, image, polygon_xy, first = K.cell_vertex_rows(np.searchsorted(ids, cells["cell"]), poly_start,
                                                                     poly_len, verts, xy, centre, lengths)
    # image_x, image_y: which periodic image of each vertex the contiguous polygon uses (exact: from the
    # traced displacements), so polygons read back from the tables are right even with a junction longer
    # than half the box
    cell_vertices = {"cell": cells["cell"][row], "rank": rank, "vertex": vertex,
                     "image_x": image[:, 0], "image_y": image[:, 1]}
    return vertices, edges, cell_vertices, (polygon_xy, first)


def kernels_cached() -> bool:
    """Whether the mesh kernels are compiled or in numba's cache (else an analysis that compiles compiles them all).

    The mesh's cell-moment kernel stands for all (every analysis of labels runs it).
    """
    return compiled_or_cached(_kernels.cell_moments)