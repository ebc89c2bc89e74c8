"""steady_motions(equations, velocities=...) -> the steady motions (relative equilibria) with their
stability: the non-cyclic coordinates constant, the cyclic ones turning at constant rates.

A cyclic coordinate (absent from L, with no generalized or damping force on it) has a conserved
momentum p = dL/dq_dot, and the system can move steadily along it: a conical pendulum, a circular
orbit, a top precessing. Fix the rate of each cyclic coordinate (``velocities={"phi_dot": 2}``) or
its momentum (``momenta={"p_phi": 1}``, Routh's way: the rate is then found with the state), and the
steady motions are the solutions of f(q, q_dot) = 0 with q_ddot = 0 and the other velocities 0:
exactly when SymPy can (the rates and momenta kept as symbols, ``theta = acos(g/(l*phi_dot**2))``),
by the checked multi-start search of the equilibria otherwise (see ``_stationary``).

Stability comes from the linearization of all 2n states about the steady motion (its eigenvalues
are reported), with the positions of the cyclic coordinates left out (moving along them changes
nothing). "stable" is Routh's theorem: the amended potential, the potential of the forces at
fixed momenta, has a strict minimum (its Hessian is positive definite) and the damping is
positive semi-definite.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Mapping

import numpy as np
import sympy

from ..equations import Equations
from ..errors import ModelError, Problem
from ._equilibria import Equilibria, Equilibrium, found_points
from ..model._kinematics import to_sympy
from .._util import did_you_mean, real_number, shown_value
from ..numeric._compiled import compile_equations
from ._setting import check_search, collect_setting
from ._roots import completeness_notes, free_axes, no_root_reasons
from ._stability import assess
from ._stationary import conserved_cyclic, stationary_problem

__all__ = ["steady_motions", "SteadyMotion", "SteadyMotions"]


@dataclass(frozen=True, eq=False)
class SteadyMotion(Equilibrium):
    """A steady motion (returned by :func:`steady_motions`): the attributes of
    :class:`Equilibrium`, and

    Attributes
    ----------
    velocities : mapping of str to float
        Every velocity by name: the cyclic coordinates' rates (given, or found from their momenta),
        0 for the others.
    momenta : mapping of str to float
        p_<name> = dL/dq_dot of each cyclic coordinate in the steady motion.
    exact_velocities : mapping of str to sympy.Expr, or None
        The exact rates found from fixed momenta, when SymPy solved.
    """

    velocities: Mapping[str, float] = field(default_factory=lambda: MappingProxyType({}))
    momenta: Mapping[str, float] = field(default_factory=lambda: MappingProxyType({}))
    exact_velocities: Mapping[str, sympy.Expr] | None = None

    _kind = "steady motions"

    def to_dict(self) -> dict:
        """The JSON contract: coordinates, velocities, stable, eigenvalues ([re, im] pairs of the
        full 2n-state linearization; of the linearization in the independent speeds with
        constraints), and momenta, stability, exact, exact_velocities, conditions, family, isolated,
        dimension, multipliers and dependent ({} without constraints)."""
        out = super().to_dict()
        out["velocities"] = dict(self.velocities)
        out["momenta"] = dict(self.momenta)
        out["exact_velocities"] = (None if self.exact_velocities is None else
                                   {k: sympy.sstr(v) for k, v in self.exact_velocities.items()})
        order = ["coordinates", "velocities", "stable", "eigenvalues", "stability", "momenta", "exact",
                 "exact_velocities", "conditions", "family", "isolated", "dimension", "multipliers", "dependent"]
        return {k: out[k] for k in order}

    def text(self) -> str:
        moving = {k: v for k, v in self.velocities.items() if v != 0 or k[:-4] in self.family}
        rates = ", ".join(f"{k} = {_rate_text(v, (self.exact_velocities or {}).get(k))}" for k, v in moving.items())
        return f"{self._where()}; {rates}: {self.stability}" if rates else f"{self._where()}: {self.stability}"


def _rate_text(v: float, exact) -> str:
    if exact is not None and not exact.is_Number:
        return f"{sympy.sstr(exact)} = {v:.6g}"
    return f"{v:.6g}"


class SteadyMotions(Equilibria):
    """The steady motions found: a tuple of :class:`SteadyMotion`, with `notes` (why there is none)
    and `given` (the rates and momenta they were found for)."""

    def __new__(cls, items=(), notes=(), given=None):
        self = super().__new__(cls, items, notes)
        self._given = MappingProxyType(dict(given or {}))
        return self

    @property
    def given(self) -> Mapping[str, float]:
        return self._given

    def text(self, name: str = "the model") -> str:
        at = ", ".join(f"{k} = {v:g}" for k, v in self.given.items())
        head = f"Steady motions of {name}" + (f" with {at}" if at else "")
        if not self:
            return f"{head}: none.\n" + "".join(f"  {n}\n" for n in self.notes).rstrip("\n")
        lines = [f"{head} ({len(self)}):", *(f"  {e.text()}" for e in self)]
        return "\n".join(lines + [f"  note: {n}" for n in self.notes])

    def __repr__(self) -> str:
        return f"SteadyMotions({tuple.__repr__(self)}, notes={self.notes!r})"


def _fixed(equations: Equations, velocities: Mapping | None, momenta: Mapping | None,
           problems: list[Problem], cyclic: tuple[int, ...] | None = None,
           why_not=None) -> tuple[dict[int, float], dict[int, float]]:
    """The checked rates and momenta, by coordinate index. `cyclic`: the coordinates that may move
    (default: the conserved cyclic ones); `why_not(i)`: why coordinate i may not."""
    names = [c.name for c in equations.coordinates]
    word = "cyclic" if cyclic is None else "ignorable"
    cyclic = conserved_cyclic(equations) if cyclic is None else cyclic
    why_not = why_not or (lambda i: _why_not_cyclic(equations, i))
    allowed_v = [f"{names[i]}_dot" for i in cyclic]
    allowed_p = [f"p_{names[i]}" for i in cyclic]
    none = (f"{equations.model.name} has no cyclic coordinate (one absent from L with no force on it), so its "
            "only steady motions are its equilibria (lagrangian equilibria)") if word == "cyclic" else (
            f"{equations.model.name} has no ignorable coordinate (one the motion does not depend on), so its only "
            "steady motions are its equilibria (lagrangian equilibria)")
    out_v: dict[int, float] = {}
    out_p: dict[int, float] = {}
    symbols = {**{u.name: "an input" for u in equations.inputs},
               **{p.name: "a parameter" for p in equations.parameters}}

    def check(kind, given, prefix, suffix, allowed, out):
        choices = f"the {word} coordinates' {'velocities' if kind == 'velocity' else 'momenta'} are " \
                  f"{', '.join(allowed)}" if allowed else none
        if given is not None and not isinstance(given, Mapping):
            example = f"{{'{prefix}{names[cyclic[0]] if cyclic else names[0]}{suffix}': 1.0}}"
            problems.append(Problem(f"the {'velocities' if kind == 'velocity' else 'momenta'} must be a mapping of "
                                    f"names to numbers, such as {example}, got {type(given).__name__} "
                                    f"{shown_value(given)}; {choices}", key="velocities" if kind == "velocity"
                                    else "momenta"))
            return
        for key, value in (given or {}).items():
            key = str(getattr(key, "name", key))
            base = key[len(prefix):len(key) - len(suffix)] if key.startswith(prefix) and key.endswith(suffix) else None
            number = real_number(value)
            if base not in names:
                everything = [f"{prefix}{n}{suffix}" for n in names]
                problems.append(Problem(f"'{key}' is not a {kind} of the model"
                                        + did_you_mean(key, everything, 0.5)
                                        + f"; {choices}", key=key))
                continue
            i = names.index(base)
            if i not in cyclic:
                problems.append(Problem(f"{base} is not {word} ({why_not(i)}), so it "
                                        f"cannot move at a constant rate in a steady motion; {choices}", key=key))
            elif number is None:
                problems.append(Problem(f"the value of '{key}' must be a finite number, got {value!r}", key=key))
            elif key in symbols:
                problems.append(Problem(f"'{key}' is both the momentum of {base} and {symbols[key]} of the model, "
                                        f"so the steady motions (their exact forms) could not tell the two apart: "
                                        f"rename the {symbols[key].split()[-1]} in the model, or give the rate "
                                        f"{base}_dot instead", key=key))
            else:
                out[i] = number

    check("velocity", velocities, "", "_dot", allowed_v, out_v)
    check("momentum", momenta, "p_", "", allowed_p, out_p)
    for i in sorted(set(out_v) & set(out_p)):
        problems.append(Problem(f"both {names[i]}_dot and p_{names[i]} are given: fix either the rate of {names[i]} "
                                "or its momentum, not both", key=f"p_{names[i]}"))
    return out_v, out_p


def _why_not_cyclic(equations: Equations, i: int) -> str:
    core = equations.core
    name = equations.coordinates[i].name
    q = core.q[i]
    dL = sympy.factor(to_sympy(core.L.diff(q)))
    if dL != 0:
        text = sympy.sstr(dL)
        return f"dL/d{name} = {text} is not 0" if len(text) <= 60 else f"L depends on {name}"
    return "a generalized or damping force acts on it, or the equations depend on it"


def steady_motions(equations: Equations, velocities: Mapping | None = None, *, momenta: Mapping | None = None,
                   params: Mapping | None = None, inputs: Mapping | None = None, t: float = 0.0,
                   exact: bool = True, starts: int | None = None, seed: int = 0) -> SteadyMotions:
    """The steady motions: non-cyclic coordinates constant, cyclic ones at constant rates.

    Parameters
    ----------
    equations : Equations
    velocities : mapping of str to float
        Rates of cyclic coordinates by velocity name (``{"phi_dot": 2.0}``); cyclic coordinates
        given neither a rate nor a momentum stay at rest.
    momenta : mapping of str to float
        Momenta p_<name> = dL/dq_dot of cyclic coordinates (``{"p_phi": 1.5}``): their rates are
        found with the steady motion (Routh).
    params, inputs : mapping of str to float
        Parameter values that override the model's; constant input values (default 0).
    t : float
        The time, for equations that contain t.
    exact : bool
        Try SymPy first (up to 3 unknowns, within a budget of work counted in calls, never a clock).
    starts : int
        Number of starting points of the numerical search (default 24 + 24 per unknown).
    seed : int
        Seed of the random starting points (results are reproducible).

    Returns
    -------
    SteadyMotions
        A tuple of :class:`SteadyMotion`, sorted by coordinates; empty when there is none, with
        `notes` saying why.

    Raises
    ------
    ModelError
        Bad names or values: a velocity of a coordinate that is not cyclic, a rate and a momentum
        for the same coordinate, unknown parameters or inputs.
    """
    check_search(exact, starts, seed)
    if equations.is_constrained:
        return _constrained_steady_motions(equations, velocities, momenta, params, inputs, t, starts, seed)
    problems: list[Problem] = []
    setting = collect_setting(equations, params, inputs, t, problems)
    fixed_v, fixed_p = _fixed(equations, velocities, momenta, problems)
    if problems:
        raise ModelError(problems)
    problem = stationary_problem(equations, setting.inputs, setting.t, exact, velocities=fixed_v,
                                 momenta=fixed_p, values=setting.p)
    points, ctx = found_points(problem, setting, starts=starts, seed=seed)
    names = [c.name for c in equations.coordinates]
    cyclic = conserved_cyclic(equations)
    found = []
    for r in points:
        a = assess(problem, setting, r.q, r.tangent, r.exact, r.solution)
        qd = a.velocities
        if not np.all(np.isfinite(qd)):
            continue
        p = compile_equations(equations).momenta(setting.t, np.concatenate((r.q, qd)), setting.u, setting.p)[0]
        exact_rates = None
        if r.solution is not None and problem.exact_velocities:
            k = next(k for k, (sol, _) in enumerate(problem.exact) if sol is r.solution)
            exact_rates = MappingProxyType({f"{names[i]}_dot": e for i, e in problem.exact_velocities[k].items()})
        found.append(SteadyMotion(
            MappingProxyType({n: float(v) for n, v in zip(names, r.q)}), a.stable, a.stability, a.eigenvalues,
            None if r.exact is None else MappingProxyType(dict(r.exact)), tuple(r.conditions), problem.family,
            a.linear_model, not r.dimension, r.dimension, free_axes(ctx, r.q, r.tangent),
            MappingProxyType({f"{n}_dot": float(v) + 0.0 for n, v in zip(names, qd)}),
            MappingProxyType({f"p_{names[i]}": float(p[i]) + 0.0 for i in cyclic}), exact_rates))
    notes = (no_root_reasons(problem, setting, ctx, "a steady motion") if not found
             else completeness_notes(problem, ctx, "the steady motions"))
    given = {**{f"{names[i]}_dot": v for i, v in fixed_v.items()}, **{f"p_{names[i]}": v for i, v in fixed_p.items()}}
    return SteadyMotions(tuple(found), notes, given)


def _constrained_steady_motions(equations: Equations, velocities, momenta, params, inputs, t, starts,
                                seed) -> SteadyMotions:
    """steady_motions() of a constrained model: numerically, in the shape coordinates (see
    ``_constrained_steady``)."""
    from ._constrained_static import assess_constrained
    from ._constrained_steady import above_ground, ignorable_coordinates, steady_details, steady_problem

    problems: list[Problem] = []
    names = [c.name for c in equations.coordinates]
    if momenta:
        key = str(getattr(next(iter(momenta)), "name", next(iter(momenta))))
        problems.append(Problem(
            f"'{equations.model.name}' has constraints, and steady motions of a constrained model are found for "
            f"given rates, not momenta (velocity constraints do not conserve momenta): fix the rates instead "
            f"(velocities={{...}}, --velocity), e.g. {key[2:] if key.startswith('p_') else key}_dot", key=key))
    setting = collect_setting(equations, params, inputs, t, problems)
    ignorable: tuple[int, ...] = ()
    fixed_v: dict[int, float] = {}
    if setting is not None:
        ignorable = ignorable_coordinates(equations, setting)
        why = "the motion depends on its value, or a holonomic constraint contains it"
        fixed_v, _ = _fixed(equations, velocities, None, problems, ignorable, lambda i: why)
    if problems:
        raise ModelError(problems)
    problem = steady_problem(equations, setting, fixed_v)
    points, ctx = found_points(problem, setting, starts=starts, seed=seed)
    points, below = above_ground(problem, setting, points)
    found = []
    for r in points:
        qd, multipliers = steady_details(problem, setting, r.q)
        if not np.all(np.isfinite(qd)):
            continue
        a, dependent = assess_constrained(problem, setting, r.q, r.tangent, qd)
        found.append(SteadyMotion(
            MappingProxyType({n: float(v) for n, v in zip(names, r.q)}), a.stable, a.stability, a.eigenvalues,
            None, (), problem.family, a.linear_model, not r.dimension, r.dimension, free_axes(ctx, r.q, r.tangent),
            MappingProxyType({f"{n}_dot": float(v) + 0.0 for n, v in zip(names, qd)}), MappingProxyType({}), None,
            multipliers=multipliers, dependent=MappingProxyType(dependent)))
    notes = below + (no_root_reasons(problem, setting, ctx, "a steady motion") if not found
                     else completeness_notes(problem, ctx, "the steady motions"))
    return SteadyMotions(tuple(found), notes, {f"{names[i]}_dot": v for i, v in fixed_v.items()})
