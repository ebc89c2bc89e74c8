"""continuation(equations, parameter, values) -> Continuation: the equilibria and their stability as
one parameter varies, the branches they form, and the critical values of the parameter.

When SymPy solves for the equilibria with symbolic parameters (equilibria' exact path), each
solution is a branch, followed exactly; its critical values are found exactly too: where a branch
starts or ends (the boundary of its existence condition, g = l Omega^2) and where its stability can
change (det K = 0 along the branch). Otherwise the branches are followed numerically: the
equilibria found at one value seed the search at the next, points are joined to the nearest one of
the previous value, and a change of stability or a branch ending between two values is located by
bisection.

A model with holonomic constraints g(q) = 0 is continued the same way in the variables z = (q, lambda):
its equilibria are the stationary points on the constraint manifold, f(q, 0) + G(q)^T lambda = 0 and
g(q) = 0, the multipliers lambda unknown (``_constrained_static``); the exact critical values are
the zeros of the determinant of that system's Jacobian in z along a branch (the bordered stiffness
[[-K - sum_k lambda_k H_k, G^T], [G, 0]], singular where the stiffness reduced to the constraint
manifold is), and the stability is the constrained linearization's (in independent coordinates).
Branches are joined by their coordinates q.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Mapping, Sequence

import numpy as np
import sympy

from ..equations import Equations
from ..equations._search import angle_difference
from .._progress import progress
from ..errors import ModelError
from ..model._constraints import VELOCITY
from ._equilibria import make_equilibrium
from ._roots import numeric_roots, solve_from
from ._stationary import StationaryProblem, evaluate_exact, normalized_exact, same_point, stationary_problem
from .._limits import MAX_MAGNITUDE
from .._util import did_you_mean, number_array, read_only, shown_value
from ._setting import Setting, resolve_setting

__all__ = ["continuation", "Continuation", "Branch", "BranchPoint"]


@dataclass(frozen=True)
class BranchPoint:
    """One equilibrium on a branch: the parameter value, q, and its stability; with constraints,
    the multipliers there too (``lambda_<name>``; empty without constraints)."""

    param: float
    coordinates: Mapping[str, float]
    stable: bool
    stability: str
    eigenvalues: np.ndarray = field(repr=False)
    multipliers: Mapping[str, float] = field(default_factory=lambda: MappingProxyType({}), kw_only=True)

    def to_dict(self) -> dict:
        """{param, coordinates, stable}, and multipliers for a constrained model."""
        out = {"param": self.param, "coordinates": dict(self.coordinates), "stable": self.stable}
        if self.multipliers:
            out["multipliers"] = dict(self.multipliers)
        return out


@dataclass(frozen=True)
class Branch:
    """A connected set of equilibria along the parameter.

    `exact` is the symbolic solution ({coordinate: expression}, and {lambda_<name>: expression} for
    the multipliers of a constrained model) when the branch is an exact one."""

    points: tuple[BranchPoint, ...]
    exact: Mapping[str, sympy.Expr] | None = None

    @property
    def params(self) -> np.ndarray:
        return read_only([p.param for p in self.points])

    @property
    def stable(self) -> np.ndarray:
        return read_only([p.stable for p in self.points])

    def coordinate(self, name: str) -> np.ndarray:
        """The values of one coordinate along the branch."""
        return read_only([p.coordinates[name] for p in self.points])


@dataclass(frozen=True, eq=False)
class Continuation:
    """Branches of equilibria along a parameter (returned by :func:`continuation`).

    Attributes
    ----------
    parameter : str
    values : ndarray
        The parameter values visited.
    coordinate_names : tuple of str
    branches : tuple of Branch
    critical_values : tuple of float
        Where stability changes or branches meet, ascending.
    critical_exact : tuple of sympy.Expr or None
        The exact form of each critical value (None where it was found numerically).
    """

    equations: Equations = field(repr=False)
    parameter: str
    values: np.ndarray = field(repr=False)
    coordinate_names: tuple[str, ...]
    branches: tuple[Branch, ...]
    critical_values: tuple[float, ...]
    critical_exact: tuple = ()

    def to_dict(self) -> dict:
        """The JSON contract: branches (each a list of {param, coordinates, stable}) and
        critical_values (numbers), with parameter and critical_values_exact (SymPy strings or null)."""
        return {
            "parameter": self.parameter,
            "coordinates": list(self.coordinate_names),
            "branches": [[p.to_dict() for p in b.points] for b in self.branches],
            "critical_values": [float(c) for c in self.critical_values],
            "critical_values_exact": [None if e is None else sympy.sstr(e) for e in self.critical_exact],
        }

    def _repr_html_(self) -> str:
        import html

        return f"<pre>{html.escape(self.text())}</pre>"

    def text(self) -> str:
        lines = [f"Equilibria of {self.equations.model.name} for {self.parameter} from {self.values[0]:g} "
                 f"to {self.values[-1]:g}: {len(self.branches)} branch{'es' if len(self.branches) != 1 else ''}"]
        for k, b in enumerate(self.branches):
            first, last = b.points[0], b.points[-1]
            form = (", ".join(f"{c} = {sympy.sstr(e)}" for c, e in b.exact.items()) if b.exact
                    else ", ".join(f"{c} from {first.coordinates[c]:.4g} to {last.coordinates[c]:.4g}"
                                   for c in self.coordinate_names))
            critical = set(self.critical_values)
            runs = [r for r in _runs(b) if not (r[1] == r[2] and b.points[r[1]].param in critical)] or _runs(b)
            stab = "; ".join(f"{'stable' if s else 'unstable'} for {self.parameter} in [{b.points[i].param:.4g}, "
                             f"{b.points[j].param:.4g}]" for s, i, j in runs)
            lines.append(f"  branch {k + 1}: {form}: {stab}")
        if self.critical_values:
            crit = ", ".join(f"{sympy.sstr(e)} = {v:.6g}" if e is not None and not e.is_Number else f"{v:.6g}"
                             for v, e in zip(self.critical_values, self.critical_exact))
            lines.append(f"  critical values of {self.parameter}: {crit}")
        else:
            lines.append(f"  no critical value of {self.parameter} in this range")
        return "\n".join(lines)

    def plot(self, coordinate: str | None = None, **kwargs):
        """The bifurcation diagram (see :func:`lagrangian.plot.bifurcation_diagram`)."""
        from ..plot._bifurcation import bifurcation_diagram

        return bifurcation_diagram(self, coordinate, **kwargs)


def _runs(branch: Branch) -> list[tuple[bool, int, int]]:
    """(stable, first index, last index) of each stretch of equal stability."""
    out: list[tuple[bool, int, int]] = []
    for i, p in enumerate(branch.points):
        if out and out[-1][0] == p.stable:
            out[-1] = (p.stable, out[-1][1], i)
        else:
            out.append((p.stable, i, i))
    return out


def continuation(equations: Equations, parameter: str, values: Sequence[float], *,
                 params: Mapping | None = None, inputs: Mapping | None = None, t: float = 0.0,
                 exact: bool = True) -> Continuation:
    """Follow the equilibria and their stability as `parameter` takes `values`.

    Parameters
    ----------
    equations : Equations
    parameter : str
        The parameter that varies (e.g. "Omega").
    values : array_like of float
        Its values, in order (``numpy.linspace(0, 8, 201)``).
    params, inputs : mapping of str to float
        Values of the other parameters (default: the model's) and of the inputs (default 0).
    t : float
        The time, for models that contain t.
    exact : bool
        Use SymPy's exact solutions and critical values where it finds them.

    Returns
    -------
    Continuation

    Raises
    ------
    ModelError
        An unknown parameter, bad values, a constraint that depends on t, or a velocity constraint.

    Notes
    -----
    With holonomic constraints g(q) = 0 the branches are those of f + G^T lambda = 0, g = 0 in
    (q, lambda): each point has its `multipliers`, and its stability comes from the linearization
    in independent coordinates.
    """
    velocity = [c.name for c in equations.model.constraints if c.kind == VELOCITY]
    if velocity:
        raise ModelError(
            f"{equations.model.name}: the continuation of equilibria follows the solutions of f(q) + G(q)^T lambda "
            f"= 0, g(q) = 0 (holonomic constraints), and velocity constraint{'s' if len(velocity) > 1 else ''} "
            f"{', '.join(velocity)} (a(q) . q_dot + b = 0, not the derivative of any g(q) = 0) leave"
            f"{'' if len(velocity) > 1 else 's'} the coordinates they do not hold free: there is no such system in "
            "q and lambda to continue; call equilibria(equations, params={...}) at each value instead")
    names = tuple(p.name for p in equations.parameters)
    if not isinstance(parameter, str):
        raise ModelError(f"the parameter to vary must be its name (text), one of {', '.join(names) or 'none'}; "
                         f"got {type(parameter).__name__} {shown_value(parameter)}")
    if parameter not in names:
        raise ModelError(f"'{parameter}' is not a parameter of {equations.model.name}"
                         + did_you_mean(parameter, names)
                         + f"; the parameters are {', '.join(names) or 'none'}")
    given = values
    values = number_array(values)
    values = np.full(1, np.nan) if values is None else values.ravel()
    if values.size < 2 or not np.all(np.isfinite(values)) or not (np.all(np.diff(values) > 0)
                                                                 or np.all(np.diff(values) < 0)):
        raise ModelError(f"the values of {parameter} must be at least 2 finite numbers in increasing (or "
                         f"decreasing) order, e.g. numpy.linspace(0, 8, 201); got {shown_value(given)}")
    if np.max(np.abs(values)) > MAX_MAGNITUDE:
        raise ModelError(f"the values of {parameter} reach {np.max(np.abs(values)):g}, too large: at most "
                         f"{MAX_MAGNITUDE:g} in magnitude, so that the products of the equations stay finite in "
                         "double precision")
    if isinstance(params, Mapping):
        params = {k: v for k, v in params.items() if str(getattr(k, "name", k)) != parameter}
    base = resolve_setting(equations, params, inputs, t, free=(parameter,))
    if equations.is_constrained:
        from ._constrained_static import constrained_problem

        problem = constrained_problem(equations, base.inputs, base.t, exact, values=base.p)
    else:
        problem = stationary_problem(equations, base.inputs, base.t, exact, values=base.p)
    settings = [base.with_parameter(parameter, v) for v in values]
    exact_branches = _exact_branches(problem, settings, parameter) if problem.exact else None
    if exact_branches is not None:
        branches, crit = exact_branches
    else:
        branches, crit = _numeric_branches(problem, settings, parameter), []
    changes, ends = _numeric_critical(problem, settings, parameter, branches)
    critical: list[tuple[float, sympy.Expr | None]] = list(crit)
    span = abs(values[-1] - values[0])
    for v in changes + ends:  # exact values first, then changes of stability, then ends of branches
        if not any(abs(v - c) <= 1e-6 * (1 + abs(c)) + 2 * span / len(values) for c, _ in critical):
            critical.append((v, None))
    critical.sort(key=lambda item: item[0])
    return Continuation(equations, parameter, read_only(values),
                        tuple(c.name for c in equations.coordinates), tuple(branches),
                        tuple(c for c, _ in critical), tuple(e for _, e in critical))


def _point(problem: StationaryProblem, setting: Setting, q: np.ndarray, parameter: str,
           exact=None) -> BranchPoint:
    """The branch point at the variables q (the coordinates, then a constrained model's multipliers)."""
    e = make_equilibrium(problem, setting, q, exact)
    return BranchPoint(setting.parameters[parameter], e.coordinates, e.stable, e.stability, e.eigenvalues,
                       multipliers=e.multipliers)


def _exact_branches(problem: StationaryProblem, settings: list[Setting], parameter: str):
    """Branches from the exact solutions; None when the numerical search finds equilibria the exact
    solutions miss (then the numerical continuation is used)."""
    critical = _exact_critical(problem, settings, parameter)
    # visit the critical values too: the branches then meet where they should, with no gap
    base, values = settings[0], [s.parameters[parameter] for s in settings]
    grid = sorted(set(values) | {v for v, _ in critical}, reverse=values[0] > values[-1])
    settings = [base.with_parameter(parameter, v) for v in grid]
    branches: list[Branch] = []
    bar = progress(len(problem.exact) * len(settings), f"following {parameter}")
    for sol, conds in problem.exact:
        exact = None
        run: list[BranchPoint] = []
        for s in settings:
            bar.update()
            q = evaluate_exact(problem, s, sol)
            if q is None:
                if run:
                    branches.append(Branch(tuple(run), exact))
                run = []
                continue
            if exact is None:
                exact = MappingProxyType(normalized_exact(problem, s, sol))
            run.append(_point(problem, s, q, parameter))
        if run:
            branches.append(Branch(tuple(run), exact))
    bar.close()
    # drop branches that duplicate another one (the same points, e.g. 2 pi apart)
    unique: list[Branch] = []
    for b in branches:
        if not any(len(b.points) == len(o.points) and all(
                p.param == r.param and same_point(_z(problem, p), _z(problem, r), problem.angles)
                for p, r in zip(b.points, o.points))
                for o in unique):
            unique.append(b)
    # check on a few values that no equilibrium is missing
    for s in settings[:: max(1, len(settings) // 8)]:
        known = [_z(problem, p) for b in unique for p in b.points if p.param == s.parameters[parameter]]
        for q in numeric_roots(problem, s, starts=16):
            if not any(same_point(q, k, problem.angles) for k in known):
                return None
    return unique, critical


def _z(problem: StationaryProblem, p: BranchPoint) -> np.ndarray:
    """The variables of a branch point: q, then the multipliers of a constrained model."""
    return np.array([p.coordinates[c.name] for c in problem.equations.coordinates]
                    + [p.multipliers[mu.name] for mu in problem.multipliers])


def _exact_critical(problem: StationaryProblem, settings: list[Setting], parameter: str):
    """Exact critical values in the range: boundaries of the existence conditions and zeros of
    det K along each exact branch (with constraints, of the bordered stiffness' determinant)."""
    psym = sympy.Symbol(parameter)
    lo, hi = sorted((settings[0].parameters[parameter], settings[-1].parameters[parameter]))
    others = {sympy.Symbol(k): v for k, v in {**settings[0].parameters, **settings[0].inputs}.items() if k != parameter}
    idx = list(problem.unknowns)
    variables = problem.variables
    # -K at m = 0; with constraints the Jacobian of (f + G^T lambda, g) in (q, lambda): the bordered stiffness
    K = (sympy.Matrix([problem.static_sympy[i] for i in idx]).jacobian([variables[i] for i in idx])
         if idx else sympy.zeros(0))
    candidates: list[sympy.Expr] = []
    for sol, conds in problem.exact:
        for c in conds:
            candidates += _solve_for(sympy.Eq(c.lhs, c.rhs), psym)
        if idx:
            detK = sympy.simplify(K.subs({variables[i]: e for i, e in sol.items()}).det())
            if detK != 0:
                candidates += _solve_for(sympy.Eq(detK, 0), psym)
    out: list[tuple[float, sympy.Expr]] = []
    for c in candidates:
        try:
            v = complex(sympy.N(c.subs(others)))
        except (TypeError, ValueError):
            continue
        if abs(v.imag) > 1e-12 * (1 + abs(v.real)) or not math.isfinite(v.real):
            continue
        v = v.real
        if lo - 1e-12 <= v <= hi + 1e-12 and not any(abs(v - w) <= 1e-9 * (1 + abs(w)) for w, _ in out):
            out.append((v, c))
    return out


def _solve_for(eq, symbol) -> list:
    if symbol not in eq.free_symbols:
        return []
    try:
        sols = sympy.solve(eq, symbol)
    except (NotImplementedError, ValueError, TypeError):
        return []
    return [s for s in sols if not s.has(*[c for c in eq.free_symbols if c.name.endswith("_dot")])]


def _numeric_branches(problem: StationaryProblem, settings: list[Setting], parameter: str) -> list[Branch]:
    open_runs: list[list[BranchPoint]] = []
    closed: list[list[BranchPoint]] = []
    previous: list[np.ndarray] = []
    bar = progress(len(settings), f"following {parameter}")
    for s in settings:
        bar.update()
        found = numeric_roots(problem, s, starts=8 + 8 * len(problem.unknowns), guesses=previous)
        points = [_point(problem, s, q, parameter) for q in found]
        still_open: list[list[BranchPoint]] = []
        taken = set()
        for run in open_runs:
            last = _z(problem, run[-1])
            best, dist = None, math.inf
            for k, p in enumerate(points):
                if k in taken:
                    continue
                d = _distance(problem, _z(problem, p), last)
                if d < dist:
                    best, dist = k, d
            if best is not None and dist <= _reach(problem, last):
                taken.add(best)
                run.append(points[best])
                still_open.append(run)
            else:
                closed.append(run)
        for k, p in enumerate(points):
            if k not in taken:
                still_open.append([p])
        open_runs = still_open
        previous = found
    bar.close()
    return [Branch(tuple(r)) for r in closed + open_runs]


def _distance(problem: StationaryProblem, a: np.ndarray, b: np.ndarray) -> float:
    """The largest difference of the coordinates of the variables a and b (angles modulo 2 pi; a
    constrained model's multipliers, forces, are not compared)."""
    n = problem.equations.n
    diff = angle_difference(a[:n], b[:n], problem.angles[:n])
    return float(np.abs(diff).max()) if diff.size else 0.0


def _reach(problem: StationaryProblem, z: np.ndarray) -> float:
    """How far a branch may move between two values of the parameter, in the coordinates."""
    return 0.5 * (1 + np.abs(z[:problem.equations.n]).max(initial=0.0))


def _numeric_critical(problem: StationaryProblem, settings: list[Setting], parameter: str,
                      branches: list[Branch]) -> list[float]:
    """(stability changes along each branch, ends of branches inside the range), each located by
    bisection."""
    values = [s.parameters[parameter] for s in settings]
    base = settings[0]
    out: list[float] = []
    for b in branches:
        for a, c in zip(b.points, b.points[1:]):
            if a.stable == c.stable:
                continue
            lo, hi, q = a.param, c.param, _z(problem, a)
            for _ in range(50):
                mid = (lo + hi) / 2
                s = base.with_parameter(parameter, mid)
                qm = solve_from(problem, s, q)
                if qm is None:
                    break
                stable = make_equilibrium(problem, s, qm).stable
                if stable == a.stable:
                    lo, q = mid, qm
                else:
                    hi = mid
                if abs(hi - lo) <= 1e-12 * (1 + abs(mid)):
                    break
            out.append((lo + hi) / 2)
    ends: list[float] = []
    ordered = sorted(values)
    for b in branches:
        for end in (b.points[0], b.points[-1]):
            # the neighbouring value of the grid beyond this end, where the branch was not found
            k = int(np.searchsorted(ordered, end.param))
            before = ordered[k - 1] if k > 0 else None
            after = ordered[k + 1] if k + 1 < len(ordered) and ordered[k] == end.param else (
                ordered[k] if k < len(ordered) and ordered[k] != end.param else None)
            params = [p.param for p in b.points]
            beyond = before if end.param == min(params) else after
            if beyond is not None:
                ends.append(_branch_end(problem, base, parameter, end, beyond))
    return sorted(out), sorted(ends)


def _branch_end(problem: StationaryProblem, base: Setting, parameter: str, end: BranchPoint,
                beyond: float) -> float:
    """Where a branch that exists at end.param and not at `beyond` ends, by bisection: the branch
    exists at a value when the solve started from its last point converges nearby."""
    inside, outside, q = end.param, beyond, _z(problem, end)
    reach = _reach(problem, q)
    for _ in range(60):
        mid = (inside + outside) / 2
        qm = solve_from(problem, base.with_parameter(parameter, mid), q)
        if qm is not None and _distance(problem, qm, q) <= reach:
            inside, q = mid, qm
        else:
            outside = mid
        if abs(outside - inside) <= 1e-10 * (1 + abs(inside)):
            break
    return (inside + outside) / 2
