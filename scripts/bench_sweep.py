"""What thousands of runs cost: N runs of 2 s of the UR5 falling from random shoulder angles (RK4,
1 ms, 2,000 steps each), with od.rollout against MuJoCo's rollout, and with od.sweep on a local
Dask cluster against a bare rollout.

    python scripts/bench_sweep.py                # 1,000 runs (about 8 minutes on 2 cores)
    python scripts/bench_sweep.py --runs 200 --rounds 1
    python scripts/bench_sweep.py --memory       # and record="final" over 100,000 runs
    python scripts/bench_sweep.py --docs         # and write docs/performance/sweeps.md

1. Rollouts, in this process, alternating, best of --rounds: od.rollout with threads = 1 and 2
   against mujoco.rollout.rollout with 1 and 2 threads (one MjData each) on the same initial
   states (the MuJoCo model of scripts/bench_sim.py: the same URDF, RK4 at 1 ms, no contact or
   limits). MuJoCo keeps every step's state; opendyn runs once keeping every step too
   (output_dt = dt) and once keeping the final states only (record="final"). Prints steps per
   second and opendyn's over MuJoCo's. Checks that opendyn's final states agree with MuJoCo's to
   within what the chaotic motion allows (printed) and with simulate's bit for bit.
2. Sweeps (output_dt = 10 ms, as a sweep's scene would record): od.sweep on a local cluster of 1
   and of 2 worker processes, a bare od.rollout (threads = 1, the same runs and record), and a
   loop over simulate; the bare rollout and the 1-worker sweep alternate, best of --rounds.
   Prints runs per second, the second worker's speed-up and the engine's overhead per run over
   the bare rollout, (T_sweep,1 worker - T_rollout) / N; the sweep's rows
   are checked against the rollout's final states, bit for bit. Then the chunk size the sweep
   chose, the seconds of work per task and the tasks per second a scheduler would then need to
   feed 16 and 64 workers.
3. --memory: the peak memory that a rollout of 100,000 runs of 0.02 s with record="final"
   allocates (tracemalloc, in a fresh process).

With --docs it also writes what it prints to docs/performance/sweeps.md, under a header that says
when, on what machine and with which versions it ran and the command that reproduces it
(scripts/docs_page.py).
"""

from __future__ import annotations

import argparse
import dataclasses
import logging
import subprocess
import sys
import time

import docs_page
import mujoco
import numpy as np
from bench_sim import MujocoSim
from mujoco import rollout as mujoco_rollout

import opendyn as od
from opendyn.io.scene.variants import Variants
from opendyn.sweep.engine import _run_seconds, chunk_runs
from opendyn.sweep.specs import combinations, parse_axis

DURATION, DT = 2.0, 1e-3
VARY = {"initial.q.shoulder_lift_joint": "uniform:-1.5:1.5"}


def scene(output_dt=0.01):
    return od.default_scene("ur5", duration=DURATION, integrator="rk4", dt=DT,
                            output_dt=output_dt)


def initial_states(n):
    """(values, q0 (n, 6)): the runs' values as the sweep draws them, and their q0."""
    runs = combinations([parse_axis(k, v) for k, v in VARY.items()], samples=n, seed=0)
    base = Variants.of(scene())
    return runs, np.array([base.scene_for(values).q0 for values in runs])


def best_of(calls, rounds):
    """{name: (best seconds, last result)} of calls {name: fn}, alternating over the rounds."""
    times, results = {name: [] for name in calls}, {}
    for _ in range(rounds):
        for name, call in calls.items():
            tic = time.perf_counter()
            results[name] = call()
            times[name].append(time.perf_counter() - tic)
    return {name: (min(t), results[name]) for name, t in times.items()}


def rollouts(q0, rounds):
    n = len(q0)
    steps = n * round(DURATION / DT)
    every = scene(output_dt=DT)
    model = od.load_urdf("ur5")
    mj = MujocoSim(model.source, model.joint_names)
    initial = np.empty((n, mj.nstate))
    for i in range(n):
        mj.set_state(q0[i], np.zeros(model.nv))
        mujoco.mj_getState(mj.model, mj.data, initial[i], mj.spec)
    datas = {k: [mujoco.MjData(mj.model) for _ in range(k)] for k in (1, 2)}
    od.rollout(every, q0=q0[:2])  # compile or load before any clock starts
    mujoco_rollout.rollout(mj.model, datas[2], initial[:2], nstep=10)
    calls = {}
    for k in (1, 2):
        calls[f"od.rollout, every step, {k} thread"] = (
            lambda k=k: od.rollout(every, q0=q0, threads=k)
        )
        calls[f"od.rollout, final states, {k} thread"] = (
            lambda k=k: od.rollout(every, q0=q0, threads=k, record="final")
        )
        calls[f"mujoco rollout, every step, {k} thread"] = (
            lambda k=k: mujoco_rollout.rollout(
                mj.model, datas[k], initial, nstep=round(DURATION / DT)
            )[0]
        )
    best = best_of(calls, rounds)
    print(f"{n} runs of {DURATION:g} s of the UR5 (RK4, {DT * 1e3:g} ms), each from a random "
          f"shoulder angle: {steps:,} steps\n")
    print("| way | threads | s | steps/s | opendyn / MuJoCo |")
    print("|---|---|---|---|---|")
    for k in (1, 2):
        t_mj = best[f"mujoco rollout, every step, {k} thread"][0]
        for what in ("every step", "final states"):
            t = best[f"od.rollout, {what}, {k} thread"][0]
            print(f"| od.rollout, {what} | {k} | {t:.2f} | {steps / t:,.0f} | "
                  f"{t_mj / t:.2f}x the steps/s |")
        print(f"| mujoco.rollout, every step | {k} | {t_mj:.2f} | {steps / t_mj:,.0f} | - |")
    result = best["od.rollout, final states, 2 thread"][1]
    states = best["mujoco rollout, every step, 2 thread"][1]
    q_mj = states[:, -1, 1 : 1 + model.nq][:, mj.idx_q]
    print(f"\nlargest |q| difference of the final states, opendyn against MuJoCo: "
          f"{np.abs(result.q_final - q_mj).max():.2g} rad (the motion is chaotic: see "
          "scripts/bench_sim.py for how far rounding alone carries)")
    first = od.simulate(dataclasses.replace(every, q0=q0[0]))
    assert np.array_equal(result.q_final[0], first.q[-1]), "run 0 differs from simulate"
    print("run 0's final state equals simulate's, bit for bit\n")


def on_cluster(workers, n):
    """(seconds to start the cluster, seconds of the sweep, its table) on a fresh local
    cluster of `workers` processes."""
    from dask.distributed import Client, LocalCluster

    tic = time.perf_counter()
    with LocalCluster(
        n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=":0",
        silence_logs=logging.CRITICAL,
    ) as cluster, Client(cluster) as client:
        client.wait_for_workers(workers)
        client.run(lambda: __import__("opendyn"))  # each worker imports opendyn once
        start = time.perf_counter() - tic
        tic = time.perf_counter()
        table = od.sweep(scene(), VARY, samples=n, seed=0, client=client)
        return start, time.perf_counter() - tic, table


def sweeps(runs, q0, rounds):
    """The sweep engine against a bare rollout of the same runs. The bare rollout and the
    one-worker sweep alternate over the rounds, best of each (this machine's speed drifts by
    10-20% over minutes: runs timed minutes apart differ by more than the engine's share)."""
    n = len(runs)
    base = scene()
    od.rollout(base, q0=q0[:2])  # compile or load before any clock starts
    variants = Variants.of(base)
    tic = time.perf_counter()
    finals = [od.simulate(variants.scene_for(values)).q[-1].tolist() for values in runs]
    t_loop = time.perf_counter() - tic
    bare_times, one_worker = [], []
    for _ in range(rounds):
        tic = time.perf_counter()
        bare = od.rollout(base, q0=q0, threads=1)
        bare_times.append(time.perf_counter() - tic)
        one_worker.append(on_cluster(1, n))
    assert finals == bare.q_final.tolist(), "the rollout differs from the loop over simulate"
    t_bare = min(bare_times)
    results = {1: min(one_worker, key=lambda r: r[1]), 2: on_cluster(2, n)}
    for _, _, table in results.values():
        assert table.column("q_final").to_pylist() == finals, "the sweep differs from the rollout"
    t1, t2 = results[1][1], results[2][1]
    print(f"Sweeps of the same {n} runs, output_dt 10 ms; every row checked against the "
          "rollout's final state, bit for bit\n")
    print("| way | cluster start (s) | runs (s) | runs/s |")
    print("|---|---|---|---|")
    print(f"| loop over simulate, this process | - | {t_loop:.1f} | {n / t_loop:.1f} |")
    print(f"| od.rollout, threads=1, this process | - | {t_bare:.1f} | {n / t_bare:.1f} |")
    for w, (start, t, _) in results.items():
        print(f"| od.sweep, {w} worker{'s' if w > 1 else ''} | {start:.1f} | {t:.1f} | "
              f"{n / t:.1f} |")
    per_run = t_bare / n
    overhead = (t1 - t_bare) / n
    print(f"\nspeed-up of the second worker: {t1 / t2:.2f}x; the engine's overhead per run over "
          f"the bare rollout (1 worker, best of {len(bare_times)} alternating rounds each): "
          f"{overhead * 1e3:.2f} ms ({overhead / per_run * 100:.1f}% "
          f"of a run's {per_run * 1e3:.1f} ms)")
    run_s = _run_seconds([base])
    size = chunk_runs(n, 2, run_s)
    task_s = size * run_s
    print(f"chunks: a run estimated at {run_s * 1e3:.1f} ms, {size} runs a task on 2 workers "
          f"({task_s:.2f} s of work); at that size 16 workers need {16 / task_s:.0f} tasks/s "
          f"and 64 workers {64 / task_s:.0f} tasks/s from the scheduler (at most "
          f"{16 / 0.1:.0f} and {64 / 0.1:.0f} for any sweep: tasks hold at least 0.1 s)\n")


MEMORY_RUNS = 100_000


def memory():
    """Peak memory of record='final' over MEMORY_RUNS runs, measured in a fresh process by
    tracemalloc (every numpy array and Python object the rollout allocates)."""
    code = f"""
import tracemalloc, numpy as np, opendyn as od
s = od.default_scene("ur5", duration=0.02, integrator="rk4", dt={DT}, output_dt=0.01)
q0 = np.tile(s.q0, ({MEMORY_RUNS}, 1))
q0[:, 1] = np.random.default_rng(0).uniform(-1.5, 1.5, {MEMORY_RUNS})
od.rollout(s, q0=q0[:2], record="final")
tracemalloc.start()
r = od.rollout(s, q0=q0, record="final")
print(tracemalloc.get_traced_memory()[1], int(r.complete.sum()), r.stats["wall_s"])
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.split()
    peak, complete, wall = int(out[0]), int(out[1]), float(out[2])
    print(f"record='final', {MEMORY_RUNS:,} runs of 0.02 s of the UR5 ({complete:,} complete, "
          f"{wall:.1f} s): peak memory allocated {peak / 1e6:.0f} MB, {peak / MEMORY_RUNS:.0f} "
          f"bytes a run")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=1000)
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--memory", action="store_true")
    parser.add_argument(
        "--docs", action="store_true", help="also write the tables to docs/performance/sweeps.md"
    )
    args = parser.parse_args()
    title = "Sweeps: what thousands of runs cost"
    with docs_page.page("sweeps.md", title, enabled=args.docs, modules=("mujoco", "dask")):
        runs, q0 = initial_states(args.runs)
        rollouts(q0, args.rounds)
        sweeps(runs, q0, args.rounds)
        if args.memory:
            memory()


if __name__ == "__main__":
    main()
