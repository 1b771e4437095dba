"""The inverse of the joint-space inertia matrix, M(q)^-1, by the articulated-body recursion,
O(n d), without forming or factorising M (Carpentier, "Analytical Inverse of the Joint Space
Inertia Matrix", 2018; Pinocchio's computeMinverse):

column c of M^-1 is the accelerations qdd that a unit generalized force e_c gives the robot at
rest without gravity, which ABA computes. Its articulated inertias do not depend on the force,
and with the robot at rest its bias wrenches are the forces' alone, linear in them: one pass
over the bodies carries every column at once. In the world frame {s}, where no wrench or
inertia needs carrying from a body to its parent, for body i with axes S_i (6 x nv_i, S_s):
Pass 1, tips to base (IA_i starts as G_s[i]; P_i (6 x nv) the bias wrenches of the unit
forces applied in the subtree of i, zero elsewhere):
    U_i = IA_i S_i,  D_i = S_i^T U_i (+ armature),
    M^-1[i, c] = D_i^-1 (e_i,c - S_i^T P_i[:, c])   for c in the subtree of i (its own
                 coordinates give D_i^-1: P_i has no column for them)
    P_lambda[:, c] += P_i[:, c] + U_i M^-1[i, c],   IA_lambda += IA_i - U_i D_i^-1 U_i^T
Pass 2, base to tips, the accelerations A_i (6 x nv) of the unit forces (A = 0 for the world),
for the columns c >= the first coordinate of i (the upper triangle):
    M^-1[i, c] -= D_i^-1 U_i^T A_lambda[:, c],      A_i[:, c] = A_lambda[:, c] + S_i M^-1[i, c]
and M^-1 is symmetric. It needs one coordinate per body: models with coupled (mimic) joints
invert M by its Cholesky factor instead (mass_matrix_inverse).
"""

from __future__ import annotations

from numba import njit

from .._runtime.kernel_cache import JIT
from .._runtime.status import Status
from ..multibody.data import coriolis_terms, inverse_terms, scratch_rows
from ..multibody.layout import tree
from ..spatial.compiled import dot6, mat6_vec
from .cholesky import SINGULAR_PIVOT, cholesky_factor, cholesky_substitute, largest_diagonal


@njit(**JIT)
def joint_inertia_inverse(n, b, S_i, U_i, armature, scale, L, Dinv):
    """Dinv[:n, :n] <- D^-1, D = S_i^T U_i (+ armature[b : b + n]), for a joint of n
    coordinates from b; L (n, n) scratch for D's Cholesky factor. Returns Status.OK.value or SINGULAR + b + k for a coordinate k with no
    inertia (a pivot not above SINGULAR_PIVOT * scale)."""
    if n == 1:
        d = dot6(S_i[0], U_i[0]) + (armature[b] if armature.shape[0] else 0.0)
        if not d > SINGULAR_PIVOT * scale:
            return Status.SINGULAR.value + b
        Dinv[0, 0] = 1.0 / d
        return Status.OK.value
    # a free joint: D = L L^T, then D^-1 column by column
    for r in range(n):
        for c in range(n):
            L[r, c] = dot6(S_i[r], U_i[c]) + (
                armature[b + r] if r == c and armature.shape[0] else 0.0
            )
    status = cholesky_factor(L, n, scale)
    if status:
        return status + b
    for c in range(n):
        for r in range(n):
            Dinv[c, r] = 1.0 if r == c else 0.0
        cholesky_substitute(L, n, Dinv[c], Dinv[c])
    return Status.OK.value


@njit(**JIT)
def inverse_mass_matrix_kernel(ibuf, fbuf, work, armature, Minv):
    """Minv (nv, nv) <- (M(q) + diag(armature))^-1 by the module docstring's two passes, with
    the CoriolisTerms of space_axes_and_inertias (S_s, G_s) in `work` for this q; armature
    (nv,) or empty. Needs one coordinate or more per body (no coupled joints). Returns
    Status.OK.value or SINGULAR + k (coordinate k moves no inertia)."""
    body_tree = tree(ibuf, fbuf)
    parent, nv_j, iv = body_tree.parent, body_tree.nv_j, body_tree.iv
    nb, nv = parent.shape[0], Minv.shape[0]
    S_s, G_s = coriolis_terms(work, nb).S_s, coriolis_terms(work, nb).G_s
    terms = inverse_terms(work, nb, nv)
    IA, U, Dinv, end, P = terms.IA_s, terms.U_s, terms.Dinv, terms.subtree_end, terms.responses
    rows = scratch_rows(work, nb, nv)
    L, x = rows[:6], rows[8]
    scale = 0.0
    for i in range(nb):
        end[i] = iv[i] + nv_j[i]
        for r in range(6):
            scale = max(scale, G_s[i, r, r])
            for c in range(6):
                IA[i, r, c] = G_s[i, r, c]
            for c in range(nv):
                P[i, r, c] = 0.0
    for i in range(nb - 1, 0, -1):
        if parent[i] >= 0:
            end[parent[i]] = max(end[parent[i]], end[i])
    for r in range(nv):
        for c in range(nv):
            Minv[r, c] = 0.0
    # pass 1, tips to base
    for i in range(nb - 1, -1, -1):
        n, b, e = nv_j[i], iv[i], int(end[i])
        for k in range(n):
            mat6_vec(IA[i], S_s[i, k], U[i, k])
        status = joint_inertia_inverse(n, b, S_s[i], U[i], armature, scale, L, Dinv[i])
        if status:
            return status
        # M^-1[i, c] = D^-1 (e_i,c - S_i^T P_i[:, c]) over the subtree's columns
        for c in range(b, e):
            for k in range(n):
                s = 0.0
                for r in range(6):
                    s += S_s[i, k, r] * P[i, r, c]
                x[k] = (1.0 if c == b + k else 0.0) - s
            for k in range(n):
                s = 0.0
                for m in range(n):
                    s += Dinv[i, k, m] * x[m]
                Minv[b + k, c] = s
        lam = parent[i]
        if lam < 0:
            continue
        # P_lambda += P_i + U_i M^-1[i, :],  IA_lambda += IA_i - U_i D^-1 U_i^T
        for c in range(b, e):
            for r in range(6):
                s = P[i, r, c]
                for k in range(n):
                    s += U[i, k, r] * Minv[b + k, c]
                P[lam, r, c] += s
        for r in range(6):
            for c in range(6):
                s = IA[i, r, c]
                for k in range(n):
                    for m in range(n):
                        s -= U[i, k, r] * Dinv[i, k, m] * U[i, m, c]
                IA[lam, r, c] += s
    # pass 2, base to tips: the accelerations A_i (in P's place) for the columns c >= b
    for i in range(nb):
        n, b, lam = nv_j[i], iv[i], parent[i]
        for c in range(b, nv):
            if lam >= 0:
                for k in range(n):
                    x[k] = dot_column(U[i, k], P[lam], c)
                for k in range(n):
                    s = 0.0
                    for m in range(n):
                        s += Dinv[i, k, m] * x[m]
                    Minv[b + k, c] -= s
            for r in range(6):
                s = P[lam, r, c] if lam >= 0 else 0.0
                for k in range(n):
                    s += S_s[i, k, r] * Minv[b + k, c]
                P[i, r, c] = s
    for r in range(nv):
        for c in range(r + 1, nv):
            Minv[c, r] = Minv[r, c]
    return Status.OK.value


@njit(**JIT)
def dot_column(u, A, c):
    """u . A[:, c] for a 6-vector u and a (6, nv) array A."""
    s = 0.0
    for r in range(6):
        s += u[r] * A[r, c]
    return s


@njit(**JIT)
def mass_matrix_inverse(M, armature, Minv):
    """Minv <- (M + diag(armature))^-1 by the Cholesky factor of M, in place in M, column by
    column: for models with coupled (mimic) joints, which the recursion cannot take. Returns
    Status.OK.value or SINGULAR + k."""
    nv = M.shape[0]
    for k in range(armature.shape[0]):
        M[k, k] += armature[k]
    status = cholesky_factor(M, nv, largest_diagonal(M))
    if status:
        return status
    for c in range(nv):
        for r in range(nv):
            Minv[c, r] = 1.0 if r == c else 0.0
        cholesky_substitute(M, nv, Minv[c], Minv[c])
    return Status.OK.value
