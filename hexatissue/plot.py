"""Figures of tissues, p-atic order, defects and stresses (matplotlib, imported lazily).

Every function draws into ``ax`` when given (else a new figure), returns the
matplotlib :class:`~matplotlib.figure.Figure`, and writes a PNG atomically
when ``path`` is given.  Figures are built without pyplot (no global state,
no GUI backend), so they work in scripts, threads and headless servers.
Positions follow the package convention: x = column, y = row, origin at the
centre of pixel (0, 0); images are drawn with row 0 at the top, so axes are
in image orientation (y grows downwards).

Figures of a tissue in image coordinates carry a scale bar (see
:func:`add_scale_bar`) in the physical length unit of their
:class:`~hexatissue.units.Calibration` (in px when there is none) and have
no axis ticks: the data stay in pixels like the tables, so ticks would show
either pixels or converted numbers that match no table, while a scale bar
reads the same on a full image, a crop or a periodic box.

Polygons are given as ``{cell: (n, 2) array of (x, y)}``, e.g.
:meth:`hexatissue.Frame.polygons`.
"""
from __future__ import annotations

import numpy as np

from .box import as_box
from .errors import InputError, as_generator
from .geometry import node_frames
from .io import atomic_path
from .units import as_calibration, in_units, velocity_unit

__all__ = [
    "add_scale_bar",
    "scale_bar_length",
    "plot_labels",
    "plot_stars",
    "plot_order_field",
    "plot_stress",
    "plot_t1_tensions",
    "plot_order_vs_radius",
    "plot_deformation_budget",
    "plot_deformation_map",
    "plot_flow",
    "plot_tensions",
    "plot_tension_histogram",
    "save_figure",
    "typical_spacing",
    "star_segments",
]

#: Colours of positive and negative defects (the paper's Fig. 3: red +, blue -).
PLUS_COLOR = "#d62728"
MINUS_COLOR = "#1f4fd6"
#: Colours of the statistics figures (the paper's analyses and the stages' report figures): T1 events and their
#: control, and the two kinds or populations of a pair (slow / fast, intercalation / cycle).
EVENT_COLOR = "#2a7f62"
CONTROL_COLOR = "#7f7f7f"
SLOW_COLOR = "#1f77b4"
FAST_COLOR = "#ff7f0e"


def _new_axes(ax, figsize):
    if ax is not None:
        return ax.figure, ax
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, dpi=100, layout="constrained")
    return fig, fig.add_subplot()


def save_figure(fig, path, dpi=150):
    """Write ``fig`` to ``path`` as PNG atomically; returns the path."""

    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=dpi)
    return path


def _finish(fig, path):
    if path is not None:
        save_figure(fig, path)
    return fig


def panels(ncols, figsize):
    """A new figure of ``ncols`` axes side by side, for the statistics figures: ``(fig, [ax, ...])``."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, dpi=100, layout="constrained")
    return fig, [fig.add_subplot(1, ncols, k + 1) for k in range(ncols)]


def finish_panels(fig, path, title=None):
    """Head a statistics figure with ``title``, write it to ``path`` (PNG, 110 dpi) when given; returns ``fig``."""
    if title:
        fig.suptitle(title, fontsize=10)
    if path is not None:
        save_figure(fig, path, dpi=110)
    return fig


def empty_panel(ax, text):
    """Say in ``ax``, in grey at its centre, why it has nothing to draw."""
    ax.text(0.5, 0.5, text, ha="center", va="center", transform=ax.transAxes, color="0.4")


def scale_bar_length(width, fraction=0.2):
    """A round length for a scale bar: 1, 2 or 5 x 10^k nearest (on a log scale) to ``fraction * width``.

    Parameters
    ----------
    width : float
        Width of the image, in the unit the bar is labelled in.
    fraction : float
        Wanted length of the bar as a fraction of ``width``.

    Returns
    -------
    float
        The bar length in the unit of ``width``; it lies within a factor
        sqrt(2.5) of ``fraction * width`` (12.6-32 % of the width for the default).
    """
    width, fraction = float(width), float(fraction)
    if not (np.isfinite(width) and width > 0 and 0 < fraction <= 1):
        raise InputError(f"scale bar needs a positive width and 0 < fraction <= 1; got {width!r}, {fraction!r}")
    target = fraction * width
    k = int(np.floor(np.log10(target)))
    # "{m}e{k}" so that e.g. 0.2 is exactly the float 0.2, not 2 * 0.1
    candidates = [float(f"{m}e{e}") for e in (k, k + 1) for m in (1, 2, 5)]
    return min(candidates, key=lambda c: abs(np.log(c / target)))


SCALE_BAR_GID = "scale_bar"


def add_scale_bar(ax, calibration=None, extent=None, fraction=0.2):
    """Draw a scale bar at the bottom right of an image axes (replacing one drawn before).

    A white bar and label on a semi-transparent dark box, so that it shows
    on white label images, dark micrographs and colour maps alike.

    Parameters
    ----------
    ax : matplotlib Axes
        Axes whose data coordinates are pixels.
    calibration : Calibration, optional
        Pixel size and length unit; None (or an uncalibrated one) gives a bar in px.
    extent : tuple of float, optional
        ``(x0, x1, y0, y1)`` of the image in px; the axes limits when None.
    fraction : float
        Wanted bar length as a fraction of the image width (see :func:`scale_bar_length`).

    Returns
    -------
    mpl_toolkits.axes_grid1.anchored_artists.AnchoredSizeBar
        The bar (gid ``"scale_bar"``); ``bar.size_bar`` holds the rectangle,
        whose width is the length in px, ``bar.txt_label`` the label, e.g. ``"10 µm"``.
    """
    from matplotlib.font_manager import FontProperties
    from mpl_toolkits.axes_grid1.anchored_artists import AnchoredSizeBar

    calibration = as_calibration(calibration)
    if extent is None:
        (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    else:
        x0, x1, y0, y1 = extent
    width_px, height_px = abs(x1 - x0), abs(y1 - y0)
    length = scale_bar_length(calibration.length(width_px), fraction)
    for old in [a for a in ax.artists if a.get_gid() == SCALE_BAR_GID]:
        old.remove()
    bar = AnchoredSizeBar(ax.transData, length / calibration.pixel_size, f"{length:g} {calibration.length_label}",
                          "lower right", pad=0.35, borderpad=0.6, sep=3, color="white", frameon=True,
                          size_vertical=0.012 * min(width_px, height_px),
                          fontproperties=FontProperties(size=9, weight="bold"))
    bar.patch.set_facecolor("black")
    bar.patch.set_edgecolor("none")
    bar.patch.set_alpha(0.65)
    bar.set_gid(SCALE_BAR_GID)
    bar.set_zorder(10)
    ax.add_artist(bar)
    return bar


def _image_axes(ax, extent, calibration):
    """Equal aspect, image orientation (row 0 at the top), limits ``(x0, x1, y0, y1)`` if given,
    no ticks, and a scale bar."""
    ax.set_aspect("equal")
    if extent is not None:
        ax.set_xlim(extent[0], extent[1])
        ax.set_ylim(extent[3], extent[2])
    elif not ax.yaxis_inverted():
        ax.invert_yaxis()
    ax.set_xticks([])
    ax.set_yticks([])
    add_scale_bar(ax, calibration, extent)


def _polygon_list(polygons, box=None):
    """``(ids, polygons)``; in a periodic box each polygon is moved so its vertex mean lies in the box,
    and the periodic copies that overlap the box are appended (with repeated ids)."""
    if polygons is None:
        return [], []
    if not isinstance(polygons, dict):
        raise InputError(f"polygons must be a dict {{cell: (n, 2) array}}; got {type(polygons).__name__}")
    ids = list(polygons)
    polys = [np.asarray(polygons[c], float) for c in ids]
    if box is None:
        return ids, polys
    L = box.lengths
    out_ids, out = [], []
    for c, poly in zip(ids, polys):
        poly = poly - L * np.floor(poly.mean(axis=0) / L)
        for shift in np.array([(i, j) for i in (0, -1, 1) for j in (0, -1, 1)]) * L:
            moved = poly + shift
            if (moved.max(axis=0) > 0).all() and (moved.min(axis=0) < L).all():
                out_ids.append(c)
                out.append(moved)
    return out_ids, out


def _draw_polygons(ax, polygons, color="k", linewidth=0.6, box=None):
    from matplotlib.collections import PolyCollection

    polys = _polygon_list(polygons, box)[1]
    if polys:
        ax.add_collection(PolyCollection(polys, closed=True, edgecolors=color, linewidths=linewidth,
                                         facecolors="none"))


def _extent_of(labels=None, polygons=None, xy=None, box=None):
    """Plot limits (x0, x1, y0, y1) from the first available source."""
    if box is not None:
        return (0.0, box.Lx, 0.0, box.Ly)
    if labels is not None:
        rows, cols = np.shape(labels)[:2]
        return (-0.5, cols - 0.5, -0.5, rows - 0.5)
    pts = [np.concatenate(_polygon_list(polygons)[1])] if polygons else []
    if xy is not None and len(xy):
        pts.append(np.asarray(xy, float))
    if not pts:
        return None
    allxy = np.concatenate(pts)
    lo, hi = np.nanmin(allxy, axis=0), np.nanmax(allxy, axis=0)
    pad = 0.02 * max(hi - lo)
    return (lo[0] - pad, hi[0] + pad, lo[1] - pad, hi[1] + pad)


def _label_colors(labels, seed=0):
    """An RGB image of ``labels`` with a random pastel colour per label (0 = white)."""
    labels = np.asarray(labels)
    if labels.ndim != 2:
        raise InputError(f"labels must be a 2-D label image; got shape {labels.shape}")
    uniq, inverse = np.unique(labels, return_inverse=True)
    rng = as_generator(seed)
    palette = 0.55 + 0.4 * rng.random((len(uniq), 3))
    palette[uniq == 0] = 1.0
    return palette[inverse.reshape(labels.shape)]


def _draw_background(ax, labels=None, image=None, alpha=1.0):
    """Label image (random colours) or grey-level image underneath, in pixel coordinates."""
    if image is not None:
        img = np.asarray(image, float)
        if img.ndim != 2:
            raise InputError(f"image must be a 2-D grey-level image; got shape {img.shape}")
        lo, hi = np.percentile(img, [1, 99.5])
        ax.imshow(img, cmap="gray", vmin=lo, vmax=hi, origin="upper", interpolation="nearest", alpha=alpha,
                  extent=(-0.5, img.shape[1] - 0.5, img.shape[0] - 0.5, -0.5))
        return img
    if labels is not None:
        rgb = _label_colors(labels)
        ax.imshow(rgb, origin="upper", interpolation="nearest", alpha=alpha,
                  extent=(-0.5, rgb.shape[1] - 0.5, rgb.shape[0] - 0.5, -0.5))
        return labels
    return None


def plot_labels(labels=None, polygons=None, cells=None, ax=None, path=None, show_ids=False, image=None,
                box=None, calibration=None, figsize=(6, 6)):
    """Label image with the cells' polygons (and optionally their ids).

    Parameters
    ----------
    labels : (rows, cols) int array, optional
        Label image (0 = background/membrane), drawn with a random colour per label.
    polygons : dict, optional
        ``{cell: (n, 2) array of (x, y)}``, drawn as outlines.
    image : (rows, cols) array, optional
        Grey-level micrograph drawn instead of ``labels``.
    box : Box, optional
        Periodic box: polygons are drawn with their periodic copies, clipped to the box.
    cells : pandas.DataFrame, optional
        Cells table (``cell``, ``x``, ``y``; ``is_border``): border cells'
        centres are marked with a grey cross, and ids are written when
        ``show_ids``.
    ax : matplotlib Axes, optional
    path : str or Path, optional
        Where to write the PNG.
    show_ids : bool
        Write every cell's id at its centre.
    calibration : Calibration, optional
        Pixel size and length unit of the scale bar (px when None); the axes
        have no ticks (see the module docstring).

    Returns
    -------
    matplotlib.figure.Figure
    """
    if labels is None and polygons is None and image is None:
        raise InputError("plot_labels needs labels, image and/or polygons")
    fig, ax = _new_axes(ax, figsize)
    background = _draw_background(ax, labels, image)
    _draw_polygons(ax, polygons, color="k" if image is None else "#ffd700", linewidth=0.8, box=box)
    if cells is not None:
        if "is_border" in cells.columns:
            border = cells[cells["is_border"].to_numpy(bool)]
            ax.plot(border["x"], border["y"], "x", color="0.4", ms=3, lw=0)
        if show_ids:
            for _, c in cells.iterrows():
                ax.text(c["x"], c["y"], str(int(c["cell"])), fontsize=5, ha="center", va="center")
    xy = None if cells is None else cells[["x", "y"]].to_numpy()
    _image_axes(ax, _extent_of(background, polygons, xy, as_box(box)), calibration)
    ax.set_title("cells and polygons")
    return _finish(fig, path)


def star_segments(xy, angle, length, p, normals=None):
    """``p`` legs per point: segments from each centre at ``angle + 2 pi k / p``.

    With ``normals`` (one unit normal per point, facing +z: a height map's
    surface) the angles are measured in each point's tangent frame
    (:func:`hexatissue.geometry.node_frames`) and every leg is drawn as the
    image-plane projection of the surface leg: on a tilted surface the star is
    foreshortened along the slope, as the tissue is in the image.
    """
    k = np.arange(p)
    a = angle[:, None] + 2 * np.pi * k[None, :] / p
    if normals is None:
        legs = np.stack([np.cos(a), np.sin(a)], axis=-1)
    else:
        e1, e2 = node_frames(np.asarray(normals, float))
        legs = np.cos(a)[..., None] * e1[:, None, :2] + np.sin(a)[..., None] * e2[:, None, :2]
    ends = xy[:, None, :] + length[:, None, None] * legs
    starts = np.broadcast_to(xy[:, None, :], ends.shape)
    return np.stack([starts, ends], axis=2).reshape(-1, 2, 2)


def _gamma(table, name, p):
    re, im = f"{name}{p}_re", f"{name}{p}_im"
    if re not in table.columns or im not in table.columns:
        raise InputError(f"table is missing columns {re!r}, {im!r} (p = {p})")
    return table[re].to_numpy(float) + 1j * table[im].to_numpy(float)


def typical_spacing(xy):
    """Median nearest-neighbour distance of points ``xy`` (1 if fewer than two)."""
    from scipy.spatial import cKDTree

    xy = xy[np.isfinite(xy).all(axis=1)]
    if len(xy) < 2:
        return 1.0
    d, _ = cKDTree(xy).query(xy, k=2)
    return float(np.median(d[:, 1]))


def plot_stars(cells, p=6, polygons=None, labels=None, ax=None, path=None, scale=0.45, color="#b0006e",
               image=None, box=None, calibration=None, figsize=(6, 6)):
    """p-legged stars at the cell centres showing each cell's p-fold orientation Arg(gamma_p)/p.

    Parameters
    ----------
    cells : pandas.DataFrame
        Cells table with ``x``, ``y`` (px) and ``gamma{p}_re``, ``gamma{p}_im``.
    p : int
        Symmetry order (6: six-legged stars; 2: nematic bars).
    polygons, labels, image, box : optional
        Drawn underneath (see :func:`plot_labels`).
    scale : float
        Leg length for ``|gamma_p| = 1`` in units of the typical cell spacing;
        legs are proportional to ``|gamma_p|``.
    color : str
        Colour of the stars.
    calibration : Calibration, optional
        Pixel size and length unit of the scale bar (px when None); the axes
        have no ticks (see the module docstring).

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax = _new_axes(ax, figsize)
    xy = cells[["x", "y"]].to_numpy(float)
    gamma = _gamma(cells, "gamma", p)
    ok = np.isfinite(gamma) & np.isfinite(xy).all(axis=1)
    background = _draw_background(ax, labels, image, alpha=0.5)
    _draw_polygons(ax, polygons, color="0.35", linewidth=0.6, box=box)
    _add_stars(ax, xy[ok], gamma[ok], p, scale * typical_spacing(xy[ok]), color, linewidth=1.1)
    _image_axes(ax, _extent_of(background, polygons, xy[ok], as_box(box)), calibration)
    ax.set_title(f"cell orientation Arg($\\gamma_{p}$)/{p}")
    return _finish(fig, path)


def _add_stars(ax, xy, value, p, unit_length, color, linewidth, normals=None):
    from matplotlib.collections import LineCollection

    segments = star_segments(xy, np.angle(value) / p, np.abs(value) * unit_length, p, normals)
    ax.add_collection(LineCollection(segments, colors=color, linewidths=linewidth, capstyle="round"))


def _frame_text(table, calibration):
    """``", frame 5"`` (``", frame 5, t = 10 min"`` with a time calibration) of a one-frame table, else ``""``."""
    if table is None or "frame" not in table.columns or not len(table):
        return ""
    t = int(table["frame"].iloc[0])
    cal = as_calibration(calibration)
    return f", frame {t}" + (f", t = {cal.time(t):g} {cal.time_label}" if cal.has_time else "")


def plot_order_field(grid, defects=None, p=6, polygons=None, labels=None, ax=None, path=None, box=None,
                     show_magnitude=True, image=None, calibration=None, figsize=(6.4, 6)):
    """Coarse-grained orientation field of Gamma_p with its +-1/p defects (the paper's Fig. 3c, d).

    Valid grid nodes carry p-legged stars of orientation Arg(Gamma_p)/p and
    length proportional to ``|Gamma_p|``; the background shows ``|Gamma_p|``.
    Positive defects are red discs, negative ones blue triangles.

    Parameters
    ----------
    grid : pandas.DataFrame
        Grid table from :func:`hexatissue.coarse_grain` (one frame).
    defects : pandas.DataFrame, optional
        Defects table from :func:`hexatissue.find_defects` (one frame).
    p : int
        Symmetry order.
    polygons, labels, image : optional
        Cell outlines / label image / grey-level image drawn underneath.
    box : Box, optional
        Periodic box: sets the plot limits; polygons are drawn with their periodic copies.
    show_magnitude : bool
        Shade the valid nodes by ``|Gamma_p|``.
    calibration : Calibration, optional
        Pixel size and length unit of the scale bar (px when None); the axes
        have no ticks (see the module docstring).

    Returns
    -------
    matplotlib.figure.Figure
    """
    for name, table in (("grid", grid), ("defects", defects)):
        if table is not None and "frame" in table.columns and table["frame"].nunique() > 1:
            raise InputError(f"{name} holds several frames; select one frame to plot")
    fig, ax = _new_axes(ax, figsize)
    gamma = _gamma(grid, "Gamma", p)
    valid = np.isfinite(gamma)
    if "valid" in grid.columns:
        valid = valid & grid["valid"].to_numpy(bool)
    xy = grid[["x", "y"]].to_numpy(float)
    background = _draw_background(ax, labels, image, alpha=0.35)
    if show_magnitude and valid.any():
        _shade_magnitude(fig, ax, grid, gamma, valid, p)
    _draw_polygons(ax, polygons, color="0.55", linewidth=0.5, box=as_box(box))
    spacing = _grid_spacing(grid)
    # the longest star spans 0.8 grid spacings, so neighbouring stars never touch
    largest = np.abs(gamma[valid]).max() if valid.any() else 1.0
    # on a height map Gamma_p's angle is measured in each node's tangent frame: the stars are drawn projected
    normals = grid[["normal_x", "normal_y", "normal_z"]].to_numpy(float)[valid] if "normal_x" in grid.columns else None
    _add_stars(ax, xy[valid], gamma[valid] / max(largest, 1e-12), p, 0.4 * spacing, "k", linewidth=0.8,
               normals=normals)
    if defects is not None and len(defects):
        _draw_defects(ax, defects, p, size=8)
    _image_axes(ax, _extent_of(background, polygons, xy, as_box(box)), calibration)
    ax.set_title(f"$\\Gamma_{p}$ orientation and $\\pm 1/{p}$ defects{_frame_text(grid, calibration)}")
    return _finish(fig, path)


def _grid_spacing(grid):
    if "spacing" in grid.columns and len(grid):
        return float(grid["spacing"].iloc[0])
    return typical_spacing(grid[["x", "y"]].to_numpy(float))


def _shade_magnitude(fig, ax, grid, gamma, valid, p):
    """|Gamma_p| as cells of a pcolormesh over the node lattice (invalid nodes blank)."""
    row, col = grid["row"].to_numpy(int), grid["col"].to_numpy(int)
    shape = (row.max() + 1, col.max() + 1)
    mag = np.full(shape, np.nan)
    mag[row[valid], col[valid]] = np.abs(gamma[valid])
    x = np.full(shape, np.nan)
    y = np.full(shape, np.nan)
    x[row, col], y[row, col] = grid["x"].to_numpy(float), grid["y"].to_numpy(float)
    mesh = ax.pcolormesh(x, y, np.ma.masked_invalid(mag), cmap="Greens", vmin=0, vmax=1, shading="nearest",
                         alpha=0.6)
    fig.colorbar(mesh, ax=ax, shrink=0.7, label=f"$|\\Gamma_{p}|$")


def _draw_defects(ax, defects, p, size):
    """Positive defects as red discs, negative ones as blue triangles; ``size`` in points."""
    charge = defects["charge"].to_numpy(float)
    for sel, color, marker, sign in ((charge > 0, PLUS_COLOR, "o", "+"), (charge < 0, MINUS_COLOR, "^", "-")):
        if sel.any():
            units = np.unique(np.rint(np.abs(charge[sel]) * p).astype(int))
            label = f"${sign}1/{p}$" if list(units) == [1] else f"${sign}$ ({', '.join(f'{u}/{p}' for u in units)})"
            ax.plot(defects["x"].to_numpy()[sel], defects["y"].to_numpy()[sel], marker, color=color, ms=size,
                    mec="k", mew=0.6, lw=0, label=label, zorder=5)
    ax.legend(loc="upper right", fontsize=8, framealpha=0.85)


def plot_stress(cells, column, polygons, ax=None, path=None, cmap="RdBu_r", title=None, box=None,
                calibration=None, figsize=(6.4, 6)):
    """Cells filled with a colour by a per-cell value, e.g. the stress (the paper's Fig. 3a, b).

    Parameters
    ----------
    cells : pandas.DataFrame
        Cells table with ``cell`` and the column ``column`` (e.g. the output
        of :func:`hexatissue.simulate.stress.cell_stress` stored as ``sigma6``).
    column : str
        Column to colour by; the colour scale is symmetric about zero.
    polygons : dict
        ``{cell: (n, 2) array of (x, y)}``; cells without a polygon are not drawn.
    cmap : str
        Diverging colour map.
    box : Box, optional
        Periodic box: polygons are drawn with their periodic copies, clipped to the box.
    calibration : Calibration, optional
        Pixel size and length unit of the scale bar (px when None); the axes
        have no ticks (see the module docstring).

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.collections import PolyCollection
    from matplotlib.colors import Normalize

    if column not in cells.columns:
        raise InputError(f"cells has no column {column!r} to colour by")
    ids, polys = _polygon_list(polygons, box)
    if not polys:
        raise InputError("plot_stress needs the cells' polygons")
    value = cells.set_index("cell")[column].reindex(ids).to_numpy(float)
    finite = np.isfinite(value)
    vmax = float(np.abs(value[finite]).max()) if finite.any() else 0.0
    vmax = vmax if vmax > 0 else 1.0
    fig, ax = _new_axes(ax, figsize)
    coll = PolyCollection([q for q, f in zip(polys, finite) if f], closed=True, edgecolors="k", linewidths=0.4,
                          cmap=cmap, norm=Normalize(-vmax, vmax))
    coll.set_array(value[finite])
    ax.add_collection(coll)
    fig.colorbar(coll, ax=ax, shrink=0.7, label=column)
    _image_axes(ax, _extent_of(None, polygons, None, as_box(box)), calibration)
    ax.set_title(title or f"cells coloured by {column}")
    return _finish(fig, path)


def plot_order_vs_radius(curve, ax=None, path=None, figsize=(5, 3.6)):
    """``|Gamma_p|`` against ``R / R_cell``, one line per ``p`` (mean and s.d. over frames).

    Parameters
    ----------
    curve : pandas.DataFrame
        Output of :func:`hexatissue.order.order_vs_radius` (columns ``p``,
        ``factor``, ``abs_Gamma``; several frames and values of p may be
        concatenated).

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax = _new_axes(ax, figsize)
    colors = {2: "#1f77b4", 6: "#d62728"}
    for p, group in curve.groupby("p"):
        stats = group.groupby("factor")["abs_Gamma"].agg(["mean", "std"]).reset_index()
        color = colors.get(int(p))
        ax.errorbar(stats["factor"], stats["mean"], yerr=stats["std"].fillna(0), marker="o", ms=4, capsize=2,
                    color=color, label=f"$p = {int(p)}$")
    ax.set_xlabel("$R / R_{cell}$")
    ax.set_ylabel("$\\langle|\\Gamma_p|\\rangle$")
    ax.set_ylim(bottom=0)
    ax.legend()
    return _finish(fig, path)


#: How the deformation budget's terms are drawn: (label, terms summed, colour); "total" is drawn on top.
BUDGET_GROUPS = (
    ("cell shape change", ("cell_shape", "corotation", "nonlinear"), "#1f77b4"),
    ("T1 cycles", ("t1_cycle",), "#9467bd"),
    ("intercalations", ("t1_intercalation",), "#d62728"),
    ("unresolved T1s", ("t1_unresolved",), "#e377c2"),
    ("divisions", ("division",), "#2ca02c"),
    ("extrusions", ("extrusion",), "#8c564b"),
    ("cells entering / leaving", ("border",), "#7f7f7f"),
    ("correlation effects", ("growth_correlation", "rotation_correlation"), "#ff7f0e"),
    ("other rearrangements", ("rearrangement", "advection"), "#bcbd22"),
    ("resampling (no contact change)", ("resampling",), "#aec7e8"),
)


def plot_deformation_budget(deformation, calibration=None, region="tissue", region_id=-1, path=None,
                            figsize=(10, 3.8)):
    """Cumulative shear (xx, xy) and growth of each contribution of the deformation budget against time.

    Parameters
    ----------
    deformation : pandas.DataFrame
        The ``deformation`` table (:func:`hexatissue.deformation.deformation_budget`).
    calibration : Calibration, optional
        Time axis in its time unit (frames when there is none).
    region, region_id : str, int
        The rows drawn (default: the whole tissue).

    Returns
    -------
    matplotlib.figure.Figure
        Three panels: cumulative shear xx, xy and cumulative log area change
        (dimensionless), each contribution a line, the total black and the
        sum of the parts dashed (cyan) over it.
    """
    from matplotlib.figure import Figure

    cal = as_calibration(calibration)
    rows = deformation[(deformation["region"] == region) & (deformation["region_id"] == region_id)]
    if len(rows) == 0:
        raise InputError(f"the deformation table has no rows for region {region!r} {region_id}")
    rows = rows.sort_values("frame")
    t = cal.time(np.r_[rows["frame"].to_numpy(float), rows["frame"].to_numpy(float)[-1] + 1])
    fig = Figure(figsize=figsize, dpi=100, layout="constrained")
    axes = fig.subplots(1, 3)
    for ax, part, title in zip(axes, ("xx", "xy", "iso"), ("shear xx", "shear xy", "growth (log area)")):
        total = None
        for label, terms, colour in BUDGET_GROUPS:
            columns = [f"{term}_{part}" for term in terms if f"{term}_{part}" in rows]
            if not columns:
                continue
            value = np.r_[0.0, np.cumsum(rows[columns].sum(axis=1).to_numpy())]
            total = value if total is None else total + value
            ax.plot(t, value, color=colour, label=label, linewidth=1.4)
        ax.plot(t, np.r_[0.0, np.cumsum(rows[f"total_{part}"].to_numpy())], color="k", linewidth=2.2, label="total")
        ax.plot(t, total, color="#17becf", linestyle="--", linewidth=1.2, label="sum of the parts")
        ax.axhline(0, color="0.6", linewidth=0.6)
        ax.set_title(title)
        ax.set_xlabel(f"time ({cal.time_label})")
    axes[0].set_ylabel("cumulative (dimensionless)")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside right center", fontsize=8, frameon=False)
    return _finish(fig, path)


def plot_deformation_map(deformation, grid, calibration=None, ax=None, path=None, box=None, figsize=(6, 5.5)):
    """Where the tissue shears, and how much of it T1s make: nematic bars on the Gamma_p grid.

    Parameters
    ----------
    deformation : pandas.DataFrame
        The ``deformation`` table with ``grid`` rows.
    grid : pandas.DataFrame
        The grid (``frame``, ``node``, ``x``, ``y``): the nodes' positions.

    Returns
    -------
    matplotlib.figure.Figure
        Per node, the shear rate averaged over the intervals the node has a
        budget: black bars the total (length proportional to the rate,
        oriented along the stretching axis), red bars the T1s' part (cycles,
        intercalations and unresolved together); a scale bar in the
        calibration's length unit and a key of the rate in 1/time.
    """
    cal = as_calibration(calibration)
    rows = deformation[deformation["region"] == "grid"]
    if len(rows) == 0:
        raise InputError("the deformation table has no grid rows (run with the order fields and the grid budget)")
    mean = rows.groupby("region_id").mean(numeric_only=True)
    nodes = grid.drop_duplicates("node").set_index("node").loc[mean.index]
    xy = nodes[["x", "y"]].to_numpy(float)
    fig, ax = _new_axes(ax, figsize)
    t1_terms = ("t1_cycle", "t1_intercalation", "t1_unresolved")
    t1 = [sum(mean[f"{k}_{c}"].to_numpy() for k in t1_terms) for c in ("xx", "xy")]
    total = [mean[f"total_{c}"].to_numpy() for c in ("xx", "xy")]
    largest = max(float(np.nanmax(np.hypot(*total), initial=0.0)), 1e-300)
    half_spacing = 0.45 * typical_spacing(xy)
    from matplotlib.collections import LineCollection

    for (xx, xy_), colour, width in ((total, "k", 2.2), (t1, PLUS_COLOR, 1.4)):
        half = half_spacing * np.hypot(xx, xy_) / largest
        angle = 0.5 * np.arctan2(xy_, xx)  # the stretching axis of the shear tensor
        d = np.c_[np.cos(angle), np.sin(angle)] * half[:, None]
        ax.add_collection(LineCollection(np.stack([xy - d, xy + d], axis=1), colors=colour, linewidths=width))
    _image_axes(ax, _extent_of(xy=xy, box=box), cal)
    rate = largest / cal.time(1.0)
    ax.set_title(f"mean shear rate: total (black), T1s (red); longest bar {rate:.3g} / {cal.time_label}",
                 fontsize=9)
    return _finish(fig, path)


def _node_lattice(x, y):
    """Row and column of every node of a regular grid from its positions (the grid's own x and y values)."""
    gx, col = np.unique(x, return_inverse=True)
    gy, row = np.unique(y, return_inverse=True)
    return row, col, (len(gy), len(gx))


def plot_flow(flow, polygons=None, ax=None, path=None, box=None, calibration=None, figsize=(6.6, 6)):
    """Flow field of one frame: velocity arrows on the valid nodes over the vorticity map.

    Velocities and vorticity are shown in the calibration's units (µm/min and
    1/min when calibrated, else px/frame and 1/frame): a key arrow gives the
    velocity scale and a scale bar the length scale.

    Parameters
    ----------
    flow : pandas.DataFrame
        One frame of the ``flow`` table (:func:`hexatissue.flow.flow_fields`).
    polygons : dict, optional
        Cell outlines drawn underneath (``{cell: (n, 2) array}``).
    box : Box, optional
        Periodic box: sets the plot limits.
    calibration : Calibration, optional
        Pixel size, frame interval and their units (px and frames when None).

    Returns
    -------
    matplotlib.figure.Figure
        Vorticity ``dvy/dx - dvx/dy`` in colour (red > 0: clockwise on the
        image, whose y axis points down), arrows of the fitted velocity.
    """
    if "frame" in flow.columns and flow["frame"].nunique() > 1:
        raise InputError("flow holds several frames; select one frame to plot")
    cal = as_calibration(calibration)
    fig, ax = _new_axes(ax, figsize)
    valid = flow["valid"].to_numpy(bool)
    x, y = flow["x"].to_numpy(float), flow["y"].to_numpy(float)
    _draw_polygons(ax, polygons, color="0.6", linewidth=0.4, box=as_box(box))
    time_unit = cal.time_unit if cal.has_time else "frame"
    if valid.any():
        row, col, shape = _node_lattice(x, y)
        vort = np.full(shape, np.nan)
        vort[row[valid], col[valid]] = in_units(flow["vorticity"].to_numpy(float)[valid], cal, 0, -1)
        gx, gy = np.full(shape, np.nan), np.full(shape, np.nan)
        gx[row, col], gy[row, col] = x, y
        top = float(np.nanpercentile(np.abs(vort), 98)) or 1.0
        mesh = ax.pcolormesh(gx, gy, np.ma.masked_invalid(vort), cmap="RdBu_r", vmin=-top, vmax=top,
                             shading="nearest", alpha=0.75)
        fig.colorbar(mesh, ax=ax, shrink=0.7, label=f"vorticity (1/{time_unit}; > 0 clockwise)")
        u, v = flow["vx"].to_numpy(float)[valid], flow["vy"].to_numpy(float)[valid]
        speed = np.hypot(u, v)
        typical = float(np.percentile(speed, 95)) if speed.max() > 0 else 1.0
        # the 95th-percentile speed spans 0.9 grid steps, so arrows rarely cross their neighbours
        step = typical_spacing(np.c_[x, y])
        ax.quiver(x[valid], y[valid], u, v, angles="xy", scale_units="xy", scale=typical / (0.9 * step),
                  width=0.004, color="k", zorder=4)
        key = scale_bar_length(float(in_units(typical, cal)), 1.0)  # a round speed near the typical one
        arrows = ax.collections[-1]
        ax.quiverkey(arrows, 0.16, 1.03, key / float(in_units(1.0, cal)), f"{key:g} {velocity_unit(cal)}",
                     labelpos="E", coordinates="axes", fontproperties={"size": 9})
    _image_axes(ax, _extent_of(None, polygons, np.c_[x, y], as_box(box)), cal)
    ax.set_title(f"velocity and vorticity{_frame_text(flow, cal)}", pad=18)
    return _finish(fig, path)


def plot_t1_tensions(histories, ax=None, path=None, figsize=(6.4, 4.2)):
    """Tension of the junctions shrinking into T1s against the frames left before the T1, by kind.

    Parameters
    ----------
    histories : pandas.DataFrame
        :func:`hexatissue.mechanics.t1_tension_histories`: ``event``,
        ``kind``, ``lag`` (frames, < 0), ``tension``.

    Returns
    -------
    matplotlib.figure.Figure
        One thin line per event and the median per lag (thick), a colour per
        kind; the mean interior tension (1) dashed.
    """
    for column in ("event", "kind", "lag", "tension"):
        if column not in histories.columns:
            raise InputError(f"histories has no column {column!r} (see mechanics.t1_tension_histories)")
    fig, ax = _new_axes(ax, figsize)
    colours = {"cycle": "tab:blue", "intercalation": "tab:red", "unresolved": "0.5"}
    for kind, rows in histories.groupby("kind", sort=True):
        colour = colours.get(str(kind), "k")
        for _, one in rows.groupby("event"):
            ax.plot(one["lag"], one["tension"], color=colour, alpha=0.25, linewidth=0.7)
        median = rows.groupby("lag")["tension"].median()
        ax.plot(median.index, median.to_numpy(), color=colour, linewidth=2.2,
                label=f"{kind} ({rows['event'].nunique()} events), median")
    ax.axhline(1.0, color="0.4", linestyle="--", linewidth=0.8)
    ax.set_xlabel("frames before the T1 (lag)")
    ax.set_ylabel("tension of the lost junction (mean = 1)")
    if len(histories):
        ax.legend(fontsize=8)
    return _finish(fig, path)


def _tension_limits(tension):
    """Colour limits of a tension map: the 2nd and 98th percentiles of the finite values ((0, 1) if none;
    widened by 0.5 each way when they coincide)."""
    tension = np.asarray(tension, float)
    known = np.isfinite(tension)
    low, high = np.percentile(tension[known], [2, 98]) if known.any() else (0.0, 1.0)
    return (float(low), float(high)) if high > low else (float(low) - 0.5, float(high) + 0.5)


def plot_tension_histogram(edges, ax=None, path=None, figsize=(5, 3.4)):
    """Histogram of the inferred tensions of one frame, with the colour range of :func:`plot_tensions`.

    Parameters
    ----------
    edges : pandas.DataFrame
        One frame's ``edges`` with ``tension`` (relative: mean interior
        tension 1) and optionally ``tension_sd``.

    Returns
    -------
    matplotlib.figure.Figure
        Counts of junctions per tension bin (all finite tensions, outliers
        included: the bins span the data), the colour range shaded, 0 and 1
        marked, the median posterior s.d. in the title when there is one.
    """
    if "tension" not in edges.columns:
        raise InputError("edges has no column 'tension' (run force inference: --mechanics)")
    tension = edges["tension"].to_numpy(float)
    known = np.isfinite(tension)
    fig, ax = _new_axes(ax, figsize)
    if known.any():
        ax.hist(tension[known], bins=min(60, max(10, int(np.sqrt(known.sum())) * 2)), color="0.35")
    low, high = _tension_limits(tension)
    ax.axvspan(low, high, color="tab:green", alpha=0.12, label="colour range of the map (2nd-98th percentile)")
    ax.axvline(0.0, color="red", lw=1)
    ax.axvline(1.0, color="k", lw=0.8, ls="--")
    ax.set_xlabel("tension (relative: mean interior tension = 1)")
    ax.set_ylabel("junctions")
    ax.yaxis.get_major_locator().set_params(integer=True)  # counts
    sd = edges["tension_sd"].to_numpy(float) if "tension_sd" in edges.columns else np.full(len(edges), np.nan)
    note = f"; median posterior s.d. {np.nanmedian(sd[known]):.3f}" if np.isfinite(sd[known]).any() else ""
    ax.set_title(f"{int(known.sum())} tensions, {int((tension[known] < 0).sum())} negative{note}", fontsize=9)
    ax.legend(fontsize=7, loc="upper right")
    return _finish(fig, path)


def plot_tensions(edges, vertices, calibration=None, ax=None, path=None, box=None, cmap="viridis",
                  figsize=(6.4, 6)):
    """The junction network, each junction coloured by its inferred tension (force inference, ``--mechanics``).

    Parameters
    ----------
    edges : pandas.DataFrame
        One frame's ``edges`` with ``vertex_a``, ``vertex_b`` and ``tension``
        (relative: mean interior tension 1).
    vertices : pandas.DataFrame
        The frame's ``vertices`` (``vertex``, ``x``, ``y``, px).
    calibration : Calibration, optional
        Pixel size and length unit of the scale bar (px when None).
    box : Box, optional
        Periodic box: junctions are drawn from their first vertex by minimum image.

    Returns
    -------
    matplotlib.figure.Figure
        Junctions without a tension (NaN) thin and grey, the others coloured
        on a scale from the frame's own 2nd to 98th percentile (the colour
        bar's pointed ends: values beyond it); tensions outside that range
        drawn thicker, negative ones in red, so outliers show; a colour bar
        and a scale bar.  The title counts the junctions with a tension, the
        negative ones and their median.
    """
    from matplotlib.collections import LineCollection
    from matplotlib.colors import Normalize

    for column in ("vertex_a", "vertex_b", "tension"):
        if column not in edges.columns:
            raise InputError(f"edges has no column {column!r} (run force inference: --mechanics)")
    box = as_box(box)
    v = vertices.set_index("vertex")[["x", "y"]]
    a = v.reindex(edges["vertex_a"].to_numpy()).to_numpy(float)
    b = v.reindex(edges["vertex_b"].to_numpy()).to_numpy(float)
    d = b - a if box is None else box.min_image(b - a)
    segments = np.stack([a, a + d], axis=1)
    tension = edges["tension"].to_numpy(float)
    known = np.isfinite(tension)
    fig, ax = _new_axes(ax, figsize)
    ax.add_collection(LineCollection(segments[~known], colors="0.75", linewidths=0.5))
    low, high = _tension_limits(tension)
    outside = known & ((tension < low) | (tension > high))
    widths = np.where(outside[known], 3.0, 1.6)
    lines = LineCollection(segments[known], cmap=cmap, norm=Normalize(low, high), linewidths=widths)
    lines.set_array(tension[known])
    ax.add_collection(lines)
    negative = known & (tension < 0)
    if negative.any():
        ax.add_collection(LineCollection(segments[negative], colors="red", linewidths=3.0))
    fig.colorbar(lines, ax=ax, shrink=0.7, extend="both",
                 label="tension (relative: the frame's mean interior tension = 1)")
    _image_axes(ax, _extent_of(xy=vertices[["x", "y"]].to_numpy(float), box=box), calibration)
    median = float(np.median(tension[known])) if known.any() else np.nan
    ax.set_title(f"inferred junction tensions: {int(known.sum())} of {len(tension)} junctions, median "
                 f"{median:.2f};\n{int(outside.sum())} beyond the colour range (thick), {int(negative.sum())} "
                 f"negative (red)", fontsize=9)
    return _finish(fig, path)
