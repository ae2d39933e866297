"""npe2 sample data: the bundled EpiCure label movie as a calibrated Labels layer, ready for the Analyze widget."""
from __future__ import annotations

from ..samples import sample_path

__all__ = ["epicure_labels"]


def epicure_labels() -> list:
    """``[(labels, kwargs, "labels")]``: the 11-frame EpiCure label movie, ``(t, y, x)`` at (300 s, 0.2 um, 0.2 um).

    The scale and units are the calibration :func:`hexatissue.open_source` gives the file (its metadata, then
    what :data:`hexatissue.samples.SAMPLE_CALIBRATION` documents), so the Analyze widget and
    ``hexatissue analyze`` of the same file use one calibration.

    Raises
    ------
    InputError
        The sample is missing from this installation (a repackaging that dropped the package data).
    """
    import tifffile

    from ..source import open_source

    path = sample_path("epicure_notum")
    cal = open_source(path).calibration
    labels = tifffile.imread(path).astype("int32")  # float32 with integer values in the file
    time = "pixel" if cal.time_unit in ("frame", "iteration") else cal.time_unit  # napari's "no physical unit"
    length = "pixel" if cal.length_unit == "px" else cal.length_unit
    return [(labels, {"name": "EpiCure notum labels", "scale": (cal.frame_interval, cal.pixel_size, cal.pixel_size),
                      "units": (time, length, length), "axis_labels": ("t", "y", "x")}, "labels")]
