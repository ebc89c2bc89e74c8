"""The one root search: Newton and least squares from many starts, roots told apart modulo 2 pi.

Four searches use it, each with its own residual:

* the equilibria and steady motions (``analysis._roots``: f(q) = 0, or f + G^T lambda = 0 and g = 0);
* the zeros of det M (``equations._singular``: det M(q)^2 and the inertia measure minimised);
* where the constraint Jacobian loses rank (``equations._constraint_singular``: g(q) = 0,
  A(q)^T y = 0, |y| = 1);
* the consistent initial state (``numeric._constrained.consistent_state``: g(q) = 0 with some
  coordinates held) and the assembly of a mechanism at a guess (``_constraint_singular``).

Its parts: :func:`newton` (Powell's hybrid method where the rows are as many as the unknowns,
Levenberg-Marquardt otherwise, MINPACK's both), :func:`least_squares` (Levenberg-Marquardt to
round-off, for systems that are singular at their roots), :func:`gauss_newton` (steps of the
smallest change: the assembly onto g = 0 and the polish of a root), :func:`minimize` (a scalar
measure driven to 0), :func:`multistart` (each start solved, the roots kept once), and one rule for
angles: :func:`wrap_angles` into (-pi, pi] (exact numbers too, :func:`wrap_angle`),
:func:`angle_difference` and :func:`same_point`. A residual is a function of the unknowns that
returns (r, dr/dz) as NumPy arrays.

The tolerances are named once, here; each search states which it uses.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Iterable, Sequence

import numpy as np
import sympy

__all__ = ["NEWTON_XTOL", "NUDGE", "PRECISE", "ROUND_OFF", "SAME_POINT", "STEP_ROUND_OFF", "angle_difference",
           "distinct", "gauss_newton", "least_squares", "minimize", "multistart", "newton", "same_point", "wrap_angle",
           "wrap_angles"]

#: Values this small (1e-17 left by cos(pi/2)) are exact zeros once wrapped.
ROUND_OFF = 1e-13
#: Two roots are one when every component differs by at most this, relative to 1 + |q| (angles
#: modulo 2 pi).
SAME_POINT = 1e-6
#: The step tolerance of Powell's and Levenberg-Marquardt's iterations in :func:`newton`.
NEWTON_XTOL = 1e-13
#: The tolerances of :func:`least_squares`: driven to round-off, for roots that are singular.
PRECISE = 1e-15
#: A Gauss-Newton step this short, relative to the size of x, is round-off: the polish ends.
STEP_ROUND_OFF = 1e-15
#: A guess where the residual is not finite or flat is moved by this, relative to the length scale.
NUDGE = 1e-3

Residual = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]


# --------------------------------------------------------------------------- angles
def wrap_angle(value):
    """One angle in (-pi, pi]: a float, or an exact SymPy number kept exact (3*pi/2 -> -pi/2);
    anything else (a symbol, a value that is not finite) as it is."""
    if isinstance(value, sympy.Basic):
        if value.is_number and math.isfinite(float(value)):
            k = sympy.floor((value + sympy.pi) / (2 * sympy.pi))
            w = sympy.nsimplify(value - 2 * sympy.pi * k)
            return sympy.pi if w == -sympy.pi else w
        return value
    return float(wrap_angles(np.array([value], float), [True])[0])


def wrap_angles(q, angles: Sequence[bool]) -> np.ndarray:
    """q with its angles (where `angles` is True) in (-pi, pi], -pi given as pi; round-off next to 0
    (|q| <= ROUND_OFF) set to 0 in every component."""
    q = np.array(q, dtype=float)
    q[np.abs(q) <= ROUND_OFF] = 0.0
    for i, a in enumerate(angles):
        if a and math.isfinite(q[i]):
            w = math.remainder(q[i], 2 * math.pi)
            q[i] = math.pi if w <= -math.pi + 1e-12 else w
    return q


def angle_difference(a, b, angles: Sequence[bool]) -> np.ndarray:
    """a - b, its angles' components modulo 2 pi in [-pi, pi] (angles a whole turn apart are the same)."""
    d = np.array(a, dtype=float) - np.asarray(b, dtype=float)
    for i, is_angle in enumerate(angles):
        if is_angle:
            d[i] = math.remainder(d[i], 2 * math.pi)
    return d


def same_point(a, b, angles: Sequence[bool], tol: float = SAME_POINT) -> bool:
    """Whether a and b are one point: every component within `tol` (1 + |a|), angles modulo 2 pi."""
    return bool(np.all(np.abs(angle_difference(a, b, angles)) <= tol * (1 + np.abs(a))))


def distinct(points: Iterable, angles: Sequence[bool], tol: float = SAME_POINT) -> list[np.ndarray]:
    """The points wrapped (:func:`wrap_angles`), each kept once (:func:`same_point`), in their order."""
    out: list[np.ndarray] = []
    for p in points:
        p = wrap_angles(p, angles)
        if not any(same_point(p, o, angles, tol) for o in out):
            out.append(p)
    return out


# --------------------------------------------------------------------------- one solve
def _padded(fun: Residual, k: int, rows: int) -> Residual:
    """`fun` with zero rows below, up to `k` (MINPACK's Levenberg-Marquardt wants rows >= unknowns)."""
    pad = max(0, k - rows)
    if not pad:
        return fun

    def padded(z):
        r, J = fun(z)
        m = len(r)
        out, jac = np.zeros(m + pad), np.zeros((m + pad, k))  # np.concatenate and np.vstack's arrays, made
        out[:m] = r                                            # without their checks (MINPACK calls it
        jac[:m] = J                                            # thousands of times)
        return out, jac

    return padded


def _memo(fun: Residual) -> Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]:
    """`fun` evaluated once per point: MINPACK asks for r and dr/dz at a point separately (one evaluation
    serves both), as SciPy's MemoizeJac does (a new evaluation where the point differs from the last one,
    compared as np.array_equal does), without its checks."""
    last: list = [None, None]

    def evaluate(z):
        if last[0] is None or last[0].shape != np.shape(z) or not (last[0] == z).all():
            last[:] = [np.array(z, dtype=float), fun(z)]
        return last[1]

    return evaluate


def newton(fun: Residual, z0, rows: int):
    """The solution of r(z) = 0 from z0 (`rows`: the length of r): Powell's hybrid method where the
    rows are as many as the unknowns or fewer (zero rows added), Levenberg-Marquardt where they are
    more (the minimum of |r|). Returns the last iterate, checked by the caller; None where the solve
    raised (a residual that is not finite).

    MINPACK's hybrj and lmder are called as SciPy's root(jac=True, method="hybr" or "lm") calls them
    (through fsolve and leastsq, with the same arguments: the same iterates bit for bit), without
    root's wrappers of each evaluation (MemoizeJac, the counters)."""
    from scipy.optimize import fsolve, leastsq

    z0 = np.asarray(z0, dtype=float)
    k = len(z0)
    evaluate = _memo(_padded(fun, k, rows))
    try:
        with np.errstate(all="ignore"):
            if rows <= k:
                return fsolve(lambda z: evaluate(z)[0], z0, fprime=lambda z: evaluate(z)[1], full_output=True,
                              xtol=NEWTON_XTOL)[0]
            return leastsq(lambda z: evaluate(z)[0], z0, Dfun=lambda z: evaluate(z)[1], full_output=True,
                           xtol=NEWTON_XTOL, ftol=PRECISE)[0]
    except (ValueError, FloatingPointError, np.linalg.LinAlgError):
        return None


def least_squares(fun: Residual, z0, rows: int):
    """The minimum of |r(z)| from z0 by Levenberg-Marquardt with every tolerance at PRECISE (round-off:
    for roots where dr/dz is singular, which converge linearly); zero rows added where the rows are fewer
    than the unknowns. Returns the last iterate, checked by the caller; None where the solve raised."""
    from scipy.optimize import least_squares as lm

    z0 = np.asarray(z0, dtype=float)
    evaluate = _memo(_padded(fun, len(z0), rows))
    try:
        if _lm_diag_none():  # least_squares' own call of MINPACK, without its wrappers of each evaluation
            from scipy.optimize import leastsq

            if not (np.all(np.isfinite(z0)) and np.all(np.isfinite(evaluate(z0)[0]))):
                return None  # where least_squares raises ValueError (x0, or the residuals there, not finite)
            return leastsq(lambda z: evaluate(z)[0], z0, Dfun=lambda z: evaluate(z)[1], full_output=True,
                           ftol=PRECISE, xtol=PRECISE, gtol=PRECISE, maxfev=50 * len(z0))[0]
        res = lm(lambda z: evaluate(z)[0], z0, jac=lambda z: evaluate(z)[1], method="lm", xtol=PRECISE, ftol=PRECISE,
                 gtol=PRECISE, max_nfev=50 * len(z0))
    except (ValueError, np.linalg.LinAlgError, FloatingPointError):
        return None
    return res.x


@functools.cache
def _lm_diag_none() -> bool:
    """Whether SciPy's least_squares(method="lm") calls MINPACK's lmder with diag=None (x_scale="jac", its
    default from SciPy 1.16): then leastsq(Dfun=..., diag=None) makes the same call, the same iterates, without
    least_squares' VectorFunction around each evaluation (a third of the constraints' diagnosis of the bicycle)."""
    import scipy

    try:
        return tuple(int(x) for x in scipy.__version__.split(".")[:2]) >= (1, 16)
    except ValueError:
        return False


def gauss_newton(fun: Residual, x, free: Sequence[int] | None = None, *, iterations: int,
                 small: float | Callable[[np.ndarray, np.ndarray, np.ndarray], bool], polish: int = 0,
                 step_tol: float = 0.0, max_step: float = math.inf, nudge: float = 0.0, rcond: float | None = None,
                 seed: int = 1) -> tuple[np.ndarray, bool]:
    """(x moved onto r(x) = 0, whether r got small) by Gauss-Newton steps of the smallest change in
    x[free] (the others held), each at most `max_step` long (its largest component).

    `fun(x)` returns r and dr/dx[free] (the columns of the free components). r is small where
    max |r| <= `small` (or where ``small(r, J, x)`` says so); the steps go on `polish` times more
    from there (to round-off), or until one is at most `step_tol` long. Where r or its Jacobian is not
    finite (0/0 at a guess: the pivot of a mechanism), or the Jacobian vanishes (a guess where a
    constraint is flat: y = 0 on a circle), x[free] is moved off by `nudge` times a normal draw
    (with nudge 0 the solve stops there, not converged)."""
    x = np.array(x, dtype=float)
    free = list(range(len(x))) if free is None else list(free)
    rng = np.random.default_rng(seed)
    polished = 0
    for _ in range(iterations):
        r, J = fun(x)
        if not r.size:
            return x, True
        finite = bool(np.all(np.isfinite(r)) and np.all(np.isfinite(J)))
        ok = finite and (small(r, J, x) if callable(small) else bool(np.max(np.abs(r)) <= small))
        if not finite or (not ok and J.size and np.max(np.abs(J)) == 0.0):
            if not nudge:
                return x, False
            x[free] += nudge * rng.standard_normal(len(free))
            continue
        if ok and polished >= polish:
            return x, True
        dx = np.linalg.lstsq(J, r, rcond=rcond)[0]
        step = float(np.max(np.abs(dx), initial=0.0))
        if ok:
            polished += 1
            if step <= step_tol:
                return x, True
        x[free] -= dx * (max_step / step) if step > max_step else dx
    return x, polished > 0


def minimize(measure: Callable[[np.ndarray], float], x0, *, method: str, options: dict):
    """(x, measure(x)) at a local minimum of a scalar measure from x0 (SciPy's `method`: Nelder-Mead for a
    squared function, Powell for one without derivatives)."""
    from scipy.optimize import minimize as scipy_minimize

    res = scipy_minimize(measure, np.asarray(x0, dtype=float), method=method, options=options)
    return res.x, float(res.fun)


def multistart(solve: Callable[[np.ndarray], np.ndarray | None], starts: Iterable,
               angles: Sequence[bool] | None = None, *, tol: float = SAME_POINT, first: bool = False,
               found: list | None = None) -> list[np.ndarray]:
    """The roots `solve` finds from each start (None: none from there), each kept once (:func:`same_point`
    with `angles`; every root kept without `angles`), in the order found; only the first with `first`.
    `found` (a list) collects them as they come.

    `solve` is a function of its start: with `angles`, a start equal (bit for bit) to an earlier one that
    gave a root is not solved again, as its root would be the same point and not kept (the equilibria's
    starts repeat the grid's all-zero and all-pi points: the bicycle's upright start alone took 400
    evaluations of its residual, twice)."""
    found = [] if found is None else found
    rooted: set[bytes] = set()  # the starts that gave a root
    for start in starts:
        start = np.asarray(start, dtype=float)
        key = start.tobytes() if angles is not None else None
        if key is not None and key in rooted:
            continue
        z = solve(start)
        if z is None:
            continue
        if key is not None:
            rooted.add(key)
        if angles is None or not any(same_point(z, other, angles, tol) for other in found):
            found.append(z)
            if first:
                break
    return found
