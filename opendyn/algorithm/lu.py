"""LU factorisation with partial pivoting of a general square matrix, and its solve:

    P A = L U,   x = A^-1 b  by  L y = P b,  U x = y

(L unit lower triangular, U upper triangular, both in place in A; P the row swaps, piv[k] the
row swapped into place k). For the linearly implicit Euler step, whose matrix
M + dt D + dt^2 K is not symmetric once the contact's exact derivatives enter it
(opendyn.algorithm.contact), where the Cholesky factorisation of opendyn.algorithm.cholesky
would read only its lower triangle. A column with no pivot above SINGULAR_PIVOT times the
largest entry reports which coordinate has nothing moving with it.
"""

from __future__ import annotations

from numba import njit

from .._runtime.kernel_cache import JIT
from .._runtime.status import Status
from .cholesky import SINGULAR_PIVOT


@njit(**JIT)
def lu_factor(A, piv):
    """A (n, n) <- L and U of P A = L U in place; piv (n,) int64 <- the row brought to place k
    at step k. Returns Status.OK.value, or SINGULAR + k for the first column k whose largest
    remaining entry is not above SINGULAR_PIVOT times the largest entry of A."""
    n = A.shape[0]
    scale = 0.0
    for r in range(n):
        for c in range(n):
            scale = max(scale, abs(A[r, c]))
    for k in range(n):
        # the largest entry of column k at or below the diagonal becomes the pivot
        best = k
        for r in range(k + 1, n):
            if abs(A[r, k]) > abs(A[best, k]):
                best = r
        piv[k] = best
        if not abs(A[best, k]) > SINGULAR_PIVOT * scale:
            return Status.SINGULAR.value + k
        if best != k:
            for c in range(n):
                A[k, c], A[best, c] = A[best, c], A[k, c]
        # rows below: l_rk = a_rk / u_kk, a_rc -= l_rk u_kc
        for r in range(k + 1, n):
            A[r, k] /= A[k, k]
            l_rk = A[r, k]
            if l_rk != 0.0:
                for c in range(k + 1, n):
                    A[r, c] -= l_rk * A[k, c]
    return Status.OK.value


@njit(**JIT)
def lu_substitute(LU, piv, b, x):
    """x (n,) <- A^-1 b for LU, piv from lu_factor: the row swaps, L y = P b, U x = y (x may
    be b)."""
    n = LU.shape[0]
    for r in range(n):
        x[r] = b[r]
    for k in range(n):
        x[k], x[piv[k]] = x[piv[k]], x[k]
    for r in range(n):
        s = x[r]
        for c in range(r):
            s -= LU[r, c] * x[c]
        x[r] = s
    for r in range(n - 1, -1, -1):
        s = x[r]
        for c in range(r + 1, n):
            s -= LU[r, c] * x[c]
        x[r] = s / LU[r, r]


@njit(**JIT)
def lu_solve(A, piv, b, x):
    """x (n,) <- A^-1 b for a general (n, n) A (overwritten by its factors; piv (n,) int64 <-
    its row swaps). Returns Status.OK.value or SINGULAR + k (lu_factor)."""
    status = lu_factor(A, piv)
    if status == Status.OK.value:
        lu_substitute(A, piv, b, x)
    return status
