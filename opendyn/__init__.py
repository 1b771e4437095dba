"""opendyn: URDF-driven rigid-body robot dynamics.

Conventions: twists (omega, v) and wrenches (m, f), angular first; f_tip maps a frame name to
the wrench that frame applies to the environment, in its own coordinates; gravity is the
world-frame vector applied as the base acceleration dV_0 = (0, -g).
"""

from ._kernel_cache import kernel_cache
from .constraints import FixedPose, JointCoupling, PointOnPlane, PointToPoint, PointToWorld
from .dynamics._args import NonFiniteResultError, SingularMassMatrixError
from .dynamics.christoffel import christoffel_symbols, coriolis_matrix
from .dynamics.configuration import (
    difference,
    integrate,
    neutral,
    normalize,
    random_configuration,
)
from .dynamics.crba import mass_matrix
from .dynamics.energy import kinetic_energy, potential_energy
from .dynamics.forward import forward_dynamics
from .dynamics.kinematics import frame_pose, jacobian
from .dynamics.rnea import bias_forces, coriolis_forces, gravity_forces, inverse_dynamics
from .dynamics.task_space import (
    SingularTaskSpaceError,
    frame_acceleration,
    task_space_bias,
    task_space_mass_matrix,
)
from .model import CollisionSphere, Frame, Model
from .urdf import FidelityReport, URDFError, available_robots, load_urdf

with kernel_cache():  # compiled kernels cache in the folder named by the sources' hash
    from .dynamics.constraints import (
        constrained_forward_dynamics,
        constrained_inverse_dynamics,
        constraint_drift,
        constraint_error,
        constraint_jacobian,
        constraint_projection,
        constraint_wrench,
    )

__version__ = "0.1.0"

from .scene import (  # noqa: E402
    Scene,
    SceneError,
    SceneWarning,
    default_scene,
    load_scene,
    scene_from_dict,
)
from .simulate import SimulationError, simulate  # noqa: E402
from .sweep import SweepError, SweepInterrupted, sweep  # noqa: E402
from .sweep_plot import plot_sweep  # noqa: E402
from .trajectory import Trajectory  # noqa: E402

__all__ = [
    "Scene",
    "SceneError",
    "SceneWarning",
    "SimulationError",
    "Trajectory",
    "default_scene",
    "difference",
    "integrate",
    "neutral",
    "normalize",
    "random_configuration",
    "load_scene",
    "scene_from_dict",
    "simulate",
    "sweep",
    "SweepError",
    "SweepInterrupted",
    "plot_sweep",
    "FixedPose",
    "CollisionSphere",
    "Frame",
    "JointCoupling",
    "PointOnPlane",
    "PointToPoint",
    "PointToWorld",
    "constrained_forward_dynamics",
    "constrained_inverse_dynamics",
    "constraint_drift",
    "constraint_error",
    "constraint_jacobian",
    "constraint_projection",
    "constraint_wrench",
    "FidelityReport",
    "Model",
    "NonFiniteResultError",
    "SingularMassMatrixError",
    "SingularTaskSpaceError",
    "URDFError",
    "available_robots",
    "bias_forces",
    "christoffel_symbols",
    "coriolis_forces",
    "coriolis_matrix",
    "forward_dynamics",
    "frame_acceleration",
    "frame_pose",
    "gravity_forces",
    "inverse_dynamics",
    "jacobian",
    "kinetic_energy",
    "load_urdf",
    "mass_matrix",
    "potential_energy",
    "task_space_bias",
    "task_space_mass_matrix",
]
