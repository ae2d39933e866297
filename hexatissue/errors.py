"""Exceptions raised on bad input.

Every error caused by what the user passed in is an :class:`InputError`, a
``ValueError`` subclass whose message names the argument, what was wrong and
what is expected.
"""
import numpy as np


class InputError(ValueError):
    """Invalid input given to a hexatissue function (a ``ValueError``)."""


class HexatissueWarning(UserWarning):
    """Something valid but unusual was found in the input (documented per function)."""


def check_positive(value, name, integer=False, unit=""):
    """``value`` as float (int when ``integer``) if it is a positive finite number; else :class:`InputError`.

    ``unit`` (e.g. ``"px"``) is named in the message.
    """
    ok = not isinstance(value, bool) and np.isscalar(value) and np.isfinite(value) and value > 0
    if ok and integer:
        ok = float(value) == int(value)
    if not ok:
        kind = "a positive integer" if integer else "a positive finite number"
        raise InputError(f"{name} must be {kind}{' in ' + unit if unit else ''}; got {value!r}")
    return int(value) if integer else float(value)
