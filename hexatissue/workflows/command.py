"""``hexatissue report RESULTS_DIR [--out DIR]``: figures and report.md of a ``hexatissue analyze`` folder.
"""
from __future__ import annotations


__all__ = ["add_parser"]


def add_parser(subparsers):
    """Register the ``report`` subcommand on an argparse ``subparsers`` object."""
    p = subparsers.add_parser(
        "report", help="figures and a Markdown summary of a 'hexatissue analyze' folder",
        description="Render the figures that apply to the results of 'hexatissue analyze' (single frame: "
                    "order fields and defects; movie: also T1 events, T1-defect proximity, migration vs defect "
                    "density, event timing) as PNGs, with report.md holding the key numbers.")
    p.add_argument("results", metavar="RESULTS_DIR", help="output folder of 'hexatissue analyze'")
    p.add_argument("--out", help="report folder (default: RESULTS_DIR/report)")
    p.add_argument("--p", type=int, default=6, help="defect order for the T1 and migration analyses (default 6)")
    p.add_argument("--dl", type=float, default=35.0, help="migration subregion side, px (default 35)")
    p.add_argument("--dt", type=int, default=None,
                   help="migration window, frames (default: a quarter of the movie; for MPF runs use "
                        "25000 / save_every to match the paper)")
    p.add_argument("--n-control", type=int, default=5, help="random cells per T1 event in the control (default 5)")
    p.add_argument("--control", choices=["cells", "vertices"], default="cells",
                   help="T1-defect control: random cells (the paper's, default) or random vertices (junction level)")
    p.add_argument("--seed", type=int, default=0, help="seed of the control draw and mixture fit (default 0)")
    p.add_argument("--frame-interval", type=float,
                   help="time between frames (default: the one recorded by analyze)")
    p.add_argument("--time-unit", help="unit of --frame-interval (default: the recorded one, else min)")
    p.add_argument("--pixel-size", type=float, help="physical pixel size (default: the one recorded by analyze)")
    p.add_argument("--units", help="length unit of --pixel-size (default: the recorded one, else um)")
    p.add_argument("--include-border", action="store_true",
                   help="keep border cells and the T1s touching them in the proximity and migration analyses")
    p.set_defaults(func=_run)
    return p


def _run(args) -> int:
    from pathlib import Path

    from ..errors import InputError
    from ..results import read_results
    from .report import report

    if args.out is not None and Path(args.out).resolve() == Path(args.results).resolve():
        raise InputError(f"--out {args.out!r} is the results folder itself; the report goes into a folder of its own "
                         f"(default: RESULTS_DIR/report)")
    movie = read_results(args.results, lazy=False)
    movie = movie.replace(calibration=movie.calibration.override(
        pixel_size=args.pixel_size, length_unit=args.units, frame_interval=args.frame_interval,
        time_unit=args.time_unit, assume_units=True))
    out = Path(args.results) / "report" if args.out is None else args.out
    numbers = report(movie, out, p=args.p, dl=args.dl, dt=args.dt, n_control=args.n_control,
                     seed=args.seed, include_border=args.include_border, control=args.control)
    md = next(w for w in numbers["written"] if w.endswith("report.md"))
    print(f"report written: {md} ({len(numbers['written'])} files)")
    return 0

