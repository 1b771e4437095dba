"""Compiling opendyn's kernels, said out loud: a one-line notice before numba starts compiling,
a progress bar while it does, and the seconds it took.

numba compiles a kernel the first time it is called with a new combination of argument types,
then caches the machine code on disk (opendyn._runtime.kernel_cache), so a later process loads it in
milliseconds. A listener on numba's "numba:compile" events sees every real compilation (a cache
hit raises no event), so:
  - a warm cache prints nothing;
  - the first compilation of a call prints one line on stderr (what, why, about how long, that it
    happens once per machine and opendyn version) and a bar that counts the pieces compiled;
  - `compiling(what, pieces)` announces a planned compilation of known size (a simulation's
    loop, `opendyn compile`): the bar then moves over those pieces.
`compile_seconds()` is the total time spent compiling in this process.
"""

from __future__ import annotations

import sys
import threading
import time
from contextlib import contextmanager

from numba.core import event

from .kernel_cache import CACHE_DIR

_lock = threading.RLock()


class _Watch(event.Listener):
    """Counts and times opendyn's compilations; draws the notice and the bar."""

    def __init__(self):
        self.depth = 0  # nested compilations in progress (a kernel compiles its callees)
        self.seconds = 0.0  # total seconds of top-level compilations
        self.started = 0.0
        self.bar = None
        self.plan = None  # (what, pieces, estimate) of an announced compilation
        self.quiet = False

    def on_start(self, ev):
        dispatcher = ev.data["dispatcher"]
        if not dispatcher.py_func.__module__.startswith("opendyn"):
            return
        with _lock:
            if self.depth == 0:
                self.started = time.perf_counter()
                if self.bar is None and not self.quiet:
                    self._announce(dispatcher)
            self.depth += 1
            if self.bar is not None:
                self.bar.set_postfix_str(dispatcher.py_func.__name__, refresh=False)

    def on_end(self, ev):
        dispatcher = ev.data["dispatcher"]
        if not dispatcher.py_func.__module__.startswith("opendyn"):
            return
        with _lock:
            self.depth -= 1
            if self.depth > 0:
                return
            self.seconds += time.perf_counter() - self.started
            if self.plan is None and self.bar is not None:
                self.bar.update(1)
                self.bar.close()
                self.bar = None

    def _announce(self, dispatcher):
        """The notice line, then a bar (planned pieces, or one kernel and its callees)."""
        from tqdm import tqdm

        if self.plan is not None:
            what, pieces, estimate = self.plan
        else:
            what, pieces = f"{dispatcher.py_func.__module__}.{dispatcher.py_func.__name__}", 1
            estimate = "a few seconds"
        where = f"cached in {CACHE_DIR}" if CACHE_DIR else "no writable cache: every process"
        print(
            f"opendyn: compiling {what} for this machine ({estimate} on 2 cores; once per "
            f"machine and opendyn version, {where})",
            file=sys.stderr,
            flush=True,
        )
        self.bar = tqdm(
            total=pieces,
            unit="piece",
            desc="compiling",
            file=sys.stderr,
            leave=False,
            disable=None,  # no bar when stderr is not a terminal; the notice line stays
            bar_format="{desc}: {percentage:3.0f}%|{bar}| {n}/{total} pieces "
            "[{elapsed}<{remaining}{postfix}]",
        )


_watch = _Watch()
event.register("numba:compile", _watch)


def compile_seconds() -> float:
    """Seconds this process has spent compiling opendyn kernels so far."""
    return _watch.seconds


@contextmanager
def compiling(what: str, pieces: int, estimate: str):
    """Announce a compilation of `pieces` steps, each started by the block with `step()`:
    if any step compiles, one notice names `what` and its `estimate`, and the bar moves by
    one per step; if everything loads from the cache, nothing is printed.

        with compiling("the simulation loop", 3, "about 15 s") as step:
            for piece in pieces:
                piece()
                step()
    """
    with _lock:
        outer = _watch.plan
        _watch.plan = (what, pieces, estimate)

    def step():
        with _lock:
            if _watch.bar is not None:
                _watch.bar.update(1)

    try:
        yield step
    finally:
        with _lock:
            _watch.plan = outer
            if outer is None and _watch.bar is not None:
                _watch.bar.close()
                _watch.bar = None


@contextmanager
def quiet():
    """No notice and no bar inside the block (the caller shows its own progress)."""
    with _lock:
        before = _watch.quiet
        _watch.quiet = True
    try:
        yield
    finally:
        with _lock:
            _watch.quiet = before


def core_calls(model, batch=64):
    """(name, call) for every public core function on `model`, single states, then batches of
    `batch` states, then the constraint functions: what `opendyn compile` runs so that numba
    compiles them ahead of time (the kernels' types do not depend on the robot, so one small
    model compiles them for every robot), and what scripts/bench_coldstart.py times."""
    import numpy as np

    import opendyn as od

    rng = np.random.default_rng(0)
    q, qd, qdd = rng.normal(size=(3, model.nv))
    Q, QD, QDD = rng.normal(size=(3, batch, model.nv))
    frame = model.body_names[-1]  # a frame that moves with every joint above it
    point = od.PointToWorld(frame)
    calls = [
        ("inverse_dynamics", lambda: od.inverse_dynamics(model, q, qd, qdd)),
        (
            "inverse_dynamics f_tip",
            lambda: od.inverse_dynamics(model, q, qd, qdd, f_tip={frame: np.ones(6)}),
        ),
        ("mass_matrix", lambda: od.mass_matrix(model, q)),
        ("gravity_forces", lambda: od.gravity_forces(model, q)),
        ("coriolis_forces", lambda: od.coriolis_forces(model, q, qd)),
        ("bias_forces", lambda: od.bias_forces(model, q, qd)),
        ("coriolis_matrix", lambda: od.coriolis_matrix(model, q, qd)),
        ("christoffel_symbols", lambda: od.christoffel_symbols(model, q)),
    ]
    for m in ("aba", "crba", "newton_euler"):
        calls.append(
            (f"forward_dynamics {m}", lambda m=m: od.forward_dynamics(model, q, qd, qdd, method=m))
        )
    calls += [
        ("frame_pose", lambda: od.frame_pose(model, q, frame)),
        ("jacobian space", lambda: od.jacobian(model, q, frame)),
        ("jacobian body", lambda: od.jacobian(model, q, frame, expressed_in="body")),
        ("kinetic_energy", lambda: od.kinetic_energy(model, q, qd)),
        ("potential_energy", lambda: od.potential_energy(model, q)),
        ("integrate", lambda: od.integrate(model, q, qd, 0.01)),
        (
            "task_space_mass_matrix",
            lambda: od.task_space_mass_matrix(model, q, frame, damping=1e-6),
        ),
        ("frame_acceleration", lambda: od.frame_acceleration(model, q, qd, qdd, frame)),
        ("center_of_mass", lambda: od.center_of_mass(model, q)),
        ("centroidal_momentum_matrix", lambda: od.centroidal_momentum_matrix(model, q)),
        ("centroidal_momentum", lambda: od.centroidal_momentum(model, q, qd)),
        ("torque_regressor", lambda: od.torque_regressor(model, q, qd, qdd)),
        ("batch inverse_dynamics", lambda: od.inverse_dynamics(model, Q, QD, QDD)),
        ("batch mass_matrix", lambda: od.mass_matrix(model, Q)),
        ("batch bias_forces", lambda: od.bias_forces(model, Q, QD)),
        ("batch coriolis_matrix", lambda: od.coriolis_matrix(model, Q, QD)),
        ("batch christoffel_symbols", lambda: od.christoffel_symbols(model, Q)),
    ]
    for m in ("aba", "crba", "newton_euler"):
        calls.append(
            (
                f"batch forward_dynamics {m}",
                lambda m=m: od.forward_dynamics(model, Q, QD, QDD, method=m),
            )
        )
    calls += [
        ("batch frame_pose", lambda: od.frame_pose(model, Q, frame)),
        ("batch jacobian", lambda: od.jacobian(model, Q, frame)),
        ("batch kinetic_energy", lambda: od.kinetic_energy(model, Q, QD)),
        ("batch potential_energy", lambda: od.potential_energy(model, Q)),
        ("batch integrate", lambda: od.integrate(model, Q, QD, 0.01)),
        ("batch center_of_mass", lambda: od.center_of_mass(model, Q)),
        ("batch centroidal_momentum_matrix", lambda: od.centroidal_momentum_matrix(model, Q)),
        ("batch centroidal_momentum", lambda: od.centroidal_momentum(model, Q, QD)),
        ("batch torque_regressor", lambda: od.torque_regressor(model, Q, QD, QDD)),
        ("constraint_jacobian", lambda: od.constraint_jacobian(model, q, point)),
        ("constraint_drift", lambda: od.constraint_drift(model, q, qd, point)),
        ("constraint_error", lambda: od.constraint_error(model, q, point, q_bound=q)),
        (
            "constrained_forward_dynamics",
            lambda: od.constrained_forward_dynamics(model, q, qd, qdd, point),
        ),
    ]
    return calls


def compile_ahead(scenes, functions, out=sys.stderr, simulations=True, announce=True):
    """Compile (or load from the cache) what `scenes` (opendyn.Scene objects) need, their
    rollouts and, with `simulations`, their simulate() (a scene with a Python controller has
    only that), and with `functions` every public core function, with one bar over the items
    on `out`. announce=False: say nothing unless something compiles (then the usual notice on
    stderr). Returns [(item, seconds)]."""
    from tqdm import tqdm

    from ..io.urdf import load_urdf
    from ..sim.effects import python_control
    from ..sim.rollout import rollout
    from ..sim.simulate import simulate

    items = []
    if functions:
        items += core_calls(load_urdf("double_pendulum"))
    for scene in scenes:
        run = scene.run
        short = scene.replace_run(duration=run.dt, output_dt=run.dt)
        compiled = python_control.record(scene) is None  # else it runs with simulate only
        if simulations or not compiled:
            items.append((f"scene {scene.name}", lambda s=short: simulate(s)))
        if compiled:  # a sweep's workers roll its runs out
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
