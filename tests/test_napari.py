"""The napari plugin in a headless viewer: reader (npe2), screenshot, dock widget.

Marked ``napari`` and left out of the default run; CI runs them in their own job
(``xvfb-run python -m pytest -q -m napari`` with ``QT_QPA_PLATFORM=offscreen``).
"""
import os
import time
import warnings

import numpy as np
import pytest
import tifffile

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
napari = pytest.importorskip("napari")

from hexatissue import OrderOptions, TrackOptions, analyze, open_source, read_results  # noqa: E402
from hexatissue.errors import HexatissueWarning  # noqa: E402
from hexatissue.napari.layers import legend_entries  # noqa: E402
from hexatissue.napari.legend import DOCK_NAME, LegendWidget  # noqa: E402
from hexatissue.napari.reader import get_reader, read_folder, read_labels_source  # noqa: E402
from tests.test_napari_layers import SAMPLE, epicure  # noqa: E402,F401  (the analysed sample, a fixture)
from tests.test_stages import toy_stage  # noqa: E402,F401  (a stage added with its entry alone, a fixture)

pytestmark = pytest.mark.napari


@pytest.fixture
def viewer():
    v = napari.Viewer(show=False)
    yield v
    v.close()


def _layer(viewer, name):
    return viewer.layers[name]


def test_the_reader_opens_a_results_folder_as_the_layers(viewer, epicure):
    assert get_reader(str(epicure)) is read_folder
    # the folder's metadata.json is ours alone: napari opens it with no plugin named and no reader choice
    viewer.open(str(epicure / "metadata.json"), plugin=None)
    movie = read_results(epicure)
    names = [layer.name for layer in viewer.layers]
    assert names == ["labels", "polygons", "vertices", "gamma6 stars", "Gamma2 defects", "Gamma6 defects",
                     "T1 events", "tracks", "flow"]
    assert _layer(viewer, "polygons").nshapes == int((movie.cells["n_sides"] >= 3).sum())
    assert len(_layer(viewer, "vertices").data) == len(movie.vertices)
    assert list(_layer(viewer, "vertices").features["degree"]) == list(movie.vertices["degree"])
    assert len(_layer(viewer, "Gamma6 defects").data) + len(_layer(viewer, "Gamma2 defects").data) == len(movie.defects)
    assert len(_layer(viewer, "T1 events").data) == len(movie.events)
    tracks = _layer(viewer, "tracks")
    assert len(np.unique(tracks.data[:, 0])) == len(movie.lineage)
    assert tracks.graph == {477: [73], 490: [73]}
    for layer in viewer.layers:
        n = layer.ndim
        assert tuple(layer.scale) == (300.0, 0.2, 0.2)[-n:], layer.name
        assert [str(u) for u in layer.units] == ["second", "micrometer", "micrometer"][-n:], layer.name
        assert tuple(layer.axis_labels) == ("t", "y", "x")[-n:], layer.name
    assert viewer.layers.extent.units is not None  # one set of units over every layer
    # the legend is a dock widget beside the canvas, not a layer in data space
    legend = viewer.window.dock_widgets[DOCK_NAME]
    assert isinstance(legend, LegendWidget)
    assert list(legend.entries["label"]) == list(legend_entries(movie)["label"])
    assert "≤3 sides" in legend.label.text() and "T1 intercalation" in legend.label.text()
    extent = viewer.layers.extent.world  # the canvas holds the tissue (the legend's column took half of it)
    assert extent[1][-1] < 1.1 * movie.shape[1] * 0.2
    assert np.array_equal(np.asarray(_layer(viewer, "labels").data), tifffile.imread(SAMPLE).astype(np.int64))


def test_the_reader_analyses_a_label_stack_and_declines_other_files(viewer, tmp_path):
    stack = tifffile.imread(SAMPLE)[:3].astype(np.uint16)
    path = tmp_path / "three_labels.tif"  # the manifest claims TIFFs named *labels* only
    tifffile.imwrite(path, stack, photometric="minisblack")
    assert get_reader(str(path)) is read_labels_source
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HexatissueWarning)
        viewer.open(str(path), plugin="hexatissue")
        movie = analyze(open_source(path), workers=1, progress=False)
    assert np.array_equal(np.asarray(_layer(viewer, "labels").data), stack)
    assert _layer(viewer, "polygons").nshapes == int((movie.cells["n_sides"] >= 3).sum())
    assert len(np.unique(_layer(viewer, "tracks").data[:, 0])) == movie.cells["track"].nunique()
    raw = tmp_path / "raw.tif"
    tifffile.imwrite(raw, np.random.default_rng(0).random((20, 30)).astype(np.float32))
    assert get_reader(str(raw)) is None  # an intensity image is not ours
    assert get_reader(str(tmp_path)) is None  # a folder of two different images is not a results folder
    assert get_reader([str(path), str(raw)]) is None


def test_a_raw_tiff_opens_with_napari_alone_and_no_reader_choice(viewer, tmp_path):
    """The manifest does not claim every file: a raw TIFF has one compatible reader (napari's), so opening it
    with no plugin named raises no MultipleReaderError."""
    from napari.plugins import _npe2

    raw = tmp_path / "raw.tif"
    image = np.random.default_rng(0).random((20, 30)).astype(np.float32)
    tifffile.imwrite(raw, image)
    assert "hexatissue" not in _npe2.get_readers(str(raw))
    layers = viewer.open(str(raw), plugin=None)
    assert [layer._type_string for layer in layers] == ["image"] and np.array_equal(layers[0].data, image)
    for name in ("x.csv", "x.npy", "x.zarr", "x.png", "x.parquet"):  # napari's formats stay napari's
        assert "hexatissue" not in _npe2.get_readers(str(tmp_path / name)), name
    for name in ("metadata.json", "TA.db", "cells.mat", "movie_labels.tif"):
        assert "hexatissue" in _npe2.get_readers(str(tmp_path / name)), name


def test_the_manifest_validates_and_its_commands_import():
    """What ``npe2 validate`` checks: the schema, and that every command's python_name resolves."""
    import importlib
    from pathlib import Path

    from npe2 import PluginManifest

    import hexatissue

    manifest = PluginManifest.from_file(Path(hexatissue.__file__).parent / "napari" / "napari.yaml")
    assert manifest.name == "hexatissue"
    for command in manifest.contributions.commands:
        module, _, attr = command.python_name.partition(":")
        assert callable(getattr(importlib.import_module(module), attr)), command.id
    patterns = [pat for r in manifest.contributions.readers for pat in r.filename_patterns]
    assert "*" not in patterns and "*.tif" not in patterns
    assert {w.command for w in manifest.contributions.writers} == {"hexatissue.write_ome_zarr", "hexatissue.write_ctc",
                                                                    "hexatissue.write_geff"}
    assert [s.key for s in manifest.contributions.sample_data] == ["epicure"]
    # and npe2's own command line, importing every python_name (this checkout's package first on the path)
    import subprocess
    import sys

    root = Path(hexatissue.__file__).resolve().parents[1]
    run = subprocess.run([sys.executable, "-m", "npe2", "validate", "--imports",
                          str(root / "hexatissue" / "napari" / "napari.yaml")], capture_output=True, text=True,
                         env=os.environ | {"PYTHONPATH": str(root)}, timeout=300)
    assert run.returncode == 0 and "valid!" in run.stdout, run.stdout + run.stderr


def test_the_sample_is_the_calibrated_epicure_label_movie(viewer):
    viewer.open_sample("hexatissue", "epicure")
    layer = viewer.layers[-1]
    assert layer._type_string == "labels" and layer.data.shape == (11, 160, 257)
    assert np.array_equal(layer.data, tifffile.imread(SAMPLE).astype(np.int32))
    assert tuple(layer.scale) == (300.0, 0.2, 0.2) and tuple(layer.axis_labels) == ("t", "y", "x")
    assert [str(u) for u in layer.units] == ["second", "micrometer", "micrometer"]


def test_the_writers_save_ome_zarr_ctc_and_geff_from_the_layers(viewer, epicure, tmp_path):
    """Each writer's output read back: the OME-Zarr labels are the layer's, the CTC masks are the labels with
    track ids (hexatissue.exchange.track_masks) and the lineage, the GEFF graphs hold every cell."""
    import zarr

    from hexatissue.exchange.ctc import read_ctc
    from hexatissue.exchange.geff import read_geff
    from hexatissue.exchange.labels import track_masks

    viewer.open(str(epicure), plugin="hexatissue")
    movie = read_results(epicure)
    labels, polygons = viewer.layers["labels"], viewer.layers["polygons"]
    stack = np.asarray(labels.data)

    viewer.layers.selection.clear()
    viewer.layers.selection.add(labels)
    out = tmp_path / "labels.zarr"
    viewer.layers.save(str(out), selected=True, plugin="hexatissue")
    root = zarr.open_group(str(out), mode="r")
    assert np.array_equal(np.asarray(root["labels/cells/0"]), stack)  # the image at the root, the labels beside it
    datasets = root["labels/cells"].attrs.asdict()
    assert "300" in str(datasets) and "0.2" in str(datasets)  # the layer's scale in the multiscales metadata

    viewer.layers.selection.add(polygons)
    viewer.layers.save(str(tmp_path / "ctc"), selected=True, plugin="hexatissue")
    masks, tracks = read_ctc(tmp_path / "ctc")
    expected = np.stack(track_masks(movie, labels=stack))
    assert np.array_equal(masks > 0, expected > 0)
    # the same cells: write_ctc may give a track with a gap new ids, never merge or split cells
    for t in range(len(masks)):
        pairs = np.unique(np.c_[expected[t].ravel(), masks[t].ravel()], axis=0)
        pairs = pairs[pairs[:, 0] > 0]
        assert len(np.unique(pairs[:, 0])) == len(np.unique(pairs[:, 1])) == len(pairs), t
    daughters = tracks.loc[tracks["parent"] > 0]
    assert len(daughters) >= 2 and len(tracks) >= len(movie.lineage)  # the division 73 -> 477 + 490

    viewer.layers.selection.remove(labels)
    viewer.layers.save(str(tmp_path / "geff"), selected=True, plugin="hexatissue")
    graph, _ = read_geff(tmp_path / "geff" / "neighbours.geff")
    assert graph.number_of_nodes() == len(movie.cells)

    # a layer hexatissue did not make has no results to export (napari turns the error into a warning)
    from hexatissue.errors import InputError
    from hexatissue.napari.writers import write_ctc_layers

    plain = viewer.add_labels(stack, name="plain")
    with pytest.raises(InputError, match="CTC: layer 'plain' holds no hexatissue results"):
        write_ctc_layers(str(tmp_path / "ctc2"), [plain.as_layer_data_tuple(), plain.as_layer_data_tuple()[:2] +
                                                  ("shapes",)])


def test_the_reader_opens_cell_polygons_without_labels(viewer, tmp_path):
    """A vertices table of a 3 x 2 grid of unit-10 squares (hand-made truth: 6 quadrilaterals, 12 vertices)."""
    import pandas as pd

    rows = []
    for cell, (i, j) in enumerate([(i, j) for j in range(2) for i in range(3)], start=1):
        x0, y0 = 10.0 * i, 10.0 * j
        rows += [(cell, x, y) for x, y in ((x0, y0), (x0, y0 + 10), (x0 + 10, y0 + 10), (x0 + 10, y0))]
    path = tmp_path / "vertices.csv"
    pd.DataFrame(rows, columns=["cell", "x", "y"]).to_csv(path, index=False)
    assert get_reader(str(path)) is read_labels_source
    # a CSV is napari's (its points/shapes reader): the manifest does not claim it, Python calls the reader
    from napari.layers import Layer

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HexatissueWarning)
        for data, kwargs, kind in read_labels_source(str(path)):
            viewer.add_layer(Layer.create(data, kwargs, kind))
    assert "labels" not in [layer.name for layer in viewer.layers]
    polygons = viewer.layers["polygons"]
    assert polygons.nshapes == 6 and list(polygons.features["n_sides"]) == [4] * 6
    assert len(viewer.layers["vertices"].data) == 12
    first = polygons.features["cell"].tolist().index(1)
    assert {tuple(v) for v in polygons.data[first]} == {(0, 0), (10, 0), (10, 10), (0, 10)}  # (y, x)


def test_a_headless_screenshot_of_the_epicure_sample_shows_polygons_stars_and_defects(viewer, epicure, tmp_path):
    from hexatissue.napari.screenshot import canvas_image

    if not os.environ.get("DISPLAY"):
        pytest.skip("OpenGL needs an X server: run the napari tests under xvfb-run")
    viewer.open(str(epicure), plugin="hexatissue")
    viewer.dims.set_point(0, 0)
    viewer.reset_view()
    path = tmp_path / "napari_epicure.png"
    image = canvas_image(viewer, path)
    assert path.stat().st_size > 10_000
    rgb = image[..., :3].reshape(-1, 3)
    assert len(np.unique(rgb, axis=0)) > 200 and rgb.std() > 20
    # the defect colours (red +1/6, blue -1/6) are drawn
    red = (rgb[:, 0] > 180) & (rgb[:, 1] < 80) & (rgb[:, 2] < 80)
    blue = (rgb[:, 2] > 180) & (rgb[:, 0] < 80) & (rgb[:, 1] < 140)
    assert red.sum() > 50 and blue.sum() > 50
    # hiding polygons, stars and defects leaves a different picture
    for name in ("polygons", "gamma6 stars", "Gamma6 defects", "Gamma2 defects"):
        _layer(viewer, name).visible = False
    assert np.abs(canvas_image(viewer).astype(int) - image).mean() > 5


def test_canvas_image_refuses_clearly_without_an_opengl_context(tmp_path):
    """No display: the viewer has no GL context; the helper says so (InputError, exit 1) instead of crashing
    inside vispy (rc 134 when it happens in a Qt paint callback)."""
    import subprocess
    import sys
    from pathlib import Path

    script = ("import napari\nfrom hexatissue.napari.screenshot import canvas_image\n"
              "canvas_image(napari.Viewer(show=False))\n")
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    env |= {"QT_QPA_PLATFORM": "offscreen", "PYTHONPATH": str(Path(__file__).resolve().parents[1])}
    run = subprocess.run([sys.executable, "-c", script], env=env, cwd=tmp_path, capture_output=True, text=True,
                         timeout=300)
    assert run.returncode == 1, run.stderr[-2000:]
    assert "InputError: viewer has no OpenGL context to render with" in run.stderr


def test_canvas_image_refuses_a_closed_viewer():
    from hexatissue.errors import InputError
    from hexatissue.napari.screenshot import canvas_image

    v = napari.Viewer(show=False)
    v.close()
    with pytest.raises(InputError, match="viewer is closed"):
        canvas_image(v)


def _run(widget):
    """Press Analyze and process Qt events until the widget is done (button enabled again); True when it is."""
    from qtpy.QtWidgets import QApplication

    widget.start()
    deadline = time.monotonic() + 300  # a bound on the wait, not a timing assertion
    while not widget.run.enabled and time.monotonic() < deadline:
        QApplication.processEvents()
        time.sleep(0.02)
    QApplication.processEvents()
    return widget.run.enabled


def test_the_widget_analyses_a_labels_layer_and_adds_the_layers(viewer):
    from hexatissue.napari.widget import AnalyzeWidget

    stack = tifffile.imread(SAMPLE)[:3].astype(np.int32)
    # a calibrated layer, as an OME-Zarr reader gives it: 0.2 um pixels, shifted
    viewer.add_labels(stack, name="epicure", scale=(1, 0.2, 0.2), translate=(0, 4.0, 6.0),
                      units=("pixel", "um", "um"), axis_labels=("t", "y", "x"))
    widget = AnalyzeWidget(viewer)
    viewer.window.add_dock_widget(widget)
    widget.reset_choices()
    widget.layer.value = viewer.layers["epicure"]
    widget.track_mode.value = "never"
    # every stage view's fields, from the options classes: flow on, force inference off by default
    assert widget.flow.value is True and widget.mechanics.value is False and widget.merge_distance.value == 2.0
    widget.deformation.value = True
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HexatissueWarning)
        done = _run(widget)
        movie = analyze(stack, track=TrackOptions(mode="never"), order=OrderOptions(p=(6,)), workers=1,
                        progress=False)
    assert done, "the analysis did not finish"
    names = [layer.name for layer in viewer.layers]
    assert names == ["epicure", "polygons", "vertices", "gamma6 stars", "Gamma6 defects", "T1 events", "tracks",
                     "flow", "shear rate (total)", "shear rate (T1s)"]
    assert widget.status.value == "added 9 layers"
    assert isinstance(viewer.window.dock_widgets[DOCK_NAME], LegendWidget)
    assert viewer.layers["polygons"].nshapes == int((movie.cells["n_sides"] >= 3).sum())
    assert len(viewer.layers["Gamma6 defects"].data) == len(movie.defects)
    for layer in viewer.layers[1:]:  # every result layer on the input's grid, so they lie over it
        n = layer.ndim
        assert tuple(layer.scale) == (1.0, 0.2, 0.2)[-n:], layer.name
        assert tuple(layer.translate) == (0.0, 4.0, 6.0)[-n:], layer.name
        assert [str(u) for u in layer.units] == ["pixel", "micrometer", "micrometer"][-n:], layer.name
        assert tuple(layer.axis_labels) == ("t", "y", "x")[-n:], layer.name
    assert viewer.layers.extent.units is not None  # napari's "Inconsistent units across layers" when None
    # the calibration came from the layer: the results are in um
    cal = viewer.layers["polygons"].metadata["calibration"]
    assert (cal["pixel_size"], cal["length_unit"], cal["time_unit"]) == (0.2, "um", "frame")
    # a polygon vertex lands on its pixel's world position: translate + scale * (row, col)
    row, col = viewer.layers["polygons"].data[0][0][1:]
    assert np.allclose(viewer.layers["polygons"].data_to_world([0, row, col])[1:],
                       viewer.layers["epicure"].data_to_world([0, row, col])[1:])


def test_the_widget_runs_in_a_shown_viewer_without_aborting(tmp_path):
    """A shown viewer (as users have it): the progress bar must be made in the main thread; made in the worker
    it aborted Python (rc 134). In a subprocess, since an abort would end pytest."""
    import subprocess
    import sys
    from pathlib import Path

    if not os.environ.get("DISPLAY"):
        pytest.skip("OpenGL needs an X server: run the napari tests under xvfb-run")
    script = f"""
import time, warnings, numpy as np, tifffile, napari
from qtpy.QtWidgets import QApplication
from hexatissue.napari.widget import AnalyzeWidget
warnings.simplefilter("ignore")
v = napari.Viewer(show=True)
v.window.resize(1300, 900)
v.add_labels(tifffile.imread({str(SAMPLE)!r})[:2].astype(np.int32), name="input", scale=(1, 0.2, 0.2),
             units=("pixel", "um", "um"))
w = AnalyzeWidget(v)
v.window.add_dock_widget(w)
w.reset_choices()
w.layer.value = v.layers["input"]
w.track_mode.value = "never"
w.start()
deadline = time.monotonic() + 300
while not w.run.enabled and time.monotonic() < deadline:
    QApplication.processEvents()
    time.sleep(0.02)
QApplication.processEvents()
print(w.status.value)
print(",".join(layer.name for layer in v.layers))
"""
    env = os.environ | {"QT_QPA_PLATFORM": "offscreen", "PYTHONPATH": str(Path(__file__).resolve().parents[1])}
    run = subprocess.run([sys.executable, "-c", script], env=env, cwd=tmp_path, capture_output=True, text=True,
                         timeout=600)
    assert run.returncode == 0, run.stderr[-3000:]
    status, names = run.stdout.strip().splitlines()[-2:]
    names = names.split(",")
    assert names[0] == "input" and {"polygons", "gamma6 stars", "Gamma6 defects"} <= set(names)
    assert status == f"added {len(names) - 1} layers"


def test_the_widget_reports_bad_input_in_its_status_line(viewer):
    from hexatissue.napari.widget import AnalyzeWidget

    viewer.add_labels(tifffile.imread(SAMPLE)[:2].astype(np.int32), name="epicure")
    widget = AnalyzeWidget(viewer)
    widget.reset_choices()
    widget.layer.value = viewer.layers["epicure"]
    widget.pixel_size.value = 0.2
    widget.length_unit.value = "parsec"
    assert _run(widget)
    assert widget.status.value.startswith("error: length unit 'parsec' is not a known unit")
    assert [layer.name for layer in viewer.layers] == ["epicure"] and widget.run.enabled


def test_the_widget_fields_come_from_the_options_classes(viewer):
    """Choices, defaults and help (tooltips) of the widget are those of the stages' options, as on the CLI."""
    from hexatissue.napari.widget import AnalyzeWidget
    from hexatissue.options import TRACK_MODES, MeshOptions, OrderOptions

    widget = AnalyzeWidget(viewer)
    assert tuple(widget.track_mode.choices) == TRACK_MODES and widget.track_mode.value == "auto"
    assert widget.merge_distance.value == MeshOptions().merge_distance
    assert "four-fold" in widget.merge_distance.tooltip
    assert OrderOptions().radius is None and widget.radius.value == 0  # 0 = chosen from the data
    assert widget.deformation.value is False and "deformation budget" in widget.deformation.tooltip


def test_the_widget_offers_a_new_stage_s_field_and_runs_it(viewer, toy_stage):
    """A stage added with its entry alone (tests/test_stages.py) gets its field in the analyze widget, and
    run_analysis gives that stage its value and shows its layer."""
    from hexatissue.napari.widget import AnalyzeWidget, run_analysis
    from hexatissue.synthetic import voronoi_movie

    widget = AnalyzeWidget(viewer)
    assert widget.toy_factor.value == 2.0 and widget.toy_factor.tooltip == "factor of the toy area"
    movie_frames = voronoi_movie(30, (64, 64), 3, periodic=False, amplitude=0.3, seed=1)
    labels = np.stack([np.asarray(movie_frames[t]) for t in range(3)])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HexatissueWarning)
        layers = run_analysis(labels, toy_factor=4.0, progress=False)
    by_name = {kw["name"]: (data, kw) for data, kw, _ in layers}
    movie = by_name["toy cells"][1]["metadata"]["movie"]
    assert movie.options["toy"].factor == 4.0
    np.testing.assert_allclose(by_name["toy cells"][1]["features"]["toy_area"], 4.0 * movie.cells["area"])
    with pytest.raises(TypeError, match="toy_facto"):
        run_analysis(labels, toy_facto=4.0)
