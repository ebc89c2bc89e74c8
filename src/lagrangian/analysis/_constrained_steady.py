"""Steady motions of constrained models, and equilibria of models with velocity constraints.

A steady motion keeps the *shape* of the system constant while it moves along symmetries: a coin
rolling on a circle at a constant lean, a bicycle running straight or turning steadily. With
constraints the symmetries are not always single coordinates absent from L: the coin's heading psi
appears in its kinetic energy (written with the contact point's velocity), and the no-slip
conditions turn x_dot, y_dot with psi. What matters is whether the motion *reduced* to the
independent speeds depends on a coordinate's value, so that is what is tested:

* **Ignorable coordinates.** Coordinate q_i is ignorable when the holonomic constraints do not
  contain it and shifting it changes none of the independent accelerations (those of the
  independent speeds, with the dependent speeds found from the constraints at the shifted state),
  at random states made consistent (three of them, at the model's parameter values). The test is
  numerical, as the periodicity test of the equilibria is; it can miss a symmetry that the chosen
  independent speeds hide (then fewer steady motions are found, never false ones), and it never
  calls a coordinate that matters ignorable. The coin: x, y, psi and the spin; the bicycle: x, y,
  the yaw, both wheels' rotations.
* **The state.** The other coordinates (the shape) are constant: their rates are 0 and their
  values are the unknowns. The user fixes the rates of ignorable coordinates (``theta_dot = 20``);
  the rates of the other ignorable ones follow from the constraints W q_dot + b = 0 (least
  squares; those the constraints leave free stay at rest, and a set of rates that the
  constraints couple without fixing is refused). Ignorable coordinates sit at 0: the motion is the
  same at any value of them.
* **The equations.** The constrained accelerations q_ddot (and the multipliers) come from the
  saddle-point system [M W^T; W 0] at that state, as in a simulation. Steady means q_ddot = 0 for
  the shape and for the coordinates whose rates are fixed, with g(q) = 0 and the constraints met by
  the rates (rows that can fail when a given rate over-determines the others: a bicycle's yaw rate
  and speed fix its steer angle). Those rows are solved for the shape by the shared multi-start
  search of ``_roots`` (least squares where rows outnumber unknowns: the rows the symmetry makes
  dependent, as energy conservation makes a bicycle's wheel acceleration vanish once roll and steer
  are steady). The Jacobian is a central difference (about 1e-10 relative: the roots are
  polished by the residual, which is exact, and the Jacobian only steers). The residual at q and
  the 2k points of the differences is one batch: one call of each compiled function of the model,
  then the saddle-point solve of each point in compiled loops (``_steady_c``, C loaded with ctypes, or
  numba's ``_steady_kernel`` where there is no C compiler: the same numbers bit for bit; the search of the
  bicycle's equilibria makes 7800 such calls, 0.4 ms each in NumPy, now 26 us in the arrays a
  ``_steady_c.Workspace`` allocates once).
  Everything is numerical: no symbolic solve of the constraints, so no exact solutions.
* **Stability** comes from the linearization about the steady motion in the independent speeds
  (``_constrained_linear.linearize_steady``) with the ignorable coordinates left out. Its
  eigenvalues decide "unstable" and "asymptotically stable"; otherwise the answer is "marginally
  stable" at best: with velocity constraints energy does not give Lagrange-Dirichlet's or Routh's
  "stable" (the linearization's K is not the Hessian of a potential), and a steady motion whose
  nearby steady motions (another speed, another lean) have a zero eigenvalue is never asymptotically
  stable.

Momenta are not conserved under velocity constraints in general (the coin's angular momentum about
the vertical changes as friction turns it), so rates are given, not momenta.
"""

from __future__ import annotations

from types import MappingProxyType

import numpy as np
import symengine as se

from ..equations import Equations
from ..errors import ModelError
from ..model._constraints import VELOCITY
from ..numeric._compiled import SINGULAR_RATIO, compile_equations
from ._setting import Setting
from ._stationary import StationaryProblem, periodic_in

__all__ = ["ignorable_coordinates", "steady_problem", "SteadyState", "above_ground", "steady_details"]

#: Relative size below which a change of an acceleration under a shift counts as round-off.
_SAME = 1e-9


def _model(equations: Equations):
    """The saddle-point solve and the projection (numeric._constrained): the accelerations, the
    multipliers and a state moved onto the constraints."""
    from ..numeric._constrained import constrained_model

    return constrained_model(equations, compile_equations(equations))


def _constraints(equations: Equations, t, x, p) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(W, g, w) at the state: the constraint Jacobian, the residuals g and w = W q_dot + b, by the one
    numeric model (they take no input)."""
    return compile_equations(equations).constraint_residuals(t, x, np.zeros(len(equations.inputs)), p)


def _holonomic(equations: Equations, cm, t, x, p) -> tuple[np.ndarray, np.ndarray]:
    """(g, G) of the holonomic constraints at the state."""
    W, g, _ = _constraints(equations, t, x, p)
    return g[cm.holonomic], W[cm.holonomic]


def _dependent_speeds_at(equations: Equations, cm, t, q, p) -> list[int]:
    """The dependent speeds at q, as the linearization chooses them."""
    from ._constrained_linear import _dependent_speeds, _independent

    n = cm.n
    hol = [int(k) for k in cm.holonomic]
    W = _constraints(equations, t, np.concatenate((q, np.zeros(n))), p)[0]
    dep_q = [] if not hol else [i for i in range(n) if i not in _independent(equations, W[hol])]
    return _dependent_speeds(equations, W, hol, dep_q)


def _completed(equations: Equations, cm, t, q, qd, dep, p) -> np.ndarray:
    """The state (q, q_dot) with the dependent speeds `dep` solved from the constraints."""
    n = cm.n
    x = np.concatenate((q, qd))
    x[n + np.array(dep, int)] = 0.0
    W, _, w0 = _constraints(equations, t, x, p)
    x[n + np.array(dep, int)] = np.linalg.solve(W[:, dep], -w0) if dep else []
    return x


def ignorable_coordinates(equations: Equations, setting: Setting) -> tuple[int, ...]:
    """Indices of the coordinates on whose values the motion reduced to the independent speeds does
    not depend (see the module), at the setting's parameter values."""
    from ..numeric._cache import per_equations

    key = (tuple(setting.p), tuple(setting.u), setting.t)
    cache = per_equations(equations).setdefault("ignorable coordinates", {})
    if key in cache:
        return cache[key]
    from ..numeric._constrained import ConstraintSingular

    cm = _model(equations)
    n, t, p, u = cm.n, setting.t, setting.p, setting.u
    rng = np.random.default_rng(11)
    candidates = set(range(n))
    for _ in range(3):
        for _attempt in range(20):  # a random state where the constraints are regular
            q = rng.uniform(-0.6, 0.6, n)
            try:
                x = cm.project(t, np.concatenate((q, np.zeros(n))), p)
                dep_v = _dependent_speeds_at(equations, cm, t, x[:n], p)
                ind_v = [i for i in range(n) if i not in dep_v]
                qd = np.zeros(n)
                qd[ind_v] = rng.uniform(-1.5, 1.5, len(ind_v))
                x = _completed(equations, cm, t, x[:n], qd, dep_v, p)
                with np.errstate(all="ignore"):
                    qdd = cm.solve(t, x, u, p)[0]
                    G = _holonomic(equations, cm, t, x, p)[1]
            except (ConstraintSingular, np.linalg.LinAlgError):
                continue
            if np.all(np.isfinite(qdd)) and np.all(np.isfinite(x)):
                break
        else:
            candidates.clear()
            break
        scale = 1.0 + float(np.max(np.abs(qdd)))
        gscale = 1.0 + float(np.max(np.abs(G), initial=0.0))
        held = ind_v + [j for j in dep_v if G.size and np.max(np.abs(G[:, j])) > 0]
        for i in sorted(candidates):
            if G.size and np.max(np.abs(G[:, i])) > 1e-12 * gscale:
                candidates.discard(i)
                continue
            shifted = x[:n].copy()
            shifted[i] += 1.3
            try:
                y = _completed(equations, cm, t, shifted, x[n:], dep_v, p)
                with np.errstate(all="ignore"):
                    qdd1 = cm.solve(t, y, u, p)[0]
            except (ConstraintSingular, np.linalg.LinAlgError):
                candidates.discard(i)
                continue
            if not (np.all(np.isfinite(qdd1)) and np.allclose(qdd1[ind_v], qdd[ind_v], rtol=0, atol=_SAME * scale)
                    and np.allclose(y[n:][held], x[n:][held], rtol=0, atol=_SAME * (1 + np.abs(x[n:]).max()))):
                candidates.discard(i)
    out = cache[key] = tuple(sorted(candidates))
    return out


class SteadyState:
    """The residual of the steady conditions in the shape coordinates (the `evaluator` of a
    StationaryProblem: see the module), and the state, accelerations and multipliers at a root."""

    def __init__(self, equations: Equations, shape: list[int], given: dict[int, float], free: list[int]):
        self.equations = equations
        self.cm = _model(equations)
        self.shape, self.given, self.free = shape, dict(given), free
        self.held = sorted(set(shape) | set(given))   # their accelerations must vanish
        # the index arrays of the compiled residual (_steady_kernel)
        self._shape, self._free, self._held = (np.array(v, dtype=np.int64) for v in (shape, free, self.held))
        self._hol = np.asarray(self.cm.holonomic, dtype=np.int64)
        self._given = np.array(list(self.given), dtype=np.int64)
        self._given_values = np.array(list(self.given.values()), dtype=float)
        self._constraints_fun = compile_equations(equations)._group("constraints").fun
        self._sizes: dict[int, tuple[int, int]] = {}  # the compiled functions' (inputs, outputs) a point, checked
        self._last = None
        self._workspace = None  # the C kernels' arrays (_steady_c.Workspace) once the sizes are checked, or False

    def state(self, setting: Setting, q: np.ndarray) -> np.ndarray:
        """(q, q_dot): given rates, the free ignorable ones from the constraints, the shape at rest."""
        return self._state(setting, q)[0]

    def _state(self, setting: Setting, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(state, w = W q_dot + b there, W)."""
        n = self.cm.n
        x = np.concatenate((np.asarray(q, float)[:n], np.zeros(n)))
        for i, v in self.given.items():
            x[n + i] = v
        W, _, w = _constraints(self.equations, setting.t, x, setting.p)
        if self.free:
            # least squares, cut off against W as a whole: where the free rates' columns vanish (a
            # knife edge across its rail) they stay finite and the constraint row is left unmet
            U, sv, Vt = np.linalg.svd(W[:, self.free], full_matrices=False)
            keep = sv > 1e-10 * max(float(np.max(np.abs(W), initial=0.0)), 1e-300)
            rates = Vt[keep].T @ ((U[:, keep].T @ -w) / sv[keep])
            x[n + np.array(self.free)] = rates
            w = w + W[:, self.free] @ rates  # w is affine in q_dot
        return x, w, W

    def values(self, setting: Setting, q: np.ndarray):
        """(x, q_ddot, lambda, r): the state, its accelerations and multipliers, the residual rows."""
        from ..numeric._constrained import ConstraintSingular

        cm, t, p = self.cm, setting.t, setting.p
        n = cm.n
        with np.errstate(all="ignore"):
            try:
                x, w, _ = self._state(setting, q)
                qdd, lam = cm.solve(t, x, setting.u, p)
                g = _holonomic(self.equations, cm, t, x, p)[0]
            except (ConstraintSingular, np.linalg.LinAlgError, ValueError):
                nan = np.full(n, np.nan)
                return (np.concatenate((q[:n], nan)), nan, np.full(cm.m, np.nan),
                        np.full(len(self.held) + cm.m + len(cm.holonomic), np.nan))
        return x, qdd, lam, np.concatenate((qdd[self.held], g, w))

    def _rows_batch(self, setting: Setting, A: np.ndarray) -> tuple[np.ndarray, ...]:
        """(rows, W, scale): the residual rows of `values` at the points whose arguments (t, q, q_dot,
        u, p) are the rows of A (the given rates set, the others 0; the free ones are written into A
        here), evaluated together: one call of each compiled function, then the saddle-point solve of
        each point in compiled loops (``_steady_kernel``); with the constraint Jacobians and the size of
        the terms of the accelerations at each point (``term_scale`` without the squared rates). A row of
        NaN where a point is singular or not finite (the caller asks `values` for those)."""
        kernel = steady_kernels()
        cm = self.cm
        n, m, k = cm.n, cm.m, len(A)
        C = self._batch(self._constraints_fun, A)
        bad = np.zeros(k, dtype=np.bool_)
        w = kernel.free_rates(C, A, self._free, n, m, bad)
        P = self._batch(cm._parts, A)
        rows = np.empty((k, len(self.held) + len(cm.holonomic) + m))
        scale = np.empty(k)
        kernel.steady_rows(P, w, C[:, m * n:m * n + m], self._held, self._hol, n, m, SINGULAR_RATIO, bad, rows, scale)
        return rows, C[:, :m * n].reshape(k, m, n), scale

    def _batch(self, fun, A: np.ndarray) -> np.ndarray:
        """``fun(A)`` as a (len(A), outputs) array, for a SymEngine Lambdify `fun` of the arguments that are A's
        columns: after the first call (which checks that each row of A is one point of `fun`), by its
        ``unsafe_eval`` into a new buffer, the same compiled code point by point without the checks and
        the broadcasting of its call (8 of the 50 us an evaluation of the bicycle's residual took)."""
        k = len(A)
        known = self._sizes.get(id(fun))
        if known is None or known[0] != A.shape[1] or not A.flags.c_contiguous or A.dtype != np.float64:
            out = np.asarray(fun(A), float)
            if A.ndim == 2 and out.ndim == 2 and out.shape[0] == k and hasattr(fun, "unsafe_eval"):
                self._sizes[id(fun)] = (A.shape[1], out.shape[1])
            return out.reshape(k, -1)
        size = known[1]
        out = np.empty(k * size)
        fun.unsafe_eval(A, out, k)
        return out.reshape(k, size)

    def meets_constraints(self, setting: Setting, q: np.ndarray) -> bool:
        """Whether q meets the holonomic constraints, g(q) = 0 to round-off of the coordinates (a
        root must: next to a singular configuration, the bicycle lying flat, the residual's
        Jacobian grows without bound and a residual of the size of the forces looks small)."""
        with np.errstate(all="ignore"):
            g = _holonomic(self.equations, self.cm, setting.t, self.state(setting, np.asarray(q, float)), setting.p)[0]
        return bool(np.all(np.isfinite(g)) and np.all(np.abs(g) <= 1e-9 * (1.0 + float(np.max(np.abs(q))))))

    def term_scale(self, setting: Setting, q: np.ndarray) -> float:
        """The size of the accelerations the terms of the equations make at q (forces over masses,
        the constraints' c, the squared rates): the scale against which a residual is round-off."""
        with np.errstate(all="ignore"):
            x = self.state(setting, np.asarray(q, float))
            # M, f and c by the saddle-point solve's one compiled evaluation (the search's), not the
            # numeric model's groups of M and f and of c, which would be compiled for this alone
            M, f, _, c = self.cm.parts(setting.t, x, np.asarray(setting.u, float), np.asarray(setting.p, float))
        return self._scale(x, M, f, c)

    def _scale(self, x, M, f, c) -> float:
        """term_scale from the state and M, f, c there."""
        n = self.cm.n
        mass = float(np.max(np.abs(np.diag(M)), initial=0.0))
        forces = float(np.max(np.abs(f), initial=0.0)) / mass if mass > 0 else 0.0
        return forces + float(np.max(np.abs(c), initial=0.0)) + float(np.max(x[n:] ** 2, initial=0.0))

    def __call__(self, setting: Setting, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(r, dr/dz) in the shape coordinates z."""
        q = np.asarray(q, float)
        ws = self._workspace
        if ws and self._fast(ws, setting, q):  # the batch in the C kernels' arrays, every point finite: done
            return ws.R[0].copy(), ws.J.copy()
        kernel = steady_kernels()
        n, k = self.cm.n, len(self.shape)
        a, kh = len(self.held), len(self.cm.holonomic)
        with np.errstate(all="ignore"):
            # q and the 2k points of the central differences in one batched evaluation
            h = 1e-5 * (1.0 + np.abs(q[self._shape]))
            u, p = self._arguments(setting)
            A = np.empty((2 * k + 1, 1 + 2 * n + len(u) + len(p)))
            kernel.points(A, float(setting.t), u, p, q, self._shape, h, self._given, self._given_values)
            R, Ws, scales = self._rows_batch(setting, A)
            J = np.empty((R.shape[1], k))
            if ws is None:
                self._workspace = self._new_workspace(u, p) or False
            # central differences: error O(h^2) + round-off/h, about 1e-10 relative; their round-off
            # (about 1e-11 of the terms) as exact zeros, so that a set of steady motions (a knife edge
            # sliding at any heading) shows as a singular Jacobian
            if kernel.central_jacobian(R, A, Ws, scales, q, h, n, a, kh, J):
                return R[0].copy(), J
        finite = np.isfinite(R).all(axis=1)
        r = R[0] if finite[0] else self.values(setting, q)[3]
        if not np.all(np.isfinite(r)):
            return r, np.full((len(r), k), np.nan)
        with np.errstate(all="ignore"):
            for i in np.flatnonzero(~finite[1:]) + 1:  # a singular or not finite point: as `values` decides it
                R[i] = self.values(setting, A[i, 1:1 + n])[3]
            if finite[0]:
                x, W = A[0, 1:1 + 2 * n], Ws[0]
                scale = float(scales[0]) + float(np.max(x[n:] ** 2, initial=0.0))
            else:
                x, _, W = self._state(setting, q)
                scale = self.term_scale(setting, q)
            floor = np.empty(len(r))
            floor[:a] = scale
            floor[a:a + kh] = 1.0 + np.max(np.abs(q))
            floor[a + kh:] = (1.0 + np.max(np.abs(x[n:]))) * (1.0 + np.max(np.abs(W), initial=0.0))
            kernel.differences(R, h, floor, J)
        return r, J

    def _new_workspace(self, u: np.ndarray, p: np.ndarray):
        """The C kernels' arrays for this evaluator (_steady_c.Workspace), once both compiled functions' sizes
        are checked (by the first batch); None without the C kernels (numba's then, point by point)."""
        from ._steady_c import CKernels, Workspace

        kernel, cm = steady_kernels(), self.cm
        sizes = [self._sizes.get(id(fun)) for fun in (self._constraints_fun, cm._parts)]
        width = 1 + 2 * cm.n + len(u) + len(p)  # a point's arguments (t, q, q_dot, u, p), as checked by the call
        if not isinstance(kernel, CKernels) or None in sizes or any(size[0] != width for size in sizes):
            return None
        return Workspace(kernel.lib, cm.n, cm.m, self.shape, self.free, self.held, cm.holonomic, list(self.given),
                         list(self.given.values()), len(u), len(p), sizes[0][1], sizes[1][1])

    def _fast(self, ws, setting: Setting, q: np.ndarray) -> bool:
        """The batch of __call__ in the workspace `ws` (the same kernels' operations on the same arrays, without
        their allocation and checks); True where every point is finite (r is ws.R[0], dr/dz ws.J), else False
        (the caller takes the whole way, which decides the points that are not). No NumPy arithmetic: no
        floating-point state to set."""
        if ws.setting is not setting:
            u, p = self._arguments(setting)
            ws.u[:], ws.p[:], ws.setting = u, p, setting
        rows = ws.A.shape[0]
        ws.points(float(setting.t), q)
        self._constraints_fun.unsafe_eval(ws.A, ws.C, rows)
        ws.free_rates()
        self.cm._parts.unsafe_eval(ws.A, ws.P, rows)
        return ws.rows_jacobian(SINGULAR_RATIO)

    def _arguments(self, setting: Setting) -> tuple[np.ndarray, np.ndarray]:
        """(u, p) of the setting as float arrays (kept for the last setting: the search asks thousands
        of times at one)."""
        last = self._last
        if last is None or last[0] is not setting:
            last = self._last = (setting, np.asarray(setting.u, float).ravel(), np.asarray(setting.p, float).ravel())
        return last[1], last[2]


def steady_kernels():
    """The steady residual's compiled loops: the C kernels (_steady_c, no numba to start), or numba's
    (_steady_kernel) where there is no C compiler; the same numbers bit for bit."""
    from ._steady_c import kernels

    found = kernels()
    if found is not None:
        return found
    from . import _steady_kernel

    return _steady_kernel


def _angles(evaluator: SteadyState, setting: Setting, n: int) -> tuple[bool, ...]:
    """Which shape coordinates the steady conditions are 2 pi-periodic in (at random points)."""
    rng = np.random.default_rng(7)
    points = []
    for _ in range(3):
        q = np.zeros(n)
        q[evaluator.shape] = rng.uniform(-1.0, 1.0, len(evaluator.shape))
        points.append(q)
    rows = lambda q: (evaluator.values(setting, q)[3],)  # noqa: E731
    return tuple(i in evaluator.shape and periodic_in(rows, points, i) for i in range(n))


def steady_problem(equations: Equations, setting: Setting, given: dict[int, float]) -> StationaryProblem:
    """The steady motions (or, with no rate given, the equilibria) of a constrained model as a
    StationaryProblem in its shape coordinates, whose residual is numerical (see the module).

    Raises
    ------
    ModelError
        A constraint that depends on t, or free ignorable rates that the constraints couple without
        fixing them.
    """
    from ..equations._equations import _depends_on

    model = equations.model
    core = equations.core
    moving = [c.name for c, g in zip(model.constraints, core.g) if _depends_on(g, core.t)]
    moving += [c.name for c, w in zip(model.constraints, core.w) if c.kind == VELOCITY and _depends_on(w, core.t)]
    if moving:
        raise ModelError(
            f"{model.name}: constraint{'s' if len(moving) > 1 else ''} {', '.join(moving)} depend"
            f"{'' if len(moving) > 1 else 's'} on the time t, so no motion of it stays steady; linearize about a "
            "chosen state instead, with linearize(equations, at=..., t=...), or simulate it")
    n = equations.n
    names = [c.name for c in equations.coordinates]
    ignorable = ignorable_coordinates(equations, setting)
    shape = [i for i in range(n) if i not in ignorable]
    free = [i for i in ignorable if i not in given]
    evaluator = SteadyState(equations, shape, given, free)
    if free and _coupled(evaluator, setting):
        coupled = ", ".join(f"{names[i]}_dot" for i in free)
        raise ModelError(f"the constraints of '{model.name}' couple the rates {coupled} without fixing them, and the "
                         "given rates move them: give the rate of one more of them (velocities={...}, --velocity), "
                         "so that the others follow")
    rows = len(evaluator.held) + len(evaluator.cm.holonomic) + evaluator.cm.m
    return StationaryProblem(
        equations, tuple(shape), _angles(evaluator, setting, n), tuple(names[i] for i in ignorable),
        tuple(range(rows)), (), MappingProxyType(dict(given)), MappingProxyType({}), (), (), None,
        evaluator=evaluator)


def _coupled(evaluator: SteadyState, setting: Setting) -> bool:
    """Whether the constraints leave the free ignorable rates undetermined (W's columns of them
    dependent) while the given rates push them (a right-hand side that is not 0): at rest, the
    free rates stay 0, as cyclic coordinates given no rate do without constraints. Tested at the
    zero shape and two random ones."""
    n, free = evaluator.cm.n, evaluator.free
    rng = np.random.default_rng(5)
    for k in range(3):
        q = np.zeros(n)
        if k:
            q[evaluator.shape] = rng.uniform(-0.5, 0.5, len(evaluator.shape))
        x = evaluator.state(setting, q)
        x[n + np.array(free)] = 0.0
        with np.errstate(all="ignore"):
            W, _, w0 = _constraints(evaluator.equations, setting.t, x, setting.p)
        if not (np.all(np.isfinite(W)) and np.all(np.isfinite(w0))):
            continue
        Wf = W[:, free]
        tiny = 1e-12 * max(float(np.max(np.abs(W), initial=0.0)), 1e-300)
        if np.linalg.matrix_rank(Wf) < sum(1 for j in range(len(free)) if np.max(np.abs(Wf[:, j])) > tiny) \
                and np.max(np.abs(w0)) > 1e-12 * (1.0 + np.max(np.abs(x[n:]))):
            return True
    return False


def _heights(equations: Equations):
    """(q, p) -> (the heights above the ground of the wheels' centres, of the centres of mass of the
    bodies and particles in space): two arrays (empty without wheels), and the names of the latter."""
    import sympy

    from ..model._elements import Particle, RigidBody3D
    from ..model._frames import chain

    model = equations.model
    wheels = []
    for wheel in model.wheels:
        # model._frames.frame_pose's origin + R center, in SymEngine (SymPy's matrix products took a third
        # of a second for the bicycle)
        origin, R = se.zeros(3, 1), se.eye(3)
        for frame in chain(model.frames, wheel.frame):
            origin = origin + R * se.DenseMatrix(3, 1, [se.sympify(x) for x in frame.origin])
            R = R * se.DenseMatrix(3, 3, [se.sympify(x) for x in frame.rotation])
        wheels.append((origin + R * se.DenseMatrix(3, 1, [se.sympify(x) for x in wheel.center]))[2])
    masses = [e for e in model.elements if isinstance(e, (RigidBody3D, Particle)) and len(e.position) == 3]
    names = tuple(e.name for e in masses)
    if not wheels:
        return (lambda q, p: (np.zeros(0), np.zeros(0))), names
    heights = compile_equations(equations).function(
        "heights", lambda: wheels + [sympy.sympify(e.position[2]) for e in masses])
    n, k, u = equations.n, len(wheels), np.zeros(len(equations.inputs))

    def height(q, p):
        z = heights(0.0, np.concatenate((q, np.zeros(n))), u, p)
        return z[:k], z[k:]

    return height, names


def above_ground(problem: StationaryProblem, setting: Setting, points: list) -> tuple[list, tuple[str, ...]]:
    """The points in a pose the ground allows, and a note on those left out: where the coordinates
    keep a wheel on the ground, they allow it to touch the ground from below (its centre under the
    ground, the contact at the top of the rim), and the rest of the mechanism to turn over under it
    (a bicycle's frame pitched by about -pi, its rider under the ground): no rolling state. Those
    with a wheel's centre, or the centre of mass of a body or particle, below the ground z = 0 are
    left out."""
    if not problem.equations.model.wheels:
        return points, ()
    height, names = _heights(problem.equations)
    kept, wheel_below, body_below = [], 0, {}
    for r in points:
        wheels, masses = height(r.q, setting.p)
        under = [n for n, z in zip(names, masses) if z < -1e-9 * (1.0 + float(np.max(np.abs(masses))))]
        if not np.all(wheels > 0):
            wheel_below += 1
        elif under:
            body_below[tuple(under)] = body_below.get(tuple(under), 0) + 1
        else:
            kept.append(r)
    notes = []
    if wheel_below:
        notes.append(f"{wheel_below} solution{'s' if wheel_below > 1 else ''} with a wheel's centre below the ground "
                     f"(touching it from below, which the coordinates allow) {'are' if wheel_below > 1 else 'is'} "
                     "left out")
    for under, count in body_below.items():
        which = (f"the centre of mass of {under[0]}" if len(under) == 1 else
                 f"the centres of mass of {', '.join(under[:-1])} and {under[-1]}")
        notes.append(f"{count} solution{'s' if count > 1 else ''} with {which} below the ground (the mechanism "
                     f"turned over under its wheels: upside down, which the coordinates allow) "
                     f"{'are' if count > 1 else 'is'} left out")
    return kept, tuple(notes)


def steady_details(problem: StationaryProblem, setting: Setting, q: np.ndarray):
    """(velocities, multipliers) at a root of a steady problem."""
    ev = problem.evaluator
    x, _, lam, _ = ev.values(setting, q)
    n = problem.equations.n
    qd = np.where(np.abs(x[n:]) <= 1e-13 * (1.0 + np.abs(x[n:]).max()), 0.0, x[n:])
    mult = MappingProxyType({mu.name: float(v) + 0.0 for mu, v in zip(problem.equations.multipliers, lam)})
    return qd, mult
