"""singularities(equations): where det M = 0, the velocities with no inertia, why, and a fix.

The seed's cart with an inverted pendulum and a massless cart has det M = M^2 L^2 cos(q2)^2:
at q2 = +-pi/2 the motion q1_dot = L q2_dot (the cart sliding under a pendulum standing still)
moves no mass, and no solver can find q_ddot there.
"""

from __future__ import annotations

import functools
import itertools
import math
from dataclasses import dataclass, field
from typing import Mapping

import numpy as np
import symengine as se
import sympy

from .._limits import value_problem
from .._util import did_you_mean, real_number, shown_value
from ..errors import ModelError, Problem
from ..model._elements import Particle, RigidBody, RigidBody3D
from ._equations import Equations
from ._lambdify import lambdify
from ._readable import trigonometric_polynomial
from ._search import minimize, multistart, wrap_angle, wrap_angles

__all__ = ["diagnosis", "diagnosis_at", "singularities", "SingularityReport", "SingularConfiguration",
           "inertia_measure", "determinant",
           "factored"]

_SYMBOLIC_DET_MAX_N = 4


@dataclass(frozen=True)
class SingularConfiguration:
    """One place where det M = 0.

    Attributes
    ----------
    where : dict of str to sympy.Expr
        Coordinate values ({} when M is singular everywhere).
    condition : str
        The same as text, e.g. ``"q2 = pi/2"``.
    null_velocity : dict of str to sympy.Expr
        A velocity direction {"q1_dot": L, "q2_dot": 1} with no inertia there.
    still : tuple of str
        Elements with mass that do not move along that direction.
    moving_massless : tuple of str
        Elements whose mass is zero and that do move along it.
    """

    where: dict
    condition: str
    null_velocity: dict
    still: tuple = ()
    moving_massless: tuple = ()

    def velocity_text(self) -> str:
        items = [(k, v) for k, v in self.null_velocity.items() if v != 0]
        if len(items) == 1:
            return f"{items[0][0]} alone (every other velocity zero)"
        ref_name, ref = items[-1]
        parts = [f"{k} = {sympy.sstr(sympy.simplify(v / ref) * sympy.Symbol(ref_name))}"
                 for k, v in items[:-1]]
        return ", ".join(parts)


@dataclass(frozen=True)
class SingularityReport:
    """The diagnosis of a mass matrix (returned by :func:`singularities`).

    Attributes
    ----------
    det_mass_matrix : sympy.Expr
        det M in factored form, with symbolic parameters; for more than 4 coordinates the
        unevaluated ``sympy.Determinant(M)`` (expanding it is hopeless for long chains).
    det_with_values : sympy.Expr or None
        det M with the model's parameter values.
    singular : bool
        Whether det M vanishes at some real configuration for the parameter values.
    everywhere : bool
        Whether det M vanishes identically (every configuration).
    configurations : tuple of SingularConfiguration
    cause, fix : str
        The likely cause and how to fix the model ("" when not singular).
    """

    det_mass_matrix: sympy.Expr | None
    det_with_values: sympy.Expr | None
    singular: bool
    everywhere: bool
    configurations: tuple = ()
    cause: str = ""
    fix: str = ""
    coordinates: tuple = field(default=(), repr=False)

    def text(self) -> str:
        lines = []
        if isinstance(self.det_mass_matrix, sympy.Determinant):
            lines.append(f"det M: not expanded for {len(self.coordinates)} coordinates; its zeros are "
                         "searched for numerically.")
        elif self.det_mass_matrix is not None:
            lines.append(f"det M = {sympy.sstr(self.det_mass_matrix)}")
        if not self.singular:
            lines.append("The mass matrix is regular: det M does not vanish at any real configuration "
                         "for the parameter values.")
            return "\n".join(lines)
        if self.everywhere:
            lines.append("det M vanishes at every configuration for the parameter values: the mass matrix "
                         "is always singular.")
        else:
            conds = " or ".join(c.condition for c in self.configurations) or "some configurations"
            lines.append(f"det M vanishes where {conds}.")
        for c in self.configurations:
            at = f"At {c.condition}" if c.condition else "Everywhere"
            lines.append(f"{at}, the velocity combination {c.velocity_text()} has no inertia"
                         + (f": {_still(c.still)}." if c.still else "."))
        lines.append(f"Likely cause: {self.cause}")
        lines.append(f"Fix: {self.fix}")
        return "\n".join(lines)

    __str__ = text

    def to_dict(self) -> dict:
        s = sympy.sstr
        return {
            "singular": bool(self.singular),
            "everywhere": bool(self.everywhere),
            "det_mass_matrix": _det_text(self.det_mass_matrix),
            "det_with_values": None if self.det_with_values is None else s(self.det_with_values),
            "configurations": [
                {"where": {k: s(v) for k, v in c.where.items()}, "condition": c.condition,
                 "null_velocity": {k: s(v) for k, v in c.null_velocity.items()},
                 "still": list(c.still), "moving_massless": list(c.moving_massless)}
                for c in self.configurations],
            "cause": self.cause,
            "fix": self.fix,
            "diagnosis": self.text(),
        }


def _det_text(det) -> str | None:
    """det M as one line of SymPy syntax."""
    if det is None:
        return None
    if isinstance(det, sympy.Determinant):
        return f"Determinant(Matrix({sympy.sstr(det.arg.tolist())}))"
    return sympy.sstr(det)


def _still(names) -> str:
    return ", ".join(names) + (" stays still" if len(names) == 1 else " stay still")


def scaled_cholesky(M: np.ndarray):
    """(s, Lc) with Lc Lc^T = diag(s) M diag(s) and s = 1/sqrt(diag M), or None when M is not
    positive definite (or not finite)."""
    d = np.diag(M)
    if np.any(d <= 0) or not np.all(np.isfinite(M)):
        return None
    s = 1.0 / np.sqrt(d)
    try:
        return s, np.linalg.cholesky(M * s[:, None] * s[None, :])
    except np.linalg.LinAlgError:
        return None


def inertia_measure(M: np.ndarray, factor=None) -> float:
    """How far a symmetric M is from singular: the smallest squared pivot of the Cholesky factor
    of M scaled to a unit diagonal. 1 for a diagonal M, 0 for a singular one (or one that is not
    positive definite). Unlike det M / prod(diag M), it does not decay with the size of M.
    `factor` is ``scaled_cholesky(M)`` when the caller has it already."""
    factor = scaled_cholesky(M) if factor is None else factor
    return 0.0 if factor is None else float(np.min(np.diag(factor[1])) ** 2)


def determinant(M) -> se.Basic:
    """det M in SymEngine by expansion in minors along the rows (no division, unlike SymEngine's
    det, so a polynomial stays one); M is small, its entries in readable form."""
    n = M.shape[0]
    a = [[se.sympify(M[i, j]) for j in range(n)] for i in range(n)]
    minors = {frozenset(): se.Integer(1)}  # det of the last rows on a set of columns
    for row in range(n - 1, -1, -1):
        size = n - row
        new = {}
        for cols in itertools.combinations(range(n), size):
            total = se.Integer(0)
            for k, j in enumerate(cols):
                rest = frozenset(cols[:k] + cols[k + 1:])
                total = total + (-1) ** k * a[row][j] * minors[rest]
            new[frozenset(cols)] = total
        minors = new
    return minors[frozenset(range(n))]


def factored(expr) -> sympy.Expr:
    """`expr` (a determinant, a polynomial in sines and cosines) written short (see
    :func:`~lagrangian.equations._readable.trigonometric_polynomial`: 1 - sin(q)**2 = cos(q)**2,
    or the Fourier form when it has fewer terms), then factored by SymPy:
    ``L**2*M2*(M1 + M2*cos(q2)**2)``."""
    return sympy.factor(trigonometric_polynomial(expr))


def _values(eqs: Equations, parameters: Mapping | None = None) -> dict:
    """The parameter values, exact where they are simple numbers: the model's, those of `parameters`
    (by name) in their place."""
    names = [p.name for p in eqs.parameters]
    if parameters is not None and not isinstance(parameters, Mapping):
        raise ModelError([Problem(f"parameters must be a mapping of names to numbers, such as "
                                  f"{{'{names[0] if names else 'm'}': 1.0}}, got {type(parameters).__name__} "
                                  f"{shown_value(parameters)}", key="parameters")])
    given = {getattr(k, "name", k): v for k, v in (parameters or {}).items()}
    unknown = [k for k in given if k not in names]
    if unknown:
        raise ModelError([Problem(f"'{k}' is not a parameter of the model" + did_you_mean(k, names)
                                  + f"; its parameters are {', '.join(names) or 'none'}", key=f"parameters.{k}")
                          for k in unknown])
    bad = [(k, why) for k, v in given.items()
           if (why := value_problem(k, v if real_number(v) is None else real_number(v))) is not None]
    if bad:
        raise ModelError([Problem(why, key=f"parameters.{k}") for k, why in bad])
    values = {p: given.get(p.name, v) for p, v in eqs.parameters.items()}
    return {p: exact_number(v) for p, v in values.items() if v is not None}


def exact_number(value) -> sympy.Expr:
    """``sympy.nsimplify(value)``, kept for the next diagnosis (of the same or another model): it takes
    20 ms for some values (0.0603 -> 603/10000), and the mass matrix's and the constraints' diagnoses of a
    model ask for the same values (the bicycle's 20 parameters: 0.12 s each time). A float whose value is
    a rational number is also kept on disk (:func:`_stored_exact_numbers`), for the next process."""
    try:
        return _exact_number(type(value), value)
    except TypeError:  # not hashable
        return sympy.nsimplify(value)


@functools.lru_cache(maxsize=4096)
def _exact_number(kind, value) -> sympy.Expr:
    if not (isinstance(value, float) and math.isfinite(value)):
        return sympy.nsimplify(value)
    stored = _stored_exact_numbers()
    key = float(value).hex()
    hit = stored.get(key)
    if hit is not None and _close(hit, value):
        return sympy.Rational(*hit)
    out = sympy.nsimplify(value)
    if isinstance(out, sympy.Rational) and max(abs(out.p), out.q) < _STORED_MAX and _close((out.p, out.q), value):
        stored[key] = (int(out.p), int(out.q))
        _store_exact_numbers(stored)
    return out


#: The largest numerator or denominator of a stored exact number (a bound on what is read back).
_STORED_MAX = 10 ** 30
#: How many exact numbers the file keeps (it is read whole at the first diagnosis of a process).
_STORED_COUNT = 4096
#: A larger file is not read (4096 entries of two 30-digit numbers are about 300 KB).
_STORED_BYTES = 1 << 20


def _close(ratio: tuple[int, int], value: float) -> bool:
    """Whether p/q is `value` to 1e-14 relative (nsimplify's rationals are, to its 1e-15): a stored number
    changed on disk can move a value by no more than that (else it is computed again)."""
    from fractions import Fraction

    return abs(Fraction(*ratio) - Fraction(value)) <= Fraction(1, 10 ** 14) * abs(Fraction(value))


def _exact_numbers_path():
    """The file of stored exact numbers: in $LAGRANGIAN_CACHE_DIR or ~/.cache/lagrangian (the compile
    cache's folder), named after the SymPy and mpmath versions whose nsimplify gave them."""
    import os
    from pathlib import Path

    import mpmath

    folder = Path(os.environ.get("LAGRANGIAN_CACHE_DIR") or Path.home() / ".cache" / "lagrangian")
    return folder / f"exact-numbers-sympy-{sympy.__version__}-mpmath-{mpmath.__version__}.json"


_STORED: dict | None = None


def _stored_exact_numbers() -> dict:
    """{float.hex(): (p, q)}: the values whose ``sympy.nsimplify`` is the rational p/q, as this process
    read them from the file (or found them since); empty where the file is missing or not what this
    writes (it is only read as JSON, each entry checked: two integers, q > 0, below _STORED_MAX)."""
    global _STORED
    if _STORED is None:
        import json

        _STORED = {}
        path = _exact_numbers_path()
        try:
            raw = json.loads(path.read_text(encoding="utf-8")) if path.stat().st_size <= _STORED_BYTES else None
        except (OSError, ValueError, RecursionError):
            raw = None
        if isinstance(raw, dict):
            for k, v in list(raw.items())[:_STORED_COUNT]:
                if (isinstance(k, str) and isinstance(v, list) and len(v) == 2
                        and all(type(x) is int and abs(x) < _STORED_MAX for x in v) and v[1] > 0):
                    try:
                        float.fromhex(k)
                    except (ValueError, OverflowError):
                        continue
                    _STORED[k] = (v[0], v[1])
    return _STORED


def _store_exact_numbers(stored: dict) -> None:
    """Write `stored` to the file, atomically; nothing (silently) where that fails: it only saves time."""
    import json

    from ..io._files import write_atomically

    if len(stored) > _STORED_COUNT:
        return
    path = _exact_numbers_path()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        write_atomically(path, json.dumps({k: list(v) for k, v in stored.items()}, sort_keys=True))
    except OSError:
        pass


def _is_angle(eqs: Equations, q: sympy.Symbol) -> bool:
    """A coordinate that appears inside trigonometric functions is treated as an angle."""
    exprs = list(eqs.mass_matrix) + [eqs.V]
    for e in exprs:
        for f in e.atoms(sympy.sin, sympy.cos, sympy.tan):
            if q in f.free_symbols:
                return True
    return False


def _zeros_of_factor(eqs: Equations, f: sympy.Expr) -> list[dict] | None:
    """Real zeros of a factor of det M: a list of {q: value} (angles wrapped into (-pi, pi]),
    or None if they could not be found symbolically."""
    qs = [q for q in eqs.coordinates if q in f.free_symbols]
    if len(qs) != 1:
        return None
    q = qs[0]
    angle = _is_angle(eqs, q)
    domain = sympy.Interval.Lopen(-sympy.pi, sympy.pi) if angle else sympy.S.Reals
    try:
        sol = sympy.solveset(f, q, domain)
    except Exception:  # noqa: BLE001 - solveset raises many kinds; fall back to numerics
        return None
    if isinstance(sol, sympy.FiniteSet):
        out = []
        for v in sorted(sol, key=lambda s: float(s) if s.is_number else 0):
            if v.is_number and not v.is_real:
                continue
            out.append({q: wrap_angle(v) if angle else v})
        return out
    if sol == sympy.S.EmptySet:
        return []
    return None


def _numeric_zero_search(eqs: Equations, det_num: sympy.Expr) -> list[dict]:
    """Look for real zeros of det M numerically (equations._search: det^2, scaled, minimised by
    Nelder-Mead from 40 random starts; the zeros kept once, angles modulo 2 pi)."""
    qs = [q for q in eqs.coordinates if q in det_num.free_symbols]
    if not qs:
        return []
    func = sympy.lambdify([qs], det_num, "numpy")
    rng = np.random.default_rng(0)
    scale = max(abs(float(func(rng.uniform(-np.pi, np.pi, len(qs))))) for _ in range(20)) or 1.0
    angles = [_is_angle(eqs, q) for q in qs]

    def solve(x0):
        x, value = minimize(lambda x: (float(func(x)) / scale) ** 2, x0, method="Nelder-Mead",
                            options={"xatol": 1e-10, "fatol": 1e-24, "maxiter": 4000})
        return wrap_angles(x, angles) if value < 1e-16 else None

    found = multistart(solve, (rng.uniform(-np.pi, np.pi, len(qs)) for _ in range(40)), angles, tol=1e-5)
    return [{q: sympy.Float(v, 8) for q, v in zip(qs, x)} for x in found[:4]]


def _null_direction(M: sympy.Matrix, M_values: sympy.Matrix, where: dict,
                    numeric: bool = False) -> sympy.Matrix | None:
    """The velocity combination without inertia at `where`: SymPy's null space (exact), or, with
    `numeric` (large models, whose symbolic null space would not finish), the eigenvector of M's
    smallest eigenvalue there."""
    for mat in (() if numeric else (M, M_values)):
        at = mat.subs(where)
        try:
            ns = at.nullspace(simplify=True)
        except Exception:  # noqa: BLE001
            ns = []
        if ns:
            v = ns[0]
            nz = [x for x in v if x != 0]
            return (v / nz[-1]).applyfunc(sympy.simplify) if nz else v
    # numerical fallback
    A = M_values if isinstance(M_values, np.ndarray) else np.array(M_values.subs(where).evalf(), dtype=float)
    w, V = np.linalg.eigh(A)
    v = V[:, 0]
    v = v / v[np.argmax(np.abs(v))]
    if numeric:  # floats as they are (a fraction made of a rounded float reads as noise)
        return sympy.Matrix([sympy.Integer(0) if abs(x) < 1e-6 else sympy.Float(round(x, 6), 6) for x in v])
    return sympy.Matrix([sympy.nsimplify(round(x, 10)) for x in v])


def _element_motion(eqs: Equations, where: dict, direction: sympy.Matrix, values: dict):
    """Which massive elements stay still along `direction` at `where`, and which massless ones move."""
    still, moving_massless = [], []
    at = {**values, **where}
    # at a zero the numeric search found (floats: a large model), the rates in SymEngine, not SymPy's
    # diff, subs and simplify of the bodies' positions (a third of a second for the bicycle)
    numeric = bool(where) and all(isinstance(v, sympy.Float) for v in where.values())
    at_se = {se.Symbol(k.name): se.sympify(v) for k, v in at.items()} if numeric else None
    for el in eqs.model.elements:
        if not isinstance(el, (Particle, RigidBody, RigidBody3D)):
            continue
        coords = list(el.position) + ([el.angle] if isinstance(el, RigidBody) else [])
        if isinstance(el, RigidBody3D):  # a body in space moves when its centre or its rotation does
            coords += [f.angle for f in el.factors if f.matrix is None]
            coords += [x for f in el.factors if f.matrix is not None for row in f.matrix for x in row]
        moves = False
        for c in coords:
            if numeric:
                val = _rate_at(c, eqs.coordinates, direction, at_se)
            else:
                rate = sum(sympy.diff(c, q) * d for q, d in zip(eqs.coordinates, direction))
                val = sympy.simplify(rate.subs(at))
            if val != 0:
                moves = True
                break
        mass = sympy.sympify(el.mass).subs(values)
        massless = mass == 0
        if moves and massless:
            moving_massless.append(f"{el.kind} '{el.name}' (mass {sympy.sstr(el.mass)} = 0)")
        elif not moves and not massless:
            still.append(f"{el.kind} '{el.name}'")
    return tuple(still), tuple(moving_massless)


def _rate_at(c, coordinates, direction, at: dict):
    """d c/dt along `direction` (one velocity per coordinate) at `at` ({SymEngine symbol: number}), a
    number (SymEngine): 0 exactly where no term survives."""
    e = se.sympify(c)
    rate = se.Integer(0)
    for q, d in zip(coordinates, direction):
        if d != 0:
            rate = rate + e.diff(se.Symbol(q.name)) * se.sympify(d)
    return rate.subs(at)


def _blamed_coordinate(eqs: Equations, direction: sympy.Matrix) -> sympy.Symbol:
    support = [q for q, d in zip(eqs.coordinates, direction) if d != 0]
    translations = [q for q in support if not _is_angle(eqs, q)]
    return (translations or support)[0]


def singularities(equations: Equations, parameters: Mapping | None = None) -> SingularityReport:
    """Diagnose the mass matrix of `equations`.

    det M is computed symbolically and factored (for up to 4 coordinates; numerically beyond),
    its real zeros are found for the parameter values, and at each the velocity combination with
    no inertia is named, with the likely cause and a fix.

    Parameters
    ----------
    equations : Equations
    parameters : mapping of str to float, optional
        Parameter values that override the model's (a simulation's diagnosis uses those it ran
        with, ``--param M2=0`` included).

    Returns
    -------
    SingularityReport

    Raises
    ------
    ModelError
        A name in `parameters` that is not a parameter of the model.
    """
    return diagnosis(equations, parameters, equations.mass_matrix)


def diagnosis(equations: Equations, parameters: Mapping | None, mass_matrix) -> SingularityReport:
    """:func:`singularities` with the mass matrix given as it is to be shown (and kept in the report's
    det M): the Equations' readable M, or the derived one (equal to it) for a model too large to expand,
    whose readable M takes a second to build (the derivation report's)."""
    eqs = equations
    values = _values(eqs, parameters)
    M = sympy.Matrix(mass_matrix)
    n = eqs.n
    det = det_values = numeric_M = None
    if n <= _SYMBOLIC_DET_MAX_N:
        raw = determinant(M)
        det = factored(raw)
        det_values = factored(raw.subs({se.Symbol(p.name): v for p, v in values.items()}))
        everywhere = det_values == 0
    else:  # expanding det M of a large system is hopeless: keep it unevaluated, search numerically
        det = sympy.Determinant(sympy.ImmutableMatrix(M))
        numeric_M = _numeric_mass_matrix(eqs, values)
        everywhere = _numerically_zero_everywhere(eqs, numeric_M)
    configurations: list[SingularConfiguration] = []
    if everywhere:
        configurations.append(_configuration(eqs, M, M.subs(values), {}, values))
    else:
        zeros: list[dict] = []
        symbolic_ok = det_values is not None
        if symbolic_ok:
            factors = [f for f, _ in sympy.factor_list(det_values)[1]]
            for f in factors:
                if not (f.free_symbols & set(eqs.coordinates)):
                    continue
                z = _zeros_of_factor(eqs, f)
                if z is None:
                    zeros.extend(_numeric_zero_search(eqs, f))
                else:
                    zeros.extend(z)
        else:
            zeros = _numeric_det_search(eqs, numeric_M)
        zeros = [z for z in zeros if _may_meet_constraints(eqs, z, values)]
        # the numeric search's zeros are diagnosed with the compiled M (SymPy's subs of the parameter
        # values into the bicycle's M took 30 s)
        M_values = M.subs(values) if zeros and symbolic_ok else None
        seen = set()
        for z in zeros:
            key = tuple(sorted((k.name, sympy.sstr(v)) for k, v in z.items()))
            if key in seen:
                continue
            seen.add(key)
            configurations.append(_configuration(eqs, M, M_values, z, values, numeric=not symbolic_ok,
                                                 numeric_M=numeric_M))
    singular = bool(configurations)
    cause = fix = ""
    if singular:
        cause, fix = _cause_and_fix(eqs, configurations[0], values)
    return SingularityReport(det, det_values, singular, bool(everywhere), tuple(configurations),
                             cause, fix, tuple(q.name for q in eqs.coordinates))


def _may_meet_constraints(eqs: Equations, where: dict, values: dict) -> bool:
    """False where `where` gives every coordinate of a quaternion joint's unit-norm constraint and violates
    it: det M there (at q = 0, off the unit sphere) is no singularity of the motion. (Other constraints' are
    kept: the bicycle lying flat, off its contact constraints, is still reported, as the gimbal lock it is.)"""
    norms = {f"{j.name}_norm" for j in eqs.model.joints.values() if getattr(j, "parametrization", "") == "quaternion"}
    for c in eqs.model.constraints:
        if c.name not in norms:
            continue
        g = c.expression.xreplace(values)
        free = g.free_symbols
        if free and free <= set(where):
            try:
                if abs(float(g.xreplace({k: where[k] for k in free}))) > 1e-6:
                    return False
            except (TypeError, ValueError):
                continue
    return True


def _configuration(eqs, M, M_values, where, values, numeric: bool = False,
                   numeric_M=None) -> SingularConfiguration:
    if numeric and numeric_M is not None:  # M at `where` from the compiled M(q)
        M_values = numeric_M([float(where[q]) for q in eqs.coordinates])
    direction = _null_direction(M, M_values, where, numeric)
    cond = " and ".join(f"{q.name} = {sympy.sstr(v)}" for q, v in where.items())
    still, massless = _element_motion(eqs, where, direction, values) if direction is not None else ((), ())
    nv = {d.name: x for d, x in zip(eqs.velocities, direction)} if direction is not None else {}
    return SingularConfiguration({q.name: v for q, v in where.items()}, cond, nv, still, massless)


def _cause_and_fix(eqs: Equations, c: SingularConfiguration, values: dict,
                   blamed: sympy.Symbol | None = None) -> tuple[str, str]:
    """(cause, fix) of the singular configuration `c`; `blamed`: the coordinate to name where the
    readable M would choose it (diagnosis_at: a model too large to read it)."""
    direction = [c.null_velocity.get(v.name, 0) for v in eqs.velocities]
    has_elements = any(isinstance(e, (Particle, RigidBody, RigidBody3D)) for e in eqs.model.elements)
    if c.moving_massless:
        q = blamed or _blamed_coordinate(eqs, direction)
        cause = (f"along this motion only massless parts move: {', '.join(c.moving_massless)}; "
                 "every body with mass stays still, so the motion has no inertia.")
        fix = ("give the massless part a positive mass (set its mass parameter > 0), "
               f"or eliminate coordinate {q.name} if it is not a real degree of freedom.")
        return cause, fix
    angles = {f.angle for fr in eqs.model.frames.values() for f in fr.factors if f.matrix is None}
    rotated = [v for v, x in zip(eqs.coordinates, direction) if x != 0
               and any(v in sympy.sympify(a).free_symbols for a in angles)]
    if eqs.model.frames and len(rotated) >= 2 and not c.moving_massless:
        moving = [v.name for v, x in zip(eqs.coordinates, direction) if x != 0]
        cause = (f"the coordinates {', '.join(moving)} together describe no motion there: the frames' rotations by "
                 f"{', '.join(v.name for v in rotated)} turn about axes that line up in this configuration (the "
                 "gimbal lock of successive rotations), so the coordinates, not the bodies, are singular.")
        fix = ("keep the motion away from these configurations, or describe the rotation by other angles (another "
               "order of the elementary rotations) that are regular where the motion goes.")
        return cause, fix
    q = blamed or _blamed_coordinate(eqs, direction)  # (reads the readable M: after the gimbal lock's test)
    if has_elements:
        still = f" ({_still(c.still)})" if c.still else ""
        cause = (f"coordinate {q.name} moves no mass of its own: along this combination no element with "
                 f"mass moves{still}, as when a cart or slider is modelled without its mass "
                 "(the seed's massless cart).")
    else:
        cause = (f"T* does not depend on this combination of velocities there: the motion of coordinate "
                 f"{q.name} carries no inertia of its own (for example a massless cart or slider).")
    fix = (f"give the body that {q.name} moves a mass (add a particle or rigid body with mass whose "
           f"position depends on {q.name}, e.g. a cart of mass M1 at ({q.name}, 0), or a term "
           f"1/2*M1*{q.name}_dot**2 in T), or eliminate coordinate {q.name} from the model.")
    return cause, fix


def diagnosis_at(equations: Equations, M, state: Mapping) -> str:
    """The diagnosis of M from its numbers at one `state` (M there, an n x n array), for a model too large for
    :func:`singularities` (numeric._codegen.large_model: its M written out as trees passes 1e7 nodes; the
    readable M, det M's search and SymPy's forms of it would take minutes to hours): the velocity combination
    with the least inertia there (the least eigenvector of M scaled to a unit diagonal), the likely cause and a
    fix, in the words of :meth:`SingularityReport.text`. Reads no symbolic M; bounded by one n x n eigensolve."""
    M = np.asarray(M, dtype=float)
    n = equations.n
    d = np.diag(M).copy()
    ok = np.isfinite(M).all() and np.all(d > 0) and M.shape == (n, n)
    lines = [f"det M: not expanded or searched for a model this large ({n} coordinates); M is diagnosed from "
             "its numbers in this state."]
    if not ok:
        bad = ([v.name for v, x in zip(equations.velocities, d) if not x > 0]
               if M.shape == (n, n) and np.isfinite(M).all() else [])
        what = (f"the diagonal entry of M of {', '.join(bad)} is zero, negative or not finite in this state: that "
                "velocity carries no inertia of its own" if bad else "M is not finite in this state")
        return "\n".join(lines + [f"Likely cause: {what}.",
                                   "Fix: give the body that this coordinate moves a mass or inertia, or eliminate the "
                                   "coordinate from the model."])
    s = 1.0 / np.sqrt(d)
    values, vectors = np.linalg.eigh(M * s[:, None] * s[None, :])
    direction = s * vectors[:, 0]
    direction = direction / np.max(np.abs(direction))
    # the largest components first, equal ones (to 6 digits) in the coordinates' order; the first scaled to 1
    order = sorted(range(n), key=lambda i: (-round(abs(float(direction[i])), 6), i))
    direction = direction / direction[order[0]]
    support = [i for i in order if abs(direction[i]) >= 1e-3]
    shown = ", ".join(f"{equations.velocities[i].name} = {direction[i]:.3g}" for i in support[:8])
    more = f" and {len(support) - 8} more" if len(support) > 8 else ""
    lines.append(f"Here the velocity combination {shown}{more} has almost no inertia (the least eigenvalue of M "
                 f"scaled to a unit diagonal is {values[0]:.3g}, the largest {values[-1]:.3g}).")
    nv = {equations.velocities[i].name: float(direction[i]) for i in support}
    where = {k: v for k, v in state.items() if k in {q.name for q in equations.coordinates}}
    c = SingularConfiguration(where, "", nv)
    blamed = equations.coordinates[support[0]]
    cause, fix = _cause_and_fix(equations, c, {}, blamed=blamed)
    return "\n".join(lines + [f"Likely cause: {cause}", f"Fix: {fix}"])


def _numeric_mass_matrix(eqs: Equations, values: dict):
    """M(q) with the parameter `values` (see _values) as a fast function of q (SymEngine), for large n."""
    core = eqs.core
    values = {se.Symbol(p.name): float(v) for p, v in values.items()}
    n = eqs.n
    entries = [core.M[i, j].subs(values).subs({core.t: 0}) for i in range(n) for j in range(n)]
    f = lambdify(list(core.q), entries)
    return lambda x: np.asarray(f(np.asarray(x, float)), dtype=float).reshape(n, n)


def _numerically_zero_everywhere(eqs, M) -> bool:
    rng = np.random.default_rng(1)
    return all(inertia_measure(M(rng.uniform(-np.pi, np.pi, eqs.n))) < 1e-12 for _ in range(8))


def _numeric_det_search(eqs, M) -> list[dict]:
    """For large n: a local minimisation of the inertia measure of M (a function of q) from a few
    random starts (equations._search), the first zero found."""
    rng = np.random.default_rng(2)

    def solve(x0):
        x, value = minimize(lambda x: inertia_measure(M(x)), x0, method="Powell",
                            options={"maxfev": 400 * eqs.n, "xtol": 1e-9, "ftol": 1e-16})
        return x if value < 1e-12 else None

    found = multistart(solve, (rng.uniform(-np.pi, np.pi, eqs.n) for _ in range(4)), first=True)
    return [{q: sympy.Float(v, 8) for q, v in zip(eqs.coordinates, x)} for x in found]
