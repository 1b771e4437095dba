"""Scene files: every rejected input raises SceneError naming the file, the dotted key and the
valid choices; accepted scenes give the arrays the file asks for; the shipped scenes load with
the effects they name; default_scene, Scene.without and Scene.replace_run.

Bad scenes are written to pytest's tmp_path. Most name the shipped double pendulum
(joints shoulder, elbow; frames base, link1, link2, tip; <dynamics> damping 0.1, 0.05 and
friction 0.05, 0.02; limits +-3.14; effort limits 50, 20).
"""

from __future__ import annotations

import math
import os

import numpy as np
import pytest

import opendyn as od
from opendyn.errors import SceneError
from opendyn.io.scene.files import (
    DEFAULT_SCENE,
    default_scene,
    load_scene,
    scene_from_dict,
    shipped_scenes,
)
from opendyn.sim.effects import registry
from opendyn.sim.run import Run, integrator_names
from opendyn.io.urdf import shipped_robots_dir

PENDULUM = '[robot]\nname = "double_pendulum"\n'


def write(tmp_path, text, name="scene.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def compose(robot, body) -> str:
    """A scene's text: body's top-level keys (its lines before the first table header) go
    before the [robot] table, so that TOML keeps them at the top level."""
    lines = body.splitlines(keepends=True)
    first = next((i for i, line in enumerate(lines) if line.startswith("[")), len(lines))
    return "".join(lines[:first]) + robot + "".join(lines[first:])


def load(tmp_path, body, robot=PENDULUM):
    return load_scene(write(tmp_path, compose(robot, body)))


def rejected(tmp_path, body, robot=PENDULUM, *fragments) -> str:
    """The SceneError message of a bad scene; it names the file and every fragment."""
    path = write(tmp_path, compose(robot, body))
    with pytest.raises(SceneError) as info:
        load_scene(path)
    message = str(info.value)
    assert str(path) in message
    for fragment in fragments:
        assert fragment in message, f"{fragment!r} not in {message!r}"
    return message


# A robot with two continuous joints: no position limits, no effort limits, no <dynamics>.
FREE_URDF = """<?xml version="1.0"?>
<robot name="free">
  <link name="base"/>
  <joint name="a" type="continuous">
    <parent link="base"/><child link="l1"/><axis xyz="0 0 1"/>
  </joint>
  <link name="l1"><inertial><mass value="1"/>
    <inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial></link>
  <joint name="b" type="continuous">
    <parent link="l1"/><child link="l2"/><origin xyz="1 0 0"/><axis xyz="0 0 1"/>
  </joint>
  <link name="l2"><inertial><mass value="1"/>
    <inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial></link>
</robot>
"""

# The same with joint b revolute, limited to +-1 rad.
HALF_LIMITED_URDF = FREE_URDF.replace(
    '<joint name="b" type="continuous">',
    '<joint name="b" type="revolute"><limit lower="-1" upper="1" effort="5" velocity="1"/>',
)


def free_robot(tmp_path, text=FREE_URDF):
    (tmp_path / "free.urdf").write_text(text)
    return '[robot]\nurdf = "free.urdf"\n'


# --- accepted scenes ---------------------------------------------------------------------------


def test_a_minimal_scene_has_default_run_settings_and_no_effects(tmp_path):
    scene = load(tmp_path, "")
    assert scene.effects == ()
    assert scene.run == Run(5.0, "rk4", 1e-3, 1e-6, 1e-9, 0.01, 1e4)
    assert scene.name == "scene"  # the file stem
    np.testing.assert_array_equal(scene.q0, [0.0, 0.0])
    np.testing.assert_array_equal(scene.qd0, [0.0, 0.0])
    assert scene.gravity is None and scene.control is None and scene.wrenches == ()
    assert scene.source == str(tmp_path / "scene.toml")


def test_a_joint_table_sets_the_named_joint_and_zeros_elsewhere(tmp_path):
    scene = load(
        tmp_path,
        "[initial]\nq = { elbow = 0.7 }\nqd = [0.25, -1]\n"
        "[effects.damping]\ncoefficients = { shoulder = 0.3 }\n",
    )
    np.testing.assert_array_equal(scene.q0, [0.0, 0.7])
    np.testing.assert_array_equal(scene.qd0, [0.25, -1.0])
    np.testing.assert_array_equal(scene.damping, [0.3, 0.0])
    assert scene.q0.dtype == np.float64 and not scene.q0.flags.writeable


def test_a_number_applies_to_every_joint_and_urdf_reads_dynamics(tmp_path):
    scene = load(
        tmp_path,
        "[effects.damping]\ncoefficients = 2\n"
        '[effects.friction]\ncoefficients = "urdf"\nsmoothing = 0.5\n'
        "[effects.armature]\nvalues = [0.1, 0.2]\n",
    )
    np.testing.assert_array_equal(scene.damping, [2.0, 2.0])
    np.testing.assert_array_equal(scene.friction.coulomb, [0.05, 0.02])
    assert scene.friction.smoothing == 0.5
    np.testing.assert_array_equal(scene.armature, [0.1, 0.2])
    assert scene.effects == ("damping", "friction", "armature")


def test_damping_coefficients_default_to_the_urdf(tmp_path):
    scene = load(tmp_path, "[effects.damping]\n[effects.friction]\n")
    np.testing.assert_array_equal(scene.damping, [0.1, 0.05])
    np.testing.assert_array_equal(scene.friction.coulomb, [0.05, 0.02])
    assert scene.friction.smoothing == 0.01


def test_gravity_true_is_the_models_and_a_vector_is_taken_as_written(tmp_path):
    on = load(tmp_path, "[effects]\ngravity = true\n")
    np.testing.assert_array_equal(on.gravity, [0.0, 0.0, -9.81])
    vector = load(tmp_path, "[effects]\ngravity = [1, 0, -3.5]\n")
    np.testing.assert_array_equal(vector.gravity, [1.0, 0.0, -3.5])
    off = load(tmp_path, "[effects]\ngravity = false\n")
    assert off.gravity is None and off.effects == ()


def test_limit_springs_act_only_on_joints_with_finite_limits(tmp_path):
    robot = free_robot(tmp_path, HALF_LIMITED_URDF)
    scene = load(tmp_path, "[effects.limits]\nstiffness = 1e4\ndamping = 3\n", robot)
    np.testing.assert_array_equal(scene.limits.stiffness, [0.0, 1e4])
    np.testing.assert_array_equal(scene.limits.damping, [0.0, 3.0])
    np.testing.assert_array_equal(scene.limits.lower, [-np.inf, -1.0])
    np.testing.assert_array_equal(scene.limits.upper, [np.inf, 1.0])


def test_limit_damping_defaults_to_zero(tmp_path):
    scene = load(tmp_path, "[effects.limits]\nstiffness = { elbow = 100 }\n")
    np.testing.assert_array_equal(scene.limits.stiffness, [0.0, 100.0])
    np.testing.assert_array_equal(scene.limits.damping, [0.0, 0.0])
    np.testing.assert_array_equal(scene.limits.lower, [-3.14, -3.14])


def test_a_constant_wrench_is_one_sample(tmp_path):
    scene = load(tmp_path, '[[effects.wrench]]\nframe = "tip"\nvalue = [0, 0, 1, 0, 0, -10]\n')
    (w,) = scene.wrenches
    assert (w.frame, w.expressed_in) == ("tip", "frame")
    np.testing.assert_array_equal(w.times, [0.0])
    np.testing.assert_array_equal(w.values, [[0, 0, 1, 0, 0, -10]])
    np.testing.assert_array_equal(w.at(123.0), [0, 0, 1, 0, 0, -10])
    assert scene.effects == ("wrench",)


def test_a_wrench_table_is_linear_between_samples_and_held_outside(tmp_path):
    scene = load(
        tmp_path,
        '[[effects.wrench]]\nframe = "elbow"\nexpressed_in = "world"\n'
        "times = [1.0, 2.0, 4.0]\n"
        "values = [[0, 0, 0, 0, 0, 0], [0, 0, 0, 10, 0, 0], [2, 0, 0, 0, 0, 0]]\n"
        '[[effects.wrench]]\nframe = "link1"\nvalue = [0, 0, 0, 0, 0, 1]\n',
    )
    w, second = scene.wrenches
    assert w.frame == "elbow" and w.expressed_in == "world" and second.frame == "link1"
    assert w.values.shape == (3, 6)
    np.testing.assert_allclose(w.at(0.0), np.zeros(6))
    np.testing.assert_allclose(w.at(1.5), [0, 0, 0, 5, 0, 0])
    np.testing.assert_allclose(w.at(3.0), [1, 0, 0, 5, 0, 0])
    np.testing.assert_allclose(w.at(10.0), [2, 0, 0, 0, 0, 0])


def test_pd_setpoint_defaults_to_the_initial_posture(tmp_path):
    scene = load(
        tmp_path,
        '[initial]\nq = [0.3, -0.2]\n[control]\ntype = "pd"\nkp = [10, 20]\nkd = { elbow = 2 }\n',
    )
    c = scene.control
    assert c.kind == "pd" and c.clip is False
    np.testing.assert_array_equal(c.kp, [10.0, 20.0])
    np.testing.assert_array_equal(c.kd, [0.0, 2.0])
    np.testing.assert_array_equal(c.setpoint, [0.3, -0.2])
    assert c.tau is None and c.offset is None and c.frequency is None


def test_computed_torque_defaults(tmp_path):
    scene = load(
        tmp_path,
        "[initial]\nq = { shoulder = 0.4 }\n"
        '[control]\ntype = "computed_torque"\nkp = 100\nkd = 20\n'
        "amplitude = { elbow = 0.1 }\nclip = true\n",
    )
    c = scene.control
    np.testing.assert_array_equal(c.offset, [0.4, 0.0])
    np.testing.assert_array_equal(c.amplitude, [0.0, 0.1])
    np.testing.assert_array_equal(c.frequency, [0.5, 0.5])
    np.testing.assert_array_equal(c.phase, [0.0, 0.0])
    assert c.clip is True and c.setpoint is None and c.tau is None


def test_constant_control_and_control_type_none(tmp_path):
    scene = load(tmp_path, '[control]\ntype = "constant"\ntau = { shoulder = -1.5 }\n')
    np.testing.assert_array_equal(scene.control.tau, [-1.5, 0.0])
    assert scene.effects == ("control",)
    assert load(tmp_path, '[control]\ntype = "none"\n').control is None


def test_output_dt_defaults_to_dt_when_dt_is_coarser(tmp_path):
    assert load(tmp_path, "[run]\ndt = 0.02\n").run.output_dt == 0.02
    assert load(tmp_path, "[run]\ndt = 0.002\n").run.output_dt == 0.01


def test_dopri5_takes_any_output_interval(tmp_path):
    run = load(tmp_path, '[run]\nintegrator = "dopri5"\ndt = 0.003\noutput_dt = 0.01\n').run
    assert (run.integrator, run.dt, run.output_dt) == ("dopri5", 0.003, 0.01)


def test_output_dt_that_is_a_multiple_up_to_rounding_is_accepted(tmp_path):
    run = load(tmp_path, "[run]\ndt = 0.001\noutput_dt = 0.03\n").run  # 0.03 / 0.001 = 29.99..
    assert run.output_dt == 0.03


def test_a_relative_urdf_is_found_from_the_scene_files_folder(tmp_path):
    (tmp_path / "urdfs").mkdir()
    (tmp_path / "scenes").mkdir()
    (tmp_path / "urdfs" / "free.urdf").write_text(FREE_URDF)
    path = write(tmp_path / "scenes", '[robot]\nurdf = "../urdfs/free.urdf"\n')
    assert load_scene(path).model.joint_names == ("a", "b")


def test_settings_are_the_file_as_read(tmp_path):
    scene = load(tmp_path, 'description = "d"\n[initial]\nq = { elbow = 1 }\n[run]\ndt = 0.002\n')
    assert scene.settings == {
        "description": "d",
        "robot": {"name": "double_pendulum"},
        "initial": {"q": {"elbow": 1}},
        "run": {"dt": 0.002},
    }


def test_scene_from_dict_accepts_numpy_arrays_and_keeps_plain_settings():
    scene = scene_from_dict(
        {
            "robot": {"name": "double_pendulum"},
            "initial": {"q": np.array([0.1, 0.2])},
            "effects": {"gravity": np.array([0.0, 0.0, -1.0])},
        }
    )
    np.testing.assert_array_equal(scene.q0, [0.1, 0.2])
    np.testing.assert_array_equal(scene.gravity, [0.0, 0.0, -1.0])
    assert scene.settings["initial"]["q"] == (0.1, 0.2)
    assert scene.source == "<dict>" and scene.name == "double_pendulum"


def test_scene_from_dict_resolves_urdf_from_base_dir(tmp_path):
    (tmp_path / "free.urdf").write_text(FREE_URDF)
    scene = scene_from_dict({"robot": {"urdf": "free.urdf"}}, source="mine", base_dir=tmp_path)
    assert scene.model.name == "free" and scene.source == "mine"


# --- rejected scenes: keys -------------------------------------------------------------------


@pytest.mark.parametrize(
    "body, key, valid",
    [
        ("nmae = 'x'\n", "nmae", "name, description, robot"),
        ("[run]\ndtt = 0.1\n", "run.dtt", "duration, integrator, dt"),
        ("[initial]\nqdd = [0, 0]\n", "initial.qdd", "q, qd"),
        ("[effects]\ngravty = true\n", "effects.gravty", "gravity, damping, friction"),
        ("[effects.damping]\ncoefficient = 1\n", "effects.damping.coefficient", "coefficients"),
        ("[effects.friction]\nsmooth = 1\n", "effects.friction.smooth", "smoothing"),
        ("[effects.armature]\nvalue = 1\n", "effects.armature.value", "values"),
        ("[effects.limits]\nstiffness = 1\nk = 1\n", "effects.limits.k", "stiffness, damping"),
        (
            "[[effects.wrench]]\nframe = 'tip'\nvalue = [0,0,0,0,0,0]\nframes = 1\n",
            "effects.wrench[0].frames",
            "frame, expressed_in, value, times, values",
        ),
        ("[control]\ntype = 'pd'\nkp = 1\nkd = 1\ngain = 1\n", "control.gain", "kp, kd, setpoint"),
    ],
)
def test_an_unknown_key_is_named_with_the_valid_keys(tmp_path, body, key, valid):
    rejected(tmp_path, body, PENDULUM, f": {key}: unknown key", valid)


def test_an_unknown_robot_key_is_named(tmp_path):
    rejected(tmp_path, "", PENDULUM + "mimc = true\n", "robot.mimc", "did you mean 'mimic'")


def test_an_unknown_key_gets_a_close_match_suggestion(tmp_path):
    rejected(tmp_path, "[run]\nduraton = 1\n", PENDULUM, "did you mean 'duration'")


def test_a_control_key_of_another_control_type_is_named(tmp_path):
    rejected(
        tmp_path,
        "[control]\ntype = 'pd'\nkp = 1\nkd = 1\ntau = 3\n",
        PENDULUM,
        "control.tau",
        "not a setting of control type 'pd'",
        "'constant'",
    )


def test_a_section_that_is_not_a_table_is_rejected(tmp_path):
    rejected(tmp_path, "run = 5\n", PENDULUM, "run: expected a table", "5 (an integer)")


# --- rejected scenes: values ------------------------------------------------------------------


@pytest.mark.parametrize(
    "body, key, found",
    [
        ('[run]\ndt = "0.001"\n', "run.dt", "'0.001' (a string)"),
        ("[run]\nduration = true\n", "run.duration", "True (a boolean)"),
        ("[run]\ndt = nan\n", "run.dt", "finite"),
        ("[run]\nmax_speed = inf\n", "run.max_speed", "finite"),
        ("[run]\nduration = -1\n", "run.duration", "> 0"),
        ("[run]\nrtol = 0\n", "run.rtol", "> 0"),
        ("[initial]\nq = [1, 2, 3]\n", "initial.q", "list of 3"),
        ("[initial]\nq = 1.0\n", "initial.q", "1.0 (a float)"),
        ("[initial]\nqd = { elbow = 'fast' }\n", "initial.qd.elbow", "'fast' (a string)"),
        ("[effects]\ngravity = [0, -9.81]\n", "effects.gravity", "list of 2"),
        ("[effects]\ngravity = 'down'\n", "effects.gravity", "'down' (a string)"),
        ("[effects.damping]\ncoefficients = -0.1\n", "effects.damping.coefficients", ">= 0"),
        (
            "[effects.damping]\ncoefficients = [0.1, -2]\n",
            "effects.damping.coefficients[1]",
            ">= 0",
        ),
        ("[effects.damping]\ncoefficients = true\n", "effects.damping.coefficients", "boolean"),
        ("[effects.damping]\ncoefficients = 'URDF'\n", "effects.damping.coefficients", "'URDF'"),
        ("[effects.friction]\nsmoothing = 0\n", "effects.friction.smoothing", "> 0"),
        ("[effects.armature]\nvalues = [0.1, nan]\n", "effects.armature.values[1]", "finite"),
        ("[effects.limits]\nstiffness = -1e4\n", "effects.limits.stiffness", ">= 0"),
        (
            "[effects.limits]\nstiffness = 1e4\ndamping = { elbow = -3 }\n",
            "effects.limits.damping.elbow",
            ">= 0",
        ),
        ("[control]\ntype = 'pd'\nkp = -1\nkd = 1\n", "control.kp", ">= 0"),
        ("[control]\ntype = 'pd'\nkp = 1\nkd = 1\nclip = 1\n", "control.clip", "true or false"),
        ("[control]\ntype = 'constant'\ntau = [1]\n", "control.tau", "list of 1"),
        (
            "[control]\ntype = 'computed_torque'\nkp = 1\nkd = 1\nfrequency = -0.5\n",
            "control.frequency",
            ">= 0",
        ),
        ("[control]\ntype = 3\n", "control.type", "3 (an integer)"),
        ("name = 5\n", "name", "5 (an integer)"),
    ],
)
def test_a_wrong_value_is_named_with_what_was_expected_and_found(tmp_path, body, key, found):
    message = rejected(tmp_path, body, PENDULUM, f": {key}: ", found)
    assert "expected" in message


def test_a_wrong_list_length_says_how_many_per_joint(tmp_path):
    rejected(
        tmp_path,
        "[effects.armature]\nvalues = [1, 2, 3]\n",
        PENDULUM,
        "effects.armature.values",
        "list of 2 numbers (one per joint: shoulder, elbow)",
        "found a list of 3",
    )


@pytest.mark.parametrize(
    "body, key",
    [
        ("[initial]\nq = { knee = 1 }\n", "initial.q.knee"),
        ("[effects.damping]\ncoefficients = { sholder = 1 }\n", "effects.damping.coefficients"),
        ("[effects.limits]\nstiffness = { wrist = 1 }\n", "effects.limits.stiffness.wrist"),
        ("[control]\ntype = 'pd'\nkp = { hip = 1 }\nkd = 0\n", "control.kp.hip"),
    ],
)
def test_an_unknown_joint_is_named_with_the_joints(tmp_path, body, key):
    rejected(tmp_path, body, PENDULUM, key, "not a joint of 'double_pendulum'", "shoulder, elbow")


def test_an_unknown_frame_is_named_with_the_frames(tmp_path):
    rejected(
        tmp_path,
        '[[effects.wrench]]\nframe = "tipp"\nvalue = [0, 0, 0, 0, 0, 1]\n',
        PENDULUM,
        "effects.wrench[0].frame",
        "'tipp' is not a frame",
        "base, link1, link2, tip",
        "did you mean 'tip'",
    )


@pytest.mark.parametrize(
    "body, key, choices",
    [
        ('[run]\nintegrator = "rk45"\n', "run.integrator", ", ".join(integrator_names())),
        ('[control]\ntype = "PID"\n', "control.type", "none, constant, pd, computed_torque"),
        (
            '[[effects.wrench]]\nframe = "tip"\nexpressed_in = "body"\nvalue = [0,0,0,0,0,0]\n',
            "effects.wrench[0].expressed_in",
            "frame, world",
        ),
    ],
)
def test_an_unknown_choice_is_named_with_the_choices(tmp_path, body, key, choices):
    rejected(tmp_path, body, PENDULUM, key, choices)


def test_output_dt_must_be_a_whole_multiple_of_a_fixed_step(tmp_path):
    rejected(
        tmp_path,
        "[run]\ndt = 0.003\noutput_dt = 0.01\n",
        PENDULUM,
        "run.output_dt",
        "not a whole multiple of run.dt",
    )
    rejected(tmp_path, "[run]\ndt = 0.01\noutput_dt = 0.005\n", PENDULUM, "run.output_dt")


def test_a_step_longer_than_the_run_is_rejected(tmp_path):
    rejected(tmp_path, "[run]\nduration = 0.5\ndt = 1.0\n", PENDULUM, "run.dt", "run.duration")


@pytest.mark.parametrize(
    "body, key, what",
    [
        (
            '[[effects.wrench]]\nframe = "tip"\ntimes = [0, 1, 1]\nvalues = [[0,0,0,0,0,0]]\n',
            "effects.wrench[0].times[2]",
            "strictly increasing",
        ),
        (
            '[[effects.wrench]]\nframe = "tip"\ntimes = [0, 1]\nvalues = [[0,0,0,0,0,0]]\n',
            "effects.wrench[0].values",
            "one wrench [m, f] of 6 numbers per time (2 times), found a list of 1",
        ),
        (
            '[[effects.wrench]]\nframe = "tip"\ntimes = [0]\nvalues = [[0,0,0,0,1]]\n',
            "effects.wrench[0].values[0]",
            "list of 6",
        ),
        (
            '[[effects.wrench]]\nframe = "tip"\nvalue = [0,0,0,0,0,1]\ntimes = [0]\n',
            "effects.wrench[0]",
            "both value and times/values",
        ),
        ('[[effects.wrench]]\nframe = "tip"\n', "effects.wrench[0]", "no wrench given"),
        ("[[effects.wrench]]\nvalue = [0,0,0,0,0,1]\n", "effects.wrench[0].frame", "missing"),
        ('[[effects.wrench]]\nframe = "tip"\ntimes = [0]\n', "effects.wrench[0].values", "missing"),
        ("[effects]\nwrench = 3\n", "effects.wrench", "[[effects.wrench]]"),
    ],
)
def test_a_malformed_wrench_is_named(tmp_path, body, key, what):
    rejected(tmp_path, body, PENDULUM, f"{key}: ", what)


@pytest.mark.parametrize(
    "body, key",
    [
        ("[effects.armature]\n", "effects.armature.values"),
        ("[effects.limits]\ndamping = 1\n", "effects.limits.stiffness"),
        ("[control]\ntype = 'pd'\nkd = 1\n", "control.kp"),
        ("[control]\ntype = 'computed_torque'\nkp = 1\n", "control.kd"),
        ("[control]\ntype = 'constant'\n", "control.tau"),
    ],
)
def test_a_missing_required_value_is_named(tmp_path, body, key):
    rejected(tmp_path, body, PENDULUM, key, "missing")


# --- rejected scenes: robot and model-dependent rules ------------------------------------------


def test_a_scene_without_a_robot_is_rejected(tmp_path):
    rejected(tmp_path, "[run]\ndt = 0.001\n", "", ": robot: missing")


def test_both_urdf_and_name_are_rejected(tmp_path):
    robot = '[robot]\nname = "double_pendulum"\nurdf = "double_pendulum.urdf"\n'
    rejected(tmp_path, "", robot, ": robot: both of robot.urdf and robot.name")


def test_neither_urdf_nor_name_is_rejected(tmp_path):
    rejected(
        tmp_path, "", "[robot]\nmimic = true\n", ": robot: neither of robot.urdf and robot.name"
    )


def test_a_missing_urdf_file_is_named(tmp_path):
    message = rejected(tmp_path, "", '[robot]\nurdf = "nowhere.urdf"\n', "robot.urdf", "no such")
    assert "nowhere.urdf" in message


def test_an_unknown_robot_name_passes_the_loaders_message_on(tmp_path):
    rejected(
        tmp_path,
        "",
        '[robot]\nname = "double_pendulm"\n',
        "robot.name",
        "known robot name",
        "double_pendulum",
    )


def test_a_bad_urdf_passes_the_loaders_message_on_with_the_scene_named(tmp_path):
    (tmp_path / "bad.urdf").write_text("<robot name='x'><link name='a'>")
    rejected(
        tmp_path, "", '[robot]\nurdf = "bad.urdf"\n', "robot.urdf", "bad.urdf", "malformed XML"
    )


def test_robot_options_are_checked_and_passed_on(tmp_path):
    rejected(tmp_path, "", PENDULUM + 'check_inertia = "no"\n', "robot.check_inertia")
    bad_inertia = FREE_URDF.replace(
        'ixx="0.1" ixy="0" ixz="0" iyy="0.1"', 'ixx="5" ixy="0" ixz="0" iyy="0.1"', 1
    )
    robot = free_robot(tmp_path, bad_inertia)
    rejected(tmp_path, "", robot, "robot.urdf", "free.urdf")
    scene = load(tmp_path, "", robot + "check_inertia = false\n")
    assert scene.model.nv == 2


@pytest.mark.parametrize("effect", ["damping", "friction"])
def test_urdf_coefficients_when_the_urdf_gives_none_are_rejected(tmp_path, effect):
    robot = free_robot(tmp_path)
    rejected(
        tmp_path,
        f'[effects.{effect}]\ncoefficients = "urdf"\n',
        robot,
        f"effects.{effect}.coefficients",
        f"<dynamics {effect}>",
        "gives none",
        "give the coefficients",
    )


def test_limits_on_a_robot_without_finite_limits_are_rejected(tmp_path):
    rejected(
        tmp_path,
        "[effects.limits]\nstiffness = 1e4\n",
        free_robot(tmp_path),
        "effects.limits: ",
        "no joint of 'free' has a finite position limit",
    )


def test_a_limit_spring_on_an_unlimited_joint_is_rejected(tmp_path):
    robot = free_robot(tmp_path, HALF_LIMITED_URDF)
    rejected(
        tmp_path,
        "[effects.limits]\nstiffness = { a = 1e4 }\n",
        robot,
        "effects.limits.stiffness.a",
        "no finite position limit",
        "limited joints: b",
    )
    rejected(tmp_path, "[effects.limits]\nstiffness = [5, 5]\n", robot, "stiffness[0]")


def test_clipping_without_finite_effort_limits_is_rejected(tmp_path):
    rejected(
        tmp_path,
        "[control]\ntype = 'constant'\ntau = 1\nclip = true\n",
        free_robot(tmp_path),
        "control.clip",
        "no joint of 'free' has a finite effort limit",
    )


def test_malformed_toml_names_the_file_and_the_line(tmp_path):
    rejected(tmp_path, "[run]\nduration = 1\ndt = = 2\n", PENDULUM, "malformed TOML", "line 5")


def test_a_missing_scene_file_lists_the_shipped_scenes(tmp_path):
    with pytest.raises(SceneError, match="no such scene file.*double_pendulum_swing"):
        load_scene(tmp_path / "none.toml")


def test_scene_from_dict_errors_name_the_source():
    with pytest.raises(SceneError, match=r"^mine: run\.dt: expected a number > 0"):
        scene_from_dict({"robot": {"name": "double_pendulum"}, "run": {"dt": 0}}, source="mine")


# --- shipped scenes ---------------------------------------------------------------------------

SHIPPED = (
    "double_pendulum_swing",
    "planar_3r_limits",
    "ur5_falling",
    "panda_computed_torque",
    "double_pendulum_push",
    "t_handle_flip",
    "solo12_falling",
    "g1_floating",
)


def test_the_shipped_scenes_are_listed_by_name():
    scenes = shipped_scenes()
    assert set(SHIPPED) <= set(scenes)
    assert DEFAULT_SCENE in scenes
    for name, path in scenes.items():
        assert path.parent == shipped_robots_dir() and path.stem == name


def test_every_shipped_scene_loads():
    for name, path in shipped_scenes().items():
        scene = load_scene(path)
        assert scene.source == str(path)
        assert scene.settings["name"] == scene.name


def test_a_shipped_scene_loads_by_name():
    scene = load_scene("double_pendulum_swing")
    assert scene.source == str(shipped_scenes()["double_pendulum_swing"])


def test_the_default_scene_is_the_conservative_double_pendulum():
    scene = load_scene(DEFAULT_SCENE)
    assert scene.model.name == "double_pendulum"
    assert scene.effects == ("gravity",)  # nothing dissipates or supplies energy
    np.testing.assert_array_equal(scene.gravity, [0.0, 0.0, -9.81])
    np.testing.assert_array_equal(scene.q0, [2.0, 0.5])
    np.testing.assert_array_equal(scene.qd0, [0.0, 0.0])
    assert scene.run == Run(10.0, "rk4", 1e-3, 1e-6, 1e-9, 0.01, 1e4)


def test_the_planar_3r_scene_pushes_joints_into_stiff_limits():
    scene = load_scene("planar_3r_limits")
    model = scene.model
    assert scene.effects == ("limits", "control")
    assert (scene.run.integrator, scene.run.dt) == ("implicit_euler", 0.005)
    np.testing.assert_array_equal(scene.limits.stiffness, [1e5, 1e5, 1e5])
    np.testing.assert_array_equal(scene.limits.damping, [50.0, 50.0, 50.0])
    np.testing.assert_array_equal(scene.limits.lower, model.lower)
    np.testing.assert_array_equal(scene.limits.upper, model.upper)
    c = scene.control
    assert c.kind == "constant" and c.clip
    np.testing.assert_array_equal(c.tau, [20.0, 0.0, -2.0])
    np.testing.assert_array_equal(scene.qd0, [0.0, 1.0, 0.0])
    # the arm turns about z, so default gravity would exert no torque: it is left out
    assert np.allclose(od.gravity_forces(model, [0.3, -1.0, 2.0]), 0.0)


def test_the_double_pendulum_push_is_a_world_aligned_table_at_the_tip():
    scene = load_scene("double_pendulum_push")
    assert scene.effects == ("gravity", "damping", "wrench")
    np.testing.assert_array_equal(scene.damping, [0.1, 0.05])  # the URDF's
    (w,) = scene.wrenches
    assert (w.frame, w.expressed_in) == ("tip", "world")
    np.testing.assert_array_equal(w.at(0.0), np.zeros(6))
    np.testing.assert_allclose(w.at(1.2), [0, 0, 0, 20, 0, 0])
    np.testing.assert_allclose(w.at(1.05), [0, 0, 0, 10, 0, 0])
    np.testing.assert_array_equal(w.at(9.0), np.zeros(6))


def test_the_ur5_scene_falls_with_damping_written_per_joint():
    scene = load_scene("ur5_falling")
    assert scene.model.nv == 6
    assert not scene.model.damping.any()  # the URDF has no <dynamics>, hence explicit values
    assert scene.effects == ("gravity", "damping")
    np.testing.assert_array_equal(scene.damping, np.full(6, 0.5))
    assert (scene.run.integrator, scene.run.dt, scene.run.duration) == ("rk4", 0.001, 5.0)
    q0 = dict(zip(scene.model.joint_names, scene.q0))
    assert q0["shoulder_lift_joint"] == -0.3 and q0["shoulder_pan_joint"] == 0.0


def test_urdf_damping_on_the_ur5_is_rejected(tmp_path):
    rejected(
        tmp_path,
        "[effects.damping]\n",
        '[robot]\nname = "ur5"\n',
        "effects.damping.coefficients",
        "ur5_robot.urdf gives none",
    )


def test_the_panda_scene_tracks_sinusoids_inside_the_joint_limits():
    scene = load_scene("panda_computed_torque")
    model = scene.model
    assert scene.effects == ("gravity", "damping", "friction", "control")
    c = scene.control
    assert c.kind == "computed_torque" and c.clip
    np.testing.assert_array_equal(c.offset, scene.q0)
    reach = np.abs(c.amplitude)
    assert np.all(c.offset - reach >= model.lower) and np.all(c.offset + reach <= model.upper)
    arm = [name.startswith("panda_joint") for name in model.joint_names]
    assert np.all((c.frequency[arm] >= 0.2) & (c.frequency[arm] <= 0.5))
    assert np.all(c.amplitude[arm] > 0)
    friction = dict(zip(model.joint_names, scene.friction.coulomb))
    assert friction["panda_joint1"] == 0.5 and friction["panda_finger_joint1"] == 0.0
    np.testing.assert_array_equal(scene.damping, np.full(9, 0.1))
    assert np.isfinite(model.effort_limit).all()


# --- default_scene, without, replace_run -------------------------------------------------------


def test_default_scene_has_gravity_only_and_rest_state():
    scene = default_scene("double_pendulum")
    assert scene.effects == ("gravity",)
    np.testing.assert_array_equal(scene.gravity, scene.model.gravity)
    np.testing.assert_array_equal(scene.q0, [0.0, 0.0])
    np.testing.assert_array_equal(scene.qd0, [0.0, 0.0])
    assert scene.run == Run()
    assert scene.source == "<robot double_pendulum>"


def test_default_scene_takes_a_model_or_a_path_and_run_settings():
    model = od.load_urdf("planar_3r")
    scene = default_scene(model, duration=2.0, integrator="semi_implicit_euler", dt=0.02)
    assert scene.model is model
    assert scene.run == Run(2.0, "semi_implicit_euler", 0.02, 1e-6, 1e-9, 0.02, 1e4)
    from_path = default_scene(shipped_robots_dir() / "planar_3r.urdf")
    assert from_path.model.joint_names == model.joint_names


def test_default_scene_validates_run_settings():
    with pytest.raises(SceneError, match="run.integrator.*'rk5'.*rk4"):
        default_scene("double_pendulum", integrator="rk5")
    with pytest.raises(SceneError, match="run.step: unknown key"):
        default_scene("double_pendulum", step=0.1)
    with pytest.raises(SceneError, match="<robot nobody>: robot"):
        default_scene("nobody")


def test_without_switches_effects_off_and_keeps_the_rest(tmp_path):
    scene = load_scene("panda_computed_torque")
    lean = scene.without("friction", "control")
    assert lean.effects == ("gravity", "damping")
    assert lean.model is scene.model and lean.run == scene.run
    np.testing.assert_array_equal(lean.q0, scene.q0)
    assert "friction" not in lean.settings["effects"] and "control" not in lean.settings
    assert "friction" in scene.settings["effects"]  # the original is untouched
    assert scene.effects == ("gravity", "damping", "friction", "control")
    assert load_scene("double_pendulum_push").without(*registry.names()).effects == ()


def test_without_an_unknown_effect_lists_the_effects():
    with pytest.raises(SceneError, match="'frictoin'.*gravity, damping, friction"):
        default_scene("double_pendulum").without("frictoin")


def test_replace_run_validates_like_the_file():
    scene = load_scene(DEFAULT_SCENE)
    coarse = scene.replace_run(dt=0.005, duration=1.0)
    assert (coarse.run.dt, coarse.run.duration, coarse.run.output_dt) == (0.005, 1.0, 0.01)
    assert coarse.settings["run"]["dt"] == 0.005 and scene.run.dt == 0.001
    with pytest.raises(SceneError, match="run.output_dt.*whole multiple"):
        scene.replace_run(dt=0.003)
    with pytest.raises(SceneError, match="run.dt: expected a number > 0"):
        scene.replace_run(dt=-1.0)
    with pytest.raises(SceneError, match="unknown run setting 'step'.*duration"):
        scene.replace_run(step=0.1)


def test_replace_run_none_restores_the_default_that_follows_dt():
    scene = default_scene("double_pendulum", dt=0.001, output_dt=0.01)
    coarse = scene.replace_run(dt=0.05, output_dt=None)
    assert coarse.run.output_dt == 0.05
    assert math.isclose(scene.replace_run(integrator="dopri5", dt=0.003).run.dt, 0.003)


@pytest.mark.parametrize(
    "section, words",
    [
        ({"effects": {"damping": {"coefficients": 1.0}}}, "effects.damping: 't_handle' has no joints"),
        ({"effects": {"friction": {"coefficients": 1.0}}}, "effects.friction: 't_handle' has no"),
        ({"effects": {"armature": {"values": 0.1}}}, "effects.armature: 't_handle' has no joints"),
        ({"effects": {"limits": {"stiffness": 1e3}}}, "effects.limits: 't_handle' has no joints"),
        ({"control": {"type": "pd", "kp": 1.0, "kd": 0.1}}, "a 'pd' controller of the joints"),
        ({"control": {"type": "computed_torque", "kp": 1.0, "kd": 0.1}}, "'computed_torque'"),
        ({"control": {"type": "constant", "tau": 1.0}}, "a 'constant' controller of the joints"),
    ],
)
def test_a_robot_without_joints_refuses_what_acts_on_joints(section, words):
    """The free T-handle has no joints: a per-joint effect or a controller would act on nothing,
    so the scene is refused (it was accepted, listed in the run's header, and did nothing)."""
    urdf = os.path.join(os.path.dirname(__file__), "..", "robots", "t_handle.urdf")
    settings = {"robot": {"urdf": urdf, "floating_base": True}, **section}
    with pytest.raises(SceneError) as refused:
        od.scene_from_dict(settings)
    assert words in str(refused.value) and "would act on nothing" in str(refused.value)
    od.scene_from_dict({"robot": settings["robot"], "effects": {"gravity": True}})  # the rest runs


@pytest.mark.parametrize(
    "section, key",
    [
        ({"run": {"duration": 10**400}}, "run.duration"),
        ({"run": {"dt": -(10**400)}}, "run.dt"),
        ({"initial": {"q": {"shoulder_pan_joint": 10**400}}}, "initial.q.shoulder_pan_joint"),
        ({"effects": {"damping": {"coefficients": 10**400}}}, "effects.damping.coefficients"),
    ],
)
def test_an_integer_too_large_for_a_float_is_a_scene_error(section, key):
    """A TOML integer of 400 digits was an OverflowError traceback from float()."""
    with pytest.raises(SceneError) as refused:
        od.scene_from_dict({"robot": {"name": "ur5"}, **section})
    assert f"{key}: expected a finite number, found an integer of 401 digits" in str(refused.value)
