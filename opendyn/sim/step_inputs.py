"""What a Simulator is given, checked: torques, states, a controller (a function, or one a
scene or a command names as "FILE.py:NAME" or "MODULE:NAME") and the periods it runs at. Every
refusal is a TypeError, ValueError or SceneError naming the argument and what is wrong."""

from __future__ import annotations

import importlib
import importlib.util
import math
import pathlib
import sys

import numpy as np

from .._runtime.options import as_real
from ..algorithm import checks
from ..algorithm.configuration import check_unit_quaternions
from ..errors import SceneError
from ..multibody.joints import FREE
from .effects import python_control
from .run import whole_steps

# A period (a step's duration, control_dt) shorter than RESOLUTION max(1, |t|) s would be lost to
# the rounding of the time t it is added to (float64 keeps about 16 digits; the compiled loops
# take two times within integrators.SLIVER max(1, |t|) of each other as one).
RESOLUTION = 1e-12


def checked_period(value, what, t=0.0):
    """value as a period (s): a real number, finite, > 0 and at least RESOLUTION max(1, |t|),
    the time t (s) it is added to; TypeError or ValueError naming `what` otherwise. A float32
    (or float16) is read as the shortest decimal it stands for: np.float32(0.001) is 0.001 s,
    not the 0.0010000000475 s that float32 holds, which no step of 0.001 s divides."""
    period = as_real(value, what)
    dtype = getattr(value, "dtype", None)
    if dtype is not None and dtype.kind == "f" and dtype.itemsize < 8 and math.isfinite(period):
        period = float(str(value[()]))
    if not (math.isfinite(period) and period > 0):
        raise ValueError(f"{what} must be a time > 0 (s), got {period}")
    floor = RESOLUTION * max(1.0, abs(t))
    if period < floor:
        raise ValueError(
            f"{what} = {period:g} s is below what the simulated time resolves at t = {t:g} s: a "
            f"period shorter than {floor:.3g} s is lost to the rounding of t + period (float64)"
        )
    return period


def controller_of(scene, integ, controller, control_dt):
    """(fn or None, control period s): the given controller or the scene's Python one, and
    its period: control_dt, else the scene's [control] control_dt, else run.control_dt, else
    run.dt; for a fixed-step integrator a whole number of steps."""
    run = scene.run
    own = python_control.record(scene)
    if controller is None and own is not None:
        controller = load_controller(own.function, f"{scene.source}: control.function")
    if controller is not None and not callable(controller):
        raise TypeError(
            f"controller must be a function fn(t, q, qd) -> tau, got "
            f"{type(controller).__name__} {controller!r}"[:200]
        )
    if own is not None and own.control_dt is not None and run.control_dt is not None:
        raise SceneError(
            f"{scene.source}: control.control_dt and run.control_dt are both given; give one"
        )
    if control_dt is None:
        control_dt = next(
            (dt for dt in (own and own.control_dt, run.control_dt) if dt is not None), run.dt
        )
    control_dt = checked_period(control_dt, "control_dt")
    if not integ.adaptive and whole_steps(control_dt / run.dt) is None:
        raise ValueError(
            f"{scene.source}: control_dt = {control_dt:g} s is not a whole number of steps of "
            f"run.dt = {run.dt:g} s ({control_dt / run.dt:.6g} steps); the fixed-step "
            f"integrator {run.integrator!r} holds the torque over whole steps"
        )
    return controller, control_dt


def load_controller(spec, what):
    """The function that spec names: "FILE.py:NAME" (a file, loaded as a module of its own) or
    "MODULE:NAME" (imported). SceneError naming `what`, the file or module and the reason
    when it cannot be loaded."""
    where, name = python_control.function_parts(spec)
    if where is None:
        raise SceneError(f"{what}: {python_control.NOT_A_FUNCTION.format(spec=spec)}")
    try:
        if where.endswith(".py"):
            path = pathlib.Path(where)
            if not path.is_file():
                raise SceneError(f"{what}: no file {str(path)!r}")
            module_name = f"opendyn_controller_{abs(hash(str(path.resolve())))}"
            spec_ = importlib.util.spec_from_file_location(module_name, path)
            module = importlib.util.module_from_spec(spec_)
            sys.modules[module_name] = module
            spec_.loader.exec_module(module)
        elif pathlib.Path(where).is_file():
            # "dp.toml:f": a file, but not Python; as a module name it was "No module 'dp'"
            raise SceneError(
                f"{what}: {where!r} is not a Python file: a controller is FILE.py:NAME or "
                "MODULE:NAME"
            )
        else:
            module = importlib.import_module(where)
    except SceneError:
        raise
    except SystemExit as error:  # sys.exit() at import: not the command's exit
        raise SceneError(
            f"{what}: loading {where!r} failed: it called sys.exit({error.code!r}) while being "
            "imported"
        ) from None
    except Exception as error:
        raise SceneError(
            f"{what}: loading {where!r} failed: {type(error).__name__}: {error}"
        ) from error
    fn = getattr(module, name, None)
    if not callable(fn):
        found = "nothing" if fn is None else f"a {type(fn).__name__}"
        raise SceneError(f"{what}: {where!r} has no function {name!r} ({found} by that name)")
    return fn


def checked_torque(model, tau, what):
    """tau as a (nv,) float64 generalized force: (nv,), or with free joints (a floating base,
    a scene's objects) the joints' (model.v_index,); 0.0 for None; TypeError or ValueError
    naming `what` otherwise."""
    if tau is None:
        return 0.0
    joints, base = model.v_index, model._unactuated
    a = checks.as_float_array(tau, what)
    if base.size and a.shape == joints.shape:
        full = np.zeros(model.nv)
        full[joints] = a
        a = full
    if a.shape != (model.nv,):
        also = f" or the joints' ({len(joints)},)" if base.size else ""
        raise ValueError(f"{what}: expected shape ({model.nv},){also}, got {shown(a)}")
    if not np.isfinite(a).all():
        raise ValueError(f"{what}: not finite: {shown(a)}")
    if base.size and np.any(a[base] != 0.0):
        raise ValueError(
            f"{what}: the free joints (a floating base, a scene's objects) are not actuated, "
            f"so tau at their coordinates "
            f"{base.tolist()} must be zero, got {a[base].tolist()} (give the joints' "
            f"({len(joints)},) alone)"
        )
    return a


def checked_configuration(model, q, what):
    """q checked as an initial configuration (nq,): finite, each quaternion within
    QUATERNION_TOLERANCE of unit norm as every dynamics function takes it (the same check), and
    normalised; errors name `what`."""
    q = checked_vector(model, q, what, model.nq)
    check_unit_quaternions(model, q, "q", what)
    for i in np.flatnonzero(model.jtype == FREE):
        k = int(model.iq[i]) + 3
        q[k : k + 4] /= np.linalg.norm(q[k : k + 4])
    return q


def checked_vector(model, x, what, n=None):
    """x as a finite float64 (n,) copy (n = nv by default); TypeError or ValueError naming
    `what`."""
    n = model.nv if n is None else n
    a = np.array(checks.as_float_array(x, what), dtype=np.float64)
    if a.shape != (n,):
        raise ValueError(f"{what}: expected shape ({n},), got {shown(a)}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{what}: not finite: {shown(a)}")
    return a


def shown(a):
    """An array in a message: its shape and a few of its numbers."""
    text = np.array2string(np.asarray(a), precision=4, threshold=12)
    return f"shape {np.shape(a)}: {text}"


def controller_name(fn):
    """The controller as messages name it: its qualified name (Class.method) without the
    "outer.<locals>." of a function defined inside another."""
    name = getattr(fn, "__qualname__", None) or type(fn).__name__
    return repr(name.rpartition("<locals>.")[2])

