"""A scene's settings (a dict in the layout of the TOML file) -> a validated, frozen ``Scene``.

Every number is checked here (type, shape, sign, finiteness, joint and frame names), so a scene
that loads is one the simulator can run; anything else raises ``SceneError`` naming the file,
the dotted key (``effects.damping.coefficients``), what was expected and what was found. What
depends on the run as a whole (the record's size against the memory available, the initial
state's speed, energy and limits) is checked by ``simulate`` before it allocates or compiles
anything (opendyn.sim.preflight), with the same kind of message.

The file format (every key optional unless marked required):

    name = "double pendulum swinging"      # default: the file stem
    description = "..."                    # free text

    [robot]                                # required (but in a scene of [[objects]] alone):
                                           # exactly one of urdf and name
    urdf = "double_pendulum.urdf"          # a URDF path, relative to the scene file's folder
    # name = "ur5"                         # or a robot name that load_urdf resolves
    mimic = false                          # passed to load_urdf
    check_inertia = true                   # passed to load_urdf
    floating_base = false                  # passed to load_urdf: true makes the root link a
                                           # free body (a 6-dof base, unactuated)
    srdf = "robot.srdf"                    # passed to load_urdf (relative to the scene file):
                                           # its <disable_collisions> leave model.collision_pairs
    [robot.payload]                        # a rigid payload welded to a frame: its inertia is
                                           # added to the frame's body (model.with_payload)
    frame = "tool0"                        # required: a frame (link or joint name) that moves
    mass = 2.5                             # required: kg >= 0
    com = [0.0, 0.0, 0.05]                 # m, its centre of mass in the frame (default 0)
    inertia = { ixx = 0.01, iyy = 0.01, izz = 0.005 }   # kg m^2 about the centre of mass,
                                           # frame axes, as a URDF <inertia>: ixx iyy izz ixy
                                           # ixz iyz, missing entries 0 (default: a point mass)

    [[objects]]                            # any number: a free rigid body each, moving with the
                                           # robot (opendyn.multibody.assembly)
    name = "box"                           # required: its body, frame and geometry; its
                                           # coordinates box.x ... box.qw, box.wx ... box.vz
    shape = "box"                          # required but with urdf: "box", "sphere",
                                           # "cylinder", "capsule"
    size = [0.1, 0.1, 0.1]                 # required with shape: m, as a URDF's (box: edges;
                                           # sphere: [r]; cylinder, capsule: [r, length] along z)
    mass = 1.0                             # required with shape: kg > 0, spread uniformly
    # urdf = "mug.urdf"                    # instead of shape, size, mass: a URDF (relative to
                                           # the scene file) on a floating base of its own; its
                                           # root link is the object, its other links and joints
                                           # NAME.link, NAME.joint
    position = [0.0, 0.0, 0.05]            # m, its centre in the world (default the origin)
    rpy = [0.0, 0.0, 0.0]                  # rad; or orientation = [x, y, z, w], a unit
                                           # quaternion (not both; default upright)
    velocity = [0.0, 0.0, 0.0]             # m/s, its centre's, world axes (default 0)
    angular_velocity = [0.0, 0.0, 0.0]     # rad/s, world axes (default 0)

    [[world]]                              # any number: static geometry, welded to the world
    name = "table"                         # required
    shape = "box"                          # required: "box", "sphere", "cylinder", "capsule",
                                           # "plane" (the solid below the plane through
                                           # position, normal the entry's z axis) or "mesh"
                                           # (the convex hull of the file's vertices; one
                                           # far from convex warns: split it in entries)
    size = [1.0, 0.6, 0.05]                # m, as an object's; none for a plane; a mesh's is
                                           # the scale of its file (default [1, 1, 1])
    mesh = "step.stl"                      # mesh: the file (STL, OBJ, DAE), relative to the
                                           # scene file
    position = [0.5, 0.0, 0.375]           # m, its centre (a plane: a point on it)
    rpy = [0.0, 0.0, 0.0]                  # rad

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
                                           # implicit_euler (default rk4); a hard model
                                           # (model = "hard" below) needs semi_implicit_euler
    dt = 0.001                             # s, > 0: the fixed step, or dopri5's first trial step
    output_dt = 0.01                       # s: recorded sample interval (default 0.01, or dt if
                                           # dt > 0.01); a whole multiple of dt for fixed steps
    rtol = 1e-6                            # dopri5's tolerances
    atol = 1e-9
    max_speed = 1e4                        # rad/s or m/s: a faster joint stops the run
    control_dt = 0.001                     # s: a Python controller's period (default dt); a
                                           # whole number of steps dt for fixed steps

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
    # model = "hard"                       # "compliant" (default: the smoothed law above) or
                                           # "hard": |lambda| <= f_c dt, static friction held
                                           # exactly (no smoothing); then also the hard
                                           # model's settings, as the contact's below:
    # stabilization = 0.2                  # compliance, solver, tolerance, max_iterations
    # compliance = 0.0
    # solver = "admm"
    # tolerance = 1e-8
    # max_iterations = 100
    [effects.armature]
    values = 0.1                           # required: number, list or table
    [effects.limits]
    stiffness = 1e4                        # required: number, list or table; acts only on
                                           # joints with a finite limit (a number is 0 elsewhere)
    damping = 10.0                         # default 0
    # model = "hard"                       # "compliant" (default: the spring-dampers above)
                                           # or "hard": a unilateral row per limit within
                                           # margin (no stiffness, no damping); then also the
                                           # hard model's settings, as the contact's below:
    # margin = 1e-3                        # rad or m
    # stabilization = 0.2
    # compliance = 0.0
    # solver = "admm"
    # tolerance = 1e-8
    # max_iterations = 100

    [effects.contact]                      # the ground: the plane z = ground_height, normal +z
    ground_height = 0.0                    # m (world frame; default 0)
    stiffness = 1e5                        # required: N/m, the normal spring k > 0
    damping = 0.0                          # N s/m, the normal damper d >= 0 (default 0)
    friction = 0.8                         # required: the Coulomb coefficient mu >= 0 (0 =
                                           # frictionless)
    slip_velocity = 1e-3                   # m/s > 0, regularises friction near zero slip
    points = "urdf"                        # required but with geometry: "urdf" (the spheres
                                           # and box corners of the <collision> elements) or
                                           # tables [[effects.contact.points]] (below)
    # geometry = "collision"               # instead of points: the contact between every
                                           # collision geometry of the robot, the objects, the
                                           # world and the ground (named "ground") at the
                                           # same law, equal and opposite on both bodies
    # self_collision = false               # with geometry: the robot's own pairs take part
    # model = "hard"                       # "compliant" (default: the law above) or "hard":
                                           # contacts as constraints of the velocity-level
                                           # step (only friction per pair; no stiffness,
                                           # damping or slip_velocity). Its settings, in any
                                           # hard section (the limits' and friction's too;
                                           # the same where repeated):
    # margin = 1e-3                        # m (rad for limits) >= 0: a gap within it is a row
    # stabilization = 0.2                  # in [0, 1]: the share of a penetration taken out
                                           # per step
    # compliance = 0.0                     # s/kg >= 0, added to every row of G
    # solver = "admm"                      # "admm" or "pgs"
    # tolerance = 1e-8                     # m/s > 0, on the NCP's residual
    # max_iterations = 100                 # >= 1; a step that does not converge still
                                           # completes, and the summary counts it
    # [[effects.contact.points]]
    # frame = "FL_FOOT"                    # required: a frame (link or joint name) that moves
    # position = [0.0, 0.0, 0.0]           # m, the sphere's centre in the frame (default 0)
    # radius = 0.02                        # m >= 0 (default 0: a point)
    # [[effects.contact.pairs]]            # with geometry: one pair's own law, or none
    # a = "box"                            # required: a link, an object, a world entry or
    # b = "table"                          # "ground"; every pair of their geometries
    # stiffness = 1e6                      # any of stiffness, damping, friction and
                                           # slip_velocity (default: the contact's)
    # enabled = true                       # false: the pair never touches

    [[effects.wrench]]                     # any number of these
    frame = "tip"                          # required: a frame (link) or joint name
    expressed_in = "frame"                 # "frame" (default) or "world"
    value = [0, 0, 0, 0, 0, -10]           # a constant (m, f) applied to the robot; or
    # times = [0.0, 1.0, 2.0]              # strictly increasing times (s) and one wrench per
    # values = [[...], [...], [...]]       # time: linear in between, held outside

    [control]
    type = "pd"                            # "none" (default), "constant", "pd", "computed_torque",
                                           # "python"
    tau = 1.0                              # constant: tau (required)
    kp = 100.0                             # pd, computed_torque: gains (required)
    kd = 20.0
    setpoint = { shoulder = 0.5 }          # pd: tau = kp (setpoint - q) - kd qd; default q0
    offset = [0.0, 0.0]                    # computed_torque: q_r(t) = offset + amplitude
    amplitude = 0.1                        #   sin(2 pi frequency t + phase); offset default q0,
    frequency = 0.5                        #   amplitude and phase 0, frequency 0.5 Hz;
    phase = 0.0                            #   the torque is M (qdd_r + kd ed + kp e) + h
    function = "ctl.py:impedance"          # python: fn(t, q, qd) -> tau, a FILE.py (relative to
                                           #   the scene file) or MODULE, then :FUNCTION
    # control_dt = 0.001                   # python: its period (or [run] control_dt), held
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
"""

from __future__ import annotations

import warnings

from ...errors import SceneWarning
from ...multibody.assembly import empty_model
from ...sim.effects.registry import scene_fields
from ...sim.run import RunSection
from ...sim.scene import Scene
from ..urdf import welded_mobile_warning
from .sections_constraints import ConstraintsSection
from .sections_control import ControlSection
from .sections_effects import EffectsSection
from .sections_robot import RobotSection
from .sections_world import WorldSection

TOP_KEYS = (
    "name",
    "description",
    "robot",
    "initial",
    "run",
    "effects",
    "control",
    "constraints",
    "baumgarte",
    "objects",
    "world",
)


def _build(data, source, base_dir, default_name=None, model=None) -> Scene:
    r = _Reader(source)
    r.base_dir = base_dir  # where paths in the file are relative to (None: the working folder)
    r.keys(data, "", TOP_KEYS)
    if model is None:
        robotless = "robot" not in data and "objects" in data  # the objects are the scene
        model = empty_model() if robotless else r.robot(data.get("robot"), base_dir)
    r.model = model
    # after the robot is loaded or given, so that a given model (a sweep's, loaded once) gets
    # the payload and the objects its scene names
    model = r.model = r.payload((data.get("robot") or {}).get("payload"))
    model = r.world_model(data.get("objects"), data.get("world"))
    warning = welded_mobile_warning(
        model, "set robot.floating_base = true (opendyn simulate --floating-base)"
    )
    if warning:
        warnings.warn(f"{source}: robot: {warning}", SceneWarning, stacklevel=3)
    name = data.get("name", default_name if default_name is not None else model.name)
    r.string(name, "name")
    if "description" in data:
        r.string(data["description"], "description")
    q0, qd0 = r.initial(data.get("initial", {}))
    run = r.run(data.get("run", {}))
    r.meshes_readable(data.get("effects"))
    records = r.effects(data.get("effects", {}))
    r.contact_reaches(records["contact"])
    records["control"] = r.control(data.get("control"), q0[model.q_index])
    kind = (data.get("control") or {}).get("type")
    if run.control_dt is not None and records["control"] is not None and kind != "python":
        warnings.warn(
            f"{source}: run.control_dt: {run.control_dt:g} s is the period of a Python "
            f"controller (--controller, od.simulate(controller=...)); the scene's [control] "
            f"type = {kind!r} is compiled into the step and acts at every evaluation, not held "
            "for a period: the value changes nothing here",
            SceneWarning,
            stacklevel=3,
        )
    return Scene(
        name=name,
        model=model,
        q0=q0,
        qd0=qd0,
        run=run,
        **scene_fields(records),
        source=source,
        settings=data,
        constraints=r.constraints(data.get("constraints"), q0, qd0),
        baumgarte=r.baumgarte(data.get("baumgarte"), "constraints" in data),
        files=tuple(dict.fromkeys(str(path) for path in r.files)),
    )


class _Reader(
    RobotSection, WorldSection, RunSection, EffectsSection, ConstraintsSection, ControlSection
):
    """Checks one scene's values, every section; every error names ``source`` and the dotted
    key."""
