"""Surface Evolver dumps of 2-D foams and tissues (``STRING`` model) as junction networks with their exact forces.

A dump lists ``vertices`` (id, x, y), ``edges`` (id, tail, head, ``density``
= line tension), ``faces`` (id, loop of signed edge ids) and ``bodies`` (id,
signed face, ``volume``, ``lagrange_multiplier`` = pressure, the outside being
at 0).  Junctions are drawn as chains of many short edges; the network
hexatissue extracts from an image has one straight junction per chain, from
triple junction to triple junction.  Used to test force inference against
truth (docs/mechanics.md).
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd

from ..errors import InputError
from ..geometry import polygon_area_centroid
from .curvature import fit_arcs

__all__ = ["read_evolver", "evolver_network", "evolver_labels"]

_SECTIONS = ("vertices", "edges", "faces", "bodies")


def read_evolver(path) -> dict:
    """The ``vertices``, ``edges``, ``faces`` and ``bodies`` of a Surface Evolver dump.

    Returns
    -------
    dict
        ``vertices``: {id: (x, y)}; ``edges``: {id: (tail, head, density)};
        ``faces``: {id: [signed edge ids]}; ``bodies``: {id: (signed face,
        pressure)}.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"path must be a Surface Evolver dump file; {path} does not exist")
    text = re.sub(r"/\*.*?\*/", " ", path.read_text(), flags=re.S).replace("\\\n", " ")
    out = {name: {} for name in _SECTIONS}
    section = None
    for line in text.splitlines():
        words = line.split()
        if not words:
            continue
        if words[0] in _SECTIONS:
            section = words[0]
            continue
        if section is None or not words[0].isdigit():
            if section is not None and words[0] == "read":
                break
            continue
        key = int(words[0])
        if section == "vertices":
            out[section][key] = (float(words[1]), float(words[2]))
        elif section == "edges":
            density = float(words[words.index("density") + 1]) if "density" in words else 1.0
            out[section][key] = (int(words[1]), int(words[2]), density)
        elif section == "faces":
            out[section][key] = [int(w) for w in words[1:] if re.fullmatch(r"-?\d+", w)]
        else:
            pressure = float(words[words.index("lagrange_multiplier") + 1])
            out[section][key] = (int(words[1]), pressure)
    if not all(out[name] for name in _SECTIONS):
        raise InputError(f"{path} is not a Surface Evolver dump of a 2-D string model (missing a section)")
    return out


def evolver_network(path, fine=False):
    """The junction network of a Surface Evolver dump, with each junction's tension and each cell's pressure.

    Parameters
    ----------
    path : str or Path
        The dump.
    fine : bool
        False: one straight junction per chain of edges, between the vertices
        where three or more edges meet (the network of an image).  True:
        every edge of the dump is a junction (its exact geometry).

    Returns
    -------
    tables : dict
        ``cells`` (``cell`` = body id; ``is_border``: a junction with the
        outside), ``vertices``, ``edges``, ``cell_vertices`` (counter-clockwise
        in x, y) as DataFrames of frame 0, in the dump's length unit;
        ``edges.curvature`` (1/px, signed as in
        :mod:`hexatissue.mechanics.curvature`) is the arc through the
        junction's ends fitted to its chain's inner vertices (0 with
        ``fine``).
    tension : ndarray
        Per row of ``edges``: the chain's ``density``.
    pressure : ndarray
        Per row of ``cells``: the body's ``lagrange_multiplier``.
    """
    dump = read_evolver(path)
    xy = dump["vertices"]
    edges = dump["edges"]
    degree = {}
    for tail, head, _ in edges.values():
        degree[tail] = degree.get(tail, 0) + 1
        degree[head] = degree.get(head, 0) + 1
    node = {v for v, k in degree.items() if fine or k != 2}
    face_of = {abs(f): body for body, (f, _) in dump["bodies"].items()}
    cells, loops, between = [], {}, {}
    for face, loop in dump["faces"].items():
        chain = [edges[e][0] if e > 0 else edges[-e][1] for e in loop]  # each edge's first vertex along the loop
        signed = [(e, edges[abs(e)][2]) for e in loop]
        body = face_of[face]
        keep = [k for k, v in enumerate(chain) if v in node]
        polygon = [chain[k] for k in keep]
        for k0, k1 in zip(keep, keep[1:] + [keep[0] + len(chain)]):  # the points between two kept vertices
            inner = [chain[k % len(chain)] for k in range(k0 + 1, k1)]
            key = (min(chain[k0], chain[k1 % len(chain)]), max(chain[k0], chain[k1 % len(chain)]))
            between.setdefault(key, inner)
        # the density of the junction that starts at each kept vertex
        density = [signed[k][1] for k in keep]
        area = polygon_area_centroid(np.array([xy[v] for v in polygon]), np.zeros(1, np.int64))[0][0]
        if area < 0:
            polygon, density = polygon[::-1], density[::-1][1:] + density[::-1][:1]
        loops[body] = (polygon, density)
        cells.append(body)
    sides = {}
    for body, (polygon, density) in loops.items():
        for a, b, t in zip(polygon, polygon[1:] + polygon[:1], density):
            sides.setdefault((min(a, b), max(a, b)), []).append((body, t))
    vid = sorted(node)
    vrow = {v: k for k, v in enumerate(vid)}
    keys = sorted(sides)
    outside = {v for key in keys if len(sides[key]) == 1 for v in key}
    cell_a = [min(c for c, _ in sides[k]) if len(sides[k]) == 2 else 0 for k in keys]
    cell_b = [max(c for c, _ in sides[k]) for k in keys]
    tension = np.array([sides[k][0][1] for k in keys])
    pos = np.array([xy[v] for v in vid])
    va = np.array([vrow[k[0]] for k in keys])
    vb = np.array([vrow[k[1]] for k in keys])
    border_cells = {c for k in keys if len(sides[k]) == 1 for c, _ in sides[k]}
    rows = []
    for body in sorted(cells):
        polygon = loops[body][0]
        poly = np.array([xy[v] for v in polygon])
        (a,), (c,) = polygon_area_centroid(poly, np.zeros(1, np.int64))
        perimeter = np.hypot(*np.diff(np.vstack([poly, poly[:1]]), axis=0).T).sum()
        rows.append((body, c[0], c[1], a, a, perimeter, len(polygon), 1, body in border_cells))
    cell_table = pd.DataFrame(rows, columns=["cell", "x", "y", "area", "polygon_area", "perimeter", "n_sides",
                                             "n_boundaries", "is_border"])
    cell_table.insert(0, "frame", 0)
    cv = [(body, k, vrow[v]) for body in sorted(cells) for k, v in enumerate(loops[body][0])]
    tables = {
        "cells": cell_table,
        "vertices": pd.DataFrame({"frame": 0, "vertex": np.arange(len(vid)), "x": pos[:, 0], "y": pos[:, 1],
                                  "degree": np.bincount(np.r_[va, vb], minlength=len(vid)),
                                  "is_border": [v in outside for v in vid]}),
        "edges": pd.DataFrame({"frame": 0, "edge": np.arange(len(keys)), "vertex_a": va, "vertex_b": vb,
                               "cell_a": cell_a, "cell_b": cell_b,
                               "length": np.hypot(*(pos[vb] - pos[va]).T)}),
        "cell_vertices": pd.DataFrame(cv, columns=["cell", "rank", "vertex"]).assign(frame=0)[
            ["frame", "cell", "rank", "vertex"]],
    }
    points = [(k, xy[v]) for k, key in enumerate(keys) for v in between.get(key, [])]
    owner = np.array([k for k, _ in points], np.int64)
    tables["edges"]["curvature"] = fit_arcs(np.array([p for _, p in points]).reshape(-1, 2), owner, pos[va], pos[vb])
    pressure = np.array([dump["bodies"][b][1] for b in sorted(cells)])
    return tables, tension, pressure


def evolver_labels(path, px_per_unit=2.0, margin=4):
    """A Surface Evolver dump drawn as a label image: every body filled with its id, the outside 0.

    Pixel ``(row, col)`` is centred on ``x = x0 + col / px_per_unit``, ``y =
    y0 + row / px_per_unit`` of the dump (``x0``, ``y0``: its smallest vertex
    coordinates less ``margin`` pixels); a pixel belongs to the body whose
    face (the full chain of edges, its curved junctions) contains its centre.

    Parameters
    ----------
    path : str or Path
        The dump.
    px_per_unit : float
        Pixels per length unit of the dump.
    margin : int
        Pixels of outside around the tissue.

    Returns
    -------
    labels : ndarray (H, W) of int32
        Body ids; 0 outside.
    origin : ndarray (2,)
        ``x0``, ``y0``: the dump coordinates of pixel (0, 0).
    """
    from skimage.draw import polygon as fill

    if not (np.isfinite(px_per_unit) and px_per_unit > 0):
        raise InputError(f"px_per_unit must be a positive number; got {px_per_unit!r}")
    dump = read_evolver(path)
    xy, edges = dump["vertices"], dump["edges"]
    pos = np.array(list(xy.values()))
    origin = pos.min(axis=0) - margin / px_per_unit
    shape = tuple((np.ceil((pos.max(axis=0) - origin) * px_per_unit) + margin + 1).astype(int)[::-1])
    labels = np.zeros(shape, np.int32)
    face_of = {abs(f): body for body, (f, _) in dump["bodies"].items()}
    for face, loop in dump["faces"].items():
        chain = np.array([xy[edges[e][0] if e > 0 else edges[-e][1]] for e in loop])
        cols, rows = ((chain - origin) * px_per_unit).T
        r, c = fill(rows, cols, shape)
        labels[r, c] = face_of[face]
    return labels, origin
