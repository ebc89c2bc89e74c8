"""constraint_singularities(equations): where a mechanism's constraints become dependent, and where
the coordinates that drive it lose their grip (dead points).

With G the constraints' Jacobian (m x n: rows dg/dq of the holonomic constraints g(q, t) = 0, the
velocities' coefficients of the velocity constraints), a configuration on the constraints is

- **singular** where G loses rank: some combination y of the constraints has no gradient
  (y^T G = 0), so the constraints are dependent there. Their multipliers are not determined (a force
  y lambda is carried without any generalized force), the saddle-point system of a simulation is
  singular (it stops there), and G q_dot = 0 admits more motions than the mechanism's degrees of
  freedom: a change point, where the mechanism can switch from one assembly branch to another
  (a four-bar whose links all line up, with a + d = b + c);
- a **dead point** of a set S of driving coordinates where G keeps its rank but its columns of the
  other coordinates, G_D, lose it (G's holonomic rows): a combination of S's velocities is locked
  (y^T G = (c^T, 0) for some y, so every allowed motion has c . q_dot_S = 0: S at the end of its
  travel), the other coordinates can move with S held (G_D v = 0), and a force on S along c is carried
  by the constraints alone, doing no work: it cannot drive the mechanism through (the dead centres of
  a slider-crank driven from its piston, where the crank and the rod line up).

The drivers are the model's independent coordinates ([simulation] independent) and each coordinate
that an input alone acts on (a motor's torque, a piston's force), or those the caller names.

The zeros are found by solving: from random configurations moved onto the constraints,
Levenberg-Marquardt on g(q) = 0, G(q)^T y = 0, |y| = 1 (or with G_D), every candidate verified
(|g| and the smallest singular value at round-off) and, where its values are recognized as exact
(0, pi, 9/20), verified again exactly by SymPy. det(G G^T) (or det G_D, when square) is shown
factored for small models; a nonzero constant proves that there is no such configuration at all.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np
import symengine as se
import sympy

from .._util import shown_value
from ..errors import ModelError
from ..model._constraints import HOLONOMIC
from ..model._kinematics import to_sympy
from ._equations import Equations
from ._lambdify import lambdify
from ._search import NUDGE, angle_difference, distinct, gauss_newton, least_squares, wrap_angles
from ._singular import determinant, exact_number, factored

__all__ = ["constraint_singularities", "ConstraintSingularityReport", "ConstraintConfiguration", "DeadPoints"]

#: A verified zero: the smallest singular value, relative to the largest of G, below this.
RANK_TOL = 1e-8
#: Random starting configurations of each search.
STARTS = 40
#: Symbolic determinants for up to this many coordinates (as for det M).
_SYMBOLIC_MAX_N = 4
#: Configurations listed per search (the nearest to the initial configuration first).
_MAX_LISTED = 8


@dataclass(frozen=True)
class ConstraintConfiguration:
    """A configuration on the constraints where G (or G_D) loses rank.

    Attributes
    ----------
    where : dict of str to sympy number
        The coordinates' values (exact where recognized, else floats).
    condition : str
        The same as text, ``"th = 0, ph = 0, s = 9/20"``; for a curve of them, its equation where the
        determinant gives one (``"z = 0"``), else "".
    exact : bool
        True when SymPy verified the configuration exactly (g = 0 and the rank loss).
    rank : int
        The rank of G there (of G's holonomic rows for a dead point).
    dependent : dict of str to float
        The combination y of the constraints (by name) whose gradient vanishes (singular), or whose
        force acts on the drivers alone (dead point); largest coefficient 1.
    free : tuple of dict
        Motions G q_dot = 0 allows there: for a singular configuration a basis of them (more than the
        degrees of freedom); for a dead point, the motion with the drivers held.
    locked : dict of str to float
        For a dead point: the combination c of the drivers' velocities that every allowed motion keeps
        at 0 (``{"s_dot": 1}``: s_dot = 0); {} for a singular configuration.
    dimension : int
        0 for an isolated configuration; 1 for a curve of them (``where`` one point of it), and so on.
    """

    where: dict
    condition: str
    exact: bool
    rank: int
    dependent: dict
    free: tuple = ()
    locked: dict = field(default_factory=dict)
    dimension: int = 0

    @property
    def point(self) -> str:
        """The configuration as text (for a curve, the point of it in ``where``)."""
        return ", ".join(f"{k} = {_num(v)}" for k, v in self.where.items())

    @property
    def summary(self) -> str:
        """"th = 0, ph = 0" for a point; "z = 0 (a curve of them)" for a curve."""
        if not self.dimension:
            return self.condition or self.point
        shape = "a curve" if self.dimension == 1 else f"a set of dimension {self.dimension}"
        return f"{self.condition} ({shape} of them)" if self.condition else f"{shape} of them through {self.point}"

    @property
    def at(self) -> str:
        """Where the lines about this configuration start: "At th = 0, ph = 0"."""
        if not self.where:
            return "Everywhere"
        if self.dimension and self.condition:
            return f"At {self.point} (on the {'curve' if self.dimension == 1 else 'set'} {self.condition})"
        return f"At {self.point}"

    def to_dict(self) -> dict:
        return {"where": {k: sympy.sstr(v) for k, v in self.where.items()}, "condition": self.condition,
                "exact": self.exact, "dimension": self.dimension, "rank": self.rank,
                "dependent_constraints": dict(self.dependent), "free_motions": [dict(m) for m in self.free],
                "locked": dict(self.locked)}


@dataclass(frozen=True)
class DeadPoints:
    """The dead points of one set of driving coordinates.

    Attributes
    ----------
    drivers : tuple of str
        The driving coordinates S.
    others : tuple of str
        The other coordinates, D, that the holonomic constraints fix when S is given.
    reason : str
        Why they drive: ``"[simulation] independent"``, ``"input P"`` or ``"given"``.
    determinant : sympy.Expr or None
        det G_D (G's holonomic rows, the other coordinates' columns) when square, factored.
    configurations : tuple of ConstraintConfiguration
    more : int
        How many more were found than listed.
    never : bool
        True when det G_D with the parameter values is a nonzero constant (no dead point anywhere).
    searched : bool
        False when the search did not run (a parameter without a value).
    """

    drivers: tuple
    others: tuple
    reason: str
    determinant: sympy.Expr | None
    configurations: tuple = ()
    more: int = 0
    never: bool = False
    searched: bool = True

    def to_dict(self) -> dict:
        return {"drivers": list(self.drivers), "others": list(self.others), "reason": self.reason,
                "determinant": None if self.determinant is None else sympy.sstr(self.determinant),
                "never": self.never, "searched": self.searched,
                "configurations": [c.to_dict() for c in self.configurations],
                "more": self.more}


@dataclass(frozen=True)
class ConstraintSingularityReport:
    """The diagnosis of a model's constraints (returned by :func:`constraint_singularities`).

    Attributes
    ----------
    constraints : tuple of str
        Every constraint's name (the rows of G), holonomic ones and velocity ones.
    holonomic : tuple of str
    degrees_of_freedom : int
        n - m, the motions G q_dot = 0 allows where G has full rank.
    gram_determinant : sympy.Expr or None
        det(G G^T) for up to 4 coordinates (None beyond), as the sum of the squares of G's m x m minors
        (or factored, when shorter); it vanishes exactly where G loses rank.
    initial : dict of str to float
        The model's initial configuration on the constraints ([simulation] initial, the independent
        coordinates held, the others moved onto g = 0 as a simulation does).
    initial_rank : int
        The rank of G there.
    singular : bool
        Whether G loses rank at some configuration on the constraints.
    everywhere : bool
        Whether it does at every one (a constraint that restates others).
    configurations : tuple of ConstraintConfiguration
    more : int
        How many more singular configurations were found than listed.
    dead_points : tuple of DeadPoints
        One per set of drivers.
    notes : tuple of str
        What was not searched and why.
    cause, fix : str
        The likely cause and how to fix the model ("" when nothing was found).
    """

    constraints: tuple
    holonomic: tuple
    n: int
    degrees_of_freedom: int
    gram_determinant: sympy.Expr | None
    initial: dict
    initial_rank: int
    singular: bool
    everywhere: bool = False
    configurations: tuple = ()
    more: int = 0
    dead_points: tuple = ()
    starts: int = STARTS
    notes: tuple = ()
    cause: str = ""
    fix: str = ""

    def text(self) -> str:
        m = len(self.constraints)
        kinds = [f"{name} ({'holonomic' if name in self.holonomic else 'velocity'})" for name in self.constraints]
        lines = [f"Constraints: {', '.join(kinds)}; G is {m} x {self.n}, "
                 f"{_plural(self.degrees_of_freedom, 'degree')} of freedom."]
        lines += list(self.notes)
        if self.gram_determinant is not None:
            lines.append(f"det(G G^T) = {sympy.sstr(self.gram_determinant)}")
        if self.initial:
            where = ", ".join(f"{k} = {_num(v)}" for k, v in self.initial.items())
            full = "full" if self.initial_rank == m else "lost: the constraints are dependent there"
            lines.append(f"At the initial configuration {where}: G has rank {self.initial_rank} of {m} ({full}).")
        if self.everywhere:
            lines.append("G loses rank at every configuration on the constraints: they are dependent everywhere.")
        elif self.singular:
            conds = " or ".join(c.summary for c in self.configurations)
            more = f" (and {self.more} more)" if self.more else ""
            lines.append(f"G loses rank where {conds}{more}.")
        elif self.gram_determinant is not None and self.gram_determinant.is_number and self.gram_determinant != 0:
            lines.append("G has full rank at every configuration: det(G G^T) does not vanish.")
        elif self._searched:
            lines.append(f"G has full rank at every configuration on the constraints found by the search (from "
                         f"{self.starts} starting points): no singular configuration.")
        for c in self.configurations:
            lines.append(f"{c.at}: G has rank {c.rank} of {m}; {_combination(c.dependent)} "
                         f"has no gradient, so the constraints are "
                         f"dependent; G q_dot = 0 allows {_plural(len(c.free), 'independent motion')} "
                         f"({'; '.join(_motion(f) for f in c.free)}) where the mechanism has "
                         f"{self.degrees_of_freedom}.")
        for d in self.dead_points:
            lines.extend(_dead_point_lines(d))
        if self.cause:
            lines.append(f"Likely cause: {self.cause}")
            lines.append(f"Fix: {self.fix}")
        return "\n".join(lines)

    __str__ = text

    @property
    def _searched(self) -> bool:
        return not any(note.startswith("Not searched") for note in self.notes)

    def to_dict(self) -> dict:
        return {
            "constraints": list(self.constraints),
            "holonomic": list(self.holonomic),
            "degrees_of_freedom": self.degrees_of_freedom,
            "gram_determinant": None if self.gram_determinant is None else sympy.sstr(self.gram_determinant),
            "initial": {k: float(v) for k, v in self.initial.items()},
            "initial_rank": self.initial_rank,
            "singular": bool(self.singular),
            "everywhere": bool(self.everywhere),
            "configurations": [c.to_dict() for c in self.configurations],
            "more": self.more,
            "dead_points": [d.to_dict() for d in self.dead_points],
            "notes": list(self.notes),
            "cause": self.cause,
            "fix": self.fix,
            "diagnosis": self.text(),
        }


# ----------------------------------------------------------------------------- text helpers
def _plural(k: int, word: str) -> str:
    return f"{k} {word}{'' if k == 1 else 's'}"


def _num(v) -> str:
    if isinstance(v, sympy.Basic):
        return sympy.sstr(v) if v.is_Rational or not v.is_number or v.has(sympy.pi) else f"{float(v):.6g}"
    return f"{float(v):.6g}"


def _coef(v: float) -> str:
    r = sympy.nsimplify(v, tolerance=1e-9, rational=True)
    if r.q <= 100:
        return sympy.sstr(r)
    return f"{v:.6g}"


def _times(c: str, name: str) -> str:
    """"2*x", "x", "-x" for the coefficients "2", "1", "-1"."""
    return name if c == "1" else f"-{name}" if c == "-1" else f"{c}*{name}"


def _linear(weights: dict) -> str:
    """{"a": 1, "b": -0.5} -> "a - 1/2*b"."""
    terms = []
    for name, w in weights.items():
        if w == 0:
            continue
        c = _coef(abs(w))
        sign = "-" if w < 0 else "+"
        terms.append(f"{sign} {name if c == '1' else f'{c}*{name}'}")
    text = " ".join(terms)
    return text[2:] if text.startswith("+ ") else "-" + text[2:]


def _combination(weights: dict) -> str:
    """"constraint rod" for one name, "the combination pin_x - 1/2*pin_y" for more."""
    if len(weights) == 1:
        return f"constraint {next(iter(weights))}"
    return f"the combination {_linear(weights)}"


def _motion(v: dict) -> str:
    """A velocity direction as text: "th_dot = -7/2*ph_dot (s_dot = 0)", "z_dot alone"."""
    nonzero = [(k, w) for k, w in v.items() if w != 0]
    zero = [k for k, w in v.items() if w == 0]
    if len(nonzero) == 1:
        return f"{nonzero[0][0]} alone"
    ref, wr = nonzero[-1]
    text = ", ".join(f"{k} = {_times(_coef(w / wr), ref)}" for k, w in nonzero[:-1])
    return text + (f" ({', '.join(zero)} = 0)" if zero else "")


def _locked_text(c: dict) -> str:
    return f"{_linear(c)} = 0"


def _dead_point_lines(d: DeadPoints) -> list[str]:
    names = ", ".join(d.drivers)
    head = f"Dead points of {names} ({d.reason})"
    det = f"; det dg/d({', '.join(d.others)}) = {sympy.sstr(d.determinant)}" if d.determinant is not None else ""
    if d.never:
        return [f"{head}: none: the determinant does not vanish{det}."]
    if not d.searched:
        return [f"{head}: not searched{det}."]
    if not d.configurations:
        return [f"{head}: none found on the constraints{det}."]
    conds = " or ".join(c.summary for c in d.configurations)
    more = f" (and {d.more} more)" if d.more else ""
    lines = [f"{head}: at {conds}{more}{det}."]
    for c in d.configurations:
        free = _motion(c.free[0]) if c.free else ""
        lines.append(f"{c.at}: every motion the constraints allow keeps {_locked_text(c.locked)} "
                     f"({names} at the end of {'its' if len(d.drivers) == 1 else 'their'} travel), and "
                     f"{free} is free with {names} held; a force on {names} there is carried by "
                     f"{_combination(c.dependent)} alone and does no work: it cannot drive the mechanism.")
    return lines


# ------------------------------------------------------------------------------ numerics
class _Numbers:
    """g (holonomic rows) and G (all rows) as functions of q, with the parameter values and t = t0."""

    def __init__(self, eqs: Equations, values: dict, t0: float = 0.0):
        core = eqs.core
        self.n, self.m = eqs.n, len(core.g)
        kinds = [c.kind for c in eqs.model.constraints]
        self.hol = [k for k, kind in enumerate(kinds) if kind == HOLONOMIC]
        subs = {se.Symbol(p.name): float(v) for p, v in values.items()}
        subs[core.t] = t0
        self.q = list(core.q)
        self.g_exprs = [se.sympify(core.g[k]).subs(subs) for k in self.hol]
        self.G_exprs = [[se.sympify(core.G[k, j]).subs(subs) for j in range(self.n)] for k in range(self.m)]
        self._g = _point_call(lambdify(self.q, self.g_exprs or [se.Integer(0)]), self.n, len(self.g_exprs) or 1)
        self._G = _point_call(lambdify(self.q, [e for row in self.G_exprs for e in row]), self.n, self.m * self.n)
        self._systems: dict = {}
        self.assembled: dict = {}  # _assemble's results without held coordinates, by (start, scale)

    def g(self, q) -> np.ndarray:
        return self._g(q)[:len(self.hol)]

    def G(self, q) -> np.ndarray:
        return self._G(q).reshape(self.m, self.n)

    def system(self, rows, cols):
        """z = (q, y) -> (F, dF/dz) of F = (g(q), A(q)^T y, |y|^2 - 1) with A = G[rows][:, cols]: its zeros
        are the configurations on the constraints where A has the left null vector y."""
        key = (tuple(rows), tuple(cols))
        if key not in self._systems:
            y = [se.Symbol(f"_y{k}") for k in range(len(rows))]
            F = list(self.g_exprs)
            F += [sum((y[a] * self.G_exprs[k][j] for a, k in enumerate(rows)), se.Integer(0)) for j in cols]
            F.append(sum((v * v for v in y), se.Integer(0)) - 1)
            z = self.q + y
            J = [se.diff(f, v) for f in F for v in z]
            size, width = len(F), len(z)
            fn = _point_call(lambdify(z, F + J), width, size + size * width)

            def evaluate(zz, fn=fn, size=size, width=width):
                out = fn(zz)
                return out[:size], out[size:].reshape(size, width)

            self._systems[key] = evaluate
        return self._systems[key]


def _point_call(fn, args: int, outputs: int):
    """`fn` (a SymEngine Lambdify of `args` arguments and `outputs` outputs) at one point, as a flat float
    array: by its ``unsafe_eval`` into a new array where the point is a contiguous vector of `args` floats (the
    same compiled code as ``fn(x)``, without the checks and broadcasting of its call: the searches make
    thousands), else ``np.asarray(fn(x), float).ravel()``."""
    unsafe = getattr(fn, "unsafe_eval", None)

    def call(x):
        x = np.asarray(x, float)
        if unsafe is None or x.shape != (args,) or not x.flags.c_contiguous:
            return np.asarray(fn(x), float).ravel()
        out = np.empty(outputs)
        unsafe(x, out, 1)
        return out

    return call


def _assemble(num: _Numbers, q, held=(), scale=1.0):
    """q moved onto g = 0 by Gauss-Newton steps of the smallest change (equations._search), each at
    most half the length scale, the `held` indices kept; None where that fails. Without `held`, kept
    per start (a copy returned): the searches of one diagnosis (G's rank, then each set of drivers' dead
    points) start from the same points."""
    q = np.array(q, float)
    if not num.hol:
        return q
    if not held:
        key = (q.tobytes(), float(scale))
        if key not in num.assembled:
            num.assembled[key] = _assembled(num, q, (), scale)
        hit = num.assembled[key]
        return None if hit is None else hit.copy()
    return _assembled(num, q, held, scale)


def _assembled(num: _Numbers, q: np.ndarray, held, scale: float):
    """_assemble's solve."""
    free = [i for i in range(num.n) if i not in set(held)]
    if not free:
        return q if np.max(np.abs(num.g(q))) <= 1e-10 * scale else None
    q, _ = gauss_newton(lambda x: (num.g(x), num.G(x)[num.hol][:, free]), q, free, iterations=60,
                        small=1e-14 * scale, max_step=0.5 * scale, nudge=NUDGE * scale)
    r = num.g(q)
    return q if np.all(np.isfinite(r)) and np.max(np.abs(r)) <= 1e-10 * scale else None


def _ratio(A: np.ndarray, ref: np.ndarray | None = None) -> float:
    """The smallest singular value of A (of min(rows, cols) ones) over the largest of `ref` (A)."""
    if A.size == 0:
        return 1.0
    s = np.linalg.svd(A, compute_uv=False)
    top = np.linalg.svd(ref, compute_uv=False)[0] if ref is not None else s[0]
    if A.shape[0] > A.shape[1]:
        return 0.0  # more rows than columns: never full row rank
    return float(s[-1] / top) if top > 0 else 0.0


def _search(num: _Numbers, starts, rows, cols, scale):
    """Configurations on g = 0 where A = G[rows][:, cols] has a left null vector: Levenberg-Marquardt
    on F = (g(q), A(q)^T y, |y|^2 - 1) from each start (moved onto g = 0 first), each result verified
    (|g| and A's smallest singular value at round-off). Returns [(q, dimension)]: the dimension of the
    set of such configurations there (0: an isolated one; 1: a curve of them)."""
    n = num.n
    system = num.system(rows, cols)
    rows, cols = list(rows), list(cols)
    found = []
    for q0 in starts:
        q = _assemble(num, q0, scale=scale)
        if q is None:
            continue
        A = num.G(q)[rows][:, cols]
        if not np.all(np.isfinite(A)):
            continue
        y = np.linalg.svd(A)[0][:, -1]
        z = least_squares(system, np.concatenate((q, y)), len(num.hol) + len(cols) + 1)
        if z is None:
            continue
        q = z[:n]
        G, g = num.G(q), num.g(q)
        if not (np.all(np.isfinite(q)) and np.all(np.isfinite(G)) and np.all(np.isfinite(g))):
            continue
        if np.max(np.abs(g), initial=0.0) > 1e-9 * scale:
            continue
        if _ratio(G[rows][:, cols], G[num.hol] if num.hol and rows != list(range(num.m)) else G) > RANK_TOL:
            continue
        found.append((q, _dimension(system(z)[1], n)))
    return found


def _dimension(J: np.ndarray, n: int) -> int:
    """The dimension of the zeros of F near a zero z = (q, y) where dF/dz = J: the rank of the
    q-part of J's null space (the directions q can move along them)."""
    _, sv, Vt = np.linalg.svd(J)
    rank = int(np.sum(sv > 1e-7 * sv[0])) if len(sv) else 0
    null = Vt[rank:, :n]
    if not len(null):
        return 0
    s = np.linalg.svd(null, compute_uv=False)
    return int(np.sum(s > 1e-6))


def _exact(value: float, angle: bool):
    """A short exact number equal to `value` to 1e-10 (0, pi/2, 9/20: a rational, times pi for an
    angle, of denominator at most 24), or None."""
    ratios = [(sympy.nsimplify(value / np.pi, tolerance=1e-10, rational=True), sympy.pi)] if angle else []
    ratios.append((sympy.nsimplify(value, tolerance=1e-10, rational=True), sympy.Integer(1)))
    for r, unit in ratios:
        candidate = r * unit
        if r.q <= 24 and abs(r.p) <= 1000 and abs(float(candidate) - value) <= 1e-10 * (1 + abs(value)):
            return candidate
    return None


# ------------------------------------------------------------------------------ the analysis
def constraint_singularities(equations: Equations, drivers=None) -> ConstraintSingularityReport:
    """Diagnose a model's constraints: the rank of their Jacobian G at the initial configuration,
    the configurations on the constraints where G loses rank (the constraints dependent), and the dead
    points of the coordinates that drive the mechanism.

    Parameters
    ----------
    equations : Equations
        Of a model with constraints.
    drivers : list of str or of lists of str, optional
        The driving coordinates whose dead points are sought: each item a coordinate's name or a list
        of names driving together. Default: the model's ``[simulation] independent`` coordinates (as
        one set) and each coordinate that an input alone acts on.

    Returns
    -------
    ConstraintSingularityReport

    Raises
    ------
    ModelError
        For a model without constraints, or drivers that are not coordinates or leave the
        constraints no coordinate to fix.
    """
    eqs = equations
    if not isinstance(eqs, Equations):
        raise TypeError("constraint_singularities() expects the Equations of a model (lagrangian.derive(model)), "
                        f"got {type(eqs).__name__}")
    model = eqs.model
    if not model.constraints:
        raise ModelError(f"model '{model.name}' has no constraints, so there is no constraint Jacobian to diagnose; "
                         "lagrangian.singularities (lagrangian check) diagnoses its mass matrix")
    names = [q.name for q in eqs.coordinates]
    n, m = eqs.n, len(model.constraints)
    con_names = tuple(c.name for c in model.constraints)
    hol = [k for k, c in enumerate(model.constraints) if c.kind == HOLONOMIC]
    hol_names = tuple(con_names[k] for k in hol)
    driver_sets = _driver_sets(eqs, drivers, names, len(hol))
    values = {p: v for p, v in eqs.parameters.items() if v is not None}
    exact_values = {p: exact_number(v) for p, v in values.items()}
    missing = [p.name for p, v in eqs.parameters.items() if v is None]
    gram = gram_values = None
    if n <= _SYMBOLIC_MAX_N:
        gram, gram_values = _gram_determinant(sympy.Matrix(eqs.constraint_jacobian), exact_values)
    notes = []
    if any(eqs.core.t in se.sympify(g).free_symbols for g in eqs.core.g):
        notes.append("The constraints depend on t: they are diagnosed at t = 0.")
    dets = [_driver_det(eqs, s) for s, _ in driver_sets]
    if missing:
        notes.append(f"Not searched: parameter{'s' if len(missing) > 1 else ''} {', '.join(missing)} "
                     f"{'have' if len(missing) > 1 else 'has'} no value; give "
                     f"{'them values' if len(missing) > 1 else 'it a value'} in the model to have the "
                     "configurations found.")
        dead = tuple(DeadPoints(tuple(names[i] for i in s), tuple(names[i] for i in range(n) if i not in s), why, d,
                                never=bool(d is not None and d.is_number and d != 0), searched=False)
                     for (s, why), d in zip(driver_sets, dets))
        return ConstraintSingularityReport(con_names, hol_names, n, n - m, gram, {}, 0, False, dead_points=dead,
                                           notes=tuple(notes))
    num = _Numbers(eqs, values)
    angles = _angles(eqs)
    initial, scale = _initial(eqs, num, names, notes)
    Gi = num.G(initial)
    initial_rank = int(np.linalg.matrix_rank(Gi, tol=RANK_TOL * np.linalg.norm(Gi, 2))) if np.all(np.isfinite(Gi)) \
        else 0
    starts = _starts(initial, angles, scale)
    search = _Search(eqs, num, angles, initial, scale, exact_values, starts)

    # singular configurations: G loses rank on the constraints
    configurations, more, everywhere = [], 0, False
    if not (gram_values is not None and gram_values.is_number and gram_values != 0):
        everywhere = gram_values == 0 or _everywhere(num, starts, scale)
        if everywhere:
            q = next(q for q in (_assemble(num, x, scale=scale) for x in starts) if q is not None)
            configurations = [_singular_configuration(eqs, num, q, {}, False, "", n - m)]
        else:
            located, more = search.locate(list(range(m)), list(range(n)), gram_values, m)
            configurations = [_singular_configuration(eqs, num, *item) for item in located]
    dead = [_dead_points(eqs, num, search, s, why, det) for (s, why), det in zip(driver_sets, dets)]
    cause, fix = _cause_and_fix(configurations, everywhere, dead, eqs.model.wheels)
    return ConstraintSingularityReport(con_names, hol_names, n, n - m, gram,
                                       {k: float(v) for k, v in zip(names, initial)}, initial_rank,
                                       bool(configurations), everywhere, tuple(configurations), more, tuple(dead),
                                       STARTS, tuple(notes), cause, fix)


def _angles(eqs: Equations) -> list[bool]:
    """Which coordinates are angles: those inside a sine, cosine or tangent of M, V or a constraint
    (read in SymEngine: the readable forms of a large model are slow to build)."""
    core = eqs.core
    inside: set = set()
    for e in [*core.M, core.V, *core.g]:
        for f in se.sympify(e).atoms(se.sin, se.cos, se.tan):
            inside |= f.free_symbols
    return [q in inside for q in core.q]


def _driver_sets(eqs: Equations, drivers, names, m_h) -> list[tuple[tuple[int, ...], str]]:
    """[(indices of a driver set, why it drives)] for the dead-point searches."""
    n = len(names)
    out: list[tuple[tuple[int, ...], str]] = []
    if drivers is not None:
        problems = []
        if isinstance(drivers, str):
            drivers = [drivers]
        sets = (list, tuple, set, frozenset)
        if not isinstance(drivers, sets) or not all(
                isinstance(item, str) or (isinstance(item, sets) and all(isinstance(k, str) for k in item))
                for item in drivers):
            raise ModelError(f"drivers must be a coordinate's name, a list of names or a list of sets of names, "
                             f"such as drivers='{names[0]}' or drivers=[('{names[0]}',)], got "
                             f"{shown_value(drivers)}; the coordinates are {', '.join(names)}")
        for item in drivers:
            group = [item] if isinstance(item, str) else list(item)
            bad = [k for k in group if k not in names]
            if not group:
                problems.append(f"a set of drivers names no coordinate; name one or more of {', '.join(names)}")
            elif bad:
                problems.append(f"driver {', '.join(repr(k) for k in bad)} is not a coordinate of model "
                                f"'{eqs.model.name}'; its coordinates are {', '.join(names)}")
            elif not m_h:
                problems.append(f"a driver has dead points only through holonomic constraints, and model "
                                f"'{eqs.model.name}' has none")
            elif n - len(set(group)) < m_h:
                problems.append(f"the drivers {', '.join(group)} leave {n - len(set(group))} coordinates to the "
                                f"{m_h} holonomic constraints to fix: name at most {n - m_h} drivers in a set")
            else:
                out.append((tuple(sorted(names.index(k) for k in set(group))), "given"))
        if problems:
            raise ModelError("; ".join(dict.fromkeys(problems)))
        return out
    if not m_h:
        return out
    independent = [str(q) for q in eqs.model.simulation.get("independent", ()) if str(q) in names]
    if independent and n - len(independent) >= m_h:
        out.append((tuple(sorted(names.index(k) for k in independent)), "[simulation] independent"))
    core = eqs.core
    for u in eqs.inputs:
        rows = [i for i in range(n) if se.diff(se.sympify(core.Q[i]), se.Symbol(u.name)) != 0]
        if len(rows) == 1 and n - 1 >= m_h and (rows[0],) not in [s for s, _ in out]:
            out.append(((rows[0],), f"driven by input {u.name}"))
    return out


def _gram_determinant(G: sympy.Matrix, exact_values: dict) -> tuple[sympy.Expr, sympy.Expr]:
    """(det(G G^T) as shown, the same with the parameter values). Shown as the sum of the squares of
    G's m x m minors (Cauchy-Binet: it vanishes where they all do) unless det(G G^T) factored is
    shorter (a number, as for a rod: 1)."""
    m, n = G.shape
    total = factored(determinant(G * G.T))
    minors = [factored(determinant(G.extract(list(range(m)), list(cols))))
              for cols in itertools.combinations(range(n), m)]
    squares = sympy.Add(*(f**2 for f in minors if f != 0))
    shown = total if total.is_number or sympy.count_ops(total) <= sympy.count_ops(squares) else squares
    return shown, factored(total.subs(exact_values))


def _driver_det(eqs: Equations, s) -> sympy.Expr | None:
    """det of G's holonomic rows in the other coordinates' columns, when square and small."""
    hol = [k for k, c in enumerate(eqs.model.constraints) if c.kind == HOLONOMIC]
    others = [i for i in range(eqs.n) if i not in s]
    if len(others) != len(hol) or eqs.n > _SYMBOLIC_MAX_N:
        return None
    return factored(determinant(sympy.Matrix(eqs.constraint_jacobian).extract(hol, others)))


def _initial(eqs: Equations, num: _Numbers, names, notes):
    """The model's initial configuration moved onto the constraints as a simulation does (the
    independent coordinates held), and the length scale of the model's numbers."""
    given = {str(k): float(v) for k, v in (eqs.model.simulation.get("initial") or {}).items() if str(k) in names}
    held = [names.index(str(k)) for k in eqs.model.simulation.get("independent", ()) if str(k) in names]
    if getattr(eqs.model, "joints", None):  # quaternion joints start as a simulation does (the one rule)
        from ..model._joints import quaternion_start

        start, quaternion_notes = quaternion_start(eqs.model, eqs.model.simulation.get("initial"))
        given.update({k: v for k, v in start.items() if k in names})
        held += [names.index(k) for k in start if k in names and names.index(k) not in held]
        notes.extend(quaternion_notes)
    q = np.array([given.get(k, 0.0) for k in names])
    scale = max([1.0, *np.abs(q), *(abs(float(v)) for v in eqs.parameters.values() if v is not None)])
    assembled = _assemble(num, q, held, scale)
    if assembled is None and held:
        assembled = _assemble(num, q, (), scale)
        if assembled is not None:
            notes.append(f"The initial configuration cannot be assembled with {', '.join(names[i] for i in held)} "
                         "held at the model's values ([simulation] independent); it was assembled with them free.")
    if assembled is None:
        notes.append("The model's initial values do not meet the constraints and could not be moved onto them: "
                     "G's rank is given at those values.")
        return q, scale
    return assembled, scale


def _starts(initial, angles, scale) -> list[np.ndarray]:
    rng = np.random.default_rng(0)
    out = [np.array(initial, float)]
    for _ in range(STARTS - 1):
        out.append(np.array([rng.uniform(-np.pi, np.pi) if a else rng.uniform(-2 * scale, 2 * scale)
                             for a in angles]))
    return out


def _everywhere(num: _Numbers, starts, scale) -> bool:
    """G loses rank at every one of a few configurations on the constraints."""
    points = [q for q in (_assemble(num, x, scale=scale) for x in starts[1:12]) if q is not None][:6]
    return bool(points) and all(_ratio(num.G(q)) <= RANK_TOL for q in points)


class _Search:
    """The searches of one report: the configurations where a part of G loses rank, distinct, sorted
    by their distance from the initial configuration, recognized exactly where SymPy can."""

    def __init__(self, eqs, num, angles, initial, scale, exact_values, starts):
        self.eqs, self.num, self.angles, self.initial = eqs, num, angles, initial
        self.scale, self.exact_values, self.starts = scale, exact_values, starts

    def locate(self, rows, cols, det_values, rank_below):
        """([(q, where, exact, condition, dimension)], how many more points than listed)."""
        angles = self.angles
        raw = _search(self.num, self.starts, rows, cols, self.scale)

        def key(q):  # the distance from the initial configuration
            return float(np.linalg.norm(angle_difference(q, self.initial, angles)))

        points = [q for q, nullity in raw if not nullity]
        families = []
        for (vanishing, dim), members in self._groups([item for item in raw if item[1]], det_values).items():
            members.sort(key=key)  # dim: the smallest estimate (it is too large only where the set is singular)
            if self._moves(members[0], rows, cols):  # a curve (or more) of them: one entry
                families.append((self._nearest(members[0], rows, cols), dim, vanishing))
            else:  # isolated zeros where dF/dz is singular too
                points.extend(members)
        points = sorted(distinct(points, angles), key=key)
        out = []
        for q in points[:_MAX_LISTED]:
            where, exact = self._recognize(q, rows, cols, rank_below)
            out.append((q, where, exact, ", ".join(f"{k} = {_num(v)}" for k, v in where.items()), 0))
        for q, dim, condition in families:
            rounded = wrap_angles(np.where(np.abs(q) < 1e-9 * self.scale, 0.0, q), angles)  # its round-off zeroed
            q = rounded if self._is_zero(rounded, rows, cols) else wrap_angles(q, angles)
            where, exact = self._recognize(q, rows, cols, rank_below)
            out.append((q, where, exact, condition, dim))
        return out, max(0, len(points) - _MAX_LISTED)

    def _moves(self, q, rows, cols) -> bool:
        """Whether the zeros continue from q along the null direction of dF/dz (a curve of them), rather
        than q being an isolated but degenerate zero."""
        num = self.num
        system = num.system(rows, cols)
        y = np.linalg.svd(num.G(q)[rows][:, cols])[0][:, -1]
        direction = np.linalg.svd(system(np.concatenate((q, y)))[1])[2][-1][:num.n]
        if np.linalg.norm(direction) < 1e-6:
            return False
        h = 1e-3 * self.scale
        moved = _search(num, [q + h * direction / np.linalg.norm(direction)], rows, cols, self.scale)
        return bool(moved) and np.linalg.norm(moved[0][0] - q) > 0.5 * h

    def _is_zero(self, q, rows, cols) -> bool:
        """q is on the constraints and G[rows][:, cols] has lost rank there."""
        G = self.num.G(q)
        g = self.num.g(q)
        if not (np.all(np.isfinite(G)) and np.all(np.isfinite(g))):
            return False
        return (np.max(np.abs(g), initial=0.0) <= 1e-9 * self.scale
                and _ratio(G[rows][:, cols], G[self.num.hol] if self.num.hol and len(rows) != self.num.m else G)
                <= RANK_TOL)

    def _nearest(self, q, rows, cols) -> np.ndarray:
        """A point of the set of zeros through q near the initial configuration: steps towards it along
        the set's tangent, each followed back onto the set (a point that is easy to read)."""
        num = self.num
        system = num.system(rows, cols)
        for _ in range(20):
            y = np.linalg.svd(num.G(q)[rows][:, cols])[0][:, -1]
            J = system(np.concatenate((q, y)))[1]
            _, sv, Vt = np.linalg.svd(J)
            tangent = Vt[int(np.sum(sv > 1e-7 * sv[0])):, :num.n]
            basis = np.linalg.svd(tangent)[2][:_dimension(J, num.n)] if len(tangent) else np.zeros((0, num.n))
            d = angle_difference(self.initial, q, self.angles)
            step = basis.T @ (basis @ d)
            if np.linalg.norm(step) < 1e-9 * self.scale:
                break
            for fraction in (1.0, 0.5, 0.25, 0.125):  # a shorter step where the set curves away
                moved = _search(num, [q + fraction * step], rows, cols, self.scale)
                if moved and (np.linalg.norm(angle_difference(self.initial, moved[0][0], self.angles))
                              < np.linalg.norm(d)):
                    q = moved[0][0]
                    break
            else:
                break
        return q

    def _groups(self, candidates, det_values) -> dict:
        """{(condition, dimension): [q, ...]}: the zeros that are not isolated, grouped by the factors of
        the determinant that vanish there (the condition "z = 0"; "" without a determinant), with the
        smallest dimension estimated in each group."""
        factors = []
        if det_values is not None and not det_values.is_number:
            numerator = sympy.fraction(sympy.together(det_values))[0]
            coords = set(self.eqs.coordinates)
            factors = [f for f, _ in sympy.factor_list(numerator)[1] if f.free_symbols & coords]
        fns = [sympy.lambdify(list(self.eqs.coordinates), f, "numpy") for f in factors]
        groups: dict = {}
        dims: dict = {}
        for q, dim in candidates:
            vanishing = [f for f, fn in zip(factors, fns) if abs(float(fn(*q))) < 1e-8 * self.scale]
            condition = " and ".join(f"{sympy.sstr(f)} = 0" for f in vanishing)
            groups.setdefault(condition, []).append(q)
            dims[condition] = min(dim, dims.get(condition, dim))
        return {(condition, dims[condition]): members for condition, members in groups.items()}

    def _recognize(self, q, rows, cols, rank_below):
        """(where, exact): q's values, exact and verified by SymPy (g = 0, the rank lost) where each is
        recognized as a short exact number, else floats."""
        eqs = self.eqs
        names = [c.name for c in eqs.coordinates]
        exact = [_exact(v, a) for v, a in zip(q, self.angles)]
        if all(e is not None for e in exact):
            at = dict(zip(eqs.coordinates, exact))
            at.update(self.exact_values)
            on = all(sympy.simplify(to_sympy(g).subs(at)) == 0
                     for c, g in zip(eqs.model.constraints, eqs.core.g) if c.kind == HOLONOMIC)
            if on:
                A = sympy.Matrix([[to_sympy(eqs.core.G[k, j]).subs(at) for j in cols] for k in rows])
                if A.rank(iszerofunc=lambda e: sympy.simplify(e) == 0) < rank_below:
                    return dict(zip(names, exact)), True
        return {k: sympy.Float(v, 8) for k, v in zip(names, q)}, False


def _unit(v: np.ndarray) -> np.ndarray:
    """Largest component 1 (the first such positive), round-off zeroed."""
    v = np.asarray(v, float)
    v = np.where(np.abs(v) < 1e-7 * np.max(np.abs(v)), 0.0, v)
    return v / v[np.argmax(np.abs(v))] + 0.0


def _named(v, names) -> dict:
    return {k: float(x) for k, x in zip(names, _unit(v))}


def _singular_configuration(eqs, num, q, where, exact, condition, dimension) -> ConstraintConfiguration:
    G = num.G(q)
    U, s, Vt = np.linalg.svd(G)
    r = int(np.sum(s > RANK_TOL * s[0]))
    cons = [c.name for c in eqs.model.constraints]
    y = {k: w for k, w in _named(U[:, -1], cons).items() if w != 0}
    vel = [v.name for v in eqs.velocities]
    return ConstraintConfiguration(where, condition, exact, r, y, tuple(_named(v, vel) for v in _echelon(Vt[r:])),
                                   dimension=dimension)


def _echelon(B: np.ndarray) -> np.ndarray:
    """The rows of B (a basis of a subspace) recombined into reduced row echelon form: each has 1 in a
    column of its own where the others have 0, the columns chosen by QR with pivoting (the basis
    read as "these coordinates move, those stay")."""
    from scipy.linalg import qr

    if B.shape[0] <= 1:
        return B
    pivots = qr(B, pivoting=True)[2][:B.shape[0]]
    return np.linalg.solve(B[:, pivots], B)


def _dead_points(eqs, num, search: _Search, s, why, det) -> DeadPoints:
    n = eqs.n
    names = [c.name for c in eqs.coordinates]
    others = [i for i in range(n) if i not in s]
    hol = num.hol
    with_values = None if det is None else factored(det.subs(search.exact_values))
    never = bool(with_values is not None and with_values.is_number and with_values != 0)
    configurations, more = [], 0
    if not never:
        located, more = search.locate(hol, others, with_values, len(hol))
        cons = [eqs.model.constraints[k].name for k in hol]
        vel = [v.name for v in eqs.velocities]
        for q, where, exact, condition, dim in located:
            Gh = num.G(q)[hol]
            if _ratio(Gh) <= 1e-6:  # G itself loses rank there: a singular configuration, reported as such
                continue
            U, sv, Vt = np.linalg.svd(Gh[:, others])
            y = U[:, -1]
            locked_all = np.zeros(n)
            locked_all[list(s)] = (y @ Gh)[list(s)]
            locked = {vel[i]: x for i, x in enumerate(_unit(locked_all).tolist()) if i in s}
            free_all = np.zeros(n)
            free_all[others] = Vt[-1]
            rank = int(np.sum(sv > RANK_TOL * sv[0]))
            configurations.append(ConstraintConfiguration(
                where, condition, exact, rank, {k: w for k, w in _named(y, cons).items() if w != 0},
                (_named(free_all, vel),), locked, dim))
    return DeadPoints(tuple(names[i] for i in s), tuple(names[i] for i in others), why, det, tuple(configurations),
                      more, never)


def _cause_and_fix(configurations, everywhere, dead, wheels=()) -> tuple[str, str]:
    if everywhere:
        c = configurations[0]
        cause = (f"{_combination(c.dependent)} has no gradient at any configuration: one of these constraints "
                 "restates the others (the same condition written twice, or implied by the rest), so their "
                 "multipliers are never determined and a simulation cannot start.")
        fix = (f"remove one of {', '.join(c.dependent)} from the model (keep the constraints independent: one "
               "for each coordinate they fix).")
        sliding = [w.name for w in wheels if w.lateral and {f"{w.name}_x", f"{w.name}_y"} & set(c.dependent)]
        if len(sliding) > 1:  # wheels on one rigid axle: their lateral conditions are one condition twice
            fix = (f"leave out the lateral no-slip condition of one of the wheels {', '.join(sliding)} (wheels on "
                   f"one rigid axle cannot slide along it independently): lateral = false in the [[wheels]] table "
                   f"of '{sliding[-1]}' (Model.add_wheel(..., lateral=False)); it then keeps only its longitudinal "
                   f"condition {sliding[-1]}_longitudinal. Otherwise " + fix)
        return cause, fix
    if configurations:
        cause = ("at these configurations the constraints' gradients are dependent: the mechanism's links line "
                 "up (a change point), where it can move in more ways than its degrees of freedom and switch "
                 "assembly branch; the multipliers are not determined there (a simulation that lands on one stops "
                 "with this diagnosis; one that steps across it may carry on along either branch).")
        fix = ("keep the motion away from them (other initial values, a driving input), or change the "
               "dimensions so that the links cannot line up (for a four-bar: a + d != b + c, a + b != c + d, "
               "a + c != b + d).")
        return cause, fix
    stuck = [d for d in dead if d.configurations]
    if stuck:
        names = " and ".join(", ".join(d.drivers) for d in stuck)
        one = len(stuck) == 1 and len(stuck[0].drivers) == 1
        cause = (f"{names} {'reaches' if one else 'reach'} the end of {'its' if one else 'their'} travel at the "
                 "dead points: the mechanism cannot be driven through them from there (a force there does no "
                 "work), and a model that takes them as its independent coordinates cannot find the others there "
                 "(linearize refuses, a simulation holding them cannot assemble the mechanism).")
        fix = ("drive the mechanism from a coordinate that turns through (a crank, with a flywheel to carry it "
               "past), or take other coordinates as independent ([simulation] independent) near the dead points.")
        return cause, fix
    return "", ""
