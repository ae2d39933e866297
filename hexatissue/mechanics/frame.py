"""The forces of one segmented frame (:func:`frame_forces`, what the stage runs): straight or curved
junctions chosen from the junctions' own pixels.
"""
from __future__ import annotations

import numpy as np

from ..errors import InputError
from .curvature import junction_curvature, junction_shapes
from .inference import infer_forces


#: Junction models of :func:`frame_forces`.
JUNCTION_MODELS = ("auto", "straight", "curved")


# frame_forces, junctions="auto": arcs when more than this share of the tested junctions show a curvature.  Measured
# shares: Surface Evolver foam drawn at 4 px per unit 0.78; vertex-model sheets (straight junctions) 0.00-0.01
# clean, 0.13 (20 px per cell) and 0.24 (40 px) with boundary noise of 0.5 px.
_CURVED_SHARE = 0.5
# frame_forces: s.d. of a vertex coordinate found in a label image, px (the mesh's sub-pixel vertices: median distance
# to the truth 0.21-0.33 px on rendered vertex models, 0.25 px on Voronoi labels, i.e. about 0.2 px per axis).  It
# floors the posterior s.d. where the balance is met exactly (infer_forces, vertex_sd); on the benchmark's clean
# sheets (seed 0) the fitted noise is 1.4-2.4 x the floor, and benchmarks/results_forces.md is the same without it.
_VERTEX_SD = 0.2


def frame_forces(labels, cells, vertices, edges, cell_vertices, box=None, junctions="auto", method="bayes", mu=None,
                 sd=True):
    """Forces of one frame with the junction model chosen from its pixels: what the mechanics stage runs.

    ``junctions="auto"``: every interior junction with at least 4 pixel
    points is tested on its own pixels
    (:func:`hexatissue.mechanics.curvature.junction_shapes`: a parabola
    against a line, by the drop of the residual over the pixel noise).  When
    more than half of them show a curvature (``_CURVED_SHARE``), the tissue is
    a foam of arcs: every junction is an arc through its end vertices
    (tangent forces and Young-Laplace); else every junction is straight,
    with the pressures pushing on the vertices (the vertex model).  With
    pixels, the posterior s.d. are floored by vertices known to 0.2 px per
    axis (:func:`infer_forces`, ``vertex_sd``).  The
    choice is made per frame, not per junction: a network mixing the two
    forms is exact for exact shapes (:func:`force_system`, ``arcs``) but, with
    the curvatures of a few junctions only, ill-conditioned: measured on the
    Surface Evolver foam with 68 % of the junctions as arcs, tension r = 0.05
    (0.985 with all of them), and on a vertex-model sheet with boundary noise
    0.07 (0.61 straight; benchmarks/results_forces.md).  ``"straight"``,
    ``"curved"``: that model for every junction.  ``labels`` None (polygon
    input): straight.

    Parameters
    ----------
    labels : ndarray (H, W) of int or None
        The frame's touching cell labels (``Frame.labels``).
    cells, vertices, edges, cell_vertices : pandas.DataFrame
    box : Box, optional
    junctions : {"auto", "straight", "curved"}
    method, mu, sd
        As :func:`infer_forces`.

    Returns
    -------
    forces : Forces
    curvature : ndarray
        Per row of ``edges``: the curvature of the arcs, 1/px; 0 for
        straight junctions.
    model : str
        The model used: ``"straight"`` or ``"curved"``.
    curved_share : float
        The share of the tested junctions whose pixels show a curvature (NaN
        when none was tested: ``"straight"``, ``"curved"``, no pixels).
    """
    if junctions not in JUNCTION_MODELS:
        raise InputError(f"junctions must be one of {JUNCTION_MODELS}; got {junctions!r}")
    pixels = labels is not None and isinstance(labels, np.ndarray) and labels.ndim == 2
    model, share = ("straight" if junctions == "auto" or not pixels else junctions), np.nan
    if pixels and junctions == "auto":
        shapes = junction_shapes(labels, vertices, edges, box)
        tested = ((edges["cell_a"].to_numpy() != 0) & (edges["cell_b"].to_numpy() != 0)
                  & (shapes["n_points"].to_numpy() >= 4))
        if tested.any():
            share = float(shapes["curved"].to_numpy(bool)[tested].mean())
            model = "curved" if share > _CURVED_SHARE else "straight"
    curvature = junction_curvature(labels, vertices, edges, box) if model == "curved" else None
    forces = infer_forces(cells, vertices, edges, cell_vertices, box=box, method=method, mu=mu, sd=sd,
                          curvature=curvature, vertex_sd=_VERTEX_SD if pixels else None)
    return forces, (np.zeros(len(edges)) if curvature is None else curvature), model, share
