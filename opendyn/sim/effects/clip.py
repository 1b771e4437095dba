"""The control torque clipped to the URDF's effort limits (clip = true, any control type).

    tau_control,j <- clip(tau_control,j, -limit_k, limit_k)   limit (n,) N m or N, +inf where
                                                               the URDF gives none
at joint k's velocity j = iv_k. It runs after the control law. Control.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit

from ..._runtime.kernel_cache import JIT
from .control import Control
from .interface import CONTROL, OK, floats, v_indices

NAME = "control"
SECTION = "control"
CONTROL_TYPE = None  # a key of every control type
KEYS = ("clip",)
FIELD = "control"
OFF = None
DOC = "clipped to +-effort_limit with clip = true"
ENABLE = None
EXAMPLE = {"type": "constant", "tau": [80.0, -30.0], "clip": True}
STAGE = "clip"
ENERGY = CONTROL
DERIVATIVES = ()
rates = None

# limit (n,) the effort limits; iv (n,) int64 each joint's velocity index
Params = namedtuple("Params", ("limit", "iv"))


def record(scene) -> Control | None:
    control = scene.control
    return control if control is not None and control.clip else None


def read(r, table) -> bool:
    """[control] clip (default false): refused on a robot without a finite effort limit."""
    clip = r.boolean(table.get("clip", False), "control.clip")
    if clip and not np.isfinite(r.model.effort_limit).any():
        r.fail(
            "control.clip",
            f"no joint of {r.model.name!r} has a finite effort limit (<limit effort>) to clip "
            f"to; set clip = false",
        )
    return clip


def pack(control, model) -> Params:
    return Params(floats(model.effort_limit), v_indices(model))


@njit(**JIT)
def apply(p, ctx, out):
    """out.control_j <- clip(out.control_j, -limit_k, limit_k) at each joint's velocity
    j = iv_k. p: Params, or None. Returns a Status."""
    if p is None:
        return OK
    for k in range(p.iv.shape[0]):
        j = p.iv[k]
        out.control[j] = min(max(out.control[j], -p.limit[k]), p.limit[k])
    return OK


def tangent(control, at):
    """The change clipping makes to the control laws' torque and derivatives so far
    (at.control): where |tau_j| exceeds the limit, tau_j becomes +-limit and its derivatives
    0."""
    tau, dtau_dq, dtau_dqd = at.control
    limit = np.full(tau.shape[0], np.inf)
    limit[v_indices(at.scene.model)] = at.scene.model.effort_limit
    clipped = np.abs(tau) > limit
    change = np.zeros_like(tau)
    change[clipped] = np.sign(tau[clipped]) * limit[clipped] - tau[clipped]
    return change, -dtau_dq * clipped[:, None], -dtau_dqd * clipped[:, None]
