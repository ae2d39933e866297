"""Gamma_p and its defects on a height map's surface (the order fields stage after the surface stage).

Truth: a plane (the field of the tissue imaged flat; a constant height map
gives the flat analysis byte for byte), rotations (|Gamma_p| and the charges
do not depend on the image axes), a Gaussian bump (every plaquette charge a
multiple of 1/p before rounding; a discrete Gauss-Bonnet identity on loops
of plaquettes; the enclosed solid angle against the integral of the
Gaussian curvature) and fields with defects placed on the bump's flank.
"""
import warnings

import numpy as np
import pandas as pd
import pytest

from hexatissue import OrderOptions, analyze, coarse_grain, find_defects
from hexatissue.surface import (node_frames, node_normals, surface_coarse_grain, surface_defects,
                                surface_plaquette_charges)
from hexatissue.surface.transport import solid_angles, transport_angles
from hexatissue.synthetic import jittered_seeds, voronoi_labels
from hexatissue.synthetic_surface import gaussian_bump_tissue, tilted_plane_tissue

pytestmark = pytest.mark.filterwarnings("ignore::hexatissue.errors.HexatissueWarning")

NORMALS = ["normal_x", "normal_y", "normal_z"]


def _run(labels, height=None, box=None, **order):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return analyze(labels, surface=height, box=box, order=OrderOptions(**order) if order else None, workers=1,
                       progress=False)


def _modulus(grid, p=6):
    return np.hypot(grid[f"Gamma{p}_re"], grid[f"Gamma{p}_im"]).to_numpy()


@pytest.mark.parametrize("periodic", [False, True])
def test_a_constant_height_map_gives_the_flat_grid_and_defects_byte_for_byte(periodic):
    labels = voronoi_labels(jittered_seeds((96, 128), 12, seed=3), (96, 128), periodic=periodic)
    box = True if periodic else None
    flat = _run(labels, box=box)
    surface = _run(labels, np.full(labels.shape, 7.0), box=box)
    assert len(flat.defects) > 0
    pd.testing.assert_frame_equal(surface.grid[list(flat.grid.columns)], flat.grid, check_exact=True)
    pd.testing.assert_frame_equal(surface.defects, flat.defects, check_exact=True)
    np.testing.assert_array_equal(surface.grid[NORMALS].to_numpy(), [[0.0, 0.0, 1.0]] * len(surface.grid))
    assert not set(NORMALS) & set(flat.grid.columns)  # the flat path writes no surface column


def test_the_surface_path_on_a_constant_height_map_equals_the_flat_one():
    """The transport and the curvature terms themselves (not the stage's shortcut) vanish on a plane z = const."""
    labels = voronoi_labels(jittered_seeds((96, 128), 12, seed=3), (96, 128))
    cells = _run(labels, np.full(labels.shape, 7.0)).cells
    flat = coarse_grain(cells, p=(6, 2))
    grid = surface_coarse_grain(cells, np.full(labels.shape, 7.0), p=(6, 2))
    for p in (6, 2):
        for part in ("re", "im"):
            np.testing.assert_allclose(grid[f"Gamma{p}_{part}"], flat[f"Gamma{p}_{part}"], atol=1e-12)
    np.testing.assert_array_equal(grid["n_cells"], flat["n_cells"])
    pd.testing.assert_frame_equal(surface_defects(grid, p=(6, 2)), find_defects(flat, p=(6, 2)))


def test_a_tilted_plane_gives_the_field_of_the_tissue_imaged_flat():
    """Tilted 50 degrees about x: the surface Gamma_6 against the flat tissue's cells coarse-grained on the same
    disks (their centroids squeezed into the image), and the projected (flat) analysis against the same."""
    t = tilted_plane_tissue(50.0, shape=(320, 400))
    cos = np.cos(np.radians(50.0))
    order = dict(radius=1.5 * 11.0, spacing=11.0, r_cell=11.0)
    surface = _run(t.labels, t.height, **order)
    grid = surface.grid
    shape = (int(grid["row"].max()) + 1, int(grid["col"].max()) + 1)
    origin = (float(grid["x"].min()), float(grid["y"].min()))
    flat_cells = _run(t.flat_labels).cells.copy()
    flat_cells["y"] *= cos  # the flat tissue's cells where the projection puts them
    truth = coarse_grain(flat_cells, p=(6, 2), origin=origin, shape=shape, **order)
    projected = _run(t.labels, origin=origin, shape=shape, **order).grid
    np.testing.assert_allclose(grid[["x", "y"]], truth[["x", "y"]])
    # a plane: every node's normal is the plane's, the transport the identity
    np.testing.assert_allclose(grid[NORMALS].to_numpy(), [[0.0, -np.sin(np.radians(50.0)), cos]] * len(grid),
                               atol=1e-12)
    valid = grid["valid"].to_numpy() & truth["valid"].to_numpy()
    assert valid.sum() > 300
    error = np.median(np.abs(_modulus(grid) - _modulus(truth))[valid])
    projected_error = np.median(np.abs(_modulus(projected) - _modulus(truth))[valid])
    # measured: 0.019 (the cells' own surface gamma_6 error, test_surface.py) against 0.142 projected
    assert error < 0.03 and projected_error > 4 * error, (error, projected_error)
    found = find_defects(truth, p=(6, 2))
    for p in (6, 2):
        def key(d):
            d = d[d["p"] == p]
            return set(map(tuple, np.round(d[["x", "y", "charge"]].to_numpy(), 6)))
        same, proj = key(surface.defects) & key(found), key(find_defects(projected, p=p)) & key(found)
        # measured: p = 6, 15 of the 25 defects of the truth (the projected analysis: 0); p = 2, 22 of 31 (0)
        assert len(same) >= 0.5 * len(key(found)) and len(proj) <= 0.1 * len(key(found)), (p, len(same), len(proj))


def test_rotating_labels_and_height_map_keeps_the_moduli_and_the_charges():
    t = gaussian_bump_tissue(shape=(192, 192), amplitude=60.0, width=45.0, spacing=16.0, subdivisions=1)
    n = t.labels.shape[1]
    s, x0, y0, shape = 10.0, 6.0, 11.0, (17, 18)
    order = dict(radius=15.0, spacing=s, r_cell=10.0)
    one = _run(t.labels, t.height, origin=(x0, y0), shape=shape, **order)
    # np.rot90: the point (x, y) goes to (y, n - 1 - x); node (row r, col c) to (row shape[1] - 1 - c, col r)
    two = _run(np.rot90(t.labels), np.rot90(t.height), origin=(y0, n - 1 - x0 - (shape[1] - 1) * s),
               shape=shape[::-1], **order)
    a, b = one.grid, two.grid
    key = b.set_index(["row", "col"])
    b = key.loc[list(zip(shape[1] - 1 - a["col"], a["row"]))].reset_index()
    np.testing.assert_allclose(b["x"], a["y"])
    np.testing.assert_allclose(b["y"], n - 1 - a["x"])
    both = a["valid"].to_numpy() & b["valid"].to_numpy()
    assert both.sum() > 100
    for p in (6, 2):
        np.testing.assert_allclose(_modulus(b, p)[both], _modulus(a, p)[both], atol=1e-9)
    da, db = one.defects, two.defects
    assert len(da) > 5
    moved = pd.DataFrame({"x": da["y"], "y": n - 1 - da["x"], "charge": da["charge"], "p": da["p"]})
    left = moved.sort_values(["p", "x", "y"]).reset_index(drop=True)
    right = db[["x", "y", "charge", "p"]].sort_values(["p", "x", "y"]).reset_index(drop=True)
    pd.testing.assert_frame_equal(left, right, check_exact=False, atol=1e-9)


def _bump():
    t = gaussian_bump_tissue(shape=(256, 256), amplitude=80.0, width=60.0, spacing=14.0, subdivisions=1)
    return t, _run(t.labels, t.height, radius=14.0, spacing=8.0, r_cell=8.0, validity="occupied")


def _curvature_integral(x0, x1, y0, y1, centre, h=80.0, s=60.0, n=400):
    """Integral of the Gaussian curvature K dA of z = h exp(-r^2 / 2 s^2) over a rectangle of (x, y) (midpoints)."""
    x = x0 + (np.arange(n) + 0.5) * (x1 - x0) / n
    y = y0 + (np.arange(n) + 0.5) * (y1 - y0) / n
    X, Y = np.meshgrid(x - centre[0], y - centre[1])
    z = h * np.exp(-(X ** 2 + Y ** 2) / (2 * s * s))
    zx, zy = -X / s ** 2 * z, -Y / s ** 2 * z
    zxx, zyy, zxy = (X ** 2 / s ** 4 - 1 / s ** 2) * z, (Y ** 2 / s ** 4 - 1 / s ** 2) * z, X * Y / s ** 4 * z
    k_da = (zxx * zyy - zxy ** 2) / (1 + zx ** 2 + zy ** 2) ** 1.5  # K sqrt(g)
    return float(k_da.sum() * (x1 - x0) * (y1 - y0) / n ** 2)


def test_on_a_bump_every_plaquette_charge_is_a_multiple_of_1_over_p_and_loops_obey_gauss_bonnet():
    """Discrete Gauss-Bonnet on an open patch: for every rectangle of plaquettes, the sum of their (rounded)
    charges equals (W + p Omega) / (2 pi p), with W the winding of the field along the rectangle's boundary nodes
    (steps wrap(a_v - a_u - p phi_uv) into (-pi, pi], a = Arg Gamma_p, phi the transport angle; walked here, not
    taken from the plaquettes) and Omega the solid angle its boundary normals enclose (a fan of geodesic triangles
    from the middle node's normal, not the plaquettes' two-triangle split); Omega is also checked against the
    integral of the bump's Gaussian curvature over the rectangle (1.5 %)."""
    t, movie = _bump()
    grid = movie.grid
    ny, nx = int(grid["row"].max()) + 1, int(grid["col"].max()) + 1
    assert grid["valid"].all()
    normals = grid[NORMALS].to_numpy().reshape(ny, nx, 3)
    xy = grid[["x", "y"]].to_numpy().reshape(ny, nx, 2)
    e1, e2 = (e.reshape(ny, nx, 3) for e in node_frames(normals.reshape(-1, 3)))
    centre = ((t.labels.shape[1] - 1) / 2, (t.labels.shape[0] - 1) / 2)
    checked = 0
    for p in (6, 2):
        gamma = (grid[f"Gamma{p}_re"] + 1j * grid[f"Gamma{p}_im"]).to_numpy().reshape(ny, nx)
        raw = surface_plaquette_charges(np.angle(gamma) / p, normals, p, rounded=False)
        assert np.isfinite(raw).all()
        assert np.abs(raw * p - np.round(raw * p)).max() < 1e-9
        charges = np.round(raw * p) / p
        # the defects the stage found are the plaquettes of nonzero charge
        found = movie.defects[movie.defects["p"] == p]
        assert len(found) == int((charges != 0).sum()) > 4
        np.testing.assert_allclose(np.sort(found["charge"]), np.sort(charges[charges != 0]))
        for i0, j0, size in ((2, 2, 10), (8, 8, 14), (0, 0, min(ny, nx) - 1), (4, 12, 7)):
            i1, j1 = i0 + size, j0 + size  # corner nodes; plaquettes i0 .. i1 - 1
            loop = ([(i0, j) for j in range(j0, j1)] + [(i, j1) for i in range(i0, i1)]
                    + [(i1, j) for j in range(j1, j0, -1)] + [(i, j0) for i in range(i1, i0, -1)])
            u = np.array(loop)
            v = np.roll(u, -1, axis=0)
            phi = transport_angles(normals[u[:, 0], u[:, 1]], e1[u[:, 0], u[:, 1]], normals[v[:, 0], v[:, 1]],
                                   e1[v[:, 0], v[:, 1]], e2[v[:, 0], v[:, 1]])
            a = np.angle(gamma)
            winding = np.angle(np.exp(1j * (a[v[:, 0], v[:, 1]] - a[u[:, 0], u[:, 1]] - p * phi))).sum()
            middle = np.broadcast_to(normals[(i0 + i1) // 2, (j0 + j1) // 2], (len(u), 3))
            omega = solid_angles(middle, normals[u[:, 0], u[:, 1]], normals[v[:, 0], v[:, 1]]).sum()
            total = charges[i0:i1, j0:j1].sum()
            assert abs(total - (winding + p * omega) / (2 * np.pi * p)) < 1e-9, (p, i0, j0, size)
            area = _curvature_integral(xy[i0, j0, 0], xy[i1, j1, 0], xy[i0, j0, 1], xy[i1, j1, 1], centre)
            assert abs(omega - area) < 0.015 * max(abs(area), 0.05), (omega, area)
            checked += 1
    assert checked == 8


def _defect_cells(charges, p=(6, 2), spacing=6.0, shape=(200, 200), h=80.0, s=60.0):
    """Cells on a bump whose surface gamma_p (in their tangent frames) wind by ``charge`` about given points."""
    seeds = jittered_seeds(shape, spacing, 0.3, 4)
    centre = np.array([(shape[1] - 1) / 2, (shape[0] - 1) / 2])
    d = seeds - centre
    z = h * np.exp(-(d ** 2).sum(axis=1) / (2 * s * s))
    n = np.column_stack([d[:, 0] / s ** 2 * z, d[:, 1] / s ** 2 * z, np.ones(len(seeds))])
    n /= np.linalg.norm(n, axis=1)[:, None]
    cells = pd.DataFrame({"cell": np.arange(1, len(seeds) + 1), "x": seeds[:, 0], "y": seeds[:, 1],
                          "area": np.full(len(seeds), spacing ** 2), "is_border": np.zeros(len(seeds), bool),
                          "normal_x": n[:, 0], "normal_y": n[:, 1], "normal_z": n[:, 2]})
    yy, xx = np.mgrid[0:shape[0], 0:shape[1]].astype(float)
    height = h * np.exp(-((xx - centre[0]) ** 2 + (yy - centre[1]) ** 2) / (2 * s * s))
    for q in p:
        angle = sum(k * q * np.arctan2(seeds[:, 1] - y, seeds[:, 0] - x) for x, y, k in charges)
        cells[f"surface_gamma{q}_re"], cells[f"surface_gamma{q}_im"] = 0.6 * np.cos(angle), 0.6 * np.sin(angle)
    return cells, height


def test_defects_placed_on_a_bump_are_found_where_they_are_with_their_charges():
    """+1/p on the bump's steepest flank (r = s) and -1/p across the top, at the centres of plaquettes: the
    field's orientation winds by +-2 pi / p about the points in the cells' own tangent frames; each is found in the
    plaquette holding it, and no other plaquette is charged."""
    plus, minus = (160.0, 104.0), (56.0, 96.0)  # plaquette centres of the grid from (4, 4), spacing 8
    cells, height = _defect_cells([(*plus, 1 / 6), (*minus, -1 / 6)], p=(6,))
    grid = surface_coarse_grain(cells, height, p=6, radius=10.0, spacing=8.0, r_cell=6.0, origin=(4.0, 4.0),
                                shape=(25, 25))
    found = surface_defects(grid, p=6)
    assert len(found) == 2
    assert sorted(found["charge"]) == pytest.approx([-1 / 6, 1 / 6])
    for (x, y), q in ((plus, 1 / 6), (minus, -1 / 6)):
        d = found[np.isclose(found["charge"], q)]
        assert (float(d["x"].iloc[0]), float(d["y"].iloc[0])) == (x, y)
    # the nematic: +1/2 at the same place, on its own
    cells, height = _defect_cells([(*plus, 1 / 2)], p=(2,))
    grid = surface_coarse_grain(cells, height, p=2, radius=10.0, spacing=8.0, r_cell=6.0, origin=(4.0, 4.0),
                                shape=(25, 25))
    found = surface_defects(grid, p=2)
    assert list(found["charge"]) == [0.5]
    assert (float(found["x"].iloc[0]), float(found["y"].iloc[0])) == plus


def test_node_normals_of_a_plane_and_of_a_bump():
    yy, xx = np.mgrid[0:40, 0:50].astype(float)
    plane = 0.3 * xx - 0.7 * yy + 2.0
    n = node_normals(plane, [3.3, 20.0, 49.0], [0.0, 17.5, 39.0])
    np.testing.assert_allclose(n, np.tile(np.array([-0.3, 0.7, 1.0]) / np.sqrt(1.58), (3, 1)), atol=1e-12)
    np.testing.assert_allclose(node_normals(plane, [10.0], [10.0], scale=2.0),
                               [np.array([-0.6, 1.4, 1.0]) / np.sqrt(1 + 0.36 + 1.96)], atol=1e-12)
    np.testing.assert_array_equal(node_normals(np.full((5, 5), 3.0), [1.5], [2.25]), [[0.0, 0.0, 1.0]])


def test_in_a_periodic_box_the_surface_charges_sum_to_zero():
    """A periodic height map is a torus: the steps cancel around the wrapped grid and the node normals' solid
    angles sum to 4 pi deg = 0 (its Gauss map has degree 0), so the charges of every p sum to 0."""
    shape = (128, 160)
    labels = voronoi_labels(jittered_seeds(shape, 12, seed=5), shape, periodic=True)
    yy, xx = np.mgrid[0:shape[0], 0:shape[1]].astype(float)
    height = 15.0 * np.sin(2 * np.pi * xx / shape[1]) * np.cos(2 * np.pi * yy / shape[0] * 2)
    movie = _run(labels, height, box=True)
    grid = movie.grid
    assert grid["valid"].all() and np.abs(grid["normal_z"] - 1).max() > 0.05
    d = movie.defects
    assert len(d) > 10
    for p in (6, 2):
        assert abs(d.loc[d["p"] == p, "charge"].sum()) < 1e-9
    with warnings.catch_warnings():  # the disks are coarse_grain's exactly (no warning of a count that differs)
        warnings.simplefilter("error")
        again = surface_coarse_grain(movie.cells, height, p=(6, 2), box=movie.box)
    pd.testing.assert_frame_equal(again[list(grid.columns)], grid[list(grid.columns)], check_dtype=False)
    flat = _run(labels, box=True)  # the same tissue read flat: other defects
    assert not flat.defects[["x", "y", "charge"]].equals(d[["x", "y", "charge"]])


def test_on_any_plane_the_transport_is_the_identity():
    """z = 0.4 x - 0.3 y + 5: every cell's and node's normal is the plane's, their frames are one frame, and the
    surface Gamma_p is the plain mean of the cells' surface gamma_p (coarse_grain of those columns) to 1e-12."""
    labels = voronoi_labels(jittered_seeds((96, 128), 12, seed=6), (96, 128))
    yy, xx = np.mgrid[0:96, 0:128].astype(float)
    height = 0.4 * xx - 0.3 * yy + 5.0
    movie = _run(labels, height)
    cells, grid = movie.cells, movie.grid
    plane = np.array([-0.4, 0.3, 1.0]) / np.sqrt(1.25)
    measured = np.isfinite(cells["normal_z"]).to_numpy() & ~cells["is_border"].to_numpy(bool)  # (the border
    # cells' vertices on the image's edge are lifted with the edge's heights, clamped)
    np.testing.assert_allclose(cells.loc[measured, NORMALS].to_numpy(), np.tile(plane, (measured.sum(), 1)),
                               atol=1e-9)
    np.testing.assert_allclose(grid[NORMALS].to_numpy(), np.tile(plane, (len(grid), 1)), atol=1e-12)
    plain = cells.assign(**{f"gamma{p}_{part}": cells[f"surface_gamma{p}_{part}"] for p in (6, 2)
                            for part in ("re", "im")})
    flat = coarse_grain(plain, p=(6, 2))
    for p in (6, 2):
        both = np.isfinite(flat[f"Gamma{p}_re"]).to_numpy()
        assert both.sum() > 20
        for part in ("re", "im"):
            np.testing.assert_allclose(grid[f"Gamma{p}_{part}"][both], flat[f"Gamma{p}_{part}"][both], atol=1e-9)
    expected = find_defects(flat, p=(6, 2))
    assert len(expected) > 5
    def rows(d):
        return d[["p", "x", "y", "charge"]].sort_values(["p", "x", "y"]).reset_index(drop=True)
    pd.testing.assert_frame_equal(rows(movie.defects), rows(expected))


def test_the_field_figure_draws_each_surface_star_as_its_projection_into_the_image():
    """Tilted by 50 degrees about x, a star of angle a in a node's tangent frame is the flat tissue's star of angle a
    squeezed along y by cos 50 degrees (the projection); a normal along z draws the flat star exactly."""
    from hexatissue.plot import star_segments

    rng = np.random.default_rng(3)
    xy, angle, length = rng.uniform(0, 100, (20, 2)), rng.uniform(-np.pi, np.pi, 20), rng.uniform(1, 5, 20)
    flat = star_segments(xy, angle, length, 6)
    up = np.tile([0.0, 0.0, 1.0], (20, 1))
    np.testing.assert_array_equal(star_segments(xy, angle, length, 6, normals=up), flat)
    tilt = np.radians(50.0)
    tilted = np.tile([0.0, -np.sin(tilt), np.cos(tilt)], (20, 1))
    squeezed = flat.copy()
    squeezed[:, 1, 1] = flat[:, 0, 1] + np.cos(tilt) * (flat[:, 1, 1] - flat[:, 0, 1])
    np.testing.assert_allclose(star_segments(xy, angle, length, 6, normals=tilted), squeezed, atol=1e-12)
