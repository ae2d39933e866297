"""``hexatissue simulate``: run the bundled multiphase-field model into a zarr store."""
from __future__ import annotations

import sys

from ..errors import InputError
from .params import INTEGRATORS

__all__ = ["add_parser", "main"]


def add_parser(subparsers):
    """Register the ``simulate`` subcommand on an argparse ``subparsers`` object."""
    p = subparsers.add_parser(
        "simulate",
        help="run the multiphase-field epithelium model (numba) into a zarr store",
        description=(
            "Run the paper's multiphase-field model: N cells seeded on a jittered lattice, relaxed "
            "passively (v0 = 0) for --relax steps, then --steps active steps; every --save-every steps a "
            "frame (labels, centroids, theta, areas) is appended to the zarr store --out.  Ctrl-C stops "
            "at the next frame with a checkpoint; --resume continues exactly.  Read the result with "
            "hexatissue.simulate.read_run."
        ),
    )
    p.add_argument("--out", required=True, help="output store, e.g. RUN.zarr")
    p.add_argument("--cells", type=int, default=440, help="number of cells N (default 440)")
    p.add_argument("--size", type=int, nargs=2, default=(384, 403), metavar=("LX", "LY"),
                   help="periodic box in px: LX columns, LY rows (default 384 403)")
    p.add_argument("--steps", type=int, default=None, help="active steps (default 10000; on --resume: the stored value)")
    p.add_argument("--save-every", type=int, default=100, help="steps between saved frames (default 100)")
    p.add_argument("--relax", type=int, default=10_000, help="passive relaxation steps before the active run (default 10000)")
    p.add_argument("--dr", type=float, default=1e-5, help="rotational diffusion D_r (default 1e-5; paper range 1e-6..8e-5)")
    p.add_argument("--v0", type=float, default=0.006, help="self-propulsion speed, px per time unit (default 0.006)")
    p.add_argument("--dt", type=float, default=0.5, help="time step (default 0.5; must be < pi R^2 phi0^2 / (4 M lambda))")
    p.add_argument("--preset", choices=("paper", "loewe"), default="paper",
                   help="paper: phi0 = 1 (default); loewe: phi0 = 2 as in the MPF code of Loewe et al. 2020")
    p.add_argument("--patch", type=int, default=41, help="patch side P in px (default 41)")
    p.add_argument("--advection", choices=("upwind3", "central"), default="upwind3",
                   help="stencil of v . grad phi: upwind3 = third-order upwind as in the published MPF code "
                        "(default); central = central differences (slower free cells; runs made before "
                        "this option used it)"),
    p.add_argument("--integrator", choices=INTEGRATORS, default="heun",
                   help="time stepper: heun = second order, 2 right-hand sides per step (default); "
                        "euler = first order, 1 per step, about 2x faster (the published MPF code's scheme)")
    p.add_argument("--float64", action="store_true", help="double-precision fields (default float32)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--threads", default="auto",
                   help="numba threads, or 'auto' = cores left idle by the current load, then the fastest of that, 1 and "
                        "all threads, timed on chunks of the run (default auto)")
    p.add_argument("--patches-every", type=int, default=0, help="save full patch fields every K frames (default 0 = never)")
    p.add_argument("--checkpoint-seconds", type=float, default=60.0,
                   help="least wall time between checkpoints, s (default 60; 0 = after every frame)")
    p.add_argument("--resume", action="store_true", help="continue --out from its last checkpoint")
    p.add_argument("--overwrite", action="store_true", help="replace an existing --out")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=main, cli_text=cli_text)
    return p


#: Params fields -> the options that set them, so errors and warnings name what the user typed
CLI_NAMES = {"Params.n_cells": "--cells", "Params.Lx": "--size LX", "Params.Ly": "--size LY",
             "Params.patch": "--patch", "Params.dt": "--dt", "Params.v0": "--v0", "Params.D_r": "--dr",
             "Params.dtype": "--float64", "save_every": "--save-every", "patches_every": "--patches-every",
             "checkpoint_seconds": "--checkpoint-seconds", "relax": "--relax", "steps": "--steps",
             "seed": "--seed", "threads": "--threads"}


def cli_text(text: str) -> str:
    """An error or warning text of the library with parameter names replaced by their ``simulate`` options."""
    import re

    names = sorted(CLI_NAMES, key=len, reverse=True)
    pattern = re.compile(r"(?<![\w.-])(" + "|".join(re.escape(n) for n in names) + r")(?![\w])")
    return pattern.sub(lambda m: CLI_NAMES[m.group(1)], text)


def _threads(value):
    if value == "auto":
        return "auto"
    try:
        return int(value)
    except ValueError:
        raise InputError(f"--threads must be an integer or 'auto'; got {value!r}") from None


def main(args) -> int:
    """Run the ``simulate`` subcommand; returns the exit code (0 done, 130 interrupted, 2 bad input)."""
    from .params import Params
    from .runner import run_simulation

    try:
        threads = _threads(args.threads)
        if args.resume:
            summary = run_simulation(args.out, steps=args.steps, threads=threads, resume=True,
                                     checkpoint_seconds=args.checkpoint_seconds, progress=not args.quiet)
        else:
            preset = Params.loewe if args.preset == "loewe" else Params.paper
            params = preset(n_cells=args.cells, Lx=args.size[0], Ly=args.size[1], D_r=args.dr, v0=args.v0,
                            dt=args.dt, patch=args.patch, dtype="float64" if args.float64 else "float32",
                            advection=args.advection, integrator=args.integrator)
            summary = run_simulation(args.out, params, steps=args.steps, save_every=args.save_every,
                                     relax=args.relax, seed=args.seed, patches_every=args.patches_every,
                                     threads=threads, overwrite=args.overwrite,
                                     checkpoint_seconds=args.checkpoint_seconds, progress=not args.quiet)
    except InputError as exc:
        if getattr(args, "debug", False):
            raise
        print(f"hexatissue simulate: error: {cli_text(str(exc))}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as exc:
        print(f"{exc}\nresume with: hexatissue simulate --out {args.out} --resume", file=sys.stderr)
        return 130
    print(summary)
    return 0
