"""Exceptions raised on bad input, and the checks that raise them.

Every error caused by what the user passed in is an :class:`InputError`, a
``ValueError`` subclass whose message names the argument, what was wrong and
what is expected.  The checks here are the only copies in the package: one
positive-number check, one symmetry-order check, one seeded-generator helper.
"""
from pathlib import Path

import numpy as np

__all__ = ["InputError", "HexatissueWarning", "FrameWarning", "check_positive", "check_p", "check_orders",
           "as_generator", "is_real", "deprecated_alias"]


class InputError(ValueError):
    """Invalid input given to a hexatissue function (a ``ValueError``)."""


class HexatissueWarning(UserWarning):
    """Something valid but unusual was found in the input (documented per function)."""


class FrameWarning(HexatissueWarning):
    """A warning about one frame whose ``text`` is the same in every frame it concerns and ``detail`` is the frame's.

    ``str()`` is the whole message (``text`` then ``detail``); an analysis
    reports one warning per ``text`` with each frame's ``detail``.
    """

    def __init__(self, text, detail=""):
        super().__init__(f"{text} ({detail})" if detail else text)
        self.text, self.detail = text, detail


def is_real(value) -> bool:
    """True for a finite real number (int, float or numpy number; not bool, str, None or an array)."""
    return (isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, (bool, np.bool_))
            and bool(np.isfinite(value)))


def check_positive(value, name, integer=False, unit=""):
    """``value`` as float (int when ``integer``) if it is a positive finite number; else :class:`InputError`.

    ``unit`` (e.g. ``"px"``) is named in the message.
    """
    ok = is_real(value) and value > 0
    if ok and integer:
        ok = float(value) == int(value)
    if not ok:
        kind = "a positive integer" if integer else "a positive finite number"
        raise InputError(f"{name} must be {kind}{' in ' + unit if unit else ''}; got {value!r}")
    return int(value) if integer else float(value)


def check_p(p, name="p"):
    """``p`` as int if it is a positive integer symmetry order (2 nematic, 6 hexatic); else :class:`InputError`."""
    if isinstance(p, bool) or not isinstance(p, (int, np.integer)) or p < 1:
        raise InputError(f"{name} must be a positive integer symmetry order (e.g. 2 or 6); got {p!r}")
    return int(p)


def check_orders(p, name="p"):
    """One or more symmetry orders as a tuple of distinct ints (a single int is accepted)."""
    if p is None or isinstance(p, (str, bytes, dict)):
        raise InputError(f"{name} must be a positive integer symmetry order or a sequence of them; got {p!r}")
    try:
        orders = (p,) if np.isscalar(p) else tuple(p)
    except TypeError:
        raise InputError(f"{name} must be a positive integer symmetry order or a sequence of them; "
                         f"got {p!r}") from None
    if not orders:
        raise InputError(f"{name} must list at least one symmetry order; got {p!r}")
    orders = tuple(check_p(q, name) for q in orders)
    if len(set(orders)) != len(orders):
        raise InputError(f"{name} lists a symmetry order twice; got {p!r}")
    return orders


def as_generator(seed, name="seed"):
    """A numpy Generator from a non-negative int seed or a Generator (never the global RNG)."""
    if isinstance(seed, np.random.Generator):
        return seed
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise InputError(f"{name} must be a non-negative int or a numpy.random.Generator; got {seed!r}")
    return np.random.default_rng(int(seed))


def user_stacklevel() -> int:
    """The ``stacklevel`` for ``warnings.warn`` that points at the first caller outside hexatissue."""
    import sys

    package = str(Path(__file__).resolve().parent)
    frame, level = sys._getframe(1), 1
    while frame is not None and frame.f_code.co_filename.startswith(package):
        frame, level = frame.f_back, level + 1
    return level


def deprecated_alias(func, old_name):
    """``func`` under its old public name ``old_name``: it works as before and warns that it is deprecated.

    Old spellings are kept this way for one release after a rename.
    """
    import functools
    import warnings

    @functools.wraps(func)
    def alias(*args, **kwargs):
        warnings.warn(f"{old_name} is deprecated and will be removed in the next release; use {func.__name__}",
                      DeprecationWarning, stacklevel=2)
        return func(*args, **kwargs)

    alias.__name__ = alias.__qualname__ = old_name
    alias.__doc__ = f"Deprecated spelling of :func:`{func.__name__}`."
    return alias
