"""Force inference from the junction network: junction tensions, cell pressures, and the stress they make.

At mechanical equilibrium every vertex of the network is at force balance
(Ishihara & Sugimura, J. Theor. Biol. 313, 201, 2012; Chiou et al., PLoS
Comput. Biol. 8, e1002512, 2012).  With straight junctions, the force on
vertex ``v`` is

    F_v = sum_j T_j u_j + sum_c P_c dA_c/dx_v = 0,

the sum over the junctions ``j`` meeting at ``v`` (``u_j`` the unit vector
from ``v`` along ``j``) and the cells ``c`` around it (``dA_c/dx_v =
(y_next - y_prev, x_prev - x_next) / 2`` for the counter-clockwise polygon).
This is minus the gradient of ``E = sum_j T_j l_j - sum_c P_c A_c``.  The
equations of the vertices that lie wholly inside the tissue (no cell 0
around them) form a sparse linear system ``A x = 0`` in the unknown
tensions and pressures (:func:`force_system`), homogeneous: tensions are
known up to a scale (fixed here by mean tension = 1) and pressures up to a
constant (fixed by mean pressure = 0).  :func:`infer_forces` solves it by
least squares (``method="lsq"``) or as the Bayesian MAP estimate with a
Gaussian prior on the tensions whose weight is chosen by ABIC
(``method="bayes"``), with posterior standard deviations.  Where the
equations leave unknowns free (open images: the vertices on the tissue's edge
give no equation but their junctions and cells are unknowns; four-fold
vertices), those are found and reported, never given a silent number
(:func:`infer_forces`); the free modes are extended, so on an open image
least squares determines nothing and only the Bayesian prior makes an
estimate (docs/mechanics.md).  Curved junctions (Young-Laplace; the
``curvature`` argument, measured by :mod:`hexatissue.mechanics.curvature`):
the vertices are balanced by the tensions along the arcs' end tangents, and
each junction's curvature ties the pressure difference across it to its
tension (:func:`force_system`); the vertices then set the tensions on their
own, and open images are determined.  :func:`frame_forces`, what the stage
runs, chooses between the two from the junctions' own pixels
(:func:`hexatissue.mechanics.curvature.junction_shapes`).
:mod:`hexatissue.mechanics.stress` turns
the forces into the Batchelor stress of each cell, of the tissue and on the
Gamma_p grid.  On a height map (``normals``, with the vertices' heights) every
vertex is balanced in the surface's tangent plane, and the stress is taken
in each cell's tangent frame (docs/surface.md, "Forces on a height map").

The package, by concept (each module imports only those listed before it):
:mod:`.curvature` (junction arcs), :mod:`.stress` (Batchelor stress),
:mod:`.history` (tensions before each T1), :mod:`.system` (the force balance
as a sparse system), :mod:`.solve` (factorisation, free unknowns, posterior
variances), :mod:`.inference` (:func:`infer_forces`) and :mod:`.frame`
(:func:`frame_forces`); :mod:`.evolver` and :mod:`.vdat` read other tools'
files.
"""
from __future__ import annotations

from . import curvature
from .curvature import junction_curvature
from .frame import JUNCTION_MODELS, frame_forces
from .history import t1_tension_histories
from .inference import METHODS, MU_RANGE, Forces, infer_forces
from .stress import cell_stress, stress_grid, tissue_stress
from .system import ForceSystem, force_system

__all__ = ["ForceSystem", "Forces", "force_system", "infer_forces", "frame_forces", "JUNCTION_MODELS", "MU_RANGE",
           "cell_stress", "tissue_stress", "stress_grid",
           "junction_curvature", "t1_tension_histories", "METHODS"]

# beyond __all__, the name the one-module package also gave (assigned, not imported: it lives in .curvature)
junction_shapes = curvature.junction_shapes
