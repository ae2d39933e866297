"""Calibration from file metadata: ImageJ and OME-XML (TIFF), raw values (OME-Zarr), unit spellings.

Values are rounded to 12 significant digits (``1.0000000000000002`` ->
``1.0``), pixel sizes from ImageJ's resolution tags to 7 (what their 6
decimals hold).  A unit hexatissue does not know is ignored with a warning
and a note.
"""
from __future__ import annotations

import warnings

import numpy as np

from ..errors import HexatissueWarning, InputError, user_stacklevel
from ..units import Calibration, normalize_length_unit, normalize_time_unit

__all__ = ["NON_SQUARE", "clean_number", "file_unit", "metadata_calibration", "tiff_calibration",
           "ome_xml_calibration"]

NON_SQUARE = "non-square pixels: hexatissue uses the x (column) pixel size for all lengths"


def clean_number(value) -> float:
    """``value`` as float without float noise (12 significant digits)."""
    return float(f"{float(value):.12g}")


def file_unit(unit, normalize, kind, notes):
    """Canonical unit from a file's metadata, or None (with a warning) when hexatissue does not know it."""
    try:
        return normalize(str(unit))
    except InputError:
        warnings.warn(f"unknown {kind} unit {unit!r} in the file's metadata; that calibration is ignored (pass "
                      f"{'length_unit' if kind == 'length' else 'time_unit'}= to set it)", HexatissueWarning,
                      stacklevel=user_stacklevel())
        notes.append(f"unknown {kind} unit {unit!r} in the metadata: ignored")
        return None


def metadata_calibration(notes, size_x=None, size_y=None, length_unit=None, interval=None,
                         time_unit=None) -> Calibration:
    """A Calibration from raw metadata values (None or non-positive = absent); units are file spellings.

    Choices made (non-square pixels, ignored values or units) are appended to ``notes``.
    """
    fields = {}
    lu = file_unit(length_unit, normalize_length_unit, "length", notes) if length_unit is not None else None
    if lu not in (None, "px") and size_x is not None and np.isfinite(size_x) and size_x > 0:
        fields.update(pixel_size=clean_number(size_x), length_unit=lu, length_from="file")
        if fields["pixel_size"] == 1:
            warnings.warn(f"the file's metadata gives a pixel size of exactly 1 {lu}, the default that several tools "
                          f"write when nobody set it (PartSeg, ImageJ with a unit but no scale): if it is not the "
                          f"microscope's, give the real one (--pixel-size)", HexatissueWarning,
                          stacklevel=user_stacklevel())
            notes.append(f"pixel size exactly 1 {lu} in the metadata: possibly a placeholder")
        if size_y is not None and size_y > 0 and not np.isclose(size_x, size_y, rtol=1e-6):
            warnings.warn(NON_SQUARE, HexatissueWarning, stacklevel=user_stacklevel())
            notes.append(f"non-square pixels: x {clean_number(size_x)} and y {clean_number(size_y)} {lu}; "
                         f"the x size is used for all lengths")
    elif lu == "px" and size_x not in (None, 1, 1.0):
        notes.append(f"the length unit is pixels; the pixel size {clean_number(size_x)} in the metadata is ignored")
    tu = file_unit(time_unit, normalize_time_unit, "time", notes) if time_unit is not None else None
    if tu not in (None, "frame") and interval is not None and np.isfinite(interval) and interval > 0:
        fields.update(frame_interval=clean_number(interval), time_unit=tu, time_from="file")
    return Calibration(**fields)


def tiff_calibration(tf, notes) -> Calibration:
    """The calibration of an open ``tifffile.TiffFile``: OME-XML, else ImageJ metadata, else none.

    The resolution tags of plain TIFFs are not used (72 dpi defaults are common).
    """
    if tf.is_ome and tf.ome_metadata:
        return ome_xml_calibration(tf.ome_metadata, notes)
    md = tf.imagej_metadata if tf.is_imagej else None
    if not md:
        return Calibration()
    page = tf.pages[0]

    def per_pixel(tag):
        t = page.tags.get(tag)
        if t is None:
            return None
        num, den = t.value if isinstance(t.value, tuple) else (t.value, 1)
        # pixel size = 1 / (pixels per unit); ImageJ stores pixels per unit with 6 decimals, so 7
        # significant digits of the pixel size are all it holds (0.275 um, not 0.275000048)
        return float(f"{den / num:.7g}") if num else None

    unit = md.get("unit")
    size_x, size_y = per_pixel("XResolution"), per_pixel("YResolution")
    if unit is not None and size_x is None:
        size_x = size_y = 1.0  # ImageJ: a unit without a resolution means 1 unit per pixel
    interval = md.get("finterval")
    # ImageJ writes tunit only when it is not its default, seconds
    tunit = md.get("tunit", "sec") if interval else None
    return metadata_calibration(notes, size_x, size_y, unit, float(interval) if interval else None, tunit)


def ome_xml_calibration(xml, notes) -> Calibration:
    """The calibration in OME-XML: ``PhysicalSizeX``/``Y`` (default unit µm) and ``TimeIncrement`` (default s)."""
    import xml.etree.ElementTree as ET

    root = ET.fromstring(xml)
    pixels = next((e for e in root.iter() if e.tag.rsplit("}", 1)[-1] == "Pixels"), None)
    if pixels is None:
        return Calibration()
    a = pixels.attrib

    def number(name):
        return float(a[name]) if name in a else None

    size_x = number("PhysicalSizeX")
    length_unit = a.get("PhysicalSizeXUnit", "µm") if size_x is not None else None  # OME's default unit
    interval = number("TimeIncrement")
    time_unit = a.get("TimeIncrementUnit", "s") if interval is not None else None
    return metadata_calibration(notes, size_x, number("PhysicalSizeY"), length_unit, interval, time_unit)
