"""The hard model of a scene as the step takes it: `model = "hard"` in [effects.contact],
[effects.limits] or [effects.friction] makes contacts, joint limits or joint dry friction
constraints on the step's velocity, solved together by the velocity-level stepper
(opendyn.sim.hard_step) that integrator = "semi_implicit_euler" runs for such a scene
(opendyn.sim.hard_settings reads and checks the settings). This module builds the step's
HardTable and turns the run's per-sample log into the trajectory's contact record."""

from __future__ import annotations

from collections import namedtuple

import numpy as np

from ..algorithm.constraints import ROW_COUNT
from ..algorithm.constraints.terms import terms_work
from ..algorithm.contact import FORCE, PAIR, ROW
from ..algorithm.contact_list import contact_room, room_parts
from ..algorithm.ncp import SOLVERS
from .hard_settings import sections
from .hard_step import (
    BLOCKS,
    G_ROW,
    ITERATIONS,
    LAM,
    RESIDUAL,
    ROWS,
    UNCONVERGED,
    WORST,
    HardLog,
    HardRoom,
    HardTable,
    Impulses,
    hard_velocity_step,
    restart_hard,
)


def hard_table(scene, spheres, geometry, constraints=None) -> HardTable | None:
    """The step's HardTable of the scene, or None when no section is hard. spheres: the
    contact spheres' Spheres record (effects.contact.contact_table) when the scene's contact
    is a hard one of spheres; geometry: the geometry contact's Geometries record
    (effects.geometry_contact.pack) when it is a hard one of geometries; else None each (both
    opendyn.algorithm.contact_list: the hard model reads their laws' mu);
    constraints: the scene's ConstraintTable (opendyn.algorithm.constraints), or None."""
    found = sections(scene)
    if not found:
        return None
    model = scene.model
    shared = next(iter(found.values()))
    contact = found.get("effects.contact")
    limits = found.get("effects.limits")
    n = len(model.joint_names)
    q_index = np.array(model.q_index, dtype=np.int64)
    v_index = np.array(model.v_index, dtype=np.int64)
    contacts = room_parts(contact_room(spheres, geometry, model.nv))
    capacity = contacts.found.pair.shape[0]
    limit_rows = None
    if limits is not None:
        limit_rows = (q_index, v_index, np.array(model.lower, float), np.array(model.upper, float))
    friction_rows = None
    if scene.friction is not None and scene.friction.hard is not None:
        friction_rows = (v_index, np.array(scene.friction.coulomb, float))
    equality_rows = None
    k = 0
    if constraints is not None:
        k = int(constraints.rows[:, ROW_COUNT].sum())
        equality_rows = (
            constraints.rows, constraints.params, np.zeros((k, model.nv)), np.zeros(k),
            np.zeros(k), terms_work(model.nb, model.nv), np.zeros(k),
        )
    joints = (2 * n if limit_rows else 0) + (n if friction_rows else 0)
    rows = 3 * capacity + k + joints
    blocks = capacity + k + joints
    settings = np.array([
        contact.margin if contact else 0.0,
        limits.margin if limits else 0.0,
        shared.stabilization,
        shared.compliance,
        shared.tolerance,
    ])
    solver = np.array([SOLVERS[shared.solver], shared.max_iterations], dtype=np.int64)
    nv = model.nv
    room = HardRoom(
        contacts.found,
        Impulses(
            np.zeros(1, dtype=np.int64), np.zeros(capacity, dtype=np.int64),
            np.zeros(capacity, dtype=np.int64), np.zeros((capacity, 3)),
        ),
        contacts.pairs,
        np.zeros((rows, nv)),
        np.zeros((rows, nv)),
        np.zeros((rows, rows)),
        np.zeros((rows, rows)),
        np.zeros((rows, rows)),
        np.zeros((12, rows)),
        np.zeros((blocks, 3), dtype=np.int64),
        np.zeros(blocks),
        np.zeros(rows, dtype=np.int64),
        contacts.scratch,
        np.zeros((3, nv)),
        np.zeros(6),
        np.zeros((n, 3)),
        np.zeros((n, 2)),
        np.zeros(6),
    )
    return HardTable(
        spheres, geometry, limit_rows, friction_rows, equality_rows, settings, solver,
        room,
    )


def new_log(hard, samples) -> HardLog | None:
    """A HardLog of `samples` rows for the HardTable hard, or None for None."""
    return None if hard is None else empty_log(hard.room.found.pair.shape[0], samples)


def empty_log(width, samples) -> HardLog:
    """A HardLog of `samples` rows of `width` contacts each, empty."""
    return HardLog(
        np.zeros(samples, dtype=np.int64), np.zeros((samples, width, ROW)), np.zeros((samples, 2))
    )


def grow_log(log, samples) -> HardLog | None:
    """The HardLog with room for `samples` rows, the old ones kept."""
    if log is None or len(log.counts) >= samples:
        return log
    new = empty_log(log.rows.shape[1], samples)
    for old, fresh in zip(log, new):
        fresh[: len(old)] = old
    return new


def log_rows(log, n):
    """(sample (C,) int, rows (C, opendyn.algorithm.contact.ROW)) of the first n samples of a
    HardLog: one row per contact per sample, in the geometry contact record's layout (its depth
    the penetration -d, negative for a gap within the margin)."""
    counts = log.counts[:n]
    keep = np.arange(log.rows.shape[1])[None, :] < counts[:, None]
    return np.repeat(np.arange(n), counts), log.rows[:n][keep]


def sphere_forces(log, n, points):
    """(K, P, 3) N: each contact sphere's force at the first n samples of a hard run's
    HardLog (`points` spheres), lambda / dt of the step from each sample, zero for a sphere
    that is not in the sample's list."""
    sample, rows = log_rows(log, n)
    forces = np.zeros((n, points, 3))
    forces[sample, rows[:, PAIR].astype(np.int64)] = rows[:, FORCE : FORCE + 3]
    return forces


def solve_stats(hard) -> dict:
    """The run's statistics of the hard model's solves (hard: its HardTable after the run):
    unconverged_steps, the steps whose solve stopped at max_iterations above the tolerance,
    and worst_residual (m/s), the largest residual among them (0 when every solve
    converged)."""
    stats = hard.room.stats
    return {"unconverged_steps": int(stats[UNCONVERGED]), "worst_residual": float(stats[WORST])}


# One step of the hard model laid open (contact_problem): the contacts found at q (a
# ContactList's entries: pair, feature, bodies, point, frame, depth, mu), the free velocity
# v_free (nv,), the rows J (m, nv), G = J M^-1 J^T + R (m, m), g (m,), the blocks (B, 3) int
# (ncp.KIND, FIRST, SIZE) and their params (B,), the impulses lambda (m,), the velocity after
# the step v_next (nv,) and q_next (nq,), the solve's iterations and residual (m/s).
ContactProblem = namedtuple(
    "ContactProblem",
    ("contacts", "v_free", "J", "G", "g", "blocks", "param", "lam", "v_next", "q_next",
     "iterations", "residual"),
)


def contact_problem(scene, table, data, state):
    """The ContactProblem of one step of the hard model from state = (t, q, qd), with the
    scene's stage table and its SceneData data (step.scene_data) made for it. A failed step
    is a RuntimeError naming the state's status."""
    from . import integrators

    t, q, qd = state
    model = scene.model
    hard = table.hard
    restart_hard(hard)
    x = integrators.State(q, qd, np.zeros(2))
    x1 = integrators.State(np.empty(model.nq), np.empty(model.nv), np.empty(2))
    work = integrators.rk_work(1, model.nq, model.nv)
    status = hard_velocity_step(hard, data, t, scene.run.dt, x, x1, work)
    if status:
        raise RuntimeError(f"contact_problem: the step failed at this state (status {status})")
    room = hard.room
    m, B = int(room.stats[ROWS]), int(room.stats[BLOCKS])
    found = room.found
    n = int(found.count[0])
    contacts = type(found)(n, *(part[:n].copy() for part in found[1:]))
    return ContactProblem(
        contacts, work.vectors[1].copy(), room.J[:m].copy(), room.G[:m, :m].copy(),
        room.vectors[G_ROW, :m].copy(), room.blocks[:B].copy(), room.param[:B].copy(),
        room.vectors[LAM, :m].copy(), x1.qd.copy(), x1.q.copy(), int(room.stats[ITERATIONS]),
        float(room.stats[RESIDUAL]),
    )
