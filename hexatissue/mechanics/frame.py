"""The forces of one segmented frame (:func:`frame_forces`, what the stage runs): straight or curved
junctions chosen from the junctions' own pixels.
"""
from __future__ import annotations

import warnings

import numpy as np

from ..errors import FrameWarning, InputError, user_stacklevel
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
                 sd=True, normals=None):
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

    On a surface (``normals``, with ``vertices["z"]``) every vertex is
    balanced in its tangent plane (:func:`force_system`).  Arcs are modelled
    in the image plane only: a circle on a tilted or curved surface is not a
    circle in its projection, and Young-Laplace on it needs the junction's
    geodesic curvature, which its projected pixels do not give.  So where the
    surface is not the image plane itself (some normal other than ``(0, 0,
    1)``), a frame found curved (or ``"curved"``) is inferred with straight
    junctions, with a :class:`~hexatissue.errors.FrameWarning`; on a constant
    height map everything is as without it.

    Parameters
    ----------
    labels : ndarray (H, W) of int or None
        The frame's touching cell labels (``Frame.labels``).
    cells, vertices, edges, cell_vertices : pandas.DataFrame
    box : Box, optional
    junctions : {"auto", "straight", "curved"}
    method, mu, sd
        As :func:`infer_forces`.
    normals : ndarray (n_vertices, 3), optional
        The surface's unit normal at every vertex (e.g.
        :func:`hexatissue.surface.node_normals` of the height map at the
        vertices); None: the image plane.

    Returns
    -------
    forces : Forces
    curvature : ndarray
        Per row of ``edges``: the curvature of the arcs, 1/px; 0 for
        straight junctions.
    model : str
        The model used: ``"straight"`` or ``"curved"`` (never ``"curved"`` on
        a surface other than the image plane).
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
    if normals is not None and model == "curved":
        if np.all(np.asarray(normals, float) == (0.0, 0.0, 1.0)):
            normals = None  # the image plane: its arcs are the image's
        else:
            why = (f"{share:.0%} of the tested junctions are curved" if junctions == "auto"
                   else 'junctions="curved" was asked')
            warnings.warn(FrameWarning("force inference on a surface: junction arcs are modelled in the image plane "
                                       "only, so the junctions are taken straight (vertex to vertex in 3-D) and the "
                                       "pressures push on the vertices; the curvature column is 0",
                                       f"{why}; the height map is not constant"), stacklevel=user_stacklevel())
            model = "straight"
    curvature = junction_curvature(labels, vertices, edges, box) if model == "curved" else None
    forces = infer_forces(cells, vertices, edges, cell_vertices, box=box, method=method, mu=mu, sd=sd,
                          curvature=curvature, vertex_sd=_VERTEX_SD if pixels else None, normals=normals)
    return forces, (np.zeros(len(edges)) if curvature is None else curvature), model, share
