"""A controller written in Python, sampled at a control rate with its torque held in between.

    tau_j(t) = fn(t_k, q(t_k), qd(t_k))_j     for t_k <= t < t_k + control_dt   (zero-order hold)

A scene names it as [control] type = "python", function = "FILE.py:NAME" (a path relative to the
scene file) or "MODULE:NAME" (an importable module), and optionally control_dt (s; default the
run's control_dt, else its dt). The function runs in Python between compiled stretches of the
run (opendyn.sim.simulator); the step adds the held torque as control torque (its work is put
in), through the held-torque row of step.SceneData.forces rather than a stage of its own: the
Simulator holds the sum of its caller's torque and the controller's there.
"""

from __future__ import annotations

import pathlib

import numpy as np

from .control import Control, of_kind
from .interface import CONTROL

NAME = "control"
SECTION = "control"
CONTROL_TYPE = "python"
KEYS = ("function", "control_dt")
FIELD = "control"
OFF = None
DOC = "python: fn(t, q, qd) -> tau, called every control_dt and held in between"
ENABLE = None
EXAMPLE = {"type": "python", "function": "math:cos", "control_dt": 0.01}
STAGE = None
ENERGY = CONTROL
DERIVATIVES = ()
Params = None  # the parameters are the held torque (nv,)
rates = None
apply = None


def record(scene) -> Control | None:
    return of_kind(scene, CONTROL_TYPE)


def read(r, table, q0) -> Control:
    """[control] type = "python": function (required), control_dt (optional, s, > 0)."""
    if "function" not in table:
        r.fail(
            "control.function",
            'missing: control type "python" needs function = "FILE.py:NAME" (a path relative '
            'to the scene file) or "MODULE:NAME"',
        )
    function = r.string(table["function"], "control.function")
    where, name = function_parts(function)
    if where is None:
        r.fail("control.function", NOT_A_FUNCTION.format(spec=function))
    if where.endswith(".py"):
        path = pathlib.Path(where)
        if not path.is_absolute() and getattr(r, "base_dir", None) is not None:
            path = pathlib.Path(r.base_dir) / path
        if not path.is_file():
            r.fail("control.function", f"no file {str(path)!r} (from {function!r})")
        r.files.append(path)
        function = f"{path.resolve()}:{name}"
    control_dt = None
    if "control_dt" in table:
        control_dt = r.number(table["control_dt"], "control.control_dt", positive=True)
    return Control(kind=CONTROL_TYPE, function=function, control_dt=control_dt)


NOT_A_FUNCTION = '{spec!r} is not "FILE.py:NAME" or "MODULE:NAME" (NAME: the function\'s name)'


def function_parts(spec) -> tuple[str | None, str | None]:
    """(where, name) of a function spec "FILE.py:NAME" or "MODULE:NAME" (the last colon
    splits, so a Windows path's drive stays in where); (None, None) when it is neither."""
    where, _, name = str(spec).rpartition(":")
    return (where, name) if where and name.isidentifier() else (None, None)


def pack(control, model) -> np.ndarray:
    """The held torque tau_held (nv,) N m or N, zero until the first control tick."""
    return held_torque(model)


def held_torque(model) -> np.ndarray:
    """A fresh zero held torque (nv,): what step.scene_data takes as `held`."""
    return np.zeros(model.nv)


def tangent(control, at):
    """A Python function has no derivative opendyn can take: a clear error."""
    raise ValueError(
        f"linearize: the scene's controller is the Python function {control.function!r}, "
        "whose derivatives opendyn cannot take; linearize the scene without it "
        "(scene.without('control')) and add your controller's own gains to A and B"
    )
