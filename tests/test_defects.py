"""Defect finding, tracking and events against exact synthetic truth."""
import numpy as np
import pandas as pd
import pytest

from hexatissue import Box, InputError
from hexatissue.defects import defect_events, track_defects


def _same_partition(track, truth):
    """Track ids equal the true ids up to a relabelling (a bijection)."""
    pairs = set(zip(track, truth))
    return len(pairs) == len(set(track)) == len(set(truth))


def _table(rows):
    return pd.DataFrame(rows, columns=["frame", "x", "y", "charge", "truth"])


def moving_defects(n_frames=12, box=Box(40.0, 30.0)):
    """Four defects on straight lines, two of them crossing the periodic boundary."""
    start = np.array([[38.0, 5.0], [10.0, 28.5], [20.0, 15.0], [5.0, 15.0]])
    velocity = np.array([[1.0, 0.3], [-0.4, 0.9], [0.0, -0.7], [0.8, 0.0]])
    charge = np.array([1, -1, 1, -1]) / 6
    rows = []
    for f in range(n_frames):
        xy = box.wrap(start + f * velocity)
        rows += [(f, *xy[k], charge[k], k) for k in range(4)]
    return _table(rows)


def test_tracks_follow_straight_lines_across_the_periodic_boundary():
    box = Box(40.0, 30.0)
    table = moving_defects(box=box)
    tracked = track_defects(table.drop(columns="truth"), max_distance=2.0, box=box)
    assert list(tracked.columns) == ["frame", "x", "y", "charge", "track"]
    assert tracked["track"].dtype == np.int64
    assert tracked["track"].nunique() == 4
    assert _same_partition(tracked["track"], table["truth"])
    # Without minimum-image distances the wrapped defects start new tracks.
    open_tracks = track_defects(table, max_distance=2.0, box=None)
    assert open_tracks["track"].nunique() > 4


def test_same_charge_only_when_opposite_charges_cross():
    # +1/6 moving right and -1/6 moving left swap places; nearest-neighbour
    # linking ignoring charge would swap their identities.
    rows = []
    for f in range(6):
        rows += [(f, 10 + 2.0 * f, 10.0, 1 / 6, 0), (f, 20 - 2.0 * f, 10.6, -1 / 6, 1)]
    table = _table(rows)
    tracked = track_defects(table, max_distance=3.0)
    assert _same_partition(tracked["track"], table["truth"])


def test_optimal_assignment_beats_greedy():
    # Greedy nearest-neighbour would link a->B (distance 1) leaving b->A at 6;
    # the optimum links a->A (2) and b->B (3).
    table = _table([
        (0, 0.0, 0.0, 1 / 6, 0), (0, 4.0, 0.0, 1 / 6, 1),
        (1, -2.0, 0.0, 1 / 6, 0), (1, 1.0, 0.0, 1 / 6, 1),
    ])
    tracked = track_defects(table, max_distance=6.0)
    assert _same_partition(tracked["track"], table["truth"])


def pair_movie():
    """A +- pair created at frame 3, separating, re-approaching and annihilating after frame 8,
    plus a far-away isolated +1/6 defect present throughout (on a 50 x 50 torus)."""
    rows = []
    for f in range(12):
        rows.append((f, 45.0, 45.0 + 0.2 * f, 1 / 6, 0))
        if 3 <= f <= 8:
            half = 1.0 + 0.5 * min(f - 3, 8 - f)  # 1.0, 1.5, 2.0, 2.0, 1.5, 1.0
            # centred on x = 0: the pair straddles the periodic boundary
            rows.append((f, (0.0 + half) % 50, 20.0, 1 / 6, 1))
            rows.append((f, (0.0 - half) % 50, 20.0, -1 / 6, 2))
    return _table(rows)


def test_pair_creation_and_annihilation_events():
    box = Box(50.0, 50.0)
    table = pair_movie()
    tracked = track_defects(table.drop(columns="truth"), max_distance=1.5, box=box)
    assert _same_partition(tracked["track"], table["truth"])
    events = defect_events(tracked, pair_distance=3.0, box=box)
    assert list(events["kind"]) == ["creation", "annihilation"]
    assert list(events["frame"]) == [3, 8]
    # midpoint across the boundary is x = 0, not x = 25
    np.testing.assert_allclose(events["x"].to_numpy() % 50, 0.0, atol=1e-12)
    np.testing.assert_allclose(events["y"], 20.0)
    np.testing.assert_allclose(events["separation"], 2.0)
    plus = tracked.loc[table["truth"] == 1, "track"].iloc[0]
    minus = tracked.loc[table["truth"] == 2, "track"].iloc[0]
    assert (events["track_plus"] == plus).all() and (events["track_minus"] == minus).all()


def test_unpaired_births_and_deaths():
    # a single +1/6 enters an open image at frame 2 and leaves after frame 4
    rows = [(f, 5.0, 5.0, -1 / 6, 0) for f in range(7)]
    rows += [(f, 30.0 + f, 5.0, 1 / 6, 1) for f in range(2, 5)]
    tracked = track_defects(_table(rows), max_distance=2.0)
    assert defect_events(tracked, pair_distance=5.0).empty
    events = defect_events(tracked, pair_distance=5.0, include_unpaired=True)
    assert list(events["kind"]) == ["appearance", "disappearance"]
    assert list(events["frame"]) == [2, 4]
    assert (events["track_minus"] == -1).all() and events["separation"].isna().all()


def test_far_jump_and_gap_frames_break_tracks():
    rows = [(0, 0.0, 0.0, 1 / 6, 0), (1, 0.5, 0.0, 1 / 6, 0), (2, 10.0, 0.0, 1 / 6, 1), (5, 10.5, 0.0, 1 / 6, 1)]
    tracked = track_defects(_table(rows), max_distance=2.0)
    assert list(tracked["track"]) == [0, 0, 1, 1]
    # with the full list of frames, the empty frames 3-4 end the track
    tracked = track_defects(_table(rows), max_distance=2.0, frames=range(6))
    assert list(tracked["track"]) == [0, 0, 1, 2]


def test_time_column_and_row_order_preserved():
    table = moving_defects().rename(columns={"frame": "t"}).sample(frac=1.0, random_state=3)
    tracked = track_defects(table, max_distance=2.0, box=Box(40.0, 30.0), time_column="t")
    assert tracked.index.equals(table.index)
    assert _same_partition(tracked["track"], table["truth"])


def test_tracking_bad_input():
    table = moving_defects()
    with pytest.raises(InputError, match="max_distance"):
        track_defects(table, max_distance=0)
    with pytest.raises(InputError, match="charge"):
        track_defects(table.drop(columns="charge"), max_distance=1)
    with pytest.raises(InputError, match="box"):
        track_defects(table, max_distance=1, box=(40, 30))
    with pytest.raises(InputError, match="frames"):
        track_defects(table, max_distance=1, frames=[0, 1])
    with pytest.raises(InputError, match="pair_distance"):
        defect_events(track_defects(table, 2.0), pair_distance=-1)
    with pytest.raises(InputError, match="frames"):
        defect_events(track_defects(table, 2.0), pair_distance=1.0, frames=[])


def test_empty_tables():
    empty = pd.DataFrame({"frame": pd.Series(dtype=np.int64), "x": [], "y": [], "charge": []})
    tracked = track_defects(empty, max_distance=1.0)
    assert len(tracked) == 0 and "track" in tracked
    assert defect_events(tracked, 1.0).empty


# ---------------------------------------------------------------------------- winding numbers and density

from hexatissue.defects import defect_density, defects_from_field, plaquette_charges  # noqa: E402


@pytest.mark.parametrize("p", [1, 2, 6])
@pytest.mark.parametrize("k", [-1, 1])  # |k| >= 2 needs steps >= pi/p: unresolvable on one plaquette
def test_plaquette_charges_of_a_vortex(p, k):
    # theta = k phi / p around (x, y) = (10.3, 7.6): charge k/p in the plaquette holding the core
    y, x = np.mgrid[0:16, 0:22].astype(float)
    field = np.exp(1j * k * np.arctan2(y - 7.6, x - 10.3))
    charges = plaquette_charges(field, p)
    assert charges.shape == (15, 21)
    assert charges[7, 10] == pytest.approx(k / p)
    assert np.count_nonzero(charges) == 1
    table = defects_from_field(field, p)
    assert (table["x"].iloc[0], table["y"].iloc[0]) == (10.5, 7.5)


def test_plaquette_charges_sum_to_zero_on_a_torus():
    rng = np.random.default_rng(2)
    field = rng.normal(size=(12, 17)) + 1j * rng.normal(size=(12, 17))
    charges = plaquette_charges(field, 6, periodic=True)
    assert np.count_nonzero(charges) > 10 and charges.sum() == pytest.approx(0.0, abs=1e-12)


def test_defect_density_counts_per_bin_and_frame():
    box = Box(40.0, 20.0)
    table = pd.DataFrame({
        "frame": [0, 0, 0, 2, 2],
        "x": [1.0, 2.0, 39.0, 41.0, 15.0],  # 41 wraps to 1
        "y": [1.0, 3.0, 19.0, 2.0, 15.0],
        "charge": [1 / 6, -1 / 6, 1 / 6, -1 / 6, 1 / 6],
    })
    dens = defect_density(table, box, bin_size=10.0, frames=[0, 1, 2])
    assert len(dens) == 3 * 2 * 4
    assert list(dens.columns) == ["frame", "row", "col", "x", "y", "n_plus", "n_minus", "density", "charge_density"]
    one = dens.set_index(["frame", "row", "col"])
    assert (one.loc[(0, 0, 0), "n_plus"], one.loc[(0, 0, 0), "n_minus"]) == (1, 1)
    assert one.loc[(0, 1, 3), "n_plus"] == 1
    assert one.loc[(2, 0, 0), "n_minus"] == 1 and one.loc[(2, 1, 1), "n_plus"] == 1
    assert one.loc[1, "density"].sum() == 0
    assert one.loc[(0, 0, 0), "density"] == pytest.approx(2 / 100)
    assert one.loc[(0, 0, 0), "charge_density"] == pytest.approx(0.0)
    # number of defects is conserved: sum(density * bin area) = rows
    assert (dens["density"] * 100).sum() == pytest.approx(len(table))
    # bin centres
    assert one.loc[(0, 1, 3), "x"] == 35.0 and one.loc[(0, 1, 3), "y"] == 15.0


def test_defect_density_on_an_image_shape_without_frames():
    table = pd.DataFrame({"x": [-0.4, 99.4, 50.0], "y": [0.0, 59.0, 200.0], "charge": [0.5, -0.5, 0.5]})
    dens = defect_density(table, (60, 100), bin_size=50.0)
    assert "frame" not in dens.columns and len(dens) == 2  # round(60 / 50) = 1 row, 2 columns
    assert dens["n_plus"].tolist() == [1, 0] and dens["n_minus"].tolist() == [0, 1]  # y = 200 is outside
    with pytest.raises(InputError, match="bin_size"):
        defect_density(table, (60, 100), bin_size=0)
    with pytest.raises(InputError, match="extent"):
        defect_density(table, (60,), bin_size=5)


def _track_ends_reference(tracked, time_column, first):
    """The former pandas code of ``defects._track_ends``: a stably sorted copy and a groupby."""
    groups = tracked.sort_values([time_column], kind="stable").groupby("track")
    return groups.head(1) if first else groups.tail(1)


@pytest.mark.parametrize("seed", range(4))
def test_track_ends_match_the_groupby_reference(seed):
    """First and last rows of each track, rows and index as the sorted groupby gives, rows in any order."""
    from hexatissue.defects import _track_ends

    rng = np.random.default_rng(seed)
    n = 300
    tracked = pd.DataFrame({"frame": rng.integers(0, 12, n), "x": rng.random(n), "y": rng.random(n),
                            "charge": rng.choice([-1 / 6, 1 / 6], n), "track": rng.integers(0, 40, n)},
                           index=rng.permutation(n) + 7)
    for first in (True, False):
        pd.testing.assert_frame_equal(_track_ends(tracked, "frame", first),
                                      _track_ends_reference(tracked, "frame", first))
    empty = tracked.iloc[:0]
    pd.testing.assert_frame_equal(_track_ends(empty, "frame", True), _track_ends_reference(empty, "frame", True))
