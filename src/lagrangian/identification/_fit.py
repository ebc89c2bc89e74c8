"""fit(equations, data, params) -> FitResult: parameter identification by multiple shooting.

The method (Bock's multiple shooting with a Gauss-Newton / Levenberg-Marquardt engine):

- each experiment's time span is cut into shooting intervals; the state at the start of each
  interval (a node) is an unknown, beside the fitted parameters;
- every interval is integrated from its node by the classical Runge-Kutta method together with
  its forward sensitivities S' = A S + B (``_sensitivity``: exact derivatives generated from the
  symbolic equations in saddle-point form, compiled, all intervals advanced at once);
- the residuals are the weighted differences between the measured columns and the model's
  values at the sample times, the continuity defects between consecutive intervals (and, for a
  constrained model, the constraint residuals at the nodes), the last two weighted so heavily that
  they vanish at the solution: equality constraints that need not hold while the iteration runs,
  which is what makes multiple shooting robust to a poor first guess and to chaotic data;
- scipy.optimize.least_squares ('trf', bounds) minimises their sum of squares with the exact
  Jacobian assembled from the sensitivities.

Before the fit, the parameters the data cannot decide (structurally, from the equations, by
``identification._identifiability`` when present; numerically, by the singular values of the
sensitivity matrix at the guess) are named and held at their guesses, not fitted; afterwards the
singular values of the sensitivity matrix at the estimates confirm the rank.
"""

from __future__ import annotations

import contextlib
import math
import warnings
from collections.abc import Callable, Mapping, Sequence

import numpy as np
import sympy

from .._limits import MAX_MAGNITUDE
from .._util import did_you_mean, real_number
from ..errors import LagrangianError, ModelError, SimulationError
from ._data import Measurements, measurements, unknown_column
from ._result import FitResult
from ._sensitivity import Sensitivities, rk4_with_sensitivities

__all__ = ["fit"]

#: Weight of a continuity defect or a constraint residual, relative to its state's range: a defect of
#: 1e-8 of the range weighs as much as one standard deviation of a measurement.
DEFECT_WEIGHT = 1e8
#: The defect weights of the continuation: first the nodes follow the data and the parameters fit the
#: local motion (a weak continuity), then the weight rises to DEFECT_WEIGHT, where the defects vanish.
CONTINUATION = (1e1, 1e3, 1e5)
#: Relative singular value of the (scaled) parameter sensitivity below which a direction is not determined.
RANK_TOLERANCE = 1e-7
#: Samples per shooting interval when `intervals` is not given.
SAMPLES_PER_INTERVAL = 10
#: The most intervals per experiment chosen by default (the Jacobian is dense: its size grows with them).
AUTO_INTERVALS = 40
MAX_INTERVALS = 400
MAX_SUBSTEPS = 256
#: The most entries of the (dense) Jacobian of a fit: 2e7 doubles, 160 MB.
MAX_JACOBIAN = 20_000_000


# ---------------------------------------------------------------------------------------------- checks
def _names(params) -> list[str]:
    if isinstance(params, str):
        params = [p for p in params.split(",")]
    if not isinstance(params, Sequence):
        raise ModelError(f"params: expected a list of parameter names (or 'm,l,c'), not {type(params).__name__}")
    out = []
    for p in params:
        p = str(getattr(p, "name", p)).strip()
        if p in out:
            raise ModelError(f"params: '{p}' is given twice; name each parameter to fit once")
        out.append(p)
    if not out or not all(out):
        raise ModelError("params: no parameter to fit; name at least one, e.g. params=['m', 'c']")
    return out


def _check_params(equations, names: list[str], guess, bounds):
    all_names = [p.name for p in equations.parameters]
    values = np.array([np.nan if v is None else float(v) for v in equations.parameters.values()])
    problems = []
    for p in names:
        if p not in all_names:
            problems.append(f"params: '{p}' is not a parameter of {equations.model.name}"
                            f"{did_you_mean(p, all_names, 0.5)}; its parameters are {', '.join(all_names) or 'none'}")
    if problems:
        raise ModelError(problems[0] if len(problems) == 1 else "; ".join(problems))
    if guess is not None and not isinstance(guess, Mapping):
        raise ModelError(f"guess: expected a mapping of parameter name to value, not {type(guess).__name__}")
    for name, value in (guess or {}).items():
        name = str(getattr(name, "name", name))
        if name not in all_names:
            raise ModelError(f"guess: '{name}' is not a parameter of {equations.model.name}"
                             f"{did_you_mean(name, all_names, 0.5)}; its parameters are {', '.join(all_names)}")
        v = real_number(value)
        if v is None or abs(v) > MAX_MAGNITUDE:
            raise ModelError(f"guess: the value of '{name}' ({value!r}) is not a finite number; give a number")
        values[all_names.index(name)] = v
    missing = [p for p, v in zip(all_names, values) if not math.isfinite(v)]
    if missing:
        raise ModelError(f"parameter(s) {', '.join(missing)} have no value in the model; give them in guess= "
                         f"(e.g. guess={{'{missing[0]}': 1.0}}): a first guess for a fitted parameter, the value of "
                         "another")
    fitted = tuple(all_names.index(p) for p in names)
    lo = np.full(len(names), -np.inf)
    hi = np.full(len(names), np.inf)
    if bounds is not None and not isinstance(bounds, Mapping):
        raise ModelError(f"bounds: expected a mapping of parameter name to (low, high), not {type(bounds).__name__}")
    for name, pair in (bounds or {}).items():
        name = str(getattr(name, "name", name))
        if name not in names:
            raise ModelError(f"bounds: '{name}' is not a fitted parameter{did_you_mean(name, names, 0.5)}; the fitted "
                             f"parameters are {', '.join(names)}")
        try:
            a, b = pair
        except (TypeError, ValueError):
            raise ModelError(f"bounds: '{name}' must be a pair (low, high), e.g. (0, 10); use None or inf for no "
                             "bound on a side") from None
        a = -np.inf if a is None else a
        b = np.inf if b is None else b
        a, b = real_number(a) if not (isinstance(a, float) and math.isinf(a)) else a, \
            real_number(b) if not (isinstance(b, float) and math.isinf(b)) else b
        if a is None or b is None or not a < b:
            raise ModelError(f"bounds: '{name}' = {pair!r} must be two numbers with low < high, e.g. (0, 10)")
        i = names.index(name)
        lo[i], hi[i] = a, b
        g = values[fitted[i]]
        if not a <= g <= b:
            raise ModelError(f"bounds: the guess {g:g} of '{name}' is outside its bounds [{a:g}, {b:g}]; give a guess "
                             f"inside them (guess={{'{name}': {(a + b) / 2 if math.isfinite(a + b) else a + 1:g}}}) "
                             "or widen the bounds")
        if g == a or g == b:  # least_squares needs a strictly feasible start
            values[fitted[i]] = g + (1e-6 * (b - a) if g == a else -1e-6 * (b - a)) if math.isfinite(b - a) else \
                g + (1e-6 * max(1.0, abs(g)) if g == a else -1e-6 * max(1.0, abs(g)))
    return values, fitted, lo, hi


def _input_function(value, name: str) -> Callable:
    v = real_number(value)
    if v is not None:
        return lambda t: np.full(np.shape(t), v)
    if callable(value):
        def f(t):
            out = np.asarray(value(t), dtype=float)
            if out.shape != np.shape(t):
                out = np.array([float(value(s)) for s in np.ravel(t)]).reshape(np.shape(t))
            return out
        return f
    raise ModelError(f"inputs: '{name}' must be a number, a function of t or a lagrangian.Signal, not "
                     f"{type(value).__name__}")


#: Columns that lagrangian's own simulation CSV carries beside the measurable ones: left out unless named.
COMPUTED_COLUMNS = ("energy", "jacobi_integral")


def _select(experiments: list[Measurements], columns, inputs=(), multipliers=()) -> list[Measurements]:
    """Only the columns named in `columns` and the model's inputs (a measured input drives the model
    whether or not it is named); None: all of them but those a simulation computes (the energy or
    Jacobi integral, the multipliers lambda_*), so that simulate's own CSV fits as it is."""
    if columns is None:
        skip = set(COMPUTED_COLUMNS) | set(multipliers)
        return [ex if not skip & set(ex.columns) else
                Measurements(ex.t, {c: v for c, v in ex.columns.items() if c not in skip}, ex.source)
                for ex in experiments]
    if isinstance(columns, str):
        columns = [c.strip() for c in columns.split(",") if c.strip()]
    if not isinstance(columns, Sequence) or not columns or not all(isinstance(c, str) for c in columns):
        raise ModelError("columns: expected a list of column names of the data (e.g. ['theta', 'F'])")
    out = []
    for ex in experiments:
        for c in columns:
            if c not in ex.columns:
                raise ModelError(f"columns: {ex.source} has no column '{c}'{did_you_mean(c, ex.columns)}; its "
                                 f"columns are {', '.join(ex.columns)}")
        kept = [*columns, *(u for u in inputs if u in ex.columns and u not in columns)]
        out.append(Measurements(ex.t, {c: ex.columns[c] for c in kept}, ex.source))
    return out


class _Setup:
    """The validated problem: experiments, measured expressions, weights, the shooting layout."""

    def __init__(self, equations, data, params, guess, bounds, initial, noise, inputs, intervals, columns=None):
        from ..numeric import Signal

        self.equations = equations
        model = equations.model
        self.names = _names(params)
        self.values, self.fitted, self.lo, self.hi = _check_params(equations, self.names, guess, bounds)
        self.experiments: list[Measurements] = _select(measurements(data), columns,
                                                       [u.name for u in equations.inputs],
                                                       [lam.name for lam in equations.multipliers])
        n = equations.n
        self.n = n
        state = list(equations.state_names)
        input_names = [u.name for u in equations.inputs]
        outputs = dict(model.outputs) if model is not None else {}
        q_syms = [sympy.Symbol(s) for s in state]
        known = state + input_names + list(outputs)
        self.exprs: list = []  # measured expressions (sympy), shared by the experiments
        self.expr_names: list[str] = []
        self.columns: list[list[tuple[str, int]]] = []  # per experiment: (column, expression index)
        self.input_funcs: list[list[Callable]] = []
        if inputs is not None and not isinstance(inputs, Mapping):
            raise ModelError(f"inputs: expected a mapping of input name to a number, function of t or Signal, not "
                             f"{type(inputs).__name__}")
        given_inputs = dict(inputs or {})
        for name in given_inputs:
            if name not in input_names:
                raise ModelError(f"inputs: '{name}' is not an input of {model.name}{did_you_mean(name, input_names)}; "
                                 f"its inputs are {', '.join(input_names) or 'none'}")
        for ex in self.experiments:
            cols = []
            funcs = {}
            for col, values in ex.columns.items():
                if col in input_names:
                    funcs[col] = Signal(ex.t, values, "linear", "hold", name=f"{ex.source}:{col}")
                    continue
                if col in state:
                    expr = q_syms[state.index(col)]
                elif col in outputs:
                    expr = outputs[col]
                else:
                    expr = None
                    head, dot_, axis = col.rpartition(".")
                    if dot_ and head.isidentifier() and axis in ("x", "y", "z") and model is not None:
                        try:
                            expr = model._point_component(col, f"{ex.source}: column '{col}'")
                        except ModelError as exc:
                            raise ModelError(f"{ex.source}: column '{col}': {exc.problems[0].message}") from None
                    if expr is None:
                        raise unknown_column(col, ex.source, known)
                if col not in self.expr_names:
                    self.expr_names.append(col)
                    self.exprs.append(expr)
                cols.append((col, self.expr_names.index(col)))
            if not cols:
                raise ModelError(f"{ex.source}: no measured column to fit (only inputs {', '.join(ex.columns)}); add a "
                                 "coordinate, velocity, output or point column")
            for name in input_names:
                if name not in funcs:
                    if name not in given_inputs:
                        raise ModelError(f"{ex.source}: the input '{name}' is neither a column of the data nor given; "
                                         f"add a column '{name}' (the measured signal) or give it: inputs={{'{name}': "
                                         f"0.0}} (a number, a function of t or a lagrangian.Signal; --input {name}=0 "
                                         "on the command line)")
                    value = given_inputs[name]
                    funcs[name] = value if isinstance(value, Signal) else _input_function(value, name)
            self.columns.append(cols)
            self.input_funcs.append([funcs[name] for name in input_names])
        self.k = len(input_names)
        self._noise(noise)
        self._initial(initial, state)
        self._layout(intervals)

    def _noise(self, noise):
        self.noise_given = noise is not None
        sig = {}
        if noise is None:
            for ex, cols in zip(self.experiments, self.columns):
                for col, _ in cols:
                    spread = float(np.ptp(ex.columns[col])) or max(1.0, float(np.max(np.abs(ex.columns[col]))))
                    sig[col] = max(sig.get(col, 0.0), 1e-2 * spread)
        else:
            if isinstance(noise, Mapping):
                for col, v in noise.items():
                    if col not in self.expr_names:
                        raise ModelError(f"noise: '{col}' is not a measured column{did_you_mean(col, self.expr_names)};"
                                         f" the measured columns are {', '.join(self.expr_names)}")
                    sig[col] = v
                missing = [c for c in self.expr_names if c not in sig]
                if missing:
                    raise ModelError(f"noise: no noise level for {', '.join(missing)}; give one for every measured "
                                     "column, or one number for all (noise=0.01), or none to estimate them")
            else:
                sig = {c: noise for c in self.expr_names}
            for col, v in sig.items():
                x = real_number(v)
                if x is None or not 0 < x < MAX_MAGNITUDE:
                    raise ModelError(f"noise: the level of '{col}' ({v!r}) must be a positive number (the standard "
                                     "deviation of the measurement, in its units)")
                sig[col] = x
        self.sigma = {c: float(sig[c]) for c in self.expr_names}

    def _initial(self, initial, state):
        E = len(self.experiments)
        if initial is None:
            per = [{} for _ in range(E)]
        elif isinstance(initial, Mapping):
            per = [dict(initial) for _ in range(E)]
        elif isinstance(initial, Sequence) and len(initial) == E and all(isinstance(d, Mapping) for d in initial):
            per = [dict(d) for d in initial]
        else:
            raise ModelError(f"initial: expected a mapping of state name to value (for every experiment) or a list of "
                             f"{E} mappings (one per experiment)")
        self.initial = []
        for e, d in enumerate(per):
            fixed = {}
            for name, value in d.items():
                name = str(getattr(name, "name", name))
                if name not in state:
                    raise ModelError(f"initial: '{name}' is not a coordinate or velocity"
                                     f"{did_you_mean(name, state)}; the state is {', '.join(state)}")
                v = real_number(value)
                if v is None or abs(v) > MAX_MAGNITUDE:
                    raise ModelError(f"initial: the value of '{name}' ({value!r}) is not a finite number")
                fixed[state.index(name)] = v
            self.initial.append(fixed)

    def _layout(self, intervals):
        if intervals is not None:
            if isinstance(intervals, bool) or not isinstance(intervals, (int, np.integer)) or not \
                    1 <= intervals <= MAX_INTERVALS:
                raise ModelError(f"intervals: expected a whole number of shooting intervals per experiment from 1 "
                                 f"(single shooting) to {MAX_INTERVALS}, not {intervals!r}")
        rows = []  # (experiment, first sample, last sample)
        for e, ex in enumerate(self.experiments):
            N = len(ex.t)
            count = intervals if intervals is not None else min(round((N - 1) / SAMPLES_PER_INTERVAL), AUTO_INTERVALS)
            count = int(min(max(count, 1), N - 1, MAX_INTERVALS))
            cuts = np.unique(np.round(np.linspace(0, N - 1, count + 1)).astype(int))
            rows += [(e, int(a), int(b)) for a, b in zip(cuts[:-1], cuts[1:])]
        self.rows = rows
        R = len(rows)
        L = max(b - a for _, a, b in rows)
        self.times = np.empty((R, L + 1))
        self.row_exp = np.array([e for e, _, _ in rows])
        for r, (e, a, b) in enumerate(rows):
            t = self.experiments[e].t
            self.times[r, :b - a + 1] = t[a:b + 1]
            self.times[r, b - a + 1:] = t[b]
        # observations: (row, sample in row, expression, measured value, experiment, sample in experiment)
        obs = []
        for r, (e, a, b) in enumerate(rows):
            last = r + 1 == R or rows[r + 1][0] != e
            for j in range(0, b - a + (1 if last else 0)):
                for col, ei in self.columns[e]:
                    obs.append((r, j, ei, self.experiments[e].columns[col][a + j], e, a + j))
        o = np.array(obs, dtype=float)
        self.obs_row, self.obs_j, self.obs_expr = o[:, 0].astype(int), o[:, 1].astype(int), o[:, 2].astype(int)
        self.obs_y, self.obs_exp, self.obs_k = o[:, 3], o[:, 4].astype(int), o[:, 5].astype(int)
        self.next_row = np.array([r + 1 if r + 1 < R and rows[r + 1][0] == e else -1
                                  for r, (e, _, _) in enumerate(rows)])
        self.first_row = {e: next(r for r, row in enumerate(rows) if row[0] == e) for e in range(len(self.experiments))}

    def inputs_at(self, exp: np.ndarray, t: np.ndarray) -> np.ndarray:
        U = np.zeros((len(t), self.k))
        if not self.k:
            return U
        for e in np.unique(exp):
            sel = exp == e
            for j, f in enumerate(self.input_funcs[e]):
                U[sel, j] = f(t[sel])
        return U


# ---------------------------------------------------------------------------------------------- the problem
class _Problem:
    """The multiple-shooting least-squares problem of a setup: residuals and their exact Jacobian."""

    def __init__(self, setup: _Setup, sens: Sensitivities, free_params: np.ndarray, substeps: int = 1):
        self.s = setup
        self.sens = sens
        n2 = 2 * setup.n
        R = len(setup.rows)
        self.R, self.n2 = R, n2
        self.free_params = free_params  # boolean over the fitted parameters: fitted now (not held)
        mask = np.ones((R, n2), bool)
        for e, fixed in enumerate(setup.initial):
            for i in fixed:
                mask[setup.first_row[e], i] = False
        self.state_mask = mask
        self.substeps = substeps
        self.weights = np.array([1.0 / setup.sigma[setup.expr_names[i]] for i in setup.obs_expr])
        self.scale = np.ones(n2)
        self.defect_weight = DEFECT_WEIGHT
        self._cache = (None, None)

    # z = [free node states, free parameters]
    def split(self, z):
        s = self.s
        nodes = np.zeros((self.R, self.n2))
        fixed_vals = self.fixed_nodes
        nodes[:] = fixed_vals
        k = int(self.state_mask.sum())
        nodes[self.state_mask] = z[:k]
        theta = s.values[list(s.fitted)].copy()
        theta[self.free_params] = z[k:]
        P = s.values.copy()
        P[list(s.fitted)] = theta
        return nodes, P

    def pack(self, nodes, P):
        s = self.s
        theta = P[list(s.fitted)]
        return np.concatenate((nodes[self.state_mask], theta[self.free_params]))

    def set_nodes(self, nodes):
        self.fixed_nodes = nodes.copy()

    def inputs(self, t):
        return self.s.inputs_at(self.s.row_exp, t)

    def integrate(self, nodes, P, with_sensitivities=True, substeps=None):
        return rk4_with_sensitivities(self.sens, self.s.times, nodes, self.inputs, P, substeps or self.substeps,
                                      with_sensitivities)

    def evaluate(self, z, jacobian=True):
        key = z.tobytes()
        if self._cache[0] == key and (self._cache[1][1] is not None or not jacobian):
            return self._cache[1]
        try:
            with np.errstate(all="ignore"):
                out = self._evaluate(z, jacobian)
        except np.linalg.LinAlgError:
            nres = len(self.s.obs_y) + self.n_equalities
            out = (np.full(nres, np.nan), None if not jacobian else np.full((nres, len(z)), np.nan), None)
        self._cache = (key, out)
        return out

    @property
    def n_equalities(self) -> int:
        return int((self.s.next_row >= 0).sum()) * self.n2 + self.R * 2 * self.sens.m

    def _evaluate(self, z, jacobian):
        s, sens, n2, R = self.s, self.sens, self.n2, self.R
        nodes, P = self.split(z)
        X, S = self.integrate(nodes, P, jacobian)
        # data
        rows, js = s.obs_row, s.obs_j
        t_obs = s.times[rows, js]
        X_obs = X[rows, js]
        U_obs = s.inputs_at(s.obs_exp, t_obs)
        h, dhx, dhp = sens.outputs(t_obs, X_obs, U_obs, P)
        idx = np.arange(len(rows))
        pred = h[idx, s.obs_expr]
        res_data = (pred - s.obs_y) * self.weights
        # continuity defects
        has = np.flatnonzero(s.next_row >= 0)
        L_end = np.array([b - a for _, a, b in s.rows])
        X_end = X[np.arange(R), L_end]
        wd = self.defect_weight / self.scale
        defects = ((X_end[has] - nodes[s.next_row[has]]) * wd).ravel()
        # constraints at the nodes
        t0 = s.times[:, 0]
        U0 = self.inputs(t0)
        c, dcx, dcp = sens.constraints(t0, nodes, U0, P)
        wc = self.defect_weight / max(float(np.max(self.scale)), 1e-300)
        res = np.concatenate((res_data, defects, (c * wc).ravel()))
        self.last = (X, pred)
        if not jacobian:
            return res, None, pred
        nth = sens.nth
        nfull = R * n2 + nth
        J = np.zeros((len(res), nfull))
        S_obs = S[rows, js]  # (N, n2, n2 + nth)
        g = dhx[idx, s.obs_expr]  # (N, n2)
        Jx = np.einsum("ni,nij->nj", g, S_obs) * self.weights[:, None]
        cols = rows[:, None] * n2 + np.arange(n2)[None, :]
        J[idx[:, None], cols] = Jx[:, :n2]
        J[:len(rows), R * n2:] = Jx[:, n2:] + dhp[idx, s.obs_expr] * self.weights[:, None]
        # defects
        base = len(rows)
        S_end = S[np.arange(R), L_end]
        for q, r in enumerate(has):
            r0 = base + q * n2
            J[r0:r0 + n2, r * n2:(r + 1) * n2] = S_end[r, :, :n2] * wd[:, None]
            nr = s.next_row[r]
            J[r0:r0 + n2, nr * n2:(nr + 1) * n2] = -np.diag(wd)
            J[r0:r0 + n2, R * n2:] = S_end[r, :, n2:] * wd[:, None]
        base += len(has) * n2
        mc = c.shape[1]
        for r in range(R if mc else 0):
            r0 = base + r * mc
            J[r0:r0 + mc, r * n2:(r + 1) * n2] = dcx[r] * wc
            J[r0:r0 + mc, R * n2:] = dcp[r] * wc
        keep = np.concatenate((self.state_mask.ravel(), self.free_params))
        return res, J[:, keep], pred


# ---------------------------------------------------------------------------------------------- first guess
def _guess_states(setup: _Setup, sens: Sensitivities) -> list[np.ndarray]:
    """The state at every sample of every experiment: measured coordinates and velocities as they
    are, the other coordinates by Gauss-Newton on the measured expressions (and the constraints),
    each sample from the previous one's answer; unmeasured velocities by differences of the
    coordinates."""
    n = setup.n
    P = setup.values
    out = []
    model_initial = {}
    sim = getattr(setup.equations.model, "simulation", {}) or {}
    for name, v in dict(sim.get("initial", {}) or {}).items():
        if name in setup.equations.state_names and real_number(v) is not None:
            model_initial[setup.equations.state_names.index(name)] = real_number(v)
    for e, ex in enumerate(setup.experiments):
        N = len(ex.t)
        X = np.zeros((N, 2 * n))
        for i, v in model_initial.items():
            X[:, i] = v
        measured_states = set()
        for col, ei in setup.columns[e]:
            if col in setup.equations.state_names:
                i = setup.equations.state_names.index(col)
                X[:, i] = ex.columns[col]
                measured_states.add(i)
        for i, v in setup.initial[e].items():
            if i not in measured_states:
                X[:, i] = v
        unknown_q = [i for i in range(n) if i not in measured_states]
        cols = setup.columns[e]
        if unknown_q:
            Y = np.array([ex.columns[c] for c, _ in cols]).T  # (N, r_e)
            ei = np.array([j for _, j in cols])
            U = setup.inputs_at(np.full(N, e), ex.t)
            x = X[0].copy()
            for k in range(N):
                x[unknown_q] = x[unknown_q] if k else X[0, unknown_q]
                x[[i for i in range(n) if i in measured_states]] = X[k, [i for i in range(n) if i in measured_states]]
                for _ in range(12):
                    h, dhx, _ = sens.outputs(ex.t[k:k + 1], x[None], U[k:k + 1], P)
                    r = h[0, ei] - Y[k]
                    Jq = dhx[0][ei][:, unknown_q]
                    w = np.array([1.0 / setup.sigma[c] for c, _ in cols])
                    r, Jq = r * w, Jq * w[:, None]
                    if sens.m:
                        c, dcx, _ = sens.constraints(ex.t[k:k + 1], x[None], U[k:k + 1], P)
                        mm = sens.m
                        big = 1e3 * max(float(np.max(w)), 1.0)
                        r = np.concatenate((r, c[0, :mm] * big))
                        Jq = np.vstack((Jq, dcx[0, :mm][:, unknown_q] * big))
                    lam = 1e-6 * (np.trace(Jq.T @ Jq) + 1e-12)
                    step = np.linalg.solve(Jq.T @ Jq + lam * np.eye(len(unknown_q)), -Jq.T @ r)
                    x[unknown_q] += step
                    if np.max(np.abs(step)) < 1e-10:
                        break
                X[k, unknown_q] = x[unknown_q]
        for i in range(n):
            if n + i not in measured_states:
                X[:, n + i] = np.gradient(X[:, i], ex.t)
        for i, v in setup.initial[e].items():
            X[0, i] = v
        out.append(X)
    return out


# ---------------------------------------------------------------------------------------------- rank
def _parameter_sensitivity(problem: _Problem, J: np.ndarray) -> np.ndarray:
    """The data rows of the sensitivity in the free parameters with the node states eliminated
    (their span projected out), columns scaled by the parameters' magnitudes: what the data can
    tell of the parameters beyond what the initial states explain."""
    k = int(problem.state_mask.sum())
    Js, Jp = J[:, :k], J[:, k:]
    if k:
        Q, _ = np.linalg.qr(Js)
        Jp = Jp - Q @ (Q.T @ Jp)
    nd = len(problem.s.obs_y)
    return Jp[:nd]


def _null_directions(Sp: np.ndarray, theta: np.ndarray):
    scale = np.where(np.abs(theta) > 0, np.abs(theta), 1.0)
    A = Sp * scale[None, :]
    if A.shape[1] == 0:
        return np.zeros(0), np.zeros((0, 0))
    _, sv, Vt = np.linalg.svd(A, full_matrices=False)
    rel = sv / sv[0] if sv[0] > 0 else np.zeros_like(sv)
    return rel, Vt


# ---------------------------------------------------------------------------------------------- BLAS threads
@contextlib.contextmanager
def _one_blas_thread():
    """OpenBLAS on one thread while a fit runs. Its matrices are small and many (an SVD of a few
    hundred rows per iteration); on a machine whose cores are busy, OpenBLAS's threads wait for each
    other: measured here (2 cores, load 8), one SVD of a 358 x 63 Jacobian took 2.2 s on the default
    threads and 1.7 ms on one. Linux only (the loaded libraries are read from /proc/self/maps); a no-op
    elsewhere."""
    import ctypes

    restore = []
    try:
        with open("/proc/self/maps") as fh:
            paths = {line.split()[-1] for line in fh if "openblas" in line.lower() and "/" in line}
    except OSError:
        paths = set()
    for path in sorted(paths):
        try:
            lib = ctypes.CDLL(path)
        except OSError:
            continue
        for stem in ("scipy_openblas", "openblas"):
            for tail in ("64_", ""):
                setter = getattr(lib, f"{stem}_set_num_threads{tail}", None)
                getter = getattr(lib, f"{stem}_get_num_threads{tail}", None)
                if setter is not None and getter is not None:
                    getter.restype = ctypes.c_int
                    before = getter()
                    setter(ctypes.c_int(1))
                    restore.append((setter, before))
                    break
            else:
                continue
            break
    try:
        yield
    finally:
        for setter, before in restore:
            setter(ctypes.c_int(before))


# ---------------------------------------------------------------------------------------------- front door
def fit(equations, data, params, *, guess: Mapping | None = None, bounds: Mapping | None = None,
        initial=None, noise=None, inputs: Mapping | None = None, intervals: int | None = None,
        columns: Sequence[str] | None = None, confidence: float = 0.95, max_iterations: int = 200) -> FitResult:
    """Fit parameters of `equations` to measurements: multiple shooting, exact sensitivities,
    Gauss-Newton / Levenberg-Marquardt.

    Parameters
    ----------
    equations : Equations or Model
        The model's equations (``lagrangian.derive``; a Model is derived first); constrained models too.
    data : str, path, mapping, Measurements, or a list of those
        One experiment per item: a CSV file (a header row, a time column ``t``), or a mapping of
        column name to array with the sample times under ``"t"``. Columns are named as coordinates
        (``theta``), velocities (``theta_dot``), inputs (``F``: the measured signal, interpolated
        linearly and used as the input; not fitted), the model's named outputs, or a point's
        position component (``bob.x``, ``bob.y``).
    params : sequence of str, or "m,l,c"
        The parameters to fit.
    guess : mapping of str to float, optional
        The first guess of fitted parameters (default: the model's values) and the value of the
        others where the model gives none.
    bounds : mapping of str to (low, high), optional
        Bounds of fitted parameters (None or inf for an open side).
    initial : mapping of str to float, or a list of them (one per experiment), optional
        Initial states that are known: held, not estimated. The others are estimated.
    noise : float or mapping of str to float, optional
        The standard deviation of each measured column (its weight is 1 / noise); default:
        estimated from the residuals (per column), and the intervals use Student's t.
    inputs : mapping of str to number, function of t or Signal, optional
        Inputs that are not measured columns.
    intervals : int, optional
        Shooting intervals per experiment (1: single shooting); default one per 10 samples, at most 40.
    columns : sequence of str, optional
        The columns of the data to use (default: all but those a simulation computes: the energy or
        Jacobi integral and the multipliers); an input's column drives the model whether named or not.
    confidence : float
        The level of the confidence intervals (default 0.95).
    max_iterations : int
        The most Gauss-Newton iterations (evaluations of the residuals and their Jacobian).

    Returns
    -------
    FitResult
        Estimates, standard errors, confidence intervals, correlation, residuals, the fitted
        columns against the data, and which parameters the data cannot determine.
    """
    with _one_blas_thread():
        return _fit(equations, data, params, guess, bounds, initial, noise, inputs, intervals, columns, confidence,
                    max_iterations)


def _fit(equations, data, params, guess, bounds, initial, noise, inputs, intervals, columns, confidence,
         max_iterations):
    from scipy.optimize import least_squares
    from scipy.stats import norm, t as student

    from ..equations import Equations, derive
    from ..model import Model

    if isinstance(equations, Model):
        equations = derive(equations)
    if not isinstance(equations, Equations):
        raise ModelError(f"fit: equations must be the Equations of a model (lagrangian.derive(model)) or a Model, "
                         f"not {type(equations).__name__}")
    c = real_number(confidence)
    if c is None or not 0 < c < 1:
        raise ModelError(f"confidence: {confidence!r} must be a level between 0 and 1, e.g. 0.95")
    if isinstance(max_iterations, bool) or not isinstance(max_iterations, (int, np.integer)) or max_iterations < 1:
        raise ModelError(f"max_iterations: {max_iterations!r} must be a whole number >= 1")
    setup = _Setup(equations, data, params, guess, bounds, initial, noise, inputs, intervals, columns)
    nth = len(setup.names)
    rows = len(setup.obs_y) + sum(1 for r in setup.next_row if r >= 0) * 2 * setup.n
    cols = len(setup.rows) * 2 * setup.n + nth
    if rows * cols > MAX_JACOBIAN:
        raise ModelError(f"the fit's Jacobian would have {rows:,} x {cols:,} entries "
                         f"({rows * cols * 8 / 1e6:,.0f} MB), more than {MAX_JACOBIAN:,}; use fewer samples (every "
                         "k-th row of the data), fewer columns (columns=) or fewer shooting intervals (intervals=)")
    sens = Sensitivities.build(equations, setup.fitted, setup.exprs)

    # first guess of the node states
    Xg = _guess_states(setup, sens)
    nodes = np.array([Xg[e][a] for e, a, _ in setup.rows])
    allX = np.vstack(Xg)
    scale = np.maximum(np.ptp(allX, axis=0), 1e-3 * np.maximum(np.max(np.abs(allX), axis=0), 1.0))

    problem = _Problem(setup, sens, np.ones(nth, bool))
    problem.scale = scale
    problem.set_nodes(nodes)
    P0 = setup.values.copy()
    problem.substeps = _substeps(problem, nodes, P0, scale)

    # identifiability: structural (the equations), then numeric at the guess
    structural, ident_note = _structural(equations, setup)
    held: dict[str, str] = {}
    candidates = [p for p in setup.names if structural is not None and p in structural.not_identifiable]
    z0 = problem.pack(nodes, P0)
    res0, J0, _ = problem.evaluate(z0)
    if not np.all(np.isfinite(res0)) or not np.all(np.isfinite(J0)):
        raise SimulationError(f"the model cannot be integrated from the first guess (parameters "
                              f"{_fmt(dict(zip(setup.names, P0[list(setup.fitted)])))}): the state or its "
                              "sensitivities are not finite; give a better guess= or bounds=")
    free = np.ones(nth, bool)
    # as many held as the structural rank leaves undetermined, then any direction the data leave open
    need = len(setup.names) - int(structural.rank) if structural is not None and candidates else 0
    while True:
        Sp = _parameter_sensitivity(problem, J0)
        rel, Vt = _null_directions(Sp, P0[list(setup.fitted)][free])
        deficient = rel.size > 0 and rel[-1] <= RANK_TOLERANCE
        structural_left = sum(p in candidates for p in held) < need
        if not deficient and not structural_left:
            break
        names_free = [p for p, f in zip(setup.names, free) if f]
        if deficient:
            v = np.abs(Vt[-1])
            involved = [p for p, vi in zip(names_free, v) if vi > 0.1]
            pick = next((p for p in candidates if p in involved and structural_left), None) or \
                names_free[int(np.argmax(v))]
        else:  # the structural analysis holds more than the rank at the guess shows
            pick = next((p for p in candidates if p in names_free), None)
            if pick is None:
                break
        why = ("structurally" if pick in candidates else "numerically (by the data)")
        held[pick] = why
        free[setup.names.index(pick)] = False
        problem.free_params = free.copy()
        z0 = problem.pack(nodes, P0)
        res0, J0, _ = problem.evaluate(z0)
    if not free.any():
        raise ModelError(f"none of {', '.join(setup.names)} can be determined by these data "
                         f"({_held_text(held, structural)}); fit other parameters or measure more")

    # the fit
    k_states = int(problem.state_mask.sum())
    lo = np.concatenate((np.full(k_states, -np.inf), setup.lo[free]))
    hi = np.concatenate((np.full(k_states, np.inf), setup.hi[free]))
    total_iterations = 0

    def solve(z0, budget, tol):
        nonlocal total_iterations
        problem._cache = (None, None)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            # without bounds, MINPACK's Levenberg-Marquardt (a QR of J per step, several times cheaper
            # than the SVD of 'trf' on these tall Jacobians); with bounds, the trust-region reflective
            bounded = bool(np.isfinite(lo).any() or np.isfinite(hi).any())
            sol = least_squares(lambda z: problem.evaluate(z)[0], z0, jac=lambda z: problem.evaluate(z)[1],
                                bounds=(lo, hi) if bounded else (-np.inf, np.inf), method="trf" if bounded else "lm",
                                x_scale="jac", max_nfev=budget, xtol=tol, ftol=tol, gtol=tol)
        total_iterations += int(sol.nfev)
        return sol

    if len(setup.rows) > len(setup.experiments):  # multiple shooting: continuation in the defect weight
        for w in CONTINUATION:
            problem.defect_weight = w
            z0 = solve(z0, max(max_iterations // 8, 5), 1e-6).x
        problem.defect_weight = DEFECT_WEIGHT
    sol = solve(z0, max_iterations, 1e-12)
    if not setup.noise_given:
        # reweight: each column's noise level from its residuals, then fit again
        res, _, pred = problem.evaluate(sol.x, jacobian=False)
        resid = pred - setup.obs_y
        for ei, name in enumerate(setup.expr_names):
            sel = setup.obs_expr == ei
            setup.sigma[name] = max(float(np.sqrt(np.mean(resid[sel] ** 2))), 1e-300)
        problem.weights = np.array([1.0 / setup.sigma[setup.expr_names[i]] for i in setup.obs_expr])
        sol = solve(sol.x, max_iterations, 1e-12)
    z = sol.x
    res, J, pred = problem.evaluate(z)
    nodes_f, P = problem.split(z)

    # statistics
    nd = len(setup.obs_y)
    n_free = J.shape[1]
    dof = max(nd - (n_free - problem.n_equalities), 1)
    data_cost = float(np.sum(res[:nd] ** 2))
    s2 = 1.0 if setup.noise_given else data_cost / dof
    _, sv, Vt = np.linalg.svd(J, full_matrices=False)
    tol = sv[0] * max(J.shape) * np.finfo(float).eps
    inv = np.where(sv > tol, 1.0 / np.where(sv > tol, sv, 1.0) ** 2, 0.0)
    cov_full = (Vt.T * inv) @ Vt * s2
    cov = cov_full[k_states:, k_states:]
    se_ = np.sqrt(np.maximum(np.diag(cov), 0.0))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(se_, se_)
    q = float(norm.ppf((1 + c) / 2)) if setup.noise_given else float(student.ppf((1 + c) / 2, dof))
    Sp = _parameter_sensitivity(problem, J)
    rel, _ = _null_directions(Sp, P[list(setup.fitted)][free])
    rank = int(np.sum(rel > RANK_TOLERANCE))
    fitted_names = tuple(p for p, f in zip(setup.names, free) if f)
    est = {p: float(P[setup.fitted[setup.names.index(p)]]) for p in fitted_names}
    X, _ = problem.last
    # the fitted columns and residuals per experiment
    fitted_cols, residuals = [], []
    for e, ex in enumerate(setup.experiments):
        fc, rc = {}, {}
        for col, ei in setup.columns[e]:
            sel = (setup.obs_exp == e) & (setup.obs_expr == ei)
            order = np.argsort(setup.obs_k[sel])
            fc[col] = pred[sel][order]
            rc[col] = ex.columns[col] - fc[col]
        fitted_cols.append(fc)
        residuals.append(rc)
    initial_states = [dict(zip(equations.state_names, nodes_f[setup.first_row[e]].tolist()))
                      for e in range(len(setup.experiments))]
    nh = len(setup.obs_y)
    defect = float(np.max(np.abs(res[nh:]) / problem.defect_weight)) if len(res) > nh else 0.0
    combos = _combinations(structural, setup, P, fitted_names, cov)
    return FitResult(
        parameters=fitted_names, estimates=est, standard_errors=dict(zip(fitted_names, se_.tolist())),
        intervals={p: (est[p] - q * s, est[p] + q * s) for p, s in zip(fitted_names, se_.tolist())},
        confidence=c, covariance=cov, correlation=corr,
        held={p: float(P[setup.fitted[setup.names.index(p)]]) for p in held}, held_reasons=held,
        combinations=combos, identifiability=structural, identifiability_note=ident_note,
        singular_values=rel, rank=rank, data=tuple(setup.experiments), fitted=tuple(fitted_cols),
        residuals=tuple(residuals), noise=dict(setup.sigma), noise_estimated=not setup.noise_given,
        initial_states=tuple(initial_states), cost=0.5 * data_cost, degrees_of_freedom=dof,
        iterations=total_iterations, success=bool(sol.success), message=str(sol.message),
        intervals_per_experiment=tuple(sum(1 for row in setup.rows if row[0] == e)
                                       for e in range(len(setup.experiments))),
        substeps=problem.substeps, max_defect=defect, model_name=equations.model.name if equations.model else "",
    )


def _fmt(d: Mapping) -> str:
    return ", ".join(f"{k} = {v:.6g}" for k, v in d.items())


def _held_text(held, structural) -> str:
    return "; ".join(f"{p} is not identifiable {why}" for p, why in held.items())


def _substeps(problem: _Problem, nodes, P, scale) -> int:
    """Runge-Kutta steps between two samples: doubled until halving the step changes the states at
    the samples by less than 1e-6 of their ranges (at the first guess)."""
    sub = 1
    try:
        with np.errstate(all="ignore"):
            X1, _ = problem.integrate(nodes, P, False, sub)
            while sub < MAX_SUBSTEPS:
                X2, _ = problem.integrate(nodes, P, False, 2 * sub)
                err = np.nanmax(np.abs(X2 - X1) / scale) if np.all(np.isfinite(X2)) else np.inf
                if err < 1e-6:
                    break
                sub, X1 = 2 * sub, X2
    except np.linalg.LinAlgError:
        return 4
    return sub


def _structural(equations, setup: _Setup):
    """The structural identifiability analysis of identification._identifiability (when present)."""
    try:
        from ._identifiability import identifiability
    except ImportError:
        return None, "the structural analysis is not available in this version; the numeric rank is used alone"
    try:
        return identifiability(equations, setup.names, measured=list(setup.expr_names)), ""
    except (LagrangianError, NotImplementedError, TypeError, ValueError) as exc:
        return None, f"the structural analysis failed ({exc}); the numeric rank is used alone"


def _combinations(structural, setup: _Setup, P, fitted_names, cov) -> dict:
    """{text: (value, standard error)} of each determined combination, at the estimates (delta method)."""
    out = {}
    combos = getattr(structural, "combinations", None) or ()
    if not combos:
        return out
    all_names = [p.name for p in setup.equations.parameters]
    subs = {sympy.Symbol(nm): float(v) for nm, v in zip(all_names, P)}
    for expr in combos:
        expr = sympy.sympify(expr)
        try:
            value = float(expr.subs(subs))
            grad = np.array([float(expr.diff(sympy.Symbol(p)).subs(subs)) for p in fitted_names])
        except (TypeError, ValueError):
            continue
        se_ = float(np.sqrt(max(grad @ cov @ grad, 0.0))) if cov.size else 0.0
        out[str(expr)] = (value, se_)
    return out
