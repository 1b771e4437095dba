"""The Coriolis matrix C(q, v) and the Christoffel symbols Gamma(q):

    C = sum_i J_i^T (G_i Jdot_i + B_i(V_i) J_i),
    B(V) = 1/2 (G ad_V - ad_V^T G) - 1/2 X(G V),    X(F) W = ad_W^T F,
    Gamma[i, j, k] = 1/2 (dC_ij/dv_k + dC_ik/dv_j)

over the bodies i, with J_i body i's Jacobian in its own frame {i} (6 x nv), V_i = J_i v its
twist and G_i its spatial inertia (constant in {i}). For F = (m, f), X(F) = [[ [m], [f] ],
[ [f], 0 ]] is skew, so B is skew and B(V) V = -ad_V^T G V. Hence
    C v = sum_i J_i^T (G_i Jdot_i v - ad_{V_i}^T G_i V_i) = c(q, v)   (RNEA with vdot = 0),
    Mdot - 2C = sum_i (Jdot_i^T G_i J_i - J_i^T G_i Jdot_i - 2 J_i^T B_i J_i)   is skew.
This holds for any joint, a free base included, where v's first six entries are the base's
body twist (quasi-velocities, not derivatives of coordinates); it is the choice of Pinocchio's
computeCoriolisMatrix (Inertia::variation and the force cross matrix).

Computed in the world frame {s}. A column of any body's Jacobian there is the space axis of one
joint's motion, S_k = mult_k Ad_{T_sk} s_k (s_k a row of S_k in {k}), whichever body's
Jacobian holds it, and dS_k/dt = ad_{V_k} S_k with V_k the space twist of body k. The world
inertias Gs_i = Ad_{T_is}^T G_i Ad_{T_is} and Ad_{T_is}^T B_i Ad_{T_is} = B(V_s,i) at Gs_i;
with Jdot_i = Ad_{T_is} (d/dt J_s,i - ad_{V_s,i} J_s,i) this gives
    C = sum_i J_s,i^T (Gs_i dS + Bs_i J_s,i),
    Bs_i = B(V_s,i) - Gs_i ad_{V_s,i} = -1/2 (Gs_i ad_V + ad_V^T Gs_i) - 1/2 X(Gs_i V),  V = V_s,i.
For a rigid-body inertia G = [[I, [h]], [[h]^T, m 1]] (h = m c) and V = (w, u), with the
momentum G V = (I w + h x u, m u - h x w) = (p_ang, p_lin), the blocks multiply out to
    Bs = [[K, 0], [-[p_lin], 0]],   K = -1/2 (I [w] - [w] I + [h][u] + [u][h] + [p_ang]):
only the angular columns, 6 x 3.
Body i's Jacobian holds the columns of the joints from the root to i, so a pair of joints a, b
meets in the bodies below both; with the composites of a backward pass, tips to base,
    Gc_b = sum over the subtree of b of Gs_i,        Bc_b = the same sum of Bs_i,
    C[a, b] = S_a^T (Gc_b dS_b + Bc_b S_b)   for a on the path from the root to b (a = b too),
    C[b, a] = S_b^T (Gc_b dS_a + Bc_b S_a)   for a strictly above b,
and 0 for joints on different branches: O(n d) for a tree of n bodies and depth d.

The Christoffel symbols: C is linear in v, C(q, v) = sum_k v_k C(q, e_k), so
Gamma[:, j, k] = 1/2 (C(e_k)[:, j] + C(e_j)[:, k]), symmetric in j, k, with v^T Gamma_i v = c_i:
one kinematic pass and nv passes of the velocity terms.

Fixed and floating bases. When every coordinate is a joint coordinate (v = qd, fixed base),
C(q, v) w = C(q, w) v, so C[i, j] = sum_k Gamma[i, j, k] qd_k and Gamma are the Christoffel
symbols of the first kind, 1/2 (dM_ij/dq_k + dM_ik/dq_j - dM_jk/dq_i) (Lynch & Park, Section
8.1.2). With a free joint that contraction does not hold, and no C with Mdot - 2C skew is the
contraction of a symmetric Gamma: for one free rigid body M = G is constant and
c = -ad_V^T G V, whose symmetric Gamma gives C_Gamma(V) W = -1/2 (ad_V^T G W + ad_W^T G V) and
W^T C_Gamma(V) W = -1/2 (ad_V W)^T G W, which is not zero (V = (e_1, 0), W = (e_2 + e_3, 0),
G = diag(I_1, I_2, I_3, m, m, m): (I_2 - I_3) / 2), while Mdot - 2 C_Gamma = -2 C_Gamma would
have to be skew.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .._runtime.arrays import all_finite, fill, result_status, zero_matrix
from .._runtime.kernel_cache import BATCH, INLINE, JIT
from .._runtime.status import Status
from ..multibody.joints import configuration_status
from ..multibody.layout import body_count, dof_count, spatial_inertias, tree
from ..multibody.work_views import (
    coriolis_terms,
    joint_vectors,
    new_work,
    scratch_rows,
    skew_scratch,
    temp_vectors,
    world_poses,
)
from ..spatial.compiled import ad_twist, add_inertia_to_parent, dot6, mat6_vec
from . import checks
from .kinematics import forward_kinematics, place_space_axes


@njit(**JIT)
def space_axes_and_inertias(ibuf, fbuf, work, q):
    """At q, for every body i, in the work buffer's CoriolisTerms: S_s[i, k] = mult_i Ad_{T_si}
    S_i[k] for its joint's rows k < nv_i; G_s[i] = Ad_{T_is}^T G_i Ad_{T_is}; Gc[i] = the sum
    of G_s over the subtree of i (all in the world frame)."""
    body_tree = tree(ibuf, fbuf)
    parent = body_tree.parent
    G = spatial_inertias(ibuf, fbuf)
    nb = parent.shape[0]
    terms = coriolis_terms(work, nb)
    S_s, G_s, Gc = terms.S_s, terms.G_s, terms.Gc
    forward_kinematics(ibuf, fbuf, work, q)
    R_s, p_s = world_poses(work, nb)
    scratch = scratch_rows(work, nb, dof_count(ibuf))
    place_space_axes(body_tree, R_s, p_s, S_s)
    for i in range(nb):
        zero_matrix(G_s[i])
        add_inertia_to_parent(R_s[i], p_s[i], G[i], G_s[i], scratch)
        for r in range(6):
            for c in range(6):
                Gc[i, r, c] = G_s[i, r, c]
    # Gc_lambda += Gc_i, tips to base (a child's index is larger than its parent's)
    for i in range(nb - 1, 0, -1):
        lam = parent[i]
        if lam >= 0:
            for r in range(6):
                for c in range(6):
                    Gc[lam, r, c] += Gc[i, r, c]


@njit(**INLINE)
def cross_matrix(x, y, z, out):
    """out (3, 3) <- [u], the cross-product matrix of u = (x, y, z): [u] a = u x a."""
    out[0, 0], out[0, 1], out[0, 2] = 0.0, -z, y
    out[1, 0], out[1, 1], out[1, 2] = z, 0.0, -x
    out[2, 0], out[2, 1], out[2, 2] = -y, x, 0.0


@njit(**JIT)
def velocity_terms(ibuf, fbuf, work, v):
    """At velocity v, for every body i (world frame), in the work buffer's CoriolisTerms (with
    S_s and G_s from space_axes_and_inertias): V_s[i] = V_s[lambda] + sum_k S_s[i, k]
    v[iv_i + k]; dS[i, k] = ad_{V_s[i]} S_s[i, k], the rate of the axis S_s[i, k]; Bc[i] (6, 3)
    = the angular columns of the sum over the subtree of i of Bs = -1/2 (G ad_V + ad_V^T G)
    - 1/2 X(G V) at (G_s, V_s) (its linear columns are 0: module docstring).

    idle[i]: V_s = 0 on the path from the root to i and in the subtree of i, so that dS = 0 on
    that path and Bc[i] = 0: body i adds nothing to C (the unit velocities of
    christoffel_kernel leave most bodies idle)."""
    body_tree = tree(ibuf, fbuf)
    parent, nv_j, iv = body_tree.parent, body_tree.nv_j, body_tree.iv
    nb = parent.shape[0]
    terms = coriolis_terms(work, nb)
    S_s, G_s, V_s, dS = terms.S_s, terms.G_s, terms.V_s, terms.dS
    Bc, idle, still = terms.Bc, terms.idle, terms.still
    P = temp_vectors(work, nb, v.shape[0])[0]
    # [w], [u], [h], [p_ang] of the body at hand
    sk = skew_scratch(work, nb, v.shape[0])
    W, U, H, P_ang = sk[0], sk[1], sk[2], sk[3]
    # forward: idle[i] <- V_s = 0 from the root to i; still[i] <- V_s[i] = 0 (flags 1.0, 0.0)
    for i in range(nb):
        lam = parent[i]
        for r in range(6):
            V_s[i, r] = 0.0 if lam < 0 else V_s[lam, r]
        for k in range(nv_j[i]):
            for r in range(6):
                V_s[i, r] += S_s[i, k, r] * v[iv[i] + k]
        still[i] = 1.0
        for r in range(6):
            if V_s[i, r] != 0.0:
                still[i] = 0.0
        idle[i] = 1.0 if still[i] == 1.0 and (lam < 0 or idle[lam] == 1.0) else 0.0
        if still[i] == 1.0:  # dS[i] = 0 and Bs_i = 0
            for k in range(nv_j[i]):
                fill(dS[i, k], 0.0)
            for r in range(6):
                fill(Bc[i, r], 0.0)
            continue
        for k in range(nv_j[i]):
            ad_twist(V_s[i], S_s[i, k], dS[i, k])
        # Bs = [[K, 0], [-[p_lin], 0]], K = -1/2 (I [w] - [w] I + [h][u] + [u][h] + [p_ang]),
        # with I = G[:3, :3], [h] = G[:3, 3:] and (p_ang, p_lin) = G V
        G = G_s[i]
        mat6_vec(G, V_s[i], P)
        cross_matrix(V_s[i, 0], V_s[i, 1], V_s[i, 2], W)
        cross_matrix(V_s[i, 3], V_s[i, 4], V_s[i, 5], U)
        cross_matrix(G[2, 4], G[0, 5], G[1, 3], H)
        cross_matrix(P[0], P[1], P[2], P_ang)
        for r in range(3):
            for c in range(3):
                s = P_ang[r, c]
                for k in range(3):
                    s += G[r, k] * W[k, c] - W[r, k] * G[k, c]
                    s += H[r, k] * U[k, c] + U[r, k] * H[k, c]
                Bc[i, r, c] = -0.5 * s
        cross_matrix(-P[3], -P[4], -P[5], Bc[i, 3:])
    # backward: Bc_lambda += Bc_i, and idle_lambda stays only while every subtree below is still
    # (still[i] <- the whole subtree of i is still)
    for i in range(nb - 1, 0, -1):
        lam = parent[i]
        if lam >= 0 and still[i] == 0.0:
            still[lam] = 0.0
            idle[lam] = 0.0
            for r in range(6):
                for c in range(3):
                    Bc[lam, r, c] += Bc[i, r, c]


@njit(**JIT)
def assemble(ibuf, fbuf, work, C):
    """C (nv, nv) <- C[a, b] = S_a^T (Gc_b dS_b + Bc_b S_b) for a on the path from the root to b,
    C[b, a] = S_b^T (Gc_b dS_a + Bc_b S_a) for a strictly above b (the module docstring);
    idle bodies (velocity_terms) add nothing and are skipped. S_s, Gc, dS, Bc and idle are
    the work buffer's CoriolisTerms."""
    body_tree = tree(ibuf, fbuf)
    parent, nv_j, iv = body_tree.parent, body_tree.nv_j, body_tree.iv
    terms = coriolis_terms(work, parent.shape[0])
    S_s, Gc, dS, Bc, idle = terms.S_s, terms.Gc, terms.dS, terms.Bc, terms.idle
    zero_matrix(C)
    temp = temp_vectors(work, parent.shape[0], C.shape[0])
    F, GcS, BcS = temp[0], temp[1], temp[2]
    fill(BcS, 0.0)  # Bc^T S: its linear half is 0
    for b in range(parent.shape[0]):
        if idle[b] == 1.0:
            continue
        for k in range(nv_j[b]):
            col_b = iv[b] + k
            # F = Gc_b dS_b + Bc_b S_b;  GcS = Gc_b S_b and BcS = Bc_b^T S_b for the row of b
            # (Bc_b holds the angular columns of the composite Bs, its linear ones are 0)
            mat6_vec(Gc[b], dS[b, k], F)
            mat6_vec(Gc[b], S_s[b, k], GcS)
            for r in range(6):
                for c in range(3):
                    F[r] += Bc[b, r, c] * S_s[b, k, c]
            for c in range(3):
                s = 0.0
                for r in range(6):
                    s += Bc[b, r, c] * S_s[b, k, r]
                BcS[c] = s
            a = b
            while a >= 0:
                for m in range(nv_j[a]):
                    row_a = iv[a] + m
                    C[row_a, col_b] += dot6(S_s[a, m], F)
                    if a != b:
                        C[col_b, row_a] += dot6(GcS, dS[a, m]) + dot6(BcS, S_s[a, m])
                a = parent[a]


@njit(**JIT)
def coriolis_matrix_kernel(ibuf, fbuf, work, q, v, C):
    """C (nv, nv) <- C(q, v) in O(n d), in `work` (a Data's buffer: its CoriolisTerms are left
    as this state's). Returns a Status: OK, Q_NOT_FINITE, Q_NOT_UNIT_QUATERNION, QD_NOT_FINITE
    or RESULT_NOT_FINITE."""
    status = configuration_status(ibuf, q)
    if status:
        return status
    if not all_finite(v):
        return Status.QD_NOT_FINITE.value
    space_axes_and_inertias(ibuf, fbuf, work, q)
    velocity_terms(ibuf, fbuf, work, v)
    assemble(ibuf, fbuf, work, C)
    return result_status(C)


@njit(**JIT)
def christoffel_kernel(ibuf, fbuf, work, q, C_e, Gamma):
    """Gamma (nv, nv, nv) <- Gamma[:, j, k] = 1/2 (C(e_k)[:, j] + C(e_j)[:, k]) at q, in
    `work` (a Data's buffer), with C_e (nv, nv, nv) the scratch for C(e_k).
    Returns a Status: OK, Q_NOT_FINITE, Q_NOT_UNIT_QUATERNION or RESULT_NOT_FINITE."""
    status = configuration_status(ibuf, q)
    if status:
        return status
    nb, nv = body_count(ibuf), Gamma.shape[0]
    space_axes_and_inertias(ibuf, fbuf, work, q)
    # C_e[k] = C(e_k), then Gamma[i, j, k] = 1/2 (C_e[k, i, j] + C_e[j, i, k])
    _, _, e_k = joint_vectors(work, nb, nv)
    for k in range(nv):
        e_k[k] = 1.0
        velocity_terms(ibuf, fbuf, work, e_k)
        assemble(ibuf, fbuf, work, C_e[k])
        e_k[k] = 0.0
    for i in range(nv):
        for j in range(nv):
            for k in range(nv):
                Gamma[i, j, k] = 0.5 * (C_e[k, i, j] + C_e[j, i, k])
    return result_status(Gamma)


@njit(**BATCH)
def christoffel_batch_kernel(ibuf, fbuf, q, v, matrix, symbols, out, status, start, stop):
    """Coriolis matrices (q, v) or Christoffel symbols (q; v unused) over rows [start, stop), as
    the compile-time switches (matrix, symbols) say: the one that is not None (only it is
    compiled). The rows work in a buffer of their own."""
    nv = out.shape[1]
    work = new_work(body_count(ibuf), nv)
    C_e = np.empty((nv, nv, nv) if symbols is not None else (0, 0, 0))
    for n in range(start, stop):
        if matrix is not None:
            status[n] = coriolis_matrix_kernel(ibuf, fbuf, work, q[n], v[n], out[n])
        if symbols is not None:
            status[n] = christoffel_kernel(ibuf, fbuf, work, q[n], C_e, out[n])


def _run(model, q, v, what, data):
    """C(q, v), or Gamma(q) when v is None, for a single state or a batch; with data (single
    states), the Data's C or Gamma."""
    work = checks.work_of(model, data, what)
    matrix = v is not None
    if matrix:
        (q, v), batch = checks.as_states(model, q, ("qd", v))
    else:
        q = checks.as_q(model, q)
        batch = q.ndim == 2
    result, arguments = ("C", {"q": q, "qd": v}) if matrix else ("Gamma", {"q": q})
    nv = model.nv
    if not batch:
        if matrix:
            out = np.empty((nv, nv)) if data is None else data.C
            status = coriolis_matrix_kernel(model._ibuf, model._fbuf, work, q, v, out)
        else:
            out = np.empty((nv, nv, nv)) if data is None else data.Gamma
            C_e = np.empty((nv, nv, nv)) if data is None else data._C_e
            status = christoffel_kernel(model._ibuf, model._fbuf, work, q, C_e, out)
        if status:
            checks.raise_status(status, model, what, result, arguments)
        return out
    checks.single_state_only(data, what)
    n = q.shape[0]
    # C-contiguous rows out[n]: a strided view would make numba compile the kernel again
    out = np.empty((n, nv, nv) if matrix else (n, nv, nv, nv))
    inputs = (q, v if matrix else q, *((True, None) if matrix else (None, True)))
    return checks.run_batch(model, christoffel_batch_kernel, inputs, out, what, result, arguments)


def christoffel_symbols(model, q, data=None):
    """Gamma(q): (nv, nv, nv), Gamma[i, j, k] = 1/2 d^2 c_i / dv_j dv_k, the symmetric
    quadratic form of the Coriolis forces: symmetric in j, k, with c_i(q, v) = sum_jk
    Gamma[i, j, k] v_j v_k (N m or N per (rad/s or m/s)^2).

    q: (nq,) or a batch (N, nq) -> (nv, nv, nv) or (N, nv, nv, nv).
    Fixed base: the Christoffel symbols of the first kind,
    1/2 (dM_ij/dq_k + dM_ik/dq_j - dM_jk/dq_i), and C[i, j] = sum_k Gamma[i, j, k] qd_k.
    Floating base: v's base twist is no derivative of coordinates, and that contraction is not
    coriolis_matrix (it is not even Mdot - 2C skew-compatible; see the module docstring: for
    one free rigid body the contraction C_Gamma(V) W = -1/2 (ad_V^T G W + ad_W^T G V) has
    W^T C_Gamma W = -1/2 (ad_V W)^T G W != 0 while Mdot = 0).
    data: optional Data of this model (single configurations): returns data.Gamma, allocating
    nothing.
    """
    checks.check_model(model, "christoffel_symbols")
    return _run(model, q, None, "christoffel_symbols", data)


def coriolis_matrix(model, q, qd, data=None):
    """C(q, qd): (nv, nv) Coriolis matrix with C qd = c(q, qd) (coriolis_forces) and
    Mdot - 2C skew-symmetric; Pinocchio's computeCoriolisMatrix, any base.

    q: (nq,), qd: (nv,) (a floating base's twist (omega_b, v_b) in its own frame first), or
    batches (N, nq), (N, nv) -> (N, nv, nv). Units: N m s (or N s) per joint.
    Fixed base: C[i, j] = sum_k Gamma[i, j, k] qd_k with Gamma = christoffel_symbols(model, q).
    Floating base: C is linear in qd and Gamma[i, j, k] = 1/2 (dC_ij/dqd_k + dC_ik/dqd_j), but
    C != sum_k Gamma[:, :, k] qd_k (module docstring: no C with Mdot - 2C skew is such a
    contraction for a free body).
    data: optional Data of this model (single states): returns data.C, allocating nothing;
    data.S_s, data.V_s, ... hold the terms it is made of.
    """
    checks.check_model(model, "coriolis_matrix")
    return _run(model, q, qd, "coriolis_matrix", data)
