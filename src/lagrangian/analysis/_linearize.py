"""linearize(equations, at=...) -> LinearModel, and the stability of a linearization.

About an operating point (q0, q_dot0, u0) where M0 q_ddot0 = f0, the residuals
E = M(q) q_ddot - f(q, q_dot, t, u) give, to first order in the deviations,

    M0 dq'' + (C0 + G0) dq' + K0 dq = B0 du,

with M0 = M(q0), K0 = d(M q_ddot0)/dq - df/dq, C0 + G0 = -df/dq_dot (C0 its symmetric part: damping;
G0 its skew-symmetric part: gyroscopic, and Coriolis terms away from rest) and B0 = df/du, all at the
operating point. The state-space form x' = A x + B u, x = [dq, dq_dot], has

    A = [[0, I], [-M0^-1 K0, -M0^-1 (C0 + G0)]],   B = [[0], [M0^-1 B0]]

(outputs y = x: C = I, D = 0). Everything comes from derivatives evaluated at the point and a
linear solve with M0; nothing divides by a symbolic M, so no NaN appears.

A model with m holonomic constraints is the same linearization in the coordinates z of the
constraints' tangent space at the point, dq = T dz (T = [I; -G_d^-1 G_i], ``_constrained_linear``):
M0, C0 + G0, K0 and B0 become T^T M0 T, ..., T^T B0, and K0 gains the constraint forces' stiffness
-sum_k lambda_k H_k. At m = 0, T = I and there is none: one assembly (:func:`assembled`) for both.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass, field
from functools import cached_property
from types import MappingProxyType
from typing import Mapping

import numpy as np
import symengine as se
import sympy

from ..equations import Equations, singularities
from ..equations._equations import _depends_on, _latex_name, vector_names
from ..equations._exact import exact_number
from ..equations._singular import diagnosis_at, inertia_measure
from ..errors import ModelError, Problem, SingularMassMatrixError
from ..model._kinematics import to_sympy
from ..numeric._compiled import compile_equations
from .._util import named_values, number_array, read_only, shown_value
from ._setting import Setting, collect_setting

__all__ = ["linearize", "LinearModel", "SymbolicLinearization", "classify", "STABILITY"]

#: The stability classes, from the eigenvalues of A and the Lagrange-Dirichlet criterion.
STABILITY = ("asymptotically stable", "stable", "marginally stable", "unstable")

_SINGULAR = 1e-12
_ROUND_OFF = 1e-14


@dataclass(frozen=True)
class SymbolicLinearization:
    """The linearization with symbolic parameters (SymPy matrices), at an exact operating point.

    M, C, G, K: shape (n, n); input_matrix: shape (n, m); A: (2n, 2n); B: (2n, m)."""

    M: sympy.ImmutableMatrix
    C: sympy.ImmutableMatrix
    G: sympy.ImmutableMatrix
    K: sympy.ImmutableMatrix
    input_matrix: sympy.ImmutableMatrix
    A: sympy.ImmutableMatrix
    B: sympy.ImmutableMatrix


def classify(A: np.ndarray, K: np.ndarray, C: np.ndarray, G: np.ndarray,
             keep: np.ndarray | None = None, energy: bool = True) -> tuple[str, bool, bool | None]:
    """(stability class, stable, Lagrange-Dirichlet applies and holds) of a linearization.

    `keep` selects the coordinates whose positions matter: a cyclic coordinate (one the equations do
    not contain) is left out, so the free drift along it is not counted as instability.

    * unstable: an eigenvalue of A with a positive real part, or a defective one on the imaginary axis;
    * asymptotically stable: every eigenvalue in the open left half-plane;
    * stable: Lagrange-Dirichlet: K symmetric positive definite (a strict minimum of the potential,
      centrifugal potential included), damping positive semi-definite: stable for the nonlinear
      system too (only with `energy`: False for a linearization about a steady motion of a
      constrained model, or with velocity constraints, whose K is not the Hessian of a potential);
    * marginally stable: eigenvalues on the imaginary axis, non-defective: the linearization is
      bounded but does not decide the nonlinear system.
    """
    n = K.shape[0]
    keep = np.arange(n) if keep is None else np.asarray(keep, dtype=int)
    rows = np.concatenate((keep, n + np.arange(n)))
    Ar = A[np.ix_(rows, rows)]
    lam = np.linalg.eigvals(Ar) if Ar.size else np.zeros(0, complex)
    scale = max(1.0, float(np.max(np.abs(lam)))) if lam.size else 1.0
    tol = 1e-7 * scale
    Kr = K[np.ix_(keep, keep)]
    ld = None
    if energy and Kr.size and np.allclose(Kr, Kr.T, rtol=1e-9, atol=1e-12 * max(1.0, np.abs(Kr).max())):
        Cs = (C + G + (C + G).T) / 2  # the velocity terms' power: damping and any other symmetric part
        c_ok = not Cs.size or np.linalg.eigvalsh(Cs).min() >= -1e-9 * max(1.0, np.abs(Cs).max())
        kmin = np.linalg.eigvalsh((Kr + Kr.T) / 2).min()
        ld = bool(c_ok and kmin > 1e-9 * max(1.0, np.abs(Kr).max()))
    if lam.size and np.max(lam.real) > tol:
        return "unstable", False, ld
    if not lam.size or np.max(lam.real) < -tol:
        return "asymptotically stable", True, ld
    if ld:
        return "stable", True, ld
    # eigenvalues on the imaginary axis: bounded only if each is non-defective
    on_axis = lam[np.abs(lam.real) <= tol]
    seen: list[complex] = []
    for z in on_axis:
        if any(abs(z - s) <= tol for s in seen):
            continue
        seen.append(z)
        algebraic = int(np.sum(np.abs(lam - z) <= tol))
        rank = np.linalg.matrix_rank(Ar - z * np.eye(len(Ar)), tol=1e-6 * scale)
        if len(Ar) - rank < algebraic:
            return "unstable", False, ld
    return "marginally stable", True, ld


@dataclass(frozen=True, eq=False)
class LinearModel:
    """A linearization (returned by :func:`linearize`); all arrays are read-only.

    Attributes
    ----------
    coordinate_names, state_names, input_names : tuple of str
        n coordinates; the state x = [q, q_dot] (2n); m inputs.
    operating_point : mapping of str to float
        q0 and q_dot0 by state name.
    input_values, parameter_values : mapping of str to float
    t : float
    M, C, G, K : ndarray, shape (n, n)
        M0 dq'' + (C + G) dq' + K dq = input_matrix du, with C the damping (symmetric part of
        -df/dq_dot) and G the gyroscopic part (skew-symmetric).
    input_matrix : ndarray, shape (n, m)
    A : ndarray, shape (2n, 2n)
    B : ndarray, shape (2n, m)
    accelerations : ndarray, shape (n,)
        q_ddot0 at the operating point (zero at an equilibrium).
    family : tuple of str
        Cyclic coordinates (absent from the equations): moving along them changes nothing.
    """

    equations: Equations = field(repr=False)
    coordinate_names: tuple[str, ...]
    state_names: tuple[str, ...]
    input_names: tuple[str, ...]
    operating_point: Mapping[str, float]
    input_values: Mapping[str, float]
    parameter_values: Mapping[str, float]
    t: float
    M: np.ndarray = field(repr=False)
    C: np.ndarray = field(repr=False)
    G: np.ndarray = field(repr=False)
    K: np.ndarray = field(repr=False)
    input_matrix: np.ndarray = field(repr=False)
    A: np.ndarray = field(repr=False)
    B: np.ndarray = field(repr=False)
    accelerations: np.ndarray = field(repr=False)
    family: tuple[str, ...] = ()
    _exact_point: Mapping = field(default_factory=lambda: MappingProxyType({}), repr=False)
    #: For a constrained model (linearized in its independent coordinates): "dependent" (the other
    #: coordinates' values at the point), "multipliers" (lambda there) and "basis" (T, dq = T dq_i).
    constrained: Mapping = field(default_factory=lambda: MappingProxyType({}), repr=False)

    @property
    def n(self) -> int:
        return len(self.coordinate_names)

    @property
    def output_names(self) -> tuple[str, ...]:
        """The outputs y of the state-space form: the states, then the model's named outputs
        (``Model.add_output``, ``[outputs]``)."""
        return (*self.state_names, *self.equations.model.outputs)

    @property
    def output_matrix(self) -> np.ndarray:
        """C of the state-space form y = C x + D u: the identity (y = x), shape (2n, 2n), followed by
        one row d(output)/dx at the point for each named output, shape (2n + r, 2n)."""
        return np.vstack((np.eye(2 * self.n), self._outputs[0]))

    @property
    def feedthrough(self) -> np.ndarray:
        """D of the state-space form: zeros for the states, then d(output)/du at the point for each
        named output, shape (2n + r, m)."""
        return np.vstack((np.zeros((2 * self.n, len(self.input_names))), self._outputs[1]))

    @cached_property
    def _outputs(self) -> tuple[np.ndarray, np.ndarray]:
        """(C, D) of the named outputs alone: shapes (r, 2n), (r, m)."""
        return _output_rows(self)

    @property
    def is_equilibrium(self) -> bool:
        """Whether the operating point is at rest with zero acceleration."""
        qd = np.array([self.operating_point[s] for s in self.state_names[self.n:]])
        scale = 1.0 + float(np.abs(self.A).max()) if self.A.size else 1.0
        return bool(np.all(qd == 0) and np.all(np.abs(self.accelerations) <= 1e-9 * scale))

    @cached_property
    def eigenvalues(self) -> np.ndarray:
        """Eigenvalues of A, shape (2n,), sorted by real part then imaginary part."""
        lam = np.linalg.eigvals(self.A)
        if lam.size:  # round-off (8.9e-16 beside 5.8j) as exact zeros
            tiny = 1e-12 * float(np.abs(lam).max())
            lam = (np.where(np.abs(lam.real) <= tiny, 0.0, lam.real)
                   + 1j * np.where(np.abs(lam.imag) <= tiny, 0.0, lam.imag))
        lam = lam[np.lexsort((lam.imag, lam.real))]
        return read_only(lam)

    @property
    def lagrange_dirichlet_applies(self) -> bool:
        """Whether K is the Hessian of a potential, so that Lagrange-Dirichlet may decide: not about a
        steady motion of a constrained model, nor with velocity constraints."""
        return not (self.constrained and "rates" in self.constrained)

    @cached_property
    def _stability(self):
        keep = [i for i, c in enumerate(self.coordinate_names) if c not in self.family]
        return classify(self.A, self.K, self.C, self.G, np.array(keep, dtype=int),
                        energy=self.lagrange_dirichlet_applies)

    @property
    def stability(self) -> str:
        """One of STABILITY (see :func:`classify`)."""
        return self._stability[0]

    @property
    def stable(self) -> bool:
        """True unless the linearization is unstable (marginal counts as stable)."""
        return self._stability[1]

    @property
    def lagrange_dirichlet(self) -> bool | None:
        """Whether the Lagrange-Dirichlet criterion holds (K positive definite, damping positive
        semi-definite); None where it does not apply (K not symmetric)."""
        return self._stability[2]

    @cached_property
    def symbolic(self) -> SymbolicLinearization:
        """The same linearization with symbolic parameters, at the exact operating point
        (floats given for it are read as exact numbers, 3.14159... as pi)."""
        return _symbolic(self)

    def to_control(self):
        """A python-control StateSpace (A, B, C, D) with the state, input and output names: the
        outputs are the states (C = I, D = 0) followed by the model's named outputs (their rows of
        :attr:`output_matrix` and :attr:`feedthrough`), so that ``control.bode(sys[tip_x, F])``
        works (needs the optional extra: pip install "lagrangian[control]")."""
        try:
            import control
        except ImportError:
            raise ImportError("to_control() needs python-control: pip install \"lagrangian[control]\"") from None
        return control.ss(self.A, self.B, self.output_matrix, self.feedthrough,
                          states=list(self.state_names), inputs=list(self.input_names),
                          outputs=list(self.output_names))

    def lqr(self, Q=None, R=None, *, sample_time: float | None = None):
        """The linear-quadratic regulator u = u0 - K (x - x0) of this linearization (see
        :func:`lagrangian.control.lqr`): Q weighs the states (by name, as a vector or a matrix),
        R the inputs; `sample_time` designs for a sampled controller. Returns a
        :class:`~lagrangian.control.StateFeedback`, whose ``inputs`` simulate the nonlinear
        model with the law."""
        from ..control import lqr

        return lqr(self, Q, R, sample_time=sample_time)

    def place(self, poles, *, sample_time: float | None = None):
        """The state feedback u = u0 - K (x - x0) that puts the eigenvalues of A - B K at `poles`
        (see :func:`lagrangian.control.place`). Returns a
        :class:`~lagrangian.control.StateFeedback`."""
        from ..control import place

        return place(self, poles, sample_time=sample_time)

    def to_dict(self) -> dict:
        """The JSON contract: state_names, input_names, A, B, M, C, K (numeric lists), and G,
        input_matrix, operating_point, inputs, parameters, eigenvalues ([re, im]), stability; and
        "outputs" ({"names", "C", "D"}: the named outputs' rows of y = C x + D u) when the model
        has named outputs."""
        outputs = self.equations.model.outputs
        return {
            "state_names": list(self.state_names),
            "input_names": list(self.input_names),
            "operating_point": dict(self.operating_point),
            "inputs": dict(self.input_values),
            "parameters": dict(self.parameter_values),
            "t": self.t,
            "A": self.A.tolist(), "B": self.B.tolist(),
            "M": self.M.tolist(), "C": self.C.tolist(), "G": self.G.tolist(), "K": self.K.tolist(),
            "input_matrix": self.input_matrix.tolist(),
            "eigenvalues": [[float(z.real), float(z.imag)] for z in self.eigenvalues],
            "stability": self.stability,
            "stable": self.stable,
            **({"constrained": {"dependent": dict(self.constrained["dependent"]),
                                "multipliers": dict(self.constrained["multipliers"]),
                                "basis": self.constrained["basis"],
                                **{k: (list(v) if k == "ignorable" else dict(v))
                                   for k, v in self.constrained.items() if k in ("ignorable", "rates")}}}
               if self.constrained else {}),
            **({"outputs": {"names": list(outputs), "C": self._outputs[0].tolist(), "D": self._outputs[1].tolist()}}
               if outputs else {}),
        }

    def text(self) -> str:
        def mat(name, a):
            rows = [" ".join(f"{x:12.6g}" for x in r) for r in np.atleast_2d(a)] if a.size else ["(empty)"]
            return [f"  {name} ="] + [f"    {r}" for r in rows]

        at = ", ".join(f"{k} = {v:.6g}" for k, v in self.operating_point.items())
        q, x, u = vector_names(self.equations).values()
        lines = [f"Linearization of {self.equations.model.name} at {at}"
                 + (f", inputs {', '.join(f'{k} = {v:g}' for k, v in self.input_values.items())}"
                    if self.input_values else ""),
                 f"  M d{q}'' + (C + G) d{q}' + K d{q} = B0 d{u};  {x}' = A {x} + B {u}, {x} = ["
                 + ", ".join(self.state_names) + "]"
                 + (f", {u} = [{', '.join(self.input_names)}]" if self.input_names else "")]
        if self.constrained:
            dependent = ", ".join(f"{k} = {v:.6g}" for k, v in self.constrained["dependent"].items())
            lines.insert(1, "  in the independent coordinates (constraints eliminated at the point"
                         + (f": {dependent}" if dependent else "") + "); multipliers "
                         + ", ".join(f"{k} = {v:.6g}" for k, v in self.constrained["multipliers"].items()))
            moving = {k: v for k, v in self.constrained.get("rates", {}).items() if v != 0}
            if moving:
                lines.insert(2, "  about the steady motion with "
                             + ", ".join(f"{k} = {v:.6g}" for k, v in moving.items())
                             + (f"; ignorable (left out: nothing depends on them): "
                                f"{', '.join(self.constrained['ignorable'])}"
                                if self.constrained.get("ignorable") else ""))
        labels = {"M": "M", "C": "C (damping)", "K": "K",
                  "G": "G (gyroscopic, Coriolis" + (", and the constraint forces' velocity terms)"
                                                    if self.constrained else ")")}
        for name in ("M", "C", "G", "K"):
            lines += mat(labels[name], getattr(self, name))
        lines += mat("B0", self.input_matrix) + mat("A", self.A) + mat("B", self.B)
        lines.append("  eigenvalues: " + ", ".join(_complex_text(z) for z in self.eigenvalues))
        lines.append(f"  {self.stability}" + (" (Lagrange-Dirichlet: K positive definite)"
                                               if self.stability == "stable" else ""))
        return "\n".join(lines)

    def _repr_latex_(self) -> str:
        def mat(a):
            return sympy.latex(sympy.Matrix(np.atleast_2d(a)).applyfunc(lambda x: sympy.Float(x, 6))) if a.size else "0"

        at = ", ".join(f"{_latex_name(k)} = {v:.6g}" for k, v in self.operating_point.items())
        q, x, u = (_latex_name(v) for v in vector_names(self.equations).values())
        return ("$$\\begin{aligned}&\\text{at } " + at + "\\\\ "
                f"&M\\,\\delta\\ddot {q} + (C + G)\\,\\delta\\dot {q} + K\\,\\delta {q} = B_0\\,\\delta {u},\\quad "
                f"M = {mat(self.M)},\\ C = {mat(self.C)},\\ G = {mat(self.G)},\\ K = {mat(self.K)}\\\\ "
                f"&\\dot {x} = A {x} + B {u},\\quad A = {mat(self.A)},\\ B = {mat(self.B)}"
                "\\end{aligned}$$")

    def __repr__(self) -> str:
        at = ", ".join(f"{k}={v:.4g}" for k, v in self.operating_point.items())
        return f"<LinearModel of {self.equations.model.name!r} at {at}: {self.stability}>"


#: The printed names of the vectors (the coordinates, the state, the inputs), each with the
#: letters used in its place when the model names a symbol so (a coordinate named x).
def _complex_text(z: complex) -> str:
    if abs(z.imag) <= 1e-12 * max(1.0, abs(z)):
        return f"{z.real:.6g}"
    return f"{z.real:.6g}{z.imag:+.6g}j"


def _point(equations: Equations, at, problems: list[Problem]) -> tuple[dict[str, float], dict]:
    """State values by name (others 0) and their exact forms."""
    names = equations.state_names
    values = {s: 0.0 for s in names}
    exact: dict = {}
    if at is None:
        return values, exact
    if not isinstance(at, Mapping):
        arr = number_array(at)
        arr = np.full(1, np.nan) if arr is None else arr.ravel()
        if arr.shape == (equations.n,):
            arr = np.concatenate((arr, np.zeros(equations.n)))
        if arr.shape != (2 * equations.n,) or not np.all(np.isfinite(arr)):
            problems.append(Problem(f"the operating point must give {equations.n} coordinates or "
                                    f"{2 * equations.n} state values ({', '.join(names)}), got {shown_value(at)}",
                                    key="at"))
            return values, exact
        return dict(zip(names, map(float, arr))), exact
    values.update(named_values(at, names, "a coordinate or velocity", "at", problems))
    for name, value in at.items():
        name = str(getattr(name, "name", name))
        if isinstance(value, sympy.Basic) and name in values:
            exact[name] = value
    return values, exact


def linearize(equations: Equations, at: Mapping | None = None, *, inputs: Mapping | None = None,
              params: Mapping | None = None, t: float = 0.0) -> LinearModel:
    """Linearize the equations about an operating point.

    Parameters
    ----------
    equations : Equations
    at : mapping of str to float, or array_like, shape (n,) or (2n,)
        The operating point: coordinates and velocities by name (``{"q2": sympy.pi/2}``); those
        not given are 0. An equilibrium's ``coordinates`` work as they are. Default: the model's
        ``operating_point`` (its parameters' values, overrides included), else all 0. A model with
        velocity constraints is linearized about a steady motion (see docs/constraints.md).
    inputs : mapping of str to float
        Constant input values (default 0).
    params : mapping of str to float
        Parameter values that override the model's.
    t : float
        The time, for models whose equations depend on t.

    Returns
    -------
    LinearModel

    Raises
    ------
    ModelError
        An unknown name or a value that is not a number.
    SingularMassMatrixError
        M is singular at the operating point (with the diagnosis of :func:`singularities`).
    """
    problems: list[Problem] = []
    setting = collect_setting(equations, params, inputs, t, problems)
    if at is None and equations.model.operating_point and not problems:
        at = model_operating_point(equations, setting)
    point, exact = _point(equations, at, problems)
    if problems:
        raise ModelError(problems)
    if equations.is_constrained:
        from ._constrained_linear import linearize_constrained

        given = {str(getattr(k, "name", k)) for k in at} if isinstance(at, Mapping) else set(equations.state_names)
        return linearize_constrained(equations, point, given, setting)
    return linearize_at(equations, point, setting, exact)


def model_operating_point(equations: Equations, setting: Setting) -> dict[str, float]:
    """The model's [operating_point] at the setting's parameter values."""
    values = {sympy.Symbol(k): v for k, v in setting.parameters.items()}
    return {k: float(sympy.sympify(e).subs(values)) for k, e in equations.model.operating_point.items()}


def linearize_at(equations: Equations, point: Mapping[str, float], setting: Setting,
                 exact: Mapping | None = None, given: set | None = None) -> LinearModel:
    """linearize() for checked values (used by equilibria and continuation): one linearization for
    every model, in the coordinates z of the constraints' tangent space at the point (dq = T dz),
    with T = I and no constraint forces when there are no constraints (m = 0).

    For a model with holonomic constraints (m > 0) the point is first moved onto them, keeping the
    coordinates named in `given` (:func:`~lagrangian.analysis._constrained_linear.tangent_space`:
    the independent coordinates, T, the multipliers and the constraint forces' stiffness); then
    both cases assemble the same M, C, G, K, B0, A and B (:func:`assembled`)."""
    n = equations.n
    names = equations.state_names
    x = np.array([point[s] for s in names], dtype=float)
    space = None
    if equations.is_constrained:
        from ._constrained_linear import tangent_space

        space = tangent_space(equations, x, set(names) if given is None else given, setting)
        x = space.x
    nm = compile_equations(equations, "scipy")  # the one numeric model: its Jacobians, in (t, x, u, p)
    u, p = setting.u, setting.p
    base = nm.jacobians(setting.t, x, u, p, np.zeros(n))
    M, f = base["M"], base["f"]
    if space is not None:  # at rest on the constraints (checked): the accelerations are 0
        space.require_rest(M, f)
        qdd, parts = np.zeros(n), base
    else:
        diag = np.abs(np.diag(M)) if M.size else np.ones(0)
        if (not np.all(np.isfinite(M)) or inertia_measure(M) <= _SINGULAR
                or (diag.size and diag.min() <= _ROUND_OFF * diag.max())):
            # the second test: a diagonal entry at round-off against the others (sin(pi)**2 = 1.5e-32
            # at the pole of spherical coordinates), which the scaled measure cannot see
            raise _singular_error(equations, point, setting.parameters, M)
        qdd = np.linalg.solve(M, f)
        parts = nm.jacobians(setting.t, x, u, p, qdd) if np.any(qdd) else base
    K = parts["Maq"] - parts["fq"]
    if space is not None:  # the constraint forces' stiffness, sum_k lambda_k H_k
        K = K - space.stiffness
    M, C, G, K, B0, A, B = assembled(M, K, -parts["fqd"], parts["fu"], nm.damping(setting.t, x, u, p),
                                     None if space is None else space.basis)
    if not (np.all(np.isfinite(A)) and np.all(np.isfinite(B))):
        bad = ", ".join(f"{k} = {v:g}" for k, v in point.items())
        raise ModelError(f"the linearization at {bad} is not finite (a derivative of the equations is "
                         "infinite or undefined there); choose another operating point")
    A, B = _clean(A), _clean(B)
    if space is None:
        coords, state, operating = names[:n], names, dict(zip(names, map(float, x)))
        family, constrained, accelerations = cyclic_coordinates(equations), {}, qdd
    else:
        coords = tuple(names[i] for i in space.independent)
        state = coords + tuple(f"{c}_dot" for c in coords)
        operating = {s: 0.0 for s in state}
        operating.update({names[i]: float(x[i]) for i in space.independent})
        family, constrained, accelerations = (), space.summary(equations), np.zeros(len(coords))
    return LinearModel(
        equations=equations, coordinate_names=coords, state_names=state,
        input_names=tuple(setting.inputs), operating_point=MappingProxyType(operating),
        input_values=setting.inputs, parameter_values=setting.parameters, t=setting.t,
        M=read_only(M), C=read_only(C), G=read_only(G), K=read_only(K), input_matrix=read_only(B0),
        A=read_only(A), B=read_only(B), accelerations=read_only(accelerations), family=family,
        _exact_point=MappingProxyType(dict(exact or {})), constrained=MappingProxyType(constrained))


def assembled(M: np.ndarray, K: np.ndarray, D: np.ndarray, B0: np.ndarray, damping: np.ndarray,
              basis: np.ndarray | None = None):
    """(M, C, G, K, B0, A, B) of M dq'' + D dq' + K dq = B0 du (shapes (n, n) and (n, m)), in the
    coordinates z of dq = basis dz (shape (n, r): the constraints' tangent space; None: the identity,
    no constraints): M, D and K become basis^T M basis and so on, and K is made exactly symmetric
    where it is to round-off. C is the damping's part of D (`damping`, see split_velocity_terms),
    G the rest; A = [[0, I], [-M^-1 K, -M^-1 D]] and B = [[0], [M^-1 B0]], not cleaned of round-off."""
    if basis is not None:
        T = basis
        M, K, D, B0 = _clean(T.T @ M @ T), T.T @ K @ T, T.T @ D @ T, T.T @ B0
    D, K, B0 = _clean(D), _clean(K), _clean(B0)
    if basis is not None and np.allclose(K, K.T, rtol=1e-10, atol=1e-12 * np.abs(K).max(initial=1)):
        K = (K + K.T) / 2
    C, G = split_velocity_terms(D, damping, basis)
    r = M.shape[0]
    A = np.zeros((2 * r, 2 * r))
    A[:r, r:] = np.eye(r)
    A[r:, :r] = -np.linalg.solve(M, K)
    A[r:, r:] = -np.linalg.solve(M, D)
    B = np.zeros((2 * r, B0.shape[1]))
    if B0.size:
        B[r:] = np.linalg.solve(M, B0)
    return M, C, G, K, B0, A, B


def split_velocity_terms(D: np.ndarray, damping: np.ndarray, basis: np.ndarray | None = None):
    """(C, G) with C + G = D (the coefficient of dq' in the linearized equations): C the damping,
    that of the forces that take power from the motion (d2D/dq_dot2 - dQ/dq_dot, symmetric), in
    the coordinates of `basis` (dq_dot = basis dz_dot) when given; G the rest: gyroscopic and
    Coriolis terms (skew-symmetric at rest), and, with constraints, the velocity terms the
    constraint forces bring into the minimal coordinates (a rolling coin's, which do no work and
    are not skew-symmetric). A conservative system has C = 0."""
    C = damping if basis is None else basis.T @ damping @ basis
    C = _clean((C + C.T) / 2)
    return C, _clean(D - C)


def _clean(a: np.ndarray) -> np.ndarray:
    """Round-off (cos(pi/2) = 6e-17) set to exact zeros, relative to the matrix's largest entry;
    -0.0 printed as 0."""
    if a.size:
        a = np.where(np.abs(a) <= 1e-14 * np.abs(a).max(), 0.0, a)
    return a + 0.0


def cyclic_coordinates(equations: Equations) -> tuple[str, ...]:
    """Coordinates absent from M and f: the equations are the same wherever they are (a coordinate
    that appears only through sin(phi)**2 + cos(phi)**2, as elements give it, counts as absent)."""
    out = _CYCLIC.get(equations)
    if out is None:
        core = equations.core
        entries = (*core.M, *core.f)
        out = _CYCLIC[equations] = tuple(
            q.name for q, qs in zip(equations.coordinates, core.q)
            if not any(qs in e.free_symbols and _depends_on(e, qs) for e in entries))
    return out


_CYCLIC: "weakref.WeakKeyDictionary[Equations, tuple]" = weakref.WeakKeyDictionary()


def _singular_error(equations: Equations, point: Mapping[str, float],
                    parameters: Mapping[str, float], M=None) -> SingularMassMatrixError:
    """The error of a linearization at a singular M (`M`: its numbers at the point): the diagnosis with the values
    it was linearized at; for a large model (numeric._codegen.large_model) from M's numbers at the point, as
    simulate's (equations._singular.diagnosis_at: the symbolic one would take minutes to hours)."""
    from ..numeric._codegen import large_model

    where = ", ".join(f"{k} = {v:.6g}" for k, v in point.items() if not k.endswith("_dot"))
    if M is not None and large_model(equations):
        diagnosis = diagnosis_at(equations, M, point)
    else:
        diagnosis = singularities(equations, parameters=parameters).text()
    return SingularMassMatrixError(
        f"the mass matrix is singular at the operating point ({where}), so the equations cannot be "
        f"solved for q_ddot there and have no linearization in state-space form.\n{diagnosis}",
        state=dict(point), diagnosis=diagnosis)


def _symbolic(lin: LinearModel) -> SymbolicLinearization:
    eqs = lin.equations
    # refused with constraints: the dependent coordinates at the point solve g(q) = 0, with no closed
    # form in general, and T = [I; -G_d^-1 G_i] is a symbolic inverse (ARCHITECTURE: never)
    eqs.require_unconstrained("the exact (symbolic) linearization", "its numeric linearization (A, B, M, C, K) is "
                              "in the independent coordinates; an exact one needs the dependent coordinates at the "
                              "point as exact roots of g(q) = 0, functions of the symbolic parameters, and the "
                              "tangent basis T = [I; -G_d^-1 G_i], a symbolic inverse of the constraints' Jacobian: "
                              "g(q) = 0 has no closed-form solution in general (a four-bar's loop closes where two "
                              "circles meet), so the constraints are eliminated numerically at the point. Use the "
                              "numeric matrices, or write the model in independent coordinates without constraints "
                              "for the exact form")
    core, n = eqs.core, eqs.n
    point = {se.Symbol(s): se.sympify(exact_number(v, lin._exact_point.get(s)))
             for s, v in lin.operating_point.items()}
    point[core.t] = se.sympify(exact_number(lin.t))
    point.update({se.Symbol(u): se.sympify(exact_number(v)) for u, v in lin.input_values.items()})
    q, qd = list(core.q), list(core.qd)
    us = [se.Symbol(u) for u in lin.input_names]

    def at(e):
        return sympy.simplify(to_sympy(se.expand(e.subs(point))) if not isinstance(e, sympy.Basic) else e)

    def matrix(rows, cols, entry):
        return sympy.Matrix(rows, cols, [entry(i, j) for i in range(rows) for j in range(cols)])

    M = matrix(n, n, lambda i, j: at(core.M[i, j]))
    f = sympy.Matrix([at(fi) for fi in core.f])
    qdd = sympy.simplify(M.LUsolve(f)) if any(v != 0 for v in f) else sympy.zeros(n, 1)
    a = {se.Symbol(f"_a{i}"): se.sympify(qdd[i]) for i in range(n)}
    Ma = [sum((core.M[i, j] * se.Symbol(f"_a{j}") for j in range(n)), se.Integer(0)) for i in range(n)]
    K = matrix(n, n, lambda i, j: at(Ma[i].diff(q[j]).subs(a) - core.f[i].diff(q[j])))
    D = matrix(n, n, lambda i, j: at(-core.f[i].diff(qd[j])))
    B0 = matrix(n, len(us), lambda i, j: at(core.f[i].diff(us[j])))
    Q = list(core.Q) or [se.Integer(0)] * n
    C = matrix(n, n, lambda i, j: at(core.D.diff(qd[i]).diff(qd[j]) - (Q[i].diff(qd[j]) + Q[j].diff(qd[i])) / 2))
    G = sympy.simplify(D - C)
    A = sympy.zeros(2 * n, 2 * n)
    A[:n, n:] = sympy.eye(n)
    A[n:, :n] = sympy.simplify(-M.LUsolve(K))
    A[n:, n:] = sympy.simplify(-M.LUsolve(D))
    B = sympy.zeros(2 * n, len(us))
    if us:
        B[n:, :] = sympy.simplify(M.LUsolve(B0))
    I = sympy.ImmutableMatrix
    return SymbolicLinearization(I(M), I(C), I(G), I(K), I(B0), I(A), I(B))



def _output_rows(lin: LinearModel) -> tuple[np.ndarray, np.ndarray]:
    """The rows C (r, 2n) and D (r, m) of the model's named outputs h(t, x, u, p) about the point of
    `lin`: dh/dx and dh/du, from their symbolic derivatives evaluated by the one numeric model. For
    a constrained model (linearized in its independent coordinates, dq = T dq_i), at rest with
    holonomic constraints only: (dh/dq T, dh/dq_dot T)."""
    eq = lin.equations
    outputs = eq.model.outputs
    k = len(eq.inputs)
    if not outputs:
        return np.zeros((0, 2 * lin.n)), np.zeros((0, k))
    from ..model._constraints import VELOCITY
    from ..numeric._compiled import compile_equations

    names = [*(s.name for s in eq.coordinates), *(s.name for s in eq.velocities)]
    point = dict(lin.operating_point)
    if lin.constrained:
        rates = dict(lin.constrained.get("rates", {}))
        if any(c.kind == VELOCITY for c in eq.model.constraints) or any(v != 0 for v in rates.values()):
            raise ModelError("the named outputs of a constrained model are linearized only at rest with holonomic "
                             "constraints (dq = T dq_i); this linearization has velocity constraints or a steady "
                             "motion: read the outputs' derivatives from a simulation, or linearize at rest")
        point.update(lin.constrained["dependent"])
        point.update(rates)
    x = np.array([point.get(s, 0.0) for s in names], dtype=float)
    u = np.array([lin.input_values.get(s.name, 0.0) for s in eq.inputs], dtype=float)
    p = np.array([lin.parameter_values.get(s.name, np.nan) for s in eq.parameters], dtype=float)
    variables = [*eq.coordinates, *eq.velocities, *eq.inputs]

    def build():
        return [sympy.diff(e, v) for e in outputs.values() for v in variables]

    n_full = len(eq.coordinates)
    rows = compile_equations(eq, "scipy").function("outputs.jacobian", build)(lin.t, x, u, p)
    rows = np.asarray(rows, float).reshape(len(outputs), 2 * n_full + k)
    C, D = rows[:, :2 * n_full], rows[:, 2 * n_full:]
    if lin.constrained:
        T = np.asarray(lin.constrained["basis"], float)
        C = np.hstack((C[:, :n_full] @ T, C[:, n_full:] @ T))
    return read_only(C + 0.0), read_only(D + 0.0)
