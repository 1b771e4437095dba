"""od.rollout: run i equals simulate of the same scene with the same values, bit for bit (every
integrator, a fixed and a floating robot, contact, params, a failing run among good ones, a run
simulate refuses), on one thread or two, with record="samples" or "final"; bad arguments are
refused naming the argument; Ctrl-C keeps the runs done."""

from __future__ import annotations

import dataclasses
import re
import os
import signal
import subprocess
import sys

import numpy as np
import pytest

import opendyn as od
from opendyn.errors import RolloutInterrupted, SceneError
from opendyn.io.scene.variants import Variants

RECORDED = ("t", "q", "qd", "tau", "kinetic", "potential", "work_applied", "work_passive")
CONTACT = ("contact_point", "contact_force", "penetration", "com", "centroidal_momentum")


def pendulum(integrator="rk4", duration=0.3, **run):
    scene = od.load_scene("double_pendulum_swing")
    return scene.replace_run(duration=duration, integrator=integrator, output_dt=0.01, **run)


def starts(scene, n, seed=0, spread=1.0):
    """n initial states around the scene's: (q0 (n, nq), qd0 (n, nv))."""
    rng = np.random.default_rng(seed)
    q0 = np.tile(scene.q0, (n, 1)) + rng.uniform(-spread, spread, (n, scene.model.nq))
    qd0 = np.tile(scene.qd0, (n, 1)) + rng.uniform(-spread, spread, (n, scene.model.nv))
    return q0, qd0


def assert_same_run(result, i, scene):
    """Run i of the rollout is simulate(scene), bit for bit."""
    expected = od.simulate(scene, raise_on_failure=False)
    got = result.trajectory(i)
    for name in RECORDED + CONTACT:
        a, b = getattr(expected, name), getattr(got, name)
        assert a.shape == b.shape and np.array_equal(a, b, equal_nan=True), (i, name)
    assert got.complete == expected.complete and got.message == expected.message
    for key in ("steps", "rejected_steps", "evaluations", "simulated_s"):
        assert got.stats[key] == expected.stats[key], (i, key)
    n = result.rows[i]
    assert np.array_equal(result.q[i, :n], expected.q) and np.isnan(result.q[i, n:]).all()
    assert np.array_equal(result.kinetic[i, :n], expected.kinetic)
    assert np.array_equal(result.q_final[i], expected.q[-1])
    assert np.array_equal(result.tau_final[i], expected.tau[-1], equal_nan=True)
    assert result.complete[i] == expected.complete
    assert result.status[i] == ("complete" if expected.complete else "failed")


@pytest.mark.parametrize(
    "integrator", ["euler", "semi_implicit_euler", "rk4", "dopri5", "implicit_euler"]
)
def test_each_run_is_simulate_bit_for_bit(integrator):
    scene = pendulum(integrator, dt=0.002 if integrator != "dopri5" else 0.01)
    q0, qd0 = starts(scene, 5)
    result = od.rollout(scene, q0=q0, qd0=qd0, threads=2)
    assert len(result) == 5 and result.complete.all()
    for i in range(5):
        assert_same_run(result, i, dataclasses.replace(scene, q0=q0[i], qd0=qd0[i]))


def test_a_failing_run_keeps_its_rows_and_the_others_go_on():
    scene = pendulum(duration=1.0, max_speed=20.0)
    q0, qd0 = starts(scene, 4, spread=0.1)
    qd0[1] = [15.0, 19.0]  # speeds up past max_speed as it falls
    qd0[2] = [25.0, 0.0]  # beyond max_speed at the start: simulate refuses it
    result = od.rollout(scene, q0=q0, qd0=qd0)
    assert list(result.status) == ["complete", "failed", "failed", "complete"]
    assert "max_speed" in result.message[1] and 0 < result.rows[1] < result.rows[0]
    assert_same_run(result, 1, dataclasses.replace(scene, q0=q0[1], qd0=qd0[1]))
    with pytest.raises(SceneError) as refused:
        od.simulate(dataclasses.replace(scene, q0=q0[2], qd0=qd0[2]))
    assert result.message[2] == str(refused.value) and result.rows[2] == 0
    assert np.isnan(result.q[2]).all() and result.steps[2] == 0
    assert np.isnan(result.q_final[2]).all() and np.isnan(result.t_final[2])  # no last state
    with pytest.raises(SceneError) as again:
        result.trajectory(2)
    assert str(again.value) == str(refused.value)
    for i in (0, 3):
        assert_same_run(result, i, dataclasses.replace(scene, q0=q0[i], qd0=qd0[i]))


def test_a_floating_robot_on_contact_is_simulate_bit_for_bit():
    scene = od.load_scene("ball_drop").replace_run(duration=0.4)
    q0, qd0 = np.tile(scene.q0, (3, 1)), np.tile(scene.qd0, (3, 1))
    q0[:, 2] = [0.6, 0.3, 0.15]  # the ball's centre: 0.5 m, 0.2 m and 5 cm above the ground
    qd0[:, 3] = [0.0, 1.0, -2.0]  # a spin and a fall, in the body frame
    result = od.rollout(scene, q0=q0, qd0=qd0)
    assert result.complete.all()
    for i in range(3):
        assert_same_run(result, i, dataclasses.replace(scene, q0=q0[i], qd0=qd0[i]))
    assert result.trajectory(2).penetration.max() > 0  # it reached the ground


def test_params_set_each_runs_keys_as_a_scene_file_would():
    scene = od.default_scene("ur5", duration=0.2, integrator="rk4", dt=0.001, output_dt=0.01)
    settings = od.sim.scene.thaw(scene.settings)
    settings["robot"]["payload"] = {"frame": "wrist_3_link", "mass": 1.0}
    scene = od.scene_from_dict(settings)
    params = {
        "robot.payload.mass": [0.5, 2.0, 4.0],
        "robot.payload.com": [[0, 0, 0.05], [0, 0.1, 0], [0.02, 0, 0]],
        "effects.damping.coefficients": np.linspace(0.5, 2.0, 18).reshape(3, 6),
    }
    result = od.rollout(scene, params=params)
    variants = Variants.of(scene)
    for i in range(3):
        values = {
            "robot.payload.mass": params["robot.payload.mass"][i],
            "robot.payload.com": params["robot.payload.com"][i],
            "effects.damping.coefficients": list(params["effects.damping.coefficients"][i]),
        }
        assert result.values(i)["robot.payload.mass"] == values["robot.payload.mass"]
        assert_same_run(result, i, variants.scene_for(values))
    assert not np.array_equal(result.q_final[0], result.q_final[2])  # each its own payload


@pytest.mark.parametrize(
    "key, entry",
    [("objects.0.velocity.0", "objects.0.velocity"),
     ("effects.contact.pairs.0.a", "effects.contact.pairs")],
)
def test_an_index_into_an_entry_the_scene_does_not_give_says_it_is_absent(key, entry):
    """Not "expected a list of 3 numbers, found {'0': 0.0}" nor "pairs[0].0: unknown key": the
    entry is absent, and the message says how to give it."""
    box = {"name": "box", "shape": "box", "size": [0.1, 0.1, 0.1], "mass": 1.0}
    contact = {"geometry": "collision", "stiffness": 1e4, "friction": 0.5}
    scene = od.scene_from_dict({"objects": [box], "effects": {"contact": contact}})
    with pytest.raises(SceneError) as e:
        Variants.of(scene).scene_for({key: 0.0})
    text = str(e.value)
    assert f"{key}: the scene gives no {entry}, so it has no entry 0" in text
    assert f"set the whole {entry}" in text and f"add {entry} to the scene file" in text


def test_final_keeps_the_last_states_of_samples_and_threads_change_nothing():
    scene = pendulum(duration=0.5)
    q0, qd0 = starts(scene, 12, seed=1)
    samples = od.rollout(scene, q0=q0, qd0=qd0, threads=2)
    one = od.rollout(scene, q0=q0, qd0=qd0, threads=1)
    final = od.rollout(scene, q0=q0, qd0=qd0, record="final")
    for name in ("t", "q", "qd", "tau", "work_applied", "work_passive"):
        assert np.array_equal(getattr(samples, name), getattr(one, name), equal_nan=True)
    assert final.q.shape == (12, 1, 2) and (final.rows == 1).all()
    last = samples.rows - 1
    runs = np.arange(12)
    assert np.array_equal(final.q[:, 0], samples.q[runs, last])
    assert np.array_equal(final.t[:, 0], samples.t[runs, last])
    assert np.array_equal(final.tau[:, 0], samples.tau[runs, last])
    assert np.array_equal(final.work_applied[:, 0], samples.work_applied[runs, last])
    assert np.array_equal(final.kinetic[:, 0], samples.kinetic[runs, last])
    assert np.array_equal(final.q_final, samples.q_final)
    with pytest.raises(ValueError, match="record='final'"):
        final.trajectory(0)


def test_defaults_repeat_the_scenes_state():
    scene = pendulum()
    result = od.rollout(scene)
    assert len(result) == 1
    assert_same_run(result, 0, scene)
    assert len(od.rollout(scene, params={"initial.q.shoulder": [0.1, 0.2, 0.3]})) == 3


@pytest.mark.parametrize(
    "kwargs, error, words",
    [
        (dict(record="all"), ValueError, "record must be 'samples' or 'final'"),
        (dict(threads=0), ValueError, "threads must be at least 1"),
        (dict(threads=1.5), TypeError, "threads must be a whole number"),
        (dict(q0=np.zeros((3, 5))), ValueError, "q0 must have shape (N, 2)"),
        (dict(q0=np.zeros(2)), ValueError, "q0 must have shape (N, 2)"),
        (dict(qd0=[["a", "b"]]), TypeError, "rollout: qd0 must be"),
        (dict(q0=np.zeros((3, 2)), qd0=np.zeros((2, 2))), ValueError, "disagree on N"),
        (dict(params={"run.dt": [0.001]}), ValueError, "od.sweep varies them"),
        (dict(params=[("control.kp", [1.0])]), TypeError, "params must be a mapping"),
        (dict(params={"initial.q.shoulder": [[[1.0]]]}), ValueError, "shape (N,) or (N, k)"),
        (dict(params={"initial.q.elbw": [1.0]}), SceneError, "initial.q"),
        (dict(params={"effects.gravity": [True]}), TypeError, "od.sweep varies words and true"),
        (dict(params={"control.type": ["pd"]}), TypeError, "rollout varies numbers only"),
        (dict(q0=np.zeros((0, 2))), ValueError, "no runs: q0 has no rows"),
    ],
)
def test_bad_arguments_are_refused_naming_them(kwargs, error, words):
    with pytest.raises(error) as e:
        od.rollout(pendulum(), **kwargs)
    assert words in str(e.value)


def test_a_floating_base_quaternion_must_be_a_unit_one():
    """A run whose q0 row has a quaternion off unit norm fails, naming it; the others run."""
    scene = od.load_scene("ball_drop").replace_run(duration=0.01)
    q0 = np.tile(scene.q0, (2, 1))
    q0[1, 3:7] *= 5.0
    result = od.rollout(scene, q0=q0)
    assert list(result.status) == ["complete", "failed"]
    assert re.search(r"q0\[1\]\[3:7\].*unit norm", result.message[1]), result.message[1]


def test_a_python_controller_is_refused():
    scene = od.load_scene("double_pendulum_lqr").replace_run(duration=0.1)
    with pytest.raises(SceneError, match="rollout runs compiled scenes only"):
        od.rollout(scene)


def test_run_indices_are_checked():
    result = od.rollout(pendulum(duration=0.05))
    assert result.trajectory(-1).q.shape == result.trajectory(0).q.shape
    with pytest.raises(IndexError, match="run 1 of a rollout of 1 runs"):
        result.trajectory(1)
    with pytest.raises(TypeError, match="whole number"):
        result.trajectory(0.0)


def test_ctrl_c_stops_after_the_runs_under_way_and_keeps_them(monkeypatch, ctrl_c_raises):
    """SIGINT while the second block is read: the first block's runs go on to their end, the
    rest never start, and RolloutInterrupted carries them. Ctrl-C is set to raise for the test
    (ctrl_c_raises): a suite started with it ignored would have the rollout ignore it too."""
    import opendyn.sim.rollout as rollout_module

    prepare = rollout_module._prepare
    calls = []

    def prepare_then_interrupt(*args):
        block = prepare(*args)
        calls.append(len(block.range))
        if len(calls) == 2:
            os.kill(os.getpid(), signal.SIGINT)
        return block

    monkeypatch.setattr(rollout_module, "_prepare", prepare_then_interrupt)
    scene = pendulum(duration=0.2)
    q0, qd0 = starts(scene, 200, seed=2)
    with pytest.raises(RolloutInterrupted) as stopped:
        od.rollout(scene, q0=q0, qd0=qd0, threads=2)
    result = stopped.value.result
    sent = calls[0]
    assert result.complete[:sent].all() and (result.status[sent:] == "interrupted").all()
    assert 0 < sent < 200 and (result.rows[sent:] == 0).all()
    assert np.isnan(result.q_final[sent:]).all() and not np.isnan(result.q_final[:sent]).any()
    for name in ("t", "q", "qd", "tau", "work_applied"):  # the record of a run never started
        assert np.isnan(getattr(result, name)[sent:]).all(), name
    assert all(m == "interrupted (Ctrl-C) before it started" for m in result.message[sent:])
    assert_same_run(result, sent - 1, dataclasses.replace(scene, q0=q0[sent - 1], qd0=qd0[sent - 1]))


_TYPED_LIST_HELPERS_COMPILED = r"""
import numpy as np
import opendyn as od
from numba.typed import typedlist
scene = od.load_scene("double_pendulum_swing").replace_run(duration=0.01)
od.rollout(scene, q0=np.tile(scene.q0, (3, 1)), threads=2)
helpers = (typedlist._make_list, typedlist._append, typedlist._length, typedlist._getitem)
print(sum(len(f.signatures) for f in helpers))
"""


def test_a_rollout_compiles_nothing_outside_the_kernel_cache():
    """numba's typed List called from Python compiles its helpers in every process, where no
    cache keeps them (0.6 s, each sweep worker's first task): a rollout's list of runs is made
    by compiled functions, so that a fresh process with a warm cache compiles none of them."""
    proc = subprocess.run(
        [sys.executable, "-c", _TYPED_LIST_HELPERS_COMPILED],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip().splitlines()[-1] == "0"
