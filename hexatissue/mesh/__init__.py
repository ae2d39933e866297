"""Label images (or cell polygons) -> junction network (vertices, junctions, ordered polygons)."""
from ..options import KINDS
from .labels import detect_kind, label_skeleton, normalize_labels
from .network import mesh_from_labels, warm_up
from .polygons import mesh_from_polygons

__all__ = ["mesh_from_labels", "mesh_from_polygons", "warm_up", "normalize_labels", "detect_kind", "label_skeleton", "KINDS"]
