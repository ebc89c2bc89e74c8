"""Equations: Lagrange's equations of a model, in every form users ask for.

All forms share one convention, written once here:

    M(q, t) q_ddot + C(q, q_dot) q_dot + G(q) = Q + gyroscopic_forces + centrifugal_forces
                                                 + damping_forces + rheonomic_forces

where M = d2T*/dq_dot2 is the mass matrix, C the Coriolis/centrifugal matrix from the
Christoffel symbols of M (dM/dt - 2C is skew-symmetric), G = dV/dq, Q the generalized forces
(B = dQ/du the input matrix), and, splitting T* = T2 + T1 + T0 by degree in the velocities
(T1 = a(q, t) . q_dot):

* gyroscopic_forces  = -Gamma q_dot with Gamma_ij = da_i/dq_j - da_j/dq_i (skew-symmetric),
* centrifugal_forces = dT0/dq (Preumont's potential of centrifugal forces),
* damping_forces     = -dD/dq_dot,
* rheonomic_forces   = -(dM/dt) q_dot - da/dt (zero unless T depends on t explicitly).

The residuals E_i = d/dt(dL/dq_dot_i) - dL/dq_i + dD/dq_dot_i - Q_i are the left side minus
the right side, never rescaled; forcing f is such that M q_ddot = f.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
import symengine as se
import sympy

from ..errors import LagrangianError, ModelError
from ..model import Model
from ..model._kinematics import to_sympy
from ._readable import negated, plus, readable, readable_many, text as _text, times

__all__ = ["Equations", "LinearSystem", "SymbolicCore"]


@dataclass(frozen=True)
class SymbolicCore:
    """The SymEngine objects derive() computes (internal; Equations exposes SymPy versions)."""

    q: tuple
    qd: tuple
    t: se.Symbol
    T: se.Basic
    V: se.Basic
    D: se.Basic
    Q: tuple
    L: se.Basic
    p: tuple
    M: se.DenseMatrix
    f: tuple
    #: Constraints: their residuals g (holonomic: g(q, t); velocity: w = a . q_dot + b), the
    #: Jacobian G (m x n, rows dg/dq or a), the velocity residuals w = G q_dot + b, and c with
    #: G q_ddot = c (all empty without constraints).
    g: tuple = ()
    G: se.DenseMatrix | None = None
    w: tuple = ()
    c: tuple = ()


@dataclass(frozen=True)
class LinearSystem:
    """M x'' + C x' + K x = f, for a system whose equations are linear in q, q_dot, q_ddot.

    M, C, K are constant (they may hold parameters); f may depend on t and the inputs.
    """

    M: sympy.ImmutableMatrix
    C: sympy.ImmutableMatrix
    K: sympy.ImmutableMatrix
    f: sympy.ImmutableMatrix

    def latex(self) -> str:
        return (f"{sympy.latex(self.M)} \\ddot{{x}} + {sympy.latex(self.C)} \\dot{{x}} + "
                f"{sympy.latex(self.K)} x = {sympy.latex(self.f)}")

    def _repr_latex_(self) -> str:
        return "$$" + self.latex() + "$$"


def _vec(items) -> sympy.ImmutableMatrix:
    return sympy.ImmutableMatrix([to_sympy(e) for e in items])


@dataclass(frozen=True, eq=False)
class Equations:
    """Lagrange's equations of a model (immutable; returned by :func:`lagrangian.derive`).

    Attributes
    ----------
    model : Model
        A snapshot of the model they were derived from.
    coordinates, velocities, accelerations : tuple of sympy.Symbol, shape (n,)
    mass_matrix : sympy.ImmutableMatrix, shape (n, n)
        M, symmetric.
    forcing : sympy.ImmutableMatrix, shape (n, 1)
        f, with M q_ddot = f.
    equations : tuple of sympy.Expr, shape (n,)
        The residuals E_i (each equation reads E_i = 0).

    The parts of the matrix form (see the module docstring) are properties computed on first
    use: `coriolis_matrix` (C), `potential_gradient` (G), `generalized_forces` (Q),
    `input_matrix` (B), `gyroscopic_matrix`, `gyroscopic_forces`, `centrifugal_forces`,
    `damping_forces`, `rheonomic_forces`, and `linear` (a :class:`LinearSystem` or None).
    """

    model: Model = field(repr=False)
    core: SymbolicCore = field(repr=False)

    # ------------------------------------------------------------------ symbols
    @property
    def coordinates(self) -> tuple[sympy.Symbol, ...]:
        return self.model.q

    q = coordinates

    @property
    def velocities(self) -> tuple[sympy.Symbol, ...]:
        return self.model.q_dot

    @property
    def accelerations(self) -> tuple[sympy.Symbol, ...]:
        return self.model.q_ddot

    @property
    def t(self) -> sympy.Symbol:
        return self.model.t

    @property
    def n(self) -> int:
        """Number of degrees of freedom."""
        return len(self.core.q)

    @property
    def parameters(self) -> dict[sympy.Symbol, float | None]:
        return self.model.parameters

    @property
    def inputs(self) -> tuple[sympy.Symbol, ...]:
        return self.model.inputs

    @property
    def state_names(self) -> tuple[str, ...]:
        """Names of the state x = [q, q_dot]."""
        return tuple(c.name for c in self.coordinates) + tuple(v.name for v in self.velocities)

    # ----------------------------------------------------------- main results
    @cached_property
    def mass_matrix(self) -> sympy.ImmutableMatrix:
        n = self.n
        pairs = [(i, j) for i in range(n) for j in range(i, n)]
        upper = dict(zip(pairs, readable_many([self.core.M[i, j] for i, j in pairs], state=self._varying,
                                              bounds=self._bounds)))
        return sympy.ImmutableMatrix(n, n, [upper[min(i, j), max(i, j)] for i in range(n) for j in range(n)])

    M = property(lambda self: self.mass_matrix, doc="Alias of `mass_matrix`.")

    @cached_property
    def forcing(self) -> sympy.ImmutableMatrix:
        return sympy.ImmutableMatrix(readable_many(self.core.f, state=self._varying, collect_on=self.velocities,
                                                   bounds=self._bounds))

    @cached_property
    def _bounds(self) -> dict:
        """The memo of expanded_terms_bound at the readable forms' budget (MAX_TERMS), shared by M,
        f and too_large_to_expand, which count the same entries."""
        return {}

    def readable(self, expr, collect_on=()) -> sympy.Expr:
        """`expr` (SymPy or SymEngine) in the compact form the equations are shown in: expanded,
        sin(x)*sin(y) + cos(x)*cos(y) and the like written as cos(x - y), sin^2 + cos^2 as 1, the
        terms grouped on `collect_on`, then on their coordinate-, velocity- and time-dependent part,
        with the parameters' common factor taken out (``l1*l2*(m2 + m3)*cos(q1 - q2)``); equal to
        `expr`. An expression too large to expand quickly is returned as derived."""
        return readable(expr, state=self._varying, collect_on=collect_on)

    @cached_property
    def too_large_to_expand(self) -> bool:
        """True when an entry of M or f could expand to more terms than the readable form's budget
        (5,000: a chain of bodies in space, the bicycle); :meth:`text` then shows the
        :attr:`named_form` (unless asked for every entry in full)."""
        from ._readable import MAX_TERMS as budget, expanded_terms_bound

        n = self.n
        entries = [self.core.M[i, j] for i in range(n) for j in range(i, n)] + list(self.core.f)
        return any(expanded_terms_bound(e, budget, self._bounds) > budget for e in entries)

    @cached_property
    def named_form(self):
        """M and f (and the constraints' G, c and g) with named intermediate quantities: each body's
        angular velocity and mass-centre velocity, and the common subexpressions, listed once (a
        :class:`~lagrangian.equations._named.NamedForm`, SymEngine expressions; equal to the derived
        ones). Compact where the expanded form is not: a chain of three bodies in space prints in
        50 KB instead of 15 MB."""
        from ._named import named_form

        return named_form(self)

    def quasi_velocities(self):
        """Lagrange's equations in quasi-velocities (Boltzmann-Hamel / Poincare; Kane's method):
        each frame turned by three coordinates of its own (a spherical joint) has as speeds its
        angular velocity relative to its parent in its own axes, u_<frame>_x, _y, _z, with the
        kinematic equations q_dot = W(q) u; M_u u_dot = f_u with M_u = W^T M W (a
        :class:`~lagrangian.equations._named.QuasiVelocityForm`, named quantities). A ModelError
        for a model with constraints or without such a frame."""
        from ._named import quasi_velocity_form

        return quasi_velocity_form(self)

    def quasi_velocity_text(self) -> str:
        """:meth:`quasi_velocities` as text (``lagrangian derive MODEL --quasi-velocities``)."""
        form = self.quasi_velocities()
        return "\n".join([f"Lagrange's equations of {self.model.name} in quasi-velocities (Boltzmann-Hamel; "
                          "Kane's form): each frame turned by three coordinates of its own has as speeds its "
                          "angular velocity relative to its parent, in its own axes", ""] + form.lines())

    @cached_property
    def _varying(self) -> frozenset[str]:
        """Names of the symbols that vary: coordinates, velocities, accelerations, t, inputs."""
        return frozenset(s.name for s in (*self.coordinates, *self.velocities, *self.accelerations, self.t,
                                          *self.inputs))

    @cached_property
    def _residuals_se(self) -> tuple:
        qdd = [se.Symbol(a.name) for a in self.accelerations]
        lam = [se.Symbol(m.name) for m in self.multipliers]
        n, G = self.n, self.core.G
        return tuple(sum((self.core.M[i, j] * qdd[j] for j in range(n)), se.Integer(0)) - self.core.f[i]
                     - sum((G[k, i] * lam[k] for k in range(len(lam))), se.Integer(0)) for i in range(n))

    @cached_property
    def equations(self) -> tuple[sympy.Expr, ...]:
        """The residuals E_i, in readable form collected on the accelerations and velocities (with
        constraints: E_i - (G^T lambda)_i, so that each reads M q_ddot - f - G^T lambda = 0)."""
        if self._mass_matrix_free_of_velocities:
            # E_i = sum_j M_ij q_ddot_j - f_i, whose terms in q_ddot and in f cannot combine: the
            # readable form of E_i is made of those of M and f, already computed
            M, f, qdd = self.mass_matrix, self.forcing, self.accelerations
            R = self.constraint_forces
            # sympy.Add(*(M[i, j] * qdd[j] for j in range(n)), -f[i], -R[i]), built without SymPy's
            # flattening where it would only sort (the same objects; the text of a 20-link chain)
            return tuple(plus([times(M[i, j], sympy.S.One, [qdd[j]]) for j in range(self.n)]
                              + negated(f[i]) + negated(R[i])) for i in range(self.n))
        on = list(self.accelerations) + list(self.velocities) + list(self.multipliers)
        return tuple(self.readable(e, on) for e in self._residuals_se)

    @cached_property
    def inverse_dynamics(self) -> sympy.ImmutableMatrix:
        """tau = M q_ddot - f (n x 1), in readable form: the generalized forces that, added to the model's,
        drive the motion q(t) (tau = M q_ddot + C q_dot + G - Q - damping forces ...); at rest, those that
        hold the pose. With constraints, the actuators and the constraint forces share it:
        tau_a + G^T lambda = M q_ddot - f (see :func:`lagrangian.inverse_dynamics` for the numbers)."""
        M, f, qdd = self.mass_matrix, self.forcing, self.accelerations
        return sympy.ImmutableMatrix([sympy.Add(*(M[i, j] * qdd[j] for j in range(self.n)), -f[i])
                                      for i in range(self.n)])

    # ------------------------------------------------------------ constraints
    @property
    def is_constrained(self) -> bool:
        """True when the model has constraints (and so multipliers)."""
        return bool(self.model.constraints)

    @property
    def multipliers(self) -> tuple[sympy.Symbol, ...]:
        """The Lagrange multipliers ``lambda_<name>``, one per constraint."""
        return tuple(c.multiplier for c in self.model.constraints)

    @cached_property
    def constraints(self) -> dict[str, sympy.Expr]:
        """Each constraint's left side (= 0) by name, in readable form: g(q, t) for a holonomic
        constraint, a(q, t) . q_dot + b(q, t) for a velocity constraint."""
        return {c.name: self.readable(g, self.velocities) for c, g in zip(self.model.constraints, self.core.g)}

    @cached_property
    def constraint_jacobian(self) -> sympy.ImmutableMatrix:
        """G (m x n): its rows are dg/dq (holonomic) or the velocities' coefficients a (velocity
        constraints); the constraints at velocity level read G q_dot + b = 0."""
        m = len(self.core.g)
        if not m:
            return sympy.ImmutableMatrix(sympy.zeros(0, self.n))
        return sympy.ImmutableMatrix(m, self.n, readable_many(list(self.core.G), state=self._varying))

    @cached_property
    def constraint_acceleration(self) -> sympy.ImmutableMatrix:
        """c (m x 1), with G q_ddot = c: the constraints differentiated to acceleration level."""
        return sympy.ImmutableMatrix(readable_many(self.core.c, state=self._varying, collect_on=self.velocities)
                                     ) if self.core.c else sympy.ImmutableMatrix(sympy.zeros(0, 1))

    @cached_property
    def constraint_forces(self) -> sympy.ImmutableMatrix:
        """G^T lambda (n x 1): the generalized forces the constraints exert."""
        if not self.is_constrained:
            return sympy.ImmutableMatrix(sympy.zeros(self.n, 1))
        return self.constraint_jacobian.T * sympy.Matrix(self.multipliers)

    def require_unconstrained(self, what: str, instead: str = "") -> None:
        """Raise a ModelError saying that `what` does not handle constraints (yet), when the model has some."""
        if self.is_constrained:
            names = ", ".join(c.name for c in self.model.constraints)
            raise ModelError(f"{what} does not handle constraints yet, and model '{self.model.name}' has "
                             f"{len(self.model.constraints)} ({names}): "
                             + (instead or "simulate it (lagrangian simulate), or write it in independent "
                                           "coordinates without constraints"))

    @cached_property
    def _constraints_scleronomic(self) -> bool:
        """Constraints that do no work: free of t, and velocity constraints homogeneous in the velocities."""
        t = se.Symbol(self.t.name)
        zero = {v: 0 for v in self.core.qd}
        return all(t not in w.free_symbols and w.subs(zero) == 0 for w in self.core.w)

    @cached_property
    def _mass_matrix_free_of_velocities(self) -> bool:
        """True when T* is quadratic in the velocities (M depends on q and t only)."""
        velocities = set(self.core.qd)
        return not any(set(e.free_symbols) & velocities for e in self.core.M)

    @cached_property
    def T(self) -> sympy.Expr:
        """Kinetic co-energy T* (elements and explicit terms together)."""
        return to_sympy(self.core.T)

    @cached_property
    def V(self) -> sympy.Expr:
        return to_sympy(self.core.V)

    @cached_property
    def D(self) -> sympy.Expr:
        return to_sympy(self.core.D)

    @cached_property
    def L(self) -> sympy.Expr:
        """The Lagrangian T* - V."""
        return to_sympy(self.core.L)

    @cached_property
    def generalized_forces(self) -> sympy.ImmutableMatrix:
        """Q, from virtual work and the [forces] table (not including D)."""
        return _vec(self.core.Q)

    Q = property(lambda self: self.generalized_forces, doc="Alias of `generalized_forces`.")

    @cached_property
    def input_matrix(self) -> sympy.ImmutableMatrix:
        """B = dQ/du, shape (n, number of inputs), in readable form."""
        u = [se.Symbol(s.name) for s in self.inputs]
        entries = readable_many([Qi.diff(uj) for Qi in self.core.Q for uj in u], state=self._varying)
        return sympy.ImmutableMatrix(self.n, len(u), entries)

    B = property(lambda self: self.input_matrix, doc="Alias of `input_matrix`.")

    @cached_property
    def potential_gradient(self) -> sympy.ImmutableMatrix:
        """G = dV/dq."""
        return _vec(self.core.V.diff(qi) for qi in self.core.q)

    G = property(lambda self: self.potential_gradient, doc="Alias of `potential_gradient`.")

    # ------------------------------------------------------ kinetic structure
    @cached_property
    def _kinetic_split(self):
        """(T2, T1 coefficients a, T0) in SymEngine; raises if T is not quadratic in q_dot."""
        qd = self.core.qd
        if not self._mass_matrix_free_of_velocities:
            raise LagrangianError(
                "T* is not quadratic in the velocities (its second derivatives still depend on "
                "q_dot), so the matrix-form parts C, gyroscopic and centrifugal forces are not defined; "
                "the residuals, M and f are still valid")
        zero = {v: 0 for v in qd}
        T = self.core.T
        a = tuple(T.diff(v).subs(zero) for v in qd)
        T0 = T.subs(zero)
        return a, T0

    @cached_property
    def coriolis_matrix(self) -> sympy.ImmutableMatrix:
        """C(q, q_dot) from the Christoffel symbols of M: C_ij = sum_k Gamma_ijk q_dot_k,
        Gamma_ijk = (dM_ij/dq_k + dM_ik/dq_j - dM_jk/dq_i) / 2."""
        self._kinetic_split  # checks T is quadratic
        M, q, qd, n = self.core.M, self.core.q, self.core.qd, self.n
        dM = [[[M[i, j].diff(q[k]) for k in range(n)] for j in range(n)] for i in range(n)]
        C = []
        for i in range(n):
            for j in range(n):
                cij = se.Integer(0)
                for k in range(n):
                    cij = cij + (dM[i][j][k] + dM[i][k][j] - dM[j][k][i]) * qd[k] / 2
                C.append(to_sympy(cij))
        return sympy.ImmutableMatrix(n, n, C)

    C = property(lambda self: self.coriolis_matrix, doc="Alias of `coriolis_matrix`.")

    @cached_property
    def gyroscopic_matrix(self) -> sympy.ImmutableMatrix:
        """Gamma_ij = da_i/dq_j - da_j/dq_i, skew-symmetric, from T1 = a . q_dot."""
        a, _ = self._kinetic_split
        q, n = self.core.q, self.n
        return sympy.ImmutableMatrix(n, n, [to_sympy(a[i].diff(q[j]) - a[j].diff(q[i]))
                                            for i in range(n) for j in range(n)])

    @cached_property
    def gyroscopic_forces(self) -> sympy.ImmutableMatrix:
        """-Gamma q_dot (they do no work)."""
        return -self.gyroscopic_matrix * sympy.Matrix(self.velocities)

    @cached_property
    def centrifugal_forces(self) -> sympy.ImmutableMatrix:
        """dT0/dq: the forces of the centrifugal potential T0 (the part of T* free of q_dot)."""
        _, T0 = self._kinetic_split
        return _vec(T0.diff(qi) for qi in self.core.q)

    @cached_property
    def damping_forces(self) -> sympy.ImmutableMatrix:
        """-dD/dq_dot."""
        return _vec(-self.core.D.diff(v) for v in self.core.qd)

    @cached_property
    def rheonomic_forces(self) -> sympy.ImmutableMatrix:
        """-(dM/dt) q_dot - da/dt: zero unless T* depends explicitly on t."""
        a, _ = self._kinetic_split
        M, qd, t, n = self.core.M, self.core.qd, self.core.t, self.n
        return _vec(-sum((M[i, j].diff(t) * qd[j] for j in range(n)), se.Integer(0)) - a[i].diff(t)
                    for i in range(n))

    @property
    def is_scleronomic(self) -> bool:
        """True when T* and V do not depend explicitly on t."""
        return not (_depends_on(self.core.T, self.core.t) or _depends_on(self.core.V, self.core.t))

    @cached_property
    def explicit_time(self) -> bool:
        """True when L depends explicitly on t (checked after cancellation: a spinning frame whose
        rotation drops out of T*, as in the rotating pendulum, does not count)."""
        return _depends_on(self.core.L, self.core.t)

    # ----------------------------------------------------------------- linear
    @cached_property
    def linear(self) -> LinearSystem | None:
        """M x'' + C x' + K x = f when the equations are linear in q, q_dot, q_ddot with constant
        coefficients (free of t and the inputs; they may hold parameters); None otherwise (and for
        a constrained model, whose multipliers are further unknowns)."""
        if self.is_constrained:
            return None
        qdd = [se.Symbol(a.name) for a in self.accelerations]
        q, qd, n = self.core.q, self.core.qd, self.n
        states = set(q) | set(qd) | set(qdd)
        varying = states | {self.core.t} | {se.Symbol(u.name) for u in self.inputs}
        if any(set(x.free_symbols) & varying for x in self.core.M):
            return None  # dE/dq_ddot = M varies (the first test below, without expanding the residuals)
        blocks = []
        for var in (qdd, qd, q):
            rows = []
            for E in self._residuals_se:
                for v in var:
                    d = se.expand(E.diff(v))
                    if set(d.free_symbols) & varying:
                        return None
                    rows.append(to_sympy(d))
            blocks.append(sympy.ImmutableMatrix(n, n, rows))
        zero = {v: 0 for v in states}
        f = sympy.ImmutableMatrix([to_sympy(-se.expand(E.subs(zero))) for E in self._residuals_se])
        return LinearSystem(*blocks, f)

    @property
    def is_linear(self) -> bool:
        return self.linear is not None

    # ------------------------------------------------------- conserved quantity
    @cached_property
    def jacobi_integral(self) -> sympy.Expr:
        """h = sum q_dot dL/dq_dot - L. It equals the energy T* + V when T* = T2, and is conserved
        when L has no explicit t and D = 0, Q = 0."""
        return to_sympy(self._jacobi_se)

    @cached_property
    def _jacobi_se(self) -> se.Basic:
        h = sum((v * pi for v, pi in zip(self.core.qd, self.core.p)), se.Integer(0)) - self.core.L
        return h if self._jacobi_too_large else se.expand(h)

    @cached_property
    def _jacobi_too_large(self) -> bool:
        """Whether h = q_dot . dL/dq_dot - L could expand to more terms than derive() allows (a chain
        of bodies in space): then it is kept as derived (h - T* - V = 0 exactly when T* = T2)."""
        from .._limits import MAX_TERMS as limit
        from ._readable import expanded_terms_bound

        h = sum((v * pi for v, pi in zip(self.core.qd, self.core.p)), se.Integer(0)) - self.core.L
        return expanded_terms_bound(h, limit.value) > limit.value

    @property
    def is_conservative(self) -> bool:
        """True when the Jacobi integral is conserved: L free of t, D = 0 and Q = 0."""
        return (not self.explicit_time and self.core.D == 0 and all(Qi == 0 for Qi in self.core.Q)
                and self._constraints_scleronomic)

    @property
    def energy_name(self) -> str | None:
        """The name of h = T2 - T0 + V along a trajectory: "energy" when T* = T2 (no terms of degree
        1 or 0 in the velocities, so h = T* + V), "jacobi_integral" otherwise; None when L depends
        explicitly on t (h is then not computed)."""
        if self.explicit_time:
            return None
        return "energy" if self._natural else "jacobi_integral"

    @cached_property
    def _natural(self) -> bool:
        """T* = T2: no terms of degree 1 or 0 in the velocities."""
        zero = {v: 0 for v in self.core.qd}
        T = self.core.T
        return bool(T.subs(zero) == 0 and all(T.diff(v).subs(zero) == 0 for v in self.core.qd))

    @cached_property
    def cyclic_coordinates(self) -> tuple[sympy.Symbol, ...]:
        """Coordinates whose momentum p_i = dL/dq_dot_i is conserved: L does not contain q_i, and
        the i-th generalized force and damping force vanish (Q_i - dD/dq_dot_i = 0)."""
        core = self.core
        out = []
        memo: dict = {}  # L's free symbols, sample points and values, for every coordinate
        for i, (c, qi, qdi, Qi) in enumerate(zip(self.coordinates, core.q, core.qd, core.Q)):
            if _depends_on(core.L, qi, memo=memo):
                continue
            if se.expand(Qi - core.D.diff(qdi)) != 0:
                continue
            if core.G is not None and any(se.expand(core.G[k, i]) != 0 for k in range(core.G.rows)):
                continue  # a constraint force acts on it
            out.append(c)
        return tuple(out)

    @cached_property
    def conserved_quantities(self) -> dict[str, sympy.Expr]:
        """The first integrals that Lagrange's equations give: ``energy`` (T* + V, when T* = T2 and the
        system is conservative) or ``jacobi_integral`` (h = q_dot . dL/dq_dot - L, when L has no
        explicit t, D = 0 and Q = 0), and ``p_<q>`` = dL/dq_dot for each cyclic coordinate."""
        readable = {"h": lambda: self._readable_jacobi_integral(), "p": self.readable}
        return {k: readable[kind](e) if kind == "p" else readable[kind]()
                for k, (kind, e) in self._conserved_se().items()}

    def _conserved_se(self) -> dict[str, tuple[str, se.Basic]]:
        """{name: (kind, the SymEngine expression)} of :attr:`conserved_quantities` (kind "h": the
        energy or Jacobi integral, "p": a cyclic momentum), as derived."""
        out: dict[str, tuple[str, se.Basic]] = {}
        if self.is_conservative:
            h = self._jacobi_se
            is_energy = self._natural if self._jacobi_too_large else se.expand(h - self.core.T - self.core.V) == 0
            out["energy" if is_energy else "jacobi_integral"] = ("h", h)
        names = [c.name for c in self.coordinates]
        for c in self.cyclic_coordinates:
            out[f"p_{c.name}"] = ("p", self.core.p[names.index(c.name)])
        return out

    def _readable_jacobi_integral(self) -> sympy.Expr:
        """h in readable form, collected on the velocities. With L quadratic in the velocities
        (M free of them), h = q_dot^T M q_dot / 2 - L0 (L0: L at q_dot = 0), written with the
        readable M already computed."""
        if not self._mass_matrix_free_of_velocities:
            return self.readable(self._jacobi_se, self.velocities)
        M, v, n = self.mass_matrix, self.velocities, self.n
        L0 = self.core.L.subs({qd: 0 for qd in self.core.qd})
        # sympy.Add(*(Mul(1/2 or 1, M[i, j], v[i], v[j]) for i <= j), readable(-L0)), built without
        # SymPy's flattening where it would only sort (the same object)
        kinetic = [times(M[i, j], sympy.S.Half, [v[i] ** 2]) if i == j else times(M[i, j], sympy.S.One, [v[i], v[j]])
                   for i in range(n) for j in range(i, n)]
        return plus(kinetic + [self.readable(-L0, v)])

    # ------------------------------------------------------------- printing
    def equation(self, i: int) -> sympy.Eq:
        """The i-th equation as ``sympy.Eq(residual, 0)``."""
        return sympy.Eq(self.equations[i], 0)

    def text(self, *, expanded: bool = False) -> str:
        """The equations and the matrix form as plain text.

        When an entry of M or f is too large to expand (:attr:`too_large_to_expand`), M, f and the
        constraints are shown in the :attr:`named_form` unless `expanded` is True (then every entry
        is printed in full, as derived where it could not be made readable: megabytes for a chain
        of bodies in space)."""
        if not expanded and self.too_large_to_expand:
            return self._named_text()
        lines = [f"Lagrange's equations of {self.model.name} "
                 f"({self.n} coordinate{'s' if self.n != 1 else ''}: "
                 f"{', '.join(c.name for c in self.coordinates)})", ""]
        for i, (c, e) in enumerate(zip(self.coordinates, self.equations)):
            lines.append(f"  ({i + 1}) [{c.name}]  {_text(e)} = 0")
        if self.is_constrained:
            lines += ["", f"Constraints ({len(self.multipliers)}; multipliers "
                          f"{', '.join(m.name for m in self.multipliers)}):"]
            for c, (name, g) in zip(self.model.constraints, self.constraints.items()):
                lines.append(f"  {name} ({c.kind}): {_text(g)} = 0")
        q, _, u = vector_names(self).values()
        form = (f"M({q}) {q}_ddot = f({q}, {q}_dot, t, {u})"
                + (f" + G^T lambda, G {q}_ddot = c" if self.is_constrained else ""))
        lines += ["", f"Matrix form {form}:", "  M ="]
        for r in range(self.n):
            lines.append("    [" + ", ".join(_text(x) for x in self.mass_matrix.row(r)) + "]")
        lines.append("  f =")
        for x in self.forcing:
            lines.append(f"    {_text(x)}")
        if self.is_constrained:
            lines.append("  G =")
            for r in range(self.constraint_jacobian.rows):
                lines.append("    [" + ", ".join(_text(x) for x in self.constraint_jacobian.row(r)) + "]")
            lines.append("  c =")
            lines += [f"    {_text(x)}" for x in self.constraint_acceleration]
        if self.conserved_quantities:
            lines += ["", "Conserved quantities:"]
            lines += [f"  {k} = {_text(v)}" for k, v in self.conserved_quantities.items()]
        if self.linear is not None:
            lin = self.linear
            lines += ["", "Linear: M x'' + C x' + K x = f with",
                      f"  M = {sympy.sstr(lin.M.tolist())}", f"  C = {sympy.sstr(lin.C.tolist())}",
                      f"  K = {sympy.sstr(lin.K.tolist())}", f"  f = {sympy.sstr(list(lin.f))}"]
        return "\n".join(lines)

    __str__ = text

    def _named_text(self) -> str:
        """:meth:`text` in the named form (see `named_form`)."""
        from ._readable import MAX_TERMS as budget

        form = self.named_form
        q, _, u = vector_names(self).values()
        lines = [f"Lagrange's equations of {self.model.name} "
                 f"({self.n} coordinate{'s' if self.n != 1 else ''}: "
                 f"{', '.join(c.name for c in self.coordinates)})", "",
                 f"The entries of M and f could expand to more than {budget:,} terms each, so they are written with "
                 "named quantities,",
                 "in Kane's form (M = sum over bodies of J^T diag(m, I) J with J the Jacobians of their velocities, "
                 "f = Q - dV/dq - dD/dq_dot - sum J^T (m a, I alpha + w x I w) at q_ddot = 0), equal to Lagrange's;",
                 "'lagrangian derive MODEL --expanded' (Python: equations.text(expanded=True)) prints every entry "
                 "in full.",
                 f"The equations read M {q}_ddot = f" + (" + G^T lambda, with G and c of the constraints."
                                                         if self.is_constrained else "."),
                 "", f"Named quantities ({len(form.quantities)}, each in terms of those before it):"]
        lines += [f"  {name} = {expr}" + (f"    # {note}" if note else "") for name, expr, note in form.quantities]
        if self.is_constrained:
            lines += ["", f"Constraints ({len(self.multipliers)}; multipliers "
                          f"{', '.join(m.name for m in self.multipliers)}):"]
            lines += [f"  {c.name} ({c.kind}): {g} = 0" for c, g in zip(self.model.constraints, form.g)]
        form_text = (f"M({q}) {q}_ddot = f({q}, {q}_dot, t, {u})"
                     + (f" + G^T lambda, G {q}_ddot = c" if self.is_constrained else ""))
        lines += ["", f"Matrix form {form_text}:", "  M ="]
        lines += ["    [" + ", ".join(str(x) for x in row) + "]" for row in form.M]
        lines += ["  f ="] + [f"    {x}" for x in form.f]
        if self.is_constrained:
            lines += ["  G ="] + ["    [" + ", ".join(str(x) for x in row) + "]" for row in form.G]
            lines += ["  c ="] + [f"    {x}" for x in form.c]
        if self.is_conservative:
            name = "energy" if self._natural else "jacobi_integral"
            lines += ["", "Conserved quantities:",
                      f"  {name} = {q}_dot^T M {q}_dot / 2 + V" + ("" if self._natural else " - T0, T0 = T* at "
                                                                   f"{q}_dot = 0")
                      + " (with M above and V of the model)"]
        return "\n".join(lines)

    def latex(self, *, matrix_form: bool = True) -> str:
        """LaTeX of each equation (an ``align`` environment) and of the matrix form."""
        names = {s: _latex_name(s.name) for s in (*self.coordinates, *self.velocities, *self.accelerations)}
        body = " \\\\\n".join(f"  {sympy.latex(e, symbol_names=names)} &= 0" for e in self.equations)
        out = "\\begin{align}\n" + body + "\n\\end{align}"
        if matrix_form:
            qdd = sympy.Matrix(self.accelerations)
            out += ("\n\\begin{equation}\n  " + sympy.latex(self.mass_matrix, symbol_names=names)
                    + " " + sympy.latex(qdd, symbol_names=names) + " = "
                    + sympy.latex(self.forcing, symbol_names=names)
                    + (" + " + sympy.latex(self.constraint_jacobian.T, symbol_names=names) + " "
                       + sympy.latex(sympy.Matrix(self.multipliers)) if self.is_constrained else "")
                    + "\n\\end{equation}")
        if self.is_constrained:
            out += ("\n\\begin{align}\n" + " \\\\\n".join(
                f"  {sympy.latex(g, symbol_names=names)} &= 0" for g in self.constraints.values())
                + "\n\\end{align}")
        return out

    def _repr_latex_(self) -> str:
        return "$$" + self.latex(matrix_form=False).replace("align", "aligned") + "$$"

    def to_dict(self) -> dict:
        """The JSON contract: coordinates, velocities, accelerations, parameters, inputs,
        mass_matrix, forcing, equations (SymPy syntax), linear (M, C, K, f) or null, constraints
        (name, kind, expression, multiplier, jacobian row, acceleration c) and multipliers, and
        conserved_quantities ({name: expression}); T*, V, D and Q in readable form too.

        For a model too large to expand (:attr:`too_large_to_expand`: the bicycle), the entries of M, f,
        the equations, the constraints and the conserved quantities are printed as derived (SymEngine's
        printer, SymPy syntax; equal to the readable forms), not expanded entry by entry: megabytes
        that no one reads, in a tenth of the time; the named form is ``lagrangian derive``'s text."""
        s = _text
        if self.too_large_to_expand:
            return self._to_dict_as_derived()
        out = {
            "name": self.model.name,
            "coordinates": [c.name for c in self.coordinates],
            "velocities": [v.name for v in self.velocities],
            "accelerations": [a.name for a in self.accelerations],
            "parameters": {p.name: v for p, v in self.parameters.items()},
            "inputs": [u.name for u in self.inputs],
            "mass_matrix": [[s(x) for x in self.mass_matrix.row(r)] for r in range(self.n)],
            "forcing": [s(x) for x in self.forcing],
            "equations": [s(e) for e in self.equations],
            "kinetic_coenergy": s(self.readable(self.core.T, self.velocities)),
            "potential_energy": s(self.readable(self.core.V)),
            "dissipation": s(self.readable(self.core.D, self.velocities)),
            "generalized_forces": [s(self.readable(x)) for x in self.core.Q],
            "linear": None,
            "conserved_quantities": {k: s(v) for k, v in self.conserved_quantities.items()},
            "constraints": [{"name": c.name, "kind": c.kind, "expression": s(g), "multiplier": c.multiplier.name,
                             "jacobian": [s(x) for x in self.constraint_jacobian.row(k)],
                             "acceleration": s(self.constraint_acceleration[k])}
                            for k, (c, g) in enumerate(zip(self.model.constraints, self.constraints.values()))],
            "multipliers": [m.name for m in self.multipliers],
        }
        derived = getattr(self.model, "derived_parameters", {})
        if derived:  # parameters given as expressions of the others: not free, so not among "parameters"
            out["derived_parameters"] = {k: s(v) for k, v in derived.items()}
        if self.linear is not None:
            lin = self.linear
            out["linear"] = {k: [[s(x) for x in getattr(lin, k).row(r)] for r in range(self.n)]
                             for k in ("M", "C", "K")}
            out["linear"]["f"] = [s(x) for x in lin.f]
        return out

    def _to_dict_as_derived(self) -> dict:
        """:meth:`to_dict` of a model too large to expand (see there): the same keys, in the same order."""
        core, n, m = self.core, self.n, len(self.core.g)
        d = str  # SymEngine's printer
        out = {
            "name": self.model.name,
            "coordinates": [c.name for c in self.coordinates],
            "velocities": [v.name for v in self.velocities],
            "accelerations": [a.name for a in self.accelerations],
            "parameters": {p.name: v for p, v in self.parameters.items()},
            "inputs": [u.name for u in self.inputs],
            "mass_matrix": [[d(core.M[r, j]) for j in range(n)] for r in range(n)],
            "forcing": [d(x) for x in core.f],
            "equations": [d(e) for e in self._residuals_se],
            "kinetic_coenergy": _text(self.readable(core.T, self.velocities)),
            "potential_energy": _text(self.readable(core.V)),
            "dissipation": _text(self.readable(core.D, self.velocities)),
            "generalized_forces": [_text(self.readable(x)) for x in core.Q],
            "linear": None,
            "conserved_quantities": {k: d(e) for k, (_, e) in self._conserved_se().items()},
            "constraints": [{"name": c.name, "kind": c.kind, "expression": d(core.g[k]),
                             "multiplier": c.multiplier.name, "jacobian": [d(core.G[k, j]) for j in range(n)],
                             "acceleration": d(core.c[k])}
                            for k, c in enumerate(self.model.constraints)] if m else [],
            "multipliers": [mu.name for mu in self.multipliers],
        }
        derived = getattr(self.model, "derived_parameters", {})
        if derived:
            out["derived_parameters"] = {k: _text(v) for k, v in derived.items()}
        if self.linear is not None:
            lin = self.linear
            out["linear"] = {k: [[_text(x) for x in getattr(lin, k).row(r)] for r in range(n)] for k in ("M", "C", "K")}
            out["linear"]["f"] = [_text(x) for x in lin.f]
        return out

    def to_json(self, **kwargs) -> str:
        return json.dumps(self.to_dict(), **({"indent": 2} | kwargs))

    def __repr__(self) -> str:
        return f"<Equations of {self.model.name!r}: {self.n} coordinates ({', '.join(self.state_names[:self.n])})>"


def _depends_on(expr: se.Basic, var: se.Symbol, samples: int = 6, memo: dict | None = None) -> bool:
    """Whether `expr` really depends on `var`: d expr/d var is evaluated at random points, so
    dependence that cancels (sin^2 + cos^2 of a rotation angle) is not counted.

    `memo` (one dict for one `expr`, several `var`): its free symbols, and the points and the values
    of `expr` there, found once (the points are drawn from the symbols of `expr`, among which are
    those of its derivative: the same for every `var`; L of a 20-link chain, 20 coordinates)."""
    if memo is None:
        memo = {}
    free = memo.get("free")
    if free is None:
        free = memo["free"] = expr.free_symbols
    if var not in free:
        return False
    d = expr.diff(var)
    if d == 0:
        return False
    symbols = memo.get("symbols")
    if symbols is None:
        symbols = memo["symbols"] = sorted(free, key=str)
    if not set(d.free_symbols) <= free:  # not from SymEngine's diff: the points of these symbols, not cached
        symbols, memo = sorted(d.free_symbols | free, key=str), {}
    points = memo.get("points")
    if points is None or len(points) < samples:  # the draws of the generator seeded 12345, in turn
        rng = np.random.default_rng(12345)
        points = memo["points"] = [{s: se.Float(float(v)) for s, v in zip(symbols, rng.uniform(0.3, 1.7, len(symbols)))}
                                   for _ in range(samples)]
        memo["scales"] = []
    scales = memo["scales"]
    for k in range(samples):
        point = points[k]
        try:
            value = complex(d.subs(point).n())
            if k == len(scales):
                scales.append(abs(complex(expr.subs(point).n())) + 1.0)
            scale = scales[k]
        except (RuntimeError, TypeError, ValueError):
            return True
        if not np.isfinite(value) or abs(value) > 1e-10 * scale:
            return True
    return False


def _latex_name(name: str) -> str:
    for suffix, accent in (("_ddot", "\\ddot"), ("_dot", "\\dot")):
        if name.endswith(suffix):
            return f"{accent}{{{_latex_name(name[: -len(suffix)])}}}"
    base = sympy.latex(sympy.Symbol(name))
    return base


_VECTOR_NAMES = {"q": ("q", "r", "s"), "x": ("x", "z", "X", "xi"), "u": ("u", "w", "U", "v")}


def vector_names(equations: Equations) -> dict[str, str]:
    """{"q": ..., "x": ..., "u": ...}: the letters that stand for the vector of coordinates, the state
    and the inputs in printed linearizations, each the first of its candidates that no coordinate,
    velocity, input or parameter of the model (nor t, nor another vector) is named: a model whose
    coordinates are x and y has the state z = [x, x_dot, y, y_dot], not x = [x, ...]."""
    return vector_letters({*(c.name for c in equations.coordinates), *(v.name for v in equations.velocities),
                           *(u.name for u in equations.inputs), *(p.name for p in equations.parameters)})


def vector_letters(taken) -> dict[str, str]:
    """:func:`vector_names` for a model whose names are `taken`."""
    taken = {"t", *taken}
    out = {}
    for vector, candidates in _VECTOR_NAMES.items():
        name = next((c for c in candidates if c not in taken), None)
        k = 1
        while name is None:  # every candidate taken: number the first (x1, x2, ...)
            name = f"{candidates[0]}{k}" if f"{candidates[0]}{k}" not in taken else None
            k += 1
        taken.add(name)
        out[vector] = name
    return out
