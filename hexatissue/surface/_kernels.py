"""Numba kernel of the surface stage: every cell polygon lifted onto the height map and measured, in one pass.

Its plain-numpy twin of the same name and signature is
:func:`hexatissue.surface._reference.surface_polygons`; the tests compare the
two.  Positions are (x, y) = (column, row) in px, z in px.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def _height(height, x, y, scale, periodic):
    """``scale`` times the height map at (x, y), bilinear (as :func:`hexatissue.geometry.bilinear`)."""
    rows, cols = height.shape
    fx0, fy0 = math.floor(x), math.floor(y)
    fx, fy = x - fx0, y - fy0
    x0, y0 = int(fx0), int(fy0)
    x1, y1 = x0 + 1, y0 + 1
    if periodic:
        x0, x1, y0, y1 = x0 % cols, x1 % cols, y0 % rows, y1 % rows
    else:
        x0, x1 = min(max(x0, 0), cols - 1), min(max(x1, 0), cols - 1)
        y0, y1 = min(max(y0, 0), rows - 1), min(max(y1, 0), rows - 1)
    top = height[y0, x0] * (1 - fx) + height[y0, x1] * fx
    bottom = height[y1, x0] * (1 - fx) + height[y1, x1] * fx
    return scale * (top * (1 - fy) + bottom * fy)


@njit(cache=True)
def surface_polygons(xy, starts, height, scale, periodic, degenerate_area):
    """Area, perimeter, unit normal and in-plane vertices of every polygon lifted onto ``height``.

    Parameters
    ----------
    xy : (M, 2) float array
        Vertices (x, y), polygon after polygon; polygon k starts at row ``starts[k]``.
    starts : (N,) int64 array
    height : (rows, cols) float array
        The height map (finite).
    scale : float
        px per unit of ``height``.
    periodic : bool
        Heights read wrapped around the image (a periodic box), else clamped at its edge.
    degenerate_area : float
        A polygon whose vector area is not above ``degenerate_area`` times
        its vertices' mean squared distance from their mean, or with fewer
        than 3 vertices, gets NaN everywhere.

    Returns
    -------
    area : (N,) float array
        The fan from the surface point above the vertex mean over the
        sides, each through its lifted midpoint; each triangle signed by its
        orientation against the normal (px^2).
    perimeter : (N,) float array
        The lifted sides, each through its lifted midpoint (px).
    normal : (N, 3) float array
        The unit vector area of the lifted vertices, facing +z.
    uv : (M, 2) float array
        Each lifted vertex, relative to the polygon's 3-D vertex mean, on
        ``e1`` (the x axis projected on the tangent plane) and ``e2 = n x e1``.
    """
    n, m = len(starts), len(xy)
    area = np.full(n, np.nan)
    perimeter = np.full(n, np.nan)
    normal = np.full((n, 3), np.nan)
    uv = np.full((m, 2), np.nan)
    for k in range(n):
        s = starts[k]
        e = starts[k + 1] if k + 1 < n else m
        c = e - s
        if c < 3:
            continue
        z = np.empty(c)
        mx, my, mz = 0.0, 0.0, 0.0
        for i in range(c):
            z[i] = _height(height, xy[s + i, 0], xy[s + i, 1], scale, periodic)
            mx += xy[s + i, 0]
            my += xy[s + i, 1]
            mz += z[i]
        mx, my, mz = mx / c, my / c, mz / c
        vx, vy, vz, spread = 0.0, 0.0, 0.0, 0.0
        for i in range(c):
            j = i + 1 if i + 1 < c else 0
            ax, ay, az = xy[s + i, 0] - mx, xy[s + i, 1] - my, z[i] - mz
            bx, by, bz = xy[s + j, 0] - mx, xy[s + j, 1] - my, z[j] - mz
            vx += ay * bz - az * by
            vy += az * bx - ax * bz
            vz += ax * by - ay * bx
            spread += ax * ax + ay * ay + az * az
        vx, vy, vz = 0.5 * vx, 0.5 * vy, 0.5 * vz
        size = math.sqrt(vx * vx + vy * vy + vz * vz)
        if not size > degenerate_area * spread / c:
            continue
        nx, ny, nz = vx / size, vy / size, vz / size
        if nz < 0:
            nx, ny, nz = -nx, -ny, -nz
        ex, ey, ez = 1.0 - nx * nx, -nx * ny, -nx * nz
        length = math.sqrt(ex * ex + ey * ey + ez * ez)
        ex, ey, ez = ex / length, ey / length, ez / length
        fx, fy, fz = ny * ez - nz * ey, nz * ex - nx * ez, nx * ey - ny * ex
        normal[k, 0], normal[k, 1], normal[k, 2] = nx, ny, nz
        for i in range(c):
            ax, ay, az = xy[s + i, 0] - mx, xy[s + i, 1] - my, z[i] - mz
            uv[s + i, 0] = ax * ex + ay * ey + az * ez
            uv[s + i, 1] = ax * fx + ay * fy + az * fz
        px, py = mx, my
        pz = _height(height, px, py, scale, periodic)
        total, around = 0.0, 0.0
        for i in range(c):
            j = i + 1 if i + 1 < c else 0
            x0, y0, z0 = xy[s + i, 0], xy[s + i, 1], z[i]
            x2, y2, z2 = xy[s + j, 0], xy[s + j, 1], z[j]
            # a side straight in the image is a curve on the surface: its lifted midpoint follows the curve (the
            # fan's error on a curved surface falls 3-4 fold, benchmarks/results_surface.md); a plane is unchanged
            x1, y1 = 0.5 * (x0 + x2), 0.5 * (y0 + y2)
            z1 = _height(height, x1, y1, scale, periodic)
            for h in range(2):  # the two halves of the side
                if h == 0:
                    qx, qy, qz, rx, ry, rz = x0, y0, z0, x1, y1, z1
                else:
                    qx, qy, qz, rx, ry, rz = x1, y1, z1, x2, y2, z2
                ax, ay, az = qx - px, qy - py, qz - pz
                bx, by, bz = rx - px, ry - py, rz - pz
                tx, ty, tz = ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx
                t = 0.5 * math.sqrt(tx * tx + ty * ty + tz * tz)
                total += -t if tx * nx + ty * ny + tz * nz < 0 else t
                dx, dy, dz = rx - qx, ry - qy, rz - qz
                around += math.sqrt(dx * dx + dy * dy + dz * dz)
        area[k] = total
        perimeter[k] = around
    return area, perimeter, normal, uv
