"""The tissue's deformation budget: how much of its shear and growth each kind of cellular process makes.

The triangle method (Merkel et al., Phys. Rev. E 95, 032401, 2017; Etournay et
al., eLife 4, e07090, 2015): the cell centres around every interior vertex of
the junction network form a triangle (a four-fold vertex gives two,
:func:`frame_triangles`), and the area-weighted mean elongation ``Q`` of the
triangles measures the cells' shape.  Between two frames the tissue's
deformation is split exactly into the change of ``Q`` and the part that each
kind of cellular event takes (:func:`deformation_budget`):

1. cells leaving the analysed tissue (field of view, mask) are removed, at the
   positions of the first frame (``border``);
2. extruding cells move to the mean of their neighbours (``extrusion``);
3. the triangles move to the second frame's positions, a mother cell at the
   mean of its daughters: the tissue's total shear and growth, split into
   cell shape change, corotation, the nonlinear corotational term and the two
   correlation terms (:mod:`hexatissue.deformation.flow`);
4. the triangulation changes to the second frame's, daughters still merged:
   each connected retriangulation is an extrusion (it holds an extruding
   cell), a T1 of the ``events`` table (its kind: ``t1_cycle``,
   ``t1_intercalation``, ``t1_unresolved``), a ``resampling`` (no cell
   contact changes: the pixel network resampled, not an event) or another
   ``rearrangement``;
5. daughters split (``division``), then cells entering the tissue are added
   (``border``).

Each topological term is minus the jump of ``Q`` it makes; the total minus
the sum of the parts is the ``closure`` column (zero up to the quadrature's
error).  The order follows TissueMiner's intermediate triangulations.

The package, by concept (each module imports only those listed before it):
:mod:`.triangles` (a triangle's state tensor -> area, elongation, rotation),
:mod:`~hexatissue.deformation.flow` (the continuous part by quadrature), :mod:`.triangulation`
(each frame's triangles and contacts), :mod:`.states` (triangulations with
their shapes and regions), :mod:`.movie` (the cells by frame, the lineage,
the T1s by frame), :mod:`.regions` (tissue, grid, regions of interest),
:mod:`.interval` (one frame interval's steps) and :mod:`.budget`
(:func:`deformation_budget`; :func:`budget_chunks`, the same a chunk of frames
at a time, for movies read from disk, and :func:`event_shear`).
"""
from __future__ import annotations

from . import interval, triangulation
from .budget import budget_chunks, deformation_budget, event_shear
from .regions import read_roi, roi_tracks
from .triangulation import frame_contacts, frame_triangles

__all__ = ["frame_triangles", "frame_contacts", "deformation_budget", "budget_chunks", "event_shear", "roi_tracks",
           "read_roi"]

# beyond __all__, the names other code and the tests read from the package keep their names here (assigned, not
# imported: the module map above says where each lives)
pair_keys, triangle_edges = triangulation.pair_keys, triangulation.triangle_edges
_triple_keys = triangulation._triple_keys
COLLAPSE, _stays_positive = interval.COLLAPSE, interval._stays_positive
