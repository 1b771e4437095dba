"""The dynamics' derivatives: inverse_dynamics_derivatives and forward_dynamics_derivatives
against Pinocchio's computeRNEADerivatives and computeABADerivatives (every example-robot-data
URDF, fixed and floating; seeded random trees with prismatic and coupled mimic joints), against
central differences of our own inverse and forward dynamics (q moved along integrate), and
against identities: dtau/dqdd = M, dqdd/dtau = M^-1, for a fixed base dtau/dqd = 2 C (the
Christoffel contraction) and, at rest, dtau/dq = d^2U/dq^2 (symmetric); for a floating base
without gravity, moving the whole robot changes no acceleration."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import opendyn as od

pin = pytest.importorskip("pinocchio")
from pin_adapter import PinOracle  # noqa: E402
from randtree import write_random_tree  # noqa: E402
from test_pinocchio import MIMIC, URDFS, _states, _test_frames  # noqa: E402
from test_pinocchio import assert_close as pinocchio_close  # noqa: E402

RTOL = 1e-8  # relative to the largest entry of the reference (or 1 when that is smaller)
SINGULAR_M = 1e-12


def assert_close(ours, ref, what, rtol=RTOL):
    """|ours - ref| <= rtol max(1, max |ref|) for every entry. A derivative is a sum of
    products of large terms (through M^-1 for the forward dynamics'), computed by Pinocchio in
    the joints' frames and by opendyn in the world frame: an entry's rounding is set by the
    terms that make the whole array, not by its own size, so the scale is the array's (the
    dynamics functions themselves are compared entry by entry, test_pinocchio.assert_close)."""
    ours, ref = np.asarray(ours, dtype=float), np.asarray(ref, dtype=float)
    assert ours.shape == ref.shape, f"{what}: shape {ours.shape} != {ref.shape}"
    if ref.size == 0:
        return
    scale = max(1.0, float(np.abs(ref).max()))
    pinocchio_close(ours, ref, what, rtol, floor=scale)


def _load(path, **kw):
    model = od.load_urdf(path, check_inertia=False, **kw)
    return model, PinOracle(path, model, mimic=kw.get("mimic", False))


def _check_derivatives(model, P, n_states=2):
    """Both functions at random states, plain, with an f_tip wrench on every test frame and
    with another gravity; a singular M must be refused by the forward derivatives."""
    rng = np.random.default_rng(3)
    frames = [f for f in _test_frames(model) if model.frames[model.frame_index(f)].body >= 0]
    for k, (q, (qd, qdd, tau)) in enumerate(_states(model, 5)):
        if k == n_states:
            break
        variants = [
            {},
            {"f_tip": {name: rng.normal(size=6) for name in frames}},
            {"gravity": np.array([0.3, -0.2, -1.62])},
        ]
        for loads in variants:
            ours = od.inverse_dynamics_derivatives(model, q, qd, qdd, **loads)
            ref = P.rnea_derivatives(q, qd, qdd, **loads)
            for name, a, b in zip(("dtau_dq", "dtau_dqd", "dtau_dqdd"), ours, ref):
                assert_close(a, b, f"{name} {list(loads)}")
            M = ref[2]
            if model.nv and np.linalg.eigvalsh(M)[0] <= SINGULAR_M * np.abs(M).max():
                with pytest.raises(od.SingularMassMatrixError):
                    od.forward_dynamics_derivatives(model, q, qd, tau, **loads)
                continue
            ours = od.forward_dynamics_derivatives(model, q, qd, tau, **loads)
            ref = P.aba_derivatives(q, qd, tau, **loads)
            for name, a, b in zip(("dqdd_dq", "dqdd_dqd", "dqdd_dtau"), ours, ref):
                assert_close(a, b, f"{name} {list(loads)}")


@pytest.mark.parametrize("floating_base", [False, True], ids=["fixed", "floating"])
@pytest.mark.parametrize("path", URDFS, ids=[Path(p).stem for p in URDFS])
def test_derivatives_match_pinocchio(path, floating_base):
    _check_derivatives(*_load(path, floating_base=floating_base))


@pytest.mark.parametrize("floating_base", [False, True], ids=["fixed", "floating"])
@pytest.mark.parametrize("seed", range(6))
def test_derivatives_match_pinocchio_on_random_trees(tmp_path, seed, floating_base):
    """Seeded random trees: revolute, continuous and prismatic joints, fixed joints inside
    chains, several children per link, massless links."""
    model, P = _load(str(write_random_tree(tmp_path, seed)), floating_base=floating_base)
    _check_derivatives(model, P)


@pytest.mark.parametrize("floating_base", [False, True], ids=["fixed", "floating"])
@pytest.mark.parametrize("seed", range(4))
def test_derivatives_with_coupled_mimic_joints(tmp_path, seed, floating_base):
    """Random trees where up to three joints mimic a joint above them (mult and offset), coupled
    (mimic=True): against Pinocchio's RNEA differentiated (it has no derivatives for them),
    and M^-1 by Cholesky."""
    path = str(write_random_tree(tmp_path, seed, n_mimic=3))
    model, P = _load(path, mimic=True, floating_base=floating_base)
    assert model.coupled or seed == 2  # seed 2 draws no joint pair that can couple
    _check_derivatives(model, P, n_states=1)


@pytest.mark.parametrize("path", MIMIC, ids=[Path(p).stem for p in MIMIC])
def test_derivatives_of_robots_with_mimic_joints(path):
    try:
        model, P = _load(path, mimic=True)
    except (od.URDFError, ValueError) as e:
        pytest.skip(f"not loadable with coupled mimic joints: {e}")
    assert model.coupled
    _check_derivatives(model, P, n_states=1)


# -- central differences of our own functions --------------------------------------------------


def _central(f, n, h):
    E = np.eye(n)
    return np.stack([(f(h * E[k]) - f(-h * E[k])) / (2 * h) for k in range(n)], axis=1)


DIFFERENCED = [("ur5", False), ("panda", False), ("solo12", True), ("talos_reduced", True)]


@pytest.mark.parametrize("name, floating", DIFFERENCED)
def test_derivatives_equal_central_differences_of_our_dynamics(name, floating):
    """In q along od.integrate (the tangent space of a floating base), in qd, qdd and tau:
    agreement to the differences' own error (h = 1e-6: about 1e-7 relative)."""
    model = od.load_urdf(name, floating_base=floating, check_inertia=False)
    rng = np.random.default_rng(5)
    q = od.random_configuration(model, rng)
    qd, qdd, tau = rng.normal(size=(3, model.nv))
    nv, h = model.nv, 1e-6
    zero = np.zeros(nv)

    def tau_at(dq=zero, dqd=zero, dqdd=zero):
        return od.inverse_dynamics(model, od.integrate(model, q, dq, 1.0), qd + dqd, qdd + dqdd)

    def qdd_at(dq=zero, dqd=zero, dtau=zero):
        return od.forward_dynamics(model, od.integrate(model, q, dq, 1.0), qd + dqd, tau + dtau)

    dtau = od.inverse_dynamics_derivatives(model, q, qd, qdd)
    assert_close(dtau[0], _central(lambda e: tau_at(dq=e), nv, h), "dtau_dq", 1e-6)
    assert_close(dtau[1], _central(lambda e: tau_at(dqd=e), nv, h), "dtau_dqd", 1e-6)
    assert_close(dtau[2], _central(lambda e: tau_at(dqdd=e), nv, h), "dtau_dqdd", 1e-6)
    dqdd = od.forward_dynamics_derivatives(model, q, qd, tau)
    assert_close(dqdd[0], _central(lambda e: qdd_at(dq=e), nv, h), "dqdd_dq", 1e-6)
    assert_close(dqdd[1], _central(lambda e: qdd_at(dqd=e), nv, h), "dqdd_dqd", 1e-6)
    assert_close(dqdd[2], _central(lambda e: qdd_at(dtau=e), nv, h), "dqdd_dtau", 1e-6)


# -- identities ---------------------------------------------------------------------------------


def test_identities_on_a_fixed_base():
    """dtau/dqdd = M and dqdd/dtau = M^-1 (full, symmetric); c = qd^T Gamma qd gives
    dtau/dqd = 2 C(q, qd) (Christoffel contraction) at any qdd; at rest dtau/dq = dg/dq is the
    Hessian of the potential energy, symmetric."""
    model = od.load_urdf("panda")
    rng = np.random.default_rng(9)
    q = od.random_configuration(model, rng)
    qd, qdd, tau = rng.normal(size=(3, model.nv))
    dq, dqd, M = od.inverse_dynamics_derivatives(model, q, qd, qdd)
    np.testing.assert_allclose(M, od.mass_matrix(model, q), rtol=0, atol=1e-13)
    np.testing.assert_allclose(dqd, 2 * od.coriolis_matrix(model, q, qd), rtol=0, atol=1e-12)
    _, _, Minv = od.forward_dynamics_derivatives(model, q, qd, tau)
    np.testing.assert_allclose(Minv @ M, np.eye(model.nv), rtol=0, atol=1e-10)
    np.testing.assert_array_equal(Minv, Minv.T)
    zero = np.zeros(model.nv)
    dg, dqd0, _ = od.inverse_dynamics_derivatives(model, q, zero, zero)
    np.testing.assert_allclose(dg, dg.T, rtol=0, atol=1e-12 * np.abs(dg).max())
    assert not dqd0.any()
    assert np.abs(dg).max() > 1.0  # gravity does act


def test_moving_a_floating_robot_changes_its_accelerations_only_through_gravity():
    """The dynamics in the base's own frame do not see where the base is (left invariance):
    without gravity, dqdd/dq of the base's six tangent coordinates is zero; with gravity,
    turning the base turns gravity in its frame, and the angular columns are not."""
    model = od.load_urdf("solo12", floating_base=True)
    rng = np.random.default_rng(2)
    q = od.random_configuration(model, rng)
    qd, tau = rng.normal(size=(2, model.nv))
    dq, _, _ = od.forward_dynamics_derivatives(model, q, qd, tau, gravity=np.zeros(3))
    # moving the whole robot (base pose) changes nothing without gravity: columns 0-5 vanish
    assert np.abs(dq[:, :6]).max() < 1e-9 * max(1.0, np.abs(dq).max())
    dq_g, _, _ = od.forward_dynamics_derivatives(model, q, qd, tau)
    assert np.abs(dq_g[:, :3]).max() > 1e-3  # turning the base turns gravity in its frame


# -- batches, data=, errors ---------------------------------------------------------------------


@pytest.mark.parametrize("name, floating", [("ur5", False), ("solo12", True)])
def test_batches_equal_single_calls(name, floating):
    model = od.load_urdf(name, floating_base=floating)
    rng = np.random.default_rng(4)
    n = 150  # several threads
    q = np.stack([od.random_configuration(model, rng) for _ in range(n)])
    qd, qdd = rng.normal(size=(2, n, model.nv))
    frame = model.frame_names[-1]
    F = rng.normal(size=(n, 6))
    for fn in (od.inverse_dynamics_derivatives, od.forward_dynamics_derivatives):
        batch = fn(model, q, qd, qdd, f_tip={frame: F})
        assert all(x.shape == (n, model.nv, model.nv) for x in batch)
        for i in (0, 77, n - 1):
            single = fn(model, q[i], qd[i], qdd[i], f_tip={frame: F[i]})
            for a, b in zip(batch, single):
                np.testing.assert_array_equal(a[i], b)


@pytest.mark.parametrize("name, floating", [("ur5", False), ("solo12", True)])
def test_data_holds_the_results_and_equals_fresh_calls(name, floating):
    model = od.load_urdf(name, floating_base=floating)
    data = model.data()
    rng = np.random.default_rng(6)
    for _ in range(2):
        q = od.random_configuration(model, rng)
        qd, qdd = rng.normal(size=(2, model.nv))
        held = od.inverse_dynamics_derivatives(model, q, qd, qdd, data=data)
        assert held[0] is data.dtau_dq and held[1] is data.dtau_dqd and held[2] is data.M
        for a, b in zip(held, od.inverse_dynamics_derivatives(model, q, qd, qdd)):
            np.testing.assert_array_equal(a, b)
        held = od.forward_dynamics_derivatives(model, q, qd, qdd, data=data)
        assert held[0] is data.ddq_dq and held[1] is data.ddq_dqd and held[2] is data.Minv
        for a, b in zip(held, od.forward_dynamics_derivatives(model, q, qd, qdd)):
            np.testing.assert_array_equal(a, b)
        # qdd = M^-1 (tau - h) there, where forward_dynamics runs ABA: equal to rounding
        assert_close(data.qdd, od.forward_dynamics(model, q, qd, qdd), "data.qdd", rtol=1e-12)


def test_bad_arguments_are_named():
    model = od.load_urdf("ur5")
    q, v = np.zeros(model.nq), np.zeros(model.nv)
    with pytest.raises(ValueError, match="qdd must have shape"):
        od.inverse_dynamics_derivatives(model, q, v, np.zeros(3))
    with pytest.raises(ValueError, match="tau must have shape"):
        od.forward_dynamics_derivatives(model, q, v, np.zeros(7))
    with pytest.raises(ValueError, match="qd must be finite"):
        od.inverse_dynamics_derivatives(model, q, np.full(model.nv, np.nan), v)
    with pytest.raises(ValueError, match="tau must be finite"):
        od.forward_dynamics_derivatives(model, q, v, np.full(model.nv, np.inf))
    with pytest.raises(TypeError, match="model must be an opendyn Model"):
        od.forward_dynamics_derivatives("ur5", q, v, v)
    with pytest.raises(ValueError, match="made for model"):
        od.inverse_dynamics_derivatives(model, q, v, v, data=od.load_urdf("panda").data())
    with pytest.raises(KeyError):
        od.inverse_dynamics_derivatives(model, q, v, v, f_tip={"no_such_frame": np.zeros(6)})


def test_a_singular_mass_matrix_is_refused_naming_the_joint(tmp_path):
    from test_verify import MASSLESS_TIP_URDF

    path = tmp_path / "massless_tip.urdf"
    path.write_text(MASSLESS_TIP_URDF)
    model = od.load_urdf(path)
    v = np.zeros(model.nv)
    with pytest.raises(od.SingularMassMatrixError, match="forward_dynamics_derivatives"):
        od.forward_dynamics_derivatives(model, np.zeros(model.nq), v, v)
    # inverse dynamics has an answer: its M is singular, not wrong
    _, _, M = od.inverse_dynamics_derivatives(model, np.zeros(model.nq), v, v)
    assert not M[-1].any()


def test_importing_opendyn_compiles_none_of_the_derivative_kernels():
    """They compile (or load from the cache) on their first call, never at import: the cold
    start of everything else is unchanged."""
    import json
    import subprocess
    import sys

    code = (
        "import opendyn, json\n"
        "from opendyn.algorithm import aba_derivatives, minverse, rnea_derivatives\n"
        "modules = (aba_derivatives, minverse, rnea_derivatives)\n"
        "kernels = [getattr(m, n) for m in modules for n in dir(m)\n"
        "           if hasattr(getattr(m, n), 'signatures')]\n"
        "print(json.dumps({k.__name__: len(k.signatures) for k in kernels}))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    signatures = json.loads(out.stdout)
    assert "rnea_derivatives_kernel" in signatures and "inverse_mass_matrix_kernel" in signatures
    assert not any(signatures.values()), signatures
