"""The [control] section's record, which the control laws (constant, pd, computed_torque,
python) and clip share, and the checks of a law's per-joint keys. A scene names one law, its `type`; the
laws and clip are effects of their own, all named "control" in a scene."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, eq=False)
class Control:
    """A joint-space controller; fields that its kind does not use are None.

    kind: "constant", "pd", "computed_torque" or "python"; every array has one entry per joint (n,), in
    model.joint_names order. tau: N m or N (constant). kp, kd: gains (pd, computed_torque).
    setpoint: rad or m (pd: tau = kp (setpoint - q) - kd qd).
    offset, amplitude: rad or m; frequency: Hz; phase: rad (computed_torque
    reference q_r(t) = offset + amplitude sin(2 pi frequency t + phase)). function: "FILE.py:NAME"
    (an absolute path) or "MODULE:NAME", and control_dt: s or None (python: a function
    fn(t, q, qd) -> tau called every control_dt, its torque held in between). clip: clip the
    torque to +-model.effort_limit.
    """

    kind: str
    tau: np.ndarray | None = None
    kp: np.ndarray | None = None
    kd: np.ndarray | None = None
    setpoint: np.ndarray | None = None
    offset: np.ndarray | None = None
    amplitude: np.ndarray | None = None
    frequency: np.ndarray | None = None
    phase: np.ndarray | None = None
    function: str | None = None
    control_dt: float | None = None
    clip: bool = False


def of_kind(scene, kind) -> Control | None:
    """The scene's Control when its law is `kind`, else None."""
    control = scene.control
    return control if control is not None and control.kind == kind else None


def required(r, table, kind, field, minimum=None) -> np.ndarray:
    """(n,) the per-joint key `field` of control type `kind`, which must be given."""
    n = len(r.model.joint_names)
    if field not in table:
        r.fail(
            f"control.{field}",
            f"missing: control type {kind!r} needs {field} (a number, a list of "
            f"{n} or a table {{joint = number}})",
        )
    return r.per_joint(table[field], f"control.{field}", np.zeros(n), minimum=minimum)


def optional(r, table, field, default, minimum=None) -> np.ndarray:
    """(n,) the per-joint key `field`, `default` where absent."""
    return r.per_joint(table.get(field), f"control.{field}", default, minimum=minimum)
