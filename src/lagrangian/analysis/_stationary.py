"""Stationary states of Lagrange's equations, shared by equilibria and steady motions: the problem.

A stationary state has q_ddot = 0, every coordinate the equations contain constant (its velocity
0), and each cyclic coordinate moving at a constant rate: zero for an equilibrium, given (or given
through its momentum p = dL/dq_dot, Routh's way) for a steady motion. Lagrange's equations then
reduce to

    f(q, q_dot) = 0,  q_dot = the fixed rates (those fixed by momenta solved from p(q, q_dot) = p0),

for the coordinates that are not cyclic (the unknowns). Every row of f must vanish, the rows of
cyclic coordinates included: a coordinate that the equations do not contain but that a constant
force pushes (an Atwood machine, V = -(m1 - m2) g x) has no equilibrium, and it is never reported
as "any x". Rows that contain no unknown are conditions on the parameters.

This module states the problem (which rows, which unknowns, the exact solutions with symbolic
parameters, inputs, rates and momenta) and evaluates its residual; ``_roots`` finds and checks the
roots, ``_stability`` classifies them.

A model with holonomic constraints adds its multipliers to the variables (``_constrained_static``
states that problem: f + G^T lambda = 0 and g = 0 in (q, lambda)); everything here and in
``_roots`` works on the variables, the coordinates followed by the multipliers.
"""

from __future__ import annotations

import math
import sys
from contextlib import contextmanager
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Mapping

import numpy as np
import symengine as se
import sympy

from ..equations import Equations
from ..equations._equations import _depends_on
from ..equations._search import same_point, wrap_angles  # the one rule for angles (re-exported)
from ..errors import ModelError
from ..model._kinematics import to_sympy
from ._linearize import cyclic_coordinates
from ..numeric._compiled import compile_equations
from ._setting import Setting

__all__ = ["StationaryProblem", "stationary_problem", "conserved_cyclic", "state_velocities", "forces",
           "residual", "conditions_hold", "parameter_conditions", "constant_map", "evaluate_exact",
           "normalized_exact", "wrap_angles", "same_point", "solved_exactly", "periodic_in"]

#: The work SymPy may do looking for exact solutions before the numerical search takes over,
#: counted in Python function calls (here about a million a second; the arm of two links takes 3
#: million): a count, not a clock, so that the answer never depends on the machine or its load.
EXACT_CALL_BUDGET = 10_000_000
_MAX_EXACT_UNKNOWNS = 3


# --------------------------------------------------------------------------- the problem
@dataclass(frozen=True, eq=False)
class StationaryProblem:
    """f(q, q_dot) = 0 in a stationary state, for one Equations object; with holonomic constraints,
    f + G^T lambda = 0 and g = 0 in the variables (q, lambda).

    Indices (unknowns, rows, angles) count the variables: the n coordinates, then the multipliers
    (none without constraints).

    Attributes
    ----------
    equations : Equations
    unknowns : tuple of int
        The variables solved for (the coordinates the equations contain, and the multipliers).
    angles : tuple of bool, shape (n + number of multipliers,)
        Which variables are angles (the equations are 2 pi-periodic in them).
    family : tuple of str
        Cyclic coordinates (absent from M and f): the state holds for every value of these.
    rows : tuple of int
        The rows of f that contain an unknown: the equations solved.
    condition_rows : tuple of int
        Rows that contain no unknown and are not identically 0: conditions on the parameters.
    velocities : mapping of int to float
        The fixed rates of moving cyclic coordinates (by coordinate index).
    momenta : mapping of int to float
        The fixed momenta of cyclic coordinates whose rates are found.
    static_sympy : tuple of sympy.Expr, shape (n,)
        f in the stationary state, with symbolic parameters, inputs, rates and momenta.
    constants : tuple of sympy.Symbol
        What exact solutions depend on: the parameters, the inputs, then the rates' and momenta's
        symbols.
    exact : tuple of (dict, conditions), or None
        SymPy's solutions ({coordinate index: expression}) when it found them all.
    exact_functions : tuple
        The numerical form of each exact solution: f(*constant values).
    exact_complete : bool
        SymPy ran to completion (then an empty `exact` means it proved there is no solution).
    exact_velocities : tuple of dict
        For each exact solution, the rates found from fixed momenta ({index: expression}).
    multipliers : tuple of sympy.Symbol
        The constraints' multipliers, the variables after the coordinates (empty without
        constraints).
    evaluator : callable or None
        A numerical residual ``(setting, q) -> (r, dr/dz)`` that replaces the symbolic rows (the
        steady motions of constrained models, ``_constrained_steady``: `static_sympy` is empty).
    """

    equations: Equations
    unknowns: tuple[int, ...]
    angles: tuple[bool, ...]
    family: tuple[str, ...]
    rows: tuple[int, ...]
    condition_rows: tuple[int, ...]
    velocities: Mapping[int, float]
    momenta: Mapping[int, float]
    static_sympy: tuple
    constants: tuple
    exact: tuple | None
    exact_functions: tuple = ()
    exact_complete: bool = False
    exact_velocities: tuple = ()
    multipliers: tuple = ()
    evaluator: object = None
    _contexts: dict = field(default_factory=dict, repr=False)
    _precise: list = field(default_factory=list, repr=False)

    @property
    def variables(self) -> tuple:
        """The symbols of the variables: the coordinates, then the multipliers."""
        return (*self.equations.coordinates, *self.multipliers)

    @property
    def size(self) -> int:
        """The number of variables."""
        return self.equations.n + len(self.multipliers)

    @property
    def moving(self) -> bool:
        """Whether some cyclic coordinate moves (a steady motion rather than an equilibrium)."""
        return bool(self.momenta) or any(v != 0 for v in self.velocities.values())

    def constant_values(self, setting: Setting) -> np.ndarray:
        """Values of `constants` at the setting."""
        return np.array([*setting.p, *setting.u,
                         *(self.velocities[i] for i in sorted(self.velocities) if self.velocities[i]),
                         *(self.momenta[i] for i in sorted(self.momenta))], dtype=float)


def conserved_cyclic(equations: Equations) -> tuple[int, ...]:
    """Indices of the cyclic coordinates whose momentum is conserved: absent from M and f, absent
    from L, and no generalized or damping force on them. Only these can move steadily."""
    family = set(cyclic_coordinates(equations))
    names = {c.name for c in equations.cyclic_coordinates}
    return tuple(i for i, c in enumerate(equations.coordinates) if c.name in family and c.name in names)


def _periodic(equations: Equations, i: int) -> bool:
    """Whether the equations at rest and M are 2 pi-periodic in coordinate i (an angle)."""
    nm = compile_equations(equations)
    rng = np.random.default_rng(7)
    n = equations.n
    p = np.array([v if v is not None else 1.0 for v in equations.parameters.values()], dtype=float)
    p = np.where(np.isfinite(p), p, 1.0)
    u = rng.uniform(-1, 1, len(equations.inputs))
    for _ in range(3):
        q = rng.uniform(-2, 2, n)
        shifted = q.copy()
        shifted[i] += 2 * math.pi
        f1, J1 = nm.static(0.3, q, u, p)
        f2, J2 = nm.static(0.3, shifted, u, p)
        scale = 1.0 + np.abs(f1).max() + np.abs(J1).max()
        if not (np.all(np.isfinite(f1)) and np.allclose(f1, f2, atol=1e-9 * scale)
                and np.allclose(J1, J2, atol=1e-9 * scale)):
            return False
    return True


def periodic_in(evaluate, points, i: int, rtol: float = 0.0) -> bool:
    """Whether `evaluate` (a point -> a tuple of arrays) gives the same arrays, finite, with
    coordinate i a whole turn further, at every one of `points` (to 1e-9 of each array's size, and
    `rtol`)."""
    for z in points:
        shifted = np.array(z, float)
        shifted[i] += 2 * math.pi
        with np.errstate(all="ignore"):
            a, b = evaluate(np.array(z, float)), evaluate(shifted)
        for x, y in zip(a, b):
            scale = 1.0 + np.abs(x).max(initial=0.0)
            if not (np.all(np.isfinite(x)) and np.allclose(x, y, rtol=rtol, atol=1e-9 * scale)):
                return False
    return True


class _OverBudget(BaseException):
    """Raised inside SymPy when it has used its budget (a BaseException: SymPy's own
    ``except Exception`` clauses must not swallow it)."""


@contextmanager
def _call_budget(calls: int):
    """Interrupt the code inside (SymPy) with _OverBudget after `calls` Python function calls in
    this thread: a budget that is the same on every machine and under any load (the profile hook
    is per thread, so the server's worker threads count only their own work)."""
    previous = sys.getprofile()
    count = 0

    def profile(frame, event, arg):
        nonlocal count
        if event == "call":
            count += 1
            if count > calls:
                raise _OverBudget()

    sys.setprofile(profile)
    try:
        yield
    finally:
        sys.setprofile(previous)


def _conditions(solution: dict, assumptions) -> tuple:
    """Where the solution is real: arguments of acos/asin in [-1, 1], of sqrt and log >= 0 / > 0."""
    out = []
    for expr in solution.values():
        for f in expr.atoms(sympy.acos, sympy.asin):
            a = f.args[0]
            out += [sympy.Le(a, 1), sympy.Ge(a, -1)]
        for pw in expr.atoms(sympy.Pow):
            if pw.exp.is_Rational and not pw.exp.is_integer and pw.exp.q % 2 == 0:
                out.append(sympy.Ge(pw.base, 0))
        for f in expr.atoms(sympy.log):
            out.append(sympy.Gt(f.args[0], 0))
    kept = []
    for c in out:
        c = c.subs(assumptions)
        try:
            c = _simplify_relational(c)
        except (TypeError, ValueError):
            pass
        if c is sympy.true:
            continue
        c = c.subs({v: k for k, v in assumptions.items()})
        if c not in kept:
            kept.append(c)
    return tuple(kept)


def _simplify_relational(c):
    """a <= 1 with positive symbols: clear positive denominators (g/(l*Omega**2) <= 1 becomes
    g <= l*Omega**2)."""
    c = sympy.simplify(c)
    if c in (sympy.true, sympy.false) or not isinstance(c, sympy.core.relational.Relational):
        return c
    lhs, rhs = sympy.together(c.lhs - c.rhs).as_numer_denom()
    if rhs.is_positive:
        c = c.func(lhs, 0)
        num = sympy.expand(lhs)
        neg = sympy.Add(*[t for t in sympy.Add.make_args(num) if t.could_extract_minus_sign()])
        pos = num - neg
        c = c.func(pos, -neg)
        c = sympy.simplify(c) if c not in (sympy.true, sympy.false) else c
    return c


def _exact_solutions(variables: tuple, exprs: list, unknowns: tuple[int, ...], constants: tuple,
                     values: np.ndarray, unknown_rates: dict, most: int = _MAX_EXACT_UNKNOWNS):
    """(SymPy's solutions of exprs = 0 for the unknowns, complete): None when it fails, uses up
    EXACT_CALL_BUDGET, or has more than `most` unknowns. `variables` are the symbols the unknowns index;
    `unknown_rates` maps a coordinate index to the expression of its rate (fixed momenta)."""
    qs = [variables[i] for i in unknowns]
    if not exprs or len(qs) > most or sum(sympy.count_ops(e) for e in exprs) > 400:
        return None, False
    # constants whose value is positive are solved as positive symbols: conditions simplify
    assumptions = {c: sympy.Symbol(c.name, positive=True) for c, v in zip(constants, values)
                   if math.isfinite(v) and v > 0}
    back = {v: k for k, v in assumptions.items()}
    try:
        with _call_budget(EXACT_CALL_BUDGET):
            exprs = [sympy.factor(sympy.trigsimp(e.subs(assumptions))) for e in exprs]
            sols = sympy.solve(exprs, qs, dict=True)
    except (NotImplementedError, _OverBudget, ValueError, TypeError, ZeroDivisionError, RecursionError):
        return None, False
    allowed = set(assumptions.values()) | set(constants)
    out, rates = [], []
    for s in sols:
        if set(s) != set(qs) or any(s[q].has(*qs) for q in qs):
            return None, False  # a solution left in terms of other unknowns: not a list of points
        if any(not s[q].free_symbols <= allowed for q in qs):
            return None, False
        sol = {unknowns[k]: s[q].subs(back) for k, q in enumerate(qs)}
        at = {variables[i]: e for i, e in sol.items()}
        rates.append({i: e.subs(at) for i, e in unknown_rates.items()})
        out.append((sol, _conditions(sol, assumptions)))
    return (tuple(out), tuple(rates)), True


def _rate_symbol(equations: Equations, i: int) -> sympy.Symbol:
    return equations.velocities[i]


def _momentum_symbol(equations: Equations, i: int) -> sympy.Symbol:
    return sympy.Symbol(f"p_{equations.coordinates[i].name}")


def stationary_problem(equations: Equations, inputs: Mapping[str, float], t: float, exact: bool = True,
                       velocities: Mapping[int, float] | None = None,
                       momenta: Mapping[int, float] | None = None, values: np.ndarray | None = None
                       ) -> StationaryProblem:
    """The equations in a stationary state, checked: they must not depend on t.

    `velocities` and `momenta` fix the motion of cyclic coordinates (by index); `values` are the
    parameter values (for the sign assumptions of the exact solution)."""
    core = equations.core
    n = equations.n
    velocities = {i: float(v) for i, v in (velocities or {}).items()}
    momenta = {i: float(v) for i, v in (momenta or {}).items()}
    for e in core.f:
        static = e.subs({**{v: se.Integer(0) for v in core.qd},
                         **{se.Symbol(k): v for k, v in inputs.items()}})
        if _depends_on(static, core.t):
            raise ModelError(
                f"{equations.model.name}: at rest the equations still depend on the time t, so there is no "
                "equilibrium (a state that stays at rest); linearize about a chosen state instead, with "
                "linearize(equations, at=..., t=...)")
    family = cyclic_coordinates(equations)
    unknowns = tuple(i for i, c in enumerate(equations.coordinates) if c.name not in family)
    angles = tuple(_periodic(equations, i) for i in range(n))
    # the rates in the stationary state: 0, a fixed value (kept as its symbol), or found from a momentum
    rate: dict = {}
    for i in range(n):
        if i in velocities and velocities[i] != 0:
            rate[i] = _rate_symbol(equations, i)
        elif i not in momenta:
            rate[i] = sympy.Integer(0)
    unknown_rates: dict = {}
    if momenta:
        unknown_rates = _rates_from_momenta(equations, sorted(momenta), rate)
        rate.update(unknown_rates)
    subs = {core.qd[i]: se.sympify(r) for i, r in rate.items()}
    subs.update({core.q[i]: se.Integer(0) for i, c in enumerate(equations.coordinates) if c.name in family})
    static = [to_sympy(e.subs(subs)) for e in core.f]
    static = [sympy.Integer(0) if e != 0 and _is_zero(e) else e for e in static]
    qsyms = {equations.coordinates[i] for i in unknowns}
    rows = tuple(i for i, e in enumerate(static) if e != 0 and e.free_symbols & qsyms)
    condition_rows = tuple(i for i, e in enumerate(static) if e != 0 and not e.free_symbols & qsyms)
    constants = (*equations.parameters, *equations.inputs,
                 *(_rate_symbol(equations, i) for i in sorted(velocities) if velocities[i]),
                 *(_momentum_symbol(equations, i) for i in sorted(momenta)))
    problem = StationaryProblem(equations, unknowns, angles, family, rows, condition_rows,
                                MappingProxyType(velocities), MappingProxyType(momenta), tuple(static),
                                constants, None)
    if not (exact and unknowns and rows):
        return problem
    return solved_exactly(problem, inputs, values, unknown_rates)


def solved_exactly(problem: StationaryProblem, inputs: Mapping[str, float], values: np.ndarray | None,
                   unknown_rates: dict | None = None, most: int = _MAX_EXACT_UNKNOWNS) -> StationaryProblem:
    """The problem with SymPy's solutions, when it finds them all (for at most `most` unknowns, within
    EXACT_CALL_BUDGET); `values` are the parameter values (for the sign assumptions)."""
    equations, velocities, momenta = problem.equations, problem.velocities, problem.momenta
    unknown_rates = unknown_rates or {}
    defaults = np.array([v if v is not None else math.nan for v in equations.parameters.values()], dtype=float)
    given = defaults if values is None else np.where(np.isfinite(values), values, defaults)
    cvalues = np.concatenate((given, [float(inputs.get(u.name, 0.0)) for u in equations.inputs],
                              [velocities[i] for i in sorted(velocities) if velocities[i]],
                              [momenta[i] for i in sorted(momenta)]))
    found, complete = _exact_solutions(problem.variables, [problem.static_sympy[i] for i in problem.rows],
                                       problem.unknowns, problem.constants, cvalues, unknown_rates, most)
    if found is None:
        return _replace(problem, exact_complete=complete)
    sols, rates = found
    conds = parameter_conditions(problem)
    sols = tuple((sol, c + conds) for sol, c in sols)
    functions = tuple(sympy.lambdify(problem.constants, [sol[i] for i in sorted(sol)], modules="numpy")
                      for sol, _ in sols)
    return _replace(problem, exact=sols, exact_functions=functions, exact_complete=True, exact_velocities=rates)


def constant_map(problem: StationaryProblem, setting: Setting, number=float) -> dict:
    """{symbol: value} of the constants and the time at the setting (`number`: float, or
    sympy.Rational for exact arithmetic)."""
    values = {c: number(repr(float(v))) if number is not float else float(v)
              for c, v in zip(problem.constants, problem.constant_values(setting)) if math.isfinite(v)}
    values[problem.equations.t] = number(repr(float(setting.t))) if number is not float else float(setting.t)
    return values


def parameter_conditions(problem: StationaryProblem) -> tuple:
    """The conditions the rows free of unknowns put on the parameters: (g*(m1 - m2) = 0,)."""
    return tuple(sympy.Eq(sympy.factor(problem.static_sympy[i]), 0) for i in problem.condition_rows)


def _replace(problem: StationaryProblem, **changes) -> StationaryProblem:
    import dataclasses

    return dataclasses.replace(problem, _contexts={}, _precise=[], **changes)


def _is_zero(e: sympy.Expr) -> bool:
    """Whether a stationary row vanishes identically (after expansion, or at random points)."""
    if sympy.expand(e) == 0:
        return True
    symbols = sorted(e.free_symbols, key=str)
    if not symbols:
        return False
    rng = np.random.default_rng(4321)
    fn = sympy.lambdify(symbols, e, modules="numpy")
    for _ in range(4):
        with np.errstate(all="ignore"):
            try:
                v = complex(fn(*rng.uniform(0.3, 1.7, len(symbols))))
            except (ZeroDivisionError, ValueError, TypeError, OverflowError):
                return False
        if not (math.isfinite(v.real) and abs(v) <= 1e-12):
            return False
    return True


def _rates_from_momenta(equations: Equations, idx: list[int], rate: dict) -> dict:
    """The rates of the coordinates whose momenta are fixed, in terms of q: p = dL/dq_dot is linear in
    the rates (T* is quadratic), M_cc q_dot_c = p0 - (p with those rates at 0)."""
    core = equations.core
    vel = {core.qd[i]: se.sympify(r) for i, r in rate.items()}
    vel0 = {**vel, **{core.qd[i]: se.Integer(0) for i in idx}}
    Mcc = sympy.Matrix([[to_sympy(core.M[i, j].subs(vel0)) for j in idx] for i in idx])
    rhs = sympy.Matrix([_momentum_symbol(equations, i) - to_sympy(core.p[i].subs(vel0)) for i in idx])
    sol = Mcc.LUsolve(rhs) if len(idx) > 1 else rhs / Mcc[0, 0]
    return {i: sympy.cancel(sympy.together(s)) for i, s in zip(idx, sol)}


# --------------------------------------------------------------------------- numerical residual
def state_velocities(problem: StationaryProblem, setting: Setting, q: np.ndarray):
    """(q_dot, d q_dot/dq): the rates in the stationary state at q (those fixed by momenta solved
    from p(q, q_dot) = p0); the derivative is None when no rate depends on q."""
    eqs = problem.equations
    n = eqs.n
    qd = np.zeros(n)
    for i, v in problem.velocities.items():
        qd[i] = v
    if not problem.momenta:
        return qd, None
    nm = compile_equations(eqs)
    idx = sorted(problem.momenta)
    p0 = np.array([problem.momenta[i] for i in idx])
    p, _, M = nm.momenta(setting.t, np.concatenate((q, qd)), setting.u, setting.p)
    Mcc = M[np.ix_(idx, idx)]
    try:
        qd[idx] = np.linalg.solve(Mcc, p0 - p[idx])
    except np.linalg.LinAlgError:
        qd[idx] = np.nan
        return qd, np.full((n, n), np.nan)
    p, pq, M = nm.momenta(setting.t, np.concatenate((q, qd)), setting.u, setting.p)
    dqd = np.zeros((n, n))
    dqd[idx] = -np.linalg.solve(M[np.ix_(idx, idx)], pq[idx])
    return qd, dqd


def forces(problem: StationaryProblem, setting: Setting, q: np.ndarray):
    """(f, df/dq along the stationary states, q_dot) at q: shapes (n,), (n, n), (n,). With rates fixed
    by momenta, df/dq includes how those rates change with q (Routh's reduction)."""
    nm = compile_equations(problem.equations)
    qd, dqd = state_velocities(problem, setting, q)
    if not problem.moving:
        f, fq = nm.static(setting.t, q, setting.u, setting.p)
        return f, fq, qd
    parts = nm.jacobians(setting.t, np.concatenate((q, qd)), setting.u, setting.p)
    fq = parts["fq"] if dqd is None else parts["fq"] + parts["fqd"] @ dqd
    return parts["f"], fq, qd


def residual(problem: StationaryProblem, setting: Setting, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(r, dr/dz): the rows that must vanish, and their Jacobian in the unknowns (q: all the
    variables, the multipliers after the coordinates)."""
    if problem.evaluator is not None:
        return problem.evaluator(setting, q)
    if problem.multipliers:
        from ._constrained_static import constrained_residual

        return constrained_residual(problem, setting, q)
    f, fq, _ = forces(problem, setting, q)
    rows, unk = list(problem.rows), list(problem.unknowns)
    return f[rows], fq[np.ix_(rows, unk)]


def conditions_hold(problem: StationaryProblem, setting: Setting) -> list[int]:
    """The condition rows that fail at the setting (empty when all hold)."""
    if not problem.condition_rows:
        return []
    values = constant_map(problem, setting)
    failed = []
    for i in problem.condition_rows:
        terms = sympy.Add.make_args(sympy.expand(problem.static_sympy[i]))
        with np.errstate(all="ignore"):
            numbers = [complex(sympy.N(t.subs(values))) for t in terms]
        total = sum(numbers)
        size = sum(abs(x) for x in numbers)
        if not (math.isfinite(abs(total)) and abs(total) <= 1e-12 * size):
            failed.append(i)
    return failed


# --------------------------------------------------------------------------- exact solutions
def evaluate_exact(problem: StationaryProblem, setting: Setting, solution: dict,
                   wrap: bool = True) -> np.ndarray | None:
    """The exact solution's value at the setting, angles wrapped unless `wrap` is False (None where
    it is not real, or where a condition on the parameters fails)."""
    if conditions_hold(problem, setting):
        return None
    k = next(k for k, (sol, _) in enumerate(problem.exact) if sol is solution)
    with np.errstate(all="ignore"):
        try:
            zs = problem.exact_functions[k](*np.asarray(problem.constant_values(setting), dtype=complex))
        except (ZeroDivisionError, ValueError, TypeError):
            return None
    q = np.zeros(problem.size)
    for i, z in zip(sorted(solution), zs):
        z = complex(z)
        if not (math.isfinite(z.real) and math.isfinite(z.imag)) or abs(z.imag) > 1e-9 * (1 + abs(z.real)):
            return None
        q[i] = z.real
    return wrap_angles(q, problem.angles) if wrap else q


def normalized_exact(problem: StationaryProblem, setting: Setting, solution: dict) -> dict[str, sympy.Expr]:
    """{variable name: expression} with whole turns removed from angles so that, at the setting,
    the expression gives the wrapped value (2*pi - acos(c) becomes -acos(c))."""
    raw = evaluate_exact(problem, setting, solution, wrap=False)
    wrapped = wrap_angles(raw, problem.angles)
    out = {problem.variables[i].name: (_wrap_exact(expr, raw[i], wrapped[i]) if problem.angles[i]
                                                    else expr) for i, expr in solution.items()}
    for name in problem.family:
        out[name] = sympy.Integer(0)
    return out


def _wrap_exact(expr: sympy.Expr, value_before: float, value_after: float) -> sympy.Expr:
    turns = round((value_before - value_after) / (2 * math.pi))
    out = expr - 2 * sympy.pi * turns if turns else expr
    if abs(value_after - math.pi) < 1e-12 and out.is_number and out != sympy.pi:
        out = sympy.pi
    return sympy.simplify(out) if turns else out


