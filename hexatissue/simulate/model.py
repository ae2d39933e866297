"""The MPF simulation state, its time stepping and its initial conditions.

Positions follow the package convention: x = column, y = row, in lattice
sites (px), origin at the centre of node (0, 0).  Angles are
``atan2(dy, dx)``.
"""
from __future__ import annotations

import math
import os
import warnings

import numpy as np

from ..errors import HexatissueWarning, InputError, as_generator
from . import _kernels as K
from .params import Params

__all__ = ["Simulation", "initial_state", "select_threading_layer", "set_threads", "auto_threads", "ThreadTuner"]

LEAK_LIMIT = 1e-3  # fraction of int phi^2 allowed on the two rings next to a patch's zero ring
RECENTRE_THRESHOLD = 1.0  # px of centroid drift before a patch is shifted
OMP_SPIN_COUNT = 5000  # libgomp spins before a waiting thread sleeps (select_threading_layer)


def select_threading_layer() -> str:
    """Use numba's ``omp`` threading layer when libgomp is available (it scales; ``workqueue`` barely does).

    Only acts before numba has launched its threads and when the user did
    not choose a layer (``NUMBA_THREADING_LAYER``).  Returns the layer that
    is (or will be) used.
    """
    import numba
    from numba.np.ufunc import parallel

    if parallel._is_initialized:
        return numba.threading_layer()
    if os.environ.get("NUMBA_THREADING_LAYER") or numba.config.THREADING_LAYER != "default":
        return numba.config.THREADING_LAYER
    try:
        from numba.np.ufunc import omppool  # noqa: F401  (fails when libgomp is missing)
    except Exception:
        return "default"
    # Spinning OpenMP threads collapse on a shared, oversubscribed machine (measured 15-60x slower at
    # load 13 on 2 cores).  Threads that sleep at once collapse too, less: every parallel region (4 per
    # Heun step) then wakes a thread that waits for the scheduler (2 threads at load 6-7: 35-67 ms per
    # step, 10 ms with a short spin).  So wait passively after a short spin (GOMP_SPINCOUNT, ~0.05 ms),
    # which covers the gap between back-to-back regions.  The user's settings win.
    if "OMP_WAIT_POLICY" not in os.environ:
        os.environ["OMP_WAIT_POLICY"] = "PASSIVE"
        os.environ.setdefault("GOMP_SPINCOUNT", str(OMP_SPIN_COUNT))
    numba.config.THREADING_LAYER = "omp"
    return "omp"


def auto_threads() -> int:
    """Threads worth using now: the cores left idle by the current load (1-minute average), at least 1."""
    import numba

    try:
        idle = (os.cpu_count() or 1) - os.getloadavg()[0]
    except OSError:  # no load average on this platform
        idle = os.cpu_count() or 1
    return int(max(1, min(numba.config.NUMBA_NUM_THREADS, round(idle))))


def set_threads(n: int | str | None) -> int:
    """Set numba's thread count (``None`` keeps the current one, ``"auto"`` uses :func:`auto_threads`).

    Returns the count in use.  Results do not depend on it.
    """
    import numba

    select_threading_layer()
    if isinstance(n, str) and n == "auto":
        n = auto_threads()
    if n is not None:
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not 1 <= n <= numba.config.NUMBA_NUM_THREADS:
            raise InputError(f"threads must be an integer in 1..{numba.config.NUMBA_NUM_THREADS}; got {n!r}")
        numba.set_num_threads(int(n))
    return numba.get_num_threads()


class ThreadTuner:
    """Thread count chosen chunk by chunk from measured step rates (``threads="auto"`` of a run).

    The load average lags and ignores how a shared machine's cores are split: with other processes
    busy, two threads ran 2-5x slower than one (``benchmarks/results_mpf.md``).  So the run starts
    with the first candidate (the load-based guess), times the other one on a chunk after
    ``reprobe_seconds``, and then uses the faster; the one not in use is timed again
    ``reprobe_seconds`` after its last chunk, and each time it loses again that wait doubles (up to
    16x), since a chunk at a collapsed count is expensive.  Results do not depend on the count.

    Parameters
    ----------
    counts : sequence of int
        Candidate thread counts; the first is used until the others are due.
    reprobe_seconds : float
        Time after which a count that is not in use is measured again.
    """

    def __init__(self, counts, reprobe_seconds: float = 30.0):
        self.counts = tuple(dict.fromkeys(int(n) for n in counts))
        self.reprobe_seconds = float(reprobe_seconds)
        self.rate = {}  # count -> steps/s of its latest chunk
        self.when = {}  # count -> time of that measurement
        self.wait = {n: self.reprobe_seconds for n in self.counts}  # count -> wait before timing it again
        self.start = None  # time of the first choice

    @classmethod
    def for_machine(cls, first: int) -> "ThreadTuner":
        """Candidates ``first`` (e.g. :func:`auto_threads`), then the other of 1 and numba's maximum."""
        import numba

        return cls((first, 1, numba.config.NUMBA_NUM_THREADS))

    def choose(self, now: float) -> int:
        """Count for the next chunk (``now``: a monotonic clock, seconds)."""
        if self.start is None:
            self.start = now
        measured = [n for n in self.counts if n in self.rate]
        if not measured:
            return self.counts[0]
        best = max(measured, key=self.rate.__getitem__)
        due = [n for n in self.counts if n != best and now - self.when.get(n, self.start) >= self.wait[n]]
        return due[0] if due else best

    def record(self, n: int, steps_per_second: float, now: float):
        """Store the rate of a chunk run with ``n`` threads."""
        self.rate[n] = float(steps_per_second)
        self.when[n] = now
        if all(m in self.rate for m in self.counts):
            if max(self.counts, key=self.rate.__getitem__) == n:
                self.wait[n] = self.reprobe_seconds
            elif self.wait[n] < 16 * self.reprobe_seconds:
                self.wait[n] *= 2


class Simulation:
    """State of an MPF run: per-cell patches, origins, polarities, RNG and step counter.

    Build one with :func:`initial_state`.  ``phi[c]`` is cell ``c``'s field on
    a ``P x P`` patch whose node ``(i, j)`` lies at lattice row
    ``(oy[c] + i) mod Ly`` and column ``(ox[c] + j) mod Lx``; ``ox, oy`` are
    unwrapped integer origins.  Cell ``c`` has label ``c + 1``.

    Attributes
    ----------
    params : Params
    phi : (N, P, P) array of ``params.dtype``
    ox, oy : (N,) int64
    theta : (N,) float64
        Polarity angles, rad, ``atan2(dy, dx)`` convention.
    step : int
        Global step counter (negative during the passive relaxation of a run).
    rng : numpy.random.Generator
        Source of the rotational noise.
    leak : (N,) float64
        Largest fraction of ``int phi^2`` seen on the two rings next to the
        patch's zero ring (should stay below 1e-3).
    """

    def __init__(self, params: Params, phi, ox, oy, theta, rng, step=0, leak=None):
        if not isinstance(params, Params):
            raise InputError(f"params must be a hexatissue.simulate.Params; got {type(params).__name__}")
        self.params = params
        N, P = params.n_cells, params.patch
        phi = np.ascontiguousarray(phi, dtype=params.np_dtype)
        if phi.shape != (N, P, P):
            raise InputError(f"phi must have shape (n_cells, patch, patch) = {(N, P, P)}; got {phi.shape}")
        self.phi = phi
        self.ox = np.array(ox, dtype=np.int64).reshape(N)
        self.oy = np.array(oy, dtype=np.int64).reshape(N)
        self.theta = np.array(theta, dtype=np.float64).reshape(N)
        self.rng = rng
        self.step = int(step)
        self.leak = np.zeros(N) if leak is None else np.array(leak, dtype=np.float64).reshape(N)
        select_threading_layer()
        self._alloc()
        self._zero_ring()
        self.refresh_geometry()

    # -- workspace --------------------------------------------------------------
    def _alloc(self):
        p, dt = self.params, self.params.np_dtype
        N, P = p.n_cells, p.patch
        self._phis = np.zeros_like(self.phi)
        self._S1 = np.zeros(p.shape, dtype=dt)
        self._S2 = np.zeros(p.shape, dtype=dt)
        self._L = np.zeros(p.shape, dtype=dt)  # lap S1
        self._gx = np.empty((N, P), dtype=np.int32)
        self._gy = np.empty((N, P), dtype=np.int32)
        nb = -(-p.Ly // K.CHUNK_ROWS)
        self._ptr = np.zeros(nb + 1, dtype=np.int64)
        self._cells = np.zeros(N * ((P - 2) // K.CHUNK_ROWS + 3), dtype=np.int64)
        self._coef = np.zeros(N, dtype=dt)
        self._vx = np.zeros(N, dtype=dt)
        self._vy = np.zeros(N, dtype=dt)
        self._area = np.zeros(N, dtype=np.float64)
        self._par = K.pack_params(p, dt)

    def _zero_ring(self):
        self.phi[:, 0, :] = 0
        self.phi[:, -1, :] = 0
        self.phi[:, :, 0] = 0
        self.phi[:, :, -1] = 0

    def refresh_geometry(self):
        """Recompute the wrapped index rows and the band lists after ``ox``/``oy`` changed."""
        p = self.params
        K.index_rows(self.ox, p.Lx, p.patch, self._gx)
        K.index_rows(self.oy, p.Ly, p.patch, self._gy)
        K.build_bands(self.oy, p.Ly, p.patch, self._ptr, self._cells)

    # -- dynamics ---------------------------------------------------------------
    def advance(self, nsteps: int, active: bool = True) -> int:
        """Advance ``nsteps`` steps (``params.integrator``); returns the number of patch re-centrings.

        ``active=False`` gives passive relaxation: ``v0 = 0`` and theta frozen
        (no random numbers are drawn).  Active steps draw ``nsteps x N``
        standard normals from ``rng`` for the rotational noise.
        """
        nsteps = int(nsteps)
        if nsteps <= 0:
            return 0
        p = self.params
        sigma = math.sqrt(2.0 * p.D_r * p.dt) if active else 0.0
        if active and sigma > 0:
            noise = self.rng.standard_normal((nsteps, p.n_cells))
        else:
            noise = np.zeros((0, p.n_cells))
        v0 = p.v0 if active else 0.0
        moves = K.advance(
            self.phi, self._phis, self._S1, self._S2, self._L, self.ox, self.oy, self._gx, self._gy,
            self._ptr, self._cells, self.theta, noise, self._coef, self._vx, self._vy, self._area, self.leak,
            self._par, 1.0 / p.target_area, 4.0 * p.lam, v0, sigma, self.step, nsteps,
            p.recentre_every, RECENTRE_THRESHOLD, K.SCHEMES[p.advection], p.integrator == "euler",
        )
        self.step += nsteps
        return int(moves)

    def check_leak(self):
        """Warn (HexatissueWarning) when a cell's field reached its patch rim; returns the worst fraction."""
        worst = float(self.leak.max()) if self.leak.size else 0.0
        if worst > LEAK_LIMIT:
            c = int(self.leak.argmax())
            warnings.warn(
                f"cell {c + 1}: {worst:.2e} of its area reached the rim of its {self.params.patch} px patch "
                f"(limit {LEAK_LIMIT:g}); use a larger Params.patch",
                HexatissueWarning,
                stacklevel=2,
            )
        return worst

    # -- observables ------------------------------------------------------------
    def moments(self) -> np.ndarray:
        """``(N, 3)`` float64: area ``int phi^2 dA / phi0^2`` (px^2) and unwrapped centroid x, y (px)."""
        out = np.empty((self.params.n_cells, 3))
        K.moments(self.phi, self.ox, self.oy, out)
        out[:, 0] /= self.params.phi0**2
        return out

    def max_field(self):
        """Lattice arrays ``(vmax, imax, vsum)``: largest field, its cell index (-1 where none), total field."""
        vmax = np.empty(self.params.shape)
        vsum = np.empty(self.params.shape)
        imax = np.empty(self.params.shape, dtype=np.int64)
        K.max_field(self.phi, self.oy, self._gx, self._ptr, self._cells, vmax, imax, vsum)
        return vmax, imax, vsum

    def full_fields(self) -> np.ndarray:
        """Every cell's field on the whole lattice, ``(N, Ly, Lx)`` (memory heavy: tests and small systems)."""
        from ._reference import patches_to_full

        return patches_to_full(self.phi, self.ox, self.oy, self.params.shape)

    def energy(self) -> float:
        """Free energy F of the current state (float64, via the full-lattice reference)."""
        from ._reference import free_energy, patch_masks

        masks = patch_masks(self.ox, self.oy, self.params.patch, self.params.shape)
        return free_energy(self.full_fields(), self.params, masks)

    def copy(self) -> "Simulation":
        """Independent copy (RNG state included)."""
        rng = np.random.Generator(type(self.rng.bit_generator)())
        rng.bit_generator.state = self.rng.bit_generator.state
        return Simulation(self.params, self.phi.copy(), self.ox, self.oy, self.theta, rng, self.step, self.leak)


# -- initial conditions ---------------------------------------------------------
def _lattice_seeds(n, Lx, Ly, jitter, rng):
    """``n`` positions (x, y) on a row-offset lattice filling the box, jittered by ``jitter`` x spacing."""
    ny = max(1, int(round(math.sqrt(n * Ly / Lx))))
    counts = np.full(ny, n // ny)
    counts[: n % ny] += 1
    # spread the longer rows evenly over the box
    counts = counts[np.argsort((np.arange(ny) * 0.618034) % 1.0, kind="stable")]
    pts = []
    for row, m in enumerate(counts):
        y = (row + 0.5) * Ly / ny
        shift = 0.5 * (row % 2)
        x = (np.arange(m) + 0.25 + shift) * Lx / m
        pts.append(np.c_[x, np.full(m, y)])
    xy = np.concatenate(pts)
    spacing = math.sqrt(Lx * Ly / n)
    xy += rng.uniform(-jitter, jitter, size=xy.shape) * spacing
    return np.mod(xy, [Lx, Ly])


def _disc_patch(p: Params, fx, fy, radius):
    """A tanh disc of ``radius`` px centred at patch coordinates (fx, fy)."""
    P = p.patch
    i, j = np.mgrid[0:P, 0:P]
    r = np.hypot(j - fx, i - fy)
    return 0.5 * p.phi0 * (1.0 - np.tanh((r - radius) / p.interface_width))


def _patches_from_points(p: Params, xy, radius):
    P = p.patch
    xy = np.asarray(xy, dtype=float)
    half = (P - 1) // 2
    ox = np.floor(xy[:, 0]).astype(np.int64) - half
    oy = np.floor(xy[:, 1]).astype(np.int64) - half
    phi = np.empty((len(xy), P, P))
    for c, (x, y) in enumerate(xy):
        phi[c] = _disc_patch(p, x - ox[c], y - oy[c], radius)
    return phi, ox, oy


def _patches_from_labels(p: Params, labels):
    labels = np.asarray(labels)
    if labels.shape != p.shape:
        raise InputError(f"labels must have shape (Ly, Lx) = {p.shape}; got {labels.shape}")
    if not np.issubdtype(labels.dtype, np.integer):
        raise InputError(f"labels must be an integer image; got dtype {labels.dtype}")
    ids = np.unique(labels)
    ids = ids[ids > 0]
    if len(ids) != p.n_cells:
        raise InputError(f"labels hold {len(ids)} cells but params.n_cells = {p.n_cells}; expected them equal")
    P = p.patch
    half = (P - 1) // 2
    rows, cols = np.indices(p.shape)
    phi = np.zeros((len(ids), P, P))
    ox = np.empty(len(ids), dtype=np.int64)
    oy = np.empty(len(ids), dtype=np.int64)
    smooth = _smoothing_kernel(p)
    for c, lab in enumerate(ids):
        rr, cc = rows[labels == lab], cols[labels == lab]
        # periodic centroid through the circular mean, so cells cut by the box edge stay whole
        x = _circular_mean(cc, p.Lx)
        y = _circular_mean(rr, p.Ly)
        ox[c], oy[c] = int(math.floor(x)) - half, int(math.floor(y)) - half
        i = (rr - oy[c]) % p.Ly
        j = (cc - ox[c]) % p.Lx
        inside = (i >= 2) & (i <= P - 3) & (j >= 2) & (j <= P - 3)
        if not inside.all():
            raise InputError(
                f"labels: cell {lab} does not fit in a {P} px patch around its centroid; "
                "expected cells smaller than the patch (raise Params.patch)"
            )
        box = np.zeros((P, P))
        box[i, j] = p.phi0
        phi[c] = smooth(box)
    return phi, ox, oy


def _smoothing_kernel(p: Params):
    from scipy.ndimage import gaussian_filter

    return lambda a: gaussian_filter(a, sigma=0.5 * p.interface_width, mode="constant")


def _circular_mean(v, L):
    ang = 2 * np.pi * np.asarray(v, float) / L
    m = math.atan2(np.sin(ang).mean(), np.cos(ang).mean())
    return (m % (2 * np.pi)) * L / (2 * np.pi)


def initial_state(params: Params, seed=0, labels=None, positions=None, radius=None, jitter=0.2) -> Simulation:
    """A fresh (unrelaxed) state: N cells seeded as discs, or taken from a label image.

    Parameters
    ----------
    params : Params
    seed : int or numpy.random.Generator
        Draws the lattice jitter, the polarities theta (uniform in [0, 2 pi))
        and, later, the rotational noise.
    labels : (Ly, Lx) int array, optional
        Start from this segmentation: cell ``c`` is the ``c``-th smallest
        positive label, with phi = phi0 inside (smoothed over the interface
        width).  Needs ``params.n_cells`` labels, each smaller than the patch.
    positions : (N, 2) array, optional
        Disc centres (x = column, y = row, px) instead of the jittered lattice.
    radius : float, optional
        Initial disc radius, px; default ``min(R, 0.45 * spacing)`` with
        ``spacing = sqrt(Lx Ly / N)``, so discs start separated.
    jitter : float
        Random displacement of lattice seeds, as a fraction of the spacing.

    Returns
    -------
    Simulation
        At ``step = 0``; relax it passively (``advance(n, active=False)``) before an active run.
    """
    if not isinstance(params, Params):
        raise InputError(f"params must be a hexatissue.simulate.Params; got {type(params).__name__}")
    rng = as_generator(seed)
    p = params
    if labels is not None:
        phi, ox, oy = _patches_from_labels(p, labels)
    else:
        spacing = math.sqrt(p.Lx * p.Ly / p.n_cells)
        if radius is None:
            radius = min(p.R, 0.45 * spacing)
        if not (np.isfinite(radius) and 0 < radius < 0.5 * (p.patch - 1) - p.interface_width):
            raise InputError(f"radius must be positive and fit in the patch; got {radius!r}")
        if positions is None:
            if not 0 <= jitter < 0.5:
                raise InputError(f"jitter must be in [0, 0.5); got {jitter!r}")
            xy = _lattice_seeds(p.n_cells, p.Lx, p.Ly, jitter, rng)
        else:
            xy = np.asarray(positions, dtype=float)
            if xy.shape != (p.n_cells, 2) or not np.isfinite(xy).all():
                raise InputError(f"positions must be a finite (n_cells, 2) = ({p.n_cells}, 2) array; got shape {xy.shape}")
        phi, ox, oy = _patches_from_points(p, xy, radius)
    theta = rng.uniform(0.0, 2 * np.pi, p.n_cells)
    return Simulation(p, phi, ox, oy, theta, rng, step=0)
