"""``hexatissue benchmark ACTION``: synthetic benchmark folders (``make``), and what is built on them.

Every action registers itself with one function in :data:`SUBCOMMANDS`
(``add(actions)`` on the ``benchmark`` parser's subparsers).
"""
from __future__ import annotations

import time

from ..options import add_flags, flag_text, from_flags
from .render import RenderOptions
from .score_command import add_baseline, add_score

__all__ = ["add_parser", "SUBCOMMANDS"]


def cli_text(text: str) -> str:
    """An error text of the library with ``RenderOptions.field`` replaced by the option that sets it."""
    return flag_text(text, [RenderOptions])


def _add_make(actions):
    p = actions.add_parser(
        "make", help="render a ground-truth movie as microscopy, with its exact truth",
        description="Render the membrane channel (and optionally nuclei) of a ground-truth movie -- an MPF run "
        "or a synthetic Voronoi / scripted T1 movie -- and write OUT/raw.tif (uint16, ImageJ metadata with pixel "
        "size and frame interval), OUT/truth/ (a results folder: every table and labels.tif), OUT/ctc/ (Cell "
        "Tracking Challenge ground truth), OUT/drift.csv and OUT/benchmark.json (how it was made).")
    p.add_argument("--from", dest="source", required=True, metavar="RUN.zarr|voronoi|t1",
                   help="an MPF run store, 'voronoi' (moving Voronoi tissue) or 't1' (the scripted T1 movie)")
    p.add_argument("--out", required=True, help="output folder")
    p.add_argument("--cells", type=int, help="voronoi: number of cells (default 100)")
    p.add_argument("--frames", type=int, help="frames (voronoi default 10, t1 default 36; a run: its first FRAMES)")
    p.add_argument("--size", type=int, nargs=2, metavar=("ROWS", "COLS"), help="voronoi: image size (default 256 256)")
    p.add_argument("--open", dest="periodic", action="store_false",
                   help="voronoi, t1: an open image instead of a periodic box")
    p.add_argument("--crop", type=int, nargs=4, metavar=("ROW0", "COL0", "ROWS", "COLS"),
                   help="open field of view cut from the periodic box (cells on its edge become border cells)")
    p.add_argument("--seed", type=int, default=0, help="random seed of the tissue and the rendering (default 0)")
    p.add_argument("--pixel-size", type=float, help="pixel size written to the TIFFs (default: the source's)")
    p.add_argument("--units", default="um", help="length unit of --pixel-size (default um)")
    p.add_argument("--frame-interval", type=float, help="time between frames (default: the source's)")
    p.add_argument("--time-unit", default="min", help="unit of --frame-interval (default min)")
    p.add_argument("--workers", type=int, default=1, help="processes for the truth analysis (default 1)")
    add_flags(p, RenderOptions)
    p.set_defaults(func=_run_make, cli_text=cli_text)


def _run_make(args) -> int:
    from ..io import check_output_folder
    from .make import make_benchmark

    check_output_folder(args.out, "--out")
    render = from_flags(args, RenderOptions)
    start = time.perf_counter()
    out = make_benchmark(args.source, args.out, render=render, seed=args.seed, crop=args.crop, n_cells=args.cells,
                         n_frames=args.frames, shape=args.size, periodic=args.periodic, pixel_size=args.pixel_size,
                         length_unit=args.units, frame_interval=args.frame_interval, time_unit=args.time_unit,
                         workers=args.workers)
    print(f"benchmark {args.source}: raw.tif, truth/, benchmark.json in {out} ({time.perf_counter() - start:.1f} s)")
    return 0


#: the actions of ``hexatissue benchmark``, each ``add(actions)``
SUBCOMMANDS = (_add_make, add_baseline, add_score)


def add_parser(subparsers):
    """Register ``hexatissue benchmark`` and its actions on an argparse ``subparsers`` object."""
    p = subparsers.add_parser("benchmark", help="synthetic benchmarks: rendered movies with exact truth",
                              description="Synthetic benchmarks for segmentation, tracking and T1 detection: "
                              "rendered microscopy with the exact answer beside it (docs/benchmark.md).")
    actions = p.add_subparsers(dest="action", required=True, metavar="ACTION")
    for add in SUBCOMMANDS:
        add(actions)
    return p
