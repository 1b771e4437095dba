"""What accuracy costs in time: integrators and steps, forward-dynamics algorithms, effects.

    python scripts/accuracy_vs_time.py             # the full study (5-7 min on 2 cores)
    python scripts/accuracy_vs_time.py --quick     # the same pipeline on small sweeps (< 2 min)
    python scripts/accuracy_vs_time.py --docs      # the full study, published in docs/study/

1. Integrators. Each scene runs with every integrator over a sweep of steps (tolerances for the
   adaptive dopri5). The error of a run is max_j |q_j - q_ref,j| (rad or m) at the final time and
   the maximum over the recorded samples, against a reference run: dopri5 at rtol = atol = 1e-12,
   whose own error is bounded by its distance to dopri5 at 1e-11 (a run ten times less accurate).
   Reported with it: the energy error max_t |E - E(0) - W_applied - W_passive| (the drift, on a
   conservative scene), the dynamics evaluations and the wall time (best of a few runs, kernels
   loaded). The convergence order is the slope of log(final error) against log(step) (against
   log(rtol) for dopri5) over the four smallest steps whose error lies between 100x the
   reference's and 0.1.
2. The constrained scene. The shipped four-bar linkage (one loop closure; 5 s, quick 2 s) with
   every integrator over the same sweeps, with the scene's Baumgarte stabilisation and without
   it (baumgarte = None): the loop-closure violation (max and final |phi| (m), max |A qd| (m/s)
   over the samples), the state error against dopri5 at 1e-12 with Baumgarte, evaluations and
   wall time; the convergence order of max |phi| against step (fitted as for the errors, above
   100x the reference's own violation); the fastest run with max |phi| <= 1e-6 m and 1e-9 m.
   An integrator the simulator refuses on a constrained scene (SceneError) is recorded as not
   supported.
3. Algorithms. Forward dynamics by ABA, CRBA + Cholesky and n RNEA calls + Cholesky (the seed's
   method) on random serial chains of n links: time per call inside a compiled loop (what a
   simulation step pays), time per call of od.forward_dynamics and of Pinocchio's aba from
   Python, and the growth exponent p of time ~ n^p. Then accuracy as M(q) becomes
   ill-conditioned: the residual ||M qdd + h - tau|| / ||tau|| on chains whose links alternate
   between 1 kg and a lighter mass.
4. Effects. The cost of every stage of the step (as `opendyn simulate --profile` reports it) on
   scenes that switch every effect on.
5. Contact. The shipped ball drop (1 kg on k = 1e5 N/m, no damping or friction; 1 s, two
   bounces; quick 0.5 s) and Solo12 drop (k = 1e5, d = 300, mu = 0.8, PD on the joints; 1 s, the
   landing at 0.25 s and the settling; quick 0.4 s), and a box dropped spinning onto a table
   (box_on_table's box let go 3 cm above it, contact between collision geometries: corner, edge
   and face manifolds, implicit Euler's held contact points and normals; 0.5 s, quick 0.3 s)
   with every integrator over a sweep of steps from 10 ms to 10 us (dopri5: tolerances), samples
   every 1 ms. Per run: its status (complete; refused before it starts by the simulator's
   stability check, with the stiffest cause the check names; failed, with where it stopped), max
   and final state error against dopri5 (at 1e-12 on the ball, 1e-11 on Solo12, where 1e-12
   underflows its step at touchdown, 1e-12 on the box; each bounded by its distance to the run
   ten times looser), the energy-balance residual max |energy_error|, the deepest penetration
   and its error against the reference's at the same samples, evaluations and wall time.
   Stability per fixed-step integrator: the largest step run, the smallest refused, the largest
   that completes and the largest whose max error is within 0.1 (m or rad). The hard contact
   model on each scene (model = "hard": contacts as constraints of semi-implicit Euler's
   velocity-level step, solved by ADMM; the compliant law's stiffness, damping and slip velocity
   removed, the friction kept) over the same fixed steps (quick: 10 ms to 0.5 ms and 50 us): per
   run its status, steps and wall time, the solves' unconverged steps and worst residual, the
   deepest penetration at the samples (a contact within the margin, short of the surface,
   counts as 0), the error against the hard model's own run at the finest step and the order of
   its max error over the steps from ten times the finest, and the distance to the compliant
   reference (what rigid contact changes against k = 1e5, an error of neither); the largest
   usable step of each model side by side. Then what the stiffness costs: the ball drop (0.5 s)
   at k = 1e4 to 1e7 N/m, whose rate sqrt(k/m) sets RK4's stability step 2.8 / rate, and each
   integrator's fastest run within 1e-3 m.

Writes into --out (default accuracy_study/ in the current folder): accuracy_vs_time.png (error
against wall time, one curve per integrator: the Pareto plot), convergence.png (error against
step), constraint.png (the four-bar's max violation against step and wall time; solid with
Baumgarte, dashed without), algorithms.png, contact.png (error against wall time on the three
contact scenes; the stiffness cost), study.md (every table) and study.json (every number; the
four-bar under "constrained", contact under "contact"). Only --docs writes the published study,
docs/study/, and then study.md starts with a header that says when, on what machine and with
which versions it ran and the command that reproduces it (scripts/docs_page.py); --docs refuses
--quick (quick results must never replace the published study) and --out.
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import json
import pathlib
import re
import sys
import time

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from tqdm import tqdm  # noqa: E402

import opendyn as od  # noqa: E402
from opendyn.algorithm.forward import METHODS, NO_ARMATURE  # noqa: E402
from opendyn.io.scene.variants import Variants  # noqa: E402
from opendyn.sim import effects, step  # noqa: E402
from opendyn.sim.profile import stage_costs  # noqa: E402
from opendyn.sim.scene import thaw  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "tests"), str(ROOT / "scripts")]
import docs_page  # noqa: E402
from randtree import random_chain_urdf  # noqa: E402

DEFAULT_OUT = "accuracy_study"  # in the current folder: a trial run never touches the docs
DOCS_OUT = ROOT / "docs" / "study"

OUTPUT_DT = 0.02  # s: every fixed step below divides it, so all runs share the sample times
FIXED = ("euler", "semi_implicit_euler", "implicit_euler", "rk4")
LABEL = {
    "euler": "explicit Euler",
    "semi_implicit_euler": "semi-implicit Euler",
    "implicit_euler": "implicit Euler",
    "rk4": "RK4",
    "dopri5": "DOPRI5 (adaptive)",
}
STEPS = {
    "full": {
        "first_order": [1e-2, 5e-3, 2e-3, 1e-3, 5e-4, 2e-4, 1e-4, 5e-5, 2e-5, 1e-5],
        "rk4": [2e-2, 1e-2, 5e-3, 2e-3, 1e-3, 5e-4, 2e-4, 1e-4],
        "dopri5": [1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10],
    },
    "quick": {
        "first_order": [1e-2, 2e-3, 5e-4, 1e-4],
        "rk4": [1e-2, 5e-3, 2e-3, 1e-3],
        "dopri5": [1e-3, 1e-5, 1e-7, 1e-9],
    },
}
# (key, shipped scene, title, conservative, duration full, duration quick)
SCENES = [
    ("double_pendulum", "double_pendulum_swing", "double pendulum (chaotic)", True, 3.0, 1.0),
    ("ur5", "ur5_falling", "UR5 falling (gravity, damping)", False, 2.0, 0.5),
    ("panda", "panda_computed_torque", "Panda (computed torque, friction)", False, 2.0, 0.5),
    ("limits", "planar_3r_limits", "planar 3R on stiff limits (k = 1e5)", False, 2.0, 0.5),
]
REFERENCE_TOL, CHECK_TOL = 1e-12, 1e-11
TARGETS = (1e-2, 1e-4, 1e-6, 1e-8)  # rad: max error over the run, for the recommendations


# ---------------------------------------------------------------- 1. integrators


def timed_run(scene, repeats):
    """The trajectory of `scene` and its best wall time (s) over `repeats` runs (one when the
    first takes longer than a second)."""
    traj = od.simulate(scene, raise_on_failure=False)
    wall = traj.stats["wall_s"]
    for _ in range(repeats - 1):
        if wall > 1.0:
            break
        wall = min(wall, od.simulate(scene, raise_on_failure=False).stats["wall_s"])
    return traj, wall


def sample_rows(traj, ref):
    """The rows of the reference's record at the run's sample times (the reference records
    every one of them: same output_dt, or the run's a multiple of it)."""
    rows = np.minimum(np.searchsorted(ref.t, traj.t - 1e-9), len(ref.t) - 1)
    assert np.allclose(ref.t[rows], traj.t, atol=1e-9), "sample times differ"
    return rows


def state_error(traj, ref):
    """(final, max over samples) of max_j |q_j - q_ref,j| at the run's sample times."""
    err = np.max(np.abs(traj.q - ref.q[sample_rows(traj, ref)]), axis=1)
    return float(err[-1]), float(err.max())


def fit_order(x, err, floor):
    """Slope of log(err) against log(x) over the (up to) four smallest x whose error lies in
    100 floor < err < 0.1 (the asymptotic range, clear of the reference's own error), or None
    when fewer than three points lie there."""
    x, err = np.asarray(x, float), np.asarray(err, float)
    keep = np.flatnonzero(np.isfinite(err) & (err > 100 * floor) & (err < 0.1))
    keep = keep[np.argsort(x[keep])][:4]
    if len(keep) < 3:
        return None
    return float(np.polyfit(np.log(x[keep]), np.log(err[keep]), 1)[0])


def convergence_orders(runs, floor):
    """{integrator: fit_order of its complete runs' final errors against their steps}."""
    orders = {}
    for name in LABEL:
        done = [r for r in runs if r["integrator"] == name and r["complete"]]
        orders[name] = fit_order(
            [r["step"] for r in done], [r["error_final"] for r in done], floor
        )
    return orders


def integrator_study(mode, repeats):
    """Every scene x integrator x step: errors, energy error, evaluations, wall time."""
    results = []
    sweeps = STEPS[mode]
    for key, shipped, title, conservative, full_T, quick_T in SCENES:
        duration = full_T if mode == "full" else quick_T
        base = od.load_scene(shipped).replace_run(duration=duration, output_dt=OUTPUT_DT)
        ref = od.simulate(
            base.replace_run(integrator="dopri5", rtol=REFERENCE_TOL, atol=REFERENCE_TOL)
        )
        check = od.simulate(base.replace_run(integrator="dopri5", rtol=CHECK_TOL, atol=CHECK_TOL))
        ref_bound = state_error(check, ref)[1]
        runs = []
        plan = [(name, dt) for name in FIXED for dt in sweeps[_sweep(name)]]
        plan += [("dopri5", tol) for tol in sweeps["dopri5"]]
        for name, x in tqdm(plan, desc=title, leave=False):
            settings = dict(integrator=name)
            settings.update(dt=x) if name != "dopri5" else settings.update(rtol=x, atol=x)
            traj, wall = timed_run(base.replace_run(**settings), repeats)
            row = dict(integrator=name, step=x, wall_s=wall, complete=traj.complete)
            row.update(evaluations=int(traj.stats["evaluations"]), steps=int(traj.stats["steps"]))
            if traj.complete:
                final, worst = state_error(traj, ref)
                energy = float(np.max(np.abs(traj.energy_error)))
                row.update(error_final=final, error_max=worst, energy_error=energy)
            else:
                row.update(failed_at=float(traj.t[-1]) if len(traj.t) else 0.0)
            runs.append(row)
        orders = convergence_orders(runs, ref_bound)
        results.append(
            dict(
                key=key,
                scene=shipped,
                title=title,
                conservative=conservative,
                duration=duration,
                reference=dict(
                    rtol=REFERENCE_TOL,
                    error_bound=ref_bound,
                    steps=int(ref.stats["steps"]),
                    energy_error=float(np.max(np.abs(ref.energy_error))),
                ),
                runs=runs,
                orders=orders,
                pareto=pareto_front(runs),
                recommendations=recommend(runs),
            )
        )
    return results


def _sweep(integrator):
    return "rk4" if integrator == "rk4" else "first_order"


def pareto_front(runs):
    """The runs that no other run beats on both wall time and max error, fastest first."""
    done = sorted((r for r in runs if r["complete"]), key=lambda r: (r["wall_s"], r["error_max"]))
    front, best = [], np.inf
    for r in done:
        if r["error_max"] < best:
            front.append(r)
            best = r["error_max"]
    return front


def recommend(runs, targets=TARGETS, measure="error_max"):
    """For each target: the fastest complete run whose `measure` (max error, rad; or max
    violation, m) meets it (None when none does)."""
    out = {}
    for target in targets:
        ok = [r for r in runs if r["complete"] and r[measure] <= target]
        out[target] = min(ok, key=lambda r: r["wall_s"]) if ok else None
    return out


# ---------------------------------------------------------------- 2. the constrained scene

# (key, shipped scene, title, duration full, duration quick). The quick run lasts 2 s, about two
# crank revolutions: the stabilised violation peaks on the first revolution, and before its end
# (1 s) RK4 without stabilisation has not yet drifted past RK4 with it.
CONSTRAINED = ("four_bar", "four_bar", "four-bar linkage (one loop closure)", 5.0, 2.0)
STABILISATION = {"baumgarte": "with Baumgarte", "none": "without stabilisation"}
VIOLATION_TARGETS = (1e-6, 1e-9)  # m: max |phi| over the run, for the recommendations


def _run_settings(integrator, x):
    """replace_run arguments for a fixed step x (s), or dopri5 at rtol = atol = x."""
    if integrator == "dopri5":
        return dict(integrator=integrator, rtol=x, atol=x)
    return dict(integrator=integrator, dt=x)


def refusal(error, scene):
    """The simulator's reason for refusing `scene` (a SceneError), without the scene file's
    path that opens it."""
    return str(error).removeprefix(f"{scene.source}: ")


def constrained_study(mode, repeats):
    """The four-bar (one loop closure) with every integrator x step, with the scene's Baumgarte
    stabilisation and without it: constraint violation (max and final |phi|, max |A qd|), state
    error against the reference, evaluations and wall time. A combination the simulator refuses
    (SceneError) is recorded as not supported, with its message."""
    key, shipped, title, full_T, quick_T = CONSTRAINED
    duration = full_T if mode == "full" else quick_T
    base = od.load_scene(shipped).replace_run(duration=duration, output_dt=OUTPUT_DT)
    scenes = {"baumgarte": base, "none": dataclasses.replace(base, baumgarte=None)}
    ref = od.simulate(base.replace_run(**_run_settings("dopri5", REFERENCE_TOL)))
    check = od.simulate(base.replace_run(**_run_settings("dopri5", CHECK_TOL)))
    ref_bound = state_error(check, ref)[1]
    ref_violation = float(ref.violation_position.max())
    sweeps = STEPS[mode]
    plan = [
        (stab, name, x)
        for stab in STABILISATION
        for name in LABEL
        for x in sweeps["dopri5" if name == "dopri5" else _sweep(name)]
    ]
    runs = []
    for stab, name, x in tqdm(plan, desc=title, leave=False):
        row = dict(stabilisation=stab, integrator=name, step=x)
        try:
            traj, wall = timed_run(scenes[stab].replace_run(**_run_settings(name, x)), repeats)
        except od.SceneError as e:
            row.update(supported=False, complete=False, reason=refusal(e, scenes[stab]))
            runs.append(row)
            continue
        row.update(supported=True, complete=traj.complete, wall_s=wall)
        row.update(evaluations=int(traj.stats["evaluations"]), steps=int(traj.stats["steps"]))
        if traj.complete:
            final, worst = state_error(traj, ref)
            row.update(
                violation_max=float(traj.violation_position.max()),
                violation_final=float(traj.violation_position[-1]),
                velocity_violation_max=float(traj.violation_velocity.max()),
                error_final=final,
                error_max=worst,
            )
        else:
            row.update(failed_at=float(traj.t[-1]) if len(traj.t) else 0.0, reason=traj.message)
        runs.append(row)
    orders = {}
    for stab in STABILISATION:
        orders[stab] = {}
        for name in LABEL:
            done = [
                r
                for r in runs
                if r["stabilisation"] == stab and r["integrator"] == name and r["complete"]
            ]
            orders[stab][name] = fit_order(
                [r["step"] for r in done], [r["violation_max"] for r in done], ref_violation
            )
    recommendations = {
        stab: recommend(
            [r for r in runs if r["stabilisation"] == stab], VIOLATION_TARGETS, "violation_max"
        )
        for stab in STABILISATION
    }
    return dict(
        key=key,
        scene=shipped,
        title=title,
        duration=duration,
        baumgarte=list(base.baumgarte),
        reference=dict(
            rtol=REFERENCE_TOL,
            error_bound=ref_bound,
            steps=int(ref.stats["steps"]),
            violation_max=ref_violation,
            velocity_violation_max=float(ref.violation_velocity.max()),
        ),
        runs=runs,
        orders=orders,
        recommendations=recommendations,
    )


# ---------------------------------------------------------------- 3. algorithms


def chain_model(n, tmp):
    """A random serial chain of n moving joints (revolute, continuous, prismatic; random axes,
    offsets and inertias): the seeded generator of the test suite."""
    path = tmp / f"chain_{n}.urdf"
    path.write_text(random_chain_urdf(1000 + n, n))
    return od.load_urdf(path), path


def kernel_time(model, method, q, qd, budget):
    """Seconds per forward-dynamics call of `method` inside a compiled loop over the states
    (q, qd): the stage-cost loop of the simulation step, with no stage rows and zero torque."""
    table = effects.StageTable(
        effects=(None,) * len(effects.registry.stages()),
        names=(),
        slots=(),
        method=method,
        armature=NO_ARMATURE,
    )
    args = (step.scene_data(model, table), -1)
    t = np.zeros(len(q))
    step.stage_cost_kernel(*args, t[:1], q[:1], qd[:1])
    tic = time.perf_counter()
    step.stage_cost_kernel(*args, t[:1], q[:1], qd[:1])
    once = max(time.perf_counter() - tic, 1e-7)
    calls = int(np.clip(budget / once, 1, len(q)))
    best = np.inf
    for _ in range(3):
        tic = time.perf_counter()
        step.stage_cost_kernel(*args, t[:calls], q[:calls], qd[:calls])
        best = min(best, (time.perf_counter() - tic) / calls)
    return best


def python_call_time(fn, states, budget):
    """Seconds per call of fn(*state) from Python, best of three passes over the states."""
    fn(*states[0])
    tic = time.perf_counter()
    fn(*states[0])
    calls = int(np.clip(budget / max(time.perf_counter() - tic, 1e-7), 1, len(states)))
    best = np.inf
    for _ in range(3):
        tic = time.perf_counter()
        for s in states[:calls]:
            fn(*s)
        best = min(best, (time.perf_counter() - tic) / calls)
    return best


def pinocchio_aba(path, model):
    """fn(q, qd, tau) -> Pinocchio's aba on the same URDF, states converted, or None without
    Pinocchio."""
    try:
        from opendyn.verify.oracle import PinocchioOracle
    except ImportError:
        return None
    try:
        oracle = PinocchioOracle(str(path), model)
    except ImportError:
        return None
    import pinocchio as pin

    def fn(q, qd, tau):
        return pin.aba(oracle.model, oracle.data, q, qd, tau)

    return fn, oracle


def growth_exponent(n, t, n_min):
    n, t = np.asarray(n, float), np.asarray(t, float)
    keep = n >= n_min
    return float(np.polyfit(np.log(n[keep]), np.log(t[keep]), 1)[0])


def method_times(model, path, rng, budget):
    """Per-call times (us) of the three forward-dynamics methods in a compiled loop, of
    od.forward_dynamics from Python and, with Pinocchio, of pin.aba from Python."""
    nv = model.nv
    q = rng.uniform(-1.0, 1.0, (2000, nv))
    qd = rng.normal(size=(2000, nv))
    tau = rng.normal(size=(2000, nv))
    row = {f"{m}_kernel_us": kernel_time(model, m, q, qd, budget) * 1e6 for m in METHODS}
    states = list(zip(q[:500], qd[:500], tau[:500]))
    row["aba_public_us"] = (
        python_call_time(
            lambda q_, qd_, tau_: od.forward_dynamics(model, q_, qd_, tau_), states, budget
        )
        * 1e6
    )
    pin_fn = pinocchio_aba(path, model)
    if pin_fn is not None:
        fn, oracle = pin_fn
        pin_states = [(oracle.q(a), oracle.v(b), oracle.v(c)) for a, b, c in states]
        row["pinocchio_aba_us"] = python_call_time(fn, pin_states, budget) * 1e6
    return row


BUNDLED = ("double_pendulum", "planar_3r", "four_bar", "ur5", "panda")  # the last two: ERD


def algorithm_study(mode, tmp):
    sizes = [2, 3, 5, 7, 10, 15, 20, 30, 50, 70, 100, 150, 200] if mode == "full" else [2, 10, 50]
    budget = 0.2 if mode == "full" else 0.01
    rng = np.random.default_rng(0)
    rows = []
    for n in tqdm(sizes, desc="chains", leave=False):
        model, path = chain_model(n, tmp)
        rows.append(dict(n=n, **method_times(model, path, rng, budget)))
    robots = []
    for name in tqdm(BUNDLED, desc="robots", leave=False):
        try:
            model = od.load_urdf(name)
        except od.URDFError:
            continue  # example-robot-data not installed
        robots.append(
            dict(robot=name, nv=model.nv, **method_times(model, model.source, rng, budget))
        )
    n_min = 20 if mode == "full" else 10
    exponents = {
        m: growth_exponent([r["n"] for r in rows], [r[f"{m}_kernel_us"] for r in rows], n_min)
        for m in METHODS
    }
    return dict(chains=rows, robots=robots, exponents=exponents, fit_from_n=n_min)


AXES = ("0 0 1", "0 1 0", "1 0 0")
STATES = 20  # random states per conditioning level


def ratio_chain_urdf(n, light):
    """A serial chain of n revolute joints (axes alternating z, y, x; links 0.3 m along x) whose
    links alternate between 1 kg and `light` kg, each a slender rod of its mass."""
    parts = ['<?xml version="1.0"?>\n<robot name="mass_ratio_chain">\n<link name="base"/>\n']
    parent = "base"
    for k in range(n):
        m = 1.0 if k % 2 == 0 else light
        i_rod = m * 0.3**2 / 12.0  # slender rod about its centre, m L^2 / 12
        i_axis = m * 1e-4
        parts.append(
            f'<link name="l{k}"><inertial><origin xyz="0.15 0 0"/><mass value="{m!r}"/>'
            f'<inertia ixx="{i_axis!r}" ixy="0" ixz="0" iyy="{i_rod!r}" iyz="0" '
            f'izz="{i_rod!r}"/></inertial></link>\n'
            f'<joint name="j{k}" type="revolute"><parent link="{parent}"/>'
            f'<child link="l{k}"/><origin xyz="{0.3 if k else 0.0} 0 0"/>'
            f'<axis xyz="{AXES[k % 3]}"/>'
            f'<limit lower="-3" upper="3" effort="10" velocity="10"/></joint>\n'
        )
        parent = f"l{k}"
    parts.append("</robot>\n")
    return "".join(parts)


def conditioning_study(mode, tmp):
    """Residual ||M qdd + h - tau|| / ||tau|| of each method as cond(M) grows."""
    n = 8
    lights = [1.0, 1e-2, 1e-4, 1e-6, 1e-8, 1e-10, 1e-12]
    if mode == "quick":
        lights = lights[::2]
    rng = np.random.default_rng(1)
    rows = []
    for light in lights:
        path = tmp / f"ratio_{light:g}.urdf"
        path.write_text(ratio_chain_urdf(n, light))
        model = od.load_urdf(path, check_inertia=False)
        conds, residuals = [], {m: [] for m in METHODS}
        singular = {m: 0 for m in METHODS}
        for _ in range(STATES):
            q, qd, tau = rng.uniform(-1, 1, n), rng.normal(size=n), rng.normal(size=n)
            M = od.mass_matrix(model, q)
            h = od.bias_forces(model, q, qd)
            conds.append(np.linalg.cond(M))
            for m in METHODS:
                try:
                    qdd = od.forward_dynamics(model, q, qd, tau, method=m)
                except od.SingularMassMatrixError:
                    singular[m] += 1
                    continue
                residuals[m].append(np.linalg.norm(M @ qdd + h - tau) / np.linalg.norm(tau))
        row = dict(light_kg=light, cond_median=float(np.median(conds)))
        for m in METHODS:
            row[f"{m}_residual_max"] = float(max(residuals[m])) if residuals[m] else None
            row[f"{m}_singular"] = singular[m]
        rows.append(row)
    return rows


# ---------------------------------------------------------------- 4. effects


def effect_scenes():
    """Scenes that switch every effect on: the double pendulum, the UR5 and the Panda."""
    common = {
        "run": {"duration": 1.0, "dt": 1e-3},
        "effects": {
            "gravity": True,
            "damping": {"coefficients": 0.1},
            "friction": {"coefficients": 0.2, "smoothing": 0.01},
            "armature": {"values": 0.01},
            "limits": {"stiffness": 1e4, "damping": 10.0},
        },
    }
    # each starts at q = 0 inside its limits, except the Panda's elbow, whose range is
    # [-3.07, -0.07] rad: it starts mid-range
    robots = [
        ("double pendulum", {"urdf": str(ROOT / "robots" / "double_pendulum.urdf")}, "tip", {}),
        ("UR5", {"name": "ur5"}, "tool0", {}),
        ("Panda", {"name": "panda"}, "panda_hand", {"panda_joint4": -1.5}),
    ]
    scenes = []
    for title, robot, frame, q0 in robots:
        for control in ({"type": "pd", "kp": 50.0, "kd": 5.0}, {"type": "computed_torque"}):
            data = json.loads(json.dumps(common))
            data["robot"] = robot
            data["initial"] = {"q": q0}
            data["effects"]["wrench"] = [{"frame": frame, "value": [0, 0, 0.1, 0, 0, -5.0]}]
            data["control"] = dict(control, clip=True)
            if control["type"] == "computed_torque":
                data["control"].update(kp=100.0, kd=20.0, amplitude=0.2)
            scenes.append((title, od.scene_from_dict(data, source=f"<{title} study>")))
    return scenes


def effect_study(mode):
    evaluations = 20000 if mode == "full" else 4000
    out = {}
    for title, scene in tqdm(effect_scenes(), desc="effects", leave=False):
        costs, _, evals_per_step = stage_costs(scene, steps=1000, evaluations=evaluations)
        table = out.setdefault(title, {"evaluations_per_step": evals_per_step})
        for name, per_call, per_step in costs:
            if name.startswith("wrench on "):
                name = "wrench"  # one applied wrench, at the robot's tool frame
            elif name in ("step (measured)", "whole evaluation"):
                name = f"{name}, {scene.control.kind.replace('_', ' ')}"
            elif name == "integrator and loop":
                continue  # the difference of two timings: left to --profile
            table.setdefault(name, dict(per_call_us=per_call, per_step_us=per_step))
    return out


# ---------------------------------------------------------------- 5. contact

# (key, shipped scene, title, duration full, duration quick, reference rtol = atol). The ball
# falls for 0.32 s and stays 10 ms on the ground per bounce: 1 s holds two bounces, 0.5 s one.
# The quadruped lands at 0.25 s and settles by about 0.6 s. Its reference runs at 1e-11: at
# 1e-12 DOPRI5's step underflows at touchdown, where the damper's force jumps from 0 to
# d |v_z| (720 N per foot).
# The box drop is box_on_table's box let go 3 cm above the table, spinning: it lands on an edge
# and a corner, rocks onto its face and settles, the contact between collision geometries
# (points that switch from one to four, on either side of the manifolds) under each integrator;
# implicit Euler's linearisation holds the contact points and normals fixed over a step, and
# its rows show what that costs.
CONTACT_SCENES = [
    ("ball_drop", "ball_drop", "ball drop (k = 1e5, no damping or friction)", 1.0, 0.5, 1e-12),
    (
        "quadruped_drop",
        "quadruped_drop",
        "Solo12 drop (k = 1e5, d = 300, mu = 0.8, PD)",
        1.0,
        0.4,
        1e-11,
    ),
    (
        "box_drop",
        "box_on_table",
        "box drop onto a table, geometry contact (k = 1e5, d = 300, mu = 0.5)",
        0.5,
        0.3,
        1e-12,
    ),
]
BOX_DROP = {  # box_on_table's [[objects]] entry, changed
    "objects.0.position.2": 0.48,
    "objects.0.rpy": [0.2, -0.1, 0.3],
    "objects.0.angular_velocity": [1.5, -2.0, 0.5],
}
CONTACT_OUTPUT_DT = 1e-3  # s: resolves the deepest penetration of a 10 ms contact
CONTACT_STEPS = {
    "full": {
        "fixed": [1e-2, 5e-3, 2e-3, 1e-3, 5e-4, 2e-4, 1e-4, 5e-5, 2e-5, 1e-5],
        "dopri5": [1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10],
    },
    "quick": {
        "fixed": [1e-2, 1e-3, 2e-4, 2e-5, 1e-5],
        "dopri5": [1e-4, 1e-6, 1e-8],
    },
}
# The hard contact model (model = "hard": contacts as constraints of the velocity-level step,
# semi_implicit_euler, solved by ADMM) over the fixed steps; the quick run's finest, its
# reference, is 5e-5 s, so that its steps from 0.5 ms up lie HARD_FIT_FROM x above it, for the
# order's fit.
HARD_LABEL = "hard (semi-implicit Euler, ADMM)"
HARD_STEPS = {
    "full": CONTACT_STEPS["full"]["fixed"],
    "quick": [1e-2, 5e-3, 2e-3, 1e-3, 5e-4, 5e-5],
}
HARD_FIT_FROM = 10  # the hard order is fitted over steps >= this x the finest (its reference)
COMPLIANT_KEYS = ("stiffness", "damping", "slip_velocity")  # refused with model = "hard"
USABLE = 0.1  # m or rad: the max error of a run that keeps the motion's shape
STIFFNESSES = {"full": [1e4, 1e5, 1e6, 1e7], "quick": [1e5, 1e7]}  # N/m
STIFFNESS_DURATION = 0.5  # s: the ball's fall, its bounce and half its rise
STIFFNESS_TARGET = 1e-3  # m: the max error the stiffness study asks of every integrator


def penetration(traj):
    """(K, P) m: the depth of each contact point of the run at each sample, >= 0 (sphere contact:
    traj.penetration, zero off the ground; between collision geometries, the deepest point of
    each sample's contact table, P = 1, zero where none is deeper than zero: a hard run's table
    also holds the contacts within its margin, at a negative depth, their gap)."""
    if traj.contacts is None:
        return traj.penetration
    deepest = np.zeros((len(traj.t), 1))
    np.maximum.at(deepest[:, 0], traj.contacts.sample, traj.contacts.depth)
    return deepest


def contact_reference(scene, rtol):
    """The reference run of a contact scene, dopri5 at rtol = atol = `rtol`, and its summary:
    the bound on its error (its max distance to the run at 10 rtol), steps, wall time, energy
    residual and deepest penetration."""
    ref = od.simulate(scene.replace_run(**_run_settings("dopri5", rtol)))
    check = od.simulate(scene.replace_run(**_run_settings("dopri5", 10 * rtol)))
    return ref, dict(
        rtol=rtol,
        error_bound=state_error(check, ref)[1],
        steps=int(ref.stats["steps"]),
        wall_s=ref.stats["wall_s"],
        energy_error=float(np.max(np.abs(ref.energy_error))),
        penetration_max=float(penetration(ref).max()),
    )


def contact_run(scene, integrator, x, ref, repeats, compliant=None):
    """One run of a contact scene at step x (s; dopri5: rtol = atol = x) as a row. status:
    "complete", "refused" (the simulator's stability check refused the step before the run;
    reason) or "failed" (failed_at, reason). A complete run has its final and max state error
    against `ref`, max |energy_error| (J), its deepest penetration (m) at its samples and the
    distance to the reference's deepest at the same samples; a run of the hard model, its
    solves' unconverged_steps and worst_residual (m/s), and with `compliant` (the compliant
    model's reference) its final and max distance to it, compliant_final and compliant_max (m or
    rad). A fixed step longer than the scene's output_dt records every step."""
    row = dict(integrator=integrator, step=x)
    settings = _run_settings(integrator, x)
    if integrator != "dopri5":
        settings["output_dt"] = max(scene.run.output_dt, x)
    try:
        traj, wall = timed_run(scene.replace_run(**settings), repeats)
    except od.SceneError as e:
        row.update(status="refused", complete=False, reason=refusal(e, scene))
        return row
    row.update(status="complete" if traj.complete else "failed", complete=traj.complete)
    row.update(wall_s=wall, evaluations=int(traj.stats["evaluations"]))
    row.update(steps=int(traj.stats["steps"]))
    if not traj.complete:
        row.update(failed_at=float(traj.t[-1]) if len(traj.t) else 0.0, reason=traj.message)
        return row
    final, worst = state_error(traj, ref)
    deepest = float(penetration(traj).max())
    row.update(
        error_final=final,
        error_max=worst,
        energy_error=float(np.max(np.abs(traj.energy_error))),
        penetration_max=deepest,
        penetration_error=abs(deepest - float(penetration(ref)[sample_rows(traj, ref)].max())),
    )
    if "unconverged_steps" in traj.stats:
        row.update(
            unconverged_steps=int(traj.stats["unconverged_steps"]),
            worst_residual=float(traj.stats["worst_residual"]),
        )
    if compliant is not None:
        row["compliant_final"], row["compliant_max"] = state_error(traj, compliant)
    return row


def stability(runs, names=FIXED):
    """Per fixed-step integrator of `names`: the largest step the simulator runs (does not
    refuse), the smallest it refuses, the largest that completes and the largest whose max error
    is within USABLE (None where no step of the sweep is)."""
    out = {}
    for name in names:
        rows = [r for r in runs if r["integrator"] == name]
        out[name] = dict(
            largest_run=max((r["step"] for r in rows if r["status"] != "refused"), default=None),
            smallest_refused=min(
                (r["step"] for r in rows if r["status"] == "refused"), default=None
            ),
            largest_complete=max((r["step"] for r in rows if r["complete"]), default=None),
            largest_usable=max(
                (r["step"] for r in rows if r["complete"] and r["error_max"] <= USABLE),
                default=None,
            ),
        )
    return out


def hard_contact(scene):
    """`scene` with its contact solved as constraints: [effects.contact] model = "hard" (the
    compliant law's stiffness, damping and slip_velocity removed, friction kept, the hard
    model's settings at their defaults) on the velocity-level step, run.integrator =
    "semi_implicit_euler"."""
    settings = thaw(scene.settings)
    table = settings["effects"]["contact"]
    for key in COMPLIANT_KEYS:
        table.pop(key, None)
    table["model"] = "hard"
    settings["run"]["integrator"] = "semi_implicit_euler"
    return od.scene_from_dict(
        settings,
        source=f"{scene.source} (hard contact)",
        base_dir=od.io.urdf.shipped_robots_dir(),
    )


def hard_order(runs):
    """fit_order of the hard model's max error (against its run at the finest step) over its
    complete runs at steps of at least HARD_FIT_FROM x the finest: nearer, the reference's own
    error, as large as theirs, steepens the slope. The max error and not the final one: a body
    at rest at the end carries none of its landing's error there."""
    finest = min(r["step"] for r in runs)
    fitted = [r for r in runs if r["complete"] and r["step"] >= HARD_FIT_FROM * finest]
    return fit_order([r["step"] for r in fitted], [r["error_max"] for r in fitted], 0.0)


def hard_study(scene, compliant, mode, repeats, title):
    """The hard model (hard_contact) on a contact scene over the steps HARD_STEPS[mode], each a
    contact_run row whose error is against the hard model's own run at the finest step (its
    convergence) and whose compliant_final and compliant_max are its distance to the compliant
    model's reference `compliant` (what rigid contact changes, an error of neither); with the
    hard settings, the reference's summary, hard_order and the step's stability."""
    hard = hard_contact(scene)
    finest = min(HARD_STEPS[mode])
    ref = od.simulate(hard.replace_run(dt=finest))
    runs = [
        contact_run(hard, "semi_implicit_euler", x, ref, repeats, compliant)
        for x in tqdm(HARD_STEPS[mode], desc=f"{title}, hard", leave=False)
    ]
    return dict(
        label=HARD_LABEL,
        settings=dataclasses.asdict(hard.contact.hard),
        reference=dict(
            step=finest,
            steps=int(ref.stats["steps"]),
            wall_s=ref.stats["wall_s"],
            energy_error=float(np.max(np.abs(ref.energy_error))),
            penetration_max=float(penetration(ref).max()),
        ),
        runs=runs,
        order=hard_order(runs),
        stability=stability(runs, ("semi_implicit_euler",))["semi_implicit_euler"],
    )


def contact_study(mode, repeats):
    """The contact scenes with every integrator x step (contact_run rows against each scene's
    reference): convergence orders, stability of the fixed steps, Pareto front and
    recommendations, and the hard model's runs (hard_study); then what the contact stiffness
    costs (stiffness_study)."""
    sweeps = CONTACT_STEPS[mode]
    scenes = []
    for key, shipped, title, full_T, quick_T, rtol in CONTACT_SCENES:
        duration = full_T if mode == "full" else quick_T
        base = od.load_scene(shipped)
        if key == "box_drop":
            base = Variants.of(base).scene_for(BOX_DROP)
        base = base.replace_run(duration=duration, output_dt=CONTACT_OUTPUT_DT)
        ref, reference = contact_reference(base, rtol)
        plan = [(name, x) for name in LABEL for x in sweeps[_contact_sweep(name)]]
        runs = [
            contact_run(base, name, x, ref, repeats)
            for name, x in tqdm(plan, desc=title, leave=False)
        ]
        scenes.append(
            dict(
                key=key,
                scene=shipped,
                title=title,
                duration=duration,
                reference=reference,
                runs=runs,
                orders=convergence_orders(runs, reference["error_bound"]),
                stability=stability(runs),
                pareto=pareto_front(runs),
                recommendations=recommend(runs),
                hard=hard_study(base, ref, mode, repeats, title),
            )
        )
    stiffness = stiffness_study(mode, repeats)
    return dict(output_dt=CONTACT_OUTPUT_DT, scenes=scenes, stiffness=stiffness)


def _contact_sweep(integrator):
    return "dopri5" if integrator == "dopri5" else "fixed"


def stiffness_study(mode, repeats):
    """What the contact stiffness k costs, on the ball drop (one bounce) at each k of
    STIFFNESSES: the contact's rate sqrt(k/m) (1/s), which sets RK4's stability step 2.8 / rate,
    and, per integrator, the fastest run whose max error meets STIFFNESS_TARGET. Each integrator
    walks down the full sweep (fixed steps from 10 ms, dopri5 tolerances from 1e-2) and stops at
    the first run that meets it, the largest such step: every run is kept."""
    base = od.load_scene("ball_drop").replace_run(
        duration=STIFFNESS_DURATION, output_dt=OUTPUT_DT
    )
    mass = float(np.sum(base.model.mass))
    sweeps = CONTACT_STEPS["full"]
    rows = []
    for k in tqdm(STIFFNESSES[mode], desc="contact stiffness", leave=False):
        scene = dataclasses.replace(base, contact=dataclasses.replace(base.contact, stiffness=k))
        ref, reference = contact_reference(scene, REFERENCE_TOL)
        runs = []
        for name in LABEL:
            for x in sweeps[_contact_sweep(name)]:
                runs.append(contact_run(scene, name, x, ref, repeats))
                if runs[-1]["complete"] and runs[-1]["error_max"] <= STIFFNESS_TARGET:
                    break
        rate = float(np.sqrt(k / mass))
        fastest = {
            name: recommend(
                [r for r in runs if r["integrator"] == name], (STIFFNESS_TARGET,)
            )[STIFFNESS_TARGET]
            for name in LABEL
        }
        rows.append(
            dict(
                stiffness=k,
                rate=rate,
                half_period_s=np.pi / rate,
                rk4_step=2.8 / rate,
                reference=reference,
                runs=runs,
                stability=stability(runs),
                fastest=fastest,
            )
        )
    return dict(
        scene="ball_drop",
        mass=mass,
        duration=STIFFNESS_DURATION,
        output_dt=OUTPUT_DT,
        target=STIFFNESS_TARGET,
        rows=rows,
    )


# ---------------------------------------------------------------- output


def plot_front_and_reference(ax, res):
    """The scene's Pareto front (error against wall time, dashed) and its reference's error
    bound (dotted) on the axes ax."""
    front = res["pareto"]
    ax.loglog(
        [r["wall_s"] for r in front],
        [max(r["error_max"], 1e-16) for r in front],
        "k--",
        lw=1,
        label="Pareto front",
    )
    ax.axhline(res["reference"]["error_bound"], color="grey", lw=0.8, ls=":")


def plot_pareto(results, path):
    fig, axes = plt.subplots(2, 2, figsize=(12, 9))
    for ax, res in zip(axes.ravel(), results):
        for name in LABEL:
            done = [r for r in res["runs"] if r["integrator"] == name and r["complete"]]
            if done:
                x = [r["wall_s"] for r in done]
                y = [max(r["error_max"], 1e-16) for r in done]
                ax.loglog(x, y, "o-", label=LABEL[name], ms=4)
        plot_front_and_reference(ax, res)
        ax.set_title(f"{res['title']}, {res['duration']:g} s")
        ax.set_xlabel("wall time (s)")
        ax.set_ylabel("max |q - q_ref| over the run (rad)")
        ax.grid(True, which="major", alpha=0.3)
    axes[0, 0].legend(fontsize=8)
    fig.suptitle("Error against wall time (dotted: the reference's own error bound)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_convergence(results, path):
    fig, axes = plt.subplots(2, 2, figsize=(12, 9))
    for ax, res in zip(axes.ravel(), results):
        for name in FIXED:
            done = [r for r in res["runs"] if r["integrator"] == name and r["complete"]]
            if done:
                order = res["orders"][name]
                label = LABEL[name] + (f" (order {order:.2f})" if order is not None else "")
                ax.loglog(
                    [r["step"] for r in done],
                    [max(r["error_final"], 1e-16) for r in done],
                    "o-",
                    ms=4,
                    label=label,
                )
        ax.axhline(res["reference"]["error_bound"], color="grey", lw=0.8, ls=":")
        ax.set_title(res["title"])
        ax.set_xlabel("step dt (s)")
        ax.set_ylabel("final |q - q_ref| (rad)")
        ax.grid(True, which="major", alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_constraint(res, path):
    """Max |phi| against step (DOPRI5 against its mean step) and against wall time: one colour
    per integrator, solid with Baumgarte, dashed without."""
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(13, 6))
    style = {"baumgarte": "o-", "none": "s--"}
    refused = []
    for k, name in enumerate(LABEL):
        colour = f"C{k}"
        for stab in STABILISATION:
            rows = [
                r for r in res["runs"] if r["integrator"] == name and r["stabilisation"] == stab
            ]
            if rows and not any(r["supported"] for r in rows):
                refused.append(f"{LABEL[name]} {STABILISATION[stab]}")
            done = [r for r in rows if r["complete"]]
            if not done:
                continue
            if name == "dopri5":
                x = [res["duration"] / r["steps"] for r in done]
                label = f"{LABEL[name]}, mean step, {STABILISATION[stab]}"
            else:
                x = [r["step"] for r in done]
                label = f"{LABEL[name]}, {STABILISATION[stab]}"
            y = [max(r["violation_max"], 1e-16) for r in done]
            ax1.loglog(x, y, style[stab], color=colour, ms=4, label=label)
            ax2.loglog([r["wall_s"] for r in done], y, style[stab], color=colour, ms=4)
    for ax in (ax1, ax2):
        for target in VIOLATION_TARGETS:
            ax.axhline(target, color="grey", lw=0.8, ls=":")
        ax.set_ylabel("max |phi| over the run (m)")
        ax.grid(True, which="major", alpha=0.3)
    ax1.set_xlabel("step dt (s)")
    ax1.set_title("Loop-closure violation against step")
    ax2.set_xlabel("wall time (s)")
    ax2.set_title("Loop-closure violation against wall time")
    alpha, beta = res["baumgarte"]
    note = (
        f"{res['title']}, {res['duration']:g} s; Baumgarte alpha = {alpha:g}, beta = {beta:g} 1/s"
    )
    note += "; dotted: " + ", ".join(f"{t:.0e} m" for t in VIOLATION_TARGETS)
    if refused:
        note += "\nnot supported: " + "; ".join(refused)
    fig.suptitle(note, fontsize=10)
    fig.legend(*ax1.get_legend_handles_labels(), loc="lower center", ncol=4, fontsize=8)
    fig.tight_layout(rect=(0, 0.1, 1, 1))
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_algorithms(algo, cond_rows, path):
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(12, 4.5))
    n = [r["n"] for r in algo["chains"]]
    for m in METHODS:
        p = algo["exponents"][m]
        ax1.loglog(n, [r[f"{m}_kernel_us"] for r in algo["chains"]], "o-", label=f"{m} (n^{p:.2f})")
    if "pinocchio_aba_us" in algo["chains"][0]:
        ax1.loglog(
            n,
            [r["pinocchio_aba_us"] for r in algo["chains"]],
            "k--",
            label="pinocchio aba (Python)",
        )
    ax1.set_xlabel("links n")
    ax1.set_ylabel("us per forward-dynamics call")
    ax1.set_title("Forward dynamics on random serial chains")
    ax1.legend(fontsize=8)
    ax1.grid(True, alpha=0.3)
    cond = [r["cond_median"] for r in cond_rows]
    for m in METHODS:
        y = [r[f"{m}_residual_max"] for r in cond_rows]
        ax2.loglog(cond, [v if v is not None else np.nan for v in y], "o-", label=m)
    ax2.set_xlabel("cond(M)")
    ax2.set_ylabel("max ||M qdd + h - tau|| / ||tau||")
    ax2.set_title("Residual as M becomes ill-conditioned (8 links)")
    ax2.legend(fontsize=8)
    ax2.grid(True, alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_contact(contact, path):
    """Max error against wall time on each contact scene (one curve per integrator, its refused
    steps in the legend), and the wall time of each integrator's fastest run within
    STIFFNESS_TARGET on the ball drop against the contact stiffness."""
    count = len(contact["scenes"])
    fig, axes = plt.subplots(1, count + 1, figsize=(5.7 * (count + 1), 5.5))
    for ax, res in zip(axes, contact["scenes"]):
        for k, name in enumerate(LABEL):
            rows = [r for r in res["runs"] if r["integrator"] == name]
            done = [r for r in rows if r["complete"]]
            refused = [r["step"] for r in rows if r["status"] == "refused"]
            label = LABEL[name]
            if refused:
                label += f" (refused >= {min(refused) * 1e3:g} ms)"
            if done:
                x = [r["wall_s"] for r in done]
                y = [max(r["error_max"], 1e-16) for r in done]
                ax.loglog(x, y, "o-", color=f"C{k}", ms=4, label=label)
            elif refused:
                ax.plot([], [], "o-", color=f"C{k}", label=label)
        plot_front_and_reference(ax, res)
        ax.set_title(f"{res['title']}, {res['duration']:g} s", fontsize=10)
        ax.set_xlabel("wall time (s)")
        ax.set_ylabel("max |q - q_ref| over the run (m or rad)")
        ax.grid(True, which="major", alpha=0.3)
        ax.legend(fontsize=7, loc="lower left")
    study = contact["stiffness"]
    ax = axes[-1]
    k_values = [row["stiffness"] for row in study["rows"]]
    for k, name in enumerate(LABEL):
        picks = [row["fastest"][name] for row in study["rows"]]
        wall = [np.nan if r is None else r["wall_s"] for r in picks]
        label = LABEL[name] if any(picks) else f"{LABEL[name]}: no step of the sweep"
        ax.loglog(k_values, wall, "o-", color=f"C{k}", ms=4, label=label)
    ax.set_xlabel("contact stiffness k (N/m)")
    ax.set_ylabel(f"wall time of the fastest run within {study['target']:g} m (s)")
    ax.set_title(
        f"Ball drop, {study['duration']:g} s: what the stiffness costs\n(no point: no step of "
        f"the sweep is within {study['target']:g} m)",
        fontsize=10,
    )
    ax.grid(True, which="major", alpha=0.3)
    ax.legend(fontsize=7)
    fig.suptitle("Contact: error against wall time (dotted: the reference's own error bound)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _e(x):
    return "-" if x is None else f"{x:.1e}"


def _step(r):
    return f"rtol {r['step']:.0e}" if r["integrator"] == "dopri5" else f"dt {r['step'] * 1e3:g} ms"


def _recommended(r):
    if r is None:
        return "none"
    return f"{LABEL[r['integrator']]}, {_step(r)}: {r['wall_s'] * 1e3:.3g} ms"


def constrained_recommendations(res):
    """Markdown lines: the fastest run that keeps max |phi| under each target, per setting."""
    out = [
        f"\nConstrained scene ({res['title']}, {res['duration']:g} s): the fastest run whose max "
        "loop-closure violation |phi| meets each bound.\n"
    ]
    out.append(
        "| stabilisation | " + " | ".join(f"max abs(phi) <= {t:.0e} m" for t in VIOLATION_TARGETS)
    )
    out[-1] += " |"
    out.append("|---" * (len(VIOLATION_TARGETS) + 1) + "|")
    for stab, title in STABILISATION.items():
        cells = [_recommended(res["recommendations"][stab][t]) for t in VIOLATION_TARGETS]
        out.append(f"| {title} | " + " | ".join(cells) + " |")
    return out


def constrained_markdown(res):
    """Markdown lines: the constrained scene's section (tables of runs, orders)."""
    ref = res["reference"]
    alpha, beta = res["baumgarte"]
    out = [
        f"\n## Constrained scene: {res['title']}, {res['duration']:g} s\n\n"
        f"The shipped four_bar scene (crank driven at 2 N m against damping, gravity) run with "
        f"its Baumgarte stabilisation (alpha = {alpha:g} 1/s, beta = {beta:g} 1/s) and without "
        f"it. |phi|: the largest loop-closure error (m) at the recorded samples; |A qd|: the "
        f"largest closure velocity error (m/s). The state error is max_j |q_j - q_ref,j| (rad) "
        f"against dopri5 at rtol = atol = {ref['rtol']:.0e} with Baumgarte ({ref['steps']} "
        f"steps; bound {ref['error_bound']:.1e} rad from the run at {CHECK_TOL:.0e}; its own max "
        f"|phi| is {ref['violation_max']:.1e} m, max |A qd| {ref['velocity_violation_max']:.1e} "
        f"m/s). Every run, stabilised or not, approximates the same exact motion, on which phi = 0 "
        f"and the Baumgarte terms vanish.\n",
        figure("constraint.png", "loop-closure violation against step and wall time") + "\n",
    ]
    for stab, title in STABILISATION.items():
        out.append(f"### {title[0].upper() + title[1:]}\n")
        out.append(
            "| integrator | step | max abs(phi) (m) | final abs(phi) (m) | max abs(A qd) (m/s) "
            "| final state error (rad) | max state error (rad) | evaluations | wall (ms) |"
        )
        out.append("|---" * 9 + "|")
        refused = set()
        for r in res["runs"]:
            if r["stabilisation"] != stab:
                continue
            if not r["supported"]:
                if r["integrator"] not in refused:
                    refused.add(r["integrator"])
                    out.append(
                        f"| {LABEL[r['integrator']]} | every step | not supported: {r['reason']} "
                        "| - | - | - | - | - | - |"
                    )
                continue
            if r["complete"]:
                cells = [r["violation_max"], r["violation_final"], r["velocity_violation_max"]]
                cells = [_e(v) for v in cells + [r["error_final"], r["error_max"]]]
            else:
                cells = [f"diverged at t = {r['failed_at']:.3g} s"] + ["-"] * 4
            out.append(
                f"| {LABEL[r['integrator']]} | {_step(r)} | " + " | ".join(cells) + f" | "
                f"{r['evaluations']} | {r['wall_s'] * 1e3:.3g} |"
            )
        out.append("")
    out.append(
        "### Convergence order of the violation\n\nThe slope of log(max abs(phi)) against "
        "log(step) (DOPRI5: against log(rtol)) over the four smallest steps whose violation lies "
        f"between 100x the reference's ({100 * ref['violation_max']:.0e} m) and 0.1 m. '-': "
        "fewer than three runs there, or not supported.\n"
    )
    out.append("| stabilisation | " + " | ".join(LABEL[n] for n in LABEL) + " |")
    out.append("|---" * (len(LABEL) + 1) + "|")
    for stab, title in STABILISATION.items():
        cells = [f"{o:.2f}" if o is not None else "-" for o in res["orders"][stab].values()]
        out.append(f"| {title} | " + " | ".join(cells) + " |")
    out += constrained_recommendations(res)
    return out


def _ms(x):
    return "-" if x is None else f"{x * 1e3:g} ms"


def _first_part(r):
    """The first clause of a run's reason: for a refusal, the stiffest effect the stability
    check names (its rate and dt x rate); for a failure, where and why the run stopped."""
    clause = re.split(r"; |, above ", r["reason"])[0]
    return clause.rsplit(": ", 1)[-1] if r["status"] == "refused" else clause


def contact_recommendations(contact):
    """Markdown lines: the fastest run that keeps the max error under each target, per contact
    scene."""
    out = [
        "\nContact scenes: the fastest run whose max error (m for the base position, rad for the "
        "joints) meets each bound.\n"
    ]
    out.append("| scene | " + " | ".join(f"error <= {t:.0e}" for t in TARGETS) + " |")
    out.append("|---" * (len(TARGETS) + 1) + "|")
    for res in contact["scenes"]:
        cells = [_recommended(res["recommendations"][t]) for t in TARGETS]
        out.append(f"| {res['title']}, {res['duration']:g} s | " + " | ".join(cells) + " |")
    return out


def contact_markdown(contact):
    """Markdown lines: the contact section (each scene's runs, stability, orders and Pareto
    front; the stiffness study)."""
    out = [
        "\n## Contact\n\n"
        "Ground contact: spheres against the plane z = 0, f_n = max(0, k delta + d delta_dot), "
        "regularised Coulomb friction. The error of a run is max_j |q_j - q_ref,j| at samples "
        f"every {contact['output_dt'] * 1e3:g} ms (m for the base position, rad for the joints, "
        "the quaternion's components); a fixed step longer than that records, and is compared "
        "at, every step. Energy residual: max |energy_error| (J), the balance E - E(0) - "
        "W_applied - W_passive. Penetration: the deepest at the run's samples and its distance "
        "to the reference's deepest at the same samples. refused: the simulator refused the "
        "step before the run (its stability check at the initial state; the stiffest cause "
        "shown); failed: the run stopped.\n",
        figure("contact.png", "error against wall time on three drops; the stiffness cost") + "\n",
    ]
    for res in contact["scenes"]:
        ref = res["reference"]
        out.append(
            f"\n### {res['title']}, {res['duration']:g} s\n\nReference: dopri5 at rtol = atol "
            f"= {ref['rtol']:.0e} ({ref['steps']} steps, {ref['wall_s']:.3g} s); its distance to "
            f"the run at {10 * ref['rtol']:.0e} bounds its error: {ref['error_bound']:.1e}. Its "
            f"deepest penetration {ref['penetration_max'] * 1e3:.4g} mm, energy residual "
            f"{ref['energy_error']:.1e} J.\n"
        )
        out.append(
            "| integrator | step | final error | max error | energy residual (J) | deepest "
            "penetration (mm) | its error (mm) | evaluations | wall (ms) |"
        )
        out.append("|---" * 9 + "|")
        for r in res["runs"]:
            head = f"| {LABEL[r['integrator']]} | {_step(r)} | "
            if r["status"] == "refused":
                out.append(head + f"refused: {_first_part(r)} | - | - | - | - | - | - |")
                continue
            if r["complete"]:
                cells = [_e(r["error_final"]), _e(r["error_max"]), _e(r["energy_error"])]
                cells += [f"{r['penetration_max'] * 1e3:.4g}", _e(r["penetration_error"] * 1e3)]
            else:
                cells = [f"failed: {_first_part(r)}"] + ["-"] * 4
            out.append(
                head + " | ".join(cells) + f" | {r['evaluations']} | {r['wall_s'] * 1e3:.3g} |"
            )
        out.append(
            f"\nStability of the fixed steps (usable: max error <= {USABLE:g}):\n\n"
            "| integrator | largest step run | refused from | largest step completing "
            "| largest usable step |"
        )
        out.append("|---" * 5 + "|")
        for name, st in res["stability"].items():
            cells = [st["largest_run"], st["smallest_refused"], st["largest_complete"]]
            cells = [_ms(x) for x in cells + [st["largest_usable"]]]
            out.append(f"| {LABEL[name]} | " + " | ".join(cells) + " |")
        orders = ", ".join(
            f"{LABEL[n]} {o:.2f}" for n, o in res["orders"].items() if o is not None
        )
        front = ", ".join(
            f"{LABEL[r['integrator']]} {_step(r)} ({r['wall_s'] * 1e3:.3g} ms, "
            f"{r['error_max']:.1e})"
            for r in res["pareto"]
        )
        out.append(
            f"\nConvergence orders (final error against step, as above): {orders or '-'}."
            f"\n\nPareto front (fastest first): {front}."
        )
        out += hard_markdown(res)
    out += usable_steps_markdown(contact)
    study = contact["stiffness"]
    out.append(
        f"\n### What the contact stiffness costs: the ball drop, {study['duration']:g} s\n\n"
        f"The ball drop (1 bounce) at each stiffness k, samples every "
        f"{study['output_dt'] * 1e3:g} ms, each against its own reference (dopri5 at "
        f"{REFERENCE_TOL:.0e}). The contact's rate sqrt(k/m) (m = {study['mass']:g} kg) sets "
        f"how long it lasts (half a period, pi / rate) and RK4's stability step 2.8 / rate. "
        f"Each integrator walks down the sweep (fixed steps from 10 ms, DOPRI5 tolerances from "
        f"1e-2) to the first run whose max error is within {study['target']:g} m: its step and "
        f"wall time (none: no step of the sweep is; the smallest step's error in brackets).\n"
    )
    out.append(
        "| k (N/m) | rate (1/s) | pi / rate (ms) | 2.8 / rate (ms) | RK4 refused from | "
        + " | ".join(LABEL[n] for n in LABEL)
        + " |"
    )
    out.append("|---" * (len(LABEL) + 5) + "|")
    for row in study["rows"]:
        cells = [
            f"{row['stiffness']:.0e}",
            f"{row['rate']:.3g}",
            f"{row['half_period_s'] * 1e3:.3g}",
            f"{row['rk4_step'] * 1e3:.3g}",
            _ms(row["stability"]["rk4"]["smallest_refused"]),
        ]
        for name in LABEL:
            r = row["fastest"][name]
            if r is not None:
                cells.append(f"{_step(r)}: {r['wall_s'] * 1e3:.3g} ms")
                continue
            tried = [x for x in row["runs"] if x["integrator"] == name and x["complete"]]
            last = min(tried, key=lambda x: x["step"])
            cells.append(f"none ({_step(last)}: {last['error_max']:.1e} m)")
        out.append("| " + " | ".join(cells) + " |")
    return out


def hard_markdown(res):
    """Markdown lines: a contact scene's runs of the hard model (hard_study), its order and the
    stability of its step."""
    hard = res["hard"]
    ref, settings, st = hard["reference"], hard["settings"], hard["stability"]
    out = [
        (
            f"\n#### The hard model: {hard['label']}\n\n"
            'The same scene with model = "hard": contacts as constraints of the velocity-level '
            f"step, friction as above (margin {settings['margin'] * 1e3:g} mm, stabilization "
            f"{settings['stabilization']:g}, {settings['solver'].upper()} to "
            f"{settings['tolerance']:.0e} m/s within {settings['max_iterations']} iterations). "
            "Error: against the hard model's own run at the finest step, "
            f"{_ms(ref['step'])} ({ref['steps']} steps, {ref['wall_s']:.3g} s): its convergence. "
            "Distance to compliant: max over the samples of max_j |q_j - q_compliant,j| to the "
            "compliant reference above, what rigid contact changes against the compliant law, "
            "an error of neither: as the step shrinks it settles at the finest run's, the "
            "difference between the two models. Penetration: the deepest at the samples, zero for a contact "
            "short of the surface; a step that starts farther than the margin from a surface has "
            "no row for it and may end inside it (by up to the approach speed times the step, "
            "less the margin), and the stabilization takes that out over the following steps. "
            "Unconverged: the steps whose solve stopped at the iteration limit above the "
            "tolerance, and the largest residual among them (m/s).\n"
        )
    ]
    out.append(
        "| step | final error | max error | max distance to compliant | deepest penetration "
        "(mm) | energy residual (J) | unconverged steps | worst residual (m/s) | steps | wall "
        "(ms) |"
    )
    out.append("|---" * 10 + "|")
    for r in hard["runs"]:
        head = f"| {_step(r)} | "
        if r["status"] == "refused":
            out.append(head + f"refused: {_first_part(r)} |" + " - |" * 8)
            continue
        if r["complete"]:
            cells = [_e(r["error_final"]), _e(r["error_max"]), _e(r["compliant_max"])]
            cells += [f"{r['penetration_max'] * 1e3:.3g}", _e(r["energy_error"])]
            cells += [str(r["unconverged_steps"]), _e(r["worst_residual"])]
        else:
            cells = [f"failed: {_first_part(r)}"] + ["-"] * 6
        out.append(head + " | ".join(cells) + f" | {r['steps']} | {r['wall_s'] * 1e3:.3g} |")
    order = "-" if hard["order"] is None else f"{hard['order']:.2f}"
    out.append(
        f"\nOrder of the max error against the step, over the steps from {HARD_FIT_FROM}x the "
        f"finest: {order}. Largest step completing: {_ms(st['largest_complete'])}; largest "
        f"usable (max error <= {USABLE:g}): {_ms(st['largest_usable'])}."
    )
    return out


def usable_steps_markdown(contact):
    """Markdown lines: the largest usable step of each model on each contact scene, the hard
    model's against its finest step and the compliant law's against its DOPRI5 reference."""
    out = [
        (
            "\n### The largest usable step of each contact model\n\nThe largest step of the "
            f"sweep whose max error is within {USABLE:g} (m or rad) against the model's own "
            "reference: the hard model's run at its finest step; DOPRI5 for the compliant law, "
            "per integrator.\n"
        ),
        f"| scene | {HARD_LABEL} | " + " | ".join(f"compliant, {LABEL[n]}" for n in FIXED) + " |",
        "|---" * (len(FIXED) + 2) + "|",
    ]
    for res in contact["scenes"]:
        cells = [_ms(res["hard"]["stability"]["largest_usable"])]
        cells += [_ms(res["stability"][n]["largest_usable"]) for n in FIXED]
        out.append(f"| {res['title']}, {res['duration']:g} s | " + " | ".join(cells) + " |")
    return out


def method_table(rows, key, title):
    """Markdown lines: one row of per-call times per model."""
    if not rows:
        return ["(none)"]
    has_pin = "pinocchio_aba_us" in rows[0]
    head = f"| {title} | ABA (us) | CRBA + Cholesky (us) | n-RNEA + Cholesky (us) | "
    head += "od.forward_dynamics (us)"
    lines = [head + (" | pin.aba (us) | ratio |" if has_pin else " |")]
    lines.append("|---" * (7 if has_pin else 5) + "|")
    for r in rows:
        cells = [f"{r[f'{m}_kernel_us']:.3g}" for m in METHODS] + [f"{r['aba_public_us']:.3g}"]
        if has_pin:
            cells += [
                f"{r['pinocchio_aba_us']:.3g}",
                f"{r['aba_public_us'] / r['pinocchio_aba_us']:.2f}",
            ]
        name = r[key] if key == "n" else f"{r[key]} ({r['nv']})"
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return lines


def figure(name, what):
    """A Markdown image of one of the study's plots, written beside study.md."""
    return f"![{what}]({name})"


def markdown(results, constrained, contact, algo, cond_rows, effect_rows):
    """Every table of the study, in Markdown, from its first section on (no title)."""
    out = ["## Recommendations: the fastest run that meets each max error\n"]
    out.append("| scene | " + " | ".join(f"error <= {t:.0e} rad" for t in TARGETS) + " |")
    out.append("|---" * (len(TARGETS) + 1) + "|")
    for res in results:
        cells = []
        for target in TARGETS:
            r = res["recommendations"][target]
            cells.append(
                "none"
                if r is None
                else f"{LABEL[r['integrator']]}, {_step(r)}: {r['wall_s'] * 1e3:.3g} ms"
            )
        out.append(f"| {res['title']} | " + " | ".join(cells) + " |")
    pareto = figure("accuracy_vs_time.png", "error against wall time, one curve per integrator")
    out.append(f"\n{pareto}")
    out += constrained_recommendations(constrained)
    out += contact_recommendations(contact)
    out.append(
        "\n## Convergence orders\n\nThe slope of log(final error) against log(step); for DOPRI5 "
        "against log(rtol) (1: the error is proportional to the tolerance). '-': fewer than "
        "three runs in the asymptotic range.\n"
    )
    out.append(figure("convergence.png", "error against step, one curve per integrator") + "\n")
    out.append("| scene | " + " | ".join(LABEL[n] for n in LABEL) + " |")
    out.append("|---" * (len(LABEL) + 1) + "|")
    for res in results:
        cells = [f"{o:.2f}" if o is not None else "-" for o in res["orders"].values()]
        out.append(f"| {res['title']} | " + " | ".join(cells) + " |")
    for res in results:
        ref = res["reference"]
        out.append(
            f"\n## {res['title']}, {res['duration']:g} s\n\nReference: dopri5 at rtol = atol = "
            f"{ref['rtol']:.0e} ({ref['steps']} steps); its distance to the run at "
            f"{CHECK_TOL:.0e} bounds its error: {ref['error_bound']:.1e} rad. "
            + ("Energy drift" if res["conservative"] else "Energy-balance residual")
            + f" of the reference: {ref['energy_error']:.1e} J.\n"
        )
        out.append(
            "| integrator | step | final error (rad) | max error (rad) | energy error (J) "
            "| evaluations | wall (ms) |"
        )
        out.append("|---|---|---|---|---|---|---|")
        for r in res["runs"]:
            if r["complete"]:
                cells = [_e(r["error_final"]), _e(r["error_max"]), _e(r["energy_error"])]
            else:
                cells = [f"diverged at t = {r['failed_at']:.3g} s", "-", "-"]
            out.append(
                f"| {LABEL[r['integrator']]} | {_step(r)} | " + " | ".join(cells) + f" | "
                f"{r['evaluations']} | {r['wall_s'] * 1e3:.3g} |"
            )
        front = ", ".join(
            f"{LABEL[r['integrator']]} {_step(r)} ({r['wall_s'] * 1e3:.3g} ms, "
            f"{r['error_max']:.1e} rad)"
            for r in res["pareto"]
        )
        out.append(f"\nPareto front (fastest first): {front}.")
    out += constrained_markdown(constrained)
    out.append("\n## Forward dynamics: time per call on random serial chains\n")
    out.append(figure("algorithms.png", "time per call against n, and residual against cond(M)"))
    out.append("")
    out += method_table(algo["chains"], "n", "n")
    out.append("\nAnd on the bundled robots (and example-robot-data's UR5 and Panda):\n")
    out += method_table(algo["robots"], "robot", "robot (nv)")
    exps = ", ".join(f"{m} n^{p:.2f}" for m, p in algo["exponents"].items())
    out.append(
        f"\nThe first three columns are per call inside a compiled loop (what a simulation step "
        f"pays); od.forward_dynamics and pin.aba are called from Python (ratio = opendyn / "
        f"Pinocchio). Growth fitted for n >= {algo['fit_from_n']}: {exps}."
    )
    out.append("\n## Residual ||M qdd + h - tau|| / ||tau|| as M becomes ill-conditioned\n")
    out.append(
        f"8 revolute links alternating 1 kg and a lighter mass; {STATES} random states each.\n"
    )
    out.append("| light link (kg) | median cond(M) | " + " | ".join(METHODS) + " |")
    out.append("|---" * (len(METHODS) + 2) + "|")
    for r in cond_rows:
        cells = []
        for m in METHODS:
            v, s = r[f"{m}_residual_max"], r[f"{m}_singular"]
            cell = _e(v) if v is not None else "-"
            cells.append(cell + (f" ({s}/{STATES} reported singular)" if s else ""))
        out.append(f"| {r['light_kg']:.0e} | {r['cond_median']:.1e} | " + " | ".join(cells) + " |")
    out.append("\n## What each effect costs per step (us; RK4, 4 evaluations per step)\n")
    titles = list(effect_rows)
    names = []
    for title in titles:
        names += [k for k in effect_rows[title] if k != "evaluations_per_step" and k not in names]
    out.append("| stage | " + " | ".join(titles) + " |")
    out.append("|---" * (len(titles) + 1) + "|")
    for name in names:
        cells = []
        for title in titles:
            c = effect_rows[title].get(name)
            cells.append("-" if c is None else f"{c['per_step_us']:.3g}")
        out.append(f"| {name} | " + " | ".join(cells) + " |")
    out += contact_markdown(contact)
    return "\n".join(out) + "\n"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="small sweeps, under 2 minutes")
    parser.add_argument("--out", help=f"output folder (default {DEFAULT_OUT}/ in this folder)")
    parser.add_argument(
        "--docs", action="store_true", help="write the published study, docs/study/ (full run)"
    )
    args = parser.parse_args(argv)
    if args.docs and args.quick:
        parser.error(
            "--docs writes the published study, docs/study/, and quick results must never "
            "replace it: run --quick without --docs (it writes to --out)"
        )
    if args.docs and args.out:
        parser.error("--docs writes docs/study/: give --docs or --out, not both")
    mode = "quick" if args.quick else "full"
    out = DOCS_OUT if args.docs else pathlib.Path(args.out or DEFAULT_OUT)
    started = datetime.datetime.now(datetime.timezone.utc)
    out.mkdir(parents=True, exist_ok=True)
    tmp = out / "urdf"
    tmp.mkdir(exist_ok=True)
    tic = time.perf_counter()
    results = integrator_study(mode, repeats=5 if mode == "full" else 1)
    constrained = constrained_study(mode, repeats=5 if mode == "full" else 1)
    contact = contact_study(mode, repeats=5 if mode == "full" else 1)
    algo = algorithm_study(mode, tmp)
    cond_rows = conditioning_study(mode, tmp)
    effect_rows = effect_study(mode)
    elapsed = time.perf_counter() - tic
    plot_pareto(results, out / "accuracy_vs_time.png")
    plot_convergence(results, out / "convergence.png")
    plot_constraint(constrained, out / "constraint.png")
    plot_algorithms(algo, cond_rows, out / "algorithms.png")
    plot_contact(contact, out / "contact.png")
    title = f"Accuracy versus time ({mode} run, {elapsed:.0f} s)"
    if args.docs:
        argv = sys.argv[1:] if argv is None else argv
        head = docs_page.header(title, __file__, argv, modules=("pinocchio",), when=started)
    else:
        head = f"# {title}\n\n"
    text = head + markdown(results, constrained, contact, algo, cond_rows, effect_rows)
    docs_page.write_atomic(out / "study.md", text)
    record = dict(
        mode=mode,
        elapsed_s=elapsed,
        integrators=results,
        constrained=constrained,
        algorithms=algo,
        conditioning=cond_rows,
        effects=effect_rows,
        contact=contact,
        versions=dict(opendyn=od.__version__, numpy=np.__version__),
    )
    docs_page.write_atomic(out / "study.json", json.dumps(record, indent=1, default=_json_default))
    for path in sorted(tmp.iterdir()):
        path.unlink()
    tmp.rmdir()
    print(text)
    print(
        f"wrote {out.resolve()}/: accuracy_vs_time.png convergence.png constraint.png "
        "algorithms.png contact.png study.md study.json"
    )
    return 0


def _json_default(x):
    if isinstance(x, (np.floating, np.integer)):
        return x.item()
    raise TypeError(f"not JSON: {type(x)}")


if __name__ == "__main__":
    sys.exit(main())
