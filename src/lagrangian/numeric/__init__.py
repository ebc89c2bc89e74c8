"""Numerics: the state equations x' = f(t, x, u, p), simulation and trajectories."""

from ._compiled import NumericModel, compile_equations
from ._simulate import METHODS, output_times, simulate
from ._trajectory import Trajectory

__all__ = ["NumericModel", "compile_equations", "simulate", "Trajectory", "METHODS", "output_times"]
