"""compile(equations) -> CompiledModel or NumericModel: the numerical state equations x' = f(t, x, u, p),
by the fastest backend (numba) unless another is asked for.

NumericModel is the portable backend: SymEngine's Lambdify with common-subexpression elimination
evaluates M and the forcing in one call, and NumPy solves M q_ddot = f (Cholesky, which also
measures how close M is to singular). Faster backends plug in behind the same interface.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass, field

import numpy as np
import symengine as se

from ..equations import Equations
from ..errors import ModelError
from ..equations._singular import inertia_measure, scaled_cholesky

__all__ = ["NumericModel", "compile", "compile_equations", "SINGULAR_RATIO"]

#: inertia_measure(M) below which the mass matrix counts as singular.
SINGULAR_RATIO = 1e-12

_CACHE: "weakref.WeakKeyDictionary[Equations, NumericModel]" = weakref.WeakKeyDictionary()


class _Singular(Exception):
    def __init__(self, t, x, ratio):
        self.t, self.x, self.ratio = t, x, ratio


class _NotFinite(Exception):
    def __init__(self, t, x):
        self.t, self.x = t, x


@dataclass(frozen=True, eq=False)
class NumericModel:
    """The numerical form of :class:`~lagrangian.equations.Equations`.

    Every function takes ``(t, x, u, p)``: time (float), state ``x = [q, q_dot]`` (shape (2n,),
    in `state_names` order), inputs ``u`` (shape (m,), `input_names` order) and parameters ``p``
    (shape (k,), `parameter_names` order; `parameter_values` holds the model's values, NaN where
    the model gives none).
    """

    equations: Equations = field(repr=False)
    state_names: tuple[str, ...]
    input_names: tuple[str, ...]
    parameter_names: tuple[str, ...]
    parameter_values: np.ndarray = field(repr=False)
    _fun: object = field(repr=False)
    _energy: object = field(repr=False)

    @property
    def n(self) -> int:
        return len(self.state_names) // 2

    def _evaluate(self, t, x, u, p):
        n = self.n
        args = np.concatenate(([t], x, u, p))
        out = np.asarray(self._fun(args), dtype=float).ravel()
        return out[: n * n].reshape(n, n), out[n * n:]

    def mass_matrix(self, t, x, u, p) -> np.ndarray:
        """M at the state, shape (n, n)."""
        return self._evaluate(t, np.asarray(x, float), np.asarray(u, float), np.asarray(p, float))[0]

    def forcing(self, t, x, u, p) -> np.ndarray:
        """f at the state, shape (n,)."""
        return self._evaluate(t, np.asarray(x, float), np.asarray(u, float), np.asarray(p, float))[1]

    def solve(self, t, x, u, p) -> tuple[np.ndarray, float]:
        """(q_ddot, inertia measure of M): q_ddot solves M q_ddot = f.

        Raises :class:`_Singular` where the measure is below SINGULAR_RATIO and
        :class:`_NotFinite` where f is not finite.
        """
        M, f = self._evaluate(t, x, u, p)
        factor = scaled_cholesky(M)
        measure = inertia_measure(M, factor)
        if measure <= SINGULAR_RATIO:
            raise _Singular(t, np.array(x), measure)
        if not np.all(np.isfinite(f)):
            raise _NotFinite(t, np.array(x))
        s, Lc = factor
        y = np.linalg.solve(Lc, f * s)
        return np.linalg.solve(Lc.T, y) * s, measure

    def accelerations(self, t, x, u, p) -> np.ndarray:
        """q_ddot solving M q_ddot = f, shape (n,); for a constrained model the q_ddot of the
        saddle-point system ``[M G^T; G 0] [q_ddot; -lambda] = [f; c]``, as the compiled backends give it."""
        x, u, p = (np.asarray(v, float) for v in (x, u, p))
        if self.equations.is_constrained:
            from ._constrained import constrained_model

            return constrained_model(self.equations, self).solve(t, x, u, p)[0]
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
        return float(self._energy(np.concatenate(([t], np.asarray(x, float), u, p)))[0])


def compile(equations: Equations, backend: str = "auto"):
    """The numerical state equations of `equations`, x' = f(t, x, u, p), by the fastest backend.

    Parameters
    ----------
    equations : Equations
    backend : {"auto", "numba", "c", "scipy"}
        "auto" (default): numba's compiled code (:class:`~lagrangian.numeric.CompiledModel`), or
        the portable :class:`NumericModel` for a model whose expressions numba cannot be given;
        the others as :func:`compile_equations` (every backend gives the same numbers, constrained
        models included).

    Returns
    -------
    CompiledModel or NumericModel
        ``rhs``, ``mass_matrix``, ``forcing``, ``accelerations``, ``energy``, all in the argument
        order (t, x, u, p). :func:`simulate` runs a CompiledModel's integration compiled.
    """
    if backend == "auto":
        from ._codegen import Unsupported

        try:
            return compile_equations(equations, "numba")
        except Unsupported:
            return compile_equations(equations, "scipy")
    return compile_equations(equations, backend)


def compile_equations(equations: Equations, backend: str = "scipy"):
    """The numerical state equations of `equations` (cached per Equations object).

    Parameters
    ----------
    equations : Equations
    backend : {"scipy", "numba", "c"}
        "scipy" (default): a :class:`NumericModel` evaluated by SymEngine and NumPy (portable).
        :func:`compile`, the public one, takes the fastest by default.
        "numba": a :class:`~lagrangian.numeric.CompiledModel` of generated code compiled by
        numba; "c": the same with the model's functions in C (cffi and a C compiler needed).
        Every backend gives the same numbers; the compiled ones also run the compiled
        integrators (see :func:`simulate`).
    """
    if backend != "scipy":
        from ._fast import BACKENDS, compile_c, compile_numba

        if backend == "numba" or backend == "auto":
            return compile_numba(equations)
        if backend == "c":
            return compile_c(equations)
        raise ModelError(f"unknown backend '{backend}'; choose one of {', '.join(BACKENDS[1:])}")
    cached = _CACHE.get(equations)
    if cached is not None:
        return cached
    core = equations.core
    inputs = [se.Symbol(u.name) for u in equations.inputs]
    params = list(equations.parameters)
    args = [core.t, *core.q, *core.qd, *inputs, *[se.Symbol(p.name) for p in params]]
    exprs = [core.M[i, j] for i in range(equations.n) for j in range(equations.n)] + list(core.f)
    fun = se.Lambdify(args, exprs, cse=True, real=True)
    h = sum((v * pi for v, pi in zip(core.qd, core.p)), se.Integer(0)) - core.L
    energy = se.Lambdify(args, [h], cse=True, real=True)
    values = np.array([np.nan if v is None else v for v in equations.parameters.values()], dtype=float)
    nm = NumericModel(equations, equations.state_names, tuple(u.name for u in equations.inputs),
                      tuple(p.name for p in params), values, fun, energy)
    _CACHE[equations] = nm
    return nm
