"""Parameters of the multiphase-field (MPF) epithelium model.

The model (Methods of "Collective epithelial migration mediated by the
unbinding of hexatic defects") has one field ``phi_c`` per cell on a periodic
``Lx x Ly`` lattice (lattice spacing 1 px, time in simulation units) with the
free energy density

    f = alpha/4 sum_c phi_c^2 (phi_c - phi0)^2 + k_phi/2 sum_c |grad phi_c|^2
      + eps sum_{c<c'} phi_c^2 phi_c'^2 + k_ad sum_{c<c'} grad phi_c . grad phi_c'
      + sum_c lam (1 - int phi_c^2 dA / (pi phi0^2 R^2))^2

and the dynamics ``d_t phi_c + v_c . grad phi_c = -M dF/dphi_c`` with
``v_c = v0 (cos theta_c, sin theta_c)`` and rotational diffusion
``d theta_c = sqrt(2 D_r dt) xi_c``.  Angles are ``atan2(dy, dx)`` with x =
column and y = row.

The paper gives no ``phi0``, ``M`` or ``dt``; the defaults (phi0 = 1, M = 0.1,
dt = 0.5) follow docs/simulate.md: M and dt are those of the published MPF
code of Loewe et al. (PRL 2020), phi0 = 1 the CELADRO convention.  The
``loewe`` preset uses that code's phi0 = 2 instead.  phi0 is *not* a free
rescaling: at fixed alpha, k_phi it halves the interface width
(``w = sqrt(8 k_phi / alpha) / phi0``: 2.8 px at phi0 = 1, 1.4 px at phi0 = 2)
and changes the area deficit of compressed cells (~0.7 % vs ~5 %).
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError

__all__ = ["Params", "stability_limit", "ADVECTION_SCHEMES", "INTEGRATORS"]

ADVECTION_SCHEMES = ("upwind3", "central")  # discretisations of v . grad phi (Params.advection)
INTEGRATORS = ("heun", "euler")  # time steppers (Params.integrator)

_POSITIVE = ("alpha", "k_phi", "R", "phi0", "M", "dt")
_NONNEGATIVE = ("eps", "k_ad", "lam", "v0", "D_r")


@dataclass(frozen=True)
class Params:
    """All parameters of an MPF run (frozen; a run is fully described by these and a seed).

    Parameters
    ----------
    n_cells : int
        Number of cells N.
    Lx, Ly : int
        Periodic box size in lattice sites (px): Lx columns, Ly rows.  Label
        images have shape ``(Ly, Lx)``.
    alpha : float
        Double-well strength.
    k_phi : float
        Interface stiffness (gradient energy).
    eps : float
        Repulsion between overlapping cells.
    k_ad : float
        Adhesion (cross-gradient coupling).
    lam : float
        Area-constraint strength lambda.
    R : float
        Target radius, px: the target area is ``int phi^2 dA = pi phi0^2 R^2``.
    v0 : float
        Self-propulsion speed, px per time unit.
    D_r : float
        Rotational diffusion coefficient of theta, per time unit.
    phi0 : float
        Bulk value of the field inside a cell.
    M : float
        Mobility.
    dt : float
        Time step; must be below :func:`stability_limit`.
    patch : int
        Side P of the square patch (px) that follows each cell.  The field is
        held at 0 on the patch's outer ring.
    dtype : {"float32", "float64"}
        Precision of the fields (area and centroid sums are always float64).
    recentre_every : int
        Steps between checks that re-centre each patch on its cell.
    advection : {"upwind3", "central"}
        Discretisation of ``v_c . grad phi_c``.  ``"upwind3"`` (default) is
        the third-order upwind scheme of the published MPF code (Loewe et al.
        2020); ``"central"`` (second-order central differences) is kept for
        comparison and for runs made before it existed: its numerical
        dispersion slows a free cell to ~0.99 v0 at phi0 = 1 and ~0.94 v0 at
        phi0 = 2 (docs/simulate.md).
    integrator : {"heun", "euler"}
        Time stepper.  ``"heun"`` (default): predictor-corrector, second order,
        two right-hand sides per step.  ``"euler"``: explicit Euler, first
        order, one right-hand side per step (about twice as fast), the scheme
        of the published MPF code; same stability limit.
    """

    n_cells: int = 440
    Lx: int = 384
    Ly: int = 403
    alpha: float = 0.2
    k_phi: float = 0.2
    eps: float = 0.1
    k_ad: float = 0.005
    lam: float = 600.0
    R: float = 11.5
    v0: float = 0.006
    D_r: float = 1e-5
    phi0: float = 1.0
    M: float = 0.1
    dt: float = 0.5
    patch: int = 41
    dtype: str = "float32"
    recentre_every: int = 10
    advection: str = "upwind3"
    integrator: str = "heun"

    def __post_init__(self):
        self._validate()

    # -- presets -----------------------------------------------------------
    @classmethod
    def paper(cls, **overrides) -> "Params":
        """The paper's parameters with phi0 = 1, M = 0.1, dt = 0.5 (the defaults)."""
        return cls(**overrides)

    @classmethod
    def loewe(cls, **overrides) -> "Params":
        """The paper's parameters with phi0 = 2 as in the MPF code of Loewe et al. (2020).

        Same M = 0.1 and dt = 0.5; the interface is 1.4 px wide instead of
        2.8 px and compressed cells keep a larger area deficit (~5 %).
        """
        return cls(**{"phi0": 2.0, **overrides})

    # -- derived quantities ---------------------------------------------------
    @property
    def target_area(self) -> float:
        """Target ``int phi^2 dA`` = pi phi0^2 R^2 (field units x px^2)."""
        return math.pi * self.phi0**2 * self.R**2

    @property
    def interface_width(self) -> float:
        """Interface width ``sqrt(8 k_phi / alpha) / phi0`` in px (tanh profile length)."""
        return math.sqrt(8 * self.k_phi / self.alpha) / self.phi0

    @property
    def shape(self) -> tuple[int, int]:
        """Lattice shape ``(Ly, Lx)`` = (rows, columns)."""
        return (int(self.Ly), int(self.Lx))

    @property
    def np_dtype(self) -> np.dtype:
        return np.dtype(self.dtype)

    def replace(self, **changes) -> "Params":
        """A copy with some fields changed (validated again)."""
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict:
        """Plain JSON-serialisable dict of all fields."""
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> "Params":
        """Inverse of :meth:`to_dict`; unknown keys raise :class:`InputError`."""
        names = {f.name for f in dataclasses.fields(cls)}
        unknown = set(d) - names
        if unknown:
            raise InputError(f"params: unknown parameter(s) {sorted(unknown)}; expected a subset of {sorted(names)}")
        return cls(**d)

    # -- validation -----------------------------------------------------------
    def _validate(self):
        for name in ("n_cells", "Lx", "Ly", "patch", "recentre_every"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
                raise InputError(f"Params.{name} must be a positive integer; got {value!r}")
            object.__setattr__(self, name, int(value))
        for name in _POSITIVE + _NONNEGATIVE:
            value = getattr(self, name)
            try:
                value = float(value)
            except (TypeError, ValueError):
                raise InputError(f"Params.{name} must be a real number; got {value!r}") from None
            if not math.isfinite(value) or value < 0 or (name in _POSITIVE and value == 0):
                kind = "positive" if name in _POSITIVE else "non-negative"
                raise InputError(f"Params.{name} must be a {kind} finite number; got {value!r}")
            object.__setattr__(self, name, value)
        if self.advection not in ADVECTION_SCHEMES:
            raise InputError(
                f"Params.advection must be one of {', '.join(repr(a) for a in ADVECTION_SCHEMES)}; "
                f"got {self.advection!r}"
            )
        if self.integrator not in INTEGRATORS:
            raise InputError(
                f"Params.integrator must be one of {', '.join(repr(a) for a in INTEGRATORS)}; got {self.integrator!r}"
            )
        if self.dtype not in ("float32", "float64"):
            raise InputError(f"Params.dtype must be 'float32' or 'float64'; got {self.dtype!r}")
        if self.patch < 2 * self.R + 4 * self.interface_width + 2:
            need = math.ceil(2 * self.R + 4 * self.interface_width + 2)
            raise InputError(
                f"Params.patch = {self.patch} px is too small for a cell of radius R = {self.R} "
                f"with interface width {self.interface_width:.2f} px; expected patch >= {need}"
            )
        if self.patch > min(self.Lx, self.Ly):
            raise InputError(
                f"Params.patch = {self.patch} px exceeds the box ({self.Lx} x {self.Ly}); "
                "a patch must not wrap onto itself: expected patch <= min(Lx, Ly)"
            )
        _check_packing(self)
        limit = stability_limit(self)
        if self.dt >= limit:
            raise InputError(
                f"Params.dt = {self.dt} is unstable: the explicit scheme needs dt < {limit:.4g} "
                f"(area constraint: pi R^2 phi0^2 / (4 M lam) = {_area_limit(self):.4g}); "
                "lower dt or M, or raise R or phi0"
            )


#: Largest packing fraction N pi R^2 / (Lx Ly); the paper's 440 cells in 384 x 403 px pack 1.18.
MAX_PACKING = 1.4


def _check_packing(p: Params):
    """InputError when the cells' target areas overfill the box (the fields would be squeezed, silently)."""
    packing = p.n_cells * math.pi * p.R**2 / (p.Lx * p.Ly)
    if packing > MAX_PACKING:
        most = int(MAX_PACKING * p.Lx * p.Ly / (math.pi * p.R**2))
        raise InputError(
            f"Params.n_cells = {p.n_cells} cells of target area pi R^2 = {math.pi * p.R**2:.0f} px^2 do not fit "
            f"the {p.Lx} x {p.Ly} box: {packing:.2f} times its area (each cell would get "
            f"{p.Lx * p.Ly / p.n_cells:.0f} px^2); expected at most {MAX_PACKING} times (the paper packs 1.18): "
            f"use at most {most} cells or a larger box"
        )


def _area_limit(p: Params) -> float:
    return math.inf if p.lam == 0 else math.pi * p.R**2 * p.phi0**2 / (4 * p.M * p.lam)


def stability_limit(p: Params) -> float:
    """Largest stable time step of the explicit (Euler or Heun) scheme.

    Both schemes are stable for ``0 < gamma dt <= 2`` on every linear mode.
    The area constraint's global mode has ``gamma = 8 M lam / (pi R^2 phi0^2)``,
    giving ``dt < pi R^2 phi0^2 / (4 M lam)`` (1.73 for the paper's values);
    the local modes (5-point Laplacian, double well, repulsion, adhesion) are
    bounded together by ``gamma <= M (8 k_phi + 8 k_ad + alpha phi0^2 / 2 + 2 eps phi0^2)``.
    """
    local = p.M * (8 * p.k_phi + 8 * p.k_ad + p.alpha * p.phi0**2 / 2 + 2 * p.eps * p.phi0**2)
    return min(_area_limit(p), 2.0 / local)
