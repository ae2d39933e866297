"""The sample data shipped inside the package (``hexatissue/sample_data/``), by name.

The files are package data, so they are in the wheel as well as in the
source tree: ``hexatissue analyze "$(python -m hexatissue.samples epicure_notum)"``
works from any folder once the package is installed.
"""
from __future__ import annotations

import sys
from pathlib import Path

from .errors import InputError

__all__ = ["SAMPLES", "SAMPLE_DATA", "sample_path"]

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
