"""simulate(...) -> Trajectory: integrate the state equations with an adaptive integrator."""

from __future__ import annotations

from dataclasses import dataclass
from decimal import Decimal
import math
import numbers
import os
from typing import Callable, Mapping

import numpy as np
import sympy

from ..equations import Equations, derive, singularities
from .._limits import MAX_EXPONENT, MAX_ROWS, MAX_STEPS, number_problem, value_problem
from .._util import did_you_mean, named_values, number_array, read_only, real_number, shown_value
from ..errors import ModelError, Problem, SimulationError, SingularMassMatrixError, Status
from ..model import Model
from ._cache import cached, per_equations
from ._compiled import NumericModel, _NotFinite, _Singular, compile_equations, raise_on_failure
from ._fast import (BACKENDS, CompiledModel, PreparedDop853, _address, inputs_and_energy, run_dop853,
                    run_variational)
from ._inputs import Signal, programs, signal_problems
from ._options import SimulationOptions
from ._solvers import METHODS, Solver, Variational, solver_of
from ._trajectory import RunTemplate, Trajectory, run_trajectory

__all__ = ["simulate", "output_times", "METHODS"]

#: Event threshold on the inertia measure of M (see inertia_measure): closer to singular than this stops the simulation.
_EVENT_RATIO = 1e-9
#: An integrator whose step size collapsed where M has kept less of its inertia at the start than this
#: (see _inertia_kept) stopped at a singular M, not for want of a stiff method.
_KEPT_INERTIA = 1e-6


def output_times(t_end: float, dt: float) -> np.ndarray:
    """0, dt, 2 dt, ... <= t_end, as the decimal multiples of dt (0.3 * 3 is 0.9, not 0.8999...)."""
    count = int(math.floor(t_end / dt * (1 + 1e-12) + 1e-9))
    decimals = max(0, -Decimal(repr(float(dt))).normalize().as_tuple().exponent)
    times = np.arange(count + 1) * dt
    if decimals <= 15:
        times = np.round(times, decimals)
    return times[times <= t_end * (1 + 1e-12)] if count else times


class _Names:
    """The names and parameter values of a model, for checking the arguments before anything is
    compiled (one per Equations: :func:`_names`)."""

    def __init__(self, equations: Equations):
        self.equations = equations
        self.states = (*equations.coordinates, *equations.velocities)
        self.state_names = tuple(s.name for s in self.states)
        self.input_names = tuple(u.name for u in equations.inputs)
        self.parameter_names = tuple(p.name for p in equations.parameters)
        self.parameter_values = read_only([np.nan if v is None else v for v in equations.parameters.values()], float)
        self.n = equations.n


def _names(equations: Equations) -> _Names:
    """The _Names of `equations`, built once (the one cache)."""
    return cached(equations, "simulate.names", lambda: _Names(equations))


def _last(equations: Equations, key: str, arguments, build):
    """``build()`` for these `arguments`, kept per Equations until other arguments come: what
    simulate() would otherwise redo on every call for the same model (the output times, the inputs'
    programs)."""
    per = per_equations(equations)
    hit = per.get(key)
    if hit is not None and hit[0] == arguments:
        return hit[1]
    value = build()
    per[key] = (arguments, value)
    return value


def requested_times(t_end: float, dt: float, t_eval=None) -> np.ndarray:
    """The output times: `t_eval` checked, or 0, dt, 2 dt, ... <= t_end."""
    if t_eval is None:
        return output_times(float(t_end), float(dt))
    times = number_array(t_eval)
    if times is None:
        raise ModelError(f"t_eval must be a non-empty increasing sequence of times (numbers) in [0, t_end = "
                         f"{t_end:g}], got {shown_value(t_eval, 80)}")
    times = times.ravel()
    if times.size == 0 or times[0] < 0 or np.any(np.diff(times) <= 0) or times[-1] > t_end * (1 + 1e-12):
        raise ModelError(f"t_eval must be a non-empty increasing sequence of times in [0, t_end = {t_end:g}], "
                         f"got {t_eval!r}")
    return times


def _work_problems(t_end, dt, t_eval, step, method) -> list[Problem]:
    """The bounds on the work a simulation may be asked for (lagrangian._limits): its output rows
    (t_end / dt + 1, or len(t_eval)) and the fixed steps of method "variational" (t_end / step)."""
    if number_problem(t_end, "t_end", positive=True) or number_problem(dt, "dt", positive=True):
        return []  # reported already
    if t_eval is not None:
        times = number_array(t_eval)
        rows = 0 if times is None else times.size  # (times that are not numbers: requested_times says so)
        fix = "give fewer times in t_eval"
    else:
        rows = t_end / dt + 1
        fix = f"raise dt (--dt {t_end / (MAX_ROWS.value - 1):.3g} or more) or give the times wanted as t_eval"
    out = []
    if rows > MAX_ROWS.value:
        out.append(Problem(f"t_end = {t_end:g} with dt = {dt:g} asks for {rows:.4g} output rows, too many to keep: "
                           f"{fix}; {MAX_ROWS.how_to_raise()}", key="t_eval" if t_eval is not None else "dt"))
    if method == "variational":
        fixed = min(dt, 1e-3) if step is None else step
        if isinstance(fixed, numbers.Real) and fixed > 0 and t_end / fixed > MAX_STEPS.value:
            out.append(Problem(f"t_end = {t_end:g} in fixed steps of {fixed:g} is {t_end / fixed:.4g} steps: use a "
                               f"larger step (--step) or a shorter t_end; {MAX_STEPS.how_to_raise()}", key="step"))
    return out


def _as_numeric(system):
    """A NumericModel or CompiledModel as given, or the names of a Model's or Equations'."""
    if isinstance(system, (NumericModel, CompiledModel)):
        return system
    if isinstance(system, Model):
        system = derive(system)
    if isinstance(system, Equations):
        return _names(system)
    raise TypeError(f"simulate() expects a Model, Equations or NumericModel, got {type(system).__name__}")


def _named_values(values: Mapping, names: tuple[str, ...], what: str, key: str,
                  problems: list[Problem], derived: Mapping | None = None) -> dict[int, float]:
    """{index in `names`: value} for a mapping of names (or symbols) to finite numbers; every bad
    name or value becomes a problem (see lagrangian._util.named_values: the analysis' rule)."""
    return {names.index(name): value
            for name, value in named_values(values, names, what, key, problems, derived).items()}


def _parameters(nm: NumericModel, params: Mapping | None, problems: list[Problem]) -> np.ndarray:
    values = nm.parameter_values.copy()
    derived = getattr(getattr(getattr(nm, "equations", None), "model", None), "derived_parameters", None)
    for i, v in _named_values(params or {}, nm.parameter_names, "a parameter of the model", "params",
                              problems, derived).items():
        values[i] = v
    if not np.isnan(values).any():  # (one test of the array: simulate() asks on every call)
        return values
    reported = {p.key for p in problems}
    for name, v in zip(nm.parameter_names, values):
        if np.isnan(v) and f"params.{name}" not in reported:
            problems.append(Problem(f"parameter '{name}' has no value: give one in the model or pass "
                                    f"params={{'{name}': ...}} (--param {name}=... on the command line)",
                                    key=f"params.{name}"))
    return values


def _initial_state(nm: NumericModel, initial, problems: list[Problem]) -> np.ndarray:
    x0 = np.zeros(2 * nm.n)
    if initial is None:
        return x0
    if not isinstance(initial, Mapping):
        arr = number_array(initial)
        if arr is None:
            problems.append(Problem(f"the initial state must be {2 * nm.n} numbers ({', '.join(nm.state_names)}) or "
                                    f"a mapping of these names to numbers, got {shown_value(initial, 80)}",
                                    key="initial"))
            return x0
        if arr.shape != (2 * nm.n,):
            problems.append(Problem(f"the initial state must have {2 * nm.n} values "
                                    f"({', '.join(nm.state_names)}), got shape {arr.shape}", key="initial"))
            return x0
        return arr
    for i, v in _named_values(initial, nm.state_names, "a coordinate or velocity", "initial", problems).items():
        x0[i] = v
    return x0


def _input_function(nm, inputs, pvalues, problems: list[Problem]):
    """(u(t, x) as a Python function, the inputs as sympy expressions of t, the state and the
    parameters for compiled code, or None when one is a Python function)."""
    m = len(nm.input_names)
    constant = np.zeros(m)
    funcs: list[tuple[int, Callable]] = []
    exprs: list | None = [sympy.Integer(0)] * m
    for name, spec in (inputs or {}).items():
        name = getattr(name, "name", name)
        if name not in nm.input_names:
            problems.append(Problem(f"'{name}' is not an input of the model{did_you_mean(name, nm.input_names, 0.5)}; "
                                    f"its inputs are {', '.join(nm.input_names) or 'none'}", key=f"inputs.{name}"))
            continue
        i = nm.input_names.index(name)
        if isinstance(spec, Signal):  # a measured signal: a sympy function of t, interpolated in compiled code
            spec = spec(nm.equations.t)
        if isinstance(spec, numbers.Real) and not isinstance(spec, bool):
            if (why := value_problem(name, spec)) is not None:
                problems.append(Problem(f"input {why[len('the value of '):]}" if why.startswith("the value of ")
                                        else why, key=f"inputs.{name}"))
                continue
            constant[i] = float(spec)
            if exprs is not None:
                exprs[i] = sympy.Float(float(spec))
        elif isinstance(spec, (str, sympy.Basic)):
            try:
                fun, expr = _input_expression(nm, spec, pvalues)
                funcs.append((i, fun))
                if exprs is not None:
                    exprs[i] = expr
            except ModelError as exc:
                problems.extend(Problem(p.message, key=f"inputs.{name}") for p in exc.problems)
        elif callable(spec):
            fun = _feedback_function(spec, name, problems)
            if fun is not None:
                funcs.append((i, fun))
            exprs = None
        else:
            problems.append(Problem(f"input '{name}' must be a number, an expression (a string) of t, the "
                                    f"coordinates, velocities and parameters, or a function u(t) or u(t, x), got "
                                    f"{spec!r}", key=f"inputs.{name}"))
    if not funcs:
        return (lambda t, x: constant), exprs

    def u(t: float, x) -> np.ndarray:
        out = constant.copy()
        for i, f in funcs:
            try:
                value = f(t, x)
            except (ValueError, ArithmeticError) as exc:  # an expression out of its domain here: acos(2 + q1)
                raise SimulationError(f"input '{nm.input_names[i]}' has no value at t = {t:g} ({exc}): its "
                                      "expression leaves the domain of a function there (acos, asin, log, sqrt of "
                                      "a negative number, a division by zero); keep the arguments in range, e.g. "
                                      "with clip(x, lo, hi)", time=float(t)) from None
            try:
                out[i] = float(value)
            except (TypeError, ValueError):
                raise ModelError(f"input '{nm.input_names[i]}': its function returned {value!r} at t = {t:g}; "
                                 "expected a number (a float) for each time") from None
        return out

    return u, exprs


def _feedback_function(spec, name: str, problems: list[Problem]):
    """A Python function u(t) or u(t, x) as u(t, x); None after a problem."""
    import inspect

    try:
        params = [q for q in inspect.signature(spec).parameters.values()
                  if q.kind in (q.POSITIONAL_ONLY, q.POSITIONAL_OR_KEYWORD) and q.default is q.empty]
        varargs = any(q.kind == q.VAR_POSITIONAL for q in inspect.signature(spec).parameters.values())
    except (TypeError, ValueError):  # a builtin without a signature: a function of t
        return lambda t, x: spec(t)
    if len(params) == 2 or (varargs and len(params) < 2):
        return spec
    if len(params) == 1:
        return lambda t, x: spec(t)
    problems.append(Problem(f"input '{name}': a function must take (t) or (t, x), the time and the state "
                            f"[q, q_dot], but it takes {len(params)} arguments", key=f"inputs.{name}"))
    return None


def _input_names(eq: Equations) -> dict:
    """The names an input's expression may use: t, the coordinates, velocities and parameters."""
    return {"t": eq.t, **{s.name: s for s in (*eq.coordinates, *eq.velocities)},
            **{p.name: p for p in eq.parameters}}


def _input_expression(nm, spec, pvalues) -> tuple[Callable[[float, np.ndarray], float], sympy.Expr]:
    from ..model._expr import parse_expression
    from ..errors import ExpressionError

    eq = nm.equations
    names = _input_names(eq)
    if isinstance(spec, str):
        try:
            expr = parse_expression(spec, names, feedback=True)
        except ExpressionError as exc:
            raise ModelError(f"{exc} (an input is an expression of t, the coordinates, velocities and "
                             "parameters)") from None
    else:
        expr = spec
    extra = expr.free_symbols - set(names.values())
    if extra:
        raise ModelError(f"an input may depend on t, the coordinates, velocities and parameters, not on "
                         f"{', '.join(sorted(s.name for s in extra))}")
    if expr.is_number:  # a constant: its value is checked as a number given directly is
        value = real_number(expr)
        if value is None:
            raise ModelError(f"the input {str(spec)[:40]} is not a finite real number")
        if (why := value_problem("the input", value)) is not None:
            raise ModelError(why.replace("the value of 'the input'", "the input").replace("'the input'", "the input"))
    f = sympy.lambdify([eq.t, list((*eq.coordinates, *eq.velocities)), list(eq.parameters)], expr, "math")
    pv = [float(v) for v in pvalues]
    return (lambda time, x: f(time, x, pv)), expr


def sample_times(sample_time, input_names: tuple[str, ...], t_end: float, problems: list[Problem]):
    """The sampled inputs: (hold (m,) int, sample instants (S,), which (S, m) int), or None.
    `sample_time`: a period for every input, or a mapping of input names to periods."""
    if sample_time is None:
        return None
    m = len(input_names)
    periods = np.zeros(m)
    if isinstance(sample_time, Mapping):
        items = sample_time.items()
    else:
        items = [(name, sample_time) for name in input_names]
        if not m:
            problems.append(Problem("sample_time is given but the model has no inputs to sample", key="sample_time"))
    for name, value in items:
        name = getattr(name, "name", name)
        key = "sample_time" if not isinstance(sample_time, Mapping) else f"sample_time.{name}"
        if name not in input_names:
            problems.append(Problem(f"'{name}' is not an input of the model{did_you_mean(name, input_names, 0.5)}; "
                                    f"its inputs are {', '.join(input_names) or 'none'}", key=key))
        elif (not isinstance(value, numbers.Real) or isinstance(value, bool) or not value > 0
              or not math.isfinite(value)):
            problems.append(Problem(f"a sample time must be a positive number of seconds, got {value!r}", key=key))
        else:
            periods[input_names.index(name)] = float(value)
    if problems or not np.any(periods > 0) or t_end is None:
        return None
    for i in np.flatnonzero(periods > 0):
        if t_end / periods[i] + 1 > MAX_ROWS.value:
            problems.append(Problem(f"sample time {float(periods[i])!r} s over t_end = {t_end:g} s makes "
                                    f"{t_end / periods[i] + 1:.3g} samples of input '{input_names[i]}': use a "
                                    f"longer sample time or a shorter t_end; {MAX_ROWS.how_to_raise()}",
                                    key="sample_time"))
            return None
    instants = {i: output_times(float(t_end), periods[i]) for i in range(m) if periods[i] > 0}
    samples = np.unique(np.concatenate(list(instants.values())))
    which = np.zeros((len(samples), max(1, m)), np.int64)
    for i, times in instants.items():
        which[:, i] = np.isin(samples, times)
    hold = np.zeros(max(1, m), np.int64)
    hold[:m] = periods > 0
    from ._fast import Sampling

    return Sampling(hold, samples, which)


def held_inputs(sampling, values: np.ndarray, times: np.ndarray) -> np.ndarray:
    """The held values at `times`: those computed at the last sample instant at or before each."""
    rows = np.searchsorted(sampling.samples, times, side="right") - 1
    return values[np.clip(rows, 0, len(values) - 1)]


def simulate(system, t_end: float | None = None, initial=None, *, inputs: Mapping | None = None,
             params: Mapping | None = None, dt: float | None = None, t_eval=None,
             rtol: float | None = None, atol: float | None = None, method: "str | Solver | None" = None,
             max_step: float | None = None, backend: str | None = None, step: float | None = None,
             events: Mapping[str, str] | None = None, stop_on=None, progress: bool | None = None,
             sample_time: float | Mapping[str, float] | None = None, constraints: str | None = None,
             options: SimulationOptions | None = None) -> Trajectory:
    """Integrate x' = f(t, x, u, p) from t = 0 to `t_end`.

    Every option not given (None) is the model file's ([simulation]) or the default; a mapping
    given (`initial`, `inputs`, `params`, `events`, a `sample_time` mapping) updates the model's
    name by name (see :class:`~lagrangian.numeric._options.SimulationOptions`: the one merge rule of
    the API, the command line, the exports and the playground).

    Parameters
    ----------
    system : Model, Equations or NumericModel
    t_end : float
        Final time (default: the model's [simulation] t_end).
    initial : mapping of str to float, or array_like, shape (2n,)
        Initial coordinates and velocities by name (``{"q2": 0.5, "q2_dot": 0}``); those not
        given keep the model's [simulation] initial values (0 where it has none). An array is the
        whole initial state.
    inputs : mapping of str to float, str or callable
        Each input as a constant, an expression of t, the coordinates, velocities and parameters
        (``"1.5*sin(3*t)"``, or a feedback law ``"-20*(q2 - pi/2) - 5*q2_dot"``, which may
        switch with ``where``, ``min``, ``max``, ``clip``), or a Python function ``u(t)`` or
        ``u(t, x)`` (x the state [q, q_dot]; these run on the SciPy path). Inputs not given keep
        the model's [simulation] inputs (0 where it has none).
    params : mapping of str to float
        Parameter values that override the model's.
    dt : float
        Output every dt: t = 0, dt, 2 dt, ... <= t_end (default: the model's, or 0.01).
    t_eval : array_like, optional
        Explicit output times instead of `dt`.
    rtol, atol : float
        Tolerances of the adaptive integrator (default: the model's, or 1e-9 both).
    method : str or Solver
        A solver object (``lagrangian.numeric.DOP853()``, ``Variational(step=...)``,
        ``SciPyMethod("Radau")``: each says what it supports) or its name, one of METHODS:
        DOP853 (default, an explicit Runge-Kutta method of order 8 with error control and dense
        output), "variational" (the midpoint variational integrator: a fixed step, an energy error
        that stays bounded over long runs of a conservative model), or another of SciPy's
        solve_ivp methods (RK45, RK23, Radau, BDF, LSODA; these always run in SciPy).
    max_step : float
        Largest step the integrator may take (default: no limit, math.inf).
    backend : {"auto", "numba", "c", "scipy"}
        Where the integrator runs. "auto" (default): compiled by numba when the method is
        DOP853 or variational and every input is a constant or an expression, else SciPy.
        "numba": generated code compiled by numba (cached on disk: a model compiles once).
        "c": the model's functions generated in C and compiled with cffi (needs a C compiler).
        "scipy": SciPy's solve_ivp calling the portable NumPy functions (Python functions as
        inputs need it; "auto" picks it for them).
    step : float
        The fixed step of method="variational" (default: dt divided into steps of at most
        1e-3); made to divide dt exactly.
    events : mapping of str to str, optional
        Named event functions, expressions of t, the coordinates, velocities, inputs and
        parameters (``{"bottom": "q2 + pi/2", "turn": "q1_dot"}``). Every zero crossing is located
        on the interpolant and recorded in ``Trajectory.events[name]`` (times "t" and states "x").
        Watched by the compiled DOP853 only.
    stop_on : sequence of str
        Names of `events` whose first crossing stops the simulation there (the trajectory ends
        at the last output time before it; ``stats["stopped_by"]`` names the event).
    progress : bool, optional
        Draw a progress bar on stderr; by default only when stderr is a terminal and the run
        takes more than a second (the results do not depend on it).
    sample_time : float or mapping of str to float, optional
        A sampled (digital) controller: each input is evaluated at t = 0, Ts, 2 Ts, ... and held
        in between (zero-order hold); a number samples every input, a mapping only the named
        ones (``{"F": 0.01}``; the others stay continuous). Default: the model's [simulation]
        sample_time, or none.
    constraints : {"project", "eliminate"}
        For a model with holonomic constraints: "project" (default) integrates all coordinates and
        projects onto the constraints after every step (compiled when it can); "eliminate" integrates
        an ODE in the independent coordinates ([simulation] independent), the others found by Newton on
        g = 0 at every evaluation (SciPy's integrators; no drift by construction).
    options : SimulationOptions, optional
        The options to start from instead of the model file's (``SimulationOptions.from_model``);
        the keywords given are merged onto them by the same rule.

    Returns
    -------
    Trajectory
        ``stats["status"]`` is its :class:`~lagrangian.errors.Status`.

    Raises
    ------
    ModelError
        Bad input (unknown names, missing parameter values), every problem at once.
    SingularMassMatrixError
        The motion reached a configuration where M is singular; names the time, the state
        and the diagnosis.
    SimulationError
        The integrator failed for another reason (``status``: a member of Status).
    """
    nm = _as_numeric(system)
    eq = nm.equations
    table = _table_key(eq)
    key = None
    if table is not None and options is None and t_eval is None and events is None and stop_on is None and \
            sample_time is None:
        key = _checked_key(table, id(nm), t_end, initial, inputs, params, dt, rtol, atol, method, max_step,
                           backend, step, progress, constraints)
        hit = per_equations(eq).get("simulate.checked", _NO_RUNS).get(key) if key is not None else None
        if hit is not None and hit[0] is nm and _same_limits(hit[4]):  # the same call as one checked before: run it
            return hit[5]() if hit[5] is not None else _run_compiled(hit[1], hit[2], hit[3], hit[2].x0)
    if options is not None:
        if not isinstance(options, SimulationOptions):
            raise ModelError([Problem(f"options must be a SimulationOptions (lagrangian.numeric.SimulationOptions"
                                      f"(...)), got {type(options).__name__} {shown_value(options)}; or pass each "
                                      "option as its own argument (t_end=..., dt=...)", key="options")])
        base = options
    elif table is not None:  # the model file's options, built again only when its [simulation] table changed
        base = _last(eq, "simulate.options", table, lambda: SimulationOptions.from_model(eq.model))
    else:
        base = SimulationOptions.from_model(eq.model)
    merged = base.merged(
        t_end=t_end, initial=initial, inputs=inputs, params=params, dt=dt, t_eval=t_eval, rtol=rtol, atol=atol,
        method=method, max_step=max_step, backend=backend, step=step, events=events, stop_on=stop_on,
        progress=progress, sample_time=sample_time, constraints=constraints)
    opts = merged.read_signals()
    run = _prepare(nm, opts)
    if eq.is_constrained:
        return _simulate_constrained(nm, run, opts, base.initial)
    fast = _compiled_model(nm, opts.backend, run.solver, run.u_exprs)
    if fast is not None:
        if key is not None and opts is merged:  # (a model file's CSV inputs are read, and checked, every time)
            _keep_checked(eq, key, nm, fast, run, opts)
        return _run_compiled(fast, run, opts, run.x0)
    if run.event_exprs:
        raise ModelError("events are watched by the compiled integrators: give inputs as expression strings "
                         "and use backend='auto', 'numba' or 'c'")
    return _simulate_scipy(nm if isinstance(nm, NumericModel) else compile_equations(eq), run, opts)


#: The checked calls of simulate() kept per Equations (the newest; see _checked_key).
_CHECKED_CALLS = 16
_NO_RUNS: dict = {}


class _Uncheckable(Exception):
    """An argument _checked_key does not key (an array, a function, a symbol as a name...)."""


def _argument_key(value):
    """`value` as part of a key that is equal only for values simulate() treats alike: None, a str,
    a bool, an int, a float (its exact bits: -0.0 is not 0.0), or a dict (of str), list or tuple of
    those; _Uncheckable for anything else. (A float inside a dict, list or tuple is keyed in place,
    without a call: the key of every repeated call is built here.)"""
    kind = type(value)
    if kind is dict:
        items = [(name, (_FLOAT, v.hex()) if type(v) is _FLOAT else _argument_key(v)) for name, v in value.items()]
        for name, _ in items:
            if type(name) is not str:
                raise _Uncheckable
        return tuple(items)
    if value is None or kind is str:
        return value
    if kind is float:
        return kind, value.hex()
    if kind is int or kind is bool:
        return kind, value
    if kind is list or kind is tuple:
        return kind, tuple([(_FLOAT, v.hex()) if type(v) is _FLOAT else _argument_key(v) for v in value])
    raise _Uncheckable


_FLOAT = float


def _table_key(eq: Equations):
    """The model file's [simulation] table (``model.simulation``) as it reads now, as a key (see
    _argument_key); None when it holds anything else (a CSV input, an array...)."""
    try:
        return _argument_key(getattr(eq.model, "simulation", None))
    except _Uncheckable:
        return None


def _checked_key(table, *arguments):
    """The key of a call of simulate() whose options, once merged with the model file's and checked
    against the model, can be kept (with the compiled model and the run they give: _keep_checked)
    and taken again for the same call: the model file's [simulation] table as it reads now (`table`,
    _table_key's) and the arguments (plain values, see _argument_key); the limits the checks read
    from the environment are compared when the call is taken again (_keep_checked). None for
    arguments it cannot key: such a call takes the whole path."""
    try:
        return table, tuple([a if a is None else _argument_key(a) for a in arguments])
    except _Uncheckable:
        return None


def _keep_checked(eq: Equations, key, nm, fast: CompiledModel, run: _Run, opts: SimulationOptions) -> None:
    """Keep what the call with `key` checked and found (its numeric model, compiled model, _Run and
    options) with the values of the limits its checks read from the environment (lagrangian._limits:
    the output rows, the variational integrator's steps, the exponents of the expressions parsed),
    for the same call again: the newest _CHECKED_CALLS of them."""
    limits = [MAX_ROWS]
    if isinstance(run.solver, Variational):
        limits.append(MAX_STEPS)
    if opts.events or any(isinstance(v, str) for v in opts.inputs.values()):
        limits.append(MAX_EXPONENT)
    kept = cached(eq, "simulate.checked", dict)
    kept.pop(key, None)
    repeat = None  # (the Equations' model is a frozen snapshot: its named outputs cannot change)
    if not isinstance(run.solver, Variational) and not run.event_exprs and run.sampling is None and \
            not (eq.model is not None and eq.model.outputs):
        repeat = _Repeat(fast, run, opts)
    kept[key] = (nm, fast, run, opts, tuple((limit.variable, os.environ.get(limit.variable)) for limit in limits),
                 repeat)
    while len(kept) > _CHECKED_CALLS:
        kept.pop(next(iter(kept)), None)


def _same_limits(limits) -> bool:
    """Whether the limits' environment variables read as they did (_keep_checked's (name, value) pairs)."""
    get = os.environ.get
    for variable, value in limits:
        if get(variable) != value:
            return False
    return True


class _Repeat:
    """A kept call's compiled DOP853 run (no events, no sampled inputs, no constraints, a model
    without named outputs: _keep_checked), prepared for the same call again: the kernel's arguments
    (PreparedDop853) and the Trajectory's fields (RunTemplate) built once. A complete run with finite
    states becomes its Trajectory at once; any other (a failure, a stop, a non-finite state, inputs
    that switch) goes on as _run_compiled's (_finish_compiled: the same errors, the same partial
    rows). The same kernel with the same arguments: the same numbers bit for bit."""

    __slots__ = ("fast", "run", "opts", "prog", "call", "template")

    def __init__(self, fast: CompiledModel, run: _Run, opts: SimulationOptions):
        self.fast, self.run, self.opts = fast, run, opts
        self.prog = _input_programs(fast.equations, run.u_exprs)
        self.call = PreparedDop853(fast, run.x0, run.times, run.p, self.prog, float(opts.rtol), float(opts.atol),
                                   opts.max_step)
        self.template = RunTemplate(fast.equations, run.p)

    def __call__(self) -> Trajectory:
        call, times = self.call, self.call.times
        status, X, U, E, stats, info, done = call.run(self.opts.progress)
        nfev, nstep, nreject, k, nswitch = stats.tolist()
        rows = len(times)
        if status or k != rows or done[0] != rows or self.prog.nswitch or not np.isfinite(X).all():
            return _finish_compiled(self.fast, self.run, self.opts, self.run.x0, None, self.prog,
                                    call.raw(status, X, U, E, stats, info, done))
        return self.template.make(times, X, U, E, {"backend": self.fast.backend, "method": self.run.solver.name,
                                                   "nfev": nfev, "nstep": nstep, "nreject": nreject,
                                                   "status": Status.SUCCESS})


@dataclass(frozen=True)
class _Run:
    """What simulate() runs, checked against the model: the solver, the output times, the parameter
    values, the initial state, the inputs (a Python function and, for compiled code, expressions),
    the sampled inputs and the event functions."""

    solver: Solver
    times: np.ndarray
    p: np.ndarray
    x0: np.ndarray
    u_of: Callable
    u_exprs: list | None
    sampling: object
    event_exprs: dict


def _prepare(nm, opts: SimulationOptions) -> _Run:
    """The options checked against the model, every problem at once (ModelError), as a _Run."""
    eq = nm.equations
    problems = opts.problems()
    solver = solver_of(opts.method, opts.step, problems)
    if opts.backend not in BACKENDS:
        problems.append(Problem(f"unknown backend '{opts.backend}'{did_you_mean(str(opts.backend), BACKENDS, 0.5)}; "
                                f"choose one of {', '.join(BACKENDS)}", key="backend"))
    problems += opts.step_problems()
    p = _parameters(nm, opts.params, problems)
    x0 = _initial_state(nm, opts.initial, problems)
    u_of, u_exprs = _input_function(nm, opts.inputs, p, problems)
    problems += signal_problems(opts.inputs, eq.t, 0.0, opts.t_end)
    t_end = opts.t_end if isinstance(opts.t_end, numbers.Real) else None
    sampling = sample_times(opts.sample_time, nm.input_names, t_end, problems)
    event_exprs = _event_expressions(nm, opts.events, opts.stop_on, problems)
    name = solver.name if solver is not None else str(opts.method)
    if solver is not None:
        problems += solver.problems(
            backend=opts.backend if opts.backend in BACKENDS else "auto", sample_time=opts.sample_time,
            t_eval=opts.t_eval, callable_inputs=u_exprs is None, events=bool(event_exprs),
            velocity_dependent_mass=isinstance(solver, Variational) and any(
                set(e.free_symbols) & set(eq.core.qd) for e in eq.core.M))
    constraint_problems = opts.constraints_problems()
    problems += constraint_problems
    if not constraint_problems and opts.constraints == "eliminate":
        _elimination_problems(eq, name, problems)
    if eq.is_constrained and not constraint_problems:
        _constrained_problems(nm, name, event_exprs, opts.sample_time, opts.constraints, problems)
    step = solver.step if isinstance(solver, Variational) else opts.step
    problems += _work_problems(opts.t_end, opts.dt, opts.t_eval, step, name)
    if problems:
        raise ModelError(problems)
    if opts.t_eval is None:  # the same grid as the last run's, as a rule (read-only, shared)
        times = _last(eq, "simulate.times", (float(opts.t_end), float(opts.dt)),
                      lambda: read_only(output_times(float(opts.t_end), float(opts.dt))))
    else:
        times = requested_times(opts.t_end, opts.dt, opts.t_eval)
    return _Run(solver, times, p, x0, u_of, u_exprs, sampling, event_exprs)


def _simulate_scipy(nm: NumericModel, run: _Run, opts: SimulationOptions) -> Trajectory:
    """The run on SciPy's solve_ivp calling the portable NumPy functions, the singular-mass-matrix
    event watched (and the sampled inputs held, one solve_ivp from one sample instant to the next)."""
    from scipy.integrate import solve_ivp

    from .._progress import Progress

    times, p, x0, u_of, sampling = run.times, run.p, run.x0, run.u_of, run.sampling
    nfev = 0
    last = [None, None, 1.0]  # t, x and inertia measure of the latest right-hand side
    bar = Progress(1000, "simulating", enabled=opts.progress)
    per_time = 1000 / float(times[-1]) if times[-1] > 0 else 0.0
    m = len(nm.input_names)
    held = np.zeros(m)
    hold = sampling.hold[:m].astype(bool) if sampling is not None else np.zeros(m, bool)

    def u_at(t, x):
        u = u_of(t, x)
        return np.where(hold, held, u) if sampling is not None else u

    def rhs(t, x):
        nonlocal nfev
        nfev += 1
        if bar.enabled:
            bar.set(int(t * per_time))
        qdd, last[2] = nm.solve(t, x, u_at(t, x), p)
        raise_on_failure(t, x, last[2])
        last[0], last[1] = t, x
        return np.concatenate((x[nm.n:], qdd))

    def near_singular(t, x):
        # the integrator has just evaluated the right-hand side at the end of the step: reuse it
        if t == last[0] and np.array_equal(x, last[1]):
            return last[2] - _EVENT_RATIO
        return nm.singular_ratio(t, x, u_at(t, x), p) - _EVENT_RATIO

    near_singular.terminal = True
    near_singular.direction = -1
    history = np.zeros((len(sampling.samples) if sampling is not None else 0, m))
    method, rtol, atol, max_step = run.solver.name, opts.rtol, opts.atol, opts.max_step
    try:
        if times[-1] == 0:  # t_end < dt: the initial state is the whole output
            if sampling is not None:
                held[:] = history[0] = u_of(0.0, x0)
            rhs(0.0, x0)  # still stops with a clear error when M is singular at the start
            sol = _Initial(times, x0)
        elif sampling is None:
            sol = solve_ivp(rhs, (0.0, float(times[-1])), x0, method=method, t_eval=times, rtol=rtol, atol=atol,
                            max_step=max_step, events=near_singular)
        else:
            sol = _solve_sampled(solve_ivp, rhs, near_singular, u_of, held, history, sampling, x0, times,
                                 method=method, rtol=rtol, atol=atol, max_step=max_step)
    except _Singular as s:
        raise failure(nm, Status.SINGULAR_MASS_MATRIX, s.t, s.x, s.ratio, p) from None
    except _NotFinite as s:
        raise failure(nm, Status.FORCING_NOT_FINITE, s.t, s.x, None, p) from None
    finally:
        bar.close()

    def trajectory(t, x, status, failure=None) -> Trajectory:
        U = np.array([u_of(ti, xi) for ti, xi in zip(t, x)]).reshape(len(t), m)
        if sampling is not None:
            U[:, hold] = held_inputs(sampling, history, t)[:, hold]
        energy = None if nm.equations.explicit_time else [nm.energy(ti, xi, ui, p) for ti, xi, ui in zip(t, x, U)]
        stats = {"backend": "scipy", "method": method, "nfev": nfev}
        if sampling is not None:
            stats["samples"] = int(np.searchsorted(sampling.samples, t[-1], side="right"))
        return run_trajectory(nm.equations, t, x, U, p, energy=energy, stats=stats, status=status,
                              message=sol.message, failure=failure)

    error = None
    if sol.status == -1 and last[0] is not None:  # where the step size collapsed: M lost its inertia?
        kept = _inertia_kept(nm, x0, last[0], last[1], p)
        if kept < _KEPT_INERTIA:
            error = failure(nm, Status.STEP_TOO_SMALL, last[0], last[1], last[2], p, kept=kept)
    if error is None and sol.status != 0:
        if sol.status == 1 and len(sol.t_events[0]):
            te, xe = sol.t_events[0][0], sol.y_events[0][0]
        else:  # (no output yet when the first step failed: the start)
            te, xe = _last_state(sol) if len(sol.t) else (float(times[0]), x0)
        measure = nm.singular_ratio(te, xe, u_at(te, xe), p) if sol.status == 1 or len(sol.t) else None
        error = failure(nm, sol.status, te, xe, measure, p, message=sol.message)
    if error is not None:
        # the output times reached: solve_ivp's t_eval points before the failure (none when its first step failed)
        reached = _finite_rows(sol.y.T) if len(sol.t) else 0
        if reached:
            error.partial = trajectory(sol.t[:reached], sol.y.T[:reached], error.status if isinstance(
                error, SimulationError) else Status.SINGULAR_MASS_MATRIX, failure=str(error))
        raise error
    if not np.all(np.isfinite(sol.y)):
        raise failure(nm, Status.SOLUTION_NOT_FINITE, None, None, None, p)
    return trajectory(sol.t, sol.y.T, Status.SUCCESS)


def _solve_sampled(solve_ivp, rhs, near_singular, u_of, held, history, sampling, x0, times, **options):
    """solve_ivp from one sample instant to the next, the sampled inputs held (in `held`, set at
    each instant from u_of(t, x); `history` receives them); the outputs at `times` joined as one
    solution."""
    import types

    hold = sampling.hold[:len(held)].astype(bool)
    t_end = float(times[-1])
    instants = [float(s) for s in sampling.samples if s < t_end] + [t_end]
    x = np.array(x0, dtype=float)
    ts, ys = [], []
    status, message = 0, "The solver successfully reached the end of the integration interval."
    t_events, y_events = np.zeros(0), np.zeros((0, len(x)))
    for k in range(len(instants) - 1):
        a, b = instants[k], instants[k + 1]
        now = sampling.which[k, :len(held)].astype(bool) & hold
        held[now] = np.asarray(u_of(a, x), dtype=float)[now]
        history[k] = held
        last = k == len(instants) - 2  # the last segment ends at the last output time
        inside = times[(times >= a) & ((times <= b) if last else (times < b))]
        sol = solve_ivp(rhs, (a, b), x, t_eval=inside if last else np.append(inside, b), events=near_singular,
                        **options)
        keep = np.ones(len(sol.t), bool) if last else sol.t < b
        ts.append(sol.t[keep])
        ys.append(sol.y[:, keep])
        if sol.status != 0:
            status, message = sol.status, sol.message
            t_events, y_events = sol.t_events[0], sol.y_events[0]
            break
        x = sol.y[:, -1]
    else:
        x = sol.y[:, -1]
        k = len(instants) - 1
        if k < len(sampling.samples) and sampling.samples[k] == t_end:  # a sample instant at the end too
            now = sampling.which[k, :len(held)].astype(bool) & hold
            held[now] = np.asarray(u_of(t_end, x), dtype=float)[now]
            history[k] = held
    t = np.concatenate(ts) if ts else np.zeros(0)
    y = np.concatenate(ys, axis=1) if ys else np.zeros((len(x), 0))
    return types.SimpleNamespace(t=t, y=y, status=status, message=message, t_events=[t_events],
                                 y_events=[y_events])


class _Initial:
    """The 'solution' when the only output time is t = 0."""

    def __init__(self, times, x0):
        self.t, self.y, self.status, self.message = times[:1], x0[:, None], 0, "t_end < dt: initial state only"
        self.t_events = [np.zeros(0)]


def _last_state(sol):
    # solve_ivp's t_eval output may stop short of where the integrator failed; use its last point.
    return float(sol.t[-1]), sol.y[:, -1]


def _state_text(nm: NumericModel, x) -> str:
    return ", ".join(f"{k} = {v:.6g}" for k, v in zip(nm.state_names, x))


def _inertia_kept(nm, x0, t, x, p) -> float:
    """The least inertia M(t, x) has kept of the start's: the smallest eigenvalue of
    D0^-1/2 M(t, x) D0^-1/2, D0 the diagonal of M at the start (1 for a diagonal M that has not
    changed; 0 where a velocity's inertia has vanished, as T = x**2*x_dot**2/2 does at x = 0, which
    the scale-free inertia measure of a diagonal M cannot see). 1 where it cannot be told."""
    u = np.zeros(len(nm.input_names))  # T, hence M, never depends on the inputs (Model.check)
    with np.errstate(all="ignore"):
        d0 = np.diag(nm.mass_matrix(0.0, np.asarray(x0, float), u, p))
        M = nm.mass_matrix(float(t), np.asarray(x, float), u, p)
    if not (np.all(d0 > 0) and np.all(np.isfinite(d0)) and np.all(np.isfinite(M))):
        return 1.0
    s = 1.0 / np.sqrt(d0)
    return float(np.linalg.eigvalsh(M * s[:, None] * s[None, :]).min())


def _singular_error(nm: NumericModel, t, x, ratio, p, kept: float | None = None) -> SingularMassMatrixError:
    """The error of a run that reached a singular M: where, and the diagnosis of M with the parameter
    values `p` it ran with. `kept`: the inertia left of the start's (_inertia_kept), when that is how
    it was found (the integrator's step size collapsed there)."""
    state = dict(zip(nm.state_names, map(float, x)))
    from ._codegen import large_model

    if large_model(nm.equations):  # its symbolic diagnosis would take minutes to hours: M's numbers here
        from ..equations._singular import diagnosis_at

        with np.errstate(all="ignore"):
            M = nm.mass_matrix(float(t), np.asarray(x, float), np.zeros(len(nm.input_names)), p)
        report, diagnosis = None, diagnosis_at(nm.equations, M, state)
    else:
        report = singularities(nm.equations, parameters=dict(zip(nm.parameter_names, map(float, p))))
        diagnosis = report.text()
    if report is not None and not report.singular:  # no real zero of det M for these values: say why all the same
        diagnosis = "\n".join(diagnosis.splitlines()[:-1] + [
            "det M has no real zero for these parameter values, yet M is singular to working precision in this "
            "state: a mass or inertia negligible next to the others, or a motion that runs away to where M has no "
            "inertia left; check the parameter values and the initial state."])
    how = (f"its least inertia is {kept:.3g} of that at the start" if kept is not None
           else f"inertia measure of M = {ratio:.3g}")
    msg = (f"the mass matrix became singular at t = {float(t):.6g} ({how}) "
           f"in the state {_state_text(nm, x)}: q_ddot cannot be solved for there, so the simulation stops.\n"
           f"{diagnosis}")
    return SingularMassMatrixError(msg, time=float(t), state=state, diagnosis=diagnosis)


def _compiled_model(nm, backend: str, method: "str | Solver", u_exprs):
    """The CompiledModel to integrate with, or None for the SciPy path (a solver that does not
    run compiled, backend "scipy", or "auto" with inputs compiled code cannot take)."""
    solver = solver_of(method)
    if isinstance(nm, NumericModel) or backend == "scipy":
        return None
    if not solver.compiled:
        return None  # SciPy's other methods
    if isinstance(nm, CompiledModel):
        if backend in ("auto", nm.backend):
            if u_exprs is None:
                raise ModelError(_CALLABLE_INPUT)
            return nm
        nm = _names(nm.equations)
    from ._codegen import Unsupported
    from ._inputs import NotCompilable

    try:
        if u_exprs is None:
            raise NotCompilable(_CALLABLE_INPUT)
        _input_programs(nm.equations, u_exprs)
        cm = compile_equations(nm.equations, backend=backend)
        if not isinstance(cm, CompiledModel):  # "auto": a large model without a C compiler (auto_backend)
            return None if solver.scipy else compile_equations(nm.equations, backend="numba")
        return cm
    except (Unsupported, NotCompilable) as exc:
        if backend == "auto" and solver.scipy:
            return None
        raise ModelError(f"backend '{backend}' cannot run this model: {exc}; use backend='scipy'") from None


def _input_programs(eq: Equations, u_exprs):
    """The compiled programs of the inputs (expressions of t, the state and the parameters), kept
    for the next run with the same inputs."""
    return _last(eq, "simulate.inputs", tuple(u_exprs), lambda: programs(
        u_exprs, eq.t, list(eq.parameters), states=_names(eq).states))


_CALLABLE_INPUT = ("an input is a Python function, which compiled code cannot call: give it as an expression "
                   "string of t, the coordinates, velocities and parameters (for example '1.5*sin(3*t)' or "
                   "'-20*(q2 - pi/2) - 5*q2_dot'), or use backend='scipy'")


def _event_expressions(nm, events, stop_on, problems) -> dict:
    """{name: sympy expression} of the event functions; problems for bad names or expressions."""
    if not events and not stop_on:  # (before the imports: simulate() asks on every call)
        return {}
    from ..errors import ExpressionError
    from ..model._expr import parse_expression

    events = dict(events or {})
    eq = nm.equations
    names = {"t": eq.t, **{s.name: s for s in (*eq.coordinates, *eq.velocities, *eq.inputs)},
             **{s.name: s for s in eq.parameters}}
    out = {}
    for name, spec in events.items():
        try:
            out[str(name)] = parse_expression(str(spec), names)
        except ExpressionError as exc:
            problems.append(Problem(f"event '{name}': {exc} (an event is an expression of t, the coordinates, "
                                    "velocities, inputs and parameters)", key=f"events.{name}"))
    if isinstance(stop_on, str):
        stop_on = (stop_on,)
    for name in stop_on:
        if name not in events:
            known = (f"the events are {', '.join(events)}" if events else
                     f"no events are given: define it first, e.g. events={{'{name}': 'q1'}} "
                     f"(on the command line: --event {name}=EXPR)")
            problems.append(Problem(f"stop_on names '{name}', which is not one of the events"
                                    f"{did_you_mean(name, list(events), 0.5)}; {known}", key="stop_on"))
    return out


def _run_compiled(fast: CompiledModel, run: _Run, opts: SimulationOptions, x0, cm=None) -> Trajectory:
    """The one compiled run, from x0: DOP853 in numba or C (events and sampled inputs included) or the
    variational integrator. A model with constraints (`cm`, its ConstrainedModel: m > 0, and x0
    consistent) integrates the saddle-point right-hand side with the projection onto the constraints
    after every accepted step (see _codegen_constrained), and its Trajectory has the multipliers and
    the constraint drift; at m = 0 nothing is projected. A failure raises its error with the finite
    output rows reached (SimulationError.partial)."""
    eq = fast.equations
    solver, times, p, event_exprs = run.solver, run.times, run.p, run.event_exprs
    prog = _input_programs(eq, run.u_exprs)
    if isinstance(solver, Variational):  # (not for constrained models: _constrained_problems)
        every = solver.steps(float(opts.dt))
        raw = run_variational(fast, x0, float(opts.dt) / every, every * (len(times) - 1), every, p, prog)
    else:
        eprog, terminal = None, ()
        if event_exprs:
            eprog = _last(eq, "simulate.events", tuple(event_exprs.values()), lambda: programs(
                list(event_exprs.values()), eq.t, list(eq.parameters), states=_names(eq).states, inputs=eq.inputs,
                switches=False))
            terminal = [int(name in opts.stop_on) for name in event_exprs]
        projection = {}
        if cm is not None:
            from ._codegen_constrained import work_size

            projection = {"project": _address(fast.project_c), "nwork": work_size(cm.n, cm.m)}
        raw = run_dop853(fast, x0, times, p, prog, float(opts.rtol), float(opts.atol), opts.max_step, events=eprog,
                         terminal=terminal, progress=opts.progress, sampling=run.sampling, **projection)
    return _finish_compiled(fast, run, opts, x0, cm, prog, raw)


def _finish_compiled(fast: CompiledModel, run: _Run, opts: SimulationOptions, x0, cm, prog, raw) -> Trajectory:
    """The Trajectory (or the error) of _run_compiled's run `raw`."""
    solver, times, p, event_exprs = run.solver, run.times, run.p, run.event_exprs
    stats = {"backend": fast.backend, "method": solver.name, "nfev": raw.nfev}
    error = None if raw.status == 0 and cm is None else _compiled_failure(fast, cm, raw, p, x0)  # (0: SUCCESS)
    if error is not None:
        error.partial = _compiled_trajectory(fast, cm, times, raw, p, prog, run.sampling, stats, failure=error)
        raise error
    stats["nstep"], stats["nreject"] = raw.nstep, raw.nreject
    if prog.nswitch:
        stats["switches"] = raw.nswitch
    stopped = raw.status == Status.EVENT_STOP
    found = {}
    if event_exprs:
        names = list(event_exprs)
        keep = raw.event_t <= (raw.stop_t if stopped else math.inf)
        for k, name in enumerate(names):
            sel = keep & (raw.event_k == k)
            xe = np.array(raw.event_x[sel], float).reshape(-1, 2 * fast.n)
            if cm is not None:  # on the constraints, as the outputs
                _project_rows(cm, raw.event_t[sel], xe, p, every=True)
            found[name] = {"t": read_only(raw.event_t[sel], float), "x": read_only(xe, float)}
        if stopped:
            stats["stopped_by"] = names[int(raw.stop_measure)]
            stats["stop_time"] = raw.stop_t
            times = times[: len(raw.t)]
    if not np.isfinite(raw.x).all():
        raise failure(fast, Status.SOLUTION_NOT_FINITE, None, None, None, p)
    return _compiled_trajectory(fast, cm, times, raw, p, prog, run.sampling, stats, found, stopped=stopped)


def _compiled_failure(fast: CompiledModel, cm, raw, p, x0):
    """The error of a compiled run (None: it ended as asked), by the one map `failure`; with
    constraints (`cm`), a singular saddle-point system is told apart by its two measures: the kernel's
    is min(r_M, rho_G) (_codegen_constrained), and the smaller of the two, in the same algorithm
    transcribed in NumPy, says whether G lost rank (a dead point) or M is singular."""
    if cm is None:
        return failure(fast, raw.status, raw.stop_t, raw.stop_x, raw.stop_measure, p, x0=x0)
    if raw.status in (Status.PROJECTION_SINGULAR, Status.PROJECTION_NOT_FINITE):  # info[1]: the projection's code
        from ._constrained import projection_failure

        return projection_failure(cm, raw.stop_t, raw.stop_x, int(raw.stop_measure), p)
    if raw.status in (1, 2) or (raw.status not in (0, 3, 4) and raw.stop_measure < 1e-6):
        r_M, rho = cm.measures(raw.stop_t, raw.stop_x, np.zeros(len(fast.input_names)), p)
        if rho < r_M:
            return _dead_point(cm, raw.stop_t, raw.stop_x, p)
        return _singular_error(fast, raw.stop_t, raw.stop_x, raw.stop_measure, p)
    return failure(fast, raw.status, raw.stop_t, raw.stop_x, None, p)  # status 3, -1, ...


def _dead_point(cm, t, x, p) -> SimulationError:
    """The error of a constrained model whose constraints' Jacobian G lost rank at (t, x)."""
    from ._constrained import singular_constraint_message

    return SimulationError(singular_constraint_message(cm, t, x, p), status=Status.SINGULAR_CONSTRAINTS,
                           time=float(t))


def _compiled_trajectory(fast: CompiledModel, cm, times, raw, p, prog, sampling, stats, events=None, *,
                         failure=None, stopped: bool = False) -> Trajectory | None:
    """The Trajectory of a compiled run's output rows at `times` (all of them, or those up to an
    event's stop, whose last rows, from the stopping step's interpolant, are projected here when the
    model has constraints); with `failure` (the run's error), the finite rows before it as a partial
    Trajectory (its status the error's; with constraints, without the last rows where the
    multipliers cannot be solved for), None without rows. Without constraints, the arrays of the run
    (its states, inputs and energy) become the Trajectory's as they are (run_trajectory's `fresh`)."""
    if cm is not None:
        from ._constrained import ConstraintSingular, multipliers_and_drift

    reached = len(times) if failure is None else _finite_rows(raw.x[:len(raw.t)])
    m = len(fast.input_names)
    while reached:
        t, X = (times, raw.x) if reached == len(times) == len(raw.x) else (times[:reached], raw.x[:reached])
        held = None
        if sampling is not None:
            held = (sampling.hold, held_inputs(sampling, raw.held[:, :m], t))
            stats["samples"] = int(np.searchsorted(sampling.samples, t[-1], side="right"))
        if cm is not None and stopped:
            X = np.array(X)
            _project_rows(cm, t, X, p)
        U, energy = inputs_and_energy(fast, t, X, p, prog, held, run=raw if cm is None else None)
        Lam = None
        if cm is not None:
            try:  # the compiled rhs's multipliers after a run, the NumPy solve (it tells a dead point) after a failure
                Lam, drift = multipliers_and_drift(cm, t, X, U, p, fast=fast if failure is None else None)
            except ConstraintSingular:
                if failure is None:
                    raise
                reached -= 1  # the last row already at the dead point: keep those before it
                continue
            stats.update(projection="coordinate projection after every step", constraint_drift=drift)
        return run_trajectory(fast.equations, t, X, U, p, energy=energy, stats=stats, events=events,
                              status=raw.status if failure is None else _status(failure), multipliers=Lam,
                              failure=None if failure is None else str(failure), fresh=cm is None)
    return None


def _status(error) -> Status:
    """The status of a failed run's error (the singular-mass-matrix error has none of its own)."""
    return error.status if isinstance(error, SimulationError) else Status.SINGULAR_MASS_MATRIX


def _finite_rows(x: np.ndarray) -> int:
    """How many rows of `x`, from the first, are finite: the rows a failed run may keep."""
    bad = ~np.all(np.isfinite(x), axis=1)
    return int(np.argmax(bad)) if bad.any() else len(x)


def failure(nm, status, t, x, measure, p, *, x0=None, kept: float | None = None,
            message: str | None = None) -> SimulationError | SingularMassMatrixError | None:
    """The error of a run that ended with `status` (a Status member or its code) at time `t` in the
    state `x` with the inertia measure `measure` of M there (None: unknown); None for a run that
    ended as asked (SUCCESS, EVENT_STOP). The one map from a status to an error, for every path:
    compiled, SciPy (its status 1 is the singular-mass-matrix event, -1 a failed step; `message` its
    own words) and constrained.

    A failed step where M has (nearly) lost its inertia is the singular-mass-matrix error: the
    inertia measure below 1e-6, or `kept` (the least inertia M has kept of the start's, computed from
    `x0` when not given) below _KEPT_INERTIA."""
    status = Status.of(status)
    if status in (Status.SUCCESS, Status.EVENT_STOP):
        return None
    if status in (Status.SINGULAR_EVENT, Status.SINGULAR_MASS_MATRIX):
        return _singular_error(nm, t, x, measure, p)
    if status == Status.SOLUTION_NOT_FINITE:
        return SimulationError(f"the solution is not finite (NaN or infinity): {status.fix}", status=status)
    t = float(t)
    where = f"state {_state_text(nm, x)}"
    if status == Status.FORCING_NOT_FINITE:
        return SimulationError(f"the forcing f is not finite (NaN or infinity) at t = {t:.6g} in the {where}: "
                               f"{status.fix}", status=status, time=t)
    if status == Status.VARIATIONAL_NOT_CONVERGED:
        return SimulationError(f"the variational integrator stopped at t = {t:.6g}: its implicit midpoint step did "
                               f"not converge ({where}); {status.fix}", status=status, time=t)
    if status in (Status.PROJECTION_SINGULAR, Status.PROJECTION_NOT_FINITE):  # (with its model: projection_failure)
        return SimulationError(f"the projection onto the constraints failed at t = {t:.6g} in the {where}: "
                               f"{status.message[:1].lower()}{status.message[1:]} {status.fix}", status=status, time=t)
    if status == Status.CHATTERING:
        return SimulationError(f"the inputs switch at every step near t = {t:.6g} (the last steps shorter than "
                               f"{measure:.2g} s, {where}): the motion slides on a switching surface of the law (a "
                               f"sliding mode, which only infinitely fast switching follows); {status.fix}",
                               status=status, time=t)
    if measure is not None and measure < 1e-6:
        return _singular_error(nm, t, x, measure, p)
    if kept is None and x0 is not None and status == Status.STEP_TOO_SMALL:
        kept = _inertia_kept(nm, x0, t, x, p)
    if kept is not None and kept < _KEPT_INERTIA:  # the step size collapsed where M lost its inertia
        return _singular_error(nm, t, x, measure, p, kept=kept)
    text = message or (status.message if isinstance(status, Status) else f"status {status}")
    return SimulationError(f"the integrator stopped at t = {t:.6g}: {text} ({where}); {Status.STEP_TOO_SMALL.fix}",
                           status=status, time=t)


def _constrained_problems(nm, method, event_exprs, sample_time, constraints, problems) -> None:
    """What the integration of a constrained model does not do, each with its reason and its fix."""
    if method == "variational":
        problems.append(Problem("method 'variational' does not integrate constrained models: use method='DOP853' "
                                "(projected onto the constraints after every step). The midpoint rule's discrete "
                                "Euler-Lagrange equations would need the constraint forces G^T lambda in them and "
                                "g(q) = 0 imposed at every step (a RATTLE step, not built here)", key="method"))
    if constraints == "eliminate" and event_exprs:
        problems.append(Problem("events are not watched with constraints='eliminate': its right-hand side finds the "
                                "dependent coordinates by Newton on g(q, t) = 0 at every evaluation, in SciPy's "
                                "integrators, while crossings are located by the compiled DOP853 of the projected "
                                "integration: use constraints='project' (the default)", key="events"))


def _independent_state_names(model) -> set[str]:
    """[simulation] independent coordinates and independent speeds (default: the independent
    coordinates' velocities): SimulationOptions.held."""
    return set(SimulationOptions.from_model(model).held)


def given_initial_names(model) -> list[str]:
    """The initial coordinates and velocities that a simulation of `model` with its own initial values
    keeps as given, in state order: the model file's initial values; with constraints and
    independent coordinates named, those and the independent speeds instead (the file's other values
    are starting guesses for the assembly). Giving these names' values (and any others the user
    sets) simulates as the defaults do: the playground's sliders send them."""
    options = SimulationOptions.from_model(model)
    names = set(options.held) if model.constraints else set()
    if not (model.constraints and options.independent):
        names |= set(options.initial)
    order = [q.name for q in model.coordinates] + [f"{q.name}_dot" for q in model.coordinates]
    return [n for n in order if n in names]


def _consistent_guess(eq: Equations, x0, initial, model_initial) -> tuple[np.ndarray, set[str]]:
    """(x0 with the model file's values as guesses, the names consistent_state keeps fixed) for a start
    from `x0`: the independent coordinates and speeds and the values the caller gave (`initial`, a
    mapping), or, without `initial`, the model's own given names (given_initial_names)."""
    names = eq.state_names
    fixed = _independent_state_names(eq.model)
    x0 = np.array(x0, float)
    if isinstance(initial, Mapping):
        fixed |= {getattr(k, "name", k) for k in initial}
        for k, v in (model_initial or {}).items():  # the model file's values as guesses for the others
            if k in names and k not in fixed:
                x0[names.index(k)] = v
    elif initial is None:
        fixed = set(given_initial_names(eq.model))
    if getattr(eq.model, "joints", None):  # quaternion joints start by the one rule (model._joints.quaternion_start)
        from ..model._joints import quaternion_start

        caller = None if initial is None else {k: x0[i] for i, k in enumerate(names) if not isinstance(
            initial, Mapping) or k in {getattr(c, "name", c) for c in initial}}
        start, _ = quaternion_start(eq.model, model_initial, caller)
        for k, v in start.items():
            x0[names.index(k)] = v
        fixed |= set(start)
    return x0, fixed


def _constrained_numbers(eq: Equations):
    """The ConstrainedModel of `eq` (M, f, G, c and the projection, evaluated by SymEngine and NumPy)."""
    from ._constrained import constrained_model

    return constrained_model(eq, compile_equations(eq))


def _simulate_constrained(nm, run: _Run, opts: SimulationOptions, model_initial) -> Trajectory:
    """simulate() of a model with constraints: consistent initial state, then the projected
    integration of M q_ddot = f + G^T lambda, G q_ddot = c (see _constrained): the one compiled run
    with its projection (_run_compiled), or SciPy's integrators.

    The initial state is moved onto the constraints keeping fixed the independent coordinates
    ([simulation] independent) and the independent speeds ([simulation] independent_speeds; default:
    the independent coordinates' velocities), and the values the caller gave (``opts.given``);
    the model file's other initial values are starting guesses (the assembly closest to them is
    found). Without independent coordinates and without given values, the model file's are kept.

    Events are watched by the compiled run: the crossings are located on the interpolant of each
    step, which starts from the projected state, and the states recorded there are projected as the
    outputs are. Sampled inputs are held there too, and on SciPy's projected integration one run
    goes from one sample instant to the next (_integrate_sampled)."""
    from ._constrained import ConstraintSingular, consistent_state, constrained_model, integrate

    eq = nm.equations
    fast = None if opts.constraints == "eliminate" else _compiled_model(nm, opts.backend, run.solver, run.u_exprs)
    if fast is None and run.event_exprs:  # as for a model without constraints
        raise ModelError("events are watched by the compiled projected integration of a constrained model: give "
                         "the inputs as expression strings and use method='DOP853' with a compiled backend "
                         "(backend='auto')")
    if not isinstance(nm, NumericModel):
        nm = compile_equations(eq)
    cm = constrained_model(eq, nm)
    times, p, u_of, sampling, method = run.times, run.p, run.u_of, run.sampling, run.solver.name
    x0, fixed = _consistent_guess(eq, run.x0, opts.given, model_initial)
    try:
        x0 = consistent_state(cm, x0, fixed, p)
        if fast is not None:
            return _run_compiled(fast, run, opts, x0, cm)
        # SciPy's integrators: the projected integration, or the ODE in the independent coordinates
        rtol, atol, max_step = float(opts.rtol), float(opts.atol), opts.max_step
        if opts.constraints == "eliminate":
            from ._constrained import integrate_eliminated

            ind = [nm.state_names.index(str(q)) for q in eq.model.simulation.get("independent", ())]

            def integration(x, run_times, u):
                return integrate_eliminated(cm, x, run_times, p, u, rtol, atol, max_step, method, ind)
        else:
            def integration(x, run_times, u):
                return integrate(cm, x, run_times, p, u, rtol, atol, max_step, method)
        if sampling is not None:
            X, U, Lam, stats = _integrate_sampled(integration, cm, x0, times, p, u_of, sampling)
        else:
            X, U, Lam, stats = integration(x0, times, u_of)
    except ConstraintSingular as s:
        error = _dead_point(cm, s.t, s.x, p)
        error.partial = _constrained_partial(nm, cm, method, times, getattr(s, "rows", None), u_of, p,
                                             str(error), getattr(s, "inputs", None), error.status)
        raise error from None
    except (SimulationError, SingularMassMatrixError) as exc:
        if fast is None:  # (the compiled run's errors carry their rows already)
            exc.partial = _constrained_partial(nm, cm, method, times, getattr(exc, "rows", None), u_of, p,
                                               str(exc), getattr(exc, "inputs", None), _status(exc))
        raise
    if not np.all(np.isfinite(X)):
        raise failure(nm, Status.SOLUTION_NOT_FINITE, None, None, None, p)
    return _constrained_trajectory(nm, method, times[:len(X)], X, U, Lam, stats, p)


def _integrate_sampled(run, cm, x0, times, p, u_of, sampling):
    """A SciPy integration of a constrained model (`run(x, times, u_of)`: the projected one or the
    ODE in the independent coordinates, from x at times[0]) with sampled inputs, as _solve_sampled
    runs a model without constraints: one run from one sample instant to the next, the sampled
    inputs held at their values at the instant (the others continuous); (X, U, Lambda, stats) at
    `times`. A failure carries the rows (and held inputs) reached in every run so far."""
    from ._constrained import ConstraintSingular

    m = len(cm.equations.inputs)
    hold = sampling.hold[:m].astype(bool)
    held = np.zeros(m)
    t_end = float(times[-1])
    instants = [float(s) for s in sampling.samples if s < t_end] + [t_end]
    x = np.array(x0, float)
    rows: list = [[], [], []]  # X, U, Lambda of the output rows so far
    nfev = nstep = 0
    drift = {"position": 0.0, "velocity": 0.0}

    def joined(k):
        return np.concatenate(rows[k]) if rows[k] else np.zeros((0, 2 * cm.n if k == 0 else m))

    for k in range(len(instants) - 1):
        a, b = instants[k], instants[k + 1]
        now = sampling.which[k, :m].astype(bool) & hold
        held[now] = np.asarray(u_of(a, x), dtype=float)[now]
        frozen = held.copy()

        def u_held(t, xt, frozen=frozen):
            return np.where(hold, frozen, u_of(t, xt))

        last = k == len(instants) - 2  # the last run ends at the last output time
        inside = times[(times >= a) & ((times <= b) if last else (times < b))]
        run_times = np.unique(np.concatenate(([a], inside, [b])))
        keep = np.isin(run_times, inside)
        try:
            X, U, Lam, stats = run(x, run_times, u_held)
        except (ConstraintSingular, SimulationError) as exc:
            reached = getattr(exc, "rows", None)
            reached = np.zeros((0, 2 * cm.n)) if reached is None else np.asarray(reached)
            new = reached[keep[:len(reached)]]
            exc.rows = np.concatenate([joined(0), new])
            exc.inputs = np.concatenate([joined(1), np.array([u_held(t, xt) for t, xt in zip(
                run_times[:len(reached)][keep[:len(reached)]], new)]).reshape(len(new), m)])
            raise
        for r, part in zip(rows, (X, U, Lam)):
            r.append(part[keep])
        nfev += stats["nfev"]
        nstep += stats["nstep"]
        for key, value in drift.items():
            drift[key] = max(value, stats["constraint_drift"][key])
        x = X[-1]
    X, U, Lam = joined(0), joined(1), joined(2)
    k = len(instants) - 1
    if k < len(sampling.samples) and sampling.samples[k] == t_end and hold.any():  # a sample at the end too
        now = sampling.which[k, :m].astype(bool) & hold
        held[now] = np.asarray(u_of(t_end, X[-1]), dtype=float)[now]
        U[-1] = np.where(hold, held, U[-1])
        Lam[-1] = cm.solve(t_end, X[-1], U[-1], p)[1]
    stats = {**stats, "nfev": nfev, "nstep": nstep, "constraint_drift": drift,
             "samples": int(np.searchsorted(sampling.samples, t_end, side="right"))}
    return X, U, Lam, stats


def _constrained_trajectory(nm, method, times, X, U, Lam, stats, p, failure: str | None = None,
                            status: Status | None = None) -> Trajectory:
    """The Trajectory of a constrained run on SciPy's integrators at `times` (all of them, or those
    before a failure, whose message is `failure` and whose status is `status`, where known)."""
    eq = nm.equations
    energy = None if eq.explicit_time else [nm.energy(t, x, u, p) for t, x, u in zip(times, X, U)]
    return run_trajectory(eq, times, X, U, p, energy=energy, stats={"backend": "scipy", "method": method, **stats},
                          status=Status.SUCCESS if failure is None else status, failure=failure, multipliers=Lam,
                          message="stopped" if failure is not None else "constrained integration finished")


def _constrained_partial(nm, cm, method, times, rows, u_of, p, failure: str,
                         inputs=None, status: Status | None = None) -> Trajectory | None:
    """The rows a failed constrained run reached (`rows`: its states at the first output times, as
    the integrators attach them to their error; `inputs`: the inputs there, where they were held by a
    sampled controller), as a Trajectory marked partial; None without rows."""
    from ._constrained import ConstraintSingular, multipliers_and_drift

    reached = 0 if rows is None else _finite_rows(np.asarray(rows))
    while reached:
        t, X = times[:reached], np.asarray(rows)[:reached]
        U = (np.array([u_of(ti, xi) for ti, xi in zip(t, X)]).reshape(reached, -1) if inputs is None
             else np.asarray(inputs)[:reached])
        try:
            Lam, drift = multipliers_and_drift(cm, t, X, U, p)
            break
        except ConstraintSingular:  # the last row already at the dead point: keep those before it
            reached -= 1
    else:
        return None
    stats = {"nfev": 0, "projection": "coordinate projection after every step", "constraint_drift": drift}
    return _constrained_trajectory(nm, method, t, X, U, Lam, stats, p, failure, status)


def _project_rows(cm, times, X, p, every: bool = False) -> None:
    """Project the rows of X (states at `times`) onto the constraints in place: from the last row
    back to the first that the projection no longer moves (those were projected by the kernel), or
    `every` row."""
    for j in range(len(X) - 1, -1, -1):
        x = cm.projected(float(times[j]), X[j], p)  # (a failed projection raises, as in the kernel)
        moved = np.max(np.abs(x - X[j]))
        X[j] = x
        if not every and moved <= 1e-14 * (1.0 + np.max(np.abs(x))):
            break


def _elimination_problems(eq: Equations, method: str, problems: list) -> None:
    """Why constraints='eliminate' cannot run this model, if it cannot."""
    from ..model._constraints import VELOCITY

    if not eq.is_constrained:
        problems.append(Problem("constraints='eliminate' is for models with constraints; this one has none",
                                key="constraints"))
    elif any(c.kind == VELOCITY for c in eq.model.constraints):
        problems.append(Problem("constraints='eliminate' reduces holonomic constraints to an ODE; velocity "
                                "constraints cannot be eliminated so: use constraints='project'", key="constraints"))
    elif not eq.model.simulation.get("independent"):
        problems.append(Problem("constraints='eliminate' integrates the independent coordinates: name them under "
                                f"[simulation] independent (e.g. independent = [\"{eq.coordinates[0].name}\"]), "
                                "or use constraints='project'", key="constraints"))
    elif method == "variational":
        problems.append(Problem("constraints='eliminate' runs on SciPy's integrators: use method='DOP853' or "
                                "another SciPy method", key="constraints"))
