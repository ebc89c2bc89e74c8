"""The roots of a stationary problem: found, checked, grouped, and explained when there is none.

Answers are right or absent:

* SymPy's exact solutions come first (``_stationary``); a multi-start numerical search runs as well.
* Every candidate, exact or numerical, is checked to be a root: the residual is small relative to
  the scale of the forces (measured at the starting points, not at the candidate), the Newton
  correction there is small relative to the point, and no coordinate has run away. Where the
  Jacobian is singular the Newton test is done again in 50-digit arithmetic, so that forces that
  underflow to 0 far away (exp(-x**2) at x = 45) are not taken for roots. A search that drifts to
  r = 1e25 because the forces tend to 0 at infinity finds nothing, and says so.
* The images of the numerical roots under changes of sign of the coordinates are tested as roots
  too (a symmetric model's mirror images: a bicycle turning left and right), whichever one the
  starts found; a root reported once, wrapped, polished and compared modulo 2 pi in angles.
* A root where the Jacobian is singular is tested for being non-isolated (a curve or surface of
  roots): the roots found on one connected set are reported once, with its dimension.
* When there is none, the reasons are given: a condition on the parameters that fails
  ("dV/dx = -g*(m1 - m2) is never 0"), SymPy's proof, a search that found nothing or ran away.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import sympy

from ..equations._search import (
    STEP_ROUND_OFF,
    angle_difference,
    gauss_newton,
    multistart,
    newton,
    same_point,
    wrap_angles,
)
from ..model._kinematics import to_sympy
from ._setting import Setting
from ._stationary import StationaryProblem, conditions_hold, constant_map, residual

__all__ = ["Search", "search_context", "is_root", "solve_from", "numeric_roots", "mirror_images", "RootSet",
           "group_roots", "free_axes", "no_root_reasons", "runaway_notes", "completeness_notes"]

#: A root's residual, relative to the scale of the forces.
_RESIDUAL = 1e-9
#: A root's Newton correction, relative to 1 + |q|.
_NEWTON = 1e-6
#: Steps of a walk between two roots without getting nearer before it gives up.
_STALL = 30
#: Walks between groups of roots that failed one after the other before the grouping stops.
_FAILED_IN_A_ROW = 40


# --------------------------------------------------------------------------- the search
@dataclass
class Search:
    """What the numerical search needs at one setting, and what it saw."""

    problem: StationaryProblem
    setting: Setting
    force_scale: float
    far: float
    starts: int = 0
    runaway: dict = field(default_factory=dict)  # coordinate name -> number of starts that ran away along it
    lasting: set = field(default_factory=set)  # names along which a runaway ended where the forces had not faded


def search_context(problem: StationaryProblem, setting: Setting) -> Search:
    """The scales of the search at this setting (cached per problem)."""
    key = (tuple(setting.p), tuple(setting.u), setting.t)
    ctx = problem._contexts.get(key)
    if ctx is not None:
        return ctx
    p = setting.p[np.isfinite(setting.p)]
    big = max([1.0, *np.abs(p)])
    magnitudes = []
    starts = _starts(problem, setting, 12, 11)[:16]
    for q in starts:
        with np.errstate(all="ignore"):
            r, _ = residual(problem, setting, q)
        if r.size and np.all(np.isfinite(r)) and np.abs(r).max() > 0:
            magnitudes.append(float(np.abs(r).max()))
    scale = float(np.median(magnitudes)) if magnitudes else 1.0
    if problem.evaluator is not None:  # a numerical residual that vanishes everywhere (no force) is round-off
        terms = [problem.evaluator.term_scale(setting, q) for q in starts]
        terms = [x for x in terms if math.isfinite(x) and x > 0]
        scale = max(scale, float(np.median(terms)) if terms else 1.0)
    ctx = Search(problem, setting, scale, 1e6 * big)
    if len(problem._contexts) > 64:
        problem._contexts.clear()
    problem._contexts[key] = ctx
    return ctx


def _checked_residual(ctx: Search, q: np.ndarray):
    """(r, J, whether r is small against the scale of the forces) at q; None where not finite."""
    with np.errstate(all="ignore"):
        r, J = residual(ctx.problem, ctx.setting, q)
    if not (np.all(np.isfinite(r)) and np.all(np.isfinite(J))):
        return None
    return r, J, _small(ctx, r, J, q)


def _small(ctx: Search, r: np.ndarray, J: np.ndarray, q: np.ndarray) -> bool:
    """Whether the residual r (Jacobian J) at q is small against the scale of the forces."""
    z = q[list(ctx.problem.unknowns)]
    scale = max(ctx.force_scale, float(np.abs(J).max(initial=0.0)) * (1.0 + float(np.abs(z).max(initial=0.0))))
    return bool(not r.size or np.abs(r).max() <= _RESIDUAL * scale)


def is_root(ctx: Search, q: np.ndarray) -> bool:
    """Whether q (full) is a root of the stationary equations: finite, within reach, residual small
    against the scale of the forces, Newton correction small against the point."""
    problem = ctx.problem
    if not np.all(np.isfinite(q)):
        return False
    unk = list(problem.unknowns)
    z = q[unk]
    if any(not problem.angles[i] and abs(q[i]) > ctx.far for i in unk):
        return False
    if problem.evaluator is not None and not problem.evaluator.meets_constraints(ctx.setting, q):
        return False
    checked = _checked_residual(ctx, q)
    if checked is None:
        return False
    r, J, small = checked
    if not r.size:
        return True
    if not small:
        return False
    step = np.linalg.lstsq(J, r, rcond=1e-12)[0] if J.size else np.zeros(0)
    if not np.all(np.abs(step) <= _NEWTON * (1.0 + np.abs(z))):
        return False
    sv = np.linalg.svd(J, compute_uv=False) if J.size else np.zeros(0)
    if sv.size and sv.min() <= 1e-8 * sv.max(initial=0.0) or (sv.size and sv.max() == 0):
        # a singular Jacobian: a multiple or non-isolated root, or forces that underflow to 0 far
        # away (exp(-x**2) at x = 45): decide in 50-digit arithmetic, or, for a numerical residual
        # (no symbolic rows), ask for one at round-off
        if problem.evaluator is not None:
            return bool(np.abs(r).max() <= 1e-12 * max(ctx.force_scale, float(np.abs(J).max())))
        return _precise_newton_ok(ctx, q)
    return True


def _precise_newton_ok(ctx: Search, q: np.ndarray) -> bool:
    """The Newton test of is_root in 50-digit arithmetic, from the symbolic stationary rows."""
    import mpmath

    problem = ctx.problem
    eqs = problem.equations
    unk = list(problem.unknowns)
    xs = [problem.variables[i] for i in unk]
    if not problem._precise:
        rows = sympy.Matrix([problem.static_sympy[i] for i in problem.rows])
        args = [*xs, *problem.constants, eqs.t]
        problem._precise.append((sympy.lambdify(args, rows, modules="mpmath"),
                                 sympy.lambdify(args, rows.jacobian(xs), modules="mpmath")))
    fr, fj = problem._precise[0]
    with mpmath.workdps(50):
        args = [mpmath.mpf(float(v)) for v in (*q[unk], *problem.constant_values(ctx.setting), ctx.setting.t)]
        try:
            r = mpmath.matrix(fr(*args))
            J = mpmath.matrix(fj(*args))
        except (ZeroDivisionError, ValueError, TypeError, OverflowError):
            return False
        U, S, V = mpmath.svd_r(J)
        smax = max((abs(x) for x in S), default=mpmath.mpf(0))
        step = mpmath.matrix(len(unk), 1)
        for k in range(len(S)):
            if smax and abs(S[k]) > mpmath.mpf(10) ** -40 * smax:
                coef = sum(U[i, k] * r[i] for i in range(r.rows)) / S[k]
                for j in range(len(unk)):
                    step[j] += V[k, j] * coef
        return all(abs(step[j]) <= _NEWTON * (1 + abs(q[unk[j]])) for j in range(len(unk)))


def solve_from(problem: StationaryProblem, setting: Setting, start: np.ndarray,
               ctx: Search | None = None) -> np.ndarray | None:
    """A root of the stationary equations found from `start` (full q); None when the solve does
    not end at one (is_root). The solve is equations._search.newton (Powell's hybrid method, or
    Levenberg-Marquardt where the rows outnumber the unknowns)."""
    ctx = ctx or search_context(problem, setting)
    idx = list(problem.unknowns)
    q = np.array(start, dtype=float)
    if not idx:
        return wrap_angles(q, problem.angles)

    def fun(z):
        q[idx] = z
        return residual(problem, setting, q)

    z = newton(fun, q[idx], len(problem.rows))
    if z is None:
        return None
    out = np.array(start, dtype=float)
    out[idx] = z
    # checked where it is reported, angles wrapped: an angle that ran away to 1e17 turns is a root
    # of the floating-point residual only (th1 + th2 rounded to the spacing of the doubles there)
    wrapped = wrap_angles(out, problem.angles) if np.all(np.isfinite(out)) else out
    if not is_root(ctx, wrapped):
        _note_runaway(ctx, start, out)
        return None
    return wrapped


def _note_runaway(ctx: Search, start: np.ndarray, end: np.ndarray) -> None:
    problem = ctx.problem
    for i in problem.unknowns:
        if not problem.angles[i] and (not math.isfinite(end[i]) or abs(end[i]) > 1e4 * (1 + abs(start[i]))):
            name = problem.variables[i].name
            ctx.runaway[name] = ctx.runaway.get(name, 0) + 1
            with np.errstate(all="ignore"):
                r = residual(problem, ctx.setting, end)[0] if np.all(np.isfinite(end)) else np.array([np.nan])
            if not (r.size == 0 or np.abs(r).max() <= 1e-3 * ctx.force_scale):
                ctx.lasting.add(name)


def _starts(problem: StationaryProblem, setting: Setting, count: int, seed: int) -> list[np.ndarray]:
    n = problem.size
    rng = np.random.default_rng(seed)
    p = np.abs(setting.p[np.isfinite(setting.p)])
    lengths = sorted({float(x) for x in p if x > 0} | {1.0})
    starts = [np.zeros(n)]
    angles = [i for i in problem.unknowns if problem.angles[i]]
    if 0 < len(angles) <= 8:  # every combination of 0 and pi: the equilibria of chains of pendulums
        for bits in range(1, 2 ** len(angles)):
            q = np.zeros(n)
            for b, i in enumerate(angles):
                q[i] = math.pi if bits >> b & 1 else 0.0
            starts.append(q)
    angle_grid = [0.0, math.pi, math.pi / 2, -math.pi / 2, math.pi / 4, -3 * math.pi / 4]
    for k in range(count):
        q = np.zeros(n)
        for i in problem.unknowns:
            if problem.angles[i]:
                q[i] = angle_grid[k % len(angle_grid)] if k < len(angle_grid) else rng.uniform(-math.pi, math.pi)
            else:
                scale = lengths[k % len(lengths)] * 10.0 ** rng.uniform(-2, 1)
                q[i] = scale * rng.choice([-1, 1]) if k else 0.0
        starts.append(q)
    if problem.multipliers:  # each start's multipliers: those that balance its forces best
        from ._constrained_static import balancing_multipliers

        starts = [balancing_multipliers(problem, setting, q) for q in starts]
    return starts


def numeric_roots(problem: StationaryProblem, setting: Setting, *, starts: int | None = None,
                  seed: int = 0, guesses=(), ctx: Search | None = None) -> list[np.ndarray]:
    """Distinct roots of the multi-start search (from `guesses` first); none when a condition on
    the parameters fails."""
    if conditions_hold(problem, setting):
        return []
    ctx = ctx or search_context(problem, setting)
    k = sum(1 for i in problem.unknowns if i < problem.equations.n)  # the multipliers follow the coordinates
    count = starts if starts is not None else 24 + 24 * k
    points = [*guesses, *_starts(problem, setting, count, seed)]
    ctx.starts += len(points)
    return multistart(lambda start: solve_from(problem, setting, start, ctx), points, problem.angles)


def mirror_images(ctx: Search, roots: list[np.ndarray]) -> list[np.ndarray]:
    """The images of the roots under changes of sign of the coordinates that are roots too, and
    not among `roots` (those of a symmetric model: the bicycle's turn to the right as well as to
    the left, whichever one the starts led to). Each image is tested as any root is (is_root);
    only of isolated roots (a set of roots is walked as a set); none for more than 6 unknown
    coordinates, or with multipliers among the variables."""
    problem = ctx.problem
    coords = [i for i in problem.unknowns if i < problem.equations.n]
    if problem.multipliers or not 0 < len(coords) <= 6:
        return []

    def size(q):  # the residual alone (a numerical residual's Jacobian costs 2 evaluations per unknown)
        with np.errstate(all="ignore"):
            r = (problem.evaluator.values(ctx.setting, q)[3] if problem.evaluator is not None
                 else residual(problem, ctx.setting, q)[0])
        return float(np.max(np.abs(r), initial=0.0)) if np.all(np.isfinite(r)) else math.inf

    def isolated(q):  # a Jacobian of full rank (a set of roots, a ring, is found and walked as a set)
        with np.errstate(all="ignore"):
            J = residual(problem, ctx.setting, q)[1]
        if not (J.size and np.all(np.isfinite(J))):
            return False
        sv = np.linalg.svd(J, compute_uv=False)
        return bool(sv.max() > 0 and np.sum(sv > 1e-9 * sv.max()) == J.shape[1])

    out: list[np.ndarray] = []
    for q in roots:
        if not isolated(q):
            continue
        # the image of a root of a symmetric problem is a root to the same round-off: a far larger
        # residual (one that is_root lets pass next to a singular point) is no image
        bound = 10.0 * size(q) + 1e-13 * ctx.force_scale
        for bits in range(1, 2 ** len(coords)):
            flipped = [i for b, i in enumerate(coords) if bits >> b & 1]
            if not np.any(q[flipped]):  # a sign change of zeros: the same point
                continue
            image = np.array(q, dtype=float)
            image[flipped] = -image[flipped]
            image = wrap_angles(image, problem.angles)
            if any(same_point(image, other, problem.angles) for other in (*roots, *out)):
                continue
            if size(image) <= bound and is_root(ctx, image):
                out.append(image)
    return out


# --------------------------------------------------------------------------- non-isolated roots
@dataclass(frozen=True)
class RootSet:
    """A root, or one point standing for a connected set of roots.

    `tangent` (shape (n, d)) spans the directions along which the roots continue (d = 0: isolated)."""

    q: np.ndarray
    tangent: np.ndarray
    exact: dict | None = None
    conditions: tuple = ()
    solution: dict | None = None

    @property
    def dimension(self) -> int:
        return self.tangent.shape[1]


def _project(ctx: Search, q: np.ndarray, iterations: int = 60) -> np.ndarray | None:
    """Gauss-Newton with minimal-norm corrections from q onto the roots, polished to round-off;
    None when it fails."""
    problem = ctx.problem
    unk = list(problem.unknowns)
    q = np.array(q, dtype=float)

    def fun(x):
        with np.errstate(all="ignore"):
            return residual(problem, ctx.setting, x)

    q, ok = gauss_newton(fun, q, unk, iterations=iterations, small=lambda r, J, x: _small(ctx, r, J, x), polish=3,
                         rcond=1e-10,
                         step_tol=STEP_ROUND_OFF * (1.0 + float(np.abs(q[unk]).max(initial=0.0))))
    return q if ok else None


def _tangent(ctx: Search, q: np.ndarray) -> np.ndarray:
    """The directions (columns, in full q) along which the roots through q continue."""
    problem = ctx.problem
    n, unk = problem.size, list(problem.unknowns)
    with np.errstate(all="ignore"):
        _, J = residual(problem, ctx.setting, q)
    k = len(unk)
    if not np.all(np.isfinite(J)):  # no derivative there (a numerical residual next to a singular point)
        return np.zeros((n, 0))
    if J.size:
        s, vt = np.linalg.svd(J)[1:]
        rank = int(np.sum(s > 1e-9 * s.max())) if s.size and s.max() > 0 else 0
        null = vt[rank:].T
    else:
        null = np.eye(k)
    h = 1e-3 * (1.0 + float(np.abs(q[unk]).max(initial=0.0)))
    directions = []
    for v in null.T:
        moved = np.array(q, dtype=float)
        moved[unk] += h * v
        landed = _project(ctx, moved)
        if landed is not None and np.linalg.norm(landed[unk] - q[unk]) >= 0.5 * h:
            full = np.zeros(n)
            full[unk] = v
            directions.append(full)
    return np.array(directions).T if directions else np.zeros((n, 0))


def _connected(ctx: Search, a: np.ndarray, b: np.ndarray, budget: int = 400) -> bool:
    """Whether a path of roots joins a and b: walk from a on the set of roots, each step along the
    set's tangent towards b, projected back onto the roots; the step shrinks where the walk strays."""
    problem = ctx.problem
    unk = list(problem.unknowns)

    def towards(c):
        return angle_difference(b, c, problem.angles)[unk]

    c = np.array(a, dtype=float)
    h = 0.1 * (1.0 + float(np.linalg.norm(towards(c))))
    best, since = math.inf, 0
    for _ in range(budget):
        gap = towards(c)
        dist = float(np.linalg.norm(gap))
        if dist <= 1e-6 * (1.0 + float(np.abs(c[unk]).max(initial=0.0))):
            return True
        if dist < (1.0 - 1e-3) * best:
            best, since = dist, 0
        else:
            since += 1
            if since > _STALL:  # stuck where the set passes nearest b: b is on another set, or far round this one
                return False
        t = _tangent(ctx, c)[unk]
        if not t.shape[1]:
            return False
        t, _ = np.linalg.qr(t)
        step = t @ (t.T @ gap)
        if np.linalg.norm(step) <= 1e-3 * dist:  # b lies straight across the set: go round it
            step = t[:, 0] * dist
        length = min(h, dist, float(np.linalg.norm(step)))
        moved = np.array(c)
        moved[unk] += step * (length / np.linalg.norm(step))
        if dist <= h:  # close enough: go straight for b
            moved[unk] = c[unk] + gap
        landed = _project(ctx, moved)
        if landed is None or np.linalg.norm(landed[unk] - moved[unk]) > 0.5 * length:
            h *= 0.5
            if h < 1e-6 * (1.0 + dist):
                return False
            continue
        c = landed
        h = min(1.5 * h, 0.25 * (1.0 + dist))
    return False


def group_roots(ctx: Search, roots: list[RootSet]) -> list[RootSet]:
    """Roots with their tangent directions; those on one connected non-isolated set merged into
    one, represented by the point nearest q = 0."""
    out = []
    for r in roots:
        q = r.q
        if r.exact is None:  # polished to round-off: the rank of the Jacobian is then clear-cut
            q = wrap_angles(_project(ctx, q) if _project(ctx, q) is not None else q, ctx.problem.angles)
        out.append(RootSet(q, _tangent(ctx, q), r.exact, r.conditions, r.solution))
    loose = [k for k, r in enumerate(out) if r.dimension]
    parent = {k: k for k in loose}

    def find(k):
        while parent[k] != k:
            parent[k] = parent[parent[k]]
            k = parent[k]
        return k

    def gap(a, b):  # angles a whole turn apart are the same
        return float(np.linalg.norm(angle_difference(out[a].q, out[b].q, ctx.problem.angles)))

    pairs = sorted((gap(a, b), a, b) for i, a in enumerate(loose) for b in loose[i + 1:])
    attempts = failed = 0
    for _, a, b in pairs:  # nearest first, as in Kruskal's algorithm: a chain of short walks joins a set
        if find(a) == find(b) or out[a].dimension != out[b].dimension:
            continue
        attempts += 1
        if attempts > 200 or failed > _FAILED_IN_A_ROW:  # the rest lie on other sets (a mechanism's assembly modes)
            break
        if _connected(ctx, out[a].q, out[b].q):
            parent[find(a)] = find(b)
            failed = 0
        else:
            failed += 1
    groups: dict[int, list[int]] = {}
    for k in loose:
        groups.setdefault(find(k), []).append(k)
    chosen = {min(g, key=lambda k: (out[k].exact is None, float(np.abs(out[k].q).sum()))) for g in groups.values()}
    return [r for k, r in enumerate(out) if not r.dimension or k in chosen]


def free_axes(ctx: Search, q: np.ndarray, tangent: np.ndarray) -> tuple[str, ...]:
    """The coordinates that may take any value on the set of roots through q: when every tangent
    direction is a coordinate axis and q moved far along it is still a root (the parabola y = x**2
    is tangent to the x axis at 0, but x is not free on it)."""
    problem = ctx.problem
    names = []
    for v in tangent.T:
        big = np.flatnonzero(np.abs(v) > 1e-9)
        if len(big) != 1:
            return ()
        i = int(big[0])
        shifts = ((-2.5, -1.0, 1.0, 2.5) if problem.angles[i]
                  else tuple(x * (1.0 + abs(q[i])) for x in (-3, -0.5, 0.5, 3)))
        for d in shifts:
            moved = np.array(q, dtype=float)
            moved[i] += d
            if not is_root(ctx, moved):
                return ()
        names.append(problem.variables[i].name)
    return tuple(names)


# --------------------------------------------------------------------------- why none
def no_root_reasons(problem: StationaryProblem, setting: Setting, ctx: Search, what: str) -> tuple[str, ...]:
    """Sentences saying why no stationary state was found (`what`: "equilibrium", "steady motion")."""
    eqs = problem.equations
    failed = conditions_hold(problem, setting)
    values = constant_map(problem, setting)
    out = []
    if failed:
        for i in failed:
            if i >= eqs.n:  # a constraint free of the unknowns that does not hold
                con = eqs.model.constraints[i - eqs.n]
                value = complex(sympy.N(problem.static_sympy[i].subs(values)))
                out.append(f"constraint '{con.name}', {sympy.sstr(con.expression)} = 0, never holds "
                           f"({value.real:.6g} with these values)")
                continue
            name = eqs.coordinates[i].name
            row = problem.static_sympy[i]
            dV = to_sympy(eqs.core.V.diff(eqs.core.q[i]))
            value = complex(sympy.N(row.subs(values)))
            shown = f"{value.real:.6g}" if abs(value.imag) <= 1e-12 * abs(value) else f"{value:.6g}"
            if not problem.moving and sympy.expand(row + dV) == 0:
                out.append(f"dV/d{name} = {sympy.sstr(sympy.factor(dV))} is never 0 ({_negate(shown)} with these "
                           f"values; {what} needs {sympy.sstr(sympy.factor(row))} = 0)")
            else:
                where = "at rest" if not problem.moving else "in a steady motion"
                out.append(f"the generalized force on {name} {where}, {sympy.sstr(sympy.factor(row))}, is never 0 "
                           f"({shown} with these values)")
        return tuple(out)
    if problem.exact is not None:
        eqs_text = ", ".join(f"{sympy.sstr(sympy.factor(problem.static_sympy[i]))} = 0" for i in problem.rows)
        out.append(f"SymPy finds no solution of {eqs_text}" if not problem.exact else
                   f"SymPy's solutions of {eqs_text} are not real with these values")
    if problem.unknowns and problem.rows:
        out.append(f"the numerical search from {ctx.starts} starting points found none")
    return tuple(out) + runaway_notes(ctx, what)


def completeness_notes(problem: StationaryProblem, ctx: Search, what: str) -> tuple[str, ...]:
    """When some were found only numerically: that others may exist (SymPy solved it completely
    otherwise)."""
    if problem.exact is not None or not problem.rows:
        return ()
    if problem.evaluator is not None:
        return (f"found by a numerical search from {ctx.starts} starting points (a constrained model's steady "
                f"motions, and its equilibria with velocity constraints, are found numerically only): there may be "
                f"others",)
    return (f"found by a numerical search from {ctx.starts} starting points, SymPy not having solved for "
            f"{what}: there may be others",)


def runaway_notes(ctx: Search, what: str) -> tuple[str, ...]:
    """What the search saw run away: a root at infinity is not a stationary state."""
    return tuple(f"{count} of the {ctx.starts} searches ran away towards {name} = +-infinity"
                 + ("" if name in ctx.lasting else ", where the forces tend to 0")
                 + f": a root at infinity is not {what}" for name, count in sorted(ctx.runaway.items()))


def _negate(text: str) -> str:
    return text[1:] if text.startswith("-") else "-" + text


