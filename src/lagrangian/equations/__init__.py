"""Equations: derive(model), their parts and forms, the singular-mass-matrix diagnosis and the
constraints' (where their Jacobian loses rank, the dead points of a mechanism's drivers)."""

from ._derive import derive
from ._equations import Equations, LinearSystem
from ._constraint_singular import (ConstraintConfiguration, ConstraintSingularityReport, DeadPoints,
                                   constraint_singularities)
from ._singular import SingularConfiguration, SingularityReport, singularities

__all__ = ["derive", "Equations", "LinearSystem", "singularities", "SingularityReport",
           "SingularConfiguration", "constraint_singularities", "ConstraintSingularityReport",
           "ConstraintConfiguration", "DeadPoints"]
