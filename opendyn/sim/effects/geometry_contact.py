"""Contact between collision geometries: [effects.contact] with geometry = "collision".

    tau = sum over the touching pairs (a, b), over their contact points x, of J^T f

with J = J_b(x) - J_a(x) and f the compliant normal force and regularised Coulomb friction of
opendyn.algorithm.contact, the law over the contact list, which computes it (and
opendyn.algorithm.contact_tangent its linearisation): equal and opposite forces on the two
bodies. The pairs: every geometry of the robot (its URDF's <collision>
elements, meshes as their convex hulls), of the scene's objects and of its world entries, and
the ground plane z = ground_height (named "ground"), two by two: robot-world, robot-object,
object-object and object-world, the robot's own pairs (model.collision_pairs: not a body and its
parent, not a pair its SRDF disables) only with self_collision = true.
[[effects.contact.pairs]] sets a pair's own law (a and b: a link, an object, a world entry or
"ground"), or removes it with enabled = false. Passive, with the springs' energy 1/2 k delta^2
in E, as the spheres' (opendyn.sim.effects.contact).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from numba import njit

from ..._runtime.kernel_cache import JIT
from ...algorithm.contact import compliant_contact, contact_jacobians_kernel
from ...algorithm.contact_extremes import begin
from ...algorithm.contact_list import Geometries, Spheres
from ...multibody.assembly import object_of
from ...multibody.geometry import Geometry, GeometryArrays, GeometryTable
from ...multibody.model import Frame
from ..hard_settings import SOLVER_KEYS, HardSettings, read_model
from .interface import OK, PASSIVE

NAME = "contact"
SECTION = "effects"
LAW_KEYS = ("stiffness", "damping", "friction", "slip_velocity")
KEYS = ("geometry", "ground_height", *LAW_KEYS, "self_collision", "pairs", "model", *SOLVER_KEYS)
COMPLIANT_KEYS = ("stiffness", "damping", "slip_velocity")  # the compliant law's own
PAIR_KEYS = ("a", "b", *LAW_KEYS, "enabled")  # of each [[effects.contact.pairs]]
COLLISION_ONLY = ("geometry", "self_collision", "pairs")  # keys the spheres' contact lacks
FIELD = "contact"
OFF = None
DOC = (
    'geometry = "collision": sum J^T f over the touching pairs of collision geometries '
    "(robot, objects, world, ground), equal and opposite on the two bodies"
)
ENABLE = None
EXAMPLE = {
    "geometry": "collision",
    "ground_height": 1.0,
    "stiffness": 1e3,
    "damping": 10.0,
    "friction": 0.3,
}
STAGE = "geometry contact"
ENERGY = PASSIVE
WORLD_POSES = True
DERIVATIVES = ("K", "D")
Params = None  # a Geometries record (opendyn.algorithm.contact_list): see pack
GROUND = "ground"


@dataclass(frozen=True, eq=False)
class Law:
    """The compliant law of a pair: stiffness k N/m > 0, damping c N s/m >= 0, friction mu >= 0,
    slip_velocity v_s m/s > 0."""

    stiffness: float
    damping: float
    friction: float
    slip_velocity: float


@dataclass(frozen=True, eq=False)
class PairSetting:
    """[[effects.contact.pairs]]: the pairs between the geometries of `a` and of `b` (names of
    links, objects, world entries or "ground") take `law` (None: the scene's), or none with
    enabled False."""

    a: str
    b: str
    law: Law | None
    enabled: bool


@dataclass(frozen=True, eq=False)
class GeometryContact:
    """Contact between the scene's collision geometries (module docstring): the ground plane
    z = ground_height m (world frame, normal +z), the default Law, whether the robot's own
    pairs take part, and the per-pair settings. hard: the hard model's settings
    (opendyn.sim.hard_settings), or None for the compliant law; a hard contact's laws have
    stiffness and damping 0 (only their friction counts)."""

    ground_height: float
    law: Law
    self_collision: bool
    pairs: tuple[PairSetting, ...]
    hard: HardSettings | None = None


def record(scene) -> GeometryContact | None:
    """The scene's compliant geometry contact (a force of the step), else None."""
    contact = scene.contact
    return contact if isinstance(contact, GeometryContact) and contact.hard is None else None


def hard(scene) -> GeometryContact | None:
    """The scene's hard geometry contact (rows of the velocity-level step), else None."""
    contact = scene.contact
    return contact if isinstance(contact, GeometryContact) and contact.hard is not None else None


def read(r, table) -> GeometryContact | None:
    """[effects.contact] with geometry = "collision"; None without the key (the spheres'
    contact, opendyn.sim.effects.contact, reads the table then)."""
    if table is None or "geometry" not in table:
        return None
    key = "effects.contact"
    if "points" in table:
        r.fail(
            f"{key}.points",
            'points are the spheres of the ground contact; geometry = "collision" uses the '
            "collision geometry of the robot, the objects and the world: give one of the two",
        )
    r.keys(table, key, KEYS)
    geometry = r.string(table["geometry"], f"{key}.geometry", ("collision",))
    if geometry != "collision":
        r.fail(f"{key}.geometry", f'expected "collision", found {geometry!r}')
    settings = read_model(r, table, key, COMPLIANT_KEYS)
    for field in ("friction",) if settings else ("stiffness", "friction"):
        if field not in table:
            r.fail(
                f"{key}.{field}",
                "missing: the contact needs "
                + ("friction (mu)" if settings else "stiffness (N/m) and friction (mu)"),
            )
    default = Law(0.0, 0.0, None, 1e-3) if settings else None
    found = GeometryContact(
        ground_height=r.number(table.get("ground_height", 0.0), f"{key}.ground_height"),
        law=_law(r, table, key, default),
        self_collision=r.boolean(table.get("self_collision", False), f"{key}.self_collision"),
        pairs=_pair_settings(r, table.get("pairs", []), f"{key}.pairs", settings),
        hard=settings,
    )
    if len(pair_table(r.model, found)[1]) == 0:
        r.fail(key, 'geometry = "collision": nothing can touch: ' + _why_untouched(r.model, found))
    return found


def _why_untouched(model, contact) -> str:
    """Why `contact` checks no pair: its [[effects.contact.pairs]] with enabled = false take
    out every pair (named), or no body that moves has collision geometry (the objects whose
    URDF has no <collision> named)."""
    if len(pair_table(model, dataclasses.replace(contact, pairs=()))[1]):
        off = [
            f"pairs[{k}] (a = {s.a!r}, b = {s.b!r})"
            for k, s in enumerate(contact.pairs) if not s.enabled
        ]
        return (
            f"[[effects.contact.pairs]] with enabled = false take out every pair it would "
            f"check: {', '.join(off)}; enable one, or remove one of these entries"
        )
    bare = [name for name in model.objects if not _geometries_of(model, name)]
    if not bare:
        return (
            f"{model.name!r} has no collision geometry on a moving body that a pair would "
            "check; give the robot <collision> elements or the scene [[objects]]"
        )
    robot = any(object_of(model, i) is None for i in range(len(model.body_names)))
    many = len(bare) > 1
    return (
        f"no body that moves has collision geometry: the object{'s' * many} "
        f"{', '.join(map(repr, bare))} (URDF{'s' * many} without <collision> elements)"
        + (f" and the robot {model.name!r}" if robot else "")
        + f" ha{'ve' if many or robot else 's'} none; give them <collision> elements, or add "
        "[[objects]] of a shape"
    )


def _law(r, table, key, default) -> Law:
    """The Law of `table`'s keys, each defaulting to `default`'s (None: the scene's own rules:
    damping 0, slip_velocity 1e-3 m/s; stiffness and friction checked present by the caller)."""

    def value(field, fallback, **bounds):
        given = table.get(field)
        if given is None:
            return getattr(default, field) if default is not None else fallback
        return r.number(given, f"{key}.{field}", **bounds)

    return Law(
        stiffness=value("stiffness", None, positive=True),
        damping=value("damping", 0.0, minimum=0.0),
        friction=value("friction", None, minimum=0.0),
        slip_velocity=value("slip_velocity", 1e-3, positive=True),
    )


def _pair_settings(r, value, key, hard=None) -> tuple[PairSetting, ...]:
    if isinstance(value, dict):
        value = [value]
    if not isinstance(value, list):
        r.fail(key, "expected tables [[effects.contact.pairs]] (a, b, and the law's keys)")
    found = []
    for k, table in enumerate(value):
        where = f"{key}[{k}]"
        r.keys(table, where, PAIR_KEYS)
        for field in COMPLIANT_KEYS if hard is not None else ():
            if field in table:
                r.fail(
                    f"{where}.{field}",
                    'is the compliant law\'s; model = "hard" has only friction per pair',
                )
        for field in ("a", "b"):
            if field not in table:
                r.fail(f"{where}.{field}", "missing: a pair names a and b")
        names = [r.string(table[field], f"{where}.{field}") for field in ("a", "b")]
        for field, name in zip(("a", "b"), names):
            if not _geometries_of(r.model, name):
                r.fail(
                    f"{where}.{field}",
                    f"{name!r} has no collision geometry; names that have: "
                    f"{', '.join(_named(r.model))}",
                )
        given = any(field in table for field in LAW_KEYS)
        law = _law(r, table, where, SENTINEL) if given else None
        enabled = r.boolean(table.get("enabled", True), f"{where}.enabled")
        found.append(PairSetting(names[0], names[1], law, enabled))
    return tuple(found)


# a Law whose fields are None: a pair's keys that are absent take the scene's (pair_table)
SENTINEL = Law(None, None, None, None)


def _named(model) -> list[str]:
    """The names a pair may take: the links, objects and world entries with geometry, and
    "ground"."""
    return [*dict.fromkeys(g.link for g in model.geometries), GROUND]


def _object_of(model, k) -> str | None:
    """The object that geometry k belongs to, else None."""
    return object_of(model, model.geometry_table.body[k])


def _geometries_of(model, name) -> list[int]:
    """The indices of the geometries of link, object (all of its links) or world entry `name`
    (the ground: the index after the model's)."""
    if name == GROUND:
        return [len(model.geometries)]
    return [
        k for k, g in enumerate(model.geometries)
        if g.link == name or (name in model.objects and _object_of(model, k) == name)
    ]


def _robot_geometry(model, k) -> bool:
    """Whether geometry k is the robot's (not an object's, not a world entry's)."""
    return _object_of(model, k) is None and model.geometries[k].link not in model.world


def pair_table(model, contact):
    """(pairs (P, 2) int64, laws (P,) of Law): the pairs that take part, each with its law
    (module docstring). Geometry index len(model.geometries) is the ground."""
    body = model.geometry_table.body
    ground = len(model.geometries)
    candidates = [tuple(p) for p in model.collision_pairs]
    candidates += [(k, ground) for k in range(ground) if body[k] >= 0]
    own = {
        (a, b) for a, b in candidates if b != ground and _robot_geometry(model, a)
        and _robot_geometry(model, b)
    }
    laws = {p: contact.law for p in candidates if contact.self_collision or p not in own}
    for setting in contact.pairs:
        A, B = _geometries_of(model, setting.a), _geometries_of(model, setting.b)
        for p in candidates:
            if not ((p[0] in A and p[1] in B) or (p[0] in B and p[1] in A)):
                continue
            if not setting.enabled:
                laws.pop(p, None)
                continue
            law = setting.law or contact.law
            laws[p] = Law(*(
                getattr(contact.law, f.name) if getattr(law, f.name) is None
                else getattr(law, f.name) for f in dataclasses.fields(Law)
            ))
    ordered = [p for p in candidates if p in laws]
    return np.array(ordered, dtype=np.int64).reshape(-1, 2), [laws[p] for p in ordered]


def geometry_table(model, contact) -> GeometryTable:
    """The model's geometries and the ground plane z = ground_height, as the kernels take
    them."""
    T_ground = np.eye(4)
    T_ground[2, 3] = contact.ground_height
    frames = {f.name: f for f in model.frames}
    frames[GROUND] = Frame(GROUND, -1, T_ground)
    ground = Geometry(GROUND, GROUND, "halfspace", (), np.eye(4))
    return GeometryTable.of((*model.geometries, ground), frames)


def pack(contact, model) -> Geometries:
    """The Geometries record (opendyn.algorithm.contact_list): the geometries with the ground
    last (GeometryArrays), the pairs (P, 2) int64 and each pair's law row (k, c, mu, v_s)."""
    table = geometry_table(model, contact)
    pairs, laws = pair_table(model, contact)
    law = np.array(
        [[w.stiffness, w.damping, w.friction, w.slip_velocity] for w in laws], dtype=np.float64
    ).reshape(-1, 4)
    arrays = GeometryArrays(*(np.array(a) for a in table.arrays()))  # writable copies
    return Geometries(arrays, pairs, law)


def smallest_dimensions(model) -> np.ndarray:
    """(G + 1,) m: the smallest dimension of each of the model's geometries (a sphere's or a
    capsule's diameter, a box's shortest edge, the shorter of a cylinder's diameter and
    length, the shortest side of a mesh hull's bounding box in its own frame; inf for a
    halfspace), then the ground's, inf."""
    sizes = np.full(len(model.geometries) + 1, np.inf)
    for k, g in enumerate(model.geometries):
        if g.shape in ("sphere", "capsule"):
            sizes[k] = 2.0 * g.size[0]
        elif g.shape == "box":
            sizes[k] = min(g.size)
        elif g.shape == "cylinder":
            sizes[k] = min(2.0 * g.size[0], g.size[1])
        elif g.shape == "mesh":
            sizes[k] = float(np.ptp(g.vertices, axis=0).min())
    return sizes


def label(contact, model) -> str:
    return f"contact ({len(pair_table(model, contact)[0])} geometry pairs)"


@njit(**JIT)
def apply(p, ctx, out):
    """out.passive += sum J^T f over the touching pairs; out.power[1] += their springs' share
    sum k delta delta_dot; with out.jac, out.K, out.D += their linearisation
    (opendyn.algorithm.contact). p: a Geometries record, or None. Finds the pairs' contacts in
    ctx.room's list (a ContactRoom), on the world poses the step placed in ctx.work,
    allocating nothing; this evaluation's deepest point and largest force go to ctx.touch
    (opendyn.algorithm.contact_extremes). Returns a Status."""
    if p is None:
        return OK
    linear = (out.K, out.D, np.bool_(out.jac))
    begin(ctx.touch, ctx.t)
    out.power[1] += compliant_contact(
        (ctx.ibuf, ctx.fbuf, ctx.work), ctx.room, (None, p), p.law, ctx.qd,
        (out.passive, linear), ctx.touch, None,
    )
    return OK


def rates(contact, at):
    """[(name, rates, where)] of the contact's spring, damper and friction near zero slip at
    the origin of every geometry that a pair checks, over the smallest apparent mass there,
    m_p = 1 / max_r (e_r^T J_p M^-1 J_p^T e_r) (any direction can be a normal): sqrt(k / m_p),
    c / m_p and mu f_n / (v_s m_p), f_n the weight of the model shared by those points."""
    model = at.scene.model
    pairs, laws = pair_table(model, contact)
    table = model.geometry_table
    law = {}
    for (a, b), w in zip(pairs, laws):
        for k in (a, b):
            if k < len(model.geometries) and table.body[k] >= 0:
                old = law.get(k, w)
                law[k] = w if w.stiffness >= old.stiffness else old
    if not law:
        return []
    keys = sorted(law)
    # each geometry's origin, as a contact point of radius 0 (no ground, no law: the
    # Jacobians alone)
    origins = Spheres(
        np.array([table.body[k] for k in keys], dtype=np.int64),
        np.array([table.T_body_geom[k][:3, 3] for k in keys], dtype=np.float64),
        np.zeros(len(keys)), np.zeros(1), np.zeros((len(keys), 4)),
    )
    J = np.empty((len(keys), 3, model.nv))
    contact_jacobians_kernel(model._ibuf, model._fbuf, origins, at.q, J)
    inverse_mass = np.empty(len(keys))
    for n in range(len(keys)):
        worst = 0.0
        for r in range(3):
            tau = np.ascontiguousarray(J[n, r])
            qdd = at.solve(tau)
            if qdd is None:
                return []
            worst = max(worst, float(tau @ qdd))
        inverse_mass[n] = worst
    mass = 1.0 / np.maximum(inverse_mass, 1e-300)
    where = [f"geometry {model.geometries[k].name!r}" for k in keys]
    k_p = np.array([law[k].stiffness for k in keys])
    c_p = np.array([law[k].damping for k in keys])
    found = [
        ("contact stiffness", np.sqrt(k_p / mass), where),
        ("contact damping", c_p / mass, where),
    ]
    gravity = at.scene.gravity
    if gravity is not None:
        f_n = float(np.linalg.norm(gravity)) * float(np.sum(model.mass)) / len(keys)
        mu = np.array([law[k].friction for k in keys])
        v_s = np.array([law[k].slip_velocity for k in keys])
        found.append(("contact friction near zero slip", mu * f_n / v_s / mass, where))
    return found


def tangent(contact, at):
    """The contact between geometries has no exact derivatives: its points move along the
    shapes and its normal turns with both. Refused with the reason (ValueError)."""
    raise ValueError(
        'linearize: [effects.contact] geometry = "collision" has no exact derivatives (its '
        "contact points slide along the shapes and its normals turn with them); linearize "
        "the scene without it (Scene.without(\"contact\"))"
    )
