"""Compiled building blocks shared by the dynamics kernels: views of the model's flat buffers
(laid out by the tables in opendyn.model) and the 3x3-block forms of Ad_T and ad_V on twists,
wrenches and spatial inertias (the joints themselves are in opendyn.dynamics.joints).

Pose of body i in its parent: (R, p) = (R_{lambda i}, p_{lambda i}). Then, angular first,
  twist to child   Ad_{T_{i,lambda}} V  = (R^T w,  R^T (v + w x p))
  wrench to parent Ad_{T_{i,lambda}}^T F = (R m + p x (R f),  R f)
  ad_V W = (w x w_W,  v x w_W + w x v_W);   -ad_V^T F = (w x m + v x f,  w x f)
Small helpers are inlined by numba, so the kernels read like the algorithm boxes.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor

import numpy as np
from numba import njit

from .._kernel_cache import CACHING
from ..model import FLOAT_AT, INT_AT, INT_HEADER
from ..status import Status

JIT = dict(cache=CACHING)
# batch loops release the GIL so that threads run them in parallel (see run_rows); single-state
# kernels keep it, which saves the release and re-acquisition on every call
BATCH = dict(cache=CACHING, nogil=True)
# helpers that take views of the per-body arrays are inlined into the kernels at the numba IR
# level (measured: RNEA on a UR5 1.46 -> 1.10 us per call inside a compiled loop; called as
# compiled functions instead, 1.2 -> 2.1 us). IR inlining is what costs numba's front end most
# when a kernel compiles, so the loop helpers (all_finite, copy_into, fill, zero_matrix, dot6)
# are plain compiled functions, which LLVM inlines anyway: ABA compiles in 4.6 s instead of
# 5.6 s at the same speed.
INLINE = dict(cache=CACHING, inline="always")

_MIN_ROWS_PER_THREAD = 64
_pool = None


def run_rows(batch_kernel, n, *args):
    """batch_kernel(*args, start, stop) over the rows [0, n) of a batch, one slice per core.

    The batch kernels are plain compiled loops that release the GIL, so threads run them in
    parallel; a plain loop compiles in a fraction of the time of a numba prange loop.
    """
    global _pool
    cores = os.cpu_count() or 1
    chunks = min(cores, max(1, n // _MIN_ROWS_PER_THREAD))
    if chunks == 1:
        batch_kernel(*args, 0, n)
        return
    if _pool is None:
        _pool = ThreadPoolExecutor(max_workers=cores, thread_name_prefix="opendyn")
    bounds = np.linspace(0, n, chunks + 1).astype(int)
    futures = [
        _pool.submit(batch_kernel, *args, int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:])
    ]
    for f in futures:
        f.result()


def _where(at, name, header=0):
    """(header, first, last) of one field, first and last in units of nb: a tuple, which numba
    freezes as a compile-time constant."""
    start, size, _ = at[name]
    return (header, start, start + size)


_PARENT, _JTYPE, _NV_J, _IQ, _IV = (
    _where(INT_AT, n, INT_HEADER) for n in ("parent", "jtype", "nv_j", "iq", "iv")
)
_MULT, _OFFSET, _S, _G, _MASS, _H, _I_O, _R_HOME, _P_HOME = (
    _where(FLOAT_AT, n)
    for n in ("mult", "offset", "S", "G", "mass", "h", "I_o", "R_home", "p_home")
)


@njit(**INLINE)
def field(buf, nb, where):
    """The flat slice of one field of a buffer; where = (header, first, last) from the layout
    table in opendyn.model (first, last in units of nb)."""
    header, first, last = where
    return buf[header + first * nb : header + last * nb]


@njit(**INLINE)
def body_count(ibuf):
    """nb from the model's int buffer, as int64 whatever the buffer's dtype
    (opendyn.model.FREE_JOINTS_INT), so that shapes built from it type alike."""
    return np.int64(ibuf[0])


@njit(**INLINE)
def tree(ibuf, fbuf):
    """Views of the model's tree: parent, jtype, nv_j, iq, iv, mult, offset, S, R_home, p_home
    (fields of model.INT_FIELDS and model.FLOAT_FIELDS). Each kernel takes only the views it
    needs (a reshaped view costs about 20 ns)."""
    nb = body_count(ibuf)
    return (
        field(ibuf, nb, _PARENT),
        field(ibuf, nb, _JTYPE),
        field(ibuf, nb, _NV_J),
        field(ibuf, nb, _IQ),
        field(ibuf, nb, _IV),
        field(fbuf, nb, _MULT),
        field(fbuf, nb, _OFFSET),
        field(fbuf, nb, _S).reshape((nb, 6, 6)),
        field(fbuf, nb, _R_HOME).reshape((nb, 3, 3)),
        field(fbuf, nb, _P_HOME).reshape((nb, 3)),
    )


@njit(**INLINE)
def rigid_inertias(ibuf, fbuf):
    """Views of the body inertias in rigid-body form: mass (nb,), h = m c (nb, 3),
    I_o (nb, 3, 3)."""
    nb = body_count(ibuf)
    return (
        field(fbuf, nb, _MASS),
        field(fbuf, nb, _H).reshape((nb, 3)),
        field(fbuf, nb, _I_O).reshape((nb, 3, 3)),
    )


@njit(**INLINE)
def spatial_inertias(ibuf, fbuf):
    """View of the (nb, 6, 6) spatial inertias G_i."""
    nb = body_count(ibuf)
    return field(fbuf, nb, _G).reshape((nb, 6, 6))


@njit(**JIT)
def copy_into(src, dst):
    """dst[k] = src[k] for 1-D arrays of one length. An explicit loop: a slice assignment
    `dst[:] = src` makes numba compile a shape-mismatch error path into every kernel."""
    for k in range(dst.shape[0]):
        dst[k] = src[k]


@njit(**JIT)
def fill(x, value):
    """x[k] = value for every entry of the 1-D array x (see copy_into)."""
    for k in range(x.shape[0]):
        x[k] = value


@njit(**JIT)
def zero_matrix(X):
    """X[r, c] = 0 for a 2-D array (see copy_into)."""
    for r in range(X.shape[0]):
        for c in range(X.shape[1]):
            X[r, c] = 0.0


@njit(**JIT)
def all_finite(x):
    """True when every entry of the 1-D array x is finite."""
    for k in range(x.shape[0]):
        if not np.isfinite(x[k]):
            return False
    return True


@njit(**JIT)
def result_status(x):
    """OK when every entry of the C-contiguous result x is finite, else RESULT_NOT_FINITE: a
    kernel's last check, after its finite arguments (float64 overflowed on the way)."""
    return Status.OK.value if all_finite(x.reshape(x.size)) else Status.RESULT_NOT_FINITE.value


@njit(**INLINE)
def cross3(a, b, out):
    """out = a x b (out must not alias a or b)."""
    out[0] = a[1] * b[2] - a[2] * b[1]
    out[1] = a[2] * b[0] - a[0] * b[2]
    out[2] = a[0] * b[1] - a[1] * b[0]


@njit(**INLINE)
def twist_to_child(R, p, V_parent, V_child):
    """V_child = Ad_{T_{i,lambda}} V_parent = (R^T w, R^T (v + w x p))."""
    w0, w1, w2 = V_parent[0], V_parent[1], V_parent[2]
    u0 = V_parent[3] + w1 * p[2] - w2 * p[1]
    u1 = V_parent[4] + w2 * p[0] - w0 * p[2]
    u2 = V_parent[5] + w0 * p[1] - w1 * p[0]
    for k in range(3):
        V_child[k] = R[0, k] * w0 + R[1, k] * w1 + R[2, k] * w2
        V_child[3 + k] = R[0, k] * u0 + R[1, k] * u1 + R[2, k] * u2


@njit(**INLINE)
def add_wrench_to_parent(R, p, F_child, F_parent):
    """F_parent += Ad_{T_{i,lambda}}^T F_child = (R m + p x (R f), R f)."""
    m0 = R[0, 0] * F_child[0] + R[0, 1] * F_child[1] + R[0, 2] * F_child[2]
    m1 = R[1, 0] * F_child[0] + R[1, 1] * F_child[1] + R[1, 2] * F_child[2]
    m2 = R[2, 0] * F_child[0] + R[2, 1] * F_child[1] + R[2, 2] * F_child[2]
    f0 = R[0, 0] * F_child[3] + R[0, 1] * F_child[4] + R[0, 2] * F_child[5]
    f1 = R[1, 0] * F_child[3] + R[1, 1] * F_child[4] + R[1, 2] * F_child[5]
    f2 = R[2, 0] * F_child[3] + R[2, 1] * F_child[4] + R[2, 2] * F_child[5]
    F_parent[0] += m0 + p[1] * f2 - p[2] * f1
    F_parent[1] += m1 + p[2] * f0 - p[0] * f2
    F_parent[2] += m2 + p[0] * f1 - p[1] * f0
    F_parent[3] += f0
    F_parent[4] += f1
    F_parent[5] += f2


@njit(**INLINE)
def ad_twist(V, W, out):
    """out = ad_V W = (w x w_W, v x w_W + w x v_W)  (the Lie bracket [V, W])."""
    out[0] = V[1] * W[2] - V[2] * W[1]
    out[1] = V[2] * W[0] - V[0] * W[2]
    out[2] = V[0] * W[1] - V[1] * W[0]
    out[3] = V[4] * W[2] - V[5] * W[1] + V[1] * W[5] - V[2] * W[4]
    out[4] = V[5] * W[0] - V[3] * W[2] + V[2] * W[3] - V[0] * W[5]
    out[5] = V[3] * W[1] - V[4] * W[0] + V[0] * W[4] - V[1] * W[3]


@njit(**INLINE)
def add_neg_ad_transpose(V, P, out):
    """out += -ad_V^T P = (w x P_m + v x P_f, w x P_f) for a momentum or wrench P."""
    out[0] += V[1] * P[2] - V[2] * P[1] + V[4] * P[5] - V[5] * P[4]
    out[1] += V[2] * P[0] - V[0] * P[2] + V[5] * P[3] - V[3] * P[5]
    out[2] += V[0] * P[1] - V[1] * P[0] + V[3] * P[4] - V[4] * P[3]
    out[3] += V[1] * P[5] - V[2] * P[4]
    out[4] += V[2] * P[3] - V[0] * P[5]
    out[5] += V[0] * P[4] - V[1] * P[3]


@njit(**INLINE)
def mat6_vec(G, V, out):
    """out = G V for a (6, 6) matrix."""
    for r in range(6):
        s = 0.0
        for c in range(6):
            s += G[r, c] * V[c]
        out[r] = s


@njit(**INLINE)
def inertia_times_motion(I, s, out):
    """out = I s for a (6, 6) inertia and a motion axis s (a row of a joint's S), reading only
    the columns of I where s is not zero (three for a revolute or prismatic axis)."""
    for r in range(6):
        out[r] = 0.0
    for c in range(6):
        if s[c] != 0.0:
            for r in range(6):
                out[r] += I[r, c] * s[c]


@njit(**JIT)
def dot6(a, b):
    """a . b for 6-vectors (e.g. the power F . A of a wrench on a screw axis)."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3] + a[4] * b[4] + a[5] * b[5]


@njit(**INLINE)
def add_inertia_to_parent(R, p, I_child, I_parent, S):
    """I_parent += Ad_{T_{i,lambda}}^T I_child Ad_{T_{i,lambda}} for a symmetric (6, 6) inertia.

    Rotate the blocks of I_child = [[K, B], [B^T, C]] into the parent's axes (K' = R K R^T,
    B' = R B R^T, C' = R C R^T, each as R (X R^T)), then shift the reference point by p:
      C_p = C',   B_p = B' + [p] C',   K_p = K' - B'[p] + [p] B'^T - [p] C' [p].
    S is (9, 6) scratch: K', B', C' in rows 0-2, 3-5, 6-8 of columns 0-2; X R^T in rows 0-2
    and [p] C' in rows 3-5 of columns 3-5.
    """
    for blk in range(3):
        br = 0 if blk < 2 else 3
        bc = 0 if blk == 0 else 3
        for k in range(3):
            for c in range(3):
                S[k, 3 + c] = (
                    I_child[br + k, bc] * R[c, 0]
                    + I_child[br + k, bc + 1] * R[c, 1]
                    + I_child[br + k, bc + 2] * R[c, 2]
                )
        for r in range(3):
            for c in range(3):
                S[3 * blk + r, c] = R[r, 0] * S[0, 3 + c] + R[r, 1] * S[1, 3 + c] + R[r, 2] * S[
                    2, 3 + c
                ]
    P = ((0.0, -p[2], p[1]), (p[2], 0.0, -p[0]), (-p[1], p[0], 0.0))
    for r in range(3):
        for c in range(3):
            S[3 + r, 3 + c] = P[r][0] * S[6, c] + P[r][1] * S[7, c] + P[r][2] * S[8, c]
    for r in range(3):
        for c in range(3):
            B_rc = S[3 + r, c] + S[3 + r, 3 + c]
            I_parent[r, 3 + c] += B_rc
            I_parent[3 + c, r] += B_rc
            I_parent[3 + r, 3 + c] += S[6 + r, c]
            K_rc = S[r, c]
            for k in range(3):
                K_rc += -S[3 + r, k] * P[k][c] + P[r][k] * S[3 + c, k] - S[3 + r, 3 + k] * P[k][c]
            I_parent[r, c] += K_rc


@njit(**INLINE)
def rigid_inertia_times(mass, h, I_o, V, out):
    """out = G V for G = [[I_o, [h]], [[h]^T, m 1]]: (I_o w + h x v, m v - h x w)."""
    w0, w1, w2, v0, v1, v2 = V[0], V[1], V[2], V[3], V[4], V[5]
    out[0] = I_o[0, 0] * w0 + I_o[0, 1] * w1 + I_o[0, 2] * w2 + h[1] * v2 - h[2] * v1
    out[1] = I_o[1, 0] * w0 + I_o[1, 1] * w1 + I_o[1, 2] * w2 + h[2] * v0 - h[0] * v2
    out[2] = I_o[2, 0] * w0 + I_o[2, 1] * w1 + I_o[2, 2] * w2 + h[0] * v1 - h[1] * v0
    out[3] = mass * v0 - h[1] * w2 + h[2] * w1
    out[4] = mass * v1 - h[2] * w0 + h[0] * w2
    out[5] = mass * v2 - h[0] * w1 + h[1] * w0


@njit(**INLINE)
def add_rigid_inertia_to_parent(R, p, mass, h, I_o, mass_p, h_p, I_p, S):
    """(mass_p, h_p, I_p) += the rigid-body inertia (mass, h, I_o) of {i} expressed in {lambda}.

    With u = R h:  m' = m,  h' = u + m p,
    I' = R I_o R^T - ([u][p] + [p][u]) - m [p][p]
       = R I_o R^T - (p u^T + u p^T) + 2 (u . p) 1 - m (p p^T - |p|^2 1).
    S is (3, 3) scratch for I_o R^T.
    """
    u0 = R[0, 0] * h[0] + R[0, 1] * h[1] + R[0, 2] * h[2]
    u1 = R[1, 0] * h[0] + R[1, 1] * h[1] + R[1, 2] * h[2]
    u2 = R[2, 0] * h[0] + R[2, 1] * h[1] + R[2, 2] * h[2]
    u = (u0, u1, u2)
    mass_p[0] += mass
    for r in range(3):
        h_p[r] += u[r] + mass * p[r]
    diag = 2.0 * (u0 * p[0] + u1 * p[1] + u2 * p[2]) + mass * (
        p[0] * p[0] + p[1] * p[1] + p[2] * p[2]
    )
    for k in range(3):
        for c in range(3):
            S[k, c] = I_o[k, 0] * R[c, 0] + I_o[k, 1] * R[c, 1] + I_o[k, 2] * R[c, 2]
    for r in range(3):
        for c in range(r, 3):
            v = (
                R[r, 0] * S[0, c]
                + R[r, 1] * S[1, c]
                + R[r, 2] * S[2, c]
                - p[r] * u[c]
                - u[r] * p[c]
                - mass * p[r] * p[c]
            )
            if r == c:
                I_p[r, r] += v + diag
            else:
                I_p[r, c] += v
                I_p[c, r] += v


@njit(**INLINE)
def wrench_to_parent(R, p, F):
    """F <- Ad_{T_{i,lambda}}^T F = (R m + p x (R f), R f), in place."""
    f0 = R[0, 0] * F[3] + R[0, 1] * F[4] + R[0, 2] * F[5]
    f1 = R[1, 0] * F[3] + R[1, 1] * F[4] + R[1, 2] * F[5]
    f2 = R[2, 0] * F[3] + R[2, 1] * F[4] + R[2, 2] * F[5]
    m0 = R[0, 0] * F[0] + R[0, 1] * F[1] + R[0, 2] * F[2] + p[1] * f2 - p[2] * f1
    m1 = R[1, 0] * F[0] + R[1, 1] * F[1] + R[1, 2] * F[2] + p[2] * f0 - p[0] * f2
    m2 = R[2, 0] * F[0] + R[2, 1] * F[1] + R[2, 2] * F[2] + p[0] * f1 - p[1] * f0
    F[0], F[1], F[2], F[3], F[4], F[5] = m0, m1, m2, f0, f1, f2
