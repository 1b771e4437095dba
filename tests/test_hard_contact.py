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


def test_a_box_on_a_table_rests_on_it_carrying_its_weight():
    """box_on_table with model = "hard" (its box starts 2.5e-5 m into the table, the compliant
    law's resting depth): the stabilization lifts it out, and at rest its four corners are
    less than 1e-6 m deep, their normal forces adding up to m g (to the solve's tolerance
    over dt: 5e-6 N of 9.81 N)."""
    settings = _thaw(od.load_scene("box_on_table"))
    contact = settings["effects"]["contact"]
    for key in ("stiffness", "damping"):
        contact.pop(key)
    contact["model"] = "hard"
    settings["run"] = {"integrator": "semi_implicit_euler", "dt": 0.002, "duration": 1.0}
    traj = od.simulate(od.scene_from_dict(settings, base_dir=_robots()))
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


def test_one_step_agrees_with_pinocchios_solvers_on_solo12():
    """Solo12 on its four feet at random states (touching, sliding, sticking): the same
    problem built with Pinocchio's kinematics (each foot's contact rows J_b(x) in its frame),
    Delassus matrix and free velocity, solved by Pinocchio's ADMMConstraintSolver and
    PGSConstraintSolver, gives opendyn's velocity after the step to 1e-7 m/s; opendyn's
    impulses, put into Pinocchio's G and g, satisfy the cone, the dual cone and
    complementarity (residuals computed here)."""
    scene = solo12_feet()
    model = scene.model
    oracle = PinOracle(model.source, model)
    rng = np.random.default_rng(3)
    dt = scene.run.dt
    checked = 0
    for trial in range(8):
        q = scene.q0.copy()
        q[7:] += rng.uniform(-0.2, 0.2, model.nv - 6)
        feet = np.array([od.frame_pose(model, q, f)[2, 3] for f in ("FL_FOOT", "FR_FOOT",
                                                                       "HL_FOOT", "HR_FOOT")])
        q[2] += 0.016 - feet.min() + rng.uniform(-2e-3, 2e-3)
        qd = rng.normal(scale=0.3, size=model.nv)
        problem = od.contact_problem(scene, q, qd)
        if not len(problem.lam):
            continue
        checked += 1
        q_pin = oracle.q(q)
        pin_model, pin_data = oracle.model, oracle.data
        # the rows, from Pinocchio's kinematics, in opendyn's column order
        rows = []
        for k in range(problem.contacts.count):
            body = problem.contacts.bodies[k, 1]
            joint = pin_model.getJointId(model.body_joints[body])
            J_k = relative_point_contact_jacobian(
                pin_model, pin_data, q_pin, 0, joint, problem.contacts.point[k],
                problem.contacts.frame[k].T,
            )
            rows.append(J_k[:, oracle.perm_v])
        J = np.vstack(rows)
        np.testing.assert_allclose(J, problem.J, atol=1e-10)
        M = oracle.back_matrix(pin.crba(pin_model, pin_data, q_pin))
        M = np.triu(M) + np.triu(M, 1).T
        tau0 = np.zeros(pin_model.nv)
        a = oracle.back(pin.aba(pin_model, pin_data, q_pin, oracle.v(qd), tau0))
        v_free = qd + dt * a
        np.testing.assert_allclose(v_free, problem.v_free, atol=1e-9)
        G_pin = J @ np.linalg.solve(M, J.T)
        g_pin = J @ v_free
        for k in range(problem.contacts.count):
            d = problem.contacts.depth[k]
            g_pin[3 * k + 2] += (max(d, 0.0) + 0.2 * min(d, 0.0)) / dt
        blocks = [("cone", 3 * k, 0.7) for k in range(problem.contacts.count)]
        found = ncp_residuals(G_pin, g_pin, blocks, problem.lam)
        assert max(found["primal"], found["dual"], found["complementarity"]) <= 1e-8, found
        agreed = 0
        for solver in ("admm", "pgs"):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                lam, info = solve_with_pinocchio(
                    G_pin, g_pin, blocks, solver, 1e-13, 100000, return_info=True
                )
            if not info["converged"]:  # Pinocchio's PGS stalls on some of these states
                continue
            v_next = v_free + np.linalg.solve(M, J.T @ lam)
            np.testing.assert_allclose(problem.v_next, v_next, atol=1e-7)
            agreed += 1
        assert agreed >= 1
    assert checked >= 4


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
