"""Simulator (stepping from Python) and Python controllers (simulate(controller=), [control]
type = "python"): stepping in pieces equals one run bit for bit, a held PD torque is the
built-in PD law (explicit Euler: exactly; RK4: up to the zero-order hold's first-order error),
the energy balance closes with the held torque's work, and bad controllers stop the run with a
clear message and the trajectory up to them."""

from __future__ import annotations

import textwrap

import numpy as np
import pytest
from shipped_controller import shipped_controller

import opendyn as od
from opendyn.cli.main import main
from opendyn.io.urdf import shipped_robots_dir

PENDULUM = {"urdf": str(shipped_robots_dir() / "double_pendulum.urdf")}
KP, KD, SETPOINT = 20.0, 2.0, [0.4, -0.3]


def pendulum(integrator="rk4", duration=0.2, control=None, **run):
    settings = {
        "robot": PENDULUM,
        "initial": {"q": [0.2, 0.1]},
        "run": {"integrator": integrator, "duration": duration, "dt": 1e-3,
                "output_dt": 0.01, **run},
        "effects": {"gravity": True, "damping": {"coefficients": 0.1}},
    }
    if control is not None:
        settings["control"] = control
    return od.scene_from_dict(settings)


def pd(t, q, qd):
    return KP * (np.array(SETPOINT) - q) - KD * qd


def same(a, b):
    """Two trajectories equal bit for bit in every recorded array."""
    for name in ("t", "q", "qd", "tau", "work_applied", "work_passive", "kinetic", "potential"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name


@pytest.mark.parametrize("integrator", ["euler", "semi_implicit_euler", "rk4", "implicit_euler"])
def test_stepping_in_pieces_equals_one_run_bit_for_bit(integrator):
    scene = pendulum(integrator, duration=0.1)
    sim = od.Simulator(scene)
    for _ in range(100):
        sim.step(duration=1e-3)
    assert sim.t == pytest.approx(0.1, abs=1e-15)
    same(sim.trajectory(), od.simulate(scene))


@pytest.mark.parametrize("name", ["quadruped_drop", "ball_drop"])
def test_stepping_a_floating_robot_with_contact_equals_one_run(name):
    scene = od.load_scene(name).replace_run(duration=0.1)
    sim = od.Simulator(scene)
    for _ in range(round(0.1 / scene.run.dt)):
        sim.step(duration=scene.run.dt)
    full = od.simulate(scene)
    same(sim.trajectory(), full)
    assert np.array_equal(sim.trajectory().contact_force, full.contact_force)


def test_a_python_pd_with_euler_at_every_step_is_the_built_in_pd():
    """Explicit Euler evaluates once per step, at its start: the held torque is the law."""
    law = {"type": "pd", "kp": KP, "kd": KD, "setpoint": SETPOINT}
    built_in = od.simulate(pendulum("euler", control=law))
    python = od.simulate(pendulum("euler"), controller=pd, control_dt=1e-3)
    np.testing.assert_allclose(python.q, built_in.q, rtol=0, atol=1e-10)
    np.testing.assert_allclose(python.tau[:-1], built_in.tau[:-1], rtol=0, atol=1e-10)


def test_the_zero_order_hold_error_is_first_order_in_control_dt():
    """RK4 with the PD held over control_dt against the PD evaluated at every stage: the
    difference halves as control_dt halves (O(control_dt))."""
    law = {"type": "pd", "kp": KP, "kd": KD, "setpoint": SETPOINT}
    built_in = od.simulate(pendulum("rk4", control=law))
    errors = []
    for k in (8, 4, 2):
        held = od.simulate(pendulum("rk4"), controller=pd, control_dt=k * 1e-3)
        errors.append(np.abs(held.q[-1] - built_in.q[-1]).max())
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    assert np.all((ratios > 1.7) & (ratios < 2.3)), (errors, ratios)


def test_simulate_with_a_controller_equals_a_loop_of_steps_bit_for_bit():
    scene = pendulum("rk4", duration=0.2)
    run = od.simulate(scene, controller=pd, control_dt=0.01)
    sim = od.Simulator(scene)
    while sim.t < 0.2 - 1e-12:
        sim.step(tau=pd(sim.t, sim.q, sim.qd), duration=0.01)
    same(run, sim.trajectory())
    own = od.Simulator(scene, controller=pd, control_dt=0.01)
    own.step(duration=0.2)
    same(run, own.trajectory())


def test_the_energy_balance_closes_with_the_held_torque_s_work():
    tr = od.simulate(pendulum("rk4", duration=1.0), controller=pd, control_dt=5e-3)
    energy = tr.kinetic + tr.potential
    assert np.abs(tr.work_applied).max() > 0.1  # the controller does work
    balance = energy - energy[0] - tr.work_applied - tr.work_passive
    assert np.abs(balance).max() < 1e-8 * np.abs(energy).max()


def test_dopri5_lands_on_the_end_of_each_interval():
    scene = pendulum("dopri5", duration=0.1)
    sim = od.Simulator(scene)
    for k in range(1, 8):
        sim.step(tau=[0.5, -0.2], duration=0.0137)
        assert sim.t == pytest.approx(0.0137 * k, rel=0, abs=1e-15)
    tr = sim.trajectory()
    # rows at the output times, and the current state last
    np.testing.assert_allclose(tr.t[:-1], 0.01 * np.arange(len(tr.t) - 1), atol=1e-15)
    assert tr.t[-1] == sim.t
    # the same constant torque as a scene's constant control: same trajectory to tolerance
    constant = od.simulate(
        pendulum("dopri5", duration=0.0959, control={"type": "constant", "tau": [0.5, -0.2]})
    )
    np.testing.assert_allclose(tr.q[-1], constant.q[-1], atol=1e-7)


def test_state_reset_and_torque_checks():
    scene = pendulum()
    sim = od.Simulator(scene)
    assert sim.t == 0.0 and np.array_equal(sim.q, scene.q0) and sim.model is scene.model
    q = sim.q
    q[0] = 5.0  # a copy
    assert sim.q[0] == scene.q0[0]
    sim.step(tau=[1.0, 0.0], duration=0.005)
    assert sim.t == pytest.approx(0.005)
    sim.reset(q=[0.0, 0.0], qd=[1.0, 0.0], t=2.0)
    assert sim.t == 2.0 and np.array_equal(sim.qd, [1.0, 0.0])
    sim.step(duration=0.02)
    assert sim.trajectory().t[0] == 2.0
    with pytest.raises(ValueError, match=r"tau: expected shape \(2,\)"):
        sim.step(tau=[1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="tau: not finite"):
        sim.step(tau=[np.nan, 0.0])
    with pytest.raises(TypeError, match="tau"):
        sim.step(tau=["a", "b"])
    with pytest.raises(ValueError, match=r"0.0015 s is not a whole number of steps of run.dt"):
        sim.step(duration=0.0015)
    with pytest.raises(ValueError, match=r"reset: q: expected shape \(2,\)"):
        sim.reset(q=[0.0])


def test_a_floating_base_takes_the_joints_torque_and_refuses_a_base_torque():
    scene = od.load_scene("quadruped_drop").replace_run(duration=0.05).without("control")
    sim = od.Simulator(scene)
    n = len(scene.model.v_index)
    sim.step(tau=np.ones(n), duration=scene.run.dt)
    tau = sim.trajectory().tau[-1]
    np.testing.assert_allclose(tau[scene.model.v_index], 1.0)
    full = np.zeros(scene.model.nv)
    full[2] = 1.0
    with pytest.raises(ValueError, match="a floating base, a scene.s objects. are not"):
        sim.step(tau=full)


def test_a_failure_keeps_the_trajectory_and_stops_the_simulator():
    scene = pendulum(max_speed=5.0)
    sim = od.Simulator(scene)
    with pytest.raises(od.SimulationError) as caught:
        for _ in range(1000):
            sim.step(tau=[200.0, 0.0], duration=0.01)
    tr = caught.value.trajectory
    assert not tr.complete and len(tr.t) > 1 and np.all(np.isfinite(tr.q))
    with pytest.raises(od.SimulationError, match="reset"):
        sim.step()
    sim.reset()
    sim.step()


@pytest.mark.parametrize(
    "controller, message",
    [
        (lambda t, q, qd: 1 / 0 if t > 0.05 else np.zeros(2), "raised ZeroDivisionError"),
        (lambda t, q, qd: np.zeros(3), r"returned tau: expected shape \(2,\)"),
        (lambda t, q, qd: np.full(2, np.nan) if t > 0.05 else np.zeros(2), "not finite"),
        (lambda t, q, qd: "torque", "returned tau"),
    ],
    ids=["raises", "wrong shape", "nan", "text"],
)
def test_a_bad_controller_stops_the_run_with_a_clear_message(controller, message):
    with pytest.raises(od.SimulationError, match=message) as caught:
        od.simulate(pendulum(), controller=controller, control_dt=0.01)
    error = caught.value
    assert "controller" in str(error) and "t = " in str(error)
    tr = error.trajectory
    assert not tr.complete and len(tr.t) >= 1
    kept = od.simulate(pendulum(), controller=controller, control_dt=0.01,
                       raise_on_failure=False)
    assert not kept.complete and "controller" in kept.message and len(kept.t) >= 1


def test_a_slow_controller_still_moves_the_progress_bar(capsys):
    import time

    def slow(t, q, qd):
        time.sleep(0.03)
        return np.zeros(2)

    tr = od.simulate(pendulum(duration=0.06), controller=slow, control_dt=1e-3, progress=True)
    assert tr.complete
    bar = capsys.readouterr().err
    shown = [line for line in bar.replace("\r", "\n").splitlines() if "simulating" in line]
    assert len(shown) >= 2 and any("100%" not in line for line in shown), bar


def test_a_scene_names_its_python_controller(tmp_path):
    (tmp_path / "my_controllers.py").write_text(textwrap.dedent(f"""
        import numpy as np
        def pd(t, q, qd):
            return {KP} * (np.array({SETPOINT}) - q) - {KD} * qd
    """))
    (tmp_path / "scene.toml").write_text(textwrap.dedent(f"""
        [robot]
        urdf = {str(PENDULUM["urdf"])!r}
        [initial]
        q = [0.2, 0.1]
        [run]
        duration = 0.2
        dt = 0.001
        [effects]
        gravity = true
        damping = {{ coefficients = 0.1 }}
        [control]
        type = "python"
        function = "my_controllers.py:pd"
        control_dt = 0.01
    """))
    from_file = od.simulate(tmp_path / "scene.toml")
    given = od.simulate(pendulum(), controller=pd, control_dt=0.01)
    np.testing.assert_array_equal(from_file.q, given.q)
    bad = od.load_scene(tmp_path / "scene.toml")
    with pytest.raises(od.SceneError, match="no file"):
        od.scene_from_dict({"robot": PENDULUM, "control": {"type": "python",
                                                            "function": "nope.py:pd"}})
    with pytest.raises(od.SceneError, match="has no function 'missing'"):
        od.simulate(od.scene_from_dict({**bad.settings, "control": {
            "type": "python", "function": str(tmp_path / "my_controllers.py") + ":missing"}}))


def test_the_command_line_runs_a_controller_file(tmp_path, capsys):
    (tmp_path / "ctl.py").write_text("import numpy as np\n"
                                     "def hold(t, q, qd):\n    return -5.0 * qd\n")
    scene = str(shipped_robots_dir() / "double_pendulum_swing.toml")
    run = ["simulate", scene, "--duration", "0.2", "-q", "-o", str(tmp_path / "out.npz")]
    assert main(run + ["--controller", f"{tmp_path / 'ctl.py'}:hold", "--control-dt", "0.01"]) == 0
    saved = od.Trajectory.load(tmp_path / "out.npz")
    expected = od.simulate(od.load_scene(scene).replace_run(duration=0.2),
                           controller=lambda t, q, qd: -5.0 * qd, control_dt=0.01)
    np.testing.assert_array_equal(saved.q, expected.q)
    capsys.readouterr()
    assert main(run + ["--controller", f"{tmp_path / 'ctl.py'}:nope"]) == 2
    err = capsys.readouterr().err
    assert "has no function 'nope'" in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1, err


def test_the_panda_impedance_example_holds_its_tool_with_the_commanded_stiffness():
    """robots/panda_impedance: 10 N along world x at the tool from 0.6 s to 1.9 s (full
    force); the tool gives way by F / k_lin (k_lin = 500 N/m) and comes back; the energy
    balance closes with the controller's and the push's work."""
    example = shipped_controller("panda_impedance")
    tr = od.simulate("panda_impedance")
    assert tr.complete
    p = np.array([od.frame_pose(example.MODEL, q, example.TOOL)[:3, 3] for q in tr.q])
    offset = p - example.T_SD[:3, 3]

    def at(t):
        return offset[np.argmin(np.abs(tr.t - t))]

    assert np.abs(offset[tr.t <= 0.5]).max() < 1e-6  # held where it started before the push
    k_lin = example.K[3, 3]
    under_push = at(1.85)
    assert 10.0 / under_push[0] == pytest.approx(k_lin, rel=0.02)  # seen stiffness: F / dx
    assert np.abs(under_push[1:]).max() < 0.05 * under_push[0]  # gives way along the push
    assert np.abs(at(3.5)).max() < 1e-4  # back at the set pose within 0.1 mm
    energy = tr.kinetic + tr.potential
    balance = energy - energy[0] - tr.work_applied - tr.work_passive
    assert np.abs(balance).max() < 1e-8 * np.abs(energy).max()


def test_a_controller_that_returns_nothing_stops_the_run_naming_it():
    """A controller that forgot its return ran the whole scene at zero torque, without a word
    (None means zero only as Simulator.step's own argument)."""
    def forgot(t, q, qd):
        tau = -10.0 * qd  # noqa: F841 (computed, never returned)

    scene = od.load_scene("ur5_falling").replace_run(duration=0.05)
    with pytest.raises(od.SimulationError) as stopped:
        od.simulate(scene, controller=forgot)
    assert str(stopped.value).startswith(
        "controller 'forgot' returned None at t = 0 s; it must return the joint torques tau "
        "(a (6,) array"
    )
    assert len(stopped.value.trajectory.t) == 1  # the initial state, kept


def test_a_torque_that_alone_passes_max_speed_in_one_step_is_named_as_the_cause():
    """Simulator.step(1e9 N m) on the quadruped was put down to the integrator's step, with
    the advice to use dopri5; the torque is the cause, and the message names it."""
    sim = od.Simulator(od.load_scene("quadruped_drop").replace_run(duration=1.0))
    sim.step(np.zeros(12), duration=0.01)
    with pytest.raises(od.SimulationError) as stopped:
        sim.step(np.full(12, 1e9))
    message = str(stopped.value)
    assert "Likely cause: the torque the step was given (|tau| up to 1e+09 on 'FL_HAA')" in message
    assert "past max_speed = 10000; check the torque" in message and "dopri5" not in message
    assert stopped.value.trajectory.t[-1] == pytest.approx(0.01)


def test_the_wall_time_of_a_controlled_run_counts_the_controller_s_calls():
    """A controller that sleeps 20 ms a call: the run's wall time holds the sleeps, and the
    summary's real-time factor is the whole run's, with the compiled step's alone beside it."""
    import time

    from opendyn.cli.simulate import summary

    calls = []

    def sleepy(t, q, qd):
        calls.append(t)
        time.sleep(0.02)
        return np.zeros(2)

    scene = pendulum(duration=0.05)
    traj = od.simulate(scene, controller=sleepy, control_dt=0.01)
    slept = 0.02 * len(calls)
    assert len(calls) == 5
    assert traj.stats["wall_s"] >= slept and traj.stats["controller_s"] >= slept
    assert traj.stats["wall_s"] > traj.stats["controller_s"]
    (line,) = [line for line in summary(scene, traj).splitlines() if line.startswith("simulated")]
    factor = traj.stats["simulated_s"] / traj.stats["wall_s"]
    assert f"({factor:.3g}x real time; of it " in line
    assert "s in the Python controller, the compiled step alone " in line
    sim = od.Simulator(scene, controller=sleepy, control_dt=0.01)
    sim.step(duration=0.03)
    assert sim.trajectory().stats["wall_s"] >= 0.06
