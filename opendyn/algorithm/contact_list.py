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

from .._runtime.kernel_cache import JIT, UNCOUNTED, UNCOUNTED_INLINE
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
# What a contact list is found in, made once per run: ints (1 + 4 C,) int64 and floats
# (14 C + 6,) the list's entries (list_of views them as a ContactList; the last six floats are
# the finders' scratch, finder_scratch), and the pairs' GeometryRoom (None without geometries).
# Two buffers, not the list's eight arrays: the room rides in the step's SceneData and Context,
# which every compiled call of the step passes on, each array at a cost.
ContactRoom = namedtuple("ContactRoom", ("ints", "floats", "pairs"))
SCRATCH = 6  # the finders' scratch at the end of a room's floats: two (3,) vectors


@njit(**JIT)
def list_of(ints, floats):
    """The ContactList (module docstring) held in the buffers ints (1 + 4 C,) int64 and floats
    (at least 14 C,), as views: count, pair, feature, bodies in ints, point, frame, depth, mu
    in floats, each field contiguous."""
    C = (ints.shape[0] - 1) // 4
    return ContactList(
        ints[0:1],
        ints[1 : 1 + C],
        ints[1 + C : 1 + 2 * C],
        ints[1 + 2 * C : 1 + 4 * C].reshape((C, 2)),
        floats[0 : 3 * C].reshape((C, 3)),
        floats[3 * C : 12 * C].reshape((C, 3, 3)),
        floats[12 * C : 13 * C],
        floats[13 * C : 14 * C],
    )


@njit(**JIT)
def finder_scratch(floats):
    """(2, 3): the finders' scratch, the last SCRATCH floats of a ContactRoom's floats."""
    return floats[floats.shape[0] - SCRATCH :].reshape((2, 3))


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
    C = most_contacts(spheres, geometry)
    return ContactRoom(
        np.zeros(1 + 4 * C, dtype=np.int64), np.zeros(14 * C + SCRATCH),
        geometry_room(geometry, nv),
    )


@njit(**UNCOUNTED_INLINE)
def add_contact(found, ids, bodies, x, n, depth, mu):
    """found's next entry <- the contact of ids = (pair, feature) between bodies = (a, b) at the
    point x (3,) with normal n (3,) (a to b), signed distance depth and coefficient mu; its
    frame from n (module docstring). Nothing when the list is full (contact_room makes room
    for every point there can be)."""
    k = found.count[0]
    if k >= found.pair.shape[0]:
        return
    found.count[0] = k + 1
    found.pair[k], found.feature[k] = ids[0], ids[1]
    found.bodies[k, 0], found.bodies[k, 1] = bodies[0], bodies[1]
    found.depth[k], found.mu[k] = depth, mu
    n0, n1, n2 = n[0], n[1], n[2]
    # t1 = n x e / |n x e|, e the world axis least aligned with n (the first of the least)
    if abs(n0) <= abs(n1) and abs(n0) <= abs(n2):
        a0, a1, a2 = 0.0, n2, -n1  # n x e_x
    elif abs(n1) <= abs(n2):
        a0, a1, a2 = -n2, 0.0, n0  # n x e_y
    else:
        a0, a1, a2 = n1, -n0, 0.0  # n x e_z
    size = np.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
    a0, a1, a2 = a0 / size, a1 / size, a2 / size
    F = found.frame
    F[k, 0, 0], F[k, 0, 1], F[k, 0, 2] = a0, a1, a2
    # t2 = n x t1
    F[k, 1, 0] = n1 * a2 - n2 * a1
    F[k, 1, 1] = n2 * a0 - n0 * a2
    F[k, 1, 2] = n0 * a1 - n1 * a0
    F[k, 2, 0], F[k, 2, 1], F[k, 2, 2] = n0, n1, n2
    found.point[k, 0], found.point[k, 1], found.point[k, 2] = x[0], x[1], x[2]


@njit(**UNCOUNTED_INLINE)
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


@njit(**UNCOUNTED)
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


@njit(**UNCOUNTED)
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


@njit(**UNCOUNTED)
def find_contacts(posed, sources, margin, room):
    """room.found <- the contacts within margin (m) of sources = (spheres, geometry) (Spheres,
    Geometries, either None), the spheres' first, at the bodies' world poses posed = (R_s,
    p_s); room: anything with a ContactList found, the pairs' GeometryRoom pairs and scratch
    (2, 3) (the hard step's HardRoom; room_parts of a ContactRoom)."""
    room.found.count[0] = 0
    find_sphere_contacts(posed, sources[0], margin, room.found, room.scratch)
    find_pair_contacts(posed, sources[1], margin, room.pairs, room.found, room.scratch)


# A ContactRoom's parts by name, as the finders and the compliant law read them: found (the
# ContactList of its buffers), pairs and scratch (room_parts).
RoomParts = namedtuple("RoomParts", ("found", "pairs", "scratch"))


@njit(**JIT)
def room_parts(room):
    """The RoomParts of a ContactRoom: its buffers viewed as the list and the scratch."""
    return RoomParts(list_of(room.ints, room.floats), room.pairs, finder_scratch(room.floats))


@njit(**UNCOUNTED)
def contact_rows(body_tree, posed, found, k, J3, S, out):
    """out (3, nv) <- contact k's rows of the constraint Jacobian: its frame (t1, t2, n) times
    J = J_b(x) - J_a(x) (module docstring); J3 (3, nv) and S (6,) scratch."""
    relative_jacobian(body_tree, posed, found, k, J3, S)
    F = found.frame[k]
    for r in range(3):
        for j in range(J3.shape[1]):
            out[r, j] = F[r, 0] * J3[0, j] + F[r, 1] * J3[1, j] + F[r, 2] * J3[2, j]


@njit(**UNCOUNTED)
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
