"""Collision queries: opendyn's od.distances against Pinocchio's computeDistances (coal, C++)
with the same convex geometry, in the same process; a box resting on a halfspace in a compiled
loop; and what the collision kernels cost to compile.

    python scripts/bench_collision.py [--quick] [--docs]

Measures:
  - od.distances over every pair of model.collision_pairs, with and without data=, against
    pin.computeDistances over the same pairs (each mesh as the convex hull of its vertices:
    coal.Convex.convexHull of the points of Pinocchio's buildConvexRepresentation, the geometry
    opendyn uses), on the Panda, Solo12 and Talos, at the same random configurations, and the
    largest difference of the two distances;
  - the contacts of a box resting face-on on a halfspace (four corners), a call in a compiled
    loop;
  - the first call of od.distances and od.collisions in a fresh kernel cache (compile time), and
    whether `opendyn simulate` of the default scene compiles any collision kernel (it should
    not: a scene that does not ask for collision does not compile or run it).
With --docs it also writes what it prints to docs/performance/collision.md (scripts/docs_page.py).
"""

from __future__ import annotations

import argparse
import os
import pathlib
import subprocess
import sys
import tempfile
import time

import docs_page
import numpy as np

import opendyn as od

ROBOTS = ("panda", "solo12", "talos_full_v2")

FIRST_QUERIES = r"""
import time
import opendyn as od
model = od.load_urdf("panda")
q = od.neutral(model)
t0 = time.perf_counter(); od.distances(model, q); t1 = time.perf_counter()
od.collisions(model, q); t2 = time.perf_counter()
print(t1 - t0, t2 - t1)
"""


def pinocchio_geometry(model):
    """(pin model, pin data, geometry model, geometry data) of model's URDF with model's
    collision pairs, every mesh the convex hull of its vertices."""
    import coal
    import pinocchio as pin

    path = model.source
    share = next(str(p.parent) for p in pathlib.Path(path).parents if p.name == "example-robot-data")
    pin_model = pin.buildModelFromUrdf(path)
    geometry = pin.buildGeomFromUrdf(pin_model, path, pin.COLLISION, package_dirs=[share])
    for obj in geometry.geometryObjects:
        if isinstance(obj.geometry, coal.BVHModelBase):
            obj.geometry.buildConvexRepresentation(False)
            points = coal.StdVec_Vec3s()
            for v in np.array(obj.geometry.convex.points()):
                points.append(v)
            obj.geometry = coal.Convex.convexHull(points, False, None)
    index, seen = {}, {}
    for i, obj in enumerate(geometry.geometryObjects):
        link = pin_model.frames[obj.parentFrame].name
        k = seen[link] = seen.get(link, -1) + 1
        index[link, k] = i
    ours, seen = [], {}
    for g in model.geometries:
        k = seen[g.link] = seen.get(g.link, -1) + 1
        ours.append(index[g.link, k])
    for a, b in model.collision_pairs:
        geometry.addCollisionPair(pin.CollisionPair(ours[a], ours[b]))
    return pin_model, pin_model.createData(), geometry, pin.GeometryData(geometry)


def pinocchio_order(model, pin_model):
    """The permutation P with q_pin = q[P] for a fixed-base model of 1-dof joints (the two
    libraries walk a tree's children in different orders)."""
    assert pin_model.nq == model.nq, "continuous joints (cos, sin in Pinocchio) are not mapped"
    order = np.empty(model.nq, dtype=int)
    for k, name in enumerate(model.joint_names):
        order[pin_model.idx_qs[pin_model.getJointId(name)]] = model.q_index[k]
    return order


def per_call(call, states, budget):
    """Seconds per call, the best of 3 rounds over the states (each round at least budget s)."""
    best = np.inf
    for _ in range(3):
        n, t0 = 0, time.perf_counter()
        while time.perf_counter() - t0 < budget:
            for x in states:
                call(x)
            n += len(states)
        best = min(best, (time.perf_counter() - t0) / n)
    return best


def distance_rows(budget):
    import pinocchio as pin

    rng = np.random.default_rng(0)
    print("| robot | pairs | od.distances | with data= | pin.computeDistances | ratio "
          "(data=) | largest difference (m) |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for name in ROBOTS:
        model = od.load_urdf(name)
        pin_model, pin_data, geometry, geometry_data = pinocchio_geometry(model)
        lower = np.where(np.isfinite(model.lower), model.lower, -np.pi)
        upper = np.where(np.isfinite(model.upper), model.upper, np.pi)
        states = [rng.uniform(lower, upper) for _ in range(8)]
        pin_states = [q[pinocchio_order(model, pin_model)] for q in states]
        data = od.Data(model)
        od.distances(model, states[0], data=data)
        t_new = per_call(lambda q: od.distances(model, q), states, budget)
        t_data = per_call(lambda q: od.distances(model, q, data=data), states, budget)
        t_pin = per_call(
            lambda q: pin.computeDistances(pin_model, pin_data, geometry, geometry_data, q),
            pin_states,
            budget,
        )
        worst = 0.0
        for q, q_pin in zip(states, pin_states):
            ours = od.distances(model, q).distance
            pin.computeDistances(pin_model, pin_data, geometry, geometry_data, q_pin)
            theirs = [r.min_distance for r in geometry_data.distanceResults]
            worst = max(worst, float(np.max(np.abs(ours - theirs))))
        print(
            f"| {name} | {len(model.collision_pairs)} | {t_new * 1e6:.0f} us | "
            f"{t_data * 1e6:.0f} us | {t_pin * 1e6:.0f} us | {t_data / t_pin:.2f} | {worst:.1e} |"
        )


def box_on_halfspace(budget):
    """Seconds per call of the contacts of a box resting on a halfspace, in a compiled loop."""
    from numba import njit

    from opendyn.algorithm.collision.narrow_phase import no_hull, work_array
    from opendyn.algorithm.collision.queries import pair_contacts
    from opendyn.multibody.shapes import BOX, HALFSPACE

    @njit
    def loop(n, box, plane, rows, scratch):
        total = 0
        for _ in range(n):
            count, _ = pair_contacts(box, plane, 0.0, rows, scratch)
            total += count
        return total

    T_box = np.eye(4)
    T_box[2, 3] = 0.05 - 1e-3  # a 0.1 m cube sunk 1 mm into the ground
    box = (BOX, np.array([0.1, 0.1, 0.1]), no_hull(), T_box)
    plane = (HALFSPACE, np.zeros(3), no_hull(), np.eye(4))
    rows, scratch = np.zeros((4, 10)), work_array()
    assert loop(1, box, plane, rows, scratch) == 4
    n, best = 100_000, np.inf
    for _ in range(3):
        t0 = time.perf_counter()
        loop(n, box, plane, rows, scratch)
        best = min(best, (time.perf_counter() - t0) / n)
    return best


def compile_times():
    """(first od.distances, first od.collisions) in a fresh cache, and the collision kernels
    `opendyn simulate` of the default scene compiles in another fresh cache."""
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "NUMBA_CACHE_DIR": cache}
        out = subprocess.run(
            [sys.executable, "-c", FIRST_QUERIES], env=env, capture_output=True, text=True,
            check=True,
        ).stdout
        first_distances, first_collisions = (float(x) for x in out.split())
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "NUMBA_CACHE_DIR": cache}
        run = subprocess.run(
            [sys.executable, "-m", "opendyn.cli", "simulate", "--no-save"], env=env, capture_output=True,
            text=True, check=True,
        )
        compiled = [line for line in run.stderr.splitlines() if "collision" in line]
    return first_distances, first_collisions, compiled


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="short timing loops (noisier)")
    parser.add_argument(
        "--docs", action="store_true", help="also write docs/performance/collision.md"
    )
    args = parser.parse_args()
    title = "Collision queries: opendyn against Pinocchio and coal"
    with docs_page.page("collision.md", title, enabled=args.docs, modules=("pinocchio",)):
        budget = 0.1 if args.quick else 0.5
        print(
            "od.distances over every pair of model.collision_pairs against "
            "pin.computeDistances over the same pairs (coal, each mesh as the convex hull of "
            "its vertices), 8 random configurations within the joint limits, microseconds a "
            "call, in the same process:\n"
        )
        distance_rows(budget)
        print(
            "\nThe largest difference is of the size of coal's default GJK tolerance in "
            "computeDistances (1e-6 m); the suite runs coal at 1e-12 and holds opendyn to it "
            "within 1e-6 m apart and 1e-5 m in penetration (tests/test_distances.py)."
        )
        t_box = box_on_halfspace(budget)
        print(
            f"\nThe four contacts of a box resting on a halfspace, in a compiled loop: "
            f"{t_box * 1e6:.3f} us a call.\n"
        )
        first_distances, first_collisions, compiled = compile_times()
        print(
            f"Compile time in a fresh kernel cache (the Panda): the first od.distances "
            f"{first_distances:.1f} s, then the first od.collisions {first_collisions:.1f} s. "
            f"`opendyn simulate` of the default scene in another fresh cache compiled "
            f"{len(compiled)} collision kernels."
        )


if __name__ == "__main__":
    main()
