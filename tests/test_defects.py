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


# ---------------------------------------------------------------------------- a movie linked chunk by chunk

def _scripted_movie():
    """Ten frames of p = 6 and p = 2 defects (open image, links and pairs within 3 px), with the truth.

    p = 6: A (+1/6, moving 1 px a frame) and B (-1/6, still) in every frame
    but frame 6, which holds no defect at all (so A and B end at 5 and
    start again at 7); a pair C created at frame 3 and annihilated at frame
    5.  p = 2: a pair D present from frame 0 and annihilated at frame 2; no
    p = 2 defect in frames 3-7; a pair E created at frame 8, alive at the
    last frame.  Rows of a frame by p as the order stage lists them (6, then
    2), ids from 0 per frame and p.
    """
    rows = []  # frame, p, x, y, charge, truth track
    for t in range(10):
        if t == 6:
            continue
        rows += [(t, 6, 5.0 + t, 5.0, 1 / 6, 0 if t < 6 else 4), (t, 6, 30.0, 30.0, -1 / 6, 1 if t < 6 else 5)]
        if 3 <= t <= 5:
            half = 1.5 if t == 4 else 1.0
            rows += [(t, 6, 20.0 - half, 12.0, 1 / 6, 2), (t, 6, 20.0 + half, 12.0, -1 / 6, 3)]
        if t <= 2:
            rows += [(t, 2, 9.0, 20.0, 0.5, 0), (t, 2, 11.0, 20.0, -0.5, 1)]
        if t >= 8:
            rows += [(t, 2, 30.0, 40.0, 0.5, 2), (t, 2, 32.0, 40.0, -0.5, 3)]
    table = pd.DataFrame(rows, columns=["frame", "p", "x", "y", "charge", "truth"])
    table["defect"] = table.groupby(["frame", "p"]).cumcount().astype(np.int64)
    table = table[["frame", "defect", "x", "y", "charge", "p", "truth"]]
    events = pd.DataFrame({"frame": [3, 5, 2, 8], "kind": ["creation", "annihilation", "annihilation", "creation"],
                           "x": [20.0, 20.0, 10.0, 31.0], "y": [12.0, 12.0, 20.0, 40.0],
                           "track_plus": [2, 2, 0, 2], "track_minus": [3, 3, 1, 3], "separation": [2.0] * 4,
                           "p": [6, 6, 2, 2]})
    return table, events


def _chunked(defects, cuts, orders, max_distance, box, linked=True):
    """The defects linked by one MovieDefects over the chunks of frames ``cuts[k]`` to ``cuts[k + 1] - 1``."""
    from hexatissue.defects import MovieDefects

    linker = MovieDefects(orders, max_distance, box, linked)
    frame = defects["frame"].to_numpy()
    parts = [linker.link(defects[(frame >= lo) & (frame < hi)].reset_index(drop=True), lo, hi - 1)
             for lo, hi in zip(cuts[:-1], cuts[1:])]
    return pd.concat(parts, ignore_index=True), linker.events()


@pytest.mark.parametrize("cuts", [[0, 3, 6, 7, 10], [0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10], [0, 5, 10], [0, 10],
                                  [0, 2, 4, 6, 8, 10], [0, 3, 9, 10]])
def test_a_movie_linked_chunk_by_chunk_gives_the_true_tracks_and_pair_events(cuts):
    """Tracks crossing chunk borders, pairs created at a chunk's first frame and annihilated at a chunk's last, a
    chunk without defects, two p: the true tracks (numbered from 0 per p) and events, whatever the chunks."""
    from hexatissue.defects import link_movie_defects

    table, truth = _scripted_movie()
    tracked, events = _chunked(table.drop(columns="truth"), np.array(cuts), (6, 2), 3.0, None)
    expected = table.sort_values(["frame", "p", "defect"], kind="stable").reset_index(drop=True)
    assert list(tracked.columns) == ["frame", "defect", "x", "y", "charge", "p", "track"]
    pd.testing.assert_frame_equal(tracked.drop(columns="track"), expected.drop(columns=["truth"]))
    assert tracked["track"].tolist() == expected["truth"].tolist()
    assert events["kind"].tolist() == truth["kind"].tolist()
    pd.testing.assert_frame_equal(events.drop(columns="kind"), truth.drop(columns="kind"))
    whole = {"defects": table.drop(columns="truth"), "grid": pd.DataFrame({"spacing": [2.0]})}
    link_movie_defects(whole, (6, 2), 3.0, None, 10)
    pd.testing.assert_frame_equal(tracked, whole["defects"])
    pd.testing.assert_frame_equal(events, whole["defect_events"])


def _random_defect_movie(rng, n_frames, size):
    """Defects of p = 6 and 2 wandering, vanishing, created in close +- pairs, some frames without one p."""
    rows = []
    for q in (6, 2):
        xy = rng.uniform(0, size, (rng.integers(0, 10), 2))
        charge = rng.choice([1 / q, -1 / q], len(xy))
        for t in range(n_frames):
            xy = (xy + rng.normal(0, 1.0, xy.shape)) % size
            kept = rng.random(len(xy)) > 0.15
            born = rng.uniform(0, size, (rng.integers(0, 3), 2))
            xy = np.concatenate([xy[kept], born, (born + rng.normal(0, 0.5, born.shape)) % size])
            charge = np.concatenate([charge[kept], np.full(len(born), 1 / q), np.full(len(born), -1 / q)])
            if rng.random() > 0.1:  # else a frame without defects of this p
                rows += [(t, q, x, y, c) for (x, y), c in zip(xy[rng.permutation(len(xy))], charge)]
    table = pd.DataFrame(rows, columns=["frame", "p", "x", "y", "charge"])
    table = table.sort_values("frame", kind="stable").reset_index(drop=True)
    table.insert(1, "defect", table.groupby(["frame", "p"]).cumcount().astype(np.int64))
    return table[["frame", "defect", "x", "y", "charge", "p"]]


def _whole_movie_reference(defects, orders, max_distance, box, n_frames, linked):
    """Each p's defects of the whole movie through track_defects and defect_events (every frame alone when not
    linked: each defect its own track, numbered in frame then row order, and no events)."""
    from hexatissue.schema import validate

    p = defects["p"].to_numpy()
    track, events = np.zeros(len(defects), np.int64), []
    for q in orders:
        rows = np.flatnonzero(p == q)
        of_p = defects.iloc[rows][["frame", "x", "y", "charge"]].reset_index(drop=True)
        if linked:
            tracked = track_defects(of_p, max_distance, box=box, frames=range(n_frames))
            track[rows] = tracked["track"].to_numpy()
        else:
            tracked = of_p.assign(track=0).iloc[:0]
            track[rows[np.argsort(of_p["frame"].to_numpy(), kind="stable")]] = np.arange(len(rows))
        events.append(defect_events(tracked, max_distance, box=box, frames=range(n_frames)).assign(p=np.int64(q)))
    order = np.lexsort((defects["defect"].to_numpy(), p, defects["frame"].to_numpy()))
    order = order[np.isin(p[order], orders)]
    tracked = defects.iloc[order].reset_index(drop=True).assign(track=track[order])
    events = pd.concat(events, ignore_index=True).astype({"frame": np.int64})
    return validate(tracked, "defects"), validate(events, "defect_events")


@pytest.mark.parametrize("seed", range(4))
def test_chunked_linking_equals_the_whole_movies_on_random_movies(seed, monkeypatch):
    from hexatissue.defects.pairs import PairEvents

    rng = np.random.default_rng(seed)
    n_frames = int(rng.integers(2, 16))
    box = Box(40.0, 40.0) if seed % 2 else None
    defects = _random_defect_movie(rng, n_frames, 40.0)
    n_events = 0
    for linked in (True, False):
        expected = _whole_movie_reference(defects, (6, 2), 2.5, box, n_frames, linked)
        n_events += len(expected[1])
        for _ in range(2):
            cuts = np.unique(np.r_[0, rng.integers(1, n_frames, rng.integers(0, n_frames)), n_frames])
            with monkeypatch.context() as patch:
                if seed % 2:  # the events of a few frames merged into blocks, as a long movie's are
                    patch.setattr(PairEvents, "MERGE_PARTS", 3)
                tracked, events = _chunked(defects, cuts, (6, 2), 2.5, box, linked)
            pd.testing.assert_frame_equal(tracked, expected[0])
            pd.testing.assert_frame_equal(events, expected[1])
    assert n_events > 0 and expected[1].empty  # events when linked; none when every frame is alone


def test_default_max_distance_is_the_median_spacing_of_the_movie():
    """From each chunk's value counts: the median of the whole column, bit for bit (odd, even, repeated, infinite,
    NaN values), times 1.5; 1 px without a grid."""
    from hexatissue.defects import DEFECT_SPACINGS, default_max_distance, link_movie_defects
    from hexatissue.defects.movie import median_of_counts

    rng = np.random.default_rng(5)
    for n in (1, 2, 3, 4, 7, 10, 101, 1000):
        for values in (rng.normal(20, 3, n), rng.choice([0.1, 0.2, 0.3, 1e300], n), rng.integers(0, 4, n) / 3,
                       np.where(rng.random(n) < 0.2, np.inf, rng.random(n))):
            median = np.median(values)
            assert median_of_counts(*np.unique(values, return_counts=True)) == median
            chunks = np.array_split(values, np.sort(rng.integers(0, n, 3)))
            counted = [np.unique(chunk, return_counts=True) for chunk in chunks]
            got = default_max_distance(np.concatenate([v for v, _ in counted]), np.concatenate([c for _, c in counted]))
            assert got == DEFECT_SPACINGS * float(median)
    assert np.isnan(median_of_counts(*np.unique([1.0, np.nan, 2.0], return_counts=True)))
    assert median_of_counts([1.0, 2.0, 3.0], [0, 2, 0]) == 2.0
    assert default_max_distance([], []) == 1.0
    with pytest.raises(InputError, match="counts"):
        median_of_counts([1.0], [0])
    table, _ = _scripted_movie()
    tables = {"defects": table.drop(columns="truth"), "grid": pd.DataFrame({"spacing": [1.0, 3.0, 2.0, 2.0]})}
    link_movie_defects(tables, (6, 2), None, None, 10)  # 1.5 x 2 px: the scripted links and pairs are within 3 px
    assert tables["defects"]["track"].tolist() == table.sort_values(["frame", "p", "defect"])["truth"].tolist()


def test_chunked_linking_refuses_frames_out_of_order():
    from hexatissue.defects import DefectLinker, MovieDefects

    linker = DefectLinker(2.0)
    assert linker.link([0, 0, 1], [[0.0, 0.0], [5.0, 0.0], [1.0, 0.0]], [0.5, 0.5, 0.5]).tolist() == [0, 1, 0]
    assert linker.n_tracks == 2 and linker.last_frame == 1
    with pytest.raises(InputError, match="follow"):
        linker.link([1], [[1.0, 0.0]], [0.5])
    with pytest.raises(InputError, match="one entry per defect"):
        linker.link([2, 3], [[1.0, 0.0]], [0.5])
    table, _ = _scripted_movie()
    defects = table.drop(columns="truth")
    movie = MovieDefects((6, 2), 3.0)
    with pytest.raises(InputError, match="holds defects of frames 0 to 9"):
        movie.link(defects.copy(), 0, 4)
    movie.link(defects[defects["frame"] <= 4].reset_index(drop=True), 0, 4)
    with pytest.raises(InputError, match="must start at frame 5"):
        movie.link(defects[defects["frame"] >= 6].reset_index(drop=True), 6, 9)
