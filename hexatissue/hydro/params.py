"""Parameters of the active hexatic hydrodynamics model."""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from ..errors import InputError

__all__ = ["HydroParams"]

SCHEMES = ("fd", "spectral")
INTEGRATORS = ("sbdf2", "rk4")


@dataclass(frozen=True)
class HydroParams:
    """Model and numerical parameters (defaults: the paper's model values; production numerics).

    Production numerics: ``scheme="spectral", integrator="sbdf2", dt=0.05``.  The
    paper's scheme is ``scheme="fd", integrator="rk4", dt=0.1`` (stable up to dt
    0.2); ``fd`` with ``sbdf2`` needs dt <= 0.05 (docs/hydro.md).

    Parameters
    ----------
    rho, eta : float
        Mass density and shear viscosity.
    L6, A6, B6 : float
        Free-energy constants: ``F = int L6/4 |grad Psi|^2 + A6/4 |Psi|^2 + B6/16 |Psi|^4``.
    Gamma6 : float
        Rotational mobility.
    lambda6 : float
        Flow-alignment (reactive) coupling.
    alpha6 : float
        Activity (> 0 contractile, < 0 extensile in the paper's convention).
    dx : float
        Grid spacing (length unit of positions in all outputs: x = column * dx).
    dt : float
        Time step.
    scheme : {"fd", "spectral"}
        "fd": second-order centred differences (symbols ``sin(k dx)/dx``, compact
        5-point Laplacian), the paper's scheme, applied through FFTs (identical
        to the stencils on a periodic grid).  "spectral": exact wavenumbers with
        2/3-rule dealiasing and zeroed Nyquist for odd derivatives.
    integrator : {"sbdf2", "rk4"}
        "sbdf2": semi-implicit 2nd-order backward differentiation, with the
        stiff linear block (diffusion of Psi, viscosity, the linearised
        lambda6 couplings) implicit.  "rk4": classical explicit Runge-Kutta.
    dtype : {"float64", "float32"}
        Working precision.
    """

    rho: float = 1.0
    eta: float = 1.0
    L6: float = 0.5
    A6: float = -0.2
    B6: float = 0.4
    Gamma6: float = 1.0
    lambda6: float = 1.11
    alpha6: float = 0.0
    dx: float = 1.0
    dt: float = 0.05
    scheme: str = "spectral"
    integrator: str = "sbdf2"
    dtype: str = "float64"

    def __post_init__(self):
        for name in ("rho", "eta", "L6", "B6", "Gamma6", "dx", "dt"):
            value = getattr(self, name)
            if not np.isfinite(value) or value <= 0:
                raise InputError(f"HydroParams.{name} must be a positive finite number; got {value!r}")
        for name in ("A6", "lambda6", "alpha6"):
            if not np.isfinite(getattr(self, name)):
                raise InputError(f"HydroParams.{name} must be finite; got {getattr(self, name)!r}")
        if self.A6 >= 0:
            raise InputError(f"HydroParams.A6 must be negative (ordered hexatic phase); got {self.A6!r}")
        # the bulk term is explicit in both integrators: |Psi| relaxes at rate 2 Gamma6 |A6|, stable for rate * dt < 2
        limit = 1.0 / (self.Gamma6 * -self.A6)
        if self.dt > limit:
            raise InputError(f"HydroParams.dt = {self.dt!r} is too large: the explicit bulk term needs dt <= "
                             f"1 / (Gamma6 |A6|) = {limit:.4g} (production 0.05)")
        if self.scheme not in SCHEMES:
            raise InputError(f"HydroParams.scheme must be one of {SCHEMES}; got {self.scheme!r}")
        if self.integrator not in INTEGRATORS:
            raise InputError(f"HydroParams.integrator must be one of {INTEGRATORS}; got {self.integrator!r}")
        if self.dtype not in ("float64", "float32"):
            raise InputError(f"HydroParams.dtype must be 'float64' or 'float32'; got {self.dtype!r}")

    @property
    def psi0(self) -> float:
        """Equilibrium amplitude ``|Psi6| = sqrt(-2 A6 / B6)``."""
        return float(np.sqrt(-2 * self.A6 / self.B6))

    @property
    def real_dtype(self):
        return np.dtype(self.dtype)

    @property
    def complex_dtype(self):
        return np.dtype(np.complex64 if self.dtype == "float32" else np.complex128)

    def to_dict(self) -> dict:
        return asdict(self)
