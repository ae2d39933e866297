"""The tissue flow on a height map's surface (the tissue flow stage after the surface stage).

Truth: a constant height map is the image plane (every surface column equals
its flat counterpart, byte for byte; the flat columns are those without a
height map); a flat height map rising in time moves the cells along their
normal alone; exact affine 3-D velocity fields on a plane and a radially
inflating sphere (the fits' algebra); a tissue translating on a tilted plane
(its speed on the surface against the projected one); a tissue on a growing
Gaussian bump with its cells fixed in (x, y) (the areal rate against the
analytic rate of the area element and the cells' own surface areas; the flat
divergence is zero); labels and height maps turned by 90 degrees.
"""
import warnings

import numpy as np
import pandas as pd
import pytest

from hexatissue import FlowOptions, OrderOptions, analyze
from hexatissue.errors import InputError
from hexatissue.flow import area_rates, surface_flow_fields, surface_velocities
from hexatissue.surface import node_frames
from hexatissue.synthetic import jittered_seeds, voronoi_labels
from hexatissue.synthetic_surface import bump_movie, tilted_plane_movie

NORMALS = ["normal_x", "normal_y", "normal_z"]
CELL_COLUMNS = ["z", "vz", "surface_vx", "surface_vy", "vn"]
FLOW_COLUMNS = ["surface_vx", "surface_vy", "vn", "surface_vorticity", "surface_divergence", "surface_strain_xx",
                "surface_strain_xy", "mean_curvature", "areal_rate"]
FLAT_OF = {"surface_vx": "vx", "surface_vy": "vy", "surface_vorticity": "vorticity",
           "surface_divergence": "divergence", "areal_rate": "divergence", "surface_strain_xx": "strain_xx",
           "surface_strain_xy": "strain_xy"}


def _run(labels, height=None, box=None, flow=None, **order):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return analyze(labels, surface=height, box=box, order=OrderOptions(**order) if order else None,
                       flow=flow, workers=1, progress=False)


def _voronoi_movie(periodic, n_frames=4, shape=(96, 128)):
    seeds = jittered_seeds(shape, 12, seed=3)
    step = np.array([0.7, -0.4])
    if periodic:
        return np.stack([voronoi_labels((seeds + t * step) % shape[::-1], shape, periodic=True)
                         for t in range(n_frames)])
    return np.stack([voronoi_labels(seeds + t * step, shape) for t in range(n_frames)])


@pytest.mark.parametrize("periodic", [False, True])
def test_a_constant_height_map_gives_the_flat_flow_byte_for_byte(periodic):
    labels = _voronoi_movie(periodic)
    box = True if periodic else None
    flat = _run(labels, box=box)
    surface = _run(labels, np.full(labels.shape[1:], 7.0), box=box)
    assert not set(CELL_COLUMNS) & set(flat.cells.columns) and not set(FLOW_COLUMNS) & set(flat.flow.columns)
    pd.testing.assert_frame_equal(surface.flow[list(flat.flow.columns)], flat.flow, check_exact=True)
    pd.testing.assert_frame_equal(surface.cells[list(flat.cells.columns)], flat.cells, check_exact=True)
    cells, flow = surface.cells, surface.flow
    moving, fitted = np.isfinite(cells["vx"]).to_numpy(), np.isfinite(flow["divergence"]).to_numpy()
    assert moving.sum() > 100 and fitted.sum() > 50
    for column in ("surface_vx", "surface_vy"):
        np.testing.assert_array_equal(cells[column], cells[FLAT_OF[column]])
    np.testing.assert_array_equal(cells["z"], 7.0)
    np.testing.assert_array_equal(cells.loc[moving, ["vz", "vn"]], 0.0)
    np.testing.assert_array_equal(flow.loc[fitted, ["vn", "mean_curvature"]], 0.0)
    for column, flat_column in FLAT_OF.items():
        np.testing.assert_array_equal(flow[column], flow[flat_column])


def test_a_flat_height_map_rising_in_time_moves_the_cells_along_their_normal():
    labels = _voronoi_movie(False)
    heights = np.stack([np.full(labels.shape[1:], 3.0 + 0.5 * t) for t in range(len(labels))])
    result = _run(labels, heights)
    cells, flow = result.cells, result.flow
    moving = np.isfinite(cells["vx"]).to_numpy()
    assert moving.sum() > 100
    np.testing.assert_array_equal(cells["surface_vx"], cells["vx"])
    np.testing.assert_array_equal(cells["vn"][moving], 0.5)
    fitted = np.isfinite(flow["divergence"]).to_numpy()
    np.testing.assert_allclose(flow["vn"][fitted], 0.5, rtol=1e-12)
    np.testing.assert_array_equal(flow["areal_rate"], flow["divergence"])  # a plane: no curvature, no area change


def _exact_field(cells, velocity, normal):
    cells = cells.copy()
    cells[["vx", "vy", "vz"]] = velocity
    cells[NORMALS] = normal
    return cells


def _scattered(n=400, size=120.0, seed=0):
    rng = np.random.default_rng(seed)
    xy = rng.uniform(0, size, (n, 2))
    return pd.DataFrame({"frame": 0, "cell": np.arange(1, n + 1), "x": xy[:, 0], "y": xy[:, 1],
                         "is_border": False})


def _grid(x, y, normal, radius=25.0):
    n = len(x)
    grid = pd.DataFrame({"frame": 0, "node": np.arange(n), "x": x, "y": y, "radius": radius / 2, "valid": True})
    grid[NORMALS] = normal
    return grid


def test_an_affine_velocity_field_on_a_plane_gives_its_exact_surface_gradient():
    """On the plane z = 0.6 x - 0.3 y + 4 the 3-D field v = v0 + W X is affine in (x, y): every fit is exact, and
    L_ij = E_i . W E_j, div_s v = tr(P W), the vorticity N . curl of the tangential part."""
    cells = _scattered()
    gradient = np.array([0.6, -0.3])
    n = np.array([-gradient[0], -gradient[1], 1.0]) / np.sqrt(1 + gradient @ gradient)
    X = np.column_stack([cells["x"], cells["y"], 4 + cells[["x", "y"]].to_numpy() @ gradient])
    W = np.array([[0.02, -0.01, 0.03], [0.015, -0.005, 0.01], [-0.02, 0.04, 0.01]])
    v = np.array([0.3, -0.2, 0.1]) + X @ W.T
    cells = _exact_field(cells, v, np.tile(n, (len(cells), 1)))
    cells["z"] = X[:, 2]
    nodes = np.array([[40.0, 50.0], [70.0, 60.0], [60.0, 80.0]])
    grid = _grid(nodes[:, 0], nodes[:, 1], np.tile(n, (3, 1)))
    out = surface_flow_fields(cells, grid)
    e1, e2 = node_frames(n[None, :])
    E = np.stack([e1[0], e2[0]])
    L = E @ W @ E.T
    P = np.eye(3) - np.outer(n, n)
    node_v = np.array([0.3, -0.2, 0.1]) + np.column_stack([nodes, 4 + nodes @ gradient]) @ W.T
    np.testing.assert_allclose(out["areal_rate"], np.trace(P @ W), rtol=1e-9)
    np.testing.assert_allclose(out["areal_rate"], L[0, 0] + L[1, 1], rtol=1e-9)
    np.testing.assert_allclose(out["surface_vorticity"], L[1, 0] - L[0, 1], rtol=1e-9)
    np.testing.assert_allclose(out["surface_strain_xx"], (L[0, 0] - L[1, 1]) / 2, rtol=1e-9)
    np.testing.assert_allclose(out["surface_strain_xy"], (L[0, 1] + L[1, 0]) / 2, rtol=1e-9)
    np.testing.assert_allclose(out["surface_vx"], node_v @ e1[0], rtol=1e-9)
    np.testing.assert_allclose(out["surface_vy"], node_v @ e2[0], rtol=1e-9)
    np.testing.assert_allclose(out["vn"], node_v @ n, rtol=1e-9)
    np.testing.assert_allclose(out["mean_curvature"], 0.0, atol=1e-15)
    # on a plane the normal term vanishes: the tangential part's divergence is the whole
    np.testing.assert_allclose(out["surface_divergence"], out["areal_rate"], rtol=1e-9)


def test_the_cells_velocities_are_split_in_their_tangent_frames():
    """Cells moving with V from the plane z = 0.6 x - 0.3 y + 4 (V in the plane plus 0.2 n): vx, vy, vz are V's,
    surface_vx = V . e1, surface_vy = V . e2, vn = 0.2; a cell without a normal has only vx, vy, vz."""
    gradient = np.array([0.6, -0.3])
    n = np.array([-gradient[0], -gradient[1], 1.0]) / np.sqrt(1 + gradient @ gradient)
    e1, e2 = (e[0] for e in node_frames(n[None, :]))
    V = 0.7 * e1 - 0.4 * e2 + 0.2 * n
    start = _scattered(20)[["x", "y"]].to_numpy()
    frames = []
    for t in range(3):
        xy = start + t * V[:2]
        frames.append(pd.DataFrame({"frame": t, "cell": np.arange(1, 21), "x": xy[:, 0], "y": xy[:, 1],
                                    "z": 4 + start @ gradient + t * V[2]}))
    cells = pd.concat(frames, ignore_index=True)
    cells[NORMALS] = n
    cells.loc[25, NORMALS] = np.nan  # a cell of frame 1 without a polygon
    out = surface_velocities(cells)
    middle = (cells["frame"] == 1).to_numpy() & (cells.index != 25)
    np.testing.assert_allclose(np.column_stack([out["vx"], out["vy"], out["vz"]])[middle], np.tile(V, (19, 1)),
                               atol=1e-12)
    np.testing.assert_allclose(out["surface_vx"][middle], 0.7, atol=1e-12)
    np.testing.assert_allclose(out["surface_vy"][middle], -0.4, atol=1e-12)
    np.testing.assert_allclose(out["vn"][middle], 0.2, atol=1e-12)
    assert np.isnan(out["vn"][25]) and np.isfinite(out["vz"][25])
    assert np.isnan(out["vx"][(cells["frame"] != 1).to_numpy()]).all()  # the ends of the tracks


def test_a_sphere_inflating_radially_grows_its_area_by_the_normal_term_alone():
    """v = eps (X - c) on a sphere of radius R about c: the areal rate is 2 eps, all of it -2 H vn with
    H = -1/R (a dome: the normal faces +z, away from c) and vn = eps R; the tangential part is zero."""
    R, eps = 300.0, 0.01
    cells = _scattered(size=160.0, n=600)
    centre = np.array([80.0, 80.0, -250.0])
    d = cells[["x", "y"]].to_numpy() - centre[:2]
    X = np.column_stack([cells["x"], cells["y"], centre[2] + np.sqrt(R ** 2 - (d ** 2).sum(axis=1))])
    normal = (X - centre) / R
    cells = _exact_field(cells, eps * (X - centre), normal)
    cells["z"] = X[:, 2]
    nodes = np.array([[80.0, 80.0], [60.0, 100.0], [100.0, 70.0]])
    dn = nodes - centre[:2]
    node_normal = np.column_stack([dn, np.sqrt(R ** 2 - (dn ** 2).sum(axis=1))]) / R
    out = surface_flow_fields(cells, _grid(nodes[:, 0], nodes[:, 1], node_normal))
    np.testing.assert_allclose(out["areal_rate"], 2 * eps, rtol=1e-3)
    np.testing.assert_allclose(out["mean_curvature"], -1 / R, rtol=1e-3)
    # the affine fit's value at the node averages the sphere's height over the disk: off by about
    # eps r^2 / 4 R (r = 25 px, the fit's radius: 0.005 px/frame)
    np.testing.assert_allclose(out["vn"], eps * R, rtol=3e-3)
    np.testing.assert_allclose(out["surface_divergence"], 0.0, atol=1e-5)
    np.testing.assert_allclose(out["surface_divergence"] - 2 * out["mean_curvature"] * out["vn"], 2 * eps,
                               rtol=2e-3)
    np.testing.assert_allclose(out[["surface_vorticity", "surface_strain_xx", "surface_strain_xy"]], 0.0, atol=1e-5)


def test_a_tissue_translating_on_a_tilted_plane_moves_at_its_true_speed_on_the_surface():
    """50 degrees about x, 1 px/frame up the slope: the image sees cos 50 = 0.643 of it."""
    movie = tilted_plane_movie(50.0, n_frames=5, velocity=(0.0, 1.0), shape=(160, 220))
    result = _run(movie.labels, movie.height)
    cells = result.cells[~result.cells["is_border"] & np.isfinite(result.cells["surface_vx"])]
    assert len(cells) > 80
    speed = np.hypot(cells["surface_vx"], cells["surface_vy"])
    projected = np.hypot(cells["vx"], cells["vy"])
    # measured: median |speed - 1| 0.024 over 112 cells, mean speed 1.002; projected median 0.645
    assert np.median(np.abs(speed - 1)) < 0.06 and abs(speed.mean() - 1) < 0.01
    assert abs(np.median(projected) - np.cos(np.radians(50.0))) < 0.02
    np.testing.assert_allclose(cells["vn"], 0.0, atol=1e-9)  # the cells stay in the plane
    np.testing.assert_allclose(np.median(cells["surface_vy"]), 1.0, atol=0.01)  # e2 runs up the slope
    flow = result.flow[result.flow["valid"] & np.isfinite(result.flow["areal_rate"])]
    assert len(flow) > 100
    # measured: median 0.013; the areal rate of a uniform translation is zero (median |.| 6.6e-4 1/frame)
    assert np.median(np.abs(np.hypot(flow["surface_vx"], flow["surface_vy"]) - 1)) < 0.03
    assert np.median(np.abs(flow["areal_rate"])) < 2e-3
    np.testing.assert_allclose(flow[["vn", "mean_curvature"]], 0.0, atol=1e-9)


def _growing_bump():
    return bump_movie(5, amplitude=60.0, growth=0.05, width=45.0, shape=(160, 160), spacing=12.0, subdivisions=2)


def _area_element_rate(x, y, t, h0=60.0, growth=0.05, s=45.0, centre=79.5):
    """d log sqrt(1 + |grad z|^2) / dt of z = h0 (1 + growth t) g, g = exp(-r^2 / 2 s^2)."""
    q = np.exp(-((x - centre) ** 2 + (y - centre) ** 2) / (s * s)) * ((x - centre) ** 2 + (y - centre) ** 2) / s ** 4
    h = h0 * (1 + growth * t)
    return h * h0 * growth * q / (1 + h * h * q)


def test_on_a_growing_bump_the_areal_rate_is_the_rate_of_the_cells_surface_areas():
    """Cells fixed in (x, y) on a bump whose height grows 5 % a frame: no flow in the image (the flat divergence is
    0), yet their surface areas grow; the areal rate from the 3-D flow gives that growth."""
    movie = _growing_bump()
    result = _run(movie.labels, movie.height, flow=FlowOptions(radius_factor=1.5))
    cells = result.cells.sort_values(["track", "frame"]).reset_index(drop=True)
    rate = area_rates(cells)
    area, frame = cells["surface_area"].to_numpy(), cells["frame"].to_numpy()
    inner = ~cells["is_border"].to_numpy() & np.isfinite(rate)
    truth = _area_element_rate(cells["x"], cells["y"], cells["frame"])[inner]
    # the cells' own area rates follow the area element's (measured: 0.9 % of the median rate)
    assert np.median(np.abs(rate[inner] - truth)) < 0.02 * np.median(truth)
    np.testing.assert_allclose(cells["vx"][inner], 0.0, atol=1e-12)
    flow = result.flow[result.flow["valid"] & np.isfinite(result.flow["areal_rate"])]
    assert len(flow) > 300
    truth = _area_element_rate(flow["x"], flow["y"], flow["frame"])
    scale = np.median(truth)
    error = np.median(np.abs(flow["areal_rate"] - truth)) / scale
    # measured: 0.030 of the median rate (1.85e-2 1/frame) over 846 nodes; the flat divergence is exactly 0
    assert error < 0.05, error
    np.testing.assert_array_equal(flow["divergence"], 0.0)
    # the region of each node: its cells' summed surface area changes at the node's areal rate
    regional = []
    for t, nodes in flow.groupby("frame"):
        here = inner & (frame == t)
        xy, a, r = cells.loc[here, ["x", "y"]].to_numpy(), area[here], rate[here]
        for x, y, radius, areal in nodes[["x", "y", "radius", "areal_rate"]].itertuples(index=False):
            near = np.hypot(xy[:, 0] - x, xy[:, 1] - y) <= radius
            if near.sum() >= 3:
                regional.append(areal - (a[near] * r[near]).sum() / a[near].sum())
    # measured: 0.022 of the median rate
    assert np.median(np.abs(regional)) < 0.05 * scale
    # the decomposition: the normal term carries the growth, the tangential divergence the rest (measured: their
    # sum is 0.086 of the median rate off, the product of two fits carrying the errors of both)
    normal_term = -2 * flow["mean_curvature"] * flow["vn"]
    assert np.median(np.abs(flow["surface_divergence"] + normal_term - truth)) < 0.15 * scale
    top = np.hypot(flow["x"] - 79.5, flow["y"] - 79.5) < 15
    assert (normal_term[top] > 0).all() and (flow["mean_curvature"][top] < 0).all()


def test_turning_labels_and_height_maps_by_90_degrees_keeps_the_surface_flow():
    movie = bump_movie(4, amplitude=50.0, growth=0.05, width=40.0, drift=(0.6, 0.3), shape=(128, 128), spacing=12.0,
                       subdivisions=1)
    n = movie.labels.shape[2]
    s, x0, y0, shape = 8.0, 8.0, 10.0, (13, 14)
    order = dict(radius=12.0, spacing=s, r_cell=8.0)
    one = _run(movie.labels, movie.height, origin=(x0, y0), shape=shape, **order)
    two = _run(np.rot90(movie.labels, axes=(1, 2)).copy(), np.rot90(movie.height, axes=(1, 2)).copy(),
               origin=(y0, n - 1 - x0 - (shape[1] - 1) * s), shape=shape[::-1], **order)
    a = one.cells.set_index(["frame", "cell"])
    b = two.cells.set_index(["frame", "cell"]).loc[a.index]
    np.testing.assert_allclose(b["x"], a["y"], atol=1e-9)
    moving = np.isfinite(a["vn"]).to_numpy()
    assert moving.sum() > 100
    np.testing.assert_allclose(np.hypot(b["surface_vx"], b["surface_vy"])[moving],
                               np.hypot(a["surface_vx"], a["surface_vy"])[moving], atol=1e-9)
    np.testing.assert_allclose(b["vn"][moving], a["vn"][moving], atol=1e-9)
    # np.rot90: (x, y) -> (y, n - 1 - x), a vector (a, b) -> (b, -a)
    np.testing.assert_allclose(b["vx"][moving], a["vy"][moving], atol=1e-9)
    np.testing.assert_allclose(b["vy"][moving], -a["vx"][moving], atol=1e-9)
    fa, fb = (m.flow.merge(m.grid[["frame", "node", "row", "col"]]) for m in (one, two))
    fb = fb.set_index(["frame", "row", "col"]).loc[list(zip(fa["frame"], shape[1] - 1 - fa["col"], fa["row"]))]
    np.testing.assert_allclose(fb["x"], fa["y"])
    both = np.isfinite(fa["areal_rate"]).to_numpy()
    assert both.sum() > 200
    np.testing.assert_array_equal(np.isfinite(fb["areal_rate"]).to_numpy(), both)
    for column in ("areal_rate", "surface_divergence", "mean_curvature", "vn", "surface_vorticity"):
        np.testing.assert_allclose(fb[column].to_numpy()[both], fa[column].to_numpy()[both], atol=1e-9, err_msg=column)
    for pair in (("surface_vx", "surface_vy"), ("surface_strain_xx", "surface_strain_xy")):
        np.testing.assert_allclose(np.hypot(*(fb[c].to_numpy()[both] for c in pair)),
                                   np.hypot(*(fa[c].to_numpy()[both] for c in pair)), atol=1e-9, err_msg=pair[0])


def test_bad_input_is_named():
    cells = _scattered(10)
    with pytest.raises(InputError, match="z"):
        surface_velocities(cells)
    cells = _exact_field(cells.assign(z=0.0), np.zeros((10, 3)), np.tile([0.0, 0.0, 1.0], (10, 1)))
    grid = _grid([10.0], [10.0], [[0.0, 0.0, 1.0]])
    with pytest.raises(InputError, match="normal_x"):
        surface_flow_fields(cells, grid.drop(columns=["normal_x"]))
    with pytest.raises(InputError, match="min_cells"):
        surface_flow_fields(cells, grid, min_cells=2)
    with pytest.raises(InputError, match="drift"):
        bump_movie(drift=(1.0,))
    with pytest.raises(InputError, match="growth"):
        bump_movie(n_frames=5, growth=-0.5)


def test_streamed_surface_flow_equals_the_in_memory_one(tmp_path, monkeypatch):
    """Tables streamed to Parquet parts of a few frames each: the flow stage reads the surface columns chunk by
    chunk (one frame of halo) and writes the same columns."""
    from hexatissue import pipeline
    from hexatissue.stored import StoredTable

    monkeypatch.setattr(pipeline, "PART_BYTES", 20_000)
    movie = bump_movie(6, amplitude=40.0, growth=0.05, width=35.0, drift=(0.5, 0.2), shape=(96, 96), spacing=12.0,
                       subdivisions=1)
    memory = _run(movie.labels, movie.height)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        streamed = analyze(movie.labels, surface=movie.height, out=tmp_path, workers=1, progress=False)
    assert isinstance(streamed.cells, StoredTable) and len(streamed.cells.parts) > 1
    for name, columns in (("cells", CELL_COLUMNS), ("flow", FLOW_COLUMNS)):
        got = streamed.tables[name]
        got = got.to_pandas() if isinstance(got, StoredTable) else got
        assert np.isfinite(memory.tables[name][columns[-1]]).sum() > 20
        pd.testing.assert_frame_equal(got[columns], memory.tables[name][columns], obj=name)


def test_area_rates_are_centred_along_each_track_in_row_order():
    cells = pd.DataFrame({"track": [2, 1, 1, 2, 1, 2, 1], "frame": [0, 2, 0, 1, 1, 2, 4],
                          "surface_area": [10.0, 4.0, 1.0, 12.0, 2.0, 16.0, 8.0]})
    rate = area_rates(cells)
    # track 1: frames 0, 1, 2 then a gap (4): only frame 1 is centred; track 2: frame 1
    np.testing.assert_array_equal(np.isnan(rate), [True, True, True, False, False, True, True])
    assert rate[4] == (4.0 - 1.0) / (2 * 2.0) and rate[3] == (16.0 - 10.0) / (2 * 12.0)
