"""The contact problem of one velocity-level step, solved: Coulomb's law with maximum
dissipation as a nonlinear complementarity problem (NCP), by ADMM or by projected Gauss-Seidel.

The m rows of the problem come in blocks, each of one kind:

    CONE        3 rows (t1, t2, n) of a contact: lambda in K_mu = {|lambda_t| <= mu lambda_n},
                the exact circular cone (param: mu)
    UNILATERAL  1 row of a joint limit: lambda >= 0
    BOX         1 row of joint dry friction: |lambda| <= b (param: b, an impulse, N s or N m s)
    EQUALITY    1 row that holds exactly: lambda free

With the Delassus matrix G = J M^-1 J^T (m, m), the compliance R (s/kg, on every row) and the
free velocity's drift g (m,), the velocity of the rows after the step is c = (G + R) lambda + g,
and the problem is (Acary, Cadoux, Lemarechal & Marquez, "A formulation of the linear discrete
Coulomb friction problem via convex optimization", ZAMM 2011; Le Lidec, Jallet, Montaut,
Carpentier et al., "From compliant to rigid contact simulation", RSS 2024, Section III):

    lambda in K,   c + s(c) in K*,   lambda . (c + s(c)) = 0,        s(c) = (0, 0, mu |c_t|)

per block, K* the dual cone (for a contact K*_mu = {mu |w_t| <= w_n}; for a limit c >= 0; for
friction c = 0 strictly inside the box, c >= 0 at lambda = -b, c <= 0 at lambda = b; for an
equality c = 0). The de Saxce shift s makes a sliding contact keep c_n = 0 (no lift-off as the
convex relaxation would have, c_n = mu |c_t|).

Residual (m/s), what both solvers stop on and what the step reports: the largest, over the
blocks, of the distance of c + s from K* and of the velocity along the force,
|lambda . (c + s)| / |lambda| (0 where lambda = 0); lambda itself is always in K (both solvers
return a projected iterate).

ADMM (Boyd et al., "Distributed optimization ... ADMM", 2011, Section 3; the splitting of
Pinocchio's ADMMContactSolver) on min 1/2 x^T A x + (g + s)^T x over x = y, y in K, with
A = G + R and the shift s taken, as Pinocchio's, from the dual variable's velocity -u (a fixed
point, as the RSS 2024 paper's; taken from c(y) instead, it cycled on some problems Pinocchio's
ADMM solves):

    s = s(-u)
    (A + rho I) x = rho y - u - (g + s)
    y <- Pi_K(x + u / rho)
    u <- u + rho (x - y)                      -u converges to c + s, a velocity in K*

The problem is first preconditioned (Jacobi, as Pinocchio 4's ADMM can be): each block's rows
scaled by one factor, 1 / sqrt of the mean of its diagonal entries of A, so that the scaled A
has a unit diagonal on average per block; a cone stays the same cone, a box's bound is scaled
with its row, and the residual is measured in the unscaled problem (without it, masses a
hundred times apart, as in box_stack_hard, slowed ADMM's convergence many times over). rho
starts at sqrt(L_max d_min) (L_max the largest eigenvalue of the scaled A by power iteration,
d_min its smallest positive diagonal entry) and is rebalanced (times or over RHO_STEP) when
the primal residual d_mean |x - y| and the dual one rho |y - y_prev| differ by more than
RHO_RATIO; A + rho I is factored again then.

PGS (Jean & Moreau; Pinocchio's PGSContactSolver): block by block, a contact's normal row first,
lambda_n <- max(0, lambda_n - c_n / A_nn), then its tangent rows,
lambda_t <- Pi_{|.| <= mu lambda_n}(lambda_t - c_t / max(A_t1t1, A_t2t2)); a limit's
lambda <- max(0, lambda - c / A_ii), friction's clamped to [-b, b], an equality's unclamped.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .._runtime.kernel_cache import JIT
from .._runtime.status import Status
from .cholesky import cholesky_factor, cholesky_substitute

CONE, UNILATERAL, BOX, EQUALITY = 0, 1, 2, 3
# the columns of a block row: its kind, its first row, its number of rows
KIND, FIRST, SIZE = 0, 1, 2
ADMM, PGS = 0, 1
SOLVERS = {"admm": ADMM, "pgs": PGS}
RHO_RATIO = 10.0  # ADMM rebalances rho when its primal and dual residuals differ by this
RHO_STEP = 2.0  # ... by this factor
POWER_ITERATIONS = 12  # for the estimate of A's largest eigenvalue
TINY = 1e-300


@njit(**JIT)
def row_velocities(A, g, lam, m, c):
    """c[:m] <- A[:m, :m] lam[:m] + g[:m]: the rows' velocities after the step (m/s)."""
    for r in range(m):
        s = g[r]
        for k in range(m):
            s += A[r, k] * lam[k]
        c[r] = s


@njit(**JIT)
def project_cone(x, first, a):
    """x[first:first + 3] (t1, t2, n) <- its projection on {|x_t| <= a x_n}, a >= 0."""
    t1, t2, n = x[first], x[first + 1], x[first + 2]
    norm_t = np.sqrt(t1 * t1 + t2 * t2)
    if norm_t <= a * n:
        return
    if a * norm_t <= -n:
        x[first] = x[first + 1] = x[first + 2] = 0.0
        return
    n_new = (a * norm_t + n) / (1.0 + a * a)
    scale = a * n_new / norm_t
    x[first], x[first + 1], x[first + 2] = scale * t1, scale * t2, n_new


@njit(**JIT)
def project(blocks, param, x):
    """x <- its projection on K, block by block (module docstring)."""
    for k in range(blocks.shape[0]):
        kind, r = blocks[k, KIND], blocks[k, FIRST]
        if kind == CONE:
            project_cone(x, r, param[k])
        elif kind == UNILATERAL:
            x[r] = max(0.0, x[r])
        elif kind == BOX:
            x[r] = min(param[k], max(-param[k], x[r]))


@njit(**JIT)
def shift(blocks, param, c, s):
    """s <- the de Saxce shift of the velocities c: (0, 0, mu |c_t|) for each contact, 0 on the
    other rows."""
    for k in range(blocks.shape[0]):
        r = blocks[k, FIRST]
        for i in range(blocks[k, SIZE]):
            s[r + i] = 0.0
        if blocks[k, KIND] == CONE:
            s[r + 2] = param[k] * np.sqrt(c[r] * c[r] + c[r + 1] * c[r + 1])


@njit(**JIT)
def block_residual(kind, b, lam, w, r):
    """The residual (m/s) of one block at rows r.. with force lam and shifted velocity
    w = c + s: the distance of w from K* and the velocity along the force (module
    docstring)."""
    if kind == CONE:
        wt1, wt2, wn = w[r], w[r + 1], w[r + 2]
        norm_t = np.sqrt(wt1 * wt1 + wt2 * wt2)
        # K*_mu = {mu |w_t| <= w_n}: the cone of aperture 1 / mu (a half-space for mu = 0)
        if b == 0.0:
            dual = max(0.0, -wn)
        elif b * norm_t <= wn:
            dual = 0.0
        elif norm_t <= -b * wn:
            dual = np.sqrt(norm_t * norm_t + wn * wn)
        else:
            a = 1.0 / b
            n_p = (a * norm_t + wn) / (1.0 + a * a)
            dt_ = norm_t - a * n_p
            dual = np.sqrt(dt_ * dt_ + (wn - n_p) * (wn - n_p))
        size = np.sqrt(lam[r] ** 2 + lam[r + 1] ** 2 + lam[r + 2] ** 2)
        along = 0.0
        if size > 0.0:
            along = abs(lam[r] * wt1 + lam[r + 1] * wt2 + lam[r + 2] * wn) / size
        return max(dual, along)
    x, v = lam[r], w[r]
    if kind == UNILATERAL:
        return max(max(0.0, -v), abs(v) if x > 0.0 else 0.0)
    if kind == BOX:
        if b > 0.0 and x >= b:
            return max(0.0, v)  # at +b the row may only move backwards
        if x <= -b:
            return max(0.0, -v)
        return abs(v)
    return abs(v)


@njit(**JIT)
def residual(blocks, param, lam, w, scale):
    """The problem's residual (m/s): the largest block_residual at force lam, shifted
    velocity w; with scale (m,) (a block's rows scaled by one factor, precondition), of the
    scaled problem's lam and w, each block's residual divided by its factor: the unscaled
    problem's (the cone and its dual are invariant under a positive factor). scale None: the
    problem as it is."""
    worst = 0.0
    for k in range(blocks.shape[0]):
        r = blocks[k, FIRST]
        value = block_residual(blocks[k, KIND], param[k], lam, w, r)
        if scale is not None:
            value /= scale[r]
        worst = max(worst, value)
    return worst


@njit(**JIT)
def shifted_residual(problem, lam, c, s, scale):
    """c <- the rows' velocities at lam, s <- c + its shift; returns the residual (m/s,
    residual's scale). problem = (A, g, blocks, param, m)."""
    A, g, blocks, param, m = problem
    row_velocities(A, g, lam, m, c)
    shift(blocks, param, c, s)
    for r in range(m):
        s[r] += c[r]
    return residual(blocks, param, lam, s, scale)


@njit(**JIT)
def precondition(problem, scale, out):
    """The problem scaled block by block (Jacobi, one factor a block so that a cone stays a
    cone): scale[r] <- 1 / sqrt(the mean of A's diagonal over row r's block), out = (S (m', m'),
    g_s (m',), param_s (B,)) <- S = D A D, g_s = D g, a friction box's bound over its factor
    (D = diag(scale)). Returns the scaled problem (S, g_s, blocks, param_s, m): its lambda is
    D^-1 lambda, its velocities D c."""
    A, g, blocks, param, m = problem
    S, g_s, param_s = out
    for k in range(blocks.shape[0]):
        first, size = blocks[k, FIRST], blocks[k, SIZE]
        mean = 0.0
        for r in range(first, first + size):
            mean += A[r, r] / size
        factor = 1.0 / np.sqrt(mean) if mean > TINY else 1.0
        for r in range(first, first + size):
            scale[r] = factor
        param_s[k] = param[k] / factor if blocks[k, KIND] == BOX else param[k]
    for r in range(m):
        g_s[r] = g[r] * scale[r]
        for c in range(m):
            S[r, c] = A[r, c] * scale[r] * scale[c]
    return S, g_s, blocks, param_s, m


@njit(**JIT)
def largest_eigenvalue(A, m, x, y):
    """An estimate of the largest eigenvalue of the symmetric positive semi-definite A[:m, :m]
    by POWER_ITERATIONS power iterations (x, y (m,) scratch)."""
    for r in range(m):
        x[r] = 1.0 / np.sqrt(m) * (1.0 + 0.01 * r)
    value = 0.0
    for _ in range(POWER_ITERATIONS):
        for r in range(m):
            s = 0.0
            for k in range(m):
                s += A[r, k] * x[k]
            y[r] = s
        norm = 0.0
        for r in range(m):
            norm += y[r] * y[r]
        norm = np.sqrt(norm)
        if norm <= TINY:
            return 0.0
        value = norm
        for r in range(m):
            x[r] = y[r] / norm
    return value


@njit(**JIT)
def factor_shifted(A, m, rho, F):
    """F[:m, :m] <- the Cholesky factor of A + rho I. Returns a Status."""
    for r in range(m):
        for k in range(m):
            F[r, k] = A[r, k]
        F[r, r] += rho
    return cholesky_factor(F, m, rho)


@njit(**JIT)
def admm(problem, settings, lam, work):
    """lam[:m] <- the NCP's solution by ADMM (module docstring), from lam as it is (the warm
    start, projected on K first), on the problem preconditioned (precondition). problem = (A
    (m', m') with A = G + R, g, blocks (B, 3) int64, param (B,), m); settings = (tolerance
    m/s, max_iterations); work = (F (m', m'), S (m', m'), rows (10, m')). Returns (status,
    iterations, residual m/s)."""
    rows = work[2]
    scale = rows[7]
    m = problem[4]
    scaled = precondition(problem, scale, (work[1], rows[8], rows[9]))
    for r in range(m):
        lam[r] /= scale[r]
    status, iterations, worst = admm_scaled(scaled, settings, lam, work)
    for r in range(m):
        lam[r] *= scale[r]
    return status, iterations, worst


@njit(**JIT)
def admm_scaled(problem, settings, lam, work):
    """admm's iterations on the preconditioned problem (its lam D^-1 lam, work's rows[7] the
    factors D, residuals in the unscaled problem's m/s). Returns (status, iterations,
    residual m/s)."""
    A, g, blocks, param, m = problem
    tolerance, max_iterations = settings
    F, rows = work[0], work[2]
    x, y_prev, u, s, c, w, rhs = rows[0], rows[1], rows[2], rows[3], rows[4], rows[5], rows[6]
    scale = rows[7]
    project(blocks, param, lam)
    worst = shifted_residual(problem, lam, c, w, scale)
    if worst <= tolerance or m == 0:
        return Status.OK.value, 0, worst
    # d_min: the smallest diagonal entry of a row that moves something (a row of zeros, an
    # equality that holds whatever the velocity, has none)
    d_min, d_mean = np.inf, 0.0
    for r in range(m):
        if A[r, r] > TINY:
            d_min = min(d_min, A[r, r])
        d_mean += A[r, r] / m
    largest = max(largest_eigenvalue(A, m, x, rhs), TINY)
    rho = np.sqrt(largest * min(d_min, largest))
    status = factor_shifted(A, m, rho, F)
    if status:
        return status, 0, worst
    # u = -(c + s) at the warm start: a warm start at the solution is a fixed point
    for r in range(m):
        u[r] = -w[r]
    iterations = 0
    while iterations < max_iterations:
        iterations += 1
        # (A + rho I) x = rho y - u - (g + s), s the shift of the dual's velocity -u
        for r in range(m):
            rhs[r] = -u[r]
        shift(blocks, param, rhs, s)
        for r in range(m):
            rhs[r] = rho * lam[r] - u[r] - g[r] - s[r]
            y_prev[r] = lam[r]
        cholesky_substitute(F, m, rhs, x)
        # y = Pi_K(x + u / rho), u += rho (x - y)
        for r in range(m):
            lam[r] = x[r] + u[r] / rho
        project(blocks, param, lam)
        primal = 0.0
        dual = 0.0
        for r in range(m):
            u[r] += rho * (x[r] - lam[r])
            primal = max(primal, abs(x[r] - lam[r]))
            dual = max(dual, abs(lam[r] - y_prev[r]))
        worst = shifted_residual(problem, lam, c, w, scale)
        if worst <= tolerance:
            break
        primal *= d_mean
        dual *= rho
        if primal > RHO_RATIO * dual or dual > RHO_RATIO * primal:
            rho = rho * RHO_STEP if primal > dual else rho / RHO_STEP
            status = factor_shifted(A, m, rho, F)
            if status:
                return status, iterations, worst
    return Status.OK.value, iterations, worst


@njit(**JIT)
def pgs(problem, settings, lam, work):
    """lam[:m] <- the NCP's solution by projected Gauss-Seidel (module docstring), from lam as
    it is (projected on K first); problem, settings and work as admm's (work's F unused).
    Returns (status, iterations, residual m/s)."""
    A, g, blocks, param, m = problem
    tolerance, max_iterations = settings
    rows = work[2]
    c, w = rows[4], rows[5]
    project(blocks, param, lam)
    worst = shifted_residual(problem, lam, c, w, None)
    iterations = 0
    while worst > tolerance and iterations < max_iterations and m > 0:
        iterations += 1
        for k in range(blocks.shape[0]):
            kind, r = blocks[k, KIND], blocks[k, FIRST]
            if kind == CONE:
                pgs_cone(problem, lam, r, param[k])
            elif A[r, r] > TINY:  # a row that moves nothing (A_rr = 0) keeps its impulse
                x = lam[r] - row_dot(A, g, lam, m, r) / A[r, r]
                if kind == UNILATERAL:
                    x = max(0.0, x)
                elif kind == BOX:
                    x = min(param[k], max(-param[k], x))
                lam[r] = x
        worst = shifted_residual(problem, lam, c, w, None)
    return Status.OK.value, iterations, worst


@njit(**JIT)
def pgs_cone(problem, lam, r, mu):
    """One projected Gauss-Seidel update of the contact at rows r.. (t1, t2, n) with
    coefficient mu: the normal row, then the tangent rows projected on the disk of radius
    mu lambda_n (module docstring); nothing for a contact whose normal moves nothing."""
    A, g, _, _, m = problem
    n = r + 2
    if not A[n, n] > TINY:
        return
    lam[n] = max(0.0, lam[n] - row_dot(A, g, lam, m, n) / A[n, n])
    step = max(A[r, r], A[r + 1, r + 1], TINY)
    c1 = row_dot(A, g, lam, m, r)
    c2 = row_dot(A, g, lam, m, r + 1)
    lam[r] -= c1 / step
    lam[r + 1] -= c2 / step
    size = np.sqrt(lam[r] ** 2 + lam[r + 1] ** 2)
    bound = mu * lam[n]
    if size > bound:
        scale = bound / size
        lam[r] *= scale
        lam[r + 1] *= scale


@njit(**JIT)
def row_dot(A, g, lam, m, r):
    """(A lam + g)[r]: row r's velocity (m/s)."""
    s = g[r]
    for k in range(m):
        s += A[r, k] * lam[k]
    return s


@njit(**JIT)
def solve_ncp(solver, problem, settings, lam, work):
    """lam <- the NCP's solution by `solver` (ADMM or PGS) from the warm start in lam. Returns
    (status, iterations, residual m/s)."""
    if solver == PGS:
        return pgs(problem, settings, lam, work)
    return admm(problem, settings, lam, work)
