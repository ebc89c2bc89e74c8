"""Symbols: coordinates with their velocities and accelerations, parameters, inputs, time.

Every symbol is a plain SymPy ``Symbol`` without assumptions, so that it survives the round
trip through SymEngine unchanged. A coordinate ``q`` has the velocity ``q_dot`` and the
acceleration ``q_ddot``; time is ``t``.
"""

from __future__ import annotations

import keyword
import re

import sympy

__all__ = ["t", "dot", "ddot", "check_name", "RESERVED_NAMES", "FUNCTION_NAMES"]

#: Time.
t = sympy.Symbol("t")

#: Names of the functions a model expression may call.
FUNCTION_NAMES = (
    "sin", "cos", "tan", "asin", "acos", "atan", "atan2",
    "sinh", "cosh", "tanh", "exp", "log", "sqrt", "abs", "sign",
)
#: Names no coordinate, parameter or input may take.
RESERVED_NAMES = frozenset(("t", "pi") + FUNCTION_NAMES)

_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")


def dot(q: sympy.Symbol) -> sympy.Symbol:
    """The velocity symbol of coordinate `q`: ``dot(theta)`` is ``theta_dot``."""
    return sympy.Symbol(f"{_name_of(q)}_dot")


def ddot(q: sympy.Symbol) -> sympy.Symbol:
    """The acceleration symbol of coordinate `q`: ``ddot(theta)`` is ``theta_ddot``."""
    return sympy.Symbol(f"{_name_of(q)}_ddot")


def _name_of(q) -> str:
    if isinstance(q, str):
        return q
    if isinstance(q, sympy.Symbol):
        return q.name
    raise TypeError(f"expected a coordinate symbol or name, got {q!r} ({type(q).__name__})")


def check_name(name: object, kind: str) -> str | None:
    """Return why `name` cannot name a `kind` (coordinate, parameter, input), or None if it can."""
    a = "an" if kind[:1] in "aeiou" else "a"
    if not isinstance(name, str):
        return f"{a} {kind} name must be a string, got {name!r}"
    if not _NAME.match(name):
        return (f"'{name}' is not a valid {kind} name: use letters, digits and underscores, "
                "starting with a letter (for example 'theta1')")
    if keyword.iskeyword(name):
        return f"'{name}' is a Python keyword and cannot name {a} {kind}: choose another name"
    if name in RESERVED_NAMES:
        return f"'{name}' is reserved (time, pi or a function name) and cannot name {a} {kind}: choose another name"
    if name.endswith("_dot") or name.endswith("_ddot"):
        return (f"'{name}' ends in _dot or _ddot, which is kept for velocities and accelerations: "
                f"choose another {kind} name")
    return None
