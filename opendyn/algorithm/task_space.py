"""Task-space (operational-space) dynamics of a frame, in the frame's own coordinates:

    F = Lambda(q) dV_b + eta(q, qd)
    Lambda = (J_b M^-1 J_b^T)^-1,    eta = Lambda (J_b M^-1 h - Jdot_b qd)

For a square invertible J_b these are the seed's Lambda = J^-T M J^-1 and
eta = J^-T h - Lambda Jdot J^-1 V (Lynch & Park, Section 8.6). Jdot_b qd is the frame's twist
rate at qdd = 0 without gravity, taken from the RNEA forward pass.

Compiled, in a work buffer (a Data's, or the model's own): J_b by the Jacobian kernel, M by
CRBA and its Cholesky factor M = L L^T (opendyn.algorithm.cholesky), then

    Y = L^-1 J_b^T,   J_b M^-1 J_b^T = Y^T Y,   J_b M^-1 = (L^-T Y)^T

and Lambda from the eigendecomposition J_b M^-1 J_b^T = E diag(e) E^T
(opendyn.algorithm.eigen), damped or not:

    Lambda = E diag(1 / (e + damping)) E^T

J_b M^-1 J_b^T is symmetric positive semi-definite, so its eigenvalues are its singular
values: without damping, e_min <= TASK_SPACE_RCOND e_max leaves Lambda undefined.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .._runtime.arrays import all_finite, fill, result_status
from .._runtime.kernel_cache import JIT
from .._runtime.options import as_real
from .._runtime.status import Status
from ..errors import SingularTaskSpaceError
from ..multibody.layout import body_count, dof_count, tree
from ..multibody.work_views import (
    body_motion,
    joint_poses,
    joint_vectors,
    no_loads,
    scratch_rows,
    task_space_fields,
    temp_vectors,
)
from ..spatial.compiled import twist_to_child
from . import checks
from .cholesky import back_substitute, cholesky_factor, forward_substitute, largest_diagonal
from .crba import crba_kernel, mass_matrix
from .eigen import symmetric_eigen
from .kinematics import _frame, jacobian, jacobian_kernel
from .rnea import forward_pass, rnea_kernel
from .singular import singular_mass_matrix

TASK_SPACE_RCOND = 1e-10  # J_b M^-1 J_b^T is singular when e_min <= this times e_max


@njit(**JIT)
def frame_acceleration_kernel(ibuf, fbuf, work, state, frame, dV_f):
    """dV_f (6,) <- dV_b = J_b qdd + Jdot_b qd of frame = (body, T_bf) at state = (q, qd, qdd),
    from RNEA's forward pass without gravity, in `work` (its R, p, V, dV are left as this
    state's); 0 for a frame of the fixed world. Returns a Status: OK, Q/QD/QDD_NOT_FINITE or
    RESULT_NOT_FINITE."""
    q, qd, qdd = state
    body, T_bf = frame
    if body < 0:
        fill(dV_f, 0.0)
        return Status.OK.value
    if not all_finite(q):
        return Status.Q_NOT_FINITE.value
    if not all_finite(qd):
        return Status.QD_NOT_FINITE.value
    if not all_finite(qdd):
        return Status.QDD_NOT_FINITE.value
    nb, nv = body_count(ibuf), dof_count(ibuf)
    R, p = joint_poses(work, nb)
    V, dV, _ = body_motion(work, nb)
    # the forward pass with dV_0 = 0: dV_i = J_b(i) qdd + Jdot_b(i) qd, in {i}
    dV_0 = no_loads(work, nb, nv)[0]
    forward_pass(tree(ibuf, fbuf), q, qd, qdd, dV_0, R, p, V, dV, scratch_rows(work, nb, nv))
    # dV_f = Ad_{T_{frame,body}} dV_body (the frame is rigidly attached to its body)
    twist_to_child(T_bf[:3, :3], T_bf[:3, 3], dV[body], dV_f)
    return result_status(dV_f)


@njit(**JIT)
def task_space_kernel(ibuf, fbuf, work, q, frame, damping, Lambda):
    """Lambda (6, 6) <- (J_b M^-1 J_b^T + damping I)^-1 of frame = (body, T_bf) at q (nq,),
    in `work`: its J is left holding J_b, M the Cholesky factor L of M = L L^T (lower
    triangle), JMinv J_b M^-1. Returns a Status: OK, Q_NOT_FINITE, Q_NOT_UNIT_QUATERNION,
    RESULT_NOT_FINITE, SINGULAR + k (M singular at coordinate k) or SINGULAR_TASK_SPACE
    (damping 0 and J_b M^-1 J_b^T singular)."""
    nb, nv = body_count(ibuf), dof_count(ibuf)
    J_b, M, JMinv, _, _ = task_space_fields(work, nb, nv)
    status = jacobian_kernel(ibuf, fbuf, work, q, frame, True, J_b)
    if status:
        return status
    status = crba_kernel(ibuf, fbuf, work, q, M)
    if status:
        return status
    # M = L L^T, L in M's lower triangle
    status = cholesky_factor(M, nv, largest_diagonal(M))
    if status:
        return status
    # Y = L^-1 J_b^T, column r of Y in row r of JMinv; J_b M^-1 J_b^T = Y^T Y
    for r in range(6):
        forward_substitute(M, nv, J_b[r], JMinv[r])
    for r in range(6):
        for c in range(r, 6):
            s = 0.0
            for k in range(nv):
                s += JMinv[r, k] * JMinv[c, k]
            Lambda[r, c] = s
            Lambda[c, r] = s
    # J_b M^-1 = (L^-T Y)^T
    for r in range(6):
        back_substitute(M, nv, JMinv[r], JMinv[r])
    # J_b M^-1 J_b^T = E diag(e) E^T (Lambda overwritten), e in the scratch row after E
    s6 = scratch_rows(work, nb, nv)
    E, e = s6[:6], s6[6]
    symmetric_eigen(Lambda, E, e)
    if damping == 0.0 and not e.min() > TASK_SPACE_RCOND * e.max():
        return Status.SINGULAR_TASK_SPACE.value
    # Lambda = E diag(1 / (e + damping)) E^T
    for r in range(6):
        for c in range(r, 6):
            s = 0.0
            for k in range(6):
                s += E[r, k] * E[c, k] / (e[k] + damping)
            Lambda[r, c] = s
            Lambda[c, r] = s
    return result_status(Lambda)


@njit(**JIT)
def task_space_bias_kernel(ibuf, fbuf, work, state, frame, loads, eta):
    """eta (6,) <- Lambda (J_b M^-1 h - Jdot_b qd) of frame = (body, T_bf) at state = (q, qd),
    h with the base acceleration (and wrenches) of loads as in rnea_kernel, in `work`: as
    task_space_kernel leaves it (undamped Lambda in its Lambda), with h(q, qd) in its h and
    Jdot_b qd in its dV_f. Returns a Status as task_space_kernel, or QD_NOT_FINITE."""
    q, qd = state
    nb, nv = body_count(ibuf), dof_count(ibuf)
    _, _, JMinv, Lambda, Jdot_qd = task_space_fields(work, nb, nv)
    status = task_space_kernel(ibuf, fbuf, work, q, frame, 0.0, Lambda)
    if status:
        return status
    h, zero, _ = joint_vectors(work, nb, nv)
    status = rnea_kernel(ibuf, fbuf, work, q, qd, zero, loads, h)
    if status:
        return status
    frame_acceleration_kernel(ibuf, fbuf, work, (q, qd, zero), frame, Jdot_qd)
    # b = J_b M^-1 h - Jdot_b qd, eta = Lambda b
    b = temp_vectors(work, nb, nv)[0]
    for r in range(6):
        s = -Jdot_qd[r]
        for k in range(nv):
            s += JMinv[r, k] * h[k]
        b[r] = s
    for r in range(6):
        s = 0.0
        for c in range(6):
            s += Lambda[r, c] * b[c]
        eta[r] = s
    return result_status(eta)


def _single_q(model, q, data, what):
    """q as a single (nq,) configuration; a batch is refused (with data=, as every data= call
    refuses one)."""
    q = checks.as_q(model, q)
    if q.ndim != 1:
        checks.single_state_only(data, what)
        raise ValueError(f"{what}: q must be a single configuration (nv,)")
    return q


def _raise(status, model, q, frame, what, result, arguments):
    """The error of a failing task-space kernel: SingularTaskSpaceError naming the frame and
    the singular values of J_b M^-1 J_b^T, or as checks.raise_status."""
    if status != Status.SINGULAR_TASK_SPACE:
        checks.raise_status(status, model, what, result, arguments, singular_mass_matrix)
    J_b = jacobian(model, q, frame, expressed_in="body")
    sv = np.linalg.svd(J_b @ np.linalg.solve(mass_matrix(model, q), J_b.T), compute_uv=False)
    raise SingularTaskSpaceError(
        f"{what}: frame {frame!r} of {model.name!r} cannot move in every "
        f"task direction at this q (J_b M^-1 J_b^T has singular values {sv}; rank "
        f"{int(np.sum(sv > TASK_SPACE_RCOND * sv[0]))} < 6): Lambda is undefined. Pass "
        f"damping > 0 for a damped inverse"
    )


def task_space_mass_matrix(model, q, frame, damping=0.0, data=None):
    """Lambda(q) = (J_b M^-1 J_b^T)^-1: (6, 6) apparent spatial inertia of a frame, in the
    frame's coordinates (angular first), so that F = Lambda dV_b + eta.

    q: (nv,) configuration; frame: a frame name.
    damping: 0 (default) raises SingularTaskSpaceError where J_b M^-1 J_b^T is singular or
      ill-conditioned (fewer than 6 joints, or a singular configuration); damping > 0 returns
      the damped (J_b M^-1 J_b^T + damping I)^-1, finite everywhere.
    data: optional Data of this model: the call works in it and returns data.Lambda,
      allocating nothing; data.J holds J_b, data.JMinv J_b M^-1 and data.M's lower triangle
      the Cholesky factor of M.
    """
    what = "task_space_mass_matrix"
    work = checks.work_of(model, data, what)  # checks model and data
    q = _single_q(model, q, data, what)
    damping = as_real(damping, f"{what}: damping")
    if damping < 0 or not np.isfinite(damping):
        raise ValueError(f"{what}: damping must be finite and >= 0, got {damping}")
    Lambda = np.empty((6, 6)) if data is None else data.Lambda
    status = task_space_kernel(
        model._ibuf, model._fbuf, work, q, _frame(model, frame), damping, Lambda
    )
    if status:
        _raise(status, model, q, frame, what, "Lambda", {"q": q})
    return Lambda


def frame_acceleration(model, q, qd, qdd, frame, data=None):
    """dV_b = J_b qdd + Jdot_b qd: (6,) rate of the frame's body twist V_b = J_b qd, angular
    first, in the frame's coordinates (rad/s^2, m/s^2); a kinematic quantity, no gravity.

    q, qd, qdd: (nv,) single states; frame: a frame name.
    data: optional Data of this model: the call works in it and returns data.dV_f, allocating
    nothing; data.V and data.dV hold the bodies' twists and their rates (no gravity).
    """
    what = "frame_acceleration"
    work = checks.work_of(model, data, what)  # checks model and data
    state, batch = checks.as_states(model, q, ("qd", qd), ("qdd", qdd))
    if batch:
        checks.single_state_only(data, what)
        raise ValueError(f"{what}: q, qd, qdd must be single states (nv,)")
    dV_f = np.empty(6) if data is None else data.dV_f
    frame_at = _frame(model, frame)
    status = frame_acceleration_kernel(model._ibuf, model._fbuf, work, tuple(state), frame_at, dV_f)
    if status:
        arguments = dict(zip(("q", "qd", "qdd"), state))
        checks.raise_status(status, model, what, "dV_b", arguments, singular_mass_matrix)
    return dV_f


def task_space_bias(model, q, qd, frame, gravity=None, data=None):
    """eta(q, qd) = Lambda (J_b M^-1 h - Jdot_b qd): (6,) the wrench (m, f), in the frame's
    coordinates, of velocity-product and gravity terms, so that F = Lambda dV_b + eta.

    data: optional Data of this model: the call works in it and returns data.eta, allocating
    nothing (a gravity override is converted first); data.Lambda holds Lambda, data.h h and
    data.dV_f Jdot_b qd, with the fields task_space_mass_matrix leaves.
    Raises SingularTaskSpaceError where Lambda is undefined (see task_space_mass_matrix).
    """
    what = "task_space_bias"
    work = checks.work_of(model, data, what)  # checks model and data
    q = _single_q(model, q, data, what)
    qd = checks.as_state(model, qd, "qd")
    if qd.ndim != 1:
        checks.single_state_only(data, what)
        raise ValueError(f"{what}: qd must be a single state (nv,)")
    eta = np.empty(6) if data is None else data.eta
    loads = checks.loads(model, gravity, None)
    status = task_space_bias_kernel(
        model._ibuf, model._fbuf, work, (q, qd), _frame(model, frame), loads, eta
    )
    if status:
        arguments = {"q": q, "qd": qd, "gravity": gravity}
        _raise(status, model, q, frame, what, "eta", arguments)
    return eta
