"""equilibria(equations) -> the states at rest, exactly when SymPy can solve for them, with their
stability.

At rest (q_dot = 0, q_ddot = 0, inputs constant) Lagrange's equations reduce to f(q, 0, t, u) = 0:
gravity and springs (dV/dq), the constant generalized forces and, when T* has a part T0 free of the
velocities (steady rotation), the centrifugal forces dT0/dq. No special handling is needed for the
latter: they are in f.

* Coordinates absent from the equations (cyclic) are reported as families: any value is an
  equilibrium too; they are given the value 0.
* Angles (coordinates the equations contain only through 2 pi-periodic functions) are reported in
  (-pi, pi].
* The exact solutions keep the parameters symbolic, with the conditions for them to be real
  (cos theta = g/(l Omega^2) needs g <= l Omega^2); a multi-start numerical search runs as well and
  adds any solution the exact one missed.
"""

from __future__ import annotations

import math
import signal
import threading
from contextlib import contextmanager
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Mapping

import numpy as np
import sympy

from ..equations import Equations
from ..equations._equations import _depends_on
from ..errors import ModelError, SingularMassMatrixError
from ..model._kinematics import to_sympy
from ._linearize import LinearModel, cyclic_coordinates, linearize_at
from ._setting import Setting, derivatives, read_only, resolve_setting

__all__ = ["equilibria", "Equilibrium", "EquilibriumProblem", "equilibrium_problem"]

#: Seconds SymPy may spend looking for exact equilibria before the numerical search takes over.
EXACT_TIME_LIMIT = 5.0
_MAX_EXACT_UNKNOWNS = 3
#: The stability of an equilibrium where M is singular: no linearization exists there.
UNDETERMINED = "undetermined (singular mass matrix)"


@dataclass(frozen=True, eq=False)
class Equilibrium:
    """A state at rest (returned by :func:`equilibria`).

    Attributes
    ----------
    coordinates : mapping of str to float
        q at the equilibrium (angles in (-pi, pi]; cyclic coordinates at 0).
    stable : bool
        False only when the linearization is unstable.
    stability : str
        "asymptotically stable", "stable" (Lagrange-Dirichlet), "marginally stable", "unstable", or
        "undetermined (singular mass matrix)" where M is singular (no eigenvalues then).
    eigenvalues : ndarray of complex, shape (2n,)
        Of the state matrix A there.
    exact : mapping of str to sympy.Expr, or None
        The solution with symbolic parameters, when SymPy found it.
    conditions : tuple of sympy relationals
        When the exact solution is real (e.g. ``g <= Omega**2*l``); empty when always.
    family : tuple of str
        Cyclic coordinates: the equilibrium holds for every value of these.
    linear_model : LinearModel or None
        The linearization there (None where M is singular).
    """

    coordinates: Mapping[str, float]
    stable: bool
    stability: str
    eigenvalues: np.ndarray = field(repr=False)
    exact: Mapping[str, sympy.Expr] | None = None
    conditions: tuple = ()
    family: tuple[str, ...] = ()
    linear_model: LinearModel | None = field(default=None, repr=False)

    def to_dict(self) -> dict:
        """The JSON contract: coordinates, stable, eigenvalues ([re, im] pairs), and stability,
        exact (SymPy strings or null), conditions, family."""
        return {
            "coordinates": dict(self.coordinates),
            "stable": self.stable,
            "stability": self.stability,
            "eigenvalues": [[float(z.real), float(z.imag)] for z in self.eigenvalues],
            "exact": None if self.exact is None else {k: sympy.sstr(v) for k, v in self.exact.items()},
            "conditions": [sympy.sstr(c) for c in self.conditions],
            "family": list(self.family),
        }

    def _repr_html_(self) -> str:
        import html

        return f"<pre>{html.escape(self.text())}</pre>"

    def text(self) -> str:
        coords = ", ".join(f"{k} = {_value_text(v, None if self.exact is None else self.exact.get(k))}"
                           for k, v in self.coordinates.items())
        extra = ""
        if self.family:
            extra += f" (any {', '.join(self.family)})"
        if self.conditions:
            extra += f" [exists when {' and '.join(sympy.sstr(c) for c in self.conditions)}]"
        return f"{coords}{extra}: {self.stability}"


def _value_text(v: float, exact) -> str:
    if exact is not None and not exact.is_Number and exact.is_number:
        return f"{sympy.sstr(exact)} = {v:.6g}"
    if exact is not None and not exact.is_number:
        return f"{sympy.sstr(exact)} = {v:.6g}"
    return f"{v:.6g}"


# --------------------------------------------------------------------------- the problem at rest
@dataclass(frozen=True, eq=False)
class EquilibriumProblem:
    """f(q, 0, t, u) = 0 for one Equations object: which coordinates are unknowns, which are
    angles, and the exact solutions with symbolic parameters (shared by equilibria and
    continuation)."""

    equations: Equations
    unknowns: tuple[int, ...]
    angles: tuple[bool, ...]
    family: tuple[str, ...]
    exact: tuple | None  # tuple of (dict index -> sympy expr, conditions) or None
    static_sympy: tuple  # f at rest with the inputs' values, symbolic parameters
    exact_functions: tuple = ()  # numerical form of each exact solution: f(*parameter values)


def _periodic(equations: Equations, i: int) -> bool:
    """Whether the equations at rest and M are 2 pi-periodic in coordinate i (an angle)."""
    d = derivatives(equations)
    rng = np.random.default_rng(7)
    n = equations.n
    p = np.array([v if v is not None else 1.0 for v in equations.parameters.values()], dtype=float)
    p = np.where(np.isfinite(p), p, 1.0)
    u = rng.uniform(-1, 1, d.m)
    for _ in range(3):
        q = rng.uniform(-2, 2, n)
        shifted = q.copy()
        shifted[i] += 2 * math.pi
        f1, J1 = d.static(q, 0.3, u, p)
        f2, J2 = d.static(shifted, 0.3, u, p)
        scale = 1.0 + np.abs(f1).max() + np.abs(J1).max()
        if not (np.all(np.isfinite(f1)) and np.allclose(f1, f2, atol=1e-9 * scale)
                and np.allclose(J1, J2, atol=1e-9 * scale)):
            return False
    return True


class _TimeUp(Exception):
    pass


@contextmanager
def _time_limit(seconds: float):
    """Interrupt SymPy after `seconds` (only in the main thread, where signals can be used)."""
    if threading.current_thread() is not threading.main_thread() or not hasattr(signal, "setitimer"):
        yield False
        return

    def handler(signum, frame):
        raise _TimeUp()

    old = signal.signal(signal.SIGALRM, handler)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield True
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


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


def _exact_solutions(equations: Equations, static: list, unknowns: tuple[int, ...]):
    """SymPy's solutions of static = 0 for the unknowns, or None when it fails or takes too long."""
    qs = [equations.coordinates[i] for i in unknowns]
    exprs = [e for e in static if e != 0]
    if not exprs or len(qs) > _MAX_EXACT_UNKNOWNS or sum(sympy.count_ops(e) for e in exprs) > 400:
        return None
    # parameters whose value is positive are solved as positive symbols: conditions simplify
    assumptions = {}
    for p, v in equations.parameters.items():
        if v is not None and v > 0:
            assumptions[p] = sympy.Symbol(p.name, positive=True)
    exprs = [sympy.factor(sympy.trigsimp(e.subs(assumptions))) for e in exprs]
    with _time_limit(EXACT_TIME_LIMIT) as limited:
        if not limited and len(qs) > 1:
            return None
        try:
            sols = sympy.solve(exprs, qs, dict=True)
        except (NotImplementedError, _TimeUp, ValueError, TypeError, ZeroDivisionError):
            return None
    back = {v: k for k, v in assumptions.items()}
    out = []
    for s in sols:
        if set(s) != set(qs) or any(s[q].has(*qs) for q in qs):
            return None  # a solution left in terms of other unknowns: not a list of points
        if any(not s[q].free_symbols <= set(assumptions.values()) | set(equations.parameters) for q in qs):
            return None
        sol = {unknowns[k]: s[q].subs(back) for k, q in enumerate(qs)}
        out.append((sol, _conditions(sol, assumptions)))
    return tuple(out)


def equilibrium_problem(equations: Equations, inputs: Mapping[str, float], t: float,
                        exact: bool = True) -> EquilibriumProblem:
    """The equations at rest, checked: they must not depend on t."""
    core = equations.core
    d = derivatives(equations)
    static = [to_sympy(e) for e in d.static_forcing]
    subs = {sympy.Symbol(k): sympy.nsimplify(v) if float(v).is_integer() else sympy.Float(v)
            for k, v in inputs.items()}
    static = [e.subs(subs) for e in static]
    import symengine as se

    for e in d.static_forcing:
        if _depends_on(e.subs({se.Symbol(k): v for k, v in inputs.items()}), core.t):
            raise ModelError(
                f"{equations.model.name}: at rest the equations still depend on the time t, so there is no "
                "equilibrium (a state that stays at rest); linearize about a chosen state instead, with "
                "linearize(equations, at=..., t=...)")
    family = cyclic_coordinates(equations)
    unknowns = tuple(i for i, c in enumerate(equations.coordinates) if c.name not in family)
    angles = tuple(_periodic(equations, i) for i in range(equations.n))
    sols = _exact_solutions(equations, static, unknowns) if exact and unknowns else None
    params = list(equations.parameters)
    functions = tuple(sympy.lambdify(params, [sol[i] for i in sorted(sol)], modules="numpy")
                      for sol, _ in sols or ())
    return EquilibriumProblem(equations, unknowns, angles, family, sols, tuple(static), functions)


# --------------------------------------------------------------------------- numerical search
def wrap_angles(q: np.ndarray, angles) -> np.ndarray:
    """Angles into (-pi, pi]; round-off next to 0 (1e-17) set to 0."""
    q = np.array(q, dtype=float)
    q[np.abs(q) <= 1e-13] = 0.0
    for i, a in enumerate(angles):
        if a:
            w = math.remainder(q[i], 2 * math.pi)
            q[i] = math.pi if w <= -math.pi + 1e-12 else w
    return q


def _same(a: np.ndarray, b: np.ndarray, angles) -> bool:
    diff = a - b
    for i, is_angle in enumerate(angles):
        if is_angle:
            diff[i] = math.remainder(diff[i], 2 * math.pi)
    return bool(np.all(np.abs(diff) <= 1e-6 * (1 + np.abs(a))))


def solve_from(problem: EquilibriumProblem, setting: Setting, start: np.ndarray) -> np.ndarray | None:
    """Newton-type solve of f(q, 0) = 0 from `start` (full q); None when it does not converge."""
    import scipy.optimize

    d = derivatives(problem.equations)
    idx = list(problem.unknowns)
    q = np.array(start, dtype=float)
    u, p, t = setting.u, setting.p, setting.t

    def fun(z):
        q[idx] = z
        f, J = d.static(q, t, u, p)
        return f[idx], J[np.ix_(idx, idx)]

    try:
        with np.errstate(all="ignore"):
            sol = scipy.optimize.root(fun, q[idx], jac=True, method="hybr", options={"xtol": 1e-13})
    except (ValueError, FloatingPointError):
        return None
    if not np.all(np.isfinite(sol.x)):
        return None
    f, J = fun(sol.x)
    scale = 1.0 + np.abs(J).max() * (1.0 + np.abs(sol.x).max())
    if not np.all(np.isfinite(f)) or np.abs(f).max() > 1e-9 * scale:
        return None
    out = np.array(start, dtype=float)
    out[idx] = sol.x
    return wrap_angles(out, problem.angles)


def _starts(problem: EquilibriumProblem, setting: Setting, count: int, seed: int) -> list[np.ndarray]:
    n = problem.equations.n
    rng = np.random.default_rng(seed)
    p = np.abs(setting.p[np.isfinite(setting.p)])
    lengths = sorted({float(x) for x in p if x > 0} | {1.0})
    starts = [np.zeros(n)]
    angles = [i for i in problem.unknowns if problem.angles[i]]
    if 0 < len(angles) <= 8:  # every combination of 0 and pi: the equilibria of chains of pendulums
        for bits in range(1, 2 ** len(angles)):
            q = np.zeros(n)
            for b, i in enumerate(angles):
                q[i] = math.pi if bits >> b & 1 else 0.0
            starts.append(q)
    angle_grid = [0.0, math.pi, math.pi / 2, -math.pi / 2, math.pi / 4, -3 * math.pi / 4]
    for k in range(count):
        q = np.zeros(n)
        for i in problem.unknowns:
            if problem.angles[i]:
                q[i] = angle_grid[k % len(angle_grid)] if k < len(angle_grid) else rng.uniform(-math.pi, math.pi)
            else:
                scale = lengths[k % len(lengths)] * 10.0 ** rng.uniform(-2, 1)
                q[i] = scale * rng.choice([-1, 1]) if k else 0.0
        starts.append(q)
    return starts


def numeric_equilibria(problem: EquilibriumProblem, setting: Setting, *, starts: int | None = None,
                       seed: int = 0, guesses=()) -> list[np.ndarray]:
    """Distinct solutions of the multi-start search (and from `guesses` first)."""
    k = len(problem.unknowns)
    count = starts if starts is not None else 24 + 24 * k
    found: list[np.ndarray] = []
    for start in [*guesses, *_starts(problem, setting, count, seed)]:
        q = solve_from(problem, setting, start)
        if q is not None and not any(_same(q, g, problem.angles) for g in found):
            found.append(q)
    return found


def evaluate_exact(problem: EquilibriumProblem, setting: Setting, solution: dict,
                   wrap: bool = True) -> np.ndarray | None:
    """The exact solution's value at the setting's parameters, angles wrapped unless `wrap` is
    False (None where it is not real)."""
    k = next(k for k, (sol, _) in enumerate(problem.exact) if sol is solution)
    with np.errstate(all="ignore"):
        try:
            zs = problem.exact_functions[k](*np.asarray(setting.p, dtype=complex))
        except (ZeroDivisionError, ValueError, TypeError):
            return None
    q = np.zeros(problem.equations.n)
    for i, z in zip(sorted(solution), zs):
        z = complex(z)
        if not (math.isfinite(z.real) and math.isfinite(z.imag)) or abs(z.imag) > 1e-9 * (1 + abs(z.real)):
            return None
        q[i] = z.real
    return wrap_angles(q, problem.angles) if wrap else q


def normalized_exact(problem: EquilibriumProblem, setting: Setting, solution: dict) -> dict[str, sympy.Expr]:
    """{coordinate name: expression} with whole turns removed from angles so that, at the setting,
    the expression gives the wrapped value (2*pi - acos(c) becomes -acos(c))."""
    raw = evaluate_exact(problem, setting, solution, wrap=False)
    wrapped = wrap_angles(raw, problem.angles)
    out = {problem.equations.coordinates[i].name: (_wrap_exact(expr, raw[i], wrapped[i]) if problem.angles[i]
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


def equilibria(equations: Equations, *, params: Mapping | None = None, inputs: Mapping | None = None,
               t: float = 0.0, exact: bool = True, starts: int | None = None,
               seed: int = 0) -> tuple[Equilibrium, ...]:
    """The equilibria of the equations (states at rest), with their stability.

    Parameters
    ----------
    equations : Equations
    params : mapping of str to float
        Parameter values that override the model's.
    inputs : mapping of str to float
        Constant input values (default 0).
    t : float
        The time, for equations that contain t (they must not, at rest).
    exact : bool
        Try SymPy first (for up to 3 unknowns, within EXACT_TIME_LIMIT seconds).
    starts : int
        Number of starting points of the numerical search (default 24 + 24 per unknown).
    seed : int
        Seed of the random starting points (results are reproducible).

    Returns
    -------
    tuple of Equilibrium
        Sorted by coordinates. Empty when there is none.

    Raises
    ------
    ModelError
        Bad names or values, or equations that depend on t at rest.
    """
    setting = resolve_setting(equations, params, inputs, t)
    problem = equilibrium_problem(equations, setting.inputs, setting.t, exact)
    points: list[tuple[np.ndarray, dict | None, tuple]] = []
    for sol, conds in problem.exact or ():
        q = evaluate_exact(problem, setting, sol)
        if q is None or any(_same(q, other, problem.angles) for other, _, _ in points):
            continue
        points.append((q, normalized_exact(problem, setting, sol), conds))
    if problem.unknowns:
        for q in numeric_equilibria(problem, setting, starts=starts, seed=seed):
            if not any(_same(q, other, problem.angles) for other, _, _ in points):
                points.append((q, None, ()))
    elif not points:
        points.append((np.zeros(equations.n), {c.name: sympy.Integer(0) for c in equations.coordinates}, ()))
    points.sort(key=lambda item: tuple(np.round(item[0], 9)))
    return tuple(make_equilibrium(problem, setting, q, ex, conds) for q, ex, conds in points)


def make_equilibrium(problem: EquilibriumProblem, setting: Setting, q: np.ndarray, exact=None,
                     conditions=()) -> Equilibrium:
    eqs = problem.equations
    names = eqs.state_names
    point = dict(zip(names, [*map(float, q), *([0.0] * eqs.n)]))
    coords = MappingProxyType({c.name: float(v) for c, v in zip(eqs.coordinates, q)})
    exact = None if exact is None else MappingProxyType(dict(exact))
    try:
        lin = linearize_at(eqs, point, setting, exact)
    except SingularMassMatrixError:
        return Equilibrium(coords, False, UNDETERMINED, read_only(np.zeros(0, complex)), exact,
                           tuple(conditions), problem.family, None)
    return Equilibrium(coords, lin.stable, lin.stability, lin.eigenvalues, exact, tuple(conditions),
                       problem.family, lin)
