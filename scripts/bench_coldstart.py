"""What a first run costs: numba compiling opendyn's kernels in a fresh, empty cache, against the
same run once the on-disk cache is warm.

    python scripts/bench_coldstart.py [--quick] [--json FILE] [--docs]

Measures, each in fresh processes (wall time of the whole process, import included):
  - `opendyn simulate` on the default scene, cold (empty NUMBA_CACHE_DIR) and warm (again, in
    that cache), and `od.rollout` of the default scene (one run) the same way;
  - `opendyn simulate SCENE` for every shipped scene, each cold in its own empty cache, then
    warm (skipped with --quick);
  - the first call of every public core function on the UR5 (example-robot-data), single
    states and batches, all in one process: cold, then warm in a second process.
Prints Markdown tables (the README's "Start-up" section is written from them). With --docs it also
writes what it prints to docs/performance/startup.md, under a header that says when, on what
machine and with which versions it ran and the command that reproduces it (scripts/docs_page.py).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import docs_page

# The first call of each function (opendyn.cli.cache.core_calls, the list `opendyn
# compile` runs), in one process; prints {name: seconds} as JSON. Run as a child process so that
# every measurement starts with nothing loaded.
FIRST_CALLS = r"""
import json, time
t0 = time.perf_counter()
import opendyn as od
from opendyn.cli.cache import core_calls
times = {"import opendyn": time.perf_counter() - t0}
t0 = time.perf_counter()
model = od.load_urdf("ur5")
times["load_urdf(ur5)"] = time.perf_counter() - t0
for name, call in core_calls(model):
    t0 = time.perf_counter()
    call()
    times[name] = time.perf_counter() - t0
print(json.dumps(times))
"""

CONSTRAINT_CALLS = (
    "constraint_jacobian",
    "constraint_drift",
    "constraint_error",
    "constrained_forward_dynamics",
)
SCENES = (
    "double_pendulum_swing",
    "double_pendulum_push",
    "planar_3r_limits",
    "ur5_falling",
    "panda_computed_torque",
    "four_bar",
    "planar_3r_pinned",
    "ur5_on_plane",
    "ball_drop",
    "quadruped_drop",
    "panda_impedance",
)


def _env(cache):
    env = dict(os.environ)
    env["NUMBA_CACHE_DIR"] = cache
    return env


def timed(cmd, cache):
    """Wall time (s) of a child process run with NUMBA_CACHE_DIR=cache, and its stdout."""
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, env=_env(cache), capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed:\n{proc.stdout}\n{proc.stderr}")
    return wall, proc.stdout


def simulate_cold_warm(scene):
    """(cold, warm) wall seconds of `opendyn simulate [scene]` in a fresh cache (--no-save:
    the start-up and the run, as measured before the command saved by default)."""
    cmd = [sys.executable, "-m", "opendyn.cli", "simulate", "--no-save"]
    cmd += [scene] if scene else []
    with tempfile.TemporaryDirectory() as cache:
        cold, _ = timed(cmd, cache)
        warm, _ = timed(cmd, cache)
    return cold, warm


ROLLOUT = "import opendyn as od; od.rollout('double_pendulum_swing', threads=1)"


def rollout_cold_warm():
    """(cold, warm) wall seconds of a process that rolls the default scene out once."""
    cmd = [sys.executable, "-c", ROLLOUT]
    with tempfile.TemporaryDirectory() as cache:
        cold, _ = timed(cmd, cache)
        warm, _ = timed(cmd, cache)
    return cold, warm


def first_calls():
    """({call: cold s}, {call: warm s}) of the first call of every core function on a UR5."""
    cmd = [sys.executable, "-c", FIRST_CALLS]
    with tempfile.TemporaryDirectory() as cache:
        _, cold = timed(cmd, cache)
        _, warm = timed(cmd, cache)
    return json.loads(cold), json.loads(warm)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="default scene and functions only")
    parser.add_argument("--json", help="also write every number to this file")
    parser.add_argument(
        "--docs", action="store_true", help="also write the tables to docs/performance/startup.md"
    )
    args = parser.parse_args()
    title = "Start-up: compiling the kernels, and the on-disk cache"
    with docs_page.page("startup.md", title, enabled=args.docs):
        results = print_tables(args.quick)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(results, f, indent=1)


def print_tables(quick):
    """Measure and print every table (the shipped scenes' rows skipped when `quick`); returns
    every number, as --json writes them."""
    results = {}

    cold, warm = simulate_cold_warm(None)
    results["simulate (default scene)"] = (cold, warm)
    print("## opendyn simulate, whole process (s)\n")
    print("| command | cold (empty cache) | warm |")
    print("|---|---:|---:|")
    print(f"| `opendyn simulate` (default scene) | {cold:.1f} | {warm:.2f} |")
    cold, warm = rollout_cold_warm()
    results["rollout (default scene)"] = (cold, warm)
    print(f"| `od.rollout` of the default scene, one run | {cold:.1f} | {warm:.2f} |")
    if not quick:
        for scene in SCENES:
            cold, warm = simulate_cold_warm(scene)
            results[f"simulate {scene}"] = (cold, warm)
            print(f"| `opendyn simulate {scene}` | {cold:.1f} | {warm:.2f} |")
    sys.stdout.flush()

    cold, warm = first_calls()
    results["first calls"] = {"cold": cold, "warm": warm}
    print("\n## First call of each function on the UR5, in one process (s)\n")
    print("| call | cold | warm |")
    print("|---|---:|---:|")
    for name in cold:
        print(f"| {name} | {cold[name]:.2f} | {warm[name]:.4f} |")
    core = [n for n in cold if n not in CONSTRAINT_CALLS and n not in ("import opendyn",)]
    core = [n for n in core if n != "load_urdf(ur5)"]
    total_core = sum(cold[n] for n in core)
    total_con = sum(cold[n] for n in CONSTRAINT_CALLS)
    print(
        f"\nCore functions (dynamics, kinematics, energy, task space; single and batch): "
        f"{total_core:.1f} s cold, {sum(warm[n] for n in core):.3f} s warm; "
        f"the constraint functions add {total_con:.1f} s cold."
    )
    results["totals"] = {"core_cold": total_core, "constraints_cold": total_con}
    return results


if __name__ == "__main__":
    main()
