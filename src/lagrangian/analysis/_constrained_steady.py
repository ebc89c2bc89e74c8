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
  polished by the residual, which is exact, and the Jacobian only steers).
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

    def _rows_batch(self, setting: Setting, Q: np.ndarray) -> tuple[np.ndarray, ...]:
        """(rows, X, W, M, f, c): the residual rows of `values` at each configuration of Q (shape
        (k, n)), evaluated together (one call of each compiled function, stacked LAPACK: the same
        arithmetic point by point), with the states, constraint Jacobians, M, f and c there; a row of
        NaN where a point is singular or not finite (the caller asks `values` for those)."""
        cm, t, p = self.cm, setting.t, setting.p
        n, m, k = cm.n, cm.m, len(Q)
        nm = compile_equations(self.equations)
        X = np.zeros((k, 2 * n))
        X[:, :n] = Q
        for i, v in self.given.items():
            X[:, n + i] = v
        u = np.asarray(setting.u, float).ravel()
        pv = np.asarray(p, float).ravel()

        def args(X):
            return np.hstack((np.full((k, 1), t), X, np.broadcast_to(u, (k, len(u))),
                              np.broadcast_to(pv, (k, len(pv)))))

        out = np.asarray(nm._group("constraints").fun(args(X)), float).reshape(k, -1)
        W, g, w = out[:, :m * n].reshape(k, m, n), out[:, m * n:m * n + m], out[:, m * n + m:m * n + 2 * m]
        bad = ~(np.all(np.isfinite(out), axis=1))
        if self.free:
            Wf = W[:, :, self.free]
            try:
                U, sv, Vt = np.linalg.svd(np.where(bad[:, None, None], 0.0, Wf), full_matrices=False)
            except np.linalg.LinAlgError:
                return (np.full((k, len(self.held) + m + len(cm.holonomic)), np.nan),)
            big = np.maximum(np.max(np.abs(W), axis=(1, 2), initial=0.0), 1e-300)
            keep = sv > 1e-10 * big[:, None]
            coef = np.where(keep, np.einsum("kij,ki->kj", U, -w) / np.where(keep, sv, 1.0), 0.0)
            rates = np.einsum("kji,kj->ki", Vt, coef)
            X[:, n + np.array(self.free)] = rates
            w = w + np.einsum("kij,kj->ki", Wf, rates)
        parts = np.asarray(cm._parts(args(X)), float).reshape(k, -1)
        M = parts[:, :n * n].reshape(k, n, n)
        f = parts[:, n * n:n * n + n]
        G = parts[:, n * n + n:n * n + n + m * n].reshape(k, m, n)
        c = parts[:, n * n + n + m * n:]
        d = np.diagonal(M, axis1=1, axis2=2)
        bad |= ~(np.all(np.isfinite(parts), axis=1) & np.all(d > 0, axis=1))
        M = np.where(bad[:, None, None], np.eye(n), M)
        G = np.where(bad[:, None, None], np.eye(m, n), G)
        f, c = np.where(bad[:, None], 0.0, f), np.where(bad[:, None], 0.0, c)
        try:
            Lc = np.linalg.cholesky(M)
        except np.linalg.LinAlgError:
            return (np.full((k, len(self.held) + m + len(cm.holonomic)), np.nan),)
        ratio = np.min(np.diagonal(Lc, axis1=1, axis2=2) ** 2 / np.where(bad[:, None], 1.0, d), axis=1)
        B = np.linalg.solve(Lc, np.swapaxes(G, 1, 2))
        Qr, Rr = np.linalg.qr(B)
        big = np.max(np.sum(B * B, axis=1), axis=1)
        rho = np.min(np.abs(np.diagonal(Rr, axis1=1, axis2=2)), axis=1) / np.sqrt(big)
        bad |= ~((ratio > SINGULAR_RATIO) & (rho > SINGULAR_RATIO) & np.isfinite(rho))
        Rr = np.where(bad[:, None, None], np.eye(m), Rr)
        LcT, RrT = np.swapaxes(Lc, 1, 2), np.swapaxes(Rr, 1, 2)
        a = np.linalg.solve(LcT, np.linalg.solve(Lc, f[..., None]))
        wr = np.linalg.solve(RrT, c[..., None] - G @ a)
        qdd = (a + np.linalg.solve(LcT, Qr @ wr))[..., 0]
        rows = np.hstack((qdd[:, self.held], g[:, cm.holonomic], w))
        rows[bad] = np.nan
        return rows, X, W, M, f, c

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
            nm = compile_equations(self.equations)
            M, f = nm.mass_matrix(setting.t, x, setting.u, setting.p), nm.forcing(setting.t, x, setting.u, setting.p)
            c = nm.constraint_parts(setting.t, x, setting.u, setting.p)[1]
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
        z = q[self.shape]
        with np.errstate(all="ignore"):
            # q and the 2k points of the central differences in one batched evaluation
            h = 1e-5 * (1.0 + np.abs(z))
            points = np.repeat(q[None, :], 2 * len(z) + 1, axis=0)
            for j in range(len(z)):
                points[2 * j + 1, self.shape[j]] = z[j] + h[j]
                points[2 * j + 2, self.shape[j]] = z[j] - h[j]
            batch = self._rows_batch(setting, points)
        R = batch[0]
        r = R[0] if np.all(np.isfinite(R[0])) else self.values(setting, q)[3]
        if not np.all(np.isfinite(r)):
            return r, np.full((len(r), len(self.shape)), np.nan)

        def rows(z):
            moved = q.copy()
            moved[self.shape] = z
            return self.values(setting, moved)[3]

        J = np.zeros((len(r), len(z)))
        with np.errstate(all="ignore"):
            # central differences: error O(h^2) + round-off/h, about 1e-10 relative
            for j in range(len(z)):
                for i in (2 * j + 1, 2 * j + 2):
                    if not np.all(np.isfinite(R[i])):  # a singular or not finite point: as `values` decides it
                        R[i] = rows(points[i, self.shape])
                J[:, j] = (R[2 * j + 1] - R[2 * j + 2]) / (2 * h[j])
            # round-off of the differences (about 1e-11 of the terms) as exact zeros, so that a set of
            # steady motions (a knife edge sliding at any heading) shows as a singular Jacobian
            a, k = len(self.held), len(self.cm.holonomic)
            n = self.cm.n
            if np.all(np.isfinite(R[0])) and len(batch) > 1:
                x, W = batch[1][0], batch[2][0]
                scale = self._scale(x, batch[3][0], batch[4][0], batch[5][0])
            else:
                x, _, W = self._state(setting, q)
                scale = self.term_scale(setting, q)
            floor = np.concatenate((np.full(a, scale), np.full(k, 1.0 + np.max(np.abs(q))),
                                    np.full(len(r) - a - k, (1.0 + np.max(np.abs(x[n:])))
                                            * (1.0 + np.max(np.abs(W), initial=0.0)))))
            J[np.abs(J) <= 1e-8 * floor[:, None]] = 0.0
        return r, J


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
    from ..model._frames import frame_pose

    model = equations.model
    wheels = []
    for wheel in model.wheels:
        origin, R = frame_pose(model.frames, wheel.frame)
        wheels.append((sympy.Matrix(origin) + R * sympy.Matrix(wheel.center))[2])
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
