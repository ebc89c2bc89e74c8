"""compile(equations) -> CompiledModel or NumericModel: the numerical state equations x' = f(t, x, u, p),
by the fastest backend (numba) unless another is asked for.

Both implement one contract, :class:`NumericContract` (every function in the argument order
(t, x, u, p); constraints as the m >= 0 case; one failure value). NumericModel is the portable
backend: SymEngine's Lambdify with common-subexpression elimination evaluates each group of
expressions (M and f; the energy; the Jacobians analysis needs; the constraint parts) in one call,
built on first use, and NumPy solves M q_ddot = f (Cholesky, which also measures how close M is to
singular). The compiled backends evaluate the dynamics by generated code and take the Jacobians
from the NumericModel they carry. All of it is cached in one place (``_cache``), per Equations.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import builtins
import math

import numpy as np
import symengine as se

from ..equations import Equations
from ..equations._lambdify import lambdify
from ..equations._singular import inertia_measure, scaled_cholesky
from ..errors import ModelError
from ._cache import cached

__all__ = ["NOT_FINITE", "SINGULAR_RATIO", "NumericContract", "NumericModel", "compile", "compile_equations"]

#: inertia_measure(M) at or below which the mass matrix counts as singular (the compiled kernels' too).
SINGULAR_RATIO = 1e-12
#: The ratio ``solve`` returns where f is not finite (NaN or infinity).
NOT_FINITE = -1.0


class _Singular(Exception):
    def __init__(self, t, x, ratio):
        self.t, self.x, self.ratio = t, x, ratio


class _NotFinite(Exception):
    def __init__(self, t, x):
        self.t, self.x = t, x


def raise_on_failure(t, x, ratio: float) -> None:
    """Raise :class:`_Singular` or :class:`_NotFinite` for the failure value of ``solve`` (a ratio
    at or below SINGULAR_RATIO), for a caller (SciPy's integrator) that must stop there."""
    if ratio == NOT_FINITE:
        raise _NotFinite(t, np.array(x))
    if not ratio > SINGULAR_RATIO:
        raise _Singular(t, np.array(x), ratio)


@runtime_checkable
class NumericContract(Protocol):
    """What every numeric model gives: :class:`NumericModel` (SymEngine and NumPy) and
    :class:`~lagrangian.numeric.CompiledModel` (numba or C) alike.

    Every function takes ``(t, x, u, p)``: time (float), the state ``x = [q, q_dot]`` (shape (2n,),
    `state_names` order), the inputs ``u`` (shape (k,), `input_names` order) and the parameters ``p``
    (shape (l,), `parameter_names` order; `parameter_values` holds the model's, NaN where it gives
    none). The static functions take the configuration in place of the state: q (shape (n,)) for
    ``static``, z = (q, lambda) (shape (n + m,)) for ``statics``.

    A model has n coordinates and m >= 0 constraints (G q_ddot = c, with G of shape (m, n));
    ``solve`` gives the q_ddot of the saddle-point system ``[M G^T; G 0] [q_ddot; -lambda] = [f; c]``,
    which at m = 0 is M q_ddot = f, and the constraint parts are empty arrays at m = 0.

    The one failure value: ``solve`` returns ``(q_ddot, ratio)``; ``ratio`` is the inertia measure
    of M (1 for a diagonal M, 0 for a singular one), and at or below :data:`SINGULAR_RATIO` the
    model is singular there and q_ddot is NaN; ``ratio`` is :data:`NOT_FINITE` (-1.0) where f is not
    finite. ``rhs`` and ``accelerations`` are NaN there too. Nothing raises.
    """

    equations: Equations
    state_names: tuple[str, ...]
    input_names: tuple[str, ...]
    parameter_names: tuple[str, ...]
    parameter_values: np.ndarray

    @property
    def n(self) -> int:
        """The number of coordinates."""

    @property
    def m(self) -> int:
        """The number of constraints (0 without)."""

    def rhs(self, t, x, u, p) -> np.ndarray:
        """x' = [q_dot, q_ddot], shape (2n,)."""

    def mass_matrix(self, t, x, u, p) -> np.ndarray:
        """M, shape (n, n)."""

    def forcing(self, t, x, u, p) -> np.ndarray:
        """f, shape (n,), with M q_ddot = f (+ G^T lambda)."""

    def solve(self, t, x, u, p) -> tuple[np.ndarray, float]:
        """(q_ddot, ratio): see the failure value above."""

    def accelerations(self, t, x, u, p) -> np.ndarray:
        """q_ddot, shape (n,)."""

    def singular_ratio(self, t, x, u, p) -> float:
        """The inertia measure of M."""

    def energy(self, t, x, u, p) -> float:
        """The Jacobi integral h = q_dot . dL/dq_dot - L."""

    def constraint_parts(self, t, x, u, p) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(G, c, g, w): shapes (m, n), (m,), (m,), (m,): the constraint Jacobian, G q_ddot = c, the
        residuals g (g(q, t) of a holonomic constraint, the velocity residual of the others) and the
        velocity residuals w = G q_dot + b."""

    def constraint_residuals(self, t, x, u, p) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(G, g, w): ``constraint_parts`` without c."""

    def function(self, name: str, build) -> Callable[..., np.ndarray]:
        """``(t, x, u, p) -> array`` of the expressions ``build()`` gives (positions, outputs), kept
        with the model under `name`."""

    def jacobians(self, t, x, u, p, qdd=None) -> dict[str, np.ndarray]:
        """M, f and their derivatives: {"M": (n, n), "f": (n,), "fq": df/dq (n, n), "fqd": df/dq_dot
        (n, n), "fu": df/du (n, k), "Maq": d(M a)/dq at a = qdd (n, n); 0 when qdd is None}."""

    def state_jacobians(self, t, x, u, p) -> tuple[np.ndarray, np.ndarray]:
        """(d rhs/dx, d rhs/du): shapes (2n, 2n), (2n, k); for m = 0 (a constrained model's state
        moves on the constraints: its linearization is ``lagrangian.linearize``'s)."""

    def momenta(self, t, x, u, p) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(dL/dq_dot, its Jacobian in q, M): shapes (n,), (n, n), (n, n)."""

    def damping(self, t, x, u, p) -> np.ndarray:
        """The damping matrix, shape (n, n): the symmetric part of d2D/dq_dot2 - dQ/dq_dot."""

    def static(self, t, q, u, p) -> tuple[np.ndarray, np.ndarray]:
        """(f, df/dq) at rest (q_dot = 0): shapes (n,), (n, n)."""

    def statics(self, t, z, u, p) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """At rest, in z = (q, lambda): (F = f + G^T lambda, g, dF/dq, G): shapes (n,), (m,), (n, n), (m, n)."""


def _evaluator_of(args, exprs):
    """The one SymEngine evaluator of every group of expressions (common subexpressions shared)."""
    return lambdify(args, list(exprs) or [se.Integer(0)])


#: The groups a large model evaluates by its shared statement list (:func:`_shared_function`).
_SHARED_GROUPS = ("dynamics", "energy")


def _shared_function(equations: Equations, exprs: list):
    """For a large model (numeric._codegen.large_model), `exprs` as a plain Python function of the argument vector
    [t, x, u, p]: the statements of the code generator's one walk over their shared subexpressions (each name through
    lagrangian._codetext, as in the numba module), instead of SymEngine's cse over the whole expressions (65 s at 8
    rods, about 4x per rod). None for other models, or expressions the generator cannot write (SymEngine's then)."""
    from ._codegen import Unsupported, _Printer, large_model

    if not large_model(equations):
        return None
    n, k = equations.n, len(equations.inputs)
    pr = _Printer(equations, "py")
    try:
        lines, outputs = pr.block(list(exprs))
    except Unsupported:
        return None

    def slot(acc: str) -> str:
        if acc == "t":
            return "a[0]"
        kind, i = acc[0], int(acc[2:-1])
        return f"a[{1 + i + {'x': 0, 'u': 2 * n, 'p': 2 * n + k}[kind]}]"

    source = "\n".join(["def evaluate(a):", *(f"    {local} = {slot(acc)}" for local, acc, _ in pr.locals), *lines,
                         "    return [" + ", ".join(outputs) + "]", ""])
    namespace = {"math": math, "_sign": lambda v: 1.0 if v > 0.0 else (-1.0 if v < 0.0 else 0.0),
                 "_heaviside": lambda v: 1.0 if v > 0.0 else (0.5 if v == 0.0 else 0.0),
                 "_step": lambda v: 1.0 if v > 0.0 else 0.0}
    exec(builtins.compile(source, "<lagrangian shared statements>", "exec"), namespace)  # (generated: no raw names)
    evaluate = namespace["evaluate"]
    return lambda args: np.array(evaluate(np.asarray(args, dtype=float).tolist()), dtype=float)


def _flat(matrix, rows: int, cols: int) -> list:
    return [matrix[i, j] for i in range(rows) for j in range(cols)]


def _group(equations: Equations, name: str):
    """(the expressions of group `name`, the symbols it takes after (t, x, u, p), its shapes)."""
    core = equations.core
    n, k, m = equations.n, len(equations.inputs), len(core.g)
    q, qd = list(core.q), list(core.qd)
    zero = se.Integer(0)
    G = _flat(core.G, m, n) if m else []
    if name == "dynamics":
        return _flat(core.M, n, n) + list(core.f), [], [(n, n), (n,)]
    if name == "energy":
        return [sum((v * pi for v, pi in zip(qd, core.p)), zero) - core.L], [], [()]
    if name == "jacobians":
        u = [se.Symbol(s.name) for s in equations.inputs]
        a = [se.Symbol(f"_a{i}") for i in range(n)]  # placeholder accelerations for d(M a)/dq
        f = list(core.f)
        Ma = [sum((core.M[i, j] * a[j] for j in range(n)), zero) for i in range(n)]
        exprs = (_flat(core.M, n, n) + f + [fi.diff(qj) for fi in f for qj in q]
                 + [fi.diff(vj) for fi in f for vj in qd] + [fi.diff(uj) for fi in f for uj in u]
                 + [e.diff(qj) for e in Ma for qj in q])
        return exprs, a, [(n, n), (n,), (n, n), (n, n), (n, k), (n, n)]
    if name == "momenta":
        mom = list(core.p)
        return mom + [e.diff(qj) for e in mom for qj in q] + _flat(core.M, n, n), [], [(n,), (n, n), (n, n)]
    if name == "damping":
        Q = list(core.Q) or [zero] * n
        entries = [se.expand(core.D.diff(qd[i]).diff(qd[j]) - (Q[i].diff(qd[j]) + Q[j].diff(qd[i])) / 2)
                   for i in range(n) for j in range(n)]
        return (entries if any(e != 0 for e in entries) else []), [], [(n, n)]
    if name == "static":
        rest = {v: zero for v in qd}
        fs = [fi.subs(rest) for fi in core.f]
        return fs + [e.diff(qj) for e in fs for qj in q], [], [(n,), (n, n)]
    if name == "statics":
        lam = [se.Symbol(mu.name) for mu in equations.multipliers] if m else []
        rest = {v: zero for v in qd}
        F = [fi.subs(rest) + sum((core.G[r, i] * lam[r] for r in range(m)), zero) for i, fi in enumerate(core.f)]
        return (F + list(core.g) + [Fi.diff(qj) for Fi in F for qj in q] + G, lam,
                [(n,), (m,), (n, n), (m, n)])
    if name == "constraints":  # without c (the largest: the constraints differentiated twice)
        return G + list(core.g) + list(core.w), [], [(m, n), (m,), (m,)]
    if name == "bias":
        return list(core.c), [], [(m,)]
    raise KeyError(name)


@dataclass(frozen=True)
class _Evaluator:
    """One group of expressions evaluated at (t, x, u, p, extra) and cut into arrays of its shapes
    (zeros for a group with no expression: no evaluator is built)."""

    fun: object
    shapes: tuple

    def __call__(self, args: np.ndarray) -> list[np.ndarray]:
        if self.fun is None:
            return [np.zeros(s) for s in self.shapes]
        out = np.asarray(self.fun(args), dtype=float).ravel()
        parts, k = [], 0
        for s in self.shapes:
            size = int(np.prod(s, dtype=int))
            parts.append(out[k:k + size].reshape(s))
            k += size
        return parts


@dataclass(frozen=True, eq=False)
class NumericModel:
    """The numerical form of :class:`~lagrangian.equations.Equations`, evaluated by SymEngine and
    NumPy: the portable implementation of :class:`NumericContract` (read it for the functions,
    their shapes and the failure value).

    Every function takes ``(t, x, u, p)``: time (float), state ``x = [q, q_dot]`` (shape (2n,),
    in `state_names` order), inputs ``u`` (shape (k,), `input_names` order) and parameters ``p``
    (shape (l,), `parameter_names` order; `parameter_values` holds the model's values, NaN where
    the model gives none).
    """

    equations: Equations = field(repr=False)
    state_names: tuple[str, ...]
    input_names: tuple[str, ...]
    parameter_names: tuple[str, ...]
    parameter_values: np.ndarray = field(repr=False)
    _groups: dict = field(default_factory=dict, repr=False)  # name -> _Evaluator, built on first use

    @property
    def n(self) -> int:
        return len(self.state_names) // 2

    @property
    def m(self) -> int:
        return len(self.equations.core.g)

    def _group(self, name: str, build=None) -> _Evaluator:
        ev = self._groups.get(name)
        if ev is None:
            eq = self.equations
            exprs, extra, shapes = _group(eq, name) if build is None else build()
            args = [eq.core.t, *eq.core.q, *eq.core.qd, *(se.Symbol(s.name) for s in eq.inputs),
                    *(se.Symbol(s.name) for s in eq.parameters), *extra]
            fun = None
            if exprs and build is None and name in _SHARED_GROUPS:
                fun = _shared_function(eq, exprs)
            if fun is None and exprs:
                fun = _evaluator_of(args, exprs)
            ev = self._groups.setdefault(name, _Evaluator(fun, tuple(shapes)))
        return ev

    def _at(self, name: str, t, x, u, p, extra=()) -> list[np.ndarray]:
        args = np.concatenate(([t], np.asarray(x, float).ravel(), np.asarray(u, float).ravel(),
                               np.asarray(p, float).ravel(), np.asarray(extra, float).ravel()))
        return self._group(name)(args)

    def function(self, name: str, build) -> Callable[..., np.ndarray]:
        """``(t, x, u, p) -> array``: other expressions of the model's symbols evaluated in the same
        argument order, by the same evaluator, kept with the model under `name` (``build()`` gives
        them, SymPy or SymEngine, on first use): positions, heights, outputs. Vectorised over the
        rows of a run: with `t` of shape (N,), `x` (N, 2n) and `u` (N, k), it returns shape (N, r)."""
        def make():
            exprs = [se.sympify(e) for e in build()]
            return exprs, [], [(len(exprs),)]

        ev = self._group(f"function {name}", make)

        def evaluate(t, x, u, p):
            if np.ndim(t) == 0:
                return self._at(f"function {name}", t, x, u, p)[0]
            t = np.asarray(t, float)
            rows = len(t)
            if ev.fun is None or rows == 0:
                return np.zeros((rows, *ev.shapes[0]))
            args = np.column_stack((t, np.reshape(np.asarray(x, float), (rows, -1)),
                                    np.reshape(np.asarray(u, float), (rows, -1)),
                                    np.broadcast_to(np.asarray(p, float).ravel(), (rows, np.size(p)))))
            return np.asarray(ev.fun(args), dtype=float).reshape(rows, -1)

        return evaluate

    def _evaluate(self, t, x, u, p):
        return self._at("dynamics", t, x, u, p)

    def mass_matrix(self, t, x, u, p) -> np.ndarray:
        """M at the state, shape (n, n)."""
        return self._evaluate(t, x, u, p)[0]

    def forcing(self, t, x, u, p) -> np.ndarray:
        """f at the state, shape (n,)."""
        return self._evaluate(t, x, u, p)[1]

    def solve(self, t, x, u, p) -> tuple[np.ndarray, float]:
        """(q_ddot, ratio): q_ddot solves M q_ddot = f and ratio is the inertia measure of M; with
        constraints, q_ddot is the saddle-point system's ``[M G^T; G 0] [q_ddot; -lambda] = [f; c]``
        and ratio min(r_M, rho_G) (numeric._codegen_constrained). Where the ratio is at or below
        SINGULAR_RATIO (a singular M, or dependent constraints), q_ddot is NaN; where f is not
        finite, q_ddot is NaN and ratio is NOT_FINITE (-1.0). As the compiled backends."""
        n = self.n
        if self.m:  # the saddle-point algorithm (numeric._constrained), its measure min(r_M, rho_G)
            from ._constrained import ConstraintSingular, constrained_model

            cm = constrained_model(self.equations, self)
            x, u, p = (np.asarray(v, float) for v in (x, u, p))
            try:
                qdd = cm.solve(t, x, u, p)[0]
            except ConstraintSingular as exc:
                return np.full(n, np.nan), float(exc.ratio)
            return qdd, float(min(cm.measures(t, x, u, p)))
        M, f = self._evaluate(t, x, u, p)
        factor = scaled_cholesky(M)
        measure = inertia_measure(M, factor)
        if measure <= SINGULAR_RATIO:
            return np.full(n, np.nan), measure
        if not np.all(np.isfinite(f)):
            return np.full(n, np.nan), NOT_FINITE
        s, Lc = factor
        y = np.linalg.solve(Lc, f * s)
        return np.linalg.solve(Lc.T, y) * s, measure

    def accelerations(self, t, x, u, p) -> np.ndarray:
        """q_ddot, shape (n,): of M q_ddot = f, or of the saddle-point system
        ``[M G^T; G 0] [q_ddot; -lambda] = [f; c]`` for a constrained model, as the compiled backends
        give it (NaN where ``solve`` fails)."""
        return self.solve(t, x, u, p)[0]

    def rhs(self, t, x, u, p) -> np.ndarray:
        """x' = [q_dot, q_ddot], shape (2n,)."""
        x = np.asarray(x, float)
        return np.concatenate((x[self.n:], self.accelerations(t, x, u, p)))

    def singular_ratio(self, t, x, u, p) -> float:
        """inertia_measure(M) at the state: 1 for a diagonal M, 0 for a singular one."""
        return inertia_measure(self.mass_matrix(t, x, u, p))

    def energy(self, t, x, u, p) -> float:
        """The Jacobi integral h = q_dot . dL/dq_dot - L (the energy T* + V when T* = T2)."""
        return float(self._at("energy", t, x, u, p)[0])

    def constraint_parts(self, t, x, u, p) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(G, c, g, w), shapes (m, n), (m,), (m,), (m,) (empty without constraints): see
        :meth:`NumericContract.constraint_parts`."""
        G, g, w = self._at("constraints", t, x, u, p)
        return G, self._at("bias", t, x, u, p)[0], g, w

    def constraint_residuals(self, t, x, u, p) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(G, g, w): ``constraint_parts`` without c, for the searches and projections that need no
        acceleration (one evaluation of the smaller expressions)."""
        return tuple(self._at("constraints", t, x, u, p))

    def jacobians(self, t, x, u, p, qdd=None) -> dict[str, np.ndarray]:
        """{"M", "f", "fq", "fqd", "fu", "Maq"}: M, f, df/dq, df/dq_dot, df/du and d(M a)/dq at
        a = qdd (zeros when qdd is None)."""
        a = np.zeros(self.n) if qdd is None else qdd
        return dict(zip(("M", "f", "fq", "fqd", "fu", "Maq"), self._at("jacobians", t, x, u, p, a)))

    def state_jacobians(self, t, x, u, p) -> tuple[np.ndarray, np.ndarray]:
        """(A, B) = (d rhs/dx, d rhs/du), shapes (2n, 2n), (2n, k), at any state (not only at rest):
        q_ddot = M^-1 f, so d q_ddot = M^-1 (df - dM q_ddot).

        Raises
        ------
        ModelError
            For a constrained model, whose state moves on the constraints (x' = rhs holds only on
            g = 0, w = 0): its linearization is in independent coordinates, ``lagrangian.linearize``.
        """
        if self.m:
            raise ModelError(f"{self.equations.model.name} has {self.m} constraint{'s' if self.m > 1 else ''}: its "
                             "state moves on the constraints g = 0, G q_dot + b = 0, so d rhs/dx in all 2n state "
                             "variables is not its linearization; use lagrangian.linearize(equations, at=...), "
                             "which linearizes in independent coordinates")
        n, k = self.n, len(self.input_names)
        qdd, ratio = self.solve(t, x, u, p)
        if not ratio > SINGULAR_RATIO:
            nan = np.full((2 * n, 2 * n), np.nan)
            return nan, np.full((2 * n, k), np.nan)
        d = self.jacobians(t, x, u, p, qdd)
        Minv = np.linalg.inv(d["M"])
        A = np.zeros((2 * n, 2 * n))
        A[:n, n:] = np.eye(n)
        A[n:, :n] = Minv @ (d["fq"] - d["Maq"])
        A[n:, n:] = Minv @ d["fqd"]
        B = np.zeros((2 * n, k))
        B[n:] = Minv @ d["fu"]
        return A, B

    def momenta(self, t, x, u, p) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(p, dp/dq, M) with p = dL/dq_dot, the generalized momenta: shapes (n,), (n, n), (n, n)
        (M = dp/dq_dot)."""
        return tuple(self._at("momenta", t, x, u, p))

    def damping(self, t, x, u, p) -> np.ndarray:
        """The damping matrix at the state, shape (n, n): the symmetric part of d2D/dq_dot2 - dQ/dq_dot,
        the velocity-dependent forces that take power from the motion (or give it: a negative
        damping). The other velocity terms of -df/dq_dot (gyroscopic, Coriolis, those of the
        constraint forces) are not damping. Zeros without a Rayleigh function or velocity-dependent
        forces."""
        return self._at("damping", t, x, u, p)[0]

    def static(self, t, q, u, p) -> tuple[np.ndarray, np.ndarray]:
        """(f, df/dq) at rest (q_dot = 0) in the configuration q: shapes (n,), (n, n)."""
        q = np.asarray(q, float)
        return tuple(self._at("static", t, np.concatenate((q, np.zeros(self.n))), u, p))

    def statics(self, t, z, u, p) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(F = f + G^T lambda, g, dF/dq, G) at rest in z = (q, lambda): shapes (n,), (m,), (n, n), (m, n)."""
        n = self.n
        z = np.asarray(z, float)
        return tuple(self._at("statics", t, np.concatenate((z[:n], np.zeros(n))), u, p, z[n:]))


def compile(equations: Equations, backend: str = "auto"):
    """The numerical state equations of `equations`, x' = f(t, x, u, p), by the fastest backend.

    Parameters
    ----------
    equations : Equations
    backend : {"auto", "numba", "c", "scipy"}
        "auto" (default): numba's compiled code (:class:`~lagrangian.numeric.CompiledModel`; C's for a
        large model where cffi and a C compiler are present, see :func:`auto_backend`), or
        the portable :class:`NumericModel` for a model whose expressions numba cannot be given and for a
        large model without a C compiler;
        the others as :func:`compile_equations` (every backend gives the same numbers, constrained
        models included).

    Returns
    -------
    CompiledModel or NumericModel
        Either implements :class:`NumericContract`: ``rhs``, ``mass_matrix``, ``forcing``, ``solve``,
        ``accelerations``, ``energy``, the constraint parts and the Jacobians, all in the argument
        order (t, x, u, p). :func:`simulate` runs a CompiledModel's integration compiled.
    """
    if not isinstance(equations, Equations):
        raise TypeError(f"compile() expects Equations (lagrangian.derive(model)), got {type(equations).__name__}")
    if not isinstance(backend, str):
        raise ModelError(f"backend must be one of auto, numba, c, scipy (text), got {type(backend).__name__}")
    if backend == "auto":
        from ._codegen import Unsupported

        try:
            return compile_equations(equations, "auto")
        except Unsupported:
            return compile_equations(equations, "scipy")
    return compile_equations(equations, backend)


def compile_equations(equations: Equations, backend: str = "scipy"):
    """The numerical state equations of `equations` (cached per Equations object).

    Parameters
    ----------
    equations : Equations
    backend : {"scipy", "numba", "c", "auto"}
        "scipy" (default): a :class:`NumericModel` evaluated by SymEngine and NumPy (portable).
        "auto": "numba", or for a large model "c", or "scipy" where there is no C compiler (:func:`auto_backend`).
        :func:`compile`, the public one, takes the fastest by default.
        "numba": a :class:`~lagrangian.numeric.CompiledModel` of generated code compiled by
        numba; "c": the same with the model's functions in C (cffi and a C compiler needed).
        Every backend gives the same numbers; the compiled ones also run the compiled
        integrators (see :func:`simulate`).
    """
    if backend == "auto":
        backend = auto_backend(equations)
    if backend != "scipy":
        from ._fast import BACKENDS, compile_c, compile_numba

        if backend == "numba":
            return compile_numba(equations)
        if backend == "c":
            return compile_c(equations)
        raise ModelError(f"unknown backend '{backend}'; choose one of {', '.join(BACKENDS[1:])}")
    return cached(equations, "scipy", lambda: _numeric_model(equations))


def auto_backend(equations: Equations) -> str:
    """The compiled backend "auto" takes for `equations`: "c" for a large model (M and f past 1e7 nodes written out
    as trees: spatial chains of 5 rods and more, see :func:`~lagrangian.numeric._codegen.large_model`) where cffi
    and a C compiler are present, "scipy" for a large model without them, else "numba". numba's compile of such a
    model grows faster than linearly with its functions' size (the 8-rod chain 165 s, 12 rods past 15 min); the C
    backend writes it as small helpers (about 10 s of gcc at 8 rods); the SciPy backend runs its shared statements
    as Python (the 20-rod chain's 1 s in about 8 s) where numba would compile for hours. The trajectory's
    ``stats["backend"]`` says which ran."""
    from ._cbackend import c_compiler
    from ._codegen import large_model

    def decide():
        if not large_model(equations):
            return "numba"
        if c_compiler() is None:
            return "scipy"
        try:
            import cffi  # noqa: F401
        except ImportError:
            return "scipy"
        return "c"

    return cached(equations, "auto-backend", decide)


def _numeric_model(equations: Equations) -> NumericModel:
    values = np.array([np.nan if v is None else v for v in equations.parameters.values()], dtype=float)
    return NumericModel(equations, equations.state_names, tuple(u.name for u in equations.inputs),
                        tuple(p.name for p in equations.parameters), values)
