"""Frames, parallel transport, curvature and distances on a surface sampled by unit normals: what the mesh and
height-map measures share (:func:`tangent_frames`, :func:`transport_angles`, :func:`solid_angles`,
:func:`arc_lengths`).
"""
from __future__ import annotations

import numpy as np

from ..errors import InputError

__all__ = ["tangent_frames", "transport_angles", "solid_angles", "arc_lengths", "FALLBACK_COS"]

#: Where ``|n . reference| > FALLBACK_COS`` (within 25.8 degrees of the normal) the tangent frame's e1 is the
#: coordinate axis most orthogonal to the reference instead (the frame does not change |gamma_p| or defects).
FALLBACK_COS = 0.9


def tangent_frames(normals, reference=(1.0, 0.0, 0.0), fallback_cos=FALLBACK_COS):
    """``(e1, e2)`` of unit normals ``(N, 3)``: the reference direction projected on each tangent plane.

    ``e1`` is ``reference`` minus its normal component, normalised; where
    ``|n . reference| > fallback_cos`` the coordinate axis most orthogonal
    to ``reference`` is projected instead.  ``e2 = n x e1``.  NaN normals
    give NaN frames.
    """
    n = np.asarray(normals, dtype=float).reshape(-1, 3)
    ref = np.asarray(reference, dtype=float).reshape(3)
    size = np.linalg.norm(ref)
    if not np.isfinite(ref).all() or size == 0:
        raise InputError(f"reference must be a finite non-zero 3-vector; got {reference!r}")
    ref = ref / size
    other = np.zeros(3)
    other[int(np.argmin(np.abs(ref)))] = 1.0
    dot = n @ ref
    use = np.where((np.abs(dot) > fallback_cos)[:, None], other, ref)
    e1 = use - (n * use).sum(axis=1)[:, None] * n
    with np.errstate(invalid="ignore", divide="ignore"):
        e1 /= np.linalg.norm(e1, axis=1)[:, None]
    e2 = np.cross(n, e1)
    return e1, e2


def transport_angles(n_from, e1_from, n_to, e1_to, e2_to):
    """Angle (rad, in (-pi, pi]) of frame ``from``'s e1, carried onto ``to``'s plane, in frame ``to``.

    The carrying rotation is the minimal one taking ``n_from`` to ``n_to``
    (about ``n_from x n_to``): the Levi-Civita transport along the great
    circle between the normals on the unit sphere.  A vector at angle
    ``alpha`` in frame ``from`` is at ``alpha + angle`` in frame ``to``.
    Antipodal normals give NaN.
    """
    c = (n_from * n_to).sum(axis=1)
    v = np.cross(n_from, n_to)
    x = e1_from
    with np.errstate(invalid="ignore", divide="ignore"):
        scale = np.where(1.0 + c > 1e-12, 1.0 / (1.0 + c), np.nan)
    rx = x * c[:, None] + np.cross(v, x) + v * ((v * x).sum(axis=1) * scale)[:, None]
    return np.arctan2((rx * e2_to).sum(axis=1), (rx * e1_to).sum(axis=1))


def solid_angles(a, b, c):
    """Signed area (sr) of the geodesic triangles ``(a, b, c)`` of unit vectors on the unit sphere.

    ``2 atan2(a . (b x c), 1 + a.b + b.c + c.a)`` (Van Oosterom and
    Strackee 1983), positive when ``a, b, c`` turn counter-clockwise seen
    from outside the sphere.
    """
    triple = (a * np.cross(b, c)).sum(axis=1)
    den = 1.0 + (a * b).sum(axis=1) + (b * c).sum(axis=1) + (c * a).sum(axis=1)
    return 2.0 * np.arctan2(triple, den)


def arc_lengths(a, b, n_a, n_b):
    """Distance along the surface between points ``a`` and ``b`` ``(N, 3)`` with unit normals ``n_a``, ``n_b``.

    The arc of the circle through both points whose normal turns from
    ``n_a`` to ``n_b``: ``|b - a| theta / (2 sin(theta / 2))``, ``theta`` the
    angle between the normals (``theta / |n_b - n_a|``, as ``|n_b - n_a| =
    2 sin(theta / 2)``).  Exact on a plane (the chord) and between points of
    a sphere (the great circle's arc); elsewhere the arc of the normal
    section's osculating circle.  Never shorter than the chord.
    """
    chord = np.linalg.norm(b - a, axis=1)
    gap = np.linalg.norm(n_b - n_a, axis=1)
    theta = 2.0 * np.arctan2(gap, np.linalg.norm(n_b + n_a, axis=1))
    with np.errstate(invalid="ignore", divide="ignore"):
        # below 1e-4 the series (error ~ gap^4 / 600) avoids 0 / 0 and keeps a plane's distance the exact chord
        stretch = np.where(gap > 1e-4, theta / gap, 1.0 + gap * gap / 24.0)
    return chord * stretch
