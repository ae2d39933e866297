"""The active vertex model of the T1 event benchmark: its geometry, its T1 log against its own junctions, its events."""
import numpy as np
import pandas as pd
import pytest

from hexatissue.benchmark.vertex_model import vertex_model_events, vertex_model_movie
from hexatissue.errors import InputError


@pytest.fixture(scope="module")
def movie():
    return vertex_model_movie(n_cells=64, n_frames=12, steps_per_frame=60, v0=2.0, relax_steps=300, seed=3)


def _area(p):
    return 0.5 * np.sum(p[:, 0] * np.roll(p[:, 1], -1) - np.roll(p[:, 0], -1) * p[:, 1])


def test_polygons_tile_the_box_and_labels_follow_them(movie):
    box_area = movie.box.Lx * movie.box.Ly
    for t, polys in enumerate(movie.polygons):
        areas = np.array([_area(p) for p in polys])
        assert (areas > 0).all()  # counter-clockwise, none inverted
        assert areas.sum() == pytest.approx(box_area, rel=1e-12)
        counts = np.bincount(movie.labels[t].ravel(), minlength=len(polys) + 1)
        assert counts[0] == 0
        perimeter = np.array([np.hypot(*np.diff(np.vstack([p, p[:1]]), axis=0).T).sum() for p in polys])
        # a pixel belongs to the polygon holding its centre: the pixel area is the polygon area up to the
        # pixels its boundary cuts
        assert (np.abs(counts[1:] - areas) <= 0.5 * perimeter + 1).all()
    # three junctions per cell on average on a torus of three-fold vertices (V - E + F = 0, 2E = 3V)
    assert (movie.contacts.groupby("frame").size() == 3 * len(movie.polygons[0])).all()


def test_the_log_explains_every_change_of_the_junctions(movie):
    """Each frame's lost and gained contacts are exactly those of the logged flips since the previous frame."""
    assert len(movie.t1_log) > 0
    pairs = {t: set(zip(g.cell_a, g.cell_b)) for t, g in movie.contacts.groupby("frame")}
    for t in range(1, len(movie.polygons)):
        net = {}
        for row in movie.t1_log[movie.t1_log["frame"] == t].sort_values("step").itertuples():
            lost, gained = tuple(sorted((row.cell_a, row.cell_b))), tuple(sorted((row.cell_c, row.cell_d)))
            net[lost] = net.get(lost, 0) - 1
            net[gained] = net.get(gained, 0) + 1
        assert {p for p, v in net.items() if v < 0} == pairs[t - 1] - pairs[t]
        assert {p for p, v in net.items() if v > 0} == pairs[t] - pairs[t - 1]


def test_events_from_a_log():
    log = pd.DataFrame([
        # an intercalation at frame 2 (flip in the step before it)
        (9, 2, 1, 2, 3, 4, 0.0, 0.0),
        # a flip undone before the next frame: never seen
        (21, 3, 5, 6, 7, 8, 0.0, 0.0), (25, 3, 7, 8, 5, 6, 0.0, 0.0),
        # a cycle: 9-10 -> 11-12 at frame 4, back at frame 7
        (31, 4, 9, 10, 11, 12, 0.0, 0.0), (61, 7, 11, 12, 10, 9, 0.0, 0.0),
        # too close to the end to be called an intercalation
        (91, 10, 13, 14, 15, 16, 0.0, 0.0),
    ], columns=["step", "frame", "cell_a", "cell_b", "cell_c", "cell_d", "x", "y"])
    ev = vertex_model_events(log, n_frames=11, censor=2)
    assert ev[["kind", "frame_start", "cell_a", "cell_b", "cell_c", "cell_d"]].values.tolist() == [
        ["intercalation", 2, 1, 2, 3, 4], ["cycle", 4, 9, 10, 11, 12], ["unresolved", 10, 13, 14, 15, 16]]
    assert ev["frame_end"].tolist()[1] == 7 and ev["duration"].tolist()[1] == 3
    assert np.isnan(ev["frame_end"].tolist()[0])


def test_bad_parameters_name_the_argument():
    with pytest.raises(InputError, match="new_length"):
        vertex_model_movie(t1_length=1.0, new_length=0.5)
    with pytest.raises(InputError, match="n_cells"):
        vertex_model_movie(n_cells=4)
