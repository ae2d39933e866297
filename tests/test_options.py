"""Options objects: defaults equal the stage functions' keywords, validation names the field, JSON round trip."""
import dataclasses
import inspect

import pytest

from hexatissue import EventOptions, InputError, MeshOptions, OrderOptions, TrackOptions, detect_t1, mesh_from_labels
from hexatissue.options import OPTION_CLASSES


def test_field_names_and_defaults_match_the_stage_functions():
    mesh = inspect.signature(mesh_from_labels).parameters
    for f in dataclasses.fields(MeshOptions):
        assert mesh[f.name].default == getattr(MeshOptions(), f.name), f.name
    events = inspect.signature(detect_t1).parameters
    assert EventOptions().min_length == events["min_length"].default
    assert EventOptions().censor == events["censor"].default


@pytest.mark.parametrize("cls", list(OPTION_CLASSES.values()))
def test_round_trip_through_dicts(cls):
    opts = cls()
    assert cls.from_dict(opts.to_dict()) == opts
    with pytest.raises(InputError, match="has no field"):
        cls.from_dict({"nonsense": 1})


@pytest.mark.parametrize("build, field", [
    (lambda: MeshOptions(kind="cellpose"), "MeshOptions.kind"),
    (lambda: MeshOptions(merge_distance=-1), "MeshOptions.merge_distance"),
    (lambda: MeshOptions(merge_distance="2"), "MeshOptions.merge_distance"),
    (lambda: MeshOptions(membrane_width=1.5), "MeshOptions.membrane_width"),
    (lambda: OrderOptions(p=(6, 6)), "OrderOptions.p"),
    (lambda: OrderOptions(p=1.5), "OrderOptions.p"),
    (lambda: OrderOptions(p=True), "OrderOptions.p"),
    (lambda: OrderOptions(p=None), "OrderOptions.p"),
    (lambda: OrderOptions(center="middle"), "OrderOptions.center"),
    (lambda: OrderOptions(radius=0), "OrderOptions.radius"),
    (lambda: OrderOptions(min_coverage=1.5), "OrderOptions.min_coverage"),
    (lambda: TrackOptions(min_iou=0), "TrackOptions.min_iou"),
    (lambda: TrackOptions(max_gap=-1), "TrackOptions.max_gap"),
    (lambda: TrackOptions(mode="yes"), "TrackOptions.mode"),
    (lambda: TrackOptions(mode=True), "TrackOptions.mode"),
    (lambda: TrackOptions(division_min_frames=2.5), "TrackOptions.division_min_frames"),
    (lambda: TrackOptions(division_min_cycle=-1), "TrackOptions.division_min_cycle"),
    (lambda: TrackOptions(division_area_tolerance=float("inf")), "TrackOptions.division_area_tolerance"),
    (lambda: EventOptions(censor=2.5), "EventOptions.censor"),
    (lambda: EventOptions(min_length=float("nan")), "EventOptions.min_length"),
])
def test_an_invalid_field_is_named(build, field):
    with pytest.raises(InputError, match=field.replace(".", r"\.")):
        build()


def test_options_are_frozen_and_normalised():
    opts = OrderOptions(p=[2, 6], radius=10)
    assert opts.p == (2, 6) and isinstance(opts.radius, float)
    with pytest.raises(AttributeError):
        opts.p = (6,)
    assert opts.replace(center="area_centroid").center == "area_centroid"


def test_division_rules_and_merge_distance_are_flags():
    """Issue 29: the division plausibility options and merge_distance are set from the command line."""
    import argparse

    from hexatissue.options import MeshOptions, add_flags, from_flags

    parser = argparse.ArgumentParser()
    add_flags(parser, TrackOptions)
    add_flags(parser, MeshOptions, prefix="mesh_")
    args = parser.parse_args(["--division-min-frames", "4", "--division-min-cycle", "20",
                              "--division-area-tolerance", "0.25", "--merge-distance", "3"])
    track = from_flags(args, TrackOptions)
    assert (track.division_min_frames, track.division_min_cycle, track.division_area_tolerance) == (4, 20, 0.25)
    assert from_flags(args, MeshOptions, prefix="mesh_").merge_distance == 3.0
    assert from_flags(parser.parse_args([]), TrackOptions) == TrackOptions()
