"""``hexatissue export RESULTS --to {geff,ctc,ome-zarr,anndata} OUT``: a results folder in another tool's format."""
from __future__ import annotations

__all__ = ["add_parser", "export"]

FORMATS = ("geff", "ctc", "ome-zarr", "anndata")
#: The OME-Zarr that ``--to geff --with-ome-zarr`` writes beside the GEFF stores (and their related_objects name).
OME_ZARR_BESIDE = "cells.zarr"


def add_parser(subparsers):
    """Register the ``export`` subcommand on an argparse ``subparsers`` object."""
    p = subparsers.add_parser(
        "export", help="write a 'hexatissue analyze' folder as GEFF graphs, a Cell Tracking Challenge folder, "
                       "an OME-Zarr image with its labels or an AnnData file",
        description="geff: OUT/neighbours.geff (cells and their contacts, every frame) and OUT/tracks.geff (cells "
                    "linked along their tracks and divisions), node and edge properties from the tables. ctc: "
                    "OUT/maskTTT.tif with track ids + OUT/res_track.txt (--truth: OUT/TRA/man_track* and "
                    "OUT/SEG/man_seg*). ome-zarr: "
                    "OUT, an OME-Zarr image (the raw channel: --image, or the analysis's intensity image; else the "
                    "cell outlines) with the labels with track ids in OUT/labels/cells. ctc and ome-zarr re-open "
                    "the labels the results were computed from (the path in metadata.json, or --labels). anndata: "
                    "OUT.h5ad or OUT.zarr, the cells as observations with their features (X, units in var), centroids "
                    "and neighbour graph (extra anndata). geff --with-ome-zarr: the labels as OME-Zarr in "
                    "OUT/cells.zarr too, linked from both stores (related_objects).")
    p.add_argument("results", metavar="RESULTS", help="output folder of 'hexatissue analyze'")
    p.add_argument("out", metavar="OUT", help="output folder (ome-zarr: the .zarr folder)")
    p.add_argument("--to", required=True, choices=FORMATS, help="format to write")
    p.add_argument("--labels", metavar="FILE",
                   help="ctc, ome-zarr: the label image or stack the results were computed from (default: the "
                        "path recorded in metadata.json)")
    p.add_argument("--mask", metavar="FILE", help="ctc, ome-zarr: the --mask of the analysis (default: the recorded one)")
    p.add_argument("--truth", action="store_true",
                   help="ctc: the ground-truth layout OUT/TRA/man_trackTTT.tif + OUT/TRA/man_track.txt, with the "
                        "reference segmentation of every frame in OUT/SEG/man_segTTT.tif")
    p.add_argument("--keep-membranes", action="store_true",
                   help="ctc, ome-zarr: keep the input's membranes (or skeleton lines) at 0 instead of sharing them "
                        "out between the cells, so that analysing the export again gives the same network "
                        "(docs/exchange.md)")
    p.add_argument("--with-ome-zarr", action="store_true",
                   help=f"geff: also write the labels as OME-Zarr, OUT/{OME_ZARR_BESIDE} (as --to ome-zarr, with its "
                        f"options), and point both GEFF stores to it (related_objects; without it they are null)")
    p.add_argument("--levels", type=int, default=1, help="ome-zarr: resolution levels (default 1)")
    p.add_argument("--image", metavar="FILE",
                   help="ome-zarr: the raw channel to write under the labels (default: the intensity image of the "
                        "analysis, if it had one, else the cell outlines)")
    p.add_argument("--ngff-version", choices=("0.5", "0.4"), default="0.5",
                   help="ome-zarr: OME-NGFF version (default 0.5, zarr v3; 0.4: zarr v2 for older readers)")
    p.add_argument("--overwrite", action="store_true",
                   help="replace OUT (ome-zarr, anndata; geff: its two stores and, with --with-ome-zarr, "
                        "OUT/cells.zarr; ctc: the mask folder, or TRA and SEG with --truth) even when it holds "
                        "something that is not an earlier export of the same format; without it such an OUT is "
                        "refused. The results folder is never replaced")
    p.set_defaults(func=_run)
    return p


def export(results, out, to, *, labels=None, mask=None, truth=False, levels=1, image=None, ngff_version="0.5",
           keep_membranes=False, with_ome_zarr=False, overwrite=False):
    """Write a results folder (or Movie) as ``to`` (one of :data:`FORMATS`); returns what was written.

    See :func:`~hexatissue.exchange.geff.write_geff`,
    :func:`~hexatissue.exchange.ctc.write_ctc` (masks from
    :func:`~hexatissue.exchange.labels.track_masks`, lines from the lineage),
    :func:`~hexatissue.exchange.omezarr.write_ome_zarr_labels` (``image``:
    the raw channel, a path or array; default: the analysis's intensity
    image when it had one, else the cell outlines) and
    :func:`~hexatissue.exchange.anndata.write_anndata`; ``keep_membranes``:
    ``membranes`` of :func:`~hexatissue.exchange.labels.track_masks`.
    ``with_ome_zarr`` (geff): the OME-Zarr export is written too, to
    ``out/cells.zarr``, and the GEFF stores point to it
    (``related_objects``); the OME-Zarr is returned first.

    A results folder is read for ``ctc`` and ``ome-zarr`` with its large
    tables left on disk (``read_results(lazy=True)``): of them these read
    only the cells' ``frame``, ``cell``, ``track`` and ``area`` (and the
    lineage); the masks they write are made from the labels, every frame
    in memory before it is written.  ``geff`` and ``anndata`` read the
    whole tables: every column of every cell, the edges (neighbours) and,
    for AnnData, the vertices and the cells' vertices (the shape tensors).

    Nothing is deleted that an export did not write: ``out`` (for geff its
    two stores, for ctc its mask folder) must not exist, be empty or be an
    earlier export of the same format, else it is refused before any work
    unless ``overwrite``; ``out`` that is, or holds, the results folder is
    always refused.
    """
    from ..errors import InputError
    from ..results import Movie, read_results

    if to not in FORMATS:
        raise InputError(f"to must be one of {FORMATS}; got {to!r}")
    from pathlib import Path

    if with_ome_zarr and to != "geff":
        raise InputError(f"with_ome_zarr (--with-ome-zarr) is for to='geff'; got to={to!r}")
    _check_out(results, out, to, truth, overwrite)
    if with_ome_zarr:
        _check_out(results, Path(out) / OME_ZARR_BESIDE, "ome-zarr", truth, overwrite)
    # the labels' exports read four columns of the cells (and the lineage); GEFF and AnnData write every cell's
    # columns, the neighbours from the edges and (AnnData) the polygons: whole tables
    movie = results if isinstance(results, Movie) else read_results(results, lazy=to in ("ctc", "ome-zarr"))
    if to == "geff":
        from .geff import write_geff

        if not with_ome_zarr:
            return write_geff(movie, out, overwrite=overwrite)
        beside = export(movie, Path(out) / OME_ZARR_BESIDE, "ome-zarr", labels=labels, mask=mask, levels=levels,
                        image=image, ngff_version=ngff_version, keep_membranes=keep_membranes,
                        overwrite=overwrite)
        return beside + write_geff(movie, out, labels=beside[0], overwrite=overwrite)
    if to == "anndata":
        from .anndata import write_anndata

        return [write_anndata(movie, out, overwrite=overwrite)]
    from .labels import track_masks

    masks = track_masks(movie, labels, mask, membranes=keep_membranes)
    if to == "ctc":
        from .ctc import write_ctc

        if movie.lineage is None:
            raise InputError("the results have no lineage table; expected the output of hexatissue analyze")
        folder = write_ctc(masks, movie.lineage, out, truth=truth, overwrite=overwrite)
        return [folder, folder.parent / "SEG"] if truth else [folder]  # the truth's reference segmentation too
    import numpy as np

    from .omezarr import track_properties, write_ome_zarr_labels

    biggest = max(int(m.max()) for m in masks)
    dtype = np.uint16 if biggest < 2**16 else np.uint32 if biggest < 2**32 else np.uint64
    colors, properties = track_properties(movie)
    return [write_ome_zarr_labels([m.astype(dtype) for m in masks], out, image=_raw_image(movie, image),
                                  calibration=movie.calibration, levels=levels, version=ngff_version,
                                  colors=colors, properties=properties, overwrite=overwrite)]


def _check_out(results, out, to, truth, overwrite):
    """Refuse, before any work, an ``out`` that is or holds the results folder, or that the export would replace."""
    from pathlib import Path

    from ..errors import InputError
    from ..io import check_replaceable

    if not isinstance(out, (str, Path)) or not str(out):
        raise InputError(f"out must be a path (str or Path); got {out!r}")
    out = Path(out)
    if isinstance(results, (str, Path)):
        folder, target = Path(results).resolve(), out.resolve()
        if target == folder or target in folder.parents:
            what = "the results folder" if target == folder else "a folder holding the results folder"
            raise InputError(f"out {str(out)!r} is {what} {str(results)!r}; the export would replace it: write "
                             f"to another path")
    if to == "ome-zarr":
        from .omezarr import is_ome_zarr_export

        check_replaceable(out, is_ome_zarr_export, name="out", overwrite=overwrite)
    elif to == "anndata":
        from .anndata import is_anndata_export

        check_replaceable(out, is_anndata_export, name="out", overwrite=overwrite)
    elif to == "geff":
        from .geff import NEIGHBOURS, TRACKS, is_geff_export

        for name in (NEIGHBOURS, TRACKS):
            check_replaceable(out / name, is_geff_export, name="out", overwrite=overwrite)
    else:
        from .ctc import is_ctc_export

        for where in (out / "TRA", out / "SEG") if truth else (out,):
            check_replaceable(where, is_ctc_export, name="out", overwrite=overwrite)


def _raw_image(movie, image):
    """The raw channel to write under the labels: ``image`` opened, or the analysis's intensity image, or None."""
    from ..source import open_source, recorded_labels

    if image is not None:
        return image if hasattr(image, "shape") and not isinstance(image, (str, bytes)) else open_source(image)
    recorded = (movie.source or {}).get("intensity")
    return recorded_labels(recorded)[0] if recorded else None


def _run(args) -> int:
    written = export(args.results, args.out, args.to, labels=args.labels, mask=args.mask, truth=args.truth,
                     levels=args.levels, image=args.image, ngff_version=args.ngff_version,
                     keep_membranes=args.keep_membranes, with_ome_zarr=args.with_ome_zarr,
                     overwrite=args.overwrite)
    print(f"{args.results} -> {args.to}: " + ", ".join(str(w) for w in written))
    return 0
