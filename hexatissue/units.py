"""Physical calibration of a movie: pixel size, frame interval and their units.

Tables stay in pixels and frames everywhere in hexatissue; a
:class:`Calibration` travels with the :class:`~hexatissue.Movie` (and the
:class:`~hexatissue.Source` it came from) so that figures, reports and
analyses can show micrometres and minutes where the user has them.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, field, replace

import numpy as np

from .errors import InputError, check_positive

__all__ = ["Calibration", "as_calibration", "velocity_unit", "in_units", "override_units", "normalize_length_unit", "normalize_time_unit"]

# spellings found in ImageJ / OME / zarr metadata -> one canonical ASCII name
_LENGTH_ALIASES = {
    "px": "px", "pixel": "px", "pixels": "px", "": "px",
    "um": "um", "µm": "um", "μm": "um", "micron": "um", "microns": "um", "micrometer": "um",
    "micrometre": "um", "micrometers": "um", "micrometres": "um", "\\u00b5m": "um", "u": "um",
    "nm": "nm", "nanometer": "nm", "nanometre": "nm", "nanometers": "nm",
    "mm": "mm", "millimeter": "mm", "millimetre": "mm",
    "cm": "cm", "centimeter": "cm", "centimetre": "cm", "m": "m", "meter": "m", "metre": "m",
}
_TIME_ALIASES = {
    "frame": "frame", "frames": "frame", "": "frame",
    "ms": "ms", "millisecond": "ms", "milliseconds": "ms", "msec": "ms",
    "s": "s", "sec": "s", "second": "s", "seconds": "s",
    "min": "min", "minute": "min", "minutes": "min",
    "h": "h", "hr": "h", "hour": "h", "hours": "h",
    "iteration": "iteration", "iterations": "iteration", "step": "iteration", "steps": "iteration",
}
_LENGTH_LABELS = {"um": "µm"}


def _normalize(unit, aliases, name):
    if not isinstance(unit, str):
        raise InputError(f"{name} must be a unit name (str); got {unit!r}")
    key = unit.strip().lower()
    if key not in aliases:
        raise InputError(f"{name} {unit!r} is not a known unit; expected one of {sorted(set(aliases.values()))}")
    return aliases[key]


def normalize_length_unit(unit) -> str:
    """Canonical name of a length unit (``"micron"``, ``"µm"`` -> ``"um"``; ``"pixel"`` -> ``"px"``)."""
    return _normalize(unit, _LENGTH_ALIASES, "length unit")


def normalize_time_unit(unit) -> str:
    """Canonical name of a time unit (``"sec"`` -> ``"s"``, ``"minutes"`` -> ``"min"``, ``"frames"`` -> ``"frame"``)."""
    return _normalize(unit, _TIME_ALIASES, "time unit")


#: Where a calibration's pixel size or frame interval came from (:class:`Calibration`); "sample": the documentation
#: of a bundled sample whose file lacks it (:func:`hexatissue.samples.documented_calibration`).
ORIGINS = ("file", "given", "sample", "none")


@dataclass(frozen=True)
class Calibration:
    """Size of a pixel and time between frames.

    Parameters
    ----------
    pixel_size : float
        Length of one pixel side in ``length_unit``.  Must be 1 when
        ``length_unit`` is ``"px"`` (uncalibrated).
    length_unit : str
        ``"px"`` (uncalibrated) or a physical unit (``"um"``, ``"nm"``, ...;
        common spellings such as ``"micron"`` or ``"µm"`` are accepted).
    frame_interval : float
        Time between consecutive frames in ``time_unit``.  Must be 1 when
        ``time_unit`` is ``"frame"``.
    time_unit : str
        ``"frame"`` (uncalibrated), ``"s"``, ``"min"``, ``"h"``, ``"ms"`` or
        ``"iteration"`` (simulation steps).
    length_from, time_from : str
        Where the pixel size (frame interval) came from: ``"file"`` (the
        file's metadata), ``"given"`` (an argument or flag), ``"sample"``
        (the documentation of a bundled sample whose file lacks it:
        :mod:`hexatissue.samples`) or ``"none"`` (uncalibrated); by default ``"given"`` when calibrated.  Carried into
        ``metadata.json`` and the report; not compared (two calibrations with
        the same values are equal wherever they came from).
    """

    pixel_size: float = 1.0
    length_unit: str = "px"
    frame_interval: float = 1.0
    time_unit: str = "frame"
    length_from: str = field(default="", compare=False)
    time_from: str = field(default="", compare=False)

    def __post_init__(self):
        object.__setattr__(self, "pixel_size", check_positive(self.pixel_size, "pixel_size"))
        object.__setattr__(self, "frame_interval", check_positive(self.frame_interval, "frame_interval"))
        object.__setattr__(self, "length_unit", normalize_length_unit(self.length_unit))
        object.__setattr__(self, "time_unit", normalize_time_unit(self.time_unit))
        if self.length_unit == "px" and self.pixel_size != 1.0:
            raise InputError(f"pixel_size {self.pixel_size!r} needs a physical length_unit (e.g. 'um'); "
                             f"with length_unit 'px' it must be 1")
        if self.time_unit == "frame" and self.frame_interval != 1.0:
            raise InputError(f"frame_interval {self.frame_interval!r} needs a time_unit (e.g. 's', 'min'); "
                             f"with time_unit 'frame' it must be 1")
        for name, calibrated in (("length_from", self.has_length), ("time_from", self.has_time)):
            origin = getattr(self, name) or ("given" if calibrated else "none")
            if origin not in ORIGINS or (origin == "none") == calibrated:
                raise InputError(f"{name} must be one of {ORIGINS} ('none' exactly when uncalibrated); got "
                                 f"{getattr(self, name)!r}")
            object.__setattr__(self, name, origin)

    @property
    def has_length(self) -> bool:
        """True when lengths have a physical unit."""
        return self.length_unit != "px"

    @property
    def has_time(self) -> bool:
        """True when times have a unit other than frames."""
        return self.time_unit != "frame"

    @property
    def length_label(self) -> str:
        """The length unit as printed on figures (``"µm"`` for ``"um"``)."""
        return _LENGTH_LABELS.get(self.length_unit, self.length_unit)

    @property
    def time_label(self) -> str:
        """The time unit as printed on figures (``"frames"`` when uncalibrated, ``"iterations"`` for simulations)."""
        return {"frame": "frames", "iteration": "iterations"}.get(self.time_unit, self.time_unit)

    def length(self, px):
        """A length (or array of lengths) in px converted to ``length_unit``."""
        return px * self.pixel_size

    def area(self, px2):
        """An area in px^2 converted to the square of ``length_unit``."""
        return px2 * self.pixel_size**2

    def time(self, frames):
        """A duration in frames converted to ``time_unit``."""
        return frames * self.frame_interval

    def replace(self, *, pixel_size=None, length_unit=None, frame_interval=None, time_unit=None) -> "Calibration":
        """A copy with the given fields changed (None keeps a field); a changed length (time) is ``"given"``."""
        changes = dict(pixel_size=pixel_size, length_unit=length_unit, frame_interval=frame_interval,
                       time_unit=time_unit)
        changes = {k: v for k, v in changes.items() if v is not None}
        if {"pixel_size", "length_unit"} & set(changes):
            changes["length_from"] = ""  # re-derived: "given", or "none" when it is removed
        if {"frame_interval", "time_unit"} & set(changes):
            changes["time_from"] = ""
        return replace(self, **changes)

    @property
    def origin_text(self) -> str:
        """Where the calibration came from, for reports: e.g. ``"pixel size from the file, frame interval given"``."""
        words = {"file": "from the file's metadata", "given": "given",
                 "sample": "from the bundled sample's documentation", "none": "none"}
        return f"pixel size {words[self.length_from]}, frame interval {words[self.time_from]}"

    def override(self, *, pixel_size=None, length_unit=None, frame_interval=None, time_unit=None,
                 assume_units=False) -> "Calibration":
        """This calibration with a user's values (None keeps a field): the one rule of every override.

        Used by :meth:`hexatissue.Source.with_calibration` (and so
        :func:`hexatissue.open_source`) and by the command line.

        - A ``pixel_size`` (``frame_interval``) with no length (time) unit,
          neither given nor already here, is refused; with
          ``assume_units`` it is in micrometres (minutes) instead, what the
          command line assumes (:func:`override_units`).
        - ``length_unit="px"`` without a ``pixel_size`` removes the length
          calibration (pixel size 1); ``time_unit="frame"`` without a
          ``frame_interval`` the time calibration.

        Raises
        ------
        InputError
            A number with no unit anywhere (without ``assume_units``), or
            an invalid value or unit.
        """
        if assume_units:
            length_unit, time_unit = override_units(self, pixel_size=pixel_size, length_unit=length_unit,
                                                    frame_interval=frame_interval, time_unit=time_unit)
        if pixel_size is not None and length_unit is None and not self.has_length:
            raise InputError(f"pixel_size={pixel_size!r} was given but there is no length unit (the source is "
                             f"uncalibrated); pass length_unit= as well (e.g. 'um')")
        if frame_interval is not None and time_unit is None and not self.has_time:
            raise InputError(f"frame_interval={frame_interval!r} was given but there is no time unit (the source "
                             f"is uncalibrated); pass time_unit= as well (e.g. 's', 'min')")
        if length_unit is not None and pixel_size is None and normalize_length_unit(length_unit) == "px":
            pixel_size = 1.0
        if time_unit is not None and frame_interval is None and normalize_time_unit(time_unit) == "frame":
            frame_interval = 1.0
        return self.replace(pixel_size=pixel_size, length_unit=length_unit, frame_interval=frame_interval,
                            time_unit=time_unit)

    def to_dict(self) -> dict:
        """Plain dict (for ``metadata.json``)."""
        return asdict(self)

    @classmethod
    def from_dict(cls, data) -> "Calibration":
        """Inverse of :meth:`to_dict`; unknown keys raise :class:`InputError`."""
        if not isinstance(data, dict):
            raise InputError(f"calibration must be a dict; got {type(data).__name__}")
        known = {"pixel_size", "length_unit", "frame_interval", "time_unit", "length_from", "time_from"}
        extra = set(data) - known
        if extra:
            raise InputError(f"calibration has unknown field(s) {sorted(extra)}; expected {sorted(known)}")
        return cls(**data)


def override_units(calibration, *, pixel_size=None, length_unit=None, frame_interval=None, time_unit=None):
    """The units of a user's override of ``calibration``: ``(length_unit, time_unit)``.

    A bare pixel size given for an uncalibrated image is in micrometres, a bare frame interval for an
    uncalibrated movie in minutes (what the command line assumes); given units, or the file's own, are kept.
    :meth:`Calibration.override` with ``assume_units=True`` applies them.
    """
    if pixel_size is not None and length_unit is None and not calibration.has_length:
        length_unit = "um"
    if frame_interval is not None and time_unit is None and not calibration.has_time:
        time_unit = "min"
    return length_unit, time_unit


def as_calibration(calibration) -> Calibration:
    """``calibration``, or the uncalibrated :class:`Calibration` (px, frames) when None."""
    if calibration is None:
        return Calibration()
    if not isinstance(calibration, Calibration):
        raise InputError(f"calibration must be a hexatissue.Calibration or None; got {type(calibration).__name__}")
    return calibration


def velocity_unit(calibration=None) -> str:
    """Unit of a velocity in ``calibration``: ``"µm/min"``, or ``"px/frame"`` when uncalibrated."""
    cal = as_calibration(calibration)
    time = cal.time_unit if cal.has_time else "frame"
    return f"{cal.length_label}/{time}"


def in_units(values, calibration=None, length_power=1, time_power=-1):
    """``values`` in px^length_power frame^time_power converted to ``calibration``'s units.

    Velocities are ``(1, -1)`` (px/frame -> µm/min), rates ``(0, -1)``,
    mean squared displacements ``(2, 0)``.
    """
    cal = as_calibration(calibration)
    return np.asarray(values, float) * cal.pixel_size ** length_power * cal.frame_interval ** time_power
