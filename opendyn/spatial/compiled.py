"""Spatial algebra in compiled form: the 3x3-block forms of Ad_T and ad_V on twists, wrenches and
spatial inertias, the compiled twin of opendyn.spatial.algebra (the numpy reference).

Pose of body i in its parent: (R, p) = (R_{lambda i}, p_{lambda i}). Then, angular first,
  twist to child   Ad_{T_{i,lambda}} V  = (R^T w,  R^T (v + w x p))
  wrench to parent Ad_{T_{i,lambda}}^T F = (R m + p x (R f),  R f)
  ad_V W = (w x w_W,  v x w_W + w x v_W);   -ad_V^T F = (w x m + v x f,  w x f)
Small helpers are inlined by numba, so the kernels read like the algorithm boxes.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .._runtime.kernel_cache import INLINE, JIT


@njit(**INLINE)
def twist_to_child(R, p, V_parent, V_child):
    """V_child = Ad_{T_{i,lambda}} V_parent = (R^T w, R^T (v + w x p))."""
    w0, w1, w2 = V_parent[0], V_parent[1], V_parent[2]
    u0 = V_parent[3] + w1 * p[2] - w2 * p[1]
    u1 = V_parent[4] + w2 * p[0] - w0 * p[2]
    u2 = V_parent[5] + w0 * p[1] - w1 * p[0]
    for k in range(3):
        V_child[k] = R[0, k] * w0 + R[1, k] * w1 + R[2, k] * w2
        V_child[3 + k] = R[0, k] * u0 + R[1, k] * u1 + R[2, k] * u2


@njit(**INLINE)
def add_wrench_to_parent(R, p, F_child, F_parent):
    """F_parent += Ad_{T_{i,lambda}}^T F_child = (R m + p x (R f), R f)."""
    m0 = R[0, 0] * F_child[0] + R[0, 1] * F_child[1] + R[0, 2] * F_child[2]
    m1 = R[1, 0] * F_child[0] + R[1, 1] * F_child[1] + R[1, 2] * F_child[2]
    m2 = R[2, 0] * F_child[0] + R[2, 1] * F_child[1] + R[2, 2] * F_child[2]
    f0 = R[0, 0] * F_child[3] + R[0, 1] * F_child[4] + R[0, 2] * F_child[5]
    f1 = R[1, 0] * F_child[3] + R[1, 1] * F_child[4] + R[1, 2] * F_child[5]
    f2 = R[2, 0] * F_child[3] + R[2, 1] * F_child[4] + R[2, 2] * F_child[5]
    F_parent[0] += m0 + p[1] * f2 - p[2] * f1
    F_parent[1] += m1 + p[2] * f0 - p[0] * f2
    F_parent[2] += m2 + p[0] * f1 - p[1] * f0
    F_parent[3] += f0
    F_parent[4] += f1
    F_parent[5] += f2


@njit(**INLINE)
def ad_twist(V, W, out):
    """out = ad_V W = (w x w_W, v x w_W + w x v_W)  (the Lie bracket [V, W])."""
    out[0] = V[1] * W[2] - V[2] * W[1]
    out[1] = V[2] * W[0] - V[0] * W[2]
    out[2] = V[0] * W[1] - V[1] * W[0]
    out[3] = V[4] * W[2] - V[5] * W[1] + V[1] * W[5] - V[2] * W[4]
    out[4] = V[5] * W[0] - V[3] * W[2] + V[2] * W[3] - V[0] * W[5]
    out[5] = V[3] * W[1] - V[4] * W[0] + V[0] * W[4] - V[1] * W[3]


@njit(**INLINE)
def add_neg_ad_transpose(V, P, out):
    """out += -ad_V^T P = (w x P_m + v x P_f, w x P_f) for a momentum or wrench P."""
    out[0] += V[1] * P[2] - V[2] * P[1] + V[4] * P[5] - V[5] * P[4]
    out[1] += V[2] * P[0] - V[0] * P[2] + V[5] * P[3] - V[3] * P[5]
    out[2] += V[0] * P[1] - V[1] * P[0] + V[3] * P[4] - V[4] * P[3]
    out[3] += V[1] * P[5] - V[2] * P[4]
    out[4] += V[2] * P[3] - V[0] * P[5]
    out[5] += V[0] * P[4] - V[1] * P[3]


@njit(**INLINE)
def mat6_vec(G, V, out):
    """out = G V for a (6, 6) matrix."""
    for r in range(6):
        s = 0.0
        for c in range(6):
            s += G[r, c] * V[c]
        out[r] = s


@njit(**INLINE)
def inertia_times_motion(I, s, out):
    """out = I s for a (6, 6) inertia and a motion axis s (a row of a joint's S), reading only
    the columns of I where s is not zero (three for a revolute or prismatic axis)."""
    for r in range(6):
        out[r] = 0.0
    for c in range(6):
        if s[c] != 0.0:
            for r in range(6):
                out[r] += I[r, c] * s[c]


@njit(**JIT)
def dot6(a, b):
    """a . b for 6-vectors (e.g. the power F . A of a wrench on a screw axis)."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3] + a[4] * b[4] + a[5] * b[5]


@njit(**INLINE)
def add_inertia_to_parent(R, p, I_child, I_parent, S):
    """I_parent += Ad_{T_{i,lambda}}^T I_child Ad_{T_{i,lambda}} for a symmetric (6, 6) inertia.

    Rotate the blocks of I_child = [[K, B], [B^T, C]] into the parent's axes (K' = R K R^T,
    B' = R B R^T, C' = R C R^T, each as R (X R^T)), then shift the reference point by p:
      C_p = C',   B_p = B' + [p] C',   K_p = K' - B'[p] + [p] B'^T - [p] C' [p].
    S is (9, 6) scratch: K', B', C' in rows 0-2, 3-5, 6-8 of columns 0-2; X R^T in rows 0-2
    and [p] C' in rows 3-5 of columns 3-5.
    """
    for blk in range(3):
        br = 0 if blk < 2 else 3
        bc = 0 if blk == 0 else 3
        for k in range(3):
            for c in range(3):
                S[k, 3 + c] = (
                    I_child[br + k, bc] * R[c, 0]
                    + I_child[br + k, bc + 1] * R[c, 1]
                    + I_child[br + k, bc + 2] * R[c, 2]
                )
        for r in range(3):
            for c in range(3):
                S[3 * blk + r, c] = R[r, 0] * S[0, 3 + c] + R[r, 1] * S[1, 3 + c] + R[r, 2] * S[
                    2, 3 + c
                ]
    P = ((0.0, -p[2], p[1]), (p[2], 0.0, -p[0]), (-p[1], p[0], 0.0))
    for r in range(3):
        for c in range(3):
            S[3 + r, 3 + c] = P[r][0] * S[6, c] + P[r][1] * S[7, c] + P[r][2] * S[8, c]
    for r in range(3):
        for c in range(3):
            B_rc = S[3 + r, c] + S[3 + r, 3 + c]
            I_parent[r, 3 + c] += B_rc
            I_parent[3 + c, r] += B_rc
            I_parent[3 + r, 3 + c] += S[6 + r, c]
            K_rc = S[r, c]
            for k in range(3):
                K_rc += -S[3 + r, k] * P[k][c] + P[r][k] * S[3 + c, k] - S[3 + r, 3 + k] * P[k][c]
            I_parent[r, c] += K_rc


@njit(**INLINE)
def rigid_inertia_times(mass, h, I_o, V, out):
    """out = G V for G = [[I_o, [h]], [[h]^T, m 1]]: (I_o w + h x v, m v - h x w)."""
    w0, w1, w2, v0, v1, v2 = V[0], V[1], V[2], V[3], V[4], V[5]
    out[0] = I_o[0, 0] * w0 + I_o[0, 1] * w1 + I_o[0, 2] * w2 + h[1] * v2 - h[2] * v1
    out[1] = I_o[1, 0] * w0 + I_o[1, 1] * w1 + I_o[1, 2] * w2 + h[2] * v0 - h[0] * v2
    out[2] = I_o[2, 0] * w0 + I_o[2, 1] * w1 + I_o[2, 2] * w2 + h[0] * v1 - h[1] * v0
    out[3] = mass * v0 - h[1] * w2 + h[2] * w1
    out[4] = mass * v1 - h[2] * w0 + h[0] * w2
    out[5] = mass * v2 - h[0] * w1 + h[1] * w0


@njit(**INLINE)
def add_rigid_inertia_to_parent(R, p, mass, h, I_o, mass_p, h_p, I_p):
    """(mass_p, h_p, I_p) += the rigid-body inertia (mass, h, I_o) of {i} expressed in {lambda}.

    With u = R h:  m' = m,  h' = u + m p,
    I' = R I_o R^T - ([u][p] + [p][u]) - m [p][p]
       = R I_o R^T - (p u^T + u p^T) + 2 (u . p) 1 - m (p p^T - |p|^2 1).
    I_o R^T is kept in registers (a 3 x 3 tuple), not in a scratch array: stores to a scratch
    that may alias I_p would have to be read back.
    """
    u0 = R[0, 0] * h[0] + R[0, 1] * h[1] + R[0, 2] * h[2]
    u1 = R[1, 0] * h[0] + R[1, 1] * h[1] + R[1, 2] * h[2]
    u2 = R[2, 0] * h[0] + R[2, 1] * h[1] + R[2, 2] * h[2]
    u = (u0, u1, u2)
    mass_p[0] += mass
    for r in range(3):
        h_p[r] += u[r] + mass * p[r]
    diag = 2.0 * (u0 * p[0] + u1 * p[1] + u2 * p[2]) + mass * (
        p[0] * p[0] + p[1] * p[1] + p[2] * p[2]
    )
    # IR[k][c] = (I_o R^T)[k, c] = I_o[k] . R[c]
    IR = (
        row_times_rows(I_o, 0, R),
        row_times_rows(I_o, 1, R),
        row_times_rows(I_o, 2, R),
    )
    for r in range(3):
        for c in range(r, 3):
            v = (
                R[r, 0] * IR[0][c]
                + R[r, 1] * IR[1][c]
                + R[r, 2] * IR[2][c]
                - p[r] * u[c]
                - u[r] * p[c]
                - mass * p[r] * p[c]
            )
            if r == c:
                I_p[r, r] += v + diag
            else:
                I_p[r, c] += v
                I_p[c, r] += v


@njit(**INLINE)
def row_times_rows(A, k, B):
    """(A[k] . B[0], A[k] . B[1], A[k] . B[2]): row k of A B^T for 3 x 3 A, B."""
    a0, a1, a2 = A[k, 0], A[k, 1], A[k, 2]
    return (
        a0 * B[0, 0] + a1 * B[0, 1] + a2 * B[0, 2],
        a0 * B[1, 0] + a1 * B[1, 1] + a2 * B[1, 2],
        a0 * B[2, 0] + a1 * B[2, 1] + a2 * B[2, 2],
    )


@njit(**INLINE)
def wrench_to_parent(R, p, F):
    """F <- Ad_{T_{i,lambda}}^T F = (R m + p x (R f), R f), in place."""
    f0 = R[0, 0] * F[3] + R[0, 1] * F[4] + R[0, 2] * F[5]
    f1 = R[1, 0] * F[3] + R[1, 1] * F[4] + R[1, 2] * F[5]
    f2 = R[2, 0] * F[3] + R[2, 1] * F[4] + R[2, 2] * F[5]
    m0 = R[0, 0] * F[0] + R[0, 1] * F[1] + R[0, 2] * F[2] + p[1] * f2 - p[2] * f1
    m1 = R[1, 0] * F[0] + R[1, 1] * F[1] + R[1, 2] * F[2] + p[2] * f0 - p[0] * f2
    m2 = R[2, 0] * F[0] + R[2, 1] * F[1] + R[2, 2] * F[2] + p[0] * f1 - p[1] * f0
    F[0], F[1], F[2], F[3], F[4], F[5] = m0, m1, m2, f0, f1, f2


# below this angle (rad), the coefficient of [w]^2 in V^-1 is its Taylor series
LOG_SERIES = 1e-2


@njit(**INLINE)
def se3_log_translation(w0, w1, w2, t, p, out):
    """out (3,) <- V^-1 p = (I - [w]/2 + ((1 - (t/2) cot(t/2)) / t^2) [w]^2) p: the translation
    part of log(T) for T = (exp([w]), p), t = |w| (MR eq. 3.92), the coefficient by its series
    1/12 + t^2/720 + t^4/30240 + t^6/1209600 below LOG_SERIES. out may not alias p."""
    if t < LOG_SERIES:
        t2 = t * t
        coef = 1.0 / 12.0 + t2 / 720.0 + t2 * t2 / 30240.0 + t2 * t2 * t2 / 1209600.0
    else:
        half = 0.5 * t
        coef = (1.0 - half * np.cos(half) / np.sin(half)) / (t * t)
    # [w] p = w x p,  [w]^2 p = w x (w x p)
    x0 = w1 * p[2] - w2 * p[1]
    x1 = w2 * p[0] - w0 * p[2]
    x2 = w0 * p[1] - w1 * p[0]
    out[0] = p[0] - 0.5 * x0 + coef * (w1 * x2 - w2 * x1)
    out[1] = p[1] - 0.5 * x1 + coef * (w2 * x0 - w0 * x2)
    out[2] = p[2] - 0.5 * x2 + coef * (w0 * x1 - w1 * x0)


@njit(**INLINE)
def log_se3(R, p, out):
    """out (6,) <- log(T), T = (R, p): (w, V^-1 p) with w = log(R), t = |w| in [0, pi] (MR eqs.
    3.91-3.92; opendyn.spatial.algebra.log_se3, the numpy reference) and V^-1 p as
    se3_log_translation gives it."""
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
        col = out[3:6]  # scratch until the translation is written
        for j in range(3):
            col[j] = (0.5 * (R[j, k] + R[k, j]) - (cos_t if j == k else 0.0)) / (1.0 - cos_t)
        norm = np.sqrt(col[0] * col[0] + col[1] * col[1] + col[2] * col[2])
        s = t / norm
        if col[0] * d0 + col[1] * d1 + col[2] * d2 < 0.0:
            s = -s
        w0, w1, w2 = s * col[0], s * col[1], s * col[2]
    out[0], out[1], out[2] = w0, w1, w2
    se3_log_translation(w0, w1, w2, t, p, out[3:6])
