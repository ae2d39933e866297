"""Multiphase-field (MPF) runs: a run object (``.labels``, ``.box``) or its zarr store (:mod:`hexatissue.simulate.store`).

The run's label ids are its cells (consistent over time), its box is
periodic, and it is calibrated in simulation iterations (one frame every
``save_every`` iterations, lengths in px).
"""
from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..units import Calibration
from .arrays import ArrayReader
from .base import Opened

__all__ = ["MPF_FORMAT", "is_run", "open_run", "open_run_store"]

MPF_FORMAT = "hexatissue-mpf"  # attrs["format"] of a run store (hexatissue.simulate.store), what read_run needs


def is_run(obj) -> bool:
    """True for an MPF run object (anything with ``.labels`` and ``.box``)."""
    return hasattr(obj, "labels") and hasattr(obj, "box")


def open_run(run, path=None) -> Opened:
    """An MPF run object (e.g. ``hexatissue.simulate.read_run(path)``); ``path``: its store, if known."""
    attrs = dict(getattr(run, "attrs", None) or {})
    labels = run.labels
    n = int(labels.shape[0]) if hasattr(labels, "shape") else len(labels)
    if n < 1:
        raise InputError("the MPF run holds no frames yet; expected at least one")
    reader = ArrayReader("the MPF run's labels", array=labels, axes="TYX", rgb_allowed=False)
    save_every = attrs.get("save_every")
    calibration = (Calibration(frame_interval=float(save_every), time_unit="iteration", time_from="file") if save_every
                   else Calibration())
    run_path = getattr(run, "path", path)
    desc = {"kind": "mpf_run", "path": None if run_path is None else str(run_path),
            "save_every": None if save_every is None else int(save_every)}
    for name in ("seed", "relax", "steps", "format_version"):
        if isinstance(attrs.get(name), (int, np.integer)):
            desc[name] = int(attrs[name])
    return Opened(reader, desc, calibration, box=run.box, ids_consistent=True)


def open_run_store(path) -> Opened:
    """The zarr store of an MPF run, opened with :func:`hexatissue.simulate.store.read_run`."""
    from ..simulate.store import read_run  # imported on first use: the package does not load the simulator

    return open_run(read_run(path), path)
