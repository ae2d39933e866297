"""GetVertex tables (``VDat_*.txt``) of Ishihara & Sugimura's Bayesian force inference, as cell polygons.

The table (IshiharaLab/BayesianForceInference, made by its Fiji plugin
GetVertex from a skeleton) lists ``V[i] x y [Ext]`` (vertex ``i``; ``y`` is
minus the image row), ``E[i] a b [Ext]`` (a junction between vertices ``a``
and ``b``) and ``C[i] n : v_1 ... v_n [Ext]`` (a cell's vertices in order);
``Ext`` marks the vertices, junctions and cells on the tissue's edge.
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ..errors import InputError

__all__ = ["read_vdat"]

_LINE = re.compile(r"^([VEC])\[(\d+)\]\s+(.*?)\s*(Ext)?\s*$")


def read_vdat(path) -> dict:
    """The vertices, junctions and cells of a GetVertex table, in hexatissue's coordinates.

    Returns
    -------
    dict
        ``vertices``: ndarray (n, 2) of x = column, y = row (px; the table's
        y negated), row ``i`` = ``V[i]``; ``vertex_ext``: bool per vertex;
        ``edges``: ndarray (m, 2) of vertex indices; ``edge_ext``: bool;
        ``polygons``: {cell id (``C[i]`` gives ``i + 1``): (k, 2) ndarray of
        x, y}; ``cell_vertices``: {cell id: vertex indices}; ``cell_ext``:
        {cell id: bool}.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"path must be a GetVertex table (VDat_*.txt); {path} does not exist")
    v, v_ext, e, e_ext, cells, c_ext = {}, {}, {}, {}, {}, {}
    for line in path.read_text().splitlines():
        match = _LINE.match(line)
        if not match:
            continue
        kind, idx, rest, ext = match.group(1), int(match.group(2)), match.group(3).split(), bool(match.group(4))
        if kind == "V":
            v[idx], v_ext[idx] = (float(rest[0]), -float(rest[1])), ext
        elif kind == "E":
            e[idx], e_ext[idx] = (int(rest[0]), int(rest[1])), ext
        else:
            ids = [int(w) for w in rest[rest.index(":") + 1:]]
            if len(ids) != int(rest[0]):
                raise InputError(f"{path}: C[{idx}] announces {rest[0]} vertices and lists {len(ids)}")
            cells[idx + 1], c_ext[idx + 1] = ids, ext
    if not v or not cells or sorted(v) != list(range(len(v))):
        raise InputError(f"{path} is not a GetVertex table (V[i] rows numbered from 0 and C[i] rows expected)")
    xy = np.array([v[i] for i in range(len(v))])
    return {"vertices": xy, "vertex_ext": np.array([v_ext[i] for i in range(len(v))]),
            "edges": np.array([e[i] for i in sorted(e)], np.int64).reshape(-1, 2),
            "edge_ext": np.array([e_ext[i] for i in sorted(e)], bool),
            "polygons": {c: xy[ids] for c, ids in cells.items()}, "cell_vertices": cells, "cell_ext": c_ext}
