"""The effect registry: every effect module declares every part of its effect, every list of
effects derives from the registry, every effect is read from a scene, packed into fresh arrays,
reached by the step's dispatch, and adds only to the force vector of its energy class and to
the derivatives it declares.

A new effect fails here until it is complete; the scenes here are built from the modules' own
EXAMPLE settings, so a new effect needs no line here (the module's own closed-form test is for
its law; docs/developing.md)."""

from __future__ import annotations

import dataclasses
import pathlib

import numpy as np
import pytest
from numba import njit
from numba.core.registry import CPUDispatcher

import opendyn as od
from opendyn.cli import simulate as cli_simulate
from opendyn.sim.scene import Scene
from opendyn.io.urdf import shipped_robots_dir
from opendyn.sim import effects, step
from opendyn.sim.effects import pd, registry
from opendyn.sim.effects.dispatch import run_stages
from opendyn.sim.effects.interface import CONSERVATIVE, ENERGY_CLASSES, Context, Out

SCENES_GUIDE = (
    pathlib.Path(__file__).resolve().parents[1] / "docs" / "guides" / "scenes.md"
).read_text(encoding="utf-8")
SCENE_FIELDS = {field.name for field in dataclasses.fields(Scene)}

# the double pendulum (limits +-3.14 rad, effort limits 50 and 20 N m); one scene per module of
# [control], each with every effect of [effects] on, all from the modules' own EXAMPLE settings
PENDULUM = {"urdf": str(shipped_robots_dir() / "double_pendulum.urdf")}


def scene_settings():
    """{module's name: the scene's settings}: together they switch on every effect of the
    registry, a scene naming one control law with the first module of each name of [effects],
    and one scene (PD control) for each further module of a name (the collision geometries'
    contact, which shares [effects.contact] with the ground's spheres)."""
    in_effects = registry.in_section("effects")
    every_force = {}
    for effect in in_effects:
        every_force.setdefault(effect.NAME, effect.EXAMPLE)
    found = {
        ids([effect])[0]: {"effects": every_force, "control": effect.EXAMPLE}
        for effect in registry.in_section("control")
    }
    for effect in in_effects:
        if every_force[effect.NAME] is not effect.EXAMPLE:
            found[ids([effect])[0]] = {
                "effects": {**every_force, effect.NAME: effect.EXAMPLE},
                "control": pd.EXAMPLE,
            }
    return found


def scene_named(key):
    return od.scene_from_dict({"robot": PENDULUM, **scene_settings()[key]})


def scenes_naming(effect):
    """The scenes of scene_settings() that name `effect` (a module of the registry)."""
    found = [scene_named(key) for key in scene_settings()]
    return [scene for scene in found if effect.record(scene) is not None]


def arrays_of(record):
    """The arrays a scene's record holds (a record, a tuple of records, or an array)."""
    if isinstance(record, np.ndarray):
        return [record]
    if isinstance(record, tuple):
        return [array for item in record for array in arrays_of(item)]
    if dataclasses.is_dataclass(record):
        return [v for v in vars(record).values() if isinstance(v, np.ndarray)]
    return []


def leaves(items):
    """The items of a tuple, the items of the tuples in it taken one by one (the geometry
    contact's parameters hold the GeometryTable's arrays as one tuple)."""
    for item in items:
        if isinstance(item, tuple):
            yield from leaves(item)
        else:
            yield item


def ids(modules):
    return [module.__name__.rsplit(".", 1)[1] for module in modules]


@pytest.mark.parametrize("effect", registry.EFFECTS, ids=ids(registry.EFFECTS))
def test_every_effect_declares_every_part(effect):
    assert_declares_every_part(effect)


def assert_declares_every_part(effect):
    """Every part interface's docstring lists, of the right kind."""
    assert isinstance(effect.NAME, str) and effect.NAME, "NAME: its name in a scene"
    assert effect.SECTION in ("effects", "control"), "SECTION: where a scene file sets it"
    if effect.SECTION == "control":
        assert effect.CONTROL_TYPE is None or isinstance(effect.CONTROL_TYPE, str)
    assert isinstance(effect.KEYS, tuple) and all(isinstance(k, str) for k in effect.KEYS)
    assert effect.KEYS or effect.SECTION == "effects", "KEYS: a [control] effect sets keys"
    assert effect.FIELD is None or effect.FIELD in SCENE_FIELDS, "FIELD: a Scene field"
    assert effect.OFF in (None, ()), "OFF: its record when off"
    assert callable(effect.read) and callable(effect.record) and callable(effect.pack)
    assert isinstance(effect.DOC, str) and effect.DOC and "\n" not in effect.DOC, "DOC line"
    assert effect.ENABLE is None or effect.ENABLE is True or isinstance(effect.ENABLE, dict)
    assert effect.EXAMPLE not in (None, False), "EXAMPLE: settings that switch it on"
    if effect.SECTION == "control":
        assert isinstance(effect.EXAMPLE, dict) and "type" in effect.EXAMPLE, "a [control] table"
    assert effect.ENERGY in ENERGY_CLASSES, "ENERGY: how its power enters the energy balance"
    assert set(effect.DERIVATIVES) <= {"K", "D"}
    assert effect.Params is None or hasattr(effect.Params, "_fields"), "Params: a namedtuple"
    if effect.Params is not None:
        # numba's cache pickles the type by its name: it must be the module's attribute
        assert effect.Params.__name__ == "Params" and effect.Params.__module__ == effect.__name__
    if effect.STAGE is None:
        assert effect.apply is None and not effect.DERIVATIVES
    else:
        assert isinstance(effect.STAGE, str) and isinstance(effect.apply, CPUDispatcher)
    if effect.ENERGY == CONSERVATIVE and effect.SECTION == "effects":
        assert effect.tangent is None, "gravity and armature act through the dynamics"
    else:
        assert callable(effect.tangent), "tangent(record, at): its exact derivatives"
    if effect.DERIVATIVES:
        assert callable(effect.rates), "a stiff effect names itself: rates(record, at)"
    else:
        assert effect.rates is None or callable(effect.rates)


def test_modules_of_one_name_agree_on_where_it_lives():
    for name in registry.names():
        modules = registry.named(name)
        assert len({(m.SECTION, m.FIELD, m.OFF) for m in modules}) == 1, name
    stages = [effect.STAGE for effect in registry.EFFECTS if effect.STAGE is not None]
    assert len(set(stages)) == len(stages), "a stage's name is its own"


def test_the_lists_of_effects_derive_from_the_registry():
    assert registry.stages() == tuple(e for e in registry.EFFECTS if e.apply is not None)
    scene = scene_named("pd")
    assert scene.effects == tuple(n for n in registry.names() if registry.is_on(scene, n))
    assert cli_simulate.ENABLE_FROM_URDF == registry.enable_settings()
    assert set(registry.enable_settings()) == {"gravity", "damping", "friction"}


def test_the_documentations_effects_table_is_the_registry_s():
    """The scenes guide's table is generated from the registry when the site is built (the
    built page is checked in tests/test_docs.py)."""
    assert "<!-- generated: effects -->" in SCENES_GUIDE
    table = registry.effects_table().splitlines()
    assert len(table) == 2 + len(registry.names())
    for name in registry.names():
        assert any(row.startswith(f"| {name} | ") for row in table)


@pytest.mark.parametrize("effect", registry.EFFECTS, ids=ids(registry.EFFECTS))
def test_every_effect_is_read_from_a_scene_and_packed_into_fresh_arrays(effect):
    scenes = scenes_naming(effect)
    assert scenes, f"no scene names {effect.__name__}: its EXAMPLE must switch it on"
    for scene in scenes:
        assert effect.NAME in scene.effects
        record = effect.record(scene)
        params = effect.pack(record, scene.model)
        if effect.Params is not None:
            assert isinstance(params, effect.Params)
        arrays = params if isinstance(params, tuple) else (params,)
        if effect.Params is not None and "floating" in effect.Params._fields:
            arrays = params[:-1]  # computed torque's compile-time switch (None or True)
        for array in leaves(arrays):
            assert isinstance(array, np.ndarray) and array.flags.writeable, effect.__name__
            assert array.flags.c_contiguous and array.dtype in (np.float64, np.int64, np.bool_)
            assert not any(np.shares_memory(array, value) for value in arrays_of(record))
        table = effects.stage_table(scene)
        if effect.STAGE is not None:
            assert table.params(effect) is not None
        off = scene.without(effect.NAME)
        assert effect.record(off) is None and effect.NAME not in off.effects
        if effect.STAGE is not None:
            assert effects.stage_table(off).params(effect) is None


@njit
def one_stage(which, table_effects, ctx, out):
    return run_stages(which, table_effects, ctx, out)


@pytest.mark.parametrize("stage", registry.stages(), ids=ids(registry.stages()))
def test_every_stage_is_reached_by_the_dispatch_and_adds_to_its_energy_class(stage):
    """Through the step's dispatch at random states, after the stages before it (as the step
    runs them): the stage changes something, only the force vector of its energy class (none
    for a conservative one), and only the derivatives it declares."""
    rng = np.random.default_rng(11)
    slot = registry.slot(stage)
    acted = False
    for scene in scenes_naming(stage):
        model = scene.model
        table = effects.stage_table(scene)
        for _ in range(12):
            q = rng.uniform(-3.5, 3.5, model.nq)
            qd = rng.normal(size=model.nv)
            t = rng.uniform(0, 1)
            dV_0 = np.zeros(6)
            data = step.scene_data(model, table)
            ctx = Context(
                model._ibuf, model._fbuf, data.work, t, q, qd, dV_0, table.armature, data.room,
                data.touch,
            )
            nv = model.nv
            out = Out(*np.zeros((3, nv)), np.zeros(2), *np.zeros((2, nv, nv)), np.bool_(True))
            assert step.place(data, q, qd) == 0  # as the step does before its stages
            for earlier in range(slot):
                assert one_stage(earlier, table.effects, ctx, out) == 0
            before = {name: np.copy(value) for name, value in out._asdict().items()}
            base = dV_0.copy()
            assert one_stage(slot, table.effects, ctx, out) == 0
            changed = {name for name in before if np.any(getattr(out, name) != before[name])}
            assert changed & {"control", "applied", "passive"} <= {stage.ENERGY}, stage.STAGE
            assert changed & {"K", "D"} <= set(stage.DERIVATIVES), stage.STAGE
            acted |= bool(changed) or np.any(dV_0 != base)
    assert acted, f"{stage.STAGE} never acted through the dispatch"


def stage_forces(stage, scene, q, qd, poses_q, world):
    """The stage's out vectors at (q, qd) after the step places the poses at poses_q (the world
    poses only when `world`; else they hold NaN), gravity's base acceleration set first."""
    model = scene.model
    table = effects.stage_table(scene)
    held = model.data()
    data = step.scene_data(model, table)._replace(world=True if world else None, work=held._work)
    work = data.work
    held.R_s[...] = np.nan
    held.p_s[...] = np.nan
    assert step.place(data, poses_q, qd) == 0
    assert np.shares_memory(work, held.R_s)
    dV_0 = np.zeros(6)
    ctx = Context(
        model._ibuf, model._fbuf, work, 0.3, q, qd, dV_0, table.armature, data.room, data.touch
    )
    nv = model.nv
    out = Out(*np.zeros((3, nv)), np.zeros(2), *np.zeros((2, nv, nv)), np.bool_(True))
    assert one_stage(registry.slot(effects.gravity), table.effects, ctx, out) == 0
    assert one_stage(registry.slot(stage), table.effects, ctx, out) == 0
    return np.concatenate([np.ravel(v) for v in out[:6]])


@pytest.mark.parametrize("stage", registry.stages(), ids=ids(registry.stages()))
def test_a_stage_reads_the_world_poses_only_if_it_declares_them(stage):
    """Kinematics once per evaluation (opendyn.sim.step): the step places the world poses only
    for a scene that names an effect declaring WORLD_POSES. A stage that does not declare them
    must not read them (here NaN); one that does must take them as placed, without walking the
    tree again: placed at another configuration, its force is the force there."""
    rng = np.random.default_rng(5)
    for scene in scenes_naming(stage):
        model = scene.model
        assert effects.stage_table(scene).world_poses == any(
            getattr(e, "WORLD_POSES", False) for e in registry.stages() if e.record(scene) is not None
        )
        for _ in range(6):
            q, q2 = rng.uniform(-1.5, 1.5, (2, model.nq))
            q2[0] = q[0] + 0.1  # the tip (wrench, contact) goes elsewhere
            qd = rng.normal(size=model.nv)
            forces = stage_forces(stage, scene, q, qd, q, getattr(stage, "WORLD_POSES", False))
            assert np.all(np.isfinite(forces)), stage.STAGE
            if getattr(stage, "WORLD_POSES", False):
                there = stage_forces(stage, scene, q2, qd, q2, True)
                mixed = stage_forces(stage, scene, q, qd, q2, True)
                np.testing.assert_array_equal(mixed, there)


def test_the_step_with_its_poses_placed_once_is_forward_dynamics_of_its_forces():
    """evaluate (the poses placed once, the effects and ABA on them) against the public
    functions called one by one at the same state: a wrench and contact scene."""
    scene = scene_named("pd")
    model = scene.model
    table = effects.stage_table(scene)
    assert table.world_poses
    data = step.scene_data(model, table)
    rng = np.random.default_rng(2)
    for _ in range(5):
        q, qd = rng.uniform(-1.5, 1.5, model.nq), rng.normal(size=model.nv)
        qdd, tau_ctrl, power = np.empty(model.nv), np.empty(model.nv), np.empty(2)
        assert step.evaluate(data, 0.3, q, qd, qdd, tau_ctrl, power) == 0
        tau = data.forces[0].copy()
        M = od.mass_matrix(model, q) + np.diag(table.armature)
        h = od.bias_forces(model, q, qd)
        np.testing.assert_allclose(M @ qdd + h, tau, rtol=1e-10, atol=1e-10)
        # the wrench's share: J_b(tip)^T F_tip with F in world axes at the tip
        wrench = np.array([0, 0, 0, 1, 0, 2.0])
        T = od.frame_pose(model, q, "tip")
        F_b = np.concatenate([T[:3, :3].T @ wrench[:3], T[:3, :3].T @ wrench[3:]])
        J_b = od.jacobian(model, q, "tip", "body")
        np.testing.assert_allclose(data.forces[1], J_b.T @ F_b, atol=1e-12)
