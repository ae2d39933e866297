"""A one-dimensional Gaussian mixture fitted by expectation–maximisation (numpy only).

Used to split subregions into slow and fast populations from the logarithm of
their displacement (:func:`hexatissue.analysis.migration_populations`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..errors import as_generator

__all__ = ["GaussianMixture1D", "fit_gaussian_mixture"]

_LOG_2PI = np.log(2.0 * np.pi)


@dataclass(frozen=True)
class GaussianMixture1D:
    """A fitted mixture, components sorted by increasing mean.

    Attributes
    ----------
    weights, means, sds : (k,) float arrays
        Mixing weights (sum 1), means and standard deviations.
    log_likelihood : float
        Total log-likelihood of the data.
    n : int
        Number of data points.
    converged : bool
    """

    weights: np.ndarray
    means: np.ndarray
    sds: np.ndarray
    log_likelihood: float
    n: int
    converged: bool

    @property
    def bic(self) -> float:
        """Bayesian information criterion, ``(3k - 1) ln n - 2 ln L`` (lower is better)."""
        return (3 * len(self.means) - 1) * np.log(self.n) - 2.0 * self.log_likelihood

    def log_densities(self, x):
        """``(n, k)`` array of ``ln(w_j N(x | mu_j, sd_j))``."""
        x = np.asarray(x, float)[:, None]
        z = (x - self.means) / self.sds
        return np.log(self.weights) - 0.5 * z**2 - np.log(self.sds) - 0.5 * _LOG_2PI

    def pdf(self, x):
        """Mixture density at ``x``."""
        return np.exp(self.log_densities(x)).sum(axis=1)

    def posterior(self, x):
        """``(n, k)`` membership probabilities of each point."""
        logp = self.log_densities(x)
        logp -= logp.max(axis=1, keepdims=True)
        p = np.exp(logp)
        return p / p.sum(axis=1, keepdims=True)

    def predict(self, x):
        """Most probable component of each point (0 = lowest mean)."""
        return np.argmax(self.posterior(x), axis=1)

    def boundary(self):
        """Two components: the x between the means where both posteriors are 1/2 (NaN if none)."""
        if len(self.means) != 2:
            raise InputError("boundary() needs a two-component mixture")
        grid = np.linspace(self.means[0], self.means[1], 2001)
        post = self.posterior(grid)[:, 1]
        cross = np.flatnonzero(np.diff(np.sign(post - 0.5)) != 0)
        if len(cross) == 0:
            return float("nan")
        i = cross[0]
        # linear interpolation between the two grid points that bracket 1/2
        t = (0.5 - post[i]) / (post[i + 1] - post[i])
        return float(grid[i] + t * (grid[i + 1] - grid[i]))


def _em(x, means, sds, weights, max_iter, tol, sd_floor):
    ll_old = -np.inf
    for it in range(max_iter):
        model = GaussianMixture1D(weights, means, sds, np.nan, len(x), False)
        logp = model.log_densities(x)
        top = logp.max(axis=1, keepdims=True)
        ll = float((top[:, 0] + np.log(np.exp(logp - top).sum(axis=1))).sum())
        resp = np.exp(logp - top)
        resp /= resp.sum(axis=1, keepdims=True)
        nk = resp.sum(axis=0) + 1e-300
        weights = nk / len(x)
        means = (resp * x[:, None]).sum(axis=0) / nk
        # the floor keeps a component from collapsing onto a single point (infinite likelihood)
        sds = np.maximum(np.sqrt((resp * (x[:, None] - means) ** 2).sum(axis=0) / nk), sd_floor)
        if abs(ll - ll_old) <= tol * max(1.0, abs(ll)):
            return weights, means, sds, ll, True
        ll_old = ll
    return weights, means, sds, ll, False


def fit_gaussian_mixture(x, n_components=2, seed=0, n_init=5, max_iter=500, tol=1e-10):
    """Maximum-likelihood Gaussian mixture of 1-D data by EM, best of several starts.

    The first start places the means at evenly spaced quantiles of ``x``
    (deterministic); the others at randomly drawn data points (seeded).
    Standard deviations are floored at ``1e-3 x`` the data's standard
    deviation so that no component collapses onto one point.

    Parameters
    ----------
    x : (n,) array_like
        Finite data, n >= 2 * n_components.
    n_components : int
    seed : int or numpy.random.Generator
    n_init : int
        Number of starts; the highest log-likelihood wins.
    max_iter : int
    tol : float
        Relative change of the log-likelihood that stops EM.

    Returns
    -------
    GaussianMixture1D
        Components sorted by mean.
    """
    x = np.asarray(x, float).ravel()
    if not np.isfinite(x).all():
        raise InputError("x must be finite to fit a Gaussian mixture")
    k = int(n_components)
    if k < 1 or len(x) < 2 * k:
        raise InputError(f"need n_components >= 1 and at least {2 * k} points; got {k} and {len(x)}")
    gen = as_generator(seed)
    spread = float(np.std(x))
    if spread == 0:
        raise InputError("x has zero variance; a mixture cannot be fitted")
    sd_floor = 1e-3 * spread
    best = None
    for start in range(max(1, int(n_init))):
        if start == 0:
            means = np.quantile(x, (np.arange(k) + 0.5) / k)
        else:
            means = np.sort(gen.choice(x, size=k, replace=False))
        sds, weights = np.full(k, spread / k), np.full(k, 1.0 / k)
        fit = _em(x, means, sds, weights, max_iter, tol, sd_floor)
        if best is None or fit[3] > best[3]:
            best = fit
    weights, means, sds, ll, ok = best
    order = np.argsort(means)
    return GaussianMixture1D(weights[order], means[order], sds[order], ll, len(x), ok)
