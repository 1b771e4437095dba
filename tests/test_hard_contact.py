"""The hard model: contacts, joint limits and joint dry friction as constraints of the
velocity-level step (model = "hard", integrator = "semi_implicit_euler"), against Pinocchio 4's
own ADMM and PGS solvers on the same problems, closed forms and physical identities."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pinocchio as pin
import pytest
from pin_adapter import PinOracle
from pin_contact import ncp_residuals, relative_point_contact_jacobian, solve_with_pinocchio

import opendyn as od
from opendyn.algorithm import ncp
from opendyn.cli.simulate import summary
from opendyn.sim import hard_settings
from opendyn.sim.scene import thaw

G = 9.81
KINDS = {ncp.CONE: "cone", ncp.UNILATERAL: "unilateral", ncp.BOX: "box"}


def solve_ours(G_, g, blocks, solver, tolerance=1e-10, max_iterations=5000):
    """(lam, iterations, residual) of opendyn's solver on the problem (blocks: (kind, first,
    param) as pin_contact's)."""
    m = len(g)
    rows = np.array(
        [[kind, first, 3 if kind == ncp.CONE else 1] for kind, first, _ in blocks], np.int64
    )
    param = np.array([p for *_, p in blocks], float)
    lam = np.zeros(m)
    work = (np.zeros((m, m)), np.zeros((m, m)), np.zeros((10, m)))
    status, iterations, residual = ncp.solve_ncp(
        ncp.SOLVERS[solver], (G_, g, rows, param, m), (tolerance, max_iterations), lam, work
    )
    assert status == 0
    return lam, iterations, residual


def as_pin_blocks(blocks):
    return [(KINDS[kind], first, param) for kind, first, param in blocks]


def random_problem(rng, contacts, joints):
    """A contact problem of a random tree: G = J M^-1 J^T of a random SPD M (nv = 12) and
    random rows, `contacts` cones, then `joints` limit and friction rows."""
    nv = 12
    A = rng.normal(size=(nv, nv))
    M = A @ A.T + nv * np.eye(nv)
    m = 3 * contacts + 2 * joints
    J = rng.normal(size=(m, nv))
    G_ = J @ np.linalg.solve(M, J.T)
    g = rng.normal(size=m)
    blocks = [(ncp.CONE, 3 * k, rng.uniform(0.2, 1.0)) for k in range(contacts)]
    for k in range(joints):
        blocks.append((ncp.UNILATERAL, 3 * contacts + 2 * k, 0.0))
        blocks.append((ncp.BOX, 3 * contacts + 2 * k + 1, rng.uniform(0.05, 0.5)))
    return G_, g, blocks


@pytest.mark.parametrize("solver", ["admm", "pgs"])
def test_the_solvers_give_the_velocities_pinocchios_solvers_give(solver):
    """At random problems (cones, limits, friction boxes; G from a random tree) opendyn's
    impulses satisfy Coulomb's law with maximum dissipation (residuals computed by the test,
    not by either solver) and give the rows' velocities c = G lambda + g of Pinocchio's
    ADMMConstraintSolver and PGSConstraintSolver on the same problem (lambda itself is not
    unique where G is singular)."""
    rng = np.random.default_rng(7)
    for trial in range(12):
        G_, g, blocks = random_problem(rng, contacts=1 + trial % 4, joints=trial % 3)
        lam, iterations, residual = solve_ours(G_, g, blocks, solver)
        assert residual <= 1e-10, (trial, iterations, residual)
        found = ncp_residuals(G_, g, as_pin_blocks(blocks), lam)
        assert max(found["primal"], found["dual"], found["complementarity"]) <= 1e-9, found
        theirs = solve_with_pinocchio(G_, g, as_pin_blocks(blocks), "admm", tolerance=1e-13)
        np.testing.assert_allclose(G_ @ lam + g, G_ @ theirs + g, atol=1e-7)


def test_a_sliding_contact_does_not_lift_off():
    """One contact pushed sideways (G = I, g = (0.5, 0, -1), mu = 0.3): it slides with
    lambda = (-0.3, 0, 1) and c_n = 0, the NCP's answer, where the convex relaxation would lift
    it off (c_n = mu |c_t|); both solvers."""
    for solver in ("admm", "pgs"):
        lam, _, _ = solve_ours(np.eye(3), np.array([0.5, 0.0, -1.0]), [(ncp.CONE, 0, 0.3)], solver)
        np.testing.assert_allclose(lam, [-0.3, 0.0, 1.0], atol=1e-9)
        assert abs(lam[2] - 1.0) <= 1e-9  # c_n = lam_n + g_n = 0


def painleve_problem(mu, angle):
    """The impulse problem of a rod (1 m, 1 kg) sliding at `angle` from the ground on its
    lower end, towards which it leans: the Painleve configuration, whose acceleration-level
    problem has no solution for mu > 4 / 3 here."""
    length, mass = 1.0, 1.0
    R = np.array(
        [[math.cos(angle), 0.0, -math.sin(angle)], [0.0, 1.0, 0.0],
         [math.sin(angle), 0.0, math.cos(angle)]]
    )
    inertia = R @ np.diag([1e-4, mass * length**2 / 12, mass * length**2 / 12]) @ R.T
    M = np.block([[inertia, np.zeros((3, 3))], [np.zeros((3, 3)), mass * np.eye(3)]])
    r = -R @ np.array([length / 2, 0.0, 0.0])  # the lower end from the centre of mass
    skew = np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]])
    J = np.hstack([-skew, np.eye(3)])  # v_point = v + w x r
    return J @ np.linalg.solve(M, J.T), np.array([-2.0, 0.0, -G * 0.002])


def test_a_painleve_rod_never_gives_nan():
    """The Painleve rod at friction coefficients up to 5 and steep angles: every solve returns
    finite impulses, and says how far it got (a residual, never NaN)."""
    for mu in (0.5, 1.5, 5.0):
        for angle in (0.3, 0.6, 1.0, 1.3):
            G_, g = painleve_problem(mu, angle)
            for solver in ("admm", "pgs"):
                lam, _, residual = solve_ours(G_, g, [(ncp.CONE, 0, mu)], solver, 1e-8, 100)
                assert np.all(np.isfinite(lam)) and np.isfinite(residual)


def hard_ball(**contact):
    data = {
        "robot": {"urdf": "ball.urdf", "floating_base": True},
        "initial": {"base_position": [0.0, 0.0, 0.6]},
        "run": {"duration": 1.0, "integrator": "semi_implicit_euler", "dt": 0.002},
        "effects": {
            "gravity": True,
            "contact": {"model": "hard", "friction": 0.5, "points": "urdf", **contact},
        },
    }
    return od.scene_from_dict(data, base_dir=_robots())


def _robots():
    return od.io.urdf.shipped_robots_dir()


def _thaw(scene):
    return thaw(scene.settings)


def test_a_dropped_ball_comes_to_rest_on_the_ground_carrying_its_weight():
    """The ball dropped from 0.5 m stops at the ground (no bounce: the step is inelastic),
    rests less than 1e-6 m deep with a normal force m g, and no step gains energy: the passive
    work (the impulses') never grows and the balance closes within the step's own error."""
    traj = od.simulate(hard_ball())
    rest = traj.t >= 0.5
    assert np.abs(traj.penetration[rest, 0]).max() <= 1e-6
    force = traj.contact_force[rest][:-1, 0]  # the last sample takes no step
    np.testing.assert_allclose(force[:, 2], G * 1.0, rtol=1e-6)
    np.testing.assert_allclose(force[:, :2], 0.0, atol=1e-9)
    assert np.all(np.diff(traj.work_passive) <= 1e-12)
    assert traj.stats["unconverged_steps"] == 0


def box_on_table_hard(**contact):
    """The shipped box_on_table with model = "hard" (and `contact`'s keys) at 2 ms."""
    settings = _thaw(od.load_scene("box_on_table"))
    table = settings["effects"]["contact"]
    for key in ("stiffness", "damping"):
        table.pop(key)
    table.update(model="hard", **contact)
    settings["run"] = {"integrator": "semi_implicit_euler", "dt": 0.002, "duration": 1.0}
    return od.scene_from_dict(settings, base_dir=_robots())


def test_a_box_on_a_table_rests_on_it_carrying_its_weight():
    """box_on_table with model = "hard" (its box starts 2.5e-5 m into the table, the compliant
    law's resting depth): the stabilization lifts it out, and at rest its four corners are
    less than 1e-6 m deep, their normal forces adding up to m g (to the solve's tolerance
    over dt: 5e-6 N of 9.81 N)."""
    traj = od.simulate(box_on_table_hard())
    for k in np.flatnonzero(traj.t >= 0.5)[:-1]:
        rows = traj.contacts.at(k)
        assert len(rows) == 4 and np.abs(rows.depth).max() <= 1e-6
        np.testing.assert_allclose(abs(rows.force[:, 2].sum()), G * 1.0, atol=5e-6)


def test_the_hard_model_needs_the_velocity_level_step():
    """A hard model with another integrator is refused, naming both keys; the compliant law's
    keys are refused with model = "hard", the hard model's without it."""
    with pytest.raises(od.SceneError, match=r"effects\.contact\.model.*run\.integrator"):
        od.load_scene("box_incline_hard").replace_run(integrator="rk4")
    with pytest.raises(od.SceneError, match=r"effects\.contact\.stiffness: is the compliant"):
        hard_ball(stiffness=1e5)
    data = {
        "robot": {"urdf": "ball.urdf", "floating_base": True},
        "effects": {"contact": {"stiffness": 1e5, "friction": 0.5, "points": "urdf",
                                "solver": "pgs"}},
    }
    with pytest.raises(od.SceneError, match=r"effects\.contact\.solver: is a setting of the hard"):
        od.scene_from_dict(data, base_dir=_robots())
    with pytest.raises(ValueError, match="hard"):
        od.linearize(hard_ball())


def test_a_box_on_a_steep_ramp_holds_exactly_or_slides_at_coulombs_rate():
    """box_incline_hard: 25 degrees, mu = 0.6 > tan 25 holds the box (it moves less than
    1e-7 m in the 1.5 s after settling); with mu = 0.25 it slides down at
    a = g (sin 25 - mu cos 25), its speed a t to 1e-6 relative."""
    traj = od.simulate("box_incline_hard")
    settled = traj.t >= 0.5
    p = traj.q[settled, :3]
    assert np.abs(p - p[0]).max() <= 1e-7
    scene = od.load_scene("box_incline_hard")
    settings = _thaw(scene)
    settings["effects"]["contact"]["friction"] = 0.25
    sliding = od.simulate(od.scene_from_dict(settings, base_dir=_robots()))
    angle = math.radians(25.0)
    a = G * (math.sin(angle) - 0.25 * math.cos(angle))
    speed = np.linalg.norm(sliding.qd[:, 3:6], axis=1)
    later = (sliding.t >= 0.2) & (sliding.t <= 0.9)  # on the ramp: it leaves its end at 1 s
    np.testing.assert_allclose(speed[later], a * sliding.t[later], rtol=1e-6)


def test_ten_stacked_boxes_carry_the_weight_above_them():
    """box_stack_hard (1 kg to 10 g, 2 ms): at rest each interface's normal forces add up to
    the weight of the boxes above it, to 1e-6 relative; the stack drifts less than 1e-6 m in
    5 s; ADMM converges at every step. PGS on the same stack, for comparison, takes more
    iterations over the run."""
    scene = od.load_scene("box_stack_hard")
    traj = od.simulate(scene)
    assert traj.stats["unconverged_steps"] == 0
    masses = np.array([float(scene.settings["objects"][k]["mass"]) for k in range(10)])
    rows = traj.contacts.at(len(traj.t) - 2)  # the last sample takes no step
    for level in range(10):
        at = np.abs(rows.point[:, 2] - 0.1 * level) < 0.01
        # each pair's force is the one a gives b: the ground is b of its pair with box0
        np.testing.assert_allclose(abs(rows.force[at, 2].sum()), masses[level:].sum() * G,
                                   rtol=1e-6)
    assert np.abs(traj.q[-1] - traj.q[0]).max() <= 1e-6
    pgs = _thaw(scene)
    pgs["effects"]["contact"]["solver"] = "pgs"
    pgs_traj = od.simulate(od.scene_from_dict(pgs, base_dir=_robots()))
    assert np.all(np.isfinite(pgs_traj.solver_residual))
    assert pgs_traj.solver_iterations.sum() > traj.solver_iterations.sum()


def test_solo12_stands_without_its_feet_sliding():
    """solo12_stand_hard: over 10 s at 2 ms the feet do not slide (each foot's sphere centre
    moves under 1e-6 m horizontally after the first 0.5 s), and once the PD's sway has settled
    the ground carries the robot's weight."""
    scene = od.load_scene("solo12_stand_hard")
    traj = od.simulate(scene)
    model = scene.model
    feet = ("FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT")
    later = np.flatnonzero(traj.t >= 0.5)
    for foot in feet:
        xy = np.array([od.frame_pose(model, traj.q[k], foot)[:2, 3] for k in later])
        assert np.abs(xy - xy[0]).max() <= 1e-6, foot
    weight = float(np.sum(model.mass)) * G
    still = np.flatnonzero(traj.t >= 2.0)[:-1]  # the PD's sway settled; the last takes no step
    np.testing.assert_allclose(traj.contact_force[still, :, 2].sum(axis=1), weight, rtol=1e-6)


def test_hard_limits_hold_and_push_back_the_torque():
    """planar_3r_limits_hard: no joint passes its limit by more than 1e-8 rad; at rest against
    its limits (joint1 at +3 rad driven by 20 N m, joint3 at -2.5 rad by -2 N m) each limit's
    impulse is the torque pushing its joint, times dt."""
    scene = od.load_scene("planar_3r_limits_hard")
    traj = od.simulate(scene)
    model = scene.model
    over = np.maximum(traj.q - model.upper, model.lower - traj.q)
    assert over.max() <= 1e-8
    problem = od.contact_problem(scene, traj.q[-1], np.zeros(3))
    dt = scene.run.dt
    assert problem.lam.shape == (2,)
    # the rows' velocities are solved to the tolerance (1e-8 rad/s): the impulses to that
    # times the largest eigenvalue of G^-1
    bound = 1e-8 * np.linalg.norm(np.linalg.inv(problem.G), 2)
    np.testing.assert_allclose(np.sort(problem.lam), np.sort([2.0 * dt, 20.0 * dt]), atol=bound)
    # the command line's summary says how the solves went
    lines = summary(scene, traj).splitlines()
    assert any(line.startswith("solver      ADMM: every step converged") for line in lines)


def test_hard_joint_friction_holds_a_pendulum_exactly():
    """The double pendulum at rest, 0.3 rad out, with hard dry friction of 100 N m on both
    joints: static friction holds it exactly, to the solve's tolerance (a smoothed law lets it
    creep at v_s times the share of f_c it needs); with 0.01 N m it falls."""
    def pendulum(f_c):
        return od.scene_from_dict(
            {
                "robot": {"urdf": "double_pendulum.urdf"},
                "initial": {"q": [0.3, 0.0]},
                "run": {"duration": 0.5, "integrator": "semi_implicit_euler", "dt": 0.002},
                "effects": {
                    "gravity": True,
                    "friction": {"model": "hard", "coefficients": f_c},
                },
            },
            base_dir=_robots(),
        )

    held = od.simulate(pendulum(100.0))
    # held to the solver's tolerance (1e-8 rad/s, the default) over the run's 0.5 s
    assert np.abs(held.q - held.q[0]).max() <= 1e-8 * 0.5
    falling = od.simulate(pendulum(0.01))
    assert abs(falling.q[-1, 0] - 0.3) > 0.1


def solo12_feet():
    return od.scene_from_dict(
        {
            "robot": {"name": "solo12", "floating_base": True},
            "run": {"integrator": "semi_implicit_euler", "dt": 0.002},
            "effects": {
                "gravity": True,
                "contact": {
                    "model": "hard",
                    "friction": 0.7,
                    "tolerance": 1e-11,
                    "max_iterations": 5000,
                    "margin": 0.01,
                    "points": [
                        {"frame": foot, "radius": 0.016}
                        for foot in ("FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT")
                    ],
                },
            },
        }
    )


def agrees_with_pinocchio(scene, oracle, q, qd):
    """One step of the scene's hard contact from (q, qd), od.contact_problem's, against the same
    problem built with Pinocchio: each contact's rows J_b(x) - J_a(x) from Pinocchio's
    kinematics (in opendyn's column order) equal opendyn's to 1e-10; v_free = qd + dt M^-1 (-h)
    from pin.aba (gravity, no torque) equals opendyn's; with G = J M^-1 J^T (M from pin.crba),
    g = J v_free plus each normal row's drift (max(d, 0) + stabilization min(d, 0)) / dt and a
    cone of the contact's mu per contact, opendyn's impulses satisfy the cone, the dual cone
    and complementarity (residuals computed here), and its velocity after the step is
    v_free + M^-1 J^T lambda.

    Where the contacts' normal rows are independent, the velocity after the step is also that
    of every one of Pinocchio's ADMMConstraintSolver and PGSConstraintSolver that converges, to
    1e-7 m/s, at least one of them converging. Where they are not (a body touching another at
    three or more coplanar points: a face), the normal impulses are statically indeterminate
    and so is the NCP's answer: opendyn's and Pinocchio's answers, all solving the problem to
    1e-11, differ by up to 1e-3 m/s at a sliding box's corners, so none is compared.

    Returns (the problem, the Pinocchio solvers that converged): () when there is no contact,
    None when the normal rows are dependent."""
    model = scene.model
    problem = od.contact_problem(scene, q, qd)
    contacts = problem.contacts
    if not contacts.count:
        return problem, ()
    assert problem.J.shape[0] == 3 * contacts.count  # contacts alone: no other rows
    settings = hard_settings.sections(scene)["effects.contact"]
    dt = scene.run.dt
    q_pin = oracle.q(q)
    pin_model, pin_data = oracle.model, oracle.data

    def joint(body):  # body -1 is the world, Pinocchio's joint 0
        return 0 if body < 0 else pin_model.getJointId(model.body_joints[body])

    # the rows, from Pinocchio's kinematics, in opendyn's column order
    J = np.vstack([
        relative_point_contact_jacobian(
            pin_model, pin_data, q_pin, joint(a), joint(b), x, frame.T
        )[:, oracle.perm_v]
        for (a, b), x, frame in zip(contacts.bodies, contacts.point, contacts.frame)
    ])
    np.testing.assert_allclose(J, problem.J, atol=1e-10)
    M = oracle.back_matrix(pin.crba(pin_model, pin_data, q_pin))
    M = np.triu(M) + np.triu(M, 1).T
    tau0 = np.zeros(pin_model.nv)
    v_free = qd + dt * oracle.back(pin.aba(pin_model, pin_data, q_pin, oracle.v(qd), tau0))
    np.testing.assert_allclose(v_free, problem.v_free, atol=1e-9)
    G_pin = J @ np.linalg.solve(M, J.T)
    g_pin = J @ v_free
    for k, d in enumerate(contacts.depth):
        g_pin[3 * k + 2] += (max(d, 0.0) + settings.stabilization * min(d, 0.0)) / dt
    blocks = [("cone", 3 * k, mu) for k, mu in enumerate(contacts.mu)]
    compliance = settings.compliance
    found = ncp_residuals(G_pin, g_pin, blocks, problem.lam, compliance)
    assert max(found["primal"], found["dual"], found["complementarity"]) <= 1e-8, found
    pushed = v_free + np.linalg.solve(M, J.T @ problem.lam)
    np.testing.assert_allclose(problem.v_next, pushed, atol=1e-9)
    if np.linalg.matrix_rank(J[2::3], tol=1e-9 * np.linalg.norm(J[2::3], 2)) < contacts.count:
        return problem, None
    converged = []
    for solver in ("admm", "pgs"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            lam, info = solve_with_pinocchio(
                G_pin, g_pin, blocks, solver, 1e-13, 100000, compliance, return_info=True
            )
        if not info["converged"]:  # Pinocchio's PGS stalls on some of these states
            continue
        v_next = v_free + np.linalg.solve(M, J.T @ lam)
        np.testing.assert_allclose(problem.v_next, v_next, atol=1e-7, err_msg=solver)
        converged.append(solver)
    assert converged
    return problem, converged


def test_one_step_agrees_with_pinocchios_solvers_on_solo12():
    """Solo12 on its four feet at random states (touching, sliding, sticking): the same
    problem built with Pinocchio's kinematics (each foot's contact rows J_b(x) in its frame),
    Delassus matrix and free velocity, solved by Pinocchio's ADMMConstraintSolver and
    PGSConstraintSolver, gives opendyn's velocity after the step to 1e-7 m/s; opendyn's
    impulses, put into Pinocchio's G and g, satisfy the cone, the dual cone and
    complementarity (residuals computed here; agrees_with_pinocchio)."""
    scene = solo12_feet()
    model = scene.model
    oracle = PinOracle(model.source, model)
    rng = np.random.default_rng(3)
    checked = 0
    for _ in range(8):
        q = scene.q0.copy()
        q[7:] += rng.uniform(-0.2, 0.2, model.nv - 6)
        feet = np.array([od.frame_pose(model, q, f)[2, 3] for f in ("FL_FOOT", "FR_FOOT",
                                                                       "HL_FOOT", "HR_FOOT")])
        q[2] += 0.016 - feet.min() + rng.uniform(-2e-3, 2e-3)
        qd = rng.normal(scale=0.3, size=model.nv)
        _, converged = agrees_with_pinocchio(scene, oracle, q, qd)
        checked += bool(converged)
    assert checked >= 4


BOX_HALF = np.array([0.1, 0.1, 0.05])  # the half sizes of the shipped scenes' boxes
BOX_CORNERS = BOX_HALF * np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])


def on_face(rng, face, shape, gap, offset, yaw):
    """(p, R) of a box resting on `face` = (R_s, x0): the plane through x0 with the normal
    R_s[:, 2], R_s's other columns its in-plane axes. The box's yaw about the normal is
    uniform in +-yaw, its centre up to `offset` from x0 in the plane, its lowest corner `gap`
    above the plane (< 0: into it), and `shape` its tilt: "face" (1e-4 rad: the whole bottom
    face within the margin), "edge" (10-40 mrad about the box's x or y axis: one edge, two
    corners) or "corner" (10-40 mrad about another axis: one corner)."""
    R_s, x0 = face
    angle = rng.uniform(0.01, 0.04) * rng.choice((-1.0, 1.0))
    if shape == "face":
        axis = np.r_[rng.normal(scale=1e-4, size=2), 0.0]
    elif shape == "edge":
        axis = angle * np.eye(3)[rng.integers(2)]
    else:
        phi = rng.choice((0.25, 0.75)) * math.pi + rng.uniform(-0.4, 0.4)
        axis = angle * np.array([math.cos(phi), math.sin(phi), 0.0])
    R = R_s @ pin.exp3(np.array([0.0, 0.0, rng.uniform(-yaw, yaw)])) @ pin.exp3(axis)
    n = R_s[:, 2]
    lowest = (BOX_CORNERS @ R.T @ n).min()
    p = x0 + R_s[:, :2] @ rng.uniform(-offset, offset, 2) + (gap - lowest) * n
    return p, R


def box_velocity(rng, face, motion, gap, dt):
    """A box's world twist (omega, v) relative to `face`'s: "stick" (1e-3 m/s along the face,
    1e-2 rad/s) or "slide" (0.1-0.5 m/s in a random direction along it, 0.2 rad/s); closing
    at up to 1e-2 m/s when `gap` <= 0, else at 0.8-1.5 times gap / dt (most of the gaps close
    within the step)."""
    R_s = face[0]
    if motion == "stick":
        along, spin = rng.normal(scale=1e-3, size=2), 1e-2
    else:
        direction = rng.uniform(0.0, 2.0 * math.pi)
        along = rng.uniform(0.1, 0.5) * np.array([math.cos(direction), math.sin(direction)])
        spin = 0.2
    closing = rng.uniform(0.0, 1e-2) if gap <= 0.0 else rng.uniform(0.8, 1.5) * gap / dt
    return rng.normal(scale=spin, size=3), R_s @ np.r_[along, -closing]


def pose_q(p, R):
    return np.r_[p, pin.Quaternion(R).coeffs()]  # (x, y, z, w) in both


def box_states(scene, rng, count):
    """`count` random states (q, qd) of a scene of boxes in contact: each box's lowest corner
    within the margin of its support or up to a margin into it, its tilt a face, an edge or a
    corner, sticking or sliding (on_face, box_velocity). A scene with a world box (box_on_table,
    box_incline_hard) has its one box on that box's top face; one without (box_stack_hard) its
    boxes stacked on the ground, each on the one below with a twist relative to it, and in
    every other state none of them on a face."""
    margin = hard_settings.sections(scene)["effects.contact"].margin
    dt = scene.run.dt
    shapes, motions = ("face", "edge", "corner"), ("stick", "slide")
    world = scene.settings.get("world")
    for k in range(count):
        q, qd = [], []
        if world:
            size, position = world[0]["size"], world[0]["position"]
            R_s = pin.rpy.rpyToMatrix(*world[0].get("rpy", (0.0, 0.0, 0.0)))
            face = (R_s, np.asarray(position, float) + R_s[:, 2] * size[2] / 2.0)
            gap = rng.uniform(0.0, margin) if k % 2 else rng.uniform(-margin, 0.0)
            p, R = on_face(rng, face, shapes[k % 3], gap, offset=0.2, yaw=math.pi)
            omega, v = box_velocity(rng, face, motions[k // 3 % 2], gap, dt)
            q.append(pose_q(p, R))
            qd.append(np.r_[R.T @ omega, R.T @ v])
        else:
            face, twist = (np.eye(3), np.zeros(3)), np.zeros(6)  # the ground, at rest
            for _ in scene.model.objects:
                gap = rng.uniform(-margin, margin)
                shape = rng.choice(shapes if k % 2 else shapes[1:])
                p, R = on_face(rng, face, shape, gap, offset=0.01, yaw=0.05)
                omega, v = box_velocity(rng, face, rng.choice(motions), gap, dt)
                # twists (omega, the velocity at the world's origin), the one below added
                twist = twist + np.r_[omega, v - np.cross(omega, p)]
                q.append(pose_q(p, R))
                qd.append(np.r_[R.T @ twist[:3], R.T @ (twist[3:] + np.cross(twist[:3], p))])
                face = (R, p + R[:, 2] * BOX_HALF[2])
        yield np.concatenate(q), np.concatenate(qd)


@pytest.mark.parametrize("name", ["box_on_table", "box_incline_hard", "box_stack_hard"])
def test_one_step_agrees_with_pinocchios_solvers_on_collision_geometry(name):
    """Boxes of collision geometry (box_on_table made hard, box_incline_hard, box_stack_hard,
    whose contacts between two boxes move both: rows J_b(x) - J_a(x)) at random states in
    contact: sticking and sliding, within the margin and slightly into their support, flat on
    a face or tilted onto an edge or a corner (box_states). Each step's problem built with
    Pinocchio's kinematics, Delassus matrix and free velocity (the objects on free-flyer joints
    of a model built joint by joint) agrees with opendyn's as agrees_with_pinocchio checks: the
    rows, the free velocity and opendyn's impulses solving Pinocchio's problem at every state;
    the velocity after the step that of each of Pinocchio's ADMM and PGS solvers that
    converges where no box lies on a face (there the answer is not unique)."""
    tight = {"tolerance": 1e-11, "max_iterations": 100000}
    if name == "box_on_table":
        scene = box_on_table_hard(**tight)
    else:
        settings = _thaw(od.load_scene(name))
        settings["effects"]["contact"].update(tight)
        scene = od.scene_from_dict(settings, base_dir=_robots())
    model = scene.model
    oracle = PinOracle(model.source, model)
    rng = np.random.default_rng(11)
    count = 8 if name == "box_stack_hard" else 12
    compared = active = between_boxes = 0
    for q, qd in box_states(scene, rng, count):
        problem, converged = agrees_with_pinocchio(scene, oracle, q, qd)
        assert problem.contacts.count > 0
        active += bool(np.any(problem.lam))
        if converged is not None:
            compared += 1
            between_boxes += int(np.all(problem.contacts.bodies >= 0, axis=1).sum())
    assert active >= count - 2  # most states press or rub
    assert compared >= count // 2
    if name == "box_stack_hard":  # contacts of two moving boxes among those compared
        assert between_boxes >= 30


def pinned_hard(solver="admm", **run):
    settings = _thaw(od.load_scene("planar_3r_pinned"))
    settings.pop("baumgarte")
    settings["run"] = {"integrator": "semi_implicit_euler", "dt": 1e-3, "duration": 2.0, **run}
    settings["effects"]["friction"] = {"model": "hard", "coefficients": 0.01, "solver": solver}
    return od.scene_from_dict(settings, base_dir=_robots())


@pytest.mark.parametrize("solver", ["admm", "pgs"])
def test_a_pinned_tool_is_an_equality_row_of_the_same_solve(solver):
    """planar_3r_pinned with hard joint friction: its point_to_world constraint joins the
    friction's rows in one solve as equality rows (one of them, the plane's normal, a row of
    zeros), and the tool stays pinned: the velocity rows hold it to first order and the
    stabilization takes out the drift, so the violation stays under a step's second-order
    drift, dt^2 times the largest joint speed squared over the shortest link (0.3 m), a few
    times over; halving the step halves the difference to a run at a tenth of the step (first
    order)."""
    traj = od.simulate(pinned_hard(solver=solver))
    speed = np.abs(traj.qd).max()
    assert traj.violation_position.max() <= 5 * (1e-3 * speed) ** 2 / 0.3
    assert traj.stats["unconverged_steps"] == 0
    fine = od.simulate(pinned_hard(dt=1e-4, duration=0.5))
    errors = []
    for dt in (2e-3, 1e-3):
        coarse = od.simulate(pinned_hard(dt=dt, duration=0.5))
        errors.append(np.abs(coarse.q[-1] - fine.q[-1]).max())
    assert 1.6 <= errors[0] / errors[1] <= 2.5, errors
