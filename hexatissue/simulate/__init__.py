"""Multiphase-field (MPF) simulator of epithelia: the paper's model in numba.

Quick use::

    from hexatissue.simulate import Params, run_simulation, read_run
    run_simulation("run.zarr", Params(n_cells=60, Lx=140, Ly=151), steps=20_000, save_every=100, relax=5_000)
    run = read_run("run.zarr")
    run.labels[0], run.cells, run.box

See ``params.py`` for the model and docs/simulate.md for the design.  Names
are imported lazily so that ``read_run`` does not import numba.
"""
from importlib import import_module

# eager (numpy only): binding the function after importing the submodule of the same name
# keeps ``hexatissue.simulate.segment`` the function
from .segment import labels_from_fields, labels_from_max, segment  # noqa: E402

_EXPORTS = {
    "Params": "params",
    "stability_limit": "params",
    "Simulation": "model",
    "initial_state": "model",
    "set_threads": "model",
    "auto_threads": "model",
    "select_threading_layer": "model",
    "run_simulation": "runner",
    "RunSummary": "runner",
    "read_run": "store",
    "MPFRun": "store",
    "cell_stress": "stress",
}

__all__ = sorted(list(_EXPORTS) + ["segment", "labels_from_fields", "labels_from_max"])


def __getattr__(name):
    if name in _EXPORTS:
        value = getattr(import_module(f".{_EXPORTS[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_EXPORTS))
