"""Equations: derive(model), their parts and forms, and the singular-mass-matrix diagnosis."""

from ._derive import derive
from ._equations import Equations, LinearSystem

__all__ = ["derive", "Equations", "LinearSystem"]
