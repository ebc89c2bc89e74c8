"""Equilibria of a model with holonomic constraints: the stationary problem in (q, lambda).

At rest (q_dot = 0, q_ddot = 0, inputs constant) the constrained equations
M q_ddot = f + G^T lambda, G q_ddot = c reduce to

    f(q, 0, t, u) + G(q)^T lambda = 0,        g(q) = 0,

n + m equations in the n coordinates and the m multipliers: the forces are balanced by forces the
constraints can exert, on the constraints. This module states that problem for the shared search
(``_stationary``, ``_roots``: exact solutions with SymPy for up to 4 unknowns, the multi-start
numerical search, every candidate checked to be a root, non-isolated sets grouped); its Jacobian in
(q, lambda) is the saddle-point matrix [[df/dq + sum_k lambda_k H_k, G^T], [G, 0]] (H_k the Hessian
of g_k), differentiated once in SymEngine (the one numeric model's ``statics``). A mechanism without
forces (every configuration at rest) is a set of equilibria of dimension n - m, with lambda = 0.

The stability comes from the linearization in independent coordinates
(``_constrained_linear.linearize_constrained``: the reduced M, D and K with the constraint forces'
stiffness), with the directions along a non-isolated set left out as for unconstrained models.

Only scleronomic holonomic constraints: a model with velocity constraints is searched numerically in
its shape coordinates (``_constrained_steady``), and a constraint that depends on t moves, so that no
state stays at rest.
"""

from __future__ import annotations

from types import MappingProxyType

import numpy as np
import sympy

from ..equations import Equations
from ..equations._equations import _depends_on
from ..errors import ModelError
from ..model._kinematics import to_sympy
from ._setting import Setting
from ._stability import DEGENERATE, Assessment, classify_across
from ._stationary import StationaryProblem, _is_zero, _replace, periodic_in, solved_exactly, stationary_problem

__all__ = ["constrained_problem", "constrained_residual", "balancing_multipliers", "assess_constrained",
           "CONSTRAINTS_DEPENDENT", "NO_REDUCTION"]

#: SymPy solves for (q, lambda) exactly up to this many unknowns (a pendulum in Cartesian
#: coordinates in space: x, y, z and the rod's multiplier).
MOST_EXACT_UNKNOWNS = 4

#: The stability where the constraints are dependent (G loses rank): there is no linearization in
#: independent coordinates.
CONSTRAINTS_DEPENDENT = "undetermined (the constraints are dependent there: G loses rank)"
#: Where the declared independent coordinates do not determine the others.
NO_REDUCTION = "undetermined (the independent coordinates do not determine the others there)"


def _statics(equations: Equations):
    """(t, z, u, p) -> (F = f + G^T lambda, g, dF/dq, G) at rest in z = (q, lambda): the one
    numeric model's ``statics``."""
    from ..numeric._compiled import compile_equations

    return compile_equations(equations).statics


# --------------------------------------------------------------------------- the problem
def constrained_problem(equations: Equations, inputs, t: float, exact: bool = True,
                        values: np.ndarray | None = None) -> StationaryProblem:
    """The stationary problem of a model with holonomic constraints only (velocity constraints:
    ``_constrained_steady``), in the variables (q, lambda).

    Raises
    ------
    ModelError
        A constraint that depends on t, or equations that depend on t at rest.
    """
    model = equations.model
    core = equations.core
    moving = [c.name for c, g in zip(model.constraints, core.g) if _depends_on(g, core.t)]
    if moving:
        raise ModelError(
            f"{model.name}: constraint{'s' if len(moving) > 1 else ''} {', '.join(moving)} depend"
            f"{'' if len(moving) > 1 else 's'} on the time t (a constraint that moves), so no state stays at "
            "rest and there is no equilibrium; linearize about a chosen state instead, with "
            "linearize(equations, at=..., t=...), or simulate it")
    base = stationary_problem(equations, inputs, t, exact=False, values=values)  # f at rest, checked free of t
    n, m = equations.n, len(core.g)
    lam = equations.multipliers
    constrained = {i for i, qs in enumerate(core.q) if any(_depends_on(g, qs) for g in core.g)}
    family = tuple(c.name for i, c in enumerate(equations.coordinates)
                   if c.name in base.family and i not in constrained)
    unknowns = tuple(i for i, c in enumerate(equations.coordinates) if c.name not in family) + tuple(range(n, n + m))
    G = [[to_sympy(core.G[k, i]) for i in range(n)] for k in range(m)]
    static = [base.static_sympy[i] + sum((G[k][i] * lam[k] for k in range(m)), sympy.Integer(0)) for i in range(n)]
    static += [to_sympy(g) for g in core.g]
    static = [sympy.Integer(0) if e != 0 and _is_zero(e) else e for e in static]
    variables = (*equations.coordinates, *lam)
    unknown = {variables[i] for i in unknowns}
    rows = tuple(i for i, e in enumerate(static) if e != 0 and e.free_symbols & unknown)
    condition_rows = tuple(i for i, e in enumerate(static) if e != 0 and not e.free_symbols & unknown)
    angles = tuple(base.angles[i] and _periodic_constraints(equations, i) for i in range(n)) + (False,) * m
    problem = _replace(base, unknowns=unknowns, angles=angles, family=family, rows=rows,
                       condition_rows=condition_rows, static_sympy=tuple(static), multipliers=lam)
    if not (exact and rows):
        return problem
    return solved_exactly(problem, inputs, values, most=MOST_EXACT_UNKNOWNS)


def _periodic_constraints(equations: Equations, i: int) -> bool:
    """Whether g and G are 2 pi-periodic in coordinate i (f is checked by the unconstrained test)."""
    s = _statics(equations)
    rng = np.random.default_rng(7)
    p = np.array([v if v is not None else 1.0 for v in equations.parameters.values()], dtype=float)
    p = np.where(np.isfinite(p), p, 1.0)
    u = rng.uniform(-1, 1, len(equations.inputs))
    points = [np.concatenate((rng.uniform(-2, 2, equations.n), rng.uniform(-1, 1, len(equations.core.g))))
              for _ in range(3)]
    return periodic_in(lambda z: s(0.3, z, u, p), points, i, rtol=1e-5)


def constrained_residual(problem: StationaryProblem, setting: Setting, z: np.ndarray):
    """(r, dr/dz): the rows of (f + G^T lambda, g) that must vanish, and their Jacobian in the unknowns."""
    eqs = problem.equations
    n = eqs.n
    F, g, J, G = _statics(eqs)(setting.t, z, setting.u, setting.p)
    m = len(g)
    full = np.zeros((n + m, n + m))
    full[:n, :n], full[:n, n:], full[n:, :n] = J, G.T, G
    rows = list(problem.rows)
    return np.concatenate((F, g))[rows], full[np.ix_(rows, list(problem.unknowns))]


def balancing_multipliers(problem: StationaryProblem, setting: Setting, z: np.ndarray) -> np.ndarray:
    """z with the multipliers that balance the forces at its coordinates best (least squares:
    G^T lambda = -f), a starting point of the search."""
    eqs = problem.equations
    n = eqs.n
    z = np.array(z, float)
    z[n:] = 0.0
    with np.errstate(all="ignore"):
        f, _, _, G = _statics(eqs)(setting.t, z, setting.u, setting.p)
        if np.all(np.isfinite(f)) and np.all(np.isfinite(G)):
            lam = np.linalg.lstsq(G.T, -f, rcond=None)[0]
            if np.all(np.isfinite(lam)):
                z[n:] = lam
    return z


# --------------------------------------------------------------------------- stability
def assess_constrained(problem: StationaryProblem, setting: Setting, z: np.ndarray,
                       tangent: np.ndarray,
                       velocities: np.ndarray | None = None) -> tuple[Assessment, dict[str, float]]:
    """The linearization in independent coordinates about the equilibrium z = (q, lambda), or about
    the steady motion at q with `velocities`, its stability across the set of stationary states
    through it (`tangent`, in the variables), and the dependent coordinates' values there."""
    from ._constrained_linear import _independent, linearize_constrained

    eqs = problem.equations
    n = eqs.n
    names = [c.name for c in eqs.coordinates]
    qd = np.zeros(n) if velocities is None else np.asarray(velocities, float)
    point = {**dict(zip(names, map(float, z[:n]))), **{v.name: float(w) for v, w in zip(eqs.velocities, qd)}}
    empty = np.zeros(0, complex)
    try:
        lin = linearize_constrained(eqs, point, set(names), setting)
    except ModelError as exc:
        if problem.evaluator is not None:  # a steady motion, or a model with velocity constraints
            return Assessment(None, f"undetermined (no linearization there: {exc})", False, empty, qd), {}
        _, _, _, G = _statics(eqs)(setting.t, z, setting.u, setting.p)
        try:
            dep = [i for i in range(n) if i not in _independent(eqs, G)]
        except ModelError:
            dep = []
        reason = NO_REDUCTION if "independent coordinates" in str(exc) else CONSTRAINTS_DEPENDENT
        return Assessment(None, reason, False, empty, qd), {names[i]: float(z[i]) for i in dep}
    ind = [names.index(c) for c in lin.coordinate_names]
    r = len(ind)
    along = [tangent[ind, k] for k in range(tangent.shape[1])]
    along += [np.eye(r)[j] for j, i in enumerate(ind) if names[i] in problem.family]
    if along:
        t, _ = np.linalg.qr(np.array(along).T)
        u, _, _ = np.linalg.svd(np.eye(r) - t @ t.T)
        across = u[:, :r - t.shape[1]]
        P = np.hstack((across, t))
    else:
        P, across = np.eye(r), np.eye(r)
    stability, stable, degenerate, _ = classify_across(lin.A, lin.K, lin.C, lin.G, P, across.shape[1],
                                                      lin.lagrange_dirichlet_applies)
    if degenerate:
        stability, stable = DEGENERATE, False
    dependent = dict(lin.constrained["dependent"])
    return Assessment(lin, stability, stable, lin.eigenvalues, qd), dependent


def forceless_note(problem: StationaryProblem, setting: Setting) -> tuple[str, ...]:
    """The note for a constrained model on which no force acts at rest: every configuration on the
    constraints is an equilibrium (empty when some force acts)."""
    from ._stationary import constant_map

    n = problem.equations.n
    values = {**constant_map(problem, setting), **{mu: 0 for mu in problem.multipliers}}
    for e in problem.static_sympy[:n]:
        e = e.subs(values)
        if not (_is_zero(e) if e.free_symbols else complex(e) == 0):
            return ()
    dimension = n - len(problem.multipliers)
    return (f"no force acts at rest (f = 0 with these inputs): every configuration that meets the constraints "
            f"is an equilibrium, with its multipliers 0, a set of dimension {dimension} (n - m) for each assembly "
            "mode of the mechanism",)


def multiplier_values(problem: StationaryProblem, z: np.ndarray) -> MappingProxyType:
    """{lambda_<name>: value} at the variables z."""
    n = problem.equations.n
    return MappingProxyType({mu.name: float(v) + 0.0 for mu, v in zip(problem.multipliers, z[n:])})
