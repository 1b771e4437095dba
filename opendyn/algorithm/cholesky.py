"""Cholesky factorisation of a symmetric positive definite matrix, and its solve:

    M = L L^T,   x = M^-1 b  by  L y = b,  L^T x = y

on the leading n x n block of an array (the forward dynamics' M, and the joint-space inertia
D_i = S_i^T IA_i S_i of a multi-dof joint in ABA). A pivot that is not positive, relative to the
largest diagonal entry, reports which coordinate has no inertia moving with it.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .._runtime.kernel_cache import JIT
from .._runtime.status import Status

SINGULAR_PIVOT = 1e-14  # a pivot below this times the scale: nothing moves with that coordinate


@njit(**JIT)
def cholesky_factor(M, n, scale):
    """M[:n, :n] = L L^T, L in place in the lower triangle of M's leading block. Returns
    Status.OK.value, or SINGULAR + k for the first k whose pivot is not above
    SINGULAR_PIVOT * scale (scale: the largest inertia in play)."""
    for k in range(n):
        d = M[k, k]
        for m in range(k):
            d -= M[k, m] * M[k, m]
        if not d > SINGULAR_PIVOT * scale:
            return Status.SINGULAR.value + k
        d = np.sqrt(d)
        M[k, k] = d
        for r in range(k + 1, n):
            s = M[r, k]
            for m in range(k):
                s -= M[r, m] * M[k, m]
            M[r, k] = s / d
    return Status.OK.value


@njit(**JIT)
def forward_substitute(L, n, b, y):
    """y[:n] = L^-1 b[:n] for L from cholesky_factor: L y = b (y may be b)."""
    for r in range(n):
        s = b[r]
        for m in range(r):
            s -= L[r, m] * y[m]
        y[r] = s / L[r, r]


@njit(**JIT)
def back_substitute(L, n, y, x):
    """x[:n] = L^-T y[:n] for L from cholesky_factor: L^T x = y (x may be y)."""
    for r in range(n - 1, -1, -1):
        s = y[r]
        for m in range(r + 1, n):
            s -= L[m, r] * x[m]
        x[r] = s / L[r, r]


@njit(**JIT)
def cholesky_substitute(L, n, b, x):
    """x[:n] = (L L^T)^-1 b[:n] for L from cholesky_factor: L y = b, then L^T x = y (x may be
    b)."""
    forward_substitute(L, n, b, x)
    back_substitute(L, n, x, x)


@njit(**JIT)
def largest_diagonal(M):
    """max_k M[k, k]: the scale of a mass matrix's pivots."""
    scale = 0.0
    for k in range(M.shape[0]):
        scale = max(scale, M[k, k])
    return scale


@njit(**JIT)
def cholesky_solve(M, b, x):
    """x = M^-1 b for a whole (n, n) M, by M = L L^T in place in M, pivots relative to M's
    largest diagonal entry. Returns Status.OK.value or SINGULAR + k."""
    n = M.shape[0]
    status = cholesky_factor(M, n, largest_diagonal(M))
    if status == Status.OK.value:
        cholesky_substitute(M, n, b, x)
    return status
