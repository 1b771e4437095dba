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

from .._runtime.kernel_cache import INLINE, JIT
from .._runtime.status import Status
from ..multibody.layout import tree
from ..multibody.work_views import coriolis_terms, inverse_terms, scratch_rows
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


@njit(**INLINE)
def one_dof_upward(b, e, S, U, d, P_i, P_lambda, has_parent, Minv):
    """Pass 1 for a 1-dof joint at coordinate b with subtree columns [b, e), axis S, U = IA S,
    d = D^-1: M^-1[b, c] = d (e_b,c - S . P_i[c]); P_lambda[c] = P_i[c] + U M^-1[b, c] when
    has_parent."""
    for c in range(b, e):
        m = d * (1.0 if c == b else -dot6(S, P_i[c]))
        Minv[b, c] = m
        if has_parent:
            for r in range(6):
                P_lambda[c, r] = (P_i[c, r] if c > b else 0.0) + U[r] * m


@njit(**INLINE)
def one_dof_downward(b, e, S, U, d, A_lambda, has_parent, A_i, Minv):
    """Pass 2 for a 1-dof joint: M^-1[b, c] -= d U . A_lambda[c] for c >= b (set from 0 past
    the subtree's end e), and A_i[c] = A_lambda[c] + S M^-1[b, c]."""
    nv = Minv.shape[0]
    for c in range(b, nv):
        m = Minv[b, c] if c < e else 0.0
        if has_parent:
            m -= d * dot6(U, A_lambda[c])
            Minv[b, c] = m
            for r in range(6):
                A_i[c, r] = A_lambda[c, r] + S[r] * m
        else:
            Minv[b, c] = m
            for r in range(6):
                A_i[c, r] = S[r] * m


@njit(**JIT)
def inverse_mass_matrix_kernel(ibuf, fbuf, work, armature, Minv):
    """Minv (nv, nv) <- (M(q) + diag(armature))^-1 by the module docstring's two passes, with
    the CoriolisTerms of space_axes_and_inertias (S_s, G_s) in `work` for this q; armature
    (nv,) or empty. Needs one coordinate or more per body (no coupled joints). Returns
    Status.OK.value or SINGULAR + k (coordinate k moves no inertia).

    Each column c of P_lambda below lambda's own coordinates comes from exactly one child's
    subtree, so it is set, not added to, and nothing needs zeroing first; the entries of
    M^-1[i, c] past the subtree of i are likewise set in pass 2."""
    body_tree = tree(ibuf, fbuf)
    parent, nv_j, iv = body_tree.parent, body_tree.nv_j, body_tree.iv
    nb, nv = parent.shape[0], Minv.shape[0]
    axes = coriolis_terms(work, nb)
    S_s, G_s = axes.S_s, axes.G_s
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
    for i in range(nb - 1, 0, -1):
        if parent[i] >= 0:
            end[parent[i]] = max(end[parent[i]], end[i])
    # pass 1, tips to base
    for i in range(nb - 1, -1, -1):
        n, b, e = nv_j[i], iv[i], int(end[i])
        for k in range(n):
            mat6_vec(IA[i], S_s[i, k], U[i, k])
        status = joint_inertia_inverse(n, b, S_s[i], U[i], armature, scale, L, Dinv[i])
        if status:
            return status
        lam = parent[i]
        if n == 1:  # the common joint, written out: D^-1 is a number d
            one_dof_upward(
                b,
                e,
                S_s[i, 0],
                U[i, 0],
                Dinv[i, 0, 0],
                P[i],
                P[lam] if lam >= 0 else P[i],
                lam >= 0,
                Minv,
            )
            if lam >= 0:
                for r in range(6):
                    for c in range(6):
                        IA[lam, r, c] += IA[i, r, c] - U[i, 0, r] * U[i, 0, c] * Dinv[i, 0, 0]
            continue
        # M^-1[i, c] = D^-1 (e_i,c - S_i^T P_i[:, c]) over the subtree's columns (P_i is 0 at
        # i's own)
        for c in range(b, e):
            for k in range(n):
                x[k] = 1.0 if c == b + k else 0.0
                if c >= b + n:
                    x[k] -= dot6(S_s[i, k], P[i, c])
            for k in range(n):
                s = 0.0
                for m in range(n):
                    s += Dinv[i, k, m] * x[m]
                Minv[b + k, c] = s
        if lam < 0:
            continue
        # P_lambda[:, c] = P_i[:, c] + U_i M^-1[i, c],  IA_lambda += IA_i - U_i D^-1 U_i^T
        for c in range(b, e):
            for r in range(6):
                s = P[i, c, r] if c >= b + n else 0.0
                for k in range(n):
                    s += U[i, k, r] * Minv[b + k, c]
                P[lam, c, r] = s
        for r in range(6):
            for c in range(6):
                s = IA[i, r, c]
                for k in range(n):
                    for m in range(n):
                        s -= U[i, k, r] * Dinv[i, k, m] * U[i, m, c]
                IA[lam, r, c] += s
    # pass 2, base to tips: M^-1[i, c] -= D^-1 U_i^T A_lambda[:, c] for the columns c >= b
    # (set past the subtree of i), then the accelerations A_i[:, c] (in P's place)
    for i in range(nb):
        n, b, e, lam = nv_j[i], iv[i], int(end[i]), parent[i]
        if n == 1:
            one_dof_downward(
                b,
                e,
                S_s[i, 0],
                U[i, 0],
                Dinv[i, 0, 0],
                P[lam] if lam >= 0 else P[i],
                lam >= 0,
                P[i],
                Minv,
            )
            continue
        for c in range(b, nv):
            for k in range(n):
                x[k] = dot6(U[i, k], P[lam, c]) if lam >= 0 else 0.0
            for k in range(n):
                s = 0.0
                for m in range(n):
                    s += Dinv[i, k, m] * x[m]
                Minv[b + k, c] = (Minv[b + k, c] if c < e else 0.0) - s
            for r in range(6):
                s = P[lam, c, r] if lam >= 0 else 0.0
                for k in range(n):
                    s += S_s[i, k, r] * Minv[b + k, c]
                P[i, c, r] = s
    for r in range(nv):
        for c in range(r + 1, nv):
            Minv[c, r] = Minv[r, c]
    return Status.OK.value


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
