"""Contact between collision geometries: the compliant law of opendyn.algorithm.contact at every
contact point of every pair that touches, as equal and opposite forces on the two bodies.

For each pair (a, b) of geometries the narrow phase (opendyn.algorithm.collision) gives up to
four contacts, each with its points p_A, p_B in {s}, the unit normal n from a towards b and the
signed distance d, p_B - p_A = d n. At the midpoint x = (p_A + p_B) / 2:

    delta     = -d                          penetration (m); only delta > 0 pushes
    J         = J_b(x) - J_a(x)             (3, nv): the velocity of b's material at x relative
                                            to a's per unit of v (J_world = 0)
    v_r       = J v,  delta_dot = -n . v_r
    f_n       = max(0, k delta + c delta_dot)
    v_t       = v_r - (n . v_r) n,  s = sqrt(|v_t|^2 + v_s^2)
    f         = f_n n - mu f_n v_t / s      the force a applies to b at x; b applies -f to a
    tau      += J^T f

(k stiffness N/m, c damping N s/m, mu the Coulomb coefficient, v_s the slip velocity m/s, each
the pair's). The forces add up: whatever a pair pushes into b it takes out of a, so momentum
moves between bodies and to the world only through a pair with the world.

Energy: as the ground's spheres, the spring k delta is conservative with U = 1/2 k delta^2 per
contact point; the kernel returns sum k delta delta_dot, which the step adds to the passive
power, so that the dampers and friction are what the balance shows as passive work.

Linearisation for an implicit step (K = -dtau/dq, D = -dtau/dqd), the contact points and the
normal held where they are (their motion along the shapes and the normal's turning are left
out; the accuracy study measures what that costs):

    df/d(delta) = k u,  u = n - mu v_t / s,           d(delta)/dq = -n^T J
    df/dv_r     = -c u n^T - mu f_n F,                P_t = 1 - n n^T
    F           = P_t / s - (1 - w) v_t v_t^T / s^3,  w = v_s / s
    K += J^T (k u n^T) J,     D += J^T (c u n^T + mu f_n F) J

F is the friction's tangent (w = 0) with part of its secant (w = 1, the viscous coefficient
P_t / s) along the slip. Across the slip both are 1 / s. Along it the tangent's slope,
v_s^2 / s^3, is next to nothing once |v_t| >> v_s: a linearly implicit step takes the friction
as explicit there, and where a step's friction impulse exceeds what stops the slip the velocity
overshoots zero and flips sign every step, for ever (a box spinning on the ground at 1 ms went
on flipping at 0.05 rad/s, gaining energy in the balance). The secant alone stops that, but it
takes the friction at the step's end velocity, slowing a steady slide by a dt / v (a box on a
20 degree ramp slid 0.24% slow at 1 ms). The slope along the slip with weight w,
v_s / s^2 + (1 - w) v_s^2 / s^3, is the secant's at rest (w = 1) and the tangent's where the
slip is fast: a slip that one step's impulse A = dt mu f_n / m would reverse is cut to
v - A / (1 + A v_s / v^2), short of zero or within v_s of it, where the tangent itself is
stiff, so it comes to rest; a steady slide keeps its Coulomb deceleration to (v_s / v) a dt / v.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit

from .._runtime.kernel_cache import BATCH, JIT
from ..multibody.layout import body_count, dof_count, tree
from ..multibody.work_views import effect_rows, new_work, scratch_rows, world_poses
from .collision import DISTANCE, MAX_CONTACTS, NORMAL, OUT_SIZE, POINT_A, POINT_B
from .collision.narrow_phase import COLUMNS, ROWS
from .collision.queries import pair_rows
from .collision.world import bounding_boxes, pair_near, place_geometries
from .contact_extremes import note
from .kinematics import add_point_jacobian, forward_kinematics

# a pair's law, one row of `law` (P, 4)
STIFFNESS, DAMPING, FRICTION, SLIP = range(4)

# The arrays the contact pass works in, made once per run (geometry_room): the geometries'
# world poses T_sg (G, 3, 4), each hull's climbing start hints (G,) int, their bounding boxes
# (G, 6), the narrow phase's scratch, one pair's contact rows (MAX_CONTACTS, OUT_SIZE), and
# rows (3, nv) for A J of the linearisation.
GeometryRoom = namedtuple("GeometryRoom", ("T_sg", "hints", "boxes", "scratch", "rows", "AJ"))


def geometry_room(count, nv) -> GeometryRoom:
    """The GeometryRoom of `count` geometries on a model of nv velocity coordinates."""
    return GeometryRoom(
        np.zeros((count, 3, 4)),
        np.zeros(count, dtype=np.int64),
        np.zeros((count, 6)),
        np.zeros((ROWS, COLUMNS)),
        np.zeros((MAX_CONTACTS, OUT_SIZE)),
        np.zeros((3, nv)),
    )


@njit(**JIT)
def contact_force(body_tree, posed, bodies, row, law, qd, tau, linear, scratch):
    """The law (module docstring) at one contact row (OUT_SIZE,) of bodies = (a, b) (-1 the
    world), its pair's law (4,): tau (nv,) += J^T f; with linear = (K, D, jac) and jac, K and
    D (nv, nv) += its linearisation. posed = (R_s, p_s) the bodies' world poses; scratch =
    (J, AJ (3, nv), s (9, 6)), s left holding x (s[1, :3]), n (s[1, 3:]) and f (s[3, :3],
    zero where the clamp holds f_n at zero). Returns (k delta delta_dot (W), delta (m))."""
    R_s, p_s = posed
    K, D, jac = linear
    J, AJ, s = scratch
    nv = qd.shape[0]
    x, n, S = s[1, :3], s[1, 3:], s[0]
    v_r, v_t, f, u = s[2, :3], s[2, 3:], s[3, :3], s[3, 3:]
    f[:] = 0.0
    for r in range(3):
        x[r] = 0.5 * (row[POINT_A + r] + row[POINT_B + r])
        n[r] = row[NORMAL + r]
    delta = -row[DISTANCE]
    if delta <= 0.0:
        return 0.0, delta
    J[:] = 0.0
    a, b = bodies
    if b >= 0:
        add_point_jacobian(body_tree, R_s, p_s, b, x, 1.0, J, S)
    if a >= 0:
        add_point_jacobian(body_tree, R_s, p_s, a, x, -1.0, J, S)
    for r in range(3):
        v_r[r] = 0.0
        for j in range(nv):
            v_r[r] += J[r, j] * qd[j]
    along = n[0] * v_r[0] + n[1] * v_r[1] + n[2] * v_r[2]
    k, c, mu, v_s = law[STIFFNESS], law[DAMPING], law[FRICTION], law[SLIP]
    delta_dot = -along
    spring = k * delta * delta_dot
    f_n = k * delta + c * delta_dot
    if f_n <= 0.0:
        return spring, delta
    for r in range(3):
        v_t[r] = v_r[r] - along * n[r]
    slip = np.sqrt(v_t[0] * v_t[0] + v_t[1] * v_t[1] + v_t[2] * v_t[2] + v_s * v_s)
    for r in range(3):
        f[r] = f_n * n[r] - mu * f_n * v_t[r] / slip
        u[r] = n[r] - mu * v_t[r] / slip
    for j in range(nv):
        tau[j] += J[0, j] * f[0] + J[1, j] * f[1] + J[2, j] * f[2]
    if jac:
        # K += J^T (k u n^T) J
        add_sandwich(J, AJ, k, u, n, (0.0, slip, v_s), v_t, K)
        # D += J^T (c u n^T + mu f_n F) J
        add_sandwich(J, AJ, c, u, n, (mu * f_n, slip, v_s), v_t, D)
    return spring, delta


@njit(**JIT)
def add_sandwich(J, AJ, gain, u, n, friction, v_t, out):
    """out (nv, nv) += J^T A J with A = gain u n^T + slide F (the module docstring's F:
    P_t / s - (1 - w) v_t v_t^T / s^3, P_t = 1 - n n^T, w = v_s / s); friction = (slide,
    s the slip, v_s), v_t (3,) the tangential velocity; AJ (3, nv) scratch."""
    slide, slip, v_s = friction
    nv = J.shape[1]
    along = (1.0 - v_s / slip) / (slip * slip * slip)
    for r in range(3):
        for j in range(nv):
            AJ[r, j] = 0.0
        for m in range(3):
            A = gain * u[r] * n[m]
            if slide != 0.0:
                P = (1.0 if r == m else 0.0) - n[r] * n[m]
                A += slide * (P / slip - along * v_t[r] * v_t[m])
            if A != 0.0:
                for j in range(nv):
                    AJ[r, j] += A * J[m, j]
    for i in range(nv):
        for j in range(nv):
            out[i, j] += J[0, i] * AJ[0, j] + J[1, i] * AJ[1, j] + J[2, i] * AJ[2, j]


@njit(**JIT)
def geometry_contact_on_poses(ibuf, fbuf, work, contacts, room, qd, tau, linear, record, touch):
    """tau (nv,) += the contact forces of every pair that touches, on the world poses R_s, p_s
    of every body that `work` holds (a Data's buffer, forward kinematics placed at a valid q);
    with linear = (K, D, jac) and jac, K, D (nv, nv) += their linearisation. contacts =
    (table: the GeometryTable's arrays in its order, pairs (P, 2) int, law (P, 4): k, c, mu,
    v_s of each pair); room: a GeometryRoom. record: None, or (rows (R, ROW), count (1,) int):
    each contact point that overlaps is counted, and written while count < R (keep_contact).
    touch: None, or the run's extremes, to which each contact point that overlaps is noted
    with its pair (opendyn.algorithm.contact_extremes.note). Allocates nothing. Returns
    sum k delta delta_dot (W), the springs' share of the power."""
    table, pairs, law = contacts
    T_sg, hints, boxes, scratch, rows, AJ = room
    body_tree = tree(ibuf, fbuf)
    nb, nv = body_count(ibuf), qd.shape[0]
    R_s, p_s = world_poses(work, nb)
    place_geometries(R_s, p_s, table, T_sg)
    bounding_boxes(table, hints, T_sg, boxes)
    J = effect_rows(work, nb, nv)
    s = scratch_rows(work, nb, nv)
    body = table[0]
    spring = 0.0
    for p in range(pairs.shape[0]):
        i, j = pairs[p, 0], pairs[p, 1]
        if not pair_near(table[2], T_sg, boxes, i, j, 0.0):
            continue
        found, _ = pair_rows((table, hints, T_sg), i, j, 0.0, rows, scratch)
        for c in range(found):
            power, delta = contact_force(
                body_tree, (R_s, p_s), (body[i], body[j]), rows[c], law[p], qd, tau, linear,
                (J, AJ, s),
            )
            spring += power
            if delta > 0.0:
                keep_contact(record, p, s, delta)
                f = s[3, :3]  # |f|, the force contact_force left there
                note(touch, p, delta, np.sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]))
    return spring


# a row of the contact record: the pair's index, the point x (3) m, the normal n (3) from a to
# b, the force f (3) N that a applies to b, all in {s}, and the depth delta m
PAIR, POINT, NORMAL_AT, FORCE, DEPTH = 0, 1, 4, 7, 10
ROW = 11


@njit(**JIT)
def keep_contact(record, p, s, delta):
    """record = (rows, count): rows[count] <- (p, x, n, f, delta) of the contact that
    contact_force left in s, while count < len(rows); count += 1. Nothing for None."""
    if record is None:
        return
    rows, count = record
    k = count[0]
    count[0] = k + 1
    if k >= rows.shape[0]:
        return
    rows[k, PAIR] = p
    for r in range(3):
        rows[k, POINT + r] = s[1, r]
        rows[k, NORMAL_AT + r] = s[1, 3 + r]
        rows[k, FORCE + r] = s[3, r]
    rows[k, DEPTH] = delta


@njit(**BATCH)
def geometry_contact_record_kernel(ibuf, fbuf, contacts, states, out, start, stop):
    """The contact points of the recorded states = (q (N, nq), qd (N, nv)), rows [start,
    stop): out = (counts (N,) int64, offsets (N,) int64, rows (R, ROW)): counts[n] <- how many
    points overlap at state n, written (keep_contact) into rows[offsets[n]:] up to the room
    the last counts left there (run it once with empty rows to count, then with rows of
    sum(counts) at offsets, the counts' running sums, to fill)."""
    q, qd = states
    counts, offsets, rows = out
    nb, nv = body_count(ibuf), dof_count(ibuf)
    work = new_work(nb, nv)
    count = contacts[0][0].shape[0]
    room = GeometryRoom(
        np.zeros((count, 3, 4)), np.zeros(count, dtype=np.int64), np.zeros((count, 6)),
        np.zeros((ROWS, COLUMNS)), np.zeros((MAX_CONTACTS, OUT_SIZE)), np.zeros((3, nv)),
    )
    tau = np.empty(nv)
    unused = np.empty((0, 0))
    no_jac = np.bool_(False)
    found = np.zeros(1, dtype=np.int64)
    for n in range(start, stop):
        found[0] = 0
        mine = rows[offsets[n] : offsets[n] + counts[n]]
        forward_kinematics(ibuf, fbuf, work, q[n])
        geometry_contact_on_poses(
            ibuf, fbuf, work, contacts, room, qd[n], tau, (unused, unused, no_jac),
            (mine, found), None,
        )
        counts[n] = found[0]
