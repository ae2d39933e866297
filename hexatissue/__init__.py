"""hexatissue: the physics of epithelial tissues from segmented images and simulations.

Conventions used everywhere: images are indexed ``[row, col]``; tables use
``x`` = column and ``y`` = row, in pixels, with the origin at the centre of
pixel (0, 0).  Ids are columns, never the index.
"""
from ._version import __version__
from .box import Box
from .errors import HexatissueWarning, InputError
from .units import Calibration
from .frame import Frame
from .results import Movie, read_results
from .options import (DeformationOptions, EventOptions, IntensityOptions, MechanicsOptions, MeshOptions, OrderOptions,
                      SurfaceOptions, TrackOptions)
from .graph import contact_table, neighbor_graph, neighbour_graph
from .io import read_table, write_table, write_tables
from .mesh import mesh_from_labels, mesh_from_polygons
from .defects import defect_density, defect_events, find_defects, track_defects
from .order import cell_radius, cells_from_polygons, coarse_grain, order_vs_radius, shape_function, shape_order
from .events import cell_event_stats, detect_t1, intercalation_intervals
from .pipeline import analyze
from .source import Source, open_source, read_labels
from .track import Tracker, lineage_table, track_labels
from .theory import active_force, ell6, quadrupole_flow, quadrupole_psi
from .options import FlowOptions
from .flow import cell_velocities, flow_fields

__all__ = [
    "Box",
    "Calibration",
    "Frame",
    "Movie",
    "read_results",
    "analyze",
    "MeshOptions",
    "OrderOptions",
    "TrackOptions",
    "EventOptions",
    "IntensityOptions",
    "SurfaceOptions",
    "DeformationOptions",
    "MechanicsOptions",
    "shape_order",
    "InputError",
    "HexatissueWarning",
    "open_source",
    "Source",
    "read_labels",
    "mesh_from_polygons",
    "read_table",
    "write_table",
    "write_tables",
    "shape_function",
    "cells_from_polygons",
    "coarse_grain",
    "cell_radius",
    "order_vs_radius",
    "find_defects",
    "track_defects",
    "defect_events",
    "defect_density",
    "Tracker",
    "track_labels",
    "lineage_table",
    "detect_t1",
    "cell_event_stats",
    "intercalation_intervals",
    "MPFParams",
    "run_simulation",
    "read_run",
    "HydroParams",
    "run_dipole",
    "run_quadrupole",
    "quadrupole_psi",
    "active_force",
    "quadrupole_flow",
    "ell6",
    "mesh_from_labels",
    "neighbour_graph",
    "contact_table",
    "score",
    "__version__",
    "FlowOptions",
    "cell_velocities",
    "flow_fields",
]


# the simulators (numba + zarr) and the benchmark scorer are imported on first use, not with the package
_LAZY = {"MPFParams": ("hexatissue.simulate", "Params"), "read_run": ("hexatissue.simulate", "read_run"),
         "run_simulation": ("hexatissue.simulate", "run_simulation"),
         "HydroParams": ("hexatissue.hydro", "HydroParams"), "run_dipole": ("hexatissue.hydro", "run_dipole"),
         "run_quadrupole": ("hexatissue.hydro", "run_quadrupole"),
         "score": ("hexatissue.benchmark.score", "score")}


def __getattr__(name):
    if name in _LAZY:
        from importlib import import_module

        module, attr = _LAZY[name]
        return getattr(import_module(module), attr)
    raise AttributeError(f"module 'hexatissue' has no attribute {name!r}")
