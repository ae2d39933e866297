"""A benchmark folder: the rendered movie beside its exact truth, in the formats people use.

``make_benchmark(source, out)`` writes::

    OUT/raw.tif          rendered movie, uint16, ImageJ hyperstack (TYX, or TCYX with nuclei),
                         pixel size, unit and frame interval in the metadata
    OUT/truth/           hexatissue results folder (read_results): every table + labels.tif (OME-TIFF)
    OUT/ctc/             Cell Tracking Challenge ground truth (TRA/man_trackTTT.tif, TRA/man_track.txt)
    OUT/drift.csv        frame, dx, dy: the stage drift of every frame, px
    OUT/benchmark.json   how it was made: source, seed, every rendering parameter, version (written last)

Every file is written to a temporary name and renamed (:func:`hexatissue.io.atomic_path`).
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..errors import InputError, check_positive
from ..exchange.ctc import write_ctc
from ..io import write_tiff
from .render import Renderer, RenderOptions, SNR_DEFINITION
from .truth import Truth, truth_from_run, truth_from_t1, truth_from_voronoi

__all__ = ["make_benchmark", "SOURCES"]

#: named synthetic sources of ``make_benchmark`` (anything else is a path to an MPF run)
SOURCES = ("voronoi", "t1")


def _truth(source, *, n_cells, n_frames, shape, periodic, crop, seed, workers, progress) -> Truth:
    """The Truth named by ``source`` (a Truth, ``"voronoi"``, ``"t1"`` or an MPF run path)."""
    if isinstance(source, Truth):
        if crop is not None or n_cells is not None or n_frames is not None or shape is not None:
            raise InputError("crop, n_cells, n_frames and shape apply to a source built here (an MPF run, "
                             "'voronoi', 't1'); a Truth is used as it is (crop it when you build it)")
        return source
    common = dict(workers=workers, progress=progress)
    if isinstance(source, str) and source == "voronoi":
        return truth_from_voronoi(n_cells or 100, tuple(shape or (256, 256)), n_frames or 10, periodic=periodic,
                                  seed=seed, crop=crop, **common)
    if isinstance(source, str) and source == "t1":
        if crop is not None or n_cells is not None or shape is not None:
            raise InputError("the 't1' source is the fixed scripted T1 movie (12 x 10 cells, 360 x 260 px): "
                             "n_cells, shape and crop do not apply")
        return truth_from_t1(periodic=periodic, n_frames=n_frames or 36, seed=seed, **common)
    if isinstance(source, str) and not Path(source).exists():
        raise InputError(f"source {source!r} is neither one of {SOURCES} nor an existing MPF run store (RUN.zarr)")
    if n_cells is not None or shape is not None:
        raise InputError("n_cells and shape apply to the 'voronoi' source; an MPF run has its own cells and box")
    return truth_from_run(source, frames=slice(0, n_frames), crop=crop, **common)


def _calibration(truth, pixel_size, length_unit, frame_interval, time_unit):
    """The truth's calibration with the user's pixel size / frame interval (in the given units)."""
    cal = truth.calibration
    if pixel_size is not None:
        cal = cal.replace(pixel_size=check_positive(pixel_size, "pixel_size"), length_unit=length_unit)
    if frame_interval is not None:
        cal = cal.replace(frame_interval=check_positive(frame_interval, "frame_interval"), time_unit=time_unit)
    return cal


def _imagej_metadata(cal, axes):
    """tifffile ``resolution`` and ImageJ ``metadata`` of a calibration."""
    meta = {"axes": axes, "unit": "um" if cal.length_unit == "um" else
            ("pixel" if cal.length_unit == "px" else cal.length_unit)}
    if cal.has_time:
        meta.update(finterval=float(cal.frame_interval), tunit=cal.time_unit)
    return (1.0 / cal.pixel_size, 1.0 / cal.pixel_size), meta


def _write_tiff(path, pages, shape, dtype, cal, axes):
    """An ImageJ hyperstack written page by page to a temporary name, then renamed."""
    import tifffile

    from ..io import atomic_path

    resolution, meta = _imagej_metadata(cal, axes)
    with atomic_path(path) as tmp:
        tifffile.imwrite(tmp, pages, shape=shape, dtype=dtype, imagej=True, resolution=resolution,
                         metadata=meta)
    return path


def make_benchmark(source, out, *, render=RenderOptions(), seed=0, crop=None, n_cells=None, n_frames=None,
                   shape=None, periodic=True, pixel_size=None, length_unit="um", frame_interval=None,
                   time_unit="min", workers=1, progress=True) -> Path:
    """Render a ground-truth movie and write it with its truth to the folder ``out``.

    Parameters
    ----------
    source : Truth, "voronoi", "t1", or str / Path of an MPF run (``.zarr``)
        Where the truth comes from (:mod:`hexatissue.benchmark.truth`).
    out : str or Path
        Output folder (created; files already there with the same names are replaced).
    render : RenderOptions
        Image model (:mod:`hexatissue.benchmark.render`).
    seed : int
        Seed of the rendering and of the synthetic tissue (``voronoi``, ``t1``).
    crop : (row0, col0, rows, cols), optional
        Open field of view cut from a periodic source.
    n_cells, n_frames, shape : int, int, (rows, cols), optional
        ``voronoi``: cells (default 100), frames (10), image shape (256 x 256);
        ``t1``: frames (default 36, at least 36); a run: its first
        ``n_frames`` frames (default all).
    periodic : bool
        ``voronoi`` and ``t1``: periodic box (default) or open image.
    pixel_size, length_unit : float, str
        Physical pixel size written to the TIFFs and the truth (default: the
        source's; uncalibrated sources stay in px).
    frame_interval, time_unit : float, str
        Time between frames (default: the source's; MPF runs: ``save_every`` iterations).
    workers : int
        Processes for the truth analysis.
    progress : bool
        Progress bars (on a terminal).

    Returns
    -------
    Path
        ``out``.
    """
    from .._version import __version__
    from ..io import atomic_path, check_output_folder, write_table
    from ..progress import progress as bar

    out = check_output_folder(out, "out")
    if not isinstance(render, RenderOptions):
        raise InputError(f"render must be a hexatissue.benchmark.RenderOptions; got {type(render).__name__}")
    truth = _truth(source, n_cells=n_cells, n_frames=n_frames, shape=shape, periodic=periodic, crop=crop,
                   seed=seed, workers=workers, progress=progress)
    cal = _calibration(truth, pixel_size, length_unit, frame_interval, time_unit)
    truth = Truth(truth.labels, truth.movie.replace(calibration=cal), truth.source)
    out.mkdir(parents=True, exist_ok=True)
    (out / "benchmark.json").unlink(missing_ok=True)  # the folder is incomplete until it is written again

    renderer = Renderer(truth, render, seed)
    n, (rows, cols), c = len(truth), truth.labels.shape[1:], renderer.channels
    frames = bar(range(n), enabled=progress, desc="render", unit="frame")
    pages = (page for t in frames for page in renderer.frame(t))
    axes = "TCYX" if c > 1 else "TYX"
    shape_out = (n, c, rows, cols) if c > 1 else (n, rows, cols)
    _write_tiff(out / "raw.tif", pages, shape_out, np.uint16, cal, axes)
    write_table(renderer.drift, out / "drift.csv")

    truth_dir = out / "truth"
    truth.movie.write(truth_dir)
    # OME-TIFF keeps any id range (uint32 for > 65535 cells); ImageJ hyperstacks hold 16 bits at most
    write_tiff(truth_dir / "labels.tif", truth.labels, cal)
    ctc = _write_ctc(truth, out / "ctc")

    description = {
        "hexatissue_version": __version__,
        "source": truth.source,
        "seed": int(seed),
        "render": render.to_dict(),
        "snr_definition": SNR_DEFINITION,
        "membrane_amplitude": renderer.amplitude,
        "nucleus_radius": renderer.nucleus_radius,
        "channels": ["membrane", "nuclei"][:c],
        "n_frames": n, "shape": [int(rows), int(cols)],
        "box": None if truth.box is None else truth.box.to_list(),
        "calibration": cal.to_dict(),
        "drift": {"file": "drift.csv", "convention": "a truth point (x, y) of frame t is seen at (x + dx, y + dy) "
                                                     "in raw.tif; the truth is in specimen coordinates"},
        "files": {"raw": "raw.tif", "truth": "truth", "labels": "truth/labels.tif", "ctc": ctc},
    }
    with atomic_path(out / "benchmark.json") as tmp:
        tmp.write_text(json.dumps(description, indent=2))
    return out


def _write_ctc(truth, folder):
    """The Cell Tracking Challenge ground truth of ``truth`` (masks + ``TRA/man_track.txt``)."""
    write_ctc(truth.labels, truth.movie.lineage, folder, truth=True)
    return folder.name
