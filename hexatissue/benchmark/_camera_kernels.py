"""Numba kernels of the camera model (:mod:`hexatissue.benchmark.render`): exact Poisson counts, fast.

Each kernel has a plain-numpy twin of the same name and signature in
:mod:`hexatissue.benchmark._camera_reference`; the tests compare the two
(identical outputs for the same uniforms) and the counts against the
Poisson distribution.

Poisson(lam) is sampled as Poisson(n) + Poisson(lam - n) with n = floor(lam)
(the sum of independent Poisson variables is Poisson with the summed mean,
so this is exact):

- Poisson(n) by Walker's alias method on a table of Poisson(n) built once
  per n (:func:`alias_tables`; support 0 .. n + 12 sqrt(n) + 20, whose
  left-out tail has probability below 1e-31): one uniform, one table read;
- Poisson(lam - n), a mean below 1, by inversion (about 1.6 comparisons).

This costs about a third of numpy's ``Generator.poisson`` (transformed
rejection, a logarithm and a log-gamma per sample).  Means of at least
:data:`TABLE_MAX` are left to numpy (tables would grow as n^2).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

#: largest floor(lam) with an alias table (the tables hold ~ TABLE_MAX^2 / 2 entries, 12 bytes each)
TABLE_MAX = 1024


def table_size(n):
    """Support 0 .. size - 1 of the Poisson(n) table: n + 12 sqrt(n) + 20 (tail mass beyond < 1e-31 for n < 1024)."""
    return int(n + 12 * math.sqrt(n) + 20)


@njit(cache=True)
def alias_tables(n_max):
    """Alias tables of Poisson(n), n = 0 .. n_max, back to back.

    Returns ``(offset, size, prob, alias)``: the table of n is
    ``prob[offset[n]:offset[n] + size[n]]`` (acceptance probabilities) and
    ``alias[...]`` (the value taken when not accepted), Vose's construction.
    """
    size = np.empty(n_max + 1, np.int64)
    for n in range(n_max + 1):
        size[n] = int(n + 12 * math.sqrt(n) + 20)  # = table_size(n)
    offset = np.zeros(n_max + 2, np.int64)
    for n in range(n_max + 1):
        offset[n + 1] = offset[n] + size[n]
    prob = np.empty(offset[n_max + 1], np.float64)
    alias = np.empty(offset[n_max + 1], np.int64)
    for n in range(n_max + 1):
        k_n, start = size[n], offset[n]
        scaled = np.empty(k_n)
        total = 0.0
        for k in range(k_n):
            p = (1.0 if k == 0 else 0.0) if n == 0 else math.exp(k * math.log(n) - n - math.lgamma(k + 1.0))
            scaled[k] = p
            total += p
        for k in range(k_n):
            scaled[k] *= k_n / total
        small = np.empty(k_n, np.int64)
        large = np.empty(k_n, np.int64)
        ns = nl = 0
        for k in range(k_n):
            if scaled[k] < 1.0:
                small[ns] = k
                ns += 1
            else:
                large[nl] = k
                nl += 1
        while ns > 0 and nl > 0:
            ns -= 1
            s = small[ns]
            l_ = large[nl - 1]
            prob[start + s] = scaled[s]
            alias[start + s] = l_
            scaled[l_] = scaled[l_] + scaled[s] - 1.0
            if scaled[l_] < 1.0:
                nl -= 1
                small[ns] = l_
                ns += 1
        for j in range(nl):
            prob[start + large[j]] = 1.0
            alias[start + large[j]] = large[j]
        for j in range(ns):  # rounding leftovers: probability 1 up to float error
            prob[start + small[j]] = 1.0
            alias[start + small[j]] = small[j]
    return offset, size, prob, alias


#: 1 / k for the inversion loop (index 0 unused): a multiplication is cheaper than a division
RECIPROCALS = np.r_[0.0, 1.0 / np.arange(1, 65)]


@njit(cache=True)
def poisson_counts(lam, p0, u1, u2, offset, size, prob, alias, reciprocals):
    """Poisson counts of means ``lam`` (1-D, 0 <= lam < TABLE_MAX) from uniforms ``u1``, ``u2`` in [0, 1).

    ``p0 = exp(floor(lam) - lam)`` (float64; numpy's vectorised exp is
    faster than one call per pixel here) and ``reciprocals`` =
    :data:`RECIPROCALS`.  Returns a float32 array of the counts.
    """
    out = np.empty(lam.size, np.float32)
    for i in range(lam.size):
        m = lam[i]
        n = int(m)
        k_n = size[n]
        x = u1[i] * k_n
        j = min(int(x), k_n - 1)
        count = j if x - j < prob[offset[n] + j] else alias[offset[n] + j]
        # the fractional mean by inversion: the smallest k with P(K <= k) > u2
        delta = m - n
        p = p0[i]
        cdf = p
        k = 0
        while u2[i] >= cdf and k < 64:
            k += 1
            p *= delta * reciprocals[k]
            cdf += p
        out[i] = count + k
    return out
