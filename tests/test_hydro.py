"""Active hexatic hydrodynamics: stress terms, energy, invariants, experiments, resume."""
import itertools

import numpy as np
import pytest

from hexatissue.errors import InputError
from hexatissue.hydro import HydroParams, Solver, integrate, open_run, run_dipole
from hexatissue.hydro._kernels import pointwise
from hexatissue.hydro._reference import pointwise_numpy

ALL = Solver.TERMS


def smooth_field(n, amp=0.3):
    """A periodic Psi6 with non-uniform modulus and a varying phase (low modes only)."""
    x = np.arange(n) * 2 * np.pi / n
    X, Y = np.meshgrid(x, x)
    mod = 1 + amp * np.cos(X) * np.sin(2 * Y)
    phase = np.sin(Y) + 0.5 * np.cos(X + 2 * Y) - 0.3 * np.sin(2 * X)
    return mod * np.exp(1j * phase)


def vorticity_source(psi, params, term):
    """rho d omega / dt of one stress term alone, at rest (omega = 0), and the (dealiased) Psi used."""
    solver = Solver(psi.shape[0], params, off=[t for t in ALL if t != term])
    state = solver.state_from_fields(psi)
    _, domega = solver.rhs(state.psi_hat, state.omega_hat)
    return np.fft.ifft2(domega).real * params.rho, solver.ops, solver.psi(state)


# ---- independent evaluations: explicit rank-6 tensors -----------------------------------

def _deriv(f, ops, axes):
    """Spectral derivative of a real field along the given axes (0 = x, 1 = y)."""
    sym = np.ones_like(ops.k2, dtype=complex)
    for a in axes:
        sym = sym * 1j * (ops.kx if a == 0 else ops.ky)
    return np.fft.ifft2(sym * np.fft.fft2(f)).real


def _tensor(c):
    """Rank-6 tensor components {index tuple: field} of Re(c mbar^6): component with k y's is Re((-i)^k c)."""
    return {idx: ((-1j) ** sum(idx) * c).real for idx in itertools.product((0, 1), repeat=6)}


def _contract6(a, b):
    return sum(a[idx] * b[idx] for idx in a)


def _laplacian(f, ops):
    return np.fft.ifft2(-ops.k2 * np.fft.fft2(f)).real


def _molecular_tensor(Q, params, ops):
    """H6 = L6 lap Q6 - A6 Q6 - B6 (Q6 . Q6) Q6, component by component."""
    qq = _contract6(Q, Q)
    return {idx: params.L6 * _laplacian(q, ops) - params.A6 * q - params.B6 * qq * q for idx, q in Q.items()}


def _curl_div(sigma, ops):
    """curl of f_i = d_j sigma_ij."""
    f = [sum(_deriv(sigma[i][j], ops, (j,)) for j in range(2)) for i in range(2)]
    return _deriv(f[1], ops, (0,)) - _deriv(f[0], ops, (1,))


def _grad4_contract(T, ops, coef):
    """sigma_ij = coef d_k d_l d_m d_n T_klmnij."""
    return [[coef * sum(_deriv(T[k + (i, j)], ops, k) for k in itertools.product((0, 1), repeat=4))
             for j in range(2)] for i in range(2)]


def _masked(f, ops):
    return np.fft.ifft2(np.fft.fft2(f) * ops.mask).real


PARAMS = HydroParams(scheme="spectral", alpha6=0.37, lambda6=1.11, rho=2.0)


def test_active_stress_matches_tensor_contraction():
    psi = smooth_field(48)
    got, ops, psi = vorticity_source(psi, PARAMS, "active")
    Q = _tensor(psi / 8)
    want = _masked(_curl_div(_grad4_contract(Q, ops, PARAMS.alpha6), ops), ops)
    assert np.abs(want).max() > 1e-5
    assert np.abs(got - want).max() < 1e-9 * np.abs(want).max() + 1e-12


def test_reactive_stress_matches_tensor_contraction():
    psi = smooth_field(48)
    got, ops, psi = vorticity_source(psi, PARAMS, "reactive")
    H = _molecular_tensor(_tensor(psi / 8), PARAMS, ops)
    want = _masked(_curl_div(_grad4_contract(H, ops, -PARAMS.lambda6), ops), ops)
    assert np.abs(want).max() > 1e-5
    assert np.abs(got - want).max() < 1e-8 * np.abs(want).max()


def test_antisymmetric_stress_matches_tensor_contraction():
    psi = smooth_field(48)
    got, ops, psi = vorticity_source(psi, PARAMS, "antisymmetric")
    Q = _tensor(psi / 8)
    H = _molecular_tensor(Q, PARAMS, ops)
    five = list(itertools.product((0, 1), repeat=5))
    qh = [[sum(Q[(i,) + k] * H[k + (j,)] for k in five) for j in range(2)] for i in range(2)]
    sigma = [[3 * (qh[i][j] - qh[j][i]) for j in range(2)] for i in range(2)]
    want = _masked(_curl_div(sigma, ops), ops)
    assert np.abs(want).max() > 1e-5
    assert np.abs(got - want).max() < 1e-8 * np.abs(want).max()


def test_elastic_stress_matches_finite_differences():
    """sigma_ij = -L6 d_i Q6 . d_j Q6 = -(L6/2) Re(d_i Psi d_j conj Psi), 4th-order differences."""
    n = 96
    psi = smooth_field(n)
    got, ops, psi = vorticity_source(psi, PARAMS, "elastic")

    def d(f, axis):  # axis 0 = x = columns
        ax = 1 if axis == 0 else 0
        return (8 * (np.roll(f, -1, ax) - np.roll(f, 1, ax)) - (np.roll(f, -2, ax) - np.roll(f, 2, ax))) / 12

    grads = [d(psi, 0), d(psi, 1)]
    sigma = [[-PARAMS.L6 / 2 * (grads[i] * np.conj(grads[j])).real for j in range(2)] for i in range(2)]
    f = [d(sigma[i][0], 0) + d(sigma[i][1], 1) for i in range(2)]
    want = d(f[1], 0) - d(f[0], 1)
    assert np.abs(want).max() > 1e-6
    assert np.abs(got - want).max() < 5e-3 * np.abs(want).max()


def test_flow_alignment_and_corotation_terms():
    """Psi equation at given flow: (lambda6/4) D^5 V and 3 i omega Psi against finite differences."""
    n = 64
    psi = smooth_field(n)
    x = np.arange(n) * 2 * np.pi / n
    X, Y = np.meshgrid(x, x)
    stream = 0.3 * np.sin(X) * np.cos(2 * Y)
    params = HydroParams(scheme="spectral", lambda6=0.8)
    solver = Solver(n, params, off=[t for t in ALL if t != "alignment"])
    omega = -np.fft.ifft2(-solver.ops.k2 * np.fft.fft2(stream)).real
    state = solver.state_from_fields(np.ones((n, n), complex), omega)
    dpsi, _ = solver.rhs(state.psi_hat, state.omega_hat)
    # analytic: V = -i D psi, D^5 V = -i D^6 psi with D = d_x + i d_y on sin X cos 2Y
    kx, ky = np.meshgrid(np.fft.fftfreq(n, 1 / n), np.fft.fftfreq(n, 1 / n))
    D = 1j * (kx + 1j * ky) * 2 * np.pi / n
    want = 0.8 / 4 * np.fft.ifft2(-1j * D**6 * np.fft.fft2(stream))
    got = np.fft.ifft2(dpsi) - params.Gamma6 * (-params.A6 - params.B6 / 2)  # H of Psi = 1
    assert np.abs(got - want).max() < 1e-7 * np.abs(want).max()
    solver = Solver(n, params, off=[t for t in ALL if t != "corotation"])
    state = solver.state_from_fields(psi, omega)
    dpsi_rot, _ = solver.rhs(state.psi_hat, state.omega_hat)
    solver0 = Solver(n, params, off=ALL)
    dpsi0, _ = solver0.rhs(state.psi_hat, state.omega_hat)
    rot = np.fft.ifft2(dpsi_rot - dpsi0)
    assert np.abs(rot - 3j * omega * psi).max() < 1e-10 * np.abs(omega).max()


def test_numba_kernel_matches_numpy_reference():
    rng = np.random.default_rng(3)
    shape = (17, 23)
    args = [rng.normal(size=shape) + 1j * rng.normal(size=shape) for _ in range(5)]
    omega = rng.normal(size=shape)
    domega = rng.normal(size=shape) + 1j * rng.normal(size=shape)
    a = pointwise(args[0], args[1], args[2], args[3], args[4], omega, domega, 0.5, -0.2, 0.4)
    b = pointwise_numpy(args[0], args[1], args[2], args[3], args[4], omega, domega, 0.5, -0.2, 0.4)
    for x, y in zip(a, b):
        np.testing.assert_allclose(x, y, rtol=1e-13, atol=1e-13)


def test_fd_symbols_are_centred_stencils():
    n = 16
    ops = Solver(n, HydroParams(scheme="fd")).ops
    f = np.random.default_rng(0).normal(size=(n, n))
    hat = np.fft.fft2(f)
    dx = (np.roll(f, -1, 1) - np.roll(f, 1, 1)) / 2
    lap = np.roll(f, 1, 0) + np.roll(f, -1, 0) + np.roll(f, 1, 1) + np.roll(f, -1, 1) - 4 * f
    np.testing.assert_allclose(np.fft.ifft2(1j * ops.kx * hat).real, dx, atol=1e-12)
    np.testing.assert_allclose(np.fft.ifft2(-ops.k2 * hat).real, lap, atol=1e-12)


@pytest.mark.parametrize("scheme,integrator,dt", [("spectral", "sbdf2", 0.1), ("fd", "rk4", 0.1)])
def test_energy_never_increases_without_activity(scheme, integrator, dt):
    n = 48
    rng = np.random.default_rng(1)
    psi = smooth_field(n, 0.5) * np.exp(1j * 0.3 * rng.normal(size=(n, n)))
    solver = Solver(n, HydroParams(scheme=scheme, integrator=integrator, dt=dt, alpha6=0.0))
    state = solver.state_from_fields(psi, omega=0.05 * rng.normal(size=(n, n)))
    energies = []
    for _ in range(150):
        solver.step(state)
        energies.append(solver.free_energy(state) + solver.kinetic_energy(state))
    e = np.array(energies)
    assert e[-1] < e[0]
    assert np.all(np.diff(e) <= 1e-10 * np.abs(e).max())


@pytest.mark.parametrize("alpha", [0.0, -0.3])
def test_uniform_state_stays_uniform(alpha):
    n = 32
    solver = Solver(n, HydroParams(alpha6=alpha))
    psi = np.full((n, n), np.exp(0.7j))
    state = solver.state_from_fields(psi)
    for _ in range(50):
        solver.step(state)
    np.testing.assert_allclose(solver.psi(state), psi, atol=1e-12)
    assert np.abs(solver.velocity(state)).max() < 1e-12


def test_dipole_annihilates_without_activity():
    r = run_dipole(0.0, n=48, distance=12, disk=3.0, progress=False)
    assert r.annihilation_time is not None and 0 < r.annihilation_time < r.diagnostics["time"].max() + 1
    first = r.defects[r.defects["frame"] == 0].sort_values("charge")
    np.testing.assert_allclose(first[["x", "y"]].to_numpy(), [[29.5, 23.5], [17.5, 23.5]])
    # two trajectories that approach each other
    assert sorted(r.defects["defect"].unique()) == [0, 1]
    last = r.defects[r.defects["frame"] == r.defects["frame"].max()]
    assert np.ptp(last["x"]) < 12
    assert r.diagnostics["n_defects"].iloc[-1] == 0


def test_orientation_turns_the_initial_field():
    """theta_inf multiplies Psi6 by exp(6 i theta_inf); model-A relaxation is odd in Psi, so it commutes."""
    from hexatissue.hydro.initial import dipole_initial, quadrupole_initial

    for make, kw in ((dipole_initial, dict(n=32, distance=8, disk=2.0)), (quadrupole_initial, dict(n=48, ell=4, disk=10.0))):
        base, _ = make(**kw)
        for angle, factor in ((np.pi / 6, -1), (np.pi / 12, 1j)):
            turned, _ = make(**kw, orientation=angle)
            np.testing.assert_allclose(turned, factor * base, atol=1e-9)
    with pytest.raises(InputError, match="orientation"):
        dipole_initial(n=32, distance=8, disk=2.0, orientation=float("nan"))


def test_resume_equals_uninterrupted(tmp_path):
    n = 32
    solver = Solver(n, HydroParams(alpha6=-0.1))
    state = solver.state_from_fields(smooth_field(n))
    full = integrate(solver, state, steps=30, save_every=5, field_every=2, out=tmp_path / "a.zarr", progress=False)
    integrate(solver, state, steps=15, save_every=5, field_every=2, out=tmp_path / "b.zarr", progress=False)
    resumed = integrate(solver, None, steps=30, save_every=5, field_every=2, out=tmp_path / "b.zarr",
                        resume=True, progress=False)
    np.testing.assert_array_equal(full.psi, resumed.psi)
    np.testing.assert_array_equal(full.diagnostics.to_numpy(), resumed.diagnostics.to_numpy())
    da, dfa, fa, _ = open_run(tmp_path / "a.zarr")
    db, dfb, fb, _ = open_run(tmp_path / "b.zarr")
    assert da.equals(db) and dfa.equals(dfb)
    np.testing.assert_array_equal(fa["psi_re"][:], fb["psi_re"][:])
    assert fa["psi_re"].shape == (4, n, n)


def test_bad_input():
    with pytest.raises(InputError, match="scheme"):
        HydroParams(scheme="lbm")
    with pytest.raises(InputError, match="dt"):
        HydroParams(dt=0)
    with pytest.raises(InputError, match="off"):
        Solver(16, off=["magic"])
    with pytest.raises(InputError, match="psi"):
        Solver(16).state_from_fields(np.ones((8, 8)))


def test_command_line_runs_and_resumes(tmp_path, capsys):
    from hexatissue.cli import main

    out = tmp_path / "run.zarr"
    args = ["hydro", "dipole", "--alpha", "0", "--n", "32", "--distance", "8", "--steps", "40", "--dt", "0.05", "--out", str(out),
            "--orientation-deg", "30", "--defects", str(tmp_path / "d.csv")]
    assert main(args) == 0
    assert "dipole alpha6=+0" in capsys.readouterr().out
    diag, defects, fields, attrs = open_run(out)
    assert attrs["meta"]["orientation"] == pytest.approx(np.pi / 6)
    assert attrs["params"]["alpha6"] == 0.0 and len(diag) == 3 and (tmp_path / "d.csv").exists()
    assert main(args[:-2] + ["--resume"]) == 0


def test_float32_tracks_float64():
    n = 32
    psi = smooth_field(n)
    fields = {}
    for dtype in ("float64", "float32"):
        solver = Solver(n, HydroParams(alpha6=-0.1, dtype=dtype))
        state = solver.state_from_fields(psi)
        for _ in range(40):
            solver.step(state)
        assert state.psi_hat.dtype == (np.complex64 if dtype == "float32" else np.complex128)
        fields[dtype] = solver.psi(state)
    # high-k symbols (D^6 ~ k^6) amplify float32 round-off: ~3e-4 after 40 steps
    assert np.abs(fields["float32"] - fields["float64"]).max() < 1e-3


def test_hermitian_partner_and_real_part():
    ops = Solver(12).ops
    rng = np.random.default_rng(5)
    a = rng.normal(size=(12, 12)) + 1j * rng.normal(size=(12, 12))
    want = np.array([[np.conj(a[(-i) % 12, (-j) % 12]) for j in range(12)] for i in range(12)])
    np.testing.assert_array_equal(ops.partner(a), want)
    field = rng.normal(size=(12, 12)) + 1j * rng.normal(size=(12, 12))
    hat = np.fft.fft2(field)
    np.testing.assert_allclose(np.fft.ifft2(ops.re_part(hat)), field.real, atol=1e-13)
    np.testing.assert_allclose(np.fft.ifft2(ops.im_part(hat)), field.imag, atol=1e-13)


def test_implicit_solve_kernel_matches_numpy_and_inverts_the_block():
    from hexatissue.hydro._kernels import implicit_solve
    from hexatissue.hydro._reference import implicit_solve_numpy

    solver = Solver(16, HydroParams(alpha6=-0.4))
    o = solver.ops
    rng = np.random.default_rng(7)
    r_psi = np.fft.fft2(rng.normal(size=(16, 16)) + 1j * rng.normal(size=(16, 16)))
    r_om = np.fft.fft2(rng.normal(size=(16, 16)))
    args = (r_psi, r_om, o.u, o.a, o.visc, o.c1, o.c2, 0.3)
    a, b = implicit_solve(*args), implicit_solve_numpy(*args)
    np.testing.assert_allclose(a[0], b[0], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(a[1], b[1], rtol=1e-12, atol=1e-12)
    lp, lo = solver.linear(*a)  # (1 - tau L) X == R
    np.testing.assert_allclose(a[0] - 0.3 * lp, r_psi, atol=1e-9)
    np.testing.assert_allclose(a[1] - 0.3 * lo, r_om, atol=1e-9)
