"""Time opendyn's public API against Pinocchio's Python bindings, in the same run.

    python scripts/bench_core.py [--quick]

Prints, for UR5, Panda and talos_full_v2 (fixed base), microseconds per call and the ratio
opendyn / Pinocchio for inverse dynamics, the mass matrix, forward dynamics (each method),
the Coriolis matrix and a frame Jacobian; then batched inverse dynamics over N = 10,000 states
against a Python loop over pin.rnea and against pin.rneaInParallel; then numba's first-call
compile time and the start-up time with the on-disk cache, measured in fresh processes.
Every call goes through the public API with the argument checks a user gets. Each pair of
functions is timed in alternation (best of 25 rounds each), so that a slow spell of a shared
machine hits both sides alike.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import timeit

import numpy as np
import pinocchio as pin

import opendyn as od

ROBOTS = ("ur5", "panda", "talos_full_v2")


def per_call_us(fn, budget_s):
    """Best of 5 repeats of a loop sized to take about budget_s / 5 each, in microseconds."""
    n = max(1, int(timeit.Timer(fn).autorange()[0]))
    n = max(1, int(n * budget_s / 5 / max(timeit.timeit(fn, number=n), 1e-9)))
    return min(timeit.repeat(fn, number=n, repeat=5)) / n * 1e6


def paired_us(ours, theirs, budget_s, rounds=25):
    """Microseconds per call of two functions timed in alternation, best of `rounds` each, so
    that a slow spell of the machine hits both sides alike."""
    sizes = []
    for fn in (ours, theirs):
        n = max(1, int(timeit.Timer(fn).autorange()[0]))
        sizes.append(max(1, int(n * budget_s / rounds / max(timeit.timeit(fn, number=n), 1e-9))))
    best = [np.inf, np.inf]
    for _ in range(rounds):
        for k, fn in enumerate((ours, theirs)):
            best[k] = min(best[k], timeit.timeit(fn, number=sizes[k]) / sizes[k] * 1e6)
    return best


def pin_state(pmodel, model, q, qd):
    """Pinocchio's q (continuous joints as cos/sin) and v in its joint order."""
    qp, vp = pin.neutral(pmodel), np.zeros(pmodel.nv)
    for k, name in enumerate(model.joint_names):
        joint = pmodel.joints[pmodel.getJointId(name)]
        if joint.nq == 2:
            qp[joint.idx_q : joint.idx_q + 2] = np.cos(q[k]), np.sin(q[k])
        else:
            qp[joint.idx_q] = q[k]
        vp[joint.idx_v] = qd[k]
    return qp, vp


def single_state_rows(name, budget):
    model = od.load_urdf(name, check_inertia=False)
    pmodel = pin.buildModelFromUrdf(model.source)
    pdata = pmodel.createData()
    rng = np.random.default_rng(0)
    q, qd, qdd = rng.uniform(-1, 1, (3, model.nv))
    qp, vp = pin_state(pmodel, model, q, qd)
    ap = pin_state(pmodel, model, q, qdd)[1]
    frame = model.frame_names[-1]
    fid = pmodel.getFrameId(frame)

    def pin_crba_solve():
        M = pin.crba(pmodel, pdata, qp)
        h = pin.nonLinearEffects(pmodel, pdata, qp, vp)
        return np.linalg.solve(M, ap - h)

    cases = [
        (
            "inverse_dynamics",
            lambda: od.inverse_dynamics(model, q, qd, qdd),
            "rnea",
            lambda: pin.rnea(pmodel, pdata, qp, vp, ap),
        ),
        (
            "mass_matrix",
            lambda: od.mass_matrix(model, q),
            "crba",
            lambda: pin.crba(pmodel, pdata, qp),
        ),
        (
            "forward_dynamics aba",
            lambda: od.forward_dynamics(model, q, qd, qdd),
            "aba",
            lambda: pin.aba(pmodel, pdata, qp, vp, ap),
        ),
        (
            "forward_dynamics crba",
            lambda: od.forward_dynamics(model, q, qd, qdd, method="crba"),
            "crba+nle+np.solve",
            pin_crba_solve,
        ),
        (
            "forward_dynamics newton_euler",
            lambda: od.forward_dynamics(model, q, qd, qdd, method="newton_euler"),
            "aba",
            lambda: pin.aba(pmodel, pdata, qp, vp, ap),
        ),
        (
            "coriolis_matrix",
            lambda: od.coriolis_matrix(model, q, qd),
            "computeCoriolisMatrix",
            lambda: pin.computeCoriolisMatrix(pmodel, pdata, qp, vp),
        ),
        (
            "jacobian (body)",
            lambda: od.jacobian(model, q, frame, "body"),
            "computeFrameJacobian",
            lambda: pin.computeFrameJacobian(pmodel, pdata, qp, fid, pin.LOCAL),
        ),
    ]
    rows = []
    for ours_name, ours, pin_name, theirs in cases:
        ours(), theirs()
        t_ours, t_pin = paired_us(ours, theirs, budget)
        rows.append((name, model.nv, ours_name, t_ours, pin_name, t_pin))
    return rows


def batch_rows(name, n_states, budget):
    model = od.load_urdf(name, check_inertia=False)
    pmodel = pin.buildModelFromUrdf(model.source)
    pdata = pmodel.createData()
    rng = np.random.default_rng(1)
    q, qd, qdd = rng.uniform(-1, 1, (3, n_states, model.nv))
    states = [pin_state(pmodel, model, q[k], qd[k]) for k in range(n_states)]
    Qp = np.array([s[0] for s in states])
    Vp = np.array([s[1] for s in states])
    Ap = np.array([pin_state(pmodel, model, q[k], qdd[k])[1] for k in range(n_states)])
    pool = pin.ModelPool(pmodel, 2)
    QpT, VpT, ApT = (np.asfortranarray(x.T) for x in (Qp, Vp, Ap))
    tau_out = np.zeros((pmodel.nv, n_states), order="F")

    def pin_loop():
        for k in range(n_states):
            pin.rnea(pmodel, pdata, Qp[k], Vp[k], Ap[k])

    ours = per_call_us(lambda: od.inverse_dynamics(model, q, qd, qdd), budget)
    loop = per_call_us(pin_loop, budget)
    parallel = per_call_us(lambda: pin.rneaInParallel(2, pool, QpT, VpT, ApT, tau_out), budget)
    return [(name, n_states, ours / n_states, loop / n_states, parallel / n_states)]


STARTUP = """
import time
t0 = time.perf_counter()
import numpy as np
import opendyn as od
m = od.load_urdf("ur5")
q = np.zeros(m.nv)
for method in ("aba", "crba", "newton_euler"):
    od.forward_dynamics(m, q, q, q, method=method)
od.inverse_dynamics(m, q, q, q); od.mass_matrix(m, q); od.coriolis_matrix(m, q, q)
od.jacobian(m, q, m.frame_names[-1]); od.kinetic_energy(m, q, q); od.potential_energy(m, q)
print(time.perf_counter() - t0)
"""


def startup_times():
    """Seconds to import opendyn, load the UR5 and make the first call of each function: with
    an empty kernel cache (compiling) and again with the cache that run wrote."""
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        run = [sys.executable, "-c", STARTUP]
        cold = float(
            subprocess.run(run, env=env, capture_output=True, text=True, check=True).stdout
        )
        warm = float(
            subprocess.run(run, env=env, capture_output=True, text=True, check=True).stdout
        )
    return cold, warm


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="short timing loops (noisier)")
    parser.add_argument("--no-startup", action="store_true", help="skip the compile-time runs")
    args = parser.parse_args()
    budget = 0.1 if args.quick else 0.5

    print(
        f"opendyn {od.__version__}, Pinocchio {pin.__version__}, numpy {np.__version__}, "
        f"{os.cpu_count()} cores\n"
    )
    print("| robot | nv | opendyn | us | Pinocchio | us | ratio |")
    print("|---|---:|---|---:|---|---:|---:|")
    for name in ROBOTS:
        for robot, nv, ours_name, t_ours, pin_name, t_pin in single_state_rows(name, budget):
            print(
                f"| {robot} | {nv} | {ours_name} | {t_ours:.2f} | {pin_name} | {t_pin:.2f} "
                f"| {t_ours / t_pin:.2f} |"
            )

    n = 10_000
    print(f"\nBatched inverse dynamics, N = {n} states, microseconds per state:\n")
    print(
        "| robot | opendyn batch | pin.rnea loop | pin.rneaInParallel (2 threads) "
        "| loop / opendyn |"
    )
    print("|---|---:|---:|---:|---:|")
    for name in ROBOTS:
        for robot, _, ours, loop, parallel in batch_rows(name, n, budget * 4):
            print(f"| {robot} | {ours:.3f} | {loop:.3f} | {parallel:.3f} | {loop / ours:.1f}x |")

    if not args.no_startup:
        cold, warm = startup_times()
        print(
            f"\nImport + UR5 load + first call of every function: {cold:.1f} s with an empty "
            f"kernel cache (numba compiles), {warm:.2f} s with the on-disk cache."
        )


if __name__ == "__main__":
    main()
