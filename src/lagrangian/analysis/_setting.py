"""The fixed values an analysis works at (parameters, constant inputs, time).

The numbers an analysis needs at points (f and its Jacobians with respect to q, q_dot and u, the
momenta, the damping matrix, the static forces and the constraint parts) are the one numeric
model's (``numeric._compiled.NumericModel``, in the argument order (t, x, u, p), cached per
Equations object).
"""

from __future__ import annotations

from dataclasses import dataclass
from types import MappingProxyType
from typing import Mapping

import numpy as np

from ..equations import Equations
from .._limits import number_problem
from .._util import named_values, real_number, shown_value
from ..errors import ModelError, Problem

__all__ = ["Setting", "resolve_setting", "collect_setting", "check_search"]


@dataclass(frozen=True)
class Setting:
    """Parameter values, constant input values and the time at which an analysis is done.

    `parameters` and `inputs` map names to floats, in the model's order."""

    parameters: Mapping[str, float]
    inputs: Mapping[str, float]
    t: float = 0.0

    @property
    def p(self) -> np.ndarray:
        return np.array(list(self.parameters.values()), dtype=float)

    @property
    def u(self) -> np.ndarray:
        return np.array(list(self.inputs.values()), dtype=float)

    def with_parameter(self, name: str, value: float) -> "Setting":
        return Setting(MappingProxyType({**self.parameters, name: float(value)}), self.inputs, self.t)


def resolve_setting(equations: Equations, params: Mapping | None = None, inputs: Mapping | None = None,
                    t: float = 0.0, *, free: tuple[str, ...] = ()) -> Setting:
    """Check and complete the values: parameters default to the model's, inputs to 0.

    `free` names parameters that need no value (a swept parameter). Every problem is reported at
    once as a :class:`ModelError`."""
    if not isinstance(equations, Equations):
        raise TypeError(f"expected Equations (lagrangian.derive(model)), got {type(equations).__name__}")
    problems: list[Problem] = []
    pnames = tuple(p.name for p in equations.parameters)
    unames = tuple(u.name for u in equations.inputs)
    given_p = named_values(params, pnames, "a parameter of the model", "params", problems,
                           getattr(equations.model, "derived_parameters", None))
    given_u = named_values(inputs, unames, "an input of the model", "inputs", problems)
    values: dict[str, float] = {}
    for sym, default in equations.parameters.items():
        v = given_p.get(sym.name, default)
        if v is None and sym.name not in free:
            if f"params.{sym.name}" not in {p.key for p in problems}:
                problems.append(Problem(f"parameter '{sym.name}' has no value: give one in the model or pass "
                                        f"params={{'{sym.name}': ...}} (--param {sym.name}=... on the command "
                                        "line)", key=f"params.{sym.name}"))
            continue
        values[sym.name] = float("nan") if v is None else float(v)
    if real_number(t) is None:
        problems.append(Problem(f"the time t must be a finite number, got {t!r}", key="t"))
    if problems:
        raise ModelError(problems)
    return Setting(MappingProxyType(values), MappingProxyType({u: given_u.get(u, 0.0) for u in unames}), float(t))


def collect_setting(equations: Equations, params: Mapping | None, inputs: Mapping | None, t: float,
                    problems: list[Problem]) -> Setting | None:
    """resolve_setting() that adds its problems to `problems` (to be reported with others at once)."""
    try:
        return resolve_setting(equations, params, inputs, t)
    except ModelError as exc:
        problems.extend(exc.problems)
        return None


def check_search(exact, starts, seed) -> None:
    """Check the options of the search for equilibria and steady motions: `exact` True or False, `starts` None
    or a whole number >= 0, `seed` a whole number >= 0; one ModelError names each that is not."""
    problems: list[Problem] = []
    if not isinstance(exact, (bool, np.bool_)):
        problems.append(Problem(f"exact must be True or False, got {shown_value(exact)}", key="exact"))
    for name, value, example in (("starts", starts, "starts=48"), ("seed", seed, "seed=0")):
        if value is None and name == "starts":
            continue
        if isinstance(value, np.integer):
            value = int(value)
        why = number_problem(value, name, minimum=0, integer=True, example=example, shown=shown_value(value))
        if why is None and not isinstance(value, int):
            why = f"{name} must be a whole number, got {shown_value(value)}; for example {example}"
        if why is not None:
            problems.append(Problem(why, key=name))
    if problems:
        raise ModelError(problems)
