"""Eigendecomposition of a small symmetric matrix, compiled:

    G = E diag(e) E^T,   E^T E = I

by cyclic Jacobi rotations (Golub & Van Loan, Matrix Computations, Section 8.5): the
pseudo-inverse (A M^-1 A^T)^+ of the constrained solve (opendyn.algorithm.constraints.solve)
and the task-space inertia Lambda = (J_b M^-1 J_b^T)^-1 (opendyn.algorithm.task_space).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .._runtime.arrays import zero_matrix
from .._runtime.kernel_cache import JIT

JACOBI_MAX_SWEEPS = 60


@njit(**JIT)
def symmetric_eigen(G, E, e):
    """G = E diag(e) E^T for a symmetric (k, k) G, by cyclic Jacobi rotations (Golub & Van Loan,
    Matrix Computations, Section 8.5): G is overwritten, E (k, k) <- orthonormal eigenvectors
    (columns), e (k,) <- eigenvalues. A fixed cap of sweeps: no exception, no NaN from finite G."""
    k = G.shape[0]
    zero_matrix(E)
    for i in range(k):
        E[i, i] = 1.0
    total = 0.0
    for i in range(k):
        for j in range(k):
            total += G[i, j] * G[i, j]
    for sweep in range(JACOBI_MAX_SWEEPS):
        off = 0.0
        for i in range(k):
            for j in range(i + 1, k):
                off += G[i, j] * G[i, j]
        if not off > 1e-32 * total:
            break
        for a in range(k - 1):
            for b in range(a + 1, k):
                g_ab = G[a, b]
                if g_ab == 0.0:
                    continue
                theta = (G[b, b] - G[a, a]) / (2.0 * g_ab)
                if abs(theta) > 1e150:
                    t = 0.5 / theta
                else:
                    t = 1.0 / (abs(theta) + np.sqrt(theta * theta + 1.0))
                    if theta < 0.0:
                        t = -t
                c = 1.0 / np.sqrt(t * t + 1.0)
                s = t * c
                # G <- J^T G J with J = [[c, s], [-s, c]] in the (a, b) plane; E <- E J
                for i in range(k):
                    g_ia, g_ib = G[i, a], G[i, b]
                    G[i, a] = c * g_ia - s * g_ib
                    G[i, b] = s * g_ia + c * g_ib
                for i in range(k):
                    g_ai, g_bi = G[a, i], G[b, i]
                    G[a, i] = c * g_ai - s * g_bi
                    G[b, i] = s * g_ai + c * g_bi
                G[a, b] = 0.0
                G[b, a] = 0.0
                for i in range(k):
                    e_ia, e_ib = E[i, a], E[i, b]
                    E[i, a] = c * e_ia - s * e_ib
                    E[i, b] = s * e_ia + c * e_ib
    for i in range(k):
        e[i] = G[i, i]
