"""Centre of mass and centroidal dynamics: the robot's momentum about its centre of mass.

Frame {G}: origin at the centre of mass c, axes those of the world {s}. With every body's pose
T_{s,i} = (R_i, p_i), mass m_i and first moment h_i = m_i c_i in {i}, M = sum_i m_i:

    c   = (1/M) sum_i (R_i h_i + m_i p_i)                                   (m, world frame)
    h_G = (k_G, l_G) = sum_i Ad_{T_{i,G}}^T G_i V_i = A_G(q) qd             (angular first)
    A_G[:, k] = mult_k Ic_{G,j} S_{G,k},  Ic_{G,j} = sum_{i in subtree(j)} Ad_{i,G}^T G_i Ad_{i,G}
    J_c[:, k] = mult_k (m_{c,j} v_k + w_k x h_{c,j}) / M = l_G-rows of A_G / M,   c_dot = J_c qd
    dh_G/dt = sum_i Ad_{T_{i,G}}^T (G_i dV_i - ad_{V_i}^T G_i V_i) = A_G qdd + Adot_G qd

S_{G,k} is row k of joint j's motion subspace S_j as a twist of {G} (Ad_{T_{G,j}} s_k), Ic_{G,j}
the composite inertia of the subtree of j about c in world axes (Ad_{i,G} = Ad_{T_{i,G}}),
(w_k, v_k) = Ad_{T_{s,j}} s_k the axis in {s}, m_{c,j} and h_{c,j} the subtree's mass and first
moment sum_i m_i c_i in {s}, V_i and dV_i the body twists and
accelerations of the RNEA forward pass (opendyn.algorithm.rnea) without gravity. {G} moves with
c but keeps its axes, and c_dot x l_G = c_dot x M c_dot = 0, so the rate of the momentum about
the moving point c is the rate about a fixed point momentarily at c: the sum of the bodies'
net wrenches moved to {G}, which the Newton-Euler equations of the whole robot make equal to the
sum of the external wrenches about c (gravity's (0, M g) and contacts). Adot_G qd is that sum
at qdd = 0. (Orin, Goswami and Lee, "Centroidal dynamics of a humanoid robot", Autonomous
Robots 35, 2013; Orin and Goswami, "Centroidal momentum matrix of a humanoid robot", IROS 2008.)
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .._runtime.arrays import fill, result_status, zero_matrix
from .._runtime.entry import exact
from .._runtime.kernel_cache import BATCH, INLINE, JIT
from ..multibody.joints import configuration_status, place_joints, state_status
from ..multibody.layout import body_count, dof_count, rigid_inertias, tree
from ..multibody.work_views import (
    body_motion,
    com_field,
    composite_inertias,
    joint_poses,
    joint_vectors,
    new_work,
    no_loads,
    scratch_rows,
    temp_vectors,
    world_poses,
)
from ..spatial.compiled import (
    add_neg_ad_transpose,
    add_rigid_inertia_to_parent,
    add_wrench_to_parent,
    rigid_inertia_times,
)
from . import checks
from .calls import Call, checked_call
from .kinematics import forward_kinematics, place_bodies, space_axis
from .rnea import acceleration_pass, velocity_pass


@njit(**INLINE)
def world_first_moment(R_s, p_s, mass, h):
    """A body's first moment in {s}, R_s h + m p_s (kg m, a 3-tuple), for its pose (R_s, p_s)
    in {s}, mass m and first moment h in its own frame."""
    return (
        R_s[0, 0] * h[0] + R_s[0, 1] * h[1] + R_s[0, 2] * h[2] + mass * p_s[0],
        R_s[1, 0] * h[0] + R_s[1, 1] * h[1] + R_s[1, 2] * h[2] + mass * p_s[1],
        R_s[2, 0] * h[0] + R_s[2, 1] * h[1] + R_s[2, 2] * h[2] + mass * p_s[2],
    )


@njit(**INLINE)
def centre_of_mass_of(R_s, p_s, mass, h, c):
    """c (3,) <- (1/M) sum_i (R_s[i] h_i + m_i p_s[i]), the centre of mass in {s} of bodies at
    world poses (R_s, p_s); returns M = sum_i m_i (kg). The caller makes sure M > 0."""
    fill(c, 0.0)
    total = 0.0
    for i in range(mass.shape[0]):
        total += mass[i]
        m_s = world_first_moment(R_s[i], p_s[i], mass[i], h[i])
        for r in range(3):
            c[r] += m_s[r]
    for r in range(3):
        c[r] /= total
    return total


@njit(**INLINE)
def relative_to(p_s, c, p_G):
    """p_G (3,) <- p_s - c: a body's origin in {G}."""
    for r in range(3):
        p_G[r] = p_s[r] - c[r]


@njit(**JIT)
def center_of_mass_kernel(ibuf, fbuf, work, q, c):
    """c (3,) <- the centre of mass at q (m, world frame), in `work` (its R_s, p_s are left as
    the body poses). Returns a Status: OK, Q_NOT_FINITE, Q_NOT_UNIT_QUATERNION or
    RESULT_NOT_FINITE."""
    status = configuration_status(ibuf, q)
    if status:
        return status
    nb = body_count(ibuf)
    forward_kinematics(ibuf, fbuf, work, q)
    R_s, p_s = world_poses(work, nb)
    mass, h, _ = rigid_inertias(ibuf, fbuf)
    centre_of_mass_of(R_s, p_s, mass, h, c)
    return result_status(c)


@njit(**JIT)
def center_of_mass_jacobian_kernel(ibuf, fbuf, work, q, J_c):
    """J_c (3, nv) <- the centre of mass Jacobian at q, in `work` (R_s, p_s are left as the
    body poses, mass_c and h_c as the subtrees' masses and first moments in {s}). Returns a
    Status: OK, Q_NOT_FINITE, Q_NOT_UNIT_QUATERNION or RESULT_NOT_FINITE.

    The subtree of joint j moving alone at unit speed about its axis S_{s,k} = (w, v) in {s}
    has linear momentum sum_i m_i (v + w x c_i) = m_c v + w x h_c (m_c its mass, h_c its
    first moment sum_i m_i c_i in {s}), the column's share of M c_dot: no rotational
    inertia and no centre of mass are formed."""
    status = configuration_status(ibuf, q)
    if status:
        return status
    body_tree = tree(ibuf, fbuf)
    parent, nv_j, iv = body_tree.parent, body_tree.nv_j, body_tree.iv
    mult, S = body_tree.mult, body_tree.S
    nb, nv = body_count(ibuf), dof_count(ibuf)
    forward_kinematics(ibuf, fbuf, work, q)
    R_s, p_s = world_poses(work, nb)
    mass, h, _ = rigid_inertias(ibuf, fbuf)
    mass_c, h_c, _ = composite_inertias(work, nb)
    S_s = temp_vectors(work, nb, nv)[0]
    # m_c,i = sum of m_j, h_c,i = sum of R_j h_j + m_j p_j over the subtree of i, tips first
    total = 0.0
    for i in range(nb):
        total += mass[i]
        mass_c[i] = mass[i]
        m_s = world_first_moment(R_s[i], p_s[i], mass[i], h[i])
        for r in range(3):
            h_c[i, r] = m_s[r]
    for i in range(nb - 1, -1, -1):
        lam = parent[i]
        if lam >= 0:
            mass_c[lam] += mass_c[i]
            for r in range(3):
                h_c[lam, r] += h_c[i, r]
    # J_c[:, iv_i + k] += mult_i (m_c,i v + w x h_c,i) / M,  (w, v) = Ad_{T_{s,i}} s_k
    zero_matrix(J_c)
    for i in range(nb):
        f = mult[i] / total
        for k in range(nv_j[i]):
            space_axis(R_s[i], p_s[i], S[i, k], S_s)
            col = iv[i] + k
            J_c[0, col] += f * (mass_c[i] * S_s[3] + S_s[1] * h_c[i, 2] - S_s[2] * h_c[i, 1])
            J_c[1, col] += f * (mass_c[i] * S_s[4] + S_s[2] * h_c[i, 0] - S_s[0] * h_c[i, 2])
            J_c[2, col] += f * (mass_c[i] * S_s[5] + S_s[0] * h_c[i, 1] - S_s[1] * h_c[i, 0])
    return result_status(J_c)


@njit(**JIT)
def momentum_matrix_kernel(ibuf, fbuf, work, q, A_G):
    """A_G (6, nv) <- the centroidal momentum matrix at q, in `work` (R_s, p_s are left as the
    body poses; mass_c, h_c and I_c as the subtrees' composite inertias about c in world
    axes). Returns a Status: OK, Q_NOT_FINITE, Q_NOT_UNIT_QUATERNION or RESULT_NOT_FINITE."""
    status = configuration_status(ibuf, q)
    if status:
        return status
    body_tree = tree(ibuf, fbuf)
    parent, nv_j, iv = body_tree.parent, body_tree.nv_j, body_tree.iv
    mult, S = body_tree.mult, body_tree.S
    nb, nv = body_count(ibuf), dof_count(ibuf)
    forward_kinematics(ibuf, fbuf, work, q)
    R_s, p_s = world_poses(work, nb)
    mass, h, I_o = rigid_inertias(ibuf, fbuf)
    mass_c, h_c, I_c = composite_inertias(work, nb)
    temp = temp_vectors(work, nb, nv)
    S_G, F, c = temp[0], temp[1], temp[2, :3]
    p_G = temp[2, 3:]
    centre_of_mass_of(R_s, p_s, mass, h, c)
    # Ic_{G,i} <- G_i in {G}, then the subtree sums (all in one frame: plain sums), tips first
    fill(mass_c, 0.0)
    fill(h_c, 0.0)
    fill(I_c, 0.0)
    for i in range(nb):
        relative_to(p_s[i], c, p_G)
        add_rigid_inertia_to_parent(
            R_s[i], p_G, mass[i], h[i], I_o[i], mass_c[i : i + 1], h_c[i], I_c[i]
        )
    for i in range(nb - 1, -1, -1):
        lam = parent[i]
        if lam >= 0:
            mass_c[lam] += mass_c[i]
            for r in range(3):
                h_c[lam, r] += h_c[i, r]
                for k in range(3):
                    I_c[lam, r, k] += I_c[i, r, k]
    # A_G[:, iv_i + k] += mult_i Ic_{G,i} S_{G,k},  S_{G,k} = Ad_{T_{G,i}} s_k
    zero_matrix(A_G)
    for i in range(nb):
        relative_to(p_s[i], c, p_G)
        for k in range(nv_j[i]):
            space_axis(R_s[i], p_G, S[i, k], S_G)
            rigid_inertia_times(mass_c[i], h_c[i], I_c[i], S_G, F)
            for r in range(6):
                A_G[r, iv[i] + k] += mult[i] * F[r]
    return result_status(A_G)


@njit(**JIT)
def centroidal_momentum_kernel(ibuf, fbuf, work, q, qd, rate, out):
    """out (2, 6) <- (h_G, Adot_G qd) at (q, qd), or, unless rate, (h_G, 0), in `work` (R, p,
    R_s, p_s, V and, with rate, dV at qdd = 0 are left as this state's, and com as the centre
    of mass c; without rate the accelerations are not formed). Returns a Status: OK,
    Q/QD_NOT_FINITE, Q_NOT_UNIT_QUATERNION or RESULT_NOT_FINITE."""
    status = state_status(ibuf, q, qd)
    if status:
        return status
    body_tree = tree(ibuf, fbuf)
    nb, nv = body_count(ibuf), dof_count(ibuf)
    R, p = joint_poses(work, nb)
    R_s, p_s = world_poses(work, nb)
    V, dV, _ = body_motion(work, nb)
    mass, h, I_o = rigid_inertias(ibuf, fbuf)
    s = scratch_rows(work, nb, nv)
    temp = temp_vectors(work, nb, nv)
    P, F, p_G = temp[0], temp[1], temp[2, :3]
    c = com_field(work, nb, nv)
    place_joints(body_tree, q, R, p)
    place_bodies(body_tree, work)
    velocity_pass(body_tree, qd, R, p, V, s)
    if rate:  # dV_i at qdd = 0, without gravity (dV_0 = 0)
        zero_v = joint_vectors(work, nb, nv)[1]
        acceleration_pass(body_tree, qd, zero_v, no_loads(work, nb, nv)[0], R, p, V, dV, s)
    centre_of_mass_of(R_s, p_s, mass, h, c)
    # h_G = sum_i Ad_{T_{i,G}}^T P_i,  P_i = G_i V_i;
    # dh_G/dt = sum_i Ad_{T_{i,G}}^T F_i,  F_i = G_i dV_i - ad_{V_i}^T P_i
    fill(out, 0.0)
    for i in range(nb):
        rigid_inertia_times(mass[i], h[i], I_o[i], V[i], P)
        relative_to(p_s[i], c, p_G)
        add_wrench_to_parent(R_s[i], p_G, P, out[0])
        if rate:
            rigid_inertia_times(mass[i], h[i], I_o[i], dV[i], F)
            add_neg_ad_transpose(V[i], P, F)
            add_wrench_to_parent(R_s[i], p_G, F, out[1])
    return result_status(out)


@njit(**BATCH)
def center_of_mass_batch_kernel(ibuf, fbuf, q, c, status, start, stop):
    """Centres of mass over rows [start, stop) of a batch (N, nq) -> (N, 3)."""
    work = new_work(body_count(ibuf), dof_count(ibuf))
    for n in range(start, stop):
        status[n] = center_of_mass_kernel(ibuf, fbuf, work, q[n], c[n])


@njit(**BATCH)
def center_of_mass_jacobian_batch_kernel(ibuf, fbuf, q, J_c, status, start, stop):
    """Centre of mass Jacobians over rows [start, stop) of a batch (N, nq) -> (N, 3, nv)."""
    work = new_work(body_count(ibuf), dof_count(ibuf))
    for n in range(start, stop):
        status[n] = center_of_mass_jacobian_kernel(ibuf, fbuf, work, q[n], J_c[n])


@njit(**BATCH)
def momentum_matrix_batch_kernel(ibuf, fbuf, q, A_G, status, start, stop):
    """Centroidal momentum matrices over rows [start, stop) of a batch (N, nq) -> (N, 6, nv)."""
    work = new_work(body_count(ibuf), dof_count(ibuf))
    for n in range(start, stop):
        status[n] = momentum_matrix_kernel(ibuf, fbuf, work, q[n], A_G[n])


@njit(**BATCH)
def centroidal_momentum_batch_kernel(ibuf, fbuf, q, qd, rate, out, status, start, stop):
    """(h_G, dh_G/dt or 0) over rows [start, stop) of a batch -> (N, 2, 6)."""
    work = new_work(body_count(ibuf), dof_count(ibuf))
    for n in range(start, stop):
        status[n] = centroidal_momentum_kernel(ibuf, fbuf, work, q[n], qd[n], rate, out[n])


@njit(**BATCH)
def centroidal_record_batch_kernel(ibuf, fbuf, q, qd, out, status, start, stop):
    """A floating run's centroidal record over rows [start, stop) of its samples: out (N, 9)
    <- (c, h_G) at (q[n], qd[n]), the centre of mass (m, world frame) and the centroidal
    momentum (k_G, l_G), by the momentum kernel alone (which leaves c in its work buffer):
    one kernel to compile for both."""
    nb, nv = body_count(ibuf), dof_count(ibuf)
    work = new_work(nb, nv)
    momentum = np.empty((2, 6))
    for n in range(start, stop):
        status[n] = centroidal_momentum_kernel(ibuf, fbuf, work, q[n], qd[n], False, momentum)
        c = com_field(work, nb, nv)
        for r in range(3):
            out[n, r] = c[r]
        for r in range(6):
            out[n, 3 + r] = momentum[0, r]


def _evaluate(call, model, data, states, out, what, result, options=()):
    """checked_call of `call` at states = (q, ...) into out, after the check that the model
    has a centre of mass: ValueError when nothing that moves has mass. The checked path, after
    the public function's exact call (or instead of it)."""
    if not model._total_mass > 0.0:
        raise ValueError(
            f"{what}: model {model.name!r} has no moving mass (its bodies' masses sum to "
            f"{model._total_mass:g} kg), so it has no centre of mass"
        )
    return checked_call(call, model, data, states, out, what, result, options)


center_of_mass_exact = exact(center_of_mass_kernel)
jacobian_exact = exact(center_of_mass_jacobian_kernel)
momentum_matrix_exact = exact(momentum_matrix_kernel)
momentum_exact = exact(centroidal_momentum_kernel)
CENTER_OF_MASS = Call(
    center_of_mass_kernel, center_of_mass_exact, center_of_mass_batch_kernel, ("q",)
)
COM_JACOBIAN = Call(
    center_of_mass_jacobian_kernel, jacobian_exact, center_of_mass_jacobian_batch_kernel, ("q",)
)
MOMENTUM_MATRIX = Call(
    momentum_matrix_kernel, momentum_matrix_exact, momentum_matrix_batch_kernel, ("q",)
)
MOMENTUM = Call(
    centroidal_momentum_kernel, momentum_exact, centroidal_momentum_batch_kernel, ("q", "qd")
)


def center_of_mass(model, q, data=None):
    """c(q) = (1/M) sum_i m_i c_i(q): the centre of mass of the moving bodies (m, world frame).

    q: (nq,) configuration, or a batch (N, nq) -> (3,) or (N, 3). M = sum_i m_i is the mass of
    the moving bodies: links welded to a fixed root are part of the world, as in every dynamics
    function. ValueError when M is zero.
    data: optional Data of this model (single states): returns data.com, allocating nothing.
    """
    work = checks.work_of(model, data, "center_of_mass")  # checks model and data
    c = np.empty(3) if data is None else data.com
    if model._total_mass > 0.0:
        try:
            if not center_of_mass_exact(model._ibuf, model._fbuf, work, q, c):
                return c
        except TypeError:  # arguments to convert: the checked path
            pass
    return _evaluate(CENTER_OF_MASS, model, data, (q,), c, "center_of_mass", "c")


def center_of_mass_jacobian(model, q, data=None):
    """J_c(q) (3, nv), so that c_dot = J_c qd: the centre of mass's velocity (m/s, world frame)
    per velocity coordinate (for a floating base, per component of the base twist (omega_b,
    v_b) in the base frame, then per joint).

    J_c = the l_G rows of A_G over M (centroidal_momentum_matrix), the linear momentum being
    M c_dot: column k is m_c v + w x h_c over M, for the subtree moved by velocity coordinate
    k (its mass m_c and first moment h_c in {s}) and that coordinate's axis (w, v) in {s}.
    q: (nq,) or (N, nq) -> (3, nv) or (N, 3, nv).
    data: optional Data of this model (single states): returns data.J_c, allocating nothing.
    """
    work = checks.work_of(model, data, "center_of_mass_jacobian")  # checks model and data
    J_c = np.empty((3, model.nv)) if data is None else data.J_c
    if model._total_mass > 0.0:
        try:
            if not jacobian_exact(model._ibuf, model._fbuf, work, q, J_c):
                return J_c
        except TypeError:  # arguments to convert: the checked path
            pass
    return _evaluate(COM_JACOBIAN, model, data, (q,), J_c, "center_of_mass_jacobian", "J_c")


def centroidal_momentum_matrix(model, q, data=None):
    """A_G(q) (6, nv), so that h_G = A_G qd: the centroidal momentum matrix (Orin and Goswami
    2008, 2013; Pinocchio's ccrba, whose rows are linear first).

    h_G = (k_G, l_G), angular first: the angular momentum about the centre of mass (kg m^2/s)
    and the linear momentum (kg m/s), both in world-aligned axes. Column k is the momentum of
    everything that moves with velocity coordinate k at unit speed:
        A_G[:, k] = Ic_{G,j} S_{G,k},
    Ic_{G,j} the composite inertia of the subtree of k's joint j about the centre of mass in
    world axes, S_{G,k} its motion axis as a twist there. For a floating base the first six
    columns are the base twist's (omega_b, v_b) in the base frame, and A_G[:, :6] is the whole
    robot's spatial inertia moved from the base frame to {G}.
    q: (nq,) or (N, nq) -> (6, nv) or (N, 6, nv).
    data: optional Data of this model (single states): returns data.A_G, allocating nothing.
    """
    work = checks.work_of(model, data, "centroidal_momentum_matrix")  # checks model and data
    A_G = np.empty((6, model.nv)) if data is None else data.A_G
    if model._total_mass > 0.0:
        try:
            if not momentum_matrix_exact(model._ibuf, model._fbuf, work, q, A_G):
                return A_G
        except TypeError:  # arguments to convert: the checked path
            pass
    what = "centroidal_momentum_matrix"
    return _evaluate(MOMENTUM_MATRIX, model, data, (q,), A_G, what, "A_G")


def centroidal_momentum(model, q, qd, data=None):
    """h_G = A_G(q) qd = (k_G, l_G) (6,): the angular momentum about the centre of mass
    (kg m^2/s) and the linear momentum (kg m/s), world-aligned axes, angular first; summed
    over the bodies, h_G = sum_i Ad_{T_{i,G}}^T G_i V_i.

    q, qd: (nq,), (nv,), or batches (N, nq), (N, nv) -> (6,) or (N, 6).
    data: optional Data of this model (single states): returns data.h_G, allocating nothing.
    """
    return _momentum(model, q, qd, False, data)


def centroidal_momentum_rate_bias(model, q, qd, data=None):
    """Adot_G(q, qd) qd (6,): the part of the centroidal momentum's rate that does not depend on
    qdd, so that

        dh_G/dt = A_G qdd + Adot_G qd = sum of the external wrenches about the centre of mass

    (gravity's (0, M g) and contacts; angular first, world-aligned axes; N m and N). It is the
    sum of the bodies' net wrenches G_i dV_i - ad_{V_i}^T G_i V_i at qdd = 0, moved to {G}.
    q, qd: (nq,), (nv,), or batches -> (6,) or (N, 6).
    data: optional Data of this model (single states): returns data.Adot_G_qd, allocating
    nothing (data.h_G holds h_G).
    """
    return _momentum(model, q, qd, True, data)


def centroidal_record(model, q, qd):
    """(c (K, 3), h_G (K, 6)): the centre of mass (m, world frame) and the centroidal momentum
    (k_G, l_G) at each sample of a run, q (K, nq), qd (K, nv) (a floating run's record), by one
    compiled kernel (centroidal_record_batch_kernel); the values of center_of_mass and
    centroidal_momentum at each row. The model has moving mass."""
    q, qd = np.ascontiguousarray(q, dtype=float), np.ascontiguousarray(qd, dtype=float)
    out = np.empty((q.shape[0], 9))
    arguments = {"q": q, "qd": qd}
    checks.run_batch(
        model, centroidal_record_batch_kernel, (q, qd), out, "centroidal_momentum", "h_G",
        arguments,
    )
    return out[:, :3].copy(), out[:, 3:].copy()


# (function, result) of the momentum kernel's two results, for errors: h_G, then Adot_G qd
MOMENTUM_NAMES = (("centroidal_momentum", "h_G"), ("centroidal_momentum_rate_bias", "Adot_G qd"))


def _momentum(model, q, qd, rate, data):
    """h_G (rate False) or Adot_G qd (rate True) for a single state or a batch: a float64 state
    goes straight to the kernel's exact twin; anything else through _evaluate (which converts,
    raises naming the argument, or runs the batch)."""
    what, result = MOMENTUM_NAMES[rate]
    work = checks.work_of(model, data, what)  # checks model and data
    out = np.empty((2, 6)) if data is None else data._momentum
    if model._total_mass > 0.0:
        try:
            if not momentum_exact(model._ibuf, model._fbuf, work, q, qd, rate, out):
                if data is None:
                    return out[1] if rate else out[0]
                return data.Adot_G_qd if rate else data.h_G
        except TypeError:  # arguments to convert: the checked path
            pass
    out = _evaluate(MOMENTUM, model, data, (q, qd), out, what, result, (rate,))
    k = 1 if rate else 0
    if out.ndim == 3:
        return out[:, k, :]
    return out[k] if data is None else (data.Adot_G_qd if rate else data.h_G)
