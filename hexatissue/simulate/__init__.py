"""Multiphase-field (MPF) simulator of epithelia: the paper's model in numba.

Quick use::

    from hexatissue.simulate import Params, run_simulation, read_run
    run_simulation("run.zarr", Params(n_cells=60, Lx=140, Ly=150), steps=20_000, save_every=100, relax=5_000)
    run = read_run("run.zarr")
    run.labels[0], run.cells, run.box

See ``params.py`` for the model and ../docs/simulate.md for the design.
"""
from .model import Simulation, initial_state, select_threading_layer, set_threads
from .params import Params, stability_limit
from .runner import RunSummary, run_simulation
from .segment import labels_from_fields, labels_from_max, segment
from .store import MPFRun, read_run

__all__ = [
    "Params",
    "stability_limit",
    "Simulation",
    "initial_state",
    "set_threads",
    "select_threading_layer",
    "segment",
    "labels_from_fields",
    "labels_from_max",
    "run_simulation",
    "RunSummary",
    "read_run",
    "MPFRun",
]
