"""Computed-torque control: the joint torques that give the joints a reference's acceleration
plus PD feedback, from the scene's own model (rigid bodies, gravity and armature).

    qdd_c = qdd_r + kp (q_r - q) + kd (qd_r - qd),
    q_r(t) = offset + amplitude sin(w t + phase),  w = 2 pi frequency

      fixed base      tau = M(q) qdd_c + h(q, qd) + armature qdd_c          (RNEA)
      floating base   tau_j = M_jb a_b + M_jj qdd_c + h_j + armature qdd_c,
                      a_b = -M_bb^-1 (M_bj qdd_c + h_b): the acceleration of the unactuated
                      base under those torques (base_reaction)

(joint k's position q[iq_k], velocity qd[iv_k]; kp, kd (n,); offset, amplitude rad or m,
frequency Hz, phase rad). Control: its work is put in, and it is the record's control torque.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit

from ..._runtime.arrays import fill, shaped
from ..._runtime.kernel_cache import JIT
from ...algorithm.cholesky import cholesky_solve
from ...algorithm.crba import crba_on_poses
from ...algorithm.rnea import rnea_on_poses
from ...multibody.layout import body_count
from ...multibody.work_views import effect_rows, mass_matrix_field, scratch_rows
from .control import Control, of_kind, optional, required
from .interface import CONTROL, OK, floats, q_indices, v_indices

NAME = "control"
SECTION = "control"
CONTROL_TYPE = "computed_torque"
KEYS = ("kp", "kd", "offset", "amplitude", "frequency", "phase")
FIELD = "control"
OFF = None
DOC = "computed torque M (qdd_r + kd e' + kp e) + h by RNEA (on the joints)"
ENABLE = None
EXAMPLE = {"type": "computed_torque", "kp": 5.0, "kd": 1.0, "amplitude": 0.3}
STAGE = "control (computed torque)"
ENERGY = CONTROL
DERIVATIVES = ()
rates = None

# each (n,): the gains kp, kd and the reference's offset, amplitude, frequency, phase; iq, iv
# int64 the joints' indices; floating None for a fixed base, True for a floating one (a
# compile-time switch: a fixed-base scene does not compile base_reaction's body)
Params = namedtuple(
    "Params",
    ("kp", "kd", "offset", "amplitude", "frequency", "phase", "iq", "iv", "floating"),
)


def record(scene) -> Control | None:
    return of_kind(scene, CONTROL_TYPE)


def read(r, table, q0) -> Control:
    """[control] type = "computed_torque": kp, kd (required, >= 0); offset (default q0),
    amplitude (0), frequency (0.5 Hz, >= 0), phase (0)."""
    zeros = np.zeros(len(r.model.joint_names))
    kp = required(r, table, CONTROL_TYPE, "kp", 0.0)
    kd = required(r, table, CONTROL_TYPE, "kd", 0.0)
    return Control(
        kind=CONTROL_TYPE,
        kp=kp,
        kd=kd,
        offset=optional(r, table, "offset", q0),
        amplitude=optional(r, table, "amplitude", zeros),
        frequency=optional(r, table, "frequency", np.full(len(zeros), 0.5), 0.0),
        phase=optional(r, table, "phase", zeros),
    )


def pack(control, model) -> Params:
    return Params(
        floats(control.kp),
        floats(control.kd),
        floats(control.offset),
        floats(control.amplitude),
        floats(control.frequency),
        floats(control.phase),
        q_indices(model),
        v_indices(model),
        True if model.floating_base else None,
    )


@njit(**JIT)
def base_reaction(floating, ctx, tau_c):
    """A floating base is unactuated: given tau_c (nv,) = RNEA(q, qd, (0, qdd_c)) = M_{:,j} qdd_c
    + h, the base accelerates with a_b = -M_bb^-1 tau_c[:6] (its rows of M a + h vanish), and
    the joints need tau_j = tau_c[j] + M_jb a_b. tau_c <- (0, tau_j). floating None (a fixed
    base): nothing. Works in ctx.work: M in its mass-matrix field, M_bb (6, 6), -h_b and a_b
    (6,) in its scratch rows. Returns a Status (SINGULAR when the whole body has no
    inertia)."""
    if floating is None:
        return OK
    nv = tau_c.shape[0]
    nb = body_count(ctx.ibuf)
    M = mass_matrix_field(ctx.work, nb, nv)
    crba_on_poses(ctx.ibuf, ctx.fbuf, ctx.work, M)
    s = scratch_rows(ctx.work, nb, nv)
    M_bb, minus_h_b, a_b = s[:6], s[6], s[7]
    for r in range(6):
        minus_h_b[r] = -tau_c[r]
        for c in range(6):
            M_bb[r, c] = M[r, c]
    status = cholesky_solve(M_bb, minus_h_b, a_b)
    if status:
        return status
    for r in range(6):
        tau_c[r] = 0.0
    for j in range(6, nv):
        for c in range(6):
            tau_c[j] += M[j, c] * a_b[c]
    return OK


@njit(**JIT)
def apply(p, ctx, out):
    """out.control += the computed torques (module docstring) at each joint's velocity. p:
    Params, or None. Works in ctx.work (qdd_c and tau_c in its effect rows, and RNEA's and
    CRBA's fields), allocating nothing. Returns a Status."""
    if p is None:
        return OK
    q, qd, t = ctx.q, ctx.qd, ctx.t
    nv = qd.shape[0]
    rows = effect_rows(ctx.work, body_count(ctx.ibuf), nv)
    qdd_c, tau_c = rows[0], rows[1]
    fill(qdd_c, 0.0)  # the base's rows stay 0 in the RNEA call
    for k in range(p.iv.shape[0]):
        i, j = p.iq[k], p.iv[k]
        w = 2.0 * np.pi * p.frequency[k]
        a, phase = p.amplitude[k], p.phase[k]
        s, c = np.sin(w * t + phase), np.cos(w * t + phase)
        q_r = p.offset[k] + a * s
        qd_r = a * w * c
        qdd_r = -a * w * w * s
        qdd_c[j] = qdd_r + p.kp[k] * (q_r - q[i]) + p.kd[k] * (qd_r - qd[j])
    loads = shaped(ctx.dV_0, (1, 6))  # dV_0 = (0, -g) as RNEA's loads, a view
    status = rnea_on_poses(ctx.ibuf, ctx.fbuf, ctx.work, qd, qdd_c, loads, tau_c)
    if status:
        return status
    status = base_reaction(p.floating, ctx, tau_c)
    if status:
        return status
    for k in range(p.iv.shape[0]):
        j = p.iv[k]
        out.control[j] += tau_c[j]
        if ctx.armature.shape[0]:
            out.control[j] += ctx.armature[j] * qdd_c[j]
    return OK


def tangent(control, at):
    """(tau, dtau_dq, dtau_dqd) of the computed torques, exactly: with qdd_c's slopes -kp and
    -kd on the joints and y = (a_b, qdd_c) (a_b = 0 for a fixed base),
        tau = ID(q, qd, y) + armature qdd_c,
        dtau/dq = dID/dq + (M + diag(armature)) dy/dq     (likewise in qd),
    where on a floating base a_b keeps ID's base rows at zero:
        da_b/dq = -M_bb^-1 (dID_b/dq + M_bj dqdd_c/dq)."""
    from ...algorithm.crba import mass_matrix
    from ...algorithm.rnea import inverse_dynamics
    from ...algorithm.rnea_derivatives import inverse_dynamics_derivatives

    model, t = at.scene.model, at.t
    nv, iq, iv = model.nv, q_indices(model), v_indices(model)
    w = 2.0 * np.pi * control.frequency
    s, c = np.sin(w * t + control.phase), np.cos(w * t + control.phase)
    q_r, qd_r = control.offset + control.amplitude * s, control.amplitude * w * c
    qdd_r = -control.amplitude * w * w * s
    y = np.zeros(nv)
    y[iv] = qdd_r + control.kp * (q_r - at.q[iq]) + control.kd * (qd_r - at.qd[iv])
    dy_dq, dy_dqd = np.zeros((nv, nv)), np.zeros((nv, nv))
    dy_dq[iv, iv], dy_dqd[iv, iv] = -control.kp, -control.kd
    if model.floating_base:
        b = slice(0, 6)
        M = mass_matrix(model, at.q)
        h_b = inverse_dynamics(model, at.q, at.qd, y, gravity=at.gravity)[b]  # y_b = 0 here
        y[b] = -np.linalg.solve(M[b, b], h_b)
    dID_dq, dID_dqd, M = inverse_dynamics_derivatives(model, at.q, at.qd, y, gravity=at.gravity)
    if model.floating_base:
        dy_dq[b] = -np.linalg.solve(M[b, b], dID_dq[b] + M[b] @ dy_dq)
        dy_dqd[b] = -np.linalg.solve(M[b, b], dID_dqd[b] + M[b] @ dy_dqd)
    M_a = M + np.diag(at.armature)
    tau = inverse_dynamics(model, at.q, at.qd, y, gravity=at.gravity) + at.armature * y
    dtau_dq = dID_dq + M_a @ dy_dq
    dtau_dqd = dID_dqd + M_a @ dy_dqd
    joints = np.zeros(nv, dtype=bool)
    joints[iv] = True
    return tau * joints, dtau_dq * joints[:, None], dtau_dqd * joints[:, None]
