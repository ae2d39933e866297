"""Linking two frames' cells by overlap: divisions first, then an optimal one-to-one assignment by IoU."""
from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.optimize import linear_sum_assignment

from .._components import components
from ..errors import InputError
from ..mesh.labels import validate_labels
from . import _kernels
from .._dispatch import Kernels
from .overlap import _DENSE_LIMIT, _Compact, _compact, _contingency

K = Kernels(_kernels, "hexatissue.track._reference", names={"_division_kernel": "_division_reference"})


def _divisions(i, j, n, area_a, area_b, child_fraction, mother_fraction, min_iou):
    """Mother index -> two daughter indices, from overlaps.

    A daughter candidate of mother ``i`` is a cell ``j`` lying mostly inside
    ``i`` (``n_ij >= child_fraction * area_j``) and holding a sizeable part of
    it (``n_ij >= mother_fraction * area_i``), and that is not the best
    successor (highest IoU, at least ``min_iou / 2``) of another cell: a
    neighbour that took over part of ``i`` is not its daughter.  A mother with
    two or more candidates divided; its two largest overlaps are the daughters
    (ties: the earlier pair of ``i, j, n``).

    Returns
    -------
    mothers : (m,) int64 array
        Indices into ``area_a``, ascending.
    daughters : (m, 2) int64 array
        Indices into ``area_b``, the larger overlap first.
    """
    i, j, n = (np.ascontiguousarray(x, np.int64) for x in (i, j, n))
    mothers, first, second = K._division_kernel(i, j, n, np.asarray(area_a, np.int64), np.asarray(area_b, np.int64),
                                              float(child_fraction), float(mother_fraction), float(min_iou))
    return mothers, np.stack((first, second), axis=1)


def _assign(i, j, iou):
    """Links maximising the summed IoU over the candidate pairs ``(i, j, iou)``; returns (i, j, iou) linked.

    Candidates that are the only option of both their row and their column
    are linked directly; the rest is solved with linear_sum_assignment, per
    connected component when it is large.
    """
    empty = (np.empty(0, np.int64), np.empty(0, np.int64), np.empty(0))
    if len(i) == 0:
        return empty
    row_deg = np.bincount(i)[i]
    col_deg = np.bincount(j)[j]
    alone = (row_deg == 1) & (col_deg == 1)
    out = [(i[alone], j[alone], iou[alone])]
    i, j, iou = i[~alone], j[~alone], iou[~alone]
    if len(i):
        rows, ri = np.unique(i, return_inverse=True)
        cols, cj = np.unique(j, return_inverse=True)
        if len(rows) * len(cols) <= _DENSE_LIMIT:
            groups = [np.arange(len(i))]
        else:  # large problem: the candidate graph splits into independent components
            comp = components(len(rows) + len(cols), ri, len(rows) + cj)[ri]
            order = np.argsort(comp, kind="stable")
            groups = np.split(order, np.flatnonzero(np.diff(comp[order])) + 1)
        for sel in groups:
            sr, sri = np.unique(ri[sel], return_inverse=True)
            sc, sci = np.unique(cj[sel], return_inverse=True)
            dense = np.zeros((len(sr), len(sc)))
            dense[sri, sci] = iou[sel]
            r, c = linear_sum_assignment(dense, maximize=True)
            value = dense[r, c]
            keep = value > 0
            out.append((rows[sr[r[keep]]], cols[sc[c[keep]]], value[keep]))
    return tuple(np.concatenate(parts) for parts in zip(*out))


def _link(i, j, n, area_a, area_b, min_iou, child_fraction, mother_fraction):
    """Divisions, then one-to-one links maximising the summed IoU, from overlaps ``(i, j, n)``.

    Returns ``(r, c, iou of each link, mothers, daughters)``.
    """
    mothers, daughters = _divisions(i, j, n, area_a, area_b, child_fraction, mother_fraction, min_iou)
    if len(mothers):  # mothers and daughters leave the one-to-one assignment
        free = ~(np.isin(i, mothers) | np.isin(j, daughters.ravel()))
        i, j, n = i[free], j[free], n[free]
    iou = n / (area_a[i] + area_b[j] - n)
    cand = iou >= min_iou
    r, c, value = _assign(i[cand], j[cand], iou[cand])
    return r, c, value, mothers, daughters


def _match(a: _Compact, b: _Compact, min_iou, child_fraction, mother_fraction):
    i, j, n = _contingency(a, b)
    r, c, _, mothers, daughters = _link(i, j, n, a.area, b.area, min_iou, child_fraction, mother_fraction)
    return r, c, mothers, daughters


def match_frames(prev, cur, min_iou=0.2, child_fraction=0.6, mother_fraction=0.2):
    """Links between the cells of two consecutive label images.

    Parameters
    ----------
    prev, cur : (rows, cols) int arrays
        Label images indexed ``[row, col]``; 0 = background.
    min_iou : float
        Smallest IoU of a candidate link; among the candidates the links
        maximise the summed IoU (one-to-one).
    child_fraction, mother_fraction : float
        Division rule: a cell of ``cur`` is a daughter of a cell of ``prev``
        when at least ``child_fraction`` of the daughter and at least
        ``mother_fraction`` of the mother overlap; a cell with two or more
        daughters divided (its two largest overlaps are kept).

    Returns
    -------
    links : pandas.DataFrame
        ``cell_prev``, ``cell_next`` (label ids) of the one-to-one links.
    divisions : pandas.DataFrame
        ``mother`` (id in ``prev``), ``daughter_a``, ``daughter_b`` (ids in ``cur``).
    """
    a, b = _compact(validate_labels(prev, "prev")), _compact(validate_labels(cur, "cur"))
    if a.index.shape != b.index.shape:
        raise InputError(f"prev and cur must have the same shape; got {np.shape(prev)} and {np.shape(cur)}")
    r, c, mothers, daughters = _match(a, b, min_iou, child_fraction, mother_fraction)
    links = pd.DataFrame({"cell_prev": a.ids[r], "cell_next": b.ids[c]})
    divisions = pd.DataFrame(
        {"mother": a.ids[mothers], "daughter_a": b.ids[daughters[:, 0]], "daughter_b": b.ids[daughters[:, 1]]}
    )
    return links, divisions


def _check_fractions(min_iou, child_fraction, mother_fraction):
    for name, value in (("min_iou", min_iou), ("child_fraction", child_fraction),
                        ("mother_fraction", mother_fraction)):
        if not 0 < value <= 1:
            raise InputError(f"{name} must be in (0, 1]; got {value!r}")
