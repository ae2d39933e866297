"""The ``hexatissue`` command: thin subcommands over the public API.

Run ``hexatissue --help`` or ``hexatissue SUBCOMMAND --help``.
"""
from __future__ import annotations

import argparse
import contextlib
import os
import re
import signal
import sys
import threading
import time
import warnings
from importlib import import_module
from pathlib import Path

from .errors import HexatissueWarning, InputError
from .options import OPTION_CLASSES, add_flags, flag_text, from_flags

__all__ = ["main"]

# stages that register their own subcommand with ``add_parser(subparsers)``
SUBCOMMAND_MODULES = ("hexatissue.simulate.command", "hexatissue.hydro.command", "hexatissue.workflows.command",
                      "hexatissue.exchange.command", "hexatissue.benchmark.command", "hexatissue.surface.command")
#: What compiling the kernels cost, measured (benchmarks/results_first_run.md).
COMPILE_TEXT = "measured: 38-54 CPU-seconds, 59-107 s on a shared 2-core machine at load 5-6"
DEBUG_HELP = "on an error, show the Python traceback instead of one line"
#: Seconds a command has to stop after Ctrl-C before it is ended: an interrupt inside numba's compiler (a first
#: run, an empty cache) can be swallowed there, or end in an error that no longer names it.
INTERRUPT_GRACE = 1.0


def _analyze_parser(sub):
    p = sub.add_parser(
        "analyze",
        help="junction network, shape order, defects (and, for movies, tracks and T1 events)",
        description="Extract vertices, junctions, ordered polygons and per-cell shape functions from a 2-D "
        "label image, a T x Y x X label stack, an MPF run or cell polygons (a vertices table, a Tissue Analyzer "
        "TA.db, hexanematic Polygon.mat files: no label image needed); coarse-grain the shape order and find its "
        "defects; for movies also track cells and classify T1 events. Writes every table and metadata.json "
        "to --out (read it back with hexatissue.read_results). Lengths in the tables are px, times frames; "
        "the pixel size and frame interval (from the file, or --pixel-size / --frame-interval) go to "
        "metadata.json and to the figures.",
    )
    p.add_argument("input", help="label image or stack (.tif/.tiff, .png, .npy, Cellpose _seg.npy, .npz, zarr / "
                                 "OME-Zarr, a folder of frames), an MPF run (.zarr), or cell polygons: a vertices "
                                 "table (.csv/.parquet: cell, x, y in polygon order, optional frame), a Tissue "
                                 "Analyzer TA.db, a hexanematic ImageN_Polygon.mat or a folder of them (independent "
                                 "images, not tracked)")
    p.add_argument("--out", required=True, help="output folder for the tables")
    src = p.add_argument_group("input")
    src.add_argument("--key", help="array inside an .npz, zarr group or Cellpose _seg.npy file")
    src.add_argument("--channel", type=int, help="channel of a multi-channel image (0-based)")
    src.add_argument("--level", type=int, help="resolution level of an OME-Zarr image (default 0)")
    src.add_argument("--axes", help="the input's dimensions, one letter each from TCZYXS (e.g. TYX: a stack of 3 or "
                                    "4 frames that would read as one colour image)")
    src.add_argument("--periodic", action="store_true", help="the images tile a periodic box (simulations)")
    src.add_argument("--pixel-size", type=float, help="physical size of a pixel (default: from the file)")
    src.add_argument("--units", help="length unit of --pixel-size (default: from the file, else um)")
    src.add_argument("--frame-interval", type=float,
                     help="time between frames (default: from the file, or a bundled sample's documentation)")
    src.add_argument("--time-unit", help="unit of --frame-interval, e.g. s, min, h (default: from the file or a bundled "
                                         "sample's documentation, else min)")
    src.add_argument("--mask", metavar="FILE",
                     help="region of interest: an image of the frames' shape, nonzero = inside; pixels outside are 0")
    add_stage_flags(p)
    run = p.add_argument_group("running")
    run.add_argument("--checkpoint", metavar="DIR", help="movies: save progress to DIR and resume from it when run again")
    run.add_argument("--workers", type=int, help="local processes for movies (default: all cores)")
    run.add_argument("--scheduler", metavar="ADDRESS", help="dask.distributed scheduler address for movies")
    run.add_argument("--stream", choices=["auto", "yes", "no"], default="auto",
                     help="write the tables to --out as the frames finish, in Parquet parts by chunk of frames "
                          "(OUT/cells/part-*.parquet, ...), so that memory does not grow with the movie; auto "
                          "(default): for movies of more than 1.5e8 pixel-frames (about 1 GB of tables)")
    run.add_argument("--figures", action="store_true", help="also write PNG figures to OUT/figures")
    run.add_argument("--format", nargs="+", default=["parquet"], choices=["parquet", "csv"],
                     help="table formats to write (default: parquet)")
    p.set_defaults(func=_run_analyze, cli_text=analyze_text)


def add_stage_flags(parser):
    """A group of flags per stage's options class (:func:`hexatissue.options.add_flags`), to ``"<stage>.<field>"``."""
    for name, cls in OPTION_CLASSES.items():
        add_flags(parser, cls, prefix=f"{name}.")


def stage_options(args) -> dict:
    """The options object of every stage from the flags of :func:`add_stage_flags`."""
    return {name: from_flags(args, cls, prefix=f"{name}.") for name, cls in OPTION_CLASSES.items()}


def analyze_text(text: str) -> str:
    """An error text of the library with ``SomeOptions.field`` replaced by the ``hexatissue analyze`` flag."""
    return flag_text(text, OPTION_CLASSES.values())


def open_cli_source(args):
    """The :class:`~hexatissue.Source` named by the input options of ``hexatissue analyze``."""
    from .source import open_source

    from .units import override_units

    source = open_source(args.input, key=args.key, channel=args.channel, level=args.level, axes=args.axes)
    units, time_unit = override_units(source.calibration, pixel_size=args.pixel_size, length_unit=args.units,
                                      frame_interval=args.frame_interval, time_unit=args.time_unit)
    return source.with_calibration(pixel_size=args.pixel_size, length_unit=units,
                                   frame_interval=args.frame_interval, time_unit=time_unit)


def _run_analyze(args) -> int:
    from .io import check_output_folder, lock_folder
    from .results import RUN_LOCK, check_replaceable_tables

    source = open_cli_source(args)
    options = stage_options(args)
    out = check_output_folder(args.out, "--out")  # now, not after the whole computation
    if args.checkpoint is not None:
        check_output_folder(args.checkpoint, "--checkpoint")
    check_replaceable_tables(out, "--out")  # before the lock, which marks the folder as a run's
    made = not out.exists()
    lock = lock_folder(out, RUN_LOCK, "--out folder")  # two runs into one folder: the second is refused
    try:
        return _analyze_into(args, source, options)
    except BaseException:
        if made:  # a folder this run made, holding nothing but its lock: not left behind
            (out / RUN_LOCK).unlink(missing_ok=True)
            with contextlib.suppress(OSError):
                out.rmdir()
        raise
    finally:
        if lock is not None:
            lock.close()


def _analyze_into(args, source, options) -> int:
    from .pipeline import analyze, first_run_compiles, streams_by_default
    from .results import write_results

    client = connect_scheduler(args.scheduler) if args.scheduler else None
    if first_run_compiles(source, client):
        announce_compile(source, options)
    start = time.perf_counter()
    stream = args.stream == "yes" or (args.stream == "auto" and streams_by_default(source))
    try:
        movie = analyze(source, box=True if args.periodic else None, client=client, workers=args.workers,
                        checkpoint=args.checkpoint, mask=args.mask, out=args.out if stream else None, **options)
    finally:
        if client is not None:
            client.close()
    line = summary_line(movie)
    if stream:  # the folder is complete: the Parquet tables are written; CSV and figures come from them
        if args.figures:
            from .results import read_results
            from .workflows.figures import save_movie_figures

            tables = read_results(args.out, lazy=False)  # the figures' functions take DataFrames
            (Path(args.out) / "metadata.json").unlink(missing_ok=True)
            figures = save_movie_figures(tables, Path(args.out) / "figures", source)
        else:
            figures = []
        written = movie.write(args.out, formats=tuple(args.format)) + figures
    elif args.figures:
        from .workflows.figures import save_movie_figures

        # the figures first, then the tables and metadata.json last: a folder whose figures failed (a full
        # disk) or were interrupted has no metadata.json, so it never reads as complete
        (Path(args.out) / "metadata.json").unlink(missing_ok=True)
        figures = save_movie_figures(movie, Path(args.out) / "figures", source)
        written = movie.write(args.out, formats=tuple(args.format)) + figures
    else:  # the tables are not used again: each is freed once written (less memory under the writer)
        written = write_results(movie, args.out, formats=tuple(args.format), release=True)
    print(f"{args.input}: {line}; {len(written)} files in {args.out} "
          f"({time.perf_counter() - start:.1f} s)")
    return 0


def announce_compile(source, options):
    """Say that this run compiles the numba kernels, once its first frame has been read and checked.

    A refused input so stops before the message (and compiles nothing);
    the check runs the kernels' references (:func:`hexatissue._dispatch.references`),
    so nothing is compiled before the message either.  The figure is
    measured by ``benchmarks/bench_first_run.py``.
    """
    from ._dispatch import references

    if source.kind != "polygons":
        with references("auto"), warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the run reports the frame's warnings with the others
            source.checked_frame(0, options["mesh"].kind)
    print(f"hexatissue analyze: first run on an empty numba cache: compiling the kernels this input needs "
          f"({COMPILE_TEXT}; once: later runs load them from numba's cache)", file=sys.stderr, flush=True)


def connect_scheduler(address, name="--scheduler"):
    """A dask.distributed Client connected to ``address``; InputError naming ``name`` when that fails."""
    from dask.distributed import Client

    try:
        return Client(address)
    except (OSError, TimeoutError, ValueError, TypeError) as exc:
        detail = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise InputError(f"{name} {address!r}: no dask scheduler could be reached there ({detail}); expected the "
                         f"address of a running dask.distributed scheduler, e.g. tcp://HOST:8786") from None


def summary_line(movie) -> str:
    """One line of key numbers of an analysis (frames, cells, vertices, T1 events, defects)."""
    n = max(len(movie), 1)
    cells = movie.cells
    parts = [f"{len(movie)} frame(s)",
             f"{len(cells) / n:.0f} cells/frame ({int((~cells['is_border']).sum()) / n:.0f} interior)",
             f"{len(movie.vertices) / n:.0f} vertices/frame"]
    tracking = movie.summary.get("tracking")
    independent = bool(tracking) and tracking["resolved"] == "off"
    if len(movie) > 1 and independent:
        parts.append("independent frames: not tracked")
    elif len(movie) > 1 and tracking:
        how = ("ids kept" if tracking["resolved"] == "never" else
               "re-tracked following the motion" if tracking.get("follow") == "flow" else "re-tracked by overlap")
        suspect = (f", {tracking['n_divisions_suspect']} suspect" if "n_divisions_suspect" in tracking else "")
        extruded = (f", {tracking['interior_extrusions']} interior extrusions" if "interior_extrusions" in tracking
                    else "")
        doubtful = tracking.get("doubtful_frames") or []
        doubtful = f"; DOUBTFUL at {len(doubtful)} frame(s)" if doubtful else ""
        parts.append(f"tracks: {how} ({tracking['rows_track_not_cell']} rows changed, "
                     f"{tracking['n_divisions']} divisions{suspect}{extruded}{doubtful})")
    if len(movie) > 1 and movie.events is not None and not independent:
        counts = movie.events["kind"].value_counts()
        censor = movie.summary.get("events", {}).get("censor")
        parts.append("T1 events " + (", ".join(f"{k} {v}" for k, v in counts.items()) or "none")
                     + (f" (censor {censor})" if censor is not None else ""))
    if movie.defects is not None:  # counts per p from two columns (a groupby copies every column of each p)
        import numpy as np

        p, charge = movie.defects["p"].to_numpy(), movie.defects["charge"].to_numpy()
        counts = [(q, charge[p == q]) for q in np.unique(p)]
        parts.append("defects " + (", ".join(f"p={q}: +{int((c > 0).sum())}/-{int((c < 0).sum())}" for q, c in counts)
                                   or "none"))
    return "; ".join(parts)


class _Parser(argparse.ArgumentParser):
    """argparse taking every negative number as a value, also in exponent notation (``--alpha -1e-3``).

    argparse's own test (``-1``, ``-.5``, ``-0.5``) leaves ``-1e-3`` to be
    read as an unknown flag; the subcommands' parsers are of this class too.
    """

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = re.compile(r"^-(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="hexatissue",
        description="Junction networks, T1 events, hexatic order and defects of epithelial tissues.",
    )
    from ._version import __version__

    parser.add_argument("--version", action="version", version=f"hexatissue {__version__}")
    parser.add_argument("--debug", action="store_true", help=DEBUG_HELP)
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    _analyze_parser(sub)
    for module in SUBCOMMAND_MODULES:
        import_module(module).add_parser(sub)
    _add_debug(sub)
    return parser


def _add_debug(subparsers):
    """``--debug`` also after every subcommand, and after the actions of a subcommand that has some."""
    for subparser in subparsers.choices.values():
        subparser.add_argument("--debug", action="store_true", default=argparse.SUPPRESS, help=DEBUG_HELP)
        for action in subparser._actions:
            if isinstance(action, argparse._SubParsersAction):
                _add_debug(action)


def _show_warning(command, translate):
    """A ``warnings.showwarning`` printing hexatissue's own warnings as one line (no internal source line)."""
    default = warnings.showwarning

    def show(message, category, filename, lineno, file=None, line=None):
        if issubclass(category, HexatissueWarning):
            print(f"hexatissue {command}: warning: {translate(str(message))}", file=file or sys.stderr)
        else:
            default(message, category, filename, lineno, file, line)

    return show


def _interrupted(exc) -> bool:
    """Whether ``exc`` is Ctrl-C: a KeyboardInterrupt, or raised inside compiled (numba) code, where it surfaces
    as SystemErrors chained around the KeyboardInterrupt."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return True
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return False


class _Interrupt:
    """The SIGINT handler of a command: a KeyboardInterrupt where the run is, and, if the command has not ended
    :data:`INTERRUPT_GRACE` s later, its workers killed and the process ended with code 130.

    Installed even where SIGINT was ignored (a shell without job control starts background commands so): kill
    -INT, like Ctrl-C, must stop a run with its workers.
    """

    def __init__(self, command):
        self.command = command
        self.received = False
        self.timer = None
        self._lock = threading.Lock()
        self._reported = False

    def __call__(self, signum, frame):
        if not self.received:
            self.received = True
            # an interrupt inside numba's compiler lands in ctypes callbacks of LLVM, which print it and go on, and
            # leaves half-built LLVM objects whose destructors fail when collected: noise, not news
            sys.unraisablehook = lambda unraisable: None
            self.timer = threading.Timer(INTERRUPT_GRACE, self.end)
            self.timer.daemon = True
            self.timer.start()
        raise KeyboardInterrupt

    def report(self):
        """Say once that the command was interrupted."""
        with self._lock:
            if not self._reported:
                self._reported = True
                print(f"hexatissue {self.command}: interrupted; files already written are complete", file=sys.stderr,
                      flush=True)

    def end(self):
        """The command did not stop by itself: its worker processes are killed, then this one."""
        import multiprocessing

        for child in multiprocessing.active_children():
            child.kill()
        self.report()
        os._exit(130)


def main(argv=None) -> int:
    """Entry point of the ``hexatissue`` command; returns the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    translate = getattr(args, "cli_text", None) or (lambda text: text)
    saved = warnings.showwarning
    if not args.debug:
        warnings.showwarning = _show_warning(args.command, translate)
    interrupt, previous = _Interrupt(args.command), None
    with contextlib.suppress(ValueError):  # not the main thread: signals are the host's business
        previous = signal.signal(signal.SIGINT, interrupt)
    try:
        return int(args.func(args) or 0)
    except BaseException as exc:
        # after Ctrl-C, whatever the run raised is the interrupt: numba's cache, interrupted while it compiled,
        # fails with "no compiled object yet", which no longer names it
        if interrupt.received or _interrupted(exc):
            interrupt.report()
            sys.unraisablehook = lambda unraisable: None  # as in _Interrupt: the compiler's leftovers are noise
            return 130
        if isinstance(exc, (InputError, OSError)) and not args.debug:
            # bad input (and files that cannot be read or written) is one line; --debug shows the traceback
            print(f"hexatissue {args.command}: error: {translate(str(exc))}", file=sys.stderr)
            return 2
        raise
    finally:
        if interrupt.timer is not None:
            interrupt.timer.cancel()  # the command did stop
        if previous is not None:
            signal.signal(signal.SIGINT, previous)
        warnings.showwarning = saved


if __name__ == "__main__":
    sys.exit(main())
