"""Calibration: canonical unit names, conversions, validation, JSON round trip."""
import numpy as np
import pytest

from hexatissue import Calibration, InputError
from hexatissue.units import as_calibration, normalize_length_unit, normalize_time_unit


@pytest.mark.parametrize("name", ["um", "µm", "μm", "micron", "Microns", "micrometre", "\\u00B5m"])
def test_micrometre_spellings(name):
    assert normalize_length_unit(name) == "um"


def test_time_spellings():
    assert [normalize_time_unit(u) for u in ("sec", "minutes", "h", "frames", "steps")] == \
        ["s", "min", "h", "frame", "iteration"]


def test_conversions_and_labels():
    cal = Calibration(0.2, "micron", 5.0, "minutes")
    assert cal.length_unit == "um" and cal.length_label == "µm" and cal.time_label == "min"
    assert cal.length(10.0) == pytest.approx(2.0) and cal.area(100.0) == pytest.approx(4.0)
    np.testing.assert_allclose(cal.time(np.array([1, 4])), [5.0, 20.0])
    assert cal.has_length and cal.has_time
    plain = Calibration()
    assert not plain.has_length and plain.length_label == "px" and plain.time_label == "frames"
    assert Calibration.from_dict(cal.to_dict()) == cal
    assert cal.replace(pixel_size=0.4) == Calibration(0.4, "um", 5.0, "min")


@pytest.mark.parametrize("kwargs, message", [
    ({"pixel_size": -1.0}, "pixel_size"),
    ({"pixel_size": float("nan")}, "pixel_size"),
    ({"pixel_size": 0.2}, "needs a physical length_unit"),
    ({"frame_interval": 3.0}, "needs a time_unit"),
    ({"length_unit": "furlong"}, "not a known unit"),
    ({"time_unit": 5}, "must be a unit name"),
])
def test_bad_calibrations(kwargs, message):
    with pytest.raises(InputError, match=message):
        Calibration(**kwargs)


def test_as_calibration_and_from_dict_errors():
    assert as_calibration(None) == Calibration()
    with pytest.raises(InputError, match="Calibration or None"):
        as_calibration(0.2)
    with pytest.raises(InputError, match="unknown field"):
        Calibration.from_dict({"pixel_size": 1.0, "colour": "red"})


def test_override_units_assumes_micrometres_and_minutes_only_when_uncalibrated():
    from hexatissue.units import override_units

    plain, file_cal = Calibration(), Calibration(0.2, "nm", 3.0, "s")
    assert override_units(plain, pixel_size=0.5, frame_interval=2.0) == ("um", "min")
    assert override_units(file_cal, pixel_size=0.5, frame_interval=2.0) == (None, None)  # keep the file's units
    assert override_units(plain, pixel_size=0.5, length_unit="nm") == ("nm", None)
    assert override_units(plain) == (None, None)
