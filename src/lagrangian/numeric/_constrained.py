"""Constrained systems in numbers: M q_ddot = f + G^T lambda with G q_ddot = c.

The accelerations and multipliers solve the saddle-point system

    [ M   G^T ] [ q_ddot  ]   [ f ]
    [ G    0  ] [ -lambda ] = [ c ]

(the constraints differentiated twice: index reduction). Integrating it alone lets g and
w = G q_dot + b drift with the integration error; after every accepted step the state is
projected back (coordinate projection): the coordinates onto g(q, t) = 0 by Gauss-Newton steps
with the smallest change (q <- q - G^T (G G^T)^-1 g), the velocities onto G q_dot + b = 0 with the
smallest change of kinetic energy (q_dot <- q_dot - M^-1 G^T (G M^-1 G^T)^-1 w, what an impulse of
the constraints would do). The drift then stays at the size of one step's error, however long the
run (the trajectory's ``constraint_drift`` reports it).

The solve, the projection and their "singular" decision are one algorithm with one set of
thresholds, written once in numeric._codegen_constrained (its module docstring) and emitted for
numba and C; ConstrainedModel.solve and .project below are its NumPy transcription (LAPACK's
Cholesky and QR for the loops: the same factors, the same measures).
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
import symengine as se

from ..equations import Equations
from ..equations._lambdify import lambdify
from ..equations._search import NUDGE, STEP_ROUND_OFF, gauss_newton
from ..errors import ModelError, Problem, SimulationError
from ..model._constraints import HOLONOMIC
from ._codegen_constrained import (
    EVENT_RATIO,
    MET,
    NEWTON_EXIT,
    NOT_FINITE,
    PROJECTION_STEPS,
    PROJECTION_TOL,
    SINGULAR,
    SINGULAR_RATIO,
)

__all__ = ["ConstrainedModel", "constrained_model", "ConstraintSingular", "projection_failure"]

class ConstraintSingular(Exception):
    """The saddle-point system is singular at (t, x): its measure `ratio` is at most
    SINGULAR_RATIO (see numeric._codegen_constrained); `mass`: through M (the inertia measure of M
    is the smaller), not through the constraints' Jacobian G losing rank."""

    def __init__(self, t, x, ratio, mass: bool = False):
        super().__init__(t, x, ratio)
        self.t, self.x, self.ratio, self.mass = t, np.array(x), ratio, mass


def _triangular(R, b, transpose: bool = False, lower: bool = False):
    """R^-1 b (R^-T b: `transpose`) of a triangular R. (numpy.linalg.solve: SciPy's
    solve_triangular measured 2 ms a call for n = 3 on a loaded machine, LAPACK's gesv 10 us.)"""
    return np.linalg.solve(R.T if transpose else R, b)


def _qr(B) -> tuple[np.ndarray, np.ndarray, float]:
    """(Q, R, rank measure min_k |R_kk| / max_k |b_k|) of B = Q R (n x m, m <= n): step 2 of the
    algorithm, B = D^-1/2 Z. The measure is 0 where a column is 0 or B not finite."""
    if B.shape[1] == 0:
        return B, np.zeros((0, 0)), 1.0
    big = float(np.max(np.sum(B * B, axis=0)))
    if not (0.0 < big < np.inf) or not np.all(np.isfinite(B)):
        return B, np.eye(B.shape[1]), 0.0
    Q, R = np.linalg.qr(B)
    return Q, R, float(np.min(np.abs(np.diag(R)))) / np.sqrt(big)


def _factor(M, G):
    """Steps 1 and 2 of the algorithm: (r_M, rho_G, Lc, Q, R) with Lc = L D^1/2 (Cholesky: M =
    Lc Lc^T) and Lc^-1 G^T = Q R; r_M = min_j D_j / M_jj (0.0 where M is not positive definite,
    and then rho_G = 1.0: not computed)."""
    d = np.diag(M)
    if not (np.all(np.isfinite(M)) and np.all(d > 0)):
        return 0.0, 1.0, None, None, None
    try:
        Lc = np.linalg.cholesky(M)
    except np.linalg.LinAlgError:
        return 0.0, 1.0, None, None, None
    r = float(np.min(np.diag(Lc) ** 2 / d))
    Q, R, rho = _qr(_triangular(Lc, G.T, lower=True))
    return r, rho, Lc, Q, R


@dataclass(frozen=True, eq=False)
class ConstrainedModel:
    """The numbers of a constrained model: M, f, G, c (one call), and g, w, G for projections."""

    equations: Equations = field(repr=False)
    nm: object = field(repr=False)          # the NumericModel of M and f
    _parts: object = field(repr=False)      # (t, x, u, p) -> M, f, G, c
    _position: object = field(repr=False)   # (t, x, p) -> g (holonomic rows), their G rows
    _velocity: object = field(repr=False)   # (t, x, p) -> w, G, M
    holonomic: np.ndarray = field(repr=False)  # indices of the holonomic constraints

    @property
    def n(self) -> int:
        return self.nm.n

    @cached_property
    def m(self) -> int:
        return len(self.equations.model.constraints)

    def parts(self, t, x, u, p) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(M, f, G, c) at the state."""
        n, m = self.n, self.m
        out = np.asarray(self._parts(np.concatenate(([t], x, u, p))), float).ravel()
        return (out[:n * n].reshape(n, n), out[n * n:n * n + n], out[n * n + n:n * n + n + m * n].reshape(m, n),
                out[n * n + n + m * n:])

    def solve(self, t, x, u, p) -> tuple[np.ndarray, np.ndarray]:
        """(q_ddot, lambda) at the state; ConstraintSingular where the measure is at most
        SINGULAR_RATIO (or f, G or c is not finite: ratio -1.0)."""
        M, f, G, c = self.parts(t, x, u, p)
        r, rho, Lc, Q, R = _factor(M, G)
        if r <= SINGULAR_RATIO:
            raise ConstraintSingular(t, x, r, mass=True)
        if not (np.all(np.isfinite(f)) and np.all(np.isfinite(G)) and np.all(np.isfinite(c))):
            raise ConstraintSingular(t, x, -1.0)
        if rho <= SINGULAR_RATIO:
            raise ConstraintSingular(t, x, rho)
        a = _triangular(Lc, _triangular(Lc, f, lower=True), transpose=True, lower=True)
        w = _triangular(R, c - G @ a, transpose=True)
        qdd = a + _triangular(Lc, Q @ w, transpose=True, lower=True)
        return qdd, _triangular(R, w)

    def measures(self, t, x, u, p) -> tuple[float, float]:
        """(r_M, rho_G): the inertia measure of M and the rank measure of G in the kinetic-energy
        metric (see numeric._codegen_constrained); the saddle-point measure is their minimum."""
        M, _, G, _ = self.parts(t, x, u, p)
        with np.errstate(all="ignore"):
            r, rho, *_ = _factor(M, G)
        return r, rho

    def residuals(self, t, x, p) -> tuple[np.ndarray, np.ndarray]:
        """(g of the holonomic constraints, w = G q_dot + b of all) at the state."""
        g = self._holonomic(t, x, p)[0]
        w = self._velocity_parts(t, x, p)[0]
        return g, w

    def _holonomic(self, t, x, p):
        k = len(self.holonomic)
        out = np.asarray(self._position(np.concatenate(([t], x, p))), float).ravel()
        return out[:k], out[k:k + k * self.n].reshape(k, self.n)

    def _velocity_parts(self, t, x, p):
        n, m = self.n, self.m
        out = np.asarray(self._velocity(np.concatenate(([t], x, p))), float).ravel()
        return out[:m], out[m:m + m * n].reshape(m, n), out[m + m * n:].reshape(n, n)

    def project(self, t, x, p) -> np.ndarray:
        """The state moved onto the constraints: coordinates onto g = 0 (Gauss-Newton, the smallest
        change), then velocities onto G q_dot + b = 0 (the smallest change of kinetic energy); the
        steps, tolerances and singular decision of numeric._codegen_constrained. Where a step
        cannot be taken (not finite, or singular) the state is returned as it is there: see
        :meth:`projection` for the result code that says so."""
        return self.projection(t, x, p)[0]

    def projection(self, t, x, p) -> tuple[np.ndarray, int]:
        """(the state moved onto the constraints, as :meth:`project`; the result code of the compiled
        lg_projection: MET, or SINGULAR or NOT_FINITE where a step could not be taken, the state then
        as it was there)."""
        n = self.n
        x = np.array(x, float)
        with np.errstate(invalid="ignore"):
            nq = 1.0 + np.max(np.abs(x[:n]))
        if len(self.holonomic):
            for _ in range(PROJECTION_STEPS):
                g, Gh = self._holonomic(t, x, p)
                if not (np.all(np.isfinite(g)) and np.all(np.isfinite(Gh))):
                    return x, NOT_FINITE
                gmax = np.max(np.abs(g))
                if gmax <= PROJECTION_TOL * nq:
                    break
                Q, R, rho = _qr(Gh.T)
                if rho <= SINGULAR_RATIO:
                    return x, SINGULAR
                x[:n] -= Q @ _triangular(R, g, transpose=True)
                if gmax <= NEWTON_EXIT * nq:
                    break
        w, G, M = self._velocity_parts(t, x, p)
        if not (np.all(np.isfinite(w)) and np.all(np.isfinite(G)) and np.all(np.isfinite(M))):
            return x, NOT_FINITE
        if np.max(np.abs(w), initial=0.0) > 0.0:
            r, rho, Lc, Q, R = _factor(M, G)
            if min(r, rho) <= SINGULAR_RATIO:
                return x, SINGULAR
            x[n:] -= _triangular(Lc, Q @ _triangular(R, w, transpose=True), transpose=True, lower=True)
        if not np.all(np.isfinite(x)):
            return x, NOT_FINITE
        return x, MET

    def projected(self, t, x, p) -> np.ndarray:
        """The state moved onto the constraints (:meth:`projection`); a SimulationError
        (Status.PROJECTION_SINGULAR or PROJECTION_NOT_FINITE, see projection_failure) where the
        projection fails: what the integrations call, as the compiled DOP853 stops there."""
        y, code = self.projection(t, x, p)
        if code != MET:
            raise projection_failure(self, t, y, code, p)
        return y


_CACHE: "weakref.WeakKeyDictionary[Equations, ConstrainedModel]" = weakref.WeakKeyDictionary()


def constrained_model(equations: Equations, nm) -> ConstrainedModel:
    """The ConstrainedModel of `equations` (nm: its NumericModel), cached per Equations."""
    hit = _CACHE.get(equations)
    if hit is not None:
        return hit
    core = equations.core
    n, m = equations.n, len(core.g)
    inputs = [se.Symbol(u.name) for u in equations.inputs]
    params = [se.Symbol(p.name) for p in equations.parameters]
    state = [*core.q, *core.qd]
    args = [core.t, *state, *inputs, *params]
    M = [core.M[i, j] for i in range(n) for j in range(n)]
    G = [core.G[k, j] for k in range(m) for j in range(n)]
    parts = lambdify(args, M + list(core.f) + G + list(core.c))
    kinds = [c.kind for c in equations.model.constraints]
    hol = [k for k, kind in enumerate(kinds) if kind == HOLONOMIC]
    position = lambdify([core.t, *state, *params], [core.g[k] for k in hol]
                        + [core.G[k, j] for k in hol for j in range(n)] or [se.Integer(0)])
    velocity = lambdify([core.t, *state, *params], list(core.w) + G + M)
    cm = ConstrainedModel(equations, nm, parts, position, velocity, np.array(hol, int))
    _CACHE[equations] = cm
    return cm


# ---------------------------------------------------------------------------- initial state
def consistent_state(cm: ConstrainedModel, x0, fixed_names, p) -> np.ndarray:
    """x0 moved onto the constraints, keeping the coordinates and velocities named in
    `fixed_names`; a clear error where that is impossible."""
    eq = cm.equations
    n = cm.n
    names = eq.state_names
    fixed_q = sorted({names.index(k) for k in fixed_names if names.index(k) < n})
    fixed_v = sorted({names.index(k) - n for k in fixed_names if names.index(k) >= n})
    x = np.array(x0, float)
    scale = 1.0 + np.max(np.abs(x[:n]))
    free = [i for i in range(n) if i not in fixed_q]
    problems = []
    if len(cm.holonomic) and free:
        # Gauss-Newton of the smallest change, steps of at most 1, polished until a step is at
        # round-off (linear convergence where G loses rank at the solution): equations._search,
        # transcribed in the C export's <id>_consistent_state
        def holonomic(x):
            g, G = cm._holonomic(0.0, x, p)
            return g, G[:, free]

        x, _ = gauss_newton(holonomic, x, free, iterations=200, small=1e-13 * scale, polish=200,
                            step_tol=STEP_ROUND_OFF * scale, max_step=1.0, nudge=NUDGE)
    if len(cm.holonomic):
        g, G = cm._holonomic(0.0, x, p)
        bad = [k for k, v in zip(cm.holonomic, g) if not abs(v) <= 1e-9 * scale]
        if bad:
            held = ", ".join(names[i] for i in fixed_q) or "none"
            for k in bad:
                con = eq.model.constraints[k]
                problems.append(Problem(
                    f"the initial coordinates do not meet constraint '{con.name}' ({con.expression} = "
                    f"{g[list(cm.holonomic).index(k)]:.3g}, not 0), and changing the coordinates that were not "
                    f"given ({', '.join(names[i] for i in free) or 'none'}; given: {held}) does not fix it: give "
                    "fewer coordinates (the independent ones) or values that meet it", key="initial"))
            raise ModelError(problems)
    w, G, M = cm._velocity_parts(0.0, x, p)
    freev = [i for i in range(n) if i not in fixed_v]
    if freev and np.max(np.abs(w), initial=0.0) > 0:
        dv, *_ = np.linalg.lstsq(G[:, freev], w, rcond=None)
        x[n + np.array(freev, int)] -= dv
    w = cm._velocity_parts(0.0, x, p)[0]
    vscale = 1.0 + np.max(np.abs(x[n:]))
    bad = [k for k, v in enumerate(w) if not abs(v) <= 1e-9 * vscale]
    if bad:
        con = eq.model.constraints[bad[0]]
        raise ModelError([Problem(
            f"the initial velocities do not meet constraint '{con.name}' (its velocity residual is "
            f"{w[bad[0]]:.3g}, not 0), and changing the velocities that were not given does not fix it: give "
            "fewer velocities (those of the independent coordinates) or values that meet it", key="initial")])
    return x


# ------------------------------------------------------------------------------- integration
def multipliers_and_drift(cm: ConstrainedModel, times, X, U, p, fast=None) -> tuple[np.ndarray, dict]:
    """The multipliers at the outputs (one row each), and the largest |g| ("position") and
    |G q_dot + b| ("velocity") there: the trajectory's constraint_drift. `fast`: the compiled model
    the run integrated, whose rhs gives the multipliers (the same algorithm, in compiled code)."""
    if fast is not None and getattr(fast, "project_c", None) is not None:
        from ._codegen_constrained import compiled_multipliers

        Lam = compiled_multipliers(fast, times, X, U, p)
    else:
        Lam = np.array([cm.solve(t, x, u, p)[1] for t, x, u in zip(times, X, U)]).reshape(len(times), cm.m)
    drift_q = drift_v = 0.0
    for t, x in zip(times, X):
        g, w = cm.residuals(t, x, p)
        drift_q = max(drift_q, float(np.max(np.abs(g), initial=0.0)))
        drift_v = max(drift_v, float(np.max(np.abs(w), initial=0.0)))
    return Lam, {"position": drift_q, "velocity": drift_v}


def _solver(method: str):
    """SciPy's OdeSolver class of `method`."""
    from scipy import integrate as si

    return getattr(si, method)


def _measure(cm: ConstrainedModel, t, x, u_of, p) -> float:
    return min(cm.measures(t, x, u_of(t, x), p))


def integrate(cm: ConstrainedModel, x0, times, p, u_of, rtol, atol, max_step, method="DOP853"):
    """(X at `times`, Lambda at `times`, stats): the projected integration (see the module), from
    x0 at t = times[0]."""
    n = cm.n
    nfev = 0

    def rhs(t, x):
        nonlocal nfev
        nfev += 1
        qdd, _ = cm.solve(t, x, u_of(t, x), p)
        return np.concatenate((x[n:], qdd))

    X = np.empty((len(times), 2 * n))
    X[0] = x0
    t0 = float(times[0])
    if times[-1] == t0:
        rhs(t0, x0)
        nstep = 0
    else:
        solver = _solver(method)(rhs, t0, x0, float(times[-1]), rtol=rtol, atol=atol, max_step=max_step)
        j, nstep = 1, 0
        above = _measure(cm, t0, x0, u_of, p) > EVENT_RATIO
        try:
            while j < len(times):
                t_old = solver.t
                _step(solver)
                nstep += 1
                dense = solver.dense_output()
                if above and _measure(cm, solver.t, solver.y, u_of, p) <= EVENT_RATIO:
                    # the measure crossed EVENT_RATIO in the step: located on the interpolant, as compiled
                    a, b = t_old, solver.t
                    for _ in range(200):
                        if b - a <= 4.0 * np.finfo(float).eps * max(1.0, abs(b)):
                            break
                        mid = 0.5 * (a + b)
                        if _measure(cm, mid, dense(mid), u_of, p) <= EVENT_RATIO:
                            b = mid
                        else:
                            a = mid
                    while j < len(times) and times[j] <= b:
                        X[j] = cm.projected(times[j], dense(times[j]), p)
                        j += 1
                    xb = dense(b)
                    r_M, rho = cm.measures(b, xb, u_of(b, xb), p)
                    raise ConstraintSingular(b, xb, min(r_M, rho), mass=r_M <= rho)
                while j < len(times) and times[j] < solver.t:  # the outputs, then the step's end, as compiled
                    X[j] = cm.projected(times[j], dense(times[j]), p)
                    j += 1
                projected = cm.projected(solver.t, solver.y, p)
                while j < len(times) and times[j] <= solver.t:
                    X[j] = projected
                    j += 1
                solver.y = projected
                if hasattr(solver, "f") and method != "DOP853":  # DOP853 keeps its last stage, as compiled
                    solver.f = rhs(solver.t, projected)
                if solver.status == "finished" and j < len(times):
                    X[j:] = projected
                    break
        except (ConstraintSingular, SimulationError) as exc:
            exc.rows = X[:j]  # the output rows reached: simulate keeps them (SimulationError.partial)
            raise
    U = np.array([u_of(t, x) for t, x in zip(times, X)]).reshape(len(times), -1)
    Lam, drift = multipliers_and_drift(cm, times, X, U, p)
    stats = {"nfev": nfev, "nstep": nstep, "projection": "coordinate projection after every step",
             "constraint_drift": drift}
    return X, U, Lam, stats


def singular_constraint_message(cm: ConstrainedModel, t, x, p) -> str:
    """Where the constraint Jacobian lost rank: which constraints are dependent there, and which
    motion they no longer fix (or lock)."""
    eq = cm.equations
    n = cm.n
    _, G, _ = cm._velocity_parts(t, x, p)
    U, s, Vt = np.linalg.svd(G)
    names = [c.name for c in eq.model.constraints]
    dependent = U[:, -1]
    rows = [f"{v:+.3g}*{nm}" for v, nm in zip(dependent, names) if abs(v) > 1e-6]
    state = ", ".join(f"{k} = {v:.6g}" for k, v in zip(eq.state_names, x))
    locked = ""
    if G.shape[0] <= n:
        free_dir = Vt[G.shape[0] - 1] if len(s) else np.zeros(n)
        combo = " ".join(f"{v:+.3g}*{q.name}_dot" for v, q in zip(free_dir, eq.coordinates) if abs(v) > 1e-6)
        locked = (f"; the constraints no longer fix the velocity combination {combo}, and no force of the "
                  "constraints can act along it")
    return (f"the constraints' Jacobian G loses rank at t = {float(t):.6g} (state {state}): the rows "
            f"{' '.join(rows)} combine to zero, so the constraints are dependent there (a dead point or a "
            f"singular configuration of the mechanism){locked}. Their multipliers are not defined there: avoid "
            "the configuration (other initial values, a driving input), or write the mechanism with one "
            "constraint fewer")



def projection_failure(cm: ConstrainedModel, t, x, code: int, p) -> SimulationError:
    """The error of a run whose projection onto the constraints returned `code` (SINGULAR or
    NOT_FINITE) at (t, x): Status.PROJECTION_SINGULAR with where the constraints' Jacobian lost rank
    (or M its inertia), or Status.PROJECTION_NOT_FINITE with the constraints whose residuals are not
    finite there. The numba, C and NumPy projections stop with it alike."""
    from ..errors import Status

    eq = cm.equations
    t = float(t)
    x = np.asarray(x, float)
    state = ", ".join(f"{k} = {v:.6g}" for k, v in zip(eq.state_names, x))
    head = f"the projection onto the constraints failed at t = {t:.6g}"
    if code == SINGULAR:
        status = Status.PROJECTION_SINGULAR
        with np.errstate(all="ignore"):
            r_M, rho = cm.measures(t, x, np.zeros(len(eq.inputs)), p)
        if r_M < rho and r_M <= EVENT_RATIO:
            why = (f"the mass matrix is singular there (inertia measure {r_M:.3g}, state {state}), so the "
                   "velocities cannot be moved onto the constraints")
        else:
            why = singular_constraint_message(cm, t, x, p)
        return SimulationError(f"{head}: it met a singular system, and the state was left off the constraints; "
                               f"{why}. ({status.fix})", status=status, time=t)
    status = Status.PROJECTION_NOT_FINITE
    names = [c.name for c in eq.model.constraints]
    with np.errstate(all="ignore"):
        g, w = cm.residuals(t, x, p) if np.all(np.isfinite(x)) else (np.zeros(0), np.zeros(0))
    bad = [names[k] for k, v in zip(cm.holonomic, g) if not np.isfinite(v)]
    bad += [nm for nm, v in zip(names, w) if not np.isfinite(v) and nm not in bad]
    if not np.all(np.isfinite(x)):
        what = "the state is not finite (NaN or infinity)"
    elif bad:
        many = len(bad) > 1
        what = (f"constraint{'s' if many else ''} {', '.join(repr(b) for b in bad)} {'are' if many else 'is'} "
                "not finite (NaN or infinity) there")
    else:
        what = "the constraints' Jacobian G or the mass matrix M is not finite (NaN or infinity) there"
    return SimulationError(f"{head} in the state {state}: {what}, so the state cannot be moved onto the "
                           f"constraints; {status.fix}", status=status, time=t)


# ------------------------------------------------------------------------------- elimination
def _step(solver) -> None:
    """One step of a SciPy solver; a SimulationError where it fails."""
    message = solver.step()
    if solver.status == "failed":
        raise SimulationError(f"the integrator stopped at t = {solver.t:.6g}: {message}; try a smaller "
                              "rtol/atol or check the model's parameters", status=-1, time=float(solver.t))


def integrate_eliminated(cm: ConstrainedModel, x0, times, p, u_of, rtol, atol, max_step, method, independent):
    """(X at `times`, Lambda at `times`, stats): the ODE in the independent coordinates.

    The state is (q_i, q_dot_i), the independent coordinates and their velocities. At every
    evaluation the dependent coordinates are found by Newton on g(q, t) = 0 (G_d, the Jacobian's
    columns of the dependent ones, square; started from the last solution, so the mechanism stays on
    its assembly branch), their velocities from G q_dot + b = 0, and q_ddot_i from the saddle-point
    system. The constraints hold to Newton's tolerance at every output by construction: no drift,
    and no projection."""
    n = cm.n
    ind = list(independent)
    dep = [i for i in range(n) if i not in ind]
    r = len(ind)
    last = np.array(x0[:n], float)
    nfev = 0

    def full(t, z) -> np.ndarray:
        x = np.zeros(2 * n)
        x[:n] = last
        x[ind] = z[:r]
        scale = 1.0 + np.max(np.abs(x[:n]))
        for _ in range(30):
            g, G = cm._holonomic(t, x, p)
            if np.max(np.abs(g), initial=0.0) <= 1e-14 * scale:
                break
            Gd = G[:, dep]
            try:
                x[dep] -= np.linalg.solve(Gd, g)
            except np.linalg.LinAlgError:
                raise ConstraintSingular(t, x, 0.0) from None
        else:
            raise ConstraintSingular(t, x, 0.0)
        x[n + np.array(ind, int)] = z[r:]
        w, G, _ = cm._velocity_parts(t, x, p)
        x[n + np.array(dep, int)] = -np.linalg.solve(G[:, dep], w)  # w at q_dot_d = 0: G_i q_dot_i + b
        last[:] = x[:n]
        return x

    def rhs(t, z):
        nonlocal nfev
        nfev += 1
        x = full(t, z)
        qdd, _ = cm.solve(t, x, u_of(t, x), p)
        return np.concatenate((z[r:], qdd[ind]))

    z0 = np.concatenate((x0[ind], x0[n + np.array(ind, int)]))
    X = np.empty((len(times), 2 * n))
    X[0] = full(float(times[0]), z0)
    nstep = 0
    if times[-1] > times[0]:
        solver = _solver(method)(rhs, float(times[0]), z0, float(times[-1]), rtol=rtol, atol=atol,
                                 max_step=max_step)
        j = 1
        try:
            while j < len(times):
                _step(solver)
                nstep += 1
                dense = solver.dense_output()
                while j < len(times) and times[j] <= solver.t:
                    X[j] = full(times[j], dense(times[j]))
                    j += 1
                full(solver.t, solver.y)  # the branch at the step's end, for the next step's start
                if solver.status == "finished" and j < len(times):
                    X[j:] = full(solver.t, solver.y)
                    break
        except (ConstraintSingular, SimulationError) as exc:
            exc.rows = X[:j]  # the output rows reached: simulate keeps them (SimulationError.partial)
            raise
    U = np.array([u_of(t, x) for t, x in zip(times, X)]).reshape(len(times), -1)
    Lam, drift = multipliers_and_drift(cm, times, X, U, p)
    stats = {"nfev": nfev, "nstep": nstep,
             "elimination": "an ODE in the independent coordinates (the others by Newton on g = 0 at every "
                            "evaluation)",
             "constraint_drift": drift}
    return X, U, Lam, stats
