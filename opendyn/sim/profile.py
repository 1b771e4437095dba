"""What each stage of a scene's step costs, as `opendyn simulate --profile` reports it: the whole
step timed on a short run of the scene, then each effect stage, forward dynamics and the whole
evaluation timed alone in compiled loops over that run's states.
"""

from __future__ import annotations

import time

import numpy as np

from . import effects, integrators, step
from .simulate import simulate


def stage_costs(scene, *, steps=2000, evaluations=20000):
    """What each stage of the scene's step costs: a list of (name, us per call, us per step).

    The whole loop is timed on up to `steps` steps of the scene (best of three runs after a
    warm-up); then each stage alone, forward dynamics alone and the whole evaluation are timed
    (best of three) in a compiled loop over the states of that run, repeated to about
    `evaluations` calls. Per step = per call x the integrator's evaluations per step; the last
    two rows are the rest of the step (the integrator itself, or the implicit solve) and the
    measured step, with no per-call time (None).
    """
    run = scene.run
    if not integrators.INTEGRATORS[run.integrator].adaptive:
        short = scene.replace_run(duration=min(run.duration, steps * run.dt), output_dt=run.dt)
    else:
        short = scene.replace_run(duration=min(run.duration, 10.0))
    runs = [simulate(short, raise_on_failure=False) for _ in range(4)]  # the first warms up
    traj = runs[0]
    stats = traj.stats
    n_steps = max(1, stats["steps"])
    per_step = min(r.stats["wall_s"] for r in runs[1:]) / n_steps
    evals_per_step = stats["evaluations"] / n_steps
    model = scene.model
    table = effects.stage_table(scene)
    reps = max(1, evaluations // max(1, len(traj.t)))
    t = np.tile(traj.t, reps)
    q = np.ascontiguousarray(np.tile(traj.q, (reps, 1)))
    qd = np.ascontiguousarray(np.tile(traj.qd, (reps, 1)))

    def cost(which):
        data = step.scene_data(model, table)
        step.stage_cost_kernel(data, which, t[:1], q[:1], qd[:1])
        best = np.inf
        for _ in range(3):
            tic = time.perf_counter()
            step.stage_cost_kernel(data, which, t, q, qd)
            best = min(best, time.perf_counter() - tic)
        return best / len(t) * 1e6

    # implicit and semi-implicit Euler run the stages, then their own solve, not an evaluation
    implicit = integrators.INTEGRATORS[run.integrator].kind != integrators.EXPLICIT_RK
    rows = [(name, cost(slot)) for slot, name in zip(table.slots, table.names)]
    if not implicit:
        if scene.constraints:
            dynamics = "constrained forward dynamics (CRBA"
        else:
            dynamics = (
                "forward dynamics (ABA" if table.method == "aba" else "forward dynamics (CRBA"
            )
        dynamics += ", with armature)" if scene.armature is not None else ")"
        rows.append((dynamics, cost(-1)))
    evaluation = sum(us for _, us in rows) if implicit else cost(-2)
    rows.append(("stages" if implicit else "whole evaluation", evaluation))
    costs = [(name, us, us * evals_per_step) for name, us in rows]
    per_step_us = per_step * 1e6
    rest_name = "own solve + integrator" if implicit else "integrator and loop"
    costs.append((rest_name, None, per_step_us - evaluation * evals_per_step))
    costs.append(("step (measured)", None, per_step_us))
    return costs, n_steps, evals_per_step


def profile(scene, *, steps=2000, evaluations=20000):
    """stage_costs(scene) as a text table: us per call, us per step and share of the step."""
    costs, n_steps, evals_per_step = stage_costs(scene, steps=steps, evaluations=evaluations)
    per_step = costs[-1][2]
    lines = [
        f"profile: {scene.name}, {scene.run.integrator}, {n_steps} steps, "
        f"{evals_per_step:.3g} evaluations per step",
        f"{'stage':<34}{'us/call':>10}{'us/step':>10}{'share':>8}",
    ]
    for name, per_call, step_us in costs:
        call = f"{per_call:>10.3f}" if per_call is not None else f"{'':>10}"
        lines.append(f"{name:<34}{call}{step_us:>10.3f}{step_us / per_step:>8.0%}")
    return "\n".join(lines)
