"""PD control at the joints, about a setpoint.

    tau_j = kp (q_set - q_i) - kd qd_j,   K_jj += kp, D_jj += kd

at joint k's coordinates i = iq_k, j = iv_k; kp, kd (n,), q_set (n,) rad or m (default q0).
Control: its work is put in, and it is the record's control torque.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit

from ..._runtime.kernel_cache import JIT
from .control import Control, of_kind, optional, required
from .interface import CONTROL, OK, floats, joint_labels, q_indices, v_indices

NAME = "control"
SECTION = "control"
CONTROL_TYPE = "pd"
KEYS = ("kp", "kd", "setpoint")
FIELD = "control"
OFF = None
DOC = "PD kp (q* - q) - kd qd"
ENABLE = None
EXAMPLE = {"type": "pd", "kp": 5.0, "kd": 1.0}
STAGE = "control (pd)"
ENERGY = CONTROL
DERIVATIVES = ("K", "D")

# each (n,): the gains kp, kd and the setpoint q_set; iq, iv int64 the joints' indices
Params = namedtuple("Params", ("kp", "kd", "q_set", "iq", "iv"))


def record(scene) -> Control | None:
    return of_kind(scene, CONTROL_TYPE)


def read(r, table, q0) -> Control:
    """[control] type = "pd": kp, kd (required, >= 0), setpoint (default q0)."""
    kp = required(r, table, CONTROL_TYPE, "kp", 0.0)
    kd = required(r, table, CONTROL_TYPE, "kd", 0.0)
    return Control(kind=CONTROL_TYPE, kp=kp, kd=kd, setpoint=optional(r, table, "setpoint", q0))


def pack(control, model) -> Params:
    return Params(
        floats(control.kp),
        floats(control.kd),
        floats(control.setpoint),
        q_indices(model),
        v_indices(model),
    )


@njit(**JIT)
def apply(p, ctx, out):
    """out.control_j += kp (q_set - q_i) - kd qd_j; with out.jac, out.K_jj += kp,
    out.D_jj += kd, with i = iq_k, j = iv_k joint k's coordinates. p: Params, or None.
    Returns a Status."""
    if p is None:
        return OK
    for k in range(p.iv.shape[0]):
        i, j = p.iq[k], p.iv[k]
        out.control[j] += p.kp[k] * (p.q_set[k] - ctx.q[i]) - p.kd[k] * ctx.qd[j]
        if out.jac:
            out.K[j, j] += p.kp[k]
            out.D[j, j] += p.kd[k]
    return OK


def rates(control, at):
    """Each joint's natural frequency sqrt(kp / M_jj) and damping rate kd / M_jj (1/s)."""
    joints = joint_labels(at.scene.model)
    return [
        ("PD stiffness", np.sqrt(control.kp / at.joint_mass), joints),
        ("PD damping", control.kd / at.joint_mass, joints),
    ]


def tangent(control, at):
    """(tau, dtau_dq, dtau_dqd): kp (q_set - q) - kd qd at the joints, slopes -kp and -kd."""
    model = at.scene.model
    nv, iq, iv = model.nv, q_indices(model), v_indices(model)
    tau, dtau_dq, dtau_dqd = np.zeros(nv), np.zeros((nv, nv)), np.zeros((nv, nv))
    tau[iv] = control.kp * (control.setpoint - at.q[iq]) - control.kd * at.qd[iv]
    dtau_dq[iv, iv] = -control.kp
    dtau_dqd[iv, iv] = -control.kd
    return tau, dtau_dq, dtau_dqd
