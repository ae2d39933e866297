"""Scoring a prediction against exact truth: segmentation, junction network, tracking, T1 events, gamma_p.

``score(prediction, truth)`` compares two hexatissue results (folders
written by ``hexatissue analyze`` / ``benchmark make``, or Movies) frame by
frame.  Everything rests on one cell matching per frame, made from the two
label images (x = column, y = row, px, as everywhere):

- a truth cell R is *covered* by the predicted cell S holding more than
  half of R's pixels (the Cell Tracking Challenge SEG rule; at most one S);
- a predicted cell S *belongs* to the truth cell holding more than half of
  S's pixels;
- R and S are *matched* when their Jaccard index |R & S| / |R | S| exceeds
  0.5 (one-to-one; a matched pair is always a covering pair).

Network, tracking, T1 and gamma_p scores map the prediction's cells,
pairs, links and quartets to truth ids through the matched pairs.  Every
score in :attr:`Scores.summary` lies in [0, 1] with 1 = perfect; a score
whose denominator is empty (no T1 event in the truth, no division
predicted, ...) is left out, never set to 1.  The exact definitions are in
``docs/benchmark.md`` ("Scoring").
"""
from __future__ import annotations

import json
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from ..errors import HexatissueWarning, InputError, check_positive, user_stacklevel
from ..results import Movie, read_results
from ..geometry import match_points
from ..progress import progress
from ..schema import interior_mask, track_ids
from ..track import count_overlaps

__all__ = ["Scores", "score", "score_to_folder", "plot_scores", "SCORE_NAMES"]

#: Every score :func:`score` can report, in the order of the summary and the figure.
SCORE_NAMES = ("seg_jaccard", "split_score", "merge_score", "missed_score", "extra_score",
               "neighbour_pairs_precision", "neighbour_pairs_recall", "vertex_precision", "vertex_recall",
               "n_sides_accuracy", "link_precision", "link_recall", "division_precision", "division_recall",
               "t1_precision", "t1_recall", "t1_kind_accuracy")
LABELS_FILE = "labels.tif"  # the label stack beside the tables of a truth folder (benchmark make)


@dataclass
class Scores:
    """The result of :func:`score`.

    Attributes
    ----------
    summary : dict
        Score name -> value in [0, 1] (1 = perfect), in :data:`SCORE_NAMES`
        order, then ``gamma{p}_score`` for every p both sides have; scores
        that cannot be computed are absent.
    counts : dict
        The numbers behind the scores: cells, pairs, vertices, links,
        divisions and T1 events of each side and how many were matched;
        ``n_split``, ``n_merge``, ``n_missed``, ``n_extra``;
        ``gamma{p}_mean_error`` (mean ``|gamma_p,pred - gamma_p,true|`` of the
        matched interior cells, in [0, 2]).
    tables : dict of str -> pandas.DataFrame
        ``cells`` (one row per truth cell and frame), ``pred_cells`` (per
        predicted cell and frame), ``neighbour_pairs``, ``vertices``,
        ``links``, ``divisions``, ``t1`` (columns in ``docs/benchmark.md``).
        Only the tables of computed scores are present.
    notes : list of str
        Why scores were left out.
    """

    summary: dict
    counts: dict
    tables: dict
    notes: list = field(default_factory=list)

    def text(self) -> str:
        """A one-screen summary: every score, then the counts behind them."""
        lines = ["score                          value"]
        lines += [f"{name:<30} {value:.4f}" for name, value in self.summary.items()]
        c = self.counts
        lines.append("")
        for label, keys in (("cells (truth / pred / matched)", ("n_truth_cells", "n_pred_cells", "n_matched_cells")),
                            ("split / merge / missed / extra", ("n_split", "n_merge", "n_missed", "n_extra")),
                            ("neighbour pairs (truth / pred / matched)",
                             ("n_truth_pairs", "n_pred_pairs", "n_matched_pairs")),
                            ("vertices (truth / pred / matched)",
                             ("n_truth_vertices", "n_pred_vertices", "n_matched_vertices")),
                            ("links (truth / pred / matched)", ("n_truth_links", "n_pred_links", "n_matched_links")),
                            ("divisions (truth / pred / matched)",
                             ("n_truth_divisions", "n_pred_divisions", "n_matched_divisions")),
                            ("T1 events (truth / pred / matched / right kind)",
                             ("n_truth_t1", "n_pred_t1", "n_matched_t1", "n_t1_right_kind"))):
            if all(k in c for k in keys):
                lines.append(f"{label}: " + " / ".join(str(c[k]) for k in keys))
        lines += [f"{k}: {v:.4f}" for k, v in c.items() if k.endswith("_mean_error")]
        lines += [f"note: {n}" for n in self.notes]
        return "\n".join(lines)


# ---------------------------------------------------------------------------------------------------------
# inputs
# ---------------------------------------------------------------------------------------------------------
class _Labels:
    """The normalised label image of frame t, as the mesh saw it (same kind, membranes shared out, mask)."""

    def __init__(self, source, movie):
        from ..options import MeshOptions
        from ..source import recorded_mask

        self.source, self.mesh, self.box = source, movie.options.get("mesh", MeshOptions()), movie.box
        self.mask, info = recorded_mask(movie.source, source.shape)
        if info is not None and self.mask is None:
            warnings.warn("these results were computed with a mask given as an array, which the results folder "
                          "does not hold: the labels are scored without it (cells outside it count as extra or "
                          "missed)", HexatissueWarning, stacklevel=user_stacklevel())

    def __call__(self, t) -> np.ndarray:
        from ..mesh.labels import mesh_labels

        return mesh_labels(self.source.checked_frame(t, self.mesh.kind)[0], self.box, self.mesh, self.mask)[0]  # as the analysis saw them


def _side(obj, labels, name, box):
    """``(Movie, _Labels or None, where the labels came from)`` for one side of :func:`score`."""
    from ..options import OrderOptions
    from ..source import open_source, recorded_labels

    folder = None
    if isinstance(obj, Movie):
        movie = obj
    elif isinstance(obj, (str, Path)) and Path(obj).is_dir() and (Path(obj) / "metadata.json").exists():
        folder = Path(obj)
        movie = read_results(folder, lazy=False)
    else:  # a label movie: analyse it (its tables are then those of hexatissue analyze with default options)
        from ..pipeline import analyze

        try:
            src = open_source(obj)
        except InputError as exc:
            raise InputError(f"{name} must be a results folder, a Movie or a label movie; {exc}") from None
        movie = analyze(src, box=box or False, order=OrderOptions(p=(6,), fields=False), workers=1, progress=False)
        return movie, _Labels(src, movie), "analysed label movie"
    if labels is not None:
        return movie, _Labels(open_source(labels), movie), f"{name}_labels argument"
    if folder is not None and (folder / LABELS_FILE).exists():
        return movie, _Labels(open_source(folder / LABELS_FILE), movie), str(folder / LABELS_FILE)
    src = recorded_labels(movie.source)[0]
    if src is not None:
        return movie, _Labels(src, movie), movie.source["path"]
    return movie, None, None


# ---------------------------------------------------------------------------------------------------------
# cell matching and segmentation
# ---------------------------------------------------------------------------------------------------------
def _overlaps(t, truth, pred):
    """Frame t's overlaps (``frame``, ``truth``, ``pred``, ``n`` px; both ids > 0) and the cells' areas."""
    if truth.shape != pred.shape:
        raise InputError(f"frame {t}: the prediction's labels have shape {pred.shape} and the truth's {truth.shape}; "
                         f"expected the same image size")
    ov = count_overlaps(truth, pred)  # the tracker's overlap counts: pairs sorted by (truth, pred)
    areas = [pd.DataFrame({"frame": np.int64(t), "cell": ids, "area": area})
             for ids, area in ((ov.ids_prev, ov.area_prev), (ov.ids_next, ov.area_next))]
    return pd.DataFrame({"frame": np.int64(t), "truth": ov.ids_prev[ov.i], "pred": ov.ids_next[ov.j],
                         "n": ov.n}), *areas


def _match_cells(truth_labels, pred_labels, n_frames, show_progress):
    """The truth-cell and predicted-cell tables of every frame (matching rules in the module docstring)."""
    parts = [_overlaps(t, truth_labels(t), pred_labels(t))
             for t in progress(range(n_frames), enabled=show_progress, desc="matching cells", unit="frame")]
    ov, t_area, p_area = (pd.concat([p[k] for p in parts], ignore_index=True) for k in range(3))
    ov = ov.merge(t_area.rename(columns={"cell": "truth", "area": "at"}), on=["frame", "truth"]).merge(
        p_area.rename(columns={"cell": "pred", "area": "ap"}), on=["frame", "pred"])
    ov["iou"] = ov["n"] / (ov["at"] + ov["ap"] - ov["n"])
    covers = ov[2 * ov["n"] > ov["at"]]  # the truth cell's SEG match (at most one per truth cell)
    belongs = ov[2 * ov["n"] > ov["ap"]]  # the predicted cell lies mostly in this truth cell
    matched = ov[ov["iou"] > 0.5]
    cells = _attach(t_area, covers, "truth", "pred", "seg_cell", 0)
    cells = _attach(cells, covers, "truth", "iou", "jaccard", 0.0)
    cells = _attach(cells, matched, "truth", "pred", "pred_cell", 0)
    parts = belongs.groupby(["frame", "truth"], as_index=False).size()
    cells = _attach(cells, parts, "truth", "size", "n_parts", 0)
    cells["is_split"] = cells["n_parts"] >= 2
    cells["is_missed"] = (cells["seg_cell"] == 0) & (cells.pop("n_parts") == 0)
    pred_cells = _attach(p_area, matched, "pred", "truth", "truth_cell", 0)
    covered = covers.groupby(["frame", "pred"], as_index=False).size()
    pred_cells = _attach(pred_cells, covered, "pred", "size", "n_covered", 0)
    pred_cells = _attach(pred_cells, belongs, "pred", "truth", "owner", 0)
    pred_cells["is_merge"] = pred_cells["n_covered"] >= 2
    pred_cells["is_extra"] = (pred_cells.pop("n_covered") == 0) & (pred_cells.pop("owner") == 0)
    return (cells.astype({"seg_cell": np.int64, "pred_cell": np.int64}),
            pred_cells.astype({"truth_cell": np.int64}))


def _attach(df, table, key, value, name, fill):
    """``df`` (``frame``, ``cell``) with column ``name``: ``table[value]`` where ``table[key]`` is the cell, else
    ``fill``."""
    got = table[["frame", key, value]].rename(columns={key: "cell", value: name})
    return df.merge(got, on=["frame", "cell"], how="left").fillna({name: fill})


def _segmentation(cells, pred_cells, summary, counts):
    n_t, n_p = len(cells), len(pred_cells)
    counts.update(n_truth_cells=n_t, n_pred_cells=n_p, n_matched_cells=int((cells["pred_cell"] > 0).sum()),
                  n_split=int(cells["is_split"].sum()), n_merge=int(pred_cells["is_merge"].sum()),
                  n_missed=int(cells["is_missed"].sum()), n_extra=int(pred_cells["is_extra"].sum()))
    if n_t:
        summary["seg_jaccard"] = float(cells["jaccard"].mean())
        summary["split_score"] = 1.0 - counts["n_split"] / n_t
        summary["missed_score"] = 1.0 - counts["n_missed"] / n_t
    if n_p:
        summary["merge_score"] = 1.0 - counts["n_merge"] / n_p
        summary["extra_score"] = 1.0 - counts["n_extra"] / n_p


def _to_truth(cells):
    """``frame``, ``pred``, ``truth``: the matched pairs (the mapping every later score uses)."""
    m = cells[cells["pred_cell"] > 0]
    return pd.DataFrame({"frame": m["frame"].to_numpy(np.int64), "pred": m["pred_cell"].to_numpy(np.int64),
                         "truth": m["cell"].to_numpy(np.int64)})


def _map(table, columns, to_truth):
    """``table`` with ``t_<column>`` for each predicted cell id column: its matched truth cell in the row's
    frame (0 if none)."""
    known = _keys(to_truth["frame"], to_truth["pred"])  # unique: one truth cell per predicted cell and frame
    truth = np.r_[to_truth["truth"].to_numpy(np.int64), 0]  # index -1 (not matched) reads the 0 at the end
    out = table.copy()
    for col in columns:
        out[f"t_{col}"] = truth[known.get_indexer(_keys(out["frame"], out[col]))]
    return out


def _keys(*columns):
    """Rows of equal-length columns as one index of tuples (vectorised lookups and membership)."""
    return pd.MultiIndex.from_arrays([np.asarray(c, np.int64) for c in columns])


def _ratio(summary, name, num, den):
    if den:
        summary[name] = num / den


# ---------------------------------------------------------------------------------------------------------
# junction network
# ---------------------------------------------------------------------------------------------------------
def _pairs(edges):
    """Distinct cell-cell contacts of every frame: ``frame``, ``a`` < ``b`` (both > 0)."""
    a, b = edges["cell_a"].to_numpy(np.int64), edges["cell_b"].to_numpy(np.int64)
    keep = (a > 0) & (b > 0)
    out = pd.DataFrame({"frame": edges["frame"].to_numpy(np.int64)[keep], "a": np.minimum(a, b)[keep],
                        "b": np.maximum(a, b)[keep]})
    return out.drop_duplicates(ignore_index=True)


def _neighbour_pairs(truth, pred, to_truth, summary, counts):
    tp, pp = _pairs(truth.edges), _pairs(pred.edges)
    pp = _map(pp, ["a", "b"], to_truth)
    lo, hi = np.minimum(pp["t_a"], pp["t_b"]), np.maximum(pp["t_a"], pp["t_b"])
    mapped = pd.DataFrame({"frame": pp["frame"], "a": np.where(lo > 0, lo, 0), "b": np.where(lo > 0, hi, 0),
                           "pred_a": pp["a"], "pred_b": pp["b"]})
    table = tp.merge(mapped[mapped["a"] > 0], on=["frame", "a", "b"], how="outer", indicator=True)
    table = pd.concat([table, mapped[mapped["a"] == 0].assign(_merge="right_only")], ignore_index=True)
    table["status"] = table.pop("_merge").map({"both": "matched", "left_only": "missed", "right_only": "extra"})
    table = table.rename(columns={"a": "cell_a", "b": "cell_b"})
    for col in ("cell_a", "cell_b", "pred_a", "pred_b"):
        table[col] = table[col].fillna(0).astype(np.int64)
    n_match = int((table["status"] == "matched").sum())
    counts.update(n_truth_pairs=len(tp), n_pred_pairs=len(pp), n_matched_pairs=n_match)
    _ratio(summary, "neighbour_pairs_precision", n_match, len(pp))
    _ratio(summary, "neighbour_pairs_recall", n_match, len(tp))
    return table.sort_values(["frame", "cell_a", "cell_b", "pred_a", "pred_b"], ignore_index=True)


def _vertices(truth, pred, radius, box, summary, counts):
    rows = []
    tv, pv = truth.vertices, pred.vertices
    t_groups, p_groups = dict(tuple(tv.groupby("frame"))), dict(tuple(pv.groupby("frame")))
    n_match = 0
    for t in sorted(set(t_groups) | set(p_groups)):
        a = t_groups.get(t, tv.iloc[:0])
        b = p_groups.get(t, pv.iloc[:0])
        pairs = match_points(a[["x", "y"]].to_numpy(), b[["x", "y"]].to_numpy(), radius, box)
        ia, ib = pairs[:, 0].astype(int), pairs[:, 1].astype(int)
        n_match += len(pairs)
        va, vb = a["vertex"].to_numpy(np.int64), b["vertex"].to_numpy(np.int64)
        missed, extra = np.setdiff1d(np.arange(len(a)), ia), np.setdiff1d(np.arange(len(b)), ib)
        rows.append(pd.DataFrame({
            "frame": np.int64(t), "vertex": np.r_[va[ia], va[missed], np.zeros(len(extra), np.int64)],
            "pred_vertex": np.r_[vb[ib], np.zeros(len(missed), np.int64), vb[extra]],
            "distance": np.r_[pairs[:, 2], np.full(len(missed) + len(extra), np.nan)],
            "status": ["matched"] * len(ia) + ["missed"] * len(missed) + ["extra"] * len(extra)}))
    counts.update(n_truth_vertices=len(tv), n_pred_vertices=len(pv), n_matched_vertices=n_match)
    _ratio(summary, "vertex_precision", n_match, len(pv))
    _ratio(summary, "vertex_recall", n_match, len(tv))
    return pd.concat(rows, ignore_index=True) if rows else pd.DataFrame(
        columns=["frame", "vertex", "pred_vertex", "distance", "status"])


def _per_cell(truth, pred, cells, summary, counts):
    """n_sides and gamma_p of the matched cells, added to the truth-cells table; their scores."""
    keys = ["frame", "cell"]
    t_cols = [c for c in truth.cells.columns if c == "n_sides" or (c.startswith("gamma") and c[-3:] in ("_re", "_im"))]
    tc = truth.cells[keys + t_cols].assign(is_border=~interior_mask(truth.cells), track=track_ids(truth.cells))
    p_cols = [c for c in t_cols if c in pred.cells.columns]
    pc = pred.cells[keys + p_cols].rename(columns={"cell": "pred_cell", **{c: f"pred_{c}" for c in p_cols}})
    out = cells.merge(tc, on=keys, how="left").merge(pc, on=["frame", "pred_cell"], how="left")
    scored = (out["pred_cell"] > 0) & ~out["is_border"].fillna(True).astype(bool)
    if "n_sides" in p_cols:
        ok = scored & (out["n_sides"] >= 3)
        counts["n_sides_cells"] = int(ok.sum())
        _ratio(summary, "n_sides_accuracy", int((out["n_sides"][ok] == out["pred_n_sides"][ok]).sum()), int(ok.sum()))
    for p in sorted({int(c[5:-3]) for c in p_cols if c.startswith("gamma") and c.endswith("_re")}):
        re, im = f"gamma{p}_re", f"gamma{p}_im"
        if im not in p_cols:
            continue
        err = np.hypot(out[f"pred_{re}"] - out[re], out[f"pred_{im}"] - out[im])
        out[f"gamma{p}_error"] = err.where(scored)
        valid = err[scored].dropna()
        if len(valid):
            counts[f"gamma{p}_mean_error"] = float(valid.mean())
            summary[f"gamma{p}_score"] = 1.0 - float(valid.mean()) / 2.0  # |gamma_p| <= 1: errors lie in [0, 2]
    return out


# ---------------------------------------------------------------------------------------------------------
# tracking
# ---------------------------------------------------------------------------------------------------------
def _links(cells):
    """Track links t -> t+1: ``frame`` (t), ``track``, ``cell`` (at t), ``cell_next`` (at t+1)."""
    c = pd.DataFrame({"frame": cells["frame"].to_numpy(np.int64), "track": track_ids(cells),
                      "cell": cells["cell"].to_numpy(np.int64)})
    nxt = c.assign(frame=c["frame"] - 1).rename(columns={"cell": "cell_next"})
    return c.merge(nxt, on=["frame", "track"])


def _tracking(truth, pred, to_truth, summary, counts):
    tl, pl = _links(truth.cells), _links(pred.cells)
    pl = _map(pl, ["cell"], to_truth)
    pl["t_cell_next"] = _map(pl.assign(frame=pl["frame"] + 1), ["cell_next"], to_truth)["t_cell_next"]
    truth_links, pred_links = _keys(tl["frame"], tl["cell"], tl["cell_next"]), _keys(
        pl["frame"], pl["t_cell"], pl["t_cell_next"])
    hit = pred_links.isin(truth_links)
    table = pd.concat([
        tl.assign(status=np.where(truth_links.isin(pred_links[hit]), "matched", "missed")),
        pd.DataFrame({"frame": pl["frame"][~hit], "track": 0, "cell": pl["t_cell"][~hit],
                      "cell_next": pl["t_cell_next"][~hit], "pred_track": pl["track"][~hit],
                      "pred_cell": pl["cell"][~hit], "pred_cell_next": pl["cell_next"][~hit], "status": "extra"})],
        ignore_index=True)
    n_match = int(hit.sum())
    counts.update(n_truth_links=len(tl), n_pred_links=len(pl), n_matched_links=n_match)
    _ratio(summary, "link_precision", n_match, len(pl))
    _ratio(summary, "link_recall", n_match, len(tl))
    return table.fillna({"pred_track": 0, "pred_cell": 0, "pred_cell_next": 0}).astype(
        {"pred_track": np.int64, "pred_cell": np.int64, "pred_cell_next": np.int64})


def _track_lookup(movie, to_truth, truth):
    """``{(frame, predicted track): truth track}`` of every matched predicted cell."""
    p = pd.DataFrame({"frame": movie.cells["frame"].to_numpy(np.int64), "pred": movie.cells["cell"].to_numpy(np.int64),
                      "ptrack": track_ids(movie.cells)})
    t = pd.DataFrame({"frame": truth.cells["frame"].to_numpy(np.int64),
                      "truth": truth.cells["cell"].to_numpy(np.int64), "ttrack": track_ids(truth.cells)})
    m = p.merge(to_truth, on=["frame", "pred"]).merge(t, on=["frame", "truth"])
    return dict(zip(zip(m["frame"].to_numpy(), m["ptrack"].to_numpy()), m["ttrack"].to_numpy()))


def _greedy(pairs):
    """One-to-one choice among ``(cost, pred, truth)`` candidates, cheapest first (ties: lower ids first)."""
    used_p, used_t, out = set(), set(), {}
    for cost, p, t in sorted(pairs):
        if p not in used_p and t not in used_t:
            used_p.add(p), used_t.add(t)
            out[p] = t
    return out


def _divisions(movie):
    """``parent`` track and ``frame`` (first frame of the daughters) of every division of a lineage."""
    lin = movie.lineage
    if lin is None:
        return None
    d = lin[lin["parent"] > 0]
    return d.groupby("parent", as_index=False)["frame_start"].min().rename(columns={"frame_start": "frame"})


def _division_scores(truth, pred, lookup, tolerance, summary, counts):
    td, pd_ = _divisions(truth), _divisions(pred)
    if td is None or pd_ is None:
        return None
    cand = []
    t_frame = td["frame"].to_numpy(np.int64)
    order = np.argsort(t_frame, kind="stable")
    for k, p in enumerate(pd_.itertuples()):
        # only the truth divisions within the frame tolerance (not every one)
        lo, hi = np.searchsorted(t_frame[order], [int(p.frame) - tolerance, int(p.frame) + tolerance + 1])
        for m in order[lo:hi].tolist():
            t = td.iloc[m]
            gap = abs(int(p.frame) - int(t.frame))
            # the predicted mother before either side's division, mapped to a truth track
            if gap <= tolerance and lookup.get((min(p.frame, t.frame) - 1, p.parent)) == t.parent:
                cand.append((gap, k, m))
    chosen = _greedy(cand)
    by_truth = {m: k for k, m in chosen.items()}
    rows = [(int(t.parent), int(t.frame), int(pd_["parent"].iloc[by_truth[m]]) if m in by_truth else 0,
             int(pd_["frame"].iloc[by_truth[m]]) if m in by_truth else -1, "matched" if m in by_truth else "missed")
            for m, t in enumerate(td.itertuples())]
    rows += [(0, -1, int(p.parent), int(p.frame), "extra") for k, p in enumerate(pd_.itertuples()) if k not in chosen]
    table = pd.DataFrame(rows, columns=["parent", "frame", "pred_parent", "pred_frame", "status"])
    counts.update(n_truth_divisions=len(td), n_pred_divisions=len(pd_), n_matched_divisions=len(chosen))
    _ratio(summary, "division_precision", len(chosen), len(pd_))
    _ratio(summary, "division_recall", len(chosen), len(td))
    return table


# ---------------------------------------------------------------------------------------------------------
# T1 events
# ---------------------------------------------------------------------------------------------------------
def _mapped_quartet(event, lookup):
    """The truth tracks of a predicted event's a, b, c, d: each read at the last frame with the a-b contact,
    else at frame_start, else at frame_gain (the first frame where that cell is matched)."""
    frames = (int(event.frame_start) - 1, int(event.frame_start), int(getattr(event, "frame_gain", event.frame_start)))
    out = []
    for cell in (event.cell_a, event.cell_b, event.cell_c, event.cell_d):
        out.append(next((lookup[(f, int(cell))] for f in frames if (f, int(cell)) in lookup), 0))
    return out


def _quartet_key(a, b, c, d):
    """The T1 quartet {a, b} -> {c, d} as a key (each pair unordered)."""
    return min(a, b), max(a, b), min(c, d), max(c, d)


def _held(event):
    """The frames from the loss of a-b to the gain of c-d of an event: ``(frame_start, frame_gain)``."""
    start = int(event.frame_start)
    return start, max(start, int(getattr(event, "frame_gain", start)))


def _t1_scores(truth, pred, lookup, tolerance, summary, counts, timing="start"):
    te, pe = truth.events, pred.events
    if te is None or pe is None:
        return None
    # truth events by quartet (the pair losing, the pair gaining contact): each prediction meets only its own,
    # not every truth event
    by_quartet = {}
    for m, t in enumerate(te.itertuples()):
        key = _quartet_key(int(t.cell_a), int(t.cell_b), int(t.cell_c), int(t.cell_d))
        by_quartet.setdefault(key, []).append((m, _held(t)))
    cand = []
    mapped = [_mapped_quartet(e, lookup) for e in pe.itertuples()]
    for k, (p, quartet) in enumerate(zip(pe.itertuples(), mapped)):
        p_start, p_gain = _held(p)
        for m, (t_start, t_gain) in by_quartet.get(_quartet_key(*quartet), ()):
            if timing == "start":
                gap = abs(p_start - t_start)
            else:  # the frames between the two held intervals (0 when they overlap)
                gap = max(0, p_start - t_gain, t_start - p_gain)
            if gap <= tolerance:
                cand.append((gap, k, m))
    chosen = _greedy(cand)
    by_truth = {m: k for k, m in chosen.items()}
    cols = ["event", "kind", "frame_start", "cell_a", "cell_b", "cell_c", "cell_d"]
    rows = []
    for m, t in enumerate(te[cols].itertuples(index=False)):
        k = by_truth.get(m)
        p = pe.iloc[k] if k is not None else None
        rows.append((*t, -1 if p is None else int(p["event"]), "" if p is None else p["kind"],
                     -1 if p is None else int(p["frame_start"]), "missed" if p is None else "matched"))
    for k, p in enumerate(pe.itertuples()):
        if k not in chosen:
            rows.append((-1, "", -1, *mapped[k], int(p.event), p.kind, int(p.frame_start), "extra"))
    table = pd.DataFrame(rows, columns=cols + ["pred_event", "pred_kind", "pred_frame_start", "status"])
    right = int(((table["status"] == "matched") & (table["kind"] == table["pred_kind"])).sum())
    counts.update(n_truth_t1=len(te), n_pred_t1=len(pe), n_matched_t1=len(chosen), n_t1_right_kind=right)
    _ratio(summary, "t1_precision", len(chosen), len(pe))
    _ratio(summary, "t1_recall", len(chosen), len(te))
    _ratio(summary, "t1_kind_accuracy", right, len(chosen))
    return table


# ---------------------------------------------------------------------------------------------------------
# the public functions
# ---------------------------------------------------------------------------------------------------------
def _box_lengths(box):
    """``(Lx, Ly)`` of a periodic box, None for an open image (how the two sides' boxes are compared)."""
    return None if box is None else (float(box.Lx), float(box.Ly))


def score(prediction, truth, *, pred_labels=None, truth_labels=None, vertex_radius=3.0, frame_tolerance=2,
          t1_timing="start", show_progress=True) -> Scores:
    """Score a prediction against exact truth (segmentation, network, tracking, T1 events, gamma_p).

    Parameters
    ----------
    prediction, truth : str, Path, Movie or label movie
        A results folder (``hexatissue analyze``, ``benchmark make``'s
        ``truth/``), a :class:`~hexatissue.Movie`, or a label image / stack
        (path or array; it is analysed with default options, the truth's box,
        and gamma6 only).  Both sides must have the same frames and image size.
    pred_labels, truth_labels : path, array or Source, optional
        The label images the tables were computed from.  Default: the
        folder's ``labels.tif``, else the input recorded in the results'
        ``metadata.json`` (``source.path``).  Without labels on both sides
        no cell can be matched: only the vertex scores are computed (warning).
    vertex_radius : float
        Vertices closer than this are matched, px (default 3).
    frame_tolerance : int
        T1 events and divisions may be found this many frames early or late (default 2).
    t1_timing : {"start", "held"}
        When a T1 is on time.  ``"start"`` (default): its ``frame_start``
        (the first frame without the a-b contact) is within
        ``frame_tolerance`` of the truth's.  ``"held"``: the frames it holds
        a four-fold vertex, ``frame_start`` to ``frame_gain`` (the first frame
        with c-d), come within ``frame_tolerance`` of the truth's; a T1 is
        only known to lie somewhere in that interval.
    show_progress : bool
        Progress bar over the frames.

    Returns
    -------
    Scores
        ``summary`` (score name -> [0, 1], 1 = perfect), ``counts``,
        ``tables`` and ``notes``; definitions in ``docs/benchmark.md``.

    Raises
    ------
    InputError
        An input is not a results folder, Movie or label movie, or the two
        sides differ in frames or image size.

    Warns
    -----
    HexatissueWarning
        No labels were found for a side (matching-based scores left out), or
        the two sides' tables were computed with different boxes (a periodic
        truth against a prediction analysed as an open image).
    """
    vertex_radius = check_positive(vertex_radius, "vertex_radius", unit="px")
    if isinstance(frame_tolerance, bool) or not isinstance(frame_tolerance, (int, np.integer)) or frame_tolerance < 0:
        raise InputError(f"frame_tolerance must be a non-negative integer number of frames; got {frame_tolerance!r}")
    if t1_timing not in ("start", "held"):
        raise InputError(f"t1_timing must be 'start' or 'held'; got {t1_timing!r}")
    t_movie, t_labels, t_where = _side(truth, truth_labels, "truth", None)
    p_movie, p_labels, p_where = _side(prediction, pred_labels, "prediction", t_movie.box)
    if len(p_movie) != len(t_movie) or tuple(p_movie.shape) != tuple(t_movie.shape):
        raise InputError(f"the prediction has {len(p_movie)} frame(s) of {tuple(p_movie.shape)} and the truth "
                         f"{len(t_movie)} of {tuple(t_movie.shape)}; expected the same frames and image size")
    notes = []
    if _box_lengths(p_movie.box) != _box_lengths(t_movie.box):
        notes.append(f"the prediction was analysed with box {_box_lengths(p_movie.box)} and the truth with "
                     f"{_box_lengths(t_movie.box)} (None = an open image): cells crossing the box edge and "
                     f"the vertices there do not match; for a periodic truth analyse the prediction with "
                     f"`hexatissue analyze LABELS --periodic` (or box=)")
        warnings.warn(notes[-1], HexatissueWarning, stacklevel=user_stacklevel())
    for name, movie, lab, where in (("prediction", p_movie, p_labels, p_where), ("truth", t_movie, t_labels, t_where)):
        if lab is None:
            continue
        if lab.source.n_frames != len(movie) or tuple(lab.source.shape) != tuple(movie.shape):
            raise InputError(f"{name} labels ({where}) have {lab.source.n_frames} frame(s) of {lab.source.shape} "
                             f"but its tables {len(movie)} of {tuple(movie.shape)}; expected the labels the tables "
                             f"were computed from")
        notes.append(f"{name} labels: {where}")
    summary, counts, tables = {}, {}, {}
    missing = [name for name, lab in (("prediction", p_labels), ("truth", t_labels)) if lab is None]
    if missing:
        notes.append(f"no label images for the {' and the '.join(missing)} (pass pred_labels= / truth_labels=): "
                     f"segmentation, neighbour-pair, n_sides, tracking, T1 and gamma scores left out")
        warnings.warn(notes[-1], HexatissueWarning, stacklevel=user_stacklevel())
    else:
        cells, tables["pred_cells"] = _match_cells(t_labels, p_labels, len(t_movie), show_progress)
        _segmentation(cells, tables["pred_cells"], summary, counts)
        to_truth = _to_truth(cells)
        tables["neighbour_pairs"] = _neighbour_pairs(t_movie, p_movie, to_truth, summary, counts)
    tables["vertices"] = _vertices(t_movie, p_movie, vertex_radius, t_movie.box, summary, counts)
    if not missing:
        tables["cells"] = _per_cell(t_movie, p_movie, cells, summary, counts)
        if len(t_movie) > 1:
            tables["links"] = _tracking(t_movie, p_movie, to_truth, summary, counts)
            lookup = _track_lookup(p_movie, to_truth, t_movie)
            tables["divisions"] = _division_scores(t_movie, p_movie, lookup, frame_tolerance, summary, counts)
            tables["t1"] = _t1_scores(t_movie, p_movie, lookup, frame_tolerance, summary, counts, t1_timing)
            tables = {name: table for name, table in tables.items() if table is not None}
        else:
            notes.append("single frame: tracking and T1 scores left out")
    order = {name: k for k, name in enumerate(SCORE_NAMES)}
    summary = {k: float(summary[k]) for k in sorted(summary, key=lambda k: (order.get(k, len(order)), k))}
    left_out = [name for name in SCORE_NAMES if name not in summary]
    if left_out:
        notes.append(f"not computable (empty denominator or missing tables): {', '.join(left_out)}")
    return Scores(summary, counts, tables, notes)


def plot_scores(scores, path=None):
    """Horizontal bar chart of every score (1 = perfect); returns the Figure (PNG written when ``path``)."""
    from ..plot import _new_axes, save_figure

    names = list(scores.summary)
    fig, ax = _new_axes(None, (6.0, 0.28 * max(len(names), 4) + 1.0))
    y = np.arange(len(names))[::-1]
    values = np.array([scores.summary[n] for n in names])
    ax.barh(y, values, color=["#2a7ab0" if v >= 0.95 else "#d98c1f" if v >= 0.8 else "#c0392b" for v in values])
    for yy, v in zip(y, values):
        ax.text(min(v, 0.86) + 0.01, yy, f"{v:.3f}", va="center", fontsize=8)
    ax.set_yticks(y, names, fontsize=8)
    ax.set_xlim(0, 1)
    ax.set_xlabel("score (1 = perfect; blue >= 0.95, orange >= 0.8, red < 0.8)")
    ax.axvline(1.0, color="k", lw=0.8)
    ax.set_title("prediction vs truth", fontsize=10)
    if path is not None:
        save_figure(fig, path)
    return fig


def score_to_folder(scores, out, formats=("parquet",)) -> list[Path]:
    """Write ``scores`` to folder ``out``; returns the paths written.

    Files: every table (``<name>.parquet`` / ``.csv``), ``scores.json`` (the
    flat mapping score name -> value in [0, 1]), ``counts.json`` (the counts
    and mean errors behind them), ``summary.txt`` (:meth:`Scores.text`) and
    ``scores.png`` (bar chart).  Each file is written atomically.
    """
    from ..io import atomic_path, check_output_folder, write_tables

    out = check_output_folder(out, "out")
    written = write_tables(scores.tables, out, formats=tuple(formats))
    for name, text in (("scores.json", json.dumps(scores.summary, indent=2)),
                       ("counts.json", json.dumps(scores.counts, indent=2)), ("summary.txt", scores.text() + "\n")):
        with atomic_path(out / name) as tmp:
            tmp.write_text(text)
        written.append(out / name)
    plot_scores(scores, out / "scores.png")
    return written + [out / "scores.png"]
