"""Numerics: the state equations x' = f(t, x, u, p), simulation, batch runs and trajectories."""

from ._batch import BatchResult, grid, simulate_batch
from ._compiled import NumericContract, NumericModel, compile, compile_equations
from ._fast import BACKENDS, CompiledModel
from ._inputs import Signal
from ._options import SimulationOptions
from ._simulate import METHODS, output_times, simulate
from ._solvers import DOP853, SciPyMethod, Solver, Variational
from ._trajectory import Trajectory

__all__ = ["NumericContract", "NumericModel", "CompiledModel", "compile", "compile_equations", "simulate",
           "simulate_batch", "BatchResult", "grid", "Trajectory", "METHODS", "BACKENDS", "output_times",
           "SimulationOptions", "Solver", "DOP853", "Variational", "SciPyMethod", "Signal"]
