"""Structural identifiability: which parameters measurements can determine, and in which combinations.

The mathematics, written once here
----------------------------------
With the whole state measured (every coordinate, hence its velocity and acceleration) and the inputs
known, the data determine the acceleration map

    a(q, q_dot, u, t; p) = M(q, t; p)^-1 f(q, q_dot, u, t; p),

not M and f separately: multiplying the equations M q_ddot - f = 0 on the left by any invertible
matrix gives the same motion. For a constrained model the data determine the states that satisfy the
constraints and the accelerations of the saddle-point solve M q_ddot - f - G^T lambda = 0, G q_ddot = c
(the multipliers are not measured). A parameter direction dp is *locally not identifiable* when it
changes none of these to first order, at every state:

* unconstrained: da/dp dp = 0, and since E(q, q_dot, a(p); p) = 0 identically, da/dp = -M^-1 dE/dp at
  q_ddot = a, so the rows of dE/dp = (dM/dp) a - df/dp, stacked over states, have the same null space;
* constrained: N^T (dR/dp) dp = 0 with R = M q_ddot - f - G^T lambda at the solution (N spanning the null
  space of G: a change along G^T is taken up by the multipliers), and the constraints stay satisfied
  on the measured states: dg/dp dp = 0 (holonomic), dw/dp dp = 0 (velocity constraints), d(G q_ddot - c)/dp
  dp = 0.

The rank of that stacked Jacobian over generic states is the number of determined quantities
(`Identifiability.rank`). It is computed in log coordinates (columns times p), where a *scaling
symmetry* p_i -> p_i s^{d_i} (the motion unchanged for every s) is a constant rational null vector d.
How the rank is found, in order:

1. **Exact** (unconstrained models of bounded size): every state variable, input and t takes a random
   rational value, sin and cos of a coordinate (or of t) a rational point of the unit circle (so
   sin^2 + cos^2 = 1 holds exactly), any other function of the state an independent random rational
   (a relaxation that can only raise the rank: the numeric check below catches it); the parameters
   take generic rational values near the model's. The rows are exact rationals (fractions), the rank
   and null space are exact (Gauss-Jordan elimination), states are added until the rank stops rising.
   By the Schwartz-Zippel lemma the generic rank is found with probability one.
2. **Numeric** (always, as the confirmation; the method itself for constrained models, models too large
   for the exact path and parameters inside functions): the same rows in double precision at random real
   states (consistent states for constrained models: coordinates by Gauss-Newton onto g = 0, velocities
   projected onto G q_dot + b = 0), rank by singular values of the column-normalized matrix, counted
   above ``rtol * sigma_max`` (:func:`numeric_rank`; rtol = 1e-8 here, where the derivatives are exact).
3. With only some quantities measured (``measured=["bob.x"]``): the sensitivities of the measured
   outputs along simulated experiments (random initial states, which are unknowns too, and random
   known inputs), by central finite differences of :func:`lagrangian.simulate`, rank as in 2 with
   rtol = 1e-5 (the differences' accuracy). A constrained model's experiments start from its
   [simulation] independent coordinates and their velocities; velocity constraints are refused.

The null space, found at two generic parameter vectors, is then classified: the same rational vectors
in log coordinates at both is a scaling symmetry; the same in the parameters themselves a translation
(p_i -> p_i + s d_i, for parameters that enter only as a sum such as m1 + m2); otherwise the symmetry is
neither (rare) and only the parameters moving along the numeric null directions are named. A parameter
is *identifiable* when no null direction moves it. The *combinations* are a basis of the determined
quantities among the others: integer exponent vectors orthogonal to every scaling direction (monomials
such as ``g/l``, ``c/(l**2*m)``), preferring the ratios of the equations' own terms, or linear forms
orthogonal to every translation (``m1 + m2``). ``rank = len(identifiable) + len(combinations)``.
"""

from __future__ import annotations

import math
import random
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from fractions import Fraction

import numpy as np
import symengine as se
import sympy

from .._util import did_you_mean
from ..equations import Equations, derive
from ..errors import ModelError, Problem
from ..model import Model

__all__ = ["Identifiability", "identifiability", "numeric_rank"]

#: The threshold of the numeric rank where the derivatives are exact (analytic rows, round-off only).
ANALYTIC_RTOL = 1e-8
#: The threshold of the numeric rank of finite-difference sensitivities of simulations.
SENSITIVITY_RTOL = 1e-5
#: The exact path is taken when the derivative expressions are at most this many characters long in
#: all (a bound on the work of exact rational arithmetic), the model has at most EXACT_MAX_N coordinates
#: and at most EXACT_MAX_PARAMS parameters are asked about; past them the numeric path is the method.
EXACT_MAX_CHARS = 200_000
EXACT_MAX_N = 8
EXACT_MAX_PARAMS = 24
#: The most random states of the numeric path.
MAX_FLOAT_STATES = 400
#: The most parameters one call may ask about.
MAX_PARAMS = 200
#: Exponents and weights of a null direction are recognized as fractions of denominator at most this.
MAX_DENOMINATOR = 24
#: The most terms of the expanded equations searched for readable combinations (c/m: a ratio of terms).
MAX_CANDIDATE_TERMS = 5_000

SCALING, TRANSLATION, OTHER, NONE = "scaling", "translation", "other", "none"


# ------------------------------------------------------------------------------------ the result
@dataclass(frozen=True)
class Identifiability:
    """Which parameters the measurements determine (returned by :func:`identifiability`).

    Attributes
    ----------
    parameters : tuple of str
        The parameters asked about, in the order given (the others are known, at the model's values).
    identifiable : tuple of str
        Those the data determine, each on its own.
    not_identifiable : tuple of str
        Those they do not: a fit must not report a number for them alone.
    combinations : tuple of sympy.Expr
        A basis of what the data do determine among the not identifiable parameters: monomials such
        as ``g/l`` and ``c/(l**2*m)`` (scaling symmetries) or sums such as ``m1 + m2`` (translations).
    rank : int
        The number of independent quantities determined: len(identifiable) + len(combinations) (where
        the symmetry is a scaling or a translation).
    reasons : dict of str to str
        For each not identifiable parameter, why, in words.
    symmetry : str
        "none" (all identifiable), "scaling", "translation" or "other".
    null_directions : tuple of dict of str to float
        A basis of the parameter changes that leave the data unchanged: for a scaling, the exponents d
        (p -> p * s**d); for a translation, the weights (p -> p + s*d); else the numeric directions of
        the relative changes dp/p.
    method : str
        How the rank was found, and how it was confirmed, in words.
    singular_values : tuple of float
        The numeric confirmation's singular values (columns normalized, largest first).
    threshold : float
        The relative threshold they are counted above.
    measured : tuple of str or None
        The measured quantities (None: the whole state).
    """

    parameters: tuple[str, ...]
    identifiable: tuple[str, ...]
    not_identifiable: tuple[str, ...]
    combinations: tuple[sympy.Expr, ...]
    rank: int
    reasons: Mapping[str, str]
    symmetry: str
    null_directions: tuple[Mapping[str, float], ...]
    method: str
    singular_values: tuple[float, ...] = ()
    threshold: float = ANALYTIC_RTOL
    measured: tuple[str, ...] | None = None
    model_name: str = field(default="", repr=False)

    @property
    def all_identifiable(self) -> bool:
        """True when every parameter asked about is determined."""
        return not self.not_identifiable

    def text(self) -> str:
        """A plain-text account, as the command line prints it."""
        what = "the whole state" if self.measured is None else ", ".join(self.measured)
        lines = [f"Identifiability of {', '.join(self.parameters)}"
                 + (f" (model '{self.model_name}')" if self.model_name else "")
                 + f": {what} measured, inputs known",
                 f"  rank {self.rank} of {len(self.parameters)}"]
        if self.identifiable:
            lines.append("  determined: " + ", ".join(self.identifiable))
        if self.combinations:
            lines.append("  determined only in combination: " + ", ".join(str(c) for c in self.combinations))
        if self.not_identifiable:
            lines.append("  not determined alone (a fit reports no value for them): "
                         + ", ".join(self.not_identifiable))
            for name in self.not_identifiable:
                lines.append(f"    {name}: {self.reasons[name]}")
        lines.append("  method: " + self.method)
        return "\n".join(lines)

    def __str__(self) -> str:
        return self.text()

    def to_dict(self) -> dict:
        """JSON-safe: names, strings of the combinations, numbers."""
        return {
            "parameters": list(self.parameters),
            "measured": None if self.measured is None else list(self.measured),
            "identifiable": list(self.identifiable),
            "not_identifiable": list(self.not_identifiable),
            "combinations": [str(c) for c in self.combinations],
            "rank": int(self.rank),
            "reasons": dict(self.reasons),
            "symmetry": self.symmetry,
            "null_directions": [{k: float(v) for k, v in d.items()} for d in self.null_directions],
            "method": self.method,
            "singular_values": [float(s) for s in self.singular_values],
            "threshold": float(self.threshold),
        }


# ------------------------------------------------------------------------------- numeric rank
def numeric_rank(S, names: Sequence[str], rtol: float = 1e-6) -> tuple[int, tuple[dict[str, float], ...]]:
    """The rank of a sensitivity matrix and the parameter directions it does not see.

    Parameters
    ----------
    S : array_like, shape (rows, P)
        Sensitivities, one column per parameter (the derivative of every residual or measured value
        with respect to that parameter).
    names : sequence of str, length P
        The parameters' names, in column order.
    rtol : float
        The threshold: the columns are scaled to unit length (so that units do not matter), and the
        singular values above ``rtol * sigma_max`` are counted. 1e-6 suits sensitivities by finite
        differences of accurate simulations; 1e-8 exact derivatives in double precision.

    Returns
    -------
    rank : int
    null_directions : tuple of dict of str to float
        A basis of the null space in the columns' own coordinates (a change dp of the parameters that
        leaves S dp = 0), in reduced echelon form (each direction 1 at its own leading parameter),
        entries at the noise level (below ``max(1e-9, 100 * rtol)`` of the direction's largest, columns
        normalized) dropped: ``({"m": 1.0, "c": 1.0},)`` when m and c trade off.
    """
    names = tuple(names)
    S = np.asarray(S, dtype=float)
    if S.ndim != 2 or S.shape[1] != len(names):
        raise ModelError(f"numeric_rank: S must be a matrix with one column per name, shape (rows, {len(names)}); "
                         f"got shape {S.shape}; pass the sensitivities as S[:, j] = dy/d{names[0] if names else 'p'}")
    if not np.all(np.isfinite(S)):
        raise ModelError("numeric_rank: S has entries that are not finite (NaN or infinite): the sensitivities "
                         "must be finite numbers; check the simulation they came from")
    if not (isinstance(rtol, (int, float)) and math.isfinite(rtol) and 0 < rtol < 1):
        raise ModelError(f"numeric_rank: rtol must be a number between 0 and 1, got {rtol!r}; for example rtol=1e-6")
    rank, null, _ = _svd_rank(S, rtol)
    return rank, tuple({n: float(v) for n, v in zip(names, row) if abs(v) > 1e-9} for row in null)


def _svd_rank(S: np.ndarray, rtol: float) -> tuple[int, np.ndarray, np.ndarray]:
    """(rank, null basis in the columns' coordinates (k, P) in reduced echelon form, singular values)
    of S with the columns normalized."""
    P = S.shape[1]
    if S.shape[0] == 0 or P == 0:
        return 0, np.eye(P), np.zeros(0)
    S, scale = _normalized(S, rtol)
    _, s, vt = np.linalg.svd(S, full_matrices=True)
    sigma = np.zeros(P)
    sigma[:len(s)] = s[:P]
    top = sigma[0] if len(sigma) else 0.0
    rank = int(np.sum(sigma > rtol * top)) if top > 0 else 0
    null = vt[rank:]
    # entries at the noise level of the null vectors (round-off, or the differences' error) are zero
    null = np.where(np.abs(null) > max(1e-9, 100 * rtol) * np.max(np.abs(null), axis=1, initial=0.0)[:, None],
                    null, 0.0)
    return rank, _rref_float(null / scale), sigma  # back to the columns' own coordinates


def _normalized(S: np.ndarray, rtol: float) -> tuple[np.ndarray, np.ndarray]:
    """(S with unit columns, the columns' norms): a column at round-off next to the largest (norm at
    most rtol times it) is a zero column, since normalizing it would make noise a direction."""
    norms = np.linalg.norm(S, axis=0)
    S = np.where(norms > rtol * np.max(norms, initial=0.0), S, 0.0)
    norms = np.linalg.norm(S, axis=0)
    scale = np.where(norms > 0, norms, 1.0)
    return S / scale, scale


def _rref_float(A: np.ndarray) -> np.ndarray:
    """Reduced row echelon form of the rows of A (partial pivoting), each row 1 at its pivot."""
    A = np.array(A, float)
    k, P = A.shape
    row = 0
    for col in range(P):
        if row >= k:
            break
        piv = row + int(np.argmax(np.abs(A[row:, col])))
        if abs(A[piv, col]) < 1e-9 * max(1.0, np.max(np.abs(A))):
            continue
        A[[row, piv]] = A[[piv, row]]
        A[row] /= A[row, col]
        for r in range(k):
            if r != row:
                A[r] -= A[r, col] * A[row]
        row += 1
    A[np.abs(A) < 1e-12] = 0.0
    return A[:row]


# ------------------------------------------------------------------------ exact linear algebra
def _rref(rows: list[list[Fraction]], ncols: int) -> tuple[list[list[Fraction]], list[int]]:
    """Reduced row echelon form (exact), and the pivot columns."""
    A = [list(r) for r in rows]
    pivots: list[int] = []
    r = 0
    for c in range(ncols):
        piv = next((i for i in range(r, len(A)) if A[i][c] != 0), None)
        if piv is None:
            continue
        A[r], A[piv] = A[piv], A[r]
        inv = 1 / A[r][c]
        A[r] = [x * inv for x in A[r]]
        for i in range(len(A)):
            if i != r and A[i][c] != 0:
                f = A[i][c]
                A[i] = [x - f * y for x, y in zip(A[i], A[r])]
        pivots.append(c)
        r += 1
        if r == len(A):
            break
    return A[:r], pivots


def _nullspace(rows: list[list[Fraction]], ncols: int) -> list[list[Fraction]]:
    """An exact basis of {x: A x = 0}, in reduced echelon form."""
    R, pivots = _rref(rows, ncols)
    free = [c for c in range(ncols) if c not in pivots]
    basis = []
    for fcol in free:
        v = [Fraction(0)] * ncols
        v[fcol] = Fraction(1)
        for i, pc in enumerate(pivots):
            v[pc] = -R[i][fcol]
        basis.append(v)
    return _rref(basis, ncols)[0] if basis else []


def _integer(v: Sequence[Fraction]) -> list[int]:
    """The primitive integer vector along v."""
    den = 1
    for x in v:
        den = den * Fraction(x).denominator // math.gcd(den, Fraction(x).denominator)
    ints = [int(Fraction(x) * den) for x in v]
    g = 0
    for x in ints:
        g = math.gcd(g, abs(x))
    return [x // g for x in ints] if g else ints


def _recognize(null: np.ndarray, check) -> list[list[Fraction]] | None:
    """The float null basis (rows, in echelon form) as fractions of small denominator, when the
    fractions are still null vectors (check(v) says so); else None."""
    out = []
    for row in null:
        v = [Fraction(float(x)).limit_denominator(MAX_DENOMINATOR) for x in row]
        if not check(np.array([float(x) for x in v])):
            return None
        out.append(v)
    return out


# ------------------------------------------------------------------------------ the front door
def identifiability(equations, params, measured=None) -> Identifiability:
    """Which of the parameters `params` measurements determine, and in which combinations.

    Parameters
    ----------
    equations : Equations or Model
        The model's equations (a Model is derived first).
    params : sequence of str, or str "m,l,c"
        The parameters to be determined; every other parameter is known, at the model's value.
    measured : sequence of str, optional
        What is measured: coordinates, velocities, named outputs or ``"<point>.x"`` components. None
        (default) or every coordinate: the whole state (velocities and accelerations follow).

    Returns
    -------
    Identifiability
        See its attributes; the module docstring gives the mathematics and the methods.

    Examples
    --------
    >>> import lagrangian as lg
    >>> m = lg.Model(coordinates=["th"], T="m*l**2*th_dot**2/2", V="-m*g*l*cos(th)",
    ...              D="c*th_dot**2/2", parameters={"m": 1, "l": 1, "g": 9.81, "c": 0.1})
    >>> r = lg.identifiability(lg.derive(m), ["m", "l", "g", "c"])
    >>> r.combinations
    (g/l, c/(l**2*m))
    """
    if isinstance(equations, Model):
        equations = derive(equations)
    if not isinstance(equations, Equations):
        raise ModelError(f"identifiability: equations must be the Equations of a model (lagrangian.derive(model)) "
                         f"or a Model, got {type(equations).__name__}")
    names = _check_params(equations, params)
    problem = _Problem(equations, names, _check_measured(equations, measured))
    return problem.solve()


def _check_params(eq: Equations, params) -> tuple[str, ...]:
    known = [p.name for p in eq.parameters]
    if isinstance(params, str):
        params = [s.strip() for s in params.split(",")] if params.strip() else []
    if isinstance(params, (sympy.Symbol, se.Symbol)):
        params = [params]
    if params is None or not isinstance(params, (list, tuple)):
        raise ModelError(f"identifiability: params must be a list of parameter names, got {params!r}; "
                         f"for example params={known[:3]!r}")
    problems, seen, names = [], set(), []
    if not params:
        problems.append(Problem("params is empty: name the parameters to be determined, for example "
                                f"params={known[:3]!r} (the model's parameters: {', '.join(known) or 'none'})",
                                key="params"))
    if len(params) > MAX_PARAMS:
        problems.append(Problem(f"params names {len(params)} parameters, more than {MAX_PARAMS}", key="params"))
    for p in params:
        name = getattr(p, "name", p)
        if not isinstance(name, str):
            problems.append(Problem(f"a parameter name must be a string, got {p!r}", key="params"))
            continue
        if name in seen:
            problems.append(Problem(f"parameter '{name}' is named twice: name each parameter once", key="params"))
            continue
        seen.add(name)
        if name not in known:
            shown = name if len(name) <= 60 and name.isprintable() else repr(name[:60]) + "..."
            problems.append(Problem(f"'{shown}' is not a parameter of model '{eq.model.name}'"
                                    f"{did_you_mean(name, known)}; its parameters are: {', '.join(known) or 'none'}",
                                    key="params"))
            continue
        names.append(name)
    values = {p.name: v for p, v in eq.parameters.items()}
    for k in known:
        if k not in seen and not _finite(values.get(k)):
            problems.append(Problem(f"parameter '{k}' is known (not in params) but has no finite value "
                                    f"({values.get(k)!r}): give it a value in the model, or add it to params",
                                    key=f"parameters.{k}"))
    if problems:
        raise ModelError(problems)
    return tuple(names)


def _finite(v) -> bool:
    try:
        return v is not None and math.isfinite(float(v))
    except (TypeError, ValueError):
        return False


def _check_measured(eq: Equations, measured) -> tuple[tuple[str, ...], list] | None:
    """None for the whole state; else the names and their SymEngine expressions."""
    if measured is None:
        return None
    if isinstance(measured, str):
        measured = [s.strip() for s in measured.split(",") if s.strip()]
    if not isinstance(measured, (list, tuple)) or not measured:
        raise ModelError(f"identifiability: measured must be a non-empty list of names (coordinates, velocities, "
                         f"outputs, '<point>.x'), or None for the whole state; got {measured!r}")
    model = eq.model
    q = [c.name for c in eq.coordinates]
    v = [c.name for c in eq.velocities]
    outputs = dict(getattr(model, "outputs", {}) or {})
    choices = q + v + list(outputs)
    problems, exprs, names = [], [], []
    for name in measured:
        if not isinstance(name, str):
            problems.append(Problem(f"a measured name must be a string, got {name!r}", key="measured"))
            continue
        if name in names:
            problems.append(Problem(f"'{name}' is measured twice: name each quantity once", key="measured"))
            continue
        if name in q or name in v:
            expr = sympy.Symbol(name)
        elif name in outputs:
            expr = outputs[name]
        else:
            try:
                expr = model._point_component(name, "measured")
            except ModelError as error:
                problems.extend(error.problems)
                continue
            if expr is None:
                shown = name if len(name) <= 60 and name.isprintable() else repr(name[:60]) + "..."
                problems.append(Problem(f"'{shown}' is not a coordinate, velocity, output or '<point>.x' of model "
                                        f"'{model.name}'{did_you_mean(name, choices)}; measurable: "
                                        f"{', '.join(choices)}", key="measured"))
                continue
        names.append(name)
        exprs.append(se.sympify(expr))
    if problems:
        raise ModelError(problems)
    if set(q) <= set(names) or (set(q) | set(v)) <= set(names):
        return None
    velocity = [c.name for c in model.constraints if c.kind != "holonomic"]
    if velocity:
        raise ModelError(f"identifiability with only some quantities measured ({', '.join(names)}) does not handle "
                         f"velocity constraints yet, and model '{model.name}' has {', '.join(velocity)}: measure every "
                         "coordinate (measured=None), which the analysis of constrained models supports")
    return tuple(names), exprs


# ---------------------------------------------------------------------------------- the problem
class _Problem:
    """The symbolic pieces and the sampling of one identifiability question."""

    def __init__(self, eq: Equations, names: tuple[str, ...], measured):
        self.eq, self.names, self.measured = eq, names, measured
        core = eq.core
        self.n = eq.n
        self.P = len(names)
        self.rng = random.Random(20261126)
        self.nrng = np.random.default_rng(20261126)
        self.q, self.qd, self.t = list(core.q), list(core.qd), core.t
        self.u = [se.Symbol(u.name) for u in eq.inputs]
        self.p_all = [se.Symbol(p.name) for p in eq.parameters]
        self.values = {p.name: v for p, v in eq.parameters.items()}
        self.p = [se.Symbol(n) for n in names]
        self.known = {s: self.values[s.name] for s in self.p_all if s.name not in names}
        self.qdd = [se.Symbol(a.name) for a in eq.accelerations]
        self.lam = [se.Symbol(m.name) for m in eq.multipliers]
        n, m = self.n, len(core.g)
        self.m = m
        self.M = [[core.M[i, j] for j in range(n)] for i in range(n)]
        self.f = list(core.f)
        self.G = [[core.G[k, j] for j in range(n)] for k in range(m)] if m else []
        self.c = list(core.c)
        kinds = [c.kind for c in eq.model.constraints]
        self.hol = [core.g[k] for k, kind in enumerate(kinds) if kind == "holonomic"]
        self.w = list(core.w)
        self.residuals = [sum((self.M[i][j] * self.qdd[j] for j in range(n)), se.Integer(0)) - self.f[i]
                          - sum((self.G[k][i] * self.lam[k] for k in range(m)), se.Integer(0)) for i in range(n)]

    # ------------------------------------------------------------------ parameter values
    def generic_p(self) -> list[Fraction]:
        """Generic values of the parameters asked about: near the model's (within 30 %), rational."""
        out = []
        for name in self.names:
            v = self.values.get(name)
            base = float(v) if _finite(v) and float(v) != 0 else 1.0
            out.append(Fraction(base * (1 + 0.3 * (2 * self.rng.random() - 1))).limit_denominator(997))
        return out

    # ------------------------------------------------------------------------- solve
    def solve(self) -> Identifiability:
        if self.measured is not None:
            return self._solve_measured()
        return self._solve_full()

    def _solve_full(self) -> Identifiability:
        exact_ok, why = self._exact_possible()
        p1, p2 = self.generic_p(), self.generic_p()
        # the numeric confirmation (the method itself for constrained or large models)
        J1 = self._float_rows(p1)
        rank_f, null_f, sigma = _svd_rank(J1, ANALYTIC_RTOL)
        if exact_ok:
            try:
                rows1, relaxed = self._exact_rows(p1)
                rows2 = self._exact_rows(p2)[0]
            except _NotRational as exc:
                exact_ok, why = False, f"an expression holds an irrational constant ({exc})"
        if exact_ok:
            null1 = _nullspace(rows1, self.P)
            rank_e = self.P - len(null1)
            if rank_e != rank_f and relaxed and rank_f < rank_e:
                method = (f"the exact rank {rank_e} (functions {', '.join(relaxed)} taken as independent) is above "
                          f"the numeric rank {rank_f} at real states; the numeric rank is reported")
                return self._finish_numeric(p1, p2, J1, null_f, sigma, ANALYTIC_RTOL, method)
            null2 = _nullspace(rows2, self.P)
            method = ("exact: the rank of the Jacobian of the accelerations with respect to log p, in rational "
                      f"arithmetic at {self._exact_samples} random states and two generic parameter vectors")
            method += (f"; confirmed numerically (singular values above {ANALYTIC_RTOL:g} * the largest: rank {rank_f})"
                       if rank_f == rank_e else
                       f"; the numeric rank at real states is {rank_f} (singular values above {ANALYTIC_RTOL:g} * "
                       "the largest), the exact one is reported")
            return self._finish(p1, p2, null1, null2, sigma, ANALYTIC_RTOL, method)
        method = ("numeric: the rank of the Jacobian of the "
                  + ("saddle-point accelerations and the constraints" if self.m else "accelerations")
                  + f" with respect to log p at {self._float_samples} random "
                  + ("consistent " if self.m else "") + f"states (singular values above {ANALYTIC_RTOL:g} * the "
                  f"largest; exact arithmetic not used: {why})")
        return self._finish_numeric(p1, p2, J1, null_f, sigma, ANALYTIC_RTOL, method)

    def _finish_numeric(self, p1, p2, J1, null_f, sigma, rtol, method):
        J2 = self._float_rows(p2)
        _, null_f2, _ = _svd_rank(J2, rtol)
        rec1 = self._recognize(null_f, J1, rtol)
        rec2 = self._recognize(null_f2, J2, rtol)
        if rec1 is not None and rec2 is not None and len(rec1) == len(null_f) and len(rec2) == len(null_f2):
            return self._finish(p1, p2, rec1, rec2, sigma, rtol, method)
        # not rational in log coordinates: perhaps in the parameters themselves (a translation)
        pv1, pv2 = (np.array([float(x) for x in p]) for p in (p1, p2))
        lin1 = self._recognize(_rref_float(null_f * pv1) if len(null_f) else null_f, J1 / pv1, rtol)
        lin2 = self._recognize(_rref_float(null_f2 * pv2) if len(null_f2) else null_f2, J2 / pv2, rtol)
        if (lin1 and lin2 and len(lin1) == len(null_f) and len(lin2) == len(null_f2)
                and _same_span(lin1, lin2, self.P)):
            return self._build(TRANSLATION, lin1, p1, sigma, rtol, method)
        return self._build(OTHER, [list(r) for r in null_f], p1, sigma, rtol, method, exact=False)

    def _recognize(self, null, J, rtol):
        if len(null) == 0:
            return []
        if J is None:
            return None
        Jn, scale = _normalized(J, rtol)
        top = np.linalg.norm(Jn, 2) if J.size else 1.0

        def check(v):
            return np.linalg.norm(Jn @ (v * scale)) <= 10 * rtol * top * np.linalg.norm(v * scale)

        return _recognize(null, check)

    def _finish(self, p1, p2, null1, null2, sigma, rtol, method) -> Identifiability:
        """Classify the null spaces (exact fractions, log coordinates) at p1 and p2."""
        P = self.P
        if not null1:
            return self._build(NONE, [], p1, sigma, rtol, method)
        if _same_span(null1, null2, P):
            return self._build(SCALING, null1, p1, sigma, rtol, method)
        lin1 = _rref([[x * p for x, p in zip(v, p1)] for v in null1], P)[0]
        lin2 = _rref([[x * p for x, p in zip(v, p2)] for v in null2], P)[0]
        if _same_span(lin1, lin2, P):
            return self._build(TRANSLATION, lin1, p1, sigma, rtol, method)
        return self._build(OTHER, [[float(x) for x in v] for v in null1], p1, sigma, rtol, method, exact=False)

    # ------------------------------------------------------------------- exact rows
    def _exact_possible(self) -> tuple[bool, str]:
        if self.m:
            return False, "the model has constraints (consistent states are not rational)"
        if self.n > EXACT_MAX_N:
            return False, f"more than {EXACT_MAX_N} coordinates"
        if self.P > EXACT_MAX_PARAMS:
            return False, f"more than {EXACT_MAX_PARAMS} parameters asked about"
        self._derivatives()
        size = sum(len(str(e)) for e in self._all_exprs)
        if size > EXACT_MAX_CHARS:
            return False, f"the derivatives are {size:,} characters long, past the bound {EXACT_MAX_CHARS:,}"
        pset = set(self.p)
        for e in self._all_exprs:
            for atom in _atoms(e):
                if set(atom.free_symbols) & pset:
                    return False, f"a parameter asked about is inside {atom}"
        return True, ""

    def _derivatives(self):
        if hasattr(self, "_dM"):
            return
        n = self.n
        self._dM = [[[self.M[i][j].diff(p) for j in range(n)] for i in range(n)] for p in self.p]
        self._df = [[fi.diff(p) for fi in self.f] for p in self.p]
        self._all_exprs = ([e for row in self.M for e in row] + self.f
                           + [e for d in self._dM for row in d for e in row] + [e for d in self._df for e in d])

    def _exact_rows(self, p: list[Fraction]) -> tuple[list[list[Fraction]], list[str]]:
        """Stacked exact rows (log coordinates), adding random states until the rank stops rising."""
        self._derivatives()
        known = {s: se.Rational(*_ratio(Fraction(float(v)).limit_denominator(10**6))) for s, v in self.known.items()}
        pv = {s: se.Rational(x.numerator, x.denominator) for s, x in zip(self.p, p)}
        atoms = set()
        for e in self._all_exprs:
            atoms |= _atoms(e)
        circle_vars = [*self.q, self.t]
        varying = set(self.q + self.qd + self.u + [self.t])
        combos = {a: _integer_combination(a.args[0], circle_vars) for a in atoms if _is_trig(a)}
        # functions of the known parameters alone: one generic value for the whole analysis
        if not hasattr(self, "_fixed_atoms"):
            self._fixed_atoms = {}
        for a in atoms:
            if combos.get(a) is None and not set(a.free_symbols) & varying and a not in self._fixed_atoms:
                self._fixed_atoms[a] = _se(Fraction(self.rng.randint(1, 60), self.rng.randint(1, 13)))
        relaxed = sorted(str(a) for a in atoms if combos.get(a) is None and a not in self._fixed_atoms)
        rows: list[list[Fraction]] = []
        rank, stale, samples = 0, 0, 0
        limit = 3 * self.P + 6
        while samples < limit and stale < 2 and rank < self.P:
            sub = dict(known)
            sub.update(pv)
            sub.update(self._fixed_atoms)
            circle = {}
            for s in circle_vars:
                tau = Fraction(self.rng.randint(-40, 40), self.rng.randint(1, 17))
                circle[s] = ((1 - tau * tau) / (1 + tau * tau), 2 * tau / (1 + tau * tau))  # (cos, sin)
            for a, combo in combos.items():
                if combo is not None:  # sin or cos of an integer combination: exact, from the circle points
                    cos_, sin_ = _circle_power(combo, circle)
                    sub[a] = _se(sin_ if isinstance(a, se.sin) else cos_)
            for a in atoms:
                if a not in sub:
                    sub[a] = _se(Fraction(self.rng.randint(1, 60), self.rng.randint(1, 13)))
            for s in self.q + self.qd + self.u + [self.t]:
                sub[s] = _se(Fraction(self.rng.randint(-60, 60), self.rng.randint(1, 13)))
            M = [[_frac(e.subs(sub)) for e in row] for row in self.M]
            f = [_frac(e.subs(sub)) for e in self.f]
            samples += 1
            a = _solve_exact(M, f)
            if a is None:
                continue
            block = [[Fraction(0)] * self.P for _ in range(self.n)]
            for j in range(self.P):
                dM = [[_frac(e.subs(sub)) for e in row] for row in self._dM[j]]
                df = [_frac(e.subs(sub)) for e in self._df[j]]
                for i in range(self.n):
                    block[i][j] = (sum((dM[i][k] * a[k] for k in range(self.n)), Fraction(0)) - df[i]) * p[j]
            rows = _rref(rows + block, self.P)[0]
            new_rank = len(rows)
            stale = stale + 1 if new_rank == rank else 0
            rank = new_rank
        self._exact_samples = samples
        return rows, relaxed

    # ------------------------------------------------------------------- float rows
    def _float_rows(self, p: list[Fraction]) -> np.ndarray:
        """Stacked float rows (log coordinates) at random (consistent) states."""
        n, m, P = self.n, self.m, self.P
        if not hasattr(self, "_lambdified"):
            args = [self.t, *self.q, *self.qd, *self.u, *self.qdd, *self.lam, *self.p_all]
            out = [e for row in self.M for e in row] + self.f + [e for row in self.G for e in row] + self.c
            for p_ in self.p:
                out += [r.diff(p_) for r in self.residuals]
                out += [e.diff(p_) for e in self.hol] + [e.diff(p_) for e in self.w]
                out += [sum((self.G[k][j].diff(p_) * self.qdd[j] for j in range(n)), se.Integer(0)) - self.c[k].diff(p_)
                        for k in range(m)]
            self._lambdified = se.Lambdify(args, out, cse=True, real=True)
            if m:
                self._hol_f = se.Lambdify([self.t, *self.q, *self.p_all],
                                          self.hol + [h.diff(q) for h in self.hol for q in self.q] or [se.Integer(0)],
                                          cse=True, real=True)
                self._w_f = se.Lambdify([self.t, *self.q, *self.qd, *self.p_all], self.w or [se.Integer(0)],
                                        cse=True, real=True)
        pvals = []
        pmap = dict(zip(self.names, p))
        for s in self.p_all:
            pvals.append(float(pmap[s.name]) if s.name in pmap else float(self.known[s]))
        pvals = np.array(pvals)
        pvec = np.array([float(x) for x in p])
        # the dynamics give n - m rows per state: twice the parameters' count to start with, then more
        # states while the rank still rises (at most MAX_FLOAT_STATES)
        count = max(4, math.ceil(2 * P / max(n - m, 1)) + 3)
        rows, got, tries, rank = [], 0, 0, -1
        initial = self.eq.model.simulation.get("initial") or {}
        while tries < 10 * MAX_FLOAT_STATES:
            if got >= count:
                new_rank = _svd_rank(np.vstack(rows), ANALYTIC_RTOL)[0]
                if new_rank == rank or new_rank == P or got >= MAX_FLOAT_STATES:
                    break
                rank, count = new_rank, got + max(2, count // 2)
            if tries >= 10 * count:
                break
            tries += 1
            t = float(self.nrng.uniform(0, 1))
            q = np.array([float(initial.get(s.name, 0.0)) for s in self.q]) + self.nrng.uniform(-1.5, 1.5, n)
            qd = self.nrng.uniform(-1, 1, n)
            if m:
                state = self._consistent(t, q, qd, pvals)
                if state is None:
                    continue
                q, qd = state
            u = self.nrng.uniform(-1, 1, len(self.u))
            base = np.concatenate(([t], q, qd, u, np.zeros(n + m), pvals))
            out = np.asarray(self._lambdified(base), float).ravel()
            M = out[:n * n].reshape(n, n)
            f = out[n * n:n * n + n]
            G = out[n * n + n:n * n + n + m * n].reshape(m, n)
            c = out[n * n + n + m * n:n * n + n + m * n + m]
            K = np.block([[M, -G.T], [G, np.zeros((m, m))]])
            try:
                sol = np.linalg.solve(K, np.concatenate((f, c)))
            except np.linalg.LinAlgError:
                continue
            if not np.all(np.isfinite(sol)) or np.linalg.cond(K) > 1e10:
                continue
            full = np.concatenate(([t], q, qd, u, sol, pvals))
            out = np.asarray(self._lambdified(full), float).ravel()[n * n + n + m * n + m:]
            cols = out.reshape(P, -1).T  # rows: residuals, hol, w, acceleration constraints
            R = cols[:n]
            if m:
                _, s, vt = np.linalg.svd(G)
                N = vt[int(np.sum(s > 1e-10 * max(s[0], 1e-300))):].T
                R = N.T @ R
            block = np.vstack([R, cols[n:]]) * pvec
            rn = np.linalg.norm(block, axis=1, keepdims=True)
            rows.append(block / np.where(rn > 0, rn, 1.0))
            got += 1
        if not got:
            raise ModelError(f"identifiability: no state of model '{self.eq.model.name}' where the equations can be "
                             "solved (a singular mass matrix or constraints that cannot be met near the model's "
                             "initial state); check the model's [simulation] initial values")
        self._float_samples = self.__dict__.get("_float_samples", got)
        return np.vstack(rows)

    def _consistent(self, t, q, qd, pvals):
        n = self.n
        for _ in range(60):
            out = np.asarray(self._hol_f(np.concatenate(([t], q, pvals))), float).ravel()
            k = len(self.hol)
            if not k:
                break
            g, Gh = out[:k], out[k:].reshape(k, n)
            if not (np.all(np.isfinite(g)) and np.all(np.isfinite(Gh))):
                return None
            if np.max(np.abs(g)) < 1e-13 * (1 + np.max(np.abs(q))):
                break
            try:
                q = q - np.linalg.lstsq(Gh, g, rcond=None)[0]
            except np.linalg.LinAlgError:
                return None
        else:
            return None
        if self.w:
            args = np.concatenate(([t], q, np.zeros(n), pvals))
            b = np.asarray(self._w_f(args), float).ravel()
            cols = []
            for j in range(n):
                e = np.zeros(n)
                e[j] = 1.0
                cols.append(np.asarray(self._w_f(np.concatenate(([t], q, e, pvals))), float).ravel() - b)
            G = np.array(cols).T
            if not (np.all(np.isfinite(G)) and np.all(np.isfinite(b))):
                return None
            try:
                qd = qd - np.linalg.lstsq(G, G @ qd + b, rcond=None)[0]
            except np.linalg.LinAlgError:
                return None
        return q, qd

    # ------------------------------------------------------------------ measured outputs
    def _solve_measured(self) -> Identifiability:
        names, exprs = self.measured
        p1, p2 = self.generic_p(), self.generic_p()
        S1, count = self._sensitivities(p1, exprs)
        rank, null1, sigma = _svd_rank(S1, SENSITIVITY_RTOL)
        method = (f"numeric: the rank of the sensitivities of {', '.join(names)} with respect to log p (the "
                  f"{self._unknown_count} initial values of each experiment unknown too, projected out), by central "
                  f"differences of simulations of {count} experiments with random initial states and inputs (singular "
                  f"values above {SENSITIVITY_RTOL:g} * the largest)")
        if not len(null1):
            return self._build(NONE, [], p1, sigma, SENSITIVITY_RTOL, method)
        S2, _ = self._sensitivities(p2, exprs)
        _, null2, _ = _svd_rank(S2, SENSITIVITY_RTOL)
        rec1 = self._recognize(null1, S1, SENSITIVITY_RTOL * 10)
        rec2 = self._recognize(null2, S2, SENSITIVITY_RTOL * 10)
        if rec1 is None or rec2 is None or len(rec1) != len(null1) or len(rec2) != len(null2):
            return self._build(OTHER, [list(r) for r in null1], p1, sigma, SENSITIVITY_RTOL, method, exact=False)
        return self._finish(p1, p2, rec1, rec2, sigma, SENSITIVITY_RTOL, method)

    def _unknown_initial(self) -> list[str]:
        """The names of the initial state a simulation is given (and the analysis treats as unknown): the
        whole state, or for a constrained model its [simulation] independent coordinates and their velocities."""
        names = list(self.eq.state_names)
        if not self.m:
            return names
        independent = list(self.eq.model.simulation.get("independent") or [])
        if not independent:
            raise ModelError(f"identifiability with only some quantities measured needs the independent coordinates "
                             f"of the constrained model '{self.eq.model.name}' (the initial states of the simulated "
                             "experiments are given by them): add independent = [...] to its [simulation] table, or "
                             "measure every coordinate (measured=None)")
        return independent + [f"{q}_dot" for q in independent]

    def _sensitivities(self, p: list[Fraction], exprs) -> tuple[np.ndarray, int]:
        """d(measured values)/d(log p), the unknown initial state's columns projected out."""
        from ..numeric import compile as compile_model, simulate

        P = self.P
        if not hasattr(self, "_nm"):
            self._nm = compile_model(self.eq)
            self._out_f = se.Lambdify([self.t, *self.q, *self.qd, *self.u, *self.p_all], list(exprs), cse=True,
                                      real=True)
        base = {name: float(v) for name, v in zip(self.names, p)}
        base.update({s.name: float(v) for s, v in self.known.items()})
        experiments = 3
        times = np.linspace(0.0, 2.0, 41)
        unknown = self._unknown_initial()
        model_initial = self.eq.model.simulation.get("initial") or {}
        spread = 0.2 if self.m else 0.8
        blocks = []
        for _ in range(experiments):
            x0 = {k: float(model_initial.get(k, 0.0)) + float(self.nrng.uniform(-spread, spread)) for k in unknown}
            inputs = {u.name: " + ".join(f"{a:.3f}*sin({w:.3f}*t + {ph:.3f})" for a, w, ph in
                                         zip(self.nrng.uniform(0.3, 1.0, 2), self.nrng.uniform(0.5, 4.0, 2),
                                             self.nrng.uniform(0, 3, 2))) for u in self.eq.inputs}

            def run(params, x0=x0, inputs=inputs):
                tr = simulate(self._nm, t_end=float(times[-1]), initial=x0, inputs=inputs, params=params,
                              t_eval=times, rtol=1e-12, atol=1e-12)
                if len(tr.t) != len(times):
                    raise ModelError(f"identifiability: a simulation of model '{self.eq.model.name}' stopped early "
                                     f"({tr.message}); the sensitivities need whole runs")
                U = np.asarray(tr.u, float).reshape(len(times), -1) if len(self.u) else np.zeros((len(times), 0))
                pv = np.array([params.get(s.name, 0.0) for s in self.p_all])
                return np.concatenate([np.asarray(self._out_f(np.concatenate(([tk], xk, uk, pv))), float).ravel()
                                       for tk, xk, uk in zip(times, np.asarray(tr.x), U)])

            h = 1e-4
            cols = []
            for name in self.names:
                up, down = dict(base), dict(base)
                up[name] = base[name] * (1 + h)
                down[name] = base[name] * (1 - h)
                cols.append((run(up) - run(down)) / (2 * h))
            xcols = []
            for k in unknown:
                xu, xd = dict(x0), dict(x0)
                xu[k] += h
                xd[k] -= h
                xcols.append((run(base, xu) - run(base, xd)) / (2 * h))
            blocks.append((np.array(cols).T, np.array(xcols).T))
        rows = sum(len(b[0]) for b in blocks)
        k = len(unknown)
        S = np.zeros((rows, P + k * experiments))
        r = 0
        for e, (Sp, Sx) in enumerate(blocks):
            S[r:r + len(Sp), :P] = Sp
            S[r:r + len(Sp), P + k * e:P + k * (e + 1)] = Sx
            r += len(Sp)
        # project the initial states' columns out: S_p - U U^T S_p, U spanning the columns of S_x
        U, sx, _ = np.linalg.svd(S[:, P:], full_matrices=False)
        U = U[:, sx > 1e-10 * max(sx[0] if len(sx) else 0.0, 1e-300)]
        Sp = S[:, :P] - U @ (U.T @ S[:, :P])
        self._unknown_count = k
        return Sp, experiments

    # ------------------------------------------------------------------------- result
    def _build(self, symmetry, null, p, sigma, rtol, method, exact=True) -> Identifiability:
        names, P = self.names, self.P
        if exact:
            moved = [j for j in range(P) if any(v[j] != 0 for v in null)]
        else:
            moved = [j for j in range(P) if any(abs(v[j]) > 1e-6 for v in null)]
        ident = tuple(names[j] for j in range(P) if j not in moved)
        not_ident = tuple(names[j] for j in moved)
        combos: list[sympy.Expr] = []
        if symmetry == SCALING:
            combos = self._monomials(null, moved)
        elif symmetry == TRANSLATION:
            combos = self._sums(null, moved)
        reasons = self._reasons(symmetry, null, moved, combos, exact)
        rank = P - len(null) if symmetry == OTHER else len(ident) + len(combos)
        directions = tuple({names[j]: float(v[j]) for j in range(P) if (v[j] != 0 if exact else abs(v[j]) > 1e-9)}
                           for v in null)
        return Identifiability(parameters=names, identifiable=ident, not_identifiable=not_ident,
                               combinations=tuple(combos), rank=rank, reasons=reasons, symmetry=symmetry,
                               null_directions=directions, method=method,
                               singular_values=tuple(float(s) for s in sigma), threshold=rtol,
                               measured=None if self.measured is None else self.measured[0],
                               model_name=self.eq.model.name)

    def _monomials(self, null, moved) -> list[sympy.Expr]:
        """A basis of the monomials in the moved parameters that every scaling leaves unchanged:
        first the ratios of the equations' terms, simplest first, then the lattice's echelon basis."""
        P = self.P
        want = len(moved) - len(null)
        if want <= 0:
            return []

        def ok(e):
            return any(e[j] for j in moved) and all(sum(Fraction(e[j]) * v[j] for j in range(P)) == 0 for v in null)

        chosen: list[list[int]] = []

        def add(e):
            e = [e[j] if j in moved else 0 for j in range(P)]
            e = _integer([Fraction(x) for x in e])
            if not ok(e) or len(_rref([[Fraction(x) for x in c] for c in chosen + [e]], P)[0]) <= len(chosen):
                return
            if all(x <= 0 for x in e) or (flip and (sum(e) < 0 or (sum(e) == 0 and next(x for x in e if x) < 0))):
                e = [-x for x in e]  # m*l**2 rather than 1/(m*l**2)
            nonzero = [x for x in e if x]
            if len(nonzero) == 2 and nonzero[0] == -nonzero[1] and nonzero[0] > 0:
                e = [-x for x in e]  # a ratio over the parameter named first: mb/ma, mc/ma
            chosen.append(e)

        ratios = self._term_ratios()
        order = {tuple(e): k for k, e in enumerate(ratios)}
        candidates = sorted(ratios, key=lambda e: (sum(1 for x in e if x), sum(abs(x) for x in e), order[tuple(e)]))
        flip = False
        for e in candidates:
            if len(chosen) == want:
                break
            add(e)
        flip = True
        if len(chosen) < want:
            fixed = [[Fraction(1 if k == j else 0) for k in range(P)] for j in range(P) if j not in moved]
            for v in _nullspace([[Fraction(x) for x in d] for d in null] + fixed, P):
                if len(chosen) == want:
                    break
                add(_integer(v))
        syms = [sympy.Symbol(n, **_assumptions(self.eq, n)) for n in self.names]
        return [sympy.Mul(*(s ** x for s, x in zip(syms, e) if x)) for e in chosen]

    def _term_ratios(self) -> list[list[int]]:
        """Exponent vectors (in the parameters asked about) of the ratios of the terms of each equation
        to its first acceleration term (and to each other), from the expanded residuals."""
        pos = {p: j for j, p in enumerate(self.p)}
        out: dict[tuple[int, ...], None] = {}  # ordered: the ratios to the first acceleration term first
        count = 0
        exprs = list(self.residuals) + list(self.hol)
        for i, r in enumerate(exprs):
            own = self.qdd[i] if i < self.n else None
            terms = se.expand(r)
            terms = terms.args if isinstance(terms, se.Add) else (terms,)
            count += len(terms)
            if count > MAX_CANDIDATE_TERMS:
                break
            vecs = []
            for term in terms:
                vec = [0] * self.P
                good = True
                for factor in (term.args if isinstance(term, se.Mul) else (term,)):
                    base, exp = (factor.args if isinstance(factor, se.Pow) else (factor, se.Integer(1)))
                    if base in pos:
                        if not exp.is_Integer:
                            good = False
                            break
                        vec[pos[base]] += int(exp)
                if good:
                    vecs.append((own is not None and own in term.free_symbols, tuple(vec)))
            pivots = sorted({v for acc, v in vecs if acc} or {v for _, v in vecs},
                            key=lambda v: (sum(1 for x in v if x), [-x for x in v]))
            for piv in pivots[:1] + pivots[1:2]:
                for _, v in vecs:
                    d = tuple(a - b for a, b in zip(v, piv))
                    if any(d):
                        out.setdefault(d)
        return [list(d) for d in out]

    def _sums(self, null, moved) -> list[sympy.Expr]:
        P = self.P
        basis = _nullspace([list(v) for v in null]
                           + [[Fraction(1 if k == j else 0) for k in range(P)] for j in range(P) if j not in moved], P)
        syms = [sympy.Symbol(n, **_assumptions(self.eq, n)) for n in self.names]
        out = []
        for v in basis:
            e = _integer(v)
            if sum(e) < 0:
                e = [-x for x in e]
            out.append(sympy.Add(*(x * s for s, x in zip(syms, e) if x)))
        return out

    def _reasons(self, symmetry, null, moved, combos, exact) -> dict[str, str]:
        reasons = {}
        free = set()
        for e in self._all_symbols():
            free |= e
        for j in moved:
            name = self.names[j]
            sym = self.p[j]
            mine = [c for c in combos if sympy.Symbol(name) in {sympy.Symbol(s.name) for s in c.free_symbols}]
            if sym not in free:
                reasons[name] = (f"{name} does not appear in the equations of motion, so the data say nothing about "
                                 "it")
                continue
            dirs = [v for v in null if (v[j] != 0 if exact else abs(v[j]) > 1e-6)]
            if symmetry == SCALING:
                moves = "; ".join(_scaling_text(v, self.names) for v in dirs)
                alone = len(dirs) == 1 and sum(1 for x in dirs[0] if x != 0) == 1
                why = (f"{name} cancels from the accelerations M^-1 f (scaling {name} alone leaves the motion "
                       "unchanged)" if alone else f"the motion is unchanged under {moves}, for every s > 0")
            elif symmetry == TRANSLATION:
                moves = "; ".join(_translation_text(v, self.names) for v in dirs)
                why = f"the motion is unchanged under {moves}, for every s"
            else:
                shown = "; ".join(_largest(v, self.names) for v in dirs[:3]) + ("; ..." if len(dirs) > 3 else "")
                why = ("the motion is unchanged to first order along a direction of the parameters that is neither "
                       f"a scaling nor a translation (relative changes dp/p: {shown})")
            if mine:
                why += "; determined only in " + ", ".join(str(c) for c in mine)
            reasons[name] = why
        return reasons

    def _all_symbols(self):
        exprs = [e for row in self.M for e in row] + self.f + [e for row in self.G for e in row] + self.c \
            + self.hol + self.w
        if self.measured is not None:
            exprs += list(self.measured[1])
        return [set(e.free_symbols) for e in exprs]


# ----------------------------------------------------------------------------------- helpers
def _assumptions(eq: Equations, name: str) -> dict:
    for s in eq.parameters:
        if s.name == name:
            return dict(s.assumptions0)
    return {}


def _largest(v, names, most: int = 6) -> str:
    """The largest entries of a numeric direction, by name."""
    order = sorted((k for k in range(len(v)) if abs(v[k]) > 1e-6), key=lambda k: -abs(v[k]))
    text = ", ".join(f"{names[k]}: {float(v[k]):.3g}" for k in order[:most])
    return text + (", ..." if len(order) > most else "")


def _scaling_text(v, names) -> str:
    parts = []
    for x, n in zip(v, names):
        if x == 0:
            continue
        x = Fraction(x)
        parts.append(f"{n} -> {n}*s" if x == 1 else f"{n} -> {n}*s**({x})" if x.denominator != 1 or x < 0
                     else f"{n} -> {n}*s**{x}")
    return ", ".join(parts)


def _translation_text(v, names) -> str:
    parts = []
    for x, n in zip(v, names):
        if x == 0:
            continue
        x = Fraction(x)
        parts.append(f"{n} -> {n} + s" if x == 1 else f"{n} -> {n} - s" if x == -1 else f"{n} -> {n} + ({x})*s")
    return ", ".join(parts)


def _same_span(A, B, P) -> bool:
    if len(A) != len(B):
        return False
    return len(_rref([list(r) for r in A] + [list(r) for r in B], P)[0]) == len(A)


def _ratio(x: Fraction) -> tuple[int, int]:
    return x.numerator, x.denominator


def _se(x: Fraction):
    return se.Rational(x.numerator, x.denominator)


def _frac(v) -> Fraction:
    """A SymEngine rational number as a Fraction (a non-rational result is a bug of the substitution)."""
    if isinstance(v, se.Integer):
        return Fraction(int(v))
    if isinstance(v, se.Rational):
        num, den = v.get_num_den()
        return Fraction(int(num), int(den))
    raise _NotRational(str(v))


class _NotRational(Exception):
    """An expression holds an irrational constant (sqrt(2), pi): the exact path cannot be taken."""


def _solve_exact(M: list[list[Fraction]], f: list[Fraction]) -> list[Fraction] | None:
    n = len(f)
    A = [row[:] + [fi] for row, fi in zip(M, f)]
    R, piv = _rref(A, n + 1)
    if piv != list(range(n)):
        return None
    return [R[i][n] for i in range(n)]


def _integer_combination(arg, variables) -> dict | None:
    """{variable: integer coefficient} when `arg` is an integer combination of `variables` (q1 - q2,
    2*th), else None."""
    arg = se.expand(arg)
    terms = arg.args if isinstance(arg, se.Add) else (arg,)
    out: dict = {}
    for term in terms:
        coeff, var = se.Integer(1), term
        if isinstance(term, se.Mul):
            nums = [f for f in term.args if f.is_Number]
            rest = [f for f in term.args if not f.is_Number]
            if len(nums) != 1 or len(rest) != 1:
                return None
            coeff, var = nums[0], rest[0]
        if var not in variables or not coeff.is_Integer:
            return None
        out[var] = out.get(var, 0) + int(coeff)
    return out


def _circle_power(combo: dict, circle: dict) -> tuple[Fraction, Fraction]:
    """(cos, sin) of sum k_i x_i from each x_i's (cos, sin): the product of (cos + i sin)**k_i."""
    re_, im_ = Fraction(1), Fraction(0)
    for var, k in combo.items():
        c, s = circle[var]
        if k < 0:
            s, k = -s, -k  # on the unit circle, z**-1 is the conjugate
        for _ in range(k):
            re_, im_ = re_ * c - im_ * s, re_ * s + im_ * c
    return re_, im_


def _is_trig(a) -> bool:
    return isinstance(a, (se.sin, se.cos))


def _atoms(expr) -> set:
    """The non-polynomial parts of `expr` that contain a symbol: functions, and powers with a
    non-integer or symbolic exponent (exp(x) is E**x in SymEngine)."""
    out = set()
    stack = [expr]
    while stack:
        e = stack.pop()
        if not e.free_symbols:
            continue
        if isinstance(e, se.Function):
            out.add(e)
            continue
        if isinstance(e, se.Pow):
            base, exp = e.args
            if not exp.is_Integer:
                out.add(e)
                continue
            stack.append(base)
            continue
        stack.extend(e.args)
    return out
