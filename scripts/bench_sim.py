"""Time 10 s of a UR5 falling under gravity, RK4 at 1 ms, in opendyn, Pinocchio and MuJoCo.

    python scripts/bench_sim.py [--quick] [--rounds N] [--docs]

The same robot in all three: example-robot-data's ur5 URDF, loaded by opendyn
(``load_urdf("ur5")``), by Pinocchio (``buildModelFromUrdf``) and by MuJoCo (which reads the
URDF itself, with its visuals, collisions and simulator tags removed, fixed joints fused, inertias
taken from the ``<inertial>`` elements, no armature, damping or friction loss, contacts and joint
limits switched off, gravity (0, 0, -9.81) m/s^2, the RK4 integrator at a 1 ms step).

First it proves that the three compute the same dynamics: at random states it prints the largest
relative difference between MuJoCo's mass matrix (``mj_fullM`` after ``mj_forward``) and bias
forces (``qfrc_bias``) and Pinocchio's ``crba`` and ``rnea(q, qd, 0)``, and the same for
opendyn's ``mass_matrix`` and ``bias_forces``. Then it runs each simulation from the same state
(q0 a nonzero pose, qd0 = 0, no torque) and prints the largest |q| difference of each pair at
1, 2, 4, 6, 8 and 10 s (and |qd| at 10 s), next to the difference that a 1e-12 rad change of
q0 makes in Pinocchio's own run: the motion is chaotic, and that change shows how far rounding
alone carries.

Timed, in alternation, best of N rounds (5, or 2 with --quick), each a whole 10 s run that keeps
every state:
- opendyn: ``simulate(scene)`` with ``scene = default_scene("ur5", duration=10.0, dt=1e-3,
  integrator="rk4", output_dt=1e-3)`` (every step recorded), q0 and qd0 replaced
  (``dataclasses.replace``); its loop is compiled (a warm-up call compiles it first, or loads it
  from numba's disk cache);
- Pinocchio: a plain Python RK4 loop over ``pin.aba(model, data, q, v, 0)``, 10,000 steps, q
  advanced by plain addition (every UR5 joint is revolute, nq = nv);
- MuJoCo: ``mujoco.mj_step`` called 10,000 times from Python, and ``mujoco.rollout.rollout``,
  which runs the same loop in C.
It prints a markdown table (wall time, real-time factor, opendyn's time over each other's) and a
one-line summary.

With --docs it also writes what it prints to docs/performance/simulation.md, under a header that
says when, on what machine and with which versions it ran and the command that reproduces it
(scripts/docs_page.py).
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import pathlib
import time
import xml.etree.ElementTree as ET

import docs_page
import mujoco
import numpy as np
import pinocchio as pin
from mujoco import rollout

import opendyn as od

ROBOT = "ur5"
DURATION = 10.0  # s
DT = 1e-3  # s
GRAVITY = (0.0, 0.0, -9.81)  # m/s^2, world frame
Q0 = np.array([0.3, -1.2, 1.0, -0.6, 0.9, 0.4])  # rad, in opendyn's joint order
CHECKPOINTS = (1.0, 2.0, 4.0, 6.0, 8.0, 10.0)  # s, the last one DURATION
CHAOS_EPS = 1e-12  # rad, change of q0 that measures how far rounding alone carries


# ------------------------------------------------------------------------------------------
# MuJoCo


def mujoco_urdf_xml(urdf_path):
    """The URDF text MuJoCo should read for a dynamics comparison: every <visual>, <collision>,
    <gazebo> and <transmission> removed (no meshes to find, no geoms, no contacts) and a
    <mujoco><compiler .../></mujoco> element that fuses fixed joints and takes the inertias from
    the <inertial> elements as written."""
    root = ET.parse(urdf_path).getroot()
    for link in root.findall("link"):
        for tag in ("visual", "collision"):
            for element in link.findall(tag):
                link.remove(element)
    for tag in ("gazebo", "transmission", "mujoco"):
        for element in root.findall(tag):
            root.remove(element)
    extension = ET.SubElement(root, "mujoco")
    ET.SubElement(
        extension,
        "compiler",
        angle="radian",
        discardvisual="true",
        fusestatic="true",
        balanceinertia="true",
        inertiafromgeom="false",
    )
    return ET.tostring(root, encoding="unicode")


def load_mujoco(urdf_path):
    """MjModel of the URDF: RK4 at DT, gravity GRAVITY, contacts and joint limits off, no
    armature, damping or friction loss (checked to be absent in the URDF, then zeroed)."""
    m = mujoco.MjModel.from_xml_string(mujoco_urdf_xml(urdf_path))
    passive = {
        "dof_armature": m.dof_armature,
        "dof_damping": m.dof_damping,
        "dof_frictionloss": m.dof_frictionloss,
        "jnt_stiffness": m.jnt_stiffness,
    }
    for name, values in passive.items():
        if np.any(values != 0):
            raise ValueError(f"{urdf_path}: MuJoCo read nonzero {name} {values}")
        values[:] = 0.0
    m.opt.timestep = DT
    m.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
    m.opt.gravity[:] = GRAVITY
    m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT | mujoco.mjtDisableBit.mjDSBL_LIMIT
    return m


class MujocoSim:
    """A MuJoCo model of the URDF with opendyn-ordered states (joints matched by name)."""

    def __init__(self, urdf_path, joint_names):
        self.model = load_mujoco(urdf_path)
        self.data = mujoco.MjData(self.model)
        if self.model.nq != len(joint_names) or self.model.nv != len(joint_names):
            raise ValueError(
                f"MuJoCo model of {urdf_path} has nq={self.model.nq}, nv={self.model.nv}; "
                f"opendyn has {len(joint_names)} joints"
            )
        ids = [mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_JOINT, n) for n in joint_names]
        if min(ids) < 0:
            missing = [n for n, i in zip(joint_names, ids) if i < 0]
            raise KeyError(f"MuJoCo model has no joint(s) {missing}")
        self.idx_q = self.model.jnt_qposadr[ids]
        self.idx_v = self.model.jnt_dofadr[ids]
        self.spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
        self.nstate = mujoco.mj_stateSize(self.model, self.spec)

    def set_state(self, q, qd):
        mujoco.mj_resetData(self.model, self.data)
        self.data.qpos[self.idx_q] = q
        self.data.qvel[self.idx_v] = qd

    def mass_and_bias(self, q, qd):
        """M (nv, nv) from mj_fullM and h = qfrc_bias (nv,), in opendyn's joint order."""
        self.set_state(q, qd)
        mujoco.mj_forward(self.model, self.data)
        M = np.zeros((self.model.nv, self.model.nv))
        mujoco.mj_fullM(self.model, self.data, M)
        return M[np.ix_(self.idx_v, self.idx_v)], self.data.qfrc_bias[self.idx_v].copy()

    def step_loop(self, q0, qd0, n_steps):
        """q, qd (n_steps + 1, nv): mj_step called n_steps times from Python."""
        m, d = self.model, self.data
        self.set_state(q0, qd0)
        qs = np.empty((n_steps + 1, m.nq))
        vs = np.empty((n_steps + 1, m.nv))
        qs[0], vs[0] = d.qpos, d.qvel
        step = mujoco.mj_step
        for k in range(1, n_steps + 1):
            step(m, d)
            qs[k] = d.qpos
            vs[k] = d.qvel
        return qs[:, self.idx_q], vs[:, self.idx_v]

    def rollout(self, q0, qd0, n_steps):
        """q, qd (n_steps + 1, nv): the same loop run in C by mujoco.rollout."""
        m = self.model
        self.set_state(q0, qd0)
        initial = np.empty(self.nstate)
        mujoco.mj_getState(m, self.data, initial, self.spec)
        states, _ = rollout.rollout(m, self.data, initial[None], nstep=n_steps)
        states = np.concatenate([initial[None], states[0]])
        # full-physics state layout: time, qpos, qvel, ...
        qs = states[:, 1 : 1 + m.nq]
        vs = states[:, 1 + m.nq : 1 + m.nq + m.nv]
        return qs[:, self.idx_q], vs[:, self.idx_v]


# ------------------------------------------------------------------------------------------
# Pinocchio


class PinSim:
    """A Pinocchio model of the URDF with opendyn-ordered states (joints matched by name)."""

    def __init__(self, urdf_path, joint_names):
        self.model = pin.buildModelFromUrdf(str(urdf_path))
        self.model.gravity.linear = np.array(GRAVITY)
        self.data = self.model.createData()
        if self.model.nq != self.model.nv:
            raise ValueError(
                f"{urdf_path}: Pinocchio nq={self.model.nq} != nv={self.model.nv} (a continuous "
                "or floating joint); the plain-addition RK4 loop needs revolute joints"
            )
        self.idx_v = np.array(
            [self.model.joints[self.model.getJointId(n)].idx_v for n in joint_names]
        )

    def mass_and_bias(self, q, qd):
        """M (nv, nv) from crba (upper triangle mirrored) and h = rnea(q, qd, 0), opendyn order."""
        qp, vp = np.empty(self.model.nq), np.empty(self.model.nv)
        qp[self.idx_v], vp[self.idx_v] = q, qd
        M = pin.crba(self.model, self.data, qp)
        M = np.triu(M) + np.triu(M, 1).T
        h = pin.rnea(self.model, self.data, qp, vp, np.zeros(self.model.nv))
        return M[np.ix_(self.idx_v, self.idx_v)], h[self.idx_v]

    def rk4_loop(self, q0, qd0, n_steps):
        """q, qd (n_steps + 1, nv): the classical RK4 for (q, v) with qdd = aba(q, v, 0), a plain
        Python loop, q advanced by plain addition."""
        model, data, aba = self.model, self.data, pin.aba
        h, h2, h6 = DT, DT / 2.0, DT / 6.0
        tau = np.zeros(model.nv)
        q, v = np.empty(model.nq), np.empty(model.nv)
        q[self.idx_v], v[self.idx_v] = q0, qd0
        qs = np.empty((n_steps + 1, model.nq))
        vs = np.empty((n_steps + 1, model.nv))
        qs[0], vs[0] = q, v
        for k in range(1, n_steps + 1):
            a1 = aba(model, data, q, v, tau)
            v2 = v + h2 * a1
            a2 = aba(model, data, q + h2 * v, v2, tau)
            v3 = v + h2 * a2
            a3 = aba(model, data, q + h2 * v2, v3, tau)
            v4 = v + h * a3
            a4 = aba(model, data, q + h * v3, v4, tau)
            q = q + h6 * (v + 2.0 * v2 + 2.0 * v3 + v4)
            v = v + h6 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
            qs[k], vs[k] = q, v
        return qs[:, self.idx_v], vs[:, self.idx_v]


# ------------------------------------------------------------------------------------------
# opendyn


class OpendynSim:
    """opendyn's compiled simulation loop on the default scene of the robot."""

    def __init__(self, robot):
        self.robot = robot
        self.model = od.load_urdf(robot)

    def scene(self, q0, qd0):
        """default_scene(robot, duration=DURATION, dt=DT, integrator="rk4", output_dt=DT) from
        (q0, qd0): every step recorded, as the other simulators here keep every state;
        it must have gravity GRAVITY and no other effect (the others here have none)."""
        scene = od.default_scene(
            self.robot, duration=DURATION, dt=DT, integrator="rk4", output_dt=DT
        )
        scene = dataclasses.replace(
            scene, q0=np.asarray(q0, dtype=float), qd0=np.asarray(qd0, dtype=float)
        )
        if scene.effects != ("gravity",) or not np.allclose(scene.gravity, GRAVITY):
            raise ValueError(
                f"default_scene({self.robot!r}) has effects {scene.effects} and gravity "
                f"{scene.gravity}; this comparison needs gravity {GRAVITY} alone"
            )
        return scene

    def time_run(self, scene):
        """The call that is timed: one whole simulation."""
        return od.simulate(scene)

    def run(self, scene):
        """q, qd (n_steps + 1, nv) sampled every DT from time 0, from simulate(scene)."""
        traj = od.simulate(scene)
        q, qd, t = (np.asarray(x) for x in (traj.q, traj.qd, traj.t))
        n_steps = int(round(DURATION / DT))
        if q.shape != (n_steps + 1, self.model.nv) or not np.allclose(
            t, DT * np.arange(n_steps + 1), rtol=0.0, atol=DT * 1e-6
        ):
            raise ValueError(
                f"opendyn's trajectory has q {q.shape} over t = [{t[0]}, {t[-1]}]; expected "
                f"({n_steps + 1}, {self.model.nv}) every {DT} s over [0, {DURATION}]"
            )
        return q, qd


def opendyn_available():
    """None when opendyn.simulate and opendyn.default_scene exist, else why not."""
    missing = [name for name in ("simulate", "default_scene") if not hasattr(od, name)]
    return f"opendyn has no {', '.join(missing)}" if missing else None


# ------------------------------------------------------------------------------------------
# checks and timing


def urdf_label(path):
    """The URDF's path below the last folder called robots above it, without the machine's
    prefix (ur_description/urdf/ur5_robot.urdf for example-robot-data's UR5); its name alone
    when no folder above it is called robots."""
    parts = pathlib.Path(path).parts
    if "robots" not in parts[:-1]:
        return parts[-1]
    last = len(parts) - 1 - parts[::-1].index("robots")
    return "/".join(parts[last + 1 :])


def relative_difference(a, b):
    """max |a - b| / max |b|."""
    return float(np.max(np.abs(a - b)) / max(np.max(np.abs(b)), 1e-300))


def same_dynamics_rows(nv, pin_sim, others, n_states=5):
    """Largest relative difference of M and h against Pinocchio's over random states, for each
    of `others`: {name: fn(q, qd) -> (M, h)}."""
    rng = np.random.default_rng(0)
    worst = {name: [0.0, 0.0] for name in others}
    for _ in range(n_states):
        q = rng.uniform(-np.pi, np.pi, nv)
        qd = rng.uniform(-2.0, 2.0, nv)
        M_pin, h_pin = pin_sim.mass_and_bias(q, qd)
        for name in worst:
            M, h = others[name](q, qd)
            worst[name][0] = max(worst[name][0], relative_difference(M, M_pin))
            worst[name][1] = max(worst[name][1], relative_difference(h, h_pin))
    return worst


def at_time(qs, t):
    """The row at time t of a trajectory sampled every DT from time 0."""
    return qs[int(round(t / DT))]


def best_of_alternating(runs, rounds):
    """Best wall time in seconds of each zero-argument callable, run in alternation `rounds`
    times, so that a slow spell of a shared machine hits every side alike."""
    best = {name: np.inf for name in runs}
    for _ in range(rounds):
        for name, fn in runs.items():
            t0 = time.perf_counter()
            fn()
            best[name] = min(best[name], time.perf_counter() - t0)
    return best


# a Python PD controller at 1 kHz (section 4): gains (N m/rad, N m s/rad) about Q0
KP, KD = 100.0, 10.0


def python_pd(t, q, qd):
    """The controller every simulator here calls from Python: tau = KP (Q0 - q) - KD qd."""
    return KP * (Q0 - q) - KD * qd


def controller_runs(ours, mj_sim, n_steps):
    """{name: zero-argument run}: the UR5 for DURATION under python_pd at 1 kHz (every 1 ms
    step) in opendyn (simulate(controller=)) and in a MuJoCo mj_step loop setting
    qfrc_applied, and the same PD as opendyn's scene controller (evaluated in compiled code)."""
    base = ours.scene(Q0, np.zeros(len(Q0)))
    built_in = od.scene_from_dict(
        {
            "robot": {"name": ROBOT},
            "initial": {"q": [float(v) for v in Q0]},
            "run": {"duration": DURATION, "dt": DT, "integrator": "rk4", "output_dt": DT},
            "effects": {"gravity": True},
            "control": {"type": "pd", "kp": KP, "kd": KD, "setpoint": [float(v) for v in Q0]},
        }
    )
    m, d = mj_sim.model, mj_sim.data
    iq, iv = mj_sim.idx_q, mj_sim.idx_v

    def mj_loop():
        mj_sim.set_state(Q0, np.zeros(len(Q0)))
        qs = np.empty((n_steps + 1, m.nq))
        qs[0] = d.qpos
        for k in range(1, n_steps + 1):
            d.qfrc_applied[iv] = python_pd(d.time, d.qpos[iq], d.qvel[iv])
            mujoco.mj_step(m, d)
            qs[k] = d.qpos
        return qs

    return {
        "opendyn simulate(controller=python_pd)": lambda: od.simulate(
            base, controller=python_pd, control_dt=DT
        ),
        "opendyn scene PD (compiled)": lambda: od.simulate(built_in),
        "MuJoCo mj_step loop + python_pd": mj_loop,
    }


def controller_section(ours, mj_sim, n_steps, rounds):
    """Section 4: what a Python controller at 1 kHz costs per control tick."""
    runs = controller_runs(ours, mj_sim, n_steps)
    for run in runs.values():
        run()  # compile or load, once
    best = best_of_alternating(runs, rounds)
    q, qd = Q0.copy(), np.zeros(len(Q0))
    calls = 20000
    t0 = time.perf_counter()
    for _ in range(calls):
        python_pd(0.0, q, qd)
    own = (time.perf_counter() - t0) / calls
    print(
        f"\nA Python PD controller at 1 kHz on {DURATION:g} s of {ROBOT} (RK4 at 1 ms, a tick "
        f"every step; the controller alone takes {own * 1e6:.2f} us a call), best of {rounds}\n"
    )
    print("| run | wall s | us / tick |")
    print("|---|---:|---:|")
    for name, seconds in best.items():
        print(f"| {name} | {seconds:.4f} | {seconds / n_steps * 1e6:.2f} |")
    python = best["opendyn simulate(controller=python_pd)"]
    compiled = best["opendyn scene PD (compiled)"]
    round_trip = (python - compiled) / n_steps - own
    print(
        f"\nThe Python round trip beyond the controller's own time: {round_trip * 1e6:.2f} us "
        f"per tick ({round_trip / DT * 100:.2f}% of real time at 1 kHz); opendyn with "
        f"the Python controller / MuJoCo's mj_step loop with it = "
        f"{python / best['MuJoCo mj_step loop + python_pd']:.2f}"
    )


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="2 timing rounds instead of 5")
    parser.add_argument("--rounds", type=int, default=None, help="timing rounds (best of N)")
    parser.add_argument(
        "--docs",
        action="store_true",
        help="also write the tables to docs/performance/simulation.md",
    )
    args = parser.parse_args()
    rounds = args.rounds if args.rounds is not None else (2 if args.quick else 5)
    if rounds < 1:
        parser.error(f"--rounds must be at least 1, got {rounds}")
    title = "Simulation: opendyn, Pinocchio and MuJoCo on the UR5"
    with docs_page.page(
        "simulation.md", title, enabled=args.docs, modules=("pinocchio", "mujoco")
    ):
        print_tables(rounds)


def print_tables(rounds):
    """Print every table and sentence, timing with best of `rounds`."""
    n_steps = int(round(DURATION / DT))

    model = od.load_urdf(ROBOT)
    urdf = model.source
    pin_sim = PinSim(urdf, model.joint_names)
    mj_sim = MujocoSim(urdf, model.joint_names)
    missing = opendyn_available()
    ours = None if missing else OpendynSim(ROBOT)

    print(
        f"opendyn {od.__version__}, Pinocchio {pin.__version__}, MuJoCo {mujoco.__version__}, "
        f"numpy {np.__version__}, {os.cpu_count()} cores"
    )
    print(f"{ROBOT}: {urdf_label(urdf)}")
    masses = {
        "opendyn": float(np.sum(model.mass)),
        "Pinocchio": float(sum(inertia.mass for inertia in pin_sim.model.inertias[1:])),
        "MuJoCo": float(np.sum(mj_sim.model.body_mass)),
    }
    print("moving mass, kg: " + ", ".join(f"{name} {mass:.6g}" for name, mass in masses.items()))

    # 1. the same dynamics -----------------------------------------------------------------
    others = {
        "MuJoCo": mj_sim.mass_and_bias,
        "opendyn": lambda q, qd: (od.mass_matrix(model, q), od.bias_forces(model, q, qd)),
    }
    print("\nSame dynamics: largest relative difference against Pinocchio at 5 random states\n")
    print("| model | M vs crba | h vs rnea(q, qd, 0) |")
    print("|---|---:|---:|")
    for name, (dM, dh) in same_dynamics_rows(model.nv, pin_sim, others).items():
        print(f"| {name} | {dM:.1e} | {dh:.1e} |")

    # 2. the same motion --------------------------------------------------------------------
    qd0 = np.zeros(model.nv)
    runs = {
        "Pinocchio RK4 loop": lambda: pin_sim.rk4_loop(Q0, qd0, n_steps),
        "MuJoCo mj_step loop": lambda: mj_sim.step_loop(Q0, qd0, n_steps),
        "MuJoCo rollout": lambda: mj_sim.rollout(Q0, qd0, n_steps),
    }
    results = {name: fn() for name, fn in runs.items()}
    if ours is not None:
        scene = ours.scene(Q0, qd0)
        t0 = time.perf_counter()
        ours.time_run(scene)  # the first call compiles the loop (or loads it from the cache)
        first_call = time.perf_counter() - t0
        runs = {"opendyn simulate": lambda: ours.time_run(scene), **runs}
        results = {"opendyn simulate": ours.run(scene), **results}
    q0_perturbed = Q0 + CHAOS_EPS
    chaos = pin_sim.rk4_loop(q0_perturbed, qd0, n_steps)

    print(
        f"\nSame motion: q0 = {np.array2string(Q0, separator=', ')} rad, qd0 = 0, RK4 at "
        f"{DT * 1e3:g} ms; largest |q difference| (rad) at each time, |qd difference| (rad/s) "
        "at the end\n"
    )
    pairs = []
    names = list(results)
    for i, a in enumerate(names):
        for b in names[i + 1 :]:
            pairs.append((f"{a} vs {b}", results[a], results[b]))
    pairs.append(
        (f"Pinocchio vs itself with q0 + {CHAOS_EPS:g}", results["Pinocchio RK4 loop"], chaos)
    )
    header = " | ".join(f"q @ {t:g} s" for t in CHECKPOINTS)
    print(f"| pair | {header} | qd @ {DURATION:g} s |")
    print("|---|" + "---:|" * (len(CHECKPOINTS) + 1))
    dq = {}  # (pair label, time) -> largest |q difference|
    for label, (qa, va), (qb, vb) in pairs:
        for t in CHECKPOINTS:
            dq[label, t] = float(np.max(np.abs(at_time(qa, t) - at_time(qb, t))))
        cells = [f"{dq[label, t]:.1e}" for t in CHECKPOINTS]
        cells.append(f"{np.max(np.abs(va[-1] - vb[-1])):.1e}")
        print(f"| {label} | " + " | ".join(cells) + " |")
    chaos_label = pairs[-1][0]
    between = [label for label, _, _ in pairs[:-1]]
    agree = max(dq[label, DURATION] for label in between)
    # the growth of a small change of q0, read where it is still small (linear)
    linear = [t for t in CHECKPOINTS if dq[chaos_label, t] < 1e-4] or [CHECKPOINTS[0]]
    t_lin = linear[-1]
    growth = dq[chaos_label, t_lin] / CHAOS_EPS
    worst = max(dq[label, t_lin] for label in between)
    print(
        f"\nA {CHAOS_EPS:g} rad change of q0 grows {growth:.1e}-fold by {t_lin:g} s (to "
        f"{dq[chaos_label, DURATION]:.1e} rad by {DURATION:g} s): the largest difference "
        f"between simulators at {t_lin:g} s, {worst:.1e} rad, is what a q0 difference of "
        f"{worst / growth:.1e} rad would grow to, i.e. rounding carried by a chaotic motion."
    )

    # 3. timing ----------------------------------------------------------------------------
    best = best_of_alternating(runs, rounds)
    print(
        f"\nWall time of {DURATION:g} s of {ROBOT} (nv = {model.nv}) at {DT * 1e3:g} ms "
        f"({n_steps} RK4 steps, every state kept), best of {rounds} alternating rounds\n"
    )
    if ours is None:
        print(f"(opendyn not timed: {missing})\n")
    print("| simulator | wall s | us / step | real-time factor | opendyn / this |")
    print("|---|---:|---:|---:|---:|")
    for name, seconds in best.items():
        ratio = f"{best['opendyn simulate'] / seconds:.2f}" if ours is not None else "-"
        print(
            f"| {name} | {seconds:.4f} | {seconds / n_steps * 1e6:.2f} "
            f"| {DURATION / seconds:.0f}x | {ratio} |"
        )
    if ours is not None:
        print(f"\nopendyn's first simulate call (compile or cache load): {first_call:.1f} s")

    if ours is not None:
        controller_section(ours, mj_sim, n_steps, rounds)

    mj = best["MuJoCo mj_step loop"]
    pin_loop = best["Pinocchio RK4 loop"]
    c_loop = best["MuJoCo rollout"]
    if ours is not None:
        od_s = best["opendyn simulate"]
        print(
            f"\nSummary: {DURATION:g} s of {ROBOT} (RK4, 1 ms) takes opendyn {od_s:.3f} s "
            f"({DURATION / od_s:.0f}x real time); opendyn / Python RK4 loop over pin.aba = "
            f"{od_s / pin_loop:.2f}, opendyn / MuJoCo mj_step loop = {od_s / mj:.2f}, "
            f"opendyn / MuJoCo rollout = {od_s / c_loop:.2f}; final q agree to {agree:.1e} rad."
        )
    else:
        print(
            f"\nSummary: {DURATION:g} s of {ROBOT} (RK4, 1 ms): Python RK4 loop over pin.aba "
            f"{pin_loop:.3f} s, MuJoCo mj_step loop {mj:.3f} s, rollout {c_loop:.3f} s; final q "
            f"agree to {agree:.1e} rad; opendyn not timed ({missing})."
        )


if __name__ == "__main__":
    main()
