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
"""

from __future__ import annotations

from types import MappingProxyType

import numpy as np
import symengine as se

from ..equations import Equations
from ..errors import ModelError, Problem
from ..model._constraints import VELOCITY

__all__ = ["linearize_constrained"]


def _hessians(equations: Equations, cm):
    """(t, x, p) -> the Hessians of the holonomic constraints, shape (k, n, n)."""
    core = equations.core
    n = equations.n
    exprs = [core.g[k].diff(a).diff(b) for k in cm.holonomic for a in core.q for b in core.q]
    params = [se.Symbol(p.name) for p in equations.parameters]
    f = se.Lambdify([core.t, *core.q, *core.qd, *params], exprs or [se.Integer(0)], cse=True, real=True)
    k = len(cm.holonomic)
    return lambda t, x, p: np.asarray(f(np.concatenate(([t], x, p))), float).ravel()[:k * n * n].reshape(k, n, n)


def _independent(equations: Equations, G: np.ndarray) -> list[int]:
    """The independent coordinates: those the model declares ([simulation] independent), else the
    ones left when the best-conditioned columns of G (QR with column pivoting) are taken as dependent."""
    from scipy.linalg import qr

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
    _, _, piv = qr(G, pivoting=True)
    dep = sorted(piv[:m])
    return [i for i in range(n) if i not in dep]


def linearize_constrained(equations: Equations, at: dict, given: set, setting):
    """The LinearModel of a constrained model in its independent coordinates (see the module)."""
    from ..numeric._compiled import compile_equations
    from ..numeric._constrained import ConstraintSingular, consistent_state, constrained_model, \
        singular_constraint_message
    from ._linearize import LinearModel, _clean, read_only
    from ._setting import derivatives

    if any(c.kind == VELOCITY for c in equations.model.constraints):
        raise ModelError("linearize does not handle velocity (nonholonomic) constraints yet: simulate the model, "
                         "or write the constraint as a holonomic one where it integrates")
    n = equations.n
    names = equations.state_names
    x = np.array([at[s] for s in names], float)
    if np.any(x[n:] != 0):
        raise ModelError([Problem("a constrained model is linearized about a configuration at rest: give "
                                  "coordinates only (the velocities 0)", key="at")])
    p, u, t = setting.p, setting.u, setting.t
    cm = constrained_model(equations, compile_equations(equations))
    for k, v in (equations.model.simulation.get("initial") or {}).items():  # guesses for the others
        if k in names and k not in given and names.index(k) < n:
            x[names.index(k)] = v
    x = consistent_state(cm, x, given | {s for s in names[n:]}, p)
    try:
        qdd, lam = cm.solve(t, x, u, p)
    except ConstraintSingular as s:
        raise ModelError(singular_constraint_message(cm, s.t, s.x, p)) from None
    d = derivatives(equations)
    parts = d.full(x[:n], x[n:], t, u, p, np.zeros(n))
    M = parts["M"]
    scale = np.max(np.abs(parts["f"]), initial=0.0) / max(np.max(np.abs(np.diag(M))), 1e-300) + 1e-300
    if np.max(np.abs(qdd), initial=0.0) > 1e-6 * max(scale, 1.0):  # g = 0 is met to sqrt(eps) at a tangency
        where = ", ".join(f"{k} = {v:.6g}" for k, v in zip(names[:n], x[:n]))
        accel = ", ".join(f"{q.name}_ddot = {a:.3g}" for q, a in zip(equations.coordinates, qdd) if abs(a) > 0)
        raise ModelError(f"the configuration {where} is not at rest: the constrained accelerations there are "
                         f"{accel}; linearize about an equilibrium (where the forces balance on the constraints), "
                         "or simulate the motion")
    _, G, _ = cm._velocity_parts(t, x, p)
    ind = _independent(equations, G)
    dep = [i for i in range(n) if i not in ind]
    T = np.zeros((n, len(ind)))
    T[ind, range(len(ind))] = 1.0
    T[dep, :] = -np.linalg.solve(G[:, dep], G[:, ind])
    H = _hessians(equations, cm)(t, x, p)
    K = parts["Maq"] - parts["fq"] - np.einsum("k,kij->ij", lam[cm.holonomic], H)
    D = -parts["fqd"]
    Mr, Kr, Dr = _clean(T.T @ M @ T), _clean(T.T @ K @ T), _clean(T.T @ D @ T)
    Kr = (Kr + Kr.T) / 2 if np.allclose(Kr, Kr.T, rtol=1e-10, atol=1e-12 * np.abs(Kr).max(initial=1)) else Kr
    B0 = _clean(T.T @ parts["fu"])
    r = len(ind)
    A = np.zeros((2 * r, 2 * r))
    A[:r, r:] = np.eye(r)
    A[r:, :r] = -np.linalg.solve(Mr, Kr)
    A[r:, r:] = -np.linalg.solve(Mr, Dr)
    B = np.zeros((2 * r, B0.shape[1]))
    if B0.size:
        B[r:] = np.linalg.solve(Mr, B0)
    coords = tuple(names[i] for i in ind)
    state = coords + tuple(f"{c}_dot" for c in coords)
    point = {s: 0.0 for s in state}
    point.update({names[i]: float(x[i]) for i in ind})
    return LinearModel(
        equations=equations, coordinate_names=coords, state_names=state, input_names=tuple(setting.inputs),
        operating_point=MappingProxyType(point), input_values=setting.inputs, parameter_values=setting.parameters,
        t=setting.t, M=read_only(Mr), C=read_only((Dr + Dr.T) / 2), G=read_only((Dr - Dr.T) / 2), K=read_only(Kr),
        input_matrix=read_only(B0), A=read_only(_clean(A)), B=read_only(_clean(B)), accelerations=read_only(np.zeros(r)),
        family=(), constrained=MappingProxyType({
            "dependent": {names[i]: float(x[i]) for i in dep},
            "multipliers": {mu.name: float(v) + 0.0 for mu, v in zip(equations.multipliers, _clean(lam))},
            "basis": T.tolist()}))
