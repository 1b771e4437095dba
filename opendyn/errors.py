"""Every public exception of opendyn, in one place. Each message names the file, element, key or
argument at fault and what is wrong with it."""

from __future__ import annotations

import numpy as np


class URDFError(ValueError):
    """A URDF that cannot be turned into a model; the message names the file, element, problem."""


class SceneError(ValueError):
    """A scene that cannot be run: the message names the file, the key (dotted path, e.g.
    'effects.damping.coefficients') and what is wrong, with the valid choices."""


class SceneWarning(UserWarning):
    """A scene that runs, but probably not as meant (a joint starting outside its limits that
    the scene does not enforce): the message names the file and the key, as SceneError's."""


class URDFWarning(UserWarning):
    """A URDF (or its SRDF, or its meshes) that loads, but probably not as meant: a collision
    mesh that cannot be read, a ``<geometry>`` of two shapes, an SRDF pair of a link with
    itself. The message names the file, the element and what was done with it; the model's
    fidelity report (``model.report``) lists it too. (A mesh far from convex is a line of the
    report, and a SceneWarning of the scenes whose contact uses it.)"""


class NonFiniteResultError(ValueError):
    """Finite arguments whose result overflowed float64 to inf or NaN: some number is too large
    for double precision (it ends near 1.8e308, and the dynamics multiply numbers together).
    A ValueError, as for arguments that are not finite: the cure is in the arguments' values.
    ``result`` names the result ("tau", "qdd", "M", ...)."""

    def __init__(self, what, result, arguments):
        self.result = result
        sizes = {name: _largest(value) for name, value in arguments.items()}
        largest = max(sizes, key=sizes.get, default=None)
        if largest is not None and sizes[largest] >= 1e50:
            cause = f"{largest} up to {sizes[largest]:.3g} in magnitude"
        else:
            cause = "the model's own numbers (masses, inertias, lengths) are too large"
        super().__init__(
            f"{what}: the result {result} overflowed float64 (it has inf or NaN) although "
            f"every argument is finite; likely cause: {cause}"
        )


def _largest(value):
    """The largest magnitude in an argument: an array, a number, or a dict of arrays (f_tip)."""
    if value is None:
        return 0.0
    if isinstance(value, dict):
        return max((_largest(v) for v in value.values()), default=0.0)
    a = np.abs(np.asarray(value, dtype=np.float64))
    return float(a.max()) if a.size else 0.0


class SingularMassMatrixError(ValueError):
    """M(q) is singular: a joint, or a combination of joints, moves nothing with mass or
    inertia (or too little beside the rest for float64), so its acceleration is undetermined.

    joints: the coordinates (model.v_names) whose column of M is zero: nothing with mass or
      inertia moves with them; or, when each moves some, those whose inertia is too small
      beside M's largest for float64's 16 digits (the message says which). Empty when every
      joint moves some inertia but a combination of them moves none; `together` then names
      the joints of that combination.
    (opendyn.algorithm.singular.singular_mass_matrix finds them and builds the error.)
    """

    def __init__(self, what, model_name, joints, together, why):
        self.joints, self.together = joints, together
        super().__init__(f"{what}: the mass matrix of {model_name!r} is singular: {why}")


class SingularTaskSpaceError(ValueError):
    """J_b M^-1 J_b^T is singular: the frame cannot move in every task direction."""


class SimulationError(RuntimeError):
    """A run that stopped early. `trajectory` holds everything computed up to the failure
    (complete=False); the message names the time, the step and the likely cause."""

    def __init__(self, message, trajectory):
        super().__init__(message)
        self.trajectory = trajectory


class SweepError(ValueError):
    """A sweep that cannot start: a spec, a key or a value of some run that is not valid (the
    message names it), or a results file that holds another sweep."""


class SweepInterrupted(KeyboardInterrupt):
    """Ctrl-C stopped a sweep after its arrived rows were saved; `table` holds every row."""

    def __init__(self, table):
        super().__init__("the sweep was interrupted")
        self.table = table


class SweepWriteError(OSError):
    """A sweep that stopped because a file could not be written (a full disk, a folder made
    read-only): `filename` names the file, `errno` and `strerror` say why, and `table` holds
    every row that arrived before it. The rows already in the results file and its parts stay
    there, and the same sweep resumes from them once the file can be written."""

    def __init__(self, message, errno, strerror, filename, table):
        super().__init__(message)
        self.errno, self.strerror, self.filename = errno, strerror, filename
        self.table = table

    def __str__(self):
        return self.args[0]  # the message, not OSError's "[Errno N] ..." of the fields


class RolloutInterrupted(KeyboardInterrupt):
    """Ctrl-C stopped a rollout after the runs under way finished; `result` (a RolloutResult)
    holds every run done, and the runs never started have status 'interrupted'."""

    def __init__(self, result):
        super().__init__("the rollout was interrupted")
        self.result = result
