"""Pfaffian constraints A(q) qd = 0 on a robot, as frozen data (the seed notes, "Constrained
Dynamics"): each constraint contributes k_i rows of A(q), of Adot(q, qd) qd and of its position
error phi(q), whose time derivative is A qd:

    PointToWorld   3 rows  a point of a frame held at a world point     phi = p - target
    PointOnPlane   1 row   a point of a frame kept on a world plane     phi = n . p - offset
    PointToPoint   3 rows  two points of two frames coincide (loop)    phi = p_a - p_b
    FixedPose      6 rows  frame b keeps the pose T_ab relative to a    phi = log(T_ab*^-1 T_ab)
    JointCoupling  k rows  a constant (k, nv) matrix C: C qd = 0        phi = C (q (-) q_ref)

q is a configuration (nq,) and qd a velocity (nv,): on a floating base q = (p, quat, q_joints)
and qd = v = (omega_b, v_b, qd_joints), so A is (k, nv) and its base columns are the base's
body-twist coordinates (angular first); Adot qd is the rate of A qd at qdd = 0 with qdd the
time derivative of v (as everywhere in opendyn), so that d/dt (A qd) = A qdd + Adot qd.
q (-) q_ref = opendyn.difference(model, q_ref, q), the velocity (nv,) that moves q_ref to q in
unit time: q - q_ref on a fixed-base model.

Points are in metres, in their frame's coordinates; world vectors (targets, normals) are in the
world frame (the root link). Point rows are world axes: A qd is the point's velocity in the
world frame (m/s) and Adot qd its classical acceleration at qdd = 0 without gravity. FixedPose
rows are the twist of frame b relative to frame a, in frame b's axes, angular first:
    A qd = V_b - Ad_{T_ba} V_a   (V_a, V_b: each frame's body twist; rad/s, m/s)
and phi is the se(3) logarithm (angular first, frame b axes) of T_ab*^-1 T_ab, the pose of
frame b relative to where it should be; d/dt phi = A qd where phi = 0.

A target, offset, pose or reference configuration left None is bound at the configuration the
constraint is bound at: `opendyn.algorithm.constraints.constraint_table(model, constraints, q0)`
resolves it at q0. Each class validates its fields when built and raises ValueError naming the
class and the field (TypeError for a field that is not numbers: text, booleans, complex).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._runtime.options import as_float_array

# kinds, as in the rows of the compiled constraint table (column 0)
POINT_TO_WORLD = 0
POINT_ON_PLANE = 1
POINT_TO_POINT = 2
FIXED_POSE = 3
JOINT_COUPLING = 4

_ORTHONORMAL_TOLERANCE = 1e-9


def _fail(cls, field, message):
    raise ValueError(f"{cls.__name__}: {field} {message}")


def _name(cls, field, value):
    if not isinstance(value, str) or not value:
        _fail(cls, field, f"must be a frame name (a non-empty string), got {value!r}")
    return value


def _vector(cls, field, value, size=3):
    """value as a tuple of `size` finite floats; size None: any number of them, at least one
    (a configuration, checked against the model when bound)."""
    try:
        x = as_float_array(value, f"{cls.__name__}: {field}")
    except ValueError:
        count = "numbers" if size is None else "a number" if size == 1 else f"{size} numbers"
        _fail(cls, field, f"must be {count}, got {value!r}")
    if size is None:
        if x.ndim != 1 or x.size == 0:
            _fail(cls, field, f"must be a vector of shape (nq,), got shape {x.shape}")
    elif x.shape != (size,):
        _fail(cls, field, f"must have shape ({size},), got shape {x.shape}")
    if not np.all(np.isfinite(x)):
        _fail(cls, field, f"must be finite, got {x}")
    return tuple(float(v) for v in x)


def _transform(cls, field, value):
    """value as a (4, 4) tuple of tuples: a rigid transform [[R, p], [0, 0, 0, 1]]."""
    try:
        T = as_float_array(value, f"{cls.__name__}: {field}")
    except ValueError:
        _fail(cls, field, f"must be a (4, 4) homogeneous transform, got {value!r}")
    if T.shape != (4, 4):
        _fail(cls, field, f"must be a (4, 4) homogeneous transform, got shape {T.shape}")
    if not np.all(np.isfinite(T)):
        _fail(cls, field, "must be finite")
    R = T[:3, :3]
    if (
        np.abs(T[3] - (0.0, 0.0, 0.0, 1.0)).max() > 0.0
        or np.abs(R.T @ R - np.eye(3)).max() > _ORTHONORMAL_TOLERANCE
        or np.linalg.det(R) < 0.0
    ):
        _fail(
            cls,
            field,
            "must be a rigid transform: rotation block orthonormal with determinant +1 "
            f"(within {_ORTHONORMAL_TOLERANCE:g}) and last row (0, 0, 0, 1)",
        )
    return tuple(tuple(float(v) for v in row) for row in T)


@dataclass(frozen=True)
class PointToWorld:
    """The point `point` (m, in `frame`'s coordinates) of `frame` is held at the world point
    `target` (m, world frame). 3 rows, world axes: A qd = the point's velocity in the world.

    target None: where the point is at the configuration the constraint is bound at.
    phi = p(q) - target (3,), m.
    """

    frame: str
    point: tuple = (0.0, 0.0, 0.0)
    target: tuple | None = None

    kind = POINT_TO_WORLD

    def __post_init__(self):
        cls = type(self)
        object.__setattr__(self, "frame", _name(cls, "frame", self.frame))
        object.__setattr__(self, "point", _vector(cls, "point", self.point))
        if self.target is not None:
            object.__setattr__(self, "target", _vector(cls, "target", self.target))

    def n_rows(self, nv):
        """Rows of A this constraint contributes: 3."""
        return 3


@dataclass(frozen=True)
class PointOnPlane:
    """The point `point` (m, in `frame`'s coordinates) of `frame` stays on the world plane
    n . x = offset; `normal` (3,) is a world-frame direction, normalised here. 1 row:
    A qd = n . (the point's velocity in the world).

    offset None (m): the plane through the point at the configuration the constraint is bound at.
    phi = n . p(q) - offset, m.
    """

    frame: str
    normal: tuple
    point: tuple = (0.0, 0.0, 0.0)
    offset: float | None = None

    kind = POINT_ON_PLANE

    def __post_init__(self):
        cls = type(self)
        object.__setattr__(self, "frame", _name(cls, "frame", self.frame))
        n = np.array(_vector(cls, "normal", self.normal))
        norm = np.linalg.norm(n)
        if not norm > 0.0:
            _fail(cls, "normal", "must be a non-zero vector (the plane's normal, world frame)")
        object.__setattr__(self, "normal", tuple(float(v) for v in n / norm))
        object.__setattr__(self, "point", _vector(cls, "point", self.point))
        if self.offset is not None:
            object.__setattr__(self, "offset", _vector(cls, "offset", [self.offset], 1)[0])

    def n_rows(self, nv):
        """Rows of A this constraint contributes: 1."""
        return 1


@dataclass(frozen=True)
class PointToPoint:
    """Loop closure: the point `point_a` of `frame_a` and `point_b` of `frame_b` (m, each in
    its frame's coordinates) coincide. 3 rows, world axes: A qd = v_a - v_b, the points'
    velocities in the world. Either frame may be a frame of the fixed world, not both.

    phi = p_a(q) - p_b(q) (3,), m.
    """

    frame_a: str
    frame_b: str
    point_a: tuple = (0.0, 0.0, 0.0)
    point_b: tuple = (0.0, 0.0, 0.0)

    kind = POINT_TO_POINT

    def __post_init__(self):
        cls = type(self)
        object.__setattr__(self, "frame_a", _name(cls, "frame_a", self.frame_a))
        object.__setattr__(self, "frame_b", _name(cls, "frame_b", self.frame_b))
        object.__setattr__(self, "point_a", _vector(cls, "point_a", self.point_a))
        object.__setattr__(self, "point_b", _vector(cls, "point_b", self.point_b))

    def n_rows(self, nv):
        """Rows of A this constraint contributes: 3."""
        return 3


@dataclass(frozen=True)
class FixedPose:
    """Weld: frame b keeps the pose T_ab (4, 4; m) relative to frame a. 6 rows, the twist of
    frame b relative to frame a in frame b's axes, angular first:
        A qd = V_b - Ad_{T_ba} V_a      (V_a, V_b: body twists of the frames)
    Either frame may be a frame of the fixed world, not both (with a = world, A qd = V_b).

    T_ab None: the relative pose at the configuration the constraint is bound at.
    phi = log(T_ab*^-1 T_ab(q)) (6,): se(3) exponential coordinates (rad, m) of frame b's pose
    relative to its target pose, angular first, frame b axes; d/dt phi = A qd where phi = 0.
    """

    frame_a: str
    frame_b: str
    T_ab: tuple | None = None

    kind = FIXED_POSE

    def __post_init__(self):
        cls = type(self)
        object.__setattr__(self, "frame_a", _name(cls, "frame_a", self.frame_a))
        object.__setattr__(self, "frame_b", _name(cls, "frame_b", self.frame_b))
        if self.T_ab is not None:
            object.__setattr__(self, "T_ab", _transform(cls, "T_ab", self.T_ab))

    def n_rows(self, nv):
        """Rows of A this constraint contributes: 6."""
        return 6


@dataclass(frozen=True)
class JointCoupling:
    """A constant (k, nv) matrix C of couplings between velocity coordinates: C qd = 0
    (Adot = 0); e.g. C = [[0, 1, -1]] makes qd_1 = qd_2. C acts on v-space: on a floating base
    its first 6 columns weigh the base's body twist (omega_b, v_b). Its shape is checked
    against the model when bound.

    q_ref (nq,) None: the configuration the constraint is bound at. phi (k,) is defined on
    v-space, as C times the velocity that moves q_ref to q in unit time:
        phi = C (q (-) q_ref) = C opendyn.difference(model, q_ref, q),
    which is C (q - q_ref) on a fixed-base model (nq = nv). With a free joint, q - q_ref would
    not even have nv entries: the base part of the difference is log(T_ref^-1 T) (angular
    first, base frame), whose rate is the base twist where it is zero, so d/dt phi = A qd there
    (as for FixedPose) and everywhere for the joint coordinates.
    """

    A: tuple
    q_ref: tuple | None = None

    kind = JOINT_COUPLING

    def __post_init__(self):
        cls = type(self)
        try:
            C = as_float_array(self.A, f"{cls.__name__}: A")
        except ValueError:
            _fail(cls, "A", f"must be a (k, nv) matrix of numbers, got {self.A!r}")
        if C.ndim == 1 and C.size:
            C = C[None]
        if C.ndim != 2 or C.shape[0] == 0 or C.shape[1] == 0:
            _fail(cls, "A", f"must be a (k, nv) matrix with k >= 1, got shape {C.shape}")
        if not np.all(np.isfinite(C)):
            _fail(cls, "A", "must be finite")
        object.__setattr__(self, "A", tuple(tuple(float(v) for v in row) for row in C))
        if self.q_ref is not None:
            object.__setattr__(self, "q_ref", _vector(cls, "q_ref", self.q_ref, None))

    @property
    def matrix(self):
        """C as a (k, nv) float64 array."""
        return np.array(self.A, dtype=np.float64)

    def n_rows(self, nv):
        """Rows of A this constraint contributes: k."""
        return len(self.A)


CONSTRAINT_TYPES = (PointToWorld, PointOnPlane, PointToPoint, FixedPose, JointCoupling)

__all__ = [
    "CONSTRAINT_TYPES",
    "FIXED_POSE",
    "JOINT_COUPLING",
    "POINT_ON_PLANE",
    "POINT_TO_POINT",
    "POINT_TO_WORLD",
    "FixedPose",
    "JointCoupling",
    "PointOnPlane",
    "PointToPoint",
    "PointToWorld",
]
