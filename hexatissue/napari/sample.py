"""npe2 sample data: the bundled EpiCure label movie as a calibrated Labels layer, ready for the Analyze widget."""
from __future__ import annotations

from pathlib import Path

from ..errors import InputError

__all__ = ["epicure_labels", "EPICURE"]

#: The EpiCure sample (sample_data/epicure_notum/README.md): 0.2 um/px, 300 s between frames.
EPICURE = Path(__file__).resolve().parents[2] / "sample_data" / "epicure_notum" / "013_crop_labels.tif"


def epicure_labels() -> list:
    """``[(labels, kwargs, "labels")]``: the 11-frame EpiCure label movie, ``(t, y, x)`` at (300 s, 0.2 um, 0.2 um).

    Raises
    ------
    InputError
        The sample is not there (it ships with the source tree, not in every install).
    """
    import tifffile

    if not EPICURE.exists():
        raise InputError(f"sample {str(EPICURE)!r} not found: the EpiCure sample ships with hexatissue's source "
                         f"tree (sample_data/); install from a checkout to use it")
    labels = tifffile.imread(EPICURE).astype("int32")  # float32 with integer values in the file
    return [(labels, {"name": "EpiCure notum labels", "scale": (300.0, 0.2, 0.2), "units": ("second", "um", "um"),
                      "axis_labels": ("t", "y", "x")}, "labels")]
