"""T1 kinds (cycle, intercalation, unresolved) and the right-censoring window that separates the last two."""
from __future__ import annotations

import numpy as np
import pandas as pd

from .._dispatch import Kernels
from ..errors import InputError
from ..schema import string_column
from . import _kernels


# the kernels, or their references (:mod:`hexatissue._dispatch`); not ``K``, which names the key base here
KERNELS = Kernels(_kernels, "hexatissue.events._reference", names={"_undo_pairs": "_undo_pairs_reference",
                                                                  "_excursion_starts": "_excursion_starts_reference"})


#: The ``kind`` of a T1 (quartet or per-cell event); tables are built from codes, its indices.
T1_KINDS = ("cycle", "intercalation", "unresolved")
CYCLE, INTERCALATION, UNRESOLVED = range(3)


#: Longest default censoring window, frames (enough for most T1 cycles of MPF runs, see docs/t1.md).
CENSOR_MAX = 10
#: The default censoring window is at most a fifth of the movie (``n_frames // CENSOR_DIVISOR``).
CENSOR_DIVISOR = 5


def default_censor(n_frames) -> int:
    """Censoring window used when none is given: ``min(10, max(1, n_frames // 5))`` frames.

    Long movies get :data:`CENSOR_MAX` (10) frames; a short one keeps four
    fifths of its frames classifiable (11 frames -> 2, 10 -> 2, 301 -> 10),
    and never less than 1: a T1 in the last frame cannot be classified.

    Parameters
    ----------
    n_frames : int
        Frames of the movie.

    Returns
    -------
    int
        Frames.
    """
    if isinstance(n_frames, bool) or int(n_frames) != n_frames or n_frames < 0:
        raise InputError(f"n_frames must be a non-negative integer; got {n_frames!r}")
    return min(CENSOR_MAX, max(1, int(n_frames) // CENSOR_DIVISOR))


def classify_t1(t1: pd.DataFrame, last_frame: int, censor: int = 10) -> pd.DataFrame:
    """Pair each T1 with its inverse on the same quartet: cycles, intercalations, unresolved.

    Parameters
    ----------
    t1 : pandas.DataFrame
        Output of :func:`find_t1`.
    last_frame : int
        Last frame of the movie.
    censor : int
        A T1 not undone whose ``frame_start`` is fewer than ``censor`` frames
        before ``last_frame`` is ``unresolved`` instead of ``intercalation``.

    Returns
    -------
    pandas.DataFrame
        ``kind``, ``frame_start``, ``frame_end``, ``duration``, ``cell_a``..``cell_d``,
        ``frame_gain``, ``frame_undo`` (see ``hexatissue.schema.TABLES["events"]``).
    """
    _check_censor(censor)
    df = t1.copy()
    K = np.int64(max([int(df[c].max()) if len(df) else 0 for c in ("cell_a", "cell_b", "cell_c", "cell_d")]) + 1)
    ab = df["cell_a"].to_numpy(np.int64) * K + df["cell_b"].to_numpy(np.int64)
    cd = df["cell_c"].to_numpy(np.int64) * K + df["cell_d"].to_numpy(np.int64)
    # the unordered quartet {a-b, c-d} is the key pairing a T1 with its inverse
    df["q_lo"], df["q_hi"] = np.minimum(ab, cd), np.maximum(ab, cd)
    df = df.sort_values(["q_lo", "q_hi", "frame_lost"], kind="stable").reset_index(drop=True)
    cells = {c: df[c].to_numpy(np.int64) for c in ("cell_a", "cell_b", "cell_c", "cell_d")}
    lost, gain = df["frame_lost"].to_numpy(np.int64), df["frame_gain"].to_numpy(np.int64)
    q_lo, q_hi = df["q_lo"].to_numpy(), df["q_hi"].to_numpy()
    # T1 k is undone by T1 k + 1: the same quartet, the contact lost by k + 1 the one k gained
    undone = np.zeros(len(lost), bool)
    undone[:-1] = (q_lo[1:] == q_lo[:-1]) & (q_hi[1:] == q_hi[:-1]) & (cells["cell_a"][1:] == cells["cell_c"][:-1]) \
        & (cells["cell_b"][1:] == cells["cell_d"][:-1])
    first, cycle = KERNELS._undo_pairs(undone)
    kind = _kind_codes(cycle, lost[first], last_frame, censor)
    undo = np.minimum(first + 1, len(lost) - 1)  # the inverse T1 of a cycle (clipped where there is none)
    end, undo_at = np.where(cycle, gain[undo], np.nan), np.where(cycle, lost[undo], np.nan)
    order = np.lexsort((cells["cell_b"][first], cells["cell_a"][first], lost[first]))  # as sort_values: stable
    first, kind, end, undo_at = first[order], kind[order], end[order], undo_at[order]
    return pd.DataFrame({"kind": string_column(kind, T1_KINDS), "frame_start": lost[first], "frame_end": end,
                         "duration": end - lost[first], **{c: v[first] for c, v in cells.items()},
                         "frame_gain": gain[first], "frame_undo": undo_at})


def _kind_codes(cycle, start, last_frame, censor):
    """:data:`T1_KINDS` codes: a cycle, else unresolved when it started fewer than ``censor`` frames before the end."""
    return np.where(cycle, CYCLE, np.where(last_frame - start < censor, UNRESOLVED, INTERCALATION)).astype(np.int8)


def _check_censor(censor):
    if int(censor) != censor or censor < 0:
        raise InputError(f"censor must be a non-negative integer number of frames; got {censor!r}")
