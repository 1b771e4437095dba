"""Kinetic and potential energy of the tree:

    K(q, qd) = 1/2 qd^T M(q) qd = sum_i 1/2 V_i^T G_i V_i          (V_i: body twist in {i})
    U(q)     = - sum_i m_i g . c_i(q)                               (c_i: centre of mass in {s})

so that dU/dq = g(q), the gravity torques (Lynch & Park, Section 8.1). The gradient of K in q
at fixed qd, the force term of the momentum form of the equations of motion
(d/dt (M qd) = dK/dq - g + tau), takes one forward and one backward pass:

    dV_i/dq_j = Ad_{T_ij} ad_{V_j} s_j     (i in the subtree of j; 0 elsewhere; s_j a row of S_j)
    dK/dq_j   = (ad_{V_j} s_j)^T P_j,      P_j = G_j V_j + sum_children Ad_{T_cj}^T P_c

with P_j the momentum of the subtree of j in {j}.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .._runtime.arrays import fill
from .._runtime.entry import exact
from .._runtime.kernel_cache import BATCH, JIT
from .._runtime.status import Status
from ..multibody.joints import joint_motion, place_joints, state_status
from ..multibody.layout import body_count, rigid_inertias, tree
from ..multibody.work_views import (
    body_motion,
    joint_poses,
    new_work,
    scratch_rows,
    temp_vectors,
    world_poses,
)
from ..spatial.compiled import (
    add_neg_ad_transpose,
    add_wrench_to_parent,
    dot6,
    rigid_inertia_times,
    twist_to_child,
)
from . import checks
from .calls import Call, checked_call
from .kinematics import world_pose
from .rnea import velocity_pass


@njit(**JIT)
def kinetic_gradient_kernel(ibuf, fbuf, work, q, qd, dK_dq):
    """dK_dq (nv,) <- dK/dq at fixed qd (N m or N), in `work` (a Data's buffer: R, p and V are
    left as this state's joint poses and body twists, F as the momenta P). Returns a Status:
    OK, Q/QD_NOT_FINITE or Q_NOT_UNIT_QUATERNION."""
    status = state_status(ibuf, q, qd)
    if status:
        return status
    body_tree = tree(ibuf, fbuf)
    parent, nv_j, iv = body_tree.parent, body_tree.nv_j, body_tree.iv
    mult, S = body_tree.mult, body_tree.S
    mass, h, I_o = rigid_inertias(ibuf, fbuf)
    nb = mass.shape[0]
    # T_{lambda,i} and V_i = Ad_{T_{i,lambda}} V_lambda + S_i qd_i (RNEA's velocity pass)
    R, p = joint_poses(work, nb)
    V, _, P = body_motion(work, nb)
    scratch = scratch_rows(work, nb, qd.shape[0])
    place_joints(body_tree, q, R, p)
    velocity_pass(body_tree, qd, R, p, V, scratch)
    s = scratch[0]
    # backward pass: P_j = G_j V_j + sum_children Ad_{T_cj}^T P_c
    for i in range(nb):
        rigid_inertia_times(mass[i], h[i], I_o[i], V[i], P[i])
    fill(dK_dq, 0.0)
    for j in range(nb - 1, -1, -1):
        # dK/dq_j = (ad_{V_j} s_j)^T P_j = -s_j . (-ad_{V_j}^T P_j) for each row s_j of S_j
        fill(s, 0.0)
        add_neg_ad_transpose(V[j], P[j], s)
        for k in range(nv_j[j]):
            dK_dq[iv[j] + k] -= mult[j] * dot6(S[j, k], s)
        if parent[j] >= 0:
            add_wrench_to_parent(R[j], p[j], P[j], P[parent[j]])
    return Status.OK.value


@njit(**JIT)
def energy_kernel(ibuf, fbuf, work, q, qd, gravity, out):
    """out (2,) <- (K(q, qd), U(q)) under the world-frame gravity (3,), in `work` (a Data's
    buffer: R, p, R_s, p_s and V are left as this state's), in one pass from the base to the
    tips:
        T_{s,i} = T_{s,lambda} T_{lambda,i},   V_i = Ad_{T_{i,lambda}} V_lambda + S_i qd_i,
        K = sum_i 1/2 V_i^T G_i V_i,           U = -sum_i g . (R_si h_i + m_i p_si).
    Returns a Status: OK, Q/QD_NOT_FINITE or Q_NOT_UNIT_QUATERNION."""
    status = state_status(ibuf, q, qd)
    if status:
        return status
    body_tree = tree(ibuf, fbuf)
    parent, nv_j, iv = body_tree.parent, body_tree.nv_j, body_tree.iv
    mult, S = body_tree.mult, body_tree.S
    mass, h, I_o = rigid_inertias(ibuf, fbuf)
    nb = parent.shape[0]
    R, p = joint_poses(work, nb)
    place_joints(body_tree, q, R, p)
    R_s, p_s = world_poses(work, nb)
    V, _, _ = body_motion(work, nb)
    temp = temp_vectors(work, nb, qd.shape[0])
    s, V_J = temp[0], temp[1]
    K = 0.0
    U = 0.0
    for i in range(nb):
        lam = parent[i]
        world_pose(R_s, p_s, lam, R[i], p[i], i)
        joint_motion(nv_j[i], S[i], mult[i], qd, iv[i], V_J)
        if lam < 0:
            fill(V[i], 0.0)
        else:
            twist_to_child(R[i], p[i], V[lam], V[i])
        for k in range(6):
            V[i, k] += V_J[k]
        rigid_inertia_times(mass[i], h[i], I_o[i], V[i], s)
        K += 0.5 * dot6(V[i], s)
        for r in range(3):
            mc = (
                R_s[i, r, 0] * h[i, 0]
                + R_s[i, r, 1] * h[i, 1]
                + R_s[i, r, 2] * h[i, 2]
                + mass[i] * p_s[i, r]
            )
            U -= gravity[r] * mc
    out[0] = K
    out[1] = U
    return Status.OK.value


@njit(**BATCH)
def energy_batch_kernel(ibuf, fbuf, q, qd, gravity, out, status, start, stop):
    """(K, U) over rows [start, stop) of a batch -> out (N, 2), in a work buffer of their own."""
    work = new_work(body_count(ibuf), qd.shape[1])
    for n in range(start, stop):
        status[n] = energy_kernel(ibuf, fbuf, work, q[n], qd[n], gravity, out[n])


energy_exact = exact(energy_kernel)
ENERGY = Call(energy_kernel, energy_exact, energy_batch_kernel, ("q", "qd"))


def energies(model, q, qd, gravity=None, what="energies", data=None):
    """(K, U): kinetic energy 1/2 qd^T M qd and potential energy -sum_i m_i g . c_i (J), each a
    float, or (N,) arrays for batches (N, nq), (N, nv), by one compiled kernel. gravity:
    optional (3,) world-frame vector (m/s^2); what: the function named in error messages;
    data: optional Data of this model (single states), which the kernel works in.
    An energy that overflows float64 is returned as it is (inf): a simulation records the
    energies of its states with this; kinetic_energy and potential_energy refuse it."""
    work = checks.work_of(model, data, what)
    out = np.empty(2) if data is None else data.energy
    if gravity is None:
        # float64 vectors of the model's sizes go to the kernel's exact twin
        try:
            if not energy_exact(model._ibuf, model._fbuf, work, q, qd, model._gravity, out):
                return float(out[0]), float(out[1])
        except TypeError:  # arguments to convert: the checked path
            pass
    g = checks.as_gravity(model, gravity)
    out = checked_call(ENERGY, model, data, (q, qd), out, what, None, (g,))
    if out.ndim == 2:
        return out[:, 0], out[:, 1]
    return float(out[0]), float(out[1])


def kinetic_energy(model, q, qd, data=None):
    """K = 1/2 qd^T M(q) qd (J): float, or (N,) for a batch of states (q (N, nq), qd (N, nv)).

    data: optional Data of this model (single states): the call works in it and allocates no
    array (data.energy holds (K, U), data.V the body twists)."""
    checks.check_model(model, "kinetic_energy")
    K = energies(model, q, qd, what="kinetic_energy", data=data)[0]
    return checks.check_result(K, "kinetic_energy", "K", {"q": q, "qd": qd})


def potential_energy(model, q, gravity=None, data=None):
    """U(q) = -sum_i m_i g . c_i(q) (J), zero at the world origin: float, or (N,) for (N, nq).

    gravity: optional (3,) world-frame vector (m/s^2), default model.gravity; dU/dq = g(q).
    data: optional Data of this model (single configurations): the call works in it and
    allocates no array (data.energy holds (0, U), data.R_s, data.p_s the body poses).
    """
    checks.check_model(model, "potential_energy")
    if data is not None:  # a single state (energies converts q, or refuses a batch)
        zero = data.zero_v
    else:
        q = checks.as_q(model, q)
        zero = np.zeros(q.shape[:-1] + (model.nv,))
    U = energies(model, q, zero, gravity, "potential_energy", data)[1]
    return checks.check_result(U, "potential_energy", "U", {"q": q, "gravity": gravity})
