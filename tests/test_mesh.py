"""Junction network from label images against exact synthetic truth."""
import warnings

import numpy as np
import pandas as pd
import pytest
from scipy.spatial import cKDTree

from hexatissue import Box, HexatissueWarning, InputError, mesh_from_labels, shape_order
from hexatissue.mesh import _kernels as K
from hexatissue.mesh.labels import detect_kind
from hexatissue.synthetic import (
    draw_membranes,
    hexagonal_seeds,
    jittered_seeds,
    square_labels,
    voronoi_labels,
    voronoi_truth,
)

SHAPE = (203, 310)  # non-square on purpose



def with_order(frame, p=(6, 2)):
    """The mesh's geometry plus the order stage's shape functions (the mesh gives geometry only)."""
    return shape_order(frame, p=p)

def pairs_of(frame):
    e = frame.edges
    return set(zip(e["cell_a"], e["cell_b"]))


def vertex_errors(frame, truth, periodic, shape=SHAPE):
    """Distance from each true vertex to the nearest found vertex, and whether it is isolated (>= 3 px from others)."""
    boxsize = [shape[1], shape[0]] if periodic else None
    d, _ = cKDTree(frame.vertices[["x", "y"]].to_numpy(), boxsize=boxsize).query(truth)
    nearest_other = cKDTree(truth, boxsize=boxsize).query(truth, k=2)[0][:, 1]
    return d, nearest_other >= 3


@pytest.fixture(scope="module", params=[False, True], ids=["open", "periodic"])
def voronoi(request):
    periodic = request.param
    seeds = jittered_seeds(SHAPE, 16, seed=7)
    pairs, vertices = voronoi_truth(seeds, SHAPE, periodic)
    return dict(seeds=seeds, periodic=periodic, pairs=pairs, vertices=vertices,
                box=Box.from_shape(SHAPE) if periodic else None)


def voronoi_inputs(v):
    s, per = v["seeds"], v["periodic"]
    touching = voronoi_labels(s, SHAPE, per)
    return {
        "touching": touching,
        "membrane 1 px (centred)": voronoi_labels(s, SHAPE, per, membrane=1.0),
        "membrane 2 px": draw_membranes(touching, 2, per),
    }


@pytest.mark.parametrize("variant", ["touching", "membrane 1 px (centred)", "membrane 2 px"])
def test_voronoi_network_matches_truth(voronoi, variant):
    labels = voronoi_inputs(voronoi)[variant]
    frame = mesh_from_labels(labels, box=voronoi["box"])
    found = pairs_of(frame)
    truth = voronoi["pairs"]
    long_enough = {k for k, length in truth.items() if length >= 3}
    assert long_enough <= found, f"missing neighbours {sorted(long_enough - found)[:5]}"
    cell_pairs = {k for k in found if k[0] != 0}
    assert cell_pairs <= set(truth), f"spurious neighbours {sorted(cell_pairs - set(truth))[:5]}"
    d, isolated = vertex_errors(frame, voronoi["vertices"], voronoi["periodic"])
    assert d[isolated].max() < 1.0
    assert np.median(d) < 0.5


def test_voronoi_one_sided_membrane(voronoi):
    """A 1-px membrane drawn on one side of each true ridge shifts junctions by 0.5 px: topology stays exact."""
    labels = draw_membranes(voronoi_labels(voronoi["seeds"], SHAPE, voronoi["periodic"]), 1, voronoi["periodic"])
    frame = mesh_from_labels(labels, box=voronoi["box"])
    long_enough = {k for k, length in voronoi["pairs"].items() if length >= 3}
    assert long_enough <= pairs_of(frame)
    assert {k for k in pairs_of(frame) if k[0]} <= set(voronoi["pairs"])
    d, isolated = vertex_errors(frame, voronoi["vertices"], voronoi["periodic"])
    assert d[isolated].max() < 2.0 and np.median(d) < 0.75


def test_skeleton_gives_the_same_network(voronoi):
    """A binary skeleton of 1-px junction lines gives the network of the same image as labels."""
    membranes = draw_membranes(voronoi_labels(voronoi["seeds"], SHAPE, voronoi["periodic"]), 1, voronoi["periodic"])
    skeleton = (membranes == 0).astype(np.uint8) * 255
    assert detect_kind(skeleton, voronoi["periodic"]) == "skeleton"
    ref = mesh_from_labels(membranes, box=voronoi["box"])
    frame = mesh_from_labels(skeleton, box=voronoi["box"])
    # the skeleton's regions are numbered anew: map them to the labels (cells are convex, so the
    # label at a region's centroid is its id)
    xy = np.round(frame.cells[["x", "y"]].to_numpy()).astype(int) % [SHAPE[1], SHAPE[0]]
    to_label = dict(zip(frame.cells["cell"], membranes[xy[:, 1], xy[:, 0]]))
    to_label[0] = 0
    assert len(frame.cells) == len(ref.cells) and 0 not in list(to_label.values())[:-1]
    assert {tuple(sorted((to_label[a], to_label[b]))) for a, b in pairs_of(frame)} == pairs_of(ref)
    # identical but where a speck of one pixel enclosed by skeleton lines was dropped (min_area)
    np.testing.assert_allclose(np.sort(frame.vertices["x"]), np.sort(ref.vertices["x"]), atol=0.5)
    assert np.isclose(np.sort(frame.vertices["x"]), np.sort(ref.vertices["x"])).mean() > 0.98


def test_periodic_euler_characteristic(voronoi):
    if not voronoi["periodic"]:
        pytest.skip("Euler's V - E + F = 0 is for the torus")
    for labels in voronoi_inputs(voronoi).values():
        f = mesh_from_labels(labels, box=voronoi["box"])
        assert len(f.vertices) - len(f.edges) + len(f.cells) == 0
        assert (f.vertices["degree"] >= 3).all()
        assert not f.cells["is_border"].any()


def test_hexagonal_tiling():
    seeds, box = hexagonal_seeds(12, 10)
    labels = voronoi_labels(seeds, (int(box.Ly), int(box.Lx)), periodic=True)
    f = with_order(mesh_from_labels(labels, box=box))
    n = len(seeds)
    assert len(f.cells) == n and len(f.vertices) == 2 * n and len(f.edges) == 3 * n
    assert (f.cells["n_sides"] == 6).all() and (f.vertices["degree"] == 3).all()
    g6 = np.hypot(f.cells["gamma6_re"], f.cells["gamma6_im"])
    assert g6.min() > 0.95
    # and the open version: every interior cell is a hexagon
    fo = mesh_from_labels(voronoi_labels(seeds, (int(box.Ly), int(box.Lx))))
    inner = fo.cells[~fo.cells["is_border"]]
    assert len(inner) > 50 and (inner["n_sides"] == 6).all()


def test_square_tiling_has_four_fold_vertices():
    labels = square_labels(7, 5, 9)
    f = with_order(mesh_from_labels(labels, box=Box.from_shape(labels.shape)), p=4)
    assert len(f.vertices) == 35 and (f.vertices["degree"] == 4).all()
    assert len(f.edges) == 70
    g4 = f.cells["gamma4_re"] + 1j * f.cells["gamma4_im"]
    np.testing.assert_allclose(np.abs(g4), 1.0, atol=1e-12)
    np.testing.assert_allclose(f.cells["polygon_area"], 81.0)
    np.testing.assert_allclose(f.cells["perimeter"], 36.0)


def test_four_fold_vertex_is_not_split():
    """Two 3-fold corners 1 px apart (a rasterised T1 intermediate) merge into one vertex of degree 4."""
    labels = np.zeros((40, 40), np.int32)
    labels[:20, :20], labels[:20, 20:] = 1, 2
    labels[20:, :21], labels[20:, 21:] = 3, 4  # the vertical junction is offset by 1 px below
    f = mesh_from_labels(labels)
    inner = f.vertices[~f.vertices["is_border"]]
    assert len(inner) == 1 and inner["degree"].iloc[0] == 4
    assert (1, 4) not in pairs_of(f) and (2, 3) not in pairs_of(f)
    assert np.hypot(inner["x"].iloc[0] - 20.0, inner["y"].iloc[0] - 19.5) < 1.0
    # with no merging, the short junction between cells 2 and 3 is kept
    f0 = mesh_from_labels(labels, merge_distance=0)
    assert (2, 3) in pairs_of(f0)


def test_no_junction_shorter_than_merge_distance(voronoi):
    for merge in (2.0, 3.5):
        f = mesh_from_labels(voronoi_inputs(voronoi)["touching"], box=voronoi["box"], merge_distance=merge)
        assert f.edges["length"].min() >= merge


def test_polygons_are_counter_clockwise_and_consistent():
    labels = voronoi_labels(jittered_seeds(SHAPE, 20, seed=2), SHAPE, periodic=True)
    f = mesh_from_labels(labels, box=Box.from_shape(SHAPE))
    assert (f.cells["polygon_area"] > 0).all()
    # the polygon follows the pixel boundary within half a pixel on average
    assert ((f.cells["polygon_area"] - f.cells["area"]).abs() <= 0.5 * f.cells["perimeter"]).all()
    assert sum(f.cells["polygon_area"]) == pytest.approx(SHAPE[0] * SHAPE[1], rel=1e-3)
    # every junction is a side of the polygons of both of its cells
    polys = f.polygons()
    cv = f.cell_vertices
    assert (f.cells.set_index("cell")["n_sides"] == cv.groupby("cell").size()).all()
    sides = set()
    for cell, group in cv.groupby("cell"):
        v = group.sort_values("rank")["vertex"].to_numpy()
        sides |= {(cell, frozenset(e)) for e in zip(v, np.roll(v, -1))}
    for row in f.edges.itertuples():
        for cell in (row.cell_a, row.cell_b):
            assert (cell, frozenset((row.vertex_a, row.vertex_b))) in sides
    assert all(np.all(np.isfinite(p)) for p in polys.values())


def test_relabelling_changes_only_ids():
    labels = voronoi_labels(jittered_seeds(SHAPE, 18, seed=4), SHAPE)
    rng = np.random.default_rng(0)
    perm = np.r_[0, rng.permutation(np.arange(1, labels.max() + 1)) * 7 + 3]  # sparse, shuffled ids
    a = mesh_from_labels(labels)
    b = mesh_from_labels(perm[labels])
    mapped = {tuple(sorted((perm[x], perm[y]))) for x, y in pairs_of(a)}
    assert mapped == pairs_of(b)
    ca = a.cells.assign(cell=perm[a.cells["cell"]]).sort_values("cell").reset_index(drop=True)
    cb = b.cells.sort_values("cell").reset_index(drop=True)
    pd.testing.assert_frame_equal(ca, cb, check_exact=False, atol=1e-9)


def test_roll_on_the_torus_is_a_translation():
    box = Box.from_shape(SHAPE)
    labels = voronoi_labels(jittered_seeds(SHAPE, 18, seed=5), SHAPE, periodic=True)
    a = with_order(mesh_from_labels(labels, box=box))
    b = with_order(mesh_from_labels(np.roll(labels, (17, -40), axis=(0, 1)), box=box))
    assert pairs_of(a) == pairs_of(b)
    ca, cb = a.cells.set_index("cell"), b.cells.set_index("cell").loc[a.cells["cell"]]
    shift = box.min_image(cb[["x", "y"]].to_numpy() - ca[["x", "y"]].to_numpy())
    np.testing.assert_allclose(shift, np.broadcast_to([-40.0, 17.0], shift.shape), atol=1e-9)
    for col in ("area", "polygon_area", "perimeter", "n_sides", "gamma6_re", "gamma6_im", "gamma2_re"):
        np.testing.assert_allclose(cb[col].to_numpy(), ca[col].to_numpy(), atol=1e-9)


@pytest.mark.parametrize("k, quarter_turns", [(-1, 1), (1, -1)])
def test_rot90_multiplies_gamma_by_the_phase(k, quarter_turns):
    """np.rot90(labels, -1) maps (x, y) -> (-y, x) + const: a +90 degree rotation in (x, y)."""
    labels = voronoi_labels(jittered_seeds(SHAPE, 18, seed=6), SHAPE, periodic=True)
    a = with_order(mesh_from_labels(labels, box=Box.from_shape(SHAPE)))
    rotated = np.rot90(labels, k)
    b = with_order(mesh_from_labels(rotated, box=Box.from_shape(rotated.shape)))
    ca, cb = a.cells.set_index("cell"), b.cells.set_index("cell").loc[a.cells["cell"]]
    for p in (2, 6):
        ga = ca[f"gamma{p}_re"] + 1j * ca[f"gamma{p}_im"]
        gb = cb[f"gamma{p}_re"] + 1j * cb[f"gamma{p}_im"]
        np.testing.assert_allclose(gb.to_numpy(), ga.to_numpy() * np.exp(1j * p * quarter_turns * np.pi / 2), atol=1e-9)


def test_two_cells_no_vertex():
    labels = np.ones((10, 12), np.int32)
    labels[:, 6:] = 2
    f = with_order(mesh_from_labels(labels, box=Box(12, 10)))  # two bands around the torus: no vertices
    assert set(f.cells["cell"]) == {1, 2} and pairs_of(f) == {(1, 2)}
    assert np.isnan(f.cells["gamma6_re"]).all()


def test_cell_in_two_pieces_warns():
    labels = square_labels(3, 3, 10)
    labels[labels == 9] = 1  # cell 1 now has two pieces, in opposite corners
    with pytest.warns(HexatissueWarning, match="several boundary cycles"):
        f = mesh_from_labels(labels)
    row = f.cells.set_index("cell").loc[1]
    assert row["n_boundaries"] == 2 and row["n_sides"] >= 3


def test_border_polygons_follow_the_image_edge():
    labels = square_labels(3, 2, 10)
    f = mesh_from_labels(labels)
    np.testing.assert_allclose(f.cells["polygon_area"], 100.0)
    assert set(f.vertices.loc[f.vertices["degree"] == 2, ["x", "y"]].itertuples(index=False, name=None)) == {
        (-0.5, -0.5), (29.5, -0.5), (-0.5, 19.5), (29.5, 19.5)}


def test_background_marks_border_cells():
    labels = voronoi_labels(jittered_seeds((80, 80), 10, seed=0), (80, 80))
    labels[:, :20] = 0  # a wide background region on the left
    f = mesh_from_labels(labels, kind="touching")
    left = f.cells["x"] < 26
    assert f.cells.loc[left, "is_border"].all()
    assert not f.cells["is_border"].all()
    assert f.vertices["is_border"].any()


def test_small_holes_in_touching_labels_are_filled():
    """Gaps of a few px at triple junctions (segmented phase fields, Cellpose) do not make border cells."""
    box = Box.from_shape(SHAPE)
    labels = voronoi_labels(jittered_seeds(SHAPE, 16, seed=9), SHAPE, periodic=True)
    ref = mesh_from_labels(labels, box=box)
    holed = labels.copy()
    rows, cols = np.round(ref.vertices[["y", "x"]].to_numpy()).astype(int).T % [[SHAPE[0]], [SHAPE[1]]]
    holed[rows, cols] = 0
    holed[(rows + 1) % SHAPE[0], cols] = 0
    f = mesh_from_labels(holed, box=box, kind="touching")
    assert not f.cells["is_border"].any()
    assert long_pairs(ref) <= pairs_of(f) and len(f.vertices) - len(f.edges) + len(f.cells) == 0
    # a large background region is not a hole
    open_labels = labels.copy()
    open_labels[:, :40] = 0
    assert mesh_from_labels(open_labels, kind="touching").cells["is_border"].any()


def long_pairs(frame, min_length=3.0):
    return set(zip(*frame.edges.loc[frame.edges["length"] >= min_length, ["cell_a", "cell_b"]].to_numpy().T))


def test_float_labels_with_integer_values_are_accepted():
    labels = square_labels(3, 3, 8)
    a = mesh_from_labels(labels)
    b = mesh_from_labels(labels.astype(np.float32))
    pd.testing.assert_frame_equal(a.edges, b.edges)


# --- bad input --------------------------------------------------------------------------------

@pytest.mark.parametrize(
    "labels, message",
    [
        (np.full((8, 8), 0.5), "non-integer"),
        (np.array([[1.0, np.nan], [1.0, 1.0]]), "NaN"),
        (-np.ones((8, 8), int), "negative"),
        (np.zeros((8, 8), int), "no cells"),
        (np.ones((3, 8, 8), int), "hexatissue.analyze"),
        (np.ones(8, int), "2-D"),
        (np.array([["a", "b"], ["c", "d"]]), "integer"),
    ],
)
def test_bad_labels(labels, message):
    with pytest.raises(InputError, match=message):
        mesh_from_labels(labels)


def test_bad_options():
    labels = square_labels(2, 2, 5)
    with pytest.raises(InputError, match="box"):
        mesh_from_labels(labels, box=Box(11, 10))
    with pytest.raises(InputError, match="kind"):
        mesh_from_labels(labels, kind="cellpose")
    with pytest.raises(InputError, match="merge_distance"):
        mesh_from_labels(labels, merge_distance=-1)
    with pytest.raises(InputError, match="p must"):
        shape_order(mesh_from_labels(labels), p=0)
    with pytest.raises(TypeError):  # gamma_p is the order stage's: the mesh has no p
        mesh_from_labels(labels, p=6)
    assert issubclass(InputError, ValueError)


def test_kind_detection():
    labels = voronoi_labels(jittered_seeds((100, 120), 12, seed=8), (100, 120))
    assert detect_kind(labels) == "touching"
    assert detect_kind(draw_membranes(labels, 1)) == "membrane"
    assert detect_kind((draw_membranes(labels, 1) == 0).astype(np.uint8)) == "skeleton"
    one_blob = np.zeros((50, 50), np.uint8)
    one_blob[10:40, 10:40] = 1
    assert detect_kind(one_blob) == "touching"
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert len(mesh_from_labels(one_blob).cells) == 1


def test_a_raw_intensity_image_is_not_taken_for_labels():
    rng = np.random.default_rng(0)
    noisy = rng.poisson(100, (80, 90)).astype(np.uint16)  # photon counts: neighbours rarely equal
    with pytest.raises(InputError, match="does not look like a label image"):
        mesh_from_labels(noisy)
    labels = voronoi_labels(jittered_seeds((80, 90), 12, seed=3), (80, 90))
    assert len(mesh_from_labels(labels).cells) == labels.max()


def test_white_membranes_are_refused_with_the_fix_in_the_message():
    """uint8 labels whose membranes are 255 instead of 0 would be one giant cell: a clear error, and the fix works."""
    from hexatissue.synthetic import draw_membranes

    labels = voronoi_labels(jittered_seeds((90, 120), 12, seed=1), (90, 120))
    zero = draw_membranes(labels, width=1)
    white = np.where(zero == 0, 255, zero).astype(np.uint8)
    with pytest.raises(InputError, match=r"label 255 .* looks like membranes drawn in white.*--background 255"):
        mesh_from_labels(white)
    fixed = mesh_from_labels(white, background=(255,), kind="membrane")
    ref = mesh_from_labels(zero)
    pd.testing.assert_frame_equal(fixed.cells, ref.cells)
    big_id = labels.astype(np.uint8).copy()  # a real cell with id 255 among many: still a cell
    big_id[big_id == big_id.max()] = 255
    assert 255 in mesh_from_labels(big_id).cells["cell"].tolist()
