"""Topological defects of p-atic fields by winding numbers.

For a complex field ``F`` sampled on a regular grid (``Gamma_p`` coarse-grained
from cells, or ``Psi_6`` of the continuum model), the orientation is
``theta = Arg(F) / p``.  Around every grid plaquette the charge is
``s = (1 / 2 pi) sum dtheta`` with each ``dtheta`` wrapped into
``(-pi/p, pi/p]``, so ``s`` is a multiple of ``1/p``; nonzero ``s`` marks a
defect at the plaquette centre.  Loops run counter-clockwise in (x, y),
x = column, y = row.

The package, by concept (each module imports only those listed before it):
:mod:`.field` (the winding of one field), :mod:`.grid` (the defects of a
coarse-grained grid table), :mod:`.density`, :mod:`.tracking` (trajectories),
:mod:`.pairs` (pair events) and :mod:`.movie` (a movie's defects per p, a
chunk of frames at a time: what the defect tracks stage runs).
"""
from __future__ import annotations

from . import field, grid, movie, pairs, tracking
from .density import defect_density
from .field import charge_mask, defects_from_field, plaquette_charges
from .grid import find_defects
from .pairs import defect_events
from .tracking import DefectLinker, track_defects

__all__ = [
    "plaquette_charges",
    "defects_from_field",
    "find_defects",
    "defect_density",
    "track_defects",
    "DefectLinker",
    "defect_events",
    "charge_mask",
]

# beyond __all__, the names other code and the tests read from the package keep their names here (assigned, not
# imported: the module map above says where each lives)
K, EVENT_KINDS, DEFECT_SPACINGS = grid.K, pairs.EVENT_KINDS, movie.DEFECT_SPACINGS
winding, link_movie_defects, _track_ends = field.winding, movie.link_movie_defects, tracking._track_ends
MovieDefects, default_max_distance = movie.MovieDefects, movie.default_max_distance
