"""Drivers of the hydro experiments (figures and numbers in docs/hydro.md).

    python scripts/hydro_experiments.py dipole [--n 128 --distance 32]
    python scripts/hydro_experiments.py quadrupole [--n 128] [--alphas 0 -0.1 ...]

``--orientation-deg`` sets the far-field bond angle (default 0; 30 reverses the active force).

Outputs go to docs/figures/ (PNG, JSON summaries) and runs/ (zarr stores; not committed).
"""
import argparse
import json
from pathlib import Path

import numpy as np

from hexatissue.hydro import default_params, departure_angle, run_dipole, run_quadrupole
from hexatissue.hydro.plots import plot_dipole_trajectories, plot_quadrupole_tracks, plot_state

FIG = Path("docs/figures")
RUNS = Path("runs")


def dipole(a):
    results = {}
    for alpha in a.alphas:
        out = RUNS / f"dipole_n{a.n}_d{a.distance:g}_a{alpha:+g}{_scheme_tag(a)}.zarr"
        # diagnostics every 0.1 time units: the activity effect on t_a is small
        r = run_dipole(alpha, n=a.n, distance=a.distance, out=out, seed=a.seed, resume=True, progress=False,
                       save_every=2 if a.scheme == "spectral" else 1, field_every=100 * (a.n // 128) ** 2,
                       params=_params(a, alpha), orientation=np.deg2rad(a.orientation_deg))
        results[alpha] = r
        print(f"dipole alpha={alpha:+g}: annihilation time {r.annihilation_time}", flush=True)
    tag = f"n{a.n}_d{a.distance:g}{_scheme_tag(a)}" + (f"_{a.tag}" if a.tag else "")
    plot_dipole_trajectories(results, FIG / f"hydro_dipole_{tag}.png")
    summary = {str(k): {"annihilation_time": v.annihilation_time,
                        "final_time": float(v.diagnostics["time"].iloc[-1])} for k, v in results.items()}
    (FIG / f"hydro_dipole_{tag}.json").write_text(json.dumps(summary, indent=1))
    # a snapshot like Fig. 2 for the extensile case, halfway to annihilation
    import zarr

    alpha = min(results)
    g = zarr.open_group(str(RUNS / f"dipole_n{a.n}_d{a.distance:g}_a{alpha:+g}{_scheme_tag(a)}.zarr"), mode="r")
    k = g["field_time"].shape[0] // 2
    _snapshot(g, k, results[alpha], FIG / f"hydro_dipole_state_{tag}.png", f"dipole, alpha6={alpha:+g}")


def _scheme_tag(a):
    return (("" if a.scheme == "spectral" else "_fd") + ("_f32" if a.dtype == "float32" else "")
            + (f"_o{a.orientation_deg:g}" if a.orientation_deg else ""))


def _params(a, alpha):
    """Production scheme, or the paper's finite differences (explicit RK4, dt = 0.1)."""
    if a.scheme == "spectral":
        return default_params(alpha, dtype=a.dtype)
    return default_params(alpha, scheme="fd", integrator="rk4", dt=0.1, dtype=a.dtype)


def _snapshot(g, k, result, path, title, window=None):
    psi = g["psi_re"][k] + 1j * g["psi_im"][k]
    vel = g["vx"][k] + 1j * g["vy"][k]
    t = g["field_time"][k]
    d = result.defects[np.isclose(result.defects["time"], t)]
    fig = plot_state(psi, vel, d, title=f"{title}, t={t:g}", window=window)
    fig.savefig(path, dpi=120)


def quadrupole(a):
    summary = {}
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(a.alphas), figsize=(3.2 * len(a.alphas), 3.4), squeeze=False)
    for ax, alpha in zip(axes[0], a.alphas):
        out = RUNS / f"quad_n{a.n}_a{alpha:+g}{_scheme_tag(a)}.zarr"
        try:
            r = run_quadrupole(alpha, n=a.n, ell=a.ell, out=out, seed=a.seed, resume=True, max_time=a.max_time,
                               field_every=5, progress=False, params=_params(a, alpha),
                               orientation=np.deg2rad(a.orientation_deg))
        except FloatingPointError as exc:
            summary[str(alpha)] = {"fate": "numerically unstable", "error": str(exc)}
            print(f"quadrupole alpha={alpha:+g}: {exc}", flush=True)
            continue
        center = ((a.n / 2 - 0.5),) * 2
        last = r.defects[r.defects["frame"] == r.defects["frame"].max()] if len(r.defects) else r.defects
        far = float(np.hypot(last["x"] - center[0], last["y"] - center[1]).max()) if len(last) else 0.0
        n_max = int(r.diagnostics["n_defects"].max())
        if n_max > 4:
            fate = "proliferated"  # activity creates new defects: bulk active instability
        elif r.annihilation_time is not None:
            fate = "annihilated"
        elif far > 6 * a.ell:
            fate = "split"
        else:
            fate = "undecided"
        angles = departure_angle(r.defects, center, 2 * a.ell) if fate == "split" else np.zeros(0)
        summary[str(alpha)] = {"fate": fate, "annihilation_time": r.annihilation_time,
                               "final_time": float(r.diagnostics["time"].iloc[-1]),
                               "departure_angles_deg": np.degrees(angles).round(1).tolist(),
                               "max_distance_from_centre": far, "max_defects": n_max}
        print(f"quadrupole alpha={alpha:+g}: {summary[str(alpha)]}", flush=True)
        plot_quadrupole_tracks(r, center, ax=ax, title=rf"$\alpha_6={alpha:+g}$: {fate}")
        import zarr

        g = zarr.open_group(str(out), mode="r")
        k = min(g["field_time"].shape[0] - 1, max(1, g["field_time"].shape[0] // 2))
        c = center[0]
        w = 6 * a.ell
        _snapshot(g, k, r, FIG / f"hydro_quadrupole_state_a{alpha:+g}{_scheme_tag(a)}.png", f"quadrupole, alpha6={alpha:+g}",
                  window=(c - w, c + w, c - w, c + w))
    fig.tight_layout()
    fig.savefig(FIG / f"hydro_quadrupole_tracks_n{a.n}{_scheme_tag(a)}{'_' + a.tag if a.tag else ''}.png", dpi=120)
    path = FIG / f"hydro_quadrupole_n{a.n}{_scheme_tag(a)}.json"
    old = json.loads(path.read_text()) if path.exists() else {}
    old.update(summary)
    path.write_text(json.dumps(old, indent=1))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("kind", choices=["dipole", "quadrupole"])
    ap.add_argument("--n", type=int, default=128)
    ap.add_argument("--distance", type=float, default=32.0)
    ap.add_argument("--ell", type=float, default=7.0)
    ap.add_argument("--alphas", type=float, nargs="+", default=None)
    ap.add_argument("--max-time", type=float, default=1500.0)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--tag", default="", help="suffix of the output figure names")
    ap.add_argument("--scheme", choices=["spectral", "fd"], default="spectral")
    ap.add_argument("--dtype", choices=["float64", "float32"], default="float64")
    ap.add_argument("--orientation-deg", type=float, default=0.0, help="far-field bond angle (degrees)")
    a = ap.parse_args()
    FIG.mkdir(parents=True, exist_ok=True)
    RUNS.mkdir(exist_ok=True)
    if a.kind == "dipole":
        a.alphas = a.alphas or [-0.1, 0.0, 0.1]
        dipole(a)
    else:
        a.alphas = a.alphas or [0.0, -0.1, -0.2, -0.3]
        quadrupole(a)


if __name__ == "__main__":
    main()
