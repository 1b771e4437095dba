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

For an implicit integrator the linearisation, mapped to joint space (full matrices):

    K += J_p^T K_p J_p,  K_p = k e_z e_z^T                 (stiffness -dtau/dq)
    D += J_p^T D_p J_p,  D_p = d e_z e_z^T + mu f_n (I_2 / s - v_t v_t^T / s^3) on (x, y)
                         s = sqrt(|v_t|^2 + v_s^2)           (damping -dtau/dv)

while f_n > 0; near zero slip the friction term is a stiff damper mu f_n / v_s. The slopes of
f_t with respect to delta and delta_dot (through f_n) are left out, which keeps K and D
symmetric positive semi-definite.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .._runtime.arrays import zero_matrix
from .._runtime.kernel_cache import BATCH, INLINE, JIT
from ..multibody.data import new_work, world_poses
from ..multibody.layout import body_count, dof_count, tree
from .kinematics import add_point_jacobian, forward_kinematics

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


@njit(**JIT)
def add_congruence(J_p, C, out):
    """out (nv, nv) += J_p^T C J_p with J_p (3, nv), C (3, 3)."""
    nv = J_p.shape[1]
    CJ = np.zeros((3, nv))
    for r in range(3):
        for c in range(3):
            if C[r, c] != 0.0:
                for j in range(nv):
                    CJ[r, j] += C[r, c] * J_p[c, j]
    for r in range(3):
        for a in range(nv):
            if J_p[r, a] != 0.0:
                for b in range(nv):
                    out[a, b] += J_p[r, a] * CJ[r, b]


@njit(**INLINE)
def contact_kernel(ibuf, fbuf, work, contacts, q, qd, tau, linear, record):
    """The contact forces at (q, qd): tau (nv,) += sum_p J_p^T f_p; record = (x_c (P, 3),
    f_c (P, 3), delta (P,)) <- the points' lowest points x_p (m, {s}), their forces f_p
    (N, {s}) and their penetrations (m). linear = (K, D, jac): with jac, K, D (nv, nv) += the
    contacts' stiffness and damping (module docstring). contacts = (bodies (P,) int64: each
    point's body; params: SHARED values (ground height, k, d, mu, v_s), then (c_b (3,) m in
    the body's frame, r m) per point). q must be a valid configuration. Works in `work` (a
    Data's buffer: the world poses R_s, p_s of every body). Returns sum_p k delta_p
    delta_dot_p (W), the spring's share of the power. Written out where it is called (the
    record's kernel): the step calls contact_on_poses, on the poses it placed."""
    forward_kinematics(tree(ibuf, fbuf), work, q, np.int64(-1))
    return contact_on_poses(ibuf, fbuf, work, contacts, qd, tau, linear, record)


@njit(**JIT)
def contact_on_poses(ibuf, fbuf, work, contacts, qd, tau, linear, record):
    """contact_kernel on the world poses R_s, p_s of every body that `work` holds
    (forward_kinematics at a valid q). Returns the springs' power as contact_kernel's."""
    bodies, params = contacts
    K, D, jac = linear
    x_c, f_c, delta = record
    body_tree = tree(ibuf, fbuf)
    nb = body_count(ibuf)
    nv = qd.shape[0]
    R_s, p_s = world_poses(work, nb)
    h, k, d = params[GROUND], params[STIFFNESS], params[DAMPING]
    mu, v_s = params[FRICTION], params[SLIP]
    J_p = np.empty((3, nv))
    S = np.empty(6)  # a joint axis in {s}
    v_p = np.empty(3)
    C = np.zeros((3, 3))
    spring = 0.0
    for p in range(bodies.shape[0]):
        # x_p = p_sb + R_sb c_b - r e_z; delta = max(0, h - x_z)
        b = lowest_point(R_s, p_s, bodies, params, p, x_c[p])
        f_c[p, :] = 0.0
        delta[p] = max(0.0, h - x_c[p, 2])
        if delta[p] == 0.0:
            continue
        # v_p = J_p v
        zero_matrix(J_p)
        add_point_jacobian(body_tree, R_s, p_s, b, x_c[p], 1.0, J_p, S)
        for r in range(3):
            v_p[r] = 0.0
            for j in range(nv):
                v_p[r] += J_p[r, j] * qd[j]
        delta_dot = -v_p[2]
        spring += k * delta[p] * delta_dot
        # f_n = max(0, k delta + d delta_dot); f_t = -mu f_n v_t / s
        f_n = k * delta[p] + d * delta_dot
        if f_n <= 0.0:
            continue
        s = np.sqrt(v_p[0] * v_p[0] + v_p[1] * v_p[1] + v_s * v_s)
        f_c[p, 0] = -mu * f_n * v_p[0] / s
        f_c[p, 1] = -mu * f_n * v_p[1] / s
        f_c[p, 2] = f_n
        # tau += J_p^T f_p
        for j in range(nv):
            tau[j] += J_p[0, j] * f_c[p, 0] + J_p[1, j] * f_c[p, 1] + J_p[2, j] * f_c[p, 2]
        if jac:
            # K_p = k e_z e_z^T
            C[:, :] = 0.0
            C[2, 2] = k
            add_congruence(J_p, C, K)
            # D_p = d e_z e_z^T + mu f_n (I / s - v_t v_t^T / s^3) on (x, y)
            C[2, 2] = d
            slope = mu * f_n / s
            for r in range(2):
                for c in range(2):
                    C[r, c] = -slope * v_p[r] * v_p[c] / (s * s)
                C[r, r] += slope
            add_congruence(J_p, C, D)
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
    forward_kinematics(body_tree, work, q, np.int64(-1))
    R_s, p_s = world_poses(work, nb)
    x_s = np.empty(3)
    S = np.empty(6)  # a joint axis in {s}
    for p in range(bodies.shape[0]):
        b = lowest_point(R_s, p_s, bodies, params, p, x_s)
        zero_matrix(J[p])
        add_point_jacobian(body_tree, R_s, p_s, b, x_s, 1.0, J[p], S)
