"""hexatissue: the physics of epithelial tissues from segmented images and simulations.

Conventions used everywhere: images are indexed ``[row, col]``; tables use
``x`` = column and ``y`` = row, in pixels, with the origin at the centre of
pixel (0, 0).  Ids are columns, never the index.
"""
from importlib.metadata import PackageNotFoundError, version as _version

from .box import Box
from .errors import HexatissueWarning, InputError
from .frame import Frame, Movie
from .graph import contact_table, neighbor_graph
from .io import read_labels, read_table, write_table, write_tables
from .mesh import mesh_from_labels
from .order import shape_function

try:
    __version__ = _version("hexatissue")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0.1.0"

__all__ = [
    "Box",
    "Frame",
    "Movie",
    "InputError",
    "HexatissueWarning",
    "read_labels",
    "read_table",
    "write_table",
    "write_tables",
    "shape_function",
    "mesh_from_labels",
    "neighbor_graph",
    "contact_table",
    "__version__",
]
