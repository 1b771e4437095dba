"""The frozen robot model: joint models, home transforms M_{i,i-1}, spatial inertias G_i.

A kinematic tree of ``nb`` moving bodies. Body ``i`` is the child link of the i-th moving joint
(revolute, continuous, prismatic, or the free joint of a floating base) with every link welded
to it by fixed joints lumped in. Its frame {i} is that child link's frame, which by the URDF
convention is also the joint frame. The configuration of {i} relative to its parent body's frame
{lambda(i)} is

    T_{lambda(i), i}(q_i) = M_{lambda(i), i} X_J(q_i)

with ``M_{lambda(i), i}`` the home transform and X_J the joint's own transform (the joint models
of opendyn.multibody.joints): exp([A_i] q_i) for a 1-dof joint with screw axis ``A_i`` in {i}
(angular first: (a, 0) for a revolute joint with unit axis a, (0, a) for a prismatic one), the
pose (p, quat) for a free joint. Joint i has nq_i configuration coordinates starting at ``iq[i]``
in q and nv_i velocity coordinates starting at ``iv[i]`` in v, and the motion subspace
``S_i`` (nv_i rows of 6, angular first): V_J = S_i v_i. Parent index -1 is the fixed world: the
root link and every link welded to it, unless the base floats; then the root link is body 0,
on a free joint whose q is (p, quat) of the root link frame in the world, (x, y, z, w) order,
and whose v is the root's twist (omega_b, v_b) in its own frame.

A 1-dof joint may follow another (mimic joints loaded with ``mimic=True``): its angle is
``mult[i] * q[iq[i]] + offset[i]`` with iq, iv those of the joint it follows; mult 1 and
offset 0 otherwise.

All per-body numbers live in two flat buffers (``_ibuf`` ints, ``_fbuf`` float64) that the
compiled kernels receive as two arguments, laid out by one table (INT_FIELDS, FLOAT_FIELDS);
the documented fields are immutable copies of them (``immutable``): no array a Model shows
can be written, or made writeable again, so what the kernels compute never drifts from what
the fields say.
Conventions: twists (omega, v) and wrenches (m, f), angular first; SI units; gravity is the
world-frame vector g, applied as the base acceleration dV_0 = (0, -g).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from .._runtime.arrays import immutable
from .._runtime.options import flag
from ..spatial.algebra import (
    _as_rotational_inertia,
    inverse_transform,
    linear,
    skew,
    spatial_inertia,
    transform_inertia,
)
from .data import Data, work_size
from .geometry import Geometry, GeometryTable, default_pairs
from .joints import FREE, FREE_Q_NAMES, FREE_V_NAMES, JOINT_NQ, JOINT_NV, JOINT_TYPE_NAMES
from .layout import (
    FIXED_JOINTS_INT,
    FLOAT_AT,
    FREE_JOINTS_INT,
    INT_AT,
    INT_HEADER,
    buffer_size,
    field_copy,
    rigid_body_form,
    write_field,
)


def _frame_index(frames, aliases):
    index = {f.name: k for k, f in enumerate(frames)}
    for alias, name in aliases.items():
        index.setdefault(alias, index[name])
    return index


@dataclass(frozen=True)
class Frame:
    """A named frame rigidly attached to a body: ``T_{body, frame}`` is constant.

    ``body`` is the index of the moving body the frame is welded to, or -1 for the fixed world;
    ``T_body_frame`` (4, 4) is immutable (metres).
    """

    name: str
    body: int
    T_body_frame: np.ndarray

    def __post_init__(self):
        object.__setattr__(self, "T_body_frame", immutable(self.T_body_frame).reshape(4, 4))


@dataclass(frozen=True, eq=False)
class CollisionSphere:
    """A contact sphere of a URDF ``<collision>``: centre ``position`` (3,) in metres in the frame
    of link ``link``, ``radius`` in metres.

    ``geometry`` says where it comes from: "sphere" (a ``<sphere>`` at the collision origin) or
    "box corner" (a corner of a ``<box>``, radius 0; a box's 8 come with the signs of
    (x, y, z) in the order (-,-,-), (-,-,+), (-,+,-), ..., (+,+,+), z fastest). ``link`` is
    always a frame of the model (``model.frame_index(link)``), also for links merged by fixed
    joints or welded to the world; ``position`` is immutable.
    """

    link: str
    position: np.ndarray
    radius: float
    geometry: str

    def __post_init__(self):
        object.__setattr__(self, "position", immutable(self.position).reshape(3))
        object.__setattr__(self, "radius", float(self.radius))


# the array fields of a Model, each made immutable with its dtype
_ARRAY_FIELDS = (
    ("q_index", np.int64),
    ("v_index", np.int64),
    ("lower", np.float64),
    ("upper", np.float64),
    ("velocity_limit", np.float64),
    ("effort_limit", np.float64),
    ("damping", np.float64),
    ("friction", np.float64),
    ("continuous", bool),
    ("gravity", np.float64),
)


def parameters_of(mass, h, I_o):
    """(..., 10) inertial parameters (m, h_x, h_y, h_z, I_xx, I_xy, I_yy, I_xz, I_yz, I_zz) of
    masses (...,), first moments h = m c (..., 3) and rotational inertias I_o (..., 3, 3) about
    the frames' origins (Model.inertial_parameters' order)."""
    mass = np.asarray(mass, dtype=float)
    pi = np.empty((*mass.shape, 10))
    pi[..., 0] = mass
    pi[..., 1:4] = h
    pi[..., 4:] = np.asarray(I_o)[..., (0, 0, 1, 0, 1, 2), (0, 1, 1, 2, 2, 2)]
    return pi


def rigid_body_of(pi_i):
    """(m, h (3,), I_o (3, 3)) of one body's 10 inertial parameters (parameters_of's inverse)."""
    mass, h0, h1, h2, xx, xy, yy, xz, yz, zz = (float(x) for x in pi_i)
    I_o = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
    return mass, np.array([h0, h1, h2]), I_o


def inertia_from_parameters(mass, h, I_o):
    """G = [[I_o, [h]], [[h]^T, m 1]] (6, 6): the spatial inertia of mass m (kg), first moment
    h = m c (kg m) and rotational inertia I_o (kg m^2) about the frame's origin, angular first
    (the inverse of layout.rigid_body_form)."""
    G = np.zeros((6, 6))
    G[:3, :3] = I_o
    G[:3, 3:] = skew(h)
    G[3:, :3] = skew(h).T
    G[3:, 3:] = mass * np.eye(3)
    return G


def _rigid_body_problem(mass, h, I_o, check_inertia):
    """What makes (m, h, I_o) no rigid body's parameters, as a phrase; "" when they are one
    (or, with check_inertia False, when only a negative mass is refused)."""
    if mass < 0:
        return f"negative mass {mass:g} kg"
    if not check_inertia:
        return ""
    if mass == 0:
        if np.any(h != 0):
            return f"no mass but a first moment m c = {h} kg m"
        I_com = I_o
    else:
        I_com = I_o - (np.dot(h, h) * np.eye(3) - np.outer(h, h)) / mass
    try:
        _as_rotational_inertia(I_com, "its inertia about the centre of mass")
    except ValueError as e:
        return str(e)
    return ""


@dataclass(frozen=True, eq=False)
class Model:
    """A frozen kinematic tree with its inertias, as the dynamics kernels see it.

    Sizes: nb moving bodies; nq configuration and nv velocity coordinates (nq = nv for a fixed
    base; a floating base adds 7 and 6: q = (p, quat, q_joints), v = (omega_b, v_b, qd_joints));
    nj = len(joint_names) joint coordinates. Fields (numpy arrays that can never be written):
      name            robot name from the URDF
      floating_base   True when a free joint carries the root link (or a URDF floating joint);
                      a scene's objects do not count
      joint_names     (nj,) names of the moving URDF joints that are coordinates, in the order of
                      their coordinates after the base (mimic joints with mimic=True are not)
      q_index, v_index (nj,) int: joint k's coordinate is q[q_index[k]], its velocity v[v_index[k]]
      q_names, v_names (nq,), (nv,) a name per coordinate: a free joint's are base_x base_y
                      base_z base_qx base_qy base_qz base_qw and base_wx ... base_vz for the
                      free joint on the world (the floating base; its body's name in place of
                      "base" for a free joint further out), then the joint names
      body_names      (nb,) link name of each moving body (the joint's child link)
      body_joints     (nb,) name of the joint that moves each body ("root_joint" for the free
                      joint of a floating root link)
      parent          (nb,) int, parent body index, -1 = fixed world; parent[i] < i
      jtype           (nb,) int, REVOLUTE (0), PRISMATIC (1) or FREE (2); continuous is revolute
      nv_j, iq, iv    (nb,) int: joint i's velocity size, first index in q and first index in v
      mult, offset    (nb,) a 1-dof joint's angle is mult[i] * q[iq[i]] + offset[i] (mimic)
      S               (nb, 6, 6) motion subspaces: rows 0 .. nv_j[i] - 1 of S[i], angular first
      A               (nb, 6) screw axis of each 1-dof joint in {i} (S[i, 0]), unit axis
      G               (nb, 6, 6) spatial inertia of body i about the origin of {i}, in {i} (kg, m)
      mass, h, I_o    (nb,), (nb, 3), (nb, 3, 3): the same inertia as mass, first moment m c (kg m)
                      and rotational inertia about {i}'s origin (kg m^2), all in {i}
      R_home, p_home  (nb, 3, 3), (nb, 3): M_{lambda(i), i} = (R_home[i], p_home[i]) in metres
      lower, upper    (nj,) position limits (rad or m); -inf/+inf where the joint has none
      velocity_limit, effort_limit (nj,) (rad/s or m/s, N m or N); +inf where absent
      damping, friction (nj,) from the URDF ``<dynamics>`` (N m s/rad or N s/m; N m or N)
      continuous      (nj,) bool, joint is continuous (unbounded angle)
      frames          tuple of Frame, one per URDF link, by name; a joint's name also finds the
                      frame of its child link (the URDF joint frame)
      collision_spheres tuple of CollisionSphere: the spheres and box corners (radius 0) of the
                      URDF's <collision> elements, each centre in its link's frame (m), by link
                      in URDF order, then by <collision> in document order
      geometries      tuple of Geometry (opendyn.multibody.geometry), one per <collision>
                      element the loader could read, in the same order
      collision_pairs (P, 2) int, the pairs of geometries (indices into geometries) checked by
                      default: on different bodies, neither the other's parent, not disabled by
                      an SRDF
      geometry_table  the geometries packed for the collision kernels (GeometryTable)
      objects, world  a scene's free objects (roots on free joints after the robot's bodies,
                      coordinates NAME.x ... NAME.vz) and static world entries (frames welded
                      to the world with a geometry each), by name: empty for a robot
      gravity         (3,) default gravity vector in the world frame (m/s^2)
      report          the loader's FidelityReport (what was honoured, transformed, ignored)
    """

    name: str
    joint_names: tuple[str, ...]
    body_names: tuple[str, ...]
    body_joints: tuple[str, ...]
    frames: tuple[Frame, ...]
    q_index: np.ndarray
    v_index: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    velocity_limit: np.ndarray
    effort_limit: np.ndarray
    damping: np.ndarray
    friction: np.ndarray
    continuous: np.ndarray
    gravity: np.ndarray
    _ibuf: np.ndarray
    _fbuf: np.ndarray
    report: object = None
    source: str = ""
    collision_spheres: tuple[CollisionSphere, ...] = ()
    geometries: tuple[Geometry, ...] = ()
    collision_pairs: np.ndarray | None = None
    geometry_table: GeometryTable | None = None
    objects: tuple[str, ...] = ()
    world: tuple[str, ...] = ()
    _frame_index: dict = field(default_factory=dict, repr=False)

    @classmethod
    def build(
        cls,
        *,
        name,
        joint_names,
        body_names,
        body_joints,
        parent,
        jtype,
        mult,
        offset,
        S,
        G,
        R_home,
        p_home,
        frames,
        lower,
        upper,
        velocity_limit,
        effort_limit,
        damping,
        friction,
        continuous,
        follows=None,
        gravity=(0.0, 0.0, -9.81),
        report=None,
        source="",
        frame_aliases=None,
        collision_spheres=(),
        geometries=(),
        disabled_links=frozenset(),
        objects=(),
        world=(),
    ):
        """Pack per-body arrays into the kernels' flat buffers and freeze everything.

        jtype (nb,) joint types; S (nb, 6, 6) motion subspaces, rows past nv_j zero.
        follows: {body: the body whose coordinate it follows} for mimic joints (no coordinate
        of their own). Coordinates are allocated in body order: JOINT_NQ[jtype] of q from iq,
        JOINT_NV[jtype] of v from iv.
        frame_aliases: {other name: frame name}, e.g. each URDF joint's name for its child link
        (the URDF joint frame is the child link's frame); a frame's own name always wins.
        collision_spheres: CollisionSpheres, each on a link that is one of the frames.
        geometries: Geometries, each on a link that is one of the frames; disabled_links: the
        link pairs (frozensets of two names) whose geometries are not checked by default.
        objects, world: a scene's objects and world entries by name (Model.objects, .world).
        """
        nb = len(body_names)
        jtype = np.asarray(jtype, dtype=np.int64).reshape(nb)
        follows = follows or {}
        nv_j = np.array([JOINT_NV[t] for t in jtype], dtype=np.int64)
        iq, iv = np.zeros(nb, dtype=np.int64), np.zeros(nb, dtype=np.int64)
        nq = nv = 0
        for i in range(nb):
            if i not in follows:
                iq[i], iv[i] = nq, nv
                nq, nv = nq + JOINT_NQ[jtype[i]], nv + JOINT_NV[jtype[i]]
        for i, leader in follows.items():  # a mimic joint may come before the one it follows
            iq[i], iv[i] = iq[leader], iv[leader]
        ibuf = np.zeros(
            INT_HEADER + buffer_size(INT_AT, nb),
            dtype=FREE_JOINTS_INT if np.any(jtype == FREE) else FIXED_JOINTS_INT,
        )
        fbuf = np.zeros(buffer_size(FLOAT_AT, nb), dtype=np.float64)
        ibuf[0], ibuf[1], ibuf[2] = nb, nv, nq
        for key, arr in (
            ("parent", parent),
            ("jtype", jtype),
            ("nv_j", nv_j),
            ("iq", iq),
            ("iv", iv),
        ):
            write_field(ibuf, INT_AT, key, nb, arr, INT_HEADER)
        G = np.reshape(np.asarray(G, dtype=np.float64), (nb, 6, 6))
        mass, h, I_o = rigid_body_form(G)
        for key, arr in (
            ("mult", mult),
            ("offset", offset),
            ("S", S),
            ("G", G),
            ("mass", mass),
            ("h", h),
            ("I_o", I_o),
            ("R_home", R_home),
            ("p_home", p_home),
        ):
            write_field(fbuf, FLOAT_AT, key, nb, arr)

        # each joint coordinate belongs to the 1-dof joint that carries its name
        owner = {body_joints[i]: i for i in range(nb) if jtype[i] != FREE and i not in follows}
        frames = tuple(frames)
        geometries = tuple(geometries)
        table = GeometryTable.of(geometries, {f.name: f for f in frames})
        links = [g.link for g in geometries]
        return cls(
            name=name,
            joint_names=tuple(joint_names),
            body_names=tuple(body_names),
            body_joints=tuple(body_joints),
            frames=frames,
            q_index=[iq[owner[j]] for j in joint_names],
            v_index=[iv[owner[j]] for j in joint_names],
            lower=lower,
            upper=upper,
            velocity_limit=velocity_limit,
            effort_limit=effort_limit,
            damping=damping,
            friction=friction,
            continuous=continuous,
            gravity=gravity,
            _ibuf=ibuf,
            _fbuf=fbuf,
            report=report,
            source=source,
            collision_spheres=tuple(collision_spheres),
            geometries=geometries,
            collision_pairs=default_pairs(table, parent, disabled_links, links),
            geometry_table=table,
            objects=tuple(objects),
            world=tuple(world),
            _frame_index=_frame_index(frames, frame_aliases or {}),
        )

    def __post_init__(self):
        for key, dtype in _ARRAY_FIELDS:
            object.__setattr__(self, key, immutable(getattr(self, key), dtype))
        # plain attributes, read on every call
        nb, nv, nq = (int(x) for x in self._ibuf[:3])
        object.__setattr__(self, "nb", nb)
        object.__setattr__(self, "nv", nv)
        object.__setattr__(self, "nq", nq)
        if self.geometry_table is None:  # a model made without Model.build
            table = GeometryTable.of(self.geometries, {f.name: f for f in self.frames})
            object.__setattr__(self, "geometry_table", table)
        # the per-body fields, copied once from the kernels' buffers
        fields = {key: field_copy(self._ibuf, INT_AT, key, nb, INT_HEADER) for key in INT_AT}
        fields.update((key, field_copy(self._fbuf, FLOAT_AT, key, nb)) for key in FLOAT_AT)
        object.__setattr__(self, "_fields", fields)
        if self.collision_pairs is None:  # a model made without Model.build
            pairs = default_pairs(self.geometry_table, fields["parent"])
            object.__setattr__(self, "collision_pairs", pairs)
        robot_free = [i for i in np.flatnonzero(self.jtype == FREE) if not self._is_object(i)]
        object.__setattr__(self, "floating_base", bool(robot_free))
        # mimic joints share coordinates: the joints' velocity sizes add up to more than nv
        object.__setattr__(self, "coupled", int(np.sum(self.nv_j)) != nv)
        q_names, v_names = [""] * nq, [""] * nv
        for i in range(nb):
            if self.jtype[i] == FREE:
                name = self.body_names[i]
                if self._is_object(i):  # a scene's object: box.x, box.qw, box.vz
                    stem, join = name, "."
                else:
                    stem, join = ("base" if self.parent[i] < 0 else name), "_"
                a, b = self.iq[i], self.iv[i]
                q_names[a : a + 7] = [f"{stem}{join}{n}" for n in FREE_Q_NAMES]
                v_names[b : b + 6] = [f"{stem}{join}{n}" for n in FREE_V_NAMES]
        for k, name in enumerate(self.joint_names):
            q_names[self.q_index[k]], v_names[self.v_index[k]] = name, name
        object.__setattr__(self, "q_names", tuple(q_names))
        object.__setattr__(self, "v_names", tuple(v_names))
        # writeable private copies handed to the kernels (one array type per argument, so
        # numba compiles each kernel once), never exposed
        object.__setattr__(self, "_q_shape", (nq,))
        object.__setattr__(self, "_vector_shape", (nv,))
        object.__setattr__(self, "_matrix_shape", (nv, nv))
        object.__setattr__(self, "_zero_v", np.zeros(nv))
        object.__setattr__(self, "_total_mass", float(np.sum(self._fields["mass"])))
        object.__setattr__(self, "_gravity", np.array(self.gravity))
        loads = np.zeros((1, 6))
        linear(loads[0])[:] = -self._gravity  # the kernels' dV_0 = (0, -g), no wrenches
        object.__setattr__(self, "_loads", loads)
        # the work buffer of calls made without data= (the kernels hold the GIL, so calls from
        # several threads take turns in it; batches give each thread a buffer of its own)
        object.__setattr__(self, "_work", np.zeros(work_size(nb, nv)))
        # each frame's name (and alias) -> (body, T_body_frame): the pair the kernels take
        frame_targets = {
            name: (self.frames[k].body, self.frames[k].T_body_frame)
            for name, k in self._frame_index.items()
        }
        object.__setattr__(self, "_frame_targets", frame_targets)
        # the velocity coordinates no joint owns: a free joint's twist (a floating base's)
        object.__setattr__(self, "_unactuated", np.setdiff1d(np.arange(nv), self.v_index))

    def _is_object(self, i) -> bool:  # body i is one of a scene's objects
        return self.body_names[i] in self.objects

    parent = property(lambda self: self._fields["parent"], doc="(nb,) parent body, -1 = world")
    jtype = property(lambda self: self._fields["jtype"], doc="(nb,) REVOLUTE/PRISMATIC/FREE")
    nv_j = property(lambda self: self._fields["nv_j"], doc="(nb,) velocity size of each joint")
    iq = property(lambda self: self._fields["iq"], doc="(nb,) first q index of each joint")
    iv = property(lambda self: self._fields["iv"], doc="(nb,) first v index of each joint")
    mult = property(lambda self: self._fields["mult"], doc="(nb,) mimic multiplier")
    offset = property(lambda self: self._fields["offset"], doc="(nb,) mimic offset")
    S = property(lambda self: self._fields["S"], doc="(nb, 6, 6) motion subspaces, by rows")
    A = property(lambda self: self.S[:, 0], doc="(nb, 6) screw axes A_i of 1-dof joints in {i}")
    G = property(lambda self: self._fields["G"], doc="(nb, 6, 6) spatial inertias G_i in {i}")
    mass = property(lambda self: self._fields["mass"], doc="(nb,) body masses (kg)")
    h = property(lambda self: self._fields["h"], doc="(nb, 3) first moments m c in {i} (kg m)")
    I_o = property(lambda self: self._fields["I_o"], doc="(nb, 3, 3) inertia about {i}'s origin")
    R_home = property(lambda self: self._fields["R_home"], doc="(nb, 3, 3) rotation of M_{p,i}")
    p_home = property(lambda self: self._fields["p_home"], doc="(nb, 3) translation of M_{p,i}")

    @property
    def frame_names(self) -> tuple[str, ...]:
        """Names of every frame: each URDF link, in URDF order."""
        return tuple(f.name for f in self.frames)

    def frame_index(self, frame: str) -> int:
        """Index of a frame by name (a link, or a joint, which names its child link's frame);
        KeyError naming the frame and some valid names if unknown."""
        try:
            return self._frame_index[frame]
        except (KeyError, TypeError):
            names = ", ".join(self.frame_names[:12])
            more = "" if len(self.frames) <= 12 else f", ... ({len(self.frames)} in all)"
            raise KeyError(
                f"frame {frame!r} is not a frame of model {self.name!r}; "
                f"valid frames: {names}{more}"
            ) from None

    def with_payload(self, frame: str, mass, com=(0.0, 0.0, 0.0), inertia=None) -> Model:
        """G_i' = G_i + [Ad_{T_fi}]^T G_payload_f [Ad_{T_fi}],  T_fi = T_{i,f}^-1: a new Model
        whose body i, the one carrying `frame` {f}, also carries a rigid payload.

        G_payload_f = spatial_inertia(mass, com, inertia) is the payload's spatial inertia about
        {f}'s origin in {f}'s axes; [Ad_{T_fi}]^T ... [Ad_{T_fi}] moves it to {i}'s origin and
        axes (MR Section 8.2.2), and mass, h and I_o of body i follow from G_i'.
        frame: a frame name (a link, or a joint for its child link) on a moving body.
        mass: kg >= 0. com: (3,) m, the payload's centre of mass in {f}'s coordinates.
        inertia: (3, 3) kg m^2, its rotational inertia about its centre of mass in {f}'s axes
        (symmetric, positive semi-definite, principal moments within the triangle
        inequality); None: a point mass.
        Returns the new Model (this one is unchanged; mass 0 with no inertia gives the same
        arrays). KeyError for an unknown frame (as ``frame_index``); ValueError naming the
        frame when it is welded to the fixed world (the payload would not move), or naming
        mass, com or inertia when one is not a physical value of its shape.
        """
        f = self.frames[self.frame_index(frame)]
        if f.body < 0:
            raise ValueError(
                f"frame {frame!r} of model {self.name!r} is welded to the fixed world, so a "
                "payload on it would not move and no joint would carry it; name a frame of a "
                "moving link"
            )
        I_com = np.zeros((3, 3)) if inertia is None else _as_rotational_inertia(inertia, "inertia")
        G_payload_f = spatial_inertia(mass, com, I_com)
        T_fi = inverse_transform(f.T_body_frame)
        G = np.array(self.G)
        G[f.body] += transform_inertia(G_payload_f, T_fi)
        return self._with_inertias(G)

    def _with_inertias(self, G) -> Model:
        """A new Model with the spatial inertias G (nb, 6, 6), everything else this one's."""
        fbuf = self._fbuf.copy()
        for key, values in zip(("G", "mass", "h", "I_o"), (G, *rigid_body_form(G))):
            write_field(fbuf, FLOAT_AT, key, self.nb, values)
        return dataclasses.replace(self, _fbuf=fbuf)

    def inertial_parameters(self) -> np.ndarray:
        """pi (10 nb,): the inertial parameters of the moving bodies, 10 per body in body
        order, pi[10 i : 10 i + 10] = (m, m c_x, m c_y, m c_z, I_xx, I_xy, I_yy, I_xz, I_yz,
        I_zz) of body i: its mass (kg), first moment (kg m) and rotational inertia about the
        origin of its frame {i} (kg m^2), all in {i}'s axes (Pinocchio's order). Inverse
        dynamics is linear in them: tau = torque_regressor(model, q, qd, qdd) @ pi."""
        return parameters_of(self.mass, self.h, self.I_o).ravel()

    def with_inertial_parameters(self, pi, check_inertia=True) -> Model:
        """A new Model whose bodies have the inertial parameters pi (10 nb,), in the order of
        ``inertial_parameters`` (this one is unchanged; ``with_inertial_parameters(
        model.inertial_parameters())`` gives the same arrays).

        Each body's parameters must be those of a rigid body: mass m >= 0; with m > 0, the
        rotational inertia about the centre of mass c = (m c) / m, I_c = I - m [c]^T [c],
        symmetric positive semi-definite with principal moments within the triangle
        inequality; with m = 0, a zero first moment and such an I. check_inertia=False keeps
        parameters no rigid body has (as load_urdf's check_inertia=False keeps a URDF's),
        except a negative mass. ValueError naming the body and its slice of pi otherwise;
        pi of another length, or not finite, is a ValueError naming pi.
        """
        pi = np.asarray(pi)
        if pi.dtype.kind not in "iuf":
            raise TypeError(
                f"pi must be an array of numbers (integers or floats), got dtype {pi.dtype}"
            )
        pi = pi.astype(float)
        if pi.shape != (10 * self.nb,):
            raise ValueError(
                f"pi must have shape ({10 * self.nb},) (10 inertial parameters for each of the "
                f"{self.nb} bodies of model {self.name!r}), got shape {pi.shape}"
            )
        if not np.all(np.isfinite(pi)):
            raise ValueError(f"pi must be finite, got {pi}")
        check_inertia = flag(check_inertia, "with_inertial_parameters: check_inertia")
        G = np.zeros((self.nb, 6, 6))
        for i, pi_i in enumerate(pi.reshape(-1, 10)):
            mass, h, I_o = rigid_body_of(pi_i)
            problem = _rigid_body_problem(mass, h, I_o, check_inertia)
            if problem:
                raise ValueError(
                    f"with_inertial_parameters: body {self.body_names[i]!r} (pi[{10 * i}:"
                    f"{10 * i + 10}]): {problem}"
                    + ("" if mass < 0 else "; check_inertia=False keeps it as written")
                )
            G[i] = inertia_from_parameters(mass, h, I_o)
        return self._with_inertias(G)

    def data(self) -> Data:
        """A new Data for this model: the work arrays that the dynamics functions' ``data=``
        works in (opendyn.multibody.data)."""
        return Data(self)

    def home_transform(self, i: int) -> np.ndarray:
        """M_{lambda(i), i}: (4, 4) home configuration of body i in its parent's frame."""
        T = np.eye(4)
        T[:3, :3] = self.R_home[i]
        T[:3, 3] = self.p_home[i]
        return T

    def __repr__(self) -> str:
        return (
            f"Model({self.name!r}, nq={self.nq}, nv={self.nv}, bodies={self.nb}, "
            f"frames={len(self.frames)})"
        )

    def summary(self) -> str:
        """A human-readable table of joints, limits and masses."""
        lines = [
            f"robot {self.name!r}: nq={self.nq}, nv={self.nv}, {self.nb} moving bodies, "
            f"{'floating' if self.floating_base else 'fixed'} base, "
            f"{len(self.frames)} frames, total moving mass "
            f"{float(self.G[:, 3, 3].sum()) if self.nb else 0.0:.4g} kg"
        ]
        continuous = dict(zip(self.joint_names, self.continuous))
        for i in range(self.nb):
            kind = JOINT_TYPE_NAMES[self.jtype[i]]
            if continuous.get(self.body_joints[i], False):
                kind = "continuous"
            parent = self.body_names[self.parent[i]] if self.parent[i] >= 0 else "(world)"
            lines.append(
                f"  {self.body_joints[i]:<28} {kind:<10} {parent} -> "
                f"{self.body_names[i]}  mass {self.G[i, 3, 3]:.4g} kg"
            )
        return "\n".join(lines)
