"""Linearization of a constrained model in minimal coordinates.

About a configuration at rest q0 on the holonomic constraints g(q) = 0 (with multipliers lambda0
balancing the forces there: f0 + G0^T lambda0 = 0), the admissible displacements are
dq = T dq_i, where q_i are the independent coordinates and T = [I; -G_d^-1 G_i] (G0's columns
split into the dependent and the independent ones). Projecting the linearized equations
M dq'' + D dq' + K dq = G0^T dlambda + sum_k lambda0_k H_k dq + B0 du onto T (T^T G0^T = 0
removes the multipliers) gives

    (T^T M T) dq_i'' + (T^T D T) dq_i' + T^T (K - sum_k lambda0_k H_k) T dq_i = T^T B0 du,

where H_k is the Hessian of g_k: the constraint forces' stiffness (a Cartesian pendulum's only
one). Everything is evaluated numerically at the point; the dependent coordinates are found by
Newton on g = 0, never by a symbolic solve.

With velocity (nonholonomic) constraints, or about a steady motion (some coordinates moving at
constant rates: a rolling wheel, a bicycle at speed v), the state is not (q, q_dot) any more: the
admissible perturbations y = (dq, dq_dot) satisfy the linearized constraints

    G_h dq = 0,        N dq + W dq_dot = 0        (N = d(W q_dot + b)/dq, W all constraints' rows),

and the linearized dynamics M dq'' + (d(M q_ddot0)/dq - df/dq - d(W^T lambda0)/dq) dq - df/dq_dot dq'
= W^T dlambda + df/du du with W dq'' = dc (the constraints twice differentiated) give dq'' from the
saddle-point system. With z = (the independent coordinates, the independent speeds) and y = Z z
(the dependent parts solved from the constraints at the point), z' = S L Z z. The derivatives at the
point are central differences of the compiled M, f, W, c and w extrapolated twice (error O(h^6),
checked against the exact ones and the bicycle's published eigenvalues in the tests). Coordinates on
which nothing depends (the position of a rolling wheel on the ground, its heading, its spin angle:
columns of zeros) are ignorable: they are
left out, which is what makes a motion at constant rates steady. What remains is in second-order
form over the coordinates of the independent speeds, with M = T^T M T (T = dq_dot/du).
"""

from __future__ import annotations

from dataclasses import dataclass
from types import MappingProxyType

import numpy as np
import symengine as se

from ..equations import Equations
from ..equations._lambdify import lambdify
from ..errors import ModelError
from ..model._constraints import VELOCITY

__all__ = ["linearize_constrained"]


def _hessians(equations: Equations, cm):
    """(t, x, p) -> the Hessians of the holonomic constraints, shape (k, n, n)."""
    core = equations.core
    n = equations.n
    exprs = [core.g[k].diff(a).diff(b) for k in cm.holonomic for a in core.q for b in core.q]
    params = [se.Symbol(p.name) for p in equations.parameters]
    f = lambdify([core.t, *core.q, *core.qd, *params], exprs or [se.Integer(0)])
    k = len(cm.holonomic)
    return lambda t, x, p: np.asarray(f(np.concatenate(([t], x, p))), float).ravel()[:k * n * n].reshape(k, n, n)


def _independent(equations: Equations, G: np.ndarray) -> list[int]:
    """The independent coordinates: those the model declares ([simulation] independent), else the
    ones left when the best-conditioned columns of G (QR with column pivoting) are taken as dependent."""
    names = [c.name for c in equations.coordinates]
    declared = [str(q) for q in equations.model.simulation.get("independent", ())]
    n, m = len(names), G.shape[0]
    if declared:
        ind = [names.index(q) for q in declared]
        dep = [i for i in range(n) if i not in ind]
        if len(ind) != n - m or np.linalg.matrix_rank(G[:, dep]) < m:
            raise ModelError(f"the independent coordinates {', '.join(declared)} ([simulation] independent) do not "
                             f"determine the others at this configuration ({n} coordinates, {m} constraints: "
                             f"{n - m} independent ones are needed, and the constraints must fix the rest); name "
                             "other independent coordinates or linearize elsewhere")
        return ind
    dep = _pivot_columns(G, m)
    return [i for i in range(n) if i not in dep]


@dataclass(frozen=True, eq=False)
class TangentSpace:
    """The constraints' tangent space at a configuration at rest on them: dq = T dz.

    Attributes
    ----------
    x : ndarray, shape (2n,)
        The state moved onto the constraints (the given coordinates held, the velocities 0).
    independent : list of int
        The coordinates z (those of T's identity rows), the others dependent.
    basis : ndarray, shape (n, n - m)
        T = [I; -G_d^-1 G_i] (rows in coordinate order).
    accelerations, multipliers : ndarray, shapes (n,) and (m,)
        q_ddot and lambda of the saddle-point solve there.
    stiffness : ndarray, shape (n, n)
        sum_k lambda_k H_k (H_k the Hessian of the holonomic constraint g_k): the constraint forces'
        stiffness, subtracted from K.
    """

    x: np.ndarray
    independent: list
    basis: np.ndarray
    accelerations: np.ndarray
    multipliers: np.ndarray
    stiffness: np.ndarray
    names: tuple = ()

    def require_rest(self, M: np.ndarray, f: np.ndarray) -> None:
        """A ModelError unless the accelerations are 0 at the point, against the scale f / diag M."""
        scale = np.max(np.abs(f), initial=0.0) / max(np.max(np.abs(np.diag(M))), 1e-300) + 1e-300
        qdd = self.accelerations
        if np.max(np.abs(qdd), initial=0.0) > 1e-6 * max(scale, 1.0):  # g = 0 is met to sqrt(eps) at a tangency
            n = len(qdd)
            where = ", ".join(f"{k} = {v:.6g}" for k, v in zip(self.names[:n], self.x[:n]))
            accel = ", ".join(f"{q}_ddot = {a:.3g}" for q, a in zip(self.names[:n], qdd) if abs(a) > 0)
            raise ModelError(f"the configuration {where} is not at rest: the constrained accelerations there are "
                             f"{accel}; linearize about an equilibrium (where the forces balance on the constraints), "
                             "or simulate the motion")

    def summary(self, equations: Equations) -> dict:
        """LinearModel.constrained: the dependent coordinates' values, the multipliers and T."""
        from ._linearize import _clean

        dep = [i for i in range(equations.n) if i not in self.independent]
        return {"dependent": {self.names[i]: float(self.x[i]) for i in dep},
                "multipliers": {mu.name: float(v) + 0.0 for mu, v in zip(equations.multipliers,
                                                                          _clean(self.multipliers))},
                "basis": self.basis.tolist()}


def tangent_space(equations: Equations, x: np.ndarray, given: set, setting) -> TangentSpace:
    """The tangent space of the holonomic constraints at the state x moved onto them, keeping the
    coordinates in `given` and the velocities (see the module); the model's initial values are the
    guesses of the others."""
    from ..numeric._compiled import compile_equations
    from ..numeric._constrained import ConstraintSingular, consistent_state, constrained_model, \
        singular_constraint_message

    n = equations.n
    names = equations.state_names
    p, u, t = setting.p, setting.u, setting.t
    cm = constrained_model(equations, compile_equations(equations))
    x = np.array(x, float)
    for k, v in (equations.model.simulation.get("initial") or {}).items():  # guesses for the others
        if k in names and k not in given and names.index(k) < n:
            x[names.index(k)] = v
    x = consistent_state(cm, x, given | {s for s in names[n:]}, p)
    try:
        qdd, lam = cm.solve(t, x, u, p)
    except ConstraintSingular as s:
        raise ModelError(singular_constraint_message(cm, s.t, s.x, p)) from None
    _, G, _ = cm._velocity_parts(t, x, p)
    ind = _independent(equations, G)
    dep = [i for i in range(n) if i not in ind]
    T = np.zeros((n, len(ind)))
    T[ind, range(len(ind))] = 1.0
    T[dep, :] = -np.linalg.solve(G[:, dep], G[:, ind])
    H = _hessians(equations, cm)(t, x, p)
    return TangentSpace(x, ind, T, qdd, lam, np.einsum("k,kij->ij", lam[cm.holonomic], H), tuple(names))


def linearize_constrained(equations: Equations, at: dict, given: set, setting):
    """The LinearModel of a constrained model in its independent coordinates (see the module): at
    rest with holonomic constraints, linearize_at in the tangent space (the unconstrained model's
    linearization with dq = T dz); with velocity constraints or about a steady motion, linearize_steady."""
    from ._linearize import linearize_at

    n = equations.n
    x = np.array([at[s] for s in equations.state_names], float)
    if any(c.kind == VELOCITY for c in equations.model.constraints) or np.any(x[n:] != 0):
        return linearize_steady(equations, at, given, setting)
    return linearize_at(equations, at, setting, given=given)


# ------------------------------------------------------------------ steady motions, velocity constraints
def _jacobian(F, x: np.ndarray) -> np.ndarray:
    """dF/dx by central differences extrapolated twice (Richardson: the error is O(h^6), about 1e-12
    of F's scale for the smooth functions of mechanics; checked against exact derivatives in the tests)."""
    cols = []
    for j in range(len(x)):
        h = 1e-2 * (1.0 + abs(x[j]))
        d = []
        for k in range(3):
            e = np.zeros_like(x)
            e[j] = h / 2 ** k
            d.append((F(x + e) - F(x - e)) / (2 * e[j]))
        d1 = [(4 * d[k + 1] - d[k]) / 3 for k in range(2)]
        cols.append((16 * d1[1] - d1[0]) / 15)
    return np.array(cols).T


def _linearized_parts(cm, t, q, qd, u, p, qdd, lam):
    """At the point: M, f_q, f_qd, f_u, d(M q_ddot0)/dq, d(W^T lambda0)/dq, d(W q_ddot0 - c)/dq and /dq_dot,
    N = dw/dq (cm: the ConstrainedModel, whose compiled M, f, W, c and w are differentiated)."""
    n = cm.n

    def dynamic(z):  # M q_ddot0 - f - W^T lambda0 and W q_ddot0 - c and w, of (q, q_dot, u)
        x = z[:2 * n]
        M, f, W, c = cm.parts(t, x, z[2 * n:], p)
        w = cm._velocity_parts(t, x, p)[0]
        return np.concatenate((M @ qdd - f - W.T @ lam, W @ qdd - c, w))

    J = _jacobian(dynamic, np.concatenate((q, qd, u)))
    m = len(lam)
    M = cm.parts(t, np.concatenate((q, qd)), u, p)[0]
    dyn, con, vel = J[:n], J[n:n + m], J[n + m:]
    return M, dyn[:, :n], dyn[:, n:2 * n], dyn[:, 2 * n:], con[:, :n], con[:, n:2 * n], vel[:, :n]


def _pivot_columns(A: np.ndarray, k: int) -> list[int]:
    """The k best-conditioned columns of A: QR with column pivoting (Businger and Golub), each
    step taking the column with the largest part orthogonal to those taken (NumPy only: importing
    SciPy's QR costs more than a linearization)."""
    R = np.array(A, float)
    taken: list[int] = []
    for _ in range(min(k, R.shape[1])):
        norms = np.linalg.norm(R, axis=0)
        norms[taken] = -1.0
        j = int(np.argmax(norms))
        taken.append(j)
        if norms[j] > 0:
            e = R[:, j] / norms[j]
            R -= np.outer(e, e @ R)
    return sorted(taken)


def _dependent_speeds(equations: Equations, W: np.ndarray, hol: list[int], dep_q: list[int]) -> list[int]:
    """The coordinates whose rates the constraints fix: those of the declared independent speeds'
    complement ([simulation] independent_speeds), else the dependent coordinates (holonomic rows)
    and the best-conditioned columns of the velocity rows once those are eliminated."""
    n = equations.n
    names = [c.name for c in equations.coordinates]
    declared = [str(v) for v in equations.model.simulation.get("independent_speeds", ())]
    m = W.shape[0]
    if declared:
        ind = [names.index(v[:-len("_dot")]) for v in declared]
        dep = [i for i in range(n) if i not in ind]
        if len(dep) != m or np.linalg.matrix_rank(W[:, dep]) < m:
            raise ModelError(f"the independent speeds {', '.join(declared)} ([simulation] independent_speeds) do not "
                             f"determine the other rates at this state ({n} velocities, {m} constraints: {n - m} "
                             "independent speeds are needed, and the constraints must fix the rest); name other "
                             "independent speeds")
        return dep
    vel = [k for k in range(m) if k not in hol]
    rest = [i for i in range(n) if i not in dep_q]
    A = W[np.ix_(vel, rest)]
    if hol:
        Gh = W[hol]
        A = A - W[np.ix_(vel, dep_q)] @ np.linalg.solve(Gh[:, dep_q], Gh[:, rest])
    return sorted(dep_q + [rest[j] for j in _pivot_columns(A, len(vel))])


def linearize_steady(equations: Equations, at: dict, given: set, setting):
    """The LinearModel of a model with velocity constraints, or about a steady motion (see the module)."""
    from ..numeric._compiled import compile_equations
    from ..numeric._constrained import ConstraintSingular, consistent_state, constrained_model, \
        singular_constraint_message
    from ._linearize import LinearModel, _clean, read_only, split_velocity_terms

    n = equations.n
    names = equations.state_names
    coords = [c.name for c in equations.coordinates]
    p, u, t = setting.p, setting.u, setting.t
    cm = constrained_model(equations, compile_equations(equations))
    hol = [int(k) for k in cm.holonomic]
    x = np.array([at[s] for s in names], float)
    declared = {str(v) for v in equations.model.simulation.get("independent_speeds", ())}
    declared |= {str(v) for v in equations.model.simulation.get("independent", ())}
    for k, v in (equations.model.simulation.get("initial") or {}).items():  # guesses for the assembly
        if hol and k in names and k not in given | declared and names.index(k) < n:
            x[names.index(k)] = v
    x = consistent_state(cm, x, given | declared, p)
    for part in (x[:n], x[n:]):  # round-off of the Newton and velocity solves as exact zeros
        part[np.abs(part) <= 1e-13 * (1.0 + np.max(np.abs(part)))] = 0.0
    try:
        qdd, lam = cm.solve(t, x, u, p)
    except ConstraintSingular as s:
        raise ModelError(singular_constraint_message(cm, s.t, s.x, p)) from None
    q0, v0 = x[:n], x[n:]
    _, W, _ = cm._velocity_parts(t, x, p)
    dep_q = [] if not hol else [i for i in range(n) if i not in _independent(equations, W[hol])]
    dep_v = _dependent_speeds(equations, W, hol, dep_q)
    ind_q = [i for i in range(n) if i not in dep_q]
    ind_v = [i for i in range(n) if i not in dep_v]
    still = [coords[i] for i in ind_v if abs(qdd[i]) > 1e-9 * (1.0 + np.max(np.abs(qdd)))]
    if still:
        raise ModelError(f"the state {_state_text(names, x)} is not a steady motion: the independent speeds "
                         f"{', '.join(c + '_dot' for c in still)} change there ("
                         + ", ".join(f"{coords[i]}_ddot = {qdd[i]:.3g}" for i in ind_v if coords[i] in still)
                         + "); linearize about a motion at constant rates, or simulate it")
    M, Kq, Dq, Fu, Rq, Rqd, N = _linearized_parts(cm, t, q0, v0, u, p, qdd, lam)
    m = W.shape[0]
    # dq'' = P [dq; dq'] + Bq du, from [M -W^T; W 0] [dq''; dlambda] = -[Kq dq + Dq dq' + Fu du; Rq dq + Rqd dq']
    # (Kq, Dq, Fu: the derivatives of the residual M q_ddot0 - f - W^T lambda0)
    KKT = np.zeros((n + m, n + m))
    KKT[:n, :n], KKT[:n, n:], KKT[n:, :n] = M, -W.T, W
    rhs = np.zeros((n + m, 2 * n + len(u)))
    rhs[:n, :n], rhs[:n, n:2 * n], rhs[:n, 2 * n:] = -Kq, -Dq, -Fu
    rhs[n:, :n], rhs[n:, n:2 * n] = -Rq, -Rqd
    sol = np.linalg.solve(KKT, rhs)[:n]
    L = np.zeros((2 * n, 2 * n))
    L[:n, n:] = np.eye(n)
    L[n:] = sol[:, :2 * n]
    Bfull = np.zeros((2 * n, len(u)))
    Bfull[n:] = sol[:, 2 * n:]
    # y = Z z, z = (dq at ind_q, dq' at ind_v); the dependent parts from Phi y = 0
    Phi = np.zeros((len(hol) + m, 2 * n))
    if hol:
        Phi[:len(hol), :n] = W[hol]
    Phi[len(hol):, :n], Phi[len(hol):, n:] = N, W
    z_idx = ind_q + [n + i for i in ind_v]
    y_dep = dep_q + [n + i for i in dep_v]
    Z = np.zeros((2 * n, len(z_idx)))
    Z[z_idx, range(len(z_idx))] = 1.0
    Z[y_dep] = -np.linalg.solve(Phi[:, y_dep], Phi[:, z_idx])
    A = L[z_idx] @ Z
    B = Bfull[z_idx]
    # ignorable coordinates: nothing depends on them (their columns vanish); left out, repeatedly
    scale = np.max(np.abs(A), initial=1.0)
    keep = list(range(len(z_idx)))
    ignorable = []
    changed = True
    while changed:
        changed = False
        for j, yi in enumerate(z_idx):
            if j in keep and yi < n and yi not in ind_v:
                others = [r for r in keep if r != j]
                if np.max(np.abs(A[others, j]), initial=0.0) <= 1e-11 * scale:
                    keep.remove(j)
                    ignorable.append(coords[yi])
                    changed = True
    kept_q = [z_idx[j] for j in keep if z_idx[j] < n]
    moving = [coords[i] for i in kept_q if abs(v0[i]) > 1e-12 * (1.0 + np.max(np.abs(v0)))
              and np.max(np.abs(A[keep, z_idx.index(i)]), initial=0.0) > 1e-11 * scale]
    if moving:
        raise ModelError(f"the state {_state_text(names, x)} is not a steady motion: "
                         f"{', '.join(moving)} change{'s' if len(moving) == 1 else ''} there and the motion depends "
                         f"on {'it' if len(moving) == 1 else 'them'}; linearize about a motion in which only "
                         "ignorable coordinates move (a rolling "
                         "wheel's position and spin), or simulate it")
    if kept_q != ind_v:
        extra = [coords[i] for i in kept_q if i not in ind_v]
        raise ModelError(f"the linearization keeps the coordinates {', '.join(extra)} whose rates are not independent "
                         "speeds, and the motion depends on them: choose independent speeds that include their "
                         "rates ([simulation] independent_speeds), where the constraints allow it")
    r = len(ind_v)
    rows = [z_idx.index(i) for i in ind_v] + [z_idx.index(n + i) for i in ind_v]
    Ar, Br = A[np.ix_(rows, rows)], B[rows]
    T = Z[n:, [z_idx.index(n + i) for i in ind_v]]
    Mr = _clean(T.T @ M @ T)
    Kr, Dr, B0 = _clean(-Mr @ Ar[r:, :r]), _clean(-Mr @ Ar[r:, r:]), _clean(Mr @ Br[r:])
    # the coordinates of independent speeds on which nothing depends (a wheel's spin, a heading):
    # cyclic in the linearization, so their drift is not instability
    family = tuple(coords[i] for k, i in enumerate(ind_v) if np.max(np.abs(np.delete(Ar[:, k], k)), initial=0.0)
                   <= 1e-11 * scale)
    C, G = split_velocity_terms(Dr, compile_equations(equations, "scipy").damping(t, np.concatenate((q0, v0)), u, p), T)
    state = tuple(coords[i] for i in ind_v) + tuple(f"{coords[i]}_dot" for i in ind_v)
    point = {s: float(x[names.index(s)]) + 0.0 for s in state}
    return LinearModel(
        equations=equations, coordinate_names=tuple(coords[i] for i in ind_v), state_names=state,
        input_names=tuple(setting.inputs), operating_point=MappingProxyType(point), input_values=setting.inputs,
        parameter_values=setting.parameters, t=setting.t, M=read_only(Mr), C=read_only(C),
        G=read_only(G), K=read_only(Kr), input_matrix=read_only(B0), A=read_only(_clean(Ar)),
        B=read_only(_clean(Br)), accelerations=read_only(np.zeros(r)), family=family, constrained=MappingProxyType({
            "dependent": {names[i]: float(x[i]) + 0.0 for i in dep_q},
            "multipliers": {mu.name: float(v) + 0.0 for mu, v in zip(equations.multipliers, _clean(lam))},
            "basis": T.tolist(),
            "ignorable": ignorable,
            "rates": {f"{coords[i]}_dot": float(v0[i]) + 0.0 for i in range(n)}}))


def _state_text(names, x) -> str:
    return ", ".join(f"{k} = {v:.6g}" for k, v in zip(names, x) if v != 0) or "at rest at 0"
