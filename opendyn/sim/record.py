"""A run's record -> its Trajectory: the recorded rows (Samples), the energies, constraint
violation, contact and centroidal records computed from them, and the provenance. Shared by
simulate, the Simulator and rollouts, so that a run gives the same trajectory whichever ran it.
"""

from __future__ import annotations

import datetime
import platform
import warnings

import numpy as np

from .._runtime.batch import run_rows
from .._runtime.version import __version__
from ..algorithm.centroidal import centroidal_record
from ..algorithm.constraints import ROW_COUNT, constraint_terms_kernel
from ..algorithm.contact import ROW, contact_record_kernel
from ..algorithm.contact_list import STIFFNESS
from ..algorithm.energy import energies
from ..multibody.joints import FREE
from . import effects, integrators
from .contacts import ContactExtremes, ContactTable
from .effects.geometry_contact import GROUND
from .hard import grow_log, log_rows, new_log, solve_stats, sphere_forces
from .scene import thaw

# integrate renormalises the quaternion at every step, so a recorded one is a product of unit
# quaternions rounded a few times: its norm is 1 within a few units of float64 rounding (2.2e-16)
QUATERNION_NORM_BOUND = 1e-14


def gravity_of(scene):
    """The scene's gravity (3,), or zeros when it names none (then U = 0)."""
    return np.zeros(3) if scene.gravity is None else np.asarray(scene.gravity, float)


class Samples:
    """The recorded rows: t, q, qd, tau and the work (applied, passive) of each sample, and
    with a hard model (hard: its HardTable, opendyn.sim.hard_step) its HardLog of the same
    rows."""

    def __init__(self, rows, nq, nv, hard=None):
        self.t = np.full(rows, np.nan)
        self.q = np.full((rows, nq), np.nan)
        self.qd = np.full((rows, nv), np.nan)
        self.tau = np.full((rows, nv), np.nan)
        self.w = np.full((rows, 2), np.nan)
        self.hard = new_log(hard, rows)
        self.filled = 0

    @staticmethod
    def row_bytes(nq, nv) -> int:
        """The bytes of one row: t, q (nq,), qd (nv,), tau (nv,) and w (2,), float64."""
        return 8 * (3 + nq + 2 * nv)

    def arrays(self):
        """The integrators.Record (t, q, qd, tau, w) that the compiled loops write."""
        return integrators.Record(self.t, self.q, self.qd, self.tau, self.w, self.hard)

    def put(self, r, t, x, tau):
        """Row r <- the time t, the State x and the control torque tau there."""
        self.t[r] = t
        self.q[r], self.qd[r], self.w[r] = x.q, x.qd, x.w
        self.tau[r] = tau

    def grow(self, rows):
        """Room for at least `rows` rows, the new ones NaN (the arrays are replaced: take
        arrays() again)."""
        for name in ("t", "q", "qd", "tau", "w"):
            old = getattr(self, name)
            if len(old) < rows:
                new = np.full((rows, *old.shape[1:]), np.nan)
                new[: len(old)] = old
                setattr(self, name, new)
        self.hard = grow_log(self.hard, rows)

    def copy(self):
        """A copy of the filled rows."""
        n = self.filled
        out = Samples(n, self.q.shape[1], self.qd.shape[1])
        for name in ("t", "q", "qd", "tau", "w"):
            getattr(out, name)[:] = getattr(self, name)[:n]
        if self.hard is not None:
            out.hard = type(self.hard)(*(part[:n].copy() for part in self.hard))
        out.filled = n
        return out


def quaternion_norm_error(model, q):
    """(K,) max over the free joints of | |quat| - 1 | at each configuration of q (K, nq)."""
    error = np.zeros(len(q))
    for i in np.flatnonzero(model.jtype == FREE):
        k = int(model.iq[i]) + 3
        error = np.maximum(error, np.abs(np.linalg.norm(q[:, k : k + 4], axis=1) - 1.0))
    return error


def energies_of(scene, table, q, qd):
    """(kinetic (K,), potential (K,), contact) at the samples q (K, nq), qd (K, nv) of a run of
    `scene` (its stage table `table`): T = 1/2 qd^T (M + diag(armature)) qd and U = the gravity
    potential plus the contact springs' sum_p 1/2 k delta_p^2 (J); contact: the spheres'
    contact record (points, forces, penetrations; contact_record) or the geometry contact's
    ContactTable (geometry_contact_record), or None without contact."""
    model = scene.model
    contact = None
    spheres = effects.contact.record(scene)
    if spheres is not None:
        contact = contact_record(model, table.params(effects.contact), q, qd)
    elif effects.geometry_contact.record(scene) is not None:
        contact = geometry_contact_record(model, table.params(effects.geometry_contact), q, qd)
    if not len(q):
        return np.zeros(0), np.zeros(0), contact
    kinetic, potential = energies(model, q, qd, gravity_of(scene))
    if scene.armature is not None:
        kinetic = kinetic + 0.5 * (qd[:, model.v_index] ** 2) @ scene.armature
    if spheres is not None:
        potential = potential + 0.5 * spheres.stiffness * (contact[2] ** 2).sum(axis=1)
    elif contact is not None:  # each point's spring, at its pair's stiffness
        k = table.params(effects.geometry_contact).law[contact.pair, STIFFNESS]
        potential = potential + np.bincount(
            contact.sample, 0.5 * k * contact.depth**2, minlength=len(q)
        )
    return kinetic, potential, contact


def trajectory_of(scene, table, out, n, complete, message, stats, touch=None):
    """The Trajectory of the first n rows of the Record out (integrators.Record: t, q, qd, tau,
    w) of a run of `scene` (its stage table `table`), with its energies, constraint violation,
    contact and centroidal records, provenance, and complete, message and stats as given;
    touch: the run's contact extremes that its steps kept (step.SceneData.touch), or None
    (then the contact's extremes are its samples')."""
    from .trajectory import Trajectory

    model = scene.model
    t, q, qd, tau, w = out.t[:n], out.q[:n], out.qd[:n], out.tau[:n], out.w[:n]
    try:
        (kinetic, potential, spheres), off, centroidal = records_of(scene, table, q, qd)
    except MemoryError:
        # the run's states are kept: what ran out is said once, and the rest is left out
        warnings.warn(
            f"opendyn: out of memory computing the record of {n} samples after the run: the "
            "trajectory keeps t, q, qd, tau and the work; its energies are NaN and its "
            "constraint, contact and centroidal records are left out",
            RuntimeWarning,
            stacklevel=3,
        )
        kinetic = potential = np.full(n, np.nan)
        spheres, off, centroidal = None, (np.zeros(0),) * 2, {}
    contact = {}
    if table.hard is not None:
        # a rollout's run keeps no HardLog: its solve statistics come in stats
        if out.hard is not None:
            contact, spheres = hard_record(scene, table, out.hard, n, (q, qd)), None
            stats = {**stats, **solve_stats(table.hard)}
    elif scene.contact is not None:
        contact["contact_extremes"] = contact_extremes(scene, table, touch, spheres, t)
    if isinstance(spheres, ContactTable):
        contact["contacts"] = spheres
    elif spheres is not None:
        points, forces, depth = spheres
        contact.update(
            contact_names=tuple(p.name for p in scene.contact.points),
            contact_point=points,
            contact_force=forces,
            penetration=depth,
            ground_height=scene.contact.ground_height,
        )
    return Trajectory(
        **contact,
        **centroidal,
        violation_position=off[0],
        violation_velocity=off[1],
        t=t,
        q=q,
        qd=qd,
        tau=tau,
        kinetic=np.atleast_1d(kinetic),
        potential=np.atleast_1d(potential),
        work_applied=w[:, 0].copy(),
        work_passive=w[:, 1].copy(),
        joint_names=tuple(model.joint_names),
        q_names=tuple(model.q_names),
        v_names=tuple(model.v_names),
        complete=complete,
        message=message,
        stats=stats,
        provenance=_provenance(scene, table),
    )


def hard_record(scene, table, log, n, states):
    """The Trajectory's contact record of a hard run from its HardLog log (first n samples;
    states = (q, qd) there): the solve's iterations and residual per sample, and the contacts
    with their forces lambda / dt: the spheres' points and penetrations at the samples with
    their forces, or the geometry contact's ContactTable."""
    found = {
        "solver_iterations": log.solver[:n, 0].copy(),
        "solver_residual": log.solver[:n, 1].copy(),
    }
    spheres = effects.contact.hard(scene)
    if spheres is not None:
        points, _, depth = contact_record(
            scene.model, effects.contact.contact_table(scene.model, spheres), *states
        )
        found.update(
            contact_names=tuple(p.name for p in spheres.points),
            contact_point=points,
            contact_force=sphere_forces(log, n, len(spheres.points)),
            penetration=depth,
            ground_height=spheres.ground_height,
        )
    elif effects.geometry_contact.hard(scene) is not None:
        sample, rows = log_rows(log, n)
        names = pair_names(scene.model, table.hard.geometry.pairs)
        found["contacts"] = ContactTable.of_rows(sample, rows, names)
    return found


def warn_too_deep(traj, stacklevel):
    """A RuntimeWarning (at `stacklevel` above the caller) when a contact pair of the
    Trajectory traj went deeper than its limit (ContactExtremes.warning): the run completes,
    but what it computed is no longer two bodies touching."""
    too_deep = traj.contact_extremes.warning() if traj.contact_extremes is not None else ""
    if too_deep:
        warnings.warn(f"simulate: {too_deep}", RuntimeWarning, stacklevel=stacklevel + 1)


def records_of(scene, table, q, qd):
    """What a trajectory records beside its samples q (K, nq), qd (K, nv): energies_of's
    (kinetic, potential, contact), the constraint violation ((K,) position and velocity; empty
    without constraints) and the centroidal record ({} but for a floating robot)."""
    model = scene.model
    off = violation(model, table, q, qd) if scene.constraints else (np.zeros(0),) * 2
    return energies_of(scene, table, q, qd), off, _centroidal_record(model, q, qd)


def _centroidal_record(model, q, qd):
    """{com: (K, 3), centroidal_momentum: (K, 6)} of a floating robot's samples (the centre of
    mass in the world frame, m; h_G = (k_G, l_G), kg m^2/s and kg m/s); {} for a fixed base or
    a robot without moving mass (a Trajectory's defaults: empty arrays)."""
    if not model.floating_base or not model._total_mass > 0.0 or not len(q):
        return {}
    com, momentum = centroidal_record(model, q, qd)
    return {"com": com, "centroidal_momentum": momentum}


def violation(model, table, q, qd):
    """(max_i |phi_i|, max_i |(A qd)_i|) at each sample (K,): how far the samples are off the
    constraints, in position (m or rad) and velocity (m/s or rad/s)."""
    rows, params = table.constraints.rows, table.constraints.params
    k = int(rows[:, ROW_COUNT].sum())
    A, Adot_qd, phi = np.empty((k, model.nv)), np.empty(k), np.empty(k)
    position, velocity = np.empty(len(q)), np.empty(len(q))
    for i in range(len(q)):
        constraint_terms_kernel(
            model._ibuf, model._fbuf, rows, params, q[i], qd[i], A, Adot_qd, phi
        )
        position[i] = np.abs(phi).max()
        velocity[i] = np.abs(A @ qd[i]).max()
    return position, velocity


def contact_record(model, spheres, q, qd):
    """(points (K, P, 3) m, forces (K, P, 3) N, penetrations (K, P) m) of the contact spheres
    (a Spheres record: a stage table's contact parameters, effects.contact.pack) at the
    samples (q (K, nq), qd (K, nv)), world frame (opendyn.algorithm.contact)."""
    shape = (len(q), len(spheres.body))
    points, forces, depth = np.empty(shape + (3,)), np.empty(shape + (3,)), np.empty(shape)
    run_rows(
        contact_record_kernel, len(q), model._ibuf, model._fbuf, (spheres, None), spheres.law,
        (q, qd), (points, forces, depth),
    )
    return points, forces, depth


def geometry_contact_record(model, geometry, q, qd):
    """The ContactTable of the contact points at the samples (q (K, nq), qd (K, nv));
    geometry: a stage table's Geometries record of effects.geometry_contact (pair_names from
    model.geometries, the last geometry the ground): counted, then written
    (opendyn.algorithm.contact.contact_record_kernel)."""
    counts, offsets = np.zeros(len(q), dtype=np.int64), np.zeros(len(q), dtype=np.int64)
    args = (model._ibuf, model._fbuf, (None, geometry), geometry.law, (q, qd))
    run_rows(contact_record_kernel, len(q), *args, (counts, offsets, np.zeros((0, ROW))))
    offsets[1:] = np.cumsum(counts)[:-1]
    rows = np.zeros((int(counts.sum()), ROW))
    run_rows(contact_record_kernel, len(q), *args, (counts, offsets, rows))
    sample = np.repeat(np.arange(len(q)), counts)
    return ContactTable.of_rows(sample, rows, pair_names(model, geometry.pairs))


def pair_names(model, pairs) -> tuple[tuple[str, str], ...]:
    """The geometries' names (a, b) of each pair (P, 2) of the geometry contact (geometry
    len(model.geometries) is the ground)."""
    names = [g.name for g in model.geometries] + [GROUND]
    return tuple((names[a], names[b]) for a, b in pairs)


def contact_extremes(scene, table, touch, contact, t):
    """The ContactExtremes of a run of `scene` (stage table `table`) with contact: those its
    steps kept (touch, or None) and its samples' (contact: energies_of's contact record, or
    None where it was left out; t (K,) s the samples' times). A pair of the geometry contact
    is named "a-b"; each sphere is its own pair with the ground."""
    model = scene.model
    spheres = effects.contact.record(scene)
    if spheres is not None:
        pairs = [p.name for p in spheres.points]
        sizes = effects.contact.point_sizes(spheres, model)
        limit = np.where(sizes > 0.0, 0.5 * sizes, np.inf)
        rows = _sphere_rows(contact)
    else:
        ab = table.params(effects.geometry_contact).pairs
        pairs = ["-".join(names) for names in pair_names(model, ab)]
        sizes = effects.geometry_contact.smallest_dimensions(model)
        limit = 0.5 * np.minimum(sizes[ab[:, 0]], sizes[ab[:, 1]])
        rows = _table_rows(contact if contact is not None else ContactTable())
    return ContactExtremes.of(touch, rows, t, pairs, limit)


def _sphere_rows(contact):
    """(sample, point, depth m, |force| N) of every sphere that overlaps the ground at a
    sample, from contact_record's (points, forces, depth), or none for None."""
    if contact is None:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0), np.zeros(0)
    _, forces, depth = contact
    sample, point = np.nonzero(depth > 0.0)
    return sample, point, depth[sample, point], np.linalg.norm(forces[sample, point], axis=-1)


def _table_rows(contacts):
    """(sample, pair, depth m, |force| N) of every row of a ContactTable."""
    force = np.linalg.norm(contacts.force, axis=1)
    return contacts.sample, contacts.pair, contacts.depth, force


def _provenance(scene, table):
    import numba

    run = scene.run
    return {
        "scene": {
            "name": scene.name,
            "source": scene.source,
            "settings": thaw(scene.settings),
            "effects": list(scene.effects),
            "stages": list(table.names) + (["armature"] if scene.armature is not None else []),
            "inputs": [path for path, _ in scene.inputs()],
        },
        "robot": {
            "name": scene.model.name,
            "urdf": scene.model.source,
            "floating_base": scene.model.floating_base,
            "nq": scene.model.nq,
            "nv": scene.model.nv,
        },
        "run": {
            "integrator": run.integrator,
            "duration": run.duration,
            "dt": run.dt,
            "output_dt": run.output_dt,
            "rtol": run.rtol,
            "atol": run.atol,
            "max_speed": run.max_speed,
        },
        "versions": {
            "opendyn": __version__,
            "python": platform.python_version(),
            "numpy": np.__version__,
            "numba": numba.__version__,
        },
        "platform": platform.platform(),
        "created": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
    }


