"""napari layer data of a Movie (hexatissue.napari.layers, the stages' views): counts, coordinates, colours and scale, no napari needed."""
import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest
import tifffile

from hexatissue import EventOptions, analyze, open_source, read_results
from hexatissue.errors import HexatissueWarning, InputError
from hexatissue.napari import layers as L
from hexatissue.views import deformation as deformation_view, events as events_view, mechanics as mechanics_view
from hexatissue.views import mesh as mesh_view, order as order_view, track as track_view
from hexatissue.views.layerdata import rgba
from hexatissue.plot import MINUS_COLOR, PLUS_COLOR
from hexatissue.synthetic import t1_movie

SAMPLE = Path(__file__).resolve().parents[1] / "hexatissue" / "sample_data" / "epicure_notum" / "013_crop_labels.tif"


@pytest.fixture(scope="module")
def epicure(tmp_path_factory):
    """The EpiCure sample analysed and written to a results folder (300 s between frames, from its README)."""
    if not SAMPLE.exists():
        pytest.skip("hexatissue/sample_data/epicure_notum/013_crop_labels.tif is absent")
    folder = tmp_path_factory.mktemp("epicure")
    source = open_source(SAMPLE, frame_interval=300, time_unit="s")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HexatissueWarning)  # a few cells without polygon (covered below)
        analyze(source, progress=False).write(folder)
    return folder


@pytest.fixture(scope="module")
def layers(epicure):
    movie = read_results(epicure)
    return movie, {kw["name"]: (data, kw, kind) for data, kw, kind in
                   L.movie_layers(movie, labels=L.open_labels(movie, epicure))}


def test_every_layer_of_the_epicure_results_has_the_table_counts_and_the_scale(layers):
    movie, by_name = layers
    assert list(by_name) == ["labels", "polygons", "vertices", "gamma6 stars", "Gamma2 defects", "Gamma6 defects",
                             "T1 events", "tracks", "flow"]  # the legend is a dock widget (hexatissue.napari.legend)
    for data, kw, kind in by_name.values():
        assert kw["scale"] == (300.0, 0.2, 0.2), kw["name"]
        assert kw["metadata"]["units"] == {"t": "s", "y": "um", "x": "um"}, kw["name"]
        assert kw["units"] == ("s", "um", "um"), kw["name"]  # napari's (pint) names
        assert kw["axis_labels"] == ("t", "y", "x"), kw["name"]
    cells = movie.cells
    polygons = by_name["polygons"][0]
    assert len(polygons) == int((cells["n_sides"] >= 3).sum()) == 894  # 8 cells have no polygon (n_sides 0)
    assert len(by_name["vertices"][0]) == len(movie.vertices)
    for p in (2, 6):
            assert len(by_name[f"Gamma{p} defects"][0]) == int((movie.defects["p"] == p).sum())
    assert len(by_name["Gamma2 defects"][0]) + len(by_name["Gamma6 defects"][0]) == len(movie.defects)
    assert len(by_name["T1 events"][0]) == len(movie.events)
    tracks = by_name["tracks"][0]
    assert len(np.unique(tracks[:, 0])) == len(movie.lineage) == cells["track"].nunique()
    assert len(tracks) == len(cells)
    # the annotated division of the sample: 73 -> 477 + 490 at frame 3
    assert by_name["tracks"][1]["graph"] == {477: [73], 490: [73]}
    assert by_name["tracks"][0][tracks[:, 0] == 477][:, 1].min() == 3


def test_flow_arrows_are_the_valid_nodes_velocities_at_one_scale(layers):
    movie, by_name = layers
    data, kw, kind = by_name["flow"]
    valid = movie.flow[movie.flow["valid"]].reset_index(drop=True)
    assert kind == "vectors" and len(data) == len(valid) > 0
    np.testing.assert_allclose(data[:, 0], valid[["frame", "y", "x"]].to_numpy(float))  # (t, row, col) in px
    scale = kw["metadata"]["px_per_velocity"]
    np.testing.assert_allclose(data[:, 1], np.c_[np.zeros(len(valid)), scale * valid[["vy", "vx"]].to_numpy()])
    np.testing.assert_allclose(kw["features"]["speed"], np.hypot(valid["vx"], valid["vy"]))


def test_labels_are_the_sample_frames(layers):
    _, by_name = layers
    data, kw, kind = by_name["labels"]
    assert kind == "labels" and data.shape == (11, 160, 257)
    truth = tifffile.imread(SAMPLE).astype(np.int64)
    assert np.array_equal(np.asarray(data), truth)


def test_polygons_are_the_cell_vertices_in_row_col_order_coloured_by_sides(layers):
    movie, by_name = layers
    polygons, kw, _ = by_name["polygons"]
    features = kw["features"]
    assert (features["n_sides"].to_numpy() == [len(p) for p in polygons]).all()
    # a hand-checked cell: its polygon is its cell_vertices rows in rank order, as (frame, row = y, col = x)
    i = int(np.flatnonzero((features["frame"] == 5).to_numpy())[0])
    cell = int(features["cell"].iloc[i])
    cv = movie.cell_vertices.query("frame == 5 and cell == @cell").sort_values("rank")
    v = movie.vertices.query("frame == 5").set_index("vertex").loc[cv["vertex"]]
    assert np.allclose(polygons[i], np.column_stack([np.full(len(v), 5.0), v["y"], v["x"]]))
    hexagon = np.flatnonzero(features["n_sides"].to_numpy() == 6)[0]
    pentagon = np.flatnonzero(features["n_sides"].to_numpy() == 5)[0]
    assert np.allclose(kw["face_color"][hexagon], rgba([mesh_view.SIDES_COLORS[6]])[0])
    assert np.allclose(kw["face_color"][pentagon], rgba([mesh_view.SIDES_COLORS[5]])[0])
    # opaque faces: the labels layer's random colours cannot show through and change the side colours
    assert np.allclose(kw["face_color"][:, 3], 1.0) and kw["edge_color"] == mesh_view.POLYGON_EDGE_COLOR


def test_stars_have_p_legs_along_arg_gamma_over_p_scaled_by_its_modulus(layers):
    movie, by_name = layers
    vectors, kw, kind = by_name["gamma6 stars"]
    cells = movie.cells
    gamma = cells["gamma6_re"].to_numpy() + 1j * cells["gamma6_im"].to_numpy()
    ok = np.isfinite(gamma)
    assert kind == "vectors" and vectors.shape == (6 * ok.sum(), 2, 3)
    unit = kw["metadata"]["leg_per_unit_gamma_px"]
    first = cells[ok].iloc[0]
    g = gamma[ok][0]
    legs = vectors[:6]
    assert np.allclose(legs[:, 0], [first["frame"], first["y"], first["x"]])  # every leg starts at the centroid
    assert np.allclose(legs[:, 1, 0], 0.0)  # and stays in its frame
    angles = np.arctan2(legs[:, 1, 1], legs[:, 1, 2])  # (dy, dx) in image axes, as hexatissue.plot draws them
    expected = np.angle(g) / 6 + 2 * np.pi * np.arange(6) / 6
    assert np.allclose(np.exp(1j * angles), np.exp(1j * expected))
    assert np.allclose(np.hypot(legs[:, 1, 1], legs[:, 1, 2]), abs(g) * unit)
    assert np.allclose(kw["features"]["abs_gamma6"].to_numpy(), np.repeat(np.abs(gamma[ok]), 6))


def test_defects_are_red_for_positive_and_blue_for_negative_charges(layers):
    movie, by_name = layers
    data, kw, _ = by_name["Gamma6 defects"]
    charge = kw["features"]["charge"].to_numpy()
    assert set(np.round(charge * 6).astype(int)) <= {-1, 1} and (charge > 0).any() and (charge < 0).any()
    assert np.allclose(kw["face_color"][charge > 0], rgba([PLUS_COLOR])[0])
    assert np.allclose(kw["face_color"][charge < 0], rgba([MINUS_COLOR])[0])
    rows = movie.defects[movie.defects["p"] == 6]
    assert np.allclose(data, rows[["frame", "y", "x"]].to_numpy(float))


def test_labels_fall_back_to_labels_tif_then_are_left_out_with_a_warning(epicure, tmp_path):
    moved = tmp_path / "moved"
    shutil.copytree(epicure, moved)
    movie = read_results(moved).replace(source={"path": str(tmp_path / "gone.tif")})
    with pytest.warns(HexatissueWarning, match="no label image"):
        assert L.open_labels(movie, moved) is None
    assert [kw["name"] for _, kw, _ in L.movie_layers(movie)][0] == "polygons"
    tifffile.imwrite(moved / "labels.tif", tifffile.imread(SAMPLE).astype(np.uint16))
    assert L.open_labels(movie, moved).shape == (11, 160, 257)
    tifffile.imwrite(moved / "labels.tif", tifffile.imread(SAMPLE)[:4].astype(np.uint16),
                    photometric="minisblack")  # another frame count
    with pytest.warns(HexatissueWarning, match="4 frame"):
        assert L.open_labels(movie, moved) is None
    # a relative path, as `hexatissue analyze IMAGE --out results` records it, is also looked for beside the folder
    run = tmp_path / "run"
    shutil.copytree(epicure, run / "results")
    shutil.copy(SAMPLE, run / "image.tif")
    movie = movie.replace(source={"path": "image.tif"})
    assert L.open_labels(movie, run / "results").shape == (11, 160, 257)
    with pytest.raises(InputError, match="labels must have shape"):
        L.labels_layer(movie, np.zeros((3, 160, 257), int))
    with pytest.raises(InputError, match="p=4"):
        order_view.star_layer(movie, p=4)


@pytest.fixture(scope="module")
def scripted(tmp_path_factory):
    """The scripted T1 movie in a periodic box (exact events) and its analysis, written and read back."""
    m = t1_movie(periodic=True, seed=2)
    folder = tmp_path_factory.mktemp("t1")
    analyze(m.labels, box=m.box, events=EventOptions(min_length=m.min_length, censor=m.censor),
            workers=1, progress=False).write(folder)
    return m, read_results(folder)


def test_t1_events_are_points_at_their_quartet_centre_with_kind_and_duration(scripted):
    truth, movie = scripted
    data, kw, kind = events_view.event_layer(movie)
    assert kind == "points" and len(data) == len(movie.events) == len(truth.events) == 5
    assert np.allclose(data, movie.events[["frame_start", "y", "x"]].to_numpy(float))
    assert sorted(kw["features"]["kind"]) == sorted(truth.events["kind"])
    cycles = kw["features"][kw["features"]["kind"] == "cycle"]
    assert np.isfinite(cycles["duration"]).all() and len(cycles) == 2
    assert np.allclose(kw["face_color"][(kw["features"]["kind"] == "cycle").to_numpy()],
                       rgba([events_view.EVENT_COLORS["cycle"]])[0])


def test_periodic_polygons_sit_at_their_cell_and_tracks_are_unwrapped(scripted):
    truth, movie = scripted
    polygons, kw, _ = mesh_view.polygon_layer(movie)
    features = kw["features"]
    assert len(polygons) == int((movie.cells["n_sides"] >= 3).sum()) == len(movie.cells)
    centre = np.array([p[:, 1:].mean(axis=0) for p in polygons])  # (y, x) vertex mean
    offset = centre - features[["y", "x"]].to_numpy()
    assert np.abs(offset).max() < 3.0  # next to the centroid, never a box length away
    # cells cut by the box edge stick out of it instead of being split
    lo = np.array([p[:, 1:].min(axis=0) for p in polygons])
    hi = np.array([p[:, 1:].max(axis=0) for p in polygons])
    assert (lo < 0).any() and (hi[:, 1] > truth.box.Lx).any()
    assert (hi - lo).max() < 60  # contiguous: cells are 30-41 px across; a polygon split by the box spans ~L
    tracks, tkw, _ = track_view.track_layer(movie)
    same = tracks[1:, 0] == tracks[:-1, 0]
    steps = np.abs(np.diff(tracks[:, 2:], axis=0))[same]
    assert steps.max() < 10.0  # drift, wobble and the T1 scripts move cells < 6 px a frame; a wrap jumps ~L
    assert (tracks[:, 3] > truth.box.Lx).any() or (tracks[:, 3] < 0).any()  # the drift carries cells out
    assert tkw["scale"] == (1.0, 1.0, 1.0) and tkw["units"] == ("pixel",) * 3 and tkw["graph"] == {}


def test_a_single_image_gives_2d_layers_without_tracks(scripted):
    truth, _ = scripted
    movie = analyze(truth.labels[0], box=truth.box, workers=1, progress=False)
    layers = {kw["name"]: (data, kw) for data, kw, _ in L.movie_layers(movie)}
    assert "tracks" not in layers and "T1 events" in layers
    assert layers["polygons"][1]["scale"] == (1.0, 1.0) and layers["polygons"][1]["ndim"] == 2
    assert layers["polygons"][0][0].shape[1] == 2 and layers["vertices"][0].shape[1] == 2
    assert layers["gamma6 stars"][0].shape[1:] == (2, 2)
    assert layers["polygons"][1]["metadata"]["units"] == {"y": "px", "x": "px"}
    assert layers["polygons"][1]["units"] == ("pixel", "pixel")
    assert layers["polygons"][1]["axis_labels"] == ("y", "x")


def test_deformation_bars_sit_on_their_grid_node_along_the_stretching_axis():
    from hexatissue import DeformationOptions

    m = t1_movie(periodic=True, seed=2)
    movie = analyze(m.labels, box=m.box, workers=1, progress=False, deformation=DeformationOptions(enabled=True))
    assert deformation_view.deformation_layers(analyze(m.labels[:3], box=m.box, workers=1, progress=False)) == []
    (total, kw, kind), (t1, t1_kw, _) = deformation_view.deformation_layers(movie)
    rows = movie.deformation[movie.deformation["region"] == "grid"]
    assert kind == "vectors" and len(total) == len(t1) == len(rows)
    assert kw["visible"] and not t1_kw["visible"]
    nodes = movie.grid.drop_duplicates(["frame", "node"]).set_index(["frame", "node"])
    centre = total[:, 0, 1:] + 0.5 * total[:, 1, 1:]  # (y, x)
    expected = nodes.loc[list(zip(rows["frame"], rows["region_id"])), ["y", "x"]].to_numpy()
    np.testing.assert_allclose(centre, expected, atol=1e-9)
    np.testing.assert_array_equal(total[:, 0, 0], rows["frame"].to_numpy())
    # the bar lies along the stretching axis, 0.5 arg(xx + i xy); its length goes with the rate
    step = total[:, 1, 1:]
    moving = np.hypot(*step.T) > 1e-9
    angle = np.arctan2(step[moving, 0], step[moving, 1])
    axis = 0.5 * np.arctan2(rows["total_xy"].to_numpy()[moving], rows["total_xx"].to_numpy()[moving])
    assert np.allclose(np.sin(2 * (angle - axis)), 0, atol=1e-9)
    rate = np.hypot(rows["total_xx"], rows["total_xy"]).to_numpy()
    np.testing.assert_allclose(np.hypot(*step.T), kw["metadata"]["bar_per_unit_rate_px"] * rate, rtol=1e-9)


def test_tension_layer_draws_each_junction_with_its_tension():
    from hexatissue import Box, MechanicsOptions
    from hexatissue.synthetic import jittered_seeds, voronoi_labels

    labels = voronoi_labels(jittered_seeds((96, 96), 24, seed=5), (96, 96), periodic=True)
    assert mechanics_view.tension_layer(analyze(labels, box=Box(96, 96), workers=1, progress=False)) is None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HexatissueWarning)
        movie = analyze(labels, box=Box(96, 96), workers=1, progress=False,
                        mechanics=MechanicsOptions(enabled=True, sd=False))
    data, kw, kind = mechanics_view.tension_layer(movie)
    edges = movie.tables["edges"]
    assert kind == "vectors" and len(data) == int(np.isfinite(edges["tension"]).sum())
    np.testing.assert_allclose(kw["features"]["tension"], edges["tension"].dropna())
    v = movie.vertices.set_index("vertex")
    a = v.loc[kw["features"]["edge"].map(edges.set_index("edge")["vertex_a"]), ["y", "x"]].to_numpy()
    np.testing.assert_allclose(data[:, 0], a)
    np.testing.assert_allclose(np.hypot(*data[:, 1].T), edges.set_index("edge").loc[kw["features"]["edge"],
                                                                                     "length"], rtol=1e-9)
    assert kw["edge_color"] == "tension" and any(layer[1]["name"] == "tension" for layer in L.movie_layers(movie))


def test_the_legend_lists_every_side_colour_defect_symbol_star_and_t1_kind(layers):
    movie, _ = layers
    entries = L.legend_entries(movie)
    assert len(entries) == 13
    sides = entries.iloc[:7]
    assert list(sides["label"]) == ["≤3 sides", "4 sides", "5 sides", "6 sides", "7 sides", "8 sides", "≥9 sides"]
    assert list(sides["color"]) == list(mesh_view.SIDES_COLORS.values())
    plus, minus, star = entries.iloc[7], entries.iloc[8], entries.iloc[9]
    assert (plus["symbol"], plus["color"]) == ("disc", PLUS_COLOR) and "charge > 0" in plus["label"]
    assert (minus["symbol"], minus["color"]) == ("triangle_up", MINUS_COLOR) and "charge < 0" in minus["label"]
    assert (star["label"], star["color"]) == ("γ6 star", order_view.STAR_COLOR)
    assert list(entries["label"].iloc[10:]) == [f"T1 {kind}" for kind in events_view.EVENT_COLORS]
    assert list(L.legend_entries(movie, p=2)["label"].iloc[7:10]) == ["Γ2 defect, charge > 0", "Γ2 defect, charge < 0",
                                                                     "γ2 star"]


def test_aligned_layers_take_the_reference_grid_on_their_last_axes(layers):
    _, by_name = layers
    flat = (np.zeros((1, 2)), {"name": "2-D", "scale": (0.2, 0.2)}, "points")  # drawn in every frame
    moved = L.aligned([by_name["polygons"], flat], (2.0, 0.5, 0.25), (10.0, 3.0, 4.0),
                      ("minute", "nm", "nm"), ("T", "Y", "X"))
    (_, poly, _), (_, legend, _) = moved
    assert poly["scale"] == (2.0, 0.5, 0.25) and poly["translate"] == (10.0, 3.0, 4.0)
    assert poly["units"] == ("minute", "nm", "nm") and poly["axis_labels"] == ("T", "Y", "X")
    assert legend["scale"] == (0.5, 0.25) and legend["translate"] == (3.0, 4.0) and legend["units"] == ("nm", "nm")
    assert by_name["polygons"][1]["scale"] == (300.0, 0.2, 0.2)  # the input tuples are left as they were
    with pytest.raises(InputError, match="translate must have one value per axis"):
        L.aligned([by_name["polygons"]], (1.0, 1.0, 1.0), (0.0, 0.0))
    with pytest.raises(InputError, match="fewer axes"):
        L.aligned([by_name["polygons"]], (1.0, 1.0))
