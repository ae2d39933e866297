"""Active hexatic hydrodynamics on a periodic grid: Psi6 + vorticity / stream function.

Equations (complex form, ../docs/hydro.md and physics.md section 6); ``D = d_x + i d_y``,
``Dbar = d_x - i d_y``, ``V = v_x + i v_y = -i D psi``, ``omega = -lap psi``::

    d_t Psi + v.grad Psi = Gamma6 H + 3 i omega Psi + (lambda6/4) D^5 V
    rho (d_t omega + v.grad omega) = eta lap omega + Im(G) + (3/2) lap Im(Psi conj H)
    G = (alpha6/8) Dbar^6 Psi - (lambda6/8) Dbar^6 H + Dbar F_el
    H = L6 lap Psi - A6 Psi - (B6/2) |Psi|^2 Psi,   F_el = -(1/2) Re(H grad conj Psi)

All linear operators are applied as Fourier symbols: for ``scheme="fd"`` the
symbols of second-order centred differences (``i sin(k dx)/dx``, compact
Laplacian ``-(2 - 2 cos(k dx))/dx^2``), identical to the finite-difference
stencils on a periodic grid; for ``scheme="spectral"`` exact wavenumbers with
dealiasing.  The grid is indexed ``[row, col]`` = ``[y, x]``.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.fft as sfft

from ..errors import InputError
from ..theory import derivative_symbols
from ._kernels import implicit_solve, pointwise
from .params import HydroParams

__all__ = ["Operators", "State", "Solver"]

WORKERS = 2


def fft2(a):
    return sfft.fft2(a, workers=WORKERS)


def ifft2(a):
    return sfft.ifft2(a, workers=WORKERS)


class Operators:
    """Fourier symbols of the derivative operators for one grid and scheme.

    Attributes: ``kx``, ``ky`` (first-derivative symbols are ``1j * kx``,
    ``1j * ky``), ``k2`` (minus the Laplacian symbol), ``D``, ``Dbar``,
    ``D6``, ``Dbar6``, ``inv_k2`` (0 at k = 0), ``mask`` (dealiasing, all True
    for fd) and the pieces of the linear block used by the semi-implicit step.
    """

    def __init__(self, n, params: HydroParams):
        dx = params.dx
        k = 2 * np.pi * np.fft.fftfreq(n, d=dx)
        ks, lap1 = derivative_symbols(k, dx, params.scheme)
        if params.scheme == "fd":
            mask1 = np.ones(n, bool)
        else:
            if n % 2 == 0:
                ks[n // 2] = 0.0  # odd derivatives: zero Nyquist, else spurious growing modes
            mask1 = np.abs(k) < (2.0 / 3.0) * np.abs(k).max()
        ctype = params.complex_dtype
        self.n = n
        self.kx = ks[None, :]
        self.ky = ks[:, None]
        self.k2 = lap1[None, :] + lap1[:, None]
        self.inv_k2 = np.divide(1.0, self.k2, out=np.zeros_like(self.k2), where=self.k2 > 0)
        self.D = 1j * (self.kx + 1j * self.ky)
        self.Dbar = 1j * (self.kx - 1j * self.ky)
        self.D6 = self.D**6
        self.Dbar6 = self.Dbar**6
        self.mask = mask1[None, :] & mask1[:, None]
        self.dealias = params.scheme == "spectral"
        # index of -k on the FFT grid, for Hermitian partners
        self.neg = (-np.arange(n)) % n
        p = params
        m = np.abs(self.D6)
        self.u = np.where(m > 0, self.D6 / np.where(m > 0, m, 1), 1.0)
        self.a = p.Gamma6 * p.L6 * self.k2
        self.visc = p.eta / p.rho * self.k2
        self.c1 = p.lambda6 * m * self.inv_k2 / 2
        # the linear active stress has the same structure as the reactive one: it enters the same block
        self.c2 = p.lambda6 * p.L6 * self.k2 * m / (16 * p.rho)
        self.c2_active = p.alpha6 * m / (16 * p.rho)
        for name in ("kx", "ky", "D", "Dbar", "D6", "Dbar6", "u"):
            setattr(self, name, getattr(self, name).astype(ctype) if np.iscomplexobj(getattr(self, name))
                    else getattr(self, name).astype(params.real_dtype))
        for name in ("k2", "inv_k2", "a", "visc", "c1", "c2", "c2_active"):
            setattr(self, name, getattr(self, name).astype(params.real_dtype))

    def partner(self, a_hat):
        """``conj(a_hat[-k])``: the transform of ``conj(a)``."""
        # index -k = (n - k) % n: reverse both axes, then shift by one (one copy, no fancy indexing)
        out = np.roll(a_hat[::-1, ::-1], 1, axis=(0, 1))
        return np.conjugate(out, out=out)

    def im_part(self, a_hat):
        """Transform of ``Im(a)`` from the transform of a complex field ``a``."""
        return (a_hat - self.partner(a_hat)) / 2j

    def re_part(self, a_hat):
        """Transform of ``Re(a)``."""
        return (a_hat + self.partner(a_hat)) / 2


@dataclass
class State:
    """Solver state: transforms of Psi6 and of the vorticity, time and step count.

    ``prev`` holds what the two-step integrator needs from the previous step
    (previous state and explicit terms); it is part of a checkpoint so that a
    resumed run is identical to an uninterrupted one.
    """

    psi_hat: np.ndarray
    omega_hat: np.ndarray
    time: float = 0.0
    step: int = 0
    prev: dict = field(default_factory=dict)

    def copy(self):
        return State(self.psi_hat.copy(), self.omega_hat.copy(), self.time, self.step,
                     {k: v.copy() for k, v in self.prev.items()})


class Solver:
    """Time stepper of the active hexatic model on an ``n x n`` periodic grid.

    Parameters
    ----------
    n : int
        Grid size (nodes per side); node ``[i, j]`` sits at ``x = j dx``, ``y = i dx``.
    params : HydroParams
        Model and numerical parameters.
    off : iterable of str
        Terms to switch off (for tests and dissection of the physics): any of
        "active" (alpha6 stress), "reactive" (symmetric lambda6 stress),
        "antisymmetric" (stress 3(QH - HQ)), "elastic" (Ericksen stress),
        "alignment" (lambda6/4 D^5 V in the Psi equation), "corotation"
        (3 i omega Psi), "advection" (of Psi and omega).
    """

    TERMS = ("active", "reactive", "antisymmetric", "elastic", "alignment", "corotation", "advection")

    def __init__(self, n, params: HydroParams | None = None, off=()):
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 8:
            raise InputError(f"n must be an integer grid size >= 8; got {n!r}")
        self.params = params if params is not None else HydroParams()
        self.n = int(n)
        self.ops = Operators(self.n, self.params)
        bad = set(off) - set(self.TERMS)
        if bad:
            raise InputError(f"off must name terms among {self.TERMS}; got {sorted(bad)}")
        self.on = {t: float(t not in off) for t in self.TERMS}
        self.ops.c1 = self.ops.c1 * self.on["alignment"]
        self.ops.c2 = self.ops.c2 * self.on["reactive"] + self.ops.c2_active * self.on["active"]

    # ---- state conversion -------------------------------------------------
    def state_from_fields(self, psi, omega=None, time=0.0):
        """A :class:`State` from a Psi6 grid (and optional vorticity, default 0)."""
        psi = np.asarray(psi)
        if psi.shape != (self.n, self.n):
            raise InputError(f"psi must have shape ({self.n}, {self.n}); got {psi.shape}")
        if not np.all(np.isfinite(psi)):
            raise InputError("psi must be finite everywhere")
        omega = np.zeros((self.n, self.n)) if omega is None else np.asarray(omega, dtype=float)
        if omega.shape != psi.shape:
            raise InputError(f"omega must have shape {psi.shape}; got {omega.shape}")
        ct = self.params.complex_dtype
        psi_hat, omega_hat = fft2(psi.astype(ct)), fft2(omega.astype(ct))
        if self.ops.dealias:
            psi_hat, omega_hat = psi_hat * self.ops.mask, omega_hat * self.ops.mask
        return State(psi_hat, omega_hat, float(time), 0)

    def psi(self, state):
        """Psi6 on the grid, complex ``(n, n)``."""
        return ifft2(state.psi_hat)

    def stream_hat(self, state):
        return state.omega_hat * self.ops.inv_k2

    def velocity(self, state):
        """Velocity ``v_x + i v_y`` on the grid, complex ``(n, n)``."""
        return ifft2(-1j * self.ops.D * self.stream_hat(state))

    def vorticity(self, state):
        """Vorticity on the grid, real ``(n, n)``."""
        return ifft2(state.omega_hat).real

    # ---- energies ---------------------------------------------------------
    def free_energy(self, state):
        """``F = sum dx^2 [L6/4 |grad Psi|^2 + A6/4 |Psi|^2 + B6/16 |Psi|^4]``, gradient by the scheme's symbols."""
        p, o = self.params, self.ops
        n2 = self.n**2
        grad2 = np.sum(o.k2 * np.abs(state.psi_hat) ** 2) / n2  # Parseval: sum over nodes
        a2 = np.abs(self.psi(state)) ** 2
        return float(p.dx**2 * (p.L6 / 4 * grad2 + np.sum(p.A6 / 4 * a2 + p.B6 / 16 * a2**2)))

    def kinetic_energy(self, state):
        """``E_k = sum dx^2 rho |v|^2 / 2``."""
        p = self.params
        return float(p.dx**2 * p.rho / 2 * np.sum(np.abs(self.velocity(state)) ** 2))

    # ---- right-hand side --------------------------------------------------
    def rhs(self, psi_hat, omega_hat, kernel=pointwise):
        """Time derivatives ``(d psi_hat / dt, d omega_hat / dt)`` of the full model."""
        p, o = self.params, self.ops
        stream = omega_hat * o.inv_k2
        psi = ifft2(psi_hat)
        psi_x = ifft2(1j * o.kx * psi_hat)
        psi_y = ifft2(1j * o.ky * psi_hat)
        lap = ifft2(-o.k2 * psi_hat)
        vel = ifft2(-1j * o.D * stream)
        omega = ifft2(omega_hat).real
        domega = ifft2(o.D * omega_hat)
        on = self.on
        omega_rot = omega * on["corotation"]
        h, nl, fel, r = kernel(psi, psi_x, psi_y, lap, vel * on["advection"], omega_rot, domega,
                               p.L6, p.A6, p.B6)
        if on["corotation"] != on["advection"]:  # rare (tests): the kernel fuses both into nl
            nl = -(vel.real * psi_x + vel.imag * psi_y) * on["advection"] + 3j * omega_rot * psi
        h_hat = fft2(h)
        r_hat = fft2(r)
        dpsi = fft2(nl) + p.Gamma6 * h_hat - 0.25j * p.lambda6 * on["alignment"] * o.D6 * stream
        g = ((p.alpha6 / 8) * on["active"] * o.Dbar6 * psi_hat
             - (p.lambda6 / 8) * on["reactive"] * o.Dbar6 * h_hat
             + on["elastic"] * o.Dbar * fft2(fel))
        sources = o.im_part(g) - 1.5 * on["antisymmetric"] * o.k2 * o.re_part(r_hat)
        domg = (-p.eta * o.k2 * omega_hat + sources) / p.rho - o.im_part(r_hat)
        if o.dealias:
            dpsi = dpsi * o.mask
            domg = domg * o.mask
        return dpsi, domg

    # ---- stiff linear block ----------------------------------------------
    def linear(self, psi_hat, omega_hat):
        """The linear block treated implicitly.

        Diffusion of Psi, viscosity, the lambda6 couplings linearised with
        ``H ~ L6 lap Psi``, and the (linear) active stress.  Per wavevector it
        couples ``p = Psi_hat(k)``, ``q = conj(Psi_hat(-k))`` and ``w = omega_hat(k)``;
        with ``D^6 = m u`` (``|u| = 1``), ``s = conj(u) p + u q`` decays alone and
        ``e = conj(u) p - u q`` pairs with ``w``:
        ``de/dt = -a e - i c1 w``, ``dw/dt = -i c2 e - nu k2 w``.
        """
        o = self.ops
        # (lambda6/4) D^6 / k2 = (c1/2) u: the same coefficients as solve_implicit
        lpsi = -o.a * psi_hat - 0.5j * o.c1 * o.u * omega_hat
        lom = -o.visc * omega_hat - 1j * o.c2 * (np.conj(o.u) * psi_hat - o.u * o.partner(psi_hat))
        return lpsi, lom

    def solve_implicit(self, r_psi, r_om, tau):
        """Solve ``(1 - tau L) X = R`` for the linear block ``L``, one 3 x 3 system per wavevector.

        With ``p = R_psi(k)``, ``q = conj(R_psi(-k))``: ``s = conj(u) p + u q`` is divided by
        ``1 + tau a``; ``(e, w)`` with ``e = conj(u) p - u q`` solve a 2 x 2 system in closed
        form; ``Psi_hat = u (s + e) / 2``.  Numba kernel, numpy reference in ``_kernels``.
        """
        o = self.ops
        return implicit_solve(r_psi, r_om, o.u, o.a, o.visc, o.c1, o.c2, tau)

    # ---- stepping ---------------------------------------------------------
    def step(self, state):
        """Advance ``state`` by one time step in place."""
        if self.params.integrator == "rk4":
            self._rk4(state)
        else:
            self._sbdf(state)
        state.step += 1
        state.time = state.step * self.params.dt

    def _rk4(self, s):
        dt = self.params.dt
        p0, w0 = s.psi_hat, s.omega_hat
        k1 = self.rhs(p0, w0)
        k2 = self.rhs(p0 + dt / 2 * k1[0], w0 + dt / 2 * k1[1])
        k3 = self.rhs(p0 + dt / 2 * k2[0], w0 + dt / 2 * k2[1])
        k4 = self.rhs(p0 + dt * k3[0], w0 + dt * k3[1])
        s.psi_hat = p0 + dt / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
        s.omega_hat = w0 + dt / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])

    def _explicit_part(self, psi_hat, omega_hat):
        f = self.rhs(psi_hat, omega_hat)
        lin = self.linear(psi_hat, omega_hat)
        return f[0] - lin[0], f[1] - lin[1]

    def _sbdf(self, s):
        dt = self.params.dt
        n_psi, n_om = self._explicit_part(s.psi_hat, s.omega_hat)
        if not s.prev:  # first step: semi-implicit Euler
            new = self.solve_implicit(s.psi_hat + dt * n_psi, s.omega_hat + dt * n_om, dt)
        else:
            rp = (4 * s.psi_hat - s.prev["psi_hat"]) / 3 + (2 * dt / 3) * (2 * n_psi - s.prev["n_psi"])
            ro = (4 * s.omega_hat - s.prev["omega_hat"]) / 3 + (2 * dt / 3) * (2 * n_om - s.prev["n_om"])
            new = self.solve_implicit(rp, ro, 2 * dt / 3)
        s.prev = {"psi_hat": s.psi_hat, "omega_hat": s.omega_hat, "n_psi": n_psi, "n_om": n_om}
        s.psi_hat, s.omega_hat = new
        if self.ops.dealias:
            s.psi_hat = s.psi_hat * self.ops.mask
            s.omega_hat = s.omega_hat * self.ops.mask
        # vorticity is real: keep its transform Hermitian against round-off drift
        s.omega_hat = self.ops.re_part(s.omega_hat)
