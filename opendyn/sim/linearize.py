"""A scene's dynamics linearized about a state, for LQR and MPC: A and B with

    d(dx)/dt = A dx + B du,    dx = (dq, dqd) (2 nv),    du the joint torques,

exactly (analytical derivatives, no finite differences). The scene's dynamics are
    qdd = (M(q) + diag(armature))^-1 (tau_e(t, q, qd) + u - h(q, qd))
with tau_e the sum of the generalized forces of the effects the scene names (each effect module
declares its exact derivatives, `tangent`) and h under the scene's gravity. So, with the
derivatives of forward dynamics at qdd (opendyn.algorithm.aba_derivatives),
    dqdd/dq  = (M + diag(armature))^-1 (dtau_e/dq - dID/dq),     likewise in qd,
    dqdd/du  = (M + diag(armature))^-1 on the joints' columns.
dq is in the tangent space, q = integrate(q_0, dq) (for a free joint T_0 exp(dq), the body
twist coordinates): for a joint d(dq)/dt = dqd; for a free joint moving at v_0 the error
e = log(T_0^-1 T) moves as de/dt = dv - ad_{v_0} e (first order), so
    A = [[-ad_{v_0} on the free joints (0 elsewhere), I], [dqdd/dq, dqdd/dqd]],
    B = [[0], [dqdd/du]].
With discrete=True, the zero-order hold over the scene's step dt:
    expm([[A, B], [0, 0]] dt) = [[A_d, B_d], [0, I]],   dx_{k+1} = A_d dx_k + B_d du_k.
Constraints are not linearized yet (a clear error).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from .._runtime.options import as_real, finite, flag
from ..algorithm import checks
from ..algorithm.aba_derivatives import aba_derivatives_kernel, coupled_switch
from ..algorithm.singular import singular_mass_matrix
from ..multibody.joints import FREE
from ..spatial.algebra import ad
from . import hard_settings
from .effects import registry
from .effects.interface import CONTROL
from .effects.tangent import LinearAt, space_axes
from .record import gravity_of
from .step_inputs import checked_configuration, checked_torque, checked_vector


def effect_forces(scene, t, q, qd):
    """(tau_e (nv,), dtau_e/dq, dtau_e/dqd (nv, nv)): the generalized force of every effect
    the scene names at (t, q, qd), with its exact derivatives, each effect's `tangent` in the
    registry's order (clip after the control laws it clips)."""
    model = scene.model
    nv = model.nv
    armature = np.zeros(nv)
    if scene.armature is not None:
        armature[model.v_index] = scene.armature
    control = [np.zeros(nv), np.zeros((nv, nv)), np.zeros((nv, nv))]
    at = LinearAt(scene, t, q, qd, gravity_of(scene), armature, space_axes(model, q), control)
    total = [np.zeros(nv), np.zeros((nv, nv)), np.zeros((nv, nv))]
    for effect in registry.EFFECTS:
        record = effect.record(scene)
        if record is None or effect.tangent is None:
            continue
        parts = effect.tangent(record, at)
        into = control if effect.ENERGY == CONTROL else total
        for k in range(3):
            into[k] += parts[k]
    return tuple(total[k] + control[k] for k in range(3)), armature


def linearize(scene, t=0.0, q=None, qd=None, tau=None, discrete=False):
    """The scene's (a Scene's) dynamics linearized at (t, q, qd) under the joint
    torques tau: the driver of od.linearize (opendyn.api.linearize), which documents the
    arguments and also takes a scene file or a shipped scene's name (module docstring for the
    equations)."""
    model = scene.model
    if scene.constraints:
        raise ValueError(
            f"linearize: scene {scene.name!r} has constraints, whose linearization is not built "
            "yet; linearize it without them (scene.without('constraints'))"
        )
    hard = hard_settings.sections(scene)
    if hard:
        raise ValueError(
            f"linearize: scene {scene.name!r} has {next(iter(hard))}.model = \"hard\": its "
            "contacts, limits or friction are constraints solved at each step, a map with no "
            "derivative where a contact opens, closes or sticks; linearize it with the "
            "compliant model"
        )
    t = finite(as_real(t, "linearize: t"), "linearize: t")
    discrete = flag(discrete, "linearize: discrete")
    q = scene.q0.copy() if q is None else checked_configuration(model, q, "linearize: q")
    qd = scene.qd0.copy() if qd is None else checked_vector(model, qd, "linearize: qd")
    u = np.zeros(model.nv) if tau is None else checked_torque(model, tau, "linearize: tau")
    (tau_e, dtau_dq, dtau_dqd), armature = effect_forces(scene, t, q, qd)
    nv = model.nv
    ddq_dq, ddq_dqd, Minv = np.empty((3, nv, nv))
    work = model.data()._work
    loads = checks.loads(model, gravity_of(scene), None)
    status = aba_derivatives_kernel(
        model._ibuf,
        model._fbuf,
        work,
        (q, qd, tau_e + u),
        loads,
        armature,
        coupled_switch(model),
        ddq_dq,
        ddq_dqd,
        Minv,
    )
    if status:
        arguments = {"q": q, "qd": qd, "tau": tau_e + u}
        checks.raise_status(
            status, model, "linearize", "dqdd_dq", arguments, singular_mass_matrix
        )
    A = np.zeros((2 * nv, 2 * nv))
    A[:nv, nv:] = np.eye(nv)
    for i in np.flatnonzero(model.jtype == FREE):
        b = slice(model.iv[i], model.iv[i] + 6)
        A[b, b] = -ad(qd[b])
    A[nv:, :nv] = ddq_dq + Minv @ dtau_dq
    A[nv:, nv:] = ddq_dqd + Minv @ dtau_dqd
    B = np.zeros((2 * nv, len(model.v_index)))
    B[nv:] = Minv[:, model.v_index]
    if not discrete:
        return A, B
    n, m = A.shape[0], B.shape[1]
    blocks = np.zeros((n + m, n + m))
    blocks[:n, :n], blocks[:n, n:] = A, B
    E = scipy.linalg.expm(blocks * scene.run.dt)
    return E[:n, :n], E[:n, n:]
