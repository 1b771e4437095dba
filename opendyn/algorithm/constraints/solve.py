"""The constrained solve: M qdd + A^T lam = rhs with A qdd = -gamma, for qdd and lam, compiled
for the simulation step:

    lam = (A M^-1 A^T)^-1 (A M^-1 (tau - h) + Adot qd),   qdd = M^-1 (tau - h - A^T lam)

Rank-deficient A (a 3-row point closure on a planar mechanism, whose out-of-plane row is
identically zero; a duplicated constraint) leaves G = A M^-1 A^T singular. Everywhere in
opendyn.algorithm.constraints (G)^-1 is the pseudo-inverse G^+ from the symmetric
eigendecomposition G = V diag(e) V^T (cyclic Jacobi, opendyn.algorithm.eigen), keeping the
eigenvalues e_i > RANK_RTOL * max(e) (RANK_RTOL = 1e-12): lam is the minimum-norm
least-squares solution of G lam = A M^-1 (tau - h) + Adot qd, and qdd, A^T lam and P are unique
when the constraints are consistent (the right-hand side lies in the range of G); the numerical
rank is the number of eigenvalues kept.

Compiled interface:
  constrained_solve_kernel(M, rhs, A, gamma, qdd, lam) -> Status.OK.value, or SINGULAR + k (pivot k)
  constrained_solve_rank_kernel(M, rhs, A, gamma, qdd, lam, rank) -> the same, rank[0] = rank
  constrained_forward_kernel(ibuf, fbuf, con, q, qd, tau, loads, armature, qdd, lam) -> status
and, in a ConstraintWork made once for a model and its constraints' k rows (constraint_work),
the simulation step's, which allocate nothing:
  constrained_solve_at(ibuf, fbuf, con, q, qd, M, rhs, qdd, work) -> status, lam in work.lam
  general_constrained_solve_at(...)     the same for a general M (the implicit Euler step's,
                                        not symmetric: by LU)
  constrained_on_poses(ibuf, fbuf, work, con, (q, qd, tau), loads, armature, (qdd, con_work))
                                        constrained forward dynamics on the joint poses placed
                                        in work -> status
with con a ConstraintTable (rows, params, gains): the table (opendyn.algorithm.constraints.table)
and gains = (alpha, beta), the Baumgarte stabilisation A qdd + Adot qd + 2 alpha A qd +
beta^2 phi = 0 of a simulation ((0, 0), NO_STABILISATION: none).
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit

from ..._runtime.arrays import all_finite, copy_into, fill, zero_matrix
from ..._runtime.kernel_cache import JIT
from ..._runtime.status import Status
from ...multibody.joints import place_joints, state_status
from ...multibody.layout import body_count, tree
from ...multibody.work_views import joint_poses, joint_vectors, mass_matrix_field, new_work
from ..cholesky import cholesky_solve
from ..crba import crba_on_poses
from ..eigen import symmetric_eigen
from ..lu import lu_factor, lu_substitute
from ..rnea import rnea_on_poses
from .terms import constraint_terms_in, terms_work

RANK_RTOL = 1e-12  # eigenvalues of A M^-1 A^T below this times the largest count as zero
NO_STABILISATION = np.zeros(2)  # Baumgarte gains (alpha, beta) = 0: A qdd + Adot qd = 0

# The solve's scratch for k rows and nv coordinates (solve_work): Y (nv, k), L^-1 A^T or
# M^-1 A^T; G = A M^-1 A^T and G^T G (k, k); the eigenvectors E (k, k) and eigenvalues e (k,)
# of the pseudo-inverse; the right-hand sides b and G^T b (k,); qdd_free = M^-1 rhs and a
# column (nv,) of M^-1 A^T or of L^-T Y lam; the LU factorisation's row swaps piv (nv,) int64.
SolveWork = namedtuple(
    "SolveWork", ("Y", "G", "GtG", "E", "e", "b", "Gtb", "qdd_free", "column", "piv")
)

# What the simulation step's constrained solve works in, made once for a model and its
# constraints' k rows (constraint_work): the rows A (k, nv), their right-hand side gamma (k,)
# (A qdd = -gamma) and errors phi (k,), the multipliers lam (k,) (the rows' force units), the
# solve's SolveWork and the rows' TermsWork (opendyn.algorithm.constraints.terms).
ConstraintWork = namedtuple("ConstraintWork", ("A", "gamma", "phi", "lam", "solve", "terms"))


@njit(**JIT)
def solve_work(nv, k):
    """The SolveWork of k constraint rows on nv velocity coordinates."""
    return SolveWork(
        np.empty((nv, k)),
        np.empty((k, k)),
        np.empty((k, k)),
        np.empty((k, k)),
        np.empty(k),
        np.empty(k),
        np.empty(k),
        np.empty(nv),
        np.empty(nv),
        np.empty(nv, dtype=np.int64),
    )


@njit(**JIT)
def constraint_work(nb, nv, k):
    """The ConstraintWork of k constraint rows on a model of nb bodies and nv velocity
    coordinates."""
    return ConstraintWork(
        np.empty((k, nv)),
        np.empty(k),
        np.empty(k),
        np.empty(k),
        solve_work(nv, k),
        terms_work(nb, nv),
    )


@njit(**JIT)
def pseudo_solve(G, b, x, E, e):
    """x <- G^+ b for a symmetric positive semi-definite (k, k) G (overwritten): the
    minimum-norm least-squares solution, eigenvalues e_i <= RANK_RTOL * max(e) treated as 0;
    G = E diag(e) E^T in E (k, k) and e (k,). Returns the numerical rank."""
    k = G.shape[0]
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
    status, kept = constrained_solve_in(
        M, rhs, A, gamma, qdd, lam, solve_work(M.shape[0], A.shape[0])
    )
    rank[0] = kept
    return status


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
    return constrained_solve_in(M, rhs, A, gamma, qdd, lam, solve_work(M.shape[0], A.shape[0]))[0]


@njit(**JIT)
def constrained_solve_in(M, rhs, A, gamma, qdd, lam, work):
    """constrained_solve_kernel in work, a SolveWork of nv coordinates and k rows (solve_work):
    allocates nothing. Returns (Status, the numerical rank of A M^-1 A^T; 0 on failure)."""
    nv = M.shape[0]
    k = A.shape[0]
    Y, G, b, qdd_free, z = work.Y, work.G, work.b, work.qdd_free, work.column
    # M = L L^T (L in M's lower triangle), qdd_free = M^-1 rhs
    status = cholesky_solve(M, rhs, qdd_free)
    if status:
        return status, 0
    # Y = L^-1 A^T (nv, k), G = Y^T Y = A M^-1 A^T
    for j in range(k):
        for r in range(nv):
            s = A[j, r]
            for c in range(r):
                s -= M[r, c] * Y[c, j]
            Y[r, j] = s / M[r, r]
    for i in range(k):
        for j in range(i, k):
            s = 0.0
            for r in range(nv):
                s += Y[r, i] * Y[r, j]
            G[i, j] = s
            G[j, i] = s
    # lam = G^+ (A M^-1 rhs + gamma)
    for i in range(k):
        s = gamma[i]
        for c in range(nv):
            s += A[i, c] * qdd_free[c]
        b[i] = s
    rank = pseudo_solve(G, b, lam, work.E, work.e)
    # qdd = M^-1 (rhs - A^T lam) = qdd_free - L^-T (Y lam)
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
    return Status.OK.value, rank


@njit(**JIT)
def constraint_rows_at(ibuf, fbuf, con, q, qd, work):
    """work.A (k, nv), work.gamma (k,) <- the rows of the constraints con (a ConstraintTable) at
    (q (nq,), qd (nv,)) and their right-hand side with its Baumgarte stabilisation gains
    (alpha, beta) (1/s): A qdd = -gamma is
        A qdd + Adot qd + 2 alpha A qd + beta^2 phi = 0
    ((0, 0): A qdd + Adot qd = 0, the drift of phi left alone); work.phi (k,) <- phi. work: a
    ConstraintWork (constraint_work). Returns a Status: OK, Q/QD_NOT_FINITE or
    Q_NOT_UNIT_QUATERNION."""
    nv = qd.shape[0]
    A, gamma, phi = work.A, work.gamma, work.phi
    k = gamma.shape[0]
    status = constraint_terms_in(
        ibuf, fbuf, con.rows, con.params, q, qd, A, gamma, phi, work.terms
    )
    if status:
        return status
    alpha, beta = con.gains[0], con.gains[1]
    if alpha != 0.0 or beta != 0.0:
        for r in range(k):
            rate = 0.0
            for j in range(nv):
                rate += A[r, j] * qd[j]
            gamma[r] += 2.0 * alpha * rate + beta * beta * phi[r]
    return Status.OK.value


@njit(**JIT)
def constrained_solve_at(ibuf, fbuf, con, q, qd, M, rhs, qdd, work):
    """qdd (nv,), work.lam (k,) <- the solution of M qdd + A^T lam = rhs with the rows of the
    constraints con at (q, qd) held to second order (constraint_rows_at), M (nv, nv) symmetric
    positive definite (overwritten by its Cholesky factor: constrained_solve_kernel), in work,
    a ConstraintWork (constraint_work). Returns a Status: OK, Q/QD_NOT_FINITE,
    Q_NOT_UNIT_QUATERNION, or SINGULAR + j when M is singular at coordinate j."""
    status = constraint_rows_at(ibuf, fbuf, con, q, qd, work)
    if status:
        return status
    return constrained_solve_in(M, rhs, work.A, work.gamma, qdd, work.lam, work.solve)[0]


@njit(**JIT)
def general_constrained_solve_at(ibuf, fbuf, con, q, qd, M, rhs, qdd, work):
    """constrained_solve_at for a general (nv, nv) M, not symmetric (the linearly implicit
    Euler step's M + dt D + dt^2 K once contact's exact derivatives are in it; overwritten):
    by P M = L U (opendyn.algorithm.lu),
        G = A M^-1 A^T,   lam = G^+ b = (G^T G)^+ G^T b,  b = A M^-1 rhs + gamma,
        qdd = M^-1 rhs - (M^-1 A^T) lam
    (G^+ through the symmetric G^T G: pseudo_solve, whose eigenvalues are the squares of G's
    singular values). Returns a Status as constrained_solve_at's."""
    nv = qd.shape[0]
    status = constraint_rows_at(ibuf, fbuf, con, q, qd, work)
    if status:
        return status
    A, gamma, lam, s = work.A, work.gamma, work.lam, work.solve
    k = lam.shape[0]
    piv, qdd_free, Y, column = s.piv, s.qdd_free, s.Y, s.column
    G, b, GtG, Gtb = s.G, s.b, s.GtG, s.Gtb
    status = lu_factor(M, piv)
    if status:
        return status
    # qdd_free = M^-1 rhs, Y = M^-1 A^T (nv, k), G = A Y, b = A qdd_free + gamma
    lu_substitute(M, piv, rhs, qdd_free)
    for j in range(k):
        lu_substitute(M, piv, A[j], column)
        Y[:, j] = column
    zero_matrix(G)
    copy_into(gamma, b)
    for i in range(k):
        for r in range(nv):
            b[i] += A[i, r] * qdd_free[r]
            for j in range(k):
                G[i, j] += A[i, r] * Y[r, j]
    # the normal equations G^T G lam = G^T b, their minimum-norm solution
    zero_matrix(GtG)
    fill(Gtb, 0.0)
    for i in range(k):
        for j in range(k):
            Gtb[i] += G[j, i] * b[j]
            for m in range(k):
                GtG[i, j] += G[m, i] * G[m, j]
    pseudo_solve(GtG, Gtb, lam, s.E, s.e)
    # qdd = qdd_free - Y lam
    for r in range(nv):
        value = qdd_free[r]
        for j in range(k):
            value -= Y[r, j] * lam[j]
        qdd[r] = value
    return Status.OK.value


@njit(**JIT)
def constrained_forward_kernel(ibuf, fbuf, con, q, qd, tau, loads, armature, qdd, lam):
    """qdd (nv,), lam (k,) <- constrained forward dynamics at one state (q (nq,); qd, tau
    (nv,)): M by CRBA (+ diag(armature), (nv,) or empty), h (and the f_tip wrenches in loads,
    as in rnea_kernel) by RNEA, then constrained_solve_at with the constraints con (a
    ConstraintTable; gains zeros: no stabilisation). Returns a Status: OK, Q/QD/TAU_NOT_FINITE,
    Q_NOT_UNIT_QUATERNION, RESULT_NOT_FINITE (h overflowed), or SINGULAR + j when M is singular
    at coordinate j."""
    status = state_status(ibuf, q, qd)
    if status:
        return status
    nb, nv = body_count(ibuf), qd.shape[0]
    work = new_work(nb, nv)
    R, p = joint_poses(work, nb)
    place_joints(tree(ibuf, fbuf), q, R, p)
    con_work = constraint_work(nb, nv, lam.shape[0])
    status = constrained_on_poses(
        ibuf, fbuf, work, con, (q, qd, tau), loads, armature, (qdd, con_work)
    )
    if status == Status.OK.value:
        copy_into(con_work.lam, lam)
    return status


@njit(**JIT)
def constrained_on_poses(ibuf, fbuf, work, con, state, loads, armature, solution):
    """constrained_forward_kernel at state = (q, qd, tau), (q, qd) checked, on the joint poses
    that `work` (a Data's buffer) holds (joints.place_joints at q): h and M share them;
    solution = (qdd, con_work), lam in con_work.lam (con_work: a ConstraintWork). Works in
    work's h (the right-hand side tau - h) and M (its Cholesky factor) and in con_work:
    allocates nothing. Returns a Status as constrained_forward_kernel's."""
    q, qd, tau = state
    qdd, con_work = solution
    if not all_finite(tau):
        return Status.TAU_NOT_FINITE.value
    nb, nv = body_count(ibuf), qd.shape[0]
    rhs, zero_v, _ = joint_vectors(work, nb, nv)
    status = rnea_on_poses(ibuf, fbuf, work, qd, zero_v, loads, rhs)
    if status:
        return status
    for i in range(nv):
        rhs[i] = tau[i] - rhs[i]
    M = mass_matrix_field(work, nb, nv)
    crba_on_poses(ibuf, fbuf, work, M)
    for i in range(armature.shape[0]):
        M[i, i] += armature[i]
    return constrained_solve_at(ibuf, fbuf, con, q, qd, M, rhs, qdd, con_work)
