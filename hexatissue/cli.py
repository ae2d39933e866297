"""The ``hexatissue`` command: thin subcommands over the public API.

Run ``hexatissue --help`` or ``hexatissue SUBCOMMAND --help``.
"""
from __future__ import annotations

import argparse
import sys

from importlib import import_module

from .errors import InputError

__all__ = ["main"]

# stages that register their own subcommand with ``add_parser(subparsers)``
SUBCOMMAND_MODULES = ("hexatissue.simulate.command", "hexatissue.hydro.command", "hexatissue.analysis.command")


def _analyze_parser(sub):
    p = sub.add_parser(
        "analyze",
        help="junction network, shape order, defects (and, for movies, tracks and T1 events)",
        description="Extract vertices, junctions, ordered polygons and per-cell shape functions from a 2-D "
        "label image, a T x Y x X label stack or an MPF run; coarse-grain the shape order and find its "
        "defects; for movies also track cells and classify T1 events. Writes tables to --out.",
    )
    p.add_argument("input", help="label image or stack (.tif/.tiff, .png, .npy, Cellpose _seg.npy, .npz) "
                                 "or an MPF run (.zarr)")
    p.add_argument("--out", required=True, help="output folder for the tables")
    p.add_argument("--periodic", action="store_true", help="the images tile a periodic box (simulations)")
    p.add_argument("--kind", default="auto", choices=["auto", "touching", "membrane", "skeleton"],
                   help="label convention (default: detected)")
    p.add_argument("--p", type=int, nargs="+", default=[2, 6], metavar="P",
                   help="symmetry orders of the shape function columns (default: 2 6)")
    p.add_argument("--order-p", type=int, nargs="*", default=[6, 2], metavar="P",
                   help="orders of the coarse-grained field and defects (default: 6 2; none to skip)")
    p.add_argument("--radius", type=float, help="coarse-graining radius, px (default 1.5 R_cell)")
    p.add_argument("--spacing", type=float, help="coarse-graining grid spacing, px (default R_cell)")
    p.add_argument("--merge-distance", type=float, default=2.0,
                   help="junctions shorter than this (px) become four-fold vertices (default: 2)")
    p.add_argument("--membrane-width", type=int, default=3,
                   help="0-valued junction pixels within this many px of a cell are shared out (default: 3)")
    p.add_argument("--center", default="vertex_mean", choices=["vertex_mean", "area_centroid"],
                   help="cell centre of the shape function (default: vertex_mean)")
    p.add_argument("--track", dest="track", action="store_true", default=None,
                   help="link cells by overlap (default for label stacks)")
    p.add_argument("--no-track", dest="track", action="store_false",
                   help="trust the ids as consistent over time (default for MPF runs)")
    p.add_argument("--min-length", type=float, default=0.0,
                   help="contacts shorter than this (px) count as four-fold vertices in T1 detection (default: 0)")
    p.add_argument("--censor", type=int, default=10,
                   help="T1s within this many frames of the end are 'unresolved' (default: 10)")
    p.add_argument("--max-gap", type=int, default=0,
                   help="tracking: link cells missing for up to this many frames (default: 0)")
    p.add_argument("--checkpoint", metavar="DIR",
                   help="movies: save progress to DIR and resume from it when run again")
    p.add_argument("--workers", type=int, help="local processes for movies (default: all cores)")
    p.add_argument("--scheduler", metavar="ADDRESS", help="dask.distributed scheduler address for movies")
    p.add_argument("--figures", action="store_true", help="also write PNG figures to OUT/figures")
    p.add_argument("--format", nargs="+", default=["parquet"], choices=["parquet", "csv"],
                   help="table formats to write (default: parquet)")
    p.add_argument("--pixel-size", type=float, default=1.0, help="physical size of a pixel (metadata)")
    p.add_argument("--units", default="px", help="unit of --pixel-size (metadata)")
    p.set_defaults(func=_run_analyze)


def _run_analyze(args) -> int:
    from .results import analyze_to_folder

    client = None
    if args.scheduler:
        from dask.distributed import Client

        client = Client(args.scheduler)
    try:
        summary = analyze_to_folder(
            args.input, args.out, periodic=args.periodic, p=tuple(args.p), order_p=tuple(args.order_p),
            radius=args.radius, spacing=args.spacing, formats=tuple(args.format), figures=args.figures,
            client=client, n_workers=args.workers, track=args.track, min_length=args.min_length,
            censor=args.censor, max_gap=args.max_gap, checkpoint=args.checkpoint, kind=args.kind, merge_distance=args.merge_distance,
            membrane_width=args.membrane_width, center=args.center, pixel_size=args.pixel_size, units=args.units,
        )
    finally:
        if client is not None:
            client.close()
    parts = [
        f"{summary['frames']} frame(s)",
        f"{summary['cells_per_frame']:.0f} cells/frame ({summary['interior_cells_per_frame']:.0f} interior)",
        f"{summary['vertices_per_frame']:.0f} vertices/frame",
    ]
    if "events" in summary:
        parts.append("T1 events " + (", ".join(f"{k} {v}" for k, v in summary["events"].items()) or "none"))
    if "defects" in summary:
        parts.append("defects " + ", ".join(f"{k}: +{v['+']}/-{v['-']}" for k, v in summary["defects"].items()))
    print(f"{args.input}: " + "; ".join(parts) + f"; {len(summary['written'])} files in {args.out} "
          f"({summary['seconds']:.1f} s)")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="hexatissue",
        description="Junction networks, T1 events, hexatic order and defects of epithelial tissues.",
    )
    from . import __version__

    parser.add_argument("--version", action="version", version=f"hexatissue {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    _analyze_parser(sub)
    for module in SUBCOMMAND_MODULES:
        import_module(module).add_parser(sub)
    return parser


def main(argv=None) -> int:
    """Entry point of the ``hexatissue`` command; returns the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except InputError as exc:
        print(f"hexatissue {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"hexatissue {args.command}: interrupted; files already written are complete", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
