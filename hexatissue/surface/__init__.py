"""Curved epithelia: cells measured on the surface that a height map describes (the surface stage).

Surface projections (LocalZProjector, SurfCut, PreMosa, MorphoGraphX) turn a
curved epithelium into a 2-D image plus a height map, z per pixel.  The
projected cells are foreshortened by the surface's tilt (a 50 degree tilt
shrinks areas by 36 %) and their shapes and orientations are distorted.  The
surface stage lifts every cell polygon's vertices onto the height map and
measures each cell in its own tangent plane: area and perimeter in 3-D, the
unit normal, the height above its centroid (its 3-D position, which the tissue
flow differentiates along the tracks: :mod:`hexatissue.flow.surface`), and the
shape functions gamma_p of the polygon's in-plane
coordinates, with the definition of :func:`hexatissue.order.shape_function`
(docs/surface.md).

Conventions: ``(x, y, z)`` px, x = column, y = row, z the height converted
to px, a right-handed frame; the normal faces +z; the tangent frame of a
cell is ``e1`` = the image x axis projected on its plane and normalised,
``e2 = n x e1`` (on a flat height map ``e1`` = x and ``e2`` = y, so the
surface columns equal the flat ones).

Surface meshes (triangle meshes with cell labels, PLY/OBJ; closed surfaces
and overhangs a height map cannot hold): :func:`read_mesh`,
:func:`mesh_tissue` (cells, junction vertices, junctions, gamma_p in each
cell's tangent frame, the coarse-grained Gamma_p at every cell, the p-atic
defects of both with the curvature they enclose),
:func:`mesh_tables` and :func:`read_mesh_tables` for several frames;
``hexatissue surface-mesh`` on the command line (docs/surface.md).

Gamma_p on a height map's surface (the order fields stage after the surface
stage): :func:`surface_coarse_grain` (each cell's surface gamma_p
parallel-transported into the tangent frame of the grid node, from
:func:`node_normals`, before the mean) and :func:`surface_defects` (plaquette
charges with the transport between node frames and the curvature each
plaquette encloses: :func:`surface_plaquette_charges`).

A height map from a z-stack of the junctions, when no surface projection
gave one: :func:`height_map`, and the projected image :func:`project_stack`.
"""
from __future__ import annotations

from .field import (node_frames, node_normals, surface_coarse_grain, surface_defects, surface_plaquette_charges,
                    transport_to_nodes)
from .files import LabelledMesh, read_mesh, write_obj, write_ply
from .mesh import mesh_tables, mesh_tissue, read_mesh_tables
from .stack import HeightMap, height_map, project_stack
from .tangent import DEGENERATE_AREA, cell_heights, check_height, lift, surface_arrays, surface_cells, tangent_polygons

__all__ = ["check_height", "lift", "cell_heights", "tangent_polygons", "surface_arrays", "surface_cells", "DEGENERATE_AREA",
           "LabelledMesh", "read_mesh", "write_ply", "write_obj", "mesh_tissue", "mesh_tables", "read_mesh_tables",
           "node_normals", "node_frames", "transport_to_nodes", "surface_coarse_grain", "surface_plaquette_charges",
           "surface_defects", "HeightMap", "height_map", "project_stack"]
