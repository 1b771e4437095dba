"""Armature: rotor inertias on the joints' diagonal of the mass matrix.

    M(q) -> M(q) + diag(I_a)                          I_a (n,) kg m^2 or kg, >= 0

Armature is not a force but a change of M, which forward dynamics (and computed torque, which
drives the joints through it) reads from the StageTable: it has no stage. Its kinetic energy
1/2 I_a qd^2 is in E: conservative.
"""

from __future__ import annotations

import numpy as np

from .interface import CONSERVATIVE

NAME = "armature"
SECTION = "effects"
JOINTS = True  # acts on the joint coordinates only: a robot without joints refuses it
KEYS = ("values",)
FIELD = "armature"
OFF = None
DOC = "M + diag(I_a) in forward dynamics"
ENABLE = None
EXAMPLE = {"values": 0.01}
STAGE = None
ENERGY = CONSERVATIVE
DERIVATIVES = ()
Params = None  # the parameters are the (nv,) diagonal
rates = None
apply = None


def record(scene) -> np.ndarray | None:
    return scene.armature


def read(r, table) -> np.ndarray | None:
    """[effects.armature] values (required): a number, a list or {joint = kg m^2}."""
    if table is None:
        return None
    key = "effects.armature"
    r.keys(table, key, KEYS)
    if "values" not in table:
        r.fail(f"{key}.values", "missing: give a number, a list or a table {joint = kg m^2}")
    return r.per_joint(
        table["values"], f"{key}.values", np.zeros(len(r.model.joint_names)), minimum=0.0
    )


def pack(values, model) -> np.ndarray:
    """(nv,) the rotor inertias in velocity space: zero on a floating base's rows."""
    out = np.zeros(model.nv)
    out[model.v_index] = values
    return out


tangent = None  # armature changes M, not tau
