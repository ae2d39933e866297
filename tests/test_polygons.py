"""Polygon input: polygons -> network tables, the three file formats, analyze and the CLI, bad input."""
import shutil
import sqlite3
import warnings

import numpy as np
import pandas as pd
import pytest

from hexatissue import EventOptions, HexatissueWarning, InputError, analyze, mesh_from_labels, open_source, read_results
from hexatissue.cli import main
from hexatissue.graph import neighbor_graph
from hexatissue.order import shape_function
from hexatissue.mesh.polygons import mesh_from_polygons, polygon_network
from hexatissue.readers.polygons import read_tissue_analyzer
from hexatissue.synthetic import (jittered_seeds, t1_movie, voronoi_labels, voronoi_polygons, voronoi_truth)

from .conftest import mdck_published_gamma, real_subdir

SHAPE = (160, 200)


def square(x, y, side=2.0):
    return np.array([[x, y], [x + side, y], [x + side, y + side], [x, y + side]], float)


def pairs(frame):
    e = frame.edges[frame.edges["cell_a"] > 0]
    return set(zip(e["cell_a"].tolist(), e["cell_b"].tolist()))


def write_table(path, polygons, frame=None):
    rows = [pd.DataFrame({"cell": c, "x": xy[:, 0], "y": xy[:, 1]}) for c, xy in polygons.items()]
    table = pd.concat(rows, ignore_index=True)
    if frame is not None:
        table.insert(0, "frame", frame)
    table.to_csv(path, index=False)
    return path


# ---------------------------------------------------------------------------------------------------------
# hand-made cases
# ---------------------------------------------------------------------------------------------------------
def test_two_squares_and_a_triangle():
    """A and B share a side, A and C share a side, B and C touch at one vertex only."""
    a = square(0, 0)
    b = square(2, 0)[::-1]  # clockwise: made counter-clockwise
    c = np.array([[0, 2], [2, 2], [1, 3], [0, 2]], float)  # closed: the repeated vertex is dropped
    f = mesh_from_polygons({1: a, 2: b, 3: c})
    v = f.vertices.set_index(["x", "y"])
    assert len(v) == 7 and len(f.edges) == 9
    assert v["degree"].to_dict() == {(0, 0): 2, (2, 0): 3, (2, 2): 4, (0, 2): 3, (4, 0): 2, (4, 2): 2, (1, 3): 2}
    assert v["is_border"].all()  # every vertex is on the outer boundary
    assert pairs(f) == {(1, 2), (1, 3)}
    assert (f.edges["cell_a"] == 0).sum() == 7
    assert f.cells["cell"].tolist() == [1, 2, 3] and f.cells["is_border"].all()
    assert f.cells["n_sides"].tolist() == [4, 4, 3]
    np.testing.assert_allclose(f.cells["polygon_area"], [4, 4, 1])
    np.testing.assert_allclose(f.cells[["x", "y"]].to_numpy()[2], [1, 7 / 3])  # area centroid of the triangle
    # ranks run counter-clockwise in (x, y): B's polygon was reversed
    cv = f.cell_vertices[f.cell_vertices["cell"] == 2].merge(f.vertices, on=["frame", "vertex"])
    xy = cv.sort_values("rank")[["x", "y"]].to_numpy()
    assert 0.5 * np.sum(xy[:, 0] * np.roll(xy[:, 1], -1) - np.roll(xy[:, 0], -1) * xy[:, 1]) > 0


def test_grid_of_squares_interior_cell_and_tolerance():
    """3 x 3 squares: only the centre cell is interior; vertices moved by 1e-9 px are still shared."""
    polys = {3 * i + j + 1: square(2 * j, 2 * i) for i in range(3) for j in range(3)}
    f = mesh_from_polygons(polys)
    assert f.cells.loc[~f.cells["is_border"], "cell"].tolist() == [5]
    assert len(f.vertices) == 16 and len(f.edges) == 24
    assert f.vertices.set_index(["x", "y"])["degree"].loc[(2, 2)] == 4
    assert neighbor_graph(f).degree[5] == 4
    moved = {k: p + (1e-9 if k == 5 else 0.0) for k, p in polys.items()}
    g = mesh_from_polygons(moved)
    assert len(g.vertices) == 16 and not g.cells.set_index("cell").loc[5, "is_border"]
    np.testing.assert_allclose(g.vertices[["x", "y"]], f.vertices[["x", "y"]], atol=1e-9)
    h = mesh_from_polygons(moved, tolerance=0)  # exact sharing only: cell 5 is cut loose
    assert len(h.vertices) == 20 and h.cells.set_index("cell").loc[5, "is_border"]


def test_overlapping_polygons_warn():
    with pytest.warns(HexatissueWarning, match="overlap"):
        f = mesh_from_polygons({1: square(0, 0), 2: square(0, 0)[[1, 2, 3, 0]], 3: square(2, 0)})
    assert (1, 2) in pairs(f)


# ---------------------------------------------------------------------------------------------------------
# synthetic truth
# ---------------------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def voronoi():
    seeds = jittered_seeds(SHAPE, 16, seed=3)
    return seeds, voronoi_polygons(seeds, SHAPE)


def test_voronoi_polygons_give_the_exact_network(voronoi, tmp_path):
    seeds, polys = voronoi
    from scipy.spatial import Voronoi

    vor = Voronoi(seeds)
    kept = set(polys)
    regions = {k: vor.regions[vor.point_region[k - 1]] for k in kept}
    truth_vertices = set().union(*map(set, regions.values()))
    truth_sides = {frozenset((r[i], r[(i + 1) % len(r)])) for r in regions.values() for i in range(len(r))}
    f = mesh_from_polygons(polys)
    assert len(f.vertices) == len(truth_vertices) and len(f.edges) == len(truth_sides)
    truth_xy = {tuple(vor.vertices[i]) for i in truth_vertices}
    assert set(zip(f.vertices["x"], f.vertices["y"])) == truth_xy  # exact floats
    cells = f.cells.set_index("cell")
    assert cells["n_sides"].to_dict() == {k: len(r) for k, r in regions.items()}
    truth_pairs = {p for p, length in voronoi_truth(seeds, SHAPE)[0].items() if length > 0}
    assert pairs(f) == {p for p in truth_pairs if set(p) <= kept}
    # border = a Voronoi neighbour that is not among the polygons
    border = {k for p in truth_pairs if len(set(p) & kept) == 1 for k in set(p) & kept}
    assert set(cells.index[cells["is_border"]]) == border and 0 < len(border) < len(kept)
    # through analyze, from a vertices table (CSV): gamma_p about the vertex mean, in the file's cell order
    return_order = list(polys)[::-1]
    path = write_table(tmp_path / "vertices.csv", {k: polys[k] for k in return_order})
    movie = analyze(path, workers=1, progress=False)
    assert movie.cells["cell"].tolist() == return_order
    for p in (2, 6):
        truth = shape_function([polys[k] for k in return_order], p=p)
        got = movie.cells[f"gamma{p}_re"].to_numpy() + 1j * movie.cells[f"gamma{p}_im"].to_numpy()
        np.testing.assert_allclose(got, truth, atol=1e-12)
    assert len(movie.grid) and movie.grid["valid"].any()


def test_mesh_polygons_round_trip():
    """The mesh of a Voronoi label image and the network of its own polygons are the same network."""
    seeds = jittered_seeds(SHAPE, 16, seed=5)
    m = mesh_from_labels(voronoi_labels(seeds, SHAPE))
    g = mesh_from_polygons(m.polygons())
    mv = m.vertices.set_index(["x", "y"])[["degree", "is_border"]].sort_index()
    gv = g.vertices.set_index(["x", "y"])[["degree", "is_border"]].sort_index()
    pd.testing.assert_frame_equal(mv, gv)

    def sides(f):
        xy = f.vertices.set_index("vertex")[["x", "y"]]
        a, b = xy.loc[f.edges["vertex_a"]].to_numpy(), xy.loc[f.edges["vertex_b"]].to_numpy()
        return {(frozenset((tuple(p), tuple(q))), ca, cb) for p, q, ca, cb in
                zip(a, b, f.edges["cell_a"], f.edges["cell_b"])}

    assert sides(m) == sides(g)
    cols = ["n_sides", "is_border", "polygon_area", "perimeter"]
    pd.testing.assert_frame_equal(m.cells.set_index("cell")[cols], g.cells.set_index("cell")[cols])


def test_polygon_movie_tracks_ids_and_finds_the_scripted_t1s(tmp_path):
    """A vertices table with frames (exact Voronoi polygons of the scripted T1 movie): ids are the tracks and
    every scripted T1 whose quartet is among the polygons is found, with its kind and frames."""
    mv = t1_movie(periodic=False, seed=1)
    parts = []
    for t, s in enumerate(mv.seeds):
        polys = voronoi_polygons(s, mv.shape)
        parts.append(pd.concat([pd.DataFrame({"frame": t, "cell": c, "x": xy[:, 0], "y": xy[:, 1]})
                                for c, xy in polys.items()]))
    pd.concat(parts).to_parquet(tmp_path / "movie.parquet", index=False)
    source = open_source(tmp_path / "movie.parquet")
    assert source.kind == "polygons" and source.n_frames == len(mv.seeds) and source.ids_consistent
    movie = analyze(source, events=EventOptions(min_length=mv.min_length, censor=mv.censor), workers=1,
                    progress=False)
    assert movie.summary["tracking"]["resolved"] == "never"
    assert (movie.cells["track"] == movie.cells["cell"]).all()
    key = ["kind", "frame_start", "frame_end", "duration", "cell_a", "cell_b", "cell_c", "cell_d", "frame_gain"]
    kept = set(movie.cells["cell"])
    inside = mv.events[mv.events[["cell_a", "cell_b", "cell_c", "cell_d"]].isin(kept).all(axis=1)]
    assert len(inside) >= 3
    pd.testing.assert_frame_equal(movie.events[key].astype({"kind": object}).reset_index(drop=True),
                                  inside[key].astype({"kind": object}).reset_index(drop=True))


# ---------------------------------------------------------------------------------------------------------
# real data
# ---------------------------------------------------------------------------------------------------------
def assert_published_gamma(cells, folder, image):
    for p in (2, 6):
        published = mdck_published_gamma(folder, image, p)
        assert len(cells) == len(published)
        got = cells[f"gamma{p}_re"].to_numpy() + 1j * cells[f"gamma{p}_im"].to_numpy()
        assert np.abs(got - published).max() < 1e-9


def test_mdck_polygons_give_the_published_gamma_from_the_cli(real_data, tmp_path):
    folder = real_subdir(real_data, "hexanematic_mdck")
    assert main(["analyze", str(folder / "mat" / "Image13_Polygon.mat"), "--out", str(tmp_path / "one"),
                 "--workers", "1"]) == 0
    movie = read_results(tmp_path / "one")
    assert movie.cells["cell"].tolist() == list(range(1, 142))  # file order
    assert_published_gamma(movie.cells, folder, 13)
    assert movie.source["kind"] == "polygon_mat" and len(movie.defects)


def test_mdck_folder_is_independent_images_from_the_cli(real_data, tmp_path):
    """All 63 configurations (images 6-68) as one folder: published gamma_p for every cell, nothing tracked."""
    folder = real_subdir(real_data, "hexanematic_mdck")
    images = tmp_path / "mat"
    images.mkdir()
    for image in range(6, 69):
        shutil.copy(folder / "mat" / f"Image{image}_Polygon.mat", images)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HexatissueWarning)  # a few published polygons overlap (images 36, 50, ...)
        assert main(["analyze", str(images), "--out", str(tmp_path / "all"), "--workers", "1"]) == 0
    movie = read_results(tmp_path / "all")
    assert len(movie) == 63 and len(movie.cells) == 8518
    for t, image in enumerate(range(6, 69)):
        assert_published_gamma(movie.cells[movie.cells["frame"] == t], folder, image)
    assert movie.summary["tracking"]["resolved"] == "off" and movie.cells["track"].is_unique
    assert len(movie.events) == 0 and len(movie.defect_events) == 0
    assert not movie.defects.duplicated(["p", "track"]).any()  # no defect linked across images
    # the published coordination numbers (SOURCE.md: 40.62 % hexagons, per-image mean over images 6-68)
    hexagons = movie.cells.groupby("frame")["n_sides"].apply(lambda n: (n == 6).mean()).mean()
    assert abs(hexagons - 0.4062) < 5e-4


def test_tissue_analyzer_polygons_give_ta_vertex_counts_and_bonds(real_data, tmp_path):
    path = real_subdir(real_data, "tissue_analyzer_single") / "1" / "TA.db"
    assert main(["analyze", str(path), "--out", str(tmp_path / "ta"), "--workers", "1"]) == 0
    movie = read_results(tmp_path / "ta")
    with sqlite3.connect(path) as con:
        ta = pd.read_sql("select * from Cells", con).set_index("local_id_cells")
        bonds = pd.read_sql("select * from Bonds", con)
    interior = ta[ta["is_border_cell"] == "false"]
    assert len(interior) == 19
    cells = movie.cells.set_index("cell")
    np.testing.assert_array_equal(cells.loc[interior.index, "n_sides"], interior["nb_of_vertices_no_cut_off"])
    # TA's border flags, exactly; cell 1 (two vertices, a sliver at the image corner) has no polygon
    assert sorted(cells.index[~cells["is_border"]]) == sorted(interior.index)
    assert set(ta.index) - set(cells.index) == {1}
    # TA's bonds are our edges: the same vertex pairs (TA lists the sliver's bond twice)
    xy = movie.vertices.set_index("vertex")[["x", "y"]]
    ours = {frozenset((tuple(xy.loc[a]), tuple(xy.loc[b]))) for a, b in
            zip(movie.edges["vertex_a"], movie.edges["vertex_b"])}
    theirs = {frozenset(((float(r.vx_1_x), float(r.vx_1_y)), (float(r.vx_2_x), float(r.vx_2_y))))
              for r in bonds.itertuples()}
    assert ours == theirs and len(ours) == 125


# ---------------------------------------------------------------------------------------------------------
# bad input
# ---------------------------------------------------------------------------------------------------------
def test_bad_vertices_tables(tmp_path):
    good = {1: square(0, 0), 2: square(2, 0)}
    path = write_table(tmp_path / "v.csv", good)
    pd.read_csv(path).drop(columns="y").to_csv(tmp_path / "no_y.csv", index=False)
    with pytest.raises(InputError, match=r"missing column\(s\) \['y'\]"):
        open_source(tmp_path / "no_y.csv")
    table = pd.read_csv(path)
    table.iloc[[0, 4, 1, 2, 3, 5, 6, 7]].to_csv(tmp_path / "split.csv", index=False)
    with pytest.raises(InputError, match="rows of cell 1 are not contiguous"):
        open_source(tmp_path / "split.csv")
    table.assign(cell=table["cell"] + 0.5).to_csv(tmp_path / "float_ids.csv", index=False)
    with pytest.raises(InputError, match="'cell' must hold integers"):
        open_source(tmp_path / "float_ids.csv")
    (tmp_path / "junk.parquet").write_text("not parquet")
    with pytest.raises(InputError, match="could not read the vertices table"):
        open_source(tmp_path / "junk.parquet")
    write_table(tmp_path / "two.csv", {**good, 3: np.array([[0, 5], [1, 5]], float)})
    with pytest.raises(InputError, match="polygon of cell 3 .*2 distinct vertices"):
        analyze(tmp_path / "two.csv", workers=1, progress=False)
    write_table(tmp_path / "flat.csv", {**good, 3: np.array([[0, 5], [1, 5], [2, 5]], float)})
    with pytest.raises(InputError, match="cell 3 .*zero area"):
        analyze(tmp_path / "flat.csv", workers=1, progress=False)
    bow = np.array([[0, 5], [2, 7], [2, 5], [1, 6], [0, 7], [1, 6]], float)  # passes through (1, 6) twice
    with pytest.raises(InputError, match="cell 3 passes through one vertex twice"):
        mesh_from_polygons({**good, 3: bow})
    with pytest.raises(InputError, match="cell ids must be positive"):
        mesh_from_polygons({0: square(0, 0)})
    with pytest.raises(InputError, match="tolerance"):
        polygon_network(good, tolerance=-1)


def test_bad_polygon_files(tmp_path):
    from scipy.io import savemat

    cells = np.empty(2, dtype=object)  # a MATLAB cell array
    cells[0], cells[1] = np.r_[square(0, 0), [[0, 0]]], square(2, 0)  # the first is closed, the second not
    savemat(tmp_path / "open_Polygon.mat", {"Polygon": {"Vertex": cells, "CenterOfMass": np.ones((2, 2))}})
    with pytest.raises(InputError, match=r"Vertex\{2\} is not closed"):
        open_source(tmp_path / "open_Polygon.mat")
    savemat(tmp_path / "other.mat", {"labels": np.ones((3, 3))})
    with pytest.raises(InputError, match="no struct 'Polygon'.*it holds \\['labels'\\]"):
        open_source(tmp_path / "other.mat")
    (tmp_path / "text.mat").write_text("hello")
    with pytest.raises(InputError, match="could not read .* as a MATLAB .mat file"):
        open_source(tmp_path / "text.mat")
    with sqlite3.connect(tmp_path / "other.db") as con:
        con.execute("create table Bonds (x int)")
    with pytest.raises(InputError, match="not a Tissue Analyzer database: it has no Cells table"):
        open_source(tmp_path / "other.db")
    (tmp_path / "text.db").write_text("hello, not sqlite" * 10)
    with pytest.raises(InputError, match="could not read .* as a Tissue Analyzer database"):
        read_tissue_analyzer(tmp_path / "text.db")


def test_polygon_source_refuses_what_needs_pixels(tmp_path):
    path = write_table(tmp_path / "v.csv", {1: square(0, 0), 2: square(2, 0)})
    source = open_source(path)
    assert source.kind == "polygons" and source.shape == (3, 5) and len(source.polygons(0)) == 2
    with pytest.raises(InputError, match="holds cell polygons, not a label image"):
        source.frame(0)
    with pytest.raises(InputError, match="key=.*means nothing"):
        open_source(path, key="labels")
    with pytest.raises(InputError, match="mask= needs a label image"):
        analyze(source, mask=np.ones((3, 5), bool), workers=1, progress=False)
    with pytest.raises(InputError, match="open image"):
        analyze(source, box=True, workers=1, progress=False)
    from hexatissue import TrackOptions

    with pytest.raises(InputError, match="'always' .*needs label images"):
        analyze(source, track=TrackOptions(mode="always"), workers=1, progress=False)


def test_polygon_mat_files_and_a_folder_of_them(voronoi, tmp_path):
    """The hexanematic format written here (closed polygons in a cell array): one file is one image, a folder of
    files is independent images (no tracks across them, no T1s, no defect links)."""
    from scipy.io import savemat

    _, polys = voronoi
    cells = np.empty(len(polys), dtype=object)
    for k, xy in enumerate(polys.values()):
        cells[k] = np.r_[xy, xy[:1]]
    folder = tmp_path / "mat"
    folder.mkdir()
    for name in ("Image2_Polygon.mat", "Image10_Polygon.mat"):
        savemat(folder / name, {"Polygon": {"Vertex": cells, "CenterOfMass": np.zeros((len(polys), 2))}})
    one = analyze(folder / "Image2_Polygon.mat", workers=1, progress=False)
    assert one.cells["cell"].tolist() == list(range(1, len(polys) + 1))
    truth = shape_function(list(polys.values()), p=6)
    np.testing.assert_allclose(one.cells["gamma6_re"] + 1j * one.cells["gamma6_im"], truth, atol=1e-12)
    source = open_source(folder)
    assert source.independent and source.description["files"] == ["Image2_Polygon.mat", "Image10_Polygon.mat"]
    both = analyze(source, workers=1, progress=False)
    assert both.summary["tracking"]["resolved"] == "off" and both.cells["track"].is_unique
    assert len(both.events) == 0 and len(both.defect_events) == 0 and len(both.lineage) == 2 * len(polys)
    d0, d1 = (both.defects[both.defects["frame"] == t] for t in (0, 1))
    assert len(d0) == len(d1) > 0 and not set(d0["track"] + 1000 * d0["p"]) & set(d1["track"] + 1000 * d1["p"])


def test_cli_figures_and_report_of_a_vertices_table(voronoi, tmp_path):
    """Figures are drawn from the tables alone (no label image underneath); the report runs."""
    from hexatissue.workflows import report

    _, polys = voronoi
    path = write_table(tmp_path / "v.csv", polys)
    assert main(["analyze", str(path), "--out", str(tmp_path / "res"), "--figures", "--workers", "1"]) == 0
    assert (tmp_path / "res" / "figures" / "polygons.png").stat().st_size > 0
    numbers = report(tmp_path / "res")
    assert numbers["frames"] == 1 and (tmp_path / "res" / "report" / "order6.png").exists()
