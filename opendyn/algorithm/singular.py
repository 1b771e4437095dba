"""Why M(q) is singular, for the error that says so: the coordinates that move no inertia, or
the joints whose combined motion moves none (singular_coordinates), and the
SingularMassMatrixError that names them (singular_mass_matrix). Above CRBA, which it runs; the
calls that solve with M hand singular_mass_matrix to the argument checks' raise_status."""

from __future__ import annotations

import numpy as np

from ..errors import SingularMassMatrixError
from .cholesky import SINGULAR_PIVOT
from .crba import mass_matrix


def mass_matrix_with_armature(model, q, armature=None):
    """M(q) (nv, nv), plus diag(armature) on the joints' coordinates (model.v_index) as a
    scene's armature effect adds it; armature: (n,) or None."""
    M = mass_matrix(model, q)
    if armature is not None:
        M[model.v_index, model.v_index] += armature
    return M


def singular_mass_matrix(model, q, what, armature=None):
    """The SingularMassMatrixError for M(q) (+ diag(armature)) of `model`, raised by `what`,
    naming the joints that move no inertia (singular_coordinates)."""
    joints, together, why = singular_coordinates(model, q, armature)
    return SingularMassMatrixError(what, model.name, joints, together, why)


def singular_coordinates(model, q, armature=None):
    """Why M(q) (+ diag(armature) on the joints, as a scene adds it) is singular:
    (massless, together, sentence).

    massless: the coordinates k whose diagonal entry M_kk = S_k^T Ic_k S_k (Ic_k the composite
    inertia of everything below joint k) is zero to the forward dynamics' pivot tolerance;
    M is positive semi-definite, so their whole column of M is zero. When none of them is
    exactly zero, the sentence says that M's entries span more than float64's digits (a 1e30 kg
    payload beside 1 kg links), not that nothing moves. When there are none,
    together: the coordinates of M's null direction (of M scaled to a unit diagonal, so that
    revolute and prismatic units do not matter): joints whose combined motion moves nothing
    with inertia, as two joints moving one body along or about the same axis. The sentence
    says so.
    """
    M = mass_matrix_with_armature(model, q, armature)
    d = np.diag(M)
    small = np.flatnonzero(d <= SINGULAR_PIVOT * d.max(initial=0))
    if small.size and not (d[small] <= 0.0).any():
        # each moves some inertia, too little beside the largest for float64's 16 digits
        k, j = int(small[np.argmin(d[small])]), int(np.argmax(d))
        heaviest = int(np.argmax(model.mass))
        inertia = np.abs(model.I_o).max(axis=(1, 2))  # about each body's frame origin
        widest = int(np.argmax(inertia))
        return [model.v_names[k] for k in small], [], (
            f"joint {model.v_names[k]!r} moves an inertia M_kk = {d[k]:.3g}, {d[k] / d[j]:.1g} "
            f"times the largest on M's diagonal ({d[j]:.3g}, {model.v_names[j]!r}): M's entries "
            "span more digits than float64 keeps (16), so M is singular to working precision "
            f"although everything moves some mass; the masses or inertias differ too much (the "
            f"heaviest body: {model.body_names[heaviest]!r}, {model.mass[heaviest]:.3g} kg; the "
            f"largest inertia about its frame: {model.body_names[widest]!r}, "
            f"{inertia[widest]:.3g} kg m^2, as a payload's centre of mass far from its frame "
            "makes)"
        )
    massless = [model.v_names[k] for k in small]
    if massless:
        names = ", ".join(map(repr, massless))
        if len(massless) == 1:
            subject, pronoun = f"joint {names}, so its acceleration is", "it"
        else:
            subject, pronoun = f"joints {names}, so their accelerations are", "them"
        return massless, [], (
            f"nothing with mass or inertia moves with {subject} undetermined (give the links "
            f"below {pronoun} inertia, or name the armature effect for {pronoun} in a scene)"
        )
    scale = 1 / np.sqrt(d)
    null = np.linalg.eigh(scale[:, None] * M * scale)[1][:, 0] * scale
    null /= null[np.argmax(np.abs(null))]
    involved = np.flatnonzero(np.abs(null) > 1e-6)
    together = [model.v_names[k] for k in involved]
    ratio = ", ".join(f"{x:.3g}" for x in null[involved])
    return [], together, (
        f"every joint moves some inertia, but joints {', '.join(map(repr, together))} moving "
        f"together, with velocities in the ratio ({ratio}), move none (as two joints moving one "
        f"body along or about the same axis), so that motion's acceleration is undetermined"
    )
