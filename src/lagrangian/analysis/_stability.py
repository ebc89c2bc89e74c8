"""The stability of a stationary state (equilibrium or steady motion), right or absent.

From the linearization of all 2n states about it, with the positions of the cyclic coordinates
and the directions along a non-isolated set of states left out (moving along them changes nothing):

* "unstable": an eigenvalue with a positive real part (Lyapunov's indirect method);
* "asymptotically stable": every eigenvalue in the open left half-plane;
* "stable": Lagrange-Dirichlet, or Routh with cyclic coordinates: the potential of the forces at
  fixed momenta (the amended potential) has a positive definite Hessian and the damping is
  positive semi-definite;
* "marginally stable": eigenvalues on the imaginary axis, non-defective: the linearization is
  bounded but does not decide the nonlinear system;
* where the linearization is degenerate (K singular, or defective eigenvalues on the axis) it does
  not decide: with one unknown known exactly, the first non-zero derivative of the force does (a
  restoring force of odd order: stable; otherwise unstable); else "undetermined (degenerate ...)".
  Where M is singular, or a derivative is not finite, the stability is undetermined too.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np
import sympy

from .._util import read_only
from ..errors import ModelError
from ..numeric._compiled import compile_equations
from ._setting import Setting
from ._stationary import StationaryProblem, conserved_cyclic, constant_map, state_velocities

__all__ = ["assess", "Assessment", "classify_across", "routh_stiffness", "UNDETERMINED", "DEGENERATE", "NOT_FINITE"]


#: The stability of a stationary state where M is singular: no linearization exists there.
UNDETERMINED = "undetermined (singular mass matrix)"
#: Where the linearization has eigenvalues on the imaginary axis with K singular (or defective
#: ones) and no higher-order test decides.
DEGENERATE = "undetermined (degenerate: the linearization does not decide)"
#: Where a derivative of the equations is infinite or undefined.
NOT_FINITE = "undetermined (the linearization is not finite there)"


@dataclass(frozen=True)
class Assessment:
    """The linearization about a stationary state and what it says about its stability."""

    linear_model: object
    stability: str
    stable: bool
    eigenvalues: np.ndarray
    velocities: np.ndarray


def routh_stiffness(problem: StationaryProblem, setting: Setting, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """K = -d f/dq along the stationary states at fixed momenta of the conserved cyclic coordinates
    (Routh: the Hessian of the amended potential, when the forces derive from one); -df/dq at
    rest when there is no such coordinate."""
    eqs = problem.equations
    nm = compile_equations(eqs)
    n = eqs.n
    x = np.concatenate((q, qd))
    parts = nm.jacobians(setting.t, x, setting.u, setting.p)
    idx = [i for i in conserved_cyclic(eqs)]
    if not idx:
        return -parts["fq"]
    _, pq, M = nm.momenta(setting.t, x, setting.u, setting.p)
    dqd = np.zeros((n, n))
    try:
        dqd[idx] = -np.linalg.solve(M[np.ix_(idx, idx)], pq[idx])
    except np.linalg.LinAlgError:
        return -parts["fq"]
    return -(parts["fq"] + parts["fqd"] @ dqd)


def _basis(problem: StationaryProblem, tangent: np.ndarray) -> tuple[np.ndarray, int]:
    """An orthonormal basis of q-space: the directions across the set of states (kept), then along
    it, then the cyclic coordinates; and the number kept."""
    n = problem.equations.n
    unit = np.eye(n)[:, list(problem.unknowns)]
    if tangent.shape[1]:
        t, _ = np.linalg.qr(tangent)
        rest = unit - t @ (t.T @ unit)
        u, s, _ = np.linalg.svd(rest, full_matrices=False)
        across = u[:, : len(problem.unknowns) - t.shape[1]]
    else:
        t, across = np.zeros((n, 0)), unit
    family = np.eye(n)[:, [i for i in range(n) if i not in problem.unknowns]]
    return np.hstack((across, t, family)), across.shape[1]


def assess(problem: StationaryProblem, setting: Setting, q: np.ndarray, tangent: np.ndarray | None = None,
           exact: Mapping | None = None, exact_solution: dict | None = None) -> Assessment:
    """Linearize about the stationary state at q and classify it (see the module docstring of
    lagrangian.analysis._equilibria for the classes)."""
    from ..errors import SingularMassMatrixError
    from ._linearize import linearize_at

    eqs = problem.equations
    n = eqs.n
    qd, _ = state_velocities(problem, setting, q)
    point = dict(zip(eqs.state_names, [*map(float, q), *map(float, qd)]))
    tangent = np.zeros((n, 0)) if tangent is None else tangent
    try:
        lin = linearize_at(eqs, point, setting, exact)
    except SingularMassMatrixError:
        return Assessment(None, UNDETERMINED, False, read_only(np.zeros(0, complex)), qd)
    except ModelError:
        return Assessment(None, NOT_FINITE, False, read_only(np.zeros(0, complex)), qd)
    K = routh_stiffness(problem, setting, q, qd)
    P, kept = _basis(problem, tangent)
    stability, stable, degenerate, Cp = classify_across(lin.A, K, lin.C, lin.G, P, kept)
    if degenerate:
        stability, stable = _higher_order(problem, setting, tangent, exact_solution, Cp)
    return Assessment(lin, stability, stable, lin.eigenvalues, qd)


def classify_across(A, K, C, G, P: np.ndarray, kept: int, energy: bool = True) -> tuple[str, bool, bool, np.ndarray]:
    """(stability, stable, degenerate, the velocity terms C + G in the basis) of the linearization A (2n x 2n), K, C,
    G (n x n) in the orthonormal basis P of q-space whose first `kept` columns run across the set of
    stationary states (the others along it: moving along them changes nothing). `degenerate`: the
    linearization does not decide (no eigenvalue grows, and K is singular across the set or an
    eigenvalue on the axis is defective), so a higher-order test must. `energy`: whether
    Lagrange-Dirichlet may decide (see `classify`)."""
    from ._linearize import classify

    n = P.shape[0]
    B = np.zeros((2 * n, 2 * n))
    B[:n, :n] = B[n:, n:] = P
    A = B.T @ np.asarray(A) @ B
    Kp, Cp, Gp = (P.T @ np.asarray(m) @ P for m in (K, C, G))
    keep = np.arange(kept)
    stability, stable, _ = classify(A, Kp, Cp, Gp, keep, energy)
    degenerate = False
    if stability in ("unstable", "marginally stable"):
        rows = np.concatenate((keep, n + np.arange(n)))
        lam = np.linalg.eigvals(A[np.ix_(rows, rows)]) if rows.size else np.zeros(0)
        scale = max(1.0, float(np.abs(lam).max(initial=0.0)))
        growing = lam.size and float(np.max(lam.real)) > 1e-7 * scale
        Kt = Kp[np.ix_(keep, keep)]
        sv = np.linalg.svd(Kt, compute_uv=False) if Kt.size else np.zeros(0)
        singular = bool(sv.size) and sv.min() <= 1e-9 * max(float(sv.max()), 1e-300)
        degenerate = bool(not growing and (stability == "unstable" or singular))
    return stability, stable, degenerate, Cp + Gp


def _higher_order(problem: StationaryProblem, setting: Setting, tangent: np.ndarray, solution: dict | None,
                  damping: np.ndarray) -> tuple[str, bool]:
    """A degenerate stationary state with one unknown, exactly known, and no rate fixed by value:
    the first non-zero derivative of its force decides (a restoring force of odd order: a strict
    minimum of the potential, stable by Lagrange-Dirichlet; otherwise unstable)."""
    if (solution is None or len(problem.unknowns) != 1 or tangent.shape[1]
            or any(v != 0 for v in problem.velocities.values())):
        return DEGENERATE, False
    sym = (damping + damping.T) / 2
    if sym.size and np.linalg.eigvalsh(sym).min() < -1e-9 * max(1.0, np.abs(sym).max()):
        return DEGENERATE, False
    i = problem.unknowns[0]
    x = problem.equations.coordinates[i]
    values = constant_map(problem, setting, sympy.Rational)
    root = solution[i].subs(values)
    g = problem.static_sympy[i].subs(values)
    try:
        for k in range(1, 9):
            g = sympy.diff(g, x)
            terms = [complex(term.subs(x, root).evalf(50)) for term in sympy.Add.make_args(sympy.expand(g))]
            value, size = sum(terms), sum(abs(z) for z in terms)
            if abs(value) > 1e-12 * size:  # not a cancellation of round-off in the parameter values
                if k % 2 and value.real < 0:
                    return "stable", True
                return "unstable", False
    except (TypeError, ValueError, ZeroDivisionError):
        pass
    return DEGENERATE, False



