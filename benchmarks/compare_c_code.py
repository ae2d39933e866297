"""Side by side: hexatissue's MPF simulator and the published C code of the same functional.

The C code is https://github.com/mchchiang/phase_field_benjamin (the MPF code used by Loewe et al.,
PRL 2020).  This script does not contain or copy it: give it a checkout (or a bare git clone) of
that repository with ``--c-code DIR``; the script copies ``src/`` into a temporary build folder,
runs the repository's own ``make`` there (with the OpenMP link flag its README asks for) and deletes the folder afterwards (``--keep`` keeps it).

One state, two codes
--------------------
The C code starts every cell from one template field (its "shape file") placed at a given centre
(its "cm file", with the polarity as a unit velocity).  So the common initial state is: N identical
tanh discs (radius 0.45 x the mean spacing, hexatissue's default) whose P x P patches (``--patch``, 41) have their
origins on hexatissue's jittered lattice, and one random polarity per cell.  Both codes get exactly
these fields (hexatissue's ``phi[c, row, col]`` = the C code's ``field[x = col][y = row]``) and
polarities.  Parameters: the paper's (alpha = k_phi = 0.2, eps = 0.1, lambda = mu = 600, R = 11.5,
v0 = 0.006, D_r = 1e-5) with the C code's phi0 = 2, M = 0.1, dt = 0.5 and k_ad = 0 (its functional
has no adhesion term).

Both relax for ``--nequil`` steps at zero motility.  The C code's polarities diffuse during its
equilibration (its ``updateVelocity`` runs in every step), so hexatissue's do too (same D_r, its
own random numbers).  Then both run ``--nsteps`` active steps.

Compared (the same functions applied to the output of both codes):

- centroids: phi-weighted, as the C code writes them (``sum phi x / sum phi``, node centres at
  +0.5), unwrapped; every ``--every`` steps;
- mean displacement ``<|r(T) - r(0)|>`` at the end, the MSD and its log-log slope over the second
  half of the run, and the mean speed over ``--every`` steps in units of v0;
- holes: the fraction of the box where the total field ``sum_c phi_c`` is below phi0 / 2;
- neighbour changes: from the index field (each node to the cell with the largest field above
  phi0 / 2, as the C code's ``dump_index_field``; gaps covered by the tissue or smaller than a cell
  filled as in ``hexatissue.simulate.segment``), the fraction of the neighbour pairs at the start
  of the active run that are lost at the end.

Before the active runs, a passive check (``--check-steps`` steps from the unrelaxed state, no
motility) compares the centroids of the two codes cell by cell: it tests the bridge (layout,
axes, parameters), since the passive dynamics are deterministic in both.

Usage::

    NUMBA_NUM_THREADS=1 PYTHONPATH=. python benchmarks/compare_c_code.py --c-code /path/to/phase_field_benjamin \\
        [--seeds 1 2] [--nsteps 25000] [--nequil 5000] [--advection upwind3 central] [--out results.md]

Each C run uses one OpenMP thread and runs concurrently with hexatissue's (one numba thread).
"""
from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from _timing import emit  # noqa: E402  (benchmarks/_timing.py)
from hexatissue.simulate import Params, set_threads  # noqa: E402
from hexatissue.simulate.model import Simulation, _disc_patch, _lattice_seeds  # noqa: E402
from hexatissue.simulate.segment import labels_from_max  # noqa: E402



# -- building the C code ---------------------------------------------------------------------
def build_c_code(repo: Path, build: Path) -> Path:
    """Copy ``src/`` of a checkout (or of a bare clone's HEAD) into ``build`` and run its ``make``.

    Returns the executable.  Nothing is written into ``repo``.
    """
    repo = Path(repo)
    src = build / "src"
    if (repo / "src" / "Makefile").exists():
        shutil.copytree(repo / "src", src)
    elif (repo / "HEAD").exists() or (repo / ".git").exists():
        build.mkdir(parents=True, exist_ok=True)
        archive = subprocess.run(["git", f"--git-dir={repo if (repo / 'HEAD').exists() else repo / '.git'}",
                                  "archive", "HEAD", "src"], check=True, capture_output=True).stdout
        subprocess.run(["tar", "-x", "-C", str(build)], input=archive, check=True)
    else:
        raise SystemExit(f"--c-code {repo}: neither a checkout with src/Makefile nor a git repository")
    log = build / "make.log"
    with open(log, "w") as fh:
        # its Makefile compiles with -fopenmp but links with LFLAGS = -lm only; its README says to add the
        # OpenMP library to LFLAGS (-lgomp; it must follow the objects, so the driver's -fopenmp is used)
        r = subprocess.run(["make", "LFLAGS=-fopenmp -lm"], cwd=src, stdout=fh, stderr=subprocess.STDOUT)
    exe = build / "bin" / "exe" / "run_phase_field_model"
    if r.returncode != 0 or not exe.exists():
        raise SystemExit(f"make in {src} failed; see {log}:\n{log.read_text()[-2000:]}")
    return exe


# -- the common initial state ----------------------------------------------------------------
def common_params(**kw) -> Params:
    """The paper's parameters with the C code's phi0 = 2, M = 0.1, dt = 0.5 and no adhesion (patch 41 by default)."""
    return Params.loewe(**{"k_ad": 0.0, "dtype": "float64", "patch": 41, **kw})


def half(p: Params) -> int:
    """The C code places a cell's template at ``int(x_cm - cellLx / 2)``, with integer division."""
    return p.patch // 2


def initial_fields(p: Params, seed: int):
    """(template (P, P), ox, oy, theta): one disc template, nonnegative patch origins, polarities."""
    rng = np.random.default_rng(seed)
    xy = _lattice_seeds(p.n_cells, p.Lx, p.Ly, 0.2, rng)
    ox = (np.floor(xy[:, 0]).astype(np.int64) - half(p)) % p.Lx
    oy = (np.floor(xy[:, 1]).astype(np.int64) - half(p)) % p.Ly
    radius = min(p.R, 0.45 * math.sqrt(p.Lx * p.Ly / p.n_cells))
    template = _disc_patch(p, half(p), half(p), radius)
    # the C code holds the two outer rings of its patch fixed, hexatissue the outer one at 0: start both at 0
    template[:2, :] = template[-2:, :] = template[:, :2] = template[:, -2:] = 0.0
    theta = rng.uniform(0.0, 2 * np.pi, p.n_cells)
    return template, ox, oy, theta


def write_c_inputs(run: Path, p: Params, template, ox, oy, theta, nequil, nsteps, every, field_every, seed):
    """The C code's cm file, shape file and parameter file (formats from its README and source)."""
    run.mkdir(parents=True, exist_ok=True)
    P = template.shape[0]
    with open(run / "cm.in", "w") as fh:  # the C code reads these lines into an 80-char buffer
        for c in range(p.n_cells):
            # x_cm - P // 2 = origin + 0.5, which the C code truncates to the origin (origins are >= 0)
            fh.write(f"{c} {ox[c] + half(p) + 0.5:.1f} {oy[c] + half(p) + 0.5:.1f} "
                     f"{math.cos(theta[c]):.12f} {math.sin(theta[c]):.12f}\n")
    with open(run / "shape.in", "w") as fh:
        for x in range(P):
            for y in range(P):
                fh.write(f"{x} {y} {template[y, x]:.12e}\n")  # field[x][y] = phi[row y, col x]
    lines = [
        f"phi0 = {p.phi0}", f"M = {p.M}", f"R = {p.R}", f"kappa = {p.k_phi}", f"alpha = {p.alpha}",
        f"mu = {p.lam}", f"Dr = {p.D_r}", f"epsilon = {p.eps}", f"cellLx = {P}", f"cellLy = {P}",
        f"lx = {p.Lx}", f"ly = {p.Ly}", f"ncells = {p.n_cells}", f"nsteps = {nsteps}", f"nequil = {nequil}",
        f"dt = {p.dt}", f"v = {p.v0}", f"seed = {seed}", "cm_file = cm.in", "shape_file = shape.in",
        "",
        f"dump_cm {every} 0 main pos.dat",
        f"dump_field {field_every} 0 main field.dat",
        f"dump_index_field {field_every} 0 main index.dat",
    ]
    (run / "params.txt").write_text("\n".join(lines) + "\n")


def start_c_run(exe: Path, run: Path):
    env = dict(os.environ, OMP_NUM_THREADS="1")
    log = open(run / "run.log", "w")
    return subprocess.Popen([str(exe), "params.txt"], cwd=run, stdout=log, stderr=subprocess.STDOUT, env=env), log


def read_c_positions(path: Path, p: Params):
    """steps (T,), unwrapped phi-weighted centroids (T, N, 2) from the C code's ``dump_cm`` file."""
    steps, frames = [], []
    with open(path) as fh:
        lines = fh.read().split("\n")
    k = 0
    while k < len(lines) and lines[k].startswith("Cells:"):
        n = int(lines[k].split()[1])
        steps.append(int(lines[k + 1].split()[1]))
        a = np.array([[float(v) for v in line.split()] for line in lines[k + 2:k + 2 + n]])
        frames.append(np.c_[a[:, 0] + a[:, 2] * p.Lx, a[:, 1] + a[:, 3] * p.Ly])
        k += 2 + n
    return np.array(steps), np.array(frames)


def read_c_image(path: Path, p: Params, dtype=float):
    """A ``dump_field`` / ``dump_index_field`` file (lines ``x y value``) as an image [row = y, col = x]."""
    a = np.loadtxt(path)
    img = np.zeros(p.shape, dtype=dtype)
    img[a[:, 1].astype(int), a[:, 0].astype(int)] = a[:, 2]
    return img


# -- hexatissue's side -----------------------------------------------------------------------
def hexatissue_sim(p: Params, template, ox, oy, theta, seed) -> Simulation:
    phi = np.broadcast_to(template, (p.n_cells,) + template.shape).copy()
    return Simulation(p, phi, ox, oy, theta, np.random.default_rng(10_000 + seed))


def phi_centroids(sim: Simulation):
    """Unwrapped phi-weighted centroids (N, 2) with the C code's node-centre convention (+0.5)."""
    P = sim.params.patch
    w = sim.phi.astype(float)
    m = w.sum((1, 2))
    j = np.arange(P)
    x = (w.sum(1) * j).sum(1) / m
    y = (w.sum(2) * j).sum(1) / m
    return np.c_[sim.ox + x + 0.5, sim.oy + y + 0.5]


def index_and_total(sim: Simulation):
    """The C code's index field (cell + 1 of the largest field above phi0 / 2, else 0) and total field."""
    vmax, imax, vsum = sim.max_field()
    return np.where(vmax > 0.5 * sim.params.phi0, imax + 1, 0), vsum


def run_hexatissue(p: Params, template, ox, oy, theta, seed, nequil, nsteps, every, field_every):
    """Equilibrate (v0 = 0, theta diffusing, as in the C code), then run; returns positions and images."""
    eq = hexatissue_sim(p.replace(v0=0.0), template, ox, oy, theta, seed)
    eq.advance(nequil, active=True)
    sim = Simulation(p, eq.phi, eq.ox, eq.oy, eq.theta, eq.rng)
    steps, pos, images = [0], [phi_centroids(sim)], {0: index_and_total(sim)}
    t0 = time.perf_counter()
    for s in range(every, nsteps + 1, every):
        sim.advance(every)
        steps.append(s)
        pos.append(phi_centroids(sim))
        if s % field_every == 0:
            images[s] = index_and_total(sim)
    return np.array(steps), np.array(pos), images, time.perf_counter() - t0, float(sim.leak.max())


# -- observables (the same for both codes) ---------------------------------------------------
def neighbour_pairs(index, total, p: Params):
    """Set of neighbouring cell pairs (4-adjacency, periodic) after filling gaps as ``segment`` does."""
    proxy = np.where(index > 0, p.phi0, 0.0)  # the C code writes no largest-field value: fill ties by position
    lab = labels_from_max(proxy, index - 1, total, p.phi0, max_hole=math.pi * p.R**2)
    pairs = set()
    for axis in (0, 1):
        a, b = lab, np.roll(lab, -1, axis)
        m = (a > 0) & (b > 0) & (a != b)
        pairs |= {(min(u, v), max(u, v)) for u, v in zip(a[m].tolist(), b[m].tolist())}
    return pairs


def observables(steps, pos, images, p: Params, every):
    d = pos - pos[0]
    disp = np.hypot(d[..., 0], d[..., 1])
    msd = (disp**2).mean(1)
    t = steps * p.dt
    half = len(steps) // 2
    slope = float(np.polyfit(np.log(t[half:]), np.log(msd[half:]), 1)[0]) if len(steps) > 3 else float("nan")
    step_d = np.diff(pos, axis=0)
    speed = float(np.hypot(step_d[..., 0], step_d[..., 1]).mean() / (every * p.dt) / p.v0)
    keys = sorted(images)
    holes = float(np.mean([(images[k][1] < 0.5 * p.phi0).mean() for k in keys]))
    first, last = neighbour_pairs(*images[keys[0]], p), neighbour_pairs(*images[keys[-1]], p)
    lost = len(first - last) / max(1, len(first))
    return dict(mean_displacement=float(disp[-1].mean()), msd_end=float(msd[-1]), msd_slope=slope,
                speed_over_v0=speed, holes=holes, pairs_start=len(first), pairs_lost=lost,
                neighbours_per_cell=2 * len(first) / p.n_cells)


# -- passive check -----------------------------------------------------------------------------
def passive_check(exe, work, p, template, ox, oy, theta, steps):
    """Centroid differences (max, mean; px) between the codes after ``steps`` passive steps."""
    q = p.replace(D_r=0.0)
    run = work / "passive"
    write_c_inputs(run, q, template, ox, oy, theta, nequil=steps, nsteps=0, every=1, field_every=10**9, seed=1)
    proc, log = start_c_run(exe, run)
    sim = hexatissue_sim(q, template, ox, oy, theta, 0)
    start = phi_centroids(sim)
    sim.advance(steps, active=False)
    ours = phi_centroids(sim)
    proc.wait()
    log.close()
    _, c_pos = read_c_positions(run / "pos.dat", q)
    dev = np.hypot(*(ours - c_pos[-1]).T)
    moved = np.hypot(*(ours - start).T)
    return float(dev.max()), float(dev.mean()), float(moved.mean())


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--c-code", required=True, type=Path, help="checkout or bare clone of mchchiang/phase_field_benjamin")
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--nsteps", type=int, default=25_000)
    ap.add_argument("--nequil", type=int, default=5_000)
    ap.add_argument("--every", type=int, default=500, help="steps between centroid frames")
    ap.add_argument("--field-every", type=int, default=5_000, help="steps between field / index frames")
    ap.add_argument("--check-steps", type=int, default=400, help="passive check length (0 = skip)")
    ap.add_argument("--advection", nargs="+", default=["upwind3", "central"], choices=["upwind3", "central"])
    ap.add_argument("--cells", type=int, default=440)
    ap.add_argument("--size", type=int, nargs=2, default=(384, 403))
    ap.add_argument("--patch", type=int, default=41, help="patch side in both codes (odd; default 41)")
    ap.add_argument("--out", type=Path, default=None, help="append the markdown report here")
    ap.add_argument("--json", type=Path, default=None, help="write all numbers here")
    ap.add_argument("--keep", action="store_true", help="keep the temporary build and run folder")
    args = ap.parse_args(argv)
    if args.nsteps % args.field_every or args.field_every % args.every:
        raise SystemExit("--nsteps must be a multiple of --field-every, and that of --every")

    set_threads(1)
    work = Path(tempfile.mkdtemp(prefix="hexatissue-vs-c-"))
    results = {"settings": {k: (str(v) if isinstance(v, Path) else v) for k, v in vars(args).items()}, "runs": []}
    try:
        exe = build_c_code(args.c_code, work / "build")
        base = common_params(n_cells=args.cells, Lx=args.size[0], Ly=args.size[1], patch=args.patch)
        lines = [f"## hexatissue vs the C code, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}", "",
                 f"- {base.n_cells} cells, {base.Lx} x {base.Ly}, phi0 = {base.phi0:g}, M = {base.M:g}, "
                 f"dt = {base.dt:g}, v0 = {base.v0:g}, D_r = {base.D_r:g}, k_ad = 0, patch {base.patch}; "
                 f"{args.nequil} equilibration + {args.nsteps} active steps; seeds {args.seeds}",
                 f"- load before: `{os.getloadavg()}`", ""]
        if args.check_steps:
            p = base.replace(advection=args.advection[0])
            tpl, ox, oy, th = initial_fields(p, args.seeds[0])
            dmax, dmean, moved = passive_check(exe, work, p, tpl, ox, oy, th, args.check_steps)
            results["passive_check"] = dict(steps=args.check_steps, max=dmax, mean=dmean, moved=moved)
            lines += [f"- passive check ({args.check_steps} steps from the unrelaxed state, {p.advection}): centroids "
                      f"moved {moved:.3f} px on average; the codes differ by {dmean:.2e} px on average, "
                      f"{dmax:.2e} px at most", ""]
            print(lines[-2], flush=True)
        header = ("| seed | code | mean displacement (px) | MSD (px^2) | MSD slope | speed / v0 | holes | "
                  "neighbour pairs lost | wall s |")
        lines += [header, "|---|---|---|---|---|---|---|---|---|"]
        for seed in args.seeds:
            p = base
            tpl, ox, oy, th = initial_fields(p, seed)
            run = work / f"seed{seed}"
            write_c_inputs(run, p, tpl, ox, oy, th, args.nequil, args.nsteps, args.every, args.field_every, seed)
            t0 = time.perf_counter()
            proc, log = start_c_run(exe, run)
            rows = []
            for adv in args.advection:
                steps, pos, images, wall, leak = run_hexatissue(p.replace(advection=adv), tpl, ox, oy, th, seed,
                                                                args.nequil, args.nsteps, args.every, args.field_every)
                obs = dict(observables(steps, pos, images, p, args.every), wall=wall, leak=leak)
                rows.append((f"hexatissue {adv}", obs))
                print(seed, adv, json.dumps(obs), flush=True)
            rc = proc.wait()
            log.close()
            c_wall = time.perf_counter() - t0
            if rc != 0:
                raise SystemExit(f"the C run failed (exit {rc}); see {run / 'run.log'}")
            c_steps, c_pos = read_c_positions(run / "pos.dat", p)
            c_images = {s: (read_c_image(run / f"index.dat.{s}", p, int), read_c_image(run / f"field.dat.{s}", p))
                        for s in range(0, args.nsteps + 1, args.field_every)}
            c_obs = dict(observables(c_steps, c_pos, c_images, p, args.every), wall=c_wall)
            print(seed, "C", json.dumps(c_obs), flush=True)
            rows.insert(0, ("C code", c_obs))
            for name, o in rows:
                lines.append(f"| {seed} | {name} | {o['mean_displacement']:.2f} | {o['msd_end']:.0f} | "
                             f"{o['msd_slope']:.2f} | {o['speed_over_v0']:.3f} | {o['holes']:.4f} | "
                             f"{o['pairs_lost']:.3f} | {o['wall']:.0f} |")
            results["runs"].append({"seed": seed, **{name: o for name, o in rows}})
        lines += ["", "Mean displacement relative to the C code (mean over seeds):", ""]
        for adv in args.advection:
            key = f"hexatissue {adv}"
            ratios = [r[key]["mean_displacement"] / r["C code"]["mean_displacement"] for r in results["runs"]]
            results[f"ratio_{adv}"] = ratios
            lines.append(f"- {adv}: " + ", ".join(f"{x:.3f}" for x in ratios) + f" (mean {np.mean(ratios):.3f})")
        emit(lines, os.getloadavg(), args.out)
        if args.json:
            args.json.write_text(json.dumps(results, indent=1))
    finally:
        if args.keep:
            print(f"kept {work}")
        else:
            shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
