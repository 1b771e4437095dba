"""Scene files: a TOML description of one simulation -> a validated, frozen ``Scene``.

A scene names the robot, its initial state, the run settings, the physical effects that exist
and the control. An effect that a scene does not name is off: the simulator never computes it.
Every number is checked here (type, shape, sign, finiteness, joint and frame names), so a scene
that loads is one the simulator can run; anything else raises ``SceneError`` naming the file,
the dotted key (``effects.damping.coefficients``), what was expected and what was found. What
depends on the run as a whole (the record's size against the memory available, the initial
state's speed, energy and limits) is checked by ``simulate`` before it allocates or compiles
anything (opendyn.sim.preflight), with the same kind of message.

Conventions (as in the rest of opendyn): SI units (rad or m, N m or N, s); twists (omega, v) and
wrenches (m, f), moment first; per-joint arrays are ordered as ``model.joint_names``
(depth-first over the URDF tree); gravity is the world-frame vector g (the acceleration of a
falling body, default (0, 0, -9.81) m/s^2). The generalized forces of the effects, on the right
of M(q) qdd + h(q, qd) = tau + ..., are:

    damping      -b * qd                          b >= 0 per joint (N m s/rad or N s/m)
    friction     -c * tanh(qd / smoothing)        c >= 0 per joint (N m or N), smoothing > 0
    armature     M(q) + diag(a)                   a >= 0 per joint (kg m^2 or kg)
    limits       -k (q - upper) - d qd  where q > upper;  -k (q - lower) - d qd  where q < lower
    wrench       J_b(frame)^T F  (or the world-aligned Jacobian for expressed_in = "world")
    contact      sum_p J_p^T f_p at each contact sphere's lowest point x_p (world frame):
                 delta = max(0, ground_height - x_z), f_n = max(0, k delta + d delta_dot) along
                 +z, f_t = -mu f_n v_t / sqrt(|v_t|^2 + slip_velocity^2)
    control      tau of the controller, optionally clipped to +-effort_limit

A wrench F = (m, f) of a scene is the wrench the environment applies TO THE ROBOT at the
frame's origin (a push), the opposite sign of the dynamics functions' ``f_tip``, which is the
wrench the frame applies to the environment (so ``f_tip = {frame: -F}`` in frame coordinates).
``expressed_in = "frame"`` gives m and f in the frame's own axes; ``"world"`` gives them in
axes parallel to the world's, still about the frame's origin.

The file format (every key optional unless marked required):

    name = "double pendulum swinging"      # default: the file stem
    description = "..."                    # free text

    [robot]                                # required: exactly one of urdf and name
    urdf = "double_pendulum.urdf"          # a URDF path, relative to the scene file's folder
    # name = "ur5"                         # or a robot name that load_urdf resolves
    mimic = false                          # passed to load_urdf
    check_inertia = true                   # passed to load_urdf
    floating_base = false                  # passed to load_urdf: true makes the root link a
                                           # free body (a 6-dof base, unactuated)
    [robot.payload]                        # a rigid payload welded to a frame: its inertia is
                                           # added to the frame's body (model.with_payload)
    frame = "tool0"                        # required: a frame (link or joint name) that moves
    mass = 2.5                             # required: kg >= 0
    com = [0.0, 0.0, 0.05]                 # m, its centre of mass in the frame (default 0)
    inertia = { ixx = 0.01, iyy = 0.01, izz = 0.005 }   # kg m^2 about the centre of mass,
                                           # frame axes, as a URDF <inertia>: ixx iyy izz ixy
                                           # ixz iyz, missing entries 0 (default: a point mass)

    [initial]
    q = { shoulder = 1.0 }                 # a table {joint = value} (others 0) or a list with
                                           # one number per joint (model.joint_names)
    qd = [0.0, 0.0]                        # the same; default zeros
    # a floating base only (each optional; default: at the origin, upright, at rest):
    base_position = [0.0, 0.0, 0.5]        # m, the root frame's origin in the world
    base_orientation = [0.0, 0.0, 0.0, 1.0]  # unit quaternion (x, y, z, w), root frame in world
    # base_rpy = [0.0, 0.0, 0.0]           # or roll, pitch, yaw (rad, as a URDF <origin>);
                                           # not both
    base_velocity = [0.0, 0.0, 0.0]        # m/s, the root frame origin's velocity, world axes
    base_angular_velocity = [0.0, 0.0, 0.0]  # rad/s, the root's angular velocity, world axes

    [run]
    duration = 10.0                        # s, > 0 (default 5); for a fixed-step integrator
                                           # a whole number of steps dt
    integrator = "rk4"                     # euler, semi_implicit_euler, rk4, dopri5,
                                           # implicit_euler (default rk4)
    dt = 0.001                             # s, > 0: the fixed step, or dopri5's first trial step
    output_dt = 0.01                       # s: recorded sample interval (default 0.01, or dt if
                                           # dt > 0.01); a whole multiple of dt for fixed steps
    rtol = 1e-6                            # dopri5's tolerances
    atol = 1e-9
    max_speed = 1e4                        # rad/s or m/s: a faster joint stops the run

    [effects]
    gravity = true                         # true = the model's gravity; a vector [gx, gy, gz]
                                           # in m/s^2; false or absent = no gravity
    [effects.damping]                      # a table that is present switches the effect on
    coefficients = "urdf"                  # "urdf" (default: <dynamics damping>), a number (every
                                           # joint), a list (one per joint), or a table
                                           # {joint = value}
    [effects.friction]
    coefficients = "urdf"                  # as damping, from <dynamics friction>
    smoothing = 0.01                       # rad/s or m/s, > 0
    [effects.armature]
    values = 0.1                           # required: number, list or table
    [effects.limits]
    stiffness = 1e4                        # required: number, list or table; acts only on
                                           # joints with a finite limit (a number is 0 elsewhere)
    damping = 10.0                         # default 0

    [effects.contact]                      # the ground: the plane z = ground_height, normal +z
    ground_height = 0.0                    # m (world frame; default 0)
    stiffness = 1e5                        # required: N/m, the normal spring k > 0
    damping = 0.0                          # N s/m, the normal damper d >= 0 (default 0)
    friction = 0.8                         # required: the Coulomb coefficient mu >= 0 (0 =
                                           # frictionless)
    slip_velocity = 1e-3                   # m/s > 0, regularises friction near zero slip
    points = "urdf"                        # required: "urdf" (the spheres and box corners of
                                           # the URDF's <collision> elements) or tables:
    # [[effects.contact.points]]
    # frame = "FL_FOOT"                    # required: a frame (link or joint name) that moves
    # position = [0.0, 0.0, 0.0]           # m, the sphere's centre in the frame (default 0)
    # radius = 0.02                        # m >= 0 (default 0: a point)

    [[effects.wrench]]                     # any number of these
    frame = "tip"                          # required: a frame (link) or joint name
    expressed_in = "frame"                 # "frame" (default) or "world"
    value = [0, 0, 0, 0, 0, -10]           # a constant (m, f) applied to the robot; or
    # times = [0.0, 1.0, 2.0]              # strictly increasing times (s) and one wrench per
    # values = [[...], [...], [...]]       # time: linear in between, held outside

    [control]
    type = "pd"                            # "none" (default), "constant", "pd", "computed_torque"
    tau = 1.0                              # constant: tau (required)
    kp = 100.0                             # pd, computed_torque: gains (required)
    kd = 20.0
    setpoint = { shoulder = 0.5 }          # pd: tau = kp (setpoint - q) - kd qd; default q0
    offset = [0.0, 0.0]                    # computed_torque: q_r(t) = offset + amplitude
    amplitude = 0.1                        #   sin(2 pi frequency t + phase); offset default q0,
    frequency = 0.5                        #   amplitude and phase 0, frequency 0.5 Hz;
    phase = 0.0                            #   the torque is M (qdd_r + kd ed + kp e) + h
    clip = false                           # clip the torque to +-effort_limit

    [[constraints]]                        # any number of these: A(q) qd = 0 (see below)
    type = "point_to_point"                # loop closure: two points coincide
    frame_a = "rocker"                     # required: frames (link or joint names)
    point_a = [0.4, 0.0, 0.0]              # m, in frame_a's coordinates (default the origin)
    frame_b = "base_link"                  # a frame of the fixed world is fine
    point_b = [0.8, 0.0, 0.0]
    # type = "point_to_world": frame, point, target ([x, y, z] world; default: where the
    #                          point is at the initial state)
    # type = "point_on_plane": frame, point, normal (required, world), offset (n . x = offset;
    #                          default: the plane through the point at the initial state)
    # type = "fixed_pose":     frame_a, frame_b, xyz, rpy (frame_b's pose in frame_a; default
    #                          the initial relative pose)
    # type = "joint_coupling": coefficients = {joint = c} (sum c_j qd_j = 0) or
    #                          matrix = [[nv numbers], ...] (rows of a constant A)

    [baumgarte]                            # optional drift stabilisation of the constraints:
    alpha = 10.0                           # 1/s   A qdd + Adot qd + 2 alpha A qd
    beta = 10.0                            # 1/s                 + beta^2 phi = 0

Every per-joint value (gains, coefficients, tau...) is a number for every joint, a list of one
number per joint (model.joint_names), or a table by joint name; joints a table does not name take
the key's default (0, or q0 for ``setpoint`` and ``offset``). They act on the joint coordinates
only: a floating base is moved by gravity, wrenches and the joints' reactions, never damped or
actuated directly.

A floating base's initial motion is given in world axes (as one thinks of it) and stored as the
body twist of the convention, v = (omega_b, v_b, qd_joints) with omega_b = R^T omega_s and
v_b = R^T p_dot (R the base's orientation in the world); q0 = (p, quat, q_joints).

Constraints (the seed's Pfaffian constraints A(q) qd = 0) add the forces A^T lambda that keep
them, lambda solved with the accelerations at every evaluation (opendyn.algorithm.constraints).
The initial state must satisfy them (position and velocity within CONSTRAINT_TOLERANCE).
Integrating A qdd + Adot qd = 0 lets the position error phi drift; [baumgarte] pulls it back
(alpha = beta = w: a critically damped error at rate w). The trajectory records the largest
|phi| and |A qd| of every sample.
"""

from __future__ import annotations

import dataclasses
import difflib
import math
import numbers
import os
import pathlib
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np
from scipy.spatial.transform import Rotation

from .._runtime.arrays import immutable
from ..errors import SceneError, URDFError
from ..multibody.constraint_objects import (
    FixedPose,
    JointCoupling,
    PointOnPlane,
    PointToPoint,
    PointToWorld,
)
from ..multibody.joints import FREE
from ..multibody.model import Model
from .urdf import available_robots, load_urdf, shipped_robots_dir

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

INTEGRATORS = ("euler", "semi_implicit_euler", "rk4", "dopri5", "implicit_euler")
EFFECTS = (
    "gravity", "damping", "friction", "armature", "limits", "wrench", "contact", "control"
)
CONTROL_TYPES = ("none", "constant", "pd", "computed_torque")
CONSTRAINT_TYPES = (
    "point_to_world",
    "point_on_plane",
    "point_to_point",
    "fixed_pose",
    "joint_coupling",
)
_CONSTRAINT_KEYS = {
    "point_to_world": ("type", "frame", "point", "target"),
    "point_on_plane": ("type", "frame", "normal", "point", "offset"),
    "point_to_point": ("type", "frame_a", "frame_b", "point_a", "point_b"),
    "fixed_pose": ("type", "frame_a", "frame_b", "xyz", "rpy"),
    "joint_coupling": ("type", "coefficients", "matrix"),
}
# an initial state farther than this from the constraints (m or rad; m/s or rad/s) is refused
CONSTRAINT_TOLERANCE = 1e-6
EXPRESSED_IN = ("frame", "world")
ADAPTIVE_INTEGRATORS = ("dopri5",)
DEFAULT_SCENE = "double_pendulum_swing"

_TOP_KEYS = (
    "name",
    "description",
    "robot",
    "initial",
    "run",
    "effects",
    "control",
    "constraints",
    "baumgarte",
)
_ROBOT_KEYS = ("urdf", "name", "mimic", "check_inertia", "floating_base", "payload")
_PAYLOAD_KEYS = ("frame", "mass", "com", "inertia")
# a URDF <inertia>'s attributes, each the entry (row, column) of the symmetric matrix
_INERTIA_ENTRIES = {
    "ixx": (0, 0), "iyy": (1, 1), "izz": (2, 2), "ixy": (0, 1), "ixz": (0, 2), "iyz": (1, 2)
}
_BASE_KEYS = (
    "base_position",
    "base_orientation",
    "base_rpy",
    "base_velocity",
    "base_angular_velocity",
)
_INITIAL_KEYS = ("q", "qd") + _BASE_KEYS
# a base_orientation quaternion whose norm is off 1 by more than this is refused as a mistake
BASE_QUATERNION_TOLERANCE = 1e-6
_RUN_KEYS = ("duration", "integrator", "dt", "output_dt", "rtol", "atol", "max_speed")
_EFFECT_KEYS = ("gravity", "damping", "friction", "armature", "limits", "wrench", "contact")
_CONTACT_KEYS = (
    "ground_height", "stiffness", "damping", "friction", "slip_velocity", "points"
)
_CONTACT_POINT_KEYS = ("frame", "position", "radius")
_CONTROL_KEYS = {
    "none": ("type",),
    "constant": ("type", "tau", "clip"),
    "pd": ("type", "kp", "kd", "setpoint", "clip"),
    "computed_torque": (
        "type",
        "kp",
        "kd",
        "offset",
        "amplitude",
        "frequency",
        "phase",
        "clip",
    ),
}
# a ratio of times counts as a whole number of steps within this relative tolerance
_WHOLE_STEPS_RTOL = 1e-9
# float64 counts steps exactly up to 2^53; a run of more steps could not say which step failed
MAX_STEPS = 2**53


@dataclass(frozen=True)
class Run:
    """How to advance a scene in time.

    duration: s, > 0. integrator: one of INTEGRATORS. dt: s, the step of fixed-step integrators,
    the first trial step of "dopri5". rtol, atol: "dopri5"'s tolerances. output_dt: s, the
    sample interval of the recorded trajectory (a whole multiple of dt for fixed-step
    integrators). max_speed: rad/s or m/s; any |qd| above it stops the run as diverging.
    """

    duration: float = 5.0
    integrator: str = "rk4"
    dt: float = 1e-3
    rtol: float = 1e-6
    atol: float = 1e-9
    output_dt: float = 0.01
    max_speed: float = 1e4


@dataclass(frozen=True, eq=False)
class Friction:
    """Smoothed Coulomb friction: generalized force -coulomb * tanh(qd / smoothing).

    coulomb: (n,) per joint, N m or N, >= 0. smoothing: rad/s or m/s, > 0.
    """

    coulomb: np.ndarray
    smoothing: float = 0.01


@dataclass(frozen=True, eq=False)
class Limits:
    """Joint-limit spring-dampers, acting only beyond a limit:
    -stiffness (q - upper) - damping qd where q > upper, -stiffness (q - lower) - damping qd
    where q < lower.

    stiffness: (n,) per joint, N m/rad or N/m, >= 0; damping: (n,) N m s/rad or N s/m, >= 0;
    both 0 where the joint has no finite limit. lower, upper: (n,) rad or m, the model's limits.
    """

    stiffness: np.ndarray
    damping: np.ndarray
    lower: np.ndarray
    upper: np.ndarray


@dataclass(frozen=True, eq=False)
class Wrench:
    """A wrench the environment applies TO THE ROBOT at a frame's origin.

    frame: a frame name of the model (a joint name finds its child link's frame).
    expressed_in: "frame" (the frame's own axes) or "world" (world-aligned axes at the frame's
    origin). times: (K,) s, strictly increasing. values: (K, 6) (m in N m, f in N); piecewise
    linear in t between the samples, held constant before the first and after the last.
    """

    frame: str
    expressed_in: str
    times: np.ndarray
    values: np.ndarray

    def at(self, t: float) -> np.ndarray:
        """(6,) the wrench (m, f) at time t (s), in the axes of ``expressed_in``."""
        if len(self.times) == 1:
            return self.values[0].copy()
        return np.array([np.interp(t, self.times, self.values[:, k]) for k in range(6)])


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
    N s/m >= 0; friction mu >= 0; slip_velocity v_s m/s > 0; points: the spheres."""

    ground_height: float
    stiffness: float
    damping: float
    friction: float
    slip_velocity: float
    points: tuple[ContactPoint, ...]


@dataclass(frozen=True, eq=False)
class Control:
    """A joint-space controller; fields that its kind does not use are None.

    kind: "constant", "pd" or "computed_torque"; every array has one entry per joint (n,), in
    model.joint_names order. tau: N m or N (constant). kp, kd: gains (pd, computed_torque).
    setpoint: rad or m (pd: tau = kp (setpoint - q) - kd qd).
    offset, amplitude: rad or m; frequency: Hz; phase: rad (computed_torque
    reference q_r(t) = offset + amplitude sin(2 pi frequency t + phase)). clip: clip the torque
    to +-model.effort_limit.
    """

    kind: str
    tau: np.ndarray | None = None
    kp: np.ndarray | None = None
    kd: np.ndarray | None = None
    setpoint: np.ndarray | None = None
    offset: np.ndarray | None = None
    amplitude: np.ndarray | None = None
    frequency: np.ndarray | None = None
    phase: np.ndarray | None = None
    clip: bool = False


@dataclass(frozen=True, eq=False)
class Scene:
    """A robot, its initial state, the effects that exist, the control and the run settings.

    model: the robot's Model, carrying the payload of [robot.payload] when the scene names one
    (``Model.with_payload``). q0: (nq,) rad or m, with a floating base (p, quat (x, y, z, w),
    q_joints); qd0: (nv,) rad/s or m/s, with a floating base (omega_b, v_b, qd_joints) the
    base twist in its own frame. gravity: (3,) world-frame m/s^2 or None. The per-joint arrays
    (damping, friction, armature, limits, control) have one entry per joint, in
    model.joint_names order (n = nv without a floating base, nv - 6 with one). damping: (n,)
    viscous coefficients or None. armature: (n,) or None. wrenches: () when none is applied.
    contact: ground contact (Contact) or None. control: None = zero torque. source: the scene
    file, "<dict>" or "<robot NAME>". settings: the scene as read, for provenance records: a
    read-only mapping (tables as mappings, lists as tuples; ``thaw(scene.settings)`` is a plain
    dict to edit and pass to scene_from_dict). Every array is immutable.
    An effect that is None (or, for wrenches, empty) is never computed.
    constraints: Pfaffian constraints A(q) qd = 0 (opendyn.multibody.constraint_objects objects),
    () for none; baumgarte: (alpha, beta) 1/s, the stabilisation A qdd + Adot qd + 2 alpha A qd +
    beta^2 phi = 0 of their drift, or None (A qdd + Adot qd = 0: the drift is left alone).
    """

    name: str
    model: Model
    q0: np.ndarray
    qd0: np.ndarray
    run: Run
    gravity: np.ndarray | None
    damping: np.ndarray | None
    friction: Friction | None
    armature: np.ndarray | None
    limits: Limits | None
    wrenches: tuple[Wrench, ...]
    control: Control | None
    source: str
    settings: Mapping
    constraints: tuple = ()
    baumgarte: tuple[float, float] | None = None
    contact: Contact | None = None

    def __post_init__(self):
        object.__setattr__(self, "settings", _freeze(thaw(self.settings)))

    @property
    def effects(self) -> tuple[str, ...]:
        """The names from EFFECTS that are on, in EFFECTS order."""
        on = {
            "gravity": self.gravity is not None,
            "damping": self.damping is not None,
            "friction": self.friction is not None,
            "armature": self.armature is not None,
            "limits": self.limits is not None,
            "wrench": len(self.wrenches) > 0,
            "contact": self.contact is not None,
            "control": self.control is not None,
        }
        return tuple(name for name in EFFECTS if on[name])

    def without(self, *effects: str) -> Scene:
        """The same scene with these effects (names from EFFECTS) off; ``settings`` follows."""
        for name in effects:
            if name not in EFFECTS:
                raise SceneError(
                    f"{self.source}: Scene.without: unknown effect {name!r}"
                    f"{_suggest(name, EFFECTS)}; effects: {', '.join(EFFECTS)}"
                )
        changes, settings = {}, thaw(self.settings)
        table = settings.get("effects") if isinstance(settings.get("effects"), dict) else {}
        for name in effects:
            if name == "control":
                changes["control"] = None
                settings.pop("control", None)
                continue
            changes[{"wrench": "wrenches"}.get(name, name)] = () if name == "wrench" else None
            table.pop(name, None)
        return dataclasses.replace(self, settings=settings, **changes)

    def replace_run(self, **changes) -> Scene:
        """The same scene with new Run fields (duration, integrator, dt, output_dt, rtol, atol,
        max_speed), validated as in a scene file; a value None restores that field's default."""
        for key in changes:
            if key not in _RUN_KEYS:
                raise SceneError(
                    f"{self.source}: Scene.replace_run: unknown run setting {key!r}"
                    f"{_suggest(key, _RUN_KEYS)}; valid: {', '.join(_RUN_KEYS)}"
                )
        settings = thaw(self.settings)
        table = settings.get("run") or {}
        for key, value in changes.items():
            if value is None:
                table.pop(key, None)
            else:
                table[key] = thaw(value)
        run = _Reader(self.source).run(table)
        settings["run"] = table
        return dataclasses.replace(self, run=run, settings=settings)


def load_scene(path) -> Scene:
    """Read a TOML scene file (or a shipped scene by name, e.g. ``"double_pendulum_swing"``).

    A relative ``robot.urdf`` is found from the scene file's folder. Raises SceneError naming
    the file (and the line, for malformed TOML) on any problem.
    """
    file = _resolve_scene(path)
    try:
        # utf-8-sig: a byte-order mark, as some Windows editors write, is not part of the TOML
        data = tomllib.loads(file.read_bytes().decode("utf-8-sig"))
    except tomllib.TOMLDecodeError as e:
        raise SceneError(f"{file}: malformed TOML: {e}") from None
    except UnicodeDecodeError as e:
        raise SceneError(f"{file}: not a UTF-8 text file: {e}") from None
    except OSError as e:
        raise SceneError(f"{file}: cannot read the scene file: {e.strerror or e}") from None
    return _build(data, source=str(file), base_dir=file.parent, default_name=file.stem)


def scene_from_dict(data: dict, source: str = "<dict>", base_dir=None) -> Scene:
    """A scene from a dict with the layout of the TOML file (numpy arrays are accepted where
    the file has lists). ``base_dir`` is the folder a relative ``robot.urdf`` is found from
    (default: the current directory). Raises SceneError naming ``source`` and the key."""
    base = pathlib.Path(base_dir) if base_dir is not None else pathlib.Path.cwd()
    return _build(thaw(data), source=source, base_dir=base, default_name=None)


def default_scene(robot, **run) -> Scene:
    """The plainest scene of a robot: the model's gravity and nothing else, at rest at q0 = 0
    (for a joint whose limits exclude 0, the nearer limit), no control. robot: a Model, a URDF
    path or a robot name; run: Run fields (e.g. duration=2.0).
    """
    if isinstance(robot, Model):
        model = robot
        spec = {"urdf": model.source} if model.source else {"name": model.name}
        if model.floating_base:
            spec["floating_base"] = True
    else:
        try:
            model = load_urdf(robot)
        except (URDFError, TypeError) as e:
            raise SceneError(f"<robot {robot}>: robot: {e}") from None
        spec = {"urdf": model.source}
    data = {"name": model.name, "robot": spec, "effects": {"gravity": True}, "run": thaw(run)}
    nearest = np.clip(0.0, model.lower, model.upper)
    if np.any(nearest):
        data["initial"] = {
            "q": {name: float(x) for name, x in zip(model.joint_names, nearest) if x}
        }
    return _build(data, source=f"<robot {model.name}>", base_dir=None, model=model)


def is_scene_file(path) -> bool:
    """Whether the file at `path` is a scene (TOML) rather than a URDF (XML): by its extension
    when it is .toml or .urdf/.xml in any case, otherwise by its content (a URDF's first
    character, after a byte-order mark and blank space, is '<'; a TOML file's never is)."""
    suffix = pathlib.Path(path).suffix.lower()
    if suffix in (".toml", ".urdf", ".xml"):
        return suffix == ".toml"
    with open(path, "rb") as f:
        head = f.read(4096)
    return not head.removeprefix(b"\xef\xbb\xbf").lstrip().startswith(b"<")


def shipped_scenes() -> dict[str, pathlib.Path]:
    """The scenes shipped with opendyn: name (file stem) -> path of each robots/*.toml."""
    return {p.stem: p for p in sorted(shipped_robots_dir().glob("*.toml"))}


# --- reading ---------------------------------------------------------------------------------


def _resolve_scene(path) -> pathlib.Path:
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"load_scene: path must be a file path or a scene name, not {path!r}")
    file = pathlib.Path(path)
    if file.is_file():
        return file
    shipped = shipped_scenes()
    if isinstance(path, str) and path in shipped:
        return shipped[path]
    robot = (
        f"; {path!r} is a robot: od.default_scene({path!r}) is its plainest scene"
        if path in available_robots()
        else ""
    )
    raise SceneError(
        f"{path}: no such scene file{_suggest(str(path), shipped)}; "
        f"shipped scenes: {', '.join(shipped) or '(none)'}{robot}"
    )


def _build(data, source, base_dir, default_name=None, model=None) -> Scene:
    r = _Reader(source)
    r.keys(data, "", _TOP_KEYS)
    if model is None:
        model = r.robot(data.get("robot"), base_dir)
    r.model = model
    # after the robot is loaded or given, so that a given model (a sweep's, loaded once) gets
    # the payload its scene names
    model = r.model = r.payload((data.get("robot") or {}).get("payload"))
    name = data.get("name", default_name if default_name is not None else model.name)
    r.string(name, "name")
    if "description" in data:
        r.string(data["description"], "description")
    q0, qd0 = r.initial(data.get("initial", {}))
    run = r.run(data.get("run", {}))
    effects = r.table(data.get("effects", {}), "effects")
    r.keys(effects, "effects", _EFFECT_KEYS)
    return Scene(
        name=name,
        model=model,
        q0=q0,
        qd0=qd0,
        run=run,
        gravity=r.gravity(effects.get("gravity")),
        damping=r.damping(effects.get("damping")),
        friction=r.friction(effects.get("friction")),
        armature=r.armature(effects.get("armature")),
        limits=r.limits(effects.get("limits")),
        wrenches=r.wrenches(effects.get("wrench")),
        contact=r.contact(effects.get("contact")),
        control=r.control(data.get("control"), q0[model.q_index]),
        source=source,
        settings=data,
        constraints=r.constraints(data.get("constraints"), q0, qd0),
        baumgarte=r.baumgarte(data.get("baumgarte"), "constraints" in data),
    )


class _Reader:
    """Checks one scene's values; every error names ``source`` and the dotted key."""

    def __init__(self, source: str):
        self.source = source
        self.model: Model | None = None

    def fail(self, key: str, what: str):
        where = f"{self.source}: {key}: " if key else f"{self.source}: "
        raise SceneError(where + what)

    # basic values

    def table(self, value, key) -> dict:
        if not isinstance(value, dict):
            self.fail(key, f"expected a table, found {_found(value)}")
        return value

    def keys(self, table, key, valid):
        self.table(table, key or "(top level)")
        for k in table:
            if k not in valid:
                full = f"{key}.{k}" if key else str(k)
                level = f"in [{key}]" if key else "at the top level"
                self.fail(
                    full,
                    f"unknown key{_suggest(str(k), valid)}; valid keys {level}: {', '.join(valid)}",
                )

    def string(self, value, key, choices=None) -> str:
        if not isinstance(value, str):
            expected = f"one of {', '.join(choices)}" if choices else "a string"
            self.fail(key, f"expected {expected}, found {_found(value)}")
        if choices is not None and value not in choices:
            self.fail(
                key, f"{value!r} is not one of {', '.join(choices)}{_suggest(value, choices)}"
            )
        return value

    def boolean(self, value, key) -> bool:
        if not isinstance(value, bool):
            self.fail(key, f"expected true or false, found {_found(value)}")
        return value

    def number(self, value, key, minimum=None, positive=False) -> float:
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
            self.fail(key, f"expected a number, found {_found(value)}")
        x = float(value)
        if not math.isfinite(x):
            self.fail(key, f"expected a finite number, found {x!r}")
        if positive and not x > 0:
            self.fail(key, f"expected a number > 0, found {x!r}")
        if minimum is not None and x < minimum:
            self.fail(key, f"expected a number >= {minimum:g}, found {x!r}")
        return x

    def vector(self, value, key, n, minimum=None) -> np.ndarray:
        if not isinstance(value, list):
            self.fail(key, f"expected a list of {n} numbers, found {_found(value)}")
        if len(value) != n:
            self.fail(key, f"expected a list of {n} numbers, found a list of {len(value)}")
        return immutable([self.number(v, f"{key}[{i}]", minimum) for i, v in enumerate(value)])

    def per_joint(self, value, key, default, scalar=True, minimum=None) -> np.ndarray:
        """(n,) per joint from a number (every joint; if scalar), a list of n or a table
        {joint: value} (joints not named keep ``default``); None -> default."""
        names = self.model.joint_names
        nv = len(names)
        if value is None:
            return immutable(default)
        if isinstance(value, dict):
            out = np.array(default, dtype=float)
            for joint, v in value.items():
                if joint not in names:
                    self.fail(
                        f"{key}.{joint}",
                        f"{joint!r} is not a joint of {self.model.name!r}"
                        f"{_suggest(str(joint), names)}; joints: {', '.join(names)}",
                    )
                out[names.index(joint)] = self.number(v, f"{key}.{joint}", minimum)
            return immutable(out)
        if isinstance(value, list):
            if len(value) != nv:
                self.fail(
                    key,
                    f"expected a list of {nv} numbers (one per joint: {', '.join(names)}), "
                    f"found a list of {len(value)}",
                )
            return self.vector(value, key, nv, minimum)
        if scalar and isinstance(value, numbers.Real) and not isinstance(value, bool):
            return immutable(np.full(nv, self.number(value, key, minimum)))
        shapes = "a number (every joint), " if scalar else ""
        sign = f" >= {minimum:g}" if minimum is not None else ""
        self.fail(
            key,
            f"expected {shapes}a list of {nv} numbers{sign} or a table {{joint = number}}, "
            f"found {_found(value)}",
        )

    # sections

    def robot(self, table, base_dir) -> Model:
        if table is None:
            self.fail("robot", "missing: a scene needs [robot] with urdf = PATH or name = NAME")
        self.keys(table, "robot", _ROBOT_KEYS)
        given = [k for k in ("urdf", "name") if k in table]
        if len(given) != 1:
            what = "both" if given else "neither"
            self.fail(
                "robot",
                f"{what} of robot.urdf and robot.name given; give exactly one: urdf = a URDF "
                f"path (relative to the scene file) or name = a robot name (e.g. 'ur5')",
            )
        key = f"robot.{given[0]}"
        target = self.string(table[given[0]], key)
        options = {
            "mimic": self.boolean(table.get("mimic", False), "robot.mimic"),
            "check_inertia": self.boolean(table.get("check_inertia", True), "robot.check_inertia"),
            "floating_base": self.boolean(
                table.get("floating_base", False), "robot.floating_base"
            ),
        }
        if given[0] == "urdf":
            path = pathlib.Path(target)
            if not path.is_absolute() and base_dir is not None:
                path = pathlib.Path(base_dir) / path
            if not path.is_file():
                self.fail(key, f"no such URDF file: {path}")
            target = str(path)
        elif "/" in target or os.sep in target or target.endswith(".urdf"):
            self.fail(key, f"{target!r} is a path, not a robot name; use robot.urdf for a file")
        try:
            return load_urdf(target, **options)
        except URDFError as e:
            self.fail(key, str(e))

    def payload(self, table) -> Model:
        """[robot.payload] -> self.model.with_payload(frame, mass, com, inertia); self.model
        itself when there is none. inertia: a table of a URDF <inertia>'s entries (kg m^2,
        about the centre of mass in the frame's axes), missing entries 0."""
        m = self.model
        if table is None:
            return m
        key = "robot.payload"
        self.keys(table, key, _PAYLOAD_KEYS)
        for field in ("frame", "mass"):
            if field not in table:
                self.fail(
                    f"{key}.{field}",
                    "missing: [robot.payload] needs frame (a frame that moves) and mass (kg)",
                )
        frame = self.moving_frame(table["frame"], f"{key}.frame", "a payload on it would not move")
        mass = self.number(table["mass"], f"{key}.mass", minimum=0.0)
        com = self.vector(table.get("com", [0.0] * 3), f"{key}.com", 3)
        inertia = None
        if "inertia" in table:
            entries = table["inertia"]
            if not isinstance(entries, dict):
                self.fail(
                    f"{key}.inertia",
                    f"expected a table {{{', '.join(_INERTIA_ENTRIES)}}} (kg m^2, about the "
                    f"centre of mass in the frame's axes), found {_found(entries)}",
                )
            self.keys(entries, f"{key}.inertia", tuple(_INERTIA_ENTRIES))
            inertia = np.zeros((3, 3))
            for name, (row, column) in _INERTIA_ENTRIES.items():
                value = self.number(entries.get(name, 0.0), f"{key}.inertia.{name}")
                inertia[row, column] = inertia[column, row] = value
        try:
            return m.with_payload(frame, mass, com, inertia)
        except ValueError as e:  # frame, mass and com are checked above: the inertia is wrong
            self.fail(f"{key}.inertia", str(e))

    def initial(self, table) -> tuple[np.ndarray, np.ndarray]:
        """[initial] -> (q0 (nq,), qd0 (nv,)): the joints from q and qd, a floating base from
        the base_* keys (world-frame motion turned into the body twist)."""
        m = self.model
        self.keys(table, "initial", _INITIAL_KEYS)
        given = [k for k in _BASE_KEYS if k in table]
        if given and not m.floating_base:
            self.fail(
                f"initial.{given[0]}",
                f"{m.name!r} is loaded with a fixed base (welded to the world), so it has no base "
                f"state; set floating_base = true under [robot] to make its root link free",
            )
        zeros = np.zeros(len(m.joint_names))
        q0, qd0 = np.zeros(m.nq), np.zeros(m.nv)
        q0[m.q_index] = self.per_joint(table.get("q"), "initial.q", zeros, scalar=False)
        qd0[m.v_index] = self.per_joint(table.get("qd"), "initial.qd", zeros, scalar=False)
        if m.floating_base:
            self.base_state(table, q0, qd0)
        return immutable(q0), immutable(qd0)

    def base_state(self, table, q0, qd0):
        """q0's (p, quat) and qd0's (omega_b, v_b) of the free joint from the base_* keys:
        omega_b = R^T omega_s, v_b = R^T p_dot."""
        m = self.model
        free = int(np.flatnonzero(m.jtype == FREE)[0])
        a, b = int(m.iq[free]), int(m.iv[free])

        def vec3(key):
            value = table.get(key)
            return np.zeros(3) if value is None else self.vector(value, f"initial.{key}", 3)

        if "base_orientation" in table and "base_rpy" in table:
            self.fail(
                "initial.base_rpy",
                "both base_orientation and base_rpy given; give the base's orientation once: "
                "a quaternion [x, y, z, w] or roll, pitch, yaw in rad",
            )
        if "base_orientation" in table:
            key = "initial.base_orientation"
            quat = self.vector(table["base_orientation"], key, 4)
            norm = float(np.linalg.norm(quat))
            if not abs(norm - 1.0) <= BASE_QUATERNION_TOLERANCE:
                self.fail(
                    key,
                    f"expected a unit quaternion [x, y, z, w] (norm within "
                    f"{BASE_QUATERNION_TOLERANCE:g} of 1), found norm {norm:.6g}",
                )
            R_sb = Rotation.from_quat(quat)
        else:
            R_sb = Rotation.from_euler("xyz", vec3("base_rpy"))
        q0[a : a + 3] = vec3("base_position")
        q0[a + 3 : a + 7] = R_sb.as_quat()
        R = R_sb.as_matrix()
        qd0[b : b + 3] = R.T @ vec3("base_angular_velocity")
        qd0[b + 3 : b + 6] = R.T @ vec3("base_velocity")

    def run(self, table) -> Run:
        table = self.table(table, "run")
        self.keys(table, "run", _RUN_KEYS)
        d = Run()
        duration = self.number(table.get("duration", d.duration), "run.duration", positive=True)
        integrator = self.string(
            table.get("integrator", d.integrator), "run.integrator", INTEGRATORS
        )
        dt = self.number(table.get("dt", d.dt), "run.dt", positive=True)
        rtol = self.number(table.get("rtol", d.rtol), "run.rtol", positive=True)
        atol = self.number(table.get("atol", d.atol), "run.atol", positive=True)
        output_dt = self.number(
            table.get("output_dt", max(0.01, dt)), "run.output_dt", positive=True
        )
        max_speed = self.number(table.get("max_speed", d.max_speed), "run.max_speed", positive=True)
        if dt > duration:
            self.fail("run.dt", f"the step {dt:g} s is longer than run.duration = {duration:g} s")
        run = Run(
            duration=duration,
            integrator=integrator,
            dt=dt,
            rtol=rtol,
            atol=atol,
            output_dt=output_dt,
            max_speed=max_speed,
        )
        check_fixed_steps(run, self.source)
        return run

    def gravity(self, value) -> np.ndarray | None:
        if value is None or value is False:
            return None
        if value is True:
            return immutable(self.model.gravity)
        if not isinstance(value, list):
            self.fail(
                "effects.gravity",
                f"expected true, false or a vector [gx, gy, gz] (m/s^2), found {_found(value)}",
            )
        return self.vector(value, "effects.gravity", 3)

    def _coefficients(self, table, key, field, urdf_values, element):
        value = table.get(field, "urdf")
        full = f"{key}.{field}"
        if isinstance(value, str):
            if value != "urdf":
                self.fail(
                    full,
                    f'expected "urdf", a number, a list of {len(self.model.joint_names)} '
                    f"numbers or a table {{joint = number}}, found {_found(value)}",
                )
            if not np.any(urdf_values > 0):
                self.fail(
                    full,
                    f'"urdf" asks for the URDF\'s <dynamics {element}>, but '
                    f"{self.model.source or self.model.name} gives none (all joints 0); give "
                    f"the coefficients: a number, a list of {len(self.model.joint_names)} or a "
                    f"table {{joint = number}}",
                )
            return immutable(urdf_values)
        return self.per_joint(value, full, np.zeros(len(self.model.joint_names)), minimum=0.0)

    def damping(self, table) -> np.ndarray | None:
        if table is None:
            return None
        key = "effects.damping"
        self.keys(table, key, ("coefficients",))
        return self._coefficients(table, key, "coefficients", self.model.damping, "damping")

    def friction(self, table) -> Friction | None:
        if table is None:
            return None
        key = "effects.friction"
        self.keys(table, key, ("coefficients", "smoothing"))
        coulomb = self._coefficients(table, key, "coefficients", self.model.friction, "friction")
        smoothing = self.number(table.get("smoothing", 0.01), f"{key}.smoothing", positive=True)
        return Friction(coulomb=coulomb, smoothing=smoothing)

    def armature(self, table) -> np.ndarray | None:
        if table is None:
            return None
        key = "effects.armature"
        self.keys(table, key, ("values",))
        if "values" not in table:
            self.fail(f"{key}.values", "missing: give a number, a list or a table {joint = kg m^2}")
        return self.per_joint(
            table["values"], f"{key}.values", np.zeros(len(self.model.joint_names)), minimum=0.0
        )

    def limits(self, table) -> Limits | None:
        if table is None:
            return None
        key = "effects.limits"
        self.keys(table, key, ("stiffness", "damping"))
        m = self.model
        finite = np.isfinite(m.lower) | np.isfinite(m.upper)
        if not finite.any():
            self.fail(
                key,
                f"no joint of {m.name!r} has a finite position limit, so limit spring-dampers "
                f"would never act; remove [effects.limits]",
            )
        if "stiffness" not in table:
            self.fail(
                f"{key}.stiffness", "missing: give a number, a list or a table {joint = N m/rad}"
            )
        out = {}
        for field in ("stiffness", "damping"):
            full = f"{key}.{field}"
            value = table.get(field, 0.0)
            arr = self.per_joint(value, full, np.zeros(len(m.joint_names)), minimum=0.0)
            if isinstance(value, (dict, list)):
                for j in np.flatnonzero((arr != 0) & ~finite):
                    name = m.joint_names[j]
                    self.fail(
                        f"{full}.{name}" if isinstance(value, dict) else f"{full}[{j}]",
                        f"joint {name!r} has no finite position limit; limited joints: "
                        f"{', '.join(n for n, f in zip(m.joint_names, finite) if f)}",
                    )
            out[field] = immutable(np.where(finite, arr, 0.0))
        return Limits(
            stiffness=out["stiffness"],
            damping=out["damping"],
            lower=immutable(m.lower),
            upper=immutable(m.upper),
        )

    def wrenches(self, value) -> tuple[Wrench, ...]:
        if value is None:
            return ()
        if isinstance(value, dict):
            return (self.wrench(value, "effects.wrench"),)
        if not isinstance(value, list):
            self.fail(
                "effects.wrench",
                f"expected tables [[effects.wrench]] (frame, value or times/values), "
                f"found {_found(value)}",
            )
        return tuple(self.wrench(w, f"effects.wrench[{i}]") for i, w in enumerate(value))

    def wrench(self, table, key) -> Wrench:
        self.keys(table, key, ("frame", "expressed_in", "value", "times", "values"))
        m = self.model
        if "frame" not in table:
            self.fail(f"{key}.frame", f"missing; frames: {', '.join(m.frame_names)}")
        frame = self.moving_frame(table["frame"], f"{key}.frame", "a wrench on it moves nothing")
        expressed_in = self.string(
            table.get("expressed_in", "frame"), f"{key}.expressed_in", EXPRESSED_IN
        )
        has_value = "value" in table
        has_table = "times" in table or "values" in table
        if has_value == has_table:
            self.fail(
                key,
                ("both value and times/values given" if has_value else "no wrench given")
                + ": give value = [m, f] (6 numbers, constant) or times = [...] with "
                "values = [[6 numbers], ...]",
            )
        if has_value:
            times = immutable([0.0])
            values = immutable(self.vector(table["value"], f"{key}.value", 6)[None, :])
        else:
            for field in ("times", "values"):
                if field not in table:
                    self.fail(f"{key}.{field}", "missing: times and values go together")
            raw_t, raw_v = table["times"], table["values"]
            if not isinstance(raw_t, list) or not raw_t:
                self.fail(
                    f"{key}.times", f"expected a non-empty list of times (s), found {_found(raw_t)}"
                )
            times = self.vector(raw_t, f"{key}.times", len(raw_t))
            bad = np.flatnonzero(np.diff(times) <= 0)
            if bad.size:
                k = int(bad[0]) + 1
                self.fail(
                    f"{key}.times[{k}]",
                    f"times must be strictly increasing; {times[k]:g} follows {times[k - 1]:g}",
                )
            if not isinstance(raw_v, list) or len(raw_v) != len(times):
                found = f"a list of {len(raw_v)}" if isinstance(raw_v, list) else _found(raw_v)
                self.fail(
                    f"{key}.values",
                    f"expected one wrench [m, f] of 6 numbers per time ({len(times)} times), "
                    f"found {found}",
                )
            values = immutable(
                np.array([self.vector(v, f"{key}.values[{i}]", 6) for i, v in enumerate(raw_v)])
            )
        return Wrench(frame=frame, expressed_in=expressed_in, times=times, values=values)

    def contact(self, table) -> Contact | None:
        if table is None:
            return None
        key = "effects.contact"
        self.keys(table, key, _CONTACT_KEYS)
        for field in ("stiffness", "friction", "points"):
            if field not in table:
                self.fail(
                    f"{key}.{field}",
                    'missing: [effects.contact] needs stiffness (N/m), friction (mu) and points '
                    '("urdf" or [[effects.contact.points]] tables)',
                )
        return Contact(
            ground_height=self.number(table.get("ground_height", 0.0), f"{key}.ground_height"),
            stiffness=self.number(table["stiffness"], f"{key}.stiffness", positive=True),
            damping=self.number(table.get("damping", 0.0), f"{key}.damping", minimum=0.0),
            friction=self.number(table["friction"], f"{key}.friction", minimum=0.0),
            slip_velocity=self.number(
                table.get("slip_velocity", 1e-3), f"{key}.slip_velocity", positive=True
            ),
            points=self.contact_points(table["points"], f"{key}.points"),
        )

    def contact_points(self, value, key) -> tuple[ContactPoint, ...]:
        """"urdf" (the model's collision spheres on moving frames) or a list of tables."""
        m = self.model
        if value == "urdf":
            spheres = [s for s in m.collision_spheres if m.frames[m.frame_index(s.link)].body >= 0]
            if not spheres:
                held = " (those there are belong to the fixed world)" if m.collision_spheres else ""
                self.fail(
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
                self.fail(
                    key,
                    f'expected "urdf" or tables [[effects.contact.points]] (frame, position, '
                    f"radius), found {_found(value)}",
                )
            found = []
            for i, point in enumerate(value):
                where = f"{key}[{i}]"
                self.keys(point, where, _CONTACT_POINT_KEYS)
                if "frame" not in point:
                    self.fail(f"{where}.frame", f"missing; frames: {', '.join(m.frame_names)}")
                frame = self.frame(point["frame"], f"{where}.frame")
                if m.frames[m.frame_index(frame)].body < 0:
                    self.fail(
                        f"{where}.frame",
                        f"{frame!r} is welded to the fixed world: a contact sphere there never "
                        "moves and can push nothing; name a frame of a moving link",
                    )
                position = self.vector(point.get("position", [0.0] * 3), f"{where}.position", 3)
                radius = self.number(point.get("radius", 0.0), f"{where}.radius", minimum=0.0)
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

    def constraints(self, value, q0, qd0) -> tuple:
        """[[constraints]] -> constraint objects (opendyn.multibody.constraint_objects), checked at
        (q0, qd0)."""
        if value is None:
            return ()
        if isinstance(value, dict):
            value = [value]
        if not isinstance(value, list) or not value:
            self.fail(
                "constraints",
                f"expected tables [[constraints]] with type = one of "
                f"{', '.join(CONSTRAINT_TYPES)}, found {_found(value)}",
            )
        out = tuple(self.constraint(c, f"constraints[{i}]") for i, c in enumerate(value))
        self._check_initial_state(out, q0, qd0)
        return out

    def constraint(self, table, key):
        table = self.table(table, key)
        if "type" not in table:
            self.fail(f"{key}.type", f"missing: one of {', '.join(CONSTRAINT_TYPES)}")
        kind = self.string(table["type"], f"{key}.type", CONSTRAINT_TYPES)
        self.keys(table, key, _CONSTRAINT_KEYS[kind])

        def frame(field):
            if field not in table:
                self.fail(f"{key}.{field}", f"missing; frames: {', '.join(self.model.frame_names)}")
            return self.frame(table[field], f"{key}.{field}")

        def point(field):
            if field not in table:
                return (0.0, 0.0, 0.0)
            return tuple(self.vector(table[field], f"{key}.{field}", 3))

        try:
            if kind == "point_to_world":
                target = table.get("target")
                return PointToWorld(
                    frame("frame"),
                    point("point"),
                    None if target is None else tuple(self.vector(target, f"{key}.target", 3)),
                )
            if kind == "point_on_plane":
                if "normal" not in table:
                    self.fail(f"{key}.normal", "missing: the plane's normal, 3 numbers (world)")
                normal = self.vector(table["normal"], f"{key}.normal", 3)
                offset = table.get("offset")
                return PointOnPlane(
                    frame("frame"),
                    tuple(normal),
                    point("point"),
                    None if offset is None else self.number(offset, f"{key}.offset"),
                )
            if kind == "point_to_point":
                return PointToPoint(
                    frame("frame_a"), frame("frame_b"), point("point_a"), point("point_b")
                )
            if kind == "fixed_pose":
                T_ab = None
                if "xyz" in table or "rpy" in table:
                    T_ab = np.eye(4)
                    T_ab[:3, :3] = Rotation.from_euler("xyz", point("rpy")).as_matrix()
                    T_ab[:3, 3] = point("xyz")
                return FixedPose(frame("frame_a"), frame("frame_b"), T_ab)
            return JointCoupling(self.coupling(table, key))
        except ValueError as e:
            if isinstance(e, SceneError):
                raise
            self.fail(key, str(e))

    def moving_frame(self, value, key, why) -> str:
        """A frame (`frame`) that moves: one welded to the fixed world is refused, saying `why`
        and listing the frames that move."""
        name = self.frame(value, key)
        m = self.model
        if m.frames[m.frame_index(name)].body < 0:
            moving = [f.name for f in m.frames if f.body >= 0]
            self.fail(
                key,
                f"{name!r} is welded to the fixed world (it is the root link or fixed to it), "
                f"so {why}; frames that move: {', '.join(moving)}",
            )
        return name

    def frame(self, value, key) -> str:
        name = self.string(value, key)
        try:
            self.model.frame_index(name)
        except KeyError:
            frames = self.model.frame_names
            self.fail(
                key,
                f"{name!r} is not a frame of {self.model.name!r}{_suggest(name, frames)}; "
                f"frames: {', '.join(frames)} (a joint name also finds its child link)",
            )
        return name

    def coupling(self, table, key) -> np.ndarray:
        """joint_coupling: one row as a table {joint = coefficient}, or matrix = k lists of nv
        (every velocity coordinate, a floating base's six first)."""
        if ("coefficients" in table) == ("matrix" in table):
            self.fail(
                key,
                "give exactly one of coefficients = {joint = number} (one row: the sum of "
                "coefficient x joint velocity is 0) and matrix = [[nv numbers], ...]",
            )
        m = self.model
        nv = m.nv
        if "coefficients" in table:
            row = np.zeros((1, nv))
            row[0, m.v_index] = self.per_joint(
                table["coefficients"],
                f"{key}.coefficients",
                np.zeros(len(m.joint_names)),
                scalar=False,
            )
            return row
        rows = table["matrix"]
        if not isinstance(rows, list) or not rows:
            self.fail(f"{key}.matrix", f"expected a list of rows, found {_found(rows)}")
        return np.array([self.vector(r, f"{key}.matrix[{i}]", nv) for i, r in enumerate(rows)])

    def _check_initial_state(self, constraints, q0, qd0):
        """Refuse an initial state that breaks a constraint: simulating it would start off the
        constraint manifold (and, without stabilisation, stay off it)."""
        from ..algorithm.constraints import constraint_error, constraint_jacobian

        try:
            phi = constraint_error(self.model, q0, constraints, q_bound=q0)
        except ValueError as e:
            self.fail("constraints", str(e))
        velocity = constraint_jacobian(self.model, q0, constraints) @ qd0
        row = 0
        for i, c in enumerate(constraints):
            k = c.n_rows(self.model.nv)
            for what, values, unit in (("position", phi, "m or rad"), ("velocity", velocity, "")):
                worst = float(np.max(np.abs(values[row : row + k])))
                if not worst <= CONSTRAINT_TOLERANCE:
                    self.fail(
                        f"constraints[{i}]",
                        f"the initial state breaks this {type(c).__name__} constraint: its "
                        f"{what} error is {worst:.3g} (tolerance {CONSTRAINT_TOLERANCE:g}); give "
                        f"[initial] q and qd that satisfy it",
                    )
            row += k

    def baumgarte(self, table, has_constraints) -> tuple[float, float] | None:
        if table is None:
            return None
        self.keys(table, "baumgarte", ("alpha", "beta"))
        if not has_constraints:
            self.fail("baumgarte", "stabilises constraints, but the scene has no [[constraints]]")
        return (
            self.number(table.get("alpha", 0.0), "baumgarte.alpha", minimum=0.0),
            self.number(table.get("beta", 0.0), "baumgarte.beta", minimum=0.0),
        )

    def control(self, table, q0) -> Control | None:
        if table is None:
            return None
        self.table(table, "control")
        kind = self.string(table.get("type", "none"), "control.type", CONTROL_TYPES)
        for k in table:
            owners = [t for t, keys in _CONTROL_KEYS.items() if k in keys]
            if owners and kind not in owners:
                self.fail(
                    f"control.{k}",
                    f"not a setting of control type {kind!r} (its keys: "
                    f"{', '.join(_CONTROL_KEYS[kind])}); {k} belongs to type "
                    f"{' or '.join(repr(t) for t in owners)}",
                )
        self.keys(table, "control", _CONTROL_KEYS[kind])
        if kind == "none":
            return None
        m = self.model
        zeros = np.zeros(len(m.joint_names))
        clip = self.boolean(table.get("clip", False), "control.clip")
        if clip and not np.isfinite(m.effort_limit).any():
            self.fail(
                "control.clip",
                f"no joint of {m.name!r} has a finite effort limit (<limit effort>) to clip to; "
                f"set clip = false",
            )

        def required(field, minimum=None):
            if field not in table:
                self.fail(
                    f"control.{field}",
                    f"missing: control type {kind!r} needs {field} (a number, a list of "
                    f"{len(m.joint_names)} or a table {{joint = number}})",
                )
            return self.per_joint(table[field], f"control.{field}", zeros, minimum=minimum)

        def optional(field, default, minimum=None):
            return self.per_joint(table.get(field), f"control.{field}", default, minimum=minimum)

        if kind == "constant":
            return Control(kind=kind, tau=required("tau"), clip=clip)
        kp, kd = required("kp", 0.0), required("kd", 0.0)
        if kind == "pd":
            return Control(kind=kind, kp=kp, kd=kd, setpoint=optional("setpoint", q0), clip=clip)
        return Control(
            kind=kind,
            kp=kp,
            kd=kd,
            offset=optional("offset", q0),
            amplitude=optional("amplitude", zeros),
            frequency=optional("frequency", np.full(len(m.joint_names), 0.5), 0.0),
            phase=optional("phase", zeros),
            clip=clip,
        )


# --- helpers ---------------------------------------------------------------------------------


def check_fixed_steps(run: Run, source: str) -> None:
    """A fixed-step run records every k-th step and ends on a step: run.output_dt and
    run.duration must be whole numbers of steps run.dt, and the steps countable (at most
    MAX_STEPS). Raises SceneError naming `source` and the key; adaptive runs pass."""
    if run.integrator in ADAPTIVE_INTEGRATORS:
        return
    r = _Reader(source)
    duration, dt, output_dt = run.duration, run.dt, run.output_dt
    ratio = output_dt / dt
    if not np.isfinite(ratio):
        r.fail("run.dt", f"{dt:g} s is too small a step to count in float64")
    if not _whole(ratio):
        r.fail(
            "run.output_dt",
            f"{output_dt:g} s is not a whole multiple of run.dt = {dt:g} s (it is "
            f"{ratio:.6g} steps); the fixed-step integrator {run.integrator!r} records "
            f"every k-th step: choose output_dt = k * dt",
        )
    ratio = duration / dt
    if not ratio <= MAX_STEPS:
        r.fail(
            "run.dt",
            f"run.duration / run.dt = {duration:g} s / {dt:g} s = {ratio:.3g} steps, more "
            f"than a run can count (2^53 = {MAX_STEPS:.3g}); shorten run.duration or raise "
            "run.dt",
        )
    if not _whole(ratio):
        below, above = int(np.floor(ratio)) or 1, int(np.ceil(ratio))
        r.fail(
            "run.duration",
            f"{duration:g} s is not a whole number of steps of run.dt = {dt:g} s (it is "
            f"{ratio:.6g} steps), so a fixed-step run cannot end at it; choose duration = "
            f"n * dt (e.g. {below * dt:.10g} or {above * dt:.10g} s) or a dt that divides it",
        )


def _whole(ratio: float) -> bool:
    """Whether a ratio of times is a whole number (at least 1) of steps, to rounding."""
    steps = round(ratio)
    return steps >= 1 and abs(ratio - steps) <= _WHOLE_STEPS_RTOL * ratio


def _suggest(name: str, choices) -> str:
    close = difflib.get_close_matches(str(name), [str(c) for c in choices], n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


def _found(value) -> str:
    """What a TOML value is, for error messages: its text and its TOML type."""
    if isinstance(value, (bool, np.bool_)):
        kind = "a boolean"
    elif isinstance(value, str):
        kind = "a string"
    elif isinstance(value, numbers.Integral):
        kind = "an integer"
    elif isinstance(value, numbers.Real):
        kind = "a float"
    elif isinstance(value, list):
        kind = f"a list of {len(value)}"
    elif isinstance(value, dict):
        kind = "a table"
    elif value is None:
        return "nothing"
    else:
        kind = f"a {type(value).__name__}"
    text = repr(value)
    if len(text) > 60:
        text = text[:57] + "..."
    return f"{text} ({kind})"


def _freeze(value):
    """A read-only copy of a settings tree: mappings as MappingProxyType, lists as tuples."""
    if isinstance(value, Mapping):
        return MappingProxyType({k: _freeze(v) for k, v in value.items()})
    if isinstance(value, (list, tuple)):
        return tuple(_freeze(v) for v in value)
    return value


def thaw(value):
    """A plain, mutable copy of a settings tree (``scene.settings``, or a dict that holds
    numpy arrays): mappings as dicts, lists and tuples as lists, numpy arrays and scalars as
    Python values, paths as strings; what scene_from_dict takes and JSON writes."""
    if isinstance(value, Mapping):
        return {k: thaw(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [thaw(v) for v in value]
    if isinstance(value, np.ndarray):
        return thaw(value.tolist())
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    return value
