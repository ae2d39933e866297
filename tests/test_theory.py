"""Analytic quadrupole results checked against independent numerics."""
import numpy as np
import pytest

from hexatissue import theory as th
from hexatissue.defects import plaquette_charges
from hexatissue.errors import InputError


def _grid(half, h):
    x = np.arange(-half, half + 1) * h
    return np.meshgrid(x, x)


def test_quadrupole_psi_defects_and_limits():
    X, Y = _grid(40, 0.5)
    psi = th.quadrupole_psi(X + 0.25, Y + 0.25, 7.0)  # offset: no node on a core
    assert np.allclose(np.abs(psi), 1)
    q = plaquette_charges(psi, 6)
    i, j = np.nonzero(q)
    got = sorted(zip(np.round(X[i, j] + 0.5, 1), np.round(Y[i, j] + 0.5, 1), q[i, j]))
    want = sorted([(-7.0, 0.0, -1 / 6), (7.0, 0.0, -1 / 6), (0.0, -7.0, 1 / 6), (0.0, 7.0, 1 / 6)])
    assert len(got) == 4
    for g, w in zip(got, want):
        assert g[2] == pytest.approx(w[2]) and abs(g[0] - w[0]) <= 0.5 and abs(g[1] - w[1]) <= 0.5
    assert abs(th.quadrupole_psi(1e4, 3e3, 7.0) - 1) < 1e-5


def test_phase_expansion_matches_exact_far_away():
    phi = np.linspace(0, 2 * np.pi, 50)
    for r, tol in [(3.0, 2e-4), (6.0, 5e-8)]:
        exact = th.quadrupole_phase(r * np.cos(phi), r * np.sin(phi), 1.0)
        three = th.quadrupole_phase(r * np.cos(phi), r * np.sin(phi), 1.0, terms=3)
        assert np.abs(exact - three).max() < tol
    # leading coefficient is -ell^2/3 (the paper prints -2 ell^2/3)
    one = th.quadrupole_phase(10 * np.cos(phi), 10 * np.sin(phi), 1.0, terms=1)
    assert np.allclose(one, -np.sin(2 * phi) / 300)


def test_exact_force_matches_finite_differences():
    """(alpha/8) Dbar^5 (W/|W|) by five centred differences vs the closed form."""
    h, alpha = 0.01, 0.7
    X, Y = _grid(350, h)
    f = th.quadrupole_psi(X, Y, 1.0)
    for _ in range(5):
        fx = (f[1:-1, 2:] - f[1:-1, :-2]) / (2 * h)
        fy = (f[2:, 1:-1] - f[:-2, 1:-1]) / (2 * h)
        f = fx - 1j * fy
    f *= alpha / 8
    Xc, Yc = X[5:-5, 5:-5], Y[5:-5, 5:-5]
    ax, ay = th.active_force(Xc, Yc, 1.0, alpha)
    r = np.hypot(Xc, Yc)
    m = (r > 1.5) & (np.maximum(abs(Xc), abs(Yc)) < 3.2)
    ref = ax + 1j * ay
    assert np.abs(f - ref)[m].max() < 3e-3 * np.abs(ref)[m].max()


def test_expanded_force_converges_to_exact():
    phi = np.linspace(0, 2 * np.pi, 100)
    errors = []
    for r in (5.0, 10.0, 20.0):
        a = np.array(th.active_force(r * np.cos(phi), r * np.sin(phi), 1.0, -0.1))
        b = np.array(th.active_force(r * np.cos(phi), r * np.sin(phi), 1.0, -0.1, exact=False))
        errors.append(np.abs(a - b).max() / np.abs(a).max())
    assert errors[0] < 0.05 and errors[1] < 4e-3
    # neglected terms are of relative order (ell/r)^4
    assert errors[1] / errors[2] == pytest.approx(16, rel=0.2)


def _divergence(h):
    X, Y = _grid(int(round(3 / h)), h)
    vx, vy = th.quadrupole_flow(X, Y, 1.0, 1.0)
    div = (vx[1:-1, 2:] - vx[1:-1, :-2] + vy[2:, 1:-1] - vy[:-2, 1:-1]) / (2 * h)
    r = np.hypot(X, Y)[1:-1, 1:-1]
    away = np.abs(r - 1) > 0.05  # the flow has a kink at r = ell
    return np.abs(div)[away].max(), np.hypot(vx, vy).max()


def test_flow_is_divergence_free_and_continuous():
    coarse, _ = _divergence(0.01)
    fine, speed = _divergence(0.005)
    assert fine < 1.5e-3 * speed
    assert coarse / fine == pytest.approx(4, rel=0.1)  # pure O(h^2) truncation: the field is solenoidal
    phi = np.linspace(0, 2 * np.pi, 64)
    inside = np.array(th.quadrupole_flow((1 - 1e-9) * np.cos(phi), (1 - 1e-9) * np.sin(phi), 1.0, 1.0))
    outside = np.array(th.quadrupole_flow((1 + 1e-9) * np.cos(phi), (1 + 1e-9) * np.sin(phi), 1.0, 1.0))
    assert np.allclose(inside, outside, atol=1e-6)


def test_flow_matches_fft_stokes_solve():
    """Independent periodic spectral Stokes solve of the two-term force outside r = ell."""
    n, ell, alpha, sub = 512, 32.0, 1.0, 4
    x = np.arange(n) - n / 2 + 0.5
    X, Y = np.meshgrid(x, x)
    # area fraction of each pixel outside r = ell (a pixelated step adds spurious force moments)
    offsets = (np.arange(sub) + 0.5) / sub - 0.5
    frac = sum((np.hypot(X + a, Y + b) > ell) for a in offsets for b in offsets) / sub**2
    fx, fy = th.active_force(X, Y, ell, alpha, exact=False)
    fx, fy = np.nan_to_num(fx * frac), np.nan_to_num(fy * frac)
    k = 2 * np.pi * np.fft.fftfreq(n)
    KX, KY = np.meshgrid(k, k)
    k2 = KX**2 + KY**2
    k2[0, 0] = 1
    Fx, Fy = np.fft.fft2(fx), np.fft.fft2(fy)
    dot = (KX * Fx + KY * Fy) / k2
    vx = np.fft.ifft2((Fx - KX * dot) / k2).real
    vy = np.fft.ifft2((Fy - KY * dot) / k2).real
    ax, ay = th.quadrupole_flow(X, Y, ell, alpha)
    r = np.hypot(X, Y)
    for lo, hi, tol in [(1.1, 1.6, 0.02), (1.6, 2.2, 0.04)]:
        m = (r > lo * ell) & (r < hi * ell)
        assert np.hypot(vx - ax, vy - ay)[m].max() < tol * np.hypot(ax, ay)[m].max()


def test_ell6_and_bad_input():
    assert th.ell6(-0.5, 0.5) == pytest.approx(1.0)
    with pytest.raises(InputError, match="ell"):
        th.quadrupole_psi(0, 0, -1)
    with pytest.raises(InputError, match="L6"):
        th.ell6(0.1, 0)
