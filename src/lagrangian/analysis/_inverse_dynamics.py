"""inverse_dynamics(equations, q, q_dot, q_ddot): the generalized forces that hold a pose or drive a
given motion, from the same equations the simulation integrates.

With M(q, t) q_ddot = f(q, q_dot, t, u) (f holds the Coriolis and centrifugal terms, -G = -dV/dq,
the damping and the generalized forces Q of the model's loads and inputs, see
lagrangian.equations), the generalized forces tau to be added to the model's own,

    M q_ddot = f + tau,     that is     tau = M q_ddot + C q_dot + G - Q (- damping forces ...),

are ``tau = M q_ddot - f``: for a state at rest (q_dot = q_ddot = 0), the forces that hold the pose
(the gravity torques G(q) for an arm). The model's inputs keep the values given (default 0), so tau
is what must be added to them.

A constrained model (M q_ddot = f + G^T lambda + tau, the motion consistent with the constraints)
shares M q_ddot - f between the actuators and the constraints: the actuators act on the
coordinates named `actuated` (default: the model's independent coordinates, ``[simulation]
independent``), and ``[E_a G^T] [tau_a; lambda] = M q_ddot - f`` is solved for their forces tau_a and
the multipliers lambda (least squares; with more actuators than degrees of freedom, the smallest
forces). A motion the actuators cannot produce (the residual of that solve is not small) is an error.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np
import symengine as se

from .._util import did_you_mean, number_array, read_only, shown_value
from ..equations import Equations
from ..errors import LagrangianError, ModelError, Problem
from ._setting import resolve_setting

__all__ = ["inverse_dynamics", "InverseDynamics"]

#: The relative residual of the actuated solve above which a motion counts as not producible.
RESIDUAL_TOLERANCE = 1e-8


@dataclass(frozen=True, eq=False)
class InverseDynamics:
    """The generalized forces along a motion (returned by :func:`inverse_dynamics`; immutable).

    Attributes
    ----------
    coordinates : tuple of str, shape (n,)
    t : ndarray, shape (N,)
    q, q_dot, q_ddot : ndarray, shape (N, n)
    tau : ndarray, shape (N, n)
        The generalized forces to add, by coordinate (zero on the coordinates not actuated).
    actuated : tuple of str
        The coordinates tau acts on (all of them without constraints).
    multiplier_names : tuple of str
        ``lambda_<name>``, one per constraint (empty without constraints).
    multipliers : ndarray, shape (N, m)
        The multipliers along the motion (constraint forces G^T lambda).
    total : ndarray, shape (N, n)
        M q_ddot - f: tau + G^T lambda (tau itself without constraints).
    single : bool
        True when one state was given: :attr:`torques` then has shape (n,).
    """

    model_name: str
    coordinates: tuple[str, ...]
    t: np.ndarray
    q: np.ndarray
    q_dot: np.ndarray
    q_ddot: np.ndarray
    tau: np.ndarray
    actuated: tuple[str, ...]
    multiplier_names: tuple[str, ...]
    multipliers: np.ndarray
    total: np.ndarray
    single: bool = False

    @property
    def torques(self) -> np.ndarray:
        """tau, shape (n,) for one state, (N, n) along a motion."""
        return self.tau[0] if self.single else self.tau

    def __getitem__(self, name: str) -> np.ndarray:
        """The force on one coordinate (``result["q1"]``) or a multiplier, shape (N,)."""
        if name in self.coordinates:
            return self.tau[:, self.coordinates.index(name)]
        if name in self.multiplier_names:
            return self.multipliers[:, self.multiplier_names.index(name)]
        names = [*self.coordinates, *self.multiplier_names]
        raise KeyError(f"'{name}' is not a coordinate or a multiplier{did_you_mean(name, names)}; "
                       f"the choices are {', '.join(names)}")

    @property
    def columns(self) -> tuple[str, ...]:
        """The CSV columns: t, tau_<q> for each coordinate, then the multipliers."""
        return ("t", *(f"tau_{c}" for c in self.coordinates), *self.multiplier_names)

    def to_csv(self, path=None) -> str:
        """The table t, tau_<q>..., lambda_<c>... as CSV text (17 significant digits); written to
        `path` (atomically) when given."""
        data = np.column_stack((self.t, self.tau, self.multipliers))
        lines = [",".join(self.columns)]
        lines += [",".join(repr(float(v)) for v in row) for row in data]
        out = "\n".join(lines) + "\n"
        if path is not None:
            from ..io._files import write_output

            write_output(path, out, "-o")
        return out

    def to_dict(self) -> dict:
        """{model, coordinates, actuated, t, q, q_dot, q_ddot, tau, multiplier_names, multipliers, total}:
        lists of numbers (one row per state)."""
        return {"model": self.model_name, "coordinates": list(self.coordinates), "actuated": list(self.actuated),
                "t": self.t.tolist(), "q": self.q.tolist(), "q_dot": self.q_dot.tolist(),
                "q_ddot": self.q_ddot.tolist(), "tau": self.tau.tolist(),
                "multiplier_names": list(self.multiplier_names),
                "multipliers": self.multipliers.tolist(), "total": self.total.tolist()}

    def text(self) -> str:
        rows = len(self.t)
        head = (f"Inverse dynamics of {self.model_name}: tau = M q_ddot - f"
                + (" = tau_a + G^T lambda (actuated: " + ", ".join(self.actuated) + ")" if self.multiplier_names
                   else "") + f", {rows} state{'s' if rows != 1 else ''}")
        lines = [head]
        if rows == 1:
            lines += [f"  tau_{c} = {v:.10g}" for c, v in zip(self.coordinates, self.tau[0])]
            lines += [f"  {c} = {v:.10g}" for c, v in zip(self.multiplier_names, self.multipliers[0])]
            return "\n".join(lines)
        lines.append("  " + "  ".join(f"{c:>14}" for c in self.columns))
        shown = list(range(rows)) if rows <= 12 else [*range(5), -1, *range(rows - 5, rows)]
        for i in shown:
            if i < 0:
                lines.append("  ...")
                continue
            values = [self.t[i], *self.tau[i], *self.multipliers[i]]
            lines.append("  " + "  ".join(f"{v:>14.8g}" for v in values))
        return "\n".join(lines)

    __str__ = text

    def __repr__(self) -> str:
        return f"<InverseDynamics of {self.model_name!r}: {len(self.t)} states, {len(self.coordinates)} coordinates>"


def _array(values, names: Sequence[str], what: str) -> np.ndarray:
    """(N, n) from (n,), (N, n) or a mapping by name (each value a number or an array (N,))."""
    n = len(names)
    if isinstance(values, Mapping):
        unknown = [str(k) for k in values if str(getattr(k, "name", k)) not in names]
        if unknown:
            raise ModelError([Problem(f"'{k}' is not a name of {what}{did_you_mean(k, names)}; the names are "
                                      f"{', '.join(names)}", key=f"{what}.{k}") for k in unknown])
        given = {str(getattr(k, "name", k)): v for k, v in values.items()}
        columns = [np.atleast_1d(np.asarray(_floats(given.get(name, 0.0), f"{what}.{name}"))) for name in names]
        flat = [name for name, c in zip(names, columns) if c.ndim != 1]
        if flat:
            raise ModelError(f"{what}.{flat[0]}: expected one number or a sequence of numbers (one per state), got "
                             f"an array of shape {np.shape(given[flat[0]])}")
        rows = max(len(c) for c in columns)
        if any(len(c) not in (1, rows) for c in columns):
            raise ModelError(f"{what}: the values by name have different lengths "
                             f"({', '.join(f'{k}: {len(c)}' for k, c in zip(names, columns))}); give one value or "
                             "the same number of samples for each")
        return np.column_stack([np.broadcast_to(c, (rows,)) for c in columns])
    a = np.asarray(_floats(values, what))
    if a.ndim not in (1, 2) or a.shape[-1] != n:
        raise ModelError(f"{what}: expected shape ({n},) or (N, {n}), one column per coordinate in the order "
                         f"{', '.join(names)}, got shape {a.shape}")
    return np.atleast_2d(a)


def _ndim(value) -> int:
    """np.ndim(value), or -1 for a ragged list (whose np.ndim is NumPy's ValueError); _floats then says what is
    wrong with it."""
    try:
        return np.ndim(value)
    except ValueError:
        return -1


def _floats(values, where: str) -> np.ndarray:
    a = number_array(values)
    if a is None:
        raise ModelError(f"{where}: expected numbers, got {shown_value(values)}")
    if not np.all(np.isfinite(a)):
        raise ModelError(f"{where}: every value must be a finite number (no NaN or infinity)")
    return a


def inverse_dynamics(equations: Equations, q, q_dot=None, q_ddot=None, *, params: Mapping | None = None,
                     inputs: Mapping | None = None, t=0.0, actuated: Sequence[str] | None = None) -> InverseDynamics:
    """The generalized forces tau = M q_ddot - f that hold a pose or drive a motion (see the module
    docstring: tau = M q_ddot + C q_dot + G - Q).

    Parameters
    ----------
    equations : Equations
    q : array_like, shape (n,) or (N, n), or mapping of coordinate names to values
        The configuration(s), in the model's coordinate order.
    q_dot, q_ddot : array_like of the same shape, or mappings by name (``theta_dot``, ``theta_ddot``)
        Velocities and accelerations (default 0: the forces that hold the pose).
    params : mapping of str to float, optional
        Parameter values that replace the model's.
    inputs : mapping of str to float or array_like (N,), optional
        The model's inputs along the motion (default 0); tau is what is needed beyond them.
    t : float or array_like, shape (N,)
        Time(s), for models that contain t (default 0).
    actuated : sequence of str, optional
        A constrained model's actuated coordinates (default: ``[simulation] independent``).

    Returns
    -------
    InverseDynamics
        ``.torques`` (shape (n,) for one state, (N, n) along a motion), ``.tau``, ``.multipliers``,
        ``.to_csv()``, ``.to_dict()``, ``.text()``.

    Examples
    --------
    >>> import lagrangian as lg
    >>> eqs = lg.derive(lg.load("double-pendulum"))
    >>> [round(v, 6) for v in lg.inverse_dynamics(eqs, [0.5, 0.0]).torques]  # g*l1*(m1 + m2)*sin(0.5), 0
    [9.406329, 0.0]
    """
    if not isinstance(equations, Equations):
        raise TypeError(f"inverse_dynamics() expects Equations (lagrangian.derive(model)), got "
                        f"{type(equations).__name__}")
    eq = equations
    names = [c.name for c in eq.coordinates]
    single = (all(_ndim(v) == 0 for v in q.values()) if isinstance(q, Mapping) else _ndim(q) == 1)
    Q = _array(q, names, "q")
    rows = Q.shape[0]
    parts = {}
    for key, value, labels in (("q_dot", q_dot, [f"{c}_dot" for c in names]),
                               ("q_ddot", q_ddot, [f"{c}_ddot" for c in names])):
        a = np.zeros_like(Q) if value is None else _array(value, labels, key)
        if a.shape[0] == 1 and rows > 1:
            a = np.broadcast_to(a, Q.shape)
        if a.shape != Q.shape:
            raise ModelError(f"{key}: {a.shape[0]} rows, q has {rows}: give one row per state")
        parts[key] = np.array(a, dtype=float)
    unames = [u.name for u in eq.inputs]
    if inputs is not None and not isinstance(inputs, Mapping):
        raise ModelError([Problem(f"inputs must be a mapping of names to numbers or arrays (one value per state), "
                                  f"such as {{'{unames[0] if unames else 'F'}': 1.0}}, got {type(inputs).__name__} "
                                  f"{shown_value(inputs)}", key="inputs")])
    constant = {k: v for k, v in (inputs or {}).items() if _ndim(v) == 0}
    varying = {str(getattr(k, "name", k)): v for k, v in (inputs or {}).items() if _ndim(v) != 0}
    setting = resolve_setting(eq, params, constant, 0.0)
    tt = _floats(t, "t")
    if tt.ndim == 0:
        tt = np.full(rows, float(tt))
    if tt.shape != (rows,):
        raise ModelError(f"t: expected one time or {rows} (one per state), got shape {tt.shape}")
    U = np.tile(setting.u, (rows, 1)) if unames else np.zeros((rows, 0))
    for name, values in varying.items():
        if name not in unames:
            raise ModelError([Problem(f"'{name}' is not an input of the model{did_you_mean(name, unames)}; the "
                                      f"choices are {', '.join(unames) or 'none'}", key=f"inputs.{name}")])
        v = _floats(values, f"inputs.{name}")
        if v.shape != (rows,):
            raise ModelError(f"inputs.{name}: expected one value or {rows} (one per state), got shape {v.shape}")
        U[:, unames.index(name)] = v
    n, m = eq.n, len(eq.core.g)
    X = np.column_stack((Q, parts["q_dot"]))
    evaluate = _evaluator(eq)
    out = evaluate(tt, X, U, setting.p)
    M = out[:, :n * n].reshape(rows, n, n)
    f = out[:, n * n:n * n + n]
    total = np.einsum("kij,kj->ki", M, parts["q_ddot"]) - f
    if not np.all(np.isfinite(total)):
        bad = int(np.argmax(~np.all(np.isfinite(total), axis=1)))
        raise LagrangianError(f"M q_ddot - f is not finite at state {bad} (t = {tt[bad]:g}, q = {Q[bad].tolist()}): "
                              "the model's expressions are singular there (a division by zero)")
    if not m:
        if actuated is not None and set(_actuated(eq, actuated)) != set(names):
            raise ModelError(f"actuated: model '{eq.model.name}' has no constraints, so every coordinate is actuated "
                             f"and tau has one force per coordinate ({', '.join(names)}); leave actuated out (it "
                             "names the actuated coordinates of a mechanism with constraints)")
        tau, lam, act = total, np.zeros((rows, 0)), tuple(names)
    else:
        G = out[:, n * n + n:n * n + n + m * n].reshape(rows, m, n)
        g, w, c = (out[:, n * n + n + m * n + k * m:n * n + n + m * n + (k + 1) * m] for k in range(3))
        act = _actuated(eq, actuated)
        _check_consistent(eq, Q, parts["q_dot"], parts["q_ddot"], G, g, w, c, tt)
        tau, lam = _split(eq, total, G, [names.index(a) for a in act], tt)
    return InverseDynamics(eq.model.name, tuple(names), read_only(tt), read_only(Q), read_only(parts["q_dot"]),
                           read_only(parts["q_ddot"]), read_only(tau), act,
                           tuple(mu.name for mu in eq.multipliers), read_only(lam), read_only(total), single)


def _evaluator(eq: Equations):
    """(t (N,), x (N, 2n), u (N, k), p) -> (N, n*n + n + m*n): M, f and G by the one numeric model."""
    from ..numeric._compiled import compile_equations

    core, n, m = eq.core, eq.n, len(eq.core.g)

    def build():
        exprs = [core.M[i, j] for i in range(n) for j in range(n)] + list(core.f)
        if m:
            exprs += [core.G[k, j] for k in range(m) for j in range(n)] + list(core.g) + list(core.w) + list(core.c)
        return exprs or [se.Integer(0)]

    return compile_equations(eq, "scipy").function("inverse dynamics", build)


def _actuated(eq: Equations, actuated) -> tuple[str, ...]:
    names = [c.name for c in eq.coordinates]
    if actuated is None:
        independent = list((eq.model.simulation or {}).get("independent") or ())
        if not independent:
            raise ModelError(f"model '{eq.model.name}' has {len(eq.model.constraints)} constraint(s): say which "
                             "coordinates the actuators act on, e.g. actuated=['" + names[0] + "'] (--actuated "
                             f"{names[0]} on the command line), or name the independent coordinates in the model "
                             "file ([simulation] independent = [...]), the default")
        actuated = independent
    if isinstance(actuated, str):
        actuated = [actuated]
    if not isinstance(actuated, (list, tuple)) or not all(isinstance(a, str) for a in actuated):
        raise ModelError(f"actuated must be a list of coordinate names, e.g. actuated=['{names[0]}'], got "
                         f"{shown_value(actuated)}; the coordinates are {', '.join(names)}")
    problems = [Problem(f"'{a}' is not a coordinate{did_you_mean(a, names)}; the coordinates are "
                        f"{', '.join(names)}", key=f"actuated.{a}") for a in actuated if a not in names]
    if problems:
        raise ModelError(problems)
    if not actuated or len(set(actuated)) != len(actuated):
        raise ModelError("actuated: name each actuated coordinate once, at least one, e.g. actuated=['"
                         + names[0] + "']")
    return tuple(actuated)


#: The relative size of g, G q_dot + b and G q_ddot - c above which a motion does not meet the constraints.
CONSTRAINT_TOLERANCE = 1e-6


def _check_consistent(eq: Equations, Q, V, A, G, g, w, c, t) -> None:
    """Every state on the constraints: g = 0 (holonomic), G q_dot + b = 0, G q_ddot = c."""
    acc = np.einsum("kij,kj->ki", G, A) - c
    holonomic = np.array([con.kind == "holonomic" for con in eq.model.constraints])
    for level, values, scale, what in (
            ("g(q, t) = 0", np.where(holonomic, g, 0.0), 1.0 + np.abs(Q).max(axis=1), "coordinates"),
            ("G q_dot + b = 0", w, 1.0 + np.abs(V).max(axis=1), "velocities"),
            ("G q_ddot = c", acc, 1.0 + np.abs(A).max(axis=1) + np.abs(c).max(axis=1), "accelerations")):
        bad = np.abs(values) > CONSTRAINT_TOLERANCE * scale[:, None]
        if bad.any():
            k, j = map(int, np.argwhere(bad)[0])
            name = eq.model.constraints[j].name
            raise ModelError(f"state {k} (t = {t[k]:g}) does not meet the constraint '{name}' at the level of the "
                             f"{what} ({level}: residual {values[k, j]:.3g}): inverse dynamics needs a motion the "
                             "mechanism can make; give consistent q, q_dot and q_ddot (a simulated trajectory's, or "
                             "q from the constraints and q_dot, q_ddot from their derivatives)")


def _split(eq: Equations, total, G, columns, t) -> tuple[np.ndarray, np.ndarray]:
    """tau (zeros off the actuated columns) and lambda with [E_a G^T] [tau_a; lambda] = total."""
    rows, n = total.shape
    m = G.shape[1]
    tau = np.zeros((rows, n))
    lam = np.zeros((rows, m))
    for k in range(rows):
        A = np.zeros((n, len(columns) + m))
        A[columns, range(len(columns))] = 1.0
        A[:, len(columns):] = G[k].T
        z, *_ = np.linalg.lstsq(A, total[k], rcond=None)
        residual = np.abs(A @ z - total[k]).max()
        scale = 1.0 + np.abs(total[k]).max()
        if residual > RESIDUAL_TOLERANCE * scale:
            names = [eq.coordinates[j].name for j in columns]
            raise ModelError(f"at state {k} (t = {t[k]:g}) the actuators on {', '.join(names)} and the constraints "
                             f"cannot produce the motion (residual {residual:.3g} of M q_ddot - f): the accelerations "
                             "do not meet the constraints (G q_ddot = c), or the actuated coordinates do not move "
                             "the mechanism there; give consistent q, q_dot, q_ddot, or actuate other coordinates "
                             "(actuated=[...])")
        tau[k, columns] = z[:len(columns)]
        lam[k] = z[len(columns):]
    return tau, lam
