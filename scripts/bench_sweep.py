"""What a sweep on Dask costs against a plain loop over simulate: N runs of 2 s of the UR5 falling
from random shoulder angles (RK4, 1 ms), one by one in this process, then with od.sweep on a
local cluster of 1 and of 2 worker processes.

    python scripts/bench_sweep.py            # 1,000 runs (about 2 minutes on 2 cores)
    python scripts/bench_sweep.py --runs 100

Prints, for each way: the wall time of the runs, runs per second, and for the sweeps the time to
start the cluster (apart), the speed-up of 2 workers over 1 and the engine's overhead per run
over the loop, (T_sweep,1 worker - T_loop) / N. The runs are the same in all three (one seeded
draw), and the sweep's rows are checked against the loop's final states, bit for bit.
"""

from __future__ import annotations

import argparse
import logging
import time

import opendyn as od
from opendyn.io.scene.variants import Variants
from opendyn.sweep.engine import combinations, parse_axis


def scene():
    return od.default_scene("ur5", duration=2.0, integrator="rk4", dt=0.001, output_dt=0.01)


VARY = {"initial.q.shoulder_lift_joint": "uniform:-1.5:1.5"}


def loop(base, runs):
    """(seconds, final states) of the runs done one by one with simulate."""
    tic = time.perf_counter()
    finals = [od.simulate(base.scene_for(values)).q[-1].tolist() for values in runs]
    return time.perf_counter() - tic, finals


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


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=1000)
    args = parser.parse_args()
    n = args.runs
    base = Variants.of(scene())
    runs = combinations([parse_axis(k, v) for k, v in VARY.items()], samples=n, seed=0)
    od.simulate(base.scene_for(runs[0]))  # compile or load the step before any clock starts
    t_loop, finals = loop(base, runs)
    results = {w: on_cluster(w, n) for w in (1, 2)}
    for start, _, table in results.values():
        assert table.column("q_final").to_pylist() == finals, "the sweep differs from the loop"
    t1, t2 = results[1][1], results[2][1]
    print(f"{n} runs of 2 s of the UR5 (RK4, 1 ms), each from a random shoulder angle\n")
    print("| way | cluster start (s) | runs (s) | runs/s |")
    print("|---|---|---|---|")
    print(f"| loop over simulate, this process | - | {t_loop:.1f} | {n / t_loop:.1f} |")
    for w, (start, t, _) in results.items():
        print(f"| od.sweep, {w} worker{'s' if w > 1 else ''} | {start:.1f} | {t:.1f} | "
              f"{n / t:.1f} |")
    print(f"\nspeed-up of the second worker: {t1 / t2:.2f}x; engine overhead per run over the "
          f"loop (1 worker): {(t1 - t_loop) / n * 1e3:.1f} ms "
          f"({(t1 - t_loop) / t_loop * 100:.0f}% of a run's {t_loop / n * 1e3:.1f} ms)")


if __name__ == "__main__":
    main()
