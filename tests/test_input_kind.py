"""Is this a segmentation?  Class maps, membrane maps and colour renderings are refused or routed, not analysed
as cells; a background label that is not 0 is found as the outside (docs/input.md)."""
import warnings

import numpy as np
import pytest
from scipy import ndimage

import hexatissue as ht
from hexatissue import HexatissueWarning, InputError
from hexatissue.cli import main
from hexatissue.synthetic import draw_membranes, jittered_seeds, voronoi_labels

from .conftest import real_subdir

SHAPE = (160, 200)


@pytest.fixture(scope="module")
def tissue():
    return voronoi_labels(jittered_seeds(SHAPE, 16, seed=3), SHAPE).astype(np.int32)


def membrane_map(tissue, width=3):
    """Bright membranes (255) of ``width`` (2 or 3) px on dark cells (0), as a thresholded membrane channel."""
    lines = draw_membranes(tissue, 2) == 0
    if width == 3:
        lines = ndimage.binary_dilation(lines, np.array([[0, 0, 0], [0, 1, 1], [0, 0, 0]], bool))
    return np.where(lines, 255, 0).astype(np.uint8)


def class_map(tissue):
    """A pixel classifier's two-class output ("Simple Segmentation"): 1 = cell interior, 2 = membrane."""
    return np.where(membrane_map(tissue) > 0, 2, 1).astype(np.uint8)


def colour_rendering(tissue, colours=7):
    """Labels drawn with a repeating colour map, then read back as colours: ids repeat over many cells."""
    return (tissue % colours + 1).astype(np.int32)


def interior_recovered(pred, truth):
    """Share of the truth cells away from the image edge that one predicted cell covers at IoU >= 0.8."""
    inner = np.setdiff1d(np.unique(truth), np.unique(np.r_[truth[0], truth[-1], truth[:, 0], truth[:, -1]]))
    hits = 0
    for cell in inner:
        mask = truth == cell
        ids, counts = np.unique(pred[mask], return_counts=True)
        best = ids[np.argmax(counts)]
        hits += np.count_nonzero(mask & (pred == best)) / np.count_nonzero(mask | (pred == best)) >= 0.8
    return hits / len(inner)


@pytest.mark.parametrize("make", [class_map, membrane_map, colour_rendering])
def test_class_membrane_and_colour_maps_are_refused(tissue, make):
    with pytest.raises(InputError, match="do not look like cell labels.*class map.*--kind membrane-map"):
        ht.mesh_from_labels(make(tissue))


def test_refusal_names_the_frame_on_the_command_line(tissue, tmp_path, capsys):
    np.save(tmp_path / "classes.npy", np.stack([tissue, class_map(tissue)]))
    assert main(f"analyze {tmp_path}/classes.npy --out {tmp_path}/o".split()) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "error: frame 1: labels do not look like cell labels" in err[0]
    assert not (tmp_path / "o").exists()


def test_real_segmentations_are_not_refused(tissue):
    # ids in pieces only here and there (a fragment, a cell with a hole) are real labels
    labels = tissue.copy()
    labels[5:9, 5:9] = labels[100, 100]  # one cell with a far-away piece
    labels[labels == labels[60, 60]] = np.where(ndimage.binary_erosion(labels == labels[60, 60], iterations=3),
                                                0, labels[60, 60])[labels == labels[60, 60]]  # a hole
    with pytest.warns(HexatissueWarning, match="several boundary cycles"):
        frame = ht.mesh_from_labels(labels)
    assert len(frame.cells) == len(np.unique(tissue))


@pytest.mark.parametrize("form", ["binary", "probability"])
def test_membrane_maps_are_segmented_with_kind_membrane_map(tissue, form):
    image = membrane_map(tissue, width=2)
    if form == "probability":  # a smooth float map in [0, 1], as a classifier's membrane probability
        image = ndimage.gaussian_filter(image / 255.0, 1.0).astype(np.float32)
    frame = ht.mesh_from_labels(image, kind="membrane-map")
    source = ht.open_source(image[None])
    labels, _, _ = source.checked_frame(0, "membrane-map")
    assert interior_recovered(labels, tissue) >= 0.95
    assert abs(len(frame.cells) - len(np.unique(tissue))) <= 0.05 * len(np.unique(tissue))


def test_membrane_map_from_the_command_line(tissue, tmp_path):
    np.save(tmp_path / "map.npy", np.stack([membrane_map(tissue, 2)] * 3))
    assert main(f"analyze {tmp_path}/map.npy --kind membrane-map --out {tmp_path}/o".split()) == 0
    movie = ht.read_results(tmp_path / "o")
    assert movie.options["mesh"].kind == "membrane-map"
    assert abs(movie.cells.groupby("frame").size() - len(np.unique(tissue))).max() <= 0.05 * len(np.unique(tissue))


def test_background_label_that_is_not_zero_is_found_on_the_command_line(tissue, tmp_path, capsys):
    labels = np.pad(tissue + 1, 30, constant_values=1)  # hand-labelled: the outside is label 1
    np.save(tmp_path / "rim.npy", labels)
    assert main(f"analyze {tmp_path}/rim.npy --out {tmp_path}/o".split()) == 0
    assert "label 1 touches the image edge" in capsys.readouterr().err
    cells = ht.read_results(tmp_path / "o").cells
    assert 1 not in set(cells["cell"])
    # the cells on the tissue's edge are border cells, as if the outside were 0
    assert cells["is_border"].sum() == ht.mesh_from_labels(np.pad(tissue + 1, 30)).cells["is_border"].sum()
    assert main(f"analyze {tmp_path}/rim.npy --outside none --out {tmp_path}/o2".split()) == 0
    assert 1 in set(ht.read_results(tmp_path / "o2").cells["cell"])


# real data (skipped without ../shared): maps made from the EpiCure notum movie and its curated labels
def test_maps_made_from_real_data_are_refused_or_routed(real_data):
    import tifffile

    folder = real_subdir(real_data, "epicure_notum")
    raw = tifffile.imread(folder / "013_crop.tif")[0].astype(float)
    labels = tifffile.imread(folder / "013_crop_labels.tif")[0].astype(np.int64)
    smooth = ndimage.gaussian_filter(raw, 1)
    classes = (1 + (smooth > np.percentile(smooth, 70))).astype(np.uint8)  # ilastik-like two-class output
    for image in (classes, (labels % 20 + 1) * (labels > 0), (classes - 1) * 255):
        with pytest.raises(InputError, match="do not look like cell labels"):
            ht.mesh_from_labels(image)
    frame = ht.mesh_from_labels(raw, kind="membrane-map")  # the raw membrane channel, routed
    inner = frame.cells[~frame.cells["is_border"] & (frame.cells["n_sides"] >= 3)]
    assert len(inner) > 50 and 5.5 < inner["n_sides"].mean() < 6.5


# --- drawings of junction lines and dim raw planes: refused, saying what they look like ----------------------

def junction_drawing(tissue):
    """Coloured junction lines on black, one colour per cell pair (as vertex-extraction tools draw them), RGB."""
    lines = draw_membranes(tissue, 2) == 0
    right = np.roll(tissue, -2, axis=1)
    below = np.roll(tissue, -2, axis=0)
    pair = np.minimum(tissue, np.where(right != tissue, right, below)) * 1000 + np.maximum(tissue, right)
    code = np.where(lines, pair % 16_000_000 + 1, 0)
    return np.stack([(code >> 16) & 255, (code >> 8) & 255, code & 255], -1).astype(np.uint8)


def dim_plane(tissue, seed=0):
    """A dim 8-bit raw membrane plane: blurred junctions 2.5 grey values bright on 6, smooth noise: 4-10."""
    signal = ndimage.gaussian_filter((draw_membranes(tissue, 2) == 0).astype(float), 2)
    noise = ndimage.gaussian_filter(np.random.default_rng(seed).normal(0, 1, signal.shape), 3)
    return np.clip(np.round(6 + 2.5 * signal / signal.max() + 0.5 * noise / noise.std()), 3, 35).astype(np.uint8)


def test_a_drawing_of_junction_lines_is_refused_and_reads_as_a_skeleton_when_told(tissue, tmp_path, capsys):
    drawing = junction_drawing(tissue)
    with pytest.raises(InputError, match=r"values are lines on a black ground.*drawing of the junctions in colour"
                                         r".*--kind skeleton"):
        ht.open_source(drawing).frame(0)
    np.save(tmp_path / "drawing.npy", drawing)
    assert main(f"analyze {tmp_path}/drawing.npy --out {tmp_path}/o".split()) == 2
    assert "lines on a black ground" in capsys.readouterr().err
    # told, the lines are a skeleton: the cells of the binary skeleton, exactly
    lines = (drawing.any(-1) * 255).astype(np.uint8)
    told = ht.mesh_from_labels(ht.open_source(drawing).raw_frame(0), kind="skeleton")
    pd_cells = ht.mesh_from_labels(lines).cells
    assert len(told.cells) == len(pd_cells) and np.array_equal(np.sort(told.cells["area"]), np.sort(pd_cells["area"]))
    assert main(f"analyze {tmp_path}/drawing.npy --kind skeleton --out {tmp_path}/o2".split()) == 0


def test_a_dim_raw_plane_is_refused_as_one(tissue):
    plane = dim_plane(tissue)
    same = ((plane[:, 1:] == plane[:, :-1]).mean() + (plane[1:] == plane[:-1]).mean()) / 2
    assert same > 0.7  # few grey values: the test of equal neighbours alone lets it through
    with pytest.raises(InputError, match=r"each scattered over \d+ separate specks.*dim raw image"):
        ht.mesh_from_labels(plane)


@pytest.mark.parametrize("side", [6, 9, 14])
def test_labels_of_small_cells_are_accepted(side):
    # cells of 36-196 px: their boundary pixels are a large share, but each id is one region
    shape = (20 * side, 24 * side)
    labels = voronoi_labels(jittered_seeds(shape, side, seed=2), shape)
    frame = ht.mesh_from_labels(labels)
    assert len(frame.cells) == len(np.unique(labels))


def test_real_overlay_and_dim_plane_are_refused(real_data):
    import tifffile

    vertex = real_subdir(real_data, "ishihara_bfi_sample") / "Vertex.png"
    with pytest.raises(InputError, match="lines on a black ground"):
        ht.open_source(vertex).frame(0)
    # told it is a skeleton, the overlay gives the network of the skeleton it was drawn on (281 regions)
    told = ht.mesh_from_labels(ht.open_source(vertex).raw_frame(0), kind="skeleton")
    skeleton = ht.mesh_from_labels(tifffile.imread(vertex.parent / "sample.tif"))
    assert abs(len(told.cells) - len(skeleton.cells)) <= 2  # measured 282 and 281
    plane = tifffile.imread(real_subdir(real_data, "epitools_wingdisc") / "test_image.tif")[1]
    with pytest.raises(InputError, match=r"33 values \(3-35\), each scattered.*dim raw image"):
        ht.mesh_from_labels(plane)


@pytest.mark.slow
def test_the_label_ness_corpus_has_no_wrong_outcome(real_data, tmp_path):
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "benchmarks" / "input_corpus.py"
    spec = importlib.util.spec_from_file_location("input_corpus", path)
    corpus = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(corpus)
    rows = [(name, truth, klass, *corpus.outcome(image)) for name, truth, klass, image in corpus.cases()]
    table, wrong = corpus.confusion(rows)
    assert len(rows) >= 300 and set(table) >= {"segmentation", "raw plane", "dim raw plane", "classifier map",
                                                "render", "overlay"}
    assert wrong == []


# --- the membrane-map route checks its own count against the image's dark basins --------------------------

def broken_membranes(tissue, share, seed=0):
    """``membrane_map(tissue, 2)`` with a 7 x 7 px gap in the middle of ``share`` of the junctions."""
    lines = draw_membranes(tissue, 2) == 0
    image = np.where(lines, 255, 0).astype(np.uint8)
    rng = np.random.default_rng(seed)
    middles = {}
    for y, x in zip(*np.nonzero(lines)):
        a, b = tissue[y, max(x - 2, 0)], tissue[y, min(x + 2, tissue.shape[1] - 1)]
        if a != b:
            middles.setdefault((min(a, b), max(a, b)), []).append((y, x))
    for pixels in middles.values():
        if rng.random() < share:
            y, x = pixels[len(pixels) // 2]
            image[max(y - 3, 0):y + 4, max(x - 3, 0):x + 4] = 0
    return image


def test_membrane_map_segmentation_warns_when_its_count_is_implausible():
    from hexatissue.errors import FrameWarning
    from hexatissue.mesh.segment import basin_count, segment_membrane_map

    shape = (240, 300)
    truth = voronoi_labels(jittered_seeds(shape, 16, seed=3), shape)
    n_truth = len(np.unique(truth))  # 270
    # every junction broken: about half the cells found, as on a two-class map with 143 cells of 343
    intact, broken = broken_membranes(truth, 0.0), broken_membranes(truth, 1.0)
    assert abs(basin_count(broken) / n_truth - 1) < 0.1  # the basins see through the gaps (measured 258)
    with warnings.catch_warnings():
        warnings.simplefilter("error", HexatissueWarning)
        assert abs(len(np.unique(segment_membrane_map(intact))) / n_truth - 1) < 0.05
    with pytest.warns(FrameWarning, match=r"fewer cells than the image's dark basins.*under-segmented") as caught:
        cells = segment_membrane_map(broken)
    n_cells = len(np.unique(cells))
    assert n_cells < 0.6 * n_truth  # measured 133: merged through the gaps
    details = [w.message.detail for w in caught if isinstance(w.message, FrameWarning)]
    assert details == [f"{n_cells} cells, {basin_count(broken)} basins"]


def test_membrane_map_over_segmentation_of_a_real_image_is_warned(real_data):
    import tifffile

    image = tifffile.imread(real_subdir(real_data, "epicure_notum") / "static_image.tif")
    with pytest.warns(HexatissueWarning, match=r"more cells than the image's dark basins.*over-segmented.*"
                                               r"\(435 cells, 190 basins\)"):
        ht.mesh_from_labels(image, kind="membrane-map")  # Cellpose finds 217 cells in this image


def test_membrane_map_warnings_of_a_movie_name_their_frames(tissue):
    broken = broken_membranes(tissue, 1.0)
    with pytest.warns(HexatissueWarning) as caught:
        ht.analyze(np.stack([broken, broken]), mesh=ht.MeshOptions(kind="membrane-map"), workers=1, progress=False)
    texts = [str(w.message) for w in caught if "membrane-map segmentation" in str(w.message)]
    assert len(texts) == 1 and texts[0].startswith("frames 0, 1: the membrane-map segmentation has fewer cells")
    assert "(frame 0: " in texts[0] and "; frame 1: " in texts[0]
