"""equilibria(equations) -> the states at rest, exactly when SymPy can solve for them, with their
stability; right or absent, never invented.

At rest (q_dot = 0, q_ddot = 0, inputs constant) Lagrange's equations reduce to f(q, 0, t, u) = 0:
gravity and springs (dV/dq), the constant generalized forces and, when T* has a part T0 free of the
velocities (steady rotation), the centrifugal forces dT0/dq. No special handling is needed for the
latter: they are in f. The search itself (exact and numerical, every candidate checked to be a
root, non-isolated roots grouped, the reasons when there is none) is in ``_stationary``, shared
with the steady motions.

* Coordinates absent from the equations (cyclic) are reported as families: any value is an
  equilibrium too; they are given the value 0. Every equation must still hold: a coordinate that a
  constant force pushes (dV/dx a non-zero constant) has no equilibrium at all.
* Angles (coordinates the equations contain only through 2 pi-periodic functions) are reported in
  (-pi, pi].
* The exact solutions keep the parameters symbolic, with the conditions for them to be real
  (cos theta = g/(l Omega^2) needs g <= l Omega^2).
* A set of equilibria that is not isolated (a curve, a surface) is reported once, by its point
  nearest q = 0, with its dimension; its stability is the stability across the set.
* Stability: "asymptotically stable", "stable" (Lagrange-Dirichlet, or Routh with cyclic
  coordinates, or, where K is singular, a restoring force of higher odd order), "marginally stable"
  (eigenvalues on the imaginary axis: the linearization is bounded), "unstable" (an eigenvalue with
  a positive real part, or a force of even order where K is singular), or undetermined: where M is
  singular, where the linearization is not finite, or where it is degenerate and nothing decides.
* With holonomic constraints (``_constrained_static``) the unknowns are q and the multipliers:
  f + G^T lambda = 0 on g = 0. Each equilibrium has its multipliers (the forces the constraints
  exert to hold it) and the coordinates taken as dependent; its stability comes from the
  linearization in the independent coordinates.
* With velocity (nonholonomic) constraints (``_constrained_steady``) the unknowns are the shape
  coordinates (those the motion depends on), solved numerically from q_ddot = 0 with the
  multipliers from the saddle-point system; the ignorable coordinates (a wheel's position, heading
  and spin) are a family.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Mapping

import numpy as np
import sympy

from ..equations import Equations
from ..model._constraints import VELOCITY
from ._linearize import LinearModel
from ._setting import Setting, check_search, resolve_setting
from ._roots import (RootSet, completeness_notes, free_axes, group_roots, is_root, mirror_images, no_root_reasons,
                     numeric_roots, search_context)
from ._stability import DEGENERATE, NOT_FINITE, UNDETERMINED, assess
from ._stationary import (StationaryProblem, conditions_hold, evaluate_exact, normalized_exact,
                          parameter_conditions, same_point, stationary_problem)

__all__ = ["equilibria", "Equilibrium", "Equilibria", "make_equilibrium", "UNDETERMINED", "DEGENERATE",
           "NOT_FINITE"]


@dataclass(frozen=True, eq=False)
class Equilibrium:
    """A state at rest (returned by :func:`equilibria`).

    Attributes
    ----------
    coordinates : mapping of str to float
        q at the equilibrium (angles in (-pi, pi]; cyclic coordinates at 0).
    stable : bool
        True when the stability is established: asymptotically stable, stable, or marginally stable
        (bounded linearization); False when unstable or undetermined.
    stability : str
        "asymptotically stable", "stable" (Lagrange-Dirichlet, Routh, or a restoring force of higher
        order), "marginally stable", "unstable", or "undetermined (...)" with the reason: a singular
        mass matrix, a linearization that is not finite, or a degenerate one that does not decide;
        with constraints, also constraints that are dependent there, or independent coordinates
        that do not determine the others.
    eigenvalues : ndarray of complex, shape (2n,)
        Of the state matrix A there (empty where there is no linearization); with constraints, of
        the linearization in the independent coordinates (2 (n - m) of them).
    exact : mapping of str to sympy.Expr, or None
        The solution with symbolic parameters, when SymPy found it.
    conditions : tuple of sympy relationals
        When the exact solution exists (e.g. ``g <= Omega**2*l``); empty when always.
    family : tuple of str
        Cyclic coordinates: the equilibrium holds for every value of these.
    linear_model : LinearModel or None
        The linearization there (None where it does not exist).
    isolated : bool
        False when the equilibrium lies on a curve or surface of equilibria (then this one point
        stands for the whole connected set found).
    dimension : int
        The dimension of that set (0 when isolated; cyclic coordinates not counted).
    along : tuple of str
        When the set runs along coordinate axes: the coordinates that may take any value on it.
    multipliers : mapping of str to float
        A constrained model's Lagrange multipliers there, ``lambda_<name>`` (the constraint forces
        G^T lambda balance the others); empty without constraints.
    exact_multipliers : mapping of str to sympy.Expr, or None
        The multipliers with symbolic parameters, when SymPy found the equilibrium.
    dependent : mapping of str to float
        A constrained model's dependent coordinates (those the independent ones determine; the
        linearization is in the others) and their values; empty without constraints.
    """

    coordinates: Mapping[str, float]
    stable: bool
    stability: str
    eigenvalues: np.ndarray = field(repr=False)
    exact: Mapping[str, sympy.Expr] | None = None
    conditions: tuple = ()
    family: tuple[str, ...] = ()
    linear_model: LinearModel | None = field(default=None, repr=False)
    isolated: bool = True
    dimension: int = 0
    along: tuple[str, ...] = ()
    # keyword-only: SteadyMotion adds positional fields after the ones above
    multipliers: Mapping[str, float] = field(default_factory=lambda: MappingProxyType({}), kw_only=True)
    exact_multipliers: Mapping[str, sympy.Expr] | None = field(default=None, kw_only=True)
    dependent: Mapping[str, float] = field(default_factory=lambda: MappingProxyType({}), kw_only=True)

    def to_dict(self) -> dict:
        """The JSON contract: coordinates, stable, eigenvalues ([re, im] pairs), and stability,
        exact (SymPy strings or null), conditions, family, isolated, dimension, and multipliers,
        exact_multipliers (SymPy strings or null) and dependent ({} and null without constraints)."""
        return {
            "coordinates": dict(self.coordinates),
            "stable": self.stable,
            "stability": self.stability,
            "eigenvalues": [[float(z.real), float(z.imag)] for z in self.eigenvalues],
            "exact": None if self.exact is None else {k: sympy.sstr(v) for k, v in self.exact.items()},
            "conditions": [sympy.sstr(c) for c in self.conditions],
            "family": list(self.family),
            "isolated": self.isolated,
            "dimension": self.dimension,
            "multipliers": dict(self.multipliers),
            "exact_multipliers": (None if self.exact_multipliers is None else
                                  {k: sympy.sstr(v) for k, v in self.exact_multipliers.items()}),
            "dependent": dict(self.dependent),
        }

    def _repr_html_(self) -> str:
        import html

        return f"<pre>{html.escape(self.text())}</pre>"

    def _where(self) -> str:
        coords = ", ".join(f"{k} = {_value_text(v, None if self.exact is None else self.exact.get(k))}"
                           for k, v in self.coordinates.items())
        extra = ""
        if self.family:
            extra += f" (any {', '.join(self.family)})"
        if not self.isolated:
            extra += f" (non-isolated: {_set_text(self.dimension, self.along, self._kind)})"
        if self.dependent:
            extra += f" (dependent: {', '.join(self.dependent)})"
        if self.conditions:
            extra += f" [exists when {' and '.join(condition_text(c) for c in self.conditions)}]"
        if self.multipliers:
            exact = self.exact_multipliers or {}
            extra += "; " + ", ".join(f"{k} = {_value_text(v, exact.get(k))}" for k, v in self.multipliers.items())
        return coords + extra

    _kind = "equilibria"

    def text(self) -> str:
        return f"{self._where()}: {self.stability}"


def _set_text(dimension: int, along: tuple[str, ...], kind: str) -> str:
    if along:
        return f"any {', '.join(along)}"
    shape = {1: "a curve", 2: "a surface"}.get(dimension, f"a {dimension}-dimensional set")
    return f"on {shape} of {kind}"


def condition_text(c) -> str:
    """A condition as text: "g <= Omega**2*l", "g*(m1 - m2) = 0"."""
    if isinstance(c, sympy.Equality):
        return f"{sympy.sstr(c.lhs)} = {sympy.sstr(c.rhs)}"
    return sympy.sstr(c)


def _value_text(v: float, exact) -> str:
    if exact is not None and not exact.is_Number:
        return f"{sympy.sstr(exact)} = {v:.6g}"
    return f"{v:.6g}"


class Equilibria(tuple):
    """The equilibria found: a tuple of :class:`Equilibrium`, sorted by coordinates, with `notes`:
    why there is none (a force that never vanishes, SymPy's proof, a search that found nothing or ran
    away to infinity), or that there may be others (found by the numerical search alone)."""

    def __new__(cls, items=(), notes=()):
        self = super().__new__(cls, items)
        self._notes = tuple(notes)
        return self

    @property
    def notes(self) -> tuple[str, ...]:
        return self._notes

    def text(self, name: str = "the model") -> str:
        if not self:
            return f"Equilibria of {name}: none.\n" + "".join(f"  {n}\n" for n in self.notes).rstrip("\n")
        lines = [f"Equilibria of {name} ({len(self)}):", *(f"  {e.text()}" for e in self)]
        return "\n".join(lines + [f"  note: {n}" for n in self.notes])

    def __repr__(self) -> str:
        return f"Equilibria({tuple.__repr__(self)}, notes={self.notes!r})"


def found_points(problem: StationaryProblem, setting: Setting, *, starts, seed) -> tuple[list[RootSet], object]:
    """The stationary states of a problem at a setting, exact first, checked and grouped, and the
    search context (what the search saw)."""
    ctx = search_context(problem, setting)
    points: list[RootSet] = []
    size = problem.size
    for sol, conds in problem.exact or ():
        q = evaluate_exact(problem, setting, sol)
        if q is None or not is_root(ctx, q) or any(same_point(q, other.q, problem.angles) for other in points):
            continue
        points.append(RootSet(q, np.zeros((len(q), 0)), normalized_exact(problem, setting, sol), conds, sol))
    if problem.unknowns:
        numeric = numeric_roots(problem, setting, starts=starts, seed=seed, ctx=ctx)
        for q in numeric + mirror_images(ctx, numeric):
            if not any(same_point(q, other.q, problem.angles) for other in points):
                points.append(RootSet(q, np.zeros((len(q), 0))))
    elif not conditions_hold(problem, setting) and (problem.evaluator is None or is_root(ctx, np.zeros(size))):
        points.append(RootSet(np.zeros(size), np.zeros((size, 0)),
                              {v.name: sympy.Integer(0) for v in problem.variables},
                              parameter_conditions(problem), {}))
    distinct: list[RootSet] = []
    for r in group_roots(ctx, points):  # polishing may bring two to one point: kept once, the exact first
        if not any(same_point(r.q, other.q, problem.angles) for other in distinct):
            distinct.append(r)
    points = sorted(distinct, key=lambda r: tuple(np.round(r.q, 9)))
    return points, ctx


def equilibria(equations: Equations, *, params: Mapping | None = None, inputs: Mapping | None = None,
               t: float = 0.0, exact: bool = True, starts: int | None = None,
               seed: int = 0) -> Equilibria:
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
        Try SymPy first (for up to 3 unknowns, 4 with constraints counting the multipliers, within a
        budget of work counted in calls, never a clock: the same answer on every machine).
    starts : int
        Number of starting points of the numerical search (default 24 + 24 per unknown coordinate;
        the multipliers of a constrained model follow from each start).
    seed : int
        Seed of the random starting points (results are reproducible).

    Returns
    -------
    Equilibria
        A tuple of :class:`Equilibrium`, sorted by coordinates; empty when there is none, with
        `notes` saying why.

    Raises
    ------
    ModelError
        Bad names or values, equations that depend on t at rest, or a constraint that depends on t.

    Notes
    -----
    With holonomic constraints g(q) = 0 the equilibria solve f + G^T lambda = 0, g = 0 for q and
    the multipliers; each has its `multipliers` and `dependent` coordinates, and its stability
    from the linearization in the independent coordinates. With velocity constraints the search is
    numerical, in the coordinates the motion depends on (see ``steady_motions``), the others a family.
    """
    check_search(exact, starts, seed)
    setting = resolve_setting(equations, params, inputs, t)
    if any(c.kind == VELOCITY for c in equations.model.constraints):
        from ._constrained_steady import steady_problem

        problem = steady_problem(equations, setting, {})
    elif equations.is_constrained:
        from ._constrained_static import constrained_problem

        problem = constrained_problem(equations, setting.inputs, setting.t, exact, values=setting.p)
    else:
        problem = stationary_problem(equations, setting.inputs, setting.t, exact, values=setting.p)
    points, ctx = found_points(problem, setting, starts=starts, seed=seed)
    below: tuple[str, ...] = ()
    if problem.evaluator is not None:
        from ._constrained_steady import above_ground

        points, below = above_ground(problem, setting, points)
    found = tuple(make_equilibrium(problem, setting, r.q, r.exact, r.conditions, r.tangent, r.solution)
                  for r in points)
    notes = below + (no_root_reasons(problem, setting, ctx, "an equilibrium") if not found
                     else completeness_notes(problem, ctx, "the equilibria"))
    if problem.multipliers:
        from ._constrained_static import forceless_note

        notes = forceless_note(problem, setting) + notes
    return Equilibria(found, notes)


def make_equilibrium(problem: StationaryProblem, setting: Setting, q: np.ndarray, exact=None,
                     conditions=(), tangent: np.ndarray | None = None, solution: dict | None = None) -> Equilibrium:
    eqs = problem.equations
    tangent = np.zeros((problem.size, 0)) if tangent is None else tangent
    coords = MappingProxyType({c.name: float(v) for c, v in zip(eqs.coordinates, q)})
    along = free_axes(search_context(problem, setting), q, tangent)
    if problem.evaluator is not None:  # velocity constraints: the shape found numerically
        from ._constrained_static import assess_constrained
        from ._constrained_steady import steady_details

        qd, multipliers = steady_details(problem, setting, q)
        a, dependent = assess_constrained(problem, setting, q, tangent, qd)
        return Equilibrium(coords, a.stable, a.stability, a.eigenvalues, None, (), problem.family, a.linear_model,
                           not tangent.shape[1], tangent.shape[1], along, multipliers=multipliers,
                           dependent=MappingProxyType(dependent))
    if problem.multipliers:
        from ._constrained_static import assess_constrained, multiplier_values

        a, dependent = assess_constrained(problem, setting, q, tangent)
        names = {mu.name for mu in problem.multipliers}
        exact_lambda = None if exact is None else MappingProxyType({k: v for k, v in exact.items() if k in names})
        exact = None if exact is None else MappingProxyType({k: v for k, v in exact.items() if k not in names})
        return Equilibrium(coords, a.stable, a.stability, a.eigenvalues, exact, tuple(conditions), problem.family,
                           a.linear_model, not tangent.shape[1], tangent.shape[1], along,
                           multipliers=multiplier_values(problem, q), exact_multipliers=exact_lambda,
                           dependent=MappingProxyType(dependent))
    exact = None if exact is None else MappingProxyType(dict(exact))
    a = assess(problem, setting, q, tangent, exact, solution)
    return Equilibrium(coords, a.stable, a.stability, a.eigenvalues, exact, tuple(conditions), problem.family,
                       a.linear_model, not tangent.shape[1], tangent.shape[1], along)
