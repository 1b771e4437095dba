"""The effects opendyn knows: ONE ordered tuple of modules, each of which declares everything
about its effect (what, opendyn.sim.effects.interface lists).

EFFECTS is the order of a scene's effects (Scene.effects) and of the step's stages: a stage's
slot in a StageTable's effects tuple is its place among the effects with a compiled force. Every
list of effects derives from it, at the time it is asked for: the scene reader's keys, the
Scene's effect names, the stage table and the step's dispatch (dispatch.run_stages), the
stiff-effect diagnosis, the command line's --enable and --disable, and the effects table of the
documentation. Adding an effect is one module and one line here (docs/developing.md).
"""

from __future__ import annotations

from . import (
    armature,
    clip,
    computed_torque,
    constant,
    contact,
    damping,
    friction,
    geometry_contact,
    gravity,
    limits,
    pd,
    python_control,
    wrench,
)

EFFECTS = (
    gravity,
    damping,
    friction,
    armature,
    limits,
    wrench,
    contact,
    geometry_contact,
    constant,
    pd,
    computed_torque,
    python_control,
    clip,
)


def stages() -> tuple:
    """The effects with a compiled force, in the order the step runs them (the slots)."""
    return tuple(effect for effect in EFFECTS if effect.apply is not None)


def slot(effect) -> int:
    """The effect's slot in a StageTable's effects tuple."""
    return stages().index(effect)


def names() -> tuple[str, ...]:
    """The effects' names in a scene (Scene.effects), in EFFECTS order, each once."""
    return tuple(dict.fromkeys(effect.NAME for effect in EFFECTS))


def named(name) -> tuple:
    """The modules of the effect called `name` in a scene (the control laws and clip share
    "control")."""
    return tuple(effect for effect in EFFECTS if effect.NAME == name)


def in_section(section) -> tuple:
    """The effects a scene file sets in `section`: "effects" or "control"."""
    return tuple(effect for effect in EFFECTS if effect.SECTION == section)


def is_on(scene, name) -> bool:
    """Whether `scene` names the effect called `name`: as a force of the step (its record), or
    as rows of the hard model's velocity-level step (its `hard`, where it has one)."""
    return any(
        effect.record(scene) is not None
        or getattr(effect, "hard", lambda _: None)(scene) is not None
        for effect in named(name)
    )


def scene_fields(records) -> dict:
    """The Scene fields of the records {name: record} a scene file gives: each effect's record
    in its module's FIELD, and those of the effects without one in other_effects."""
    fields, others = {}, {}
    for name, record in records.items():
        field = named(name)[0].FIELD
        if field is None:
            others[name] = record
        else:
            fields[field] = record
    return {**fields, "other_effects": others}


def enable_settings() -> dict:
    """{name: settings}: what `opendyn simulate --enable NAME` puts in [effects.NAME]."""
    return {effect.NAME: effect.ENABLE for effect in EFFECTS if effect.ENABLE is not None}


def effects_table() -> str:
    """The table of effects of the documentation's scenes guide (generated there): one row per
    name, its modules' DOC lines joined."""
    rows = ["| effect | generalized force |", "|---|---|"]
    for name in names():
        rows.append(f"| {name} | {'; '.join(effect.DOC for effect in named(name))} |")
    return "\n".join(rows)
