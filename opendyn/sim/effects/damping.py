"""Viscous damping at the joints.

    tau_j = -b_k qd_j,   D_jj += b_k                  b (n,) N m s/rad or N s/m, >= 0

at joint k's velocity j = iv_k. Passive: it takes energy out at the rate qd^T diag(b) qd.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit

from ..._runtime.kernel_cache import JIT
from .interface import OK, PASSIVE, floats, joint_labels, v_indices

NAME = "damping"
SECTION = "effects"
JOINTS = True  # acts on the joint coordinates only: a robot without joints refuses it
KEYS = ("coefficients",)
FIELD = "damping"
OFF = None
DOC = "-b qd"
ENABLE = {}  # coefficients = "urdf": <dynamics damping>
EXAMPLE = {"coefficients": 0.3}
STAGE = "damping"
ENERGY = PASSIVE
DERIVATIVES = ("D",)

# b (n,) the coefficients; iv (n,) int64 each joint's velocity index
Params = namedtuple("Params", ("b", "iv"))


def record(scene) -> np.ndarray | None:
    return scene.damping


def read(r, table) -> np.ndarray | None:
    """[effects.damping] coefficients: "urdf" (default), a number, a list or {joint = b}."""
    if table is None:
        return None
    key = "effects.damping"
    r.keys(table, key, KEYS)
    return r.coefficients(table, key, "coefficients", r.model.damping, "damping")


def pack(b, model) -> Params:
    return Params(floats(b), v_indices(model))


@njit(**JIT)
def apply(p, ctx, out):
    """out.passive_j -= b_k qd_j; with out.jac, out.D_jj += b_k, at each joint's velocity
    j = iv_k. p: Params, or None (no damping). Returns a Status."""
    if p is None:
        return OK
    for k in range(p.b.shape[0]):
        j = p.iv[k]
        out.passive[j] -= p.b[k] * ctx.qd[j]
        if out.jac:
            out.D[j, j] += p.b[k]
    return OK


def rates(b, at):
    """The damping rate b / M_jj of each joint (1/s)."""
    return [("viscous damping", b / at.joint_mass, joint_labels(at.scene.model))]


def tangent(b, at):
    """(tau, dtau_dq, dtau_dqd): -b_k qd_j and its slope -b_k at each joint's velocity j."""
    nv, iv = at.qd.shape[0], v_indices(at.scene.model)
    tau, dtau_dqd = np.zeros(nv), np.zeros((nv, nv))
    tau[iv] = -b * at.qd[iv]
    dtau_dqd[iv, iv] = -b
    return tau, np.zeros((nv, nv)), dtau_dqd
