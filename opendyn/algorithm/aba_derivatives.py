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
from .._runtime.entry import exact
from .._runtime.kernel_cache import BATCH, JIT
from .._runtime.status import Status
from ..multibody.joints import state_status, vector_status
from ..multibody.layout import body_count, dof_count
from ..multibody.work_views import (
    derivative_fields,
    joint_accelerations,
    joint_vectors,
    mass_matrix_field,
    new_work,
)
from . import checks
from .calls import Call
from .christoffel import space_axes_and_inertias, velocity_terms
from .crba import crba_kernel
from .forward import NO_ARMATURE
from .minverse import inverse_mass_matrix_kernel, mass_matrix_inverse
from .rnea_derivatives import (
    accelerations_and_wrenches,
    assemble_derivatives,
    derivatives_at,
    joint_space_forces,
)
from .singular import singular_mass_matrix


@njit(**JIT)
def invert(coupled, ibuf, fbuf, work, q, armature, M, Minv):
    """Minv <- (M(q) + diag(armature))^-1, with the CoriolisTerms of space_axes_and_inertias in
    `work`: by the recursion when the compile-time switch coupled is None (one coordinate per
    body), else by the Cholesky factor of M from CRBA (coupled joints; M is left holding it).
    Returns a Status."""
    if coupled is None:
        return inverse_mass_matrix_kernel(ibuf, fbuf, work, armature, Minv)
    crba_kernel(ibuf, fbuf, work, q, M)
    return mass_matrix_inverse(M, armature, Minv)


@njit(**JIT)
def times_minus(Minv, D, out):
    """out = -Minv D for (nv, nv) arrays (a BLAS product into out, then its sign)."""
    np.dot(Minv, D, out)
    n = out.shape[0]
    for r in range(n):
        for c in range(n):
            out[r, c] = -out[r, c]


@njit(**JIT)
def aba_derivatives_kernel(
    ibuf, fbuf, work, state, loads, armature, coupled, ddq_dq, ddq_dqd, Minv
):
    """ddq_dq, ddq_dqd, Minv (nv, nv) <- the derivatives of forward dynamics at state = (q, qd,
    tau), in `work` (a Data's buffer: its qdd, dtau_dq, dtau_dqd and M are left as the forward
    dynamics' and RNEA derivatives' at that state); loads as rnea_kernel's; armature (nv,) or
    empty; coupled None, or True for coupled joints (invert). One kinematic pass serves all:
    M^-1 first, then h from the world-frame wrenches at qdd = 0, qdd = M^-1 (tau - h), and the
    RNEA derivatives at qdd. Returns a Status."""
    q, qd, tau = state
    status = state_status(ibuf, q, qd)
    if status:
        return status
    status = vector_status(ibuf, tau, Status.TAU_NOT_FINITE.value)
    if status:
        return status
    nb, nv = body_count(ibuf), dof_count(ibuf)
    M = mass_matrix_field(work, nb, nv)
    space_axes_and_inertias(ibuf, fbuf, work, q)
    status = invert(coupled, ibuf, fbuf, work, q, armature, M, Minv)
    if status:
        return status
    velocity_terms(ibuf, fbuf, work, qd)
    # qdd = M^-1 (tau - h), h = sum over each axis's subtree of the wrenches at qdd = 0
    h, zero, _ = joint_vectors(work, nb, nv)
    accelerations_and_wrenches(ibuf, fbuf, work, qd, zero, loads)
    joint_space_forces(ibuf, fbuf, work, h)
    qdd = joint_accelerations(work, nb, nv)
    for r in range(nv):
        s = 0.0
        for c in range(nv):
            s += Minv[r, c] * (tau[c] - h[c])
        qdd[r] = s
    accelerations_and_wrenches(ibuf, fbuf, work, qd, qdd, loads)
    fields = derivative_fields(work, nb, nv)
    assemble_derivatives(ibuf, fbuf, work, fields.dtau_dq, fields.dtau_dqd, M)
    times_minus(Minv, fields.dtau_dq, ddq_dq)
    times_minus(Minv, fields.dtau_dqd, ddq_dqd)
    status = result_status(ddq_dq)
    return status if status else result_status(ddq_dqd)


@njit(**BATCH)
def aba_derivatives_batch_kernel(
    ibuf, fbuf, states, loads, armature, coupled, out, status, start, stop
):
    """Forward dynamics derivatives over rows [start, stop) of a batch, states = (q, qd, tau),
    into out (N, 3, nv, nv) (ddq_dq, ddq_dqd, Minv); loads (1 or N, rows, 6); armature and
    coupled as aba_derivatives_kernel's. The rows work in a buffer of their own."""
    q, qd, tau = states
    shared = loads.shape[0] == 1
    work = new_work(body_count(ibuf), dof_count(ibuf))
    for n in range(start, stop):
        status[n] = aba_derivatives_kernel(
            ibuf,
            fbuf,
            work,
            (q[n], qd[n], tau[n]),
            loads[0] if shared else loads[n],
            armature,
            coupled,
            out[n, 0],
            out[n, 1],
            out[n, 2],
        )


def coupled_switch(model):
    """The kernel's compile-time switch: True for a model with coupled (mimic) joints, else
    None."""
    return True if model.coupled else None


aba_derivatives_exact = exact(aba_derivatives_kernel)
ABA_DERIVATIVES = Call(
    aba_derivatives_kernel,
    aba_derivatives_exact,
    aba_derivatives_batch_kernel,
    ("q", "qd", "tau"),
    (True, True),
    True,
    singular_mass_matrix,
)


def forward_dynamics_derivatives(model, q, qd, tau, f_tip=None, gravity=None, data=None):
    """The partial derivatives of qdd = forward_dynamics(model, q, qd, tau, f_tip, gravity),
    analytical: -M^-1 (dtau/dq, dtau/dqd) of the RNEA derivatives at qdd, and M^-1 by the
    articulated-body recursion (the module docstring).

    Args:
      q, qd, tau: as forward_dynamics: q (nq,), qd and tau (nv,), or batches (N, nq), (N, nv).
      f_tip: {frame: (6,) wrench (m, f) the frame applies to the environment, in its
        coordinates}.
      gravity: (3,) world-frame (m/s^2), default model.gravity.
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
    return derivatives_at(
        model,
        ABA_DERIVATIVES,
        (q, qd, tau),
        (f_tip, gravity),
        data,
        ("ddq_dq", "ddq_dqd", "Minv"),
        (NO_ARMATURE, coupled_switch(model)),
        "forward_dynamics_derivatives",
    )
