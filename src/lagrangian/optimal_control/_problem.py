"""The optimal control problem: from keyword arguments or the model file's [optimal_control] table.

Both go through the one validator (``io._optimal.check_optimal_control``): the same keys, rules and
messages. The keyword arguments update the table name by name (a keyword given replaces the table's
entry of that name).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import sympy

from ..errors import ExpressionError, LagrangianError, ModelError, Problem, UnknownNameError
from ..io._optimal import OPTIMAL_CONTROL_KEYS, check_optimal_control
from ..model._expr import parse_expression

__all__ = ["OptimalControlProblem", "OptimalControlError", "build_problem"]


class OptimalControlError(LagrangianError, RuntimeError):
    """The solver found no optimal motion (infeasible problem, iteration limit, ...).

    ``status`` is IPOPT's return status (``"Infeasible_Problem_Detected"``, ...)."""

    def __init__(self, message: str, status: str = ""):
        super().__init__(message)
        self.status = status


@dataclass(frozen=True)
class OptimalControlProblem:
    """An optimal motion problem, validated (see ``lagrangian.optimal_motion`` for the meaning).

    ``duration`` is a float (fixed) or ``(lower, upper)`` (free); ``inputs`` maps every input of
    the model to ``(lower, upper)`` (free) or a float (held); ``path`` maps a name to
    ``(expression, lower, upper)``."""

    duration: float | tuple[float, float]
    objective: sympy.Expr | None = None
    terminal_cost: sympy.Expr | None = None
    minimum_time: bool = False
    initial: Mapping[str, float] = field(default_factory=dict)
    final: Mapping[str, float] = field(default_factory=dict)
    bounds: Mapping[str, tuple[float, float]] = field(default_factory=dict)
    inputs: Mapping[str, Any] = field(default_factory=dict)
    path: Mapping[str, tuple[sympy.Expr, float, float]] = field(default_factory=dict)
    intervals: int = 25
    tolerance: float = 1e-6
    max_refinements: int = 6

    @property
    def free_duration(self) -> bool:
        return isinstance(self.duration, tuple)


def _python_expr(problems: list[Problem]):
    """expr(value, key, names): a string through the safe parser, or a SymPy expression checked."""

    def expr(value: object, key: str, names: Mapping[str, sympy.Basic]):
        if isinstance(value, bool):
            problems.append(Problem(f"expected an expression, got the boolean {value}", key=key))
            return None
        if isinstance(value, (int, float)):
            if not math.isfinite(value):
                problems.append(Problem(f"expected a finite number, got {value!r}", key=key))
                return None
            return sympy.Float(value)
        if isinstance(value, str):
            try:
                return parse_expression(value, names)
            except UnknownNameError as exc:
                problems.append(Problem(f"{exc}; an expression may use the coordinates, velocities "
                                        "(<coordinate>_dot), inputs, parameters and t", key=key))
            except ExpressionError as exc:
                problems.append(Problem(f"malformed expression {value!r}: {exc}", key=key))
            return None
        if isinstance(value, sympy.Basic):
            unknown = sorted(s.name for s in value.free_symbols if s.name not in names)
            if unknown:
                problems.append(Problem(f"the name(s) {', '.join(unknown)} are not known here; an expression may use "
                                        "the coordinates, velocities (<coordinate>_dot), inputs, parameters and t",
                                        key=key))
                return None
            return value
        problems.append(Problem(f"expected an expression (a string such as \"F**2\" or a SymPy expression), got "
                                f"{type(value).__name__}", key=key))
        return None

    return expr


def build_problem(equations, overrides: Mapping[str, Any]) -> OptimalControlProblem:
    """The problem of the model's [optimal_control] table updated by `overrides` (keyword arguments).

    Raises
    ------
    ModelError
        Every problem of the table and the arguments at once.
    """
    model = equations.model
    table = dict(getattr(model, "optimal_control", None) or {})
    given = {k: v for k, v in overrides.items() if v is not None}
    problems: list[Problem] = []
    names = {**model.names(), **getattr(model, "derived_parameters", {})}  # derived: their expressions
    coordinates = [c.name for c in model.q]
    inputs = [u.name for u in model.inputs]
    if given:
        checked = check_optimal_control(given, names, coordinates, inputs,
                                        lambda key, message: problems.append(Problem(message, key=key)),
                                        _python_expr(problems))
        # the duration may come from the table: its absence is judged after the merge
        problems = [p for p in problems if not (p.key == "optimal_control" and "needs the motion's duration"
                                                in p.message)]
        if checked is not None:
            table.update(checked)
    if problems:
        raise ModelError(problems)
    if "duration" not in table:
        raise ModelError(f"no optimal control problem for model '{model.name}': give duration= (and the objective, "
                         "inputs, initial and final states) to optimal_motion, or an [optimal_control] table in the "
                         "model file (duration = 2.0, objective = \"F**2\", ...)")
    if table.get("minimum_time") and not isinstance(table["duration"], tuple):
        raise ModelError("minimum_time=True needs a free duration, but duration is fixed; give duration=(0.1, 10.0) "
                         "(its bounds)")
    input_bounds: dict[str, Any] = {u: (-math.inf, math.inf) for u in inputs}  # not named: free
    input_bounds.update(table.get("inputs", {}))
    _check_constrained_ends(equations, table)
    kwargs = {k: table[k] for k in OPTIMAL_CONTROL_KEYS if k in table and k != "inputs"}
    return OptimalControlProblem(inputs=input_bounds, **kwargs)


def _check_constrained_ends(equations, table) -> None:
    """A constrained model's ends fix at most its degrees of freedom (the others follow the constraints)."""
    if not equations.is_constrained:
        return
    n = equations.n
    holonomic = sum(1 for c in equations.model.constraints if c.kind == "holonomic")
    m = len(equations.model.constraints)
    coordinates = {c.name for c in equations.q}
    for which in ("initial", "final"):
        given = table.get(which, {})
        fixed_q = [s for s in given if s in coordinates]
        fixed_v = [s for s in given if s not in coordinates]
        if len(fixed_q) > n - holonomic or len(fixed_v) > n - m:
            raise ModelError(
                f"the {which} state fixes {len(fixed_q)} coordinate(s) ({', '.join(fixed_q)}) and {len(fixed_v)} "
                f"velocit(ies) ({', '.join(fixed_v)}), but model '{equations.model.name}' has {m} constraint(s): "
                f"at most {n - holonomic} coordinate(s) and {n - m} velocit(ies) can be given, the others follow "
                "from the constraints; give only the independent ones (for example the crank's angle and speed)")
