"""Scene values that cannot be run are refused before anything is allocated or compiled, naming
the key to change; a run that stops names the real cause, not a generic one."""

from __future__ import annotations

import importlib
import subprocess
import sys
import warnings

import numpy as np
import pytest

import opendyn as od
from opendyn.cli.main import main
from opendyn.sim.scene import thaw
from opendyn.io.scene.files import shipped_scenes
from opendyn.io.urdf import shipped_robots_dir
from opendyn.sim import preflight

simulate_module = importlib.import_module("opendyn.sim.simulate")  # od.simulate is the function
PENDULUM = {"robot": {"name": "double_pendulum"}, "effects": {"gravity": True}}


def scene(**sections):
    return od.scene_from_dict({**PENDULUM, **sections})


@pytest.fixture
def nothing_allocated(monkeypatch):
    """Fail the test if simulate gets as far as allocating the record."""

    def refuse(*args):
        raise AssertionError("the record was allocated before the scene was refused")

    monkeypatch.setattr(simulate_module, "Samples", refuse)


def test_a_record_too_large_for_memory_is_refused_before_allocating(nothing_allocated):
    # 1e12 samples of 11 numbers, three times over: 264 TB, on any machine more than it has
    huge = scene(run={"duration": 1e9, "dt": 1e-3, "output_dt": 1e-3})
    with pytest.raises(od.SceneError, match=r"run\.output_dt: the record would hold 1e\+12 "
                       r"samples of 11 numbers, about 264 TB") as info:
        od.simulate(huge)
    assert "raise run.output_dt (now 0.001 s) or shorten run.duration (now 1e+09 s)" in str(info.value)


def test_the_memory_estimate_counts_contact_points_and_compares_with_what_is_available(
    monkeypatch, nothing_allocated
):
    """ball_drop: 1 contact point on a free body (nq = 7, nv = 6): 3 + 7 + 12 + 2 + 7 = 31
    numbers per sample, three times over. With 1 MB available, 4 s at 1 ms output (4001
    samples, 2.98 MB) is refused; the same at 10 ms (401 samples, 0.3 MB) is not."""
    ball = od.load_scene("ball_drop").replace_run(duration=4.0, dt=1e-4, output_dt=1e-3)
    monkeypatch.setattr(preflight, "available_memory", lambda: (1e6, "memory available"))
    with pytest.raises(od.SceneError, match=r"4001 samples of 31 numbers, about 2\.98 MB"):
        od.simulate(ball)
    integ = simulate_module.integrators.INTEGRATORS["rk4"]
    assert preflight.preflight(ball.replace_run(output_dt=1e-2), integ) == (40000, 100, 401)


def test_an_overflowing_step_count_is_refused(nothing_allocated):
    with pytest.raises(od.SceneError, match=r"run\.dt: .* = inf steps, more than a run can count"):
        od.simulate(scene(run={"duration": 1e300, "dt": 1e-300}))
    with pytest.raises(od.SceneError, match=r"run\.dt: .* = 1e\+16 steps"):
        od.simulate(scene(run={"duration": 1e13, "dt": 1e-3, "output_dt": 1e12}))


def test_a_subnormal_step_is_refused_naming_it():
    """1e-320 is subnormal in float64 (stored as 9.99989e-321): output_dt / dt overflows."""
    with pytest.raises(od.SceneError, match=r"run\.dt: 9\.99989e-321 s is too small a step to count"):
        scene(run={"duration": 0.2, "dt": 1e-320})


def test_a_duration_that_is_not_a_whole_number_of_steps_is_refused(nothing_allocated):
    with pytest.raises(od.SceneError) as info:
        od.simulate(scene(run={"duration": 0.0105, "dt": 1e-3}))
    message = str(info.value)
    assert "run.duration: 0.0105 s is not a whole number of steps of run.dt = 0.001 s" in message
    assert "10.5 steps" in message and "0.01 or 0.011 s" in message


def test_a_duration_of_whole_steps_runs_exactly_to_it_despite_rounding():
    """0.3 / 0.1 is 2.9999999999999996 in float64: three steps, ending at 0.3 s."""
    run = scene(run={"duration": 0.3, "dt": 0.1, "output_dt": 0.1})
    traj = od.simulate(run)
    assert traj.stats["steps"] == 3 and traj.t[-1] == pytest.approx(0.3, abs=1e-15)
    np.testing.assert_allclose(traj.t, [0.0, 0.1, 0.2, 0.3], atol=1e-15)


def test_an_initial_velocity_beyond_max_speed_is_refused_naming_the_joint(nothing_allocated):
    with pytest.raises(od.SceneError, match=r"initial\.qd\.elbow: the initial velocity -20000 "
                       r"of 'elbow' is beyond run\.max_speed = 10000"):
        od.simulate(scene(initial={"qd": [1.0, -2e4]}))


def test_an_initial_base_velocity_beyond_max_speed_names_the_base_key(nothing_allocated):
    falling = od.scene_from_dict(
        {
            "robot": {"urdf": str(shipped_robots_dir() / "ball.urdf"), "floating_base": True},
            "initial": {"base_velocity": [0.0, 50.0, 0.0]},
            "run": {"max_speed": 20.0},
        }
    )
    with pytest.raises(od.SceneError, match=r"initial\.base_velocity: the initial velocity 50"):
        od.simulate(falling)


def test_an_initial_energy_that_overflows_is_refused(nothing_allocated):
    fast = scene(initial={"qd": [1e200, 0.0]}, run={"max_speed": 1e300})
    with pytest.raises(od.SceneError, match=r"initial\.qd: the energy at the initial state is "
                       r"not a finite number \(kinetic inf J"):
        od.simulate(fast)
    heavy = scene(effects={"gravity": [0.0, 0.0, -1e308]})
    with pytest.raises(od.SceneError, match=r"effects\.gravity: .*potential -?inf J"):
        od.simulate(heavy)


def test_an_initial_position_outside_the_limits_warns_and_is_refused_where_enforced():
    outside = {"q": {"shoulder": 4.0}}
    with pytest.warns(od.SceneWarning, match=r"initial\.q\.shoulder: joint 'shoulder' starts at "
                      r"4, outside its limits \[-3\.14, 3\.14\]"):
        traj = od.simulate(scene(initial=outside, run={"duration": 0.01}))
    assert traj.complete and traj.q[0, 0] == 4.0
    enforced = scene(initial=outside, effects={"gravity": True, "limits": {"stiffness": 1e3}})
    with pytest.raises(od.SceneError, match=r"initial\.q\.shoulder: .*which \[effects\.limits\] "
                       r"enforces: its spring would start 0\.86 deep"):
        od.simulate(enforced)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # inside the limits: no warning at all
        od.simulate(scene(initial={"q": {"shoulder": 3.0}}, run={"duration": 0.01}))


def test_a_wrench_on_a_frame_welded_to_the_world_is_refused():
    with pytest.raises(od.SceneError, match=r"effects\.wrench\.frame: 'base' is welded to the "
                       r"fixed world .* frames that move: link1, link2, tip"):
        scene(effects={"gravity": True, "wrench": {"frame": "base", "value": [0, 0, 0, 1, 0, 0]}})


@pytest.mark.parametrize("name, prefix", [("SCENE.TOML", b""), ("scene.txt", b""),
                                          ("bom.toml", b"\xef\xbb\xbf")])
def test_a_scene_file_is_recognised_by_content_and_its_byte_order_mark_ignored(
    tmp_path, capsys, name, prefix
):
    text = (shipped_robots_dir() / "double_pendulum_swing.toml").read_text()
    urdf = (shipped_robots_dir() / "double_pendulum.urdf").as_posix()
    text = text.replace('urdf = "double_pendulum.urdf"', f'urdf = "{urdf}"')
    path = tmp_path / name
    path.write_bytes(prefix + text.encode())
    out = tmp_path / "out.npz"
    assert main(["simulate", str(path), "--duration", "0.1", "-q", "-o", str(out)]) == 0
    assert od.Trajectory.load(out).provenance["scene"]["name"] == "double pendulum swing"
    assert od.load_scene(path).name == "double pendulum swing"


def test_a_urdf_without_the_urdf_extension_is_still_read_as_a_robot(tmp_path, capsys):
    path = tmp_path / "pendulum.robot"
    path.write_bytes((shipped_robots_dir() / "double_pendulum.urdf").read_bytes())
    out = tmp_path / "out.npz"
    assert main(["simulate", str(path), "--duration", "0.1", "-q", "-o", str(out)]) == 0
    assert od.Trajectory.load(out).provenance["robot"]["name"] == "double_pendulum"


def test_a_run_that_fails_at_the_first_step_names_the_initial_forces():
    """Gravity of 1e200 m/s^2 on a tilted pendulum: finite energy, but accelerations of about
    1e200 that one step turns into velocities far past max_speed. No effect is stiff: the
    message must say the forces at the start, not that the integrator is unstable."""
    traj = od.simulate(
        scene(effects={"gravity": [0.0, 0.0, -1e200]}, initial={"q": [0.3, 0.0]},
              run={"duration": 0.01}),
        raise_on_failure=False,
    )
    assert not traj.complete and traj.stats["steps"] == 0
    assert "the forces at the initial state: they accelerate" in traj.message
    assert "beyond run.max_speed = 10000" in traj.message
    assert "integrator is unstable" not in traj.message


def test_a_huge_contact_stiffness_under_implicit_euler_is_named_not_a_singular_mass_matrix():
    """k = 1e300 N/m: the implicit step's M + dt D + dt^2 K loses M in float64 at touch-down.
    The ball's M is a regular 6 x 6 body inertia; the message names the contact stiffness."""
    ball = od.load_scene("ball_drop")
    settings = thaw(ball.settings)
    settings["effects"]["contact"]["stiffness"] = 1e300
    stiff = od.scene_from_dict(settings, base_dir=shipped_robots_dir())
    traj = od.simulate(
        stiff.replace_run(integrator="implicit_euler", dt=1e-3, duration=0.5),
        raise_on_failure=False,
    )
    assert not traj.complete
    assert "the implicit step's matrix M + dt D + dt^2 K became singular" in traj.message
    assert "mass matrix M alone is regular" in traj.message
    assert "contact stiffness on contact point 'ball' has rate 1e+150 1/s" in traj.message
    assert "nothing with mass" not in traj.message


def test_an_adaptive_step_underflow_names_the_stiff_effect():
    pd = scene(
        control={"type": "pd", "kp": 1e300, "kd": 1.0, "setpoint": [0.5, 0.0]},
        run={"duration": 0.01, "integrator": "dopri5"},
    )
    traj = od.simulate(pd, raise_on_failure=False)
    assert not traj.complete and "adaptive step underflow" in traj.message
    assert "PD stiffness on joint" in traj.message and "above 3.3" in traj.message


@pytest.mark.parametrize(
    "change, words",
    [
        ({"initial": {"base_position": [0.0, 0.0, 0.05]}}, "starts 0.05 m inside the ground"),
        ({"points": [{"frame": "ball", "radius": 1000.0}]}, "starts 999 m inside the ground"),
    ],
)
def test_a_contact_point_that_starts_inside_the_ground_is_refused(change, words):
    """A ball 5 cm into the ground got 125 J from its spring and was shot 13 m up, exit 0; with a
    1000 m radius the failure blamed the integrator's step. Both are refused at the start,
    naming the point, its depth, the energy and the keys to change."""
    scene = od.load_scene("ball_drop")
    settings = thaw(scene.settings)
    if "points" in change:
        settings["effects"]["contact"]["points"] = change["points"]
    else:
        settings["initial"].update(change["initial"])
    moved = od.scene_from_dict(settings, source=scene.source, base_dir=shipped_robots_dir())
    with pytest.raises(od.SceneError) as refused:
        od.simulate(moved)
    message = str(refused.value)
    assert words in message and "contact point 'ball'" in message
    assert "initial.base_position" in message and "effects.contact.ground_height" in message
    if "initial" in change:
        assert "hold 125 J" in message
    # resting in the ground as deep as its weight presses it is a start, not a mistake
    box = od.load_scene("box_slide")
    assert od.simulate(box.replace_run(duration=0.01)).complete


def box_on_table(stiffness=1e5, **box):
    """The shipped box_on_table scene's settings, the box's and the contact's changed."""
    data = thaw(od.load_scene("box_on_table").settings)
    data["objects"][0].update(box)
    data["effects"]["contact"]["stiffness"] = stiffness
    return data


def test_a_light_box_deep_in_a_table_is_refused_whatever_weighs_elsewhere():
    """The start check weighed the whole scene: a 1000 kg ball elsewhere (in the air, touching
    nothing) let a 0.1 kg box start 5 cm inside the table, 500 J in its four corners' springs,
    which threw it metres up. A pair is weighed by the bodies resting on it."""
    data = box_on_table(mass=0.1, position=[0.0, 0.0, 0.40])
    data["objects"].append({"name": "anvil", "shape": "sphere", "size": [0.5], "mass": 1000.0,
                            "position": [3.0, 0.0, 2.0]})
    with pytest.raises(od.SceneError) as refused:
        preflight.check_start(od.scene_from_dict(data))
    message = str(refused.value)
    assert "'box' starts 0.05 m inside 'table'" in message and "would hold 500 J" in message
    assert "initial.q or initial.base_position" in message and "m g / k" in message


def test_a_shallow_start_that_holds_joules_in_a_stiff_contact_is_refused():
    """A box 0.9 mm into a table of k = 1e7 N/m holds 16 J in its springs, which the 1 mm depth
    the check allowed let through (DOPRI5 threw it 1.3 m); the ball of ball_drop 0.9 mm into
    such ground, 4 J. The stored energy is bounded instead, by the weight and the size."""
    box = box_on_table(stiffness=1e7, position=[0.0, 0.0, 0.45 - 0.0009])
    with pytest.raises(od.SceneError, match=r"'box' starts 0.0009 m inside 'table'.*hold 16.2 J"):
        preflight.check_start(od.scene_from_dict(box))
    ball = thaw(od.load_scene("ball_drop").settings)
    ball["effects"]["contact"]["stiffness"] = 1e7
    ball["initial"]["base_position"] = [0.0, 0.0, 0.1 - 0.0009]
    with pytest.raises(od.SceneError, match=r"contact point 'ball' starts 0.0009 m .*hold 4.05 J"):
        preflight.check_start(od.scene_from_dict(ball, base_dir=shipped_robots_dir()))


def test_resting_starts_are_accepted_however_heavy_what_rests_on_the_pair():
    """Every shipped scene with contact starts; a box resting at its own depth in a 1e7 N/m
    table starts; and so does a stack of ten 1 kg boxes, each at the depth the boxes above
    press it to (the bottom pair carries 10 kg: its bound is their weight's, not one box's)."""
    for name, path in shipped_scenes().items():
        if "[effects.contact]" in path.read_text():
            preflight.check_start(od.load_scene(name))
    k, weight = 1e7, 9.81
    preflight.check_start(
        od.scene_from_dict(box_on_table(k, position=[0.0, 0.0, 0.45 - weight / (4 * k)]))
    )
    k, n, z = 1e5, 10, 0.05
    boxes = []
    for i in range(n):
        z -= (n - i) * weight / (4 * k)  # the corners of box i under the n - i boxes from it up
        boxes.append({"name": f"box{i}", "shape": "box", "size": [0.2, 0.2, 0.1], "mass": 1.0,
                      "position": [0.0, 0.0, z]})
        z += 0.1
    stack = {"objects": boxes, "effects": {"gravity": True, "contact": {
        "geometry": "collision", "stiffness": k, "damping": 300.0, "friction": 0.5}}}
    preflight.check_start(od.scene_from_dict(stack))


# a child process that lowers its own address-space limit (ulimit -v) to what it uses now
# plus LIMIT_ROOM bytes, then runs `body`
LIMIT_ROOM = 2e9
_UNDER_A_LIMIT = """
import resource
from opendyn._runtime.memory import _process_status, _system
if _system()[0] < 2 * {room}:
    print("SKIP: too little memory available to set a limit under it")
    raise SystemExit(0)
used = _process_status()["VmSize"]
resource.setrlimit(resource.RLIMIT_AS, (int(used + {room}), resource.RLIM_INFINITY))
"""


def _under_a_limit(body):
    code = _UNDER_A_LIMIT.format(room=LIMIT_ROOM) + body
    proc = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=300
    )
    assert proc.returncode == 0, proc.stderr
    if proc.stdout.startswith("SKIP"):
        pytest.skip(proc.stdout)
    return proc.stdout


@pytest.mark.skipif(sys.platform != "linux", reason="reads /proc")
def test_the_memory_room_is_the_smallest_of_what_the_system_and_the_limits_allow():
    out = _under_a_limit(
        "from opendyn._runtime.memory import available_memory\n"
        "room, what = available_memory()\n"
        "print(room, what, sep='|')\n"
    )
    room, what = out.strip().split("|")
    assert what == "the address-space limit (ulimit -v)"
    assert 0.9 * LIMIT_ROOM < float(room) <= LIMIT_ROOM


@pytest.mark.skipif(sys.platform != "linux", reason="reads /proc")
def test_a_record_beyond_the_address_space_limit_is_refused_before_the_run():
    """1e7 samples of 11 numbers, three times over, 2.64 GB: under the system's available memory
    (the child checks that) but beyond a 2 GB ulimit -v, which the preflight now counts."""
    out = _under_a_limit(
        "import opendyn as od\n"
        "scene = od.scene_from_dict({'robot': {'name': 'double_pendulum'},\n"
        "    'effects': {'gravity': True},\n"
        "    'run': {'duration': 1000.0, 'dt': 1e-4, 'output_dt': 1e-4}})\n"
        "try:\n"
        "    od.simulate(scene)\n"
        "except od.SceneError as e:\n"
        "    print(e)\n"
    )
    assert "the record would hold 1e+07 samples of 11 numbers, about 2.64 GB" in out
    assert "that the address-space limit (ulimit -v) leaves this process" in out


def test_out_of_memory_after_the_run_keeps_the_states_and_says_so(monkeypatch):
    record_module = importlib.import_module("opendyn.sim.record")
    run = scene(run={"duration": 0.5, "dt": 1e-3, "output_dt": 1e-3})
    whole = od.simulate(run)

    energies_of = record_module.energies_of

    def out_of_memory(scene, table, q, qd):
        # the run's 501 samples do not fit; one state (the record's kernels loaded before the
        # run, opendyn.sim.driver.load_kernels) does
        if len(q) > 1:
            raise MemoryError("Unable to allocate 2.1 GiB")
        return energies_of(scene, table, q, qd)

    monkeypatch.setattr(record_module, "energies_of", out_of_memory)
    with pytest.warns(RuntimeWarning, match=r"out of memory computing the record of 501 samples"):
        kept = od.simulate(run)
    assert kept.complete
    for name in ("t", "q", "qd", "tau", "work_applied", "work_passive"):
        np.testing.assert_array_equal(getattr(kept, name), getattr(whole, name), err_msg=name)
    assert kept.kinetic.shape == (501,) and np.isnan(kept.kinetic).all()
    assert np.isnan(kept.energy_error).all()


def test_a_spin_too_fast_for_the_step_is_named_not_the_initial_forces():
    """The T-handle spun at 5000 rad/s about its unstable axis, no force acting: RK4 at 1 ms
    turns it 5 rad a step. The cause is the rotation's speed (with the step to use), not the
    forces at the initial state, of which there are none."""
    settings = thaw(od.load_scene("t_handle_flip").settings)
    settings["initial"]["base_angular_velocity"] = [300.0, 5000.0, 300.0]
    settings["run"].update(duration=0.1)
    spin = od.scene_from_dict(settings, base_dir=shipped_robots_dir())
    traj = od.simulate(spin, raise_on_failure=False)
    assert not traj.complete
    assert "the rotation is too fast for the step: 'base_wy' turns at" in traj.message
    assert "rad per step of 0.001 s" in traj.message and "use a step below" in traj.message
    assert "forces at the initial state" not in traj.message


def test_a_mass_matrix_singular_for_its_range_of_masses_says_so_not_that_nothing_moves():
    """A 1e30 kg payload on the UR5's tool: every joint moves mass, but M's diagonal spans 32
    orders of magnitude, beyond float64's 16."""
    heavy = od.load_urdf("ur5").with_payload("tool0", 1e30)
    with pytest.raises(od.SingularMassMatrixError) as info:
        od.forward_dynamics(heavy, np.full(6, 0.3), np.zeros(6), np.zeros(6))
    message = str(info.value)
    assert "span more digits than float64 keeps (16)" in message
    assert "the heaviest body: 'wrist_3_link', 1e+30 kg" in message
    assert "nothing with mass" not in message
    assert info.value.joints == ["wrist_3_joint"]


@pytest.mark.parametrize(
    "tolerances, words",
    [
        ({"atol": 1e-14}, "the tolerances (run.rtol = 1e-06, run.atol = 1e-14) are tighter than"),
        ({}, "contact switching on is a kink in the forces: loosen run.rtol = 1e-06"),
    ],
    ids=["tight atol", "default tolerances"],
)
def test_an_adaptive_step_underflow_at_a_touchdown_names_the_tolerances(tolerances, words):
    """quadruped_drop under dopri5 with rtol = atol = 1e-14 stopped at its first touchdown
    (t = 0.247 s, step 76) with a step underflow put down to "discontinuous or singular"
    dynamics. The diagnosis of such a stop (here of ball_drop's, at its touchdown) must point
    at a tolerance too tight, or, with sensible ones, at the contact's kink."""
    from opendyn._runtime.status import Status
    from opendyn.sim import effects
    from opendyn.sim.diagnostics import failure_message

    ball = od.load_scene("ball_drop").replace_run(integrator="dopri5", **tolerances)
    message = failure_message(
        ball, effects.stage_table(ball), Status.STEP_UNDERFLOW.value, 0.45, 80, ball.q0, ball.qd0
    )
    assert message.startswith("adaptive step underflow at t = 0.45 s (step 80)")
    assert words in message


def test_a_payload_far_from_its_frame_is_named_by_its_inertia_not_only_the_heaviest_body():
    """2.5 kg a million metres out on the UR5's tool: the message named the heaviest body (the
    upper arm, 8.4 kg) as if the masses were to blame; it now also names the body with the
    largest inertia about its frame, the payload's, 2.5e12 kg m^2."""
    far = od.load_urdf("ur5").with_payload("tool0", 2.5, com=(0.0, 0.0, 1e6))
    with pytest.raises(od.SingularMassMatrixError) as info:
        od.forward_dynamics(far, np.full(6, 0.3), np.zeros(6), np.zeros(6))
    assert "the largest inertia about its frame: 'wrist_3_link', 2.5e+12 kg m^2" in str(
        info.value
    )
