"""The Model: coordinates, parameters, inputs, elements and explicit energies.

A Model is a description that you build step by step (in Python or from a model file);
:func:`lagrangian.derive` takes a snapshot of it and returns immutable
:class:`~lagrangian.equations.Equations`.
"""

from __future__ import annotations

import copy
import math
import difflib
import numbers
from typing import Mapping, Sequence

import sympy

from ..errors import ExpressionError, ModelError, Problem
from ._elements import (Damper, Element, Force, Gravity, Particle, Point, RigidBody, Spring,
                        Torque)
from ._symbols import check_name, ddot, dot, t

__all__ = ["Model"]

ExprLike = "sympy.Expr | str | float | int"


class Model:
    """A holonomic mechanical system described by generalized coordinates.

    Describe it either by its energies (kinetic co-energy ``T``, potential ``V``, Rayleigh
    dissipation ``D``, generalized forces ``Q`` by coordinate) or by elements that contribute
    to them (particles, rigid bodies, springs, dampers, gravity, forces and torques), or both.

    Parameters
    ----------
    name : str
    coordinates : sequence of str, optional
        Names of the generalized coordinates, in order.
    parameters : mapping of str to float or None, optional
        Named constants and their values (SI units, radians). ``None`` leaves a parameter
        without a value: fine for symbolic work, but a simulation then needs it in ``params``.
    inputs : sequence of str, optional
        Names of external inputs (forces, torques, signals) that may appear in V, D and Q.
    T, V, D : expression, optional
        Kinetic co-energy, potential energy and dissipation function (SymPy expressions,
        numbers, or strings in the model-file syntax).
    Q : mapping of coordinate name to expression, optional
        Generalized forces not already in D.
    description : str, optional

    Examples
    --------
    >>> import lagrangian as lg
    >>> m = lg.Model("pendulum")
    >>> theta = m.coordinate("theta")
    >>> mass, l, g = m.parameter("m", 1.0), m.parameter("l", 0.5), m.parameter("g", 9.81)
    >>> bob = m.add_particle(mass, (l * lg.sin(theta), -l * lg.cos(theta)), name="bob")
    >>> m.add_gravity(g)
    """

    def __init__(self, name: str = "model", *, coordinates: Sequence[str] = (),
                 parameters: Mapping[str, float | None] | None = None,
                 inputs: Sequence[str] = (), T=0, V=0, D=0,
                 Q: Mapping[str, object] | None = None, description: str = ""):
        self.name = name
        self.description = description
        self._coordinates: list[sympy.Symbol] = []
        self._parameters: dict[sympy.Symbol, float | None] = {}
        self._inputs: list[sympy.Symbol] = []
        self._elements: list[Element] = []
        self._T = sympy.Integer(0)
        self._V = sympy.Integer(0)
        self._D = sympy.Integer(0)
        self._Q: dict[sympy.Symbol, sympy.Expr] = {}
        self.simulation: dict = {}
        self._naming_problems: list[Problem] = []
        for c in coordinates:
            self.coordinate(c)
        for p, v in (parameters or {}).items():
            self.parameter(p, v)
        for u in inputs:
            self.input(u)
        self.add_energy(T=T, V=V, D=D)
        for qname, expr in (Q or {}).items():
            self.add_generalized_force(qname, expr)

    # ------------------------------------------------------------------ symbols
    def coordinate(self, *names: str):
        """Declare generalized coordinates; the velocity of ``q`` is ``q_dot``, its acceleration ``q_ddot``.

        Returns the symbol for one name (``x = m.coordinate("x")``), a tuple for several
        (``x, theta = m.coordinate("x", "theta")``).
        """
        if not names:
            raise ModelError("coordinate(): give at least one name, e.g. m.coordinate('x')")
        self._check_mutable()
        for i, name in enumerate(names):  # all or nothing
            self._check_new_name(name, "coordinate")
            if name in names[:i]:
                raise ModelError(f"'{name}' is declared twice: each coordinate, parameter and input needs its own name")
        out = []
        for name in names:
            s = sympy.Symbol(name)
            self._coordinates.append(s)
            out.append(s)
        return out[0] if len(out) == 1 else tuple(out)

    def parameter(self, name: str, value: float | None = None) -> sympy.Symbol:
        """Declare a named constant with its value (SI units, radians)."""
        self._check_new_name(name, "parameter")
        if value is not None and (not isinstance(value, numbers.Real) or isinstance(value, bool)
                                  or not math.isfinite(value)):
            raise ModelError(f"parameter '{name}': the value must be a finite real number, got {value!r}")
        s = sympy.Symbol(name)
        self._parameters[s] = None if value is None else float(value)
        return s

    def input(self, name: str) -> sympy.Symbol:
        """Declare a named external input (a force, torque or signal given at simulation time)."""
        self._check_new_name(name, "input")
        s = sympy.Symbol(name)
        self._inputs.append(s)
        return s

    @property
    def t(self) -> sympy.Symbol:
        """Time."""
        return t

    @property
    def q(self) -> tuple[sympy.Symbol, ...]:
        """The coordinates, in order."""
        return tuple(self._coordinates)

    @property
    def q_dot(self) -> tuple[sympy.Symbol, ...]:
        return tuple(dot(c) for c in self._coordinates)

    @property
    def q_ddot(self) -> tuple[sympy.Symbol, ...]:
        return tuple(ddot(c) for c in self._coordinates)

    @property
    def coordinates(self) -> tuple[sympy.Symbol, ...]:
        return self.q

    @property
    def parameters(self) -> dict[sympy.Symbol, float | None]:
        """Parameters and their values (None where a value was not given)."""
        return dict(self._parameters)

    @property
    def inputs(self) -> tuple[sympy.Symbol, ...]:
        return tuple(self._inputs)

    @property
    def elements(self) -> tuple[Element, ...]:
        return tuple(self._elements)

    def symbol(self, name: str) -> sympy.Symbol:
        """The symbol of a declared name (coordinate, velocity, parameter, input or t)."""
        known = self.names()
        if name not in known:
            hint = difflib.get_close_matches(name, list(known), n=1)
            extra = f" (did you mean '{hint[0]}'?)" if hint else ""
            raise ModelError(f"model '{self.name}' has no symbol '{name}'{extra}")
        return known[name]

    def names(self, *, accelerations: bool = False) -> dict[str, sympy.Symbol]:
        """Every name an expression of this model may use, mapped to its symbol."""
        out: dict[str, sympy.Symbol] = {"t": t}
        for c in self._coordinates:
            out[c.name] = c
            out[dot(c).name] = dot(c)
            if accelerations:
                out[ddot(c).name] = ddot(c)
        for p in self._parameters:
            out[p.name] = p
        for u in self._inputs:
            out[u.name] = u
        return out

    def _check_mutable(self) -> None:
        if getattr(self, "_frozen", False):
            raise ModelError(f"model '{self.name}' is the snapshot held by an Equations object and cannot change: "
                             "change a copy (model.copy()) and derive it again")

    def _freeze(self) -> "Model":
        self._frozen = True
        return self

    def _check_new_name(self, name, kind) -> None:
        self._check_mutable()
        why = check_name(name, kind)
        if why is None and name in self._all_names():
            why = f"'{name}' is declared twice: each coordinate, parameter and input needs its own name"
        if why is not None:
            raise ModelError(why)

    def _all_names(self) -> set[str]:
        names = {c.name for c in self._coordinates} | {p.name for p in self._parameters}
        return names | {u.name for u in self._inputs}

    # -------------------------------------------------------------- expressions
    def expr(self, value, where: str = "expression") -> sympy.Expr:
        """`value` as a SymPy expression: numbers and SymPy objects as they are, strings parsed
        safely (never executed) with this model's names."""
        if isinstance(value, sympy.Expr):
            return value
        if isinstance(value, (bool, sympy.Basic)):
            raise ModelError(f"{where}: expected an expression or a number, got {value!r}")
        if isinstance(value, numbers.Integral):
            return sympy.Integer(int(value))
        if isinstance(value, numbers.Real):
            return sympy.Float(float(value))
        if isinstance(value, str):
            from ..io._expr import parse_expression

            try:
                return parse_expression(value, self.names())
            except ExpressionError as exc:
                raise ModelError([Problem(str(exc), key=where)]) from None
        raise ModelError(f"{where}: expected an expression, a number or a string, got {value!r} "
                         f"({type(value).__name__})")

    def _vector(self, value, where: str) -> tuple[sympy.Expr, ...]:
        if isinstance(value, str) and value in self._points():
            return self._points()[value]
        if isinstance(value, (sympy.Matrix, sympy.ImmutableMatrix)):
            value = list(value)
        if not isinstance(value, (list, tuple)) or len(value) not in (2, 3):
            raise ModelError(f"{where}: expected a position with 2 or 3 components "
                             f"(x, y) or (x, y, z), or the name of a point, got {value!r}")
        return tuple(self.expr(v, f"{where}[{i}]") for i, v in enumerate(value))

    def _points(self) -> dict[str, tuple]:
        return {e.name: e.position for e in self._elements if hasattr(e, "position")
                and isinstance(e, (Particle, RigidBody, Point))}

    def _unique_element_name(self, name: str | None, kind: str) -> str:
        self._check_mutable()
        taken = {e.name for e in self._elements}
        if name is None:
            i = 1
            while f"{kind}{i}" in taken:
                i += 1
            return f"{kind}{i}"
        if not isinstance(name, str) or not name:
            raise ModelError(f"an element name must be a non-empty string, got {name!r}")
        if name in taken:
            raise ModelError(f"two elements are named '{name}': give each element its own name")
        return name

    # ----------------------------------------------------------------- elements
    def add_point(self, name: str, position) -> Point:
        """A massless named point (a pivot, an attachment) that springs and loads can refer to."""
        e = Point(self._unique_element_name(name, "point"), self._vector(position, f"point '{name}'.position"))
        self._elements.append(e)
        return e

    def add_particle(self, mass, position, *, name: str | None = None) -> Particle:
        """A point mass at `position`: a 2- or 3-tuple of expressions of q and t."""
        name = self._unique_element_name(name, "particle")
        e = Particle(name, self.expr(mass, f"particle '{name}'.mass"),
                     self._vector(position, f"particle '{name}'.position"))
        self._elements.append(e)
        return e

    def add_rigid_body(self, mass, inertia, position, angle, *, name: str | None = None) -> RigidBody:
        """A planar rigid body: `mass`, centroidal `inertia`, centre `position` and rotation `angle`."""
        name = self._unique_element_name(name, "body")
        e = RigidBody(name, self.expr(mass, f"body '{name}'.mass"),
                      self.expr(inertia, f"body '{name}'.inertia"),
                      self._vector(position, f"body '{name}'.position"),
                      self.expr(angle, f"body '{name}'.angle"))
        self._elements.append(e)
        return e

    def _ends(self, between, where):
        if not isinstance(between, (list, tuple)) or len(between) != 2:
            raise ModelError(f"{where}.between: expected two points (names or positions), got {between!r}")
        a, b = (self._vector(p, f"{where}.between[{i}]") for i, p in enumerate(between))
        if len(a) != len(b):
            raise ModelError(f"{where}.between: the two points have {len(a)} and {len(b)} components; "
                             "use points of the same dimension")
        names = tuple(p if isinstance(p, str) else None for p in between)
        return (a, b), (names if all(names) else None)

    def _length(self, between, length, where):
        if (between is None) == (length is None):
            raise ModelError(f"{where}: give either `between` (two points) or `length` (an expression), "
                             "exactly one of them")
        if between is not None:
            ends, names = self._ends(between, where)
            dist = sympy.sqrt(sum((b - a) ** 2 for a, b in zip(*ends)))
            return dist, ends, names
        return self.expr(length, f"{where}.length"), None, None

    def add_spring(self, stiffness, *, between=None, length=None, rest_length=0,
                   name: str | None = None) -> Spring:
        """A linear spring, V = k (length - rest_length)^2 / 2.

        Give `between` (two point names or positions) or `length` (any expression, e.g. a
        coordinate, or an angle for a torsional spring).
        """
        name = self._unique_element_name(name, "spring")
        where = f"spring '{name}'"
        L, ends, names = self._length(between, length, where)
        e = Spring(name, self.expr(stiffness, f"{where}.stiffness"), L,
                   self.expr(rest_length, f"{where}.rest_length"), names, ends)
        self._elements.append(e)
        return e

    def add_damper(self, coefficient, *, between=None, length=None, name: str | None = None) -> Damper:
        """A linear viscous damper, D = c (d length/dt)^2 / 2 (`between` or `length` as for springs)."""
        name = self._unique_element_name(name, "damper")
        where = f"damper '{name}'"
        L, ends, names = self._length(between, length, where)
        if ends is not None and all(sympy.simplify(a - b) == 0 for a, b in zip(*ends)):
            raise ModelError(f"{where}.between: both ends are the same point, so the damper has no length "
                             "and no direction; attach it between two different points")
        e = Damper(name, self.expr(coefficient, f"{where}.coefficient"), L, names, ends)
        self._elements.append(e)
        return e

    def add_gravity(self, g, direction=None) -> Gravity:
        """Uniform gravity of magnitude `g` acting on every particle and body, along `direction`
        (default: -y for planar positions, -z for spatial ones)."""
        if any(isinstance(e, Gravity) for e in self._elements):
            raise ModelError("gravity is added twice: a model has at most one uniform gravity field")
        self._unique_element_name("gravity", "gravity")
        d = None if direction is None else self._vector(direction, "gravity.direction")
        if d is not None and all(c.is_zero for c in d):
            raise ModelError("gravity.direction is the zero vector: give the direction gravity pulls in, "
                             "e.g. (0, -1) in a plane or (0, 0, -1) in space")
        e = Gravity(self.expr(g, "gravity.g"), d)
        self._elements.append(e)
        return e

    def add_force(self, force, at, *, name: str | None = None) -> Force:
        """A force vector applied at a point (its name or position); Q by virtual work."""
        name = self._unique_element_name(name, "force")
        where = f"force '{name}'"
        F = self._vector(force, f"{where}.force")
        r = self._vector(at, f"{where}.at")
        if len(F) != len(r):
            raise ModelError(f"{where}: the force has {len(F)} components but the point has {len(r)}; "
                             "give them the same dimension")
        e = Force(name, F, r, at if isinstance(at, str) else None)
        self._elements.append(e)
        return e

    def add_torque(self, torque, *, angle=None, body: str | None = None, name: str | None = None) -> Torque:
        """A torque acting on the rotation `angle` (an expression) or on the rigid body named `body`."""
        name = self._unique_element_name(name, "torque")
        where = f"torque '{name}'"
        if (angle is None) == (body is None):
            raise ModelError(f"{where}: give either `angle` (an expression) or `body` (a rigid body's name), "
                             "exactly one of them")
        if body is not None:
            bodies = {e.name: e for e in self._elements if isinstance(e, RigidBody)}
            if body not in bodies:
                hint = difflib.get_close_matches(body, list(bodies), n=1)
                extra = f" (did you mean '{hint[0]}'?)" if hint else ""
                raise ModelError(f"{where}.body: no rigid body is named '{body}'{extra}")
            a = bodies[body].angle
        else:
            a = self.expr(angle, f"{where}.angle")
        e = Torque(name, self.expr(torque, f"{where}.torque"), a, body)
        self._elements.append(e)
        return e

    # ----------------------------------------------------------------- energies
    def add_energy(self, *, T=0, V=0, D=0) -> None:
        """Add explicit terms to the kinetic co-energy T, the potential V and the dissipation D."""
        self._check_mutable()
        terms = [self.expr(T, "energy.T"), self.expr(V, "energy.V"), self.expr(D, "energy.D")]  # all or nothing
        self._T, self._V, self._D = self._T + terms[0], self._V + terms[1], self._D + terms[2]

    def add_generalized_force(self, coordinate, expr) -> None:
        """Add a generalized force (not already in D) on `coordinate` (its symbol or name)."""
        self._check_mutable()
        name = coordinate.name if isinstance(coordinate, sympy.Symbol) else coordinate
        matches = [c for c in self._coordinates if c.name == name]
        if not matches:
            hint = difflib.get_close_matches(str(name), [c.name for c in self._coordinates], n=1)
            extra = f" (did you mean '{hint[0]}'?)" if hint else ""
            raise ModelError(f"forces.{name}: '{name}' is not a coordinate{extra}; "
                             "generalized forces are given by coordinate name")
        q = matches[0]
        self._Q[q] = self._Q.get(q, sympy.Integer(0)) + self.expr(expr, f"forces.{name}")

    @property
    def T(self) -> sympy.Expr:
        """The explicit part of T (without the elements' contributions)."""
        return self._T

    @property
    def V(self) -> sympy.Expr:
        return self._V

    @property
    def D(self) -> sympy.Expr:
        return self._D

    @property
    def Q(self) -> dict[sympy.Symbol, sympy.Expr]:
        return dict(self._Q)

    # -------------------------------------------------------------------- checks
    def check(self) -> list[Problem]:
        """Every problem of the model, found in one pass (an empty list when it is sound)."""
        problems: list[Problem] = []
        if not self._coordinates:
            problems.append(Problem("the model has no coordinates: declare at least one "
                                    "(m.coordinate('x'), or coordinates = [\"x\"] in a model file)",
                                    key="coordinates"))
        known = set(self.names().values())
        qd = {dot(c) for c in self._coordinates}
        qdd = {ddot(c) for c in self._coordinates}
        inputs = set(self._inputs)
        sources: list[tuple[str, sympy.Expr, str]] = [
            ("energy.T", self._T, "T"), ("energy.V", self._V, "V"), ("energy.D", self._D, "D")]
        sources += [(f"forces.{c.name}", e, "Q") for c, e in self._Q.items()]
        el_of = {}
        for el in self._elements:
            for field_name, e in el.expressions().items():
                el_of[f"{el.kind} '{el.name}'.{field_name}"] = el
                role = "position" if field_name.startswith(("position", "angle")) else field_name
                if isinstance(el, Force) and field_name.startswith("force["):
                    role = "force"  # a force may depend on velocities (and inputs)
                if isinstance(el, (Spring, Damper)) and field_name == "length":
                    role = "length"
                sources.append((f"{el.kind} '{el.name}'.{field_name}", e, role))
        for where, e, role in sources:
            free = e.free_symbols
            for s in sorted(free - known - qdd, key=str):
                hint = difflib.get_close_matches(s.name, [k.name for k in known], n=1)
                extra = f" Did you mean '{hint[0]}'?" if hint else ""
                problems.append(Problem(
                    f"unknown symbol '{s.name}': it is not a coordinate, velocity, parameter, input or t.{extra} "
                    f"Declare it (m.parameter('{s.name}', value), or under [parameters] in a model file).",
                    key=where))
            for s in sorted(free & qdd, key=str):
                problems.append(Problem(f"acceleration '{s.name}' may not appear in a model: "
                                        "the equations produce accelerations, write energies and forces "
                                        "in terms of coordinates and velocities", key=where))
            if role in ("V", "position", "length", "inertia", "mass", "stiffness", "rest_length",
                        "coefficient", "g") and free & qd:
                names = ", ".join(sorted(s.name for s in free & qd))
                what = {"V": "the potential energy V depends only on coordinates and time"}.get(
                    role, f"a {role} depends only on coordinates and time")
                problems.append(Problem(f"velocity {names} appears here, but {what}: move velocity-dependent "
                                        "terms to T (kinetic co-energy), D (dissipation) or the forces",
                                        key=where))
            if role in ("T",) and free & inputs:
                names = ", ".join(sorted(s.name for s in free & inputs))
                problems.append(Problem(f"input {names} appears in T, whose time derivative the equations "
                                        "would need: inputs may appear in V, D and forces; write a "
                                        "prescribed motion as a function of t instead", key=where))
            if role == "position" and free & inputs and not isinstance(el_of.get(where), (Force, Torque)):
                names = ", ".join(sorted(s.name for s in free & inputs))
                problems.append(Problem(f"input {names} appears in a position, whose velocity the equations "
                                        "would need: write a prescribed motion as a function of t instead",
                                        key=where))
        values = {p: v for p, v in self._parameters.items() if v is not None}
        for el in self._elements:
            for field_name in ("mass", "inertia", "stiffness", "coefficient"):
                e = getattr(el, field_name, None)
                if e is None:
                    continue
                # a symbol or a number, as fields mostly are, without SymPy's (slow) subs
                val = sympy.sympify(values.get(e, e)) if e.is_Symbol else e if e.is_Number else e.subs(values)
                if val.is_number and val.is_real and float(val) < 0:
                    problems.append(Problem(f"{field_name} is negative ({float(val):g}): it must be zero or positive; "
                                            "check the sign or the parameter values",
                                            key=f"{el.kind} '{el.name}'.{field_name}"))
        return problems

    def validate(self) -> None:
        """Raise :class:`ModelError` listing every problem, if there is any."""
        problems = self.check()
        if problems:
            raise ModelError(problems)

    # ------------------------------------------------------------------- misc
    def copy(self) -> "Model":
        """An independent, changeable copy (elements are immutable and shared)."""
        out = copy.copy(self)._with_copied_containers()
        out._frozen = False
        return out

    def _with_copied_containers(self):
        self._coordinates = list(self._coordinates)
        self._parameters = dict(self._parameters)
        self._inputs = list(self._inputs)
        self._elements = list(self._elements)
        self._Q = dict(self._Q)
        self.simulation = copy.deepcopy(self.simulation)
        return self

    def _repr_html_(self) -> str:
        """A table for notebooks: coordinates, parameters, inputs, elements and explicit energies (LaTeX)."""
        import html

        def tex(e) -> str:
            return f"${sympy.latex(e)}$"

        rows = [("coordinates", ", ".join(tex(c) for c in self._coordinates) or "none"),
                ("parameters", ", ".join(f"{tex(p)} = {v:g}" if v is not None else f"{tex(p)} (no value)"
                                         for p, v in self._parameters.items()) or "none"),
                ("inputs", ", ".join(tex(u) for u in self._inputs) or "none")]
        for e in self._elements:
            parts = []
            for key, value in e.__dict__.items():
                if key in ("name", "ends") or value is None:
                    continue
                if isinstance(value, tuple) and value and all(isinstance(v, sympy.Basic) for v in value):
                    parts.append(f"{key} ${sympy.latex(sympy.Matrix(value).T)}$")
                elif isinstance(value, sympy.Basic):
                    parts.append(f"{key} {tex(value)}")
                elif isinstance(value, tuple):
                    parts.append(f"{key} {html.escape(', '.join(map(str, value)))}")
            rows.append((f"{e.kind} {html.escape(e.name)}", "; ".join(parts)))
        for label, value in (("T*", self._T), ("V", self._V), ("D", self._D)):
            if value != 0:
                rows.append((label, tex(value)))
        for c, value in self._Q.items():
            rows.append((f"Q[{c.name}]", tex(value)))
        body = "".join(f"<tr><th style='text-align:left'>{k}</th><td style='text-align:left'>{v}</td></tr>"
                       for k, v in rows)
        desc = f"<br><i>{html.escape(self.description)}</i>" if self.description else ""
        return f"<div><b>Model {html.escape(self.name)}</b>{desc}<table>{body}</table></div>"

    def __repr__(self) -> str:
        return (f"Model({self.name!r}, coordinates={[c.name for c in self._coordinates]}, "
                f"elements={len(self._elements)})")
