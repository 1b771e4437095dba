"""Data with the task-space and constraint functions: a call with data= returns the array the
Data holds for its result (a field, or data.constraint_rows(k) for a result of k constraint
rows), equal to a fresh call's answer; one Data serves call after call; a Data of another
model, or with a batch, is refused as by every data= call. (That the task-space calls allocate
nothing is measured with the others in test_data.py.)"""

from __future__ import annotations

import numpy as np
import pytest

import opendyn as od

# (robot, its task frame, constraints of several kinds on it)
ROBOTS = {
    "ur5": (
        "tool0",
        [
            od.PointToWorld("tool0"),
            od.PointOnPlane("wrist_2_link", (0.2, -1.0, 0.5), (0.05, 0.0, 0.1)),
            od.FixedPose("base_link", "tool0"),
        ],
    ),
    "panda": (
        "panda_hand",
        [od.PointToWorld("panda_hand"), od.PointOnPlane("panda_link4", (0.0, 0.0, 1.0))],
    ),
}


def _A(m, q, cs):
    """A at q (at its first state for a batch: the calls refuse the batch, not A)."""
    return od.constraint_jacobian(m, np.atleast_2d(q)[0], cs)


def _lam(m, q, cs):
    return np.linspace(-1.0, 2.0, len(_A(m, q, cs)))


# (function, the array the Data holds for it: held(data, k), a call at the state (q, qd, qdd)
# with the robot's frame and constraints)
CALLS = (
    (
        "task_space_mass_matrix",
        lambda d, k: d.Lambda,
        lambda m, s, f, cs, **kw: od.task_space_mass_matrix(m, s[0], f, **kw),
    ),
    (
        "task_space_mass_matrix damped",
        lambda d, k: d.Lambda,
        lambda m, s, f, cs, **kw: od.task_space_mass_matrix(m, s[0], f, damping=0.01, **kw),
    ),
    (
        "task_space_bias",
        lambda d, k: d.eta,
        lambda m, s, f, cs, **kw: od.task_space_bias(m, s[0], s[1], f, **kw),
    ),
    (
        "frame_acceleration",
        lambda d, k: d.dV_f,
        lambda m, s, f, cs, **kw: od.frame_acceleration(m, *s, f, **kw),
    ),
    (
        "constraint_jacobian",
        lambda d, k: d.constraint_rows(k).A,
        lambda m, s, f, cs, **kw: od.constraint_jacobian(m, s[0], cs, **kw),
    ),
    (
        "constraint_drift",
        lambda d, k: d.constraint_rows(k).Adot_qd,
        lambda m, s, f, cs, **kw: od.constraint_drift(m, s[0], s[1], cs, **kw),
    ),
    (
        "constraint_error",
        lambda d, k: d.constraint_rows(k).phi,
        lambda m, s, f, cs, **kw: od.constraint_error(m, s[0], cs, q_bound=s[1][: m.nq], **kw),
    ),
    (
        "constrained_forward_dynamics",
        lambda d, k: (d.qdd, d.constraint_rows(k).lam),
        lambda m, s, f, cs, **kw: od.constrained_forward_dynamics(m, *s, cs, **kw),
    ),
    (
        "constrained_forward_dynamics A",
        lambda d, k: (d.qdd, d.constraint_rows(k).lam),
        lambda m, s, f, cs, **kw: od.constrained_forward_dynamics(
            m, *s, A=_A(m, s[0], cs), Adot_qd=_lam(m, s[0], cs), **kw
        ),
    ),
    (
        "constraint_projection",
        lambda d, k: d.P,
        lambda m, s, f, cs, **kw: od.constraint_projection(m, s[0], _A(m, s[0], cs), **kw),
    ),
    (
        "constrained_inverse_dynamics",
        lambda d, k: d.tau,
        lambda m, s, f, cs, **kw: od.constrained_inverse_dynamics(
            m, *s, _A(m, s[0], cs), **kw
        ),
    ),
    (
        "constrained_inverse_dynamics lam",
        lambda d, k: d.tau,
        lambda m, s, f, cs, **kw: od.constrained_inverse_dynamics(
            m, *s, _A(m, s[0], cs), _lam(m, s[0], cs), **kw
        ),
    ),
    (
        "constraint_wrench",
        lambda d, k: d.F_tip,
        lambda m, s, f, cs, **kw: od.constraint_wrench(
            m, s[0], f, _A(m, s[0], cs), _lam(m, s[0], cs), **kw
        ),
    ),
)


@pytest.fixture(scope="module", params=sorted(ROBOTS))
def robot(request):
    return od.load_urdf(request.param, check_inertia=False), *ROBOTS[request.param]


def _states(model, n=2):
    rng = np.random.default_rng(17)
    return [
        (od.random_configuration(model, rng), *rng.uniform(-1, 1, (2, model.nv)))
        for _ in range(n)
    ]


@pytest.mark.parametrize("name, held, call", CALLS, ids=[c[0] for c in CALLS])
def test_a_call_with_data_returns_the_datas_array_equal_to_a_fresh_call(robot, name, held, call):
    """Two calls with one Data at two states: each returns the Data's own array(s), holding
    what a call without data= answers at that state (the second call overwrites the first)."""
    model, frame, constraints = robot
    if name == "constraint_wrench" and model.nv != 6:
        pytest.skip("F_tip = J_b^-T A^T lam needs a square J_b (nv = 6)")
    data = od.Data(model)
    k = len(_A(model, od.neutral(model), constraints))
    for state in _states(model):
        fresh = call(model, state, frame, constraints)
        out = call(model, state, frame, constraints, data=data)
        arrays = held(data, k)
        if isinstance(arrays, tuple):
            assert len(out) == len(fresh) == len(arrays)
        else:
            out, fresh, arrays = (out,), (fresh,), (arrays,)
        for x, expected, array in zip(out, fresh, arrays):
            assert x is array
            np.testing.assert_array_equal(x, expected)
            assert not np.shares_memory(expected, data._work)
    for x in arrays:  # the Data's fields are views of its buffer; the k-row arrays its own
        assert np.shares_memory(x, data._work) or any(
            x is a for a in data.constraint_rows(k)
        )


def test_constraint_rows_are_made_once_per_row_count(robot):
    """data.constraint_rows(k) is the same arrays call after call, one set per k."""
    model, _, constraints = robot
    data = model.data()
    q = od.neutral(model)
    A = od.constraint_jacobian(model, q, constraints, data=data)
    assert A is od.constraint_jacobian(model, q, constraints, data=data)
    assert A is data.constraint_rows(len(A)).A
    A1 = od.constraint_jacobian(model, q, constraints[:1], data=data)
    assert A1.shape == (3, model.nv) and A1 is not A
    np.testing.assert_array_equal(A1, A[:3])
    assert A is data.constraint_rows(len(A)).A


@pytest.mark.parametrize("name, held, call", CALLS, ids=[c[0] for c in CALLS])
def test_data_with_a_batch_or_of_another_model_is_refused(robot, name, held, call):
    model, frame, constraints = robot
    q, qd, qdd = _states(model, 1)[0]
    batch = (np.array([q, q]), np.array([qd, qd]), np.array([qdd, qdd]))
    with pytest.raises(ValueError, match="data= works for a single state"):
        call(model, batch, frame, constraints, data=model.data())
    other = od.load_urdf("double_pendulum")
    with pytest.raises(ValueError, match="data was made for model 'double_pendulum'"):
        call(model, (q, qd, qdd), frame, constraints, data=other.data())
