"""Two overlapping boxes by the separating-axis theorem (Gottschalk, Lin and Manocha, OBBTree,
SIGGRAPH 1996; Ericson, Real-Time Collision Detection, 2005, 4.4.1): along a unit axis L the
boxes' projections overlap by

    o(L) = r_A(L) + r_B(L) - |L . (p_B - p_A)|,   r_X(L) = sum_k h_k |L . u_k|

(h_k the half sizes, u_k the box's axes in the world). Boxes are disjoint when some L has
o(L) < 0, and L among the 15 candidates suffices: the 3 + 3 face normals u_i, v_j and the 9 edge
directions u_i x v_j. For overlapping boxes the least o(L) over those 15 is the penetration
depth (the same candidates bound the Minkowski difference of two polytopes: its faces' normals
are exactly these), with L, turned from a towards b, the normal. The witness points follow the
axis' kind: a face of A (B's vertex deepest along -L is p_B), a face of B (A's vertex deepest
along L is p_A), or an edge of each (the closest points of the two supporting edges, as
MuJoCo's and ODE's box-box routines do).
"""

from __future__ import annotations

import math

from numba import njit

from ..._runtime.kernel_cache import UNCOUNTED
from .closed_forms import segments_closest, write_inflated
from .support import core_support
from .vectors import axis, axpy, cross, dot, norm, origin, scale, sub

PARALLEL = 1e-9  # |u_i x v_j| below this: the edges are parallel, the face axes cover them
# an edge axis must beat the best face axis by this much (metres): faces give the steadier
# witness points where the two are equal
EDGE_BIAS = 1e-12


@njit(**UNCOUNTED)
def projected_radius(T, h, L):
    """r(L) = sum_k h_k |L . u_k|: the half length of a box's projection on L."""
    return (
        h[0] * abs(dot(L, axis(T, 0)))
        + h[1] * abs(dot(L, axis(T, 1)))
        + h[2] * abs(dot(L, axis(T, 2)))
    )


@njit(**UNCOUNTED)
def supporting_edge(T, h, i, L):
    """The box's edge along its axis u_i that is farthest along L: centre
    p + sum_{k != i} sign(L . u_k) h_k u_k, ends -/+ h_i u_i about it."""
    centre = origin(T)
    for k in range(3):
        if k != i:
            centre = axpy(math.copysign(h[k], dot(L, axis(T, k))), axis(T, k), centre)
    half = scale(axis(T, i), h[i])
    return sub(centre, half), axpy(1.0, half, centre)


@njit(**UNCOUNTED)
def box_box(a, b, margin, out):
    """Boxes a and b: -1 when an axis separates them by more than margin (m; out untouched:
    GJK measures the distance), else the least-overlap axis' index k (0-2 A's faces, 3-5 B's,
    6-14 the edge pairs u_(k-6)//3 x v_(k-6)%3) with out = (-depth, p_A, p_B, L)
    (closed_forms.write_inflated). Within the margin but apart, the least overlap is negative:
    the axis that separates them most, -depth their gap along it (exact for a face; a
    contact's manifold, where GJK's and EPA's answers degrade as two faces come to touch
    within rounding)."""
    T_a, T_b = a[3], b[3]
    h_a = (0.5 * a[1][0], 0.5 * a[1][1], 0.5 * a[1][2])
    h_b = (0.5 * b[1][0], 0.5 * b[1][1], 0.5 * b[1][2])
    t = sub(origin(T_b), origin(T_a))
    depth, best, kind = math.inf, (0.0, 0.0, 1.0), 0
    for k in range(15):
        if k < 3:
            L = axis(T_a, k)
        elif k < 6:
            L = axis(T_b, k - 3)
        else:
            L = cross(axis(T_a, (k - 6) // 3), axis(T_b, (k - 6) % 3))
            length = norm(L)
            if length < PARALLEL:
                continue
            L = scale(L, 1.0 / length)
        s = dot(L, t)
        overlap = projected_radius(T_a, h_a, L) + projected_radius(T_b, h_b, L) - abs(s)
        if overlap < -margin:
            return -1
        if overlap < depth - (EDGE_BIAS if k >= 6 else 0.0):
            depth, best, kind = overlap, (L if s >= 0.0 else scale(L, -1.0)), k
    if kind < 3:  # a face of A: B's deepest vertex
        p_b = core_support(b, scale(best, -1.0))
        p_a = axpy(depth, best, p_b)
    elif kind < 6:  # a face of B: A's deepest vertex
        p_a = core_support(a, best)
        p_b = axpy(-depth, best, p_a)
    else:  # an edge of each
        p1, q1 = supporting_edge(T_a, h_a, (kind - 6) // 3, best)
        p2, q2 = supporting_edge(T_b, h_b, (kind - 6) % 3, scale(best, -1.0))
        p_a, p_b = segments_closest(p1, q1, p2, q2)
    write_inflated(out, p_a, p_b, best, 0.0, 0.0)
    return kind
