"""A scene's world as one Model: the robot, its free objects and the static geometry.

Each object is a rigid body on a free joint of its own (or a URDF's tree on a floating base),
a root of the tree after the robot's bodies, so that the robot's coordinates come first and each
object's follow:

    q = (q_robot, p_o (3), quat_o (4), q_o joints..., ...),
    v = (v_robot, omega_o (3), v_o (3), qd_o joints..., ...)

(p_o, quat_o) the pose of the object's frame {o} in the world, (omega_o, v_o) its twist in {o},
as a floating base's (opendyn.multibody.joints). A primitive object's frame is at its shape's
centre, its axes the shape's (a cylinder's and a capsule's along z), and its mass is spread
uniformly, so its centre of mass is {o}'s origin and its rotational inertia about it is
diagonal:

    box (x, y, z)      I_xx = m (y^2 + z^2) / 12, I_yy = m (x^2 + z^2) / 12,
                       I_zz = m (x^2 + y^2) / 12
    sphere (r)         I = 2/5 m r^2
    cylinder (r, L)    I_zz = m r^2 / 2,  I_xx = I_yy = m (3 r^2 + L^2) / 12
    capsule (r, L)     the cylinder's share m_c = m V_c / V and the two hemispheres' m_h = m V_h / V
                       (V_c = pi r^2 L, V_h = 4/3 pi r^3, V = V_c + V_h):
                       I_zz = m_c r^2 / 2 + 2/5 m_h r^2,
                       I_xx = I_yy = m_c (3 r^2 + L^2) / 12 + m_h (2/5 r^2 + L^2 / 4 + 3/8 L r)

(the capsule's by the parallel-axis theorem on each hemisphere, whose centroid lies 3 r / 8 from
its flat face). The static geometry is a frame welded to the world per entry, its pose the
entry's, carrying the entry's Geometry.

Collision pairs: the robot's own (model.collision_pairs, its SRDF applied), and every new
geometry with every earlier one on another body: robot-object, robot-world, object-object and
object-world (the world's entries never with each other, nor with the robot's links welded to
the world: they share the body -1).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .._runtime.arrays import immutable
from ..spatial.algebra import spatial_inertia
from .geometry import Geometry
from .joints import FREE
from .model import Frame, Model


def uniform_inertia(shape, size, mass) -> np.ndarray:
    """(3, 3) kg m^2: the rotational inertia about its centre of a solid `shape` of `size` (m)
    and mass (kg), uniformly dense, in the shape's axes (module docstring)."""
    if shape == "box":
        x, y, z = size
        moments = mass / 12.0 * np.array([y * y + z * z, x * x + z * z, x * x + y * y])
    elif shape == "sphere":
        moments = np.full(3, 0.4 * mass * size[0] ** 2)
    elif shape == "cylinder":
        r, L = size
        side = mass * (3.0 * r * r + L * L) / 12.0
        moments = np.array([side, side, 0.5 * mass * r * r])
    elif shape == "capsule":
        r, L = size
        V_c, V_h = math.pi * r * r * L, 4.0 / 3.0 * math.pi * r**3
        m_c, m_h = mass * V_c / (V_c + V_h), mass * V_h / (V_c + V_h)
        side = m_c * (3.0 * r * r + L * L) / 12.0 + m_h * (
            0.4 * r * r + 0.25 * L * L + 0.375 * L * r
        )
        moments = np.array([side, side, 0.5 * m_c * r * r + 0.4 * m_h * r * r])
    else:
        raise ValueError(f"an object's shape is box, sphere, cylinder or capsule, not {shape!r}")
    return np.diag(moments)


def empty_model() -> Model:
    """A Model with no body: the fixed world alone (frame "world"), to which a scene without a
    robot adds its objects and static geometry."""
    none = np.zeros(0)
    return Model.build(
        name="world", joint_names=(), body_names=(), body_joints=(), parent=none, jtype=none,
        mult=none, offset=none, S=np.zeros((0, 6, 6)), G=np.zeros((0, 6, 6)),
        R_home=np.zeros((0, 3, 3)), p_home=np.zeros((0, 3)),
        frames=[Frame("world", -1, np.eye(4))], lower=none, upper=none, velocity_limit=none,
        effort_limit=none, damping=none, friction=none, continuous=np.zeros(0, bool),
    )


def object_model(name, shape, size, mass) -> Model:
    """The Model of a free rigid body `name` (its body, frame and geometry): `shape` ("box",
    "sphere", "cylinder" or "capsule") of `size` as a Geometry's (m) and `mass` (kg > 0), spread
    uniformly over the shape (module docstring), on a free joint."""
    G = spatial_inertia(mass, np.zeros(3), uniform_inertia(shape, size, mass))
    none = np.zeros(0)
    return Model.build(
        name=name, joint_names=(), body_names=(name,), body_joints=(name,), parent=[-1],
        jtype=[FREE], mult=[1.0], offset=[0.0], S=np.eye(6)[None], G=G[None],
        R_home=np.eye(3)[None], p_home=np.zeros((1, 3)), frames=[Frame(name, 0, np.eye(4))],
        lower=none, upper=none, velocity_limit=none, effort_limit=none, damping=none,
        friction=none, continuous=np.zeros(0, bool),
        geometries=[Geometry(name, name, shape, tuple(size), np.eye(4))],
    )


def _follows(model) -> dict:
    """{body: the body whose coordinate it follows} of the model's mimic joints: the 1-dof
    bodies whose joint owns no coordinate (Model.build's `follows`)."""
    owners = {}
    for i in range(model.nb):
        if model.jtype[i] != FREE and model.body_joints[i] in model.joint_names:
            owners[int(model.iq[i])] = i
    return {
        i: owners[int(model.iq[i])]
        for i in range(model.nb)
        if model.jtype[i] != FREE and model.body_joints[i] not in model.joint_names
    }


def _renamed_geometry(g, rename) -> str:
    """A geometry's name in the merged model: one named after its link ("flap_0") keeps its
    suffix after the link's new name ("door.flap_0"); any other takes the new name whole."""
    if g.name.startswith(g.link):
        return rename(g.link) + g.name[len(g.link):]
    return rename(g.name)


def object_of(model: Model, body: int) -> str | None:
    """The name of the scene object whose tree holds `body` (the name of its root), else None:
    the robot's bodies and the world (-1)."""
    i = int(body)
    while i >= 0 and model.parent[i] >= 0:
        i = int(model.parent[i])
    return model.body_names[i] if i >= 0 and model.body_names[i] in model.objects else None


class _Parts:
    """The per-body, per-joint and per-frame lists of the merged model, grown one part (the
    robot, then each object) at a time."""

    LIMITS = ("lower", "upper", "velocity_limit", "effort_limit", "damping", "friction")

    def __init__(self):
        self.body_names, self.body_joints, self.joint_names = [], [], []
        self.frames, self.geometries, self.aliases, self.follows = [], [], {}, {}
        self.arrays = {key: [] for key in (
            "parent", "jtype", "mult", "offset", "S", "G", "R_home", "p_home", "continuous",
            *self.LIMITS,
        )}
        self.owner = []  # each geometry's part: -1 the robot, k the k-th object

    def add(self, model, rename, owner):
        """Append `model`'s bodies after those added so far, its names through `rename`."""
        first = len(self.body_names)
        self.body_names += [rename(b) for b in model.body_names]
        self.body_joints += [rename(j) for j in model.body_joints]
        self.joint_names += [rename(j) for j in model.joint_names]
        names = {f.name for f in model.frames}
        self.frames += [
            Frame(rename(f.name), f.body + first if f.body >= 0 else -1, f.T_body_frame)
            for f in model.frames
        ]
        self.aliases.update(
            (rename(alias), rename(model.frames[k].name))
            for alias, k in model._frame_index.items() if alias not in names
        )
        self.geometries += [
            dataclasses.replace(g, name=_renamed_geometry(g, rename), link=rename(g.link))
            for g in model.geometries
        ]
        self.owner += [owner] * len(model.geometries)
        self.follows.update((i + first, j + first) for i, j in _follows(model).items())
        parent = np.asarray(model.parent)
        self.arrays["parent"].append(np.where(parent >= 0, parent + first, -1))
        for key in ("jtype", "mult", "offset", "S", "G", "R_home", "p_home"):
            self.arrays[key].append(np.asarray(getattr(model, key)))
        for key in ("continuous", *self.LIMITS):
            self.arrays[key].append(np.asarray(getattr(model, key)))

    def array(self, key):
        return np.concatenate(self.arrays[key])


def with_world(model: Model, objects=(), world=()) -> Model:
    """The Model of the robot `model` with the free `objects` ((name, Model) pairs: each a
    model whose root body is on a free joint, an object_model or a URDF loaded with a floating
    base) and the static `world` ((Geometry, T_s (4, 4)) pairs: each geometry on a frame of its
    own name welded to the world at T_s): its bodies, frames, geometries and pairs as the module
    docstring lays out. `model` itself when there is neither.

    An object's root body and frame take its name; its other bodies, joints, frames and
    geometries are named "NAME.their own name" (a URDF's elbow joint of object "door": the
    joint and coordinate "door.elbow"). Names must be new frame names (the scene reader checks
    them)."""
    if not objects and not world:
        return model
    parts = _Parts()
    parts.add(model, lambda s: s, -1)
    for k, (name, part) in enumerate(objects):
        root = part.body_names[0]
        parts.add(part, lambda s, name=name, root=root: name if s == root else f"{name}.{s}", k)
    parts.frames += [Frame(g.link, -1, T_s) for g, T_s in world]
    parts.geometries += [g for g, _ in world]
    parts.owner += [len(objects)] * len(world)
    merged = Model.build(
        name=model.name,
        joint_names=parts.joint_names,
        body_names=parts.body_names,
        body_joints=parts.body_joints,
        follows=parts.follows,
        frames=parts.frames,
        gravity=model.gravity,
        report=model.report,
        source=model.source,
        frame_aliases=parts.aliases,
        collision_spheres=model.collision_spheres,
        geometries=parts.geometries,
        objects=(*model.objects, *(name for name, _ in objects)),
        world=(*model.world, *(g.link for g, _ in world)),
        **{key: parts.array(key) for key in parts.arrays},
    )
    body, owner = merged.geometry_table.body, parts.owner
    added = [
        (a, b)
        for b in range(len(model.geometries), len(parts.geometries))
        for a in range(b)
        if owner[a] != owner[b] and (body[a] >= 0 or body[b] >= 0)
    ]
    pairs = np.concatenate([model.collision_pairs, np.array(added, np.int64).reshape(-1, 2)])
    return dataclasses.replace(merged, collision_pairs=immutable(pairs, np.int64))
