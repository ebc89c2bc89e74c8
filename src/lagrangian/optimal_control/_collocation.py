"""Direct collocation: Hermite-Simpson (separated) on the implicit equations, solved by IPOPT.

The unknowns at every collocation point (the mesh's nodes and the intervals' midpoints, 2N + 1 in
all) are the state x = [q, q_dot], the accelerations a = q_ddot, the multipliers lambda (constrained
models) and the inputs u; with a free duration, the duration T too. The constraints:

* the dynamics at every point, implicit: ``M(q) a - f(q, q_dot, u, t) - G(q)^T lambda = 0`` (M is
  never inverted), and for constrained models ``G a - c = 0`` (the constraints at acceleration level);
  the position and velocity constraints ``g(q) = 0``, ``G q_dot + b = 0`` at the first node (the
  acceleration-level ones then hold them up to the collocation error, which is reported);
* Hermite-Simpson on each interval k (F = [q_dot, a]):
  ``x_m = (x_k + x_k+1)/2 + h/8 (F_k - F_k+1)`` and ``x_k+1 = x_k + h/6 (F_k + 4 F_m + F_k+1)``;
* bounds on states and inputs at every point, path expressions at every point, the fixed states at
  the ends.

The objective: Simpson's rule of the integrand, plus the terminal cost, plus T for minimum time.
CasADi builds the exact sparse Jacobian and Hessian of the Lagrangian from the SX graph translated
node by node from the symbolic equations (``_casadi.to_casadi``).

The collocation error of interval k is h times the largest residual of the dynamics at its quarter
points (1/4 and 3/4) along the cubic Hermite interpolant of the states (inputs: the quadratic through
the interval's three values), each state scaled by 1 + its largest magnitude; the interpolant meets
the dynamics exactly at the nodes and the midpoint. Intervals above the tolerance are split (into 2
to 5, by the ratio, since the error falls as h^4) and the problem is solved again from the
interpolated solution.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ModelError
from ._casadi import import_casadi, to_casadi
from ._problem import OptimalControlError, OptimalControlProblem

__all__ = ["Transcription", "Solution"]

_STATUS_FIX = {
    "Infeasible_Problem_Detected": "no motion satisfies the constraints: widen the input or state bounds, lengthen "
                                   "the duration (or free it: duration = [lower, upper]), or relax the final state",
    "Maximum_Iterations_Exceeded": "IPOPT stopped at its iteration limit: give a better first guess (guess=), more "
                                   "intervals, or a looser problem",
    "Restoration_Failed": "IPOPT could not restore feasibility: the problem is probably infeasible or badly scaled; "
                          "widen the bounds or lengthen the duration",
    "Diverging_Iterates": "the iterates diverged: bound the states and inputs",
}


@dataclass(frozen=True)
class Solution:
    """One solve on one mesh (internal)."""

    tau: np.ndarray          # (2N+1,) the points in [0, 1]
    T: float
    X: np.ndarray            # (2N+1, 2n)
    A: np.ndarray            # (2N+1, n)
    L: np.ndarray            # (2N+1, m)
    U: np.ndarray            # (2N+1, k)
    cost: float
    iterations: int
    status: str
    errors: np.ndarray       # (N,) collocation error per interval


class Transcription:
    """The problem's functions in CasADi (built once; one NLP per mesh)."""

    def __init__(self, equations, problem: OptimalControlProblem, params: dict[str, float]):
        ca = import_casadi()
        self.ca = ca
        self.eq = equations
        self.problem = problem
        core = equations.core
        n = equations.n
        m = len(equations.multipliers)
        self.n, self.m = n, m
        self.input_names = [u.name for u in equations.inputs]
        self.k = len(self.input_names)
        self.state_names = list(equations.state_names)
        q = ca.SX.sym("q", n)
        v = ca.SX.sym("v", n)
        a = ca.SX.sym("a", n)
        lam = ca.SX.sym("lam", m)
        u = ca.SX.sym("u", self.k)
        t = ca.SX.sym("t")
        symbols: dict = {"t": t}
        for i, c in enumerate(equations.q):
            symbols[c.name] = q[i]
            symbols[f"{c.name}_dot"] = v[i]
        for i, name in enumerate(self.input_names):
            symbols[name] = u[i]
        symbols.update(params)
        self.symbols = symbols
        M = to_casadi([core.M[i, j] for i in range(n) for j in range(n)], symbols, where="the mass matrix M")
        f = to_casadi(core.f, symbols, where="the forcing f")
        Mx = ca.reshape(ca.vertcat(*M), n, n)  # symmetric, so row/column order does not matter
        fx = ca.vertcat(*f)
        res = ca.mtimes(Mx, a) - fx
        args = [q, v, a, lam, u, t]
        if m:
            G = to_casadi([core.G[i, j] for i in range(m) for j in range(n)], symbols,
                          where="the constraint Jacobian G")
            Gx = ca.reshape(ca.vertcat(*G), n, m).T
            c = ca.vertcat(*to_casadi(core.c, symbols, where="the constraints' c"))
            res = res - ca.mtimes(Gx.T, lam)
            acc = ca.mtimes(Gx, a) - c
            holo = [g for g, con in zip(core.g, equations.model.constraints) if con.kind == "holonomic"]
            pos = ca.vertcat(*to_casadi(holo, symbols, where="the constraints g")) if holo else ca.SX(0, 1)
            vel = ca.vertcat(*to_casadi(core.w, symbols, where="the constraints' velocities"))
            self.acc = ca.Function("acc", args, [acc])
            self.boundary = ca.Function("boundary", [q, v, t], [ca.vertcat(pos, vel)])
            self.pos = ca.Function("pos", [q, t], [pos])
            self.posjac = ca.Function("posjac", [q, t], [pos, ca.jacobian(pos, q)])
            self.veljac = ca.Function("veljac", [q, v, t], [vel, ca.jacobian(vel, v)])
            self.parts = ca.Function("parts", [q, v, u, t], [Mx, fx, Gx, c])
        else:
            self.parts = ca.Function("parts", [q, v, u, t], [Mx, fx, ca.SX(0, n), ca.SX(0, 1)])
        self.dyn = ca.Function("dyn", args, [res])
        # the implicit function theorem on M a - f = 0 (unconstrained): da/d(q, v, u) = -M^-1 d(M a - f)/d(q, v, u)
        unconstrained = ca.mtimes(Mx, a) - fx
        self.jac = ca.Function("implicit_jacobian", [q, v, a, u, t], [Mx, ca.jacobian(unconstrained, ca.vertcat(q, v)),
                                                        ca.jacobian(unconstrained, u)])
        zero = ca.SX(0)
        obj = to_casadi([problem.objective], symbols, where="the objective")[0] if problem.objective is not None \
            else zero
        self.integrand = ca.Function("L", [q, v, u, t], [obj])
        term = to_casadi([problem.terminal_cost], symbols, where="the terminal cost")[0] \
            if problem.terminal_cost is not None else zero
        self.terminal = ca.Function("phi", [q, v, t], [term])
        self.path_names = list(problem.path)
        exprs = [problem.path[name][0] for name in self.path_names]
        pathx = ca.vertcat(*to_casadi(exprs, symbols, where="the path constraints")) if exprs else ca.SX(0, 1)
        self.pathf = ca.Function("path", [q, v, u, t], [pathx])
        self.path_lo = np.array([problem.path[name][1] for name in self.path_names])
        self.path_hi = np.array([problem.path[name][2] for name in self.path_names])

    # ---------------------------------------------------------------- one NLP
    def solve(self, tau_nodes: np.ndarray, guess: dict, *, max_iter: int = 3000, tol: float = 1e-9) -> Solution:
        ca = self.ca
        n, m, k = self.n, self.m, self.k
        N = len(tau_nodes) - 1
        P = 2 * N + 1
        tau = np.empty(P)
        tau[0::2] = tau_nodes
        tau[1::2] = 0.5 * (tau_nodes[:-1] + tau_nodes[1:])
        nz = 3 * n + m + k
        Z = ca.MX.sym("Z", nz, P)
        free = self.problem.free_duration
        T = ca.MX.sym("T") if free else float(self.problem.duration)
        X, A = Z[:2 * n, :], Z[2 * n:3 * n, :]
        Lam, U = Z[3 * n:3 * n + m, :], Z[3 * n + m:, :]
        tp = T * ca.DM(tau).T
        Q, V = X[:n, :], X[n:, :]
        F = ca.vertcat(V, A)
        dyn = self.dyn.map(P)(Q, V, A, Lam, U, tp)
        i0, im, i1 = list(range(0, P - 2, 2)), list(range(1, P - 1, 2)), list(range(2, P, 2))
        h = T * ca.DM(np.diff(tau_nodes)).T
        H = ca.repmat(h, 2 * n, 1)
        mid = X[:, im] - 0.5 * (X[:, i0] + X[:, i1]) - H / 8 * (F[:, i0] - F[:, i1])
        simpson = X[:, i1] - X[:, i0] - H / 6 * (F[:, i0] + 4 * F[:, im] + F[:, i1])
        Lp = self.integrand.map(P)(Q, V, U, tp)
        cost = ca.sum2(h / 6 * (Lp[:, i0] + 4 * Lp[:, im] + Lp[:, i1]))
        cost = cost + self.terminal(Q[:, P - 1], V[:, P - 1], T)
        if self.problem.minimum_time:
            cost = cost + T
        g = [ca.vec(mid), ca.vec(simpson), ca.vec(dyn)]
        lbg = [np.zeros(2 * n * N * 2 + n * P)]
        ubg = [np.zeros(2 * n * N * 2 + n * P)]
        if m:
            g.append(ca.vec(self.acc.map(P)(Q, V, A, Lam, U, tp)))
            g.append(self.boundary(Q[:, 0], V[:, 0], 0.0))
            size = m * P + self.boundary.size1_out(0)
            lbg.append(np.zeros(size))
            ubg.append(np.zeros(size))
        r = len(self.path_names)
        if r:
            g.append(ca.vec(self.pathf.map(P)(Q, V, U, tp)))
            lbg.append(np.tile(self.path_lo, P))
            ubg.append(np.tile(self.path_hi, P))
        lbz, ubz = self._bounds(P, nz)
        w = ca.vec(Z)
        lbw, ubw = lbz.ravel(order="F"), ubz.ravel(order="F")
        w0 = self._guess_matrix(guess, tau, nz, P).ravel(order="F")
        if free:
            w = ca.vertcat(w, T)
            lo, hi = self.problem.duration
            lbw, ubw = np.append(lbw, lo), np.append(ubw, hi)
            w0 = np.append(w0, min(max(guess["T"], lo), hi))
        nlp = {"x": w, "f": cost, "g": ca.vertcat(*g)}
        opts = {"expand": True, "print_time": False,
                "ipopt": {"print_level": 0, "sb": "yes", "max_iter": max_iter, "tol": tol}}
        solver = ca.nlpsol("collocation", "ipopt", nlp, opts)
        sol = solver(x0=w0, lbx=lbw, ubx=ubw, lbg=np.concatenate(lbg), ubg=np.concatenate(ubg))
        stats = solver.stats()
        status = str(stats.get("return_status", "unknown"))
        if not stats.get("success", False) and status != "Solved_To_Acceptable_Level":
            fix = _STATUS_FIX.get(status, "check the bounds, the duration and the final state; give a better guess")
            raise OptimalControlError(
                f"no optimal motion found: IPOPT stopped with '{status}' after {stats.get('iter_count', 0)} "
                f"iterations on a mesh of {N} intervals; {fix}", status=status)
        x = np.asarray(sol["x"]).ravel()
        Tval = float(x[-1]) if free else float(self.problem.duration)
        Zv = x[:nz * P].reshape((nz, P), order="F")
        out = Solution(tau=tau, T=Tval, X=Zv[:2 * n].T.copy(), A=Zv[2 * n:3 * n].T.copy(),
                       L=Zv[3 * n:3 * n + m].T.copy(), U=Zv[3 * n + m:].T.copy(), cost=float(sol["f"]),
                       iterations=int(stats.get("iter_count", 0)), status=status, errors=np.empty(0))
        return Solution(**{**out.__dict__, "errors": self.errors(out)})

    def _bounds(self, P: int, nz: int) -> tuple[np.ndarray, np.ndarray]:
        n, m = self.n, self.m
        lo = np.full((nz, P), -np.inf)
        hi = np.full((nz, P), np.inf)
        pb = self.problem
        for i, s in enumerate(self.state_names):
            if s in pb.bounds:
                lo[i, :], hi[i, :] = pb.bounds[s]
            if s in pb.initial:
                lo[i, 0] = hi[i, 0] = pb.initial[s]
            if s in pb.final:
                lo[i, -1] = hi[i, -1] = pb.final[s]
        for j, name in enumerate(self.input_names):
            b = pb.inputs[name]
            row = 3 * n + m + j
            if isinstance(b, tuple):
                lo[row, :], hi[row, :] = b
            else:
                lo[row, :] = hi[row, :] = b
        return lo, hi

    def _guess_matrix(self, guess: dict, tau: np.ndarray, nz: int, P: int) -> np.ndarray:
        n, m = self.n, self.m
        Z = np.zeros((nz, P))
        Z[:2 * n] = guess["X"].T
        Z[2 * n:3 * n] = guess["A"].T
        Z[3 * n:3 * n + m] = guess["L"].T
        Z[3 * n + m:] = guess["U"].T
        lo, hi = self._bounds(P, nz)
        return np.clip(Z, np.where(np.isfinite(lo), lo, -1e300), np.where(np.isfinite(hi), hi, 1e300))

    # ---------------------------------------------------------------- the first guess
    def first_guess(self, tau: np.ndarray, T: float, hints: dict[str, float]) -> dict:
        """States linear between the given ends (a state given at one end only: held; at neither:
        the hint, from [simulation] initial, or 0); constrained models projected onto the constraints."""
        n, m = self.n, self.m
        pb = self.problem
        X = np.zeros((len(tau), 2 * n))
        pinned = np.zeros((len(tau), 2 * n), dtype=bool)
        for i, s in enumerate(self.state_names):
            a, b = pb.initial.get(s), pb.final.get(s)
            if a is not None and b is not None:
                X[:, i] = a + (b - a) * tau
                pinned[:, i] = True
            elif a is not None or b is not None:
                X[:, i] = a if a is not None else b
                pinned[0 if a is not None else -1, i] = True
            else:
                X[:, i] = hints.get(s, 0.0)
        for i in range(n):  # velocities free at both ends: the mean speed of the coordinate
            s = self.state_names[n + i]
            if s not in pb.initial and s not in pb.final and pinned[0, i] and pinned[-1, i]:
                X[:, n + i] = (X[-1, i] - X[0, i]) / T
        if m:
            X = self._project(X, T * tau, pinned)
        U = np.zeros((len(tau), self.k))
        for j, name in enumerate(self.input_names):
            b = pb.inputs[name]
            U[:, j] = (0.0 if b[0] <= 0.0 <= b[1] else (b[0] if math.isfinite(b[0]) else b[1])) \
                if isinstance(b, tuple) else b
        return {"X": X, "A": np.zeros((len(tau), n)), "L": np.zeros((len(tau), m)), "U": U, "T": T}

    def _project(self, X: np.ndarray, times: np.ndarray, pinned: np.ndarray) -> np.ndarray:
        """Gauss-Newton onto g(q) = 0 then onto the velocity constraints, moving only what is not
        pinned; each point starts from the previous one's answer (continuation along the motion)."""
        n = self.n
        X = X.copy()
        prev = None
        for p in range(len(X)):
            q = X[p, :n].copy()
            free_q = ~pinned[p, :n]
            if prev is not None:
                q[free_q] = prev[free_q]
            for _ in range(30):
                g, J = (np.asarray(v, dtype=float) for v in self.posjac(q, times[p]))
                g = g.ravel()
                if g.size == 0 or np.max(np.abs(g)) < 1e-12:
                    break
                step = np.linalg.lstsq(J[:, free_q], -g, rcond=None)[0]
                q[free_q] += step
            X[p, :n] = q
            prev = q
            v = X[p, n:].copy()
            free_v = ~pinned[p, n:]
            w, W = (np.asarray(z, dtype=float) for z in self.veljac(q, v, times[p]))
            if w.size:
                v[free_v] += np.linalg.lstsq(W[:, free_v], -w.ravel(), rcond=None)[0]
            X[p, n:] = v
        return X

    # ---------------------------------------------------------------- errors and interpolation
    def rates(self, x: np.ndarray, u: np.ndarray, t: float) -> np.ndarray:
        """x' at one point, by a numeric solve of M a = f (with the constraints' KKT system)."""
        n, m = self.n, self.m
        Mv, fv, Gv, cv = (np.asarray(z, dtype=float) for z in self.parts(x[:n], x[n:], u, t))
        if m:
            K = np.block([[Mv, Gv.T], [Gv, np.zeros((m, m))]])
            a = np.linalg.solve(K, np.concatenate([fv.ravel(), cv.ravel()]))[:n]
        else:
            a = np.linalg.solve(Mv, fv.ravel())
        return np.concatenate([x[n:], a])

    def linear(self, x: np.ndarray, u: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray]:
        """A = dF/dx (2n x 2n) and B = dF/du (2n x k) of F = [q_dot, a] at one point (unconstrained models)."""
        n = self.n
        a = self.rates(x, u, t)[n:]
        Mv, Rx, Ru = (np.asarray(z, dtype=float) for z in self.jac(x[:n], x[n:], a, u, t))
        A = np.zeros((2 * n, 2 * n))
        A[:n, n:] = np.eye(n)
        A[n:] = -np.linalg.solve(Mv, Rx)
        B = np.zeros((2 * n, self.k))
        B[n:] = -np.linalg.solve(Mv, Ru.reshape(n, self.k))
        return A, B

    def errors(self, s: Solution) -> np.ndarray:
        n = self.n
        N = (len(s.tau) - 1) // 2
        scale = 1.0 + np.max(np.abs(s.X), axis=0)
        F = np.hstack([s.X[:, n:], s.A])
        out = np.zeros(N)
        for j in range(N):
            t0, t1 = s.tau[2 * j] * s.T, s.tau[2 * j + 2] * s.T
            h = t1 - t0
            worst = 0.0
            for sig in (0.25, 0.75):
                x, dx = _hermite(s.X[2 * j], s.X[2 * j + 2], F[2 * j], F[2 * j + 2], h, sig)
                u = _quadratic(s.U[2 * j], s.U[2 * j + 1], s.U[2 * j + 2], sig)
                try:
                    r = dx - self.rates(x, u, t0 + sig * h)
                except np.linalg.LinAlgError:
                    r = np.full(2 * n, np.inf)
                worst = max(worst, float(np.max(np.abs(r) / scale)))
            out[j] = h * worst
        return out


def _hermite(x0, x1, f0, f1, h, s):
    """The cubic Hermite interpolant and its derivative at s in [0, 1] of an interval of length h."""
    h00, h10, h01, h11 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s, -2 * s**3 + 3 * s**2, s**3 - s**2
    d00, d10, d01, d11 = 6 * s**2 - 6 * s, 3 * s**2 - 4 * s + 1, -6 * s**2 + 6 * s, 3 * s**2 - 2 * s
    x = h00 * x0 + h10 * h * f0 + h01 * x1 + h11 * h * f1
    dx = (d00 * x0 + d01 * x1) / h + d10 * f0 + d11 * f1
    return x, dx


def _quadratic(y0, ym, y1, s):
    """The quadratic through (0, y0), (1/2, ym), (1, y1) at s."""
    return y0 * (2 * s - 1) * (s - 1) + ym * 4 * s * (1 - s) + y1 * s * (2 * s - 1)


def interpolate(tr: Transcription, s: Solution, tau_new: np.ndarray) -> dict:
    """The solution at new points in [0, 1]: states by the cubic Hermite interpolant, accelerations,
    multipliers and inputs by the quadratics (a warm start for the next mesh)."""
    n = tr.n
    nodes = s.tau[0::2]
    F = np.hstack([s.X[:, n:], s.A])
    out = {key: np.zeros((len(tau_new), arr.shape[1])) for key, arr in (("X", s.X), ("A", s.A), ("L", s.L),
                                                                         ("U", s.U))}
    for i, tn in enumerate(tau_new):
        j = min(max(int(np.searchsorted(nodes, tn, side="right")) - 1, 0), len(nodes) - 2)
        h = (nodes[j + 1] - nodes[j]) * s.T
        sig = (tn - nodes[j]) / (nodes[j + 1] - nodes[j])
        out["X"][i] = _hermite(s.X[2 * j], s.X[2 * j + 2], F[2 * j], F[2 * j + 2], h, sig)[0]
        for key, arr in (("A", s.A), ("L", s.L), ("U", s.U)):
            out[key][i] = _quadratic(arr[2 * j], arr[2 * j + 1], arr[2 * j + 2], sig)
    out["T"] = s.T
    return out


def refine(tau_nodes: np.ndarray, errors: np.ndarray, tol: float, cap: int) -> np.ndarray:
    """Split each interval whose error is above tol into 2 to 5 (the error falls as h^4)."""
    new = [tau_nodes[0]]
    for j, e in enumerate(errors):
        a, b = tau_nodes[j], tau_nodes[j + 1]
        pieces = 1 if e <= tol else int(min(5, max(2, math.ceil((e / tol) ** 0.25))))
        new.extend(a + (b - a) * np.arange(1, pieces + 1) / pieces)
    out = np.array(new)
    if len(out) - 1 > cap:
        raise ModelError(f"mesh refinement needs {len(out) - 1} intervals, more than the limit of {cap}; "
                         "loosen tolerance= or lower max_refinements=")
    return out
