"""The contact manifold of two overlapping boxes: up to four points, each with its own depth,
by clipping (clipping.py), on the separating axis of box_box.py:

  1. the separating-axis test (box_box.py) gives the axis of least overlap L, from a towards b;
     an edge pair gives its one contact, a face is the reference face, normal N (outward)
  2. the incident face: the other box's face whose outward normal is most against N
  3. the incident face's four corners clipped by the reference face's four side planes
     (u_j . (x - c) <= h_j and -u_j . (x - c) <= h_j for the face's two in-plane axes)
  4. each remaining point x below the reference face, s = N . (x - f) <= 0 (f on the face), is a
     contact of depth s: x on the incident box, x - s N on the reference face
  5. more than four: clipping.reduce_to_four

Each contact is a row of the narrow phase's out layout (d, p_A, p_B, L).
"""

from __future__ import annotations

import math

from numba import njit

from ..._runtime.kernel_cache import UNCOUNTED
from .box_box import box_box
from .clipping import DEPTH, clip, reduce_to_four
from .closed_forms import room_by_depth, write_inflated
from .vectors import axis, axpy, dot, origin, put, row, scale, sub

POLYGON, CLIPPED = 0, 8  # work rows of the polygon being clipped and of its clipped copy


@njit(**UNCOUNTED)
def incident_face(work, T, h, N):
    """The four corners, in order around it, of the face of box (T, h) whose outward normal is
    most against N, into work rows POLYGON..POLYGON + 3."""
    m, best = 0, -1.0
    for k in range(3):
        if abs(dot(N, axis(T, k))) > best:
            m, best = k, abs(dot(N, axis(T, k)))
    centre = axpy(-math.copysign(h[m], dot(N, axis(T, m))), axis(T, m), origin(T))
    i, j = (m + 1) % 3, (m + 2) % 3
    e_i, e_j = scale(axis(T, i), h[i]), scale(axis(T, j), h[j])
    signs = ((1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0))
    for r in range(4):
        put(work, POLYGON + r, 0, axpy(signs[r][1], e_j, axpy(signs[r][0], e_i, centre)))


@njit(**UNCOUNTED)
def clipped_contacts(work, T_ref, h_ref, r, N, count):
    """The incident polygon clipped by the reference face's side planes (face axis r of box
    (T_ref, h_ref)); returns the corner count, the corners in rows POLYGON.."""
    for j in ((r + 1) % 3, (r + 2) % 3):
        u = axis(T_ref, j)
        c = dot(u, origin(T_ref))
        count = clip(work, POLYGON, count, CLIPPED, u, c + h_ref[j])
        count = clip(work, CLIPPED, count, POLYGON, scale(u, -1.0), -c + h_ref[j])
    return count


@njit(**UNCOUNTED)
def box_contacts(code_a, size_a, hull_a, T_a, code_b, size_b, hull_b, T_b, contacts, work):
    """Up to four contacts of boxes a and b (the arguments as pair_distance's; code_a
    and code_b BOX) into rows of contacts (4, OUT_SIZE), the deepest first; `work`
    as pair_distance's. Returns their count: 0 when the boxes are apart, 1 for an edge on an
    edge (pair_distance's result)."""
    a = (code_a, size_a, hull_a, T_a)
    b = (code_b, size_b, hull_b, T_b)
    kind = box_box(a, b, contacts[0])
    if kind < 0:
        return 0
    if kind >= 6:
        return 1
    L = row(contacts, 0, 7)
    if kind < 3:  # A's face is the reference: N = L
        T_ref, size_ref, T_inc, size_inc, r, N = T_a, size_a, T_b, size_b, kind, L
    else:  # B's: N = -L
        T_ref, size_ref, T_inc, size_inc, r, N = T_b, size_b, T_a, size_a, kind - 3, scale(L, -1.0)
    h_ref = (0.5 * size_ref[0], 0.5 * size_ref[1], 0.5 * size_ref[2])
    h_inc = (0.5 * size_inc[0], 0.5 * size_inc[1], 0.5 * size_inc[2])
    face = axpy(math.copysign(h_ref[r], dot(N, axis(T_ref, r))), axis(T_ref, r), origin(T_ref))
    incident_face(work, T_inc, h_inc, N)
    count = clipped_contacts(work, T_ref, h_ref, r, N, 4)
    below = 0
    for i in range(count):  # keep those under the reference face, with their depth s
        x = row(work, POLYGON + i, 0)
        s = dot(N, sub(x, face))
        if s <= 0.0:
            put(work, POLYGON + below, 0, x)
            work[POLYGON + below, DEPTH] = s
            below += 1
    if below == 0:  # (rounding) the separating-axis contact alone
        return 1
    n_contacts = 0
    for i in reduce_to_four(work, POLYGON, below, N):
        if i < 0:
            continue
        x, s = row(work, POLYGON + i, 0), work[POLYGON + i, DEPTH]
        on_ref = axpy(-s, N, x)
        k = room_by_depth(contacts, n_contacts, s)
        if kind < 3:
            write_inflated(contacts[k], on_ref, x, L, 0.0, 0.0)
        else:
            write_inflated(contacts[k], x, on_ref, L, 0.0, 0.0)
        n_contacts += 1
    return n_contacts
