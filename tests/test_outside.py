"""Outside and background (background labels, masks, the outside of a skeleton, holes) and honest statistics.

Synthetic cases against truth computed from the drawn tissue, then real-data regressions
(../shared/data/real; skipped when absent).
"""
import json
import warnings

import numpy as np
import pandas as pd
import pytest
from scipy import ndimage

from hexatissue import Box, HexatissueWarning, InputError, MeshOptions, analyze, mesh_from_labels
from hexatissue.results import Movie
from hexatissue.mesh.labels import OUTSIDE_FACTOR, normalize_labels
from hexatissue.synthetic import draw_membranes, jittered_seeds, voronoi_labels

from .conftest import real_subdir

SHAPE = (120, 160)


@pytest.fixture(scope="module")
def tissue():
    return voronoi_labels(jittered_seeds(SHAPE, 14, seed=3), SHAPE)


def adjacent_to(region, labels):
    """Labels of the pixels 4-adjacent to ``region`` (outside it)."""
    ring = ndimage.binary_dilation(region) & ~region
    ids = set(np.unique(labels[ring]).tolist())
    return ids - {0}


def image_edge_ids(labels):
    return set(np.unique(np.r_[labels[0], labels[-1], labels[:, 0], labels[:, -1]]).tolist()) - {0}


def border_set(frame):
    return set(frame.cells.loc[frame.cells["is_border"], "cell"].tolist())


def majority(regions, labels):
    """Majority label of ``labels`` under each region id of ``regions``."""
    out = {}
    for r, idx in ndimage.value_indices(regions).items():
        if r:
            out[int(r)] = int(np.bincount(labels[idx]).argmax())
    return out


# --- background labels ---------------------------------------------------------------------

def test_rim_background_label_is_outside(tissue):
    rim = int(tissue.max()) + 1
    labels = tissue.copy()
    inside = np.zeros(SHAPE, bool)
    inside[20:100, 25:135] = True
    labels[~inside] = rim  # a hand-labelled background label around the tissue
    as_cell = mesh_from_labels(labels, outside="none")
    assert rim in set(as_cell.cells["cell"]) and border_set(as_cell) == image_edge_ids(labels)
    # by default the rim (touching the image edge, > 20 x the median cell area) is found as the outside, with a
    # warning naming the flags; the same network as when it is named
    with pytest.warns(HexatissueWarning, match=f"label {rim} touches the image edge.*--outside none.*--background"):
        found = mesh_from_labels(labels)
    f = mesh_from_labels(labels, background=(rim,))
    for name in ("cells", "edges", "vertices"):
        pd.testing.assert_frame_equal(getattr(found, name), getattr(f, name))
    assert rim not in set(f.cells["cell"])
    # truth: the cells next to the rim; the same network as with the rim drawn as 0
    assert border_set(f) == adjacent_to(~inside, labels) - {rim}
    zeroed = mesh_from_labels(np.where(labels == rim, 0, labels))
    for name in ("cells", "edges", "vertices"):
        pd.testing.assert_frame_equal(getattr(f, name), getattr(zeroed, name))


def test_background_on_membrane_labels_and_periodic_box(tissue):
    labels = draw_membranes(tissue, 1)
    rim = int(tissue.max()) + 1
    labels[:, :30] = rim
    f = mesh_from_labels(labels, background=[rim], kind="membrane")
    assert rim not in set(f.cells["cell"])
    assert f.cells.loc[f.cells["x"] < 33, "is_border"].all()
    # on a torus only the cells next to the background are border cells
    per = voronoi_labels(jittered_seeds(SHAPE, 14, seed=4), SHAPE, periodic=True)
    inner = int(per[60, 80])
    g = mesh_from_labels(per, box=Box.from_shape(SHAPE), background=(inner,))
    assert border_set(g) == adjacent_to(per == inner, per)


# --- holes between touching cells -------------------------------------------------------------

def test_fill_holes_closes_pockets_between_touching_cells(tissue):
    ref = mesh_from_labels(tissue)
    holed = tissue.copy()
    centres = ref.vertices.loc[(ref.vertices["degree"] == 3) & ~ref.vertices["is_border"], ["y", "x"]]
    centres = np.round(centres.to_numpy()).astype(int)[::3]
    rr, cc = np.mgrid[: SHAPE[0], : SHAPE[1]]
    for y, x in centres:
        holed[(rr - y) ** 2 + (cc - x) ** 2 <= 10] = 0  # 37-px pockets at triple junctions
    sizes = np.bincount(ndimage.label(holed == 0)[0].ravel())[1:]
    assert sizes.min() > 16  # (neighbouring pockets may merge)
    default = mesh_from_labels(holed)  # 16 px: these pockets stay and make border cells
    assert border_set(default) > border_set(ref)
    filled = mesh_from_labels(holed, fill_holes=int(sizes.max()) + 1)
    assert border_set(filled) == border_set(ref) == image_edge_ids(tissue)
    assert set(filled.cells["cell"]) == set(ref.cells["cell"])
    np.testing.assert_allclose(filled.cells["area"].sum(), SHAPE[0] * SHAPE[1])
    # 0 disables filling, even of a 1-px hole
    one = tissue.copy()
    y, x = centres[0]
    one[y, x] = 0
    assert border_set(mesh_from_labels(one, fill_holes=0)) > border_set(ref)
    assert border_set(mesh_from_labels(one)) == border_set(ref)


def test_pockets_on_the_image_edge_are_not_holes(tissue):
    labels = tissue.copy()
    labels[50:56, :4] = 0  # a notch open to the image edge
    lab, _ = normalize_labels(labels, fill_holes=1000)
    assert (lab[50:56, :4] == 0).all()
    # on a torus a pocket across the box edge is one pocket (18 px): a hole only for fill_holes > 18
    bands = np.ones((20, 20), np.int32)
    bands[:, 10:] = 2
    bands[5:8, :3] = bands[5:8, 17:] = 0
    assert (normalize_labels(bands, periodic=True, fill_holes=18)[0] == 0).sum() == 18
    assert normalize_labels(bands, periodic=True, fill_holes=19)[0].all()


# --- masks -----------------------------------------------------------------------------------

@pytest.mark.parametrize("periodic", [False, True], ids=["open", "periodic"])
def test_mask_cuts_the_tissue(periodic):
    labels = voronoi_labels(jittered_seeds(SHAPE, 14, seed=5), SHAPE, periodic=periodic)
    rr, cc = np.mgrid[: SHAPE[0], : SHAPE[1]]
    mask = (rr - 60) ** 2 + (cc - 80) ** 2 < 45**2
    box = Box.from_shape(SHAPE) if periodic else None
    f = mesh_from_labels(labels, box=box, mask=mask)
    cut = set(np.unique(labels[mask]).tolist()) & set(np.unique(labels[~mask]).tolist())
    assert set(f.cells["cell"]) == set(np.unique(labels[mask]).tolist())  # the cells outside vanish
    assert border_set(f) == cut  # cells along the mask's edge, and only they, are border cells
    full = mesh_from_labels(labels, box=box).cells.set_index("cell")
    kept = f.cells.set_index("cell")
    whole = sorted(set(kept.index) - cut)
    np.testing.assert_array_equal(kept.loc[whole, "area"], full.loc[whole, "area"])
    np.testing.assert_array_equal(kept.loc[whole, "n_sides"], full.loc[whole, "n_sides"])
    assert kept["area"].sum() == mask.sum()


def test_mask_on_membranes_does_not_leak(tissue):
    labels = draw_membranes(tissue, 1)
    mask = np.zeros(SHAPE, bool)
    mask[10:110, 30:130] = True
    lab, membrane = normalize_labels(labels, kind="membrane", mask=mask)
    assert not lab[~mask].any() and not membrane[~mask].any()
    f = mesh_from_labels(labels, kind="membrane", mask=mask.astype(np.uint8) * 255)
    assert f.cells["area"].sum() == mask.sum()
    assert border_set(f) == set(np.unique(lab[mask & ~ndimage.binary_erosion(mask)]).tolist()) - {0}


def test_bad_masks_and_options(tissue):
    with pytest.raises(InputError, match="mask must have the shape"):
        mesh_from_labels(tissue, mask=np.ones((3, 3), bool))
    with pytest.raises(InputError, match="mask is all zeros"):
        mesh_from_labels(tissue, mask=np.zeros(SHAPE, bool))
    with pytest.raises(InputError, match="mask must be a 2-D bool"):
        mesh_from_labels(tissue, mask=np.full(SHAPE, "a"))
    with pytest.raises(InputError, match="no cell is left"):
        mesh_from_labels(tissue, background=np.unique(tissue).tolist())
    with pytest.raises(InputError, match="fill_holes"):
        mesh_from_labels(tissue, fill_holes=-1)
    with pytest.raises(InputError, match="outside"):
        mesh_from_labels(tissue, outside="inside")
    with pytest.raises(InputError, match="background"):
        mesh_from_labels(tissue, background=(-1,))
    for field, value in (("background", ("a",)), ("fill_holes", 2.5), ("outside", "yes")):
        with pytest.raises(InputError, match=f"MeshOptions.{field}"):
            MeshOptions(**{field: value})
    opts = MeshOptions(background=[7, 3, 7], fill_holes=500, outside="none")
    assert opts.background == (3, 7)
    assert MeshOptions.from_dict(json.loads(json.dumps(opts.to_dict()))) == opts


# --- the outside of a skeleton -----------------------------------------------------------------

def masked_skeleton(tissue, seeds_inside):
    """Junction lines around the Voronoi cells whose seeds lie in a rectangle: a skeleton of a masked tissue.

    Returns the skeleton (255 = line), the tissue labels (0 outside) and the
    tissue region.
    """
    rows, cols = np.nonzero(tissue)
    region = np.zeros(tissue.shape, bool)
    keep = np.isin(tissue, seeds_inside)
    region[keep] = True
    lab = np.where(region, tissue, 0)
    lines = (draw_membranes(lab, 2) == 0) & region  # cell-cell lines 2 px, the tissue outline 1 px
    return (lines * 255).astype(np.uint8), lab, region


def test_outer_region_of_a_skeleton_is_outside(tissue):
    seeds = jittered_seeds(SHAPE, 14, seed=3)
    ids = np.unique(tissue)
    centre = np.array([tissue[int(round(y)), int(round(x))] for x, y in seeds if 25 < y < 95 and 30 < x < 130])
    skeleton, lab, region = masked_skeleton(tissue, centre)
    kept = mesh_from_labels(skeleton, outside="none")
    outer_area = kept.cells["area"].max()
    assert outer_area > OUTSIDE_FACTOR * kept.cells["area"].median()
    outer = int(kept.cells.loc[kept.cells["area"].idxmax(), "cell"])
    assert border_set(kept) == {outer}  # kept as a cell, the outside hides the tissue's edge
    f = mesh_from_labels(skeleton)  # outside="auto"
    assert len(f.cells) == len(kept.cells) - 1 == len(set(centre)) and outer not in set(f.cells["cell"])
    # truth: the tissue cells next to the outside are the border cells
    regions, _ = normalize_labels(skeleton)
    to_tissue = majority(regions, lab)
    assert sorted(to_tissue.values()) == sorted(set(centre)) and set(centre) < set(ids)
    assert {to_tissue[c] for c in border_set(f)} == adjacent_to(~region, lab)
    # a full-frame skeleton loses nothing
    full = (draw_membranes(tissue, 1) == 0).astype(np.uint8)
    pd.testing.assert_frame_equal(mesh_from_labels(full).cells, mesh_from_labels(full, outside="none").cells)


# --- analyze and the command line ------------------------------------------------------------

def test_analyze_with_mask_path_and_cli(tissue, tmp_path):
    import tifffile

    from hexatissue.cli import main
    from hexatissue.results import read_results

    rim = int(tissue.max()) + 1
    labels = tissue.copy()
    labels[:, :20] = rim
    mask = np.zeros(SHAPE, np.uint8)
    mask[:, :130] = 1
    tifffile.imwrite(tmp_path / "labels.tif", labels.astype(np.uint16))
    tifffile.imwrite(tmp_path / "mask.tif", mask)
    mesh = MeshOptions(background=(rim,), fill_holes=50)
    movie = analyze(tmp_path / "labels.tif", mesh=mesh, mask=tmp_path / "mask.tif", workers=1, progress=False)
    truth = mesh_from_labels(labels, background=(rim,), fill_holes=50, mask=mask)
    pd.testing.assert_frame_equal(movie.cells[truth.cells.columns].drop(columns="frame").reset_index(drop=True),
                                  truth.cells.drop(columns="frame"), check_dtype=False)
    assert movie.source["mask"] == {"path": str(tmp_path / "mask.tif"), "shape": list(SHAPE),
                                    "inside": int(mask.sum())}
    assert main(["analyze", str(tmp_path / "labels.tif"), "--out", str(tmp_path / "out"), "--background", str(rim),
                 "--mask", str(tmp_path / "mask.tif"), "--fill-holes", "50", "--outside", "none",
                 "--workers", "1"]) == 0
    back = read_results(tmp_path / "out")
    assert back.options["mesh"] == MeshOptions(background=(rim,), fill_holes=50, outside="none")
    assert back.source["mask"]["inside"] == int(mask.sum())
    pd.testing.assert_frame_equal(back.cells[["cell", "is_border"]], movie.cells[["cell", "is_border"]])
    with pytest.raises(InputError, match="mask"):
        analyze(labels, mask=np.ones((5, 5), bool), workers=1, progress=False)


# --- statistics that mislead --------------------------------------------------------------------

def test_enclosed_cells_give_no_zero_length_loop():
    labels = np.ones((30, 30), np.int32)
    labels[:, 15:] = 2
    labels[8:14, 4:10] = 3  # enclosed by cell 1: a boundary with no vertex
    labels[20:24, 20:24] = 0  # a hole (16 px, not filled) in cell 2
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HexatissueWarning)
        f = mesh_from_labels(labels)
    e = f.edges
    assert not ((e["vertex_a"] == e["vertex_b"]) & (e["length"] == 0)).any()
    assert (f.vertices["degree"] >= 2).all() and set(f.vertices["vertex"]) == set(e["vertex_a"]) | set(e["vertex_b"])
    c = f.cells.set_index("cell")
    assert c.loc[3, "n_sides"] == 0 and np.isnan(c.loc[3, "polygon_area"]) and not c.loc[3, "is_border"]
    assert c.loc[1, "n_boundaries"] == 2 and c.loc[2, "n_boundaries"] == 2 and c.loc[2, "is_border"]
    # a loop around a periodic box is a real junction (the bands' contact)
    bands = np.ones((10, 12), np.int32)
    bands[:, 6:] = 2
    g = mesh_from_labels(bands, box=Box(12, 10))
    assert len(g.edges) == 2 and np.allclose(g.edges["length"], 10.0)


def test_report_mean_sides_leaves_out_fragments(tissue, tmp_path):
    from hexatissue.workflows.report import report

    labels = tissue.copy()
    f0 = mesh_from_labels(labels)
    host = int(f0.cells.loc[~f0.cells["is_border"]].sort_values("area")["cell"].iloc[-1])
    ys, xs = np.nonzero(labels == host)
    y, x = int(np.median(ys)), int(np.median(xs))
    labels[y - 1:y + 2, x - 1:x + 2] = labels.max() + 1  # a 9-px fragment inside an interior cell
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HexatissueWarning)
        f = mesh_from_labels(labels)
    inner = f.cells[~f.cells["is_border"]]
    assert (inner["n_sides"] == 0).sum() == 1
    expected = inner.loc[inner["n_sides"] >= 3, "n_sides"].mean()
    numbers = report(Movie.from_frames([f]), tmp_path / "rep")
    assert numbers["mean_sides"] == pytest.approx(expected) and numbers["fragments_left_out"] == 1
    text = (tmp_path / "rep" / "report.md").read_text()
    assert f"n_sides >= 3): {expected:.3f}; 1 interior fragment(s)" in text


def test_cycle_histogram_keeps_the_longest_cycles():
    from hexatissue.views.events import plot_event_overview

    durations = np.r_[np.arange(1, 40), 95, 96]
    events = pd.DataFrame({"kind": "cycle", "frame_start": np.arange(len(durations)), "duration": durations})
    fig = plot_event_overview(events, n_frames=200)
    counts = [p.get_height() for p in fig.axes[1].patches]
    assert sum(counts) == len(durations)


def test_migration_figure_follows_the_verdict():
    from hexatissue.analysis import migration_populations, plot_migration

    rng = np.random.default_rng(0)
    one = pd.DataFrame({"displacement": 10 ** rng.normal(-2, 0.2, 200), "msd": np.ones(200),
                        "defect_density": rng.uniform(0, 1e-3, 200), "n_cells": np.ones(200)})
    pops = migration_populations(one, seed=0)
    assert not pops.two_populations
    fig = plot_migration(pops)
    texts = [t.get_text() for ax in fig.axes for t in ax.get_legend().get_texts()]
    titles = " ".join(ax.get_title() for ax in fig.axes)
    assert not any("slow" in t or "fast" in t for t in texts) and "split at" not in titles
    assert pops.verdict in titles
    two = pd.DataFrame({"displacement": 10 ** np.r_[rng.normal(-3, 0.1, 100), rng.normal(-1, 0.1, 100)],
                        "msd": np.ones(200), "defect_density": rng.uniform(0, 1e-3, 200), "n_cells": np.ones(200)})
    pops2 = migration_populations(two, seed=0)
    assert pops2.two_populations
    fig2 = plot_migration(pops2)
    texts2 = [t.get_text() for t in fig2.axes[0].get_legend().get_texts()]
    assert texts2 == ["slow", "fast"] and "split at" in fig2.axes[0].get_title()


def test_timing_ticks_are_categories_and_title_has_p():
    from hexatissue.analysis import plot_timing, timing_test

    rng = np.random.default_rng(1)
    table = pd.DataFrame({"mean_intercalation_interval": rng.uniform(5, 10, 30),
                          "mean_cycle_period": rng.uniform(8, 14, 30)})
    fig = plot_timing(table)
    ax = fig.axes[0]
    assert [t.get_text() for t in ax.get_xticklabels()] == ["between\nintercalations", "T1-cycle\nperiod"]
    assert f"p = {timing_test(table)['pvalue']:.2g}" in ax.get_title()
    runs = plot_timing({1e-5: table, 4e-5: table}).axes[0]
    assert [t.get_text() for t in runs.get_xticklabels()] == ["D_r=1e-05", "D_r=4e-05"]
    assert "D_r=1e-05: " in runs.get_title()


# --- real data ----------------------------------------------------------------------------------

def test_skeletor_outside_is_not_a_cell(real_data):
    import tifffile

    folder = real_subdir(real_data, "skeletor_pupal_abdomen")
    skeleton = tifffile.imread(folder / "Final_Skeleton" / "Final_Skeleton_Frame_1.tif")
    f = mesh_from_labels(skeleton)
    # SOURCE.md: 530 enclosed regions including the outside; the outside was cell 1 (498,793 px^2, 75 sides)
    assert len(f.cells) == 529 and 1 not in set(f.cells["cell"])
    assert f.cells["area"].max() < 30_000  # the largest LECs are about 25,000 px^2
    n_interior = int((~f.cells["is_border"]).sum())
    assert 400 < n_interior < 500  # measured 460: the ring of cells along the tissue outline is border
    kept = mesh_from_labels(skeleton, outside="none")
    assert kept.cells["area"].max() > 490_000 and (~kept.cells["is_border"]).sum() == 528


def test_itasc_fill_holes_leaves_only_the_real_edge_cells(real_data):
    import tifffile

    folder = real_subdir(real_data, "itasc_micropattern")
    stack = tifffile.imread(folder / "pos02" / "cell_labels.tif")
    for t in (0, 5):
        labels = stack[t].astype(np.int64)
        zero, _ = ndimage.label(labels == 0)
        outer = zero == np.bincount(zero.ravel())[1:].argmax() + 1  # the outside of the island
        edge_cells = adjacent_to(outer, labels)
        before = border_set(mesh_from_labels(labels))
        after = border_set(mesh_from_labels(labels, fill_holes=1000))  # largest hole: 886 px (frame 5)
        assert len(before) > 40 and after == edge_cells and len(after) == 24


def test_cellpose_mean_sides_without_fragments(real_data):
    import tifffile

    folder = real_subdir(real_data, "epicure_notum")
    f = mesh_from_labels(tifffile.imread(folder / "static_image_cellpose.tif"))
    inner = f.cells[~f.cells["is_border"]]
    assert inner["n_sides"].mean() == pytest.approx(5.756, abs=5e-4)  # with the 3 two-vertex fragments
    polygons = inner[inner["n_sides"] >= 3]
    assert len(inner) - len(polygons) == 3 and polygons["n_sides"].mean() == pytest.approx(5.866, abs=5e-4)
    # polygon_area and perimeter: finite exactly for cells with a polygon
    c = f.cells
    assert (np.isfinite(c["polygon_area"]) == (c["n_sides"] >= 3)).all()
    assert (np.isfinite(c["perimeter"]) == (c["n_sides"] >= 3)).all()


def test_epicure_has_no_zero_length_self_loops(real_data):
    folder = real_subdir(real_data, "epicure_notum")
    stack = np.load(folder / "013_crop_labels_copy.npz")["labels"]
    for t in range(3):
        f = mesh_from_labels(stack[t])
        e = f.edges
        assert not (e["vertex_a"] == e["vertex_b"]).any()
        assert (e["length"] > 0).all()
        assert (f.vertices.set_index("vertex").loc[np.r_[e["vertex_a"], e["vertex_b"]], "degree"] >= 2).all()
        c = f.cells
        assert (np.isfinite(c["polygon_area"]) == (c["n_sides"] >= 3)).all()


# --- the outside wherever it is: a region enclosing the tissue, edge or not ------------------

def _ringed(tissue, rim, width):
    """The tissue cut to a disc, a rim label ``width`` px wide around it, 0 beyond: nothing of the rim on the edge."""
    rr, cc = np.mgrid[: SHAPE[0], : SHAPE[1]]
    r = np.hypot(rr - SHAPE[0] / 2, cc - SHAPE[1] / 2)
    labels = np.where(r < 50, tissue, 0)
    labels[(r >= 50) & (r < 50 + width)] = rim
    return labels, r < 50


@pytest.mark.parametrize("width", [6, 8])
def test_a_rim_label_that_misses_the_image_edge_is_the_outside(tissue, width):
    rim = int(tissue.max()) + 1
    labels, disc = _ringed(tissue, rim, width)
    ids, areas = np.unique(labels[labels > 0], return_counts=True)
    ratio = areas[ids == rim][0] / np.median(areas[ids != rim])
    assert 10 < ratio < OUTSIDE_FACTOR and rim not in image_edge_ids(labels)  # the old rule missed it
    with pytest.warns(HexatissueWarning, match=f"label {rim} encloses the tissue .*--outside none.*--background"):
        found = mesh_from_labels(labels)
    named = mesh_from_labels(labels, background=(rim,))
    for name in ("cells", "edges", "vertices"):
        pd.testing.assert_frame_equal(getattr(found, name), getattr(named, name))
    # truth: the cells of the disc next to the rim are the border cells, every other cell is interior
    assert rim not in set(found.cells["cell"]) and border_set(found) == adjacent_to(labels == rim, labels)
    kept = mesh_from_labels(labels, outside="none")
    assert rim in set(kept.cells["cell"]) and border_set(kept) == {rim}


def test_a_skeleton_drawn_along_the_image_edge_loses_its_outside(tissue):
    seeds = jittered_seeds(SHAPE, 14, seed=3)
    centre = np.array([tissue[int(round(y)), int(round(x))] for x, y in seeds if 25 < y < 95 and 30 < x < 130])
    skeleton, lab, region = masked_skeleton(tissue, centre)
    skeleton[[0, -1], :] = skeleton[:, [0, -1]] = 255  # a frame line: the outside no longer touches the edge
    f = mesh_from_labels(skeleton)
    assert len(f.cells) == len(set(centre))
    regions, _ = normalize_labels(skeleton)
    to_tissue = majority(regions, lab)
    assert sorted(to_tissue.values()) == sorted(set(centre))
    assert {to_tissue[c] for c in border_set(f)} == adjacent_to(~region, lab)


def test_no_ordinary_cell_is_taken_for_the_outside(tissue):
    # a cell holding another inside it (one region in its hole) and a big merged cell in a full tissue stay cells
    labels = tissue.copy()
    inner = int(labels[60, 80])
    nested = labels.copy()
    nested[55:66, 74:87] = int(tissue.max()) + 1
    merged = np.where(np.isin(labels, np.unique(labels[40:80, 50:110])), inner, labels)
    for case in (nested, merged, tissue):
        with warnings.catch_warnings():
            warnings.simplefilter("error", HexatissueWarning)
            lab, _ = normalize_labels(case)
        np.testing.assert_array_equal(lab, case)


def test_holes_left_in_the_tissue_are_reported_with_their_sizes_and_the_flag(tissue, tmp_path):
    from hexatissue.errors import FrameWarning

    holed = tissue.copy()
    holed[40:46, 60:66] = 0  # 36 px
    holed[80:85, 100:110] = 0  # 50 px
    with pytest.warns(FrameWarning, match=r"holes of background 0 inside the tissue.*--fill-holes AREA") as caught:
        f = mesh_from_labels(holed)
    assert [w.message.detail for w in caught if isinstance(w.message, FrameWarning)] == \
        [f"2 hole(s): 50, 36 px; median cell {np.median(np.unique(tissue, return_counts=True)[1]):.0f} px"]
    assert border_set(f) > image_edge_ids(tissue)
    with warnings.catch_warnings():
        warnings.simplefilter("error", HexatissueWarning)
        filled = mesh_from_labels(holed, fill_holes=51)  # asked: no hint
        mesh_from_labels(holed, fill_holes=0)  # filling switched off: nothing was asked
        mesh_from_labels(np.where(np.arange(SHAPE[1]) < 40, 0, tissue))  # background open to the image edge
    assert border_set(filled) == image_edge_ids(tissue)
    # through analyze: one warning, the frames named, each frame's holes
    stack = np.stack([holed, holed, tissue]).astype(np.int32)
    with pytest.warns(HexatissueWarning, match=r"^frames 0, 1: holes of background 0.*\(frame 0: 2 hole\(s\): 50, "
                                               r"36 px; .*; frame 1: 2 hole\(s\): 50, 36 px;") as caught:
        analyze(stack, workers=1, progress=False)
    assert sum("holes of background 0" in str(w.message) for w in caught) == 1


def test_forsys_skeletons_lose_the_outside_that_misses_the_image_edge(real_data):
    from hexatissue import open_source

    folder = real_subdir(real_data, "forsys_skeletons")
    for t in range(5):
        source = open_source(folder / f"in_vivo_t_{t}.tif.gz")  # read through gzip
        assert source.description["path"].endswith(f"in_vivo_t_{t}.tif.gz")
        skeleton = source.frame(0)
        f = mesh_from_labels(skeleton)
        # SOURCE.md: 49 enclosed regions in every frame; one of them is the outside (about 407,000 px)
        regions, n = ndimage.label(skeleton == 0)
        assert n == 49 and len(f.cells) == 48 and f.cells["area"].max() < 20_000
        kept = mesh_from_labels(skeleton, outside="none")
        assert kept.cells["area"].max() > 400_000 and (~kept.cells["is_border"]).sum() == 48
        assert 10 < f.cells["is_border"].sum() < 40  # the cells along the outline (24 in frame 0)


def test_itasc_holes_are_reported_and_fill_holes_clears_them(real_data):
    import tifffile

    folder = real_subdir(real_data, "itasc_micropattern")
    labels = tifffile.imread(folder / "pos02" / "cell_labels.tif")[0].astype(np.int64)
    with pytest.warns(HexatissueWarning, match=r"--fill-holes AREA.*9 hole\(s\): 336, 219, 182, 59, \.\.\. px"):
        mesh_from_labels(labels)
    with warnings.catch_warnings():
        warnings.simplefilter("error", HexatissueWarning)
        lab, _ = normalize_labels(labels, fill_holes=337)
