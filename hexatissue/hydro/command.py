"""``hexatissue hydro dipole|quadrupole --alpha A [--n 256] [--steps N] --out RUN.zarr``.
"""
from __future__ import annotations

from pathlib import Path

from ..errors import InputError

__all__ = ["add_parser"]


def add_parser(subparsers):
    """Register the ``hydro`` subcommand on an argparse ``subparsers`` object."""
    p = subparsers.add_parser(
        "hydro", help="active hexatic hydrodynamics experiments (defect pair, defect quadrupole)",
        description="Run the paper's continuum experiments; writes a zarr store frame by frame "
                    "(resumable) and prints the annihilation time.")
    p.add_argument("experiment", choices=["dipole", "quadrupole"])
    p.add_argument("--alpha", type=float, required=True, help="activity alpha6 (<0 extensile)")
    p.add_argument("--n", type=int, default=256, help="grid size (default 256)")
    p.add_argument("--steps", type=int, default=None,
                   help="number of time steps (default: until annihilation, capped)")
    p.add_argument("--dt", type=float, default=None, help="time step (default 0.05)")
    p.add_argument("--distance", type=float, default=64.0, help="dipole: initial separation")
    p.add_argument("--ell", type=float, default=7.0, help="quadrupole: half-distance of like defects")
    p.add_argument("--max-time", type=float, default=None, help="safety cap on the simulated time")
    p.add_argument("--orientation-deg", type=float, default=0.0,
                   help="far-field bond angle in degrees (0: a bond along the dipole axis; 30 reverses the "
                        "active force)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", required=True, help="output zarr store (RUN.zarr)")
    p.add_argument("--resume", action="store_true", help="continue from the checkpoint in --out")
    p.add_argument("--defects", default=None, help="also write the defect trajectories (.parquet/.csv)")
    p.set_defaults(func=_run, cli_text=cli_text)
    return p


def cli_text(text: str) -> str:
    """An error text of the library with the names of its arguments replaced by the ``hydro`` options that set them."""
    if text.startswith(("ell must", "distance must")):  # the run's geometry, checked before the grid's
        text = "--" + text
    for name, flag in (("HydroParams.dt", "--dt"), ("HydroParams.alpha6", "--alpha"), ("max_time", "--max-time"),
                       ("defect separation and disk radius", "--distance (dipole) or 2 x --ell (quadrupole), and "
                                                             "the disk radius,"),
                       ("defects plus fixed disks", "--distance / --ell: defects plus fixed disks")):
        text = text.replace(name, flag)
    return text


def _run(args) -> int:
    import numpy as np

    from ..io import write_table
    from .experiments import run_dipole, run_quadrupole

    if args.resume and not (Path(args.out) / "checkpoint.npz").exists():
        raise InputError(f"--resume: {args.out!r} holds no hydro run checkpoint to continue; expected the --out "
                         f"of an earlier run (or drop --resume to start a new one)")
    if not np.isfinite(args.orientation_deg):
        raise InputError(f"--orientation-deg must be a finite angle in degrees; got {args.orientation_deg!r}")
    common = dict(n=args.n, steps=args.steps, dt=args.dt, seed=args.seed, out=args.out, resume=args.resume,
                  progress=True, orientation=float(np.deg2rad(args.orientation_deg)))
    if args.max_time is not None:
        common["max_time"] = args.max_time
    if args.experiment == "dipole":
        result = run_dipole(args.alpha, distance=args.distance, **common)
    else:
        result = run_quadrupole(args.alpha, ell=args.ell, **common)
    if args.defects:
        write_table(result.defects, args.defects)
    t = result.annihilation_time
    print(f"{args.experiment} alpha6={args.alpha:+g}: "
          + (f"annihilated at t = {t:g}" if t is not None else
             f"no annihilation by t = {result.diagnostics['time'].iloc[-1]:g}")
          + f"; output {args.out}")
    return 0

