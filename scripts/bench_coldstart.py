"""What a first run costs: numba compiling opendyn's kernels in a fresh, empty cache, against the
same run once the on-disk cache is warm.

    python scripts/bench_coldstart.py [--quick] [--wheel WHEEL] [--json FILE] [--docs]

Measures, each in fresh processes (wall time of the whole process, import included), for the
source install (the checkout) and, with --wheel, for a wheel built by scripts/build_wheel.py
(installed into a new folder; every run in its own empty kernel cache, as on a machine that
never ran opendyn, so that what it does not compile it loads from the wheel):
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
import re
import subprocess
import sys
import tempfile
import time

import docs_page

# The first call of each function (opendyn.cli.cache.core_calls, the list `opendyn
# compile` runs), in one process, after `import opendyn` (which imports no layer) and the import
# of the layers those calls use; prints {name: seconds} as JSON. Run as a child process so that
# every measurement starts with nothing loaded.
LAYERS = "import the layers (numpy, numba, the kernels' modules)"
FIRST_CALLS = f"LAYERS = {LAYERS!r}\n" + r"""
import json, time
t0 = time.perf_counter()
import opendyn as od
times = {"import opendyn": time.perf_counter() - t0}
t0 = time.perf_counter()
from opendyn.cli.cache import core_calls
times[LAYERS] = time.perf_counter() - t0
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


def _env(cache, site):
    env = dict(os.environ)
    env["NUMBA_CACHE_DIR"] = cache
    if site:
        env["PYTHONPATH"] = site
    return env


def timed(cmd, cache, site=None):
    """Wall time (s) of a child process run with NUMBA_CACHE_DIR=cache, and its stdout; with
    `site` (a folder the wheel is installed in), the opendyn found there, run from a folder
    outside the checkout."""
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as elsewhere:
        proc = subprocess.run(cmd, env=_env(cache, site), capture_output=True, text=True,
                              cwd=elsewhere if site else None)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed:\n{proc.stdout}\n{proc.stderr}")
    return wall, proc.stdout


# the run summary's report of its step's compile: "...; 18.5 s more compiling the step, ..."
STEP_COMPILED = re.compile(r"([0-9.]+) s more compiling the step")


def simulate_cold_warm(scene, site, then=None):
    """(cold, warm, wheel, step, after) wall seconds of `opendyn simulate [scene]` in a fresh
    cache (--no-save: the start-up and the run), warm in that cache, and from the wheel
    installed in `site` in another fresh cache (None without one); step: the seconds the cold
    run reports compiling its step (None if it reports none); after: timed(then) in the same
    cache once those ran (None without a command `then`)."""
    cmd = [sys.executable, "-m", "opendyn.cli", "simulate", "--no-save"]
    cmd += [scene] if scene else []
    with tempfile.TemporaryDirectory() as cache:
        cold, out = timed(cmd, cache)
        warm, _ = timed(cmd, cache)
        after = timed(then, cache) if then else None
    step = STEP_COMPILED.search(out)
    step = float(step.group(1)) if step else None
    return cold, warm, _from_wheel(cmd, site)[0], step, after


def _from_wheel(cmd, site):
    """(wall s, stdout) of `cmd` with the wheel installed in `site`, in an empty cache; (None,
    None) without a wheel."""
    if not site:
        return None, None
    with tempfile.TemporaryDirectory() as cache:
        return timed(cmd, cache, site)


ROLLOUT = (
    "import opendyn as od; print(od.rollout('double_pendulum_swing', threads=1).stats"
    "['compile_s'])"
)


def rollout_cold_warm():
    """(cold, warm, compiled): wall seconds of a process that rolls the default scene out once,
    in an empty cache, then warm; and the seconds the cold one reports compiling."""
    cmd = [sys.executable, "-c", ROLLOUT]
    with tempfile.TemporaryDirectory() as cache:
        cold, out = timed(cmd, cache)
        warm, _ = timed(cmd, cache)
    return cold, warm, float(out.split()[-1])


def first_calls(site):
    """({call: cold s}, {call: warm s}, {call: s from the wheel} or None) of the first call of
    every core function on a UR5."""
    cmd = [sys.executable, "-c", FIRST_CALLS]
    with tempfile.TemporaryDirectory() as cache:
        _, cold = timed(cmd, cache)
        _, warm = timed(cmd, cache)
    _, wheel = _from_wheel(cmd, site)
    return json.loads(cold), json.loads(warm), json.loads(wheel) if wheel else None


def installed(wheel, folder):
    """The folder `wheel` is installed into (pip --target), or None without a wheel."""
    if not wheel:
        return None
    site = os.path.join(folder, "site")
    subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--target",
                    site, wheel], check=True)
    return site


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="default scene and functions only")
    parser.add_argument(
        "--wheel", help="a wheel built by scripts/build_wheel.py: its first runs too"
    )
    parser.add_argument("--json", help="also write every number to this file")
    parser.add_argument(
        "--docs", action="store_true", help="also write the tables to docs/performance/startup.md"
    )
    args = parser.parse_args()
    title = "Start-up: compiling the kernels, and the on-disk cache"
    with (
        docs_page.page("startup.md", title, enabled=args.docs),
        tempfile.TemporaryDirectory() as tmp,
    ):
        results = print_tables(args.quick, installed(args.wheel, tmp))
    if args.json:
        with open(args.json, "w") as f:
            json.dump(results, f, indent=1)


DEFAULT = "double_pendulum_swing"


def estimate(scene):
    """What the compile notice says `scene`'s step takes to compile (opendyn.sim.driver)."""
    from opendyn import load_scene
    from opendyn.sim.driver import compile_estimate

    return compile_estimate(load_scene(scene))


def _estimated(words, compiled):
    """The table's cells: the notice's estimate (words), the seconds compiled, their ratio."""
    if compiled is None:
        return f"{words} | |"
    said = float(re.search(r"[0-9.]+", words).group())
    return f"{words} | {compiled:.1f} | {compiled / said:.2f}"


def _s(seconds, digits=1):
    return "" if seconds is None else f"{seconds:.{digits}f}"


def print_tables(quick, site):
    """Measure and print every table (the shipped scenes' rows skipped when `quick`; the
    wheel's column with `site`, the folder it is installed in); returns every number, as
    --json writes them."""
    results = {}
    from opendyn.sim.rollout import BATCH_LOOP_SECONDS

    wheel_col = " wheel, first run |" if site else ""
    wheel_rule = "---:|" if site else ""

    print("## opendyn simulate, whole process (s)\n")
    print("Cold: the source install's first run, in an empty cache; warm: the same again."
          + (" Wheel: the first run of the wheel built by `scripts/build_wheel.py`, installed"
             " into a new folder, in an empty cache." if site else "") + "\n")
    print("The compile notice's estimate is what its one notice says the run's kernels take "
          "to compile (its start checks, its step and its record); compiled is what the cold "
          "run then reports it took, and the ratio the two's.\n")
    print(f"| command | cold (empty cache) | warm | notice's estimate | compiled | ratio |"
          f"{wheel_col}")
    print(f"|---|---:|---:|---|---:|---:|{wheel_rule}")
    # the rollout after a plain run: in the cache the default scene's runs leave
    rollout = [sys.executable, "-c", ROLLOUT]
    cold, warm, wheel, step, (after, after_out) = simulate_cold_warm(None, site, rollout)
    results["simulate (default scene)"] = (cold, warm, wheel, step)
    print(f"| `opendyn simulate` (default scene) | {cold:.1f} | {warm:.2f} |"
          f" {_estimated(estimate(DEFAULT), step)} |" + (f" {_s(wheel, 2)} |" if site else ""))
    after_compiled = float(after_out.split()[-1])
    cold, warm, compiled = rollout_cold_warm()
    results["rollout (default scene)"] = (cold, warm, compiled, after, after_compiled)
    print(f"| `od.rollout` of the default scene, one run | {cold:.1f} | {warm:.2f} |"
          f" {_estimated(estimate(DEFAULT), compiled)} |" + (" |" if site else ""))
    print(f"| the same, after `opendyn simulate` of it | {after:.1f} | |"
          f" {_estimated(f'about {BATCH_LOOP_SECONDS} s', after_compiled)} |"
          + (" |" if site else ""))
    if not quick:
        for scene in SCENES:
            cold, warm, wheel, step, _ = simulate_cold_warm(scene, site)
            results[f"simulate {scene}"] = (cold, warm, wheel, step)
            print(f"| `opendyn simulate {scene}` | {cold:.1f} | {warm:.2f} |"
                  f" {_estimated(estimate(scene), step)} |"
                  + (f" {_s(wheel, 2)} |" if site else ""))
    sys.stdout.flush()

    cold, warm, wheel = first_calls(site)
    results["first calls"] = {"cold": cold, "warm": warm, "wheel": wheel}
    print("\n## First call of each function on the UR5, in one process (s)\n")
    print(f"| call | cold | warm |{' wheel, first call |' if site else ''}")
    print(f"|---|---:|---:|{wheel_rule}")
    for name in cold:
        print(f"| {name} | {cold[name]:.2f} | {warm[name]:.4f} |"
              + (f" {wheel[name]:.4f} |" if site else ""))
    core = [n for n in cold if n not in CONSTRAINT_CALLS and n not in ("import opendyn", LAYERS)]
    core = [n for n in core if n != "load_urdf(ur5)"]
    total_core = sum(cold[n] for n in core)
    total_con = sum(cold[n] for n in CONSTRAINT_CALLS)
    print(
        f"\nCore functions (dynamics, kinematics, energy, task space; single and batch): "
        f"{total_core:.1f} s cold, {sum(warm[n] for n in core):.3f} s warm"
        + (f", {sum(wheel[n] for n in core):.3f} s from the wheel" if site else "")
        + f"; the constraint functions add {total_con:.1f} s cold."
    )
    results["totals"] = {"core_cold": total_core, "constraints_cold": total_con}
    return results


if __name__ == "__main__":
    main()
