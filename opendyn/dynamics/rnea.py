"""Inverse dynamics by the recursive Newton-Euler algorithm (RNEA) on a kinematic tree:

    tau = M(q) qdd + c(q, qd) + g(q) + sum_frames J_b(frame)^T F_tip(frame)

Forward pass, base to tips, dV_0 = (0, -g) (gravity as a fictitious base acceleration):
    T_{i,lambda} = exp(-[A_i] q_i) M_{i,lambda}
    V_i  = Ad_{T_{i,lambda}} V_lambda + A_i qd_i
    dV_i = Ad_{T_{i,lambda}} dV_lambda + ad_{V_i} A_i qd_i + A_i qdd_i
Backward pass, tips to base:
    F_i = G_i dV_i - ad_{V_i}^T G_i V_i + F_tip,i + sum_children Ad_{T_{c,i}}^T F_c
    tau_i = F_i^T A_i
(Lynch & Park, Modern Robotics, Section 8.3.2; the seed notes, "Newton-Euler inverse dynamics".)
"""

from __future__ import annotations

import numpy as np
from numba import njit

from . import _args
from ._kernels import (
    BATCH,
    INLINE,
    JIT,
    ad_twist,
    add_neg_ad_transpose,
    add_wrench_to_parent,
    all_finite,
    dot6,
    fill,
    joint_transform,
    rigid_inertia_times,
    rigid_inertias,
    run_rows,
    tree,
    twist_to_child,
)
from ..status import Status


@njit(**INLINE)
def forward_pass(body_tree, q, qd, qdd, dV_0, R, p, V, dV, s):
    """Forward pass of RNEA: R[i], p[i] = T_{lambda,i}; V[i], dV[i] twist and its rate in {i}.

    body_tree is _kernels.tree(ibuf, fbuf); dV_0 is the base's acceleration, (0, -g) for
    gravity. s is (6,) scratch. Also used for energies and frame accelerations.
    """
    parent, jtype, coord, mult, offset, A, R_home, p_home = body_tree
    for i in range(parent.shape[0]):
        j = coord[i]
        joint_transform(
            jtype[i], A[i], R_home[i], p_home[i], mult[i] * q[j] + offset[i], R[i], p[i]
        )
        lam = parent[i]
        # V_i = Ad_{T_{i,lambda}} V_lambda + A_i qd_i  (the world does not move: V_0 = 0)
        if lam < 0:
            fill(V[i], 0.0)
        else:
            twist_to_child(R[i], p[i], V[lam], V[i])
        qd_i, qdd_i = mult[i] * qd[j], mult[i] * qdd[j]
        for k in range(6):
            V[i, k] += A[i, k] * qd_i
        # dV_i = Ad_{T_{i,lambda}} dV_lambda + ad_{V_i} A_i qd_i + A_i qdd_i
        twist_to_child(R[i], p[i], dV_0 if lam < 0 else dV[lam], dV[i])
        ad_twist(V[i], A[i], s)
        for k in range(6):
            dV[i, k] += s[k] * qd_i + A[i, k] * qdd_i


@njit(**JIT)
def rnea_kernel(ibuf, fbuf, q, qd, qdd, loads, tau):
    """tau (nv,) <- RNEA at one state. loads[0] = dV_0 = (0, -g); loads[1 + i], when present,
    the wrench body i applies to the environment. Returns a Status: OK, or Q/QD/QDD_NOT_FINITE."""
    if not all_finite(q):
        return Status.Q_NOT_FINITE.value
    if not all_finite(qd):
        return Status.QD_NOT_FINITE.value
    if not all_finite(qdd):
        return Status.QDD_NOT_FINITE.value
    body_tree = tree(ibuf, fbuf)
    parent, jtype, coord, mult, offset, A, R_home, p_home = body_tree
    mass, h, I_o = rigid_inertias(ibuf, fbuf)
    nb = parent.shape[0]
    vec = np.empty((3, nb, 6))
    V, dV, F = vec[0], vec[1], vec[2]
    R = np.empty((nb, 3, 3))
    p = np.empty((nb, 3))
    s = np.empty(6)
    forward_pass(body_tree, q, qd, qdd, loads[0], R, p, V, dV, s)

    # backward pass: F_i = G_i dV_i - ad_{V_i}^T G_i V_i + F_tip,i + sum_children Ad^T F_c,
    # tau_i = F_i^T A_i
    wrenches = loads.shape[0] > 1
    for i in range(nb):
        rigid_inertia_times(mass[i], h[i], I_o[i], dV[i], F[i])
        rigid_inertia_times(mass[i], h[i], I_o[i], V[i], s)
        add_neg_ad_transpose(V[i], s, F[i])
        if wrenches:
            for k in range(6):
                F[i, k] += loads[1 + i, k]
    fill(tau, 0.0)
    for i in range(nb - 1, -1, -1):
        tau[coord[i]] += mult[i] * dot6(F[i], A[i])
        if parent[i] >= 0:
            add_wrench_to_parent(R[i], p[i], F[i], F[parent[i]])
    return Status.OK.value


@njit(**BATCH)
def rnea_batch_kernel(ibuf, fbuf, q, qd, qdd, loads, tau, status, start, stop):
    """RNEA over rows [start, stop) of a batch (N, nv); loads (1, rows, 6) shared or (N, ...);
    """
    shared = loads.shape[0] == 1
    for n in range(start, stop):
        status[n] = rnea_kernel(
            ibuf, fbuf, q[n], qd[n], qdd[n], loads[0] if shared else loads[n], tau[n]
        )


_NO_GRAVITY = np.zeros(3)


def run_rnea(model, q, qd, qdd, f_tip, gravity, what):
    """Checked RNEA for single states (nv,) or batches (N, nv); the public functions' core."""
    (q, qd, qdd), batch = _args.as_states(model, ("q", q), ("qd", qd), ("qdd", qdd))
    if not batch:
        tau = np.empty(model._vector_shape)
        status = rnea_kernel(
            model._ibuf,
            model._fbuf,
            q,
            qd,
            qdd,
            _args.loads(model, gravity, f_tip),
            tau,
        )
        if status:
            _args.raise_status(status, model, what)
        return tau
    n = q.shape[0]
    tau = np.empty((n, model.nv))
    status = np.zeros(n, dtype=np.int64)
    run_rows(
        rnea_batch_kernel,
        n,
        model._ibuf,
        model._fbuf,
        q,
        qd,
        qdd,
        _args.loads(model, gravity, f_tip, n),
        tau,
        status,
    )
    _args.raise_batch_status(status, model, what)
    return tau


def inverse_dynamics(model, q, qd, qdd, f_tip=None, gravity=None):
    """tau = M(q) qdd + c(q, qd) + g(q) + sum_frames J_b(frame)^T F_tip(frame), by RNEA.

    Args:
      q, qd, qdd: (nv,) joint positions (rad or m), velocities, accelerations; or batches (N, nv).
      f_tip: optional {frame_name: (6,) wrench (m, f)} that each frame applies TO THE
        ENVIRONMENT, in that frame's coordinates (N m, N); (N, 6) per frame for a batch.
      gravity: optional (3,) world-frame gravity (m/s^2), default model.gravity.
    Returns tau, (nv,) or (N, nv): joint torques (N m) or forces (N).
    """
    if gravity is None and f_tip is None and _args.is_single(model, q, qd, qdd):
        # the common call, with nothing to convert: straight to the kernel
        tau = np.empty(model._vector_shape)
        status = rnea_kernel(
            model._ibuf, model._fbuf, q, qd, qdd, model._loads, tau
        )
        if status:
            _args.raise_status(status, model, "inverse_dynamics")
        return tau
    return run_rnea(model, q, qd, qdd, f_tip, gravity, "inverse_dynamics")


def _zeros_like_state(model, q):
    if _args.is_single(model, q):
        return q, model._zero_v
    q = _args.as_state(model, q, "q")
    return q, np.zeros_like(q)


def gravity_forces(model, q, gravity=None):
    """g(q) = dU/dq: the joint torques that hold the robot still against gravity (RNEA with
    qd = qdd = 0).

    q: (nv,) or (N, nv); gravity: optional (3,) world-frame vector (m/s^2).
    Returns (nv,) or (N, nv).
    """
    q, zero = _zeros_like_state(model, q)
    return run_rnea(model, q, zero, zero, None, gravity, "gravity_forces")


def coriolis_forces(model, q, qd):
    """c(q, qd) = C(q, qd) qd: Coriolis and centripetal torques (RNEA, qdd = 0, no gravity).

    q, qd: (nv,) or (N, nv). Returns (nv,) or (N, nv).
    """
    q, zero = _zeros_like_state(model, q)
    return run_rnea(model, q, qd, zero, None, _NO_GRAVITY, "coriolis_forces")


def bias_forces(model, q, qd, gravity=None):
    """h(q, qd) = c(q, qd) + g(q): the torques when qdd = 0 (RNEA).

    q, qd: (nv,) or (N, nv); gravity: optional (3,) world-frame vector. Returns (nv,) or (N, nv).
    """
    q, zero = _zeros_like_state(model, q)
    return run_rnea(model, q, qd, zero, None, gravity, "bias_forces")
