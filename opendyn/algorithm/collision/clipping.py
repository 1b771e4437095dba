"""Polygon clipping, the step every face contact is built by (Ericson, Real-Time Collision
Detection, 2005, 8.3.4, Sutherland-Hodgman; the way MuJoCo's box-box routine and Box2D's and
Bullet's build a face contact), and the reduction of the clipped points to four.

Polygons live in rows of the narrow phase's work array: a corner's point x (columns 0-2, world,
metres) and, once it is a contact, its signed distance s (column DEPTH).

  clip            the polygon cut by the plane m . x <= c, corners in order
  reduce_to_four  the deepest point, the farthest from it, and the two that span the largest
                  triangles with those on either side: the four that keep the largest area, as
                  Gregorius' "Robust contact creation for physics simulations" (GDC 2015)
                  reduces a manifold
"""

from __future__ import annotations

from numba import njit

from ..._runtime.kernel_cache import UNCOUNTED
from .vectors import axpy, cross, dot, put, row, sub

DEPTH = 3  # the work column of a contact's signed distance


@njit(**UNCOUNTED)
def clip(work, source, count, target, m, c):
    """The polygon in work rows source.. (count corners) clipped by the plane m . x <= c into
    rows target..; returns its corner count (at most count + 1)."""
    kept = 0
    for i in range(count):
        p = row(work, source + i, 0)
        q = row(work, source + (i + 1) % count, 0)
        dp, dq = dot(m, p) - c, dot(m, q) - c
        if dp <= 0.0:
            put(work, target + kept, 0, p)
            kept += 1
        if (dp < 0.0 and dq > 0.0) or (dp > 0.0 and dq < 0.0):
            put(work, target + kept, 0, axpy(dp / (dp - dq), sub(q, p), p))
            kept += 1
    return kept


@njit(**UNCOUNTED)
def reduce_to_four(work, first, count, N):
    """Indices (rows from `first`, -1 for none) of at most four of the count points in rows
    first.. (their signed distance in column DEPTH) that keep the deepest and the largest area
    seen along N (module docstring)."""
    i0, i1, i2, i3 = 0, -1, -1, -1
    for i in range(count):
        if work[first + i, DEPTH] < work[first + i0, DEPTH]:
            i0 = i
    x0 = row(work, first + i0, 0)
    far = 0.0
    for i in range(count):
        e = sub(row(work, first + i, 0), x0)
        if dot(e, e) > far:
            i1, far = i, dot(e, e)
    if i1 < 0:
        return i0, i1, i2, i3
    edge = sub(row(work, first + i1, 0), x0)
    most, least = 0.0, 0.0
    for i in range(count):
        area = dot(cross(edge, sub(row(work, first + i, 0), x0)), N)
        if area > most:
            i2, most = i, area
        if area < least:
            i3, least = i, area
    return i0, i1, i2, i3
