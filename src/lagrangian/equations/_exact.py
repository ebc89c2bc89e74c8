"""Exact numbers for the symbolic forms: a float operating point written back as the number it
stands for (2 -> 2, 1.5707963267948966 -> pi/2), used by the symbolic linearization
(analysis/_linearize.py) and the feedback law's exact operating point (control/_feedback.py)."""

from __future__ import annotations

import sympy

__all__ = ["exact_number"]


def exact_number(value: float, given=None) -> sympy.Expr:
    """`given` (the exact value a user wrote, e.g. "pi/2") when there is one; else `value` as an
    integer below 2**53, as a rational multiple of pi or a rational within 1e-12 (relative), or the
    float itself."""
    if given is not None:
        return sympy.sympify(given)
    if value == int(value) and abs(value) < 2**53:
        return sympy.Integer(int(value))
    guess = sympy.nsimplify(value, [sympy.pi], tolerance=1e-12)
    return guess if abs(float(guess) - value) <= 1e-12 * max(1.0, abs(value)) else sympy.Float(value)
