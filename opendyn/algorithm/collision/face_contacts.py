"""The contact manifold of two convex shapes that touch face-on or edge-on (a cylinder standing
on its cap or lying on its side, a mesh's face on a box, two hulls face to face): up to four
points, each with its own depth, clipped from the shapes' contact features (features.py), as
Bullet's polyhedral contact clipping and MuJoCo's multi-point convex contacts do.

Given the narrow phase's one contact (d, p_A, p_B, n), n from a towards b:

  1. the features: a's along n, b's along -n (a face's corners, an edge's ends, or a point);
     either a point: the one contact is the manifold
  2. the reference: a face (over an edge), the face more along the contact (N_a . n >= -N_b . n)
     of two faces, a's edge of two parallel edges (two edges that cross touch at one point);
     the other feature is the incident one
  3. the incident feature clipped by the reference's side planes: a face's edges
     ((x_{i+1} - x_i) x N . (x - x_i) <= 0, N its outward normal), an edge's two ends
  4. each clipped point x, of the incident core: s = N . (x - f) (f on the reference, N = n for a
     reference edge), a contact of distance s - r_a - r_b (the radii of a capsule's core) at x
     and at x - s N on the reference, kept when at most the margin
  5. more than four: clipping.reduce_to_four; none: the narrow phase's one contact

Each contact is a row of the narrow phase's out layout (d, p_A, p_B, normal), the normal N from a
towards b (-N when b's face is the reference).
"""

from __future__ import annotations

from numba import njit

from ..._runtime.kernel_cache import UNCOUNTED
from ...multibody.shapes import SPHERE
from .clipping import DEPTH, clip, reduce_to_four
from .closed_forms import NORMAL, room_by_depth, write_inflated
from .features import EDGE_ON, MAX_CORNERS, feature
from .support import core_radius
from .vectors import axpy, cross, dot, norm, put, row, scale, sub

# work rows: a's feature, b's feature, the incident polygon and its clipped copy (each clip by
# one plane adds at most one corner: MAX_CORNERS + MAX_CORNERS in all)
FEATURE_A, FEATURE_B = 0, MAX_CORNERS
POLYGON, CLIPPED = 2 * MAX_CORNERS, 4 * MAX_CORNERS


@njit(**UNCOUNTED)
def clip_segment(work, count, m, c):
    """The segment in rows POLYGON, POLYGON + 1 cut by the plane m . x <= c in place; returns 2,
    or 0 when all of it is outside."""
    p, q = row(work, POLYGON, 0), row(work, POLYGON + 1, 0)
    dp, dq = dot(m, p) - c, dot(m, q) - c
    if count == 0 or (dp > 0.0 and dq > 0.0):
        return 0
    if dp > 0.0:
        put(work, POLYGON, 0, axpy(dp / (dp - dq), sub(q, p), p))
    elif dq > 0.0:
        put(work, POLYGON + 1, 0, axpy(dq / (dq - dp), sub(p, q), q))
    return 2


@njit(**UNCOUNTED)
def clip_incident(work, reference, sides, N, count):
    """The incident feature in rows POLYGON.. (count points) clipped by the side planes of the
    reference feature in rows reference.. (`sides` corners; 2: an edge), left in rows
    POLYGON..; returns its point count."""
    for i in range(sides if sides > 2 else 2):
        x_i = row(work, reference + i, 0)
        if sides > 2:  # the face's edge i, its outward side
            m = cross(sub(row(work, reference + (i + 1) % sides, 0), x_i), N)
        else:  # the edge's end i: beyond it along the edge
            m = sub(x_i, row(work, reference + 1 - i, 0))
        c = dot(m, x_i)
        if count == 2:
            count = clip_segment(work, count, m, c)
        elif count > 2:
            count = clip(work, POLYGON, count, CLIPPED, m, c)
            for r in range(count):
                put(work, POLYGON + r, 0, row(work, CLIPPED + r, 0))
    return count


@njit(**UNCOUNTED)
def face_contacts(a, b, margin, contacts, work):
    """The manifold of shapes a and b (code, size, hull, T: support.py), whose narrow-phase
    contact is row 0 of contacts (MAX_CONTACTS, OUT_SIZE), into rows of contacts, the deepest
    first, those at distance at most margin (m) (module docstring); `work` as pair_distance's.
    Returns the count of rows: 1 when the shapes touch at a point (row 0 is left as it is)."""
    if a[0] == SPHERE or b[0] == SPHERE:
        return 1
    n = row(contacts, 0, NORMAL)
    count_a, N_a = feature(a, n, work, FEATURE_A)
    if count_a == 1:
        return 1
    count_b, N_b = feature(b, scale(n, -1.0), work, FEATURE_B)
    if count_b == 1:
        return 1
    if count_a == 2 and count_b == 2:
        e_a = sub(row(work, FEATURE_A + 1, 0), row(work, FEATURE_A, 0))
        e_b = sub(row(work, FEATURE_B + 1, 0), row(work, FEATURE_B, 0))
        if norm(cross(e_a, e_b)) > EDGE_ON * norm(e_a) * norm(e_b):
            return 1
    a_reference = count_a > 2 and (count_b == 2 or dot(N_a, n) >= -dot(N_b, n))
    a_reference = a_reference or (count_a == 2 and count_b == 2)
    if a_reference:
        reference, sides, N, incident, count = FEATURE_A, count_a, N_a, FEATURE_B, count_b
    else:
        reference, sides, N, incident, count = FEATURE_B, count_b, N_b, FEATURE_A, count_a
    for r in range(count):
        put(work, POLYGON + r, 0, row(work, incident + r, 0))
    count = clip_incident(work, reference, sides, N, count)
    r_a, r_b = core_radius(a[0], a[1]), core_radius(b[0], b[1])
    f = row(work, reference, 0)
    kept = 0
    for i in range(count):  # the points within the margin, with their distance
        x = row(work, POLYGON + i, 0)
        s = dot(N, sub(x, f)) - r_a - r_b
        if s <= margin:
            put(work, POLYGON + kept, 0, x)
            work[POLYGON + kept, DEPTH] = s
            kept += 1
    if kept == 0:
        return 1
    written = 0
    for i in reduce_to_four(work, POLYGON, kept, N):
        if i < 0:
            continue
        x, s = row(work, POLYGON + i, 0), work[POLYGON + i, DEPTH]
        on_reference = axpy(-(s + r_a + r_b), N, x)
        k = room_by_depth(contacts, written, s)
        if a_reference:
            write_inflated(contacts[k], on_reference, x, N, r_a, r_b)
        else:
            write_inflated(contacts[k], x, on_reference, scale(N, -1.0), r_a, r_b)
        written += 1
    return written
