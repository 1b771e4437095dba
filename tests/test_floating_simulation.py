"""Simulating free-floating robots: scenes with a floating base, every integrator through
`integrate`, the effects on the joints only, and the physics of a body that nothing outside
pushes.

Independent references: Pinocchio (centre of mass and centroidal momentum of the same URDF with
a JointModelFreeFlyer root), the torque-free Euler equations' closed form in Jacobi elliptic
functions (Landau & Lifshitz, Mechanics, 3rd ed., Section 37), Newton's second law for the
centre of mass (m c'' = m g + external forces; internal forces cancel), and scipy's rotations.
"""

from __future__ import annotations

import numpy as np
import pytest
from randtree import write_random_tree
from scipy.spatial.transform import Rotation
from scipy.special import ellipk, ellipkinc

import opendyn as od
from opendyn.errors import SceneError
from opendyn.io.urdf import shipped_robots_dir
from opendyn.sim.record import QUATERNION_NORM_BOUND

pin = pytest.importorskip("pinocchio")
from pin_adapter import PinOracle  # noqa: E402

T_HANDLE = str(shipped_robots_dir() / "t_handle.urdf")


def _scene(data):
    base_dir = od.io.urdf.shipped_robots_dir()
    return od.scene_from_dict(data, source="floating.toml", base_dir=base_dir)


def _handle_scene(**initial):
    return _scene(
        {
            "robot": {"urdf": "t_handle.urdf", "floating_base": True},
            "initial": initial,
            "run": {"duration": 1.0, "dt": 1e-3},
        }
    )


def world_momentum(oracle, q, v):
    """(K, 6) the spatial momentum (angular about the world origin, linear) in world axes, from
    Pinocchio's centroidal momentum: L_O = L_c + c x p."""
    out = np.empty((len(q), 6))
    for k in range(len(q)):
        pq, pv = oracle.q(q[k]), oracle.v(v[k])
        pin.centerOfMass(oracle.model, oracle.data, pq, pv)
        h = pin.computeCentroidalMomentum(oracle.model, oracle.data, pq, pv)
        c = oracle.data.com[0]
        out[k, :3] = h.angular + np.cross(c, h.linear)
        out[k, 3:] = h.linear
    return out


def pin_kinetic_energy(oracle, q, v):
    return np.array(
        [
            pin.computeKineticEnergy(oracle.model, oracle.data, oracle.q(a), oracle.v(b))
            for a, b in zip(q, v)
        ]
    )


def centre_of_mass(oracle, q):
    return np.array([pin.centerOfMass(oracle.model, oracle.data, oracle.q(a)) for a in q])


# --- the scene's base state ------------------------------------------------------------------


def test_the_initial_base_motion_is_given_in_world_axes_and_stored_as_the_body_twist():
    rpy = [0.3, -0.7, 1.1]
    omega_s, p_dot = np.array([0.4, -1.0, 2.0]), np.array([0.5, 0.2, -0.3])
    scene = _handle_scene(
        base_position=[1.0, 2.0, 3.0],
        base_rpy=rpy,
        base_velocity=list(p_dot),
        base_angular_velocity=list(omega_s),
    )
    R_sb = Rotation.from_euler("xyz", rpy)  # URDF rpy: fixed axes x, then y, then z
    np.testing.assert_allclose(scene.q0[:3], [1.0, 2.0, 3.0])
    assert (Rotation.from_quat(scene.q0[3:7]) * R_sb.inv()).magnitude() < 1e-12
    R = R_sb.as_matrix()
    np.testing.assert_allclose(scene.qd0[:3], R.T @ omega_s, atol=1e-15)
    np.testing.assert_allclose(scene.qd0[3:6], R.T @ p_dot, atol=1e-15)
    # the same pose by quaternion gives the same state
    again = _handle_scene(
        base_position=[1.0, 2.0, 3.0],
        base_orientation=list(R_sb.as_quat()),
        base_velocity=list(p_dot),
        base_angular_velocity=list(omega_s),
    )
    np.testing.assert_allclose(again.q0, scene.q0, atol=1e-15)
    np.testing.assert_allclose(again.qd0, scene.qd0, atol=1e-15)


def test_a_floating_scene_defaults_to_the_neutral_base_at_rest():
    scene = _handle_scene()
    np.testing.assert_array_equal(scene.q0, [0, 0, 0, 0, 0, 0, 1])
    np.testing.assert_array_equal(scene.qd0, np.zeros(6))


@pytest.mark.parametrize(
    "initial, key, what",
    [
        ({"base_rpy": [0, 0, 0], "base_orientation": [0, 0, 0, 1]}, "initial.base_rpy", "both"),
        ({"base_orientation": [0, 0, 0, 2.0]}, "initial.base_orientation", "unit quaternion"),
        ({"base_orientation": [0, 0, 1]}, "initial.base_orientation", "list of 4"),
        ({"base_velocity": [0, 0]}, "initial.base_velocity", "list of 3"),
        ({"base_angular_velocity": "fast"}, "initial.base_angular_velocity", "list of 3"),
        ({"base_position": [0, 0, float("nan")]}, r"initial.base_position\[2\]", "finite"),
        ({"base_spin": [0, 0, 1]}, "initial.base_spin", "unknown key"),
    ],
)
def test_bad_base_keys_are_errors_naming_the_key(initial, key, what):
    with pytest.raises(SceneError, match=f"{key}: .*{what}"):
        _handle_scene(**initial)


def test_one_quaternion_tolerance_for_scene_files_the_simulator_linearize_and_the_dynamics():
    """A quaternion typed to four digits (norm 0.99998) is taken and normalised everywhere, as
    the dynamics functions take it; one further than 1e-3 from unit norm is refused everywhere.
    The scene file, Simulator.reset and linearize refused anything beyond 1e-6."""
    typed = [0.7071, 0.0, 0.0, 0.7071]
    scene = _handle_scene(base_orientation=typed)
    unit = np.array(typed) / np.linalg.norm(typed)
    np.testing.assert_allclose(scene.q0[3:7], unit, atol=1e-15)
    q = scene.q0.copy()
    q[3:7] = typed
    sim = od.Simulator(scene)
    sim.reset(q=q)
    np.testing.assert_allclose(sim.q[3:7], unit, atol=1e-15)
    # the typed quaternion is taken as the rotation of its unit one, scipy's (which normalises)
    R = Rotation.from_quat(typed).as_matrix()
    root = scene.model.frames[0].name
    np.testing.assert_allclose(od.frame_pose(scene.model, q, root)[:3, :3], R, atol=1e-15)
    # and so by linearize: a free body at rest under gravity has omega' = 0 and
    # v_b' = R^T g, so along e = (dtheta, dp) (T = T_0 exp(e)) v_b' moves by [R^T g]x dtheta
    falling = _scene(
        {
            "robot": {"urdf": "t_handle.urdf", "floating_base": True},
            "effects": {"gravity": True},
            "initial": {"base_orientation": typed},
        }
    )
    A, B = od.linearize(falling, q=q, qd=np.zeros(6))
    g_b = R.T @ np.array([0.0, 0.0, -9.81])
    K = np.zeros((6, 6))
    K[3:, :3] = [[0.0, -g_b[2], g_b[1]], [g_b[2], 0.0, -g_b[0]], [-g_b[1], g_b[0], 0.0]]
    expected = np.block([[np.zeros((6, 6)), np.eye(6)], [K, np.zeros((6, 6))]])
    np.testing.assert_allclose(A, expected, rtol=0, atol=1e-12)
    assert B.shape == (12, 0)  # the handle has no actuated joint
    od.mass_matrix(scene.model, q)  # taken (M of a lone free body does not depend on its pose)
    far = np.array([0.0, 0.0, 0.0, 1.002])
    with pytest.raises(SceneError, match="initial.base_orientation: .*unit quaternion"):
        _handle_scene(base_orientation=list(far))
    q[3:7] = far
    with pytest.raises(ValueError, match="unit norm"):
        sim.reset(q=q)
    with pytest.raises(ValueError, match="unit norm"):
        od.linearize(scene, q=q)
    with pytest.raises(ValueError, match="unit norm"):
        od.mass_matrix(scene.model, q)


def test_a_fixed_base_scene_with_a_base_key_is_an_error_naming_it():
    with pytest.raises(SceneError, match="initial.base_velocity: .*fixed base.*floating_base"):
        _scene({"robot": {"urdf": "t_handle.urdf"}, "initial": {"base_velocity": [0, 0, 1]}})


def test_the_robot_floating_base_key_must_be_a_boolean():
    with pytest.raises(SceneError, match="robot.floating_base: expected true or false"):
        _scene({"robot": {"urdf": "t_handle.urdf", "floating_base": "yes"}})


# --- the T-handle flips at the closed form's period ------------------------------------------


def euler_top_sign_changes(I, omega_0, n):
    """The first n times (s) at which the intermediate-axis angular velocity omega_2 of a
    torque-free rigid body changes sign, for principal inertias I = (I1 < I2 < I3) and initial
    body angular velocity omega_0 with L^2 > 2 E I2 (Landau & Lifshitz, Section 37, eq. 37.10):

      omega_1 = A1 cn(u), omega_2 = A2 sn(u), omega_3 = A3 dn(u),  u = s t + u0,
      A1^2 = (2E I3 - L^2) / (I1 (I3 - I1)), A2^2 = (2E I3 - L^2) / (I2 (I3 - I2)),
      A3^2 = (L^2 - 2E I1) / (I3 (I3 - I1)), s^2 = (I3 - I2)(L^2 - 2E I1) / (I1 I2 I3),
      m = k^2 = (I2 - I1)(2E I3 - L^2) / ((I3 - I2)(L^2 - 2E I1)),

    signs chosen so that omega_3 keeps the sign of omega_3(0) (dn > 0) and omega_2 has it too
    (Euler's equation I2 omega_2' = (I3 - I1) omega_3 omega_1). sn vanishes at u = 2 K(m) j, so
    omega_2 changes sign at t_j = (2 K j - u0) / s: every 2 K / s seconds (the flip)."""
    I1, I2, I3 = I
    two_E = float(I @ omega_0**2)
    L2 = float(((I * omega_0) ** 2).sum())
    assert L2 > two_E * I2  # the regime of these formulas (else exchange axes 1 and 3)
    A1 = np.sqrt((two_E * I3 - L2) / (I1 * (I3 - I1)))
    A2 = np.sqrt((two_E * I3 - L2) / (I2 * (I3 - I2)))
    s = np.sqrt((I3 - I2) * (L2 - two_E * I1) / (I1 * I2 * I3))
    m = (I2 - I1) * (two_E * I3 - L2) / ((I3 - I2) * (L2 - two_E * I1))
    sign = np.sign(omega_0[2])
    # u0: sn(u0) = omega_2(0) / (sign A2), cn(u0) = omega_1(0) / A1, u0 = F(am(u0) | m)
    u0 = ellipkinc(np.arctan2(omega_0[1] / (sign * A2), omega_0[0] / A1), m)
    K = ellipk(m)
    times = [(2 * K * j - u0) / s for j in range(-2, 2 * n + 2)]
    return np.array([t for t in times if t > 0][:n]), 2 * K / s


def sign_changes(t, x):
    """Times where x (K,) changes sign, by linear interpolation between samples."""
    k = np.flatnonzero(np.sign(x[:-1]) * np.sign(x[1:]) < 0)
    return t[k] - x[k] * (t[k + 1] - t[k]) / (x[k + 1] - x[k])


def test_the_t_handle_flips_at_the_period_of_the_closed_form():
    """The shipped T-handle (principal axes along its link frame, centre of mass at its origin)
    spun about its intermediate axis: omega_b = v[:3] is the body angular velocity of Euler's
    equations. Its sign changes land on the closed form's times (2.3268 s, then every 4.0028 s)
    within 1e-8 of the flip period (40 ns): RK4 at 1 ms keeps the energy to 1e-12 here, and
    interpolating the 1 ms samples linearly errs by about h^3 s^2 / 6 ~ 3e-9 s (sn's curvature
    vanishes at its zeros). Measured: 4e-10 s."""
    scene = od.load_scene("t_handle_flip").replace_run(output_dt=1e-3)
    model = scene.model
    assert model.floating_base and model.nq == 7
    traj = od.simulate(scene)
    inertia = np.array([0.00079, 0.004435, 0.005175])  # the URDF's principal moments
    expected, half_period = euler_top_sign_changes(inertia, scene.qd0[:3], 2)
    flips = sign_changes(traj.t, traj.qd[:, 1])
    assert len(flips) == len(expected) == 2  # it flips, twice in 10 s
    np.testing.assert_allclose(flips, expected, atol=1e-8 * half_period)
    np.testing.assert_allclose(np.diff(flips), half_period, atol=1e-8 * half_period)


# --- conservation without gravity ------------------------------------------------------------


@pytest.fixture(scope="module")
def free_tree(tmp_path_factory):
    path = write_random_tree(tmp_path_factory.mktemp("free"), 5, n_links=8)
    return str(path)


def test_momentum_and_energy_are_conserved_over_10_s(free_tree):
    """A floating random tree (7 bodies, revolute and prismatic joints) thrown with a random
    twist and joint velocities, no gravity, no effects: nothing acts from outside, so its
    spatial momentum in the world frame is constant, and nothing does work, so its kinetic
    energy is constant. RK4 at 1 ms over 10 s (Munthe-Kaas stages for the base): its global
    error is about T w^5 dt^4 relative, w the fastest rate of the motion (here |qd| < 2 rad/s:
    10 * 2^5 * 1e-12 = 3e-10); the bound 1e-9 of max |momentum| and of max E is that estimate
    with a margin (measured: 5e-13 and 1e-14, rounding). Summing the stages' body twists
    without the dexp^-1 correction made the momentum drift 5e-7, falling as dt^2."""
    model = od.load_urdf(free_tree, floating_base=True)
    rng = np.random.default_rng(0)
    v0 = rng.uniform(-1.0, 1.0, model.nv)
    data = {
        "robot": {"urdf": free_tree, "floating_base": True},
        "initial": {
            "base_position": [0.0, 0.0, 1.0],
            "base_rpy": [0.2, 0.3, -0.4],
            "base_velocity": list(v0[3:6]),
            "base_angular_velocity": list(v0[:3]),
            "q": list(rng.uniform(-1.0, 1.0, model.nv - 6).clip(model.lower, model.upper)),
            "qd": list(v0[6:]),
        },
        "run": {"duration": 10.0, "integrator": "rk4", "dt": 1e-3, "output_dt": 0.05},
    }
    traj = od.simulate(od.scene_from_dict(data))
    oracle = PinOracle(free_tree, model)
    assert np.abs(traj.qd[:, :6]).max() > 0.3  # the base does move
    h = world_momentum(oracle, traj.q, traj.qd)
    scale = np.abs(h).max()
    assert scale > 0.1
    np.testing.assert_allclose(h, np.broadcast_to(h[0], h.shape), atol=1e-9 * scale)
    energy = pin_kinetic_energy(oracle, traj.q, traj.qd)
    np.testing.assert_allclose(traj.kinetic, energy, rtol=1e-9)  # our energy is Pinocchio's
    assert np.abs(energy - energy[0]).max() <= 1e-9 * energy.max()
    assert traj.stats["quaternion_norm_error"] <= QUATERNION_NORM_BOUND


def test_a_humanoid_moving_its_joints_keeps_its_momentum():
    """The shipped G1 scene (zero gravity, PD on the 29 joints, the pelvis thrown), 1 s: the
    joint torques are internal forces, so the world-frame spatial momentum keeps its initial
    value while the posture changes by more than half a radian, and the energy changes by the
    controller's work. What is left is RK4's truncation error in the stiffest joint modes (the
    ankle roll: kp / I = 5 / 0.00032 kg m^2, w dt = 0.125 at 1 ms): it falls 16-fold when dt
    halves (measured 6e-8 and 4e-9 of the momentum at 1 and 0.5 ms), which a modelling error
    would not. Bounds: 1e-6 of the momentum and 1e-6 of the controller's work at 1 ms, and at
    least an 8-fold fall at half the step."""

    def errors(dt):
        scene = od.load_scene("g1_floating").replace_run(duration=1.0, dt=dt)
        traj = od.simulate(scene)
        model = scene.model
        joints = traj.q[:, model.q_index]
        assert np.abs(joints[-1] - joints[0]).max() > 0.5
        h = world_momentum(PinOracle(model.source, model), traj.q, traj.qd)
        assert np.abs(h).max() > 1.0
        work = np.abs(traj.work_applied).max()
        assert work > 1.0  # the controller does work
        momentum = np.abs(h - h[0]).max() / np.abs(h).max()
        return momentum, np.abs(traj.energy_error).max() / work

    momentum, energy = errors(1e-3)
    assert momentum < 1e-6 and energy < 1e-6
    momentum_half, energy_half = errors(5e-4)
    assert momentum_half < momentum / 8 and energy_half < energy / 8


# --- gravity -----------------------------------------------------------------------------------


def test_the_centre_of_mass_of_a_falling_quadruped_accelerates_at_g():
    """The shipped Solo12 scene: gravity and a PD controller moving the legs. Internal forces
    cancel, so the centre of mass follows c(t) = c0 + g t^2 / 2 exactly (Newton's second law
    for the whole body, released at rest); the legs move meanwhile, and the trunk does not fall
    at g. c from Pinocchio. The remainder is RK4's truncation error in the fast leg modes (the
    knee: kd / I = 0.05 / 0.00039 = 128 1/s): 4.5e-8 m at 1 ms, 16-fold less at 0.5 ms. Bounds:
    5e-7 m at 1 ms and at least an 8-fold fall at half the step."""

    def error(dt):
        scene = od.load_scene("solo12_falling").replace_run(dt=dt)
        traj = od.simulate(scene)
        model = scene.model
        joints = traj.q[:, model.q_index]
        assert np.abs(joints[-1] - joints[0]).max() > 0.3  # the legs moved
        c = centre_of_mass(PinOracle(model.source, model), traj.q)
        t = traj.t[:, None]
        g = np.array(scene.gravity)
        trunk_fall = traj.q[0, :3] + 0.5 * g * t**2
        assert np.abs(traj.q[:, :3] - trunk_fall).max() > 1e-3
        return np.abs(c - (c[0] + 0.5 * g * t**2)).max()

    at_1ms = error(1e-3)
    assert at_1ms < 5e-7
    assert error(5e-4) < at_1ms / 8


def test_computed_torque_on_a_floating_base_tracks_exactly():
    """Computed torque on the falling Solo12: the controller solves for the unactuated trunk's
    acceleration, so each joint follows e'' + kd e' + kp e = 0 from e(0) = e'(0) = 0: it tracks
    its sinusoid to the integrator's accuracy while the trunk tumbles."""
    scene = _scene(
        {
            "robot": {"name": "solo12", "floating_base": True},
            "initial": {"base_position": [0, 0, 1], "qd": {"FL_KFE": 0.2 * 2 * np.pi * 1.0}},
            "run": {"duration": 1.0, "dt": 1e-3},
            "effects": {"gravity": True},
            "control": {
                "type": "computed_torque",
                "kp": 100.0,
                "kd": 20.0,
                "amplitude": {"FL_KFE": 0.2},
                "frequency": 1.0,
            },
        }
    )
    traj = od.simulate(scene)
    model = scene.model
    k = model.joint_names.index("FL_KFE")
    reference = 0.2 * np.sin(2 * np.pi * traj.t)
    np.testing.assert_allclose(traj.q[:, model.q_index[k]], reference, atol=1e-9)
    others = np.delete(traj.q[:, model.q_index], k, axis=1)
    np.testing.assert_allclose(others, 0.0, atol=1e-9)
    assert np.abs(traj.q[-1, 3:6]).max() > 1e-3  # the trunk turned in reaction
    assert np.all(traj.tau[:, :6] == 0.0)  # the base is not actuated


# --- every integrator goes through integrate -------------------------------------------------


@pytest.mark.parametrize(
    "integrator, dt, rtol",
    [
        ("euler", 1e-4, 2e-3),
        ("semi_implicit_euler", 1e-4, 2e-3),
        ("implicit_euler", 1e-4, 2e-3),
        ("dopri5", 1e-3, 1e-6),
    ],
)
def test_every_integrator_advances_a_floating_base(free_tree, integrator, dt, rtol):
    """A floating tree with joint damping and PD, 0.5 s: every integrator ends where RK4 at
    0.1 ms does (the reference, accurate to about 1e-12), within its order's error (order 1 at
    dt = 0.1 ms: about dt w^2 T ~ 1e-3 of the motion; DOPRI5 within its tolerance), the
    difference taken on the configuration manifold; the quaternions stay unit."""
    model = od.load_urdf(free_tree, floating_base=True)
    data = {
        "robot": {"urdf": free_tree, "floating_base": True},
        "initial": {
            "base_angular_velocity": [0.5, -1.0, 0.8],
            "base_velocity": [0.3, 0.0, 0.1],
            "qd": [0.5] * (model.nv - 6),
        },
        "run": {"duration": 0.5, "dt": 1e-4, "rtol": 1e-10, "atol": 1e-12},
        "effects": {"damping": {"coefficients": 0.05}},
        "control": {"type": "pd", "kp": 2.0, "kd": 0.1, "setpoint": 0.3},
    }
    reference = od.simulate(od.scene_from_dict(data))
    data["run"].update(integrator=integrator, dt=dt)
    traj = od.simulate(od.scene_from_dict(data))
    assert traj.stats["quaternion_norm_error"] <= QUATERNION_NORM_BOUND
    size = np.abs(od.difference(model, reference.q[0], reference.q[-1])).max()
    error = np.abs(od.difference(model, reference.q[-1], traj.q[-1])).max()
    assert error <= rtol * max(size, 1.0)
    speed = np.abs(reference.qd).max()
    np.testing.assert_allclose(traj.qd[-1], reference.qd[-1], atol=10 * rtol * speed)


# --- effects act on the joints -----------------------------------------------------------------


def test_joint_damping_and_pd_do_not_push_the_base(free_tree):
    """Damping and PD on every joint of a floating tree without gravity (the effects of the
    integrator test above, so that no other step is compiled): both are internal, so the
    momentum stays (a damper or a spring on the base's own coordinates would brake or pull it)
    while the dampers take energy out, and the energy balance E - E(0) = W_applied + W_passive
    holds to RK4's error."""
    data = {
        "robot": {"urdf": free_tree, "floating_base": True},
        "initial": {"base_velocity": [1.0, 0.0, 0.0], "base_angular_velocity": [0.0, 0.0, 0.5]},
        "run": {"duration": 2.0, "dt": 1e-3},
        "effects": {"damping": {"coefficients": 0.5}},
        "control": {"type": "pd", "kp": 2.0, "kd": 0.1, "setpoint": 0.3},
    }
    traj = od.simulate(od.scene_from_dict(data))
    model = od.load_urdf(free_tree, floating_base=True)
    assert np.abs(traj.q[-1, model.q_index] - 0.3).max() < 0.3  # the joints moved to 0.3
    oracle = PinOracle(free_tree, model)
    h = world_momentum(oracle, traj.q, traj.qd)
    np.testing.assert_allclose(h, np.broadcast_to(h[0], h.shape), atol=1e-9 * np.abs(h).max())
    assert traj.work_passive[-1] < -1e-3  # the dampers took energy out
    assert np.abs(traj.energy_error).max() < 1e-9 * traj.energy.max()


def test_a_wrench_on_a_free_body_accelerates_it_by_newtons_law():
    """A constant 2 N force along world z, applied at the T-handle's centre of mass (its link
    origin) in world-aligned axes, while it spins steadily about its principal axis z: J^T F
    moves the base, the centre of mass accelerates at F / m = 2 m/s^2 (m = 1 kg), and a force
    through the centre of mass leaves the spin alone."""
    scene = _scene(
        {
            "robot": {"urdf": "t_handle.urdf", "floating_base": True},
            "initial": {"base_angular_velocity": [0.0, 0.0, 3.0]},
            "run": {"duration": 1.0, "dt": 1e-3},
            "effects": {
                "wrench": [
                    {"frame": "handle", "expressed_in": "world", "value": [0, 0, 0, 0, 0, 2]}
                ]
            },
        }
    )
    traj = od.simulate(scene)
    t = traj.t
    np.testing.assert_allclose(traj.q[:, :3], np.column_stack([0 * t, 0 * t, t**2]), atol=1e-12)
    np.testing.assert_allclose(traj.qd[:, :3], np.tile([0, 0, 3.0], (len(t), 1)), atol=1e-12)
    # the work of the force is the kinetic energy it gave: F z = 2 * 1 J at t = 1 s
    np.testing.assert_allclose(traj.work_applied[-1], 2.0, rtol=1e-9)


# --- the record ----------------------------------------------------------------------------------


def test_the_record_names_the_base_coordinates(tmp_path):
    scene = _handle_scene(base_angular_velocity=[0.0, 1.0, 0.0], base_velocity=[0.0, 0.0, 1.0])
    traj = od.simulate(scene)
    assert traj.q.shape[1] == 7 and traj.qd.shape[1] == 6
    assert traj.q_names == scene.model.q_names and traj.v_names == scene.model.v_names
    assert traj.q_names[3:7] == tuple(f"{traj.q_names[0][:-2]}_q{c}" for c in "xyzw")
    columns = traj.to_csv(tmp_path / "h.csv").read_text().splitlines()[0].split(",")
    assert columns[1:8] == [f"q_{n}" for n in scene.model.q_names]
    assert columns[8:14] == [f"qd_{n}" for n in scene.model.v_names]
    # the centre of mass (the link origin) rose 1 m in 1 s along world z while the handle
    # turned about its own y, a principal axis (a steady spin)
    np.testing.assert_allclose(traj.q[-1, :3], [0.0, 0.0, 1.0], atol=1e-9)
    np.testing.assert_allclose(traj.qd[-1, :3], [0.0, 1.0, 0.0], atol=1e-12)
    again = od.Trajectory.load(traj.save(tmp_path / "h.npz"))
    assert again.q_names == traj.q_names and again.v_names == traj.v_names
    assert traj.provenance["robot"]["floating_base"] is True


def test_the_playback_moves_the_floating_base(tmp_path):
    """The meshcat page of a T-handle spinning steadily about its principal axis z at 1 rad/s
    while drifting at 0.5 m/s along x: the handle's track is the pose T_sb(t) = (Rot(z, t),
    (0.5 t, 0, 1)) (steady rotation about a principal axis through the centre of mass)."""
    pytest.importorskip("meshcat")
    from test_viz import page_commands

    from opendyn.viz import playback as viz

    scene = _handle_scene(
        base_position=[0.0, 0.0, 1.0],
        base_velocity=[0.5, 0.0, 0.0],
        base_angular_velocity=[0.0, 0.0, 1.0],
    )
    traj = od.simulate(scene.replace_run(duration=2.0, output_dt=0.05))
    html = viz.write_html(scene.model, traj.t, traj.q, tmp_path / "page.html", fps=10)
    (animation,) = [c for c in page_commands(html.read_text()) if c["type"] == "set_animation"]
    (clip,) = [a["clip"] for a in animation["animations"] if a["path"].endswith("/handle")]
    tracks = {tr["name"]: tr["keys"] for tr in clip["tracks"]}
    times = np.array([k["time"] for k in tracks[".position"]]) / clip["fps"]
    np.testing.assert_allclose(times, np.linspace(0.0, 2.0, 21))
    position = np.array([k["value"] for k in tracks[".position"]])
    expected_position = np.column_stack([0.5 * times, 0 * times, 1 + 0 * times])
    np.testing.assert_allclose(position, expected_position, atol=1e-9)
    quaternion = np.array([k["value"] for k in tracks[".quaternion"]])  # (x, y, z, w)
    expected = np.column_stack([0 * times, 0 * times, np.sin(times / 2), np.cos(times / 2)])
    np.testing.assert_allclose(np.abs(np.sum(quaternion * expected, axis=1)), 1.0, atol=1e-9)


def test_a_floating_quadruped_on_pinned_feet_sags_without_losing_energy():
    """Solo12 with its four feet held by point_to_world constraints (12 rows on 18 velocities),
    no control, no damping: it sags under gravity (the trunk drops 0.2 m in 0.2 s, before the
    knees fold flat, a singular configuration), the ideal constraints do no work, so the energy
    stays constant (measured 3e-11 J), and the feet stay where they were (measured 6e-12 m)."""
    feet = ("FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT")
    scene = _scene(
        {
            "robot": {"name": "solo12", "floating_base": True},
            "initial": {
                "base_position": [0.0, 0.0, 0.3],
                "q": {"FL_HFE": 0.8, "FL_KFE": -1.6, "FR_HFE": 0.8, "FR_KFE": -1.6,
                      "HL_HFE": -0.8, "HL_KFE": 1.6, "HR_HFE": -0.8, "HR_KFE": 1.6},
            },
            "constraints": [{"type": "point_to_world", "frame": f} for f in feet],
            "effects": {"gravity": True},
            "run": {"duration": 0.2, "dt": 1e-3},
        }
    )
    traj = od.simulate(scene)
    assert traj.complete
    assert traj.violation_position.max() < 1e-8
    assert np.abs(traj.energy - traj.energy[0]).max() < 1e-6 * np.abs(traj.energy).max()
    assert traj.q[0, 2] - traj.q[-1, 2] > 1e-3  # the trunk really sags
    for foot in feet:
        start = od.frame_pose(scene.model, traj.q[0], foot)[:3, 3]
        end = od.frame_pose(scene.model, traj.q[-1], foot)[:3, 3]
        np.testing.assert_allclose(end, start, atol=1e-8)
