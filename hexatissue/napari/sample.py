"""npe2 sample data: the bundled EpiCure label movie as a calibrated Labels layer, ready for the Analyze widget."""
from __future__ import annotations

from ..samples import sample_path

__all__ = ["epicure_labels"]


def epicure_labels() -> list:
    """``[(labels, kwargs, "labels")]``: the 11-frame EpiCure label movie, ``(t, y, x)`` at (300 s, 0.2 um, 0.2 um).

    Raises
    ------
    InputError
        The sample is missing from this installation (a repackaging that dropped the package data).
    """
    import tifffile

    # the sample's README.md (hexatissue/sample_data/epicure_notum/): 0.2 um/px, 300 s between frames
    labels = tifffile.imread(sample_path("epicure_notum")).astype("int32")  # float32 with integer values in the file
    return [(labels, {"name": "EpiCure notum labels", "scale": (300.0, 0.2, 0.2), "units": ("second", "um", "um"),
                      "axis_labels": ("t", "y", "x")}, "labels")]
