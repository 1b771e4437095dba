"""Forward dynamics by the articulated-body algorithm (ABA), O(n):

    qdd = M(q)^-1 (tau - h(q, qd) - sum_frames J_b(frame)^T F_tip(frame))

Pass 1, base to tips: T_{i,lambda}, V_i = Ad V_lambda + A_i qd_i, the velocity-product
acceleration c_i = ad_{V_i} A_i qd_i, and the bias wrench pA_i = -ad_{V_i}^T G_i V_i + F_tip,i.
Pass 2, tips to base, articulated inertias IA_i (starting from G_i) and bias wrenches:
    U_i = IA_i A_i,  D_i = A_i^T U_i (+ armature_i),  u_i = tau_i - A_i^T pA_i
    Ia = IA_i - U_i U_i^T / D_i,   pa = pA_i + Ia c_i + U_i u_i / D_i
    IA_lambda += Ad^T Ia Ad,       pA_lambda += Ad^T pa
Pass 3, base to tips, dV_0 = (0, -g):
    a_i = Ad_{T_{i,lambda}} dV_lambda + c_i,   qdd_i = (u_i - U_i^T a_i) / D_i,
    dV_i = a_i + A_i qdd_i
(Featherstone, Rigid Body Dynamics Algorithms, 2008, Table 7.1; Lynch & Park, Section 8.5.)
ABA needs one coordinate per body: models with coupled (mimic) joints use CRBA + Cholesky.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ._kernels import (
    JIT,
    ad_twist,
    add_inertia_to_parent,
    add_neg_ad_transpose,
    add_wrench_to_parent,
    all_finite,
    dot6,
    fill,
    joint_transform,
    inertia_times_axis,
    mat6_vec,
    rigid_inertia_times,
    rigid_inertias,
    spatial_inertias,
    tree,
    twist_to_child,
)
from ..status import Status

SINGULAR_PIVOT = 1e-14  # D_i below this times the largest body inertia: nothing moves with i


@njit(**JIT)
def aba_kernel(ibuf, fbuf, q, qd, tau, loads, qdd, armature):
    """qdd (nv,) <- ABA at one state; loads as in rnea_kernel (dV_0, then body wrenches).
    armature: (nv,) rotor inertias added to D_i (M's diagonal), or an empty array for none.
    Returns a Status: OK, Q/QD/TAU_NOT_FINITE, or SINGULAR + k
    when joint coordinate k has no inertia moving with it (D_k ~ 0)."""
    if not all_finite(q):
        return Status.Q_NOT_FINITE.value
    if not all_finite(qd):
        return Status.QD_NOT_FINITE.value
    if not all_finite(tau):
        return Status.TAU_NOT_FINITE.value
    parent, jtype, coord, mult, offset, A, R_home, p_home = tree(ibuf, fbuf)
    G = spatial_inertias(ibuf, fbuf)
    mass, h, I_o = rigid_inertias(ibuf, fbuf)
    nb = parent.shape[0]
    R = np.empty((nb, 3, 3))
    p = np.empty((nb, 3))
    IA = np.empty((nb, 6, 6))
    vec = np.empty((5, nb, 6))
    V, c, pA, U, dV = vec[0], vec[1], vec[2], vec[3], vec[4]
    D = np.empty(nb)
    u = np.empty(nb)
    S = np.empty((9, 6))
    s = np.empty(6)
    wrenches = loads.shape[0] > 1
    rotors = armature.shape[0] > 0
    scale = 0.0
    for i in range(nb):
        for k in range(6):
            scale = max(scale, G[i, k, k])

    # pass 1: V_i, c_i = ad_{V_i} A_i qd_i, pA_i = -ad_{V_i}^T G_i V_i + F_tip,i; IA_i = G_i
    for i in range(nb):
        joint_transform(jtype[i], A[i], R_home[i], p_home[i], q[i], R[i], p[i])
        lam = parent[i]
        if lam < 0:
            fill(V[i], 0.0)
        else:
            twist_to_child(R[i], p[i], V[lam], V[i])
        for k in range(6):
            V[i, k] += A[i, k] * qd[i]
        ad_twist(V[i], A[i], c[i])
        for k in range(6):
            c[i, k] *= qd[i]
        rigid_inertia_times(mass[i], h[i], I_o[i], V[i], s)
        fill(pA[i], 0.0)
        add_neg_ad_transpose(V[i], s, pA[i])
        if wrenches:
            for k in range(6):
                pA[i, k] += loads[1 + i, k]
        for r in range(6):
            for k in range(6):
                IA[i, r, k] = G[i, r, k]

    # pass 2: articulated inertias and bias wrenches, tips to base
    for i in range(nb - 1, -1, -1):
        inertia_times_axis(jtype[i], IA[i], A[i], U[i])
        D[i] = dot6(A[i], U[i])
        if rotors:
            D[i] += armature[i]
        u[i] = tau[i] - dot6(A[i], pA[i])
        if not D[i] > SINGULAR_PIVOT * scale:
            return Status.SINGULAR.value + i
        lam = parent[i]
        if lam < 0:
            continue
        D_inv = 1.0 / D[i]
        for r in range(6):
            for k in range(6):
                IA[i, r, k] -= U[i, r] * U[i, k] * D_inv
        # pa = pA_i + Ia c_i + U_i u_i / D_i  (reuse pA[i])
        mat6_vec(IA[i], c[i], s)
        for k in range(6):
            pA[i, k] += s[k] + U[i, k] * u[i] * D_inv
        add_inertia_to_parent(R[i], p[i], IA[i], IA[lam], S)
        add_wrench_to_parent(R[i], p[i], pA[i], pA[lam])

    # pass 3: accelerations, base to tips
    for i in range(nb):
        lam = parent[i]
        twist_to_child(R[i], p[i], loads[0] if lam < 0 else dV[lam], dV[i])
        for k in range(6):
            dV[i, k] += c[i, k]
        qdd[i] = (u[i] - dot6(U[i], dV[i])) / D[i]
        for k in range(6):
            dV[i, k] += A[i, k] * qdd[i]
    return Status.OK.value
