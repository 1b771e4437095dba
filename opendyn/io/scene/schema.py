"""What a scene is: the frozen ``Scene`` (a robot, its initial state, the run settings, the
physical effects that exist and the control), the records of its effects and control, and
``thaw``, which turns its read-only settings back into a plain dict. An effect that a scene does
not name is off: the simulator never computes it.

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
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np

from ...errors import SceneError
from ...multibody.model import Model
from .sections_run import _RUN_KEYS, Run, RunSection
from .values import _suggest

EFFECTS = (
    "gravity", "damping", "friction", "armature", "limits", "wrench", "contact", "control"
)


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
        run = RunSection(self.source).run(table)
        settings["run"] = table
        return dataclasses.replace(self, run=run, settings=settings)


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
