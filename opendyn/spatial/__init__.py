"""Spatial algebra of rigid bodies: `algebra`, the readable numpy reference (the user API and the
tests' oracle), and `compiled`, its twin in the 3x3-block forms the kernels inline. The
reference's functions are importable from here (``from opendyn.spatial import exp_se3``)."""

from .algebra import (
    ad,
    adjoint,
    angular,
    exp_se3,
    exp_so3,
    inverse_transform,
    kinetic_energy_body,
    lie_bracket,
    linear,
    log_se3,
    log_so3,
    principal_axes,
    rigid_body_acceleration,
    rigid_body_wrench,
    rpy_matrix,
    skew,
    spatial_inertia,
    transform_inertia,
    twist_to_matrix,
    unskew,
)

__all__ = [
    "ad",
    "adjoint",
    "angular",
    "exp_se3",
    "exp_so3",
    "inverse_transform",
    "kinetic_energy_body",
    "lie_bracket",
    "linear",
    "log_se3",
    "log_so3",
    "principal_axes",
    "rigid_body_acceleration",
    "rigid_body_wrench",
    "rpy_matrix",
    "skew",
    "spatial_inertia",
    "transform_inertia",
    "twist_to_matrix",
    "unskew",
]
