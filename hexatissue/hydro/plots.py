"""Figures of the hydro experiments (matplotlib, Agg backend, imported lazily).

Images are drawn with x = column, y = row and the origin at the lower left
(``origin="lower"``), so angles are counter-clockwise from +x.
"""
from __future__ import annotations

import numpy as np

__all__ = ["plot_state", "plot_dipole_trajectories", "plot_quadrupole_tracks", "plot_stability_diagram"]


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _defects(ax, defects, size=40):
    if defects is None or not len(defects):
        return
    for sign, colour in ((1, "red"), (-1, "blue")):
        d = defects[np.sign(defects["charge"]) == sign]
        ax.scatter(d["x"], d["y"], s=size, c=colour, edgecolors="white", linewidths=0.8, zorder=3,
                   label="+1/6" if sign > 0 else "-1/6")


def plot_state(psi, velocity, defects=None, dx=1.0, ax=None, title=None, window=None, density=1.2):
    """Like the paper's Fig. 2: orientation arg(Psi6)/6 (cyclic colours), flow streamlines, defects.

    Parameters
    ----------
    psi : (n, n) complex array
        Psi6, indexed [row, col].
    velocity : (n, n) complex array
        ``v_x + i v_y``.
    defects : DataFrame, optional
        Columns x, y, charge (+1/6 red, -1/6 blue).
    window : (x0, x1, y0, y1), optional
        Region to show.

    Returns
    -------
    matplotlib Figure
    """
    plt = _plt()
    if ax is None:
        fig, ax = plt.subplots(figsize=(5.5, 5))
    else:
        fig = ax.figure
    n = psi.shape[0]
    x = np.arange(n) * dx
    theta = np.angle(psi) / 6
    im = ax.imshow(theta, origin="lower", extent=(x[0] - dx / 2, x[-1] + dx / 2) * 2, cmap="twilight",
                   vmin=-np.pi / 6, vmax=np.pi / 6, interpolation="nearest")
    speed = np.abs(velocity)
    if speed.max() > 0:
        ax.streamplot(x, x, velocity.real, velocity.imag, color="k", linewidth=0.5, density=density,
                      arrowsize=0.6)
    _defects(ax, defects)
    if window is not None:
        ax.set_xlim(window[0], window[1])
        ax.set_ylim(window[2], window[3])
    ax.set_xlabel("x")
    ax.set_ylabel("y")
    if title:
        ax.set_title(title, fontsize=9)
    cb = fig.colorbar(im, ax=ax, fraction=0.046, pad=0.03)
    cb.set_label(r"$\theta = \arg\Psi_6/6$")
    fig.tight_layout()
    return fig


def plot_dipole_trajectories(results, path=None):
    """Like the paper's SI Fig. 2: x(t) of the +1/6 and -1/6 defect for several alpha6.

    Parameters
    ----------
    results : dict {alpha: HydroResult}
    path : path, optional
        PNG written when given.

    Returns
    -------
    matplotlib Figure
    """
    plt = _plt()
    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    colours = plt.cm.plasma(np.linspace(0, 0.85, max(2, len(results))))
    top = 1.0
    for colour, (alpha, res) in zip(colours, sorted(results.items())):
        d = res.defects
        label = rf"$\alpha_6={alpha:+.2f}$" + (f", $t_a={res.annihilation_time:.1f}$" if res.annihilation_time else "")
        for k, (track, g) in enumerate(d.groupby("defect")):
            g = g.sort_values("time")
            style = "-" if g["charge"].iloc[0] > 0 else "--"
            axes[0].plot(g["time"], g["x"], style, color=colour, label=label if k == 0 else None)
        pairs = d[d.groupby("frame")["charge"].transform("size") == 2]
        sep = pairs.groupby("time").apply(lambda g: np.hypot(np.ptp(g["x"]), np.ptp(g["y"])), include_groups=False)
        axes[1].plot(sep.index, sep.to_numpy(), color=colour, label=rf"$\alpha_6={alpha:+.2f}$")
        late = sep[sep.index >= 0.8 * sep.index.max()]
        top = max(top, float(late.max()) if len(late) else 0.0)
        if res.annihilation_time:
            axes[0].axvline(res.annihilation_time, color=colour, lw=0.6, ls=":")
    axes[0].set_xlabel("time")
    axes[0].set_ylabel("x of defect (solid +1/6, dashed -1/6)")
    axes[0].legend(fontsize=8)
    axes[1].set_xlabel("time")
    axes[1].set_ylabel("pair separation (px, plaquette resolution)")
    last = max(r.diagnostics["time"].iloc[-1] for r in results.values())
    axes[1].set_xlim(0.8 * last, 1.01 * last)
    axes[1].set_ylim(0, 1.1 * top)
    axes[1].legend(fontsize=8)
    fig.tight_layout()
    if path is not None:
        fig.savefig(path, dpi=120)
    return fig


def plot_quadrupole_tracks(result, center, ax=None, title=None):
    """Defect trajectories of a quadrupole run (+1/6 red, -1/6 blue), start marked by circles."""
    plt = _plt()
    if ax is None:
        fig, ax = plt.subplots(figsize=(4.5, 4.5))
    else:
        fig = ax.figure
    d = result.defects
    for _, g in d.groupby("defect"):
        g = g.sort_values("time")
        colour = "red" if g["charge"].iloc[0] > 0 else "blue"
        ax.plot(g["x"] - center[0], g["y"] - center[1], color=colour, lw=1)
        ax.plot(g["x"].iloc[0] - center[0], g["y"].iloc[0] - center[1], "o", color=colour, ms=3)
    ax.set_aspect("equal")
    ax.set_xlabel("x - center")
    ax.set_ylabel("y - center")
    if title:
        ax.set_title(title, fontsize=9)
    return fig


def plot_stability_diagram(tables, name, marked=None, ax=None):
    """Bulk stability window of alpha6 against a model constant (:func:`hexatissue.theory.stability_diagram`).

    ``tables``: {label: DataFrame} (one per scheme); the first is shaded (stable between its two onsets),
    the others drawn as lines.  ``marked``: {label: (value, alpha6)} points, e.g. the paper's parameters.
    """
    plt = _plt()
    if ax is None:
        fig, ax = plt.subplots(figsize=(5.5, 5.0))
    else:
        fig = ax.figure
    styles = ["-", "--", ":", "-."]
    for i, (label, t) in enumerate(tables.items()):
        if i == 0:
            ax.fill_between(t["value"], t["alpha_extensile"], t["alpha_contractile"], color="0.85",
                            label=f"stable uniform hexatic ({label})")
        for col, colour in (("alpha_extensile", "tab:blue"), ("alpha_contractile", "tab:red")):
            ax.plot(t["value"], t[col], styles[i % 4], color=colour, lw=1.2,
                    label=f"onset, {label}" if col == "alpha_extensile" else None)
    for label, (x, y) in (marked or {}).items():
        ax.plot([x], [y], "k*", ms=9)
        ax.annotate(label, (x, y), textcoords="offset points", xytext=(6, 4), fontsize=8)
    ax.axhline(0, color="k", lw=0.5)
    ax.set_xlabel(name)
    ax.set_ylabel("alpha6  (< 0 extensile, > 0 contractile)")
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=2)
    return fig
