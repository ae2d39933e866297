"""Figures render to non-trivial PNG files and show what they claim."""
import numpy as np
import pandas as pd
import pytest
from scipy.spatial import Voronoi

from hexatissue import Box, InputError
from hexatissue.units import Calibration
from hexatissue import plot
from hexatissue.views.order import save_analysis_figures
from hexatissue.defects import find_defects
from hexatissue.order import cells_from_polygons, coarse_grain


def voronoi_tissue(seed=0, n=9, a=20.0):
    """Interior Voronoi polygons of jittered seeds: ({cell: polygon}, cells table with gamma2, gamma6)."""
    rng = np.random.default_rng(seed)
    j, i = np.meshgrid(np.arange(n), np.arange(n))
    seeds = np.c_[(j + 0.5 * (i % 2)).ravel() * a, i.ravel() * a * 0.87] + rng.uniform(-3, 3, (n * n, 2)) + 30
    vor = Voronoi(seeds)
    polygons = {}
    for k, region in enumerate(vor.point_region):
        verts = vor.regions[region]
        if verts and -1 not in verts:
            poly = vor.vertices[verts]
            if np.all(np.hypot(*(poly - seeds[k]).T) < 2 * a):
                polygons[k + 1] = poly
    ids = np.array(list(polygons))
    return polygons, cells_from_polygons(polygons, centers=seeds[ids - 1])


def png_pixels(path):
    from matplotlib.image import imread

    assert path.exists() and path.stat().st_size > 10_000
    img = imread(path)[..., :3]
    assert img.shape[0] > 300 and img.shape[1] > 300
    assert img.std() > 0.05  # not a blank canvas
    return img


def count_color(img, hex_color, tol=0.08):
    from matplotlib.colors import to_rgb

    return int((np.abs(img - np.array(to_rgb(hex_color))).max(axis=-1) < tol).sum())


def test_plot_labels_with_polygons(tmp_path):
    polygons, cells = voronoi_tissue()
    labels = np.zeros((200, 240), np.int32)
    labels[20:100, 30:120], labels[100:180, 30:200] = 1, 2
    fig = plot.plot_labels(labels=labels, polygons=polygons, cells=cells, show_ids=True, path=tmp_path / "l.png")
    png_pixels(tmp_path / "l.png")
    ax = fig.axes[0]
    assert len(ax.collections[0].get_paths()) == len(polygons)
    assert ax.yaxis_inverted()  # image orientation: row 0 at the top
    assert len(ax.texts) == len(cells)
    grey = plot.plot_labels(image=np.random.default_rng(0).random((50, 60)), path=tmp_path / "g.png")
    assert grey.axes[0].get_xlim() == (-0.5, 59.5)
    with pytest.raises(InputError):
        plot.plot_labels()


@pytest.mark.parametrize("p", [2, 6])
def test_plot_stars_draws_p_legs_along_the_orientation(tmp_path, p):
    polygons, cells = voronoi_tissue(1)
    fig = plot.plot_stars(cells, p=p, polygons=polygons, path=tmp_path / "s.png")
    img = png_pixels(tmp_path / "s.png")
    assert count_color(img, "#b0006e", tol=0.1) > 100
    lines = [c for c in fig.axes[0].collections if c.__class__.__name__ == "LineCollection"][0]
    segments = np.array(lines.get_segments())
    assert len(segments) == p * len(cells)
    # first leg of each star points along Arg(gamma_p)/p, with length proportional to |gamma_p|
    first = segments.reshape(len(cells), p, 2, 2)[:, 0]
    leg = first[:, 1] - first[:, 0]
    gamma = cells[f"gamma{p}_re"] + 1j * cells[f"gamma{p}_im"]
    np.testing.assert_allclose(np.exp(1j * p * np.arctan2(leg[:, 1], leg[:, 0])), np.exp(1j * np.angle(gamma)),
                               atol=1e-9)
    np.testing.assert_allclose(np.hypot(leg[:, 0], leg[:, 1]) / np.abs(gamma),
                               np.hypot(leg[0, 0], leg[0, 1]) / abs(gamma.iloc[0]))


def quadrupole_grid():
    """Periodic quadrupole: cells on a jittered square lattice with gamma6 = W/|W|."""
    rng = np.random.default_rng(3)
    box = Box(200.0, 200.0)
    g = np.arange(0, 200, 10.0) + 5
    xy = np.stack(np.meshgrid(g, g), -1).reshape(-1, 2) + rng.uniform(-2, 2, (400, 2))
    z = (xy[:, 0] - 100) + 1j * (xy[:, 1] - 100)
    w = (z**2 + 30**2) / (z**2 - 30**2)
    cells = pd.DataFrame({"x": xy[:, 0], "y": xy[:, 1], "area": 100.0, "is_border": False,
                          "gamma6_re": (w / abs(w)).real, "gamma6_im": (w / abs(w)).imag})
    grid = coarse_grain(cells, box=box)
    return grid, find_defects(grid, box=box), box


def test_plot_order_field_shows_red_plus_and_blue_minus_defects(tmp_path):
    grid, defects, box = quadrupole_grid()
    assert sorted(defects["charge"] * 6) == [-1, -1, 1, 1]
    fig = plot.plot_order_field(grid, defects, p=6, box=box, path=tmp_path / "f.png")
    img = png_pixels(tmp_path / "f.png")
    assert count_color(img, plot.PLUS_COLOR) > 50 and count_color(img, plot.MINUS_COLOR) > 50
    ax = fig.axes[0]
    assert ax.get_xlim() == (0.0, 200.0)
    plus = [ln for ln in ax.lines if ln.get_label() == "$+1/6$"][0]
    np.testing.assert_allclose(sorted(plus.get_xdata()), sorted(defects.loc[defects["charge"] > 0, "x"]))
    # without defects, no red or blue markers
    plot.plot_order_field(grid, defects.iloc[:0], p=6, box=box, path=tmp_path / "f0.png")
    img0 = png_pixels(tmp_path / "f0.png")
    assert count_color(img0, plot.PLUS_COLOR) == 0 and count_color(img0, plot.MINUS_COLOR) == 0


def test_plot_order_field_refuses_several_frames():
    grid, defects, box = quadrupole_grid()
    two = pd.concat([grid.assign(frame=0), grid.assign(frame=1)])
    with pytest.raises(InputError, match="frame"):
        plot.plot_order_field(two)


def test_plot_stress_colours_cells_by_value(tmp_path):
    polygons, cells = voronoi_tissue(2)
    cells["sigma2"] = np.linspace(-1, 3, len(cells))
    fig = plot.plot_stress(cells, "sigma2", polygons, path=tmp_path / "st.png")
    png_pixels(tmp_path / "st.png")
    coll = fig.axes[0].collections[0]
    np.testing.assert_allclose(coll.get_array(), cells.set_index("cell").loc[list(polygons), "sigma2"])
    assert coll.norm.vmin == -3 and coll.norm.vmax == 3  # symmetric about zero
    with pytest.raises(InputError, match="sigma6"):
        plot.plot_stress(cells, "sigma6", polygons)


def test_plot_order_vs_radius(tmp_path):
    curve = pd.DataFrame({"p": [2] * 3 + [6] * 3, "factor": [1, 2, 3] * 2, "abs_Gamma": [0.4, 0.3, 0.2, 0.5, 0.3, 0.1]})
    fig = plot.plot_order_vs_radius(curve, path=tmp_path / "c.png")
    png_pixels(tmp_path / "c.png")
    assert len(fig.axes[0].get_legend().get_texts()) == 2


def test_figures_draw_into_given_axes():
    from matplotlib.figure import Figure

    polygons, cells = voronoi_tissue()
    fig = Figure()
    axes = fig.subplots(1, 2)
    assert plot.plot_stars(cells, 6, ax=axes[0]) is fig
    assert plot.plot_labels(polygons=polygons, ax=axes[1]) is fig


def test_figures_from_a_label_image(tmp_path):
    from hexatissue import mesh_from_labels, shape_order
    from hexatissue.synthetic import jittered_seeds, voronoi_labels

    labels = voronoi_labels(jittered_seeds((120, 150), 15.0, seed=4), (120, 150))
    frame = shape_order(mesh_from_labels(labels))
    polygons = frame.polygons()
    fig = plot.plot_labels(labels, polygons, frame.cells, path=tmp_path / "labels.png")
    png_pixels(tmp_path / "labels.png")
    assert len(fig.axes[0].collections[0].get_paths()) == len(frame.cells)
    assert fig.axes[0].get_xlim() == (-0.5, 149.5) and fig.axes[0].get_ylim() == (119.5, -0.5)
    plot.plot_stars(frame.cells, 6, polygons=polygons, labels=labels, path=tmp_path / "stars.png")
    png_pixels(tmp_path / "stars.png")
    grid = coarse_grain(frame.cells)
    plot.plot_order_field(grid, find_defects(grid), polygons=polygons, labels=labels, path=tmp_path / "field.png")
    png_pixels(tmp_path / "field.png")


def test_save_analysis_figures_of_a_periodic_frame(tmp_path):
    from hexatissue import mesh_from_labels, shape_order
    from hexatissue.synthetic import jittered_seeds, voronoi_labels

    labels = voronoi_labels(jittered_seeds((90, 120), 15.0, seed=5), (90, 120), periodic=True)
    frame = shape_order(mesh_from_labels(labels, box=Box(120, 90)))
    paths = save_analysis_figures(frame, tmp_path / "figs", labels=labels, prefix="f0_")
    assert [p.name for p in paths] == ["f0_polygons.png", "f0_stars6.png", "f0_gamma6_defects.png"]
    for path in paths:
        png_pixels(path)


def test_periodic_polygons_are_drawn_with_their_copies(tmp_path):
    box = Box(50.0, 40.0)
    square = np.array([[0, 0], [6, 0], [6, 6], [0, 6]], float)
    polygons = {1: square + [20, 15],  # inside
                2: square + [47, 17],  # crosses x = L: one copy
                3: square + [-53, 37]}  # unwrapped one box away, crosses x = 0 and y = L: four copies
    cells = pd.DataFrame({"cell": [1, 2, 3], "sigma": [1.0, 2.0, 3.0]})
    fig = plot.plot_stress(cells, "sigma", polygons, box=box, path=tmp_path / "p.png")
    coll = fig.axes[0].collections[0]
    assert sorted(coll.get_array()) == [1.0, 2.0, 2.0, 3.0, 3.0, 3.0, 3.0]
    for path in coll.get_paths():
        xy = path.vertices
        assert (xy.max(axis=0) > 0).all() and (xy.min(axis=0) < box.lengths).all()
    assert fig.axes[0].get_xlim() == (0.0, 50.0)


# ----------------------------------------------------------------------------
# Scale bars: physical units on every image figure
# ----------------------------------------------------------------------------

@pytest.mark.parametrize("width, length", [(51.4, 10), (100, 20), (257, 50), (30, 5), (170, 50), (160, 50),
                                           (3.0, 0.5), (0.9, 0.2), (1e4, 2000), (12, 2)])
def test_scale_bar_length_is_a_round_number_near_a_fifth_of_the_width(width, length):
    chosen = plot.scale_bar_length(width)
    assert chosen == length
    assert 0.12 < chosen / width < 0.32


def test_scale_bar_length_refuses_a_bad_width():
    for width in (0, -3, np.nan):
        with pytest.raises(InputError):
            plot.scale_bar_length(width)


def scale_bars(ax):
    return [a for a in ax.artists if a.get_gid() == plot.SCALE_BAR_GID]


def bar_length_and_label(ax):
    """(length of the one scale bar in data coordinates = px, its label)."""
    (bar,) = scale_bars(ax)
    (rect,) = bar.size_bar.get_children()
    return rect.get_width(), bar.txt_label.get_children()[0].get_text()


@pytest.mark.parametrize("calibration, length_px, label", [
    (None, 20.0, "20 px"),  # 150 px wide: 20 % is 30 px -> 20 px
    (Calibration(0.2, "um"), 25.0, "5 µm"),  # 30 µm wide -> 5 µm = 25 px
    (Calibration(0.65, "micron"), 20 / 0.65, "20 µm"),  # 97.5 µm wide -> 20 µm
    (Calibration(130.0, "nm"), 5000 / 130, "5000 nm"),  # 19.5 µm wide -> 5000 nm
])
def test_scale_bar_length_in_pixels_is_the_physical_length_over_the_pixel_size(calibration, length_px, label):
    labels = np.zeros((120, 150), np.int32)
    labels[20:100, 30:120] = 1
    ax = plot.plot_labels(labels, calibration=calibration).axes[0]
    length, text = bar_length_and_label(ax)
    assert length == pytest.approx(length_px) and text == label
    assert ax.get_xticks().size == 0 and ax.get_yticks().size == 0  # no ticks: the bar carries the scale


def test_every_image_figure_has_one_scale_bar_at_the_bottom_right():
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    cal = Calibration(0.5, "um")
    polygons, cells = voronoi_tissue(2)  # about 220 px wide
    cells["sigma"] = np.linspace(-1, 1, len(cells))
    grid, defects, box = quadrupole_grid()  # 200 px = 100 µm -> 20 µm = 40 px
    figs = [plot.plot_labels(polygons=polygons, calibration=cal), plot.plot_stars(cells, 6, calibration=cal),
            plot.plot_stress(cells, "sigma", polygons, calibration=cal),
            plot.plot_order_field(grid, defects, box=box, calibration=cal)]
    for fig in figs:
        ax = fig.axes[0]
        width_um = 0.5 * np.ptp(ax.get_xlim())
        length, text = bar_length_and_label(ax)
        assert text == f"{plot.scale_bar_length(width_um):g} µm" and length == 2 * plot.scale_bar_length(width_um)
        FigureCanvasAgg(fig).draw()
        inside, frame = scale_bars(ax)[0].get_window_extent(), ax.get_window_extent()
        assert inside.x0 > frame.x0 + 0.5 * frame.width and inside.x1 < frame.x1  # right half
        assert inside.y0 > frame.y0 and inside.y1 < frame.y0 + 0.5 * frame.height  # bottom half
    assert bar_length_and_label(figs[-1].axes[0]) == (40.0, "20 µm")
    # drawing a second layer into the same axes replaces the bar instead of stacking one more
    ax = figs[2].axes[0]
    plot.plot_stars(cells, 6, ax=ax, calibration=cal)
    assert len(scale_bars(ax)) == 1


def test_scale_bar_on_a_given_axes_and_bad_calibration():
    from matplotlib.figure import Figure

    ax = Figure().add_subplot()
    ax.set_xlim(0, 1000)
    ax.set_ylim(500, 0)
    bar = plot.add_scale_bar(ax, Calibration(0.1, "um"))  # 100 µm wide -> 20 µm = 200 px
    assert bar.size_bar.get_children()[0].get_width() == pytest.approx(200.0)
    _, cells = voronoi_tissue()
    with pytest.raises(InputError, match="Calibration"):
        plot.plot_stars(cells, 6, calibration=0.2)


def test_save_analysis_figures_takes_the_frame_calibration(tmp_path, monkeypatch):
    from hexatissue import mesh_from_labels, shape_order
    from hexatissue.synthetic import jittered_seeds, voronoi_labels

    labels = voronoi_labels(jittered_seeds((90, 120), 15.0, seed=5), (90, 120))
    frame = shape_order(mesh_from_labels(labels))
    used = []
    original = plot.add_scale_bar

    def recording(ax, calibration=None, extent=None, fraction=0.2):
        used.append(calibration)
        return original(ax, calibration, extent, fraction)

    monkeypatch.setattr(plot, "add_scale_bar", recording)
    save_analysis_figures(frame, tmp_path, labels=labels)
    assert used == [Calibration()] * 3

    class CalibratedFrame:  # stands in for a Frame that carries its calibration
        def __init__(self, frame, calibration):
            self.cells, self.box, self.polygons, self.calibration = frame.cells, frame.box, frame.polygons, calibration

    used.clear()
    cal = Calibration(0.2, "um")
    save_analysis_figures(CalibratedFrame(frame, cal), tmp_path, labels=labels)
    assert used == [cal] * 3
    used.clear()
    explicit = Calibration(0.1, "um")
    save_analysis_figures(CalibratedFrame(frame, cal), tmp_path, labels=labels, calibration=explicit)
    assert used == [explicit] * 3
