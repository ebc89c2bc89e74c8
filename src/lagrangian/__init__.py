"""lagrangian: Lagrangian dynamics of mechanical systems.

model -> derive -> Equations -> simulate -> Trajectory.
"""

from typing import TYPE_CHECKING

from sympy import (Abs, acos, asin, atan, atan2, cos, cosh, exp, log, pi, sign, sin, sinh, sqrt, tan,
                   tanh)

from .equations import (ConstraintConfiguration, ConstraintSingularityReport, DeadPoints, Equations, LinearSystem,
                        SingularConfiguration, SingularityReport, constraint_singularities, derive, singularities)
from .errors import (ExpressionError, LagrangianError, ModelError, ModelFileError, OutputFileError, SimulationError,
                     SingularMassMatrixError, Status, UnknownNameError)
from .io import load, load_urdf, write_model
from .model import Model, ddot, dot, quaternion_rates, t

from ._version import __version__ as __version__

if TYPE_CHECKING:  # the lazy names below, for type checkers and the API reference's static reader (griffe)
    from .analysis import (Continuation, Equilibria, Equilibrium, InverseDynamics, Kinematics, LinearModel, Modes,
                           SteadyMotion, SteadyMotions, continuation, equilibria, inverse_dynamics, kinematics,
                           linearize, modes, steady_motions)
    from .identification import FitResult, Identifiability, fit, identifiability
    from .numeric import (BatchResult, CompiledModel, NumericModel, Signal, Trajectory, compile, grid, simulate,
                          simulate_batch)
    from .optimal_control import OptimalControlError, OptimalMotion, optimal_motion
    from .reporting import Report, report

_LAZY = ("plot",)  # subpackages imported on first use (plot needs Matplotlib)

#: Public names of the numerical, analysis and reporting layers, imported on first use (PEP 562): a
#: command that only derives (lagrangian derive) does not import them (0.4 s of the 0.9 s of
#: `import lagrangian`). ``from lagrangian import simulate`` and ``lg.simulate`` work as before.
_LAZY_NAMES = {
    **dict.fromkeys(("BatchResult", "CompiledModel", "NumericModel", "Signal", "Trajectory", "grid", "simulate",
                     "simulate_batch", "compile"), "numeric"),
    **dict.fromkeys(("Continuation", "Equilibria", "Equilibrium", "LinearModel", "Modes", "SteadyMotion",
                     "SteadyMotions", "continuation", "equilibria", "linearize", "modes", "steady_motions",
                     "InverseDynamics", "Kinematics", "inverse_dynamics", "kinematics"), "analysis"),
    **dict.fromkeys(("FitResult", "Identifiability", "fit", "identifiability"), "identification"),
    **dict.fromkeys(("OptimalControlError", "OptimalMotion", "optimal_motion"), "optimal_control"),
    **dict.fromkeys(("Report", "report"), "reporting"),
}


def __getattr__(name):
    import importlib

    if name in _LAZY:
        return importlib.import_module(f".{name}", __name__)
    package = _LAZY_NAMES.get(name)
    if package is not None:
        value = getattr(importlib.import_module(f".{package}", __name__), name)
        globals()[name] = value  # once
        return value
    if name in set(_LAZY_NAMES.values()):
        return importlib.import_module(f".{name}", __name__)
    raise AttributeError(f"module 'lagrangian' has no attribute '{name}'")


def __dir__():
    return sorted(set(globals()) | set(_LAZY_NAMES))

__all__ = [
    "Model", "load", "load_urdf", "write_model", "derive", "Equations", "LinearSystem", "singularities",
    "SingularityReport", "SingularConfiguration", "constraint_singularities", "ConstraintSingularityReport",
    "ConstraintConfiguration",
    "DeadPoints", "equilibria", "Equilibrium", "Equilibria", "steady_motions", "SteadyMotion",
    "SteadyMotions", "linearize", "LinearModel", "modes", "Modes",
    "continuation", "Continuation", "kinematics", "Kinematics", "inverse_dynamics", "InverseDynamics",
    "identifiability", "Identifiability", "fit", "FitResult",
    "optimal_motion", "OptimalMotion", "OptimalControlError",
    "report", "Report", "compile", "NumericModel", "CompiledModel", "simulate",
    "simulate_batch", "BatchResult", "grid", "Trajectory", "Signal", "dot", "ddot", "t", "quaternion_rates",
    "LagrangianError", "ModelError", "ModelFileError", "ExpressionError", "UnknownNameError",
    "SingularMassMatrixError", "SimulationError", "Status", "OutputFileError",
    "sin", "cos", "tan", "asin", "acos", "atan", "atan2", "sinh", "cosh", "tanh", "exp", "log",
    "sqrt", "Abs", "sign", "pi",
]
