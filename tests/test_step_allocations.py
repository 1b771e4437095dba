"""The compiled step allocates nothing per evaluation: every effect's force works in the
scene's Data buffer and scratch (opendyn.sim.effects.interface), as the design asks of the step,
and so do the effects' derivatives that the implicit integrator asks for, the constrained solve
(in the SceneData's ConstraintWork) and the whole step of the integrators that solve with the
mass matrix (in the integrator's StepWork). Counted exactly
by numba's runtime statistics, in a fresh process with them switched on, over evaluations (or
steps) repeated inside a compiled loop (so that nothing Python passes in is counted): the count
of 11 less that of 1, over 10, must be zero. That the count sees an allocation inside the step is
shown by putting one back, in a copy of the package, where the step once made it: the count of
the same evaluations is then one or more."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest
from test_adding_an_effect import copy_of_the_package, run_in

_ALLOCATIONS = r"""
import json, sys
import numpy as np
from numba import njit
from numba.core.runtime import rtsys
import opendyn as od
from opendyn.sim.effects import stage_table
from opendyn.sim.effects.contact import contact_table
from opendyn.sim.integrators import INTEGRATORS, State, fixed_step, rk_work
from opendyn.sim.record import contact_record
from opendyn.sim.driver import free_joints
from opendyn.sim.step import evaluate, generalized_forces, scene_data

SOLO12_COMPUTED_TORQUE = {
    "robot": {"name": "solo12", "floating_base": True},
    "initial": {"base_position": [0, 0, 1], "qd": {"FL_KFE": 1.0}},
    "effects": {"gravity": True},
    "control": {"type": "computed_torque", "kp": 100.0, "kd": 20.0, "amplitude": 0.2},
}
UR5_WRENCHES = {  # one wrench in world-aligned axes, one in the frame's own
    "robot": {"name": "ur5"},
    "effects": {
        "gravity": True,
        "wrench": [
            {"frame": "tool0", "expressed_in": "world", "value": [0.1, 0, 0, 0, 5, 10]},
            {"frame": "forearm_link", "value": [0, 0.5, 0, 2, 0, 0]},
        ],
    },
}
SCENES = {"solo12 computed torque": SOLO12_COMPUTED_TORQUE, "ur5 wrenches": UR5_WRENCHES}
name, integrator, parts = sys.argv[1], sys.argv[2], sys.argv[3:]  # parts: all when none
if name in SCENES:
    scene = od.scene_from_dict(SCENES[name])
else:
    scene = od.load_scene(name)
if integrator != "shipped":
    scene = scene.replace_run(integrator=integrator)
model = scene.model
q, qd = scene.q0.copy(), np.random.default_rng(0).uniform(-0.5, 0.5, model.nv)
if scene.contact is not None:
    # sink the base until its lowest contact point is 1 cm under the ground: those points push
    points = contact_record(model, contact_table(model, scene.contact), q[None], qd[None])[0][0]
    q[2] -= points[:, 2].min() - scene.contact.ground_height + 1e-2
table = stage_table(scene)
sd = scene_data(model, table)
nv = model.nv
qdd, tau_ctrl, power, tau = np.empty(nv), np.empty(nv), np.empty(2), np.empty(nv)
K, D = np.empty((nv, nv)), np.empty((nv, nv))


@njit
def evaluations(sd, q, qd, qdd, tau_ctrl, power, n):
    status = 0
    for k in range(n):
        status |= evaluate(sd, 0.1 * k, q, qd, qdd, tau_ctrl, power)
    return status


@njit
def forces(sd, q, qd, tau, tau_ctrl, power, KD, n):
    status = 0
    for k in range(n):
        K, D, jac = KD
        status |= generalized_forces(sd, 0.1 * k, q, qd, tau, tau_ctrl, power, K, D, jac)
    return status


@njit
def steps(switches, sd, dt, x, x1, work, free, n):
    status = 0
    for k in range(n):
        status |= fixed_step(
            switches.tableau, switches.implicit, switches.symplectic, sd, 0.1 * k, dt, x, x1,
            work, free,
        )[0]
    return status


def allocations(run):
    assert run(1) == 0  # compiled, and the state is a valid one
    counts = []
    for n in (1, 11):
        before = rtsys.get_allocation_stats().alloc
        assert run(n) == 0
        counts.append(rtsys.get_allocation_stats().alloc - before)
    return (counts[1] - counts[0]) / 10


integ = INTEGRATORS[scene.run.integrator]
x = State(q, qd, np.zeros(2))
x1 = State(np.empty(model.nq), np.empty(nv), np.empty(2))
work = rk_work(len(integ.b), model.nq, nv)  # its stages (1: a step that is no RK method)
runs = {
    "evaluate": lambda n: evaluations(sd, q, qd, qdd, tau_ctrl, power, n),
    "generalized_forces": lambda n: forces(sd, q, qd, tau, tau_ctrl, power, (K, D, False), n),
    "derivatives": lambda n: forces(sd, q, qd, tau, tau_ctrl, power, (K, D, True), n),
    "step": lambda n: steps(
        integ.switches(), sd, scene.run.dt, x, x1, work, free_joints(model), n
    ),
}
counts = {part: allocations(runs[part]) for part in parts or runs}
# at t = 0: the effects' derivatives, then the largest control, applied (wrench) and passive
# (contact) generalized forces and constraint multipliers of an evaluation
forces(sd, q, qd, tau, tau_ctrl, power, (K, D, True), 1)
evaluations(sd, q, qd, qdd, tau_ctrl, power, 1)
pushed = {
    "control": float(np.abs(tau_ctrl).max()),
    "applied": float(np.abs(sd.forces[1]).max()),
    "passive": float(np.abs(sd.forces[2]).max()),
    "constraints": 0.0 if sd.con_work is None else float(np.abs(sd.con_work.lam).max()),
}
stiff = {"K": float(np.abs(K).max()), "D": float(np.abs(D).max())}  # the derivatives' last
print(json.dumps({"effects": list(table.names), "pushed": pushed, "stiff": stiff, **counts}))
"""


def counts_of(proc):
    """The counts that _ALLOCATIONS printed, from its finished process."""
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize(
    "scene, integrator",
    [
        ("quadruped_drop", "shipped"),
        ("humanoid_stand", "shipped"),
        ("solo12_falling", "semi_implicit_euler"),
        ("solo12 computed torque", "shipped"),
        ("ur5 wrenches", "shipped"),
        ("four_bar", "shipped"),
        ("four_bar", "implicit_euler"),
    ],
)
def test_an_evaluation_and_a_step_allocate_nothing(scene, integrator):
    """Ground contact (Solo12's four feet, the humanoid's foot corners pushing into the ground,
    with PD control and gravity), PD control of a falling Solo12, computed torque on a
    floating base (its base reaction by CRBA and Cholesky), wrenches applied to a UR5 (in
    world-aligned axes and in a frame's own: J_b^T F) and the four-bar's loop closure (the
    constrained solve: its rows A, Adot qd, phi, h, M, the multipliers by Cholesky or, in
    implicit Euler, by LU): not one array per evaluation of the compiled step, nor of its
    effects alone, nor of their derivatives K and D, nor per step of the shipped integrator
    (implicit Euler: the effects' derivatives, h, M and an LU solve; RK4) or of semi-implicit
    Euler (g, M, the momentum's fixed point)."""
    env = dict(os.environ, NUMBA_NRT_STATS="1")
    proc = subprocess.run(
        [sys.executable, "-c", _ALLOCATIONS, scene, integrator],
        env=env, capture_output=True, text=True, timeout=900,
    )
    counts = counts_of(proc)
    # the effect that must act, the force it adds to, and whether it has derivatives
    effect, force, stiff = {
        "quadruped_drop": ("contact", "passive", True),
        "humanoid_stand": ("contact", "passive", True),
        "solo12_falling": ("control (pd)", "control", True),
        "solo12 computed torque": ("control (computed torque)", "control", False),
        "ur5 wrenches": ("wrench", "applied", False),
        "four_bar": ("gravity", "constraints", False),  # the multipliers hold the loop
    }[scene]
    assert any(name.startswith(effect) for name in counts["effects"]), counts
    assert counts["pushed"][force] > 0.0, counts  # the effect did push
    assert (counts["stiff"]["K"] > 0.0 and counts["stiff"]["D"] > 0.0) == stiff, counts
    parts = ("evaluate", "generalized_forces", "derivatives", "step")
    assert {part: counts[part] for part in parts} == dict.fromkeys(parts, 0.0), counts


# Where the step once allocated, and the allocation put back there: a file of the package, the
# line that takes its array from the preallocated work, and the line that made it instead.
PLANTED = {
    "quadruped_drop": (
        "algorithm/contact.py",
        "    J = effect_rows(work, nb, nv)\n",
        "    J = np.empty((3, nv))\n",
    ),
    "solo12 computed torque": (
        "sim/effects/computed_torque.py",
        "    rows = effect_rows(ctx.work, body_count(ctx.ibuf), nv)\n",
        "    rows = np.empty((3, nv))\n",
    ),
    "ur5 wrenches": (
        "sim/effects/wrench.py",
        "    J_b = jacobian_field(ctx.work, nb, nv)\n",
        "    J_b = np.empty((6, nv))\n",
    ),
    "four_bar": (
        "algorithm/constraints/solve.py",
        "    M = mass_matrix_field(work, nb, nv)\n",
        "    M = np.empty((nv, nv))\n",
    ),
}


@pytest.mark.parametrize("scene", sorted(PLANTED))
def test_an_allocation_put_back_is_counted(scene, tmp_path, monkeypatch):
    """The count above is no vacuous zero: with an allocation that the step once made put
    back, in a copy of the package (a contact point's Jacobian J_p, computed torque's qdd_c and
    tau_c, the wrench's Jacobian J_b, the constrained solve's mass matrix M), the same
    evaluations count one allocation or more each."""
    package = copy_of_the_package(tmp_path)
    path, preallocated, allocated = PLANTED[scene]
    source = (package / path).read_text()
    assert source.count(preallocated) == 1, path
    (package / path).write_text(source.replace(preallocated, allocated))
    monkeypatch.setenv("NUMBA_NRT_STATS", "1")  # run_in passes the environment on
    counts = counts_of(run_in(package, _ALLOCATIONS, scene, "shipped", "evaluate"))
    assert counts["evaluate"] >= 1.0, counts
