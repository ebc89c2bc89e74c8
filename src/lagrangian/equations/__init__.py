"""Equations: derive(model), their parts and forms, and the singular-mass-matrix diagnosis."""

from ._derive import derive
from ._equations import Equations, LinearSystem
from ._singular import SingularConfiguration, SingularityReport, singularities

__all__ = ["derive", "Equations", "LinearSystem", "singularities", "SingularityReport",
           "SingularConfiguration"]
