"""Plain-numpy references of the kernels in :mod:`hexatissue.benchmark._kernels` (same names and signatures).

Table construction with scipy's Poisson pmf and a Python loop (Vose), and
vectorised sampling on the same counter-based word stream (the retries of
the rejection samplers as loops over the pixels still pending); slow but
obviously right.  The tests compare the kernels against them.
"""
from __future__ import annotations

import numpy as np
from scipy.special import gammaln

from .._hashing import GOLDEN, mix64
from ._kernels import LARGE_STREAM, NORMAL_STREAM, STREAMS, TABLE_MAX, table_size


def alias_tables(n_max):
    """Reference of :func:`hexatissue.benchmark._kernels.alias_tables`."""
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


def word(key, i, s):
    """Reference of :func:`hexatissue.benchmark._kernels.word` (arrays of pixels ``i`` and streams ``s``)."""
    u = np.uint64
    with np.errstate(over="ignore"):  # uint64 arithmetic wraps around, as it should
        return mix64(u(key) + (np.asarray(i).astype(u) * u(STREAMS) + np.asarray(s).astype(u)) * u(GOLDEN))


def uniform(key, i, s):
    """Reference of :func:`hexatissue.benchmark._kernels.uniform`."""
    return ((word(key, i, s) >> np.uint64(11)).astype(np.float64) + 0.5) * (1.0 / 9007199254740992.0)


def standard_normal(key, i, k, w, f):
    """Reference of :func:`hexatissue.benchmark._kernels.standard_normal` (an array of pixels ``i``)."""
    i = np.asarray(i, np.int64)
    out = np.empty(i.size)
    s = np.full(i.size, NORMAL_STREAM, np.int64)
    todo = np.arange(i.size)
    r = w[-1] * 2.0**52
    while todo.size:
        h = word(key, i[todo], s[todo])
        s[todo] += 1
        layer = (h & np.uint64(255)).astype(np.int64)
        sign = np.where((h >> np.uint64(8)) & np.uint64(1), -1.0, 1.0)
        position = h >> np.uint64(12)
        x = position.astype(np.float64) * w[layer]
        done = position < k[layer]
        out[todo[done]] = (sign * x)[done]
        tail = ~done & (layer == 0)
        for j in np.flatnonzero(tail):  # rare (0.03 %): pixel by pixel
            p = todo[j]
            while True:
                xx = -np.log(uniform(key, i[p], s[p])) / r
                yy = -np.log(uniform(key, i[p], s[p] + 1))
                s[p] += 2
                if yy + yy > xx * xx:
                    out[p] = sign[j] * (r + xx)
                    break
        wedge = np.flatnonzero(~done & ~tail)
        y = f[layer[wedge]] + uniform(key, i[todo[wedge]], s[todo[wedge]]) * (f[layer[wedge] - 1] - f[layer[wedge]])
        s[todo[wedge]] += 1
        inside = y < np.exp(-0.5 * x[wedge] ** 2)
        out[todo[wedge[inside]]] = (sign * x)[wedge[inside]]
        todo = todo[wedge[~inside]]
    return out


def poisson_large(lam, key, i):
    """Reference of :func:`hexatissue.benchmark._kernels.poisson_large` (arrays ``lam``, ``i``)."""
    lam, i = np.asarray(lam, np.float64), np.asarray(i, np.int64)
    slam, loglam = np.sqrt(lam), np.log(lam)
    b = 0.931 + 2.53 * slam
    a = -0.059 + 0.02483 * b
    log_alpha = np.log(1.1239 + 1.1328 / (b - 3.4))
    vr = 0.9277 - 3.6224 / (b - 2)
    out = np.empty(lam.size)
    s = LARGE_STREAM
    todo = np.arange(lam.size)
    while todo.size:  # every pending pixel is at the same stream
        u = uniform(key, i[todo], s) - 0.5
        v = uniform(key, i[todo], s + 1)
        s += 2
        us = 0.5 - np.abs(u)
        a_, b_, lam_ = a[todo], b[todo], lam[todo]
        k = np.floor((2 * a_ / us + b_) * u + lam_ + 0.43)
        quick = (us >= 0.07) & (v <= vr[todo])
        with np.errstate(divide="ignore", invalid="ignore"):
            test = (np.log(v) + log_alpha[todo] - np.log(a_ / (us * us) + b_)
                    <= -lam_ + k * loglam[todo] - gammaln(k + 1))
        done = quick | (~((k < 0) | ((us < 0.013) & (v > us))) & test)
        out[todo[done]] = k[done]
        todo = todo[~done]
    return out


def poisson_counts(lam, key, offset, size, prob, alias, reciprocals):
    """Reference of :func:`hexatissue.benchmark._kernels.poisson_counts`."""
    return _counts(lam, key, offset, size, prob, alias, reciprocals).astype(np.float32)


def _counts(lam, key, offset, size, prob, alias, reciprocals):
    """The counts of :func:`poisson_counts` in float64 (as :func:`camera` adds them to the read noise)."""
    lam = np.asarray(lam, np.float64)
    i = np.arange(lam.size)
    large = lam >= TABLE_MAX
    small = np.where(large, 0.0, lam)
    n = small.astype(np.int64)
    k_n = size[n]
    x = uniform(key, i, 0) * k_n
    j = np.minimum(x.astype(np.int64), k_n - 1)
    idx = offset[n] + j
    count = np.where(x - j < prob[idx], j, alias[idx])
    u = uniform(key, i, 1)
    delta = small - n
    k = np.zeros(lam.size, np.int64)
    p = np.exp(-delta)
    cdf = p.copy()
    for step in range(1, 65):
        more = u >= cdf
        if not more.any():
            break
        k[more] = step
        p = p * (delta * reciprocals[step])
        cdf = np.where(more, cdf + p, cdf)
    out = (count + k).astype(np.float64)
    out[large] = poisson_large(lam[large], key, i[large])
    return out


def camera(clean, key, shot_poisson, read_noise, gain, offset_adu, tables, ziggurat):
    """Reference of :func:`hexatissue.benchmark._kernels.camera`."""
    lam = np.asarray(clean, np.float64)
    lam = np.where(lam > 0, lam, 0.0)
    z = standard_normal(key, np.arange(lam.size), *ziggurat)
    if shot_poisson:
        e = _counts(lam, key, *tables) + read_noise * z
    else:
        e = lam + np.sqrt(lam + read_noise * read_noise) * z
    adu = gain * e + offset_adu + 0.5
    return np.where(adu > 0, np.minimum(adu, 65535.0), 0.0).astype(np.uint16)
