"""Junction networks of real third-party segmentations (../shared/data/real; skipped when absent)."""
import sqlite3

import numpy as np
import pandas as pd
import pytest
from scipy import ndimage
from scipy.spatial import cKDTree

from hexatissue import mesh_from_labels, neighbor_graph, read_labels
from hexatissue.mesh import detect_kind, normalize_labels
from hexatissue.synthetic import draw_membranes

from .conftest import real_subdir


def long_contacts(frame, min_length=3.0):
    """Contacts of >= min_length px between two interior cells (border cells are cut by the image or tissue edge)."""
    inner = set(frame.cells.loc[~frame.cells["is_border"], "cell"])
    e = frame.edges[frame.edges["cell_a"].isin(inner) & frame.edges["cell_b"].isin(inner)]
    total = e.groupby(["cell_a", "cell_b"])["length"].sum()
    return {pair for pair, length in total.items() if length >= min_length}


def contacts(frame):
    e = frame.edges[frame.edges["cell_a"] != 0]
    return set(zip(e["cell_a"], e["cell_b"]))


def assert_same_network(a, b, b_to_a=None, min_length=3.0):
    """Cell pairs sharing junctions of >= min_length px in one network are neighbours in the other, both ways."""
    def mapping(pairs):
        if b_to_a is None:
            return pairs
        mapped = {tuple(sorted((b_to_a[x], b_to_a[y]))) for x, y in pairs}
        return {p for p in mapped if 0 not in p}

    assert long_contacts(a, min_length) <= mapping(contacts(b))
    assert mapping(long_contacts(b, min_length)) <= contacts(a)


def membrane_skeleton(labels):
    """The junction lines of a membrane label image as a binary skeleton (background far from cells is not a line)."""
    near_cell = ndimage.binary_dilation(labels > 0, structure=np.ones((3, 3), bool))
    return ((labels == 0) & near_cell).astype(np.uint8) * 255


def region_to_label(regions, labels):
    """Majority label under each skeleton region (0 for regions with no label, e.g. the outside)."""
    out = {0: 0}
    for r, idx in ndimage.value_indices(regions).items():
        values = labels[idx]
        values = values[values > 0]
        out[int(r)] = int(np.bincount(values).argmax()) if len(values) else 0
    return out


def test_tissue_analyzer_vertices_and_bonds(real_data):
    """Cells rasterised from Tissue Analyzer's own polygons give back TA's vertices and bonds.

    Note: ``1/handCorrection.tif`` in this data set is not the segmentation that TA.db describes:
    TA.db's vertices lie on the junctions of the raw ``1.tif`` (two masked tissue strips), while the
    skeleton covers the whole frame with other cells.  So TA's own polygons are used as input.
    """
    folder = real_subdir(real_data, "tissue_analyzer_single")
    with sqlite3.connect(folder / "1" / "TA.db") as con:
        cells = pd.read_sql("select * from Cells", con)
        bonds = pd.read_sql("select * from Bonds", con)
    from skimage.draw import polygon

    labels = np.zeros((768, 1024), np.int32)
    for cell_id, coords in zip(cells["local_id_cells"], cells["vx_coords_cells"]):
        xy = np.array([[float(v) for v in p.split(":")] for p in coords.split("#")])
        rr, cc = polygon(xy[:, 1], xy[:, 0], labels.shape)
        labels[rr, cc] = cell_id
    frame = mesh_from_labels(labels)
    interior = cells[cells["is_border_cell"] == "false"]
    assert len(interior) == 19
    ours = frame.cells.set_index("cell").loc[interior["local_id_cells"]]
    np.testing.assert_array_equal(ours["n_sides"].to_numpy(), interior["nb_of_vertices_no_cut_off"].to_numpy())
    assert not ours["is_border"].any()
    # every bond touching an interior cell: same cell pair, both end vertices within 2 px -- or, at a
    # vertex where a cell's corner angle a is acute, within the 1.2 / tan(a) px over which the
    # rasterised wedge is thinner than a pixel and vanishes
    ids = set(interior["local_id_cells"])
    tree = cKDTree(frame.vertices[["x", "y"]].to_numpy())
    found = contacts(frame)
    sharpest = min_corner_angles(cells)
    inner_bonds = bonds[bonds["cell_id_around_bond1"].isin(ids) | bonds["cell_id_around_bond2"].isin(ids)]
    assert len(inner_bonds) > 50
    for b in inner_bonds.itertuples():
        assert tuple(sorted((int(b.cell_id_around_bond1), int(b.cell_id_around_bond2)))) in found
        for x, y in ((b.vx_1_x, b.vx_1_y), (b.vx_2_x, b.vx_2_y)):
            tolerance = max(2.0, 1.2 / np.tan(sharpest[(x, y)]))
            assert tree.query([x, y])[0] <= tolerance


def min_corner_angles(cells):
    """Smallest corner angle (rad) of any TA polygon at each vertex (x, y)."""
    out = {}
    for coords in cells["vx_coords_cells"]:
        xy = np.array([[float(v) for v in p.split(":")] for p in coords.split("#")])
        for k in range(len(xy)):
            u, w = xy[k - 1] - xy[k], xy[(k + 1) % len(xy)] - xy[k]
            angle = np.arccos(np.clip(u @ w / np.hypot(*u) / np.hypot(*w), -1, 1))
            key = tuple(xy[k].astype(int))
            out[key] = min(out.get(key, np.pi), angle)
    return out


def test_epitools_neighbour_counts(real_data):
    """EpiTools counts every pixel contact (skimage RAG); with merge_distance=0 so do we.

    By default contacts shorter than merge_distance (2 px) are four-fold vertices, not junctions:
    each cell whose count then differs has exactly that many such short contacts.
    """
    folder = real_subdir(real_data, "epitools_wingdisc")
    labels = read_labels(folder / "test_image-projected-segmented.tif")
    stats = pd.read_csv(folder / "test_image-projected-segmented-stats.csv").set_index("label")
    raw = mesh_from_labels(labels, merge_distance=0)
    graph = neighbor_graph(raw)
    degree = pd.Series(dict(graph.degree))
    assert (degree.loc[stats.index] == stats["neighbours"]).all()

    merged = mesh_from_labels(labels)
    lost = contacts(raw) - contacts(merged)
    assert contacts(merged) <= contacts(raw) and len(lost) > 5  # the convention matters on real data
    length = raw.edges[raw.edges["cell_a"] != 0].groupby(["cell_a", "cell_b"])["length"].sum()
    assert length.loc[sorted(lost)].max() < 3.0  # only contacts about as short as merge_distance are lost
    assert set(length[length < 1.0].index) <= lost


def test_epicure_labels_and_their_skeleton_agree(real_data):
    folder = real_subdir(real_data, "epicure_notum")
    labels = np.load(folder / "013_crop_labels_copy.npz")["labels"][0].astype(np.int64)
    assert detect_kind(labels) == "membrane"
    skeleton = membrane_skeleton(labels)
    assert detect_kind(skeleton) == "skeleton"
    a = mesh_from_labels(labels)
    b = mesh_from_labels(skeleton)
    regions, _ = normalize_labels(skeleton, "skeleton")
    assert_same_network(a, b, region_to_label(regions, labels))


@pytest.mark.parametrize("source", ["epitools", "itasc"])
def test_touching_labels_and_their_membrane_version_agree(real_data, source):
    if source == "epitools":
        folder = real_subdir(real_data, "epitools_wingdisc")
        labels = np.load(folder / "SegResults_CLabels_RegIm_TYX.npz")["CLabels"][0].astype(np.int64)
    else:
        folder = real_subdir(real_data, "itasc_micropattern")
        labels = read_labels(folder / "pos00" / "cell_labels.tif")[0].astype(np.int64)
    assert detect_kind(labels) == "touching"
    membranes = draw_membranes(labels, 1)
    assert detect_kind(membranes) == "membrane"
    # a 1-px membrane drawn on one side of each junction changes junction lengths by up to ~1 px,
    # so contacts near the 2-px merge threshold may differ: compare junctions of >= 4 px
    assert_same_network(mesh_from_labels(labels), mesh_from_labels(membranes), min_length=4.0)


@pytest.mark.parametrize("name", ["003_crop_epyseg.tif", "area3_Composite_epyseg.tif", "static_image_cellpose.tif"])
def test_real_segmentations_give_valid_networks(real_data, name):
    folder = real_subdir(real_data, "epicure_notum")
    image = read_labels(folder / name)
    image = image[0] if image.ndim == 3 else image
    frame = mesh_from_labels(image)
    inner = frame.cells[~frame.cells["is_border"] & (frame.cells["n_sides"] >= 3)]
    assert len(inner) > 50
    assert 5.5 < inner["n_sides"].mean() < 6.5  # Euler: interior polygons average about six sides
    inner_vertices = frame.vertices[~frame.vertices["is_border"]]
    assert (inner_vertices["degree"] >= 3).mean() > 0.99  # degree 2 only on loops (a cell inside another)
    assert (inner["polygon_area"] > 0).all()


@pytest.mark.parametrize("name", ["013_crop.tif", "static_image.tif"])
def test_raw_microscopy_images_are_refused_with_a_clear_error(real_data, name):
    from hexatissue import InputError, open_source

    path = real_subdir(real_data, "epicure_notum") / name
    with pytest.raises(InputError, match="does not look like a label image.*raw microscopy"):
        open_source(path).frame(0)


def test_mouse_epidermis_untracked_labels_are_tracked_by_overlap(real_data, tmp_path):
    """laptrack's mouse epidermis crop: 5 frames renumbered independently, cells 132/139/136/141/160 per frame,
    1-px zero membranes: every cell is found, auto mode re-tracks by overlap, analyze and report run."""
    import warnings

    from hexatissue import HexatissueWarning, analyze, read_results
    from hexatissue.workflows import report

    path = real_subdir(real_data, "mouse_epidermis_laptrack") / "labels.npy"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HexatissueWarning)
        movie = analyze(path, workers=1, progress=False)
    assert movie.cells.groupby("frame").size().tolist() == [132, 139, 136, 141, 160]
    assert movie.options["mesh"].kind == "auto" and movie.summary["tracking"]["resolved"] == "always"
    assert movie.summary["tracking"]["id_consistency"] < 0.5  # the ids mean nothing across frames
    # every track is a chain of overlapping cells: most cells of frame 0 reach frame 4
    assert (movie.lineage["n_frames"] == 5).sum() > 132 / 2
    movie.write(tmp_path / "res")
    numbers = report(tmp_path / "res", dt=2)
    assert numbers["frames"] == 5 and (tmp_path / "res" / "report" / "report.md").exists()
    assert read_results(tmp_path / "res").cells.equals(movie.cells)


@pytest.mark.parametrize("name, regions", [("003_crop_epyseg.tif", (118, 126)), ("area3_Composite_epyseg.tif", (112, 117))])
def test_epyseg_skeleton_movies_are_tracked_on_their_regions(real_data, name, regions):
    """The skeleton movies that crashed the tracker: regions per frame as SOURCE.md counts them (the enclosed
    regions, less specks), every cell has a track, every track is one region per frame, T1s are valid quartets."""
    import warnings

    from hexatissue import HexatissueWarning, analyze
    from tests.test_events import assert_valid_quartets

    path = real_subdir(real_data, "epicure_notum") / name
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HexatissueWarning)
        movie = analyze(path, workers=1, progress=False)
    per_frame = movie.cells.groupby("frame").size()
    assert per_frame.min() >= regions[0] - 8 and per_frame.max() <= regions[1]
    assert movie.cells["track"].notna().all() and not movie.cells.duplicated(["frame", "track"]).any()
    assert movie.summary["tracking"]["resolved"] == "always"  # region numbers mean nothing across frames
    assert_valid_quartets(movie.events, movie.edges, movie.cells)
