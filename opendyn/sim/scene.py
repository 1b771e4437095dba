"""What a scene is: the frozen ``Scene`` that the simulation runs (a robot, its initial state, the
run settings, the physical effects that exist and the control) and ``thaw``, which turns its
read-only settings back into a plain dict. A scene file is read into one by opendyn.io.scene;
each effect's record is defined by its module in opendyn.sim.effects, which also states its
generalized force (the effects table, ``registry.effects_table()``). An effect that a scene does
not name is off: the simulator never computes it.

Conventions (as in the rest of opendyn): SI units (rad or m, N m or N, s); twists (omega, v) and
wrenches (m, f), moment first; per-joint arrays are ordered as ``model.joint_names``
(depth-first over the URDF tree); gravity is the world-frame vector g (the acceleration of a
falling body, default (0, 0, -9.81) m/s^2). A wrench F = (m, f) of a scene is the wrench the
environment applies TO THE ROBOT at the frame's origin (a push), the opposite sign of the
dynamics functions' ``f_tip`` (opendyn.sim.effects.wrench).
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np

from ..errors import SceneError
from ..multibody.model import Model
from . import hard_settings
from .effects import registry
from .effects.contact import Contact
from .effects.control import Control
from .effects.friction import Friction
from .effects.limits import Limits
from .effects.wrench import Wrench
from .run import RUN_KEYS, Run, RunSection
from .values import suggest


@dataclass(frozen=True, eq=False)
class Scene:
    """A robot, its initial state, the effects that exist, the control and the run settings.

    model: the robot's Model, carrying the payload of [robot.payload] when the scene names one
    (``Model.with_payload``). q0: (nq,) rad or m, with a floating base (p, quat (x, y, z, w),
    q_joints); qd0: (nv,) rad/s or m/s, with a floating base (omega_b, v_b, qd_joints) the
    base twist in its own frame. gravity: (3,) world-frame m/s^2 or None. The per-joint arrays
    (damping, friction, armature, limits, control) have one entry per joint, in
    model.joint_names order (n = nv without a floating base, nv - 6 with one). damping: (n,)
    viscous coefficients or None. armature: (n,) or None. wrenches: () when none is applied.
    contact: ground contact (Contact) or None. control: None = zero torque. source: the scene
    file, "<dict>" or "<robot NAME>". settings: the scene as read, for provenance records: a
    read-only mapping (tables as mappings, lists as tuples; ``thaw(scene.settings)`` is a plain
    dict to edit and pass to scene_from_dict). Every array is immutable.
    An effect that is None (or, for wrenches, empty) is never computed.
    constraints: Pfaffian constraints A(q) qd = 0 (opendyn.multibody.constraint_objects objects),
    () for none; baumgarte: (alpha, beta) 1/s, the stabilisation A qdd + Adot qd + 2 alpha A qd +
    beta^2 phi = 0 of their drift, or None (A qdd + Adot qd = 0: the drift is left alone).
    other_effects: {name: record} of the effects whose module in opendyn.sim.effects keeps its
    record in no field above (FIELD = None); empty for the effects opendyn ships.
    files: the other files the scene file names, as paths: the robot's URDF and SRDF, its
    objects' URDFs, its world meshes, its Python controller's file.
    """

    name: str
    model: Model
    q0: np.ndarray
    qd0: np.ndarray
    run: Run
    gravity: np.ndarray | None
    damping: np.ndarray | None
    friction: Friction | None
    armature: np.ndarray | None
    limits: Limits | None
    wrenches: tuple[Wrench, ...]
    control: Control | None
    source: str
    settings: Mapping
    constraints: tuple = ()
    baumgarte: tuple[float, float] | None = None
    contact: Contact | None = None
    other_effects: Mapping = dataclasses.field(default_factory=dict)
    files: tuple[str, ...] = ()

    def __post_init__(self):
        object.__setattr__(self, "settings", _freeze(thaw(self.settings)))
        object.__setattr__(self, "other_effects", MappingProxyType(dict(self.other_effects)))
        hard_settings.check(self)

    def inputs(self) -> tuple[tuple[str, str], ...]:
        """(path, what it is) of each file the scene was made of: the scene file, the robot's
        URDF and the other files it names (`files`); a source that is no file ("<dict>") is
        left out. An output written there would replace an input of the run."""
        named = [(self.source, "the scene file"), (self.model.source, "the robot's URDF")]
        named += [(path, "a file the scene names") for path in self.files]
        return tuple((str(path), what) for path, what in named if path and os.path.isfile(path))

    @property
    def effects(self) -> tuple[str, ...]:
        """The names of the effects that are on, in the registry's order (registry.names())."""
        return tuple(name for name in registry.names() if registry.is_on(self, name))

    def without(self, *effects: str) -> Scene:
        """The same scene with these effects (names from registry.names()) off; ``settings`` follows."""
        known = registry.names()
        for name in effects:
            if name not in known:
                raise SceneError(
                    f"{self.source}: Scene.without: unknown effect {name!r}"
                    f"{suggest(name, known)}; effects: {', '.join(known)}"
                )
        changes, settings = {}, thaw(self.settings)
        table = settings.get("effects") if isinstance(settings.get("effects"), dict) else {}
        others = dict(self.other_effects)
        for name in effects:
            for effect in registry.named(name):
                if effect.FIELD is None:
                    others.pop(name, None)
                else:
                    changes[effect.FIELD] = effect.OFF
                if effect.SECTION == "control":
                    settings.pop("control", None)
                else:
                    table.pop(name, None)
        return dataclasses.replace(self, settings=settings, other_effects=others, **changes)

    def replace_run(self, **changes) -> Scene:
        """The same scene with new Run fields (duration, integrator, dt, output_dt, rtol, atol,
        max_speed), validated as in a scene file; a value None restores that field's default."""
        for key in changes:
            if key not in RUN_KEYS:
                raise SceneError(
                    f"{self.source}: Scene.replace_run: unknown run setting {key!r}"
                    f"{suggest(key, RUN_KEYS)}; valid: {', '.join(RUN_KEYS)}"
                )
        settings = thaw(self.settings)
        table = settings.get("run") or {}
        for key, value in changes.items():
            if value is None:
                table.pop(key, None)
            else:
                table[key] = thaw(value)
        run = RunSection(self.source).run(table)
        settings["run"] = table
        return dataclasses.replace(self, run=run, settings=settings)


def _freeze(value):
    """A read-only copy of a settings tree: mappings as MappingProxyType, lists as tuples."""
    if isinstance(value, Mapping):
        return MappingProxyType({k: _freeze(v) for k, v in value.items()})
    if isinstance(value, (list, tuple)):
        return tuple(_freeze(v) for v in value)
    return value


def thaw(value):
    """A plain, mutable copy of a settings tree (``scene.settings``, or a dict that holds
    numpy arrays): mappings as dicts, lists and tuples as lists, numpy arrays and scalars as
    Python values, paths as strings; what scene_from_dict takes and JSON writes."""
    if isinstance(value, Mapping):
        return {k: thaw(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [thaw(v) for v in value]
    if isinstance(value, np.ndarray):
        return thaw(value.tolist())
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    return value
