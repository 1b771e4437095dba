"""Ground contact: compliant spheres on the plane z = h, as generalized forces tau = J_c^T f.

For each contact point p (a sphere of radius r whose centre c_p is welded to a body), at the
sphere's lowest point x_p = c_p - r e_z, world frame {s}:

    delta   = max(0, h - x_z)                                   penetration (m)
    v_p     = J_p(q) v,   J_p (3, nv): the point's linear velocity in {s},
              column k = v_k + w_k x x_p for the space-frame joint axis (w_k, v_k) of column k
    f_n     = max(0, k delta + d delta_dot),  delta_dot = -v_z   (no pull: clamped at zero)
    f_t     = -mu f_n v_t / sqrt(|v_t|^2 + v_s^2),  v_t = (v_x, v_y)   (regularised Coulomb)
    tau    += J_p^T f,  f = (f_t, f_n): the force the ground applies to the robot at x_p

(k stiffness N/m, d damping N s/m, mu the Coulomb coefficient, v_s the slip velocity m/s).
A point not touching the ground (delta = 0) costs its position only. The model omits rolling
resistance, torsional friction, contact between links, and any ground but the plane.

Energy: the spring part k delta is conservative, with U_p = 1/2 k delta^2; the rest does the work
P_nc = f . v_p + k delta delta_dot (the normal damper's -d delta_dot^2 and friction's
f_t . v_t <= 0 while f_n > 0; k delta delta_dot < 0, the spring energy let go, while the clamp
holds f_n at zero). The kernel returns sum_p k delta_p delta_dot_p, which the step adds to the
passive power.

For an implicit integrator, K -= dtau/dq and D -= dtau/dqd exactly, while f_n > 0 (q in the
tangent space; add_contact_tangent, the same derivatives as the effect's numpy `tangent` that
linearize uses). With S_j the space axes of the joints from the point's body b to the root,
J_j(y) = v_j + w_j x y, the sphere's centre c (x = c - r e_z moves with it), W_j the twist of
b relative to the body j hangs from and w_b b's angular velocity:

    dx/dq_j   = J_j(c),   dv_p/dq_j = (S_j x W_j) at x + w_b x J_j(c),   dv_p/dqd_j = J_j(x)
    df_n      = k d(delta) - d dv_z,   d(delta) = -dx_z
    df_t      = -mu (df_n v_t / s + f_n (dv_t / s - v_t (v_t . dv_t) / s^3))
    dtau_i/dq_j  = [j at or above i] S_i . ad_{S_j}^T F_s + S_i . dF_s/dq_j,
                   F_s = (x x f, f),  dF_s/dq_j = (J_j(c) x f + x x df/dq_j, df/dq_j)
    dtau_i/dqd_j = J_i(x) . df/dqd_j

Near zero slip the friction is a stiff damper mu f_n / v_s. The friction turning with f_n and
the geometric terms make K and D non-symmetric: the implicit step solves with LU. Left out, the
step was 2-14 times less accurate on the Solo12 drop at 0.5-5 ms (docs/study).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .._runtime.arrays import fill, zero_matrix
from .._runtime.kernel_cache import BATCH, INLINE, JIT
from ..multibody.layout import body_count, dof_count, tree
from ..multibody.work_views import contact_axes, effect_rows, new_work, scratch_rows, world_poses
from .contact_extremes import note
from .kinematics import add_point_jacobian, forward_kinematics, space_axis

# the contact parameters' layout: the shared values, then (c_b (3,), r) per point
GROUND, STIFFNESS, DAMPING, FRICTION, SLIP = range(5)
SHARED = 5
PER_POINT = 4


@njit(**JIT)
def lowest_point(R_s, p_s, bodies, params, p, x_s):
    """x_s (3,) <- p_sb + R_sb c_b - r e_z, the lowest point of contact sphere p (centre c_b in
    its body b's frame, radius r, from params) in {s}. Returns b."""
    b = bodies[p]
    at = SHARED + PER_POINT * p
    for r in range(3):
        x_s[r] = (
            p_s[b, r]
            + R_s[b, r, 0] * params[at]
            + R_s[b, r, 1] * params[at + 1]
            + R_s[b, r, 2] * params[at + 2]
        )
    x_s[2] -= params[at + 3]
    return b


@njit(**INLINE)
def cross(a, b, out):
    """out (3,) <- a x b."""
    out[0] = a[1] * b[2] - a[2] * b[1]
    out[1] = a[2] * b[0] - a[0] * b[2]
    out[2] = a[0] * b[1] - a[1] * b[0]


@njit(**JIT)
def force_change(params, v_p, f_p, ddelta, dv, df):
    """df (3,) <- the change of the point's force f_p = (f_t, f_n) for a change ddelta of the
    penetration and dv (3,) of the point's velocity v_p, while f_n > 0:
        df_n = k ddelta - d dv_z,
        df_t = -mu (df_n v_t / s + f_n (dv_t / s - v_t (v_t . dv_t) / s^3))."""
    k, d = params[STIFFNESS], params[DAMPING]
    mu, v_s = params[FRICTION], params[SLIP]
    s = np.sqrt(v_p[0] * v_p[0] + v_p[1] * v_p[1] + v_s * v_s)
    df[2] = k * ddelta - d * dv[2]
    along = v_p[0] * dv[0] + v_p[1] * dv[1]
    for r in range(2):
        df[r] = -mu * (df[2] * v_p[r] / s + f_p[2] * (dv[r] / s - v_p[r] * along / (s * s * s)))


@njit(**JIT)
def add_contact_tangent(body_tree, work, b, at, params, qd, point, K, D):
    """K (nv, nv) -= dtau_p/dq, D (nv, nv) -= dtau_p/dqd: the exact derivatives of one contact
    point's generalized force tau_p = J_p^T f_p (module docstring), q in the tangent space,
    for a point of body b touching the ground with f_n > 0; at = (x (3,), c (3,)) the sphere's
    lowest point and centre in {s}, point = (v_p (3,), f_p (3,)) the velocity of the body's
    material at x and the ground's force there. Works in `work`, allocating nothing: it reads
    the world poses R_s, p_s of every body and writes the contact axes' rows (ContactAxes, row
    j for each velocity coordinate j from b up to the root) and scratch rows 0 and 5-8 (rows
    1-4 hold at and point: contact_on_poses)."""
    nb, nv = body_tree.parent.shape[0], qd.shape[0]
    parent, nv_j, iv = body_tree.parent, body_tree.nv_j, body_tree.iv
    R_s, p_s = world_poses(work, nb)
    S, moved, dF_dq, J_x, df_dqd = contact_axes(work, nb, nv)
    s = scratch_rows(work, nb, nv)
    J_c, df_dq = s[0, :3], s[0, 3:]
    twist, W = s[5], s[6]
    u, w_jW, dv, m_s = s[7, :3], s[7, 3:], s[8, :3], s[8, 3:]
    x, c = at
    v_p, f_p = point
    # the axes from b up to the root: S_j in {s} (times the mimic multipliers), in the row of
    # their velocity coordinate j; twist = sum_j qd_j S_j, b's twist (w_b its angular part)
    fill(twist, 0.0)
    i = b
    while i >= 0:
        for k in range(nv_j[i]):
            j = iv[i] + k
            space_axis(R_s[i], p_s[i], body_tree.S[i, k], S[j])
            for r in range(6):
                S[j, r] *= body_tree.mult[i]
                twist[r] += qd[j] * S[j, r]
        i = parent[i]
    # per axis j, W = sum of qd_i S_i over the axes at or below j's body (the twist of b
    # relative to the body j's joint hangs from): J_j(x), J_j(c) = v_j + w_j x y (x moves as c
    # does: dx/dq_j = J_j(c)); dv_p/dq_j = (S_j x W) at x + w_b x J_j(c); the force's changes
    # df/dq_j, df/dqd_j; dF_s/dq_j = (J_j(c) x f + x x df/dq_j, df/dq_j) of F_s = (x x f, f);
    # ad_{S_j}^T F_s
    cross(x, f_p, m_s)
    fill(W, 0.0)
    i = b
    while i >= 0:
        for k in range(nv_j[i]):
            j = iv[i] + k
            for r in range(6):
                W[r] += qd[j] * S[j, r]
        for k in range(nv_j[i]):
            j = iv[i] + k
            w_j, v_j = S[j, :3], S[j, 3:]
            cross(w_j, x, u)
            for r in range(3):
                J_x[j, r] = v_j[r] + u[r]
            cross(w_j, c, u)
            for r in range(3):
                J_c[r] = v_j[r] + u[r]
            # S_j x W = (w_j x w_W, v_j x w_W + w_j x v_W), taken at x: its v + w x x
            cross(v_j, W[:3], dv)
            cross(w_j, W[3:], u)
            dv += u
            cross(w_j, W[:3], w_jW)  # the bracket's angular part
            cross(w_jW, x, u)
            dv += u
            cross(twist[:3], J_c, u)
            dv += u
            force_change(params, v_p, f_p, -J_c[2], dv, df_dq)
            force_change(params, v_p, f_p, 0.0, J_x[j], df_dqd[j])
            cross(J_c, f_p, u)
            cross(x, df_dq, dv)
            for r in range(3):
                dF_dq[j, r] = u[r] + dv[r]
                dF_dq[j, 3 + r] = df_dq[r]
            # ad_{S_j}^T F_s = -(w_j x m + v_j x f, w_j x f)
            cross(w_j, m_s, u)
            cross(v_j, f_p, dv)
            for r in range(3):
                moved[j, r] = -(u[r] + dv[r])
            cross(w_j, f_p, u)
            for r in range(3):
                moved[j, 3 + r] = -u[r]
        i = parent[i]
    # dtau_a/dq_j = [j at or above a] S_a . ad_{S_j}^T F_s + S_a . dF_s/dq_j,
    # dtau_a/dqd_j = J_a(x) . df/dqd_j, for the axes a, j of the path
    i_a = b
    while i_a >= 0:
        for k_a in range(nv_j[i_a]):
            a = iv[i_a] + k_a
            above = False  # the inner walk has reached a's body
            i_j = b
            while i_j >= 0:
                above = above or i_j == i_a
                for k_j in range(nv_j[i_j]):
                    j = iv[i_j] + k_j
                    dq = 0.0
                    for r in range(6):
                        dq += S[a, r] * dF_dq[j, r]
                        if above:
                            dq += S[a, r] * moved[j, r]
                    dqd = (
                        J_x[a, 0] * df_dqd[j, 0]
                        + J_x[a, 1] * df_dqd[j, 1]
                        + J_x[a, 2] * df_dqd[j, 2]
                    )
                    K[a, j] -= dq
                    D[a, j] -= dqd
                i_j = parent[i_j]
        i_a = parent[i_a]


@njit(**INLINE)
def contact_kernel(ibuf, fbuf, work, contacts, q, qd, tau, linear, record):
    """The contact forces at (q, qd): tau (nv,) += sum_p J_p^T f_p; record = (x_c (P, 3),
    f_c (P, 3), delta (P,)) <- the points' lowest points x_p (m, {s}), their forces f_p
    (N, {s}) and their penetrations (m), or record None: nothing kept (the step's call).
    linear = (K, D, jac): with jac, K, D (nv, nv) += the contacts' stiffness and damping
    (module docstring). contacts = (bodies (P,) int64: each point's body; params: SHARED
    values (ground height, k, d, mu, v_s), then (c_b (3,) m in the body's frame, r m) per
    point). q must be a valid configuration. Works in `work` (a Data's buffer: the world poses
    R_s, p_s of every body, its scratch rows and effect rows), allocating nothing. Returns
    sum_p k delta_p delta_dot_p (W), the spring's share of the power. Written out where it is
    called (the record's kernel): the step calls contact_on_poses, on the poses it placed."""
    forward_kinematics(ibuf, fbuf, work, q)
    return contact_on_poses(ibuf, fbuf, work, contacts, qd, tau, linear, record, None)


@njit(**JIT)
def point_rows(record, p, x_s, f_s):
    """(x, f) (3,) each: where contact point p's lowest point and force go, the record's rows
    p, or x_s, f_s (scratch) when record is None (numba drops the other branch)."""
    if record is None:
        return x_s, f_s
    return record[0][p], record[1][p]


@njit(**JIT)
def keep_penetration(record, p, delta):
    """record's delta[p] <- delta (m); nothing when record is None."""
    if record is None:
        return
    record[2][p] = delta


@njit(**JIT)
def contact_on_poses(ibuf, fbuf, work, contacts, qd, tau, linear, record, touch):
    """contact_kernel on the world poses R_s, p_s of every body that `work` holds
    (forward_kinematics at a valid q); touch: None, or the run's extremes, to which each point
    that overlaps is noted as pair p (opendyn.algorithm.contact_extremes.note). Returns the
    springs' power as contact_kernel's."""
    bodies, params = contacts
    K, D, jac = linear
    body_tree = tree(ibuf, fbuf)
    nb = body_count(ibuf)
    nv = qd.shape[0]
    R_s, p_s = world_poses(work, nb)
    h, k, d = params[GROUND], params[STIFFNESS], params[DAMPING]
    mu, v_s = params[FRICTION], params[SLIP]
    J_p = effect_rows(work, nb, nv)  # (3, nv)
    s = scratch_rows(work, nb, nv)
    S = s[0]  # a joint axis in {s}
    v_p, c_s, x_s, f_s = s[1, :3], s[2, :3], s[3, :3], s[4, :3]
    spring = 0.0
    for p in range(bodies.shape[0]):
        # x_p = p_sb + R_sb c_b - r e_z; delta = max(0, h - x_z)
        x_p, f_p = point_rows(record, p, x_s, f_s)
        b = lowest_point(R_s, p_s, bodies, params, p, x_p)
        f_p[:] = 0.0
        delta = max(0.0, h - x_p[2])
        keep_penetration(record, p, delta)
        if delta == 0.0:
            continue
        # v_p = J_p v
        zero_matrix(J_p)
        add_point_jacobian(body_tree, R_s, p_s, b, x_p, 1.0, J_p, S)
        for r in range(3):
            v_p[r] = 0.0
            for j in range(nv):
                v_p[r] += J_p[r, j] * qd[j]
        delta_dot = -v_p[2]
        spring += k * delta * delta_dot
        # f_n = max(0, k delta + d delta_dot); f_t = -mu f_n v_t / s
        f_n = k * delta + d * delta_dot
        if f_n <= 0.0:
            note(touch, p, delta, 0.0)
            continue
        slip = np.sqrt(v_p[0] * v_p[0] + v_p[1] * v_p[1] + v_s * v_s)
        f_p[0] = -mu * f_n * v_p[0] / slip
        f_p[1] = -mu * f_n * v_p[1] / slip
        f_p[2] = f_n
        note(touch, p, delta, np.sqrt(f_p[0] * f_p[0] + f_p[1] * f_p[1] + f_n * f_n))
        # tau += J_p^T f_p
        for j in range(nv):
            tau[j] += J_p[0, j] * f_p[0] + J_p[1, j] * f_p[1] + J_p[2, j] * f_p[2]
        if jac:
            c_s[:] = x_p
            c_s[2] += params[SHARED + PER_POINT * p + 3]  # the centre, r above
            add_contact_tangent(body_tree, work, b, (x_p, c_s), params, qd, (v_p, f_p), K, D)
    return spring


@njit(**BATCH)
def contact_record_kernel(ibuf, fbuf, contacts, states, record, start, stop):
    """The contact points, forces and penetrations record = (x_c, f_c (N, P, 3), delta (N, P))
    at the recorded states = (q (N, nq), qd (N, nv)), rows [start, stop)."""
    q, qd = states
    x_c, f_c, delta = record
    tau = np.empty(qd.shape[1])
    unused = np.empty((0, 0))
    no_jac = np.bool_(False)  # a run-time flag, as the step passes it: one compiled kernel
    work = new_work(body_count(ibuf), dof_count(ibuf))
    for n in range(start, stop):
        contact_kernel(
            ibuf, fbuf, work, contacts, q[n], qd[n], tau, (unused, unused, no_jac),
            (x_c[n], f_c[n], delta[n]),
        )


@njit(**JIT)
def contact_jacobians_kernel(ibuf, fbuf, contacts, q, J):
    """J (P, 3, nv) <- each contact point's J_p at q (the lowest point of its sphere);
    contacts = (bodies, params) as contact_kernel's."""
    bodies, params = contacts
    body_tree = tree(ibuf, fbuf)
    nb = body_count(ibuf)
    work = new_work(nb, dof_count(ibuf))  # the world poses R_s, p_s
    forward_kinematics(ibuf, fbuf, work, q)
    R_s, p_s = world_poses(work, nb)
    x_s = np.empty(3)
    S = np.empty(6)  # a joint axis in {s}
    for p in range(bodies.shape[0]):
        b = lowest_point(R_s, p_s, bodies, params, p, x_s)
        zero_matrix(J[p])
        add_point_jacobian(body_tree, R_s, p_s, b, x_s, 1.0, J[p], S)
