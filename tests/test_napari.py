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
from hexatissue.napari.reader import get_reader, read_folder, read_labels_source  # noqa: E402
from tests.test_napari_layers import SAMPLE, epicure  # noqa: E402,F401  (the analysed sample, a fixture)

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
    viewer.open(str(epicure), plugin="hexatissue")
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
        assert tuple(layer.scale) == (300.0, 0.2, 0.2), layer.name
        assert [str(u) for u in layer.units] == ["second", "micrometer", "micrometer"], layer.name
    assert np.array_equal(np.asarray(_layer(viewer, "labels").data), tifffile.imread(SAMPLE).astype(np.int64))


def test_the_reader_analyses_a_label_stack_and_declines_other_files(viewer, tmp_path):
    stack = tifffile.imread(SAMPLE)[:3].astype(np.uint16)
    path = tmp_path / "three.tif"
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
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HexatissueWarning)
        viewer.open(str(path), plugin="hexatissue")
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
    viewer.add_labels(stack, name="epicure")
    widget = AnalyzeWidget(viewer)
    viewer.window.add_dock_widget(widget)
    widget.reset_choices()
    widget.layer.value = viewer.layers["epicure"]
    widget.pixel_size.value = 0.2
    widget.track_mode.value = "never"
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
    assert viewer.layers["polygons"].nshapes == int((movie.cells["n_sides"] >= 3).sum())
    assert len(viewer.layers["Gamma6 defects"].data) == len(movie.defects)
    assert tuple(viewer.layers["polygons"].scale) == (1.0, 0.2, 0.2)


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
