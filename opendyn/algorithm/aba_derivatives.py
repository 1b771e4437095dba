"""The partial derivatives of forward dynamics, qdd = FD(q, qd, tau), from those of inverse
dynamics (Carpentier and Mansard, RSS 2018, Section IV; Pinocchio's computeABADerivatives):

FD inverts ID: ID(q, qd, FD(q, qd, tau)) = tau for every (q, qd, tau). Differentiating,
    dID/dq + M dqdd/dq = 0,   dID/dqd + M dqdd/dqd = 0,   M dqdd/dtau = I,
so at qdd = FD(q, qd, tau)
    dqdd/dq = -M^-1 dID/dq,   dqdd/dqd = -M^-1 dID/dqd,   dqdd/dtau = M^-1,
with dID/dq and dID/dqd by the RNEA derivatives (opendyn.algorithm.rnea_derivatives) and M^-1
by the articulated-body recursion (opendyn.algorithm.minverse), not by inverting M. A rotor
inertia (armature, the scenes' effect) adds diag(armature) to M and nothing to dID.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .._runtime.arrays import result_status
from .._runtime.kernel_cache import BATCH, JIT
from ..multibody.data import (
    derivative_fields,
    joint_accelerations,
    mass_matrix_field,
    new_work,
)
from ..multibody.layout import body_count, dof_count
from . import checks
from .forward import NO_ARMATURE, forward_kernel, method_switches
from .minverse import inverse_mass_matrix_kernel, mass_matrix_inverse
from .rnea_derivatives import rnea_derivatives_kernel


@njit(**JIT)
def invert(aba, ibuf, fbuf, work, armature, M, Minv):
    """Minv <- (M + diag(armature))^-1: by the recursion when the compile-time switch aba is
    not None (one coordinate per body), else by M's Cholesky factor (coupled joints; M is
    overwritten by it). Returns a Status."""
    if aba is not None:
        return inverse_mass_matrix_kernel(ibuf, fbuf, work, armature, Minv)
    return mass_matrix_inverse(M, armature, Minv)


@njit(**JIT)
def times_minus(Minv, D, out):
    """out = -Minv D for (nv, nv) arrays."""
    n = Minv.shape[0]
    for r in range(n):
        for c in range(n):
            s = 0.0
            for k in range(n):
                s += Minv[r, k] * D[k, c]
            out[r, c] = -s


@njit(**JIT)
def aba_derivatives_kernel(ibuf, fbuf, work, state, loads, armature, method, ddq_dq, ddq_dqd, Minv):
    """ddq_dq, ddq_dqd, Minv (nv, nv) <- the derivatives of forward dynamics at state = (q, qd,
    tau), in `work` (a Data's buffer: its qdd, dtau_dq, dtau_dqd and M are left as the forward
    dynamics' and RNEA derivatives' at that state); loads as rnea_kernel's; armature (nv,) or
    empty; method forward_kernel's switches (ABA, or CRBA for coupled joints). Returns a
    Status."""
    q, qd, tau = state
    nb, nv = body_count(ibuf), dof_count(ibuf)
    qdd = joint_accelerations(work, nb, nv)
    status = forward_kernel(ibuf, fbuf, work, q, qd, tau, loads, qdd, armature, method)
    if status:
        return status
    fields = derivative_fields(work, nb, nv)
    M = mass_matrix_field(work, nb, nv)
    status = rnea_derivatives_kernel(
        ibuf, fbuf, work, q, qd, qdd, loads, fields.dtau_dq, fields.dtau_dqd, M
    )
    if status:
        return status
    status = invert(method[0], ibuf, fbuf, work, armature, M, Minv)
    if status:
        return status
    times_minus(Minv, fields.dtau_dq, ddq_dq)
    times_minus(Minv, fields.dtau_dqd, ddq_dqd)
    status = result_status(ddq_dq)
    return status if status else result_status(ddq_dqd)


@njit(**BATCH)
def aba_derivatives_batch_kernel(ibuf, fbuf, states, loads, method, out, status, start, stop):
    """Forward dynamics derivatives over rows [start, stop) of a batch, states = (q, qd, tau),
    into out (N, 3, nv, nv) (ddq_dq, ddq_dqd, Minv); loads (1 or N, rows, 6). The rows work in
    a buffer of their own."""
    q, qd, tau = states
    shared = loads.shape[0] == 1
    work = new_work(body_count(ibuf), dof_count(ibuf))
    armature = np.zeros(0)
    for n in range(start, stop):
        status[n] = aba_derivatives_kernel(
            ibuf,
            fbuf,
            work,
            (q[n], qd[n], tau[n]),
            loads[0] if shared else loads[n],
            armature,
            method,
            out[n, 0],
            out[n, 1],
            out[n, 2],
        )


def forward_dynamics_derivatives(model, q, qd, tau, f_tip=None, gravity=None, data=None):
    """The partial derivatives of qdd = forward_dynamics(model, q, qd, tau, f_tip, gravity),
    analytical: -M^-1 (dtau/dq, dtau/dqd) of the RNEA derivatives at qdd, and M^-1 by the
    articulated-body recursion (the module docstring).

    Args: as forward_dynamics: q (nq,), qd and tau (nv,), or batches (N, nq), (N, nv); f_tip
      {frame: (6,) wrench (m, f) the frame applies to the environment, in its coordinates};
      gravity (3,) world-frame (m/s^2), default model.gravity.
      data: optional Data of this model (single states): the call works in it and returns
        (data.ddq_dq, data.ddq_dqd, data.Minv), allocating nothing; data.qdd holds qdd and
        data.dtau_dq, data.dtau_dqd the inverse dynamics' derivatives there.
    Returns (dqdd_dq, dqdd_dqd, dqdd_dtau), each (nv, nv), or (N, nv, nv) for a batch:
      dqdd_dq[:, k] = d qdd / d q along coordinate k of the tangent space (a joint's angle or
        displacement; for a free joint, the body twist coordinate k of integrate(q, e e_k) =
        T exp(e e_k), as Pinocchio's), (rad/s^2 or m/s^2 per rad or m);
      dqdd_dqd (per s); dqdd_dtau = M(q)^-1, full and symmetric.
    Raises SingularMassMatrixError (a ValueError) when M(q) is singular, as forward_dynamics.
    Models with coupled (mimic) joints invert M by its Cholesky factor (no ABA for them).
    """
    checks.check_model(model, "forward_dynamics_derivatives")
    what = "forward_dynamics_derivatives"
    work = checks.work_of(model, data, what)
    (q, qd, tau), batch = checks.as_states(model, q, ("qd", qd), ("tau", tau))
    arguments = {"q": q, "qd": qd, "tau": tau, "gravity": gravity, "f_tip": f_tip}
    nv, method = model.nv, method_switches(model, "aba")
    if not batch:
        if data is None:
            out = (np.empty((nv, nv)), np.empty((nv, nv)), np.empty((nv, nv)))
        else:
            out = (data.ddq_dq, data.ddq_dqd, data.Minv)
        status = aba_derivatives_kernel(
            model._ibuf,
            model._fbuf,
            work,
            (q, qd, tau),
            checks.loads(model, gravity, f_tip),
            NO_ARMATURE,
            method,
            *out,
        )
        if status:
            checks.raise_status(status, model, what, "dqdd_dq", arguments)
        return out
    checks.single_state_only(data, what)
    n = q.shape[0]
    inputs = ((q, qd, tau), checks.loads(model, gravity, f_tip, n), method)
    out = checks.run_batch(
        model, aba_derivatives_batch_kernel, inputs, np.empty((n, 3, nv, nv)), what,
        "dqdd_dq", arguments,
    )
    return out[:, 0], out[:, 1], out[:, 2]
