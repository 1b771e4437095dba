"""Nothing lost, nothing silent, round three: the stepping API, Python controllers, rollouts,
sweeps and identification under bad input. Each test is a case that failed before: DOPRI5 stepped
in periods that land on its output times, a controller that blocks, a sweep resumed after its
controller changed, states that skip the start checks, outputs that would replace the run's
inputs, params that contradict q0, identification without the signal it needs, tracebacks,
Ctrl-C inside one long step, and messages that named the wrong cause."""

from __future__ import annotations

import shutil
import signal
import subprocess
import sys
import textwrap
import time
import warnings

import numpy as np
import pytest
from conftest import ctrl_c_default

import opendyn as od
from opendyn.api import as_scene
from opendyn.cli.main import main
from opendyn.io.urdf import shipped_robots_dir

PENDULUM = {"urdf": str(shipped_robots_dir() / "double_pendulum.urdf")}


def pendulum(integrator="dopri5", duration=1.0, **run):
    return od.scene_from_dict({
        "robot": PENDULUM,
        "initial": {"q": [0.2, 0.1]},
        "run": {"integrator": integrator, "duration": duration, "dt": 1e-3, "output_dt": 0.01,
                **run},
        "effects": {"gravity": True, "damping": {"coefficients": 0.1}},
    })


def zero(t, q, qd):
    return np.zeros(2)


# -- 1. DOPRI5 stepped in periods that land on its output times --------------------------------


def test_dopri5_steps_of_a_hundredth_land_on_every_output_time_and_equal_one_run():
    # 0.05 + 0.01 = 0.060000000000000005: the period's end lies a rounding sliver past the
    # output time 0.06, which the loop used to take as a step to make, and underflow on
    scene = pendulum()
    sim = od.Simulator(scene)
    for _ in range(100):
        sim.step(None, 0.01)
    tr = sim.trajectory()
    assert tr.complete and sim.t == pytest.approx(1.0, abs=1e-14)
    # one row per output time, none a sliver apart
    np.testing.assert_allclose(tr.t, 0.01 * np.arange(101), rtol=0, atol=1e-14)
    # nothing changes at the ends of the periods (zero torque held): the one run's steps, but
    # for the rounding of the first stage evaluated anew at each period's start
    whole = od.simulate(scene)
    np.testing.assert_allclose(tr.q, whole.q, rtol=0, atol=1e-12)


@pytest.mark.parametrize("control_dt", [0.001, 0.007, 0.01, 0.02])
def test_simulate_with_a_controller_under_dopri5_runs_to_the_end(control_dt):
    tr = od.simulate(pendulum(), controller=zero, control_dt=control_dt)
    assert tr.complete and tr.t[-1] == 1.0
    # each period's end is k control_dt from the start, not a sum of rounded periods
    np.testing.assert_allclose(tr.t[:101], 0.01 * np.arange(101), rtol=0, atol=1e-14)


def test_the_command_line_runs_a_python_controller_scene_under_dopri5(tmp_path, capsys):
    status = main(["simulate", "double_pendulum_lqr", "--integrator", "dopri5", "--duration",
                   "0.3", "--quiet", "-o", str(tmp_path / "lqr.npz")])
    assert status == 0, capsys.readouterr().err
    assert od.Trajectory.load(tmp_path / "lqr.npz").t[-1] == pytest.approx(0.3, abs=1e-14)


# -- 2. a controller that blocks ---------------------------------------------------------------

BLOCKER = """
import pathlib, time
import numpy as np

def blocking(t, q, qd):
    if t > 0.05:
        pathlib.Path({marker!r}).write_text("blocking")
        time.sleep(3600)
    return np.zeros(2)
"""


def _blocked_run(tmp_path, command, signals):
    """Start `command` (argv) whose controller blocks once t > 0.05 s; once it blocks, send
    `signals` (each (signal, seconds to wait after it)). Returns (returncode, stdout, stderr,
    seconds from the last signal to the exit)."""
    proc = subprocess.Popen(command, cwd=tmp_path, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, preexec_fn=ctrl_c_default)
    marker = tmp_path / "marker"
    try:
        deadline = time.monotonic() + 300
        while not marker.exists() and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
        assert marker.exists(), proc.communicate(timeout=5)
        for signum, wait in signals:
            proc.send_signal(signum)
            if wait:
                with pytest.raises(subprocess.TimeoutExpired):
                    proc.wait(timeout=wait)  # the first Ctrl-C waits for the controller
        sent = time.monotonic()
        stdout, stderr = proc.communicate(timeout=30)
        return proc.returncode, stdout, stderr, time.monotonic() - sent
    finally:
        proc.kill()


@pytest.mark.parametrize(
    "signals, name",
    [([(signal.SIGINT, 1.0), (signal.SIGINT, 0)], "Ctrl-C"), ([(signal.SIGTERM, 0)], "SIGTERM")],
    ids=["two Ctrl-C", "SIGTERM"],
)
def test_a_blocking_controller_is_stopped_and_the_partial_record_written(signals, name, tmp_path):
    (tmp_path / "blocker.py").write_text(BLOCKER.format(marker=str(tmp_path / "marker")))
    assert main(["compile", "double_pendulum_push"]) == 0
    command = [sys.executable, "-m", "opendyn.cli", "simulate", "double_pendulum_push",
               "--controller", "blocker.py:blocking", "--control-dt", "0.01", "-o", "run.npz"]
    code, _, stderr, seconds = _blocked_run(tmp_path, command, signals)
    # a run stopped early: exit status 1, as for any Ctrl-C or SIGTERM during a run
    assert code == 1 and seconds < 5, stderr
    assert f"interrupted ({name}) at t = 0.06 s" in stderr, stderr
    partial = od.Trajectory.load(tmp_path / "run-partial.npz")
    assert not partial.complete and partial.t[-1] == pytest.approx(0.06, abs=1e-12)


def test_a_blocking_controller_in_python_ends_in_a_simulation_error_with_the_record(tmp_path):
    (tmp_path / "blocker.py").write_text(BLOCKER.format(marker=str(tmp_path / "marker")))
    script = tmp_path / "run.py"
    script.write_text(textwrap.dedent("""
        import numpy as np, opendyn as od
        from blocker import blocking
        try:
            od.simulate("double_pendulum_push", controller=blocking, control_dt=0.01)
        except od.SimulationError as e:
            print("SimulationError", e.trajectory.t[-1], e)
    """))
    code, stdout, stderr, seconds = _blocked_run(
        tmp_path, [sys.executable, str(script)], [(signal.SIGINT, 1.0), (signal.SIGINT, 0)]
    )
    assert code == 0 and seconds < 5, stderr
    words = stdout.split()
    assert words[0] == "SimulationError" and float(words[1]) == pytest.approx(0.06, abs=1e-12)
    assert "interrupted (Ctrl-C) at t = 0.06 s" in stdout and "had not returned" in stdout


# -- 3. a sweep resumed after its controller's code changed ------------------------------------


def test_a_sweep_of_a_python_controller_scene_is_another_sweep_once_the_controller_changes(
    tmp_path,
):
    pytest.importorskip("dask.distributed")
    controller = tmp_path / "gain.py"
    controller.write_text("import numpy as np\nKP = 1.0\ndef pd(t, q, qd):\n"
                          "    return -KP * q\n")
    scene = tmp_path / "scene.toml"
    scene.write_text(textwrap.dedent(f"""
        [robot]
        urdf = {PENDULUM['urdf']!r}
        [run]
        duration = 0.02
        dt = 0.001
        [control]
        type = "python"
        function = "gain.py:pd"
    """))
    table = tmp_path / "sweep.parquet"
    vary = {"initial.q.shoulder": [0.1, 0.2]}
    first = od.sweep(str(scene), vary, parquet=str(table), workers=1)
    assert first.num_rows == 2
    controller.write_text(controller.read_text().replace("KP = 1.0", "KP = 2.0"))
    with pytest.raises(od.SweepError, match="another sweep"):
        od.sweep(str(scene), vary, parquet=str(table), workers=1)


# -- 4. one start check wherever a state enters ------------------------------------------------


def test_rollout_and_reset_refuse_a_four_bar_state_off_its_loop_closure():
    q0 = np.array(as_scene("four_bar").q0)
    off = q0 + np.r_[0.3, 0.0, 0.0]
    result = od.rollout("four_bar", q0=[q0, off])
    assert list(result.status) == ["complete", "failed"]
    assert "constraints[0]" in result.message[1] and "position error is 0.236" in result.message[1]
    sim = od.Simulator("four_bar")
    with pytest.raises(ValueError, match=r"Simulator.reset: .*constraints\[0\].*0.236"):
        sim.reset(off)
    assert np.array_equal(sim.q, q0)  # the refused state changed nothing


def test_reset_refuses_a_ball_deep_in_the_ground_and_a_speed_past_max_speed():
    sim = od.Simulator("ball_drop")
    q = sim.q
    q[2] = 0.05  # the ball's centre 5 cm up: 5 cm into the ground
    with pytest.raises(ValueError, match="Simulator.reset: .*0.05 m inside the ground.*125 J"):
        sim.reset(q)
    qd = sim.qd
    qd[5] = 1e5
    with pytest.raises(ValueError, match="Simulator.reset: .*beyond run.max_speed"):
        sim.reset(None, qd)


# -- 5. outputs that would replace the run's inputs --------------------------------------------


def _scene_folder(tmp_path):
    """A copy of double_pendulum_lqr (scene, URDF with a visual mesh, controller) in tmp_path."""
    robots = shipped_robots_dir()
    for name in ("double_pendulum_lqr.toml", "double_pendulum_lqr.py"):
        shutil.copy(robots / name, tmp_path / name)
    urdf = (robots / "double_pendulum.urdf").read_text()
    mesh = '<visual><geometry><mesh filename="tip.stl"/></geometry></visual>'
    urdf = urdf.replace("</link>", mesh + "</link>", 1)
    (tmp_path / "double_pendulum.urdf").write_text(urdf)
    (tmp_path / "tip.stl").write_text("solid tip\nendsolid tip\n")
    return tmp_path / "double_pendulum_lqr.toml"


@pytest.mark.parametrize(
    "option, target, what",
    [("--csv", "double_pendulum_lqr.toml", "the scene file"),
     ("--html", "double_pendulum_lqr.toml", "the scene file"),
     ("--csv", "double_pendulum.urdf", "the robot's URDF"),
     ("--html", "double_pendulum_lqr.py", "a file the scene names"),
     ("--csv", "tip.stl", "a mesh of the robot or an object")],
)
def test_an_output_that_is_one_of_the_run_s_inputs_is_refused(
    option, target, what, tmp_path, monkeypatch, capsys
):
    scene = _scene_folder(tmp_path)
    monkeypatch.chdir(tmp_path)
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    assert main(["simulate", str(scene), "--no-save", option, target, "--duration", "0.01"]) == 2
    err = capsys.readouterr().err
    assert f"{option} {target!r}: is {what}, an input of this run" in err, err
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before


def test_an_output_that_is_the_controller_file_given_on_the_command_line_is_refused(
    tmp_path, monkeypatch, capsys
):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "ctrl.py").write_text("import numpy as np\ndef zero(t, q, qd):\n"
                                      "    return np.zeros(2)\n")
    status = main(["simulate", "double_pendulum_push", "--controller", "ctrl.py:zero",
                   "--no-save", "--csv", "ctrl.py"])
    assert status == 2 and "is the controller's file" in capsys.readouterr().err
    assert "def zero" in (tmp_path / "ctrl.py").read_text()


# -- 6. rollout params that contradict q0 or qd0 -----------------------------------------------


@pytest.mark.parametrize(
    "scene, key, given",
    [("double_pendulum_push", "initial.q.shoulder", "q0"),
     ("double_pendulum_push", "initial.qd.elbow", "qd0"),
     ("ball_drop", "initial.base_position", "q0"),
     ("box_on_table", "objects.0.position", "q0"),
     ("box_on_table", "objects.0.velocity", "qd0")],
)
def test_rollout_refuses_params_that_set_what_q0_or_qd0_replaces(scene, key, given):
    base = as_scene(scene)
    states = {"q0": np.array(base.q0), "qd0": np.array(base.qd0)}
    value = [[0.1, 0.2, 0.3]] * 2 if "base" in key or "objects" in key else [0.1, 0.2]
    with pytest.raises(ValueError, match=rf"params\['{key}'\].*{given}="):
        od.rollout(scene, **{given: [states[given]] * 2}, params={key: value})


# -- 7. identification without the signal it needs ---------------------------------------------


def _ur5_samples(n=40):
    model = od.load_urdf("ur5")
    rng = np.random.default_rng(3)
    q, qd, qdd = (rng.uniform(-1, 1, (n, model.nv)) for _ in range(3))
    return model, q, qd, qdd


def test_identify_payload_of_torques_that_hold_no_payload_says_so_without_nan_or_warnings():
    model, q, qd, qdd = _ur5_samples()
    tau = od.inverse_dynamics(model, q, qd, qdd)  # the robot's own torques: no payload
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(ValueError, match="identify_payload: the torques show no payload at "
                                             "frame 'tool0'.*not told apart from zero"):
            od.identify_payload(model, "tool0", q, qd, qdd, tau)


def test_identify_of_samples_that_move_no_torque_says_so():
    model = od.load_urdf(str(shipped_robots_dir() / "planar_3r.urdf"))
    n = 20
    at_rest = np.zeros((n, model.nv))
    q = np.random.default_rng(0).uniform(-1, 1, (n, model.nq))
    tau = od.inverse_dynamics(model, q, at_rest, at_rest)  # vertical axes: gravity moves none
    with pytest.raises(ValueError, match="identify: the samples move no torque"):
        od.identify(model, q, at_rest, at_rest, tau)


# -- 8. tracebacks -----------------------------------------------------------------------------


def test_a_step_whose_record_would_not_fit_in_memory_is_refused_before_it_runs():
    sim = od.Simulator(pendulum("rk4"))
    with pytest.raises(ValueError, match=r"Simulator.step: duration = 1e\+12 s .* samples"):
        sim.step(None, 1e12)
    assert sim.t == 0.0
    sim.step(None, 0.01)  # and it steps on


def test_sweep_takes_a_scheduler_address_as_client_and_refuses_anything_else():
    pytest.importorskip("dask.distributed")
    with pytest.raises(ValueError, match="client tcp://127.0.0.1:9: cannot connect"):
        od.sweep("double_pendulum_push", {"run.duration": [0.01]}, client="tcp://127.0.0.1:9")
    with pytest.raises(TypeError, match="client: expected a dask.distributed Client or a "
                                        "scheduler's address 'tcp://HOST:PORT', got int 42"):
        od.sweep("double_pendulum_push", {"run.duration": [0.01]}, client=42)


def test_rollout_names_the_argument_of_ragged_params_or_states():
    with pytest.raises(ValueError, match=r"params\['effects.damping.coefficients'\].*rows of "
                                         "different lengths"):
        od.rollout("double_pendulum_push", params={"effects.damping.coefficients": [[1, 2], [1]]})
    with pytest.raises(ValueError, match=r"rollout: q0 must be an array of numbers.*rows of"):
        od.rollout("double_pendulum_push", q0=[[0.1, 0.2], [0.3]])


def test_a_controller_that_steps_its_own_simulator_is_named_once():
    holder = {}

    def reenter(t, q, qd):
        holder["sim"].step(None, 0.001)
        return np.zeros(2)

    sim = holder["sim"] = od.Simulator(pendulum("rk4"), controller=reenter)
    with pytest.raises(od.SimulationError) as stopped:
        sim.step(None, 0.002)
    message = str(stopped.value)
    assert message.count("raised") == 1 and "called while this Simulator steps" in message


# -- 9. Ctrl-C inside one long step ------------------------------------------------------------

LONG_STEP = """
import time, numpy as np, opendyn as od
from opendyn.api import as_scene
sim = od.Simulator(as_scene({scene!r}).replace_run(integrator={integrator!r}))
print("stepping", flush=True)
try:
    sim.step(None, 4000.0)
except KeyboardInterrupt as e:
    caught = time.monotonic()
    tr = sim.trajectory()
    t_before = sim.t
    sim.step(None, 0.002)  # it steps on from there
    print("caught", caught, tr.t[-1] == t_before, sim.t - t_before, e, flush=True)
"""


@pytest.mark.parametrize("scene, integrator", [("ur5_falling", "rk4"),
                                               ("double_pendulum_push", "dopri5")])
def test_ctrl_c_stops_one_long_step_within_a_second_with_the_state_consistent(
    scene, integrator, tmp_path
):
    od.Simulator(as_scene(scene).replace_run(integrator=integrator))  # compiled ahead
    script = tmp_path / "long.py"
    script.write_text(LONG_STEP.format(scene=scene, integrator=integrator))
    proc = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, preexec_fn=ctrl_c_default)
    try:
        assert proc.stdout.readline().strip() == "stepping"
        time.sleep(2.0)
        sent = time.monotonic()
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=60)
    finally:
        proc.kill()
    words = out.split()
    assert words[:1] == ["caught"], out + err
    assert float(words[1]) - sent < 1.0 and words[2] == "True", out
    assert float(words[3]) == pytest.approx(0.002, abs=1e-12)
    assert "Simulator.step: interrupted (Ctrl-C) at t = " in out


def test_a_ctrl_c_right_after_a_short_compiled_step_puts_the_state_back(monkeypatch):
    sim, twin = od.Simulator(pendulum("rk4")), od.Simulator(pendulum("rk4"))
    sim.step(None, 0.01)
    twin.step(None, 0.01)
    real = sim._run_fixed

    def interrupted(*args):
        real(*args)  # the steps are taken, then Ctrl-C lands before they are booked
        raise KeyboardInterrupt

    sim._run_fixed = interrupted
    with pytest.raises(KeyboardInterrupt):
        sim.step(None, 0.01)
    sim._run_fixed = real
    assert sim.t == twin.t and np.array_equal(sim.q, twin.q) and np.array_equal(sim.qd, twin.qd)
    sim.step(None, 0.02)
    twin.step(None, 0.02)
    a, b = sim.trajectory(), twin.trajectory()
    assert np.array_equal(a.t, b.t) and np.array_equal(a.q, b.q)


# -- 10. the causes named ----------------------------------------------------------------------


def test_a_period_below_the_time_s_resolution_is_named_not_blamed_on_the_dynamics():
    with pytest.raises(ValueError, match="control_dt = 1e-300 s is below what the simulated time"):
        od.simulate(pendulum(), controller=zero, control_dt=1e-300)
    sim = od.Simulator(pendulum())
    with pytest.raises(ValueError, match="Simulator.step: duration = 1e-300 s is below"):
        sim.step(None, 1e-300)


def test_a_simulator_of_a_scene_too_long_to_simulate_whole_steps_all_the_same():
    scene = pendulum("rk4", duration=1e9)  # 1e12 steps: simulate refuses the record
    with pytest.raises(od.SceneError, match="run.output_dt"):
        od.simulate(scene)
    sim = od.Simulator(scene)  # which the Simulator, stepping its own durations, never makes
    sim.step(None, 0.05)
    assert sim.trajectory().complete and sim.t == pytest.approx(0.05)


def test_a_float32_duration_is_the_decimal_it_stands_for():
    """np.float32(0.001) holds 0.0010000000475 s: it was refused as not a whole number of steps
    of 0.001 s."""
    sim = od.Simulator(pendulum("rk4"))
    sim.step(None, np.float32(0.001))
    sim.step(None, np.float32(0.049))
    assert sim.t == pytest.approx(0.05, abs=1e-15) and sim.trajectory().complete


def test_a_zero_quaternion_is_named_as_no_orientation_not_sent_to_normalize():
    scene = od.load_scene("t_handle_flip")
    q = np.array(scene.q0)
    q[3:7] = 0.0
    with pytest.raises(ValueError, match=r"linearize: q: the quaternion q\[3:7\] .* no "
                                         r"orientation.*\(0, 0, 0, 1\)") as refused:
        od.linearize(scene, q=q)
    assert "od.normalize" not in str(refused.value)


CONTROLLER = "import numpy as np\n\ndef control(t, q, qd):\n    return np.zeros(2)\n"


def test_a_controller_that_exits_at_import_is_an_error_naming_it(tmp_path, capsys):
    """sys.exit(4) in the controller's module made `opendyn simulate` exit 4 without a word."""
    path = tmp_path / "quits.py"
    path.write_text("import sys\n\nsys.exit(4)\n" + CONTROLLER)
    argv = ["simulate", "double_pendulum_swing", "--no-save", "-q", "--controller",
            f"{path}:control"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert f"--controller: loading {str(path)!r} failed: it called sys.exit(4)" in err, err


def test_a_controller_with_control_disabled_is_refused_naming_both(tmp_path, capsys):
    """--disable control switched the scene's control off, and --controller ran one anyway."""
    path = tmp_path / "ctrl.py"
    path.write_text(CONTROLLER)
    argv = ["simulate", "double_pendulum_push", "--no-save", "-q", "--duration", "0.01",
            "--controller", f"{path}:control", "--disable", "control"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert f"--controller {path}:control and --disable control" in err, err


def test_a_record_too_large_names_the_options_that_made_it(capsys):
    """The refusal blamed run.output_dt of the scene file, which holds 0.01 s."""
    argv = ["simulate", "double_pendulum_swing", "--no-save", "-q", "--duration", "1e6",
            "--output-dt", "0.001"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "opendyn simulate: --output-dt: the record would hold 1e+09 samples" in err, err
    assert "raise --output-dt (now 0.001 s) or shorten --duration (now 1e+06 s)" in err, err
    assert "run." not in err and ".toml" not in err, err


@pytest.mark.parametrize("command", [["sweep", "double_pendulum_push", "--vary",
                                      "run.duration=0.01"], ["verify", "double_pendulum"]])
def test_a_negative_seed_is_named_as_the_option(command, capsys):
    with pytest.raises(SystemExit) as refused:
        main([*command, "--seed", "-1"])
    err = capsys.readouterr().err
    assert refused.value.code == 2 and "argument --seed: invalid seed: '-1'" in err, err


def test_a_joint_starting_too_far_for_its_sine_is_refused_naming_it():
    """A revolute joint at q = 1e308 ran "complete" on sines of rounding noise."""
    scene = od.scene_from_dict({"robot": PENDULUM, "initial": {"q": [0.2, 1e308]},
                                "run": {"duration": 0.01}})
    with pytest.raises(od.SceneError, match=r"initial.q.elbow: joint 'elbow' starts at 1e\+308, "
                                            r"beyond \|q\| = 1e\+06"):
        od.simulate(scene)


def test_a_rollout_with_one_bad_q0_row_fails_that_run_and_runs_the_others():
    """A NaN row raised for the whole batch, where a run that cannot start is a failed run."""
    scene = pendulum("rk4", duration=0.05)
    result = od.rollout(scene, q0=[[0.2, 0.1], [np.nan, 0.0], [0.3, 0.0]],
                        params={"effects.damping.coefficients": [0.1, 0.2, 0.3]})
    assert list(result.status) == ["complete", "failed", "complete"]
    assert result.message[1] == "rollout: q0[1] is not finite: [nan  0.]"
    first = od.rollout(scene, q0=[[np.nan, 0.0], [0.2, 0.1]])
    assert list(first.status) == ["failed", "complete"]


# -- the last pass: what a user tried after the round's fixes ----------------------------------


def test_an_effect_both_enabled_and_disabled_is_refused_naming_both(capsys):
    """--enable gravity --disable gravity ran with no effects at all, exit 0."""
    argv = ["simulate", "double_pendulum_swing", "--no-save", "-q", "--duration", "0.01",
            "--enable", "gravity", "--disable", "gravity"]
    assert main(argv) == 2
    assert "--enable gravity and --disable gravity" in capsys.readouterr().err


def test_run_control_dt_with_a_compiled_control_law_warns_that_it_changes_nothing(tmp_path):
    """[run] control_dt with a built-in [control] type (pd, constant) was accepted, even
    below dt, and did nothing: the law acts at every evaluation."""
    scene = (shipped_robots_dir() / "planar_3r_limits.toml").read_text()
    assert 'type = "constant"' in scene and "[run]\n" in scene
    path = tmp_path / "held.toml"
    path.write_text(scene.replace("[run]\n", "[run]\ncontrol_dt = 0.0025\n", 1).replace(
        'urdf = "', f'urdf = "{shipped_robots_dir()}/', 1))
    with pytest.warns(od.SceneWarning, match=r"run.control_dt: 0.0025 s is the period of a Py"):
        od.load_scene(path)


def test_a_trajectory_is_not_written_over_the_files_its_run_read(tmp_path):
    """tr.to_csv("dp.toml") replaced the scene file with a table; save("") and save(123) said
    nothing of the argument."""
    scene = tmp_path / "dp.toml"
    scene.write_text((shipped_robots_dir() / "double_pendulum_swing.toml").read_text().replace(
        'urdf = "', f'urdf = "{shipped_robots_dir()}/', 1))
    traj = od.simulate(od.load_scene(scene).replace_run(duration=0.01))
    before = scene.read_bytes()
    with pytest.raises(ValueError, match="is a file this run read"):
        traj.to_csv(scene)
    with pytest.raises(ValueError, match="is a file this run read"):
        traj.to_csv(od.load_scene(scene).model.source)  # the robot's URDF
    assert scene.read_bytes() == before
    with pytest.raises(ValueError, match=r"Trajectory.save: path is empty"):
        traj.save("")
    with pytest.raises(TypeError, match=r"Trajectory.to_csv: path must be a file name .* int"):
        traj.to_csv(123)


def test_messages_that_named_the_wrong_thing(tmp_path, capsys):
    """A scene file given as --controller was "No module named 'dp'"; a folder given as a
    scene "no such scene file"; [effects]' valid keys listed contact twice."""
    scene = tmp_path / "dp.toml"
    scene.write_text("")
    argv = ["simulate", "double_pendulum_swing", "--no-save", "-q", "--duration", "0.01",
            "--controller", f"{scene}:f"]
    assert main(argv) == 2
    assert f"{str(scene)!r} is not a Python file" in capsys.readouterr().err
    with pytest.raises(od.SceneError, match="is a folder, not a scene file"):
        od.load_scene(tmp_path)
    with pytest.raises(od.SceneError) as unknown:
        od.scene_from_dict({"robot": {"urdf": "double_pendulum.urdf"}, "effects": {"gravty": 1}},
                           base_dir=shipped_robots_dir())
    valid = str(unknown.value).split("valid keys in [effects]: ")[1].split(", ")
    assert len(valid) == len(set(valid)) and "contact" in valid
