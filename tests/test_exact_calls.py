"""The common call of a public dynamics function hands float64 vectors of the model's sizes to
its kernel's exact twin (opendyn._runtime.entry), which runs only what the kernel has compiled.
Any other argument (float32, a read-only or strided array, a list, a wrong length) takes the
checked path: the same numbers, or the same clear error, and never a second compiled version of
the kernel."""

from __future__ import annotations

import numpy as np
import pytest
from numba import njit

import opendyn as od
from opendyn._runtime.entry import exact, learn
from opendyn._runtime.status import Status
from opendyn.algorithm import aba_derivatives, crba, forward, kinematics, rnea, rnea_derivatives

FRAME = "tool0"
# (function, its kernel, a call with the state (q, v, a))
CALLS = (
    ("inverse_dynamics", rnea.rnea_kernel, lambda m, q, v, a: od.inverse_dynamics(m, q, v, a)),
    ("mass_matrix", crba.crba_kernel, lambda m, q, v, a: od.mass_matrix(m, q)),
    (
        "forward_dynamics",
        forward.forward_kernel,
        lambda m, q, v, a: od.forward_dynamics(m, q, v, a),
    ),
    ("frame_pose", kinematics.frame_pose_kernel, lambda m, q, v, a: od.frame_pose(m, q, FRAME)),
    ("jacobian", kinematics.jacobian_kernel, lambda m, q, v, a: od.jacobian(m, q, FRAME)),
    (
        "inverse_dynamics_derivatives",
        rnea_derivatives.rnea_derivatives_kernel,
        lambda m, q, v, a: od.inverse_dynamics_derivatives(m, q, v, a),
    ),
    (
        "forward_dynamics_derivatives",
        aba_derivatives.aba_derivatives_kernel,
        lambda m, q, v, a: od.forward_dynamics_derivatives(m, q, v, a),
    ),
)


def _read_only(x):
    x = x.copy()
    x.flags.writeable = False
    return x


def _strided(x):
    wide = np.zeros(2 * x.size)
    wide[::2] = x
    return wide[::2]


# each a different numba type from a writeable float64 C-contiguous vector, same values
VARIANTS = {
    "float32": lambda x: x.astype(np.float32),
    "read-only": _read_only,
    "strided": _strided,
    "list": lambda x: x.tolist(),
}


@pytest.fixture(scope="module")
def ur5_state():
    model = od.load_urdf("ur5")
    rng = np.random.default_rng(7)
    # values a float32 holds exactly, so that every variant carries the same numbers
    q = od.random_configuration(model, rng).astype(np.float32).astype(np.float64)
    v, a = rng.uniform(-1, 1, (2, model.nv)).astype(np.float32).astype(np.float64)
    return model, q, v, a


@pytest.mark.parametrize("name, kernel, call", CALLS, ids=[c[0] for c in CALLS])
def test_other_argument_types_give_the_same_numbers_and_compile_nothing_new(
    ur5_state, name, kernel, call
):
    model, q, v, a = ur5_state
    expected = call(model, q, v, a)
    call(model, q, v, a)  # the twin has learnt the kernel's version
    versions = len(kernel.signatures)
    for variant, convert in VARIANTS.items():
        got = call(model, convert(q), convert(v), convert(a))
        for x, y in zip(np.atleast_1d(got), np.atleast_1d(expected)):
            np.testing.assert_array_equal(x, y, err_msg=f"{name} with {variant} arguments")
    assert len(kernel.signatures) == versions, f"{name} compiled another version of its kernel"


@pytest.mark.parametrize("name, kernel, call", CALLS, ids=[c[0] for c in CALLS])
def test_a_wrong_length_on_the_common_call_is_the_clear_error(ur5_state, name, kernel, call):
    model, q, v, a = ur5_state
    call(model, q, v, a)
    with pytest.raises(ValueError, match=r"q must have shape \(6,\) or \(N, 6\)"):
        call(model, q[:5], v, a)
    with pytest.raises(ValueError, match=r"q must have shape \(6,\) or \(N, 6\)"):
        call(model, np.append(q, 0.0), v, a)
    if name not in ("mass_matrix", "frame_pose", "jacobian"):
        second = "tau" if name.startswith("forward") else "qd"
        with pytest.raises(ValueError, match=rf"{second} must have shape \(6,\)"):
            call(model, q, v, a[:5]) if second == "tau" else call(model, q, v[:5], a)


def test_the_twin_runs_only_what_its_kernel_compiled_and_never_compiles():
    @njit
    def twice(x, out):
        out[0] = 2.0 * x[0]
        return 0

    twin = exact(twice)
    x, out = np.array([1.5]), np.zeros(1)
    with pytest.raises(TypeError):  # the kernel has compiled nothing yet
        twin(x, out)
    assert twice(x, out) == 0
    assert learn(twin, twice) == Status.CONVERT
    assert twin(x, out) == 0 and out[0] == 3.0
    with pytest.raises(TypeError):  # float32 would compile a new version: refused
        twin(x.astype(np.float32), out)
    assert len(twin.signatures) == len(twice.signatures) == 1
