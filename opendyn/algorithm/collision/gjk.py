"""GJK: the distance between two convex sets A and B, as the distance from the origin to their
Minkowski difference D = A - B (Gilbert, Johnson and Keerthi, IEEE J. Robotics and Automation 4(2),
1988; van den Bergen, Collision Detection in Interactive 3D Environments, 2003, 4.3).

    v_0 = s_D(d), d from A's origin towards B's: a point of D near its nearest to the origin
    repeat:  w = s_D(-v) = s_A(-v) - s_B(v)
             |v| - v.w/|v| <= TOLERANCE   -> |v| is the distance to within TOLERANCE
             simplex += w;  v = the simplex's point closest to the origin;  simplex reduced

v.w/|v| is a lower bound of the distance and |v| an upper bound, so the loop stops on their
difference, the duality gap, in metres; it also stops when a support point is already in the
simplex or |v| no longer decreases (a polytope's last step), and reports NO_CONVERGENCE after
MAX_ITERATIONS. |v| can stall while the gap is still wide, on a thin simplex whose nearest point
float64 cannot resolve (a box's face against a cylinder's rim: the distance right to 1e-10 m, its
direction off by 1e-4); the simplex then starts again from the last support point, at most
MAX_RESTARTS times. The origin inside the simplex, or |v| below OVERLAP, means that the sets
overlap: EPA (epa.py) takes the simplex from there.

GJK here runs on the shapes' cores (support.py): the caller adds the radii.
"""

from __future__ import annotations

import math

from numba import njit

from ..._runtime.kernel_cache import UNCOUNTED
from ..._runtime.status import Status
from .simplex import WEIGHT, A, B, W, reduce_simplex, weighted
from .support import difference_support
from .vectors import dot, origin, put, row, sub

TOLERANCE = 1e-11  # the duality gap at which GJK stops, metres
OVERLAP = 1e-12  # |v| below this: the origin is on the simplex, the sets touch or overlap
MAX_ITERATIONS = 256
RESTART = 1e-9  # a stall with a duality gap above this (m) restarts the simplex, MAX_RESTARTS times
MAX_RESTARTS = 4


@njit(**UNCOUNTED)
def put_vertex(work, r, w, sa, sb):
    """Row r of the work array = (w, s_A, s_B)."""
    put(work, r, W, w)
    put(work, r, A, sa)
    put(work, r, B, sb)


@njit(**UNCOUNTED)
def gjk(a, b, work):
    """GJK on the cores of shapes a and b (tuples (code, size, vertices, T), see support.py),
    with the simplex in rows 0-3 of `work`. Returns (status, overlap, n):
      overlap False: the simplex's n rows and weights give the cores' nearest points,
                     p_A = sum lambda s_A and p_B = sum lambda s_B (simplex.weighted);
      overlap True:  the cores overlap (or touch); the n rows hold a simplex around the origin.
    status is Status.OK, or NO_CONVERGENCE after MAX_ITERATIONS (the rows then hold the last
    estimate)."""
    # the first point: each shape's farthest towards the other (s_A(d) - s_B(-d) with d from
    # A's origin to B's), near the nearest points already: 2.2 iterations a Panda pair, not 3.4
    d = sub(origin(b[3]), origin(a[3]))
    if dot(d, d) == 0.0:
        d = (1.0, 0.0, 0.0)
    w, sa, sb = difference_support(a, b, d)
    put_vertex(work, 0, w, sa, sb)
    work[0, WEIGHT] = 1.0
    n, v, restarts = 1, w, 0
    for _ in range(MAX_ITERATIONS):
        vv = dot(v, v)
        if vv <= OVERLAP * OVERLAP:
            return Status.OK.value, True, n
        w, sa, sb = difference_support(a, b, (-v[0], -v[1], -v[2]))
        gap = vv - dot(v, w)  # the duality gap |v| - v.w / |v|, times |v|
        if gap <= TOLERANCE * math.sqrt(vv):
            return Status.OK.value, False, n
        for r in range(n):  # w already in the simplex: no support point comes closer
            e = sub(row(work, r, W), w)
            if dot(e, e) == 0.0:
                return Status.OK.value, False, n
        put_vertex(work, n, w, sa, sb)
        n, inside = reduce_simplex(work, n + 1)
        if inside:
            return Status.OK.value, True, n
        v_next = weighted(work, n, W)
        if dot(v_next, v_next) >= vv:
            if gap <= RESTART * math.sqrt(vv) or restarts == MAX_RESTARTS:
                return Status.OK.value, False, n  # no progress: v is as close as float64 gets
            # a thin simplex (a flat face against a curved rim) whose nearest point float64
            # cannot resolve while the gap is still wide: start again from w alone
            put_vertex(work, 0, w, sa, sb)
            work[0, WEIGHT] = 1.0
            n, v_next, restarts = 1, w, restarts + 1
        v = v_next
    return Status.NO_CONVERGENCE.value, False, n
