"""Dynamics of open chains on kinematic trees: one algorithm per module, compiled kernels
(cached on disk in a folder named by a hash of their sources, see opendyn._kernel_cache)."""

from .._kernel_cache import kernel_cache

with kernel_cache():
    from . import (  # noqa: F401
        aba,
        christoffel,
        configuration,
        crba,
        energy,
        forward,
        kinematics,
        rnea,
        task_space,
    )
