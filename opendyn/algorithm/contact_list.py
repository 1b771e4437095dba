"""The contact list of one evaluation: every contact point within a margin, found once, from the
contact spheres on the ground and from the pairs of collision geometries, as MuJoCo's
mjData.contact holds them; the named records of those two sources; and the rows of the
velocity-level contact problem the list gives. Both contact laws read the list: the compliant
one (opendyn.algorithm.contact) and the hard one (opendyn.sim.hard_step).

The sources, made once per run (opendyn.sim.effects.contact.pack and
opendyn.sim.effects.geometry_contact.pack):

    Spheres     body (P,) int     each contact sphere's body
                centre (P, 3) m   its centre in the body's frame
                radius (P,) m     its radius (0: a point)
                ground (1,) m     the height h of the ground plane z = h
                law (P, 4)        each sphere's law with the ground (a law row, below)
    Geometries  table             the geometries, the ground last (a GeometryArrays,
                                  opendyn.multibody.geometry)
                pairs (P, 2) int  the pairs (a, b) of geometries the contact checks
                law (P, 4)        each pair's law

A law row: STIFFNESS k N/m, DAMPING c N s/m, FRICTION mu (Coulomb), SLIP v_s m/s (the compliant
law reads the four, the hard model mu alone).

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
from .collision import DISTANCE, MAX_CONTACTS, NORMAL, OUT_SIZE, POINT_A, POINT_B
from .collision.narrow_phase import COLUMNS, ROWS
from .collision.queries import pair_rows
from .collision.world import bounding_boxes, pair_near, place_geometries
from .kinematics import add_point_jacobian

STIFFNESS, DAMPING, FRICTION, SLIP = range(4)  # a law row's entries
Spheres = namedtuple("Spheres", ("body", "centre", "radius", "ground", "law"))
Geometries = namedtuple("Geometries", ("table", "pairs", "law"))
ContactList = namedtuple(
    "ContactList", ("count", "pair", "feature", "bodies", "point", "frame", "depth", "mu")
)
# The arrays the pairs of geometries are found in, made once per run: the geometries' world
# poses T_sg (G, 3, 4), each hull's climbing start hints (G,) int, their bounding boxes (G, 6),
# the narrow phase's scratch, one pair's contact rows (MAX_CONTACTS, OUT_SIZE), and rows
# (3, nv) for A J of the compliant law's linearisation (opendyn.algorithm.contact_tangent).
GeometryRoom = namedtuple("GeometryRoom", ("T_sg", "hints", "boxes", "scratch", "rows", "AJ"))
# What a contact list is found in, made once per run: the list `found`, the pairs' GeometryRoom
# (None without geometries) and scratch (2, 3).
ContactRoom = namedtuple("ContactRoom", ("found", "pairs", "scratch"))


@njit(**JIT)
def contact_list(capacity):
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
def geometry_room(geometry, nv):
    """The GeometryRoom of the Geometries geometry on a model of nv velocity coordinates, or
    None for None."""
    if geometry is None:
        return None
    count = geometry.table.body.shape[0]
    return GeometryRoom(
        np.zeros((count, 3, 4)),
        np.zeros(count, dtype=np.int64),
        np.zeros((count, 6)),
        np.zeros((ROWS, COLUMNS)),
        np.zeros((MAX_CONTACTS, OUT_SIZE)),
        np.zeros((3, nv)),
    )


@njit(**JIT)
def most_contacts(spheres, geometry):
    """How many contacts the sources can have at once: one per sphere, MAX_CONTACTS per pair
    (either None: none)."""
    count = 0
    if spheres is not None:
        count += spheres.body.shape[0]
    if geometry is not None:
        count += MAX_CONTACTS * geometry.pairs.shape[0]
    return count


@njit(**JIT)
def contact_room(spheres, geometry, nv):
    """The ContactRoom of the sources spheres (Spheres or None) and geometry (Geometries or
    None) on a model of nv velocity coordinates: a list with room for every contact they can
    have (most_contacts), so that it never fills. Called from Python for a run's step and
    compiled into the record's kernels, which make one per thread."""
    found = contact_list(most_contacts(spheres, geometry))
    return ContactRoom(found, geometry_room(geometry, nv), np.zeros((2, 3)))


@njit(**JIT)
def add_contact(found, ids, bodies, x, n, depth, mu):
    """found's next entry <- the contact of ids = (pair, feature) between bodies = (a, b) at the
    point x (3,) with normal n (3,) (a to b), signed distance depth and coefficient mu; its
    frame from n (module docstring). Nothing when the list is full (contact_room makes room
    for every point there can be)."""
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
def lowest_point(posed, spheres, p, x_s):
    """x_s (3,) <- p_sb + R_sb c_b - r e_z, the lowest point of contact sphere p of the
    Spheres (centre c_b in its body b's frame, radius r) in {s}, posed = (R_s, p_s) the bodies'
    world poses. Returns b."""
    R_s, p_s = posed
    b = spheres.body[p]
    c_b = spheres.centre[p]
    for r in range(3):
        x_s[r] = p_s[b, r] + R_s[b, r, 0] * c_b[0] + R_s[b, r, 1] * c_b[1] + R_s[b, r, 2] * c_b[2]
    x_s[2] -= spheres.radius[p]
    return b


@njit(**JIT)
def find_sphere_contacts(posed, spheres, margin, found, scratch):
    """found += each contact sphere whose lowest point is within margin (m) of the ground
    plane: posed = (R_s, p_s) the bodies' world poses; spheres: Spheres; scratch (2, 3). The
    ground is a, the sphere's body b, n = +z. Nothing for spheres None (numba drops the call
    when it compiles)."""
    if spheres is None:
        return
    x, n = scratch[0], scratch[1]
    n[0], n[1], n[2] = 0.0, 0.0, 1.0
    for p in range(spheres.body.shape[0]):
        b = lowest_point(posed, spheres, p, x)
        d = x[2] - spheres.ground[0]
        if d <= margin:
            add_contact(found, (p, 0), (-1, b), x, n, d, spheres.law[p, FRICTION])


@njit(**JIT)
def find_pair_contacts(posed, geometry, margin, room, found, scratch):
    """found += the manifold points within margin (m) of every pair of collision geometries:
    geometry: Geometries; room: its GeometryRoom; posed = (R_s, p_s) the bodies' world poses;
    scratch (2, 3). Each point at the midpoint of its witness points, with the narrow phase's
    normal (a to b) and distance, in the pair's order and then the manifold's. Nothing for
    geometry None (numba drops the call when it compiles)."""
    if geometry is None:
        return
    R_s, p_s = posed
    table, pairs = geometry.table, geometry.pairs
    place_geometries(R_s, p_s, table, room.T_sg)
    bounding_boxes(table, room.hints, room.T_sg, room.boxes)
    rows, x = room.rows, scratch[0]
    for p in range(pairs.shape[0]):
        i, j = pairs[p, 0], pairs[p, 1]
        if not pair_near(table.code, room.T_sg, room.boxes, i, j, margin):
            continue
        count, _ = pair_rows((table, room.hints, room.T_sg), i, j, margin, rows, room.scratch)
        for c in range(count):
            for r in range(3):
                x[r] = 0.5 * (rows[c, POINT_A + r] + rows[c, POINT_B + r])
            add_contact(
                found, (p, c), (table.body[i], table.body[j]), x, rows[c, NORMAL : NORMAL + 3],
                rows[c, DISTANCE], geometry.law[p, FRICTION],
            )


@njit(**JIT)
def find_contacts(posed, sources, margin, room):
    """room.found <- the contacts within margin (m) of sources = (spheres, geometry) (Spheres,
    Geometries, either None), the spheres' first, at the bodies' world poses posed = (R_s,
    p_s); room: a ContactRoom (or anything with its found, pairs and scratch)."""
    room.found.count[0] = 0
    find_sphere_contacts(posed, sources[0], margin, room.found, room.scratch)
    find_pair_contacts(posed, sources[1], margin, room.pairs, room.found, room.scratch)


@njit(**JIT)
def contact_rows(body_tree, posed, found, k, J3, S, out):
    """out (3, nv) <- contact k's rows of the constraint Jacobian: its frame (t1, t2, n) times
    J = J_b(x) - J_a(x) (module docstring); J3 (3, nv) and S (6,) scratch."""
    relative_jacobian(body_tree, posed, found, k, J3, S)
    F = found.frame[k]
    for r in range(3):
        for j in range(J3.shape[1]):
            out[r, j] = F[r, 0] * J3[0, j] + F[r, 1] * J3[1, j] + F[r, 2] * J3[2, j]


@njit(**JIT)
def relative_jacobian(body_tree, posed, found, k, J, S):
    """J (3, nv) <- J_b(x) - J_a(x) of contact k at its point x, world axes (the velocity of
    b's material at x relative to a's per unit of v); S (6,) scratch."""
    R_s, p_s = posed
    J[:] = 0.0
    a, b = found.bodies[k, 0], found.bodies[k, 1]
    x = found.point[k]
    if b >= 0:
        add_point_jacobian(body_tree, R_s, p_s, b, x, 1.0, J, S)
    if a >= 0:
        add_point_jacobian(body_tree, R_s, p_s, a, x, -1.0, J, S)
