"""The compiled step allocates nothing per evaluation: every effect's force works in the
scene's Data buffer and scratch (opendyn.sim.effects.interface), as the design asks of the step,
and so do the effects' derivatives that the implicit integrator asks for, and the whole step of
the integrators that solve with the mass matrix (in the integrator's StepWork). Counted exactly
by numba's runtime statistics, in a fresh process with them switched on, over evaluations (or
steps) repeated inside a compiled loop (so that nothing Python passes in is counted): the count
of 11 less that of 1, over 10, must be zero."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

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
name, integrator = sys.argv[1], sys.argv[2]
if name == "solo12 computed torque":
    scene = od.scene_from_dict(SOLO12_COMPUTED_TORQUE)
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
counts = {
    "evaluate": allocations(lambda n: evaluations(sd, q, qd, qdd, tau_ctrl, power, n)),
    "generalized_forces": allocations(
        lambda n: forces(sd, q, qd, tau, tau_ctrl, power, (K, D, False), n)
    ),
    "derivatives": allocations(
        lambda n: forces(sd, q, qd, tau, tau_ctrl, power, (K, D, True), n)
    ),
    "step": allocations(
        lambda n: steps(
            integ.switches(), sd, scene.run.dt, x, x1, work, free_joints(model), n
        )
    ),
}
# the largest control and passive (contact) generalized forces of the last evaluation
pushed = {"control": float(np.abs(tau_ctrl).max()), "passive": float(np.abs(sd.forces[2]).max())}
stiff = {"K": float(np.abs(K).max()), "D": float(np.abs(D).max())}  # the derivatives' last
print(json.dumps({"effects": list(table.names), "pushed": pushed, "stiff": stiff, **counts}))
"""


@pytest.mark.parametrize(
    "scene, integrator",
    [
        ("quadruped_drop", "shipped"),
        ("humanoid_stand", "shipped"),
        ("solo12_falling", "semi_implicit_euler"),
        ("solo12 computed torque", "shipped"),
    ],
)
def test_an_evaluation_and_a_step_allocate_nothing(scene, integrator):
    """Ground contact (Solo12's four feet, the humanoid's foot corners pushing into the ground,
    with PD control and gravity), PD control of a falling Solo12 and computed torque on a
    floating base (its base reaction by CRBA and Cholesky): not one array per evaluation of the
    compiled step, nor of its effects alone, nor of their derivatives K and D, nor per step of
    the shipped integrator (implicit Euler: the effects' derivatives, h, M and an LU solve; RK4)
    or of semi-implicit Euler (g, M, the momentum's fixed point)."""
    env = dict(os.environ, NUMBA_NRT_STATS="1")
    proc = subprocess.run(
        [sys.executable, "-c", _ALLOCATIONS, scene, integrator],
        env=env, capture_output=True, text=True, timeout=900,
    )
    assert proc.returncode == 0, proc.stderr
    counts = json.loads(proc.stdout.strip().splitlines()[-1])
    # the effect that must push, the force it adds to, and whether it has derivatives
    effect, force, stiff = {
        "quadruped_drop": ("contact", "passive", True),
        "humanoid_stand": ("contact", "passive", True),
        "solo12_falling": ("control (pd)", "control", True),
        "solo12 computed torque": ("control (computed torque)", "control", False),
    }[scene]
    assert any(name.startswith(effect) for name in counts["effects"]), counts
    assert counts["pushed"][force] > 0.0, counts  # the effect did push
    assert (counts["stiff"]["K"] > 0.0 and counts["stiff"]["D"] > 0.0) == stiff, counts
    parts = ("evaluate", "generalized_forces", "derivatives", "step")
    assert {part: counts[part] for part in parts} == dict.fromkeys(parts, 0.0), counts
