"""The contact manifold of two boxes, overlapping or apart by at most the margin: up to four
points, each with its own depth, by clipping (clipping.py), on the separating axis of
box_box.py:

  1. the separating-axis test (box_box.py) gives the axis of least overlap L, from a towards b
     (of most separation, for boxes apart within the margin);
     an edge pair gives its one contact, unless a face axis lies within features.FACE_ON of L
     (faces a hair from parallel), a face is the reference face, normal N (outward)
  2. the incident face: the other box's face whose outward normal is most against N
  3. the incident face's four corners clipped by the reference face's four side planes
     (u_j . (x - c) <= h_j and -u_j . (x - c) <= h_j for the face's two in-plane axes)
  4. each remaining point x below the reference face or within the margin above it,
     s = N . (x - f) <= margin (f on the face), is a contact of depth s: x on the incident box,
     x - s N on the reference face (a corner a hair above the face, of a box that rocks or
     rests a hair from flat, stays in the manifold: a velocity-level step that lost it would
     let the box tip about the others)
  5. more than four: clipping.reduce_to_four

Each contact is a row of the narrow phase's out layout (d, p_A, p_B, L). The deepest of the
clipped points is also the pair's one witness pair (box_witnesses: pair_distance's points of two
overlapping boxes).
"""

from __future__ import annotations

import math

from numba import njit

from ..._runtime.kernel_cache import UNCOUNTED
from .box_box import box_box
from .clipping import DEPTH, clip, reduce_to_four
from .closed_forms import NORMAL, room_by_depth, write_inflated
from .features import FACE_ON
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
def below_reference(a, b, axis_of, margin, work):
    """Steps 2-4 for boxes a and b whose least-overlap axis L (from a towards b) is face axis
    `kind` (< 6) of box_box, axis_of = (kind, L): the incident face clipped by the reference
    face's side planes, the points x at most margin (m) above the reference face in work rows
    POLYGON.., each with its depth s = N . (x - f) (<= margin) in column DEPTH. Returns
    (count, N) with N the reference face's outward normal (L when it is A's, -L when it is
    B's)."""
    kind, L = axis_of
    if kind < 3:  # A's face is the reference: N = L
        T_ref, size_ref, T_inc, size_inc, r, N = a[3], a[1], b[3], b[1], kind, L
    else:  # B's: N = -L
        T_ref, size_ref, T_inc, size_inc, r, N = b[3], b[1], a[3], a[1], kind - 3, scale(L, -1.0)
    h_ref = (0.5 * size_ref[0], 0.5 * size_ref[1], 0.5 * size_ref[2])
    h_inc = (0.5 * size_inc[0], 0.5 * size_inc[1], 0.5 * size_inc[2])
    face = axpy(math.copysign(h_ref[r], dot(N, axis(T_ref, r))), axis(T_ref, r), origin(T_ref))
    incident_face(work, T_inc, h_inc, N)
    count = clipped_contacts(work, T_ref, h_ref, r, N, 4)
    below = 0
    for i in range(count):  # keep those under the reference face or within the margin
        x = row(work, POLYGON + i, 0)
        s = dot(N, sub(x, face))
        if s <= margin:
            put(work, POLYGON + below, 0, x)
            work[POLYGON + below, DEPTH] = s
            below += 1
    return below, N


@njit(**UNCOUNTED)
def write_face_contact(out, x, s, N, kind):
    """out <- the contact at the incident box's point x of depth s under the reference face
    (outward normal N): x on the incident box and x - s N on the reference face, the normal
    from a towards b (N when A's face is the reference, kind < 3; -N otherwise)."""
    on_ref = axpy(-s, N, x)
    if kind < 3:
        write_inflated(out, on_ref, x, N, 0.0, 0.0)
    else:
        write_inflated(out, x, on_ref, scale(N, -1.0), 0.0, 0.0)


@njit(**UNCOUNTED)
def box_witnesses(a, b, kind, out, work):
    """The witness points of overlapping (or touching) boxes a and b whose box_box result
    `kind` and out = (-depth, p_A, p_B, L) are given: for a face axis, the deepest point of the
    incident face inside the reference face's sides (steps 2-4), on the incident box, and its
    foot on the reference face. box_box's own points for a face axis are the incident box's
    support vertex and that vertex moved by the depth, which lies off the reference face where
    the vertex is beyond its sides (a box resting across another's edge); the deepest clipped
    point is on both boxes, and at the same depth: the incident feature that reaches deepest
    along -N is part of the incident face, and its projection meets the reference face (the
    least-overlap axis is a face of the Minkowski difference, which holds the origin's
    projection). An edge pair's points (kind >= 6) stay as box_box found them."""
    if kind >= 6:
        return
    L = (out[NORMAL], out[NORMAL + 1], out[NORMAL + 2])
    count, N = below_reference(a, b, (kind, L), 0.0, work)
    if count == 0:  # (rounding) the separating-axis points
        return
    deepest = 0
    for i in range(count):
        if work[POLYGON + i, DEPTH] < work[POLYGON + deepest, DEPTH]:
            deepest = i
    depth = work[POLYGON + deepest, DEPTH]
    write_face_contact(out, row(work, POLYGON + deepest, 0), depth, N, kind)


@njit(**UNCOUNTED)
def face_on(a, b, L):
    """(kind, L_face): the face axis of box a (kind 0-2) or b (3-5) most along the edge pair's
    axis L, turned to point as L does, when it is within FACE_ON of L; (-1, L) otherwise. Two
    boxes face to face whose faces are a hair from parallel (a tilt of 1e-9 rad) have an edge
    axis of least overlap, by the tilt times their size, where the contact is a face's: the
    face axis gives its corners, the edge axis one point, and the manifold would jump between
    four points and one as the tilt changes sign."""
    kind, best = -1, FACE_ON
    L_face = L
    for k in range(6):
        u = axis(a[3], k) if k < 3 else axis(b[3], k - 3)
        c = dot(u, L)
        if abs(c) >= best:
            kind, best, L_face = k, abs(c), (u if c > 0.0 else scale(u, -1.0))
    return kind, L_face


@njit(**UNCOUNTED)
def box_contacts(a, b, margin, contacts, work):
    """Up to four contacts of boxes a and b overlapping or apart by at most margin (m) (each
    (code, size, hull, T) as pair_distance's arguments, the codes BOX) into rows of contacts
    (4, OUT_SIZE), the deepest first, the points of the incident face at most margin above the
    reference face included; `work` as pair_distance's. Returns their count: 0 when the boxes
    are farther apart, 1 for an edge on an edge (box_box's result)."""
    kind = box_box(a, b, margin, contacts[0])
    if kind < 0:
        return 0
    L = row(contacts, 0, NORMAL)
    if kind >= 6:  # an edge pair: a face contact still, when L is within FACE_ON of a face's
        kind, L = face_on(a, b, L)
        if kind < 0:
            return 1
    below, N = below_reference(a, b, (kind, L), margin, work)
    if below == 0:  # (rounding) the separating-axis contact alone
        return 1
    n_contacts = 0
    for i in reduce_to_four(work, POLYGON, below, N):
        if i < 0:
            continue
        s = work[POLYGON + i, DEPTH]
        k = room_by_depth(contacts, n_contacts, s)
        write_face_contact(contacts[k], row(work, POLYGON + i, 0), s, N, kind)
        n_contacts += 1
    return n_contacts
