"""Closed forms of the narrow phase, each writing the out row (narrow_phase.py) of its pair
(a, b) in the order given:

  rounded    sphere or capsule against sphere or capsule: the closest points of their cores
             (a point is a segment of length zero; Ericson, Real-Time Collision Detection, 2005,
             5.1.9, ClosestPtSegmentSegment), then the radii
  sphere_box the sphere's centre clamped to the box (Ericson 5.1.3); inside, the nearest face
  halfspace  any shape against the halfspace z_g <= 0 of b's frame: the shape's deepest point
             along -n is its support point s(-n), exact for every convex shape

A shape is the tuple (code, size, hull, T) of support.py.

Every result goes through `write_inflated`: the cores' points c_A, c_B and the unit normal n from
a towards b give, for radii r_A and r_B (zero for shapes without a core),

    d = n . (c_B - c_A) - r_A - r_B,   p_A = c_A + r_A n,   p_B = c_B - r_B n,

so p_B - p_A = d n; exact when n is the cores' normal, as the set core (+) ball(r) is at
distance d_core - r from any point outside it.
"""

from __future__ import annotations

from numba import njit

from ..._runtime.kernel_cache import UNCOUNTED
from .support import core_radius, core_support
from .vectors import (
    axis,
    axpy,
    cross,
    dot,
    norm,
    origin,
    perpendicular,
    rotate,
    scale,
    sub,
    to_local,
    to_world,
)

TINY = 1e-14  # squared lengths below this are zero: a segment that is a point, parallel segments
# out row: d, p_A (3), p_B (3), n (3)
DISTANCE, POINT_A, POINT_B, NORMAL = 0, 1, 4, 7
OUT_SIZE = 10


@njit(**UNCOUNTED)
def write_inflated(out, c_a, c_b, n, r_a, r_b):
    """out = (d, p_A, p_B, n) from the cores' points and normal and the radii (module
    docstring)."""
    out[DISTANCE] = dot(n, sub(c_b, c_a)) - r_a - r_b
    p_a, p_b = axpy(r_a, n, c_a), axpy(-r_b, n, c_b)
    for k in range(3):
        out[POINT_A + k], out[POINT_B + k], out[NORMAL + k] = p_a[k], p_b[k], n[k]


@njit(**UNCOUNTED)
def swap_sides(out):
    """out (OUT_SIZE,), a result of (b, a), read as (a, b): p_A and p_B swapped, n negated."""
    for k in range(3):
        out[POINT_A + k], out[POINT_B + k] = out[POINT_B + k], out[POINT_A + k]
        out[NORMAL + k] = -out[NORMAL + k]


@njit(**UNCOUNTED)
def room_by_depth(rows, last, d):
    """The row at which a contact of distance d goes among rows[:last], sorted the deepest first:
    the rows from there to last - 1 move down one (row `last` is overwritten). Returns it."""
    r = last
    while r > 0 and rows[r - 1, DISTANCE] > d:
        for c in range(OUT_SIZE):
            rows[r, c] = rows[r - 1, c]
        r -= 1
    return r


@njit(**UNCOUNTED)
def clamp01(x):
    return min(max(x, 0.0), 1.0)


@njit(**UNCOUNTED)
def segments_closest(p1, q1, p2, q2):
    """The closest points c1 = p1 + s d1 and c2 = p2 + t d2 of the segments [p1, q1] and
    [p2, q2] (Ericson 5.1.9): with d1 = q1 - p1, d2 = q2 - p2, r = p1 - p2,
      s = clamp((b f - c e) / (a e - b^2)),  t = (b s + f) / e,  then t clamped and s recomputed,
    a = d1.d1, b = d1.d2, c = d1.r, e = d2.d2, f = d2.r; parallel segments (a e - b^2 = 0)
    take s = 0, a point (a or e zero) its own formula."""
    d1, d2, r = sub(q1, p1), sub(q2, p2), sub(p1, p2)
    a, e, f = dot(d1, d1), dot(d2, d2), dot(d2, r)
    if a <= TINY and e <= TINY:
        s, t = 0.0, 0.0
    elif a <= TINY:
        s, t = 0.0, clamp01(f / e)
    else:
        c = dot(d1, r)
        if e <= TINY:
            s, t = clamp01(-c / a), 0.0
        else:
            b = dot(d1, d2)
            denom = a * e - b * b
            s = clamp01((b * f - c * e) / denom) if denom > TINY * a * e else 0.0
            t = (b * s + f) / e
            if t < 0.0:
                s, t = clamp01(-c / a), 0.0
            elif t > 1.0:
                s, t = clamp01((b - c) / a), 1.0
    return axpy(s, d1, p1), axpy(t, d2, p2)


@njit(**UNCOUNTED)
def core_segment(shape):
    """The ends of a sphere's or capsule's core: p -/+ (length/2) z_g (the centre twice for a
    sphere, whose size[1] is zero)."""
    T = shape[3]
    half = scale(axis(T, 2), 0.5 * shape[1][1])
    return sub(origin(T), half), axpy(1.0, half, origin(T))


@njit(**UNCOUNTED)
def rounded(a, b, out):
    """Sphere or capsule a against sphere or capsule b: the cores' closest points c_A, c_B, the
    normal n = (c_B - c_A)/|c_B - c_A|; cores that meet take n perpendicular to both (any
    perpendicular when they are parallel), turned towards b's centre. The depth r_A + r_B is then
    exact: moving b along n by it separates the cores' sum with the ball (concentric spheres
    take z)."""
    p1, q1 = core_segment(a)
    p2, q2 = core_segment(b)
    c_a, c_b = segments_closest(p1, q1, p2, q2)
    gap = sub(c_b, c_a)
    length = norm(gap)
    if length > 1e-12:
        n = scale(gap, 1.0 / length)
    else:
        u1, u2 = sub(q1, p1), sub(q2, p2)
        m = cross(u1, u2)
        if dot(m, m) > TINY:
            n = scale(m, 1.0 / norm(m))
        elif dot(u1, u1) > TINY:
            n = perpendicular(u1)
        elif dot(u2, u2) > TINY:
            n = perpendicular(u2)
        else:
            n = (0.0, 0.0, 1.0)  # concentric spheres: every direction is as deep
        if dot(n, sub(origin(b[3]), origin(a[3]))) < 0.0:
            n = scale(n, -1.0)
    write_inflated(out, c_a, c_b, n, core_radius(a[0], a[1]), core_radius(b[0], b[1]))


@njit(**UNCOUNTED)
def sphere_box(a, b, out):
    """Sphere a (centre c, radius r) against box b (half sizes h): with c_l = R^T (c - p) in the
    box's frame, the box's point nearest c is q = clamp(c_l, -h, h) (Ericson 5.1.3); c outside:
    n = (q - c_l)/|q - c_l|; c inside: the face k of least h_k - |c_l,k| is nearest, q = c_l with
    q_k = sign(c_l,k) h_k, n = -sign(c_l,k) e_k, the depth h_k - |c_l,k| + r."""
    T = b[3]
    c = origin(a[3])
    c_l = to_local(T, sub(c, origin(T)))
    h = (0.5 * b[1][0], 0.5 * b[1][1], 0.5 * b[1][2])
    q = (
        min(max(c_l[0], -h[0]), h[0]),
        min(max(c_l[1], -h[1]), h[1]),
        min(max(c_l[2], -h[2]), h[2]),
    )
    gap = sub(q, c_l)
    length = norm(gap)
    if length > 0.0:
        n_l = scale(gap, 1.0 / length)
    else:
        k, least = 0, h[0] - abs(c_l[0])
        for j in (1, 2):
            if h[j] - abs(c_l[j]) < least:
                k, least = j, h[j] - abs(c_l[j])
        side = 1.0 if c_l[k] >= 0.0 else -1.0
        q = (
            side * h[0] if k == 0 else q[0],
            side * h[1] if k == 1 else q[1],
            side * h[2] if k == 2 else q[2],
        )
        n_l = (-side if k == 0 else 0.0, -side if k == 1 else 0.0, -side if k == 2 else 0.0)
    write_inflated(out, c, to_world(T, q), rotate(T, n_l), a[1][0], 0.0)


@njit(**UNCOUNTED)
def halfspace(a, b, out):
    """Shape a against the halfspace b = {x : n . (x - p) <= 0}, n = z_g of b, p its origin: a's
    point deepest along -n is its core's support point c_A = s(-n) (less r_A n), its signed
    distance d = n . (c_A - p) - r_A, and c_B = c_A - (n . (c_A - p)) n its projection on the
    plane; the normal from a towards b is -n."""
    n = axis(b[3], 2)
    c_a = core_support(a, scale(n, -1.0))
    c_b = axpy(-dot(n, sub(c_a, origin(b[3]))), n, c_a)
    write_inflated(out, c_a, c_b, scale(n, -1.0), core_radius(a[0], a[1]), 0.0)
