"""Polygon clipping, the step every face contact is built by (Ericson, Real-Time Collision
Detection, 2005, 8.3.4, Sutherland-Hodgman; the way MuJoCo's box-box routine and Box2D's and
Bullet's build a face contact), and the reduction of the clipped points to four.

Polygons live in rows of the narrow phase's work array: a corner's point x (columns 0-2, world,
metres) and, once it is a contact, its signed distance s (column DEPTH).

  clip            the polygon cut by the plane m . x <= c, corners in order
  reduce_to_four  the deepest point (of a face resting flat, the outermost), then the three
                  that span the largest quadrilateral with it: the support polygon, as
                  Gregorius' "Robust contact creation for physics simulations" (GDC 2015)
                  reduces a manifold, chosen so that it does not jump under small motions
"""

from __future__ import annotations

import math

from numba import njit

from ..._runtime.kernel_cache import UNCOUNTED
from .vectors import axpy, cross, dot, put, row, scale, sub

DEPTH = 3  # the work column of a contact's signed distance
# depths within this fraction of the points' spread count as one depth (a face resting flat:
# tilted by less than about half a degree)
FLAT = 0.01
AREA_TIE = 1e-9  # areas within this fraction of each other count as equal
PRESELECT = 16  # more points than this: the quadrilateral is looked for among 9 of them
# the direction along which the reduction orders points it cannot tell apart otherwise: fixed in
# the world, and lined up with no face or edge a body rests on by design, (1, 1/phi, 1/phi^2)
# normalised (phi the golden ratio)
TIE_BREAK = (0.8090169943749473, 0.5, 0.3090169943749474)


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
def along_g(work, first, i):
    """x_i . G: where point i lies along TIE_BREAK, the order in which points the reduction
    cannot otherwise tell apart are taken."""
    return dot(row(work, first + i, 0), TIE_BREAK)


@njit(**UNCOUNTED)
def anchor(work, first, count):
    """The point every reduced manifold keeps (a row from `first`): the deepest, unless others
    are as deep within FLAT of the points' spread (a face resting flat, whose depths differ by
    rounding or a tilt of a fraction of a degree); then, of those, the farthest along TIE_BREAK,
    an outer corner of the polygon. Neither choice moves with a small tilt, nor with the order
    the points come in (which box of two is the reference face)."""
    deepest = 0
    for i in range(count):
        if work[first + i, DEPTH] < work[first + deepest, DEPTH]:
            deepest = i
    x0 = row(work, first + deepest, 0)
    spread = 0.0
    for i in range(count):
        e = sub(row(work, first + i, 0), x0)
        spread = max(spread, math.sqrt(dot(e, e)))
    tied = work[first + deepest, DEPTH] + FLAT * spread
    best = deepest
    for i in range(count):
        if work[first + i, DEPTH] <= tied and along_g(work, first, i) > along_g(work, first, best):
            best = i
    return best


@njit(**UNCOUNTED)
def reduce_to_four(work, first, count, N):
    """Indices (rows from `first`, -1 for none) of at most four of the count points in rows
    first.. (their signed distance in column DEPTH) that keep the anchor (the deepest point, or
    an outer corner of a flat face: `anchor`) and, with it, the largest area seen along N: the
    support polygon's quadrilateral, as Gregorius' "Robust contact creation for physics
    simulations" (GDC 2015) reduces a manifold. For each other point j, the points k of largest
    area on either side of the diagonal x_0 x_j (`diagonal`); the diagonal of largest total area
    wins. Areas within AREA_TIE of each other count as equal, and the point farther along
    TIE_BREAK is taken, so that the choice does not flicker between quadrilaterals that
    rounding alone tells apart, whatever order the points come in."""
    if count <= 4:
        return 0, 1 if count > 1 else -1, 2 if count > 2 else -1, 3 if count > 3 else -1
    i0 = anchor(work, first, count)
    if count > PRESELECT:
        count, i0 = preselect(work, first, count, N, i0), 0
    best, far, j_far = 0.0, 0.0, -1
    for j in range(count):
        best = max(best, diagonal(work, first, count, N, i0, j)[2])
        e = sub(row(work, first + j, 0), row(work, first + i0, 0))
        if dot(e, e) > far:
            far, j_far = dot(e, e), j
    if best <= 0.0:  # on one line: its two ends
        return i0, j_far, -1, -1
    chosen = -1
    for j in range(count):
        total = diagonal(work, first, count, N, i0, j)[2]
        if j != i0 and total >= best * (1.0 - AREA_TIE):
            if chosen < 0 or along_g(work, first, j) > along_g(work, first, chosen):
                chosen = j
    k_plus, k_minus, _ = diagonal(work, first, count, N, i0, chosen)
    return i0, chosen, k_plus, k_minus


@njit(**UNCOUNTED)
def preselect(work, first, count, N, i0):
    """The rows of the points the quadrilateral is looked for among when there are more than
    PRESELECT (a hull's many vertices on a halfspace), moved to the front: the anchor i0 (row
    first), then each point farthest along one of 8 directions of the plane seen along N, 45
    degrees apart from TIE_BREAK's part in it (the farther along TIE_BREAK of two within
    AREA_TIE of the spread). The support polygon's corners are among them, and the search over
    them costs 81 area terms instead of count^2. Returns how many rows were kept (2 to 9)."""
    swap_rows(work, first, first + i0)
    u1 = sub(TIE_BREAK, scale(N, dot(TIE_BREAK, N)))
    u1 = scale(u1, 1.0 / math.sqrt(dot(u1, u1)))
    u2 = cross(N, u1)
    x0 = row(work, first, 0)
    kept = 1
    for k in range(8):
        u = axpy(math.sin(0.25 * math.pi * k), u2, scale(u1, math.cos(0.25 * math.pi * k)))
        best, high = 0, 0.0
        for i in range(count):
            h = dot(sub(row(work, first + i, 0), x0), u)
            tie = AREA_TIE * abs(high)
            farther = along_g(work, first, i) > along_g(work, first, best)
            if h > high + tie or (h >= high - tie and farther):
                best, high = i, h
        if best >= kept:
            swap_rows(work, first + kept, first + best)
            kept += 1
    return kept


@njit(**UNCOUNTED)
def swap_rows(work, r, s):
    """Rows r and s of the work array exchange a point and its depth (columns 0 to DEPTH)."""
    for c in range(DEPTH + 1):
        work[r, c], work[s, c] = work[s, c], work[r, c]


@njit(**UNCOUNTED)
def diagonal(work, first, count, N, i0, j):
    """(k_plus, k_minus, area): the points of largest area (x_j - x_0) x (x_k - x_0) . N on
    either side of the diagonal from point i0 to point j (-1: none that side; the farther along
    TIE_BREAK of two within AREA_TIE), and twice the area of the quadrilateral they span."""
    x0 = row(work, first + i0, 0)
    edge = sub(row(work, first + j, 0), x0)
    most, least = 0.0, 0.0
    for k in range(count):
        area = dot(cross(edge, sub(row(work, first + k, 0), x0)), N)
        most, least = max(most, area), min(least, area)
    k_plus, k_minus = -1, -1
    for k in range(count):
        area = dot(cross(edge, sub(row(work, first + k, 0), x0)), N)
        if area > 0.0 and area >= most * (1.0 - AREA_TIE):
            if k_plus < 0 or along_g(work, first, k) > along_g(work, first, k_plus):
                k_plus = k
        if area < 0.0 and area <= least * (1.0 - AREA_TIE):
            if k_minus < 0 or along_g(work, first, k) > along_g(work, first, k_minus):
                k_minus = k
    return k_plus, k_minus, most - least
