"""Before a run: what it will need and whether it can start, checked before anything is allocated
or compiled.

    steps        N = duration / dt            a whole number, at most 2^53 (scene.check_fixed_steps)
    samples      K = N / every + 1            (adaptive: ceil(duration / output_dt) + 1)
    memory       8 K (3 + nq + 2 nv + 2 + 7 P + 2 c)  bytes, three times over, below what the
                 process may allocate (opendyn._runtime.memory: limits and cgroups included)
    start        |qd0_k| <= max_speed,  lower_j <= q0_j <= upper_j,  K(q0, qd0), U(q0) finite,
                 |phi(q0)|, |A(q0) qd0| <= CONSTRAINT_TOLERANCE, no contact point deep in the ground
                 or in another body

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
from ..algorithm.energy import energies
from ..errors import SceneError, SceneWarning
from ..multibody.joints import FREE
from . import effects
from .record import contact_record, geometry_contact_record
from .run import MAX_STEPS, check_fixed_steps

# the record's arrays are built, then energies, contact and the outputs' copies: room for the
# record three times (measured: a 1e6-sample run saved as .npz and CSV peaked at 2.45 times it)
_RECORD_COPIES = 3
# how deep a contact point may start in the ground (m), beyond the depth the robot's weight
# would press it to
START_DEPTH = 1e-3


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
    Simulator.reset): its velocities within max_speed, its positions within the joint limits,
    its constraints met, its contact points not inside the ground or each other, its energy
    finite (SceneError naming the key to change; SceneWarning)."""
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
    """Refuse a start with a contact point deeper in the ground than START_DEPTH or, when its
    weight alone would press the robot deeper, than twice that depth m g / k: the spring would
    hold energy the scene never meant to give, and throw the robot (a ball 5 cm deep in a
    1e5 N/m ground got 125 J and flew 13 m up)."""
    contact = effects.contact.record(scene)
    if contact is None:
        return
    model = scene.model
    q, qd = np.array(scene.q0)[None], np.array(scene.qd0)[None]
    _, _, depth = contact_record(model, effects.contact.pack(contact, model), q, qd)
    weight = model._total_mass * np.linalg.norm(scene.gravity if scene.gravity is not None else 0)
    allowed = max(START_DEPTH, 2.0 * weight / contact.stiffness)
    k = int(np.argmax(depth[0]))
    d = float(depth[0, k])
    if not d > allowed:
        return
    raise_by = "initial.base_position (its z)" if model.floating_base else "initial.q"
    _fail(
        scene,
        "initial",
        f"the contact point {contact.points[k].name!r} starts {d:.3g} m inside the ground "
        f"(z = {contact.ground_height:g} m), where its spring (effects.contact.stiffness = "
        f"{contact.stiffness:g} N/m) would hold {0.5 * contact.stiffness * d * d:.3g} J and "
        f"throw the robot; start it above the ground (raise {raise_by}, or lower "
        "effects.contact.ground_height), or check the point's radius",
    )


def _check_geometry_start(scene):
    """The same refusal for the contact between collision geometries: no contact point at the
    initial state deeper than START_DEPTH or twice the depth m g / k the model's weight would
    press a pair of stiffness k to."""
    contact = effects.geometry_contact.record(scene)
    if contact is None:
        return
    model = scene.model
    params = effects.geometry_contact.pack(contact, model)
    q, qd = np.array(scene.q0)[None], np.array(scene.qd0)[None]
    table = geometry_contact_record(model, params, q, qd)
    if not len(table):
        return
    weight = model._total_mass * np.linalg.norm(scene.gravity if scene.gravity is not None else 0)
    k_pair = params[2][table.pair, 0]
    excess = table.depth - np.maximum(START_DEPTH, 2.0 * weight / k_pair)
    worst = int(np.argmax(excess))
    if not excess[worst] > 0:
        return
    d, k = float(table.depth[worst]), float(k_pair[worst])
    a, b = table.pair_names[table.pair[worst]]
    _fail(
        scene,
        "initial",
        f"{a!r} starts {d:.3g} m inside {b!r}, where the contact's spring (stiffness {k:g} "
        f"N/m) would hold {0.5 * k * d * d:.3g} J and throw them apart; start them apart (move "
        "the objects' positions, initial.q or initial.base_position)",
    )


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
    """The initial velocities within max_speed, the initial positions within the joint limits."""
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
