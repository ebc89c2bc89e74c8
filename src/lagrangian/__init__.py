"""lagrangian: Lagrangian dynamics of mechanical systems.

model -> derive -> Equations -> simulate -> Trajectory.
"""

from sympy import (Abs, acos, asin, atan, atan2, cos, cosh, exp, log, pi, sign, sin, sinh, sqrt, tan,
                   tanh)

from .equations import (Equations, LinearSystem, SingularConfiguration, SingularityReport, derive,
                        singularities)
from .errors import (ExpressionError, LagrangianError, ModelError, ModelFileError, SimulationError,
                     SingularMassMatrixError, UnknownNameError)
from .io import load
from .model import Model, ddot, dot, t
from .numeric import NumericModel, Trajectory, simulate
from .numeric import compile_equations as compile

__version__ = "0.1.0"

__all__ = [
    "Model", "load", "derive", "Equations", "LinearSystem", "singularities", "SingularityReport",
    "SingularConfiguration", "compile", "NumericModel", "simulate", "Trajectory", "dot", "ddot", "t",
    "LagrangianError", "ModelError", "ModelFileError", "ExpressionError", "UnknownNameError",
    "SingularMassMatrixError", "SimulationError",
    "sin", "cos", "tan", "asin", "acos", "atan", "atan2", "sinh", "cosh", "tanh", "exp", "log",
    "sqrt", "Abs", "sign", "pi",
]
