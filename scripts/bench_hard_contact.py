"""Time the hard model's step (contact as constraints) against MuJoCo's mj_step, its solve against
Pinocchio's ADMMConstraintSolver, and find the largest step at which each stays at rest.

    python scripts/bench_hard_contact.py [--quick] [--rounds N] [--docs]

Scenes, each built the same way in MuJoCo (scripts/bench_contact.py's mujoco_model: the same
boxes, masses, inertias and friction, the floor plane):
- `box_on_table` with [effects.contact] model = "hard" and integrator "semi_implicit_euler":
  a 1 kg box resting on a table;
- `box_stack_hard`: ten boxes from 1 kg to 10 g.
MuJoCo runs its default solver (Newton) with its default pyramidal friction cones, and again
with elliptic cones (opendyn's cone is the exact circular one), its Euler integrator, at the
same step. Both start at rest where the scene file puts the boxes.

Timed, in alternation, best of N rounds (5, or 2 with --quick), at dt = 2 ms and 1 ms:
- opendyn: `od.simulate` over STEPS steps (its compiled loop; the loop's own wall time), per step;
- MuJoCo: `mujoco.rollout.rollout` (its loop in C) over the same steps, per step.
The solve alone: the contact problems of the run's samples (od.contact_problem: G, g, the
cones), each solved from zero by opendyn's ADMM (opendyn.algorithm.ncp, called from Python) and
by Pinocchio's ADMMConstraintSolver (called from Python, its Delassus operator made beforehand),
to the same residual measure of ours, 1e-8 m/s, per problem; Pinocchio's own stopping test at
its tolerance 1e-8.
The largest stable step: the largest dt of STEPS_TRIED at which the boxes stay at rest for 1 s
(every box within 1 mm of where it started), opendyn and MuJoCo (default solver).

With --docs it also writes what it prints to docs/performance/hard-contact.md (docs_page).
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings

import docs_page
import mujoco
import numpy as np
import pinocchio as pin
from bench_contact import MujocoRun

import opendyn as od
from opendyn.algorithm import ncp
from opendyn.io.urdf import shipped_robots_dir
from opendyn.sim.scene import thaw

STEPS = 1000  # steps a timed run takes
STEPS_TRIED = (0.001, 0.002, 0.005, 0.01, 0.02, 0.05)  # s, for the largest stable step
TOLERANCE = 1e-8  # m/s


def hard_scene(name, dt, duration=None):
    """The shipped scene `name` with its contact hard (box_on_table is compliant as shipped) at
    step dt, run for STEPS steps or `duration` s."""
    settings = thaw(od.load_scene(name).settings)
    contact = settings["effects"]["contact"]
    for key in ("stiffness", "damping", "slip_velocity"):
        contact.pop(key, None)
    contact["model"] = "hard"
    settings["run"] = {
        "integrator": "semi_implicit_euler", "dt": dt, "output_dt": dt,
        "duration": duration if duration is not None else STEPS * dt,
    }
    return od.scene_from_dict(settings, source=f"{name}.toml", base_dir=shipped_robots_dir())


def mujoco_run(scene, cone):
    """A MujocoRun of the scene from its initial state, with friction cones `cone`."""
    run = MujocoRun(scene, scene.q0, scene.qd0, None, STEPS)
    run.m.opt.cone = cone
    return run


def step_times(scene, rounds):
    """(opendyn, MuJoCo pyramidal, MuJoCo elliptic) s per step, best of `rounds`."""
    runs = {
        "opendyn": lambda: od.simulate(scene).stats["wall_s"],
        "pyramidal": timed(mujoco_run(scene, mujoco.mjtCone.mjCONE_PYRAMIDAL)),
        "elliptic": timed(mujoco_run(scene, mujoco.mjtCone.mjCONE_ELLIPTIC)),
    }
    runs["opendyn"]()  # compiles (or loads) the loop
    best = {key: np.inf for key in runs}
    for _ in range(rounds):
        for key, run in runs.items():
            best[key] = min(best[key], run() / STEPS)
    return best["opendyn"], best["pyramidal"], best["elliptic"]


def timed(run):
    def call():
        t0 = time.perf_counter()
        run.rollout(STEPS)
        return time.perf_counter() - t0

    return call


def problems(scene, count):
    """`count` contact problems (G, g, mu) of the scene's run, from its samples."""
    traj = od.simulate(scene)
    found = []
    for k in np.linspace(0, len(traj.t) - 2, count).astype(int):
        p = od.contact_problem(scene, traj.q[k], traj.qd[k])
        if len(p.g):
            found.append((p.G, p.g, p.param.copy()))
    return found


def solve_times(found, rounds):
    """(opendyn, Pinocchio) s per problem, each solved from zero, best of `rounds`; and the
    largest residual (our measure) of Pinocchio's answers."""
    ours = []
    for G, g, mu in found:
        m = len(g)
        blocks = np.array([[ncp.CONE, 3 * k, 3] for k in range(m // 3)], dtype=np.int64)
        work = (np.zeros((m, m)), np.zeros((m, m)), np.zeros((10, m)))
        args = (ncp.ADMM, (G, g, blocks, mu, m), (TOLERANCE, 100000))
        ours.append((args, work, m))
    theirs = []
    for G, g, mu in found:
        m = len(g)
        model = pin.Model()
        joint = model.addJoint(0, pin.JointModelRX(), pin.SE3.Identity(), "j")
        models, datas = pin.StdVec_ConstraintModel(), pin.StdVec_ConstraintData()
        for k in range(m // 3):
            contact = pin.PointContactConstraintModel(model, joint)
            contact.setFriction(float(mu[k]))
            models.append(contact)
        for k in range(m // 3):
            datas.append(models[k].createData())
        settings = pin.ADMMSolverSettings()
        for name in ("absolute_feasibility_tol", "relative_feasibility_tol",
                     "absolute_complementarity_tol", "relative_complementarity_tol"):
            setattr(settings, name, TOLERANCE)
        settings.max_iterations = 100000
        theirs.append((G, g, models, datas, settings, m))

    def run_ours():
        for args, work, m in ours:
            ncp.solve_ncp(*args, np.zeros(m), work)

    def run_theirs():
        for G, g, models, datas, settings, m in theirs:
            delassus = pin.DelassusOperatorDense(G)  # the solver damps it: a fresh one a solve
            pin.ADMMConstraintSolver(m).solve(
                delassus, g, models, datas, settings, pin.ADMMSolverResult()
            )

    run_ours()
    best = [np.inf, np.inf]
    for _ in range(rounds):
        for k, run in enumerate((run_ours, run_theirs)):
            t0 = time.perf_counter()
            run()
            best[k] = min(best[k], (time.perf_counter() - t0) / len(found))
    return best


def at_rest(traj, tolerance=1e-3):
    """Whether every free body of the record stayed within `tolerance` m of its start."""
    return bool(np.all(np.isfinite(traj.q))) and float(
        np.abs(traj.q - traj.q[0]).max()
    ) <= tolerance


def largest_stable(name):
    """(opendyn, MuJoCo) the largest dt of STEPS_TRIED at which the scene rests for 1 s."""
    ours = theirs = 0.0
    for dt in STEPS_TRIED:
        scene = hard_scene(name, dt, duration=1.0)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            traj = od.simulate(scene, raise_on_failure=False)
        if traj.complete and at_rest(traj):
            ours = dt
        run = MujocoRun(scene, scene.q0, scene.qd0, None, round(1.0 / dt))
        run.reset()
        start = run.d.qpos.copy()
        for _ in range(round(1.0 / dt)):
            mujoco.mj_step(run.m, run.d)
        if np.all(np.isfinite(run.d.qpos)) and np.abs(run.d.qpos - start).max() <= 1e-3:
            theirs = dt
    return ours, theirs


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="2 rounds instead of 5")
    parser.add_argument("--rounds", type=int, default=None)
    parser.add_argument(
        "--docs", action="store_true", help="also write docs/performance/hard-contact.md"
    )
    args = parser.parse_args()
    rounds = args.rounds or (2 if args.quick else 5)
    title = "Hard contact: opendyn against MuJoCo and Pinocchio"
    names = ("box_on_table", "box_stack_hard")
    with docs_page.page(
        "hard-contact.md", title, enabled=args.docs, modules=("mujoco", "pinocchio")
    ):
        print(
            f"Microseconds a step, best of {rounds} rounds in alternation of {STEPS} steps, in "
            "the same process, the boxes at rest where the scene file puts them. opendyn: "
            "od.simulate's compiled loop (the velocity-level step, ADMM to the scene's "
            "tolerance: 1e-8 m/s, box_stack_hard's 1e-9); MuJoCo: "
            "mujoco.rollout (its loop in C; Newton, Euler) with pyramidal and with elliptic "
            "friction cones. Ratio: opendyn's step over MuJoCo's.\n"
        )
        print(
            "| scene | dt (ms) | opendyn (us) | MuJoCo pyramidal (us) | MuJoCo elliptic (us) | "
            "ratio to pyramidal | ratio to elliptic |"
        )
        print("|---|---:|---:|---:|---:|---:|---:|")
        for name in names:
            for dt in (0.002, 0.001):
                ours, pyramidal, elliptic = step_times(hard_scene(name, dt), rounds)
                print(
                    f"| {name} | {dt * 1e3:g} | {ours * 1e6:.2f} | {pyramidal * 1e6:.2f} | "
                    f"{elliptic * 1e6:.2f} | {ours / pyramidal:.2f} | {ours / elliptic:.2f} |"
                )
                sys.stdout.flush()
        print(
            "\nThe solve alone: microseconds a problem, the contact problems of 20 samples of "
            "each run at 2 ms, each solved from zero (no warm start) to 1e-8 (opendyn's "
            "residual in m/s; Pinocchio's own tolerances), both called from Python.\n"
        )
        print("| scene | problems | rows | opendyn ADMM (us) | Pinocchio ADMM (us) | ratio |")
        print("|---|---:|---:|---:|---:|---:|")
        for name in names:
            found = problems(hard_scene(name, 0.002), 20)
            ours, theirs = solve_times(found, rounds)
            rows = np.mean([len(g) for _, g, _ in found])
            print(
                f"| {name} | {len(found)} | {rows:.0f} | {ours * 1e6:.1f} | {theirs * 1e6:.1f} "
                f"| {ours / theirs:.2f} |"
            )
        print(
            "\nThe largest step at which the boxes stay at rest for 1 s (each within 1 mm), of "
            f"{', '.join(f'{dt * 1e3:g}' for dt in STEPS_TRIED)} ms.\n"
        )
        print("| scene | opendyn (ms) | MuJoCo (ms) |")
        print("|---|---:|---:|")
        for name in names:
            ours, theirs = largest_stable(name)
            print(f"| {name} | {ours * 1e3:g} | {theirs * 1e3:g} |")


if __name__ == "__main__":
    main()
