"""Small helpers shared by the analyses: input checks, track ids, seeded generators."""
from __future__ import annotations

import numpy as np

from ..box import periodic_or_none as check_box  # noqa: F401  (the analyses work on periodic boxes or None)
from ..errors import InputError, check_positive  # noqa: F401  (re-exported)



def check_p(p):
    if isinstance(p, bool) or not isinstance(p, (int, np.integer)) or p < 1:
        raise InputError(f"p must be a positive integer symmetry order; got {p!r}")
    return int(p)


def track_ids(cells):
    """Track id of every row of a cells table: ``track`` when present, else the label ``cell``."""
    column = "track" if "track" in cells.columns else "cell"
    if column not in cells.columns:
        raise InputError("cells needs a 'track' or 'cell' column")
    return cells[column].to_numpy(np.int64)


def interior(cells):
    """Mask of the rows that are not border cells (all rows when there is no ``is_border``)."""
    if "is_border" in cells.columns:
        return ~cells["is_border"].to_numpy(bool)
    return np.ones(len(cells), bool)


def rng(seed):
    """A numpy Generator from an int seed or a Generator (never the global RNG)."""
    if isinstance(seed, np.random.Generator):
        return seed
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)):
        raise InputError(f"seed must be an int or a numpy.random.Generator; got {seed!r}")
    return np.random.default_rng(int(seed))


def charge_mask(charge, p):
    """Defects of elementary charge ``±1/p``."""
    return np.isclose(np.abs(np.asarray(charge, float)), 1.0 / p)
