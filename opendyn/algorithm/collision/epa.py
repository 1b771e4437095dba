"""EPA, the expanding polytope algorithm: the penetration depth of two overlapping convex sets,
the distance from the origin to the boundary of their Minkowski difference D = A - B (van den
Bergen, "Proximity queries and penetration depth computation on 3D game objects", GDC 2001;
the same algorithm as coal's EPA).

    P = a tetrahedron of points of D around the origin (GJK's last simplex, grown if need be)
    repeat:  f = the face of P nearest the origin: unit normal n (outward), distance delta
             w = s_D(n)
             n.w - delta <= TOLERANCE  -> depth = delta, normal n
             P = hull(P + w): the faces w sees removed, their horizon joined to w

The boundary point delta n of D is s_A - s_B for the points p_A, p_B found by the face's
barycentric weights: p_A on A's boundary deepest in B, p_B on B's deepest in A, and moving B by
delta n separates the sets (the normal from A towards B).

The polytope lives in the work array after the simplex (layout below): vertices as GJK's rows
(w, s_A, s_B), faces as (i, j, k, n (3), delta, alive), the horizon's edges as (i, j).
"""

from __future__ import annotations

import math

from numba import njit

from ..._runtime.kernel_cache import UNCOUNTED
from ..._runtime.status import Status
from .gjk import put_vertex
from .simplex import COLUMNS, A, B, W, plane_side
from .support import difference_support
from .vectors import add, cross, dot, norm, perpendicular, row, scale, sub

TOLERANCE = 1e-9  # n.w - delta at which EPA stops, metres
# w sees a face when it is farther than this beyond its plane (metres): a face w lies on stays,
# as one on either side of it by rounding would make the horizon ragged
VISIBLE = 1e-13
# faces whose normals are this close (cosine) lie in one plane of D, for the witness points
COPLANAR = 1.0 - 1e-9
DISTINCT = 1e-10  # a support point nearer than this to the polytope's span adds no dimension
MAX_VERTICES = 256
MAX_FACES = 2 * MAX_VERTICES  # a closed triangulated polytope has 2 V - 4 faces
MAX_EDGES = 2 * MAX_VERTICES

VERTICES = 4  # rows of the vertices (w, s_A, s_B)
FACES = VERTICES + MAX_VERTICES  # rows of the faces
EDGES = FACES + MAX_FACES  # rows of the horizon's edges
ROWS = EDGES + MAX_EDGES  # the work array is (ROWS, COLUMNS)
# columns of a face row
I, J, K, NORMAL, DELTA, ALIVE = 0, 1, 2, 3, 6, 7


@njit(**UNCOUNTED)
def vertex(work, i):
    """w of the polytope's vertex i."""
    return row(work, VERTICES + i, W)


@njit(**UNCOUNTED)
def add_face(work, i, j, k):
    """Face (i, j, k), counter-clockwise seen from outside, in the first free face row:
    n = (w_j - w_i) x (w_k - w_i) / |.|, delta = n . w_i; a face of no area has no normal and
    delta = inf, so that it is never the nearest. Returns False when no row is free."""
    a = vertex(work, i)
    n = cross(sub(vertex(work, j), a), sub(vertex(work, k), a))
    length = norm(n)
    if length > 0.0:
        n = scale(n, 1.0 / length)
    for f in range(FACES, EDGES):
        if work[f, ALIVE] == 0.0:
            work[f, I], work[f, J], work[f, K] = i, j, k
            work[f, NORMAL], work[f, NORMAL + 1], work[f, NORMAL + 2] = n
            work[f, DELTA] = dot(n, a) if length > 0.0 else math.inf
            work[f, ALIVE] = 1.0
            return True
    return False


@njit(**UNCOUNTED)
def grow_simplex(a, b, work, n):
    """GJK's simplex of n < 4 points around the origin (the cores touch) grown to a tetrahedron
    by support points along directions that add a dimension: any axis for a point, two
    perpendiculars for a segment, the normals of a triangle. Returns the number of vertices: 4,
    or fewer when D is flat (then it has no interior and the depth is zero)."""
    for _ in range(3):
        if n == 4:
            break
        w0 = vertex(work, 0)
        if n == 1:
            directions = ((1.0, 0.0, 0.0), (-1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, -1.0, 0.0))
        elif n == 2:
            e = perpendicular(sub(vertex(work, 1), w0))
            f = cross(sub(vertex(work, 1), w0), e)
            directions = (e, scale(e, -1.0), f, scale(f, -1.0))
        else:
            e = cross(sub(vertex(work, 1), w0), sub(vertex(work, 2), w0))
            directions = (e, scale(e, -1.0), e, scale(e, -1.0))
        grown = False
        for d in directions:
            w, sa, sb = difference_support(a, b, d)
            if span_distance(work, n, w) > DISTINCT:
                put_vertex(work, VERTICES + n, w, sa, sb)
                n += 1
                grown = True
                break
        if not grown:
            break
    return n


@njit(**UNCOUNTED)
def span_distance(work, n, w):
    """The distance from w to the affine span of the polytope's first n (1 to 3) vertices."""
    e = sub(w, vertex(work, 0))
    if n == 1:
        return norm(e)
    u = sub(vertex(work, 1), vertex(work, 0))
    if n == 2:
        return norm(cross(e, u)) / norm(u)
    m = cross(u, sub(vertex(work, 2), vertex(work, 0)))
    return abs(dot(e, m)) / norm(m)


@njit(**UNCOUNTED)
def known_vertex(work, n, w):
    """Whether w is one of the polytope's n vertices already."""
    for i in range(n):
        e = sub(vertex(work, i), w)
        if dot(e, e) == 0.0:
            return True
    return False


@njit(**UNCOUNTED)
def toggle_edge(work, n_edges, i, j):
    """The horizon, as directed edges of the removed faces: edge i -> j cancels a listed j -> i
    (the face across it is removed too), else it is added. Returns the new count, or -1 when
    the list is full."""
    for e in range(EDGES, EDGES + n_edges):
        if work[e, 0] == j and work[e, 1] == i:
            last = EDGES + n_edges - 1
            work[e, 0], work[e, 1] = work[last, 0], work[last, 1]
            return n_edges - 1
    if n_edges == MAX_EDGES:
        return -1
    work[EDGES + n_edges, 0], work[EDGES + n_edges, 1] = i, j
    return n_edges + 1


@njit(**UNCOUNTED)
def nearest_face(work):
    """The live face of least delta (the nearest to the origin)."""
    best, delta = FACES, math.inf
    for f in range(FACES, EDGES):
        if work[f, ALIVE] != 0.0 and work[f, DELTA] < delta:
            best, delta = f, work[f, DELTA]
    return best


@njit(**UNCOUNTED)
def face_weights(work, f, closest):
    """(lambda_i, lambda_j, lambda_k): the barycentric weights of the point `closest` of face
    f's plane (Ericson 3.4), each in [0, 1] when the point is inside the face."""
    a = vertex(work, int(work[f, I]))
    v0, v1 = sub(vertex(work, int(work[f, J])), a), sub(vertex(work, int(work[f, K])), a)
    v2 = sub(closest, a)
    d00, d01, d11 = dot(v0, v0), dot(v0, v1), dot(v1, v1)
    d20, d21 = dot(v2, v0), dot(v2, v1)
    denom = d00 * d11 - d01 * d01
    lj = (d11 * d20 - d01 * d21) / denom if denom > 0.0 else 0.0
    lk = (d00 * d21 - d01 * d20) / denom if denom > 0.0 else 0.0
    return 1.0 - lj - lk, lj, lk


@njit(**UNCOUNTED)
def witness_face(work, f):
    """The face whose barycentric weights of delta n hold best (their least is largest) among
    face f and the live faces in its plane (delta within TOLERANCE, normal within COPLANAR).
    Two shapes face to face make a flat part of D out of many triangles of the same delta, some
    of them slivers: the nearest by rounding may hold delta n far outside itself, where its
    weights would put p_A and p_B off their shapes; the triangle that holds delta n puts them
    on the features that touch."""
    closest = scale(row(work, f, NORMAL), work[f, DELTA])
    best, held = f, min(face_weights(work, f, closest))
    for g in range(FACES, EDGES):
        if held >= 0.0:
            break
        if (
            work[g, ALIVE] == 0.0
            or work[g, DELTA] > work[f, DELTA] + TOLERANCE
            or dot(row(work, g, NORMAL), row(work, f, NORMAL)) < COPLANAR
        ):
            continue
        weight = min(face_weights(work, g, closest))
        if weight > held:
            best, held = g, weight
    return best


@njit(**UNCOUNTED)
def face_witnesses(work, f):
    """(p_A, p_B) of the boundary point delta n of face f, by barycentric weights
    (face_weights of witness_face): delta n = sum lambda w, p_A = sum lambda s_A,
    p_B = sum lambda s_B. The weights are clamped to [0, 1] (a sliver face's rounding), so that
    the points are convex combinations of support points; each then takes back half of what
    the clamp left between p_A - p_B and delta n, so that p_A - p_B = delta n exactly. On the
    face that holds delta n that residue is rounding: the points stay on their shapes."""
    closest = scale(row(work, f, NORMAL), work[f, DELTA])
    f = witness_face(work, f)
    i, j, k = int(work[f, I]), int(work[f, J]), int(work[f, K])
    li, lj, lk = face_weights(work, f, closest)
    li, lj, lk = max(li, 0.0), max(lj, 0.0), max(lk, 0.0)
    total = li + lj + lk
    li, lj, lk = li / total, lj / total, lk / total
    p_a = add(
        add(scale(row(work, VERTICES + i, A), li), scale(row(work, VERTICES + j, A), lj)),
        scale(row(work, VERTICES + k, A), lk),
    )
    p_b = add(
        add(scale(row(work, VERTICES + i, B), li), scale(row(work, VERTICES + j, B), lj)),
        scale(row(work, VERTICES + k, B), lk),
    )
    half_residue = scale(sub(sub(p_a, p_b), closest), 0.5)
    return sub(p_a, half_residue), add(p_b, half_residue)


@njit(**UNCOUNTED)
def epa(a, b, work, n):
    """EPA on the cores of shapes a and b from GJK's simplex of n rows around the origin (rows
    0 to n - 1 of `work`, which must have ROWS rows of COLUMNS). Returns (status, depth, normal,
    p_A, p_B): depth >= 0, normal the unit direction from A towards B in which moving B by depth
    separates the cores, p_B - p_A = -depth normal. status is Status.OK, or NO_CONVERGENCE when
    the gap stays open: the polytope ran out of rows, or its support point is a vertex already
    (the result is then its nearest face's)."""
    for r in range(n):
        for c in range(COLUMNS):
            work[VERTICES + r, c] = work[r, c]
    for f in range(FACES, EDGES):
        work[f, ALIVE] = 0.0
    n = grow_simplex(a, b, work, n)
    if n < 4:  # D is flat: the origin is on its boundary
        u = sub(vertex(work, 1), vertex(work, 0)) if n > 1 else (0.0, 0.0, 1.0)
        normal = perpendicular(u)
        if n == 3:  # the plane's normal
            m = cross(u, sub(vertex(work, 2), vertex(work, 0)))
            normal = scale(m, 1.0 / norm(m))
        return Status.OK.value, 0.0, normal, row(work, VERTICES, A), row(work, VERTICES, B)
    # the tetrahedron's faces, counter-clockwise seen from outside: (0, 1, 2) has vertex 3 behind
    if plane_side(work, VERTICES, VERTICES + 1, VERTICES + 2, vertex(work, 3)) > 0.0:
        for c in range(COLUMNS):
            work[VERTICES + 1, c], work[VERTICES + 2, c] = (
                work[VERTICES + 2, c],
                work[VERTICES + 1, c],
            )
    for i, j, k in ((0, 1, 2), (0, 3, 1), (1, 3, 2), (2, 3, 0)):
        add_face(work, i, j, k)
    status = Status.NO_CONVERGENCE.value
    while True:
        f = nearest_face(work)
        normal, delta = row(work, f, NORMAL), work[f, DELTA]
        w, sa, sb = difference_support(a, b, normal)
        if dot(normal, w) - delta <= TOLERANCE:
            status = Status.OK.value
            break
        if n == MAX_VERTICES or known_vertex(work, n, w):
            break  # out of rows, or the polytope cannot grow towards w: the gap stays open
        put_vertex(work, VERTICES + n, w, sa, sb)
        n_edges = 0
        for g in range(FACES, EDGES):  # the faces w sees go; their horizon stays
            if work[g, ALIVE] != 0.0 and dot(row(work, g, NORMAL), w) - work[g, DELTA] > VISIBLE:
                work[g, ALIVE] = 0.0
                for e0, e1 in ((I, J), (J, K), (K, I)):
                    if n_edges >= 0:
                        n_edges = toggle_edge(work, n_edges, work[g, e0], work[g, e1])
        if n_edges < 0:
            break
        full = False
        for e in range(EDGES, EDGES + n_edges):
            full = full or not add_face(work, int(work[e, 0]), int(work[e, 1]), n)
        n += 1
        if full:
            break
    f = nearest_face(work)
    p_a, p_b = face_witnesses(work, f)
    return status, work[f, DELTA], row(work, f, NORMAL), p_a, p_b
