"""Label images (or cell polygons) -> junction network (vertices, junctions, ordered polygons)."""
from ..options import KINDS
from .labels import detect_kind, label_skeleton, normalize_labels
from .network import kernels_cached, mesh_from_labels
from .polygons import mesh_from_polygons

__all__ = ["mesh_from_labels", "mesh_from_polygons", "kernels_cached", "normalize_labels", "detect_kind", "label_skeleton", "KINDS"]
