"""`opendyn compile` and `opendyn info --cache`: the kernels compiled into the cache ahead of time
(every public core function's first call, `core_calls`, and each scene's simulation and
rollout, `compile_ahead`), and where that cache is."""

from __future__ import annotations

import os
import sys
import time

import numpy as np

from .._runtime.compile_notice import compiling, quiet
from .._runtime.kernel_cache import CACHE_DIR, CACHE_WHERE, SHIPPED_FOLDER
from .._runtime.kernel_target import CHOSEN, target
from .._runtime.shipped_kernels import export_used
from ..algorithm import (
    centroidal,
    christoffel,
    configuration,
    constraints,
    crba,
    energy,
    forward,
    kinematics,
    regressor,
    rnea,
    task_space,
)
from ..algorithm.collision import queries
from ..errors import SceneError
from ..io.scene.files import load_scene, shipped_scenes
from ..io.urdf import load_urdf
from ..multibody.constraint_objects import PointToWorld
from ..sim.effects import python_control
from ..sim.rollout import rollout
from ..sim.simulate import simulate


def _compile_ahead(args) -> int:
    """opendyn compile: the scenes named (or, with --all or nothing named, every core function
    and every shipped scene whose robot is installed), compiled into the kernel cache."""
    names = args.scenes or []
    everything = args.all or not names
    scenes, skipped = [], []
    for name in list(shipped_scenes()) if everything else names:
        try:
            scenes.append(load_scene(name))
        except SceneError as e:
            if not everything:
                raise
            skipped.append(f"{name} ({e})")
    if skipped and args.export:
        for name in skipped:
            print(f"opendyn compile: cannot export scene {name}", file=sys.stderr)
        print("opendyn compile: --export ships every shipped scene's kernels; install what "
              "the scenes above need (pip install example-robot-data) first", file=sys.stderr)
        return 1
    t0 = time.perf_counter()
    # a wheel ships what `opendyn simulate` and the functions need; a sweep compiles its
    # rollout loop on its first run
    done = compile_ahead(scenes, functions=everything, rollouts=not args.export)
    for name in skipped:
        print(f"skipped scene {name}", file=sys.stderr)
    print(f"compiled {len(done)} items in {time.perf_counter() - t0:.1f} s")
    if args.export:
        entries, size = export_used(args.export)
        print(f"exported {entries} kernels ({size / 1e6:.1f} MB) into {args.export}")
    return 0


def _cache_info() -> int:
    """opendyn info --cache: the kernel cache folder, why it is there, and its size."""
    print(f"kernel cache  {CACHE_DIR or 'none: kernels are compiled in every process'}")
    print(f"chosen as     {CACHE_WHERE} (first writable of NUMBA_CACHE_DIR, the per-user cache, "
          "the package folder)")
    name, features = target()
    print(f"compiled for  CPU {name!r}{' with ' + features if features else ''}: {CHOSEN}")
    print(f"shipped       {SHIPPED_FOLDER or 'none (a source install; a built wheel ships them)'}")
    if CACHE_DIR and os.path.isdir(CACHE_DIR):
        files = [os.path.join(d, f) for d, _, fs in os.walk(CACHE_DIR) for f in fs]
        size = sum(os.path.getsize(f) for f in files)
        print(f"holds         {len(files)} files, {size / 1e6:.1f} MB")
    return 0


def core_calls(model, batch=64):
    """(name, call) for every public core function on `model`, single states, then batches of
    `batch` states, then the constraint functions: what `opendyn compile` runs so that numba
    compiles them ahead of time (the kernels' types do not depend on the robot, so one small
    model compiles them for every robot), and what scripts/bench_coldstart.py times."""
    rng = np.random.default_rng(0)
    q, qd, qdd = rng.normal(size=(3, model.nv))
    Q, QD, QDD = rng.normal(size=(3, batch, model.nv))
    frame = model.body_names[-1]  # a frame that moves with every joint above it
    point = PointToWorld(frame)
    calls = [
        ("inverse_dynamics", lambda: rnea.inverse_dynamics(model, q, qd, qdd)),
        (
            "inverse_dynamics f_tip",
            lambda: rnea.inverse_dynamics(model, q, qd, qdd, f_tip={frame: np.ones(6)}),
        ),
        ("mass_matrix", lambda: crba.mass_matrix(model, q)),
        ("gravity_forces", lambda: rnea.gravity_forces(model, q)),
        ("coriolis_forces", lambda: rnea.coriolis_forces(model, q, qd)),
        ("bias_forces", lambda: rnea.bias_forces(model, q, qd)),
        ("coriolis_matrix", lambda: christoffel.coriolis_matrix(model, q, qd)),
        ("christoffel_symbols", lambda: christoffel.christoffel_symbols(model, q)),
    ]
    for m in ("aba", "crba", "newton_euler"):
        calls.append(
            (f"forward_dynamics {m}", lambda m=m: forward.forward_dynamics(model, q, qd, qdd, method=m))
        )
    calls += [
        ("frame_pose", lambda: kinematics.frame_pose(model, q, frame)),
        ("jacobian space", lambda: kinematics.jacobian(model, q, frame)),
        ("jacobian body", lambda: kinematics.jacobian(model, q, frame, expressed_in="body")),
        ("kinetic_energy", lambda: energy.kinetic_energy(model, q, qd)),
        ("potential_energy", lambda: energy.potential_energy(model, q)),
        ("integrate", lambda: configuration.integrate(model, q, qd, 0.01)),
        (
            "task_space_mass_matrix",
            lambda: task_space.task_space_mass_matrix(model, q, frame, damping=1e-6),
        ),
        ("frame_acceleration", lambda: task_space.frame_acceleration(model, q, qd, qdd, frame)),
        ("center_of_mass", lambda: centroidal.center_of_mass(model, q)),
        ("centroidal_momentum_matrix", lambda: centroidal.centroidal_momentum_matrix(model, q)),
        ("centroidal_momentum", lambda: centroidal.centroidal_momentum(model, q, qd)),
        ("torque_regressor", lambda: regressor.torque_regressor(model, q, qd, qdd)),
        ("distances", lambda: queries.distances(model, q)),
        ("collisions", lambda: queries.collisions(model, q)),
        ("batch inverse_dynamics", lambda: rnea.inverse_dynamics(model, Q, QD, QDD)),
        ("batch mass_matrix", lambda: crba.mass_matrix(model, Q)),
        ("batch bias_forces", lambda: rnea.bias_forces(model, Q, QD)),
        ("batch coriolis_matrix", lambda: christoffel.coriolis_matrix(model, Q, QD)),
        ("batch christoffel_symbols", lambda: christoffel.christoffel_symbols(model, Q)),
    ]
    for m in ("aba", "crba", "newton_euler"):
        calls.append(
            (
                f"batch forward_dynamics {m}",
                lambda m=m: forward.forward_dynamics(model, Q, QD, QDD, method=m),
            )
        )
    calls += [
        ("batch frame_pose", lambda: kinematics.frame_pose(model, Q, frame)),
        ("batch jacobian", lambda: kinematics.jacobian(model, Q, frame)),
        ("batch kinetic_energy", lambda: energy.kinetic_energy(model, Q, QD)),
        ("batch potential_energy", lambda: energy.potential_energy(model, Q)),
        ("batch integrate", lambda: configuration.integrate(model, Q, QD, 0.01)),
        ("batch center_of_mass", lambda: centroidal.center_of_mass(model, Q)),
        ("batch centroidal_momentum_matrix", lambda: centroidal.centroidal_momentum_matrix(model, Q)),
        ("batch centroidal_momentum", lambda: centroidal.centroidal_momentum(model, Q, QD)),
        ("batch torque_regressor", lambda: regressor.torque_regressor(model, Q, QD, QDD)),
        ("constraint_jacobian", lambda: constraints.constraint_jacobian(model, q, point)),
        ("constraint_drift", lambda: constraints.constraint_drift(model, q, qd, point)),
        ("constraint_error", lambda: constraints.constraint_error(model, q, point, q_bound=q)),
        (
            "constrained_forward_dynamics",
            lambda: constraints.constrained_forward_dynamics(model, q, qd, qdd, point),
        ),
    ]
    return calls


def compile_ahead(
    scenes, functions, out=sys.stderr, simulations=True, announce=True, rollouts=True
):
    """Compile (or load from the cache) what `scenes` (opendyn.Scene objects) need: with
    `rollouts` their rollouts, with `simulations` their simulate() (a scene with a Python
    controller has only that), and with `functions` every public core function, with one bar
    over the items on `out`. announce=False: say nothing unless something compiles (then the
    usual notice on stderr). Returns [(item, seconds)]."""
    from tqdm import tqdm

    items = []
    if functions:
        items += core_calls(load_urdf("double_pendulum"))
    for scene in scenes:
        run = scene.run
        short = scene.replace_run(duration=run.dt, output_dt=run.dt)
        compiled = python_control.record(scene) is None  # else it runs with simulate only
        if simulations or not compiled:
            items.append((f"scene {scene.name}", lambda s=short: simulate(s)))
        if compiled and rollouts:  # a sweep's workers roll its runs out
            items.append(
                (f"rollout {scene.name}", lambda s=short: rollout(s, threads=1).trajectory(0))
            )
    done = []
    if announce:
        where = CACHE_DIR or "nowhere (no writable cache folder: set NUMBA_CACHE_DIR)"
        print(f"opendyn: compiling {len(items)} items ahead of time into {where}", file=out)
        watch = quiet()
        items = tqdm(items, desc="compiling", unit="item", file=out, disable=None)
    else:
        watch = compiling(f"{len(items)} items ahead of time", len(items), "20-80 s each")
    with watch as step:
        for name, call in items:
            if announce:
                items.set_postfix_str(name, refresh=True)
            tic = time.perf_counter()
            call()
            done.append((name, time.perf_counter() - tic))
            if step is not None:
                step()
    return done
