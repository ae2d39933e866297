"""``hexatissue benchmark baseline`` and ``hexatissue benchmark score``.

Each ``add_*`` function adds its action to the subparsers of ``hexatissue
benchmark`` (:data:`hexatissue.benchmark.command.SUBCOMMANDS`).
"""
from __future__ import annotations

__all__ = ["add_baseline", "add_score"]


def add_baseline(actions):
    """Add ``baseline`` to the subparsers of the ``benchmark`` command."""
    b = actions.add_parser(
        "baseline", help="segment a membrane movie with the scikit-image baseline",
        description="Segment a membrane image or movie (bright junctions) into touching cell labels: Gaussian "
                    "smoothing, h-minima seeds, seeded watershed, small-cell cleanup. A baseline, not a "
                    "competitor to learned segmenters. Writes an OME-TIFF label stack with the input's pixel "
                    "size and frame interval; analyse it with 'hexatissue analyze LABELS.tif --out DIR'.")
    b.add_argument("raw", metavar="RAW", help="membrane image or movie (.tif, .png, .npy, zarr, ...)")
    b.add_argument("--out", required=True, metavar="LABELS.tif", help="output label stack (OME-TIFF)")
    b.add_argument("--channel", type=int, help="membrane channel of a multi-channel file (0-based)")
    b.add_argument("--sigma", type=float, default=1.0, help="Gaussian smoothing, px (default 1)")
    b.add_argument("--h", type=float, default=0.1,
                   help="seed basin depth as a fraction of the robust intensity range (default 0.1)")
    b.add_argument("--min-area", type=int, default=30, help="smaller cells go to their neighbours, px (default 30)")
    b.add_argument("--periodic", action="store_true",
                   help="the frames tile a periodic box (MPF runs): a cell crossing the edge gets one id")
    b.set_defaults(func=_run_baseline)


def add_score(actions):
    """Add ``score`` to the subparsers of the ``benchmark`` command."""
    s = actions.add_parser(
        "score", help="score a prediction against exact truth",
        description="Compare two results folders (PRED: e.g. 'hexatissue analyze' of a segmentation; TRUTH: "
                    "'benchmark make''s truth/ folder) frame by frame: segmentation (CTC SEG Jaccard, splits, "
                    "merges, misses, extras), neighbour pairs, vertices, n_sides, track links, divisions, T1 "
                    "events and their kinds, gamma6. Writes the tables, scores.json (score -> [0, 1], 1 = "
                    "perfect; uncomputable scores left out), counts.json, summary.txt and scores.png to --out "
                    "and prints the summary.")
    s.add_argument("pred", metavar="PRED", help="results folder of the prediction")
    s.add_argument("truth", metavar="TRUTH", help="results folder of the truth")
    s.add_argument("--out", required=True, help="output folder")
    s.add_argument("--pred-labels", metavar="FILE",
                   help="labels of PRED (default: PRED/labels.tif, else the input recorded in its metadata.json)")
    s.add_argument("--truth-labels", metavar="FILE", help="labels of TRUTH (default: TRUTH/labels.tif, else its input)")
    s.add_argument("--vertex-radius", type=float, default=3.0, help="vertex matching radius, px (default 3)")
    s.add_argument("--frame-tolerance", type=int, default=2,
                   help="T1 events and divisions may be this many frames off (default 2)")
    s.add_argument("--t1-timing", choices=["start", "held"], default="start",
                   help="a T1 is on time when its frame_start is within the tolerance of the truth's (start, default) "
                        "or when its held four-fold interval frame_start..frame_gain is (held)")
    s.add_argument("--format", nargs="+", default=["parquet"], choices=["parquet", "csv"],
                   help="table formats (default: parquet)")
    s.set_defaults(func=_run_score)


def _run_baseline(args) -> int:
    from ..io import write_tiff
    from ..source import open_source
    from .baseline import segment_movie

    source = open_source(args.raw, channel=args.channel)
    labels = segment_movie(source.images(), sigma=args.sigma, h=args.h, min_area=args.min_area,
                           periodic=args.periodic)
    if source.description.get("frame_axis") is None:
        labels = labels[0]
    if labels.max() < 2**16:
        labels = labels.astype("uint16")
    write_tiff(args.out, labels, source.calibration)
    n = labels.max(axis=(-2, -1)) if labels.ndim == 3 else labels.max()
    print(f"{args.raw}: {source.n_frames} frame(s), {float(n.mean()):.0f} cells/frame; labels written to {args.out}")
    return 0


def _run_score(args) -> int:
    from ..io import check_output_folder
    from .score import score, score_to_folder

    check_output_folder(args.out, "--out")
    scores = score(args.pred, args.truth, pred_labels=args.pred_labels, truth_labels=args.truth_labels,
                   vertex_radius=args.vertex_radius, frame_tolerance=args.frame_tolerance,
                   t1_timing=args.t1_timing)
    written = score_to_folder(scores, args.out, formats=tuple(args.format))
    print(scores.text())
    print(f"{len(written)} files in {args.out}")
    return 0
