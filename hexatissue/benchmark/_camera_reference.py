"""Plain-numpy references of the kernels in :mod:`hexatissue.benchmark._camera_kernels` (same names and signatures).

Table construction with scipy's Poisson pmf and a Python loop (Vose), and
vectorised sampling; slow but obviously right.  The tests compare the
kernels against them.
"""
from __future__ import annotations

import numpy as np

from ._camera_kernels import table_size


def alias_tables(n_max):
    """Reference of :func:`hexatissue.benchmark._camera_kernels.alias_tables`."""
    from scipy.stats import poisson

    size = np.array([table_size(n) for n in range(n_max + 1)], np.int64)
    offset = np.r_[0, np.cumsum(size)].astype(np.int64)
    prob = np.empty(offset[-1])
    alias = np.empty(offset[-1], np.int64)
    for n in range(n_max + 1):
        k_n, start = int(size[n]), int(offset[n])
        pmf = poisson.pmf(np.arange(k_n), n) if n > 0 else (np.arange(k_n) == 0).astype(float)
        scaled = list(pmf * k_n / pmf.sum())
        small = [k for k in range(k_n) if scaled[k] < 1.0]
        large = [k for k in range(k_n) if scaled[k] >= 1.0]
        while small and large:
            s, big = small.pop(), large[-1]
            prob[start + s], alias[start + s] = scaled[s], big
            scaled[big] = scaled[big] + scaled[s] - 1.0
            if scaled[big] < 1.0:
                large.pop()
                small.append(big)
        for k in large + small:
            prob[start + k], alias[start + k] = 1.0, k
    return offset, size, prob, alias


def poisson_counts(lam, p0, u1, u2, offset, size, prob, alias, reciprocals):
    """Reference of :func:`hexatissue.benchmark._camera_kernels.poisson_counts`."""
    n = lam.astype(np.int64)
    k_n = size[n]
    x = u1 * k_n
    j = np.minimum(x.astype(np.int64), k_n - 1)
    idx = offset[n] + j
    count = np.where(x - j < prob[idx], j, alias[idx])
    delta = lam.astype(np.float64) - n
    k = np.zeros(lam.size, np.int64)
    p = p0.copy()
    cdf = p.copy()
    for step in range(1, 65):
        more = u2 >= cdf
        if not more.any():
            break
        k[more] = step
        p = p * (delta * reciprocals[step])
        cdf = np.where(more, cdf + p, cdf)
    return (count + k).astype(np.float32)
