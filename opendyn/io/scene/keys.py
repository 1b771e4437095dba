"""Every key a scene file takes, by its dotted name, from the very tuples the section readers
check a file against: the scene file reference (the documentation's page, the command line's
suggestions) cannot miss one that the reader takes."""

from __future__ import annotations

from ...sim.effects import contact, geometry_contact, registry
from .reader import TOP_KEYS
from .sections_constraints import BAUMGARTE_KEYS, CONSTRAINT_KEYS
from .sections_control import control_keys
from .sections_robot import INITIAL_KEYS, PAYLOAD_KEYS, ROBOT_KEYS
from .sections_world import OBJECT_KEYS, WORLD_KEYS
from ...sim.run import RUN_KEYS

# the tables of tables: their keys are listed under their own dotted names
_TABLES = (
    "robot", "initial", "run", "effects", "control", "constraints", "baumgarte", "objects",
    "world",
)


def scene_keys() -> tuple[str, ...]:
    """The dotted name of every key of a scene file, in the file's order: `name`,
    `robot.urdf`, `robot.payload.mass`, ..., `effects.contact.points.radius`, `control.kp`,
    `constraints.frame_a`, `baumgarte.alpha`. A table's name is listed before its keys; the
    keys of arrays of tables (`[[effects.wrench]]`, `[[constraints]]`) under the array's
    name."""
    keys = [k for k in TOP_KEYS if k not in _TABLES]
    keys += ["robot", *(f"robot.{k}" for k in ROBOT_KEYS if k != "payload")]
    keys += ["robot.payload", *(f"robot.payload.{k}" for k in PAYLOAD_KEYS)]
    keys += ["objects", *(f"objects.{k}" for k in OBJECT_KEYS)]
    keys += ["world", *(f"world.{k}" for k in WORLD_KEYS)]
    keys += ["initial", *(f"initial.{k}" for k in INITIAL_KEYS)]
    keys += ["run", *(f"run.{k}" for k in RUN_KEYS)]
    keys.append("effects")
    for effect in registry.in_section("effects"):
        name = f"effects.{effect.NAME}"
        keys.append(name)
        keys += [f"{name}.{k}" for k in effect.KEYS]
        if effect is contact:
            keys += [f"{name}.points.{k}" for k in contact.POINT_KEYS]
        if effect is geometry_contact:
            keys += [f"{name}.pairs.{k}" for k in geometry_contact.PAIR_KEYS]
    keys += ["control", *(f"control.{k}" for k in control_keys())]
    constraint_keys = dict.fromkeys(k for kind in CONSTRAINT_KEYS.values() for k in kind)
    keys += ["constraints", *(f"constraints.{k}" for k in constraint_keys)]
    keys += ["baumgarte", *(f"baumgarte.{k}" for k in BAUMGARTE_KEYS)]
    return tuple(dict.fromkeys(keys))
