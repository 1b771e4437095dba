"""The partial derivatives of inverse dynamics, tau = ID(q, qd, qdd), by differentiating the
recursive Newton-Euler algorithm (Carpentier and Mansard, "Analytical Derivatives of Rigid
Body Dynamics Algorithms", RSS 2018; Pinocchio's computeRNEADerivatives), O(n d) for a tree
of n bodies and depth d:

    dtau/dq (nv, nv),   dtau/dqd (nv, nv),   dtau/dqdd = M(q) (nv, nv).

Computed in the world frame {s}, where moving a joint carries its whole subtree along rigidly.
Per body i, with lambda its parent (the world for a root: V = 0, A = (0, -g)):
    S_k = mult_i Ad_{T_si} S_i[k]          the space axis of each coordinate k of joint i
    V_i = V_lambda + sum_k S_k qd_k        its space twist
    A_i = A_lambda + sum_k (dS_k qd_k + S_k qdd_k),   dS_k = V_i x S_k
    F_i = G_i A_i + V_i x* G_i V_i + F_ext,i          (G_i = Ad_{T_is}^T G Ad_{T_is})
    tau_k = S_k^T Fc_i,  Fc_i = sum over the subtree of i of F_j
(x is ad, x* = -ad^T.) Moving coordinate k by dq_k moves every body j of the subtree by the
screw S_k dq_k: what is fixed in those bodies turns with it (dS_j = S_k x S_j, dF_j = S_k x*
F_j, dG_j = S_k x* G_j - G_j (S_k x)), and the twists and accelerations change by that rigid
motion plus what the parent's motion adds (for every j in the subtree of i):
    dV_j = S_k x V_j + psi_k,        psi_k   = V_lambda x S_k
    dA_j = S_k x A_j + alpha_k + psi_k x V_j,   alpha_k = A_lambda x S_k + V_lambda x psi_k
so that (the rigid parts cancel in S_m^T F, a power)
    dF_j = S_k x* F_j + G_j alpha_k + D_j psi_k,
    D_j x = V_j x* G_j x - G_j (V_j x x) + x x* (G_j V_j) = 2 Bs_j x
with Bs the Coriolis matrix's body term (opendyn.algorithm.christoffel, angular columns only).
In qd: dV_j/dqd_k = S_k and dA_j/dqd_k = S_k x V_j + beta_k, beta_k = dS_k + psi_k, so
    dF_j/dqd_k = G_j beta_k + D_j S_k.
With the subtree sums Gc, Dc = 2 Bc and Fc, for coordinates m of body a and k of body b:
    a in the subtree of b (a = b too):   dtau_m/dq_k  = u_m . alpha_k + w_m . psi_k
                                         dtau_m/dqd_k = u_m . beta_k + w_m . S_k
                                         M_mk         = u_m . S_k
        with u_m = Gc_a S_m and w_m = Dc_a^T S_m,
    b strictly below a:                  dtau_m/dq_k  = S_m . (Gc_b alpha_k + Dc_b psi_k
                                                                + S_k x* Fc_b)
                                         dtau_m/dqd_k = S_m . (Gc_b beta_k + Dc_b S_k)
                                         M_mk         = S_m . Gc_b S_k
and 0 between branches. The same formulas hold for a free joint anywhere in the tree: its
coordinates are the body twist, and dq moves it by q (+) dq = T exp(dq) (the configuration
functions' integrate), whose space screw is S_k dq_k. Derivatives in q are taken in that
tangent space: dtau/dq[:, k] = d/de tau(integrate(q, e e_k), qd, qdd) at e = 0, as Pinocchio's.
A coupled (mimic) joint adds mult times its share: its axes carry mult (S_s).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .._runtime.arrays import result_status, zero_matrix
from .._runtime.entry import exact
from .._runtime.kernel_cache import BATCH, INLINE, JIT
from ..multibody.joints import motion_status
from ..multibody.layout import body_count, dof_count, tree
from ..multibody.work_views import (
    axis_rates,
    coriolis_terms,
    new_work,
    scratch_rows,
    temp_vectors,
    world_poses,
)
from ..spatial.compiled import (
    ad_twist,
    add_neg_ad_transpose,
    add_wrench_to_parent,
    dot6,
    mat6_vec,
)
from . import checks
from .calls import Call, checked_call
from .christoffel import space_axes_and_inertias, velocity_terms


@njit(**JIT)
def accelerations_and_wrenches(ibuf, fbuf, work, qd, qdd, loads):
    """With the CoriolisTerms of space_axes_and_inertias and velocity_terms in `work`, the
    AxisRates there: A_s[i] = A_lambda + sum_k (dS_k qd_k + S_k qdd_k) (A = (0, -g) for the
    world), per axis k of joint i psi = V_lambda x S_k, alpha = A_lambda x S_k + V_lambda x
    psi, beta = dS_k + psi; Fc_s[i] = the sum over the subtree of i of G_s A_s + V_s x* G_s
    V_s + F_ext (loads[1 + j] in {j}, when present, carried to {s})."""
    body_tree = tree(ibuf, fbuf)
    parent, nv_j, iv = body_tree.parent, body_tree.nv_j, body_tree.iv
    nb = parent.shape[0]
    terms = coriolis_terms(work, nb)
    S_s, G_s, dS, V_s = terms.S_s, terms.G_s, terms.dS, terms.V_s
    rates = axis_rates(work, nb)
    A_s, Fc, psi, alpha, beta = rates.A_s, rates.Fc_s, rates.psi, rates.alpha, rates.beta
    R_s, p_s = world_poses(work, nb)
    x = temp_vectors(work, nb, qd.shape[0])[0]
    wrenches = loads.shape[0] > 1
    for i in range(nb):
        lam = parent[i]
        A_lam = loads[0] if lam < 0 else A_s[lam]
        for r in range(6):
            A_s[i, r] = A_lam[r]
        for k in range(nv_j[i]):
            qd_k, qdd_k = qd[iv[i] + k], qdd[iv[i] + k]
            for r in range(6):
                A_s[i, r] += dS[i, k, r] * qd_k + S_s[i, k, r] * qdd_k
        # psi = V_lambda x S_k, alpha = A_lambda x S_k + V_lambda x psi, beta = dS_k + psi
        for k in range(nv_j[i]):
            ad_twist(A_lam, S_s[i, k], alpha[i, k])
            if lam < 0:
                for r in range(6):
                    psi[i, k, r] = 0.0
            else:
                ad_twist(V_s[lam], S_s[i, k], psi[i, k])
                ad_twist(V_s[lam], psi[i, k], x)
                for r in range(6):
                    alpha[i, k, r] += x[r]
            for r in range(6):
                beta[i, k, r] = dS[i, k, r] + psi[i, k, r]
        # F_i = G A + V x* G V (+ the wrench on the environment, carried from {i} to {s})
        mat6_vec(G_s[i], A_s[i], Fc[i])
        mat6_vec(G_s[i], V_s[i], x)
        add_neg_ad_transpose(V_s[i], x, Fc[i])
        if wrenches:
            add_wrench_to_parent(R_s[i], p_s[i], loads[1 + i], Fc[i])
    for i in range(nb - 1, 0, -1):
        lam = parent[i]
        if lam >= 0:
            for r in range(6):
                Fc[lam, r] += Fc[i, r]


@njit(**INLINE)
def dot3(w, x):
    """w . x[:3]: a 3-vector against the angular half of a 6-vector."""
    return w[0] * x[0] + w[1] * x[1] + w[2] * x[2]


@njit(**JIT)
def assemble_derivatives(ibuf, fbuf, work, dtau_dq, dtau_dqd, M):
    """dtau_dq, dtau_dqd, M (nv, nv) from the CoriolisTerms and AxisRates in `work` (the module
    docstring's last formulas), walking each body's path to the root once."""
    body_tree = tree(ibuf, fbuf)
    parent, nv_j, iv = body_tree.parent, body_tree.nv_j, body_tree.iv
    nb = parent.shape[0]
    terms = coriolis_terms(work, nb)
    S_s, Gc, Bc = terms.S_s, terms.Gc, terms.Bc
    rates = axis_rates(work, nb)
    Fc, psi, alpha, beta = rates.Fc_s, rates.psi, rates.alpha, rates.beta
    zero_matrix(dtau_dq)
    zero_matrix(dtau_dqd)
    zero_matrix(M)
    # u = Gc_b S_k, w = Dc_b^T S_k (its linear half is 0: Dc = 2 Bc has angular columns
    # only), and for the rows above b: X = Gc_b alpha_k + Dc_b psi_k + S_k x* Fc_b,
    # Y = Gc_b beta_k + Dc_b S_k
    rows = scratch_rows(work, nb, M.shape[0])
    u, w, X, Y = rows[0], rows[1], rows[2], rows[3]
    for b in range(nb):
        for k in range(nv_j[b]):
            kb = iv[b] + k
            S_k = S_s[b, k]
            mat6_vec(Gc[b], S_k, u)
            mat6_vec(Gc[b], alpha[b, k], X)
            mat6_vec(Gc[b], beta[b, k], Y)
            for c in range(3):
                s = 0.0
                for r in range(6):
                    s += Bc[b, r, c] * S_k[r]
                    X[r] += 2.0 * Bc[b, r, c] * psi[b, k, c]
                    Y[r] += 2.0 * Bc[b, r, c] * S_k[c]
                w[c] = 2.0 * s
            add_neg_ad_transpose(S_k, Fc[b], X)
            a = b
            while a >= 0:
                for m in range(nv_j[a]):
                    ka = iv[a] + m
                    S_m = S_s[a, m]
                    # b in the subtree of a: the row of b's axis k, the column of a's axis m
                    dtau_dq[kb, ka] += dot6(u, alpha[a, m]) + dot3(w, psi[a, m])
                    dtau_dqd[kb, ka] += dot6(u, beta[a, m]) + dot3(w, S_m)
                    M[kb, ka] += dot6(u, S_m)
                    if a != b:  # b strictly below a: the row of a's axis m, the column of b's
                        dtau_dq[ka, kb] += dot6(S_m, X)
                        dtau_dqd[ka, kb] += dot6(S_m, Y)
                        M[ka, kb] += dot6(S_m, u)
                a = parent[a]


@njit(**JIT)
def joint_space_forces(ibuf, fbuf, work, tau):
    """tau (nv,) <- S_k . Fc_s[i] for every axis k of every body i, the shares of coupled
    joints added: the generalized forces of the AxisRates' subtree wrenches in `work`."""
    body_tree = tree(ibuf, fbuf)
    parent, nv_j, iv = body_tree.parent, body_tree.nv_j, body_tree.iv
    nb = parent.shape[0]
    S_s = coriolis_terms(work, nb).S_s
    Fc = axis_rates(work, nb).Fc_s
    for k in range(tau.shape[0]):
        tau[k] = 0.0
    for i in range(nb):
        for k in range(nv_j[i]):
            tau[iv[i] + k] += dot6(S_s[i, k], Fc[i])


@njit(**JIT)
def rnea_derivatives_kernel(ibuf, fbuf, work, state, loads, dtau_dq, dtau_dqd, M):
    """dtau_dq, dtau_dqd, M (nv, nv) <- the derivatives of RNEA at state = (q, qd, qdd), in
    `work` (a Data's buffer: its CoriolisTerms and AxisRates are left as this state's); loads
    as rnea_kernel's. Returns a Status: OK, Q/QD/QDD_NOT_FINITE, Q_NOT_UNIT_QUATERNION or
    RESULT_NOT_FINITE."""
    q, qd, qdd = state
    status = motion_status(ibuf, q, qd, qdd)
    if status:
        return status
    space_axes_and_inertias(ibuf, fbuf, work, q)
    velocity_terms(ibuf, fbuf, work, qd)
    accelerations_and_wrenches(ibuf, fbuf, work, qd, qdd, loads)
    assemble_derivatives(ibuf, fbuf, work, dtau_dq, dtau_dqd, M)
    status = result_status(dtau_dq)
    return status if status else result_status(dtau_dqd)


@njit(**BATCH)
def rnea_derivatives_batch_kernel(ibuf, fbuf, states, loads, out, status, start, stop):
    """RNEA derivatives over rows [start, stop) of a batch, states = (q, qd, qdd), into out
    (N, 3, nv, nv) (dtau_dq, dtau_dqd, M); loads (1, rows, 6) shared or (N, rows, 6). The
    rows work in a buffer of their own."""
    q, qd, qdd = states
    shared = loads.shape[0] == 1
    work = new_work(body_count(ibuf), dof_count(ibuf))
    for n in range(start, stop):
        status[n] = rnea_derivatives_kernel(
            ibuf,
            fbuf,
            work,
            (q[n], qd[n], qdd[n]),
            loads[0] if shared else loads[n],
            out[n, 0],
            out[n, 1],
            out[n, 2],
        )


rnea_derivatives_exact = exact(rnea_derivatives_kernel)
RNEA_DERIVATIVES = Call(
    rnea_derivatives_kernel,
    rnea_derivatives_exact,
    rnea_derivatives_batch_kernel,
    ("q", "qd", "qdd"),
    (True, True),
    True,
)


def derivatives_at(model, call, state, extra_loads, data, fields, extra, what):
    """The three (nv, nv) derivative matrices that `call` (a Call of kernels taking the state
    (q, x, y) as one tuple, then the loads, then `extra`, then the three results) computes at
    state = (q, x, y), for a single state or a batch (N, nv, nv) each; extra_loads = (f_tip,
    gravity); with data (single states) the Data's `fields`. The public derivative functions'
    one path (after their check_model): a single float64 state goes straight to the kernel's
    twin (opendyn._runtime.entry), anything else through checked_call."""
    work = checks.work_of(model, data, what)
    f_tip, gravity = extra_loads
    if data is None:
        held = np.empty((3, model.nv, model.nv))
        out = (held[0], held[1], held[2])
    else:
        out = (getattr(data, fields[0]), getattr(data, fields[1]), getattr(data, fields[2]))
    if gravity is None and f_tip is None:
        try:
            if not call.twin(model._ibuf, model._fbuf, work, state, model._loads, *extra, *out):
                return out
        except TypeError:  # arguments to convert: the checked path
            pass
    given = {"gravity": gravity, "f_tip": f_tip}
    return checked_call(call, model, data, state, out, what, fields[0], extra, given)


def inverse_dynamics_derivatives(model, q, qd, qdd, f_tip=None, gravity=None, data=None):
    """The partial derivatives of tau = inverse_dynamics(model, q, qd, qdd, f_tip, gravity),
    analytical (by differentiating RNEA, O(n d); the module docstring has the recursion).

    Args:
      q, qd, qdd: as inverse_dynamics: q (nq,), qd and qdd (nv,), or batches (N, nq), (N, nv).
      f_tip: {frame: (6,) wrench (m, f) the frame applies to the environment, in its
        coordinates}.
      gravity: (3,) world-frame (m/s^2), default model.gravity.
      data: optional Data of this model (single states): the call works in it and returns
        (data.dtau_dq, data.dtau_dqd, data.M), allocating nothing.
    Returns (dtau_dq, dtau_dqd, dtau_dqdd), each (nv, nv), or (N, nv, nv) for a batch:
      dtau_dq[:, k] = d tau / d q along coordinate k of the tangent space: for a joint, its
        angle or displacement; for a free joint (a floating base), the body twist coordinate
        k of q (+) e e_k = integrate(q, e e_k), the pose T exp(e e_k) (Pinocchio's
        convention), so every q-derivative is (nv, nv) (N m per rad or per m);
      dtau_dqd = d tau / d qd (N m s per rad);
      dtau_dqdd = M(q), full and symmetric (kg m^2, kg m, kg).
    """
    checks.check_model(model, "inverse_dynamics_derivatives")
    return derivatives_at(
        model,
        RNEA_DERIVATIVES,
        (q, qd, qdd),
        (f_tip, gravity),
        data,
        ("dtau_dq", "dtau_dqd", "M"),
        (),
        "inverse_dynamics_derivatives",
    )
