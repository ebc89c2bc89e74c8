"""Bounds on the work a model or an option may ask for, and the checks of numeric options.

Every computation whose size the user's input decides is bounded by a count (never a clock), and
a request past a bound is refused before the work starts, with the bound and how to raise it:

- ``max_rows`` (default 1,000,000, ``LAGRANGIAN_MAX_ROWS``): output rows of a simulation
  (``t_end / dt + 1``, or ``len(t_eval)``) and its input samples (``t_end / sample_time + 1``);
- ``max_steps`` (default 100,000,000, ``LAGRANGIAN_MAX_STEPS``): fixed steps of the variational
  integrator (``t_end / step``);
- ``max_terms`` (default 100,000, ``LAGRANGIAN_MAX_TERMS``): terms of the expansion of T, V, D, Q
  and each constraint, counted on the tree;
- ``max_exponent`` (default 1,000, ``LAGRANGIAN_MAX_EXPONENT``): the exponent of a power of a
  variable (``x**1000``);
- ``max_coordinates`` (default 100, ``LAGRANGIAN_MAX_COORDINATES``): coordinates of a model.

The numeric options (``t_end``, ``dt``, ``rtol``, ...) are checked by :func:`number_problem`, the
one rule used by the command line's options and by the library's functions where the same value
enters.
"""

from __future__ import annotations

import math
import numbers
import os
from dataclasses import dataclass

from .errors import ModelError

__all__ = ["Limit", "MAX_MAGNITUDE", "MAX_ROWS", "MAX_STEPS", "MAX_TERMS", "MAX_EXPONENT", "MAX_COORDINATES", "LIMITS",
           "number_problem"]


@dataclass(frozen=True)
class Limit:
    """A bound on the work an input may ask for: its default and the environment variable that
    changes it (read at each use, so a running program sees a new value)."""

    name: str
    default: int
    bounds: str

    @property
    def variable(self) -> str:
        """The environment variable that sets it: ``LAGRANGIAN_<NAME>``."""
        return "LAGRANGIAN_" + self.name.upper()

    @property
    def value(self) -> int:
        """The limit in force: the environment variable's value when set, else the default."""
        raw = os.environ.get(self.variable)
        if raw is None or not raw.strip():
            return self.default
        try:
            value = int(raw.strip().replace("_", ""))
        except ValueError:
            value = 0
        if value < 1:
            raise ModelError(f"the environment variable {self.variable}={raw!r} must be a whole number >= 1 "
                             f"(the limit on {self.bounds}; default {self.default:,}); unset it or give e.g. "
                             f"{self.variable}={self.default * 10}")
        return value

    def how_to_raise(self) -> str:
        """The sentence a refusal ends with."""
        return (f"the limit on {self.bounds} is {self.value:,}; to raise it, set the environment variable "
                f"{self.variable} (e.g. {self.variable}={self.value * 10})")


MAX_ROWS = Limit("max_rows", 1_000_000, "output rows and input samples of a simulation")
MAX_STEPS = Limit("max_steps", 100_000_000, "fixed steps of a simulation")
MAX_TERMS = Limit("max_terms", 100_000, "terms of the expansion of an energy, dissipation function, generalized "
                                       "force or constraint")
MAX_EXPONENT = Limit("max_exponent", 1_000, "the exponent of a power of a variable")
MAX_COORDINATES = Limit("max_coordinates", 100, "coordinates of a model")

#: The largest magnitude of a value given to a simulation, an export or a batch (an initial value, a
#: parameter's value): the square root of the largest double is about 1.3e154, so that the products of
#: two such values, as the equations form them, stay finite.
MAX_MAGNITUDE = 1e150

def value_problem(name: str, value) -> str | None:
    """Why `value` cannot be the value of the parameter, input or state component `name` (not a
    finite number, or past :data:`MAX_MAGNITUDE`), or None when it can."""
    if not isinstance(value, numbers.Real) or isinstance(value, bool) or not math.isfinite(value):
        shown = " ".join(repr(value).split())
        shown = shown if len(shown) <= 40 else shown[:37] + "..."
        return f"the value of '{name}' must be a finite number, got {shown}"
    if abs(value) > MAX_MAGNITUDE:
        return (f"the value of '{name}' is {float(value):g}, too large: at most {MAX_MAGNITUDE:g} in magnitude, so "
                "that the products of the equations stay finite in double precision")
    return None


#: Every limit, by name.
LIMITS = {limit.name: limit for limit in (MAX_ROWS, MAX_STEPS, MAX_TERMS, MAX_EXPONENT, MAX_COORDINATES)}


def number_problem(value, name: str, *, positive: bool = False, minimum: float | None = None,
                   maximum: float | None = None, integer: bool = False, example: str | None = None,
                   shown: str | None = None) -> str | None:
    """Why `value` cannot be the numeric option `name`, or None when it can.

    Every number must be finite (not NaN or infinite); `positive` asks for > 0, `minimum` and
    `maximum` bound it (inclusive), `integer` asks for a whole number. `example` is a value shown
    in the message (``"--dt 0.01"``), `shown` the value as the user wrote it (default its repr)."""
    hint = f"; for example {example}" if example else ""
    got = shown if shown is not None else repr(value)
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        kind = "a whole number" if integer else "a number"
        return f"{name} must be {kind}, got {got}{hint}"
    if not math.isfinite(value):
        return f"{name} must be a finite number, got {got}{hint}"
    if integer and value != int(value):
        return f"{name} must be a whole number, got {got}{hint}"
    if positive and not value > 0:
        return f"{name} must be a positive number, got {got}{hint}"
    if minimum is not None and value < minimum:
        return f"{name} must be at least {minimum:g}, got {got}{hint}"
    if maximum is not None and value > maximum:
        return f"{name} must be at most {maximum:g}, got {got}{hint}"
    return None
