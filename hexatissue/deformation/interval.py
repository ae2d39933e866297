"""The budget of one frame interval: the intermediate triangulations of steps 1-5, each connected
retriangulation's kind, and the triangles that collapse on the way.
"""
from __future__ import annotations

import numpy as np

from ..geometry import in_sorted
from ..schema import DEFORMATION_TERMS, ISOTROPIC_TERMS
from .flow import integrate_flow
from .movie import _corners, _lookup, _mean_position
from .states import _State, _components, _isin_rows, _means
from .triangles import det2, edge_matrices, inv2
from .triangulation import _first_of_each, _sorted_unique, _triple_keys, pair_keys


# the order in which the retriangulations of step 4 are applied
_STEP4 = ("extrusion", "t1_cycle", "t1_intercalation", "t1_unresolved", "resampling", "rearrangement")


def _step4_kinds(removed, added, dying, candidates, K, contacts):
    """The kind of each connected retriangulation, as shares per kind: (n_components, len(_STEP4)), labels.

    ``contacts``: the sorted pair keys of the cells sharing a vertex before
    and after (:func:`frame_contacts`, daughters merged into their mother).
    A retriangulation with no extruding cell and no T1 of ``candidates``
    whose every triangle edge is a contact on both sides changes no contact:
    a ``resampling``; else a ``rearrangement``.
    """
    both = np.concatenate([removed, added])
    labels = _components(both, K)
    n = labels.max() + 1 if len(labels) else 0
    share = np.zeros((n, len(_STEP4)))
    matched = [[] for _ in range(n)]
    if n == 0:
        return share, labels, matched
    edges = np.concatenate([pair_keys(both[:, i], both[:, j], K) for i, j in ((0, 1), (1, 2), (0, 2))])
    flips = in_sorted(edges, contacts[0]) != in_sorted(edges, contacts[1])
    contact_changes = np.bincount(np.tile(labels, 3), flips, n) > 0
    ids_of = [set() for _ in range(n)]
    for lab, row in zip(labels, both):
        ids_of[lab].update(row.tolist())
    for c in range(n):
        if ids_of[c] & dying:
            share[c, 0] = 1.0
            continue
        hits = [(event, kind) for event, kind, quartet in candidates if quartet <= ids_of[c]]
        if hits:
            for event, kind in hits:
                share[c, _STEP4.index(kind)] += 1.0 / len(hits)
            matched[c] = [event for event, _ in hits]
        else:
            share[c, _STEP4.index("rearrangement" if contact_changes[c] else "resampling")] = 1.0
    return share, labels, matched


def _pair(frames, lineage, layers, t, tri_t, tri_next, t1, tolerance, K, contacts):
    """The budget of the interval ``t`` -> ``t + 1``: per layer a (terms, n_regions) block, and per-event shares.

    ``contacts``: the two frames' :func:`frame_contacts`.
    """
    box = frames.box
    t_next = t + 1
    # the analysed tissue: the interior cells (a cell turning into a border cell leaves it)
    now = frames.track[frames.rows(t)][frames.interior[frames.rows(t)]]
    nxt = frames.track[frames.rows(t_next)][frames.interior[frames.rows(t_next)]]
    lost = np.setdiff1d(now, nxt)
    new = np.setdiff1d(nxt, now)
    mothers = {}
    for d in new.tolist():
        m = lineage.parent.get(d, 0)
        if m > 0 and m in set(lost.tolist()):
            mothers.setdefault(m, []).append(d)
    dying = {int(c) for c in lost.tolist() if lineage.end.get(int(c)) == "extrusion"}
    leaving = set(lost.tolist()) - dying - set(mothers)
    entering = set(new.tolist()) - {d for ds in mothers.values() for d in ds}
    sl_next = frames.rows(t_next)
    merged = {m: np.searchsorted(frames.track[sl_next], np.array(ds, np.int64)) for m, ds in mothers.items()}
    sizes = layers.sizes(t)

    ids0, xy0 = tri_t
    s0 = _State(ids0, xy0, layers.labels(t, ids0, xy0))
    sums = s0.sums(sizes)
    chain = [("start", sums)]
    # 1. cells leaving the tissue
    keep = ~np.isin(ids0, np.array(sorted(leaving), np.int64)).any(axis=1)
    s1 = s0.take(keep)
    chain.append(("border", s1.sums(sizes)))
    # 2. extruding cells to the mean of their neighbours (in this frame and the next), or out when they have none
    ghost_now, ghost_next = {}, {}
    for c in sorted(dying):
        rows = (s1.ids == c).any(axis=1)
        ring = np.setdiff1d(s1.ids[rows].ravel(), np.array(sorted(dying), np.int64))
        if len(ring) < 3:  # at the mean of two neighbours the ghost's triangles would be flat
            continue
        p_now = frames.positions(t, ring)
        p_next = frames.positions(t_next, ring, merged)
        if np.isnan(p_next).any():
            continue
        ghost_now[c], ghost_next[c] = _mean_position(p_now, box), _mean_position(p_next, box)
    out_dying = np.array(sorted(dying - set(ghost_now)), np.int64)
    s1b = s1.take(~np.isin(s1.ids, out_dying).any(axis=1))
    pos_now = frames.positions(t, s1b.ids.ravel()).reshape(-1, 3, 2)
    for c, g in ghost_now.items():
        pos_now[s1b.ids == c] = g
    xy2 = _corners(s1b.ids, pos_now, box)
    s2 = _State(s1b.ids, xy2, s1b.labels)
    s2 = s2.take(s2.area > 0)  # a ghost on its neighbours' line leaves a flat triangle: out, with the extrusion
    xy2 = s2.xy
    chain.append(("extrusion", s2.sums(sizes)))
    # 3. the continuous motion; triangles that would flip over on the way are retriangulated in step 4
    pos_next = frames.positions(t_next, s2.ids.ravel(), merged).reshape(-1, 3, 2)
    for c, g in ghost_next.items():
        pos_next[s2.ids == c] = g
    usable = ~np.isnan(pos_next).any(axis=(1, 2))
    xy3 = _corners(s2.ids, np.where(np.isnan(pos_next), 0.0, pos_next), box)
    usable &= _stays_positive(xy2, xy3)
    s2b = s2.take(usable)
    chain.append(("rearrangement", s2b.sums(sizes)))
    s3 = _State(s2b.ids, xy3[usable], s2b.labels)
    start, end = s2b.sums(sizes), s3.sums(sizes)
    change = [(_means(e) - _means(s))[:2] for s, e in zip(start, end)]
    layer_labels = [(lab, n) for lab, n in zip(s2b.labels, sizes)]
    flow, splits = integrate_flow(s2b.xy, s3.xy, layer_labels, change, tolerance) if len(s3.ids) else (None, 0)
    chain.append(("flow", end))
    # regions are fixed in space: a triangle now labelled by where it is in the next frame
    s3 = _State(s3.ids, s3.xy, layers.labels(t, s3.ids, s3.xy))
    chain.append(("advection", s3.sums(sizes)))
    # 4. the next frame's triangulation, daughters merged into their mother
    ids_n, xy_n = tri_next
    mapped = ids_n.copy()
    if mothers:  # each daughter's id replaced by its mother's
        daughters = np.array([d for ds in mothers.values() for d in ds], np.int64)
        mother_of = np.array([m for m, ds in mothers.items() for _ in ds], np.int64)
        at, found = _lookup(mapped, np.sort(daughters))
        mapped[found] = mother_of[np.argsort(daughters)][at[found]]
    good = (mapped[:, 0] != mapped[:, 1]) & (mapped[:, 1] != mapped[:, 2]) & (mapped[:, 0] != mapped[:, 2])
    good &= ~np.isin(ids_n, np.array(sorted(entering), np.int64)).any(axis=1)
    mapped = mapped[good]
    first = _first_of_each(_triple_keys(mapped))  # two triangles that become the same when daughters merge
    mapped = mapped[first]
    xy4 = xy_n[good][first]
    moved = np.isin(mapped, np.array(sorted(mothers), np.int64)).any(axis=1)
    if moved.any():  # a mother at the mean of its daughters; the other triangles as they are in the next frame
        pos4 = frames.positions(t_next, mapped[moved].ravel(), merged).reshape(-1, 3, 2)
        xy4[moved] = _corners(mapped[moved], pos4, box)
    s4 = _State(mapped, xy4, layers.labels(t, mapped, xy4))
    s4 = s4.take(s4.area > 0)
    gone, come = ~_isin_rows(s3.ids, s4.ids), ~_isin_rows(s4.ids, s3.ids)
    removed, added = s3.take(gone), s4.take(come)
    share, comp, matched = _step4_kinds(removed.ids, added.ids, dying, t1.at(t_next), K,
                                        (contacts[0], _merge_daughters(contacts[1], mothers, K)))
    n_removed = len(removed.ids)
    sums = s3.sums(sizes)
    events = []
    for k, term in enumerate(_STEP4):
        w = share[comp, k] if len(comp) else np.zeros(0)
        plus, minus = added.sums(sizes, w[n_removed:]), removed.sums(sizes, w[:n_removed])
        sums = [s + p - m for s, p, m in zip(sums, plus, minus)]
        chain.append((term, sums))
    chain[-1] = (chain[-1][0], s4.sums(sizes))  # the same, without the sums' rounding
    for c, evs in enumerate(matched):
        if not evs:
            continue
        rows_r, rows_a = np.flatnonzero(comp[:n_removed] == c), np.flatnonzero(comp[n_removed:] == c)
        dxx = (added.area[rows_a] * added.qxx[rows_a]).sum() - (removed.area[rows_r] * removed.qxx[rows_r]).sum()
        dxy = (added.area[rows_a] * added.qxy[rows_a]).sum() - (removed.area[rows_r] * removed.qxy[rows_r]).sum()
        events.extend((e, -dxx / len(evs), -dxy / len(evs)) for e in evs)
    # 5. daughters split, then the cells entering the tissue
    keep = ~np.isin(ids_n, np.array(sorted(entering), np.int64)).any(axis=1)
    s5 = _State(ids_n[keep], xy_n[keep], layers.labels(t, ids_n[keep], xy_n[keep]))
    chain.append(("division", s5.sums(sizes)))
    s6 = _State(ids_n, xy_n, layers.labels(t, ids_n, xy_n))
    chain.append(("border", s6.sums(sizes)))
    blocks = [_block(chain, flow, i, n) for i, n in enumerate(sizes)]
    # a region empty at any step has no mean elongation there: it gets no row for this interval
    complete = [np.all([sums[i][0] > 0 for _, sums in chain], axis=0) for i in range(len(sizes))]
    info = {"n_triangles": len(ids0), "n_flipped": int((~usable).sum()), "splits": splits,
            "area": [c[0] for c in end], "complete": complete}
    return blocks, events, info


def _merge_daughters(keys, mothers, K):
    """Contact keys with each daughter's id replaced by its mother's (a contact between sisters dropped)."""
    if not mothers or len(keys) == 0:
        return keys
    daughters = np.array([d for ds in mothers.values() for d in ds], np.int64)
    mother_of = np.array([m for m, ds in mothers.items() for _ in ds], np.int64)
    order = np.argsort(daughters)
    daughters, mother_of = daughters[order], mother_of[order]
    ab = np.stack(np.divmod(keys, np.int64(K)))
    at, found = _lookup(ab, daughters)
    ab = np.where(found, mother_of[at], ab)
    keep = ab[0] != ab[1]
    return _sorted_unique(pair_keys(ab[0][keep], ab[1][keep], K))


#: A triangle whose area falls below this fraction of its start within an interval is retriangulated
#: (``rearrangement``) instead of deformed: near a collapse its velocity gradient diverges, the quadrature
#: cannot follow it (closure 2e-6 of the total on the ITASC movie at 1e-9, 3e-13 from 0.02 on).
COLLAPSE = 0.05


def _stays_positive(xy0, xy1):
    """Triangles whose area stays above :data:`COLLAPSE` of its start on the straight path from ``xy0`` to ``xy1``."""
    R0, R1 = edge_matrices(xy0), edge_matrices(xy1)
    ok = det2(R0) > 0
    M = (R1 - R0) @ inv2(np.where(ok[:, None, None], R0, np.eye(2)))
    # det(I + tau M) = 1 + tau tr M + tau^2 det M on [0, 1]
    tr, dt = M[:, 0, 0] + M[:, 1, 1], det2(M)
    end = 1 + tr + dt
    with np.errstate(invalid="ignore", divide="ignore"):
        vertex = np.where(dt != 0, -tr / (2 * dt), -1.0)
    inner = (vertex > 0) & (vertex < 1)
    low = np.where(inner, 1 + vertex * tr + vertex ** 2 * dt, 1.0)
    # and not flat at the end, relative to its size (an area of rounding errors is no shape)
    flat = det2(R1) <= 1e-12 * np.einsum("nij,nij->n", R1, R1)
    return ok & (end > COLLAPSE) & (low > COLLAPSE) & ~flat


def _block(chain, flow, layer, n):
    """The budget of one layer: an array (len(DEFORMATION_COLUMNS), n) in the order of :func:`_columns`."""
    cols = {}
    first, last = _means(chain[0][1][layer]), _means(chain[-1][1][layer])
    shear = {term: np.zeros((3, n)) for term in _TERMS_OF_STEPS}
    with np.errstate(invalid="ignore"):  # a region empty at a step: no row (see _pair's "complete")
        for (_, before), (term, after) in zip(chain[:-1], chain[1:]):
            if term != "flow":
                shear[term] -= _means(after[layer]) - _means(before[layer])
    f = flow[layer] if flow is not None else np.full((12, n), np.nan)
    cols["total"] = np.array([f[0], f[1], f[2]])
    cols["cell_shape"] = last - first
    cols["corotation"] = np.array([f[3], f[4], np.zeros(n)])
    cols["nonlinear"] = np.array([f[5], f[6], np.zeros(n)])
    cols["growth_correlation"] = np.array([f[7], f[8], np.zeros(n)])
    cols["rotation_correlation"] = np.array([f[9], f[10], np.zeros(n)])
    cols.update(shear)
    parts = sum(v for k, v in cols.items() if k != "total")
    cols["closure"] = cols["total"] - parts
    out = []
    for term in DEFORMATION_TERMS:
        out.extend([cols[term][0], cols[term][1]])
        if term in ISOTROPIC_TERMS:
            out.append(cols[term][2])
    out.append(f[11])
    return np.array(out)


_TERMS_OF_STEPS = ("border", "extrusion", "rearrangement", "resampling", "advection", "t1_cycle",
                   "t1_intercalation", "t1_unresolved", "division")
