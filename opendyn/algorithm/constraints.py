"""Constrained dynamics with k Pfaffian constraints A(q) qd = 0 (the seed notes, "Constrained
Dynamics"; Lynch & Park, Section 8.7):

    tau = M(q) qdd + h(q, qd) + A^T lam,          A qdd + Adot qd = 0
    lam = (A M^-1 A^T)^-1 (A M^-1 (tau - h) + Adot qd),   qdd = M^-1 (tau - h - A^T lam)
    P   = I - A^T (A M^-1 A^T)^-1 A M^-1,          P tau = P (M qdd + h)   (constrained ID)
    J_b^T F_tip = A^T lam,  F_tip = J_b^-T A^T lam  where J_b is square and invertible

lam is the generalized force the robot applies TO the constraints (as f_tip is the wrench a frame
applies to the environment): for a point constraint, the force (N, world axes) the point pushes
on it with. The constraint objects and the meaning of their rows are in
opendyn.multibody.constraint_objects.

Rank-deficient A (a 3-row point closure on a planar mechanism, whose out-of-plane row is
identically zero; a duplicated constraint) leaves G = A M^-1 A^T singular. Everywhere here
(G)^-1 is the pseudo-inverse G^+ from the symmetric eigendecomposition G = V diag(e) V^T
(cyclic Jacobi), keeping the eigenvalues e_i > RANK_RTOL * max(e) (RANK_RTOL = 1e-12): lam is the
minimum-norm least-squares solution of G lam = A M^-1 (tau - h) + Adot qd, and qdd, A^T lam and
P are unique when the constraints are consistent (the right-hand side lies in the range of G);
the numerical rank is the number of eigenvalues kept.

Floating base: q is (nq,), qd, qdd, tau and the columns of A are (nv,)
(opendyn.multibody.constraint_objects): the kernels walk each joint through its rows of S and its
index iv into v, so a free joint's six columns are its body-twist coordinates (angular first) and
nothing here assumes one coordinate per body.

Compiled interface (for the simulation step, inside compiled loops):
  constraint_table(model, constraints, q0 (nq,)) -> rows (n_c, 5) int64, params (p,) float64
      row: (kind, offset into params, m rows of A, body_a, body_b), body -1 = the fixed world
  constraint_terms_kernel(ibuf, fbuf, rows, params, q (nq,), qd (nv,), A, Adot_qd, phi)
      -> status
  constrained_solve_kernel(M, rhs, A, gamma, qdd, lam) -> Status.OK.value, or SINGULAR + k (pivot k)
  constrained_solve_rank_kernel(M, rhs, A, gamma, qdd, lam, rank) -> the same, rank[0] = rank
  constrained_solve_at(ibuf, fbuf, rows, params, gains, q, qd, M, rhs, qdd, lam) -> status
  constrained_forward_kernel(ibuf, fbuf, rows, params, gains, q, qd, tau, loads, armature,
                             qdd, lam) -> status
with gains = (alpha, beta), the Baumgarte stabilisation A qdd + Adot qd + 2 alpha A qd +
beta^2 phi = 0 of a simulation ((0, 0): none).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .._runtime.arrays import all_finite, fill, zero_matrix
from .._runtime.kernel_cache import INLINE, JIT
from .._runtime.status import Status
from ..multibody.constraint_objects import (
    CONSTRAINT_TYPES,
    FIXED_POSE,
    JOINT_COUPLING,
    POINT_ON_PLANE,
    POINT_TO_POINT,
    POINT_TO_WORLD,
    FixedPose,
    PointOnPlane,
    PointToPoint,
    PointToWorld,
)
from ..multibody.data import new_work
from ..multibody.joints import quaternion_status, state_status
from ..multibody.layout import body_count, tree
from ..spatial.compiled import ad_twist, twist_to_child
from . import checks
from .cholesky import cholesky_solve
from .configuration import difference_kernel
from .crba import crba_kernel, mass_matrix
from .kinematics import frame_pose, jacobian, space_axis
from .rnea import forward_pass, rnea_kernel

RANK_RTOL = 1e-12  # eigenvalues of A M^-1 A^T below this times the largest count as zero
JACOBI_MAX_SWEEPS = 60
ROW_FIELDS = ("kind", "offset", "rows", "body_a", "body_b")  # columns of the table's rows
_LOG_SERIES = 1e-2
NO_STABILISATION = np.zeros(2)  # Baumgarte gains (alpha, beta) = 0: A qdd + Adot qd = 0


# --------------------------------------------------------------------------------------------
# compiled kinematics of the constraint points and frames


@njit(**INLINE)
def world_poses(parent, R, p, R_s, p_s):
    """R_s[i], p_s[i] <- T_{s,i} from the parent-relative poses (R[i], p[i]) = T_{lambda,i}."""
    for i in range(parent.shape[0]):
        lam = parent[i]
        if lam < 0:
            R_s[i] = R[i]
            p_s[i] = p[i]
            continue
        for r in range(3):
            for c in range(3):
                R_s[i, r, c] = (
                    R_s[lam, r, 0] * R[i, 0, c]
                    + R_s[lam, r, 1] * R[i, 1, c]
                    + R_s[lam, r, 2] * R[i, 2, c]
                )
            p_s[i, r] = (
                p_s[lam, r]
                + R_s[lam, r, 0] * p[i, 0]
                + R_s[lam, r, 1] * p[i, 1]
                + R_s[lam, r, 2] * p[i, 2]
            )


@njit(**INLINE)
def point_motion(R_s, p_s, V, dV, body, r, p_w, a_w):
    """p_w <- the world position of the point r (body coordinates) of `body`, and a_w <- its
    classical acceleration in world axes from the body twist V = (w, v) and its rate dV:
        a = R (dv + dw x r + w x (v + w x r));   body -1: r is a world point at rest."""
    if body < 0:
        for k in range(3):
            p_w[k] = r[k]
            a_w[k] = 0.0
        return
    w0, w1, w2 = V[body, 0], V[body, 1], V[body, 2]
    u0 = V[body, 3] + w1 * r[2] - w2 * r[1]
    u1 = V[body, 4] + w2 * r[0] - w0 * r[2]
    u2 = V[body, 5] + w0 * r[1] - w1 * r[0]
    b0 = dV[body, 3] + dV[body, 1] * r[2] - dV[body, 2] * r[1] + w1 * u2 - w2 * u1
    b1 = dV[body, 4] + dV[body, 2] * r[0] - dV[body, 0] * r[2] + w2 * u0 - w0 * u2
    b2 = dV[body, 5] + dV[body, 0] * r[1] - dV[body, 1] * r[0] + w0 * u1 - w1 * u0
    for k in range(3):
        R = R_s[body, k]
        p_w[k] = p_s[body, k] + R[0] * r[0] + R[1] * r[1] + R[2] * r[2]
        a_w[k] = R[0] * b0 + R[1] * b1 + R[2] * b2


@njit(**INLINE)
def add_point_jacobian(parent, nv_j, iv, mult, axes, R_s, p_s, body, p_w, sign, J, S):
    """J (3, nv) += sign * d(world velocity of the world point p_w fixed to `body`)/d v:
    column iv[i] + k gets mult[i] (v_i + w_i x p_w) with (w_i, v_i) = Ad_{T_{s,i}} axes[i, k]
    (row k of S_i), for every body i from `body` to the root. S is (6,) scratch."""
    i = body
    while i >= 0:
        f = sign * mult[i]
        for k in range(nv_j[i]):
            space_axis(R_s[i], p_s[i], axes[i, k], S)
            c = iv[i] + k
            J[0, c] += f * (S[3] + S[1] * p_w[2] - S[2] * p_w[1])
            J[1, c] += f * (S[4] + S[2] * p_w[0] - S[0] * p_w[2])
            J[2, c] += f * (S[5] + S[0] * p_w[1] - S[1] * p_w[0])
        i = parent[i]


@njit(**INLINE)
def relative_pose(R_s1, p_s1, R_s2, p_s2, R_12, p_12):
    """(R_12, p_12) <- T_12 = T_s1^-1 T_s2 = (R_s1^T R_s2, R_s1^T (p_s2 - p_s1))."""
    for i in range(3):
        for j in range(3):
            R_12[i, j] = R_s1[0, i] * R_s2[0, j] + R_s1[1, i] * R_s2[1, j] + R_s1[2, i] * R_s2[2, j]
        p_12[i] = (
            R_s1[0, i] * (p_s2[0] - p_s1[0])
            + R_s1[1, i] * (p_s2[1] - p_s1[1])
            + R_s1[2, i] * (p_s2[2] - p_s1[2])
        )


@njit(**INLINE)
def frame_in_world(R_s, p_s, body, R_bf, p_bf, R_sf, p_sf):
    """(R_sf, p_sf) <- T_{s,body} T_{body,frame}; body -1: T_{body,frame} is already T_sf."""
    for r in range(3):
        if body < 0:
            for c in range(3):
                R_sf[r, c] = R_bf[r, c]
            p_sf[r] = p_bf[r]
            continue
        for c in range(3):
            R_sf[r, c] = (
                R_s[body, r, 0] * R_bf[0, c]
                + R_s[body, r, 1] * R_bf[1, c]
                + R_s[body, r, 2] * R_bf[2, c]
            )
        p_sf[r] = (
            p_s[body, r]
            + R_s[body, r, 0] * p_bf[0]
            + R_s[body, r, 1] * p_bf[1]
            + R_s[body, r, 2] * p_bf[2]
        )


@njit(**INLINE)
def frame_twist(V, body, R_bf, p_bf, out):
    """out <- Ad_{T_{frame,body}} V[body], a frame's body twist (or its rate); 0 in the world."""
    if body < 0:
        for k in range(6):
            out[k] = 0.0
        return
    twist_to_child(R_bf, p_bf, V[body], out)


@njit(**INLINE)
def add_relative_twist_jacobian(
    parent, nv_j, iv, mult, axes, R_s, p_s, body, R_sb, p_sb, sign, J, S, c6
):
    """J (6, nv) += sign * Ad_{T_{b,s}} J_s(body): the space twist of `body` per unit v, in the
    axes of frame b at (R_sb, p_sb). S, c6: (6,) scratch."""
    i = body
    while i >= 0:
        f = sign * mult[i]
        for k in range(nv_j[i]):
            space_axis(R_s[i], p_s[i], axes[i, k], S)
            twist_to_child(R_sb, p_sb, S, c6)
            c = iv[i] + k
            for r in range(6):
                J[r, c] += f * c6[r]
        i = parent[i]


@njit(**INLINE)
def log_se3(R, p, out):
    """out (6,) <- log(T), T = (R, p): (w, (I - [w]/2 + ((1 - (t/2) cot(t/2)) / t^2) [w]^2) p),
    w = log(R), t = |w| in [0, pi] (MR eqs. 3.91-3.92; opendyn.spatial.log_se3)."""
    d0 = R[2, 1] - R[1, 2]
    d1 = R[0, 2] - R[2, 0]
    d2 = R[1, 0] - R[0, 1]
    cos_t = 0.5 * (R[0, 0] + R[1, 1] + R[2, 2] - 1.0)
    t = np.arctan2(0.5 * np.sqrt(d0 * d0 + d1 * d1 + d2 * d2), cos_t)
    if cos_t >= 0.0:
        # [w] = (t / (2 sin t)) (R - R^T)
        ratio = 0.5 if t == 0.0 else 0.5 * t / np.sin(t)
        w0, w1, w2 = ratio * d0, ratio * d1, ratio * d2
    else:
        # axis from the column of a a^T = ((R + R^T)/2 - cos t I) / (1 - cos t) with the
        # largest diagonal entry, its sign from R - R^T
        k = 0
        best = -1.0
        for j in range(3):
            if R[j, j] > best:
                best = R[j, j]
                k = j
        col = np.empty(3)
        for j in range(3):
            col[j] = (0.5 * (R[j, k] + R[k, j]) - (cos_t if j == k else 0.0)) / (1.0 - cos_t)
        norm = np.sqrt(col[0] * col[0] + col[1] * col[1] + col[2] * col[2])
        s = t / norm
        if col[0] * d0 + col[1] * d1 + col[2] * d2 < 0.0:
            s = -s
        w0, w1, w2 = s * col[0], s * col[1], s * col[2]
    if t < _LOG_SERIES:
        t2 = t * t
        coef = 1.0 / 12.0 + t2 / 720.0 + t2 * t2 / 30240.0 + t2 * t2 * t2 / 1209600.0
    else:
        half = 0.5 * t
        coef = (1.0 - half * np.cos(half) / np.sin(half)) / (t * t)
    # [w] p = w x p,  [w]^2 p = w x (w x p)
    x0 = w1 * p[2] - w2 * p[1]
    x1 = w2 * p[0] - w0 * p[2]
    x2 = w0 * p[1] - w1 * p[0]
    y0 = w1 * x2 - w2 * x1
    y1 = w2 * x0 - w0 * x2
    y2 = w0 * x1 - w1 * x0
    out[0], out[1], out[2] = w0, w1, w2
    out[3] = p[0] - 0.5 * x0 + coef * y0
    out[4] = p[1] - 0.5 * x1 + coef * y1
    out[5] = p[2] - 0.5 * x2 + coef * y2


# --------------------------------------------------------------------------------------------
# the constraint terms A, Adot qd, phi


@njit(**JIT)
def constraint_terms_kernel(ibuf, fbuf, rows, params, q, qd, A, Adot_qd, phi):
    """A (k, nv), Adot_qd (k,), phi (k,) <- every constraint's rows at (q (nq,), qd (nv,)),
    k = rows[:, 2].sum(), in table order. Adot qd is d/dt (A qd) at qdd = 0 (no gravity).
    Point rows: world axes; FIXED_POSE: frame b axes, angular first (see
    opendyn.multibody.constraint_objects). Returns a Status: OK, Q_NOT_FINITE,
    Q_NOT_UNIT_QUATERNION or QD_NOT_FINITE."""
    status = state_status(ibuf, q, qd)
    if status:
        return status
    body_tree = tree(ibuf, fbuf)
    parent, nv_j, iv = body_tree.parent, body_tree.nv_j, body_tree.iv
    mult, axes = body_tree.mult, body_tree.S
    nb = parent.shape[0]
    nv = qd.shape[0]
    poses = np.empty((2, nb, 3, 3))
    R, R_s = poses[0], poses[1]
    points = np.empty((2, nb, 3))
    p, p_s = points[0], points[1]
    twists = np.empty((2, nb, 6))
    V, dV = twists[0], twists[1]
    s6 = np.empty((6, 6))
    S, c6, Va, Vb, X, Y = s6[0], s6[1], s6[2], s6[3], s6[4], s6[5]
    v3 = np.empty((4, 3))
    p_a, a_a, p_b, a_b = v3[0], v3[1], v3[2], v3[3]
    frames = np.empty((3, 3, 3))
    R_sa, R_sb, R_ab = frames[0], frames[1], frames[2]
    t3 = np.empty((3, 3))
    p_sa, p_sb, p_ab = t3[0], t3[1], t3[2]
    J3 = np.empty((3, nv))
    dq = np.empty(nv)
    # forward pass at qdd = 0, no gravity: V_i and dV_i = the velocity-product part of the rate
    forward_pass(body_tree, q, qd, np.zeros(nv), np.zeros(6), R, p, V, dV, s6[:2])
    world_poses(parent, R, p, R_s, p_s)

    zero_matrix(A)
    r0 = 0
    for n in range(rows.shape[0]):
        kind, o, m, body_a, body_b = rows[n, 0], rows[n, 1], rows[n, 2], rows[n, 3], rows[n, 4]
        if kind == POINT_TO_WORLD or kind == POINT_TO_POINT:
            # world velocity of point a (minus that of point b): 3 rows
            point_motion(R_s, p_s, V, dV, body_a, params[o : o + 3], p_a, a_a)
            add_point_jacobian(
                parent, nv_j, iv, mult, axes, R_s, p_s, body_a, p_a, 1.0, A[r0 : r0 + 3], S
            )
            if kind == POINT_TO_WORLD:
                for k in range(3):
                    p_b[k] = params[o + 3 + k]  # the target
                    a_b[k] = 0.0
            else:
                point_motion(R_s, p_s, V, dV, body_b, params[o + 3 : o + 6], p_b, a_b)
                add_point_jacobian(
                    parent, nv_j, iv, mult, axes, R_s, p_s, body_b, p_b, -1.0, A[r0 : r0 + 3], S
                )
            for k in range(3):
                Adot_qd[r0 + k] = a_a[k] - a_b[k]
                phi[r0 + k] = p_a[k] - p_b[k]
        elif kind == POINT_ON_PLANE:
            # n . (world velocity of the point): 1 row
            point_motion(R_s, p_s, V, dV, body_a, params[o : o + 3], p_a, a_a)
            zero_matrix(J3)
            add_point_jacobian(parent, nv_j, iv, mult, axes, R_s, p_s, body_a, p_a, 1.0, J3, S)
            nrm = params[o + 3 : o + 6]
            for c in range(nv):
                A[r0, c] = nrm[0] * J3[0, c] + nrm[1] * J3[1, c] + nrm[2] * J3[2, c]
            Adot_qd[r0] = nrm[0] * a_a[0] + nrm[1] * a_a[1] + nrm[2] * a_a[2]
            phi[r0] = nrm[0] * p_a[0] + nrm[1] * p_a[1] + nrm[2] * p_a[2] - params[o + 6]
        elif kind == FIXED_POSE:
            # V_rel = V_b - Ad_{T_ba} V_a in frame b axes: 6 rows
            R_af = params[o : o + 9].reshape((3, 3))
            p_af = params[o + 9 : o + 12]
            R_bf = params[o + 12 : o + 21].reshape((3, 3))
            p_bf = params[o + 21 : o + 24]
            R_ab_ref = params[o + 24 : o + 33].reshape((3, 3))
            p_ab_ref = params[o + 33 : o + 36]
            frame_in_world(R_s, p_s, body_a, R_af, p_af, R_sa, p_sa)
            frame_in_world(R_s, p_s, body_b, R_bf, p_bf, R_sb, p_sb)
            Arows = A[r0 : r0 + 6]
            add_relative_twist_jacobian(
                parent, nv_j, iv, mult, axes, R_s, p_s, body_b, R_sb, p_sb, 1.0, Arows, S, c6
            )
            add_relative_twist_jacobian(
                parent, nv_j, iv, mult, axes, R_s, p_s, body_a, R_sb, p_sb, -1.0, Arows, S, c6
            )
            # T_ba = T_bs T_sa: R_ab holds R_ba here, p_ab holds p_ba
            relative_pose(R_sb, p_sb, R_sa, p_sa, R_ab, p_ab)
            # d/dt V_rel at qdd = 0: dV_b - Ad_{T_ba} dV_a + ad_{V_b} (Ad_{T_ba} V_a)
            frame_twist(V, body_a, R_af, p_af, Va)
            space_axis(R_ab, p_ab, Va, X)  # X = Ad_{T_ba} V_a
            frame_twist(V, body_b, R_bf, p_bf, Vb)
            ad_twist(Vb, X, Y)
            frame_twist(dV, body_a, R_af, p_af, Va)
            space_axis(R_ab, p_ab, Va, X)  # X = Ad_{T_ba} dV_a
            frame_twist(dV, body_b, R_bf, p_bf, Vb)
            for k in range(6):
                Adot_qd[r0 + k] = Vb[k] - X[k] + Y[k]
            # phi = log(T_ab*^-1 T_ab), T_ab = T_sa^-1 T_sb
            relative_pose(R_sa, p_sa, R_sb, p_sb, R_ab, p_ab)
            for i in range(3):
                for j in range(3):
                    R_sa[i, j] = (
                        R_ab_ref[0, i] * R_ab[0, j]
                        + R_ab_ref[1, i] * R_ab[1, j]
                        + R_ab_ref[2, i] * R_ab[2, j]
                    )
                p_sa[i] = (
                    R_ab_ref[0, i] * (p_ab[0] - p_ab_ref[0])
                    + R_ab_ref[1, i] * (p_ab[1] - p_ab_ref[1])
                    + R_ab_ref[2, i] * (p_ab[2] - p_ab_ref[2])
                )
            log_se3(R_sa, p_sa, phi[r0 : r0 + 6])
        else:
            # JOINT_COUPLING: a constant C (m, nv); phi = C (q (-) q_ref)
            difference_kernel(ibuf, params[o + m * nv : o + m * nv + q.shape[0]], q, dq)
            for i in range(m):
                e = 0.0
                for c in range(nv):
                    C_ic = params[o + i * nv + c]
                    A[r0 + i, c] = C_ic
                    e += C_ic * dq[c]
                Adot_qd[r0 + i] = 0.0
                phi[r0 + i] = e
        r0 += m
    return Status.OK.value


# --------------------------------------------------------------------------------------------
# the constrained solve


@njit(**JIT)
def symmetric_eigen(G, E, e):
    """G = E diag(e) E^T for a symmetric (k, k) G, by cyclic Jacobi rotations (Golub & Van Loan,
    Matrix Computations, Section 8.5): G is overwritten, E (k, k) <- orthonormal eigenvectors
    (columns), e (k,) <- eigenvalues. A fixed cap of sweeps: no exception, no NaN from finite G."""
    k = G.shape[0]
    zero_matrix(E)
    for i in range(k):
        E[i, i] = 1.0
    total = 0.0
    for i in range(k):
        for j in range(k):
            total += G[i, j] * G[i, j]
    for sweep in range(JACOBI_MAX_SWEEPS):
        off = 0.0
        for i in range(k):
            for j in range(i + 1, k):
                off += G[i, j] * G[i, j]
        if not off > 1e-32 * total:
            break
        for a in range(k - 1):
            for b in range(a + 1, k):
                g_ab = G[a, b]
                if g_ab == 0.0:
                    continue
                theta = (G[b, b] - G[a, a]) / (2.0 * g_ab)
                if abs(theta) > 1e150:
                    t = 0.5 / theta
                else:
                    t = 1.0 / (abs(theta) + np.sqrt(theta * theta + 1.0))
                    if theta < 0.0:
                        t = -t
                c = 1.0 / np.sqrt(t * t + 1.0)
                s = t * c
                # G <- J^T G J with J = [[c, s], [-s, c]] in the (a, b) plane; E <- E J
                for i in range(k):
                    g_ia, g_ib = G[i, a], G[i, b]
                    G[i, a] = c * g_ia - s * g_ib
                    G[i, b] = s * g_ia + c * g_ib
                for i in range(k):
                    g_ai, g_bi = G[a, i], G[b, i]
                    G[a, i] = c * g_ai - s * g_bi
                    G[b, i] = s * g_ai + c * g_bi
                G[a, b] = 0.0
                G[b, a] = 0.0
                for i in range(k):
                    e_ia, e_ib = E[i, a], E[i, b]
                    E[i, a] = c * e_ia - s * e_ib
                    E[i, b] = s * e_ia + c * e_ib
    for i in range(k):
        e[i] = G[i, i]


@njit(**JIT)
def pseudo_solve(G, b, x):
    """x <- G^+ b for a symmetric positive semi-definite (k, k) G (overwritten): the
    minimum-norm least-squares solution, eigenvalues e_i <= RANK_RTOL * max(e) treated as 0.
    Returns the numerical rank."""
    k = G.shape[0]
    E = np.empty((k, k))
    e = np.empty(k)
    symmetric_eigen(G, E, e)
    e_max = 0.0
    for i in range(k):
        e_max = max(e_max, e[i])
    fill(x, 0.0)
    rank = 0
    for i in range(k):
        if not e[i] > RANK_RTOL * e_max or not e_max > 0.0:
            continue
        rank += 1
        s = 0.0
        for j in range(k):
            s += E[j, i] * b[j]
        s /= e[i]
        for j in range(k):
            x[j] += s * E[j, i]
    return rank


@njit(**JIT)
def constrained_solve_rank_kernel(M, rhs, A, gamma, qdd, lam, rank):
    """As constrained_solve_kernel, and rank[0] <- the numerical rank of A M^-1 A^T (the number of
    independent constraint rows); rank (1,) int64."""
    nv = M.shape[0]
    k = A.shape[0]
    qdd_free = np.empty(nv)
    # M = L L^T (L in M's lower triangle), qdd_free = M^-1 rhs
    status = cholesky_solve(M, rhs, qdd_free)
    if status:
        rank[0] = 0
        return status
    # Y = L^-1 A^T (nv, k), G = Y^T Y = A M^-1 A^T
    Y = np.empty((nv, k))
    for j in range(k):
        for r in range(nv):
            s = A[j, r]
            for c in range(r):
                s -= M[r, c] * Y[c, j]
            Y[r, j] = s / M[r, r]
    G = np.empty((k, k))
    for i in range(k):
        for j in range(i, k):
            s = 0.0
            for r in range(nv):
                s += Y[r, i] * Y[r, j]
            G[i, j] = s
            G[j, i] = s
    # lam = G^+ (A M^-1 rhs + gamma)
    b = np.empty(k)
    for i in range(k):
        s = gamma[i]
        for c in range(nv):
            s += A[i, c] * qdd_free[c]
        b[i] = s
    rank[0] = pseudo_solve(G, b, lam)
    # qdd = M^-1 (rhs - A^T lam) = qdd_free - L^-T (Y lam)
    z = np.empty(nv)
    for r in range(nv):
        s = 0.0
        for j in range(k):
            s += Y[r, j] * lam[j]
        z[r] = s
    for r in range(nv - 1, -1, -1):
        s = z[r]
        for c in range(r + 1, nv):
            s -= M[c, r] * z[c]
        z[r] = s / M[r, r]
    for r in range(nv):
        qdd[r] = qdd_free[r] - z[r]
    return Status.OK.value


@njit(**JIT)
def constrained_solve_kernel(M, rhs, A, gamma, qdd, lam):
    """Solve M qdd + A^T lam = rhs, A qdd = -gamma for qdd (nv,) and lam (k,):
        lam = (A M^-1 A^T)^+ (A M^-1 rhs + gamma),   qdd = M^-1 (rhs - A^T lam)
    M (nv, nv) symmetric positive definite (overwritten by its Cholesky factor; add armature to
    its diagonal first), rhs = tau - h (nv,), A (k, nv), gamma = Adot qd (+ stabilisation) (k,).
    Rank-deficient A: lam minimum-norm (pseudo-inverse, RANK_RTOL), never NaN from finite input
    (non-finite rhs, A or gamma propagate to qdd; nothing raises, nothing loops forever).
    Returns Status.OK.value, or SINGULAR + k for the first non-positive pivot of M (singular at
    k)."""
    rank = np.zeros(1, dtype=np.int64)
    return constrained_solve_rank_kernel(M, rhs, A, gamma, qdd, lam, rank)


@njit(**JIT)
def constrained_solve_at(ibuf, fbuf, rows, params, gains, q, qd, M, rhs, qdd, lam):
    """qdd (nv,), lam (k,) <- the solution of M qdd + A^T lam = rhs with the constraint rows at
    (q (nq,), qd (nv,)) held to second order, with Baumgarte stabilisation gains =
    (alpha, beta) (1/s):
        A qdd + Adot qd + 2 alpha A qd + beta^2 phi = 0
    ((0, 0): A qdd + Adot qd = 0, the drift of phi left alone). M (nv, nv) is overwritten.
    Returns a Status: OK, Q/QD_NOT_FINITE, Q_NOT_UNIT_QUATERNION, or SINGULAR + j when M is
    singular at coordinate j."""
    nv = qd.shape[0]
    k = lam.shape[0]
    A = np.empty((k, nv))
    gamma = np.empty(k)
    phi = np.empty(k)
    status = constraint_terms_kernel(ibuf, fbuf, rows, params, q, qd, A, gamma, phi)
    if status:
        return status
    alpha, beta = gains[0], gains[1]
    if alpha != 0.0 or beta != 0.0:
        for r in range(k):
            rate = 0.0
            for j in range(nv):
                rate += A[r, j] * qd[j]
            gamma[r] += 2.0 * alpha * rate + beta * beta * phi[r]
    return constrained_solve_kernel(M, rhs, A, gamma, qdd, lam)


@njit(**JIT)
def constrained_forward_kernel(
    ibuf, fbuf, rows, params, gains, q, qd, tau, loads, armature, qdd, lam
):
    """qdd (nv,), lam (k,) <- constrained forward dynamics at one state (q (nq,); qd, tau
    (nv,)): M by CRBA (+ diag(armature), (nv,) or empty), h (and the f_tip wrenches in loads,
    as in rnea_kernel) by RNEA, then constrained_solve_at with the Baumgarte gains
    (alpha, beta) (zeros: none). Returns a Status: OK, Q/QD/TAU_NOT_FINITE,
    Q_NOT_UNIT_QUATERNION, RESULT_NOT_FINITE (h overflowed), or SINGULAR + j when M is singular
    at coordinate j."""
    if not all_finite(tau):
        return Status.TAU_NOT_FINITE.value
    nv = qd.shape[0]
    work = new_work(body_count(ibuf), nv)
    rhs = np.empty(nv)
    status = rnea_kernel(ibuf, fbuf, work, q, qd, np.zeros(nv), loads, rhs)
    if status:
        return status
    for i in range(nv):
        rhs[i] = tau[i] - rhs[i]
    M = np.empty((nv, nv))
    crba_kernel(ibuf, fbuf, work, q, M)
    for i in range(armature.shape[0]):
        M[i, i] += armature[i]
    return constrained_solve_at(ibuf, fbuf, rows, params, gains, q, qd, M, rhs, qdd, lam)


# --------------------------------------------------------------------------------------------
# the table: constraint objects -> flat arrays


def _as_list(constraints):
    if isinstance(constraints, CONSTRAINT_TYPES):
        return [constraints]
    if constraints is None or isinstance(constraints, (str, bytes, dict)):
        raise ValueError(
            "constraints must be a constraint (PointToWorld, PointOnPlane, PointToPoint, "
            f"FixedPose, JointCoupling) or a sequence of them, got {constraints!r}"
        )
    try:
        out = list(constraints)
    except TypeError:
        raise ValueError(
            "constraints must be a constraint or a sequence of constraints, got "
            f"{type(constraints).__name__}"
        ) from None
    for n, c in enumerate(out):
        if not isinstance(c, CONSTRAINT_TYPES):
            raise ValueError(
                f"constraints[{n}] must be one of "
                f"{', '.join(t.__name__ for t in CONSTRAINT_TYPES)}, got {type(c).__name__}"
            )
    return out


def _frame(model, label, name):
    """(body, T_body_frame) of a frame, or KeyError naming the constraint and the frame."""
    try:
        k = model.frame_index(name)
    except KeyError as e:
        raise KeyError(f"{label}: {e.args[0]}") from None
    fr = model.frames[k]
    return fr.body, np.asarray(fr.T_body_frame, dtype=np.float64)


def _bound_at(label, field, q0, q0_name):
    if q0 is None:
        raise ValueError(
            f"{label}: {field} is None (to be bound at a configuration) and no configuration "
            f"to bind it at was given: give {field} explicitly or pass {q0_name}"
        )
    return q0


def _point_in_body(T_bf, point):
    return T_bf[:3, :3] @ np.asarray(point) + T_bf[:3, 3]


def _world_point(model, q0, name, point):
    return _point_in_body(frame_pose(model, q0, name), point)


def _table(model, constraints, q0, q0_name="q0"):
    constraints = _as_list(constraints)
    if q0 is not None:
        q0 = _configuration(model, q0, q0_name, "constraints")
    rows = np.zeros((len(constraints), 5), dtype=np.int64)
    params = []
    offset = 0
    for n, c in enumerate(constraints):
        label = f"constraints[{n}] {c!r}"
        body_a = body_b = -1
        if isinstance(c, (PointToWorld, PointOnPlane)):
            body_a, T_af = _frame(model, label, c.frame)
            if body_a < 0:
                raise ValueError(
                    f"{label}: frame {c.frame!r} belongs to the fixed world, so the constraint "
                    f"is between two world frames and holds nothing"
                )
            r_a = _point_in_body(T_af, c.point)
            if isinstance(c, PointToWorld):
                target = c.target
                if target is None:
                    q = _bound_at(label, "target", q0, q0_name)
                    target = _world_point(model, q, c.frame, c.point)
                p = np.concatenate([r_a, target])
            else:
                off = c.offset
                if off is None:
                    q = _bound_at(label, "offset", q0, q0_name)
                    off = float(np.dot(c.normal, _world_point(model, q, c.frame, c.point)))
                p = np.concatenate([r_a, c.normal, [off]])
        elif isinstance(c, (PointToPoint, FixedPose)):
            body_a, T_af = _frame(model, label, c.frame_a)
            body_b, T_bf = _frame(model, label, c.frame_b)
            if body_a < 0 and body_b < 0:
                raise ValueError(
                    f"{label}: frames {c.frame_a!r} and {c.frame_b!r} both belong to the fixed "
                    f"world: a constraint between two world frames holds nothing"
                )
            if isinstance(c, PointToPoint):
                p = np.concatenate(
                    [_point_in_body(T_af, c.point_a), _point_in_body(T_bf, c.point_b)]
                )
            else:
                T_ab = c.T_ab
                if T_ab is None:
                    q = _bound_at(label, "T_ab", q0, q0_name)
                    T_ab = np.linalg.solve(
                        frame_pose(model, q, c.frame_a), frame_pose(model, q, c.frame_b)
                    )
                T_ab = np.asarray(T_ab, dtype=np.float64)
                p = np.concatenate(
                    [
                        T_af[:3, :3].ravel(),
                        T_af[:3, 3],
                        T_bf[:3, :3].ravel(),
                        T_bf[:3, 3],
                        T_ab[:3, :3].ravel(),
                        T_ab[:3, 3],
                    ]
                )
        else:  # JointCoupling
            C = c.matrix
            if C.shape[1] != model.nv:
                raise ValueError(
                    f"{label}: A must have nv={model.nv} columns for model {model.name!r} "
                    f"(one per joint: {', '.join(model.joint_names)}), got shape {C.shape}"
                )
            q_ref = c.q_ref
            if q_ref is None:
                q_ref = _bound_at(label, "q_ref", q0, q0_name)
            else:
                q_ref = _configuration(model, q_ref, "q_ref", label)
            p = np.concatenate([C.ravel(), q_ref])
        rows[n] = (c.kind, offset, c.n_rows(model.nv), body_a, body_b)
        params.append(np.asarray(p, dtype=np.float64))
        offset += len(p)
    params = np.ascontiguousarray(np.concatenate(params) if params else np.zeros(0))
    return rows, params


def constraint_table(model, constraints, q0):
    """The compiled form of constraints: (rows (n_c, 5) int64, params (p,) float64).

    rows[n] = (kind, offset into params, m (its rows of A), body_a, body_b), body -1 = the fixed
    world, kind one of opendyn.multibody.constraint_objects.POINT_TO_WORLD, POINT_ON_PLANE,
    POINT_TO_POINT, FIXED_POSE, JOINT_COUPLING. params per kind, from the offset (points in body
    coordinates, i.e. T_{body,frame} applied; world vectors in the world frame; m, rad):
      POINT_TO_WORLD  r_a (3), target (3)
      POINT_ON_PLANE  r_a (3), unit normal (3), offset (1)
      POINT_TO_POINT  r_a (3), r_b (3)                      (a world frame's r is a world point)
      FIXED_POSE      R_{body_a,frame_a} (9, row-major), p (3), R_{body_b,frame_b} (9), p (3),
                      target R_ab (9), p_ab (3)
      JOINT_COUPLING  C (m * nv, row-major), q_ref (nq)
    Every None default (target, offset, T_ab, q_ref) is resolved at q0 (nq,), the configuration
    the constraints are bound at; q0 None is allowed when none is left None.

    Raises KeyError naming the constraint and the frame for an unknown frame, ValueError for a
    constraint between two world frames, a JointCoupling whose A is not (k, nv) or whose q_ref
    is not (nq,), a bad q0 (shape, NaN, a quaternion far from unit norm).
    """
    checks.check_model(model, "constraint_table")
    return _table(model, constraints, q0, "q0")


# --------------------------------------------------------------------------------------------
# public functions


def _single(model, x, name, what, n):
    """x as a finite float64 (n,) array, or ValueError naming it."""
    try:
        x = checks.as_state(model, x, name, n)
    except (TypeError, ValueError) as e:
        raise type(e)(f"{what}: {e}") from None
    if x.ndim != 1:
        raise ValueError(f"{what}: {name} must be a single state ({n},), got {x.shape}")
    if not np.all(np.isfinite(x)):
        raise ValueError(f"{what}: {name} must be finite (it has NaN or inf)")
    return x


def _state(model, x, name, what):
    """A velocity-like argument (qd, qdd, tau): a finite (nv,) array."""
    return _single(model, x, name, what, model.nv)


def _configuration(model, q, name, what):
    """A configuration: a finite (nq,) array whose quaternions (a floating base) have unit
    norm within joints.QUATERNION_TOLERANCE."""
    q = _single(model, q, name, what, model.nq)
    if model.floating_base and quaternion_status(model._ibuf, q) == Status.Q_NOT_UNIT_QUATERNION:
        raise ValueError(f"{what}: {checks.quaternion_problem(model, name)}")
    return q


def _matrix_A(model, A, what):
    A = np.array(checks.as_float_array(A, f"{what}: A"), ndmin=2)
    if A.ndim != 2 or A.shape[1] != model.nv:
        raise ValueError(
            f"{what}: A must have shape (k, nv={model.nv}) for model {model.name!r}, "
            f"got shape {A.shape}"
        )
    if not np.all(np.isfinite(A)):
        raise ValueError(f"{what}: A must be finite (it has NaN or inf)")
    return np.ascontiguousarray(A)


def _vector_k(x, k, name, what):
    x = np.array(checks.as_float_array(x, f"{what}: {name}"), ndmin=1)
    if x.shape != (k,):
        raise ValueError(
            f"{what}: {name} must have shape ({k},), one entry per row of A, got shape {x.shape}"
        )
    if not np.all(np.isfinite(x)):
        raise ValueError(f"{what}: {name} must be finite (it has NaN or inf)")
    return np.ascontiguousarray(x)


_TERMS = ("A", "Adot_qd", "phi")  # what constraint_terms_kernel computes, in its order


def _term(model, q, qd, constraints, q_bound, what, term):
    """One of the constraints' terms at (q, qd): "A", "Adot_qd" or "phi", checked finite."""
    q = _configuration(model, q, "q", what)
    qd = model._zero_v if qd is None else _state(model, qd, "qd", what)
    # A and Adot qd do not depend on targets: those two bind None defaults at q
    q0 = q if isinstance(q_bound, str) else q_bound
    rows, params = _table(model, constraints, q0, "q_bound")
    k = int(rows[:, 2].sum())
    terms = np.empty((k, model.nv)), np.empty(k), np.empty(k)
    status = constraint_terms_kernel(model._ibuf, model._fbuf, rows, params, q, qd, *terms)
    arguments = {"q": q, "qd": qd, "q_bound": q0}
    if status:
        checks.raise_status(status, model, what, term, arguments)
    return checks.check_result(terms[_TERMS.index(term)], what, term, arguments)


def constraint_jacobian(model, q, constraints):
    """A(q): (k, nv) the constraints' rows stacked in order, A qd = 0 on the motion.

    q: (nq,) configuration; constraints: one constraint object or a sequence
    (opendyn.multibody.constraint_objects). Row units and frames: a point's rows are its world
    velocity per unit qd (world axes, m/s), a plane's the normal velocity, a FixedPose's the twist
    of frame b relative to frame a in frame b's axes (angular first), a JointCoupling's its
    matrix. On a floating base the first 6 columns are per unit base body twist (omega_b, v_b).
    Targets do not enter A, so None targets are simply bound at q.
    """
    checks.check_model(model, "constraint_jacobian")
    return _term(model, q, None, constraints, "q", "constraint_jacobian", "A")


def constraint_drift(model, q, qd, constraints):
    """Adot(q, qd) qd: (k,) the time derivative of A qd at qdd = 0, without gravity, so that
    d/dt (A qd) = A qdd + Adot qd. For a point: its classical acceleration in world axes
    (m/s^2); for a FixedPose: the rate of the relative twist (frame b axes, angular first);
    0 for a JointCoupling.

    q: (nq,) configuration, qd: (nv,) velocity (on a floating base qdd is the rate of the base
    body twist); constraints: one constraint object or a sequence. Targets do not enter, so
    None targets are bound at q.
    """
    checks.check_model(model, "constraint_drift")
    return _term(model, q, qd, constraints, "q", "constraint_drift", "Adot_qd")


def constraint_error(model, q, constraints, q_bound=None):
    """phi(q): (k,) the constraints' position errors, d/dt phi = A qd (for a FixedPose where
    phi = 0): p - target, n . p - offset, p_a - p_b (m, world axes), log(T_ab*^-1 T_ab) (rad, m;
    frame b axes, angular first), C (q (-) q_ref) = C difference(model, q_ref, q).

    q: (nq,) configuration; constraints: one constraint object or a sequence;
    q_bound: (nq,) the configuration at which a None target / offset / T_ab / q_ref is bound.
    A None default without q_bound raises ValueError naming the constraint and the field.
    """
    checks.check_model(model, "constraint_error")
    return _term(model, q, None, constraints, q_bound, "constraint_error", "phi")


def constrained_forward_dynamics(
    model, q, qd, tau, constraints=None, *, A=None, Adot_qd=None, gravity=None, f_tip=None
):
    """(qdd, lam): forward dynamics under A(q) qd = 0,
        M qdd + h + A^T lam = tau,   A qdd + Adot qd = 0,
        lam = (A M^-1 A^T)^+ (A M^-1 (tau - h) + Adot qd),  qdd = M^-1 (tau - h - A^T lam).

    Args:
      q: (nq,) configuration; qd, tau: (nv,) single state (rad or m, rad/s or m/s, N m or N;
        a floating base's body twist and the wrench on it in its frame, angular first).
      constraints: constraint objects (opendyn.multibody.constraint_objects), OR
      A, Adot_qd: a general (k, nv) constraint matrix and its (k,) drift Adot qd; exactly one of
        `constraints` and `A` (with `Adot_qd`).
      gravity: optional (3,) world-frame gravity (m/s^2); f_tip: optional {frame: (6,) wrench
        (m, f) the frame applies to the environment, in its own coordinates}, as in
        forward_dynamics.
    Returns qdd (nv,) and lam (k,), the generalized constraint force the robot applies to the
    constraints (for a point constraint: the force in N, world axes, that the point pushes with;
    for a FixedPose: the wrench (m, f) frame b applies, in frame b's coordinates). For
    rank-deficient A, lam is the minimum-norm solution (module docstring).
    Raises SingularMassMatrixError when M is singular.
    """
    what = "constrained_forward_dynamics"
    checks.check_model(model, what)
    if (constraints is None) == (A is None):
        raise ValueError(
            f"{what}: give exactly one of `constraints` (constraint objects) and `A` (a (k, nv) "
            f"matrix, with its Adot_qd), got {'both' if A is not None else 'neither'}"
        )
    if A is None and Adot_qd is not None:
        raise ValueError(f"{what}: Adot_qd goes with A; with `constraints` it is computed")
    if A is not None and Adot_qd is None:
        raise ValueError(f"{what}: A needs its drift Adot_qd ((k,) = d/dt (A) qd)")
    q = _configuration(model, q, "q", what)
    qd = _state(model, qd, "qd", what)
    tau = _state(model, tau, "tau", what)
    loads = checks.loads(model, gravity, f_tip)
    if constraints is not None:
        rows, params = _table(model, constraints, q, "q")
        k = int(rows[:, 2].sum())
        qdd, lam = np.empty(model.nv), np.empty(k)
        status = constrained_forward_kernel(
            model._ibuf,
            model._fbuf,
            rows,
            params,
            NO_STABILISATION,
            q,
            qd,
            tau,
            loads,
            np.zeros(0),
            qdd,
            lam,
        )
    else:
        A = _matrix_A(model, A, what)
        gamma = _vector_k(Adot_qd, A.shape[0], "Adot_qd", what)
        rhs = np.empty(model.nv)
        rnea_kernel(model._ibuf, model._fbuf, model._work, q, qd, model._zero_v, loads, rhs)
        rhs = tau - rhs
        M = mass_matrix(model, q)
        qdd, lam = np.empty(model.nv), np.empty(A.shape[0])
        status = constrained_solve_kernel(M, rhs, A, gamma, qdd, lam)
    arguments = {
        "q": q,
        "qd": qd,
        "tau": tau,
        "A": A,
        "Adot_qd": Adot_qd,
        "gravity": gravity,
        "f_tip": f_tip,
    }
    if status:
        checks.raise_status(status, model, what, "qdd", arguments)
    return (
        checks.check_result(qdd, what, "qdd", arguments),
        checks.check_result(lam, what, "lam", arguments),
    )


def _pseudo_inverse(G):
    """G^+ of a symmetric positive semi-definite G, with the cutoff of pseudo_solve."""
    k = G.shape[0]
    E, e = np.empty((k, k)), np.empty(k)
    symmetric_eigen(np.array(0.5 * (G + G.T), dtype=np.float64), E, e)
    if k == 0 or not e.max() > 0.0:
        return np.zeros((k, k))
    keep = e > RANK_RTOL * e.max()
    return (E[:, keep] / e[keep]) @ E[:, keep].T


def _projection(model, q, A, what):
    """P, G^+ and M^-1 for the checked (q, A)."""
    M = mass_matrix(model, q)
    try:
        L = np.linalg.cholesky(M)
    except np.linalg.LinAlgError:
        raise checks.singular_mass_matrix(model, q, what) from None
    M_inv = np.linalg.solve(L.T, np.linalg.solve(L, np.eye(model.nv)))
    M_inv = 0.5 * (M_inv + M_inv.T)
    G_pinv = _pseudo_inverse(A @ M_inv @ A.T)
    P = np.eye(model.nv) - A.T @ G_pinv @ A @ M_inv
    return P, G_pinv, M_inv


def constraint_projection(model, q, A):
    """P(q) = I - A^T (A M^-1 A^T)^+ A M^-1: (nv, nv), so that P tau = P (M qdd + h) on the
    constrained motion (constrained inverse dynamics). P A^T = 0 (P removes the torques the
    constraints absorb), P^2 = P, A M^-1 P = 0, and P M = M - A^T G^+ A is symmetric.

    q: (nq,) configuration; A: (k, nv) constraint matrix (e.g. constraint_jacobian). For
    rank-deficient A, (A M^-1 A^T)^+ is the pseudo-inverse (module docstring).
    """
    what = "constraint_projection"
    checks.check_model(model, what)
    q = _configuration(model, q, "q", what)
    A = _matrix_A(model, A, what)
    return checks.check_result(_projection(model, q, A, what)[0], what, "P", {"q": q, "A": A})


def constrained_inverse_dynamics(model, q, qd, qdd, A, lam=None, gravity=None):
    """tau (nv,): the joint torques that produce qdd under the constraints A qd = 0.

    lam None: tau = P (M qdd + h), the torque with no part that the constraints absorb
      (A M^-1 tau = 0); the constraints then carry lam_P = -(A M^-1 A^T)^+ A M^-1 (M qdd + h).
    lam (k,) given: tau = P (M qdd + h) + A^T (lam - lam_P) = M qdd + h + A^T lam, the torque
      that produces qdd while the constraints carry exactly lam.
    Either way constrained_forward_dynamics(tau) gives back qdd (and lam_P or lam) when qdd is
    consistent: A qdd + Adot qd = 0.

    q: (nq,) configuration; qd, qdd: (nv,); A: (k, nv); lam: (k,) constraint force as returned by
    constrained_forward_dynamics; gravity: optional (3,) world-frame gravity (m/s^2).
    """
    what = "constrained_inverse_dynamics"
    checks.check_model(model, what)
    q = _configuration(model, q, "q", what)
    qd = _state(model, qd, "qd", what)
    qdd = _state(model, qdd, "qdd", what)
    A = _matrix_A(model, A, what)
    if lam is not None:
        lam = _vector_k(lam, A.shape[0], "lam", what)
    arguments = {"q": q, "qd": qd, "qdd": qdd, "A": A, "lam": lam, "gravity": gravity}
    tau_free = np.empty(model.nv)
    status = rnea_kernel(
        model._ibuf,
        model._fbuf,
        model._work,
        q,
        qd,
        qdd,
        checks.loads(model, gravity, None),
        tau_free,
    )
    if status:
        checks.raise_status(status, model, what, "tau", arguments)
    P, G_pinv, M_inv = _projection(model, q, A, what)
    tau = P @ tau_free
    if lam is not None:
        lam_P = -G_pinv @ (A @ (M_inv @ tau_free))
        tau = tau + A.T @ (lam - lam_P)
    return checks.check_result(tau, what, "tau", arguments)


def constraint_wrench(model, q, frame, A, lam):
    """F_tip = J_b^-T A^T lam: (6,) the wrench (m, f) the frame applies to the constraint, in
    the frame's coordinates (N m, N), so that J_b^T F_tip = A^T lam (the seed's J^T F_tip =
    A^T lam); J_b is the frame's body Jacobian.

    q: (nq,) configuration; frame: a frame name; A: (k, nv); lam: (k,) (as from
    constrained_forward_dynamics). Raises ValueError when J_b is not square (nv != 6) or not
    invertible at q (a singular configuration), saying so.
    """
    what = "constraint_wrench"
    checks.check_model(model, what)
    q = _configuration(model, q, "q", what)
    A = _matrix_A(model, A, what)
    lam = _vector_k(lam, A.shape[0], "lam", what)
    J_b = jacobian(model, q, frame, expressed_in="body")
    if model.nv != 6:
        raise ValueError(
            f"{what}: J_b of frame {frame!r} is 6 x {model.nv}, not square: F_tip = J_b^-T A^T "
            f"lam needs exactly 6 velocity coordinates (model {model.name!r} has nv={model.nv})"
        )
    sv = np.linalg.svd(J_b, compute_uv=False)
    if not sv[-1] > 1e-10 * sv[0]:
        raise ValueError(
            f"{what}: J_b of frame {frame!r} is not invertible at this q (singular values "
            f"{sv}): the frame cannot move in every direction, so F_tip is not determined"
        )
    F_tip = np.linalg.solve(J_b.T, A.T @ lam)
    return checks.check_result(F_tip, what, "F_tip", {"q": q, "A": A, "lam": lam})


__all__ = [
    "FIXED_POSE",
    "JOINT_COUPLING",
    "POINT_ON_PLANE",
    "POINT_TO_POINT",
    "POINT_TO_WORLD",
    "RANK_RTOL",
    "constrained_forward_dynamics",
    "constrained_forward_kernel",
    "constrained_inverse_dynamics",
    "constrained_solve_kernel",
    "constrained_solve_rank_kernel",
    "constraint_drift",
    "constraint_error",
    "constraint_jacobian",
    "constraint_projection",
    "constraint_table",
    "constraint_terms_kernel",
    "constraint_wrench",
]
