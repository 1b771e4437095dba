"""What every effect module declares, and the records its compiled force takes.

An effect is one module of this package, listed once in registry.EFFECTS. The module declares:

  NAME         its name in a scene (Scene.effects, Scene.without, --disable); the control laws
               and clip share the name "control"
  SECTION      where a scene file sets it: "effects" (the key NAME of [effects]) or "control"
               (keys of [control]; a control module also declares CONTROL_TYPE, the type it
               implements, or None for a key that every type takes, as clip)
  KEYS         the keys of its table, or () when its setting is one value (gravity = true)
  JOINTS       (optional, default False) True when it acts on the joint coordinates only:
               a scene whose robot has no joints refuses it (it would act on nothing)
  WORLD_POSES  (optional, default False) True when its compiled force reads the bodies' world
               poses R_s, p_s from ctx.work: the step places them once per evaluation when a
               scene names it (the joint poses R, p are always placed; opendyn.sim.step)
  read         read(r, value) -> its record, checked (r: the scene's ValueReader, with r.model;
               value: its setting, None when absent, which gives OFF); a control law's is
               read(r, table, q0) -> a Control, and clip's read(r, table) -> the value of its key
  FIELD, OFF   the Scene field that holds its record (None: scene.other_effects[NAME]), and
               the record of the effect switched off (None, or () for a list of records)
  record       record(scene) -> its record in that scene, or None where it is off
  DOC          its line in the effects table (the scenes guide): the generalized force, in words
  ENABLE       what `opendyn simulate --enable NAME` puts in [effects.NAME] (values from the
               URDF), or None: no switch
  EXAMPLE      its settings in a scene of the shipped double pendulum (robots/
               double_pendulum.urdf: joints shoulder and elbow, frame tip) that switch it on:
               the value of [effects.NAME], or a control module's whole [control] table; the
               registry's tests build their scenes from these
  STAGE        the stage's name in reports, or None when the effect is no stage (armature)
  ENERGY       how its power enters the energy balance (CONTROL, APPLIED, PASSIVE or
               CONSERVATIVE below): the force vector of `out` its compiled force adds to
  DERIVATIVES  which of "K" and "D" its compiled force adds its derivatives to (for
               implicit_euler); () for none
  rates        rates(record, at) -> [(name, rates, where)]: its natural frequencies and damping
               rates (1/s) at a state (at: a RatesAt), which name it when a step is too large
               for it; None when it has none
  Params       the namedtuple its parameters are packed into, or None (one array, or the
               packing of an algorithm module)
  pack         pack(record, model) -> its parameters: fresh float64 and int64 arrays (or None
               when there is nothing to compute)
  apply        the compiled generalized force, apply(params, ctx, out) -> a Status; params
               None compiles to nothing (numba prunes `if params is None` on an argument);
               None when the effect is no stage (armature: it changes M, not tau)
  tangent      tangent(record, at) -> (tau (nv,), dtau_dq, dtau_dqd (nv, nv)): its generalized
               force again (numpy) and its exact derivatives, q in the tangent space, for
               opendyn.sim.linearize (at: opendyn.sim.effects.tangent.LinearAt); a control
               law's are the control's, and clip returns the change it makes to them; None for
               an effect that acts through the dynamics, not as a force (gravity, armature)
  label        (optional) label(record, model) -> the stage's name in reports for this record;
               STAGE when absent

Conventions: per-joint values act on the joint coordinates, joint k's position q[iq_k] and
velocity qd[iv_k] (model.q_index, model.v_index), so a floating base is neither damped, limited
nor actuated by them. Forces in N m or N; K = -d tau / d q, D = -d tau / d qd (nv, nv).
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np

from ..._runtime.status import Status

OK = Status.OK.value

# how an effect's power qd . tau enters the balance dE/dt = P_applied + P_passive, E = T + U
CONTROL = "control"  # work put in, and the torque the record calls control: out.control
APPLIED = "applied"  # work put in from outside: out.applied
PASSIVE = "passive"  # work taken out (mostly), not in E: out.passive
CONSERVATIVE = "conservative"  # in E itself: no force vector (gravity's potential is U)
ENERGY_CLASSES = (CONTROL, APPLIED, PASSIVE, CONSERVATIVE)

# What every compiled force reads: the model's buffers ibuf, fbuf and work (the buffer of a
# Data of the model, which the kernels work in, holding the poses the step placed at q: an
# effect's force leaves them as they are), the time t (s), the state q (nq,), qd (nv,),
# the base acceleration dV_0 (6,) (set by the gravity stage, which runs first, read by
# computed torque), armature (nv,) the rotor inertias (or empty), room: the compliant
# contact's ContactRoom (opendyn.algorithm.contact_list), in which it finds its contact list,
# or None for a scene without it,
# and touch: the contact's running extremes, which the contact stage writes at every
# evaluation (opendyn.algorithm.contact_extremes), or None for a scene without contact.
Context = namedtuple(
    "Context", ("ibuf", "fbuf", "work", "t", "q", "qd", "dV_0", "armature", "room", "touch")
)

# What every compiled force adds to: the generalized forces (nv,) of the energy classes
# control, applied and passive (N m or N), power (2,) (applied, passive) W, to which contact
# adds its springs' share, and with jac the stiffness K and damping D (nv, nv) of the effects.
Out = namedtuple("Out", ("control", "applied", "passive", "power", "K", "D", "jac"))

# What the effects' rates need at a state q: the scene, q (nq,) (writable float64, as the run
# passes it to the kernels), the diagonal of M (with armature) at the joints' velocities (n,)
# kg m^2 or kg (None where it is not needed), and solve(tau) -> M(q)^-1 tau (nv,) by the
# scene's own forward dynamics at rest, without gravity and constraints (None where it fails).
RatesAt = namedtuple("RatesAt", ("scene", "q", "joint_mass", "solve"))


def floats(*values) -> np.ndarray:
    """A fresh float64 array (C-contiguous) of the values, raveled and joined."""
    return np.concatenate([np.ravel(np.asarray(v, dtype=np.float64)) for v in values])


def q_indices(model) -> np.ndarray:
    """(n,) int64: each joint's index into q (model.q_index)."""
    return np.array(model.q_index, dtype=np.int64)


def v_indices(model) -> np.ndarray:
    """(n,) int64: each joint's index into v and qd (model.v_index)."""
    return np.array(model.v_index, dtype=np.int64)


def joint_labels(model) -> list[str]:
    """Where a per-joint rate acts, as diagnostics name it: "joint 'NAME'" per joint."""
    return [f"joint {name!r}" for name in model.joint_names]
