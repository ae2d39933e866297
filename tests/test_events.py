"""T1 detection and classification against exact Voronoi truth and hand-made networks."""
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from hexatissue.errors import InputError
from hexatissue.events import (cell_event_stats, classify_t1, neighbour_events, track_contacts, detect_t1, find_t1,
                               intercalation_intervals, t1_tables)
from hexatissue.synthetic import movie_contacts, t1_movie, voronoi_movie

KEY = ["kind", "frame_start", "frame_end", "duration", "cell_a", "cell_b", "cell_c", "cell_d", "frame_gain"]


@pytest.fixture(scope="module", params=[True, False], ids=["periodic", "open"])
def movie(request):
    return t1_movie(periodic=request.param, seed=1)


def test_truth_contains_every_kind(movie):
    kinds = movie.events["kind"].tolist()
    assert kinds.count("cycle") == 2 and kinds.count("intercalation") == 2 and kinds.count("unresolved") == 1
    fourfold = movie.events[movie.events["frame_gain"] > movie.events["frame_start"]]
    assert (fourfold["frame_gain"] - fourfold["frame_start"]).min() >= 3  # a persistent four-fold vertex


def test_events_equal_exact_voronoi_truth(movie):
    ev = detect_t1(movie.edges, movie.cells, min_length=movie.min_length, censor=movie.censor, box=movie.box)
    pd.testing.assert_frame_equal(ev[KEY].astype({"kind": object}), movie.events[KEY].astype({"kind": object}))
    np.testing.assert_allclose(ev[["x", "y"]], movie.events[["x", "y"]], atol=1e-9)
    assert ev["event"].tolist() == list(range(len(ev)))


def test_raw_network_without_zero_ridges_gives_same_events(movie):
    edges = movie.edges[movie.edges["length"] > 1e-6]
    ev = detect_t1(edges, movie.cells, min_length=0.0, censor=movie.censor, box=movie.box)
    assert ev[KEY[:-1]].astype(str).equals(movie.events[KEY[:-1]].astype(str))


def test_censor_window(movie):
    late = movie.events[movie.events["kind"] == "unresolved"]
    n_last = int(movie.cells["frame"].max()) - int(late["frame_start"].iloc[0])
    ev = detect_t1(movie.edges, movie.cells, min_length=movie.min_length, censor=n_last, box=movie.box)
    assert (ev["kind"] == "unresolved").sum() == 0 and (ev["kind"] == "intercalation").sum() == 3
    ev = detect_t1(movie.edges, movie.cells, min_length=movie.min_length, censor=100, box=movie.box)
    assert (ev["kind"] == "intercalation").sum() == 0 and (ev["kind"] == "cycle").sum() == 2


def test_permuted_track_ids_give_permuted_events(movie):
    rng = np.random.default_rng(4)
    perm = rng.permutation(np.arange(1, 2000))[: movie.cells["cell"].max() + 1]
    cells = movie.cells.assign(track=perm[movie.cells["cell"]], cell=movie.cells["cell"] + 1000)
    edges = movie.edges.assign(cell_a=movie.edges["cell_a"] + 1000, cell_b=movie.edges["cell_b"] + 1000)
    ev = detect_t1(edges, cells, min_length=movie.min_length, censor=movie.censor, box=movie.box)
    back = dict(zip(perm.tolist(), range(len(perm))))
    got = {(r.kind, r.frame_start, frozenset({back[r.cell_a], back[r.cell_b]}),
            frozenset({back[r.cell_c], back[r.cell_d]})) for r in ev.itertuples()}
    want = {(r.kind, r.frame_start, frozenset({r.cell_a, r.cell_b}), frozenset({r.cell_c, r.cell_d}))
            for r in movie.events.itertuples()}
    assert got == want


# Hand-made network: a quartet a=1, b=2, c=3, d=4 surrounded by nothing else.
def _quartet_tables(states, lengths=None, absent=()):
    """Frames with 'ab' (1-2 touch), 'cd' (3-4 touch) or '4' (four-fold); cells 1-4 always present
    except (frame, cell) pairs in ``absent``."""
    rows = []
    for t, s in enumerate(states):
        length = 5.0 if lengths is None else lengths[t]
        for a, b in ((1, 3), (1, 4), (2, 3), (2, 4)):
            rows.append((t, a, b, 10.0))
        if s == "ab":
            rows.append((t, 1, 2, length))
        elif s == "cd":
            rows.append((t, 3, 4, length))
        rows.append((t, 0, 1, 3.0))  # contacts with the outside are ignored
    edges = pd.DataFrame(rows, columns=["frame", "cell_a", "cell_b", "length"])
    cells = pd.DataFrame([(t, c, float(c), 0.0) for t in range(len(states)) for c in (1, 2, 3, 4)
                          if (t, c) not in absent], columns=["frame", "cell", "x", "y"])
    keep = [not ((t, a) in absent or (t, b) in absent) for t, a, b in zip(edges["frame"], edges["cell_a"],
                                                                          edges["cell_b"])]
    return edges[keep], cells


def test_oscillating_t1s_are_cycles_and_min_length_suppresses_them():
    # tyssue #239: a nearly four-fold vertex flickering between a-b and c-d
    states = ["ab"] * 3 + ["cd", "ab"] * 3 + ["ab"] * 3
    lengths = [5.0] * 3 + [0.5] * 6 + [5.0] * 3
    edges, cells = _quartet_tables(states, lengths)
    ev = detect_t1(edges, cells, censor=2)
    assert ev["kind"].tolist() == ["cycle"] * 3
    assert ev["frame_start"].tolist() == [3, 5, 7] and ev["duration"].tolist() == [1.0, 1.0, 1.0]
    assert ev[["cell_a", "cell_b", "cell_c", "cell_d"]].drop_duplicates().values.tolist() == [[1, 2, 3, 4]]
    assert detect_t1(edges, cells, min_length=1.0, censor=2).empty


def test_cycles_of_one_frame_are_counted_in_the_summary_and_the_report():
    """The doubtful class of segmented movies (docs/t1.md): a-b -> c-d -> a-b over two frame intervals. The
    summary counts those cycles and no other event: here three one-frame flickers, then a cycle of 3 frames
    through a held four-fold vertex and an intercalation; reference and streaming implementations agree."""
    from types import SimpleNamespace

    from hexatissue.events import _reference as ref
    from hexatissue.events import events_summary
    from hexatissue.views.events import _one_frame_lines

    states = ["ab"] * 2 + ["cd", "ab"] * 3 + ["4", "cd", "cd", "ab", "ab", "cd", "cd", "cd"]
    edges, cells = _quartet_tables(states)
    ev = detect_t1(edges, cells, censor=2)
    pd.testing.assert_frame_equal(ref.detect_t1(edges, cells, censor=2), ev)
    assert ev["kind"].tolist() == ["cycle"] * 4 + ["intercalation"]
    assert ev["duration"].tolist()[:4] == [1.0, 1.0, 1.0, 3.0]
    summary = events_summary(ev, 2, True, len(states))
    assert summary["n_one_frame_cycles"] == 3 and summary["n_cycles"] == 4
    line, = _one_frame_lines(SimpleNamespace(summary={"events": summary}))
    assert "3 of 5 T1s" in line
    assert _one_frame_lines(SimpleNamespace(summary={"events": events_summary(ev.iloc[3:], 2, True, 17)})) == []


def test_persistent_fourfold_vertex_then_reversal():
    states = ["ab"] * 3 + ["4"] * 4 + ["cd"] * 3 + ["4"] * 2 + ["ab"] * 2 + ["4"] * 2 + ["ab"] * 4
    ev = detect_t1(*_quartet_tables(states), censor=2)
    assert len(ev) == 1
    r = ev.iloc[0]
    assert (r["kind"], r["frame_start"], r["frame_gain"], r["frame_undo"], r["frame_end"]) == \
           ("cycle", 3, 7, 10.0, 12.0)
    assert r["duration"] == 9.0


def test_failed_t1_and_repeated_gain_are_not_events():
    # a-b lost to a four-fold vertex and regained: no exchange
    assert detect_t1(*_quartet_tables(["ab"] * 3 + ["4"] * 3 + ["ab"] * 3)).empty
    # one T1 whose c-d junction flickers through a four-fold vertex: one intercalation
    states = ["ab"] * 3 + ["cd"] * 3 + ["4"] + ["cd"] * 10
    ev = detect_t1(*_quartet_tables(states), censor=3)
    assert ev["kind"].tolist() == ["intercalation"] and ev["frame_start"].tolist() == [3]


def test_a_loss_whose_flanks_change_in_the_same_frame_is_paired_with_the_gain_that_sees_it():
    # a-b touch with only c flanking them before the loss (a-d forms in the frame a-b is lost: a T1 next to a
    # T1), so the loss has no quartet of its own; after the gain c-d is flanked by a and b: one T1, and the
    # plain reference agrees
    edges, cells = _quartet_tables(["ab"] * 3 + ["4"] * 2 + ["cd"] * 6)
    edges = edges[~((edges["frame"] < 3) & (edges["cell_a"] == 1) & (edges["cell_b"] == 4))]
    ev = detect_t1(edges, cells, censor=2)
    assert ev[["kind", "frame_start", "frame_gain", "cell_a", "cell_b", "cell_c", "cell_d"]].values.tolist() == [
        ["intercalation", 3, 5, 1, 2, 3, 4]]
    from hexatissue.events import _reference as reference

    contacts = track_contacts(edges, cells)
    presence = cells.rename(columns={"cell": "track"})[["frame", "track"]]
    pd.testing.assert_frame_equal(find_t1(contacts, presence), reference.find_t1(contacts, presence))


def test_gain_after_an_intermediate_c_d_contact_is_not_paired_with_the_loss():
    # a-b lost at 3; c-d touch at 4 while a no longer touches c (no valid quartet), lose it at 5,
    # touch again with a valid quartet at 7: the intermediate state was not a four-fold vertex
    edges, cells = _quartet_tables(["ab"] * 3 + ["4", "cd", "4", "4"] + ["cd"] * 5)
    edges = edges[~((edges["frame"] == 4) & (edges["cell_a"] == 1) & (edges["cell_b"] == 3))]
    assert detect_t1(edges, cells, censor=0).empty
    # the same without the intermediate contact is one T1 through a persistent four-fold vertex
    edges, cells = _quartet_tables(["ab"] * 3 + ["4"] * 4 + ["cd"] * 5)
    ev = detect_t1(edges, cells, censor=0)
    assert ev[["frame_start", "frame_gain"]].values.tolist() == [[3, 7]]


def test_contacts_of_cells_entering_or_leaving_are_not_t1s():
    states = ["ab"] * 3 + ["cd"] * 5
    # cell 1 is absent at frame 3: the loss of a-b is explained by it leaving
    edges, cells = _quartet_tables(states, absent={(3, 1)})
    assert detect_t1(edges, cells).empty
    # cell 3 appears at frame 3 (absent before): the c-d gain is explained by it entering
    edges, cells = _quartet_tables(states, absent={(t, 3) for t in range(3)})
    assert detect_t1(edges, cells).empty
    edges, cells = _quartet_tables(states)
    assert detect_t1(edges, cells, censor=0)["kind"].tolist() == ["intercalation"]


def test_every_event_is_a_valid_quartet_on_a_random_movie():
    mov = voronoi_movie(60, (110, 150), 40, periodic=True, amplitude=0.4, seed=2)
    seeds = np.stack([mov.seeds(t) for t in range(len(mov))])
    edges = movie_contacts(seeds, mov.shape[1:], True)
    cells = pd.DataFrame({"frame": np.repeat(np.arange(len(mov)), len(mov.base)),
                          "cell": np.tile(np.arange(1, len(mov.base) + 1), len(mov)),
                          "x": seeds[..., 0].ravel(), "y": seeds[..., 1].ravel()})
    ev = detect_t1(edges, cells, censor=3, box=mov.box)
    assert len(ev) >= 5
    assert_valid_quartets(ev, edges, cells)
    assert set(ev["kind"]) <= {"cycle", "intercalation", "unresolved"}


def assert_valid_quartets(events, edges, cells):
    """Every event is a neighbour exchange in a quartet, checked directly on the contacts.

    The quartet is seen on one side at least (c, d flank a-b before the loss, or a, b flank c-d after
    the gain: two T1s on junctions sharing a vertex in one frame see theirs on one side each, see
    test_t1s_next_to_t1s_are_each_found_with_their_kind), and every loss and gain is one T1 at most.
    Flanks count the cells around a vertex of four or more cells as neighbours (a flanking contact held as a
    four-fold vertex: test_a_t1_whose_flank_is_held_as_a_four_fold_vertex_is_found); the exchanged pairs themselves
    must be contacts.
    """
    con = track_contacts(edges, cells)
    keys = set(zip(con["frame"], con["a"], con["b"]))
    frames = np.unique(cells["frame"])
    nbrs = {}
    for f, a, b in keys:
        nbrs.setdefault((f, a), set()).add(b)
        nbrs.setdefault((f, b), set()).add(a)
    if {"vertex_a", "vertex_b"} <= set(edges.columns):  # cells around one vertex of four or more, plain loops
        track = dict(zip(zip(cells["frame"], cells["cell"]), cells["track"])) if "track" in cells else None
        around = {}
        for r in edges.itertuples():
            for v in (r.vertex_a, r.vertex_b):
                for c in (r.cell_a, r.cell_b):
                    if c > 0:
                        around.setdefault((r.frame, v), set()).add(c if track is None else track[(r.frame, c)])
        for (f, _), ring in around.items():
            if len(ring) >= 4:
                for c in ring:
                    nbrs.setdefault((f, c), set()).update(ring - {c})
    touch = lambda f, u, v: (f, min(u, v), max(u, v)) in keys
    for r in events.itertuples():
        before = frames[np.searchsorted(frames, r.frame_start) - 1]
        after = r.frame_gain
        assert touch(before, r.cell_a, r.cell_b) and not touch(r.frame_start, r.cell_a, r.cell_b)
        assert touch(after, r.cell_c, r.cell_d)
        assert ({r.cell_c, r.cell_d} <= nbrs[(before, r.cell_a)] & nbrs[(before, r.cell_b)]
                or {r.cell_a, r.cell_b} <= nbrs[(after, r.cell_c)] & nbrs[(after, r.cell_d)])
        between = frames[(frames >= r.frame_start) & (frames < after)]
        assert not any(touch(f, r.cell_a, r.cell_b) or touch(f, r.cell_c, r.cell_d) for f in between)
        if r.kind == "cycle":
            assert touch(r.frame_end, r.cell_a, r.cell_b) and not touch(r.frame_end, r.cell_c, r.cell_d)
    assert not events.duplicated(["frame_start", "cell_a", "cell_b"]).any()
    assert not events.duplicated(["frame_gain", "cell_c", "cell_d"]).any()


def test_cell_statistics():
    events = pd.DataFrame({
        "kind": ["intercalation", "cycle", "intercalation", "cycle", "unresolved"],
        "frame_start": [2, 4, 10, 12, 30], "duration": [np.nan, 3.0, np.nan, 5.0, np.nan],
        "cell_a": [1, 1, 1, 7, 1], "cell_b": [2, 5, 6, 8, 9], "cell_c": [3, 3, 3, 3, 10],
        "cell_d": [4, 4, 11, 4, 12]})
    iv = intercalation_intervals(events)
    assert iv[iv["track"] == 1][["frame_prev", "frame_next", "interval"]].values.tolist() == [[2, 10, 8]]
    assert set(iv["track"]) == {1, 3}
    stats = cell_event_stats(events, pd.DataFrame({"frame": [0, 1, 0], "cell": [1, 1, 99]})).set_index("track")
    assert stats.loc[1, ["n_cycles", "n_intercalations", "n_unresolved", "n_intervals", "n_frames"]].tolist() == \
           [1, 2, 1, 1, 2]
    assert stats.loc[1, "mean_cycle_period"] == 3.0 and stats.loc[1, "mean_intercalation_interval"] == 8.0
    assert stats.loc[99, "n_cycles"] == 0 and np.isnan(stats.loc[99, "mean_cycle_period"])
    s3 = cell_event_stats(events).set_index("track").loc[3]
    assert s3["mean_cycle_period"] == 4.0 and s3["n_intercalations"] == 2


def test_bad_input():
    edges, cells = _quartet_tables(["ab", "cd"])
    with pytest.raises(InputError, match="min_length"):
        detect_t1(edges, cells, min_length=-1)
    with pytest.raises(InputError, match="censor"):
        detect_t1(edges, cells, censor=-2)
    with pytest.raises(InputError, match="length"):
        detect_t1(edges.drop(columns="length"), cells)
    with pytest.raises(InputError, match="'x'"):
        detect_t1(edges, cells.drop(columns="x"))
    empty = classify_t1(find_t1(track_contacts(edges.iloc[:0]), cells.rename(columns={"cell": "track"})), 1)
    assert empty.empty and "kind" in empty.columns


# ---------------------------------------------------------------------------- the paper's per-cell definition

def _hand_movie(contacts_of_frame, n_frames, n_cells=4):
    """edges and cells tables of a movie given by its contacts per frame (cells 1..n_cells, all present)."""
    rows = [(f, a, b, 5.0) for f in range(n_frames) for a, b in contacts_of_frame(f)]
    edges = pd.DataFrame(rows, columns=["frame", "cell_a", "cell_b", "length"])
    cells = pd.DataFrame([(f, c, 10.0 * c, 0.0) for f in range(n_frames) for c in range(1, n_cells + 1)],
                         columns=["frame", "cell", "x", "y"])
    return edges, cells


RING = [(1, 3), (1, 4), (2, 3), (2, 4)]  # cells 3 and 4 are common neighbours of 1 and 2


def test_a_fourfold_vertex_that_returns_is_a_cycle_of_two_cells_but_no_quartet_t1():
    # 1-2 touch, lose contact at frame 3 (a four-fold vertex), touch again at 6; 3-4 never touch
    edges, cells = _hand_movie(lambda f: RING + ([] if 3 <= f < 6 else [(1, 2)]), 10)
    assert detect_t1(edges, cells, censor=2).empty
    ev = neighbour_events(edges, cells, censor=2)
    assert ev[["track", "kind", "frame_start", "frame_end", "duration", "n_lost", "n_gained"]].values.tolist() == \
        [[1, "cycle", 3, 6.0, 3.0, 1, 0], [2, "cycle", 3, 6.0, 3.0, 1, 0]]


def test_per_cell_periods_differ_from_the_quartet_duration():
    """A T1 cycle through held four-fold vertices: 1-2 lost at 3, 3-4 gained at 5, lost at 8, 1-2 back at 9."""
    def contacts(f):
        return RING + ([(1, 2)] if f < 3 or f >= 9 else []) + ([(3, 4)] if 5 <= f < 8 else [])

    edges, cells = _hand_movie(contacts, 12)
    quartet = detect_t1(edges, cells, censor=2)
    assert quartet[["kind", "frame_start", "duration"]].values.tolist() == [["cycle", 3, 6.0]]
    per_cell = neighbour_events(edges, cells, censor=2).set_index("track")
    assert per_cell.loc[[1, 2], "duration"].tolist() == [6.0, 6.0]  # a, b: frames 3 -> 9
    assert per_cell.loc[[3, 4], "duration"].tolist() == [3.0, 3.0]  # c, d: frames 5 -> 8
    # the per-cell statistics follow the definition of the table they are given
    assert cell_event_stats(quartet, cells).set_index("track")["mean_cycle_period"].tolist() == [6.0] * 4
    stats = cell_event_stats(per_cell.reset_index(), cells).set_index("track")
    assert stats["mean_cycle_period"].tolist() == [6.0, 6.0, 3.0, 3.0] and (stats["n_cycles"] == 1).all()


def test_two_overlapping_quartets_are_one_excursion_of_their_shared_cell():
    """Cell 1 loses 2 at frame 2 and 5 at frame 4 (two quartets: 3-4 and 6-7 gain); both are undone at 7."""
    base = RING + [(1, 6), (1, 7), (5, 6), (5, 7)]

    def contacts(f):
        out = list(base)
        out += [(1, 2)] if not 2 <= f < 7 else [(3, 4)]
        out += [(1, 5)] if not 4 <= f < 7 else [(6, 7)]
        return out

    edges, cells = _hand_movie(contacts, 10, n_cells=7)
    quartet = detect_t1(edges, cells, censor=1)
    assert sorted(quartet[["frame_start", "duration"]].values.tolist()) == [[2, 5.0], [4, 3.0]]
    per_cell = neighbour_events(edges, cells, censor=1)
    one = per_cell[per_cell["track"] == 1]
    assert one[["kind", "frame_start", "frame_end"]].values.tolist() == [["cycle", 2, 7.0]]  # one excursion
    assert len(per_cell) == 7  # every cell of the two quartets, cell 1 once


def test_an_unreturned_change_is_an_intercalation_and_intervals_are_per_cell():
    """Cell 1 loses 2 at frame 2 for good, then loses 5 at frame 6 for good: two intercalations, 4 frames apart."""
    base = RING + [(1, 6), (1, 7), (5, 6), (5, 7)]

    def contacts(f):
        return base + ([(1, 2)] if f < 2 else [(3, 4)]) + ([(1, 5)] if f < 6 else [(6, 7)])

    edges, cells = _hand_movie(contacts, 14, n_cells=7)
    per_cell = neighbour_events(edges, cells, censor=3)
    one = per_cell[per_cell["track"] == 1]
    assert one[["kind", "frame_start"]].values.tolist() == [["intercalation", 2], ["intercalation", 6]]
    intervals = intercalation_intervals(per_cell)
    assert intervals[intervals["track"] == 1]["interval"].tolist() == [4]
    late = neighbour_events(edges, cells, censor=10)  # 14 frames: a change at 6 is within 10 of the end
    assert late[late["track"] == 1]["kind"].tolist() == ["intercalation", "unresolved"]


@pytest.mark.parametrize("periodic", [True, False])
def test_per_cell_events_of_the_scripted_t1_movie_follow_its_quartets(periodic):
    """Each scripted quartet T1 is one event of each of its cells, a-b at frame_start, c-d at frame_gain."""
    m = t1_movie(periodic=periodic, seed=2)
    got = neighbour_events(m.edges, m.cells, min_length=m.min_length, censor=m.censor)

    def touching(a, b):  # frames in which the truth has the a-b contact
        e = m.edges[(m.edges["cell_a"] == min(a, b)) & (m.edges["cell_b"] == max(a, b))
                    & (m.edges["length"] >= m.min_length)]
        return set(e["frame"].tolist())

    expected = []
    for r in m.events.itertuples():
        cd = touching(r.cell_c, r.cell_d)
        undo = min((f for f in range(r.frame_gain, 36) if f not in cd), default=np.nan) if r.kind == "cycle" else np.nan
        for cells_, start, end in (((r.cell_a, r.cell_b), r.frame_start, r.frame_end),
                                   ((r.cell_c, r.cell_d), r.frame_gain, undo)):
            expected += [(int(c), str(r.kind), int(start), float(end)) for c in cells_]
    # the four-fold vertex that resolves back: no quartet T1, but its a-b pair leaves and regains contact
    q = m.quartets.set_index("name").loc["fourfold_return"]
    ab = sorted(touching(q.cell_a, q.cell_b))
    gone = [f for f in range(ab[0], ab[-1]) if f not in ab]
    expected += [(int(c), "cycle", gone[0], float(gone[-1] + 1)) for c in (q.cell_a, q.cell_b)]
    key = lambda rows: sorted((t, k, s, -1.0 if np.isnan(e) else e) for t, k, s, e in rows)
    assert key(got[["track", "kind", "frame_start", "frame_end"]].itertuples(index=False, name=None)) == key(expected)


def test_cells_entering_and_leaving_do_not_change_a_neighbour_list():
    """A cell present in frames 4-6 only, touching cell 3: the events are those without it (presence path)."""
    def contacts(f):
        out = RING + ([(1, 2)] if f < 3 or f >= 9 else []) + ([(3, 4)] if 5 <= f < 8 else [])
        return out + ([(3, 9)] if 4 <= f < 7 else [])

    edges, cells = _hand_movie(contacts, 12)
    visitor = pd.DataFrame([(f, 9, 50.0, 0.0) for f in range(4, 7)], columns=["frame", "cell", "x", "y"])
    cells = pd.concat([cells, visitor], ignore_index=True)
    got = neighbour_events(edges, cells, censor=2).set_index("track")
    assert sorted(got.index) == [1, 2, 3, 4]
    assert got["duration"].to_dict() == {1: 6.0, 2: 6.0, 3: 3.0, 4: 3.0}


# ----------------------------------------------------------------------------
# The streaming implementation gives the tables of the whole-movie one (hexatissue/events/_reference.py)
# ----------------------------------------------------------------------------

ROOT = Path(__file__).resolve().parents[1]


def _analysed(source, n_frames=None):
    """Edges, cells (with tracks) and box of ``hexatissue.analyze`` of a sample (its first ``n_frames``)."""
    from hexatissue import analyze, open_source

    src = open_source(source)
    if n_frames is not None:
        src = open_source([src.frame(t) for t in range(n_frames)])
    movie = analyze(src, box=open_source(source).box, progress=False)
    return movie.edges, movie.cells, movie.box


def _voronoi_tables(periodic, seed, leave=False):
    """A random moving Voronoi tissue's contacts and cells; with ``leave``, some cells absent from some frames."""
    mov = voronoi_movie(50, (100, 130), 30, periodic=periodic, amplitude=0.45, seed=seed)
    seeds = np.stack([mov.seeds(t) for t in range(len(mov))])
    edges = movie_contacts(seeds, mov.shape[1:], periodic)
    cells = pd.DataFrame({"frame": np.repeat(np.arange(len(mov)), len(mov.base)),
                          "cell": np.tile(np.arange(1, len(mov.base) + 1), len(mov)),
                          "x": seeds[..., 0].ravel(), "y": seeds[..., 1].ravel()})
    if leave:  # cells leave the tissue for a few frames: their contacts go too (not T1s)
        gone = (cells["cell"] % 7 == 0) & cells["frame"].between(8, 12)
        cells = cells[~gone].reset_index(drop=True)
        keys = set(zip(cells["frame"], cells["cell"]))
        edges = edges[[(f, a) in keys and (f, b) in keys
                       for f, a, b in zip(edges["frame"], edges["cell_a"], edges["cell_b"])]].reset_index(drop=True)
    rng = np.random.default_rng(seed)  # relabelled tracks: label ids != track ids, another order
    track = rng.permutation(200)[:len(mov.base)] + 1
    cells.insert(2, "track", track[cells["cell"].to_numpy() - 1])
    return edges, cells, mov.box


def _assert_as_reference(edges, cells, box, censor, min_lengths=(0.0, 2.0)):
    from hexatissue.events import _reference as ref

    n = {"t1": 0, "neighbour": 0}
    for min_length in min_lengths:
        contacts = track_contacts(edges, cells, min_length)
        pd.testing.assert_frame_equal(contacts, ref.track_contacts(edges, cells, min_length))
        presence = pd.DataFrame({"frame": cells["frame"].to_numpy(np.int64), "track": cells["track"].to_numpy()})
        pd.testing.assert_frame_equal(find_t1(contacts, presence), ref.find_t1(contacts, presence))
        got = detect_t1(edges, cells, min_length, censor, box)
        pd.testing.assert_frame_equal(got, ref.detect_t1(edges, cells, min_length, censor, box))
        per_cell = neighbour_events(edges, cells, min_length, censor)
        pd.testing.assert_frame_equal(per_cell, ref.neighbour_events(edges, cells, min_length, censor))
        both = t1_tables(edges, cells, min_length, censor, box)  # one pass over the contacts for both tables
        pd.testing.assert_frame_equal(both[0], got)
        pd.testing.assert_frame_equal(both[1], per_cell)
        n["t1"] += len(got)
        n["neighbour"] += len(per_cell)
    return n


def test_index_of_ids_equals_a_binary_search():
    """Dense ids (a table), sparse or negative ids (a binary search): the position of each value in the ids."""
    from hexatissue.events import _index_of

    rng = np.random.default_rng(5)
    for ids in (np.unique(rng.integers(1, 900, 300)), np.unique(rng.integers(0, 2**40, 300)),
                np.unique(rng.integers(-50, 50, 60)), np.zeros(0, np.int64)):
        values = rng.choice(ids, 500) if len(ids) else ids
        got = _index_of(ids)(values)
        assert got.dtype == np.int64
        np.testing.assert_array_equal(got, np.searchsorted(ids, values))


def test_directed_contacts_equal_a_two_key_lexsort():
    """Small non-negative ids (one argsort of a key), large or negative ones (lexsort): sorted by (u, v)."""
    from hexatissue.events import _directed

    rng = np.random.default_rng(4)
    for low, high in ((0, 50), (0, 2**40), (-30, 30)):
        keys = np.unique(rng.integers(low, high, (300, 2)), axis=0)
        a, b = keys.min(axis=1), keys.max(axis=1)
        keep = a < b
        a, b = a[keep], b[keep]
        u, v = np.concatenate((a, b)), np.concatenate((b, a))
        order = np.lexsort((v, u))
        got = _directed(a, b)
        np.testing.assert_array_equal(got[0], u[order])
        np.testing.assert_array_equal(got[1], v[order])
    assert [x.tolist() for x in _directed(np.array([2, 0]), np.array([3, 2]))] == [[0, 2, 2, 3], [2, 0, 3, 2]]
    assert all(len(x) == 0 for x in _directed(np.zeros(0, np.int64), np.zeros(0, np.int64)))


@pytest.mark.parametrize("periodic", [True, False], ids=["periodic", "open"])
def test_streaming_events_equal_the_whole_movie_reference_on_the_t1_movie(periodic):
    m = t1_movie(periodic=periodic, seed=1)
    cells = m.cells.assign(track=m.cells["cell"])
    n = _assert_as_reference(m.edges, cells, m.box, m.censor, (0.0, m.min_length))
    assert n["t1"] >= len(m.events) and n["neighbour"] > 0
    # rows in another order (frames interleaved): the same tables
    shuffled = np.random.default_rng(0).permutation(len(m.edges))
    _assert_as_reference(m.edges.iloc[shuffled].reset_index(drop=True), cells.iloc[::-1].reset_index(drop=True),
                         m.box, m.censor, (m.min_length,))


@pytest.mark.parametrize("periodic,leave", [(True, False), (False, False), (True, True)],
                         ids=["periodic", "open", "cells-leaving"])
def test_streaming_events_equal_the_whole_movie_reference_on_a_random_voronoi_movie(periodic, leave):
    edges, cells, box = _voronoi_tables(periodic, seed=3, leave=leave)
    n = _assert_as_reference(edges, cells, box if periodic else None, censor=4)
    assert n["t1"] > 0 and n["neighbour"] > 0


def test_streaming_events_equal_the_whole_movie_reference_on_the_bundled_sample():
    edges, cells, box = _analysed(ROOT / "hexatissue" / "sample_data" / "epicure_notum" / "013_crop_labels.tif")
    n = _assert_as_reference(edges, cells, box, censor=2)
    assert n["neighbour"] > 0


def test_streaming_events_equal_the_whole_movie_reference_on_the_mpf_sample():
    run = ROOT / "hexatissue" / "sample_data" / "mpf_small" / "run.zarr"
    if not run.exists():
        pytest.skip("hexatissue/sample_data/mpf_small/run.zarr is absent")
    edges, cells, box = _analysed(run, n_frames=80)
    n = _assert_as_reference(edges, cells, box, censor=10)
    assert n["t1"] > 0 and n["neighbour"] > 0


@pytest.mark.slow
def test_streaming_events_equal_the_whole_movie_reference_on_the_whole_mpf_sample():
    run = ROOT / "hexatissue" / "sample_data" / "mpf_small" / "run.zarr"
    if not run.exists():
        pytest.skip("hexatissue/sample_data/mpf_small/run.zarr is absent")
    edges, cells, box = _analysed(run)
    n = _assert_as_reference(edges, cells, box, censor=10, min_lengths=(0.0,))
    assert n["t1"] > 300


def _kernel_case(case, t1_periodic):
    """Edges and cells (with ``track``) of a kernel-vs-reference case: the scripted T1 movie, a Voronoi movie
    (``"voronoi"``), one whose cells leave (``"cells-leaving"``) or one with ids too large for a table over them
    (``"large-ids"``: binary searches)."""
    if case == "t1-movie":
        m = t1_movie(periodic=t1_periodic, seed=1)
        return m.edges, m.cells.assign(track=m.cells["cell"])
    edges, cells, _ = _voronoi_tables(periodic=True, seed=3, leave=case == "cells-leaving")
    if case == "large-ids":
        cells["track"] += 2**35
    return edges, cells


@pytest.mark.parametrize("case", ["t1-movie", "voronoi", "cells-leaving", "large-ids"])
def test_change_kernels_equal_the_numpy_reference(case):
    """:class:`_Changes` (numba kernels) and :class:`_ChangesReference` (numpy): the same changes, returns, events."""
    from hexatissue.events import _Changes, _Lists, _movie_frames, _same_cells_every_frame
    from hexatissue.events._reference import _ChangesReference
    from hexatissue.schema import FrameRows
    from hexatissue.geometry import row_keys

    edges, cells = _kernel_case(case, t1_periodic=True)
    frames, tracks = cells["frame"].to_numpy(np.int64), cells["track"].to_numpy(np.int64)
    constant = _same_cells_every_frame(tracks[rows] for _, rows in FrameRows(frames))
    keys = None if constant else np.unique(row_keys(frames, tracks))
    assert constant == (case != "cells-leaving")
    top = None if case == "large-ids" else int(tracks.max())
    got, want = _Changes(keys, top), _ChangesReference(keys, top)
    for frame, present, a, b, _ in _movie_frames(edges, cells, 0.0):
        got.add(_Lists(frame, present, a, b))
        want.add(_Lists(frame, present, a, b))
        assert got.n == want.n and got.m == len(want.track)
        np.testing.assert_array_equal(got.open[:, :got.m], np.stack((want.index, want.track, want.prev_frame)))
        np.testing.assert_array_equal(got.ref[:got.m], want.ref)
    for mine, theirs in ((got.found, want.found), (got.back, want.back)):
        assert len(mine) == len(theirs)
        for x, y in zip(mine, theirs):
            for p, q in zip(x, y):
                np.testing.assert_array_equal(p, q)
    for p, q in zip(got.events(int(frames.max()), 4), want.events(int(frames.max()), 4), strict=True):
        np.testing.assert_array_equal(p, q)
    assert want.found and (case != "t1-movie" or want.back) and (case != "cells-leaving" or got.k > 0)


@pytest.mark.parametrize("case", ["t1-movie", "cells-leaving", "large-ids"])
def test_t1_kernel_equals_the_numpy_reference(case):
    """:func:`_t1_step` (numba) and :func:`_t1_step_reference` (numpy) on every pair of consecutive frames."""
    from hexatissue.events import _FrameGraph, _directed, _ids, _index_of, _movie_frames, _t1_step
    from hexatissue.events._reference import _t1_step_reference

    edges, cells = _kernel_case(case, t1_periodic=False)
    ids = _ids(edges, cells)
    index, K = _index_of(ids), np.int64(len(ids) + 1)
    prev, n = None, np.zeros(6, int)
    for _, tracks, a, b, _ in _movie_frames(edges, cells, 0.0):
        cur = _FrameGraph(index(tracks), index(a), index(b), K)
        for x, y in zip((cur.u, cur.v), _directed(*np.divmod(cur.keys, K))):  # the graph's directed contacts
            np.testing.assert_array_equal(x, y)
        if prev is not None:
            got, want = _t1_step(prev, cur), _t1_step_reference(prev, cur)
            for x, y in zip(got, want):
                assert x.dtype == np.int64
                np.testing.assert_array_equal(x, y)
            n += [len(x) for x in got]
        prev = cur
    assert n.min() > 0  # contacts gained and lost, quartets of both
    absent = _FrameGraph(np.array([1, 2]), np.array([1, 1]), np.array([2, 3]), np.int64(5))  # cell 3 is absent
    assert absent.u.tolist() == [1, 1, 2, 3] and absent.v.tolist() == [2, 3, 1, 1]


def test_lists_kernel_equals_the_numpy_reference():
    """:class:`_Lists` (numba) and :class:`_ListsReference` (numpy): the same sorted lists, rows and hashes."""
    from hexatissue.events import _Lists
    from hexatissue.events._reference import _ListsReference

    rng = np.random.default_rng(7)
    cases = [(np.arange(1, 9), np.array([1, 1, 2, 3]), np.array([2, 5, 3, 8]))]  # hand-made, sorted
    for high in (30, 2**40):  # small and large ids; contacts unsorted, a > b, repeated, of absent cells
        ids = np.unique(rng.integers(0, high, 40))
        tracks = np.sort(rng.choice(ids, len(ids) - 5, replace=False))
        a, b = rng.choice(ids, 120), rng.choice(ids, 120)
        cases += [(tracks, a, b), (tracks, a[:0], b[:0])]
    for tracks, a, b in cases:
        got, want = _Lists(3, tracks, a, b), _ListsReference(3, tracks, a, b)
        for name in ("u", "v", "row", "h", "full"):
            x, y = getattr(got, name), getattr(want, name)
            assert x.dtype == y.dtype, name
            np.testing.assert_array_equal(x, y, err_msg=name)
    assert _Lists(0, *cases[0]).v.tolist() == [2, 5, 1, 3, 2, 8, 1, 3]


@pytest.mark.parametrize("seed", range(6))
def test_undo_pairs_kernel_equals_the_plain_python_fold(seed):
    from hexatissue.events._kernels import _undo_pairs
    from hexatissue.events._reference import _undo_pairs_reference

    rng = np.random.default_rng(seed)
    for n in (0, 1, 2, 3, 10, 200):
        undone = rng.random(n) < (0.2, 0.5, 0.9)[seed % 3]
        if n:
            undone[-1] = False  # the last T1 has no next one
        got, want = _undo_pairs(undone), _undo_pairs_reference(undone)
        for g, w in zip(got, want, strict=True):
            np.testing.assert_array_equal(g, w)
    # by hand: T1 0 undone by 1, 2 undone by 3, 3's "undoes next" flag is then inside the cycle (ignored), 4 alone
    first, cycle = _undo_pairs(np.array([True, False, True, True, False]))
    np.testing.assert_array_equal(first, [0, 2, 4])
    np.testing.assert_array_equal(cycle, [True, True, False])


@pytest.mark.parametrize("seed", range(6))
def test_excursion_starts_kernel_equals_the_plain_python_fold(seed):
    from hexatissue.events._kernels import _excursion_starts
    from hexatissue.events._reference import _excursion_starts_reference

    rng = np.random.default_rng(seed)
    for n in (0, 1, 5, 50, 400):
        track, start = rng.integers(0, 1 + n // 10, n), rng.integers(0, 30, n)
        back = np.where(rng.random(n) < 0.5, start + rng.integers(1, 8, n), -1)
        order = np.lexsort((start, track))
        np.testing.assert_array_equal(_excursion_starts(order, track, start, back),
                                      _excursion_starts_reference(order, track, start, back))
    # by hand: cell 7 changes at 2 (back at 5), 3 and 5 (inside), 6 (a new excursion); cell 8 at 3 (never back)
    track, start, back = np.array([7, 7, 7, 7, 8]), np.array([2, 3, 5, 6, 3]), np.array([5, -1, 9, -1, -1])
    np.testing.assert_array_equal(_excursion_starts(np.arange(5), track, start, back), [0, 3, 4])


def _cell_event_stats_by_groupby(events, tracks, n_frames):
    """cell_event_stats written with pandas groupby over one row per participant (the test's reference)."""
    columns = ("cell_a", "cell_b", "cell_c", "cell_d") if "cell_a" in events.columns else ("track",)
    long = pd.concat([pd.DataFrame({"track": events[c].to_numpy(np.int64), "kind": events["kind"].astype(object),
                                    "duration": events["duration"].to_numpy(float),
                                    "frame": events["frame_start"].to_numpy(np.int64)}) for c in columns])
    out = pd.DataFrame({"track": tracks, "n_frames": n_frames})
    for kind, col in (("cycle", "n_cycles"), ("intercalation", "n_intercalations"), ("unresolved", "n_unresolved")):
        out[col] = long[long["kind"] == kind].groupby("track").size().reindex(tracks).fillna(0).to_numpy(np.int64)
    out["mean_cycle_period"] = long[long["kind"] == "cycle"].groupby("track")["duration"].mean().reindex(
        tracks).to_numpy(float)
    inter = long[long["kind"] == "intercalation"].sort_values(["track", "frame"], kind="stable")
    same = inter["track"].to_numpy()[1:] == inter["track"].to_numpy()[:-1]
    gaps = pd.DataFrame({"track": inter["track"].to_numpy()[1:][same],
                         "interval": np.diff(inter["frame"].to_numpy())[same].astype(float)}).groupby("track")
    out["n_intervals"] = gaps.size().reindex(tracks).fillna(0).to_numpy(np.int64)
    out["mean_intercalation_interval"] = gaps["interval"].mean().reindex(tracks).to_numpy(float)
    return out


@pytest.mark.parametrize("quartets", [True, False])
def test_cell_event_stats_equal_a_groupby_reference(quartets):
    rng = np.random.default_rng(3 + quartets)
    n = 400
    kinds = rng.choice(np.array(["cycle", "intercalation", "unresolved", "other"], dtype=object), n, p=[.4, .4, .15, .05])
    events = pd.DataFrame({"kind": pd.array(kinds, dtype="string"), "frame_start": rng.integers(0, 60, n),
                           "duration": np.where(rng.random(n) < 0.2, np.nan, rng.integers(1, 9, n).astype(float))})
    for c in ("cell_a", "cell_b", "cell_c", "cell_d") if quartets else ("track",):
        events[c] = rng.integers(0, 50, n)
    events.loc[events.index[:3], "kind"] = pd.NA  # missing kinds count as none of the three
    cells = pd.DataFrame({"frame": rng.integers(0, 60, 900), "track": rng.integers(5, 45, 900)})  # some tracks absent
    tracks, n_frames = np.unique(cells["track"].to_numpy(), return_counts=True)
    got = cell_event_stats(events, cells)
    pd.testing.assert_frame_equal(got, _cell_event_stats_by_groupby(events, tracks, n_frames.astype(np.int64)),
                                  check_exact=True)
    assert got["n_cycles"].sum() > 0 and got["n_intervals"].sum() > 0 and got["mean_cycle_period"].notna().any()


# Two T1s on junctions that share a cell and a vertex (issue 29): the rosette of hexatissue.synthetic.rosette_movie.
# Fan 0 has the diagonals 1-3, 1-4; fan 1 has 2-4, 2-5; fan 3 has 4-1, 4-2 (labels).  Going fan 0 -> fan 1 is
# the sequence 1-3 -> 2-4 (quartet 1, 3 | 2, 4), then 1-4 -> 2-5 (quartet 1, 4 | 2, 5); fan 0 -> fan 3 -> fan 1
# makes them one frame apart.  The expected rows are written from that geometry, not from a detector.
_ROSETTE_CASES = {
    # name: (states per frame, [(kind, frame_start, frame_gain, frame_end, a, b, c, d), ...])
    "same frame, junctions growing 6 -> 11 px": (
        [0] * 4 + [(1, 0.55)] + [1] * 7,
        [("intercalation", 4, 4, np.nan, 1, 3, 2, 4), ("intercalation", 4, 4, np.nan, 1, 4, 2, 5)]),
    "consecutive frames": (
        [0] * 4 + [3] + [1] * 7,
        [("intercalation", 4, 4, np.nan, 1, 3, 2, 4), ("intercalation", 5, 5, np.nan, 1, 4, 2, 5)]),
    "five-fold vertex held two frames": (
        [0] * 4 + [None] * 2 + [1] * 6,
        [("intercalation", 4, 6, np.nan, 1, 3, 2, 4), ("intercalation", 4, 6, np.nan, 1, 4, 2, 5)]),
    "same-frame pair undone in one frame": (
        [0] * 4 + [1] * 4 + [0] * 4,
        [("cycle", 4, 4, 8.0, 1, 3, 2, 4), ("cycle", 4, 4, 8.0, 1, 4, 2, 5)]),
    "consecutive pair undone one frame apart": (
        [0] * 4 + [3, 1, 1, 3] + [0] * 5,
        [("cycle", 4, 4, 8.0, 1, 3, 2, 4), ("cycle", 5, 5, 7.0, 1, 4, 2, 5)]),
    "same-frame pair at the end": (
        [0] * 9 + [1] * 2,
        [("unresolved", 9, 9, np.nan, 1, 3, 2, 4), ("unresolved", 9, 9, np.nan, 1, 4, 2, 5)]),
}


@pytest.mark.parametrize("case", list(_ROSETTE_CASES))
def test_t1s_next_to_t1s_are_each_found_with_their_kind(case):
    """Every T1 of a pair on adjacent junctions, in one frame or in consecutive ones, is found with its kind:
    on the exact contacts, on the rendered labels through analyze, and by the whole-movie reference."""
    from hexatissue import analyze
    from hexatissue.events import _reference as ref
    from hexatissue.synthetic import rosette_movie

    states, truth = _ROSETTE_CASES[case]
    movie = rosette_movie(states)
    want = pd.DataFrame(truth, columns=["kind", "frame_start", "frame_gain", "frame_end", "cell_a", "cell_b",
                                        "cell_c", "cell_d"])
    columns = list(want.columns)
    exact = detect_t1(movie.edges, movie.cells)
    pd.testing.assert_frame_equal(exact[columns], want, check_dtype=False)
    pd.testing.assert_frame_equal(ref.detect_t1(movie.edges, movie.cells), exact)
    assert_valid_quartets(exact, movie.edges, movie.cells)
    rendered = analyze(movie.labels, workers=1, progress=False)
    assert rendered.summary["tracking"]["resolved"] == "never"  # the ids are the tracks: cells 1..5 are the rosette
    pd.testing.assert_frame_equal(rendered.events[columns], want, check_dtype=False)


def test_contacts_held_as_four_fold_vertices_are_counted():
    """A five-fold vertex held for frames 4-5 of the rosette is two junctions shorter than merge_distance
    contracted into one vertex (five cells around a point: three three-fold vertices and two junctions), no
    contact held elsewhere; the events summary counts them."""
    from hexatissue import analyze
    from hexatissue.synthetic import rosette_movie

    movie = analyze(rosette_movie([0] * 4 + [None] * 2 + [1] * 4).labels, workers=1, progress=False)
    v = movie.vertices
    held = v[v["n_merged"] > 0]
    assert held["frame"].tolist() == [4, 5] and held["n_merged"].tolist() == [2, 2] and (held["degree"] == 5).all()
    assert movie.summary["events"]["n_held_contacts"] == 4 and movie.summary["events"]["n_held_vertices"] == 2
    assert len(movie.events) == 2  # the two T1s through the held vertex, not lost to it


# ----------------------------------------------------------------------------
# Flanks held as four-fold vertices
# ----------------------------------------------------------------------------

def _vertex_edges(frames):
    """Edges (with their vertices) from per-frame lists of (vertex_a, vertex_b, cell_a, cell_b); cells 1-5 present."""
    rows = [(t, va, vb, a, b, 5.0) for t, junctions in enumerate(frames) for va, vb, a, b in junctions]
    edges = pd.DataFrame(rows, columns=["frame", "vertex_a", "vertex_b", "cell_a", "cell_b", "length"])
    cells = pd.DataFrame([(t, c, float(c), 0.0) for t in range(len(frames)) for c in range(1, 6)],
                         columns=["frame", "cell", "x", "y"])
    return edges, cells


def test_a_t1_whose_flank_is_held_as_a_four_fold_vertex_is_found():
    """a=1, b=2 lose their junction, c=3, d=4 gain one; the flank a-d is a junction contracted into a
    four-fold vertex with x=5 on both sides (no a-d edge), so neither side has four flanking contacts. The
    cells around the four-fold vertex are neighbours in the quartet search: one T1, as the reference finds."""
    before = [(0, 1, 1, 2), (0, 2, 1, 3), (0, 3, 2, 3),  # P = (a, b, c); the a-b junction P-Q
              (1, 4, 2, 4), (1, 5, 4, 5), (1, 6, 5, 1)]  # Q = (a, b, d, x): a-d held
    after = [(0, 1, 3, 4), (0, 2, 1, 3), (0, 5, 4, 5), (0, 6, 5, 1),  # P' = (a, c, d, x): a-d held; c-d P'-Q'
             (1, 3, 2, 3), (1, 4, 2, 4)]  # Q' = (b, c, d)
    edges, cells = _vertex_edges([before] * 3 + [after] * 3)
    ev = detect_t1(edges, cells, censor=1)
    assert ev[["kind", "frame_start", "frame_gain", "cell_a", "cell_b", "cell_c", "cell_d"]].values.tolist() == [
        ["intercalation", 3, 3, 1, 2, 3, 4]]
    # without the vertices (contacts only) the quartet is not seen: the T1 the held flank hides
    assert detect_t1(edges.drop(columns=["vertex_a", "vertex_b"]), cells, censor=1).empty
    from hexatissue.events import _reference as reference

    pd.testing.assert_frame_equal(ev, reference.detect_t1(edges, cells, censor=1))
    pd.testing.assert_frame_equal(t1_tables(edges, cells, censor=1)[0], ev)


def test_the_sides_of_a_held_four_fold_vertex_collapsing_in_turn_are_not_a_t1():
    """Cells 1-4 around one four-fold vertex 0 (sides 1-2, 2-3, 3-4, 4-1 to outer vertices); side 3-4 collapses
    at frame 2, side 1-2 at frame 3: 1-2 lost as 3-4 comes back, flanked through the vertex's diagonals, but
    the four cells are around one vertex before and after: no contact was exchanged, no T1."""
    sides = {(1, 2): (0, 1, 1, 2), (2, 3): (0, 2, 2, 3), (3, 4): (0, 3, 3, 4), (1, 4): (0, 4, 4, 1)}
    rest = [(1, 5, 1, 5), (2, 5, 2, 5)]
    frames = [list(sides.values()) + rest] * 2
    frames += [[j for p, j in sides.items() if p != (3, 4)] + rest]
    frames += [[j for p, j in sides.items() if p != (1, 2)] + rest]
    frames += [list(sides.values()) + rest] * 2
    edges, cells = _vertex_edges(frames)
    assert detect_t1(edges, cells, censor=1).empty
    from hexatissue.events import _reference as reference

    assert reference.detect_t1(edges, cells, censor=1).empty


def test_t1_step_with_held_flanks_equals_the_numpy_reference():
    """:func:`_t1_step` and its reference when a frame's neighbours include pairs held at four-fold vertices
    (the network of the held-flank test): the T1's quartet is seen on both sides."""
    from hexatissue.events import _FrameGraph, _held_pairs, _ids, _index_of, _movie_frames, _t1_step
    from hexatissue.events._reference import _t1_step_reference

    before = [(0, 1, 1, 2), (0, 2, 1, 3), (0, 3, 2, 3), (1, 4, 2, 4), (1, 5, 4, 5), (1, 6, 5, 1)]
    after = [(0, 1, 3, 4), (0, 2, 1, 3), (0, 5, 4, 5), (0, 6, 5, 1), (1, 3, 2, 3), (1, 4, 2, 4)]
    edges, cells = _vertex_edges([before, after])
    held = _held_pairs(edges, cells)
    ids = _ids(edges, cells)
    index, K = _index_of(ids), np.int64(len(ids) + 1)
    graphs = []
    for f, tracks, a, b, _ in _movie_frames(edges, cells, 0.0):
        g = _FrameGraph(index(tracks), index(a), index(b), K)
        g.flanks = _FrameGraph(g.present, index(np.r_[a, held[f][0]]), index(np.r_[b, held[f][1]]), K)
        graphs.append(g)
    got, want = _t1_step(*graphs), _t1_step_reference(*graphs)
    for x, y in zip(got, want):
        np.testing.assert_array_equal(x, y)
    ab, cd = index(np.array([1])) * K + index(np.array([2])), index(np.array([3])) * K + index(np.array([4]))
    # the loss's pairs of flanking cells before (c-d among them: x = 5 flanks a-b too, at the four-fold vertex)
    assert set(got[2].tolist()) == set(ab.tolist()) and int(cd[0]) in got[3].tolist()
    assert int(ab[0]) in got[4].tolist() and set(got[5].tolist()) == set(cd.tolist())  # and the gain's after


def test_two_losses_seeing_one_gain_are_told_apart_by_junction_length_not_ids():
    """A rosette: losses a-b and a-e in the same frame both see the gain c-d (one side each, held flanks).
    The lost junction that had shrunk is the T1's, whichever ids the cells have (ITASC pos01 paired by ids)."""
    from hexatissue.events import _pair_losses_and_gains

    K = 10

    def pairing(a, b, e, c, d):
        ab, ae, cd = min(a, b) * K + max(a, b), min(a, e) * K + max(a, e), min(c, d) * K + max(c, d)
        losses = pd.DataFrame({"ab": np.empty(0, np.int64), "cd": np.empty(0, np.int64),
                               "frame_lost": np.empty(0, np.int64), "held": np.empty(0, bool),
                               "next_ab": np.empty(0, np.int64)})
        gains = pd.DataFrame({"ab": [ab, ae], "cd": [cd, cd], "frame_gain": [1, 1], "held": [True, True],
                              "prev_cd": [-1, -1]})
        lost = pd.DataFrame({"ab": [ab, ae], "frame_lost": [1, 1], "next_ab": [99, 99]})
        lengths = pd.DataFrame({"pair": [ab, ae, cd], "frame": [1, 1, 1], "length": [0.7, 6.0, 0.5]})
        m = _pair_losses_and_gains(losses, gains, lost, lengths)
        assert len(m) == 1
        return {int(m["ab"].iloc[0]) // K, int(m["ab"].iloc[0]) % K}

    assert pairing(1, 2, 3, 4, 5) == {1, 2}  # a-b had shrunk to 0.7 px, a-e was 6 px long
    assert pairing(3, 2, 1, 4, 5) == {2, 3}  # the same cells numbered the other way round
    assert pairing(5, 4, 3, 1, 2) == {4, 5}


def test_cell_event_stats_from_the_lineage_equal_those_from_the_cells():
    """analyze counts each track's rows from the lineage (no read of the movie's cells): the same table."""
    from hexatissue import EventOptions, analyze

    movie = t1_movie(periodic=False, seed=4)
    result = analyze(movie.labels, box=movie.box, workers=1, progress=False,
                     events=EventOptions(min_length=movie.min_length, censor=movie.censor))
    assert len(result.events) and (result.cell_events["n_frames"] > 0).all()
    pd.testing.assert_frame_equal(result.cell_events, cell_event_stats(result.events, result.cells))
    pd.testing.assert_frame_equal(cell_event_stats(result.events, lineage=result.lineage.sample(frac=1, random_state=0)),
                                  result.cell_events)


def test_quartet_keys_find_the_four_cells_around_one_vertex_of_any_order():
    """What the quartet search keeps of a frame's held vertices (one key per four cells around a vertex) says
    exactly what the vertices' cell sets say, for four-, five- and six-fold vertices."""
    from itertools import combinations

    from hexatissue.events.quartets import _one_vertex, _quartet_keys, _vertex_quartets

    rng = np.random.default_rng(7)
    sizes = [4, 4, 5, 4, 6, 4]
    group = np.repeat(np.arange(len(sizes)), sizes)
    cell = np.concatenate([np.sort(rng.choice(np.arange(1, 40), n, replace=False)) for n in sizes])
    keys = _vertex_quartets((None, None, group, cell))
    around = {frozenset(q) for g in range(len(sizes)) for q in combinations(cell[group == g].tolist(), 4)}
    quartets = [tuple(rng.choice(np.arange(1, 40), 4, replace=False).tolist()) for _ in range(300)]
    quartets += [tuple(rng.permutation(list(q)).tolist()) for q in sorted(around, key=sorted)]
    got = _one_vertex(keys, _quartet_keys(np.array(quartets)))
    np.testing.assert_array_equal(got, [frozenset(q) in around for q in quartets])
    assert got.sum() >= len(around) and not _one_vertex(None, _quartet_keys(np.array(quartets[:3]))).any()
