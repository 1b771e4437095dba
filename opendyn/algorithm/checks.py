"""Argument checking shared by the public dynamics functions: the model, states, gravity,
f_tip and any other array or number.

The model must be a Model, and every array argument must hold real numbers (integers or
floats); anything else (None or a robot's name for a model; booleans, complex numbers, text or
objects for an array) is a TypeError that names the argument. A configuration is a (nq,)
vector or a batch (N, nq), a velocity-like argument (qd, qdd, tau) a (nv,) vector or a batch
(N, nv); any other shape raises a ValueError that names the argument. Gravity and f_tip reach
the kernels as one array of external loads. Finiteness is checked inside the compiled kernels
(it costs nothing there) and reported through a status code that `raise_status` turns into
the same kind of error; so is a result that overflowed float64 although every argument was
finite (RESULT_NOT_FINITE), which `raise_status` and `check_result` turn into a
NonFiniteResultError naming the result and the likely cause.
"""

from __future__ import annotations

import math
import os

import numpy as np

from .._runtime.batch import run_rows
from .._runtime.options import as_float_array, short_repr
from .._runtime.status import NOT_FINITE_ARGUMENT, Status, decode
from ..errors import NonFiniteResultError
from ..multibody.data import Data
from ..multibody.joints import FREE
from ..multibody.model import Model
from ..spatial.algebra import angular, linear

# a quaternion whose norm is below this has no direction to normalise to: no orientation
ZERO_QUATERNION = 1e-12



def check_model(model, what):
    """TypeError unless `model` is a Model: the first check of every public function that
    takes one, saying what was passed and how to get a Model."""
    if isinstance(model, Model):
        return
    if isinstance(model, (str, os.PathLike)):
        hint = f"; load it with od.load_urdf({os.fspath(model)!r})"
    elif isinstance(getattr(model, "model", None), Model):
        hint = f"; a {type(model).__name__}'s model is its .model"
    else:
        hint = ""
    found = "None" if model is None else f"{type(model).__name__} {short_repr(model)}"
    raise TypeError(
        f"{what}: model must be an opendyn Model (from od.load_urdf), got {found}{hint}"
    )


def work_of(model, data, what):
    """The work buffer a call runs in: the Data's, or the model's own for a call without data=.
    Checks on the way that `model` is a Model (check_model's TypeError) and `data` a Data of
    it: the public functions' first call, in one Python call (measured on the UR5: a call
    to check_model and one here cost 0.1 us of inverse_dynamics' 1.6)."""
    if data is None:
        if type(model) is Model:
            return model._work
    elif type(data) is Data and data.model is model:
        return data._work
    check_model(model, what)
    if data is None:
        return model._work
    if type(data) is not Data:
        raise TypeError(
            f"{what}: data must be an opendyn Data (od.Data(model) or model.data()), got "
            f"{type(data).__name__} {short_repr(data)}"
        )
    if data.model.name == model.name and data.model.nv == model.nv:
        raise ValueError(
            f"{what}: data was made by another load of {model.name!r} (another Model object, "
            f"from another load_urdf or scene), not by this model: a Data holds its own "
            f"model's buffers; use this model's data() (model.data())"
        )
    raise ValueError(
        f"{what}: data was made for model {data.model.name!r} (nv={data.model.nv}), not "
        f"for this model {model.name!r} (nv={model.nv}); make one with model.data()"
    )


def single_state_only(data, what):
    """ValueError when data= comes with a batch of states: a Data holds one state's results."""
    if data is not None:
        raise ValueError(
            f"{what}: data= works for a single state (it holds one state's results); call "
            "without data= for a batch (N, nq)"
        )


def as_state(model, x, name, n=None):
    """x as a writeable C-contiguous float64 array of shape (n,) or (N, n); n = nv unless
    given (model.nq for a configuration: see as_q)."""
    n = model.nv if n is None else n
    x = np.ascontiguousarray(as_float_array(x, name))
    if x.ndim not in (1, 2) or x.shape[-1] != n:
        sizes = f"nq={model.nq}" if n == model.nq != model.nv else f"nv={model.nv}"
        raise ValueError(
            f"{name} must have shape ({n},) or (N, {n}) for model {model.name!r} ({sizes}), "
            f"got shape {x.shape}"
        )
    # a read-only array is a different type to numba: copy it rather than compile again
    return x if x.flags.writeable else x.copy()


def as_q(model, q, name="q"):
    """A configuration as a writeable C-contiguous float64 array (nq,) or (N, nq)."""
    return as_state(model, q, name, model.nq)


def as_states(model, q, *named):
    """A configuration q and (name, value) velocity-like arguments: all single, or batches
    broadcast to one N. Returns [q, *values] and whether they are a batch."""
    arrays = [as_q(model, q)] + [as_state(model, x, name) for name, x in named]
    names = ["q"] + [name for name, _ in named]
    if all(a.ndim == 1 for a in arrays):
        return arrays, False
    n = max(a.shape[0] for a in arrays if a.ndim == 2)
    for name, a in zip(names, arrays):
        if a.ndim == 2 and a.shape[0] != n:
            raise ValueError(
                f"{name} has {a.shape[0]} states but another argument has {n}; "
                f"a batch must have one N"
            )
    return [a if a.ndim == 2 else np.tile(a, (n, 1)) for a in arrays], True


def as_gravity(model, gravity):
    """The (3,) world-frame gravity vector: the model's default, or the override."""
    if gravity is None:
        return model._gravity
    g = np.array(as_float_array(gravity, "gravity"))  # a writeable copy: one type for the kernels
    if g.shape != (3,):
        raise ValueError(f"gravity must be a 3-vector (m/s^2, world frame), got shape {g.shape}")
    if not np.all(np.isfinite(g)):
        raise ValueError(f"gravity must be finite, got {g}")
    return g


def loads(model, gravity, f_tip, n_states=None):
    """The kernels' external-load array: row 0 the base acceleration dV_0 = (0, -g), then (only
    when f_tip is given) one row per body with the wrench it applies to the environment.

    Shape (1, 6) or (1 + nb, 6); for a batch (1, rows, 6) shared by every state, or
    (N, 1 + nb, 6) when f_tip varies per state.

    f_tip[frame] = (m, f) is the wrench that frame applies TO THE ENVIRONMENT, in that frame's
    coordinates; (6,) or, for a batch, (N, 6). On body b it is F_b = Ad_{T_{frame, b}}^T F =
    (R m + p x (R f), R f), with (R, p) = T_{b, frame}. A frame of the fixed world moves no joint.
    """
    if gravity is None and f_tip is None:
        return model._loads if n_states is None else model._loads[None]
    dV_0 = np.zeros(6)
    linear(dV_0)[:] = -as_gravity(model, gravity)
    if f_tip is not None and not isinstance(f_tip, dict):
        raise TypeError(
            "f_tip must be a dict {frame_name: (6,) wrench (m, f) in that frame}, "
            f"got {type(f_tip).__name__} {short_repr(f_tip)}"
        )
    if not f_tip:
        return dV_0[None] if n_states is None else dV_0[None, None]
    per_state = n_states is not None and any(np.ndim(F) == 2 for F in f_tip.values())
    out = np.zeros((n_states, 1 + model.nb, 6) if per_state else (1 + model.nb, 6))
    out[..., 0, :] = dV_0
    for frame, F in f_tip.items():
        k = model.frame_index(frame)
        F = as_float_array(F, f"f_tip[{frame!r}]")
        if F.shape != (6,) and not (per_state and F.shape == (n_states, 6)):
            want = "(6,)" if n_states is None else f"(6,) or ({n_states}, 6)"
            raise ValueError(
                f"f_tip[{frame!r}] must have shape {want} (moment, force), got shape {F.shape}"
            )
        if not np.all(np.isfinite(F)):
            raise ValueError(f"f_tip[{frame!r}] must be finite, got {F}")
        fr = model.frames[k]
        if fr.body < 0:
            continue
        R, p = fr.T_body_frame[:3, :3], fr.T_body_frame[:3, 3]
        f_b = linear(F) @ R.T
        m_b = angular(F) @ R.T + np.cross(p, f_b)
        angular(out[..., 1 + fr.body, :])[...] += m_b
        linear(out[..., 1 + fr.body, :])[...] += f_b
    return out if per_state or n_states is None else out[None]


def raise_status(status, model, what, result=None, arguments=None, singular=None):
    """Turn a kernel's failing Status into a ValueError naming the argument, the joints or,
    for RESULT_NOT_FINITE, the result (its name, e.g. "tau") and the likely cause among the
    arguments ({name: value} of the call: needed where the kernel reports RESULT_NOT_FINITE,
    and its configuration "q" where it reports SINGULAR, as a kernel solving with M(q) does).
    singular: for a call that solves with M(q), the diagnosis of a singular M,
    singular(model, q, what) -> the error to raise (opendyn.algorithm.singular, which sits
    above CRBA: these checks run below it)."""
    status, _ = decode(status)
    if status in NOT_FINITE_ARGUMENT:
        raise ValueError(
            f"{what}: {NOT_FINITE_ARGUMENT[status]} must be finite (it has NaN or inf)"
        )
    if status == Status.RESULT_NOT_FINITE:
        raise NonFiniteResultError(what, result, arguments)
    if status == Status.Q_NOT_UNIT_QUATERNION:
        q = arguments.get("q") if arguments else None
        raise ValueError(f"{what}: {quaternion_problem(model, q=q)}")
    if status == Status.SINGULAR and singular is not None:
        raise singular(model, arguments["q"], what)
    raise RuntimeError(f"{what}: kernel failed with status {status.name}")


def check_result(x, what, result, arguments):
    """x, a result computed outside the kernels (a float or an array), when it is finite;
    else NonFiniteResultError as raise_status. (math.isfinite for a float: numpy takes 2 us.)"""
    if not (math.isfinite(x) if isinstance(x, float) else np.isfinite(x).all()):
        raise NonFiniteResultError(what, result, arguments)
    return x


def quaternion_problem(model, name="q", q=None):
    """What is wrong with the quaternions of the configuration `name`, for an error message:
    the slice of each free joint's quaternion and the tolerance; with q (nq,), the
    configuration, a quaternion that is zero (or not finite) is named as one without an
    orientation, which normalising cannot give it."""
    from ..multibody.joints import QUATERNION_TOLERANCE

    free = [i for i in range(model.nb) if model.jtype[i] == FREE]
    if q is not None and np.shape(q) == (model.nq,):
        for i in free:
            k = int(model.iq[i]) + 3
            quat = np.asarray(q[k : k + 4], dtype=np.float64)
            if not (np.isfinite(quat).all() and np.linalg.norm(quat) >= ZERO_QUATERNION):
                return (
                    f"the quaternion {name}[{k}:{k + 4}] ({model.body_names[i]}) is "
                    f"{quat.tolist()}: it has no orientation, and normalising cannot give it one; "
                    "give a unit quaternion (x, y, z, w), (0, 0, 0, 1) for no rotation"
                )
    slices = ", ".join(f"{name}[{model.iq[i] + 3}:{model.iq[i] + 7}] ({model.body_names[i]})"
                       for i in free)
    return (
        f"the quaternion {slices} (x, y, z, w) must have unit norm (within "
        f"{QUATERNION_TOLERANCE:g}); od.normalize(model, {name}) normalises it"
    )


def run_batch(model, batch_kernel, inputs, out, what, result=None, arguments=None,
              singular=None):
    """out (N, ...) <- batch_kernel(ibuf, fbuf, *inputs, out, status, start, stop) over the
    rows of a batch, one slice per core (opendyn._runtime.batch.run_rows); the first failing
    row raises as raise_batch_status. The one path of every public function's batches."""
    status = np.zeros(out.shape[0], dtype=np.int64)
    run_rows(batch_kernel, out.shape[0], model._ibuf, model._fbuf, *inputs, out, status)
    raise_batch_status(status, model, what, result, arguments, singular)
    return out


def raise_batch_status(statuses, model, what, result=None, arguments=None, singular=None):
    """The first failing state of a batch, named by its row, as raise_status with that row of
    every (N, n) argument."""
    bad = np.flatnonzero(statuses)
    if bad.size:
        k, n = bad[0], len(statuses)
        row = {
            name: x[k] if isinstance(x, np.ndarray) and x.ndim == 2 and len(x) == n else x
            for name, x in (arguments or {}).items()
        }
        raise_status(
            int(statuses[k]), model, f"{what} (state {k} of the batch)", result, row, singular
        )


