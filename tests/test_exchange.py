"""Exchange formats: CTC folders, GEFF graphs, OME-Zarr label stacks, ``hexatissue export``."""
import itertools
import json
import shutil
from collections import Counter
from pathlib import Path

import networkx as nx
import numpy as np
import pandas as pd
import pytest
import tifffile

import hexatissue as ht
from hexatissue.cli import main
from hexatissue.errors import InputError
from hexatissue.exchange.ctc import check_ctc, read_ctc, write_ctc
from hexatissue.exchange.geff import geff_tables, read_geff, write_geff
from hexatissue.exchange.labels import track_masks
from hexatissue.exchange.omezarr import (LABELS_KEY, boundary_image, downsample_labels, label_colors,
                                         write_ome_zarr_labels)
from hexatissue.graph import neighbour_graph
from hexatissue.options import OrderOptions
from hexatissue.readers.ctc import gap_links
from hexatissue.synthetic import jittered_seeds, voronoi_labels

from .conftest import real_subdir

SAMPLE = Path(__file__).resolve().parents[1] / "hexatissue" / "sample_data" / "epicure_notum" / "013_crop_labels.tif"
NO_FIELDS = OrderOptions(fields=False)


# ---------------------------------------------------------------------------------------------------------
# a scripted movie with a division and a gap, and its exact CTC content
# ---------------------------------------------------------------------------------------------------------
def scripted_masks():
    """6 frames of 20 x 20: track 1 (missing in frame 1), mother 2 (frames 0-2) -> daughters 3, 4 (3-5)."""
    m = np.zeros((6, 20, 20), np.int32)
    m[:, :10, :10] = 1
    m[1, :10, :10] = 0
    m[:3, 10:, :] = 2
    m[3:, 10:, :10] = 3
    m[3:, 10:, 10:] = 4
    lineage = pd.DataFrame({"track": [1, 2, 3, 4], "parent": [0, 0, 2, 2]})
    return m, lineage


# track 1's second part (frames 2-5) is a new track 5 whose parent is 1: the format has no gaps
SCRIPTED_LINES = "1 0 0 0\n2 0 2 0\n3 3 5 2\n4 3 5 2\n5 2 5 1\n"


def test_write_ctc_splits_gaps_and_writes_the_exact_track_file(tmp_path):
    masks, lineage = scripted_masks()
    folder = write_ctc(masks, lineage, tmp_path)
    assert folder == tmp_path
    assert (tmp_path / "res_track.txt").read_text() == SCRIPTED_LINES
    assert sorted(p.name for p in tmp_path.glob("mask*.tif")) == [f"mask{t:03d}.tif" for t in range(6)]
    check_ctc(tmp_path)
    stored, tracks = read_ctc(tmp_path)
    assert stored.dtype == np.uint16
    expected = masks.copy()
    expected[2:][expected[2:] == 1] = 5
    np.testing.assert_array_equal(stored, expected)
    assert tracks.values.tolist() == [[int(v) for v in line.split()] for line in SCRIPTED_LINES.splitlines()]
    same, parents = gap_links(tracks)
    assert same == {5: 1} and parents == {3: 2, 4: 2}


def test_ctc_round_trip_through_open_source_gives_back_the_tracks_and_parents(tmp_path):
    masks, lineage = scripted_masks()
    write_ctc(masks, lineage, tmp_path / "res")
    source = ht.open_source(tmp_path / "res")
    assert source.ids_consistent and source.parents == {3: 2, 4: 2}
    assert source.description["kind"] == "ctc" and source.description["layout"] == "result"
    np.testing.assert_array_equal(np.stack([source.frame(t) for t in range(6)]), masks)  # gap merged back


def test_ctc_truth_layout(tmp_path):
    masks, lineage = scripted_masks()
    folder = write_ctc(masks, lineage, tmp_path, truth=True)
    assert folder == tmp_path / "TRA"
    assert (folder / "man_track.txt").read_text() == SCRIPTED_LINES
    assert sorted(p.name for p in folder.glob("*.tif")) == [f"man_track{t:03d}.tif" for t in range(6)]
    seg = sorted((tmp_path / "SEG").glob("*.tif"))  # the reference segmentation of every frame: the TRA masks
    assert [p.name for p in seg] == [f"man_seg{t:03d}.tif" for t in range(6)]
    for t, p in enumerate(seg):
        np.testing.assert_array_equal(tifffile.imread(p), tifffile.imread(folder / f"man_track{t:03d}.tif"))
    check_ctc(tmp_path)
    check_ctc(folder)
    assert ht.open_source(tmp_path).description["layout"] == "truth"
    assert ht.open_source(folder).parents == {3: 2, 4: 2}


def test_check_ctc_checks_the_seg_folder_of_a_ground_truth(tmp_path):
    masks, lineage = scripted_masks()
    write_ctc(masks, lineage, tmp_path, truth=True)
    (tmp_path / "SEG" / "man_seg002.tif").unlink()  # the CTC annotates a subset of frames: allowed
    check_ctc(tmp_path)
    (tmp_path / "SEG" / "man_seg003.tif").rename(tmp_path / "SEG" / "man_seg0003.tif")
    tifffile.imwrite(tmp_path / "SEG" / "man_seg009.tif", masks[0].astype(np.uint16))
    tifffile.imwrite(tmp_path / "SEG" / "man_seg004.tif", masks[0, :10].astype(np.uint16))
    with pytest.raises(InputError) as info:
        check_ctc(tmp_path)
    text = str(info.value)
    assert "3 violation(s)" in text and "SEG/man_seg0003.tif: expected a frame number of 3 digits below 6" in text
    assert "SEG/man_seg009.tif: expected" in text and "SEG/man_seg004.tif is (10, 20); expected (20, 20)" in text


def test_ctc_truth_export_refuses_a_foreign_seg_folder_before_writing(tmp_path):
    masks, lineage = scripted_masks()
    (tmp_path / "SEG").mkdir()
    tifffile.imwrite(tmp_path / "SEG" / "man_seg000.tif", np.ones((4, 4), np.uint16))  # someone's annotation
    with pytest.raises(InputError, match="not an earlier output"):
        write_ctc(masks, lineage, tmp_path, truth=True)
    assert not (tmp_path / "TRA").exists() and tifffile.imread(tmp_path / "SEG" / "man_seg000.tif").shape == (4, 4)
    write_ctc(masks, lineage, tmp_path, truth=True, overwrite=True)
    check_ctc(tmp_path)


def test_ctc_evaluate_seg_measures_a_result_against_the_truth_export(tmp_path):
    """py-ctcmetrics' ``ctc_evaluate --seg --tra --det`` on the ground-truth export: its own result scores 1; a
    result missing a quarter of one cell in one frame scores SEG = (13 + 0.75) / 14 (14 reference cell-frames)."""
    evaluate = pytest.importorskip("ctc_metrics.scripts.evaluate")
    masks, lineage = scripted_masks()
    write_ctc(masks, lineage, tmp_path / "gt", truth=True)
    write_ctc(masks, lineage, tmp_path / "res")
    scores = evaluate.evaluate_sequence(str(tmp_path / "res"), str(tmp_path / "gt"), ["SEG", "TRA", "DET"], threads=1)
    assert (scores["SEG"], scores["TRA"], scores["DET"], scores["AOGM"]) == (1.0, 1.0, 1.0, 0.0)
    eroded = masks.copy()
    eroded[0, 10:15, :10] = 0  # 50 of track 2's 200 px in frame 0: IoU 0.75
    write_ctc(eroded, lineage, tmp_path / "res2")
    scores = evaluate.evaluate_sequence(str(tmp_path / "res2"), str(tmp_path / "gt"), ["SEG"], threads=1)
    assert scores["SEG"] == pytest.approx((13 + 0.75) / 14, rel=1e-12)


def test_ctc_uses_four_digits_beyond_1000_frames(tmp_path):
    masks = np.ones((1001, 2, 2), np.uint8)
    write_ctc(masks, pd.DataFrame({"track": [1], "parent": [0]}), tmp_path)
    names = sorted(p.name for p in tmp_path.glob("mask*.tif"))
    assert names[0] == "mask0000.tif" and names[-1] == "mask1000.tif" and len(names) == 1001
    assert (tmp_path / "res_track.txt").read_text() == "1 0 1000 0\n"


def test_write_ctc_removes_masks_of_an_earlier_longer_export(tmp_path):
    masks, lineage = scripted_masks()
    write_ctc(masks, lineage, tmp_path)
    write_ctc(masks[:3], lineage, tmp_path)
    assert sorted(p.name for p in tmp_path.glob("mask*.tif")) == [f"mask{t:03d}.tif" for t in range(3)]
    check_ctc(tmp_path)


def test_write_ctc_refuses_bad_input(tmp_path):
    masks, lineage = scripted_masks()
    with pytest.raises(InputError, match="lineage has no row for track"):
        write_ctc(masks, lineage[lineage["track"] != 4], tmp_path)
    with pytest.raises(InputError, match="16-bit"):
        write_ctc(masks * 70000, lineage, tmp_path)
    with pytest.raises(InputError, match="non-integer"):
        write_ctc(masks + 0.5, lineage, tmp_path)
    with pytest.raises(InputError, match="lineage is missing column"):
        write_ctc(masks, lineage.drop(columns="parent"), tmp_path)
    with pytest.raises(InputError, match="T x Y x X"):
        write_ctc(masks[0], lineage, tmp_path)


# corruptions of the track file: (text replaced, replacement)
LINE_EDITS = {"no parent line": ("5 2 5 1", "5 2 5 9"), "parent too late": ("2 0 2 0", "2 0 3 0"),
              "duplicate id": ("5 2 5 1\n", "5 2 5 1\n3 3 5 2\n"), "malformed line": ("5 2 5 1\n", "5 2 5 1\n7 3 x\n"),
              "unlisted id": ("4 3 5 2\n", ""), "gap in a line": ("1 0 0 0", "1 0 5 0"),
              "line never in masks": ("5 2 5 1\n", "5 2 5 1\n8 0 1 0\n")}


def _corrupt(folder, how):
    if how in LINE_EDITS:
        track_file = folder / "res_track.txt"
        track_file.write_text(track_file.read_text().replace(*LINE_EDITS[how]))
    elif how == "missing file":
        (folder / "mask004.tif").unlink()
    elif how == "extra frame":  # track 1 back in frame 1, outside its line 0..0
        tifffile.imwrite(folder / "mask001.tif", tifffile.imread(folder / "mask000.tif"))
    elif how == "digits":
        (folder / "mask005.tif").rename(folder / "mask0005.tif")
    return folder


CORRUPTIONS = {
    "missing file": "numbered 0..5; missing \\[4\\]",
    "extra frame": "track 1: its line says frames 0..0; present in frame\\(s\\) \\[1",
    "no parent line": "track 5: parent 9 has no line",
    "parent too late": "parent 2 ends at frame 3, not before its child begins \\(3\\)",
    "duplicate id": "track id\\(s\\) \\[3\\] have several lines",
    "malformed line": "line 6 is '7 3 x'; expected four non-negative integers",
    "unlisted id": "mask id\\(s\\) \\[4\\] have no line",
    "gap in a line": "track 1: its line says frames 0..5; absent from frame\\(s\\) \\[1, 2, 3, 4, 5\\]",
    "line never in masks": "track 8: its line says frames 0..1 but no mask holds it",
    "digits": "have \\[3, 4\\] digits",
}


@pytest.mark.parametrize("how", sorted(CORRUPTIONS))
def test_check_ctc_names_each_kind_of_violation(tmp_path, how):
    masks, lineage = scripted_masks()
    folder = _corrupt(write_ctc(masks, lineage, tmp_path), how)
    with pytest.raises(InputError, match=CORRUPTIONS[how]):
        check_ctc(folder)
    with pytest.raises(InputError, match="breaks the format"):
        read_ctc(folder)


def test_check_ctc_lists_every_violation_in_one_message(tmp_path):
    masks, lineage = scripted_masks()
    folder = write_ctc(masks, lineage, tmp_path)
    (folder / "res_track.txt").write_text(SCRIPTED_LINES.replace("5 2 5 1", "5 2 5 9") + "3 3 5 2\n8 0 1 0\n")
    with pytest.raises(InputError) as info:
        check_ctc(folder)
    text = str(info.value)
    assert "3 violation(s)" in text
    for part in ("parent 9 has no line", "[3] have several lines", "track 8"):
        assert part in text


def test_check_ctc_refuses_a_folder_that_is_not_ctc(tmp_path):
    with pytest.raises(InputError, match="not a Cell Tracking Challenge folder"):
        check_ctc(tmp_path)
    tifffile.imwrite(tmp_path / "frame0.tif", np.ones((4, 4), np.uint8))
    assert ht.open_source(tmp_path).description["kind"] == "folder"  # a folder of frames stays one


# ---------------------------------------------------------------------------------------------------------
# a hand-made two-frame movie: squares, one dividing
# ---------------------------------------------------------------------------------------------------------
def square_movie():
    """Frame 0: a 2 x 2 grid of 40-px squares 1 2 / 3 4; frame 1: square 4 split into 5 (top) and 6 (bottom)."""
    f0 = np.zeros((80, 80), np.int32)
    f0[:40, :40], f0[:40, 40:], f0[40:, :40], f0[40:, 40:] = 1, 2, 3, 4
    f1 = f0.copy()
    f1[40:60, 40:], f1[60:, 40:] = 5, 6
    return np.stack([f0, f1])


SQUARE_CONTACTS = {0: {(1, 2), (1, 3), (2, 4), (3, 4)},  # diagonal squares meet at a point only
                   1: {(1, 2), (1, 3), (2, 5), (3, 5), (3, 6), (5, 6)}}
SQUARE_TRACK_LINKS = {((0, 1), (1, 1), False), ((0, 2), (1, 2), False), ((0, 3), (1, 3), False),
                      ((0, 4), (1, 5), True), ((0, 4), (1, 6), True)}


@pytest.fixture(scope="module")
def squares(tmp_path_factory):
    folder = tmp_path_factory.mktemp("squares")
    tifffile.imwrite(folder / "squares.tif", square_movie(), photometric="minisblack")
    movie = ht.analyze(folder / "squares.tif", order=NO_FIELDS, workers=1, progress=False)
    movie.write(folder / "results")
    return folder, movie


def _by_cell(graph):
    """A GEFF graph relabelled from node ids to (frame, cell)."""
    return nx.relabel_nodes(graph, {n: (d["frame"], d["cell"]) for n, d in graph.nodes(data=True)})


def test_geff_neighbour_graph_of_the_squares_is_the_hand_made_one(squares, tmp_path):
    _, movie = squares
    assert movie.lineage.set_index("track")["parent"].to_dict() == {1: 0, 2: 0, 3: 0, 4: 0, 5: 4, 6: 4}
    neighbours, tracks = write_geff(movie, tmp_path)
    graph, meta = read_geff(neighbours)
    g = _by_cell(graph)
    assert not g.is_directed()
    assert set(g.nodes) == {(0, c) for c in (1, 2, 3, 4)} | {(1, c) for c in (1, 2, 3, 5, 6)}
    got = {t: {tuple(sorted((a[1], b[1]))) for a, b in g.edges if a[0] == t} for t in (0, 1)}
    assert got == SQUARE_CONTACTS
    assert [(a.name, a.type, a.unit) for a in meta.axes] == [("frame", "time", "frame"), ("y", "space", "pixel"),
                                                              ("x", "space", "pixel")]
    t = _by_cell(read_geff(tracks)[0])
    assert t.is_directed()
    assert {(a, b, d["is_division"]) for a, b, d in t.edges(data=True)} == SQUARE_TRACK_LINKS
    assert all(d["frame_gap"] == 1 for *_, d in t.edges(data=True))
    assert {d["lineage"] for n, d in t.nodes(data=True) if n[1] in (4, 5, 6)} == {4}


def _expected_neighbour_graph(movie):
    """Every frame's :func:`hexatissue.graph.neighbour_graph`, nodes keyed (frame, cell), plus |gamma|, angle."""
    whole = nx.Graph()
    for t in range(movie.n_frames):
        g = neighbour_graph(movie.frame(t))
        for c, attrs in g.nodes(data=True):
            attrs = dict(attrs, cell=c, frame=t)
            for p in (6, 2):
                if f"gamma{p}_re" in attrs:
                    z = np.array([attrs[f"gamma{p}_re"] + 1j * attrs[f"gamma{p}_im"]])
                    attrs[f"gamma{p}_abs"], attrs[f"gamma{p}_angle"] = float(np.abs(z)[0]), float(np.angle(z)[0] / p)
            whole.add_node((t, c), **attrs)
        whole.add_edges_from(((t, a), (t, b), d) for a, b, d in g.edges(data=True))
    return whole


def _same_attrs(a, b):
    assert a.keys() == b.keys()
    for k in a:
        if isinstance(a[k], float) and np.isnan(a[k]):
            assert np.isnan(b[k]), k
        else:
            assert a[k] == b[k], k


def test_geff_round_trip_reproduces_nodes_edges_and_attributes_exactly(epicure, tmp_path):
    movie = epicure["movie"]
    neighbours, _ = write_geff(movie, tmp_path)
    got = _by_cell(read_geff(neighbours)[0])
    want = _expected_neighbour_graph(movie)
    assert set(got.nodes) == set(want.nodes)
    assert {frozenset(e) for e in got.edges} == {frozenset(e) for e in want.edges}
    for n in want.nodes:
        _same_attrs(got.nodes[n], want.nodes[n])
    for a, b in want.edges:
        assert got.edges[a, b] == want.edges[a, b]
    nodes, edges = geff_tables(neighbours)  # and back to tables: the cells table itself
    cells = movie.cells.sort_values(["frame", "cell"]).reset_index(drop=True)
    pd.testing.assert_frame_equal(nodes[cells.columns], cells)


def test_geff_track_graph_follows_tracks_and_divisions(epicure, tmp_path):
    movie = epicure["movie"]
    _, tracks = write_geff(movie, tmp_path)
    graph, meta = read_geff(tracks)
    g = _by_cell(graph)
    divisions = {(a[1], b[1]) for a, b, d in g.edges(data=True) if d["is_division"]}
    assert divisions == {(73, 477), (73, 490)}
    assert meta.track_node_props == {"tracklet": "track", "lineage": "lineage"}
    # every other edge joins consecutive appearances of one track, and each track is one path
    cells = movie.cells
    n_links = sum(len(f) - 1 for _, f in cells.groupby("track"))
    assert g.number_of_edges() == n_links + 2
    for a, b, d in g.edges(data=True):
        if not d["is_division"]:
            assert g.nodes[a]["track"] == g.nodes[b]["track"] and d["frame_gap"] == b[0] - a[0] >= 1
    assert meta.axes[2].scale == 0.2 and meta.axes[2].scaled_unit == "micrometer"
    assert meta.extra["hexatissue"]["graph"] == "tracks"


def test_geff_exported_with_its_ome_zarr_points_to_the_labels_of_every_node(epicure, tmp_path, capsys):
    """``--with-ome-zarr``: both stores' related_objects name the labels (node_prop track) and the image, by paths
    relative to the store; following them, the pixels of value ``track`` in frame ``frame`` are each node's area."""
    import geff
    import zarr

    out = tmp_path / "g"
    assert main(["export", str(epicure["results"]), "--to", "geff", str(out), "--with-ome-zarr"]) == 0
    assert str(out / "cells.zarr") in capsys.readouterr().out
    for name in ("neighbours.geff", "tracks.geff"):
        store = out / name
        geff.validate_structure(str(store))
        graph, meta = read_geff(store)
        related = [(r.type, r.path, r.node_prop) for r in meta.related_objects]
        assert related == [("labels", "../cells.zarr/labels/cells", "track"), ("image", "../cells.zarr", None)]
        labels = zarr.open_group(str(store / related[0][1]), mode="r")["0"][:]
        assert labels.shape == (11, 160, 257)
        nodes, _ = geff_tables(store)
        for t, frame_nodes in nodes.groupby("frame"):
            counts = np.bincount(labels[t].ravel(), minlength=int(frame_nodes["track"].max()) + 1)
            np.testing.assert_array_equal(counts[frame_nodes["track"].to_numpy()], frame_nodes["area"].to_numpy())
    assert read_geff(write_geff(epicure["movie"], tmp_path / "plain")[0])[1].related_objects is None
    with pytest.raises(InputError, match="not an OME-Zarr written by hexatissue"):
        write_geff(epicure["movie"], tmp_path / "bad", labels=tmp_path / "plain")
    flipped = write_ome_zarr_labels(np.flip(labels, axis=2), tmp_path / "flipped.zarr")
    with pytest.raises(InputError, match="frame 0: its label values are not the tracks"):
        write_geff(epicure["movie"].replace(cells=epicure["movie"].cells[epicure["movie"].cells["track"] != 73]),
                   tmp_path / "bad", labels=flipped)
    with pytest.raises(InputError, match="with_ome_zarr"):
        ht.exchange.command.export(epicure["results"], tmp_path / "c", "ctc", with_ome_zarr=True)



def test_ctc_truth_export_names_both_folders_it_writes(epicure, tmp_path):
    from hexatissue.exchange.command import export

    written = export(epicure["results"], tmp_path / "gt", "ctc", truth=True)
    assert [w.name for w in written] == ["TRA", "SEG"] and all(w.is_dir() for w in written)
    assert len(list(written[1].glob("man_seg*.tif"))) == len(list(written[0].glob("man_track*.tif")))

def test_read_geff_refuses_what_is_not_a_store(tmp_path):
    with pytest.raises(InputError, match="does not exist"):
        read_geff(tmp_path / "none.geff")
    with pytest.raises(InputError, match="cannot be read"):
        geff_tables(tmp_path)


# ---------------------------------------------------------------------------------------------------------
# the EpiCure sample: its annotated division 73 -> 477 + 490
# ---------------------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def epicure(tmp_path_factory):
    folder = tmp_path_factory.mktemp("epicure")
    movie = ht.analyze(SAMPLE, workers=1, progress=False)
    movie.write(folder / "results")
    return {"folder": folder, "results": folder / "results", "movie": movie}


def test_exports_of_the_epicure_sample_pass_the_external_validators(epicure, tmp_path):
    """py-ctcmetrics' ``ctc_validate`` (the Cell Tracking Challenge's own rules: masks, res_track.txt, parents)
    accepts the CTC export; ``geff.validate_structure`` accepts both GEFF stores (it raises otherwise)."""
    import geff

    validate = pytest.importorskip("ctc_metrics.scripts.validate")
    evaluate = pytest.importorskip("ctc_metrics.scripts.evaluate")
    assert main(["export", str(epicure["results"]), "--to", "ctc", str(tmp_path / "ctc")]) == 0
    assert validate.validate_sequence(str(tmp_path / "ctc"), threads=1) == {"Valid": 1}
    # ctc_evaluate --seg --tra on the ground-truth export (TRA/ and SEG/): the result export matches it exactly
    assert main(["export", str(epicure["results"]), "--to", "ctc", "--truth", str(tmp_path / "gt")]) == 0
    assert len(list((tmp_path / "gt" / "SEG").glob("man_seg*.tif"))) == 11
    scores = evaluate.evaluate_sequence(str(tmp_path / "ctc"), str(tmp_path / "gt"), ["SEG", "TRA"], threads=1)
    assert (scores["SEG"], scores["TRA"], scores["AOGM"]) == (1.0, 1.0, 0.0)
    for store in write_geff(epicure["movie"], tmp_path / "geff"):
        geff.validate_structure(str(store))


def test_ctc_export_of_the_epicure_sample_lists_its_division(epicure, tmp_path):
    assert main(["export", str(epicure["results"]), "--to", "ctc", str(tmp_path / "ctc")]) == 0
    check_ctc(tmp_path / "ctc")
    lines = [tuple(map(int, line.split())) for line in (tmp_path / "ctc" / "res_track.txt").read_text().splitlines()]
    spans = {l: (b, e, p) for l, b, e, p in lines}
    assert spans[477] == (3, 10, 73) and spans[490] == (3, 10, 73) and spans[73][1] == 2
    masks, tracks = read_ctc(tmp_path / "ctc")
    same, _ = gap_links(tracks)
    assert same == {1163: 16, 1164: 65, 1165: 116, 1166: 116}  # ids missing from some frames of the EpiCure labels
    cells = epicure["movie"].cells
    for t in (0, 3, 10):  # each mask has the cell's pixel area under its track id (gaps merged back)
        merged = pd.Series(masks[t].ravel()).replace(same).to_numpy()
        ids, counts = np.unique(merged, return_counts=True)
        area = cells[cells["frame"] == t].set_index("track")["area"]
        assert dict(zip(ids[1:].tolist(), counts[1:].astype(float).tolist())) == area.to_dict()


def test_analyzing_the_ctc_export_gives_back_the_lineage(epicure, tmp_path):
    main(["export", str(epicure["results"]), "--to", "ctc", str(tmp_path / "ctc")])
    assert main(["analyze", str(tmp_path / "ctc"), "--out", str(tmp_path / "again"), "--workers", "1",
                 "--no-fields"]) == 0
    again = ht.read_results(tmp_path / "again")
    assert again.source["kind"] == "ctc" and again.source["gaps_merged"] == 4
    first = epicure["movie"]
    pd.testing.assert_frame_equal(again.lineage, first.lineage)
    assert again.summary["tracking"]["resolved"] == "never"
    key = ["frame", "track"]
    a = again.cells.sort_values(key).reset_index(drop=True)
    b = first.cells.sort_values(key).reset_index(drop=True)
    pd.testing.assert_frame_equal(a[key + ["area", "is_border"]], b[key + ["area", "is_border"]])


def test_export_needs_the_labels_when_the_recorded_path_is_gone(epicure, tmp_path, capsys):
    results = tmp_path / "results"
    shutil.copytree(epicure["results"], results)
    meta = json.loads((results / "metadata.json").read_text())
    meta["source"].update(path=str(tmp_path / "moved.tif"), relative_path="moved.tif")  # gone from both
    (results / "metadata.json").write_text(json.dumps(meta))
    assert main(["export", str(results), "--to", "ctc", str(tmp_path / "ctc")]) == 2
    assert "--labels FILE" in capsys.readouterr().err
    assert main(["export", str(results), "--to", "ctc", str(tmp_path / "ctc"), "--labels", str(SAMPLE)]) == 0
    check_ctc(tmp_path / "ctc")
    other = tmp_path / "other.tif"
    tifffile.imwrite(other, np.flip(tifffile.imread(SAMPLE), axis=2), photometric="minisblack")
    assert main(["export", str(results), "--to", "ctc", str(tmp_path / "ctc2"), "--labels", str(other)]) == 2
    assert "cells differ from the results' cells table" in capsys.readouterr().err


def test_track_masks_of_an_array_source_need_labels(squares):
    _, movie = squares
    array_movie = movie.replace(source={"kind": "array", "path": None})
    with pytest.raises(InputError, match="labels="):
        track_masks(array_movie)
    masks = track_masks(array_movie, labels=square_movie())
    np.testing.assert_array_equal(np.stack(masks), square_movie())  # touching squares: ids = tracks


def test_track_masks_say_why_the_recorded_labels_or_mask_cannot_be_reopened(squares, tmp_path):
    import re

    _, movie = squares
    cases = [({"kind": "array", "path": None},
              "the results were computed from 'array' data that were not a file, so their labels cannot be "
              "re-opened; pass the label image or stack the results were computed from (--labels FILE on the "
              "command line, labels= in Python)"),
             ({}, "the results were computed from 'an unknown input' data that were not a file, so their labels "
                  "cannot be re-opened; pass the label image or stack the results were computed from (--labels "
                  "FILE on the command line, labels= in Python)"),
             ({**movie.source, "path": str(tmp_path / "moved.tif")},
              f"the labels recorded in the results, {str(tmp_path / 'moved.tif')!r}, do not exist (moved, and not "
              f"at their path relative to the results folder either); pass them with --labels FILE (labels= in "
              f"Python)"),
             ({**movie.source, "mask": {"path": None, "shape": list(movie.shape), "inside": 1}},
              "the results were computed with a mask given as an array; pass the same mask (--mask FILE on the "
              "command line, mask= in Python)")]
    for source, message in cases:
        with pytest.raises(InputError, match=f"^{re.escape(message)}$"):
            track_masks(movie.replace(source=source))
    mask = np.ones(movie.shape, bool)  # the array mask given again: exported
    masked = movie.replace(source={**movie.source, "mask": {"path": None, "shape": list(movie.shape),
                                                            "inside": int(mask.sum())}})
    np.testing.assert_array_equal(np.stack(track_masks(masked, mask=mask)), np.stack(track_masks(movie)))


def test_export_geff_and_ome_zarr_from_the_command_line(epicure, tmp_path):
    assert main(["export", str(epicure["results"]), "--to", "geff", str(tmp_path / "g")]) == 0
    assert (tmp_path / "g" / "neighbours.geff").is_dir() and (tmp_path / "g" / "tracks.geff").is_dir()
    assert main(["export", str(epicure["results"]), "--to", "ome-zarr", str(tmp_path / "l.zarr"),
                 "--levels", "2"]) == 0
    source = ht.open_source(tmp_path / "l.zarr", key=LABELS_KEY)
    assert source.description["n_levels"] == 2
    assert source.calibration == ht.Calibration(0.2, "um", 300.0, "s")  # the sample's (tests/test_packaging.py)
    np.testing.assert_array_equal(np.stack([source.frame(t) for t in range(11)]),
                                  np.stack(track_masks(epicure["movie"])))
    # image-label colours (one per lineage: the division 73 -> 477 + 490 in one colour) and per-track properties
    image_label = json.loads((tmp_path / "l.zarr" / "labels" / "cells" / "zarr.json").read_text())[
        "attributes"]["ome"]["image-label"]
    colors = {c["label-value"]: c["rgba"] for c in image_label["colors"]}
    cells = epicure["movie"].cells
    assert sorted(colors) == [0, *sorted(cells["track"].unique())] and colors[0] == [0, 0, 0, 0]
    assert colors[73] == colors[477] == colors[490] != colors[16]
    props = {p["label-value"]: p for p in image_label["properties"]}
    assert sorted(props) == sorted(cells["track"].unique())
    assert {k: props[477][k] for k in ("track", "parent", "lineage", "frame_start", "frame_end", "n_frames")} == \
        {"track": 477, "parent": 73, "lineage": 73, "frame_start": 3, "frame_end": 10, "n_frames": 8}
    of_16 = cells[cells["track"] == 16]
    assert props[16]["n_frames"] == len(of_16) < 11  # missing from some frames of the curated labels
    assert props[16]["area_mean"] == pytest.approx(of_16["area"].mean(), rel=1e-12)
    assert props[16]["n_sides_mean"] == pytest.approx(of_16["n_sides"].mean(), rel=1e-12)


# ---------------------------------------------------------------------------------------------------------
# OME-Zarr
# ---------------------------------------------------------------------------------------------------------
def test_downsample_labels_is_the_mode_of_each_block():
    for values in itertools.product(range(3), repeat=4):
        counts = Counter(values)
        best = max(counts.values())
        want = values[0] if counts[values[0]] == best else next(v for v in values if counts[v] == best)
        assert downsample_labels(np.array(values).reshape(2, 2))[0, 0] == want, values
    odd = np.arange(15).reshape(3, 5)
    np.testing.assert_array_equal(downsample_labels(odd), [[0, 2, 4], [10, 12, 14]])  # edge rows repeated


def _ome_attrs(group, version):
    """A group's NGFF attributes: under "ome" in zarr.json (0.5) or in .zattrs (0.4)."""
    if version == "0.5":
        meta = json.loads((group / "zarr.json").read_text())
        assert meta["zarr_format"] == 3 and meta["attributes"]["ome"]["version"] == "0.5"
        return meta["attributes"]["ome"]
    return json.loads((group / ".zattrs").read_text())


@pytest.mark.parametrize("version", ["0.5", "0.4"])
@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.int32, np.int64])
def test_ome_zarr_label_stack_reads_back_identical(tmp_path, dtype, version):
    stack = np.random.default_rng(1).integers(0, 100, (4, 33, 47)).astype(dtype)
    cal = ht.Calibration(0.5, "um", 2.0, "min")
    path = write_ome_zarr_labels(stack, tmp_path / "s.zarr", calibration=cal, levels=3, chunks=(1, 16, 16),
                                 version=version)
    source = ht.open_source(path, key=LABELS_KEY)
    back = np.stack([source.raw_frame(t) for t in range(4)])
    assert back.dtype == stack.dtype
    np.testing.assert_array_equal(back, stack)
    assert source.calibration == cal
    assert ht.open_source(path, key=LABELS_KEY, level=2).calibration == ht.Calibration(2.0, "um", 2.0, "min")
    assert ht.open_source(path).description["ngff_labels"] == [LABELS_KEY]  # the root image lists its labels
    labels = _ome_attrs(tmp_path / "s.zarr" / "labels" / "cells", version)
    axes = labels["multiscales"][0]["axes"]
    assert [(a["name"], a.get("unit")) for a in axes] == [("t", "minute"), ("y", "micrometer"), ("x", "micrometer")]
    assert labels["image-label"]["source"] == {"image": "../../"}
    assert _ome_attrs(tmp_path / "s.zarr" / "labels", version)["labels"] == ["cells"]
    # nested chunk keys: level 0's chunk (t=3, row 2, col 2) of the labels and of the image
    nested = "c/3/2/2" if version == "0.5" else "3/2/2"
    assert (tmp_path / "s.zarr" / "labels" / "cells" / "0" / nested).is_file()
    assert (tmp_path / "s.zarr" / "0" / nested).is_file()


@pytest.mark.parametrize("version", ["0.5", "0.4"])
def test_ome_zarr_image_is_the_raw_channel_or_the_cell_outlines(tmp_path, version):
    labels = np.zeros((2, 6, 8), np.uint16)
    labels[:, :, 4:] = 1
    labels[1, 3:, :] = 2
    outlines = write_ome_zarr_labels(labels, tmp_path / "o.zarr", levels=2, version=version)
    image = ht.open_source(outlines)
    expected = np.zeros((6, 8), np.uint8)
    expected[:, 3:5] = 255  # both sides of the vertical boundary between 0 and 1
    np.testing.assert_array_equal(image.raw_frame(0), expected)
    np.testing.assert_array_equal(image.raw_frame(1), boundary_image(labels[1]))
    raw = np.random.default_rng(3).uniform(0, 1000, (2, 6, 8)).astype(np.float32)
    path = write_ome_zarr_labels(labels, tmp_path / "r.zarr", image=raw, levels=2, version=version)
    full, half = ht.open_source(path), ht.open_source(path, level=1)
    assert full.raw_frame(1).dtype == np.float32
    np.testing.assert_array_equal(full.raw_frame(1), raw[1])
    block_mean = raw[1].reshape(3, 2, 4, 2).astype(np.float64).mean(axis=(1, 3)).astype(np.float32)
    np.testing.assert_allclose(half.raw_frame(1), block_mean, rtol=1e-6)
    assert _ome_attrs(tmp_path / "r.zarr", version)["multiscales"][0]["metadata"]["image"] == "the raw channel"
    with pytest.raises(InputError, match=r"image has 2 frame\(s\) of \(6, 7\); expected 2 frame\(s\)"):
        write_ome_zarr_labels(labels, tmp_path / "bad.zarr", image=raw[:, :, :7])
    with pytest.raises(InputError, match="version must be one of"):
        write_ome_zarr_labels(labels, tmp_path / "bad.zarr", version="0.3")


@pytest.mark.parametrize("version", ["0.5", "0.4"])
def test_ome_zarr_export_passes_ome_zarr_py_ngff_zarr_and_ome_zarr_models(tmp_path, version):
    """The external readers and validators (test environment only) accept image + labels, both levels."""
    ome_zarr_reader = pytest.importorskip("ome_zarr.reader")
    ome_zarr_io = pytest.importorskip("ome_zarr.io")
    ngff_zarr = pytest.importorskip("ngff_zarr")
    ome_zarr_models = pytest.importorskip("ome_zarr_models")
    labels = np.stack([voronoi_labels(jittered_seeds((40, 56), 8, seed=s), (40, 56)) for s in (1, 2, 3)])
    values = np.unique(labels).tolist()
    properties = [{"label-value": v, "track": v, "n_sides_mean": 5.5, "name": f"cell {v}"} for v in values]
    path = write_ome_zarr_labels(labels.astype(np.uint16), tmp_path / "v.zarr", levels=2, version=version,
                                 calibration=ht.Calibration(0.2, "um", 5.0, "min"), properties=properties)
    nodes = list(ome_zarr_reader.Reader(ome_zarr_io.parse_url(str(path)))())
    kinds = {Path(n.zarr.path).relative_to(path).as_posix(): [type(s).__name__ for s in n.specs] for n in nodes}
    assert kinds["."] == ["Multiscales"] and "Label" in kinds["labels/cells"]
    cells = next(n for n in nodes if n.zarr.path.endswith("cells"))
    np.testing.assert_array_equal(np.asarray(cells.data[0]), labels)
    # ome-zarr-py reads the image-label colours (as 0-1 floats) and the properties of every label value
    want = {c["label-value"]: [x / 255 for x in c["rgba"]] for c in label_colors(values)}
    assert cells.metadata["color"] == want and len({tuple(v) for v in want.values()}) == len(values)
    assert cells.metadata["properties"] == {v: {"track": v, "n_sides_mean": 5.5, "name": f"cell {v}"}
                                            for v in values}
    for where in (path, path / "labels" / "cells"):
        ms = ngff_zarr.from_ngff_zarr(str(where), validate=True)
        assert ms.images[0].scale == {"t": 5.0, "y": 0.2, "x": 0.2}
        assert ms.images[0].axes_units == {"t": "minute", "y": "micrometer", "x": "micrometer"}
    assert type(ome_zarr_models.open_ome_zarr(str(path))).__name__ == "Image"
    assert type(ome_zarr_models.open_ome_zarr(str(path / "labels"))).__name__ == "Labels"
    image_label = ome_zarr_models.open_ome_zarr(str(path / "labels" / "cells"))
    assert type(image_label).__name__ == "ImageLabel"
    label_meta = image_label.attributes.ome.image_label if version == "0.5" else image_label.attributes.image_label
    assert [c.label_value for c in label_meta.colors] == values
    assert [p.label_value for p in label_meta.properties] == values


def test_two_level_ome_zarr_analyses_at_the_chosen_level(tmp_path):
    full = np.stack([voronoi_labels(jittered_seeds((160, 200), 20, seed=s), (160, 200)) for s in (1, 2)])
    write_ome_zarr_labels(full, tmp_path / "v.zarr", calibration=ht.Calibration(0.25, "um"), levels=2)
    half = np.stack([downsample_labels(f) for f in full])
    at_level = ht.analyze(ht.open_source(tmp_path / "v.zarr", key=LABELS_KEY, level=1), workers=1, progress=False)
    direct = ht.analyze(half, workers=1, progress=False)
    assert at_level.shape == (80, 100) and at_level.calibration == ht.Calibration(0.5, "um")
    for name, table in direct.tables.items():
        pd.testing.assert_frame_equal(at_level.tables[name], table, obj=name)


def test_write_ome_zarr_labels_refuses_bad_input(tmp_path):
    with pytest.raises(InputError, match="integer labels"):
        write_ome_zarr_labels(np.zeros((2, 8, 8)), tmp_path / "a.zarr")
    with pytest.raises(InputError, match="levels=5"):
        write_ome_zarr_labels(np.ones((1, 8, 8), np.uint8), tmp_path / "a.zarr", levels=5)
    with pytest.raises(InputError, match="levels must be a positive integer"):
        write_ome_zarr_labels(np.ones((1, 8, 8), np.uint8), tmp_path / "a.zarr", levels=0)
    assert not (tmp_path / "a.zarr").exists()


# ---------------------------------------------------------------------------------------------------------
# real data
# ---------------------------------------------------------------------------------------------------------
def test_real_mouse_epidermis_exports_to_ctc_and_geff(real_data, tmp_path):
    """Untracked per-frame labels (overlap-tracked): the exports hold every cell and the lineage comes back."""
    labels = real_subdir(real_data, "mouse_epidermis_laptrack") / "labels.npy"
    movie = ht.analyze(labels, order=NO_FIELDS, workers=1, progress=False)
    movie.write(tmp_path / "results")
    assert main(["export", str(tmp_path / "results"), "--to", "ctc", str(tmp_path / "ctc")]) == 0
    check_ctc(tmp_path / "ctc")
    masks, tracks = read_ctc(tmp_path / "ctc")
    per_frame = movie.cells.groupby("frame").size().tolist()
    assert [len(np.unique(m[m > 0])) for m in masks] == per_frame
    again = ht.analyze(tmp_path / "ctc", order=NO_FIELDS, workers=1, progress=False)
    assert movie.summary["tracking"]["resolved"] == "always"  # ids renumbered every frame: re-tracked
    pd.testing.assert_frame_equal(again.lineage, movie.lineage)  # the CTC folder is read as those tracks
    neighbours, track_store = write_geff(movie, tmp_path / "geff")
    nodes, edges = geff_tables(neighbours)
    assert len(nodes) == len(movie.cells)
    from hexatissue.graph import contact_table

    assert len(edges) == len(contact_table(movie.edges))
    assert read_geff(track_store)[0].number_of_nodes() == len(movie.cells)


def test_write_ctc_ignores_lineage_ids_absent_from_the_masks(tmp_path):
    # only the ids written count against 16 bits: a lineage row of a track beyond 65535 that is not in
    # these masks (e.g. a crop in time) used to make the export refuse
    masks = np.zeros((2, 4, 4), np.int64)
    masks[:, 0, 0] = 1
    lineage = pd.DataFrame({"track": [1, 70000], "frame_start": [0, 5], "frame_end": [1, 6], "parent": [0, 0]})
    write_ctc(masks, lineage, tmp_path / "ctc")
    check_ctc(tmp_path / "ctc")
    np.testing.assert_array_equal(read_ctc(tmp_path / "ctc")[0], masks)


def test_write_ctc_refuses_gap_ids_beyond_16_bits(tmp_path):
    # a track with a gap gets a new id above every id in use; past 65535 it would wrap in the uint16 masks
    from hexatissue.exchange.ctc import write_ctc

    masks = np.zeros((3, 4, 4), np.int64)
    masks[:, 0, 0] = 65535  # present in every frame
    masks[[0, 2], 2, 2] = 5  # missing from frame 1: its second part needs id 65536
    lineage = pd.DataFrame({"track": [5, 65535], "frame_start": [0, 0], "frame_end": [2, 2], "parent": [0, 0]})
    with pytest.raises(InputError, match="16-bit"):
        write_ctc(masks, lineage, tmp_path / "ctc")


def test_a_ctc_folder_whose_track_file_lost_its_lines_is_refused(epicure, tmp_path, capsys):
    """Issue 32: an empty res_track.txt was accepted and the EpiCure division silently lost."""
    main(["export", str(epicure["results"]), "--to", "ctc", str(tmp_path / "ctc")])
    (tmp_path / "ctc" / "res_track.txt").write_text("")
    with pytest.raises(InputError, match=r"res_track.txt has no line for \d+ id\(s\) of frame 0"):
        ht.open_source(tmp_path / "ctc")
    assert main(["analyze", str(tmp_path / "ctc"), "--out", str(tmp_path / "o")]) == 2
    assert "check_ctc" in capsys.readouterr().err


def test_results_record_the_source_by_absolute_path_and_export_works_from_another_folder(tmp_path, monkeypatch):
    """`analyze data/squares.tif --out results` run in one folder; `export` run from another, then after the data
    and the results were moved together (found through the path relative to the results folder)."""
    (tmp_path / "data").mkdir()
    (tmp_path / "elsewhere").mkdir()
    tifffile.imwrite(tmp_path / "data" / "squares.tif", square_movie(), photometric="minisblack")
    monkeypatch.chdir(tmp_path)
    assert main(["analyze", "data/squares.tif", "--out", "results", "--workers", "1", "--no-fields"]) == 0
    source = json.loads((tmp_path / "results" / "metadata.json").read_text())["source"]
    assert source["path"] == str(tmp_path / "data" / "squares.tif")
    assert source["relative_path"] == str(Path("..") / "data" / "squares.tif")
    monkeypatch.chdir(tmp_path / "elsewhere")
    assert main(["export", "../results", "--to", "ctc", "ctc"]) == 0
    expected = read_ctc(tmp_path / "elsewhere" / "ctc")[0]
    shutil.move(tmp_path / "data", tmp_path / "elsewhere" / "data")
    shutil.move(tmp_path / "results", tmp_path / "elsewhere" / "results")
    moved = ht.read_results("results")
    assert moved.source["path"] == str(tmp_path / "elsewhere" / "data" / "squares.tif")
    assert main(["export", "results", "--to", "ctc", "ctc2"]) == 0
    np.testing.assert_array_equal(read_ctc(tmp_path / "elsewhere" / "ctc2")[0], expected)


# ---------------------------------------------------------------------------------------------------------
# AnnData
# ---------------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("suffix", [".h5ad", ".zarr"])
def test_anndata_export_of_the_squares_holds_the_hand_made_neighbour_graph(squares, tmp_path, suffix):
    anndata = pytest.importorskip("anndata")
    folder, movie = squares
    out = tmp_path / f"cells{suffix}"
    assert main(["export", str(folder / "results"), "--to", "anndata", str(out)]) == 0
    adata = anndata.read_h5ad(out) if suffix == ".h5ad" else anndata.read_zarr(out)  # as squidpy users read it
    cells = movie.cells
    assert adata.n_obs == len(cells) == 9
    assert list(adata.obs_names) == [f"{t}:{c}" for t, c in zip(cells["frame"], cells["cell"])]
    pd.testing.assert_frame_equal(adata.obs.reset_index(drop=True), cells.reset_index(drop=True),
                                  check_index_type=False)
    np.testing.assert_array_equal(adata.obsm["spatial"], cells[["x", "y"]].to_numpy())
    key = adata.uns["spatial_neighbors"]["connectivities_key"]  # squidpy's way to the graph
    graph = adata.obsp[key].tocoo()
    pairs = {(int(adata.obs["frame"].iloc[i]), *sorted((int(adata.obs["cell"].iloc[i]),
                                                         int(adata.obs["cell"].iloc[j]))))
             for i, j in zip(graph.row, graph.col)}
    assert pairs == {(t, a, b) for t, contacts in SQUARE_CONTACTS.items() for a, b in contacts}
    assert graph.nnz == 2 * sum(len(c) for c in SQUARE_CONTACTS.values()) and set(graph.data) == {1.0}
    row = {(t, c): k for k, (t, c) in enumerate(zip(cells["frame"], cells["cell"]))}
    distances, lengths = adata.obsp[adata.uns["spatial_neighbors"]["distances_key"]], adata.obsp["contact_length"]
    assert distances[row[0, 1], row[0, 2]] == pytest.approx(40.0)  # 40-px squares side by side
    assert distances[row[1, 5], row[1, 6]] == pytest.approx(20.0)  # the daughters: 20-px halves
    assert lengths[row[0, 1], row[0, 2]] == pytest.approx(40.0) and lengths[row[1, 3], row[1, 5]] == pytest.approx(20.0)
    assert adata.uns["units"]["area"] == "px^2" and adata.uns["units"]["spatial"] == "px"
    assert adata.uns["descriptions"]["area"] == ht.schema.TABLES["cells"]["area"][2]
    assert adata.uns["hexatissue"]["source"] == str(folder / "squares.tif")
    # X: the features, each an exact copy of its cells column, or the squares' exact shape tensor
    assert list(adata.var_names) == ["area", "perimeter", "n_sides", "gamma6_re", "gamma6_im", "gamma2_re",
                                     "gamma2_im", "shape_xx", "shape_xy", "shape_yy"]
    assert adata.uns["features"]["left_out"] == {"tension": "not computed in this run", "pressure": "not computed "
                                                 "in this run", "vx": "NaN for every cell-frame",
                                                 "vy": "NaN for every cell-frame"}  # two frames: no centred velocity
    assert adata.var.loc["area", "unit"] == "px^2" and adata.var.loc["shape_xy", "unit"] == "px^2"
    X = pd.DataFrame(np.asarray(adata.X), columns=adata.var_names)
    for name in ("area", "perimeter", "n_sides", "gamma6_re", "gamma2_im"):
        np.testing.assert_array_equal(X[name], cells[name].to_numpy(float), err_msg=name)
    assert not np.asarray(adata.layers["missing"]).any()
    # every cell is a w x h rectangle: S = diag(w^2, h^2) / 12 with w h = polygon area and 2 (w + h) = perimeter
    w, h = np.sqrt(12 * X["shape_xx"]), np.sqrt(12 * X["shape_yy"])
    np.testing.assert_allclose(w * h, cells["polygon_area"], rtol=1e-12)
    np.testing.assert_allclose(2 * (w + h), cells["perimeter"], rtol=1e-12)
    np.testing.assert_allclose(X["shape_xy"], 0, atol=1e-9)
    daughters = cells["cell"].isin([5, 6]).to_numpy()
    np.testing.assert_allclose((w / h)[daughters], 2.0, rtol=0.1)  # 40 x 20 px halves (vertices on the cracks)


def test_anndata_export_of_the_epicure_sample_runs_scanpy_and_squidpy(epicure, tmp_path):
    """scanpy's pp.neighbors and tl.umap run on X; squidpy's nhood_enrichment, centrality_scores and Moran's I on the
    contact graph, Moran's I of every feature equal to the formula on that graph."""
    anndata = pytest.importorskip("anndata")
    sc = pytest.importorskip("scanpy")
    sq = pytest.importorskip("squidpy")
    movie = epicure["movie"]
    assert main(["export", str(epicure["results"]), "--to", "anndata", str(tmp_path / "cells.h5ad")]) == 0
    adata = anndata.read_h5ad(tmp_path / "cells.h5ad")
    cells = movie.cells
    assert adata.shape == (902, 12)  # no --mechanics: tension and pressure are not features
    assert set(adata.uns["features"]["left_out"]) == {"tension", "pressure"}
    assert not np.isnan(np.asarray(adata.X)).any()
    missing = pd.DataFrame(np.asarray(adata.layers["missing"]), columns=adata.var_names)
    pd.testing.assert_series_equal(missing["vx"], cells["vx"].isna().reset_index(drop=True), check_names=False)
    assert missing["vx"].sum() == adata.uns["features"]["n_missing"]["vx"] > 0  # the tracks' ends
    X = np.asarray(adata.X)
    vx = adata.var_names.get_loc("vx")
    np.testing.assert_array_equal(X[~missing["vx"], vx], cells["vx"].dropna().to_numpy())
    assert np.all(X[missing["vx"], vx] == np.nanmean(cells["vx"]))
    features = adata.copy()
    sc.pp.scale(features)
    sc.pp.neighbors(features, n_neighbors=10, random_state=0)
    sc.tl.umap(features, random_state=0)
    assert features.obsm["X_umap"].shape == (902, 2) and np.isfinite(features.obsm["X_umap"]).all()
    adata.obs["sides"] = pd.Categorical(adata.obs["n_sides"].clip(4, 8).astype(str))
    sq.gr.nhood_enrichment(adata, cluster_key="sides", n_perms=20, seed=0, show_progress_bar=False)
    sq.gr.centrality_scores(adata, cluster_key="sides", show_progress_bar=False)
    assert adata.uns["sides_nhood_enrichment"]["zscore"].shape == (5, 5)
    assert np.isfinite(adata.uns["sides_centrality_scores"].to_numpy()).all()
    sq.gr.spatial_autocorr(adata, mode="moran", n_perms=None, show_progress_bar=False)
    w = adata.obsp["spatial_connectivities"].toarray()
    w = w / np.maximum(w.sum(axis=1, keepdims=True), 1)  # squidpy's row-normalised weights
    for name in ("area", "gamma6_re", "vx"):
        z = X[:, adata.var_names.get_loc(name)] - X[:, adata.var_names.get_loc(name)].mean()
        want = len(z) / w.sum() * (z @ w @ z) / (z @ z)
        assert adata.uns["moranI"].loc[name, "I"] == pytest.approx(want, rel=1e-9), name


def test_anndata_features_of_a_mechanics_run_hold_the_junction_tension_and_pressure(squares):
    from hexatissue.exchange.anndata import cell_features

    _, movie = squares
    edges = movie.edges.assign(tension=np.arange(len(movie.edges), dtype=float))
    cells = movie.cells.assign(pressure=np.linspace(-1, 1, len(movie.cells)))
    features, left_out = cell_features(movie.replace(edges=edges, cells=cells))
    assert "tension" in features and "pressure" in features and "tension" not in left_out
    np.testing.assert_array_equal(features["pressure"], cells["pressure"])
    for k, (t, c) in enumerate(zip(cells["frame"], cells["cell"])):  # length-weighted mean of its junctions
        own = edges[(edges["frame"] == t) & ((edges["cell_a"] == c) | (edges["cell_b"] == c))]
        want = (own["tension"] * own["length"]).sum() / own["length"].sum()
        assert features["tension"].iloc[k] == pytest.approx(want, rel=1e-12)


def test_anndata_export_says_how_to_install_anndata_and_refuses_a_bad_name(squares, tmp_path, monkeypatch):
    import builtins

    from hexatissue.exchange.anndata import write_anndata

    _, movie = squares
    with pytest.raises(InputError, match=r"must end in \.h5ad or \.zarr"):
        write_anndata(movie, tmp_path / "cells.csv")
    real_import = builtins.__import__

    def no_anndata(name, *args, **kwargs):
        if name == "anndata":
            raise ImportError("No module named 'anndata'")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_anndata)
    with pytest.raises(InputError, match=r"^AnnData export needs the anndata package: pip install "
                                         r"'hexatissue\[anndata\]'$"):
        write_anndata(movie, tmp_path / "cells.h5ad")
    assert not (tmp_path / "cells.h5ad").exists()


def test_reanalysing_the_ome_zarr_export_keeps_the_cells_but_not_every_side_count(epicure, tmp_path):
    """The exported labels are the mesh's (membranes shared out): the same cells with the same pixel areas, but
    their junctions are refitted on touching labels, so a few side counts change. docs/exchange.md quotes the count."""
    assert main(["export", str(epicure["results"]), "--to", "ome-zarr", str(tmp_path / "e.zarr")]) == 0
    again = ht.analyze(ht.open_source(tmp_path / "e.zarr", key=LABELS_KEY), workers=1, progress=False)
    first = epicure["movie"].cells.set_index(["frame", "track"]).sort_index()
    second = again.cells.set_index(["frame", "cell"]).sort_index()
    assert first.index.tolist() == second.index.tolist()  # every cell-frame, by its track id
    np.testing.assert_array_equal(first["area"], second["area"])
    changed = first["n_sides"].to_numpy() != second["n_sides"].to_numpy()
    assert (len(first), int(changed.sum()), int((changed & ~first["is_border"].to_numpy(bool)).sum())) == (902, 25, 12)
    # --keep-membranes: the input's membranes stay 0, and the re-analysis is the analysis, side counts included
    assert main(["export", str(epicure["results"]), "--to", "ome-zarr", str(tmp_path / "m.zarr"),
                 "--keep-membranes"]) == 0
    kept = ht.open_source(tmp_path / "m.zarr", key=LABELS_KEY)
    raw = ht.open_source(SAMPLE)
    for t in (0, 3, 10):
        assert np.array_equal(kept.frame(t) == 0, raw.frame(t) == 0)  # the same membranes (and background)
    third = ht.analyze(kept, workers=1, progress=False).cells.set_index(["frame", "cell"]).sort_index()
    assert third.index.tolist() == first.index.tolist()
    for column in ("n_sides", "area", "polygon_area", "perimeter", "is_border"):
        np.testing.assert_array_equal(third[column], first[column], err_msg=column)


# ---------------------------------------------------------------------------------------------------------
# no export deletes what it did not write
# ---------------------------------------------------------------------------------------------------------
def _tree(folder):
    """Every file under ``folder`` with its content: what must survive a refused export untouched."""
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(Path(folder).rglob("*")) if p.is_file()}


@pytest.mark.parametrize("to, name", [("ome-zarr", "out.zarr"), ("anndata", "out.zarr"), ("anndata", "out.h5ad"),
                                      ("ctc", "out"), ("geff", "out/neighbours.geff")])
def test_export_refuses_a_foreign_out_and_deletes_nothing(squares, tmp_path, capsys, to, name):
    folder, _ = squares
    target = tmp_path / name
    if name.endswith(".h5ad"):
        target.write_text("someone's notes")
    else:
        target.mkdir(parents=True)
        (target / "notes.txt").write_text("someone's notes")
    out = tmp_path / ("out" if to == "geff" else name)
    before = _tree(tmp_path)
    assert main(["export", str(folder / "results"), "--to", to, str(out)]) == 2
    message = capsys.readouterr().err
    assert "not an earlier output" in message and "--overwrite" in message and str(target) in message
    assert _tree(tmp_path) == before and sorted(p.name for p in tmp_path.iterdir()) == ["out" if "/" in name else
                                                                                           name]


def test_export_never_replaces_the_results_folder_or_a_folder_holding_it(squares, tmp_path, capsys):
    folder, _ = squares
    results = tmp_path / "r"
    shutil.copytree(folder / "results", results)
    before = _tree(tmp_path)
    for to in ("ome-zarr", "anndata", "ctc", "geff"):
        for out, what in ((results, "is the results folder"), (tmp_path, "holding the results folder")):
            for extra in ([], ["--overwrite"]):
                assert main(["export", str(results), "--to", to, str(out), *extra]) == 2, (to, out, extra)
                assert what in capsys.readouterr().err
    assert _tree(tmp_path) == before
    with pytest.raises(InputError, match="results folder of 'hexatissue analyze'.*never replaced"):
        write_ome_zarr_labels(square_movie(), results, overwrite=True)  # any results folder, from any call
    assert _tree(tmp_path) == before


def test_export_replaces_its_own_earlier_output_and_a_foreign_one_only_with_overwrite(squares, tmp_path, capsys):
    folder, _ = squares
    zarr, ctc, geff = tmp_path / "l.zarr", tmp_path / "ctc", tmp_path / "g"
    for to, out in (("ome-zarr", zarr), ("ctc", ctc), ("geff", geff)):
        assert main(["export", str(folder / "results"), "--to", to, str(out)]) == 0
        first = _tree(out)
        assert main(["export", str(folder / "results"), "--to", to, str(out)]) == 0  # its own output: replaced
        assert _tree(out) == first
    (geff / "readme.txt").write_text("kept")  # geff writes two stores into OUT and touches nothing else
    assert main(["export", str(folder / "results"), "--to", "geff", str(geff)]) == 0
    assert (geff / "readme.txt").read_text() == "kept"
    foreign = tmp_path / "foreign.zarr"
    foreign.mkdir()
    (foreign / "zarr.json").write_text('{"zarr_format": 3, "node_type": "group", "attributes": {}}')
    assert main(["export", str(folder / "results"), "--to", "ome-zarr", str(foreign)]) == 2
    assert "not an earlier output" in capsys.readouterr().err and (foreign / "zarr.json").is_file()
    assert main(["export", str(folder / "results"), "--to", "ome-zarr", str(foreign), "--overwrite"]) == 0
    np.testing.assert_array_equal(ht.open_source(foreign, key=LABELS_KEY).frame(1),
                                  ht.open_source(zarr, key=LABELS_KEY).frame(1))
    masks = tmp_path / "their_masks"  # another tool's CTC result: its masks are neither replaced nor removed
    masks.mkdir()
    tifffile.imwrite(masks / "mask000.tif", np.ones((4, 4), np.uint16))
    tifffile.imwrite(masks / "mask007.tif", np.ones((4, 4), np.uint16))
    before = _tree(masks)
    with pytest.raises(InputError, match="not an earlier output"):
        write_ctc(*scripted_masks(), masks)
    assert _tree(masks) == before


def test_ctc_and_ome_zarr_exports_of_a_streamed_folder_read_four_columns_and_equal_the_in_memory_ones(tmp_path,
                                                                                                      monkeypatch):
    from hexatissue import pipeline
    from hexatissue.exchange.command import export
    from hexatissue.stored import StoredTable
    from hexatissue.synthetic import voronoi_movie

    monkeypatch.setattr(pipeline, "PART_BYTES", 20_000)  # the cells in several parts
    m = voronoi_movie(25, (60, 70), 6, periodic=False, amplitude=0.8, seed=4)
    np.save(tmp_path / "movie.npy", np.stack([m[t] for t in range(len(m))]))
    ht.analyze(tmp_path / "movie.npy", out=tmp_path / "results", workers=1, progress=False)
    assert len(StoredTable.open(tmp_path / "results" / "cells", "cells").parts) > 2
    reads, read = [], StoredTable.read

    def recording(self, columns=None, frames=None):
        reads.append((self.name, columns))
        return read(self, columns, frames)

    monkeypatch.setattr(StoredTable, "read", recording)
    for to in ("ctc", "ome-zarr"):
        reads.clear()
        streamed = export(tmp_path / "results", tmp_path / "streamed" / to, to)
        assert reads and all(name == "cells" and len(columns) == 4 for name, columns in reads)
        memory = export(ht.read_results(tmp_path / "results", lazy=False), tmp_path / "memory" / to, to)
        files = [sorted(p.relative_to(top) for p in top.rglob("*") if p.is_file()) for top in (streamed[0], memory[0])]
        assert files[0] == files[1] and len(files[0]) >= len(m)
        for name in files[0]:
            assert (streamed[0] / name).read_bytes() == (memory[0] / name).read_bytes(), name
