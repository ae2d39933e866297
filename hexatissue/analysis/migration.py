"""Cell migration against defect density in subregions and time windows (the paper's Fig. 3f).

The box is cut into square subregions of side ``dl`` (default 35 px, about
four cells) and the movie into consecutive, non-overlapping windows of ``dt``
frames.  A cell belongs to the subregion that holds its centroid at the
window's first frame ``t0``; it enters the statistics when it is present in
every frame ``t0 .. t0 + dt``.  Per cell and window

- ``displacement = sum_{t = t0+1}^{t0+dt} |r_c(t) - r_c(t-1)|^2 / dl^2``
  (the paper's normalised displacement; dimensionless),
- ``msd = |r_c(t0+dt) - r_c(t0)|^2`` (the ordinary squared displacement, px^2),

each step ``r_c(t) - r_c(t-1)`` taken as the minimum image in a periodic box,
so cells crossing the box edge move by their true step.  Per subregion and
window these are averaged over its cells and set against the mean density of
``±1/p`` defects in the subregion over the window's frames (from
:func:`hexatissue.defect_density`, the same binning).

**Converting the paper's windows.** The paper uses windows of 25,000 MPF
iterations.  A run saving a frame every ``save_every`` iterations spans that
with ``dt = 25_000 / save_every`` frames (:func:`frames_per_window`); e.g.
``save_every = 500`` gives ``dt = 50``.

Positions: ``x`` = column, ``y`` = row, px, origin at the centre of pixel (0, 0).
"""
from __future__ import annotations

from dataclasses import dataclass
import warnings

import numpy as np
import pandas as pd

from ..box import Box
from ..defects import defect_density
from ..errors import HexatissueWarning, InputError
from ..box import as_box
from ..defects import charge_mask
from ..errors import check_p, check_positive
from ..schema import interior_mask, track_ids
from ..schema import require_columns
from .mixture import GaussianMixture1D, fit_gaussian_mixture

__all__ = ["frames_per_window", "cell_steps", "cell_displacements", "migration_table", "migration_populations",
           "MigrationPopulations", "DEFAULT_DL", "PAPER_WINDOW_ITERATIONS"]

#: Subregion side of the paper, px (about four cell diameters).
DEFAULT_DL = 35.0
#: Time window of the paper, MPF iterations.
PAPER_WINDOW_ITERATIONS = 25_000


def frames_per_window(iterations=PAPER_WINDOW_ITERATIONS, save_every=1):
    """Frames spanning ``iterations`` MPF steps when a frame is saved every ``save_every`` steps.

    Raises :class:`InputError` unless ``iterations`` is a whole number of frames.
    """
    iterations = check_positive(iterations, "iterations", integer=True)
    save_every = check_positive(save_every, "save_every", integer=True)
    if iterations % save_every:
        raise InputError(f"iterations ({iterations}) must be a multiple of save_every ({save_every}) "
                         f"so that a window spans whole frames")
    return iterations // save_every


def cell_steps(cells, box=None, include_border=False):
    """Frame-to-frame displacement of every tracked cell.

    Parameters
    ----------
    cells : pandas.DataFrame
        ``frame``, ``x``, ``y`` (centroid, px), ``track`` (or ``cell``: label
        ids are then track ids), optional ``is_border``.
    box : Box, optional
        Periodic box: each step is the minimum image.
    include_border : bool
        Keep steps at which the cell is a border cell (their centroids are
        cut by the image edge, so they are left out by default).

    Returns
    -------
    pandas.DataFrame
        One row per step between consecutive frames ``t - 1`` and ``t``:
        ``track``, ``frame`` (= t), ``x_prev``, ``y_prev`` (position at
        ``t - 1``, px), ``dx``, ``dy`` (step, px).
    """
    require_columns(cells, ("frame", "x", "y"), "cells")
    box = as_box(box)
    df = pd.DataFrame({"track": track_ids(cells), "frame": cells["frame"].to_numpy(np.int64),
                       "x": cells["x"].to_numpy(float), "y": cells["y"].to_numpy(float),
                       "ok": interior_mask(cells) | include_border})
    df = df.sort_values(["track", "frame"], ignore_index=True)
    tr, fr = df["track"].to_numpy(), df["frame"].to_numpy()
    consecutive = (tr[1:] == tr[:-1]) & (fr[1:] == fr[:-1] + 1)
    ok = df["ok"].to_numpy()
    use = consecutive & ok[1:] & ok[:-1]
    xy = df[["x", "y"]].to_numpy(float)
    step = xy[1:] - xy[:-1]
    if box is not None:
        step = box.min_image(step)
    i = np.flatnonzero(use)
    return pd.DataFrame({"track": tr[i + 1], "frame": fr[i + 1], "x_prev": xy[i, 0], "y_prev": xy[i, 1],
                         "dx": step[i, 0], "dy": step[i, 1]})


def _bins(extent, dl):
    """Subregion geometry, mirroring :func:`hexatissue.defect_density`: origin, side (x, y), counts."""
    if isinstance(extent, Box):
        lo, size, wrap = np.zeros(2), extent.lengths, extent.wrap
    else:
        lo, size, wrap = np.array([-0.5, -0.5]), np.array([extent[1], extent[0]], float), (lambda xy: xy)
    n = np.maximum(1, np.round(size / dl)).astype(int)
    return lo, size / n, n, wrap


def _check_extent(extent, box, cells):
    """A Box, or an image shape (rows, cols); default: the box, else the cells' bounding image."""
    if extent is None:
        if box is not None:
            return box
        xy = cells[["x", "y"]].to_numpy(float)
        return (int(np.ceil(np.nanmax(xy[:, 1]))) + 1, int(np.ceil(np.nanmax(xy[:, 0]))) + 1)
    if isinstance(extent, Box):
        return extent
    if len(extent) != 2 or min(extent) <= 0:
        raise InputError(f"extent must be a Box or an image shape (rows, cols); got {extent!r}")
    return tuple(int(v) for v in extent)


def _windows(frames, dt):
    """Start frames of the consecutive windows of ``dt`` frames that fit in ``frames``."""
    first, last = int(frames.min()), int(frames.max())
    return np.arange(first, last - dt + 1, dt, dtype=np.int64)


def _event_counts(events, starts, dt):
    """Cycles and intercalations each cell takes part in, per window: DataFrame indexed (window, track)."""
    if events is None or len(events) == 0:
        return None
    frames = events["frame_start"].to_numpy(np.int64)
    # the contact changes between frame_start - 1 and frame_start: the step ending at frame_start
    k = np.searchsorted(starts, frames - 1, side="right") - 1
    inside = (k >= 0) & (frames - starts[np.maximum(k, 0)] <= dt) & (frames > starts[np.maximum(k, 0)])
    kind = events["kind"].astype(str).to_numpy()
    long = pd.DataFrame({
        "window": np.tile(k, 4), "track": np.concatenate([events[c].to_numpy(np.int64)
                                                          for c in ("cell_a", "cell_b", "cell_c", "cell_d")]),
        "kind": np.tile(kind, 4), "use": np.tile(inside, 4)})
    long = long[long["use"]]
    out = pd.DataFrame({
        "n_cycles": long[long["kind"] == "cycle"].groupby(["window", "track"]).size(),
        "n_intercalations": long[long["kind"] == "intercalation"].groupby(["window", "track"]).size()})
    return out.fillna(0).astype(np.int64)


def cell_displacements(cells, dl=DEFAULT_DL, dt=25, box=None, extent=None, events=None, include_border=False):
    """Normalised displacement and squared displacement of every cell in every window.

    Parameters
    ----------
    cells : pandas.DataFrame
        ``frame``, ``x``, ``y`` (px), ``track`` (or ``cell``), optional ``is_border``.
    dl : float
        Subregion side, px; the extent is cut into ``round(L / dl)`` equal
        subregions per axis (exactly ``dl`` when it divides the box).  The
        displacement is normalised by ``dl**2`` as given.
    dt : int
        Window length, frames (see :func:`frames_per_window`).
    box : Box, optional
        Periodic box (minimum-image steps; subregions tile the box).
    extent : Box or (rows, cols), optional
        Area cut into subregions.  Default: ``box``, else the smallest image
        holding every centroid.
    events : pandas.DataFrame, optional
        Events table: adds the cycles and intercalations each cell takes part
        in during the window (events whose ``frame_start`` is in
        ``t0 + 1 .. t0 + dt``).
    include_border : bool
        See :func:`cell_steps`.

    Returns
    -------
    pandas.DataFrame
        One row per cell present (and not on the border) through a whole
        window: ``window`` (index), ``frame_start`` (t0), ``frame_end``
        (t0 + dt), ``track``, ``row``, ``col`` (subregion at t0), ``x``,
        ``y`` (position at t0, px), ``displacement`` (sum of squared steps /
        dl^2), ``msd`` (squared net displacement, px^2), and with ``events``
        ``n_cycles``, ``n_intercalations``.
    """
    dl = check_positive(dl, "dl")
    dt = check_positive(dt, "dt", integer=True)
    box = as_box(box)
    extent = _check_extent(extent, box, cells)
    steps = cell_steps(cells, box, include_border)
    frames = np.unique(cells["frame"].to_numpy(np.int64))
    starts = _windows(frames, dt)
    columns = ["window", "frame_start", "frame_end", "track", "row", "col", "x", "y", "displacement", "msd"]
    if events is not None:
        columns += ["n_cycles", "n_intercalations"]
    if len(starts) == 0 or steps.empty:
        warnings.warn(f"no complete window of dt={dt} frames in a movie of {len(frames)} frames",
                      HexatissueWarning, stacklevel=2)
        return pd.DataFrame({c: pd.Series(dtype=float) for c in columns})
    fr = steps["frame"].to_numpy(np.int64)
    k = np.searchsorted(starts, fr - 1, side="right") - 1
    steps = steps.assign(window=k)
    steps = steps[(k >= 0) & (fr - starts[np.maximum(k, 0)] <= dt)]
    steps = steps.sort_values(["window", "track", "frame"])
    g = steps.assign(d2=steps["dx"] ** 2 + steps["dy"] ** 2).groupby(["window", "track"], sort=True)
    per = g.agg(n=("d2", "size"), d2=("d2", "sum"), sx=("dx", "sum"), sy=("dy", "sum"),
                x=("x_prev", "first"), y=("y_prev", "first")).reset_index()
    per = per[per["n"] == dt]
    lo, side, n, wrap = _bins(extent, dl)
    xy = wrap(per[["x", "y"]].to_numpy(float))
    ij = np.floor((xy - lo) / side).astype(np.int64)
    inside = ((ij >= 0) & (ij < n)).all(axis=1)
    window = per["window"].to_numpy(np.int64)
    out = pd.DataFrame({
        "window": window, "frame_start": starts[window], "frame_end": starts[window] + dt,
        "track": per["track"].to_numpy(np.int64), "row": ij[:, 1], "col": ij[:, 0], "x": xy[:, 0], "y": xy[:, 1],
        "displacement": per["d2"].to_numpy(float) / dl**2,
        "msd": per["sx"].to_numpy(float) ** 2 + per["sy"].to_numpy(float) ** 2})[inside]
    if events is not None:
        counts = _event_counts(events, starts, dt)
        for col in ("n_cycles", "n_intercalations"):
            vals = (counts[col].reindex(pd.MultiIndex.from_arrays([out["window"], out["track"]])).fillna(0)
                    if counts is not None else pd.Series(np.zeros(len(out))))
            out[col] = vals.to_numpy(np.int64)
    return out.reset_index(drop=True)


def migration_table(cells, defects, dl=DEFAULT_DL, dt=25, box=None, extent=None, p=6, events=None,
                    include_border=False):
    """Per subregion and window: mean displacement, mean MSD and mean defect density (Fig. 3f).

    Parameters
    ----------
    cells, dl, dt, box, extent, events, include_border
        As in :func:`cell_displacements`.
    defects : pandas.DataFrame
        Defects table with ``frame`` (rows of other orders than ``p`` and of
        charge other than ``±1/p`` are ignored).
    p : int
        Defect order.

    Returns
    -------
    pandas.DataFrame
        One row per subregion and window holding at least one cell:
        ``window``, ``frame_start``, ``frame_end``, ``row``, ``col``, ``x``,
        ``y`` (subregion centre, px), ``n_cells``, ``displacement`` (mean over
        its cells, dimensionless), ``msd`` (mean, px^2), ``defect_density``
        (mean number of ``±1/p`` defects per px^2 over frames t0 .. t0 + dt),
        and with ``events`` ``cycles_per_cell``, ``intercalations_per_cell``
        (mean participations per cell in the window).
    """
    p = check_p(p)
    require_columns(defects, ("x", "y", "charge"), "defects")
    box = as_box(box)
    extent = _check_extent(extent, box, cells)
    per_cell = cell_displacements(cells, dl, dt, box, extent, events, include_border)
    agg = dict(n_cells=("track", "size"), displacement=("displacement", "mean"), msd=("msd", "mean"))
    if events is not None:
        agg.update(cycles_per_cell=("n_cycles", "mean"), intercalations_per_cell=("n_intercalations", "mean"))
    table = per_cell.groupby(["window", "frame_start", "frame_end", "row", "col"], sort=True).agg(**agg).reset_index()
    d = defects[charge_mask(defects["charge"], p) & ((defects["p"] == p) if "p" in defects.columns else True)]
    frames = np.unique(cells["frame"].to_numpy(np.int64))
    dens = defect_density(d, extent, dl, frames=frames)
    lo, side, _, _ = _bins(extent, dl)
    mean_density = []
    for t0, t1 in table[["frame_start", "frame_end"]].drop_duplicates().itertuples(index=False):
        part = dens[(dens["frame"] >= t0) & (dens["frame"] <= t1)]
        m = part.groupby(["row", "col"])["density"].mean().rename("defect_density").reset_index()
        mean_density.append(m.assign(frame_start=t0))
    if mean_density:
        table = table.merge(pd.concat(mean_density), on=["frame_start", "row", "col"], how="left")
    else:
        table["defect_density"] = pd.Series(dtype=float)
    table.insert(5, "x", lo[0] + (table["col"].to_numpy(float) + 0.5) * side[0])
    table.insert(6, "y", lo[1] + (table["row"].to_numpy(float) + 0.5) * side[1])
    return table


@dataclass
class MigrationPopulations:
    """Slow and fast subregions separated by a two-component mixture in log10(displacement).

    Attributes
    ----------
    table : pandas.DataFrame
        The migration table with ``log_displacement`` and ``population``
        (``"slow"``, ``"fast"``; ``""`` for zero displacement or when no
        mixture could be fitted) and ``p_fast`` (posterior of the fast component).
    mixture : GaussianMixture1D or None
        Two-component fit (None when fewer than 4 subregions moved).
    single : GaussianMixture1D or None
        One-component fit, for the BIC comparison.
    threshold : float
        Displacement at which both posteriors are 1/2 (NaN if undefined).
    summary : pandas.DataFrame
        Per population: ``population``, ``n_subregions``, ``median_displacement``,
        ``mean_msd`` (px^2), ``mean_defect_density`` (1/px^2), and with events
        ``cycles_per_cell``, ``intercalations_per_cell``, ``cycle_fraction``
        (cycles / (cycles + intercalations)).
    spearman_rho, spearman_pvalue : float
        Rank correlation of displacement and defect density over all subregions.
    """

    table: pd.DataFrame
    mixture: GaussianMixture1D | None
    single: GaussianMixture1D | None
    threshold: float
    summary: pd.DataFrame
    spearman_rho: float
    spearman_pvalue: float

    @property
    def delta_bic(self) -> float:
        """BIC(1 component) - BIC(2 components): > 10 is strong evidence for two components."""
        if self.mixture is None or self.single is None:
            return float("nan")
        return float(self.single.bic - self.mixture.bic)

    @property
    def verdict(self) -> str:
        """Reading of the fit (Kass & Raftery's scale for delta BIC: > 10 very strong).

        Two components are two *populations* only if they cross between their
        means; a narrow component inside a wide one (a heavy-tailed, unimodal
        distribution) is reported as ``"nested components: one population"``.
        """
        if not np.isfinite(self.delta_bic):
            return "no fit"
        if self.delta_bic > 10:
            return "two populations" if np.isfinite(self.threshold) else "nested components: one population"
        return "weak evidence for two" if self.delta_bic > 0 else "one population suffices"

    @property
    def two_populations(self) -> bool:
        """Whether the slow/fast split holds (:attr:`verdict` is ``"two populations"``); figures and the
        report show the split only then."""
        return self.verdict == "two populations"


def migration_populations(table, seed=0) -> MigrationPopulations:
    """Split subregions into slow and fast populations (data-driven rule).

    **Rule.** Fit a two-component Gaussian mixture to ``log10(displacement)``
    of all subregion-windows with positive displacement (EM,
    :func:`~hexatissue.analysis.mixture.fit_gaussian_mixture`).  The split
    is the point between the two means where both posteriors are 1/2; a
    subregion above it is ``fast``, below ``slow`` (a single threshold, so
    the classes are monotone in displacement even when the components'
    widths differ).  The mixture is fitted whatever the data; ``delta_bic``
    tells whether two components describe them better than one (> 10:
    strong evidence for two populations; <= 0: one population suffices).

    Parameters
    ----------
    table : pandas.DataFrame
        :func:`migration_table` output.
    seed : int or numpy.random.Generator
        Seeds the EM restarts.

    Returns
    -------
    MigrationPopulations
    """
    require_columns(table, ("displacement", "defect_density"), "table")
    out = table.copy()
    disp = out["displacement"].to_numpy(float)
    moved = disp > 0
    logd = np.full(len(out), np.nan)
    logd[moved] = np.log10(disp[moved])
    out["log_displacement"] = logd
    out["p_fast"] = np.nan
    out["population"] = ""
    mixture = single = None
    threshold = float("nan")
    if moved.sum() >= 4 and np.std(logd[moved]) > 0:
        mixture = fit_gaussian_mixture(logd[moved], 2, seed=seed)
        single = fit_gaussian_mixture(logd[moved], 1, seed=seed)
        out.loc[moved, "p_fast"] = mixture.posterior(logd[moved])[:, 1]
        b = mixture.boundary()
        if np.isfinite(b):
            threshold = float(10**b)
            out.loc[moved, "population"] = np.where(logd[moved] > b, "fast", "slow")
        else:
            warnings.warn("the two mixture components do not cross between their means (a narrow one inside a "
                          "wide one: one heavy-tailed population); no slow/fast split", HexatissueWarning, stacklevel=2)
    ok = np.isfinite(disp) & np.isfinite(out["defect_density"].to_numpy(float))
    if ok.sum() >= 3 and np.ptp(disp[ok]) > 0 and np.ptp(out["defect_density"].to_numpy(float)[ok]) > 0:
        from scipy import stats  # here, not at the top: ~18 MB and 0.3 s that every CLI call paid
        rho, pval = stats.spearmanr(disp[ok], out["defect_density"].to_numpy(float)[ok])
    else:
        rho = pval = float("nan")
    return MigrationPopulations(out, mixture, single, threshold, _population_summary(out), float(rho), float(pval))


def _population_summary(table):
    rows = []
    for name in ("slow", "fast"):
        part = table[table["population"] == name]
        row = {"population": name, "n_subregions": len(part),
               "median_displacement": float(part["displacement"].median()) if len(part) else np.nan,
               "mean_msd": float(part["msd"].mean()) if len(part) else np.nan,
               "mean_defect_density": float(part["defect_density"].mean()) if len(part) else np.nan}
        if "cycles_per_cell" in table.columns:
            w = part["n_cells"].to_numpy(float)
            cyc = float((part["cycles_per_cell"] * w).sum() / w.sum()) if w.sum() else np.nan
            ic = float((part["intercalations_per_cell"] * w).sum() / w.sum()) if w.sum() else np.nan
            row.update(cycles_per_cell=cyc, intercalations_per_cell=ic,
                       cycle_fraction=cyc / (cyc + ic) if (cyc + ic) > 0 else np.nan)
        rows.append(row)
    return pd.DataFrame(rows)
