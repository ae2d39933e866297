"""Calibration: canonical unit names, conversions, validation, JSON round trip."""
import numpy as np
import pytest

from hexatissue import Calibration, InputError
from hexatissue.units import as_calibration, normalize_length_unit, normalize_time_unit, override_units


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


def test_override_is_the_one_rule_of_source_and_command_line_overrides():
    plain, file_cal = Calibration(), Calibration(0.2, "nm", 3.0, "s")
    with pytest.raises(InputError, match=r"^pixel_size=0.5 was given but there is no length unit \(the source is "
                                         r"uncalibrated\); pass length_unit= as well \(e.g. 'um'\)$"):
        plain.override(pixel_size=0.5)
    with pytest.raises(InputError, match=r"^frame_interval=3 was given but there is no time unit \(the source is "
                                         r"uncalibrated\); pass time_unit= as well \(e.g. 's', 'min'\)$"):
        plain.override(frame_interval=3)
    assert plain.override(pixel_size=0.5, length_unit="micron") == Calibration(0.5, "um")
    assert file_cal.override(pixel_size=0.5, frame_interval=2.0) == Calibration(0.5, "nm", 2.0, "s")  # file's units
    assert file_cal.override(length_unit="px", time_unit="frames") == plain  # "px" / "frame" alone drop them
    assert file_cal.override(length_unit="um") == Calibration(0.2, "um", 3.0, "s")
    assert file_cal.override() == file_cal
    with pytest.raises(InputError, match="needs a physical length_unit"):
        file_cal.override(pixel_size=0.5, length_unit="px")
    # the command line's: bare numbers of an uncalibrated movie in um and min, the file's units kept otherwise
    assert plain.override(pixel_size=0.5, frame_interval=2.0, assume_units=True) == Calibration(0.5, "um", 2.0, "min")
    assert file_cal.override(pixel_size=0.5, assume_units=True) == Calibration(0.5, "nm", 3.0, "s")
    assert file_cal.override(length_unit="px", assume_units=True) == Calibration(1.0, "px", 3.0, "s")
    for kwargs in ({"pixel_size": 0.5}, {"frame_interval": 2.0}, {"pixel_size": 0.5, "length_unit": "nm"}, {}):
        units = override_units(plain, **kwargs)
        assert plain.override(**kwargs, assume_units=True) == plain.override(
            **{**kwargs, "length_unit": units[0], "time_unit": units[1]})


def test_calibration_says_where_it_came_from(tmp_path):
    import tifffile

    from hexatissue import InputError, open_source
    from hexatissue.units import Calibration

    assert Calibration().length_from == Calibration().time_from == "none"
    given = Calibration(pixel_size=0.2, length_unit="um")
    assert (given.length_from, given.time_from) == ("given", "none")
    assert Calibration.from_dict(given.to_dict()).length_from == "given"
    assert Calibration.from_dict({"pixel_size": 0.2, "length_unit": "um"}) == given  # metadata of older versions
    assert Calibration(pixel_size=0.2, length_unit="um", length_from="file") == given  # values compared, not origin
    with pytest.raises(InputError, match="length_from"):
        Calibration(length_from="file")  # uncalibrated cannot come from a file
    labels = np.kron(np.arange(1, 10).reshape(3, 3), np.ones((6, 6))).astype(np.uint16)
    tifffile.imwrite(tmp_path / "a.ome.tif", labels, ome=True,
                     metadata={"axes": "YX", "PhysicalSizeX": 0.25, "PhysicalSizeY": 0.25, "PhysicalSizeXUnit": "µm"})
    source = open_source(tmp_path / "a.ome.tif")
    assert source.calibration.length_from == "file" and source.calibration.pixel_size == 0.25
    overridden = source.with_calibration(pixel_size=0.3)
    assert overridden.calibration.length_from == "given"
    assert overridden.calibration.origin_text == "pixel size given, frame interval none"


def test_a_placeholder_pixel_size_of_exactly_one_is_flagged(tmp_path):
    """PartSeg writes PhysicalSizeX=1 by default: cells of 469 µm^2 and a 50 µm scale bar, trusted silently before."""
    import tifffile

    from hexatissue import HexatissueWarning, analyze, open_source
    from hexatissue.workflows.report import report

    labels = np.kron(np.arange(1, 26).reshape(5, 5), np.ones((8, 8))).astype(np.uint16)
    tifffile.imwrite(tmp_path / "p.ome.tif", labels, ome=True,
                     metadata={"axes": "YX", "PhysicalSizeX": 1, "PhysicalSizeY": 1, "PhysicalSizeXUnit": "µm"})
    with pytest.warns(HexatissueWarning, match="pixel size of exactly 1 um.*--pixel-size"):
        source = open_source(tmp_path / "p.ome.tif")
    assert any("placeholder" in note for note in source.description["notes"])
    movie = analyze(source)
    movie.write(tmp_path / "r")
    report(tmp_path / "r", tmp_path / "rep")
    text = (tmp_path / "rep" / "report.md").read_text()
    assert "calibration: pixel size from the file's metadata, frame interval none" in text
    # 64 µm^2 cells: in the range of epithelial cells, no alarm; at 100 µm/px they would not be
    assert "check the pixel size" not in text
    big = analyze(source.with_calibration(pixel_size=100.0))
    big.write(tmp_path / "r2")
    report(tmp_path / "r2", tmp_path / "rep2")
    assert "check the pixel size" in (tmp_path / "rep2" / "report.md").read_text()
