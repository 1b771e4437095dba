"""One evaluation of the scene's dynamics: the stages it names, then forward dynamics.

    tau = sum over the scene's effects of tau_e(t, q, qd) + tau_held   (effects, control)
    qdd = (M(q) + diag(armature))^-1 (tau - c(q, qd) - g(q))         (forward dynamics, ABA)

with g(q) present only when the scene names gravity (it sets dV_0 = (0, -g); without it the
base does not accelerate). With constraints A(q) qd = 0 the forward dynamics is instead

    (M + diag(armature)) qdd + A^T lambda = tau - c - g,
    A qdd = -(Adot qd + 2 alpha A qd + beta^2 phi)                  (Baumgarte gains alpha, beta)

(M by CRBA, the multipliers as in opendyn.algorithm.constraints). tau_held (nv,) is the
generalized force a Python caller holds over a control period (opendyn.sim.simulator: the
torque of `Simulator.step` and of a Python controller, a zero-order hold); it is control
torque, so its work is applied work. It is a fourth row of the step's scratch `forces`, which a
run without a Python caller does not have: the test is on the array's shape, not its type, so
that one compiled step serves both (a Python controller reuses what a plain run of the scene
compiled), and a plain run adds nothing. Alongside, the power of the
non-conservative forces for the energy balance dE/dt = qd . tau_applied + qd . tau_passive,
where E = T + U_gravity:
  applied = control torques and applied wrenches (work put in),
  passive = damping, friction, joint-limit spring-dampers and the contacts' dampers and friction
            (work taken out, mostly); the contacts' springs are conservative (their energy is
            in E, see opendyn.algorithm.contact).
Each effect's module declares its class (ENERGY, opendyn.sim.effects.interface) and adds its
force to that vector.

Kinematics once per evaluation: the evaluation checks (q, qd) and places the joint poses
T_{lambda(i), i}(q) in the step's Data buffer first, and the world poses T_{s,i} when an
effect the scene names reads them (its module declares WORLD_POSES: applied wrenches,
contact). The effects (computed torque's RNEA and CRBA included) and ABA then run on those
poses, their kernels' `*_on_poses` forms, instead of walking the tree again each. An effect's
compiled force must leave the poses as they are.

Only the effects the scene names are compiled and run: an effect it does not name has None in
its slot of the effects tuple, and numba drops its call when it compiles the step (not even a
multiplication by zero remains; opendyn.sim.effects.dispatch).
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit

from .._runtime.arrays import fill, result_status, zero_matrix
from .._runtime.kernel_cache import INLINE, JIT
from .._runtime.status import Status
from ..algorithm.aba import aba_on_poses
from ..algorithm.constraints import ROW_COUNT, constrained_on_poses, constraint_work
from ..algorithm.contact_extremes import extremes_room
from ..algorithm.contact_list import contact_room
from ..algorithm.forward import forward_kernel, method_switches
from ..algorithm.kinematics import place_bodies
from ..multibody.joints import place_joints, state_status
from ..multibody.layout import body_count, tree
from ..multibody.work_views import joint_poses
from .effects import contact, geometry_contact, gravity, registry
from .effects.dispatch import EVERY, run_stages
from .effects.interface import Context, Out

# the gravity stage's slot: it runs first, setting the base acceleration dV_0 the others read
GRAVITY = registry.slot(gravity)
# the row of SceneData.forces that holds a Python caller's torque tau_held, when it has one
HELD = 3


@njit(**JIT)
def place(scene, q, qd):
    """Check the state (q (nq,), qd (nv,)) and place the poses at q in scene.work: the joint
    poses R, p of every body, and the world poses R_s, p_s when scene.world is not None.
    Returns a Status: OK, Q/QD_NOT_FINITE or Q_NOT_UNIT_QUATERNION."""
    status = state_status(scene.ibuf, q, qd)
    if status:
        return status
    body_tree = tree(scene.ibuf, scene.fbuf)
    R, p = joint_poses(scene.work, body_count(scene.ibuf))
    place_joints(body_tree, q, R, p)
    place_world(scene.world, body_tree, scene.work)
    return Status.OK.value


@njit(**JIT)
def place_world(world, body_tree, work):
    """work's R_s, p_s <- the world poses from its joint poses; nothing when world is None
    (numba drops the call when it compiles: no effect of the scene reads them)."""
    if world is None:
        return
    place_bodies(body_tree, work)


@njit(**INLINE)
def generalized_forces(scene, t, q, qd, tau, tau_ctrl, power, K, D, jac):
    """Check (q, qd), place the poses at q (place) and run every effect the scene names
    (scene: a SceneData): tau (nv,) <- their total generalized force, tau_ctrl (nv,) <- the
    control's share, the scene's base acceleration dV_0 (6,) <- (0, -g) or 0, power (2,) <-
    (applied, passive) power qd . tau_applied and qd . tau_passive (W), the passive one less the
    work of the contacts' springs. With jac, K and D (nv, nv) <- the stiffness -d tau/dq and
    damping -d tau/dqd of the effects; without, K and D are not touched. Returns a Status."""
    status = place(scene, q, qd)
    if status:
        return status
    tau_app, tau_pas, dV_0 = scene.forces[1], scene.forces[2], scene.loads[0]
    fill(tau_app, 0.0)
    fill(tau_pas, 0.0)
    fill(tau_ctrl, 0.0)
    fill(dV_0, 0.0)
    fill(power, 0.0)
    if jac:
        zero_matrix(K)
        zero_matrix(D)
    ctx = Context(
        scene.ibuf, scene.fbuf, scene.work, t, q, qd, dV_0, scene.armature, scene.room,
        scene.touch,
    )
    # np.bool_(jac): a run-time flag, so that the effects compile once for both values
    out = Out(tau_ctrl, tau_app, tau_pas, power, K, D, np.bool_(jac))
    status = run_stages(EVERY, scene.effects, ctx, out)
    if status:
        return status
    held = scene.forces.shape[0] > HELD  # tau_ctrl += tau_held
    applied = 0.0
    passive = power[1]  # the contact springs' share, if any
    for j in range(qd.shape[0]):
        if held:
            tau_ctrl[j] += scene.forces[HELD, j]
        applied += qd[j] * (tau_ctrl[j] + tau_app[j])
        passive += qd[j] * tau_pas[j]
        tau[j] = tau_ctrl[j] + tau_app[j] + tau_pas[j]
    power[0] = applied
    power[1] = passive
    return Status.OK.value


@njit(**JIT)
def dynamics(scene, q, qd, tau, qdd):
    """qdd (nv,) <- forward dynamics under tau (nv,) and the base acceleration scene.loads[0]:
    the method's without constraints, the constrained solve with them (solve_with), after
    place. Returns a Status."""
    status = place(scene, q, qd)
    if status:
        return status
    aba, crba, newton_euler = scene.method
    return solve_with(scene.constraints, aba, crba, newton_euler, scene, q, qd, tau, qdd)


@njit(**JIT)
def solve_with(con, aba, crba, newton_euler, scene, q, qd, tau, qdd):
    """dynamics on the poses placed at q: with con = (rows, params, gains) the constrained
    solve; else ABA on the poses, or the CRBA methods, which place their own (forward_kernel),
    whichever of the method's switches scene.method = (aba, crba, newton_euler) is True (as
    algorithm.forward.method_switches gives them; all None with constraints). numba drops a
    branch whose argument is None when it compiles (only a None argument decides a test at
    compile time), so only the branch a scene selects is compiled. Returns a Status."""
    if con is not None:
        return constrained_on_poses(
            scene.ibuf, scene.fbuf, scene.work, con, (q, qd, tau), scene.loads, scene.armature,
            (qdd, scene.con_work),
        )
    if aba is not None:
        status = aba_on_poses(
            scene.ibuf, scene.fbuf, scene.work, qd, tau, scene.loads, qdd, scene.armature
        )
        return status if status else result_status(qdd)
    if crba is not None or newton_euler is not None:
        return forward_kernel(
            scene.ibuf, scene.fbuf, scene.work, q, qd, tau, scene.loads, scene.armature,
            scene.method, qdd,
        )
    return Status.OK.value


# The scene as the compiled step takes it (scene_data): the model's buffers ibuf, fbuf; the
# stage table's effects tuple, armature and constraints (or None); the forward-dynamics method
# as the compile-time switches of algorithm.forward.forward_kernel (none with constraints);
# and the step's own scratch: forces (3, nv) (tau, tau_applied, tau_passive), or (4, nv) with
# the torque tau_held (nv,) that a Python caller holds over a control period, loads (1, 6)
# with dV_0, KD (2, nv, nv) the stiffness K and damping D of the effects for the implicit
# integrator, con_work the constrained solve's ConstraintWork for the constraints' k rows
# (their multipliers lam (k,), rows and scratch; None without constraints), work, the buffer
# of a Data of the model that the kernels work in, world, True when an effect the scene names
# reads the world poses (place puts them in work), or None, room, the compliant contact's
# ContactRoom (opendyn.algorithm.contact_list: its contact list), or None, and touch, the
# contact's running extremes that its stage writes and the loops fold at every step
# (opendyn.algorithm.contact_extremes), or None without contact, and hard, the hard model's HardTable (opendyn.sim.hard_step), or None.
SceneData = namedtuple(
    "SceneData",
    (
        "ibuf", "fbuf", "effects", "armature", "method", "constraints", "forces", "loads",
        "KD", "con_work", "work", "world", "room", "touch", "hard",
    ),
)


@njit(**JIT)
def constraint_room(con, nb, nv):
    """The ConstraintWork of the constraints con (a ConstraintTable) on a model of nb bodies
    and nv velocity coordinates (algorithm.constraints.constraint_work): their k rows, the
    multipliers lambda and the solve's scratch, made once so that the step allocates nothing;
    None for None (no constraints: numba decides the test when it compiles, and a step without
    constraints carries none of the twenty arrays, whose references every compiled call that
    takes the SceneData would count)."""
    if con is None:
        return None
    return constraint_work(nb, nv, con.rows[:, ROW_COUNT].sum())


def scene_data(model, table, held=None):
    """The SceneData of a model and its stage table (effects.StageTable); held: None, or the
    (nv,) torque held at first by a Python caller, who writes it between control periods in
    the SceneData's forces[HELD]."""
    method = method_switches(model, None if table.constraints else table.method)
    return SceneData(
        model._ibuf,
        model._fbuf,
        table.effects,
        table.armature,
        method,
        table.constraints,
        np.empty((3, model.nv)) if held is None else np.vstack((np.empty((3, model.nv)), held)),
        np.zeros((1, 6)),
        np.empty((2, model.nv, model.nv)),
        constraint_room(table.constraints, model.nb, model.nv),
        model.data()._work,
        True if table.world_poses else None,
        compliant_room(table, model.nv),
        contact_touch(table),
        table.hard,
    )


def compliant_room(table, nv):
    """The ContactRoom (opendyn.algorithm.contact_list) in which the scene's compliant contact
    finds its contact list at every evaluation (table: its StageTable), or None when it names
    none."""
    spheres, geometries = table.params(contact), table.params(geometry_contact)
    if spheres is None and geometries is None:
        return None
    return contact_room(spheres, geometries, nv)


def contact_touch(table):
    """The contact's running extremes (opendyn.algorithm.contact_extremes.extremes_room) over
    its pairs, the geometry contact's pairs or the spheres' points (table: the scene's
    StageTable), or None when it names no contact."""
    spheres, geometries = table.params(contact), table.params(geometry_contact)
    if geometries is not None:
        return extremes_room(len(geometries.pairs))
    return None if spheres is None else extremes_room(len(spheres.body))


@njit(**JIT)
def evaluate(scene, t, q, qd, qdd, tau_ctrl, power):
    """qdd (nv,) <- the scene's forward dynamics at (t, q, qd); tau_ctrl (nv,) <- the control
    torque; power (2,) <- (applied, passive) power. scene: scene_data(model, table).
    Compiled once and called by every loop. Returns a Status."""
    tau, KD = scene.forces[0], scene.KD
    status = generalized_forces(scene, t, q, qd, tau, tau_ctrl, power, KD[0], KD[1], False)
    if status:
        return status
    aba, crba, newton_euler = scene.method
    return solve_with(scene.constraints, aba, crba, newton_euler, scene, q, qd, tau, qdd)


@njit(**JIT)
def stage_cost_kernel(scene, which, t, q, qd):
    """Run one part of the step at every state (t[n], q[n], qd[n]), for timing it:
    which >= 0 the effect in slot `which`, -1 forward dynamics alone (with the scene's
    gravity, zero torque), -2 the whole evaluation. scene: scene_data(model, table).
    Returns a checksum of the outputs."""
    nv = q.shape[1]
    tau_ctrl = np.empty(nv)
    tau_app = np.empty(nv)
    tau_pas = np.empty(nv)
    qdd = np.empty(nv)
    power = np.empty(2)
    dV_0 = scene.loads[0]
    out = Out(tau_ctrl, tau_app, tau_pas, power, scene.KD[0], scene.KD[1], np.bool_(False))
    fill(dV_0, 0.0)
    ctx = Context(
        scene.ibuf, scene.fbuf, scene.work, t[0], q[0], qd[0], dV_0, scene.armature, scene.room,
        scene.touch,
    )
    run_stages(GRAVITY, scene.effects, ctx, out)
    total = 0.0
    for n in range(q.shape[0]):
        if which >= 0:
            fill(tau_ctrl, 0.0)
            fill(tau_app, 0.0)
            fill(tau_pas, 0.0)
            ctx = Context(
                scene.ibuf, scene.fbuf, scene.work, t[n], q[n], qd[n], dV_0, scene.armature,
                scene.room, scene.touch,
            )
            place(scene, q[n], qd[n])
            run_stages(which, scene.effects, ctx, out)
            for j in range(nv):
                total += tau_ctrl[j] + tau_app[j] + tau_pas[j]
        elif which == -1:
            fill(tau_ctrl, 0.0)
            dynamics(scene, q[n], qd[n], tau_ctrl, qdd)
            total += qdd.sum()
        else:
            evaluate(scene, t[n], q[n], qd[n], qdd, tau_ctrl, power)
            total += qdd.sum()
    return total
