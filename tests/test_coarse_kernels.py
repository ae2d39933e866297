"""Coarse-graining kernels against their plain-numpy references, and the grid conventions on hand-computed cases."""
import numpy as np
import pandas as pd
import pytest
from scipy.spatial import cKDTree

from hexatissue import Box, InputError
from hexatissue.defects import _kernels as DK
from hexatissue.defects import _reference as DR
from hexatissue.defects import find_defects
from hexatissue.order import _kernels as K
from hexatissue.order import _reference as R
from hexatissue.order import _half_widths, _neighbours, coarse_grain, order_vs_radius


def random_points(n, size, seed):
    rng = np.random.default_rng(seed)
    return rng.uniform(0, 1, (n, 2)) * size


# ---------------------------------------------------------------------------- kernels == references


def disk_means(impl, nodes, xy_nb, values, counted, radii, cl, empty=np.nan):
    """``impl.disk_means`` into fresh output arrays: ``(means (q, k, n), counts (k, n))``."""
    means = np.full((values.shape[1], len(radii), len(nodes)), -7.0)
    counts = np.full((len(radii), len(nodes)), -7, np.int64)
    impl.disk_means(nodes, xy_nb, values, counted, np.asarray(radii, float), *cl, empty, means, counts)
    return means, counts


@pytest.mark.parametrize("periodic", [False, True])
def test_disk_means_kernel_matches_reference(periodic):
    size = np.array([97.0, 61.0])
    xy = random_points(300, size, 0)
    box = Box(*size) if periodic else None
    xy_nb, cl = _neighbours(xy, box)
    rng = np.random.default_rng(1)
    values = rng.normal(size=(len(xy), 3))
    counted = rng.random(len(xy)) > 0.2  # the others (border cells) share the cell list only
    nodes = random_points(80, size + 40, 2) - 20  # some nodes outside the points' extent / the box
    # unsorted, repeated; 0.5 leaves disks empty; 40 > Ly / 2: minimum image, each point once
    radii = np.array([9.5, 0.5, 40.0, 4.0, 33.0, 9.5])
    for empty in (np.nan, 0.0):
        m_k, c_k = disk_means(K, nodes, xy_nb, values, counted, radii, cl, empty)
        m_r, c_r = disk_means(R, nodes, xy_nb, values, counted, radii, cl, empty)
        np.testing.assert_array_equal(c_k, c_r)
        np.testing.assert_allclose(m_k, m_r, rtol=0, atol=1e-12)
        np.testing.assert_array_equal(m_k[:, c_k == 0], empty)
    assert (c_k == 0).any() and c_k.max() <= counted.sum() and (c_k[1] <= c_k[3]).all() and (c_k[3] <= c_k[0]).all()
    np.testing.assert_array_equal(c_k[0], c_k[5])


def test_disk_means_boundary_is_inclusive():
    # centroids exactly at distance 3 and 5 from the node (0, 0): 3-4-5 triangles
    xy = np.array([[3.0, 0.0], [3.0, 4.0], [0.0, -5.0], [6.0, 0.0], [0.0, 1.0]])
    xy_nb, cl = _neighbours(xy, None)
    values = np.array([[1.0], [10.0], [100.0], [1000.0], [1e6]])
    counted = np.array([True, True, True, True, False])  # the centroid at distance 1 is not counted
    for impl in (K, R):
        means, counts = disk_means(impl, np.zeros((1, 2)), xy_nb, values, counted, [5.0, 3.0, 0.5], cl)
        assert counts[:, 0].tolist() == [3, 1, 0] and means[0, :2, 0].tolist() == [37.0, 1.0]
        assert np.isnan(means[0, 2, 0])


def test_disk_means_sums_in_the_order_of_the_cell_list():
    # Gamma_p are means of sums in a fixed order: the bands in cell-list order, then bands -> disks,
    # so every column of coarse_grain is reproducible to the last bit; written out here in Python
    xy = random_points(400, np.array([120.0, 90.0]), 9)
    values = np.random.default_rng(10).normal(size=(len(xy), 2))
    xy_nb, cl = _neighbours(xy, None)
    order = cl[0]
    nodes = random_points(30, np.array([120.0, 90.0]), 11)
    radii = np.array([7.0, 18.0, 30.0])
    means, counts = disk_means(K, nodes, xy_nb, values, np.ones(len(xy), bool), radii, cl)
    for i, node in enumerate(nodes):
        bands = [[0.0, 0.0] for _ in radii]
        for c in order:  # cell-list order is bin by bin (rows of bins, then columns): the kernel's
            d2 = (xy_nb[c, 0] - node[0]) ** 2 + (xy_nb[c, 1] - node[1]) ** 2
            inside = [d2 <= r * r for r in radii]
            if any(inside):
                j = inside.index(True)
                bands[j] = [bands[j][t] + values[c, t] for t in range(2)]
        total = bands[0]
        for j in range(len(radii)):
            total = total if j == 0 else [total[t] + bands[j][t] for t in range(2)]
            assert [total[t] / counts[j, i] for t in range(2)] == means[:, j, i].tolist()


def test_tissue_mask_kernel_matches_reference():
    size = np.array([120.0, 90.0])
    rng = np.random.default_rng(3)
    g = np.stack(np.meshgrid(np.arange(5, 120, 10.0), np.arange(5, 90, 10.0)), -1).reshape(-1, 2)
    xy = g + rng.uniform(-3, 3, g.shape)
    xy = xy[rng.random(len(xy)) > 0.08]  # holes
    interior = rng.random(len(xy)) > 0.2
    reach = rng.uniform(5.0, 11.0, len(xy))
    reach[::17] = 25.0  # a few far-reaching cells
    xy_nb, (order, starts, origin, bsize, nbins, _) = _neighbours(xy, None)
    rx = np.arange(-20, size[0] + 20, 0.77)
    ry = np.arange(-20, size[1] + 20, 0.91)
    args = (rx, ry, xy_nb, interior, reach, float(reach.max()), order, starts, origin, bsize, nbins)
    m_k, m_r = K.tissue_mask(*args), R.tissue_mask(*args)
    assert m_k.shape == (len(ry), len(rx)) and 0.2 < m_k.mean() < 0.9
    np.testing.assert_array_equal(m_k, m_r)


def test_disk_coverage_kernel_matches_reference():
    rng = np.random.default_rng(4)
    mask = rng.random((70, 90)) > 0.3
    step, pad = 0.8, 12
    half, n_disk = _half_widths([0.5, 3.3, 6.0, 9.6], step, pad)
    assert half.shape == (4, 2 * pad + 1) and n_disk[0] == 1  # R < step: the node alone
    ii, jj = np.meshgrid(np.arange(pad, 70 - pad, 3), np.arange(pad, 90 - pad, 5))
    out_k = K.disk_coverage(mask, ii.ravel(), jj.ravel(), half)
    out_r = R.disk_coverage(mask, ii.ravel(), jj.ravel(), half)
    np.testing.assert_array_equal(out_k, out_r)
    full = K.disk_coverage(np.ones_like(mask), ii.ravel()[:1], jj.ravel()[:1], half)
    np.testing.assert_array_equal(full[0], n_disk)  # an all-tissue raster covers the whole disk


def test_coverage_is_the_fraction_of_disk_raster_points_on_the_tissue():
    # the rule stated in the coarse_grain docstring, computed here by brute force for every node
    rng = np.random.default_rng(5)
    g = np.stack(np.meshgrid(np.arange(0, 100, 10.0), np.arange(0, 80, 10.0)), -1).reshape(-1, 2)
    xy = g + rng.uniform(-2.5, 2.5, g.shape)
    border = (g[:, 0] == 0) | (g[:, 1] == 70)
    area = rng.uniform(70, 130, len(xy))
    cells = pd.DataFrame({"x": xy[:, 0], "y": xy[:, 1], "area": area, "is_border": border,
                          "gamma6_re": 1.0, "gamma6_im": 0.0})
    r_cell = np.sqrt(area[~border].mean() / np.pi)
    grid = coarse_grain(cells, radius=13.0, spacing=7.0)
    step = 7.0 / np.ceil(4 * 7.0 / r_cell)
    reach = 1.5 * np.maximum(np.sqrt(area / np.pi), r_cell)
    off = np.arange(-40, 41) * step
    ox, oy = np.meshgrid(off, off)
    disk = ox**2 + oy**2 <= 13.0**2
    dist, near = cKDTree(xy).query(np.c_[ox[disk], oy[disk]][None, :, :] + grid[["x", "y"]].to_numpy()[:, None])
    on = ~border[near] & (dist <= reach[near])
    np.testing.assert_allclose(grid["coverage"], on.mean(axis=1), rtol=0, atol=1e-12)
    assert 0 < grid["coverage"].min() < 1 and grid["coverage"].max() == 1
    np.testing.assert_array_equal(grid["valid"], (grid["coverage"] == 1) & (grid["n_cells"] > 0))


# ---------------------------------------------------------------------------- conventions, by hand


def square_cells(gamma=(1.0, 1j, -1.0, -1j)):
    """Four cells at (0, 0), (10, 0), (0, 10), (10, 10) with gamma6 = 1, i, -1, -i; area 100 (R_cell 5.64)."""
    xy = np.array([[0.0, 0.0], [10.0, 0.0], [0.0, 10.0], [10.0, 10.0]])
    g = np.asarray(gamma, complex)
    return pd.DataFrame({"x": xy[:, 0], "y": xy[:, 1], "area": 100.0, "gamma6_re": g.real, "gamma6_im": g.imag,
                         "gamma2_re": g.real ** 2 - g.imag ** 2, "gamma2_im": 2 * g.real * g.imag})


def test_origin_spacing_and_shape_place_the_nodes():
    cells = square_cells()
    grid = coarse_grain(cells, radius=10.0, spacing=10.0, origin=(0.0, 0.0), shape=(2, 2), validity="occupied")
    np.testing.assert_array_equal(grid[["x", "y"]], [[0, 0], [10, 0], [0, 10], [10, 10]])
    assert grid["row"].tolist() == [0, 0, 1, 1] and grid["col"].tolist() == [0, 1, 0, 1]
    # node (0, 0): cells at distance 0, 10, 10 are in (|d| <= R), the one at 14.1 is not
    assert grid["n_cells"].tolist() == [3, 3, 3, 3]
    gamma = grid["Gamma6_re"].to_numpy() + 1j * grid["Gamma6_im"].to_numpy()
    np.testing.assert_allclose(gamma, [(1 + 1j - 1) / 3, (1 + 1j - 1j) / 3, (1 - 1 - 1j) / 3, (1j - 1 - 1j) / 3],
                               atol=1e-15)
    # origin alone: nodes from the origin to the cells' far edge
    grid = coarse_grain(cells, radius=4.0, spacing=4.0, origin=(1.0, -2.0))
    assert sorted(set(grid["x"])) == [1.0, 5.0, 9.0] and sorted(set(grid["y"])) == [-2.0, 2.0, 6.0, 10.0]
    # shape alone: centred on the cells' extent
    grid = coarse_grain(cells, radius=4.0, spacing=4.0, shape=(1, 2))
    assert grid["x"].tolist() == [3.0, 7.0] and grid["y"].tolist() == [5.0, 5.0]


def test_nodes_outside_the_bounding_box_and_the_validity_rules():
    cells = square_cells()
    kw = dict(radius=3.0, spacing=10.0, origin=(-20.0, 0.0), shape=(1, 4))  # nodes at x = -20, -10, 0, 10
    occupied = coarse_grain(cells, validity="occupied", **kw)
    every = coarse_grain(cells, validity="all", **kw)
    tissue = coarse_grain(cells, **kw)
    assert occupied["n_cells"].tolist() == [0, 0, 1, 1]
    # "occupied": empty nodes are NaN and invalid, the others valid
    assert np.isnan(occupied["Gamma6_re"].iloc[:2]).all() and occupied["valid"].tolist() == [False, False, True, True]
    # "all" (the published grids): empty nodes are kept as Gamma = 0
    assert every["valid"].all() and (every["Gamma6_re"].iloc[:2] == 0.0).all() and (every["Gamma6_im"].iloc[:2] == 0).all()
    np.testing.assert_array_equal(every["Gamma6_re"].iloc[2:], occupied["Gamma6_re"].iloc[2:])
    # coverage is measured only by the rule that uses it ("tissue", which with min_coverage=0 is "occupied")
    assert occupied["coverage"].isna().all() and every["coverage"].isna().all()
    measured = coarse_grain(cells, min_coverage=0.0, **kw)
    np.testing.assert_array_equal(measured["valid"], occupied["valid"])
    # "tissue": a cell reaches 1.5 R_cell = 8.46 px from its centroid, so the disk (R = 3) of the
    # node at x = -20 is wholly off the tissue, that at -10 partly, those at 0 and 10 wholly on it
    cov = tissue["coverage"].to_numpy()
    assert cov[0] == 0.0 and 0.0 < cov[1] < 1.0 and (cov[2:] == 1.0).all()
    assert tissue["valid"].tolist() == [False, False, True, True]


def test_fixed_r_cell_sets_the_defaults_for_every_frame():
    small = square_cells()
    big = square_cells().assign(x=lambda t: 3 * t["x"], y=lambda t: 3 * t["y"], area=900.0, frame=1)
    movie = pd.concat([small.assign(frame=0), big], ignore_index=True)
    own = coarse_grain(movie)
    assert own.groupby("frame")["radius"].first().tolist() == pytest.approx([1.5 * np.sqrt(100 / np.pi),
                                                                             1.5 * np.sqrt(900 / np.pi)])
    fixed = coarse_grain(movie, r_cell=4.0)
    assert (fixed["radius"] == 6.0).all() and (fixed["spacing"] == 4.0).all()
    curve = order_vs_radius(movie, factors=(1.0, 2.0), r_cell=4.0, validity="occupied")
    assert curve["radius"].tolist() == [4.0, 8.0, 4.0, 8.0]
    # no area column is needed once R_cell is given
    coarse_grain(movie.drop(columns="area"), r_cell=4.0)


def test_several_orders_and_radii_in_one_call_equal_single_calls():
    rng = np.random.default_rng(6)
    g = np.stack(np.meshgrid(np.arange(0, 200, 10.0), np.arange(0, 160, 10.0)), -1).reshape(-1, 2)
    xy = g + rng.uniform(-3, 3, g.shape)
    z6 = np.exp(1j * rng.uniform(-np.pi, np.pi, len(xy)))
    z2 = rng.uniform(0, 1, len(xy)) * np.exp(1j * rng.uniform(-np.pi, np.pi, len(xy)))
    cells = pd.DataFrame({"x": xy[:, 0], "y": xy[:, 1], "area": 100.0, "is_border": rng.random(len(xy)) < 0.1,
                          "gamma6_re": z6.real, "gamma6_im": z6.imag, "gamma2_re": z2.real, "gamma2_im": z2.imag})
    movie = pd.concat([cells.assign(frame=4), cells.assign(frame=9, x=cells["x"] + 1.0)], ignore_index=True)
    for box in (None, Box(200.0, 160.0)):
        radii = (17.0, 8.0, 30.0)
        both = coarse_grain(movie, p=(6, 2), radius=radii, box=box)
        assert len(both) == 3 * len(coarse_grain(movie, radius=8.0, box=box))
        defects = find_defects(both, p=(6, 2), box=box)
        assert list(defects.columns) == ["frame", "radius", "defect", "x", "y", "charge", "p"]
        for r in radii:
            for q in (6, 2):
                one = coarse_grain(movie, p=q, radius=r, box=box)
                part = both[both["radius"] == r].reset_index(drop=True)
                pd.testing.assert_frame_equal(part[one.columns], one)
                d_one = find_defects(one, p=q, box=box)
                d_part = defects[(defects["radius"] == r) & (defects["p"] == q)].drop(columns="radius")
                pd.testing.assert_frame_equal(d_part.reset_index(drop=True), d_one)
        curve = order_vs_radius(movie, p=(6, 2), factors=(1.0, 3.0), box=box)
        for q in (6, 2):
            alone = order_vs_radius(movie, p=q, factors=(1.0, 3.0), box=box)
            pd.testing.assert_frame_equal(curve[curve["p"] == q].reset_index(drop=True), alone)


@pytest.mark.parametrize(
    "bad, match",
    [(dict(validity="disk"), "validity"), (dict(validity="all", min_coverage=0.5), "min_coverage"),
     (dict(origin=(1.0,)), "origin"), (dict(origin=(0.0, np.inf)), "origin"), (dict(shape=(2, 0)), "shape"),
     (dict(shape=(2.5, 3)), "shape"), (dict(r_cell=0.0), "r_cell"), (dict(radius=()), "radius"),
     (dict(radius=(3.0, -1.0)), "radius"), (dict(box=Box(20.0, 20.0), shape=(2, 2)), "shape")],
)
def test_convention_options_bad_input(bad, match):
    with pytest.raises(InputError, match=match):
        coarse_grain(square_cells(), **bad)


@pytest.mark.parametrize("periodic", [False, True])
@pytest.mark.parametrize("p", [2, 6])
def test_plaquette_defects_kernel_matches_reference(periodic, p):
    rng = np.random.default_rng(7)
    theta = rng.uniform(-np.pi / p, np.pi / p, (5, 13, 17))
    theta[0, 3, 4] = np.nan
    theta[1] = 0.0  # a uniform grid: no charge
    theta[2, 5, 6] = np.pi / p  # steps of exactly pi/p
    theta[3] = np.round(theta[3] * 4 * p / np.pi) * np.pi / (4 * p)  # many steps of exactly pi/p
    charges = DR.winding(theta, p, periodic)
    flat, charge = DK.plaquette_defects(theta, p, periodic)
    np.testing.assert_array_equal(flat, np.flatnonzero(np.nan_to_num(charges)))
    np.testing.assert_array_equal(charge, charges.ravel()[flat])
    assert np.isnan(charges[0]).sum() == 4 and (charges[1] == 0).all()
    assert 0 < len(flat) and set(np.unique(np.round(charges[2:] * p))) <= {-2, -1, 0, 1, 2}
    assert (np.abs(charges[3]) > 0).sum() > 10
    flat, charge = DK.plaquette_defects(theta[1:2], p, periodic)  # none found: empty arrays
    assert flat.dtype == np.int64 and len(flat) == len(charge) == 0


def test_field_layouts_kernel_matches_reference():
    def table(ny, nx):
        r, c = np.divmod(np.arange(ny * nx), nx)
        return r, c
    r1, c1 = table(3, 4)
    r2, c2 = table(2, 5)
    row, col = np.r_[r1, r2, r1, r1[:-1], 0, r2, -2], np.r_[c1, c2, c1, c1[:-1], 0, c2, 0]
    row[-4] = -1  # the fifth field has a negative row
    n1, n2 = 12, 10
    a = np.arange(len(row))
    shuffled = np.random.default_rng(12).permutation(n1)
    fields = [a[:n1],                              # 3 x 4 in place
              a[n1:n1 + n2],                       # 2 x 5 in place
              a[n1 + n2:2 * n1 + n2][shuffled],    # every node once, out of order
              a[2 * n1 + n2:3 * n1 + n2],          # the last node missing, (0, 0) twice
              a[3 * n1 + n2:-1],                   # a negative row
              a[:n1][::-1],                        # reversed
              np.r_[a[n1 + n2:n1 + n2 + 6], a[6:n1]],  # every node once in order, rows not consecutive
              a[:1],                               # 1 x 1
              a[-1:]]                              # only negative rows: the shape is still max + 1
    rows = np.concatenate(fields)
    cuts = np.r_[0, np.cumsum([len(f) for f in fields])]
    out_k = DK.field_layouts(row, col, rows, cuts)
    out_r = DR.field_layouts(row, col, rows, cuts)
    for k, r in zip(out_k, out_r):
        np.testing.assert_array_equal(k, r)
    shapes, once, block = out_k
    assert shapes.tolist() == [[3, 4], [2, 5], [3, 4], [3, 4], [2, 5], [3, 4], [3, 4], [1, 1], [-1, 1]]
    assert once.tolist() == [True, True, True, False, False, True, True, True, False]
    assert block.tolist() == [True, True, False, False, False, False, False, True, False]


def test_find_defects_does_not_depend_on_the_row_order_of_the_grid():
    rng = np.random.default_rng(8)
    g = np.stack(np.meshgrid(np.arange(0, 150, 10.0), np.arange(0, 120, 10.0)), -1).reshape(-1, 2)
    z = np.exp(1j * rng.uniform(-np.pi, np.pi, len(g)))
    cells = pd.DataFrame({"x": g[:, 0], "y": g[:, 1], "area": 100.0, "gamma6_re": z.real, "gamma6_im": z.imag})
    movie = pd.concat([cells.assign(frame=1), cells.assign(frame=0, gamma6_im=-cells["gamma6_im"])])
    grid = coarse_grain(movie, radius=(12.0, 20.0), validity="occupied")
    ordered = find_defects(grid)
    shuffled = find_defects(grid.sample(frac=1.0, random_state=0))
    assert len(ordered) > 10 and ordered["frame"].is_monotonic_increasing
    pd.testing.assert_frame_equal(shuffled, ordered)


def test_order_options_carry_the_conventions():
    from hexatissue import OrderOptions

    options = OrderOptions(r_cell=21.5, origin=[0, 0], shape=[23, 23], validity="all")
    assert options.origin == (0.0, 0.0) and options.shape == (23, 23)
    assert OrderOptions.from_dict(options.to_dict()) == options
    for bad in (dict(validity="disk"), dict(origin=(1.0,)), dict(shape=(0, 3)), dict(r_cell=-1.0),
                dict(validity="occupied", min_coverage=0.5)):
        with pytest.raises(InputError, match=next(iter(bad)) if "min_coverage" not in bad else "min_coverage"):
            OrderOptions(**bad)


def test_analyze_passes_the_conventions_through():
    import hexatissue as ht
    from hexatissue.synthetic import jittered_seeds, voronoi_labels

    labels = voronoi_labels(jittered_seeds((120, 140), 12.0, seed=3), (120, 140))
    order = ht.OrderOptions(p=(6, 2), r_cell=7.0, origin=(0.0, 0.0), shape=(12, 14), validity="all")
    movie = ht.analyze(labels, box=False, order=order, workers=1, progress=False)
    grid = coarse_grain(movie.cells, p=(6, 2), r_cell=7.0, origin=(0.0, 0.0), shape=(12, 14), validity="all")
    pd.testing.assert_frame_equal(movie.grid.reset_index(drop=True), grid, check_dtype=False)
    keys = ["frame", "p", "x", "y"]
    ours = find_defects(grid, p=(6, 2)).sort_values(keys).reset_index(drop=True)
    theirs = movie.defects.sort_values(keys).reset_index(drop=True)
    assert len(ours) > 0
    pd.testing.assert_frame_equal(theirs[ours.columns].drop(columns="defect"), ours.drop(columns="defect"),
                                  check_dtype=False)
