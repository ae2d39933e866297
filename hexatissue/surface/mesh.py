"""The tissue on a labelled triangle mesh: cells, junctions, gamma_p in tangent frames, p-atic defects with curvature.

A surface mesh (MorphoGraphX, tissue cartography, a closed organoid or
embryo) gives the cell of every triangle.  :func:`mesh_tissue` turns one such
mesh into tables (:data:`hexatissue.schema.SURFACE_MESH_TABLES`):

- ``mesh_cells``: every cell's area, boundary length, centroid, unit normal,
  tangent frame, junction polygon, neighbours, gamma_p and the
  coarse-grained Gamma_p at the cell (the gamma_p of the cells within a
  radius along the surface, parallel-transported into its frame);
- ``mesh_vertices``: the junction vertices (mesh vertices where >= 3 cells,
  or cells and the background, meet);
- ``mesh_junctions``: the boundaries between two cells (or a cell and the
  background) from junction vertex to junction vertex;
- ``mesh_defects``: the p-atic defects of the Gamma_p field and of the
  cells' gamma_p field, with the curvature each dual triangle encloses
  (Gauss-Bonnet: on a closed surface the charges of either sum to its Euler
  characteristic, 2 on a sphere);
- ``mesh_frames``: per mesh, the counts, the mesh's Euler characteristic
  and the total charge per p.

The formulas are in docs/surface.md ("Surface meshes").  Orientation: the
faces must be consistently oriented; a cell's normal is its faces' vector
area (the side its triangles' counter-clockwise order faces), and its
tangent frame is ``e1`` = the reference direction (default x) projected on
its tangent plane, or the coordinate axis most orthogonal to it where the
reference is within ``acos(FALLBACK_COS)`` of the normal, ``e2 = n x e1``.
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from ..errors import InputError, check_orders, check_positive
from ..options import OrderOptions
from ..order.shape import shape_functions_flat
from .files import LabelledMesh, check_mesh, read_mesh
from .mesh_defects import dual_triangles, field_defects
from .mesh_events import mesh_events
from .mesh_field import RADIUS_FACTOR, cell_radius, coarse_field
from .transport import tangent_frames

__all__ = ["mesh_tissue", "mesh_tables", "read_mesh_tables", "MESH_TABLE_NAMES"]

#: The tables :func:`mesh_tissue` returns, in order.
MESH_TABLE_NAMES = ("mesh_cells", "mesh_vertices", "mesh_junctions", "mesh_defects", "mesh_frames", "mesh_events")
def _half_edges(faces, n_vertices, name):
    """Half-edges ``3 f + k`` (from corner k to corner k+1 of face f): their ends, next and previous in the face,
    and twin (-1 on the mesh's edge), by one sort of the undirected edges."""
    m = len(faces)
    frm = faces.ravel()
    to = faces[:, [1, 2, 0]].ravel()
    h = np.arange(3 * m)
    base = h - h % 3
    nxt = base + (h % 3 + 1) % 3
    prv = base + (h % 3 + 2) % 3
    key = np.minimum(frm, to) * np.int64(n_vertices) + np.maximum(frm, to)
    order = np.argsort(key, kind="stable")
    sk = key[order]
    same = sk[1:] == sk[:-1]
    twin = np.full(3 * m, -1, np.int64)
    if same.any():
        triple = same[1:] & same[:-1]
        if triple.any():
            a, b = divmod(int(sk[np.flatnonzero(triple)[0] + 1]), n_vertices)
            raise InputError(f"{name}: the edge between vertices {a} and {b} belongs to more than two faces: the "
                             f"mesh is not a manifold")
        i = np.flatnonzero(same)
        h0, h1 = order[i], order[i + 1]
        wrong = frm[h0] == frm[h1]
        if wrong.any():
            k = int(np.flatnonzero(wrong)[0])
            raise InputError(f"{name}: the edge from vertex {int(frm[h0[k]])} to vertex {int(to[h0[k]])} runs the "
                             f"same way in faces {int(h0[k] // 3)} and {int(h1[k] // 3)}: the faces are not "
                             f"consistently oriented")
        twin[h0], twin[h1] = h1, h0
    return frm, to, nxt, prv, twin


def _list_order(succ):
    """For a permutation ``succ`` (cycles), each element's cycle id and its position from the cycle's first element."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    n = len(succ)
    if n == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    graph = coo_matrix((np.ones(n), (np.arange(n), succ)), shape=(n, n))
    _, comp = connected_components(graph, directed=True, connection="weak")
    root = np.full(comp.max() + 1, n, np.int64)
    np.minimum.at(root, comp, np.arange(n))
    # break each cycle before its root; rank = steps to the cycle's end, by pointer doubling
    s = np.where(succ == root[comp], -1, succ)
    rank = (s >= 0).astype(np.int64)
    while (s >= 0).any():
        ok = s >= 0
        new_rank = rank.copy()
        new_rank[ok] += rank[s[ok]]
        new_s = s.copy()
        new_s[ok] = s[s[ok]]
        rank, s = new_rank, new_s
    size = np.bincount(comp)
    return comp, size[comp] - 1 - rank


def mesh_tissue(vertices, faces=None, labels=None, *, frame=0, p=None, reference=(1.0, 0.0, 0.0), radius=None,
                name="mesh") -> dict:
    """The tissue of a labelled triangle mesh: its cells, junction vertices, junctions, defects and summary.

    Parameters
    ----------
    vertices : (n, 3) float array or LabelledMesh
        Vertex coordinates (x, y, z, px), or a mesh from :func:`read_mesh`
        (then ``faces`` and ``labels`` are not given).
    faces : (m, 3) int array
        Triangles, consistently oriented (each interior edge runs one way in
        one face and the other way in the other).
    labels : (m,) int array
        The cell of every face; 0 = no cell (background).
    frame : int
        The ``frame`` column of every table.
    p : int or sequence of int, optional
        Symmetry orders of gamma_p and the defects; default the order
        stage's (:class:`hexatissue.OrderOptions` ``p``: 6 and 2).
    reference : 3-vector
        The direction whose projection on a cell's tangent plane is its
        ``e1`` (default x); the axis most orthogonal to it where it is within
        ``acos(FALLBACK_COS)`` of the normal.  Changes the phase of gamma_p,
        not ``|gamma_p|`` nor the defects.
    radius : float, optional
        Radius R of the coarse-graining disks along the surface, px (the
        mesh's unit).  Default ``RADIUS_FACTOR R_cell`` (2.5: each cell and
        its first shell of neighbours; :data:`RADIUS_FACTOR`), R_cell =
        sqrt(mean area / pi) of the interior cells as in
        :func:`hexatissue.coarse_grain` (of all cells when every cell is a
        border cell).
    name : str
        The mesh's name in error messages.

    Returns
    -------
    dict of pandas.DataFrame
        ``mesh_cells``, ``mesh_vertices``, ``mesh_junctions``,
        ``mesh_defects``, ``mesh_frames``; their columns, units and meanings
        are :data:`hexatissue.schema.SURFACE_MESH_TABLES`:

        ``mesh_cells``: ``frame``, ``cell`` (label), ``x``, ``y``, ``z``
        (area centroid of its faces, px), ``area`` (sum of its faces' areas,
        px^2), ``perimeter`` (length of its boundary along mesh edges, px),
        ``polygon_perimeter`` (the straight sides between its junction
        vertices, px), ``n_sides`` (junction vertices on its longest
        boundary), ``n_neighbours``, ``n_boundaries`` (boundary loops),
        ``n_faces``, ``is_border`` (touches the background or the mesh's
        edge), ``normal_x/_y/_z`` (unit vector area of its faces),
        ``e1_x/_y/_z`` (its tangent frame's first axis), ``gamma{p}_re/_im``
        (gamma_p of its junction polygon in that frame), ``Gamma{p}_re/_im``
        (the coarse-grained field at the cell, in its frame: the mean of the
        gamma_p of the interior cells within R along the surface, each
        parallel-transported into the frame; NaN when there is none),
        ``n_disk`` (the cells averaged), ``valid`` (the disk lies on the
        tissue: it averages a cell and holds no border cell, as the flat
        grid's full coverage; every cell of a closed surface).

        ``mesh_vertices``: ``frame``, ``vertex`` (mesh vertex index), ``x``,
        ``y``, ``z`` (px), ``n_cells`` (cells meeting there), ``is_border``.

        ``mesh_junctions``: ``frame``, ``junction`` (id), ``cell_a``,
        ``cell_b`` (0: the background or the mesh's edge), ``vertex_a``,
        ``vertex_b`` (its end junction vertices, with ``cell_a`` on the left
        going from a to b), ``length`` (along mesh edges, px), ``chord``
        (straight, px).

        ``mesh_defects``: ``frame``, ``defect`` (id), ``field``
        (``"coarse"``: the defects of Gamma_p, the flat analysis's defects,
        listed first, at the vertices whose cells are all ``valid``;
        ``"cells"``: those of the cells' own gamma_p),
        ``vertex``, ``x``, ``y``, ``z`` (the junction vertex, px), ``charge``
        (a multiple of 1/p), ``p``, ``cell_a``, ``cell_b``, ``cell_c`` (the
        first three cells counter-clockwise around the vertex), ``n_cells``.

        ``mesh_frames``: ``frame``, ``n_cells``, ``n_vertices`` (junction
        vertices), ``n_junctions``, ``euler`` (V - E + F of the mesh),
        ``closed`` (no mesh edge and no background), ``r_cell`` (R_cell,
        px), ``radius`` (R, px), ``charge{p}`` (sum of the charges of the
        cells' gamma_p), ``undefined{p}`` (its dual triangles without a
        charge: a cell without gamma_p), ``coarse_charge{p}``,
        ``coarse_undefined{p}`` (the same for Gamma_p: a cell with an empty
        disk).

    Raises
    ------
    InputError
        Bad arrays (:func:`hexatissue.surface.files.check_mesh`), faces not
        consistently oriented or an edge shared by more than two faces.
    """
    if isinstance(vertices, LabelledMesh):
        if faces is not None or labels is not None:
            raise InputError("mesh_tissue takes a LabelledMesh alone, or vertices, faces and labels")
        name = vertices.path or name
        mesh = check_mesh(vertices.vertices, vertices.faces, vertices.labels, name)
    else:
        if faces is None or labels is None:
            raise InputError("mesh_tissue needs vertices, faces and labels (or a LabelledMesh)")
        mesh = check_mesh(vertices, faces, labels, name)
    orders = check_orders(OrderOptions().p if p is None else p, "p")
    radius = None if radius is None else check_positive(radius, "radius", unit="px (the mesh's unit)")
    V, F, L = mesh.vertices, mesh.faces, mesh.labels
    n, m = len(V), len(F)
    frm, to, nxt, prv, twin = _half_edges(F, n, name)
    face_of = np.arange(3 * m) // 3
    lab = L[face_of]
    other = np.where(twin >= 0, L[face_of[np.maximum(twin, 0)]], 0)
    bnd = (lab > 0) & (other != lab)

    # ---- cells: areas, centroids, normals
    present = np.bincount(L) > 0 if m else np.zeros(1, bool)
    present[0] = False
    cells = np.flatnonzero(present)
    idx = (np.cumsum(present) - 1)[L]  # cell index of each face (-1: background)
    keep_face = L > 0
    nc = len(cells)
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    vec = 0.5 * np.cross(b - a, c - a)
    fa = np.linalg.norm(vec, axis=1)
    fi = idx[keep_face]
    area = np.bincount(fi, fa[keep_face], nc)
    vector = np.zeros((nc, 3))
    np.add.at(vector, fi, vec[keep_face])
    cen = np.zeros((nc, 3))
    np.add.at(cen, fi, (fa[keep_face, None] * (a + b + c)[keep_face] / 3.0))
    with np.errstate(invalid="ignore", divide="ignore"):
        centroid = cen / area[:, None]
        size = np.linalg.norm(vector, axis=1)
        normal = vector / size[:, None]
    normal[~(size > 1e-12 * area)] = np.nan
    n_faces = np.bincount(fi, minlength=nc)
    e1, e2 = tangent_frames(normal, reference)

    # ---- junction vertices: mesh vertices where >= 3 labels meet (the background, 0, counting as one)
    on_edge = np.zeros(n, bool)
    on_edge[frm[twin < 0]] = True
    on_edge[to[twin < 0]] = True
    pairs = np.sort(np.r_[F.ravel() * np.int64(nc + 1) + np.repeat(idx + 1, 3),
                          np.flatnonzero(on_edge) * np.int64(nc + 1)])
    pairs = pairs[np.r_[True, pairs[1:] != pairs[:-1]]] if len(pairs) else pairs
    pv, pl = np.divmod(pairs, nc + 1)
    degree = np.bincount(pv, minlength=n)
    touches0 = np.zeros(n, bool)
    touches0[pv[pl == 0]] = True
    junction = degree >= 3

    # ---- boundaries: boundary half-edges chained into loops, cell on the left
    B = np.flatnonzero(bnd)
    g = nxt[B].copy()
    for _ in range(3 * m + 1):
        walk = ~bnd[g]
        if not walk.any():
            break
        g[walk] = nxt[twin[g[walk]]]
    where = np.full(3 * m, -1, np.int64)
    where[B] = np.arange(len(B))
    succ = where[g]
    loop, position = _list_order(succ)
    order = np.lexsort((position, loop))
    B, loop = B[order], loop[order]
    he_len = np.linalg.norm(V[to[B]] - V[frm[B]], axis=1)
    loop_cell = idx[face_of[B]]
    n_loops = loop.max() + 1 if len(loop) else 0
    loop_start = np.searchsorted(loop, np.arange(n_loops))
    loop_length = np.bincount(loop, he_len, n_loops)
    loop_owner = loop_cell[loop_start] if n_loops else np.zeros(0, np.int64)
    perimeter = np.bincount(loop_owner, loop_length, nc)
    n_boundaries = np.bincount(loop_owner, minlength=nc)
    # each cell's longest loop carries its polygon
    best = np.full(nc, -1, np.int64)
    if n_loops:
        rank = np.lexsort((-loop_length, loop_owner))
        firsts = np.r_[True, loop_owner[rank][1:] != loop_owner[rank][:-1]]
        best[loop_owner[rank][firsts]] = rank[firsts]
    is_j = junction[frm[B]]
    on_best = best[loop_cell] == loop
    poly_he = B[on_best & is_j]
    poly_cell = loop_cell[on_best & is_j]  # in loop order; one loop per cell, so a stable sort by cell keeps it
    srt = np.argsort(poly_cell, kind="stable")
    poly_he, poly_cell = poly_he[srt], poly_cell[srt]
    n_sides = np.bincount(poly_cell, minlength=nc)
    starts = np.r_[0, np.cumsum(n_sides)[:-1]].astype(np.int64)
    P = V[frm[poly_he]]
    nxt_poly = np.arange(len(P)) + 1
    ends = starts + n_sides
    nxt_poly[ends[n_sides > 0] - 1] = starts[n_sides > 0]
    chords = np.linalg.norm(P[nxt_poly] - P, axis=1) if len(P) else np.zeros(0)
    polygon_perimeter = np.where(n_sides >= 3, np.bincount(poly_cell, chords, nc), np.nan)
    uv = np.column_stack([(P * e1[poly_cell]).sum(axis=1), (P * e2[poly_cell]).sum(axis=1)])
    gammas = shape_functions_flat(uv, starts, orders) if nc else [np.zeros(0, complex) for _ in orders]
    nb = np.unique(np.c_[idx[face_of[B]], other[B]], axis=0) if len(B) else np.zeros((0, 2), np.int64)
    n_neighbours = np.bincount(nb[nb[:, 1] > 0, 0], minlength=nc)
    is_border = np.zeros(nc, bool)
    is_border[nb[nb[:, 1] == 0, 0]] = True
    cell_table = {"frame": np.full(nc, frame, np.int64), "cell": cells.astype(np.int64),
                  "x": centroid[:, 0], "y": centroid[:, 1], "z": centroid[:, 2], "area": area,
                  "perimeter": perimeter, "polygon_perimeter": polygon_perimeter,
                  "n_sides": n_sides.astype(np.int64), "n_neighbours": n_neighbours.astype(np.int64),
                  "n_boundaries": n_boundaries.astype(np.int64), "n_faces": n_faces.astype(np.int64),
                  "is_border": is_border, "normal_x": normal[:, 0], "normal_y": normal[:, 1],
                  "normal_z": normal[:, 2], "e1_x": e1[:, 0], "e1_y": e1[:, 1], "e1_z": e1[:, 2]}
    for q, gam in zip(orders, gammas):
        cell_table[f"gamma{q}_re"] = gam.real
        cell_table[f"gamma{q}_im"] = gam.imag
    r_cell = cell_radius(area, ~is_border)
    radius = RADIUS_FACTOR * r_cell if radius is None else radius
    coarse, n_disk, valid = coarse_field(centroid, normal, e1, e2, gammas, orders, ~is_border, radius)
    for q, gam in zip(orders, coarse):
        cell_table[f"Gamma{q}_re"] = gam.real
        cell_table[f"Gamma{q}_im"] = gam.imag
    cell_table["n_disk"] = n_disk
    cell_table["valid"] = valid

    # ---- junctions: each loop cut at its junction vertices
    has_j = np.bincount(loop, is_j, n_loops) > 0 if n_loops else np.zeros(0, bool)
    inl = has_j[loop]
    Bj, loopj, isj = B[inl], loop[inl], is_j[inl]
    seg = np.cumsum(isj) - 1  # global segment counter; a loop's head before its first junction vertex
    starts_loop = np.searchsorted(loopj, np.unique(loopj))
    first_seg = seg[starts_loop] + (~isj[starts_loop])  # the loop's first segment
    count_seg = np.bincount(loopj, isj, n_loops)[np.unique(loopj)].astype(np.int64)
    lidx = np.searchsorted(np.unique(loopj), loopj)
    head = seg < first_seg[lidx]
    seg = np.where(head, first_seg[lidx] + count_seg[lidx] - 1, seg)
    n_seg = int(isj.sum())
    seg_len = np.bincount(seg, he_len[inl], n_seg)
    seg_start = Bj[isj]  # the half-edge leaving each segment's first vertex (segments numbered in this order)
    seg_loop = loopj[isj]
    seg_next = np.arange(n_seg) + 1
    last_of_loop = np.r_[seg_loop[1:] != seg_loop[:-1], True] if n_seg else np.zeros(0, bool)
    seg_next[last_of_loop] = np.searchsorted(seg_loop, seg_loop[last_of_loop])
    va, vb = frm[seg_start], frm[seg_start[seg_next]] if n_seg else np.zeros(0, np.int64)
    ca, cb = lab[seg_start], other[seg_start]
    keepj = (cb == 0) | (ca < cb)
    jt = {"frame": np.full(int(keepj.sum()), frame, np.int64), "junction": np.arange(int(keepj.sum())),
          "cell_a": ca[keepj].astype(np.int64), "cell_b": cb[keepj].astype(np.int64),
          "vertex_a": va[keepj].astype(np.int64), "vertex_b": vb[keepj].astype(np.int64),
          "length": seg_len[keepj], "chord": np.linalg.norm(V[vb[keepj]] - V[va[keepj]], axis=1)}

    jv = np.flatnonzero(junction)
    vt = {"frame": np.full(len(jv), frame, np.int64), "vertex": jv.astype(np.int64), "x": V[jv, 0], "y": V[jv, 1],
          "z": V[jv, 2], "n_cells": (degree[jv] - touches0[jv]).astype(np.int64), "is_border": touches0[jv]}

    dual = dual_triangles(frm, prv, twin, idx, face_of, jv[~touches0[jv]], normal, e1, e2)
    coarse_defects, coarse_totals = field_defects(dual, V, coarse, orders, cells, frame, "coarse", valid)
    cell_defects, totals = field_defects(dual, V, gammas, orders, cells, frame, "cells")
    defects = pd.concat([coarse_defects, cell_defects], ignore_index=True)
    defects["defect"] = np.arange(len(defects), dtype=np.int64)
    used = np.flatnonzero(np.bincount(F.ravel(), minlength=n))
    n_edges = (3 * m + int((twin < 0).sum())) // 2
    ft = {"frame": np.array([frame], np.int64), "n_cells": np.array([nc], np.int64),
          "n_vertices": np.array([len(jv)], np.int64), "n_junctions": np.array([len(jt["junction"])], np.int64),
          "euler": np.array([len(used) - n_edges + m], np.int64),
          "closed": np.array([bool((twin >= 0).all() and (L > 0).all())]), "r_cell": np.array([r_cell]),
          "radius": np.array([float(radius)])}
    for q in orders:
        ft[f"charge{q}"] = np.array([totals[q][0]])
        ft[f"undefined{q}"] = np.array([totals[q][1]], np.int64)
    for q in orders:
        ft[f"coarse_charge{q}"] = np.array([coarse_totals[q][0]])
        ft[f"coarse_undefined{q}"] = np.array([coarse_totals[q][1]], np.int64)
    return {"mesh_cells": pd.DataFrame(cell_table), "mesh_vertices": pd.DataFrame(vt),
            "mesh_junctions": pd.DataFrame(jt), "mesh_defects": defects, "mesh_frames": pd.DataFrame(ft)}


def mesh_tables(meshes, *, p=None, reference=(1.0, 0.0, 0.0), radius=None) -> dict:
    """:func:`mesh_tissue` of each mesh (frame = its position), the tables of all frames concatenated, and the
    T1 events between the frames (``mesh_events``, :func:`~hexatissue.surface.mesh_events.mesh_events`).

    ``meshes``: :class:`LabelledMesh` objects or ``(vertices, faces, labels)``
    tuples.  Cell labels are taken as given in every frame (no tracking): a
    label is one cell throughout.  ``radius`` (px) is every frame's
    coarse-graining radius; by default each frame's ``RADIUS_FACTOR R_cell``.
    """
    parts = {name: [] for name in MESH_TABLE_NAMES if name != "mesh_events"}
    for t, mesh in enumerate(meshes):
        tables = (mesh_tissue(mesh, frame=t, p=p, reference=reference, radius=radius)
                  if isinstance(mesh, LabelledMesh) else mesh_tissue(*mesh, frame=t, p=p, reference=reference,
                                                                      radius=radius))
        for name, table in tables.items():
            parts[name].append(table)
    out = {name: (pd.concat(tables, ignore_index=True) if tables else pd.DataFrame())
           for name, tables in parts.items()}
    if len(out["mesh_cells"]):
        out["mesh_events"] = mesh_events(out["mesh_cells"], out["mesh_junctions"])
    else:
        out["mesh_events"] = pd.DataFrame()
    return out


def read_mesh_tables(paths, *, label=None, p=None, reference=(1.0, 0.0, 0.0), radius=None) -> dict:
    """Read mesh files (:func:`read_mesh`; several = frames, in the order given) and measure them
    (:func:`mesh_tables`)."""
    if isinstance(paths, (str, bytes)) or hasattr(paths, "__fspath__"):
        paths = [paths]
    return mesh_tables((read_mesh(path, label=label) for path in paths), p=p, reference=reference, radius=radius)
