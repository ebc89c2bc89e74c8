"""The [optimal_control] table: an optimal motion problem as data, checked in one pass.

The one validator of the problem, used by the model-file reader (problems with key and line) and
by ``lagrangian.optimal_motion``'s keyword arguments (the same rules, the same messages). Nothing
in the table is executed: expressions go through the model's safe parser.

The table (every key optional but ``duration``)::

    [optimal_control]
    duration = 2.0                    # fixed; or [0.5, 10.0]: free between those bounds
    objective = "F**2"                # the integrand: cost = integral of it over the motion
    terminal_cost = "q1**2"           # plus this, at the final state
    minimum_time = false              # plus the duration itself (needs a free duration)
    initial = { q1 = 0.0, q1_dot = 0.0 }     # fixed states at t = 0 (the others free)
    final = { q1 = 1.0, q2 = 3.14159 }       # fixed states at the end
    bounds = { q1 = [-2.0, 2.0] }            # path bounds on coordinates and velocities
    inputs = { F = [-20.0, 20.0] }           # inputs' bounds; a number holds one fixed (others: free)
    path = { track = { expression = "q1 + L*cos(q2)", min = -2.0, max = 2.0 } }
    intervals = 25                    # the first mesh
    tolerance = 1e-6                  # the collocation error to reach by mesh refinement
    max_refinements = 6
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any

import sympy

from .._util import did_you_mean

__all__ = ["OPTIMAL_CONTROL_KEYS", "check_optimal_control", "MAX_INTERVALS"]

OPTIMAL_CONTROL_KEYS = ("duration", "objective", "terminal_cost", "minimum_time", "initial", "final", "bounds",
                        "inputs", "path", "intervals", "tolerance", "max_refinements")
_PATH_KEYS = ("expression", "min", "max")
#: The most intervals a mesh may have (the first mesh and every refinement).
MAX_INTERVALS = 5000

Problem = Callable[[str, str], None]
Expr = Callable[[object, str, Mapping[str, sympy.Basic]], "sympy.Expr | None"]


def _describe(value: object) -> str:
    if isinstance(value, bool):
        return f"the boolean {str(value).lower()}"
    if isinstance(value, str):
        return f"the string {value!r}"[:80]
    if isinstance(value, (int, float)):
        return f"the number {value!r}"
    if isinstance(value, dict):
        return "a table"
    if isinstance(value, (list, tuple)):
        return f"a list of {len(value)}"
    return f"a {type(value).__name__}"


def _number(value: object, key: str, problem: Problem, *, infinite: bool = False) -> float | None:
    """A number (finite unless `infinite`, never NaN), or None after a problem."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        problem(key, f"expected a number, got {_describe(value)}; write a plain number such as 1.5 (no quotes)")
        return None
    try:
        x = float(value)
    except OverflowError:
        x = math.inf
    if math.isnan(x) or (not infinite and math.isinf(x)):
        what = "a number, not NaN" if infinite else "a finite number"
        problem(key, f"expected {what}, got {value!r}; write a number such as 1.5")
        return None
    return x


def _pair(value: object, key: str, problem: Problem, what: str) -> tuple[float, float] | None:
    """[lo, hi] with lo <= hi (infinite ends allowed: -inf, inf)."""
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        problem(key, f"expected {what} as [lower, upper] (two numbers; -inf or inf for no bound), got "
                     f"{_describe(value)}; write for example [-1.0, 1.0]")
        return None
    lo = _number(value[0], f"{key}[0]", problem, infinite=True)
    hi = _number(value[1], f"{key}[1]", problem, infinite=True)
    if lo is None or hi is None:
        return None
    if lo > hi:
        problem(key, f"the lower bound {lo:g} is above the upper bound {hi:g}; write [lower, upper] with "
                     f"lower <= upper, such as [{hi:g}, {lo:g}]")
        return None
    return lo, hi


def _table(value: object, key: str, problem: Problem, example: str) -> dict | None:
    if not isinstance(value, Mapping):
        problem(key, f"expected a table, got {_describe(value)}; write {key.split('.')[-1]} = {example}")
        return None
    return dict(value)


def _states(value: object, key: str, states: list[str], problem: Problem, example: str,
            read: Callable[[object, str], Any]) -> dict:
    table = _table(value, key, problem, example)
    if table is None:
        return {}
    out = {}
    for name, item in table.items():
        if name not in states:
            hint = did_you_mean(str(name), states, 0.5)
            problem(f"{key}.{name}", f"'{name}' is not a coordinate or a velocity{hint}; "
                                     f"{key.split('.')[-1]} names states: {', '.join(states)}")
            continue
        got = read(item, f"{key}.{name}")
        if got is not None:
            out[name] = got
    return out


def check_optimal_control(value: object, names: Mapping[str, sympy.Basic], coordinates: list[str],
                          inputs: list[str], problem: Problem, expr: Expr) -> dict[str, Any] | None:
    """Check an [optimal_control] table and return it validated (or None when it is not a table).

    Parameters
    ----------
    value : the table (a mapping) as read from TOML, or built from keyword arguments.
    names : every name an expression may use (coordinates, velocities, parameters, inputs, t).
    coordinates, inputs : the model's coordinate and input names.
    problem : records one problem: ``problem(key, message)``.
    expr : parses one expression or records a problem and returns None: ``expr(value, key, names)``.

    Returns
    -------
    dict with the keys of :data:`OPTIMAL_CONTROL_KEYS` that were given, each validated: duration
    (float, or (lo, hi) when free), objective and terminal_cost (sympy), minimum_time (bool),
    initial and final ({state: float}), bounds ({state: (lo, hi)}), inputs ({input: (lo, hi) or
    float}), path ({name: (sympy, lo, hi)}), intervals and max_refinements (int), tolerance (float).
    """
    top = "optimal_control"
    table = _table(value, top, problem, '{ duration = 2.0, objective = "F**2" } (or an [optimal_control] header)')
    if table is None:
        return None
    states = list(coordinates) + [f"{c}_dot" for c in coordinates]
    out: dict[str, Any] = {}
    for name in table:
        if name not in OPTIMAL_CONTROL_KEYS:
            hint = did_you_mean(str(name), OPTIMAL_CONTROL_KEYS)
            problem(f"{top}.{name}", f"unknown key '{name}' in [optimal_control]{hint}"
                                     f"; the keys of [optimal_control] are: {', '.join(OPTIMAL_CONTROL_KEYS)}")
    if "duration" not in table:
        problem(top, "[optimal_control] needs the motion's duration: duration = 2.0 (fixed, seconds) or "
                     "duration = [0.5, 10.0] (free between these bounds)")
    else:
        d = table["duration"]
        key = f"{top}.duration"
        if isinstance(d, (list, tuple)):
            pair = _pair(d, key, problem, "a free duration's bounds")
            if pair is not None:
                if not (0 < pair[0] and math.isfinite(pair[1])):
                    problem(key, f"a free duration's bounds must be positive and finite, got [{pair[0]:g}, "
                                 f"{pair[1]:g}]; write for example duration = [0.1, 10.0]")
                else:
                    out["duration"] = pair
        else:
            x = _number(d, key, problem)
            if x is not None:
                if x <= 0:
                    problem(key, f"expected a positive duration (seconds), got {x:g}; write duration = 2.0, or "
                                 "duration = [0.1, 10.0] for a free duration")
                else:
                    out["duration"] = x
    plain = {k: v for k, v in names.items() if not k.endswith("_ddot")}
    for name in ("objective", "terminal_cost"):
        if name in table:
            e = expr(table[name], f"{top}.{name}", plain)
            if e is not None:
                out[name] = e
    if "terminal_cost" in out:
        used = sorted(s.name for s in out["terminal_cost"].free_symbols if s.name in inputs)
        if used:
            problem(f"{top}.terminal_cost", f"the terminal cost uses the input(s) {', '.join(used)}; it is a function "
                                            "of the final state (coordinates, velocities, parameters, t): move input "
                                            "terms into objective")
            del out["terminal_cost"]
    if "minimum_time" in table:
        m = table["minimum_time"]
        if not isinstance(m, bool):
            problem(f"{top}.minimum_time", f"expected true or false, got {_describe(m)}; write minimum_time = true")
        else:
            out["minimum_time"] = m
            if m and "duration" in out and not isinstance(out["duration"], tuple):
                problem(f"{top}.minimum_time", "minimum_time = true needs a free duration, but duration is fixed; "
                                               "write duration = [0.1, 10.0] (its bounds)")
    for name, example in (("initial", "{ q1 = 0.0, q1_dot = 0.0 }"), ("final", "{ q1 = 1.0 }")):
        if name in table:
            out[name] = _states(table[name], f"{top}.{name}", states, problem, example,
                                lambda item, key: _number(item, key, problem))
    if "bounds" in table:
        out["bounds"] = _states(table["bounds"], f"{top}.bounds", states, problem, "{ q1 = [-1.0, 1.0] }",
                                lambda item, key: _pair(item, key, problem, "a state's bounds"))
        for which in ("initial", "final"):
            for s, x in out.get(which, {}).items():
                lo, hi = out["bounds"].get(s, (-math.inf, math.inf))
                if not lo <= x <= hi:
                    problem(f"{top}.{which}.{s}", f"the {which} value {s} = {x:g} is outside its bounds "
                                                  f"[{lo:g}, {hi:g}]: no motion can satisfy both; widen the bounds "
                                                  "or change the value")
    if "inputs" in table:
        got = _table(table["inputs"], f"{top}.inputs", problem, "{ F = [-20.0, 20.0] }")
        out["inputs"] = {}
        for name, item in (got or {}).items():
            key = f"{top}.inputs.{name}"
            if name not in inputs:
                declared = f"the inputs are {', '.join(inputs)}" if inputs else "the model declares no input"
                problem(key, f"'{name}' is not an input{did_you_mean(str(name), inputs, 0.5)}: {declared}")
                continue
            v = (_pair(item, key, problem, "an input's bounds") if isinstance(item, (list, tuple))
                 else _number(item, key, problem))
            if v is not None:
                out["inputs"][name] = v
    if "path" in table:
        got = _table(table["path"], f"{top}.path", problem,
                     '{ track = { expression = "q1", min = -2.0, max = 2.0 } }')
        out["path"] = {}
        for name, item in (got or {}).items():
            key = f"{top}.path.{name}"
            spec = _table(item, key, problem, '{ expression = "q1", min = -2.0, max = 2.0 }')
            if spec is None:
                continue
            bad = [k for k in spec if k not in _PATH_KEYS]
            for k in bad:
                problem(f"{key}.{k}", f"unknown key '{k}' in a path constraint{did_you_mean(str(k), _PATH_KEYS)}; "
                                      f"its keys are: {', '.join(_PATH_KEYS)}")
            if "expression" not in spec:
                problem(key, 'a path constraint needs its expression: expression = "q1" (and min, max)')
                continue
            e = expr(spec["expression"], f"{key}.expression", plain)
            lo = _number(spec["min"], f"{key}.min", problem, infinite=True) if "min" in spec else -math.inf
            hi = _number(spec["max"], f"{key}.max", problem, infinite=True) if "max" in spec else math.inf
            if "min" not in spec and "max" not in spec:
                problem(key, "a path constraint needs min, max or both: min = -2.0, max = 2.0")
                continue
            if lo is not None and hi is not None and lo > hi:
                problem(key, f"min = {lo:g} is above max = {hi:g}; write min <= max")
                continue
            if e is not None and lo is not None and hi is not None and not bad:
                out["path"][name] = (e, lo, hi)
    for name, low, high in (("intervals", 2, MAX_INTERVALS), ("max_refinements", 0, 20)):
        if name in table:
            v = table[name]
            key = f"{top}.{name}"
            if isinstance(v, bool) or not isinstance(v, int):
                problem(key, f"expected a whole number, got {_describe(v)}; write {name} = {max(low, 5)}")
            elif not low <= v <= high:
                problem(key, f"expected {name} between {low} and {high}, got {v}")
            else:
                out[name] = int(v)
    if "tolerance" in table:
        x = _number(table["tolerance"], f"{top}.tolerance", problem)
        if x is not None:
            if x <= 0:
                problem(f"{top}.tolerance", f"expected a positive tolerance, got {x:g}; write tolerance = 1e-6")
            else:
                out["tolerance"] = x
    return out
