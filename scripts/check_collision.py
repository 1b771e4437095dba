"""The collision check over every example-robot-data robot with <collision>: od.distances at
random configurations against coal on the same geometries and placements (Pinocchio reads the
URDF, meshes are the convex hulls of their points), every witness point on its own shape, and,
where coal's penetration depth is not the least overlap of the two shapes, that least overlap
found by a search over directions (tests/coal_reference.py, which tests/test_distances.py runs
on fewer configurations).

    python scripts/check_collision.py [--configurations N] [--seed S] [ROBOT ...]

Prints a row per robot (pairs, configurations, how each pair was judged) and, last, the largest
errors met by kind: the distance against coal (apart, penetrating), the depth against the
least overlap where coal errs, and how far a witness point lies from its own shape. Fails (exit
1) on the first check that does not hold, naming the pair and configuration.
"""

from __future__ import annotations

import argparse
import pathlib
import sys
import warnings

TESTS = pathlib.Path(__file__).resolve().parents[1] / "tests"
sys.path.insert(0, str(TESTS))

import numpy as np
from coal_reference import check_against_coal
from test_geometry import URDFS

import opendyn as od


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("robots", nargs="*", help="URDF stems (default: every robot)")
    parser.add_argument(
        "--configurations", type=int, default=0,
        help="configurations per robot (default: about 3000 pair checks each, 2 to 20)",
    )
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    worst, total = {}, 0
    print(f"{'robot':28s} {'pairs':>6s} {'q':>3s}  judged by")
    for path in URDFS:
        stem = pathlib.Path(path).stem
        if args.robots and stem not in args.robots:
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model = od.load_urdf(path, check_inertia=False)
        pairs = len(model.collision_pairs)
        n = args.configurations or int(np.clip(3000 // max(pairs, 1), 2, 20))
        checked = check_against_coal(model, n, args.seed, worst)
        total += sum(checked.values())
        judged = ", ".join(f"{kind} {count}" for kind, count in checked.items())
        print(f"{stem:28s} {pairs:6d} {n:3d}  {judged}", flush=True)
    print(f"\n{total} pair checks; the largest errors met:")
    for kind, error in sorted(worst.items()):
        print(f"  {kind:50s} {error:.2e} m")


if __name__ == "__main__":
    main()
