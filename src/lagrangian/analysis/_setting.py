"""The fixed values an analysis works at (parameters, constant inputs, time) and the numerical
derivatives of the forcing that every analysis shares.

With M(q, t) q_ddot = f(q, q_dot, t, u), an analysis needs f and its Jacobians with respect to q,
q_dot and u, evaluated at points; they are differentiated once in SymEngine and evaluated with
Lambdify (common subexpressions shared), cached per Equations object.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass
from types import MappingProxyType
from typing import Mapping

import numpy as np
import symengine as se

from ..equations import Equations
from .._util import named_values, real_number
from ..errors import ModelError, Problem

__all__ = ["Setting", "resolve_setting", "collect_setting", "derivatives"]


@dataclass(frozen=True)
class Setting:
    """Parameter values, constant input values and the time at which an analysis is done.

    `parameters` and `inputs` map names to floats, in the model's order."""

    parameters: Mapping[str, float]
    inputs: Mapping[str, float]
    t: float = 0.0

    @property
    def p(self) -> np.ndarray:
        return np.array(list(self.parameters.values()), dtype=float)

    @property
    def u(self) -> np.ndarray:
        return np.array(list(self.inputs.values()), dtype=float)

    def with_parameter(self, name: str, value: float) -> "Setting":
        return Setting(MappingProxyType({**self.parameters, name: float(value)}), self.inputs, self.t)


def resolve_setting(equations: Equations, params: Mapping | None = None, inputs: Mapping | None = None,
                    t: float = 0.0, *, free: tuple[str, ...] = ()) -> Setting:
    """Check and complete the values: parameters default to the model's, inputs to 0.

    `free` names parameters that need no value (a swept parameter). Every problem is reported at
    once as a :class:`ModelError`."""
    if not isinstance(equations, Equations):
        raise TypeError(f"expected Equations (lagrangian.derive(model)), got {type(equations).__name__}")
    problems: list[Problem] = []
    pnames = tuple(p.name for p in equations.parameters)
    unames = tuple(u.name for u in equations.inputs)
    given_p = named_values(params, pnames, "a parameter of the model", "params", problems)
    given_u = named_values(inputs, unames, "an input of the model", "inputs", problems)
    values: dict[str, float] = {}
    for sym, default in equations.parameters.items():
        v = given_p.get(sym.name, default)
        if v is None and sym.name not in free:
            if f"params.{sym.name}" not in {p.key for p in problems}:
                problems.append(Problem(f"parameter '{sym.name}' has no value: give one in the model or pass "
                                        f"params={{'{sym.name}': ...}} (--param {sym.name}=... on the command "
                                        "line)", key=f"params.{sym.name}"))
            continue
        values[sym.name] = float("nan") if v is None else float(v)
    if real_number(t) is None:
        problems.append(Problem(f"the time t must be a finite number, got {t!r}", key="t"))
    if problems:
        raise ModelError(problems)
    return Setting(MappingProxyType(values), MappingProxyType({u: given_u.get(u, 0.0) for u in unames}), float(t))


def collect_setting(equations: Equations, params: Mapping | None, inputs: Mapping | None, t: float,
                    problems: list[Problem]) -> Setting | None:
    """resolve_setting() that adds its problems to `problems` (to be reported with others at once)."""
    try:
        return resolve_setting(equations, params, inputs, t)
    except ModelError as exc:
        problems.extend(exc.problems)
        return None


class Derivatives:
    """Numerical f, M and Jacobians of f at (q, q_dot, t, u, p) for one Equations object."""

    def __init__(self, equations: Equations):
        core = equations.core
        n = equations.n
        self.n, self.m = n, len(equations.inputs)
        q, qd, t = list(core.q), list(core.qd), core.t
        u = [se.Symbol(s.name) for s in equations.inputs]
        p = [se.Symbol(s.name) for s in equations.parameters]
        a = [se.Symbol(f"_a{i}") for i in range(n)]  # placeholder accelerations for d(M a)/dq
        self._args = [*q, *qd, t, *u, *p]
        f = list(core.f)
        M = [core.M[i, j] for i in range(n) for j in range(n)]
        fq = [fi.diff(qj) for fi in f for qj in q]
        fqd = [fi.diff(vj) for fi in f for vj in qd]
        fu = [fi.diff(uj) for fi in f for uj in u]
        Ma = [sum((core.M[i, j] * a[j] for j in range(n)), se.Integer(0)) for i in range(n)]
        Maq = [e.diff(qj) for e in Ma for qj in q]
        self._full = se.Lambdify(self._args + a, M + f + fq + fqd + fu + Maq, cse=True, real=True)
        self._core = core
        self._static_parts = None
        self._momenta = None
        self._damping = None

    def momenta(self, q, qd, t, u, p) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(p, dp/dq, M) with p = dL/dq_dot, the generalized momenta: shapes (n,), (n, n), (n, n)
        (M = dp/dq_dot). Built on first use (steady motions need it)."""
        n = self.n
        if self._momenta is None:
            core = self._core
            mom = list(core.p)
            self._momenta = se.Lambdify(self._args, mom + [e.diff(qj) for e in mom for qj in core.q]
                                        + [core.M[i, j] for i in range(n) for j in range(n)], cse=True, real=True)
        out = np.asarray(self._momenta(self._argv(q, qd, t, u, p)), dtype=float).ravel()
        return out[:n], out[n:n + n * n].reshape(n, n), out[n + n * n:].reshape(n, n)

    def damping(self, q, qd, t, u, p) -> np.ndarray:
        """The damping matrix at the state, shape (n, n): the symmetric part of
        d2D/dq_dot2 - dQ/dq_dot, the velocity-dependent forces that take power from the motion (or
        give it: a negative damping). The other velocity terms of -df/dq_dot (gyroscopic, Coriolis,
        those of the constraint forces) are not damping. Built on first use; zeros without a
        Rayleigh function or velocity-dependent forces."""
        n = self.n
        if self._damping is None:
            core = self._core
            qd_ = list(core.qd)
            Q = list(core.Q) or [se.Integer(0)] * n
            entries = [core.D.diff(qd_[i]).diff(qd_[j]) - (Q[i].diff(qd_[j]) + Q[j].diff(qd_[i])) / 2
                       for i in range(n) for j in range(n)]
            entries = [se.expand(e) for e in entries]
            self._damping = (se.Lambdify(self._args, entries, cse=True, real=True)
                             if any(e != 0 for e in entries) else False)
        if self._damping is False:
            return np.zeros((n, n))
        return np.asarray(self._damping(self._argv(q, qd, t, u, p)), dtype=float).reshape(n, n)

    def _argv(self, q, qd, t, u, p, extra=()):
        return np.concatenate((q, qd, [t], u, p, extra)).astype(float)

    @property
    def static_forcing(self) -> tuple:
        """f at rest (q_dot = 0), SymEngine expressions."""
        return self._static_lambdified()[0]

    def _static_lambdified(self):
        if self._static_parts is None:  # built on first use (linearizing a steady motion needs none)
            core = self._core
            zero = {v: se.Integer(0) for v in core.qd}
            fs = [fi.subs(zero) for fi in core.f]
            fsq = [e.diff(qj) for e in fs for qj in core.q]
            self._static_parts = (tuple(fs), se.Lambdify(self._args, fs + fsq, cse=True, real=True))
        return self._static_parts

    def static(self, q, t, u, p) -> tuple[np.ndarray, np.ndarray]:
        """(f, df/dq) at rest (q_dot = 0): shapes (n,), (n, n)."""
        n = self.n
        out = np.asarray(self._static_lambdified()[1](self._argv(q, np.zeros(n), t, u, p)), dtype=float).ravel()
        return out[:n], out[n:].reshape(n, n)

    def full(self, q, qd, t, u, p, qdd) -> dict[str, np.ndarray]:
        """M, f, df/dq, df/dq_dot, df/du and d(M a)/dq at a = qdd."""
        n, m = self.n, self.m
        out = np.asarray(self._full(self._argv(q, qd, t, u, p, qdd)), dtype=float).ravel()
        sizes = {"M": (n, n), "f": (n,), "fq": (n, n), "fqd": (n, n), "fu": (n, m), "Maq": (n, n)}
        parts, k = {}, 0
        for key, shape in sizes.items():
            size = int(np.prod(shape))
            parts[key] = out[k:k + size].reshape(shape)
            k += size
        return parts


_CACHE: "weakref.WeakKeyDictionary[Equations, Derivatives]" = weakref.WeakKeyDictionary()


def derivatives(equations: Equations) -> Derivatives:
    """The numerical derivatives of `equations` (built once per Equations object)."""
    d = _CACHE.get(equations)
    if d is None:
        d = _CACHE[equations] = Derivatives(equations)
    return d
