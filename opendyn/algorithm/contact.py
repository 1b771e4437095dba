"""The compliant contact law, written once over a ContactList (opendyn.algorithm.contact_list):
the contact spheres on the ground and the pairs of collision geometries alike, as equal and
opposite forces on the two bodies of each contact.

At each contact k of the list (point x, normal n from a to b, signed distance d, bodies a and
b, the pair's law row k, c, mu, v_s), all in the world frame {s}:

    delta     = -d                          penetration (m); only delta > 0 pushes
    J         = J_b(x) - J_a(x)             (3, nv): the velocity of b's material at x relative
                                            to a's per unit of v (J_world = 0)
    v_r       = J v,  delta_dot = -n . v_r
    f_n       = max(0, k delta + c delta_dot)            (no pull: clamped at zero)
    v_t       = v_r - (n . v_r) n,  s = sqrt(|v_t|^2 + v_s^2)
    f         = f_n n - mu f_n v_t / s      the force a applies to b at x; b applies -f to a
    tau      += J^T f

(k stiffness N/m, c damping N s/m, mu the Coulomb coefficient, v_s the slip velocity m/s: a
regularised Coulomb friction). A sphere's contact is its lowest point with the ground (a the
fixed world, n = +z), a geometry pair's the midpoints of its manifold's witness points. The
forces add up: whatever a contact pushes into b it takes out of a, so momentum moves between
bodies and to the world only through a contact with the world. The law omits rolling
resistance and torsional friction.

Energy: the spring k delta is conservative, with U = 1/2 k delta^2 per contact point; the rest
does the work P_nc = f . v_r + k delta delta_dot (the normal damper's -c delta_dot^2 and
friction's f_t . v_t <= 0 while f_n > 0; k delta delta_dot < 0, the spring energy let go, while
the clamp holds f_n at zero). The kernel returns sum k delta delta_dot, which the step adds to
the passive power, so that the dampers and friction are what the balance shows as passive work.

The contact list is found once per evaluation at margin 0 (compliant_contact), and the law's
linearisation for an implicit step is opendyn.algorithm.contact_tangent's.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .._runtime.arrays import fill
from .._runtime.kernel_cache import BATCH, JIT, UNCOUNTED
from ..multibody.layout import body_count, dof_count, tree
from ..multibody.work_views import effect_rows, new_work, scratch_rows, world_poses
from .contact_extremes import note
from .contact_list import (
    DAMPING,
    FRICTION,
    SLIP,
    STIFFNESS,
    contact_room,
    find_contacts,
    lowest_point,
    relative_jacobian,
    room_parts,
)
from .contact_tangent import add_sandwich, add_sphere_tangent
from .kinematics import add_point_jacobian, forward_kinematics

# a row of the geometry contact's record: the pair's index, the point x (3) m, the normal n (3)
# from a to b, the force f (3) N that a applies to b, all in {s}, and the depth delta m
PAIR, POINT, NORMAL_AT, FORCE, DEPTH = 0, 1, 4, 7, 10
ROW = 11


@njit(**UNCOUNTED)
def keep_force(force, k, f):
    """force[k] (3,) <- f (3,), contact k's force; nothing for force None (numba drops the
    code)."""
    if force is None:
        return
    force[k, 0], force[k, 1], force[k, 2] = f[0], f[1], f[2]


@njit(**UNCOUNTED)
def compliant_forces(body_tree, views, room, sources, law, qd, out, touch, force):
    """tau (nv,) += J_k^T f_k over the contacts of the list room.found (a ContactRoom's
    RoomParts, found at the world poses R_s, p_s that `work` holds) of sources = (spheres,
    geometry) (Spheres and Geometries, one of them None), the law above with each contact's
    pair's row of law (P, 4) (the source's); out = (tau, linear): with linear = (K, D, jac)
    and jac, K, D (nv, nv) += its linearisation (opendyn.algorithm.contact_tangent: the
    spheres' exact one, or the pairs' with the points held). force: None, or (C, 3) <- each
    contact's f (N, {s}; zero where it does not push). touch: None, or the run's extremes, to
    which each contact that overlaps is noted with its pair
    (opendyn.algorithm.contact_extremes.note). views = (work, (R_s, p_s), J (3, nv), s (9, 6)):
    the Data's buffer, its world poses, effect rows and scratch rows, which it works in (and in
    work's contact axes), allocating nothing. Compiled without reference counting, as the
    finders are: it binds the list's arrays at every contact. Returns sum k delta delta_dot
    (W), the springs' share of the power."""
    tau, (K, D, jac) = out
    found = room.found
    work, (R_s, p_s), J, s = views
    nv = qd.shape[0]
    v_r, v_t, f, u, c_s = s[1, :3], s[1, 3:], s[2, :3], s[2, 3:], s[3, :3]
    spring = 0.0
    for k in range(found.count[0]):
        f[:] = 0.0
        delta = -found.depth[k]
        if delta <= 0.0:
            keep_force(force, k, f)
            continue
        n, pair = found.frame[k, 2], found.pair[k]
        relative_jacobian(body_tree, (R_s, p_s), found, k, J, s[0])
        # v_r = J v; delta_dot = -n . v_r
        for r in range(3):
            v_r[r] = 0.0
            for j in range(nv):
                v_r[r] += J[r, j] * qd[j]
        along = n[0] * v_r[0] + n[1] * v_r[1] + n[2] * v_r[2]
        k_p, c_p = law[pair, STIFFNESS], law[pair, DAMPING]
        mu, v_s = law[pair, FRICTION], law[pair, SLIP]
        delta_dot = -along
        spring += k_p * delta * delta_dot
        # f_n = max(0, k delta + c delta_dot)
        f_n = k_p * delta + c_p * delta_dot
        if f_n <= 0.0:
            note(touch, pair, delta, 0.0)
            keep_force(force, k, f)
            continue
        # v_t = v_r - (n . v_r) n; f = f_n n - mu f_n v_t / s
        for r in range(3):
            v_t[r] = v_r[r] - along * n[r]
        slip = np.sqrt(v_t[0] * v_t[0] + v_t[1] * v_t[1] + v_t[2] * v_t[2] + v_s * v_s)
        for r in range(3):
            f[r] = f_n * n[r] - mu * f_n * v_t[r] / slip
            u[r] = n[r] - mu * v_t[r] / slip
        note(touch, pair, delta, np.sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]))
        # tau += J^T f
        for j in range(nv):
            tau[j] += J[0, j] * f[0] + J[1, j] * f[1] + J[2, j] * f[2]
        keep_force(force, k, f)
        if jac:
            at = (qd, law[pair], v_r, v_t, f, u, c_s, slip, f_n)
            sphere_tangent(sources[0], (body_tree, work, room), k, at, K, D)
            pair_tangent(sources[1], (body_tree, work, room, J), k, at, K, D)
    return spring


@njit(**UNCOUNTED)
def sphere_tangent(spheres, where, k, at, K, D):
    """K, D (nv, nv) -= the exact derivatives of contact k's generalized force, a sphere of
    the Spheres on the ground (opendyn.algorithm.contact_tangent); nothing for spheres None.
    where = (body_tree, work, room) as compliant_forces has them; at = (qd, the law row (4,),
    v_r, v_t, f, u (3,) each as compliant_forces left them, c (3,) scratch, s the slip,
    f_n)."""
    if spheres is None:
        return
    body_tree, work, room = where
    qd, law, v_r, _, f, _, c_s, _, _ = at
    found = room.found
    # the sphere's centre c = x + r e_z, which its lowest point x moves with
    for r in range(3):
        c_s[r] = found.point[k, r]
    c_s[2] += spheres.radius[found.pair[k]]
    add_sphere_tangent(
        body_tree, work, found.bodies[k, 1], (found.point[k], c_s), law, qd, (v_r, f), K, D
    )


@njit(**UNCOUNTED)
def pair_tangent(geometry, where, k, at, K, D):
    """K, D (nv, nv) -= the derivatives of contact k's generalized force with its point and
    normal held, a contact of the Geometries' pairs (opendyn.algorithm.contact_tangent);
    nothing for geometry None. where = (body_tree, work, room, J (3, nv) the contact's
    Jacobian); at as sphere_tangent's."""
    if geometry is None:
        return
    _, _, room, J = where
    _, law, _, v_t, _, u, _, slip, f_n = at
    n, v_s, AJ = room.found.frame[k, 2], law[SLIP], room.pairs.AJ
    # K += J^T (k u n^T) J;  D += J^T (c u n^T + mu f_n F) J
    add_sandwich(J, AJ, law[STIFFNESS], u, n, (0.0, slip, v_s), v_t, K)
    add_sandwich(J, AJ, law[DAMPING], u, n, (law[FRICTION] * f_n, slip, v_s), v_t, D)


@njit(**JIT)
def compliant_contact(model, room, sources, law, qd, out, touch, force):
    """The compliant contact of one evaluation: the list of room (a ContactRoom) <- the
    contacts of sources = (spheres, geometry) that overlap or touch (margin 0;
    find_contacts), then compliant_forces over them (law, out, touch and force as there).
    model = (ibuf, fbuf, work), work holding the bodies' world poses (forward kinematics
    placed at a valid q). Returns the springs' power as compliant_forces."""
    ibuf, fbuf, work = model
    nb, nv = body_count(ibuf), qd.shape[0]
    posed = world_poses(work, nb)
    parts = room_parts(room)
    find_contacts(posed, sources, 0.0, parts)
    J = effect_rows(work, nb, nv)
    views = (work, posed, J, scratch_rows(work, nb, nv))
    return compliant_forces(tree(ibuf, fbuf), views, parts, sources, law, qd, out, touch, force)


@njit(**BATCH)
def contact_record_kernel(ibuf, fbuf, sources, law, states, out, start, stop):
    """The compliant contact at the recorded states = (q (N, nq), qd (N, nv)), rows [start,
    stop), of sources = (spheres, geometry), one of them None, with its law (P, 4): for
    spheres, out = (x_c, f_c
    (N, P, 3), delta (N, P)) <- every sphere's lowest point (m), force (N) and penetration
    (m), world frame; for geometries, out = (counts (N,) int64, offsets (N,) int64, rows (R,
    ROW)) <- how many points overlap at each state, written into rows[offsets[n]:] up to the
    room the last counts left there (keep_pairs)."""
    q, qd = states
    nb, nv = body_count(ibuf), dof_count(ibuf)
    work = new_work(nb, nv)
    room = contact_room(sources[0], sources[1], nv)
    found = room_parts(room).found  # the list compliant_contact fills, viewed
    force = np.zeros((found.pair.shape[0], 3))
    tau = np.empty(nv)
    unused = np.empty((0, 0))
    no_jac = np.bool_(False)  # a run-time flag, as the step passes it: one compiled kernel
    for n in range(start, stop):
        forward_kinematics(ibuf, fbuf, work, q[n])
        compliant_contact(
            (ibuf, fbuf, work), room, sources, law, qd[n], (tau, (unused, unused, no_jac)), None,
            force,
        )
        keep_spheres(sources[0], world_poses(work, nb), (found, force), out, n)
        keep_pairs(sources[1], (found, force), out, n)


@njit(**JIT)
def keep_spheres(spheres, posed, contacts, out, n):
    """out = (x_c, f_c, delta)'s state n <- each sphere's lowest point, force and penetration
    max(0, h - x_z), posed = (R_s, p_s) the bodies' world poses, contacts = (found, force) the
    list and its forces. Nothing for spheres None."""
    if spheres is None:
        return
    x_c, f_c, delta = out
    found, force = contacts
    for p in range(spheres.body.shape[0]):
        lowest_point(posed, spheres, p, x_c[n, p])
        delta[n, p] = max(0.0, spheres.ground[0] - x_c[n, p, 2])
    fill(f_c[n], 0.0)
    for k in range(found.count[0]):
        f_c[n, found.pair[k]] = force[k]


@njit(**JIT)
def keep_pairs(geometry, contacts, out, n):
    """out = (counts, offsets, rows): counts[n] <- how many contacts of contacts = (found,
    force) overlap, each written as a row (pair, x, n, f, delta) of rows from offsets[n] while
    there is room (run once with empty rows to count, then with rows of sum(counts) at offsets,
    the counts' running sums, to fill). Nothing for geometry None."""
    if geometry is None:
        return
    counts, offsets, rows = out
    found, force = contacts
    kept = 0
    for k in range(found.count[0]):
        if found.depth[k] >= 0.0:
            continue
        at = offsets[n] + kept
        kept += 1
        if kept > counts[n]:  # counting: no room
            continue
        rows[at, PAIR] = found.pair[k]
        for r in range(3):
            rows[at, POINT + r] = found.point[k, r]
            rows[at, NORMAL_AT + r] = found.frame[k, 2, r]
            rows[at, FORCE + r] = force[k, r]
        rows[at, DEPTH] = -found.depth[k]
    counts[n] = kept


@njit(**JIT)
def contact_jacobians_kernel(ibuf, fbuf, spheres, q, J):
    """J (P, 3, nv) <- each contact sphere's J_p at q, at its lowest point (Spheres)."""
    body_tree = tree(ibuf, fbuf)
    nb = body_count(ibuf)
    work = new_work(nb, dof_count(ibuf))  # the world poses R_s, p_s
    forward_kinematics(ibuf, fbuf, work, q)
    R_s, p_s = world_poses(work, nb)
    x_s = np.empty(3)
    S = np.empty(6)  # a joint axis in {s}
    for p in range(spheres.body.shape[0]):
        b = lowest_point((R_s, p_s), spheres, p, x_s)
        J[p][:] = 0.0
        add_point_jacobian(body_tree, R_s, p_s, b, x_s, 1.0, J[p], S)
