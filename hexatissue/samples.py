"""The sample data shipped inside the package (``hexatissue/sample_data/``), by name.

The files are package data, so they are in the wheel as well as in the
source tree: ``hexatissue analyze "$(python -m hexatissue.samples epicure_notum)"``
works from any folder once the package is installed.
"""
from __future__ import annotations

import sys
from pathlib import Path

from .errors import InputError
from .units import Calibration

__all__ = ["SAMPLES", "SAMPLE_DATA", "SAMPLE_CALIBRATION", "sample_path", "documented_calibration"]

#: The folder of the samples (each has a README.md with its source, licence and citation).
SAMPLE_DATA = Path(__file__).resolve().parent / "sample_data"
#: name -> (path inside SAMPLE_DATA, what it is)
SAMPLES = {
    "epicure_notum": ("epicure_notum/013_crop_labels.tif",
                      "EpiCure's tracked label movie of a Drosophila epithelium: 11 frames, 160 x 257 px, "
                      "0.2 um/px, 300 s per frame (BSD-3-Clause, Gaelle Letort / Institut Pasteur)"),
    "mpf_small": ("mpf_small/run.zarr",
                  "a multiphase-field run of hexatissue's simulator: 60 cells, periodic 140 x 151 px, 301 frames"),
}


#: name -> the calibration its README documents, for what its file's metadata lacks (the one place it is written:
#: ``open_source`` of the file, hence ``hexatissue analyze``, and the napari sample both take it from here)
SAMPLE_CALIBRATION = {
    # the TIFF's ImageJ header holds 0.2 um/px but no frame interval; the README: 300 s between frames
    "epicure_notum": Calibration(0.2, "um", 300.0, "s"),
}


def documented_calibration(path) -> Calibration | None:
    """The documented calibration of a bundled sample if the file at ``path`` is one, else None.

    A file is the sample when its bytes are the bundled file's: the file in
    ``sample_data``, or a copy of it anywhere (a file of another size is
    told apart by its size alone, without reading it).
    """
    import filecmp

    try:
        path = Path(path)
        if not path.is_file():
            return None
        for name, calibration in SAMPLE_CALIBRATION.items():
            bundled = SAMPLE_DATA / SAMPLES[name][0]
            if bundled.is_file() and filecmp.cmp(path, bundled, shallow=False):
                return calibration
    except (OSError, TypeError, ValueError):
        return None
    return None


def sample_path(name: str) -> Path:
    """The path of the bundled sample ``name`` (a key of :data:`SAMPLES`).

    Raises
    ------
    InputError
        An unknown name, or a sample missing from this installation (a
        repackaging that dropped the package data).
    """
    if name not in SAMPLES:
        raise InputError(f"name must be one of {sorted(SAMPLES)}; got {name!r}")
    path = SAMPLE_DATA / SAMPLES[name][0]
    if not path.exists():
        raise InputError(f"sample {name!r} is missing from this installation ({path} does not exist); "
                         f"reinstall hexatissue from its wheel or sdist")
    return path


if __name__ == "__main__":  # python -m hexatissue.samples NAME: print the path, for shell commands
    if len(sys.argv) != 2 or sys.argv[1] not in SAMPLES:
        sys.exit("usage: python -m hexatissue.samples NAME, NAME one of: " + ", ".join(SAMPLES))
    print(sample_path(sys.argv[1]))
