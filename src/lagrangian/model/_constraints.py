"""Constraints: holonomic g(q, t) = 0 and velocity (nonholonomic) a(q, t) . q_dot + b(q, t) = 0.

Each constraint has a name and a Lagrange multiplier ``lambda_<name>``. The equations of a
constrained model read

    M q_ddot = f + G^T lambda,        G q_ddot = c,

where the row of G is dg/dq (holonomic) or a (velocity constraint), and c comes from the time
derivative of the velocity residual w = G q_dot + b (b = dg/dt for a holonomic one):
c = -(dw/dq q_dot + dw/dt). G^T lambda is the generalized force the constraint exerts: with g
written as a length (a distance minus a length), lambda_<name> is the force along dg/dq.
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy

__all__ = ["Constraint", "HOLONOMIC", "VELOCITY"]

HOLONOMIC = "holonomic"
VELOCITY = "velocity"


@dataclass(frozen=True)
class Constraint:
    """A named constraint: ``expression`` = 0 (kind "holonomic": g(q, t); kind "velocity":
    a(q, t) . q_dot + b(q, t), linear in the velocities)."""

    name: str
    expression: sympy.Expr
    kind: str = HOLONOMIC

    @property
    def multiplier(self) -> sympy.Symbol:
        """The Lagrange multiplier ``lambda_<name>``."""
        return sympy.Symbol(f"lambda_{self.name}")
