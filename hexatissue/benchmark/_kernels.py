"""Numba kernels of the camera model (:mod:`hexatissue.benchmark.render`): exact Poisson counts, fast.

Each kernel has a plain-numpy twin of the same name and signature in
:mod:`hexatissue.benchmark._reference` (``poisson_small``, inlined
into its callers, is covered by the twin of :func:`poisson_counts`); the
tests compare the two (identical outputs for the same key) and the samples
against the Poisson and normal distributions.

:func:`camera` is the whole camera in one pass over the pixels (shot noise,
read noise, gain, offset, rounding, clipping to uint16), with no per-pixel
temporaries.  Its random numbers are counter-based: the ``s``-th 64-bit word
of pixel ``i`` is the splitmix64 output ``mix64(key + (i * 2**16 + s) *
GOLDEN)`` (:func:`word`), so every draw is a pure function of (key, pixel,
stream) and the vectorised reference reproduces the kernel exactly.  Streams
of a pixel: 0 and 1 the two uniforms of the Poisson draw below, 2, 3, ... the
normal deviate (:func:`standard_normal`, ziggurat; 1.01 words on average),
32768, 32769, ... the rejection sampler of large means (:func:`poisson_large`,
2 words an attempt, acceptance above 0.9; only after 16384 rejections in a
row would it read the next pixel's words).  splitmix64 of a counter is the
generator of Steele, Lea & Flood (2014): it passes BigCrush.

Poisson(lam) is sampled as Poisson(n) + Poisson(lam - n) with n = floor(lam)
(the sum of independent Poisson variables is Poisson with the summed mean,
so this is exact):

- Poisson(n) by Walker's alias method on a table of Poisson(n) built once
  per n (:func:`alias_tables`; support 0 .. n + 12 sqrt(n) + 20, whose
  left-out tail has probability below 1e-31): one uniform, one table read;
- Poisson(lam - n), a mean below 1, by inversion (one exp, the first four
  terms without branches).

This costs about a third of numpy's ``Generator.poisson`` (transformed
rejection, a logarithm and a log-gamma per sample).  (The tables are read
as separate float64 and int64 arrays; one interleaved array was no faster.)  Means of at least
:data:`TABLE_MAX` (tables would grow as n^2) use that same exact rejection
sampler (Hoermann's PTRS, as numpy's) on the pixel's own stream.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, uint64

from .._hashing import GOLDEN, mix64_word

#: largest floor(lam) with an alias table (the tables hold ~ TABLE_MAX^2 / 2 entries, 16 bytes each)
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
#: streams per pixel (counter = pixel * STREAMS + stream); the first of the large-mean sampler's
STREAMS, LARGE_STREAM = 2**16, 2**15
#: the normal deviate's first stream
NORMAL_STREAM = 2


def ziggurat_tables(layers=256, r=3.6541528853610088, v=4.92867323399e-3):
    """Marsaglia & Tsang's (2000) ziggurat of the standard normal, 52-bit: ``(k, w, f)``.

    ``layers`` strips of area ``v``; ``r`` is where the tail starts.  Layer i
    spans x in [0, w[i] 2**52) between heights f[i] and f[i - 1] (layer 0:
    the base strip and the tail); ``k[i]`` / 2**52 is the fraction of it
    under the curve everywhere.
    """
    m = 2.0**52
    k, w, f = np.zeros(layers, np.uint64), np.zeros(layers), np.zeros(layers)
    x = top = r
    q = v / math.exp(-0.5 * x * x)
    k[0], w[0], w[-1] = int(x / q * m), q / m, x / m
    f[0], f[-1] = 1.0, math.exp(-0.5 * x * x)
    for i in range(layers - 2, 0, -1):
        x = math.sqrt(-2.0 * math.log(v / x + math.exp(-0.5 * x * x)))
        k[i + 1], top = int(x / top * m), x
        f[i], w[i] = math.exp(-0.5 * x * x), x / m
    return k, w, f


#: the ziggurat used by :func:`standard_normal`
ZIGGURAT = ziggurat_tables()


@njit(cache=True, inline="always")
def word(key, i, s):
    """The ``s``-th random 64-bit word of pixel ``i``: splitmix64 of counter ``i * STREAMS + s``."""
    return mix64_word(key + (uint64(i) * uint64(STREAMS) + uint64(s)) * uint64(GOLDEN))


@njit(cache=True, inline="always")
def uniform(key, i, s):
    """A uniform number in (0, 1) (53 bits, never 0 or 1) from :func:`word`."""
    return (float(word(key, i, s) >> uint64(11)) + 0.5) * (1.0 / 9007199254740992.0)


@njit(cache=True, inline="always")  # inlined: a call passing arrays costs atomic reference counting
def standard_normal(key, i, k, w, f):
    """Normal(0, 1) deviate of pixel ``i`` by the ziggurat (tables :data:`ZIGGURAT`), exact.

    One word: bits 0-7 the layer, bit 8 the sign, bits 12-63 the position;
    accepted at once 99 % of the time, else the wedge or tail test with
    further words of the pixel's normal streams.
    """
    s = NORMAL_STREAM
    while True:
        h = word(key, i, s)
        s += 1
        layer = int(h & uint64(255))
        sign = -1.0 if (h >> uint64(8)) & uint64(1) else 1.0
        position = h >> uint64(12)
        x = float(position) * w[layer]
        if position < k[layer]:
            return sign * x
        if layer == 0:  # the tail beyond r = x_255 (Marsaglia 1964)
            r = w[-1] * 4503599627370496.0  # w[-1] = r / 2**52
            while True:
                xx = -math.log(uniform(key, i, s)) / r
                yy = -math.log(uniform(key, i, s + 1))
                s += 2
                if yy + yy > xx * xx:
                    return sign * (r + xx)
        y = f[layer] + uniform(key, i, s) * (f[layer - 1] - f[layer])
        s += 1
        if y < math.exp(-0.5 * x * x):
            return sign * x


@njit(cache=True)
def poisson_large(lam, key, i):
    """Poisson(lam) of pixel ``i`` for lam >= 10 by transformed rejection (Hoermann 1993, PTRS; numpy's)."""
    slam, loglam = math.sqrt(lam), math.log(lam)
    b = 0.931 + 2.53 * slam
    a = -0.059 + 0.02483 * b
    log_alpha = math.log(1.1239 + 1.1328 / (b - 3.4))
    vr = 0.9277 - 3.6224 / (b - 2)
    s = LARGE_STREAM
    while True:
        u = uniform(key, i, s) - 0.5
        v = uniform(key, i, s + 1)
        s += 2
        us = 0.5 - abs(u)
        k = np.floor((2 * a / us + b) * u + lam + 0.43)
        if us >= 0.07 and v <= vr:
            return k
        if k < 0 or (us < 0.013 and v > us):
            continue
        if math.log(v) + log_alpha - math.log(a / (us * us) + b) <= -lam + k * loglam - math.lgamma(k + 1):
            return k


@njit(cache=True, inline="always")
def poisson_small(lam, key, i, offset, size, prob, alias, reciprocals):
    """Poisson(lam) of pixel ``i`` for 0 <= lam < TABLE_MAX: Poisson(floor(lam)) by its alias table + the rest by inversion.

    Callers choose between it and :func:`poisson_large` in their own loop:
    the same choice inside an inlined function made the kernels 3-4 x slower.
    """
    n = int(lam)
    k_n = size[n]
    x = uniform(key, i, 0) * k_n
    j = min(int(x), k_n - 1)
    whole = j if x - j < prob[offset[n] + j] else alias[offset[n] + j]
    # the fractional mean by inversion: the smallest k with P(K <= k) > u.  The first four terms
    # without branches (K >= 4 has probability < 2 %; a loop's exit is mispredicted once a pixel)
    u = uniform(key, i, 1)
    delta = lam - n
    p = math.exp(-delta)
    c0 = p
    p *= delta * reciprocals[1]
    c1 = c0 + p
    p *= delta * reciprocals[2]
    c2 = c1 + p
    p *= delta * reciprocals[3]
    c3 = c2 + p
    k = int(u >= c0) + int(u >= c1) + int(u >= c2)
    if u >= c3:  # k = 3 here; on as the plain inversion loop
        cdf = c3
        while u >= cdf and k < 64:
            k += 1
            p *= delta * reciprocals[k]
            cdf += p
    return float(whole + k)


@njit(cache=True)
def poisson_counts(lam, key, offset, size, prob, alias, reciprocals):
    """Poisson counts of the means ``lam`` (1-D float32, >= 0) with the word stream of ``key``; float32."""
    out = np.empty(lam.size, np.float32)
    for i in range(lam.size):
        m = np.float64(lam[i])  # float() of a float32 stays float32 in numba
        out[i] = (poisson_large(m, key, i) if m >= TABLE_MAX
                  else poisson_small(m, key, i, offset, size, prob, alias, reciprocals))
    return out


@njit(cache=True)
def camera(clean, key, shot_poisson, read_noise, gain, offset_adu, tables, ziggurat):
    """The camera: ADU (uint16, 1-D) of the expected electrons ``clean`` (1-D float32; negatives count as 0).

    ``electrons = Poisson(clean) + read_noise z`` (``shot_poisson``), or
    ``clean + sqrt(clean + read_noise**2) z``; ``ADU = round(gain electrons
    + offset_adu)`` clipped to 0..65535.  ``tables`` = :func:`alias_tables`
    and :data:`RECIPROCALS`, ``ziggurat`` = :data:`ZIGGURAT`.
    """
    offset, size, prob, alias, reciprocals = tables
    k, w, f = ziggurat
    out = np.empty(clean.size, np.uint16)
    for i in range(clean.size):
        lam = np.float64(clean[i])  # float() of a float32 stays float32 in numba
        if not lam > 0.0:  # also NaN
            lam = 0.0
        z = standard_normal(key, i, k, w, f)
        if shot_poisson:
            e = (poisson_large(lam, key, i) if lam >= TABLE_MAX
                 else poisson_small(lam, key, i, offset, size, prob, alias, reciprocals)) + read_noise * z
        else:
            e = lam + math.sqrt(lam + read_noise * read_noise) * z
        adu = gain * e + offset_adu + 0.5  # + 0.5 then truncation: rounding to the nearest ADU
        out[i] = 0 if not adu > 0.0 else (65535 if adu >= 65535.0 else int(adu))
    return out
