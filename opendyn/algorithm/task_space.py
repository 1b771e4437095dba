"""Task-space (operational-space) dynamics of a frame, in the frame's own coordinates:

    F = Lambda(q) dV_b + eta(q, qd)
    Lambda = (J_b M^-1 J_b^T)^-1,    eta = Lambda (J_b M^-1 h - Jdot_b qd)

For a square invertible J_b these are the seed's Lambda = J^-T M J^-1 and
eta = J^-T h - Lambda Jdot J^-1 V (Lynch & Park, Section 8.6). Jdot_b qd is the frame's twist
rate at qdd = 0 without gravity, taken from the RNEA forward pass.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg
from numba import njit

from .._runtime.kernel_cache import JIT
from ..errors import SingularTaskSpaceError
from ..multibody.layout import body_count, tree
from ..spatial.algebra import angular, linear
from . import checks
from .crba import mass_matrix
from .kinematics import jacobian
from .rnea import bias_forces, forward_pass


@njit(**JIT)
def body_accelerations(ibuf, fbuf, q, qd, qdd, dV_0):
    """dV (nb, 6): every body's twist rate in its own frame, from the RNEA forward pass."""
    nb = body_count(ibuf)
    R, p = np.empty((nb, 3, 3)), np.empty((nb, 3))
    V, dV = np.empty((nb, 6)), np.empty((nb, 6))
    forward_pass(tree(ibuf, fbuf), q, qd, qdd, dV_0, R, p, V, dV, np.empty((2, 6)))
    return dV


def _task_space(model, q, frame, damping, what):
    """Lambda (6, 6), J_b (6, nv) and M's Cholesky factor, each computed once."""
    q = checks.as_q(model, q)
    if q.ndim != 1:
        raise ValueError(f"{what}: q must be a single configuration (nv,)")
    damping = checks.as_real(damping, f"{what}: damping")
    if damping < 0 or not np.isfinite(damping):
        raise ValueError(f"{what}: damping must be finite and >= 0, got {damping}")
    J_b = jacobian(model, q, frame, expressed_in="body")
    try:
        M_chol = scipy.linalg.cho_factor(mass_matrix(model, q))
    except np.linalg.LinAlgError:
        raise checks.singular_mass_matrix(model, q, what) from None
    Lambda_inv = J_b @ scipy.linalg.cho_solve(M_chol, J_b.T)
    if damping > 0:
        return np.linalg.inv(Lambda_inv + damping * np.eye(6)), J_b, M_chol
    sv = np.linalg.svd(Lambda_inv, compute_uv=False)
    if sv[-1] <= 1e-10 * sv[0]:
        raise SingularTaskSpaceError(
            f"{what}: frame {frame!r} of {model.name!r} cannot move in every "
            f"task direction at this q (J_b M^-1 J_b^T has singular values {sv}; rank "
            f"{int(np.sum(sv > 1e-10 * sv[0]))} < 6): Lambda is undefined. Pass damping > 0 "
            f"for a damped inverse"
        )
    return np.linalg.inv(Lambda_inv), J_b, M_chol


def task_space_mass_matrix(model, q, frame, damping=0.0):
    """Lambda(q) = (J_b M^-1 J_b^T)^-1: (6, 6) apparent spatial inertia of a frame, in the
    frame's coordinates (angular first), so that F = Lambda dV_b + eta.

    q: (nv,) configuration; frame: a frame name.
    damping: 0 (default) raises SingularTaskSpaceError where J_b M^-1 J_b^T is singular or
      ill-conditioned (fewer than 6 joints, or a singular configuration); damping > 0 returns
      the damped (J_b M^-1 J_b^T + damping I)^-1, finite everywhere.
    """
    what = "task_space_mass_matrix"
    checks.check_model(model, what)
    Lambda = _task_space(model, q, frame, damping, what)[0]
    return checks.check_result(Lambda, what, "Lambda", {"q": q})


def frame_acceleration(model, q, qd, qdd, frame):
    """dV_b = J_b qdd + Jdot_b qd: (6,) rate of the frame's body twist V_b = J_b qd, angular
    first, in the frame's coordinates (rad/s^2, m/s^2); a kinematic quantity, no gravity.

    q, qd, qdd: (nv,) single states; frame: a frame name.
    """
    checks.check_model(model, "frame_acceleration")
    (q, qd, qdd), batch = checks.as_states(model, q, ("qd", qd), ("qdd", qdd))
    if batch:
        raise ValueError("frame_acceleration: q, qd, qdd must be single states (nv,)")
    fr = model.frames[model.frame_index(frame)]
    if fr.body < 0:
        return np.zeros(6)
    for name, x in (("q", q), ("qd", qd), ("qdd", qdd)):
        if not np.all(np.isfinite(x)):
            raise ValueError(f"frame_acceleration: {name} must be finite")
    dV = body_accelerations(model._ibuf, model._fbuf, q, qd, qdd, np.zeros(6))
    arguments = {"q": q, "qd": qd, "qdd": qdd}
    checks.check_result(dV[fr.body], "frame_acceleration", "dV_b", arguments)
    # dV_frame = Ad_{T_{frame,body}} dV_body (the frame is rigidly attached)
    T = fr.T_body_frame
    R_bf, p_bf = T[:3, :3], T[:3, 3]
    w, v = angular(dV[fr.body]), linear(dV[fr.body])
    return np.concatenate([R_bf.T @ w, R_bf.T @ (v + np.cross(w, p_bf))])


def task_space_bias(model, q, qd, frame, gravity=None):
    """eta(q, qd) = Lambda (J_b M^-1 h - Jdot_b qd): (6,) the wrench (m, f), in the frame's
    coordinates, of velocity-product and gravity terms, so that F = Lambda dV_b + eta.

    Raises SingularTaskSpaceError where Lambda is undefined (see task_space_mass_matrix).
    """
    checks.check_model(model, "task_space_bias")
    Lambda, J_b, M_chol = _task_space(model, q, frame, 0.0, "task_space_bias")
    h = bias_forces(model, q, qd, gravity)
    Jdot_qd = frame_acceleration(model, q, qd, np.zeros(model.nv), frame)
    eta = Lambda @ (J_b @ scipy.linalg.cho_solve(M_chol, h) - Jdot_qd)
    arguments = {"q": q, "qd": qd, "gravity": gravity}
    return checks.check_result(eta, "task_space_bias", "eta", arguments)
