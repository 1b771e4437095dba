"""Time opendyn's public API against Pinocchio's Python bindings, in the same run.

    python scripts/bench_core.py [--quick] [--no-startup] [--centroidal] [--docs]

Prints, for UR5, Panda and talos_full_v2 with a fixed base and for solo12, anymal and
talos_full_v2 with a floating base (Pinocchio with a JointModelFreeFlyer root), microseconds per
call and the ratio opendyn / Pinocchio for inverse dynamics, the mass matrix, forward dynamics
(each method), the Coriolis matrix, the derivatives of inverse and forward dynamics
(computeRNEADerivatives, computeABADerivatives) and a frame Jacobian, each without and with a
Data (data=); then the derivatives against central differences of our own functions; then the
centroidal functions and the joint-torque regressor (UR5, Panda, talos fixed, solo12 and talos
floating; the centroidal functions also with data=; --centroidal prints only that table); then
batched inverse dynamics over N = 10,000 states against a Python loop over pin.rnea and against
pin.rneaInParallel; then numba's first-call compile time and the start-up time with the on-disk
cache, measured in fresh processes. States are converted to Pinocchio's conventions by
opendyn.verify's adapter. Every call goes through the public API with the argument checks a user
gets. Each pair of functions is timed in alternation (best of 25 rounds each), so that a slow
spell of a shared machine hits both sides alike.

With --docs it also writes what it prints to docs/performance/core.md, under a header that says
when, on what machine and with which versions it ran and the command that reproduces it
(scripts/docs_page.py). --centroidal prints only a part of the page, so it refuses --docs.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import timeit

import docs_page
import numpy as np
import pinocchio as pin

import opendyn as od
from opendyn.verify.oracle import PinocchioOracle

# (robot, floating base)
ROBOTS = (
    ("ur5", False),
    ("panda", False),
    ("talos_full_v2", False),
    ("solo12", True),
    ("anymal", True),
    ("talos_full_v2", True),
)


def per_call_us(fn, budget_s):
    """Best of 5 repeats of a loop sized to take about budget_s / 5 each, in microseconds."""
    n = max(1, int(timeit.Timer(fn).autorange()[0]))
    n = max(1, int(n * budget_s / 5 / max(timeit.timeit(fn, number=n), 1e-9)))
    return min(timeit.repeat(fn, number=n, repeat=5)) / n * 1e6


def paired_us(*functions, budget_s, rounds=25):
    """Microseconds per call of functions timed in alternation, best of `rounds` each, so
    that a slow spell of the machine hits every side alike."""
    sizes = []
    for fn in functions:
        n = max(1, int(timeit.Timer(fn).autorange()[0]))
        sizes.append(max(1, int(n * budget_s / rounds / max(timeit.timeit(fn, number=n), 1e-9))))
    best = [np.inf] * len(functions)
    for _ in range(rounds):
        for k, fn in enumerate(functions):
            best[k] = min(best[k], timeit.timeit(fn, number=sizes[k]) / sizes[k] * 1e6)
    return best


def load_pair(name, floating_base):
    """opendyn's model, its Pinocchio oracle (state conversions) and a label."""
    model = od.load_urdf(name, floating_base=floating_base, check_inertia=False)
    oracle = PinocchioOracle(model.source, model)
    return model, oracle, name + (" (floating)" if floating_base else "")


def random_states(model, rng, n=None):
    """q, qd, qdd: random configurations (od.random_configuration) and velocities in
    [-1, 1]; (nq,), (nv,) or, with n, (n, nq), (n, nv)."""
    rows = 1 if n is None else n
    q = np.array([od.random_configuration(model, rng) for _ in range(rows)])
    qd, qdd = rng.uniform(-1, 1, (2, rows, model.nv))
    return (q[0], qd[0], qdd[0]) if n is None else (q, qd, qdd)


def single_state_rows(name, floating_base, budget):
    model, oracle, label = load_pair(name, floating_base)
    pmodel, pdata = oracle.model, oracle.data
    q, qd, qdd = random_states(model, np.random.default_rng(0))
    qp, vp, ap = oracle.q(q), oracle.v(qd), oracle.v(qdd)
    frame = model.frame_names[-1]
    fid = pmodel.getFrameId(frame)

    data = model.data()

    def pin_crba_solve():
        M = pin.crba(pmodel, pdata, qp)
        h = pin.nonLinearEffects(pmodel, pdata, qp, vp)
        return np.linalg.solve(M, ap - h)

    cases = [
        (
            "inverse_dynamics",
            lambda: od.inverse_dynamics(model, q, qd, qdd),
            lambda: od.inverse_dynamics(model, q, qd, qdd, data=data),
            "rnea",
            lambda: pin.rnea(pmodel, pdata, qp, vp, ap),
        ),
        (
            "mass_matrix",
            lambda: od.mass_matrix(model, q),
            lambda: od.mass_matrix(model, q, data=data),
            "crba",
            lambda: pin.crba(pmodel, pdata, qp),
        ),
        (
            "forward_dynamics aba",
            lambda: od.forward_dynamics(model, q, qd, qdd),
            lambda: od.forward_dynamics(model, q, qd, qdd, data=data),
            "aba",
            lambda: pin.aba(pmodel, pdata, qp, vp, ap),
        ),
        (
            "forward_dynamics crba",
            lambda: od.forward_dynamics(model, q, qd, qdd, method="crba"),
            lambda: od.forward_dynamics(model, q, qd, qdd, method="crba", data=data),
            "crba+nle+np.solve",
            pin_crba_solve,
        ),
        (
            "forward_dynamics newton_euler",
            lambda: od.forward_dynamics(model, q, qd, qdd, method="newton_euler"),
            lambda: od.forward_dynamics(model, q, qd, qdd, method="newton_euler", data=data),
            "aba",
            lambda: pin.aba(pmodel, pdata, qp, vp, ap),
        ),
        (
            "coriolis_matrix",
            lambda: od.coriolis_matrix(model, q, qd),
            None,
            "computeCoriolisMatrix",
            lambda: pin.computeCoriolisMatrix(pmodel, pdata, qp, vp),
        ),
        (
            "inverse_dynamics_derivatives",
            lambda: od.inverse_dynamics_derivatives(model, q, qd, qdd),
            lambda: od.inverse_dynamics_derivatives(model, q, qd, qdd, data=data),
            "computeRNEADerivatives",
            lambda: pin.computeRNEADerivatives(pmodel, pdata, qp, vp, ap),
        ),
        (
            "forward_dynamics_derivatives",
            lambda: od.forward_dynamics_derivatives(model, q, qd, qdd),
            lambda: od.forward_dynamics_derivatives(model, q, qd, qdd, data=data),
            "computeABADerivatives",
            lambda: pin.computeABADerivatives(pmodel, pdata, qp, vp, ap),
        ),
        (
            "jacobian (body)",
            lambda: od.jacobian(model, q, frame, "body"),
            lambda: od.jacobian(model, q, frame, "body", data=data),
            "computeFrameJacobian",
            lambda: pin.computeFrameJacobian(pmodel, pdata, qp, fid, pin.LOCAL),
        ),
    ]
    return timed_rows(label, model.nv, cases, budget)


# the centroidal functions and the regressor: (robot, floating base)
CENTROIDAL_ROBOTS = (
    ("ur5", False),
    ("panda", False),
    ("talos_full_v2", False),
    ("solo12", True),
    ("talos_full_v2", True),
)


def centroidal_rows(name, floating_base, budget):
    """The centroidal functions and the joint-torque regressor against Pinocchio's
    centerOfMass, jacobianCenterOfMass, ccrba, computeCentroidalMomentum,
    computeCentroidalMomentumTimeVariation (its dh_g at a = 0 is Adot_G qd) and
    computeJointTorqueRegressor, paired; the centroidal functions also with a Data (data=),
    as Pinocchio's calls are (the regressor takes none)."""
    model, oracle, label = load_pair(name, floating_base)
    pmodel, pdata = oracle.model, oracle.data
    q, qd, qdd = random_states(model, np.random.default_rng(0))
    qp, vp, ap = oracle.q(q), oracle.v(qd), oracle.v(qdd)
    zero = np.zeros(pmodel.nv)
    data = model.data()
    cases = [
        (
            "center_of_mass",
            lambda: od.center_of_mass(model, q),
            lambda: od.center_of_mass(model, q, data=data),
            "centerOfMass",
            lambda: pin.centerOfMass(pmodel, pdata, qp),
        ),
        (
            "center_of_mass_jacobian",
            lambda: od.center_of_mass_jacobian(model, q),
            lambda: od.center_of_mass_jacobian(model, q, data=data),
            "jacobianCenterOfMass",
            lambda: pin.jacobianCenterOfMass(pmodel, pdata, qp),
        ),
        (
            "centroidal_momentum_matrix",
            lambda: od.centroidal_momentum_matrix(model, q),
            lambda: od.centroidal_momentum_matrix(model, q, data=data),
            "ccrba",
            lambda: pin.ccrba(pmodel, pdata, qp, vp),
        ),
        (
            "centroidal_momentum",
            lambda: od.centroidal_momentum(model, q, qd),
            lambda: od.centroidal_momentum(model, q, qd, data=data),
            "computeCentroidalMomentum",
            lambda: pin.computeCentroidalMomentum(pmodel, pdata, qp, vp),
        ),
        (
            "centroidal_momentum_rate_bias",
            lambda: od.centroidal_momentum_rate_bias(model, q, qd),
            lambda: od.centroidal_momentum_rate_bias(model, q, qd, data=data),
            "computeCentroidalMomentumTimeVariation (a = 0)",
            lambda: pin.computeCentroidalMomentumTimeVariation(pmodel, pdata, qp, vp, zero),
        ),
        (
            "torque_regressor",
            lambda: od.torque_regressor(model, q, qd, qdd),
            None,
            "computeJointTorqueRegressor",
            lambda: pin.computeJointTorqueRegressor(pmodel, pdata, qp, vp, ap),
        ),
    ]
    return timed_rows(label, model.nv, cases, budget)


def timed_rows(label, nv, cases, budget):
    """(label, nv, name, us, us with data= or None, Pinocchio's name, its us) per case
    (name, ours, ours with data= or None, Pinocchio's name, theirs), timed in alternation."""
    rows = []
    for ours_name, ours, ours_with_data, pin_name, theirs in cases:
        functions = (ours, theirs) if ours_with_data is None else (ours, theirs, ours_with_data)
        for fn in functions:
            fn()
        times = paired_us(*functions, budget_s=budget)
        t_data = times[2] if ours_with_data is not None else None
        rows.append((label, nv, ours_name, times[0], t_data, pin_name, times[1]))
    return rows


def print_rows(rows):
    """The table of single-state rows (timed_rows), with and without data=."""
    print(
        "| robot | nv | opendyn | us | us with data= | Pinocchio | us | ratio | ratio with data= |"
    )
    print("|---|---:|---|---:|---:|---|---:|---:|---:|")
    for robot, nv, ours_name, t_ours, t_data, pin_name, t_pin in rows:
        with_data = ("", "") if t_data is None else (f"{t_data:.2f}", f"{t_data / t_pin:.2f}")
        print(
            f"| {robot} | {nv} | {ours_name} | {t_ours:.2f} | {with_data[0]} | {pin_name} "
            f"| {t_pin:.2f} | {t_ours / t_pin:.2f} | {with_data[1]} |"
        )


def print_centroidal_table(budget):
    rows = []
    for name, floating_base in CENTROIDAL_ROBOTS:
        rows += centroidal_rows(name, floating_base, budget)
    print_rows(rows)


def batch_rows(name, floating_base, n_states, budget):
    model, oracle, label = load_pair(name, floating_base)
    pmodel, pdata = oracle.model, oracle.data
    q, qd, qdd = random_states(model, np.random.default_rng(1), n_states)
    Qp = np.array([oracle.q(x) for x in q])
    Vp = np.array([oracle.v(x) for x in qd])
    Ap = np.array([oracle.v(x) for x in qdd])
    pool = pin.ModelPool(pmodel, 2)
    QpT, VpT, ApT = (np.asfortranarray(x.T) for x in (Qp, Vp, Ap))
    tau_out = np.zeros((pmodel.nv, n_states), order="F")

    def pin_loop():
        for k in range(n_states):
            pin.rnea(pmodel, pdata, Qp[k], Vp[k], Ap[k])

    ours = per_call_us(lambda: od.inverse_dynamics(model, q, qd, qdd), budget)
    loop = per_call_us(pin_loop, budget)
    parallel = per_call_us(lambda: pin.rneaInParallel(2, pool, QpT, VpT, ApT, tau_out), budget)
    return [(label, n_states, ours / n_states, loop / n_states, parallel / n_states)]


def central_differences(f, q, x, model):
    """(df/dq along od.integrate, df/dx) by central differences with h = 1e-6: 4 nv calls."""
    h, E = 1e-6, np.eye(model.nv)
    df_dq = [
        (f(od.integrate(model, q, h * e, 1.0), x) - f(od.integrate(model, q, -h * e, 1.0), x))
        / (2 * h)
        for e in E
    ]
    df_dx = [(f(q, x + h * e) - f(q, x - h * e)) / (2 * h) for e in E]
    return np.array(df_dq).T, np.array(df_dx).T


def difference_rows(name, floating_base, budget):
    """Microseconds of each analytical derivative function against central differences of
    our own inverse or forward dynamics (in q along integrate and in qd: 4 nv calls)."""
    model, _, label = load_pair(name, floating_base)
    q, qd, qdd = random_states(model, np.random.default_rng(0))
    rows = []
    for ours_name, analytical, function in (
        (
            "inverse_dynamics_derivatives",
            lambda: od.inverse_dynamics_derivatives(model, q, qd, qdd),
            lambda q_, qd_: od.inverse_dynamics(model, q_, qd_, qdd),
        ),
        (
            "forward_dynamics_derivatives",
            lambda: od.forward_dynamics_derivatives(model, q, qd, qdd),
            lambda q_, qd_: od.forward_dynamics(model, q_, qd_, qdd),
        ),
    ):
        analytical()
        t_ours, t_diff = paired_us(
            analytical, lambda: central_differences(function, q, qd, model), budget_s=budget
        )
        rows.append((label, model.nv, ours_name, t_ours, t_diff))
    return rows


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
    parser.add_argument(
        "--centroidal", action="store_true", help="only the centroidal and regressor table"
    )
    parser.add_argument(
        "--docs", action="store_true", help="also write the tables to docs/performance/core.md"
    )
    args = parser.parse_args()
    if args.docs and args.centroidal:
        parser.error("--centroidal prints only part of the page: run --docs without it")
    title = "Core functions: opendyn against Pinocchio"
    with docs_page.page("core.md", title, enabled=args.docs, modules=("pinocchio",)):
        print_tables(args)


def print_tables(args):
    """Print the tables (only the centroidal one with args.centroidal)."""
    budget = 0.1 if args.quick else 0.5

    print(
        f"opendyn {od.__version__}, Pinocchio {pin.__version__}, numpy {np.__version__}, "
        f"{os.cpu_count()} cores\n"
    )
    if args.centroidal:
        print_centroidal_table(budget)
        return
    rows = []
    for name, floating_base in ROBOTS:
        rows += single_state_rows(name, floating_base, budget)
    print_rows(rows)

    print(
        "\nAnalytical derivatives against central differences of opendyn's own inverse or "
        "forward dynamics (in q along integrate and in qd, 4 nv calls), microseconds:\n"
    )
    print("| robot | nv | function | analytical | central differences | speed-up |")
    print("|---|---:|---|---:|---:|---:|")
    for name, floating_base in ROBOTS:
        for robot, nv, ours_name, t_ours, t_diff in difference_rows(name, floating_base, budget):
            print(
                f"| {robot} | {nv} | {ours_name} | {t_ours:.2f} | {t_diff:.1f} "
                f"| {t_diff / t_ours:.0f}x |"
            )

    print("\nCentroidal dynamics and the joint-torque regressor:\n")
    print_centroidal_table(budget)

    n = 10_000
    print(f"\nBatched inverse dynamics, N = {n} states, microseconds per state:\n")
    print(
        "| robot | opendyn batch | pin.rnea loop | pin.rneaInParallel (2 threads) "
        "| loop / opendyn |"
    )
    print("|---|---:|---:|---:|---:|")
    for name, floating_base in ROBOTS:
        for robot, _, ours, loop, parallel in batch_rows(name, floating_base, n, budget * 4):
            print(f"| {robot} | {ours:.3f} | {loop:.3f} | {parallel:.3f} | {loop / ours:.1f}x |")

    if not args.no_startup:
        cold, warm = startup_times()
        print(
            f"\nImport + UR5 load + first call of every function: {cold:.1f} s with an empty "
            f"kernel cache (numba compiles), {warm:.2f} s with the on-disk cache."
        )


if __name__ == "__main__":
    main()
