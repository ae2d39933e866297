"""Linear stability of the uniform hexatic: theory.dispersion / bulk_onset against the solver itself."""
import warnings

import numpy as np
import pytest

from hexatissue import theory as th
from hexatissue.errors import HexatissueWarning, InputError
from hexatissue.hydro import HydroParams, Solver
from hexatissue.hydro.experiments import run_quadrupole
from hexatissue.hydro.stability import amplification, check_run, dt_limit


def _uniform(solver):
    n = solver.n
    psi_hat = np.zeros((n, n), complex)
    psi_hat[0, 0] = solver.params.psi0 * n * n
    return psi_hat, np.zeros((n, n), complex)


def _jacobian_block(solver, i, j, eps=1e-4):
    """3 x 3 block of the Jacobian of Solver.rhs about the uniform state at wavevector (i, j), by central
    differences, in the variables (psi_hat(k), conj psi_hat(-k), omega_hat(k)); also the largest response
    at any other wavevector (the Jacobian must be block-diagonal)."""
    n = solver.n
    ii, jj = (-i) % n, (-j) % n
    base_p, base_w = _uniform(solver)
    scale = eps * n * n
    cols, leak = [], 0.0
    for var in range(3):
        resp = {}
        for c in (1.0, 1j):  # the map is real-linear; complex-linear in these variables (checked)
            out = []
            for sgn in (1, -1):
                P, W = base_p.copy(), base_w.copy()
                e = sgn * scale * c
                if var == 0:
                    P[i, j] += e
                elif var == 1:
                    P[ii, jj] += np.conj(e)
                else:
                    W[i, j] += e
                    W[ii, jj] += np.conj(e)  # real vorticity
                out.append(solver.rhs(P, W))
            dp = (out[0][0] - out[1][0]) / (2 * scale)
            dw = (out[0][1] - out[1][1]) / (2 * scale)
            resp[c] = np.array([dp[i, j], np.conj(dp[ii, jj]), dw[i, j]])
            other = np.ones((n, n), bool)
            other[i, j] = other[ii, jj] = False
            leak = max(leak, np.abs(dp[other]).max(), np.abs(dw[other]).max())
        assert np.allclose(resp[1j], 1j * resp[1.0], atol=1e-7 * np.abs(resp[1.0]).max() + 1e-12)
        cols.append(resp[1.0])
    return np.array(cols).T, leak


@pytest.mark.parametrize("scheme", ["spectral", "fd"])
@pytest.mark.parametrize("alpha", [-0.7, 1.3])
def test_dispersion_matches_solver_jacobian(scheme, alpha):
    params = HydroParams(alpha6=alpha, scheme=scheme)
    n = 12
    solver = Solver(n, params)
    k1 = 2 * np.pi * np.fft.fftfreq(n)
    checked = 0
    for i in range(n):
        for j in range(n):
            if not solver.ops.mask[i, j] or ((-i) % n == i and (-j) % n == j):
                continue  # dealiased away, or k = -k (k = 0 and Nyquist corners)
            if (i, j) > ((-i) % n, (-j) % n):
                continue  # the block at -k is the conjugate of that at k (real fields): one of each pair
            block, leak = _jacobian_block(solver, i, j)
            d = th.dispersion(np.array([k1[j], k1[i]]), params, scheme)
            scale = np.abs(d.rates).max()
            assert np.abs(block - d.matrix).max() < 1e-6 * np.abs(d.matrix).max()
            got = np.linalg.eigvals(block)
            # every eigenvalue of the Jacobian block is a rate of the dispersion, and vice versa
            dist = np.abs(got[:, None] - d.rates[None, :])
            assert max(dist.min(0).max(), dist.min(1).max()) < 1e-6 * scale
            assert leak < 1e-6 * scale
            checked += 1
    assert checked == (24 if scheme == "spectral" else 70)


def test_dispersion_exact_limits():
    p = HydroParams(lambda6=0.0)
    # amplitude mode at k -> 0 relaxes at 2 Gamma6 A6; the phase (Goldstone) mode at 0
    d = th.dispersion(np.array([[1e-4, 0.0]]), p)
    assert d.rates[0, -1].real == pytest.approx(2 * p.Gamma6 * p.A6, rel=1e-6)
    assert abs(d.rates[0, 0]) < 1e-6
    amp, phase, _ = np.abs(d.modes[0, :, -1])
    assert amp > 0.999 and phase < 1e-3
    # passive bulk stable everywhere, growing with any activity when lambda6 = 0 (no damping of short waves)
    k = np.stack(np.meshgrid(np.linspace(0.01, 5, 60), np.linspace(0.01, 5, 60)), -1)
    assert th.dispersion(k, HydroParams()).rates.real.max() <= 1e-12
    onset = th.bulk_onset(p)
    assert list(onset["alpha"]) == [0.0, 0.0]


@pytest.mark.slow  # 12 s: a sweep of hydrodynamic runs
def test_bulk_onset_is_where_the_first_mode_grows():
    p = HydroParams()
    for scheme, kmax in (("continuum", 4.0), ("spectral", 2 * np.pi / 3), ("fd", np.pi)):
        onset = th.bulk_onset(p, scheme)
        assert onset["alpha"].iloc[0] < 0 < onset["alpha"].iloc[1]
        kx, ky = np.meshgrid(np.linspace(-kmax, kmax, 91), np.linspace(-kmax, kmax, 91))
        for _, row in onset.iterrows():
            # just inside: nothing grows on a dense scan; just outside: the reported wavevector grows
            m = th.linear_operator(kx, ky, HydroParams(alpha6=0.99 * row["alpha"]), scheme)
            inside = np.linalg.eigvals(m).real.max()
            outside = th.dispersion(np.array([row["kx"], row["ky"]]), HydroParams(alpha6=1.01 * row["alpha"]),
                                    scheme).rates.real.max()
            assert inside < 1e-6 < outside, (scheme, row["alpha"], inside, outside)
    # the spectral range |k| < 2 pi / 3 contains the continuum's first growing modes (k ~ 1.6 and 2.0)
    cont, spec = th.bulk_onset(p), th.bulk_onset(p, "spectral")
    assert np.allclose(cont["alpha"], spec["alpha"], rtol=1e-3)
    assert np.allclose(cont["angle_deg"], 30, atol=0.5)


def _growth_at_mode(params, n, t_end, k, seed=0):
    """Measured and predicted growth rate at wavevector k (and the wavevectors equivalent to it by symmetry),
    from a uniform state + 1e-6 noise."""
    solver = Solver(n, params)
    rng = np.random.default_rng(seed)
    psi = params.psi0 + 1e-6 * (rng.standard_normal((n, n)) + 1j * rng.standard_normal((n, n)))
    state = solver.state_from_fields(psi)
    k1 = 2 * np.pi * np.fft.fftfreq(n, params.dx)
    KX, KY = np.meshgrid(k1, k1)
    rates = np.linalg.eigvals(th.linear_operator(KX, KY, params, params.scheme)).real.max(-1)
    pred = rates[np.argmin(np.abs(k1 - k[1])), np.argmin(np.abs(k1 - k[0]))]
    top = np.isclose(rates, pred, rtol=1e-9, atol=1e-12) & solver.ops.mask  # the symmetry-equivalent wavevectors
    top[0, 0] = False
    # stay linear: noise 1e-6 may grow by e^9 at most
    steps = int(round(min(t_end, 9 / abs(pred)) / params.dt))
    times, amps = [], []
    for s in range(steps):
        solver.step(state)
        if s % 10 == 9:
            times.append(state.time)
            amps.append(np.sqrt((np.abs(state.psi_hat[top]) ** 2).sum() + (np.abs(state.omega_hat[top]) ** 2).sum()))
    half = len(times) // 2
    slope = np.polyfit(times[half:], np.log(amps[half:]), 1)[0]
    return slope, pred


@pytest.mark.slow
@pytest.mark.parametrize("scheme,integrator,dt", [("spectral", "sbdf2", 0.05), ("fd", "rk4", 0.05)])
def test_bulk_onset_brackets_the_first_growing_mode_of_runs(scheme, integrator, dt):
    n = 24
    onset = th.bulk_onset(HydroParams(scheme=scheme), scheme, n=n)
    for _, row in onset.iterrows():
        for factor in (0.95, 1.05):
            a = row["alpha"]
            p = HydroParams(alpha6=a * factor, scheme=scheme, integrator=integrator, dt=dt)
            got, want = _growth_at_mode(p, n, 150, (row["kx"], row["ky"]))
            assert (want > 0) == (factor > 1)
            assert got == pytest.approx(want, rel=0.05, abs=2e-3), (scheme, a * factor)


def test_dt_limit_matches_the_measured_scheme_comparison():
    # docs/hydro.md, scheme comparison at alpha6 = 0 (64^2): stable / unstable runs
    cases = [("fd", "rk4", 0.2, 0.3), ("fd", "sbdf2", 0.05, 0.1), ("spectral", "rk4", 0.02, None),
             ("spectral", "sbdf2", 0.05, 0.2)]
    for scheme, integrator, ok, bad in cases:
        limit = dt_limit(HydroParams(scheme=scheme, integrator=integrator, dt=0.01), 32)
        assert ok <= limit * 1.01 and (bad is None or bad > limit), (scheme, integrator, limit)
    p = HydroParams(scheme="fd", integrator="rk4", dt=0.1)
    numeric, exact = amplification(p, 16)
    assert np.all(numeric <= exact) and numeric.max() > 0.9


def test_run_checks_before_it_starts():
    with pytest.raises(InputError, match=r"stability limit 0\.09"):
        check_run(HydroParams(dt=0.12), 32, 7.0)
    with pytest.warns(HexatissueWarning, match="outside the bulk stability window"):
        info = check_run(HydroParams(alpha6=-1.6), 32, 7.0)
    assert not info["bulk_stable"] and info["warnings"]
    with pytest.warns(HexatissueWarning, match="ell6"):
        info = check_run(HydroParams(alpha6=-1.0), 32, 7.0)
    assert info["bulk_stable"] and not info["active"] and info["ell6_over_ell"] == pytest.approx(np.sqrt(2) / 7)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        info = check_run(HydroParams(alpha6=0.0), 32, 7.0)
    assert info["warnings"] == [] and info["dt_limit"] > 0.05


def test_quadrupole_warns_before_the_run_and_records_it():
    with pytest.warns(HexatissueWarning, match="outside the bulk stability window"):
        r = run_quadrupole(-2.0, n=64, ell=5.0, disk=12.0, steps=2, progress=False)
    assert r.meta["stability"]["bulk_stable"] is False
    with pytest.raises(InputError, match="stability limit"):
        run_quadrupole(0.0, n=64, ell=5.0, disk=12.0, steps=2, dt=0.15, progress=False)


def test_quadrupole_annihilates_without_activity():
    r = run_quadrupole(0.0, n=64, ell=5.0, disk=12.0, progress=False, max_time=200)
    assert r.annihilation_time is not None
    assert r.meta["stability"]["warnings"] == []
    first = r.defects[r.defects["frame"] == 0]
    assert len(first) == 4
