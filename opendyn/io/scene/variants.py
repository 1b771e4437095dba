"""A scene with some of its keys set to other values: the runs of a sweep and of a rollout.

    Variants.of(scene).scene_for({"control.kp": 50.0, "initial.q.shoulder_lift_joint": 0.3})

A key is a dotted scene key (`control.kp`, `initial.q.shoulder_pan_joint`, `run.dt`,
`effects.damping.coefficients`, `robot.payload.mass`); a value replaces what the scene file says
there, or adds it (`effects.damping.coefficients` switches damping on). A per-joint list or
number in the scene (`initial.q = [...]`) takes a joint's name after it (`initial.q.JOINT`) and
keeps its other joints' values (a URDF object's joint is whole: `initial.q.door.hinge`); a list
of tables takes an index (`effects.contact.points.0.radius`).
Each variant is read (and so checked) as a scene file with those values would be; the robot is
loaded once per process and [robot] table (a payload is added to it per variant).
"""

from __future__ import annotations

import dataclasses
import json
import numbers
import os

from ...errors import SceneError
from .reader import _build, _Reader
from ...sim.scene import Scene, thaw

_MODELS: dict = {}  # each process's robots, by their [robot] table (payload apart) and folder
_MAX_MODELS = 16


@dataclasses.dataclass(frozen=True)
class Variants:
    """What it takes to rebuild a scene with some keys set: the base scene's settings (a plain
    dict), its source (for messages), the folder a relative robot.urdf is found from, and its
    robot's joint names (for per-joint keys). Small and plain, so that it travels to a sweep's
    workers."""

    settings: dict
    source: str
    base_dir: str | None
    joints: tuple[str, ...]

    @classmethod
    def of(cls, scene: Scene) -> Variants:
        folder = os.path.dirname(scene.source) if os.path.isfile(scene.source) else None
        return cls(thaw(scene.settings), scene.source, folder, tuple(scene.model.joint_names))

    def settings_for(self, values: dict) -> dict:
        """The base settings with each dotted key of `values` set to its value."""
        settings = thaw(self.settings)
        for key, value in values.items():
            _assign(settings, key, value, self.joints, self.source)
        return settings

    def scene_for(self, values: dict) -> Scene:
        """The scene with these values, read (and checked) as a scene file with them would be
        (SceneError naming the key otherwise)."""
        settings = self.settings_for(values)
        return _build(settings, self.source, self.base_dir, model=self._model(settings))

    def _model(self, settings):
        robot = settings.get("robot")
        if not isinstance(robot, dict):
            return None  # the reader names what is missing
        table = {k: v for k, v in robot.items() if k != "payload"}
        key = json.dumps([table, self.base_dir], sort_keys=True, default=str)
        if key not in _MODELS:
            if len(_MODELS) >= _MAX_MODELS:
                _MODELS.clear()
            _MODELS[key] = _Reader(self.source).robot(table, self.base_dir)
        return _MODELS[key]


def _assign(settings, key, value, joints, source):
    """settings[k1][k2]...[kn] = value for key = 'k1.k2...kn', making missing tables; a joint's
    name in a per-joint list or number turns it into a table {joint: value}, an index in a list
    picks its entry. SceneError (naming source and key) where the key does not fit the scene: an
    index into an entry the scene does not give among them."""

    def fail(what):
        raise SceneError(f"{source}: {key}: {what}")

    if not isinstance(key, str) or not key or any(not part for part in key.split(".")):
        raise SceneError(f"{source}: {key!r} is not a dotted scene key (e.g. 'control.kp')")
    parts = key.split(".")
    node = settings
    for depth, part in enumerate(parts):
        rest = ".".join(parts[depth:])
        if rest in joints and rest != part:  # an object's joint, named "OBJECT.joint"
            parts, part = [*parts[:depth], rest], rest
        last = depth == len(parts) - 1
        if isinstance(node, list) and part.isdigit():
            index = int(part)
            if index >= len(node):
                fail(f"{'.'.join(parts[:depth])} has {len(node)} entries, no entry {index}")
            if last:
                node[index] = value
                return
            node = node[index]
            continue
        if not isinstance(node, dict):
            where = ".".join(parts[:depth])
            if isinstance(node, list) and len(node) == len(joints):
                fail(
                    f"{where} is a list of one value per joint in the scene, and {part!r} is "
                    f"not a joint; joints: {', '.join(joints)}"
                )
            fail(f"{where} is {node!r} in the scene, not a table, so it has no key {part!r}")
        if last:
            node[part] = value
            return
        child = node.get(part)
        following = parts[depth + 1]
        if child is None and following.isdigit() and following not in joints:
            where = ".".join(parts[: depth + 1])
            fail(
                f"the scene gives no {where}, so it has no entry {following}: set the whole "
                f"{where} (a list, e.g. {where} = [...]), or add {where} to the scene file to "
                f"set its entries one by one"
            )
        if child is None:
            child = node[part] = {}
        elif following in joints and isinstance(child, list) and len(child) == len(joints):
            child = node[part] = dict(zip(joints, child))
        elif following in joints and isinstance(child, numbers.Real):
            child = node[part] = {joint: child for joint in joints}
        node = child
