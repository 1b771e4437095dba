"""Centre of mass and centroidal dynamics (opendyn.algorithm.centroidal), against Pinocchio
(centerOfMass, jacobianCenterOfMass, ccrba, computeCentroidalMomentum, dccrba: the conversions
are opendyn.verify's oracle's) on every example-robot-data URDF it loads, fixed and floating,
and on seeded random trees, to 1e-9 relative; and against physics: a robot in free fall changes
its centroidal momentum at exactly (0, M g), and the momentum's rate along a path equals
A_G qdd + Adot_G qd by central differences.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import opendyn as od

pytest.importorskip("pinocchio")
from randtree import write_random_tree
from test_pinocchio import URDFS, _load, _states, assert_close


def _check_centroidal(model, P):
    if not np.sum(model.mass) > 0:
        with pytest.raises(ValueError, match="no moving mass"):
            od.center_of_mass(model, od.neutral(model))
        return
    for q, (qd, _, _) in _states(model, 5):
        assert_close(od.center_of_mass(model, q), P.center_of_mass(q), "center_of_mass")
        assert_close(
            od.center_of_mass_jacobian(model, q),
            P.center_of_mass_jacobian(q),
            "center_of_mass_jacobian",
        )
        assert_close(
            od.centroidal_momentum_matrix(model, q),
            P.centroidal_momentum_matrix(q),
            "centroidal_momentum_matrix",
        )
        assert_close(
            od.centroidal_momentum(model, q, qd),
            P.centroidal_momentum(q, qd),
            "centroidal_momentum",
        )
        assert_close(
            od.centroidal_momentum_rate_bias(model, q, qd),
            P.centroidal_momentum_rate_bias(q, qd),
            "centroidal_momentum_rate_bias",
        )


@pytest.mark.parametrize("floating_base", [False, True], ids=["fixed", "floating"])
@pytest.mark.parametrize("path", URDFS, ids=[Path(p).stem for p in URDFS])
def test_centroidal_functions_match_pinocchio(path, floating_base):
    _check_centroidal(*_load(path, floating_base=floating_base))


@pytest.mark.parametrize("floating_base", [False, True], ids=["fixed", "floating"])
@pytest.mark.parametrize("seed", range(4))
def test_centroidal_functions_match_pinocchio_on_random_trees(tmp_path, seed, floating_base):
    path = str(write_random_tree(tmp_path, seed))
    _check_centroidal(*_load(path, floating_base=floating_base))


FLOATING = ["solo12", "ur5", "panda"]


@pytest.mark.parametrize("robot", FLOATING)
def test_free_fall_changes_the_centroidal_momentum_by_gravity_alone(robot):
    """With no torques and no contact, the only external wrench is gravity, through the centre
    of mass: dh_G/dt = A_G qdd + Adot_G qd = (0, M g), whatever the joints do."""
    model = od.load_urdf(robot, floating_base=True)
    rng = np.random.default_rng(3)
    M = float(np.sum(model.mass))
    for _ in range(3):
        q = od.random_configuration(model, rng)
        qd = rng.normal(size=model.nv)
        qdd = od.forward_dynamics(model, q, qd, np.zeros(model.nv))
        rate = od.centroidal_momentum_matrix(model, q) @ qdd + od.centroidal_momentum_rate_bias(
            model, q, qd
        )
        assert_close(rate, np.r_[0.0, 0.0, 0.0, M * model.gravity], "dh_G/dt in free fall")


def _on_path(model, q0, v, a, t):
    """(q(t), qd(t)) on the path q0 (+) (t v + t^2 a / 2)."""
    return od.integrate(model, q0, t * v + 0.5 * t * t * a, 1.0), v + t * a


@pytest.mark.parametrize("robot", ["ur5", "solo12"])
@pytest.mark.parametrize("floating_base", [False, True], ids=["fixed", "floating"])
def test_momentum_rate_is_the_derivative_of_the_momentum_along_a_path(robot, floating_base):
    """Along q(t) = q0 (+) (t v + t^2 a / 2), whose velocity is v + t a (+ O(t^2), even in t,
    for a floating base) and acceleration a at t = 0: the central difference of h_G(q(t), qd(t))
    is A_G a + Adot_G v, and that of c(q(t)) is J_c v, to the difference's O(eps^2)."""
    model = od.load_urdf(robot, floating_base=floating_base)
    rng = np.random.default_rng(5)
    eps = 1e-5
    for _ in range(3):
        q0 = od.random_configuration(model, rng)
        v, a = rng.normal(size=(2, model.nv))

        h_plus = od.centroidal_momentum(model, *_on_path(model, q0, v, a, eps))
        h_minus = od.centroidal_momentum(model, *_on_path(model, q0, v, a, -eps))
        rate = od.centroidal_momentum_matrix(model, q0) @ a + od.centroidal_momentum_rate_bias(
            model, q0, v
        )
        scale = np.abs(rate).max()
        assert np.abs((h_plus - h_minus) / (2 * eps) - rate).max() <= 1e-6 * scale
        q_plus, q_minus = (_on_path(model, q0, v, a, t)[0] for t in (eps, -eps))
        c_dot = (od.center_of_mass(model, q_plus) - od.center_of_mass(model, q_minus)) / (2 * eps)
        J_c = od.center_of_mass_jacobian(model, q0)
        assert np.abs(c_dot - J_c @ v).max() <= 1e-6 * np.abs(J_c @ v).max()
        h_G = od.centroidal_momentum(model, q0, v)
        assert_close(od.centroidal_momentum_matrix(model, q0) @ v, h_G, "h_G = A_G qd")
        assert_close(h_G[3:], np.sum(model.mass) * J_c @ v, "l_G = M c_dot")


def test_batches_are_the_single_states_stacked():
    """A batch (N, ...) runs over the cores (N = 300 makes several slices) and gives each
    state's single result."""
    model = od.load_urdf("solo12", floating_base=True)
    rng = np.random.default_rng(2)
    n = 300
    q = np.array([od.random_configuration(model, rng) for _ in range(n)])
    qd = rng.normal(size=(n, model.nv))
    calls = [
        (od.center_of_mass, (q,)),
        (od.center_of_mass_jacobian, (q,)),
        (od.centroidal_momentum_matrix, (q,)),
        (od.centroidal_momentum, (q, qd)),
        (od.centroidal_momentum_rate_bias, (q, qd)),
    ]
    for fn, args in calls:
        batch = fn(model, *args)
        for k in (0, 137, n - 1):
            np.testing.assert_array_equal(batch[k], fn(model, *(x[k] for x in args)))


def test_bad_arguments_are_clear_errors_naming_them():
    model = od.load_urdf("solo12", floating_base=True)
    q, qd = od.neutral(model), np.zeros(model.nv)
    with pytest.raises(TypeError, match="model must be an opendyn Model"):
        od.center_of_mass("solo12", q)
    with pytest.raises(ValueError, match=r"q must have shape \(19,\)"):
        od.centroidal_momentum_matrix(model, q[:-1])
    with pytest.raises(ValueError, match=r"qd must have shape \(18,\)"):
        od.centroidal_momentum(model, q, qd[:-1])
    with pytest.raises(ValueError, match="qd must be finite"):
        od.centroidal_momentum_rate_bias(model, q, np.full(model.nv, np.nan))
    with pytest.raises(ValueError, match="quaternion"):
        od.center_of_mass_jacobian(model, np.r_[q[:3], 2 * q[3:7], q[7:]])
    with pytest.raises(TypeError, match="q must be an array of numbers"):
        od.center_of_mass(model, ["a"] * model.nq)
    with pytest.raises(ValueError, match="state 1 of the batch"):
        od.center_of_mass(model, np.array([q, np.full(model.nq, np.inf)]))


def test_a_robot_without_moving_mass_has_no_centre_of_mass(tmp_path):
    urdf = tmp_path / "massless.urdf"
    urdf.write_text(
        '<robot name="massless"><link name="base"/><link name="arm"/>'
        '<joint name="j" type="revolute"><parent link="base"/><child link="arm"/>'
        '<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
        "</robot>"
    )
    model = od.load_urdf(str(urdf))
    for fn in (od.center_of_mass, od.center_of_mass_jacobian, od.centroidal_momentum_matrix):
        with pytest.raises(ValueError, match="'massless' has no moving mass"):
            fn(model, np.zeros(1))


def test_importing_opendyn_compiles_none_of_these_kernels():
    """The kernels compile (or load from the cache) on their first call, never at import."""
    code = (
        "import opendyn, json\n"
        "from opendyn.algorithm import centroidal, regressor\n"
        "kernels = [getattr(centroidal, n) for n in dir(centroidal) if n.endswith('_kernel')]\n"
        "kernels += [regressor.regressor_kernel, regressor.regressor_batch_kernel]\n"
        "print(json.dumps({k.__name__: len(k.signatures) for k in kernels}))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    signatures = json.loads(out.stdout)
    assert len(signatures) == 11 and not any(signatures.values()), signatures


def test_the_momentum_is_returned_where_only_its_rate_would_overflow():
    """h_G is linear in qd, Adot_G qd quadratic: at qd ~ 1e200 the first is finite, the second
    is not, and only the second is refused."""
    model = od.load_urdf("ur5")
    q, qd = np.zeros(6), np.full(6, 1e200)
    h_G = od.centroidal_momentum(model, q, qd)
    assert np.all(np.isfinite(h_G)) and np.abs(h_G).max() > 1e199
    with pytest.raises(od.NonFiniteResultError, match="Adot_G qd"):
        od.centroidal_momentum_rate_bias(model, q, qd)
