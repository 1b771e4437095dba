"""The compliant contact law's linearisation for an implicit step, K -= dtau/dq and
D -= dtau/dqd of tau = sum_k J_k^T f_k (opendyn.algorithm.contact): exactly at a sphere on the
ground, with the contact points and normal held where they are between geometries.

A sphere on the ground. K -= dtau/dq and D -= dtau/dqd exactly, while f_n > 0 (q in the
tangent space; add_sphere_tangent, the same derivatives as the effect's numpy `tangent` that
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

Between collision geometries. Linearisation for an implicit step (K = -dtau/dq, D = -dtau/dqd), the contact points and the
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

import numpy as np
from numba import njit

from .._runtime.arrays import fill
from .._runtime.kernel_cache import INLINE, JIT
from ..multibody.work_views import contact_axes, scratch_rows, world_poses
from .contact_list import DAMPING, FRICTION, SLIP, STIFFNESS
from .kinematics import space_axis


@njit(**INLINE)
def cross(a, b, out):
    """out (3,) <- a x b."""
    out[0] = a[1] * b[2] - a[2] * b[1]
    out[1] = a[2] * b[0] - a[0] * b[2]
    out[2] = a[0] * b[1] - a[1] * b[0]


@njit(**JIT)
def force_change(law, v_p, f_p, ddelta, dv, df):
    """df (3,) <- the change of the point's force f_p = (f_t, f_n) for a change ddelta of the
    penetration and dv (3,) of the point's velocity v_p, while f_n > 0, law (4,) the sphere's
    law row (opendyn.algorithm.contact_list):
        df_n = k ddelta - d dv_z,
        df_t = -mu (df_n v_t / s + f_n (dv_t / s - v_t (v_t . dv_t) / s^3))."""
    k, d = law[STIFFNESS], law[DAMPING]
    mu, v_s = law[FRICTION], law[SLIP]
    s = np.sqrt(v_p[0] * v_p[0] + v_p[1] * v_p[1] + v_s * v_s)
    df[2] = k * ddelta - d * dv[2]
    along = v_p[0] * dv[0] + v_p[1] * dv[1]
    for r in range(2):
        df[r] = -mu * (df[2] * v_p[r] / s + f_p[2] * (dv[r] / s - v_p[r] * along / (s * s * s)))


@njit(**JIT)
def add_sphere_tangent(body_tree, work, b, at, law, qd, point, K, D):
    """K (nv, nv) -= dtau_p/dq, D (nv, nv) -= dtau_p/dqd: the exact derivatives of one contact
    point's generalized force tau_p = J_p^T f_p (module docstring), q in the tangent space,
    for a point of body b touching the ground with f_n > 0; at = (x (3,), c (3,)) the sphere's
    lowest point and centre in {s}, point = (v_p (3,), f_p (3,)) the velocity of the body's
    material at x and the ground's force there, law (4,) the sphere's law row. Works in `work`, allocating nothing: it reads
    the world poses R_s, p_s of every body and writes the contact axes' rows (ContactAxes, row
    j for each velocity coordinate j from b up to the root) and scratch rows 0 and 5-8 (rows
    1-4 hold at and point: opendyn.algorithm.contact.compliant_forces)."""
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
            force_change(law, v_p, f_p, -J_c[2], dv, df_dq)
            force_change(law, v_p, f_p, 0.0, J_x[j], df_dqd[j])
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
