"""Simulation: scenes run the effects they name and nothing else, integrators converge at their
order, energy is conserved or balanced, failures stop with a message and keep the record.

Independent references: Pinocchio's `aba` driven by a plain Python RK4 loop; the closed-form
effect laws of opendyn.sim.effects' docstring evaluated here in numpy; dynamics functions of the
core (checked against Pinocchio in test_pinocchio.py) at single states.
"""

from __future__ import annotations

import dataclasses
import json
import os
import signal
import subprocess
import sys
import threading

import numpy as np
import pytest

import opendyn as od
from opendyn.errors import SimulationError
from opendyn.sim import effects, integrators
from opendyn.sim.effects import registry
from opendyn.sim.driver import Stepper
from opendyn.sim.record import Samples

pin = pytest.importorskip("pinocchio")
from pin_adapter import PinOracle  # noqa: E402
from plotcheck import assert_lines_shown, read_png, saved_figures  # noqa: E402


def ur5_scene(duration=1.0, **effect_tables):
    return od.scene_from_dict(
        {
            "robot": {"name": "ur5"},
            "initial": {"q": [0.3, -1.2, 1.0, -0.6, 0.9, 0.4], "qd": [0.5, 0, -0.3, 0, 0.2, 1]},
            "run": {"duration": duration, "dt": 1e-3, "integrator": "rk4", "output_dt": 1e-3},
            "effects": {"gravity": True, **effect_tables},
        }
    )


def pinocchio_rk4(oracle, q0, qd0, dt, n, damping):
    """RK4 over pin.aba with tau = -b qd, q advanced by plain addition (revolute joints)."""
    pm, pd = oracle.model, oracle.data

    def f(q, v):
        return oracle.back(pin.aba(pm, pd, oracle.q(q), oracle.v(v), oracle.v(-damping * v)))

    q, v = q0.copy(), qd0.copy()
    out_q, out_v = [q.copy()], [v.copy()]
    for _ in range(n):
        k1q, k1v = v, f(q, v)
        k2q, k2v = v + 0.5 * dt * k1v, f(q + 0.5 * dt * k1q, v + 0.5 * dt * k1v)
        k3q, k3v = v + 0.5 * dt * k2v, f(q + 0.5 * dt * k2q, v + 0.5 * dt * k2v)
        k4q, k4v = v + dt * k3v, f(q + dt * k3q, v + dt * k3v)
        q = q + dt / 6 * (k1q + 2 * k2q + 2 * k3q + k4q)
        v = v + dt / 6 * (k1v + 2 * k2v + 2 * k3v + k4v)
        out_q.append(q)
        out_v.append(v)
    return np.array(out_q), np.array(out_v)


def test_ur5_rk4_matches_pinocchio_rk4_loop():
    scene = ur5_scene(duration=1.0, damping={"coefficients": 0.5})
    traj = od.simulate(scene)
    oracle = PinOracle(scene.model.source, scene.model)
    q, v = pinocchio_rk4(oracle, scene.q0, scene.qd0, 1e-3, 1000, scene.damping)
    assert traj.complete and len(traj.t) == 1001
    np.testing.assert_allclose(traj.t, np.arange(1001) * 1e-3, rtol=0, atol=1e-12)
    assert np.abs(traj.q - q).max() < 1e-9
    assert np.abs(traj.qd - v).max() < 1e-9


def test_conservative_scene_conserves_energy_at_fourth_order():
    # RK4's energy error is its global error, O(dt^4): below 1e-7 of the energy scale at 1 ms
    # over 10 s of the chaotic double pendulum, and 16x (2^4) larger at twice the step.
    scene = od.load_scene("double_pendulum_swing")
    assert scene.effects == ("gravity",)
    fine = od.simulate(scene)
    coarse = od.simulate(scene.replace_run(dt=2e-3))
    scale = np.abs(fine.energy).max()
    err_fine = np.abs(fine.energy - fine.energy[0]).max()
    err_coarse = np.abs(coarse.energy - coarse.energy[0]).max()
    assert err_fine < 1e-7 * scale
    assert 8 < err_coarse / err_fine < 32
    assert not fine.work_applied.any() and not fine.work_passive.any()


def test_damping_dissipates_energy_at_rate_qd_b_qd():
    scene = ur5_scene(duration=2.0, damping={"coefficients": [0.5, 1.0, 0.8, 0.3, 0.2, 0.1]})
    traj = od.simulate(scene)
    b = scene.damping
    # dE/dt = -qd^T diag(b) qd: the trapezoid rule over the 1 ms samples (error O(dt^2 E''))
    rate = -np.einsum("kj,j,kj->k", traj.qd, b, traj.qd)
    dissipated = np.concatenate([[0], np.cumsum(0.5 * (rate[1:] + rate[:-1]) * np.diff(traj.t))])
    loss = traj.energy - traj.energy[0]
    assert loss[-1] < -1.0  # a real loss, J
    assert np.abs(loss - dissipated).max() < 1e-5 * np.abs(loss).max()
    # the work integrated with the state agrees with E(t) - E(0) to the RK4 error
    assert np.abs(traj.energy_error).max() < 1e-9 * np.abs(loss).max()
    np.testing.assert_allclose(traj.work_passive, dissipated, atol=1e-5 * np.abs(loss).max())


def effect_names():
    """The names of [effects]: a name that several modules share (the ground's spheres and
    the collision geometries both read [effects.contact]) switches on its first module."""
    return dict.fromkeys(effect.NAME for effect in registry.in_section("effects"))


def _full_scene():
    """The double pendulum with every effect of the registry on: each [effects] entry its
    module's EXAMPLE, the contact's floor raised so that the tip swings down into it (it starts
    at 2.82 m), and PD control about the hanging pose."""
    every = {name: registry.named(name)[0].EXAMPLE for name in effect_names()}
    every["contact"] = {**every["contact"], "ground_height": 2.6, "slip_velocity": 1.0}
    return od.scene_from_dict(
        {
            "robot": {"urdf": str(od.io.urdf.shipped_robots_dir() / "double_pendulum.urdf")},
            "initial": {"q": [2.0, 0.5], "qd": [0.3, -0.2]},
            "run": {"duration": 0.5, "dt": 1e-3, "output_dt": 1e-2},
            "effects": every,
            "control": {"type": "pd", "kp": 5.0, "kd": 1.0, "setpoint": [0.0, 0.0]},
        }
    )


# every effect with a stage, by its name in a scene (the control laws share "control")
STAGED = tuple(dict.fromkeys(effect.NAME for effect in registry.stages()))


@pytest.mark.parametrize("effect", STAGED)
def test_disabled_effect_never_runs(effect):
    """A scene without an effect has None in its slot of the effects tuple, which the compiled
    step never reads: the full scene's table with that slot emptied runs to the same result as
    the scene without the effect, and poisoning the emptied parameters with NaN (had any stage
    read them) would show."""
    full = _full_scene()
    off = full.without(effect)
    table_full = effects.stage_table(full)
    table_off = effects.stage_table(off)
    (slot,) = [k for k, stage in enumerate(registry.stages()) if stage.NAME == effect
               and table_full.effects[k] is not None]
    assert table_full.effects[slot] is not None and table_off.effects[slot] is None
    assert len(table_off.names) == len(table_full.names) - 1

    emptied = list(table_full.effects)
    poisoned = emptied[slot]
    for array in poisoned if isinstance(poisoned, tuple) else (poisoned,):
        if isinstance(array, np.ndarray) and array.dtype == np.float64:
            array[:] = np.nan
    emptied[slot] = None
    table_emptied = dataclasses.replace(table_off, effects=tuple(emptied))
    q, qd, w = full.q0.copy(), full.qd0.copy(), np.zeros(2)
    status, steps = Stepper(full, table_emptied, integrators.INTEGRATORS["rk4"]).fixed_chunk(
        0,
        500,
        1,
        integrators.State(q, qd, w),
        Samples(501, full.model.nq, full.model.nv),
        integrators.new_counters(),
    )
    assert status == 0 and steps == 500
    traj_off = od.simulate(off)
    assert np.all(np.isfinite(q))
    np.testing.assert_allclose(q, traj_off.q[-1], rtol=0, atol=1e-12)
    np.testing.assert_allclose(qd, traj_off.qd[-1], rtol=0, atol=1e-12)


# Run in a fresh process with an empty kernel cache, so that everything the run needs is
# compiled there (a cache hit compiles nothing and would prove nothing): which specialisations
# of each effect function and of the forward-dynamics methods did the gravity-only default
# scene compile?
_COMPILED_FOR_DEFAULT_SCENE = r"""
import json
import opendyn as od
from opendyn.sim.effects import registry
from opendyn.algorithm import aba, contact, crba, forward, rnea
from opendyn._runtime.compile_notice import compile_seconds
scene = od.load_scene("double_pendulum_swing").replace_run(duration=0.01)
before = compile_seconds()
traj = od.simulate(scene)
run = dict(compiled=compile_seconds() - before, reported=traj.stats["compile_s"])
functions = {stage.__name__.rsplit(".", 1)[1]: stage.apply for stage in registry.stages()}
functions.update(
    aba=aba.aba_on_poses, crba=crba.crba_kernel, rnea=rnea.rnea_kernel,
    newton_euler=forward.newton_euler_mass_matrix, mass_matrix_solve=forward.mass_matrix_solve,
    compliant_contact=contact.compliant_contact, crba_on_poses=crba.crba_on_poses,
    rnea_on_poses=rnea.rnea_on_poses, aba_kernel=aba.aba_kernel,
)
compiled = {name: [str(sig[0]) for sig in f.signatures] for name, f in functions.items()}
print(json.dumps(dict(compiled, run=run)))
"""


def test_a_scene_compiles_no_effect_it_does_not_name(tmp_path):
    """The default scene names gravity only: in an empty cache its run compiles the gravity
    effect for real parameters and no other effect at all (not even for an empty slot); ABA
    is compiled and neither CRBA nor the seed's n-RNEA method is. One compile notice covers
    the whole run, and the run reports every second of it."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path))
    proc = subprocess.run(
        [sys.executable, "-c", _COMPILED_FOR_DEFAULT_SCENE],
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr
    compiled = json.loads(proc.stdout.strip().splitlines()[-1])
    run = compiled.pop("run")
    assert set(compiled["gravity"]) == {"array(float64, 1d, C)"}
    for stage in registry.stages():
        name = stage.__name__.rsplit(".", 1)[1]
        if name != "gravity":
            assert compiled[name] == [], f"{name}'s force compiled for {compiled[name]}"
    # the step runs ABA on the poses it placed (opendyn.sim.step), and nothing else of it
    assert compiled["aba"] and compiled["rnea"] == [] and compiled["aba_kernel"] == []
    assert compiled["crba_on_poses"] == [] and compiled["rnea_on_poses"] == []
    assert compiled["crba"] == [] and compiled["newton_euler"] == []
    assert compiled["mass_matrix_solve"] == [] and compiled["compliant_contact"] == []
    # and the run said so, in one notice on stderr for all it compiled (its start checks and
    # its record included), and reported all of it as the time it spent compiling
    assert proc.stderr.count("opendyn: compiling") == 1, proc.stderr
    assert proc.stderr.count("opendyn: compiling the simulation step for rk4 with gravity") == 1
    assert run["compiled"] > 0 and run["reported"] == run["compiled"]


def _evaluate(scene, t, q, qd):
    """(qdd, control torque, (applied, passive) power) of the scene's step at one state."""
    nv = scene.model.nv
    k, power, tau_ctrl = np.empty((2, nv)), np.empty(2), np.empty(nv)
    assert Stepper(scene, effects.stage_table(scene)).first_stage(t, q, qd, k, power, tau_ctrl) == 0
    return k[1], tau_ctrl, power


def test_each_effect_is_its_stated_generalized_force():
    """The step's qdd equals (M + diag(a))^-1 (tau_effects - h), with each effect's law written
    out here from the documentation and M, h, J_b from the core; the power is qd . tau of the
    applied and passive forces, less the work of the contact's spring, k delta delta_dot."""
    scene = _full_scene()
    model = scene.model
    rng = np.random.default_rng(3)
    touched = 0
    for _ in range(8):
        t = rng.uniform(0, 0.5)
        q = rng.uniform(-3.5, 3.5, 2)
        qd = rng.normal(size=2)
        qdd, tau_ctrl, power = _evaluate(scene, t, q, qd)
        b, fc, vs = scene.damping, scene.friction.coulomb, scene.friction.smoothing
        lim = scene.limits
        depth = np.where(q > lim.upper, q - lim.upper, np.where(q < lim.lower, q - lim.lower, 0))
        tau_limits = np.where(depth != 0, -lim.stiffness * depth - lim.damping * qd, 0.0)
        passive = -b * qd - fc * np.tanh(qd / vs) + tau_limits
        F_world = np.array([0, 0, 0, 1.0, 0, 2.0])
        R_sf = od.frame_pose(model, q, "tip")[:3, :3]
        F_tip = np.concatenate([R_sf.T @ F_world[:3], R_sf.T @ F_world[3:]])
        applied = od.jacobian(model, q, "tip", expressed_in="body").T @ F_tip
        control = scene.control.kp * (scene.control.setpoint - q) - scene.control.kd * qd
        c = scene.contact
        (point,) = c.points
        J = od.jacobian(model, q, "tip", expressed_in="space")
        x_p = od.frame_pose(model, q, "tip")[:3, 3] - [0, 0, point.radius]
        v_p = (J[3:] - np.cross(x_p, J[:3].T).T) @ qd
        delta = max(0.0, c.ground_height - x_p[2])
        f_n = max(0.0, c.stiffness * delta - c.damping * v_p[2]) if delta > 0 else 0.0
        f_t = -c.friction * f_n * v_p[:2] / np.sqrt(v_p[0] ** 2 + v_p[1] ** 2 + c.slip_velocity**2)
        tau_contact = (J[3:] - np.cross(x_p, J[:3].T).T).T @ np.array([*f_t, f_n])
        touched += delta > 0
        M = od.mass_matrix(model, q) + np.diag(scene.armature)
        h = od.bias_forces(model, q, qd, gravity=scene.gravity)
        np.testing.assert_allclose(
            qdd,
            np.linalg.solve(M, passive + tau_contact + applied + control - h),
            rtol=1e-10,
            atol=1e-10,
        )
        np.testing.assert_allclose(tau_ctrl, control, rtol=1e-12, atol=1e-12)
        spring = c.stiffness * delta * -v_p[2]
        np.testing.assert_allclose(
            power,
            [qd @ (control + applied), qd @ (passive + tau_contact) + spring],
            rtol=1e-10,
            atol=1e-12,
        )
    assert 0 < touched < 8  # states in contact and out of it


def test_applied_wrench_is_minus_f_tip():
    """A wrench applied to the robot at a frame (frame axes) is f_tip = -F of the dynamics
    functions, whose sign Pinocchio checks in test_pinocchio."""
    scene = od.scene_from_dict(
        {
            "robot": {"name": "ur5"},
            "effects": {"wrench": {"frame": "tool0", "value": [0.1, -0.2, 0.3, 5, -4, 3]}},
        }
    )
    q, qd = np.linspace(-1, 1, 6), np.linspace(0.5, -0.5, 6)
    qdd, _, _ = _evaluate(scene, 0.0, q, qd)
    F = np.array([0.1, -0.2, 0.3, 5, -4, 3])
    expected = od.forward_dynamics(
        scene.model, q, qd, np.zeros(6), f_tip={"tool0": -F}, gravity=np.zeros(3)
    )
    np.testing.assert_allclose(qdd, expected, rtol=1e-10, atol=1e-12)


def test_computed_torque_tracks_the_reference():
    """With the controller's model equal to the plant (gravity only), computed torque makes
    e'' + kd e' + kp e = 0: from a start on the reference the error stays at integration level."""
    scene = od.scene_from_dict(
        {
            "robot": {"name": "panda"},
            "initial": {"q": {"panda_joint2": -0.5, "panda_joint4": -2, "panda_joint6": 1.5}},
            "run": {"duration": 2.0, "dt": 1e-3},
            "effects": {"gravity": True},
            "control": {
                "type": "computed_torque",
                "kp": 100.0,
                "kd": 20.0,
                "amplitude": 0.3,
                "frequency": 0.5,
                "phase": 1.5707963267948966,
            },
        }
    )
    c = scene.control
    # start on the reference: q_r(0) = offset + amplitude sin(phase), qd_r(0) = 0
    scene = dataclasses.replace(scene, q0=c.offset + c.amplitude * np.sin(c.phase))
    # the reference moves every joint by 0.3, the fingers too: past their 4 cm travel, which
    # the scene does not enforce
    with pytest.warns(od.SceneWarning, match=r"panda_finger_joint[12].*outside its limits"):
        traj = od.simulate(scene)
    w = 2 * np.pi * c.frequency
    q_r = c.offset + c.amplitude * np.sin(w * traj.t[:, None] + c.phase)
    assert np.abs(traj.q - q_r).max() < 1e-8
    assert np.ptp(traj.q, axis=0).min() > 0.59  # every joint swept its 2 x 0.3 rad
    # the recorded torque is inverse dynamics along the reference
    k = 100
    qdd_r = -c.amplitude * w**2 * np.sin(w * traj.t[k] + c.phase)
    tau = od.inverse_dynamics(scene.model, traj.q[k], traj.qd[k], qdd_r)
    np.testing.assert_allclose(traj.tau[k], tau, rtol=1e-5, atol=1e-5)


def test_clip_limits_control_torque_to_effort_limits():
    scene = od.scene_from_dict(
        {
            "robot": {"name": "ur5"},
            "control": {"type": "constant", "tau": 1e6, "clip": True},
            "run": {"duration": 0.05},
        }
    )
    traj = od.simulate(scene)
    np.testing.assert_allclose(traj.tau, np.broadcast_to(scene.model.effort_limit, traj.tau.shape))


def test_armature_adds_to_the_mass_matrix_diagonal():
    scene = _full_scene()
    only = scene.without(*(name for name in registry.names() if name != "armature"))
    assert only.effects == ("armature",)
    q, qd = np.array([0.4, -0.3]), np.array([1.0, 2.0])
    qdd, _, _ = _evaluate(only, 0.0, q, qd)
    M = od.mass_matrix(only.model, q) + np.diag(only.armature)
    c = od.coriolis_forces(only.model, q, qd)
    np.testing.assert_allclose(qdd, np.linalg.solve(M, -c), rtol=1e-12)


def _reference(scene):
    return od.simulate(scene.replace_run(integrator="dopri5", rtol=1e-12, atol=1e-12))


@pytest.mark.parametrize(
    "integrator, order",
    [("euler", 1), ("semi_implicit_euler", 1), ("rk4", 4), ("implicit_euler", 1)],
)
def test_fixed_step_integrators_converge_at_their_order(integrator, order):
    scene = od.load_scene("double_pendulum_swing").replace_run(duration=0.5, output_dt=0.01)
    ref = _reference(scene)
    errors = []
    for dt in (2e-3, 1e-3):
        traj = od.simulate(scene.replace_run(integrator=integrator, dt=dt))
        errors.append(np.abs(traj.q[-1] - ref.q[-1]).max())
    measured = np.log2(errors[0] / errors[1])
    assert abs(measured - order) < 0.3, (errors, measured)


def test_adaptive_integrator_meets_its_tolerance_and_reports_steps():
    scene = od.load_scene("double_pendulum_swing").replace_run(duration=2.0)
    ref = _reference(scene)
    for rtol in (1e-5, 1e-8):
        traj = od.simulate(scene.replace_run(integrator="dopri5", rtol=rtol, atol=rtol * 1e-2))
        np.testing.assert_allclose(traj.t, ref.t, atol=1e-12)
        # global error of a chaotic system: a few hundred times the local tolerance over 2 s
        assert np.abs(traj.q - ref.q).max() < 1e3 * rtol
        stats = traj.stats
        assert stats["steps"] > 0 and stats["evaluations"] >= 6 * stats["steps"]
    tight = od.simulate(scene.replace_run(integrator="dopri5", rtol=1e-10, atol=1e-12))
    loose = od.simulate(scene.replace_run(integrator="dopri5", rtol=1e-5, atol=1e-7))
    assert tight.stats["steps"] > 3 * loose.stats["steps"]


def test_implicit_euler_is_stable_where_rk4_diverges():
    scene = od.load_scene("planar_3r_limits")
    assert scene.run.integrator == "implicit_euler"
    stiff = od.simulate(scene)
    assert stiff.complete and np.all(np.isfinite(stiff.q))
    lim = scene.limits
    assert np.all(stiff.q[-1] <= lim.upper + 1e-3) and np.all(stiff.q[-1] >= lim.lower - 1e-3)
    with pytest.raises(SimulationError) as info:
        od.simulate(scene.replace_run(integrator="rk4"))
    message = str(info.value)
    assert "joint-limit stiffness" in message and "implicit_euler" in message
    partial = info.value.trajectory
    assert not partial.complete
    assert np.all(np.isfinite(partial.q)) and np.all(np.isfinite(partial.qd))
    assert np.abs(partial.qd).max() <= scene.run.max_speed
    assert 0 < partial.t[-1] < scene.run.duration
    assert f"t = {partial.t[-1]:.6g} s" in message


def test_failure_names_every_effect_too_stiff_for_the_step():
    """Heavy damping (20 N m s/rad) on the stiff-limit arm: RK4 at 5 ms blows up from the
    damping before any joint reaches a limit, so the message must name the damping too, with
    its rate d / M_jj, not only the (stiffer, but idle) limit springs."""
    settings = dict(od.load_scene("planar_3r_limits").settings)
    settings["effects"] = dict(settings["effects"], damping={"coefficients": 20.0})
    scene = od.scene_from_dict(settings, base_dir=od.io.urdf.shipped_robots_dir())
    traj = od.simulate(scene.replace_run(integrator="rk4"), raise_on_failure=False)
    assert not traj.complete and traj.t[-1] < 0.05  # before any limit is reached
    M_33 = od.mass_matrix(scene.model, traj.q[0])[2, 2]
    assert f"viscous damping on joint 'joint3' has rate {20.0 / M_33:.3g} 1/s" in traj.message
    assert "joint-limit stiffness" in traj.message


def test_singular_mass_matrix_stops_naming_the_joint_and_armature_fixes_it(tmp_path):
    urdf = tmp_path / "massless.urdf"
    urdf.write_text(
        """<robot name="massless">
  <link name="base"/>
  <link name="arm"><inertial><mass value="1"/><origin xyz="0.5 0 0"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="finger"/>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="arm"/>
    <axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="10" velocity="5"/></joint>
  <joint name="wrist" type="revolute"><parent link="arm"/><child link="finger"/>
    <origin xyz="1 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-3" upper="3" effort="10" velocity="5"/></joint>
</robot>"""
    )
    scene = od.default_scene(str(urdf), duration=0.1)
    with pytest.raises(SimulationError, match="joint 'wrist'") as info:
        od.simulate(scene)
    assert "armature" in str(info.value)
    assert not info.value.trajectory.complete
    settings = dict(scene.settings, effects={"gravity": True, "armature": {"values": 1e-3}})
    traj = od.simulate(od.scene_from_dict(settings))
    assert traj.complete


def test_ctrl_c_stops_the_run_and_keeps_the_record(ctrl_c_raises):
    scene = ur5_scene(duration=600.0)
    timer = threading.Timer(1.5, os.kill, (os.getpid(), signal.SIGINT))
    timer.start()
    try:
        with pytest.raises(SimulationError, match="interrupted") as info:
            od.simulate(scene)
    finally:
        timer.cancel()
    partial = info.value.trajectory
    assert not partial.complete and 0 < partial.t[-1] < 600
    assert np.all(np.isfinite(partial.q))
    # the record is consistent up to the stop: evenly sampled, no gap, and its energy balance
    # holds to the RK4 error (relative to the energy's scale)
    np.testing.assert_allclose(np.diff(partial.t), 1e-3, rtol=1e-6)
    assert np.abs(partial.energy_error).max() < 1e-6 * np.abs(partial.energy).max()


def test_trajectory_round_trips_with_provenance(tmp_path):
    traj = od.simulate(od.load_scene("double_pendulum_push").replace_run(duration=1.5))
    path = traj.save(tmp_path / "run.npz")
    back = od.Trajectory.load(path)
    for name in ("t", "q", "qd", "tau", "kinetic", "potential", "work_applied", "work_passive"):
        np.testing.assert_array_equal(getattr(back, name), getattr(traj, name))
    assert back.joint_names == traj.joint_names and back.complete
    record = (tmp_path / "run.json").read_text()
    for key in ("double pendulum push", "rk4", "numba", "wall_s", "wrench", "settings"):
        assert key in record
    csv = traj.to_csv(tmp_path / "run.csv")
    header = csv.read_text().splitlines()[0].split(",")
    assert header[:3] == ["t", "q_shoulder", "q_elbow"] and len(header) == 1 + 3 * 2 + 4
    data = np.loadtxt(csv, delimiter=",", skiprows=1)
    np.testing.assert_array_equal(data[:, 0], traj.t)
    with saved_figures() as saved:
        png = traj.plot(tmp_path / "run.png")
    ((figure, dpi),) = saved
    positions, velocities, energy = figure.axes
    for k in range(2):
        np.testing.assert_array_equal(positions.lines[k].get_xdata(), traj.t)
        np.testing.assert_array_equal(positions.lines[k].get_ydata(), traj.q[:, k])
        np.testing.assert_array_equal(velocities.lines[k].get_ydata(), traj.qd[:, k])
    drawn = {line.get_label(): line.get_ydata() for line in energy.lines}
    np.testing.assert_array_equal(drawn["E - E(0)"], traj.energy - traj.energy[0])
    np.testing.assert_array_equal(drawn["work applied"], traj.work_applied)
    image = read_png(png, figure, dpi)
    assert_lines_shown(image, positions.lines + velocities.lines + energy.lines)


def test_integrate_is_q_plus_v_dt():
    model = od.load_urdf("double_pendulum")
    np.testing.assert_allclose(od.integrate(model, [1.0, 2.0], [0.5, -1.0], 0.1), [1.05, 1.9])
    with pytest.raises(ValueError, match="v must have shape"):
        od.integrate(model, [1.0, 2.0], [0.5], 0.1)
