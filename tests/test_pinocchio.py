"""Every contract function against Pinocchio, on every example-robot-data URDF Pinocchio loads.

Pinocchio is the oracle only; the conversions between its conventions and ours live in
pin_adapter.py. Tolerance: 1e-9 relative to each entry of the reference (or 1e-9 absolute for
an entry smaller than 1 in SI units), at several random states per robot.
"""

from __future__ import annotations

import importlib.metadata
import warnings
from pathlib import Path

import numpy as np
import pytest

import opendyn as od
from opendyn.algorithm.forward import METHODS

pin = pytest.importorskip("pinocchio")
from pin_adapter import PinOracle  # noqa: E402
from randtree import write_random_tree  # noqa: E402

RTOL = 1e-9
FLOOR = 1.0  # SI units: entries smaller than this are compared to rtol * FLOOR absolutely
N_STATES = 3


def _example_robot_data_urdfs():
    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        return []
    return sorted(str(dist.locate_file(f)) for f in dist.files or [] if str(f).endswith(".urdf"))


def _pinocchio_loads(path):
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            pin.buildModelFromUrdf(path)
        return True
    except (ValueError, RuntimeError):
        return False


URDFS = [p for p in _example_robot_data_urdfs() if _pinocchio_loads(p)]
MODELS = {p: od.load_urdf(p, check_inertia=False) for p in URDFS}


def assert_close(ours, ref, what, rtol=RTOL, floor=FLOOR):
    """Entry by entry: |ours - ref| <= rtol max(|ref|, floor). A small entry (a finger's
    inertia on a heavy floating robot) is held to its own size, not to the array's largest."""
    ours, ref = np.asarray(ours, dtype=float), np.asarray(ref, dtype=float)
    assert ours.shape == ref.shape, f"{what}: shape {ours.shape} != {ref.shape}"
    if ref.size == 0:
        return
    err = np.abs(ours - ref) / np.maximum(np.abs(ref), floor)
    worst = np.unravel_index(np.argmax(err), err.shape)
    assert err[worst] <= rtol, (
        f"{what}: entry {tuple(int(i) for i in worst)} is {ours[worst]!r}, Pinocchio's "
        f"{ref[worst]!r}: relative error {err[worst]:.3e} > {rtol:g}"
    )


def _load(path, **kw):
    """Our model and the oracle; physically invalid inertias in a few of these URDFs are kept
    as written (check_inertia=False) since Pinocchio keeps them too."""
    model = od.load_urdf(path, check_inertia=False, **kw)
    return model, PinOracle(path, model, mimic=kw.get("mimic", False))


def _states(model, seed):
    """q with every joint uniform in [-pi, pi] (limits ignored) and, for a floating base, a
    random pose; qd, qdd, tau standard normal."""
    rng = np.random.default_rng(seed)
    for _ in range(N_STATES):
        q = od.random_configuration(model, rng)
        q[model.q_index] = rng.uniform(-np.pi, np.pi, len(model.joint_names))
        yield q, rng.normal(size=(3, model.nv))


def _test_frames(model):
    """A frame on the last body, a frame on a fixed joint (when there is one), the root, and the
    last moving joint by its name."""
    moving = [f.name for f in model.frames if f.body >= 0]
    welded = [f.name for f in model.frames if f.body >= 0 and f.name not in model.body_names]
    joints = list(model.body_joints[-1:])  # a joint's name is its child link's frame
    return list(dict.fromkeys(moving[-1:] + welded[:1] + [model.frames[0].name] + joints))


def test_the_oracle_covers_example_robot_data():
    assert len(URDFS) >= 60, f"only {len(URDFS)} example-robot-data URDFs load in Pinocchio"


@pytest.mark.parametrize("path", URDFS, ids=[Path(p).stem for p in URDFS])
def test_contract_functions_match_pinocchio(path):
    _check_contract_functions(*_load(path))


@pytest.mark.parametrize("path", URDFS, ids=[Path(p).stem for p in URDFS])
def test_floating_base_matches_pinocchio(path):
    """Every robot with floating_base=True against Pinocchio with a JointModelFreeFlyer root."""
    model, P = _load(path, floating_base=True)
    assert model.floating_base and model.nq == model.nv + 1 == MODELS[path].nv + 7
    _check_contract_functions(model, P)


@pytest.mark.parametrize("seed", range(8))
def test_floating_random_trees_match_pinocchio(tmp_path, seed):
    """The seeded random trees on a free root link (its inertia now moves with the base)."""
    model, P = _load(str(write_random_tree(tmp_path, seed)), floating_base=True)
    _check_contract_functions(model, P)
    for q, _ in _states(model, 4):
        assert_close(od.christoffel_symbols(model, q), P.christoffel(q), "christoffel_symbols")


@pytest.mark.parametrize("seed", range(8))
def test_contract_functions_match_pinocchio_on_random_trees(tmp_path, seed):
    """Seeded random trees (tests/randtree.py): several branches from the root, all joint types,
    fixed joints inside chains and as flanges, missing and non-unit axes, inertial and joint
    origins with any rpy, massless links."""
    model, P = _load(str(write_random_tree(tmp_path, seed)))
    _check_contract_functions(model, P)
    for q, _ in _states(model, 4):
        assert_close(od.christoffel_symbols(model, q), P.christoffel(q), "christoffel_symbols")


def _check_contract_functions(model, P):
    rng = np.random.default_rng(7)
    frames = _test_frames(model)
    for q, (qd, qdd, tau) in _states(model, 1):
        assert_close(od.inverse_dynamics(model, q, qd, qdd), P.rnea(q, qd, qdd), "inverse_dynamics")
        f_tip = {name: rng.normal(size=6) for name in frames}
        assert_close(
            od.inverse_dynamics(model, q, qd, qdd, f_tip=f_tip),
            P.rnea(q, qd, qdd, f_tip=f_tip),
            "inverse_dynamics with f_tip",
        )
        g_moon = np.array([0.3, -0.2, -1.62])
        assert_close(
            od.inverse_dynamics(model, q, qd, qdd, gravity=g_moon),
            P.rnea(q, qd, qdd, gravity=g_moon),
            "inverse_dynamics with gravity",
        )
        M_ref = P.mass_matrix(q)
        assert_close(od.mass_matrix(model, q), M_ref, "mass_matrix")
        assert_close(od.gravity_forces(model, q), P.gravity_forces(q), "gravity_forces")
        zero = np.zeros(model.nv)
        assert_close(
            od.coriolis_forces(model, q, qd),
            P.rnea(q, qd, zero, gravity=(0, 0, 0)),
            "coriolis_forces",
        )
        assert_close(od.bias_forces(model, q, qd), P.rnea(q, qd, zero), "bias_forces")
        assert_close(od.coriolis_matrix(model, q, qd), P.coriolis_matrix(q, qd), "coriolis_matrix")
        for name in frames:
            assert_close(od.frame_pose(model, q, name), P.frame_pose(q, name), f"pose {name}")
            for where in ("space", "body"):
                assert_close(
                    od.jacobian(model, q, name, where),
                    P.jacobian(q, name, where),
                    f"jacobian {name} {where}",
                )
        assert_close(od.kinetic_energy(model, q, qd), P.kinetic_energy(q, qd), "kinetic_energy")
        assert_close(od.potential_energy(model, q), P.potential_energy(q), "potential_energy")
        _check_forward_dynamics(model, P, q, qd, tau, M_ref, f_tip)


def _check_forward_dynamics(model, P, q, qd, tau, M_ref, f_tip):
    """All three methods against Pinocchio's ABA; a singular M must be refused, not solved."""
    if model.nv and np.linalg.eigvalsh(M_ref)[0] <= 1e-12 * np.abs(M_ref).max():
        for method in METHODS:
            with pytest.raises(od.SingularMassMatrixError):
                od.forward_dynamics(model, q, qd, tau, method=method)
        return
    ref = P.aba(q, qd, tau, f_tip=f_tip)
    for method in METHODS:
        assert_close(
            od.forward_dynamics(model, q, qd, tau, f_tip=f_tip, method=method),
            ref,
            f"forward_dynamics {method}",
        )


SMALL = [p for p in URDFS if 0 < MODELS[p].nv <= 16]


@pytest.mark.parametrize("floating_base", [False, True], ids=["fixed", "floating"])
@pytest.mark.parametrize("path", SMALL, ids=[Path(p).stem for p in SMALL])
def test_christoffel_symbols_match_pinocchio(path, floating_base):
    model, P = _load(path, floating_base=floating_base)
    for q, _ in _states(model, 2):
        assert_close(od.christoffel_symbols(model, q), P.christoffel(q), "christoffel_symbols")


MIMIC = [p for p in URDFS if any("mimic" in line for line in MODELS[p].report.ignored)]


@pytest.mark.parametrize("path", MIMIC, ids=[Path(p).stem for p in MIMIC])
def test_coupled_mimic_joints_match_pinocchio(path):
    try:
        model = od.load_urdf(path, check_inertia=False, mimic=True)
    except od.URDFError as e:
        # alex_psyonic_hands mimics joints that do not exist: refused with the joint named
        assert "<mimic joint=" in str(e) and "not a moving joint" in str(e)
        return
    try:
        P = PinOracle(path, model, mimic=True)
    except ValueError as e:
        pytest.skip(f"Pinocchio cannot couple these mimic joints: {e}")
    assert model.nv < model.nb
    for q, (qd, qdd, tau) in _states(model, 3):
        assert_close(od.inverse_dynamics(model, q, qd, qdd), P.rnea(q, qd, qdd), "rnea (mimic)")
        M = od.mass_matrix(model, q)
        assert_close(M, P.mass_matrix(q), "mass_matrix (mimic)")
        name = _test_frames(model)[0]
        assert_close(
            od.jacobian(model, q, name, "body"), P.jacobian(q, name, "body"), "jacobian (mimic)"
        )
        h = P.rnea(q, qd, np.zeros(model.nv))
        assert_close(
            od.forward_dynamics(model, q, qd, tau) @ M.T,
            tau - h,
            "forward_dynamics (mimic): M qdd = tau - h",
        )


def test_physically_invalid_inertias_are_refused_unless_asked():
    """A few example-robot-data URDFs state inertias no rigid body has (e.g. pr2's
    sensor_mount_link: principal moments 0.001, 0.001, 0.01); the default load refuses them."""
    refused = []
    for path in URDFS:
        try:
            od.load_urdf(path)
        except od.URDFError as e:
            assert "check_inertia=False" in str(e) and Path(path).name in str(e)
            refused.append(Path(path).stem)
    assert "pr2" in refused and "ur5_robot" not in refused


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("floating_base", [False, True])
def test_the_adapters_wrench_convention_is_the_jacobian_transpose(tmp_path, seed, floating_base):
    """The tests' adapter sends f_tip to Pinocchio as fext; Pinocchio's RNEA with it must add
    J_b^T F, J_b being Pinocchio's LOCAL Jacobian of the frame in the adapter's angular-first
    order: two routes through the adapter's conventions that meet only if both are right."""
    model, P = _load(str(write_random_tree(tmp_path, seed)), floating_base=floating_base)
    rng = np.random.default_rng(seed)
    for q, (qd, qdd, _) in _states(model, seed):
        for name in _test_frames(model):
            F = rng.normal(size=6)
            J_b = P.jacobian(q, name, "body")
            expected = P.rnea(q, qd, qdd) + J_b.T @ F
            assert_close(P.rnea(q, qd, qdd, f_tip={name: F}), expected, f"f_tip at {name}")


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("floating_base", [False, True])
def test_opendyn_verify_converts_as_the_tests_adapter_does(tmp_path, seed, floating_base):
    """`opendyn verify`'s oracle (opendyn.verify.oracle) and the tests' adapter, whose
    conversions are written apart, agree on q (continuous joints' cos/sin, the free joint's
    (p, quat)), on the velocity order, on the external forces and on angular-first rows."""
    from opendyn.verify.oracle import PinocchioOracle

    path = str(write_random_tree(tmp_path, seed))
    model = od.load_urdf(path, check_inertia=False, floating_base=floating_base)
    ours, package = PinOracle(path, model), PinocchioOracle(path, model)
    assert (ours.perm_v == package.perm_v).all()
    rng = np.random.default_rng(seed)
    for q, (qd, _, _) in _states(model, seed):
        np.testing.assert_array_equal(ours.q(q), package.q(q))
        np.testing.assert_array_equal(ours.v(qd), package.v(qd))
        np.testing.assert_array_equal(package.back(ours.v(qd)), qd)
        for name in _test_frames(model):
            f_tip = {name: rng.normal(size=6)}
            for a, b in zip(ours.fext(q, f_tip), package.fext(q, f_tip)):
                np.testing.assert_allclose(a.vector, b.vector, rtol=0, atol=1e-12)
            for where in ("space", "body"):
                np.testing.assert_array_equal(
                    ours.jacobian(q, name, where), package.jacobian(q, name, where)
                )
        np.testing.assert_array_equal(
            ours.centroidal_momentum_matrix(q), package.centroidal_momentum_matrix(q)
        )
