"""lagrangian: Lagrangian dynamics of mechanical systems.

model -> derive -> Equations -> simulate -> Trajectory.
"""

from sympy import (Abs, acos, asin, atan, atan2, cos, cosh, exp, log, pi, sign, sin, sinh, sqrt, tan,
                   tanh)

from .equations import (ConstraintConfiguration, ConstraintSingularityReport, DeadPoints, Equations, LinearSystem,
                        SingularConfiguration, SingularityReport, constraint_singularities, derive, singularities)
from .errors import (ExpressionError, LagrangianError, ModelError, ModelFileError, OutputFileError, SimulationError,
                     SingularMassMatrixError, Status, UnknownNameError)
from .io import load, load_urdf
from .model import Model, ddot, dot, t
from .numeric import BatchResult, CompiledModel, NumericModel, Signal, Trajectory, grid, simulate, simulate_batch
from .numeric import compile
from .analysis import (Continuation, Equilibria, Equilibrium, LinearModel, Modes, SteadyMotion, SteadyMotions,
                       continuation, equilibria, linearize, modes, steady_motions)
from .analysis import InverseDynamics, Kinematics, inverse_dynamics, kinematics
from .identification import Identifiability, identifiability
from .optimal_control import OptimalControlError, OptimalMotion, optimal_motion
from .reporting import Report, report

from ._version import __version__ as __version__

_LAZY = ("plot",)  # subpackages imported on first use (plot needs Matplotlib)


def __getattr__(name):
    if name in _LAZY:
        import importlib

        return importlib.import_module(f".{name}", __name__)
    raise AttributeError(f"module 'lagrangian' has no attribute '{name}'")

__all__ = [
    "Model", "load", "load_urdf", "derive", "Equations", "LinearSystem", "singularities", "SingularityReport",
    "SingularConfiguration", "constraint_singularities", "ConstraintSingularityReport", "ConstraintConfiguration",
    "DeadPoints", "equilibria", "Equilibrium", "Equilibria", "steady_motions", "SteadyMotion",
    "SteadyMotions", "linearize", "LinearModel", "modes", "Modes",
    "continuation", "Continuation", "kinematics", "Kinematics", "inverse_dynamics", "InverseDynamics",
    "identifiability", "Identifiability",
    "optimal_motion", "OptimalMotion", "OptimalControlError",
    "report", "Report", "compile", "NumericModel", "CompiledModel", "simulate",
    "simulate_batch", "BatchResult", "grid", "Trajectory", "Signal", "dot", "ddot", "t",
    "LagrangianError", "ModelError", "ModelFileError", "ExpressionError", "UnknownNameError",
    "SingularMassMatrixError", "SimulationError", "Status", "OutputFileError",
    "sin", "cos", "tan", "asin", "acos", "atan", "atan2", "sinh", "cosh", "tanh", "exp", "log",
    "sqrt", "Abs", "sign", "pi",
]
