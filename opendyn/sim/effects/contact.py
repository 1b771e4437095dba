"""Ground contact: compliant spheres welded to frames, on the plane z = ground_height.

    tau = sum_p J_p^T f_p

with, at each sphere's lowest point, a spring-damper normal force f_n = max(0, k delta + d
delta_dot) and regularised Coulomb friction f_t = -mu f_n v_t / sqrt(|v_t|^2 + v_s^2)
(opendyn.algorithm.contact, the compliant law over the contact list, which computes it, and
opendyn.algorithm.contact_tangent its linearisation J_p^T K_p J_p, J_p^T D_p J_p). Passive,
with a conservative share: the springs' energy 1/2 k delta^2 is in E, so their power
sum_p k delta_p delta_dot_p is added to out.power[1], the passive power, to take it out.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from ..._runtime.arrays import immutable
from ..._runtime.kernel_cache import JIT
from ...algorithm.contact import compliant_contact, contact_jacobians_kernel
from ...algorithm.contact_extremes import begin
from ...algorithm.contact_list import Spheres
from ..hard_settings import SOLVER_KEYS, HardSettings, read_model
from ..values import what_is
from .interface import OK, PASSIVE
from .tangent import bracket, path_axes, point_velocities, wrench_tangent

NAME = "contact"
SECTION = "effects"
KEYS = (
    "ground_height", "stiffness", "damping", "friction", "slip_velocity", "points", "model",
    *SOLVER_KEYS,
)
COMPLIANT_KEYS = ("stiffness", "damping", "slip_velocity")  # the compliant law's own
POINT_KEYS = ("frame", "position", "radius")  # of each [[effects.contact.points]]
FIELD = "contact"
OFF = None
DOC = (
    "sum_p J_p^T f_p: spring-damper normal force and regularised Coulomb friction at spheres "
    "on the ground"
)
ENABLE = None
EXAMPLE = {
    "ground_height": 1.0,
    "stiffness": 1e3,
    "damping": 10.0,
    "friction": 0.3,
    "points": [{"frame": "tip", "radius": 0.05}],
}
STAGE = "contact"
ENERGY = PASSIVE
WORLD_POSES = True  # its force reads the world poses the step places (compliant_contact)
DERIVATIVES = ("K", "D")
Params = None  # a Spheres record (opendyn.algorithm.contact_list): see contact_table


@dataclass(frozen=True, eq=False)
class ContactPoint:
    """A contact sphere welded to a frame: centre `position` (3,) m in the frame's coordinates,
    `radius` m (0: a point). `name` labels it in the trajectory (the frame's name, with [k] for
    the k-th sphere of a frame that has several); `source` says where it came from."""

    frame: str
    position: np.ndarray
    radius: float
    name: str
    source: str = "scene"


@dataclass(frozen=True, eq=False)
class Contact:
    """Compliant contact of spheres with the ground plane z = ground_height (world frame,
    normal +z; opendyn.algorithm.contact). ground_height m; stiffness k N/m > 0; damping d
    N s/m >= 0; friction mu >= 0; slip_velocity v_s m/s > 0; points: the spheres. hard: the
    hard model's settings (opendyn.sim.hard), or None for the compliant law; a hard contact has
    stiffness and damping 0 (it has no spring)."""

    ground_height: float
    stiffness: float
    damping: float
    friction: float
    slip_velocity: float
    points: tuple[ContactPoint, ...]
    hard: HardSettings | None = None


def record(scene) -> Contact | None:
    """The scene's compliant contact of spheres (a force of the step), else None."""
    contact = scene.contact
    return contact if isinstance(contact, Contact) and contact.hard is None else None


def hard(scene) -> Contact | None:
    """The scene's hard contact of spheres (rows of the velocity-level step), else None."""
    contact = scene.contact
    return contact if isinstance(contact, Contact) and contact.hard is not None else None


def read(r, table) -> Contact | None:
    """[effects.contact]: stiffness, friction and points required; None with geometry =
    "collision" (opendyn.sim.effects.geometry_contact reads the table then)."""
    if table is None or "geometry" in table:
        return None
    key = "effects.contact"
    for field in ("self_collision", "pairs"):
        if field in table:
            r.fail(
                f"{key}.{field}",
                'only the contact between collision geometries (geometry = "collision") has '
                f'{field}; add geometry = "collision" or remove it',
            )
    r.keys(table, key, KEYS)
    settings = read_model(r, table, key, COMPLIANT_KEYS)
    needed = ("friction", "points") if settings else ("stiffness", "friction", "points")
    for field in needed:
        if field not in table:
            r.fail(
                f"{key}.{field}",
                f"missing: [effects.contact] needs {'' if settings else 'stiffness (N/m), '}"
                'friction (mu) and points ("urdf" or [[effects.contact.points]] tables)',
            )
    return Contact(
        ground_height=r.number(table.get("ground_height", 0.0), f"{key}.ground_height"),
        stiffness=0.0 if settings else r.number(
            table["stiffness"], f"{key}.stiffness", positive=True
        ),
        damping=r.number(table.get("damping", 0.0), f"{key}.damping", minimum=0.0),
        friction=r.number(table["friction"], f"{key}.friction", minimum=0.0),
        slip_velocity=r.number(
            table.get("slip_velocity", 1e-3), f"{key}.slip_velocity", positive=True
        ),
        points=read_points(r, table["points"], f"{key}.points"),
        hard=settings,
    )


def read_points(r, value, key) -> tuple[ContactPoint, ...]:
    """"urdf" (the model's collision spheres on moving frames) or a list of tables."""
    m = r.model
    if value == "urdf":
        spheres = [s for s in m.collision_spheres if m.frames[m.frame_index(s.link)].body >= 0]
        if not spheres:
            held = " (those there are belong to the fixed world)" if m.collision_spheres else ""
            r.fail(
                key,
                f'"urdf": {m.source or m.name} has no <collision> sphere or box on a moving '
                f"link{held}; give [[effects.contact.points]] tables (frame, position, "
                "radius)",
            )
        found = [(s.link, s.position, s.radius, s.geometry) for s in spheres]
    else:
        if isinstance(value, dict):
            value = [value]
        if not isinstance(value, list) or not value:
            r.fail(
                key,
                f'expected "urdf" or tables [[effects.contact.points]] (frame, position, '
                f"radius), found {what_is(value)}",
            )
        found = []
        for i, point in enumerate(value):
            where = f"{key}[{i}]"
            r.keys(point, where, POINT_KEYS)
            if "frame" not in point:
                r.fail(f"{where}.frame", f"missing; frames: {', '.join(m.frame_names)}")
            frame = r.frame(point["frame"], f"{where}.frame")
            if m.frames[m.frame_index(frame)].body < 0:
                r.fail(
                    f"{where}.frame",
                    f"{frame!r} is welded to the fixed world: a contact sphere there never "
                    "moves and can push nothing; name a frame of a moving link",
                )
            position = r.vector(point.get("position", [0.0] * 3), f"{where}.position", 3)
            radius = r.number(point.get("radius", 0.0), f"{where}.radius", minimum=0.0)
            found.append((frame, position, radius, "scene"))
    per_frame = {}
    for frame, *_ in found:
        per_frame[frame] = per_frame.get(frame, 0) + 1
    points, seen = [], {}
    for frame, position, radius, source in found:
        k = seen.get(frame, 0)
        seen[frame] = k + 1
        name = frame if per_frame[frame] == 1 else f"{frame}[{k}]"
        points.append(ContactPoint(frame, immutable(position), float(radius), name, source))
    return tuple(points)


def contact_table(model, contact) -> Spheres:
    """The Spheres record (opendyn.algorithm.contact_list) of a scene's contact (Contact): each
    point's body, its sphere's centre c_b = T_body_frame (position, 1) in the body's frame (m)
    and radius (m), the ground's height, and each point's law row (k, d, mu, v_s)."""
    bodies, centres = [], []
    for point in contact.points:
        frame = model.frames[model.frame_index(point.frame)]
        bodies.append(frame.body)
        centres.append((frame.T_body_frame @ np.append(point.position, 1.0))[:3])
    law = (contact.stiffness, contact.damping, contact.friction, contact.slip_velocity)
    count = len(bodies)
    return Spheres(
        np.array(bodies, dtype=np.int64),
        np.array(centres, dtype=np.float64).reshape(count, 3),
        np.array([p.radius for p in contact.points], dtype=np.float64),
        np.array([contact.ground_height], dtype=np.float64),
        np.tile(np.array(law, dtype=np.float64), (count, 1)),
    )


def pack(contact, model):
    return contact_table(model, contact)


def point_sizes(contact, model) -> np.ndarray:
    """(P,) m: the size of each contact point: its sphere's diameter 2 r, or for a point
    (r = 0) the shortest side of the box that its body's points span in the body's frame (a
    box's eight corners span the box); 0 where neither gives one (points on a line or a
    plane)."""
    spheres = contact_table(model, contact)
    sizes = 2.0 * spheres.radius
    for p in np.flatnonzero(sizes == 0.0):
        sizes[p] = np.ptp(spheres.centre[spheres.body == spheres.body[p]], axis=0).min()
    return sizes


def label(contact, model) -> str:
    return f"contact ({len(contact.points)} points)"


@njit(**JIT)
def apply(p, ctx, out):
    """out.passive += sum_p J_p^T f_p, the ground's forces on the contact spheres;
    out.power[1] += their springs' share sum_p k delta_p delta_dot_p (with qd . tau it makes
    the contacts' non-conservative power); with out.jac, out.K, out.D (nv, nv) += their
    linearisation (opendyn.algorithm.contact). p: a Spheres record, or None. Finds the
    spheres' contacts in ctx.room's list (a ContactRoom), on the world poses the step placed in
    ctx.work (WORLD_POSES), allocating nothing; keeps no record of the points (the run's
    record recomputes them at its samples), only this evaluation's deepest point and largest
    force in ctx.touch (opendyn.algorithm.contact_extremes), each point its own pair with the
    ground. Returns a Status."""
    if p is None:
        return OK
    # np.bool_(jac): a run-time flag, so that the kernel compiles once for both values
    linear = (out.K, out.D, np.bool_(out.jac))
    begin(ctx.touch, ctx.t)
    out.power[1] += compliant_contact(
        (ctx.ibuf, ctx.fbuf, ctx.work), ctx.room, (p, None), p.law, ctx.qd,
        (out.passive, linear), ctx.touch, None,
    )
    return OK


def rates(contact, at):
    """[(name, rates (P,), where (P,))] of the contact's spring, damper and friction at each
    point, over its apparent mass m_p = 1 / (e_r^T J_p M^-1 J_p^T e_r): the natural frequency
    sqrt(k / m_p), the damping rate d / m_p and, near zero slip, friction's mu f_n / (v_s m_p)
    with f_n the point's share of the robot's weight. M^-1 J_p^T e_r is at.solve, the scene's
    own forward dynamics, so that the check compiles nothing the run does not."""
    model = at.scene.model
    spheres = contact_table(model, contact)
    count = len(spheres.body)
    J = np.empty((count, 3, model.nv))
    contact_jacobians_kernel(model._ibuf, model._fbuf, spheres, at.q, J)
    inverse_mass = np.empty((count, 3))
    for p in range(count):
        for r in range(3):
            tau = np.ascontiguousarray(J[p, r])
            qdd = at.solve(tau)
            if qdd is None:
                return []
            inverse_mass[p, r] = tau @ qdd
    normal = 1.0 / np.maximum(inverse_mass[:, 2], 1e-300)
    tangential = 1.0 / np.maximum(inverse_mass[:, :2].max(axis=1), 1e-300)
    where = [f"contact point {p.name!r}" for p in contact.points]
    found = [
        ("contact stiffness", np.sqrt(contact.stiffness / normal), where),
        ("contact damping", contact.damping / normal, where),
    ]
    gravity = at.scene.gravity
    if gravity is not None and contact.friction > 0:
        weight = float(np.linalg.norm(gravity)) * float(np.sum(model.mass))
        f_n = weight / len(contact.points)
        found.append(
            (
                "contact friction near zero slip",
                contact.friction * f_n / contact.slip_velocity / tangential,
                where,
            )
        )
    return found


def tangent(contact, at):
    """(tau, dtau_dq, dtau_dqd) of the contact forces, exactly, at each sphere's lowest point
    x = c - r e_z touching the ground with f_n > 0 (opendyn.sim.effects.tangent): the centre c
    moves with the body, the lowest point stays below it. With J_j(y) = v_j + w_j x y the
    velocity of the body's point at y per unit of axis j and v_p = sum_j J_j(x) qd_j the
    velocity of the body's material at x,
        dx/dq_j = J_j(c),   dv_p/dq_j = (S_j x W_j) at x + w_b x J_j(c),   dv_p/dqd_j = J_j(x),
    W_j the twist of the body relative to the joint of j's parent and w_b its angular
    velocity; delta = h - x_z, delta_dot = -v_z, df_n = k d(delta) + d d(delta_dot), and
        df_t = -mu (df_n v_t / s + f_n (dv_t / s - v_t (v_t . dv_t) / s^3)),
    F_s = (x x f, f) with dF_s/dq_j = (J_j(c) x f + x x df_j, df_j), and
    dtau_i/dqd_j = J_i(x) . df_j."""
    model = at.scene.model
    nv = model.nv
    spheres = contact_table(model, contact)
    h = spheres.ground[0]
    k, d, mu, v_s = contact.stiffness, contact.damping, contact.friction, contact.slip_velocity
    tau, dtau_dq, dtau_dqd = np.zeros(nv), np.zeros((nv, nv)), np.zeros((nv, nv))
    for point, b in enumerate(spheres.body):
        c_b, radius = spheres.centre[point], spheres.radius[point]
        c = at.axes.p_s[b] + at.axes.R_s[b] @ c_b
        x = c - np.array([0.0, 0.0, radius])
        delta = h - x[2]
        if delta <= 0.0:
            continue
        S, coords, depth = path_axes(model, at.axes, b)
        qd_a = at.qd[coords]
        J, J_c = point_velocities(S, x), point_velocities(S, c)  # (n_a, 3) each
        v_p = J.T @ qd_a
        f_n = k * delta - d * v_p[2]
        if f_n <= 0.0:
            continue
        # dv_p/dq_j: W_j = sum of qd_i S_i over the axes i at or below j's body
        W = np.array([(qd_a[:, None] * S)[depth >= depth[j]].sum(0) for j in range(len(S))])
        w_b = (qd_a[:, None] * S[:, :3]).sum(0)
        dv_dq = point_velocities(bracket(S, W), x) + np.cross(w_b, J_c)  # (n_a, 3) rows j
        s = np.sqrt(v_p[0] ** 2 + v_p[1] ** 2 + v_s**2)
        f = np.array([-mu * f_n * v_p[0] / s, -mu * f_n * v_p[1] / s, f_n])

        def df(ddelta, dv):
            """the force's change (rows j, 3) for changes of delta (rows j) and v_p (j, 3)"""
            dfn = k * ddelta - d * dv[:, 2]
            v_t, dv_t = v_p[:2], dv[:, :2]
            dft = -mu * (
                dfn[:, None] * v_t / s
                + f_n * (dv_t / s - np.outer(dv_t @ v_t, v_t) / s**3)
            )
            return np.concatenate([dft, dfn[:, None]], axis=1)

        df_dq, df_dqd = df(-J_c[:, 2], dv_dq), df(np.zeros(len(S)), J)
        F_s = np.concatenate([np.cross(x, f), f])
        dF_dq = np.concatenate([np.cross(J_c, f) + np.cross(x, df_dq), df_dq], axis=1)
        tau_p, dtau_p = wrench_tangent(model, at.axes, b, F_s, dF_dq)
        tau += tau_p
        dtau_dq += dtau_p
        np.add.at(dtau_dqd, (coords[:, None], coords[None, :]), J @ df_dqd.T)
    return tau, dtau_dq, dtau_dqd
