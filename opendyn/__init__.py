"""opendyn: URDF-driven rigid-body robot dynamics.

Conventions: twists (omega, v) and wrenches (m, f), angular first; f_tip maps a frame name to
the wrench that frame applies to the environment, in its own coordinates; gravity is the
world-frame vector applied as the base acceleration dV_0 = (0, -g).
"""

# first, and all that `import opendyn` runs: the compile target, set before numba is imported
# (the public names below are imported when first used: `import opendyn` loads neither numpy nor
# numba, and a script pays only for the layers it calls)
from typing import TYPE_CHECKING

from ._runtime import kernel_target  # noqa: F401
from ._runtime.lazy import attach
from ._runtime.version import __version__  # noqa: F401  (opendyn.__version__)

if TYPE_CHECKING:  # the public names and their modules, read by `attach` (and by type checkers)
    from .algorithm.aba_derivatives import forward_dynamics_derivatives
    from .algorithm.centroidal import (
        center_of_mass,
        center_of_mass_jacobian,
        centroidal_momentum,
        centroidal_momentum_matrix,
        centroidal_momentum_rate_bias,
    )
    from .algorithm.christoffel import christoffel_symbols, coriolis_matrix
    from .algorithm.collision.queries import Contacts, Distances, collisions, distances
    from .algorithm.configuration import (
        difference,
        integrate,
        neutral,
        normalize,
        random_configuration,
    )
    from .algorithm.constraints import (
        constrained_forward_dynamics,
        constrained_inverse_dynamics,
        constraint_drift,
        constraint_error,
        constraint_jacobian,
        constraint_projection,
        constraint_wrench,
    )
    from .algorithm.crba import mass_matrix
    from .algorithm.energy import kinetic_energy, potential_energy
    from .algorithm.forward import forward_dynamics
    from .algorithm.identification import identify, identify_payload
    from .algorithm.kinematics import frame_pose, jacobian
    from .algorithm.regressor import torque_regressor
    from .algorithm.rnea import bias_forces, coriolis_forces, gravity_forces, inverse_dynamics
    from .algorithm.rnea_derivatives import inverse_dynamics_derivatives
    from .algorithm.task_space import frame_acceleration, task_space_bias, task_space_mass_matrix
    from .api import Simulator, contact_problem, linearize, rollout, simulate
    from .errors import (
        NonFiniteResultError,
        RolloutInterrupted,
        SceneError,
        SceneWarning,
        SimulationError,
        SingularMassMatrixError,
        SingularTaskSpaceError,
        SweepError,
        SweepInterrupted,
        SweepWriteError,
        URDFError,
        URDFWarning,
    )
    from .io.scene.files import default_scene, load_scene, scene_from_dict
    from .io.urdf import available_robots, load_urdf
    from .io.urdf_xml import FidelityReport
    from .multibody.constraint_objects import (
        FixedPose,
        JointCoupling,
        PointOnPlane,
        PointToPoint,
        PointToWorld,
    )
    from .multibody.data import Data
    from .multibody.geometry import Geometry
    from .multibody.model import CollisionSphere, Frame, Model
    from .sim.rollout_result import RolloutResult
    from .sim.scene import Scene
    from .sim.trajectory import Trajectory
    from .sweep.engine import sweep
    from .sweep.plot import plot_sweep

__getattr__, __dir__ = attach(globals())

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
    "linearize",
    "contact_problem",
    "simulate",
    "Simulator",
    "rollout",
    "RolloutResult",
    "RolloutInterrupted",
    "sweep",
    "SweepError",
    "SweepInterrupted",
    "SweepWriteError",
    "plot_sweep",
    "FixedPose",
    "CollisionSphere",
    "Geometry",
    "Distances",
    "Contacts",
    "distances",
    "collisions",
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
    "Data",
    "FidelityReport",
    "Model",
    "NonFiniteResultError",
    "SingularMassMatrixError",
    "SingularTaskSpaceError",
    "URDFError",
    "URDFWarning",
    "available_robots",
    "bias_forces",
    "center_of_mass",
    "center_of_mass_jacobian",
    "centroidal_momentum",
    "centroidal_momentum_matrix",
    "centroidal_momentum_rate_bias",
    "christoffel_symbols",
    "coriolis_forces",
    "coriolis_matrix",
    "forward_dynamics",
    "forward_dynamics_derivatives",
    "frame_acceleration",
    "frame_pose",
    "gravity_forces",
    "identify",
    "identify_payload",
    "inverse_dynamics",
    "inverse_dynamics_derivatives",
    "jacobian",
    "kinetic_energy",
    "load_urdf",
    "mass_matrix",
    "potential_energy",
    "task_space_bias",
    "task_space_mass_matrix",
    "torque_regressor",
]
