"""Inputs that cannot lie: a Model, its frames and a Scene's settings cannot be changed after
they are built; arguments of the wrong kind (not a Model, complex, text, boolean or object
arrays) are a TypeError naming the argument; finite arguments whose result overflows float64
are an error naming the result, never a NaN returned."""

from __future__ import annotations

import dataclasses
import inspect
import json

import numpy as np
import pytest

import opendyn as od
from opendyn.cli.main import main
from opendyn.sim.scene import thaw
from opendyn.io.urdf import shipped_robots_dir
from opendyn.verify.contract import verify

MODEL_ARRAYS = (
    "G", "S", "A", "mass", "h", "I_o", "R_home", "p_home", "parent", "jtype", "nv_j", "iq",
    "iv", "mult", "offset", "q_index", "v_index", "lower", "upper", "velocity_limit",
    "effort_limit", "damping", "friction", "continuous", "gravity",
)  # fmt: skip


@pytest.fixture(scope="module")
def ur5():
    return od.load_urdf("ur5")


@pytest.fixture(scope="module")
def solo():
    return od.load_urdf("solo", floating_base=True)


def model_arrays(model):
    """(name, array) of every array a Model shows: its fields, each frame's transform and
    each collision sphere's centre."""
    yield from ((name, getattr(model, name)) for name in MODEL_ARRAYS)
    yield from ((f"frame {f.name!r}", f.T_body_frame) for f in model.frames)
    yield from ((f"sphere of {s.link!r}", s.position) for s in model.collision_spheres)


def aba_agrees_with_crba(model, seed=0):
    rng = np.random.default_rng(seed)
    q = od.random_configuration(model, rng)
    qd, tau = rng.normal(size=(2, model.nv))
    M, h = od.mass_matrix(model, q), od.bias_forces(model, q, qd)
    np.testing.assert_allclose(
        od.forward_dynamics(model, q, qd, tau), np.linalg.solve(M, tau - h), rtol=1e-8, atol=1e-8
    )


@pytest.mark.parametrize("robot", ["ur5", "solo", "talos_full_v2"])
def test_model_arrays_cannot_be_made_writeable_again(robot):
    model = od.load_urdf(robot, floating_base=robot != "ur5")
    arrays = list(model_arrays(model))
    assert len(arrays) >= len(MODEL_ARRAYS) + len(model.frames)
    for name, array in arrays:
        for view in (array, array[...], np.asarray(array)):
            with pytest.raises(ValueError, match="WRITEABLE"):
                view.flags.writeable = True
            with pytest.raises(ValueError, match="read-only"):
                view[...] = 0
        assert not array.flags.writeable, name
    aba_agrees_with_crba(model)


def scene_arrays(value, path="scene"):
    """(path, array) of every numpy array reachable from a scene's fields."""
    if isinstance(value, np.ndarray):
        yield path, value
    elif dataclasses.is_dataclass(value) and not isinstance(value, (type, od.Model)):
        for f in dataclasses.fields(value):
            yield from scene_arrays(getattr(value, f.name), f"{path}.{f.name}")
    elif isinstance(value, tuple):
        for k, item in enumerate(value):
            yield from scene_arrays(item, f"{path}[{k}]")


@pytest.mark.parametrize("name", ["double_pendulum_push", "panda_computed_torque", "box_slide"])
def test_scene_arrays_cannot_be_made_writeable_again(name):
    scene = od.load_scene(name)
    arrays = list(scene_arrays(scene))
    assert len(arrays) >= 3
    for path, array in arrays:
        with pytest.raises(ValueError, match="WRITEABLE"):
            array.flags.writeable = True
        assert not array.flags.writeable, path


def test_scene_settings_are_a_read_only_mapping(tmp_path):
    scene = od.load_scene("double_pendulum_push").replace_run(duration=0.05)
    before = json.dumps(thaw(scene.settings))
    with pytest.raises(TypeError):
        scene.settings["name"] = "renamed"
    with pytest.raises(TypeError):
        scene.settings["run"]["duration"] = 100.0
    with pytest.raises(TypeError):
        del scene.settings["effects"]["damping"]
    with pytest.raises(AttributeError):
        scene.settings["effects"]["wrench"][0]["times"].append(2.0)
    with pytest.raises(TypeError):
        scene.settings["effects"]["wrench"][0]["values"][0][3] = 1.0
    assert json.dumps(thaw(scene.settings)) == before

    # the provenance record is the scene as read, and a copy: editing it changes no scene
    traj = od.simulate(scene)
    record = traj.provenance["scene"]["settings"]
    assert record == thaw(scene.settings) and json.dumps(record) == before
    record["run"]["duration"] = 100.0
    assert scene.settings["run"]["duration"] == 0.05

    # the ways to change a scene still work, and leave the original alone
    plain = thaw(scene.settings)
    plain["effects"]["gravity"] = [0.0, 0.0, -1.0]
    assert od.scene_from_dict(plain, base_dir=shipped_robots_dir()).gravity[2] == -1.0
    lean = scene.without("damping", "wrench")
    assert lean.effects == ("gravity",) and set(lean.settings["effects"]) == {"gravity"}
    assert scene.replace_run(dt=0.002).settings["run"]["dt"] == 0.002
    assert scene.settings["run"]["dt"] == 0.001 and "damping" in scene.settings["effects"]
    assert json.dumps(thaw(scene.settings)) == before
    out = tmp_path / "run.npz"
    args = ["planar_3r_limits", "--enable", "friction", "--duration", "0.02", "-o", str(out)]
    assert main(["simulate", *args, "-q"]) == 0
    saved = json.loads((tmp_path / "run.json").read_text())["scene"]["settings"]
    assert "friction" in saved["effects"]
    assert "friction" not in od.load_scene("planar_3r_limits").settings["effects"]


Q = np.array([0.1, -0.4, 0.3, 0.2, -0.1, 0.5])
A_ROW = np.eye(6)[:1]
SAMPLES = np.random.default_rng(0).normal(size=(4, 30, 6))  # q, qd, qdd, tau of 30 samples
POINT = od.PointToWorld("tool0")
PUBLIC = {  # every public function that takes a model, called with good other arguments
    "inverse_dynamics": lambda m: od.inverse_dynamics(m, Q, Q, Q),
    "mass_matrix": lambda m: od.mass_matrix(m, Q),
    "gravity_forces": lambda m: od.gravity_forces(m, Q),
    "coriolis_forces": lambda m: od.coriolis_forces(m, Q, Q),
    "bias_forces": lambda m: od.bias_forces(m, Q, Q),
    "coriolis_matrix": lambda m: od.coriolis_matrix(m, Q, Q),
    "christoffel_symbols": lambda m: od.christoffel_symbols(m, Q),
    "forward_dynamics": lambda m: od.forward_dynamics(m, Q, Q, Q),
    "inverse_dynamics_derivatives": lambda m: od.inverse_dynamics_derivatives(m, Q, Q, Q),
    "forward_dynamics_derivatives": lambda m: od.forward_dynamics_derivatives(m, Q, Q, Q),
    "frame_pose": lambda m: od.frame_pose(m, Q, "tool0"),
    "jacobian": lambda m: od.jacobian(m, Q, "tool0"),
    "kinetic_energy": lambda m: od.kinetic_energy(m, Q, Q),
    "potential_energy": lambda m: od.potential_energy(m, Q),
    "task_space_mass_matrix": lambda m: od.task_space_mass_matrix(m, Q, "tool0"),
    "task_space_bias": lambda m: od.task_space_bias(m, Q, Q, "tool0"),
    "frame_acceleration": lambda m: od.frame_acceleration(m, Q, Q, Q, "tool0"),
    "constraint_jacobian": lambda m: od.constraint_jacobian(m, Q, POINT),
    "constraint_drift": lambda m: od.constraint_drift(m, Q, Q, POINT),
    "constraint_error": lambda m: od.constraint_error(m, Q, POINT, Q),
    "constrained_forward_dynamics": lambda m: od.constrained_forward_dynamics(m, Q, Q, Q, POINT),
    "constrained_inverse_dynamics": lambda m: od.constrained_inverse_dynamics(m, Q, Q, Q, A_ROW),
    "constraint_projection": lambda m: od.constraint_projection(m, Q, A_ROW),
    "constraint_wrench": lambda m: od.constraint_wrench(m, Q, "tool0", A_ROW, [1.0]),
    "integrate": lambda m: od.integrate(m, Q, Q, 0.1),
    "difference": lambda m: od.difference(m, Q, Q),
    "normalize": lambda m: od.normalize(m, Q),
    "neutral": lambda m: od.neutral(m),
    "random_configuration": lambda m: od.random_configuration(m, 0),
    "center_of_mass": lambda m: od.center_of_mass(m, Q),
    "center_of_mass_jacobian": lambda m: od.center_of_mass_jacobian(m, Q),
    "centroidal_momentum_matrix": lambda m: od.centroidal_momentum_matrix(m, Q),
    "centroidal_momentum": lambda m: od.centroidal_momentum(m, Q, Q),
    "centroidal_momentum_rate_bias": lambda m: od.centroidal_momentum_rate_bias(m, Q, Q),
    "torque_regressor": lambda m: od.torque_regressor(m, Q, Q, Q),
    "distances": lambda m: od.distances(m, Q),
    "collisions": lambda m: od.collisions(m, Q),
    "identify": lambda m: od.identify(m, *SAMPLES),
    "identify_payload": lambda m: od.identify_payload(m, "tool0", *SAMPLES),
}


def test_every_public_function_taking_a_model_is_checked_here():
    takes_model = {
        name
        for name in od.__all__
        if callable(getattr(od, name))
        and not isinstance(getattr(od, name), type)
        and next(iter(inspect.signature(getattr(od, name)).parameters), None) == "model"
    }
    assert takes_model == set(PUBLIC)


@pytest.mark.parametrize("name", PUBLIC)
def test_model_argument_that_is_not_a_model_is_a_type_error(ur5, name):
    PUBLIC[name](ur5)  # the other arguments are good
    for bad, found in (
        (None, "got None"),
        ("ur5", "got str 'ur5'; load it with od.load_urdf('ur5')"),
        ({}, "got dict {}"),
    ):
        with pytest.raises(TypeError) as info:
            PUBLIC[name](bad)
        message = str(info.value)
        assert message.startswith(f"{name}: model must be an opendyn Model"), message
        assert found in message


def test_simulate_with_a_scene_name_loads_that_scene():
    traj = od.simulate("double_pendulum_push")
    source = shipped_robots_dir() / "double_pendulum_push.toml"
    assert traj.provenance["scene"]["source"] == str(source)
    assert traj.complete and traj.t[-1] == od.load_scene("double_pendulum_push").run.duration
    with pytest.raises(od.SceneError, match=r"no such scene file.*od.default_scene\('ur5'\)"):
        od.simulate("ur5")
    with pytest.raises(TypeError, match=r"an opendyn Scene.*got Model; od.default_scene\(model\)"):
        od.simulate(od.load_urdf("ur5"))
    with pytest.raises(TypeError, match="scene must be an opendyn Scene.*got NoneType"):
        od.simulate(None)


def bad_versions(good):
    """The same numbers as `good` as complex numbers (imaginary part 0), text, text mixed in
    with numbers, booleans and Python objects: (kind named in the error, value)."""
    a = np.asarray(good, dtype=np.float64)
    mixed = np.asarray(a, dtype=object)
    mixed.flat[0] = str(mixed.flat[0])
    return [
        ("complex numbers", a + 0j),
        ("text", a.astype(str).tolist()),
        ("text", mixed.tolist()),
        ("booleans", a != 0),
        ("Python objects", np.asarray(a, dtype=object)),
    ]


W = np.array([0.1, 0.2, 0.3, 1.0, -2.0, 3.0])
G3 = np.array([0.0, 0.0, -9.81])
ARRAY_ARGUMENTS = {  # (function, argument): (its good value, a call with that argument replaced)
    ("inverse_dynamics", "q"): (Q, lambda m, x: od.inverse_dynamics(m, x, Q, Q)),
    ("inverse_dynamics", "qd"): (Q, lambda m, x: od.inverse_dynamics(m, Q, x, Q)),
    ("inverse_dynamics", "qdd"): (Q, lambda m, x: od.inverse_dynamics(m, Q, Q, x)),
    ("inverse_dynamics", "gravity"): (G3, lambda m, x: od.inverse_dynamics(m, Q, Q, Q, gravity=x)),
    ("inverse_dynamics", "f_tip['tool0']"): (
        W, lambda m, x: od.inverse_dynamics(m, Q, Q, Q, f_tip={"tool0": x})
    ),
    ("mass_matrix", "q"): (Q, lambda m, x: od.mass_matrix(m, x)),
    ("gravity_forces", "gravity"): (G3, lambda m, x: od.gravity_forces(m, Q, x)),
    ("coriolis_forces", "qd"): (Q, lambda m, x: od.coriolis_forces(m, Q, x)),
    ("bias_forces", "qd"): (Q, lambda m, x: od.bias_forces(m, Q, x)),
    ("coriolis_matrix", "qd"): (Q, lambda m, x: od.coriolis_matrix(m, Q, x)),
    ("christoffel_symbols", "q"): (Q, lambda m, x: od.christoffel_symbols(m, x)),
    ("forward_dynamics", "tau"): (Q, lambda m, x: od.forward_dynamics(m, Q, Q, x)),
    ("forward_dynamics", "gravity"): (G3, lambda m, x: od.forward_dynamics(m, Q, Q, Q, gravity=x)),
    ("frame_pose", "q"): (Q, lambda m, x: od.frame_pose(m, x, "tool0")),
    ("jacobian", "q"): (Q, lambda m, x: od.jacobian(m, x, "tool0")),
    ("kinetic_energy", "qd"): (Q, lambda m, x: od.kinetic_energy(m, Q, x)),
    ("potential_energy", "gravity"): (G3, lambda m, x: od.potential_energy(m, Q, x)),
    ("task_space_mass_matrix", "damping"): (
        0.1, lambda m, x: od.task_space_mass_matrix(m, Q, "tool0", x)
    ),
    ("task_space_bias", "qd"): (Q, lambda m, x: od.task_space_bias(m, Q, x, "tool0")),
    ("frame_acceleration", "qdd"): (Q, lambda m, x: od.frame_acceleration(m, Q, Q, x, "tool0")),
    ("constraint_jacobian", "q"): (Q, lambda m, x: od.constraint_jacobian(m, x, POINT)),
    ("constraint_drift", "qd"): (Q, lambda m, x: od.constraint_drift(m, Q, x, POINT)),
    ("constraint_error", "q_bound"): (Q, lambda m, x: od.constraint_error(m, Q, POINT, x)),
    ("constrained_forward_dynamics", "tau"): (
        Q, lambda m, x: od.constrained_forward_dynamics(m, Q, Q, x, POINT)
    ),
    ("constrained_forward_dynamics", "A"): (
        A_ROW, lambda m, x: od.constrained_forward_dynamics(m, Q, Q, Q, A=x, Adot_qd=[0.0])
    ),
    ("constrained_forward_dynamics", "Adot_qd"): (
        [0.0], lambda m, x: od.constrained_forward_dynamics(m, Q, Q, Q, A=A_ROW, Adot_qd=x)
    ),
    ("constrained_inverse_dynamics", "lam"): (
        [1.0], lambda m, x: od.constrained_inverse_dynamics(m, Q, Q, Q, A_ROW, x)
    ),
    ("constraint_projection", "A"): (A_ROW, lambda m, x: od.constraint_projection(m, Q, x)),
    ("constraint_wrench", "lam"): (
        [1.0], lambda m, x: od.constraint_wrench(m, Q, "tool0", A_ROW, x)
    ),
    ("integrate", "v"): (Q, lambda m, x: od.integrate(m, Q, x, 0.1)),
    ("integrate", "dt"): (0.1, lambda m, x: od.integrate(m, Q, Q, x)),
    ("difference", "q1"): (Q, lambda m, x: od.difference(m, Q, x)),
    ("normalize", "q"): (Q, lambda m, x: od.normalize(m, x)),
    ("PointToWorld", "target"): (G3, lambda m, x: od.PointToWorld("tool0", target=x)),
    ("PointOnPlane", "normal"): (G3, lambda m, x: od.PointOnPlane("tool0", normal=x)),
    ("PointOnPlane", "offset"): (0.5, lambda m, x: od.PointOnPlane("tool0", G3, offset=x)),
    ("PointToPoint", "point_b"): (G3, lambda m, x: od.PointToPoint("tool0", "base", point_b=x)),
    ("FixedPose", "T_ab"): (np.eye(4), lambda m, x: od.FixedPose("tool0", "base", T_ab=x)),
    ("JointCoupling", "A"): (A_ROW, lambda m, x: od.JointCoupling(x)),
    ("inverse_dynamics_derivatives", "qdd"): (
        Q, lambda m, x: od.inverse_dynamics_derivatives(m, Q, Q, x)
    ),
    ("forward_dynamics_derivatives", "tau"): (
        Q, lambda m, x: od.forward_dynamics_derivatives(m, Q, Q, x)
    ),
    ("center_of_mass", "q"): (Q, lambda m, x: od.center_of_mass(m, x)),
    ("centroidal_momentum", "qd"): (Q, lambda m, x: od.centroidal_momentum(m, Q, x)),
    ("torque_regressor", "qdd"): (Q, lambda m, x: od.torque_regressor(m, Q, Q, x)),
    ("identify", "tau"): (SAMPLES[3], lambda m, x: od.identify(m, *SAMPLES[:3], x)),
}


@pytest.mark.parametrize("function, argument", ARRAY_ARGUMENTS)
def test_complex_string_bool_object_arrays_are_a_type_error_naming_the_argument(
    ur5, function, argument
):
    good, call = ARRAY_ARGUMENTS[function, argument]
    call(ur5, good)
    for found, bad in bad_versions(good):
        with pytest.raises(TypeError) as info:
            call(ur5, bad)
        message = str(info.value)
        assert f"{argument} must be " in message and f"got {found} (dtype" in message, message


BIG = np.full(6, 1e200)  # squares overflow float64 (they would be 1e400)
HUGE = np.full(6, 1e308)  # anything added to or multiplied by it overflows
OVERFLOWS = {  # finite arguments whose result overflows: (call, result name, likely cause)
    "inverse_dynamics": (lambda m: od.inverse_dynamics(m, Q, BIG, Q), "tau", "qd up to 1e+200"),
    "inverse_dynamics f_tip": (
        lambda m: od.inverse_dynamics(m, Q, Q, Q, f_tip={"tool0": HUGE}), "tau", "f_tip up to"
    ),
    "inverse_dynamics batch": (
        lambda m: od.inverse_dynamics(m, [Q, Q], [Q, BIG], Q), "tau", "qd up to 1e+200"
    ),
    "forward_dynamics aba": (lambda m: od.forward_dynamics(m, Q, Q, HUGE), "qdd", "tau up to"),
    "forward_dynamics crba": (
        lambda m: od.forward_dynamics(m, Q, Q, HUGE, method="crba"), "qdd", "tau up to"
    ),
    "forward_dynamics newton_euler": (
        lambda m: od.forward_dynamics(m, Q, Q, HUGE, method="newton_euler"), "qdd", "tau up to"
    ),
    "forward_dynamics qd": (lambda m: od.forward_dynamics(m, Q, BIG, Q), "qdd", "qd up to"),
    "forward_dynamics batch": (
        lambda m: od.forward_dynamics(m, [Q, Q], Q, [Q, HUGE]), "qdd", "tau up to"
    ),
    "gravity_forces": (
        lambda m: od.gravity_forces(m, Q, gravity=[0, 0, -1e308]), "g", "gravity up to"
    ),
    "coriolis_forces": (lambda m: od.coriolis_forces(m, Q, BIG), "c", "qd up to"),
    "bias_forces": (lambda m: od.bias_forces(m, Q, BIG), "h", "qd up to"),
    "coriolis_matrix": (lambda m: od.coriolis_matrix(m, Q, HUGE), "C", "qd up to"),
    "kinetic_energy": (lambda m: od.kinetic_energy(m, Q, BIG), "K", "qd up to"),
    "kinetic_energy batch": (lambda m: od.kinetic_energy(m, [Q, Q], [Q, BIG]), "K", "qd up to"),
    "potential_energy": (
        lambda m: od.potential_energy(m, Q, gravity=[0, 0, -1e308]), "U", "gravity up to"
    ),
    "frame_acceleration": (
        lambda m: od.frame_acceleration(m, Q, BIG, Q, "tool0"), "dV_b", "qd up to"
    ),
    "constraint_drift": (lambda m: od.constraint_drift(m, Q, BIG, POINT), "Adot_qd", "qd up to"),
    "constrained_forward_dynamics": (
        lambda m: od.constrained_forward_dynamics(m, Q, Q, HUGE, POINT), "qdd", "tau up to"
    ),
    "constrained_forward_dynamics A": (
        lambda m: od.constrained_forward_dynamics(m, Q, Q, HUGE, A=A_ROW, Adot_qd=[0.0]),
        "qdd",
        "tau up to",
    ),
    "constrained_inverse_dynamics": (
        lambda m: od.constrained_inverse_dynamics(m, Q, BIG, Q, A_ROW), "tau", "qd up to"
    ),
    "constraint_wrench": (
        lambda m: od.constraint_wrench(m, Q, "tool0", 1e300 * A_ROW, [1e308]), "F_tip", "lam up to"
    ),
    "integrate": (lambda m: od.integrate(m, Q, HUGE, 10.0), "q", "v up to"),
    "difference": (lambda m: od.difference(m, -HUGE, HUGE), "v", "q0 up to 1e+308"),
    "inverse_dynamics_derivatives": (
        lambda m: od.inverse_dynamics_derivatives(m, Q, BIG, Q), "dtau_dq", "qd up to"
    ),
    "forward_dynamics_derivatives": (
        lambda m: od.forward_dynamics_derivatives(m, Q, BIG, Q), "ddq_dq", "qd up to"
    ),
    "centroidal_momentum": (lambda m: od.centroidal_momentum(m, Q, HUGE), "h_G", "qd up to"),
    "centroidal_momentum_rate_bias": (
        lambda m: od.centroidal_momentum_rate_bias(m, Q, BIG), "Adot_G qd", "qd up to"
    ),
    "torque_regressor": (lambda m: od.torque_regressor(m, Q, BIG, Q), "Y", "qd up to"),
}


@pytest.mark.parametrize("case", OVERFLOWS)
def test_overflowing_result_is_an_error_naming_the_result(ur5, case):
    call, result, cause = OVERFLOWS[case]
    function = case.split()[0]
    with np.errstate(over="ignore", invalid="ignore"):
        with pytest.raises(od.NonFiniteResultError) as info:
            call(ur5)
    message = str(info.value)
    assert message.startswith(function) and f"the result {result} overflowed" in message, message
    assert f"likely cause: {cause}" in message, message
    assert info.value.result == result and isinstance(info.value, ValueError)


def test_overflow_on_a_floating_base_is_an_error_naming_the_result(solo):
    q = od.neutral(solo)
    q[:3] = 1e160  # the base position enters the Christoffel symbols squared
    with pytest.raises(od.NonFiniteResultError, match="result Gamma overflowed.*q up to 1e"):
        od.christoffel_symbols(solo, q)
    v = np.full(solo.nv, 1e308)
    with pytest.raises(od.NonFiniteResultError, match="integrate: the result q overflowed"):
        od.integrate(solo, od.neutral(solo), v, 10.0)


def test_a_simulation_whose_dynamics_overflow_stops_saying_so():
    """A push ramping up to 1e308 N: the run starts (finite energy), and its first step's
    accelerations overflow."""
    push = {"frame": "tip", "times": [0.0, 0.005], "values": [[0.0] * 6, [0, 0, 0, 1e308, 0, 0]]}
    data = {
        "robot": {"name": "double_pendulum"},
        "effects": {"gravity": True, "wrench": [push]},
        "run": {"max_speed": 1e308, "duration": 0.01},
    }
    traj = od.simulate(od.scene_from_dict(data), raise_on_failure=False)
    assert not traj.complete and traj.t[-1] == 0.0
    assert "the dynamics overflowed float64" in traj.message


def test_random_configuration_with_an_rng_that_is_not_one_is_a_type_error():
    model = od.load_urdf("double_pendulum")
    with pytest.raises(TypeError, match="rng must be a numpy Generator or an integer seed, got "
                       "str 'x'"):
        od.random_configuration(model, "x")


def _pendulum_scene():
    return od.load_scene("double_pendulum_swing")


# (call, error, words the message must hold): every switch of the public functions takes True
# or False only (a string "no" or a number would count as on), every count a whole number and
# every time a finite number; each refusal names the function and the argument
SWITCHES = {
    "load_urdf floating_base": (lambda: od.load_urdf("ur5", floating_base="yes"), TypeError,
                                "load_urdf: floating_base must be True or False, got 'yes'"),
    "load_urdf mimic": (lambda: od.load_urdf("ur5", mimic=1), TypeError,
                        "load_urdf: mimic must be True or False, got 1"),
    "load_urdf check_inertia": (lambda: od.load_urdf("ur5", check_inertia="no"), TypeError,
                                "load_urdf: check_inertia must be True or False"),
    "simulate progress": (lambda: od.simulate(_pendulum_scene(), progress=5), TypeError,
                          "simulate: progress must be True or False, got 5"),
    "simulate raise_on_failure": (
        lambda: od.simulate(_pendulum_scene(), raise_on_failure="no"), TypeError,
        "simulate: raise_on_failure must be True or False"),
    "rollout progress": (lambda: od.rollout(_pendulum_scene(), progress="yes"), TypeError,
                         "rollout: progress must be True or False"),
    "rollout threads": (lambda: od.rollout(_pendulum_scene(), threads=2.5), TypeError,
                        "rollout: threads must be a whole number, got 2.5"),
    "rollout threads 0": (lambda: od.rollout(_pendulum_scene(), threads=0), ValueError,
                          "rollout: threads must be at least 1, got 0"),
    "linearize discrete": (lambda: od.linearize(_pendulum_scene(), discrete="yes"), TypeError,
                           "linearize: discrete must be True or False"),
    "linearize t": (lambda: od.linearize(_pendulum_scene(), t=float("nan")), ValueError,
                    "linearize: t must be finite"),
    "torque_regressor friction": (
        lambda: od.torque_regressor(od.load_urdf("ur5"), *np.zeros((3, 6)), friction="x"),
        TypeError, "torque_regressor: friction must be True or False"),
    "identify friction": (
        lambda: od.identify(od.load_urdf("ur5"), *np.zeros((4, 20, 6)), friction="x"),
        TypeError, "identify: friction must be True or False"),
    "with_inertial_parameters check_inertia": (
        lambda: (lambda m: m.with_inertial_parameters(m.inertial_parameters(), check_inertia=0))(
            od.load_urdf("ur5")), TypeError,
        "with_inertial_parameters: check_inertia must be True or False, got 0"),
    "sweep progress": (
        lambda: od.sweep(_pendulum_scene(), {"run.duration": [0.1]}, progress="yes"),
        TypeError, "sweep: progress must be True or False"),
    "sweep seed": (
        lambda: od.sweep(_pendulum_scene(), {"run.duration": [0.1]}, seed=-1),
        od.SweepError, "seed: expected a whole number >= 0, found -1"),
    "sweep chunk_size": (
        lambda: od.sweep(_pendulum_scene(), {"run.duration": [0.1]}, chunk_size=0),
        od.SweepError, "chunk_size (--chunk): expected a whole number >= 1, found 0"),
    "verify seed": (lambda: verify("ur5", seed=-1), ValueError,
                    "verify: seed must be at least 0, got -1"),
}  # fmt: skip


@pytest.mark.parametrize("case", SWITCHES)
def test_switches_counts_and_times_of_the_wrong_kind_are_refused_naming_them(case):
    call, error, words = SWITCHES[case]
    with pytest.raises(error) as raised:
        call()
    assert words in str(raised.value)


def test_payload_values_of_the_wrong_kind_are_refused_naming_them():
    """with_payload took "2.5" as 2.5 kg and True as 1 kg, where every array argument of the
    API refuses text and booleans (the scene reader refuses mass = "2.5" too)."""
    ur5 = od.load_urdf("ur5")
    for kwargs, name in [
        (dict(mass="2.5"), "mass"),
        (dict(mass=True), "mass"),
        (dict(mass=1.0, com=(True, False, True)), "com"),
        (dict(mass=1.0, inertia=[["1", 0, 0], [0, 1, 0], [0, 0, 1]]), "inertia"),
        (dict(mass=1.0 + 0j), "mass"),
    ]:
        with pytest.raises(TypeError, match=rf"^{name} must be a number or an array of numbers"):
            ur5.with_payload("tool0", **kwargs)
    assert ur5.with_payload("tool0", np.float32(2.0), com=(0, 0, 1)).mass.sum() == pytest.approx(
        ur5.mass.sum() + 2.0
    )


def test_f_tip_that_is_not_a_mapping_is_a_type_error_naming_it():
    """f_tip=np.zeros(6) fell into numpy's "truth value of an array is ambiguous"."""
    ur5 = od.load_urdf("ur5")
    zeros = np.zeros(6)
    for f_tip in (np.zeros(6), [("tool0", np.zeros(6))], "tool0"):
        with pytest.raises(TypeError, match=r"^f_tip must be a dict \{frame_name: \(6,\) wrench"):
            od.inverse_dynamics(ur5, zeros, zeros, zeros, f_tip=f_tip)
    assert od.inverse_dynamics(ur5, zeros, zeros, zeros, f_tip={}).shape == (6,)


@pytest.mark.parametrize("where", ["q", "qd", "qdd", "tau"])
def test_identify_with_a_measurement_that_is_not_finite_names_the_sample(where):
    """A NaN or inf torque (a dropped measurement) went on to scipy's "array must not contain
    infs or NaNs"; NaN in q was blamed on torque_regressor."""
    ur5 = od.load_urdf("ur5")
    samples = list(np.random.default_rng(2).normal(size=(3, 20, 6)))
    samples.append(od.inverse_dynamics(ur5, *samples))
    k = ["q", "qd", "qdd", "tau"].index(where)
    samples[k][3, 2] = np.inf if where == "tau" else np.nan
    for call, what in [
        (lambda: od.identify(ur5, *samples), "identify"),
        (lambda: od.identify_payload(ur5, "tool0", *samples), "identify_payload"),
    ]:
        with pytest.raises(ValueError, match=rf"^{what}: {where} must be finite; sample 3 has "
                           r"(nan|inf) in column 2 \(1 such entries\)"):
            call()
