"""The frozen robot model: screw axes A_i, home transforms M_{i,i-1}, spatial inertias G_i.

A kinematic tree of ``nb`` moving bodies. Body ``i`` is the child link of the i-th moving joint
(revolute, continuous or prismatic) with every link welded to it by fixed joints lumped in. Its
frame {i} is that child link's frame, which by the URDF convention is also the joint frame.
The configuration of {i} relative to its parent body's frame {lambda(i)} is

    T_{lambda(i), i}(q_i) = M_{lambda(i), i} exp([A_i] q_i)

with ``A_i`` the joint's screw axis expressed in {i} (angular first: (a, 0) for a revolute joint
with unit axis a, (0, a) for a prismatic one) and ``M_{lambda(i), i}`` the home transform at
``q_i = 0``. Parent index -1 is the fixed world: the root link and every link welded to it.

The body coordinates come from the generalized coordinates through an affine map
``q_body[i] = mult[i] * q[coord[i]] + offset[i]``; it is the identity (coord[i] = i, mult 1,
offset 0) except for mimic joints loaded with ``mimic=True``.

All per-body numbers live in two flat buffers (``_ibuf`` ints, ``_fbuf`` float64) that the
compiled kernels receive as two arguments, laid out by one table (INT_FIELDS, FLOAT_FIELDS);
the documented fields are read-only views into them.
Conventions: twists (omega, v) and wrenches (m, f), angular first; SI units; gravity is the
world-frame vector g, applied as the base acceleration dV_0 = (0, -g).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .spatial import linear

REVOLUTE = 0
PRISMATIC = 1


# The kernels' flat buffers, defined once: (field, shape per body). Field k of _fbuf starts at
# start_k * nb; field k of _ibuf at INT_HEADER + start_k * nb, after the header [nb, nv].
INT_HEADER = 2
INT_FIELDS = (("parent", ()), ("jtype", ()), ("coord", ()))
FLOAT_FIELDS = (
    ("mult", ()),
    ("offset", ()),
    ("A", (6,)),
    ("G", (6, 6)),
    ("mass", ()),
    ("h", (3,)),
    ("I_o", (3, 3)),
    ("R_home", (3, 3)),
    ("p_home", (3,)),
)
def field_starts(fields) -> dict[str, tuple[int, int, tuple[int, ...]]]:
    """{field: (start, size, shape)}: start and size in units of nb (numbers per body)."""
    out, start = {}, 0
    for name, shape in fields:
        size = int(np.prod(shape))
        out[name] = (start, size, shape)
        start += size
    return out


INT_AT = field_starts(INT_FIELDS)
FLOAT_AT = field_starts(FLOAT_FIELDS)


def buffer_size(at: dict, nb: int) -> int:
    """Numbers in a buffer laid out by `at` for nb bodies."""
    return sum(size for _, size, _ in at.values()) * nb


def _frame_index(frames, aliases):
    index = {f.name: k for k, f in enumerate(frames)}
    for alias, name in aliases.items():
        index.setdefault(alias, index[name])
    return index


def _readonly_view(buf, at, name, nb, header=0):
    """A read-only (nb, *shape) view of one field of a flat buffer (the buffer itself stays
    writeable, so the compiled kernels see one array type)."""
    start, size, shape = at[name]
    view = buf[header + start * nb : header + (start + size) * nb].reshape((nb, *shape))
    view.flags.writeable = False
    return view


@dataclass(frozen=True)
class Frame:
    """A named frame rigidly attached to a body: ``T_{body, frame}`` is constant.

    ``body`` is the index of the moving body the frame is welded to, or -1 for the fixed world.
    """

    name: str
    body: int
    T_body_frame: np.ndarray


@dataclass(frozen=True, eq=False)
class Model:
    """A frozen kinematic tree with its inertias, as the dynamics kernels see it.

    Fields (all read-only numpy views; nb = number of moving bodies, nv = number of coordinates;
    nq = nv for a fixed base, a continuous joint having one coordinate, its angle):
      name            robot name from the URDF
      joint_names     (nv,) names of the generalized coordinates, depth-first over the URDF tree
      body_names      (nb,) link name of each moving body (the joint's child link)
      body_joints     (nb,) name of the joint that moves each body
      parent          (nb,) int, parent body index, -1 = fixed world; parent[i] < i
      jtype           (nb,) int, REVOLUTE (0) or PRISMATIC (1); continuous joints are revolute
      coord, mult, offset  (nb,) q_body[i] = mult[i] * q[coord[i]] + offset[i]
      A               (nb, 6) screw axis of joint i in {i}, angular first, unit axis
      G               (nb, 6, 6) spatial inertia of body i about the origin of {i}, in {i} (kg, m)
      mass, h, I_o    (nb,), (nb, 3), (nb, 3, 3): the same inertia as mass, first moment m c (kg m)
                      and rotational inertia about {i}'s origin (kg m^2), all in {i}
      R_home, p_home  (nb, 3, 3), (nb, 3): M_{lambda(i), i} = (R_home[i], p_home[i]) in metres
      lower, upper    (nv,) position limits (rad or m); -inf/+inf where the joint has none
      velocity_limit, effort_limit (nv,) (rad/s or m/s, N m or N); +inf where absent
      damping, friction (nv,) from the URDF ``<dynamics>`` (N m s/rad or N s/m; N m or N)
      continuous      (nv,) bool, joint is continuous (unbounded angle)
      frames          tuple of Frame, one per URDF link, by name; a joint's name also finds the
                      frame of its child link (the URDF joint frame)
      gravity         (3,) default gravity vector in the world frame (m/s^2)
      report          the loader's FidelityReport (what was honoured, transformed, ignored)
    """

    name: str
    joint_names: tuple[str, ...]
    body_names: tuple[str, ...]
    body_joints: tuple[str, ...]
    frames: tuple[Frame, ...]
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
        coord,
        mult,
        offset,
        A,
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
        gravity=(0.0, 0.0, -9.81),
        report=None,
        source="",
        frame_aliases=None,
    ):
        """Pack per-body arrays into the kernels' flat buffers and freeze everything.

        frame_aliases: {other name: frame name}, e.g. each URDF joint's name for its child link
        (the URDF joint frame is the child link's frame); a frame's own name always wins.
        """
        nb, nv = len(body_names), len(joint_names)
        ibuf = np.zeros(INT_HEADER + buffer_size(INT_AT, nb), dtype=np.int64)
        fbuf = np.zeros(buffer_size(FLOAT_AT, nb), dtype=np.float64)
        ibuf[0], ibuf[1] = nb, nv
        for key, arr in (("parent", parent), ("jtype", jtype), ("coord", coord)):
            start, size, _ = INT_AT[key]
            ibuf[INT_HEADER + start * nb : INT_HEADER + (start + size) * nb] = np.asarray(
                arr, dtype=np.int64
            ).ravel()
        G = np.reshape(np.asarray(G, dtype=np.float64), (nb, 6, 6))
        # the same inertia in rigid-body form: mass m, first moment h = m c, I_o about {i}'s
        # origin; G = [[I_o, [h]], [[h]^T, m 1]]
        mass = G[:, 3, 3]
        h = np.stack([G[:, 2, 4], G[:, 0, 5], G[:, 1, 3]], axis=-1)
        I_o = G[:, :3, :3]
        for key, arr in (
            ("mult", mult),
            ("offset", offset),
            ("A", A),
            ("G", G),
            ("mass", mass),
            ("h", h),
            ("I_o", I_o),
            ("R_home", R_home),
            ("p_home", p_home),
        ):
            start, size, _ = FLOAT_AT[key]
            fbuf[start * nb : (start + size) * nb] = np.asarray(arr, dtype=np.float64).ravel()

        def frozen(x, dtype=np.float64):
            a = np.array(x, dtype=dtype)
            a.flags.writeable = False
            return a

        frames = tuple(Frame(f.name, f.body, frozen(f.T_body_frame)) for f in frames)
        return cls(
            name=name,
            joint_names=tuple(joint_names),
            body_names=tuple(body_names),
            body_joints=tuple(body_joints),
            frames=frames,
            lower=frozen(lower),
            upper=frozen(upper),
            velocity_limit=frozen(velocity_limit),
            effort_limit=frozen(effort_limit),
            damping=frozen(damping),
            friction=frozen(friction),
            continuous=frozen(continuous, bool),
            gravity=frozen(gravity),
            _ibuf=ibuf,
            _fbuf=fbuf,
            report=report,
            source=source,
            _frame_index=_frame_index(frames, frame_aliases or {}),
        )

    def _ifield(self, key):
        return _readonly_view(self._ibuf, INT_AT, key, self.nb, INT_HEADER)

    def _ffield(self, key):
        return _readonly_view(self._fbuf, FLOAT_AT, key, self.nb)

    def __post_init__(self):
        # plain attributes, read on every call: nb bodies, nq = nv coordinates (fixed base)
        object.__setattr__(self, "nb", int(self._ibuf[0]))
        object.__setattr__(self, "nv", int(self._ibuf[1]))
        object.__setattr__(self, "nq", int(self._ibuf[1]))
        # writeable private copies handed to the kernels (one array type per argument, so
        # numba compiles each kernel once), never exposed
        object.__setattr__(self, "_vector_shape", (self.nv,))
        object.__setattr__(self, "_matrix_shape", (self.nv, self.nv))
        object.__setattr__(self, "_zero_v", np.zeros(self.nv))
        object.__setattr__(self, "_gravity", np.array(self.gravity))
        loads = np.zeros((1, 6))
        linear(loads[0])[:] = -self._gravity  # the kernels' dV_0 = (0, -g), no wrenches
        object.__setattr__(self, "_loads", loads)

    parent = property(lambda self: self._ifield("parent"), doc="(nb,) parent body, -1 = world")
    jtype = property(lambda self: self._ifield("jtype"), doc="(nb,) REVOLUTE=0 / PRISMATIC=1")
    coord = property(lambda self: self._ifield("coord"), doc="(nb,) coordinate of each body")
    mult = property(lambda self: self._ffield("mult"), doc="(nb,) mimic multiplier")
    offset = property(lambda self: self._ffield("offset"), doc="(nb,) mimic offset")
    A = property(lambda self: self._ffield("A"), doc="(nb, 6) screw axes A_i in {i}")
    G = property(lambda self: self._ffield("G"), doc="(nb, 6, 6) spatial inertias G_i in {i}")
    mass = property(lambda self: self._ffield("mass"), doc="(nb,) body masses (kg)")
    h = property(lambda self: self._ffield("h"), doc="(nb, 3) first moments m c in {i} (kg m)")
    I_o = property(lambda self: self._ffield("I_o"), doc="(nb, 3, 3) inertia about {i}'s origin")
    R_home = property(lambda self: self._ffield("R_home"), doc="(nb, 3, 3) rotation of M_{p,i}")
    p_home = property(lambda self: self._ffield("p_home"), doc="(nb, 3) translation of M_{p,i}")

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
            f"{len(self.frames)} frames, total moving mass "
            f"{float(self.G[:, 3, 3].sum()) if self.nb else 0.0:.4g} kg"
        ]
        for i in range(self.nb):
            j = int(self.coord[i])
            kind = (
                "prismatic"
                if self.jtype[i] == PRISMATIC
                else ("continuous" if self.continuous[j] else "revolute")
            )
            parent = self.body_names[self.parent[i]] if self.parent[i] >= 0 else "(world)"
            lines.append(
                f"  {self.body_joints[i]:<28} {kind:<10} {parent} -> "
                f"{self.body_names[i]}  mass {self.G[i, 3, 3]:.4g} kg"
            )
        return "\n".join(lines)
