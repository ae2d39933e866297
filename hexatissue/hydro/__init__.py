"""Active hexatic hydrodynamics: Psi6 coupled to an incompressible flow on a periodic grid.

See docs/hydro.md for the equations, the numerical scheme and the reproduced
experiments.  Positions: node ``[i, j]`` at x = j dx (column), y = i dx (row).
"""
from .experiments import default_params, departure_angle, run_dipole, run_quadrupole
from .initial import dipole_initial, quadrupole_initial, thermalise
from .params import HydroParams
from .run import HydroResult, integrate, open_run
from .solver import Solver, State

__all__ = [
    "HydroParams",
    "Solver",
    "State",
    "HydroResult",
    "integrate",
    "open_run",
    "run_dipole",
    "run_quadrupole",
    "default_params",
    "departure_angle",
    "dipole_initial",
    "quadrupole_initial",
    "thermalise",
]
