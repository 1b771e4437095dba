"""The joint-torque regressor: inverse dynamics is linear in the bodies' inertial parameters,

    tau = Y(q, qd, qdd) pi,    pi = (pi_1, ..., pi_nb),
    pi_i = (m, m c_x, m c_y, m c_z, I_xx, I_xy, I_yy, I_xz, I_yz, I_zz)

with m c the first moment and I the rotational inertia about the origin of body i's frame {i},
in its axes (Model.inertial_parameters; Pinocchio's order). The net wrench on body i of the RNEA
(opendyn.algorithm.rnea), F_i = G_i dV_i - ad_{V_i}^T G_i V_i, is linear in pi_i:

    F_i = B(V_i, dV_i) pi_i,  with the columns (V = (w, v), dV = (alpha, a), angular first)
      m:      (0, a + w x v)
      m c_k:  (e_k x a + w x (e_k x v) - v x (e_k x w),  -e_k x alpha - w x (e_k x w))
      I_rc:   (E_rc alpha + w x (E_rc w), 0)     (E_rc: the symmetric unit matrix of entry rc)

and joint j transmits the wrenches of the bodies it carries, so the columns of body i are

    Y[j's rows, 10 i + c] = mult_j S_j^T Ad_{T_{i,j}}^T B_i[:, c]   for j = i and its ancestors
                          = S_{s,j}^T Ad_{T_{i,s}}^T B_i[:, c]

(zero elsewhere), S_{s,j} = mult_j Ad_{T_{s,j}} S_j the joint's axes in the world frame {s}: each
column moves to {s} once, and each joint's share is a dot product. Gravity enters as the base
acceleration dV_0 = (0, -g), as in the RNEA.
(Atkeson, An and Hollerbach, "Estimation of inertial parameters of manipulator loads and links",
IJRR 5(3), 1986; Khalil and Dombre, Modeling, Identification and Control of Robots, 2002.)
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .._runtime.arrays import result_status, zero_matrix
from .._runtime.entry import exact
from .._runtime.kernel_cache import BATCH, INLINE, JIT
from .._runtime.options import flag
from ..multibody.joints import motion_status
from ..multibody.layout import body_count, dof_count, tree
from ..multibody.work_views import (
    body_motion,
    joint_poses,
    new_work,
    scratch_rows,
    space_axes,
    temp_vectors,
    world_poses,
)
from ..spatial.compiled import dot6, wrench_to_parent
from . import checks
from .calls import Call, checked_call
from .kinematics import place_bodies, place_space_axes
from .rnea import forward_pass

# the entries (r, c) of I in a body's parameters 4 .. 9
_INERTIA_ENTRIES = ((0, 0), (0, 1), (1, 1), (0, 2), (1, 2), (2, 2))
PARAMETERS_PER_BODY = 10


@njit(**INLINE)
def cross3(a0, a1, a2, b0, b1, b2):
    """a x b of 3-vectors given by their components."""
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@njit(**INLINE)
def body_regressor_column(V, dV, c, F):
    """F (6,) <- column c of B(V, dV), the wrench G dV - ad_V^T G V of unit parameter c
    (the module's equations; parameter order of Model.inertial_parameters)."""
    w0, w1, w2, v0, v1, v2 = V[0], V[1], V[2], V[3], V[4], V[5]
    if c == 0:
        x = cross3(w0, w1, w2, v0, v1, v2)
        F[0], F[1], F[2] = 0.0, 0.0, 0.0
        F[3], F[4], F[5] = dV[3] + x[0], dV[4] + x[1], dV[5] + x[2]
    elif c < 4:
        e0, e1, e2 = 1.0 if c == 1 else 0.0, 1.0 if c == 2 else 0.0, 1.0 if c == 3 else 0.0
        ea = cross3(e0, e1, e2, dV[3], dV[4], dV[5])
        ev = cross3(e0, e1, e2, v0, v1, v2)
        ew = cross3(e0, e1, e2, w0, w1, w2)
        eal = cross3(e0, e1, e2, dV[0], dV[1], dV[2])
        wev = cross3(w0, w1, w2, ev[0], ev[1], ev[2])
        vew = cross3(v0, v1, v2, ew[0], ew[1], ew[2])
        wew = cross3(w0, w1, w2, ew[0], ew[1], ew[2])
        for k in range(3):
            F[k] = ea[k] + wev[k] - vew[k]
            F[3 + k] = -eal[k] - wew[k]
    else:
        r, s = _INERTIA_ENTRIES[c - 4]
        Ea0, Ea1, Ea2 = 0.0, 0.0, 0.0
        Ew0, Ew1, Ew2 = 0.0, 0.0, 0.0
        # E_rs x = e_r x_s + e_s x_r (once when r = s)
        for i, j in ((r, s), (s, r)):
            if i == 0:
                Ea0, Ew0 = dV[j], V[j]
            elif i == 1:
                Ea1, Ew1 = dV[j], V[j]
            else:
                Ea2, Ew2 = dV[j], V[j]
        x = cross3(w0, w1, w2, Ew0, Ew1, Ew2)
        F[0], F[1], F[2] = Ea0 + x[0], Ea1 + x[1], Ea2 + x[2]
        F[3], F[4], F[5] = 0.0, 0.0, 0.0


@njit(**JIT)
def regressor_kernel(ibuf, fbuf, work, q, qd, qdd, dV_0, Y):
    """Y (nv, 10 nb) <- the joint-torque regressor at one state under the base acceleration
    dV_0 = (0, -g), in `work` (R, p, R_s, p_s, V, dV and the axes S_s are left as this
    state's). Returns a Status: OK, Q/QD/QDD_NOT_FINITE, Q_NOT_UNIT_QUATERNION or
    RESULT_NOT_FINITE."""
    status = motion_status(ibuf, q, qd, qdd)
    if status:
        return status
    body_tree = tree(ibuf, fbuf)
    parent, nv_j, iv = body_tree.parent, body_tree.nv_j, body_tree.iv
    nb, nv = body_count(ibuf), dof_count(ibuf)
    R, p = joint_poses(work, nb)
    R_s, p_s = world_poses(work, nb)
    V, dV, _ = body_motion(work, nb)
    S_s = space_axes(work, nb)
    forward_pass(body_tree, q, qd, qdd, dV_0, R, p, V, dV, scratch_rows(work, nb, nv))
    place_bodies(body_tree, work)
    place_space_axes(body_tree, R_s, p_s, S_s)
    F = temp_vectors(work, nb, nv)[0]
    zero_matrix(Y)
    # column c of body i: F = Ad_{T_{i,s}}^T B_i[:, c], its wrench moved to {s} once; joint j
    # carrying body i transmits mult_j s_k^T F_j = S_s[j, k]^T F (the power of a twist and a
    # wrench is the same in every frame), for j = i and its ancestors
    for i in range(nb):
        for c in range(PARAMETERS_PER_BODY):
            column = PARAMETERS_PER_BODY * i + c
            body_regressor_column(V[i], dV[i], c, F)
            wrench_to_parent(R_s[i], p_s[i], F)
            j = i
            while j >= 0:
                for k in range(nv_j[j]):
                    Y[iv[j] + k, column] += dot6(S_s[j, k], F)
                j = parent[j]
    return result_status(Y)


@njit(**BATCH)
def regressor_batch_kernel(ibuf, fbuf, q, qd, qdd, dV_0, Y, status, start, stop):
    """Regressors over rows [start, stop) of a batch -> Y (N, nv, 10 nb), in a work buffer of
    their own."""
    work = new_work(body_count(ibuf), dof_count(ibuf))
    for n in range(start, stop):
        status[n] = regressor_kernel(ibuf, fbuf, work, q[n], qd[n], qdd[n], dV_0, Y[n])


def friction_columns(model, qd):
    """(nv, 2 nj) or (N, nv, 2 nj): the friction torques per unit coefficient, joint k's
    viscous column qd_k (N m s/rad or N s/m) then, nj columns on, its Coulomb column
    sign(qd_k), each on k's row (model.v_index)."""
    nj = len(model.joint_names)
    columns = np.zeros((*qd.shape[:-1], model.nv, 2 * nj))
    rows, k = np.asarray(model.v_index), np.arange(nj)
    columns[..., rows, k] = qd[..., rows]
    columns[..., rows, nj + k] = np.sign(qd[..., rows])
    return columns


regressor_exact = exact(regressor_kernel)
REGRESSOR = Call(
    regressor_kernel, regressor_exact, regressor_batch_kernel, ("q", "qd", "qdd")
)


def torque_regressor(model, q, qd, qdd, gravity=None, friction=False):
    """Y(q, qd, qdd), so that inverse_dynamics(model, q, qd, qdd) = Y @ model.inertial_parameters().

    q (nq,), qd and qdd (nv,): the state (the base twist (omega_b, v_b) in its own frame first
    for a floating base); gravity: optional (3,) world-frame vector (m/s^2), default
    model.gravity. Returns Y (nv, 10 nb): column 10 i + c is the generalized force (N m or N)
    per unit of body i's parameter c, in the order (m, m c_x, m c_y, m c_z, I_xx, I_xy, I_yy,
    I_xz, I_yz, I_zz), first moment and inertia about {i}'s origin in its axes (kg, kg m,
    kg m^2; Pinocchio's computeJointTorqueRegressor and order).
    friction=True appends 2 nj columns, the viscous then the Coulomb friction of each joint
    coordinate: tau + fv qd + fc sign(qd) = Y @ (pi, fv (nj,), fc (nj,)) in model.joint_names
    order (N m s/rad, N m; N s/m, N for prismatic joints).
    A batch (N, nq), (N, nv) stacks the states' rows: Y (N nv, 10 nb (+ 2 nj)), row n nv + k
    for coordinate k of state n, so that Y @ pi is the batch's torques raveled; the states run
    in one compiled call over the cores.
    (Atkeson, An and Hollerbach 1986; the module docstring has the equations.)
    """
    what = "torque_regressor"
    checks.check_model(model, what)
    friction = flag(friction, "torque_regressor: friction")
    Y = np.empty((model.nv, PARAMETERS_PER_BODY * model.nb))
    if gravity is None and not friction:
        # the common call: float64 vectors of the model's sizes go to the kernel's exact twin
        ibuf, fbuf, work, dV_0 = model._ibuf, model._fbuf, model._work, model._loads[0]
        try:
            if not regressor_exact(ibuf, fbuf, work, q, qd, qdd, dV_0, Y):
                return Y
        except TypeError:  # arguments to convert: the checked path
            pass
    dV_0 = checks.loads(model, gravity, None)[0]
    given = {"gravity": gravity}
    Y = checked_call(REGRESSOR, model, None, (q, qd, qdd), Y, what, "Y", (dV_0,), given)
    if friction:
        qd = np.broadcast_to(checks.as_state(model, qd, "qd"), (*Y.shape[:-2], model.nv))
        Y = np.concatenate([Y, friction_columns(model, qd)], axis=-1)
    return Y.reshape(-1, Y.shape[-1]) if Y.ndim == 3 else Y
