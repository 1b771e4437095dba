"""Inverse dynamics by the recursive Newton-Euler algorithm (RNEA) on a kinematic tree:

    tau = M(q) qdd + c(q, qd) + g(q) + sum_frames J_b(frame)^T F_tip(frame)

Forward pass, base to tips, dV_0 = (0, -g) (gravity as a fictitious base acceleration), joint
i with motion subspace S_i (A_i for a 1-dof joint, I_6 for a free one; module joints):
    T_{i,lambda} = X_J(q_i)^-1 M_{i,lambda}
    V_i  = Ad_{T_{i,lambda}} V_lambda + S_i qd_i
    dV_i = Ad_{T_{i,lambda}} dV_lambda + ad_{V_i} S_i qd_i + S_i qdd_i
Backward pass, tips to base:
    F_i = G_i dV_i - ad_{V_i}^T G_i V_i + F_tip,i + sum_children Ad_{T_{c,i}}^T F_c
    tau_i = S_i^T F_i
(Lynch & Park, Modern Robotics, Section 8.3.2; the seed notes, "Newton-Euler inverse dynamics";
Featherstone, Rigid Body Dynamics Algorithms, Table 5.1, for multi-dof joints.)
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .._runtime.arrays import fill, result_status
from .._runtime.entry import exact
from .._runtime.kernel_cache import BATCH, INLINE, JIT
from ..multibody.joints import add_joint_force, motion_status, place_joints
from ..multibody.layout import body_count, dof_count, rigid_inertias, tree
from ..multibody.work_views import body_motion, joint_poses, new_work, scratch_rows
from ..spatial.compiled import (
    ad_twist,
    add_neg_ad_transpose,
    add_wrench_to_parent,
    rigid_inertia_times,
    twist_to_child,
)
from . import checks
from .calls import Call, checked_call


@njit(**INLINE)
def forward_pass(body_tree, q, qd, qdd, dV_0, R, p, V, dV, s):
    """Forward pass of RNEA: R[i], p[i] = T_{lambda,i}; V[i], dV[i] twist and its rate in {i}.

    body_tree is layout.tree(ibuf, fbuf); dV_0 is the base's acceleration, (0, -g) for
    gravity. s is scratch of at least two rows of 6. Also used for energies and frame
    accelerations.
    """
    place_joints(body_tree, q, R, p)
    motion_pass(body_tree, qd, qdd, dV_0, R, p, V, dV, s)


@njit(**INLINE)
def motion_pass(body_tree, qd, qdd, dV_0, R, p, V, dV, s):
    """forward_pass on the joint poses R[i], p[i] = T_{lambda,i} already placed
    (joints.place_joints): V[i], dV[i] twist and its rate in {i}."""
    velocity_pass(body_tree, qd, R, p, V, s)
    acceleration_pass(body_tree, qd, qdd, dV_0, R, p, V, dV, s)


@njit(**INLINE)
def velocity_pass(body_tree, qd, R, p, V, s):
    """V[i] <- the twist of body i in {i}, on the joint poses R[i], p[i] = T_{lambda,i}: the
    first half of motion_pass (the momentum kernel stops here). s: scratch of at least two
    rows of 6."""
    parent, nv_j, iv = body_tree.parent, body_tree.nv_j, body_tree.iv
    mult, S = body_tree.mult, body_tree.S
    V_0 = s[1]
    fill(V_0, 0.0)  # the world does not move
    for i in range(parent.shape[0]):
        lam = parent[i]
        # V_i = Ad_{T_{i,lambda}} V_lambda + S_i qd_i (a root's V_lambda is V_0; one call, not a
        # branch around two, so that numba drops the reference counting of the views here)
        twist_to_child(R[i], p[i], V_0 if lam < 0 else V[lam], V[i])
        for k in range(nv_j[i]):
            qd_k = mult[i] * qd[iv[i] + k]
            for r in range(6):
                V[i, r] += S[i, k, r] * qd_k


@njit(**INLINE)
def acceleration_pass(body_tree, qd, qdd, dV_0, R, p, V, dV, s):
    """dV[i] <- the rate of body i's twist in {i}, after velocity_pass (V[i]): the second half
    of motion_pass. s: scratch of at least one row of 6."""
    parent, nv_j, iv = body_tree.parent, body_tree.nv_j, body_tree.iv
    mult, S = body_tree.mult, body_tree.S
    a = s[0]
    for i in range(parent.shape[0]):
        lam = parent[i]
        # dV_i = Ad_{T_{i,lambda}} dV_lambda + sum_k (ad_{V_i} s_k) qd_k + s_k qdd_k over the
        # rows s_k of S_i
        twist_to_child(R[i], p[i], dV_0 if lam < 0 else dV[lam], dV[i])
        for k in range(nv_j[i]):
            qd_k, qdd_k = mult[i] * qd[iv[i] + k], mult[i] * qdd[iv[i] + k]
            ad_twist(V[i], S[i, k], a)
            for r in range(6):
                dV[i, r] += a[r] * qd_k + S[i, k, r] * qdd_k


@njit(**JIT)
def rnea_kernel(ibuf, fbuf, work, q, qd, qdd, loads, tau):
    """tau (nv,) <- RNEA at one state, working in `work` (a Data's buffer: its R, p, V, dV and
    F are left as this state's). loads[0] = dV_0 = (0, -g); loads[1 + i], when present,
    the wrench body i applies to the environment. Returns a Status: OK, Q/QD/QDD_NOT_FINITE,
    Q_NOT_UNIT_QUATERNION or RESULT_NOT_FINITE (tau overflowed)."""
    status = motion_status(ibuf, q, qd, qdd)
    if status:
        return status
    R, p = joint_poses(work, body_count(ibuf))
    place_joints(tree(ibuf, fbuf), q, R, p)
    return rnea_on_poses(ibuf, fbuf, work, qd, qdd, loads, tau)


@njit(**JIT)
def rnea_on_poses(ibuf, fbuf, work, qd, qdd, loads, tau):
    """rnea_kernel on the joint poses that `work` holds (joints.place_joints at the state's q,
    which was checked, as qd and qdd are not here). Returns OK or RESULT_NOT_FINITE."""
    body_tree = tree(ibuf, fbuf)
    parent, nv_j, iv = body_tree.parent, body_tree.nv_j, body_tree.iv
    mult, S = body_tree.mult, body_tree.S
    mass, h, I_o = rigid_inertias(ibuf, fbuf)
    nb, nv = body_count(ibuf), dof_count(ibuf)
    R, p = joint_poses(work, nb)
    V, dV, F = body_motion(work, nb)
    s = scratch_rows(work, nb, nv)
    motion_pass(body_tree, qd, qdd, loads[0], R, p, V, dV, s)

    # backward pass: F_i = G_i dV_i - ad_{V_i}^T G_i V_i + F_tip,i + sum_children Ad^T F_c,
    # tau_i = S_i^T F_i
    wrenches = loads.shape[0] > 1
    for i in range(nb):
        rigid_inertia_times(mass[i], h[i], I_o[i], dV[i], F[i])
        rigid_inertia_times(mass[i], h[i], I_o[i], V[i], s[0])
        add_neg_ad_transpose(V[i], s[0], F[i])
        if wrenches:
            for k in range(6):
                F[i, k] += loads[1 + i, k]
    fill(tau, 0.0)
    for i in range(nb - 1, -1, -1):
        add_joint_force(nv_j[i], S[i], mult[i], F[i], iv[i], tau)
        if parent[i] >= 0:
            add_wrench_to_parent(R[i], p[i], F[i], F[parent[i]])
    return result_status(tau)


@njit(**BATCH)
def rnea_batch_kernel(ibuf, fbuf, q, qd, qdd, loads, tau, status, start, stop):
    """RNEA over rows [start, stop) of a batch: q (N, nq), qd and qdd (N, nv); loads
    (1, rows, 6) shared or (N, rows, 6). The rows work in a buffer of their own."""
    shared = loads.shape[0] == 1
    work = new_work(body_count(ibuf), dof_count(ibuf))
    for n in range(start, stop):
        status[n] = rnea_kernel(
            ibuf, fbuf, work, q[n], qd[n], qdd[n], loads[0] if shared else loads[n], tau[n]
        )


rnea_exact = exact(rnea_kernel)
RNEA = Call(rnea_kernel, rnea_exact, rnea_batch_kernel, ("q", "qd", "qdd"), loads=True)
_NO_GRAVITY = np.zeros(3)


def run_rnea(model, q, qd, qdd, f_tip, gravity, what, result, data=None):
    """RNEA for single states (nv,) or batches (N, nv), by the exact twin or checked_call: the
    core of gravity_forces, coriolis_forces and bias_forces. what, result: the function and its
    result (e.g. "g") as error messages name them, and the Data field that holds it with
    data=."""
    work = checks.work_of(model, data, what)  # checks model and data
    tau = np.empty(model._vector_shape) if data is None else getattr(data, result)
    if gravity is None and f_tip is None:
        # float64 vectors of the model's sizes go to the kernel's exact twin
        try:
            if not rnea_exact(model._ibuf, model._fbuf, work, q, qd, qdd, model._loads, tau):
                return tau
        except TypeError:  # arguments to convert: the checked path
            pass
    given = {"gravity": gravity, "f_tip": f_tip}
    return checked_call(RNEA, model, data, (q, qd, qdd), tau, what, result, given=given)


def inverse_dynamics(model, q, qd, qdd, f_tip=None, gravity=None, data=None):
    """tau = M(q) qdd + c(q, qd) + g(q) + sum_frames J_b(frame)^T F_tip(frame), by RNEA.

    Args:
      q: (nq,) configuration: joint positions (rad or m), after the base pose (p, quat) for a
        floating base; qd, qdd: (nv,) velocities and accelerations (the base twist (omega_b,
        v_b) in its own frame first, then the joints'); or batches (N, nq), (N, nv).
      f_tip: optional {frame_name: (6,) wrench (m, f)} that each frame applies TO THE
        ENVIRONMENT, in that frame's coordinates (N m, N); (N, 6) per frame for a batch.
      gravity: optional (3,) world-frame gravity (m/s^2), default model.gravity.
      data: optional Data of this model (single states): the call works in it and returns
        data.tau, allocating nothing (f_tip and a gravity override are converted first);
        data.V, data.dV and data.F hold the body twists, accelerations and wrenches.
    Returns tau, (nv,) or (N, nv): joint torques (N m) or forces (N), after the wrench
    (m_b, f_b) on a floating base in its own frame.
    """
    work = checks.work_of(model, data, "inverse_dynamics")  # checks model and data
    tau = np.empty(model._vector_shape) if data is None else data.tau
    if gravity is None and f_tip is None:
        # the common call: float64 vectors of the model's sizes go to the kernel's exact twin
        try:
            if not rnea_exact(model._ibuf, model._fbuf, work, q, qd, qdd, model._loads, tau):
                return tau
        except TypeError:  # arguments to convert: the checked path
            pass
    given = {"gravity": gravity, "f_tip": f_tip}
    what = "inverse_dynamics"
    return checked_call(RNEA, model, data, (q, qd, qdd), tau, what, "tau", given=given)


def _zeros_like_state(model, q):
    """q, and a zero velocity: the model's (nv,) for a vector q (run_rnea checks it), else q
    checked and (nv,) or (N, nv) zeros for a batch."""
    if type(q) is np.ndarray and q.ndim == 1:
        return q, model._zero_v
    q = checks.as_q(model, q)
    return q, np.zeros(q.shape[:-1] + model._vector_shape)


def gravity_forces(model, q, gravity=None, data=None):
    """g(q) = dU/dq: the joint torques that hold the robot still against gravity (RNEA with
    qd = qdd = 0).

    q: (nq,) or (N, nq); gravity: optional (3,) world-frame vector (m/s^2).
    data: optional Data of this model (single states): returns data.g, allocating nothing.
    Returns (nv,) or (N, nv).
    """
    checks.check_model(model, "gravity_forces")
    q, zero = _zeros_like_state(model, q)
    return run_rnea(model, q, zero, zero, None, gravity, "gravity_forces", "g", data)


def coriolis_forces(model, q, qd, data=None):
    """c(q, qd) = C(q, qd) qd: Coriolis and centripetal torques (RNEA, qdd = 0, no gravity).

    q, qd: (nq,) and (nv,), or (N, nq) and (N, nv).
    data: optional Data of this model (single states): returns data.c, allocating nothing.
    Returns (nv,) or (N, nv).
    """
    checks.check_model(model, "coriolis_forces")
    q, zero = _zeros_like_state(model, q)
    return run_rnea(model, q, qd, zero, None, _NO_GRAVITY, "coriolis_forces", "c", data)


def bias_forces(model, q, qd, gravity=None, data=None):
    """h(q, qd) = c(q, qd) + g(q): the torques when qdd = 0 (RNEA).

    q, qd: (nq,) and (nv,), or batches; gravity: optional (3,) world-frame vector.
    data: optional Data of this model (single states): returns data.h, allocating nothing.
    Returns (nv,) or (N, nv).
    """
    checks.check_model(model, "bias_forces")
    q, zero = _zeros_like_state(model, q)
    return run_rnea(model, q, qd, zero, None, gravity, "bias_forces", "h", data)
