"""report(equations) -> Report: the derivation, step by step, as the seed's slides teach it.

The steps (Bona's recipe): the bodies and the frames (each frame's rotation as elementary
rotations, its origin and its angular velocity, derived); the generalized coordinates; the
position and velocity of every element; the kinetic co-energy T* and the potential energy V; the
dissipation D; the generalized forces Q from virtual work; the constraints, when the model has
some (g = 0 or the velocity form, the Jacobian G, the multipliers lambda and the constraint forces
G^T lambda, the acceleration form G q_ddot = c); the Lagrangian L = T* - V; each Lagrange
equation (with its constraint force); the matrix form (M q_ddot = f + G^T lambda, G q_ddot = c
with constraints); the state equations; then the diagnosis of the mass matrix and, when the
analysis layer provides them, the equilibria and their stability. Sections are numbered in order.
"""

from __future__ import annotations

import os
from functools import cached_property

import symengine as se
import sympy

from ..equations import Equations, constraint_singularities, derive
from ..equations._readable import _add_sympy, _mul, expanded_terms_bound, readable_many
from ..equations._singular import determinant, diagnosis, factored
from ..errors import LagrangianError
from ..model import Model
from ..model._elements import (Damper, Force, Gravity, Particle, Point, RigidBody, RigidBody3D, Spring, Torque,
                               Torque3D)
from ..model._frames import angular_velocity
from ..model._kinematics import Kinematics
from ._document import Math, Paragraph, Report, Section, Table
from ._printing import MAX_NODES, ConstraintForce, Given, Partial, Rotation, TimeDerivative

__all__ = ["report"]

S = sympy.Symbol
_ZERO = sympy.Integer(0)
#: q_dot after a matrix in a product (not commutative, so that the product keeps its order).
_ORDERED_QDOT = sympy.Symbol("q_dot", commutative=False)
#: For a model too large to expand (Equations.too_large_to_expand: the bicycle), the readable form's
#: budget in the report: an expression whose expansion could have more terms than this, or that has a
#: root (the wheels' contact geometry, 1/sqrt(...)), is shown as derived. The bicycle's M, G, g and c
#: came out larger expanded than derived (G's entries 2 KB derived, 9 KB expanded), over the printing
#: limit either way, and took 4 s to expand and rewrite; under this budget, without roots, the readable
#: form is cheap and usually the shorter (dL/dthetaR: 0.2 KB against 5 KB).
LARGE_MODEL_TERMS = 300
#: The printing limit of the report of a model too large to expand (MAX_NODES for the others): its
#: expressions of 1000 to 2500 nodes, 20 to 70 KB of MathML each, took 0.7 s of the bicycle's 1.2 s of
#: printing (the derivation's text, `lagrangian derive --json`, has them in full).
LARGE_MODEL_NODES = 1000


def report(source, *, title: str | None = None, equilibria: bool = True) -> Report:
    """The derivation report of a model, step by step.

    Parameters
    ----------
    source : Equations, Model, str or os.PathLike
        Derived equations, a model (derived here), or a built-in example name or model-file
        path (loaded and derived here).
    title : str, optional
        The report's title (default: ``"Lagrange's equations of NAME"``, NAME the model's name).
    equilibria : bool, optional
        Include the equilibria and their stability when :mod:`lagrangian.analysis` provides
        them (default True).

    Returns
    -------
    Report
        An immutable document: ``.to_html()`` (MathML, no network needed), ``.to_markdown()``,
        ``.to_latex()``, ``.save(path)``.

    Examples
    --------
    >>> import lagrangian as lg
    >>> rep = lg.report("cart-pendulum")
    >>> rep.math("equation[q2]").lhs
    L**2*M2*q2_ddot - L*M2*q1_ddot*sin(q2) + L*M2*g*cos(q2)
    """
    if isinstance(source, Equations):
        eqs = source
    elif isinstance(source, Model):
        eqs = derive(source)
    elif isinstance(source, (str, os.PathLike)):
        from ..io import load

        eqs = derive(load(source))
    else:
        raise TypeError(f"report() expects Equations, a Model, or a model name or path, "
                        f"got {type(source).__name__}")
    b = _Builder(eqs)
    sections = [b.bodies(), b.coordinates(), b.kinematics(), b.energies(), b.dissipation(), b.forces()]
    if eqs.is_constrained:
        sections.append(b.constraints())
    sections += [b.lagrangian(), b.equations(), b.matrix_form(), b.state_form(), b.singularities()]
    if equilibria:
        sections.append(b.equilibria())
    sections = [Section(s.key, f"{i}. {s.title}", s.blocks) for i, s in enumerate(sections, 1)]
    model = eqs.model
    return Report(title or f"Lagrange's equations of {model.name}", model.name,
                  model.description, tuple(sections), LARGE_MODEL_NODES if b.large else MAX_NODES)


_FUNCTIONS = {name: getattr(sympy, name) for name in ("sin", "cos", "tan", "exp", "log", "asin", "acos", "atan",
                                                      "sinh", "cosh", "tanh")}


def _converted(e, memo: dict) -> sympy.Expr:
    """SymEngine's ``e._sympy_()`` (the same SymPy expression, built by the same constructors in the same
    order), each shared subexpression converted once (`memo`): the derived forms of a large model share
    most of theirs (the bicycle's C, f and momenta: 40 % of the time)."""
    hit = memo.get(e)
    if hit is not None:
        return hit
    kind = type(e)
    if kind is se.Add:  # (_add_sympy: sympy.Add, without its flattening where that would only sort the terms)
        out = _add_sympy([_converted(a, memo) for a in e.args])
    elif kind is se.Mul:  # (_mul: sympy.Mul, the same, for factors of distinct bases as SymEngine's are)
        args = [_converted(a, memo) for a in e.args]
        if args[0].is_Number:
            coef, factors = args[0], args[1:]
        else:
            coef, factors = sympy.S.One, args
        if len({f.as_base_exp()[0] for f in factors}) == len(factors):
            out = _mul(coef, factors)
        else:
            out = sympy.Mul(*args)
    elif kind is se.Pow:
        out = sympy.Pow(_converted(e.args[0], memo), _converted(e.args[1], memo))
    elif kind.__name__ in _FUNCTIONS and len(e.args) == 1:
        out = _FUNCTIONS[kind.__name__](_converted(e.args[0], memo))
    else:
        out = e._sympy_()
    memo[e] = out
    return out


def _col(items) -> sympy.ImmutableMatrix:
    return sympy.ImmutableMatrix([[x] for x in items])


def _velocity_symbol(q: sympy.Symbol) -> sympy.Symbol:
    return S(f"{q.name}_dot")


class _Builder:
    def __init__(self, eqs: Equations):
        self.eqs = eqs
        self.model = eqs.model
        massive = [e for e in self.model.elements if isinstance(e, (Particle, RigidBody, RigidBody3D))]
        self.kin = Kinematics(self.model.q, massive)
        self.massive = massive
        # a model too large to expand: its expressions as derived, unless they are small
        self.large = eqs.too_large_to_expand
        if self.large:
            self.readable = self._shown
            self._memo: dict = {}  # SymEngine -> SymPy of the subexpressions the derived forms share
            self._bounds: dict = {}  # expanded_terms_bound's memo for LARGE_MODEL_TERMS (the forms share terms)
        else:
            self.readable = eqs.readable

    def _shown(self, expr, collect_on=()) -> sympy.Expr:
        """For a model too large to expand: `expr` in readable form where that is cheap (its expansion
        has at most LARGE_MODEL_TERMS terms, and no root), else as derived (converted to SymPy)."""
        try:
            e = se.sympify(expr)
        except (TypeError, ValueError, RuntimeError):
            return self.eqs.readable(expr, collect_on)
        cheap = (expanded_terms_bound(e, LARGE_MODEL_TERMS, self._bounds) <= LARGE_MODEL_TERMS
                 and all(p.args[1].is_integer for p in e.atoms(se.Pow)))
        if cheap:  # (its budget LARGE_MODEL_TERMS: met, as just counted; the same form as under MAX_TERMS)
            return readable_many((e,), state=self.eqs._varying, collect_on=collect_on, max_terms=LARGE_MODEL_TERMS,
                                 bounds=self._bounds)[0]
        return _converted(e, self._memo)

    # the parts of the equations as the report shows them: the Equations' readable forms, or for a model
    # too large to expand, the derived expressions made readable under LARGE_MODEL_TERMS (equal to them)
    @cached_property
    def mass_matrix(self) -> sympy.ImmutableMatrix:
        eqs = self.eqs
        if not self.large:
            return eqs.mass_matrix
        n, M = eqs.n, eqs.core.M
        upper = {(i, j): self.readable(M[i, j]) for i in range(n) for j in range(i, n)}
        return sympy.ImmutableMatrix(n, n, [upper[min(i, j), max(i, j)] for i in range(n) for j in range(n)])

    @cached_property
    def forcing(self) -> sympy.ImmutableMatrix:
        if not self.large:
            return self.eqs.forcing
        return sympy.ImmutableMatrix([self.readable(x, self.eqs.velocities) for x in self.eqs.core.f])

    @cached_property
    def constraint_sides(self) -> tuple:
        if not self.large:
            return tuple(self.eqs.constraints.values())
        return tuple(self.readable(g, self.eqs.velocities) for g in self.eqs.core.g)

    @cached_property
    def constraint_jacobian(self) -> sympy.ImmutableMatrix:
        eqs = self.eqs
        if not self.large:
            return eqs.constraint_jacobian
        return sympy.ImmutableMatrix(len(eqs.core.g), eqs.n, [self.readable(x) for x in eqs.core.G])

    @cached_property
    def constraint_forces(self) -> sympy.ImmutableMatrix:
        if not self.large:
            return self.eqs.constraint_forces
        return self.constraint_jacobian.T * sympy.Matrix(self.eqs.multipliers)

    @cached_property
    def constraint_acceleration(self) -> sympy.ImmutableMatrix:
        if not self.large:
            return self.eqs.constraint_acceleration
        return sympy.ImmutableMatrix([self.readable(x, self.eqs.velocities) for x in self.eqs.core.c])

    @cached_property
    def coriolis_matrix(self) -> sympy.ImmutableMatrix:
        """C from the Christoffel symbols of M (Equations.coriolis_matrix's formula), for a model too large
        to expand made readable from SymEngine (not converted to SymPy and back: 1 s for the bicycle).
        Raises LagrangianError where T* is not quadratic in the velocities."""
        eqs = self.eqs
        if not self.large:
            return eqs.coriolis_matrix.applyfunc(self.readable)
        eqs._kinetic_split  # noqa: B018 - raises where T* is not quadratic in the velocities
        M, q, qd, n = eqs.core.M, eqs.core.q, eqs.core.qd, eqs.n
        dM: dict = {}

        def d(i, j, k):  # dM_ij/dq_k, M symmetric
            key = (min(i, j), max(i, j), k)
            if key not in dM:
                dM[key] = M[i, j].diff(q[k])
            return dM[key]

        return sympy.ImmutableMatrix(n, n, [
            self.readable(sum(((d(i, j, k) + d(i, k, j) - d(j, k, i)) * qd[k] / 2 for k in range(n)), se.Integer(0)))
            for i in range(n) for j in range(n)])

    @cached_property
    def equation_residuals(self) -> tuple:
        """E_i = (M q_ddot)_i - f_i - (G^T lambda)_i, as Equations.equations for a model too large to expand."""
        eqs = self.eqs
        if not (self.large and eqs._mass_matrix_free_of_velocities):
            return eqs.equations
        M, f, qdd = self.mass_matrix, self.forcing, eqs.accelerations
        R = self.constraint_forces if eqs.is_constrained else sympy.zeros(eqs.n, 1)
        return tuple(sympy.Add(*(M[i, j] * qdd[j] for j in range(eqs.n)), -f[i], -R[i]) for i in range(eqs.n))

    # ----------------------------------------------------------- 1. bodies
    def bodies(self) -> Section:
        blocks = []
        elements = self.model.elements
        if not elements:
            blocks.append(Paragraph.of(
                "The model is given by its energies (T*, V, D and Q written directly), without "
                "elements: there are no bodies or frames to list."))
            return Section("bodies", "Bodies and frame", tuple(blocks))
        n = len(self.massive)
        frames = self.model.frames
        blocks.append(Paragraph.of(
            f"{n} {'body' if n == 1 else 'bodies'} with mass "
            f"({', '.join(f'{e.kind} {e.name}' for e in self.massive) or 'none'}). "
            + (f"With the inertial frame, {n + 1} reference frame{'s' if n else ''} (the seed's N + 1)."
               if not frames else
               f"Reference frames: the inertial frame world and {len(frames)} more, each with its parent, its "
               "origin in the parent's axes and its rotation (successive rotations about its own axes):")))
        if frames:
            blocks.append(Table(("frame", "parent", "origin", "rotation"), tuple(
                (f.name, f.parent, _col(f.origin), _rotation_text(f)) for f in frames.values())))
            blocks += self._frames()
        dims = {len(e.position) for e in elements if hasattr(e, "position")}
        axes = "x, y, z" if 3 in dims else "x, y"
        blocks.append(Paragraph.of(f"Positions are written in one inertial frame with axes {axes}"
                                   + (", each body's rotation by an angle about z." if any(
                                       isinstance(e, RigidBody) for e in elements) else ".")))
        rows = []
        for e in elements:
            if isinstance(e, Particle):
                rows.append((e.name, e.kind, e.mass, "point mass"))
            elif isinstance(e, RigidBody):
                rows.append((e.name, e.kind, e.mass, sympy.Eq(S("I"), e.inertia, evaluate=False)))
            elif isinstance(e, RigidBody3D):
                rows.append((e.name, f"{e.kind} in space, frame {e.frame}", e.mass,
                             sympy.Eq(S("I"), sympy.Matrix(e.inertia), evaluate=False)))
            else:
                rows.append((e.name, e.kind, "", ""))
        blocks.append(Table(("element", "kind", "mass", "inertia"), tuple(rows)))
        return Section("bodies", "Bodies and frame", tuple(blocks))

    def _frames(self) -> list:
        """Each frame's rotation (its elementary rotations multiplied out), its origin in world axes
        and its angular velocity in its own axes, derived as derive() derives it."""
        from ..model._frames import frame_pose, world_factors

        kin = self.kin
        frames = self.model.frames
        blocks = [Paragraph.of(
            "A frame's rotation R (its axes in its parent's axes: components b in the frame are R b in the "
            "parent) is the product of its elementary rotations, each about the current axes; its origin in "
            "world axes is the parent's plus the parent's rotation times its origin. Its angular velocity in "
            "its own axes is derived, never given: the sum, over the rotations F_1 ... F_k of the chain from "
            "the world, of each one's rate (a_i' about its axis e_i) carried into the frame's axes by the "
            "rotations after it, omega = sum_i (F_(i+1) ... F_k)^T a_i' e_i: the vector of the skew-symmetric "
            "matrix R^T dR/dt, without the products of sines and cosines that R^T dR/dt would have to cancel:")]
        for f in frames.values():
            R = f.rotation.applyfunc(self.readable)
            blocks.append(Paragraph.of(f"Frame {f.name}, in frame {f.parent}: its rotation ",
                                       Math(_product(f.factors), S(f"R_{f.name}")), ":"))
            blocks.append(Math(sympy.ImmutableMatrix(R), S(f"R_{f.name}"), key=f"rotation[{f.name}]"))
            origin, _ = frame_pose(frames, f.name)
            blocks.append(Math(_col(self.readable(x) for x in origin), S(f"o_{f.name}"), key=f"origin[{f.name}]"))
            terms = _omega_terms(world_factors(frames, f.name), kin)
            shown = tuple(_col(self.readable(x) for x in term) for term in terms)
            total = _col(self.readable(x) for x in _add(terms))
            if len(shown) > 1:
                blocks.append(Math(shown, S(f"omega_{f.name}"), key=f"omega-terms[{f.name}]"))
            blocks.append(Math(total, S(f"omega_{f.name}"), key=f"frame-omega[{f.name}]"))
        return blocks

    # ------------------------------------------------------ 2. coordinates
    def coordinates(self) -> Section:
        eqs = self.eqs
        n = eqs.n
        if eqs.is_constrained:
            kinds = [c.kind for c in self.model.constraints]
            h, v = kinds.count("holonomic"), kinds.count("velocity")
            head = (f"{n} generalized coordinates, complete but not independent: "
                    + (f"{h} holonomic constraint{'s relate' if h != 1 else ' relates'} them (section "
                       "Constraints), leaving " f"{n - h} of them free" if h else "")
                    + (", and " if h and v else "")
                    + (f"{v} velocity constraint{'s' if v != 1 else ''} restrict their velocities to "
                       f"{n - h - v} free combination{'s' if n - h - v != 1 else ''}" if v else "")
                    + "; the state is x = [q, q_dot].")
        else:
            head = (f"{n} generalized coordinate{'s' if n != 1 else ''}, complete and "
                    "independent; the state is x = [q, q_dot].")
        blocks = [Paragraph.of(head),
                  Math(_col(eqs.coordinates), S("q"), key="q"),
                  Math(_col(eqs.velocities), S("q_dot"), key="q_dot")]
        if eqs.parameters:
            rows = tuple((p, "(no value)" if v is None else f"{v:g}") for p, v in eqs.parameters.items())
            blocks += [Paragraph.of("Parameters (SI units, angles in radians):"),
                       Table(("parameter", "value"), rows)]
        if eqs.inputs:
            blocks.append(Paragraph.of("Inputs (given as functions of time when simulating): ",
                                       *_join_math(eqs.inputs), "."))
        return Section("coordinates", "Generalized coordinates", tuple(blocks))

    # ----------------------------------------------- 3. positions, velocities
    def kinematics(self) -> Section:
        kin = self.kin
        blocks = []
        if not self.model.elements:
            blocks.append(Paragraph.of(
                "This model is written with its energies only, so there are no element positions or "
                "velocities to list: T*, V and D are given directly (next sections)."))
            return Section("kinematics", "Positions and velocities", tuple(blocks))
        j = S("j")
        chain = sympy.Sum(Partial(S("r"), S("q_j")) * S("q_j_dot"), (j, 1, S("n"))) + Partial(S("r"), S("t"))
        blocks.append(Paragraph.of("Velocities are total time derivatives, by the chain rule: ",
                                   sympy.Eq(S("v"), chain, evaluate=False), "."))
        for e in self.model.elements:
            name = e.name
            if isinstance(e, (Particle, RigidBody, Point)):
                what = {"particle": f"Particle {name}, mass ", "rigid body": f"Rigid body {name}, mass ",
                        "point": f"Point {name} (massless)"}[e.kind]
                head = [what] + ([e.mass] if not isinstance(e, Point) else [])
                if isinstance(e, RigidBody):
                    head += [", centroidal inertia ", e.inertia]
                blocks.append(Paragraph.of(*head, ":"))
                r = tuple(e.position)
                v = tuple(self.readable(x) for x in kin.velocity(r))
                blocks.append(Math(_col(r), S("r"), key=f"position[{name}]"))
                blocks.append(Math(_col(v), S("v"), key=f"velocity[{name}]"))
                if isinstance(e, Point):
                    continue
                v2 = self.readable(sum((kin.se(x) ** 2 for x in v), se.Integer(0)))
                blocks.append(Math(v2, S("|v|^2"), key=f"speed2[{name}]"))
                if isinstance(e, RigidBody):
                    blocks.append(Math(e.angle, S("theta"), key=f"angle[{name}]"))
                    blocks.append(Math(self.readable(kin.rate(e.angle)), S("omega"), key=f"rate[{name}]"))
                    blocks.append(Paragraph.of("Its kinetic co-energy, translation and rotation, ", Math(
                        (S("m") * S("|v|^2") / 2, S("I") * S("omega") ** 2 / 2), S("T^*")), ":"))
                else:
                    blocks.append(Paragraph.of("Its kinetic co-energy, ",
                                               Math(S("m") * S("|v|^2") / 2, S("T^*")), ":"))
                blocks.append(Math(self.readable(e.contribute(kin).T), S("T^*"), key=f"T[{name}]"))
            elif isinstance(e, RigidBody3D):
                blocks.append(Paragraph.of(f"Rigid body {name} in space, mass ", e.mass, ", centroidal inertia in "
                                           f"the axes of its frame {e.frame} ", sympy.Matrix(e.inertia),
                                           "; its centre of mass and velocity:"))
                r = tuple(e.position)
                v = tuple(self.readable(x) for x in kin.velocity(r))
                blocks.append(Math(_col(r), S("r"), key=f"position[{name}]"))
                blocks.append(Math(_col(v), S("v"), key=f"velocity[{name}]"))
                blocks.append(Paragraph.of(
                    f"Its angular velocity in its own axes, that of its frame {e.frame} (derived from the frame's "
                    "rotation R, as in section 1: the skew-symmetric matrix of omega is R^T dR/dt; never given), and "
                    "its kinetic co-energy, translation and rotation, T* = m |v|^2/2 + omega^T I omega/2:"))
                blocks.append(Math(_col(self.readable(w) for w in angular_velocity(e.factors, kin)), S("omega"),
                                   key=f"omega[{name}]"))
                blocks.append(Math(self.readable(e.contribute(kin).T), S("T^*"), key=f"T[{name}]"))
            elif isinstance(e, Torque3D):
                blocks.append(Paragraph.of(f"Torque {name} on body {e.body}, in the axes of {e.frame}; its "
                                           "generalized forces by virtual work, the torque times the virtual "
                                           "rotation, ", Math(sympy.Mul(S("tau^T"), Partial(S("omega"), S("q_k_dot")),
                                                                        evaluate=False), S("Q_k")), ":"))
                blocks.append(Math(_col(e.torque), S("tau"), key=f"torque[{name}]"))
                blocks.append(Math(_col(self.readable(x) for x in e.contribute(kin).Q), S("Q"), key=f"Q[{name}]"))
            elif isinstance(e, Spring):
                blocks.append(Paragraph.of(f"Spring {name}, stiffness ", e.stiffness,
                                           f", between {e.between[0]} and {e.between[1]}" if e.between else "",
                                           ", length and potential energy:"))
                blocks.append(Math(self.readable(e.length), S("ell"), key=f"length[{name}]"))
                blocks.append(Math(self.readable(e.contribute(kin).V), S("V"), key=f"V[{name}]"))
            elif isinstance(e, Damper):
                blocks.append(Paragraph.of(f"Damper {name}, coefficient ", e.coefficient,
                                           f", between {e.between[0]} and {e.between[1]}" if e.between else "",
                                           ", length, its rate and the dissipation function:"))
                blocks.append(Math(self.readable(e.length), S("ell"), key=f"length[{name}]"))
                blocks.append(Math(self.readable(kin.rate(e.length)), S("ell_dot"), key=f"rate[{name}]"))
                blocks.append(Math(self.readable(e.contribute(kin).D), S("D"), key=f"D[{name}]"))
            elif isinstance(e, Gravity):
                space = any(len(x.position) == 3 for x in self.model.elements if hasattr(x, "position"))
                direction = e.direction or ("(0, 0, -1)" if space else "(0, -1)")
                blocks.append(Paragraph.of("Gravity, of magnitude ", e.g, ", along ",
                                           _col(e.direction) if e.direction else direction,
                                           ", on every body with mass: the sum of ",
                                           Math(-S("m") * S("g") * S("e^T") * S("r"), S("V")),
                                           " over the bodies, e the unit vector of gravity:"))
                blocks.append(Math(self.readable(e.contribute(kin).V), S("V"), key=f"V[{name}]"))
            elif isinstance(e, Force):
                blocks.append(Paragraph.of(f"Force {name}" + (f" at {e.at}" if e.at else "")
                                           + ", its point of application and its generalized forces by "
                                           "virtual work, ",
                                           Math(sympy.Mul(S("F^T"), Partial(S("r"), S("q_k")), evaluate=False),
                                                S("Q_k")), ":"))
                blocks.append(Math(_col(e.force), S("F"), key=f"force[{name}]"))
                blocks.append(Math(_col(e.position), S("r"), key=f"position[{name}]"))
                blocks.append(Math(_col(self.readable(x) for x in e.contribute(kin).Q), S("Q"), key=f"Q[{name}]"))
            elif isinstance(e, Torque):
                blocks.append(Paragraph.of(f"Torque {name}" + (f" on body {e.body}" if e.body else "")
                                           + ", acting on the angle ", Math(e.angle, S("alpha")),
                                           "; its generalized forces, ",
                                           Math(sympy.Mul(S("tau"), Partial(S("alpha"), S("q_k")), evaluate=False),
                                                S("Q_k")), ":"))
                blocks.append(Math(e.torque, S("tau"), key=f"torque[{name}]"))
                blocks.append(Math(_col(self.readable(x) for x in e.contribute(kin).Q), S("Q"), key=f"Q[{name}]"))
        return Section("kinematics", "Positions and velocities", tuple(blocks))

    # ------------------------------------------------------- 4. energies
    def energies(self) -> Section:
        eqs, model = self.eqs, self.model
        blocks = []
        src = "the elements above" if model.elements else "the model"
        if model.elements and model.T != 0:
            src += " and the terms given directly"
        blocks.append(Paragraph.of(f"The kinetic co-energy T*, summed over {src}:"))
        blocks.append(Math(self.readable(eqs.T), S("T^*"), key="T"))
        try:
            split = self._kinetic_split()
        except LagrangianError:
            split = None
        if split is not None:
            T1, T0 = split
            if T1 != 0 or T0 != 0:
                blocks.append(Paragraph.of(
                    "T* = T2 + T1 + T0 by degree in the velocities; T1 gives gyroscopic forces and "
                    "T0 is the potential of the centrifugal forces (Preumont):"))
                if T1 != 0:
                    blocks.append(Math(T1, S("T_1"), key="T1"))
                if T0 != 0:
                    blocks.append(Math(T0, S("T_0"), key="T0"))
        blocks.append(Paragraph.of("The potential energy V:"))
        blocks.append(Math(self.readable(eqs.V), S("V"), key="V"))
        return Section("energies", "Kinetic co-energy and potential energy", tuple(blocks))

    def _kinetic_split(self):
        core = self.eqs.core
        for e in core.M:
            if set(e.free_symbols) & set(core.qd):
                raise LagrangianError("T* is not quadratic in the velocities")
        zero = {v: 0 for v in core.qd}
        T1 = sum((core.T.diff(v).subs(zero) * v for v in core.qd), se.Integer(0))
        T0 = core.T.subs(zero)
        return self.readable(T1), self.readable(T0)

    # ---------------------------------------------------- 5. dissipation
    def dissipation(self) -> Section:
        D = self.eqs.D
        if D == 0:
            blocks = (Paragraph.of("No dissipative elements: the Rayleigh dissipation function is zero."),
                      Math(_ZERO, S("D"), key="D"))
        else:
            blocks = (Paragraph.of("The Rayleigh dissipation function D (its velocity gradient gives "
                                   "the damping forces -dD/dq_dot):"),
                      Math(self.readable(D), S("D"), key="D"))
        return Section("dissipation", "Dissipation", blocks)

    # --------------------------------------------------------- 6. forces
    def forces(self) -> Section:
        eqs = self.eqs
        Q = sympy.ImmutableMatrix([self.readable(x) for x in eqs.generalized_forces])
        if all(x == 0 for x in Q):
            blocks = [Paragraph.of("No external forces or torques: the generalized forces are zero.")]
        else:
            blocks = [Paragraph.of("The generalized forces, one for each coordinate, from the virtual work "
                                   "of the forces and torques (and the [forces] table of a model file):")]
        blocks.append(Math(Q, S("Q"), key="Q"))
        if eqs.inputs:
            blocks.append(Paragraph.of("Their input matrix ", sympy.Eq(S("B"), Partial(S("Q"), S("u")), evaluate=False),
                                       ", with u = ", _col(eqs.inputs), ":"))
            blocks.append(Math(eqs.input_matrix, S("B"), key="B"))
        return Section("forces", "Generalized forces", tuple(blocks))

    # ------------------------------------------------------- constraints
    def constraints(self) -> Section:
        """g(q, t) = 0 or a(q, t) q_dot + b = 0, their Jacobian G, the multipliers, the constraint
        forces G^T lambda and the acceleration form G q_ddot = c (only for a constrained model)."""
        eqs, model = self.eqs, self.model
        cons = model.constraints
        m = len(cons)
        blocks = [Paragraph.of(
            f"{m} constraint{'s' if m != 1 else ''}, each with its Lagrange multiplier lambda_<name>: a holonomic "
            "constraint g(q, t) = 0 restricts the configurations, a velocity (nonholonomic) constraint "
            "a(q, t) q_dot + b(q, t) = 0 the velocities only.")]
        # the constraints' g, G, c are readable already: made readable again only for a model small
        # enough to expand (the bicycle: 1 s for the same text)
        again = (lambda e: e) if eqs.too_large_to_expand else self.readable
        for c, g in zip(cons, self.constraint_sides):
            kind = "holonomic" if c.kind == "holonomic" else "velocity (nonholonomic)"
            blocks.append(Paragraph.of(f"Constraint {c.name}, {kind}, multiplier ", c.multiplier, ":"))
            blocks.append(Math(_ZERO, again(g), key=f"constraint[{c.name}]"))
        independent = [str(q) for q in model.simulation.get("independent", ())]
        if independent:
            blocks.append(Paragraph.of(f"The independent coordinates ([simulation] independent): "
                                       f"{', '.join(independent)}; the constraints fix the others."))
        G = self.constraint_jacobian.applyfunc(again)
        blocks.append(Paragraph.of(
            "Their Jacobian G, one row per constraint: dg/dq for a holonomic constraint, the velocities' "
            "coefficients a for a velocity constraint; at velocity level the constraints read ",
            Math(_ZERO, (S("G") * S("q_dot"), S("b"))), " (b = dg/dt for a holonomic one):"))
        blocks.append(Math(sympy.ImmutableMatrix(G), S("G"), key="constraint-jacobian"))
        lam = _col(eqs.multipliers)
        blocks.append(Paragraph.of("The multipliers and the generalized forces the constraints exert, ",
                                   sympy.Mul(S("G^T"), S("lambda"), evaluate=False),
                                   " (with g written as a length, a distance minus a length, dg/dq is a unit vector "
                                   "and lambda the force along it):"))
        blocks.append(Math(lam, S("lambda"), key="multipliers"))
        blocks.append(Math(self.constraint_forces.applyfunc(again),
                           sympy.Mul(S("G^T"), S("lambda"), evaluate=False), key="constraint-forces"))
        blocks.append(Paragraph.of(
            "Differentiated to acceleration level (a holonomic constraint twice, a velocity constraint once), "
            "with the velocity residual w = G q_dot + b, the constraints read ",
            Math(S("c"), S("G") * S("q_ddot")), ", with ",
            Math((-sympy.Mul(Partial(S("w"), S("q")), _ORDERED_QDOT, evaluate=False), -Partial(S("w"), S("t"))),
                 S("c")), ":"))
        blocks.append(Math(self.constraint_acceleration.applyfunc(again), S("c"), key="c"))
        return Section("constraints", "Constraints", tuple(blocks))

    # ----------------------------------------------------- 7. Lagrangian
    def lagrangian(self) -> Section:
        eqs = self.eqs
        blocks = [Math((S("T^*"), -S("V")), S("L"), key="L-definition"),
                  Math(self.readable(eqs.L), S("L"), key="L")]
        if self.large and eqs._mass_matrix_free_of_velocities:
            # h = q_dot^T M q_dot / 2 - L0 with M as shown (not h expanded and made readable, nor h as
            # derived converted to SymPy: the bicycle's h is over the budget, and either took seconds)
            M, v, n = self.mass_matrix, eqs.velocities, eqs.n
            L0 = eqs.core.L.subs({qd: 0 for qd in eqs.core.qd})
            h = sympy.Add(*(sympy.Mul(sympy.S.Half if i == j else sympy.S.One, M[i, j], v[i], v[j])
                            for i in range(n) for j in range(i, n)), self.readable(-L0, v))
        else:
            h = self.readable(eqs.jacobi_integral)
        constrained = eqs.is_constrained
        if eqs.is_conservative:
            velocity = any(c.kind != "holonomic" for c in self.model.constraints)
            conserved = ("It is conserved: L does not depend on t explicitly, D = 0 and Q = 0"
                         + (", and the constraints do no work (they do not depend on t"
                            + (", and the velocity constraints have no term free of the velocities"
                               if velocity else "") + ")." if constrained else "."))
        else:
            why = [w for w, c in (("L depends on t explicitly", eqs.explicit_time), ("D is not zero", eqs.D != 0),
                                  ("Q is not zero", any(x != 0 for x in eqs.generalized_forces)),
                                  ("the constraints do work (they depend on t)",
                                   constrained and not eqs._constraints_scleronomic)) if c]
            conserved = f"It is not conserved here: {', '.join(why)}."
        blocks.append(Paragraph.of("The Jacobi integral ",
                                   Math((sympy.Sum(S("q_i_dot") * Partial(S("L"), S("q_i_dot")), (S("i"), 1, S("n"))),
                                         -S("L")), S("h")),
                                   " (the energy T* + V when T* is quadratic in the velocities). " + conserved))
        blocks.append(Math(h, S("h"), key="h"))
        return Section("lagrangian", "Lagrangian", tuple(blocks))

    # ------------------------------------------------------- 8. equations
    def equations(self) -> Section:
        eqs, kin = self.eqs, self.kin
        core = eqs.core
        has_D = core.D != 0
        constrained = eqs.is_constrained
        generic_rhs = ((S("Q_i"), sympy.Sum(S("lambda_k") * S("G_ki"), (S("k"), 1, S("m")))) if constrained
                       else S("Q_i"))
        generic = Math(generic_rhs, (TimeDerivative(Partial(S("L"), S("q_i_dot"))), -Partial(S("L"), S("q_i")),
                                     Partial(S("D"), S("q_i_dot"))))
        blocks = [Paragraph.of("One equation for each coordinate, ", generic,
                               ", with d/dt by the chain rule (q, q_dot and q_ddot are independent "
                               "symbols)" + ("; the constraint forces (G^T lambda)_i, with the multipliers "
                                             "lambda_k as further unknowns, join the generalized forces:"
                                             if constrained else ":"))]
        forces = self.constraint_forces if constrained else None
        Lsym, Dsym = S("L"), S("D")
        qdd = [se.Symbol(a.name) for a in eqs.accelerations]
        for i, (q, qd) in enumerate(zip(eqs.coordinates, eqs.velocities)):
            Qi = S(f"Q_{i + 1}")
            lhs = [TimeDerivative(Partial(Lsym, qd)), -Partial(Lsym, q)]
            if has_D:
                lhs.append(Partial(Dsym, qd))
            blocks.append(Paragraph.of(f"Equation {i + 1}, for coordinate ", q, ":"))
            rhs = (Qi, ConstraintForce(i + 1)) if constrained else Qi
            blocks.append(Math(rhs, tuple(lhs), key=f"lagrange[{q.name}]", label=f"({i + 1})"))
            p = core.p[i]
            dpdt = kin.rate(p) + sum((p.diff(core.qd[j]) * qdd[j] for j in range(eqs.n)), se.Integer(0))
            blocks.append(Math(self.readable(p), Partial(Lsym, qd), key=f"dL/d{qd.name}"))
            blocks.append(Math(self.readable(dpdt), TimeDerivative(Partial(Lsym, qd)), key=f"d/dt dL/d{qd.name}"))
            blocks.append(Math(self.readable(core.L.diff(core.q[i])), Partial(Lsym, q), key=f"dL/d{q.name}"))
            if has_D:
                blocks.append(Math(self.readable(core.D.diff(core.qd[i])), Partial(Dsym, qd), key=f"dD/d{qd.name}"))
            blocks.append(Math(self.readable(core.Q[i]), Qi, key=f"Q_{i + 1}"))
            if constrained:
                blocks.append(Math(self.readable(forces[i]), ConstraintForce(i + 1), key=f"constraint-force[{q.name}]"))
            blocks.append(Paragraph.of("so that"))
            blocks.append(Math(_ZERO, self.equation_residuals[i], key=f"equation[{q.name}]", label=f"({i + 1})"))
        return Section("equations", "Lagrange's equations", tuple(blocks))

    # ----------------------------------------------------- 9. matrix form
    def matrix_form(self) -> Section:
        eqs = self.eqs
        blocks = []
        try:
            C = self.coriolis_matrix
        except LagrangianError as exc:
            C = None
            blocks.append(Paragraph.of(f"{exc}."))
        constrained = eqs.is_constrained
        # with constraints G is their Jacobian: the potential's gradient is written dV/dq
        gradient = Partial(S("V"), S("q")) if constrained else S("G")
        lhs = [S("M") * S("q_ddot")]
        rhs = [S("Q")]
        parts = []
        if C is not None:
            lhs += [S("C") * S("q_dot"), gradient]
            if any(x != 0 for x in eqs.gyroscopic_matrix):
                rhs.append(-S("Gamma") * S("q_dot"))
                parts.append(Math(eqs.gyroscopic_matrix, S("Gamma"), key="Gamma"))
            if any(x != 0 for x in eqs.centrifugal_forces):
                rhs.append(Partial(S("T_0"), S("q")))
                parts.append(Math(eqs.centrifugal_forces.applyfunc(self.readable), Partial(S("T_0"), S("q")),
                                  key="centrifugal"))
            if any(x != 0 for x in eqs.rheonomic_forces):
                rhs.append(S("f_t"))
                parts.append(Math(eqs.rheonomic_forces.applyfunc(self.readable), S("f_t"), key="rheonomic"))
        if eqs.D != 0:
            rhs.append(-Partial(S("D"), S("q_dot")))
            parts.append(Math(eqs.damping_forces.applyfunc(self.readable), -Partial(S("D"), S("q_dot")),
                              key="damping"))
        if constrained:
            rhs.append(sympy.Mul(S("G^T"), S("lambda"), evaluate=False))
        blocks.append(Paragraph.of("The equations in matrix form (the seed's H(q) is M(q))"
                                   + (", with the constraint forces and the constraints at acceleration level "
                                      "(G the constraints' Jacobian):" if constrained else ":")))
        blocks.append(Math(tuple(rhs), tuple(lhs), key="matrix-form"))
        if constrained:
            blocks.append(Math(S("c"), S("G") * S("q_ddot"), key="matrix-form-constraints"))
        blocks.append(Paragraph.of("with the mass matrix M = d2T*/dq_dot2 (symmetric)"
                                   + (", the Coriolis and centrifugal matrix C from the Christoffel symbols "
                                      "of M, the gradient " + ("dV/dq" if constrained else "G = dV/dq")
                                      if C is not None else "") + ":"))
        blocks.append(Math(self.mass_matrix, S("M"), key="M"))
        if C is not None:
            blocks.append(Math(C, S("C"), key="C"))
            blocks.append(Math(eqs.potential_gradient.applyfunc(self.readable), gradient, key="G"))
        blocks += parts
        if constrained:
            blocks.append(Paragraph.of(
                "Equivalently, with the forcing f below and G and c of the constraints' section, the form the "
                "simulation solves, for the accelerations and the multipliers together (a saddle-point system, "
                "solved numerically at each step: never by a symbolic inverse):"))
            blocks.append(Math((S("f"), sympy.Mul(S("G^T"), S("lambda"), evaluate=False)), S("M") * S("q_ddot"),
                               key="constrained-form"))
            saddle = sympy.MatMul(sympy.ImmutableMatrix([[S("M"), S("G^T")], [S("G"), 0]]),
                                  sympy.ImmutableMatrix([S("q_ddot"), -S("lambda")]), evaluate=False)
            blocks.append(Math(sympy.ImmutableMatrix([S("f"), S("c")]), saddle, key="saddle-point"))
        else:
            blocks.append(Paragraph.of("Equivalently M q_ddot = f, the form the simulation solves, with the forcing"))
        blocks.append(Math(self.forcing, S("f"), key="f"))
        lin = eqs.linear
        if lin is not None:
            blocks.append(Paragraph.of("The system is linear: ",
                                       "M x'' + C x' + K x = f with constant matrices"))
            for k in ("M", "C", "K", "f"):
                blocks.append(Math(getattr(lin, k), S(k), key=f"linear.{k}"))
        return Section("matrix-form", "Matrix form", tuple(blocks))

    # ------------------------------------------------------ 10. state form
    def state_form(self) -> Section:
        eqs = self.eqs
        x = _col((*eqs.coordinates, *eqs.velocities))
        if eqs.is_constrained:
            blocks = [Paragraph.of("With the state x = [q, q_dot], the state equations x' = f(t, x, u, p) are"),
                      Math(x, S("x"), key="x"),
                      Math(sympy.ImmutableMatrix([[S("q_dot")], [S("q_ddot")]]), S("x_dot"), key="x_dot"),
                      Paragraph.of(
                          "with q_ddot (and lambda) from the saddle-point system of the matrix form, solved "
                          "numerically at each evaluation. The accelerations are not solved for symbolically. "
                          "Integrated alone, these equations let g and G q_dot + b drift with the integration "
                          "error, so the simulation projects the state back onto the constraints after every "
                          "step (the coordinates onto g = 0, the velocities onto G q_dot + b = 0)."),
                      Paragraph.of(f"Order of the state: {', '.join(eqs.state_names)}; inputs: "
                                   f"{', '.join(u.name for u in eqs.inputs) or 'none'}; parameters: "
                                   f"{', '.join(p.name for p in eqs.parameters) or 'none'}; multipliers: "
                                   f"{', '.join(mu.name for mu in eqs.multipliers)}.")]
            return Section("state-form", "State equations", tuple(blocks))
        blocks = [Paragraph.of("With the state x = [q, q_dot], the state equations x' = f(t, x, u, p) are"),
                  Math(x, S("x"), key="x"),
                  Math(sympy.ImmutableMatrix([[S("q_dot")], [S("M^-1") * S("f")]]), S("x_dot"), key="x_dot")]
        explicit = self._accelerations()
        if explicit is not None:
            blocks.append(Paragraph.of("Solved for the accelerations (shown because the system is small; "
                                       "the numerical layer solves M q_ddot = f at each step instead):"))
            blocks.append(Math(explicit, _col(eqs.accelerations), key="q_ddot"))
        else:
            blocks.append(Paragraph.of("The accelerations are not solved for symbolically (the expressions "
                                       "grow fast with the number of coordinates): the numerical layer "
                                       "solves M q_ddot = f at each step."))
        names = ", ".join(eqs.state_names)
        inputs = ", ".join(u.name for u in eqs.inputs) or "none"
        params = ", ".join(p.name for p in eqs.parameters) or "none"
        blocks.append(Paragraph.of(f"Order of the state: {names}; inputs: {inputs}; parameters: {params}."))
        return Section("state-form", "State equations", tuple(blocks))

    def _accelerations(self):
        eqs = self.eqs
        if eqs.n > 2:
            return None
        M = sympy.Matrix(eqs.mass_matrix)
        f = sympy.Matrix(eqs.forcing)
        if any(x.count_ops() > 60 for x in (*M, *f)):
            return None
        det = factored(determinant(M))
        if det == 0:
            return None
        numerators = (M.adjugate() * f).applyfunc(sympy.expand)
        return sympy.ImmutableMatrix([sympy.factor_terms(sympy.cancel(x / det)) for x in numerators])

    # ----------------------------------------------------- 11. singularities
    def singularities(self) -> Section:
        rep = diagnosis(self.eqs, None, self.mass_matrix)  # singularities(), with M as the report shows it
        blocks = []
        detM = sympy.Function("det")(S("M"))
        if isinstance(rep.det_mass_matrix, sympy.Determinant):
            blocks.append(Paragraph.of(f"det M is not expanded for {self.eqs.n} coordinates; its zeros are "
                                       "searched for numerically."))
        elif rep.det_mass_matrix is not None:
            blocks.append(Math(rep.det_mass_matrix, detM, key="det M"))
            if rep.det_with_values is not None and rep.det_with_values != rep.det_mass_matrix:
                blocks.append(Paragraph.of("with the parameter values:"))
                blocks.append(Math(rep.det_with_values, detM, key="det M values"))
        lines = rep.text().splitlines()
        if lines and lines[0].startswith("det M"):
            lines = lines[1:]
        blocks += [Paragraph.of(line) for line in lines]
        if not self.eqs.is_constrained:
            return Section("singularities", "Mass matrix diagnosis", tuple(blocks))
        blocks.append(Paragraph.of(
            "With constraints, what the simulation needs to be regular is the saddle-point matrix "
            "[M, G^T; G, 0] rather than M alone: G of full rank (independent constraints; G loses rank at a "
            "mechanism's singular configurations, where the simulation stops and names the constraints that "
            "became dependent) and M positive definite on the motions the constraints allow (G q_dot = 0). "
            "The constraints' diagnosis (lagrangian check):"))
        try:
            crep = constraint_singularities(self.eqs)
        except (LagrangianError, ValueError, NotImplementedError) as exc:
            blocks.append(Paragraph.of(f"The constraints could not be diagnosed: {exc}"))
        else:
            lines = crep.text().splitlines()
            if crep.gram_determinant is not None:
                blocks.append(Math(crep.gram_determinant, sympy.Function("det")(S("G") * S("G^T")), key="det G G^T"))
                lines = [line for line in lines if not line.startswith("det(G G^T) =")]
            blocks += [Paragraph.of(line) for line in lines]
        return Section("singularities", "Mass matrix and constraints diagnosis", tuple(blocks))

    # ------------------------------------------------------- 12. equilibria
    def equilibria(self) -> Section:
        title = "Equilibria and stability"
        try:
            from ..analysis import equilibria
        except ImportError:
            return Section("equilibria", title, (Paragraph.of(
                "Equilibria are not available in this version of lagrangian (no analysis module)."),))
        try:
            found = equilibria(self.eqs)
        except (LagrangianError, ValueError, NotImplementedError) as exc:
            return Section("equilibria", title, (Paragraph.of(f"Equilibria could not be computed: {exc}"),))
        if not found:
            return Section("equilibria", title, (Paragraph.of(
                "There is no equilibrium (with the inputs at zero and the parameter values):"),
                *(Paragraph.of(f"{_sentence(note)}.") for note in getattr(found, "notes", ()))))
        constrained = self.eqs.is_constrained
        if constrained:
            blocks = [Paragraph.of(
                "Equilibria with the inputs at zero and the parameter values: at rest the forces are balanced by "
                "forces the constraints can exert, on the constraints, ",
                Math(_ZERO, (S("f"), sympy.Mul(S("G^T"), S("lambda"), evaluate=False))), " and ",
                Math(_ZERO, S("g")), ", solved for q and the multipliers; their stability from the equations "
                "linearized in the independent coordinates (the constraints eliminated at each equilibrium, "
                "with the stiffness of the constraint forces):")]
        else:
            blocks = [Paragraph.of("Equilibria with the inputs at zero and the parameter values, and their "
                                   "stability from the linearized equations:")]
        rows = []
        for i, e in enumerate(found):
            coords = _relations(e.coordinates, getattr(e, "exact", None))
            eig = getattr(e, "eigenvalues", None)
            eig_text = ""
            if eig is not None:
                eig_text = ", ".join(_complex_text(z) for z in list(eig)[:8])
            stability = getattr(e, "stability", "stable" if e.stable else "unstable")
            if not getattr(e, "isolated", True):
                from ..analysis._equilibria import _set_text

                stability += f" (non-isolated: {_set_text(e.dimension, e.along, 'equilibria')})"
            row = [str(i + 1), coords]
            if constrained:
                row.append(_relations(e.multipliers, e.exact_multipliers))
            rows.append((*row, stability, eig_text))
        header = ("", "configuration", "multipliers", "stability", "eigenvalues") if constrained else \
            ("", "configuration", "stability", "eigenvalues")
        blocks.append(Table(header, tuple(rows)))
        blocks += [Paragraph.of(f"{_sentence(note)}.") for note in getattr(found, "notes", ())]
        return Section("equilibria", title, tuple(blocks))


def _relations(values, exact) -> object:
    """name = value (exact where known) for each item, as one inline tuple ("" when none)."""
    exact = exact or {}
    out = []
    for name, value in values.items():
        ex = exact.get(name)
        out.append(sympy.Eq(S(name), ex if ex is not None else sympy.Float(value, 6), evaluate=False))
    return _join_inline(out) if out else ""


def _product(factors) -> sympy.Expr:
    """A rotation's factors as an unevaluated product R_z(phi) R_x(theta) ... (I when there is none)."""
    parts = []
    for f in factors:
        if f.matrix is not None:
            parts.append(Given(f.matrix))
        else:
            axis = {(1, 0, 0): "x", (0, 1, 0): "y", (0, 0, 1): "z"}.get(
                tuple(int(a) if a.is_Integer else a for a in f.axis))
            parts.append(Rotation(axis or tuple(f.axis), f.angle))
    if not parts:
        return S("I")
    return parts[0] if len(parts) == 1 else sympy.Mul(*parts, evaluate=False)


def _omega_terms(factors, kin) -> list:
    """The angular velocity of the rotation F1 F2 ... Fk in the last frame's axes as its terms, one
    per factor: (F_(i+1) ... F_k)^T w_i, with w_i = a_i' e_i (the vector of F_i^T F_i' for a matrix);
    their sum is model._frames.angular_velocity. Factors with a constant angle give no term."""
    from ..model._frames import factor_rate

    terms: list = []
    for f in factors:
        F, w = factor_rate(f, kin)
        terms = [list(F.T * se.DenseMatrix(3, 1, t)) for t in terms]
        terms.append(w)
    return [t for t in terms if any(se.expand(x) != 0 for x in t)]


def _add(terms) -> list:
    out = [se.Integer(0)] * 3
    for t in terms:
        out = [a + b for a, b in zip(out, t)]
    return out


def _sentence(text: str) -> str:
    """A note as a sentence: 'the search ...' -> 'The search ...' (not 'dV/dx' -> 'DV/dx')."""
    return text[0].upper() + text[1:] if len(text) > 1 and text[0].islower() and text[1].islower() else text


def _rotation_text(frame) -> str:
    """A frame's rotation in words: "z by phi, then x by theta", or "a matrix", or "none"."""
    if not frame.factors:
        return "none (the parent's axes)"
    parts = []
    for f in frame.factors:
        if f.matrix is not None:
            parts.append("the matrix " + sympy.sstr(sympy.Matrix(f.matrix).tolist()))
        else:
            axis = {(1, 0, 0): "x", (0, 1, 0): "y", (0, 0, 1): "z"}.get(tuple(int(a) if a.is_Integer else a
                                                                                for a in f.axis))
            parts.append(f"{axis or sympy.sstr(list(f.axis))} by {sympy.sstr(f.angle)}")
    return ", then ".join(parts)


def _complex_text(z) -> str:
    z = complex(z)
    if abs(z.imag) < 1e-12:
        return f"{z.real:.4g}"
    return f"{z.real:.4g}{z.imag:+.4g}i"


def _join_math(items) -> list:
    out = []
    for i, x in enumerate(items):
        if i:
            out.append(", ")
        out.append(x)
    return out


def _join_inline(eqs_list):
    """Several relations shown as one inline tuple of relations."""
    return sympy.Tuple(*eqs_list) if len(eqs_list) > 1 else eqs_list[0]
