"""Forward dynamics: solve M(q) qdd = tau - h(q, qd) - sum_frames J_b(frame)^T F_tip(frame).

Three methods, same answer, different cost:
  "aba"           articulated-body algorithm, O(n) (module aba)
  "crba"          M by CRBA, h by RNEA, then the Cholesky factorisation M = L L^T, O(n^3)
  "newton_euler"  the seed's method: column k of M is RNEA with qdd = e_k, qd = 0, g = 0 and no
                  F_tip (n RNEA calls), h is RNEA with qdd = 0, then Cholesky, O(n^3)
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .._runtime.arrays import result_status
from .._runtime.entry import exact
from .._runtime.kernel_cache import BATCH, JIT
from .._runtime.status import Status
from ..multibody.joints import vector_status
from ..multibody.layout import body_count, dof_count
from ..multibody.work_views import joint_vectors, mass_matrix_field, new_work, no_loads
from . import checks
from .aba import aba_kernel
from .calls import Call, checked_call
from .cholesky import cholesky_solve
from .crba import crba_kernel
from .rnea import rnea_kernel
from .singular import singular_mass_matrix

METHODS = ("aba", "crba", "newton_euler")
NO_ARMATURE = np.zeros(0)  # the rigid-body M: no rotor inertias


@njit(**JIT)
def newton_euler_mass_matrix(ibuf, fbuf, work, q, M):
    """M (nv, nv) <- the seed's method: column k is RNEA's tau with qdd = e_k, qd = 0,
    gravity = 0 and no F_tip (nv RNEA calls), written as row k (M is symmetric), in `work`.
    Returns a Status."""
    nb, nv = body_count(ibuf), dof_count(ibuf)
    _, zero, e_k = joint_vectors(work, nb, nv)
    loads = no_loads(work, nb, nv)
    for k in range(nv):
        e_k[k] = 1.0
        status = rnea_kernel(ibuf, fbuf, work, q, zero, e_k, loads, M[k])
        e_k[k] = 0.0
        if status:
            return status
    return Status.OK.value


@njit(**JIT)
def mass_matrix_solve(ibuf, fbuf, work, state, loads, qdd, armature, crba, newton_euler):
    """qdd <- (M + diag(armature))^-1 (tau - h - J^T F_tip) at state = (q, qd, tau), M by CRBA
    or by nv RNEA calls, whichever compile-time switch (crba, newton_euler) is not None;
    armature (nv,) or empty. In `work`: its h ends as the right-hand side tau - h - J^T F_tip,
    and its M as the Cholesky factor L (in the lower triangle, M = L L^T).
    Returns a Status as aba_kernel, or RESULT_NOT_FINITE when h overflowed."""
    q, qd, tau = state
    nb, nv = body_count(ibuf), dof_count(ibuf)
    M = mass_matrix_field(work, nb, nv)
    b, zero, _ = joint_vectors(work, nb, nv)
    status = rnea_kernel(ibuf, fbuf, work, q, qd, zero, loads, b)
    if status:
        return status
    status = vector_status(ibuf, tau, Status.TAU_NOT_FINITE.value)
    if status:
        return status
    if crba is not None:
        crba_kernel(ibuf, fbuf, work, q, M)
    if newton_euler is not None:
        newton_euler_mass_matrix(ibuf, fbuf, work, q, M)
    for k in range(armature.shape[0]):
        M[k, k] += armature[k]
    for k in range(nv):
        b[k] = tau[k] - b[k]
    return cholesky_solve(M, b, qdd)


@njit(**JIT)
def solve_by(aba, crba, newton_euler, ibuf, fbuf, work, state, loads, qdd, armature):
    """qdd at state = (q, qd, tau) by the method the compile-time switches name: one of aba,
    crba, newton_euler True, the others None (method_switches). numba drops the code behind a
    None argument when it compiles, so only the method asked for is compiled. Returns a
    Status, the method's or RESULT_NOT_FINITE (qdd overflowed)."""
    if aba is not None:
        q, qd, tau = state
        status = aba_kernel(ibuf, fbuf, work, q, qd, tau, loads, qdd, armature)
        return status if status else result_status(qdd)
    if crba is not None or newton_euler is not None:
        status = mass_matrix_solve(
            ibuf, fbuf, work, state, loads, qdd, armature, crba, newton_euler
        )
        return status if status else result_status(qdd)
    return Status.OK.value  # no method switched on: nothing to compile


@njit(**JIT)
def forward_kernel(ibuf, fbuf, work, q, qd, tau, loads, armature, method, qdd):
    """qdd (nv,) <- forward dynamics at one state by the method whose switch in method =
    (aba, crba, newton_euler) is True (solve_by); armature (nv,) rotor inertias on M's
    diagonal, or an empty array for none. Works in `work` (a Data's buffer). Returns a
    Status."""
    aba, crba, newton_euler = method
    return solve_by(aba, crba, newton_euler, ibuf, fbuf, work, (q, qd, tau), loads, qdd, armature)


@njit(**BATCH)
def forward_batch_kernel(ibuf, fbuf, states, loads, armature, method, qdd, status, start, stop):
    """Forward dynamics over rows [start, stop) of a batch, states = (q (N, nq), qd (N, nv),
    tau (N, nv)); loads (1 or N, rows, 6); armature as in forward_kernel, an argument (a
    global array would be a read-only constant to numba, and the kernel would compile again
    for it). The rows work in a buffer of their own."""
    q, qd, tau = states
    shared = loads.shape[0] == 1
    work = new_work(body_count(ibuf), dof_count(ibuf))
    for n in range(start, stop):
        status[n] = forward_kernel(
            ibuf,
            fbuf,
            work,
            q[n],
            qd[n],
            tau[n],
            loads[0] if shared else loads[n],
            armature,
            method,
            qdd[n],
        )


forward_exact = exact(forward_kernel)
FORWARD = Call(
    forward_kernel, forward_exact, forward_batch_kernel, ("q", "qd", "tau"), (False, True), True,
    singular_mass_matrix,
)
_SWITCHES = {m: tuple(True if m == k else None for k in METHODS) for m in (*METHODS, None)}


def method_switches(model, method):
    """(aba, crba, newton_euler): the compile-time switches of forward_kernel for a method
    name, True for the method and None for the others (all None for a method name of None: no
    forward dynamics). Models with coupled (mimic) joints solve "aba" by CRBA (ABA needs one
    coordinate a body). A table look-up: it runs on every forward_dynamics call."""
    try:
        return _SWITCHES["crba" if method == "aba" and model.coupled else method]
    except (KeyError, TypeError):
        raise ValueError(
            f"forward_dynamics: method must be one of {', '.join(METHODS)}, got {method!r}"
        ) from None


def forward_dynamics(model, q, qd, tau, f_tip=None, gravity=None, method="aba", data=None):
    """qdd = M(q)^-1 (tau - c(q, qd) - g(q) - sum_frames J_b(frame)^T F_tip(frame)).

    Args:
      q: (nq,) configuration (joint positions in rad or m, after a floating base's (p, quat));
      qd, tau: (nv,) velocities and generalized forces (N m or N; a floating base's twist
        (omega_b, v_b) and wrench (m_b, f_b) in its own frame first); or batches (N, nq), (N, nv).
      f_tip: optional {frame_name: (6,) wrench (m, f)} that each frame applies TO THE
        ENVIRONMENT, in that frame's coordinates.
      gravity: optional (3,) world-frame gravity (m/s^2), default model.gravity.
      method: "aba" (O(n), default), "crba" (CRBA + Cholesky) or "newton_euler" (the seed's
        n-RNEA mass matrix + Cholesky). Models with coupled mimic joints solve "aba" by CRBA.
      data: optional Data of this model (single states): the call works in it and returns
        data.qdd, allocating nothing (f_tip and a gravity override are converted first); ABA
        leaves its articulated inertias and biases in data.IA, data.pA, ..., the CRBA methods
        M's Cholesky factor L in data.M's lower triangle.
    Returns qdd, (nv,) or (N, nv) (rad/s^2 or m/s^2).
    Raises SingularMassMatrixError (a ValueError) naming every joint that moves nothing with
    mass or inertia (or the joints whose combined motion moves none) when M(q) is singular.
    """
    work = checks.work_of(model, data, "forward_dynamics")  # checks model and data
    switches = method_switches(model, method)
    qdd = np.empty(model._vector_shape) if data is None else data.qdd
    if gravity is None and f_tip is None:
        # the common call: float64 vectors of the model's sizes go to the kernel's exact twin
        ibuf, fbuf, loads = model._ibuf, model._fbuf, model._loads
        try:
            if not forward_exact(ibuf, fbuf, work, q, qd, tau, loads, NO_ARMATURE, switches, qdd):
                return qdd
        except TypeError:  # arguments to convert: the checked path
            pass
    given = {"gravity": gravity, "f_tip": f_tip}
    options = (NO_ARMATURE, switches)
    return checked_call(
        FORWARD, model, data, (q, qd, tau), qdd, "forward_dynamics", "qdd", options, given
    )
