"""The deformation budget (triangle method) against exact truth: affine motions, scripted T1s, divisions, extrusions."""
import numpy as np
import pandas as pd
import pytest
from scipy import ndimage
from scipy.linalg import expm

import hexatissue as ht
from hexatissue.deformation import (_stays_positive, budget_chunks, deformation_budget, event_shear, frame_contacts,
                                    frame_triangles, pair_keys, roi_tracks)
from hexatissue.deformation.flow import integrate_flow
from hexatissue.deformation.triangles import REFERENCE_INVERSE, edge_matrices, elongation, state_tensors
from hexatissue.errors import InputError
from hexatissue.schema import DEFORMATION_TERMS, ISOTROPIC_TERMS
from hexatissue.synthetic import hexagonal_seeds, jittered_seeds, t1_movie, voronoi_labels

TOPOLOGICAL = ("t1_cycle", "t1_intercalation", "t1_unresolved", "rearrangement", "resampling", "division", "extrusion",
               "border")


def _rotation(theta):
    return np.array([[np.cos(theta), -np.sin(theta)], [np.sin(theta), np.cos(theta)]])


def _nematic(qxx, qxy):
    return np.array([[qxx, qxy], [qxy, -qxx]])


# ----------------------------------------------------------------------------
# One triangle
# ----------------------------------------------------------------------------

def test_state_tensor_factors_into_area_elongation_and_rotation():
    rng = np.random.default_rng(1)
    for _ in range(20):
        area, qxx, qxy, theta = rng.uniform(0.5, 50), *rng.uniform(-1.2, 1.2, 2), rng.uniform(-3, 3)
        S = np.sqrt(area) * expm(_nematic(qxx, qxy)) @ _rotation(theta)
        got = elongation(S)
        np.testing.assert_allclose(got, (area, qxx, qxy, theta), rtol=1e-12, atol=1e-12)


def test_equilateral_triangle_has_no_elongation_in_any_orientation_and_corner_order():
    corners = np.array([[0.0, 0.0], [2.0, 0.0], [1.0, np.sqrt(3.0)]])
    for theta in np.linspace(0, 2 * np.pi, 7):
        xy = corners @ _rotation(theta).T + 5.0
        for roll in range(3):
            area, qxx, qxy, _ = elongation(state_tensors(edge_matrices(np.roll(xy, roll, axis=0)[None])))
            assert abs(qxx[0]) < 1e-12 and abs(qxy[0]) < 1e-12
            assert area[0] == pytest.approx(np.sqrt(3.0))


def test_stretched_triangle_elongation_is_the_log_stretch():
    eps = 0.3
    equilateral = np.linalg.inv(REFERENCE_INVERSE).T  # the reference's corners r1, r2 as rows
    xy = np.vstack([[0.0, 0.0], equilateral]) @ np.diag([np.exp(eps), np.exp(-eps)])
    _, qxx, qxy, _ = elongation(state_tensors(edge_matrices(xy[None])))
    assert qxx[0] == pytest.approx(eps, abs=1e-12) and abs(qxy[0]) < 1e-12


# ----------------------------------------------------------------------------
# The continuous part
# ----------------------------------------------------------------------------

def _random_triangles(n, seed=0):
    rng = np.random.default_rng(seed)
    xy = rng.uniform(0, 20, (n, 3, 2))
    R = edge_matrices(xy)
    clockwise = R[:, 0, 0] * R[:, 1, 1] - R[:, 0, 1] * R[:, 1, 0] < 0
    xy[clockwise] = xy[clockwise][:, [0, 2, 1]]
    return xy


def _mean_q(xy):
    """Mean elongation (xx, xy) and log area of triangles: what integrate_flow's identities end on."""
    area, qxx, qxy, _ = elongation(state_tensors(edge_matrices(xy)))
    return np.array([[np.sum(area * qxx) / area.sum()], [np.sum(area * qxy) / area.sum()], [np.log(area.sum())]])


@pytest.mark.parametrize("L", [np.array([[0.02, 0.01], [0.01, -0.02]]),  # pure shear
                               np.array([[0.03, -0.05], [0.09, 0.01]])])  # shear + rotation + dilation
def test_affine_motion_total_is_the_imposed_gradient_exactly(L):
    xy0 = _random_triangles(200)
    xy1 = xy0 @ expm(L).T
    out, _ = integrate_flow(xy0, xy1, [(np.zeros(200, int), 1)], [(_mean_q(xy1) - _mean_q(xy0))[:2]])
    terms = dict(zip(("total_xx", "total_xy", "total_iso", "corotation_xx", "corotation_xy", "nonlinear_xx",
                      "nonlinear_xy", "growth_xx", "growth_xy", "rot_xx", "rot_xy", "rotation"), out[0][:, 0]))
    assert terms["total_xx"] == pytest.approx(0.5 * (L[0, 0] - L[1, 1]), abs=1e-12)
    assert terms["total_xy"] == pytest.approx(0.5 * (L[0, 1] + L[1, 0]), abs=1e-12)
    assert terms["total_iso"] == pytest.approx(np.trace(L), abs=1e-12)
    assert terms["rotation"] == pytest.approx(0.5 * (L[1, 0] - L[0, 1]), abs=1e-12)
    # every triangle moves alike: no correlation between the triangles' motion and their elongation
    for name in ("growth_xx", "growth_xy", "rot_xx", "rot_xy"):
        assert abs(terms[name]) < 1e-12


def test_identity_closes_for_any_motion():
    rng = np.random.default_rng(3)
    xy0 = _random_triangles(300, seed=2)
    xy1 = xy0 + rng.normal(0, 0.4, xy0.shape)  # each corner on its own: rotation and growth vary
    keep = _stays_positive(xy0, xy1)  # a triangle flipping over on the way has no shape half-way
    xy0, xy1 = xy0[keep], xy1[keep]
    labels = rng.integers(0, 4, len(xy0))
    change = [_mean_q(xy1) - _mean_q(xy0)]
    by_region = [np.hstack([_mean_q(xy1[labels == r]) - _mean_q(xy0[labels == r]) for r in range(4)])]
    for layers, ch in (([(np.zeros(len(xy0), int), 1)], change), ([(labels, 4)], by_region)):
        out, _ = integrate_flow(xy0, xy1, layers, [c[:2] for c in ch])
        t = out[0]
        closure = t[:2] - (ch[0][:2] + t[3:5] + t[5:7] + t[7:9] + t[9:11])
        assert np.abs(closure).max() <= 1e-10 * np.abs(t[:2]).max()
        assert np.abs(t[2] - ch[0][2]).max() <= 1e-10 * np.abs(t[:3]).max()  # growth: the log of the area ratio
        assert np.abs(t[7:11]).max() > 1e-4  # the correlation terms are there


# ----------------------------------------------------------------------------
# Movies
# ----------------------------------------------------------------------------

def _warped_movie(F_of_t, n_frames, shape=(360, 360), spacing=20, seed=4):
    """A Voronoi label image mapped by affine maps F(t) about the image centre: no topology change.

    The seeds are a slightly jittered hexagonal lattice, so no junction is
    short enough for the pixels of the warped image to flip it; the patch
    of cells sits on background, so none enters or leaves the image.
    """
    rng = np.random.default_rng(seed)
    seeds, _ = hexagonal_seeds(shape[1] // spacing, 2 * int(shape[0] // (spacing * 1.732)), spacing, spacing * 0.866)
    seeds = seeds + rng.uniform(-0.1, 0.1, seeds.shape) * spacing
    base = voronoi_labels(seeds, shape)
    # a patch of cells on background, well inside the image: no cell enters or leaves the field of view
    outside = np.flatnonzero(np.abs(seeds - np.array(shape[::-1]) / 2.0).max(axis=1) > 0.35 * min(shape)) + 1
    base[np.isin(base, outside)] = 0
    centre = (np.array(shape) - 1) / 2.0
    frames = []
    for t in range(n_frames):
        F = F_of_t(t)  # in (x, y)
        Frc = F[::-1, ::-1]  # in (row, col)
        inv = np.linalg.inv(Frc)
        frames.append(ndimage.affine_transform(base, inv, offset=centre - inv @ centre, order=0, mode="constant"))
    return np.stack(frames)


def _budget(movie, box=None, track=None, **kwargs):
    out = ht.analyze(movie, box=box, progress=False, track=track, deformation=ht.DeformationOptions(enabled=True, **kwargs))
    return out, out.deformation


def _closure_ok(d):
    scale = d[["total_xx", "total_xy"]].abs().to_numpy().max() + 1e-3
    assert d[["closure_xx", "closure_xy", "closure_iso"]].abs().to_numpy().max() <= 1e-10 * scale


@pytest.mark.parametrize("L", [np.array([[0.01, 0.004], [0.004, -0.01]]),
                               np.array([[0.012, -0.012], [0.016, 0.004]])])
def test_affine_movie_total_is_the_imposed_rate_and_all_in_cell_shape(L):
    movie, d = _budget(_warped_movie(lambda t: expm(t * L), 5))
    tissue = d[d["region"] == "tissue"]
    assert len(tissue) == 4
    shear = np.array([0.5 * (L[0, 0] - L[1, 1]), 0.5 * (L[0, 1] + L[1, 0])])
    got = tissue[["total_xx", "total_xy"]].to_numpy().mean(axis=0)
    assert np.hypot(*(got - shear)) <= 0.01 * np.hypot(*shear)
    assert tissue["total_iso"].mean() == pytest.approx(np.trace(L), abs=0.01 * np.hypot(*shear))
    assert tissue["rotation"].mean() == pytest.approx(0.5 * (L[1, 0] - L[0, 1]), abs=0.01 * np.hypot(*shear))
    for term in TOPOLOGICAL:  # zero up to the rounding of sums over a thousand triangles
        assert tissue[[f"{term}_xx", f"{term}_xy"]].abs().to_numpy().max() < 1e-14, term
    # the cell shape change (with its corotational parts) carries the shear; the area change the growth
    shape = tissue[["cell_shape_xx", "cell_shape_xy"]].to_numpy() + tissue[["corotation_xx", "corotation_xy"]].to_numpy() \
        + tissue[["nonlinear_xx", "nonlinear_xy"]].to_numpy()
    assert np.hypot(*(shape.mean(axis=0) - shear)) <= 0.05 * np.hypot(*shear)
    np.testing.assert_allclose(tissue["cell_shape_iso"], tissue["total_iso"], atol=1e-12)
    _closure_ok(d)


@pytest.fixture(scope="module")
def scripted():
    """The scripted T1 movie (periodic) analysed once with the budget, grid regions included."""
    m = t1_movie(periodic=True)
    movie, d = _budget(m.labels, m.box)
    return m, movie, d


def _again(movie, box, t1=None, **kwargs):
    """The budget of an analysed movie's tables again, with other options."""
    return deformation_budget(movie.cells, movie.vertices, movie.cell_vertices, movie.lineage,
                              movie.events if t1 is None else t1, box=box, **kwargs)[0]


def test_scripted_t1_movie_puts_each_jump_on_its_event_and_kind(scripted):
    m, movie, d = scripted
    _closure_ok(d)
    tissue = d[d["region"] == "tissue"].set_index("frame")
    # the triangles tile the periodic box, which does not deform: no net shear or growth, exactly
    assert tissue[["total_xx", "total_xy", "total_iso"]].abs().to_numpy().max() < 1e-12
    events = movie.events.set_index("event")
    expected = {}
    for e in events.itertuples():
        term = {"cycle": "t1_cycle", "intercalation": "t1_intercalation", "unresolved": "t1_unresolved"}[e.kind]
        expected.setdefault(e.frame_gain - 1, set()).add(term)
        if e.kind == "cycle":
            expected.setdefault(int(e.frame_end) - 1, set()).add(term)
    for t, row in tissue.iterrows():
        jumps = {term for term in TOPOLOGICAL if abs(row[f"{term}_xx"]) + abs(row[f"{term}_xy"]) > 1e-12}
        assert jumps == expected.get(t, set()), t
    # a cycle's jump is undone; an intercalation's stays
    assert (events.loc[events["kind"] == "cycle", "shear_xx"].abs() < 0.05 * events["shear_xx"].abs().max()).all()
    assert (events.loc[events["kind"] == "intercalation", "shear_xx"].abs() > 100).all()
    # each event's share, over the tissue's area, is the T1 term of its frame
    for e in events.itertuples():
        if e.kind == "intercalation":
            row = tissue.loc[e.frame_gain - 1]
            assert e.shear_xx / row["area"] == pytest.approx(row["t1_intercalation_xx"], rel=0.02)


def _seed_movie(frames, shape):
    """Label images of ``(seeds, ids)`` per frame: the Voronoi cell of ``seeds[k]`` is label ``ids[k]``."""
    return np.stack([np.r_[0, ids][voronoi_labels(seeds, shape)] for seeds, ids in frames])


def test_scripted_division_is_the_division_term():
    shape = (240, 240)
    seeds = jittered_seeds(shape, 20, seed=5)
    mother = int(np.argmin(np.hypot(*(seeds - 120.0).T)))
    ids = np.arange(1, len(seeds) + 1)
    axis = np.array([6.0, 2.0])
    split = np.vstack([np.delete(seeds, mother, axis=0), seeds[mother] + axis, seeds[mother] - axis])
    daughters = np.r_[np.delete(ids, mother), len(ids) + 1, len(ids) + 2]
    labels = _seed_movie([(seeds, ids)] * 3 + [(split, daughters)] * 3, shape)
    movie, d = _budget(labels, grid=False)
    assert (movie.lineage["begin"] == "division").sum() == 2
    _closure_ok(d)
    tissue = d[d["region"] == "tissue"].set_index("frame")
    assert abs(tissue.loc[2, "division_xx"]) + abs(tissue.loc[2, "division_xy"]) > 1e-4
    assert tissue.loc[2, "division_iso"] == pytest.approx(np.log(tissue.loc[2, "n_triangles"] + 2)
                                                           - np.log(tissue.loc[2, "n_triangles"]), rel=0.2)
    for t in (0, 1, 3, 4):
        assert tissue.loc[t, ["division_xx", "division_xy", "division_iso"]].abs().max() < 1e-14
    # nothing moved: no flow
    assert tissue[["total_xx", "total_xy", "total_iso"]].abs().to_numpy().max() < 1e-12


def test_scripted_extrusion_is_the_extrusion_term():
    shape = (240, 240)
    seeds = jittered_seeds(shape, 20, seed=6)
    gone = int(np.argmin(np.hypot(*(seeds - 120.0).T)))
    ids = np.arange(1, len(seeds) + 1)
    frames = [(seeds, ids)] * 3 + [(np.delete(seeds, gone, axis=0), np.delete(ids, gone))] * 3
    movie, d = _budget(_seed_movie(frames, shape), grid=False)
    assert (movie.lineage["end"] == "extrusion").sum() == 1
    _closure_ok(d)
    tissue = d[d["region"] == "tissue"].set_index("frame")
    assert abs(tissue.loc[2, "extrusion_xx"]) + abs(tissue.loc[2, "extrusion_xy"]) > 1e-5
    assert tissue.loc[2, "extrusion_iso"] < 0  # fewer cells on the same area: larger mean cell
    others = [f"{t}_{c}" for t in TOPOLOGICAL if t != "extrusion" for c in ("xx", "xy")]
    assert tissue.loc[2, others].abs().max() < 1e-12


def test_regions_of_interest_follow_their_cells_and_the_grid_closes(scripted):
    m, movie, _ = scripted
    roi = np.zeros(m.labels.shape[1:], np.int32)
    roi[:, : roi.shape[1] // 2] = 1
    roi[:, roi.shape[1] // 2:] = 2
    d = _again(movie, m.box, grid=movie.grid, roi=roi)
    _closure_ok(d)
    rois = d[d["region"] == "roi"]
    assert set(rois["region_id"]) == {1, 2}
    assert (rois["advection_xx"] == 0).all()  # regions made of cells move with them
    grid = d[d["region"] == "grid"]
    assert len(grid) and set(grid["region_id"]) <= set(movie.grid["node"])
    # one region holding every cell is the tissue
    whole = _again(movie, m.box, roi=np.ones_like(roi))
    values = [c for c in whole.columns if c not in ("region", "region_id", "n_triangles", "n_flipped")]
    np.testing.assert_allclose(whole.loc[whole["region"] == "roi", values].to_numpy(),
                               whole.loc[whole["region"] == "tissue", values].to_numpy(), rtol=1e-12, atol=1e-15)
    members = roi_tracks(movie.cells, movie.lineage, roi)
    first = movie.cells[movie.cells["frame"] == 0]
    assert set(members) == set(first["track"]) and set(members.values()) == {1, 2}


def test_neighbour_events_name_the_kinds_too(scripted):
    m, movie, _ = scripted
    quartets = _again(movie, m.box)
    per_cell = _again(movie, m.box, movie.neighbour_events, t1_events="neighbours")
    cols = [f"{t}_{c}" for t in ("t1_cycle", "t1_intercalation") for c in ("xx", "xy")]
    np.testing.assert_allclose(per_cell[cols].to_numpy(), quartets[cols].to_numpy(), atol=1e-12)


def test_no_tracks_is_refused_clearly(scripted):
    m = scripted[0]
    with pytest.raises(InputError, match="needs cell tracks"):
        ht.analyze(m.labels, progress=False, track=ht.TrackOptions(mode="off"),
                   deformation=ht.DeformationOptions(enabled=True))
    with pytest.raises(InputError, match="t1_events"):
        ht.DeformationOptions(t1_events="quartet")
    with pytest.raises(InputError, match="roi"):
        roi_tracks(pd.DataFrame({"frame": [0], "track": [1], "x": [0.0], "y": [0.0]}),
                   pd.DataFrame({"track": [1], "parent": [0], "frame_start": [0]}), np.zeros((4, 4), float))
    # regions drawn as -1 (some tools' convention), or none under any cell: refused, not an empty budget
    one_cell = pd.DataFrame({"frame": [0], "track": [1], "x": [1.0], "y": [1.0]})
    no_lineage = pd.DataFrame({"track": [1], "parent": [0], "frame_start": [0]})
    with pytest.raises(InputError, match=r"roi has negative labels \(-1\)"):
        roi_tracks(one_cell, no_lineage, np.full((4, 4), -1))
    away = np.zeros((4, 4), int)
    away[3, 3] = 2
    with pytest.raises(InputError, match="no cell of frame 0 has its centre in a region"):
        roi_tracks(one_cell, no_lineage, away)


def test_four_fold_vertex_keeps_the_previous_diagonal():
    # four cells around one vertex: the square's two diagonals are equally short
    track = np.array([1, 2, 3, 4])
    xy = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]])
    vertices = pd.DataFrame({"vertex": [7], "x": [5.0], "y": [5.0], "is_border": [False]})
    cv = pd.DataFrame({"cell": track, "vertex": [7] * 4})
    for diagonal in ((1, 3), (2, 4)):
        previous = pair_keys(np.array([diagonal[0]]), np.array([diagonal[1]]), 5)
        ids, _ = frame_triangles(track, xy, track, vertices, cv, previous=previous, K=5)
        edges = {tuple(sorted(p)) for tri in ids.tolist() for p in ((tri[0], tri[1]), (tri[1], tri[2]), (tri[0], tri[2]))}
        assert diagonal in edges and len(ids) == 2


def test_a_ring_the_past_says_nothing_about_takes_the_contacts_it_resolves_into():
    """A four-fold vertex without a previous diagonal takes the following one; a five-fold rosette keeps the
    previous fan, else takes the following one, else fans from its smallest id."""
    track = np.array([1, 2, 3, 4])
    xy = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]])
    vertices = pd.DataFrame({"vertex": [7], "x": [5.0], "y": [5.0], "is_border": [False]})
    cv = pd.DataFrame({"cell": track, "vertex": [7] * 4})

    def edges(ids):
        return {tuple(sorted(p)) for tri in ids.tolist() for p in ((tri[0], tri[1]), (tri[1], tri[2]), (tri[0], tri[2]))}

    for diagonal in ((1, 3), (2, 4)):
        later = pair_keys(np.array([diagonal[0]]), np.array([diagonal[1]]), 5)
        ids, _ = frame_triangles(track, xy, track, vertices, cv, K=5, following=later)
        assert diagonal in edges(ids) and len(ids) == 2
        # the past wins over the future
        other = (2, 4) if diagonal == (1, 3) else (1, 3)
        before = pair_keys(np.array([other[0]]), np.array([other[1]]), 5)
        ids, _ = frame_triangles(track, xy, track, vertices, cv, previous=before, K=5, following=later)
        assert other in edges(ids) and diagonal not in edges(ids)
    # a regular pentagon of cells around one vertex
    angle = 2 * np.pi * np.arange(5) / 5
    track5 = np.array([5, 3, 9, 1, 7])  # counter-clockwise; smallest id 1 at position 3
    xy5 = 10 * np.c_[np.cos(angle), np.sin(angle)]
    v5 = pd.DataFrame({"vertex": [0], "x": [0.0], "y": [0.0], "is_border": [False]})
    cv5 = pd.DataFrame({"cell": track5, "vertex": [0] * 5})
    ids, _ = frame_triangles(track5, xy5, track5, v5, cv5, K=10)
    assert len(ids) == 3 and all(1 in tri for tri in ids.tolist())  # the fan from the smallest id
    fan_from_9 = pair_keys(np.array([9, 9]), np.array([5, 7]), 10)
    for previous, following in ((fan_from_9, None), (None, fan_from_9)):
        ids, _ = frame_triangles(track5, xy5, track5, v5, cv5, previous=previous, K=10, following=following)
        assert len(ids) == 3 and all(9 in tri for tri in ids.tolist())


def test_columns_match_the_schema(scripted):
    d = scripted[2]
    expected = ["frame", "region", "region_id", "area"]
    for term in DEFORMATION_TERMS:
        expected += [f"{term}_xx", f"{term}_xy"] + ([f"{term}_iso"] if term in ISOTROPIC_TERMS else [])
    assert list(d.columns) == expected + ["rotation", "n_triangles", "n_flipped", "tracking_doubtful"]  # the stage's
    assert not d["tracking_doubtful"].any()  # the scripted T1 movie's ids are its tracks: nothing doubtful
    with pytest.raises(InputError, match="t1_events"):
        deformation_budget(None, None, None, None, t1_events="pairs")


def test_kernels_match_their_numpy_references():
    from hexatissue.deformation import _kernels, _reference

    rng = np.random.default_rng(7)
    xy0 = _random_triangles(400, seed=8)
    xy1 = xy0 + rng.normal(0, 0.3, xy0.shape)
    keep = _stays_positive(xy0, xy1)
    xy0, xy1 = xy0[keep], xy1[keep]
    R0, R1 = edge_matrices(xy0), edge_matrices(xy1)
    M = (R1 - R0) @ np.linalg.inv(R0)
    S0 = state_tensors(R0)
    A0 = np.linalg.det(S0)
    labels = np.stack([np.zeros(len(M), np.int64), rng.integers(-1, 5, len(M))])
    args = (M, S0, A0, np.linspace(0.05, 0.95, 6), labels, np.array([0, 1]), 6)
    np.testing.assert_allclose(_kernels.flow_sums(*args), _reference.flow_sums(*args), rtol=1e-10, atol=1e-12)
    from hexatissue.deformation.triangles import REFERENCE_INVERSE

    for got, expected in zip(_kernels.triangle_shapes(xy0, REFERENCE_INVERSE),
                             _reference.triangle_shapes(xy0, REFERENCE_INVERSE)):
        np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-14)


def test_bad_regions_of_interest_are_refused_before_the_analysis(tmp_path, scripted):
    with pytest.raises(InputError, match="roi .*an existing file"):
        ht.DeformationOptions(enabled=True, roi=tmp_path / "absent.tif")
    with pytest.raises(InputError, match="roi .*a .npy, .tif or .png"):
        ht.DeformationOptions(enabled=True, roi="regions.jpg")
    with pytest.raises(InputError, match="roi .*2-D label image"):
        ht.DeformationOptions(enabled=True, roi=np.zeros((4, 4), float))
    m = scripted[0]
    with pytest.raises(InputError, match=r"roi has shape \(3, 3\)"):
        _budget(m.labels[:3], m.box, roi=np.ones((3, 3), int))


def test_triangle_keys_name_the_cell_set_for_small_and_huge_ids():
    from hexatissue.deformation import _triple_keys

    for base in (0, 10 ** 12):  # huge ids take the ranked keys
        a = np.array([[1, 2, 3], [3, 1, 2], [1, 2, 4], [2, 4, 1]]) + base
        b = np.array([[2, 3, 1], [4, 3, 2]]) + base
        ka, kb = _triple_keys(a, b)
        assert ka[0] == ka[1] == kb[0] and ka[2] == ka[3] and len({ka[0], ka[2], kb[1]}) == 3


def test_a_movie_without_t1s_writes_an_events_table_that_reads_back(tmp_path):
    """Real data (EpiCure 013: no T1): the empty events table got object columns from the budget's merge."""
    movie, d = _budget(_warped_movie(lambda t: expm(t * np.diag([0.01, -0.01])), 3), grid=False)
    assert len(movie.events) == 0 and movie.events["event"].dtype == np.int64
    assert movie.events["shear_xx"].dtype == float
    movie.write(tmp_path / "res")
    back = ht.read_results(tmp_path / "res")
    assert list(back.events.columns) == list(movie.events.columns) and len(back.deformation) == len(d)


def test_an_extruded_cell_with_two_neighbours_left_makes_no_flat_triangle():
    """Real data (Skeletor pupal abdomen): a ghost at the mean of two neighbours is on their line."""
    from hexatissue.deformation import _stays_positive

    xy0 = np.array([[[0.0, 0.0], [10.0, 0.0], [5.0, 8.0]]])
    flat = np.array([[[0.0, 0.0], [10.0, 0.0], [5.0, 0.0]]])  # the third corner on the others' line
    assert _stays_positive(xy0, xy0) and not _stays_positive(xy0, flat)[0]


def test_real_movies_give_finite_budgets_that_close(real_data, tmp_path):
    """The user trial's failures: Skeletor (flat ghost triangles: NaN terms) and EpiCure 013 (no T1: events
    table unreadable); each budget is finite, closes, and its folder reads back."""
    from pathlib import Path

    from .conftest import real_subdir

    sample = Path(__file__).resolve().parents[1] / "hexatissue" / "sample_data" / "epicure_notum" / "013_crop_labels.tif"
    for name, source in (("epicure", sample), ("skeletor", real_subdir(real_data, "skeletor_pupal_abdomen")
                                               / "Final_Skeleton")):
        with pytest.warns(ht.HexatissueWarning):
            movie = ht.analyze(source, progress=False, workers=1, deformation=ht.DeformationOptions(enabled=True))
        d = movie.deformation
        assert len(d) and np.isfinite(d.drop(columns=["region"]).to_numpy(float)).all(), name
        _closure_ok(d)
        movie.write(tmp_path / name)
        assert len(ht.read_results(tmp_path / name).deformation) == len(d)


def test_the_itasc_movie_closes_with_near_collapsing_triangles_retriangulated(real_data):
    """User trial: on the ITASC islands a triangle nearly collapsing within a frame left a closure of 2e-6 of
    the total (the quadrature cannot follow a diverging gradient); such triangles are now retriangulated."""
    from .conftest import real_subdir

    path = real_subdir(real_data, "itasc_micropattern") / "pos00" / "cell_labels.tif"
    with pytest.warns(ht.HexatissueWarning):
        movie = ht.analyze(path, progress=False, workers=1, deformation=ht.DeformationOptions(enabled=True))
    _closure_ok(movie.deformation)
    assert movie.deformation["n_flipped"].max() > 0


def test_a_nearly_motionless_interval_needs_no_refinement():
    """The benchmark movie's first interval: rounding alone (1e-15) was refined to 1,024 sub-intervals."""
    rng = np.random.default_rng(9)
    xy0 = _random_triangles(3000, seed=10)
    xy1 = xy0 + rng.normal(0, 1e-7, xy0.shape)
    keep = _stays_positive(xy0, xy1)
    out, splits = integrate_flow(xy0[keep], xy1[keep], [(np.zeros(int(keep.sum()), int), 1)],
                                 [(_mean_q(xy1[keep]) - _mean_q(xy0[keep]))[:2]])
    assert splits == 1


# ----------------------------------------------------------------------------
# Retriangulations that change no contact: resampling, not rearrangement
# ----------------------------------------------------------------------------

def test_frame_contacts_are_the_pairs_of_cells_sharing_a_vertex():
    """Against a plain loop over the vertices: a three-fold vertex, a four-fold one (both diagonals), a label
    the cells table lacks (left out) and track ids that differ from the labels."""
    cv = pd.DataFrame({"vertex": [0, 0, 0, 1, 1, 1, 1, 2, 2, 2], "cell": [1, 2, 3, 2, 3, 4, 5, 5, 6, 9]})
    cell, track = np.array([1, 2, 3, 4, 5, 6]), np.array([11, 12, 13, 14, 15, 16])
    K = 20
    want = set()
    tr = dict(zip(cell.tolist(), track.tolist()))
    for _, g in cv.groupby("vertex"):
        ids = [tr[c] for c in g["cell"] if c in tr]
        want |= {pair_keys(np.int64(a), np.int64(b), K) for i, a in enumerate(ids) for b in ids[i + 1:]}
    got = frame_contacts(track, cell, cv, K)
    assert got.tolist() == sorted(want)
    assert pair_keys(np.int64(12), np.int64(14), K) in got  # the four-fold vertex's diagonal 2-4
    assert len(frame_contacts(track[:0], cell[:0], cv, K)) == 0


def _voronoi_patch_warp(n_frames=5):
    """300 random seeds (a patch on background) pulled through exp(t L): no cell changes neighbours, but vertices
    a few px apart merge and part under the pixel resampling."""
    rng = np.random.default_rng(0)
    shape = (360, 360)
    seeds = rng.uniform(30, 330, (300, 2))
    base = voronoi_labels(seeds, shape)
    outside = np.flatnonzero(np.abs(seeds - np.array(shape[::-1]) / 2.0).max(axis=1) > 0.3 * min(shape)) + 1
    base[np.isin(base, outside)] = 0
    L = np.array([[0.01, 0.004], [0.004, -0.01]])
    centre = (np.array(shape) - 1) / 2.0
    frames = []
    for t in range(n_frames):
        inv = np.linalg.inv(expm(t * L)[::-1, ::-1])
        frames.append(ndimage.affine_transform(base, inv, offset=centre - inv @ centre, order=0, mode="constant"))
    return np.stack(frames)


def test_a_pure_warp_puts_its_retriangulations_in_resampling_not_rearrangement():
    """Exact truth: no contact changes, so no T1 and no rearrangement; the vertices that merge with the
    tissue's edge vertices still retriangulate, and that goes to ``resampling``; the budget still closes."""
    movie, d = _budget(_voronoi_patch_warp())
    tissue = d[d["region"] == "tissue"]
    assert len(movie.events) == 0
    for term in ("t1_cycle", "t1_intercalation", "t1_unresolved", "rearrangement"):
        assert tissue[[f"{term}_xx", f"{term}_xy", f"{term}_iso"]].abs().to_numpy().max() < 1e-14, term
    assert tissue[["resampling_xx", "resampling_xy"]].abs().to_numpy().max() > 1e-4  # the movie has some
    _closure_ok(d)


def test_the_scripted_t1s_are_not_resampling(scripted):
    """Every retriangulation of the scripted T1 movie changes a contact: none is resampling."""
    _, _, d = scripted
    assert d[["resampling_xx", "resampling_xy", "resampling_iso"]].abs().to_numpy().max() < 1e-14


# ----------------------------------------------------------------------------
# A chunk of frames at a time
# ----------------------------------------------------------------------------

def _reader(movie, grid=True):
    """``read(first, last)`` of :func:`budget_chunks` over an analysed movie's tables."""
    names = ("cells", "vertices", "cell_vertices") + (("grid",) if grid else ())

    def read(first, last):
        out = {}
        for name in names:
            frame = movie.tables[name]["frame"].to_numpy()
            out[name] = movie.tables[name][(frame >= first) & (frame <= last)].reset_index(drop=True)
        return out
    return read


def _by_chunks(movie, size, box=None, grid=True, **kwargs):
    """The budget of ``movie`` read ``size`` frames at a time: the table and the events' shear."""
    spans = [(a, min(a + size - 1, movie.n_frames - 1)) for a in range(0, movie.n_frames, size)]
    chunks = list(budget_chunks(_reader(movie, grid), spans, movie.lineage, movie.events, box=box, grid=grid,
                                **kwargs))
    assert [span for span, _, _ in chunks] == spans
    return (pd.concat([table for _, table, _ in chunks if len(table)], ignore_index=True),
            event_shear([share for _, _, share in chunks]))


def test_the_budget_by_chunks_equals_the_whole_movie_with_t1s_and_four_fold_vertices_across_chunks(scripted):
    """The scripted T1s and the four-fold vertices held over frames 12-17, 20-24 and 29-30 fall across the
    chunks' borders; the regions of interest and the grid's too."""
    m, movie, _ = scripted
    roi = np.zeros(m.labels.shape[1:], np.int32)
    roi[:, : roi.shape[1] // 2] = 1
    whole, shear = deformation_budget(movie.cells, movie.vertices, movie.cell_vertices, movie.lineage, movie.events,
                                      box=m.box, grid=movie.grid, roi=roi)
    assert (whole["region"] == "grid").any() and (whole["region"] == "roi").any() and len(shear) == len(movie.events)
    for size in (1, 5):  # every interval across a border; the held four-fold vertices of 12-17 and 29-30 too
        table, chunked_shear = _by_chunks(movie, size, m.box, roi=roi)
        pd.testing.assert_frame_equal(table, whole, check_exact=True)
        pd.testing.assert_frame_equal(chunked_shear, shear, check_exact=True)


def test_the_backward_pass_keeps_only_what_the_rings_ask_about(scripted, monkeypatch):
    """The keys kept for the forward pass (the diagonals of the rings of four or more cells) give the same budget
    as the later triangulations kept whole: each four-fold vertex keeps the one diagonal it resolves into."""
    from hexatissue.deformation import budget

    m, movie, d = scripted
    K = int(movie.cells["track"].max()) + 1
    later, total = budget._resolved_into(_reader(movie), [(0, movie.n_frames - 1)], K, m.box)
    assert total == movie.n_frames and set(later) == {12, 13, 14, 15, 16, 17, 20, 21, 22, 23, 24, 29, 30}
    assert all(len(keys) == 1 + (t in (22, 23, 24)) for t, keys in later.items())  # two four-fold vertices in 22-24
    # every key of the next frame's triangulation kept: the budget is the same
    monkeypatch.setattr(budget, "in_sorted", lambda values, keys: np.ones(len(values), bool))
    kept_whole = _again(movie, m.box, grid=movie.grid).drop(columns="tracking_doubtful", errors="ignore")
    pd.testing.assert_frame_equal(kept_whole, d.drop(columns="tracking_doubtful"), check_exact=True)


def test_the_budget_by_chunks_equals_the_whole_movie_with_a_division_and_an_extrusion():
    shape = (240, 240)
    seeds = jittered_seeds(shape, 20, seed=5)
    ids = np.arange(1, len(seeds) + 1)
    mother, gone = np.argsort(np.hypot(*(seeds - 120.0).T))[[0, 5]]
    axis = np.array([6.0, 2.0])
    split = np.vstack([np.delete(seeds, mother, axis=0), seeds[mother] + axis, seeds[mother] - axis])
    after = np.r_[np.delete(ids, mother), len(ids) + 1, len(ids) + 2]
    kept = after != ids[gone]
    frames = [(seeds, ids)] * 2 + [(split, after)] * 2 + [(split[kept], after[kept])] * 2
    movie, d = _budget(_seed_movie(frames, shape), grid=False)
    assert (movie.lineage["end"] == "division").sum() == 1 and (movie.lineage["end"] == "extrusion").sum() == 1
    tissue = d[d["region"] == "tissue"].set_index("frame")
    assert tissue.loc[1, "division_iso"] > 0 and tissue.loc[3, "extrusion_iso"] < 0
    for size in (1, 2, 4):  # the division (interval 1-2) and the extrusion (3-4) across a border or inside a chunk
        table, _ = _by_chunks(movie, size, grid=False)
        pd.testing.assert_frame_equal(table, d.drop(columns="tracking_doubtful"), check_exact=True)


def test_budget_chunks_refuses_spans_out_of_order_and_tracks_missing_from_the_lineage(scripted):
    m, movie, _ = scripted
    with pytest.raises(InputError, match="spans must be"):
        list(budget_chunks(_reader(movie), [(0, 5), (5, 9)], movie.lineage, box=m.box))
    with pytest.raises(InputError, match="the lineage must list every track"):
        list(budget_chunks(_reader(movie, grid=False), [(0, 35)], movie.lineage[movie.lineage["track"] < movie.cells["track"].max()],
                           box=m.box))
    with pytest.raises(InputError, match="roi_frame 40 has no cells; the movie's frames are 0..35"):
        list(budget_chunks(_reader(movie, grid=False), [(0, 17), (18, 35)], movie.lineage, box=m.box,
                           roi=np.ones(m.labels.shape[1:], int), roi_frame=40))
