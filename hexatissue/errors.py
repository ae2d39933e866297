"""Exceptions raised on bad input.

Every error caused by what the user passed in is an :class:`InputError`, a
``ValueError`` subclass whose message names the argument, what was wrong and
what is expected.
"""


class InputError(ValueError):
    """Invalid input given to a hexatissue function (a ``ValueError``)."""


class HexatissueWarning(UserWarning):
    """Something valid but unusual was found in the input (documented per function)."""
