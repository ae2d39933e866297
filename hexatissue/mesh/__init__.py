"""Label images -> junction network (vertices, junctions, ordered polygons)."""
from .labels import KINDS, detect_kind, label_skeleton, normalize_labels
from .network import mesh_from_labels

__all__ = ["mesh_from_labels", "normalize_labels", "detect_kind", "label_skeleton", "KINDS"]
