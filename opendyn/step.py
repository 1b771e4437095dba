"""One evaluation of the scene's dynamics: the stages it names, then forward dynamics.

    tau = sum over the stage table's rows of tau_e(t, q, qd)          (effects, control)
    qdd = (M(q) + diag(armature))^-1 (tau - c(q, qd) - g(q))         (forward dynamics, ABA)

with g(q) present only when the table has a gravity row (it sets dV_0 = (0, -g); without it the
base does not accelerate). With constraints A(q) qd = 0 the forward dynamics is instead

    (M + diag(armature)) qdd + A^T lambda = tau - c - g,
    A qdd = -(Adot qd + 2 alpha A qd + beta^2 phi)                  (Baumgarte gains alpha, beta)

(M by CRBA, the multipliers as in opendyn.dynamics.constraints). Alongside, the power of the
non-conservative forces for the energy balance dE/dt = qd . tau_applied + qd . tau_passive,
where E = T + U_gravity:
  applied = control torques and applied wrenches (work put in),
  passive = damping, friction and joint-limit spring-dampers (work taken out, mostly).

Only the rows of the table run: an effect the scene does not name costs nothing, not even a
multiplication by zero.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .dynamics._kernels import INLINE, JIT
from .dynamics.constraints import constrained_forward_kernel
from .dynamics.forward import forward_kernel
from .effects import (
    CLIP,
    COMPUTED_TORQUE,
    CONSTANT,
    DAMPING,
    FRICTION,
    GRAVITY,
    LIMITS,
    PD,
    WRENCH,
    clip_effect,
    computed_torque_effect,
    damping_effect,
    friction_effect,
    gravity_effect,
    limits_effect,
    pd_effect,
    wrench_effect,
)

# status codes beyond the dynamics kernels' (1 q, 2 qd, 4 tau not finite, 100 + k singular)
DIVERGED = 5  # |qd| beyond the run's max_speed


@njit(**INLINE)
def run_stage(
    ibuf, fbuf, row, params, armature, t, q, qd, dV_0, tau_ctrl, tau_app, tau_pas, K, D, jac
):
    """One row of the stage table: adds its generalized force to tau_ctrl (control), tau_app
    (applied wrenches) or tau_pas (passive effects), or sets dV_0 (gravity). Returns a status."""
    code, offset, count, body, flag = row[0], row[1], row[2], row[3], row[4]
    p = params[offset:]
    if code == GRAVITY:
        gravity_effect(p, dV_0)
    elif code == DAMPING:
        damping_effect(p, qd, tau_pas, D, jac)
    elif code == FRICTION:
        friction_effect(p, qd, tau_pas, D, jac)
    elif code == LIMITS:
        limits_effect(p, q, qd, tau_pas, K, D, jac)
    elif code == WRENCH:
        wrench_effect(ibuf, fbuf, p, count, body, flag == 1, t, q, tau_app)
    elif code == CONSTANT:
        for j in range(q.shape[0]):
            tau_ctrl[j] += p[j]
    elif code == PD:
        pd_effect(p, q, qd, tau_ctrl, K, D, jac)
    elif code == COMPUTED_TORQUE:
        return computed_torque_effect(ibuf, fbuf, p, t, q, qd, dV_0, armature, tau_ctrl)
    elif code == CLIP:
        clip_effect(p, tau_ctrl)
    return 0


@njit(**INLINE)
def generalized_forces(
    ibuf, fbuf, rows, params, armature, t, q, qd, dV_0, tau, tau_ctrl, power, K, D, jac
):
    """Run every stage: tau (nv,) <- the total generalized force of the effects, tau_ctrl (nv,)
    <- the control's share, dV_0 (6,) <- the base acceleration, power (2,) <- (applied, passive)
    power qd . tau_applied and qd . tau_passive (W). With jac, K and D (nv,) <- the diagonal
    stiffness -d tau/dq and damping -d tau/dqd of the joint-space effects. Returns a status."""
    nv = q.shape[0]
    tau_app = np.zeros(nv)
    tau_pas = np.zeros(nv)
    tau_ctrl[:] = 0.0
    dV_0[:] = 0.0
    if jac:
        K[:] = 0.0
        D[:] = 0.0
    for s in range(rows.shape[0]):
        status = run_stage(
            ibuf,
            fbuf,
            rows[s],
            params,
            armature,
            t,
            q,
            qd,
            dV_0,
            tau_ctrl,
            tau_app,
            tau_pas,
            K,
            D,
            jac,
        )
        if status:
            return status
    applied = 0.0
    passive = 0.0
    for j in range(nv):
        applied += qd[j] * (tau_ctrl[j] + tau_app[j])
        passive += qd[j] * tau_pas[j]
        tau[j] = tau_ctrl[j] + tau_app[j] + tau_pas[j]
    power[0] = applied
    power[1] = passive
    return 0


@njit(**INLINE)
def explicit_forces(ibuf, fbuf, rows, params, armature, t, q, qd, loads, tau, tau_ctrl, power):
    """generalized_forces without the stiffness and damping diagonals (for steps that treat every
    effect explicitly): tau, tau_ctrl (nv,), loads[0] <- dV_0, power (2,). Returns a status."""
    unused = np.empty(0)
    return generalized_forces(
        ibuf,
        fbuf,
        rows,
        params,
        armature,
        t,
        q,
        qd,
        loads[0],
        tau,
        tau_ctrl,
        power,
        unused,
        unused,
        False,
    )


@njit(**JIT)
def dynamics(ibuf, fbuf, q, qd, tau, loads, qdd, method, armature, con):
    """qdd (nv,) <- forward dynamics under tau (nv,) and the base acceleration loads[0]: ABA or
    CRBA (`method`) without constraints (con None), the constrained solve with them. Compiled
    apart for each: the test on None is decided when it compiles."""
    if con is None:
        return forward_kernel(ibuf, fbuf, q, qd, tau, loads, qdd, method, armature)
    rows, cparams, gains = con
    lam = np.empty(rows[:, 2].sum())
    return constrained_forward_kernel(
        ibuf, fbuf, rows, cparams, gains, q, qd, tau, loads, armature, qdd, lam
    )


def scene_data(model, table):
    """The scene as the compiled step takes it: one tuple (ibuf, fbuf, rows, params, method,
    armature, con) of the model's buffers and the stage table (effects.StageTable); con is the
    table's constraints, None without."""
    return (
        model._ibuf,
        model._fbuf,
        table.rows,
        table.params,
        table.method,
        table.armature,
        table.constraints,
    )


@njit(**INLINE)
def evaluate(scene, t, q, qd, qdd, tau_ctrl, power):
    """qdd (nv,) <- the scene's forward dynamics at (t, q, qd); tau_ctrl (nv,) <- the control
    torque; power (2,) <- (applied, passive) power. scene: scene_data(model, table).
    Returns 0, or the dynamics' status code."""
    ibuf, fbuf, rows, params, method, armature, con = scene
    tau = np.empty(q.shape[0])
    loads = np.empty((1, 6))
    status = explicit_forces(
        ibuf, fbuf, rows, params, armature, t, q, qd, loads, tau, tau_ctrl, power
    )
    if status:
        return status
    return dynamics(ibuf, fbuf, q, qd, tau, loads, qdd, method, armature, con)


@njit(**JIT)
def stage_cost_kernel(scene, which, t, q, qd):
    """Run one part of the step at every state (t[n], q[n], qd[n]), for timing it:
    which >= 0 the stage table's row `which`, -1 forward dynamics alone (with the table's
    gravity, zero torque), -2 the whole evaluation. scene: scene_data(model, table).
    Returns a checksum of the outputs."""
    ibuf, fbuf, rows, params, method, armature, con = scene
    nv = q.shape[1]
    tau_ctrl = np.empty(nv)
    tau_app = np.empty(nv)
    tau_pas = np.empty(nv)
    qdd = np.empty(nv)
    power = np.empty(2)
    loads = np.zeros((1, 6))
    unused = np.empty(0)
    for s in range(rows.shape[0]):
        if rows[s, 0] == GRAVITY:
            gravity_effect(params[rows[s, 1] :], loads[0])
    total = 0.0
    for n in range(q.shape[0]):
        if which >= 0:
            tau_ctrl[:] = 0.0
            tau_app[:] = 0.0
            tau_pas[:] = 0.0
            run_stage(
                ibuf,
                fbuf,
                rows[which],
                params,
                armature,
                t[n],
                q[n],
                qd[n],
                loads[0],
                tau_ctrl,
                tau_app,
                tau_pas,
                unused,
                unused,
                False,
            )
            for j in range(nv):
                total += tau_ctrl[j] + tau_app[j] + tau_pas[j]
        elif which == -1:
            tau_ctrl[:] = 0.0
            dynamics(ibuf, fbuf, q[n], qd[n], tau_ctrl, loads, qdd, method, armature, con)
            total += qdd.sum()
        else:
            evaluate(scene, t[n], q[n], qd[n], qdd, tau_ctrl, power)
            total += qdd.sum()
    return total
