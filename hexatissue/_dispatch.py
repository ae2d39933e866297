"""Which implementation of a kernel runs: the numba kernel, or its plain-numpy reference while compiling would cost more.

Every stage calls its kernels through a :class:`Kernels` object (``K.name``),
which holds the numba module and the reference module beside it.  By default
the numba kernel runs.  Inside :func:`references` (``pipeline.analyze`` enters
it for small inputs on an empty numba cache), a kernel that is neither
compiled in this process nor in numba's cache on disk is replaced by its
reference of the same name and outputs, when it has one: a small input then
waits on no compilation (benchmarks/results_first_run.md), while a kernel
already compiled still runs compiled.  Forked workers inherit the choice.
"""
from __future__ import annotations

import contextlib
import os

__all__ = ["Kernels", "references", "reference_mode", "compiled_or_cached"]

_MODE = ["kernel"]  # "kernel", "auto" (reference for what is not compiled) or "reference" (tests: every reference)
_MODES = ("kernel", "auto", "reference")


@contextlib.contextmanager
def references(mode="auto"):
    """Within the block, kernels with a reference run it: ``"auto"`` when not compiled, ``"reference"`` always.

    ``"kernel"`` runs every numba kernel (the default outside the block).
    """
    if mode not in _MODES:
        raise ValueError(f"mode must be one of {_MODES}; got {mode!r}")
    saved = _MODE[0]
    _MODE[0] = mode
    try:
        yield
    finally:
        _MODE[0] = saved


def reference_mode() -> str:
    """The mode :func:`references` set: ``"kernel"``, ``"auto"`` or ``"reference"``."""
    return _MODE[0]


def compiled_or_cached(kernel) -> bool:
    """Whether numba kernel ``kernel`` is compiled in this process or has an entry in numba's cache on disk.

    Numba keeps one index file per cached function.  Unknown (a numba
    without this layout, a kernel without ``cache=True``): True, so the
    kernel runs and compiles as it would without this module.
    """
    if getattr(kernel, "overloads", None):
        return True
    try:
        return os.path.exists(kernel._cache._cache_file._index_path)
    except AttributeError:
        return True


class Kernels:
    """``K.name``: kernel ``name`` of module ``kernels``, or its reference (see the module docstring).

    ``names`` maps a kernel's name to its reference's name in ``reference``
    where the two differ (a reference named ``_x_reference``); by default a
    kernel's reference has its name.  The reference module is imported on
    first use (``reference`` is its dotted name), so a run that compiles
    never loads it.
    """

    def __init__(self, kernels, reference: str, names=None):
        self._kernels, self._reference_name, self._names = kernels, reference, dict(names or {})
        self._reference = None
        self._compiled = set()  # kernels known to be compiled or cached: not looked at again

    def _reference_of(self, name):
        if self._reference is None:
            from importlib import import_module

            self._reference = import_module(self._reference_name)
        return getattr(self._reference, self._names.get(name, name), None)

    def replaced(self, name):
        """Whether kernel ``name`` is to be replaced by its reference now."""
        mode = _MODE[0]
        if mode == "kernel":
            return False
        if mode == "auto" and (name in self._compiled or compiled_or_cached(getattr(self._kernels, name))):
            self._compiled.add(name)
            return False
        return True

    def __getattr__(self, name):
        kernel = getattr(self._kernels, name)
        reference = self._reference_of(name) if self.replaced(name) else None
        return kernel if reference is None else reference

    def replacement(self, kernel, reference):
        """Object ``reference`` of the reference module when kernel ``kernel`` is to be replaced now, else None.

        For references written one level up (a class or a step that calls
        several kernels), which take the place of the code that calls the kernel.
        """
        if not self.replaced(kernel):
            return None
        self._reference_of(kernel)  # imports the module
        return getattr(self._reference, reference)
