"""Hard cases stay numerically stable: long chains, extreme mass ratios, singular Jacobians,
massless joints, high speeds, stiff effects, long horizons, wound-up continuous joints and
random trees at large velocities.

Each case says what "stable" means in numbers: the module constants below, each with the value
measured when the bound was chosen (on an x86-64 machine, numpy + numba float64). Bounds leave a
margin of a few times the measurement, or follow from floating-point error analysis where one
applies: eps = 2.2e-16 is the unit roundoff, cond(.) a 2-norm condition number.

Independent truths: numpy linear algebra on od.mass_matrix / od.bias_forces / od.jacobian
(checked against Pinocchio in test_pinocchio.py), Pinocchio's ABA, closed forms (a free wheel,
a massless joint driven through its armature, static equilibrium against a limit spring,
terminal velocity under viscous damping) and invariants (energy, angular momentum).
"""

from __future__ import annotations

from decimal import Decimal, localcontext

import numpy as np
import pytest
from randtree import random_chain_urdf, write_random_tree

import opendyn as od
from opendyn.cli.main import main
from opendyn.sim.scene import thaw
from opendyn.io.urdf import shipped_robots_dir

EPS = np.finfo(float).eps
METHODS = ("aba", "crba", "newton_euler")

# 1. A 200-link serial chain (randtree: revolute, continuous and prismatic joints, random axes
# and frames). M is symmetric to CHAIN_SYMMETRY_RTOL of max |M| (measured: exactly symmetric)
# and positive definite (Cholesky succeeds, smallest eigenvalue > 0; measured >= 0.032 with
# cond(M) up to 3.7e6). The three forward-dynamics methods agree to CHAIN_FD_RTOL of ||qdd||
# (measured 9.0e-12 at the test's states, 1.9e-11 over 23 others; cond(M) eps = 8e-10). RK4 at
# CHAIN_DT over CHAIN_DURATION, gravity on, no damping: max |E - E(0)| <= CHAIN_ENERGY_RTOL of the
# energy scale max K(t) (the energy exchanged with gravity, 3.5e5 J; measured 1.30e-8; 8.2e-10
# at 1 ms, 5.2e-11 at 0.5 ms: fourth order).
CHAIN_LINKS = 200
CHAIN_SEED = 0
CHAIN_STATES = 5
CHAIN_SYMMETRY_RTOL = 1e-12
CHAIN_FD_RTOL = 1e-10
CHAIN_DT = 2e-3
CHAIN_DURATION = 5.0
CHAIN_ENERGY_RTOL = 4e-8

# 2. Extreme mass and inertia ratios: a 6-joint chain alternating 1e3 kg and 1e-6 kg links, with
# inertias in proportion. cond(M) > RATIO_MIN_CONDITION (measured 9.9e10 to 5e11). The torque
# residual ||M qdd + h - tau|| / ||tau|| <= RATIO_RESIDUAL_RTOL for every method (measured over
# the 40 states: ABA 6.8e-12, CRBA 1.2e-11, Newton-Euler 1.3e-11; Pinocchio's ABA 6.6e-12). CRBA
# does not refuse this M: its Cholesky pivots (>= 9e-9) are far above the singularity threshold
# (1e-14 of max M_kk). Every joint's qdd agrees with Pinocchio's to RATIO_PINOCCHIO_RTOL of
# that joint's own |qdd| (measured 2.4e-12), so the heavy joints' small accelerations are not
# swamped by the light joints' large ones (|qdd| up to 3e8 rad/s^2).
RATIO_HEAVY, RATIO_LIGHT = 1e3, 1e-6
RATIO_MIN_CONDITION = 1e10
RATIO_STATES = 40
RATIO_RESIDUAL_RTOL = 5e-11
RATIO_PINOCCHIO_RTOL = 1e-11

# 3. The UR5 at q = 0 is stretched straight (elbow 0) with wrist axes 4 and 6 aligned (q5 = 0):
# J_b M^-1 J_b^T of tool0 has rank 5. Damped: (J M^-1 J^T + d I)^-1 agrees with numpy's to
# cond(J M^-1 J^T + d I) eps of its largest entry, the first-order perturbation bound of an
# inverse (measured <= 3.4e-4 of it; cond 5.8e7, 5.8e4, 585 at d = 1e-6, 1e-3, 0.1), symmetric
# to the same, positive definite. Approaching q = 0 along a line, q = s d with s from 1e-1 to
# 1e-4 (four per decade; cond grows as s^-4): either SingularTaskSpaceError, only where
# cond(J M^-1 J^T) > TASK_SPACE_REFUSED_CONDITION (measured: refused from 3.6e10 up), or
# ||Lambda (J M^-1 J^T) - I||_2 <= cond eps, the same bound (measured <= 0.011 cond eps at cond
# up to 3.6e9; <= 0.026 over 70 random near-singular UR5 configurations).
TASK_SPACE_FRAME = "tool0"
TASK_SPACE_DAMPINGS = (1e-6, 1e-3, 1e-1)
TASK_SPACE_REFUSED_CONDITION = 1e9

# 4. A moving joint with nothing below it but massless links: forward dynamics raises
# SingularMassMatrixError naming it (all methods). With armature a on it and a constant torque
# tau there, its equation decouples: qdd = tau / a exactly, so RK4 follows q0 + qd0 t +
# tau / (2 a) t^2 up to the rounding of the N additions, N ulp(|q|) / 2 (measured 2.5e-14 rad
# against 2.2e-13); the energy balance E - E(0) = W_applied holds to MASSLESS_BALANCE_RTOL of
# max |E| (measured 3.1e-13).
MASSLESS_ARMATURE = 2e-3
MASSLESS_TAU = 0.01
MASSLESS_BALANCE_RTOL = 1e-12

# 5. High speeds: the shipped double pendulum without gravity, qd0 = (100, -50) rad/s (the
# shoulder turns 86 rad in 1 s). dopri5 at SPIN_RTOL stays within SPIN_Q_ERROR_PER_RTOL * rtol
# rad of dopri5 at 1e-12 (measured 754 rtol; 631 and 873 rtol at rtol 1e-6 and 1e-10: the error
# follows the tolerance). Invariants without gravity: energy to SPIN_ENERGY_RTOL (measured
# 9.6e-9) and the angular momentum about the shoulder axis, p_1 = (M qd)_1, to
# SPIN_MOMENTUM_RTOL (measured 3.4e-8), relative to their initial values; the reference keeps
# both to SPIN_REFERENCE_RTOL (measured 7.9e-12, 5.6e-12). Explicit Euler at EULER_DT diverges:
# the run stops at t = 0.055 s (step 11) when |qd| would pass max_speed = 1e4 rad/s.
SPIN_QD0 = (100.0, -50.0)
SPIN_RTOL = 1e-8
SPIN_Q_ERROR_PER_RTOL = 2e3
SPIN_ENERGY_RTOL = 3e-8
SPIN_MOMENTUM_RTOL = 1e-7
SPIN_REFERENCE_RTOL = 3e-11
EULER_DT = 5e-3

# 6. Stiff joint limits (1e5 N m/rad) and heavy damping at dt = 5 ms. Implicit Euler stays
# bounded: kinetic energy <= LIMITS_ENERGY_GAIN (E(0) + W_applied(t)), what the torques put in
# plus the first-order method's gain at impacts (measured 1.147; exact dynamics: 1), and no
# joint deeper than LIMITS_PENETRATION past a limit (measured 0.047 rad). With HEAVY_DAMPING
# N m s/rad on every joint (a 1.5 ms time constant on link 3) joint 1 comes to rest at
# upper + tau_1 / k and joint 3 turns at its terminal velocity tau_3 / d, both to
# HEAVY_DAMPING_END_TOL (measured 1.0e-8 rad, 2.2e-8 rad/s). RK4 at the same step diverges and
# the run is stopped before any sample faster than max_speed is recorded.
LIMITS_ENERGY_GAIN = 1.25
LIMITS_PENETRATION = 0.1
HEAVY_DAMPING = 20.0
HEAVY_DAMPING_END_TOL = 1e-7

# 7. Long horizon: the double pendulum swing (chaotic, conservative) for LONG_DURATION at 1 ms.
# A symplectic first-order method keeps |E - E(0)| bounded: the max over the last 20 s is at
# most SEMI_IMPLICIT_GROWTH times that over the first 20 s, and everywhere below
# SEMI_IMPLICIT_ENERGY_RTOL of max K (semi_implicit_euler, symplectic Euler in momentum form,
# p = M(q) qd: measured 0.99, 0.92, 0.93 J in the three 20 s windows, 1.7 % of max K; the
# velocity form qd' = qd + qdd dt, q' = q + qd' dt, symplectic only for a constant M, lost
# energy secularly here: 14.6, 21.2, 31.3 J). RK4's drift over
# 60 s: <= RK4_LONG_ENERGY_RTOL of max K (measured 8.5e-8, growing 3.4e-8, 7.1e-8, 8.5e-8).
LONG_DURATION = 60.0
LONG_DT = 1e-3
SEMI_IMPLICIT_GROWTH = 1.5
SEMI_IMPLICIT_ENERGY_RTOL = 0.03
RK4_LONG_ENERGY_RTOL = 2.5e-7

# 8. Continuous joints wound up by k = 500 ... 1500 turns (|q| up to 9.4e3 rad). M, h and qdd at
# q + 2 pi k equal those at the same angle reduced exactly (50-digit decimal arithmetic) to
# WIND_REDUCED_RTOL (measured 3.4e-15: no accuracy is lost inside opendyn), and those at q to
# WIND_ARGUMENT_ULPS |q| eps: the float q + 2 pi k itself is only known to ~|q| eps absolute,
# and sin/cos pass that on (measured 0.50 |q| eps, i.e. 1e-12). A free wheel (continuous
# joint about z, gravity along its axis, no damping) at WHEEL_SPEED for WHEEL_DURATION reaches
# 4000 rad with q = q0 + w t to N ulp(q) / 2, the rounding of N additions (measured 2.5e-9 rad
# against 9.1e-9), and qd = w to WHEEL_SPEED_RTOL (measured exactly w).
WIND_TURNS = (500, 1500)
WIND_REDUCED_RTOL = 1e-14
WIND_ARGUMENT_ULPS = 4.0
WHEEL_SPEED = 100.0
WHEEL_DURATION = 40.0
WHEEL_DT = 1e-3
WHEEL_SPEED_RTOL = 1e-12

# 9. Random trees at random states: continuous joints anywhere in +-1e3 rad, other joints within
# their limits, |qd| ~ RANDOM_SPEEDS (up to 1e3 rad/s). Rounding in the recursions is relative
# to the size of the terms summed, S = ||M|| (||qdd|| + ||qd||^2) + ||g|| (+ ||tau||), not to
# the result; a torque error of nv eps S becomes an acceleration error of nv eps ||M^-1|| S.
# Bounds: ID = M qdd + h to RANDOM_ERROR_FACTOR nv eps S, FD(ID(qdd)) = qdd and the three
# methods agree to RANDOM_ERROR_FACTOR nv eps ||M^-1|| S (measured: 0.17, 0.12, 0.33 of the
# bound; 0.26, 0.17, 0.25 over 100 other trees x 3 speeds). M symmetric to CHAIN_SYMMETRY_RTOL
# (measured: exactly) and positive definite (smallest eigenvalue >= 0.021, cond(M) <= 1.1e3).
RANDOM_TREES = range(100, 130)
RANDOM_SPEEDS = (1.0, 1e2, 1e3)
RANDOM_CONTINUOUS_RANGE = 1e3
RANDOM_ERROR_FACTOR = 1.0


def rel(actual, expected, scale=None):
    """max |actual - expected| / scale, scale defaulting to max |expected|."""
    expected = np.asarray(expected, dtype=float)
    scale = np.abs(expected).max() if scale is None else scale
    return float(np.abs(np.asarray(actual) - expected).max() / scale)


# ----------------------------------------------------------------------------------------------
# 1. A 200-link chain


@pytest.fixture(scope="module")
def chain(tmp_path_factory):
    """(urdf path, model) of a serial chain of CHAIN_LINKS moving joints."""
    path = tmp_path_factory.mktemp("chain") / "chain.urdf"
    path.write_text(random_chain_urdf(CHAIN_SEED, CHAIN_LINKS))
    model = od.load_urdf(path)
    assert model.nv == CHAIN_LINKS
    return path, model


def chain_states(model, n, seed):
    rng = np.random.default_rng(seed)
    lower = np.where(np.isfinite(model.lower), model.lower, -np.pi)
    upper = np.where(np.isfinite(model.upper), model.upper, np.pi)
    for _ in range(n):
        yield rng.uniform(lower, upper), rng.normal(0, 1, model.nv), rng.normal(0, 10, model.nv)


def test_200_link_chain_mass_matrix_is_symmetric_positive_definite(chain):
    """M symmetric to CHAIN_SYMMETRY_RTOL of max |M|; Cholesky succeeds; smallest eigenvalue > 0."""
    _, model = chain
    for q, _, _ in chain_states(model, CHAIN_STATES, 1):
        M = od.mass_matrix(model, q)
        assert np.all(np.isfinite(M))
        assert rel(M, M.T) <= CHAIN_SYMMETRY_RTOL
        np.linalg.cholesky(M)
        assert np.linalg.eigvalsh(M).min() > 0.0


def test_200_link_chain_forward_dynamics_methods_agree(chain):
    """ABA, CRBA + Cholesky and the n-RNEA mass matrix give qdd equal to CHAIN_FD_RTOL ||qdd||."""
    _, model = chain
    for q, qd, tau in chain_states(model, CHAIN_STATES, 2):
        qdd = {m: od.forward_dynamics(model, q, qd, tau, method=m) for m in METHODS}
        size = np.linalg.norm(qdd["aba"])
        for m in ("crba", "newton_euler"):
            assert np.linalg.norm(qdd[m] - qdd["aba"]) <= CHAIN_FD_RTOL * size, m


def test_200_link_chain_rk4_conserves_energy(chain):
    """RK4 at CHAIN_DT for CHAIN_DURATION, gravity only: max |E - E(0)| <= CHAIN_ENERGY_RTOL
    max K(t)."""
    path, _ = chain
    scene = od.scene_from_dict(
        {
            "robot": {"urdf": str(path)},
            "run": {"duration": CHAIN_DURATION, "dt": CHAIN_DT, "integrator": "rk4"},
            "effects": {"gravity": True},
        }
    )
    traj = od.simulate(scene)
    assert traj.complete and np.all(np.isfinite(traj.q))
    scale = traj.kinetic.max()
    assert scale > 1e3  # the chain really falls and swings
    assert np.abs(traj.energy - traj.energy[0]).max() <= CHAIN_ENERGY_RTOL * scale


# ----------------------------------------------------------------------------------------------
# 2. Extreme mass and inertia ratios

RATIO_AXES = ("0 0 1", "0 1 0", "1 0 0", "0 0 1", "0 1 0", "1 0 0")


def ratio_chain_urdf():
    """A 6-joint chain, links alternating RATIO_HEAVY and RATIO_LIGHT kg, each with its centre
    of mass off the joint axis and rotational inertia m (0.2 m)^2 / 6 about its centre."""
    parts = ['<robot name="mass_ratio_chain">', '  <link name="base"/>']
    parent = "base"
    for i, axis in enumerate(RATIO_AXES):
        mass = RATIO_HEAVY if i % 2 == 0 else RATIO_LIGHT
        inertia = repr(mass * 0.2**2 / 6)
        parts += [
            f'  <link name="link{i}"><inertial><origin xyz="0.25 0.05 0"/>'
            f'<mass value="{mass!r}"/><inertia ixx="{inertia}" iyy="{inertia}" '
            f'izz="{inertia}" ixy="0" ixz="0" iyz="0"/></inertial></link>',
            f'  <joint name="joint{i}" type="revolute"><parent link="{parent}"/>'
            f'<child link="link{i}"/><origin xyz="{0.5 if i else 0.0} 0 0"/>'
            f'<axis xyz="{axis}"/><limit lower="-3" upper="3" effort="100" velocity="5"/>'
            "</joint>",
        ]
        parent = f"link{i}"
    parts.append("</robot>")
    return "\n".join(parts)


@pytest.fixture(scope="module")
def ratio_chain(tmp_path_factory):
    path = tmp_path_factory.mktemp("ratio") / "mass_ratio_chain.urdf"
    path.write_text(ratio_chain_urdf())
    return path, od.load_urdf(path)


def ratio_states(model):
    rng = np.random.default_rng(1)
    for _ in range(RATIO_STATES):
        yield rng.uniform(-3, 3, model.nv), rng.normal(0, 1, model.nv), rng.normal(0, 1, model.nv)


def torque_residual(model, q, qd, tau, qdd):
    """||M qdd + h - tau|| / ||tau||, with M and h from the core and the product in numpy."""
    M, h = od.mass_matrix(model, q), od.bias_forces(model, q, qd)
    return np.linalg.norm(M @ qdd + h - tau) / np.linalg.norm(tau)


def test_extreme_mass_ratio_chain_is_ill_conditioned(ratio_chain):
    """The case is as hard as it claims: cond(M) > RATIO_MIN_CONDITION at every state."""
    _, model = ratio_chain
    for q, _, _ in ratio_states(model):
        assert np.linalg.cond(od.mass_matrix(model, q)) > RATIO_MIN_CONDITION


def test_aba_torque_residual_stays_small_at_extreme_mass_ratios(ratio_chain):
    """||M qdd + h - tau|| / ||tau|| <= RATIO_RESIDUAL_RTOL for ABA."""
    _, model = ratio_chain
    for q, qd, tau in ratio_states(model):
        qdd = od.forward_dynamics(model, q, qd, tau, method="aba")
        assert np.all(np.isfinite(qdd))
        assert torque_residual(model, q, qd, tau, qdd) <= RATIO_RESIDUAL_RTOL


@pytest.mark.parametrize("method", ["crba", "newton_euler"])
def test_cholesky_path_stays_accurate_at_extreme_mass_ratios_rather_than_refusing(
    ratio_chain, method
):
    """What happens: the Cholesky path does NOT raise SingularMassMatrixError here (cond(M) ~
    1e11 is ill-conditioned, not singular) and its residual meets the same bound as ABA."""
    _, model = ratio_chain
    for q, qd, tau in ratio_states(model):
        qdd = od.forward_dynamics(model, q, qd, tau, method=method)  # no exception
        assert torque_residual(model, q, qd, tau, qdd) <= RATIO_RESIDUAL_RTOL


def test_extreme_mass_ratio_forward_dynamics_matches_pinocchio_joint_by_joint(ratio_chain):
    """Pinocchio's ABA is meaningful here (its residual meets RATIO_RESIDUAL_RTOL too); every
    joint's qdd, of every method, agrees with it to RATIO_PINOCCHIO_RTOL of that joint's |qdd|."""
    pytest.importorskip("pinocchio")
    from pin_adapter import PinOracle

    path, model = ratio_chain
    oracle = PinOracle(str(path), model)
    for q, qd, tau in ratio_states(model):
        ref = oracle.aba(q, qd, tau)
        assert torque_residual(model, q, qd, tau, ref) <= RATIO_RESIDUAL_RTOL
        for method in METHODS:
            qdd = od.forward_dynamics(model, q, qd, tau, method=method)
            assert np.all(np.abs(qdd - ref) <= RATIO_PINOCCHIO_RTOL * np.abs(ref)), method


# ----------------------------------------------------------------------------------------------
# 3. Singular and near-singular Jacobians


@pytest.fixture(scope="module")
def ur5():
    return od.load_urdf("ur5")


def inverse_task_inertia(model, q, frame=TASK_SPACE_FRAME):
    """J_b M^-1 J_b^T, computed here with numpy from od.mass_matrix and od.jacobian."""
    J_b = od.jacobian(model, q, frame, expressed_in="body")
    return J_b @ np.linalg.solve(od.mass_matrix(model, q), J_b.T)


def test_stretched_ur5_with_aligned_wrist_has_no_task_space_inertia(ur5):
    """q = 0: elbow straight and wrist axes 4 and 6 aligned. J M^-1 J^T has rank 5, and
    task_space_mass_matrix refuses it, naming the frame."""
    q = np.zeros(6)
    sv = np.linalg.svd(inverse_task_inertia(ur5, q), compute_uv=False)
    assert sv[-1] < 1e-20 * sv[0] and sv[-2] > 1e-4 * sv[0]
    with pytest.raises(od.SingularTaskSpaceError, match=f"frame '{TASK_SPACE_FRAME}'") as info:
        od.task_space_mass_matrix(ur5, q, TASK_SPACE_FRAME)
    assert "damping" in str(info.value)


@pytest.mark.parametrize("damping", TASK_SPACE_DAMPINGS)
def test_damped_task_space_inertia_at_the_singularity_is_the_damped_inverse(ur5, damping):
    """Lambda_d = (J M^-1 J^T + d I)^-1: finite, symmetric and positive definite, equal to
    numpy's to cond(J M^-1 J^T + d I) eps of its largest entry."""
    q = np.zeros(6)
    damped = inverse_task_inertia(ur5, q) + damping * np.eye(6)
    expected = np.linalg.inv(damped)
    tol = np.linalg.cond(damped) * EPS
    Lambda = od.task_space_mass_matrix(ur5, q, TASK_SPACE_FRAME, damping=damping)
    assert np.all(np.isfinite(Lambda))
    assert rel(Lambda, expected) <= tol
    assert rel(Lambda, Lambda.T) <= tol
    assert np.linalg.eigvalsh(0.5 * (Lambda + Lambda.T)).min() > 0.0


def test_near_singular_task_space_inertia_is_accurate_or_refused(ur5):
    """Along q = s d, s = 1e-1 ... 1e-4, towards the double singularity at 0: each call either
    raises SingularTaskSpaceError (only where cond(J M^-1 J^T) > TASK_SPACE_REFUSED_CONDITION)
    or returns Lambda with ||Lambda (J M^-1 J^T) - I||_2 <= cond eps. Both happen on the way."""
    direction = np.array([0.8, -0.6, 1.0, 0.5, -0.9, 0.7])
    accurate, refused = [], []
    for s in np.logspace(-1, -4, 13):
        q = s * direction
        inverse = inverse_task_inertia(ur5, q)
        cond = np.linalg.cond(inverse)
        try:
            Lambda = od.task_space_mass_matrix(ur5, q, TASK_SPACE_FRAME)
        except od.SingularTaskSpaceError as e:
            assert f"frame '{TASK_SPACE_FRAME}'" in str(e)
            assert cond > TASK_SPACE_REFUSED_CONDITION, (s, cond)
            refused.append(s)
            continue
        assert np.all(np.isfinite(Lambda))
        assert np.linalg.norm(Lambda @ inverse - np.eye(6), 2) <= cond * EPS, (s, cond)
        accurate.append(cond)
    assert refused and accurate and max(accurate) > TASK_SPACE_REFUSED_CONDITION


# ----------------------------------------------------------------------------------------------
# 4. A moving joint with no mass below it

MASSLESS_URDF = """<robot name="massless_wrist">
  <link name="base"/>
  <link name="arm"><inertial><mass value="1.5"/><origin xyz="0.4 0 0.1"/>
    <inertia ixx="0.02" iyy="0.03" izz="0.025" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="hand"/>
  <link name="tool"/>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="arm"/>
    <axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="10" velocity="5"/></joint>
  <joint name="wrist" type="revolute"><parent link="arm"/><child link="hand"/>
    <origin xyz="0.8 0 0" rpy="0.3 0 0"/><axis xyz="1 0 0"/>
    <limit lower="-3" upper="3" effort="10" velocity="5"/></joint>
  <joint name="tool_joint" type="fixed"><parent link="hand"/><child link="tool"/>
    <origin xyz="0.1 0 0"/></joint>
</robot>
"""


@pytest.fixture(scope="module")
def massless_urdf(tmp_path_factory):
    path = tmp_path_factory.mktemp("massless") / "massless_wrist.urdf"
    path.write_text(MASSLESS_URDF)
    return path


@pytest.mark.parametrize("method", METHODS)
def test_massless_joint_makes_forward_dynamics_name_it(massless_urdf, method):
    model = od.load_urdf(massless_urdf)
    q, qd, tau = np.array([0.4, -0.2]), np.array([0.5, 1.0]), np.array([0.1, 0.2])
    with pytest.raises(od.SingularMassMatrixError, match="'wrist'") as info:
        od.forward_dynamics(model, q, qd, tau, method=method)
    assert info.value.joints == ["wrist"]


def test_armature_on_a_massless_joint_gives_qdd_tau_over_armature(massless_urdf):
    """The wrist's row of M + diag(a) is (0, a) and its bias force is 0, so qdd_wrist = tau / a:
    q = q0 + qd0 t + tau / (2 a) t^2 to N ulp(|q|) / 2, qd = qd0 + tau / a t likewise. The
    shoulder swings under gravity unaffected; the energy balance E - E(0) = W_applied (the
    armature's kinetic energy included) holds to MASSLESS_BALANCE_RTOL of max |E|."""
    q0, qd0 = np.array([1.0, 0.3]), np.array([0.0, -0.5])
    scene = od.scene_from_dict(
        {
            "robot": {"urdf": str(massless_urdf)},
            "initial": {"q": list(q0), "qd": list(qd0)},
            "run": {"duration": 1.0, "dt": 1e-3, "integrator": "rk4"},
            "effects": {"gravity": True, "armature": {"values": {"wrist": MASSLESS_ARMATURE}}},
            "control": {"type": "constant", "tau": {"wrist": MASSLESS_TAU}},
        }
    )
    traj = od.simulate(scene)
    assert traj.complete and np.all(np.isfinite(traj.q)) and np.all(np.isfinite(traj.qd))
    t, qdd = traj.t, MASSLESS_TAU / MASSLESS_ARMATURE
    steps = traj.stats["steps"]
    q_w, qd_w = traj.q[:, 1], traj.qd[:, 1]
    rounding = steps / 2 * np.spacing([np.abs(q_w).max(), np.abs(qd_w).max()])
    assert rel(q_w, q0[1] + qd0[1] * t + 0.5 * qdd * t**2, 1.0) <= rounding[0]
    assert rel(qd_w, qd0[1] + qdd * t, 1.0) <= rounding[1]
    assert np.ptp(traj.q[:, 0]) > 0.5  # the shoulder swings
    assert np.abs(traj.energy_error).max() <= MASSLESS_BALANCE_RTOL * np.abs(traj.energy).max()


# ----------------------------------------------------------------------------------------------
# 5. High speeds


def spin_settings(**run):
    """The double pendulum without gravity, spinning: qd0 = SPIN_QD0."""
    settings = {
        "name": "spinning double pendulum",
        "robot": {"name": "double_pendulum"},
        "initial": {"q": [0.3, -0.4], "qd": list(SPIN_QD0)},
        "run": {"duration": 1.0, "dt": 1e-3, "integrator": "dopri5", "output_dt": 0.01},
    }
    settings["run"].update(run)
    return settings


def shoulder_momentum(model, traj):
    """p_1 = (M(q) qd)_1 at every sample: angular momentum about the shoulder axis."""
    return np.einsum("kj,kj->k", od.mass_matrix(model, traj.q)[:, 0, :], traj.qd)


def test_dopri5_holds_its_error_bound_at_100_rad_per_s():
    """dopri5 at SPIN_RTOL: |q - q_ref| <= SPIN_Q_ERROR_PER_RTOL rtol rad against dopri5 at
    1e-12; energy and shoulder angular momentum conserved to SPIN_ENERGY_RTOL and
    SPIN_MOMENTUM_RTOL (the reference to SPIN_REFERENCE_RTOL)."""
    ref = od.simulate(od.scene_from_dict(spin_settings(rtol=1e-12, atol=1e-12)))
    traj = od.simulate(od.scene_from_dict(spin_settings(rtol=SPIN_RTOL, atol=SPIN_RTOL * 1e-2)))
    assert ref.complete and traj.complete
    np.testing.assert_allclose(traj.t, ref.t, rtol=0, atol=1e-12)
    assert np.ptp(ref.q[:, 0]) > 80  # more than a dozen turns
    assert np.abs(traj.q - ref.q).max() <= SPIN_Q_ERROR_PER_RTOL * SPIN_RTOL
    model = od.load_urdf("double_pendulum")
    for run, bound_E, bound_p in (
        (traj, SPIN_ENERGY_RTOL, SPIN_MOMENTUM_RTOL),
        (ref, SPIN_REFERENCE_RTOL, SPIN_REFERENCE_RTOL),
    ):
        assert not run.potential.any()  # no gravity: E = K
        assert rel(run.energy, run.energy[0]) <= bound_E
        p = shoulder_momentum(model, run)
        assert rel(p, p[0]) <= bound_p


def check_partial_record(traj, scene, message):
    """A partial record holds only the states before the failure: complete=False, every sample
    finite and within max_speed, the last one at the time the message names, and the record
    identical to a complete run up to that time; one more Euler step from its last state
    really passes max_speed."""
    max_speed = scene.run.max_speed
    assert not traj.complete
    for name in ("t", "q", "qd", "kinetic"):
        assert np.all(np.isfinite(getattr(traj, name))), name
    assert np.abs(traj.qd).max() <= max_speed
    t_stop, steps = traj.t[-1], int(round(traj.t[-1] / EULER_DT))
    assert 0 < t_stop < scene.run.duration
    assert f"t = {t_stop:.6g} s (step {steps})" in message
    assert "max_speed" in message
    complete = od.simulate(scene.replace_run(duration=t_stop))
    assert complete.complete
    np.testing.assert_array_equal(traj.t, complete.t)
    np.testing.assert_array_equal(traj.q, complete.q)
    np.testing.assert_array_equal(traj.qd, complete.qd)
    q, qd = traj.q[-1], traj.qd[-1]
    qdd = od.forward_dynamics(scene.model, q, qd, np.zeros(2), gravity=np.zeros(3))
    assert np.abs(qd + EULER_DT * qdd).max() > max_speed


def test_explicit_euler_divergence_at_high_speed_stops_and_keeps_the_partial_record(tmp_path):
    """Explicit Euler at EULER_DT on the spinning pendulum gains energy until |qd| would pass
    max_speed: SimulationError names the time and step; the partial record saves, loads back
    unchanged and holds only the states before the failure."""
    scene = od.scene_from_dict(spin_settings(integrator="euler", dt=EULER_DT, output_dt=EULER_DT))
    with pytest.raises(od.SimulationError) as info:
        od.simulate(scene)
    partial = info.value.trajectory
    assert "explicit Euler" in str(info.value)
    check_partial_record(partial, scene, str(info.value))
    back = od.Trajectory.load(partial.save(tmp_path / "spin.npz"))
    assert not back.complete and back.message == str(info.value)
    np.testing.assert_array_equal(back.q, partial.q)
    np.testing.assert_array_equal(back.qd, partial.qd)


def test_explicit_euler_divergence_on_the_command_line_writes_the_partial_record(
    tmp_path, monkeypatch, capsys
):
    scene_file = tmp_path / "spin.toml"
    scene_file.write_text(
        'name = "spinning double pendulum"\n'
        '[robot]\nname = "double_pendulum"\n'
        f"[initial]\nq = [0.3, -0.4]\nqd = [{SPIN_QD0[0]!r}, {SPIN_QD0[1]!r}]\n"
        f'[run]\nduration = 1.0\nintegrator = "euler"\ndt = {EULER_DT!r}\n'
        f"output_dt = {EULER_DT!r}\n"
    )
    monkeypatch.chdir(tmp_path)
    assert main(["simulate", str(scene_file), "-q"]) == 1
    err = capsys.readouterr().err
    (path,) = tmp_path.glob("*-partial.npz")
    traj = od.Trajectory.load(path)
    assert traj.message in err
    check_partial_record(traj, od.load_scene(scene_file), traj.message)


# ----------------------------------------------------------------------------------------------
# 6. Stiff joint limits and heavy damping


def heavy_damping_scene():
    """planar_3r_limits with viscous damping HEAVY_DAMPING on every joint."""
    settings = thaw(od.load_scene("planar_3r_limits").settings)
    settings["effects"]["damping"] = {"coefficients": HEAVY_DAMPING}
    return od.scene_from_dict(settings, base_dir=shipped_robots_dir())


def limit_penetration(scene, q):
    lim = scene.limits
    return np.maximum(q - lim.upper, 0.0) + np.maximum(lim.lower - q, 0.0)


def check_divergence_is_never_recorded(scene):
    """RK4 at the scene's step: stopped early, every recorded sample finite and within
    max_speed, and the saved record says so."""
    traj = od.simulate(scene.replace_run(integrator="rk4"), raise_on_failure=False)
    assert not traj.complete and traj.t[-1] < scene.run.duration
    for name in ("t", "q", "qd", "kinetic", "work_passive"):
        assert np.all(np.isfinite(getattr(traj, name))), name
    assert np.abs(traj.qd).max() <= scene.run.max_speed
    steps = int(round(traj.t[-1] / scene.run.dt))
    assert f"t = {traj.t[-1]:.6g} s (step {steps})" in traj.message
    assert "implicit_euler" in traj.message
    assert traj.record()["complete"] is False


@pytest.mark.parametrize("variant", ["planar_3r_limits", "heavy damping"])
def test_implicit_euler_stays_bounded_where_rk4_diverges_and_is_stopped(variant):
    """Implicit Euler at 5 ms: K(t) <= LIMITS_ENERGY_GAIN (E(0) + W_applied(t)), penetration
    <= LIMITS_PENETRATION. RK4 at 5 ms: stopped, never recorded past max_speed."""
    scene = (
        od.load_scene("planar_3r_limits") if variant != "heavy damping" else heavy_damping_scene()
    )
    assert scene.run.integrator == "implicit_euler" and scene.run.dt == 5e-3
    traj = od.simulate(scene)
    assert traj.complete and np.all(np.isfinite(traj.q)) and np.all(np.isfinite(traj.qd))
    supplied = traj.energy[0] + traj.work_applied
    assert np.all(traj.kinetic <= LIMITS_ENERGY_GAIN * supplied)
    assert limit_penetration(scene, traj.q).max() <= LIMITS_PENETRATION
    check_divergence_is_never_recorded(scene)


def test_heavily_damped_arm_settles_on_its_closed_form():
    """Joint 1, pushed by tau_1 into its upper limit, rests at upper + tau_1 / k; joint 3, pushed
    by tau_3 and free, turns at its terminal velocity tau_3 / d (HEAVY_DAMPING_END_TOL)."""
    scene = heavy_damping_scene()
    traj = od.simulate(scene)
    tau = scene.control.tau
    k, upper = scene.limits.stiffness[0], scene.limits.upper[0]
    assert abs(traj.q[-1, 0] - (upper + tau[0] / k)) <= HEAVY_DAMPING_END_TOL
    assert abs(traj.qd[-1, 2] - tau[2] / HEAVY_DAMPING) <= HEAVY_DAMPING_END_TOL


# ----------------------------------------------------------------------------------------------
# 7. Long horizons


def long_swing(integrator):
    scene = od.load_scene("double_pendulum_swing")
    assert scene.effects == ("gravity",)
    return od.simulate(scene.replace_run(duration=LONG_DURATION, dt=LONG_DT, integrator=integrator))


def energy_error_by_window(traj, width=20.0):
    """max |E - E(0)| over consecutive windows of `width` seconds."""
    error = np.abs(traj.energy - traj.energy[0])
    edges = np.arange(0.0, traj.t[-1] + 1e-9, width)
    return [error[(traj.t >= a) & (traj.t <= a + width)].max() for a in edges[:-1]]


def test_semi_implicit_euler_energy_error_stays_bounded_over_60_s():
    """No secular growth: max |E - E(0)| over the last 20 s <= SEMI_IMPLICIT_GROWTH x over the
    first 20 s, and everywhere <= SEMI_IMPLICIT_ENERGY_RTOL max K."""
    traj = long_swing("semi_implicit_euler")
    assert traj.complete
    first, _, last = energy_error_by_window(traj)
    assert last <= SEMI_IMPLICIT_GROWTH * first
    assert max(first, last) <= SEMI_IMPLICIT_ENERGY_RTOL * traj.kinetic.max()


def test_rk4_energy_drift_over_60_s_is_bounded():
    """RK4 at 1 ms for 60 s: max |E - E(0)| <= RK4_LONG_ENERGY_RTOL max K."""
    traj = long_swing("rk4")
    assert traj.complete and abs(traj.t[-1] - LONG_DURATION) < 1e-9
    assert max(energy_error_by_window(traj)) <= RK4_LONG_ENERGY_RTOL * traj.kinetic.max()


# ----------------------------------------------------------------------------------------------
# 8. Continuous joints wound up to thousands of radians

PI_50_DIGITS = "3.14159265358979323846264338327950288419716939937510"


def reduced_angle(q, turns):
    """q - 2 pi turns in 50-digit decimal arithmetic (exact for the float q to far below its
    ulp), rounded once to float."""
    with localcontext() as context:
        context.prec = 50
        two_pi = 2 * Decimal(PI_50_DIGITS)
        return np.array([float(Decimal(float(x)) - int(k) * two_pi) for x, k in zip(q, turns)])


@pytest.fixture(scope="module")
def wound_trees(tmp_path_factory):
    """Random trees (randtree) that have continuous joints, with states wound up on them."""
    folder = tmp_path_factory.mktemp("wound")
    out = []
    for seed in range(1, 9):
        model = od.load_urdf(write_random_tree(folder, seed, n_links=8 + seed % 8))
        continuous = np.asarray(model.continuous)
        assert continuous.any()
        rng = np.random.default_rng(seed)
        for _ in range(3):
            q = rng.uniform(-np.pi, np.pi, model.nv)
            turns = rng.integers(*WIND_TURNS, model.nv) * continuous
            qd, tau = rng.normal(0, 2, model.nv), rng.normal(0, 10, model.nv)
            out.append((model, q, q + 2 * np.pi * turns, turns, qd, tau))
    return out


def test_wound_continuous_joints_lose_no_accuracy(wound_trees):
    """M, h, qdd at q + 2 pi k equal those at the exactly reduced angle to WIND_REDUCED_RTOL, and
    those at q to WIND_ARGUMENT_ULPS |q| eps (what the float q + 2 pi k itself carries)."""
    for model, q, q_wound, turns, qd, tau in wound_trees:
        assert np.abs(q_wound).max() > 2 * np.pi * WIND_TURNS[0]
        argument = WIND_ARGUMENT_ULPS * np.abs(q_wound).max() * EPS
        q_reduced = reduced_angle(q_wound, turns)
        for f in (
            lambda x: od.mass_matrix(model, x),
            lambda x: od.bias_forces(model, x, qd),
            lambda x: od.forward_dynamics(model, x, qd, tau),
        ):
            at_wound = f(q_wound)
            assert np.all(np.isfinite(at_wound))
            assert rel(at_wound, f(q_reduced)) <= WIND_REDUCED_RTOL
            assert rel(at_wound, f(q)) <= argument


WHEEL_URDF = """<robot name="wheel">
  <link name="base"/>
  <link name="rotor"><inertial><origin xyz="0.1 0.02 0.05" rpy="0.3 -0.2 0.1"/>
    <mass value="2"/><inertia ixx="0.01" iyy="0.012" izz="0.02" ixy="0" ixz="0" iyz="0"/>
  </inertial></link>
  <joint name="spin" type="continuous"><parent link="base"/><child link="rotor"/>
    <origin xyz="0 0 0.3"/><axis xyz="0 0 1"/></joint>
</robot>
"""


def test_free_wheel_winds_to_thousands_of_radians_at_constant_speed(tmp_path):
    """An unbalanced rotor on a vertical continuous joint, gravity along the axis, no damping:
    q = q0 + w t to N ulp(q) / 2 (N steps) over WHEEL_DURATION, and qd = w to
    WHEEL_SPEED_RTOL."""
    urdf = tmp_path / "wheel.urdf"
    urdf.write_text(WHEEL_URDF)
    q0 = 0.7
    scene = od.scene_from_dict(
        {
            "robot": {"urdf": str(urdf)},
            "initial": {"q": [q0], "qd": [WHEEL_SPEED]},
            "run": {"duration": WHEEL_DURATION, "dt": WHEEL_DT, "integrator": "rk4"},
            "effects": {"gravity": True},
        }
    )
    traj = od.simulate(scene)
    assert traj.complete and traj.q[-1, 0] > 4000
    steps = traj.stats["steps"]
    bound = steps * np.spacing(traj.q[-1, 0]) / 2
    assert rel(traj.q[:, 0], q0 + WHEEL_SPEED * traj.t, 1.0) <= bound
    assert rel(traj.qd[:, 0], WHEEL_SPEED) <= WHEEL_SPEED_RTOL


def test_integrate_on_large_angles_is_exact_addition():
    """od.integrate(q, v, dt) is q + v dt in float arithmetic, bit for bit, at |q| up to 1e4."""
    model = od.load_urdf("double_pendulum")
    rng = np.random.default_rng(8)
    q, v = rng.uniform(-1e4, 1e4, (1000, 2)), rng.uniform(-1e3, 1e3, (1000, 2))
    dt = rng.uniform(0, 1e-2, 1000)
    for k in range(len(q)):
        np.testing.assert_array_equal(od.integrate(model, q[k], v[k], dt[k]), q[k] + v[k] * dt[k])
    np.testing.assert_array_equal(od.integrate(model, q, v, 1e-3), q + v * 1e-3)


# ----------------------------------------------------------------------------------------------
# 9. Random trees at large velocities and angles


@pytest.fixture(scope="module")
def random_trees(tmp_path_factory):
    folder = tmp_path_factory.mktemp("random_trees")
    return [
        (seed, od.load_urdf(write_random_tree(folder, seed, n_links=6 + seed % 12)))
        for seed in RANDOM_TREES
    ]


def random_states(seed, model):
    """One state per speed in RANDOM_SPEEDS: continuous joints in +-RANDOM_CONTINUOUS_RANGE rad,
    the others within their limits; qd ~ N(0, speed); qdd ~ N(0, 3); tau ~ N(0, 10)."""
    rng = np.random.default_rng(seed)
    lower = np.where(np.isfinite(model.lower), model.lower, -RANDOM_CONTINUOUS_RANGE)
    upper = np.where(np.isfinite(model.upper), model.upper, RANDOM_CONTINUOUS_RANGE)
    for speed in RANDOM_SPEEDS:
        yield (
            rng.uniform(lower, upper),
            rng.normal(0, speed, model.nv),
            rng.normal(0, 3, model.nv),
            rng.normal(0, 10, model.nv),
        )


def test_random_trees_cover_continuous_joints_and_fast_states(random_trees):
    assert sum(int(np.sum(model.continuous)) for _, model in random_trees) >= 20
    qd_max = max(
        np.abs(qd).max()
        for seed, model in random_trees
        for _, qd, _, _ in random_states(seed, model)
    )
    assert qd_max > 1e3


def test_random_trees_at_large_velocities_keep_the_dynamics_identities(random_trees):
    """At every state: no exception, everything finite; M symmetric (CHAIN_SYMMETRY_RTOL) and
    positive definite; with S = ||M|| (||qdd|| + ||qd||^2) + ||g||: ID = M qdd + h to
    RANDOM_ERROR_FACTOR nv eps S and FD(ID(qdd)) = qdd for every method to RANDOM_ERROR_FACTOR
    nv eps ||M^-1|| S; for FD(tau) the three methods agree to RANDOM_ERROR_FACTOR nv eps
    ||M^-1|| S' with S' = ||M|| ||qd||^2 + ||g|| + ||tau||."""
    for seed, model in random_trees:
        nv = model.nv
        for q, qd, qdd, tau in random_states(seed, model):
            M = od.mass_matrix(model, q)
            h, g = od.bias_forces(model, q, qd), od.gravity_forces(model, q)
            for x in (M, h, g):
                assert np.all(np.isfinite(x))
            assert rel(M, M.T) <= CHAIN_SYMMETRY_RTOL
            np.linalg.cholesky(M)
            eig = np.linalg.eigvalsh(M)
            assert eig[0] > 0.0
            size = eig[-1] * (np.linalg.norm(qdd) + np.linalg.norm(qd) ** 2) + np.linalg.norm(g)
            bound = RANDOM_ERROR_FACTOR * nv * EPS * size
            tau_id = od.inverse_dynamics(model, q, qd, qdd)
            assert np.linalg.norm(tau_id - (M @ qdd + h)) <= bound, seed
            for method in METHODS:
                back = od.forward_dynamics(model, q, qd, tau_id, method=method)
                assert np.linalg.norm(back - qdd) <= bound / eig[0], (seed, method)
            solved = {m: od.forward_dynamics(model, q, qd, tau, method=m) for m in METHODS}
            size = eig[-1] * np.linalg.norm(qd) ** 2 + np.linalg.norm(g) + np.linalg.norm(tau)
            agree = RANDOM_ERROR_FACTOR * nv * EPS * size / eig[0]
            for method in ("crba", "newton_euler"):
                assert np.all(np.isfinite(solved[method]))
                assert np.linalg.norm(solved[method] - solved["aba"]) <= agree, (seed, method)
