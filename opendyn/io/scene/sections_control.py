"""[control]: the joint-space controller a scene names, read into a Control record. Its types
are the control laws of opendyn.sim.effects.registry (constant, pd, computed_torque), each of
which reads and checks its own keys; the keys of every type (clip) are effects of their own.
type = "none", or no [control], is zero torque."""

from __future__ import annotations

import dataclasses

from ...sim.effects import registry
from ...sim.effects.control import Control
from ...sim.values import ValueReader


def _laws():
    """{type: module} of the control laws, and the modules of the keys every type takes."""
    in_control = registry.in_section("control")
    laws = {effect.CONTROL_TYPE: effect for effect in in_control if effect.CONTROL_TYPE}
    return laws, tuple(effect for effect in in_control if not effect.CONTROL_TYPE)


def _keys_by_type(laws, shared) -> dict:
    """{control type: the keys it takes}: type, the law's own keys, and the shared ones."""
    every = tuple(key for effect in shared for key in effect.KEYS)
    keys = {"none": ("type",)}
    keys.update({kind: ("type", *law.KEYS, *every) for kind, law in laws.items()})
    return keys


def control_keys() -> tuple[str, ...]:
    """Every key [control] takes, over all its types."""
    keys = _keys_by_type(*_laws()).values()
    return tuple(dict.fromkeys(key for of_type in keys for key in of_type))


class ControlSection(ValueReader):
    """Reads [control] into a Control."""

    def control(self, table, q0) -> Control | None:
        if table is None:
            return None
        self.table(table, "control")
        laws, shared = _laws()
        keys = _keys_by_type(laws, shared)
        kind = self.string(table.get("type", "none"), "control.type", tuple(keys))
        for k in table:
            owners = [t for t, valid in keys.items() if k in valid]
            if owners and kind not in owners:
                self.fail(
                    f"control.{k}",
                    f"not a setting of control type {kind!r} (its keys: "
                    f"{', '.join(keys[kind])}); {k} belongs to type "
                    f"{' or '.join(repr(t) for t in owners)}",
                )
        self.keys(table, "control", keys[kind])
        if kind == "none":
            return None
        self.joints_needed("control.type", f"a {kind!r} controller of the joints")
        settings = {effect.KEYS[0]: effect.read(self, table) for effect in shared}
        return dataclasses.replace(laws[kind].read(self, table, q0), **settings)
