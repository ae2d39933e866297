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

import warnings

import numpy as np
import pandas as pd

from ..errors import HexatissueWarning, InputError, check_orders, check_positive
from ..options import OrderOptions
from ..order.shape import shape_functions_flat
from .files import LabelledMesh, check_mesh, read_mesh
from .mesh_events import mesh_events

__all__ = ["mesh_tissue", "mesh_tables", "read_mesh_tables", "tangent_frames", "transport_angles",
           "solid_angles", "arc_lengths", "FALLBACK_COS", "RADIUS_FACTOR", "MESH_TABLE_NAMES"]

#: Where ``|n . reference| > FALLBACK_COS`` (within 25.8 degrees of the normal) the tangent frame's e1 is the
#: coordinate axis most orthogonal to the reference instead (the frame does not change |gamma_p| or defects).
FALLBACK_COS = 0.9
#: The tables :func:`mesh_tissue` returns, in order.
MESH_TABLE_NAMES = ("mesh_cells", "mesh_vertices", "mesh_junctions", "mesh_defects", "mesh_frames", "mesh_events")
#: Default coarse-graining radius on a mesh, in units of R_cell = sqrt(mean area / pi).  The flat grid's 1.5 R_cell
#: disks sit anywhere between cells and hold (1.5)^2 = 2.25 cells on average; centred on a cell, whose neighbours are
#: about 1.9 R_cell away (a hexagonal tiling's spacing), a 1.5 R_cell disk holds the cell alone (1.0-1.2 cells on
#: spheres of 400 cells) and Gamma_p is gamma_p.  2.5 R_cell takes in the first shell of neighbours, not the second
#: (3.3 R_cell): about 7 cells (docs/surface.md, "Gamma_p on a mesh").
RADIUS_FACTOR = 2.5
#: A charge times p further than this from an integer is reported (it cannot happen but through round-off).
_CHARGE_TOLERANCE = 1e-6


def tangent_frames(normals, reference=(1.0, 0.0, 0.0), fallback_cos=FALLBACK_COS):
    """``(e1, e2)`` of unit normals ``(N, 3)``: the reference direction projected on each tangent plane.

    ``e1`` is ``reference`` minus its normal component, normalised; where
    ``|n . reference| > fallback_cos`` the coordinate axis most orthogonal
    to ``reference`` is projected instead.  ``e2 = n x e1``.  NaN normals
    give NaN frames.
    """
    n = np.asarray(normals, dtype=float).reshape(-1, 3)
    ref = np.asarray(reference, dtype=float).reshape(3)
    size = np.linalg.norm(ref)
    if not np.isfinite(ref).all() or size == 0:
        raise InputError(f"reference must be a finite non-zero 3-vector; got {reference!r}")
    ref = ref / size
    other = np.zeros(3)
    other[int(np.argmin(np.abs(ref)))] = 1.0
    dot = n @ ref
    use = np.where((np.abs(dot) > fallback_cos)[:, None], other, ref)
    e1 = use - (n * use).sum(axis=1)[:, None] * n
    with np.errstate(invalid="ignore", divide="ignore"):
        e1 /= np.linalg.norm(e1, axis=1)[:, None]
    e2 = np.cross(n, e1)
    return e1, e2


def transport_angles(n_from, e1_from, n_to, e1_to, e2_to):
    """Angle (rad, in (-pi, pi]) of frame ``from``'s e1, carried onto ``to``'s plane, in frame ``to``.

    The carrying rotation is the minimal one taking ``n_from`` to ``n_to``
    (about ``n_from x n_to``): the Levi-Civita transport along the great
    circle between the normals on the unit sphere.  A vector at angle
    ``alpha`` in frame ``from`` is at ``alpha + angle`` in frame ``to``.
    Antipodal normals give NaN.
    """
    c = (n_from * n_to).sum(axis=1)
    v = np.cross(n_from, n_to)
    x = e1_from
    with np.errstate(invalid="ignore", divide="ignore"):
        scale = np.where(1.0 + c > 1e-12, 1.0 / (1.0 + c), np.nan)
    rx = x * c[:, None] + np.cross(v, x) + v * ((v * x).sum(axis=1) * scale)[:, None]
    return np.arctan2((rx * e2_to).sum(axis=1), (rx * e1_to).sum(axis=1))


def solid_angles(a, b, c):
    """Signed area (sr) of the geodesic triangles ``(a, b, c)`` of unit vectors on the unit sphere.

    ``2 atan2(a . (b x c), 1 + a.b + b.c + c.a)`` (Van Oosterom and
    Strackee 1983), positive when ``a, b, c`` turn counter-clockwise seen
    from outside the sphere.
    """
    triple = (a * np.cross(b, c)).sum(axis=1)
    den = 1.0 + (a * b).sum(axis=1) + (b * c).sum(axis=1) + (c * a).sum(axis=1)
    return 2.0 * np.arctan2(triple, den)


def arc_lengths(a, b, n_a, n_b):
    """Distance along the surface between points ``a`` and ``b`` ``(N, 3)`` with unit normals ``n_a``, ``n_b``.

    The arc of the circle through both points whose normal turns from
    ``n_a`` to ``n_b``: ``|b - a| theta / (2 sin(theta / 2))``, ``theta`` the
    angle between the normals (``theta / |n_b - n_a|``, as ``|n_b - n_a| =
    2 sin(theta / 2)``).  Exact on a plane (the chord) and between points of
    a sphere (the great circle's arc); elsewhere the arc of the normal
    section's osculating circle.  Never shorter than the chord.
    """
    chord = np.linalg.norm(b - a, axis=1)
    gap = np.linalg.norm(n_b - n_a, axis=1)
    theta = 2.0 * np.arctan2(gap, np.linalg.norm(n_b + n_a, axis=1))
    with np.errstate(invalid="ignore", divide="ignore"):
        # below 1e-4 the series (error ~ gap^4 / 600) avoids 0 / 0 and keeps a plane's distance the exact chord
        stretch = np.where(gap > 1e-4, theta / gap, 1.0 + gap * gap / 24.0)
    return chord * stretch


def _cell_radius(area, interior):
    """R_cell = sqrt(mean area / pi) of the interior cells with a positive finite area (of every such cell when no
    cell is interior: a patch that is all border), as :func:`hexatissue.order.cell_radius`; NaN without any."""
    good = np.isfinite(area) & (area > 0)
    use = good & interior if (good & interior).any() else good
    return float(np.sqrt(area[use].mean() / np.pi)) if use.any() else np.nan


def _coarse_field(centroid, normal, e1, e2, gammas, orders, interior, radius):
    """Gamma_p at every cell (docs/surface.md, "Gamma_p on a mesh"), the cells averaged in each disk and whether
    the disk lies on the tissue.

    Cell j is in cell c's disk when :func:`arc_lengths` between their
    centroids is at most ``radius``; the interior cells of the disk whose
    gamma_p of every order is finite enter the mean, each carried into c's
    frame (``gamma_j exp(i p phi_jc)``, :func:`transport_angles`).  An empty
    disk gives NaN.  A disk is valid when it averages a cell and holds no
    border cell (the flat grid's full coverage: the disk does not reach the
    tissue's edge).
    """
    from scipy.spatial import cKDTree

    nc = len(centroid)
    ok = np.isfinite(centroid).all(axis=1) & np.isfinite(normal).all(axis=1)
    gamma = np.column_stack(gammas) if len(orders) else np.zeros((nc, 0), complex)
    member = ok & interior & np.isfinite(gamma).all(axis=1)
    nodes = np.flatnonzero(ok)
    if not np.isfinite(radius) or len(nodes) == 0:
        return [np.full(nc, complex(np.nan, np.nan)) for _ in orders], np.zeros(nc, np.int64), np.zeros(nc, bool)
    # an arc is never shorter than its chord: the chord's ball holds every cell of the disk
    pairs = cKDTree(centroid[nodes]).query_pairs(radius * (1 + 1e-9), output_type="ndarray")
    i, j = nodes[pairs[:, 0]], nodes[pairs[:, 1]]
    node, cell = np.r_[i, j, nodes], np.r_[j, i, nodes]
    near = arc_lengths(centroid[node], centroid[cell], normal[node], normal[cell]) <= radius
    edge = np.bincount(node[near & ~interior[cell]], minlength=nc) > 0
    near &= member[cell]
    node, cell = node[near], cell[near]
    phi = transport_angles(normal[cell], e1[cell], normal[node], e1[node], e2[node])
    phi[node == cell] = 0.0  # a cell in its own frame: exactly, not to the round-off of the rotation's formula
    keep = np.isfinite(phi)  # opposed normals (a disk across a thin fold) have no minimal rotation: not averaged
    node, cell, phi = node[keep], cell[keep], phi[keep]
    count = np.bincount(node, minlength=nc)
    means = []
    for a, q in enumerate(orders):
        carried = gamma[cell, a] * np.exp(1j * q * phi)
        total = np.bincount(node, carried.real, nc) + 1j * np.bincount(node, carried.imag, nc)
        with np.errstate(invalid="ignore", divide="ignore"):
            means.append(np.where(count > 0, total / np.maximum(count, 1), complex(np.nan, np.nan)))
    return means, count.astype(np.int64), (count > 0) & ~edge


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
    r_cell = _cell_radius(area, ~is_border)
    radius = RADIUS_FACTOR * r_cell if radius is None else radius
    coarse, n_disk, valid = _coarse_field(centroid, normal, e1, e2, gammas, orders, ~is_border, radius)
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

    dual = _dual_triangles(frm, prv, twin, idx, face_of, jv[~touches0[jv]], normal, e1, e2)
    coarse_defects, coarse_totals = _defects(dual, V, coarse, orders, cells, frame, "coarse", valid)
    cell_defects, totals = _defects(dual, V, gammas, orders, cells, frame, "cells")
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


def _dual_triangles(frm, prv, twin, idx, face_of, verts, normal, e1, e2):
    """The dual triangles around the junction vertices ``verts`` (docs/surface.md, "Surface meshes"): each vertex's
    cells counter-clockwise (``ring`` from ``ring_start``, ``d`` of them), its fan triangles of distinct cells
    (``owner`` vertex, cells ``i0, i1, i2``), each side's cells and transport angle (``sides``) and the solid angle
    of each triangle's normals (``curvature``)."""
    n_he = len(frm)
    out_he = np.full(int(frm.max()) + 1 if n_he else 0, -1, np.int64)
    out_he[frm[::-1]] = np.arange(n_he)[::-1]
    # the faces around each interior junction vertex, counter-clockwise: h -> twin(prev(h))
    start = out_he[verts]
    seqs = [idx[face_of[start]]]
    cur = start.copy()
    active = np.ones(len(verts), bool)
    for _ in range(n_he):
        cur = np.where(active, twin[prv[cur]], cur)
        active &= cur != start
        if not active.any():
            break
        seqs.append(np.where(active, idx[face_of[cur]], -2))
    seq = np.column_stack(seqs) if len(verts) else np.zeros((0, 1), np.int64)
    valid = seq != -2
    length = valid.sum(axis=1)
    prev = np.roll(seq, 1, axis=1)
    prev[:, 0] = seq[np.arange(len(seq)), length - 1] if len(seq) else prev[:, 0]
    keep = valid & (seq != prev)
    d = keep.sum(axis=1)
    ring = seq[keep]  # the cells around each vertex, counter-clockwise, vertex after vertex
    ring_start = np.r_[0, np.cumsum(d)[:-1]].astype(np.int64)
    # fan: (c0, c_k, c_k+1), k = 1 .. d-2
    n_tri = np.maximum(d - 2, 0)
    owner = np.repeat(np.arange(len(verts)), n_tri)
    k = np.arange(int(n_tri.sum())) - np.repeat(np.cumsum(n_tri) - n_tri, n_tri) + 1
    i0 = ring[ring_start[owner]]
    i1 = ring[ring_start[owner] + k]
    i2 = ring[ring_start[owner] + k + 1]
    proper = (i0 != i1) & (i1 != i2) & (i0 != i2)
    owner, i0, i1, i2 = owner[proper], i0[proper], i1[proper], i2[proper]
    # each side's transport angle from its lower cell to its higher, once for every field and order
    sides = [(i, j, transport_angles(normal[np.minimum(i, j)], e1[np.minimum(i, j)], normal[np.maximum(i, j)],
                                     e1[np.maximum(i, j)], e2[np.maximum(i, j)]))
             for i, j in ((i0, i1), (i1, i2), (i2, i0))]
    return {"verts": verts, "ring": ring, "ring_start": ring_start, "d": d, "owner": owner, "i0": i0, "i1": i1,
            "i2": i2, "sides": sides, "curvature": solid_angles(normal[i0], normal[i1], normal[i2])}


def _defects(dual, V, fields, orders, cells, frame, field, valid=None):
    """The defects of one field (one complex array per order, a value per cell, in the cells' frames) on the dual
    triangles (:func:`_dual_triangles`), labelled ``field``, and ``{p: (total charge, undefined triangles)}``.

    With ``valid`` (a flag per cell), only the vertices whose cells are all valid are looked at.
    """
    columns = ["frame", "defect", "field", "vertex", "x", "y", "z", "charge", "p", "cell_a", "cell_b", "cell_c",
               "n_cells"]
    verts, ring, ring_start, d = dual["verts"], dual["ring"], dual["ring_start"], dual["d"]
    owner, i0, i1, i2 = dual["owner"], dual["i0"], dual["i1"], dual["i2"]
    looked = np.ones(len(owner), bool)
    if valid is not None:
        outside = np.bincount(owner[~(valid[i0] & valid[i1] & valid[i2])], minlength=len(verts)) > 0
        looked = ~outside[owner]
    rows, totals = [], {}
    for q, gam in zip(orders, fields):
        phase = np.angle(gam)  # phases apart: a product of two tiny gamma_p (p = 1 about the vertex mean) would vanish
        winding = sum(_delta(i, j, phi, phase, q) for i, j, phi in dual["sides"])
        x = np.where(looked, (winding + q * dual["curvature"]) / (2 * np.pi), 0.0)
        ok = np.isfinite(x)
        whole = np.round(x[ok])
        if len(whole) and np.abs(x[ok] - whole).max() > _CHARGE_TOLERANCE:
            warnings.warn(f"defect charges of p = {q} ({field}) are up to {np.abs(x[ok] - whole).max():.2g} / {q} "
                          f"from a multiple of 1/{q} (round-off); rounded", HexatissueWarning, stacklevel=3)
        numer = np.bincount(owner[ok], whole, len(verts)).astype(np.int64)
        bad = np.bincount(owner[~ok], minlength=len(verts)) > 0
        totals[q] = (float(numer[~bad].sum()) / q, int((~ok).sum()))
        hit = np.flatnonzero((numer != 0) & ~bad)
        v = verts[hit]
        rs = ring_start[hit]
        rows.append(pd.DataFrame({
            "frame": np.full(len(hit), frame, np.int64), "defect": np.zeros(len(hit), np.int64),
            "field": np.full(len(hit), field, object), "vertex": v.astype(np.int64), "x": V[v, 0], "y": V[v, 1],
            "z": V[v, 2], "charge": numer[hit] / q, "p": np.full(len(hit), q, np.int64),
            "cell_a": cells[ring[rs]].astype(np.int64), "cell_b": cells[ring[rs + 1]].astype(np.int64),
            "cell_c": cells[ring[rs + 2]].astype(np.int64), "n_cells": d[hit].astype(np.int64)}))
    table = pd.concat(rows, ignore_index=True) if rows else pd.DataFrame(columns=columns)
    return table[columns], totals


def _delta(i, j, phi, phase, p):
    """The wrapped p-fold phase step from cell i to cell j after transport (``phi``: from the lower cell's frame to
    the higher's), antisymmetric in (i, j) by construction."""
    lo, hi = np.minimum(i, j), np.maximum(i, j)
    step = np.angle(np.exp(1j * (phase[hi] - phase[lo] - p * phi)))
    return np.where(i < j, step, -step)


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
