"""Analysis: equilibria, linearization, stability, modes and parameter continuation.

equations --equilibria--> (Equilibrium, ...) ; equations --linearize--> LinearModel --modes--> Modes ;
equations --continuation--> Continuation (branches and critical parameter values).
"""

from ._continuation import Branch, BranchPoint, Continuation, continuation
from ._equilibria import Equilibria, Equilibrium, equilibria
from ._modes import Modes, modes
from ._steady import SteadyMotion, SteadyMotions, steady_motions
from ._linearize import STABILITY, LinearModel, SymbolicLinearization, classify, linearize
from ._kinematics import Kinematics, KinematicsValues, kinematics
from ._inverse_dynamics import InverseDynamics, inverse_dynamics

__all__ = ["equilibria", "Equilibrium", "Equilibria", "linearize", "LinearModel", "SymbolicLinearization", "classify",
           "STABILITY", "modes", "Modes", "steady_motions", "SteadyMotion", "SteadyMotions", "continuation",
           "Continuation", "Branch", "BranchPoint", "kinematics", "Kinematics", "KinematicsValues",
           "inverse_dynamics", "InverseDynamics"]
