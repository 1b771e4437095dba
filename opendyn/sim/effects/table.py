"""A scene's step as data for the compiled loops: the StageTable, with one slot per effect of
the registry's stages (its parameters, or None), the armature, the forward-dynamics method and
the constraints."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...algorithm.constraints import ConstraintTable, constraint_table
from ...algorithm.forward import NO_ARMATURE
from . import armature, contact, geometry_contact, registry


@dataclass(frozen=True)
class StageTable:
    """A scene's step as data for the compiled loops.

    effects: a tuple with one slot per stage (registry.stages(), in order): the effect's
      parameters (its module's pack), or None when the scene does not name it. numba compiles
      the step for the tuple's types, and each effect's compiled force tests its slot against
      None when it compiles, so an effect the scene does not name is neither compiled nor run.
    names: the stages the scene names, in the order they run (for reports).
    slots: each named stage's slot in `effects`.
    method: forward dynamics by "aba", "crba" (CRBA + Cholesky: coupled mimic joints) or
      "newton_euler"; only that method is compiled.
    armature: (nv,) rotor inertias that forward dynamics adds to M's diagonal, or empty: armature
      is not a force but a change of M, so it has no slot.
    constraints: (rows (n_c, 5) int64, params float64, gains (2,)): the scene's constraints as
      opendyn.algorithm.constraints.constraint_table gives them and the Baumgarte gains
      (alpha, beta); None when the scene has none (the constrained solve is then neither
      compiled nor run).
    world_poses: whether an effect the scene names reads the bodies' world poses (its module
      declares WORLD_POSES), or the hard model's contact does: the step then places them once
      per evaluation.
    hard: the hard model's HardTable (opendyn.sim.hard_step), or None when no section of the
      scene is hard (the velocity-level step's rows are then neither compiled nor run).
    """

    effects: tuple
    names: tuple[str, ...]
    slots: tuple[int, ...]
    method: str
    armature: np.ndarray
    constraints: tuple | None = None
    world_poses: bool = False
    hard: tuple | None = None

    def params(self, effect):
        """The parameters in the slot of `effect` (a module of registry.stages()), or None."""
        return self.effects[registry.slot(effect)]


def stage_table(scene) -> StageTable:
    """The compiled step's data for the effects `scene` names, in the order they run
    (registry.stages(); armature goes to M)."""
    model = scene.model
    effects, names, world_poses = [], [], False
    for effect in registry.stages():
        record = effect.record(scene)
        params = None if record is None else effect.pack(record, model)
        effects.append(params)
        if params is not None:
            label = getattr(effect, "label", None)
            names.append(effect.STAGE if label is None else label(record, model))
            world_poses = world_poses or getattr(effect, "WORLD_POSES", False)
    constraints = None
    if scene.constraints:
        c_rows, c_params = constraint_table(model, scene.constraints, scene.q0)
        gains = np.array(scene.baumgarte if scene.baumgarte is not None else (0.0, 0.0))
        constraints = ConstraintTable(c_rows, c_params, gains)
    rotors = armature.record(scene)
    hard = hard_of(scene, constraints)
    return StageTable(
        effects=tuple(effects),
        names=tuple(names),
        slots=tuple(k for k, params in enumerate(effects) if params is not None),
        method="crba" if model.coupled else "aba",
        armature=NO_ARMATURE if rotors is None else armature.pack(rotors, model),
        constraints=constraints,
        world_poses=world_poses or (hard is not None and hard.room.found.pair.shape[0] > 0),
        hard=hard,
    )


def hard_of(scene, constraints):
    """The scene's HardTable (opendyn.sim.hard.hard_table), or None when nothing is hard;
    constraints: its ConstraintTable, or None."""
    from ..hard import hard_table  # the hard step is built on the stage machinery

    model = scene.model
    spheres = contact.contact_table(model, scene.contact) if contact.hard(scene) else None
    pairs = geometry_contact.hard(scene)
    packed = None if pairs is None else geometry_contact.pack(pairs, model)
    return hard_table(scene, spheres, packed, constraints)
