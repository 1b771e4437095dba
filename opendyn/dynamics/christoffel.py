"""Christoffel symbols of the first kind and the Coriolis matrix:

    Gamma_ijk(q) = 1/2 (dM_ij/dq_k + dM_ik/dq_j - dM_jk/dq_i),    C_ij(q, qd) = sum_k Gamma_ijk qd_k

so c(q, qd) = C(q, qd) qd = qd^T Gamma(q) qd and Mdot - 2C is skew-symmetric (the seed notes,
"Christoffel symbols"; Lynch & Park, Section 8.1.2).

dM/dq is exact, not a finite difference. With space-frame screw axes S_i = Ad_{T_si} A_i and
composite inertias Gc_j = sum_{b >= j} Ad_{T_bs}^T G_b Ad_{T_bs} (b over the subtree of j), for
i an ancestor of j (or j itself) M_ij = S_i^T Gc_j S_j, and moving joint k turns everything
outboard of it: dS/dq_k = ad_{S_k} S, dGc/dq_k = -(ad_{S_k}^T Gc + Gc ad_{S_k}). Hence
    k ancestor of i, or k = i:       dM_ij/dq_k = 0
    i strictly above k, k <= j:      dM_ij/dq_k = (ad_{S_i} S_k)^T Gc_j S_j
    k strictly below j:              dM_ij/dq_k = -(ad_{S_k} S_i)^T Gc_k S_j
                                                  - (Gc_k S_i)^T ad_{S_k} S_j
    otherwise:                       0
"""

from __future__ import annotations

import numpy as np
from numba import njit

from . import _args
from ._kernels import (
    BATCH,
    JIT,
    ad_twist,
    add_inertia_to_parent,
    all_finite,
    dot6,
    fill,
    mat6_vec,
    run_rows,
    spatial_inertias,
    tree,
    zero_matrix,
)
from ..status import Status
from .kinematics import forward_kinematics, space_axis


@njit(**JIT)
def space_axes_and_inertias(ibuf, fbuf, q, S, Gs, Gc):
    """S[i] = Ad_{T_si} A_i (1-dof joints), Gs[i] = Ad_{T_is}^T G_i Ad_{T_is} (space frame) and the composite
    Gc[i] = sum of Gs over the subtree of i, at q. Compiled once for both kernels below."""
    body_tree = tree(ibuf, fbuf)
    parent, jtype, nv_j, iq, iv, mult, offset, axes, R_home, p_home = body_tree
    G = spatial_inertias(ibuf, fbuf)
    nb = parent.shape[0]
    R_s = np.empty((nb, 3, 3))
    p_s = np.empty((nb, 3))
    # every body: last = -1, typed int64 as the other callers' body index (a literal -1
    # would compile forward_kinematics a second time)
    forward_kinematics(body_tree, q, ibuf[1], R_s, p_s, np.int64(-1))
    scratch = np.empty((9, 6))
    for i in range(nb):
        zero_matrix(Gs[i])
        space_axis(R_s[i], p_s[i], axes[i, 0], S[i])
        add_inertia_to_parent(R_s[i], p_s[i], G[i], Gs[i], scratch)
    for i in range(nb - 1, -1, -1):
        for r in range(6):
            for c in range(6):
                Gc[i, r, c] += Gs[i, r, c]  # Gc[i] holds the children's sum already
                if parent[i] >= 0:
                    Gc[parent[i], r, c] += Gc[i, r, c]


@njit(**JIT)
def christoffel_kernel(ibuf, fbuf, q, Gamma):
    """Gamma (nv, nv, nv) <- Christoffel symbols at q. Returns a Status: OK or Q_NOT_FINITE."""
    if not all_finite(q):
        return Status.Q_NOT_FINITE.value
    parent, jtype, nv_j, iq, iv, mult, offset, axes, R_home, p_home = tree(ibuf, fbuf)
    nb, nv = parent.shape[0], Gamma.shape[0]
    S = np.empty((nb, 6))
    Gs = np.empty((nb, 6, 6))
    Gc = np.zeros((nb, 6, 6))
    space_axes_and_inertias(ibuf, fbuf, q, S, Gs, Gc)

    # above[a, b]: a is b or an ancestor of b
    above = np.zeros((nb, nb), dtype=np.bool_)
    for b in range(nb):
        a = b
        while a >= 0:
            above[a, b] = True
            a = parent[a]
    # adS[a, b] = ad_{S_a} S_b,  GcS[a, b] = Gc_a S_b
    adS = np.empty((nb, nb, 6))
    GcS = np.empty((nb, nb, 6))
    for a in range(nb):
        for b in range(nb):
            ad_twist(S[a], S[b], adS[a, b])
            mat6_vec(Gc[a], S[b], GcS[a, b])

    # dM[a, b, c] = dM_ab / dq_c in coordinates: the body terms mapped by the mimic coupling
    dM = np.zeros((nv, nv, nv))
    for j in range(nb):
        i = j
        while i >= 0:
            for k in range(nb):
                if above[k, i]:
                    continue
                if above[i, k] and above[k, j]:
                    val = dot6(adS[i, k], GcS[j, j])
                elif above[j, k]:
                    val = -dot6(adS[k, i], GcS[k, j]) - dot6(GcS[k, i], adS[k, j])
                else:
                    continue
                w = mult[i] * mult[j] * mult[k] * val
                dM[iv[i], iv[j], iv[k]] += w
                if i != j:
                    dM[iv[j], iv[i], iv[k]] += w
            i = parent[i]

    for a in range(nv):
        for b in range(nv):
            for c in range(nv):
                Gamma[a, b, c] = 0.5 * (dM[a, b, c] + dM[a, c, b] - dM[b, c, a])
    return Status.OK.value


@njit(**JIT)
def coriolis_matrix_kernel(ibuf, fbuf, q, qd, C):
    """C (nv, nv) <- sum_k Gamma[:, :, k] qd_k in O(n^2), without forming Gamma.
    Status 1/2: q/qd not finite.

    C = 1/2 (Mdot + P - P^T) with P[a, b] = d(M qd)_a / dq_b. With space twists
    V_i = V_lambda + S_i qd_i, subtree momenta H_i = sum_{b >= i} Gs_b V_b and
    B_j = sum over k strictly below j of (ad_{S_k}^T Gc_k + Gc_k ad_{S_k}) qd_k, for i <= j:
      Mdot_ij = (ad_{S_i} (V_j - V_i))^T Gc_j S_j - S_i^T B_j S_j
      P[j, i] = (Gc_j S_j)^T ad_{V_i} S_i
      P[i, j] = (ad_{S_i} S_j)^T H_j + S_i^T Gc_j ad_{V_j} S_j     (i strictly above j)
    (the dM/dq terms of the module docstring summed against qd).
    """
    if not all_finite(q):
        return Status.Q_NOT_FINITE.value
    if not all_finite(qd):
        return Status.QD_NOT_FINITE.value
    parent, jtype, nv_j, iq, iv, mult, offset, axes, R_home, p_home = tree(ibuf, fbuf)
    nb = parent.shape[0]
    S = np.empty((nb, 6))
    Gs = np.empty((nb, 6, 6))
    Gc = np.zeros((nb, 6, 6))
    space_axes_and_inertias(ibuf, fbuf, q, S, Gs, Gc)

    # forward: space twists V_i; per body Gc_i S_i, ad_{V_i} S_i, Gc_i ad_{V_i} S_i
    vec = np.zeros((6, nb, 6))
    V, H, GcS, adVS, GcadVS, BS = vec[0], vec[1], vec[2], vec[3], vec[4], vec[5]
    qd_b = np.empty(nb)
    for i in range(nb):
        qd_b[i] = mult[i] * qd[iv[i]]
        for k in range(6):
            V[i, k] = (0.0 if parent[i] < 0 else V[parent[i], k]) + S[i, k] * qd_b[i]
        mat6_vec(Gc[i], S[i], GcS[i])
        ad_twist(V[i], S[i], adVS[i])
        mat6_vec(Gc[i], adVS[i], GcadVS[i])
    # backward: H_i (subtree momentum) and D_i = X_i + sum_children D_c, with
    # X_k = (ad_{S_k}^T Gc_k + Gc_k ad_{S_k}) qd_k; B_j = sum over the children c of D_c,
    # complete when j is reached (children have larger indices)
    D = np.zeros((nb, 6, 6))
    B = np.zeros((nb, 6, 6))
    Y = np.empty((6, 6))
    e = np.zeros(6)
    col = np.empty(6)
    for i in range(nb - 1, -1, -1):
        mat6_vec(Gs[i], V[i], col)
        for k in range(6):
            H[i, k] += col[k]
        # X_i = Y + Y^T with Y = Gc_i ad_{S_i} (Gc_i is symmetric), column by column
        for c in range(6):
            fill(e, 0.0)
            e[c] = 1.0
            ad_twist(S[i], e, col)
            mat6_vec(Gc[i], col, Y[:, c])
        for r in range(6):
            for c in range(6):
                D[i, r, c] += (Y[r, c] + Y[c, r]) * qd_b[i]
        mat6_vec(B[i], S[i], BS[i])
        lam = parent[i]
        if lam >= 0:
            for r in range(6):
                H[lam, r] += H[i, r]
                for c in range(6):
                    D[lam, r, c] += D[i, r, c]
                    B[lam, r, c] += D[i, r, c]

    zero_matrix(C)
    dV = np.empty(6)
    adSS = np.empty(6)
    for j in range(nb):
        i = j
        while i >= 0:
            for k in range(6):
                dV[k] = V[j, k] - V[i, k]
            ad_twist(S[i], dV, adSS)
            Mdot = dot6(adSS, GcS[j]) - dot6(S[i], BS[j])
            P_ji = dot6(GcS[j], adVS[i])
            if i == j:
                C[iv[i], iv[i]] += mult[i] * mult[i] * 0.5 * Mdot
            else:
                ad_twist(S[i], S[j], adSS)
                P_ij = dot6(adSS, H[j]) + dot6(S[i], GcadVS[j])
                w = mult[i] * mult[j] * 0.5
                C[iv[i], iv[j]] += w * (Mdot + P_ij - P_ji)
                C[iv[j], iv[i]] += w * (Mdot + P_ji - P_ij)
            i = parent[i]
    return Status.OK.value


@njit(**BATCH)
def christoffel_batch_kernel(ibuf, fbuf, q, qd, out, status, matrix, symbols, start, stop):
    """Coriolis matrices or Christoffel symbols over rows [start, stop), as the compile-time
    switches (matrix, symbols) say: the one that is not None (only it is compiled)."""
    for n in range(start, stop):
        if matrix is not None:
            status[n] = coriolis_matrix_kernel(ibuf, fbuf, q[n], qd[n], out[n])
        if symbols is not None:
            status[n] = christoffel_kernel(ibuf, fbuf, q[n], out[n])


def _run(model, q, qd, matrix, what):
    _args.fixed_base_only(model, what)
    (q, qd), batch = _args.as_states(model, q, ("qd", qd))
    nv = model.nv
    if not batch:
        out = np.empty((nv, nv) if matrix else (nv, nv, nv))
        status = (
            coriolis_matrix_kernel(model._ibuf, model._fbuf, q, qd, out)
            if matrix
            else christoffel_kernel(model._ibuf, model._fbuf, q, out)
        )
        if status:
            _args.raise_status(status, model, what)
        return out
    # C-contiguous rows out[n]: a strided view would make numba compile the kernel again
    out = np.empty((q.shape[0], nv, nv) if matrix else (q.shape[0], nv, nv, nv))
    status = np.zeros(q.shape[0], dtype=np.int64)
    run_rows(
        christoffel_batch_kernel,
        q.shape[0],
        model._ibuf,
        model._fbuf,
        q,
        qd,
        out,
        status,
        *((True, None) if matrix else (None, True)),
    )
    _args.raise_batch_status(status, model, what)
    return out


def christoffel_symbols(model, q):
    """Gamma(q): (nv, nv, nv) Christoffel symbols of the first kind, Gamma[i, j, k] symmetric
    in j, k, with c_i = sum_jk Gamma[i, j, k] qd_j qd_k. q: (nv,) or (N, nv) -> (N, nv, nv, nv).
    """
    _args.fixed_base_only(model, "christoffel_symbols")
    q = _args.as_q(model, q)
    return _run(model, q, np.zeros_like(q), False, "christoffel_symbols")


def coriolis_matrix(model, q, qd):
    """C(q, qd): (nv, nv) Coriolis matrix C[i, j] = sum_k Gamma[i, j, k] qd_k, so that
    C qd = c(q, qd) and Mdot - 2C is skew-symmetric. q, qd: (nv,) or (N, nv) -> (N, nv, nv).
    """
    return _run(model, q, qd, True, "coriolis_matrix")
