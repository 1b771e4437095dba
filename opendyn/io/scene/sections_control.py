"""[control]: the joint-space controller a scene names (constant, pd or computed_torque), read
into a Control record; type = "none", or no [control], is zero torque."""

from __future__ import annotations

import numpy as np

from .schema import Control
from .values import ValueReader

CONTROL_TYPES = ("none", "constant", "pd", "computed_torque")
_CONTROL_KEYS = {
    "none": ("type",),
    "constant": ("type", "tau", "clip"),
    "pd": ("type", "kp", "kd", "setpoint", "clip"),
    "computed_torque": (
        "type",
        "kp",
        "kd",
        "offset",
        "amplitude",
        "frequency",
        "phase",
        "clip",
    ),
}


class ControlSection(ValueReader):
    """Reads [control] into a Control."""

    def control(self, table, q0) -> Control | None:
        if table is None:
            return None
        self.table(table, "control")
        kind = self.string(table.get("type", "none"), "control.type", CONTROL_TYPES)
        for k in table:
            owners = [t for t, keys in _CONTROL_KEYS.items() if k in keys]
            if owners and kind not in owners:
                self.fail(
                    f"control.{k}",
                    f"not a setting of control type {kind!r} (its keys: "
                    f"{', '.join(_CONTROL_KEYS[kind])}); {k} belongs to type "
                    f"{' or '.join(repr(t) for t in owners)}",
                )
        self.keys(table, "control", _CONTROL_KEYS[kind])
        if kind == "none":
            return None
        m = self.model
        zeros = np.zeros(len(m.joint_names))
        clip = self.boolean(table.get("clip", False), "control.clip")
        if clip and not np.isfinite(m.effort_limit).any():
            self.fail(
                "control.clip",
                f"no joint of {m.name!r} has a finite effort limit (<limit effort>) to clip to; "
                f"set clip = false",
            )

        def required(field, minimum=None):
            if field not in table:
                self.fail(
                    f"control.{field}",
                    f"missing: control type {kind!r} needs {field} (a number, a list of "
                    f"{len(m.joint_names)} or a table {{joint = number}})",
                )
            return self.per_joint(table[field], f"control.{field}", zeros, minimum=minimum)

        def optional(field, default, minimum=None):
            return self.per_joint(table.get(field), f"control.{field}", default, minimum=minimum)

        if kind == "constant":
            return Control(kind=kind, tau=required("tau"), clip=clip)
        kp, kd = required("kp", 0.0), required("kd", 0.0)
        if kind == "pd":
            return Control(kind=kind, kp=kp, kd=kd, setpoint=optional("setpoint", q0), clip=clip)
        return Control(
            kind=kind,
            kp=kp,
            kd=kd,
            offset=optional("offset", q0),
            amplitude=optional("amplitude", zeros),
            frequency=optional("frequency", np.full(len(m.joint_names), 0.5), 0.0),
            phase=optional("phase", zeros),
            clip=clip,
        )
