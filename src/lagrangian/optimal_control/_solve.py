"""optimal_motion: the front door (problem, transcription, mesh refinement, replay)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from ..errors import LagrangianError, ModelError
from ..io._optimal import MAX_INTERVALS
from ._collocation import Transcription, interpolate, refine
from ._problem import build_problem
from ._result import OptimalMotion

__all__ = ["optimal_motion"]

_LAWS = ("quadratic", "cubic", "linear")


def optimal_motion(equations, *, duration=None, objective=None, terminal_cost=None, minimum_time=None,
                   initial: Mapping[str, float] | None = None, final: Mapping[str, float] | None = None,
                   bounds: Mapping[str, Any] | None = None, inputs: Mapping[str, Any] | None = None,
                   path: Mapping[str, Any] | None = None, intervals: int | None = None,
                   tolerance: float | None = None, max_refinements: int | None = None,
                   params: Mapping[str, float] | None = None, guess: OptimalMotion | None = None,
                   law: str = "quadratic", replay: bool = True) -> OptimalMotion:
    """The optimal motion of a model by direct collocation (Hermite-Simpson, IPOPT), checked by a replay.

    The problem is the model file's ``[optimal_control]`` table, each keyword given replacing the
    table's entry of that name (the same keys, rules and messages).

    Parameters
    ----------
    equations : Equations
        From :func:`lagrangian.derive` (constrained models too: the multipliers are unknowns).
    duration : float or (float, float)
        Fixed duration, or (lower, upper) for a free one.
    objective : str or sympy.Expr
        The integrand: the cost is its integral over the motion (``"F**2"``).
    terminal_cost : str or sympy.Expr
        Added at the final state.
    minimum_time : bool
        Add the duration to the cost (needs a free duration).
    initial, final : mapping of str to float
        States fixed at the start and at the end (the others are free).
    bounds : mapping of str to (float, float)
        Bounds on coordinates and velocities along the whole motion (``-inf``/``inf`` for none).
    inputs : mapping of str to (float, float) or float
        The inputs' bounds; a number holds an input fixed; inputs not named are free and unbounded.
    path : mapping of str to mapping
        Path constraints ``{"track": {"expression": "q1", "min": -2, "max": 2}}`` on expressions of
        the state, inputs, parameters and t.
    intervals : int
        The first mesh (default 25 uniform intervals).
    tolerance : float
        The collocation error to reach by mesh refinement (default 1e-6).
    max_refinements : int
        At most this many refinements (default 6).
    params : mapping of str to float
        Parameter values that override the model's.
    guess : OptimalMotion, optional
        A previous answer to start from (default: the states linear between the given ends).
    law : {"quadratic", "cubic", "linear"}
        The input law (``input_law``, replayed): "quadratic" (default) is exactly the collocation's input,
        the quadratic through each interval's three values (node, midpoint, node); "cubic" (the
        not-a-knot spline) and "linear" interpolate the points' values.
    replay : bool
        Replay the input law with ``simulate`` and report the deviation (default True).

    Returns
    -------
    OptimalMotion

    Raises
    ------
    ModelError
        A bad problem (every problem at once), or CasADi missing.
    OptimalControlError
        IPOPT found no optimal motion (infeasible, ...): its status and the fix.
    """
    if law not in _LAWS:
        raise ModelError(f"unknown input law '{law}'; choose 'quadratic' (the collocation's own), 'cubic' or 'linear'")
    problem = build_problem(equations, {
        "duration": duration, "objective": objective, "terminal_cost": terminal_cost,
        "minimum_time": minimum_time, "initial": initial, "final": final, "bounds": bounds, "inputs": inputs,
        "path": path, "intervals": intervals, "tolerance": tolerance, "max_refinements": max_refinements})
    values = _parameter_values(equations, params)
    tr = Transcription(equations, problem, values)
    N = problem.intervals
    tau_nodes = np.linspace(0.0, 1.0, N + 1)
    T0 = problem.duration if not problem.free_duration else math.sqrt(problem.duration[0] * problem.duration[1])
    tau = _points(tau_nodes)
    if guess is not None:
        if not isinstance(guess, OptimalMotion):
            raise ModelError(f"guess= expects an OptimalMotion (a previous answer), got {type(guess).__name__}")
        if guess.state_names != tuple(tr.state_names) or guess.input_names != tuple(tr.input_names):
            raise ModelError("guess= is an optimal motion of another model (its states or inputs differ); give an "
                             "answer of this model")
        start = _from_motion(guess, tau)
    else:
        hints = {k: float(v) for k, v in (equations.model.simulation.get("initial") or {}).items()}
        start = tr.first_guess(tau, T0, hints)
    meshes = []
    iterations = 0
    for refinement in range(problem.max_refinements + 1):
        sol = tr.solve(tau_nodes, start)
        iterations += sol.iterations
        worst = float(np.max(sol.errors)) if sol.errors.size else 0.0
        meshes.append({"intervals": len(tau_nodes) - 1, "collocation_error": worst, "iterations": sol.iterations,
                       "cost": sol.cost})
        if worst <= problem.tolerance or refinement == problem.max_refinements:
            break
        new = refine(tau_nodes, sol.errors, problem.tolerance, cap=MAX_INTERVALS)
        if len(new) - 1 > MAX_INTERVALS:
            break
        tau_nodes = new
        start = interpolate(tr, sol, _points(tau_nodes))
    times = sol.tau * sol.T
    law_signals = _input_law(tr, problem, times, sol.U, law)
    constraint_error = _constraint_error(tr, sol, times)
    deviation: dict[str, float] = {}
    failure = None
    if replay:
        deviation, failure = _replay(equations, tr, sol, times, law_signals, values)
    return OptimalMotion(
        t=_ro(times), x=_ro(sol.X), u=_ro(sol.U), accelerations=_ro(sol.A), multipliers=_ro(sol.L),
        state_names=tuple(tr.state_names), input_names=tuple(tr.input_names), cost=sol.cost, duration=sol.T,
        iterations=iterations, status=sol.status, intervals=len(tau_nodes) - 1, collocation_error=worst,
        converged=worst <= problem.tolerance, tolerance=problem.tolerance, meshes=tuple(meshes),
        constraint_error=constraint_error, input_law=law_signals, replay_deviation=deviation,
        replay_failure=failure, equations=equations, _transcription=tr)


def _ro(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=float)
    a.setflags(write=False)
    return a


def _points(tau_nodes: np.ndarray) -> np.ndarray:
    tau = np.empty(2 * len(tau_nodes) - 1)
    tau[0::2] = tau_nodes
    tau[1::2] = 0.5 * (tau_nodes[:-1] + tau_nodes[1:])
    return tau


def _parameter_values(equations, params) -> dict[str, float]:
    values = {p.name: v for p, v in equations.parameters.items()}
    names = list(values)
    if params:
        for name, v in params.items():
            if name not in values:
                from .._util import did_you_mean

                raise ModelError(f"params: '{name}' is not a parameter{did_you_mean(name, names, 0.5)}; the "
                                 f"parameters are {', '.join(names) or '(none)'}")
            values[name] = v
    missing = [k for k, v in values.items() if v is None]
    if missing:
        raise ModelError(f"the parameter(s) {', '.join(missing)} have no value; give them in params= "
                         f"({missing[0]}=1.0) or under [parameters]")
    out = {}
    for k, v in values.items():
        try:
            x = float(v)
        except (TypeError, ValueError):
            raise ModelError(f"params: '{k}' must be a number, got {v!r}") from None
        if not math.isfinite(x):
            raise ModelError(f"params: '{k}' must be a finite number, got {x}")
        out[k] = x
    return out


def _from_motion(motion: OptimalMotion, tau: np.ndarray) -> dict:
    s = motion.t / motion.duration
    col = {key: np.column_stack([np.interp(tau, s, arr[:, j]) for j in range(arr.shape[1])])
           if arr.shape[1] else np.zeros((len(tau), 0))
           for key, arr in (("X", motion.x), ("A", motion.accelerations), ("L", motion.multipliers),
                            ("U", motion.u))}
    col["T"] = motion.duration
    return col


def _input_law(tr, problem, times, U, law) -> dict:
    from ..numeric import Signal

    out = {}
    for j, name in enumerate(tr.input_names):
        if not isinstance(problem.inputs[name], tuple):
            continue
        if law != "quadratic":
            out[name] = Signal(times, U[:, j], interpolation=law, extrapolation="hold", name=name)
            continue
        # the collocation's input: on each interval [t_k, t_k+1] the quadratic through u_k, u_m, u_k+1,
        # written as the Signal's piecewise polynomials in (s - t_k), highest power first
        nodes, u0, um, u1 = times[0::2], U[0:-1:2, j], U[1::2, j], U[2::2, j]
        h = np.diff(nodes)
        coef = np.zeros((len(h), 4))
        coef[:, 1] = 2.0 * (u0 - 2.0 * um + u1) / h**2
        coef[:, 2] = (4.0 * um - 3.0 * u0 - u1) / h
        coef[:, 3] = u0
        out[name] = Signal.from_polynomials(nodes, coef[:, 1:], extrapolation="hold", name=name,
                                            interpolation="quadratic")
    return out


def _constraint_error(tr, sol, times) -> float:
    if not tr.m:
        return 0.0
    worst = 0.0
    for p in range(len(times)):
        r = np.asarray(tr.boundary(sol.X[p, :tr.n], sol.X[p, tr.n:], times[p]), dtype=float)
        worst = max(worst, float(np.max(np.abs(r))) if r.size else 0.0)
    return worst


def _replay(equations, tr, sol, times, law, values) -> tuple[dict[str, float], str | None]:
    from ..numeric import simulate

    initial = dict(zip(tr.state_names, (float(v) for v in sol.X[0])))
    inputs: dict[str, Any] = {}
    for j, name in enumerate(tr.input_names):
        inputs[name] = law[name] if name in law else float(sol.U[0, j])
    try:
        traj = simulate(equations, t_end=float(times[-1]), initial=initial, inputs=inputs, params=values,
                        t_eval=times, rtol=1e-10, atol=1e-10, progress=False)
    except LagrangianError as exc:
        return {s: math.nan for s in tr.state_names}, str(exc).splitlines()[0]
    if traj.x.shape[0] != len(times):
        return {s: math.nan for s in tr.state_names}, "the replay stopped early: " + str(traj.failure or "")
    diff = np.max(np.abs(np.asarray(traj.x) - sol.X), axis=0)
    return dict(zip(tr.state_names, (float(d) for d in diff))), None
