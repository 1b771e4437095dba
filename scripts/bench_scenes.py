"""Time the simulation step of shipped scenes, paired against another checkout of opendyn.

    python scripts/bench_scenes.py [--against PATH] [--rounds N] [--docs] [SCENE ...]

For each scene (default: double_pendulum_push, a wrench; quadruped_drop, ground contact;
ur5_falling, gravity alone) it runs ``simulate`` in a fresh process for this checkout and, with
``--against``, for the checkout at PATH (a source tree with its own ``opendyn/``, e.g. a git
worktree of the previous release), in alternation, best of N rounds (5). Each process loads or
compiles its kernels first (a warm-up run, not timed), then times whole runs and prints
microseconds per step. The table gives both and their ratio: below 1 this checkout is faster.

With --docs it also writes the table to docs/performance/scenes.md, under a header that says
when, on what machine and with which versions it ran (opendyn's: this checkout's) and the command
that reproduces it (scripts/docs_page.py).
"""

from __future__ import annotations

import argparse
import json
import os
import pathlib
import subprocess
import sys

import docs_page

ROOT = pathlib.Path(__file__).resolve().parents[1]
DEFAULT_SCENES = ("double_pendulum_push", "quadruped_drop", "ur5_falling")

# run in a fresh process with the checkout first on the path: microseconds per step of the best
# of `repeats` whole runs, after one run that loads or compiles the kernels
_TIME_SCENE = r"""
import json, sys, time
import opendyn as od
scene = od.load_scene(sys.argv[1])
od.simulate(scene)
best = float("inf")
for _ in range(int(sys.argv[2])):
    tic = time.perf_counter()
    traj = od.simulate(scene)
    best = min(best, time.perf_counter() - tic)
steps = round(scene.run.duration / scene.run.dt)
print(json.dumps({"us_per_step": best / steps * 1e6, "steps": steps, "source": od.__file__}))
"""


def time_scene(checkout: pathlib.Path, scene: str, repeats: int) -> dict:
    """The scene's microseconds per step with the opendyn of `checkout`."""
    env = dict(os.environ, PYTHONPATH=str(checkout))
    proc = subprocess.run(
        [sys.executable, "-c", _TIME_SCENE, scene, str(repeats)],
        env=env,
        capture_output=True,
        text=True,
        check=True,
        cwd=checkout,
    )
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    if not pathlib.Path(out["source"]).resolve().is_relative_to(checkout.resolve()):
        raise SystemExit(f"{checkout}: imported opendyn from {out['source']}, not from it")
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenes", nargs="*", default=DEFAULT_SCENES)
    parser.add_argument("--against", type=pathlib.Path, help="another checkout to pair with")
    parser.add_argument("--rounds", type=int, default=5, help="best of N rounds")
    parser.add_argument(
        "--docs", action="store_true", help="also write the table to docs/performance/scenes.md"
    )
    args = parser.parse_args()
    # the header's opendyn version is this checkout's, the one timed first
    sys.path.insert(0, str(ROOT))
    title = "Scenes: microseconds per simulation step"
    with docs_page.page("scenes.md", title, enabled=args.docs, argv=_public_argv(sys.argv[1:])):
        if args.against:
            print(f"The other checkout (OTHER_CHECKOUT below): {_described(args.against)}.\n")
        print_table(args)


def _public_argv(argv):
    """argv with the other checkout's path (a path on this machine) as OTHER_CHECKOUT."""
    public, hide = [], False
    for arg in argv:
        if hide:
            public.append("OTHER_CHECKOUT")
        elif arg.startswith("--against="):
            public.append("--against=OTHER_CHECKOUT")
        else:
            public.append(arg)
        hide = arg == "--against"
    return public


def _described(checkout):
    """The other checkout as its git commit says it (or 'not a git checkout')."""
    done = subprocess.run(
        ["git", "-C", str(checkout), "log", "-1", "--format=commit %h of %cs"],
        capture_output=True, text=True,
    )
    return done.stdout.strip() if done.returncode == 0 else "not a git checkout"


def print_table(args):
    """Time each of args.scenes with this checkout and args.against, and print the table."""
    checkouts = [ROOT] + ([args.against] if args.against else [])
    header, rule = "| scene | steps | this checkout (us/step) |", "|---|---:|---:|"
    if args.against:
        header, rule = header + " other (us/step) | ratio |", rule + "---:|---:|"
    print(header)
    print(rule)
    for scene in args.scenes:
        best = [float("inf")] * len(checkouts)
        steps = 0
        for _ in range(args.rounds):
            for k, checkout in enumerate(checkouts):
                out = time_scene(checkout, scene, repeats=3)
                best[k] = min(best[k], out["us_per_step"])
                steps = out["steps"]
        row = f"| {scene} | {steps} | {best[0]:.2f} |"
        if args.against:
            row += f" {best[1]:.2f} | {best[0] / best[1]:.2f} |"
        print(row)


if __name__ == "__main__":
    main()
