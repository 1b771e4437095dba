"""Inputs that cannot lie: a Model, its frames and a Scene's settings cannot be changed after
they are built; arguments of the wrong kind (not a Model, complex, text, boolean or object
arrays) are a TypeError naming the argument; finite arguments whose result overflows float64
are an error naming the result, never a NaN returned."""

from __future__ import annotations

import numpy as np
import pytest

import opendyn as od

MODEL_ARRAYS = (
    "G", "S", "A", "mass", "h", "I_o", "R_home", "p_home", "parent", "jtype", "nv_j", "iq",
    "iv", "mult", "offset", "q_index", "v_index", "lower", "upper", "velocity_limit",
    "effort_limit", "damping", "friction", "continuous", "gravity",
)  # fmt: skip


@pytest.fixture(scope="module")
def ur5():
    return od.load_urdf("ur5")


@pytest.fixture(scope="module")
def solo():
    return od.load_urdf("solo", floating_base=True)


def model_arrays(model):
    """(name, array) of every array a Model shows: its fields, each frame's transform and
    each collision sphere's centre."""
    yield from ((name, getattr(model, name)) for name in MODEL_ARRAYS)
    yield from ((f"frame {f.name!r}", f.T_body_frame) for f in model.frames)
    yield from ((f"sphere of {s.link!r}", s.position) for s in model.collision_spheres)


def aba_agrees_with_crba(model, seed=0):
    rng = np.random.default_rng(seed)
    q = od.random_configuration(model, rng)
    qd, tau = rng.normal(size=(2, model.nv))
    M, h = od.mass_matrix(model, q), od.bias_forces(model, q, qd)
    np.testing.assert_allclose(
        od.forward_dynamics(model, q, qd, tau), np.linalg.solve(M, tau - h), rtol=1e-8, atol=1e-8
    )


@pytest.mark.parametrize("robot", ["ur5", "solo", "talos_full_v2"])
def test_model_arrays_cannot_be_made_writeable_again(robot):
    model = od.load_urdf(robot, floating_base=robot != "ur5")
    arrays = list(model_arrays(model))
    assert len(arrays) >= len(MODEL_ARRAYS) + len(model.frames)
    for name, array in arrays:
        for view in (array, array[...], np.asarray(array)):
            with pytest.raises(ValueError, match="WRITEABLE"):
                view.flags.writeable = True
            with pytest.raises(ValueError, match="read-only"):
                view[...] = 0
        assert not array.flags.writeable, name
    aba_agrees_with_crba(model)
