"""Constant control torque at the joints.

    tau_j = tau_0,k                                    tau_0 (n,) N m or N

at joint k's velocity j = iv_k. Control: its work is put in, and it is the record's control
torque.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np

from numba import njit

from ..._runtime.kernel_cache import JIT
from .control import Control, of_kind, required
from .interface import CONTROL, OK, floats, v_indices

NAME = "control"
SECTION = "control"
CONTROL_TYPE = "constant"
KEYS = ("tau",)
FIELD = "control"
OFF = None
DOC = "constant"
ENABLE = None
EXAMPLE = {"type": "constant", "tau": [3.0, -1.0]}
STAGE = "control (constant)"
ENERGY = CONTROL
DERIVATIVES = ()
rates = None

# tau_0 (n,) the torques; iv (n,) int64 each joint's velocity index
Params = namedtuple("Params", ("tau_0", "iv"))


def record(scene) -> Control | None:
    return of_kind(scene, CONTROL_TYPE)


def read(r, table, q0) -> Control:
    """[control] type = "constant": tau (required)."""
    return Control(kind=CONTROL_TYPE, tau=required(r, table, CONTROL_TYPE, "tau"))


def pack(control, model) -> Params:
    return Params(floats(control.tau), v_indices(model))


@njit(**JIT)
def apply(p, ctx, out):
    """out.control_j += tau_0k at each joint's velocity j = iv_k. p: Params, or None.
    Returns a Status."""
    if p is None:
        return OK
    for k in range(p.iv.shape[0]):
        out.control[p.iv[k]] += p.tau_0[k]
    return OK


def tangent(control, at):
    """(tau, 0, 0): the constant torques, which depend on nothing."""
    nv = at.qd.shape[0]
    tau = np.zeros(nv)
    tau[v_indices(at.scene.model)] = control.tau
    return tau, np.zeros((nv, nv)), np.zeros((nv, nv))
