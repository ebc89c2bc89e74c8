"""Kinematics in SymEngine: conversion, total time derivatives and velocities of points."""

from __future__ import annotations

from typing import Sequence

import symengine as se
import sympy

from ._symbols import dot, t

__all__ = ["Kinematics", "to_se", "to_sympy"]


def to_se(expr) -> se.Basic:
    """A SymPy expression (or number) as a SymEngine one."""
    return se.sympify(expr)


def to_sympy(expr) -> sympy.Expr:
    """A SymEngine expression (or number) as a SymPy one."""
    if isinstance(expr, se.Basic):
        return expr._sympy_()
    return sympy.sympify(expr)


class Kinematics:
    """Total time derivatives for coordinates `q`: d/dt f(q, t) = sum df/dq_j q_dot_j + df/dt.

    Parameters
    ----------
    coordinates : sequence of sympy.Symbol
    massive_elements : sequence of elements with `mass` and `position` (for gravity)
    """

    def __init__(self, coordinates: Sequence[sympy.Symbol], massive_elements=()):
        self.q = [se.Symbol(c.name) for c in coordinates]
        self.qd = [se.Symbol(dot(c).name) for c in coordinates]
        self.t = se.Symbol(t.name)
        self.massive_elements = tuple(massive_elements)
        self._cache: dict = {}

    def se(self, expr) -> se.Basic:
        """`expr` in SymEngine (converted once per expression)."""
        out = self._cache.get(expr)
        if out is None:
            out = self._cache[expr] = to_se(expr)
        return out

    def rate(self, expr) -> se.Basic:
        """Total time derivative of a function of q and t."""
        f = self.se(expr)
        out = f.diff(self.t)
        for qj, qdj in zip(self.q, self.qd):
            out = out + f.diff(qj) * qdj
        return out

    def velocity(self, position) -> list[se.Basic]:
        return [self.rate(c) for c in position]
