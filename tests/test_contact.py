"""Ground contact against closed forms and identities.

Closed forms (a point mass on a linear spring under gravity; Coulomb friction at constant
deceleration mu g) for the shipped ball_drop and box_slide scenes, statics for the quadruped
that stands (the ground carries exactly its weight), the contact law itself recomputed in
numpy from Jacobians of od.jacobian, with its linearisation against finite differences, and
independent references integrated by scipy: the spinning ball's Newton-Euler equations, and
the Solo12 standing and dropped (tests/contact_reference.py: the law in numpy on Pinocchio's
dynamics).
"""

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

import opendyn as od
from opendyn.algorithm.contact import compliant_contact
from opendyn.algorithm.contact_list import contact_room
from opendyn.algorithm.kinematics import forward_kinematics
from opendyn.errors import SceneError
from opendyn.io.urdf import shipped_robots_dir
from opendyn.sim import effects
from opendyn.sim.record import contact_record
from opendyn.sim.scene import thaw

G = 9.81
ROBOTS = shipped_robots_dir()


def variant(name, **contact):
    """The shipped scene `name` with [effects.contact] keys replaced."""
    data = thaw(od.load_scene(name).settings)
    data["effects"]["contact"].update(contact)
    return od.scene_from_dict(data, source=f"<{name} variant>", base_dir=ROBOTS)


def crossings(t, z):
    """The times where z (K,) changes sign, by linear interpolation between samples."""
    i = np.flatnonzero(np.sign(z[:-1]) != np.sign(z[1:]))
    return t[i] + z[i] / (z[i] - z[i + 1]) * (t[i + 1] - t[i])


# ------------------------------------------------------------------------------ the ball


BALL_M, BALL_R, BALL_K, BALL_H = 1.0, 0.1, 1e5, 0.5  # kg, m, N/m, m (robots/ball_drop.toml)


@pytest.fixture(scope="module")
def ball_bounce():
    """The ball's fall, bounce and rise at RK4, 0.1 ms, sampled at every step."""
    scene = od.load_scene("ball_drop")
    assert scene.contact.damping == 0 and scene.contact.friction == 0
    return od.simulate(scene.replace_run(duration=0.7, output_dt=scene.run.dt))


def test_ball_penetrates_to_the_closed_form_depth(ball_bounce):
    """Energy from the fall and into the spring: m g (h + delta) = k delta^2 / 2, so
    delta_max = (m g + sqrt((m g)^2 + 2 k m g h)) / k. The largest sampled penetration
    misses the peak by at most 1/2 (w dt / 2)^2 = 1.25e-4 of it (w = sqrt(k / m), samples every
    dt); RK4's own error is below that."""
    mg = BALL_M * G
    expected = (mg + np.sqrt(mg**2 + 2 * BALL_K * mg * BALL_H)) / BALL_K
    assert ball_bounce.penetration.max() == pytest.approx(expected, rel=2e-4)
    assert ball_bounce.contact_force[:, 0, 2].max() == pytest.approx(BALL_K * expected, rel=2e-4)
    # frictionless: the force is normal
    assert not ball_bounce.contact_force[:, :, :2].any()


def test_ball_contact_lasts_the_spring_with_gravity_time(ball_bounce):
    """In contact, m delta'' = m g - k delta from delta = 0, delta' = v0 = sqrt(2 g h): delta =
    m g / k + A sin(w t + phi) with A = sqrt((m g / k)^2 + (v0 / w)^2), which is positive for
    (pi + 2 asin(m g / (k A))) / w. The contact's start and end are the crossings of the
    lowest point through the ground (interpolated to O(dt^2 g / v0) = 3e-8 s)."""
    w = np.sqrt(BALL_K / BALL_M)
    v0 = np.sqrt(2 * G * BALL_H)
    offset = BALL_M * G / BALL_K
    amplitude = np.hypot(offset, v0 / w)
    expected = (np.pi + 2 * np.arcsin(offset / amplitude)) / w
    bottom = ball_bounce.q[:, 2] - BALL_R
    start, end = crossings(ball_bounce.t, bottom)[:2]
    assert start == pytest.approx(np.sqrt(2 * BALL_H / G), abs=1e-7)
    assert end - start == pytest.approx(expected, abs=1e-7)


def test_undamped_frictionless_ball_conserves_energy_and_returns_to_its_height(ball_bounce):
    """E = T + U_gravity + k delta^2 / 2 stays constant; the touch-down and lift-off kinks of
    the force cost RK4 its order there (measured: 1.8e-5 of E at 0.1 ms, 1.6e-5 at 0.05 ms), so
    the bound is 1e-4 of E, and the ball's apex after the bounce is h within that energy over
    m g."""
    E = ball_bounce.energy
    assert np.abs(E - E[0]).max() < 1e-4 * E[0]
    assert not ball_bounce.work_passive.any() and not ball_bounce.work_applied.any()
    after = ball_bounce.t > 0.5
    apex = ball_bounce.q[after, 2].max() - BALL_R
    assert apex == pytest.approx(BALL_H, abs=1e-4 * E[0] / (BALL_M * G))


def test_damped_ball_comes_to_rest_at_its_static_penetration_and_the_balance_closes():
    """With a normal damper it bounces lower each time and rests where k delta = m g; the
    energy it loses is the work of the damper (and of the clamp that lets the spring go while
    f_n would pull), W_passive, to the integrator's error."""
    scene = variant("ball_drop", damping=200.0).replace_run(duration=3.0)
    traj = od.simulate(scene)
    assert traj.penetration[-1, 0] == pytest.approx(BALL_M * G / BALL_K, rel=1e-9)
    assert traj.contact_force[-1, 0, 2] == pytest.approx(BALL_M * G, rel=1e-9)
    lost = traj.energy[0] - traj.energy[-1]
    assert lost > 0.99 * BALL_M * G * BALL_H  # nearly all of it
    assert traj.work_passive[-1] == pytest.approx(-lost, rel=1e-4)
    assert np.abs(traj.energy_error).max() < 1e-4 * lost


# ------------------------------------------------------------------------------- the box


def regularised_stop(v0, mu, v_s):
    """Where a point mass sliding at v0 stops under the regularised friction
    a = -mu g v / sqrt(v^2 + v_s^2): dx = v dt = sqrt(v^2 + v_s^2) dv / (mu g), so
    x = (v0 sqrt(v0^2 + v_s^2) + v_s^2 asinh(v0 / v_s)) / (2 mu g)."""
    return (v0 * np.hypot(v0, v_s) + v_s**2 * np.arcsinh(v0 / v_s)) / (2 * mu * G)


def test_box_slides_to_rest_after_v0_squared_over_two_mu_g():
    """The box slides at 1 m/s on mu = 0.5 and stops after v0^2 / (2 mu g) = 0.1019 m, plus the
    regularisation's share x_reg - v0^2 / (2 mu g) <= (v_s^2 / (2 mu g)) (1/2 + asinh(v0 / v_s))
    (8.3e-7 m here). A rigid box on compliant corners adds one thing a point mass has not:
    friction below its centre pitches it by theta (6e-5 rad at k = 1e5), and when it stops its
    corners stick while it rocks back, which moves its centre by up to (h / 2) theta_max
    (h = 0.05 m its height; the effect falls as 1/k: 10x smaller at k = 1e6). RK4 at 0.1 ms
    (the friction damper near zero slip, mu f_n / v_s per corner, needs a small explicit
    step); its four bottom corners carry its weight throughout."""
    scene = od.load_scene("box_slide").replace_run(integrator="rk4", dt=1e-4, duration=0.4)
    traj = od.simulate(scene)
    v0, mu, v_s = 1.0, scene.contact.friction, scene.contact.slip_velocity
    travelled = traj.q[-1, 0] - traj.q[0, 0]
    coulomb = v0**2 / (2 * mu * G)
    regularisation = v_s**2 / (2 * mu * G) * (0.5 + np.arcsinh(v0 / v_s))
    pitch = 2 * np.arcsin(np.abs(traj.q[:, 4]))  # the quaternion's y part: rotation about y
    rocking = 0.05 / 2 * pitch.max()
    assert 0 < pitch.max() < 1e-4
    assert abs(travelled - coulomb) <= regularisation + rocking
    assert abs(travelled - regularised_stop(v0, mu, v_s)) <= rocking
    # stopped, after Coulomb's v0 / (mu g)
    assert np.abs(traj.qd[-1, 3:]).max() < 1e-6
    moving = traj.t[np.abs(traj.qd[:, 3]) > 1e-3]
    assert moving[-1] == pytest.approx(v0 / (mu * G), abs=2e-3)
    weight = 2.0 * G
    np.testing.assert_allclose(traj.contact_force[:, :, 2].sum(axis=1), weight, rtol=1e-3)


def test_implicit_euler_box_stops_within_its_first_order_error():
    """The shipped scene (implicit Euler at 1 ms): the stop is off the regularised closed form
    by Euler's O(dt) error, about v0 dt / 2, and halving the step halves it."""
    scene = od.load_scene("box_slide")
    x = regularised_stop(1.0, scene.contact.friction, scene.contact.slip_velocity)
    errors = []
    for dt in (1e-3, 5e-4):
        traj = od.simulate(scene.replace_run(dt=dt, output_dt=1e-3, duration=0.4))
        errors.append(abs(traj.q[-1, 0] - x))
    assert errors[0] < 1.0 * 1e-3
    assert errors[0] / errors[1] == pytest.approx(2.0, rel=0.1)


def test_frictionless_box_never_slows():
    """mu = 0: every contact force is vertical, so the horizontal momentum is conserved."""
    scene = variant("box_slide", friction=0.0).replace_run(integrator="rk4", dt=1e-4)
    traj = od.simulate(scene)
    R = od.frame_pose(scene.model, traj.q, "box")[:, :3, :3]
    v_world = np.einsum("kij,kj->ki", R, traj.qd[:, 3:6])
    np.testing.assert_allclose(v_world[:, 0], 1.0, rtol=0, atol=1e-12)
    assert traj.q[-1, 0] == pytest.approx(scene.run.duration, abs=1e-9)
    assert not traj.contact_force[:, :, :2].any()


# ------------------------------------------------------------------------- the quadruped


@pytest.fixture(scope="module")
def quadruped():
    scene = od.load_scene("quadruped_drop")
    return scene, od.simulate(scene)


def test_quadruped_lands_and_the_ground_carries_its_weight(quadruped):
    """Once settled (from t = 1.5 s, for 5 s), the trunk's acceleration vanishes, so the
    contact forces sum to the weight m g: within 1e-6 of it at every sample (measured: 1e-7
    from 1.4 s on); before, the landing (at about 0.25 s) pushed harder."""
    scene, traj = quadruped
    weight = float(np.sum(scene.model.mass)) * G
    total = traj.contact_force.sum(axis=1)
    settled = traj.t >= 1.5
    assert traj.t[-1] - 1.5 >= 5.0 - 1e-9
    assert np.abs(total[settled, 2] / weight - 1).max() < 1e-6
    assert np.abs(total[settled, :2]).max() < 1e-5 * weight  # the feet's creep, slowing
    assert total[:, 2].max() > 3 * weight  # the impact
    assert traj.complete and traj.penetration.max() < 2e-3


def standing_solo(duration):
    """The drop scene's Solo12 set on its feet at rest, in its posture, each foot in the ground
    by its share of the weight m g / (4 k), for `duration` s, sampled every 10 ms."""
    data = thaw(od.load_scene("quadruped_drop").settings)
    scene = od.scene_from_dict(data, base_dir=ROBOTS)
    m, c = float(np.sum(scene.model.mass)), scene.contact
    low = min(od.frame_pose(scene.model, scene.q0, p.frame)[2, 3] - p.radius for p in c.points)
    height = scene.q0[2] - (low - c.ground_height) - m * G / (4 * c.stiffness)
    data["initial"]["base_position"] = [0.0, 0.0, height]
    data["run"].update(duration=duration, output_dt=0.01)
    return od.scene_from_dict(data, source="<solo12 standing>", base_dir=ROBOTS)


def creep(t, q, x, since):
    """From `since` on: how far the trunk sinks (m) and the farthest a foot's lowest point x
    (K, P, 3) slides (m)."""
    s = t >= since - 1e-9
    feet = x[s][:, :, :2]
    return q[s][0, 2] - q[s][-1, 2], np.linalg.norm(feet[-1] - feet[0], axis=1).max()


STAND_T, STAND_SETTLED = 1.2, 0.9  # s: the horizon, and when the joints have given


def test_quadruped_stands_and_creeps_as_the_reference_does():
    """Solo12 set on its feet at rest, against the independent reference of
    tests/contact_reference.py (the contact law in numpy, Pinocchio's ABA, scipy's LSODA at
    rtol = atol = 1e-10). In the reference its PD joints give under the load (the trunk sinks
    10 mm) and by 0.9 s it stands: the ground carries its weight (sum f_z = m g + m a_z, the
    trunk's acceleration left by the giving and the creep: 3e-7 of m g) and it creeps: the
    regularised friction is a damper near zero slip, so the splayed feet slide outward under
    the legs' push (0.4 mm/s) and the trunk sinks (0.16 mm/s).

    opendyn's DOPRI5 at rtol = atol = 1e-8 follows it within its tolerance: 1e-8 in q (m, rad),
    k 1e-8 = 1e-3 N in the forces (the contact's stiffness turns a position error into force)
    and 1e-5 in qd (w 1e-8, w = sqrt(k / m_p) ~ 1e3 /s for the feet's apparent masses m_p ~ 0.1
    kg); measured 3e-10, 3e-5 N, 5e-8: the same physics. The scene's implicit Euler at 1 ms
    stands and creeps as the reference does, off it by its own first-order error: halving the
    step halves the state's error (measured ratio 1.98), and with x(dt) = x* + a dt + b dt^2,
    x(dt) - x* = 2 (x(dt) - x(dt/2)) - b dt^2 / 2: the creep's sink and slide and the contact
    forces are held to 3 |x(dt) - x(dt/2)|, which leaves the second-order remainder up to half
    of the first-order estimate (measured: 1.8, 2.4 and 2.3 times |x(dt) - x(dt/2)|; its sink
    and slide are within 3e-5 of the reference's, relative)."""
    pytest.importorskip("pinocchio")
    from contact_reference import ContactReference

    scene = standing_solo(STAND_T)
    weight = float(np.sum(scene.model.mass)) * G
    t = np.linspace(0.0, STAND_T, round(STAND_T / 0.01) + 1)
    q, qd, x, f, _ = ContactReference(scene).solve(t, 1e-10, 1e-10, method="LSODA")
    settled = t >= STAND_SETTLED - 1e-9
    # the reference stands: every foot pressing, the trunk level and high, the weight carried
    assert (f[settled, :, 2] > 0.2 * weight / 4).all()
    assert 0.2 < q[settled, 2].min() and np.abs(q[settled, 3:5]).max() < 1e-6
    assert np.abs(f[settled, :, 2].sum(axis=1) / weight - 1).max() < 1e-6
    # and creeps: the feet slide outward (away from the trunk's centre), the trunk sinks
    sink_ref, slide_ref = creep(t, q, x, STAND_SETTLED)
    assert 2e-5 < sink_ref < 1e-4 and 5e-5 < slide_ref < 3e-4
    out = np.einsum("pi,pi->p", x[-1, :, :2] - x[0, :, :2], x[0, :, :2] - q[0, :2])
    assert (out > 0).all()

    dopri = od.simulate(scene.replace_run(integrator="dopri5", rtol=1e-8, atol=1e-8))
    assert np.allclose(dopri.t, t)
    assert np.abs(dopri.q - q).max() < 1e-8 and np.abs(dopri.qd - qd).max() < 1e-5
    assert np.abs(dopri.contact_force - f).max() < 1e-3

    coarse, fine = (
        od.simulate(scene.replace_run(integrator="implicit_euler", dt=dt)) for dt in (1e-3, 5e-4)
    )
    errors = [np.abs(run.q - q).max() for run in (coarse, fine)]
    assert errors[0] / errors[1] == pytest.approx(2.0, rel=0.1)
    creeps = [creep(run.t, run.q, run.contact_point, STAND_SETTLED) for run in (coarse, fine)]
    for ours, theirs, finer in (
        (creeps[0], (sink_ref, slide_ref), creeps[1]),
        (coarse.contact_force[settled], f[settled], fine.contact_force[settled]),
    ):
        ours, theirs, finer = map(np.asarray, (ours, theirs, finer))
        assert np.abs(ours - theirs).max() <= 3 * np.abs(ours - finer).max()
    # standing, as the reference does
    assert np.abs(coarse.contact_force[settled, :, 2].sum(axis=1) / weight - 1).max() < 1e-6
    assert 0.2 < coarse.q[settled, 2].min() and (coarse.penetration[settled] > 0).all()
    tilt = 2 * np.arcsin(np.linalg.norm(coarse.q[settled, 3:5], axis=1))
    assert tilt.max() < 1e-3


def test_humanoid_stands_on_the_spheres_of_its_feet():
    """G1 on the eight foot spheres of its URDF: after settling the ground carries its weight
    within 1e-6, all eight spheres touch, and the pelvis holds its height within 0.5 mm."""
    scene = od.load_scene("humanoid_stand")
    assert len(scene.contact.points) == 8
    traj = od.simulate(scene.replace_run(duration=2.0))
    weight = float(np.sum(scene.model.mass)) * G
    settled = traj.t >= 1.0
    np.testing.assert_allclose(traj.contact_force[settled, :, 2].sum(axis=1), weight, rtol=1e-6)
    assert (traj.penetration[settled] > 0).all()
    assert np.ptp(traj.q[settled, 2]) < 5e-4


# ---------------------------------------------------------------- the law and its linearisation


def _solo_in_contact(friction, damping):
    """Solo12 at a random state with its four feet 1 mm into the ground at h = 0.05 m."""
    data = thaw(od.load_scene("quadruped_drop").settings)
    data["effects"]["contact"].update(friction=friction, damping=damping, ground_height=0.0)
    scene = od.scene_from_dict(data, base_dir=ROBOTS)
    model = scene.model
    rng = np.random.default_rng(7)
    q = scene.q0.copy()
    q[7:] += rng.uniform(-0.1, 0.1, model.nv - 6)
    feet = [od.frame_pose(model, q, p.frame)[2, 3] - p.radius for p in scene.contact.points]
    q[2] -= max(feet) + 1e-3  # every foot at least 1 mm in
    qd = rng.normal(0, 0.3, model.nv)
    return scene, q, qd


def _contact_tau(scene, q, qd, jac=False):
    """(tau, K, D) of the compliant law at (q, qd) (the step's kernel on its contact list) and
    the spheres' (x, f, delta) as the record keeps them."""
    model = scene.model
    spheres = effects.contact.contact_table(model, scene.contact)
    tau, K, D = np.zeros(model.nv), np.zeros((model.nv,) * 2), np.zeros((model.nv,) * 2)
    work = model.data()._work
    forward_kinematics(model._ibuf, model._fbuf, work, q)
    compliant_contact(
        (model._ibuf, model._fbuf, work), contact_room(spheres, None, model.nv),
        (spheres, None), spheres.law, qd, (tau, (K, D, np.bool_(jac))), None, None,
    )
    x, f, delta = contact_record(model, spheres, q[None], qd[None])
    return tau, K, D, x[0], f[0], delta[0]


def test_contact_force_is_the_law_at_the_point_mapped_by_the_jacobian_transpose():
    """Recomputed in numpy: each foot's lowest point x_p from frame_pose, its velocity
    v_p = v + w x x_p from the space Jacobian (w, v) of od.jacobian, the law
    f_n = k delta + d delta_dot, f_t = -mu f_n v_t / sqrt(|v_t|^2 + v_s^2), and
    tau = sum_p J_p^T f_p with J_p = J_v - [x_p] J_w."""
    scene, q, qd = _solo_in_contact(friction=0.8, damping=300.0)
    c = scene.contact
    tau, _, _, x, f, delta = _contact_tau(scene, q, qd)
    expected = np.zeros(scene.model.nv)
    for p, point in enumerate(scene.contact.points):
        T = od.frame_pose(scene.model, q, point.frame)
        x_p = T[:3, :3] @ point.position + T[:3, 3] - [0, 0, point.radius]
        J = od.jacobian(scene.model, q, point.frame, expressed_in="space")
        J_p = J[3:] - np.cross(x_p, J[:3].T).T
        v = J_p @ qd
        d = c.ground_height - x_p[2]
        f_n = max(0.0, c.stiffness * d - c.damping * v[2])
        f_t = -c.friction * f_n * v[:2] / np.sqrt(v[0] ** 2 + v[1] ** 2 + c.slip_velocity**2)
        force = np.array([*f_t, f_n])
        np.testing.assert_allclose(x[p], x_p, atol=1e-15)
        assert delta[p] == pytest.approx(d, abs=1e-15) and d > 0
        np.testing.assert_allclose(f[p], force, rtol=1e-12, atol=1e-12)
        expected += J_p.T @ force
    np.testing.assert_allclose(tau, expected, rtol=1e-12, atol=1e-10)


def _central_differences(scene, q, qd, along):
    """-dtau/dq (along "q", along integrate) or -dtau/dqd (along "qd") of the contact forces,
    by central differences with step 1e-7."""
    model = scene.model
    eps = 1e-7
    fd = np.empty((model.nv, model.nv))
    for j in range(model.nv):
        e = np.zeros(model.nv)
        e[j] = eps
        if along == "q":
            plus = _contact_tau(scene, od.integrate(model, q, e, 1.0), qd)[0]
            minus = _contact_tau(scene, od.integrate(model, q, -e, 1.0), qd)[0]
        else:
            plus, minus = _contact_tau(scene, q, qd + e)[0], _contact_tau(scene, q, qd - e)[0]
        fd[:, j] = -(plus - minus) / (2 * eps)
    return fd


@pytest.mark.parametrize("friction, damping", [(0.8, 300.0), (0.8, 0.0), (0.0, 0.0)])
def test_contact_stiffness_and_damping_matrices_are_the_exact_derivatives(friction, damping):
    """K = -dtau/dq and D = -dtau/dqd exactly: the friction turning with the normal force, the
    normal damper and the contact's geometry (the lever arm and the point moving with the
    body) included, by central differences (along integrate for q). They were the symmetric
    k J_z^T J_z and the friction's slope alone, which made implicit Euler's steps on the Solo12
    drop 2-14 times less accurate (the contact guide, the accuracy study)."""
    scene, q, qd = _solo_in_contact(friction=friction, damping=damping)
    _, K, D, _, f, _ = _contact_tau(scene, q, qd, jac=True)
    assert (f[:, 2] > 1.0).sum() >= 2  # feet pressing, away from the clamp at f_n = 0
    K_fd, D_fd = _central_differences(scene, q, qd, "q"), _central_differences(scene, q, qd, "qd")
    np.testing.assert_allclose(K, K_fd, rtol=0, atol=1e-6 * np.abs(K).max())
    np.testing.assert_allclose(D, D_fd, rtol=0, atol=1e-6 * max(np.abs(D).max(), 1.0))
    if friction:  # the friction's slopes through f_n and the geometry: not symmetric
        assert np.abs(K - K.T).max() > 1e-3 * np.abs(K).max()


def test_contact_derivatives_equal_linearizes_independent_ones():
    """The compiled K, D of the implicit step against the effect's own numpy derivatives
    (opendyn.sim.effects.contact.tangent, which linearize uses), to rounding."""
    from opendyn.sim.effects.tangent import LinearAt, space_axes

    scene, q, qd = _solo_in_contact(friction=0.8, damping=300.0)
    tau, K, D, *_ = _contact_tau(scene, q, qd, jac=True)
    at = LinearAt(scene, 0.0, q, qd, None, None, space_axes(scene.model, q), None)
    tau_np, dtau_dq, dtau_dqd = effects.contact.tangent(scene.contact, at)
    np.testing.assert_allclose(tau, tau_np, rtol=0, atol=1e-12 * np.abs(tau).max())
    np.testing.assert_allclose(K, -dtau_dq, rtol=0, atol=1e-12 * np.abs(K).max())
    np.testing.assert_allclose(D, -dtau_dqd, rtol=0, atol=1e-12 * np.abs(D).max())


DROP_T, DROP_STANCE = 0.75, 0.5  # s: the horizon, and when the landing's bounce has died out


def test_implicit_euler_with_the_exact_contact_derivatives_follows_the_reference():
    """The Solo12 drop (it lands at 0.25 s), 0.75 s sampled every 1 ms, against the independent
    reference of tests/contact_reference.py (scipy's LSODA at rtol = atol = 1e-10): implicit
    Euler at the scene's dt = 1 ms follows it within its own first-order error. Through the
    landing the error is at most the step-halving estimate 2 max |x(dt) - x(dt/2)| (measured
    8.2e-3 against 2.0e-2; the step's touchdown falls up to a step off the reference's), and in
    stance, from 0.5 s, halving the step halves the error (measured ratios 1.99 in q, 1.90 in
    qd): it converges to the reference. (The symmetric k J_z^T J_z and the friction's slope
    alone, which the exact derivatives replaced, were 7.6e-2 off.)"""
    pytest.importorskip("pinocchio")
    from contact_reference import ContactReference

    base = od.load_scene("quadruped_drop").replace_run(duration=DROP_T, output_dt=1e-3)
    t = np.linspace(0.0, DROP_T, round(DROP_T / 1e-3) + 1)
    q, qd, *_ = ContactReference(base).solve(t, 1e-10, 1e-10, method="LSODA")
    coarse, fine = (
        od.simulate(base.replace_run(integrator="implicit_euler", dt=dt)) for dt in (1e-3, 5e-4)
    )
    assert np.allclose(coarse.t, t) and np.allclose(fine.t, t)
    error = np.abs(coarse.q - q).max()
    assert 0 < error <= 2 * np.abs(coarse.q - fine.q).max()
    stance = t >= DROP_STANCE
    for name, x_ref in (("q", q), ("qd", qd)):
        e_coarse, e_fine = (
            np.abs(getattr(run, name)[stance] - x_ref[stance]).max() for run in (coarse, fine)
        )
        assert e_coarse / e_fine == pytest.approx(2.0, rel=0.1), name


# ------------------------------------------- an independent reference: the ball that rolls off


# robots/ball.urdf (a solid ball, I = 2/5 m r^2 about its centre) thrown at the ground, sliding
# and spinning backwards: damping, friction and a slip velocity wide enough for scipy's RK45
SPIN_K, SPIN_D, SPIN_MU, SPIN_VS = 1e5, 50.0, 0.5, 1e-2
SPIN_P0, SPIN_V0, SPIN_W0 = (0.0, 0.0, 0.12), (1.0, 0.0, -0.5), (0.0, 3.0, 2.0)  # world frame
SPIN_T = 0.25  # s: touchdown at 35 ms, the contact about 10 ms, then flight


def spinning_ball():
    data = thaw(od.load_scene("ball_drop").settings)
    data["effects"]["contact"].update(damping=SPIN_D, friction=SPIN_MU, slip_velocity=SPIN_VS)
    data["initial"].update(
        base_position=list(SPIN_P0),
        base_velocity=list(SPIN_V0),
        base_angular_velocity=list(SPIN_W0),
    )
    data["run"].update(duration=SPIN_T, output_dt=1e-3)
    return od.scene_from_dict(data, source="<spinning ball>", base_dir=ROBOTS)


def ball_newton_euler(t, y):
    """The ball's Newton-Euler equations with the contact law of docs/guides/contact.md,
    written here: state (p, quat xyzw, v, omega), all in the world frame; the sphere (radius
    BALL_R, centred on the body's origin) touches at its lowest point p - r e_z, whose velocity
    is v + omega x (-r e_z); f_n = max(0, k delta + d delta_dot) along +z, f_t = -mu f_n v_t /
    sqrt(|v_t|^2 + v_s^2). The inertia is isotropic, so omega x I omega = 0."""
    p, quat, v, w = y[:3], y[3:7], y[7:10], y[10:13]
    force = np.array([0.0, 0.0, -BALL_M * G])
    moment = np.zeros(3)
    delta = BALL_R - p[2]
    if delta > 0:
        arm = np.array([0.0, 0.0, -BALL_R])
        vp = v + np.cross(w, arm)
        fn = max(0.0, SPIN_K * delta - SPIN_D * vp[2])
        ft = -SPIN_MU * fn * vp[:2] / np.sqrt(vp[:2] @ vp[:2] + SPIN_VS**2)
        contact = np.array([ft[0], ft[1], fn])
        force += contact
        moment = np.cross(arm, contact)
    x, y_, z, s = quat
    wx, wy, wz = w  # d quat / dt = (omega, 0) (x) quat / 2, Hamilton product, xyzw
    dquat = 0.5 * np.array(
        [
            s * wx + wy * z - wz * y_,
            s * wy + wz * x - wx * z,
            s * wz + wx * y_ - wy * x,
            -(wx * x + wy * y_ + wz * z),
        ]
    )
    inertia = 0.4 * BALL_M * BALL_R**2
    return np.concatenate([v, dquat, force / BALL_M, moment / inertia])


@pytest.fixture(scope="module")
def spinning_ball_reference():
    """(t, q, qd) of the ball by scipy's RK45 at rtol 1e-10, in opendyn's conventions (q =
    (p, quat xyzw), qd = (omega_b, v_b) in the body frame), sampled every 1 ms."""
    y0 = np.concatenate([SPIN_P0, [0.0, 0.0, 0.0, 1.0], SPIN_V0, SPIN_W0])
    t = np.linspace(0.0, SPIN_T, 251)
    sol = solve_ivp(ball_newton_euler, (0.0, SPIN_T), y0, rtol=1e-10, atol=1e-12, t_eval=t)
    assert sol.success
    y = sol.y.T
    rot = Rotation.from_quat(y[:, 3:7]).inv()
    return t, y[:, :7], np.hstack([rot.apply(y[:, 10:13]), rot.apply(y[:, 7:10])])


def test_spinning_ball_reference_rolls_off_at_the_closed_form_speed(spinning_ball_reference):
    """About the contact point (straight under the centre), gravity and the contact force have
    no moment, so I omega_y + m r v_x is kept through the bounce: 0.004 x 3 + 0.1 x 1; friction
    brings the ball to rolling, v_x = r omega_y, so it leaves at omega_y = (I omega_0 + m r v_0)
    / (I + m r^2) = 8 rad/s, v_x = 0.8 m/s (for the solid ball (5 v_0 + 2 r omega_0) / 7)."""
    t, q, qd = spinning_ball_reference
    inertia = 0.4 * BALL_M * BALL_R**2
    w_roll = (inertia * SPIN_W0[1] + BALL_M * BALL_R * SPIN_V0[0]) / (inertia + BALL_M * BALL_R**2)
    v_roll = BALL_R * w_roll
    assert v_roll == pytest.approx((5 * SPIN_V0[0] + 2 * BALL_R * SPIN_W0[1]) / 7)
    flight = (t > 0.1) & (q[:, 2] > BALL_R)
    assert flight.sum() > 50  # it bounced: in the air from 0.1 s on
    rot = Rotation.from_quat(q[flight, 3:7])
    v_world, w_world = rot.apply(qd[flight, 3:]), rot.apply(qd[flight, :3])
    assert np.abs(v_world[:, 0] - v_roll).max() < 1e-6
    assert np.abs(w_world[:, 1] - v_roll / BALL_R).max() < 1e-5
    assert np.abs(w_world[:, 2] - SPIN_W0[2]).max() < 1e-9  # no torsional friction


def test_dopri5_follows_the_independent_reference_on_the_spinning_ball(spinning_ball_reference):
    """DOPRI5 at rtol = atol = 1e-10 against the same law integrated by scipy at 1e-10: the two
    tolerances allow 1e-10 per unit time, the touchdown's jump of the damper force lets the
    step controllers differ there; measured 5e-9 m and 2e-7 m/s, held to 1e-7 and 1e-5."""
    t, q, qd = spinning_ball_reference
    run = od.simulate(spinning_ball().replace_run(integrator="dopri5", rtol=1e-10, atol=1e-10))
    assert np.allclose(run.t, t)
    assert np.abs(run.q - q).max() < 1e-7
    assert np.abs(run.qd - qd).max() < 1e-5
    assert run.penetration.max() == pytest.approx((BALL_R - q[:, 2]).max(), rel=1e-5)


def test_implicit_euler_converges_at_first_order_to_the_independent_reference(
    spinning_ball_reference,
):
    """Implicit Euler, first order: at 0.1 s (in flight after the bounce) its error against
    scipy's integration of the law halves with the step (measured ratio 1.97 from 0.25 ms to
    0.125 ms), and Richardson's 2 x(dt/2) - x(dt) removes the first-order term, leaving a
    tenth of the error or less (measured 8e-4 against 3e-2): the limit it converges to is
    the reference's."""
    t, q, qd = spinning_ball_reference
    k = int(np.argmin(np.abs(t - 0.1)))
    ref = np.concatenate([q[k], qd[k]])
    scene = spinning_ball().replace_run(integrator="implicit_euler")
    coarse, fine = (
        od.simulate(scene.replace_run(dt=dt, output_dt=1e-3)) for dt in (2.5e-4, 1.25e-4)
    )
    states = []
    for run in (coarse, fine):
        assert np.allclose(run.t, t)
        states.append(np.concatenate([run.q[k], run.qd[k]]))
    e_coarse, e_fine = (np.abs(x - ref).max() for x in states)
    assert e_coarse / e_fine == pytest.approx(2.0, rel=0.1)
    assert np.abs(2 * states[1] - states[0] - ref).max() < 0.1 * e_fine


# ------------------------------------------------------------------------- scenes and records


def test_rk4_step_too_large_for_the_contact_is_refused_naming_it():
    scene = od.load_scene("quadruped_drop").replace_run(integrator="rk4", duration=0.5)
    with pytest.raises(SceneError, match=r"run\.dt.*contact .* on contact point 'H?F?[LR]?_?FOOT"):
        od.simulate(scene)


def test_contact_points_from_the_urdf_are_its_collision_spheres():
    scene = od.load_scene("ball_drop")
    (point,) = scene.contact.points
    assert point.frame == "ball" and point.radius == 0.1 and point.name == "ball"
    box = od.load_scene("box_slide")
    assert len(box.contact.points) == 8
    assert [p.name for p in box.contact.points][:2] == ["box[0]", "box[1]"]


@pytest.mark.parametrize(
    "contact, message",
    [
        ({"friction": 0.5, "points": "urdf"}, r"effects\.contact\.stiffness: missing"),
        ({"stiffness": -1.0, "friction": 0.5, "points": "urdf"}, r"stiffness: expected .*> 0"),
        ({"stiffness": 1e5, "friction": -0.1, "points": "urdf"}, r"friction: expected .*>= 0"),
        ({"stiffness": 1e5, "friction": 0.5, "points": "urdf", "slip": 1.0}, r"unknown key"),
        (
            {"stiffness": 1e5, "friction": 0.5, "points": [{"frame": "nope"}]},
            r"points\[0\]\.frame: 'nope' is not a frame",
        ),
        (
            {"stiffness": 1e5, "friction": 0.5, "points": [{"frame": "box", "radius": -1}]},
            r"points\[0\]\.radius: expected a number >= 0",
        ),
        ({"stiffness": 1e5, "friction": 0.5, "points": 3}, r'expected "urdf" or tables'),
    ],
)
def test_bad_contact_settings_are_errors_naming_the_key(contact, message):
    data = thaw(od.load_scene("box_slide").settings)
    data["effects"]["contact"] = contact
    with pytest.raises(SceneError, match=message):
        od.scene_from_dict(data, base_dir=ROBOTS)


def test_urdf_points_need_collision_spheres_and_frames_that_move():
    data = thaw(od.load_scene("quadruped_drop").settings)
    data["effects"]["contact"]["points"] = "urdf"
    with pytest.raises(SceneError, match=r"solo12\.urdf has no <collision> sphere or box"):
        od.scene_from_dict(data, base_dir=ROBOTS)
    fixed = {
        "robot": {"urdf": str(ROBOTS / "double_pendulum.urdf")},
        "effects": {
            "contact": {"stiffness": 1e5, "friction": 0.5, "points": [{"frame": "base"}]}
        },
    }
    with pytest.raises(SceneError, match=r"'base' is welded to the fixed world"):
        od.scene_from_dict(fixed)


def test_contact_record_survives_save_load_and_csv(tmp_path):
    traj = od.simulate(od.load_scene("ball_drop").replace_run(duration=0.35, output_dt=0.01))
    assert traj.has_contact and traj.contact_names == ("ball",)
    back = od.Trajectory.load(traj.save(tmp_path / "ball.npz"))
    assert back.ground_height == 0.0 and back.contact_names == ("ball",)
    np.testing.assert_array_equal(back.contact_force, traj.contact_force)
    np.testing.assert_array_equal(back.penetration, traj.penetration)
    header = (tmp_path / "ball.csv").write_text("") or traj.to_csv(tmp_path / "ball.csv")
    columns = header.read_text().splitlines()[0].split(",")
    assert columns[-4:] == ["fx_ball", "fy_ball", "fz_ball", "penetration_ball"]
    # a scene without contact records none
    plain = od.simulate(od.load_scene("double_pendulum_swing").replace_run(duration=0.05))
    assert not plain.has_contact and plain.contact_force.shape == (len(plain.t), 0, 3)


def test_contact_works_on_a_fixed_base_arm():
    """A fixed-base double pendulum (hanging from 2 m, its tip 0.5 m up when it hangs) swinging
    into a floor at 0.8 m: its tip comes to rest on it, and there the floor's force on the tip
    balances the torques of gravity, g(q) = J_p^T f."""
    scene = od.scene_from_dict(
        {
            "robot": {"urdf": str(ROBOTS / "double_pendulum.urdf")},
            "initial": {"q": [1.0, 0.0]},
            "run": {"duration": 3.0, "integrator": "implicit_euler", "dt": 1e-3},
            "effects": {
                "gravity": True,
                "damping": {"coefficients": 0.5},
                "contact": {
                    "ground_height": 0.8,
                    "stiffness": 1e5,
                    "damping": 100.0,
                    "friction": 0.5,
                    "points": [{"frame": "tip"}],
                },
            },
        }
    )
    traj = od.simulate(scene)
    assert traj.penetration[-1, 0] > 0
    q = traj.q[-1]
    g = od.gravity_forces(scene.model, q)
    J = od.jacobian(scene.model, q, "tip", expressed_in="space")
    x = traj.contact_point[-1, 0]
    J_p = J[3:] - np.cross(x, J[:3].T).T
    # at rest, but for the tip's creep under regularised friction (|qd| < 1e-3 rad/s, steady):
    # g(q) = J_p^T f - b qd, the joints' damping b included
    assert np.abs(traj.qd[-1]).max() < 1e-3
    balance = J_p.T @ traj.contact_force[-1, 0] - 0.5 * traj.qd[-1]
    np.testing.assert_allclose(balance, g, rtol=0, atol=1e-6 * np.abs(g).max())  # M qdd + c: 2e-7
