"""The exact derivatives a fit needs, generated from the symbolic equations and compiled.

The dynamics in saddle-point form (it covers m = 0 and constrained models alike):

    R(q_ddot, lambda; x, p) = [M q_ddot - G^T lambda - f ; G q_ddot - c] = 0,

so that ``d(q_ddot, lambda)/dz = -K^-1 dR/dz`` with ``K = [[M, -G^T], [G, 0]]`` and z = (x, p). The
state x' = [q_dot, q_ddot] then has the Jacobians A = dx'/dx and B = dx'/dp of the forward
sensitivity equations S' = A S + B. Every expression is differentiated by SymEngine and evaluated by
one SymEngine Lambdify per group (LLVM machine code where SymEngine has it), vectorised over rows:
all shooting intervals of a fit advance together, so the Python overhead is paid once per stage, not
once per interval.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import symengine as se

__all__ = ["Sensitivities", "rk4_with_sensitivities"]


def _lambdify(args, exprs):
    exprs = list(exprs) or [se.Integer(0)]
    try:
        return se.Lambdify(args, exprs, cse=True, real=True, backend="llvm")
    except (ValueError, RuntimeError, TypeError):  # SymEngine built without LLVM
        return se.Lambdify(args, exprs, cse=True, real=True)


@dataclass(frozen=True, eq=False)
class Sensitivities:
    """Compiled evaluators of the dynamics, their derivatives in the state and in the fitted
    parameters, the measured expressions and the constraint residuals, in the argument order
    (t, q, q_dot, u, p) of every row (p: all the model's parameters, in `Equations.parameters` order)."""

    n: int
    m: int
    k: int
    fitted: tuple[int, ...]  # indices of the fitted parameters in p
    dyn: object
    jac: object
    out: object
    cons: object
    r: int  # number of measured expressions

    @classmethod
    def build(cls, equations, fitted: tuple[int, ...], measured: list) -> "Sensitivities":
        core = equations.core
        n, m = equations.n, len(core.g)
        q, qd = list(core.q), list(core.qd)
        u = [se.Symbol(s.name) for s in equations.inputs]
        p = [se.Symbol(s.name) for s in equations.parameters]
        th = [p[i] for i in fitted]
        x = q + qd
        args = [core.t, *q, *qd, *u, *p]
        zero = se.Integer(0)
        G = core.G
        M = core.M
        dyn = [M[i, j] for i in range(n) for j in range(n)] + list(core.f)
        dyn += [G[i, j] for i in range(m) for j in range(n)] + list(core.c)
        a = [se.Symbol(f"_lg_a{i}") for i in range(n)]
        mu = [se.Symbol(f"_lg_mu{i}") for i in range(m)]
        R = [sum((M[i, j] * a[j] for j in range(n)), zero) - sum((G[r, i] * mu[r] for r in range(m)), zero) - core.f[i]
             for i in range(n)]
        R += [sum((G[r, j] * a[j] for j in range(n)), zero) - core.c[r] for r in range(m)]
        jac = [e.diff(v) for e in R for v in x] + [e.diff(v) for e in R for v in th]
        h = [se.sympify(e) for e in measured]
        out = h + [e.diff(v) for e in h for v in x] + [e.diff(v) for e in h for v in th]
        cons_e = list(core.g) + list(core.w)
        cons = cons_e + [e.diff(v) for e in cons_e for v in x] + [e.diff(v) for e in cons_e for v in th]
        return cls(n, m, len(u), tuple(fitted), _lambdify(args, dyn), _lambdify(args + a + mu, jac),
                   _lambdify(args, out), _lambdify(args, cons) if m else None, len(h))

    @property
    def nth(self) -> int:
        return len(self.fitted)

    # ------------------------------------------------------------------ evaluation, rows at once
    @staticmethod
    def _args(t, X, U, P):
        rows = len(t)
        return np.column_stack((t, X, np.reshape(U, (rows, -1)), np.broadcast_to(P, (rows, P.size))))

    def accelerations(self, t, X, U, P):
        """(q_ddot (R, n), lambda (R, m), K (R, n+m, n+m)) of rows (t (R,), X (R, 2n), U (R, k))."""
        n, m = self.n, self.m
        out = np.asarray(self.dyn(self._args(t, X, U, P))).reshape(len(t), -1)
        M = out[:, :n * n].reshape(-1, n, n)
        f = out[:, n * n:n * n + n]
        G = out[:, n * n + n:n * n + n + m * n].reshape(len(t), m, n)
        c = out[:, n * n + n + m * n:]
        if m:
            K = np.zeros((len(t), n + m, n + m))
            K[:, :n, :n] = M
            K[:, :n, n:] = -np.transpose(G, (0, 2, 1))
            K[:, n:, :n] = G
            sol = np.linalg.solve(K, np.concatenate((f, c), axis=1)[..., None])[..., 0]
        else:
            K = M
            sol = np.linalg.solve(M, f[..., None])[..., 0]
        return sol[:, :n], sol[:, n:], K

    def derivatives(self, t, X, U, P):
        """(x' (R, 2n), A (R, 2n, 2n), B (R, 2n, nth)): the state's rate and its Jacobians in x and
        in the fitted parameters."""
        n, m, nth = self.n, self.m, self.nth
        rows = len(t)
        a, lam, K = self.accelerations(t, X, U, P)
        args = np.column_stack((self._args(t, X, U, P), a, lam))
        d = np.asarray(self.jac(args)).reshape(rows, -1)
        dRx = d[:, :(n + m) * 2 * n].reshape(rows, n + m, 2 * n)
        dRp = d[:, (n + m) * 2 * n:].reshape(rows, n + m, nth)
        dz = -np.linalg.solve(K, np.concatenate((dRx, dRp), axis=2))
        A = np.zeros((rows, 2 * n, 2 * n))
        A[:, :n, n:] = np.eye(n)
        A[:, n:, :] = dz[:, :n, :2 * n]
        B = np.zeros((rows, 2 * n, nth))
        B[:, n:, :] = dz[:, :n, 2 * n:]
        return np.concatenate((X[:, n:], a), axis=1), A, B

    def outputs(self, t, X, U, P):
        """(h (R, r), dh/dx (R, r, 2n), dh/dp (R, r, nth)) of the measured expressions."""
        r, n, nth = self.r, self.n, self.nth
        rows = len(t)
        out = np.asarray(self.out(self._args(t, X, U, P))).reshape(rows, -1)
        return (out[:, :r], out[:, r:r + r * 2 * n].reshape(rows, r, 2 * n),
                out[:, r + r * 2 * n:].reshape(rows, r, nth))

    def constraints(self, t, X, U, P):
        """(c (R, 2m): g then w, dc/dx (R, 2m, 2n), dc/dp (R, 2m, nth)); empty without constraints."""
        n, m, nth = self.n, self.m, self.nth
        rows = len(t)
        if not m:
            return np.zeros((rows, 0)), np.zeros((rows, 0, 2 * n)), np.zeros((rows, 0, nth))
        out = np.asarray(self.cons(self._args(t, X, U, P))).reshape(rows, -1)
        c = 2 * m
        return (out[:, :c], out[:, c:c + c * 2 * n].reshape(rows, c, 2 * n),
                out[:, c + c * 2 * n:].reshape(rows, c, nth))


def rk4_with_sensitivities(sens: Sensitivities, times: np.ndarray, X0: np.ndarray, inputs, P: np.ndarray,
                           substeps: int, with_sensitivities: bool = True):
    """Integrate rows of the state and their sensitivities by the classical Runge-Kutta method.

    Parameters
    ----------
    times : ndarray, shape (R, L + 1)
        Each row's sample times (a row that ends early repeats its last time: a step of zero).
    X0 : ndarray, shape (R, 2n)
        The state at each row's first time.
    inputs : callable
        ``inputs(t (R,)) -> U (R, k)``: the input signals of each row.
    substeps : int
        Runge-Kutta steps between two samples.

    Returns
    -------
    X : ndarray, shape (R, L + 1, 2n)
        The states at the sample times.
    S : ndarray, shape (R, L + 1, 2n, 2n + nth)
        Their derivatives in the row's initial state and in the fitted parameters. The sensitivity
        equations are integrated by the same steps as the state, so S is the exact derivative of the
        computed X (an explicit Runge-Kutta method commutes with linearization).
    """
    R, L1 = times.shape
    n2 = X0.shape[1]
    nth = sens.nth
    Xs = np.empty((R, L1, n2))
    X = X0.copy()
    Xs[:, 0] = X
    S = None
    Ss = None
    if with_sensitivities:
        S = np.zeros((R, n2, n2 + nth))
        S[:, :, :n2] = np.eye(n2)
        Ss = np.empty((R, L1, n2, n2 + nth))
        Ss[:, 0] = S

    def F(t, X, S):
        U = inputs(t)
        if S is None:
            a = sens.accelerations(t, X, U, P)[0]
            return np.concatenate((X[:, n2 // 2:], a), axis=1), None
        xd, A, B = sens.derivatives(t, X, U, P)
        dS = A @ S
        dS[:, :, n2:] += B
        return xd, dS

    for j in range(L1 - 1):
        h = (times[:, j + 1] - times[:, j]) / substeps
        t = times[:, j].copy()
        for _ in range(substeps):
            hc = h[:, None]
            hS = h[:, None, None]
            k1, l1 = F(t, X, S)
            k2, l2 = F(t + h / 2, X + hc / 2 * k1, None if S is None else S + hS / 2 * l1)
            k3, l3 = F(t + h / 2, X + hc / 2 * k2, None if S is None else S + hS / 2 * l2)
            k4, l4 = F(t + h, X + hc * k3, None if S is None else S + hS * l3)
            X = X + hc / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
            if S is not None:
                S = S + hS / 6 * (l1 + 2 * l2 + 2 * l3 + l4)
            t = t + h
        Xs[:, j + 1] = X
        if S is not None:
            Ss[:, j + 1] = S
    return Xs, Ss
