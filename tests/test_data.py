"""Data: the work arrays of a model's evaluations. A call with data= returns the array the Data
holds for that quantity, equal to a fresh call's answer, and allocates nothing; one Data serves
call after call; a Data of another model, or with a batch, is refused naming the argument."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys

import numpy as np
import pytest

import opendyn as od
from opendyn.multibody.data import PUBLIC_FIELDS, WORK_AT, WORK_FIELDS

ROBOTS = (("ur5", False), ("panda", False), ("solo12", True))

# (function, the Data field it returns, a call with the state (q, qd, qdd) and a frame)
CALLS = (
    (
        "inverse_dynamics",
        "tau",
        lambda m, q, qd, qdd, f, **kw: od.inverse_dynamics(m, q, qd, qdd, **kw),
    ),
    ("gravity_forces", "g", lambda m, q, qd, qdd, f, **kw: od.gravity_forces(m, q, **kw)),
    ("coriolis_forces", "c", lambda m, q, qd, qdd, f, **kw: od.coriolis_forces(m, q, qd, **kw)),
    ("bias_forces", "h", lambda m, q, qd, qdd, f, **kw: od.bias_forces(m, q, qd, **kw)),
    ("mass_matrix", "M", lambda m, q, qd, qdd, f, **kw: od.mass_matrix(m, q, **kw)),
    (
        "forward_dynamics",
        "qdd",
        lambda m, q, qd, qdd, f, **kw: od.forward_dynamics(m, q, qd, qdd, **kw),
    ),
    (
        "forward_dynamics crba",
        "qdd",
        lambda m, q, qd, qdd, f, **kw: od.forward_dynamics(m, q, qd, qdd, method="crba", **kw),
    ),
    (
        "forward_dynamics newton_euler",
        "qdd",
        lambda m, q, qd, qdd, f, **kw: od.forward_dynamics(
            m, q, qd, qdd, method="newton_euler", **kw
        ),
    ),
    (
        "coriolis_matrix",
        "C",
        lambda m, q, qd, qdd, f, **kw: od.coriolis_matrix(m, q, qd, **kw),
    ),
    (
        "christoffel_symbols",
        "Gamma",
        lambda m, q, qd, qdd, f, **kw: od.christoffel_symbols(m, q, **kw),
    ),
    ("frame_pose", "T_sf", lambda m, q, qd, qdd, f, **kw: od.frame_pose(m, q, f, **kw)),
    ("jacobian space", "J", lambda m, q, qd, qdd, f, **kw: od.jacobian(m, q, f, **kw)),
    (
        "jacobian body",
        "J",
        lambda m, q, qd, qdd, f, **kw: od.jacobian(m, q, f, expressed_in="body", **kw),
    ),
    ("center_of_mass", "com", lambda m, q, qd, qdd, f, **kw: od.center_of_mass(m, q, **kw)),
    (
        "center_of_mass_jacobian",
        "J_c",
        lambda m, q, qd, qdd, f, **kw: od.center_of_mass_jacobian(m, q, **kw),
    ),
    (
        "centroidal_momentum_matrix",
        "A_G",
        lambda m, q, qd, qdd, f, **kw: od.centroidal_momentum_matrix(m, q, **kw),
    ),
    (
        "centroidal_momentum",
        "h_G",
        lambda m, q, qd, qdd, f, **kw: od.centroidal_momentum(m, q, qd, **kw),
    ),
    (
        "centroidal_momentum_rate_bias",
        "Adot_G_qd",
        lambda m, q, qd, qdd, f, **kw: od.centroidal_momentum_rate_bias(m, q, qd, **kw),
    ),
)


def _states(model, rng, n=2):
    return [
        (od.random_configuration(model, rng), *rng.uniform(-1, 1, (2, model.nv)))
        for _ in range(n)
    ]


@pytest.fixture(scope="module", params=ROBOTS, ids=lambda r: r[0] + ("_floating" if r[1] else ""))
def robot(request):
    name, floating = request.param
    return od.load_urdf(name, floating_base=floating, check_inertia=False)


@pytest.mark.parametrize("name, field, call", CALLS, ids=[c[0] for c in CALLS])
def test_a_call_with_data_returns_the_datas_array_equal_to_a_fresh_call(robot, name, field, call):
    """Two calls with one Data at two states: each returns the Data's own array, holding what a
    call without data= answers at that state (the second call overwrites the first)."""
    rng = np.random.default_rng(7)
    frame = robot.frame_names[-1]
    data = od.Data(robot)
    for q, qd, qdd in _states(robot, rng):
        fresh = call(robot, q, qd, qdd, frame)
        held = call(robot, q, qd, qdd, frame, data=data)
        assert held is getattr(data, field)
        np.testing.assert_array_equal(held, fresh)
        assert not np.shares_memory(fresh, data._work)


def test_energies_with_data_equal_fresh_calls_and_are_left_in_data_energy(robot):
    rng = np.random.default_rng(11)
    data = robot.data()
    for q, qd, _ in _states(robot, rng):
        K = od.kinetic_energy(robot, q, qd, data=data)
        assert K == od.kinetic_energy(robot, q, qd) and data.energy[0] == K
        U = od.potential_energy(robot, q, data=data)
        assert U == od.potential_energy(robot, q) and data.energy[1] == U


def test_model_data_and_od_data_are_the_same_kind_of_object(robot):
    data = robot.data()
    assert isinstance(data, od.Data) and data.model is robot
    assert data.M.shape == (robot.nv, robot.nv) and data.J.shape == (6, robot.nv)
    assert data.V.shape == (robot.nb, 6) and data.R.shape == (robot.nb, 3, 3)
    assert data.T_sf.shape == (4, 4)


def test_the_datas_fields_hold_the_last_evaluations_kinematics(robot):
    """After inverse_dynamics with data=, data.V is each body's twist: V_i = J_b(body i) qd,
    the body Jacobian of the body's frame (its link) times the velocities."""
    rng = np.random.default_rng(3)
    q, qd, qdd = _states(robot, rng, 1)[0]
    data = robot.data()
    od.inverse_dynamics(robot, q, qd, qdd, data=data)
    for i, link in enumerate(robot.body_names):
        J_b = od.jacobian(robot, q, link, expressed_in="body")
        np.testing.assert_allclose(data.V[i], J_b @ qd, rtol=1e-12, atol=1e-12)


def test_fields_do_not_overlap_and_cover_the_work_buffer(robot):
    """Every field of WORK_FIELDS is its own slice of the one buffer: no two share memory, and
    together they are the whole buffer."""
    data = robot.data()
    views = [getattr(data, name) for name, _, _ in WORK_FIELDS]
    assert sum(v.size for v in views) == data._work.size
    for a in range(len(views)):
        assert np.shares_memory(views[a], data._work)
        for b in range(a + 1, len(views)):
            assert not np.shares_memory(views[a], views[b]), (WORK_FIELDS[a], WORK_FIELDS[b])


def test_per_body_fields_are_placed_by_nb_alone():
    """The kernels find per-body fields without nv (multibody.data.body_field)."""
    for name, _, unit in WORK_FIELDS:
        start, size = WORK_AT[name]
        if unit == "nb":
            assert start.per_nv == start.per_nv2 == start.fixed == 0, name
            assert size.per_nv == size.per_nv2 == size.fixed == 0, name


def test_public_fields_are_documented():
    """The Data docstring (the module's) names every field a user reads."""
    documented = set()
    for line in sys.modules["opendyn.multibody.data"].__doc__.splitlines():
        if line.startswith("  ") and not line.startswith("   ") and "(" in line:
            documented.update(re.findall(r"[A-Za-z_]\w*", line[: line.index("(")]))
    assert set(PUBLIC_FIELDS) <= documented, set(PUBLIC_FIELDS) - documented


def test_a_data_of_another_model_is_refused_naming_it(robot):
    other = od.load_urdf("double_pendulum")
    q = od.neutral(robot)
    with pytest.raises(ValueError, match="data was made for model 'double_pendulum'"):
        od.mass_matrix(robot, q, data=other.data())
    with pytest.raises(TypeError, match="data must be an opendyn Data"):
        od.mass_matrix(robot, q, data={"M": None})


def test_a_data_of_another_load_of_the_same_robot_is_refused_saying_so():
    """Two loads of one URDF are two models of the same name and size: the message says the
    data is another load's, not "made for 'double_pendulum', not for 'double_pendulum'"."""
    model, again = od.load_urdf("double_pendulum"), od.load_urdf("double_pendulum")
    with pytest.raises(ValueError) as e:
        od.mass_matrix(model, od.neutral(model), data=again.data())
    text = str(e.value)
    assert "another load of 'double_pendulum'" in text and "model.data()" in text
    assert "not for this model" not in text


def test_data_with_a_batch_is_refused(robot):
    q = np.array([od.neutral(robot)] * 3)
    with pytest.raises(ValueError, match="data= works for a single state"):
        od.mass_matrix(robot, q, data=robot.data())
    with pytest.raises(ValueError, match="data= works for a single state"):
        od.inverse_dynamics(robot, q, np.zeros((3, robot.nv)), np.zeros((3, robot.nv)),
                            data=robot.data())


def test_a_bad_state_with_data_is_the_same_clear_error(robot):
    q = od.neutral(robot)
    q[-1] = np.nan
    with pytest.raises(ValueError, match="q must be finite"):
        od.inverse_dynamics(robot, q, np.zeros(robot.nv), np.zeros(robot.nv), data=robot.data())


# Counts, in a fresh process with numba's allocation statistics on, the arrays that each call
# makes: in numpy (its tracemalloc domain), and inside the compiled kernel that the call runs
# (numba's runtime: the kernel repeated in a compiled loop, so that the arrays Python passes in,
# which numba wraps once per call, are not counted).
_ALLOCATIONS = r"""
import json, sys, tracemalloc
import numpy as np
from numba import njit
from numba.core.runtime import rtsys
import opendyn as od
from opendyn.algorithm import aba_derivatives, centroidal, christoffel, crba, energy, forward
from opendyn.algorithm import kinematics
from opendyn.algorithm import rnea, rnea_derivatives, task_space

model = od.load_urdf(sys.argv[1], floating_base=sys.argv[2] == "1", check_inertia=False)
rng = np.random.default_rng(0)
q = od.random_configuration(model, rng)
qd, qdd = rng.uniform(-1, 1, (2, model.nv))
frame = model.frames[model.frame_index(model.frame_names[-1])]
data = od.Data(model)
buffers = (model._ibuf, model._fbuf, data._work)
# (public call, the kernel it runs and that kernel's arguments)
calls = {
    "inverse_dynamics": (
        lambda **kw: od.inverse_dynamics(model, q, qd, qdd, **kw),
        rnea.rnea_kernel, (*buffers, q, qd, qdd, model._loads, data.tau),
    ),
    "bias_forces": (
        lambda **kw: od.bias_forces(model, q, qd, **kw),
        rnea.rnea_kernel, (*buffers, q, qd, model._zero_v, model._loads, data.h),
    ),
    "mass_matrix": (lambda **kw: od.mass_matrix(model, q, **kw), crba.crba_kernel,
                    (*buffers, q, data.M)),
}
for method in forward.METHODS:
    calls["forward_dynamics " + method] = (
        lambda method=method, **kw: od.forward_dynamics(model, q, qd, qdd, method=method, **kw),
        forward.forward_kernel,
        (*buffers, q, qd, qdd, model._loads, forward.NO_ARMATURE,
         forward.method_switches(model, method), data.qdd),
    )
calls["coriolis_matrix"] = (
    lambda **kw: od.coriolis_matrix(model, q, qd, **kw),
    christoffel.coriolis_matrix_kernel, (*buffers, q, qd, data.C),
)
calls["christoffel_symbols"] = (
    lambda **kw: od.christoffel_symbols(model, q, **kw),
    christoffel.christoffel_kernel, (*buffers, q, data._C_e, data.Gamma),
)
calls["kinetic_energy"] = (  # a float: nothing for numpy to keep either way
    lambda **kw: od.kinetic_energy(model, q, qd, **kw),
    energy.energy_kernel, (*buffers, q, qd, model._gravity, data.energy),
)
calls["frame_pose"] = (
    lambda **kw: od.frame_pose(model, q, frame.name, **kw),
    kinematics.frame_pose_kernel, (*buffers, q, frame.body, frame.T_body_frame, data.T_sf),
)
calls["jacobian"] = (
    lambda **kw: od.jacobian(model, q, frame.name, expressed_in="body", **kw),
    kinematics.jacobian_kernel, (*buffers, q, (frame.body, frame.T_body_frame), True, data.J),
)
calls["inverse_dynamics_derivatives"] = (
    lambda **kw: od.inverse_dynamics_derivatives(model, q, qd, qdd, **kw),
    rnea_derivatives.rnea_derivatives_kernel,
    (*buffers, (q, qd, qdd), model._loads, data.dtau_dq, data.dtau_dqd, data.M),
)
calls["forward_dynamics_derivatives"] = (
    lambda **kw: od.forward_dynamics_derivatives(model, q, qd, qdd, **kw),
    aba_derivatives.aba_derivatives_kernel,
    (*buffers, (q, qd, qdd), model._loads, forward.NO_ARMATURE,
     aba_derivatives.coupled_switch(model), data.ddq_dq, data.ddq_dqd, data.Minv),
)
link = model.frames[model.frame_index(model.body_names[-1])]  # moves in six directions
calls["task_space_mass_matrix"] = (
    lambda **kw: od.task_space_mass_matrix(model, q, link.name, damping=0.01, **kw),
    task_space.task_space_kernel,
    (*buffers, q, (link.body, link.T_body_frame), 0.01, data.Lambda),
)
calls["task_space_bias"] = (
    lambda **kw: od.task_space_bias(model, q, qd, link.name, **kw),
    task_space.task_space_bias_kernel,
    (*buffers, (q, qd), (link.body, link.T_body_frame), model._loads, data.eta),
)
calls["center_of_mass"] = (
    lambda **kw: od.center_of_mass(model, q, **kw),
    centroidal.center_of_mass_kernel, (*buffers, q, data.com),
)
calls["center_of_mass_jacobian"] = (
    lambda **kw: od.center_of_mass_jacobian(model, q, **kw),
    centroidal.center_of_mass_jacobian_kernel, (*buffers, q, data.J_c),
)
calls["centroidal_momentum_matrix"] = (
    lambda **kw: od.centroidal_momentum_matrix(model, q, **kw),
    centroidal.momentum_matrix_kernel, (*buffers, q, data.A_G),
)
for rate, name in ((False, "centroidal_momentum"), (True, "centroidal_momentum_rate_bias")):
    calls[name] = (
        lambda name=name, **kw: getattr(od, name)(model, q, qd, **kw),
        centroidal.centroidal_momentum_kernel,
        (*buffers, q, qd, rate, data._momentum),
    )
calls["frame_acceleration"] = (
    lambda **kw: od.frame_acceleration(model, q, qd, qdd, link.name, **kw),
    task_space.frame_acceleration_kernel,
    (*buffers, (q, qd, qdd), (link.body, link.T_body_frame), data.dV_f),
)


@njit
def repeat(kernel, args, n):
    for _ in range(n):
        kernel(*args)


def kernel_arrays(kernel, args):
    repeat(kernel, args, 1)  # compiled
    counts = []
    for n in (1, 11):
        before = rtsys.get_allocation_stats().alloc
        repeat(kernel, args, n)
        counts.append(rtsys.get_allocation_stats().alloc - before)
    return (counts[1] - counts[0]) // 10


def numpy_arrays(call, kw):
    call(**kw)  # compiled and warm
    tracemalloc.start()
    kept = [call(**kw) for _ in range(10)]  # alive at the snapshot, so that it sees them
    snapshot = tracemalloc.take_snapshot().filter_traces(
        [tracemalloc.DomainFilter(True, np.lib.tracemalloc_domain)]
    )
    tracemalloc.stop()
    del kept
    return sum(stat.count for stat in snapshot.statistics("filename"))


out = {}
for name, (call, kernel, args) in calls.items():
    out[name] = {
        "kernel": kernel_arrays(kernel, args),
        "numpy with data": numpy_arrays(call, {"data": data}),
        "numpy without": numpy_arrays(call, {}),
    }
print(json.dumps(out))
"""


@pytest.mark.parametrize("name, floating", [("ur5", False), ("solo12", True)])
def test_a_call_with_data_allocates_nothing(name, floating):
    """With data=, a call makes no array: none that numpy still holds after the call (it
    returns the Data's), none in the compiled kernel it runs (numba's exact count). Without
    data=, numpy counts each call's result (so the counter does see arrays)."""
    env = dict(os.environ, NUMBA_NRT_STATS="1")
    proc = subprocess.run(
        [sys.executable, "-c", _ALLOCATIONS, name, "1" if floating else "0"],
        env=env, capture_output=True, text=True, timeout=900,
    )
    assert proc.returncode == 0, proc.stderr
    counts = json.loads(proc.stdout.strip().splitlines()[-1])
    assert len(counts) == 21
    for call, count in counts.items():
        assert count["kernel"] == 0 and count["numpy with data"] == 0, (call, count)
        if call != "kinetic_energy":
            assert count["numpy without"] >= 10, (call, count)
