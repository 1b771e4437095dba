"""The point of a simplex (1 to 4 points w_i of the Minkowski difference A - B) closest to the
origin, as barycentric weights lambda_i (sum 1), and the smallest sub-simplex that holds it:
GJK's sub-algorithm, here by Voronoi regions (Ericson, Real-Time Collision Detection, 2005,
5.1.2 segment, 5.1.5 triangle, 5.1.6 tetrahedron, with the query point P at the origin).

The simplex lives in rows of the work array (layout below); a row holds w = s_A - s_B, the two
support points s_A and s_B that made it, and its weight, so that the witness points are
p_A = sum lambda_i s_A,i and p_B = sum lambda_i s_B,i (van den Bergen 2003, 4.3.4).
"""

from __future__ import annotations

import math

from numba import njit

from ..._runtime.kernel_cache import UNCOUNTED
from .vectors import add, dot, row, scale, sub

# columns of a work row: w (3), s_A (3), s_B (3), the weight lambda
W, A, B, WEIGHT = 0, 3, 6, 9
COLUMNS = 10
SIMPLEX = 0  # the simplex: rows 0 to 3
# a tetrahedron's faces (i, j, k) and the vertex l opposite each
TETRAHEDRON_FACES = ((0, 1, 2, 3), (0, 1, 3, 2), (0, 2, 3, 1), (1, 2, 3, 0))


@njit(**UNCOUNTED)
def segment_weights(work, i, j):
    """(lambda_i, lambda_j) of the point of [w_i, w_j] closest to the origin:
    t = clamp(-w_i . e / e . e, 0, 1), e = w_j - w_i (Ericson 5.1.2)."""
    a = row(work, i, W)
    e = sub(row(work, j, W), a)
    ee = dot(e, e)
    t = 0.0 if ee <= 0.0 else min(max(-dot(a, e) / ee, 0.0), 1.0)
    return 1.0 - t, t


@njit(**UNCOUNTED)
def squared_distance(work, i, j, k, li, lj, lk):
    """|lambda_i w_i + lambda_j w_j + lambda_k w_k|^2."""
    p = add(add(scale(row(work, i, W), li), scale(row(work, j, W), lj)), scale(row(work, k, W), lk))
    return dot(p, p)


@njit(**UNCOUNTED)
def triangle_weights(work, i, j, k):
    """(lambda_i, lambda_j, lambda_k) of the point of triangle (a, b, c) = (w_i, w_j, w_k) closest
    to the origin, by its Voronoi regions (Ericson 5.1.5, ClosestPtPointTriangle). A degenerate
    (collinear) triangle gives its closest edge's point."""
    a, b, c = row(work, i, W), row(work, j, W), row(work, k, W)
    ab, ac = sub(b, a), sub(c, a)
    d1, d2 = -dot(ab, a), -dot(ac, a)
    if d1 <= 0.0 and d2 <= 0.0:
        return 1.0, 0.0, 0.0  # vertex region a
    d3, d4 = -dot(ab, b), -dot(ac, b)
    if d3 >= 0.0 and d4 <= d3:
        return 0.0, 1.0, 0.0  # vertex region b
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        v = d1 / (d1 - d3)
        return 1.0 - v, v, 0.0  # edge region ab
    d5, d6 = -dot(ab, c), -dot(ac, c)
    if d6 >= 0.0 and d5 <= d6:
        return 0.0, 0.0, 1.0  # vertex region c
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        w = d2 / (d2 - d6)
        return 1.0 - w, 0.0, w  # edge region ac
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and d4 - d3 >= 0.0 and d5 - d6 >= 0.0:
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        return 0.0, 1.0 - w, w  # edge region bc
    total = va + vb + vc
    if total > 0.0:
        return va / total, vb / total, vc / total  # the face's interior
    # degenerate: the nearest of the three edges
    lij = segment_weights(work, i, j)
    ljk = segment_weights(work, j, k)
    lki = segment_weights(work, k, i)
    best = (lij[0], lij[1], 0.0)
    for cand in ((0.0, ljk[0], ljk[1]), (lki[1], 0.0, lki[0])):
        if squared_distance(work, i, j, k, *cand) < squared_distance(work, i, j, k, *best):
            best = cand
    return best


@njit(**UNCOUNTED)
def plane_side(work, i, j, k, x):
    """((w_j - w_i) x (w_k - w_i)) . (x - w_i): which side of the plane (i, j, k) x is on."""
    a = row(work, i, W)
    ab, ac = sub(row(work, j, W), a), sub(row(work, k, W), a)
    n = (
        ab[1] * ac[2] - ab[2] * ac[1],
        ab[2] * ac[0] - ab[0] * ac[2],
        ab[0] * ac[1] - ab[1] * ac[0],
    )
    return dot(n, sub(x, a))


@njit(**UNCOUNTED)
def tetrahedron_weights(work):
    """Weights of the point of the tetrahedron (rows 0-3) closest to the origin, written to the
    WEIGHT column; True when the origin is inside (the shapes overlap). Only the faces whose plane
    separates the origin from the fourth vertex can hold the closest point (Ericson 5.1.6,
    ClosestPtPointTetrahedron); a flat tetrahedron tests all four faces."""
    best = math.inf
    inside = True
    for f in range(4):
        i, j, k, l = TETRAHEDRON_FACES[f]
        if (
            plane_side(work, i, j, k, (0.0, 0.0, 0.0)) * plane_side(work, i, j, k, row(work, l, W))
            > 0.0
        ):
            continue  # the origin is on the tetrahedron's side of this face
        inside = False
        li, lj, lk = triangle_weights(work, i, j, k)
        d = squared_distance(work, i, j, k, li, lj, lk)
        if d < best:
            best = d
            work[i, WEIGHT], work[j, WEIGHT], work[k, WEIGHT], work[l, WEIGHT] = li, lj, lk, 0.0
    return inside


@njit(**UNCOUNTED)
def reduce_simplex(work, n):
    """The point of the simplex (rows 0 to n - 1) closest to the origin: its weights, then the
    simplex reduced to the points of positive weight. Returns (n, inside): inside when the origin
    is in the tetrahedron (n = 4 then, left as it is)."""
    if n == 2:
        work[0, WEIGHT], work[1, WEIGHT] = segment_weights(work, 0, 1)
    elif n == 3:
        work[0, WEIGHT], work[1, WEIGHT], work[2, WEIGHT] = triangle_weights(work, 0, 1, 2)
    elif n == 4 and tetrahedron_weights(work):
        return 4, True
    kept = 0
    for r in range(n):
        if work[r, WEIGHT] > 0.0:
            for c in range(COLUMNS):
                work[kept, c] = work[r, c]
            kept += 1
    return kept, False


@njit(**UNCOUNTED)
def weighted(work, n, column):
    """sum_i lambda_i x_i over the simplex's rows, x the 3 columns from `column` (W: the closest
    point v; A, B: the witness points)."""
    x = (0.0, 0.0, 0.0)
    for r in range(n):
        x = add(x, scale(row(work, r, column), work[r, WEIGHT]))
    return x
