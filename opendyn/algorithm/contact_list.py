"""The contact list of one step: every contact point within the margin, found once, from the
contact spheres on the ground and from the pairs of collision geometries, as MuJoCo's
mjData.contact holds them; and the rows of the velocity-level contact problem they give.

Each entry k of a ContactList, all in the world frame {s}:

    pair     (C,) int      the pair: a sphere's index (with the ground), or a geometry pair's
    feature  (C,) int      the point's slot in its pair's manifold (0 for a sphere); (pair,
                           feature) is the contact's id, by which a step warm-starts its solve
                           from the step before
    bodies   (C, 2) int    the bodies a and b (-1: the fixed world, the ground)
    point    (C, 3) m      the contact point x: a sphere's lowest point, the midpoint of a
                           geometry pair's two witness points
    frame    (C, 3, 3)     rows t1, t2, n: the contact frame, n the unit normal from a to b and
                           t1, t2 tangents (t1 = n x e / |n x e|, e the world axis least
                           aligned with n; t2 = n x t1)
    depth    (C,) m        the signed distance d (negative: overlapping)
    mu       (C,)          the pair's Coulomb coefficient

and count (1,) int the number of entries. A contact's three rows of the constraint Jacobian are
the frame's rows times J = J_b(x) - J_a(x) (3, nv), the velocity of b's material at x relative
to a's, so that lambda = (lambda_t1, lambda_t2, lambda_n) is the impulse a gives b.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit

from .._runtime.kernel_cache import JIT
from .collision import DISTANCE, NORMAL, POINT_A, POINT_B
from .collision.queries import pair_rows
from .collision.world import bounding_boxes, pair_near, place_geometries
from .contact import lowest_point
from .kinematics import add_point_jacobian

ContactList = namedtuple(
    "ContactList", ("count", "pair", "feature", "bodies", "point", "frame", "depth", "mu")
)

def contact_list(capacity) -> ContactList:
    """An empty ContactList with room for `capacity` entries."""
    return ContactList(
        np.zeros(1, dtype=np.int64),
        np.zeros(capacity, dtype=np.int64),
        np.zeros(capacity, dtype=np.int64),
        np.zeros((capacity, 2), dtype=np.int64),
        np.zeros((capacity, 3)),
        np.zeros((capacity, 3, 3)),
        np.zeros(capacity),
        np.zeros(capacity),
    )


@njit(**JIT)
def add_contact(found, ids, bodies, x, n, depth, mu):
    """found's next entry <- the contact of ids = (pair, feature) between bodies = (a, b) at the
    point x (3,) with normal n (3,) (a to b), signed distance depth and coefficient mu; its
    frame from n (module docstring). Nothing when the list is full."""
    k = found.count[0]
    if k >= found.pair.shape[0]:
        return
    found.count[0] = k + 1
    found.pair[k], found.feature[k] = ids
    found.bodies[k, 0], found.bodies[k, 1] = bodies
    found.depth[k], found.mu[k] = depth, mu
    F = found.frame[k]
    # e: the world axis least aligned with n
    e = 0
    for r in range(1, 3):
        if abs(n[r]) < abs(n[e]):
            e = r
    # t1 = n x e / |n x e|
    t1x = n[1] * (e == 2) - n[2] * (e == 1)
    t1y = n[2] * (e == 0) - n[0] * (e == 2)
    t1z = n[0] * (e == 1) - n[1] * (e == 0)
    size = np.sqrt(t1x * t1x + t1y * t1y + t1z * t1z)
    F[0, 0], F[0, 1], F[0, 2] = t1x / size, t1y / size, t1z / size
    # t2 = n x t1
    F[1, 0] = n[1] * F[0, 2] - n[2] * F[0, 1]
    F[1, 1] = n[2] * F[0, 0] - n[0] * F[0, 2]
    F[1, 2] = n[0] * F[0, 1] - n[1] * F[0, 0]
    for r in range(3):
        F[2, r] = n[r]
        found.point[k, r] = x[r]


@njit(**JIT)
def find_sphere_contacts(posed, spheres, margin, found, scratch):
    """found += each contact sphere whose lowest point is within margin (m) of the ground
    plane z = h: posed = (R_s, p_s) the bodies' world poses; spheres = (bodies (P,) int,
    params: opendyn.algorithm.contact's layout, ground height first, mu (P,)); scratch
    (2, 3). The ground is a, the sphere's body b, n = +z. Nothing for spheres None (numba
    drops the call when it compiles)."""
    if spheres is None:
        return
    R_s, p_s = posed
    bodies, params, mu = spheres
    h = params[0]
    x, n = scratch[0], scratch[1]
    n[0], n[1], n[2] = 0.0, 0.0, 1.0
    for p in range(bodies.shape[0]):
        b = lowest_point(R_s, p_s, bodies, params, p, x)
        d = x[2] - h
        if d <= margin:
            add_contact(found, (p, 0), (-1, b), x, n, d, mu[p])


@njit(**JIT)
def find_pair_contacts(posed, geometry, margin, room, found, scratch):
    """found += the manifold points within margin (m) of every pair of collision geometries:
    geometry = (table: the GeometryTable's arrays, pairs (P, 2) int, mu (P,)); room: the
    geometry contact's GeometryRoom (opendyn.algorithm.geometry_contact); posed = (R_s, p_s) the bodies' world poses; scratch (2, 3). Each point at the
    midpoint of its witness points, with the narrow phase's normal (a to b) and distance.
    Nothing for geometry None (numba drops the call when it compiles)."""
    if geometry is None:
        return
    R_s, p_s = posed
    table, pairs, mu = geometry
    place_geometries(R_s, p_s, table, room.T_sg)
    bounding_boxes(table, room.hints, room.T_sg, room.boxes)
    body = table[0]
    rows, x = room.rows, scratch[0]
    for p in range(pairs.shape[0]):
        i, j = pairs[p, 0], pairs[p, 1]
        if not pair_near(table[2], room.T_sg, room.boxes, i, j, margin):
            continue
        count, _ = pair_rows((table, room.hints, room.T_sg), i, j, margin, rows, room.scratch)
        for c in range(count):
            for r in range(3):
                x[r] = 0.5 * (rows[c, POINT_A + r] + rows[c, POINT_B + r])
            add_contact(
                found, (p, c), (body[i], body[j]), x, rows[c, NORMAL : NORMAL + 3],
                rows[c, DISTANCE], mu[p],
            )


@njit(**JIT)
def contact_rows(body_tree, posed, found, k, J3, S, out):
    """out (3, nv) <- contact k's rows of the constraint Jacobian: its frame (t1, t2, n) times
    J = J_b(x) - J_a(x) (module docstring); J3 (3, nv) and S (6,) scratch."""
    R_s, p_s = posed
    J3[:] = 0.0
    a, b = found.bodies[k, 0], found.bodies[k, 1]
    x = found.point[k]
    if b >= 0:
        add_point_jacobian(body_tree, R_s, p_s, b, x, 1.0, J3, S)
    if a >= 0:
        add_point_jacobian(body_tree, R_s, p_s, a, x, -1.0, J3, S)
    F = found.frame[k]
    for r in range(3):
        for j in range(J3.shape[1]):
            out[r, j] = F[r, 0] * J3[0, j] + F[r, 1] * J3[1, j] + F[r, 2] * J3[2, j]
