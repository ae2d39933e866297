"""splitmix64's finaliser: the one integer hash behind every counter-based random number and id hash.

Used where a value must depend only on integer ids or counters, not on the
order in which rows are visited: the benchmark renderer's per-cell and
per-junction properties, its camera kernel (:func:`mix64_word`) and that kernel's plain reference, and the
order-free hash of neighbour sets in :mod:`hexatissue.events`.
"""

import numpy as np
from numba import njit, uint64

#: the splitmix64 increment, 2**64 divided by the golden ratio
GOLDEN = 0x9E3779B97F4A7C15


def mix64(z):
    """splitmix64's finaliser of uint64 values ``z`` (an array or scalar; wraps around modulo 2**64)."""
    u = np.uint64
    with np.errstate(over="ignore"):
        z = np.asarray(z, dtype=u)
        z = (z ^ (z >> u(30))) * u(0xBF58476D1CE4E5B9)
        z = (z ^ (z >> u(27))) * u(0x94D049BB133111EB)
        return z ^ (z >> u(31))


@njit(cache=True, inline="always")
def mix64_word(z):
    """:func:`mix64` of one uint64 ``z``, inside numba kernels (the camera's random words, the neighbour lists)."""
    z = (z ^ (z >> uint64(30))) * uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> uint64(27))) * uint64(0x94D049BB133111EB)
    return z ^ (z >> uint64(31))
