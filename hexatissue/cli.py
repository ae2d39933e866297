"""The ``hexatissue`` command: thin subcommands over the public API.

Run ``hexatissue --help`` or ``hexatissue SUBCOMMAND --help``.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from .errors import InputError

__all__ = ["main"]


def _analyze_parser(sub):
    p = sub.add_parser(
        "analyze",
        help="junction network, shape order (and, for movies, events) of a label image or stack",
        description="Extract vertices, junctions, ordered polygons and per-cell shape functions from a 2-D "
        "label image or a T x Y x X label stack, and write them as tables.",
    )
    p.add_argument("input", help="label image or stack: .tif/.tiff, .png, .npy, Cellpose _seg.npy, .npz")
    p.add_argument("--out", required=True, help="output folder for the tables")
    p.add_argument("--periodic", action="store_true", help="the image is a periodic box (simulations)")
    p.add_argument("--kind", default="auto", choices=["auto", "touching", "membrane", "skeleton"],
                   help="label convention (default: detected)")
    p.add_argument("--p", type=int, nargs="+", default=[2, 6], metavar="P",
                   help="symmetry orders of the shape function columns (default: 2 6)")
    p.add_argument("--merge-distance", type=float, default=2.0,
                   help="junctions shorter than this (px) become four-fold vertices (default: 2)")
    p.add_argument("--membrane-width", type=int, default=3,
                   help="0-valued junction pixels within this many px of a cell are shared out (default: 3)")
    p.add_argument("--center", default="vertex_mean", choices=["vertex_mean", "area_centroid"],
                   help="cell centre of the shape function (default: vertex_mean)")
    p.add_argument("--format", nargs="+", default=["parquet"], choices=["parquet", "csv"],
                   help="table formats to write (default: parquet)")
    p.add_argument("--pixel-size", type=float, default=1.0, help="physical size of a pixel (metadata)")
    p.add_argument("--units", default="px", help="unit of --pixel-size (metadata)")
    p.set_defaults(func=_run_analyze)


def _mesh_options(args):
    return dict(kind=args.kind, merge_distance=args.merge_distance, membrane_width=args.membrane_width,
                p=tuple(args.p), center=args.center, pixel_size=args.pixel_size, units=args.units)


def _run_analyze(args) -> int:
    import numpy as np

    from .box import Box
    from .frame import Movie
    from .io import read_labels, write_table
    from .mesh import mesh_from_labels
    from .progress import progress

    start = time.perf_counter()
    labels = read_labels(args.input)
    if labels.ndim not in (2, 3):
        raise InputError(f"{args.input}: expected a 2-D image or a T x Y x X stack; got shape {labels.shape}")
    box = Box.from_shape(labels.shape) if args.periodic else None
    options = _mesh_options(args)
    out = Path(args.out)
    if labels.ndim == 2:
        result = mesh_from_labels(labels, box=box, **options)
        n_frames = 1
    else:
        frames = [mesh_from_labels(labels[t], box=box, frame=t, **options)
                  for t in progress(range(len(labels)), desc="frames", unit="frame")]
        result = Movie.from_frames(frames)
        n_frames = len(frames)
    written = result.write(out, formats=args.format)
    meta = {
        "input": str(args.input), "shape": list(labels.shape), "periodic": bool(args.periodic),
        "options": {k: (list(v) if isinstance(v, tuple) else v) for k, v in options.items()},
    }
    from . import __version__

    meta["hexatissue_version"] = __version__
    _write_json(meta, out / "metadata.json")
    cells = result.cells
    per_frame = len(cells) / n_frames
    inner = cells[~cells["is_border"]]
    g6 = np.hypot(inner["gamma6_re"], inner["gamma6_im"]).mean() if "gamma6_re" in inner else float("nan")
    print(
        f"{args.input}: {n_frames} frame(s), {per_frame:.0f} cells/frame ({len(inner) / n_frames:.0f} interior), "
        f"{len(result.vertices) / n_frames:.0f} vertices/frame, {len(result.edges) / n_frames:.0f} junctions/frame, "
        f"mean |gamma6| {g6:.3f}; {len(written)} tables written to {out} in {time.perf_counter() - start:.1f} s"
    )
    return 0


def _write_json(obj, path):
    from .io import atomic_path

    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(obj, indent=2))


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="hexatissue",
        description="Junction networks, T1 events, hexatic order and defects of epithelial tissues.",
    )
    from . import __version__

    parser.add_argument("--version", action="version", version=f"hexatissue {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    _analyze_parser(sub)
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
