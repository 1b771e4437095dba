"""Forward dynamics by the articulated-body algorithm (ABA), O(n):

    qdd = M(q)^-1 (tau - h(q, qd) - sum_frames J_b(frame)^T F_tip(frame))

Joint i has motion subspace S_i (6 x nv_i: A_i for a 1-dof joint, I_6 for a free one).
Pass 1, base to tips: T_{i,lambda}, V_i = Ad V_lambda + S_i qd_i, the velocity-product
acceleration c_i = ad_{V_i} S_i qd_i, and the bias wrench pA_i = -ad_{V_i}^T G_i V_i + F_tip,i.
Pass 2, tips to base, articulated inertias IA_i (starting from G_i) and bias wrenches:
    U_i = IA_i S_i,  D_i = S_i^T U_i (+ armature),  u_i = tau_i - S_i^T pA_i
    Ia = IA_i - U_i D_i^-1 U_i^T,   pa = pA_i + Ia c_i + U_i D_i^-1 u_i
    IA_lambda += Ad^T Ia Ad,        pA_lambda += Ad^T pa
Pass 3, base to tips, dV_0 = (0, -g):
    a_i = Ad_{T_{i,lambda}} dV_lambda + c_i,   qdd_i = D_i^-1 (u_i - U_i^T a_i),
    dV_i = a_i + S_i qdd_i
For a 1-dof joint D_i is a number and D_i^-1 a division; for a multi-dof joint (the free
joint, nv_i = 6) D_i is solved by its Cholesky factor, kept from pass 2 for pass 3.
(Featherstone, Rigid Body Dynamics Algorithms, 2008, Table 7.1; Lynch & Park, Section 8.5.)
ABA needs one coordinate per joint: models with coupled (mimic) joints use CRBA + Cholesky.
"""

from __future__ import annotations

from collections import namedtuple

from numba import njit

from .._runtime.arrays import copy_into, fill
from .._runtime.kernel_cache import JIT
from .._runtime.status import Status
from ..multibody.joints import (
    free_joints_only,
    joint_motion,
    place_joints,
    state_status,
    vector_status,
)
from ..multibody.layout import body_count, dof_count, rigid_inertias, spatial_inertias, tree
from ..multibody.work_views import (
    articulated_biases,
    articulated_inertias,
    body_motion,
    joint_poses,
    scratch_rows,
    temp_vectors,
)
from ..spatial.compiled import (
    ad_twist,
    add_inertia_to_parent,
    add_neg_ad_transpose,
    add_wrench_to_parent,
    dot6,
    inertia_times_motion,
    mat6_vec,
    rigid_inertia_times,
    twist_to_child,
)
from .cholesky import SINGULAR_PIVOT, cholesky_factor, cholesky_substitute

# One body's ABA quantities, views of the Data's rows for body i: IA_i, pA_i, c_i (the
# velocity-product acceleration), U_i, L_i (D_i's Cholesky factor) and u_i.
ArticulatedBody = namedtuple("ArticulatedBody", ("IA", "pA", "c", "U", "L", "u"))


@njit(**JIT)
def articulate_multi_dof(n, b, S_i, body, tau, armature, scale, s, x):
    """Pass 2 of ABA for a joint with n > 1 velocity coordinates v[b : b + n], in place on
    body (an ArticulatedBody):

      U_i = IA_i S_i (rows k < n of U_i),  D_i = S_i^T U_i (+ armature) = L_i L_i^T,
      u_i = tau_i - S_i^T pA_i,
      IA_i <- IA_i - U_i D_i^-1 U_i^T,     pA_i <- pA_i + IA_i c_i + U_i D_i^-1 u_i.

    s, x: (6,) scratch. Returns Status.OK.value or SINGULAR + k (coordinate k with no
    inertia). Compiled once and called: ABA's loop keeps only the 1-dof arithmetic inline."""
    IA_i, U_i, L_i, u_i = body.IA, body.U, body.L, body.u
    for k in range(n):
        inertia_times_motion(IA_i, S_i[k], U_i[k])
        u_i[k] = tau[b + k] - dot6(S_i[k], body.pA)
    for k in range(n):
        for k2 in range(n):
            L_i[k, k2] = dot6(S_i[k], U_i[k2])
        if armature.shape[0] > 0:
            L_i[k, k] += armature[b + k]
    status = cholesky_factor(L_i, n, scale)
    if status:
        return status + b
    for r in range(6):  # column r of D_i^-1 U_i^T, from the factor
        for k in range(n):
            s[k] = U_i[k, r]
        cholesky_substitute(L_i, n, s, x)
        for col in range(6):
            for k in range(n):
                IA_i[col, r] -= U_i[k, col] * x[k]
    cholesky_substitute(L_i, n, u_i, x)
    mat6_vec(IA_i, body.c, s)
    for r in range(6):
        for k in range(n):
            s[r] += U_i[k, r] * x[k]
        body.pA[r] += s[r]
    return Status.OK.value


@njit(**JIT)
def accelerate_multi_dof(n, b, S_i, body, dV_i, qdd, s, x):
    """Pass 3 of ABA for a joint with n > 1 velocity coordinates, dV_i holding a_i on entry:
    qdd_i = D_i^-1 (u_i - U_i^T a_i) by the factor L_i of body (an ArticulatedBody), then
    dV_i <- a_i + S_i qdd_i. s, x: (6,) scratch."""
    for k in range(n):
        s[k] = body.u[k] - dot6(body.U[k], dV_i)
    cholesky_substitute(body.L, n, s, x)
    for k in range(n):
        qdd[b + k] = x[k]
        for r in range(6):
            dV_i[r] += S_i[k, r] * x[k]


# the multi-dof passes, compiled only for models with free joints
articulate_free_joint = free_joints_only(articulate_multi_dof)
accelerate_free_joint = free_joints_only(accelerate_multi_dof)


@njit(**JIT)
def aba_kernel(ibuf, fbuf, work, q, qd, tau, loads, qdd, armature):
    """qdd (nv,) <- ABA at one state, working in `work` (a Data's buffer: R, p, V, dV, IA, pA,
    a_vp, U, L, u are left as this state's); loads as in rnea_kernel (dV_0, then body
    wrenches).
    armature: (nv,) rotor inertias added to D_i (M's diagonal), or an empty array for none.
    Returns a Status: OK, Q/QD/TAU_NOT_FINITE, Q_NOT_UNIT_QUATERNION, or SINGULAR + k when
    velocity coordinate k has no inertia moving with it (a pivot of D_i ~ 0)."""
    status = state_status(ibuf, q, qd)
    if status:
        return status
    R, p = joint_poses(work, body_count(ibuf))
    place_joints(tree(ibuf, fbuf), q, R, p)
    return aba_on_poses(ibuf, fbuf, work, qd, tau, loads, qdd, armature)


@njit(**JIT)
def aba_on_poses(ibuf, fbuf, work, qd, tau, loads, qdd, armature):
    """aba_kernel on the joint poses that `work` holds (joints.place_joints at the state's q,
    which was checked with qd). Returns a Status as aba_kernel's."""
    status = vector_status(ibuf, tau, Status.TAU_NOT_FINITE.value)
    if status:
        return status
    body_tree = tree(ibuf, fbuf)
    parent, nv_j = body_tree.parent, body_tree.nv_j
    iv, S = body_tree.iv, body_tree.S
    G = spatial_inertias(ibuf, fbuf)
    mass, h, I_o = rigid_inertias(ibuf, fbuf)
    nb, nv = body_count(ibuf), dof_count(ibuf)
    R, p = joint_poses(work, nb)
    # IA_i, and per joint U_i (rows k < nv_i: IA_i s_k) and L_i (D_i, or its Cholesky factor
    # when nv_i > 1)
    IA, U, L = articulated_inertias(work, nb)
    c, pA, u = articulated_biases(work, nb)
    V, dV, _ = body_motion(work, nb)
    scratch = scratch_rows(work, nb, nv)
    temp = temp_vectors(work, nb, nv)
    s, V_J, x = temp[0], temp[1], temp[2]
    wrenches = loads.shape[0] > 1
    rotors = armature.shape[0] > 0
    scale = 0.0
    for i in range(nb):
        for k in range(6):
            scale = max(scale, G[i, k, k])

    # pass 1: V_i = Ad V_lambda + V_J, c_i = ad_{V_i} V_J with V_J = S_i qd_i,
    # pA_i = -ad_{V_i}^T G_i V_i + F_tip,i; IA_i = G_i
    for i in range(nb):
        lam = parent[i]
        joint_motion(nv_j[i], S[i], 1.0, qd, iv[i], V_J)
        if lam < 0:
            copy_into(V_J, V[i])
        else:
            twist_to_child(R[i], p[i], V[lam], V[i])
            for k in range(6):
                V[i, k] += V_J[k]
        ad_twist(V[i], V_J, c[i])
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
        n, b = nv_j[i], iv[i]
        lam = parent[i]
        if n > 1:
            body = ArticulatedBody(IA[i], pA[i], c[i], U[i], L[i], u[i])
            status = articulate_free_joint(ibuf, n, b, S[i], body, tau, armature, scale, s, x)
            if status:
                return status
        else:
            # U_i = IA_i s_i, D_i = s_i^T U_i (+ armature), u_i = tau_i - s_i^T pA_i
            inertia_times_motion(IA[i], S[i, 0], U[i, 0])
            L[i, 0, 0] = dot6(S[i, 0], U[i, 0])
            if rotors:
                L[i, 0, 0] += armature[b]
            u[i, 0] = tau[b] - dot6(S[i, 0], pA[i])
            if not L[i, 0, 0] > SINGULAR_PIVOT * scale:
                return Status.SINGULAR.value + b
            if lam < 0:
                continue
            # Ia = IA_i - U_i U_i^T / D_i,  pa = pA_i + Ia c_i + U_i u_i / D_i  (in place)
            D_inv = 1.0 / L[i, 0, 0]
            for r in range(6):
                for k in range(6):
                    IA[i, r, k] -= U[i, 0, r] * U[i, 0, k] * D_inv
            mat6_vec(IA[i], c[i], s)
            for r in range(6):
                pA[i, r] += s[r] + U[i, 0, r] * u[i, 0] * D_inv
        if lam >= 0:
            add_inertia_to_parent(R[i], p[i], IA[i], IA[lam], scratch)
            add_wrench_to_parent(R[i], p[i], pA[i], pA[lam])

    # pass 3: accelerations, base to tips: a_i = Ad dV_lambda + c_i,
    # qdd_i = D_i^-1 (u_i - U_i^T a_i), dV_i = a_i + S_i qdd_i
    for i in range(nb):
        n, b = nv_j[i], iv[i]
        lam = parent[i]
        twist_to_child(R[i], p[i], loads[0] if lam < 0 else dV[lam], dV[i])
        for k in range(6):
            dV[i, k] += c[i, k]
        if n > 1:
            body = ArticulatedBody(IA[i], pA[i], c[i], U[i], L[i], u[i])
            accelerate_free_joint(ibuf, n, b, S[i], body, dV[i], qdd, s, x)
        else:
            qdd[b] = (u[i, 0] - dot6(U[i, 0], dV[i])) / L[i, 0, 0]
            for r in range(6):
                dV[i, r] += S[i, 0, r] * qdd[b]
    return Status.OK.value
