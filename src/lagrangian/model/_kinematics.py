"""Kinematics in SymEngine: conversion, total time derivatives and velocities of points."""

from __future__ import annotations

from typing import Sequence

import symengine as se
import sympy

from ._symbols import dot, t

__all__ = ["Kinematics", "to_se", "to_sympy"]


def to_se(expr, memo: dict | None = None) -> se.Basic:
    """A SymPy expression (or number) as a SymEngine one, each shared subexpression converted once.

    SymEngine's own conversion walks the tree: a subexpression used twice is converted twice, so the
    world position of a body down a chain of frames (products of the frames' rotations, each entry
    used by three of the next product's) costs a time exponential in the chain's depth. Here sums,
    products and powers are rebuilt from their converted arguments, looked up in `memo` (by
    identity: {id(SymPy node): (node, SymEngine node)}, filled), so that a tree of shared
    subexpressions is converted in a time proportional to its distinct nodes; anything else (a
    symbol, a number, a function of a small argument) is converted by SymEngine."""
    if not isinstance(expr, sympy.Basic) or not expr.args:
        return se.sympify(expr)
    memo = {} if memo is None else memo
    return _to_se(expr, memo)


_SE_BUILD = {sympy.Add: se.Add, sympy.Mul: se.Mul, sympy.Pow: se.Pow}


def _to_se(expr, memo: dict) -> se.Basic:
    hit = memo.get(id(expr))
    if hit is not None:
        return hit[1]
    build = _SE_BUILD.get(type(expr))
    if build is None or not expr.args:
        out = se.sympify(expr)
    else:
        out = build(*[_to_se(a, memo) for a in expr.args])
    memo[id(expr)] = (expr, out)  # the node is kept, so that its id is not reused while memo lives
    return out


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
        self._nodes: dict = {}  # to_se's memo: the subexpressions converted, shared by every expression
        # the frames' velocities and their Jacobians of the Kane form (equations._named._FrameMotion), kept
        # so that what derive builds on them later uses the same expressions: two equal copies of a deep
        # expression compare (in a set, a dict, cse) as whole trees
        self.frame_motion = None

    def se(self, expr) -> se.Basic:
        """`expr` in SymEngine (converted once per expression, and each subexpression shared by
        expressions converted before it only once: see :func:`to_se`)."""
        out = self._cache.get(expr)
        if out is None:
            out = self._cache[expr] = to_se(expr, self._nodes)
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
