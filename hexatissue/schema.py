"""Table schemas: every column's dtype kind, unit and meaning, and :func:`validate`.

Ids are always columns, never the index.  Positions are in pixels with
``x`` = image column and ``y`` = image row, origin at the centre of pixel
(0, 0).  Complex values are stored as ``_re``/``_im`` column pairs so the
tables round-trip through Parquet.  Columns whose name contains ``{p}`` stand
for one column per symmetry order ``p`` (e.g. ``gamma6_re``).
"""
from __future__ import annotations

import functools
import re
import warnings

import numpy as np
import pandas as pd

from .errors import InputError

__all__ = ["TABLES", "SURFACE_MESH_TABLES", "DEFORMATION_TERMS", "ISOTROPIC_TERMS", "validate", "describe", "column_units", "require_columns", "empty_table", "track_ids", "interior_mask",
           "FrameRows", "rows_by_frame"]

#: The terms of the deformation budget (``deformation`` table), each a shear rate with ``_xx`` and ``_xy`` columns.
DEFORMATION_TERMS = {
    "total": "the tissue's shear (xx, xy) and growth (iso: rate of log area) from the cells' motion",
    "cell_shape": "change of the mean triangle elongation (xx, xy) and of the log mean triangle area (iso)",
    "corotation": "the mean elongation turned by the mean vorticity",
    "nonlinear": "the triangles' nonlinear corotational term (second order in elongation)",
    "growth_correlation": "correlation of the triangles' elongation with their growth",
    "rotation_correlation": "correlation of the triangles' elongation with their rotation",
    "t1_cycle": "T1s that are undone (events of kind cycle)",
    "t1_intercalation": "T1s that last (events of kind intercalation)",
    "t1_unresolved": "T1s too close to the end to tell (events of kind unresolved)",
    "rearrangement": "other retriangulations (cell contacts change, but no T1 of the events table explains it), incl. "
                     "triangles that flip over",
    "resampling": "retriangulations that change no cell contact (a vertex merging with or parting from another, "
                  "contacts held as four-fold vertices included): pixel resampling of the network, not an event",
    "division": "cell divisions",
    "extrusion": "cell extrusions (a cell shrinking to its neighbours' centre, then leaving)",
    "border": "cells entering or leaving the analysed tissue (field of view, mask, interior appearance)",
    "advection": "triangles moving between regions fixed in space (grid regions; 0 for the tissue and ROIs)",
    "closure": "total minus the sum of the other terms (0 up to the quadrature's error)",
}
#: The terms that also change areas: they have an ``_iso`` column.
ISOTROPIC_TERMS = ("total", "cell_shape", "t1_cycle", "t1_intercalation", "t1_unresolved", "rearrangement", "resampling",
                   "division", "extrusion", "border", "advection", "closure")


def _deformation_columns():
    out = {}
    for term, meaning in DEFORMATION_TERMS.items():
        out[f"{term}_xx"] = ("f", "1/frame", f"{meaning}: xx")
        out[f"{term}_xy"] = ("f", "1/frame", f"{meaning}: xy")
        if term in ISOTROPIC_TERMS:
            out[f"{term}_iso"] = ("f", "1/frame", f"{meaning}: isotropic")
    return out


#: Every table, in the order they are written: column -> (dtype kind: i integer, f float, b bool, O string/object, unit, meaning)
TABLES: dict[str, dict[str, tuple[str, str, str]]] = {
    "cells": {
        "frame": ("i", "frame", "time point (0 for a single image)"),
        "cell": ("i", "", "label id in the segmented image"),
        "track": ("i", "", "track id (equal to `cell` when ids are consistent over time)"),
        "x": ("f", "px", "pixel centroid, column"),
        "y": ("f", "px", "pixel centroid, row"),
        "area": ("f", "px^2", "number of pixels of the cell (membranes split between neighbours)"),
        "polygon_area": ("f", "px^2", "area of the vertex polygon (NaN when n_sides is 0: no polygon)"),
        "perimeter": ("f", "px", "perimeter of the vertex polygon (NaN when n_sides is 0)"),
        "n_sides": ("i", "", "number of polygon vertices (= junctions around the cell; 0: fewer than 3 "
                    "vertices on its boundary, no polygon)"),
        "n_boundaries": ("i", "", "boundary cycles of the cell (> 1: holes, pieces or pinches)"),
        "is_border": ("b", "", "touches the image edge or the background (0, background labels, the "
                      "outside of a skeleton, outside the mask)"),
        "intensity_mean": ("f", "intensity", "mean of the raw channel over the cell's pixels (with --intensity)"),
        "junction_polarity_re": ("f", "", "nematic of the junctions' integrated intensity, real part (with --intensity)"),
        "junction_polarity_im": ("f", "", "nematic of the junctions' integrated intensity, imaginary part"),
        "gamma{p}_re": ("f", "", "real part of the p-fold shape function"),
        "gamma{p}_im": ("f", "", "imaginary part of the p-fold shape function"),
        "z": ("f", "px", "height of the surface above the cell's centroid, converted to px: the z of its 3-D "
              "position (with --surface)"),
        "surface_area": ("f", "px^2", "area of the cell polygon lifted onto the height map (with --surface; NaN "
                         "without a polygon)"),
        "surface_perimeter": ("f", "px", "perimeter of the lifted polygon: its 3-D junction lengths (with --surface)"),
        "normal_x": ("f", "", "unit normal of the cell's tangent plane (its lifted polygon's vector area, facing +z), "
                     "x component (with --surface)"),
        "normal_y": ("f", "", "unit normal of the cell's tangent plane, y component"),
        "normal_z": ("f", "", "unit normal of the cell's tangent plane, z component (the cosine of its tilt)"),
        "surface_gamma{p}_re": ("f", "", "real part of the p-fold shape function in the cell's tangent plane, first "
                                "axis the image x axis projected on it (with --surface)"),
        "surface_gamma{p}_im": ("f", "", "imaginary part of the p-fold shape function in the cell's tangent plane"),
        "vx": ("f", "px/frame", "velocity along x: centred difference of the centroid along the track (NaN at track "
               "ends, divisions and gaps; hexatissue.flow.cell_velocities)"),
        "vy": ("f", "px/frame", "velocity along y (rows), as vx"),
        "vz": ("f", "px/frame", "velocity along z: centred difference of the cell's height z along the track, as vx "
               "(with --surface; hexatissue.flow.surface_velocities)"),
        "surface_vx": ("f", "px/frame", "3-D velocity (vx, vy, vz) along the first axis of the cell's tangent frame (the "
                       "image x axis projected on its tangent plane, as surface_gamma{p}; with --surface)"),
        "surface_vy": ("f", "px/frame", "3-D velocity along the second axis of the cell's tangent frame (normal x first "
                       "axis)"),
        "vn": ("f", "px/frame", "3-D velocity along the cell's normal (positive towards +z; with --surface)"),
        "pressure": ("f", "tension/px", "inferred pressure, relative to the frame's mean (with --mechanics)"),
        "pressure_sd": ("f", "tension/px", "posterior s.d. of the pressure (Bayesian estimator)"),
        "stress_xx": ("f", "tension/px", "Batchelor stress of the cell, xx (with --mechanics; on a height map along "
                       "the cell's tangent axes e1, e2 instead of x, y)"),
        "stress_xy": ("f", "tension/px", "Batchelor stress of the cell, xy"),
        "stress_yy": ("f", "tension/px", "Batchelor stress of the cell, yy"),
    },
    "vertices": {
        "frame": ("i", "frame", "time point (0 for a single image)"),
        "vertex": ("i", "", "vertex id"),
        "x": ("f", "px", "column"),
        "y": ("f", "px", "row"),
        "z": ("f", "px", "height of the vertex on the height map, converted to px (with --surface)"),
        "degree": ("i", "", "number of junctions (3; >=4 four-fold vertex / rosette; 2 at a corner of an open "
                   "image or on a boundary with no vertex winding around a periodic box)"),
        "is_border": ("b", "", "touches the background (cell 0)"),
        "n_merged": ("i", "", "junctions between two cells shorter than merge_distance contracted into this vertex: "
                     "contacts held as a four-fold vertex (label input only)"),
    },
    "edges": {
        "frame": ("i", "frame", "time point (0 for a single image)"),
        "edge": ("i", "", "junction id"),
        "vertex_a": ("i", "", "first end vertex"),
        "vertex_b": ("i", "", "second end vertex"),
        "cell_a": ("i", "", "smaller id of the two cells the junction separates (0 = outside the tissue)"),
        "cell_b": ("i", "", "larger id of the two cells"),
        "length": ("f", "px", "straight-line distance between the end vertices"),
        "intensity_mean": ("f", "intensity", "mean of the raw channel along the junction (with --intensity)"),
        "intensity_total": ("f", "intensity px", "intensity_mean x length: integrated junction intensity"),
        "tension": ("f", "tension", "inferred tension, relative: the frame's mean interior tension is 1 "
                    "(with --mechanics)"),
        "tension_sd": ("f", "tension", "posterior s.d. of the tension (Bayesian estimator)"),
        "curvature": ("f", "1/px", "signed curvature of the arc fitted to the junction's pixels, positive when it "
                      "turns counter-clockwise from vertex_a to vertex_b; 0 when drawn straight (with --mechanics)"),
    },
    "cell_vertices": {
        "frame": ("i", "frame", "time point (0 for a single image)"),
        "cell": ("i", "", "cell id"),
        "rank": ("i", "", "position of the vertex in the polygon (counter-clockwise in x, y)"),
        "vertex": ("i", "", "vertex id"),
        "image_x": ("i", "box", "periodic image of the vertex in the contiguous polygon, along x (0 on open images)"),
        "image_y": ("i", "box", "periodic image of the vertex in the contiguous polygon, along y"),
    },
    "grid": {
        "frame": ("i", "frame", "time point (0 for a single image)"),
        "node": ("i", "", "grid node id"),
        "x": ("f", "px", "node position, column"),
        "y": ("f", "px", "node position, row"),
        "Gamma{p}_re": ("f", "", "real part of the coarse-grained shape parameter"),
        "Gamma{p}_im": ("f", "", "imaginary part of the coarse-grained shape parameter"),
        "n_cells": ("i", "", "number of cells averaged"),
        "row": ("i", "", "node index along y"),
        "col": ("i", "", "node index along x"),
        "coverage": ("f", "", "fraction of the disk on interior cells (1 in a periodic box)"),
        "valid": ("b", "", "node used for statistics and defects"),
        "radius": ("f", "px", "coarse-graining disk radius"),
        "spacing": ("f", "px", "requested grid spacing"),
        "normal_x": ("f", "", "unit normal of the height map at the node, x (with a height map only: Gamma_p is "
                              "then in the node's tangent frame, e1 = x projected on its plane)"),
        "normal_y": ("f", "", "unit normal of the height map at the node, y (with a height map only)"),
        "normal_z": ("f", "", "unit normal of the height map at the node, z (with a height map only)"),
    },
    "defects": {
        "frame": ("i", "frame", "time point (0 for a single image)"),
        "defect": ("i", "", "defect id"),
        "x": ("f", "px", "position, column"),
        "y": ("f", "px", "position, row"),
        "charge": ("f", "", "topological charge (multiple of 1/p)"),
        "p": ("i", "", "symmetry order"),
        "track": ("i", "", "defect track id, per p (movies: linked across frames by hexatissue.track_defects)"),
    },
    "defect_events": {
        "frame": ("i", "frame", "creation: first frame the pair exists; annihilation: last frame it exists"),
        "kind": ("O", "", "creation or annihilation (appearance / disappearance for unpaired defects)"),
        "x": ("f", "px", "pair midpoint, column"),
        "y": ("f", "px", "pair midpoint, row"),
        "track_plus": ("i", "", "defect track of the positive partner (-1 when absent)"),
        "track_minus": ("i", "", "defect track of the negative partner (-1 when absent)"),
        "separation": ("f", "px", "distance between the partners (NaN when unpaired)"),
        "p": ("i", "", "symmetry order"),
    },
    "events": {
        "event": ("i", "", "event id"),
        "kind": ("O", "", "cycle, intercalation or unresolved"),
        "frame_start": ("i", "frame", "first frame after the a-b contact is lost"),
        "frame_end": ("f", "frame", "frame the inverse T1 restores a-b (NaN unless kind == cycle)"),
        "duration": ("f", "frame", "frame_end - frame_start (cycles), else NaN"),
        "cell_a": ("i", "", "first cell losing the contact"),
        "cell_b": ("i", "", "second cell losing the contact"),
        "cell_c": ("i", "", "first cell gaining a contact"),
        "cell_d": ("i", "", "second cell gaining a contact"),
        "x": ("f", "px", "centre of the quartet, column"),
        "y": ("f", "px", "centre of the quartet, row"),
        "frame_gain": ("i", "frame", "first frame with the c-d contact (> frame_start: a four-fold vertex persisted)"),
        "frame_undo": ("f", "frame", "first frame without the c-d contact again in the inverse T1 (cycles), else NaN"),
        "is_border": ("b", "", "one of the four cells is a border cell at frame_start"),
        "shear_xx": ("f", "px^2", "the T1's share of the tissue's T1 shear x the triangulated area, xx "
                     "(with the deformation stage)"),
        "shear_xy": ("f", "px^2", "the T1's share of the tissue's T1 shear x the triangulated area, xy"),
    },
    "neighbour_events": {
        "event": ("i", "", "event id"),
        "track": ("i", "", "the cell whose neighbour list changed"),
        "kind": ("O", "", "cycle (the list returns to the one it left), intercalation or unresolved"),
        "frame_start": ("i", "frame", "first frame with the changed neighbour list"),
        "frame_end": ("f", "frame", "first frame the list is back (cycles), else NaN"),
        "duration": ("f", "frame", "frame_end - frame_start (cycles), else NaN"),
        "n_lost": ("i", "", "neighbours lost at frame_start"),
        "n_gained": ("i", "", "neighbours gained at frame_start"),
        "x": ("f", "px", "the cell's centroid at frame_start, column"),
        "y": ("f", "px", "the cell's centroid at frame_start, row"),
        "is_border": ("b", "", "a border cell at frame_start"),
    },
    "lineage": {
        "track": ("i", "", "track id"),
        "frame_start": ("i", "frame", "first frame the track is present"),
        "frame_end": ("i", "frame", "last frame the track is present (inclusive)"),
        "n_frames": ("i", "frame", "frames the track is present (fewer than the span when gaps were closed)"),
        "parent": ("i", "", "track id of the mother cell for daughters of a division, else 0"),
        "begin": ("O", "", "how the track starts: movie_start, division, border (enters the field of view) or appearance (interior)"),
        "end": ("O", "", "how the track ends: movie_end, division, border (leaves the field of view) or extrusion (interior)"),
        "division_area_ratio": ("f", "", "daughters of a division: their summed area at their first frame over the "
                                "mother's at its last frame (NaN on other rows)"),
        "division_suspect": ("b", "", "daughters of a division that fails a plausibility rule (see division_reason)"),
        "division_reason": ("O", "", "the rules a suspect division fails (hexatissue.track.DIVISION_REASONS), joined "
                            "by ';'; empty when plausible or not a daughter"),
        "extrusion_area_ratio": ("f", "", "extrusions: the cell's area at its last frame over its median area (NaN on "
                                 "other rows and on tracks of one frame)"),
        "extrusion_unconfirmed": ("b", "", "an extrusion whose cell did not shrink to half its median area before it "
                                  "left (hexatissue.track.check_extrusions): as likely lost by the tracking"),
    },
    "cell_events": {
        "track": ("i", "", "track id"),
        "n_frames": ("i", "frame", "frames the cell is present"),
        "n_cycles": ("i", "", "T1 cycles the cell takes part in (as a, b, c or d)"),
        "n_intercalations": ("i", "", "intercalations the cell takes part in"),
        "n_unresolved": ("i", "", "right-censored T1s the cell takes part in"),
        "mean_cycle_period": ("f", "frame", "mean duration of its T1 cycles (NaN if none)"),
        "n_intervals": ("i", "", "intervals between consecutive intercalations of the cell"),
        "mean_intercalation_interval": ("f", "frame", "mean time between consecutive intercalations of the cell (NaN if fewer than 2)"),
    },
    "flow": {
        "frame": ("i", "frame", "time point"),
        "node": ("i", "", "grid node id (the grid table's)"),
        "x": ("f", "px", "node position, column"),
        "y": ("f", "px", "node position, row"),
        "radius": ("f", "px", "disk radius of the affine fit"),
        "vx": ("f", "px/frame", "fitted velocity at the node, along x"),
        "vy": ("f", "px/frame", "fitted velocity at the node, along y"),
        "vorticity": ("f", "1/frame", "dvy/dx - dvx/dy (positive: clockwise on the displayed image, y down)"),
        "divergence": ("f", "1/frame", "dvx/dx + dvy/dy"),
        "strain_xx": ("f", "1/frame", "traceless strain rate (dvx/dx - dvy/dy) / 2"),
        "strain_xy": ("f", "1/frame", "traceless strain rate (dvx/dy + dvy/dx) / 2"),
        "n_cells": ("i", "", "cells in the disk with a velocity"),
        "valid": ("b", "", "the grid node is valid and the fit exists"),
        "surface_vx": ("f", "px/frame", "fitted 3-D velocity at the node along the first axis of its tangent frame (the "
                       "image x axis projected on the tangent plane of grid.normal_x/_y/_z; with --surface)"),
        "surface_vy": ("f", "px/frame", "fitted 3-D velocity along the second axis of the node's tangent frame (normal x "
                       "first axis)"),
        "vn": ("f", "px/frame", "fitted 3-D velocity along the node's normal (positive towards +z; with --surface)"),
        "surface_vorticity": ("f", "1/frame", "vorticity on the surface: L21 - L12 of the velocity gradient in the "
                              "node's tangent frame (with --surface)"),
        "surface_divergence": ("f", "1/frame", "surface divergence of the tangential velocity, div_s v_t (with "
                               "--surface)"),
        "surface_strain_xx": ("f", "1/frame", "surface rate of strain (L11 - L22) / 2 in the node's tangent frame, the "
                              "normal motion's included (with --surface)"),
        "surface_strain_xy": ("f", "1/frame", "surface rate of strain (L12 + L21) / 2 in the node's tangent frame"),
        "mean_curvature": ("f", "1/px", "mean curvature H = -div_s n / 2 of the cells' normals (negative on a dome, "
                           "positive in a trough; with --surface)"),
        "areal_rate": ("f", "1/frame", "rate of change of the log of a surface area moving with the cells: the "
                       "surface divergence of their 3-D velocity, div_s v = div_s v_t - 2 H vn (with --surface)"),
        "piv_vx": ("f", "px/frame", "PIV velocity of the raw channel at the node, along x (with --intensity)"),
        "piv_vy": ("f", "px/frame", "PIV velocity of the raw channel at the node, along y (with --intensity)"),
        "piv_peak": ("f", "", "PIV normalised correlation peak (1: an exact copy)"),
    },
    "deformation": {
        "frame": ("i", "frame", "the interval from this frame to the next"),
        "region": ("O", "", "tissue (the whole triangulation), grid (a node's region of the Gamma_p grid) or roi"),
        "region_id": ("i", "", "the grid node or the ROI label (-1 for the tissue)"),
        "area": ("f", "px^2", "the region's triangulated area at the end of the interval"),
        **_deformation_columns(),
        "rotation": ("f", "rad/frame", "the mean vorticity of the cells' motion"),
        "n_triangles": ("i", "", "triangles of the tissue at the start of the interval (-1 on region rows)"),
        "n_flipped": ("i", "", "triangles that would flip over on the way, retriangulated instead (-1 on region rows)"),
        "tracking_doubtful": ("b", "", "the interval's events rest on doubtful tracking: its later frame is flagged "
                              "by the tracking QC (interior extrusions above 1 % of the cells, or frames far apart), "
                              "or a suspect division or an unconfirmed extrusion happens in it"),
    },
    "stress": {
        "frame": ("i", "frame", "time point (0 for a single image)"),
        "node": ("i", "", "grid node id (as in grid)"),
        "x": ("f", "px", "node position, column"),
        "y": ("f", "px", "node position, row"),
        "stress_xx": ("f", "tension/px", "area-weighted mean Batchelor stress of the cells in the node's disk, xx "
                       "(on a height map along the node's tangent axes e1, e2)"),
        "stress_xy": ("f", "tension/px", "mean stress, xy"),
        "stress_yy": ("f", "tension/px", "mean stress, yy"),
        "stress_iso": ("f", "tension/px", "isotropic part, (xx + yy) / 2"),
        "stress2_re": ("f", "tension/px", "nematic (p = 2) part, (xx - yy) / 2"),
        "stress2_im": ("f", "tension/px", "nematic (p = 2) part, xy"),
        "stress6_re": ("f", "tension/px", "hexatic (p = 6) moment of the junction tensions, real part"),
        "stress6_im": ("f", "tension/px", "hexatic (p = 6) moment of the junction tensions, imaginary part"),
        "n_cells": ("i", "", "cells with a stress in the disk"),
    },
    "force_fit": {
        "frame": ("i", "frame", "time point (0 for a single image)"),
        "arcs": ("b", "", "the junctions were drawn as arcs (Young-Laplace); False: straight (--junctions)"),
        "curved_share": ("f", "", "share of the tested interior junctions whose pixels show a curvature (NaN: "
                         "not tested)"),
        "mu": ("f", "", "prior weight of the Bayesian estimate (ABIC's choice or --mechanics-mu); NaN for least "
               "squares"),
        "residual": ("f", "tension", "RMS force imbalance at the balanced vertices (mean tension 1)"),
        "n_equations": ("i", "", "force-balance equations"),
        "n_unknowns": ("i", "", "unknown tensions and pressures"),
        "n_free": ("i", "", "interior junctions and cells the balance leaves free (NaN under least squares, the "
                   "prior's value under the Bayesian estimate)"),
    },
}

#: The tables of labelled surface meshes (:func:`hexatissue.surface.mesh_tissue`, ``hexatissue surface-mesh``): not
#: tables of a Movie (``analyze`` does not make them), but described, validated and written with their units alike.
SURFACE_MESH_TABLES: dict[str, dict[str, tuple[str, str, str]]] = {
    "mesh_cells": {
        "frame": ("i", "frame", "the mesh's position among the meshes read (0 for one mesh)"),
        "cell": ("i", "", "the cell's label in the mesh"),
        "x": ("f", "px", "area centroid of the cell's faces, x (inside a curved surface, not on it)"),
        "y": ("f", "px", "area centroid of the cell's faces, y"),
        "z": ("f", "px", "area centroid of the cell's faces, z"),
        "area": ("f", "px^2", "sum of the areas of the cell's faces"),
        "perimeter": ("f", "px", "length of the cell's boundary (every loop) along the mesh edges"),
        "polygon_perimeter": ("f", "px", "perimeter of the polygon of its junction vertices (straight sides; NaN "
                              "below 3 sides)"),
        "n_sides": ("i", "", "junction vertices on the cell's longest boundary loop (its polygon's vertices)"),
        "n_neighbours": ("i", "", "cells sharing a boundary with the cell"),
        "n_boundaries": ("i", "", "boundary loops of the cell (> 1: holes or pieces)"),
        "n_faces": ("i", "", "mesh faces of the cell"),
        "is_border": ("b", "", "the cell touches the background (label 0) or the mesh's edge"),
        "normal_x": ("f", "", "unit normal (the vector area of its faces), x"),
        "normal_y": ("f", "", "unit normal, y"),
        "normal_z": ("f", "", "unit normal, z"),
        "e1_x": ("f", "", "first axis of the cell's tangent frame (the reference direction projected), x"),
        "e1_y": ("f", "", "first axis of the tangent frame, y"),
        "e1_z": ("f", "", "first axis of the tangent frame, z"),
        "gamma{p}_re": ("f", "", "real part of gamma_p of the junction polygon in the tangent frame"),
        "gamma{p}_im": ("f", "", "imaginary part of gamma_p in the tangent frame"),
        "Gamma{p}_re": ("f", "", "real part of the coarse-grained Gamma_p at the cell, in its tangent frame: the mean "
                        "gamma_p of the interior cells within the radius along the surface, each parallel-transported "
                        "into the frame (NaN: no such cell)"),
        "Gamma{p}_im": ("f", "", "imaginary part of the coarse-grained Gamma_p at the cell"),
        "n_disk": ("i", "", "interior cells averaged in Gamma_p (those within the radius, the cell itself if "
                   "interior)"),
        "valid": ("b", "", "Gamma_p's disk lies on the tissue: it averages a cell and holds no border cell (every "
                  "cell of a closed surface); the coarse defects are looked for only where all cells are valid"),
    },
    "mesh_vertices": {
        "frame": ("i", "frame", "the mesh's position among the meshes read"),
        "vertex": ("i", "", "index of the mesh vertex"),
        "x": ("f", "px", "position, x"),
        "y": ("f", "px", "position, y"),
        "z": ("f", "px", "position, z"),
        "n_cells": ("i", "", "cells meeting at the vertex"),
        "is_border": ("b", "", "the background or the mesh's edge meets there too"),
    },
    "mesh_junctions": {
        "frame": ("i", "frame", "the mesh's position among the meshes read"),
        "junction": ("i", "", "junction id"),
        "cell_a": ("i", "", "the cell on the left going from vertex_a to vertex_b, seen from the side the normals "
                   "face"),
        "cell_b": ("i", "", "the cell on the right (0: the background or the mesh's edge)"),
        "vertex_a": ("i", "", "mesh vertex where the junction starts"),
        "vertex_b": ("i", "", "mesh vertex where the junction ends"),
        "length": ("f", "px", "length along the mesh edges"),
        "chord": ("f", "px", "straight distance between its end vertices"),
    },
    "mesh_defects": {
        "frame": ("i", "frame", "the mesh's position among the meshes read"),
        "defect": ("i", "", "defect id (per frame)"),
        "field": ("O", "", "the field whose defect it is: coarse (the coarse-grained Gamma_p, the flat analysis's "
                  "defects) or cells (each cell's own gamma_p)"),
        "vertex": ("i", "", "the junction vertex (mesh vertex index) whose dual triangles carry the charge"),
        "x": ("f", "px", "position (the junction vertex), x"),
        "y": ("f", "px", "position, y"),
        "z": ("f", "px", "position, z"),
        "charge": ("f", "", "topological charge with the enclosed curvature (multiple of 1/p)"),
        "p": ("i", "", "symmetry order"),
        "cell_a": ("i", "", "first cell around the vertex (counter-clockwise about the normal)"),
        "cell_b": ("i", "", "second cell around the vertex"),
        "cell_c": ("i", "", "third cell around the vertex"),
        "n_cells": ("i", "", "cells around the vertex (> 3: its dual triangles fanned from cell_a)"),
    },
    "mesh_frames": {
        "frame": ("i", "frame", "the mesh's position among the meshes read"),
        "n_cells": ("i", "", "cells"),
        "n_vertices": ("i", "", "junction vertices"),
        "n_junctions": ("i", "", "junctions"),
        "euler": ("i", "", "Euler characteristic V - E + F of the mesh (2: a closed sphere-like surface)"),
        "closed": ("b", "", "the mesh has no edge and every face is a cell"),
        "r_cell": ("f", "px", "R_cell = sqrt(mean area / pi) of the interior cells (of all cells when none is "
                   "interior)"),
        "radius": ("f", "px", "radius of the coarse-graining disks along the surface (default 2.5 R_cell)"),
        "charge{p}": ("f", "", "sum of the p-fold defect charges of the cells' gamma_p (= euler on a closed surface)"),
        "undefined{p}": ("i", "", "dual triangles with no charge of the cells' gamma_p (a cell without gamma_p)"),
        "coarse_charge{p}": ("f", "", "sum of the p-fold defect charges of the coarse-grained Gamma_p (= euler on a "
                             "closed surface)"),
        "coarse_undefined{p}": ("i", "", "dual triangles with no charge of Gamma_p (a cell whose disk averages no "
                                "cell)"),
    },
    "mesh_events": {
        "event": ("i", "", "event id"),
        "kind": ("O", "", "cycle, intercalation or unresolved"),
        "frame_start": ("i", "frame", "first frame after the a-b contact is lost"),
        "frame_end": ("f", "frame", "frame the inverse T1 restores a-b (NaN unless kind == cycle)"),
        "duration": ("f", "frame", "frame_end - frame_start (cycles), else NaN"),
        "cell_a": ("i", "", "first cell losing the contact (its label)"),
        "cell_b": ("i", "", "second cell losing the contact"),
        "cell_c": ("i", "", "first cell gaining a contact"),
        "cell_d": ("i", "", "second cell gaining a contact"),
        "x": ("f", "px", "mean of the four cells' centroids at frame_start, x (inside a curved surface)"),
        "y": ("f", "px", "mean of the four cells' centroids, y"),
        "z": ("f", "px", "mean of the four cells' centroids, z"),
        "frame_gain": ("i", "frame", "first frame with the c-d contact (> frame_start: a four-fold vertex persisted)"),
        "frame_undo": ("f", "frame", "first frame without the c-d contact again in the inverse T1 (cycles), else NaN"),
        "is_border": ("b", "", "one of the four cells touches the background or the mesh's edge at frame_start"),
    },
}


def _spec(table: str) -> dict:
    """The schema of ``table``: :data:`TABLES` or :data:`SURFACE_MESH_TABLES`."""
    if table in TABLES:
        return TABLES[table]
    if table in SURFACE_MESH_TABLES:
        return SURFACE_MESH_TABLES[table]
    raise InputError(f"table must be one of {sorted(TABLES) + sorted(SURFACE_MESH_TABLES)}; got {table!r}")


# columns a producer may leave out (every other schema column is required)
_OPTIONAL = {"vz", "surface_vx", "surface_vy", "vn", "surface_vorticity", "surface_divergence", "surface_strain_xx",
             "surface_strain_xy", "mean_curvature", "areal_rate", "surface_area", "surface_perimeter", "normal_x", "normal_y", "normal_z", "z", "piv_vx", "piv_vy", "piv_peak", "image_x", "image_y", "intensity_mean", "intensity_total", "junction_polarity_re", "junction_polarity_im", "track", "n_boundaries", "polygon_area", "row", "col", "coverage", "valid", "radius", "spacing",
             "frame_gain", "frame_undo", "is_border", "tracking_doubtful", "p", "shear_xx", "shear_xy", "vx", "vy",
             "tension", "tension_sd", "curvature", "n_merged", "division_area_ratio",
             "division_suspect", "division_reason", "extrusion_area_ratio", "extrusion_unconfirmed", "pressure", "pressure_sd", "stress_xx", "stress_xy", "stress_yy"}
_DTYPES = {"i": "int64", "f": "float64", "b": "bool", "O": "string"}
_KIND_OK = {"i": "iu", "f": "fiu", "b": "b", "O": "OSUT"}


@functools.lru_cache(maxsize=None)
def _pattern(column: str) -> re.Pattern:
    return re.compile("^" + re.escape(column).replace(r"\{p\}", r"\d+") + "$")


def deprecated_column_lists(module, lists):
    """A module ``__getattr__`` that serves the column lists of hexatissue 0.1 from :data:`TABLES`, warning.

    ``lists`` maps each old name to ``(table, columns)`` (None: every
    column); the value is ``{column: meaning}``, as the old constant was.
    """
    def __getattr__(name):
        if name not in lists:
            raise AttributeError(f"module {module!r} has no attribute {name!r}")
        table, columns = lists[name]
        warnings.warn(f"{module}.{name} is deprecated; the columns are in hexatissue.schema.TABLES[{table!r}]",
                      DeprecationWarning, stacklevel=2)
        return {c: meaning for c, (_, _, meaning) in TABLES[table].items() if columns is None or c in columns}

    return __getattr__


def describe(table: str) -> pd.DataFrame:
    """The schema of ``table`` as a DataFrame (column, dtype kind, unit, meaning)."""
    rows = [(c, k, u, m) for c, (k, u, m) in _spec(table).items()]
    return pd.DataFrame(rows, columns=["column", "kind", "unit", "meaning"])


def column_units(table: str, columns) -> dict[str, tuple[str, str]]:
    """Unit and meaning of each of ``columns`` that ``table``'s schema has (``{p}`` patterns matched).

    Returns
    -------
    dict
        ``{column: (unit, meaning)}`` for the columns of the schema, in the
        order of ``columns``; a unit of ``""`` is a count, an id, a flag or
        a dimensionless number.  Columns not in the schema are left out.
    """
    spec = _spec(table)
    patterns = [(c, _pattern(c)) for c in spec if "{p}" in c]
    out = {}
    for column in columns:
        name = str(column)
        if name in spec:
            out[name] = spec[name][1:]
        else:
            found = next((c for c, pattern in patterns if pattern.match(name)), None)
            if found is not None:
                out[name] = spec[found][1:]
    return out


def validate(df: pd.DataFrame, table: str) -> pd.DataFrame:
    """Check that ``df`` has the columns of ``table`` with compatible dtypes; return it.

    Required columns are every schema column except the optional ones
    (``track``, ``polygon_area``, ... and the per-``p`` patterns); columns not in the schema are allowed (analyses
    add their own).  Raises :class:`~hexatissue.errors.InputError` naming the
    offending column.
    """
    spec = _spec(table)
    if not isinstance(df, pd.DataFrame):
        raise InputError(f"{table} table must be a pandas DataFrame; got {type(df).__name__}")
    dtypes = dict(zip(df.columns, df.dtypes))  # one look at the columns (df[c] per column is slow)
    for column, (kind, _, _) in spec.items():
        if "{p}" in column:
            matches = [c for c in dtypes if _pattern(column).match(str(c))]
        elif column in dtypes:
            matches = [column]
        elif column in _OPTIONAL:
            matches = []
        else:
            raise InputError(f"{table} table is missing column {column!r}; expected columns {list(spec)}")
        for c in matches:
            dtype = dtypes[c]
            if dtype.kind not in _KIND_OK[kind] and not (kind == "O" and pd.api.types.is_string_dtype(df[c])):
                raise InputError(f"{table} table column {c!r} has dtype {dtype}; expected kind {kind!r}")
    return df


def require_columns(table, columns, name):
    """Raise :class:`InputError` unless ``table`` is a DataFrame holding ``columns``; return it.

    For functions that need only some columns of a table (or tables that
    have no schema).
    """
    if not isinstance(table, pd.DataFrame):
        raise InputError(f"{name} must be a pandas DataFrame; got {type(table).__name__}")
    missing = [c for c in columns if c not in table.columns]
    if missing:
        raise InputError(f"{name} is missing column(s) {missing}; expected at least {list(columns)}")
    return table


def empty_table(table: str, orders=()) -> pd.DataFrame:
    """A table with no rows and the schema's columns and dtypes (``{p}`` columns for each of ``orders``)."""
    columns = {}
    for column, (kind, _, _) in _spec(table).items():
        names = [column.replace("{p}", str(q)) for q in orders] if "{p}" in column else [column]
        for name in names:
            columns[name] = pd.Series(dtype=_DTYPES[kind])
    return pd.DataFrame(columns)


def track_ids(cells) -> np.ndarray:
    """Track id of every row of a cells table: ``track`` when present, else the label ``cell``."""
    column = "track" if "track" in cells.columns else "cell"
    if column not in cells.columns:
        raise InputError("cells needs a 'track' or 'cell' column")
    return cells[column].to_numpy(np.int64)


class FrameRows:
    """The rows of each frame of a ``frame`` column (sorted or not: one stable argsort if not).

    Iterating gives ``(frame, rows)`` in frame order; rows are a slice when
    the column is sorted, else row indices in row order.  One pass over the
    column, so per-frame work over a movie does not scan the table per frame.
    """

    def __init__(self, frame):
        frame = np.asarray(frame)
        self.order = None if len(frame) < 2 or bool(np.all(frame[1:] >= frame[:-1])) else np.argsort(frame,
                                                                                                       kind="stable")
        f = frame if self.order is None else frame[self.order]
        starts = np.flatnonzero(np.r_[True, f[1:] != f[:-1]]) if len(f) else np.zeros(0, np.int64)
        self.frames, self.bounds = f[starts].astype(np.int64), np.r_[starts, len(f)]

    def __iter__(self):
        for k, frame in enumerate(self.frames.tolist()):
            yield frame, self._rows(k)

    def blocks(self, rows):
        """Consecutive frames in blocks of about ``rows`` rows (one frame at least): ``(frames, rows)``."""
        k = 0
        while k < len(self.frames):
            end = max(int(np.searchsorted(self.bounds, self.bounds[k] + rows, "right")) - 1, k + 1)
            end = min(end, len(self.frames))
            lo, hi = self.bounds[k], self.bounds[end]
            yield self.frames[k:end], (slice(lo, hi) if self.order is None else self.order[lo:hi])
            k = end

    def between(self, first, last):
        """Row indices (a slice when the column is sorted) of the frames ``first`` to ``last``."""
        lo, hi = np.searchsorted(self.frames, first, "left"), np.searchsorted(self.frames, last, "right")
        lo, hi = self.bounds[lo], self.bounds[hi]
        return slice(lo, hi) if self.order is None else self.order[lo:hi]

    def rows(self, frame):
        """Row indices (a slice when the column is sorted) of ``frame``; none if it is absent."""
        k = int(np.searchsorted(self.frames, frame))
        return self._rows(k) if k < len(self.frames) and self.frames[k] == frame else slice(0, 0)

    def _rows(self, k):
        lo, hi = self.bounds[k], self.bounds[k + 1]
        return slice(lo, hi) if self.order is None else self.order[lo:hi]


def rows_by_frame(times) -> dict:
    """Row indices of each time point, in row order: ``{t: rows}`` for every ``t`` in ``times`` (:class:`FrameRows`)."""
    times = np.asarray(times).reshape(-1)
    by_frame = FrameRows(times)
    return {frame: np.arange(rows.start, rows.stop) if isinstance(rows, slice) else rows for frame, rows in by_frame}


def string_column(codes, names):
    """The pandas ``string`` array of ``names[codes]`` (a label column such as an event's ``kind``).

    Equal to ``pd.array(numpy.asarray(names, object)[codes], dtype="string")``,
    but built from numpy buffers when the string dtype is Arrow's: no Python
    string per row, and nothing from Arrow's allocator, whose pools keep
    several MB resident after each conversion of tens of thousands of Python
    strings (measured on the event tables of a 200-frame movie).

    Parameters
    ----------
    codes : array_like of int
        Index into ``names`` of every row.
    names : sequence of str
        The labels.
    """
    codes = np.asarray(codes, np.int64).reshape(-1)
    if len(codes) and (codes.min() < 0 or codes.max() >= len(names)):
        raise InputError(f"codes must index the {len(names)} names; got values in [{codes.min()}, {codes.max()}]")
    if pd.StringDtype().storage != "pyarrow":
        return pd.array(np.asarray(names, dtype=object)[codes], dtype="string")
    import pyarrow as pa

    encoded = [str(name).encode() for name in names]
    offsets = np.zeros(len(codes) + 1, np.int64)
    np.cumsum(np.array([len(e) for e in encoded], np.int64)[codes], out=offsets[1:])
    # byte j of every row of a name, at once: a few passes over the rows of each name, not an index array per byte
    # (which took 130 MB for the 720,000 kinds of a 10^7 cell-frame movie's defect events)
    data = np.empty(offsets[-1], np.uint8)
    for code, name in enumerate(encoded):
        starts = offsets[:-1][codes == code]
        for j, byte in enumerate(name):
            data[starts + j] = byte
    array = pa.Array.from_buffers(pa.large_string(), len(codes), [None, pa.py_buffer(offsets), pa.py_buffer(data)])
    return pd.arrays.ArrowStringArray(array)


def interior_mask(cells) -> np.ndarray:
    """Rows that are not border cells (all rows when there is no ``is_border`` column)."""
    if "is_border" in cells.columns:
        return ~cells["is_border"].to_numpy(bool)
    return np.ones(len(cells), bool)


def coerce(df: pd.DataFrame, table: str) -> pd.DataFrame:
    """``df`` with its schema columns cast to the schema's dtypes (for tables read back from CSV)."""
    spec = _spec(table)
    out = df.copy()
    for column, (kind, _, _) in spec.items():
        names = [c for c in out.columns if _pattern(column).match(str(c))] if "{p}" in column else [column]
        for name in names:
            if name not in out.columns or str(out[name].dtype) == _DTYPES[kind]:
                continue
            if kind == "i" and out[name].isna().any():
                continue  # an integer column with gaps stays float rather than fail
            if kind == "O":  # CSV writes "" as an empty field, read back as NaN (no text column holds NA)
                out[name] = out[name].astype(_DTYPES[kind]).fillna("")
                continue
            out[name] = out[name].astype(_DTYPES[kind])
    return out
