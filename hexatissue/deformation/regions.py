"""The regions a budget is given for: the whole tissue, the Gamma_p grid's nodes, and regions of interest
that follow their cells (:func:`roi_tracks`, :func:`read_roi`).
"""
from __future__ import annotations

import os

import numpy as np

from ..errors import InputError
from .movie import _lookup


class _Layers:
    """How triangles are assigned to regions: the whole tissue, the grid nodes, the user's regions."""

    def __init__(self, grid, roi, box):
        self.grid, self.roi, self.box = grid, roi, box

    def names(self):
        return ["tissue"] + (["grid"] if self.grid is not None else []) + (["roi"] if self.roi is not None else [])

    def sizes(self, t):
        out = [1]
        if self.grid is not None:
            out.append(len(self.grid[t][0]) if t in self.grid else 0)
        if self.roi is not None:
            out.append(self.roi[1])
        return out

    def labels(self, t, ids, xy):
        """Labels per layer of triangles ``ids`` with corners ``xy`` (grid nodes of frame ``t``)."""
        out = [np.zeros(len(ids), np.int64)]
        if self.grid is not None:
            out.append(self._nodes(t, xy))
        if self.roi is not None:
            member = self.roi[0]
            lab = np.stack([member.get_many(ids[:, j]) for j in range(3)], axis=1)
            same = (lab[:, 0] == lab[:, 1]) & (lab[:, 1] == lab[:, 2])
            out.append(np.where(same, lab[:, 0], -1))
        return out

    def _nodes(self, t, xy):
        """The grid node nearest each triangle's centre (its square of the lattice), -1 off the grid."""
        nodes = self.grid.get(t)
        if nodes is None:
            return np.full(len(xy), -1, np.int64)
        origin, step, table = nodes[1:]
        centre = xy.mean(axis=1)
        index = np.rint((centre - origin) / step).astype(np.int64)  # (col, row)
        shape = np.array(table.shape[::-1])
        if self.box is not None:
            index %= shape
        inside = (index >= 0).all(axis=1) & (index < shape).all(axis=1)
        out = np.full(len(xy), -1, np.int64)
        out[inside] = table[index[inside, 1], index[inside, 0]]
        return out


class _Membership:
    """Track -> region label (-1: none), vectorised."""

    def __init__(self, mapping):
        self.keys = np.array(sorted(mapping), np.int64)
        self.values = np.array([mapping[k] for k in self.keys], np.int64)

    def get_many(self, ids):
        if len(self.keys) == 0:
            return np.full(len(ids), -1, np.int64)
        at, found = _lookup(ids, self.keys)
        return np.where(found, self.values[at], -1)


def roi_tracks(cells, lineage, roi, frame=0):
    """The tracks of each region of interest, followed over the movie (daughters inherit their mother's).

    Parameters
    ----------
    cells : pandas.DataFrame
        ``frame``, ``track``, ``x``, ``y``.
    lineage : pandas.DataFrame
        ``track``, ``parent``.
    roi : (rows, cols) int or bool array
        Regions in the pixels of frame ``frame``: label ``k > 0`` is region
        ``k`` (True is region 1); a cell belongs to the region its centre
        falls in.
    frame : int
        The frame the regions are drawn on.

    Returns
    -------
    dict
        ``{track: region}``.
    """
    roi = np.asarray(roi)
    if roi.ndim != 2 or not (np.issubdtype(roi.dtype, np.integer) or roi.dtype == bool):
        raise InputError(f"roi must be a 2-D label image (ints, or a bool mask); got {roi.dtype} of shape {roi.shape}")
    at = cells[cells["frame"].to_numpy() == frame]
    if len(at) == 0:
        raise InputError(f"roi_frame {frame} has no cells; the movie's frames are "
                         f"{int(cells['frame'].min())}..{int(cells['frame'].max())}")
    if roi.dtype != bool and roi.size and roi.min() < 0:
        raise InputError(f"roi has negative labels ({int(roi.min())}); regions are the labels > 0 and 0 is outside "
                         f"every region")
    col = np.clip(np.rint(at["x"].to_numpy(float)).astype(int), 0, roi.shape[1] - 1)
    row = np.clip(np.rint(at["y"].to_numpy(float)).astype(int), 0, roi.shape[0] - 1)
    label = roi[row, col].astype(np.int64)
    members = {int(t): int(k) for t, k in zip(at["track"].to_numpy(np.int64), label) if k > 0}
    if not members:
        raise InputError(f"no cell of frame {frame} has its centre in a region of the roi (labels > 0 at "
                         f"{int(np.count_nonzero(roi))} of its {roi.size} pixels): is it drawn on frame {frame}?")
    # daughters inherit, in birth order (a daughter's mother is born before it)
    if len(lineage):
        parent = lineage.sort_values("frame_start")[["track", "parent"]].to_numpy(np.int64)
        for track, mother in parent:
            if mother > 0 and mother in members and track not in members:
                members[int(track)] = members[int(mother)]
    return members


def read_roi(roi):
    """A region-of-interest image: an array as given, or read from a ``.npy``, TIFF or PNG file."""
    if not isinstance(roi, (str, os.PathLike)):
        return np.asarray(roi)
    path = os.fspath(roi)
    suffix = os.path.splitext(path)[1].lower()
    try:
        if suffix == ".npy":
            return np.load(path)
        if suffix in (".tif", ".tiff"):
            import tifffile

            return tifffile.imread(path)
        if suffix == ".png":
            import cv2

            image = cv2.imread(path, cv2.IMREAD_UNCHANGED)
            if image is None:
                raise OSError("not a readable PNG")
            return image
    except (OSError, ValueError) as exc:
        raise InputError(f"roi {path!r} cannot be read: {exc}") from None
    raise InputError(f"roi must be an array or a .npy, .tif or .png label image; got {path!r}")


def _grid_nodes(grid):
    """Per frame: node ids, the lattice's origin and step (x, y), and a (rows, cols) table of node rows."""
    out = {}
    for f, part in grid.groupby("frame", sort=True):
        xy = part[["x", "y"]].to_numpy(float)
        col, row = part["col"].to_numpy(np.int64), part["row"].to_numpy(np.int64)
        step = np.array([_lattice_step(xy[:, 0], col), _lattice_step(xy[:, 1], row)])
        origin = (xy - np.c_[col, row] * step).mean(axis=0)
        table = np.full((row.max() + 1, col.max() + 1), -1, np.int64)
        table[row, col] = np.arange(len(part))
        out[int(f)] = (part["node"].to_numpy(np.int64), origin, step, table)
    return out


def _lattice_step(position, index):
    span = index.max() - index.min()
    return (position.max() - position.min()) / span if span > 0 else 1.0
