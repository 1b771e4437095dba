"""Before a run: what it will need and whether it can start, checked before anything is allocated
or compiled.

    steps        N = duration / dt            a whole number, at most 2^53 (scene.check_fixed_steps)
    samples      K = N / every + 1            (adaptive: ceil(duration / output_dt) + 1)
    memory       8 K (3 + nq + 2 nv + 2 + 7 P + 2 c)  bytes, three times over, below what the
                 process may allocate (opendyn._runtime.memory: limits and cgroups included)
    start        |qd0_k| <= max_speed,  |q0_j| <= MAX_POSITION,  lower_j <= q0_j <= upper_j,
                 K(q0, qd0), U(q0) finite,
                 |phi(q0)|, |A(q0) qd0| <= CONSTRAINT_TOLERANCE, and per contact pair (a sphere
                 and the ground, or two geometries) its springs' energy at q0
                 sum k delta^2 / 2 <= max(2 (m g)^2 / k, LIFT g min_b m_b s_b)
                 (allowed_energy: m the mass resting on the pair, m_b and s_b each moving body's
                 mass and size)

with P contact points and c = 1 with constraints (their violation). A scene that fails any of
these raises SceneError naming the key to change; a joint starting outside its limits is a
SceneWarning when the scene does not enforce them (no [effects.limits] spring on it) and a
SceneError when it does. The energy at the start is computed by the kernel that computes the
record's energies, so the check compiles nothing the run does not.
"""

from __future__ import annotations

import warnings

import numpy as np

from .._runtime.memory import available_memory
from ..algorithm.constraints import CONSTRAINT_TOLERANCE, broken_constraint
from ..algorithm.contact_list import STIFFNESS
from ..algorithm.energy import energies
from ..errors import SceneError, SceneWarning
from ..multibody.joints import FREE
from . import effects
from .record import contact_record, geometry_contact_record, gravity_of
from .run import MAX_STEPS, check_fixed_steps

# the record's arrays are built, then energies, contact and the outputs' copies: room for the
# record three times (measured: a 1e6-sample run saved as .npz and CSV peaked at 2.45 times it)
_RECORD_COPIES = 3
# the energy a contact's springs may hold at the start beyond what its weight presses into them:
# what lifts the pair's lighter body by this fraction of its own size (allowed_energy), under
# the scene's gravity, or standard gravity (m/s^2) in a scene without
LIFT = 0.01
# |q| (rad or m) of a joint at the start beyond which a run is refused: float64 spaces numbers
# 1e-10 apart at 1e6, and sin(1e308) is a rounding artefact, not an angle
MAX_POSITION = 1e6
STANDARD_GRAVITY = 9.80665


def preflight(scene, integ):
    """Check `scene` (opendyn.sim.scene.Scene) can run with `integ` (its Integrator). Returns
    (nsteps, every, rows): the fixed steps (0 for adaptive methods), the steps between samples
    and the number of samples. Raises SceneError naming the key to change; warns SceneWarning."""
    nsteps, every, rows = run_size(scene, integ)
    _check_memory(scene, rows)
    check_start(scene)
    return nsteps, every, rows


def check_start(scene):
    """The initial state's checks, wherever a state enters (a scene, rollout's q0 and qd0,
    Simulator.reset): its velocities within max_speed, its positions within MAX_POSITION and
    the joint limits, its constraints met, its contact points not inside the ground or each
    other, its energy finite (SceneError naming the key to change; SceneWarning)."""
    _check_start(scene)
    _check_constraint_start(scene)
    _check_contact_start(scene)
    _check_geometry_start(scene)
    _check_energy(scene)


def _check_constraint_start(scene):
    """Refuse a start off the constraints: the run would start off their manifold (and,
    without stabilisation, stay off it)."""
    if not scene.constraints:
        return
    broken = broken_constraint(scene.model, scene.q0, scene.qd0, scene.constraints)
    if broken is not None:
        i, what, worst = broken
        _fail(scene, f"constraints[{i}]", broken_message(scene.constraints[i], what, worst))


def broken_message(constraint, what, worst):
    """Why an initial state cannot start: it breaks `constraint` by `worst` in `what`."""
    return (
        f"the initial state breaks this {type(constraint).__name__} constraint: its {what} "
        f"error is {worst:.3g} (tolerance {CONSTRAINT_TOLERANCE:g}); give [initial] q and qd "
        "that satisfy it"
    )


def _check_contact_start(scene):
    """Refuse a start with a contact sphere whose spring holds more energy than its robot's
    weight presses into it or than lifts it by LIFT of its size (allowed_energy; the mass
    resting on a sphere is its robot's whole tree): the spring would throw the robot with
    energy the scene never meant to give (a ball 5 cm deep in a 1e5 N/m ground got 125 J and
    flew 13 m up)."""
    contact = effects.contact.record(scene)
    if contact is None:
        return
    model = scene.model
    spheres = effects.contact.pack(contact, model)
    q, qd = np.array(scene.q0)[None], np.array(scene.qd0)[None]
    depth = contact_record(model, spheres, q, qd)[2][0]
    stored = 0.5 * contact.stiffness * depth**2
    mass = tree_masses(model)[spheres.body]
    lift = mass * effects.contact.point_sizes(contact, model)
    allowed = allowed_energy(scene, contact.stiffness, mass, lift)
    k = int(np.argmax(stored - allowed))
    if not stored[k] > allowed[k]:
        return
    raise_by = "initial.base_position (its z)" if model.floating_base else "initial.q"
    _fail(
        scene,
        "initial",
        f"the contact point {contact.points[k].name!r} starts {depth[k]:.3g} m inside the "
        f"ground (z = {contact.ground_height:g} m), where its spring (effects.contact.stiffness "
        f"= {contact.stiffness:g} N/m) would hold {stored[k]:.3g} J, more than the "
        f"{allowed[k]:.3g} J its robot's weight presses into it or that lift it by "
        f"{LIFT:.0%} of its size, and throw the robot; start it above the ground (raise "
        f"{raise_by}, or lower effects.contact.ground_height), or check the point's radius",
    )


def _check_geometry_start(scene):
    """The same refusal for each pair of collision geometries: their springs' energy at the
    initial state, summed over the pair's contact points, against allowed_energy, with the
    mass resting on the pair that of the moving trees it joins and of every tree touching
    them at the start (the boxes of a stack above it; another body elsewhere adds nothing)."""
    contact = effects.geometry_contact.record(scene)
    if contact is None:
        return
    model = scene.model
    geometry = effects.geometry_contact.pack(contact, model)
    q, qd = np.array(scene.q0)[None], np.array(scene.qd0)[None]
    table = geometry_contact_record(model, geometry, q, qd)
    if not len(table):
        return
    pairs, k = geometry.pairs, geometry.law[:, STIFFNESS]
    stored = np.bincount(table.pair, 0.5 * k[table.pair] * table.depth**2, minlength=len(pairs))
    # each side's body (-1: the world, the ground among it), its tree's mass (a static side's
    # infinite: nothing lifts it) and its geometry's size
    bodies = np.append(model.geometry_table.body, -1)[pairs]
    moving = bodies >= 0
    mass = np.where(moving, tree_masses(model)[bodies], np.inf)
    lift = (mass * effects.geometry_contact.smallest_dimensions(model)[pairs]).min(axis=1)
    on_pair = resting_masses(model, bodies[np.unique(table.pair)])[bodies]
    resting = np.where(moving, on_pair, 0.0).max(axis=1)
    allowed = allowed_energy(scene, k, resting, lift)
    worst = int(np.argmax(stored - allowed))
    if not stored[worst] > allowed[worst]:
        return
    a, b = table.pair_names[worst]
    d = float(table.depth[table.pair == worst].max())
    _fail(
        scene,
        "initial",
        f"{a!r} starts {d:.3g} m inside {b!r}, where the contact's springs (stiffness "
        f"{k[worst]:g} N/m) would hold {stored[worst]:.3g} J, more than the "
        f"{allowed[worst]:.3g} J the weight resting on them presses in or that lift the "
        f"lighter body by {LIFT:.0%} of its size, and throw them apart; start them apart, or "
        "resting no deeper than their weight presses them (m g / k), by moving the objects' "
        "positions, initial.q or initial.base_position",
    )


def allowed_energy(scene, k, resting, lift):
    """(P,) J: the most energy the springs of each contact pair (stiffness k (P,) N/m) may
    hold at the start, the larger of

        2 (m g)^2 / k            one spring pressed to twice the depth m g / k at which it
                                 carries the weight of the mass m = resting (P,) kg
        LIFT g min_b m_b s_b     what lifts the pair's moving body b (its tree's mass m_b,
                                 the size s_b of its geometry) by LIFT of its size, the body
                                 that rises most; lift (P,) = min_b m_b s_b kg m

    g = |gravity|, and standard gravity in the lift bound of a scene without it (there a
    start may still touch, and the energy becomes a speed of sqrt(2 LIFT g s_b) at most)."""
    g = float(np.linalg.norm(gravity_of(scene)))
    weight = np.asarray(resting) * g
    return np.maximum(2.0 * weight**2 / k, LIFT * (g if g > 0 else STANDARD_GRAVITY) * lift)


def tree_masses(model) -> np.ndarray:
    """(nb,) kg: for each body, the mass of its tree, the bodies joined to it by joints up to
    the fixed world (a floating robot or an object whole, a fixed robot from its first moving
    joint down): with the joints free, all of it can rest on one of its contacts."""
    return resting_masses(model, np.zeros((0, 2), dtype=np.int64))


def resting_masses(model, touching) -> np.ndarray:
    """(nb,) kg: for each body, the mass of its tree (tree_masses) and of every tree joined to
    it through the pairs of bodies touching (C, 2) (-1: the world, which joins nothing)."""
    group = np.arange(model.nb)
    for i in range(model.nb):  # parent[i] < i: a tree's bodies take its root's group
        if model.parent[i] >= 0:
            group[i] = group[model.parent[i]]
    for a, b in touching:
        if a >= 0 and b >= 0 and group[a] != group[b]:
            group[group == group[b]] = group[a]
    return np.bincount(group, model.mass, minlength=model.nb)[group]


def run_size(scene, integ):
    """(nsteps, every, rows): the fixed steps (0 for adaptive methods), the steps between
    samples and the number of samples of a run of `scene` by `integ` (SceneError where they do
    not fit)."""
    run = scene.run
    if integ.adaptive:
        samples = run.duration / run.output_dt
        if not samples < MAX_STEPS:
            _fail(scene, "run.output_dt", f"{run.duration:g} s / {run.output_dt:g} s is "
                  f"{samples:.3g} samples, more than any record can hold; raise run.output_dt")
        return 0, 0, int(np.ceil(samples - 1e-9)) + 1
    check_fixed_steps(run, scene.source)  # as the scene's reader does, for a Run built directly
    nsteps = round(run.duration / run.dt)
    every = record_every(run)
    return nsteps, every, nsteps // every + 1 + (nsteps % every != 0)


def record_every(run) -> int:
    """The fixed steps of run.dt between two samples of the record: output_dt / dt, at least
    one."""
    return max(1, round(run.output_dt / run.dt))


def sample_numbers(scene) -> int:
    """The float64 numbers of one recorded sample of `scene` and its post-processing: t, q, qd,
    tau, the work (2), the energies (2), each contact point's position, force and depth (7) and
    the constraint violation (2)."""
    model = scene.model
    spheres = effects.contact.record(scene)
    points = len(spheres.points) if spheres is not None else 0
    return 3 + model.nq + 2 * model.nv + 2 + 7 * points + 2 * bool(scene.constraints)


def _check_memory(scene, rows):
    """Refuse a record that would not fit in the memory this process may allocate now."""
    per_sample = sample_numbers(scene)
    need = 8.0 * rows * per_sample * _RECORD_COPIES
    room = available_memory()
    if room is not None and need > room[0]:
        have, what = room
        _fail(
            scene,
            "run.output_dt",
            f"the record would hold {rows:.4g} samples of {per_sample} numbers, about "
            f"{byte_size(need)} with its post-processing and outputs, more than the "
            f"{byte_size(have)} that {what} leaves this process; raise run.output_dt (now "
            f"{scene.run.output_dt:g} s) or shorten run.duration (now {scene.run.duration:g} s)",
        )


def _check_start(scene):
    """The initial velocities within max_speed, the initial positions within MAX_POSITION and
    the joint limits."""
    model, run = scene.model, scene.run
    fast = np.flatnonzero(np.abs(scene.qd0) > run.max_speed)
    if fast.size:
        k = int(fast[np.argmax(np.abs(scene.qd0[fast]))])
        _fail(
            scene,
            _velocity_key(model, k),
            f"the initial velocity {scene.qd0[k]:g} of {model.v_names[k]!r} is beyond "
            f"run.max_speed = {run.max_speed:g} (rad/s or m/s), where a run stops as diverging; "
            "lower the initial velocity or raise run.max_speed",
        )
    q = scene.q0[model.q_index]
    far = np.flatnonzero(np.abs(q) > MAX_POSITION)
    if far.size:
        j = int(far[0])
        _fail(
            scene,
            f"initial.q.{model.joint_names[j]}",
            f"joint {model.joint_names[j]!r} starts at {q[j]:g}, beyond |q| = {MAX_POSITION:g} "
            "(rad or m), where float64 no longer resolves its motion (a revolute joint's sine "
            "and cosine are rounding noise); give a position within it",
        )
    outside = np.flatnonzero((q < model.lower) | (q > model.upper))
    enforced = scene.limits.stiffness > 0 if scene.limits is not None else np.zeros(len(q), bool)
    for j in outside:
        name = model.joint_names[j]
        what = (
            f"joint {name!r} starts at {q[j]:g}, outside its limits [{model.lower[j]:g}, "
            f"{model.upper[j]:g}] (rad or m)"
        )
        if enforced[j]:
            _fail(
                scene,
                f"initial.q.{name}",
                f"{what}, which [effects.limits] enforces: its spring would start "
                f"{_beyond(q[j], model.lower[j], model.upper[j]):.3g} deep; start inside them",
            )
        warnings.warn(
            f"{scene.source}: initial.q.{name}: {what}; the scene does not enforce them, so it "
            "runs as given",
            SceneWarning,
            stacklevel=5,  # the caller of simulate
        )


def _check_energy(scene):
    """A start whose kinetic or potential energy is not a finite number cannot be followed."""
    model = scene.model
    gravity = scene.gravity if scene.gravity is not None else np.zeros(3)
    q, qd = np.array(scene.q0)[None], np.array(scene.qd0)[None]  # (1, n): the record's batch kernel
    kinetic, potential = (float(e[0]) for e in energies(model, q, qd, gravity))
    if np.isfinite(kinetic) and np.isfinite(potential):
        return
    if not np.isfinite(kinetic):
        key, cause = "initial.qd", f"the initial velocities, |qd| up to {np.abs(scene.qd0).max():.3g}"
    else:
        key = "effects.gravity"
        cause = (
            f"gravity, up to {np.abs(gravity).max():.3g} m/s^2, on the initial positions, |q| "
            f"up to {np.abs(scene.q0).max():.3g}"
        )
    _fail(
        scene,
        key,
        f"the energy at the initial state is not a finite number (kinetic {kinetic:g} J, "
        f"potential {potential:g} J): {cause} overflow float64",
    )


def _velocity_key(model, k):
    """The scene key of velocity coordinate k: a joint's, or the floating base's."""
    free = np.flatnonzero(model.jtype == FREE)
    for i in free:
        first = int(model.iv[i])
        if first <= k < first + 6:
            return "initial.base_angular_velocity" if k < first + 3 else "initial.base_velocity"
    return f"initial.qd.{model.v_names[k]}"


def _beyond(q, lower, upper):
    return lower - q if q < lower else q - upper


def byte_size(n):
    """n bytes in the largest decimal unit up to PB that keeps the number at least 1."""
    units = ("B", "kB", "MB", "GB", "TB", "PB")
    k = min(len(units) - 1, max(0, int(np.log10(max(n, 1.0)) // 3)))
    return f"{n / 1000.0**k:.3g} {units[k]}"


def _fail(scene, key, what):
    raise SceneError(f"{scene.source}: {key}: {what}")
